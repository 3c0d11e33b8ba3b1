//! The device side of the link, without I/O: frames in, replies, commands
//! and controls out (in the manner of smoltcp's `socket/tcp.rs`).
//!
//! The receive side calls [`DeviceLink::on_frame`] with every decoded frame
//! (or why it could not be decoded); the background calls
//! [`DeviceLink::on_taken`] for each command it takes from the queue and
//! [`DeviceLink::poll`] once a pass, which returns credit to the host. The
//! protocol's rules (`link` crate docs), as this side keeps them:
//! - path commands (`StartPath`, `Point`, `EndPath`, and each point of a
//!   `Points` batch) carry sequence numbers;
//!   only the next one is accepted, a repeat of an accepted one is
//!   acknowledged again (a resend is harmless), a gap is refused with
//!   `OutOfSequence` (the host goes back to `expected_seq`);
//! - a path command is acknowledged only once it is in the queue, and
//!   nothing leaves the queue except into the scheduler, so an acknowledged
//!   command is never lost; everything the scheduler could refuse is checked
//!   before the acknowledgement (`OutOfRange`);
//! - the credit: every accepted command holds a queue slot until the
//!   background takes it, so the host may send up to `taken + CMD_CREDIT`
//!   (exclusive); past it, `NoCredit`;
//! - hold, resume, override and force samples act at once (the background
//!   applies them at its next pass) and are acknowledged; a status query is
//!   answered at once;
//! - every refused frame is counted and answered with `Error { code,
//!   expected_seq }`, but replies to line noise (frames that do not decode:
//!   framing, length, CRC, unknown or malformed messages, the wrong
//!   direction) are rate-limited ([`NOISE_BURST`], [`NOISE_REFILL_US`]) and
//!   never take the second half of the transmit buffer, so a flood of
//!   garbage cannot crowd out the replies that matter (acknowledgements,
//!   status, refusals of well-formed frames);
//! - replies that find the transmit buffer full are dropped and counted
//!   (the host's silence timeout recovers), never the background's reports
//!   ([`crate::tx`]);
//! - an abort (`HostMsg::Abort { next_seq }`) voids every path command
//!   accepted so far: the background drops those still queued as it takes
//!   them ([`DeviceLink::take_command`]) and stops the motion; the host's
//!   next path command is `next_seq` (older ones arriving late are taken
//!   for resends: acknowledged and ignored).
//!
//! - the machine around the motion: `EStop` trips the alarm at once (the
//!   tick stops at its next period, [`crate::alarm`]); in the alarm state
//!   every path command is refused (`Alarm`) until `Unlock` (refused while
//!   the e-stop input is active, `InputActive`; once the background has
//!   carried out the alarm, path commands after it wait in the queue for
//!   the unlock to complete); with homing required (`$22`) path commands
//!   are refused until every axis of the homing passes is homed
//!   (`NotHomed`), and during a homing cycle (`Busy`); with soft limits on
//!   (`$20`) a point outside the travel is refused on arrival
//!   (`OutOfTravel`, a batch all or nothing; a probe's target likewise);
//!   `Machine` commands (spindle, coolant) and `Probe` are sequenced and
//!   queued like points;
//! - settings (`GetSetting`, `SetSetting`, [`crate::config`]): a write is
//!   taken only with nothing moving: at rest with nothing queued, or in an
//!   alarm the background has carried out (the tick stopped, everything
//!   queued dropped; `Busy` otherwise), and with the spindle and coolant
//!   off (`OutputsOn`), because the background stores it in flash next,
//!   and a sector erase stalls the core, the tick and its e-stop input
//!   with it (`firmware/README.md`, flash settings); only in range
//!   (`OutOfRange`, `UnknownSetting`: nothing changed); the background
//!   applies and stores it; `Home` only at rest (`Busy`) with
//!   homing enabled (`Rejected`); `MachineQuery` is answered at once.
//!
//! Sequence numbers and the queue: commands leave the queue in order, so
//! the next command taken has sequence number `offset + taken`; `offset` is
//! zero until an abort moves the numbering on.

use fuzzy_core::planner::MotionState;
use link::{DeviceMsg, ErrorCode, HostMsg, MachineStatus, Motion, Status, StoreResult};

