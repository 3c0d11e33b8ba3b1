//! Step/direction outputs: the tick hands each setpoint to a
//! [`StepOutput`]; the step generator ([`crate::steps`]) turns it into
//! timed pulses. The motion code never touches the chip.
//!
//! - [`StepQueue`]: the tick's side of a timer-driven engine (the
//!   firmware on a board): the setpoint becomes a [`TickPlan`] queued to
//!   the [`StepEngine`] that the step timer's interrupt runs;
//! - [`SoftSteps`]: the same planner and engine, the engine run by the
//!   tick itself over the tick's window in virtual time, edges written at
//!   once (QEMU, whose timers cannot drive the engine; the cost
//!   benchmark; host tests).

use embedded_hal::digital::OutputPin;
use fuzzy_core::units::Point3Mm;

use crate::steps::{
    Edges, PlanTx, Planner, StepEngine, StepReport, StepSettings, StepShared, TickPlan,
};

/// Plans without a step in a row after which the engine has emitted every
/// step planned before them (it runs a plan 1.5 to 2.5 ticks after the
/// tick that queued it, [`crate::steps`]).
pub const SETTLE_TICKS: u8 = 3;

/// Something that takes a position setpoint per tick.
pub trait StepOutput {
    /// The tick ending at `pos` (mm).
    fn update(&mut self, pos: Point3Mm);
    /// A tick without a new setpoint: the position held.
    fn hold(&mut self) {}
    /// What the step generator reports.
    fn report(&self) -> StepReport {
        StepReport::default()
    }
    /// Stop at once (an alarm, a homing switch): no step after this call,
    /// steps planned and not yet emitted dropped. `at` is the last
    /// commanded position. Returns where the steps stopped (mm, in the
    /// setpoints' coordinates) once known (`None`: not yet, call again
    /// next tick); the next [`Self::update`] or [`Self::hold`] resumes
    /// from there. An output without a pipeline stops at `at`.
    fn stop(&mut self, at: Point3Mm) -> Option<Point3Mm> {
        Some(at)
    }
    /// New step settings `s` at rest at `at` (the commanded position): the
    /// steps from the next tick on follow them. Returns `false`, nothing
    /// changed, while steps may still be on their way (the last motion's
    /// not all emitted, steps owed, a stop in force): call again at the
    /// next tick. An output without a step generator takes them at once.
    fn reconfigure(&mut self, s: &StepSettings, at: Point3Mm) -> bool {
        let _ = (s, at);
        true
    }
}

/// Pins that take a batch of [`Edges`] at once.
pub trait StepPins {
    /// Drive the pins in `e`.
    fn write(&mut self, e: Edges);
    /// The step and direction polarity changed (bit per axis, as
    /// [`crate::steps::Timing`]'s), before the new rest levels are
    /// written: for pins that read their levels back (the simulator's).
    fn set_polarity(&mut self, invert_step: u8, invert_dir: u8) {
        let _ = (invert_step, invert_dir);
    }
}

/// Step and direction pins of three axes as `embedded-hal` pins, written
/// one by one (falling and direction edges before rising ones).
pub struct PinBank<S, D> {
    pins: [(S, D); 3],
}

impl<S: OutputPin, D: OutputPin> PinBank<S, D> {
    /// X, Y, Z (step, direction).
    pub fn new(pins: [(S, D); 3]) -> Self {
        PinBank { pins }
    }
}

impl<S: OutputPin, D: OutputPin> StepPins for PinBank<S, D> {
    fn write(&mut self, e: Edges) {
        // Pin errors cannot be reported from an interrupt: the board's
        // pins are infallible (`Infallible`), others are ignored.
        for (i, (step, dir)) in self.pins.iter_mut().enumerate() {
            let (s, d) = (1u8 << i, 8u8 << i);
            if e.clear & d != 0 {
                let _ = dir.set_low();
            }
            if e.set & d != 0 {
                let _ = dir.set_high();
            }
            if e.clear & s != 0 {
                let _ = step.set_low();
            }
            if e.set & s != 0 {
                let _ = step.set_high();
            }
        }
    }
}

