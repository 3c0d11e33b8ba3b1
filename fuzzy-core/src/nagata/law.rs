//! Nagata et al.'s feed law: `F(i) = F_min + F_base·u_A`, `ΔF(i) =
//! F_min·u_B` and `F̃(i) = F(i) + ΔF(i)` (eq. 4-6) with the limits of
//! section 3, and the CL segment lengths `d(i)`, `Δd(i)` it takes.

use fixed::types::I32F32;

use super::data::{NagataController, COMPENSATION_CONTROLLER, FEED_CONTROLLER};
use crate::curvature::Chord;
use crate::units::{FeedMmPerMin, Fx, Point3Mm, FEED_LIMIT_MM_PER_MIN};

/// F_min and F_max, "the maximum and minimum values for the feed rate
/// estimated in advance" (section 3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FeedLimits {
    /// F_min, mm/min.
    pub f_min: FeedMmPerMin,
    /// F_max, mm/min.
    pub f_max: FeedMmPerMin,
}

impl FeedLimits {
    /// `F_base = F_max − F_min`.
    pub fn f_base(&self) -> FeedMmPerMin {
        FeedMmPerMin(self.f_max.0.saturating_sub(self.f_min.0))
    }
}

/// Whether F̃ may leave `[F_min, F_max]` (module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FeedRange {
    /// As the paper: `F̃ = F + ΔF` unclamped.
    #[default]
    Paper,
    /// `F̃` clamped to `[F_min, F_max]`.
    Clamp,
}

/// Why a [`FeedGenerator`] cannot be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum NagataError {
    /// Not `0 < F_min < F_max ≤` [`FEED_LIMIT_MM_PER_MIN`].
    BadLimits,
}

impl core::fmt::Display for NagataError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            NagataError::BadLimits => write!(
                f,
                "feed limits must satisfy 0 < F_min < F_max <= {FEED_LIMIT_MM_PER_MIN} mm/min"
            ),
        }
    }
}

/// The result of eq. 4-6 for one segment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FuzzyFeed {
    /// `F(i)` (eq. 4), mm/min.
    pub base: FeedMmPerMin,
    /// `ΔF(i)` (eq. 5), mm/min, signed.
    pub compensation: I32F32,
    /// `F̃(i)` (eq. 6), after [`FeedRange`], mm/min.
    pub feed: FeedMmPerMin,
}

/// The two reasoners with their limits.
#[derive(Clone, Copy, Debug)]
pub struct FeedGenerator<'c> {
    feed: &'c NagataController,
    compensation: &'c NagataController,
    limits: FeedLimits,
    range: FeedRange,
}

/// Q16.16 → I32F32, exactly.
fn widen(v: Fx) -> I32F32 {
    I32F32::from_bits((v.to_bits() as i64) << 16)
}

/// I32F32 → Q16.16 (saturating; the inputs are clamped to ±25 mm anyway).
fn narrow(v: I32F32) -> Fx {
    Fx::from_bits((v.to_bits() >> 16).clamp(i32::MIN as i64, i32::MAX as i64) as i32)
}

impl<'c> FeedGenerator<'c> {
    /// The generator on [`FEED_CONTROLLER`] and [`COMPENSATION_CONTROLLER`].
    pub fn new(limits: FeedLimits, range: FeedRange) -> Result<Self, NagataError> {
        Self::with_controllers(&FEED_CONTROLLER, &COMPENSATION_CONTROLLER, limits, range)
    }

    /// The generator on other compiled reasoners of the same shape (e.g.
    /// retuned membership functions).
    pub fn with_controllers(
        feed: &'c NagataController,
        compensation: &'c NagataController,
        limits: FeedLimits,
        range: FeedRange,
    ) -> Result<Self, NagataError> {
        let max = I32F32::from_num(FEED_LIMIT_MM_PER_MIN);
        if !(limits.f_min.0 > 0 && limits.f_min < limits.f_max && limits.f_max.0 <= max) {
            return Err(NagataError::BadLimits);
        }
        Ok(FeedGenerator {
            feed,
            compensation,
            limits,
            range,
        })
    }

