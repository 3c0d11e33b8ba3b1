//! Rational B-spline (NURBS) curves, Lin et al. eq. 1-3: any degree, any
//! weights, clamped or unclamped knot vectors; evaluation by the Cox-de Boor
//! recursion (eq. 2-3) in its triangular form.

use anyhow::{bail, Result};

/// A NURBS curve in 2-D or 3-D (z = 0 for planar curves).
#[derive(Clone, Debug, PartialEq)]
pub struct Nurbs {
    /// Degree `p`.
    pub degree: usize,
    /// Control points `P_i`, mm.
    pub control: Vec<[f64; 3]>,
    /// Weights `w_i` (> 0).
    pub weights: Vec<f64>,
    /// Knots `u_0 … u_{n+p+1}`, non-decreasing.
    pub knots: Vec<f64>,
}

impl Nurbs {
    /// A checked curve.
    pub fn new(
        degree: usize,
        control: Vec<[f64; 3]>,
        weights: Vec<f64>,
        knots: Vec<f64>,
    ) -> Result<Self> {
        let n = control.len();
        if n <= degree {
            bail!("a degree-{degree} curve needs more than {degree} control points, got {n}");
        }
        if weights.len() != n {
            bail!("{} weights for {n} control points", weights.len());
        }
        if knots.len() != n + degree + 1 {
            bail!(
                "{} knots; a degree-{degree} curve with {n} control points needs {}",
                knots.len(),
                n + degree + 1
            );
        }
        if knots.windows(2).any(|w| w[1] < w[0]) {
            bail!("knots must be non-decreasing");
        }
        if weights.iter().any(|w| w.is_nan() || *w <= 0.0) {
            bail!("weights must be positive");
        }
        Ok(Nurbs {
            degree,
            control,
            weights,
            knots,
        })
    }

    /// The parameter range `[u_p, u_{n}]`.
    pub fn domain(&self) -> (f64, f64) {
        (self.knots[self.degree], self.knots[self.control.len()])
    }

    /// The knot span `i` with `u_i <= u < u_{i+1}` (the last non-empty span
    /// at the end of the domain).
    fn span(&self, u: f64) -> usize {
        let (p, n) = (self.degree, self.control.len());
        if u >= self.knots[n] {
            let mut i = n - 1;
            while i > p && self.knots[i] >= self.knots[n] {
                i -= 1;
            }
            return i;
        }
        let mut i = p;
        while i + 1 < n && self.knots[i + 1] <= u {
            i += 1;
        }
        i
    }

    /// The non-zero basis functions `N_{i-p,p} … N_{i,p}` at `u` (eq. 2-3).
    fn basis(&self, i: usize, u: f64) -> Vec<f64> {
        let p = self.degree;
        let k = &self.knots;
        let mut n = vec![0.0; p + 1];
        let (mut left, mut right) = (vec![0.0; p + 1], vec![0.0; p + 1]);
        n[0] = 1.0;
        for j in 1..=p {
            left[j] = u - k[i + 1 - j];
            right[j] = k[i + j] - u;
            let mut saved = 0.0;
            for r in 0..j {
                let den = right[r + 1] + left[j - r];
                let t = if den == 0.0 { 0.0 } else { n[r] / den };
                n[r] = saved + right[r + 1] * t;
                saved = left[j - r] * t;
            }
            n[j] = saved;
        }
        n
    }

    /// `C(u)`, eq. 1.
    pub fn point(&self, u: f64) -> [f64; 3] {
        let (lo, hi) = self.domain();
        let u = u.clamp(lo, hi);
        let i = self.span(u);
        let n = self.basis(i, u);
        let (mut num, mut den) = ([0.0; 3], 0.0);
        for (j, b) in n.iter().enumerate() {
            let idx = i - self.degree + j;
            let w = b * self.weights[idx];
            for (c, p) in num.iter_mut().zip(self.control[idx]) {
                *c += w * p;
            }
            den += w;
        }
        num.map(|c| c / den)
    }

    /// `count` points at equally spaced parameters from the start to the end
    /// of the domain (the paper: 2000 steps of 0.0005, i.e. 2001 points).
    pub fn sample(&self, count: usize) -> Vec<[f64; 3]> {
        let (lo, hi) = self.domain();
        (0..count)
            .map(|i| self.point(lo + (hi - lo) * i as f64 / (count - 1).max(1) as f64))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quarter_circle_is_exact() {
        // The classic rational quadratic quarter circle.
        let w = std::f64::consts::FRAC_1_SQRT_2;
        let c = Nurbs::new(
            2,
            vec![[1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]],
            vec![1.0, w, 1.0],
            vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
        )
        .unwrap();
        for i in 0..=100 {
            let p = c.point(i as f64 / 100.0);
            assert!(((p[0] * p[0] + p[1] * p[1]).sqrt() - 1.0).abs() < 1e-12);
        }
        assert_eq!(c.point(0.0), [1.0, 0.0, 0.0]);
        assert_eq!(c.point(1.0), [0.0, 1.0, 0.0]);
    }

    #[test]
    fn equal_weights_give_a_b_spline_and_end_interpolation() {
        // Clamped cubic: ends interpolate; equal weights cancel.
        let ctrl = vec![
            [0.0, 0.0, 0.0],
            [1.0, 2.0, 0.0],
            [3.0, 2.0, 0.0],
            [4.0, 0.0, 0.0],
        ];
        let a = Nurbs::new(
            3,
            ctrl.clone(),
            vec![1.0; 4],
            vec![0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0],
        )
        .unwrap();
        let b = Nurbs::new(
            3,
            ctrl,
            vec![7.0; 4],
            vec![0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0],
        )
        .unwrap();
        assert_eq!(a.point(0.0), [0.0, 0.0, 0.0]);
        assert_eq!(a.point(1.0), [4.0, 0.0, 0.0]);
        // A single-span clamped cubic is a Bézier curve: at u = 0.5 it is
        // (P0 + 3P1 + 3P2 + P3)/8.
        let m = a.point(0.5);
        assert!((m[0] - 2.0).abs() < 1e-12 && (m[1] - 1.5).abs() < 1e-12);
        for i in 0..=10 {
            let (p, q) = (a.point(i as f64 / 10.0), b.point(i as f64 / 10.0));
            assert!((p[0] - q[0]).abs() < 1e-12 && (p[1] - q[1]).abs() < 1e-12);
        }
    }

    #[test]
    fn invalid_curves_are_rejected() {
        assert!(Nurbs::new(3, vec![[0.0; 3]; 3], vec![1.0; 3], vec![0.0; 7]).is_err());
        assert!(Nurbs::new(1, vec![[0.0; 3]; 2], vec![1.0; 2], vec![0.0, 0.0, 1.0]).is_err());
        assert!(Nurbs::new(
            1,
            vec![[0.0; 3]; 2],
            vec![1.0, -1.0],
            vec![0.0, 0.0, 1.0, 1.0]
        )
        .is_err());
        assert!(Nurbs::new(1, vec![[0.0; 3]; 2], vec![1.0; 2], vec![0.0, 1.0, 0.5, 1.0]).is_err());
    }
}
