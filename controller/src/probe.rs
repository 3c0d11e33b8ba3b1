//! The probe input and the probing move (G38.2-.5): the command, what the
//! tick watches, and where it says the probe changed.
//!
//! The cycle, as Grbl's `mc_probe_cycle` (`grbl/motion_control.c`) runs
//! it, carried out by the background (`crate::background`, its
//! `probe_cycle` module) and the tick ([`crate::guard`]):
//! 1. `HostMsg::Probe` is queued like a point; taken, it ends the open path
//!    and waits until the tool is at rest at its end (the ring executed);
//! 2. the probe already in the state the move watches for (active for
//!    G38.2/.3, inactive for G38.4/.5) trips
//!    [`AlarmCode::ProbeFailInitial`](link::AlarmCode) (Grbl's `ALARM:4`);
//! 3. otherwise the tick is armed ([`ProbeLatch::arm`]) and the planner
//!    gets a path of one point, the target, at the probe's feed;
//! 4. the tick, each period, watches the debounced probe input; at the
//!    trip level it latches the position ([`ProbeWatch`]) and disarms;
//! 5. the background, seeing the trip, stops the motion under control on
//!    the path as a feed hold does, then drops the rest of the move (the
//!    planner's abort; Grbl raises `EXEC_MOTION_CANCEL`, a hold whose
//!    block is discarded, `protocol.c`); at rest it reports
//!    `DeviceMsg::Probed { tripped: true }` with the latched position;
//! 6. a move that ends without a trip: G38.2/.4 trip
//!    [`AlarmCode::ProbeFailContact`](link::AlarmCode) (`ALARM:5`), G38.3/.5
//!    report `Probed { tripped: false }` where the tool stopped (Grbl copies
//!    `sys_position` into the probe position then).
//!
//! Safety inputs win: the e-stop and the limit switches trip their alarms
//! during a probe as at any time, and an alarm drops the probe cycle.
//!
//! Where the trip is latched. Grbl's stepper interrupt reads the probe pin
//! at every step (`probe_state_monitor`, `grbl/probe.c`) and copies the
//! step counters: exact to the step, not debounced. Here the input is read
//! once a tick and debounced like the limit switches (`$26` samples in a
//! row), and the steps run behind the setpoints (the step engine runs a
//! tick's plan 1.5 ticks after the tick that queued it,
//! [`crate::steps`]), so the latch is where the steps were at the first
//! sample of the change: the midpoint of the setpoints two and three ticks
//! before that sample (the window running at the sample), kept from that
//! sample until the debounce confirms the change. The error against where
//! the steps were when the input changed is at most one step (the steps
//! follow the setpoints within one) plus one tick's travel (the change
//! falls between two samples): at 1 kHz and 600 mm/min, 10 µm.
//! The tool stops further on: the setpoints already in the ring
//! ([`crate::settings::SETPOINT_RING`] − 1 ticks), then the deceleration.

use core::cell::Cell;
use core::sync::atomic::{AtomicU8, Ordering};

use critical_section::Mutex;
use fixed::types::I32F32;
use fuzzy_core::units::{FeedMmPerMin, Point3Mm};

use crate::command::MIN_FEED_MM_PER_MIN;

/// The probe input's bit in the input word (after the limit switches).
pub const PROBE: u8 = 1 << 7;

/// A probing move as queued (`HostMsg::Probe`, checked).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ProbeCmd {
    /// The end of the move, machine coordinates.
    pub target: Point3Mm,
    /// Its feed.
    pub feed: FeedMmPerMin,
    /// Its sequence number.
    pub seq: u32,
    /// Stop on the input becoming active (G38.2/.3), else inactive.
    pub toward: bool,
    /// No trip by the target is an alarm (G38.2/.4).
    pub error_if_missed: bool,
}

impl ProbeCmd {
    /// Whether the debounced input word `inputs` is at the level the move
    /// watches for.
    pub fn tripped(&self, inputs: u8) -> bool {
        (inputs & PROBE != 0) == self.toward
    }
}

/// A probing move from the link's raw fields, if the target is in range
/// and the feed at least [`MIN_FEED_MM_PER_MIN`] (and in range).
pub fn probe_from_link(
    seq: u32,
    target_mm: [i64; 3],
    feed_bits: i64,
    toward: bool,
    error_if_missed: bool,
) -> Option<ProbeCmd> {
    let target = Point3Mm::from_bits(target_mm[0], target_mm[1], target_mm[2]);
    let feed = FeedMmPerMin(I32F32::from_bits(feed_bits));
    (target.within_limits() && feed.within_limits() && feed >= MIN_FEED_MM_PER_MIN).then_some(
        ProbeCmd {
            target,
            feed,
            seq,
            toward,
            error_if_missed,
        },
    )
}

const OFF: u8 = 0;
const TOWARD: u8 = 1;
const AWAY: u8 = 2;

/// What the tick and the background share about a probing move: armed
/// (and which level trips it), and the trip's position once latched.
pub struct ProbeLatch {
    armed: AtomicU8,
    trip: Mutex<Cell<Option<Point3Mm>>>,
}

impl Default for ProbeLatch {
    fn default() -> Self {
        Self::new()
    }
}

impl ProbeLatch {
    /// Disarmed, no trip.
    pub const fn new() -> Self {
        ProbeLatch {
            armed: AtomicU8::new(OFF),
            trip: Mutex::new(Cell::new(None)),
        }
    }

    /// Watch for the input becoming active (`toward`) or inactive; a trip
    /// left from before is dropped.
    pub fn arm(&self, toward: bool) {
        critical_section::with(|cs| self.trip.borrow(cs).set(None));
        let v = if toward { TOWARD } else { AWAY };
        self.armed.store(v, Ordering::Release);
    }

