//! A tiny, deterministic, integer-only floating-point number for the few
//! places where a ratio spans too many decades for one fixed-point format
//! (the three-point curvature of eq. 9: chords from 1 µm to metres, so
//! intermediate products span ~2^200).
//!
//! Values are positive: `mant · 2^exp` with `mant` normalised to
//! `[2^31, 2^32)`, or zero: `mant = 0` with any exponent (every operation
//! tests the mantissa, so products and scalings need not normalise a zero).
//! Every operation truncates to 32 significant bits, so each step has a
//! relative error below 2^-31 ≈ 4.7e-10. Only integer
//! instructions are used, so the host and a Cortex-M give the same bits.
//! Square roots are [`super::sqrt`]'s.
//!
//! `micromath` is not used here: its `sqrt` is an approximation to about
//! 1e-3, and the curvature needs about 1e-9.

use core::cmp::Ordering;

use super::sqrt::{isqrt_norm, rsqrt_q31};
use super::wide::{divlu, shl_u32_wide, shr_u64_low};

/// A positive number `mant · 2^exp` (`mant` in `[2^31, 2^32)`, or zero).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sf {
    mant: u32,
    exp: i32,
}

impl Sf {
    /// Zero.
    pub const ZERO: Sf = Sf { mant: 0, exp: 0 };

    /// `x · 2^exp`, truncated to 32 significant bits.
    pub const fn from_u64_exp(x: u64, exp: i32) -> Sf {
        Sf::from_u64_exp_inline(x, exp)
    }

    /// [`Self::from_u64_exp`], inlined into the caller (hot code).
    #[inline(always)]
    pub const fn from_u64_exp_inline(x: u64, exp: i32) -> Sf {
        if x == 0 {
            return Sf::ZERO;
        }
        let shift = 32 - x.leading_zeros() as i32; // in -31..=32
        let mant = if shift >= 0 {
            shr_u64_low(x, shift as u32)
        } else {
            (x as u32) << (-shift) as u32
        };
        Sf {
            mant,
            exp: exp.saturating_add(shift),
        }
    }

    /// [`Self::from_u64_exp_inline`] for a 32-bit `x` (one shift left).
    #[inline(always)]
    pub const fn from_u32_exp_inline(x: u32, exp: i32) -> Sf {
        if x == 0 {
            return Sf::ZERO;
        }
        let lz = x.leading_zeros();
        Sf {
            mant: x << lz,
            exp: exp.saturating_sub(lz as i32),
        }
    }

    /// `x` as a soft float.
    pub const fn from_u64(x: u64) -> Sf {
        Sf::from_u64_exp(x, 0)
    }

    /// [`Self::from_u64`], inlined into the caller (hot code).
    #[inline(always)]
    pub const fn from_u64_inline(x: u64) -> Sf {
        Sf::from_u64_exp_inline(x, 0)
    }

    /// Whether this is zero.
    pub const fn is_zero(self) -> bool {
        self.mant == 0
    }

    /// `self · 2^k` (exact; zero stays a zero mantissa).
    pub const fn scale2(self, k: i32) -> Sf {
        Sf {
            mant: self.mant,
            exp: self.exp.saturating_add(k),
        }
    }

    /// Product, truncated (out of line: [`Self::mul_inline`] in hot code).
    pub const fn mul(self, o: Sf) -> Sf {
        self.mul_inline(o)
    }

    /// [`Self::mul`], inlined into the caller (the curvature's chain of
    /// products: a call would cost about as much as the product).
    #[inline(always)]
    pub const fn mul_inline(self, o: Sf) -> Sf {
        // A zero operand gives a zero mantissa (with some exponent), which
        // every operation reads as zero: no test needed here.
        let p = self.mant as u64 * o.mant as u64;
        let e = self.exp.saturating_add(o.exp);
        // p is in [2^62, 2^64) (or 0): one normalising step.
        if p >> 63 != 0 {
            Sf {
                mant: (p >> 32) as u32,
                exp: e.saturating_add(32),
            }
        } else {
            Sf {
                mant: (p >> 31) as u32,
                exp: e.saturating_add(31),
            }
        }
    }

