//! Lin et al.'s normalisation of the curvature variation (section 2.7.1 A),
//! the step between the lookahead's Dκ (eq. 10) and the controller's input.
//! The feed law itself, `F = max(F_min, u·F_max)`, is the scheduler's
//! ([`crate::scheduler`]).

use fixed::types::I32F32;

use crate::numerics::wide::shr_u64_low;
use crate::units::{CurvaturePerMm, Fx};

/// How the curvature variation Dκ is normalised to the controller's `[0, 1]`
/// (section 2.7.1 A: "normalized to the interval [0, 1] based on the maximum
/// and minimum values … if the curvature variation remains greater than 3,
/// \[it\] is represented by the maximum value of 3").
///
/// The paper normalises by the minimum and maximum over the whole path,
/// which a streaming scheduler cannot know in advance. The default is the
/// fixed range `[0, 3]` 1/mm (so the same geometry always gets the same
/// feed); offline tools can emulate the paper with
/// [`VariationScale::for_path`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct VariationScale {
    /// Dκ mapped to 0, 1/mm.
    pub floor: CurvaturePerMm,
    /// Dκ mapped to 1 (and everything above), 1/mm.
    pub clip: CurvaturePerMm,
}

impl Default for VariationScale {
    fn default() -> Self {
        VariationScale::PAPER
    }
}

impl VariationScale {
    /// `[0, 3]` 1/mm.
    pub const PAPER: VariationScale = VariationScale {
        floor: CurvaturePerMm::ZERO,
        clip: CurvaturePerMm(I32F32::from_bits(3 << 32)),
    };

    /// The paper's per-path normalisation: `[min Dκ, min(max Dκ, 3)]` of a
    /// whole path (offline use).
    pub fn for_path(
        min_variation: CurvaturePerMm,
        max_variation: CurvaturePerMm,
    ) -> VariationScale {
        let clip = max_variation.min(Self::PAPER.clip);
        let floor = min_variation.min(clip);
        VariationScale { floor, clip }
    }

    /// Whether `0 <= floor < clip <= 32767` 1/mm.
    pub fn is_valid(&self) -> bool {
        self.floor.0 >= 0 && self.floor < self.clip && self.clip.0 <= I32F32::from_num(32767)
    }

    /// `(clamp(Dκ, floor, clip) − floor) / (clip − floor)` in Q16.16,
    /// rounded to nearest. An invalid scale (see [`Self::is_valid`]) gives 1
    /// for any Dκ above the floor. (Per call this prepares the division; the
    /// scheduler keeps a [`Normaliser`].)
    pub fn normalise(&self, variation: CurvaturePerMm) -> Fx {
        self.normaliser().normalise(variation)
    }

    /// The division by `clip − floor` prepared once (see [`Normaliser`]).
    pub fn normaliser(&self) -> Normaliser {
        let (floor, clip) = (self.floor.0.to_bits(), self.clip.0.to_bits());
        let span = clip.saturating_sub(floor);
        // Drop low bits until the divisor fits 32 bits (so the quotient of
        // at most 2^16 comes from a 32-bit divisor), with 32-bit shifts only.
        let k = (32 - span.leading_zeros() as i32).max(0) as u32;
        let divisor = shr_u64_low(span as u64, k);
        Normaliser {
            floor,
            clip,
            divisible: span > 0 && span < 1 << 47 && divisor > 0,
            k,
            divisor,
            reciprocal: u64::MAX / divisor.max(1) as u64,
        }
    }
}

/// [`VariationScale::normalise`] with its division by `clip − floor`
/// replaced by a multiplication with a reciprocal computed once (on the
/// target a 64-by-32-bit division is a long division:
/// [`wide::div_narrow`](crate::numerics::wide::div_narrow) in the cost table
/// of [`crate::numerics`]). Exact: the reciprocal's estimate is at most one low and is corrected, so
/// the result is the same rounded quotient, bit for bit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Normaliser {
    floor: i64,
    clip: i64,
    /// `0 < clip − floor < 2^47`: otherwise any Dκ above the floor is 1.
    divisible: bool,
    /// `clip − floor` shifted right by `k` to fit 32 bits: the divisor.
    k: u32,
    divisor: u32,
    /// `floor((2^64 − 1) / divisor)`.
    reciprocal: u64,
}

impl Default for Normaliser {
    fn default() -> Self {
        VariationScale::PAPER.normaliser()
    }
}

