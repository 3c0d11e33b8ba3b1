//! One run: a toolpath, a method, a maximum feed and a machine → schedule,
//! motion and the table's metrics.

use anyhow::Result;

use crate::config::SimConfig;
use crate::contour_error::PathIndex;
use crate::machine::Motion;
use crate::methods::{self, Method, Schedule};
use crate::metrics::{Kinematics, Metrics};
use crate::planner;
use crate::toolpath::Toolpath;

/// A toolpath prepared for repeated runs (its contour-error index built
/// once).
#[derive(Clone, Debug)]
pub struct Prepared {
    /// The toolpath.
    pub path: Toolpath,
    /// Its index for contour-error queries.
    pub index: PathIndex,
}

impl Prepared {
    /// Index `path`.
    pub fn new(path: Toolpath) -> Self {
        let index = PathIndex::new(&path.points);
        Prepared { path, index }
    }
}

/// Everything one run produces.
#[derive(Clone, Debug)]
pub struct RunResult {
    /// The method.
    pub method: Method,
    /// Its maximum feed, mm/min.
    pub f_max_mm_per_min: f64,
    /// The commanded feeds.
    pub schedule: Schedule,
    /// Commanded and actual motion.
    pub motion: Motion,
    /// Table metrics.
    pub metrics: Metrics,
    /// Actual kinematics.
    pub kinematics: Kinematics,
    /// Contour error of each actual sample, mm.
    pub contour_error_mm: Vec<f64>,
}

/// Simulate a given schedule on the configured machine and measure it.
/// With [`Method::FuzzyPlanner`] the feeds are the planner's upper bounds
/// and the machine follows the planner's positions
/// ([`crate::planner::machine`]).
pub fn run_schedule(
    prepared: &Prepared,
    method: Method,
    f_max_mm_per_min: f64,
    schedule: Schedule,
    config: &SimConfig,
) -> Result<RunResult> {
    let motion = if method == Method::FuzzyPlanner {
        let path = &prepared.path;
        let points =
            planner::motion_points(path, &schedule.feeds_mm_per_min, &schedule.curvature_per_mm)?;
        let planned = planner::plan(&points, &path.lines, &config.planner)?;
        planner::machine::follow(&config.machine, planned.commanded(), config.ts_s())
    } else {
        config.machine.simulate(
            &prepared.path.points,
            &schedule.feeds_mm_per_min,
            config.ts_s(),
        )
    };
    let (metrics, kinematics, contour_error_mm) = Metrics::measure(&prepared.index, &motion);
    Ok(RunResult {
        method,
        f_max_mm_per_min,
        schedule,
        motion,
        metrics,
        kinematics,
        contour_error_mm,
    })
}

/// Schedule with `method` at `f_max`, simulate, measure.
pub fn run(
    prepared: &Prepared,
    method: Method,
    f_max_mm_per_min: f64,
    config: &SimConfig,
) -> Result<RunResult> {
    let schedule = methods::schedule(
        method,
        &prepared.path,
        f_max_mm_per_min,
        config.ts_s(),
        &config.methods,
    )?;
    run_schedule(prepared, method, f_max_mm_per_min, schedule, config)
}