use crate::alarm::{Latch, Phase, ESTOP};
use crate::command::{config_from_link, point_from_link, Cmd};
use crate::config::{Apply, Config, Key, SettingError};
use crate::controls::{force_from_link, Controls};
use crate::probe::probe_from_link;
use crate::ring::{Consumer, Producer};
use crate::settings::{Plan, CMD_CREDIT, CMD_QUEUE, CREDIT_BATCH, PLANNER_POINTS, TX_BUFFER};
use crate::spindle::Spindle;
use crate::tick::TickExecutor;
use crate::tx::{TxBuffer, BACKGROUND_RESERVE};

/// Replies to line noise in a burst, at most.
pub const NOISE_BURST: u8 = 8;
/// One more reply to line noise allowed per this many µs (20 a second:
/// 200 bytes/s, 2 % of a 115 200-baud link).
pub const NOISE_REFILL_US: u32 = 50_000;
/// Replies to line noise leave this much of the transmit buffer free.
pub const NOISE_KEEP: usize = TX_BUFFER / 2;

/// Whether `a` comes before `b` in wrapping sequence order.
fn before(a: u32, b: u32) -> bool {
    (a.wrapping_sub(b) as i32) < 0
}

/// Sequence numbers and credit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Session {
    next_seq: u32,
    /// Commands the background took from the queue.
    taken: u32,
    /// The sequence number of the first command taken (module docs).
    offset: u32,
    /// Commands up to this `taken` count are void (an abort).
    void_until: u32,
    /// Taken since the last credit update sent.
    taken_since_ack: u32,
    bad_frames: u32,
    tx_dropped: u32,
    noise_suppressed: u32,
}

impl Session {
    /// The next sequence number expected.
    pub fn next_seq(&self) -> u32 {
        self.next_seq
    }

    /// The credit limit (exclusive): the sequence number of the next
    /// command taken, plus the queue's room.
    pub fn window_end(&self) -> u32 {
        self.offset
            .wrapping_add(self.taken)
            .wrapping_add(CMD_CREDIT)
    }

    /// Frames refused since boot.
    pub fn bad_frames(&self) -> u32 {
        self.bad_frames
    }

    /// Replies dropped for want of transmit room.
    pub fn tx_dropped(&self) -> u32 {
        self.tx_dropped
    }

    /// Replies to line noise not sent (rate limit).
    pub fn noise_suppressed(&self) -> u32 {
        self.noise_suppressed
    }

    /// Commands in the queue (accepted, not yet taken; void ones too).
    fn queued(&self) -> u32 {
        self.next_seq
            .wrapping_sub(self.offset.wrapping_add(self.taken))
    }

    /// The acknowledgement of everything accepted, with the credit.
    pub fn ack(&self) -> DeviceMsg {
        DeviceMsg::Ack {
            next_seq: self.next_seq,
            window_end: self.window_end(),
        }
    }

    /// A path command `seq` (`None`: its values were out of range): into
    /// the queue if it is the next one.
    fn accept(
        &mut self,
        seq: u32,
        cmd: Option<Cmd>,
        queue: &mut Producer<'_, Cmd, CMD_QUEUE>,
    ) -> Result<(), ErrorCode> {
        if before(seq, self.next_seq) {
            // A resend of something we have: acknowledge again.
            return Ok(());
        }
        if seq != self.next_seq {
            return Err(ErrorCode::OutOfSequence);
        }
        let cmd = cmd.ok_or(ErrorCode::OutOfRange)?;
        queue.enqueue(cmd).map_err(|_| ErrorCode::NoCredit)?;
        self.next_seq = self.next_seq.wrapping_add(1);
        Ok(())
    }

    /// An abort: everything accepted is void, the host's next command is
    /// `host_next` (or ours, if the host is behind).
    fn abort(&mut self, host_next: u32) {
        let next = if before(host_next, self.next_seq) {
            self.next_seq
        } else {
            host_next
        };
        // Every command accepted so far, counted in `taken`.
        self.void_until = self.next_seq.wrapping_sub(self.offset);
        self.offset = next.wrapping_sub(self.void_until);
        self.next_seq = next;
    }
}

/// The rate limit of replies to line noise: a token bucket.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct NoiseLimit {
    tokens: u8,
    /// When the last token was added, µs.
    since_us: u32,
}

