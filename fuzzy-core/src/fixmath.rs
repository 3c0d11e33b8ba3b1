//! Integer helpers: division on 32-bit hardware, `2^-y` and `log2`.
//!
//! - [`div_u64_u32`]: the Cortex-M4 divides 32 bits by 32 bits in hardware
//!   (`UDIV`), but a 64-bit division is a library call costing ~300
//!   instructions. Long division in base 2^16 on `UDIV` (Hacker's Delight,
//!   `divlu`) costs ~40.
//! - `2^-y` and `log2` for the Gaussian and generalised-bell membership
//!   functions (eq. 7 of Nagata et al., eq. 3.1 of Cho et al., MATLAB's
//!   `gaussmf`/`gbellmf`): a table of 64 entries plus a short series, relative
//!   error below 1e-8, far below the Q16.16 resolution of a degree.
//!
//! All functions are `const fn`, so membership tables of `const` controllers
//! are computed at compile time.

/// `(x >> s) as u32` (the low word of a logical right shift), `s` in
/// `0..64` (0 beyond), with 32-bit shifts only: at opt-level "z" a variable
/// 64-bit shift is a library call on a 32-bit core.
#[inline(always)]
pub(crate) const fn shr_u64_low(x: u64, s: u32) -> u32 {
    let (hi, lo) = ((x >> 32) as u32, x as u32);
    if s == 0 {
        lo
    } else if s < 32 {
        (hi << (32 - s)) | (lo >> s)
    } else if s < 64 {
        hi >> (s - 32)
    } else {
        0
    }
}

/// `(x >> s) as i32` (the low word of an arithmetic right shift), `s` in
/// `0..64` (the sign beyond), with 32-bit shifts only.
#[inline(always)]
pub(crate) const fn sar_i64_low(x: i64, s: u32) -> i32 {
    let (hi, lo) = ((x >> 32) as i32, x as u32);
    if s == 0 {
        lo as i32
    } else if s < 32 {
        (((hi as u32) << (32 - s)) | (lo >> s)) as i32
    } else if s < 64 {
        hi >> (s - 32)
    } else {
        hi >> 31
    }
}

/// `(x as u64) << s` for `s` in `0..=32` (`x << 32` beyond), with 32-bit
/// shifts only.
#[inline(always)]
pub(crate) const fn shl_u32_wide(x: u32, s: u32) -> u64 {
    if s == 0 {
        x as u64
    } else if s < 32 {
        (((x >> (32 - s)) as u64) << 32) | (x << s) as u64
    } else {
        (x as u64) << 32
    }
}

/// `(u1·2^32 + u0) / v` and the remainder, for `u1 < v` (so the quotient fits
/// 32 bits). Hacker's Delight, `divlu`, with 32-bit hardware divisions only.
pub(crate) const fn divlu(u1: u32, u0: u32, v: u32) -> (u32, u32) {
    if v == 0 || u1 >= v {
        return (u32::MAX, 0); // outside the contract: saturate
    }
    const B: u32 = 1 << 16;
    let s = v.leading_zeros();
    let v = v << s;
    let (vn1, vn0) = (v >> 16, v & 0xFFFF);
    let un32 = if s == 0 {
        u1
    } else {
        (u1 << s) | (u0 >> (32 - s))
    };
    let un10 = u0 << s;
    let (un1, un0) = (un10 >> 16, un10 & 0xFFFF);
    // vn1 >= 2^15 (v is normalised); checked to keep the code panic-free.
    let mut q1 = match un32.checked_div(vn1) {
        Some(q) => q,
        None => return (u32::MAX, 0),
    };
    let mut rhat = un32 - q1 * vn1;
    while q1 >= B || q1 * vn0 > (rhat << 16) + un1 {
        q1 -= 1;
        rhat += vn1;
        if rhat >= B {
            break;
        }
    }
    let un21 = (un32 << 16)
        .wrapping_add(un1)
        .wrapping_sub(q1.wrapping_mul(v));
    let mut q0 = match un21.checked_div(vn1) {
        Some(q) => q,
        None => return (u32::MAX, 0),
    };
    let mut rhat = un21 - q0 * vn1;
    while q0 >= B || q0 * vn0 > (rhat << 16) + un0 {
        q0 -= 1;
        rhat += vn1;
        if rhat >= B {
            break;
        }
    }
    let r = (un21 << 16)
        .wrapping_add(un0)
        .wrapping_sub(q0.wrapping_mul(v))
        >> s;
    ((q1 << 16) + q0, r)
}

