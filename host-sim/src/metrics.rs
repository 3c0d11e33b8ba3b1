//! What the paper's Tables 10-12 report, and the kinematics its Figures
//! 14-29 plot, computed from a simulated motion:
//!
//! - cycle time: from the start until the tool has arrived at the end;
//! - contour error ([`crate::contour_error`]) max, min and mean. The mean is
//!   weighted by the distance the tool travels (like a scanner sampling the
//!   cut groove at a fixed pitch, Table 5: 0.08 mm), so that a tool standing
//!   still does not weigh; `min` is over the samples where the tool moves;
//! - feed (tangential speed), tangential acceleration and jerk (the time
//!   derivatives of the speed), and each axis's acceleration and jerk, by
//!   finite differences of the actual positions at the interpolation period
//!   (what a controller's servo trace records). Linear acc/dec has
//!   acceleration steps, so its jerk is a spike of `Δa/Ts`: we report that
//!   as is, it is how such a trace looks.

use serde::Serialize;

use crate::contour_error::PathIndex;
use crate::machine::Motion;

/// Kinematics of a sampled motion: `speed[k]` is the mean speed over
/// `[k·Ts, (k+1)·Ts]`, etc.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Kinematics {
    /// Sample period, s.
    pub ts_s: f64,
    /// Axis velocities, mm/s.
    pub velocity_mm_per_s: Vec<[f64; 3]>,
    /// Tangential speed (feed), mm/s.
    pub speed_mm_per_s: Vec<f64>,
    /// Tangential acceleration, mm/s².
    pub tangential_acc_mm_per_s2: Vec<f64>,
    /// Tangential jerk, mm/s³.
    pub tangential_jerk_mm_per_s3: Vec<f64>,
    /// Axis accelerations, mm/s².
    pub axis_acc_mm_per_s2: Vec<[f64; 3]>,
    /// Axis jerks, mm/s³.
    pub axis_jerk_mm_per_s3: Vec<[f64; 3]>,
}

fn diff3(x: &[[f64; 3]], ts: f64) -> Vec<[f64; 3]> {
    x.windows(2)
        .map(|w| {
            [
                (w[1][0] - w[0][0]) / ts,
                (w[1][1] - w[0][1]) / ts,
                (w[1][2] - w[0][2]) / ts,
            ]
        })
        .collect()
}

fn diff1(x: &[f64], ts: f64) -> Vec<f64> {
    x.windows(2).map(|w| (w[1] - w[0]) / ts).collect()
}

impl Kinematics {
    /// Differentiate positions sampled every `ts_s`.
    pub fn of(pos: &[[f64; 3]], ts_s: f64) -> Self {
        let velocity = diff3(pos, ts_s);
        let speed: Vec<f64> = velocity
            .iter()
            .map(|v| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt())
            .collect();
        let tangential_acc = diff1(&speed, ts_s);
        let tangential_jerk = diff1(&tangential_acc, ts_s);
        let axis_acc = diff3(&velocity, ts_s);
        let axis_jerk = diff3(&axis_acc, ts_s);
        Kinematics {
            ts_s,
            velocity_mm_per_s: velocity,
            speed_mm_per_s: speed,
            tangential_acc_mm_per_s2: tangential_acc,
            tangential_jerk_mm_per_s3: tangential_jerk,
            axis_acc_mm_per_s2: axis_acc,
            axis_jerk_mm_per_s3: axis_jerk,
        }
    }
}

fn peak(x: &[f64]) -> f64 {
    x.iter().fold(0.0, |m, v| m.max(v.abs()))
}

fn peak3(x: &[[f64; 3]]) -> [f64; 3] {
    let mut m = [0.0f64; 3];
    for v in x {
        for a in 0..3 {
            m[a] = m[a].max(v[a].abs());
        }
    }
    m
}

/// One row of the paper-style table.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Metrics {
    /// Cycle time, s.
    pub cycle_time_s: f64,
    /// Largest contour error, mm.
    pub contour_error_max_mm: f64,
    /// Smallest contour error while the tool moves, mm.
    pub contour_error_min_mm: f64,
    /// Mean contour error, weighted by distance travelled, mm.
    pub contour_error_mean_mm: f64,
    /// Highest feed reached, mm/min.
    pub peak_feed_mm_per_min: f64,
    /// Peak tangential acceleration, mm/s².
    pub peak_tangential_acc_mm_per_s2: f64,
    /// Peak tangential jerk, mm/s³.
    pub peak_tangential_jerk_mm_per_s3: f64,
    /// Peak acceleration of X, Y, Z, mm/s².
    pub peak_axis_acc_mm_per_s2: [f64; 3],
    /// Peak jerk of X, Y, Z, mm/s³.
    pub peak_axis_jerk_mm_per_s3: [f64; 3],
    /// Largest peak axis acceleration over that axis's limit A
    /// (`[planner] axis_accel_max_mm_per_s2`).
    pub axis_acc_ratio: f64,
    /// Largest peak axis jerk over the jerk limit J
    /// (`[planner] jerk_max_mm_per_s3`).
    pub axis_jerk_ratio: f64,
    /// Time the tool runs at 99 % or more of the programmed feed (the F
    /// word capped by F_max, of the segment nearest the tool), s.
    pub time_at_feed_s: f64,
}

