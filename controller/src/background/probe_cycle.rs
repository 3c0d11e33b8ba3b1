//! The probing move in the background pass (`crate::probe` has the cycle
//! and Grbl's): the path before it ended, the probe's initial state
//! checked, the move planned with the tick armed, the stop on a trip, the
//! report once the tool is at rest.

use fuzzy_core::planner::MotionState;
use fuzzy_core::units::Point3Mm;
use link::{AlarmCode, DeviceMsg};
use rtic_core::Mutex;

use super::{reached, report, Background, Notice};
use crate::config::Key;
use crate::probe::ProbeCmd;
use crate::session::DeviceLink;
use crate::settings::SETPOINT_RING;
use crate::stepper::SETTLE_TICKS;

/// Where a probing move is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Stage {
    /// The path before it ending; `at`: the generated tick from which the
    /// tick has executed the rest at its end.
    Before { at: Option<u32> },
    /// Moving to the target, the tick armed (the move's end is its point
    /// 1 reached at rest).
    Moving,
    /// Tripped at `trip`: stopping as a feed hold does, then the rest of
    /// the move dropped.
    Stopping { trip: Point3Mm },
    /// The planner at rest: the tick and the steps catching up until
    /// generated tick `at`, then the report.
    Ending { trip: Option<Point3Mm>, at: u32 },
}

/// A probing move in progress.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Probing {
    cmd: ProbeCmd,
    stage: Stage,
}

impl Probing {
    pub(super) fn new(cmd: ProbeCmd) -> Self {
        Probing {
            cmd,
            stage: Stage::Before { at: None },
        }
    }

    /// Stopping on a trip: a resume must not release that stop.
    pub(super) fn stopping(&self) -> bool {
        matches!(self.stage, Stage::Stopping { .. })
    }
}

impl Background<'_> {
    /// Generated ticks from the planner's last move until the tick has
    /// executed it, the steps are out and a change of the input they
    /// caused is through the debounce.
    fn probe_settle_ticks(&self) -> u32 {
        let debounce = self.config.get(Key::Debounce).clamp(1, 255) as u32;
        SETPOINT_RING as u32 + SETTLE_TICKS as u32 + debounce
    }

    /// One pass of the probing move in progress; whether it did work.
    pub(super) fn probe_pass<L: Mutex<T = DeviceLink>>(
        &mut self,
        room: bool,
        link: &mut L,
        notice: &mut impl FnMut(Notice),
    ) -> bool {
        let Some(mut p) = self.probe else {
            return false;
        };
        if !room {
            return false;
        }
        let now = self.planning.generated();
        match p.stage {
            Stage::Before { mut at } => {
                // The path before it, as for a machine command.
                if let Some(busy) = self.drain_path_before(link, notice) {
                    return busy;
                }
                let done = self.planning.path_ended() && self.planning.state() == MotionState::Done;
                if !done {
                    at = None;
                } else {
                    let settle = self.probe_settle_ticks();
                    at.get_or_insert(now.wrapping_add(settle));
                }
                let ready = at.is_some_and(|t| reached(now, t)) && reached(now, self.hold_until);
                if !ready {
                    p.stage = Stage::Before { at };
                    self.probe = Some(p);
                    return false;
                }
                if p.cmd.tripped(self.latch.inputs()) {
                    self.probe = None;
                    self.latch.trip(AlarmCode::ProbeFailInitial);
                    return true;
                }
                self.latch.probe.arm(p.cmd.toward);
                match self
                    .planning
                    .single_move(p.cmd.target, p.cmd.feed, p.cmd.seq)
                {
                    Ok(inputs) => {
                        for input in inputs.into_iter().flatten() {
                            report(link, input, notice);
                        }
                        p.stage = Stage::Moving;
                    }
                    Err(e) => {
                        // Cannot happen: the planner is at rest and empty.
                        notice(Notice::PlannerRefused(e));
                        self.latch.probe.disarm();
                        self.probe = None;
                        return true;
                    }
                }
            }
            Stage::Moving => {
                if let Some(trip) = self.latch.probe.take_trip() {
                    let input = self.planning.abort();
                    report(link, input, notice);
                    p.stage = Stage::Stopping { trip };
                } else if self.planning.path_ended()
                    && self.planning.state() == MotionState::Done
                    && self.planning.point_reached() >= 1
                {
                    p.stage = Stage::Ending {
                        trip: None,
                        at: now.wrapping_add(self.probe_settle_ticks()),
                    };
                } else {
                    return false;
                }
            }
            Stage::Stopping { trip } => {
                if self.planning.take_aborted().is_none() {
                    return false;
                }
                p.stage = Stage::Ending {
                    trip: Some(trip),
                    at: now.wrapping_add(SETPOINT_RING as u32),
                };
            }
            Stage::Ending { trip, at } => {
                if !reached(now, at) {
                    return false;
                }
                self.latch.probe.disarm();
                self.probe = None;
                let seq = p.cmd.seq;
                match trip.or_else(|| self.latch.probe.take_trip()) {
                    Some(pos) => self.post(DeviceMsg::Probed {
                        seq,
                        pos_mm: pos.to_bits(),
                        tripped: true,
                    }),
                    None if p.cmd.error_if_missed => self.latch.trip(AlarmCode::ProbeFailContact),
                    None => self.post(DeviceMsg::Probed {
                        seq,
                        pos_mm: self.planning.position().to_bits(),
                        tripped: false,
                    }),
                }
                return true;
            }
        }
        self.probe = Some(p);
        true
    }
}
