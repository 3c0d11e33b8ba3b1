//! The firmware's planned motion, recomputed on the host and checked.
//!
//! The firmware reports every input its velocity planner takes with the
//! number of setpoints it had generated before ([`PlanLog`]: points through
//! `DeviceMsg::Scheduled`, end of path, hold, resume and override through
//! `DeviceMsg::Planned`), and in each status a checksum of every setpoint
//! generated since boot. [`replay`] feeds the same inputs at the same ticks
//! into the controller's own planning stage (`controller::planning`, the
//! code the firmware runs) on the host. Then:
//! - [`Replayed::check_statuses`]: the firmware's checksum equals the
//!   host's at every status received (the motion is the same bit for bit),
//!   and the executed position equals the host's setpoint at the tick
//!   being executed;
//! - [`check_limits`]: the setpoints respect the per-axis speed and
//!   acceleration limits and the tangential acceleration and jerk
//!   (quantisation allowances as in `fuzzy-core/tests/planner.rs`).

use std::collections::HashMap;

use controller::controls::Controls;
use controller::planning::Planning;
use controller::settings::{Plan, Sched};
use fuzzy_core::lin2021::COMPACT;
use fuzzy_core::planner::{MotionConfig, Tick};
use fuzzy_core::scheduler::{PathPoint, ScheduledPoint, SchedulerConfig};
use fuzzy_core::units::Point3Mm;
use link::{PlanEvent, Status};

use crate::firmware::PlanLog;

/// The host's schedule of a path whose points carry sequence numbers
/// `seqs` (the firmware tags each point with its sequence number), by
/// sequence number: the controller's scheduler with its sizes.
pub fn schedule(
    config: SchedulerConfig,
    pts: &[PathPoint],
    seqs: &[u32],
) -> HashMap<u32, ScheduledPoint> {
    let mut s = Sched::new(&COMPACT, config).expect("config");
    let mut out = HashMap::new();
    s.run(
        pts.iter()
            .zip(seqs)
            .map(|(p, seq)| PathPoint { tag: *seq, ..*p }),
        |o| {
            out.insert(o.point.tag, o);
        },
    )
    .expect("schedule");
    out
}

/// A probing move's point as the planner takes it (`HostMsg::Probe`: one
/// straight move at its feed, not scheduled; `Planning::single_move`),
/// for [`replay`]'s points under the probe's sequence number.
pub fn probe_point(seq: u32, target_mm: [i64; 3], feed_bits: i64) -> ScheduledPoint {
    let p = controller::probe::probe_from_link(seq, target_mm, feed_bits, true, true)
        .expect("a probe the controller takes");
    let (pos, feed) = (p.target, p.feed);
    ScheduledPoint {
        point: PathPoint {
            pos,
            feed_cap: Some(feed),
            tag: seq,
        },
        index: 1,
        curvature: fuzzy_core::units::CurvaturePerMm::ZERO,
        variation: fuzzy_core::units::CurvaturePerMm::ZERO,
        fraction: fuzzy_core::units::Fx::ZERO,
        fuzzy_feed: feed,
        feed,
        fired: false,
    }
}

/// The host's planner run over the firmware's inputs.
pub struct Replayed {
    /// Every generated tick, from boot.
    pub ticks: Vec<Tick>,
    /// `checksums[k]`: of the first `k` ticks' positions, folded to 32 bits.
    pub checksums: Vec<u32>,
    /// The tangential acceleration limit, mm/s².
    pub accel_mm_s2: f64,
}

