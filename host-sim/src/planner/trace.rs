//! A record of a planned tick stream of bounded size, for the plots and
//! the ticks CSV: one bucket per tick while there are at most
//! [`TRACE_BUCKETS`] of them; when the record is full, neighbouring
//! buckets are merged in pairs and each bucket covers twice as many ticks.
//!
//! A bucket keeps its first tick whole (the CSV's row) and the lowest and
//! highest speed and per-axis acceleration within it, in the order they
//! occurred (what [`crate::plots::thin`] keeps of a series), so a plot of a
//! long run still shows every peak. While no merge has happened the record
//! holds every tick and the plots are those of the whole stream.
//!
//! The figures (peaks, deviation) are not taken from here: they are
//! measured from every tick as it comes ([`super::figures::Meter`]).

use super::TickRecord;

/// Most buckets a [`Trace`] keeps: runs of up to this many ticks are
/// recorded tick by tick; the memory of a full record is this many
/// [`Bucket`]s.
pub const TRACE_BUCKETS: usize = 1 << 17;

/// A value at a tick: the tick's arc length (the plots' abscissa) and the
/// value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct At {
    /// Index of the tick in the stream.
    pub tick: u64,
    /// Arc length at the tick, mm.
    pub s_mm: f64,
    /// The value.
    pub value: f64,
}

/// The lowest and highest value within a bucket (the first of equal ones).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Extremes {
    /// Lowest.
    pub lo: At,
    /// Highest.
    pub hi: At,
}

impl Extremes {
    fn of(a: At) -> Self {
        Extremes { lo: a, hi: a }
    }

    /// `self` followed by `later`: strict comparisons keep the earlier of
    /// equal values, as a scan over the ticks would.
    fn merge(&mut self, later: &Extremes) {
        if later.lo.value < self.lo.value {
            self.lo = later.lo;
        }
        if later.hi.value > self.hi.value {
            self.hi = later.hi;
        }
    }

    /// The extremes in the order they occurred (one if they are the same
    /// tick).
    pub fn in_order(&self) -> impl Iterator<Item = (f64, f64)> {
        let (a, b) = if self.lo.tick <= self.hi.tick {
            (self.lo, self.hi)
        } else {
            (self.hi, self.lo)
        };
        std::iter::once((a.s_mm, a.value)).chain((b.tick != a.tick).then_some((b.s_mm, b.value)))
    }
}

/// Consecutive ticks of a [`Trace`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bucket {
    /// Index of its first tick in the stream (0: the first tick, at
    /// `t = Ts`).
    pub tick: u64,
    /// Its first tick.
    pub first: TickRecord,
    /// Speed, mm/s.
    pub speed: Extremes,
    /// Per-axis acceleration from the commanded positions (second
    /// differences, the tick in the middle), mm/s²; `None` where the bucket
    /// holds only the last tick (which has no tick after it).
    pub axis_accel: Option<[Extremes; 3]>,
}

impl Bucket {
    fn merge(&mut self, later: &Bucket) {
        self.speed.merge(&later.speed);
        self.axis_accel = match (self.axis_accel, later.axis_accel) {
            (Some(mut a), Some(b)) => {
                for (x, y) in a.iter_mut().zip(&b) {
                    x.merge(y);
                }
                Some(a)
            }
            (a, b) => a.or(b),
        };
    }
}

/// The bounded record of a tick stream.
#[derive(Clone, Debug, PartialEq)]
pub struct Trace {
    buckets: Vec<Bucket>,
    /// Ticks per bucket (a power of two).
    stride: u64,
    capacity: usize,
    /// Ticks recorded.
    ticks: u64,
    start: [f64; 3],
    /// Whether each axis moved away from the start (by more than 1 nm).
    moved: [bool; 3],
}

impl Trace {
    /// An empty record of a motion from `start`, of at most `capacity`
    /// buckets (rounded up to an even number, at least 2).
    pub fn new(start: [f64; 3], capacity: usize) -> Self {
        Trace {
            buckets: Vec::new(),
            stride: 1,
            capacity: capacity.max(2).next_multiple_of(2),
            ticks: 0,
            start,
            moved: [false; 3],
        }
    }

