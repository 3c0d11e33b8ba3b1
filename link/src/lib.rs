//! The serial link between a host and the motion controller.
//!
//! One frame carries one message:
//!
//! ```text
//! COBS( tag ‖ postcard(message) ‖ CRC-32/ISO-HDLC(tag ‖ postcard bytes), little endian ) ‖ 0x00
//! ```
//!
//! - the tag byte says which way the message goes and the protocol version
//!   ([`Message::TAG`]: `0xA0 |` [`PROTOCOL_VERSION`] `<< 1`, plus 1 from
//!   the controller): a host's message never decodes on another host, nor a
//!   controller's on a controller ([`ErrorCode::Misdirected`]), and a peer
//!   of another version is told so instead of misreading it;
//! - [`postcard`] serialises the messages ([`HostMsg`], [`DeviceMsg`]): varint
//!   integers, enum variants by index; a frame must be consumed exactly
//!   (bytes after the message: [`ErrorCode::Malformed`]);
//! - the CRC ([`crc`], CRC-32 as in Ethernet/zlib) catches corrupted bytes;
//! - COBS ([`cobs`]) removes every zero byte, so `0x00` marks the end of a
//!   frame and a receiver resynchronises on the next one after garbage.
//!
//! Everything is `no_std`, allocation-free and panic-free; errors are values
//! ([`FrameError`]), so the firmware can answer a bad frame with an error
//! reply and drop it.
//!
//! # Sequencing and credit
//! Commands that move through the controller's queue in order ([`HostMsg::StartPath`],
//! [`HostMsg::Point`], [`HostMsg::Points`], [`HostMsg::EndPath`],
//! [`HostMsg::Machine`]) carry a sequence number `seq`,
//! 0, 1, 2, … from boot. The controller accepts only `seq == next expected`;
//! a repeat of an accepted `seq` is acknowledged again (so resending is
//! harmless), anything else is refused with [`ErrorCode::OutOfSequence`]. Its
//! [`DeviceMsg::Ack`] says which `seq` it expects next and up to which `seq`
//! (exclusive) the host may send: the credit, the free room of its receive
//! queue. A host that never sends past the credit can never overrun that
//! queue; one that does gets [`ErrorCode::NoCredit`] and the command is
//! dropped. Acknowledged commands are in the queue: nothing acknowledged is
//! ever dropped.
#![cfg_attr(not(any(test, feature = "std")), no_std)]
#![deny(missing_docs)]

pub mod batch;
#[cfg(feature = "std")]
pub mod client;

pub use batch::{BatchPoint, PointBatch};

use crc::{Crc, CRC_32_ISO_HDLC};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

/// The protocol's version (in every frame's tag byte).
pub const PROTOCOL_VERSION: u8 = 4;

/// A message of the link: which way it goes (its tag).
pub trait Message: Serialize + DeserializeOwned {
    /// The tag byte that starts its frames.
    const TAG: u8;
}

/// Tags start at `0xA0`, far above a version-1 frame's first byte (its
/// message's variant index, below 16).
const TAG_BASE: u8 = 0xA0;

impl Message for HostMsg {
    const TAG: u8 = TAG_BASE | (PROTOCOL_VERSION << 1);
}

impl Message for DeviceMsg {
    const TAG: u8 = TAG_BASE | (PROTOCOL_VERSION << 1) | 1;
}

/// Largest frame on the wire, delimiter included, bytes (the largest
/// payload and its CRC, COBS-encoded: one byte more, and the delimiter).
pub const FRAME_MAX: usize = 136;
/// Largest payload (tag and postcard bytes), bytes: a [`Status`] with every
/// field at its maximum.
pub const PAYLOAD_MAX: usize = 127;
/// CRC bytes after the payload.
pub const CRC_LEN: usize = 4;
/// The frame delimiter.
pub const DELIMITER: u8 = 0;

const CRC32: Crc<u32> = Crc::<u32>::new(&CRC_32_ISO_HDLC);

/// The link's CRC-32 (ISO-HDLC, as Ethernet and zlib) of `words`, each
/// little endian, for other records that want the same check (the
/// controller's stored settings).
pub fn crc32_words(words: &[u32]) -> u32 {
    let mut d = CRC32.digest();
    for w in words {
        d.update(&w.to_le_bytes());
    }
    d.finalize()
}

/// Fixed-point raw bits: I32F32 (value × 2^32), for positions in mm and
/// feeds in mm/min. Exact on both sides of the link.
pub type I32F32Bits = i64;

