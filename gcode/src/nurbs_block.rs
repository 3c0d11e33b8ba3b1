//! LinuxCNC's curve blocks, evaluated and sampled within the chord
//! tolerance:
//!
//! - **G5.2/G5.3 NURBS** (`nurbs_G5_knot_vector_creator` in LinuxCNC's
//!   `nurbs_additional_functions.cc`): `G5.2 X Y P L` opens a block, each
//!   following line gives a control point with its weight `P`, `G5.3`
//!   closes it. The tool's position before the block is the first control
//!   point (weight 1); order `k` (degree + 1) is 3 unless an `L` word above 3
//!   raises it; the knot vector for control points `0..=n` is uniform and
//!   clamped: `k` zeros, then `1 … n−k+1`, then `k` times `n−k+2`. The
//!   control points' two coordinates are those of the selected plane (G17:
//!   X Y, G18: Z X, G19: Y Z).
//! - **G6.2 NURBS with explicit knots** (Lo Valvo and Drago's generator, in
//!   LinuxCNC's `interp_convert.cc`, `convert_nurbs`): every `G6.2` line
//!   gives a control point (the plane's two words), its weight `R` and one
//!   knot `K`; the first gives the order `P`; the block ends on the line
//!   whose knot makes the last `P` knots equal. Lines with only a `K` add a
//!   knot. The control points are the first (knots − order) entries. `Q`
//!   selects how LinuxCNC's motion follows the curve, not the curve: it is
//!   read and otherwise ignored.
//! - **G5 cubic and G5.1 quadratic splines** (LinuxCNC `convert_spline`):
//!   G5 is the cubic Bézier from the tool through `start + (I, J)` and
//!   `end + (P, Q)` to `end`; without I J, the first control point mirrors
//!   the previous G5's second; G5.1 is the quadratic Bézier through
//!   `start + (I, J)`. XY plane only.
//!
//! Curves are evaluated with [`crate::nurbs`] (Lin et al. eq. 1-3) and
//! sampled adaptively: each parameter interval is halved until the curve's
//! midpoint is within the chord tolerance of the chord (at least four
//! samples per knot span, so that no span is skipped whole). The samples are
//! counted against the point bound as they are made.

use anyhow::{anyhow, bail, Result};

use super::arc::Plane;
use crate::nurbs::Nurbs;
use crate::text::short;

/// Control points gathered between G5.2 and G5.3.
pub struct Collector {
    line: u32,
    plane: Plane,
    control: Vec<[f64; 3]>,
    weights: Vec<f64>,
    order: usize,
}

impl Collector {
    /// A block starting at the tool position `start` (mm), opened on `line`.
    pub fn new(start: [f64; 3], plane: Plane, line: u32) -> Self {
        Collector {
            line,
            plane,
            control: vec![start],
            weights: vec![1.0],
            order: 3,
        }
    }

    /// Line of the G5.2.
    pub fn line(&self) -> u32 {
        self.line
    }

    /// The plane of the block.
    pub fn plane(&self) -> Plane {
        self.plane
    }

    /// The last control point, mm.
    pub fn last(&self) -> [f64; 3] {
        *self.control.last().unwrap_or(&[0.0; 3])
    }

    /// A `G5.2` line without a point: the start point's weight `p` and the
    /// order `l`.
    pub fn set_start(&mut self, p: Option<f64>, l: Option<f64>, line: u32) -> Result<()> {
        self.order_from(l, line)?;
        if let Some(w) = p {
            if !(w.is_finite() && w > 0.0) {
                bail!("line {line}: NURBS weight P{} must be positive", short(w));
            }
            self.weights[0] = w;
        }
        Ok(())
    }

    fn order_from(&mut self, l: Option<f64>, line: u32) -> Result<()> {
        if let Some(l) = l {
            if l.fract() != 0.0 || !(1.0..=10.0).contains(&l) {
                bail!(
                    "line {line}: NURBS order L{} must be a whole number in 1..=10",
                    short(l)
                );
            }
            if l > 3.0 {
                self.order = l as usize;
            }
        }
        Ok(())
    }