impl NoiseLimit {
    /// Whether a reply may go at `now_us` (takes a token).
    fn allow(&mut self, now_us: u32) -> bool {
        let refills = now_us.wrapping_sub(self.since_us) / NOISE_REFILL_US;
        if refills > 0 {
            let t = (self.tokens as u32).saturating_add(refills);
            self.tokens = t.min(NOISE_BURST as u32) as u8;
            self.since_us = self
                .since_us
                .wrapping_add(refills.wrapping_mul(NOISE_REFILL_US));
        }
        if self.tokens == 0 {
            return false;
        }
        self.tokens -= 1;
        true
    }
}

/// Whether a refusal is of a frame that did not decode (line noise).
fn is_noise(code: ErrorCode) -> bool {
    matches!(
        code,
        ErrorCode::Framing
            | ErrorCode::TooLong
            | ErrorCode::TooShort
            | ErrorCode::Crc
            | ErrorCode::UnknownMessage
            | ErrorCode::Malformed
            | ErrorCode::Misdirected
    )
}

/// What [`DeviceLink::take_command`] found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Taken {
    /// Nothing to take (the queue is empty, or an abort waits for the
    /// background).
    Nothing,
    /// A command voided by an abort: dropped.
    Void,
    /// The next command.
    Live(Cmd),
}

/// What the background publishes for status replies.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BackgroundInfo {
    /// Points in the scheduler's lookahead.
    pub points_held: u16,
    /// Points in the planner.
    pub planned: u16,
    /// The planner's path index.
    pub point: u32,
    /// Controlled stops for want of path.
    pub underruns: u32,
    /// Feed override in force, percent.
    pub override_percent: u16,
    /// Stack high-water mark, bytes.
    pub stack: u32,
    /// Setpoints generated since boot.
    pub generated: u32,
    /// Checksum of their positions (folded).
    pub checksum: u32,
    /// Nothing in the scheduler, the planner at rest at a path's end,
    /// nothing waiting (a machine command, a spin-up, a homing cycle).
    pub idle: bool,
    /// A homing cycle is running.
    pub homing: bool,
    /// Axes homed since boot (bit 0 X).
    pub homed: u8,
    /// The spindle and coolant.
    pub spindle: Spindle,
}

/// What the link's receive side and the background share: the session,
/// the transmit buffer, the controls on their way to the planner and the
/// background's figures. One lock guards it all.
pub struct DeviceLink {
    /// Sequence numbers and credit.
    pub session: Session,
    /// Framed replies waiting for the wire.
    pub tx: TxBuffer,
    /// Hold/resume/override/force, until the background takes them.
    pub controls: Controls,
    /// The background's latest figures.
    pub info: BackgroundInfo,
    /// An abort arrived and the background has not taken it yet.
    abort: bool,
    noise: NoiseLimit,
    /// The planner's inputs are reported (`HostMsg::Reports`).
    pub reports: bool,
    /// The alarm state and the tick's stops, shared with every task.
    pub latch: &'static Latch,
    /// The machine settings (changed by `SetSetting`).
    pub config: Config,
    /// Counts the changes of `config` (the background follows it).
    pub config_version: u32,
    /// A changed setting applies only after a reset (the tick rate, the
    /// spindle PWM frequency).
    pub restart_needed: bool,
    /// The settings store: how it was read, or the last write.
    pub store: StoreResult,
    /// The settings changed and are to be written to flash.
    save: bool,
    /// An unlock the background has to carry out.
    unlock: bool,
    /// The background carried out the alarm in force (its queued commands
    /// are void): path commands after an unlock are taken.
    alarm_handled: bool,
    /// A homing cycle to start (axes).
    home: Option<u8>,
    /// When the last frame that decoded arrived, µs.
    pub last_rx_us: u32,
}

/// What the receive side does with a message.
enum Reply {
    Ack,
    Status,
    Machine,
    Setting(u16, i64),
}

