//! The three test shapes of Lin et al. (Tables 7-8; Table 9, lost from the
//! seed, is the butterfly of the literature the paper cites, as published in
//! public NURBS-interpolator code), sampled like the paper: 2001 points at
//! parameter steps of 0.0005.

use crate::nurbs::Nurbs;

/// The paper's sampling: 2000 steps of 0.0005.
pub const PAPER_POINTS: usize = 2001;

/// A named test shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Shape {
    /// ∞ shape (Table 7).
    Infinity,
    /// Trident (Table 8).
    Trident,
    /// Butterfly (Table 9).
    Butterfly,
}

impl Shape {
    /// All three, in the paper's order.
    pub const ALL: [Shape; 3] = [Shape::Infinity, Shape::Trident, Shape::Butterfly];

    /// Short name (`infinity`, `trident`, `butterfly`).
    pub fn name(self) -> &'static str {
        match self {
            Shape::Infinity => "infinity",
            Shape::Trident => "trident",
            Shape::Butterfly => "butterfly",
        }
    }

    /// The NURBS curve.
    pub fn curve(self) -> Nurbs {
        let cubic_knots = vec![0.0, 0.0, 0.0, 0.0, 0.25, 0.5, 0.75, 1.0, 1.0, 1.0, 1.0];
        let pts = |v: &[(f64, f64)]| v.iter().map(|&(x, y)| [x, y, 0.0]).collect::<Vec<_>>();
        let c = match self {
            Shape::Infinity => Nurbs::new(
                3,
                pts(&[
                    (0.0, 0.0),
                    (-48.0, -90.0),
                    (-68.0, 127.5),
                    (0.0, 0.0),
                    (68.0, -127.5),
                    (48.0, 90.0),
                    (0.0, 0.0),
                ]),
                vec![0.6; 7],
                cubic_knots,
            ),
            Shape::Trident => Nurbs::new(
                3,
                pts(&[
                    (20.0, 0.0),
                    (40.0, 40.0),
                    (24.0, 16.0),
                    (20.0, 40.0),
                    (16.0, 16.0),
                    (0.0, 40.0),
                    (20.0, 0.0),
                ]),
                vec![2.0; 7],
                cubic_knots,
            ),
            Shape::Butterfly => {
                let mut w = vec![1.0; BUTTERFLY.len()];
                for (i, v) in [
                    (4, 1.2),
                    (12, 2.0),
                    (15, 5.0),
                    (16, 3.0),
                    (18, 1.1),
                    (34, 1.1),
                    (36, 3.0),
                    (37, 5.0),
                    (40, 2.0),
                    (48, 1.2),
                ] {
                    w[i - 1] = v; // 1-based in the literature
                }
                let mut knots = vec![0.0; 4];
                knots.extend_from_slice(&BUTTERFLY_INNER_KNOTS);
                knots.extend_from_slice(&[1.0; 4]);
                Nurbs::new(3, pts(&BUTTERFLY), w, knots)
            }
        };
        c.expect("the built-in shapes are valid")
    }

    /// The shape sampled like the paper.
    pub fn points(self) -> Vec<[f64; 3]> {
        self.curve().sample(PAPER_POINTS)
    }

    /// The sampled shape as a toolpath named after the shape. The closed
    /// shapes' last point equals the first: it stays (the path ends where it
    /// started).
    pub fn toolpath(self) -> anyhow::Result<crate::toolpath::Toolpath> {
        crate::toolpath::Toolpath::from_points(self.name(), self.points())
    }
}

/// Butterfly control points, mm.
const BUTTERFLY: [(f64, f64); 51] = [
    (54.493, 52.139),
    (55.507, 52.139),
    (56.082, 49.615),
    (56.780, 44.971),
    (69.575, 51.358),
    (77.786, 58.573),
    (90.526, 67.081),
    (105.973, 63.801),
    (100.400, 47.326),
    (94.567, 39.913),
    (92.369, 30.485),
    (83.440, 33.757),
    (91.892, 28.509),
    (89.444, 20.393),
    (83.218, 15.446),
    (87.621, 4.830),
    (80.945, 9.267),
    (79.834, 14.535),
    (76.074, 8.522),
    (70.183, 12.550),
    (64.171, 16.865),
    (59.993, 22.122),
    (55.680, 36.359),
    (56.925, 24.995),
    (59.765, 19.828),
    (54.493, 14.940),
    (49.220, 19.828),
    (52.060, 24.994),
    (53.305, 36.359),
    (48.992, 22.122),
    (44.814, 16.865),
    (38.802, 12.551),
    (32.911, 8.521),
    (29.152, 14.535),
    (28.040, 9.267),
    (21.364, 4.830),
    (25.768, 15.447),
    (19.539, 20.391),
    (17.097, 28.512),
    (25.537, 33.750),
    (16.602, 30.496),
    (14.199, 39.803),
    (8.668, 47.408),
    (3.000, 63.794),
    (18.465, 67.084),
    (31.197, 58.572),
    (39.411, 51.358),
    (52.204, 44.971),
    (52.904, 49.614),
    (53.478, 52.139),
    (54.493, 52.139),
];

/// Butterfly inner knots (between the clamped 0,0,0,0 and 1,1,1,1).
const BUTTERFLY_INNER_KNOTS: [f64; 47] = [
    0.008286, 0.014978, 0.036118, 0.085467, 0.129349, 0.150871, 0.193075, 0.227259, 0.243467,
    0.256080, 0.269242, 0.288858, 0.316987, 0.331643, 0.348163, 0.355261, 0.364853, 0.383666,
    0.400499, 0.426851, 0.451038, 0.465994, 0.489084, 0.499973, 0.510862, 0.533954, 0.548910,
    0.573096, 0.599447, 0.616280, 0.635094, 0.644687, 0.651784, 0.668304, 0.682958, 0.711087,
    0.730703, 0.743865, 0.756479, 0.772923, 0.806926, 0.849130, 0.870652, 0.914534, 0.963883,
    0.985023, 0.991714,
];

#[cfg(test)]
mod tests {
    use super::*;

    fn length(p: &[[f64; 3]]) -> f64 {
        p.windows(2)
            .map(|w| ((w[1][0] - w[0][0]).powi(2) + (w[1][1] - w[0][1]).powi(2)).sqrt())
            .sum()
    }

    #[test]
    fn shapes_have_the_expected_size() {
        // Figures from an independent evaluation (numpy, Cox-de Boor).
        for (s, len, xmin, xmax) in [
            (Shape::Infinity, 475.16, -53.375, 53.375),
            (Shape::Trident, 97.99, 7.0817, 32.9183),
            (Shape::Butterfly, 382.84, 5.9200, 103.0834),
        ] {
            let p = s.points();
            assert_eq!(p.len(), 2001);
            assert!((length(&p) - len).abs() < 0.01, "{:?}: {}", s, length(&p));
            let (lo, hi) = p
                .iter()
                .fold((f64::MAX, f64::MIN), |(a, b), q| (a.min(q[0]), b.max(q[0])));
            assert!(
                (lo - xmin).abs() < 1e-3 && (hi - xmax).abs() < 1e-3,
                "{s:?}: {lo} {hi}"
            );
        }
    }

    #[test]
    fn closed_shapes_end_where_they_start() {
        for s in Shape::ALL {
            let p = s.points();
            let (a, b) = (p[0], p[2000]);
            assert!(
                (a[0] - b[0]).abs() < 1e-9 && (a[1] - b[1]).abs() < 1e-9,
                "{s:?}"
            );
        }
    }
}
