//! The time-optimal traversal of a toolpath under the machine's true limits,
//! in `f64`: the yardstick for [`crate::planner`]'s cycle times.
//!
//! Limits (all at once, no jerk limit, so the result is a lower bound for
//! any jerk-limited motion along the same geometry):
//! - per-axis velocity `|p'_a(s)|·ṡ <= V_a`;
//! - per-axis acceleration `|p'_a(s)·s̈ + p''_a(s)·ṡ²| <= A_a`: the box of
//!   each axis shared between the tangential and the centripetal part as the
//!   geometry allows, with its signs (not a fixed split);
//! - the programmed feed of each move and the largest feed (`ṡ <= F`);
//! - the chord bound of the interpolation period,
//!   `ṡ <= (2/Ts)·√(2δ/κ − δ²)` (a tick's straight move on a curve of
//!   curvature κ deviates at most δ from it);
//! - start and end at rest.
//!
//! Geometry: the polyline's corners are blended by circular arcs tangent to
//! both segments that deviate at most δ_p (the path tolerance) from the
//! vertex, each arc reaching at most half way along either segment (a
//! corner of turning angle θ gets the tangent length
//! `t = min(δ_p/tan(θ/4), L_in/2, L_out/2)` and radius `t/tan(θ/2)`). On
//! densely sampled curves the half-segment bound applies and the arcs follow
//! the sampled curvature. A reversal (θ = π) is a stop. `p'(s)` and `p''(s)`
//! are exact on every line and arc. The chord bound applies to the blended
//! path's curvature on top (so a tick's chord may lie up to δ_p + δ from a
//! programmed vertex, as the planner's may).
//!
//! Method (after Pham's TOPP-RA and the classical Bobrow/Shin-McKay phase
//! plane: the reachable and controllable sets on a grid): an arc-length grid
//! of step `h`; `w = ṡ²` is piecewise linear and `s̈ = (w_{k+1} − w_k)/2h` is
//! constant between grid points, constrained at the left point. The
//! acceleration bounds at `(s_k, w)` are `α(w) = max_a lo_a(w)` (convex)
//! and `β(w) = min_a hi_a(w)` (concave), each `lo_a`, `hi_a` linear in `w`;
//! the maximum velocity curve is the largest `w` with `α(w) <= β(w)` and
//! every speed ceiling. A backward pass gives the largest `w_k` from which
//! the end stays reachable (`w_k + 2h·α(w_k) <= w_{k+1}`, solved exactly on
//! the linear pieces), a forward pass accelerates as hard as `β` allows
//! under it. Time: `Σ 2h/(√w_k + √w_{k+1})` (exact for constant `s̈`).
//!
//! Discretisation error: first order in `h` (the limits are checked at grid
//! points, the geometry's pieces start and end on the grid to within `h`).
//! [`TimeOptimal::discretisation_s`] reports the change from `h` to `h/2`,
//! which bounds the error of the finer result when the error halves with
//! `h` (the tests print both).

/// The machine's limits, in mm, s.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// Interpolation period `Ts`, s (for the chord bound).
    pub tick_s: f64,
    /// Largest feed, mm/s.
    pub feed_max_mm_s: f64,
    /// Per-axis velocity, mm/s.
    pub axis_speed_mm_s: [f64; 3],
    /// Per-axis acceleration, mm/s².
    pub axis_accel_mm_s2: [f64; 3],
    /// Chord tolerance δ of a tick's straight move, mm.
    pub chord_mm: f64,
    /// Corner blend deviation (path tolerance), mm.
    pub path_mm: f64,
}

/// A path point and the feed of the move ending at it, mm/s (the first
/// point's feed is unused; `f64::INFINITY` for none).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Point {
    /// Position, mm.
    pub pos: [f64; 3],
    /// Feed of the move ending here, mm/s.
    pub feed_mm_s: f64,
}

