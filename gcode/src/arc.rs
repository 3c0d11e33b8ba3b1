//! G2/G3 arcs (and helices) turned into points within a chord tolerance.
//!
//! An arc of radius `r` divided into chords of angle `θ` strays at most
//! `r·(1 − cos(θ/2))` from the arc; we take the largest `θ` with that ≤ `δ`
//! and split the sweep evenly, so every chord is within `δ` of the arc.
//! The number of chords is computed (in `f64`) and checked against a bound
//! before any point is allocated: a huge radius, a huge turn count or a tiny
//! tolerance is refused with an error, never attempted.

use std::f64::consts::TAU;

use anyhow::{bail, Result};

use crate::text::short;

/// Which plane an arc lies in: the indices of its first and second axis and
/// of the axis normal to it (G17: X Y, Z; G18: Z X, Y; G19: Y Z, X, so that
/// G2 is clockwise seen from the positive normal axis, as in RS274/NGC).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Plane {
    /// G17.
    Xy,
    /// G18.
    Zx,
    /// G19.
    Yz,
}

impl Plane {
    /// `(first, second, normal)` axis indices.
    pub fn axes(self) -> (usize, usize, usize) {
        match self {
            Plane::Xy => (0, 1, 2),
            Plane::Zx => (2, 0, 1),
            Plane::Yz => (1, 2, 0),
        }
    }
}

/// How the centre is given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Centre {
    /// Absolute centre, mm.
    Point([f64; 3]),
    /// Radius (R word), mm: positive for the arc of at most 180°, negative
    /// for the longer one.
    Radius(f64),
}

/// The centre of an arc in its plane's two coordinates (an R-format arc's
/// centre found from the chord: RS274/NGC's rule, positive R for the arc of
/// at most 180°).
pub fn centre_in_plane(
    start: [f64; 3],
    end: [f64; 3],
    centre: Centre,
    plane: Plane,
    clockwise: bool,
) -> Result<(f64, f64)> {
    let (a, b, _) = plane.axes();
    let (sa, sb, ea, eb) = (start[a], start[b], end[a], end[b]);
    Ok(match centre {
        Centre::Point(c) => (c[a], c[b]),
        Centre::Radius(r) => {
            let (dx, dy) = (ea - sa, eb - sb);
            let d = dx.hypot(dy);
            if d == 0.0 {
                bail!("an R-format arc cannot end where it starts");
            }
            let half = d / 2.0;
            if r.abs() < half * (1.0 - 1e-9) {
                bail!(
                    "arc radius {} mm is shorter than half the chord ({} mm)",
                    short(r.abs()),
                    short(half)
                );
            }
            let h = (r * r - half * half).max(0.0).sqrt();
            let (mx, my) = (sa + dx / 2.0, sb + dy / 2.0);
            // Left normal of the chord; CCW short arcs have their centre on
            // the left.
            let (nx, ny) = (-dy / d, dx / d);
            let side = if clockwise { -1.0 } else { 1.0 } * r.signum();
            (mx + side * h * nx, my + side * h * ny)
        }
    })
}