    /// The limits.
    pub fn limits(&self) -> FeedLimits {
        self.limits
    }

    /// The range of every possible F̃: `[F_min, F_max]` when clamped, else
    /// the hull of Table 1, `[F_min + 0.1 F_base − 0.5 F_min,
    /// F_max + 0.5 F_min]`.
    pub fn bounds(&self) -> (FeedMmPerMin, FeedMmPerMin) {
        let FeedLimits { f_min, f_max } = self.limits;
        match self.range {
            FeedRange::Clamp => (f_min, f_max),
            FeedRange::Paper => {
                let half = f_min.0 / 2;
                let lo = f_min.0 + self.limits.f_base().0 / 10 - half;
                (
                    FeedMmPerMin(lo.max(I32F32::ZERO)),
                    FeedMmPerMin(f_max.0.saturating_add(half)),
                )
            }
        }
    }

    /// Eq. 2-6 for a segment of length `d_mm` followed by one `dd_mm`
    /// longer.
    pub fn feed(&self, d_mm: I32F32, dd_mm: I32F32) -> FuzzyFeed {
        let FeedLimits { f_min, .. } = self.limits;
        let u_a = widen(self.feed.evaluate([narrow(d_mm)]).output);
        let u_b = widen(self.compensation.evaluate([narrow(dd_mm)]).output);
        let base = f_min
            .0
            .saturating_add(self.limits.f_base().0.saturating_mul(u_a));
        let compensation = f_min.0.saturating_mul(u_b);
        let (lo, hi) = self.bounds();
        let feed = base.saturating_add(compensation).clamp(lo.0, hi.0);
        FuzzyFeed {
            base: FeedMmPerMin(base),
            compensation,
            feed: FeedMmPerMin(feed),
        }
    }
}