/// Host to controller.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum HostMsg {
    /// Ask for a [`DeviceMsg::Status`] (answered at once).
    StatusQuery,
    /// Start a path (queued): maximum and minimum feed of the scheduler,
    /// mm/min as I32F32 bits.
    StartPath {
        /// Sequence number.
        seq: u32,
        /// F_max, mm/min, I32F32 bits.
        f_max_mm_per_min: I32F32Bits,
        /// F_min, mm/min, I32F32 bits.
        f_min_mm_per_min: I32F32Bits,
    },
    /// A point of the path (queued).
    Point {
        /// Sequence number (reported back as the point's tag).
        seq: u32,
        /// Position, mm, I32F32 bits per axis.
        pos_mm: [I32F32Bits; 3],
        /// Largest feed on the way to this point, mm/min, I32F32 bits.
        feed_cap_mm_per_min: Option<I32F32Bits>,
    },
    /// End of the path (queued): the scheduler flushes its lookahead.
    EndPath {
        /// Sequence number.
        seq: u32,
    },
    /// Feed hold: decelerate to a stop on the path (immediate).
    Hold,
    /// Release a feed hold (immediate).
    Resume,
    /// Feed override, percent of the scheduled feed, 10..=200 (immediate).
    Override {
        /// Percent.
        percent: u16,
    },
    /// Measured peak cutting forces of the last spindle revolution (a
    /// dynamometer's), immediate: one step of Njiri et al.'s force-feedback
    /// controller (`fuzzy_core::njiri::ForceOverride`, the paper's
    /// references 120 N and 40 N and incremental law,
    /// `OverrideConfig::PAPER`), whose output becomes the feed override as
    /// if sent by [`HostMsg::Override`] (rounded to a percent, at least
    /// [`OVERRIDE_MIN_PERCENT`]; the controller's range is 0-150 %). Forces
    /// above the references lower the feed, below raise it. The loop
    /// keeps its own override: a manual [`HostMsg::Override`] lasts until
    /// the next force sample. Both values are magnitudes, newtons in
    /// Q16.16 bits (value × 65 536, up to 32 767 N); a negative one is
    /// refused ([`ErrorCode::OutOfRange`]). (Appended last: older
    /// messages keep their encoding.)
    Force {
        /// Peak |F_x|, N, Q16.16 bits.
        fx_n_q16: i32,
        /// Peak |F_y|, N, Q16.16 bits.
        fy_n_q16: i32,
    },
    /// Abort (immediate; Grbl's soft reset): the motion stops under control
    /// on the path (as a feed hold does), then every path command queued or
    /// held in the lookahead is dropped and the planner's buffer flushed;
    /// [`DeviceMsg::Aborted`] reports what was discarded and where the tool
    /// stopped. Acknowledged at once. The host's next path command will be
    /// `next_seq`: everything it sent before is void (a late copy is
    /// acknowledged and ignored), so it may start a new path at once.
    Abort {
        /// The sequence number of the host's next path command (at least
        /// the controller's next expected one).
        next_seq: u32,
    },
    /// Several points of the path (queued), compactly ([`batch`]): points
    /// `seq`, `seq + 1`, … Each is a path command of its own for the
    /// sequence and credit rules (those before the expected one are
    /// acknowledged again, the rest taken in order as far as the credit
    /// goes), as if sent as [`HostMsg::Point`]s.
    Points {
        /// Sequence number of the first point.
        seq: u32,
        /// The points.
        batch: PointBatch,
    },
    /// Whether the controller reports every input of its planner
    /// ([`DeviceMsg::Scheduled`], [`DeviceMsg::Planned`]; on from reset).
    /// They let a host replay the motion bit for bit, and cost about 23
    /// bytes of the return channel per point: a sender that does not
    /// check the motion turns them off (immediate).
    Reports {
        /// Planner inputs reported.
        planner: bool,
    },
    /// Emergency stop (immediate): the controller enters its alarm state
    /// ([`AlarmCode::EStopLink`]); the step output stops at the next tick,
    /// with no deceleration (unlike [`HostMsg::Hold`] and
    /// [`HostMsg::Abort`], which stop on the path under control), the
    /// drivers are disabled and everything queued is dropped.
    EStop,
    /// Leave the alarm state (Grbl's `$X`), if no e-stop input is active
    /// ([`ErrorCode::InputActive`]). Path commands are refused
    /// ([`ErrorCode::Alarm`]) until then.
    Unlock,
    /// Run the homing cycle (Grbl's `$H`) on these axes (bit 0 X, 1 Y, 2
    /// Z; 0: every axis of the configured cycle), at rest with nothing
    /// queued; [`DeviceMsg::Homed`] reports its end.
    Home {
        /// Axes, a bit mask.
        axes: u8,
    },
    /// A machine command carried in the path stream (queued, sequenced
    /// like a point): it takes effect when the motion reaches it
    /// ([`DeviceMsg::Applied`]).
    Machine {
        /// Sequence number.
        seq: u32,
        /// What.
        cmd: MachineCmd,
    },
    /// Read a setting (answered with [`DeviceMsg::Setting`]).
    GetSetting {
        /// Its id (Grbl's `$N` numbering where one exists).
        id: u16,
    },
    /// Write a setting (at rest with nothing queued or in a carried-out
    /// alarm only, [`ErrorCode::Busy`] otherwise; with the spindle and
    /// coolant off, [`ErrorCode::OutputsOn`] otherwise):
    /// checked ([`ErrorCode::OutOfRange`], [`ErrorCode::UnknownSetting`]:
    /// nothing changed), stored, answered with [`DeviceMsg::Setting`].
    SetSetting {
        /// Its id.
        id: u16,
        /// The value, in the setting's unit.
        value: i64,
    },
    /// Ask for a [`DeviceMsg::Machine`] (answered at once).
    MachineQuery,
    /// A probing move (G38.2-.5; queued, sequenced like a point): it ends
    /// the open path, waits for the tool to be at rest, then moves straight
    /// to `target_mm` at `feed_mm_per_min` and stops under control when the
    /// probe input changes; [`DeviceMsg::Probed`] reports where it changed
    /// (Grbl's `mc_probe_cycle`). The probe already in the state it watches
    /// for at the start is [`AlarmCode::ProbeFailInitial`]; the move ended
    /// without a change, with `error_if_missed`,
    /// [`AlarmCode::ProbeFailContact`]. (Appended last: older messages keep
    /// their encoding.)
    Probe {
        /// Sequence number.
        seq: u32,
        /// The end of the move, machine coordinates, mm, I32F32 bits.
        target_mm: [I32F32Bits; 3],
        /// Feed, mm/min, I32F32 bits (at least 1 mm/min).
        feed_mm_per_min: I32F32Bits,
        /// Stop on the input becoming active (G38.2, G38.3), else on it
        /// becoming inactive (G38.4, G38.5).
        toward: bool,
        /// Reaching the target without a change is an alarm (G38.2,
        /// G38.4).
        error_if_missed: bool,
    },
    /// Spindle speed override, percent of the programmed speed,
    /// [`SPINDLE_OVERRIDE_MIN_PERCENT`]..=[`SPINDLE_OVERRIDE_MAX_PERCENT`]
    /// (immediate, Grbl's 0x99-0x9D): the spindle's output follows at once,
    /// the programmed speed is kept. (Appended last: older messages keep
    /// their encoding.)
    SpindleOverride {
        /// Percent.
        percent: u16,
    },
}

