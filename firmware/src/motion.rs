//! The motion pipeline of the controller, without the chip:
//!
//! ```text
//! link (USART task) ──Cmd──► [ring] ──► idle: Feeder (fuzzy scheduler)
//!     ──ScheduledPoint──► Planner (velocity planner, fuzzy_core::planner,
//!     ticks generated ahead) ──Setpoint──► [ring] ──► tick interrupt:
//!     Executor (one setpoint per tick, step/dir outputs)
//! ```
//!
//! [`Motion::tick`] costs too much for the tick interrupt in the worst case
//! (tens of thousands of instructions), so, like Grbl's segment buffer, the
//! background generates the ticks ahead into a small ring of setpoints
//! ([`SETPOINT_RING`]` − 1` ticks) and the interrupt only takes the next one
//! ([`Executor::tick`]). Feed hold, resume and override reach the planner
//! from the background, so they take effect after the setpoints already in
//! the ring: within `SETPOINT_RING − 1` ticks. An empty ring at a tick (the
//! background fell behind; never seen in the tests) holds the position and
//! is counted ([`Executor::empty_ticks`]).
//!
//! The same code runs in the application (`src/main.rs`) and the cost
//! benchmark (`src/bin/cost.rs`).

use core::mem::MaybeUninit;

use crate::ring::{Consumer, Producer};
use fixed::types::I32F32;
use fuzzy_core::njiri::{self, ForceN, ForceOverride, NjiriCompact, OverrideConfig, OverrideError};
use fuzzy_core::planner::{Motion, MotionError, MotionPoint, MotionState, Tick};
use fuzzy_core::scheduler::{PathPoint, ScheduledPoint, SchedulerConfig, SchedulerError};
use fuzzy_core::units::{FeedMmPerMin, Fx, Point3Mm};

use crate::config::{MOTION_CONFIG, PLANNER_POINTS, SCHED_CONFIG};
use crate::replay;
pub use crate::replay::Sched;
use crate::stepper::StepOutput;

#[allow(unused_imports)] // for the docs
use crate::config::SETPOINT_RING;

/// The velocity planner as configured for the firmware.
pub type Plan = Motion<PLANNER_POINTS>;

/// A command that travels through the queue in order with the points
/// (40 bytes: the queue's slots are most of the link's RAM).
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum Cmd {
    /// Start a path with these settings (ends an open path first).
    StartPath(SchedulerConfig),
    /// The next point.
    Point {
        /// Position.
        pos: Point3Mm,
        /// Feed cap, mm/min (I32F32 bits; negative: none).
        feed_cap: i64,
        /// Its sequence number.
        tag: u32,
    },
    /// End of the path: flush the lookahead.
    EndPath,
}

impl Cmd {
    /// A point command.
    pub fn point(p: PathPoint) -> Cmd {
        Cmd::Point {
            pos: p.pos,
            feed_cap: p.feed_cap.map_or(-1, |f| f.0.to_bits()),
            tag: p.tag,
        }
    }
}

/// The scheduler side of the pipeline (idle priority).
pub struct Feeder {
    sched: Sched,
    draining: bool,
    after_drain: Option<SchedulerConfig>,
}

/// What one [`Feeder`] step produced.
// Returned by value once per step and consumed at once: no heap to box into.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Output {
    /// Nothing (a point entered the lookahead, or a setting changed).
    Nothing,
    /// A scheduled point.
    Point(ScheduledPoint),
    /// The path is complete.
    PathEnd,
}

impl Feeder {
    /// A feeder with the default settings.
    pub fn new() -> Result<Self, SchedulerError> {
        Ok(Feeder {
            sched: Sched::new(&fuzzy_core::lin2021::COMPACT, SCHED_CONFIG)?,
            draining: false,
            after_drain: None,
        })
    }

    /// Whether it is flushing a finished path (then [`Self::drain`], not
    /// [`Self::command`]).
    pub fn is_draining(&self) -> bool {
        self.draining
    }

