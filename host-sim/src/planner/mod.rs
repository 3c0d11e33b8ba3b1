//! fuzzy-core's velocity planner ([`fuzzy_core::planner::Motion`], issue 6)
//! on host-sim's toolpaths: the `[planner]` section of the TOML file, the
//! streaming run (scheduled points in, one commanded position per
//! interpolation period out), the ceilings and envelope it planned, and
//! what the planned motion is measured against ([`figures`]).
//!
//! The run streams exactly as a controller would: push each point; while
//! the buffer is full, tick and push again; after the last point end the
//! path and tick until the tool is at rest (`MotionState::Done`). No second
//! implementation: every position comes from fuzzy-core.
//!
//! - [`machine`]: how the tick stream reaches each simulated machine;
//! - [`figures`]: the plan report (cycle time vs the time-optimal reference,
//!   peak ratios to the limits, chord deviation);
//! - [`plot`]: the speed profile against arc length;
//! - [`trace`]: the bounded record of the ticks the plot and the ticks CSV
//!   are drawn from.
//!
//! Nothing grows with the number of ticks: the figures are measured as the
//! ticks come, the record is of bounded size, and a caller that needs
//! every commanded position (the machine simulation of `compare`) gets
//! them through [`plan_commanded`].

pub mod figures;
pub mod machine;
pub mod plot;
pub mod trace;

use anyhow::{bail, Context, Result};
use fuzzy_core::planner::{Motion, MotionConfig, MotionError, MotionPoint, MotionState};
use fuzzy_core::units::{CurvaturePerMm, FeedMmPerMin, Fx, Point3Mm};
use serde::{Deserialize, Serialize};

use crate::toolpath::Toolpath;

/// Lookahead buffers the host tools are compiled for (a const generic in
/// fuzzy-core), points.
pub const SUPPORTED_BUFFERS: [usize; 5] = [16, 64, 256, 1024, 4096];

/// The `[planner]` section: every field of fuzzy-core's [`MotionConfig`]
/// (same defaults, `MotionConfig::default()`), in the file's units, and the
/// lookahead buffer size.
///
/// The limits describe the simulated machine; `host-sim` warns where they
/// exceed it ([`machine::limit_notes`]). `tick_us` must equal the
/// interpolation period (the planner's ticks *are* the machine's
/// interpolation samples); `--interpolation-period-ms` sets both.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlannerSettings {
    /// Interpolation period `Ts`, µs (= `interpolation_period_ms × 1000`).
    pub tick_us: u32,
    /// Largest feed the planner runs (programmed or scheduled feeds above it
    /// are capped; it also sets the reach of the corner limits), mm/min.
    pub feed_max_mm_per_min: f64,
    /// Per-axis maximum velocity (X, Y, Z), mm/min.
    pub axis_speed_max_mm_per_min: [f64; 3],
    /// Per-axis maximum acceleration (X, Y, Z), mm/s². The FANUC-like
    /// machine's counterpart is parameter 1660.
    pub axis_accel_max_mm_per_s2: [u32; 3],
    /// Maximum tangential jerk, mm/s³.
    pub jerk_max_mm_per_s3: u32,
    /// Chord error δ allowed between two interpolation points, mm.
    pub chord_tolerance_mm: f64,
    /// Share ρ of each axis' acceleration given to tangential acceleration
    /// (the rest is kept for changes of direction), `0 < ρ < 1`.
    pub tangential_share: f64,
    /// Ticks the commanded position is averaged over (1 = off, up to 8; 0,
    /// the default: the most that fit the tolerance, tick and
    /// acceleration, up to 4): corners blended within the chord tolerance
    /// and passed faster.
    pub smoothing_ticks: u8,
    /// Lookahead buffer, points (one of [`SUPPORTED_BUFFERS`]).
    pub buffer_points: usize,
}

impl Default for PlannerSettings {
    fn default() -> Self {
        Self::from_motion_config(&MotionConfig::default(), 256)
    }
}

impl PlannerSettings {
    /// The settings that give `c`.
    pub fn from_motion_config(c: &MotionConfig, buffer_points: usize) -> Self {
        PlannerSettings {
            tick_us: c.tick_us,
            feed_max_mm_per_min: c.feed_max.to_f64(),
            axis_speed_max_mm_per_min: c.axis_speed_max.map(|f| f.to_f64()),
            axis_accel_max_mm_per_s2: c.axis_accel_max_mm_s2,
            jerk_max_mm_per_s3: c.jerk_max_mm_s3,
            // To the nanometre (the Q32 value of 1 µm prints as 0.00099999993).
            chord_tolerance_mm: (c.chord_tolerance_mm.to_num::<f64>() * 1e9).round() / 1e9,
            tangential_share: c.tangential_share.to_num(),
            smoothing_ticks: c.smoothing_ticks,
            buffer_points,
        }
    }

