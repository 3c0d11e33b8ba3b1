//! The alarm state and the other stops the tick carries out, shared by
//! every task without locks ([`Latch`]: atomics, and a critical section for
//! the few fields written on a transition).
//!
//! What the tick does each period is decided by the [`Phase`]:
//!
//! ```text
//!            trip (any cause, any task)
//!   Run ───────────────────────────────► Alarm ── unlock (background) ──► Hold ──► Run
//!    │                                     ▲                               ▲
//!    └── homing switch seen (tick) ─► Halt ┴─── next phase (background) ───┘
//! ```
//!
//! - `Run`: the tick executes the next setpoint;
//! - `Alarm`: entered from any phase by [`Latch::trip`] (the e-stop input
//!   or a limit switch seen by the tick, `HostMsg::EStop` in the receive
//!   interrupt, a soft-limit violation, link loss or a homing failure in
//!   the background, step lag after a tick). From the next tick on no
//!   setpoint is executed: the ring is drained, the driver-enable output is
//!   released. There is no deceleration: an emergency stop, unlike a feed
//!   hold or `HostMsg::Abort`, which stop on the path under control. The
//!   background then drops everything queued, rebuilds the planner at
//!   rest where the tool stopped and reports the alarm; every path
//!   command is refused until `HostMsg::Unlock` (Grbl's `$X`), which is
//!   refused while the e-stop input is active;
//! - `Halt`: a homing cycle's switch was seen: the tick stops at once (as
//!   Grbl's homing axis lock) and drains the ring, drivers on;
//! - `Hold`: the background refills the ring after a halt or an unlock:
//!   the tick neither executes nor drains.
//!
//! Whoever trips first names the alarm ([`Latch::alarm`]); later causes
//! while in alarm change nothing.

use core::cell::Cell;
use core::sync::atomic::{AtomicU32, AtomicU8, Ordering};

use critical_section::Mutex;
use fuzzy_core::units::Point3Mm;
use link::AlarmCode;

/// What the tick does (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum Phase {
    /// Execute setpoints.
    Run = 0,
    /// Stopped at a homing switch: drain the ring.
    Halt = 1,
    /// The background refills the ring: wait.
    Hold = 2,
    /// Alarm: drain the ring, drivers off.
    Alarm = 3,
}

impl Phase {
    fn of(v: u8) -> Phase {
        match v {
            0 => Phase::Run,
            1 => Phase::Halt,
            2 => Phase::Hold,
            _ => Phase::Alarm,
        }
    }
}

/// The e-stop input's bit in the input word.
pub const ESTOP: u8 = 1;

/// A limit switch's bit in the input word: axis 0-2, minimum or maximum
/// end (bits 1..=6: X min, X max, Y min, Y max, Z min, Z max).
pub const fn limit_bit(axis: usize, max: bool) -> u8 {
    1 << (1 + 2 * axis + max as usize)
}

/// How the tick treats its inputs (from the settings).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GuardConfig {
    /// Inputs that are active low (bit layout of the input word).
    pub invert: u8,
    /// Consecutive samples before a limit switch's change counts.
    pub debounce: u8,
    /// A limit switch becoming active raises an alarm.
    pub hard_limits: bool,
    /// `$4`: the driver-enable output is high to enable (else low, as
    /// Grbl's default).
    pub enable_invert: bool,
}

impl GuardConfig {
    fn pack(self) -> u32 {
        self.invert as u32
            | (self.debounce as u32) << 8
            | (self.hard_limits as u32) << 16
            | (self.enable_invert as u32) << 17
    }

    fn unpack(v: u32) -> GuardConfig {
        GuardConfig {
            invert: v as u8,
            debounce: (v >> 8) as u8,
            hard_limits: v & 1 << 16 != 0,
            enable_invert: v & 1 << 17 != 0,
        }
    }
}

/// What a transition leaves for another task.
#[derive(Clone, Copy, Debug, Default)]
struct Shared {
    code: Option<AlarmCode>,
    alarms: u32,
    /// Where the tick stopped (set by the tick on entering `Alarm` or
    /// `Halt`, taken by the background).
    stopped_at: Option<Point3Mm>,
    /// Machine coordinates minus the step output's (set by homing).
    offset: [i64; 3],
    /// Homing: halt when this input is active; hard limits are off.
    watch: Option<u8>,
    homing: bool,
}

/// The state every task shares (module docs).
pub struct Latch {
    phase: AtomicU8,
    /// Debounced active inputs, published by the tick.
    inputs: AtomicU8,
    config: AtomicU32,
    shared: Mutex<Cell<Shared>>,
    /// A probing move: armed by the background, tripped by the tick.
    pub probe: crate::probe::ProbeLatch,
}

impl Default for Latch {
    fn default() -> Self {
        Self::new()
    }
}

