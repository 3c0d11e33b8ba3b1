//! The geometry of a straight move between two points, shared by the
//! scheduler's curvature and the planner: [`Scaled`], the exact difference
//! vector scaled by a power of two to 30 significant bits (the curvature's
//! [`crate::curvature::Chord`] is built on it), and [`Segment`], its unit
//! direction and length (the planner's lookahead and executor).
//!
//! Invariants: `Scaled` keeps the difference's top bit on bit 29 (exact for
//! moves up to 0.25 mm, the low bits of the small components dropped
//! beyond); a `Segment`'s `dir` is a unit vector in Q30 (each component
//! within `±2^30`) and `len > 0` in Q32 mm, both a function of the two end
//! points only (the soft float's operations are exact in the power-of-two
//! scale, so the scaling does not change them); the planner's arc lengths
//! are running sums of `len`, and its executor places the tool at
//! `start + dir·offset` along the same segment, so both planner stages see
//! one direction and one length per move.

use crate::numerics::softfloat::Sf;
use crate::numerics::wide::sar_i64_low;
use crate::units::Point3Mm;

/// A difference vector scaled by a power of two so that its largest
/// component is in `[2^29, 2^30)`: `real (raw I32F32 units) = n · 2^shift`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Scaled {
    pub(crate) n: [i32; 3],
    pub(crate) shift: i32,
}

impl Scaled {
    /// `None` for the zero vector. (Inlined: it runs twice per point, and
    /// the `Option` then folds away.)
    #[inline(always)]
    pub(crate) fn new(d: [i64; 3]) -> Option<Scaled> {
        let m = magnitude_bits(&d);
        if m == 0 {
            return None;
        }
        // The top bit lands on bit 29. 32-bit shifts only (`numerics::wide`):
        // below 2^30 every component already fits an i32.
        let shift = 64 - m.leading_zeros() as i32 - 30;
        let n = if shift <= 0 {
            let l = (-shift) as u32;
            [(d[0] as i32) << l, (d[1] as i32) << l, (d[2] as i32) << l]
        } else {
            let r = shift as u32;
            [
                sar_i64_low(d[0], r),
                sar_i64_low(d[1], r),
                sar_i64_low(d[2], r),
            ]
        };
        Some(Scaled { n, shift })
    }

    /// Squared length in raw units².
    #[inline(always)]
    pub(crate) fn norm_sq(&self) -> Sf {
        let q: u64 = self.n.iter().map(|&c| (c as i64 * c as i64) as u64).sum();
        Sf::from_u64_inline(q).scale2(2 * self.shift)
    }
}

/// The components' magnitudes OR-ed together: 0 for the zero vector, and
/// the same leading zeros as the largest magnitude (all the callers need),
/// with fewer operations than the maximum.
#[inline(always)]
pub(crate) fn magnitude_bits(c: &[i64; 3]) -> u64 {
    c[0].unsigned_abs() | c[1].unsigned_abs() | c[2].unsigned_abs()
}

/// A straight move from one point to the next: unit direction and length.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Segment {
    /// Unit direction, Q30.
    pub(crate) dir: [i32; 3],
    /// Length, Q32 mm.
    pub(crate) len: i64,
}

impl Segment {
    /// The move from `a` to `b` (the difference saturates); `None` when the
    /// points coincide.
    pub(crate) fn between(a: Point3Mm, b: Point3Mm) -> Option<Segment> {
        Self::between_bits(a.to_bits(), b.to_bits())
    }

    /// [`Self::between`] on raw coordinates (units of 2^-32 mm).
    pub(crate) fn between_bits(a: [i64; 3], b: [i64; 3]) -> Option<Segment> {
        Self::of_diff(zip3(b, a, i64::saturating_sub))
    }

    /// Unit vector and length of a raw I32F32 difference; `None` for zero.
    fn of_diff(d: [i64; 3]) -> Option<Segment> {
        let Scaled { n, shift } = Scaled::new(d)?;
        // Length via the soft float, in the scaled units first.
        let sq: u64 = n.iter().map(|&c| (c as i64 * c as i64) as u64).sum();
        let len_scaled = Sf::from_u64(sq).sqrt();
        let len = len_scaled.scale2(shift).to_i64_scaled(0);
        let dir = n.map(|c| {
            let q = Sf::from_u64(u64::from(c.unsigned_abs()))
                .div(len_scaled)
                .map_or(0, |q| q.to_i64_scaled(30).min(1 << 30));
            (if c < 0 { -q } else { q }) as i32
        });
        Some(Segment { dir, len })
    }

    /// The point `offset` (Q32 mm) along the move from `start`.
    pub(crate) fn point_at(&self, start: [i64; 3], offset: i64) -> Point3Mm {
        let [x, y, z] = zip3(start, self.dir, |p, d| {
            p.saturating_add(((d as i128 * offset as i128) >> 30) as i64)
        });
        Point3Mm::from_bits(x, y, z)
    }
}

/// `[f(a0, b0), f(a1, b1), f(a2, b2)]`, without indexing (no bounds checks
/// left for the panic-free link check).
#[inline]
pub(crate) fn zip3<A: Copy, B: Copy, C>(
    a: [A; 3],
    b: [B; 3],
    mut f: impl FnMut(A, B) -> C,
) -> [C; 3] {
    let [a0, a1, a2] = a;
    let [b0, b1, b2] = b;
    [f(a0, b0), f(a1, b1), f(a2, b2)]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(x: f64, y: f64, z: f64) -> Point3Mm {
        Point3Mm::from_f64(x, y, z).unwrap()
    }

    #[test]
    fn length_and_direction_of_a_3_4_5_move() {
        let s = Segment::between(at(1.0, 1.0, 0.0), at(4.0, 5.0, 0.0)).unwrap();
        assert_eq!(s.len, 5 << 32);
        let q30 = (1u64 << 30) as f64;
        assert!((s.dir[0] as f64 / q30 - 0.6).abs() < 1e-9);
        assert!((s.dir[1] as f64 / q30 - 0.8).abs() < 1e-9);
        assert_eq!(s.dir[2], 0);
        // Placing the tool at the full length lands on the end point.
        let end = s.point_at(at(1.0, 1.0, 0.0).to_bits(), s.len).to_f64();
        assert!((end[0] - 4.0).abs() < 1e-8 && (end[1] - 5.0).abs() < 1e-8);
    }

    #[test]
    fn coincident_points_have_no_segment() {
        assert!(Segment::between(at(2.0, 3.0, 4.0), at(2.0, 3.0, 4.0)).is_none());
    }

    proptest::proptest! {
        /// The direction is a unit vector to the soft float's rounding and
        /// the length matches the f64 norm, at every scale of move.
        #[test]
        fn unit_direction_and_length_match_f64(
            d in proptest::prelude::any::<[i32; 3]>(),
            scale in 0u32..30,
        ) {
            let bits = d.map(|c| (c as i64) << scale);
            let b = Point3Mm::from_bits(bits[0], bits[1], bits[2]);
            let Some(s) = Segment::between(Point3Mm::ORIGIN, b) else {
                proptest::prop_assert_eq!(bits, [0; 3]);
                return Ok(());
            };
            let f = bits.map(|c| c as f64);
            let norm = (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt();
            proptest::prop_assert!((s.len as f64 - norm).abs() <= 1e-6 * norm + 1.0);
            for (&c, &u) in f.iter().zip(s.dir.iter()) {
                proptest::prop_assert!((u as f64 / (1u64 << 30) as f64 - c / norm).abs() < 1e-6);
            }
        }
    }
}
