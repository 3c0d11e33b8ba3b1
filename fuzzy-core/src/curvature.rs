//! Curvature from three points (Lin, Lin & Wang 2021, section 2.6.1,
//! eq. 4-9).
//!
//! The paper fits the quadratic `x = a1 + a2 t + a3 t²`, `y = b1 + b2 t + b3 t²`
//! through `p(i-1)`, `p(i)`, `p(i+1)` at `t = -t_a, 0, t_b` (eq. 4-8, with the
//! chord lengths `t_a`, `t_b` of eq. 5) and evaluates its curvature at `p(i)`:
//! `κ = 2(a3·b2 − a2·b3) / (a2² + b2²)^(3/2)` (eq. 9).
//!
//! Solving eq. 7-8 in closed form with `u = p(i) − p(i-1)`, `v = p(i+1) − p(i)`
//! gives `a2 = (v·t_a² + u·t_b²)/D`, `a3 = (v·t_a − u·t_b)/D`,
//! `D = t_a·t_b·(t_a + t_b)`, and eq. 9 reduces to
//!
//! ```text
//! κ = 2·|u × v|·(t_a + t_b)² / (t_a · t_b · |p(i+1) − p(i-1)|³)
//! ```
//!
//! i.e. the circumscribed-circle curvature `2|u×v|/(t_a t_b |p(i+1)−p(i-1)|)`
//! times `((t_a+t_b)/|p(i+1)−p(i-1)|)²`. The same quadratic per axis gives the
//! 3-D form (`|u × v|` is the norm of the cross product); for planar paths it
//! is exactly eq. 9. Eq. 9 is signed; the scheduler uses the magnitude.
//!
//! # Numerics
//! `u`, `v` and `p(i+1) − p(i-1)` are exact integers (coordinates are
//! I32F32, so differences are exact). Each difference is scaled by a power of
//! two to 30 significant bits, so the cross and dot products are exact 64-bit
//! products; chords up to 0.25 mm (2^30 units of 2^-32 mm) are not shifted at
//! all. The few remaining products and two reciprocal square roots (one per
//! chord length, `|d| = |d|²/sqrt(|d|²)`, and `κ = num/sqrt(num·den)` for
//! `κ² = num/den`: no division) use a 32-bit-mantissa integer soft float
//! ([`crate::numerics::softfloat`]). For chords up to 0.25 mm only the soft
//! float's 32-bit rounding remains; longer chords lose the low bits of their small components, an absolute
//! error of about 2^-28/chord 1/mm, large relative only on nearly straight
//! triples. `tests/curvature_accuracy.rs` measures the error against the
//! f64 formula on the same points (README, "Measured"). Bit-identical on
//! every target.
//!
//! # Degenerate cases (the paper does not define them; chosen here)
//! - **Coincident points** (`t_a = 0` or `t_b = 0`): no quadratic exists;
//!   [`CurvatureError::CoincidentPoints`]. The [`crate::scheduler`] merges
//!   exact duplicates before they reach this function.
//! - **Collinear points**, same direction: `κ = 0` exactly.
//! - **Reversal** (the path doubles back: collinear, opposite directions, or
//!   `p(i+1) = p(i-1)`): a cusp that must be taken at standstill, so
//!   `κ = CurvaturePerMm::MAX`.
//! - **Turns sharper than 90°**: eq. 9 evaluates the parabola at `p(i)`, but
//!   with unequal chords the parabola bends hardest elsewhere and eq. 9 falls
//!   towards 0 as the turn approaches a reversal (e.g. 0.32 /mm for a 179°
//!   turn with 1 mm and 2 mm chords). For a turn angle `α > 90°` we use
//!   `max(κ_eq9, −cos α · 2·tan(α/2) / min(t_a, t_b))`: the second term is
//!   the curvature of the circle tangent to both segments within the shorter
//!   one, faded in from 0 at 90° so the result stays continuous, and
//!   reaching `MAX` at a reversal. Smooth paths sampled densely (all three
//!   test shapes of the paper) never turn by more than 90° per point, so for
//!   them this is exactly eq. 9.
//! - **First and last point of a path**: no three-point fit exists; the
//!   scheduler gives them the curvature of their only neighbour
//!   (one-sided estimate), see [`crate::scheduler`].

