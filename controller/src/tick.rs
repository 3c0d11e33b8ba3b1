//! The tick's work: the next setpoint from the ring to the step output
//! (which plans the tick's steps for the step timer), and the counters
//! status replies report.
//!
//! The planner's tick costs too much for an interrupt in the worst case,
//! so, like Grbl's segment buffer (`grbl/stepper.c`, `st_prep_buffer`), the
//! background generates ticks ahead into a ring of setpoints
//! ([`SETPOINT_RING`]` − 1` of them) and the interrupt only takes the next
//! one. Feed hold, resume and override reach the planner from the
//! background, so they take effect after the setpoints already in the
//! ring. An empty ring at a tick (the background fell behind) holds the
//! position and is counted ([`TickExecutor::empty_ticks`]); the step
//! output is told to hold, so that its plans stay one a tick.

use fuzzy_core::planner::MotionState;
use fuzzy_core::units::Point3Mm;

use crate::planning::Setpoint;
use crate::ring::Consumer;
use crate::stepper::StepOutput;
use crate::steps::{StepFault, StepReport};

#[allow(unused_imports)] // for the docs
use crate::settings::SETPOINT_RING;

/// The tick's state and counters (also what status replies report).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TickExecutor {
    /// The setpoint in force.
    pub now: Setpoint,
    /// Ticks since reset.
    pub ticks: u32,
    /// Ticks with the ring empty (position held).
    pub empty_ticks: u32,
    /// Ticks with the tool moving (speed > 0) since the current path began
    /// to move.
    pub moving_ticks: u32,
    /// Worst tick interrupt so far, cycles (set by the caller, who has the
    /// clock).
    pub worst_cycles: u32,
    /// The step timer interrupt's worst share of a tick period, per mille
    /// (set by the caller, who has the clock; 0 where the tick runs the
    /// step engine).
    pub worst_step_isr_permille: u16,
    /// The step generator's figures (lag, late plans), as of this tick.
    pub steps: StepReport,
    /// At rest at a path's start or end: the next motion starts a new count.
    rested: bool,
}

impl TickExecutor {
    /// At rest at `start`.
    pub const fn new(start: Point3Mm) -> Self {
        TickExecutor {
            now: Setpoint::at_rest(start),
            ticks: 0,
            empty_ticks: 0,
            moving_ticks: 0,
            worst_cycles: 0,
            worst_step_isr_permille: 0,
            steps: StepReport::NONE,
            rested: true,
        }
    }

    /// One tick: the next setpoint to the outputs (or, if there is none,
    /// the position held and the miss counted).
    pub fn tick<O: StepOutput>(
        &mut self,
        ring: &mut Consumer<'_, Setpoint, SETPOINT_RING>,
        outputs: &mut O,
    ) {
        self.ticks = self.ticks.wrapping_add(1);
        let Some(sp) = ring.dequeue() else {
            self.empty_ticks = self.empty_ticks.wrapping_add(1);
            self.now.feed_q12 = 0;
            self.now.moving = false;
            outputs.hold();
            self.steps = outputs.report();
            return;
        };
        if matches!(sp.state, MotionState::Idle | MotionState::Done) {
            self.rested = true;
        } else if sp.moving {
            if self.rested {
                self.moving_ticks = 0;
                self.rested = false;
            }
            self.moving_ticks = self.moving_ticks.wrapping_add(1);
        }
        outputs.update(sp.pos);
        self.steps = outputs.report();
        self.now = sp;
    }

