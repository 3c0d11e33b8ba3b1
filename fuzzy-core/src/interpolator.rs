//! The motion interpolator: moves the tool along the polyline of scheduled
//! points, one fixed time step ("tick") at a time, at each segment's target
//! feed, with a bounded tangential acceleration.
//!
//! The same code runs in the firmware's timer interrupt and on the host
//! (tests, simulators), so it follows the crate's rules: integer-only, no
//! allocation, no panics, deterministic to the bit.
//!
//! # Units
//! - positions: [`Point3Mm`] (I32F32 mm); distances along the path in
//!   2^-32 mm ([`DISTANCE_BITS_PER_MM`]) as `u64`;
//! - speed: 2^-32 mm per tick (`u64`), converted from feeds in mm/min with the
//!   tick rate ([`InterpolatorConfig::tick_hz`]);
//! - acceleration: [`InterpolatorConfig::accel_mm_per_s2`], mm/s², becomes a
//!   speed change per tick of `accel / tick_hz²` mm per tick.
//!
//! # Motion rules, each tick
//! 1. the target speed is the current segment's feed × the override (or 0
//!    while held); the speed moves towards it by at most one acceleration
//!    step (`a` per tick);
//! 2. the tool must always be able to stop at the end of the *known* path
//!    (the queued segments) with a deceleration of at most `a`: the speed is
//!    capped at the largest `u` with `u(u + a)/2a + a/8 ≤ d` (the distance a
//!    stop from `u` at `a` per tick needs, exactly bounded), `d` the distance
//!    left. So a path that stops arriving (a buffer underrun) ends in a
//!    controlled stop at its last known point, and the tool moves on without
//!    a jump when points arrive again; a feed hold ramps down the same way;
//! 3. the tool advances by the speed, across as many segment ends as that
//!    distance covers; each segment ends exactly on its end point.
//!
//! Deceleration towards a *slower segment ahead* is not planned here: the
//! speed follows each segment's target with the acceleration limit once the
//! tool is on it. The velocity planner (`planner`, a later issue) is the
//! place for that; it hands this interpolator per-segment target feeds.
//!
//! # Interface
//! [`Segment::between`] prepares a segment (length, direction, speed) from
//! two points; it costs a few 128-bit divisions, so the firmware calls it in
//! a low-priority task. [`Interpolator::push`] only stores it, and
//! [`Interpolator::tick`] is the bounded per-tick work.

use heapless::Deque;

use crate::units::{FeedMmPerMin, Point3Mm};

/// Distance unit along the path: 2^32 per mm (the I32F32 position bits).
pub const DISTANCE_BITS_PER_MM: u64 = 1 << 32;

/// Fraction bits of a segment's unit direction vector.
const DIR_FRAC_BITS: u32 = 62;

/// Interpolator settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct InterpolatorConfig {
    /// Ticks per second (the timer rate), Hz. Valid: 100..=100 000.
    pub tick_hz: u32,
    /// Largest tangential acceleration and deceleration, mm/s².
    /// Valid: 1..=100 000.
    pub accel_mm_per_s2: u32,
}

impl InterpolatorConfig {
    /// Smallest accepted tick rate, Hz.
    pub const MIN_TICK_HZ: u32 = 100;
    /// Largest accepted tick rate, Hz.
    pub const MAX_TICK_HZ: u32 = 100_000;
    /// Largest accepted acceleration, mm/s² (10 g).
    pub const MAX_ACCEL_MM_PER_S2: u32 = 100_000;

    /// Settings for a tick rate (Hz) and an acceleration (mm/s²).
    pub const fn new(tick_hz: u32, accel_mm_per_s2: u32) -> Self {
        InterpolatorConfig {
            tick_hz,
            accel_mm_per_s2,
        }
    }

    /// Check the settings.
    pub fn validate(&self) -> Result<(), InterpolatorError> {
        if self.tick_hz < Self::MIN_TICK_HZ || self.tick_hz > Self::MAX_TICK_HZ {
            return Err(InterpolatorError::BadConfig);
        }
        if self.accel_mm_per_s2 == 0 || self.accel_mm_per_s2 > Self::MAX_ACCEL_MM_PER_S2 {
            return Err(InterpolatorError::BadConfig);
        }
        Ok(())
    }