impl DeviceLink {
    /// At reset: nothing received, override 100 %, the settings `config`
    /// (as read from the store: `store`), the alarm state in `latch`.
    pub const fn new(latch: &'static Latch, config: Config, store: StoreResult) -> Self {
        DeviceLink {
            session: Session {
                next_seq: 0,
                taken: 0,
                offset: 0,
                void_until: 0,
                taken_since_ack: 0,
                bad_frames: 0,
                tx_dropped: 0,
                noise_suppressed: 0,
            },
            tx: TxBuffer::new(),
            controls: Controls {
                hold: None,
                override_percent: None,
                spindle_percent: None,
                force: None,
            },
            info: BackgroundInfo {
                points_held: 0,
                planned: 0,
                point: 0,
                underruns: 0,
                override_percent: 100,
                stack: 0,
                generated: 0,
                checksum: 0,
                idle: true,
                homing: false,
                homed: 0,
                spindle: Spindle {
                    dir: link::SpindleDir::Off,
                    speed_rpm: 0,
                    flood: false,
                    mist: false,
                    override_percent: 100,
                },
            },
            abort: false,
            noise: NoiseLimit {
                tokens: NOISE_BURST,
                since_us: 0,
            },
            reports: true,
            latch,
            config,
            config_version: 0,
            restart_needed: false,
            store,
            save: false,
            unlock: false,
            alarm_handled: false,
            home: None,
            last_rx_us: 0,
        }
    }

    /// The hello sent once after reset: the settings in force (`plan`'s
    /// acceleration limit, rounded up to mm/s²).
    pub fn hello(&self, plan: &Plan) -> DeviceMsg {
        let bits = plan.accel_limit_mm_s2().to_bits();
        let accel = ((bits.max(0) as u64 + u32::MAX as u64) >> 32).min(u32::MAX as u64) as u32;
        DeviceMsg::Hello {
            tick_hz: self.config.tick_hz(),
            accel_mm_per_s2: accel,
            window_end: self.session.window_end(),
            feed_max_mm_per_min: self.config.get(Key::FeedMax).clamp(0, u32::MAX as i64) as u32,
            planner_points: PLANNER_POINTS as u16,
        }
    }

    /// Commands accepted and not yet taken by the background.
    fn queued(&self) -> u32 {
        let s = &self.session;
        s.next_seq.wrapping_sub(s.offset.wrapping_add(s.taken))
    }

    /// Whether the machine is at rest with nothing queued or waiting
    /// (settings may change, a homing cycle may start).
    fn idle(&self, exec: &TickExecutor) -> bool {
        self.queued() == 0 && self.info.idle && !self.abort && !exec.now.moving && !self.info.homing
    }

    /// Whether settings may be written now (module docs): nothing moves
    /// (at rest with nothing queued, or a carried-out alarm) and the
    /// spindle and coolant are off.
    fn writable(&self, exec: &TickExecutor) -> Result<(), ErrorCode> {
        let still = if self.latch.phase() == Phase::Alarm {
            self.alarm_handled && !exec.now.moving
        } else {
            self.idle(exec)
        };
        if !still {
            return Err(ErrorCode::Busy);
        }
        if self.info.spindle.any_on() {
            return Err(ErrorCode::OutputsOn);
        }
        Ok(())
    }

    /// Whether path commands are refused now, and why.
    fn path_refusal(&self) -> Option<ErrorCode> {
        // After an unlock of a handled alarm, path commands wait in the
        // queue for the background to leave the alarm.
        if self.latch.phase() == Phase::Alarm && !(self.unlock && self.alarm_handled) {
            return Some(ErrorCode::Alarm);
        }
        if self.info.homing || self.home.is_some() {
            return Some(ErrorCode::Busy);
        }
        if self.config.on(Key::Homing) {
            let need = self.config.homing_passes().iter().fold(0, |m, p| m | p);
            if self.info.homed & need != need {
                return Some(ErrorCode::NotHomed);
            }
        }
        None
    }

    /// An unlock to carry out (taken once).
    pub fn take_unlock(&mut self) -> bool {
        let u = core::mem::take(&mut self.unlock);
        if u {
            self.alarm_handled = false;
        }
        u
    }

    /// A homing cycle to start (taken once).
    pub fn take_home(&mut self) -> Option<u8> {
        self.home.take()
    }

    /// The settings are to be written (taken once).
    pub fn take_save(&mut self) -> bool {
        core::mem::take(&mut self.save)
    }

    /// Every path command accepted so far is void (an alarm): like an
    /// abort, without the controlled stop (the background drops them).
    /// Returns the sequence number the next path command must carry.
    pub fn void_all(&mut self) -> u32 {
        let next = self.session.next_seq;
        self.session.abort(next);
        self.abort = false;
        self.unlock = false;
        self.alarm_handled = true;
        next
    }

