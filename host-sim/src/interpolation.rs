//! The CNC interpolator: commanded motion (a polyline and the tool's speed
//! along it) sampled at the interpolation period `Ts` into reference
//! positions, what a controller sends its axes every `Ts` (1 ms on FANUC
//! 30i-series controls by default; configurable).
//!
//! The speed along the path is a [`SpeedProfile`]: nodes `(s, v)` with
//! constant tangential acceleration between consecutive nodes (`v²` linear
//! in `s`), which represents exactly both
//! - a programmed feed per block (a step in `v` at every block end: two
//!   nodes at the same `s`), the "no acc/dec before interpolation" case, and
//! - a planned, acceleration-limited profile (acc/dec before interpolation).
//!
//! Sampling is exact (no integration error): the interpolator carries the
//! remainder of a period into the next block, so short blocks cost no
//! block-end stops.

use crate::toolpath::distance;

/// A polyline parameterised by arc length.
#[derive(Clone, Debug)]
pub struct Polyline<'a> {
    points: &'a [[f64; 3]],
    /// Cumulative arc length at each point, mm.
    cum_mm: Vec<f64>,
}

impl<'a> Polyline<'a> {
    /// The polyline through `points` (at least one).
    pub fn new(points: &'a [[f64; 3]]) -> Self {
        let mut cum_mm = Vec::with_capacity(points.len());
        let mut s = 0.0;
        cum_mm.push(0.0);
        for w in points.windows(2) {
            s += distance(w[0], w[1]);
            cum_mm.push(s);
        }
        Polyline { points, cum_mm }
    }

    /// Total length, mm.
    pub fn length_mm(&self) -> f64 {
        self.cum_mm.last().copied().unwrap_or(0.0)
    }

    /// Arc length at each point, mm.
    pub fn cumulative_mm(&self) -> &[f64] {
        &self.cum_mm
    }

    /// The points.
    pub fn points(&self) -> &[[f64; 3]] {
        self.points
    }

    /// Position at arc length `s` (clamped to the path). `cursor` is the
    /// block searched first and is advanced: monotone queries cost O(1)
    /// amortised.
    pub fn position_at(&self, s: f64, cursor: &mut usize) -> [f64; 3] {
        let n = self.points.len();
        if n == 1 || s <= 0.0 {
            return self.points[0];
        }
        if s >= self.length_mm() {
            return self.points[n - 1];
        }
        let mut i = (*cursor).clamp(1, n - 1);
        while i > 1 && self.cum_mm[i - 1] > s {
            i -= 1;
        }
        while i < n - 1 && self.cum_mm[i] < s {
            i += 1;
        }
        *cursor = i;
        let (s0, s1) = (self.cum_mm[i - 1], self.cum_mm[i]);
        let f = if s1 > s0 { (s - s0) / (s1 - s0) } else { 1.0 };
        let (a, b) = (self.points[i - 1], self.points[i]);
        [
            a[0] + f * (b[0] - a[0]),
            a[1] + f * (b[1] - a[1]),
            a[2] + f * (b[2] - a[2]),
        ]
    }
}

/// Tool speed along the path: nodes `(s mm, v mm/s)`, `s` non-decreasing,
/// constant acceleration between consecutive nodes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SpeedProfile {
    /// Arc length of each node, mm.
    pub s_mm: Vec<f64>,
    /// Speed at each node, mm/s.
    pub v_mm_per_s: Vec<f64>,
}

impl SpeedProfile {
    /// Constant feed on each block: block `i` (`p[i-1] → p[i]`, length from
    /// `cum_mm`) at `feeds_mm_per_min[i]` (index 0 unused), changing
    /// instantly at block ends. Feeds must be positive.
    pub fn per_block(cum_mm: &[f64], feeds_mm_per_min: &[f64]) -> Self {
        let mut p = SpeedProfile::default();
        for i in 1..cum_mm.len() {
            let v = feeds_mm_per_min[i] / 60.0;
            p.s_mm.push(cum_mm[i - 1]);
            p.v_mm_per_s.push(v);
            p.s_mm.push(cum_mm[i]);
            p.v_mm_per_s.push(v);
        }
        p
    }

    /// Time to run the profile, s.
    pub fn duration_s(&self) -> f64 {
        self.s_mm
            .windows(2)
            .zip(self.v_mm_per_s.windows(2))
            .map(|(s, v)| segment_time(s[1] - s[0], v[0], v[1]))
            .sum()
    }