    /// Add a control point (mm) with weight `p` and optional order `l`.
    pub fn add(
        &mut self,
        point: [f64; 3],
        p: Option<f64>,
        l: Option<f64>,
        line: u32,
    ) -> Result<()> {
        self.order_from(l, line)?;
        let w = p.unwrap_or(1.0);
        if !(w.is_finite() && w > 0.0) {
            bail!("line {line}: NURBS weight P{} must be positive", short(w));
        }
        self.control.push(point);
        self.weights.push(w);
        Ok(())
    }

    /// The curve's points after the start, within `tolerance_mm` of it, at
    /// most `room` of them.
    pub fn finish(self, tolerance_mm: f64, room: usize) -> Result<Vec<[f64; 3]>> {
        let n = self.control.len() - 1;
        let k = self.order;
        if n + 1 < k {
            bail!(
                "line {}: a NURBS of order {k} needs at least {k} control points (with the start), got {}",
                self.line,
                n + 1
            );
        }
        let umax = (n + 2 - k) as f64;
        let knots: Vec<f64> = (0..=n + k)
            .map(|i| {
                let v = if i < k {
                    0.0
                } else if i <= n {
                    (i + 1 - k) as f64
                } else {
                    umax
                };
                v / umax
            })
            .collect();
        let last = self.control[n];
        let curve = Nurbs::new(k - 1, self.control, self.weights, knots)
            .map_err(|e| anyhow!("line {}: {e}", self.line))?;
        let spans = (n + 2 - k).max(1);
        let mut out = sample(&|u| curve.point(u), 0.0, 1.0, spans, tolerance_mm, room)
            .map_err(|e| anyhow!("line {}: NURBS block {e}", self.line))?;
        if let Some(l) = out.last_mut() {
            *l = last; // clamped: the curve ends on the last control point
        }
        Ok(out)
    }
}

/// Entries gathered by G6.2 lines.
pub struct Collector6 {
    line: u32,
    order: usize,
    control: Vec<[f64; 3]>,
    weights: Vec<f64>,
    knots: Vec<f64>,
}

impl Collector6 {
    /// A block opened on `line` with order `p`.
    pub fn new(order: f64, line: u32) -> Result<Self> {
        if order.fract() != 0.0 || !(2.0..=10.0).contains(&order) {
            bail!(
                "line {line}: G6.2 order P{} must be a whole number in 2..=10",
                short(order)
            );
        }
        Ok(Collector6 {
            line,
            order: order as usize,
            control: Vec::new(),
            weights: Vec::new(),
            knots: Vec::new(),
        })
    }

    /// Add an entry: a control point with weight, or (`None`) a knot alone.
    /// Returns whether the block is complete.
    pub fn add(&mut self, point: Option<([f64; 3], f64)>, knot: f64, line: u32) -> Result<bool> {
        if !knot.is_finite() || self.knots.last().is_some_and(|&k| knot < k) {
            bail!(
                "line {line}: G6.2 knot K{} is smaller than the knot before it",
                short(knot)
            );
        }
        if let Some((p, w)) = point {
            if !(w.is_finite() && w > 0.0) {
                bail!("line {line}: G6.2 weight R{} must be positive", short(w));
            }
            if self.knots.len() > self.control.len() {
                bail!("line {line}: G6.2 control point after a line with a knot alone");
            }
            self.control.push(p);
            self.weights.push(w);
        }
        self.knots.push(knot);
        if self.knots.len() > 10_000_000 {
            bail!("line {line}: G6.2 block with more than 10 000 000 knots");
        }
        let n = self.knots.len();
        Ok(n > self.order && self.knots[n - self.order..].iter().all(|&k| k == knot))
    }

