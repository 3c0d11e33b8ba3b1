//! Feed-scheduling methods compared in the table: each turns a toolpath and
//! a maximum feed into the feed of every block (mm/min; entry `i` is the
//! block ending at point `i`, as a CAM system would write `G1 X.. Y.. F..`).
//!
//! | method | what |
//! |---|---|
//! | `constant` | one feed for the whole path (the machinist's choice) |
//! | `chord-error` | curvature pre-schedule in the spirit of Yeh & Hsu and Luan et al. (Lin et al. refs. 9-10): `v ≤ (2/Ts)·√(2δ/κ − δ²)`, `v ≤ √(A/κ)`, then acceleration-limited passes |
//! | `fuzzy` | Lin et al.'s scheduler (fuzzy-core), with the average filter |
//! | `fuzzy-no-filter` | the same without the average filter (AVG = 1) |
//! | `fuzzy-planner` | the `fuzzy` feeds as upper bounds of fuzzy-core's velocity planner, whose tick stream goes to the machine ([`crate::planner`]) |
//! | `planner` | the programmed feeds (as `constant`) through the same planner, same limits: what the planner gives without the fuzzy stage |
//! | `grbl-like` | Grbl 1.1's planner: junction deviation, trapezoids, 16-block lookahead ([`grbl_like`]) |
//! | `blend` | LinuxCNC's `G64 P` blending: corners replaced by arcs within a tolerance, trapezoids over a 50-segment lookahead ([`blend`]) |
//!
//! Every curvature here is fuzzy-core's (eq. 4-9, the scheduler's own
//! output): no second implementation.
//!
//! The last four methods make their own motion every interpolation period
//! (a tick stream) instead of a feed per block for host-sim's interpolator:
//! their schedule here is the planner's upper bounds (`fuzzy` feeds for
//! `fuzzy-planner`, the programmed feeds for the others);
//! [`crate::simulate::run`] hands the machine their positions. The three
//! baselines plan with the machine's limits of `[planner]` (per-axis
//! acceleration and speed); Grbl and LinuxCNC's trapezoidal planner have
//! no jerk limit, fuzzy-core's planner has one.

pub mod blend;
pub mod grbl_like;

use anyhow::{bail, Result};
use fuzzy_core::lin2021::{VariationScale, CONTROLLER};
use fuzzy_core::scheduler::{ScheduledPoint, Scheduler, SchedulerConfig};
use fuzzy_core::units::{CurvaturePerMm, FeedMmPerMin};
use serde::{Deserialize, Serialize};

use crate::toolpath::Toolpath;

/// A scheduling method.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// One feed (the maximum feed) everywhere, capped by programmed feeds.
    Constant,
    /// Chord-error and acceleration pre-schedule from the curvature.
    ChordError,
    /// Lin et al.'s fuzzy scheduler with the average filter.
    Fuzzy,
    /// Lin et al.'s fuzzy scheduler without the average filter.
    FuzzyNoFilter,
    /// The fuzzy scheduler's feeds as upper bounds of fuzzy-core's
    /// acceleration- and jerk-limited velocity planner (`[planner]` in the
    /// configuration), whose positions go to the machine.
    FuzzyPlanner,
    /// The programmed feeds (F words capped by the maximum feed) through
    /// the same planner, without the fuzzy stage.
    Planner,
    /// Grbl 1.1's planner (`[methods.grbl_like]`).
    GrblLike,
    /// LinuxCNC's `G64 P` blending planner (`[methods.blend]`).
    Blend,
}

impl Method {
    /// Every method, in the table's order.
    pub const ALL: [Method; 8] = [
        Method::Constant,
        Method::ChordError,
        Method::Fuzzy,
        Method::FuzzyNoFilter,
        Method::FuzzyPlanner,
        Method::Planner,
        Method::GrblLike,
        Method::Blend,
    ];