/// A piece of the blended path: a line or an arc, with its feed ceiling.
#[derive(Clone, Copy, Debug)]
enum Piece {
    /// Direction (unit).
    Line { dir: [f64; 3] },
    /// Start direction `d0`, the in-plane unit normal `b` towards the turn,
    /// radius.
    Arc { d0: [f64; 3], b: [f64; 3], r: f64 },
}

#[derive(Clone, Copy, Debug)]
struct Span {
    s0: f64,
    len: f64,
    piece: Piece,
    /// Feed ceiling along the span, mm/s.
    feed: f64,
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

fn scale(a: [f64; 3], k: f64) -> [f64; 3] {
    [a[0] * k, a[1] * k, a[2] * k]
}

/// The blended path: spans in order, and the arc lengths where it must stop
/// (reversals).
fn blend(points: &[Point], delta: f64, feed_max: f64) -> (Vec<Span>, Vec<f64>) {
    // Segments without the zero-length ones.
    let mut segs: Vec<([f64; 3], f64, f64)> = Vec::new(); // dir, length, feed
    let mut last = match points.first() {
        Some(p) => p.pos,
        None => return (Vec::new(), Vec::new()),
    };
    for p in &points[1..] {
        let d = sub(p.pos, last);
        let l = norm(d);
        if l > 0.0 {
            segs.push((scale(d, 1.0 / l), l, p.feed_mm_s.min(feed_max)));
            last = p.pos;
        } else if let Some(s) = segs.last_mut() {
            s.2 = s.2.min(p.feed_mm_s);
        }
    }
    // Tangent length and turning angle at each interior vertex.
    let n = segs.len();
    let mut tan_len = vec![0.0; n + 1];
    let mut angle = vec![0.0; n + 1];
    for k in 1..n {
        let (d_in, l_in, _) = segs[k - 1];
        let (d_out, l_out, _) = segs[k];
        let c = dot(d_in, d_out).clamp(-1.0, 1.0);
        let theta = c.acos();
        angle[k] = theta;
        if theta > 1e-12 && theta < std::f64::consts::PI - 1e-9 {
            let by_dev = delta / (theta / 4.0).tan();
            tan_len[k] = by_dev.min(l_in / 2.0).min(l_out / 2.0);
        }
    }
    let mut spans = Vec::new();
    let mut stops = Vec::new();
    let mut s = 0.0;
    for k in 0..n {
        let (d, l, f) = segs[k];
        // The arc at vertex k (between segments k − 1 and k), second half
        // at this segment's feed, first half at the previous one's.
        if k > 0 && tan_len[k] > 0.0 {
            let (d_in, _, f_in) = segs[k - 1];
            let theta = angle[k];
            let t = tan_len[k];
            let r = t / (theta / 2.0).tan();
            let b = sub(d, scale(d_in, theta.cos()));
            let b = scale(b, 1.0 / norm(b));
            let half = r * theta / 2.0;
            spans.push(Span {
                s0: s,
                len: half,
                piece: Piece::Arc { d0: d_in, b, r },
                feed: f_in,
            });
            // The second half starts at the bisector's direction.
            let mid = add_rot(d_in, b, theta / 2.0);
            let b_mid = add_rot(d_in, b, theta / 2.0 + std::f64::consts::FRAC_PI_2);
            spans.push(Span {
                s0: s + half,
                len: half,
                piece: Piece::Arc {
                    d0: mid,
                    b: b_mid,
                    r,
                },
                feed: f,
            });
            s += 2.0 * half;
        } else if k > 0 && angle[k] >= std::f64::consts::PI - 1e-9 {
            stops.push(s);
        }
        let straight = l - tan_len[k] - tan_len[k + 1];
        if straight > 0.0 {
            spans.push(Span {
                s0: s,
                len: straight,
                piece: Piece::Line { dir: d },
                feed: f,
            });
            s += straight;
        }
    }
    (spans, stops)
}

/// `cos φ·d0 + sin φ·b`.
fn add_rot(d0: [f64; 3], b: [f64; 3], phi: f64) -> [f64; 3] {
    let (s, c) = phi.sin_cos();
    [
        c * d0[0] + s * b[0],
        c * d0[1] + s * b[1],
        c * d0[2] + s * b[2],
    ]
}

impl Piece {
    /// `p'(u)`, `p''(u)` at arc length `u` into the piece.
    fn derivatives(&self, u: f64) -> ([f64; 3], [f64; 3]) {
        match *self {
            Piece::Line { dir } => (dir, [0.0; 3]),
            Piece::Arc { d0, b, r } => {
                let phi = u / r;
                let d = add_rot(d0, b, phi);
                let n = add_rot(d0, b, phi + std::f64::consts::FRAC_PI_2);
                (d, scale(n, 1.0 / r))
            }
        }
    }

