//! A commanded toolpath: the polyline the controller is told to follow, in
//! mm, with the programmed feed of each block and where each point came from.
//!
//! Every input (built-in shape, G-code, CSV) becomes a [`Toolpath`]; every
//! method and machine works on one. Point `i` ends block `i` (the straight
//! move `p[i-1] → p[i]`); point 0 is where the tool starts.

use anyhow::{bail, Result};
use fuzzy_core::scheduler::PathPoint;
use fuzzy_core::units::{FeedMmPerMin, Point3Mm};

/// A spindle direction, or off.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpindleDir {
    /// Off (M5).
    Off,
    /// Clockwise (M3).
    Cw,
    /// Counter-clockwise (M4).
    Ccw,
}

/// A machine command of a program (spindle, coolant, dwell, path control), in order with the
/// motion: it takes effect once the tool has reached a point of the path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MachineEvent {
    /// Spindle on in a direction at a speed, or off (M3 M4 M5, or an S word
    /// while it runs).
    Spindle {
        /// Direction, or off.
        dir: SpindleDir,
        /// Speed, rpm.
        rpm: f64,
    },
    /// Coolant: flood (M8), mist (M7), both off (M9).
    Coolant {
        /// Flood on.
        flood: bool,
        /// Mist on.
        mist: bool,
    },
    /// A dwell (G4 P, or a canned cycle's P at the hole's bottom): the tool
    /// at rest for this long.
    Dwell {
        /// Seconds.
        s: f64,
    },
    /// Path control from here on (G61, G61.1, G64, G64 P): how far the
    /// planner may leave the programmed path.
    PathControl(PathMode),
}

/// A path control mode (RS274/NGC modal group 13, LinuxCNC's G61/G64).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PathMode {
    /// G64 (what a program starts in): blending within the machine's
    /// tolerance; with P (mm, > 0) within that tolerance.
    Blend(Option<f64>),
    /// G61, G61.1: exact path, a stop at every corner.
    Exact,
}

impl Default for PathMode {
    fn default() -> Self {
        PathMode::Blend(None)
    }
}

/// A polyline with per-block feed caps and source lines.
#[derive(Clone, Debug, PartialEq)]
pub struct Toolpath {
    /// A short name for reports (file stem or shape name).
    pub name: String,
    /// Points, mm. Consecutive points are distinct (see [`Toolpath::new`]).
    pub points: Vec<[f64; 3]>,
    /// Programmed feed of the block ending at each point, mm/min (`None`:
    /// no programmed limit, as for the built-in shapes).
    pub feed_caps: Vec<Option<f64>>,
    /// Source line of each point (1-based; 0 where there is none).
    pub lines: Vec<u32>,
    /// Machine commands in program order: `(i, line, event)` takes effect
    /// once the tool has reached point `i` (before the move to `i + 1`).
    pub events: Vec<(usize, u32, MachineEvent)>,
}

impl Toolpath {
    /// A toolpath from points, caps and lines of equal length. Points equal
    /// to their predecessor in the scheduler's fixed point (2⁻³² mm) are
    /// dropped (zero-length blocks, merged as the scheduler merges them), so
    /// that indices here and in the scheduler's output agree.
    pub fn new(
        name: impl Into<String>,
        points: Vec<[f64; 3]>,
        feed_caps: Vec<Option<f64>>,
        lines: Vec<u32>,
    ) -> Result<Self> {
        Self::with_events(name, points, feed_caps, lines, Vec::new())
    }

    /// [`Toolpath::new`] with machine commands, each after a point given
    /// by its index in `points` (renumbered as points are dropped).
    pub fn with_events(
        name: impl Into<String>,
        points: Vec<[f64; 3]>,
        feed_caps: Vec<Option<f64>>,
        lines: Vec<u32>,
        events: Vec<(usize, u32, MachineEvent)>,
    ) -> Result<Self> {
        if points.len() != feed_caps.len() || points.len() != lines.len() {
            bail!("toolpath: points, feed caps and lines differ in length");
        }
        // Merged in place (no second copy of a path of millions of
        // points). The events in order of the point they follow, each
        // renumbered when its point is reached.
        let (mut points, mut feed_caps, mut lines) = (points, feed_caps, lines);
        let mut order: Vec<usize> = (0..events.len()).collect();
        order.sort_by_key(|&k| events[k].0);
        let mut at = vec![usize::MAX; events.len()];
        let mut next_event = order.iter().peekable();
        let mut kept = 0;
        let mut last: Option<Point3Mm> = None;
        for r in 0..points.len() {
            let (p, cap, line) = (points[r], feed_caps[r], lines[r]);
            if p.iter().any(|c| !c.is_finite()) {
                bail!("line {line}: coordinate is not finite");
            }
            let fixed = Point3Mm::from_f64(p[0], p[1], p[2])
                .filter(|q| q.within_limits())
                .ok_or_else(|| {
                    anyhow::anyhow!(
                        "line {line}: coordinate beyond ±{} mm",
                        fuzzy_core::units::COORD_LIMIT_MM
                    )
                })?;
            if let Some(c) = cap {
                if !(c.is_finite() && c > 0.0 && c <= 1e6) {
                    bail!(
                        "line {line}: feed {} mm/min outside (0, 1e6]",
                        crate::text::short(c)
                    );
                }
            }
            // The kept point this input point is (or is merged into).
            let here = if last == Some(fixed) {
                kept - 1
            } else {
                last = Some(fixed);
                points[kept] = p;
                feed_caps[kept] = cap;
                lines[kept] = line;
                kept += 1;
                kept - 1
            };
            while let Some(&&k) = next_event.peek().filter(|&&&k| events[k].0 == r) {
                at[k] = here;
                next_event.next();
            }
        }
        points.truncate(kept);
        points.shrink_to_fit();
        feed_caps.truncate(kept);
        feed_caps.shrink_to_fit();
        lines.truncate(kept);
        lines.shrink_to_fit();
        let t = Toolpath {
            name: name.into(),
            points,
            feed_caps,
            lines,
            events: events
                .into_iter()
                .zip(at)
                .map(|((_, line, e), at)| {
                    // Events after the last point stay after it.
                    (at.min(kept.saturating_sub(1)), line, e)
                })
                .collect(),
        };
        if t.points.len() < 2 {
            bail!("toolpath {:?} has fewer than two distinct points", t.name);
        }
        Ok(t)
    }

