//! Online contour error: the distance from the measured tool position to the
//! commanded path, computed every interpolation tick without allocation, as
//! Cho, Lee & Jeon's feed controller needs it (section 2.2).
//!
//! # The paper's model and ours
//!
//! Cho et al. take the contour-error model of Joo, Lee, Lee & Jeon (their
//! ref. \[5\], in Korean, not available to us): "a variable size window is used
//! to find two closest points between previous reference points and the
//! current tool position. With these two points, we can determine the contour
//! error by considering the geometrical relationship." The window's sizing
//! rule is not in the paper. We implement the idea as a **variable window of
//! path segments**:
//!
//! - the window holds the path's vertices from a few segments behind the
//!   segment the tool was nearest to last tick (the *anchor*) up to the end
//!   of the block the interpolator is running now, and the next one (a
//!   decelerating servo can run a few µm ahead of its reference: without
//!   the next block, the tool would be measured against the current
//!   block's end point). It grows while the reference runs ahead of the
//!   tool (every block the interpolator enters is [`ContourTracker::push`]ed
//!   with the one after it) and shrinks as the tool catches up
//!   (vertices more than `back` segments behind the anchor are dropped);
//! - each tick ([`ContourTracker::update`]) every segment in the window is
//!   searched; the nearest one gives the two points ("two closest points")
//!   and the contour error is the distance to that segment (perpendicular
//!   distance inside it, distance to its end point beyond).
//!
//! "Previous reference points" in the paper are the interpolated knot
//! points; we use the path's own vertices, so a sharp corner is a vertex of
//! the window and is not cut by the chord between two knot points (at
//! 50 mm/s and 1 ms the chord across a 90° corner would pass 18 µm inside
//! it, more than Cho et al.'s whole error bound). On a curve given as fine
//! chords (a circle of 3600 chords), the two are the same.
//!
//! Where the path comes back near itself (a figure of eight at its
//! crossing), the window sees only the part of the path being followed, not
//! the other branch: the contour error of the motion, which is what a feed
//! controller should react to. host-sim's exact contour error
//! (`host-sim/src/contour_error.rs`) searches the whole path, so the two
//! agree wherever the nearest segment of the whole path lies in the window,
//! and the online value is never smaller otherwise (tested in
//! `host-sim/tests/cho_contour.rs`).
//!
//! # Sign
//!
//! [`ContourEstimate::error`] is signed in the X-Y plane: positive when the
//! tool is left of the nearest segment's direction of travel. Cho et al.'s
//! rule table has negative and positive error terms (NB..PB), so the model
//! of their ref. \[5\] is signed; which side is positive is not said. A
//! segment without X-Y extent (a plunge) gives a positive sign.
//!
//! # Arithmetic and cost
//!
//! Positions are [`Point3Mm`] (I32F32 mm, within ±[`COORD_LIMIT_MM`](crate::units::COORD_LIMIT_MM)).
//! Distances are computed in 128-bit integers from the raw 2⁻³² mm bits:
//! exact to end points; inside a segment, to the foot of the perpendicular
//! placed with the projection parameter to 62 bits (27 bits at the 100 m
//! coordinate limit, where the foot may slide 1.5 µm along the segment,
//! changing the distance only to second order), i.e. within a few 2⁻³² mm.
//! Per searched segment: about a dozen 128-bit multiplications and at most
//! one 128-bit division; one 128-bit square root per tick
//! ([`isqrt_u128`]). The window's
//! capacity `N` is a const generic; the search is linear in the segments
//! the window holds. It runs on the host (host-sim's `cho` experiment);
//! on the target the 128-bit root alone is expensive (the cost table in
//! [`crate::numerics`]).

use fixed::types::I32F32;
use heapless::Deque;

use crate::numerics::sqrt::isqrt_u128;
use crate::units::Point3Mm;

/// Why the contour error cannot be computed or a vertex cannot be taken.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ContourError {
    /// No vertex has been pushed yet.
    Empty,
    /// The window holds `N` vertices, all still within reach of the tool
    /// (the interpolator runs more than `N − back − 1` blocks ahead of the
    /// tool): a larger `N` is needed.
    WindowFull,
    /// A coordinate beyond ±[`COORD_LIMIT_MM`](crate::units::COORD_LIMIT_MM).
    OutOfRange,
}