    /// Points held in the lookahead.
    pub fn held(&self) -> usize {
        self.sched.held()
    }

    /// Take the next queued command. At most one output per call.
    pub fn command(&mut self, cmd: Cmd) -> Result<Output, SchedulerError> {
        match cmd {
            Cmd::Point { pos, feed_cap, tag } => match self.sched.push(PathPoint {
                pos,
                feed_cap: (feed_cap >= 0).then_some(FeedMmPerMin(I32F32::from_bits(feed_cap))),
                tag,
            })? {
                Some(s) => Ok(Output::Point(s)),
                None => Ok(Output::Nothing),
            },
            Cmd::EndPath => {
                self.sched.finish();
                self.draining = true;
                Ok(Output::Nothing)
            }
            Cmd::StartPath(config) => {
                config.validate()?;
                if self.sched.held() > 0 {
                    // An open path ends where the new one starts.
                    self.sched.finish();
                    self.draining = true;
                    self.after_drain = Some(config);
                } else {
                    self.sched.set_config(config)?;
                }
                Ok(Output::Nothing)
            }
        }
    }

    /// While draining: the next point of the finished path, then
    /// [`Output::PathEnd`] once.
    pub fn drain(&mut self) -> Output {
        if !self.draining {
            return Output::Nothing;
        }
        match self.sched.drain() {
            Some(s) => Output::Point(s),
            None => {
                self.draining = false;
                if let Some(c) = self.after_drain.take() {
                    // Validated when it was queued.
                    let _ = self.sched.set_config(c);
                }
                Output::PathEnd
            }
        }
    }
}

/// Feed hold, resume and override requests and force samples from the
/// link, taken by the background at its next pass.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Controls {
    /// `Some(true)`: hold; `Some(false)`: resume.
    pub hold: Option<bool>,
    /// New feed override, percent (already range-checked).
    pub override_percent: Option<u16>,
    /// Peak forces `[F_x, F_y]` of the last revolution (non-negative,
    /// checked); a sample not yet taken is replaced by the next one.
    pub force: Option<[ForceN; 2]>,
}

/// Njiri et al.'s force-feedback override (`fuzzy_core::njiri`) as the
/// firmware runs it: the paper's settings ([`OverrideConfig::PAPER`]) on
/// the compact controller ([`njiri::COMPACT`], same outputs as the host's),
/// one step per force sample; its output replaces the feed override.
/// Under 100 bytes: it lives on the background's stack.
pub struct ForceLoop(ForceOverride<'static, NjiriCompact>);

impl ForceLoop {
    /// At 100 %, no history.
    pub fn new() -> Result<Self, OverrideError> {
        ForceOverride::new(&njiri::COMPACT, OverrideConfig::PAPER).map(ForceLoop)
    }

    /// If `c` carries a force sample, step the controller and put its
    /// override, rounded to a percent and at least
    /// [`link::OVERRIDE_MIN_PERCENT`], in `c.override_percent` (it wins
    /// over a manual override taken in the same pass).
    pub fn apply(&mut self, c: &mut Controls) {
        if let Some(peak) = c.force.take() {
            let pct = self.0.step(peak).0.to_bits();
            // 0-150 % in Q16.16: rounded, within the planner's range.
            let p = ((pct.max(0) as u32 + 0x8000) >> 16) as u16;
            c.override_percent =
                Some(p.clamp(link::OVERRIDE_MIN_PERCENT, link::OVERRIDE_MAX_PERCENT));
        }
    }
}

/// A force sample from the link's raw fields (newtons, Q16.16 bits), if
/// both are magnitudes (non-negative).
pub fn force_from_link(fx_n_q16: i32, fy_n_q16: i32) -> Option<[ForceN; 2]> {
    (fx_n_q16 >= 0 && fy_n_q16 >= 0).then(|| {
        [
            ForceN(Fx::from_bits(fx_n_q16)),
            ForceN(Fx::from_bits(fy_n_q16)),
        ]
    })
}

/// One tick's commanded motion, from the planner to the tick interrupt
/// (32 bytes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Setpoint {
    /// Commanded position, mm.
    pub pos: Point3Mm,
    /// Tangential speed, mm/min in Q12 (1/4096 mm/min, up to 10^6 mm/min).
    pub feed_q12: u32,
    /// The planner's state.
    pub state: MotionState,
    /// The tool moves during this tick (speed > 0).
    pub moving: bool,
}

