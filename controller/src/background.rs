//! The background pass (the firmware's idle loop, lowest priority): force
//! loop, hold/resume/override into the planner, the setpoint ring kept
//! full, one scheduled point into the planner or one scheduler step,
//! credit, figures for status.
//!
//! Each pass, in order:
//! 1. if the transmit buffer has the background's reserve free: an abort
//!    (the scheduler's lookahead dropped, the planner stopping), then the
//!    controls the link received (a force sample first becomes an
//!    override: [`ForceLoop`]) go to the planner, each reported;
//! 2. the setpoint ring is filled (the planner runs `SETPOINT_RING − 1`
//!    ticks ahead of the tick interrupt);
//! 3. with the reserve free: a waiting scheduled point into the planner, or
//!    else one scheduler step (a point of a finished path being drained, or
//!    the next queued command; commands voided by an abort are dropped),
//!    its output to the planner, reported; while an abort is stopping the
//!    tool, nothing new enters the planner, and once it is done its report
//!    (`DeviceMsg::Aborted`) is sent;
//! 4. credit back to the host ([`DeviceLink::poll`]);
//! 5. the figures status replies report, when they changed.
//!
//! The shared part ([`DeviceLink`]) is reached through a lock
//! (`rtic_core::Mutex`: RTIC's resource proxies in the firmware, anything
//! on the host), held only for short sections.

use fuzzy_core::njiri::OverrideError;
use fuzzy_core::planner::{ConfigError, MotionError};
use fuzzy_core::scheduler::SchedulerError;
use fuzzy_core::units::Point3Mm;
use link::DeviceMsg;
use rtic_core::Mutex;

use crate::command::Cmd;
use crate::controls::{Controls, ForceLoop};
use crate::feeder::Feeder;
use crate::planning::{Dropped, PlanInput, Planning, Setpoint};
use crate::ring::{Consumer, Producer};
use crate::session::{BackgroundInfo, DeviceLink, Taken};
use crate::settings::{Plan, CMD_QUEUE, SETPOINT_RING};

/// Something worth a log line (the background cannot log by itself).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Notice {
    /// The scheduler released the last point of a path.
    PathScheduled,
    /// The scheduler refused a command (cannot happen: the link checks
    /// every value before it acknowledges).
    SchedulerRefused(SchedulerError),
    /// The planner refused a scheduled point (cannot happen, likewise).
    PlannerRefused(Dropped),
    /// A report of the planner's input found no transmit room (cannot
    /// happen: the reserve is checked first).
    ReportDropped,
    /// An abort completed: the tool is at rest, the path dropped.
    Aborted,
}

/// Why the background could not start.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StartError {
    /// Bad scheduler settings.
    Scheduler(SchedulerError),
    /// The planner refused the start point.
    Planner(MotionError),
    /// Bad force-loop settings.
    ForceLoop,
    /// Bad planner settings.
    PlannerSettings(ConfigError),
}

impl From<OverrideError> for StartError {
    fn from(_: OverrideError) -> Self {
        StartError::ForceLoop
    }
}

/// The background's state: scheduler, planner, force loop.
pub struct Background<'a> {
    feeder: Feeder,
    planning: Planning<'a>,
    force: ForceLoop,
    published: BackgroundInfo,
    /// An abort in progress: commands and points dropped so far.
    abort: Option<(u32, u32)>,
}

impl<'a> Background<'a> {
    /// At rest at `start`, with the planner in `plan`.
    pub fn new(plan: &'a mut Plan, start: Point3Mm) -> Result<Self, StartError> {
        Ok(Background {
            feeder: Feeder::new().map_err(StartError::Scheduler)?,
            planning: Planning::new(plan, start).map_err(StartError::Planner)?,
            force: ForceLoop::new()?,
            published: BackgroundInfo::default(),
            abort: None,
        })
    }

