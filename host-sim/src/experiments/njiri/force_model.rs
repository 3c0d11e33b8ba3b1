//! Peak cutting forces of ball-end contour milling from the feed per tooth
//! and the radial depth of cut: a documented simplification of Njiri et
//! al.'s mechanistic model (section I.A-B, eq. 1-8; their reference Ikua et
//! al. 2001), which the paper does not give in full (the measured helix
//! angle γ = f(φ), the workpiece and the cutting coefficients are missing).
//!
//! # The model
//!
//! A power law per axis, calibrated at the paper's nominal cut (Table II:
//! h₀ = 1.0 mm, f₀ = 0.1 mm/tooth) to the paper's reference peaks
//! (section III.A: 120 N and 40 N, which the paper took from its own force
//! model at that cut):
//!
//! ```text
//! F_j,peak(f_t, h) = F_j,ref · (f_t / f₀)^a · (h / h₀)^b_j      j = x, y
//! ```
//!
//! - **Feed exponent `a` = 0.75**: the mechanistic model's cutting term is
//!   linear in the chip thickness (eq. 4, `K_tc·t`) and its edge term is
//!   constant; together they grow less than linearly with the feed, the
//!   behaviour Kienzle's law describes with `a = 1 − m_c`, `m_c ≈ 0.25`
//!   for aluminium and steels.
//! - **Depth exponent `b_x` = 0.5**: the engaged length of a ball edge near
//!   the tip at depth `h` is `r_b·acos(1 − h/r_b) ≈ √(2 r_b h)`, and the
//!   peak force follows the engaged length.
//! - **Depth exponent `b_y` = 0.5**, the same: both components scale with
//!   the engaged edge. The paper (Fig. 11, lost) says "the x-component is
//!   the one largely affected by the depth of cut"; we do not follow it by
//!   default because then no override holds both references, and Table I's
//!   dead band (a steady error in one axis alone, `s = −1`, is Ze: no
//!   change) lets the loop rest wherever F_x is above and F_y below their
//!   references by more than the ±1.5 N universe. `host-sim njiri
//!   --depth-exponent-y 0.25` shows that case (README figures).
//!
//! Within one revolution the force of the single flute (Table II: 0.1
//! mm/tooth at 300 min⁻¹ is exactly 30 mm/min with one flute) is a half-sine
//! pulse while the flute is engaged, zero otherwise ([`ForceModel::sample`]):
//! what a dynamometer would show, from which the controller's peak is taken.
//!
//! # What this fixes about the result
//!
//! With both peaks held at their references after the step to `h₁ = 1.5
//! mm`, the override is `o = (h₀/h₁)^(b/a)` = (2/3)^(2/3) ≈ 76.3 %, before
//! the controller's dead band. The paper's 78 % is therefore a check that
//! the controller holds the forces, not an independent prediction of the
//! model: other exponents give other overrides (a purely proportional
//! model, `a = b = 1`, gives 67 %).

use std::f64::consts::PI;

use anyhow::{ensure, Result};

/// The force model's parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct ForceModel {
    /// Peak F_x, F_y at the nominal cut, N.
    pub reference_n: [f64; 2],
    /// Nominal feed per tooth f₀, mm.
    pub nominal_feed_per_tooth_mm: f64,
    /// Nominal radial depth of cut h₀, mm.
    pub nominal_depth_mm: f64,
    /// Feed exponent `a`.
    pub feed_exponent: f64,
    /// Depth exponents `b_x`, `b_y`.
    pub depth_exponent: [f64; 2],
    /// Ball radius r_b, mm (depths beyond it are refused).
    pub ball_radius_mm: f64,
    /// Number of flutes n_t.
    pub flutes: u32,
    /// Fraction of a tooth period during which the flute cuts (0, 1].
    pub engagement: f64,
}

/// Peak force magnitudes over one revolution, N.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PeakForces {
    /// max |F_x| (feed direction), N.
    pub fx: f64,
    /// max |F_y| (across the feed), N.
    pub fy: f64,
}

/// Table II's nominal depth of cut, mm.
pub const NOMINAL_DEPTH_MM: f64 = 1.0;
/// Table II: 0.1 mm/tooth.
pub const NOMINAL_FEED_PER_TOOTH_MM: f64 = 0.1;
/// Section III.A: F_x = 120 N.
pub const REFERENCE_FX_N: f64 = 120.0;
/// Section III.A: F_y = 40 N.
pub const REFERENCE_FY_N: f64 = 40.0;

impl Default for ForceModel {
    fn default() -> Self {
        ForceModel::paper()
    }
}

impl ForceModel {
    /// The module's choices, calibrated to the paper's reference peaks.
    pub fn paper() -> ForceModel {
        ForceModel {
            reference_n: [REFERENCE_FX_N, REFERENCE_FY_N],
            nominal_feed_per_tooth_mm: NOMINAL_FEED_PER_TOOTH_MM,
            nominal_depth_mm: NOMINAL_DEPTH_MM,
            feed_exponent: 0.75,
            depth_exponent: [0.5, 0.5],
            ball_radius_mm: 5.0,
            flutes: 1,
            engagement: 0.5,
        }
    }