    /// A toolpath from points alone (no caps; lines are 1-based indices).
    pub fn from_points(name: impl Into<String>, points: Vec<[f64; 3]>) -> Result<Self> {
        let n = points.len();
        Self::new(name, points, vec![None; n], (1..=n as u32).collect())
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether there are no points (never, for a constructed toolpath).
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Length of block `i` (`p[i-1] → p[i]`), mm; 0 for `i = 0`.
    pub fn block_length_mm(&self, i: usize) -> f64 {
        if i == 0 {
            return 0.0;
        }
        distance(self.points[i - 1], self.points[i])
    }

    /// Total length, mm.
    pub fn length_mm(&self) -> f64 {
        (1..self.len()).map(|i| self.block_length_mm(i)).sum()
    }

    /// The points for `fuzzy-core`'s scheduler; each point's tag is its index
    /// here.
    pub fn path_points(&self) -> Vec<PathPoint> {
        self.points
            .iter()
            .zip(&self.feed_caps)
            .enumerate()
            .map(|(i, (p, cap))| PathPoint {
                // Checked in `new`.
                pos: Point3Mm::from_f64(p[0], p[1], p[2]).unwrap_or_default(),
                feed_cap: cap.map(FeedMmPerMin::from_f64),
                tag: i as u32,
            })
            .collect()
    }

    /// The toolpath from a CSV point list (see [`crate::path_csv`]).
    pub fn from_path_points(name: impl Into<String>, points: &[PathPoint]) -> Result<Self> {
        Self::new(
            name,
            points.iter().map(|p| p.pos.to_f64()).collect(),
            points
                .iter()
                .map(|p| p.feed_cap.map(|c| c.to_f64()))
                .collect(),
            points.iter().map(|p| p.tag).collect(),
        )
    }

    /// Whether any point moves off the XY plane of the first point.
    pub fn is_planar_xy(&self) -> bool {
        let z0 = self.points[0][2];
        self.points.iter().all(|p| (p[2] - z0).abs() < 1e-9)
    }
}

/// Euclidean distance, mm.
pub fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2) + (b[2] - a[2]).powi(2)).sqrt()
}

/// Distance of `p` from the segment `a`-`b`, mm.
pub fn segment_distance(a: [f64; 3], b: [f64; 3], p: [f64; 3]) -> f64 {
    let ab = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let ap = [p[0] - a[0], p[1] - a[1], p[2] - a[2]];
    let len2 = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2];
    let t = if len2 > 0.0 {
        ((ap[0] * ab[0] + ap[1] * ab[1] + ap[2] * ab[2]) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let d = [ap[0] - t * ab[0], ap[1] - t * ab[1], ap[2] - t * ab[2]];
    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn merged_points_renumber_events_in_any_order() {
        let d = |s| MachineEvent::Dwell { s };
        let t = Toolpath::with_events(
            "t",
            vec![[0.0; 3], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]],
            vec![None; 4],
            vec![1, 2, 3, 4],
            vec![
                (3, 10, d(1.0)),
                (2, 11, d(2.0)),
                (0, 12, d(3.0)),
                (9, 13, d(4.0)),
            ],
        )
        .unwrap();
        assert_eq!(t.points, vec![[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]]);
        assert_eq!(t.lines, vec![1, 2, 4]);
        let at: Vec<(usize, u32)> = t.events.iter().map(|e| (e.0, e.1)).collect();
        assert_eq!(at, vec![(2, 10), (1, 11), (0, 12), (2, 13)]);
    }

    #[test]
    fn duplicates_dropped_and_lengths_add_up() {
        let t = Toolpath::new(
            "t",
            vec![[0.0; 3], [0.0; 3], [3.0, 4.0, 0.0], [3.0, 4.0, 12.0]],
            vec![None, None, Some(100.0), None],
            vec![1, 2, 3, 4],
        )
        .unwrap();
        assert_eq!(t.len(), 3);
        assert_eq!(t.lines, vec![1, 3, 4]);
        assert!((t.length_mm() - 17.0).abs() < 1e-12);
        assert!(!t.is_planar_xy());
        let pp = t.path_points();
        assert_eq!(pp[1].tag, 1);
        assert_eq!(pp[1].feed_cap, Some(FeedMmPerMin::from_int(100)));
    }

    #[test]
    fn bad_input_is_refused_with_its_line() {
        let e = Toolpath::new(
            "t",
            vec![[0.0; 3], [1e9, 0.0, 0.0]],
            vec![None; 2],
            vec![1, 7],
        );
        assert!(format!("{:#}", e.unwrap_err()).contains("line 7"));
        let e = Toolpath::new(
            "t",
            vec![[0.0; 3], [1.0, 0.0, 0.0]],
            vec![None, Some(-1.0)],
            vec![1, 2],
        );
        assert!(format!("{:#}", e.unwrap_err()).contains("line 2"));
        assert!(Toolpath::from_points("t", vec![[1.0; 3], [1.0; 3]]).is_err());
    }
}
