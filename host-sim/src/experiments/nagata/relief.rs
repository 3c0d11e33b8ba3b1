//! A zigzag CL path over a generated relief (the paper's Fig. 2: a relief
//! design on a flat model, pick feed along y), standing in for the paper's
//! CAM output, which is not available.
//!
//! The relief on a 60 × 40 mm flat model: a dome (radius 8 mm, 3 mm high,
//! a sharp rim where it meets the base), a raised ring (radii 5-9 mm, 2 mm
//! high, 0.5 mm wide smooth edges) and a wavy band (0.8 mm sine, pitch
//! 7.9 mm) across the model, on a flat base at z = 0.
//!
//! Each row (y constant, alternating direction) is sampled every 0.05 mm and
//! reduced as a CAM's main processor does ("a linear approximation so that
//! the workpiece can be machined within a tolerance", section 3): a point is
//! emitted when the chord from the last emitted point would leave the
//! sampled profile by more than the tolerance (0.01 mm). Curved and edged
//! parts therefore get short segments, flat parts long ones: the property
//! the fuzzy feed generator reads. Consecutive rows are joined by a
//! pick-feed move along +y.

/// Parameters of the generated path.
#[derive(Clone, Debug, PartialEq)]
pub struct ReliefSpec {
    /// Model size along x (cutting direction), mm.
    pub width_mm: f64,
    /// Model size along y (pick-feed direction), mm.
    pub length_mm: f64,
    /// Pick feed (row spacing), mm.
    pub pick_feed_mm: f64,
    /// Chord tolerance of the linear approximation, mm.
    pub tolerance_mm: f64,
    /// Sampling step along a row, mm.
    pub sample_mm: f64,
}

impl Default for ReliefSpec {
    fn default() -> Self {
        ReliefSpec {
            width_mm: 60.0,
            length_mm: 40.0,
            pick_feed_mm: 1.0,
            tolerance_mm: 0.01,
            sample_mm: 0.05,
        }
    }
}

fn smoothstep(t: f64) -> f64 {
    let t = t.clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Height of the relief at `(x, y)`, mm.
pub fn height(x: f64, y: f64) -> f64 {
    // Dome at (15, 22): a paraboloid cap, sharp rim.
    let r1 = ((x - 15.0).powi(2) + (y - 22.0).powi(2)).sqrt();
    let dome = if r1 < 8.0 {
        3.0 * (1.0 - (r1 / 8.0).powi(2))
    } else {
        0.0
    };
    // Ring at (42, 22), radii 5-9 mm, 0.5 mm edges.
    let r2 = ((x - 42.0).powi(2) + (y - 22.0).powi(2)).sqrt();
    let ring = 2.0 * smoothstep((r2 - 5.0) / 0.5) * smoothstep((9.0 - r2) / 0.5);
    // Wavy band for 3 ≤ y ≤ 9.
    let band_w = smoothstep((y - 3.0) / 0.5) * smoothstep((9.0 - y) / 0.5);
    let band = band_w * (0.4 + 0.4 * (x * 0.8).sin());
    dome.max(ring).max(band)
}

/// Reduce the samples `pts` (x, z) of a row to the indices a CAM would
/// emit: greedy chords within `tol`.
fn reduce(pts: &[(f64, f64)], tol: f64) -> Vec<usize> {
    let mut out = vec![0];
    let mut a = 0;
    let n = pts.len();
    let mut b = a + 1;
    while b < n {
        // Can the chord a → b+1 stay within tol of every sample between?
        let c = b + 1;
        let ok = c < n && {
            let (xa, za) = pts[a];
            let (xc, zc) = pts[c];
            (a + 1..c).all(|k| {
                let (x, z) = pts[k];
                let t = (x - xa) / (xc - xa);
                (za + t * (zc - za) - z).abs() <= tol
            })
        };
        if ok {
            b = c;
        } else {
            out.push(b);
            a = b;
            b = a + 1;
        }
    }
    out
}

/// The CL points of the zigzag path: rows along x, pick feed along +y.
pub fn zigzag(spec: &ReliefSpec) -> anyhow::Result<Vec<[f64; 3]>> {
    let pos = |v: f64| v.is_finite() && v > 0.0;
    anyhow::ensure!(
        pos(spec.width_mm) && pos(spec.length_mm) && spec.width_mm <= 1000.0,
        "model size must be positive (width ≤ 1000 mm)"
    );
    anyhow::ensure!(
        pos(spec.pick_feed_mm) && spec.length_mm / spec.pick_feed_mm <= 10_000.0,
        "pick feed must be positive and give at most 10000 rows"
    );
    anyhow::ensure!(
        pos(spec.tolerance_mm) && pos(spec.sample_mm) && spec.width_mm / spec.sample_mm <= 1e5,
        "tolerance and sampling step must be positive (at most 1e5 samples a row)"
    );
    let rows = (spec.length_mm / spec.pick_feed_mm).floor() as usize + 1;
    let samples = (spec.width_mm / spec.sample_mm).ceil() as usize + 1;
    let mut out = Vec::new();
    for r in 0..rows {
        let y = r as f64 * spec.pick_feed_mm;
        let xs: Vec<f64> = (0..samples)
            .map(|i| (i as f64 * spec.sample_mm).min(spec.width_mm))
            .collect();
        let mut row: Vec<(f64, f64)> = xs.iter().map(|&x| (x, height(x, y))).collect();
        if r % 2 == 1 {
            row.reverse();
        }
        for i in reduce(&row, spec.tolerance_mm) {
            let (x, z) = row[i];
            out.push([x, y, z]);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_alternate_and_segments_follow_the_relief() {
        let spec = ReliefSpec::default();
        let p = zigzag(&spec).unwrap();
        assert_eq!(p[0], [0.0, 0.0, height(0.0, 0.0)]);
        // 41 rows, each from one edge to the other.
        let ys: Vec<f64> = p.iter().map(|q| q[1]).collect();
        let rows = ys.windows(2).filter(|w| w[1] != w[0]).count() + 1;
        assert_eq!(rows, 41);
        // Within tolerance at every sample along each row.
        for w in p.windows(2).filter(|w| w[0][1] == w[1][1]) {
            let (a, b) = (w[0], w[1]);
            let (lo, hi) = (a[0].min(b[0]), a[0].max(b[0]));
            let mut k = (lo / spec.sample_mm).round() as i64;
            while (k as f64) * spec.sample_mm < hi {
                let x = k as f64 * spec.sample_mm;
                let t = (x - a[0]) / (b[0] - a[0]);
                let z = a[2] + t * (b[2] - a[2]);
                assert!((z - height(x, a[1])).abs() <= 0.0101, "{a:?} {b:?} at {x}");
                k += 1;
            }
        }
        // A flat row is one segment; the row through the dome has short ones.
        let len = |w: &[[f64; 3]]| (w[1][0] - w[0][0]).abs();
        let flat: Vec<f64> = p
            .windows(2)
            .filter(|w| w[0][1] == 0.0 && w[1][1] == 0.0)
            .map(len)
            .collect();
        assert_eq!(flat, vec![60.0]);
        let dome: Vec<f64> = p
            .windows(2)
            .filter(|w| w[0][1] == 22.0 && w[1][1] == 22.0)
            .map(len)
            .collect();
        assert!(dome.iter().any(|d| *d < 0.5) && dome.iter().any(|d| *d > 5.0));
    }
}
