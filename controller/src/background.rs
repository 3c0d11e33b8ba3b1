//! The background pass (the firmware's idle loop, lowest priority): force
//! loop, hold/resume/override into the planner, the setpoint ring kept
//! full, one scheduled point into the planner or one scheduler step,
//! credit, figures for status; and the machine around the motion: alarms,
//! homing, spindle and coolant, settings.
//!
//! Each pass, in order:
//! 1. settings changed over the link are taken (the planner rebuilt at
//!    rest if its settings changed, `PlanEvent::Reset`; changed step
//!    settings kept for the tick, [`Background::take_step_settings`]),
//!    and written to flash if asked (`DeviceMsg::Stored`);
//! 2. in the alarm state ([`crate::alarm`]): once the tick has stopped, the
//!    alarm is carried out: the scheduler's lookahead, the queued commands,
//!    a machine command or homing cycle in progress are dropped, the
//!    spindle and coolant stopped, the planner rebuilt at rest where the
//!    tool stopped (`PlanEvent::Reset`), and `DeviceMsg::Alarm` reported;
//!    then nothing runs until an unlock, which refills the ring before
//!    the tick runs again;
//! 3. during a homing cycle ([`crate::homing`]) the ring is filled by the
//!    cycle instead of the planner; at each halt on a switch the next move
//!    starts where the tool stopped; at the end the homed axes get their
//!    machine coordinates and the planner is rebuilt there;
//! 4. otherwise the motion: if the transmit buffer has the background's
//!    reserve free: an abort (the scheduler's lookahead dropped, the
//!    planner stopping), then the controls the link received (a force
//!    sample first becomes an override: [`ForceLoop`]) go to the planner,
//!    each reported; the setpoint ring is filled (the planner runs
//!    `SETPOINT_RING − 1` ticks ahead of the tick interrupt; a setpoint
//!    outside the travel, with soft limits on, trips the alarm instead of
//!    entering the ring); with the reserve free: a waiting scheduled point
//!    into the planner, or else one scheduler step (a point of a finished
//!    path being drained, or the next queued command; commands voided by
//!    an abort are dropped), its output to the planner, reported; while an
//!    abort is stopping the tool, nothing new enters the planner, and once
//!    it is done its report (`DeviceMsg::Aborted`) is sent. A machine
//!    command ends the path and waits until the tool is at rest at its end
//!    (the ring executed), then takes effect (`DeviceMsg::Applied`), and a
//!    spin-up delay or a dwell (`MachineCmd::Dwell`, G4) holds the next
//!    path back ([`crate::spindle`]); a probing move ends the path
//!    likewise, then runs as a path of its own and stops where the probe
//!    trips ([`crate::probe`], `DeviceMsg::Probed`);
//! 5. link silence and loss: a link silent for `$209` while the tool
//!    moves is a feed hold (the host is gone: what it queued must not run
//!    on without it); with the path open and the tool at rest (stopped for
//!    want of points, or held), a link silent for `$206` trips
//!    [`AlarmCode::LinkLoss`];
//! 6. credit back to the host ([`DeviceLink::poll`]); the machine's
//!    reports (alarm, homed, applied, stored) when the reserve is free;
//! 7. the figures status replies report, when they changed.
//!
//! The shared part ([`DeviceLink`]) is reached through a lock
//! (`rtic_core::Mutex`: RTIC's resource proxies in the firmware, anything
//! on the host), held only for short sections.

use fuzzy_core::njiri::OverrideError;
use fuzzy_core::planner::{ConfigError, MotionError, MotionState};
use fuzzy_core::scheduler::SchedulerError;
use fuzzy_core::units::Point3Mm;
use heapless::Deque;
use link::{AlarmCode, DeviceMsg, MachineCmd, PathControl, StoreResult};
use rtic_core::Mutex;

