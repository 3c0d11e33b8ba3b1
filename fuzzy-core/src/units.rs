//! Quantities and their units: positions in mm, curvature in 1/mm, feed in
//! mm/min, fuzzy values in Q16.16.
//!
//! One format per quantity:
//! - position: [`I32F32`] mm (resolution 2^-32 mm ≈ 0.23 pm, range ±2^31 mm).
//!   Chords down to 1 µm keep 22 significant bits and 10 m coordinates keep
//!   their full resolution, so differences of neighbouring points are exact;
//! - curvature: [`CurvaturePerMm`], [`I32F32`] 1/mm (saturates at 2^31 /mm);
//! - feed: [`FeedMmPerMin`], [`I32F32`] mm/min;
//! - the planner's tangential speed and acceleration per interpolation tick:
//!   [`SpeedMmPerTick`], [`AccelMmPerTick2`], [`I32F32`] mm/tick and
//!   mm/tick² (integrating a tick needs no multiplication by the period);
//! - fuzzy inputs, outputs and membership parameters: [`Fx`] (Q16.16).

use fixed::types::{I16F16, I32F32};

/// Q16.16 fixed point: the fuzzy engine's number (inputs, outputs,
/// membership-function parameters, degrees of membership in `[0, 1]`).
pub type Fx = I16F16;

/// Largest coordinate magnitude the scheduler accepts, in mm (100 m: more
/// than any machine tool's travel, and small enough that differences of two
/// coordinates always fit the arithmetic of [`crate::curvature`]).
pub const COORD_LIMIT_MM: i32 = 100_000;

/// Largest feed the scheduler accepts, in mm/min (1 km/min: above any
/// machine's rapid traverse; bounds the running sums of the average filter).
pub const FEED_LIMIT_MM_PER_MIN: i32 = 1_000_000;

/// A tool position in mm (machine or part coordinates).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Point3Mm {
    /// X in mm.
    pub x: I32F32,
    /// Y in mm.
    pub y: I32F32,
    /// Z in mm.
    pub z: I32F32,
}

impl Point3Mm {
    /// The origin.
    pub const ORIGIN: Point3Mm = Point3Mm {
        x: I32F32::ZERO,
        y: I32F32::ZERO,
        z: I32F32::ZERO,
    };

    /// A point from its raw I32F32 bits (units of 2^-32 mm).
    pub const fn from_bits(x: i64, y: i64, z: i64) -> Self {
        Point3Mm {
            x: I32F32::from_bits(x),
            y: I32F32::from_bits(y),
            z: I32F32::from_bits(z),
        }
    }

    /// A point from mm given as `f64`, rounded to the nearest 2^-32 mm.
    /// `None` for NaN or values outside the I32F32 range.
    pub fn from_f64(x: f64, y: f64, z: f64) -> Option<Self> {
        Some(Point3Mm {
            x: I32F32::checked_from_num(x)?,
            y: I32F32::checked_from_num(y)?,
            z: I32F32::checked_from_num(z)?,
        })
    }

    /// The coordinates in mm as `f64` (exact: 64-bit fixed fits f64's 53
    /// bits for coordinates below 2^21 mm, and rounds beyond).
    pub fn to_f64(self) -> [f64; 3] {
        [self.x.to_num(), self.y.to_num(), self.z.to_num()]
    }

    /// Raw bits `[x, y, z]`.
    pub const fn to_bits(self) -> [i64; 3] {
        [self.x.to_bits(), self.y.to_bits(), self.z.to_bits()]
    }

    /// Whether every coordinate is within ±[`COORD_LIMIT_MM`].
    #[inline(always)]
    pub fn within_limits(self) -> bool {
        // |c| <= lim as one unsigned comparison: c + lim in [0, 2·lim].
        const LIM: u64 = (COORD_LIMIT_MM as u64) << 32;
        let ok = |c: I32F32| (c.to_bits() as u64).wrapping_add(LIM) <= 2 * LIM;
        ok(self.x) & ok(self.y) & ok(self.z)
    }
}

/// Curvature in 1/mm (the reciprocal of the radius), `I32F32`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct CurvaturePerMm(pub I32F32);

