//! LinuxCNC's G5.2/G5.3 NURBS blocks: `G5.2 X Y P L` opens a block, each
//! following line gives a control point `X Y` with its weight `P`, `G5.3`
//! closes it. As in LinuxCNC's interpreter (`nurbs_G5_knot_vector_creator`
//! in `nurbs_additional_functions.cc`):
//! - the tool's position before the block is the first control point
//!   (weight 1: LinuxCNC gives it no weight word either);
//! - order `k` (degree + 1) is 3 unless an `L` word above 3 raises it;
//! - the knot vector for control points `0..=n` is uniform and clamped:
//!   `k` zeros, then `1 … n−k+1`, then `k` times `n−k+2`.
//!
//! The curve is evaluated with [`crate::nurbs`] (eq. 1-3) and sampled
//! adaptively: each parameter interval is halved until the curve's midpoint
//! is within the chord tolerance of the chord (at least four samples per
//! knot span, so that no span is skipped whole).

use anyhow::{bail, Result};

use super::{Block, State};
use crate::nurbs::Nurbs;

/// Control points gathered between G5.2 and G5.3.
pub struct Collector {
    line: u32,
    control: Vec<[f64; 3]>,
    weights: Vec<f64>,
    order: usize,
    z: f64,
}

impl Collector {
    /// A block starting at the tool position `start`, opened on `line`.
    pub fn new(start: [f64; 3], line: u32) -> Self {
        Collector {
            line,
            control: vec![start],
            weights: vec![1.0],
            order: 3,
            z: start[2],
        }
    }

    /// Line of the G5.2.
    pub fn line(&self) -> u32 {
        self.line
    }

    /// Add the control point of one line (`X Y P`, optional `L`).
    pub(super) fn add(&mut self, st: &State, b: &Block) -> Result<()> {
        let line = b.line;
        for w in &b.words {
            if !matches!(w.letter, 'X' | 'Y' | 'P' | 'L') {
                bail!(
                    "line {line}: word {} is not allowed in a NURBS block",
                    w.letter
                );
            }
        }
        if let Some(l) = b.get('L') {
            if l.fract() != 0.0 || !(1.0..=10.0).contains(&l) {
                bail!("line {line}: NURBS order L{l} must be a whole number in 1..=10");
            }
            if l > 3.0 {
                self.order = l as usize;
            }
        }
        let last = *self.control.last().unwrap_or(&[0.0; 3]);
        let mut p = [last[0], last[1], self.z];
        for (k, l) in ['X', 'Y'].iter().enumerate() {
            if let Some(v) = b.get(*l) {
                let v = v * st.mm_per_unit;
                p[k] = if st.absolute { v } else { last[k] + v };
            }
        }
        let w = b.get('P').unwrap_or(1.0);
        if w.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            bail!("line {line}: NURBS weight P{w} must be positive");
        }
        if b.get('X').is_none() && b.get('Y').is_none() {
            bail!("line {line}: a NURBS control point needs X or Y");
        }
        self.control.push(p);
        self.weights.push(w);
        Ok(())
    }

    /// The curve's points after the start, within `tolerance_mm` of it.
    pub fn finish(self, tolerance_mm: f64) -> Result<Vec<[f64; 3]>> {
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
        let curve = Nurbs::new(k - 1, self.control.clone(), self.weights, knots)
            .map_err(|e| anyhow::anyhow!("line {}: {e}", self.line))?;
        let spans = (n + 2 - k).max(1);
        let seeds = 4 * spans;
        let mut out = Vec::new();
        let mut u0 = 0.0;
        let mut p0 = curve.point(0.0);
        for s in 1..=seeds {
            let u1 = s as f64 / seeds as f64;
            let p1 = curve.point(u1);
            refine(&curve, u0, p0, u1, p1, tolerance_mm, 0, &mut out);
            u0 = u1;
            p0 = p1;
        }
        if let Some(l) = out.last_mut() {
            *l = self.control[n]; // clamped: the curve ends on the last control point
        }
        Ok(out)
    }
}

#[allow(clippy::too_many_arguments)]
fn refine(
    c: &Nurbs,
    u0: f64,
    p0: [f64; 3],
    u1: f64,
    p1: [f64; 3],
    tol: f64,
    depth: u32,
    out: &mut Vec<[f64; 3]>,
) {
    let um = 0.5 * (u0 + u1);
    let pm = c.point(um);
    // Distance of the midpoint from the chord p0-p1.
    let d = crate::contour_error::brute_force_distance(&[p0, p1], pm);
    if d > tol && depth < 30 {
        refine(c, u0, p0, um, pm, tol, depth + 1, out);
        refine(c, um, pm, u1, p1, tol, depth + 1, out);
    } else {
        out.push(p1);
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
    fn higher_weight_pulls_the_curve() {
        let s = GcodeSettings::default();
        let a = parse("t", "G1 X0 Y0 F100\nG5.2 X1 Y2 P1\nX2 Y0 P1\nG5.3\n", &s).unwrap();
        let b = parse("t", "G1 X0 Y0 F100\nG5.2 X1 Y2 P3\nX2 Y0 P1\nG5.3\n", &s).unwrap();
        let top = |t: &crate::toolpath::Toolpath| t.points.iter().map(|p| p[1]).fold(0.0, f64::max);
        assert!(top(&b) > top(&a) + 0.3);
    }
}