    /// fuzzy-core's configuration (not yet checked: see [`Self::validate`]).
    pub fn motion_config(&self) -> MotionConfig {
        MotionConfig {
            tick_us: self.tick_us,
            feed_max: FeedMmPerMin::from_f64(self.feed_max_mm_per_min),
            axis_speed_max: self.axis_speed_max_mm_per_min.map(FeedMmPerMin::from_f64),
            axis_accel_max_mm_s2: self.axis_accel_max_mm_per_s2,
            jerk_max_mm_s3: self.jerk_max_mm_per_s3,
            // I32F32 through a unit type of fuzzy-core (host-sim does not
            // depend on `fixed` itself).
            chord_tolerance_mm: CurvaturePerMm::from_f64(self.chord_tolerance_mm).0,
            tangential_share: Fx::saturating_from_num(self.tangential_share),
            smoothing_ticks: self.smoothing_ticks,
            exact_path: false,
        }
    }

    /// The ticks averaged with these settings (`smoothing_ticks`, or what
    /// 0 picks); 1 if they are invalid.
    pub fn smoothing(&self) -> u8 {
        self.motion_config().smoothing().unwrap_or(1)
    }

    /// Check the settings for the interpolation period `ts_s`.
    pub fn validate(&self, ts_s: f64) -> Result<()> {
        let finite = self.feed_max_mm_per_min.is_finite()
            && self.axis_speed_max_mm_per_min.iter().all(|v| v.is_finite())
            && self.chord_tolerance_mm.is_finite()
            && self.tangential_share.is_finite();
        anyhow::ensure!(finite, "planner: every value must be finite");
        let tick_s = self.tick_us as f64 * 1e-6;
        anyhow::ensure!(
            (tick_s - ts_s).abs() <= 1e-9,
            "planner.tick_us = {} but interpolation_period_ms = {}: they must agree (the planner's ticks are the interpolation samples)",
            self.tick_us,
            ts_s * 1000.0
        );
        anyhow::ensure!(
            SUPPORTED_BUFFERS.contains(&self.buffer_points),
            "planner.buffer_points must be one of {SUPPORTED_BUFFERS:?}"
        );
        Motion::<16>::new(self.motion_config())
            .map(|_| ())
            .map_err(|e| anyhow::anyhow!("planner: {e}"))
    }

    /// The tangential acceleration limit `ρ·min A`, mm/s².
    pub fn tangential_accel_mm_per_s2(&self) -> f64 {
        let a = self
            .axis_accel_max_mm_per_s2
            .iter()
            .copied()
            .min()
            .unwrap_or(0);
        a as f64 * self.tangential_share
    }
}

/// One interpolation tick as the planner emitted it (f64, exact copies of
/// its fixed-point values).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TickRecord {
    /// Commanded position, mm.
    pub pos: [f64; 3],
    /// Arc length travelled, mm.
    pub s_mm: f64,
    /// Tangential speed, mm/s.
    pub speed_mm_per_s: f64,
    /// Tangential acceleration, mm/s².
    pub accel_mm_per_s2: f64,
    /// Index of the last path point reached.
    pub point: u32,
    /// Executor state.
    pub state: MotionState,
}

/// What the planner derived for a path point (as the executor passed it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointPlan {
    /// Index in the toolpath.
    pub index: usize,
    /// Position, mm.
    pub pos: [f64; 3],
    /// Arc length, mm (the planner's).
    pub s_mm: f64,
    /// Speed ceiling at the point, mm/s.
    pub ceiling_mm_per_s: f64,
    /// Speed cap of the outgoing segment, mm/s (0 for the last point).
    pub cap_mm_per_s: f64,
    /// Envelope when the executor reached the point, mm/s.
    pub envelope_mm_per_s: f64,
    /// The planner's input at the point: feed of the block ending here
    /// (the scheduled upper bound), mm/s.
    pub feed_mm_per_s: f64,
    /// The planner's input at the point: curvature, 1/mm.
    pub curvature_per_mm: f64,
}