    /// Speed in 2^-32 mm per tick for a feed in mm/min (floor).
    pub fn speed_per_tick(&self, feed: FeedMmPerMin) -> u64 {
        let bits = feed.0.to_bits().max(0) as u64; // 2^-32 mm per minute
        let ticks_per_min = 60 * self.tick_hz.max(1) as u64;
        bits / ticks_per_min
    }

    /// A speed in 2^-32 mm per tick as a feed in mm/min (saturating).
    pub fn feed_of_speed(&self, speed: u64) -> FeedMmPerMin {
        let ticks_per_min = 60 * self.tick_hz.max(1) as u64;
        let bits = speed.saturating_mul(ticks_per_min).min(i64::MAX as u64);
        FeedMmPerMin(fixed::types::I32F32::from_bits(bits as i64))
    }

    /// Speed change per tick at the acceleration limit, 2^-32 mm per tick²
    /// (at least 1).
    pub fn accel_per_tick2(&self) -> u64 {
        let hz = self.tick_hz.max(1) as u64;
        ((self.accel_mm_per_s2 as u64 * DISTANCE_BITS_PER_MM) / (hz * hz)).max(1)
    }
}

/// Why the interpolator refused something.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum InterpolatorError {
    /// Settings out of range.
    BadConfig,
    /// The segment queue is full.
    QueueFull,
    /// A point beyond ±[`COORD_LIMIT_MM`](crate::units::COORD_LIMIT_MM).
    CoordinateOutOfRange,
}

impl core::fmt::Display for InterpolatorError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            InterpolatorError::BadConfig => "tick rate or acceleration out of range",
            InterpolatorError::QueueFull => "segment queue full",
            InterpolatorError::CoordinateOutOfRange => "coordinate out of range",
        })
    }
}

/// A straight move, prepared for the interpolator.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Segment {
    /// Start point (the previous segment's end).
    pub start: Point3Mm,
    /// End point.
    pub end: Point3Mm,
    /// Length, 2^-32 mm.
    pub len: u64,
    /// Unit direction, Q1.62 per axis.
    dir: [i64; 3],
    /// Target feed on this segment (the end point's scheduled feed), mm/min.
    pub feed: FeedMmPerMin,
    /// Target speed at 100 % override, 2^-32 mm per tick.
    pub speed: u64,
    /// Caller's tag (e.g. the end point's link sequence number).
    pub tag: u32,
}

/// `floor(sqrt(n))` for `u64` (bit by bit, 32 rounds).
pub fn isqrt_u64(n: u64) -> u64 {
    let mut rem = n;
    let mut root = 0u64;
    let mut bit = 1u64 << 62;
    while bit > n {
        bit >>= 2;
    }
    while bit != 0 {
        if rem >= root + bit {
            rem -= root + bit;
            root = (root >> 1) + bit;
        } else {
            root >>= 1;
        }
        bit >>= 2;
    }
    root
}

/// `sqrt(n)` for `u128`, exact below 2^64, else to 32 significant bits.
fn isqrt_u128(n: u128) -> u64 {
    let bits = 128 - n.leading_zeros();
    if bits <= 64 {
        return isqrt_u64(n as u64);
    }
    let shift = (bits - 63) & !1; // even, leaves at most 64 bits
    isqrt_u64((n >> shift) as u64) << (shift / 2)
}