/// Replay `log` (every input of the firmware's planner since boot, in
/// order) with the points of `points` (by sequence number) until `upto`
/// ticks are generated: the controller's planning stage, started at rest
/// at the origin as the firmware's, each input given at the tick the
/// firmware took it. A point the host's planner would not take at that
/// tick is a failure.
pub fn replay(
    config: MotionConfig,
    points: &HashMap<u32, ScheduledPoint>,
    log: &[PlanLog],
    upto: u32,
) -> Replayed {
    let mut m: Box<Plan> = Box::new(Plan::new(config).expect("planner settings"));
    let accel_mm_s2 = m.accel_limit_mm_s2().to_num::<f64>();
    let mut p = Planning::new(&mut m, Point3Mm::ORIGIN).expect("start at rest");
    let mut path_config = config;
    let mut r = Replayed {
        ticks: Vec::new(),
        checksums: vec![p.checksum().folded()],
        accel_mm_s2,
    };
    let gen = |p: &mut Planning, r: &mut Replayed| {
        r.ticks.push(p.generate());
        r.checksums.push(p.checksum().folded());
    };
    for (k, e) in log.iter().enumerate() {
        assert!(
            e.tick() >= p.generated(),
            "planner input {k} ({e:?}) at tick {} before the previous one's tick {}",
            e.tick(),
            p.generated()
        );
        while p.generated() < e.tick() {
            gen(&mut p, &mut r);
        }
        match *e {
            PlanLog::Point { seq, .. } => {
                let s = points
                    .get(&seq)
                    .unwrap_or_else(|| panic!("point seq {seq} not scheduled on the host"));
                let took = p.take_point(s);
                assert!(
                    matches!(took, Ok(Some(_))),
                    "seq {seq}: the host planner did not take it at tick {}: {took:?}",
                    e.tick()
                );
            }
            PlanLog::Event { event, .. } => {
                let c = |hold, override_percent| Controls {
                    hold,
                    override_percent,
                    ..Controls::default()
                };
                match event {
                    PlanEvent::EndPath => {
                        p.end_path();
                    }
                    PlanEvent::Hold => {
                        p.apply(c(Some(true), None));
                    }
                    PlanEvent::Resume => {
                        p.apply(c(Some(false), None));
                    }
                    PlanEvent::Override(pct) => {
                        p.apply(c(None, Some(pct)));
                    }
                    PlanEvent::Abort => {
                        p.abort();
                    }
                    PlanEvent::Reset { pos_mm } => {
                        let pos = Point3Mm::from_bits(pos_mm[0], pos_mm[1], pos_mm[2]);
                        p.reset(path_config, pos).expect("the firmware's settings");
                    }
                    PlanEvent::PathControl {
                        pos_mm,
                        chord_nm,
                        smoothing_ticks,
                        exact,
                    } => {
                        // A program's path control: its settings in place
                        // of the machine's from here on.
                        path_config = controller::config::PathSettings {
                            chord_nm,
                            smoothing_ticks,
                            exact,
                        }
                        .apply(config);
                        let pos = Point3Mm::from_bits(pos_mm[0], pos_mm[1], pos_mm[2]);
                        p.reset(path_config, pos).expect("the firmware's settings");
                    }
                }
            }
        }
    }
    while p.generated() < upto {
        gen(&mut p, &mut r);
    }
    r
}

impl Replayed {
    /// The firmware's statuses against the host's run: the checksum of the
    /// generated setpoints and the position being executed, bit for bit.
    /// Returns how many statuses were compared.
    pub fn check_statuses(&self, name: &str, statuses: &[Status]) -> usize {
        self.check_checksums(name, statuses);
        for (k, s) in statuses.iter().enumerate() {
            let executed = s.ticks.wrapping_sub(s.empty_ticks) as usize;
            let want = match executed {
                0 => Point3Mm::ORIGIN,
                n => self.ticks[n - 1].pos,
            };
            assert_eq!(
                s.pos_mm,
                want.to_bits(),
                "{name}: status {k}: position at executed tick {executed}"
            );
        }
        statuses.len()
    }

    /// The firmware's checksums against the host's only (after an alarm or
    /// a homing cycle the executed ticks no longer map onto the generated
    /// ones: setpoints were dropped unexecuted). Returns how many statuses
    /// were compared.
    pub fn check_checksums(&self, name: &str, statuses: &[Status]) -> usize {
        for (k, s) in statuses.iter().enumerate() {
            let g = s.generated_ticks as usize;
            assert!(g < self.checksums.len(), "{name}: replay too short");
            assert_eq!(
                s.positions_checksum, self.checksums[g],
                "{name}: status {k}: the firmware's setpoints differ from the host's within the first {g} ticks"
            );
        }
        statuses.len()
    }

    /// The host's setpoint positions from tick `from` on.
    pub fn positions(&self, from: usize) -> impl Iterator<Item = [f64; 3]> + '_ {
        self.ticks[from..].iter().map(|t| {
            let b = t.pos.to_bits();
            b.map(|c| c as f64 / 4294967296.0)
        })
    }
}

