//! Cutter radius compensation (G41 left, G42 right of the programmed path,
//! XY plane) with a look-ahead of one move, as LinuxCNC does it
//! (`interp_convert.cc`: `convert_straight_comp1`, `convert_straight_comp2`,
//! `convert_arc_comp2`; `interp_queue.cc`: `move_endpoint_and_flush`):
//!
//! 1. **Entry** (the first move after G41/G42, straight): the tool goes from
//!    where it is to the programmed end point moved by the radius along the
//!    move's normal on the compensation side. A move shorter than the radius
//!    is an error, as in LinuxCNC. An arc as the entry move is refused.
//! 2. **Offset moves**: a line is moved by the radius along its normal; an
//!    arc keeps its centre and its radius grows or shrinks by the tool radius
//!    (shrinking to zero or below is an error: the tool does not fit).
//! 3. **Corners** between consecutive offset moves: on the outside of the
//!    turn the tool rolls around the programmed corner on an arc of the tool
//!    radius; on the inside both moves are cut back to where their offsets
//!    meet (the intersection nearest the programmed corner). An inside corner
//!    whose offsets meet before the start of the earlier move or after the
//!    end of the later one would gouge: an error naming the line. Tangent
//!    joins need neither.
//! 4. Moves along Z only do not change direction: they run at the end of the
//!    offset move before them, after its end is settled.
//! 5. **Exit** (G40): the pending move ends at its offset point and the next
//!    move goes straight from there to its programmed end.
//!
//! Ambiguities and choices: LinuxCNC's interpreter also accepts an arc entry
//! move and compensation in the XZ plane (lathes); neither is done here. The
//! corner arc's feed is the feed of the move after it.

use anyhow::{bail, Result};

use super::arc::{centre_in_plane, Centre, Plane};
use super::sink::Sink;
use super::text::short;

/// Compensation side.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// G41: the tool left of the path.
    Left,
    /// G42: right.
    Right,
}

#[derive(Clone, Copy, Debug)]
enum Geo {
    Line,
    /// Centre and direction (the radius follows from the end points).
    Arc {
        c: [f64; 2],
        cw: bool,
        turns: f64,
    },
}

/// An offset move not yet emitted: its start may still be cut back (when it
/// is the later move of an inside corner) and so may its end.
#[derive(Clone, Copy, Debug)]
struct Elem {
    from: [f64; 3],
    to: [f64; 3],
    geo: Geo,
    cap: f64,
    line: u32,
    /// Programmed end point.
    prog_to: [f64; 3],
}

impl Elem {
    /// Unit tangent at the start (`at_end = false`) or the end.
    fn tangent(&self, at_end: bool) -> [f64; 2] {
        match self.geo {
            Geo::Line => unit([self.to[0] - self.from[0], self.to[1] - self.from[1]]),
            Geo::Arc { c, cw, .. } => {
                let p = if at_end { self.to } else { self.from };
                let r = [p[0] - c[0], p[1] - c[1]];
                // CCW tangent is the radius turned left.
                let t = unit([-r[1], r[0]]);
                if cw {
                    [-t[0], -t[1]]
                } else {
                    t
                }
            }
        }
    }
}

fn unit(v: [f64; 2]) -> [f64; 2] {
    let n = v[0].hypot(v[1]);
    if n == 0.0 {
        [0.0, 0.0]
    } else {
        [v[0] / n, v[1] / n]
    }
}