impl Segment {
    /// The move from `start` to `end` at `feed` (mm/min), for `config`.
    /// Coordinates must be within ±[`COORD_LIMIT_MM`](crate::units::COORD_LIMIT_MM). A zero-length move
    /// is allowed (it is passed at once).
    pub fn between(
        start: Point3Mm,
        end: Point3Mm,
        feed: FeedMmPerMin,
        tag: u32,
        config: &InterpolatorConfig,
    ) -> Result<Segment, InterpolatorError> {
        if !start.within_limits() || !end.within_limits() {
            return Err(InterpolatorError::CoordinateOutOfRange);
        }
        let (a, b) = (start.to_bits(), end.to_bits());
        // Within ±1e5 mm a difference is below 2^50: no overflow anywhere.
        let delta = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let sq: u128 = delta
            .iter()
            .map(|d| (d.unsigned_abs() as u128) * (d.unsigned_abs() as u128))
            .sum();
        let len = isqrt_u128(sq);
        // Direction = delta / len in Q1.62, through one 64-bit reciprocal
        // of len's top 32 bits (relative error below 2^-31: a position on a
        // 1 m segment is off by under 0.5 nm, and every segment ends
        // exactly on its end point anyway).
        let mut dir = [0i64; 3];
        if len > 0 {
            let k = (64 - len.leading_zeros()).saturating_sub(32);
            let len_hi = (len >> k).max(1); // in [2^31, 2^32) or len itself
            let recip = (1u64 << 63) / len_hi; // 2^(63+k) / len
            for (u, d) in dir.iter_mut().zip(delta) {
                let q = ((d.unsigned_abs() as u128 * recip as u128) >> (1 + k))
                    .min(1u128 << DIR_FRAC_BITS) as i64;
                *u = if d < 0 { -q } else { q };
            }
        }
        Ok(Segment {
            start,
            end,
            len,
            dir,
            feed,
            speed: config.speed_per_tick(feed),
            tag,
        })
    }

    /// The point at distance `s` (2^-32 mm) from the start, `s ≤ len`.
    fn at(&self, s: u64) -> Point3Mm {
        let a = self.start.to_bits();
        let mut p = [0i64; 3];
        for ((o, a), u) in p.iter_mut().zip(a).zip(self.dir) {
            let off = ((u as i128) * (s as i128)) >> DIR_FRAC_BITS;
            *o = a.wrapping_add(off as i64);
        }
        Point3Mm::from_bits(p[0], p[1], p[2])
    }
}

/// What the interpolator is doing.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MotionState {
    /// At rest, nothing queued (or the path is complete).
    #[default]
    Idle,
    /// Moving along queued segments.
    Running,
    /// Feed hold: decelerating (speed > 0) or stopped (speed 0) on the path.
    Held,
    /// The queue ran low while the path is still open: stopping (or stopped)
    /// at the last known point, waiting for more points.
    Starved,
}

/// What one tick did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TickReport {
    /// The new position setpoint.
    pub position: Point3Mm,
    /// The speed used this tick, 2^-32 mm per tick.
    pub speed: u64,
    /// Segments completed this tick.
    pub completed: u32,
    /// Tag of the last segment completed this tick, if any.
    pub last_tag: Option<u32>,
}

/// Counters since start.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MotionCounters {
    /// Segments completed.
    pub completed: u32,
    /// Stops to standstill because the path stopped arriving (underruns).
    pub underruns: u32,
    /// Ticks run.
    pub ticks: u32,
}

/// The interpolator, with room for `N` queued segments (const generic).
#[derive(Clone, Debug)]
pub struct Interpolator<const N: usize> {
    config: InterpolatorConfig,
    accel: u64,
    queue: Deque<Segment, N>,
    /// Distance covered on the front segment, 2^-32 mm.
    along: u64,
    /// Sum of the lengths of the queued segments, 2^-32 mm.
    queued_len: u64,
    position: Point3Mm,
    speed: u64,
    override_percent: u16,
    hold: bool,
    /// The path is open: more segments may come (an empty queue is an
    /// underrun, not the end).
    path_open: bool,
    state: MotionState,
    counters: MotionCounters,
    last_tag: Option<u32>,
}

impl<const N: usize> Interpolator<N> {
    /// Smallest feed override, percent.
    pub const MIN_OVERRIDE_PERCENT: u16 = 10;
    /// Largest feed override, percent.
    pub const MAX_OVERRIDE_PERCENT: u16 = 200;

    /// An interpolator at `position`, at rest.
    pub fn new(config: InterpolatorConfig, position: Point3Mm) -> Result<Self, InterpolatorError> {
        config.validate()?;
        Ok(Interpolator {
            config,
            accel: config.accel_per_tick2(),
            queue: Deque::new(),
            along: 0,
            queued_len: 0,
            position,
            speed: 0,
            override_percent: 100,
            hold: false,
            path_open: false,
            state: MotionState::Idle,
            counters: MotionCounters::default(),
            last_tag: None,
        })
    }

