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
//!
//! `micromath` is deliberately not used here: its `sqrt` is a ~1e-3
//! approximation, and this module needs ~1e-9 at the same cost.

use core::cmp::Ordering;

use crate::fixmath::{divlu, shl_u32_wide, shr_u64_low};

/// A positive number `mant · 2^exp` (`mant` in `[2^31, 2^32)`, or zero).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Sf {
    mant: u32,
    exp: i32,
}

impl Sf {
    /// Zero.
    pub(crate) const ZERO: Sf = Sf { mant: 0, exp: 0 };

    /// `x · 2^exp`, truncated to 32 significant bits.
    pub(crate) const fn from_u64_exp(x: u64, exp: i32) -> Sf {
        Sf::from_u64_exp_inline(x, exp)
    }

    /// [`Self::from_u64_exp`], inlined into the caller (hot code).
    #[inline(always)]
    pub(crate) const fn from_u64_exp_inline(x: u64, exp: i32) -> Sf {
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
    pub(crate) const fn from_u32_exp_inline(x: u32, exp: i32) -> Sf {
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
    pub(crate) const fn from_u64(x: u64) -> Sf {
        Sf::from_u64_exp(x, 0)
    }

    /// [`Self::from_u64`], inlined into the caller (hot code).
    #[inline(always)]
    pub(crate) const fn from_u64_inline(x: u64) -> Sf {
        Sf::from_u64_exp_inline(x, 0)
    }

    /// Whether this is zero.
    pub(crate) const fn is_zero(self) -> bool {
        self.mant == 0
    }

    /// `self · 2^k` (exact; zero stays a zero mantissa).
    pub(crate) const fn scale2(self, k: i32) -> Sf {
        Sf {
            mant: self.mant,
            exp: self.exp.saturating_add(k),
        }
    }

    /// Product, truncated (out of line: [`Self::mul_inline`] in hot code).
    pub(crate) const fn mul(self, o: Sf) -> Sf {
        self.mul_inline(o)
    }

    /// [`Self::mul`], inlined into the caller (the curvature's chain of
    /// products: a call costs as much as the product on a Cortex-M4).
    #[inline(always)]
    pub(crate) const fn mul_inline(self, o: Sf) -> Sf {
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
    pub(crate) const fn div(self, o: Sf) -> Option<Sf> {
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
        Some(Sf::from_u64_exp(q as u64, e))
    }

    /// Sum (both operands are positive), truncated.
    pub(crate) const fn add(self, o: Sf) -> Sf {
        self.add_inline(o)
    }

    /// [`Self::add`], inlined into the caller (the curvature's hot path).
    #[inline(always)]
    pub(crate) const fn add_inline(self, o: Sf) -> Sf {
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
    pub(crate) const fn sqrt(self) -> Sf {
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
    /// not correctly rounded, but ~6 times cheaper than [`Self::sqrt`] plus
    /// [`Self::div`]); `None` for zero. Inlined: twice per point in the
    /// curvature, where the call and the returned `Option` cost a sixth of it.
    #[inline(always)]
    pub(crate) const fn rsqrt(self) -> Option<Sf> {
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
    pub(crate) const fn to_i64_scaled(self, k: i32) -> i64 {
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
    pub(crate) const fn cmp(self, o: Sf) -> Ordering {
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
    pub(crate) const fn max(self, o: Sf) -> Sf {
        match self.cmp(o) {
            Ordering::Less => o,
            _ => self,
        }
    }

    /// The smaller of two values.
    pub(crate) const fn min(self, o: Sf) -> Sf {
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

/// Initial estimates of `1/sqrt(a)` for `a = i/8 .. (i+1)/8`, `i` in `8..32`,
/// in Q31 (the geometric mean of the bucket's end values; max error 3 %).
const RSQRT_SEED_Q31: [u32; 24] = [
    2085171282, 1972033243, 1875541541, 1791972647, 1718674801, 1653701088, 1595585333, 1543199410,
    1495659153, 1452260424, 1412434550, 1375716544, 1341721986, 1310129921, 1280669981, 1253112579,
    1227261320, 1202947073, 1180023296, 1158362288, 1137852195, 1118394560, 1099902330, 1082298212,
];

/// `1/sqrt(a/2^30)` in Q31 for `a` in `[2^30, 2^32)` (so in `(2^30, 2^31]`):
/// three division-free Newton steps from [`RSQRT_SEED_Q31`]. The
/// truncations leave it a few units (of 2^-31) low.
#[inline(always)]
const fn rsqrt_q31(a: u32) -> u32 {
    let idx = (a >> 27) as usize; // 8..=31
    let mut r: u32 = if idx >= 8 && idx < 32 {
        RSQRT_SEED_Q31[idx - 8]
    } else {
        1 << 30
    };
    // Each product is one 32×32→64-bit multiplication: r, r², a·r² and
    // (3 − a·r²)/2 all stay below 2^32 in Q31 once r is within 3 %.
    let mut i = 0;
    while i < 3 {
        let r2 = ((r as u64 * r as u64) >> 31) as u32; // r² in Q31
        let t = ((a as u64 * r2 as u64) >> 30) as u32; // a·r² in Q31, ≈ 2^31
        let h = (3u32 << 30).wrapping_sub(t >> 1); // (3 − a·r²)/2 in Q31
        r = ((r as u64 * h as u64) >> 31) as u32;
        i += 1;
    }
    r
}

/// `floor(sqrt(n))` for `n` in `[2^62, 2^64)` (so the result is in
/// `[2^31, 2^32)`): three division-free Newton steps on `1/sqrt`, then an
/// exact correction. About 60 instructions on a Cortex-M4.
const fn isqrt_norm(n: u64) -> u32 {
    let a = (n >> 32) as u32; // a / 2^30 in [1, 4)
    let r = rsqrt_q31(a);
    // sqrt(a/2^30) = (a/2^30)·r, in Q31, equals sqrt(a·2^32) ≈ sqrt(n).
    // Rounded: the truncations above leave r a few units low.
    let s = (a as u64 * r as u64 + (3 << 29)) >> 30;
    let mut s = if s > u32::MAX as u64 {
        u32::MAX as u64
    } else {
        s
    };
    // Exact floor: s is within a few units of the answer (-3..=8 over
    // random inputs). Step on the remainder d = n − s² (|d| < 2^40 here,
    // exact in i64) with additions only: (s ± 1)² = s² ± (2s ± 1).
    let mut d = n.wrapping_sub(s * s) as i64;
    while d < 0 {
        s -= 1;
        d += (2 * s + 1) as i64;
    }
    while d >= (2 * s + 1) as i64 {
        d -= (2 * s + 1) as i64;
        s += 1;
    }
    s as u32
}

/// `floor(sqrt(n))` for any `u64` (tests the normalised root on every input).
#[cfg(test)]
pub(crate) const fn isqrt_u64(n: u64) -> u32 {
    if n == 0 {
        return 0;
    }
    let lz = n.leading_zeros() & !1; // even shift keeps the root exact
    isqrt_norm(n << lz) >> (lz / 2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn exact_isqrt(n: u64) -> u64 {
        let mut s = (n as f64).sqrt() as u64;
        while (s as u128) * (s as u128) > n as u128 {
            s -= 1;
        }
        while ((s + 1) as u128) * ((s + 1) as u128) <= n as u128 {
            s += 1;
        }
        s
    }

    #[test]
    fn seed_table_matches_f64() {
        for (k, &v) in RSQRT_SEED_Q31.iter().enumerate() {
            let i = (k + 8) as f64;
            let r = ((1.0 / (i / 8.0).sqrt()) * (1.0 / ((i + 1.0) / 8.0).sqrt())).sqrt();
            assert!(((v as f64) / 2f64.powi(31) - r).abs() < 1e-9);
        }
    }

    #[test]
    fn isqrt_edges() {
        for n in [
            0u64,
            1,
            2,
            3,
            4,
            15,
            16,
            17,
            u32::MAX as u64,
            1 << 62,
            (1 << 62) - 1,
            u64::MAX,
            u64::MAX - 1,
        ] {
            assert_eq!(isqrt_u64(n) as u64, exact_isqrt(n), "n = {n}");
        }
        for k in 0..32u64 {
            let s = 1u64 << k;
            for n in [s * s - 1, s * s, s * s + 1] {
                assert_eq!(isqrt_u64(n) as u64, exact_isqrt(n), "n = {n}");
            }
        }
    }

    proptest! {
        #[test]
        fn isqrt_is_exact_floor(n in any::<u64>()) {
            prop_assert_eq!(isqrt_u64(n) as u64, exact_isqrt(n));
        }

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
