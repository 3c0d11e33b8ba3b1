//! The tick's safety work, before and around the executor
//! ([`crate::tick::TickExecutor`]): the inputs sampled and debounced, the
//! alarms the tick raises itself, and what the tick does in each
//! [`Phase`] of the [`Latch`] (`crate::alarm` module docs).
//!
//! Each tick, in this order (everything before the executor, so an input
//! seen at tick k stops the output at tick k):
//! 1. the raw input word (the board reads the pins) is made active-high
//!    with the polarity setting and debounced: the e-stop counts as active
//!    at its first active sample (a noise pulse can stop the machine, never
//!    delay a stop) and as released after `debounce` inactive samples in a
//!    row; a limit switch and the probe change after `debounce` equal
//!    samples in a row; a probing move armed, the probe at its trip level
//!    latches where the steps were at the first sample of the change
//!    ([`crate::probe`]);
//! 2. an active e-stop trips [`AlarmCode::EStopInput`]; with hard limits on
//!    (and no homing cycle running), a limit switch becoming active trips
//!    [`AlarmCode::HardLimit`] (on the change, as Grbl's pin-change
//!    interrupt: after an unlock the tool may be driven off a switch it is
//!    on); during homing, the watched switch active stops the tick
//!    ([`Phase::Halt`]);
//! 3. `Run`: the executor runs, its outputs shifted by the coordinate
//!    offset homing set ([`Shifted`]); `Alarm` and `Halt`: the ring is
//!    drained, the step output stopped at once (steps planned and not yet
//!    emitted dropped, [`StepOutput::stop`]) and the executor's state set
//!    at rest where the steps stopped (once the step output knows it,
//!    published for the background); `Hold`: the step output holds;
//! 4. the driver-enable output: on, except in `Alarm`.
//!
//! After the executor, [`Guard::check_lag`] trips [`AlarmCode::StepLag`]
//! when the step output reports it fell behind, and
//! [`Guard::apply_step_settings`] hands step settings written at rest to
//! the step output once no step is on its way.

use fuzzy_core::planner::MotionState;
use fuzzy_core::units::Point3Mm;
use link::AlarmCode;

use crate::alarm::{limit_bit, Latch, Phase, ESTOP};
use crate::planning::Setpoint;
use crate::probe::{ProbeWatch, PROBE};
use crate::ring::Consumer;
use crate::settings::SETPOINT_RING;
use crate::stepper::StepOutput;
use crate::steps::{StepReport, StepSettings};
use crate::tick::TickExecutor;

/// Step outputs that take machine coordinates minus an offset (the step
/// output keeps its own count from power-up; homing moves the machine's
/// zero).
pub struct Shifted<'a, O> {
    inner: &'a mut O,
    offset: [i64; 3],
}

impl<O> Shifted<'_, O> {
    fn inner_of(&self, pos: Point3Mm) -> Point3Mm {
        let (b, o) = (pos.to_bits(), self.offset);
        Point3Mm::from_bits(
            b[0].wrapping_sub(o[0]),
            b[1].wrapping_sub(o[1]),
            b[2].wrapping_sub(o[2]),
        )
    }

    fn outer_of(&self, pos: Point3Mm) -> Point3Mm {
        let (b, o) = (pos.to_bits(), self.offset);
        Point3Mm::from_bits(
            b[0].wrapping_add(o[0]),
            b[1].wrapping_add(o[1]),
            b[2].wrapping_add(o[2]),
        )
    }
}

impl<O: StepOutput> StepOutput for Shifted<'_, O> {
    fn update(&mut self, pos: Point3Mm) {
        let p = self.inner_of(pos);
        self.inner.update(p);
    }

    fn hold(&mut self) {
        self.inner.hold();
    }

    fn report(&self) -> StepReport {
        self.inner.report()
    }

    fn stop(&mut self, at: Point3Mm) -> Option<Point3Mm> {
        let p = self.inner_of(at);
        let stopped = self.inner.stop(p)?;
        Some(self.outer_of(stopped))
    }

    fn reconfigure(&mut self, s: &StepSettings, at: Point3Mm) -> bool {
        let p = self.inner_of(at);
        self.inner.reconfigure(s, p)
    }
}

/// The tick's safety state.
#[derive(Clone, Copy, Debug, Default)]
pub struct Guard {
    /// Debounced active inputs.
    active: u8,
    /// Per input: samples in a row at the other level.
    counts: [u8; 8],
    /// This stop (`Alarm` or `Halt`) began.
    stopped: bool,
    /// Where it stopped was published.
    published: bool,
    offset: [i64; 3],
    lag_seen: u32,
    /// Ticks the executor did not run (alarm, halt, refill).
    pub stopped_ticks: u32,
    /// Setpoints drained unexecuted.
    pub drained: u32,
    /// The probe: where the steps were when it changed.
    probe: ProbeWatch,
}