    /// A step generation fault (steps carried past their tick, ticks
    /// without a plan, plans lost), for an alarm layer.
    pub fn step_fault(&self) -> Option<StepFault> {
        self.steps.fault()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ring::Ring;

    #[derive(Default)]
    struct Last(Option<Point3Mm>, u32, u32);

    impl StepOutput for Last {
        fn update(&mut self, pos: Point3Mm) {
            self.0 = Some(pos);
            self.1 += 1;
        }
        fn hold(&mut self) {
            self.2 += 1;
        }
        fn report(&self) -> StepReport {
            StepReport {
                lag_ticks: self.1,
                ..StepReport::NONE
            }
        }
    }

    fn sp(x: i64, state: MotionState, moving: bool) -> Setpoint {
        Setpoint {
            pos: Point3Mm::from_bits(x, 0, 0),
            feed_q12: moving as u32 * 4096,
            state,
            moving,
        }
    }

    #[test]
    fn an_empty_ring_holds_the_position_and_is_counted() {
        let mut ring: Ring<Setpoint, SETPOINT_RING> = Ring::new();
        let (mut tx, mut rx) = ring.split();
        let mut e = TickExecutor::new(Point3Mm::ORIGIN);
        let mut out = Last::default();
        tx.enqueue(sp(5, MotionState::Moving, true)).unwrap();
        e.tick(&mut rx, &mut out);
        e.tick(&mut rx, &mut out);
        assert_eq!((e.ticks, e.empty_ticks), (2, 1));
        assert_eq!(out.1, 1, "nothing sent to the axes on an empty tick");
        assert_eq!(out.2, 1, "but the position held");
        assert_eq!(e.steps.lag_ticks, 1, "the step figures are the output's");
        assert_eq!(e.now.pos, Point3Mm::from_bits(5, 0, 0), "held");
        assert_eq!(e.now.feed_q12, 0);
        assert!(!e.now.moving);
    }

    #[test]
    fn step_lag_reaches_the_status_reply() {
        use crate::session::DeviceLink;
        use crate::stepper::{first_window, SoftSteps, StepQueue};
        use crate::steps::{
            Edges, PlanQueue, Planner, StepConfig, StepEngine, StepShared, StepsPerMm,
        };
        struct NoPins;
        impl crate::stepper::StepPins for NoPins {
            fn write(&mut self, _: Edges) {}
        }
        let spm = StepsPerMm::from_int(1000);
        let timing = StepConfig::new(spm).timing(84_000_000, 1000).unwrap();
        let (mut plans, shared) = (PlanQueue::new(), StepShared::new());
        let (tx, rx) = plans.split();
        let planner = Planner::new([spm; 3], &timing, Point3Mm::ORIGIN);
        let start = planner.position();
        let engine = StepEngine::new(timing, rx, &shared, start, first_window(0, timing.window));
        let mut out = SoftSteps::new(StepQueue::new(planner, tx, &shared), engine, NoPins);
        let mut ring: Ring<Setpoint, SETPOINT_RING> = Ring::new();
        let (mut sp_tx, mut sp_rx) = ring.split();
        let mut e = TickExecutor::new(Point3Mm::ORIGIN);
        // 1 mm a tick at 1000 steps/mm: 1 MHz, five times what 2.5 µs
        // pulses allow.
        for k in 1..=5 {
            sp_tx
                .enqueue(sp(k << 32, MotionState::Moving, true))
                .unwrap();
            e.tick(&mut sp_rx, &mut out);
        }
        for _ in 0..3 {
            e.tick(&mut sp_rx, &mut out);
        }
        let latch: &'static crate::alarm::Latch = Box::leak(Box::default());
        let link = DeviceLink::new(latch, crate::config::Config::DEFAULT, Default::default());
        let s = link.status(&e);
        assert!(s.step_lag_ticks >= 3, "{s:?}");
        assert!(s.step_lag_max_steps >= 1000, "{s:?}");
        assert_eq!(s.step_late_ticks, 0);
        assert!(matches!(e.step_fault(), Some(StepFault::Lag { .. })));
    }

    #[test]
    fn moving_ticks_count_from_the_first_move_of_a_path() {
        let mut ring: Ring<Setpoint, SETPOINT_RING> = Ring::new();
        let (mut tx, mut rx) = ring.split();
        let mut e = TickExecutor::new(Point3Mm::ORIGIN);
        let mut out = Last::default();
        let mut run = |seq: &[Setpoint], e: &mut TickExecutor| {
            for s in seq {
                tx.enqueue(*s).unwrap();
                e.tick(&mut rx, &mut out);
            }
        };
        run(&[sp(1, MotionState::Moving, true); 3], &mut e);
        run(&[sp(1, MotionState::Done, false)], &mut e);
        assert_eq!(e.moving_ticks, 3);
        run(&[sp(2, MotionState::Moving, true); 2], &mut e);
        assert_eq!(e.moving_ticks, 2, "a new path starts a new count");
        run(&[sp(2, MotionState::Holding, false)], &mut e);
        assert_eq!(e.moving_ticks, 2, "a hold does not reset it");
    }
}