/// `n / d` (floor) when the quotient fits 32 bits (`n < d · 2^32`, i.e. the
/// high word of `n` is below `d`): one long division, without
/// [`div_u64_u32`]'s first step. Outside the contract: `u32::MAX`.
#[inline(always)]
pub(crate) const fn div_narrow(n: u64, d: u32) -> u32 {
    divlu((n >> 32) as u32, n as u32, d).0
}

/// `n / d` (floor) for a divisor below 2^16 (the average filter's window
/// length): long division in base 2^16 where every partial dividend is below
/// `d · 2^16`, so three hardware `UDIV`s and no correction steps. Larger
/// divisors go to [`div_u64_u32`]; `u64::MAX` for `d = 0`.
#[inline(always)]
pub(crate) const fn div_u64_small(n: u64, d: u32) -> u64 {
    if d == 0 || d >= 1 << 16 {
        return div_u64_u32(n, d);
    }
    let (hi, lo) = ((n >> 32) as u32, n as u32);
    let (q2, r) = (hi / d, hi % d);
    let mid = (r << 16) | (lo >> 16);
    let (q1, r) = (mid / d, mid % d);
    let low = (r << 16) | (lo & 0xFFFF);
    ((q2 as u64) << 32) | ((q1 << 16) + low / d) as u64
}

/// `n / d` (floor) for a 32-bit divisor; `u64::MAX` for `d = 0`.
pub(crate) const fn div_u64_u32(n: u64, d: u32) -> u64 {
    if d == 0 {
        return u64::MAX;
    }
    let (hi, lo) = ((n >> 32) as u32, n as u32);
    let (q_hi, r) = (hi / d, hi % d);
    let (q_lo, _) = divlu(r, lo, d);
    ((q_hi as u64) << 32) | q_lo as u64
}

/// `round(2^30 · 2^(−k/64))`, `k` in `0..64`.
const EXP2_NEG_Q30: [u32; 64] = [
    1073741824, 1062175491, 1050733751, 1039415261, 1028218693, 1017142735, 1006186087, 995347464,
    984625594, 974019220, 963527098, 953147997, 942880699, 932724001, 922676710, 912737649,
    902905651, 893179563, 883558244, 874040567, 864625413, 855311680, 846098274, 836984114,
    827968132, 819049271, 810226483, 801498734, 792865000, 784324269, 775875538, 767517817,
    759250125, 751071493, 742980960, 734977579, 727060411, 719228525, 711481005, 703816941,
    696235434, 688735596, 681316545, 673977412, 666717336, 659535466, 652430958, 645402981,
    638450708, 631573326, 624770026, 618040012, 611382493, 604796689, 598281827, 591837143,
    585461881, 579155293, 572916640, 566745190, 560640218, 554601009, 548626854, 542717053,
];

/// `round(2^30 · log2(1 + k/64))`, `k` in `0..64`.
const LOG2_Q30: [u32; 64] = [
    0, 24017256, 47667823, 70962728, 93912511, 116527248, 138816582, 160789745, 182455581,
    203822568, 224898839, 245692198, 266210141, 286459867, 306448299, 326182095, 345667660,
    364911162, 383918542, 402695523, 421247625, 439580170, 457698295, 475606957, 493310944,
    510814882, 528123241, 545240343, 562170370, 578917365, 595485245, 611877800, 628098702,
    644151509, 660039669, 675766525, 691335320, 706749198, 722011213, 737124328, 752091421,
    766915285, 781598637, 796144114, 810554283, 824831638, 838978604, 852997541, 866890747,
    880660455, 894308843, 907838029, 921250079, 934547002, 947730758, 960803257, 973766362,
    986621888, 999371606, 1012017244, 1024560487, 1037002979, 1049346328, 1061592099,
];