impl core::fmt::Display for ContourError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            ContourError::Empty => f.write_str("contour error: no path vertex yet"),
            ContourError::WindowFull => {
                f.write_str("contour error: the window is full (the path runs too far ahead)")
            }
            ContourError::OutOfRange => f.write_str("contour error: coordinate out of range"),
        }
    }
}

/// One tick's contour error.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ContourEstimate {
    /// Signed contour error, mm: positive left of the direction of travel
    /// (X-Y plane).
    pub error: I32F32,
    /// Its magnitude, the distance to the path, mm.
    pub distance: I32F32,
    /// Index of the nearest segment (counted from the first vertex ever
    /// pushed: segment `i` runs from vertex `i` to vertex `i + 1`).
    pub segment: u32,
    /// How many segments were searched (the window's size this tick).
    pub searched: u16,
}

/// The variable-window nearest-segment search (module docs), holding at
/// most `N` vertices.
#[derive(Clone, Debug)]
pub struct ContourTracker<const N: usize> {
    verts: Deque<Point3Mm, N>,
    /// Global index of `verts[0]`.
    first: u32,
    /// Global index of the segment nearest at the last update.
    anchor: u32,
    /// Segments kept behind the anchor.
    back: u32,
}

impl<const N: usize> Default for ContourTracker<N> {
    fn default() -> Self {
        Self::new(Self::DEFAULT_BACK)
    }
}

impl<const N: usize> ContourTracker<N> {
    /// Segments kept behind the last nearest one by default.
    pub const DEFAULT_BACK: u32 = 2;

    /// An empty tracker keeping `back` segments behind the last nearest one
    /// (at least 1 is useful: a tool lagging at a corner can be nearest to
    /// the segment before the one it was nearest to).
    pub const fn new(back: u32) -> Self {
        ContourTracker {
            verts: Deque::new(),
            first: 0,
            anchor: 0,
            back,
        }
    }

    /// Forget the path (the next vertex pushed is vertex 0 again).
    pub fn clear(&mut self) {
        self.verts.clear();
        self.first = 0;
        self.anchor = 0;
    }

    /// Vertices in the window now.
    pub fn len(&self) -> usize {
        self.verts.len()
    }

    /// Whether no vertex is held.
    pub fn is_empty(&self) -> bool {
        self.verts.is_empty()
    }

    /// Append the next path vertex (the end of the block the interpolator
    /// enters; the first call gives the start point). A vertex equal to the
    /// last one is ignored (a zero-length block).
    pub fn push(&mut self, vertex: Point3Mm) -> Result<(), ContourError> {
        if !vertex.within_limits() {
            return Err(ContourError::OutOfRange);
        }
        if self.verts.back() == Some(&vertex) {
            return Ok(());
        }
        if self.verts.is_full() {
            self.prune();
        }
        self.verts
            .push_back(vertex)
            .map_err(|_| ContourError::WindowFull)
    }

    /// Drop the vertices more than `back` segments behind the anchor.
    fn prune(&mut self) {
        let keep_from = self.anchor.saturating_sub(self.back);
        while self.first < keep_from && self.verts.len() > 1 {
            self.verts.pop_front();
            self.first = self.first.saturating_add(1);
        }
    }