impl CurvaturePerMm {
    /// A straight line.
    pub const ZERO: CurvaturePerMm = CurvaturePerMm(I32F32::ZERO);
    /// The saturation value (2^31 1/mm), used for cusps and reversals.
    pub const MAX: CurvaturePerMm = CurvaturePerMm(I32F32::MAX);

    /// From 1/mm as `f64` (saturating; NaN gives zero).
    pub fn from_f64(v: f64) -> Self {
        if v.is_nan() {
            return Self::ZERO;
        }
        CurvaturePerMm(I32F32::saturating_from_num(v))
    }

    /// The value in 1/mm as `f64`.
    pub fn to_f64(self) -> f64 {
        self.0.to_num()
    }
}

/// Feed (tangential tool speed) in mm/min, `I32F32`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct FeedMmPerMin(pub I32F32);

impl FeedMmPerMin {
    /// Standstill.
    pub const ZERO: FeedMmPerMin = FeedMmPerMin(I32F32::ZERO);

    /// From a whole number of mm/min.
    pub const fn from_int(v: i32) -> Self {
        FeedMmPerMin(I32F32::from_bits((v as i64) << 32))
    }

    /// From mm/min as `f64` (saturating; NaN gives zero).
    pub fn from_f64(v: f64) -> Self {
        if v.is_nan() {
            return Self::ZERO;
        }
        FeedMmPerMin(I32F32::saturating_from_num(v))
    }

    /// The value in mm/min as `f64`.
    pub fn to_f64(self) -> f64 {
        self.0.to_num()
    }

    /// Whether `0 <= self <= FEED_LIMIT_MM_PER_MIN`.
    pub fn within_limits(self) -> bool {
        self.0 >= 0 && self.0 <= I32F32::from_num(FEED_LIMIT_MM_PER_MIN)
    }
}

/// Tangential speed in mm per interpolation tick, `I32F32`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct SpeedMmPerTick(pub I32F32);

impl SpeedMmPerTick {
    /// Standstill.
    pub const ZERO: SpeedMmPerTick = SpeedMmPerTick(I32F32::ZERO);

    /// From raw I32F32 bits (units of 2^-32 mm/tick).
    pub const fn from_bits(bits: i64) -> Self {
        SpeedMmPerTick(I32F32::from_bits(bits))
    }

    /// Raw I32F32 bits.
    pub const fn to_bits(self) -> i64 {
        self.0.to_bits()
    }

    /// The value in mm/s for a tick of `tick_s` seconds.
    pub fn to_mm_per_s_f64(self, tick_s: f64) -> f64 {
        self.0.to_num::<f64>() / tick_s
    }
}

/// Tangential acceleration in mm per interpolation tick², `I32F32`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct AccelMmPerTick2(pub I32F32);

impl AccelMmPerTick2 {
    /// None.
    pub const ZERO: AccelMmPerTick2 = AccelMmPerTick2(I32F32::ZERO);

    /// From raw I32F32 bits (units of 2^-32 mm/tick²).
    pub const fn from_bits(bits: i64) -> Self {
        AccelMmPerTick2(I32F32::from_bits(bits))
    }

    /// Raw I32F32 bits.
    pub const fn to_bits(self) -> i64 {
        self.0.to_bits()
    }