/// The tick's side of a timer-driven step engine.
pub struct StepQueue<'a> {
    planner: Planner,
    plans: PlanTx<'a>,
    shared: &'a StepShared,
    overruns: u32,
    /// The stop asked for and not yet resumed from.
    halting: Option<u32>,
    /// Where the steps stopped, mm (once the engine said).
    halted_at: Option<Point3Mm>,
    /// Plans without a step in a row (up to [`SETTLE_TICKS`]).
    still: u8,
    kick: fn(),
}

impl<'a> StepQueue<'a> {
    /// Plans from `planner` into `plans`, the engine's figures from
    /// `shared`.
    pub fn new(planner: Planner, plans: PlanTx<'a>, shared: &'a StepShared) -> Self {
        StepQueue {
            planner,
            plans,
            shared,
            overruns: 0,
            halting: None,
            halted_at: None,
            still: 0,
            kick: || {},
        }
    }

    /// `kick` makes the engine run now (on a board: pend the step timer's
    /// interrupt, whose priority is above the tick's), so that a stop takes
    /// effect within [`StepOutput::stop`].
    pub fn with_kick(self, kick: fn()) -> Self {
        StepQueue { kick, ..self }
    }

    /// Back from a stop: the engine takes plans again (the planner was
    /// moved to where it stopped).
    fn resume(&mut self) {
        if self.halting.take().is_some() {
            self.halted_at = None;
            self.shared.release();
        }
    }

    /// Where the last plan ended, whole steps per axis (where an engine
    /// rebuilt with new settings starts, [`StepOutput::reconfigure`]).
    pub fn position(&self) -> [i64; 3] {
        self.planner.position()
    }

    fn send(&mut self, plan: TickPlan) {
        self.still = if plan.axes.iter().all(|a| a.steps == 0) {
            self.still.saturating_add(1).min(SETTLE_TICKS)
        } else {
            0
        };
        if !self.plans.push(&plan) {
            // The engine takes one a tick; a full queue means it stopped.
            // The next plan starts where this one ended, so the engine
            // carries the difference and reports it as lag.
            self.overruns = self.overruns.wrapping_add(1);
        }
    }
}

impl StepOutput for StepQueue<'_> {
    fn update(&mut self, pos: Point3Mm) {
        self.resume();
        let plan = self.planner.plan(pos);
        self.send(plan);
    }

    fn hold(&mut self) {
        self.resume();
        let plan = self.planner.hold();
        self.send(plan);
    }

    fn stop(&mut self, _at: Point3Mm) -> Option<Point3Mm> {
        let seq = match self.halting {
            Some(seq) => seq,
            None => {
                let seq = self.shared.request_halt();
                self.halting = Some(seq);
                seq
            }
        };
        if self.halted_at.is_none() {
            (self.kick)();
            if let Some(steps) = self.shared.halted_at(seq) {
                self.halted_at = Some(self.planner.rebase(steps));
            }
        }
        self.halted_at
    }

    fn report(&self) -> StepReport {
        StepReport {
            plan_overruns: self.overruns,
            ..self.shared.read()
        }
    }

    /// The tick's half: the planner anew (the caller rebuilds the engine
    /// at [`StepQueue::position`] before the next plan runs).
    fn reconfigure(&mut self, s: &StepSettings, at: Point3Mm) -> bool {
        let settled = self.still >= SETTLE_TICKS && self.shared.read().lag_now_steps == 0;
        if self.halting.is_some() || !settled {
            return false;
        }
        self.planner = Planner::new(s.steps_per_mm, &s.timing, at);
        true
    }
}