    /// The contour error of the tool at `actual`: the nearest segment of the
    /// window (module docs). Moves the anchor and drops vertices that fall
    /// out of the window.
    pub fn update(&mut self, actual: Point3Mm) -> Result<ContourEstimate, ContourError> {
        if !actual.within_limits() {
            return Err(ContourError::OutOfRange);
        }
        let n = self.verts.len();
        let Some(&v0) = self.verts.front() else {
            return Err(ContourError::Empty);
        };
        if n == 1 {
            let d2 = dist2(v0, actual);
            let d = I32F32::from_bits(isqrt_u128(d2) as i64);
            return Ok(ContourEstimate {
                error: d,
                distance: d,
                segment: self.first,
                searched: 0,
            });
        }
        let start = self.anchor.saturating_sub(self.back).max(self.first) - self.first;
        let start = (start as usize).min(n - 2);
        let mut best = (u128::MAX, 0usize, 0i32);
        let mut searched = 0u16;
        let mut it = self.verts.iter().skip(start);
        let mut a = it.next().copied().unwrap_or(v0);
        for (k, &b) in it.enumerate() {
            let (d2, side) = segment_dist2(a, b, actual);
            // `<=`: on a tie (the tool at a vertex's bisector) take the later
            // segment, the one the tool is moving onto.
            if d2 <= best.0 {
                best = (d2, start + k, side);
            }
            searched = searched.saturating_add(1);
            a = b;
        }
        let (d2, seg, side) = best;
        self.anchor = self.first.saturating_add(seg as u32);
        self.prune();
        let d = I32F32::from_bits(isqrt_u128(d2) as i64);
        Ok(ContourEstimate {
            error: if side < 0 { -d } else { d },
            distance: d,
            segment: self.anchor,
            searched,
        })
    }
}

fn diff(a: Point3Mm, b: Point3Mm) -> [i64; 3] {
    let (a, b) = (a.to_bits(), b.to_bits());
    // Within ±COORD_LIMIT_MM (2^17 mm, 2^49 raw), differences fit i64.
    [b[0] - a[0], b[1] - a[1], b[2] - a[2]]
}

/// `|b − a|²` in raw² units (2^-64 mm²), exact.
fn dist2(a: Point3Mm, b: Point3Mm) -> u128 {
    diff(a, b)
        .iter()
        .map(|&c| (c as i128 * c as i128) as u128)
        .sum()
}

/// Squared distance (raw², 2^-64 mm²) from `p` to the segment `a → b`, and
/// the side of `p` in X-Y (`1` left or on the line, `-1` right).
fn segment_dist2(a: Point3Mm, b: Point3Mm, p: Point3Mm) -> (u128, i32) {
    let ab = diff(a, b);
    let ap = diff(a, p);
    let cross_z = ab[0] as i128 * ap[1] as i128 - ab[1] as i128 * ap[0] as i128;
    let side = if cross_z < 0 { -1 } else { 1 };
    let dot: i128 = (0..3).map(|i| ab[i] as i128 * ap[i] as i128).sum();
    let len2: i128 = (0..3).map(|i| ab[i] as i128 * ab[i] as i128).sum();
    if dot <= 0 || len2 == 0 {
        return (dist2(a, p), side);
    }
    if dot >= len2 {
        return (dist2(b, p), side);
    }
    // Inside: the foot of the perpendicular, `a + t·ab` with `t = dot/len2`
    // to as many bits as fit (62 for segments up to ~1 mm, 27 at the 100 m
    // limit), then the exact distance to it. An error in `t` moves the foot
    // along the segment, which changes the distance only to second order.
    let bits = 128 - (dot as u128).leading_zeros();
    let k = 126u32.saturating_sub(bits).min(62);
    let t_q = (dot << k) / len2; // t in Q(k), 0 < t < 1
    let half = 1i128 << (k.max(1) - 1);
    let mut d2 = 0u128;
    for i in 0..3 {
        let along = (t_q * ab[i] as i128 + half) >> k;
        let off = ap[i] as i128 - along;
        d2 += (off * off) as u128;
    }
    (d2, side)
}