fn cross(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// The compensation state.
#[derive(Debug, Default)]
pub struct Comp {
    side: Option<Side>,
    radius: f64,
    entry: bool,
    pending: Option<Elem>,
    /// Z-only moves after the pending one: (z, cap, line).
    z_moves: Vec<(f64, f64, u32)>,
    /// Programmed position at the end of the last move.
    prog: [f64; 3],
}

impl Comp {
    /// The active side, if compensation is on.
    pub fn side(&self) -> Option<Side> {
        self.side
    }

    /// G41/G42 with the tool `radius_mm`.
    pub fn on(&mut self, side: Side, radius_mm: f64, line: u32) -> Result<()> {
        if self.side.is_some() {
            bail!("line {line}: cutter compensation is already on (G40 first)");
        }
        self.side = Some(side);
        self.radius = radius_mm;
        self.entry = true;
        Ok(())
    }

    /// G40: emit what is pending; the next move is uncompensated.
    pub fn off(&mut self, out: &mut Sink, line: u32) -> Result<()> {
        self.flush(out, line)?;
        self.side = None;
        self.entry = false;
        Ok(())
    }

    /// Emit the pending move (ending at its offset point) and the Z moves
    /// after it.
    pub fn flush(&mut self, out: &mut Sink, _line: u32) -> Result<()> {
        if let Some(e) = self.pending.take() {
            emit(out, &e)?;
            for (z, cap, l) in self.z_moves.drain(..) {
                let p = out.last();
                out.push([p[0], p[1], z], Some(cap), l)?;
            }
        }
        Ok(())
    }

    fn normal(&self, t: [f64; 2]) -> [f64; 2] {
        let r = self.radius;
        match self.side {
            Some(Side::Left) | None => [-t[1] * r, t[0] * r],
            Some(Side::Right) => [t[1] * r, -t[0] * r],
        }
    }

    /// A straight move to the programmed point `to` under compensation.
    pub fn line(&mut self, out: &mut Sink, to: [f64; 3], cap: f64, line: u32) -> Result<()> {
        if self.entry {
            let from = out.last();
            let d = (to[0] - from[0]).hypot(to[1] - from[1]);
            if d == 0.0 {
                out.push(to, Some(cap), line)?;
                return Ok(());
            }
            if d <= self.radius {
                bail!(
                    "line {line}: the cutter compensation entry move ({} mm) is not longer than the tool radius ({} mm)",
                    short(d),
                    short(self.radius)
                );
            }
            let n = self.normal(unit([to[0] - from[0], to[1] - from[1]]));
            self.pending = Some(Elem {
                from,
                to: [to[0] + n[0], to[1] + n[1], to[2]],
                geo: Geo::Line,
                cap,
                line,
                prog_to: to,
            });
            self.entry = false;
            self.prog = to;
            return Ok(());
        }
        let p0 = self.prog;
        let t = unit([to[0] - p0[0], to[1] - p0[1]]);
        if t == [0.0, 0.0] {
            if self.pending.is_some() {
                self.z_moves.push((to[2], cap, line));
            } else {
                let p = out.last();
                out.push([p[0], p[1], to[2]], Some(cap), line)?;
            }
            self.prog = to;
            return Ok(());
        }
        let n = self.normal(t);
        let e = Elem {
            from: [p0[0] + n[0], p0[1] + n[1], p0[2]],
            to: [to[0] + n[0], to[1] + n[1], to[2]],
            geo: Geo::Line,
            cap,
            line,
            prog_to: to,
        };
        self.prog = to;
        self.join(out, e)
    }

    /// An arc to the programmed point `to` under compensation.
    #[allow(clippy::too_many_arguments)]
    pub fn arc(
        &mut self,
        out: &mut Sink,
        to: [f64; 3],
        centre: Centre,
        cw: bool,
        turns: f64,
        cap: f64,
        line: u32,
    ) -> Result<()> {
        if self.entry {
            bail!("line {line}: the first move after G41/G42 must be straight (an arc entry move is not supported)");
        }
        let p0 = self.prog;
        let (cx, cy) = centre_in_plane(p0, to, centre, Plane::Xy, cw, out.arc_tolerance.radius_mm)
            .map_err(|e| anyhow::anyhow!("line {line}: {e}"))?;
        let r0 = (p0[0] - cx).hypot(p0[1] - cy);
        let r1 = (to[0] - cx).hypot(to[1] - cy);
        if r0 == 0.0 || r1 == 0.0 {
            bail!("line {line}: arc centre is at its end point");
        }
        // Tool left of a CCW arc is inside it.
        let inside = matches!(
            (self.side, cw),
            (Some(Side::Left), false) | (Some(Side::Right), true)
        );
        let dr = if inside { -self.radius } else { self.radius };
        if r0 + dr <= 0.0 || r1 + dr <= 0.0 {
            bail!(
                "line {line}: the tool (radius {} mm) does not fit inside the arc (radius {} mm)",
                short(self.radius),
                short(r0)
            );
        }
        let at = |p: [f64; 3], r: f64| {
            let k = (r + dr) / r;
            [cx + (p[0] - cx) * k, cy + (p[1] - cy) * k, p[2]]
        };
        let e = Elem {
            from: at(p0, r0),
            to: at(to, r1),
            geo: Geo::Arc {
                c: [cx, cy],
                cw,
                turns,
            },
            cap,
            line,
            prog_to: to,
        };
        self.prog = to;
        self.join(out, e)
    }

    fn join(&mut self, out: &mut Sink, mut e: Elem) -> Result<()> {
        let Some(mut prev) = self.pending.take() else {
            // After a flush the tool is where the last move left it.
            let from = out.last();
            if (from[0] - e.from[0]).hypot(from[1] - e.from[1]) > 1e-9 {
                out.push(e.from, Some(e.cap), e.line)?;
            }
            self.pending = Some(e);
            return Ok(());
        };
        let t1 = prev.tangent(true);
        let t2 = e.tangent(false);
        let turn = cross(t1, t2);
        let gap = (prev.to[0] - e.from[0]).hypot(prev.to[1] - e.from[1]);
        let outside = match self.side {
            Some(Side::Right) => turn > 0.0,
            _ => turn < 0.0,
        };
        let corner = prev.prog_to;
        if gap <= 1e-9 {
            // Tangent: nothing to add between them.
            self.pending = Some(prev);
            self.flush(out, e.line)?;
        } else if outside || (turn.abs() < 1e-12 && t1[0] * t2[0] + t1[1] * t2[1] < 0.0) {
            self.pending = Some(prev);
            self.flush(out, e.line)?;
            let cw = self.side != Some(Side::Right);
            out.arc(
                e.from,
                Centre::Point(corner),
                Plane::Xy,
                cw,
                0.0,
                Some(e.cap),
                e.line,
            )?;
        } else {
            let p = intersect(&prev, &e, corner).ok_or_else(|| {
                anyhow::anyhow!(
                    "line {}: cutter gouging: at the inside corner before this move the offset moves do not meet (a move shorter than the tool radius?)",
                    e.line
                )
            })?;
            if !within(&prev, p, true) || !within(&e, p, false) {
                bail!(
                    "line {}: cutter gouging: the inside corner before this move needs more room than the moves around it give (tool radius {} mm)",
                    e.line,
                    short(self.radius)
                );
            }
            prev.to = [p[0], p[1], prev.to[2]];
            e.from = [p[0], p[1], e.from[2]];
            self.pending = Some(prev);
            self.flush(out, e.line)?;
        }
        self.pending = Some(e);
        Ok(())
    }
}

fn emit(out: &mut Sink, e: &Elem) -> Result<()> {
    match e.geo {
        Geo::Line => out.push(e.to, Some(e.cap), e.line),
        Geo::Arc { c, cw, turns } => out.arc(
            e.to,
            Centre::Point([c[0], c[1], 0.0]),
            Plane::Xy,
            cw,
            turns,
            Some(e.cap),
            e.line,
        ),
    }
}

/// Whether `p` lies on the kept part of `e`: for the earlier move (`end`),
/// not before its start; for the later, not after its end.
fn within(e: &Elem, p: [f64; 2], end: bool) -> bool {
    match e.geo {
        Geo::Line => {
            let d = [e.to[0] - e.from[0], e.to[1] - e.from[1]];
            let l2 = d[0] * d[0] + d[1] * d[1];
            if l2 == 0.0 {
                return false;
            }
            let t = ((p[0] - e.from[0]) * d[0] + (p[1] - e.from[1]) * d[1]) / l2;
            if end {
                t > 1e-9
            } else {
                t < 1.0 - 1e-9
            }
        }
        // On an arc the nearest intersection is taken as within it.
        Geo::Arc { .. } => true,
    }
}

/// Where the offsets of two moves meet, nearest to the programmed corner.
fn intersect(a: &Elem, b: &Elem, corner: [f64; 3]) -> Option<[f64; 2]> {
    let c = [corner[0], corner[1]];
    let mut cands: Vec<[f64; 2]> = Vec::new();
    match (a.geo, b.geo) {
        (Geo::Line, Geo::Line) => {
            let (p, d) = line_of(a);
            let (q, e) = line_of(b);
            let den = cross(d, e);
            if den.abs() > 1e-15 {
                let t = cross([q[0] - p[0], q[1] - p[1]], e) / den;
                cands.push([p[0] + t * d[0], p[1] + t * d[1]]);
            }
        }
        (Geo::Line, Geo::Arc { c: cc, .. }) => cands = line_circle(line_of(a), cc, radius(b)),
        (Geo::Arc { c: cc, .. }, Geo::Line) => cands = line_circle(line_of(b), cc, radius(a)),
        (Geo::Arc { c: c1, .. }, Geo::Arc { c: c2, .. }) => {
            cands = circle_circle(c1, radius(a), c2, radius(b))
        }
    }
    cands
        .into_iter()
        .filter(|p| p[0].is_finite() && p[1].is_finite())
        .min_by(|p, q| {
            let dp = (p[0] - c[0]).hypot(p[1] - c[1]);
            let dq = (q[0] - c[0]).hypot(q[1] - c[1]);
            dp.total_cmp(&dq)
        })
}

fn line_of(e: &Elem) -> ([f64; 2], [f64; 2]) {
    (
        [e.from[0], e.from[1]],
        [e.to[0] - e.from[0], e.to[1] - e.from[1]],
    )
}

fn radius(e: &Elem) -> f64 {
    match e.geo {
        Geo::Arc { c, .. } => (e.to[0] - c[0]).hypot(e.to[1] - c[1]),
        Geo::Line => 0.0,
    }
}

fn line_circle((p, d): ([f64; 2], [f64; 2]), c: [f64; 2], r: f64) -> Vec<[f64; 2]> {
    let f = [p[0] - c[0], p[1] - c[1]];
    let a = d[0] * d[0] + d[1] * d[1];
    let b = 2.0 * (f[0] * d[0] + f[1] * d[1]);
    let cc = f[0] * f[0] + f[1] * f[1] - r * r;
    let disc = b * b - 4.0 * a * cc;
    if a == 0.0 || disc < 0.0 {
        return Vec::new();
    }
    let s = disc.sqrt();
    [(-b - s) / (2.0 * a), (-b + s) / (2.0 * a)]
        .iter()
        .map(|t| [p[0] + t * d[0], p[1] + t * d[1]])
        .collect()
}

fn circle_circle(c1: [f64; 2], r1: f64, c2: [f64; 2], r2: f64) -> Vec<[f64; 2]> {
    let d = (c2[0] - c1[0]).hypot(c2[1] - c1[1]);
    if d == 0.0 || d > r1 + r2 || d < (r1 - r2).abs() {
        return Vec::new();
    }
    let a = (r1 * r1 - r2 * r2 + d * d) / (2.0 * d);
    let h = (r1 * r1 - a * a).max(0.0).sqrt();
    let m = [
        c1[0] + a * (c2[0] - c1[0]) / d,
        c1[1] + a * (c2[1] - c1[1]) / d,
    ];
    let o = [-(c2[1] - c1[1]) / d * h, (c2[0] - c1[0]) / d * h];
    vec![[m[0] + o[0], m[1] + o[1]], [m[0] - o[0], m[1] - o[1]]]
}

#[cfg(test)]
mod tests {
    use crate::{parse, GcodeSettings, ToolEntry};

    fn settings(d: f64) -> GcodeSettings {
        GcodeSettings {
            tools: vec![ToolEntry {
                number: 1,
                diameter_mm: d,
                length_mm: 0.0,
            }],
            ..Default::default()
        }
    }

    #[test]
    fn g41_around_a_square_outside_rolls_the_corners() {
        // A 20 mm square traced clockwise with G41 (tool left = outside),
        // tool radius 2: the offset path is the square grown by 2 with
        // quarter circles of radius 2 at the corners (independent
        // expectation: every point at distance exactly 2 from the square).
        let src = "T1 M6\nG0 X-10 Y-10\nG41 D1 G1 X0 Y0 F100\nY20\nX20\nY0\nX0\nG40 G0 X-10 Y-10\n";
        let t = parse("t", src, &settings(4.0)).unwrap();
        let sq_dist = |p: &[f64; 3]| {
            let dx = (p[0] - 10.0).abs() - 10.0;
            let dy = (p[1] - 10.0).abs() - 10.0;
            if dx > 0.0 && dy > 0.0 {
                dx.hypot(dy)
            } else {
                dx.max(dy)
            }
        };
        let on: Vec<_> = t
            .points
            .iter()
            .zip(&t.lines)
            .filter(|(_, &l)| (4..=7).contains(&l))
            .map(|(p, _)| *p)
            .collect();
        assert!(on.len() > 20);
        for p in &on {
            assert!((sq_dist(p) - 2.0).abs() < 1e-9, "{p:?} {}", sq_dist(p));
        }
        // The corners are rounded: a point on the arc at (−√2, 20+√2).
        let s2 = std::f64::consts::SQRT_2;
        assert!(on
            .iter()
            .any(|p| (p[0] + s2).abs() < 0.05 && (p[1] - 20.0 - s2).abs() < 0.05));
    }

    #[test]
    fn tangent_joins_keep_both_moves() {
        // A line into a tangent arc (G41, tool radius 1): the line's offset
        // ends where the arc's offset starts, (−1, 10); the arc (centre
        // (5, 10), radius 5, CW: tool left = outside) becomes radius 6.
        let src = "T1 M6\nG0 X0 Y-5\nG41 D1 G1 X0 Y0 F100\nY10\nG2 X10 Y10 I5 J0\nG40 G1 X10 Y20\n";
        let t = parse("t", src, &settings(2.0)).unwrap();
        assert!(t.points.iter().any(|p| p[0] == -1.0 && p[1] == 10.0));
        let arc: Vec<_> = t
            .points
            .iter()
            .zip(&t.lines)
            .filter(|(_, &l)| l == 5)
            .collect();
        assert!(arc.len() > 10);
        for (p, _) in arc {
            assert!(
                ((p[0] - 5.0).hypot(p[1] - 10.0) - 6.0).abs() < 1e-6,
                "{p:?}"
            );
        }
    }

    #[test]
    fn g42_inside_a_square_cuts_the_corners_sharp() {
        // The same clockwise square with G42 (tool right = inside): the
        // offset path is the square shrunk by 2, sharp corners at
        // (2,2) (2,18) (18,18) (18,2).
        let src = "T1 M6\nG0 X10 Y10\nG42 D1 G1 X0 Y10 F100\nY20\nX20\nY0\nX0\nY10\nG40 G1 X10\n";
        let t = parse("t", src, &settings(4.0)).unwrap();
        for c in [[2.0, 18.0], [18.0, 18.0], [18.0, 2.0], [2.0, 2.0]] {
            assert!(
                t.points
                    .iter()
                    .any(|p| (p[0] - c[0]).abs() < 1e-9 && (p[1] - c[1]).abs() < 1e-9),
                "corner {c:?} missing: {:?}",
                t.points
            );
        }
        assert!(t
            .points
            .iter()
            .skip(2)
            .all(|p| p[0] >= 2.0 - 1e-9 && p[0] <= 18.0 + 1e-9));
    }

    #[test]
    fn arcs_grow_or_shrink_by_the_radius_and_errors_are_named() {
        // G41 on a CCW circle of radius 10: the tool is inside, radius 8.
        let src = "T1 M6\nG0 X0 Y-20\nG41 D1 G1 X0 Y-10 F100\nG3 X0 Y-10 I0 J10\nG40 G1 X0 Y-20\n";
        let t = parse("t", src, &settings(4.0)).unwrap();
        let on: Vec<_> = t
            .points
            .iter()
            .zip(&t.lines)
            .filter(|(_, &l)| l == 4)
            .collect();
        // The entry meets the circle at an outside corner: first a quarter
        // circle of the tool radius around the programmed corner (0,−10),
        // then the circle of radius 10 − 2.
        let on_circle = on
            .iter()
            .filter(|(p, _)| (p[0].hypot(p[1]) - 8.0).abs() < 1e-6)
            .count();
        assert!(on_circle > 10);
        for (p, _) in on {
            let r = p[0].hypot(p[1]);
            let c = p[0].hypot(p[1] + 10.0);
            assert!((r - 8.0).abs() < 1e-6 || (c - 2.0).abs() < 1e-6, "{p:?}");
        }
        // Tool bigger than the arc, entry shorter than the radius, unknown
        // tool: errors naming the line.
        for (src, line) in [
            (
                "T1 M6\nG0 X0 Y-20\nG41 D1 G1 X0 Y-1 F100\nG3 X0 Y-1 I0 J1\n",
                "line 4",
            ),
            ("T1 M6\nG0 X0 Y0\nG41 D1 G1 X1 F100\n", "line 3"),
            ("G0 X0 Y0\nG41 D7 G1 X10 F100\n", "line 2"),
        ] {
            let e = format!("{:#}", parse("t", src, &settings(4.0)).unwrap_err());
            assert!(e.contains(line), "{src:?}: {e}");
        }
    }
}
