//! Lookahead curvature variation (Lin et al. section 2.6.2, eq. 10):
//! `Dκ(i) = max(κ(i), κ(i+1), …, κ(i+WS−1))`, the largest curvature over the
//! next `WS` points, so the controller "uses the maximum curvature in the
//! future as the basis for deceleration" (the larger `WS`, the longer the
//! deceleration zone). The paper uses `WS = 30`.
//!
//! Eq. 10 is garbled in the text (`MAX_{i=n}^{WS}`); the prose says the
//! window looks forward and has size WS. We take the `WS` points starting at
//! the current one, so `Dκ(i) >= κ(i)` always holds.
//!
//! Streaming, O(1) amortised per point: a monotonic deque of (index, κ) whose
//! curvatures decrease from front to back holds the candidates for the
//! maximum (a fixed ring of the crate's own rather than `heapless::Deque`:
//! `ring.rs` says why).
//! A point leaves with its `Dκ` once `WS − 1` more curvatures have arrived;
//! at the end of a path ([`LookaheadWindow::flush`]) the window shrinks to
//! the points that are left.

use crate::ring::Ring;
use crate::units::CurvaturePerMm;

/// A point leaving the window: the payload, its curvature and the curvature
/// variation `Dκ` (eq. 10).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Windowed<T> {
    /// The payload pushed with the curvature.
    pub item: T,
    /// `κ(i)`, 1/mm.
    pub curvature: CurvaturePerMm,
    /// `Dκ(i)`: the largest curvature of points `i .. i+WS−1` that exist, 1/mm.
    pub variation: CurvaturePerMm,
}

/// The sliding maximum of eq. 10 over a stream of curvatures.
#[derive(Clone, Debug)]
pub struct LookaheadWindow<T, const WS: usize> {
    /// Points waiting for their window to fill (at most `WS − 1` between
    /// calls).
    pending: Ring<(T, CurvaturePerMm), WS>,
    /// Candidates for the maximum: indices increasing, curvatures
    /// decreasing.
    candidates: Ring<(u32, CurvaturePerMm), WS>,
    /// Index of the next point to leave.
    next_out: u32,
}

impl<T: Copy + Default, const WS: usize> Default for LookaheadWindow<T, WS> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Copy + Default, const WS: usize> LookaheadWindow<T, WS> {
    const VALID: () = assert!(WS >= 1, "the lookahead window needs WS >= 1");

    /// An empty window.
    pub fn new() -> Self {
        #[allow(clippy::let_unit_value)]
        let () = Self::VALID;
        LookaheadWindow {
            pending: Ring::new(),
            candidates: Ring::new(),
            next_out: 0,
        }
    }

    /// Points held (accepted, not yet released).
    pub fn len(&self) -> usize {
        self.pending.len()
    }

    /// Whether no point is held.
    pub fn is_empty(&self) -> bool {
        self.pending.is_empty()
    }

    /// Add the next point's curvature; returns the point `WS − 1` places
    /// back once its window is complete.
    pub fn push(&mut self, item: T, curvature: CurvaturePerMm) -> Option<Windowed<T>> {
        let index = self.next_out.wrapping_add(self.pending.len() as u32);
        // The candidates' curvatures decrease strictly from the front, so
        // those at most `curvature` are a suffix: found by bisection, so
        // that a new maximum costs log WS probes instead of WS pops.
        if self.candidates.back().is_some_and(|&(_, k)| k <= curvature) {
            let (mut lo, mut hi) = (0, self.candidates.len().saturating_sub(1));
            while lo < hi {
                let mid = lo + (hi - lo) / 2;
                if self
                    .candidates
                    .get(mid)
                    .is_some_and(|&(_, k)| k <= curvature)
                {
                    hi = mid;
                } else {
                    lo = mid + 1;
                }
            }
            self.candidates.truncate(lo);
        }
        // Cannot fail: both deques hold at most WS − 1 entries between calls.
        let _ = self.candidates.push_back((index, curvature));
        let _ = self.pending.push_back((item, curvature));
        if self.pending.is_full() {
            self.release()
        } else {
            None
        }
    }