    fn curvature(&self) -> f64 {
        match *self {
            Piece::Line { .. } => 0.0,
            Piece::Arc { r, .. } => 1.0 / r,
        }
    }
}

/// Per grid point: the acceleration bounds as lines in `w`
/// (`lo_a(w) = c0 + c1·w`, `hi_a(w) = e0 + e1·w`) for the axes that move.
#[derive(Clone, Copy, Debug, Default)]
struct Bounds {
    lo: [(f64, f64); 3],
    hi: [(f64, f64); 3],
    n: usize,
}

impl Bounds {
    fn new(dp: [f64; 3], ddp: [f64; 3], amax: [f64; 3], mvc: &mut f64) -> Bounds {
        let mut b = Bounds::default();
        for a in 0..3 {
            if dp[a].abs() < 1e-12 {
                // No tangential component: the centripetal part alone.
                if ddp[a] != 0.0 {
                    *mvc = mvc.min(amax[a] / ddp[a].abs());
                }
                continue;
            }
            // −A <= p'·u + p''·w <= A.
            let (l0, h0) = if dp[a] > 0.0 {
                (-amax[a] / dp[a], amax[a] / dp[a])
            } else {
                (amax[a] / dp[a], -amax[a] / dp[a])
            };
            let k = -ddp[a] / dp[a];
            b.lo[b.n] = (l0, k);
            b.hi[b.n] = (h0, k);
            b.n += 1;
        }
        // α(w) <= β(w): every lo_a below every hi_b.
        for i in 0..b.n {
            for j in 0..b.n {
                let (c0, c1) = b.lo[i];
                let (e0, e1) = b.hi[j];
                let slope = c1 - e1;
                if slope > 0.0 {
                    *mvc = mvc.min((e0 - c0) / slope);
                }
            }
        }
        b
    }

    fn alpha(&self, w: f64) -> f64 {
        (0..self.n)
            .map(|i| self.lo[i].0 + self.lo[i].1 * w)
            .fold(f64::NEG_INFINITY, f64::max)
    }

    fn beta(&self, w: f64) -> f64 {
        (0..self.n)
            .map(|i| self.hi[i].0 + self.hi[i].1 * w)
            .fold(f64::INFINITY, f64::min)
    }