    /// Arc length at `t = 0, Ts, 2Ts, …` up to and including the first
    /// sample at or after the end (which is clamped to the end).
    pub fn sample_s(&self, ts_s: f64) -> Vec<f64> {
        let n = self.s_mm.len();
        let total = self.duration_s();
        let samples = (total / ts_s).ceil() as usize + 1;
        let mut out = Vec::with_capacity(samples);
        let (mut seg, mut t_seg) = (0usize, 0.0f64); // segment `seg → seg+1` starts at t_seg
        let end_s = self.s_mm.last().copied().unwrap_or(0.0);
        for k in 0..samples {
            let t = k as f64 * ts_s;
            loop {
                if seg + 1 >= n {
                    out.push(end_s);
                    break;
                }
                let ds = self.s_mm[seg + 1] - self.s_mm[seg];
                let (va, vb) = (self.v_mm_per_s[seg], self.v_mm_per_s[seg + 1]);
                let dt = segment_time(ds, va, vb);
                if t <= t_seg + dt || !dt.is_finite() {
                    let tau = (t - t_seg).max(0.0);
                    let a = if ds > 0.0 {
                        (vb * vb - va * va) / (2.0 * ds)
                    } else {
                        0.0
                    };
                    let s = (va * tau + 0.5 * a * tau * tau).clamp(0.0, ds);
                    out.push(self.s_mm[seg] + s);
                    break;
                }
                t_seg += dt;
                seg += 1;
            }
        }
        if let Some(last) = out.last_mut() {
            *last = end_s;
        }
        out
    }
}

/// Time to cover `ds` mm from `va` to `vb` mm/s at constant acceleration.
fn segment_time(ds: f64, va: f64, vb: f64) -> f64 {
    if ds <= 0.0 {
        return 0.0;
    }
    let v = va + vb;
    if v <= 0.0 {
        return f64::INFINITY;
    }
    2.0 * ds / v
}

/// Reference positions at the interpolation period.
#[derive(Clone, Debug, PartialEq)]
pub struct Reference {
    /// Interpolation period, s.
    pub ts_s: f64,
    /// Commanded position at `t = k·Ts`, mm.
    pub pos: Vec<[f64; 3]>,
}

/// Sample `profile` along `poly` every `ts_s`.
pub fn interpolate(poly: &Polyline<'_>, profile: &SpeedProfile, ts_s: f64) -> Reference {
    let mut cursor = 1;
    let pos = profile
        .sample_s(ts_s)
        .into_iter()
        .map(|s| poly.position_at(s, &mut cursor))
        .collect();
    Reference { ts_s, pos }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn per_block_feeds_take_the_expected_time() {
        // 10 mm at 600 mm/min (1 s), then 10 mm at 1200 mm/min (0.5 s).
        let pts = [[0.0; 3], [10.0, 0.0, 0.0], [10.0, 10.0, 0.0]];
        let poly = Polyline::new(&pts);
        let prof = SpeedProfile::per_block(poly.cumulative_mm(), &[0.0, 600.0, 1200.0]);
        assert!((prof.duration_s() - 1.5).abs() < 1e-12);
        let r = interpolate(&poly, &prof, 0.001);
        assert_eq!(r.pos.len(), 1501);
        // The remainder of a period carries over the block end.
        let p = r.pos[1001];
        assert!(
            (p[0] - 10.0).abs() < 1e-9 && (p[1] - 0.02).abs() < 1e-9,
            "{p:?}"
        );
        assert_eq!(r.pos[1500], [10.0, 10.0, 0.0]);
    }

    #[test]
    fn constant_acceleration_segments_are_exact() {
        // 0 → 100 mm/s over 5 mm: a = 1000 mm/s², t = 0.1 s, s(t) = ½at².
        let prof = SpeedProfile {
            s_mm: vec![0.0, 5.0],
            v_mm_per_s: vec![0.0, 100.0],
        };
        assert!((prof.duration_s() - 0.1).abs() < 1e-12);
        let s = prof.sample_s(0.01);
        assert_eq!(s.len(), 11);
        for (k, sk) in s.iter().enumerate() {
            let t = k as f64 * 0.01;
            assert!((sk - 500.0 * t * t).abs() < 1e-9, "{k}: {sk}");
        }
    }

    #[test]
    fn position_lookup_goes_both_ways() {
        let pts = [[0.0; 3], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]];
        let poly = Polyline::new(&pts);
        let mut c = 1;
        assert_eq!(poly.position_at(1.5, &mut c), [1.0, 0.5, 0.0]);
        assert_eq!(poly.position_at(0.25, &mut c), [0.25, 0.0, 0.0]);
        assert_eq!(poly.position_at(9.0, &mut c), [1.0, 1.0, 0.0]);
        assert_eq!(poly.position_at(-1.0, &mut c), [0.0; 3]);
    }
}