    /// At the end of a path: release the oldest held point, its window
    /// shrunk to what is left. `None` when empty.
    pub fn flush(&mut self) -> Option<Windowed<T>> {
        self.release()
    }

    /// Drop everything (an aborted path).
    pub fn clear(&mut self) {
        self.pending.clear();
        self.candidates.clear();
        self.next_out = 0;
    }

    #[inline(always)]
    fn release(&mut self) -> Option<Windowed<T>> {
        let (item, curvature) = self.pending.pop_front()?;
        let index = self.next_out;
        let (variation, passed) = match self.candidates.front() {
            Some(&(i, k)) => (k, i == index),
            None => (curvature, false),
        };
        if passed {
            self.candidates.drop_front();
        }
        self.next_out = index.wrapping_add(1);
        Some(Windowed {
            item,
            curvature,
            variation,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn k(v: i64) -> CurvaturePerMm {
        CurvaturePerMm(fixed::types::I32F32::from_bits(v))
    }

    fn run<const WS: usize>(ks: &[i64]) -> Vec<(usize, i64, i64)> {
        let mut w = LookaheadWindow::<usize, WS>::new();
        let mut out = Vec::new();
        for (i, &v) in ks.iter().enumerate() {
            if let Some(o) = w.push(i, k(v)) {
                out.push(o);
            }
        }
        while let Some(o) = w.flush() {
            out.push(o);
        }
        out.iter()
            .map(|o| (o.item, o.curvature.0.to_bits(), o.variation.0.to_bits()))
            .collect()
    }

    #[test]
    fn latency_is_ws_minus_one() {
        let mut w = LookaheadWindow::<u8, 3>::new();
        assert!(w.push(0, k(1)).is_none());
        assert!(w.push(1, k(5)).is_none());
        let o = w.push(2, k(2)).unwrap();
        assert_eq!((o.item, o.variation), (0, k(5)));
        assert_eq!(w.len(), 2);
    }

    #[test]
    fn window_shrinks_at_the_end() {
        assert_eq!(
            run::<3>(&[1, 5, 2, 0, 0]),
            vec![(0, 1, 5), (1, 5, 5), (2, 2, 2), (3, 0, 0), (4, 0, 0)]
        );
        assert_eq!(run::<30>(&[4, 1]), vec![(0, 4, 4), (1, 1, 1)]);
        assert_eq!(run::<1>(&[4, 1, 9]), vec![(0, 4, 4), (1, 1, 1), (2, 9, 9)]);
    }

    fn check<const WS: usize>(ks: &[i64]) -> Result<(), TestCaseError> {
        let got = run::<WS>(ks);
        prop_assert_eq!(got.len(), ks.len());
        for (i, &(item, kv, dk)) in got.iter().enumerate() {
            let end = (i + WS).min(ks.len());
            let want = ks[i..end].iter().copied().max().unwrap();
            prop_assert_eq!(item, i);
            prop_assert_eq!(kv, ks[i]);
            prop_assert_eq!(dk, want);
        }
        Ok(())
    }

    proptest! {
        #[test]
        fn equals_brute_force(ks in proptest::collection::vec(0i64..1000, 0..200)) {
            check::<7>(&ks)?;
            check::<30>(&ks)?;
        }

        /// Falling runs (long candidate lists) broken by new maxima, ties
        /// included: every length of suffix is dropped.
        #[test]
        fn equals_brute_force_on_falling_runs(
            runs in proptest::collection::vec((0i64..1000, 1usize..40, 0i64..30), 0..12),
        ) {
            let ks: Vec<i64> = runs
                .iter()
                .flat_map(|&(top, n, step)| (0..n as i64).map(move |j| (top - j * step).max(0)))
                .collect();
            check::<7>(&ks)?;
            check::<30>(&ks)?;
        }
    }
}