    /// The machine status reply, with the tick's state `exec`.
    pub fn machine_status(&self, exec: &TickExecutor) -> MachineStatus {
        let i = &self.info;
        MachineStatus {
            alarm: self.latch.alarm(),
            alarms: self.latch.alarms(),
            homing: i.homing,
            homed: i.homed,
            inputs: self.latch.inputs(),
            spindle: i.spindle.dir,
            speed_rpm: i.spindle.speed_rpm,
            flood: i.spindle.flood,
            mist: i.spindle.mist,
            store: self.store,
            restart_needed: self.restart_needed,
            step_isr_permille: exec.worst_step_isr_permille,
        }
    }

    /// One frame from the wire (or why it could not be decoded) at time
    /// `now_us` (µs, wrapping): act on it, queue the reply. `exec` gives the
    /// tick's state if a status is asked for. Returns the refusal, if the
    /// frame was refused.
    pub fn on_frame(
        &mut self,
        frame: Result<HostMsg, ErrorCode>,
        queue: &mut Producer<'_, Cmd, CMD_QUEUE>,
        now_us: u32,
        mut exec: impl FnMut() -> TickExecutor,
    ) -> Option<ErrorCode> {
        if frame.is_ok() {
            self.last_rx_us = now_us;
        }
        let reply = match frame.and_then(|m| self.handle(m, queue, &mut exec)) {
            Ok(Reply::Ack) => self.session.ack(),
            Ok(Reply::Status) => DeviceMsg::Status(self.status(&exec())),
            Ok(Reply::Machine) => DeviceMsg::Machine(self.machine_status(&exec())),
            Ok(Reply::Setting(id, value)) => DeviceMsg::Setting { id, value },
            Err(code) => {
                self.session.bad_frames = self.session.bad_frames.wrapping_add(1);
                let refused = DeviceMsg::Error {
                    code,
                    expected_seq: self.session.next_seq,
                };
                if !is_noise(code) {
                    self.queue_reply(&refused, BACKGROUND_RESERVE);
                } else if self.noise.allow(now_us) {
                    self.queue_reply(&refused, NOISE_KEEP);
                } else {
                    self.session.noise_suppressed = self.session.noise_suppressed.wrapping_add(1);
                }
                return Some(code);
            }
        };
        // An acknowledgement or a status carries the credit: no update
        // is due for what was taken before it.
        let credit = matches!(reply, DeviceMsg::Ack { .. } | DeviceMsg::Status(_));
        if self.queue_reply(&reply, BACKGROUND_RESERVE) && credit {
            self.session.taken_since_ack = 0;
        }
        None
    }

    /// Whether it was queued.
    fn queue_reply(&mut self, msg: &DeviceMsg, keep: usize) -> bool {
        let sent = self.tx.send(msg, keep);
        if !sent {
            self.session.tx_dropped = self.session.tx_dropped.wrapping_add(1);
        }
        sent
    }

