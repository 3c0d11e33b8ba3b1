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

/// How far an arc may stray from a circle and still be read: LinuxCNC's
/// rules, the more permissive of the two peers'.
///
/// - LinuxCNC (`src/emc/rs274ngc/interp_arc.cc`, `Interp::arc_data_ijk`;
///   constants in `interp_internal.hh`): refused when the start and end
///   radii differ by more than 100 × `CENTER_ARC_RADIUS_TOLERANCE`, or by
///   more than that tolerance *and* more than `SPIRAL_RELATIVE_TOLERANCE`
///   (0.1 %) of the larger radius. The tolerance is 2·√2 units of the last
///   digit CAM systems commonly round to: 0.002828 in in G20, 0.02828 mm in
///   G21, so it follows the program's units. A radius (start or end) below
///   `RADIUS_TOLERANCE` (0.00005 in, 0.00127 mm) is a zero-radius arc, and an
///   R word may fall short of half the chord by that much
///   (`Interp::arc_data_r`).
/// - Grbl (`grbl/gcode.c`, `gc_execute_line`, the `[Arc definition error]`
///   checks): refused when the radii differ by more than 0.005 mm *and*
///   either more than 0.5 mm or more than 0.1 % of the start radius, in mm
///   whatever the program's units. Every arc Grbl reads, LinuxCNC reads.
///
/// Neither peer moves the centre: LinuxCNC plans the arc as a spiral whose
/// radius changes evenly with the angle from start to end
/// (`src/libposemath/_posemath.c`, `pmCircleInit`), Grbl keeps the start
/// radius and ends on the programmed point (`grbl/motion_control.c`,
/// `mc_arc`). We keep the centre and blend the radius as LinuxCNC does, so
/// the path ends exactly on the programmed point without a jump.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RadiusTolerance {
    /// Start and end radii may differ by this much, mm…
    pub spiral_abs_mm: f64,
    /// …or by this fraction of the larger radius, up to 100 × the absolute
    /// tolerance.
    pub spiral_rel: f64,
    /// Smallest radius; how far an R word may fall short of half the
    /// chord, mm.
    pub radius_mm: f64,
}

impl RadiusTolerance {
    /// For programs in mm (G21).
    pub const MM: RadiusTolerance = RadiusTolerance {
        spiral_abs_mm: 2.0 * 0.01 * std::f64::consts::SQRT_2,
        spiral_rel: 0.001,
        radius_mm: 0.00005 * 25.4,
    };
    /// For programs in inches (G20).
    pub const INCH: RadiusTolerance = RadiusTolerance {
        spiral_abs_mm: 2.0 * 0.001 * std::f64::consts::SQRT_2 * 25.4,
        spiral_rel: 0.001,
        radius_mm: 0.00005 * 25.4,
    };

    /// For programs whose unit is `mm_per_unit` mm.
    pub fn for_units(mm_per_unit: f64) -> Self {
        if mm_per_unit == 1.0 {
            Self::MM
        } else {
            Self::INCH
        }
    }

    /// Whether radii `r0` (start) and `r1` (end) are too far apart.
    pub fn refuses(&self, r0: f64, r1: f64) -> bool {
        let abs_err = (r0 - r1).abs();
        let rel_err = abs_err / r0.max(r1);
        abs_err > 100.0 * self.spiral_abs_mm
            || (rel_err > self.spiral_rel && abs_err > self.spiral_abs_mm)
    }
}