/// Planner and engine together, the engine run by the tick over the
/// tick's window in virtual time (module docs).
pub struct SoftSteps<'a, P> {
    queue: StepQueue<'a>,
    engine: StepEngine<'a>,
    pins: P,
    /// Virtual time of the next tick, timer counts.
    now: u32,
    window: u32,
}

impl<'a, P: StepPins> SoftSteps<'a, P> {
    /// `queue` feeding `engine` (started 1.5 ticks after virtual time 0,
    /// [`crate::steps::engine`] docs), edges to `pins`.
    pub fn new(queue: StepQueue<'a>, engine: StepEngine<'a>, mut pins: P) -> Self {
        pins.write(engine.idle_edges());
        let window = engine.timing().window;
        SoftSteps {
            queue,
            engine,
            pins,
            now: 0,
            window,
        }
    }

    /// The engine (position emitted, figures).
    pub fn engine(&self) -> &StepEngine<'a> {
        &self.engine
    }

    /// The pins.
    pub fn pins(&self) -> &P {
        &self.pins
    }

    fn run(&mut self) {
        self.engine.poll_halt();
        let end = self.now.wrapping_add(self.window).wrapping_sub(1);
        let pins = &mut self.pins;
        self.engine.run_until(end, |e, _| pins.write(e));
        self.now = end.wrapping_add(1);
    }
}

impl<P: StepPins> StepOutput for SoftSteps<'_, P> {
    fn update(&mut self, pos: Point3Mm) {
        self.queue.update(pos);
        self.run();
    }

    fn hold(&mut self) {
        self.queue.hold();
        self.run();
    }

    fn report(&self) -> StepReport {
        self.queue.report()
    }

    fn stop(&mut self, at: Point3Mm) -> Option<Point3Mm> {
        if self.queue.stop(at).is_none() {
            self.engine.poll_halt();
        }
        // The window runs on: pulses started end, nothing else.
        self.run();
        self.queue.stop(at)
    }

    fn reconfigure(&mut self, s: &StepSettings, at: Point3Mm) -> bool {
        if !self.queue.reconfigure(s, at) {
            return false;
        }
        self.engine.reconfigure(s.timing, self.queue.position());
        self.pins
            .set_polarity(s.timing.invert_step, s.timing.invert_dir);
        self.pins.write(self.engine.idle_edges());
        true
    }
}