impl Latch {
    /// Running, no alarm, the defaults' input handling.
    pub const fn new() -> Self {
        Latch {
            phase: AtomicU8::new(Phase::Run as u8),
            inputs: AtomicU8::new(0),
            config: AtomicU32::new(3 << 8),
            shared: Mutex::new(Cell::new(Shared {
                code: None,
                alarms: 0,
                stopped_at: None,
                offset: [0; 3],
                watch: None,
                homing: false,
            })),
            probe: crate::probe::ProbeLatch::new(),
        }
    }

    fn with<R>(&self, f: impl FnOnce(&mut Shared) -> R) -> R {
        critical_section::with(|cs| {
            let cell = self.shared.borrow(cs);
            let mut s = cell.get();
            let r = f(&mut s);
            cell.set(s);
            r
        })
    }

    /// The phase.
    pub fn phase(&self) -> Phase {
        Phase::of(self.phase.load(Ordering::Acquire))
    }

    /// Enter the alarm state (from any task): the first cause names it.
    pub fn trip(&self, code: AlarmCode) {
        self.with(|s| {
            if self.phase() != Phase::Alarm {
                s.code = Some(code);
                s.alarms = s.alarms.wrapping_add(1);
                self.phase.store(Phase::Alarm as u8, Ordering::Release);
            }
        });
    }

    /// The alarm in force.
    pub fn alarm(&self) -> Option<AlarmCode> {
        if self.phase() == Phase::Alarm {
            self.with(|s| s.code)
        } else {
            None
        }
    }

    /// Alarms since boot.
    pub fn alarms(&self) -> u32 {
        self.with(|s| s.alarms)
    }

    /// Debounced active inputs (bit layout: [`ESTOP`], [`limit_bit`]).
    pub fn inputs(&self) -> u8 {
        self.inputs.load(Ordering::Relaxed)
    }

    pub(crate) fn set_inputs(&self, v: u8) {
        self.inputs.store(v, Ordering::Relaxed);
    }

    /// How the tick treats its inputs.
    pub fn guard_config(&self) -> GuardConfig {
        GuardConfig::unpack(self.config.load(Ordering::Relaxed))
    }

    /// Change how the tick treats its inputs.
    pub fn set_guard_config(&self, c: GuardConfig) {
        self.config.store(c.pack(), Ordering::Relaxed);
    }

    /// `from` → `to` if the phase is `from` (so a trip in between wins).
    pub fn advance(&self, from: Phase, to: Phase) -> bool {
        self.phase
            .compare_exchange(from as u8, to as u8, Ordering::AcqRel, Ordering::Acquire)
            .is_ok()
    }

    /// The tick stopped here (entering `Alarm` or `Halt`).
    pub(crate) fn set_stopped_at(&self, pos: Point3Mm) {
        self.with(|s| s.stopped_at = Some(pos));
    }

    /// Where the tick stopped, once it has (taken once).
    pub fn take_stopped_at(&self) -> Option<Point3Mm> {
        self.with(|s| s.stopped_at.take())
    }

    /// Machine coordinates minus the step output's, I32F32 bits.
    pub fn offset(&self) -> [i64; 3] {
        self.with(|s| s.offset)
    }

    /// Set the coordinate offset (homing, at rest: the tick takes it while
    /// in `Hold`).
    pub fn set_offset(&self, offset: [i64; 3]) {
        self.with(|s| s.offset = offset);
    }

    /// Homing on (hard limits off) with the switch to halt on, or off.
    pub fn set_homing(&self, homing: bool, watch: Option<u8>) {
        self.with(|s| {
            s.homing = homing;
            s.watch = watch;
        });
    }

    /// What the tick reads each period: homing on, the switch to halt on,
    /// the coordinate offset.
    pub(crate) fn tick_view(&self) -> (bool, Option<u8>, [i64; 3]) {
        self.with(|s| (s.homing, s.watch, s.offset))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_cause_names_the_alarm_and_a_trip_wins_over_a_resume() {
        let l = Latch::new();
        assert_eq!((l.phase(), l.alarm()), (Phase::Run, None));
        assert!(l.advance(Phase::Run, Phase::Halt));
        l.trip(AlarmCode::EStopLink);
        l.trip(AlarmCode::EStopInput);
        assert_eq!(l.alarm(), Some(AlarmCode::EStopLink));
        assert_eq!(l.alarms(), 1, "one alarm, however many causes");
        assert!(!l.advance(Phase::Halt, Phase::Hold), "the halt is over");
        assert!(l.advance(Phase::Alarm, Phase::Hold));
        assert_eq!(l.alarm(), None);
        l.trip(AlarmCode::SoftLimit);
        assert!(
            !l.advance(Phase::Hold, Phase::Run),
            "tripped while refilling"
        );
        assert_eq!((l.alarm(), l.alarms()), (Some(AlarmCode::SoftLimit), 2));
    }

    #[test]
    fn the_guard_config_round_trips() {
        let l = Latch::new();
        let c = GuardConfig {
            invert: 0x7F,
            debounce: 200,
            hard_limits: true,
            enable_invert: true,
        };
        l.set_guard_config(c);
        assert_eq!(l.guard_config(), c);
        assert_eq!(limit_bit(2, true), 1 << 6);
    }
}