    fn handle(
        &mut self,
        msg: HostMsg,
        queue: &mut Producer<'_, Cmd, CMD_QUEUE>,
        exec: &mut impl FnMut() -> TickExecutor,
    ) -> Result<Reply, ErrorCode> {
        let path = matches!(
            msg,
            HostMsg::StartPath { .. }
                | HostMsg::Point { .. }
                | HostMsg::Points { .. }
                | HostMsg::EndPath { .. }
                | HostMsg::Machine { .. }
                | HostMsg::Probe { .. }
        );
        if let Some(code) = path.then(|| self.path_refusal()).flatten() {
            return Err(code);
        }
        let (seq, cmd) = match msg {
            HostMsg::StatusQuery => return Ok(Reply::Status),
            HostMsg::MachineQuery => return Ok(Reply::Machine),
            HostMsg::EStop => {
                self.latch.trip(link::AlarmCode::EStopLink);
                return Ok(Reply::Ack);
            }
            HostMsg::Unlock => {
                if self.latch.phase() == Phase::Alarm {
                    if self.latch.inputs() & ESTOP != 0 {
                        return Err(ErrorCode::InputActive);
                    }
                    self.unlock = true;
                }
                return Ok(Reply::Ack);
            }
            HostMsg::Home { axes } => {
                if self.latch.phase() == Phase::Alarm {
                    return Err(ErrorCode::Alarm);
                }
                if !self.config.on(Key::Homing) {
                    return Err(ErrorCode::Rejected);
                }
                if !self.idle(&exec()) || self.home.is_some() {
                    return Err(ErrorCode::Busy);
                }
                self.home = Some(axes & 7);
                return Ok(Reply::Ack);
            }
            HostMsg::GetSetting { id } => {
                let v = self
                    .config
                    .by_id(id)
                    .map_err(|_| ErrorCode::UnknownSetting)?;
                return Ok(Reply::Setting(id, v));
            }
            HostMsg::SetSetting { id, value } => {
                self.writable(&exec())?;
                let info = self.config.set(id, value).map_err(|e| match e {
                    SettingError::Unknown => ErrorCode::UnknownSetting,
                    SettingError::OutOfRange => ErrorCode::OutOfRange,
                })?;
                self.config_version = self.config_version.wrapping_add(1);
                self.save = true;
                self.restart_needed |= info.apply == Apply::Restart;
                return Ok(Reply::Setting(id, value));
            }
            HostMsg::Machine { seq, cmd } => (
                seq,
                machine_in_range(&cmd).then_some(Cmd::Machine { seq, cmd }),
            ),
            HostMsg::Hold => {
                self.controls.hold = Some(true);
                return Ok(Reply::Ack);
            }
            HostMsg::Resume => {
                self.controls.hold = Some(false);
                return Ok(Reply::Ack);
            }
            HostMsg::Override { percent } => {
                if !(link::OVERRIDE_MIN_PERCENT..=link::OVERRIDE_MAX_PERCENT).contains(&percent) {
                    return Err(ErrorCode::OutOfRange);
                }
                self.controls.override_percent = Some(percent);
                return Ok(Reply::Ack);
            }
            HostMsg::SpindleOverride { percent } => {
                let range = link::SPINDLE_OVERRIDE_MIN_PERCENT..=link::SPINDLE_OVERRIDE_MAX_PERCENT;
                if !range.contains(&percent) {
                    return Err(ErrorCode::OutOfRange);
                }
                self.controls.spindle_percent = Some(percent);
                return Ok(Reply::Ack);
            }
            HostMsg::Force { fx_n_q16, fy_n_q16 } => {
                let f = force_from_link(fx_n_q16, fy_n_q16).ok_or(ErrorCode::OutOfRange)?;
                self.controls.force = Some(f);
                return Ok(Reply::Ack);
            }
            HostMsg::Abort { next_seq } => {
                self.session.abort(next_seq);
                self.abort = true;
                return Ok(Reply::Ack);
            }
            HostMsg::Reports { planner } => {
                self.reports = planner;
                return Ok(Reply::Ack);
            }
            HostMsg::Points { seq, batch } => {
                // All or nothing for what is wrong in the frame itself: every
                // point is checked before the first is taken.
                for p in batch.points() {
                    let p = p?;
                    point_from_link(0, p.pos_mm, p.feed_cap_mm_per_min)
                        .ok_or(ErrorCode::OutOfRange)?;
                    if !self.config.within_travel(p.pos_mm) {
                        return Err(ErrorCode::OutOfTravel);
                    }
                }
                for (i, p) in batch.points().enumerate() {
                    let p = p?;
                    let s = seq.wrapping_add(i as u32);
                    let cmd = point_from_link(s, p.pos_mm, p.feed_cap_mm_per_min).map(Cmd::point);
                    self.session.accept(s, cmd, queue)?;
                }
                return Ok(Reply::Ack);
            }
            HostMsg::StartPath {
                seq,
                f_max_mm_per_min,
                f_min_mm_per_min,
            } => (
                seq,
                config_from_link(f_max_mm_per_min, f_min_mm_per_min).map(Cmd::StartPath),
            ),
            HostMsg::Point {
                seq,
                pos_mm,
                feed_cap_mm_per_min,
            } => {
                if !self.config.within_travel(pos_mm) && !before(seq, self.session.next_seq) {
                    return Err(ErrorCode::OutOfTravel);
                }
                (
                    seq,
                    point_from_link(seq, pos_mm, feed_cap_mm_per_min).map(Cmd::point),
                )
            }
            HostMsg::EndPath { seq } => (seq, Some(Cmd::EndPath)),
            HostMsg::Probe {
                seq,
                target_mm,
                feed_mm_per_min,
                toward,
                error_if_missed,
            } => {
                if !self.config.within_travel(target_mm) && !before(seq, self.session.next_seq) {
                    return Err(ErrorCode::OutOfTravel);
                }
                let p = probe_from_link(seq, target_mm, feed_mm_per_min, toward, error_if_missed);
                (seq, p.map(Cmd::from))
            }
        };
        self.session.accept(seq, cmd, queue)?;
        Ok(Reply::Ack)
    }