use crate::alarm::{GuardConfig, Latch, Phase};
use crate::command::Cmd;
use crate::config::{Config, Key};
use crate::controls::{Controls, ForceLoop};
use crate::feeder::Feeder;
use crate::homing::{self, Cycle};
use crate::planning::{Dropped, PlanInput, Planning, Setpoint};
use crate::ring::{Consumer, Producer};
use crate::session::{BackgroundInfo, DeviceLink, Taken};
use crate::settings::{Plan, CMD_QUEUE, SETPOINT_RING};
use crate::spindle::{MachineOutputs, Spindle};
use crate::steps::StepSettings;

mod probe_cycle;
use probe_cycle::Probing;

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
    /// The alarm state was entered.
    Alarm(AlarmCode),
    /// The link fell silent while the tool moved: a feed hold.
    LinkSilent,
    /// The planner refused settings the link accepted (cannot happen: the
    /// link checks them as a whole).
    SettingsRefused(ConfigError),
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
    /// Bad step settings (with the tick rate).
    StepSettings(crate::steps::StepConfigError),
}

impl From<OverrideError> for StartError {
    fn from(_: OverrideError) -> Self {
        StartError::ForceLoop
    }
}

/// What the background drives besides the motion.
pub trait MachineIo {
    /// Set the spindle and coolant outputs.
    fn outputs(&mut self, o: MachineOutputs);
    /// Write the settings to their store (flash); how it went.
    fn save(&mut self, c: &Config) -> StoreResult;
}

/// A machine without spindle, coolant or store (the cost benchmark).
pub struct NoMachine;

impl MachineIo for NoMachine {
    fn outputs(&mut self, _: MachineOutputs) {}
    fn save(&mut self, _: &Config) -> StoreResult {
        StoreResult::WriteFailed
    }
}

/// The tick's input handling from the settings.
pub fn guard_config(c: &Config) -> GuardConfig {
    GuardConfig {
        invert: c.input_invert(),
        debounce: c.get(Key::Debounce).clamp(1, 255) as u8,
        hard_limits: c.on(Key::HardLimits),
        enable_invert: c.on(Key::EnableInvert),
    }
}

/// A machine command waiting for the motion before it.
#[derive(Clone, Copy, Debug)]
struct Waiting {
    seq: u32,
    cmd: MachineCmd,
    /// Generated tick from which the tool is at rest at the path's end
    /// (the ring executed): the command applies there.
    at: Option<u32>,
}

/// The machine's reports waiting for transmit room.
const OUTBOX: usize = 4;

/// How long the link has been silent at `now_us`, the last frame having
/// arrived at `last_rx_us` (µs, wrapping clocks). A frame can arrive
/// after `now_us` was read (the receive interrupt preempts the pass that
/// read it): that is no silence at all, not a wrapped one.
fn silence_us(now_us: u32, last_rx_us: u32) -> u32 {
    let d = now_us.wrapping_sub(last_rx_us);
    if (d as i32) < 0 {
        0
    } else {
        d
    }
}

/// Whether tick `now` is at or after `at` (wrapping).
fn reached(now: u32, at: u32) -> bool {
    (now.wrapping_sub(at) as i32) >= 0
}

/// The background's state: scheduler, planner, force loop, the machine.
pub struct Background<'a> {
    feeder: Feeder,
    planning: Planning<'a>,
    force: ForceLoop,
    published: BackgroundInfo,
    /// An abort in progress: commands and points dropped so far.
    abort: Option<(u32, u32)>,
    latch: &'a Latch,
    config: Config,
    config_version: u32,
    /// The program's path control in force (G61, G64, G64 P).
    path: PathControl,
    /// The path control the planner's last rebuild reported.
    path_reported: PathControl,
    spindle: Spindle,
    waiting: Option<Waiting>,
    /// No new path before this generated tick (spin-up delay).
    hold_until: u32,
    /// The alarm in force was carried out.
    alarm_done: bool,
    homing: Option<Cycle>,
    /// The homing cycle is done and waits for the tick to stop.
    homing_done: bool,
    homed: u8,
    outbox: Deque<DeviceMsg, OUTBOX>,
    /// Step settings changed, for the tick.
    step_settings: Option<StepSettings>,
    /// The link fell silent while the tool moved: the feed hold it caused
    /// holds until the host is heard again.
    silence_hold: bool,
    /// The generated tick from which the tool has been at rest on an open
    /// path (stopped for want of points, or held).
    rest_since: Option<u32>,
    /// A probing move in progress (`crate::probe`).
    probe: Option<Probing>,
}

