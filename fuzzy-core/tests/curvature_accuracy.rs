//! Fixed-point curvature (eq. 4-9) against the f64 implementation of the same
//! formula, on the same (quantised) points, over the whole range the issue
//! names: coordinates up to ±10 000 mm, chords from 1 µm to 100 mm, radii
//! from 10 µm to 100 m, any plane, unequal chords.
//!
//! Run with `--nocapture` to see the figures.

use fuzzy_core::curvature::{curvature, CurvatureError};
use fuzzy_core::reference;
use fuzzy_core::units::{CurvaturePerMm, Point3Mm};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};

/// A random triple on a circle: centre, radius, chord lengths, plane.
fn triple(
    c: [f64; 3],
    r: f64,
    h1: f64,
    ratio: f64,
    a0: f64,
    plane: (f64, f64),
) -> Option<(Point3Mm, Point3Mm, Point3Mm, f64)> {
    let h2 = h1 * ratio;
    if h1 >= 1.9 * r || h2 >= 1.9 * r {
        return None;
    }
    // Chord h on radius r subtends 2·asin(h/2r).
    let (t1, t2) = (2.0 * (h1 / (2.0 * r)).asin(), 2.0 * (h2 / (2.0 * r)).asin());
    let (th, ph) = plane;
    // An orthonormal basis (e1, e2) of the circle's plane.
    let e1 = [th.cos() * ph.cos(), th.sin() * ph.cos(), ph.sin()];
    let tmp = if e1[2].abs() < 0.9 {
        [0.0, 0.0, 1.0]
    } else {
        [1.0, 0.0, 0.0]
    };
    let mut e2 = [
        tmp[1] * e1[2] - tmp[2] * e1[1],
        tmp[2] * e1[0] - tmp[0] * e1[2],
        tmp[0] * e1[1] - tmp[1] * e1[0],
    ];
    let n = (e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2]).sqrt();
    e2.iter_mut().for_each(|v| *v /= n);
    let at = |a: f64| {
        let p = [0, 1, 2].map(|k| c[k] + r * (a.cos() * e1[k] + a.sin() * e2[k]));
        Point3Mm::from_f64(p[0], p[1], p[2])
    };
    Some((at(a0 - t1)?, at(a0)?, at(a0 + t2)?, (t1 + t2) / 2.0))
}

#[test]
fn fixed_point_matches_f64_over_the_whole_range() {
    let mut runner = TestRunner::new(Config {
        cases: 20_000,
        failure_persistence: None,
        ..Config::default()
    });
    // (cases judged, worst relative error where κ >= 1e-3 /mm, where, worst
    // absolute error with chords <= 0.25 mm, worst absolute error)
    let stats = std::cell::RefCell::new((0usize, 0f64, String::new(), 0f64, 0f64));
    let strategy = (
        prop::array::uniform3(-10_000.0f64..10_000.0),
        -2.0f64..5.0,                  // log10 radius: 10 µm .. 100 m
        -3.0f64..2.0,                  // log10 chord: 1 µm .. 100 mm
        -0.6f64..0.6,                  // log10 chord ratio
        0.0f64..std::f64::consts::TAU, // position on the circle
        (0.0f64..std::f64::consts::TAU, -1.5f64..1.5),
    );
    runner
        .run(&strategy, |(c, lr, lh, lq, a0, plane)| {
            let (r, h) = (10f64.powf(lr), 10f64.powf(lh));
            let Some((p1, p2, p3, turn)) = triple(c, r, h, 10f64.powf(lq), a0, plane) else {
                return Ok(());
            };
            let fixed = curvature(&p1, &p2, &p3);
            let want = reference::curvature(p1.to_f64(), p2.to_f64(), p3.to_f64());
            match (fixed, want) {
                (Ok(k), Some(w)) if w.is_finite() && w > 0.0 => {
                    // The f64 solve of eq. 7-8 itself loses ~1e-16/θ on nearly
                    // straight triples; only judge where that is negligible.
                    let f64_noise = 1e-15 / turn.max(1e-300);
                    let abs = (k.to_f64() - w).abs();
                    let rel = abs / w;
                    let long = h.max(h * 10f64.powf(lq)) > 0.25;
                    // Output rounding (half a step of I32F32, 1.2e-10 /mm) and,
                    // for chords over 0.25 mm (shifted to 30 bits before the
                    // cross product), 2^-28/chord (both chords contribute).
                    let allowed = 1e-7 * w
                        + 1.2e-10
                        + if long {
                            2f64.powi(-28) / h.min(h * 10f64.powf(lq))
                        } else {
                            0.0
                        };
                    if f64_noise < 1e-9 {
                        let mut st = stats.borrow_mut();
                        st.0 += 1;
                        if w >= 1e-3 && rel > st.1 {
                            st.1 = rel;
                            st.2 = format!("r = {r:.3e} mm, chord = {h:.3e} mm");
                        }
                        if !long {
                            st.3 = st.3.max(abs);
                        }
                        st.4 = st.4.max(abs);
                    }
                    prop_assert!(
                        f64_noise >= 1e-9 || abs <= allowed,
                        "error {abs:e} /mm (allowed {allowed:e}): r {r} h {h} κ {w}"
                    );
                }
                (Ok(k), Some(0.0)) => prop_assert_eq!(k, CurvaturePerMm::ZERO),
                (Ok(_), Some(_)) => {}
                (Err(CurvatureError::CoincidentPoints), None) => {}
                (a, b) => prop_assert!(false, "disagree: {a:?} vs {b:?}"),
            }
            Ok(())
        })
        .unwrap();
    let (n, worst_rel, worst_case, worst_fine, worst_abs) = stats.into_inner();
    eprintln!(
        "curvature: fixed point vs f64 on the same points, {n} random triples (coordinates ±10 000 mm, chords 1 µm-100 mm, \
         radii 10 µm-100 m): max relative error {worst_rel:.2e} where κ >= 1e-3 /mm (worst at {worst_case}); \
         max absolute error {worst_fine:.2e} /mm with chords <= 0.25 mm, {worst_abs:.2e} /mm overall"
    );
    assert!(n > 10_000);
}