/// A machine command of the path stream ([`HostMsg::Machine`]).
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MachineCmd {
    /// Spindle on (M3 clockwise, M4 counter-clockwise) at a speed, or off
    /// (M5).
    Spindle {
        /// Direction, or off.
        dir: SpindleDir,
        /// Speed (S), rpm.
        speed_rpm: u32,
    },
    /// Coolant: flood (M8), mist (M7); both off is M9.
    Coolant {
        /// Flood coolant on.
        flood: bool,
        /// Mist coolant on.
        mist: bool,
    },
    /// A dwell (G4 P): the tool at rest this long before the next path
    /// starts (at most [`DWELL_MAX_MS`]).
    Dwell {
        /// Milliseconds.
        ms: u32,
    },
    /// Path control (G61/G61.1, G64, G64 P): the tolerance the planner
    /// may use for chords and corner blending from the next path on
    /// (appended last: the other commands keep their encoding).
    PathControl(PathControl),
}

/// Path control of a program ([`MachineCmd::PathControl`]).
#[derive(Serialize, Deserialize, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PathControl {
    /// G64: the machine's tolerance (`$203`).
    #[default]
    Blend,
    /// G64 P: this tolerance, within the machine's largest (`$210`).
    Tolerance {
        /// Nanometres (at least 1).
        nm: u32,
    },
    /// G61, G61.1: exact path, a stop at every vertex where the path turns.
    Exact,
}

/// The longest dwell a `MachineCmd::Dwell` may ask for, ms (one hour).
pub const DWELL_MAX_MS: u32 = 3_600_000;

/// The spindle's direction, or off.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SpindleDir {
    /// Off (M5).
    #[default]
    Off,
    /// Clockwise (M3).
    Cw,
    /// Counter-clockwise (M4).
    Ccw,
}

/// Why the controller entered its alarm state (`DeviceMsg::Alarm`).
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AlarmCode {
    /// The e-stop input became active.
    EStopInput,
    /// An e-stop message ([`HostMsg::EStop`]).
    EStopLink,
    /// A limit switch became active (hard limits on).
    HardLimit {
        /// Axis, 0 X, 1 Y, 2 Z.
        axis: u8,
        /// The maximum-end switch (else the minimum end).
        max: bool,
    },
    /// The motion would have left the travel (soft limits on).
    SoftLimit,
    /// The firmware was restarted by its watchdog.
    Watchdog,
    /// The step output fell behind the commanded position.
    StepLag,
    /// The link went silent while a path was open, and the tool came to a
    /// controlled stop for want of path.
    LinkLoss,
    /// Homing: the switch was not found within the search distance.
    HomingNoSwitch {
        /// Axis.
        axis: u8,
    },
    /// Homing: the switch was still active after the pull-off.
    HomingPullOff {
        /// Axis.
        axis: u8,
    },
    /// Homing was interrupted (an abort).
    HomingAborted,
    /// The firmware restarted after a hard fault (a bug: please report
    /// it with the address and the firmware build).
    Fault {
        /// The program counter where the fault happened.
        pc: u32,
    },
    /// Probing: the probe was already in the state the move watches for
    /// when it was to start (Grbl's `ALARM:4`).
    ProbeFailInitial,
    /// Probing: the move reached its target without the probe changing,
    /// G38.2/G38.4 (Grbl's `ALARM:5`).
    ProbeFailContact,
}

/// What became of the stored settings (`DeviceMsg::Stored`).
#[derive(Serialize, Deserialize, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StoreResult {
    /// Read from flash at start-up.
    #[default]
    Loaded,
    /// Nothing stored yet: the defaults.
    Empty,
    /// The stored record was corrupt: the last good record, or the
    /// defaults if there is none.
    Corrupt,
    /// The stored record is of another format version: the defaults.
    OldVersion,
    /// Written to flash.
    Saved,
    /// Writing failed (it did not read back): in force until a reset.
    WriteFailed,
}

/// The machine's state beyond the motion, answer to
/// [`HostMsg::MachineQuery`].
#[derive(Serialize, Deserialize, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MachineStatus {
    /// The alarm in force, if any.
    pub alarm: Option<AlarmCode>,
    /// Alarms since boot.
    pub alarms: u32,
    /// A homing cycle is running.
    pub homing: bool,
    /// Axes homed since boot (bit 0 X, 1 Y, 2 Z).
    pub homed: u8,
    /// Inputs active (debounced): bit 0 e-stop, then X min, X max, Y min,
    /// Y max, Z min, Z max; bit 7 the probe.
    pub inputs: u8,
    /// Spindle direction, or off.
    pub spindle: SpindleDir,
    /// Spindle speed, rpm.
    pub speed_rpm: u32,
    /// Flood coolant on.
    pub flood: bool,
    /// Mist coolant on.
    pub mist: bool,
    /// The settings store: how it was read at start-up or the last write.
    pub store: StoreResult,
    /// A setting changed that takes effect only at the next reset.
    pub restart_needed: bool,
    /// The step timer interrupt's worst share of a tick period so far,
    /// per mille of the core (its calls' cycles within one period, each
    /// from its first instruction to its last); 0 where the tick runs the
    /// step engine itself (QEMU: within `Status::worst_tick_cycles`).
    pub step_isr_permille: u16,
}

/// Smallest feed override, percent.
pub const OVERRIDE_MIN_PERCENT: u16 = 10;
/// Largest feed override, percent.
pub const OVERRIDE_MAX_PERCENT: u16 = 200;
/// Smallest spindle speed override, percent (Grbl's
/// `MIN_SPINDLE_SPEED_OVERRIDE`).
pub const SPINDLE_OVERRIDE_MIN_PERCENT: u16 = 10;
/// Largest spindle speed override, percent (Grbl's
/// `MAX_SPINDLE_SPEED_OVERRIDE`).
pub const SPINDLE_OVERRIDE_MAX_PERCENT: u16 = 200;

