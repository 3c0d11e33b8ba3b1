//! The average filter of Lin et al. section 2.7.2: a moving average of the
//! fuzzy controller's feeds that removes "unnecessary oscillations in the
//! feedrate curve" on paths with uneven curvature.
//!
//! The paper gives neither the window length nor its alignment. We use a
//! centred window of `N = 2h + 1` feeds (`N` a const generic, odd): a
//! trailing average would delay every slow-down by `h` points, undoing part of
//! the lookahead of eq. 10. Near the ends of a path the window holds only the
//! feeds that exist (`[max(0, i−h), min(n−1, i+h)]`), so there is no dip
//! towards zero at the start or end. O(1) per feed with an exact integer
//! running sum (no drift), `h` points of latency.

use crate::numerics::wide::div_u64_small;
use crate::ring::Ring;

/// A feed leaving the filter, with its payload.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Averaged<T> {
    /// The payload pushed with the feed.
    pub item: T,
    /// The feed that was pushed (raw I32F32 bits, whatever the unit).
    pub raw: i64,
    /// The average over the window (same unit, rounded to nearest).
    pub mean: i64,
}

/// Centred moving average over `N` values (N odd).
#[derive(Clone, Debug)]
pub struct AverageFilter<T, const N: usize> {
    /// Window entries, oldest first.
    ring: Ring<(T, i64), N>,
    /// Sum of the values in `ring`.
    sum: i64,
    /// Values pushed on this path.
    pushed: u32,
    /// Values released on this path.
    released: u32,
}

impl<T: Copy + Default, const N: usize> Default for AverageFilter<T, N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Copy + Default, const N: usize> AverageFilter<T, N> {
    const VALID: () = assert!(N % 2 == 1, "the average filter needs an odd window N");
    /// Half the window, `h`: the latency in values.
    pub const HALF: usize = N / 2;

    /// An empty filter.
    pub fn new() -> Self {
        #[allow(clippy::let_unit_value)]
        let () = Self::VALID;
        AverageFilter {
            ring: Ring::new(),
            sum: 0,
            pushed: 0,
            released: 0,
        }
    }

    /// Values held, not yet released.
    pub fn len(&self) -> usize {
        (self.pushed - self.released) as usize
    }

    /// Whether nothing is held.
    pub fn is_empty(&self) -> bool {
        self.pushed == self.released
    }

    /// Add the next value; returns the value `h` places back, averaged, once
    /// its window is complete. Values must stay below 2^54 in magnitude
    /// (feeds below 2^22 mm/min in I32F32) so that the sum cannot overflow.
    pub fn push(&mut self, item: T, value: i64) -> Option<Averaged<T>> {
        let r = self.push_in_place(item, value)?;
        self.averaged(r)
    }

    /// At the end of a path: release the next held value, averaged over the
    /// values that exist. `None` when all are released (the filter is then
    /// ready for a new path).
    pub fn flush(&mut self) -> Option<Averaged<T>> {
        let r = self.flush_in_place()?;
        self.averaged(r)
    }

    /// [`Self::push`], leaving the released payload in the filter (read it
    /// with [`Self::item`] until the next push or flush): the scheduler's
    /// payload is too large to move cheaply on the target.
    pub(crate) fn push_in_place(&mut self, item: T, value: i64) -> Option<Released> {
        if self.ring.is_full() {
            // The oldest entry already left the window of every later value.
            if let Some((_, v)) = self.ring.pop_front() {
                self.sum -= v;
            }
        }
        let _ = self.ring.push_back((item, value)); // cannot fail: not full
        self.sum = self.sum.saturating_add(value);
        self.pushed += 1;
        if self.pushed as usize > Self::HALF {
            self.release()
        } else {
            None
        }
    }

    /// [`Self::flush`], leaving the released payload in the filter.
    pub(crate) fn flush_in_place(&mut self) -> Option<Released> {
        let out = self.release();
        if out.is_none() {
            self.clear();
        }
        out
    }

    /// The payload of a value just released.
    #[inline(always)]
    pub(crate) fn item(&self, r: &Released) -> Option<&T> {
        self.ring.get(r.slot).map(|(item, _)| item)
    }

