//! `2^-y` and `log2` for the Gaussian and generalised-bell membership
//! functions (eq. 7 of Nagata et al., eq. 3.1 of Cho et al., MATLAB's
//! `gaussmf`/`gbellmf`): a table of 64 entries plus a short series each,
//! relative error below 1e-8 (tested against `f64`), far below the Q16.16
//! resolution of a degree. `const fn`, so the membership tables of `const`
//! controllers are computed at compile time.

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
pub const LOG2E_Q30: u64 = 1_549_082_005;

/// `2^(−y)` for `y >= 0` in Q32, as Q30 (`1.0 = 2^30`), rounded.
pub const fn exp2_neg_q30(y_q32: u64) -> u32 {
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
pub const fn log2_q32(v: u64) -> i64 {
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
