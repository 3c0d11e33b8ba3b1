//! Acceleration/deceleration after interpolation (Dat & Phuc 2024,
//! section 2.1, eq. 1-2; FANUC parameters 1622 and 1769): each axis's
//! commanded motion passes through its own filter, so a change of feed or
//! direction reaches the axis over the time constant `T` and the tool cuts
//! inside corners and curves.
//!
//! - **Linear**: the feed of an axis goes from its old to its new value in a
//!   straight line over `T` (the paper's eq. 1: `F(t) = F_b + (F_a − F_b)·
//!   (t − t_s)/(t_e − t_s)`, `t_e − t_s = T`). A step of velocity turned into
//!   a ramp of length `T` is a moving average of the velocity over `T`;
//!   averaging velocities over `T` averages positions over `T` too, which is
//!   what we compute (`N = round(T/Ts)` samples, O(1) per sample with a
//!   running sum).
//! - **Exponential**: first-order lag with time constant `T`, FANUC's other
//!   cutting-feed type, for comparison (discretised exactly:
//!   `x_f += (1 − e^{−Ts/T})·(x − x_f)`).
//!
//! Both filters start at rest at the first commanded position and run past
//! the last commanded sample until the axis has arrived (linear: exactly
//! `N − 1` more samples; exponential: until within 10 nm).

use serde::{Deserialize, Serialize};

/// Type of acc/dec after interpolation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum AccDecKind {
    /// Linear acc/dec (moving average of the axis velocity over `T`).
    Linear,
    /// Exponential acc/dec (first-order lag, time constant `T`).
    Exponential,
}

/// Filter each axis of `pos` (sampled every `ts_s`) with time constant
/// `t_s`. Returns the filtered samples, which run on past the input's end
/// until the axes arrive.
pub fn filter(kind: AccDecKind, pos: &[[f64; 3]], ts_s: f64, t_s: f64) -> Vec<[f64; 3]> {
    match kind {
        AccDecKind::Linear => moving_average(pos, (t_s / ts_s).round().max(1.0) as usize),
        AccDecKind::Exponential => exponential(pos, ts_s, t_s),
    }
}

/// Moving average over `n` samples, inputs before the first held at the
/// first and after the last held at the last; `len + n − 1` outputs.
pub fn moving_average(pos: &[[f64; 3]], n: usize) -> Vec<[f64; 3]> {
    let Some(&first) = pos.first() else {
        return Vec::new();
    };
    let last = pos[pos.len() - 1];
    if n <= 1 {
        return pos.to_vec();
    }
    let total = pos.len() + n - 1;
    let at = |k: isize| -> [f64; 3] {
        if k < 0 {
            first
        } else if k as usize >= pos.len() {
            last
        } else {
            pos[k as usize]
        }
    };
    // Sums relative to the first point keep the running sum small (exact
    // cancellation is not needed: the sum is refreshed every block of n).
    let mut out = Vec::with_capacity(total);
    let mut sum = [0.0f64; 3];
    for j in 0..n as isize {
        let p = at(j - n as isize + 1);
        for a in 0..3 {
            sum[a] += p[a] - first[a];
        }
    }
    let inv = 1.0 / n as f64;
    for k in 0..total as isize {
        if k > 0 {
            let (add, sub) = (at(k), at(k - n as isize));
            for a in 0..3 {
                sum[a] += (add[a] - first[a]) - (sub[a] - first[a]);
            }
            if k % (4 * n as isize) == 0 {
                // Refresh to stop rounding from accumulating.
                sum = [0.0; 3];
                for j in (k - n as isize + 1)..=k {
                    let p = at(j);
                    for a in 0..3 {
                        sum[a] += p[a] - first[a];
                    }
                }
            }
        }
        out.push([
            first[0] + sum[0] * inv,
            first[1] + sum[1] * inv,
            first[2] + sum[2] * inv,
        ]);
    }
    if let Some(l) = out.last_mut() {
        *l = last;
    }
    out
}

/// First-order lag with time constant `t_s`, run on until every axis is
/// within 10 nm of the last input.
pub fn exponential(pos: &[[f64; 3]], ts_s: f64, t_s: f64) -> Vec<[f64; 3]> {
    let Some(&first) = pos.first() else {
        return Vec::new();
    };
    let last = pos[pos.len() - 1];
    if t_s <= 0.0 {
        return pos.to_vec();
    }
    let g = 1.0 - (-ts_s / t_s).exp();
    let mut y = first;
    let mut out = Vec::with_capacity(pos.len() + (5.0 * t_s / ts_s) as usize);
    out.push(y);
    let step = |y: &mut [f64; 3], x: [f64; 3]| {
        for a in 0..3 {
            y[a] += g * (x[a] - y[a]);
        }
    };
    for &x in &pos[1..] {
        step(&mut y, x);
        out.push(y);
    }
    let max_extra = (40.0 * t_s / ts_s) as usize + 1;
    for _ in 0..max_extra {
        if (0..3).all(|a| (y[a] - last[a]).abs() < 1e-5) {
            break;
        }
        step(&mut y, last);
        out.push(y);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_acc_dec_turns_a_feed_step_into_a_ramp_of_length_t() {
        // Axis starts at 600 mm/min (10 mm/s) from rest: the filtered velocity
        // ramps linearly over T = 64 ms (eq. 1 of Dat & Phuc).
        let ts = 0.001;
        let pos: Vec<[f64; 3]> = (0..500).map(|k| [0.01 * k as f64, 0.0, 0.0]).collect();
        let out = filter(AccDecKind::Linear, &pos, ts, 0.064);
        assert_eq!(out.len(), 500 + 63);
        let v: Vec<f64> = out.windows(2).map(|w| (w[1][0] - w[0][0]) / ts).collect();
        for (k, vk) in v.iter().enumerate().take(64) {
            assert!(
                (vk - 10.0 * (k + 1) as f64 / 64.0).abs() < 1e-6,
                "{k}: {vk}"
            );
        }
        assert!((v[200] - 10.0).abs() < 1e-9);
        assert_eq!(*out.last().unwrap(), pos[499]);
    }

    #[test]
    fn exponential_reaches_63_percent_after_one_time_constant() {
        let pos: Vec<[f64; 3]> = std::iter::once([0.0; 3])
            .chain(std::iter::repeat_n([1.0, 0.0, 0.0], 200))
            .collect();
        let out = filter(AccDecKind::Exponential, &pos, 0.001, 0.011);
        assert!((out[11][0] - (1.0 - (-1.0f64).exp())).abs() < 1e-9);
        assert!((out.last().unwrap()[0] - 1.0).abs() < 1e-5);
    }

    #[test]
    fn moving_average_matches_the_direct_sum() {
        let pos: Vec<[f64; 3]> = (0..1000)
            .map(|k| {
                let t = k as f64 * 0.01;
                [1000.0 + t.sin() * 5.0, t.cos(), 0.1 * t]
            })
            .collect();
        let n = 17;
        let out = moving_average(&pos, n);
        for (k, got) in out.iter().enumerate() {
            let mut s = [0.0; 3];
            for j in 0..n {
                let i = (k as isize - j as isize).clamp(0, 999) as usize;
                for a in 0..3 {
                    s[a] += pos[i][a] / n as f64;
                }
            }
            for a in 0..3 {
                assert!((s[a] - got[a]).abs() < 1e-9, "{k} {a}");
            }
        }
    }
}
