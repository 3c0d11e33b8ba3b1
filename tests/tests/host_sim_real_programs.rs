//! Real public G-code programs that are on this machine but not in the
//! repository: every program in the folder `HOST_SIM_GCODE_CORPUS` names
//! that host-sim reads runs through fuzzy + planner and the three
//! baselines at F_max 3000 mm/min, and each run must end at the program's
//! last point with finite figures. Skipped without the variable
//! (`./scripts/real-gcode.sh` fills a folder from a local LinuxCNC mirror
//! and prints the comparison). Bounded: programs of at most 20 000 points.

use host_sim::config::SimConfig;
use host_sim::inputs;
use host_sim::methods::Method;
use host_sim::simulate::{self, Prepared};

#[test]
fn real_programs_run_through_every_planner() {
    let Ok(dir) = std::env::var("HOST_SIM_GCODE_CORPUS") else {
        eprintln!("SKIPPED: HOST_SIM_GCODE_CORPUS not set");
        return;
    };
    let config = SimConfig::default();
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .collect();
    files.sort();
    let mut ran = 0;
    for f in files {
        let Ok(t) = inputs::load(&f, &config.gcode) else {
            eprintln!("refused: {}", f.display());
            continue;
        };
        if t.len() < 100 || t.len() > 20_000 {
            continue;
        }
        let end = *t.points.last().unwrap();
        let p = Prepared::new(t);
        for m in [
            Method::FuzzyPlanner,
            Method::Planner,
            Method::GrblLike,
            Method::Blend,
        ] {
            let r = simulate::run(&p, m, 3000.0, &config).unwrap();
            let last = *r.motion.actual.last().unwrap();
            let miss = (0..3).map(|k| (last[k] - end[k]).abs()).fold(0.0, f64::max);
            assert!(miss < 1e-6, "{} {m:?}: ends {miss} mm off", f.display());
            assert!(r.metrics.contour_error_max_mm.is_finite() && r.metrics.cycle_time_s > 0.0);
            eprintln!(
                "{} {}: {:.3} s, max error {:.4} mm",
                p.path.name,
                m.name(),
                r.metrics.cycle_time_s,
                r.metrics.contour_error_max_mm
            );
        }
        ran += 1;
    }
    eprintln!("{ran} real programs run");
}
