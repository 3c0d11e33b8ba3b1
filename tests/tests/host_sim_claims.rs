//! The figures host-sim's README reports, under test: on the paper's three
//! shapes at F_max 3000 mm/min on the FANUC-like machine (conventional mode,
//! default configuration), the fuzzy scheduler against a constant feed at
//! equal cycle time and at equal maximum contour error. The bounds sit just
//! below the measured values, so a change that loses accuracy or speed
//! fails here. Same figures: `./scripts/run.sh` (table in
//! `results/claims.csv`).

use host_sim::config::SimConfig;
use host_sim::experiments::lin2021::compare;
use host_sim::methods::Method;
use host_sim::shapes::Shape;
use host_sim::simulate::{self, Prepared};

#[test]
fn fuzzy_beats_constant_feed_on_the_papers_shapes() {
    let config = SimConfig::default();
    // (shape, min error reduction, min time reduction) — measured 73.3 / 48.7,
    // 85.2 / 71.6, 60.3 / 65.6 %.
    for (shape, err, time) in [
        (Shape::Infinity, 0.70, 0.46),
        (Shape::Trident, 0.82, 0.69),
        (Shape::Butterfly, 0.57, 0.62),
    ] {
        let p = Prepared::new(shape.toolpath().unwrap());
        let fuzzy = simulate::run(&p, Method::Fuzzy, 3000.0, &config).unwrap();
        let c = compare::claim(&p, &fuzzy, &config).unwrap();
        eprintln!(
            "{}: error −{:.1} % at equal time, time −{:.1} % at equal error",
            shape.name(),
            100.0 * c.error_reduction().unwrap(),
            100.0 * c.time_reduction().unwrap()
        );
        assert!(c.error_reduction().unwrap() >= err, "{shape:?}: {c:?}");
        assert!(c.time_reduction().unwrap() >= time, "{shape:?}: {c:?}");
    }
}

#[test]
fn fuzzy_planner_beats_every_baseline_on_the_trident() {
    // Measured at F_max 3000 (README): error ratio at equal time / time
    // ratio at equal error, planner 0.36 / 0.29, grbl-like (δ 0.01) 0.18 /
    // 0.30, blend (P 0.01) 0.20 / 0.27. Bounds just above.
    use host_sim::experiments::lin2021::compare::{claim_against, Variant};
    let config = SimConfig::default();
    let p = Prepared::new(Shape::Trident.toolpath().unwrap());
    let fp = simulate::run(&p, Method::FuzzyPlanner, 3000.0, &config).unwrap();
    for (method, tolerance_mm, err, time) in [
        (Method::Planner, None, 0.40, 0.33),
        (Method::GrblLike, Some(0.01), 0.21, 0.33),
        (Method::Blend, Some(0.01), 0.23, 0.30),
    ] {
        let b = Variant {
            method,
            tolerance_mm,
        };
        let c = claim_against(&p, &fp, b, &config).unwrap();
        eprintln!(
            "trident vs {}: error ratio {:?}, time ratio {:?}",
            c.baseline_label(),
            c.error_ratio,
            c.time_ratio
        );
        assert!(c.error_ratio.unwrap() <= err, "{c:?}");
        assert!(c.time_ratio.unwrap() <= time, "{c:?}");
    }
}