    /// Name as on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Method::Constant => "constant",
            Method::ChordError => "chord-error",
            Method::Fuzzy => "fuzzy",
            Method::FuzzyNoFilter => "fuzzy-no-filter",
            Method::FuzzyPlanner => "fuzzy-planner",
            Method::Planner => "planner",
            Method::GrblLike => "grbl-like",
            Method::Blend => "blend",
        }
    }

    /// Whether the method makes its own motion every interpolation period
    /// (rather than a feed per block).
    pub fn is_tick_stream(self) -> bool {
        matches!(
            self,
            Method::FuzzyPlanner | Method::Planner | Method::GrblLike | Method::Blend
        )
    }

    /// The tolerance the method is tuned by, if any: Grbl's junction
    /// deviation, LinuxCNC's P.
    pub fn tolerance_mm(self, settings: &MethodSettings) -> Option<f64> {
        match self {
            Method::GrblLike => Some(settings.grbl_like.junction_deviation_mm),
            Method::Blend => Some(settings.blend.tolerance_mm),
            _ => None,
        }
    }

    /// `settings` with the method's tolerance set to `tolerance_mm` (no
    /// change for a method without one).
    pub fn with_tolerance(self, settings: &MethodSettings, tolerance_mm: f64) -> MethodSettings {
        let mut s = settings.clone();
        match self {
            Method::GrblLike => s.grbl_like.junction_deviation_mm = tolerance_mm,
            Method::Blend => s.blend.tolerance_mm = tolerance_mm,
            _ => {}
        }
        s
    }
}

/// Per-axis limits the tick-stream baselines plan with (the machine's, from
/// `[planner]`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisLimits {
    /// Acceleration of X, Y, Z, mm/s².
    pub accel_mm_per_s2: [f64; 3],
    /// Speed of X, Y, Z, mm/s.
    pub speed_mm_per_s: [f64; 3],
}

impl AxisLimits {
    /// The limits of fuzzy-core's planner settings.
    pub fn of(p: &crate::planner::PlannerSettings) -> Self {
        AxisLimits {
            accel_mm_per_s2: p.axis_accel_max_mm_per_s2.map(f64::from),
            speed_mm_per_s: p.axis_speed_max_mm_per_min.map(|v| v / 60.0),
        }
    }

    /// The largest value along the unit vector `unit` that keeps every axis
    /// within `max` (Grbl's `limit_value_by_axis_maximum`: `min_i
    /// max_i/|u_i|`).
    pub fn along(max: [f64; 3], unit: [f64; 3]) -> f64 {
        (0..3)
            .filter(|&i| unit[i].abs() > 1e-12)
            .map(|i| max[i] / unit[i].abs())
            .fold(f64::MAX, f64::min)
    }
}

/// How Dκ is normalised to `[0, 1]` (Lin et al. section 2.7.1 A).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum VariationNormalisation {
    /// The paper's: by the minimum and maximum Dκ of the path (clipped at
    /// `variation_clip_per_mm`); needs the whole path (offline).
    PerPath,
    /// Fixed range `[0, variation_clip_per_mm]`, as a streaming controller
    /// must (the firmware's).
    Fixed,
}

/// Settings of the fuzzy scheduler.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FuzzySettings {
    /// Minimum feed F_min, mm/min.
    pub f_min_mm_per_min: f64,
    /// Lookahead window WS, points (eq. 10; paper: 30). One of
    /// [`SUPPORTED_WS`].
    pub lookahead_points: usize,
    /// Average filter length, points (section 2.7.2; odd). One of
    /// [`SUPPORTED_AVG`].
    pub average_points: usize,
    /// Dκ normalisation.
    pub variation: VariationNormalisation,
    /// Dκ that counts as "very high" (normalised to 1), 1/mm (paper: 3).
    pub variation_clip_per_mm: f64,
}

impl Default for FuzzySettings {
    fn default() -> Self {
        FuzzySettings {
            f_min_mm_per_min: 60.0,
            lookahead_points: 30,
            average_points: 9,
            variation: VariationNormalisation::PerPath,
            variation_clip_per_mm: 3.0,
        }
    }
}

/// Settings of the chord-error pre-schedule.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ChordErrorSettings {
    /// Chord-error tolerance δ, mm.
    pub tolerance_mm: f64,
    /// Acceleration limit A of the axes, used both for the normal
    /// acceleration `v²κ ≤ A` and for the tangential passes, mm/s².
    pub max_acceleration_mm_per_s2: f64,
    /// Minimum feed, mm/min.
    pub f_min_mm_per_min: f64,
}

impl Default for ChordErrorSettings {
    fn default() -> Self {
        ChordErrorSettings {
            tolerance_mm: 0.001,
            max_acceleration_mm_per_s2: 2000.0,
            f_min_mm_per_min: 60.0,
        }
    }
}

/// Lookahead windows the host tools are compiled for (a const generic in
/// fuzzy-core).
pub const SUPPORTED_WS: [usize; 6] = [10, 20, 30, 40, 60, 90];
/// Average-filter lengths the host tools are compiled for.
pub const SUPPORTED_AVG: [usize; 6] = [1, 5, 9, 15, 21, 31];