/// Peak ratios to the limits of a run of setpoints.
#[derive(Clone, Copy, Debug, Default)]
pub struct Peaks {
    /// Per-axis speed / limit.
    pub axis_vel: f64,
    /// Per-axis acceleration (second difference of positions) / limit.
    pub axis_acc: f64,
    /// Tangential acceleration / the planner's limit.
    pub tang_acc: f64,
    /// Tangential jerk (third difference of the arc length) / limit.
    pub jerk: f64,
    /// Largest tangential speed, mm/min.
    pub feed_max: f64,
    /// Tick (index in the slice) where the jerk peaks.
    pub jerk_at: usize,
    /// Jerk / limit of the last step of a stop onto its point (excluded
    /// from `jerk`: the planner arrives at creep speed, at most `J·Ts²/2`,
    /// and steps onto the point; `fuzzy_core::planner` docs).
    pub stop_step_jerk: f64,
}

/// Peaks of `ticks` against `config`'s limits (`accel_mm_s2`: the
/// tangential limit).
pub fn peaks(ticks: &[Tick], config: &MotionConfig, accel_mm_s2: f64) -> Peaks {
    let ts = config.tick_us as f64 * 1e-6;
    let q = 4294967296.0;
    let pos: Vec<[f64; 3]> = ticks
        .iter()
        .map(|t| t.pos.to_bits().map(|c| c as f64 / q))
        .collect();
    let mut p = Peaks::default();
    // Axis k of three positions in a row.
    #[allow(clippy::needless_range_loop)]
    for w in pos.windows(2) {
        for k in 0..3 {
            let v = (w[1][k] - w[0][k]).abs() / ts;
            p.axis_vel = p
                .axis_vel
                .max(v / (config.axis_speed_max[k].to_f64() / 60.0));
        }
    }
    #[allow(clippy::needless_range_loop)]
    for w in pos.windows(3) {
        for k in 0..3 {
            let a = (w[2][k] - 2.0 * w[1][k] + w[0][k]).abs() / (ts * ts);
            p.axis_acc = p.axis_acc.max(a / config.axis_accel_max_mm_s2[k] as f64);
        }
    }
    for w in ticks.windows(2) {
        let dv = (w[1].speed.to_bits() - w[0].speed.to_bits()) as f64 / q / (ts * ts);
        p.tang_acc = p.tang_acc.max(dv.abs() / accel_mm_s2);
    }
    // Creep speed J·Ts²/2 in mm/tick, raw Q32.
    let creep = config.jerk_max_mm_s3 as f64 * ts * ts * ts / 2.0 * q;
    for (k, w) in ticks.windows(4).enumerate() {
        let s: Vec<f64> = w.iter().map(|t| t.s_mm.to_num::<f64>()).collect();
        // Only within one path (the arc length restarts at a new path).
        if s[0] <= s[1] && s[1] <= s[2] && s[2] <= s[3] {
            let d3 = s[3] - 3.0 * s[2] + 3.0 * s[1] - s[0];
            let j = d3.abs() / (ts * ts * ts) / config.jerk_max_mm_s3 as f64;
            let step_on = w[1..].windows(2).any(|v| {
                let (v0, v1) = (v[0].speed.to_bits(), v[1].speed.to_bits());
                v1 == 0 && v0 > 0 && v0 as f64 <= creep
            });
            if step_on {
                p.stop_step_jerk = p.stop_step_jerk.max(j);
            } else if j > p.jerk {
                p.jerk = j;
                p.jerk_at = k;
            }
        }
    }
    for t in ticks {
        p.feed_max = p.feed_max.max(t.speed.to_mm_per_s_f64(ts) * 60.0);
    }
    p
}

/// Assert every limit (quantisation allowances: positions are exact to
/// 2⁻³² mm, so a k-th difference to 2^k quanta).
pub fn check_limits(name: &str, p: &Peaks, config: &MotionConfig) {
    let ts = config.tick_us as f64 * 1e-6;
    let q = 2f64.powi(-32);
    let amin = *config.axis_accel_max_mm_s2.iter().min().unwrap_or(&1) as f64;
    let acc_tol = 4.0 * q / (ts * ts) / amin + 1e-9;
    let jerk_tol = 8.0 * q / (ts * ts * ts) / config.jerk_max_mm_s3 as f64 + 1e-6;
    assert!(p.axis_vel <= 1.0 + 1e-9, "{name}: axis speed {p:?}");
    assert!(
        p.axis_acc <= 1.0 + acc_tol,
        "{name}: axis acceleration {p:?}"
    );
    assert!(
        p.tang_acc <= 1.0 + 1e-6,
        "{name}: tangential acceleration {p:?}"
    );
    assert!(p.jerk <= 1.0 + jerk_tol, "{name}: tangential jerk {p:?}");
}