    /// The largest `w` with `w + 2h·α(w) <= target` (0 always qualifies:
    /// `α(0) < 0`).
    fn decel_from(&self, h: f64, target: f64) -> f64 {
        let mut w = f64::INFINITY;
        for i in 0..self.n {
            let (c0, c1) = self.lo[i];
            let slope = 1.0 + 2.0 * h * c1;
            if slope > 0.0 {
                w = w.min((target - 2.0 * h * c0) / slope);
            }
        }
        w
    }
}

/// The time-optimal motion's figures.
#[derive(Clone, Debug, PartialEq)]
pub struct TimeOptimal {
    /// Cycle time at step `h`, s.
    pub time_s: f64,
    /// Cycle time at step `h/2`, s.
    pub time_half_step_s: f64,
    /// Length of the blended path, mm.
    pub length_mm: f64,
    /// Grid step `h`, mm.
    pub step_mm: f64,
}

impl TimeOptimal {
    /// The discretisation error estimate: `|t(h) − t(h/2)|`, s.
    pub fn discretisation_s(&self) -> f64 {
        (self.time_s - self.time_half_step_s).abs()
    }
}

/// Cycle time (s) of the time-optimal traversal on a grid of step `h_mm`,
/// and the speed profile `(s, ṡ)` if `profile` is given.
pub fn cycle_time_s(
    points: &[Point],
    lim: &Limits,
    h_mm: f64,
    profile: Option<&mut Vec<(f64, f64)>>,
) -> (f64, f64) {
    let (spans, stops) = blend(points, lim.path_mm, lim.feed_max_mm_s);
    let Some(last) = spans.last() else {
        return (0.0, 0.0);
    };
    let total = last.s0 + last.len;
    let m = ((total / h_mm).ceil() as usize).max(1) + 1;
    let h = total / (m - 1) as f64;
    let mut mvc = vec![f64::INFINITY; m];
    let mut bounds = vec![Bounds::default(); m];
    let ts = lim.tick_s;
    let delta = lim.chord_mm;
    let mut span = 0;
    for k in 0..m {
        let s = k as f64 * h;
        while span + 1 < spans.len() && spans[span + 1].s0 <= s {
            span += 1;
        }
        // Every span touching [s − h, s + h] caps the feed here, so that a
        // change of feed or a short span is never stepped over.
        let mut w = f64::INFINITY;
        let mut j = span;
        while j > 0 && spans[j].s0 > s - h {
            j -= 1;
        }
        while j < spans.len() && spans[j].s0 < s + h {
            let sp = &spans[j];
            if sp.s0 + sp.len > s - h {
                w = w.min(sp.feed * sp.feed);
                let kappa = sp.piece.curvature();
                if kappa > 0.0 {
                    let r = 2.0 * delta / kappa - delta * delta;
                    let v = if r > 0.0 { 2.0 * r.sqrt() / ts } else { 0.0 };
                    w = w.min(v * v);
                }
            }
            j += 1;
        }
        let sp = &spans[span];
        let (dp, ddp) = sp.piece.derivatives((s - sp.s0).clamp(0.0, sp.len));
        for (d, vmax) in dp.iter().zip(lim.axis_speed_mm_s) {
            if d.abs() > 1e-12 {
                let v = vmax / d.abs();
                w = w.min(v * v);
            }
        }
        bounds[k] = Bounds::new(dp, ddp, lim.axis_accel_mm_s2, &mut w);
        mvc[k] = w.max(0.0);
    }
    for &s in &stops {
        let k = ((s / h).round() as usize).min(m - 1);
        mvc[k] = 0.0;
    }
    mvc[0] = 0.0;
    mvc[m - 1] = 0.0;
    // Backward: the controllable set's top.
    let mut back = mvc.clone();
    for k in (0..m - 1).rev() {
        back[k] = back[k].min(bounds[k].decel_from(h, back[k + 1])).max(0.0);
    }
    // Forward: as fast as β allows, under it.
    let mut w = vec![0.0; m];
    for k in 0..m - 1 {
        let up = w[k] + 2.0 * h * bounds[k].beta(w[k]).max(bounds[k].alpha(w[k]));
        w[k + 1] = back[k + 1].min(up).max(0.0);
    }
    let v: Vec<f64> = w.iter().map(|x| x.sqrt()).collect();
    if let Some(out) = profile {
        out.clear();
        out.extend(v.iter().enumerate().map(|(k, &v)| (k as f64 * h, v)));
    }
    let time = v
        .windows(2)
        .map(|p| 2.0 * h / (p[0] + p[1]).max(1e-300))
        .sum();
    (time, total)
}

/// [`cycle_time_s`] at `h_mm` and `h_mm / 2`.
pub fn time_optimal(points: &[Point], lim: &Limits, h_mm: f64) -> TimeOptimal {
    let (t, len) = cycle_time_s(points, lim, h_mm, None);
    let (t2, _) = cycle_time_s(points, lim, h_mm / 2.0, None);
    TimeOptimal {
        time_s: t,
        time_half_step_s: t2,
        length_mm: len,
        step_mm: h_mm,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lim() -> Limits {
        Limits {
            tick_s: 1e-3,
            feed_max_mm_s: 100.0,
            axis_speed_mm_s: [1000.0; 3],
            axis_accel_mm_s2: [2000.0; 3],
            chord_mm: 1e-3,
            path_mm: 1e-3,
        }
    }

    fn pts(xyz: &[[f64; 3]], feed: f64) -> Vec<Point> {
        xyz.iter()
            .map(|&pos| Point {
                pos,
                feed_mm_s: feed,
            })
            .collect()
    }

    #[test]
    fn a_straight_line_is_a_trapezoid() {
        // Along X: accelerate at A to F, cruise, brake: L/F + F/A.
        let l = lim();
        let t = time_optimal(&pts(&[[0.0; 3], [100.0, 0.0, 0.0]], 80.0), &l, 0.002);
        let want = 100.0 / 80.0 + 80.0 / 2000.0;
        assert!((t.time_s - want).abs() < 1e-3, "{} vs {want}", t.time_s);
        // On the XY diagonal the box allows √2·A along the path.
        let d = 100.0 / 2f64.sqrt();
        let t = time_optimal(&pts(&[[0.0; 3], [d, d, 0.0]], 80.0), &l, 0.002);
        let want = 100.0 / 80.0 + 80.0 / (2000.0 * 2f64.sqrt());
        assert!((t.time_s - want).abs() < 1e-3, "{} vs {want}", t.time_s);
        assert!(t.discretisation_s() < 1e-4);
    }

    #[test]
    fn a_dense_circle_runs_at_the_centripetal_limit() {
        // r = 5 mm: with the normal along an axis the box gives v²/r <= A;
        // at 45° it gives v²/r·(1/√2) <= A. The speed along a circle is
        // bounded by the worst, √(A·r) = 100 mm/s, at the axis crossings.
        let l = Limits {
            feed_max_mm_s: 1e4,
            axis_speed_mm_s: [1e4; 3],
            ..lim()
        };
        let r = 5.0;
        let n = 4000;
        let xyz: Vec<[f64; 3]> = (0..=n)
            .map(|i| {
                let a = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
                [r * a.cos(), r * a.sin(), 0.0]
            })
            .collect();
        let mut prof = Vec::new();
        cycle_time_s(&pts(&xyz, 1e4), &l, 0.001, Some(&mut prof));
        let len = prof.last().unwrap().0;
        // A quarter turn in (away from the start and end), on an axis
        // crossing (angle π/2) and at 3π/4 (45°).
        let at = |frac: f64| prof[((prof.len() - 1) as f64 * frac) as usize].1;
        let v_axis = (2000.0 * r).sqrt();
        let v45 = (2000.0 * r * 2f64.sqrt()).sqrt();
        let chord = 2.0 * (2.0 * 1e-3 * r - 1e-6).sqrt() / 1e-3;
        assert!((at(0.25) - v_axis).abs() < 1.0, "{} vs {v_axis}", at(0.25));
        assert!(at(0.375) <= v45.min(chord) + 1e-6 && at(0.375) > v_axis);
        assert!(len > 0.99 * 2.0 * std::f64::consts::PI * r);
    }

    #[test]
    fn a_reversal_stops() {
        let l = lim();
        let t = time_optimal(
            &pts(&[[0.0; 3], [10.0, 0.0, 0.0], [0.0, 0.0, 0.0]], 80.0),
            &l,
            0.002,
        );
        let one = 10.0 / 80.0 + 80.0 / 2000.0;
        assert!((t.time_s - 2.0 * one).abs() < 2e-3, "{}", t.time_s);
    }
}