/// A schedule: the feed of each block and what the fuzzy scheduler saw.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Schedule {
    /// Feed of the block ending at each point, mm/min (index 0: the feed at
    /// the start point, unused by the interpolator).
    pub feeds_mm_per_min: Vec<f64>,
    /// κ at each point, 1/mm (fuzzy-core, eq. 9).
    pub curvature_per_mm: Vec<f64>,
    /// Dκ at each point, 1/mm (fuzzy-core, eq. 10).
    pub variation_per_mm: Vec<f64>,
}

fn run_scheduler<const WS: usize, const AVG: usize, const CAP: usize>(
    path: &Toolpath,
    config: SchedulerConfig,
) -> Result<Vec<ScheduledPoint>> {
    let mut s: Scheduler<_, WS, AVG, CAP> =
        Scheduler::new(&CONTROLLER, config).map_err(|e| anyhow::anyhow!("{e}"))?;
    let mut out = Vec::with_capacity(path.len());
    s.run(path.path_points(), |p| out.push(p))
        .map_err(|(i, e)| anyhow::anyhow!("line {}: {e}", path.lines[i]))?;
    if out.len() != path.len() {
        bail!(
            "scheduler returned {} points for {} (duplicates should have been removed)",
            out.len(),
            path.len()
        );
    }
    Ok(out)
}

macro_rules! dispatch {
    ($ws:expr, $avg:expr, $path:expr, $cfg:expr; $($w:literal),*; $($a:literal),*) => {
        dispatch!(@ws $ws, $avg, $path, $cfg; [$($w),*]; [$($a),*])
    };
    (@ws $ws:expr, $avg:expr, $path:expr, $cfg:expr; [$($w:literal),*]; $avgs:tt) => {
        match $ws {
            $( $w => dispatch!(@avg $w, $avg, $path, $cfg; $avgs), )*
            other => bail!("lookahead of {other} points not supported (one of {:?})", SUPPORTED_WS),
        }
    };
    (@avg $w:literal, $avg:expr, $path:expr, $cfg:expr; [$($a:literal),*]) => {
        match $avg {
            $( $a => run_scheduler::<$w, $a, { $w + $a / 2 + 2 }>($path, $cfg), )*
            other => bail!("average filter of {other} points not supported (one of {:?})", SUPPORTED_AVG),
        }
    };
}

/// Run fuzzy-core's scheduler over `path` with `WS = ws`, `AVG = avg`.
pub fn run_fuzzy_core(
    path: &Toolpath,
    config: SchedulerConfig,
    ws: usize,
    avg: usize,
) -> Result<Vec<ScheduledPoint>> {
    dispatch!(ws, avg, path, config; 10, 20, 30, 40, 60, 90; 1, 5, 9, 15, 21, 31)
}

/// Lin et al.'s scheduler (fuzzy-core) with `f_max`; `filtered = false`
/// runs it with AVG = 1.
pub fn fuzzy_schedule(
    path: &Toolpath,
    f_max_mm_per_min: f64,
    settings: &FuzzySettings,
    filtered: bool,
) -> Result<Schedule> {
    let avg = if filtered { settings.average_points } else { 1 };
    let clip = CurvaturePerMm::from_f64(settings.variation_clip_per_mm);
    let mut config = SchedulerConfig {
        f_max: FeedMmPerMin::from_f64(f_max_mm_per_min),
        f_min: FeedMmPerMin::from_f64(settings.f_min_mm_per_min.min(f_max_mm_per_min)),
        variation: VariationScale {
            floor: CurvaturePerMm::ZERO,
            clip,
        },
    };
    let mut out = run_fuzzy_core(path, config, settings.lookahead_points, avg)?;
    if settings.variation == VariationNormalisation::PerPath {
        // The paper normalises Dκ by its minimum and maximum over the path:
        // a first pass finds them (Dκ does not depend on the scale).
        let (lo, hi) = out.iter().fold(
            (CurvaturePerMm::MAX, CurvaturePerMm::ZERO),
            |(lo, hi), p| (lo.min(p.variation), hi.max(p.variation)),
        );
        let scale = VariationScale::for_path(lo, hi.min(clip));
        if scale.is_valid() {
            config.variation = scale;
            out = run_fuzzy_core(path, config, settings.lookahead_points, avg)?;
        }
    }
    let mut s = Schedule::default();
    for p in &out {
        s.feeds_mm_per_min.push(p.feed.to_f64());
        s.curvature_per_mm.push(p.curvature.to_f64());
        s.variation_per_mm.push(p.variation.to_f64());
    }
    Ok(s)
}