/// `round(2^30 / (1 + k/64))`, `k` in `0..64`.
const RECIP_Q30: [u32; 64] = [
    1073741824, 1057222719, 1041204193, 1025663832, 1010580540, 995934445, 981706811, 967879954,
    954437177, 941362695, 928641578, 916259690, 904203641, 892460737, 881018933, 869866794,
    858993459, 848388602, 838042399, 827945503, 818089009, 808464432, 799063683, 789879043,
    780903145, 772128952, 763549742, 755159085, 746950834, 738919105, 731058263, 723362913,
    715827883, 708448214, 701219150, 694136129, 687194767, 680390859, 673720360, 667179386,
    660764199, 654471207, 648296950, 642238100, 636291451, 630453915, 624722516, 619094385,
    613566757, 608136962, 602802428, 597560667, 592409282, 587345955, 582368447, 577474594,
    572662306, 567929560, 563274399, 558694933, 554189329, 549755814, 545392673, 541098242,
];

/// ln 2 in Q30.
const LN2_Q30: u64 = 744_261_118;
/// log2(e) = 1/ln 2 in Q30.
pub(crate) const LOG2E_Q30: u64 = 1_549_082_005;

/// `2^(−y)` for `y >= 0` in Q32, as Q30 (`1.0 = 2^30`), rounded.
pub(crate) const fn exp2_neg_q30(y_q32: u64) -> u32 {
    let n = y_q32 >> 32;
    if n >= 32 {
        return 0;
    }
    let f = y_q32 & 0xFFFF_FFFF;
    let k = (f >> 26) as usize; // 0..64
    let r = f & ((1 << 26) - 1); // < 1/64 in Q32
    let t = (r * LN2_Q30) >> 32; // r·ln2 in Q30, < 0.011
    let t2 = (t * t) >> 30;
    let t3 = ((t2 * t) >> 30) as u32; // < 2^11: 32-bit division is exact
                                      // e^(−t) = 1 − t + t²/2 − t³/6 (next term < 6e-10)
    let poly = (1u64 << 30) - t + t2 / 2 - (t3 / 6) as u64;
    let base = if k < 64 { EXP2_NEG_Q30[k] as u64 } else { 0 };
    let v = (base * poly) >> 30; // Q30
                                 // Divide by 2^n with rounding.
    if n == 0 {
        v as u32
    } else {
        ((v + (1 << (n - 1))) >> n) as u32
    }
}