    /// The curve's points after its first control point.
    pub fn finish(self, tolerance_mm: f64, room: usize) -> Result<Vec<[f64; 3]>> {
        let k = self.order;
        let ctrl = self.knots.len() - k;
        if self.control.len() < ctrl || ctrl < k {
            bail!(
                "line {}: G6.2 block with {} control points and {} knots: order {k} needs knots = control points + {k} and at least {k} control points",
                self.line,
                self.control.len(),
                self.knots.len()
            );
        }
        let mut control = self.control;
        let mut weights = self.weights;
        control.truncate(ctrl);
        weights.truncate(ctrl);
        let last = control[ctrl - 1];
        let spans = ctrl + 1 - k;
        let curve = Nurbs::new(k - 1, control, weights, self.knots)
            .map_err(|e| anyhow!("line {}: {e}", self.line))?;
        let (lo, hi) = curve.domain();
        let mut out = sample(&|u| curve.point(u), lo, hi, spans, tolerance_mm, room)
            .map_err(|e| anyhow!("line {}: G6.2 block {e}", self.line))?;
        if let Some(l) = out.last_mut() {
            *l = last;
        }
        Ok(out)
    }
}

/// Points of a Bézier curve with control points `c` (3 or 4) after its
/// start.
pub fn bezier(c: &[[f64; 3]], tolerance_mm: f64, room: usize) -> Result<Vec<[f64; 3]>> {
    let eval = |t: f64| -> [f64; 3] {
        // de Casteljau.
        let mut q = c.to_vec();
        while q.len() > 1 {
            for i in 0..q.len() - 1 {
                let next = q[i + 1];
                for (a, b) in q[i].iter_mut().zip(next) {
                    *a += t * (b - *a);
                }
            }
            q.pop();
        }
        q[0]
    };
    let mut out = sample(&eval, 0.0, 1.0, 1, tolerance_mm, room)?;
    if let (Some(l), Some(end)) = (out.last_mut(), c.last()) {
        *l = *end;
    }
    Ok(out)
}

/// Adaptive samples of `f` on `[u0, u1]` after `f(u0)`: `4·spans` seeds,
/// each interval halved (at most 30 times) until the midpoint is within
/// `tol` of the chord; more than `room` points is an error.
fn sample(
    f: &dyn Fn(f64) -> [f64; 3],
    u0: f64,
    u1: f64,
    spans: usize,
    tol: f64,
    room: usize,
) -> Result<Vec<[f64; 3]>> {
    if !(tol.is_finite() && tol > 0.0) {
        bail!("chord tolerance {} mm must be positive", short(tol));
    }
    let seeds = 4 * spans;
    if seeds > room {
        bail!("needs more points than gcode.limits.max_points allows here ({room})");
    }
    let mut out = Vec::new();
    let mut a = u0;
    let mut pa = f(u0);
    for s in 1..=seeds {
        let b = u0 + (u1 - u0) * s as f64 / seeds as f64;
        let pb = f(b);
        refine(f, (a, pa), (b, pb), tol, 0, room, &mut out)?;
        a = b;
        pa = pb;
    }
    Ok(out)
}