impl Guard {
    /// Nothing active yet.
    pub const fn new() -> Self {
        Guard {
            active: 0,
            counts: [0; 8],
            stopped: false,
            published: false,
            offset: [0; 3],
            lag_seen: 0,
            stopped_ticks: 0,
            drained: 0,
            probe: ProbeWatch::new(),
        }
    }

    /// Debounced active inputs.
    pub fn active(&self) -> u8 {
        self.active
    }

    /// Sample the raw input word (bit layout of [`crate::alarm`]);
    /// returns the inputs that became active.
    fn sample(&mut self, raw: u8, invert: u8, debounce: u8) -> u8 {
        let level = raw ^ invert;
        let mut rose = 0;
        for (bit, count) in self.counts.iter_mut().enumerate() {
            let m = 1u8 << bit;
            let now = level & m != 0;
            let was = self.active & m != 0;
            if now == was {
                *count = 0;
                continue;
            }
            *count = count.saturating_add(1);
            // The e-stop trips at once; everything else waits.
            if *count >= debounce.max(1) || (m == ESTOP && now) {
                *count = 0;
                self.active ^= m;
                if now {
                    rose |= m;
                }
            }
        }
        rose
    }

    /// One tick (module docs): `raw` inputs, then the executor on `ring`
    /// and `out` if the phase allows. Returns whether the drivers are
    /// enabled (the level of the enable output is the caller's, with
    /// [`crate::alarm::GuardConfig::enable_invert`]).
    pub fn tick<O: StepOutput>(
        &mut self,
        raw: u8,
        latch: &Latch,
        exec: &mut TickExecutor,
        ring: &mut Consumer<'_, Setpoint, SETPOINT_RING>,
        out: &mut O,
    ) -> bool {
        let cfg = latch.guard_config();
        let rose = self.sample(raw, cfg.invert, cfg.debounce);
        latch.set_inputs(self.active);
        let probe_level = (raw ^ cfg.invert) & PROBE != 0;
        self.probe
            .sample(probe_level, self.active & PROBE != 0, &latch.probe);
        if self.active & ESTOP != 0 {
            latch.trip(AlarmCode::EStopInput);
        }
        let (homing, watch, offset) = latch.tick_view();
        self.offset = offset;
        if cfg.hard_limits && !homing && rose & !ESTOP != 0 {
            if let Some(bit) = (1..7).find(|b| rose & 1 << b != 0) {
                latch.trip(AlarmCode::HardLimit {
                    axis: (bit - 1) / 2,
                    max: bit % 2 == 0,
                });
            }
        }
        if let Some(w) = watch {
            if self.active & w != 0 {
                latch.advance(Phase::Run, Phase::Halt);
            }
        }
        let mut out = Shifted {
            inner: out,
            offset: self.offset,
        };
        match latch.phase() {
            Phase::Run => {
                self.stopped = false;
                exec.tick(ring, &mut out);
            }
            Phase::Alarm | Phase::Halt => {
                self.stopped_ticks = self.stopped_ticks.wrapping_add(1);
                while ring.dequeue().is_some() {
                    self.drained = self.drained.wrapping_add(1);
                }
                if !self.stopped {
                    self.stopped = true;
                    self.published = false;
                    exec.now = Setpoint {
                        state: MotionState::Idle,
                        ..Setpoint::at_rest(exec.now.pos)
                    };
                }
                // The step output stops now; it says where once it knows
                // (the background waits for that).
                if let Some(at) = out.stop(exec.now.pos) {
                    if !self.published {
                        self.published = true;
                        exec.now.pos = at;
                        latch.set_stopped_at(at);
                    }
                }
                exec.steps = out.report();
            }
            Phase::Hold => {
                self.stopped = false;
                self.stopped_ticks = self.stopped_ticks.wrapping_add(1);
                out.hold();
                exec.steps = out.report();
            }
        }
        self.probe.executed(exec.now.pos);
        latch.phase() != Phase::Alarm
    }

    /// After the executor: the step generator's figures
    /// ([`TickExecutor::steps`]); a tick that ended with an axis short of
    /// its commanded position (a rate above what the pulse width allows, a
    /// plan lost) trips [`AlarmCode::StepLag`]: the steps are carried, not
    /// dropped, but the motion is no longer the planned one.
    pub fn check_lag(&mut self, latch: &Latch, steps: &StepReport) {
        if steps.lag_ticks != self.lag_seen {
            self.lag_seen = steps.lag_ticks;
            latch.trip(AlarmCode::StepLag);
        }
    }

