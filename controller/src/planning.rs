//! Scheduled points into the velocity planner, setpoints out: the second
//! stage of the controller's motion path (`ScheduledPoint` → [`Planning`]
//! → [`Setpoint`] → the tick).
//!
//! The policy, stated once (the firmware, the cost benchmark's replay and
//! the host's check of the firmware all run this code):
//! - the planner starts at rest where the machine is (a one-point path,
//!   ended: [`anchor`]);
//! - a scheduled point waits ([`Planning::waiting`]) while the planner is
//!   full, and a point of a new path waits until the previous path is done
//!   (at rest at its end); then the planner restarts where the tool is;
//! - a new path's first point where the tool already is merges into the
//!   start instead of being pushed ([`already_there`]);
//! - hold, resume and override are applied between ticks, an override only
//!   when it changes;
//! - an abort drops a waiting point and holds; once the tool is at rest the
//!   planner's buffer is dropped (`Motion::restart`, the path ended where
//!   the tool is) and the hold released, so the next path starts there;
//! - every input the planner takes is returned as a [`PlanInput`] with the
//!   number of ticks generated before it, and every generated position
//!   goes into a [`Checksum`]: the link reports both, so a host that feeds
//!   the same inputs at the same ticks to its own planner computes the same
//!   setpoints bit for bit.

use fixed::types::I32F32;
use fuzzy_core::planner::{MotionError, MotionPoint, MotionState, Tick};
use fuzzy_core::scheduler::ScheduledPoint;
use fuzzy_core::units::{FeedMmPerMin, Point3Mm, SpeedMmPerTick};

use crate::checksum::Checksum;
use crate::controls::Controls;
use crate::ring::Producer;
use crate::settings::{Plan, PLANNER_POINTS, SETPOINT_RING};

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
    pub fn of(plan: &Plan, t: &Tick) -> Self {
        let bits = plan.speed_mm_per_min(t.speed).0.to_bits() >> 20;
        Setpoint {
            pos: t.pos,
            feed_q12: bits.clamp(0, u32::MAX as i64) as u32,
            state: t.state,
            moving: t.speed > SpeedMmPerTick::ZERO,
        }
    }
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
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Dropped(pub MotionError);

/// Bring a new planner to rest at `pos`, as the controller does at reset: a
/// one-point path, ended (the next path starts with `Motion::restart`).
pub fn anchor<const N: usize>(
    m: &mut fuzzy_core::planner::Motion<N>,
    pos: Point3Mm,
) -> Result<(), MotionError> {
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
/// segments the tool would creep over the first one.
pub fn already_there(p: &MotionPoint, here: Point3Mm) -> bool {
    p.pos == here
}

/// A scheduled point waiting to enter the planner.
#[derive(Clone, Copy, Debug)]
struct Pending {
    point: MotionPoint,
    seq: u32,
    index: u32,
}

/// The velocity planner and the policy that feeds it (module docs).
pub struct Planning<'a> {
    motion: &'a mut Plan,
    /// A scheduled point waiting for room in the planner (or for the end of
    /// the previous path).
    pending: Option<Pending>,
    /// State of the last generated tick.
    last: MotionState,
    /// Path index of the last point the planner reached.
    point: u32,
    /// The path's first point was where the tool already was (not pushed:
    /// the planner's index 0 is that point).
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
    checksum: Checksum,
    /// Points pushed on the current path (the planner's indices 1..).
    pushed: u32,
    /// Stopping for an abort: points dropped so far.
    aborting: Option<u32>,
    /// A completed abort, not yet taken: the points it dropped.
    aborted: Option<u32>,
}

