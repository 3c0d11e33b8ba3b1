//! The scheduler and the velocity planner over a whole path with a fixed,
//! deterministic feeding policy, and a checksum of every commanded position.
//!
//! Shared, as source, by the cost benchmark (`src/bin/cost.rs`, on the
//! Cortex-M4 in QEMU) and the host test `tests/tests/firmware_qemu.rs`
//! (which includes this file with `#[path]`): both print the same checksums
//! when the planner computes the same bits on the target as on the host.
//! It depends on `fuzzy-core` and the settings in [`super::config`] only.
//!
//! The policy ([`run`]): the planner restarts where the tool is (it must be
//! at rest); each point goes through the scheduler, each scheduled point
//! into the planner (except a first point where the tool already is:
//! [`already_there`]), and while the planner is full it ticks once and
//! tries again; at the end the scheduler is drained, the path ended, and
//! the planner ticks until it is done. With [`EVENTS`] (`events = true`) a feed
//! hold, feed override changes and a starved stretch (no pushes) happen at
//! fixed ticks on the way.

use fuzzy_core::lin2021::{Lin2021Compact, COMPACT};
use fuzzy_core::planner::{Motion, MotionError, MotionPoint, MotionState, Tick};
use fuzzy_core::scheduler::{
    PathPoint, ScheduledPoint, Scheduler, SchedulerConfig, SchedulerError,
};
use fuzzy_core::units::Point3Mm;

use super::config::{AVG, SCHED_CAP, WS};

/// The scheduler as configured for the firmware.
pub type Sched = Scheduler<&'static Lin2021Compact, WS, AVG, SCHED_CAP>;

/// Spacing of [`line`]'s points: 0.05 mm (I32F32 bits, rounded to nearest).
pub const LINE_STEP_BITS: i64 = 214_748_365;

/// A straight line along X from the origin: `segments + 1` points
/// [`LINE_STEP_BITS`] apart (integer arithmetic: the same bits everywhere).
pub fn line(segments: u32) -> impl Iterator<Item = Point3Mm> {
    (0..=segments).map(|i| Point3Mm::from_bits(i as i64 * LINE_STEP_BITS, 0, 0))
}

/// Where time comes from (SysTick on the target; nothing on the host).
pub trait Clock {
    /// A reading.
    fn now(&mut self) -> u32;
    /// Elapsed since `start` (a [`Clock::now`] reading).
    fn since(&mut self, start: u32) -> u32;
}

/// No time at all (host).
pub struct NoClock;

impl Clock for NoClock {
    fn now(&mut self) -> u32 {
        0
    }
    fn since(&mut self, _: u32) -> u32 {
        0
    }
}

/// Total, worst and count of a measured operation, clock units.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Stat {
    /// Sum.
    pub total: u64,
    /// Largest single one.
    pub worst: u32,
    /// How many.
    pub n: u32,
}

impl Stat {
    /// Record one.
    pub fn add(&mut self, dt: u32) {
        self.total += dt as u64;
        self.worst = self.worst.max(dt);
        self.n += 1;
    }

    /// Add another's records.
    pub fn merge(&mut self, o: &Stat) {
        self.total += o.total;
        self.worst = self.worst.max(o.worst);
        self.n += o.n;
    }
}

/// FNV-1a over 64-bit words.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Checksum(pub u64);

impl Default for Checksum {
    fn default() -> Self {
        Checksum(0xCBF2_9CE4_8422_2325)
    }
}

impl Checksum {
    /// Fold in one word.
    pub fn add(&mut self, w: u64) {
        self.0 = (self.0 ^ w).wrapping_mul(0x0000_0100_0000_01B3);
    }

    /// Fold in a commanded position.
    pub fn add_pos(&mut self, p: Point3Mm) {
        for c in p.to_bits() {
            self.add(c as u64);
        }
    }
}

/// Something that happens at a fixed tick of a path.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Event {
    /// Feed hold on (`true`) or off.
    Hold(bool),
    /// Feed override, percent.
    Override(u16),
    /// No pushes until this tick (a path that stops arriving).
    StarveUntil(u32),
}

/// The events of an `events = true` run, by tick of the path: hold at 1.5 s
/// for 0.5 s, override 150 % then 50 %, 0.4 s without new points at 4 s,
/// override back to 100 %.
pub const EVENTS: [(u32, Event); 6] = [
    (1500, Event::Hold(true)),
    (2000, Event::Hold(false)),
    (2500, Event::Override(150)),
    (3500, Event::Override(50)),
    (4000, Event::StarveUntil(4400)),
    (4500, Event::Override(100)),
];

/// Why a run failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReplayError {
    /// The scheduler refused a point or its settings.
    Scheduler(SchedulerError),
    /// The planner refused a point, or could not restart.
    Motion(MotionError),
    /// Not done after this many ticks (a bug).
    NeverDone(u32),
}

/// What a run measured and produced.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Report {
    /// Scheduled points.
    pub points: u32,
    /// Ticks until done.
    pub ticks: u32,
    /// Checksum of every commanded position.
    pub positions: u64,
    /// Sum of the scheduled feeds (I32F32 bits, wrapping).
    pub feed_sum: i64,
    /// `Scheduler::push`/`drain`, per call.
    pub sched: Stat,
    /// `Motion::push` (accepted points), per call.
    pub push: Stat,
    /// `Motion::tick`, per call.
    pub gen: Stat,
    /// `Motion::set_override`, per call.
    pub overrides: Stat,
    /// Ticks moving with speed > 0.
    pub moving_ticks: u32,
    /// Entries into `Starved` from `Moving`.
    pub underruns: u32,
    /// Where the tool ended.
    pub end: Point3Mm,
}

