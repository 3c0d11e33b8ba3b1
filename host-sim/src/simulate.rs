//! One run: a toolpath, a method, a maximum feed and a machine → schedule,
//! motion and the table's metrics.

use anyhow::Result;

use crate::config::SimConfig;
use crate::contour_error::PathIndex;
use crate::machine::Motion;
use crate::methods::{self, blend, grbl_like, AxisLimits, Method, Schedule};
use crate::metrics::{Kinematics, Metrics, Reference};
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
    /// Its tolerance (Grbl's junction deviation, LinuxCNC's P), mm.
    pub tolerance_mm: Option<f64>,
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
    check_motion_samples(&path.points, &schedule.feeds_mm_per_min, config)?;
    let limits = AxisLimits::of(&config.planner);
    let feeds = &schedule.feeds_mm_per_min;
    let motion = match method {
        Method::FuzzyPlanner | Method::Planner => {
            let points = planner::motion_points(path, feeds, &schedule.curvature_per_mm)?;
            let (_, commanded) = planner::plan_commanded(&points, &path.lines, &config.planner)?;
            planner::machine::follow(&config.machine, commanded, ts)
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
    let programmed = programmed_feeds(path, f_max_mm_per_min);
    let reference = Reference {
        programmed_mm_per_min: &programmed,
        accel_max_mm_per_s2: limits.accel_mm_per_s2,
        jerk_max_mm_per_s3: config.planner.jerk_max_mm_per_s3 as f64,
    };
    let (metrics, kinematics, contour_error_mm) =
        Metrics::measure(&prepared.index, &motion, &reference);
    Ok(RunResult {
        method,
        tolerance_mm: method.tolerance_mm(&config.methods),
        f_max_mm_per_min,
        schedule,
        motion,
        metrics,
        kinematics,
        contour_error_mm,
    })
}

impl RunResult {
    /// The method's name with its tolerance, e.g. `grbl-like 0.002`.
    pub fn label(&self) -> String {
        label(self.method, self.tolerance_mm)
    }
}

/// `method` with its tolerance, e.g. `grbl-like 0.002`, `blend 0.01`.
pub fn label(method: Method, tolerance_mm: Option<f64>) -> String {
    match tolerance_mm {
        Some(t) => format!("{} {t}", method.name()),
        None => method.name().to_string(),
    }
}

/// The programmed feed of each segment (point `i` to `i + 1`): its F word
/// capped by `f_max`, mm/min.
pub fn programmed_feeds(path: &Toolpath, f_max_mm_per_min: f64) -> Vec<f64> {
    (1..path.len().max(2))
        .map(|i| {
            path.feed_caps
                .get(i)
                .copied()
                .flatten()
                .map_or(f_max_mm_per_min, |c| c.min(f_max_mm_per_min))
        })
        .collect()
}

/// The fewest samples a simulated motion of `points` at
/// `feeds_mm_per_min` (the feed of the block ending at each point) can
/// have: every block at its feed (no method runs a block faster), plus
/// the machine's time constants, one sample per interpolation period.
pub fn motion_samples_at_least(
    points: &[[f64; 3]],
    feeds_mm_per_min: &[f64],
    config: &SimConfig,
) -> f64 {
    let mut t_s = config.machine.time_constants_s();
    for (i, w) in points.windows(2).enumerate() {
        let len = crate::toolpath::distance(w[0], w[1]);
        if len > 0.0 {
            let f = feeds_mm_per_min.get(i + 1).copied().unwrap_or(0.0);
            t_s += if f > 0.0 {
                len * 60.0 / f
            } else {
                f64::INFINITY
            };
        }
    }
    t_s / config.ts_s()
}

/// Refuse, before anything is allocated, a simulation that would need more
/// than `max_motion_samples` samples (a feed of a few µm/min, a path of
/// hours).
pub fn check_motion_samples(
    points: &[[f64; 3]],
    feeds_mm_per_min: &[f64],
    config: &SimConfig,
) -> Result<()> {
    let n = motion_samples_at_least(points, feeds_mm_per_min, config);
    let max = config.max_motion_samples;
    if n.is_nan() || n > max as f64 {
        anyhow::bail!(
            "the motion would take at least {} at the scheduled feeds, over {} samples of {} ms: more than max_motion_samples = {max} (a feed near zero, or a path of hours; raise max_motion_samples or interpolation_period_ms if it is meant)",
            duration_text(n * config.ts_s()),
            if n.is_finite() { format!("{n:.0}") } else { "infinitely many".into() },
            config.interpolation_period_ms,
        );
    }
    Ok(())
}

/// A duration for messages: hours from an hour on, else seconds.
pub fn duration_text(t_s: f64) -> String {
    if !t_s.is_finite() {
        "forever (a zero feed)".into()
    } else if t_s >= 3600.0 {
        format!("{:.1} h", t_s / 3600.0)
    } else {
        format!("{t_s:.1} s")
    }
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