    /// Quotient, truncated; `None` when dividing by zero.
    pub const fn div(self, o: Sf) -> Option<Sf> {
        self.div_inline(o)
    }

    /// [`Self::div`], inlined into the caller (the planner's quotient).
    #[inline(always)]
    pub const fn div_inline(self, o: Sf) -> Option<Sf> {
        if o.mant == 0 {
            return None;
        }
        if self.mant == 0 {
            return Some(Sf::ZERO);
        }
        // a·2^31 / b for a, b in [2^31, 2^32): in (2^30, 2^32), on 32-bit
        // hardware division.
        let (q, _) = divlu(self.mant >> 1, (self.mant & 1) << 31, o.mant);
        let e = self.exp.saturating_sub(o.exp).saturating_sub(31);
        Some(Sf::from_u64_exp_inline(q as u64, e))
    }

    /// Sum (both operands are positive), truncated.
    pub const fn add(self, o: Sf) -> Sf {
        self.add_inline(o)
    }

    /// [`Self::add`], inlined into the caller (the curvature's hot path).
    #[inline(always)]
    pub const fn add_inline(self, o: Sf) -> Sf {
        if self.mant == 0 {
            return o;
        }
        if o.mant == 0 {
            return self;
        }
        let (big, small) = if self.exp >= o.exp {
            (self, o)
        } else {
            (o, self)
        };
        let d = big.exp.saturating_sub(small.exp);
        // Keep 31 guard bits: both mantissas fit in 63 bits after aligning.
        let hi = (big.mant as u64) << 31;
        // (small.mant << 31) >> d, with 32-bit shifts.
        let lo = if d >= 63 {
            0
        } else if d <= 31 {
            shl_u32_wide(small.mant, (31 - d) as u32)
        } else {
            (small.mant >> (d - 31) as u32) as u64
        };
        Sf::from_u64_exp(hi + lo, big.exp.saturating_sub(31))
    }

    /// Square root, correct to the last bit of the 32-bit mantissa.
    pub const fn sqrt(self) -> Sf {
        if self.mant == 0 {
            return Sf::ZERO;
        }
        // Make the exponent even so that it halves exactly.
        if self.exp & 1 == 0 {
            let s = isqrt_norm((self.mant as u64) << 32);
            Sf {
                mant: s,
                exp: (self.exp - 32) >> 1,
            }
        } else {
            let s = isqrt_norm((self.mant as u64) << 31);
            Sf {
                mant: s,
                exp: (self.exp - 31) >> 1,
            }
        }
    }

    /// `1/sqrt(self)` to about 2^-29 relative (Newton steps, truncated:
    /// not correctly rounded, but much cheaper than [`Self::sqrt`] plus
    /// [`Self::div`]: cost table in [`super`]); `None` for zero. Inlined:
    /// the curvature calls it twice per point, and the `Option` then folds
    /// away.
    #[inline(always)]
    pub const fn rsqrt(self) -> Option<Sf> {
        if self.mant == 0 {
            return None;
        }
        // self = A·2^(e + 30) with A = mant/2^30 in [2, 4) for an even
        // exponent e, or A = mant/2^31 in [1, 2) (a = mant/2, Q30) and
        // 2^(e + 31) for an odd one: the power of two halves exactly.
        let (a, p) = if self.exp & 1 == 0 {
            (self.mant, self.exp.saturating_add(30))
        } else {
            (self.mant >> 1, self.exp.saturating_add(31))
        };
        let r = rsqrt_q31(a);
        Some(Sf::from_u32_exp_inline(r, (-31i32).saturating_sub(p >> 1)))
    }

    /// `self · 2^k` as an integer, rounded to nearest, saturating at
    /// `i64::MAX`.
    pub const fn to_i64_scaled(self, k: i32) -> i64 {
        self.to_i64_scaled_inline(k)
    }

