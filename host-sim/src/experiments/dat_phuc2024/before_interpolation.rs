//! Acceleration/deceleration before interpolation, as FANUC's high-accuracy
//! contour control ("AI contour control") does it (Dat & Phuc 2024,
//! section 2.1 (ii), parameters 1660, 1772, 1783). The paper's equations
//! 3-9 for this mode are lost from the seed; we model the documented
//! behaviour of the three parameters:
//!
//! - **1783, allowable feed difference at corners**: at the vertex between
//!   blocks with unit directions `u` and `w` the feed is lowered until no
//!   axis's velocity jumps by more than `ΔF`: `F ≤ ΔF / max_i |w_i − u_i|`
//!   (the paper's case (ii): a feed difference above the allowance is
//!   decelerated). On a finely sampled curve this is what slows the tool on
//!   tight curvature: `|w − u| ≈ κ·chord`.
//! - **1660, maximum acceleration of each axis**: along block `j` the
//!   tangential acceleration is at most `min_i A_i / |u_i|`, so that no axis
//!   exceeds its own limit; forward and backward passes over the whole path
//!   (offline lookahead: the path is known) give the fastest profile under
//!   the block feeds, the corner limits and those accelerations, starting
//!   and ending at rest.
//! - **1772, acceleration change time of the bell-shaped acc/dec**: the
//!   planned speed is averaged over `T_bell` in time, which turns each
//!   constant-acceleration stretch into one whose acceleration ramps up and
//!   down over `T_bell` (jerk ≤ `2A/T_bell`). So that the averaged speed
//!   still respects every limit, each limit is first lowered to the smallest
//!   limit within `F_top·T_bell` of path on either side (the distance the
//!   window can reach).
//!
//! Then the interpolator samples the profile and the acc/dec after
//! interpolation (parameter 1769, [`crate::machine::accdec`]) acts per axis.

use crate::interpolation::{Polyline, SpeedProfile};
use crate::toolpath::distance;

/// Limits of the planner.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// Maximum acceleration of each axis (parameter 1660), mm/s².
    pub max_acceleration_mm_per_s2: [f64; 3],
    /// Allowable velocity jump of an axis at a corner (parameter 1783),
    /// mm/s.
    pub corner_feed_difference_mm_per_s: f64,
    /// Acceleration change time of the bell shape (parameter 1772), s.
    pub bell_time_s: f64,
}

fn unit(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    let d = distance(a, b);
    [(b[0] - a[0]) / d, (b[1] - a[1]) / d, (b[2] - a[2]) / d]
}

/// The speed limit at each vertex from the corner feed difference (1783):
/// `ΔF / max_i |w_i − u_i|`; unlimited at the ends (the ends are at rest
/// anyway).
pub fn corner_limits_mm_per_s(points: &[[f64; 3]], delta_f_mm_per_s: f64) -> Vec<f64> {
    let n = points.len();
    let mut out = vec![f64::INFINITY; n];
    for j in 1..n.saturating_sub(1) {
        let (u, w) = (
            unit(points[j - 1], points[j]),
            unit(points[j], points[j + 1]),
        );
        let jump = (0..3).map(|a| (w[a] - u[a]).abs()).fold(0.0, f64::max);
        if jump > 0.0 {
            out[j] = delta_f_mm_per_s / jump;
        }
    }
    out
}

/// Smallest value of a piecewise function within `h` mm of each point and
/// each block (blocks are open intervals: a block does not see the corner
/// at its own end when `h = 0`): `vertex[j]` applies at `cum[j]`, `block[j]` on
/// `(cum[j-1], cum[j])` (index 0 unused). Returns the eroded (vertex, block)
/// limits. O(n) with monotonic deques.
fn erode(cum: &[f64], vertex: &[f64], block: &[f64], h: f64) -> (Vec<f64>, Vec<f64>) {
    let n = cum.len();
    // Every limit as an interval [start, end] with a value, sorted by start:
    // vertex j: [cum j, cum j]; block j: [cum j-1, cum j].
    // The eroded value at a query interval [a, b] is the min over intervals
    // that meet [a − h, b + h]. Brute force is O(n·window); the window is
    // small compared with n in practice, but we keep it linear by sweeping.
    let mut ev = vertex.to_vec();
    let mut eb = block.to_vec();
    // Sweep forward: influence of limits behind (within h).
    let mut dq: std::collections::VecDeque<(f64, f64)> = Default::default(); // (end position, value)
    for j in 0..n {
        // Block j (ends at cum j) then vertex j.
        for (is_block, end, val) in [
            (true, cum[j], if j > 0 { block[j] } else { f64::INFINITY }),
            (false, cum[j], vertex[j]),
        ] {
            let start = if is_block && j > 0 { cum[j - 1] } else { end };
            while dq.front().is_some_and(|&(e, _)| e <= start - h) {
                dq.pop_front();
            }
            let m = dq.front().map_or(f64::INFINITY, |&(_, v)| v);
            if is_block {
                if j > 0 {
                    eb[j] = eb[j].min(m);
                }
            } else {
                ev[j] = ev[j].min(m);
            }
            while dq.back().is_some_and(|&(_, v)| v >= val) {
                dq.pop_back();
            }
            dq.push_back((end, val));
        }
    }
    // Sweep backward: influence of limits ahead.
    dq.clear();
    for j in (0..n).rev() {
        for (is_block, val) in [
            (false, vertex[j]),
            (true, if j > 0 { block[j] } else { f64::INFINITY }),
        ] {
            let (start, end) = if is_block && j > 0 {
                (cum[j - 1], cum[j])
            } else {
                (cum[j], cum[j])
            };
            while dq.front().is_some_and(|&(s, _)| s >= end + h) {
                dq.pop_front();
            }
            let m = dq.front().map_or(f64::INFINITY, |&(_, v)| v);
            if is_block {
                if j > 0 {
                    eb[j] = eb[j].min(m);
                }
            } else {
                ev[j] = ev[j].min(m);
            }
            while dq.back().is_some_and(|&(_, v)| v >= val) {
                dq.pop_back();
            }
            dq.push_back((start, val));
        }
    }
    (ev, eb)
}

