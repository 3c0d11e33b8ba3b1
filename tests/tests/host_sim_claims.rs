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
