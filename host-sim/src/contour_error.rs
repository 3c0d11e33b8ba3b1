//! Contour error: the distance from the actual tool position to the
//! commanded path, the polyline through the commanded points. Lin et al.
//! (section 3.1, Figure 13) match each scanned tool-tip point to the
//! machining program's path and take the shortest distance; so do we, over
//! the whole polyline (not just the segment the tool "should" be on: where
//! a path passes near itself, as the ∞ shape does at its crossing, the
//! nearest segment is the right one).
//!
//! Nearest-segment queries use a uniform x-y grid over the segments, searched ring by ring until no closer segment can exist: exact,
//! and O(1) per query for the tool positions near the path that a
//! simulation produces.

use std::collections::HashMap;

/// A polyline indexed for nearest-distance queries.
#[derive(Clone, Debug)]
pub struct PathIndex {
    a: Vec<[f64; 3]>,
    ab: Vec<[f64; 3]>,
    len2: Vec<f64>,
    cell_mm: f64,
    cells: HashMap<(i64, i64), Vec<u32>>,
    /// Bounds of occupied cells, for the search's stopping rule.
    lo: [i64; 2],
    hi: [i64; 2],
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Parameter of the point of segment `a → a+ab` nearest to `p`.
fn segment_t(p: [f64; 3], a: [f64; 3], ab: [f64; 3], len2: f64) -> f64 {
    if len2 > 0.0 {
        (dot(sub(p, a), ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// Distance from `p` to the segment `a → a+ab` (`len2 = |ab|²`).
fn segment_distance(p: [f64; 3], a: [f64; 3], ab: [f64; 3], len2: f64) -> f64 {
    let ap = sub(p, a);
    let t = segment_t(p, a, ab, len2);
    let d = [ap[0] - t * ab[0], ap[1] - t * ab[1], ap[2] - t * ab[2]];
    dot(d, d).sqrt()
}

/// Distance from `p` to the polyline `points`, by checking every segment
/// (the reference the index is tested against).
pub fn brute_force_distance(points: &[[f64; 3]], p: [f64; 3]) -> f64 {
    if points.len() == 1 {
        return dot(sub(p, points[0]), sub(p, points[0])).sqrt();
    }
    points
        .windows(2)
        .map(|w| {
            let ab = sub(w[1], w[0]);
            segment_distance(p, w[0], ab, dot(ab, ab))
        })
        .fold(f64::INFINITY, f64::min)
}

impl PathIndex {
    /// Index the polyline through `points` (at least one point).
    pub fn new(points: &[[f64; 3]]) -> Self {
        let segs: Vec<([f64; 3], [f64; 3])> = if points.len() == 1 {
            vec![(points[0], points[0])]
        } else {
            points.windows(2).map(|w| (w[0], w[1])).collect()
        };
        let mean_len = segs
            .iter()
            .map(|(a, b)| dot(sub(*b, *a), sub(*b, *a)).sqrt())
            .sum::<f64>()
            / segs.len() as f64;
        let mut lo_f = [f64::INFINITY; 2];
        let mut hi_f = [f64::NEG_INFINITY; 2];
        for p in points {
            for k in 0..2 {
                lo_f[k] = lo_f[k].min(p[k]);
                hi_f[k] = hi_f[k].max(p[k]);
            }
        }
        let extent = (0..2).map(|k| hi_f[k] - lo_f[k]).fold(0.0, f64::max);
        // Cells of a few mean segment lengths, at most 1024 across.
        let cell_mm = if extent > 0.0 {
            (4.0 * mean_len).max(extent / 1024.0)
        } else {
            1.0
        };
        let key = |p: [f64; 3]| {
            (
                (p[0] / cell_mm).floor() as i64,
                (p[1] / cell_mm).floor() as i64,
            )
        };
        let mut cells: HashMap<(i64, i64), Vec<u32>> = HashMap::new();
        let (mut lo, mut hi) = ([i64::MAX; 2], [i64::MIN; 2]);
        let (mut a, mut ab, mut len2) = (Vec::new(), Vec::new(), Vec::new());
        let mut keys: Vec<(i64, i64)> = Vec::new();
        for (i, (p, q)) in segs.iter().enumerate() {
            let d = sub(*q, *p);
            a.push(*p);
            ab.push(d);
            len2.push(dot(d, d));
            // Every point of the segment is within half a cell (in x-y) of a
            // sample, so the samples' cells and their neighbours cover it.
            let steps = ((d[0].hypot(d[1])) / (0.5 * cell_mm)).ceil().max(1.0) as usize;
            keys.clear();
            for s in 0..=steps {
                let t = s as f64 / steps as f64;
                let (cx, cy) = key([p[0] + t * d[0], p[1] + t * d[1], 0.0]);
                for dx in -1..=1 {
                    for dy in -1..=1 {
                        keys.push((cx + dx, cy + dy));
                    }
                }
            }
            keys.sort_unstable();
            keys.dedup();
            for &k in &keys {
                lo = [lo[0].min(k.0), lo[1].min(k.1)];
                hi = [hi[0].max(k.0), hi[1].max(k.1)];
                cells.entry(k).or_default().push(i as u32);
            }
        }
        PathIndex {
            a,
            ab,
            len2,
            cell_mm,
            cells,
            lo,
            hi,
        }
    }

    /// Distance from `p` to the polyline, mm.
    pub fn distance(&self, p: [f64; 3]) -> f64 {
        self.nearest(p).0
    }

    /// Distance from `p` to the polyline (mm) and the nearest point of it.
    pub fn nearest(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
        let (best, i) = self.nearest_segment(p);
        let t = segment_t(p, self.a[i], self.ab[i], self.len2[i]);
        let q = [
            self.a[i][0] + t * self.ab[i][0],
            self.a[i][1] + t * self.ab[i][1],
            self.a[i][2] + t * self.ab[i][2],
        ];
        (best, q)
    }

    /// Distance from `p` to the polyline (mm) and the index of the nearest
    /// segment (segment `i` runs from point `i` to point `i + 1`).
    pub fn nearest_segment(&self, p: [f64; 3]) -> (f64, usize) {
        let mut best_seg = 0usize;
        let c = [
            (p[0] / self.cell_mm).floor() as i64,
            (p[1] / self.cell_mm).floor() as i64,
        ];
        let mut best = f64::INFINITY;
        // p's own cell first: every segment passing within half a cell of p
        // (in x-y) has a sample within 3/4 of a cell of it, so it is
        // registered in p's cell (segments are registered in their
        // samples' cells and those cells' neighbours). A result within half
        // a cell is therefore final.
        if let Some(list) = self.cells.get(&(c[0], c[1])) {
            for &i in list {
                let i = i as usize;
                let d = segment_distance(p, self.a[i], self.ab[i], self.len2[i]);
                if d < best {
                    best = d;
                    best_seg = i;
                }
            }
            if best <= 0.5 * self.cell_mm {
                return (best, best_seg);
            }
        }
        // Rings of cells at Chebyshev distance r in x-y. A segment's nearest
        // point to p lies in a cell where the segment is registered; if that
        // cell is in ring r, the point is at least (r − 1)·cell away (x-y
        // distance never exceeds the 3-D distance).
        let max_r = (0..2)
            .map(|k| (c[k] - self.lo[k]).abs().max((self.hi[k] - c[k]).abs()))
            .max()
            .unwrap_or(0);
        for r in 0..=max_r {
            if (r - 1) as f64 * self.cell_mm > best {
                break;
            }
            // Only cells inside the occupied bounds can hold segments.
            for x in (c[0] - r).max(self.lo[0])..=(c[0] + r).min(self.hi[0]) {
                let edge_x = (x - c[0]).abs() == r;
                let (y0, y1) = ((c[1] - r).max(self.lo[1]), (c[1] + r).min(self.hi[1]));
                let mut visit = |y: i64| {
                    if let Some(list) = self.cells.get(&(x, y)) {
                        for &i in list {
                            let i = i as usize;
                            let d = segment_distance(p, self.a[i], self.ab[i], self.len2[i]);
                            if d < best {
                                best = d;
                                best_seg = i;
                            }
                        }
                    }
                };
                if edge_x {
                    for y in y0..=y1 {
                        visit(y);
                    }
                } else {
                    for y in [c[1] - r, c[1] + r] {
                        if y >= y0 && y <= y1 {
                            visit(y);
                        }
                    }
                }
            }
        }
        (best, best_seg)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn distances_to_a_square() {
        let sq = [
            [0.0, 0.0, 0.0],
            [10.0, 0.0, 0.0],
            [10.0, 10.0, 0.0],
            [0.0, 10.0, 0.0],
            [0.0, 0.0, 0.0],
        ];
        let idx = PathIndex::new(&sq);
        assert_eq!(idx.distance([5.0, 1.0, 0.0]), 1.0);
        assert_eq!(idx.distance([5.0, 5.0, 0.0]), 5.0);
        assert_eq!(idx.distance([13.0, 14.0, 0.0]), 5.0);
        assert_eq!(idx.distance([5.0, 0.0, 2.0]), 2.0);
        assert_eq!(idx.distance([-100.0, 5.0, 0.0]), 100.0);
    }

    proptest! {
        #[test]
        fn index_agrees_with_brute_force(
            pts in prop::collection::vec((-50.0f64..50.0, -50.0f64..50.0, -1.0f64..1.0), 1..60),
            qs in prop::collection::vec((-80.0f64..80.0, -80.0f64..80.0, -3.0f64..3.0), 1..20),
        ) {
            let pts: Vec<[f64; 3]> = pts.into_iter().map(|(x, y, z)| [x, y, z]).collect();
            let idx = PathIndex::new(&pts);
            for (x, y, z) in qs {
                let q = [x, y, z];
                let (a, b) = (idx.distance(q), brute_force_distance(&pts, q));
                prop_assert!((a - b).abs() <= 1e-9 * (1.0 + b), "{} vs {}", a, b);
            }
        }
    }
}