impl Setpoint {
    /// At rest at `pos`, nothing to do.
    pub const fn at_rest(pos: Point3Mm) -> Self {
        Setpoint {
            pos,
            feed_q12: 0,
            state: MotionState::Idle,
            moving: false,
        }
    }

    /// Tangential speed.
    pub fn feed(&self) -> FeedMmPerMin {
        FeedMmPerMin(I32F32::from_bits((self.feed_q12 as i64) << 20))
    }

    /// The setpoint of a planner tick (`plan` converts its speed).
    pub fn of<const N: usize>(plan: &Motion<N>, t: &Tick) -> Self {
        let bits = plan.speed_mm_per_min(t.speed).0.to_bits() >> 20;
        Setpoint {
            pos: t.pos,
            feed_q12: bits.clamp(0, u32::MAX as i64) as u32,
            state: t.state,
            moving: t.speed > 0,
        }
    }
}

/// The planner side of the pipeline (idle priority): scheduled points into
/// the velocity planner, its ticks into the setpoint ring.
///
/// Every input the planner takes is returned as a [`PlanInput`] with the
/// number of ticks generated before it (`Planner::generated`), and every
/// generated position goes into a checksum: the link reports both, so that
/// the host can replay the same inputs at the same ticks into its own
/// planner and check the firmware's motion bit for bit
/// (`tests/src/planned.rs`).
pub struct Planner {
    motion: &'static mut Plan,
    /// A scheduled point waiting for room in the planner (or for the end of
    /// the previous path).
    pending: Option<Pending>,
    /// State of the last generated tick.
    last: MotionState,
    /// Path index of the last point the planner reached.
    point: u32,
    /// The path's first point was where the tool already was (not pushed:
    /// the planner's index 0 is that point; see [`replay::already_there`]).
    merged: bool,
    /// The planner's path was ended (a point starts a new one).
    ended: bool,
    /// Where the planner has the tool (its last generated tick).
    here: Point3Mm,
    underruns: u32,
    override_percent: u16,
    /// Ticks generated since boot.
    generated: u32,
    /// Of every generated position since boot.
    checksum: replay::Checksum,
}

/// A scheduled point waiting to enter the planner.
#[derive(Clone, Copy, Debug)]
struct Pending {
    point: MotionPoint,
    seq: u32,
    index: u32,
}

/// An input the planner took, after `tick` generated ticks (reported on the
/// link: `DeviceMsg::Scheduled` and `DeviceMsg::Planned`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlanInput {
    /// A scheduled point went in (or, as the first point of a path where
    /// the tool already was, merged into the start).
    Point {
        /// Its sequence number (the scheduler's tag).
        seq: u32,
        /// Its index in the path.
        index: u32,
        /// Its scheduled feed, mm/min, I32F32 bits.
        feed_bits: i64,
        /// Ticks generated before.
        tick: u32,
    },
    /// A command.
    Event {
        /// Ticks generated before.
        tick: u32,
        /// What.
        event: link::PlanEvent,
    },
}

impl PlanInput {
    /// As a link message.
    pub fn to_msg(self) -> link::DeviceMsg {
        match self {
            PlanInput::Point {
                seq,
                index,
                feed_bits,
                tick,
            } => link::DeviceMsg::Scheduled {
                seq,
                index,
                feed_mm_per_min: feed_bits,
                tick,
            },
            PlanInput::Event { tick, event } => link::DeviceMsg::Planned { tick, event },
        }
    }
}

/// Why the planner refused a point the scheduler released (cannot happen:
/// the link checks every value).
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub struct Dropped(pub MotionError);