/// What the motion is doing (the firmware's planner state: `Done` and
/// `Idle` are both [`Motion::Idle`]).
#[derive(Serialize, Deserialize, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Motion {
    /// At rest, nothing to do.
    #[default]
    Idle,
    /// Moving.
    Running,
    /// Feed hold (decelerating or stopped).
    Held,
    /// Out of path while the path is open: stopping or stopped, waiting.
    Starved,
    /// In the alarm state (stopped, drivers off; `HostMsg::Unlock`).
    Alarm,
    /// Running the homing cycle.
    Homing,
}

/// The controller's state, answer to [`HostMsg::StatusQuery`].
///
/// Motion figures (`motion`, `pos_mm`, `feed_mm_per_min`, `point_reached`,
/// the tick counters) are those of the tick being executed; the planner
/// runs a few ticks ahead of it. `motion` is [`Motion::Idle`] only when
/// nothing is left to do: a tick at rest while the controller has work
/// queued behind it (a path just taken, a spin-up) reads
/// [`Motion::Running`].
#[derive(Serialize, Deserialize, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Status {
    /// Motion state.
    pub motion: Motion,
    /// Position setpoint, mm, I32F32 bits per axis.
    pub pos_mm: [I32F32Bits; 3],
    /// Current feed (tangential speed), mm/min, I32F32 bits.
    pub feed_mm_per_min: I32F32Bits,
    /// Feed override in force, percent.
    pub override_percent: u16,
    /// Next sequence number expected.
    pub next_seq: u32,
    /// Credit: the host may send up to this sequence number, exclusive.
    pub window_end: u32,
    /// Points in the velocity planner's buffer.
    pub planned_points: u16,
    /// Points held in the scheduler's lookahead.
    pub points_held: u16,
    /// Index in the current path of the last point reached: 0 is where the
    /// tool was when the path started, the path's first point is 1, so at
    /// the end of a path it is the number of points scheduled.
    pub point_reached: u32,
    /// Controlled stops caused by a path that stopped arriving.
    pub underruns: u32,
    /// Frames refused since boot.
    pub bad_frames: u32,
    /// Worst tick interrupt, SysTick cycles (QEMU: instructions × 0.168).
    pub worst_tick_cycles: u32,
    /// Stack high-water mark, bytes (painted stack).
    pub stack_used_bytes: u32,
    /// Ticks the executor ran since boot (ticks stopped by an alarm, a
    /// homing halt or a refill of the ring are not counted).
    pub ticks: u32,
    /// Ticks the current path has been moving (speed > 0), from its first
    /// move.
    pub moving_ticks: u32,
    /// Ticks at which no setpoint was ready (position held): the planner
    /// fell behind. Zero in a healthy controller.
    pub empty_ticks: u32,
    /// Setpoints the planner generated since boot (it runs up to the
    /// setpoint ring's depth ahead of `ticks − empty_ticks`, those executed).
    pub generated_ticks: u32,
    /// FNV-1a (64-bit, folded to 32: high ⊕ low) over the three I32F32
    /// coordinates of every generated setpoint since boot, in order.
    pub positions_checksum: u32,
    /// Ticks that ended with an axis short of its commanded position (step
    /// rate above what the pulse width allows, or a step plan lost): the
    /// steps are carried, never dropped. Zero in a healthy machine.
    pub step_lag_ticks: u32,
    /// Largest shortfall at a tick's end, steps.
    pub step_lag_max_steps: u32,
    /// Ticks the step engine ran without a plan (the tick interrupt late by
    /// more than half a tick): the motion after ran a tick later.
    pub step_late_ticks: u32,
}

/// A command the velocity planner took (reported by [`DeviceMsg::Planned`]).
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PlanEvent {
    /// The path ended (after its last point).
    EndPath,
    /// Feed hold on.
    Hold,
    /// Feed hold off.
    Resume,
    /// A new feed override, percent.
    Override(u16),
    /// An abort: the planner stops as for a hold, then drops its buffer.
    Abort,
    /// The planner was rebuilt at rest at this position with the settings
    /// in force (an alarm, a homing cycle or a change of settings):
    /// whatever it held is gone.
    Reset {
        /// Where it rests, mm, I32F32 bits per axis.
        pos_mm: [I32F32Bits; 3],
    },
    /// As [`PlanEvent::Reset`], with these settings in place of the
    /// machine's: a program's path control ([`MachineCmd::PathControl`]),
    /// or the machine's again after one (appended last: the other events
    /// keep their encoding).
    PathControl {
        /// Where it rests, mm, I32F32 bits per axis.
        pos_mm: [I32F32Bits; 3],
        /// Chord tolerance, nm.
        chord_nm: u32,
        /// Ticks of smoothing as set (0: the most that validates).
        smoothing_ticks: u8,
        /// Exact path.
        exact: bool,
    },
}

/// Why a frame or command was refused.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ErrorCode {
    /// Not valid COBS (garbage).
    Framing,
    /// Longer than [`FRAME_MAX`] before a delimiter (garbage or a lost
    /// delimiter).
    TooLong,
    /// Shorter than a CRC (truncated).
    TooShort,
    /// CRC mismatch (corrupted or truncated).
    Crc,
    /// CRC right but the message is not one we know.
    UnknownMessage,
    /// A known message with missing or malformed fields.
    Malformed,
    /// A value out of range (coordinate, feed, override percent, force).
    OutOfRange,
    /// Not the sequence number expected ([`DeviceMsg::Error::expected_seq`]).
    OutOfSequence,
    /// Sent past the credit window.
    NoCredit,
    /// Refused by the scheduler (e.g. a point before `StartPath`).
    Rejected,
    /// A message that goes the other way, or of another protocol version
    /// (the tag byte, [`Message::TAG`]).
    Misdirected,
    /// Refused in the alarm state (path commands, homing; `HostMsg::Unlock`).
    Alarm,
    /// A point outside the machine's travel (soft limits on).
    OutOfTravel,
    /// Motion before homing, with homing required by the settings.
    NotHomed,
    /// Needs the machine at rest with nothing queued.
    Busy,
    /// No setting with that id.
    UnknownSetting,
    /// `HostMsg::Unlock` while the e-stop input is active.
    InputActive,
    /// A setting written with the spindle or coolant on: settings are
    /// written to flash, whose erase stalls the controller, so only with
    /// the outputs off.
    OutputsOn,
}