    /// The next tick, with its per-axis acceleration (`None` for the last
    /// tick).
    pub fn push(&mut self, t: &TickRecord, axis_accel: Option<[f64; 3]>) {
        let k = self.ticks;
        self.ticks += 1;
        for (a, moved) in self.moved.iter_mut().enumerate() {
            *moved |= (t.pos[a] - self.start[a]).abs() > 1e-9;
        }
        let at = |value| At {
            tick: k,
            s_mm: t.s_mm,
            value,
        };
        let b = Bucket {
            tick: k,
            first: *t,
            speed: Extremes::of(at(t.speed_mm_per_s)),
            axis_accel: axis_accel.map(|a| a.map(|v| Extremes::of(at(v)))),
        };
        if k % self.stride != 0 {
            if let Some(last) = self.buckets.last_mut() {
                last.merge(&b);
                return;
            }
        }
        // Full at `k = capacity · stride`: after the merge (capacity even)
        // `k` starts a bucket of the doubled stride.
        if self.buckets.len() == self.capacity {
            self.halve();
        }
        self.buckets.push(b);
    }

    /// Merge the buckets in pairs: each then covers twice the ticks.
    fn halve(&mut self) {
        let n = self.buckets.len();
        for i in 0..n / 2 {
            let mut b = self.buckets[2 * i];
            b.merge(&self.buckets[2 * i + 1]);
            self.buckets[i] = b;
        }
        self.buckets.truncate(n / 2);
        self.stride *= 2;
    }

    /// The buckets, in order.
    pub fn buckets(&self) -> &[Bucket] {
        &self.buckets
    }

    /// Ticks per bucket: 1 while every tick is recorded.
    pub fn stride(&self) -> u64 {
        self.stride
    }

    /// Ticks recorded.
    pub fn ticks(&self) -> u64 {
        self.ticks
    }

    /// Whether axis `a` moved away from the start (by more than 1 nm).
    pub fn moved(&self, a: usize) -> bool {
        self.moved[a]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fuzzy_core::planner::MotionState;

    fn tick(k: u64) -> TickRecord {
        let v = ((k * 7919) % 1000) as f64;
        TickRecord {
            pos: [k as f64, 0.0, 0.0],
            s_mm: k as f64,
            speed_mm_per_s: v,
            accel_mm_per_s2: 0.0,
            point: 0,
            state: MotionState::Moving,
        }
    }

    #[test]
    fn a_full_record_halves_and_keeps_the_extremes_of_every_tick() {
        let n = 10_000u64;
        let mut t = Trace::new([0.0; 3], 64);
        for k in 0..n {
            let a = tick(k).speed_mm_per_s;
            t.push(&tick(k), (k + 1 < n).then_some([a, -a, 0.0]));
        }
        assert!(t.buckets().len() <= 64);
        let stride = t.stride();
        assert!(stride.is_power_of_two() && stride * 64 >= n, "{stride}");
        for (i, b) in t.buckets().iter().enumerate() {
            let from = i as u64 * stride;
            assert_eq!(b.tick, from);
            assert_eq!(b.first, tick(from));
            let ticks = from..(from + stride).min(n);
            let speeds = ticks.clone().map(|k| tick(k).speed_mm_per_s);
            let hi = speeds.clone().fold(f64::MIN, f64::max);
            let lo = speeds.fold(f64::MAX, f64::min);
            assert_eq!((b.speed.lo.value, b.speed.hi.value), (lo, hi));
            // The first tick with the extreme value.
            let first_hi = ticks.clone().find(|&k| tick(k).speed_mm_per_s == hi);
            assert_eq!(Some(b.speed.hi.tick), first_hi);
            let acc = b.axis_accel.unwrap();
            assert_eq!((acc[1].lo.value, acc[1].hi.value), (-hi, -lo));
        }
        assert_eq!(t.ticks(), n);
        assert!(t.moved(0) && !t.moved(1));
    }

    #[test]
    fn a_short_record_holds_every_tick() {
        let mut t = Trace::new([0.0; 3], 64);
        for k in 0..64 {
            t.push(&tick(k), None);
        }
        assert_eq!(t.stride(), 1);
        assert!(t.buckets().iter().zip(0..).all(|(b, k)| b.first == tick(k)));
        t.push(&tick(64), None);
        assert_eq!((t.stride(), t.buckets().len()), (2, 33));
    }
}