/// A planned motion: what its ticks measured, a bounded record of them,
/// and the plan. No tick is kept beyond the record: the run's memory does
/// not grow with its duration.
#[derive(Clone, Debug, PartialEq)]
pub struct PlannedRun {
    /// Interpolation period, s.
    pub ts_s: f64,
    /// Where the tool starts (the path's first point), mm.
    pub start: [f64; 3],
    /// Ticks until the tool is at rest at the end.
    pub ticks: u64,
    /// The last tick (`Done`).
    pub last: TickRecord,
    /// The figures of every tick ([`figures::Meter`]).
    pub measured: figures::TickFigures,
    /// The ticks for plots and CSV: every one, or evenly spaced ones with
    /// the extremes between them on long runs ([`trace`]).
    pub trace: trace::Trace,
    /// Every path point with its ceiling, cap and envelope.
    pub points: Vec<PointPlan>,
    /// The planner's tangential acceleration limit, mm/s².
    pub accel_limit_mm_per_s2: f64,
    /// Most ticks held at once until the points they pass were known
    /// ([`figures::Meter::check`]).
    pub held_ticks_peak: usize,
}

impl PlannedRun {
    /// Cycle time: ticks until the tool is at rest at the end, s.
    pub fn cycle_time_s(&self) -> f64 {
        self.ticks as f64 * self.ts_s
    }
}

/// The planner's input: each toolpath point with its feed (mm/min, the
/// feed of the block ending there; entry 0 unused) and curvature (1/mm).
pub fn motion_points(
    path: &Toolpath,
    feeds_mm_per_min: &[f64],
    curvature_per_mm: &[f64],
) -> Result<Vec<MotionPoint>> {
    anyhow::ensure!(
        feeds_mm_per_min.len() == path.len(),
        "{} feeds for {} points",
        feeds_mm_per_min.len(),
        path.len()
    );
    (0..path.len())
        .map(|i| {
            let p = path.points[i];
            let pos = Point3Mm::from_f64(p[0], p[1], p[2])
                .with_context(|| format!("line {}: coordinate out of range", path.lines[i]))?;
            Ok(MotionPoint {
                pos,
                feed: FeedMmPerMin::from_f64(feeds_mm_per_min[i]),
                curvature: CurvaturePerMm::from_f64(
                    curvature_per_mm.get(i).copied().unwrap_or(0.0).abs(),
                ),
            })
        })
        .collect()
}

/// Plan `points` (from [`motion_points`]; `lines` are their source lines,
/// for errors) and run the executor to the end.
pub fn plan(
    points: &[MotionPoint],
    lines: &[u32],
    settings: &PlannerSettings,
) -> Result<PlannedRun> {
    plan_with(points, lines, settings, &mut |_| {})
}

/// [`plan`], and every commanded position: the start, then one per tick
/// (what the machine receives at `t = 0, Ts, 2Ts, …`). Its length grows
/// with the duration: the caller bounds it first (`compare` checks
/// `max_motion_samples`).
pub fn plan_commanded(
    points: &[MotionPoint],
    lines: &[u32],
    settings: &PlannerSettings,
) -> Result<(PlannedRun, Vec<[f64; 3]>)> {
    let start = points.first().map_or([0.0; 3], |p| p.pos.to_f64());
    let mut commanded = vec![start];
    let run = plan_with(points, lines, settings, &mut |t| commanded.push(t.pos))?;
    Ok((run, commanded))
}

/// [`plan`], handing each tick to `on_tick` as it comes.
pub fn plan_with(
    points: &[MotionPoint],
    lines: &[u32],
    settings: &PlannerSettings,
    on_tick: &mut dyn FnMut(&TickRecord),
) -> Result<PlannedRun> {
    match settings.buffer_points {
        16 => stream::<16>(points, lines, settings, on_tick),
        64 => stream::<64>(points, lines, settings, on_tick),
        256 => stream::<256>(points, lines, settings, on_tick),
        1024 => stream::<1024>(points, lines, settings, on_tick),
        4096 => stream::<4096>(points, lines, settings, on_tick),
        n => bail!("planner.buffer_points = {n}: one of {SUPPORTED_BUFFERS:?}"),
    }
}

/// Collects the plan of each point once the executor has reached it (a
/// node is dropped only once the tool is past it by the corner reach, at
/// least 2.5 ticks of travel, so nothing is missed), which makes the plan
/// of paths longer than any buffer available without a second, whole-path
/// planner.
struct Recorder {
    points: Vec<PointPlan>,
    /// Arc length of the first point not yet recorded, where the planner
    /// has it (the chord and ceiling checks wait for the points they
    /// need: [`figures::Meter::check`]).
    horizon: Option<f64>,
}