impl ErrorCode {
    /// Whether this refuses bytes that did not make a frame of either
    /// side (line noise, a lost delimiter, a frame cut short): the frame
    /// the peer meant to send may have been swallowed with them, so the
    /// sender sends it again after a delimiter rather than taking this as
    /// the frame's refusal.
    pub fn is_line_noise(self) -> bool {
        matches!(
            self,
            ErrorCode::Framing
                | ErrorCode::TooLong
                | ErrorCode::TooShort
                | ErrorCode::Crc
                | ErrorCode::Misdirected
        )
    }
}

/// Controller to host.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DeviceMsg {
    /// Every `seq < next_seq` is accepted; the host may send `seq < window_end`.
    Ack {
        /// Next sequence number expected.
        next_seq: u32,
        /// Credit limit (exclusive).
        window_end: u32,
    },
    /// A scheduled point entered the velocity planner.
    Scheduled {
        /// The point's sequence number.
        seq: u32,
        /// Index of the point in its path.
        index: u32,
        /// Scheduled feed, mm/min, I32F32 bits (bit-exact with `fuzzy-core`).
        feed_mm_per_min: I32F32Bits,
        /// Planner ticks generated before it went in (see [`PlanEvent`]).
        tick: u32,
    },
    /// The planner took a command after `tick` generated ticks.
    ///
    /// With [`DeviceMsg::Scheduled`]'s `tick` this is the complete input
    /// of the velocity planner, in order: a host that feeds the same inputs
    /// to its own planner at the same ticks computes the same setpoints
    /// ([`Status::positions_checksum`] says whether it did).
    Planned {
        /// Planner ticks generated before the command took effect.
        tick: u32,
        /// What it was.
        event: PlanEvent,
    },
    /// State report.
    Status(Status),
    /// A frame or command was refused and dropped.
    Error {
        /// Why.
        code: ErrorCode,
        /// Next sequence number expected (resend from there).
        expected_seq: u32,
    },
    /// Sent once after reset, with the settings in force.
    Hello {
        /// Interpolation tick rate, Hz.
        tick_hz: u32,
        /// Tangential acceleration limit, mm/s² (rounded up).
        accel_mm_per_s2: u32,
        /// Credit limit (exclusive).
        window_end: u32,
        /// Largest feed the motion runs (programmed feed × override is
        /// capped to it), mm/min.
        feed_max_mm_per_min: u32,
        /// Points the velocity planner buffers.
        planner_points: u16,
    },
    /// An abort completed ([`HostMsg::Abort`]): the tool is at rest at
    /// `pos_mm`, and this much was discarded.
    Aborted {
        /// Path commands dropped from the queue.
        commands: u32,
        /// Points dropped from the scheduler's lookahead and the planner
        /// (not reached).
        points: u32,
        /// Where the tool stopped, mm, I32F32 bits per axis.
        pos_mm: [I32F32Bits; 3],
    },
    /// The controller entered its alarm state: the step output stopped,
    /// the drivers are disabled, everything queued is dropped.
    Alarm {
        /// Why.
        code: AlarmCode,
        /// Where the tool stopped, mm, I32F32 bits per axis.
        pos_mm: [I32F32Bits; 3],
        /// The sequence number the next path command must carry.
        next_seq: u32,
    },
    /// A setting's value (answer to `GetSetting`/`SetSetting`).
    Setting {
        /// Its id.
        id: u16,
        /// Its value, in the setting's unit.
        value: i64,
    },
    /// The machine's state (answer to `HostMsg::MachineQuery`).
    Machine(MachineStatus),
    /// A machine command of the path took effect.
    Applied {
        /// Its sequence number.
        seq: u32,
        /// What.
        cmd: MachineCmd,
        /// The index, in the path that ended at it, of the last point
        /// reached (the tool is at rest there).
        point: u32,
        /// Planner ticks generated before.
        tick: u32,
    },
    /// A homing cycle completed: these axes are homed, the tool rests at
    /// `pos_mm` (machine coordinates).
    Homed {
        /// Axes homed, a bit mask.
        axes: u8,
        /// Where the tool rests, mm, I32F32 bits per axis.
        pos_mm: [I32F32Bits; 3],
    },
    /// The settings store: read at start-up, or written.
    Stored(StoreResult),
    /// A probing move ([`HostMsg::Probe`]) ended, the tool at rest.
    Probed {
        /// The probe command's sequence number.
        seq: u32,
        /// Where the probe input changed, machine coordinates, mm, I32F32
        /// bits (where the tool stopped if it did not change).
        pos_mm: [I32F32Bits; 3],
        /// The input changed.
        tripped: bool,
    },
}

/// Why encoding or decoding failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum FrameError {
    /// The message does not fit [`PAYLOAD_MAX`] / the output buffer.
    BufferTooSmall,
    /// Received frame refused; the code to reply with.
    Refused(ErrorCode),
}

impl core::fmt::Display for FrameError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            FrameError::BufferTooSmall => f.write_str("message too large for a frame"),
            FrameError::Refused(code) => write!(f, "frame refused: {code:?}"),
        }
    }
}

/// Encode `msg` as a frame (delimiter included) into `out`; returns its
/// length.
pub fn encode<M: Message>(msg: &M, out: &mut [u8]) -> Result<usize, FrameError> {
    let mut raw = [0u8; PAYLOAD_MAX + CRC_LEN];
    raw[0] = M::TAG;
    let body = raw
        .get_mut(1..PAYLOAD_MAX)
        .ok_or(FrameError::BufferTooSmall)?;
    let n = 1 + postcard::to_slice(msg, body)
        .map_err(|_| FrameError::BufferTooSmall)?
        .len();
    let (payload, rest) = raw.split_at_mut(n.min(PAYLOAD_MAX));
    let crc = CRC32.checksum(payload).to_le_bytes();
    rest.get_mut(..CRC_LEN)
        .ok_or(FrameError::BufferTooSmall)?
        .copy_from_slice(&crc);
    let body = raw.get(..n + CRC_LEN).ok_or(FrameError::BufferTooSmall)?;
    let m = cobs::try_encode(body, out).map_err(|_| FrameError::BufferTooSmall)?;
    *out.get_mut(m).ok_or(FrameError::BufferTooSmall)? = DELIMITER;
    Ok(m + 1)
}