use crate::numerics::softfloat::Sf;
use crate::numerics::wide::sar_i64_low;
use crate::segment::{magnitude_bits, Scaled};
use crate::units::{CurvaturePerMm, Point3Mm};

/// Why a curvature could not be computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum CurvatureError {
    /// Two consecutive points are identical (`t_a = 0` or `t_b = 0`).
    CoincidentPoints,
}

impl core::fmt::Display for CurvatureError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            CurvatureError::CoincidentPoints => {
                f.write_str("coincident points: a chord has zero length")
            }
        }
    }
}

/// A chord `b − a` with its length, kept so that each chord is measured once
/// when points stream through the scheduler.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Chord {
    v: Scaled,
    /// Length for the curvature: `|d|² / sqrt(|d|²)`, to ~2^-29 relative.
    /// (The squared length is not kept: the scheduler copies a chord per
    /// point, and only [`Self::length_mm`] needs it.)
    len: Sf,
}

impl Chord {
    /// The chord from `a` to `b`; `None` when the points coincide.
    pub fn between(a: &Point3Mm, b: &Point3Mm) -> Option<Chord> {
        Self::from_diff(diff(b, a))
    }

    /// The chord between points the caller has checked to lie within
    /// ±2^62 raw units (±2^30 mm; the scheduler's limit is ±100 m), so the
    /// difference cannot overflow.
    pub(crate) fn between_in_range(a: &Point3Mm, b: &Point3Mm) -> Option<Chord> {
        Self::from_diff(diff_in_range(b, a))
    }

    fn from_diff(d: [i64; 3]) -> Option<Chord> {
        let v = Scaled::new(d)?;
        // |d| = |d|² / sqrt(|d|²): a reciprocal root, cheaper than a root
        // (`numerics` cost table).
        let sq = v.norm_sq();
        Some(Chord {
            len: sq.mul_inline(sq.rsqrt()?),
            v,
        })
    }

    /// Length in mm (saturating at the I32F32 maximum), from a correctly
    /// rounded square root (so a 5 mm chord is 5 mm to the last bit).
    pub fn length_mm(&self) -> fixed::types::I32F32 {
        fixed::types::I32F32::from_bits(self.v.norm_sq().sqrt().to_i64_scaled(0))
    }
}

/// `b − a` in raw units (saturating, so coordinates beyond ±2^31 mm cannot
/// wrap; the scheduler rejects anything beyond ±100 m first).
fn diff(b: &Point3Mm, a: &Point3Mm) -> [i64; 3] {
    let (b, a) = (b.to_bits(), a.to_bits());
    // Saturating through `checked_sub`: a subtract with flags on a 32-bit
    // core, shorter than `i64::saturating_sub` there.
    let sat = |x: i64, y: i64| {
        x.checked_sub(y)
            .unwrap_or(if x > y { i64::MAX } else { i64::MIN })
    };
    [sat(b[0], a[0]), sat(b[1], a[1]), sat(b[2], a[2])]
}

/// `b − a` for coordinates within ±2^62 raw units (no overflow possible).
#[inline(always)]
fn diff_in_range(b: &Point3Mm, a: &Point3Mm) -> [i64; 3] {
    let (b, a) = (b.to_bits(), a.to_bits());
    [
        b[0].wrapping_sub(a[0]),
        b[1].wrapping_sub(a[1]),
        b[2].wrapping_sub(a[2]),
    ]
}

/// `(x >> s)²` for `|x >> s| < 2^31`.
#[inline(always)]
fn square_shifted(x: i64, s: u32) -> u64 {
    let v = sar_i64_low(x, s).unsigned_abs() as u64;
    v * v
}

/// Squared norm of a vector of `i64` (the cross product).
fn norm_sq_i64(c: [i64; 3]) -> Sf {
    let m = magnitude_bits(&c);
    if m == 0 {
        return Sf::ZERO;
    }
    // Scale so every component fits 31 bits: squares sum below 2^64.
    let shift = (64 - m.leading_zeros() as i32 - 31).max(0);
    let s = shift as u32;
    let q = square_shifted(c[0], s) + square_shifted(c[1], s) + square_shifted(c[2], s);
    Sf::from_u64_inline(q).scale2(2 * shift)
}