impl Recorder {
    /// Record the points up to index `upto` (all with `None`, at the end)
    /// not yet recorded. The newest finalized point is left for later: its
    /// outgoing cap is not known until the next point is final.
    fn take<const N: usize>(&mut self, m: &Motion<N>, upto: Option<u32>) {
        let to_s = |f: FeedMmPerMin| f.to_f64() / 60.0;
        let mut it = m.planned().peekable();
        self.horizon = None;
        while let Some(p) = it.next() {
            let i = p.index as usize;
            if i < self.points.len() {
                continue;
            }
            if upto.is_some_and(|u| p.index > u) || (upto.is_some() && it.peek().is_none()) {
                if i == self.points.len() {
                    self.horizon = Some(p.s_mm.to_num());
                }
                break;
            }
            // Points arrive in order; a gap would be a planner change.
            debug_assert_eq!(i, self.points.len());
            self.points.push(PointPlan {
                index: i,
                pos: p.pos.to_f64(),
                s_mm: p.s_mm.to_num(),
                ceiling_mm_per_s: to_s(p.ceiling),
                cap_mm_per_s: to_s(p.cap),
                envelope_mm_per_s: to_s(p.envelope),
                feed_mm_per_s: 0.0,
                curvature_per_mm: 0.0,
            });
        }
    }
}

/// The tick stream's consumers: the count, the meter, the record and the
/// caller's `on_tick`.
struct Ticks<'a> {
    ts_s: f64,
    count: u64,
    /// The newest tick, not yet in the record (its acceleration needs the
    /// tick after it).
    last: Option<TickRecord>,
    meter: figures::Meter,
    trace: trace::Trace,
    on_tick: &'a mut dyn FnMut(&TickRecord),
}

impl Ticks<'_> {
    /// One tick of `m`: record the points it has reached so far, run it,
    /// measure it.
    fn tick<const N: usize>(&mut self, m: &mut Motion<N>, rec: &mut Recorder) -> MotionState {
        rec.take(m, Some(self.last.map_or(0, |t| t.point)));
        let t = m.tick();
        let r = TickRecord {
            pos: t.pos.to_f64(),
            s_mm: t.s_mm.to_num(),
            speed_mm_per_s: m.speed_mm_per_min(t.speed).to_f64() / 60.0,
            accel_mm_per_s2: t.accel.to_mm_per_s2_f64(self.ts_s),
            point: t.point,
            state: t.state,
        };
        self.count += 1;
        let acc = self.meter.tick(r.pos, r.s_mm, r.speed_mm_per_s);
        self.meter.check(&rec.points, rec.horizon);
        if let Some(prev) = self.last.replace(r) {
            self.trace.push(&prev, acc);
        }
        (self.on_tick)(&r);
        t.state
    }
}