/// `d(i) = ‖p(i+1) − p(i)‖` and `Δd(i) = d(i+1) − d(i)` for the segment
/// `p0 → p1` followed by `p1 → p2` (`None` at the end of the data: Δd = 0),
/// mm. Coincident points have length 0.
pub fn segment_lengths(p0: &Point3Mm, p1: &Point3Mm, p2: Option<&Point3Mm>) -> (I32F32, I32F32) {
    let len =
        |a: &Point3Mm, b: &Point3Mm| Chord::between(a, b).map_or(I32F32::ZERO, |c| c.length_mm());
    let d = len(p0, p1);
    let dd = p2.map_or(I32F32::ZERO, |p2| len(p1, p2).saturating_sub(d));
    (d, dd)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits(lo: i32, hi: i32) -> FeedLimits {
        FeedLimits {
            f_min: FeedMmPerMin::from_int(lo),
            f_max: FeedMmPerMin::from_int(hi),
        }
    }

    fn feed(g: &FeedGenerator<'_>, d: f64, dd: f64) -> f64 {
        g.feed(I32F32::from_num(d), I32F32::from_num(dd))
            .feed
            .to_f64()
    }

    #[test]
    fn short_segments_slow_long_ones_fast() {
        let g = FeedGenerator::new(limits(300, 1200), FeedRange::Paper).unwrap();
        let f0 = feed(&g, 0.0, 0.0);
        let f25 = feed(&g, 25.0, 0.0);
        assert!((f0 - (300.0 + 0.14 * 900.0)).abs() < 5.0, "{f0}");
        assert!((f25 - (300.0 + 0.92 * 900.0)).abs() < 5.0, "{f25}");
        // Beyond the universe: clamped to 25 mm.
        assert_eq!(feed(&g, 400.0, 0.0), f25);
        let mut last = 0.0;
        for i in 0..=250 {
            let f = feed(&g, i as f64 * 0.1, 0.0);
            assert!(f >= last - 0.01, "d = {}", i as f64 * 0.1);
            last = f;
        }
        // A shorter segment ahead slows, a longer one speeds up, Δd = 0 is
        // neutral.
        assert!(feed(&g, 5.0, -10.0) < feed(&g, 5.0, 0.0));
        assert!(feed(&g, 5.0, 10.0) > feed(&g, 5.0, 0.0));
        let z = g.feed(I32F32::from_num(5), I32F32::ZERO);
        assert!(z.compensation.abs() < I32F32::from_num(0.01));
    }

    #[test]
    fn clamped_and_paper_ranges() {
        let p = FeedGenerator::new(limits(300, 1200), FeedRange::Paper).unwrap();
        let c = FeedGenerator::new(limits(300, 1200), FeedRange::Clamp).unwrap();
        assert!(feed(&p, 25.0, 25.0) > 1200.0);
        assert_eq!(feed(&c, 25.0, 25.0), 1200.0);
        let p = FeedGenerator::new(limits(600, 700), FeedRange::Paper).unwrap();
        let c = FeedGenerator::new(limits(600, 700), FeedRange::Clamp).unwrap();
        assert!(feed(&p, 0.0, -25.0) < 600.0);
        assert_eq!(feed(&c, 0.0, -25.0), 600.0);
        let (lo, hi) = p.bounds();
        assert_eq!(lo.to_f64(), 600.0 + 10.0 - 300.0);
        assert_eq!(hi.to_f64(), 1000.0);
    }

    #[test]
    fn bad_limits_refused() {
        for (lo, hi) in [(0, 100), (100, 100), (200, 100), (-5, 100)] {
            assert_eq!(
                FeedGenerator::new(limits(lo, hi), FeedRange::Paper).err(),
                Some(NagataError::BadLimits)
            );
        }
        assert!(
            FeedGenerator::new(limits(1, FEED_LIMIT_MM_PER_MIN + 1), FeedRange::Paper).is_err()
        );
    }

    #[test]
    fn lengths() {
        let p = |x: f64, y: f64| Point3Mm::from_f64(x, y, 0.0).unwrap();
        let (d, dd) = segment_lengths(&p(0.0, 0.0), &p(3.0, 4.0), Some(&p(4.0, 4.0)));
        assert_eq!(d, I32F32::from_num(5));
        assert_eq!(dd, I32F32::from_num(-4));
        let (d, dd) = segment_lengths(&p(0.0, 0.0), &p(0.0, 0.0), None);
        assert_eq!((d, dd), (I32F32::ZERO, I32F32::ZERO));
    }

    /// Eq. 2-7 and Table 1 in `f64`, with eq. 7 as printed (`q`, not σ).
    fn reference(f_min: f64, f_max: f64, d: f64, dd: f64) -> f64 {
        let mu = |x: f64, p: f64, q: f64| (0.5f64.ln() * (x - p).powi(2) * q * q).exp();
        let base = f_max - f_min;
        let ca = [0.1, 0.2, 0.4, 0.6, 0.8, 1.0].map(|k| f_min + k * base);
        let cb = [-0.5, -0.2, -0.1, 0.1, 0.2, 0.5].map(|k| k * f_min);
        let pa = [0.0, 5.0, 10.0, 15.0, 20.0, 25.0];
        let pb = [-25.0, -15.0, -5.0, 5.0, 15.0, 25.0];
        let (d, dd) = (d.clamp(0.0, 25.0), dd.clamp(-25.0, 25.0));
        let wa = pa.map(|p| mu(d, p, 0.2));
        let wb = pb.map(|p| mu(dd, p, 0.1));
        let f: f64 = wa.iter().zip(ca).map(|(w, c)| w * c).sum::<f64>() / wa.iter().sum::<f64>();
        let df: f64 = wb.iter().zip(cb).map(|(w, c)| w * c).sum::<f64>() / wb.iter().sum::<f64>();
        f + df
    }

    #[test]
    fn matches_the_f64_reference() {
        let g = FeedGenerator::new(limits(300, 1500), FeedRange::Paper).unwrap();
        let mut worst = 0.0f64;
        for i in 0..=60 {
            for j in -30..=30 {
                let (d, dd) = (i as f64 * 0.5, j as f64 * 1.0);
                let want = reference(300.0, 1500.0, d, dd);
                worst = worst.max((feed(&g, d, dd) - want).abs());
            }
        }
        // Q16.16 memberships and weights: within 0.5 mm/min of 1500.
        assert!(worst < 0.5, "largest difference {worst} mm/min");
    }
}
