//! The committed stop: from speed `v` and acceleration `a`, the shortest
//! jerk-limited stop that ends with speed and acceleration both zero: jerk
//! `−J` down to a deceleration `D' <= D`, hold it, jerk `+J` back to zero
//! (`D' < D` when `v` is too small to reach `D`: a triangular profile).
//!
//! All in per-tick units (raw Q32): ticks, mm/tick, mm/tick², mm/tick³.
//! Products are ordered through time-like quotients (`a/J`, `v/J` in ticks)
//! so that tiny per-tick accelerations and jerks keep their precision.

use super::q::{div, mul, sqrt, ONE, SIXTH};

/// Up to three phases of constant jerk.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Brake {
    /// `(duration in ticks, jerk)`.
    pub phases: [(i64, i64); 3],
    /// Sum of the durations.
    pub total: i64,
    /// Start time of each phase and the end, ticks.
    starts: [i64; 4],
    /// Speed, acceleration and distance at each phase start and the end.
    at: [(i64, i64, i64); 4],
    /// The first phase's `a/j` (ticks; its crossing quadratic's `p`), from
    /// the `|a|/J` the stop was built with.
    p0: i64,
}

impl Brake {
    /// The stop from `(v, a)` with deceleration at most `decel` and jerk `jerk`.
    pub(crate) fn new(v: i64, a: i64, decel: i64, jerk: i64) -> Brake {
        let j = jerk.max(1);
        Self::with_ramp(v, a, div(a.saturating_abs(), j), decel, j)
    }

    /// [`Self::new`] given `ta = |a|/J` (ticks, as `q::div` gives it), for
    /// a caller that has it already; `jerk >= 1`.
    pub(crate) fn with_ramp(v: i64, a: i64, ta: i64, decel: i64, jerk: i64) -> Brake {
        let v = v.max(0);
        let j = jerk.max(1);
        // `D'/J` (the last phase's length) is computed once and reused.
        let (first, hold, last) = if a >= 0 {
            // Bring a to zero (speed grows by a²/2J), then ramp to −D' and back.
            let v0 = v + mul(ta, a) / 2;
            let dp = decel.min(mul(j, sqrt(div(v0, j))));
            let dpj = div(dp, j);
            let hold = if dp > 0 {
                div(v0 - mul(dp, dpj), dp).max(0)
            } else {
                0
            };
            (ta + dpj, hold, dpj)
        } else {
            // Already decelerating: ramp further to −D' (or start ramping up);
            // `ta` brings −a back to zero.
            let lost_up = mul(ta, -a) / 2; // speed shed by ramping −a to 0
            let dp2 = div(v, j) + mul(ta, ta) / 2; // (D'/J)² for the triangular stop
            let dp = decel.min(mul(j, sqrt(dp2)));
            if dp < -a {
                // Decelerating harder than needed: ramp up now.
                let hold = if -a > 0 {
                    div(v - lost_up, -a).max(0)
                } else {
                    0
                };
                (0, hold, ta)
            } else {
                let dpj = div(dp, j);
                let up = mul(dp, dpj) / 2; // shed while ramping −D' → 0
                let down = (mul(dp, dpj) - mul(-a, ta)) / 2; // while ramping −a → −D'
                let hold = if dp > 0 {
                    div(v - down - up, dp).max(0)
                } else {
                    0
                };
                (div(dp + a, j), hold, dpj)
            }
        };
        let phases = [(first, -j), (hold, 0), (last, j)];
        let mut starts = [0i64; 4];
        let mut at = [(v, a, 0i64); 4];
        for p in 0..3 {
            let (h, jp) = phases[p];
            let (v0, a0, x0) = at[p];
            let (v1, a1, dx) = integrate(v0, a0, &[(h, jp)], h);
            at[p + 1] = (v1, a1, x0.saturating_add(dx));
            starts[p + 1] = starts[p].saturating_add(h);
        }
        Brake {
            phases,
            total: starts[3],
            starts,
            at,
            // `a/(−J)`: `q::div` rounds the magnitude alone.
            p0: if a > 0 { -ta } else { ta },
        }
    }