/// Magnitude of the curvature at `p2` of the path `p1 → p2 → p3`, in 1/mm
/// (eq. 4-9; degenerate cases as described in the module docs).
pub fn curvature(
    p1: &Point3Mm,
    p2: &Point3Mm,
    p3: &Point3Mm,
) -> Result<CurvaturePerMm, CurvatureError> {
    let a = Chord::between(p1, p2).ok_or(CurvatureError::CoincidentPoints)?;
    let b = Chord::between(p2, p3).ok_or(CurvatureError::CoincidentPoints)?;
    Ok(curvature_of_chords(&a, &b, diff(p3, p1)))
}

/// Curvature at the joint of `incoming = p2 − p1` and `outgoing = p3 − p2`,
/// given `span = p3 − p1` in raw units.
pub(crate) fn curvature_of_chords(
    incoming: &Chord,
    outgoing: &Chord,
    span: [i64; 3],
) -> CurvaturePerMm {
    let (u, v) = (&incoming.v, &outgoing.v);
    let (ta, tb) = (incoming.len, outgoing.len);
    let cross = [
        u.n[1] as i64 * v.n[2] as i64 - u.n[2] as i64 * v.n[1] as i64,
        u.n[2] as i64 * v.n[0] as i64 - u.n[0] as i64 * v.n[2] as i64,
        u.n[0] as i64 * v.n[1] as i64 - u.n[1] as i64 * v.n[0] as i64,
    ];
    let dot: i64 = u.n[0] as i64 * v.n[0] as i64
        + u.n[1] as i64 * v.n[1] as i64
        + u.n[2] as i64 * v.n[2] as i64;
    let pair_shift = u.shift + v.shift;
    let cross_sq = norm_sq_i64(cross).scale2(2 * pair_shift);
    if cross_sq.is_zero() {
        // Collinear: straight on, or a reversal (cusp).
        return if dot > 0 {
            CurvaturePerMm::ZERO
        } else {
            CurvaturePerMm::MAX
        };
    }
    let c13_sq = match Scaled::new(span) {
        Some(w) => w.norm_sq(),
        None => return CurvaturePerMm::MAX, // back to the start point: reversal
    };
    // Work on κ²: squared norms need no square root, so the only roots are
    // the new chord's length and the final one (both reciprocal roots).
    let span = ta.add_inline(tb);
    let span_sq = span.mul_inline(span);
    let ta_tb = ta.mul_inline(tb);
    let ta_tb_sq = ta_tb.mul_inline(ta_tb);
    // Eq. 9 in closed form, squared: 4|u×v|²(ta+tb)⁴ / (ta² tb² |p3−p1|⁶).
    let num = cross_sq.mul_inline(span_sq).mul_inline(span_sq).scale2(2);
    let den = ta_tb_sq
        .mul_inline(c13_sq)
        .mul_inline(c13_sq)
        .mul_inline(c13_sq);
    // κ = sqrt(num/den) = num / sqrt(num·den): one reciprocal square root
    // and no division (den = 0 only by exponent underflow: a cusp).
    let Some(r) = num.mul_inline(den).rsqrt() else {
        return CurvaturePerMm::MAX;
    };
    let mut k = num.mul_inline(r);
    if dot < 0 {
        // Turn sharper than 90°: −cos α · 2 tan(α/2) / min(ta, tb)
        //   = 2|dot|(ta tb + |dot|) / (ta tb |u×v| min(ta, tb)), squared.
        let abs_dot = Sf::from_u64(dot.unsigned_abs()).scale2(pair_shift);
        let t = ta_tb.add(abs_dot);
        let m = ta.min(tb);
        let corner_num = abs_dot.mul(abs_dot).mul(t).mul(t).scale2(2);
        let corner_den = ta_tb_sq.mul(cross_sq).mul(m).mul(m);
        match corner_num.mul(corner_den).rsqrt() {
            Some(r) => k = k.max(corner_num.mul(r)),
            None => return CurvaturePerMm::MAX,
        }
    }
    // κ is in 1/raw unit; 1/mm = 2^32 · (1/raw), and I32F32 holds 2^32 · value.
    CurvaturePerMm(fixed::types::I32F32::from_bits(k.to_i64_scaled(64)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(x: f64, y: f64, z: f64) -> Point3Mm {
        Point3Mm::from_f64(x, y, z).unwrap()
    }

    fn on_circle(r: f64, angle: f64) -> Point3Mm {
        p(r * angle.cos(), r * angle.sin(), 0.0)
    }

    #[test]
    fn circle_gives_reciprocal_radius() {
        // Equal chords subtending h on a circle: eq. 9 = (1/R) / cos²(h/2).
        // (Sagittas stay >= 30 nm here so the 2^-32 mm input grid is
        // negligible; `tests/curvature_accuracy.rs` covers fine spacing.)
        for r in [0.1, 1.0, 10.0, 100.0, 5000.0] {
            let h: f64 = 0.05;
            let k = curvature(&on_circle(r, -h), &on_circle(r, 0.0), &on_circle(r, h))
                .unwrap()
                .to_f64();
            let want = 1.0 / (r * (h / 2.0).cos().powi(2));
            assert!(
                (k / want - 1.0).abs() < 2e-5,
                "r = {r}: κ = {k}, want {want}"
            );
        }
    }

    #[test]
    fn collinear_is_zero_and_reversal_is_max() {
        let (a, b, c) = (p(0.0, 0.0, 0.0), p(1.0, 1.0, 1.0), p(3.0, 3.0, 3.0));
        assert_eq!(curvature(&a, &b, &c).unwrap(), CurvaturePerMm::ZERO);
        // Back along the same line, shorter, equal and longer return chords.
        for back in [0.5, 1.0, 2.0] {
            let d = p(1.0 - back, 1.0 - back, 1.0 - back);
            assert_eq!(
                curvature(&a, &b, &d).unwrap(),
                CurvaturePerMm::MAX,
                "back = {back}"
            );
        }
    }

    #[test]
    fn coincident_points_are_an_error() {
        let (a, b) = (p(0.0, 0.0, 0.0), p(1.0, 0.0, 0.0));
        assert_eq!(curvature(&a, &a, &b), Err(CurvatureError::CoincidentPoints));
        assert_eq!(curvature(&a, &b, &b), Err(CurvatureError::CoincidentPoints));
    }

    #[test]
    fn sharp_turns_grow_monotonically_to_a_reversal() {
        // Unequal chords (1 mm in, 2 mm out): eq. 9 alone would fall to 0.
        let (a, b) = (p(-1.0, 0.0, 0.0), p(0.0, 0.0, 0.0));
        let mut last = 0.0;
        for deg in (0..=180).step_by(5) {
            let t = (deg as f64).to_radians();
            let c = p(2.0 * t.cos(), 2.0 * t.sin(), 0.0);
            let k = curvature(&a, &b, &c).unwrap().to_f64();
            assert!(k >= last * 0.999, "turn {}°: κ {k} after {last}", 180 - deg);
            last = k;
        }
        // ... and the exact reversal saturates.
        assert_eq!(last, CurvaturePerMm::MAX.to_f64());
    }

    #[test]
    fn planar_result_matches_eq9_in_3d_rotation() {
        // Rotating a planar triple into 3-D leaves |κ| unchanged.
        let pts = [(0.0, 0.0), (1.0, 0.2), (2.1, 0.1)];
        let flat: Vec<_> = pts.iter().map(|&(x, y)| p(x, y, 0.0)).collect();
        let (c, s) = (0.6f64, 0.8f64);
        let tilted: Vec<_> = pts.iter().map(|&(x, y)| p(x, y * c, y * s)).collect();
        let k1 = curvature(&flat[0], &flat[1], &flat[2]).unwrap().to_f64();
        let k2 = curvature(&tilted[0], &tilted[1], &tilted[2])
            .unwrap()
            .to_f64();
        assert!((k1 - k2).abs() / k1 < 1e-7, "{k1} vs {k2}");
    }

    #[test]
    fn huge_coordinates_do_not_overflow() {
        let big = 2_000_000_000.0; // beyond the scheduler's limit, still no panic
        let k = curvature(&p(-big, -big, big), &p(big, big, -big), &p(-big, big, -big)).unwrap();
        assert!(k.to_f64() > 0.0);
    }
}
