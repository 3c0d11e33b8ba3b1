//! Whole paths through the controller's scheduler and planner with a
//! fixed, deterministic order of pushes and ticks: what the cost benchmark
//! (`firmware/src/bin/cost.rs`, on the Cortex-M4 in QEMU) and its host
//! twin (`tests/tests/firmware_qemu.rs`) both run, so that equal checksums
//! of the commanded positions show the planner computes the same bits on
//! the target as on the host.
//!
//! It runs the firmware's own stages ([`Feeder`], [`Planning`]); only the
//! driver differs from the firmware's background: instead of filling a
//! ring and taking one command a pass, each path goes `StartPath`, its
//! points, `EndPath`; each scheduled point enters the planner as soon as
//! the planner has room, and while it is full the planner ticks once and
//! tries again; at the end the planner ticks until it is done. With
//! [`EVENTS`] a feed hold, override changes and a starved stretch (no
//! pushes) happen at fixed ticks of the path.

use fuzzy_core::planner::{MotionError, MotionState, Tick};
use fuzzy_core::scheduler::{ScheduledPoint, SchedulerConfig, SchedulerError};
use fuzzy_core::units::{Point3Mm, SpeedMmPerTick};

use crate::checksum::Checksum;
use crate::command::Cmd;
use crate::controls::Controls;
use crate::feeder::Feeder;
use crate::planning::{Dropped, Planning};
use crate::settings::Plan;

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

impl From<Dropped> for ReplayError {
    fn from(d: Dropped) -> Self {
        ReplayError::Motion(d.0)
    }
}

impl From<SchedulerError> for ReplayError {
    fn from(e: SchedulerError) -> Self {
        ReplayError::Scheduler(e)
    }
}

/// What a run measured and produced.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Report {
    /// Scheduled points.
    pub points: u32,
    /// Ticks until done.
    pub ticks: u32,
    /// Checksum of every commanded position of the run.
    pub positions: u64,
    /// Sum of the scheduled feeds (I32F32 bits, wrapping).
    pub feed_sum: i64,
    /// The scheduler's step (`Scheduler::push`/`drain` behind
    /// `Feeder::command`/`drain`), per call.
    pub sched: Stat,
    /// A scheduled point into the planner (accepted points), per call.
    pub push: Stat,
    /// One generated tick, per call.
    pub gen: Stat,
    /// An override change (the planner re-plans its buffer), per call.
    pub overrides: Stat,
    /// Ticks moving with speed > 0.
    pub moving_ticks: u32,
    /// Entries into `Starved` from `Moving`.
    pub underruns: u32,
    /// Where the tool ended.
    pub end: Point3Mm,
}

/// Longest run, ticks (far beyond any test path).
const TICK_GUARD: u32 = 2_000_000;

/// The controller's scheduler and planner, kept from path to path as in
/// the firmware.
pub struct Replay<'a> {
    feeder: Feeder,
    planning: Planning<'a>,
}

/// A run in progress.
struct Run<'r, 'a, C, F> {
    planning: &'r mut Planning<'a>,
    events: bool,
    clock: &'r mut C,
    on_tick: F,
    r: Report,
    sum: Checksum,
    starve_until: u32,
    last: MotionState,
}

impl<'a> Replay<'a> {
    /// The planner in `plan`, at rest at `start`; the scheduler with the
    /// firmware's default settings.
    pub fn new(plan: &'a mut Plan, start: Point3Mm) -> Result<Self, ReplayError> {
        Ok(Replay {
            feeder: Feeder::new()?,
            planning: Planning::new(plan, start).map_err(ReplayError::Motion)?,
        })
    }

    /// The planner.
    pub fn plan(&self) -> &Plan {
        self.planning.motion()
    }

    /// One path (module docs), the scheduler set to `config`, starting
    /// where the previous one ended. `on_tick` sees every tick once it is
    /// generated.
    pub fn run<C: Clock>(
        &mut self,
        config: SchedulerConfig,
        path: impl Iterator<Item = Point3Mm>,
        events: bool,
        clock: &mut C,
        on_tick: impl FnMut(&Plan, &Tick),
    ) -> Result<Report, ReplayError> {
        let feeder = &mut self.feeder;
        feeder.command(Cmd::StartPath(config))?;
        // Each path starts with the hold off and the override at 100 %.
        self.planning.apply(Controls {
            hold: Some(false),
            override_percent: Some(100),
            spindle_percent: None,
            force: None,
        });
        let mut run = Run {
            planning: &mut self.planning,
            events,
            clock,
            on_tick,
            r: Report::default(),
            sum: Checksum::default(),
            starve_until: 0,
            last: MotionState::Idle,
        };
        for (i, pos) in path.enumerate() {
            let t0 = run.clock.now();
            let out = feeder.command(Cmd::Point {
                pos,
                feed_cap: -1,
                tag: i as u32,
            });
            run.r.sched.add(run.clock.since(t0));
            if let Some(s) = out? {
                run.feed(&s)?;
            }
        }
        feeder.command(Cmd::EndPath)?;
        loop {
            let t0 = run.clock.now();
            let out = feeder.drain();
            let dt = run.clock.since(t0);
            let Some(s) = out else { break };
            run.r.sched.add(dt);
            run.feed(&s)?;
        }
        feeder.take_path_end();
        run.planning.end_path();
        while run.tick()? != MotionState::Done {}
        run.r.positions = run.sum.0;
        Ok(run.r)
    }
}

impl<C: Clock, F: FnMut(&Plan, &Tick)> Run<'_, '_, C, F> {
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
                    Event::Hold(on) => {
                        self.planning.apply(Controls {
                            hold: Some(on),
                            ..Controls::default()
                        });
                    }
                    Event::Override(p) => {
                        let t0 = self.clock.now();
                        self.planning.apply(Controls {
                            override_percent: Some(p),
                            ..Controls::default()
                        });
                        self.r.overrides.add(self.clock.since(t0));
                    }
                    Event::StarveUntil(t) => self.starve_until = t,
                }
            }
        }
        let t0 = self.clock.now();
        let t = self.planning.generate();
        self.r.gen.add(self.clock.since(t0));
        self.sum.add_pos(t.pos);
        if t.speed > SpeedMmPerTick::ZERO {
            self.r.moving_ticks += 1;
        }
        if self.last == MotionState::Moving && t.state == MotionState::Starved {
            self.r.underruns += 1;
        }
        self.last = t.state;
        self.r.ticks += 1;
        self.r.end = t.pos;
        (self.on_tick)(self.planning.motion(), &t);
        Ok(t.state)
    }

    /// A scheduled point into the planner, ticking while the planner is
    /// full (or starved by an event).
    fn feed(&mut self, s: &ScheduledPoint) -> Result<(), ReplayError> {
        self.r.points += 1;
        self.r.feed_sum = self.r.feed_sum.wrapping_add(s.feed.0.to_bits());
        self.planning.queue(s);
        loop {
            if self.r.ticks < self.starve_until {
                self.tick()?;
                continue;
            }
            let before = self.planning.planned();
            let t0 = self.clock.now();
            let res = self.planning.push_pending();
            let dt = self.clock.since(t0);
            if res?.is_some() {
                if self.planning.planned() > before {
                    self.r.push.add(dt);
                }
                return Ok(());
            }
            self.tick()?;
        }
    }
}
