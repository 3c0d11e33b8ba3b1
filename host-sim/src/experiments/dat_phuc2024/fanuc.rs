//! The FANUC-like machine of Dat & Phuc (2024): commanded blocks and feeds
//! → interpolation every `Ts` → acc/dec → predicted actual tool motion.
//!
//! Two modes, as in the paper (section 2.1):
//! - **conventional** (high-accuracy contour control off): no acc/dec
//!   before interpolation; each axis follows the interpolated positions
//!   through linear acc/dec after interpolation with the time constant of
//!   parameter 1622 (64 ms on the paper's machine). The paper shows
//!   (Figures 5-6) that this alone predicts the measured corner path.
//! - **high accuracy** (AI contour control on): acc/dec before
//!   interpolation ([`super::before_interpolation`]: corner feed difference
//!   1783 = 250 mm/min, maximum acceleration 1660, bell shape 1772), then
//!   linear acc/dec after interpolation with parameter 1769 (11 ms).
//!
//! Servo lag is not modelled: the paper attributes the path error to acc/dec
//! and matches its measurements within the servo's undershoot (Figures
//! 5-8). The X-Y servo model ([`crate::experiments::cho::servo_xy`]) is the machine with servo
//! dynamics.

use serde::{Deserialize, Serialize};

use super::before_interpolation::{self, Limits};
use crate::interpolation::{interpolate, Polyline, Reference, SpeedProfile};
use crate::machine::accdec::{self, AccDecKind};
use crate::machine::Motion;

/// Whether FANUC's high-accuracy contour control is on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum FanucMode {
    /// Acc/dec after interpolation only (parameter 1622).
    Conventional,
    /// Acc/dec before interpolation (1660, 1772, 1783) and after (1769).
    HighAccuracy,
}

/// Parameters of the FANUC-like machine (names carry the FANUC parameter
/// number and the unit).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FanucConfig {
    /// Conventional or high-accuracy contour control.
    pub mode: FanucMode,
    /// Type of acc/dec after interpolation (the paper's eq. 1-2: linear).
    pub after_interpolation: AccDecKind,
    /// 1622: time constant of acc/dec after interpolation in cutting feed,
    /// conventional mode, ms (paper: 64).
    pub p1622_time_constant_ms: f64,
    /// 1769: time constant of acc/dec after interpolation in the
    /// acc/dec-before-interpolation mode, ms (paper: 11).
    pub p1769_time_constant_ms: f64,
    /// 1783: allowable feed difference of an axis at a corner, mm/min
    /// (paper: 250).
    pub p1783_corner_feed_difference_mm_per_min: f64,
    /// 1660: maximum acceleration of X, Y, Z in acc/dec before
    /// interpolation, mm/s². Not given in the seed's surviving text; 2000
    /// mm/s² (0.2 g) is a common setting for a small machining centre.
    pub p1660_max_acceleration_mm_per_s2: [f64; 3],
    /// 1772: acceleration change time of the bell-shaped acc/dec before
    /// interpolation, ms. Not given in the seed's surviving text; 32 ms.
    pub p1772_bell_time_ms: f64,
}

impl Default for FanucConfig {
    fn default() -> Self {
        FanucConfig {
            mode: FanucMode::Conventional,
            after_interpolation: AccDecKind::Linear,
            p1622_time_constant_ms: 64.0,
            p1769_time_constant_ms: 11.0,
            p1783_corner_feed_difference_mm_per_min: 250.0,
            p1660_max_acceleration_mm_per_s2: [2000.0, 2000.0, 2000.0],
            p1772_bell_time_ms: 32.0,
        }
    }
}

impl FanucConfig {
    /// Check that every parameter is usable.
    pub fn validate(&self) -> anyhow::Result<()> {
        // Real controls use tens of ms; ten seconds bounds the filters'
        // lengths.
        let ok = |v: f64| v.is_finite() && (0.0..=10_000.0).contains(&v);
        anyhow::ensure!(
            ok(self.p1622_time_constant_ms) && ok(self.p1769_time_constant_ms),
            "fanuc: time constants must be in [0, 10000] ms"
        );
        anyhow::ensure!(
            self.p1783_corner_feed_difference_mm_per_min.is_finite()
                && self.p1783_corner_feed_difference_mm_per_min > 0.0,
            "fanuc: p1783 must be > 0 mm/min"
        );
        anyhow::ensure!(
            self.p1660_max_acceleration_mm_per_s2
                .iter()
                .all(|a| a.is_finite() && *a > 0.0),
            "fanuc: p1660 accelerations must be > 0 mm/s²"
        );
        anyhow::ensure!(
            ok(self.p1772_bell_time_ms),
            "fanuc: p1772 must be in [0, 10000] ms"
        );
        Ok(())
    }