    /// Stop watching (the trip, if any, stays until taken).
    pub fn disarm(&self) {
        self.armed.store(OFF, Ordering::Release);
    }

    /// The level the tick watches for: `Some(true)` active, `Some(false)`
    /// inactive, `None` disarmed.
    pub fn watching(&self) -> Option<bool> {
        match self.armed.load(Ordering::Acquire) {
            TOWARD => Some(true),
            AWAY => Some(false),
            _ => None,
        }
    }

    /// The tick saw the trip at `pos`: latched, disarmed.
    pub(crate) fn set_trip(&self, pos: Point3Mm) {
        critical_section::with(|cs| self.trip.borrow(cs).set(Some(pos)));
        self.disarm();
    }

    /// The latched trip, once (taken).
    pub fn take_trip(&self) -> Option<Point3Mm> {
        critical_section::with(|cs| self.trip.borrow(cs).take())
    }
}

/// The tick's side: the setpoints the step engine is working through, and
/// where the steps were at the first sample of a change of the input.
#[derive(Clone, Copy, Debug)]
pub struct ProbeWatch {
    /// The last three setpoints executed, newest first.
    recent: [Point3Mm; 3],
    /// Where the steps were at the first sample of a change the debounce
    /// has not confirmed yet.
    pending: Option<Point3Mm>,
}

impl Default for ProbeWatch {
    fn default() -> Self {
        Self::new()
    }
}

/// The midpoint of two positions (exact to 2⁻³² mm).
fn midpoint(a: Point3Mm, b: Point3Mm) -> Point3Mm {
    let (a, b) = (a.to_bits(), b.to_bits());
    let m = |i: usize| ((a[i] as i128 + b[i] as i128) >> 1) as i64;
    Point3Mm::from_bits(m(0), m(1), m(2))
}

impl ProbeWatch {
    /// At the origin.
    pub const fn new() -> Self {
        ProbeWatch {
            recent: [Point3Mm::ORIGIN; 3],
            pending: None,
        }
    }

    /// At rest at `pos` (after a stop the executor was moved).
    pub fn rest_at(&mut self, pos: Point3Mm) {
        self.recent = [pos; 3];
        self.pending = None;
    }

    /// Where the steps are at this tick's sample: the middle of the window
    /// the step engine runs, from the setpoint three ticks back to the one
    /// two ticks back (module docs).
    pub fn steps_now(&self) -> Point3Mm {
        midpoint(self.recent[1], self.recent[2])
    }

    /// At the tick's sample, after the debounce: `level` the probe's
    /// level now (polarity applied, not debounced), `active` its debounced
    /// state; trips `latch` if armed and `active` is at the watched level.
    pub fn sample(&mut self, level: bool, active: bool, latch: &ProbeLatch) {
        let here = self.steps_now();
        let first = if level != active {
            // A change being debounced: where it began.
            *self.pending.get_or_insert(here)
        } else {
            // Confirmed this tick (or no change): where it began, if known.
            self.pending.take().unwrap_or(here)
        };
        if latch.watching() == Some(active) {
            latch.set_trip(first);
        }
    }

    /// After the executor: the setpoint it ended at.
    pub fn executed(&mut self, pos: Point3Mm) {
        self.recent = [pos, self.recent[0], self.recent[1]];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn x(mm: f64) -> Point3Mm {
        Point3Mm::from_f64(mm, 0.0, 0.0).unwrap()
    }

    #[test]
    fn the_trip_is_latched_where_the_change_began_and_only_when_armed() {
        let latch = ProbeLatch::new();
        let mut w = ProbeWatch::new();
        for k in 1..=5 {
            w.executed(x(k as f64));
        }
        // Steps between setpoints 3 and 4 (of 5 executed).
        assert_eq!(w.steps_now(), x(3.5));
        w.sample(true, true, &latch);
        assert_eq!(latch.take_trip(), None, "disarmed");
        latch.arm(true);
        w.sample(false, false, &latch);
        // The change seen at 6, confirmed two ticks later.
        w.executed(x(6.0));
        w.sample(true, false, &latch);
        w.executed(x(7.0));
        w.sample(true, false, &latch);
        w.executed(x(8.0));
        assert_eq!(latch.take_trip(), None, "not confirmed yet");
        w.sample(true, true, &latch);
        assert_eq!(latch.take_trip(), Some(x(4.5)));
        assert_eq!(latch.watching(), None, "disarmed by the trip");
        // Away: the inactive level trips.
        latch.arm(false);
        w.sample(false, false, &latch);
        assert_eq!(latch.take_trip(), Some(w.steps_now()));
    }

    #[test]
    fn a_glitch_does_not_move_the_start_of_the_change() {
        let latch = ProbeLatch::new();
        let mut w = ProbeWatch::new();
        latch.arm(true);
        w.executed(x(1.0));
        w.sample(true, false, &latch);
        w.executed(x(2.0));
        // Back before the debounce: forgotten.
        w.sample(false, false, &latch);
        w.executed(x(3.0));
        w.executed(x(4.0));
        w.sample(true, false, &latch);
        w.sample(true, true, &latch);
        assert_eq!(latch.take_trip(), Some(x(2.5)));
    }

    #[test]
    fn probes_from_the_link_are_checked() {
        assert!(probe_from_link(0, [0; 3], 100 << 32, true, true).is_some());
        assert!(probe_from_link(0, [0; 3], (1 << 32) - 1, true, true).is_none());
        assert!(probe_from_link(0, [200_000 << 32, 0, 0], 100 << 32, true, true).is_none());
        let p = probe_from_link(3, [0; 3], 100 << 32, false, false).unwrap();
        assert!(p.tripped(0) && !p.tripped(PROBE));
    }
}