/// [`encode`] for the device's replies, compiled in this crate: the
/// firmware calls this one so that postcard's varint writer is inlined and
/// its bounds checks folded at this crate's opt-level (the firmware's
/// `opt-level = "z"` would outline the slice index and keep its
/// unreachable panic path; see firmware/Cargo.toml).
pub fn encode_device(msg: &DeviceMsg, out: &mut [u8]) -> Result<usize, FrameError> {
    encode(msg, out)
}

/// Check and decode one frame's content (COBS already undone): the tag,
/// the postcard payload, its CRC. The message must use every byte.
pub fn decode_payload<M: Message>(body: &[u8]) -> Result<M, ErrorCode> {
    if body.len() <= CRC_LEN + 1 {
        return Err(ErrorCode::TooShort);
    }
    let (payload, crc) = body
        .split_at_checked(body.len() - CRC_LEN)
        .ok_or(ErrorCode::TooShort)?;
    let mut want = [0u8; CRC_LEN];
    for (w, c) in want.iter_mut().zip(crc) {
        *w = *c;
    }
    if CRC32.checksum(payload) != u32::from_le_bytes(want) {
        return Err(ErrorCode::Crc);
    }
    let (&tag, message) = payload.split_first().ok_or(ErrorCode::TooShort)?;
    if tag != M::TAG {
        return Err(ErrorCode::Misdirected);
    }
    match postcard::take_from_bytes::<M>(message) {
        Ok((m, [])) => Ok(m),
        Ok(_) => Err(ErrorCode::Malformed),
        // serde reports an unknown variant index as a custom error.
        Err(postcard::Error::DeserializeBadEnum | postcard::Error::SerdeDeCustom) => {
            Err(ErrorCode::UnknownMessage)
        }
        Err(_) => Err(ErrorCode::Malformed),
    }
}

/// Collects bytes into frames: feed it every received byte; it returns a
/// complete frame's result at each delimiter. COBS is undone on the fly
/// (`cobs::DecoderState`); a frame longer than [`FRAME_MAX`] is dropped up
/// to the next delimiter ([`ErrorCode::TooLong`], reported once).
#[derive(Debug)]
pub struct FrameReader {
    buf: [u8; FRAME_MAX],
    len: usize,
    cobs: cobs::DecoderState,
    overflow: bool,
    broken: bool,
    started: bool,
}

impl Default for FrameReader {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameReader {
    /// An empty reader.
    pub const fn new() -> Self {
        FrameReader {
            buf: [0; FRAME_MAX],
            len: 0,
            cobs: cobs::DecoderState::Idle,
            overflow: false,
            broken: false,
            started: false,
        }
    }