/// Chord-error pre-schedule: at each point `v ≤ (2/Ts)·√(2δ/κ − δ²)` (the
/// chord of one interpolation period on a circle of radius `1/κ` stays
/// within `δ` of the arc; Yeh & Hsu 2002), `v ≤ √(A/κ)` (normal
/// acceleration), `F_min ≤ v ≤ min(F_max, programmed F)`; then a backward
/// and a forward pass so that `v²` changes by at most `2·A·Δs` between
/// points (Luan et al.'s pre-schedule). The ends are not forced to rest:
/// the machine's own acc/dec starts and stops the tool.
pub fn chord_error_schedule(
    path: &Toolpath,
    f_max_mm_per_min: f64,
    ts_s: f64,
    settings: &ChordErrorSettings,
    curvature_per_mm: &[f64],
) -> Schedule {
    let n = path.len();
    let delta = settings.tolerance_mm;
    let a = settings.max_acceleration_mm_per_s2;
    let f_min = settings.f_min_mm_per_min.min(f_max_mm_per_min) / 60.0;
    let mut v: Vec<f64> = (0..n)
        .map(|i| {
            let k = curvature_per_mm[i].abs();
            let mut lim = f_max_mm_per_min / 60.0;
            if let Some(cap) = path.feed_caps[i] {
                lim = lim.min(cap / 60.0);
            }
            if k > 0.0 {
                let r2 = 2.0 * delta / k - delta * delta;
                let chord = if r2 > 0.0 {
                    2.0 / ts_s * r2.sqrt()
                } else {
                    0.0
                };
                lim = lim.min(chord).min((a / k).sqrt());
            }
            lim.max(f_min)
        })
        .collect();
    for i in (0..n - 1).rev() {
        let ds = path.block_length_mm(i + 1);
        v[i] = v[i].min((v[i + 1] * v[i + 1] + 2.0 * a * ds).sqrt());
    }
    for i in 1..n {
        let ds = path.block_length_mm(i);
        v[i] = v[i].min((v[i - 1] * v[i - 1] + 2.0 * a * ds).sqrt());
    }
    Schedule {
        feeds_mm_per_min: v.into_iter().map(|x| x * 60.0).collect(),
        curvature_per_mm: curvature_per_mm.to_vec(),
        variation_per_mm: vec![],
    }
}

/// Settings of every method.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MethodSettings {
    /// The fuzzy scheduler.
    pub fuzzy: FuzzySettings,
    /// The chord-error pre-schedule.
    pub chord_error: ChordErrorSettings,
    /// Grbl 1.1's planner.
    pub grbl_like: grbl_like::GrblSettings,
    /// LinuxCNC's blending planner.
    pub blend: blend::BlendSettings,
}

/// The programmed feed of the block ending at each point: its F word capped
/// by `f_max`, mm/min.
fn programmed_feeds(path: &Toolpath, f_max_mm_per_min: f64) -> Vec<f64> {
    path.feed_caps
        .iter()
        .map(|c| c.map_or(f_max_mm_per_min, |c| c.min(f_max_mm_per_min)))
        .collect()
}