    /// Simulate: `feeds_mm_per_min[i]` is the feed of the block ending at
    /// point `i` (index 0 unused).
    pub fn simulate(&self, points: &[[f64; 3]], feeds_mm_per_min: &[f64], ts_s: f64) -> Motion {
        let poly = Polyline::new(points);
        let (commanded, t_after_s) = match self.mode {
            FanucMode::Conventional => {
                let prof = SpeedProfile::per_block(poly.cumulative_mm(), feeds_mm_per_min);
                (
                    interpolate(&poly, &prof, ts_s),
                    self.p1622_time_constant_ms / 1000.0,
                )
            }
            FanucMode::HighAccuracy => {
                let limits = Limits {
                    max_acceleration_mm_per_s2: self.p1660_max_acceleration_mm_per_s2,
                    corner_feed_difference_mm_per_s: self.p1783_corner_feed_difference_mm_per_min
                        / 60.0,
                    bell_time_s: self.p1772_bell_time_ms / 1000.0,
                };
                let prof = before_interpolation::plan(&poly, feeds_mm_per_min, &limits);
                let s = before_interpolation::bell_average(&prof, ts_s, limits.bell_time_s);
                let mut cursor = 1;
                let pos = s
                    .into_iter()
                    .map(|s| poly.position_at(s, &mut cursor))
                    .collect();
                (
                    Reference { ts_s, pos },
                    self.p1769_time_constant_ms / 1000.0,
                )
            }
        };
        let actual = accdec::filter(self.after_interpolation, &commanded.pos, ts_s, t_after_s);
        Motion::padded(ts_s, commanded.pos, actual)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Dat & Phuc's experiment (section 2.2): X then a 90° turn to Y at
    /// 900 mm/min. With linear acc/dec of time constant T each axis ramps
    /// over T, the two ramps overlapping: at the middle of the overlap each
    /// axis is `v·T/8` from the corner, the largest contour error.
    #[test]
    fn corner_of_linear_acc_dec_passes_v_t_over_8_inside() {
        let pts = [[0.0; 3], [50.0, 0.0, 0.0], [50.0, 50.0, 0.0]];
        let cfg = FanucConfig::default();
        let m = cfg.simulate(&pts, &[0.0, 900.0, 900.0], 0.0005);
        let (err, _) = m
            .actual
            .iter()
            .map(|p| ((50.0 - p[0]).powi(2) + p[1].powi(2)).sqrt())
            .enumerate()
            .fold(
                (f64::MAX, 0),
                |(b, bi), (i, d)| if d < b { (d, i) } else { (b, bi) },
            );
        // Closest approach to the corner: at the midpoint of the overlap the
        // tool is at (50 − vT/8, vT/8), √2·vT/8 from the corner; its contour
        // error (distance to the nearer leg) is vT/8 there.
        let v = 900.0 / 60.0;
        let t = 0.064;
        let expected = (2.0f64).sqrt() * v * t / 8.0;
        assert!((err - expected).abs() < 2e-3, "{err} vs {expected}");
        // Cycle time: commanded 100 mm at 15 mm/s plus T.
        let time = (m.actual.len() - 1) as f64 * m.ts_s;
        assert!((time - (100.0 / v + t)).abs() < 1e-3, "{time}");
    }

    #[test]
    fn high_accuracy_mode_cuts_the_corner_error() {
        let pts = [[0.0; 3], [50.0, 0.0, 0.0], [50.0, 50.0, 0.0]];
        let conv = FanucConfig::default().simulate(&pts, &[0.0, 900.0, 900.0], 0.001);
        let hi = FanucConfig {
            mode: FanucMode::HighAccuracy,
            ..Default::default()
        }
        .simulate(&pts, &[0.0, 900.0, 900.0], 0.001);
        let idx = crate::contour_error::PathIndex::new(&pts);
        let corner = |m: &Motion| {
            m.actual
                .iter()
                .map(|p| idx.distance(*p))
                .fold(0.0f64, f64::max)
        };
        assert!(
            corner(&hi) < corner(&conv) / 3.0,
            "{} {}",
            corner(&hi),
            corner(&conv)
        );
    }
}