/// The first window of an engine that a tick at timer count `tick` will
/// feed from then on: 1.5 ticks later ([`crate::steps::engine`] docs).
pub const fn first_window(tick: u32, window: u32) -> u32 {
    tick.wrapping_add(window + window / 2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::steps::{PlanQueue, StepConfig, StepSettings, StepsPerMm, Timing};
    use core::convert::Infallible;
    use std::cell::RefCell;
    use std::rc::Rc;

    /// Pin edges in order: (axis, pin, level), pin 0 = step, 1 = dir.
    type Log = Rc<RefCell<Vec<(usize, u8, bool)>>>;

    struct Rec {
        log: Log,
        axis: usize,
        pin: u8,
    }

    impl embedded_hal::digital::ErrorType for Rec {
        type Error = Infallible;
    }

    impl OutputPin for Rec {
        fn set_low(&mut self) -> Result<(), Infallible> {
            self.log.borrow_mut().push((self.axis, self.pin, false));
            Ok(())
        }
        fn set_high(&mut self) -> Result<(), Infallible> {
            self.log.borrow_mut().push((self.axis, self.pin, true));
            Ok(())
        }
    }

    fn pins(log: &Log) -> PinBank<Rec, Rec> {
        PinBank::new([0, 1, 2].map(|axis| {
            let pin = |pin| Rec {
                log: log.clone(),
                axis,
                pin,
            };
            (pin(0), pin(1))
        }))
    }

    /// The position each axis's pulses say it is at, counting a rising
    /// step edge as a step in the direction the DIR pin then shows
    /// (unknown DIR: a failure).
    fn replay(log: &Log) -> [i64; 3] {
        let mut dir: [Option<bool>; 3] = [None; 3];
        let mut at = [0i64; 3];
        for &(axis, pin, level) in log.borrow().iter() {
            match (pin, level) {
                (1, l) => dir[axis] = Some(l),
                (0, true) => {
                    let d = dir[axis].expect("a step before DIR was ever set");
                    at[axis] += if d { 1 } else { -1 };
                }
                _ => {}
            }
        }
        at
    }

    fn mm(x: f64, y: f64, z: f64) -> Point3Mm {
        Point3Mm::from_f64(x, y, z).unwrap()
    }

    struct Rig {
        ring: PlanQueue,
        shared: StepShared,
        timing: Timing,
        spm: [StepsPerMm; 3],
    }

    impl Rig {
        fn new(spm: [u16; 3]) -> Self {
            let spm = spm.map(StepsPerMm::from_int);
            let timing = StepConfig::new(spm[0]).timing(84_000_000, 1000).unwrap();
            Rig {
                ring: PlanQueue::new(),
                shared: StepShared::new(),
                timing,
                spm,
            }
        }

        fn soft(&mut self, log: &Log) -> SoftSteps<'_, PinBank<Rec, Rec>> {
            let (tx, rx) = self.ring.split();
            let planner = Planner::new(self.spm, &self.timing, Point3Mm::ORIGIN);
            let start = planner.position();
            let queue = StepQueue::new(planner, tx, &self.shared);
            let engine = StepEngine::new(
                self.timing,
                rx,
                &self.shared,
                start,
                first_window(0, self.timing.window),
            );
            SoftSteps::new(queue, engine, pins(log))
        }
    }

    /// Ticks to let the pipeline (1.5 ticks) drain.
    fn settle(s: &mut impl StepOutput) {
        for _ in 0..3 {
            s.hold();
        }
    }

    #[test]
    fn new_step_settings_wait_for_the_last_steps_then_apply_from_there() {
        let log = Log::default();
        let mut rig = Rig::new([100; 3]);
        let s = StepSettings {
            timing: rig.timing,
            steps_per_mm: [80, 100, 100].map(StepsPerMm::from_int),
        };
        let mut a = rig.soft(&log);
        let at = mm(1.0, 0.0, 0.0);
        a.update(at);
        for _ in 0..SETTLE_TICKS - 1 {
            assert!(!a.reconfigure(&s, at), "steps on their way");
            a.hold();
        }
        assert!(!a.reconfigure(&s, at));
        a.hold();
        assert!(a.reconfigure(&s, at), "settled");
        assert_eq!(replay(&log), [100, 0, 0], "every step of the move out");
        assert_eq!(a.engine().position(), [80, 0, 0], "1 mm at 80 steps/mm");
        for i in 1..=4 {
            a.update(mm(1.0 + 0.25 * i as f64, 0.0, 0.0));
        }
        settle(&mut a);
        assert_eq!(replay(&log), [180, 0, 0], "the next mm in 80 steps");
        assert_eq!(a.engine().position(), [160, 0, 0]);
        let r = a.report();
        assert_eq!((r.lag_ticks, r.late_windows), (0, 0));
    }

    #[test]
    fn the_first_move_of_each_axis_sets_dir_before_stepping() {
        for (first, want) in [(10.0, 1000), (-10.0, -1000)] {
            let log = Log::default();
            let mut rig = Rig::new([100; 3]);
            let mut a = rig.soft(&log);
            // 10 mm at 100 steps/mm in 0.5 mm moves (50 kHz).
            for k in 1..=20 {
                let x = first * k as f64 / 20.0;
                a.update(mm(x, -x, x / 2.0));
            }
            settle(&mut a);
            assert_eq!(replay(&log), [want, -want, want / 2]);
            assert_eq!(a.engine().position(), [want, -want, want / 2]);
        }
    }

    #[test]
    fn back_and_forth_ends_where_commanded() {
        let log = Log::default();
        let mut rig = Rig::new([100; 3]);
        let mut a = rig.soft(&log);
        let mut x = 0.0f64;
        for target in [10.0, -10.0, 10.0, 2.5] {
            while (x - target).abs() > 1e-9 {
                x += (target - x).clamp(-0.5, 0.5);
                a.update(mm(x, 0.0, 0.0));
            }
        }
        settle(&mut a);
        assert_eq!(replay(&log)[0], 250);
        assert_eq!(a.engine().position()[0], 250);
        assert_eq!(a.report().fault(), None);
    }

    #[test]
    fn per_axis_steps_per_mm() {
        let log = Log::default();
        let mut rig = Rig::new([80, 400, 3200]);
        let mut a = rig.soft(&log);
        for k in 1..=10 {
            let v = k as f64 * 0.1;
            a.update(mm(v, -v, v / 4.0));
        }
        settle(&mut a);
        assert_eq!(replay(&log), [80, -400, 800]);
        assert_eq!(a.report().fault(), None);
    }

    #[test]
    fn steps_beyond_the_pulse_rate_are_carried_and_reported() {
        let log = Log::default();
        let mut rig = Rig::new([1000; 3]);
        let mut a = rig.soft(&log);
        // 1 mm = 1000 steps in one tick (1 MHz), the default pulse allows
        // 200 kHz (200 a tick): the rest comes later, and it is reported.
        a.update(mm(1.0, 0.0, 0.0));
        settle(&mut a);
        let r = a.report();
        assert!(r.lag_ticks >= 1, "{r:?}");
        assert!(r.lag_max_steps >= 790, "{r:?}");
        assert!(matches!(
            r.fault(),
            Some(crate::steps::StepFault::Lag { .. })
        ));
        for _ in 0..10 {
            a.hold();
        }
        assert_eq!(replay(&log)[0], 1000);
        assert_eq!(a.report().lag_now_steps, 0);
    }

    #[test]
    fn a_stop_on_the_timer_path_drops_the_armed_step_and_says_where() {
        let mut rig = Rig::new([100; 3]);
        let (tx, rx) = rig.ring.split();
        let planner = Planner::new(rig.spm, &rig.timing, Point3Mm::ORIGIN);
        let mut q = StepQueue::new(planner, tx, &rig.shared);
        let w = rig.timing.window;
        let first = first_window(0, w);
        let mut engine = StepEngine::new(rig.timing, rx, &rig.shared, [0; 3], first);
        // Two ticks of 50 steps queued, the engine halfway into the first.
        q.update(mm(0.5, 0.0, 0.0));
        q.update(mm(1.0, 0.0, 0.0));
        let mut steps = 0;
        engine.run_until(first + w / 2, |e, _| steps += i64::from(e.set & 1));
        assert!((20..30).contains(&steps), "{steps}");
        while engine.due().edges.set & 1 == 0 {
            let d = engine.due();
            engine.done(d.at);
        }
        assert_eq!(q.stop(mm(1.0, 0.0, 0.0)), None, "the engine has not run");
        assert!(engine.poll_halt());
        assert_eq!(engine.due().edges.set & 1, 0, "the armed step dropped");
        engine.run_until(first + 10 * w, |e, _| steps += i64::from(e.set & 1));
        assert_eq!(engine.position()[0], steps);
        let at = q.stop(mm(1.0, 0.0, 0.0)).unwrap();
        assert_eq!(q.planner.whole_steps(at)[0], steps);
        assert_eq!(engine.report().fault(), None);
        // Resumed: the next plan starts where the steps stopped.
        q.update(at);
        assert!(!engine.poll_halt(), "a resume changes no batch");
        engine.run_until(first + 12 * w, |e, _| steps += i64::from(e.set & 1));
        assert!(!engine.halted());
        assert_eq!(engine.position()[0], steps);
        assert_eq!(engine.report().lag_ticks, 0);
    }
}