/// What [`Metrics::measure`] compares the motion with.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Reference<'a> {
    /// Programmed feed of each segment (point `i` to `i + 1`), mm/min;
    /// empty: `time_at_feed_s` is 0.
    pub programmed_mm_per_min: &'a [f64],
    /// Axis acceleration limits A, mm/s² (0: no ratio).
    pub accel_max_mm_per_s2: [f64; 3],
    /// Jerk limit J, mm/s³ (0: no ratio).
    pub jerk_max_mm_per_s3: f64,
}

/// Contour error of every actual sample, mm, and the nearest segment.
pub fn contour_errors(index: &PathIndex, motion: &Motion) -> (Vec<f64>, Vec<usize>) {
    motion
        .actual
        .iter()
        .map(|p| index.nearest_segment(*p))
        .unzip()
}

impl Metrics {
    /// Measure `motion` against the commanded path `index` and `reference`.
    pub fn measure(
        index: &PathIndex,
        motion: &Motion,
        reference: &Reference<'_>,
    ) -> (Self, Kinematics, Vec<f64>) {
        let (err, seg) = contour_errors(index, motion);
        let kin = Kinematics::of(&motion.actual, motion.ts_s);
        let mut at_feed = 0usize;
        if !reference.programmed_mm_per_min.is_empty() {
            for (k, v) in kin.speed_mm_per_s.iter().enumerate() {
                let i = seg[k + 1].min(reference.programmed_mm_per_min.len() - 1);
                if v * 60.0 >= 0.99 * reference.programmed_mm_per_min[i] {
                    at_feed += 1;
                }
            }
        }
        let acc = peak3(&kin.axis_acc_mm_per_s2);
        let jerk = peak3(&kin.axis_jerk_mm_per_s3);
        let ratio = |x: f64, lim: f64| if lim > 0.0 { x / lim } else { 0.0 };
        let (mut wsum, mut esum, mut emin) = (0.0, 0.0, f64::INFINITY);
        for (k, d) in kin.speed_mm_per_s.iter().enumerate() {
            let ds = d * motion.ts_s;
            if ds > 1e-9 {
                let e = 0.5 * (err[k] + err[k + 1]);
                wsum += ds;
                esum += ds * e;
                emin = emin.min(err[k + 1]);
            }
        }
        let mean = if wsum > 0.0 {
            esum / wsum
        } else {
            err.iter().sum::<f64>() / err.len().max(1) as f64
        };
        let m = Metrics {
            cycle_time_s: motion.cycle_time_s(),
            contour_error_max_mm: err.iter().copied().fold(0.0, f64::max),
            contour_error_min_mm: if emin.is_finite() { emin } else { 0.0 },
            contour_error_mean_mm: mean,
            peak_feed_mm_per_min: peak(&kin.speed_mm_per_s) * 60.0,
            peak_tangential_acc_mm_per_s2: peak(&kin.tangential_acc_mm_per_s2),
            peak_tangential_jerk_mm_per_s3: peak(&kin.tangential_jerk_mm_per_s3),
            peak_axis_acc_mm_per_s2: acc,
            peak_axis_jerk_mm_per_s3: jerk,
            axis_acc_ratio: (0..3)
                .map(|i| ratio(acc[i], reference.accel_max_mm_per_s2[i]))
                .fold(0.0, f64::max),
            axis_jerk_ratio: (0..3)
                .map(|i| ratio(jerk[i], reference.jerk_max_mm_per_s3))
                .fold(0.0, f64::max),
            time_at_feed_s: at_feed as f64 * motion.ts_s,
        };
        (m, kin, err)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinematics_of_a_parabola() {
        // x = ½·a·t² with a = 100 mm/s²: constant acceleration, zero jerk.
        let ts = 0.001;
        let pos: Vec<[f64; 3]> = (0..200)
            .map(|k| {
                let t = k as f64 * ts;
                [50.0 * t * t, 0.0, 0.0]
            })
            .collect();
        let k = Kinematics::of(&pos, ts);
        assert!(k
            .axis_acc_mm_per_s2
            .iter()
            .all(|a| (a[0] - 100.0).abs() < 1e-6));
        assert!(k.axis_jerk_mm_per_s3.iter().all(|j| j[0].abs() < 1e-3));
        assert!(k
            .tangential_acc_mm_per_s2
            .iter()
            .all(|a| (a - 100.0).abs() < 1e-6));
    }

    #[test]
    fn metrics_of_a_tool_offset_from_its_path() {
        // Commanded along x; the tool runs 0.01 mm beside it at 10 mm/s.
        let path = [[0.0; 3], [10.0, 0.0, 0.0]];
        let motion = Motion {
            ts_s: 0.01,
            commanded: vec![],
            actual: (0..=100).map(|k| [k as f64 * 0.1, 0.01, 0.0]).collect(),
        };
        let reference = Reference {
            programmed_mm_per_min: &[600.0],
            accel_max_mm_per_s2: [2000.0; 3],
            jerk_max_mm_per_s3: 50_000.0,
        };
        let (m, _, _) = Metrics::measure(&PathIndex::new(&path), &motion, &reference);
        assert!((m.time_at_feed_s - 1.0).abs() < 1e-12);
        assert!(m.axis_acc_ratio < 1e-6, "{}", m.axis_acc_ratio);
        assert!((m.cycle_time_s - 1.0).abs() < 1e-12);
        assert!((m.contour_error_max_mm - 0.01).abs() < 1e-12);
        assert!((m.contour_error_mean_mm - 0.01).abs() < 1e-12);
        assert!((m.contour_error_min_mm - 0.01).abs() < 1e-12);
        assert!((m.peak_feed_mm_per_min - 600.0).abs() < 1e-6);
    }
}