/// An `f64` reference of the same search, written independently (feature
/// `std`): brute-force distance from a point to a polyline, and the window
/// rule as plain index arithmetic.
#[cfg(feature = "std")]
pub mod reference {
    /// Distance from `p` to the segment `a → b` and the side in X-Y
    /// (`1.0` left or on the line, `-1.0` right).
    pub fn segment_distance(a: [f64; 3], b: [f64; 3], p: [f64; 3]) -> (f64, f64) {
        let ab = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let ap = [p[0] - a[0], p[1] - a[1], p[2] - a[2]];
        let len2 = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2];
        let t = if len2 > 0.0 {
            ((ab[0] * ap[0] + ab[1] * ap[1] + ab[2] * ap[2]) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let d = [ap[0] - t * ab[0], ap[1] - t * ab[1], ap[2] - t * ab[2]];
        let side = if ab[0] * ap[1] - ab[1] * ap[0] < 0.0 {
            -1.0
        } else {
            1.0
        };
        ((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt(), side)
    }

    /// Distance from `p` to the polyline through `points` (every segment).
    pub fn polyline_distance(points: &[[f64; 3]], p: [f64; 3]) -> f64 {
        if points.len() == 1 {
            return segment_distance(points[0], points[0], p).0;
        }
        points
            .windows(2)
            .map(|w| segment_distance(w[0], w[1], p).0)
            .fold(f64::INFINITY, f64::min)
    }

    /// The tracker's rule in `f64`: the path's vertices `0..=last` are
    /// known, the last nearest segment was `anchor`; returns the signed
    /// error and the new anchor (ties to the later segment).
    pub fn windowed(
        points: &[[f64; 3]],
        last: usize,
        anchor: usize,
        back: usize,
        p: [f64; 3],
    ) -> (f64, usize) {
        if last == 0 {
            return (segment_distance(points[0], points[0], p).0, 0);
        }
        let start = anchor.saturating_sub(back).min(last - 1);
        let mut best = (f64::INFINITY, start, 1.0);
        for i in start..last {
            let (d, s) = segment_distance(points[i], points[i + 1], p);
            if d <= best.0 {
                best = (d, i, s);
            }
        }
        (best.0 * best.2, best.1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::units::COORD_LIMIT_MM;

    fn pt(x: f64, y: f64) -> Point3Mm {
        Point3Mm::from_f64(x, y, 0.0).unwrap()
    }

    #[test]
    fn distances_and_signs_at_a_corner() {
        let mut t: ContourTracker<8> = ContourTracker::default();
        assert_eq!(t.update(pt(0.0, 0.0)), Err(ContourError::Empty));
        for p in [pt(0.0, 0.0), pt(10.0, 0.0), pt(10.0, 10.0)] {
            t.push(p).unwrap();
        }
        // Left of +X (inside the left turn): positive.
        let e = t.update(pt(5.0, 0.003)).unwrap();
        assert_eq!(e.segment, 0);
        assert!((e.error.to_num::<f64>() - 0.003).abs() < 1e-9, "{e:?}");
        // Right of +X: negative.
        let e = t.update(pt(6.0, -0.002)).unwrap();
        assert!((e.error.to_num::<f64>() + 0.002).abs() < 1e-9, "{e:?}");
        // Cut inside the corner, nearer the second leg.
        let e = t.update(pt(9.99, 1.0)).unwrap();
        assert_eq!(e.segment, 1);
        assert!((e.distance.to_num::<f64>() - 0.01).abs() < 1e-9, "{e:?}");
        // Outside the corner: the distance to the vertex.
        let e = t.update(pt(10.003, -0.004)).unwrap();
        assert!((e.distance.to_num::<f64>() - 0.005).abs() < 1e-9, "{e:?}");
    }

    #[test]
    fn the_window_drops_what_lies_behind_and_reports_a_full_window() {
        let mut t: ContourTracker<4> = ContourTracker::new(1);
        for i in 0..4 {
            t.push(pt(i as f64, 0.0)).unwrap();
        }
        // All four still within reach of the tool at the start.
        assert_eq!(t.push(pt(4.0, 0.0)), Err(ContourError::WindowFull));
        // The tool moves on to segment 2: vertex 0 leaves the window.
        let e = t.update(pt(2.5, 0.001)).unwrap();
        assert_eq!(e.segment, 2);
        assert_eq!(t.len(), 3);
        t.push(pt(4.0, 0.0)).unwrap();
        let e = t.update(pt(3.5, 0.0)).unwrap();
        assert_eq!((e.segment, e.searched), (3, 3));
        assert_eq!(t.push(pt(4.0, 0.0)), Ok(()), "a repeated vertex is ignored");
        assert_eq!(t.len(), 3);
    }

    #[test]
    fn a_single_vertex_gives_the_distance_to_it() {
        let mut t: ContourTracker<2> = ContourTracker::default();
        t.push(pt(1.0, 1.0)).unwrap();
        let e = t.update(pt(1.003, 1.004)).unwrap();
        assert!((e.distance.to_num::<f64>() - 0.005).abs() < 1e-9);
    }

    #[test]
    fn extreme_coordinates_do_not_overflow() {
        let lim = COORD_LIMIT_MM as f64;
        let mut t: ContourTracker<4> = ContourTracker::default();
        t.push(pt(-lim, -lim)).unwrap();
        t.push(pt(lim, lim)).unwrap();
        for p in [pt(lim, -lim), pt(-lim, lim), pt(0.0, 0.0), pt(lim, lim)] {
            let e = t.update(p).unwrap();
            let want =
                reference::polyline_distance(&[[-lim, -lim, 0.0], [lim, lim, 0.0]], p.to_f64());
            assert!(
                (e.distance.to_num::<f64>() - want).abs() <= 1e-6 * (1.0 + want),
                "{e:?} vs {want}"
            );
        }
        assert_eq!(t.push(pt(lim + 1.0, 0.0)), Err(ContourError::OutOfRange));
    }
    /// The tracker against the `f64` reference window rule and the brute
    /// force over the whole path, on a 90° corner and a fine circle, with a
    /// tool lagging behind the reference: the same segment and the same
    /// signed error (within 1 nm), and the window's answer equals the whole
    /// path's wherever the reference is within the window.
    #[cfg(feature = "std")]
    #[test]
    fn matches_the_f64_reference_on_a_corner_and_a_circle() {
        let mut paths: Vec<Vec<[f64; 3]>> = vec![vec![
            [0.0, 0.0, 0.0],
            [5.0, 0.0, 0.0],
            [10.0, 0.0, 0.0],
            [10.0, 5.0, 0.0],
            [10.0, 10.0, 0.0],
        ]];
        paths.push(
            (0..=720)
                .map(|i| {
                    let a = i as f64 * std::f64::consts::TAU / 720.0;
                    [20.0 * a.cos(), 20.0 * a.sin(), 0.0]
                })
                .collect(),
        );
        for pts in &paths {
            let len: Vec<f64> = pts
                .windows(2)
                .map(|w| reference::segment_distance(w[0], w[0], w[1]).0)
                .collect();
            let total: f64 = len.iter().sum();
            let mut t: ContourTracker<64> = ContourTracker::new(2);
            let (mut last, mut anchor) = (0usize, 0usize);
            t.push(Point3Mm::from_f64(pts[0][0], pts[0][1], 0.0).unwrap())
                .unwrap();
            for k in 0..=400 {
                // Reference at arc length s; the tool 0.3 mm behind it and
                // off the path by a wobble of a few µm.
                let s = total * k as f64 / 400.0;
                while last + 1 < pts.len() && len[..last].iter().sum::<f64>() <= s {
                    last += 1;
                    let p = pts[last];
                    t.push(Point3Mm::from_f64(p[0], p[1], 0.0).unwrap())
                        .unwrap();
                }
                let lag = (s - 0.3).max(0.0);
                let (mut acc, mut i) = (0.0, 0);
                while i + 1 < len.len() && acc + len[i] < lag {
                    acc += len[i];
                    i += 1;
                }
                let f = ((lag - acc) / len[i]).clamp(0.0, 1.0);
                let (a, b) = (pts[i], pts[i + 1]);
                let w = 0.004 * (k as f64 * 0.37).sin();
                let p = [
                    a[0] + f * (b[0] - a[0]) + w,
                    a[1] + f * (b[1] - a[1]) - w,
                    0.0,
                ];
                let pf = Point3Mm::from_f64(p[0], p[1], 0.0).unwrap();
                let got = t.update(pf).unwrap();
                let (want, seg) = reference::windowed(pts, last, anchor, 2, pf.to_f64());
                anchor = seg;
                assert_eq!(got.segment as usize, seg, "k {k}");
                assert!(
                    (got.error.to_num::<f64>() - want).abs() < 1e-6,
                    "k {k}: {got:?} vs {want}"
                );
                let whole = reference::polyline_distance(&pts[..=last], pf.to_f64());
                assert!(got.distance.to_num::<f64>() >= whole - 1e-6);
                assert!((got.distance.to_num::<f64>() - whole).abs() < 1e-6, "k {k}");
            }
        }
    }
}