/// Schedule `path` with `method` at maximum feed `f_max_mm_per_min`;
/// `ts_s` is the interpolation period (for the chord-error bound).
pub fn schedule(
    method: Method,
    path: &Toolpath,
    f_max_mm_per_min: f64,
    ts_s: f64,
    settings: &MethodSettings,
) -> Result<Schedule> {
    if !(f_max_mm_per_min.is_finite() && f_max_mm_per_min > 0.0 && f_max_mm_per_min <= 1e6) {
        bail!("maximum feed {f_max_mm_per_min} mm/min outside (0, 1e6]");
    }
    match method {
        Method::Fuzzy | Method::FuzzyPlanner => {
            fuzzy_schedule(path, f_max_mm_per_min, &settings.fuzzy, true)
        }
        Method::FuzzyNoFilter => fuzzy_schedule(path, f_max_mm_per_min, &settings.fuzzy, false),
        Method::GrblLike | Method::Blend => Ok(Schedule {
            // Their planners need no curvature.
            feeds_mm_per_min: programmed_feeds(path, f_max_mm_per_min),
            ..Default::default()
        }),
        Method::Constant | Method::ChordError | Method::Planner => {
            // The curvature comes from fuzzy-core's scheduler (any settings).
            let probe = fuzzy_schedule(
                path,
                f_max_mm_per_min,
                &FuzzySettings {
                    variation: VariationNormalisation::Fixed,
                    ..settings.fuzzy.clone()
                },
                false,
            )?;
            if method != Method::ChordError {
                return Ok(Schedule {
                    feeds_mm_per_min: programmed_feeds(path, f_max_mm_per_min),
                    ..probe
                });
            }
            Ok(Schedule {
                variation_per_mm: probe.variation_per_mm.clone(),
                ..chord_error_schedule(
                    path,
                    f_max_mm_per_min,
                    ts_s,
                    &settings.chord_error,
                    &probe.curvature_per_mm,
                )
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn circle(r: f64, n: usize) -> Toolpath {
        Toolpath::from_points(
            "circle",
            (0..n)
                .map(|i| {
                    let t = i as f64 / n as f64 * std::f64::consts::PI;
                    [r * t.cos(), r * t.sin(), 0.0]
                })
                .collect(),
        )
        .unwrap()
    }

    #[test]
    fn chord_error_bound_matches_its_formula() {
        // R = 2 mm, δ = 1 µm, Ts = 1 ms: v = 2000·√(2·0.001·2 − 1e-6) mm/s,
        // and √(A·R) = √4000 = 63.2 mm/s is the tighter one.
        let p = circle(2.0, 400);
        let s = schedule(Method::ChordError, &p, 10_000.0, 0.001, &Default::default()).unwrap();
        let mid = s.feeds_mm_per_min[200] / 60.0;
        assert!((mid - 4000f64.sqrt()).abs() < 0.5, "{mid}");
        let loose = ChordErrorSettings {
            max_acceleration_mm_per_s2: 1e9,
            ..Default::default()
        };
        let s = chord_error_schedule(&p, 1e6, 0.001, &loose, &vec![0.5; 400]);
        let v = 2000.0 * (2.0 * 0.001 / 0.5 - 1e-6f64).sqrt();
        assert!((s.feeds_mm_per_min[200] / 60.0 - v).abs() < 1e-9);
    }

    #[test]
    fn every_method_gives_a_positive_feed_per_point_within_f_max() {
        let p = circle(5.0, 300);
        for m in Method::ALL {
            let s = schedule(m, &p, 3000.0, 0.001, &Default::default()).unwrap();
            assert_eq!(s.feeds_mm_per_min.len(), p.len(), "{m:?}");
            assert!(
                s.feeds_mm_per_min
                    .iter()
                    .all(|f| *f > 0.0 && *f <= 3000.0 + 1e-6),
                "{m:?}"
            );
        }
    }

    #[test]
    fn unsupported_windows_are_refused() {
        let p = circle(5.0, 50);
        let s = FuzzySettings {
            lookahead_points: 7,
            ..Default::default()
        };
        assert!(fuzzy_schedule(&p, 3000.0, &s, true).is_err());
        for ws in SUPPORTED_WS {
            for avg in SUPPORTED_AVG {
                let s = FuzzySettings {
                    lookahead_points: ws,
                    average_points: avg,
                    ..Default::default()
                };
                assert_eq!(
                    fuzzy_schedule(&p, 3000.0, &s, true)
                        .unwrap()
                        .feeds_mm_per_min
                        .len(),
                    50
                );
            }
        }
    }

    #[test]
    fn fuzzy_matches_fuzzy_cores_f64_reference() {
        // Host-sim adds nothing to the scheduler: its feeds agree with the
        // f64 pipeline of fuzzy-core within the core's documented accuracy.
        let p = circle(3.0, 200);
        let settings = FuzzySettings {
            variation: VariationNormalisation::Fixed,
            ..Default::default()
        };
        let s = fuzzy_schedule(&p, 3000.0, &settings, true).unwrap();
        let cfg = SchedulerConfig::new(FeedMmPerMin::from_int(3000), FeedMmPerMin::from_int(60));
        let r = fuzzy_core::reference::schedule(
            &p.points,
            &vec![None; p.len()],
            &fuzzy_core::lin2021::SYSTEM,
            &cfg,
            30,
            9,
        );
        for (a, b) in s.feeds_mm_per_min.iter().zip(&r) {
            assert!((a - b.feed).abs() < 0.0025 * 3000.0, "{a} vs {}", b.feed);
        }
    }
}