    /// [`Self::to_i64_scaled`], inlined into the caller.
    #[inline(always)]
    pub const fn to_i64_scaled_inline(self, k: i32) -> i64 {
        if self.mant == 0 {
            return 0;
        }
        let e = self.exp.saturating_add(k);
        if e >= 32 {
            return i64::MAX; // mant · 2^32 >= 2^63
        }
        if e >= 0 {
            return shl_u32_wide(self.mant, e as u32) as i64;
        }
        if e < -33 {
            return 0;
        }
        let sh = (-e) as u32;
        // Round to nearest: add half an output unit before shifting.
        shr_u64_low(self.mant as u64 + shl_u32_wide(1, sh - 1), sh) as i64
    }

    /// Total order of positive values.
    pub const fn cmp(self, o: Sf) -> Ordering {
        match (self.mant == 0, o.mant == 0) {
            (true, true) => Ordering::Equal,
            (true, false) => Ordering::Less,
            (false, true) => Ordering::Greater,
            (false, false) => {
                if self.exp != o.exp {
                    if self.exp < o.exp {
                        Ordering::Less
                    } else {
                        Ordering::Greater
                    }
                } else if self.mant < o.mant {
                    Ordering::Less
                } else if self.mant > o.mant {
                    Ordering::Greater
                } else {
                    Ordering::Equal
                }
            }
        }
    }

    /// The larger of two values.
    pub const fn max(self, o: Sf) -> Sf {
        match self.cmp(o) {
            Ordering::Less => o,
            _ => self,
        }
    }

    /// The smaller of two values.
    pub const fn min(self, o: Sf) -> Sf {
        match self.cmp(o) {
            Ordering::Greater => o,
            _ => self,
        }
    }

    /// The value as `f64` (tests).
    #[cfg(test)]
    pub(crate) fn to_f64(self) -> f64 {
        self.mant as f64 * 2f64.powi(self.exp)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn ops_track_f64(a in 1u64.., b in 1u64.., ea in -80i32..80, eb in -80i32..80) {
            let x = Sf::from_u64_exp(a, ea);
            let y = Sf::from_u64_exp(b, eb);
            let (xf, yf) = (x.to_f64(), y.to_f64());
            let rel = |got: f64, want: f64| ((got - want) / want).abs();
            prop_assert!(rel(x.mul(y).to_f64(), xf * yf) < 1e-9);
            prop_assert!(rel(x.div(y).unwrap().to_f64(), xf / yf) < 1e-9);
            prop_assert!(rel(x.add(y).to_f64(), xf + yf) < 1e-9);
            prop_assert!(rel(x.sqrt().to_f64(), xf.sqrt()) < 1e-9);
            prop_assert_eq!(x.cmp(y), xf.partial_cmp(&yf).unwrap());
        }
    }

    proptest! {
        #[test]
        fn rsqrt_tracks_f64(a in 1u64.., e in -200i32..200) {
            let x = Sf::from_u64_exp(a, e);
            let want = 1.0 / x.to_f64().sqrt();
            let got = x.rsqrt().unwrap().to_f64();
            prop_assert!(((got - want) / want).abs() < 4e-9, "{} vs {}", got, want);
        }
    }

    #[test]
    fn conversions() {
        for x in [1u32, 2, 3, 0x7FFF_FFFF, 0x8000_0000, u32::MAX] {
            for e in [-70, 0, 5] {
                assert_eq!(Sf::from_u32_exp_inline(x, e), Sf::from_u64_exp(x as u64, e));
            }
        }
        assert!(Sf::from_u32_exp_inline(0, 3).is_zero());
        assert_eq!(Sf::from_u64(1).to_i64_scaled(0), 1);
        assert_eq!(Sf::from_u64(3).to_i64_scaled(-1), 2); // 1.5 rounds to 2
        assert_eq!(Sf::from_u64(5).to_i64_scaled(-2), 1); // 1.25 rounds to 1
        assert_eq!(Sf::from_u64(1).to_i64_scaled(70), i64::MAX);
        assert_eq!(Sf::from_u64(1).to_i64_scaled(-70), 0);
        assert_eq!(Sf::ZERO.div(Sf::ZERO), None);
        assert!(Sf::ZERO.sqrt().is_zero());
        assert_eq!(Sf::from_u64(9).sqrt().to_i64_scaled(0), 3);
    }
}