    /// Take one byte. `None` while a frame is incomplete (and for empty
    /// frames, i.e. repeated delimiters); at a delimiter, the frame's
    /// message or why it was refused.
    ///
    /// Once a frame is known bad (too long, or not COBS), the rest of it
    /// up to the delimiter costs a comparison a byte and gets one refusal
    /// at that delimiter, however long the run.
    pub fn push<M: Message>(&mut self, byte: u8) -> Option<Result<M, ErrorCode>> {
        if byte != DELIMITER {
            if self.overflow || self.broken {
                return None;
            }
            self.started = true;
            match self.cobs.feed(byte) {
                Ok(cobs::DecodeResult::DataContinue(b)) => match self.buf.get_mut(self.len) {
                    Some(slot) => {
                        *slot = b;
                        self.len += 1;
                    }
                    None => self.overflow = true,
                },
                Ok(_) => {}
                Err(_) => self.broken = true,
            }
            return None;
        }
        let end = core::mem::replace(&mut self.cobs, cobs::DecoderState::Idle).feed(DELIMITER);
        let (len, overflow, broken, started) = (self.len, self.overflow, self.broken, self.started);
        self.len = 0;
        self.overflow = false;
        self.broken = false;
        self.started = false;
        if !started {
            return None;
        }
        if overflow {
            return Some(Err(ErrorCode::TooLong));
        }
        if broken || !matches!(end, Ok(cobs::DecodeResult::DataComplete)) {
            return Some(Err(ErrorCode::Framing));
        }
        let body = self.buf.get(..len)?;
        Some(decode_payload(body))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn roundtrip<T: Message + PartialEq + core::fmt::Debug>(m: T) {
        let mut out = [0u8; FRAME_MAX];
        let n = encode(&m, &mut out).unwrap();
        assert_eq!(out[n - 1], 0);
        assert!(out[..n - 1].iter().all(|b| *b != 0));
        let mut r = FrameReader::new();
        let mut got = None;
        for b in &out[..n] {
            if let Some(x) = r.push::<T>(*b) {
                got = Some(x);
            }
        }
        assert_eq!(got, Some(Ok(m)));
    }

    #[test]
    fn every_message_round_trips_and_fits() {
        roundtrip(HostMsg::Point {
            seq: u32::MAX,
            pos_mm: [i64::MIN, i64::MAX, -1],
            feed_cap_mm_per_min: Some(i64::MAX),
        });
        roundtrip(HostMsg::Override { percent: 200 });
        roundtrip(HostMsg::Force {
            fx_n_q16: i32::MAX,
            fy_n_q16: i32::MIN,
        });
        roundtrip(HostMsg::StartPath {
            seq: 7,
            f_max_mm_per_min: 3000 << 32,
            f_min_mm_per_min: 60 << 32,
        });
        roundtrip(DeviceMsg::Status(Status {
            pos_mm: [i64::MIN; 3],
            feed_mm_per_min: i64::MIN,
            next_seq: u32::MAX,
            window_end: u32::MAX,
            point_reached: u32::MAX,
            underruns: u32::MAX,
            bad_frames: u32::MAX,
            worst_tick_cycles: u32::MAX,
            stack_used_bytes: u32::MAX,
            ticks: u32::MAX,
            moving_ticks: u32::MAX,
            empty_ticks: u32::MAX,
            generated_ticks: u32::MAX,
            positions_checksum: u32::MAX,
            step_lag_ticks: u32::MAX,
            step_lag_max_steps: u32::MAX,
            step_late_ticks: u32::MAX,
            planned_points: u16::MAX,
            points_held: u16::MAX,
            override_percent: u16::MAX,
            motion: Motion::Starved,
        }));
        roundtrip(DeviceMsg::Hello {
            tick_hz: u32::MAX,
            accel_mm_per_s2: u32::MAX,
            window_end: u32::MAX,
            feed_max_mm_per_min: u32::MAX,
            planner_points: u16::MAX,
        });
        roundtrip(DeviceMsg::Scheduled {
            seq: u32::MAX,
            index: u32::MAX,
            feed_mm_per_min: i64::MIN,
            tick: u32::MAX,
        });
        roundtrip(DeviceMsg::Planned {
            tick: u32::MAX,
            event: PlanEvent::Override(u16::MAX),
        });
        roundtrip(DeviceMsg::Error {
            code: ErrorCode::Misdirected,
            expected_seq: 3,
        });
        roundtrip(HostMsg::Abort { next_seq: u32::MAX });
        roundtrip(HostMsg::Reports { planner: false });
        let mut batch = PointBatch::new();
        while batch.push(BatchPoint {
            pos_mm: [i64::MIN & !0xFFFF, i64::MAX & !0xFFFF, 0],
            feed_cap_mm_per_min: Some(i64::MAX - 1),
        }) {}
        roundtrip(HostMsg::Points {
            seq: u32::MAX,
            batch,
        });
        roundtrip(DeviceMsg::Aborted {
            commands: u32::MAX,
            points: u32::MAX,
            pos_mm: [i64::MIN; 3],
        });
        roundtrip(DeviceMsg::Planned {
            tick: 0,
            event: PlanEvent::Abort,
        });
    }

    #[test]
    fn the_machine_messages_round_trip_and_fit() {
        for m in [
            HostMsg::EStop,
            HostMsg::Unlock,
            HostMsg::Home { axes: u8::MAX },
            HostMsg::Machine {
                seq: u32::MAX,
                cmd: MachineCmd::Spindle {
                    dir: SpindleDir::Ccw,
                    speed_rpm: u32::MAX,
                },
            },
            HostMsg::Machine {
                seq: 0,
                cmd: MachineCmd::Coolant {
                    flood: true,
                    mist: false,
                },
            },
            HostMsg::GetSetting { id: u16::MAX },
            HostMsg::SetSetting {
                id: u16::MAX,
                value: i64::MIN,
            },
            HostMsg::MachineQuery,
            HostMsg::Probe {
                seq: u32::MAX,
                target_mm: [i64::MIN; 3],
                feed_mm_per_min: i64::MIN,
                toward: true,
                error_if_missed: true,
            },
            HostMsg::SpindleOverride { percent: u16::MAX },
        ] {
            roundtrip(m);
        }
        let worst_alarm = AlarmCode::HardLimit {
            axis: u8::MAX,
            max: true,
        };
        for m in [
            DeviceMsg::Alarm {
                code: worst_alarm,
                pos_mm: [i64::MIN; 3],
                next_seq: u32::MAX,
            },
            DeviceMsg::Setting {
                id: u16::MAX,
                value: i64::MIN,
            },
            DeviceMsg::Machine(MachineStatus {
                alarm: Some(worst_alarm),
                alarms: u32::MAX,
                homing: true,
                homed: u8::MAX,
                inputs: u8::MAX,
                spindle: SpindleDir::Ccw,
                speed_rpm: u32::MAX,
                flood: true,
                mist: true,
                store: StoreResult::WriteFailed,
                restart_needed: true,
                step_isr_permille: u16::MAX,
            }),
            DeviceMsg::Applied {
                seq: u32::MAX,
                cmd: MachineCmd::Spindle {
                    dir: SpindleDir::Cw,
                    speed_rpm: u32::MAX,
                },
                point: u32::MAX,
                tick: u32::MAX,
            },
            DeviceMsg::Homed {
                axes: u8::MAX,
                pos_mm: [i64::MIN; 3],
            },
            DeviceMsg::Stored(StoreResult::Corrupt),
            DeviceMsg::Probed {
                seq: u32::MAX,
                pos_mm: [i64::MIN; 3],
                tripped: true,
            },
            DeviceMsg::Alarm {
                code: AlarmCode::ProbeFailContact,
                pos_mm: [i64::MIN; 3],
                next_seq: u32::MAX,
            },
            DeviceMsg::Planned {
                tick: u32::MAX,
                event: PlanEvent::Reset {
                    pos_mm: [i64::MIN; 3],
                },
            },
        ] {
            roundtrip(m);
        }
        roundtrip(DeviceMsg::Status(Status {
            motion: Motion::Homing,
            ..Status::default()
        }));
    }

    /// A frame with a valid CRC around `payload` (tag included).
    fn raw_frame(payload: &[u8]) -> Vec<u8> {
        let mut raw = payload.to_vec();
        raw.extend(CRC32.checksum(payload).to_le_bytes());
        let mut enc = vec![0u8; raw.len() + 2];
        let m = cobs::encode(&raw, &mut enc);
        enc.truncate(m);
        enc.push(0);
        enc
    }

    #[test]
    fn a_frame_must_be_consumed_exactly() {
        let mut r = FrameReader::new();
        // `Hold` (variant 4) and one byte more, CRC valid.
        assert_eq!(
            feed(&mut r, &raw_frame(&[HostMsg::TAG, 4])),
            vec![Ok(HostMsg::Hold)]
        );
        assert_eq!(
            feed(&mut r, &raw_frame(&[HostMsg::TAG, 4, 0])),
            vec![Err(ErrorCode::Malformed)]
        );
    }

    #[test]
    fn a_message_going_the_other_way_or_of_another_version_is_refused() {
        let mut out = [0u8; FRAME_MAX];
        let n = encode(
            &DeviceMsg::Error {
                code: ErrorCode::Crc,
                expected_seq: 0,
            },
            &mut out,
        )
        .unwrap();
        let mut r = FrameReader::new();
        let got: Vec<Result<HostMsg, ErrorCode>> =
            out[..n].iter().filter_map(|b| r.push(*b)).collect();
        assert_eq!(got, vec![Err(ErrorCode::Misdirected)]);
        // A host message from version 1 (no tag byte: its first byte is
        // the variant).
        assert_eq!(
            feed(&mut r, &raw_frame(&[4, 4])),
            vec![Err(ErrorCode::Misdirected)]
        );
        assert_eq!(
            feed(
                &mut r,
                &raw_frame(&[TAG_BASE | ((PROTOCOL_VERSION + 1) << 1), 4])
            ),
            vec![Err(ErrorCode::Misdirected)]
        );
    }

    fn frame(m: &HostMsg) -> Vec<u8> {
        let mut out = [0u8; FRAME_MAX];
        let n = encode(m, &mut out).unwrap();
        out[..n].to_vec()
    }

    fn feed(r: &mut FrameReader, bytes: &[u8]) -> Vec<Result<HostMsg, ErrorCode>> {
        bytes.iter().filter_map(|b| r.push(*b)).collect()
    }

    #[test]
    fn bad_frames_are_refused_and_the_next_one_decodes() {
        let good = frame(&HostMsg::Hold);
        let mut r = FrameReader::new();
        // Bit flip: CRC.
        let mut bad = frame(&HostMsg::Override { percent: 50 });
        bad[2] ^= 0x10;
        assert_eq!(feed(&mut r, &bad), vec![Err(ErrorCode::Crc)]);
        // Truncated: the frame lost its tail.
        let mut t = frame(&HostMsg::Point {
            seq: 1,
            pos_mm: [1, 2, 3],
            feed_cap_mm_per_min: None,
        });
        let n = t.len();
        t.drain(n - 4..n - 1);
        assert!(matches!(
            feed(&mut r, &t)[..],
            [Err(ErrorCode::Crc | ErrorCode::Framing)]
        ));
        // Too short.
        assert_eq!(feed(&mut r, &[2, 1, 0]), vec![Err(ErrorCode::TooShort)]);
        // Unknown message: valid CRC, variant 200.
        let host = HostMsg::TAG;
        assert_eq!(
            feed(&mut r, &raw_frame(&[host, 200, 1])),
            vec![Err(ErrorCode::UnknownMessage)]
        );
        // Malformed: a Point with its fields missing.
        assert_eq!(
            feed(&mut r, &raw_frame(&[host, 2])),
            vec![Err(ErrorCode::Malformed)]
        );
        // Garbage longer than a frame.
        assert_eq!(
            feed(&mut r, &[0x55; FRAME_MAX * 3]),
            Vec::<Result<HostMsg, _>>::new()
        );
        assert_eq!(feed(&mut r, &[0]), vec![Err(ErrorCode::TooLong)]);
        // And the reader is in sync again.
        assert_eq!(feed(&mut r, &good), vec![Ok(HostMsg::Hold)]);
    }

    /// 100 kB of line noise without a delimiter: one refusal at the first
    /// delimiter, and the frame after it decodes; a frame sent straight
    /// after the run (no delimiter before it) is lost in the run, and its
    /// resend after a delimiter decodes.
    #[test]
    fn a_long_run_without_a_delimiter_is_one_refusal_then_in_sync() {
        let mut r = FrameReader::new();
        let run = vec![0x55u8; 100_000];
        assert_eq!(feed(&mut r, &run), vec![]);
        let mut tail = vec![DELIMITER];
        tail.extend(frame(&HostMsg::StatusQuery));
        assert_eq!(
            feed(&mut r, &tail),
            vec![Err(ErrorCode::TooLong), Ok(HostMsg::StatusQuery)]
        );
        assert_eq!(feed(&mut r, &run), vec![]);
        let swallowed = feed(&mut r, &frame(&HostMsg::StatusQuery));
        assert_eq!(swallowed, vec![Err(ErrorCode::TooLong)]);
        assert!(swallowed[0].unwrap_err().is_line_noise());
        assert_eq!(feed(&mut r, &tail), vec![Ok(HostMsg::StatusQuery)]);
    }

    proptest! {
        /// Arbitrary bytes never panic the reader, and a good frame after a
        /// delimiter always decodes.
        #[test]
        fn garbage_never_panics_and_resyncs(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
            let mut r = FrameReader::new();
            let _ = feed(&mut r, &bytes);
            let mut tail = vec![0u8];
            tail.extend(frame(&HostMsg::Resume));
            let got = feed(&mut r, &tail);
            prop_assert_eq!(got.last(), Some(&Ok(HostMsg::Resume)));
        }

        /// Any single corrupted byte in a frame is caught (never decoded as
        /// a different message).
        #[test]
        fn single_byte_corruption_is_caught(seq in any::<u32>(), x in any::<i64>(), at in 0usize..64, flip in 1u8..=255) {
            let m = HostMsg::Point { seq, pos_mm: [x, -x, 0], feed_cap_mm_per_min: Some(x >> 3) };
            let mut f = frame(&m);
            let i = at % (f.len() - 1);
            f[i] ^= flip;
            let mut r = FrameReader::new();
            for got in feed(&mut r, &f) {
                prop_assert_ne!(got, Ok(m));
                prop_assert!(got.is_err());
            }
        }
    }
}
