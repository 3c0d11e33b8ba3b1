//! `grbl-like`: the planner of Grbl 1.1 (`grbl/planner.c`, `grbl/stepper.c`,
//! gnea/grbl), written here from its description, on host-sim's toolpaths:
//! every segment of the polyline is one planner block, and the executed
//! motion is sampled every interpolation period.
//!
//! What Grbl does, and where:
//!
//! - **Block** (`plan_buffer_line`): unit vector `u`, length, nominal speed
//!   = the programmed feed capped by the axes' speed limits along `u`
//!   (`limit_value_by_axis_maximum(settings.max_rate, unit_vec)`, at least
//!   `MINIMUM_FEED_RATE` = 1 mm/min), acceleration = the axes' limits along
//!   `u` (`limit_value_by_axis_maximum(settings.acceleration, unit_vec)`:
//!   `min_i A_i/|u_i|`, so a diagonal accelerates at up to `√2·A`).
//! - **Junction speed** (`plan_buffer_line`, "junction deviation"): with
//!   `cos θ = −u_prev·u` (θ the angle inside the corner), a circle tangent
//!   to both segments whose closest point is the deviation `δ` from the
//!   vertex has radius `R = δ·sin(θ/2)/(1 − sin(θ/2))`, and the junction
//!   speed is `v² = a_j·R` with `a_j` the axes' limit along `u − u_prev`
//!   ([`junction_speed_sqr`]). A straight continuation (`cos θ < −0.999999`)
//!   is unlimited, a reversal (`cos θ > 0.999999`) gets
//!   `MINIMUM_JUNCTION_SPEED` = 0. The first block after an empty buffer
//!   starts from rest. The entry limit is the smallest of the junction speed
//!   and both blocks' nominal speeds (`plan_compute_profile_parameters`).
//! - **Lookahead** (`planner_recalculate`, the rules of `planner.c:63-89`):
//!   each time a block is added, a reverse pass from the newest block (which
//!   must stop: exit speed 0) lowers every entry speed to what can still
//!   decelerate over the block, `v_entry² ≤ v_exit² + 2·a·L`, then a forward
//!   pass lowers it to what can be reached by accelerating,
//!   `v_exit² ≤ v_entry² + 2·a·L`. The block being executed takes part with
//!   its remaining length and the current speed as its entry
//!   (`st_update_plan_block_parameters`; `stepper.c` writes the remaining
//!   distance back into `pl_block->millimeters`). Grbl skips the part of the
//!   buffer its `block_buffer_planned` pointer marks as already optimal; the
//!   passes here run over the whole buffer, which gives the same plan.
//! - **Buffer**: `BLOCK_BUFFER_SIZE` = 16 (`planner.h`) is a ring whose head
//!   slot stays empty (`plan_check_full_buffer`), so it holds 15 blocks,
//!   the one executing included; a block leaves when the stepper has
//!   prepared its last segment (`plan_discard_current_block`) and the next
//!   one of the program enters at once (we assume the sender keeps the
//!   buffer full: a serial link at 115 200 baud is not modelled). So the
//!   tool can never go faster than it can stop within the buffered blocks:
//!   on 0.05 mm segments at 2000 mm/s², at most `√(2·A·15·0.05 mm)`.
//! - **Execution** (`st_prep_buffer`): the executing block follows the
//!   trapezoid from the current speed (accelerate at `a`, cruise at the
//!   nominal speed, decelerate at `a` to the next block's entry speed). Grbl
//!   cuts it into 10 ms segments of constant step rate
//!   (`ACCELERATION_TICKS_PER_SECOND` = 100); here the trapezoid is sampled
//!   exactly every interpolation period, carrying the rest of a period into
//!   the next block.
//!
//! Not modelled: feed overrides, hold, arcs (Grbl cuts G2/G3 into segments
//! itself, `mc_arc`; host-sim's toolpaths are already segments), steps and
//! AMASS. Grbl has no jerk limit; the machine's after-interpolation acc/dec
//! (the FANUC-like model) still applies, as for every other method.

use anyhow::{bail, Result};
use serde::{Deserialize, Serialize};

use super::AxisLimits;