#[test]
fn the_issues_example_sagitta_of_12_nm() {
    // A 0.1 mm chord on a 100 mm radius (sagitta 12.5 nm), far from the origin.
    let (r, h) = (100.0, 0.1);
    for c in [
        [0.0, 0.0, 0.0],
        [9_000.0, -9_500.0, 300.0],
        [-10_000.0, 10_000.0, -10_000.0],
    ] {
        let (p1, p2, p3, _) = triple(c, r, h, 1.0, 0.3, (0.2, 0.0)).unwrap();
        let k = curvature(&p1, &p2, &p3).unwrap().to_f64();
        let want = reference::curvature(p1.to_f64(), p2.to_f64(), p3.to_f64()).unwrap();
        assert!((k - want).abs() / want < 1e-8, "{k} vs {want}");
        // Against the true circle: the 2^-32 mm input grid is the only error.
        assert!((k * r - 1.0).abs() < 1e-4, "κ·R = {}", k * r);
    }
}

#[test]
fn micrometre_spacing_on_large_radii() {
    // 1 µm chords on radii up to 1 m: the inputs' grid (2.3e-10 mm) limits
    // what any implementation can see; fixed and f64 agree on the same points.
    for r in [0.1, 1.0, 10.0, 100.0, 1000.0] {
        let (p1, p2, p3, _) =
            triple([5000.0, 5000.0, 0.0], r, 0.001, 1.0, 1.0, (0.0, 0.0)).unwrap();
        let k = curvature(&p1, &p2, &p3).unwrap().to_f64();
        let want = reference::curvature(p1.to_f64(), p2.to_f64(), p3.to_f64()).unwrap();
        assert!(
            (k - want).abs() / want.max(1e-12) < 1e-6 || (k - want).abs() < 1e-9,
            "r {r}: {k} vs {want}"
        );
    }
}

#[test]
fn degenerate_cases_match_the_reference() {
    let p = |x: f64, y: f64| Point3Mm::from_f64(x, y, 0.0).unwrap();
    // Reversal: both saturate / infinite.
    assert_eq!(
        curvature(&p(0.0, 0.0), &p(1.0, 0.0), &p(0.5, 0.0)).unwrap(),
        CurvaturePerMm::MAX
    );
    assert_eq!(
        reference::curvature([0.0; 3], [1.0, 0.0, 0.0], [0.5, 0.0, 0.0]),
        Some(f64::INFINITY)
    );
    // Sharp turns (corner term) agree with the f64 version of the same rule.
    for deg in [95.0f64, 120.0, 150.0, 170.0, 179.0] {
        let t = deg.to_radians();
        let (a, b, c) = (p(-1.0, 0.0), p(0.0, 0.0), p(3.0 * t.cos(), 3.0 * t.sin()));
        let k = curvature(&a, &b, &c).unwrap().to_f64();
        let w = reference::curvature(a.to_f64(), b.to_f64(), c.to_f64()).unwrap();
        assert!((k - w).abs() / w < 1e-7, "{deg}°: {k} vs {w}");
    }
}