/// Bring a new planner to rest at `pos`, as the firmware does at reset: a
/// one-point path, ended (the next path starts with `Motion::restart`).
pub fn anchor<const N: usize>(m: &mut Motion<N>, pos: Point3Mm) -> Result<(), MotionError> {
    m.push(MotionPoint {
        pos,
        ..MotionPoint::default()
    })?;
    m.end_path();
    Ok(())
}

/// Whether a path's first point `p` is where the tool already is (`here`):
/// then it is not pushed. `Motion::restart` made the tool's position the
/// path's start (index 0), and pushing the same position again adds a
/// zero-length first move whose node keeps the start's stop ceiling, which
/// then caps the next segment when it is short: on a line of 0.05 mm
/// segments the tool would creep over the first one for 5 s (a limitation
/// of `fuzzy_core::planner`, see `firmware/README.md`). The firmware's
/// `Planner` does the same.
pub fn already_there(p: &MotionPoint, here: Point3Mm) -> bool {
    p.pos == here
}

/// Longest run, ticks (far beyond any test path).
const TICK_GUARD: u32 = 2_000_000;

/// A run in progress.
struct Run<'a, const N: usize, C, F> {
    motion: &'a mut Motion<N>,
    events: bool,
    clock: &'a mut C,
    on_tick: F,
    r: Report,
    sum: Checksum,
    starve_until: u32,
    last: MotionState,
    /// Where the tool is, until the path's first point was taken.
    start: Option<Point3Mm>,
}

impl<const N: usize, C: Clock, F: FnMut(&Motion<N>, &Tick)> Run<'_, N, C, F> {
    /// One tick (after the events due at it).
    fn tick(&mut self) -> Result<MotionState, ReplayError> {
        if self.r.ticks >= TICK_GUARD {
            return Err(ReplayError::NeverDone(self.r.ticks));
        }
        if self.events {
            for (at, e) in EVENTS {
                if at != self.r.ticks {
                    continue;
                }
                match e {
                    Event::Hold(on) => self.motion.set_hold(on),
                    Event::Override(p) => {
                        let t0 = self.clock.now();
                        self.motion.set_override(p);
                        self.r.overrides.add(self.clock.since(t0));
                    }
                    Event::StarveUntil(t) => self.starve_until = t,
                }
            }
        }
        let t0 = self.clock.now();
        let t = self.motion.tick();
        self.r.gen.add(self.clock.since(t0));
        self.sum.add_pos(t.pos);
        if t.speed > 0 {
            self.r.moving_ticks += 1;
        }
        if self.last == MotionState::Moving && t.state == MotionState::Starved {
            self.r.underruns += 1;
        }
        self.last = t.state;
        self.r.ticks += 1;
        self.r.end = t.pos;
        (self.on_tick)(self.motion, &t);
        Ok(t.state)
    }

    /// Push a scheduled point, ticking while the planner is full (or
    /// starved by an event).
    fn feed(&mut self, s: &ScheduledPoint) -> Result<(), ReplayError> {
        self.r.points += 1;
        self.r.feed_sum = self.r.feed_sum.wrapping_add(s.feed.0.to_bits());
        let p = MotionPoint::from(s);
        if let Some(here) = self.start.take() {
            if already_there(&p, here) {
                return Ok(());
            }
        }
        loop {
            if self.r.ticks < self.starve_until {
                self.tick()?;
                continue;
            }
            let t0 = self.clock.now();
            let res = self.motion.push(p);
            let dt = self.clock.since(t0);
            match res {
                Ok(()) => {
                    self.r.push.add(dt);
                    return Ok(());
                }
                Err(MotionError::Full) => {
                    self.tick()?;
                }
                Err(e) => return Err(ReplayError::Motion(e)),
            }
        }
    }
}

/// One path with the fixed policy (module docs), the scheduler set to
/// `config`, the tool at rest at `here`. `on_tick` sees every tick once it
/// is generated.
pub fn run<const N: usize, C: Clock>(
    motion: &mut Motion<N>,
    config: SchedulerConfig,
    here: Point3Mm,
    path: impl Iterator<Item = Point3Mm>,
    events: bool,
    clock: &mut C,
    on_tick: impl FnMut(&Motion<N>, &Tick),
) -> Result<Report, ReplayError> {
    let mut sched = Sched::new(&COMPACT, config).map_err(ReplayError::Scheduler)?;
    motion.restart().map_err(ReplayError::Motion)?;
    motion.set_hold(false);
    motion.set_override(100);
    let mut run = Run {
        motion,
        events,
        clock,
        on_tick,
        r: Report {
            end: here,
            ..Report::default()
        },
        sum: Checksum::default(),
        starve_until: 0,
        last: MotionState::Idle,
        start: Some(here),
    };
    for (i, pos) in path.enumerate() {
        let t0 = run.clock.now();
        let out = sched.push(PathPoint {
            pos,
            feed_cap: None,
            tag: i as u32,
        });
        run.r.sched.add(run.clock.since(t0));
        if let Some(s) = out.map_err(ReplayError::Scheduler)? {
            run.feed(&s)?;
        }
    }
    sched.finish();
    loop {
        let t0 = run.clock.now();
        let out = sched.drain();
        let dt = run.clock.since(t0);
        let Some(s) = out else { break };
        run.r.sched.add(dt);
        run.feed(&s)?;
    }
    run.motion.end_path();
    while run.tick()? != MotionState::Done {}
    run.r.positions = run.sum.0;
    Ok(run.r)
}