impl<'a> Planning<'a> {
    /// The planner in `motion`, brought to rest at `start` ([`anchor`]).
    pub fn new(motion: &'a mut Plan, start: Point3Mm) -> Result<Self, MotionError> {
        anchor(motion, start)?;
        Ok(Planning {
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
            checksum: Checksum::default(),
            pushed: 0,
            aborting: None,
            aborted: None,
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

    /// Where the planner has the tool (its last generated tick).
    pub fn position(&self) -> Point3Mm {
        self.here
    }

    /// Ticks generated since boot.
    pub fn generated(&self) -> u32 {
        self.generated
    }

    /// Checksum of every generated position since boot.
    pub fn checksum(&self) -> Checksum {
        self.checksum
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

    /// Abort: drop the waiting point, stop on the path as for a hold; once
    /// at rest the buffer is dropped ([`Self::take_aborted`] then says how
    /// many points were dropped in all). The event to report.
    pub fn abort(&mut self) -> PlanInput {
        let dropped = self.pending.take().is_some() as u32;
        self.aborting = Some(self.aborting.unwrap_or(0).wrapping_add(dropped));
        self.motion.set_hold(true);
        self.event(link::PlanEvent::Abort)
    }

    /// Whether an abort is stopping the tool.
    pub fn is_aborting(&self) -> bool {
        self.aborting.is_some()
    }

    /// A completed abort, once: the points it dropped (waiting, buffered,
    /// not reached).
    pub fn take_aborted(&mut self) -> Option<u32> {
        self.aborted.take()
    }

    /// Take a scheduled point (only when not [`Self::waiting`]); what the
    /// planner took, if anything (the point may wait: [`Self::push_pending`]).
    pub fn take_point(&mut self, s: &ScheduledPoint) -> Result<Option<PlanInput>, Dropped> {
        self.queue(s);
        self.push_pending()
    }

    /// The path's last point was taken: end the planner's path.
    pub fn end_path(&mut self) -> PlanInput {
        self.motion.end_path();
        self.ended = true;
        self.event(link::PlanEvent::EndPath)
    }

    /// Make `s` the waiting point (replacing one that waits: call only when
    /// not [`Self::waiting`]); [`Self::push_pending`] pushes it.
    pub fn queue(&mut self, s: &ScheduledPoint) {
        self.pending = Some(Pending {
            point: MotionPoint::from(s),
            seq: s.point.tag,
            index: s.index,
        });
    }

    /// A path of one straight move to `pos` at `feed` (a probing move,
    /// `crate::probe`; call at rest with nothing waiting): the move's
    /// point, reported as point 1 of its path with sequence number `seq`,
    /// then the path's end. What the planner took, in order.
    pub fn single_move(
        &mut self,
        pos: Point3Mm,
        feed: FeedMmPerMin,
        seq: u32,
    ) -> Result<[Option<PlanInput>; 2], Dropped> {
        self.pending = Some(Pending {
            point: MotionPoint {
                pos,
                feed,
                curvature: fuzzy_core::units::CurvaturePerMm::ZERO,
            },
            seq,
            index: 1,
        });
        let point = self.push_pending()?;
        if self.pending.take().is_some() {
            return Err(Dropped(MotionError::Full));
        }
        Ok([point, Some(self.end_path())])
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
            self.pushed = 0;
            self.merged = already_there(&p.point, self.here);
            if self.merged {
                self.pending = None;
                return Ok(Some(input));
            }
        }
        match self.motion.push(p.point) {
            Ok(()) => {
                self.pending = None;
                self.pushed = self.pushed.wrapping_add(1);
                Ok(Some(input))
            }
            Err(MotionError::Full | MotionError::PathEnded) => Ok(None),
            Err(e) => {
                self.pending = None;
                Err(Dropped(e))
            }
        }
    }

    /// One tick of the planner.
    pub fn generate(&mut self) -> Tick {
        let t = self.motion.tick();
        if self.last == MotionState::Moving && t.state == MotionState::Starved {
            self.underruns = self.underruns.wrapping_add(1);
        }
        self.last = t.state;
        self.point = t.point;
        self.here = t.pos;
        self.generated = self.generated.wrapping_add(1);
        self.checksum.add_pos(t.pos);
        if let Some(dropped) = self.aborting {
            if self.motion.at_rest() {
                self.finish_abort(dropped);
            }
        }
        t
    }

    /// The state of the last generated tick.
    pub fn state(&self) -> MotionState {
        self.last
    }

    /// Whether the planner's path was ended (a point starts a new one).
    pub fn path_ended(&self) -> bool {
        self.ended
    }

    /// Rebuild the planner with `config` at rest at `pos` (an alarm, a
    /// homing cycle, new settings): whatever it held, a waiting point and
    /// an abort in progress are dropped; the counters and the checksum go
    /// on. `config` is refused (and nothing changes) if the planner does
    /// not take it. The event to report.
    pub fn reset(
        &mut self,
        config: fuzzy_core::planner::MotionConfig,
        pos: Point3Mm,
    ) -> Result<PlanInput, fuzzy_core::planner::ConfigError> {
        self.rebuild(config, pos, None)
    }

    /// [`Self::reset`], reported as `event` (a path control's settings)
    /// instead of `PlanEvent::Reset` if given.
    pub fn rebuild(
        &mut self,
        config: fuzzy_core::planner::MotionConfig,
        pos: Point3Mm,
        event: Option<link::PlanEvent>,
    ) -> Result<PlanInput, fuzzy_core::planner::ConfigError> {
        config.validate()?;
        *self.motion = Plan::new(config)?;
        // A fresh planner takes its first point.
        let _ = anchor(self.motion, pos);
        self.pending = None;
        self.last = MotionState::Done;
        self.point = 0;
        self.merged = false;
        self.ended = true;
        self.here = pos;
        self.pushed = 0;
        self.aborting = None;
        self.aborted = None;
        if self.override_percent != 100 {
            self.motion.set_override(self.override_percent);
        }
        Ok(self.event(event.unwrap_or(link::PlanEvent::Reset {
            pos_mm: pos.to_bits(),
        })))
    }

    /// At rest after an abort: drop what is buffered, end the path here.
    fn finish_abort(&mut self, dropped: u32) {
        let unreached = self.pushed.saturating_sub(self.point);
        // At rest: `restart` cannot refuse.
        let _ = self.motion.restart();
        self.motion.end_path();
        self.motion.set_hold(false);
        self.ended = true;
        self.pushed = 0;
        self.aborting = None;
        self.aborted = Some(dropped.wrapping_add(unreached));
    }

    /// Fill the ring; returns how many setpoints were added.
    pub fn fill(&mut self, ring: &mut Producer<'_, Setpoint, SETPOINT_RING>) -> usize {
        let mut n = 0;
        while ring.ready() {
            let t = self.generate();
            let _ = ring.enqueue(Setpoint::of(self.motion, &t));
            n += 1;
        }
        n
    }
}
