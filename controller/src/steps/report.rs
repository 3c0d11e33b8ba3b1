//! What the step engine reports: steps it could not emit within their
//! tick (lag) and ticks it had to run without a plan, as counters the
//! engine (timer interrupt) writes and the tick reads without a lock.

use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};

/// The engine's counters, shared between the step timer interrupt (writer)
/// and the tick (reader).
#[derive(Debug, Default)]
pub struct StepShared {
    lag_ticks: AtomicU32,
    lag_max_steps: AtomicU32,
    lag_now_steps: AtomicU32,
    late_windows: AtomicU32,
    filtered_pairs: AtomicU32,
    /// The tick asks the engine to stop (an alarm, a homing switch).
    halt: AtomicBool,
    /// The stop asked for, numbered.
    halt_seq: AtomicU32,
    /// The stop the engine carried out, and where (whole steps, each axis
    /// as low and high word).
    halted_seq: AtomicU32,
    halted_at: [AtomicU32; 6],
}

impl StepShared {
    /// Nothing reported yet.
    pub const fn new() -> Self {
        StepShared {
            lag_ticks: AtomicU32::new(0),
            lag_max_steps: AtomicU32::new(0),
            lag_now_steps: AtomicU32::new(0),
            late_windows: AtomicU32::new(0),
            filtered_pairs: AtomicU32::new(0),
            halt: AtomicBool::new(false),
            halt_seq: AtomicU32::new(0),
            halted_seq: AtomicU32::new(0),
            halted_at: [const { AtomicU32::new(0) }; 6],
        }
    }

    /// (The tick.) Ask the engine to stop; returns the stop's number.
    pub fn request_halt(&self) -> u32 {
        let seq = self.halt_seq.load(Ordering::Relaxed).wrapping_add(1);
        self.halt_seq.store(seq, Ordering::Relaxed);
        self.halt.store(true, Ordering::Release);
        seq
    }

    /// (The tick.) Let the engine take plans again.
    pub fn release(&self) {
        self.halt.store(false, Ordering::Release);
    }

    /// (The engine.) The stop asked for, if any.
    pub fn halt_request(&self) -> Option<u32> {
        self.halt
            .load(Ordering::Acquire)
            .then(|| self.halt_seq.load(Ordering::Relaxed))
    }

    /// (The engine.) Stop `seq` is carried out: the steps stopped at `pos`.
    pub fn ack_halt(&self, seq: u32, pos: [i64; 3]) {
        for (w, p) in self.halted_at.chunks(2).zip(pos) {
            if let [lo, hi] = w {
                lo.store(p as u32, Ordering::Relaxed);
                hi.store((p >> 32) as u32, Ordering::Relaxed);
            }
        }
        self.halted_seq.store(seq, Ordering::Release);
    }

    /// (The tick.) Where the steps stopped, once the engine has carried
    /// out stop `seq`.
    pub fn halted_at(&self, seq: u32) -> Option<[i64; 3]> {
        if self.halted_seq.load(Ordering::Acquire) != seq {
            return None;
        }
        let w = |i: usize| {
            self.halted_at
                .get(i)
                .map_or(0, |a| a.load(Ordering::Relaxed)) as u64
        };
        Some([0, 1, 2].map(|a| (w(2 * a) | w(2 * a + 1) << 32) as i64))
    }

    /// Publish the engine's figures (one writer).
    pub fn publish(&self, r: &StepReport) {
        self.lag_ticks.store(r.lag_ticks, Ordering::Relaxed);
        self.lag_max_steps.store(r.lag_max_steps, Ordering::Relaxed);
        self.lag_now_steps.store(r.lag_now_steps, Ordering::Relaxed);
        self.late_windows.store(r.late_windows, Ordering::Relaxed);
        self.filtered_pairs
            .store(r.filtered_pairs, Ordering::Relaxed);
    }

    /// The figures last published.
    pub fn read(&self) -> StepReport {
        StepReport {
            lag_ticks: self.lag_ticks.load(Ordering::Relaxed),
            lag_max_steps: self.lag_max_steps.load(Ordering::Relaxed),
            lag_now_steps: self.lag_now_steps.load(Ordering::Relaxed),
            late_windows: self.late_windows.load(Ordering::Relaxed),
            filtered_pairs: self.filtered_pairs.load(Ordering::Relaxed),
            plan_overruns: 0,
        }
    }
}

/// The step generator's figures.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StepReport {
    /// Ticks that ended with an axis short of its commanded position (steps
    /// carried to later ticks: the commanded rate exceeded what the pulse
    /// width allows, or a plan was lost).
    pub lag_ticks: u32,
    /// Largest shortfall at a tick's end, steps (any axis).
    pub lag_max_steps: u32,
    /// Shortfall at the last tick's end, steps (largest axis).
    pub lag_now_steps: u32,
    /// Ticks the engine ran without a plan (the tick interrupt was late by
    /// more than half a tick): the motion after it runs a tick later.
    pub late_windows: u32,
    /// Step pairs the reversal filter cancelled.
    pub filtered_pairs: u32,
    /// Plans the tick could not hand to the engine (its queue was full).
    pub plan_overruns: u32,
}

/// A step generation fault, for an alarm layer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StepFault {
    /// Steps were carried past their tick (`lag_ticks` ticks so far,
    /// `lag_max_steps` at worst).
    Lag {
        /// Ticks with lag.
        ticks: u32,
        /// Largest lag, steps.
        max_steps: u32,
    },
    /// The engine ran ticks without a plan.
    LatePlans(u32),
    /// Plans were lost at the hand-over (the engine stopped taking them).
    PlanOverruns(u32),
}

impl StepReport {
    /// Nothing to report.
    pub const NONE: StepReport = StepReport {
        lag_ticks: 0,
        lag_max_steps: 0,
        lag_now_steps: 0,
        late_windows: 0,
        filtered_pairs: 0,
        plan_overruns: 0,
    };

    /// The most serious fault so far, if any.
    pub fn fault(&self) -> Option<StepFault> {
        if self.plan_overruns > 0 {
            Some(StepFault::PlanOverruns(self.plan_overruns))
        } else if self.lag_ticks > 0 {
            Some(StepFault::Lag {
                ticks: self.lag_ticks,
                max_steps: self.lag_max_steps,
            })
        } else if self.late_windows > 0 {
            Some(StepFault::LatePlans(self.late_windows))
        } else {
            None
        }
    }
}