    /// The settings.
    pub fn config(&self) -> &InterpolatorConfig {
        &self.config
    }

    /// Queue a segment (it must start where the previous one ends). Opens
    /// the path if it was closed.
    pub fn push(&mut self, segment: Segment) -> Result<(), InterpolatorError> {
        self.queue
            .push_back(segment)
            .map_err(|_| InterpolatorError::QueueFull)?;
        self.queued_len = self.queued_len.saturating_add(segment.len);
        self.path_open = true;
        Ok(())
    }

    /// The path ends with the last queued segment: running out of segments
    /// is then the end, not an underrun.
    pub fn end_path(&mut self) {
        self.path_open = false;
    }

    /// Room for more segments.
    pub fn free(&self) -> usize {
        N - self.queue.len()
    }

    /// Segments queued (including the one being traversed).
    pub fn queued(&self) -> usize {
        self.queue.len()
    }

    /// Feed hold: ramp down to a stop on the path.
    pub fn hold(&mut self) {
        self.hold = true;
    }

    /// Release a feed hold: ramp back up along the path.
    pub fn resume(&mut self) {
        self.hold = false;
    }

    /// Whether a feed hold is active.
    pub fn is_held(&self) -> bool {
        self.hold
    }

    /// Set the feed override, percent of the scheduled feed
    /// ([`Self::MIN_OVERRIDE_PERCENT`]..=[`Self::MAX_OVERRIDE_PERCENT`]);
    /// `false` (and no change) outside that range.
    pub fn set_override(&mut self, percent: u16) -> bool {
        if !(Self::MIN_OVERRIDE_PERCENT..=Self::MAX_OVERRIDE_PERCENT).contains(&percent) {
            return false;
        }
        self.override_percent = percent;
        true
    }

    /// The feed override, percent.
    pub fn override_percent(&self) -> u16 {
        self.override_percent
    }

    /// The current position setpoint.
    pub fn position(&self) -> Point3Mm {
        self.position
    }

    /// The current speed, 2^-32 mm per tick.
    pub fn speed(&self) -> u64 {
        self.speed
    }

    /// The current feed, mm/min.
    pub fn feed(&self) -> FeedMmPerMin {
        self.config.feed_of_speed(self.speed)
    }

    /// What the interpolator is doing.
    pub fn state(&self) -> MotionState {
        self.state
    }

    /// Counters since start.
    pub fn counters(&self) -> MotionCounters {
        self.counters
    }

    /// Tag of the last completed segment.
    pub fn last_tag(&self) -> Option<u32> {
        self.last_tag
    }

    /// Distance left to the end of the known path, 2^-32 mm.
    pub fn remaining(&self) -> u64 {
        self.queued_len.saturating_sub(self.along)
    }

    /// Drop every queued segment and stop where the tool is (an emergency
    /// stop: no ramp). The position stays.
    pub fn abort(&mut self) {
        self.queue.clear();
        self.along = 0;
        self.queued_len = 0;
        self.speed = 0;
        self.path_open = false;
        self.state = MotionState::Idle;
    }

    /// Whether a stop from speed `u` fits in distance `d` at `a` per tick:
    /// `u(u + a)/2a + a/8 ≤ d`, i.e. `4u(u + a) + a² ≤ 8ad`.
    fn can_stop(u: u64, a: u64, d: u64) -> bool {
        let (u, a, d) = (u as u128, a as u128, d as u128);
        4 * u * (u + a) + a * a <= 8 * a * d
    }

