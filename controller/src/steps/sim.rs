//! The step engine under a simulated step timer (feature `std`): ticks at
//! their times, the engine's batches written when due (or when the
//! simulated interrupt gets to them), every pin edge recorded with its
//! time; and a checker that compares the edges with the ideal trajectory
//! (the setpoints' linear interpolation, in `f64` from the exact
//! `mm × steps/mm`) and with the configured minimums.

use fuzzy_core::units::Point3Mm;

use super::config::{StepsPerMm, Timing};
use super::engine::{Edges, StepEngine};
use super::plan::Planner;
use super::queue::PlanQueue;
use super::report::{StepReport, StepShared};
use crate::stepper::{first_window, StepOutput, StepQueue};

/// How the simulated interrupt behaves, timer counts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Model {
    /// From a batch's due time to its pins written (interrupt entry and
    /// the store).
    pub latency: u32,
    /// From the write to the counter reading handed to `done`.
    pub read_after: u32,
    /// From that reading until the next batch is ready (the engine's own
    /// work); a batch due earlier is written then, late.
    pub busy: u32,
    /// More of it for a window change.
    pub busy_window: u32,
    /// More of it for a plan taken from the queue.
    pub busy_pull: u32,
    /// When the tick hands its plan over, after the tick's start.
    pub tick_delay: u32,
}

impl Model {
    /// A perfect timer and an interrupt that takes no time.
    pub const IDEAL: Model = Model {
        latency: 0,
        read_after: 0,
        busy: 0,
        busy_window: 0,
        busy_pull: 0,
        tick_delay: 0,
    };

    /// The most a write can trail its due time under this model, counts:
    /// due while the interrupt works out one batch, then another with a
    /// window change and a plan taken.
    pub const fn lateness(&self) -> u32 {
        self.latency + 2 * (self.read_after + self.busy) + self.busy_window + self.busy_pull
    }
}

/// Every write of a run.
#[derive(Clone, Debug)]
pub struct Trace {
    /// The settings in counts.
    pub timing: Timing,
    /// Steps per mm per axis.
    pub spm: [StepsPerMm; 3],
    /// Where the run started.
    pub start: Point3Mm,
    /// The setpoints, one a tick.
    pub setpoints: Vec<Point3Mm>,
    /// The first window's start, counts after tick 0.
    pub first_window: u64,
    /// Each write: time (counts after tick 0) and edges.
    pub writes: Vec<(u64, Edges)>,
    /// When window `k` ended for the engine: the write after which its
    /// crossings were all stepped (nothing owed), or its window change if
    /// that came first (steps left over are owed, lag). The next window's
    /// steps come after both.
    pub window_ends: Vec<u64>,
    /// The engine's figures at the end.
    pub report: StepReport,
    /// The interrupt model.
    pub model: Model,
    /// Steps emitted per axis.
    pub position: [i64; 3],
}

/// The setpoints (one a tick, from `start`) through the planner and the
/// engine under `model`, then `extra` ticks holding the last one (the run
/// ends with the window of the last of those).
pub fn run(
    timing: Timing,
    spm: [StepsPerMm; 3],
    start: Point3Mm,
    setpoints: &[Point3Mm],
    extra: usize,
    model: Model,
) -> Trace {
    let mut ring = PlanQueue::new();
    let shared = StepShared::new();
    let (tx, rx) = ring.split();
    let planner = Planner::new(spm, &timing, start);
    let start_steps = planner.position();
    let mut queue = StepQueue::new(planner, tx, &shared);
    let w = timing.window as u64;
    let first = first_window(0, timing.window) as u64;
    let mut engine = StepEngine::new(timing, rx, &shared, start_steps, first as u32);
    let mut writes = vec![(0u64, engine.idle_edges())];
    let mut window_ends = Vec::new();
    let end = first + (setpoints.len() + extra) as u64 * w;
    let (mut k, mut next_tick) = (0usize, model.tick_delay as u64);
    let mut now = first - w;
    let mut cpu_free = 0u64;
    // Window 0 starts with the first window change; `recorded`: the
    // running window's end is in `window_ends`.
    let (mut started, mut recorded) = (false, false);
    let mut taken = engine.plans_taken();
    // After each call into the engine at `t`: the cost of a window change
    // or a plan taken, and where the running window ended.
    let mut after_call = |engine: &StepEngine, t: u64, seen: u32, cpu_free: &mut u64| {
        if engine.window_end() != seen {
            if started && !recorded {
                window_ends.push(t);
            }
            started = true;
            recorded = false;
            *cpu_free += model.busy_window as u64;
        }
        if engine.plans_taken() != taken {
            taken = engine.plans_taken();
            *cpu_free += model.busy_pull as u64;
        }
        if started && !recorded && engine.window_stepped() {
            window_ends.push(t);
            recorded = true;
        }
    };
    loop {
        let seen = engine.window_end();
        let due = engine.due();
        after_call(&engine, now, seen, &mut cpu_free);
        let rel = due.at.wrapping_sub(now as u32) as i32;
        let due_abs = now + rel.max(0) as u64;
        let write_at = (due_abs + model.latency as u64).max(cpu_free);
        // The tick goes on holding after the setpoints (so that the last
        // window is not counted late).
        if next_tick <= write_at {
            match setpoints.get(k) {
                Some(p) => queue.update(*p),
                None => queue.hold(),
            }
            k += 1;
            next_tick += w;
            continue;
        }
        if write_at > end {
            break;
        }
        writes.push((write_at, due.edges));
        let seen = engine.window_end();
        let read = write_at + model.read_after as u64;
        engine.done(read as u32);
        now = read;
        cpu_free = read + model.busy as u64;
        after_call(&engine, write_at, seen, &mut cpu_free);
    }
    let mut report = engine.report();
    report.plan_overruns = queue.report().plan_overruns;
    Trace {
        timing,
        spm,
        start,
        setpoints: setpoints.to_vec(),
        first_window: first,
        writes,
        window_ends,
        report,
        model,
        position: engine.position(),
    }
}