impl Normaliser {
    /// `(clamp(Dκ, floor, clip) − floor) / (clip − floor)` in Q16.16 (see
    /// [`VariationScale::normalise`]).
    #[inline]
    pub fn normalise(&self, variation: CurvaturePerMm) -> Fx {
        let v = variation.0.to_bits().max(self.floor).min(self.clip) - self.floor;
        if !self.divisible {
            return if v > 0 { Fx::ONE } else { Fx::ZERO };
        }
        // v <= span, so after the shift v <= divisor and the dividend is
        // below 2^49: the quotient is at most 2^16.
        let v = shr_u64_low(v as u64, self.k);
        let n = ((v as u64) << 16) + (self.divisor / 2) as u64;
        // floor(n · r / 2^64) is q or q − 1 (r >= 2^64/d − 1, n < 2^64).
        let (n1, n0) = (n >> 32, n & 0xFFFF_FFFF);
        let (r1, r0) = (self.reciprocal >> 32, self.reciprocal & 0xFFFF_FFFF);
        let mid = ((n0 * r0) >> 32) + ((n0 * r1) & 0xFFFF_FFFF) + ((n1 * r0) & 0xFFFF_FFFF);
        let q = n1 * r1 + ((n0 * r1) >> 32) + ((n1 * r0) >> 32) + (mid >> 32);
        let q = q.min(1 << 17) as u32;
        let q = if n - q as u64 * self.divisor as u64 >= self.divisor as u64 {
            q + 1
        } else {
            q
        };
        Fx::from_bits(q.min(1 << 16) as i32)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numerics::wide::div_narrow;
    use proptest::prelude::*;

    /// The normalisation by long division (the implementation before
    /// [`Normaliser`]), for the bit-for-bit check.
    fn normalise_by_division(s: &VariationScale, variation: CurvaturePerMm) -> Fx {
        let span = s.clip.0.to_bits().saturating_sub(s.floor.0.to_bits());
        let v = variation
            .0
            .to_bits()
            .max(s.floor.0.to_bits())
            .min(s.clip.0.to_bits())
            - s.floor.0.to_bits();
        if span <= 0 || span >= 1 << 47 {
            return if v > 0 { Fx::ONE } else { Fx::ZERO };
        }
        let k = (32 - span.leading_zeros() as i32).max(0) as u32;
        let (v, span) = (shr_u64_low(v as u64, k), shr_u64_low(span as u64, k));
        let q = div_narrow(((v as u64) << 16) + (span / 2) as u64, span);
        Fx::from_bits(q.min(1 << 16) as i32)
    }

    proptest! {
        #[test]
        fn normaliser_equals_long_division(
            floor in 0i64..(1 << 48),
            width in prop_oneof![1i64..64, 1i64..(1 << 20), 1i64..(1 << 48)],
            v in prop_oneof![-(1i64 << 40)..(1 << 50), Just(i64::MAX), Just(i64::MIN)],
        ) {
            let s = VariationScale {
                floor: CurvaturePerMm(I32F32::from_bits(floor)),
                clip: CurvaturePerMm(I32F32::from_bits(floor + width)),
            };
            for x in [v, floor, floor + width, floor + width / 2, floor + width - 1] {
                let k = CurvaturePerMm(I32F32::from_bits(x));
                prop_assert_eq!(s.normalise(k), normalise_by_division(&s, k));
            }
        }
    }

    #[test]
    fn variation_scale() {
        let s = VariationScale::PAPER;
        assert_eq!(s.normalise(CurvaturePerMm::from_f64(1.5)), Fx::lit("0.5"));
        assert_eq!(s.normalise(CurvaturePerMm::from_f64(30.0)), Fx::ONE);
        assert_eq!(s.normalise(CurvaturePerMm::MAX), Fx::ONE);
        assert_eq!(s.normalise(CurvaturePerMm::ZERO), Fx::ZERO);
        let p = VariationScale::for_path(
            CurvaturePerMm::from_f64(0.01),
            CurvaturePerMm::from_f64(0.21),
        );
        assert!(p.is_valid());
        assert_eq!(p.normalise(CurvaturePerMm::from_f64(0.21)), Fx::ONE);
        assert!(!VariationScale {
            floor: CurvaturePerMm::ZERO,
            clip: CurvaturePerMm::ZERO
        }
        .is_valid());
    }
}