impl Planner {
    /// The planner in `motion` (built with [`MOTION_CONFIG`]), brought to
    /// rest at `start`.
    pub fn new(motion: &'static mut Plan, start: Point3Mm) -> Result<Self, MotionError> {
        crate::replay::anchor(motion, start)?;
        Ok(Planner {
            motion,
            pending: None,
            last: MotionState::Done,
            point: 0,
            merged: false,
            ended: true,
            here: start,
            underruns: 0,
            override_percent: 100,
            generated: 0,
            checksum: replay::Checksum::default(),
        })
    }

    /// The planner (for measurements and settings).
    pub fn motion(&self) -> &Plan {
        self.motion
    }

    /// Whether a scheduled point waits (for room, or for the previous path
    /// to end).
    pub fn waiting(&self) -> bool {
        self.pending.is_some()
    }

    /// Points in the planner.
    pub fn planned(&self) -> usize {
        PLANNER_POINTS - self.motion.free()
    }

    /// Index in the current path of the last point the planner reached
    /// (0: where the path started; it runs up to the ring's depth ahead of
    /// the tool).
    pub fn point_reached(&self) -> u32 {
        self.point.wrapping_add(self.merged as u32)
    }

    /// Entries into `Starved` while moving: the path stopped arriving.
    pub fn underruns(&self) -> u32 {
        self.underruns
    }

    /// The feed override in force, percent.
    pub fn override_percent(&self) -> u16 {
        self.override_percent
    }

    /// Ticks generated since boot.
    pub fn generated(&self) -> u32 {
        self.generated
    }

    /// Checksum of every generated position since boot, 64-bit FNV-1a
    /// folded to 32 bits (high ⊕ low), as `link::Status` carries it.
    pub fn checksum32(&self) -> u32 {
        (self.checksum.0 ^ (self.checksum.0 >> 32)) as u32
    }

    fn event(&self, event: link::PlanEvent) -> PlanInput {
        PlanInput::Event {
            tick: self.generated,
            event,
        }
    }

    /// Apply hold/resume/override requests; what was applied, in order.
    pub fn apply(&mut self, c: Controls) -> [Option<PlanInput>; 2] {
        let mut out = [None, None];
        if let Some(hold) = c.hold {
            self.motion.set_hold(hold);
            out[0] = Some(self.event(if hold {
                link::PlanEvent::Hold
            } else {
                link::PlanEvent::Resume
            }));
        }
        if let Some(p) = c.override_percent {
            if p != self.override_percent {
                self.override_percent = p;
                self.motion.set_override(p);
                out[1] = Some(self.event(link::PlanEvent::Override(p)));
            }
        }
        out
    }

    /// Take a scheduler output (only when not [`Self::waiting`]); what the
    /// planner took, if anything (a point may wait: [`Self::push_pending`]).
    pub fn take(&mut self, out: Output) -> Result<Option<PlanInput>, Dropped> {
        match out {
            Output::Point(s) => {
                self.pending = Some(Pending {
                    point: MotionPoint::from(&s),
                    seq: s.point.tag,
                    index: s.index,
                });
                self.push_pending()
            }
            Output::PathEnd => {
                self.motion.end_path();
                self.ended = true;
                Ok(Some(self.event(link::PlanEvent::EndPath)))
            }
            Output::Nothing => Ok(None),
        }
    }