/// The centre of an arc in its plane's two coordinates (an R-format arc's
/// centre found from the chord: RS274/NGC's rule, positive R for the arc of
/// at most 180°; an R up to `r_tolerance_mm` short of half the chord is
/// taken as half the chord, as LinuxCNC's `Interp::arc_data_r` does).
pub fn centre_in_plane(
    start: [f64; 3],
    end: [f64; 3],
    centre: Centre,
    plane: Plane,
    clockwise: bool,
    r_tolerance_mm: f64,
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
            if half - r.abs() > r_tolerance_mm {
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
/// `max_points` points; refused if the end is too far off the start's
/// circle (`radii`).
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
    radii: RadiusTolerance,
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
    let (ca, cb) = centre_in_plane(start, end, centre, plane, clockwise, radii.radius_mm)?;
    let r0 = (sa - ca).hypot(sb - cb);
    let r1 = (ea - ca).hypot(eb - cb);
    if !(r0.is_finite() && r1.is_finite()) {
        bail!("arc radius is not finite");
    }
    if r0 < radii.radius_mm || r1 < radii.radius_mm {
        bail!("zero-radius arc: the centre is at its start or end point (radii {r0:.4} mm and {r1:.4} mm)");
    }
    if radii.refuses(r0, r1) {
        bail!(
            "arc radius differs at start ({} mm) and end ({} mm) by more than LinuxCNC allows ({:.4} mm, or 0.1 % of the radius up to {:.4} mm)",
            short(r0),
            short(r1),
            radii.spiral_abs_mm,
            100.0 * radii.spiral_abs_mm
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
            RadiusTolerance::MM,
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
            RadiusTolerance::MM,
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
            RadiusTolerance::MM,
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
            RadiusTolerance::MM,
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
            RadiusTolerance::MM,
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
            1_000_000,
            RadiusTolerance::MM
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
            RadiusTolerance::MM,
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
            RadiusTolerance::MM,
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
            RadiusTolerance::MM,
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
            1_000_000,
            RadiusTolerance::MM
        )
        .is_err());
    }

    #[test]
    fn huge_arcs_are_refused_before_allocating() {
        let s = [1e12, 0.0, 0.0];
        let c = Centre::Point([0.0; 3]);
        // Radius 1e12 mm within 1 µm: ~2.2e9 chords per turn.
        let e = points(
            s,
            s,
            c,
            Plane::Xy,
            false,
            0.0,
            0.001,
            50_000_000,
            RadiusTolerance::MM,
        )
        .unwrap_err();
        assert!(e.to_string().contains("max_points"), "{e}");
        // A million turns of a 10 mm circle, and a radius of 1e16 mm.
        let s = [10.0, 0.0, 0.0];
        assert!(points(
            s,
            s,
            c,
            Plane::Xy,
            false,
            999_999.0,
            0.001,
            50_000_000,
            RadiusTolerance::MM
        )
        .is_err());
        let s = [1e16, 0.0, 0.0];
        assert!(points(
            s,
            s,
            c,
            Plane::Xy,
            false,
            0.0,
            0.001,
            50_000_000,
            RadiusTolerance::MM
        )
        .is_err());
        // A tolerance far below the radius: refused, not a capacity overflow.
        let s = [10.0, 0.0, 0.0];
        assert!(points(
            s,
            s,
            c,
            Plane::Xy,
            false,
            0.0,
            1e-300,
            50_000_000,
            RadiusTolerance::MM
        )
        .is_err());
        assert!(points(
            s,
            s,
            c,
            Plane::Xy,
            false,
            0.0,
            0.0,
            50_000_000,
            RadiusTolerance::MM
        )
        .is_err());
        assert!(points(
            s,
            s,
            c,
            Plane::Xy,
            false,
            f64::INFINITY,
            0.001,
            50_000_000,
            RadiusTolerance::MM
        )
        .is_err());
        // Within the bound it works, and the count is what the formula says.
        let p = points(
            s,
            s,
            c,
            Plane::Xy,
            false,
            0.0,
            0.001,
            50_000_000,
            RadiusTolerance::MM,
        )
        .unwrap();
        let expected = (std::f64::consts::TAU / (4.0 * (0.001f64 / 20.0).sqrt().asin())).ceil();
        assert_eq!(p.len() as f64, expected);
    }

    fn read(src: &str) -> anyhow::Result<crate::toolpath::Toolpath> {
        crate::parse("t", src, &crate::GcodeSettings::default())
    }

    #[test]
    fn linuxcnc_radius_tolerance_at_its_limits() {
        // LinuxCNC's own good/bad pairs (tests/interp/{good,bad}/
        // *-arc.{small,medium,big}.{metric,imperial}.center-format.ngc):
        // the same arcs just inside and just past each of the three
        // regions of its rule, in mm and in inches.
        for (units, x, i_good, i_bad) in [
            // Absolute: radii 2·0.0099·√2 apart (good), 2·0.0101·√2 (bad).
            (
                "G21",
                "50",
                "[25 - [0.0099 * sqrt[2]]]",
                "[25 - [0.0101 * sqrt[2]]]",
            ),
            (
                "G20",
                "5",
                "[2.5 - [0.00099 * sqrt[2]]]",
                "[2.5 - [0.00101 * sqrt[2]]]",
            ),
            // Relative: 0.0999 % (good), 0.2996 % (bad).
            ("G21", "2000", "[0.9995 * 1000]", "[0.9985 * 1000]"),
            ("G20", "200", "[0.9995 * 100]", "[0.9985 * 100]"),
            // 100 × the absolute tolerance, whatever the relative error.
            (
                "G21",
                "6000",
                "[3000 + [100 * [0.0099 * sqrt[2]]]]",
                "[3000 + [100 * [0.0101 * sqrt[2]]]]",
            ),
            (
                "G20",
                "600",
                "[300 + [100 * [0.00099 * sqrt[2]]]]",
                "[300 + [100 * [0.00101 * sqrt[2]]]]",
            ),
        ] {
            let prog = |i: &str| format!("{units} F1\nG0 X0 Y0 Z0\nG2 X{x} I{i}\nM2\n");
            let t = read(&prog(i_good)).unwrap_or_else(|e| panic!("{units} X{x} I{i_good}: {e:#}"));
            // The centre is kept and the path ends on the programmed point.
            let mm = if units == "G20" { 25.4 } else { 1.0 };
            let end = *t.points.last().unwrap();
            assert!(
                (end[0] - x.parse::<f64>().unwrap() * mm).abs() < 1e-9,
                "{end:?}"
            );
            let e = read(&prog(i_bad)).unwrap_err();
            let e = format!("{e:#}");
            assert!(e.contains("line 3") && e.contains("radius differs"), "{e}");
        }
    }

    #[test]
    fn arcs_grbl_reads_are_read() {
        // Grbl (gc_execute_line): up to 0.005 mm apart at any radius, and
        // up to 0.1 % of the radius below 0.5 mm.
        assert!(read("G21 F1\nG0 X0 Y0\nG2 X2.004 I1\n").is_ok());
        assert!(read("G21 F1\nG0 X0 Y0\nG2 X1000 I499.8\n").is_ok());
        // An inch program rounded to 4 decimals (CAM posts): a 0.05 in
        // radius ending one digit off, 2.5 µm, more than the old 2 µm.
        assert!(read("G20 F1\nG0 X0 Y0\nG3 X0.1001 Y0 I0.05 J0\n").is_ok());
    }

    #[test]
    fn r_words_may_fall_short_of_half_the_chord_by_linuxcnc_s_radius_tolerance() {
        // RADIUS_TOLERANCE: 0.00127 mm in G21, 0.00005 in in G20.
        assert!(read("G21 F1\nG0 X0 Y0\nG2 X10 R4.9990\n").is_ok());
        assert!(read("G21 F1\nG0 X0 Y0\nG2 X10 R4.9985\n").is_err());
        assert!(read("G20 F1\nG0 X0 Y0\nG2 X1 R0.49996\n").is_ok());
        assert!(read("G20 F1\nG0 X0 Y0\nG2 X1 R0.49994\n").is_err());
    }
}