    /// The planning stage (figures, the planner's settings).
    pub fn planning(&self) -> &Planning<'a> {
        &self.planning
    }

    /// Fill the setpoint ring (before the first tick).
    pub fn fill(&mut self, setpoints: &mut Producer<'_, Setpoint, SETPOINT_RING>) -> usize {
        self.planning.fill(setpoints)
    }

    /// One pass (module docs); `stack_bytes` is the stack high-water mark
    /// to publish. Returns whether it did work (otherwise the caller may
    /// sleep until an interrupt, once the queues are idle too).
    pub fn step<L: Mutex<T = DeviceLink>>(
        &mut self,
        link: &mut L,
        cmds: &mut Consumer<'_, Cmd, CMD_QUEUE>,
        setpoints: &mut Producer<'_, Setpoint, SETPOINT_RING>,
        stack_bytes: u32,
        mut notice: impl FnMut(Notice),
    ) -> bool {
        let mut busy = false;
        let room = link.lock(|l| l.tx.has_reserve());

        // 1. Abort; hold, resume, override, force samples.
        if room && link.lock(|l| l.take_abort()) {
            busy = true;
            let points = self.feeder.abort();
            let (c, p) = self.abort.unwrap_or((0, 0));
            self.abort = Some((c, p.wrapping_add(points)));
            let input = self.planning.abort();
            report(link, input, &mut notice);
        }
        if room {
            let mut c = link.lock(|l| core::mem::take(&mut l.controls));
            self.force.apply(&mut c);
            if c != Controls::default() {
                for input in self.planning.apply(c).into_iter().flatten() {
                    report(link, input, &mut notice);
                }
            }
        }

        // 2. Keep the ring full.
        self.planning.fill(setpoints);

        // 3. A waiting point into the planner, or one scheduler step.
        if let Some((mut commands, points)) = self.abort {
            // Drop what the abort voided; report it once the tool is at rest.
            while link.lock(|l| l.drop_void(cmds)) {
                commands = commands.wrapping_add(1);
                busy = true;
            }
            self.abort = Some((commands, points));
            if let Some(planned) = self.planning.take_aborted() {
                let pos_mm = self.planning.position().to_bits();
                let msg = DeviceMsg::Aborted {
                    commands,
                    points: points.wrapping_add(planned),
                    pos_mm,
                };
                if !link.lock(|l| l.tx.send(&msg, 0)) {
                    notice(Notice::ReportDropped);
                }
                self.abort = None;
                notice(Notice::Aborted);
                busy = true;
            }
        } else if room && self.planning.waiting() {
            match self.planning.push_pending() {
                Ok(Some(input)) => {
                    busy = true;
                    report(link, input, &mut notice);
                }
                Ok(None) => {}
                Err(e) => notice(Notice::PlannerRefused(e)),
            }
        } else if room {
            let next = if self.feeder.is_draining() {
                busy = true;
                Ok(self.feeder.drain())
            } else {
                match link.lock(|l| l.take_command(cmds)) {
                    Taken::Live(cmd) => {
                        busy = true;
                        self.feeder.command(cmd)
                    }
                    // Voided by an abort the background has not seen yet
                    // cannot be: the abort is taken first (step 1).
                    Taken::Void => {
                        busy = true;
                        Ok(None)
                    }
                    Taken::Nothing => Ok(None),
                }
            };
            match next {
                Ok(Some(s)) => match self.planning.take_point(&s) {
                    Ok(Some(input)) => report(link, input, &mut notice),
                    Ok(None) => {}
                    Err(e) => notice(Notice::PlannerRefused(e)),
                },
                Ok(None) => {
                    if self.feeder.take_path_end() {
                        notice(Notice::PathScheduled);
                        let input = self.planning.end_path();
                        report(link, input, &mut notice);
                    }
                }
                Err(e) => notice(Notice::SchedulerRefused(e)),
            }
        }

        // 4. Credit.
        link.lock(|l| l.poll(busy));

        // 5. Figures for status replies.
        let p = &self.planning;
        let info = BackgroundInfo {
            points_held: self.feeder.held() as u16,
            planned: p.planned() as u16,
            point: p.point_reached(),
            underruns: p.underruns(),
            override_percent: p.override_percent(),
            stack: stack_bytes,
            generated: p.generated(),
            checksum: p.checksum().folded(),
        };
        if info != self.published {
            self.published = info;
            link.lock(|l| l.info = info);
        }
        busy
    }
}

/// Send what the planner took, if the host wants it (room was checked:
/// the reserve).
fn report<L: Mutex<T = DeviceLink>>(
    link: &mut L,
    input: PlanInput,
    notice: &mut impl FnMut(Notice),
) {
    if !link.lock(|l| !l.reports || l.tx.send(&input.to_msg(), 0)) {
        notice(Notice::ReportDropped);
    }
}
