//! One run: a toolpath, a method, a maximum feed and a machine → schedule,
//! motion and the table's metrics.

use anyhow::Result;

use crate::config::SimConfig;
use crate::contour_error::PathIndex;
use crate::machine::Motion;
use crate::methods::{self, blend, grbl_like, AxisLimits, Method, Schedule};
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
/// With a tick-stream method ([`Method::is_tick_stream`]) the feeds are the
/// upper bounds of its planner and the machine follows the planner's
/// positions through its after-interpolation stage only
/// ([`crate::planner::machine`]).
pub fn run_schedule(
    prepared: &Prepared,
    method: Method,
    f_max_mm_per_min: f64,
    schedule: Schedule,
    config: &SimConfig,
) -> Result<RunResult> {
    let path = &prepared.path;
    let ts = config.ts_s();
    let limits = AxisLimits::of(&config.planner);
    let feeds = &schedule.feeds_mm_per_min;
    let motion = match method {
        Method::FuzzyPlanner | Method::Planner => {
            let points = planner::motion_points(path, feeds, &schedule.curvature_per_mm)?;
            let planned = planner::plan(&points, &path.lines, &config.planner)?;
            planner::machine::follow(&config.machine, planned.commanded(), ts)
        }
        Method::GrblLike => {
            let s = &config.methods.grbl_like;
            let c = grbl_like::commanded(&path.points, feeds, s, &limits, ts)?;
            planner::machine::follow(&config.machine, c, ts)
        }
        Method::Blend => {
            let s = &config.methods.blend;
            let c = blend::commanded(&path.points, feeds, s, &limits, ts)?;
            planner::machine::follow(&config.machine, c, ts)
        }
        Method::Constant | Method::ChordError | Method::Fuzzy | Method::FuzzyNoFilter => {
            config.machine.simulate(&path.points, feeds, ts)
        }
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