/// What the checker found (times in timer counts).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Figures {
    /// Rising edges, all axes.
    pub steps: u64,
    /// Largest step rate of an axis over a tick, Hz.
    pub peak_rate_hz: f64,
    /// Latest step after its ideal time, steps not held by a minimum.
    pub max_late: f64,
    /// When that step was emitted (counts after tick 0) and its axis.
    pub max_late_at: (u64, usize),
    /// Earliest step before its ideal time (positive: early).
    pub max_early: f64,
    /// Steps a minimum held back (the step before, or the direction change
    /// before, was too close to allow it at its ideal time).
    pub held: u32,
    /// Of those, the first steps after a reversal.
    pub held_reversals: u32,
    /// Latest held step after its ideal time.
    pub held_max_late: f64,
    /// Shortest pulse.
    pub min_pulse: u64,
    /// Shortest low time between two pulses.
    pub min_gap: u64,
    /// Shortest time from a DIR change to the next rising edge.
    pub min_setup: u64,
    /// DIR changed while the step pin was active.
    pub dir_while_active: u32,
    /// Steps with DIR never set.
    pub step_without_dir: u32,
    /// Ticks whose end count differs from the commanded position (not
    /// explained by the reversal filter).
    pub tick_end_mismatches: u32,
    /// Tick ends inside a pair the reversal filter cancelled (one step off,
    /// by design).
    pub filtered_tick_ends: u32,
    /// Pairs the reversal filter cancelled (the checker's count).
    pub filtered_pairs: u32,
    /// Emitted steps with no ideal step to match (count or direction).
    pub unmatched: u32,
}

/// `mm × steps/mm` exactly, as `f64` steps, and its floor.
fn exact_steps(bits: i64, spm: StepsPerMm) -> (f64, i64) {
    let p = bits as i128 * spm.0 as i128;
    ((p as f64) / 2f64.powi(48), (p >> 48) as i64)
}

/// An ideal step: time (counts after tick 0), direction, and its window.
#[derive(Clone, Copy, Debug)]
struct Ideal {
    t: f64,
    forward: bool,
}

