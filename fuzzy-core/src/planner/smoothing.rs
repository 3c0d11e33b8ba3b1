//! The smoothing stage: the commanded position as the mean of the
//! executor's last `n` positions (module docs of [`super`], "Smoothing").
//!
//! Input: the executor's position each tick. Output: the commanded
//! position of the [`Tick`](super::Tick). With `n = 1` the position passes
//! unchanged.
//!
//! Invariants:
//! - the output's second and third differences are the means of the
//!   input's, so every per-axis speed and acceleration bound of the
//!   executor's positions holds for the output;
//! - at rest the output reaches the input exactly once `n − 1` ticks have
//!   not moved it ([`Smoother::settled`]);
//! - before the first position of a path the mean starts full of that
//!   position, so the output never jumps.

use super::config::SMOOTHING_MAX;
use crate::units::Point3Mm;

/// A moving average of the last `n` positions (raw Q32).
#[derive(Clone, Debug)]
pub(super) struct Smoother {
    n: usize,
    ring: [[i64; 3]; SMOOTHING_MAX as usize],
    sum: [i64; 3],
    /// Slot the next position overwrites (`< n`).
    head: usize,
    /// The newest position.
    last: [i64; 3],
    primed: bool,
    /// Consecutive ticks the input did not change.
    still: usize,
}

impl Smoother {
    /// A mean over `n` ticks (`1..=SMOOTHING_MAX`; others are clamped).
    pub(super) fn new(n: u32) -> Self {
        Smoother {
            n: (n as usize).clamp(1, SMOOTHING_MAX as usize),
            ring: [[0; 3]; SMOOTHING_MAX as usize],
            sum: [0; 3],
            head: 0,
            last: [0; 3],
            primed: false,
            still: 0,
        }
    }

    /// Forget the history: the next position starts a full window.
    pub(super) fn reset(&mut self) {
        self.primed = false;
    }

    /// Whether the output equals the input and will stay so while the
    /// input does not move (without history it starts there).
    pub(super) fn settled(&self) -> bool {
        self.n == 1 || !self.primed || self.still + 1 >= self.n
    }

    /// The next input; the commanded position.
    pub(super) fn filter(&mut self, p: Point3Mm) -> Point3Mm {
        if self.n == 1 {
            return p;
        }
        let b = p.to_bits();
        let n = self.n;
        if !self.primed {
            for slot in self.ring.iter_mut().take(n) {
                *slot = b;
            }
            self.sum = b.map(|c| c.saturating_mul(n as i64));
            self.head = 0;
            self.last = b;
            self.primed = true;
            self.still = n - 1;
            return p;
        }
        let Some(slot) = self.ring.get_mut(self.head) else {
            return p; // unreachable: head < n <= SMOOTHING_MAX
        };
        let old = core::mem::replace(slot, b);
        self.head += 1;
        if self.head >= n {
            self.head = 0;
        }
        for ((s, o), v) in self.sum.iter_mut().zip(old).zip(b) {
            *s = s.saturating_sub(o).saturating_add(v);
        }
        self.still = if b == self.last {
            self.still.saturating_add(1)
        } else {
            0
        };
        self.last = b;
        if self.settled() {
            return p;
        }
        let [x, y, z] = self.sum.map(|s| s.checked_div(n as i64).unwrap_or(s));
        Point3Mm::from_bits(x, y, z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(x: i64) -> Point3Mm {
        Point3Mm::from_bits(x, -x, 3)
    }

    #[test]
    fn one_tick_passes_unchanged() {
        let mut s = Smoother::new(1);
        for x in [0, 5, -7, 1 << 40] {
            assert_eq!(s.filter(at(x)), at(x));
            assert!(s.settled());
        }
    }

    #[test]
    fn the_mean_of_the_last_n_and_exact_at_rest() {
        let mut s = Smoother::new(3);
        assert!(s.settled(), "nothing to catch up before the first position");
        assert_eq!(s.filter(at(30)), at(30), "starts full, no jump");
        assert!(s.settled());
        assert_eq!(s.filter(at(60)), at(40));
        assert!(!s.settled());
        assert_eq!(s.filter(at(90)), at(60));
        assert_eq!(s.filter(at(90)), at(80));
        assert!(!s.settled());
        assert_eq!(s.filter(at(90)), at(90));
        assert!(s.settled());
        s.reset();
        assert_eq!(s.filter(at(-9)), at(-9), "a new path starts full");
    }
}