/// Points of the arc from `start` to `end` (excluding `start`, including
/// `end`), clockwise if `clockwise`, with `extra_turns` full turns added (P
/// word − 1), each chord within `tolerance_mm` of the arc; at most
/// `max_points` points.
#[allow(clippy::too_many_arguments)]
pub fn points(
    start: [f64; 3],
    end: [f64; 3],
    centre: Centre,
    plane: Plane,
    clockwise: bool,
    extra_turns: f64,
    tolerance_mm: f64,
    max_points: usize,
) -> Result<Vec<[f64; 3]>> {
    if !(extra_turns >= 0.0 && extra_turns.fract() == 0.0) {
        bail!(
            "arc turn count {} is not a whole number ≥ 1",
            short(extra_turns + 1.0)
        );
    }
    if !(tolerance_mm.is_finite() && tolerance_mm > 0.0) {
        bail!(
            "chord tolerance {} mm must be positive",
            short(tolerance_mm)
        );
    }
    let (a, b, n) = plane.axes();
    let (sa, sb, ea, eb) = (start[a], start[b], end[a], end[b]);
    let (ca, cb) = centre_in_plane(start, end, centre, plane, clockwise)?;
    let r0 = (sa - ca).hypot(sb - cb);
    let r1 = (ea - ca).hypot(eb - cb);
    if !(r0.is_finite() && r1.is_finite()) {
        bail!("arc radius is not finite");
    }
    if r0 == 0.0 {
        bail!("arc centre is at its start point");
    }
    if (r0 - r1).abs() > 0.002f64.max(1e-3 * r0) {
        bail!(
            "arc radius differs at start ({} mm) and end ({} mm)",
            short(r0),
            short(r1)
        );
    }
    let a0 = (sb - cb).atan2(sa - ca);
    let a1 = (eb - cb).atan2(ea - ca);
    let mut sweep = if clockwise { a0 - a1 } else { a1 - a0 };
    sweep = sweep.rem_euclid(TAU);
    if sweep < 1e-12 {
        sweep = TAU; // full circle
    }
    sweep += TAU * extra_turns;
    let r = 0.5 * (r0 + r1);
    // 1 − cos(θ/2) = δ/r, written as 2·asin(√(δ/2r)) = θ/2 so that a tiny δ/r
    // keeps its digits (1 − δ/r would round to 1).
    let max_step = if tolerance_mm >= r {
        std::f64::consts::PI / 2.0
    } else {
        (4.0 * (tolerance_mm / (2.0 * r)).sqrt().asin()).min(std::f64::consts::PI / 2.0)
    };
    let steps_f = (sweep / max_step).ceil().max(1.0);
    if steps_f.is_nan() || steps_f > max_points as f64 {
        bail!(
            "arc of radius {} mm sweeping {} turns needs {} points within the chord tolerance {} mm: more than gcode.limits.max_points allows here ({max_points})",
            short(r),
            short(sweep / TAU),
            if steps_f.is_finite() { short(steps_f.round()).to_string() } else { "unboundedly many".into() },
            short(tolerance_mm)
        );
    }
    let steps = steps_f as usize;
    let dir = if clockwise { -1.0 } else { 1.0 };
    let mut out = Vec::with_capacity(steps);
    for k in 1..=steps {
        let f = k as f64 / steps as f64;
        if k == steps {
            out.push(end);
            break;
        }
        let ang = a0 + dir * sweep * f;
        // Radius blends from start to end (they may differ slightly).
        let rr = r0 + (r1 - r0) * f;
        let mut p = [0.0; 3];
        p[a] = ca + rr * ang.cos();
        p[b] = cb + rr * ang.sin();
        p[n] = start[n] + (end[n] - start[n]) * f;
        out.push(p);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chord_error(c: [f64; 2], r: f64, p: &[[f64; 3]], start: [f64; 3]) -> f64 {
        let mut prev = start;
        let mut worst = 0.0f64;
        for q in p {
            let m = [(prev[0] + q[0]) / 2.0, (prev[1] + q[1]) / 2.0];
            worst = worst.max(r - (m[0] - c[0]).hypot(m[1] - c[1]));
            prev = *q;
        }
        worst
    }

    #[test]
    fn quarter_circle_within_tolerance_both_ways() {
        let (s, e) = ([10.0, 0.0, 0.0], [0.0, 10.0, 0.0]);
        let p = points(
            s,
            e,
            Centre::Point([0.0; 3]),
            Plane::Xy,
            false,
            0.0,
            0.001,
            1_000_000,
        )
        .unwrap();
        assert_eq!(*p.last().unwrap(), e);
        assert!(chord_error([0.0, 0.0], 10.0, &p, s) <= 0.001 + 1e-12);
        assert!(
            p.iter().all(|q| q[0] >= -1e-9 && q[1] >= -1e-9),
            "CCW: first quadrant"
        );
        // Clockwise the long way round: three quadrants.
        let cw = points(
            s,
            e,
            Centre::Point([0.0; 3]),
            Plane::Xy,
            true,
            0.0,
            0.001,
            1_000_000,
        )
        .unwrap();
        assert!((cw.len() as f64 / p.len() as f64 - 3.0).abs() < 0.1);
        assert!(cw.iter().any(|q| q[1] < -9.0));
    }

    #[test]
    fn r_format_picks_the_short_or_long_arc() {
        let (s, e) = ([0.0; 3], [10.0, 0.0, 0.0]);
        // G2 with R5 from (0,0) to (10,0): half circle, centre (5,0), above.
        let p = points(
            s,
            e,
            Centre::Radius(5.0),
            Plane::Xy,
            true,
            0.0,
            0.001,
            1_000_000,
        )
        .unwrap();
        assert!(p.iter().all(|q| q[1] >= -1e-9));
        let long = points(
            s,
            e,
            Centre::Radius(-6.0),
            Plane::Xy,
            true,
            0.0,
            0.001,
            1_000_000,
        )
        .unwrap();
        let short = points(
            s,
            e,
            Centre::Radius(6.0),
            Plane::Xy,
            true,
            0.0,
            0.001,
            1_000_000,
        )
        .unwrap();
        assert!(long.len() > 2 * short.len());
        assert!(points(
            s,
            e,
            Centre::Radius(4.0),
            Plane::Xy,
            true,
            0.0,
            0.001,
            1_000_000
        )
        .is_err());
    }

    #[test]
    fn full_circle_helix_and_other_planes() {
        let s = [10.0, 0.0, 0.0];
        let e = [10.0, 0.0, -2.0];
        let p = points(
            s,
            e,
            Centre::Point([0.0; 3]),
            Plane::Xy,
            false,
            1.0,
            0.01,
            1_000_000,
        )
        .unwrap();
        // Two turns descending 2 mm.
        assert!((p[p.len() / 2][2] + 1.0).abs() < 0.05);
        // G18 (Z X plane, right-handed Z, X, Y): G3 from +Z to +X around the
        // origin is a quarter, G2 the three other quarters.
        let q = points(
            [0.0, 0.0, 5.0],
            [5.0, 0.0, 0.0],
            Centre::Point([0.0; 3]),
            Plane::Zx,
            false,
            0.0,
            0.001,
            1_000_000,
        )
        .unwrap();
        assert!(q
            .iter()
            .all(|p| p[0] >= -1e-9 && p[2] >= -1e-9 && p[1] == 0.0));
        let long = points(
            [0.0, 0.0, 5.0],
            [5.0, 0.0, 0.0],
            Centre::Point([0.0; 3]),
            Plane::Zx,
            true,
            0.0,
            0.001,
            1_000_000,
        )
        .unwrap();
        assert!(long.iter().any(|p| p[2] < -4.9));
        assert!(points(
            s,
            [0.0, 12.0, 0.0],
            Centre::Point([0.0; 3]),
            Plane::Xy,
            false,
            0.0,
            0.01,
            1_000_000
        )
        .is_err());
    }

    #[test]
    fn huge_arcs_are_refused_before_allocating() {
        let s = [1e12, 0.0, 0.0];
        let c = Centre::Point([0.0; 3]);
        // Radius 1e12 mm within 1 µm: ~2.2e9 chords per turn.
        let e = points(s, s, c, Plane::Xy, false, 0.0, 0.001, 50_000_000).unwrap_err();
        assert!(e.to_string().contains("max_points"), "{e}");
        // A million turns of a 10 mm circle, and a radius of 1e16 mm.
        let s = [10.0, 0.0, 0.0];
        assert!(points(s, s, c, Plane::Xy, false, 999_999.0, 0.001, 50_000_000).is_err());
        let s = [1e16, 0.0, 0.0];
        assert!(points(s, s, c, Plane::Xy, false, 0.0, 0.001, 50_000_000).is_err());
        // A tolerance far below the radius: refused, not a capacity overflow.
        let s = [10.0, 0.0, 0.0];
        assert!(points(s, s, c, Plane::Xy, false, 0.0, 1e-300, 50_000_000).is_err());
        assert!(points(s, s, c, Plane::Xy, false, 0.0, 0.0, 50_000_000).is_err());
        assert!(points(s, s, c, Plane::Xy, false, f64::INFINITY, 0.001, 50_000_000).is_err());
        // Within the bound it works, and the count is what the formula says.
        let p = points(s, s, c, Plane::Xy, false, 0.0, 0.001, 50_000_000).unwrap();
        let expected = (std::f64::consts::TAU / (4.0 * (0.001f64 / 20.0).sqrt().asin())).ceil();
        assert_eq!(p.len() as f64, expected);
    }
}