/// Check a run (module docs).
pub fn check(tr: &Trace) -> Figures {
    let tm = &tr.timing;
    let w = tm.window as f64;
    let mut f = Figures {
        min_pulse: u64::MAX,
        min_gap: u64::MAX,
        min_setup: u64::MAX,
        ..Figures::default()
    };
    for axis in 0..3 {
        let spm = tr.spm[axis];
        let bit = 1u8 << axis;
        // Ideal steps, window by window.
        let mut ideal = Vec::new();
        let mut prev = exact_steps(tr.start.to_bits()[axis], spm);
        let mut ends = Vec::new();
        for (k, p) in tr.setpoints.iter().enumerate() {
            let cur = exact_steps(p.to_bits()[axis], spm);
            let w0 = tr.first_window as f64 + k as f64 * w;
            let (s0, s1) = (prev.0, cur.0);
            let n = (cur.1 - prev.1).unsigned_abs();
            f.peak_rate_hz = f
                .peak_rate_hz
                .max(n as f64 * tm.timer_hz as f64 / tm.window as f64);
            if cur.1 > prev.1 {
                for b in prev.1 + 1..=cur.1 {
                    ideal.push(Ideal {
                        t: w0 + w * (b as f64 - s0) / (s1 - s0),
                        forward: true,
                    });
                }
            } else {
                for b in (cur.1 + 1..=prev.1).rev() {
                    ideal.push(Ideal {
                        t: w0 + w * (s0 - b as f64) / (s0 - s1),
                        forward: false,
                    });
                }
            }
            ends.push(cur.1);
            prev = cur;
        }
        // The reversal filter's pairs (a step, then one back within the
        // filter time, on the engine's rounded-up times), greedily.
        let rounded = |x: &Ideal| {
            let k = ((x.t - tr.first_window as f64) / w).floor();
            let w0 = tr.first_window as f64 + k * w;
            w0 + (x.t - w0).ceil().max(1.0)
        };
        let mut kept = Vec::new();
        let mut cancelled = Vec::new();
        let mut i = 0;
        while i < ideal.len() {
            if tm.filter > 0 && i + 1 < ideal.len() {
                let (a, b) = (ideal[i], ideal[i + 1]);
                if a.forward != b.forward && rounded(&b) - rounded(&a) < tm.filter as f64 {
                    cancelled.push((a.t, b.t));
                    i += 2;
                    continue;
                }
            }
            kept.push(ideal[i]);
            i += 1;
        }
        f.filtered_pairs += cancelled.len() as u32;

        // The pins, write by write.
        let (mut active, mut dir) = (false, None::<bool>);
        let (mut last_rise, mut last_fall, mut last_dir) = (None::<u64>, None::<u64>, None::<u64>);
        let mut dir_since_rise = false;
        let mut rises: Vec<(u64, bool, u64)> = Vec::new(); // time, forward, minimums' bound
        let step_inv = tm.invert_step & bit != 0;
        let dir_inv = tm.invert_dir & bit != 0;
        for &(t, e) in &tr.writes {
            let touched = |b: u8| e.set & b != 0 || e.clear & b != 0;
            let level = |b: u8| e.set & b != 0;
            if touched(bit) && level(bit) == step_inv && active {
                // Falling (to the inactive level).
                active = false;
                if let Some(r) = last_rise {
                    f.min_pulse = f.min_pulse.min(t - r);
                }
                last_fall = Some(t);
            }
            let dir_bit = bit << 3;
            if touched(dir_bit) && t > 0 {
                let d = level(dir_bit) != dir_inv;
                if dir != Some(d) {
                    if active {
                        f.dir_while_active += 1;
                    }
                    dir = Some(d);
                    last_dir = Some(t);
                    dir_since_rise = true;
                }
            }
            if touched(bit) && level(bit) != step_inv && !active && t > 0 {
                active = true;
                if let Some(lf) = last_fall {
                    f.min_gap = f.min_gap.min(t - lf);
                }
                if dir_since_rise {
                    if let Some(ld) = last_dir {
                        f.min_setup = f.min_setup.min(t - ld);
                    }
                }
                dir_since_rise = false;
                let Some(d) = dir else {
                    f.step_without_dir += 1;
                    continue;
                };
                // The earliest time the minimums allowed it.
                let mut bound = 0u64;
                if let Some(lf) = last_fall {
                    bound = bound.max(lf + tm.low as u64);
                }
                if let Some(ld) = last_dir {
                    bound = bound.max(ld + tm.setup as u64);
                }
                rises.push((t, d, bound));
                last_rise = Some(t);
            }
        }
        f.steps += rises.len() as u64;

        // Timing: emitted steps against the kept ideal steps, in order.
        let mut prev_dir = None;
        for (j, &(t, d, bound)) in rises.iter().enumerate() {
            let Some(id) = kept.get(j) else {
                f.unmatched += 1;
                continue;
            };
            if id.forward != d {
                f.unmatched += 1;
                continue;
            }
            let err = t as f64 - id.t;
            let reversal = prev_dir.is_some_and(|p| p != d);
            prev_dir = Some(d);
            // Held: the minimums (low time, direction setup) did not allow
            // it at its ideal time.
            if (bound as f64) > id.t {
                f.held += 1;
                f.held_reversals += reversal as u32;
                f.held_max_late = f.held_max_late.max(err);
            } else {
                if err > f.max_late {
                    f.max_late = err;
                    f.max_late_at = (t, axis);
                }
                f.max_early = f.max_early.max(-err);
            }
        }
        f.unmatched += kept.len().saturating_sub(rises.len()) as u32;

        // The count at every tick end.
        for (k, want) in ends.iter().enumerate() {
            let Some(&at) = tr.window_ends.get(k) else {
                break;
            };
            let got = tr.position_at(axis, at, &rises);
            if got != *want {
                let end = tr.first_window as f64 + (k + 1) as f64 * w;
                let in_pair = cancelled.iter().any(|&(a, b)| a <= end && end < b);
                if in_pair && got.abs_diff(*want) == 1 {
                    f.filtered_tick_ends += 1;
                } else {
                    f.tick_end_mismatches += 1;
                }
            }
        }
    }
    f
}

impl Trace {
    fn position_at(&self, axis: usize, at: u64, rises: &[(u64, bool, u64)]) -> i64 {
        let start = exact_steps(self.start.to_bits()[axis], self.spm[axis]).1;
        start
            + rises
                .iter()
                .take_while(|r| r.0 <= at)
                .map(|r| if r.1 { 1 } else { -1 })
                .sum::<i64>()
    }
}