impl<'a> Background<'a> {
    /// At rest at `start`, with the planner in `plan` (built from
    /// `config.motion_config()`), the settings `config`, the alarm state
    /// shared in `latch`.
    pub fn new(
        plan: &'a mut Plan,
        start: Point3Mm,
        latch: &'a Latch,
        config: Config,
    ) -> Result<Self, StartError> {
        latch.set_guard_config(guard_config(&config));
        Ok(Background {
            feeder: Feeder::new().map_err(StartError::Scheduler)?,
            planning: Planning::new(plan, start).map_err(StartError::Planner)?,
            force: ForceLoop::new()?,
            published: BackgroundInfo::default(),
            abort: None,
            latch,
            config,
            config_version: 0,
            path: PathControl::Blend,
            path_reported: PathControl::Blend,
            spindle: Spindle::default(),
            waiting: None,
            hold_until: 0,
            alarm_done: false,
            homing: None,
            homing_done: false,
            homed: 0,
            outbox: Deque::new(),
            step_settings: None,
            silence_hold: false,
            rest_since: None,
            probe: None,
        })
    }

    /// The planning stage (figures, the planner's settings).
    pub fn planning(&self) -> &Planning<'a> {
        &self.planning
    }

    /// The settings in force.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// Step settings changed over the link since the last call, for the
    /// tick to apply ([`crate::guard::Guard::apply_step_settings`]).
    pub fn take_step_settings(&mut self) -> Option<StepSettings> {
        self.step_settings.take()
    }

    /// Fill the setpoint ring (before the first tick).
    pub fn fill(&mut self, setpoints: &mut Producer<'_, Setpoint, SETPOINT_RING>) -> usize {
        self.fill_checked(setpoints)
    }

    /// Fill the ring from the planner; a setpoint that leaves the travel
    /// (or goes further out of it: a tool outside, not yet homed, may come
    /// back in, as Grbl allows) trips the soft-limit alarm and does not
    /// enter it.
    fn fill_checked(&mut self, setpoints: &mut Producer<'_, Setpoint, SETPOINT_RING>) -> usize {
        let mut n = 0;
        let mut excess = self
            .config
            .travel_excess(self.planning.position().to_bits());
        while setpoints.ready() {
            let t = self.planning.generate();
            let out = self.config.travel_excess(t.pos.to_bits());
            if out > excess {
                self.latch.trip(AlarmCode::SoftLimit);
                break;
            }
            excess = out;
            let _ = setpoints.enqueue(Setpoint::of(self.planning.motion(), &t));
            n += 1;
        }
        n
    }

    fn post(&mut self, msg: DeviceMsg) {
        // Full: the oldest report goes (four are far more than a pass makes).
        if self.outbox.is_full() {
            self.outbox.pop_front();
        }
        let _ = self.outbox.push_back(msg);
    }

    /// One pass (module docs); `io` the spindle, coolant and store,
    /// `now_us` the time (µs, wrapping), `stack_bytes` the stack high-water
    /// mark to publish. Returns whether it did work (otherwise the caller
    /// may sleep until an interrupt, once the queues are idle too).
    #[allow(clippy::too_many_arguments)]
    pub fn step<L: Mutex<T = DeviceLink>>(
        &mut self,
        link: &mut L,
        cmds: &mut Consumer<'_, Cmd, CMD_QUEUE>,
        setpoints: &mut Producer<'_, Setpoint, SETPOINT_RING>,
        io: &mut impl MachineIo,
        now_us: u32,
        stack_bytes: u32,
        mut notice: impl FnMut(Notice),
    ) -> bool {
        let mut busy = false;
        let room = link.lock(|l| l.tx.has_reserve());

        // 1. Settings.
        if room {
            busy |= self.settings(link, io, &mut notice);
        }

        // 2. Alarm; 3. homing; 4. the motion.
        if self.latch.phase() == Phase::Alarm || self.alarm_done {
            busy |= self.alarm(link, cmds, setpoints, io, room, &mut notice);
        } else if self.homing.is_some() {
            busy |= self.homing_pass(link, setpoints, room, &mut notice);
        } else {
            busy |= self.motion(link, cmds, setpoints, io, room, &mut notice);
            // 5. Link silence and loss.
            let silent_ms = link.lock(|l| silence_us(now_us, l.last_rx_us)) / 1000;
            busy |= self.link_silence(link, silent_ms, room, &mut notice);
            // A homing cycle to start.
            if let Some(axes) = link.lock(|l| l.take_home()) {
                if self.idle() {
                    self.homing = Cycle::new(&self.config, axes, self.planning.position());
                    self.homing_done = false;
                    busy = true;
                }
            }
        }

        // 6. Credit; the machine's reports.
        link.lock(|l| l.poll(busy));
        if let Some(msg) = self.outbox.front().copied() {
            if link.lock(|l| l.tx.has_reserve() && l.tx.send(&msg, 0)) {
                self.outbox.pop_front();
            }
        }

        // 7. Figures for status replies.
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
            idle: self.idle(),
            homing: self.homing.is_some(),
            homed: self.homed,
            spindle: self.spindle,
        };
        if info != self.published {
            self.published = info;
            link.lock(|l| l.info = info);
        }
        busy
    }

    /// Step 5: a link silent for `$209` while the tool moves is a feed
    /// hold (a host that streams a path asks for its status several times
    /// a second: a silent one is gone, and what it queued must not run on
    /// without it); a host heard again decides with its own hold and
    /// resume. On an open path at rest (stopped for want of points, or
    /// held), a link silent for `$206` trips [`AlarmCode::LinkLoss`], once
    /// the ring holds only the resting position.
    fn link_silence<L: Mutex<T = DeviceLink>>(
        &mut self,
        link: &mut L,
        silent_ms: u32,
        room: bool,
        notice: &mut impl FnMut(Notice),
    ) -> bool {
        let mut busy = false;
        let hold_ms = u32::try_from(self.config.get(Key::LinkSilence)).unwrap_or(u32::MAX);
        let state = self.planning.state();
        if self.silence_hold && silent_ms < hold_ms {
            self.silence_hold = false;
        }
        if hold_ms > 0 && room && state == MotionState::Moving && silent_ms >= hold_ms {
            let c = Controls {
                hold: Some(true),
                ..Controls::default()
            };
            for input in self.planning.apply(c).into_iter().flatten() {
                report(link, input, notice);
            }
            self.silence_hold = true;
            notice(Notice::LinkSilent);
            busy = true;
        }
        let generated = self.planning.generated();
        let stopped = matches!(state, MotionState::Starved | MotionState::Holding)
            && self.planning.motion().at_rest();
        if !stopped {
            self.rest_since = None;
            return busy;
        }
        let since = *self.rest_since.get_or_insert(generated);
        let ring_at_rest = generated.wrapping_sub(since) >= SETPOINT_RING as u32;
        let loss_ms = u32::try_from(self.config.get(Key::LinkLoss)).unwrap_or(u32::MAX);
        if loss_ms > 0 && ring_at_rest && silent_ms >= loss_ms {
            self.latch.trip(AlarmCode::LinkLoss);
        }
        busy
    }

    /// Nothing in the scheduler, the planner at rest at a path's end,
    /// nothing waiting.
    fn idle(&self) -> bool {
        self.feeder.held() == 0
            && !self.feeder.is_draining()
            && !self.planning.waiting()
            && self.planning.path_ended()
            && matches!(self.planning.state(), MotionState::Done | MotionState::Idle)
            && self.waiting.is_none()
            && self.probe.is_none()
            && self.abort.is_none()
            && self.homing.is_none()
            && reached(self.planning.generated(), self.hold_until)
    }

    /// A scheduled point to the planner (it waits while a spin-up delay
    /// runs); reported when the planner takes it.
    fn take_point<L: Mutex<T = DeviceLink>>(
        &mut self,
        s: &fuzzy_core::scheduler::ScheduledPoint,
        link: &mut L,
        notice: &mut impl FnMut(Notice),
    ) {
        if !reached(self.planning.generated(), self.hold_until) {
            self.planning.queue(s);
            return;
        }
        match self.planning.take_point(s) {
            Ok(Some(input)) => report(link, input, notice),
            Ok(None) => {}
            Err(e) => notice(Notice::PlannerRefused(e)),
        }
    }

    /// The waiting point to the planner, unless a spin-up delay runs;
    /// whether it went in.
    fn push_pending<L: Mutex<T = DeviceLink>>(
        &mut self,
        link: &mut L,
        notice: &mut impl FnMut(Notice),
    ) -> bool {
        if !reached(self.planning.generated(), self.hold_until) {
            return false;
        }
        match self.planning.push_pending() {
            Ok(Some(input)) => {
                report(link, input, notice);
                true
            }
            Ok(None) => false,
            Err(e) => {
                notice(Notice::PlannerRefused(e));
                false
            }
        }
    }

    /// Step 1: settings changed over the link.
    fn settings<L: Mutex<T = DeviceLink>>(
        &mut self,
        link: &mut L,
        io: &mut impl MachineIo,
        notice: &mut impl FnMut(Notice),
    ) -> bool {
        let v = self.config_version;
        let Some(c) =
            link.lock(|l| (l.config_version != v).then_some((l.config_version, l.config)))
        else {
            return false;
        };
        let (version, written) = c;
        // The tick rate and the PWM frequency stay as started until a
        // reset (their timers are set up at start-up).
        let config = written.in_force(&self.config);
        let rebuild = config.motion_config() != self.config.motion_config();
        // A reset is needed while a setting written differs from the one
        // running (one written back to its running value needs none).
        let mut restart = config != written;
        if config.step_config() != self.config.step_config() {
            match config.step_settings() {
                Ok(s) => self.step_settings = Some(s),
                // Valid with the tick rate written, not with the one
                // running: at the reset.
                Err(_) => restart = true,
            }
        }
        link.lock(|l| l.restart_needed = restart);
        self.config = config;
        self.config_version = version;
        self.latch.set_guard_config(guard_config(&config));
        if rebuild {
            // Changes are accepted at rest only: the planner is at rest.
            let here = self.planning.position();
            self.rebuild(here, link, notice);
        }
        if link.lock(|l| l.take_save()) {
            let r = io.save(&written);
            link.lock(|l| l.store = r);
            self.post(DeviceMsg::Stored(r));
        }
        true
    }

    /// Step 2: the alarm state.
    fn alarm<L: Mutex<T = DeviceLink>>(
        &mut self,
        link: &mut L,
        cmds: &mut Consumer<'_, Cmd, CMD_QUEUE>,
        setpoints: &mut Producer<'_, Setpoint, SETPOINT_RING>,
        io: &mut impl MachineIo,
        room: bool,
        notice: &mut impl FnMut(Notice),
    ) -> bool {
        let mut busy = false;
        if !self.alarm_done {
            if !room {
                return false;
            }
            // Wait for the tick to stop (it publishes where).
            let Some(pos) = self.latch.take_stopped_at() else {
                return false;
            };
            let code = self.latch.alarm().unwrap_or(AlarmCode::EStopLink);
            self.feeder.abort();
            self.abort = None;
            self.waiting = None;
            self.probe = None;
            self.latch.probe.disarm();
            self.hold_until = 0;
            self.homing = None;
            self.homing_done = false;
            self.latch.set_homing(false, None);
            self.spindle.stop();
            io.outputs(self.spindle.outputs(&self.config));
            let at_rest = matches!(
                code,
                AlarmCode::LinkLoss | AlarmCode::ProbeFailInitial | AlarmCode::ProbeFailContact
            );
            if !at_rest {
                // Stopped without deceleration: the position may be lost.
                self.homed = 0;
            }
            // The program is dropped, its path control with it.
            self.path = PathControl::Blend;
            self.rebuild(pos, link, notice);
            let next_seq = link.lock(|l| l.void_all());
            self.post(DeviceMsg::Alarm {
                code,
                pos_mm: pos.to_bits(),
                next_seq,
            });
            notice(Notice::Alarm(code));
            self.alarm_done = true;
            busy = true;
        }
        // Everything queued before the alarm is dropped.
        while link.lock(|l| l.drop_void(cmds)) {
            busy = true;
        }
        if link.lock(|l| l.take_unlock()) && self.latch.advance(Phase::Alarm, Phase::Hold) {
            // The ring is empty (drained by the tick): refill it at rest
            // before the tick runs again.
            self.fill_checked(setpoints);
            self.latch.advance(Phase::Hold, Phase::Run);
            self.alarm_done = false;
            busy = true;
        }
        busy
    }

    /// Step 3: a homing cycle.
    fn homing_pass<L: Mutex<T = DeviceLink>>(
        &mut self,
        link: &mut L,
        setpoints: &mut Producer<'_, Setpoint, SETPOINT_RING>,
        room: bool,
        notice: &mut impl FnMut(Notice),
    ) -> bool {
        let Some(mut cycle) = self.homing else {
            return false;
        };
        match self.latch.phase() {
            Phase::Halt => {
                if !room {
                    return false;
                }
                let Some(pos) = self.latch.take_stopped_at() else {
                    return false;
                };
                if self.homing_done {
                    self.finish_homing(link, &cycle, pos, setpoints, notice);
                    return true;
                }
                let watch = cycle.on_halt(pos);
                self.latch.set_homing(true, watch);
                self.latch.advance(Phase::Halt, Phase::Hold);
                self.homing = Some(cycle);
                self.fill_homing(setpoints);
                self.latch.advance(Phase::Hold, Phase::Run);
                true
            }
            Phase::Run if !self.homing_done => self.fill_homing(setpoints) > 0,
            _ => false,
        }
    }

    /// The ring from the homing cycle.
    fn fill_homing(&mut self, setpoints: &mut Producer<'_, Setpoint, SETPOINT_RING>) -> usize {
        let Some(mut cycle) = self.homing else {
            return 0;
        };
        let mut n = 0;
        while setpoints.ready() && !self.homing_done {
            let (sp, event) = cycle.next(self.latch.inputs());
            match event {
                homing::Event::None => {}
                homing::Event::Watch(w) => self.latch.set_homing(true, w),
                homing::Event::Failed(code) => {
                    self.latch.trip(code);
                    break;
                }
                homing::Event::Done => {
                    // Stop the tick where the tool rests; the new
                    // coordinates take over from there.
                    self.homing_done = true;
                    self.latch.advance(Phase::Run, Phase::Halt);
                }
            }
            let _ = setpoints.enqueue(sp);
            n += 1;
        }
        self.homing = Some(cycle);
        n
    }

    /// The cycle is done and the tick stopped at `pos`: the homed axes
    /// take their machine coordinates there.
    fn finish_homing<L: Mutex<T = DeviceLink>>(
        &mut self,
        link: &mut L,
        cycle: &Cycle,
        pos: Point3Mm,
        setpoints: &mut Producer<'_, Setpoint, SETPOINT_RING>,
        notice: &mut impl FnMut(Notice),
    ) {
        let home = cycle.home_position(pos);
        let (h, p, mut off) = (home.to_bits(), pos.to_bits(), self.latch.offset());
        for a in 0..3 {
            off[a] = off[a].wrapping_add(h[a].wrapping_sub(p[a]));
        }
        self.latch.set_offset(off);
        self.latch.set_homing(false, None);
        self.homed |= cycle.homed();
        self.rebuild(home, link, notice);
        self.homing = None;
        self.homing_done = false;
        if self.latch.advance(Phase::Halt, Phase::Hold) {
            self.fill_checked(setpoints);
            self.latch.advance(Phase::Hold, Phase::Run);
        }
        self.post(DeviceMsg::Homed {
            axes: cycle.homed(),
            pos_mm: h,
        });
    }

    /// Step 4: the motion.
    fn motion<L: Mutex<T = DeviceLink>>(
        &mut self,
        link: &mut L,
        cmds: &mut Consumer<'_, Cmd, CMD_QUEUE>,
        setpoints: &mut Producer<'_, Setpoint, SETPOINT_RING>,
        io: &mut impl MachineIo,
        room: bool,
        notice: &mut impl FnMut(Notice),
    ) -> bool {
        let mut busy = false;
        // Abort; hold, resume, override, force samples.
        if room && link.lock(|l| l.take_abort()) {
            busy = true;
            let points = self.feeder.abort();
            let (c, p) = self.abort.unwrap_or((0, 0));
            self.abort = Some((c, p.wrapping_add(points)));
            self.waiting = None;
            self.probe = None;
            self.latch.probe.disarm();
            let input = self.planning.abort();
            report(link, input, notice);
        }
        if room {
            let mut c = link.lock(|l| core::mem::take(&mut l.controls));
            if self.probe.is_some_and(|p| p.stopping()) {
                // The probe's stop is not the host's to release.
                c.hold = c.hold.filter(|h| *h);
            }
            self.force.apply(&mut c);
            if let Some(p) = c.spindle_percent.take() {
                self.spindle.override_percent = p;
                io.outputs(self.spindle.outputs(&self.config));
            }
            if c != Controls::default() {
                for input in self.planning.apply(c).into_iter().flatten() {
                    report(link, input, notice);
                }
            }
        }

        // Keep the ring full.
        self.fill_checked(setpoints);
        if self.latch.phase() == Phase::Alarm {
            return true;
        }

        // A waiting point into the planner, or one scheduler step.
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
                // As Grbl's soft reset: spindle and coolant off, and the
                // program's path control dropped.
                self.spindle.stop();
                io.outputs(self.spindle.outputs(&self.config));
                if self.path != PathControl::Blend {
                    self.path = PathControl::Blend;
                    let here = self.planning.position();
                    self.rebuild(here, link, notice);
                }
                notice(Notice::Aborted);
                busy = true;
            }
        } else if self.probe.is_some() {
            busy |= self.probe_pass(room, link, notice);
        } else if let Some(w) = self.waiting {
            busy |= self.machine_command(w, room, io, notice, link);
        } else if room && self.planning.waiting() {
            busy |= self.push_pending(link, notice);
        } else if room {
            let next = if self.feeder.is_draining() {
                busy = true;
                Ok(self.feeder.drain())
            } else {
                match link.lock(|l| l.take_command(cmds)) {
                    Taken::Live(cmd) => {
                        busy = true;
                        if let Cmd::Machine { seq, cmd } = cmd {
                            self.waiting = Some(Waiting { seq, cmd, at: None });
                        }
                        if let Cmd::Probe {
                            target,
                            feed,
                            seq,
                            toward,
                            error_if_missed,
                        } = cmd
                        {
                            self.probe = Some(Probing::new(crate::probe::ProbeCmd {
                                target,
                                feed,
                                seq,
                                toward,
                                error_if_missed,
                            }));
                        }
                        self.feeder.command(cmd)
                    }
                    // Voided by an abort the background has not seen yet
                    // cannot be: the abort is taken first.
                    Taken::Void => {
                        busy = true;
                        Ok(None)
                    }
                    Taken::Nothing => Ok(None),
                }
            };
            match next {
                Ok(Some(s)) => self.take_point(&s, link, notice),
                Ok(None) => {
                    if self.feeder.take_path_end() {
                        notice(Notice::PathScheduled);
                        let input = self.planning.end_path();
                        report(link, input, notice);
                    }
                }
                Err(e) => notice(Notice::SchedulerRefused(e)),
            }
        }
        busy
    }

    /// The path before a machine command or a probing move, into the
    /// planner: the waiting point, the scheduler's lookahead, the path's
    /// end. `Some(whether it did work)` while any of it is left, `None`
    /// once it is all in the planner.
    fn drain_path_before<L: Mutex<T = DeviceLink>>(
        &mut self,
        link: &mut L,
        notice: &mut impl FnMut(Notice),
    ) -> Option<bool> {
        if self.planning.waiting() {
            return Some(self.push_pending(link, notice));
        }
        if self.feeder.is_draining() {
            if let Some(s) = self.feeder.drain() {
                self.take_point(&s, link, notice);
            }
            return Some(true);
        }
        if self.feeder.take_path_end() {
            notice(Notice::PathScheduled);
            let input = self.planning.end_path();
            report(link, input, notice);
            return Some(true);
        }
        None
    }

    /// A machine command waits for the path before it to end (the
    /// scheduler drained, the planner done and the ring executed), then
    /// takes effect.
    fn machine_command<L: Mutex<T = DeviceLink>>(
        &mut self,
        mut w: Waiting,
        room: bool,
        io: &mut impl MachineIo,
        notice: &mut impl FnMut(Notice),
        link: &mut L,
    ) -> bool {
        if !room {
            return false;
        }
        if let Some(busy) = self.drain_path_before(link, notice) {
            return busy;
        }
        // Done for the ring's depth in a row: the tick executed the stop.
        let done = self.planning.path_ended() && self.planning.state() == MotionState::Done;
        if !done {
            w.at = None;
            self.waiting = Some(w);
            return false;
        }
        let now = self.planning.generated();
        let at = *w.at.get_or_insert(now.wrapping_add(SETPOINT_RING as u32));
        self.waiting = Some(w);
        if (now.wrapping_sub(at) as i32) < 0 {
            return false;
        }
        let spin_up = self.spindle.apply(w.cmd);
        io.outputs(self.spindle.outputs(&self.config));
        if let MachineCmd::PathControl(c) = w.cmd {
            // At rest at the end of the path before it.
            self.path = c;
            let here = self.planning.position();
            self.rebuild(here, link, notice);
        }
        // The next path waits: a dwell's time (G4, from here at rest), or
        // the spin-up delay after a start or a reversal.
        let wait_ms = match w.cmd {
            MachineCmd::Dwell { ms } => ms as u64,
            _ if spin_up => self.config.get(Key::SpinUp).max(0) as u64,
            _ => 0,
        };
        if wait_ms > 0 {
            let ticks = wait_ms * 1000 / self.config.tick_us().max(1) as u64;
            self.hold_until = now.wrapping_add(ticks.min(u32::MAX as u64 / 2) as u32);
        }
        self.post(DeviceMsg::Applied {
            seq: w.seq,
            cmd: w.cmd,
            point: self.planning.point_reached(),
            tick: now,
        });
        self.waiting = None;
        true
    }
}