    /// The speed for this tick: towards `target` by at most `a`, capped so
    /// that a stop within the remaining distance `d` stays possible.
    fn next_speed(&self, target: u64, d: u64) -> u64 {
        let a = self.accel;
        let lo = self.speed.saturating_sub(a);
        let want = target.clamp(lo, self.speed.saturating_add(a));
        if Self::can_stop(want, a, d) {
            return want;
        }
        // The stopping cap binds: the largest u in [lo, want) that can stop
        // (lo can, by induction; a binary search of ≤ 64 rounds).
        let (mut ok, mut bad) = (lo, want);
        if !Self::can_stop(ok, a, d) {
            // Only in the last sliver of the known path (d < a/8, so the
            // speed is below a): finish it.
            return want.min(d);
        }
        while bad - ok > 1 {
            let mid = ok + (bad - ok) / 2;
            if Self::can_stop(mid, a, d) {
                ok = mid;
            } else {
                bad = mid;
            }
        }
        ok
    }

    /// One time step: advance along the queued path and return the new
    /// position setpoint.
    pub fn tick(&mut self) -> TickReport {
        self.counters.ticks = self.counters.ticks.wrapping_add(1);
        let target = match self.queue.front() {
            Some(seg) if !self.hold => (seg.speed as u128 * self.override_percent as u128 / 100)
                .min(u64::MAX as u128) as u64,
            _ => 0,
        };
        let d = self.remaining();
        let was_moving = self.speed > 0;
        let want = target.clamp(
            self.speed.saturating_sub(self.accel),
            self.speed.saturating_add(self.accel),
        );
        let speed = self.next_speed(target, d).min(d);
        // The stopping cap binds: the known path is running out.
        let capped = speed < want;
        self.speed = speed;

        // Advance `speed` along the queue, across segment ends.
        let mut left = speed;
        let mut completed = 0u32;
        let mut last_tag = None;
        while let Some(seg) = self.queue.front().copied() {
            let rest = seg.len - self.along.min(seg.len);
            if left < rest {
                self.along += left;
                self.position = seg.at(self.along);
                break;
            }
            // Reaches (or passes) this segment's end: land on it exactly.
            left -= rest;
            self.position = seg.end;
            self.queue.pop_front();
            self.queued_len = self.queued_len.saturating_sub(seg.len);
            self.along = 0;
            completed += 1;
            last_tag = Some(seg.tag);
        }
        if completed > 0 {
            self.counters.completed = self.counters.completed.wrapping_add(completed);
            self.last_tag = last_tag;
        }

        if speed == 0 && was_moving && self.path_open && !self.hold {
            self.counters.underruns = self.counters.underruns.wrapping_add(1);
        }
        self.state = if self.hold {
            if self.queue.is_empty() && speed == 0 && !self.path_open {
                MotionState::Idle
            } else {
                MotionState::Held
            }
        } else if self.queue.is_empty() && speed == 0 {
            if self.path_open {
                MotionState::Starved
            } else {
                MotionState::Idle
            }
        } else if self.path_open && capped {
            MotionState::Starved
        } else {
            MotionState::Running
        };
        TickReport {
            position: self.position,
            speed,
            completed,
            last_tag,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const CFG: InterpolatorConfig = InterpolatorConfig::new(1000, 1000);

    fn p(x: f64, y: f64) -> Point3Mm {
        Point3Mm::from_f64(x, y, 0.0).unwrap()
    }

    fn seg(a: Point3Mm, b: Point3Mm, feed: i32) -> Segment {
        Segment::between(a, b, FeedMmPerMin::from_int(feed), 0, &CFG).unwrap()
    }

    /// Run until idle (or `max` ticks), checking the acceleration limit and
    /// that the tool never passes the known end; returns the ticks.
    fn run_checked<const N: usize>(ip: &mut Interpolator<N>, max: u32) -> u32 {
        let a = ip.config().accel_per_tick2();
        let mut prev = ip.speed();
        for t in 0..max {
            let r = ip.tick();
            assert!(
                r.speed.abs_diff(prev) <= a,
                "tick {t}: speed {} after {prev}, a = {a}",
                r.speed
            );
            prev = r.speed;
            if ip.state() == MotionState::Idle || ip.state() == MotionState::Starved && r.speed == 0
            {
                return t;
            }
        }
        max
    }

    #[test]
    fn isqrt_is_exact() {
        for n in [
            0u64,
            1,
            2,
            3,
            4,
            15,
            16,
            17,
            1 << 40,
            u64::MAX,
            (1 << 62) + 5,
        ] {
            let r = isqrt_u64(n) as u128;
            assert!(r * r <= n as u128 && (r + 1) * (r + 1) > n as u128, "{n}");
        }
        let n: u128 = (3u128 << 100) + 12345;
        let r = isqrt_u128(n) as f64;
        assert!(((r * r) / n as f64 - 1.0).abs() < 1e-9);
    }

    #[test]
    fn units() {
        // 3000 mm/min at 1 kHz = 0.05 mm per tick.
        let v = CFG.speed_per_tick(FeedMmPerMin::from_int(3000));
        assert_eq!(v, (0.05 * (1u64 << 32) as f64) as u64);
        assert!((CFG.feed_of_speed(v).to_f64() - 3000.0).abs() < 1e-3);
        // 1000 mm/s² at 1 kHz: 0.001 mm per tick per tick.
        assert_eq!(CFG.accel_per_tick2(), (1u64 << 32) / 1000);
        assert!(InterpolatorConfig::new(10, 100).validate().is_err());
        assert!(InterpolatorConfig::new(1000, 0).validate().is_err());
    }

    #[test]
    fn straight_move_reaches_its_end_at_its_feed() {
        let mut ip: Interpolator<8> = Interpolator::new(CFG, Point3Mm::ORIGIN).unwrap();
        ip.push(seg(Point3Mm::ORIGIN, p(100.0, 0.0), 3000)).unwrap();
        ip.end_path();
        let mut top = 0;
        let ticks = run_checked(&mut ip, 10_000);
        assert_eq!(ip.position(), p(100.0, 0.0));
        assert_eq!(ip.state(), MotionState::Idle);
        // 100 mm at 50 mm/s with 50 ms ramps: ~2.05 s.
        assert!((2040..2070).contains(&ticks), "{ticks}");
        // Replay to see the cruise feed.
        let mut ip: Interpolator<8> = Interpolator::new(CFG, Point3Mm::ORIGIN).unwrap();
        ip.push(seg(Point3Mm::ORIGIN, p(100.0, 0.0), 3000)).unwrap();
        for _ in 0..1000 {
            top = top.max(ip.tick().speed);
        }
        assert_eq!(top, CFG.speed_per_tick(FeedMmPerMin::from_int(3000)));
        assert_eq!(ip.counters().underruns, 0);
    }

    #[test]
    fn underrun_stops_at_the_last_point_and_resumes_without_a_jump() {
        let mut ip: Interpolator<8> = Interpolator::new(CFG, Point3Mm::ORIGIN).unwrap();
        ip.push(seg(Point3Mm::ORIGIN, p(10.0, 0.0), 3000)).unwrap();
        run_checked(&mut ip, 10_000);
        assert_eq!(ip.position(), p(10.0, 0.0));
        assert_eq!(ip.speed(), 0);
        assert_eq!(ip.state(), MotionState::Starved);
        assert_eq!(ip.counters().underruns, 1);
        // More path arrives: it accelerates from rest at the same point.
        ip.push(seg(p(10.0, 0.0), p(10.0, 10.0), 3000)).unwrap();
        let r = ip.tick();
        assert!(r.speed <= CFG.accel_per_tick2());
        assert!(r.position.y.to_bits() > 0 && r.position.x == p(10.0, 0.0).x);
        ip.end_path();
        run_checked(&mut ip, 10_000);
        assert_eq!(ip.position(), p(10.0, 10.0));
        assert_eq!(ip.state(), MotionState::Idle);
    }

    #[test]
    fn hold_ramps_down_and_resume_continues() {
        let mut ip: Interpolator<8> = Interpolator::new(CFG, Point3Mm::ORIGIN).unwrap();
        ip.push(seg(Point3Mm::ORIGIN, p(100.0, 0.0), 3000)).unwrap();
        ip.end_path();
        for _ in 0..500 {
            ip.tick();
        }
        ip.hold();
        let a = CFG.accel_per_tick2();
        let mut prev = ip.speed();
        for _ in 0..100 {
            let r = ip.tick();
            assert!(prev - r.speed <= a);
            prev = r.speed;
        }
        assert_eq!(ip.speed(), 0);
        assert_eq!(ip.state(), MotionState::Held);
        let at = ip.position();
        for _ in 0..10 {
            assert_eq!(ip.tick().position, at);
        }
        assert_eq!(ip.counters().underruns, 0);
        ip.resume();
        run_checked(&mut ip, 10_000);
        assert_eq!(ip.position(), p(100.0, 0.0));
    }

    #[test]
    fn override_scales_the_feed() {
        let mut ip: Interpolator<8> = Interpolator::new(CFG, Point3Mm::ORIGIN).unwrap();
        ip.push(seg(Point3Mm::ORIGIN, p(1000.0, 0.0), 3000))
            .unwrap();
        assert!(!ip.set_override(5));
        assert!(!ip.set_override(201));
        assert!(ip.set_override(50));
        for _ in 0..500 {
            ip.tick();
        }
        assert!((ip.feed().to_f64() - 1500.0).abs() < 0.01);
        assert!(ip.set_override(200));
        for _ in 0..500 {
            ip.tick();
        }
        assert!((ip.feed().to_f64() - 6000.0).abs() < 0.01);
    }

    #[test]
    fn positions_lie_on_the_segment() {
        let (a, b) = (p(1.0, 2.0), p(-30.0, 17.5));
        let s = seg(a, b, 1000);
        for k in 0..=100u64 {
            let q = s.at(s.len / 100 * k).to_f64();
            let t = (s.len / 100 * k) as f64 / s.len as f64;
            assert!((q[0] - (1.0 - 31.0 * t)).abs() < 1e-6);
            assert!((q[1] - (2.0 + 15.5 * t)).abs() < 1e-6);
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// Random polylines with random hold / resume / override events and
        /// late arrivals: the speed never changes by more than the
        /// acceleration step, the tool never passes the last known point,
        /// and every segment end is reached exactly.
        #[test]
        fn acceleration_bound_and_no_overshoot(
            pts in proptest::collection::vec((-50.0f64..50.0, -50.0f64..50.0, 0.0f64..2.0), 1..30),
            feeds in proptest::collection::vec(60i32..6000, 30),
            events in proptest::collection::vec((0u32..4000, 0u8..5, 10u16..=200), 0..8),
            accel in 50u32..20_000,
            hz in prop_oneof![Just(1000u32), Just(250u32), Just(10_000u32)],
        ) {
            let cfg = InterpolatorConfig::new(hz, accel);
            let a = cfg.accel_per_tick2();
            let mut ip: Interpolator<4> = Interpolator::new(cfg, Point3Mm::ORIGIN).unwrap();
            let mut last = Point3Mm::ORIGIN;
            let mut next = 0usize;
            let mut prev_speed = 0u64;
            let mut ends = 0u32;
            for t in 0..40_000u32 {
                // Points arrive one per 37 ticks (with gaps: underruns).
                if t % 37 == 0 && next < pts.len() && ip.free() > 0 {
                    let (x, y, z) = pts[next];
                    let q = Point3Mm::from_f64(x, y, z).unwrap();
                    let s = Segment::between(last, q, FeedMmPerMin::from_int(feeds[next]), next as u32, &cfg).unwrap();
                    ip.push(s).unwrap();
                    last = q;
                    next += 1;
                    if next == pts.len() { ip.end_path(); }
                }
                for &(at, kind, pct) in &events {
                    if at == t {
                        match kind { 0 => ip.hold(), 1 => ip.resume(), _ => { ip.set_override(pct); } }
                    }
                }
                let before = ip.remaining();
                let r = ip.tick();
                prop_assert!(r.speed.abs_diff(prev_speed) <= a, "t {}: {} -> {} (a {})", t, prev_speed, r.speed, a);
                prop_assert!(r.speed <= before);
                prev_speed = r.speed;
                ends += r.completed;
                if next == pts.len() && ip.state() == MotionState::Idle { break; }
            }
            if ip.state() == MotionState::Idle && !ip.is_held() {
                prop_assert_eq!(ip.position(), last);
                prop_assert_eq!(ends as usize, pts.len());
            }
        }
    }
}
