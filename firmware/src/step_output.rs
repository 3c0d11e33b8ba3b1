//! The step output's wiring: the tick's side ([`Steps`]) and, on a board,
//! the step timer's interrupt ([`StepIsr`]) around the `controller` step
//! engine ([`controller::steps`]), built from the `$` settings.
//!
//! On a board the tick queues each tick's step plan and TIM2's compare
//! interrupt runs the engine; under QEMU, whose TIM2 raises no compare
//! match (see [`crate::board`]), the tick runs the engine itself over its
//! window ([`controller::stepper::SoftSteps`]).
//!
//! Step settings written at rest are applied by the tick
//! ([`controller::guard::Guard::apply_step_settings`]): its planner
//! anew, then the engine, on a board with the step interrupt held off
//! for the moment ([`reconfigure_isr`]).

use controller::config::Config;
use controller::stepper::first_window;
#[cfg(not(feature = "qemu"))]
use controller::stepper::StepPins;
use controller::stepper::StepQueue;
#[cfg(not(feature = "qemu"))]
use controller::steps::Due;
use controller::steps::{
    PlanQueue, Planner, StepConfigError, StepEngine, StepSettings, StepShared,
};
use fuzzy_core::units::Point3Mm;

use crate::board::{StepGpio, StepTimer};
#[cfg(not(feature = "qemu"))]
use crate::measure;
#[cfg(not(feature = "qemu"))]
use core::sync::atomic::{AtomicU32, Ordering};

/// The tick's step output.
#[cfg(not(feature = "qemu"))]
pub type Steps = StepQueue<'static>;
/// The tick's step output.
#[cfg(feature = "qemu")]
pub type Steps = controller::stepper::SoftSteps<'static, StepGpio>;

/// The step timer's interrupt: the engine, the timer, the pins and the
/// batch armed.
#[cfg(not(feature = "qemu"))]
pub struct StepIsr {
    engine: StepEngine<'static>,
    timer: StepTimer,
    pins: StepGpio,
    pending: Due,
}

/// Nothing: the tick runs the engine.
#[cfg(feature = "qemu")]
pub type StepIsr = ();

/// The step output at the origin with `config`'s step settings, plans
/// through `plans`, figures through `shared`. The first tick must come one
/// tick period after this call (SysTick started right after it): the
/// engine's first window starts 1.5 ticks after that
/// ([`controller::steps::engine`]).
pub fn start(
    config: &Config,
    plans: &'static mut PlanQueue,
    shared: &'static StepShared,
    pins: StepGpio,
    timer: StepTimer,
) -> Result<(Steps, StepIsr), StepConfigError> {
    let StepSettings {
        timing,
        steps_per_mm,
    } = config.step_settings()?;
    let (plan_tx, plan_rx) = plans.split();
    let planner = Planner::new(steps_per_mm, &timing, Point3Mm::ORIGIN);
    let start = planner.position();
    let queue = StepQueue::new(planner, plan_tx, shared);
    #[cfg(not(feature = "qemu"))]
    {
        let mut pins = pins;
        let mut timer = timer;
        let first = first_window(timer.now().wrapping_add(timing.window), timing.window);
        let mut engine = StepEngine::new(timing, plan_rx, shared, start, first);
        pins.write(engine.idle_edges());
        let pending = engine.due();
        // Half a tick ahead: armed in time (else the interrupt is late,
        // and the engine keeps every minimum all the same).
        let _ = timer.arm(pending.at);
        let isr = StepIsr {
            engine,
            timer,
            pins,
            pending,
        };
        Ok((queue.with_kick(StepTimer::kick), isr))
    }
    #[cfg(feature = "qemu")]
    {
        let _ = timer;
        let engine = StepEngine::new(
            timing,
            plan_rx,
            shared,
            start,
            first_window(0, timing.window),
        );
        Ok((controller::stepper::SoftSteps::new(queue, engine, pins), ()))
    }
}

/// Cycles the step interrupt took since the tick last asked (written by
/// it alone: the tick's swap retries if the interrupt comes between its
/// exclusive load and store).
#[cfg(not(feature = "qemu"))]
static ISR_SINCE: AtomicU32 = AtomicU32::new(0);

/// The cycles the step interrupt took since the last call (the tick asks
/// once a period), each call from its first instruction to its last (the
/// entry and exit, about 12 cycles each, not counted). 0 under QEMU (the
/// tick runs the engine).
pub fn take_isr_cycles() -> u32 {
    #[cfg(not(feature = "qemu"))]
    {
        ISR_SINCE.swap(0, Ordering::Relaxed)
    }
    #[cfg(feature = "qemu")]
    {
        0
    }
}

#[cfg(not(feature = "qemu"))]
impl StepIsr {
    /// The step timer's compare interrupt ([`Self::step`]), its cycles
    /// counted ([`take_isr_cycles`]).
    #[inline]
    pub fn on_interrupt(&mut self) {
        let t0 = measure::cycles_in_period();
        self.step();
        let c = measure::cycles_in_period_since(t0);
        let since = ISR_SINCE.load(Ordering::Relaxed);
        ISR_SINCE.store(since.saturating_add(c), Ordering::Relaxed);
    }

    /// A stop (or resume) the tick
    /// asked for first, then the edges due now, then the next batch. Pins
    /// first, so that every edge follows its compare match by the same
    /// few cycles; the engine is told the counter read after the write
    /// (never earlier than the edges), which keeps every minimum. A batch
    /// already due when the compare is set is written at once (late by
    /// the engine's own time); a stale interrupt (nothing due yet) only
    /// clears the flag.
    #[inline(always)]
    fn step(&mut self) {
        if self.engine.poll_halt() {
            self.pending = self.engine.due();
            if !self.timer.arm(self.pending.at) {
                return;
            }
        } else if !self.timer.reached(self.pending.at) {
            self.timer.clear();
            return;
        }
        self.pins.write(self.pending.edges);
        loop {
            self.engine.done(self.timer.now());
            self.pending = self.engine.due();
            if !self.timer.arm(self.pending.at) {
                return;
            }
            self.pins.write(self.pending.edges);
        }
    }
}

/// The step interrupt's half of new step settings `s` the tick's half
/// (`steps`) took: the engine rebuilt where the tick's planner now starts,
/// the step pins to their rest levels, the compare armed for the next
/// batch (called from the tick, the step interrupt locked out).
#[cfg(not(feature = "qemu"))]
pub fn reconfigure_isr(isr: &mut StepIsr, s: &StepSettings, steps: &Steps) {
    isr.engine.reconfigure(s.timing, steps.position());
    isr.pins.write(isr.engine.idle_edges());
    isr.pending = isr.engine.due();
    if isr.timer.arm(isr.pending.at) {
        StepTimer::kick();
    }
}

/// Nothing: under QEMU the tick's half ([`Steps`]) holds the engine too.
#[cfg(feature = "qemu")]
pub fn reconfigure_isr(_: &mut StepIsr, _: &StepSettings, _: &Steps) {}