    /// After the executor: step settings written at rest (`pending`, from
    /// the background) to the step output, once the tool is at rest in
    /// [`Phase::Run`] and no step is on its way
    /// ([`StepOutput::reconfigure`]); until then they stay pending (the
    /// session takes a write only at rest or in a carried-out alarm, and
    /// the ring holds `SETPOINT_RING − 1` ticks of rest ahead of any new
    /// motion, more than the step pipeline's depth). Returns whether they
    /// were taken now (`pending` is then empty).
    pub fn apply_step_settings<O: StepOutput>(
        &mut self,
        pending: &mut Option<StepSettings>,
        latch: &Latch,
        exec: &TickExecutor,
        out: &mut O,
    ) -> bool {
        let Some(s) = pending else {
            return false;
        };
        if latch.phase() != Phase::Run || exec.now.moving {
            return false;
        }
        let mut out = Shifted {
            inner: out,
            offset: self.offset,
        };
        let taken = out.reconfigure(s, exec.now.pos);
        if taken {
            *pending = None;
        }
        taken
    }
}

/// The input word a limit switch at `switch_steps` (an axis's position in
/// steps at which it closes, `max`: closed at and above it, else at and
/// below) gives: for simulated axes.
pub fn switch_input(axis: usize, max: bool, steps: i64, switch_steps: i64) -> u8 {
    let closed = if max {
        steps >= switch_steps
    } else {
        steps <= switch_steps
    };
    if closed {
        limit_bit(axis, max)
    } else {
        0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::alarm::GuardConfig;
    use crate::ring::Ring;

    #[derive(Default)]
    struct Count(u32);
    impl StepOutput for Count {
        fn update(&mut self, _: Point3Mm) {
            self.0 += 1;
        }
    }

    fn moving(x: i64) -> Setpoint {
        Setpoint {
            pos: Point3Mm::from_bits(x, 0, 0),
            feed_q12: 4096,
            state: MotionState::Moving,
            moving: true,
        }
    }

    #[test]
    fn an_e_stop_stops_the_output_at_the_tick_it_is_seen() {
        let latch = Latch::new();
        let mut ring: Ring<Setpoint, SETPOINT_RING> = Ring::new();
        let (mut tx, mut rx) = ring.split();
        let mut g = Guard::new();
        let mut e = TickExecutor::new(Point3Mm::ORIGIN);
        let mut out = Count::default();
        for k in 0..10 {
            tx.enqueue(moving(k)).unwrap();
        }
        for _ in 0..3 {
            assert!(g.tick(0, &latch, &mut e, &mut rx, &mut out));
        }
        assert_eq!(out.0, 3);
        // Active at its first sample: no output at this tick.
        assert!(!g.tick(ESTOP, &latch, &mut e, &mut rx, &mut out));
        assert_eq!(out.0, 3);
        assert_eq!(latch.alarm(), Some(AlarmCode::EStopInput));
        assert_eq!(g.drained, 7, "the ring drained");
        assert_eq!(latch.take_stopped_at(), Some(Point3Mm::from_bits(2, 0, 0)));
        assert!(!e.now.moving && e.now.feed_q12 == 0);
        // Released, still in alarm: nothing until the background resumes.
        tx.enqueue(moving(100)).unwrap();
        for _ in 0..10 {
            assert!(!g.tick(0, &latch, &mut e, &mut rx, &mut out));
        }
        assert_eq!(out.0, 3);
        assert_eq!(latch.inputs(), 0, "released after the debounce");
    }

    #[test]
    fn a_limit_switch_trips_after_the_debounce_only_with_hard_limits_on() {
        let latch = Latch::new();
        let mut ring: Ring<Setpoint, SETPOINT_RING> = Ring::new();
        let (_tx, mut rx) = ring.split();
        let mut g = Guard::new();
        let mut e = TickExecutor::new(Point3Mm::ORIGIN);
        let mut out = Count::default();
        let ymax = limit_bit(1, true);
        for _ in 0..5 {
            g.tick(ymax, &latch, &mut e, &mut rx, &mut out);
        }
        assert_eq!(latch.alarm(), None, "hard limits off");
        assert_eq!(latch.inputs(), ymax);
        let cfg = GuardConfig {
            debounce: 3,
            hard_limits: true,
            ..GuardConfig::default()
        };
        latch.set_guard_config(cfg);
        let mut g = Guard::new();
        // A two-sample glitch is ignored.
        for raw in [ymax, ymax, 0, 0, 0] {
            g.tick(raw, &latch, &mut e, &mut rx, &mut out);
        }
        assert_eq!(latch.alarm(), None);
        for _ in 0..2 {
            g.tick(ymax, &latch, &mut e, &mut rx, &mut out);
        }
        assert_eq!(latch.alarm(), None);
        g.tick(ymax, &latch, &mut e, &mut rx, &mut out);
        assert_eq!(
            latch.alarm(),
            Some(AlarmCode::HardLimit { axis: 1, max: true })
        );
        // Inverted polarity: the open switch reads high.
        let latch = Latch::new();
        latch.set_guard_config(GuardConfig {
            invert: ymax,
            ..cfg
        });
        let mut g = Guard::new();
        for _ in 0..5 {
            g.tick(ymax, &latch, &mut e, &mut rx, &mut out);
        }
        assert_eq!(latch.alarm(), None);
        for _ in 0..3 {
            g.tick(0, &latch, &mut e, &mut rx, &mut out);
        }
        assert!(latch.alarm().is_some());
    }

    /// Step pins that count rising step edges per axis (active high).
    #[derive(Default)]
    struct Steps(std::rc::Rc<std::cell::RefCell<[u32; 3]>>);
    impl crate::stepper::StepPins for Steps {
        fn write(&mut self, e: crate::steps::Edges) {
            for (i, n) in self.0.borrow_mut().iter_mut().enumerate() {
                *n += u32::from(e.set & 1 << i != 0);
            }
        }
    }

    #[test]
    fn an_e_stop_stops_the_step_engine_at_once_and_unlock_resumes_where_it_stopped() {
        use crate::stepper::{first_window, SoftSteps, StepQueue};
        use crate::steps::{PlanQueue, Planner, StepConfig, StepEngine, StepShared, StepsPerMm};
        let spm = StepsPerMm::from_int(100);
        let timing = StepConfig::new(spm).timing(84_000_000, 1000).unwrap();
        let (mut plans, shared) = (PlanQueue::new(), StepShared::new());
        let (tx, rx) = plans.split();
        let planner = Planner::new([spm; 3], &timing, Point3Mm::ORIGIN);
        let engine = StepEngine::new(timing, rx, &shared, [0; 3], first_window(0, timing.window));
        let count = Steps::default();
        let seen = count.0.clone();
        let mut out = SoftSteps::new(StepQueue::new(planner, tx, &shared), engine, count);
        let latch = Latch::new();
        let mut ring: Ring<Setpoint, SETPOINT_RING> = Ring::new();
        let (mut sp_tx, mut rx) = ring.split();
        let mut g = Guard::new();
        let mut e = TickExecutor::new(Point3Mm::ORIGIN);
        // 0.5 mm a tick on X: 50 steps a tick (50 kHz).
        let x = |k: i64| moving(k << 31);
        for k in 1..=10 {
            sp_tx.enqueue(x(k)).unwrap();
            assert!(g.tick(0, &latch, &mut e, &mut rx, &mut out));
        }
        let before = seen.borrow()[0];
        assert!(before >= 400, "{before} steps");
        assert!(!g.tick(ESTOP, &latch, &mut e, &mut rx, &mut out));
        let at_stop = seen.borrow()[0];
        for _ in 0..5 {
            g.tick(ESTOP, &latch, &mut e, &mut rx, &mut out);
        }
        // Nothing after the tick the e-stop was seen; the steps planned
        // ahead (1.5 ticks) are dropped, not owed.
        assert_eq!(seen.borrow()[0], at_stop);
        assert_eq!(out.engine().position()[0], at_stop as i64);
        assert!(at_stop < 500, "the pipeline's steps dropped: {at_stop}");
        let stopped = latch.take_stopped_at().unwrap();
        assert_eq!(stopped, e.now.pos);
        assert_eq!(
            ((stopped.to_bits()[0] as i128 * 100) >> 32) as u32,
            at_stop,
            "published where the steps stopped"
        );
        assert_eq!(out.report().fault(), None, "no lag, no late tick");
        // Released (debounced), unlocked: on from where the steps stopped,
        // 1 mm further.
        for _ in 0..10 {
            g.tick(0, &latch, &mut e, &mut rx, &mut out);
        }
        assert_eq!(seen.borrow()[0], at_stop);
        assert!(latch.advance(Phase::Alarm, Phase::Run));
        let target = stopped.to_bits()[0] + (1 << 32);
        for k in 1..=4 {
            sp_tx
                .enqueue(moving(stopped.to_bits()[0] + k * (1 << 30)))
                .unwrap();
            g.tick(0, &latch, &mut e, &mut rx, &mut out);
        }
        for _ in 0..3 {
            g.tick(0, &latch, &mut e, &mut rx, &mut out);
        }
        assert_eq!(e.now.pos.to_bits()[0], target);
        assert_eq!(seen.borrow()[0], at_stop + 100, "exactly 1 mm more");
        assert_eq!(out.report().fault(), None);
    }

    #[test]
    fn step_lag_trips_an_alarm() {
        let latch = Latch::new();
        let mut g = Guard::new();
        let mut r = StepReport::NONE;
        g.check_lag(&latch, &r);
        assert_eq!(latch.alarm(), None);
        r.lag_ticks = 1;
        g.check_lag(&latch, &r);
        assert_eq!(latch.alarm(), Some(AlarmCode::StepLag));
    }
}