    /// Push the waiting point if there is room: what went in. A point of a
    /// new path waits until the previous one is done, then the planner
    /// restarts where the tool is.
    pub fn push_pending(&mut self) -> Result<Option<PlanInput>, Dropped> {
        let Some(p) = self.pending else {
            return Ok(None);
        };
        let input = PlanInput::Point {
            seq: p.seq,
            index: p.index,
            feed_bits: p.point.feed.0.to_bits(),
            tick: self.generated,
        };
        if self.ended {
            if self.last != MotionState::Done {
                // The previous path is still running.
                return Ok(None);
            }
            // At rest at its end (`Done` is only reported at rest): the new
            // path starts here.
            self.motion.restart().map_err(Dropped)?;
            self.ended = false;
            self.point = 0;
            self.merged = replay::already_there(&p.point, self.here);
            if self.merged {
                self.pending = None;
                return Ok(Some(input));
            }
        }
        match self.motion.push(p.point) {
            Ok(()) => {
                self.pending = None;
                Ok(Some(input))
            }
            Err(MotionError::Full | MotionError::PathEnded) => Ok(None),
            Err(e) => {
                self.pending = None;
                Err(Dropped(e))
            }
        }
    }

    /// One tick of the planner as a setpoint.
    pub fn generate(&mut self) -> Setpoint {
        let t = self.motion.tick();
        if self.last == MotionState::Moving && t.state == MotionState::Starved {
            self.underruns = self.underruns.wrapping_add(1);
        }
        self.last = t.state;
        self.point = t.point;
        self.here = t.pos;
        self.generated = self.generated.wrapping_add(1);
        self.checksum.add_pos(t.pos);
        Setpoint::of(self.motion, &t)
    }

    /// Fill the ring; returns how many setpoints were added.
    pub fn fill(&mut self, ring: &mut Producer<'_, Setpoint, SETPOINT_RING>) -> usize {
        let mut n = 0;
        while ring.ready() {
            let _ = ring.enqueue(self.generate());
            n += 1;
        }
        n
    }
}

/// The tick interrupt's side: the setpoint in force and counters (also
/// what status replies report).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Executor {
    /// The setpoint in force.
    pub now: Setpoint,
    /// Ticks since reset.
    pub ticks: u32,
    /// Ticks with the ring empty (position held).
    pub empty_ticks: u32,
    /// Ticks with the tool moving (speed > 0) since the current path began
    /// to move.
    pub moving_ticks: u32,
    /// Worst tick interrupt so far, SysTick cycles (set by the caller).
    pub worst_cycles: u32,
    /// At rest at a path's start or end: the next motion starts a new count.
    rested: bool,
}

impl Executor {
    /// At rest at `start`.
    pub const fn new(start: Point3Mm) -> Self {
        Executor {
            now: Setpoint::at_rest(start),
            ticks: 0,
            empty_ticks: 0,
            moving_ticks: 0,
            worst_cycles: 0,
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
        self.now = sp;
    }
}

/// A point from the link's raw fields, if every value is in range for the
/// scheduler (so that an acknowledged point is never refused later).
pub fn point_from_link(
    seq: u32,
    pos_mm: [i64; 3],
    feed_cap_mm_per_min: Option<i64>,
) -> Option<PathPoint> {
    let pos = Point3Mm::from_bits(pos_mm[0], pos_mm[1], pos_mm[2]);
    if !pos.within_limits() {
        return None;
    }
    let feed_cap = match feed_cap_mm_per_min {
        Some(bits) => {
            let f = FeedMmPerMin(I32F32::from_bits(bits));
            if !f.within_limits() {
                return None;
            }
            Some(f)
        }
        None => None,
    };
    Some(PathPoint {
        pos,
        feed_cap,
        tag: seq,
    })
}

/// Scheduler settings from the link's raw fields, if valid.
pub fn config_from_link(f_max_bits: i64, f_min_bits: i64) -> Option<SchedulerConfig> {
    let c = SchedulerConfig::new(
        FeedMmPerMin(I32F32::from_bits(f_max_bits)),
        FeedMmPerMin(I32F32::from_bits(f_min_bits)),
    );
    c.validate().ok().map(|_| c)
}

/// A planner in `slot` (a static: 6.5 KB), with [`MOTION_CONFIG`].
pub fn new_plan(
    slot: &'static mut MaybeUninit<Plan>,
) -> Result<&'static mut Plan, fuzzy_core::planner::ConfigError> {
    Ok(slot.write(Plan::new(MOTION_CONFIG)?))
}