    /// Speed, acceleration and distance after `t` ticks along the stop
    /// (from the phase boundaries computed once).
    pub(crate) fn walk(&self, t: i64) -> (i64, i64, i64) {
        let mut p = 0;
        while p < 3 && t >= self.starts[p + 1] {
            p += 1;
        }
        let (v0, a0, x0) = self.at[p];
        if p == 3 {
            return (v0, a0, x0);
        }
        let dt = t - self.starts[p];
        if dt <= 0 {
            return (v0, a0, x0);
        }
        let (v1, a1, dx) = integrate(v0, a0, &self.phases[p..p + 1], dt);
        (v1, a1, x0.saturating_add(dx))
    }

    /// Distance to rest.
    pub(crate) fn distance(&self) -> i64 {
        self.at[3].2
    }

    /// Start of the final phase (deceleration ramping back to zero), ticks.
    pub(crate) fn final_ramp_start(&self) -> i64 {
        self.total - self.phases[2].0
    }

    /// Time at which the deceleration first reaches `d` (if it does), ticks.
    pub(crate) fn reaches(&self, a: i64, d: i64) -> Option<i64> {
        if a <= -d {
            return Some(0);
        }
        let (dur, j) = self.phases[0];
        let end = a.saturating_add(mul(j, dur));
        if j < 0 && end <= -d {
            return Some(div(a + d, -j));
        }
        None
    }

    /// Whether the stop from `(v, a)` passes distance `d` at speed `w` or
    /// less. The stop's speed rises (while `a > 0`) to its peak and then
    /// falls, so it exceeds `w` on one interval of time at most: the
    /// distance must lie outside the stretch covered in that interval.
    pub(crate) fn passes_at_most(&self, d: i64, w: i64) -> bool {
        let mut t = [0i64; 4];
        let mut n = 0;
        for p in 0..3 {
            let (v0, a0, _) = self.at[p];
            let (h, j) = self.phases[p];
            let ratio = if p == 0 { Some(self.p0) } else { None };
            phase_roots(v0, a0, h, j, w, self.starts[p], ratio, &mut t, &mut n);
        }
        let v = self.at[0].0;
        let (lo, hi) = match (v > w, n) {
            (true, 0) => return false, // above w all the way (cannot happen: the stop ends at 0)
            (true, _) => (0, t[0]),
            (false, 0) | (false, 1) => return true, // touches w at most
            (false, _) => (t[0], t[1]),
        };
        let x_lo = if lo == 0 { 0 } else { self.walk(lo).2 };
        let x_hi = self.walk(hi).2;
        d <= x_lo || d >= x_hi
    }
}

/// The times (ticks, ascending, at most 4) at which the speed along `phases`
/// (piecewise-constant jerk from `(v, a)`) crosses `w`, written to `out`;
/// returns how many. Each phase is a quadratic in time, solved in time-like
/// units (`a/j` ticks, `(v − w)/j` ticks²) to keep the precision of tiny
/// per-tick accelerations and jerks.
pub(crate) fn speed_crossings(
    mut v: i64,
    mut a: i64,
    phases: &[(i64, i64)],
    w: i64,
    out: &mut [i64; 4],
) -> usize {
    let mut n = 0;
    let mut t0 = 0i64;
    for &(h, j) in phases.iter() {
        if h <= 0 {
            continue;
        }
        phase_roots(v, a, h, j, w, t0, None, out, &mut n);
        let h2 = mul(h, h);
        v = v.saturating_add(mul(a, h) + mul(j, h2) / 2);
        a = a.saturating_add(mul(j, h));
        t0 = t0.saturating_add(h);
    }
    n // ascending: phases follow each other, and −p − r <= −p + r
}

/// The times in `(0, h]` (offset by `t0`) at which the speed of one phase
/// (jerk `j` from `(v, a)`) equals `w`, appended to `out[*n..]`; `ratio`:
/// `a/j` if the caller has it.
#[allow(clippy::too_many_arguments)]
fn phase_roots(
    v: i64,
    a: i64,
    h: i64,
    j: i64,
    w: i64,
    t0: i64,
    ratio: Option<i64>,
    out: &mut [i64; 4],
    n: &mut usize,
) {
    if h <= 0 {
        return;
    }
    let mut push = |tau: i64, n: &mut usize| {
        if tau > 0 && tau <= h && *n < 4 {
            out[*n] = t0.saturating_add(tau);
            *n += 1;
        }
    };
    if j == 0 {
        if a != 0 {
            push(div(w - v, a), n);
        }
    } else {
        // τ² + 2pτ + q = 0 with p = a/j, q = 2(v − w)/j.
        let p = ratio.unwrap_or_else(|| div(a, j));
        let q = div(v - w, j).saturating_mul(2);
        let disc = mul(p, p).saturating_sub(q);
        if disc >= 0 {
            let r = sqrt(disc);
            push(-p - r, n);
            if r > 0 {
                push(-p + r, n);
            }
        }
    }
}