/// Settings of the `grbl-like` method (`[methods.grbl_like]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GrblSettings {
    /// Junction deviation δ (Grbl's `$11`, default 0.010 mm), mm.
    pub junction_deviation_mm: f64,
    /// Grbl's `BLOCK_BUFFER_SIZE` (16): the ring holds one block fewer.
    pub block_buffer_size: usize,
}

impl Default for GrblSettings {
    fn default() -> Self {
        GrblSettings {
            junction_deviation_mm: 0.01,
            block_buffer_size: 16,
        }
    }
}

impl GrblSettings {
    /// Check the values.
    pub fn validate(&self) -> Result<()> {
        anyhow::ensure!(
            self.junction_deviation_mm.is_finite()
                && self.junction_deviation_mm > 0.0
                && self.junction_deviation_mm <= 10.0,
            "methods.grbl_like.junction_deviation_mm must be in (0, 10]"
        );
        anyhow::ensure!(
            (2..=100_000).contains(&self.block_buffer_size),
            "methods.grbl_like.block_buffer_size must be in [2, 100000]"
        );
        Ok(())
    }
}

/// Grbl's `MINIMUM_FEED_RATE` (1 mm/min), mm/s.
const MINIMUM_FEED_MM_PER_S: f64 = 1.0 / 60.0;

/// The junction speed² Grbl allows between a block along `prev_unit` and
/// one along `unit` (unit vectors), mm²/s²: `None` for an unlimited
/// (straight) junction. `accel_max` are the axes' limits, mm/s²; `δ` the
/// junction deviation, mm.
pub fn junction_speed_sqr(
    prev_unit: [f64; 3],
    unit: [f64; 3],
    accel_max: [f64; 3],
    deviation_mm: f64,
) -> Option<f64> {
    let cos_theta = -(0..3).map(|i| prev_unit[i] * unit[i]).sum::<f64>();
    if cos_theta > 0.999_999 {
        return Some(0.0);
    }
    if cos_theta < -0.999_999 {
        return None;
    }
    let d = [
        unit[0] - prev_unit[0],
        unit[1] - prev_unit[1],
        unit[2] - prev_unit[2],
    ];
    let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    let a = AxisLimits::along(accel_max, [d[0] / n, d[1] / n, d[2] / n]);
    let sin_half = (0.5 * (1.0 - cos_theta)).sqrt();
    Some((a * deviation_mm * sin_half / (1.0 - sin_half)).max(0.0))
}

/// One planner block (`plan_block_t`), in mm and mm/s.
#[derive(Clone, Debug)]
struct Block {
    start: [f64; 3],
    unit: [f64; 3],
    length_mm: f64,
    /// Remaining length (the executing block's shrinks).
    mm: f64,
    accel: f64,
    nominal_sqr: f64,
    max_entry_sqr: f64,
    entry_sqr: f64,
}

/// The buffer and the stream of blocks still to come.
struct Planner<'a> {
    blocks: std::collections::VecDeque<Block>,
    capacity: usize,
    source: std::iter::Peekable<Box<dyn Iterator<Item = Block> + 'a>>,
}

impl Planner<'_> {
    /// Fill the buffer from the program, re-planning after each block, as
    /// `plan_buffer_line` does.
    fn refill(&mut self) {
        while self.blocks.len() < self.capacity {
            let Some(b) = self.source.next() else { break };
            self.blocks.push_back(b);
            self.recalculate();
        }
    }

    /// `planner_recalculate` over the whole buffer (block 0 executing: its
    /// entry is the current speed and stays).
    fn recalculate(&mut self) {
        let n = self.blocks.len();
        if n < 2 {
            // A lone block stops at its end: nothing to plan.
            return;
        }
        // Reverse pass: the newest block stops at its end.
        let last = &mut self.blocks[n - 1];
        last.entry_sqr = last.max_entry_sqr.min(2.0 * last.accel * last.mm);
        for k in (1..n - 1).rev() {
            let next_entry = self.blocks[k + 1].entry_sqr;
            let b = &mut self.blocks[k];
            b.entry_sqr = b.max_entry_sqr.min(next_entry + 2.0 * b.accel * b.mm);
        }
        // Forward pass from the executing block.
        for k in 0..n - 1 {
            let (cur_entry, cur_accel, cur_mm) = {
                let b = &self.blocks[k];
                (b.entry_sqr, b.accel, b.mm)
            };
            let next = &mut self.blocks[k + 1];
            if cur_entry < next.entry_sqr {
                let reachable = cur_entry + 2.0 * cur_accel * cur_mm;
                if reachable < next.entry_sqr {
                    next.entry_sqr = reachable;
                }
            }
        }
    }

    /// Exit speed² of the executing block (`plan_get_exec_block_exit_speed_sqr`).
    fn exit_sqr(&self) -> f64 {
        self.blocks.get(1).map_or(0.0, |b| b.entry_sqr)
    }
}

