//! Integer square roots, all exact floors or within a few units of the last
//! bit, without division:
//!
//! - [`isqrt_u64`] (and the soft float's [`Sf::sqrt`](super::softfloat::Sf::sqrt)
//!   on it): three Newton steps on `1/√a` from a 24-entry seed table, then an
//!   exact correction by additions;
//! - the reciprocal root under [`Sf::rsqrt`](super::softfloat::Sf::rsqrt):
//!   the same Newton steps without the correction (the curvature's chord
//!   lengths, `|d| = |d|²/√|d|²`);
//! - [`isqrt_u128`]: `core`'s exact `u128::isqrt`, for Cho's contour error
//!   (squared distances in 2^-64 mm², host-side).

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
pub(crate) const fn rsqrt_q31(a: u32) -> u32 {
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
/// exact correction.
pub(crate) const fn isqrt_norm(n: u64) -> u32 {
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

/// `floor(sqrt(n))` for any `u64`: the input normalised by an even shift,
/// then the root of `[2^62, 2^64)`.
pub const fn isqrt_u64(n: u64) -> u32 {
    if n == 0 {
        return 0;
    }
    let lz = n.leading_zeros() & !1; // even shift keeps the root exact
    isqrt_norm(n << lz) >> (lz / 2)
}

/// `floor(sqrt(n))` for a `u128` (`core`'s `u128::isqrt`).
pub const fn isqrt_u128(n: u128) -> u128 {
    n.isqrt()
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
        fn isqrt_u128_is_exact_floor(n in any::<u128>()) {
            let s = isqrt_u128(n);
            prop_assert!(s * s <= n);
            prop_assert!((s + 1).checked_mul(s + 1).is_none_or(|q| q > n));
        }
    }
}