/// Speed, acceleration and distance after `t` ticks of piecewise-constant
/// jerk `phases` (`(duration, jerk)`), starting from `(v, a)`; the speed is
/// clamped at zero.
pub(crate) fn integrate(
    mut v: i64,
    mut a: i64,
    phases: &[(i64, i64)],
    mut t: i64,
) -> (i64, i64, i64) {
    let mut x = 0i64;
    for &(dur, j) in phases.iter() {
        if t <= 0 {
            break;
        }
        let h = dur.min(t);
        if h == ONE {
            // A whole tick: every product with `h` or `h²` is exact (the
            // same sums as below, without those products).
            if j == 0 {
                x = x.saturating_add(v + a / 2);
                v = v.saturating_add(a);
            } else {
                x = x.saturating_add(v + a / 2 + mul(j, SIXTH));
                v = v.saturating_add(a + j / 2);
                a = a.saturating_add(j);
            }
            t -= h;
            continue;
        }
        let h2 = mul(h, h);
        if j == 0 {
            // A hold: the jerk's terms are zero (the same sums, fewer products).
            x = x.saturating_add(mul(v, h) + mul(a, h2) / 2);
            v = v.saturating_add(mul(a, h));
        } else {
            let jh2 = mul(j, h2);
            x = x.saturating_add(mul(v, h) + mul(a, h2) / 2 + mul(mul(jh2, h), SIXTH));
            v = v.saturating_add(mul(a, h) + jh2 / 2);
            a = a.saturating_add(mul(j, h));
        }
        t -= h;
    }
    (v.max(0), a, x)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn q(v: f64) -> i64 {
        (v * ONE as f64).round() as i64
    }
    fn f(v: i64) -> f64 {
        v as f64 / ONE as f64
    }

    #[test]
    fn every_stop_ends_at_rest() {
        // Per-tick units for 1 kHz: D = 1000 mm/s² = 1e-3, J = 5e4 mm/s³ = 5e-5.
        let (d, j) = (q(1e-3), q(5e-5));
        // (A state decelerating harder than its speed allows, v < a²/2J,
        // cannot stop smoothly; the executor never enters one.)
        for (v, a) in [
            (0.08, 0.0),
            (0.08, 5e-4),
            (0.003, 0.0),
            (0.003, 8e-4),
            (0.08, -9e-4),
            (0.02, -2e-4),
            (0.0, 0.0),
            (1e-4, -1e-4),
        ] {
            let b = Brake::new(q(v), q(a), d, j);
            let (ve, ae, x) = b.walk(b.total);
            assert!(f(ve) < 1e-6, "({v}, {a}): end speed {}", f(ve));
            assert!(f(ae).abs() < 2e-6, "({v}, {a}): end acceleration {}", f(ae));
            assert!(x >= 0);
            // Never decelerates harder than D.
            let mut acc_min: f64 = 0.0;
            for k in 0..=200 {
                let (_, ak, _) = b.walk(b.total * k / 200);
                acc_min = acc_min.min(f(ak));
            }
            assert!(acc_min >= -1e-3 - 1e-9, "({v}, {a}): {acc_min}");
        }
    }

    #[test]
    fn matches_the_closed_form_distance() {
        // From rest acceleration, speed v, full decel reached: distance
        // v·(v/D + D/J)/2.
        let (d, j) = (1e-3, 5e-5);
        let v = 0.08;
        let b = Brake::new(q(v), 0, q(d), q(j));
        let x = f(b.walk(b.total).2);
        let want = v * (v / d + d / j) / 2.0;
        assert!((x - want).abs() / want < 1e-6, "{x} vs {want}");
        // The speed at half the distance, from the closed form: the stop
        // passes there at that speed and not at a lower one.
        let mut vh = 0.0;
        for k in 0..=20000 {
            let (vk, _, xk) = b.walk(b.total * k / 20000);
            if f(xk) >= want / 2.0 {
                vh = f(vk);
                break;
            }
        }
        assert!(b.passes_at_most(q(want / 2.0), q(vh * 1.0005)));
        assert!(!b.passes_at_most(q(want / 2.0), q(vh * 0.9995)));
    }
}