    /// The background takes the next command (under the lock, so that the
    /// receive side sees the queue and the count change together).
    pub fn take_command(&mut self, queue: &mut Consumer<'_, Cmd, CMD_QUEUE>) -> Taken {
        let void = before(self.session.taken, self.session.void_until);
        if !void && self.abort {
            // The background handles the abort first.
            return Taken::Nothing;
        }
        let Some(cmd) = queue.dequeue() else {
            return Taken::Nothing;
        };
        self.session.taken = self.session.taken.wrapping_add(1);
        self.session.taken_since_ack = self.session.taken_since_ack.wrapping_add(1);
        if void {
            Taken::Void
        } else {
            Taken::Live(cmd)
        }
    }

    /// Drop the next command if an abort voided it; whether one was.
    pub fn drop_void(&mut self, queue: &mut Consumer<'_, Cmd, CMD_QUEUE>) -> bool {
        if !before(self.session.taken, self.session.void_until) || queue.dequeue().is_none() {
            return false;
        }
        self.session.taken = self.session.taken.wrapping_add(1);
        self.session.taken_since_ack = self.session.taken_since_ack.wrapping_add(1);
        true
    }

    /// An abort the background has to carry out, once.
    pub fn take_abort(&mut self) -> bool {
        core::mem::take(&mut self.abort)
    }

    /// Once a background pass (`busy`: it did work this pass): return the
    /// credit of taken commands to the host, every [`CREDIT_BATCH`] taken,
    /// or once the queue has run dry with the background idle (the end of
    /// a path: the host has the whole window for the next one). Not one
    /// update per command taken: each costs the return wire a frame, and
    /// a host short of credit (less than a batch, `link::client`'s
    /// `MIN_BATCH`) still has most of the queue's commands here, so the
    /// motion does not wait for a smaller update. Every acknowledgement
    /// and status carries the credit too.
    pub fn poll(&mut self, busy: bool) {
        let n = self.session.taken_since_ack;
        let due = n >= CREDIT_BATCH || (n > 0 && !busy && self.session.queued() == 0);
        if due && self.tx.send(&self.session.ack(), 0) {
            self.session.taken_since_ack = 0;
        }
    }

    /// The status reply, with the tick's state `exec`. The motion state is
    /// the executed tick's, except that a tick at rest while the
    /// background has work (a path taken whose first setpoints are still
    /// in the ring, a spin-up, a probing move about to start) reads
    /// `Running`: `Idle` means nothing left to do, so that a host may
    /// take it for the end of what it sent.
    pub fn status(&self, exec: &TickExecutor) -> Status {
        let (l, i) = (&self.session, &self.info);
        Status {
            motion: match exec.now.state {
                _ if self.latch.phase() == Phase::Alarm => Motion::Alarm,
                _ if i.homing => Motion::Homing,
                MotionState::Idle | MotionState::Done if !i.idle => Motion::Running,
                MotionState::Idle | MotionState::Done => Motion::Idle,
                MotionState::Moving => Motion::Running,
                MotionState::Holding => Motion::Held,
                MotionState::Starved => Motion::Starved,
            },
            pos_mm: exec.now.pos.to_bits(),
            feed_mm_per_min: exec.now.feed().0.to_bits(),
            override_percent: i.override_percent,
            next_seq: l.next_seq,
            window_end: l.window_end(),
            planned_points: i.planned,
            points_held: i.points_held,
            point_reached: i.point,
            underruns: i.underruns,
            bad_frames: l.bad_frames,
            worst_tick_cycles: exec.worst_cycles,
            stack_used_bytes: i.stack,
            ticks: exec.ticks,
            moving_ticks: exec.moving_ticks,
            empty_ticks: exec.empty_ticks,
            generated_ticks: i.generated,
            positions_checksum: i.checksum,
            step_lag_ticks: exec.steps.lag_ticks,
            step_lag_max_steps: exec.steps.lag_max_steps,
            step_late_ticks: exec.steps.late_windows,
        }
    }
}

/// A machine command the controller can carry out: a dwell of at most
/// [`link::DWELL_MAX_MS`] (a longer one is refused, `OutOfRange`).
fn machine_in_range(c: &link::MachineCmd) -> bool {
    !matches!(c, link::MachineCmd::Dwell { ms } if *ms > link::DWELL_MAX_MS)
}