fn stream<const N: usize>(
    points: &[MotionPoint],
    lines: &[u32],
    settings: &PlannerSettings,
    on_tick: &mut dyn FnMut(&TickRecord),
) -> Result<PlannedRun> {
    let cfg = settings.motion_config();
    let ts_s = cfg.tick_us as f64 * 1e-6;
    let mut m: Box<Motion<N>> =
        Box::new(Motion::new(cfg).map_err(|e| anyhow::anyhow!("planner: {e}"))?);
    let start = points.first().map_or([0.0; 3], |p| p.pos.to_f64());
    let accel_limit_mm_per_s2: f64 = m.accel_limit_mm_s2().to_num();
    let mut rec = Recorder {
        points: Vec::new(),
        horizon: None,
    };
    let mut ticks = Ticks {
        ts_s,
        count: 0,
        last: None,
        meter: figures::Meter::new(settings, accel_limit_mm_per_s2, ts_s, start, points.len()),
        trace: trace::Trace::new(start, trace::TRACE_BUCKETS),
        on_tick,
    };
    for (i, p) in points.iter().enumerate() {
        loop {
            match m.push(*p) {
                Ok(()) => break,
                Err(MotionError::Full) => {
                    ticks.tick(&mut *m, &mut rec);
                }
                Err(e) => bail!("line {}: planner: {e}", lines.get(i).copied().unwrap_or(0)),
            }
        }
    }
    m.end_path();
    // Generous: the slowest tool (creep speed) on the whole path.
    let length = points
        .windows(2)
        .map(|w| {
            let (a, b) = (w[0].pos.to_f64(), w[1].pos.to_f64());
            crate::toolpath::distance(a, b)
        })
        .sum::<f64>();
    let limit = ticks.count + 10_000_000 + (length * 1e3) as u64;
    while ticks.tick(&mut *m, &mut rec) != MotionState::Done {
        if ticks.count > limit {
            bail!("planner: the tool did not arrive within {limit} ticks");
        }
    }
    rec.take(&*m, None);
    anyhow::ensure!(
        rec.points.len() == points.len(),
        "planner: plan of {} points recorded for {}",
        rec.points.len(),
        points.len()
    );
    for p in &mut rec.points {
        let input = &points[p.index];
        p.feed_mm_per_s = input.feed.to_f64() / 60.0;
        p.curvature_per_mm = input.curvature.to_f64();
    }
    let Ticks {
        count,
        last,
        meter,
        mut trace,
        ..
    } = ticks;
    let last = last.context("planner: no tick")?;
    trace.push(&last, None);
    Ok(PlannedRun {
        ts_s,
        start,
        ticks: count,
        last,
        held_ticks_peak: meter.pending_peak(),
        measured: meter.finish(&rec.points),
        trace,
        points: rec.points,
        accel_limit_mm_per_s2,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_fuzzy_cores() {
        let s = PlannerSettings::default();
        assert_eq!(s.motion_config(), MotionConfig::default());
        assert_eq!(s.buffer_points, 256);
        s.validate(0.001).unwrap();
        assert!(s.validate(0.0005).is_err());
        assert!((s.tangential_accel_mm_per_s2() - 1000.0).abs() < 1e-9);
    }

    #[test]
    fn bad_settings_are_refused() {
        let d = PlannerSettings::default();
        for bad in [
            PlannerSettings {
                tangential_share: 1.0,
                ..d.clone()
            },
            PlannerSettings {
                jerk_max_mm_per_s3: 0,
                ..d.clone()
            },
            PlannerSettings {
                chord_tolerance_mm: 0.0,
                ..d.clone()
            },
            PlannerSettings {
                buffer_points: 100,
                ..d.clone()
            },
            PlannerSettings {
                feed_max_mm_per_min: f64::NAN,
                ..d.clone()
            },
        ] {
            assert!(bad.validate(0.001).is_err(), "{bad:?}");
        }
    }

    fn line_path(n: usize, step: f64) -> Toolpath {
        Toolpath::from_points(
            "line",
            (0..=n).map(|i| [i as f64 * step, 0.0, 0.0]).collect(),
        )
        .unwrap()
    }

    #[test]
    fn a_straight_line_ends_at_its_last_point_with_every_point_planned() {
        let path = line_path(400, 0.25);
        let feeds = vec![3000.0; path.len()];
        let pts = motion_points(&path, &feeds, &[]).unwrap();
        for buffer in SUPPORTED_BUFFERS {
            let s = PlannerSettings {
                buffer_points: buffer,
                ..Default::default()
            };
            let run = plan(&pts, &path.lines, &s).unwrap();
            assert_eq!(run.points.len(), path.len());
            assert!(run.points.windows(2).all(|w| w[1].s_mm > w[0].s_mm));
            let last = run.last;
            assert_eq!(last.state, MotionState::Done);
            assert_eq!(last.pos, [100.0, 0.0, 0.0]);
            // 100 mm at 50 mm/s plus the ramps.
            let t = run.cycle_time_s();
            assert!(t > 2.0 && t < 2.2, "{buffer}: {t}");
            let vmax = run
                .trace
                .buckets()
                .iter()
                .map(|b| b.speed.hi.value)
                .fold(0.0, f64::max);
            assert!((vmax - 50.0).abs() < 0.01, "{vmax}");
        }
    }

    #[test]
    fn long_segments_hold_no_more_than_a_few_ticks() {
        // Three points two metres apart: minutes of ticks between points,
        // each measured as it comes.
        let path = Toolpath::from_points(
            "long",
            vec![
                [-1000.0, 0.0, 0.0],
                [1000.0, 0.0, 0.0],
                [1000.0, 500.0, 0.0],
            ],
        )
        .unwrap();
        let pts = motion_points(&path, &[3000.0; 3], &[]).unwrap();
        for smoothing_ticks in [1, 2] {
            let s = PlannerSettings {
                smoothing_ticks,
                ..Default::default()
            };
            let run = plan(&pts, &path.lines, &s).unwrap();
            assert!(run.ticks > 50_000, "{}", run.ticks);
            assert!(run.held_ticks_peak <= 8, "{}", run.held_ticks_peak);
            assert_eq!(run.last.pos, [1000.0, 500.0, 0.0]);
        }
    }
}
