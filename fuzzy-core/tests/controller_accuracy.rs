//! The fixed-point controller against the f64 reference of the same
//! controller (membership functions, min/max, exact centroid integral) on a
//! dense grid of the whole input domain (and beyond it, where inputs clamp).
//! The bound: 0.25 % of F_max. Run with `--nocapture` for figures.

use fuzzy_core::lin2021::{CONTROLLER, SYSTEM};
use fuzzy_core::reference::Mamdani;
use fuzzy_core::units::Fx;

/// κ from −0.1 to 3.5 /mm in 0.001 steps (with extra density below 0.5,
/// where the sets are narrow), Dκ from −0.05 to 1.05 in 0.0025 steps.
fn grid() -> impl Iterator<Item = (f64, f64)> {
    let ks = (0..=3600)
        .map(|i| -0.1 + i as f64 * 0.001)
        .chain((0..=5000).map(|i| i as f64 * 0.0001));
    let ks: Vec<f64> = ks.collect();
    ks.into_iter()
        .flat_map(|k| (0..=440).map(move |j| (k, -0.05 + j as f64 * 0.0025)))
}

#[test]
fn fixed_point_controller_matches_f64_within_a_quarter_percent() {
    let reference = Mamdani::new(&SYSTEM);
    let (mut worst, mut at, mut n) = (0f64, (0.0, 0.0), 0usize);
    for (k, d) in grid().step_by(13) {
        let x = [Fx::from_num(k), Fx::from_num(d)];
        let got: f64 = CONTROLLER.evaluate(x).output.to_num();
        // The reference sees the same (Q16.16-rounded) inputs.
        let want = reference
            .evaluate([x[0].to_num(), x[1].to_num()])
            .expect("every input fires a rule");
        let err = (got - want).abs();
        if err > worst {
            worst = err;
            at = (k, d);
        }
        n += 1;
    }
    eprintln!(
        "controller: fixed point vs f64 (exact centroid) on {n} inputs covering κ -0.1..3.5 /mm, Dκ -0.05..1.05: \
         max error {:.5} % of F_max (at κ {:.4}, Dκ {:.4})",
        worst * 100.0,
        at.0,
        at.1
    );
    assert!(worst <= 0.0025, "max error {worst}");
}

#[test]
fn matlab_style_sampled_centroid_matches_f64() {
    // `evaluate_sampled` is eq. 11 over 101 samples, MATLAB's evalfis default.
    let reference = Mamdani::new(&SYSTEM);
    let (mut worst, mut worst_vs_exact) = (0f64, 0f64);
    for (k, d) in grid().step_by(97) {
        let x = [Fx::from_num(k), Fx::from_num(d)];
        let got: f64 = CONTROLLER.evaluate_sampled(x).output.to_num();
        let xf = [x[0].to_num(), x[1].to_num()];
        let want = reference.sampled(xf, 101).unwrap();
        worst = worst.max((got - want).abs());
        worst_vs_exact = worst_vs_exact.max((want - reference.evaluate(xf).unwrap()).abs());
    }
    eprintln!(
        "controller: 101-sample centroid, fixed vs f64: max error {:.5} % of F_max; \
         MATLAB's 101 samples vs the exact integral: up to {:.4} % of F_max",
        worst * 100.0,
        worst_vs_exact * 100.0
    );
    assert!(worst <= 0.0025);
    assert!(worst_vs_exact <= 0.002);
}
