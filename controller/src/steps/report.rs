//! What the step engine reports: steps it could not emit within their
//! tick (lag) and ticks it had to run without a plan, as counters the
//! engine (timer interrupt) writes and the tick reads without a lock.

use core::sync::atomic::{AtomicU32, Ordering};

/// The engine's counters, shared between the step timer interrupt (writer)
/// and the tick (reader).
#[derive(Debug, Default)]
pub struct StepShared {
    lag_ticks: AtomicU32,
    lag_max_steps: AtomicU32,
    lag_now_steps: AtomicU32,
    late_windows: AtomicU32,
    filtered_pairs: AtomicU32,
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
        }
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