/// `log2(v)` for an integer `v >= 1`, in Q32 (`v = 0` gives `i64::MIN`).
pub(crate) const fn log2_q32(v: u64) -> i64 {
    if v == 0 {
        return i64::MIN;
    }
    let lz = v.leading_zeros();
    let int_part = 63 - lz as i64;
    let m = (v << lz) >> 33; // mantissa in [2^30, 2^31): [1, 2) in Q30
    let k = ((m >> 24) & 63) as usize;
    // ε = m / (1 + k/64) − 1, in [0, 1/64) (rounding may give a hair below 0).
    let scaled = (m * RECIP_Q30[k] as u64) >> 30;
    let eps = scaled as i64 - (1i64 << 30);
    // ln(1 + ε) = ε − ε²/2 + ε³/3 − ε⁴/4 (next term < 2e-10)
    // |ε| < 2^24: the powers fit 32 bits, so the divisions are hardware ones.
    let e2 = (eps * eps) >> 30;
    let e3 = ((e2 * eps) >> 30) as i32;
    let e4 = ((e3 as i64 * eps) >> 30) as i32;
    let ln = eps - (e2 >> 1) + (e3 / 3) as i64 - (e4 >> 2) as i64;
    let frac_q30 = LOG2_Q30[k] as i64 + ((ln * LOG2E_Q30 as i64) >> 30);
    (int_part << 32) + (frac_q30 << 2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn div_matches_u64_division(n in any::<u64>(), d in 1u32..) {
            prop_assert_eq!(div_u64_u32(n, d), n / d as u64);
        }

        #[test]
        fn div_small_matches_u64_division(n in any::<u64>(), d in 0u32..70_000) {
            let want = if d == 0 { u64::MAX } else { n / d as u64 };
            prop_assert_eq!(div_u64_small(n, d), want);
        }

        #[test]
        fn div_narrow_matches(n in any::<u64>(), d in 1u32..) {
            let n = n % ((d as u64) << 32); // the contract: quotient < 2^32
            prop_assert_eq!(div_narrow(n, d) as u64, n / d as u64);
        }

        #[test]
        fn divlu_matches(u1 in any::<u32>(), u0 in any::<u32>(), v in 1u32..) {
            let u1 = u1 % v;
            let n = ((u1 as u64) << 32) | u0 as u64;
            prop_assert_eq!(divlu(u1, u0, v), ((n / v as u64) as u32, (n % v as u64) as u32));
        }
    }

    proptest! {
        #[test]
        fn narrow_shifts_match_u64_shifts(x in any::<u64>(), s in 0u32..70) {
            let want = if s < 64 { (x >> s) as u32 } else { 0 };
            prop_assert_eq!(shr_u64_low(x, s), want);
            let xi = x as i64;
            let want = if s < 64 { (xi >> s) as i32 } else { (xi >> 63) as i32 };
            prop_assert_eq!(sar_i64_low(xi, s), want);
            let w = x as u32;
            let want = (w as u64) << s.min(32);
            prop_assert_eq!(shl_u32_wide(w, s), want);
        }
    }

    #[test]
    fn div_edges() {
        for (n, d) in [
            (0u64, 1u32),
            (u64::MAX, 1),
            (u64::MAX, u32::MAX),
            (u64::MAX, 0x8000_0000),
            (1 << 63, 3),
            (12345, 0x1_0000),
            (u64::MAX, 0xFFFF),
        ] {
            assert_eq!(div_u64_u32(n, d), n / d as u64, "{n} / {d}");
        }
        assert_eq!(div_u64_u32(5, 0), u64::MAX);
    }

    #[test]
    fn tables_match_f64() {
        for k in 0..64 {
            let x = k as f64 / 64.0;
            assert!((EXP2_NEG_Q30[k] as f64 / 2f64.powi(30) - 2f64.powf(-x)).abs() < 1e-9);
            assert!((LOG2_Q30[k] as f64 / 2f64.powi(30) - (1.0 + x).log2()).abs() < 1e-9);
            assert!((RECIP_Q30[k] as f64 / 2f64.powi(30) - 1.0 / (1.0 + x)).abs() < 1e-9);
        }
    }

    #[test]
    fn exp2_neg_matches_f64() {
        let mut worst: f64 = 0.0;
        let mut y = 0u64;
        while y < 40u64 << 32 {
            let got = exp2_neg_q30(y) as f64 / 2f64.powi(30);
            let want = 2f64.powf(-(y as f64 / 2f64.powi(32)));
            worst = worst.max((got - want).abs());
            y += 0x0137_1234; // ~0.0047 steps, hitting every table entry
        }
        assert!(worst < 3e-9, "worst absolute error {worst}");
    }

    #[test]
    fn log2_matches_f64() {
        let mut worst: f64 = 0.0;
        let mut v = 1u64;
        while v < u64::MAX / 3 {
            let got = log2_q32(v) as f64 / 2f64.powi(32);
            worst = worst.max((got - (v as f64).log2()).abs());
            v = v * 3 / 2 + 7;
        }
        assert!(worst < 5e-9, "worst absolute error {worst}");
        assert_eq!(log2_q32(1), 0);
        assert_eq!(log2_q32(1 << 40), 40i64 << 32);
        assert_eq!(log2_q32(0), i64::MIN);
    }
}