impl Background<'_> {
    /// The planner's settings: the machine's with the program's path
    /// control.
    pub fn motion_config(&self) -> fuzzy_core::planner::MotionConfig {
        self.config
            .path_settings(self.path)
            .apply(self.config.motion_config())
    }

    /// Rebuild the planner at rest at `pos` with [`Self::motion_config`]:
    /// reported as `PlanEvent::Reset`, or as `PlanEvent::PathControl`
    /// where a path control other than G64 is in force or was (the
    /// replay then takes its settings in place of the machine's).
    fn rebuild<L: Mutex<T = DeviceLink>>(
        &mut self,
        pos: Point3Mm,
        link: &mut L,
        notice: &mut impl FnMut(Notice),
    ) {
        let settings = self.config.path_settings(self.path);
        let event = (self.path != PathControl::Blend || self.path_reported != PathControl::Blend)
            .then(|| settings.event(pos.to_bits()));
        match self.planning.rebuild(self.motion_config(), pos, event) {
            Ok(input) => {
                self.path_reported = self.path;
                report(link, input, notice)
            }
            Err(e) => notice(Notice::SettingsRefused(e)),
        }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frame_after_the_pass_read_the_clock_is_no_silence() {
        assert_eq!(silence_us(5_000, 1_000), 4_000);
        assert_eq!(silence_us(1_000, 1_200), 0, "arrived after `now`");
        assert_eq!(silence_us(100, u32::MAX - 899), 1_000, "across the wrap");
        assert_eq!(silence_us(u32::MAX, u32::MAX), 0);
    }
}