    /// The value in mm/s² for a tick of `tick_s` seconds.
    pub fn to_mm_per_s2_f64(self, tick_s: f64) -> f64 {
        self.0.to_num::<f64>() / (tick_s * tick_s)
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for Point3Mm {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(
            f,
            "({=f32}, {=f32}, {=f32}) mm",
            self.x.to_num::<f32>(),
            self.y.to_num::<f32>(),
            self.z.to_num::<f32>()
        )
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for CurvaturePerMm {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(f, "{=f32} /mm", self.0.to_num::<f32>())
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for SpeedMmPerTick {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(f, "{=f32} mm/tick", self.0.to_num::<f32>())
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for AccelMmPerTick2 {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(f, "{=f32} mm/tick²", self.0.to_num::<f32>())
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for FeedMmPerMin {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(f, "{=f32} mm/min", self.0.to_num::<f32>())
    }
}

/// Saturating conversion of a curvature to the fuzzy engine's Q16.16
/// (curvatures above 32767 /mm saturate; the controller clips at a few /mm).
pub fn curvature_to_fx(k: CurvaturePerMm) -> Fx {
    let bits = k.0.to_bits();
    // In range when bits 47..63 are all equal (one 32-bit test of the high
    // word instead of two 64-bit comparisons).
    let hi = (bits >> 32) as i32;
    if hi >> 15 == hi >> 31 {
        Fx::from_bits((bits >> 16) as i32)
    } else if bits < 0 {
        Fx::MIN
    } else {
        Fx::MAX
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn point_limits_and_conversion() {
        let p = Point3Mm::from_f64(10_000.0, -10_000.0, 0.001).unwrap();
        assert!(p.within_limits());
        assert_eq!(p.to_f64()[0], 10_000.0);
        assert!(Point3Mm::from_f64(f64::NAN, 0.0, 0.0).is_none());
        assert!(Point3Mm::from_f64(1e12, 0.0, 0.0).is_none());
        assert!(!Point3Mm::from_f64(100_001.0, 0.0, 0.0)
            .unwrap()
            .within_limits());
    }

    #[test]
    fn curvature_fx_saturates() {
        assert_eq!(curvature_to_fx(CurvaturePerMm::MAX), Fx::MAX);
        assert_eq!(
            curvature_to_fx(CurvaturePerMm::from_f64(0.5)),
            Fx::from_num(0.5)
        );
    }

    proptest::proptest! {
        /// The branch-light forms agree with the plain definitions.
        #[test]
        fn limit_and_conversion_tricks_match_definitions(
            bits in proptest::prelude::any::<[i64; 3]>(),
            edge in -2i64..=2,
            which in 0usize..3,
        ) {
            let lim = (COORD_LIMIT_MM as i64) << 32;
            let mut b = bits;
            // Half the cases right at the limits.
            if edge != 0 {
                b[which] = edge.signum() * lim + (edge - edge.signum());
            }
            let p = Point3Mm::from_bits(b[0], b[1], b[2]);
            let want = b.iter().all(|&c| (-lim..=lim).contains(&c));
            proptest::prop_assert_eq!(p.within_limits(), want);
            for &k in &b {
                let want = (k >> 16).clamp(i32::MIN as i64, i32::MAX as i64) as i32;
                let got = curvature_to_fx(CurvaturePerMm(I32F32::from_bits(k))).to_bits();
                proptest::prop_assert_eq!(got, want);
                let k = k >> (k as u32 % 40);
                let want = (k >> 16).clamp(i32::MIN as i64, i32::MAX as i64) as i32;
                let got = curvature_to_fx(CurvaturePerMm(I32F32::from_bits(k))).to_bits();
                proptest::prop_assert_eq!(got, want);
            }
        }
    }

    #[test]
    fn per_tick_units_convert_to_seconds() {
        // 1 µm per 1 ms tick is 1 mm/s; 1 nm per tick² at 1 ms is 1 mm/s².
        let v = SpeedMmPerTick(I32F32::from_num(0.001));
        assert!((v.to_mm_per_s_f64(1e-3) - 1.0).abs() < 1e-6);
        let a = AccelMmPerTick2(I32F32::from_num(1e-6));
        assert!((a.to_mm_per_s2_f64(1e-3) - 1.0).abs() < 1e-3);
        assert_eq!(SpeedMmPerTick::from_bits(7).to_bits(), 7);
        assert_eq!(AccelMmPerTick2::from_bits(-7).to_bits(), -7);
    }

    #[test]
    fn feed_limits() {
        assert!(FeedMmPerMin::from_int(5000).within_limits());
        assert!(!FeedMmPerMin::from_int(-1).within_limits());
        assert!(!FeedMmPerMin::from_int(FEED_LIMIT_MM_PER_MIN + 1).within_limits());
        assert_eq!(FeedMmPerMin::from_f64(f64::NAN), FeedMmPerMin::ZERO);
    }
}