fn refine(
    f: &dyn Fn(f64) -> [f64; 3],
    (u0, p0): (f64, [f64; 3]),
    (u1, p1): (f64, [f64; 3]),
    tol: f64,
    depth: u32,
    room: usize,
    out: &mut Vec<[f64; 3]>,
) -> Result<()> {
    let um = 0.5 * (u0 + u1);
    let pm = f(um);
    // Distance of the midpoint from the chord p0-p1.
    let d = crate::toolpath::segment_distance(p0, p1, pm);
    if d > tol && depth < 30 {
        refine(f, (u0, p0), (um, pm), tol, depth + 1, room, out)?;
        refine(f, (um, pm), (u1, p1), tol, depth + 1, room, out)
    } else {
        if out.len() >= room {
            bail!("needs more points than gcode.limits.max_points allows here ({room})");
        }
        out.push(p1);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::super::{parse, GcodeSettings};

    #[test]
    fn quadratic_with_equal_weights_is_the_bezier_parabola() {
        // Start (0,0), control (1,2), end (2,0), order 3: a single Bézier
        // span, y = 2·2t(1−t), x = 2t: the parabola y = x(2 − x).
        let t = parse(
            "t",
            "G1 X0 Y0 F100\nG5.2 X1 Y2 P1\nX2 Y0 P1\nG5.3\n",
            &GcodeSettings::default(),
        )
        .unwrap();
        assert!(t.len() > 20);
        assert_eq!(*t.points.last().unwrap(), [2.0, 0.0, 0.0]);
        for p in &t.points[1..] {
            assert!((p[1] - p[0] * (2.0 - p[0])).abs() < 1e-9, "{p:?}");
        }
        // Chords within the tolerance of the curve.
        for w in t.points[1..].windows(2) {
            let m = [(w[0][0] + w[1][0]) / 2.0, (w[0][1] + w[1][1]) / 2.0];
            assert!((m[0] * (2.0 - m[0]) - m[1]).abs() < 0.0011);
        }
    }

    #[test]
    fn other_planes_and_g5_splines() {
        let s = GcodeSettings::default();
        // The same parabola in the Y Z plane (G19: first Y, then Z).
        let t = parse(
            "t",
            "G19 G1 Y0 Z0 F100\nG5.2 Y1 Z2 P1\nY2 Z0 P1\nG5.3\n",
            &s,
        )
        .unwrap();
        for p in &t.points[1..] {
            assert!(
                (p[2] - p[1] * (2.0 - p[1])).abs() < 1e-9 && p[0] == 0.0,
                "{p:?}"
            );
        }
        // G5.1 with I J: the same quadratic Bézier.
        let q = parse("t", "G1 X0 Y0 F100\nG5.1 X2 Y0 I1 J2\n", &s).unwrap();
        for p in &q.points[1..] {
            assert!((p[1] - p[0] * (2.0 - p[0])).abs() < 1e-9, "{p:?}");
        }
        // G5 cubic: control points (0,0) (0,1) (1,1) (1,0): x(0.5) = 0.5,
        // y(0.5) = 0.75; the curve is symmetric about x = 0.5.
        let c = parse("t", "G1 X0 Y0 F100\nG5 X1 Y0 I0 J1 P0 Q1\n", &s).unwrap();
        let top = c.points.iter().map(|p| p[1]).fold(0.0, f64::max);
        assert!((top - 0.75).abs() < 0.001, "{top}");
        assert!(parse("t", "G1 X0 Y0 F100\nG5 X1 Y0\n", &s).is_err());
    }

    #[test]
    fn g6_2_with_knots_ends_on_its_last_control_point() {
        // Order 3, four control points, clamped knots 0 0 0 1 2 2 2.
        let src = "G1 X0 Y0 F100\nG6.2 X0 Y0 R1 K0 P3 Q1\nX1 Y1 R1 K0\nX2 Y1 R1 K0\nX3 Y0 R1 K1\nG6.2 K2\nG6.2 K2\nG6.2 K2\nG1 X4\n";
        let t = parse("t", src, &GcodeSettings::default()).unwrap();
        let i = t.lines.iter().position(|&l| l == 9).unwrap();
        assert_eq!(t.points[i - 1], [3.0, 0.0, 0.0]);
        assert!(t.points[1..i].iter().all(|p| p[1] >= 0.0 && p[1] <= 1.0));
        assert!(i > 10);
    }

    #[test]
    fn higher_weight_pulls_the_curve() {
        let s = GcodeSettings::default();
        let a = parse("t", "G1 X0 Y0 F100\nG5.2 X1 Y2 P1\nX2 Y0 P1\nG5.3\n", &s).unwrap();
        let b = parse("t", "G1 X0 Y0 F100\nG5.2 X1 Y2 P3\nX2 Y0 P1\nG5.3\n", &s).unwrap();
        let top = |t: &crate::toolpath::Toolpath| t.points.iter().map(|p| p[1]).fold(0.0, f64::max);
        assert!(top(&b) > top(&a) + 0.3);
    }

    #[test]
    fn tiny_tolerance_is_refused_not_exhausting_memory() {
        let s = GcodeSettings {
            chord_tolerance_mm: 1e-9,
            limits: super::super::Limits {
                max_points: 1_000,
                ..Default::default()
            },
            ..Default::default()
        };
        let e = parse("t", "G1 X0 Y0 F100\nG5.2 X1 Y2 P1\nX2 Y0 P1\nG5.3\n", &s)
            .err()
            .unwrap();
        assert!(format!("{e:#}").contains("max_points"), "{e:#}");
    }
}