/// Where the trapezoid of the rest of a block is after `t` seconds.
/// Returns (distance, speed, time used); the time used is less than `t`
/// only when the block ends first.
fn trapezoid(v0: f64, d: f64, v_nom: f64, v_exit: f64, a: f64, t: f64) -> (f64, f64, f64) {
    if d <= 0.0 {
        return (0.0, v0, 0.0);
    }
    // Peak speed of the accelerate-cruise-decelerate profile.
    let vp = v_nom
        .min(((2.0 * a * d + v0 * v0 + v_exit * v_exit) / 2.0).sqrt())
        .max(v_exit.min(v0));
    if v0 > vp {
        // Entered too fast for the rest (a re-plan lowered the exit):
        // decelerate uniformly to the exit over the rest.
        let a_dec = ((v0 * v0 - v_exit * v_exit) / (2.0 * d)).max(1e-12);
        let t_total = (v0 - v_exit) / a_dec;
        if t >= t_total {
            return (d, v_exit, t_total);
        }
        let s = v0 * t - 0.5 * a_dec * t * t;
        return (s.min(d), v0 - a_dec * t, t);
    }
    let (t1, s1) = ((vp - v0) / a, (vp * vp - v0 * v0) / (2.0 * a));
    let (t3, s3) = ((vp - v_exit) / a, (vp * vp - v_exit * v_exit) / (2.0 * a));
    let s2 = (d - s1 - s3).max(0.0);
    let t2 = if vp > 0.0 { s2 / vp } else { 0.0 };
    if t >= t1 + t2 + t3 {
        return (d, v_exit, t1 + t2 + t3);
    }
    if t <= t1 {
        return (v0 * t + 0.5 * a * t * t, v0 + a * t, t);
    }
    if t <= t1 + t2 {
        return (s1 + vp * (t - t1), vp, t);
    }
    let td = t - t1 - t2;
    let s = s1 + s2 + vp * td - 0.5 * a * td * td;
    (s.min(d), vp - a * td, t)
}

