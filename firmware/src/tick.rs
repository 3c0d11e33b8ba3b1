//! The tick interrupt's work: the inputs read, alarms and stops
//! ([`controller::guard`]), the next setpoint to the step output
//! ([`controller::tick`]), the driver enable, the step lag checked, step
//! settings written at rest applied once the last steps are out, and the
//! tick's own cost kept ([`TickExecutor::worst_cycles`]).

use controller::alarm::Latch;
use controller::guard::Guard;
use controller::planning::Setpoint;
use controller::ring::Consumer;
use controller::settings::SETPOINT_RING;
use controller::steps::StepSettings;
use controller::tick::TickExecutor;
use rtic::Mutex;

use crate::board::{Enable, Inputs};
use crate::measure;
use crate::step_output::{self, StepIsr, Steps};

/// What only the tick uses.
pub struct Tick {
    setpoints: Consumer<'static, Setpoint, SETPOINT_RING>,
    steps: Steps,
    guard: Guard,
    inputs: Inputs,
    enable: Enable,
    latch: &'static Latch,
}

impl Tick {
    /// Setpoints from `setpoints` to `steps`; the inputs, the drivers'
    /// enable, the alarm state in `latch`.
    pub fn new(
        setpoints: Consumer<'static, Setpoint, SETPOINT_RING>,
        steps: Steps,
        inputs: Inputs,
        enable: Enable,
        latch: &'static Latch,
    ) -> Self {
        Tick {
            setpoints,
            steps,
            guard: Guard::new(),
            inputs,
            enable,
            latch,
        }
    }

    /// One tick period; `pending`: step settings from the background, `isr`
    /// the step interrupt's state (locked only to apply them).
    pub fn run(
        &mut self,
        exec: &mut impl Mutex<T = TickExecutor>,
        pending: &mut impl Mutex<T = Option<StepSettings>>,
        isr: &mut impl Mutex<T = StepIsr>,
    ) {
        let t0 = measure::cycles_in_period();
        let latch = self.latch;
        let raw = self.inputs.read();
        // The step timer alone is above the tick: no actual lock.
        exec.lock(|e| {
            let on = self
                .guard
                .tick(raw, latch, e, &mut self.setpoints, &mut self.steps);
            self.enable.set(on, latch.guard_config().enable_invert);
            self.guard.check_lag(latch, &e.steps);
            let share = measure::permille_of_period(step_output::take_isr_cycles());
            e.worst_step_isr_permille = e.worst_step_isr_permille.max(share);
            pending.lock(|p| {
                let Some(s) = *p else {
                    return;
                };
                if self.guard.apply_step_settings(p, latch, e, &mut self.steps) {
                    isr.lock(|i| step_output::reconfigure_isr(i, &s, &self.steps));
                }
            });
            // From entry to here (the wake-up latency is not the tick's
            // cost, and under QEMU's -icount it depends on host timing).
            e.worst_cycles = e.worst_cycles.max(measure::cycles_in_period_since(t0));
        });
        measure::count_tick();
    }
}