/// Plan the speed along `poly` under per-block feeds (mm/min, index 0
/// unused) and `limits`: returns the profile before the bell-shaped
/// averaging (see [`bell_average`]).
pub fn plan(poly: &Polyline<'_>, feeds_mm_per_min: &[f64], limits: &Limits) -> SpeedProfile {
    let pts = poly.points();
    let cum = poly.cumulative_mm();
    let n = pts.len();
    let block: Vec<f64> = (0..n)
        .map(|j| {
            if j == 0 {
                f64::INFINITY
            } else {
                feeds_mm_per_min[j] / 60.0
            }
        })
        .collect();
    let corner = corner_limits_mm_per_s(pts, limits.corner_feed_difference_mm_per_s);
    let top = block[1..].iter().copied().fold(0.0, f64::max);
    let (mut vlim, blim) = erode(cum, &corner, &block, top * limits.bell_time_s);
    // A vertex is also limited by both blocks it joins.
    for j in 0..n {
        if j > 0 {
            vlim[j] = vlim[j].min(blim[j]);
        }
        if j + 1 < n {
            vlim[j] = vlim[j].min(blim[j + 1]);
        }
    }
    vlim[0] = 0.0;
    vlim[n - 1] = 0.0;
    // Tangential acceleration limit of each block.
    let acc: Vec<f64> = (0..n)
        .map(|j| {
            if j == 0 {
                return f64::INFINITY;
            }
            let u = unit(pts[j - 1], pts[j]);
            (0..3)
                .filter(|&a| u[a].abs() > 1e-12)
                .map(|a| limits.max_acceleration_mm_per_s2[a] / u[a].abs())
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    // Forward and backward passes on v².
    let mut v = vlim.clone();
    for j in 1..n {
        let ds = cum[j] - cum[j - 1];
        v[j] = v[j].min((v[j - 1] * v[j - 1] + 2.0 * acc[j] * ds).sqrt());
    }
    for j in (0..n - 1).rev() {
        let ds = cum[j + 1] - cum[j];
        v[j] = v[j].min((v[j + 1] * v[j + 1] + 2.0 * acc[j + 1] * ds).sqrt());
    }
    // Nodes: within each block accelerate, cruise at the block's limit,
    // decelerate.
    let mut p = SpeedProfile::default();
    p.s_mm.push(cum[0]);
    p.v_mm_per_s.push(v[0]);
    for j in 1..n {
        let (s0, len) = (cum[j - 1], cum[j] - cum[j - 1]);
        let (va, vb, f, a) = (v[j - 1], v[j], blim[j], acc[j]);
        if a.is_finite() && len > 0.0 {
            let x1 = (f * f - va * va) / (2.0 * a);
            let x2 = len - (f * f - vb * vb) / (2.0 * a);
            if x1 <= x2 {
                if x1 > 0.0 {
                    p.s_mm.push(s0 + x1);
                    p.v_mm_per_s.push(f);
                }
                if x2 < len {
                    p.s_mm.push(s0 + x2);
                    p.v_mm_per_s.push(f);
                }
            } else {
                let xs = (vb * vb - va * va + 2.0 * a * len) / (4.0 * a);
                if xs > 0.0 && xs < len {
                    p.s_mm.push(s0 + xs);
                    p.v_mm_per_s.push((va * va + 2.0 * a * xs).sqrt().min(f));
                }
            }
        }
        p.s_mm.push(cum[j]);
        p.v_mm_per_s.push(vb);
    }
    p
}

/// Bell-shaped acc/dec before interpolation: the arc length sampled every
/// `ts_s` from `profile`, its per-period increments averaged over
/// `bell_time_s` (causal moving average; the motion takes `bell_time_s`
/// longer). Returns arc lengths at `t = k·Ts`, ending exactly at the end.
pub fn bell_average(profile: &SpeedProfile, ts_s: f64, bell_time_s: f64) -> Vec<f64> {
    let s = profile.sample_s(ts_s);
    let n = (bell_time_s / ts_s).round().max(1.0) as usize;
    if n <= 1 || s.len() < 2 {
        return s;
    }
    let end = s[s.len() - 1];
    let inc: Vec<f64> = s.windows(2).map(|w| w[1] - w[0]).collect();
    let mut out = Vec::with_capacity(s.len() + n);
    out.push(s[0]);
    let mut window = 0.0;
    let mut acc = s[0];
    for k in 0..inc.len() + n - 1 {
        if k < inc.len() {
            window += inc[k];
        }
        if k >= n {
            window -= inc[k - n];
        }
        acc += window / n as f64;
        out.push(acc.min(end));
    }
    if let Some(l) = out.last_mut() {
        *l = end;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const LIM: Limits = Limits {
        max_acceleration_mm_per_s2: [1000.0, 1000.0, 1000.0],
        corner_feed_difference_mm_per_s: 250.0 / 60.0,
        bell_time_s: 0.0,
    };

    #[test]
    fn a_right_angle_is_taken_at_the_allowed_feed_difference() {
        let pts = [[0.0; 3], [100.0, 0.0, 0.0], [100.0, 100.0, 0.0]];
        let c = corner_limits_mm_per_s(&pts, 250.0 / 60.0);
        // |w − u| = 1 on both axes: the corner feed is ΔF itself.
        assert!((c[1] - 250.0 / 60.0).abs() < 1e-12);
        let poly = Polyline::new(&pts);
        let p = plan(&poly, &[0.0, 3000.0, 3000.0], &LIM);
        let at_corner = p
            .s_mm
            .iter()
            .zip(&p.v_mm_per_s)
            .filter(|(s, _)| (**s - 100.0).abs() < 1e-9)
            .map(|(_, v)| *v)
            .fold(f64::INFINITY, f64::min);
        assert!((at_corner - 250.0 / 60.0).abs() < 1e-9);
        // 50 mm/s needs 1.25 mm at 1000 mm/s²: the block cruises in between.
        assert!(p.v_mm_per_s.iter().all(|v| *v <= 50.0 + 1e-9));
        assert!(p.v_mm_per_s.contains(&50.0));
    }

    #[test]
    fn acceleration_never_exceeds_the_axis_limit() {
        // A diagonal: each axis sees a_t/√2, so a_t may reach 1000·√2.
        let pts = [[0.0; 3], [10.0, 10.0, 0.0]];
        let poly = Polyline::new(&pts);
        let p = plan(&poly, &[0.0, 6000.0], &LIM);
        for (s, v) in p.s_mm.windows(2).zip(p.v_mm_per_s.windows(2)) {
            if s[1] > s[0] {
                let a = (v[1] * v[1] - v[0] * v[0]) / (2.0 * (s[1] - s[0]));
                assert!(a.abs() <= 1000.0 * 2f64.sqrt() + 1e-6, "{a}");
            }
        }
        assert_eq!(p.v_mm_per_s[0], 0.0);
        assert_eq!(*p.v_mm_per_s.last().unwrap(), 0.0);
    }

    #[test]
    fn bell_shape_keeps_the_length_and_bounds_the_jerk() {
        let pts = [[0.0; 3], [50.0, 0.0, 0.0]];
        let poly = Polyline::new(&pts);
        let lim = Limits {
            bell_time_s: 0.032,
            ..LIM
        };
        let p = plan(&poly, &[0.0, 3000.0], &lim);
        let s = bell_average(&p, 0.001, 0.032);
        assert_eq!(*s.last().unwrap(), 50.0);
        let v: Vec<f64> = s.windows(2).map(|w| (w[1] - w[0]) / 0.001).collect();
        let a: Vec<f64> = v.windows(2).map(|w| (w[1] - w[0]) / 0.001).collect();
        let j: Vec<f64> = a.windows(2).map(|w| (w[1] - w[0]) / 0.001).collect();
        let amax = a.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let jmax = j.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        assert!(amax <= 1000.0 * 1.01, "{amax}");
        assert!(jmax <= 2.0 * 1000.0 / 0.032 * 1.05, "{jmax}");
        assert!(v.iter().all(|x| *x <= 50.0 + 1e-6));
    }

    #[test]
    fn erosion_takes_the_smallest_limit_within_reach() {
        let cum = [0.0, 1.0, 2.0, 3.0, 10.0];
        let vertex = [9.0, 9.0, 1.0, 9.0, 9.0];
        let block = [f64::INFINITY, 5.0, 5.0, 5.0, 5.0];
        let (v, b) = erode(&cum, &vertex, &block, 1.5);
        assert_eq!(v, vec![5.0, 1.0, 1.0, 1.0, 5.0]);
        assert_eq!(b[1..], [1.0, 1.0, 1.0, 1.0]);
    }
}