/// The commanded positions every `ts_s` (from `t = 0`, the last one at the
/// end of the path) of Grbl's planner running `points` with the feed of
/// each block `feeds_mm_per_min[i]` (block ending at point `i`).
pub fn commanded(
    points: &[[f64; 3]],
    feeds_mm_per_min: &[f64],
    settings: &GrblSettings,
    limits: &AxisLimits,
    ts_s: f64,
) -> Result<Vec<[f64; 3]>> {
    settings.validate()?;
    anyhow::ensure!(points.len() == feeds_mm_per_min.len(), "one feed per point");
    let Some(&first) = points.first() else {
        bail!("empty path")
    };
    let accel_max = limits.accel_mm_per_s2;
    let speed_max = limits.speed_mm_per_s;
    let deviation = settings.junction_deviation_mm;
    // Blocks of the program, built as `plan_buffer_line` would.
    let mut prev: Option<([f64; 3], f64)> = None; // unit, nominal speed
    let source = (1..points.len()).filter_map(move |i| {
        let (a, b) = (points[i - 1], points[i]);
        let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        if len < 1e-9 {
            return None; // Grbl drops blocks without steps.
        }
        let unit = [d[0] / len, d[1] / len, d[2] / len];
        let nominal = (feeds_mm_per_min[i] / 60.0)
            .min(AxisLimits::along(speed_max, unit))
            .max(MINIMUM_FEED_MM_PER_S);
        let max_junction_sqr = match prev {
            None => 0.0,
            Some((pu, _)) => junction_speed_sqr(pu, unit, accel_max, deviation).unwrap_or(f64::MAX),
        };
        let prev_nominal = prev.map_or(f64::MAX, |(_, n)| n);
        let max_entry_sqr = (nominal.min(prev_nominal)).powi(2).min(max_junction_sqr);
        prev = Some((unit, nominal));
        Some(Block {
            start: a,
            unit,
            length_mm: len,
            mm: len,
            accel: AxisLimits::along(accel_max, unit),
            nominal_sqr: nominal * nominal,
            max_entry_sqr,
            entry_sqr: 0.0,
        })
    });
    let boxed: Box<dyn Iterator<Item = Block> + '_> = Box::new(source);
    let mut p = Planner {
        blocks: Default::default(),
        capacity: settings.block_buffer_size - 1,
        source: boxed.peekable(),
    };
    p.refill();
    let length: f64 = points
        .windows(2)
        .map(|w| crate::toolpath::distance(w[0], w[1]))
        .sum();
    let limit = 10_000_000 + (length / ts_s) as usize;
    let mut out = vec![first];
    let mut v = 0.0f64;
    while !p.blocks.is_empty() {
        let mut t = ts_s;
        while t > 0.0 && !p.blocks.is_empty() {
            let exit = p.exit_sqr().sqrt();
            let b = &mut p.blocks[0];
            let (ds, v1, used) = trapezoid(v, b.mm, b.nominal_sqr.sqrt(), exit, b.accel, t);
            b.mm -= ds;
            v = v1;
            let done = b.mm <= 1e-12 || used < t;
            t -= used;
            if done {
                // Block done: discard it, the next program block enters.
                p.blocks.pop_front();
                if let Some(n) = p.blocks.front_mut() {
                    n.entry_sqr = v * v;
                }
                p.refill();
            }
        }
        let pos = match p.blocks.front() {
            Some(b) => {
                let s = b.length_mm - b.mm;
                [
                    b.start[0] + b.unit[0] * s,
                    b.start[1] + b.unit[1] * s,
                    b.start[2] + b.unit[2] * s,
                ]
            }
            None => *points.last().unwrap_or(&first),
        };
        out.push(pos);
        if out.len() > limit {
            bail!("grbl-like: the tool did not arrive within {limit} periods");
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits() -> AxisLimits {
        AxisLimits {
            accel_mm_per_s2: [2000.0; 3],
            speed_mm_per_s: [1000.0; 3],
        }
    }

    fn peak_speed(pos: &[[f64; 3]], ts: f64) -> f64 {
        pos.windows(2)
            .map(|w| crate::toolpath::distance(w[0], w[1]) / ts)
            .fold(0.0, f64::max)
    }

    #[test]
    fn junction_speed_is_grbls_formula() {
        // 90° corner from +X to +Y: θ = 90°, sin(θ/2) = √½, the velocity
        // change along (−1, 1)/√2 lets each axis give 2000: a_j = 2000·√2.
        let v2 = junction_speed_sqr([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [2000.0; 3], 0.01).unwrap();
        let s = 0.5f64.sqrt();
        let expected = 2000.0 * 2f64.sqrt() * 0.01 * s / (1.0 - s);
        assert!(
            (v2 - expected).abs() < 1e-9 * expected,
            "{v2} vs {expected}"
        );
        // A 30° turn (θ = 150°) along X/Y.
        let (c, sn) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
        let v2 = junction_speed_sqr(
            [1.0, 0.0, 0.0],
            [c, sn, 0.0],
            [2000.0, 1000.0, 2000.0],
            0.002,
        )
        .unwrap();
        let d = [c - 1.0, sn];
        let n = (d[0] * d[0] + d[1] * d[1]).sqrt();
        let a = (2000.0 / (d[0] / n).abs()).min(1000.0 / (d[1] / n).abs());
        let sh = (0.5 * (1.0 + c)).sqrt();
        assert!((v2 - a * 0.002 * sh / (1.0 - sh)).abs() < 1e-9);
        // Straight on: unlimited; reversal: zero.
        assert_eq!(
            junction_speed_sqr([1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2000.0; 3], 0.01),
            None
        );
        assert_eq!(
            junction_speed_sqr([1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [2000.0; 3], 0.01),
            Some(0.0)
        );
    }

    #[test]
    fn the_tool_passes_a_corner_at_the_junction_speed() {
        // Two 20 mm legs at 3000 mm/min: the speed at the vertex is the
        // junction speed (the slowest sample near it, within one period of
        // acceleration).
        let pts = vec![[0.0, 0.0, 0.0], [20.0, 0.0, 0.0], [20.0, 20.0, 0.0]];
        let feeds = vec![3000.0; 3];
        let pos = commanded(&pts, &feeds, &GrblSettings::default(), &limits(), 0.001).unwrap();
        assert_eq!(*pos.last().unwrap(), [20.0, 20.0, 0.0]);
        let vj = junction_speed_sqr([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [2000.0; 3], 0.01)
            .unwrap()
            .sqrt();
        let speeds: Vec<f64> = pos
            .windows(2)
            .map(|w| crate::toolpath::distance(w[0], w[1]) / 0.001)
            .collect();
        let mid = speeds.len() / 2;
        let slowest = speeds[mid - 200..mid + 200]
            .iter()
            .copied()
            .fold(f64::MAX, f64::min);
        assert!(
            (slowest - vj).abs() < 2000.0 * 0.001 * 1.5,
            "{slowest} vs {vj}"
        );
        assert!((peak_speed(&pos, 0.001) - 50.0).abs() < 1e-6);
    }

    #[test]
    fn sixteen_blocks_on_a_line_of_short_segments_cap_the_speed() {
        // 0.05 mm segments along X at 5000 mm/min, A = 2000 mm/s²: the 15
        // buffered blocks (0.70-0.75 mm ahead, the executing one partly
        // done) must stop, so the speed stays near √(2·A·0.75 mm), about
        // 3200 mm/min, well short of the programmed feed.
        let pts: Vec<[f64; 3]> = (0..=2000).map(|i| [i as f64 * 0.05, 0.0, 0.0]).collect();
        let feeds = vec![5000.0; pts.len()];
        let pos = commanded(&pts, &feeds, &GrblSettings::default(), &limits(), 0.001).unwrap();
        let peak = peak_speed(&pos, 0.001) * 60.0;
        let upper = (2.0 * 2000.0 * 15.0 * 0.05f64).sqrt() * 60.0;
        let lower = (2.0 * 2000.0 * 14.0 * 0.05f64).sqrt() * 60.0;
        assert!(
            peak <= upper + 1.0 && peak >= lower,
            "{peak} not in [{lower}, {upper}]"
        );
        // A bigger buffer reaches the feed.
        let big = GrblSettings {
            block_buffer_size: 256,
            ..Default::default()
        };
        let pos = commanded(&pts, &feeds, &big, &limits(), 0.001).unwrap();
        assert!((peak_speed(&pos, 0.001) * 60.0 - 5000.0).abs() < 1.0);
        assert_eq!(*pos.last().unwrap(), [100.0, 0.0, 0.0]);
    }

    #[test]
    fn acceleration_stays_within_the_axis_limits_along_a_line() {
        let pts = vec![[0.0, 0.0, 0.0], [30.0, 0.0, 0.0]];
        let pos = commanded(
            &pts,
            &[3000.0; 2],
            &GrblSettings::default(),
            &limits(),
            0.001,
        )
        .unwrap();
        let v: Vec<f64> = pos
            .windows(2)
            .map(|w| (w[1][0] - w[0][0]) / 0.001)
            .collect();
        let a_peak = v
            .windows(2)
            .map(|w| ((w[1] - w[0]) / 0.001).abs())
            .fold(0.0, f64::max);
        assert!(a_peak <= 2000.0 * (1.0 + 1e-6), "{a_peak}");
        // 30 mm at 50 mm/s plus the two ramps of 25 ms each way.
        let t = (pos.len() - 1) as f64 * 0.001;
        assert!((t - (30.0 / 50.0 + 50.0 / 2000.0)).abs() < 0.002, "{t}");
    }
}