    fn averaged(&self, r: Released) -> Option<Averaged<T>> {
        Some(Averaged {
            item: *self.item(&r)?,
            raw: r.raw,
            mean: r.mean,
        })
    }

    /// Drop everything.
    pub fn clear(&mut self) {
        self.ring.clear();
        self.sum = 0;
        self.pushed = 0;
        self.released = 0;
    }

    #[inline(always)]
    fn release(&mut self) -> Option<Released> {
        if self.released >= self.pushed {
            return None;
        }
        let i = self.released as usize;
        // The window of value i starts at max(0, i − h): drop older entries.
        let first = self.pushed as usize - self.ring.len();
        let start = i.saturating_sub(Self::HALF);
        for _ in first..start {
            if let Some((_, v)) = self.ring.pop_front() {
                self.sum -= v;
            }
        }
        let first = self.pushed as usize - self.ring.len();
        let slot = i.wrapping_sub(first);
        let &(_, raw) = self.ring.get(slot)?;
        let n = self.ring.len() as u32; // 1..=N
        let half = (n / 2) as i64;
        // Round half away from zero; n <= N is small: three hardware divisions.
        let mean = if self.sum >= 0 {
            div_u64_small((self.sum + half) as u64, n) as i64
        } else {
            -(div_u64_small((half - self.sum) as u64, n) as i64)
        };
        self.released += 1;
        Some(Released { slot, raw, mean })
    }
}

/// A value released by [`AverageFilter::push_in_place`] or
/// [`AverageFilter::flush_in_place`]: where its payload is, the value and the
/// average.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Released {
    slot: usize,
    /// The value that was pushed.
    pub(crate) raw: i64,
    /// The average over the window (rounded to nearest).
    pub(crate) mean: i64,
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn run<const N: usize>(vals: &[i64]) -> Vec<(usize, i64, i64)> {
        let mut f = AverageFilter::<usize, N>::new();
        let mut out = Vec::new();
        for (i, &v) in vals.iter().enumerate() {
            if let Some(o) = f.push(i, v) {
                out.push((o.item, o.raw, o.mean));
            }
        }
        while let Some(o) = f.flush() {
            out.push((o.item, o.raw, o.mean));
        }
        out
    }

    #[test]
    fn constant_input_has_no_dip_at_the_ends() {
        let out = run::<5>(&[100; 12]);
        assert_eq!(out.len(), 12);
        assert!(out.iter().all(|&(_, _, m)| m == 100));
    }

    #[test]
    fn centred_and_shrinking() {
        // N = 3: means of [0,1], [0,1,2], [1,2,3], [2,3].
        assert_eq!(
            run::<3>(&[0, 30, 60, 90]),
            vec![(0, 0, 15), (1, 30, 30), (2, 60, 60), (3, 90, 75)]
        );
        assert_eq!(run::<1>(&[5, 7]), vec![(0, 5, 5), (1, 7, 7)]);
        assert_eq!(run::<9>(&[8]), vec![(0, 8, 8)]);
        assert!(run::<9>(&[]).is_empty());
    }

    #[test]
    fn reusable_after_flush() {
        let mut f = AverageFilter::<u8, 3>::new();
        assert!(f.push(0, 10).is_none());
        assert_eq!(f.flush().map(|o| o.mean), Some(10));
        assert!(f.flush().is_none());
        assert!(f.push(1, 20).is_none());
        assert_eq!(f.flush().map(|o| o.mean), Some(20));
    }

    proptest! {
        #[test]
        fn equals_brute_force(vals in proptest::collection::vec(0i64..1_000_000, 0..100)) {
            let got = run::<7>(&vals);
            prop_assert_eq!(got.len(), vals.len());
            for (i, &(item, raw, mean)) in got.iter().enumerate() {
                let lo = i.saturating_sub(3);
                let hi = (i + 3).min(vals.len() - 1);
                let s: i64 = vals[lo..=hi].iter().sum();
                let n = (hi - lo + 1) as i64;
                prop_assert_eq!(item, i);
                prop_assert_eq!(raw, vals[i]);
                prop_assert_eq!(mean, (s + n / 2) / n);
            }
        }
    }
}