    /// Check the parameters.
    pub fn validate(&self) -> Result<()> {
        let pos = |v: f64| v.is_finite() && v > 0.0;
        ensure!(
            self.reference_n.iter().all(|f| pos(*f)),
            "reference forces must be > 0 N"
        );
        ensure!(
            pos(self.nominal_feed_per_tooth_mm) && pos(self.nominal_depth_mm),
            "nominal feed per tooth and depth must be > 0 mm"
        );
        ensure!(
            self.feed_exponent.is_finite() && (0.0..=2.0).contains(&self.feed_exponent),
            "feed exponent must be in [0, 2]"
        );
        ensure!(
            self.depth_exponent
                .iter()
                .all(|b| b.is_finite() && (0.0..=2.0).contains(b)),
            "depth exponents must be in [0, 2]"
        );
        ensure!(pos(self.ball_radius_mm), "ball radius must be > 0 mm");
        ensure!(self.flutes >= 1 && self.flutes <= 16, "1 to 16 flutes");
        ensure!(
            pos(self.engagement) && self.engagement <= 1.0,
            "engagement must be in (0, 1]"
        );
        Ok(())
    }

    /// Peak |F_x|, |F_y| of a revolution at feed per tooth `f_t_mm` and
    /// depth `depth_mm` (0 for no feed or no depth).
    pub fn peaks(&self, f_t_mm: f64, depth_mm: f64) -> PeakForces {
        let f = (f_t_mm.max(0.0) / self.nominal_feed_per_tooth_mm).powf(self.feed_exponent);
        let h = depth_mm.max(0.0) / self.nominal_depth_mm;
        let axis = |j: usize| {
            if f_t_mm <= 0.0 || depth_mm <= 0.0 {
                0.0
            } else {
                self.reference_n[j] * f * h.powf(self.depth_exponent[j])
            }
        };
        PeakForces {
            fx: axis(0),
            fy: axis(1),
        }
    }

    /// The force at spindle angle `spindle_rad` (one flute per `2π/n_t`): a
    /// half-sine pulse of the peak's height while the flute is engaged.
    pub fn sample(&self, spindle_rad: f64, f_t_mm: f64, depth_mm: f64) -> (f64, f64) {
        let p = self.peaks(f_t_mm, depth_mm);
        let period = 2.0 * PI / self.flutes as f64;
        let phase = spindle_rad.rem_euclid(period) / period;
        let w = if phase < self.engagement {
            (PI * phase / self.engagement).sin()
        } else {
            0.0
        };
        (p.fx * w, -p.fy * w)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nominal_cut_gives_the_reference_peaks() {
        let m = ForceModel::paper();
        m.validate().unwrap();
        let p = m.peaks(NOMINAL_FEED_PER_TOOTH_MM, NOMINAL_DEPTH_MM);
        assert!(
            (p.fx - 120.0).abs() < 1e-9 && (p.fy - 40.0).abs() < 1e-9,
            "{p:?}"
        );
    }

    #[test]
    fn forces_grow_with_feed_and_depth() {
        let m = ForceModel::paper();
        let base = m.peaks(0.1, 1.0);
        let deeper = m.peaks(0.1, 1.5);
        let faster = m.peaks(0.15, 1.0);
        assert!((deeper.fx / base.fx - 1.5f64.sqrt()).abs() < 1e-12);
        assert!(faster.fx > base.fx && faster.fy > base.fy);
        assert!(faster.fx / base.fx < 1.5, "sub-linear in the feed");
        let none = m.peaks(0.1, 0.0);
        assert_eq!((none.fx, none.fy), (0.0, 0.0));
        assert_eq!(m.peaks(0.0, 1.0).fx, 0.0);
    }

    #[test]
    fn samples_peak_at_the_peak() {
        let m = ForceModel::paper();
        let n = 3600;
        let (mut mx, mut my) = (0.0f64, 0.0f64);
        for i in 0..n {
            let (x, y) = m.sample(2.0 * PI * i as f64 / n as f64, 0.1, 1.0);
            mx = mx.max(x.abs());
            my = my.max(y.abs());
        }
        assert!((mx - 120.0).abs() < 1e-3 && (my - 40.0).abs() < 1e-3);
    }

    #[test]
    fn bad_parameters_are_refused() {
        let m = ForceModel {
            ball_radius_mm: 0.0,
            ..ForceModel::paper()
        };
        assert!(m.validate().is_err());
        let m = ForceModel {
            depth_exponent: [f64::NAN, 1.0],
            ..ForceModel::paper()
        };
        assert!(m.validate().is_err());
    }
}
