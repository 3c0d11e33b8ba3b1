//! `blend`: LinuxCNC's trajectory planner in `G64 P… ` mode (path blending
//! within a tolerance; `src/emc/tp/` and `src/emc/task/emccanon.cc` of
//! LinuxCNC), written here from its description, in its trapezoidal
//! (not S-curve) mode, on host-sim's toolpaths.
//!
//! 1. **Naive CAM detector** (`emccanon.cc`, `linkable`/`see_segment`):
//!    consecutive feed moves are merged into one line while every merged
//!    point lies within `Q` of it (at most 100 points; a feed change or a
//!    rapid ends the chain). `G64 P` without `Q` uses `Q = P`
//!    (`interp_convert.cc`).
//! 2. **Corners** (`tp.c` `tpHandleBlendArc`, `tpSetupTangent`,
//!    `tpChooseBestBlend`; `blendmath.c`). At each junction of two lines:
//!    - an anti-parallel turn within 2° stops (exact stop);
//!    - the **tangent** option: keep the kink, at the speed whose
//!      direction change in one cycle stays within `kink_ratio` (0.1,
//!      `ARC_BLEND_KINK_RATIO`) of the axes' limits (`a_inst = v/Ts + a`,
//!      `acc_scale = max_i |a_inst·(u₂−u₁)|_i / A_i`; below the ratio the
//!      full speed, else `v·ratio/acc_scale`), both lines' acceleration
//!      lowered by the same share;
//!    - the **blend arc** (`blendInit3FromLineLine`, `blendComputeParameters`):
//!      with θ half the angle inside the corner (`acos(−u₁·u₂)/2`), the arc
//!      tangent to both lines whose middle is within `P` of the corner
//!      reaches `d_tol = cos θ·P/(1 − sin θ)` along each line, at most half
//!      of each line (`BLEND_DIST_FRACTION`, of what the previous corner
//!      left); `R_geom = tan θ·d`; `v_plan = min(√(a_n·R_geom), v_goal)`
//!      with `a_n = 0.866·a_max` (`BLEND_ACC_RATIO_NORMAL`, `a_max` the axes'
//!      limit in the arc's plane, `calculateInscribedDiameter`); the radius
//!      is then only as large as that speed needs,
//!      `R = max(v_plan²/a_n, R_blend)` with `R_blend` the "equivalent
//!      parabolic blend" (`t = min(√(2·a_max/2·d), v_plan)/(a_max/2)`,
//!      `R_blend = min(t·v_plan/φ, R_geom)`, φ the turn). On the arc the
//!      tangential acceleration is `0.5·a_max` (`BLEND_ACC_RATIO_TANGENTIAL`).
//!      A line left shorter than 4 cycles at `v_plan` (`ARC_BLEND_GAP_CYCLES`)
//!      becomes part of the arc segment (`blendCheckConsume`);
//!    - whichever of tangent and arc allows the higher speed is used
//!      (`tpChooseBestBlend`; its third option, parabolic blending, is not
//!      modelled).
//! 3. **Speed limits per segment** (`tpComputeOptimalVelocity`): the
//!    programmed feed (× `max_feed_scale`, the override the arcs are sized
//!    for) and the axes' speeds along a line; no segment shorter than
//!    1.02 cycles (`TP_MIN_SEGMENT_CYCLES`: `v ≤ L/(1.02·Ts)`).
//! 4. **Lookahead** (`tpRunOptimization`, "rising tide"): each segment's
//!    final speed is the backward pass `v_f² ≤ v_next_f² + 2·a·L` from a
//!    stop at most `optimization_depth` (50, `ARC_BLEND_OPTIMIZATION_DEPTH`)
//!    segments later, limited by both segments' maximum speeds and the
//!    kink speed.
//! 5. **Execution** (`tpCalculateTrapezoidalAccel`, `tcUpdateDistFromAccel`,
//!    `tpHandleSplitCycle`): every cycle the largest speed from which the
//!    segment's final speed can still be reached over the distance left
//!    (discrete-time, `v = −a·Ts/2 + √(v_f² + a(2·dx − v·Ts) + (a·Ts/2)²)`),
//!    at most the segment's maximum, reached with at most `a`; a segment
//!    ending within a cycle hands the rest of the cycle to the next one.
//!
//! Not modelled: feed override, spindle sync, arc-arc and line-arc blends
//! (host-sim's toolpaths are lines: G2/G3 already cut within the reader's
//! chord tolerance, so LinuxCNC's own arc segments are not used), the
//! S-curve planner, the task queue's size. A LinuxCNC configuration plans
//! for its `MAX_FEED_OVERRIDE`; we take 1.0 (configurable).

use anyhow::{bail, Result};
use serde::{Deserialize, Serialize};

use super::AxisLimits;

/// Settings of the `blend` method (`[methods.blend]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BlendSettings {
    /// Path tolerance P of `G64 P`, mm.
    pub tolerance_mm: f64,
    /// Naive-CAM tolerance Q of `G64 P Q`, mm (absent: Q = P).
    pub naive_cam_tolerance_mm: Option<f64>,
    /// `ARC_BLEND_OPTIMIZATION_DEPTH` (LinuxCNC default 50), segments.
    pub optimization_depth: usize,
    /// `ARC_BLEND_KINK_RATIO` (default 0.1).
    pub kink_ratio: f64,
    /// `ARC_BLEND_GAP_CYCLES` (default 4).
    pub gap_cycles: f64,
    /// The feed override the blends are sized for (`MAX_FEED_OVERRIDE`).
    pub max_feed_scale: f64,
}

impl Default for BlendSettings {
    fn default() -> Self {
        BlendSettings {
            tolerance_mm: 0.01,
            naive_cam_tolerance_mm: None,
            optimization_depth: 50,
            kink_ratio: 0.1,
            gap_cycles: 4.0,
            max_feed_scale: 1.0,
        }
    }
}

impl BlendSettings {
    /// Check the values.
    pub fn validate(&self) -> Result<()> {
        let ok = |x: f64, lo: f64, hi: f64| x.is_finite() && x >= lo && x <= hi;
        anyhow::ensure!(
            ok(self.tolerance_mm, 1e-6, 10.0),
            "methods.blend.tolerance_mm must be in [1e-6, 10]"
        );
        if let Some(q) = self.naive_cam_tolerance_mm {
            anyhow::ensure!(
                ok(q, 0.0, 10.0),
                "methods.blend.naive_cam_tolerance_mm must be in [0, 10]"
            );
        }
        anyhow::ensure!(
            (2..=100_000).contains(&self.optimization_depth),
            "methods.blend.optimization_depth must be in [2, 100000]"
        );
        anyhow::ensure!(
            ok(self.kink_ratio, 0.001, std::f64::consts::FRAC_1_SQRT_2),
            "methods.blend.kink_ratio must be in [0.001, 0.7071]"
        );
        anyhow::ensure!(
            ok(self.gap_cycles, 0.0, 1000.0),
            "methods.blend.gap_cycles must be in [0, 1000]"
        );
        anyhow::ensure!(
            ok(self.max_feed_scale, 0.1, 10.0),
            "methods.blend.max_feed_scale must be in [0.1, 10]"
        );
        Ok(())
    }

    fn q_mm(&self) -> f64 {
        self.naive_cam_tolerance_mm.unwrap_or(self.tolerance_mm)
    }
}

/// `BLEND_ACC_RATIO_TANGENTIAL`.
const ACC_RATIO_TANGENTIAL: f64 = 0.5;
/// `TP_MIN_SEGMENT_CYCLES`.
const MIN_SEGMENT_CYCLES: f64 = 1.02;
/// Most points the naive CAM detector chains.
const MAX_CHAIN: usize = 100;

type V3 = [f64; 3];

fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
fn scale(a: V3, k: f64) -> V3 {
    [a[0] * k, a[1] * k, a[2] * k]
}
fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn norm(a: V3) -> f64 {
    dot(a, a).sqrt()
}
fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// A programmed line after the naive CAM detector.
#[derive(Clone, Debug)]
struct Line {
    start: V3,
    end: V3,
    feed_mm_per_s: f64,
}

/// The naive CAM detector over `points` (feed of the block ending at each
/// point): merged lines.
fn merge(points: &[V3], feeds_mm_per_s: &[f64], q_mm: f64) -> Vec<Line> {
    let mut out = Vec::new();
    let mut base = points[0];
    let mut chain: Vec<V3> = Vec::new();
    let mut chain_feed = 0.0;
    let flush = |out: &mut Vec<Line>, base: &mut V3, chain: &mut Vec<V3>, feed: f64| {
        if let Some(&last) = chain.last() {
            out.push(Line {
                start: *base,
                end: last,
                feed_mm_per_s: feed,
            });
            *base = last;
            chain.clear();
        }
    };
    for i in 1..points.len() {
        let x = points[i];
        if norm(sub(x, chain.last().copied().unwrap_or(base))) < 1e-9 {
            continue;
        }
        let f = feeds_mm_per_s[i];
        let linkable =
            !chain.is_empty() && q_mm > 0.0 && f == chain_feed && chain.len() <= MAX_CHAIN && {
                let m = sub(x, base);
                let mm = dot(m, m);
                mm > 0.0
                    && chain.iter().all(|&p| {
                        let t = (dot(m, sub(p, base)) / mm).clamp(0.0, 1.0);
                        norm(sub(p, add(base, scale(m, t)))) <= q_mm
                    })
            };
        if !chain.is_empty() && !linkable {
            flush(&mut out, &mut base, &mut chain, chain_feed);
        }
        chain.push(x);
        chain_feed = f;
    }
    flush(&mut out, &mut base, &mut chain, chain_feed);
    out
}

/// One segment of the planned path: an optional straight lead-in (a line
/// consumed by the blend) then an arc, or a plain line.
#[derive(Clone, Debug)]
enum Shape {
    Line {
        start: V3,
        dir: V3,
    },
    Arc {
        lead_start: V3,
        lead_dir: V3,
        lead_mm: f64,
        center: V3,
        /// Unit vector from the center to the arc's start.
        e1: V3,
        /// Unit vector in the arc's plane, 90° ahead of `e1`.
        e2: V3,
        radius: f64,
    },
}

#[derive(Clone, Debug)]
struct Segment {
    shape: Shape,
    length_mm: f64,
    max_speed: f64,
    accel: f64,
    /// Largest speed at the junction with the next segment (0: stop).
    exit_limit: f64,
}

impl Segment {
    fn at(&self, s: f64) -> V3 {
        match &self.shape {
            Shape::Line { start, dir } => add(*start, scale(*dir, s)),
            Shape::Arc {
                lead_start,
                lead_dir,
                lead_mm,
                center,
                e1,
                e2,
                radius,
            } => {
                if s < *lead_mm {
                    return add(*lead_start, scale(*lead_dir, s));
                }
                let phi = (s - lead_mm) / radius;
                add(
                    *center,
                    add(
                        scale(*e1, radius * phi.cos()),
                        scale(*e2, radius * phi.sin()),
                    ),
                )
            }
        }
    }
}

/// A corner between two lines as LinuxCNC resolves it.
enum Corner {
    /// Exact stop.
    Stop,
    /// Kink kept at `speed`; both lines' acceleration × (1 − `reduce`).
    Tangent { speed: f64, reduce: f64 },
    /// Blend arc: trimmed `d` along both lines, radius, speed.
    Arc {
        d: f64,
        radius: f64,
        speed: f64,
        a_max: f64,
    },
}

/// Largest acceleration in the plane with unit normal `n` the axes allow
/// (`calculateInscribedDiameter`).
fn planar_limit(n: V3, max: V3) -> f64 {
    let mut best = f64::MAX;
    for i in 0..3 {
        let scale_i = (1.0 - n[i] * n[i]).max(0.0).sqrt().max(1e-12);
        if max[i] > 0.0 {
            best = best.min(max[i] / scale_i);
        }
    }
    best
}

/// Resolve the corner between `l1` (length left after its own start trim:
/// `l1_left`, nominal length `l1_len`) and `l2`.
#[allow(clippy::too_many_arguments)]
fn corner(
    u1: V3,
    u2: V3,
    v1: f64,
    v2: f64,
    a2: f64,
    l1_left: f64,
    l1_len: f64,
    l2_len: f64,
    s: &BlendSettings,
    lim: &AxisLimits,
    ts: f64,
) -> Corner {
    let c = dot(u1, u2).clamp(-1.0, 1.0);
    // Anti-parallel within 2° (small-angle test of `pmCartCartAntiParallel`).
    let sharp = (std::f64::consts::PI * 2.0 / 180.0).powi(2);
    if norm(add(u1, u2)).powi(2) < sharp {
        return Corner::Stop;
    }
    // Tangent (kink) option.
    let v_max = v1.min(v2);
    let a_inst = v_max / ts + a2;
    let diff = scale(sub(u2, u1), a_inst);
    let acc_scale = (0..3)
        .map(|i| {
            if lim.accel_mm_per_s2[i] > 0.0 {
                diff[i].abs() / lim.accel_mm_per_s2[i]
            } else {
                0.0
            }
        })
        .fold(0.0, f64::max);
    if acc_scale < s.kink_ratio {
        return Corner::Tangent {
            speed: v_max,
            reduce: acc_scale,
        };
    }
    let tangent = Corner::Tangent {
        speed: v_max * s.kink_ratio / acc_scale,
        reduce: s.kink_ratio,
    };
    let tangent_speed = v_max * s.kink_ratio / acc_scale;
    // Blend arc.
    let theta = (-c).acos() / 2.0;
    if std::f64::consts::FRAC_PI_2 - theta < 1e-6 || theta < 1e-6 {
        return tangent;
    }
    let phi = std::f64::consts::PI - 2.0 * theta;
    let binormal = {
        let b = cross(u1, u2);
        let n = norm(b);
        if n < 1e-12 {
            return tangent;
        }
        scale(b, 1.0 / n)
    };
    let a_max = planar_limit(binormal, lim.accel_mm_per_s2);
    let a_n = a_max * (1.0 - ACC_RATIO_TANGENTIAL * ACC_RATIO_TANGENTIAL).sqrt();
    let v_planar = planar_limit(binormal, lim.speed_mm_per_s);
    let v_goal = (v1.max(v2) * s.max_feed_scale).min(v_planar);
    let l1 = l1_left.min(l1_len * 0.5);
    let l2 = l2_len * 0.5;
    let h_tol = s.tolerance_mm / (1.0 - theta.sin());
    let d_tol = theta.cos() * h_tol;
    let d_geom = l1.min(l2).min(d_tol);
    let r_geom = theta.tan() * d_geom;
    let v_plan = (a_n * r_geom).sqrt().min(v_goal);
    let a_par = a_max * 0.5;
    let v_tri = (2.0 * a_par * d_geom).sqrt();
    let t_blend = v_tri.min(v_plan) / a_par;
    let r_blend = (t_blend * v_plan / phi).min(r_geom);
    let radius = (v_plan * v_plan / a_n).max(r_blend);
    if radius < 1e-9 || radius * phi < 1e-6 || !radius.is_finite() {
        return tangent;
    }
    if tangent_speed >= v_plan {
        return tangent;
    }
    Corner::Arc {
        d: radius / theta.tan(),
        radius,
        speed: v_plan,
        a_max,
    }
}

/// The planned segments of `lines`.
fn segments(lines: &[Line], s: &BlendSettings, lim: &AxisLimits, ts: f64) -> Vec<Segment> {
    let n = lines.len();
    let dir: Vec<V3> = lines
        .iter()
        .map(|l| scale(sub(l.end, l.start), 1.0 / norm(sub(l.end, l.start))))
        .collect();
    let len: Vec<f64> = lines.iter().map(|l| norm(sub(l.end, l.start))).collect();
    let speed: Vec<f64> = (0..n)
        .map(|i| {
            lines[i]
                .feed_mm_per_s
                .min(AxisLimits::along(lim.speed_mm_per_s, dir[i]))
        })
        .collect();
    let accel: Vec<f64> = (0..n)
        .map(|i| AxisLimits::along(lim.accel_mm_per_s2, dir[i]))
        .collect();
    // Corners first (each needs what the previous left of the line).
    let mut trim_start = vec![0.0f64; n];
    let mut trim_end = vec![0.0f64; n];
    let mut reduce = vec![0.0f64; n];
    let mut corners: Vec<Corner> = Vec::with_capacity(n.saturating_sub(1));
    for j in 0..n.saturating_sub(1) {
        let c = corner(
            dir[j],
            dir[j + 1],
            speed[j],
            speed[j + 1],
            accel[j + 1],
            len[j] - trim_start[j],
            len[j],
            len[j + 1],
            s,
            lim,
            ts,
        );
        match &c {
            Corner::Arc { d, .. } => {
                trim_end[j] = *d;
                trim_start[j + 1] = *d;
            }
            Corner::Tangent { reduce: r, .. } => {
                reduce[j] = reduce[j].max(*r);
                reduce[j + 1] = reduce[j + 1].max(*r);
            }
            Corner::Stop => {}
        }
        corners.push(c);
    }
    // Segments: line remainders and arcs (a short remainder joins the arc
    // after it).
    let mut out: Vec<Segment> = Vec::with_capacity(2 * n);
    let mut pending_lead: Option<(V3, V3, f64)> = None;
    for j in 0..n {
        let a_line = accel[j] * (1.0 - reduce[j]);
        let start = add(lines[j].start, scale(dir[j], trim_start[j]));
        let rest = (len[j] - trim_start[j] - trim_end[j]).max(0.0);
        let next_arc = match corners.get(j) {
            Some(Corner::Arc { speed, .. }) => Some(*speed),
            _ => None,
        };
        let consume = next_arc.is_some_and(|v| rest / v < s.gap_cycles * ts);
        if consume {
            pending_lead = Some((start, dir[j], rest));
        } else if rest > 1e-12 {
            let exit_limit = match corners.get(j) {
                None | Some(Corner::Stop) => 0.0,
                Some(Corner::Tangent { speed: k, .. }) => k.min(speed[j]).min(speed[j + 1]),
                Some(Corner::Arc { speed: v, .. }) => v.min(speed[j]),
            };
            out.push(Segment {
                shape: Shape::Line { start, dir: dir[j] },
                length_mm: rest,
                max_speed: speed[j],
                accel: a_line,
                exit_limit,
            });
        }
        if let Some(Corner::Arc {
            d,
            radius,
            speed: v,
            a_max,
        }) = corners.get(j)
        {
            let p = lines[j].end;
            let a0 = sub(p, scale(dir[j], *d));
            // Center along the bisector (u₂ − u₁), at R/sin θ from the corner.
            let bis = sub(dir[j + 1], dir[j]);
            let bis = scale(bis, 1.0 / norm(bis));
            let theta = (-dot(dir[j], dir[j + 1]).clamp(-1.0, 1.0)).acos() / 2.0;
            let center = add(p, scale(bis, radius / theta.sin()));
            let e1 = scale(sub(a0, center), 1.0 / radius);
            let e2 = dir[j];
            let phi = std::f64::consts::PI - 2.0 * theta;
            let (lead_start, lead_dir, lead_mm) = pending_lead.take().unwrap_or((a0, dir[j], 0.0));
            let length = lead_mm + radius * phi;
            let exit_limit = v.min(speed[j + 1]);
            out.push(Segment {
                shape: Shape::Arc {
                    lead_start,
                    lead_dir,
                    lead_mm,
                    center,
                    e1,
                    e2,
                    radius: *radius,
                },
                length_mm: length,
                max_speed: *v,
                accel: a_max * ACC_RATIO_TANGENTIAL,
                exit_limit,
            });
        }
    }
    // A lead-in left over (no arc followed) stays a line.
    if let Some((start, d, l)) = pending_lead {
        out.push(Segment {
            shape: Shape::Line { start, dir: d },
            length_mm: l,
            max_speed: speed[n - 1],
            accel: accel[n - 1],
            exit_limit: 0.0,
        });
    }
    // No segment shorter than 1.02 cycles.
    for seg in &mut out {
        seg.max_speed = seg.max_speed.min(seg.length_mm / (ts * MIN_SEGMENT_CYCLES));
    }
    // Junction limits cannot exceed either side's maximum.
    for k in 0..out.len() {
        let next_max = out.get(k + 1).map_or(0.0, |s| s.max_speed);
        let seg = &mut out[k];
        seg.exit_limit = seg.exit_limit.min(seg.max_speed).min(next_max);
    }
    out
}

/// Final speed of each segment: the backward pass from a stop at most
/// `depth` segments later (`tpRunOptimization`).
fn final_speeds(segs: &[Segment], depth: usize) -> Vec<f64> {
    let n = segs.len();
    let mut out = vec![0.0; n];
    for (i, slot) in out.iter_mut().enumerate() {
        let end = (i + depth).min(n - 1);
        let mut v = 0.0f64; // at the end of segment `end`
        for k in (i + 1..=end).rev() {
            // v: final speed of k; entry of k = final speed of k − 1.
            let entry = (v * v + 2.0 * segs[k].accel * segs[k].length_mm).sqrt();
            v = entry.min(segs[k - 1].exit_limit);
        }
        *slot = if end == i { 0.0 } else { v };
    }
    out
}

/// The commanded positions every `ts_s` (from `t = 0`, the last one at the
/// end) of LinuxCNC's blending planner on `points` with the feed of each
/// block `feeds_mm_per_min[i]` (block ending at point `i`).
pub fn commanded(
    points: &[[f64; 3]],
    feeds_mm_per_min: &[f64],
    settings: &BlendSettings,
    limits: &AxisLimits,
    ts_s: f64,
) -> Result<Vec<[f64; 3]>> {
    settings.validate()?;
    anyhow::ensure!(points.len() == feeds_mm_per_min.len(), "one feed per point");
    let Some(&first) = points.first() else {
        bail!("empty path")
    };
    let feeds: Vec<f64> = feeds_mm_per_min.iter().map(|f| f / 60.0).collect();
    let lines = merge(points, &feeds, settings.q_mm());
    if lines.is_empty() {
        return Ok(vec![first]);
    }
    let segs = segments(&lines, settings, limits, ts_s);
    let finals = final_speeds(&segs, settings.optimization_depth);
    let total: f64 = segs.iter().map(|s| s.length_mm).sum();
    let limit = 10_000_000 + (total / ts_s) as usize;
    let mut out = vec![first];
    let (mut k, mut progress, mut v) = (0usize, 0.0f64, 0.0f64);
    while k < segs.len() {
        let mut t = ts_s;
        while t > 1e-15 && k < segs.len() {
            let seg = &segs[k];
            let a = seg.accel;
            let vf = finals[k];
            let dx = seg.length_mm - progress;
            // Largest speed after this cycle that can still reach vf over dx.
            let half = a * t * 0.5;
            let discr = vf * vf + a * (2.0 * dx - v * t) + half * half;
            let max_new = if discr > half * half {
                -half + discr.sqrt()
            } else {
                -half
            };
            let new_v = max_new.min(seg.max_speed).max(0.0);
            let acc = ((new_v - v) / t).clamp(-a, a);
            let v_end = (v + acc * t).max(0.0);
            let ds = 0.5 * (v + v_end) * t;
            if ds >= dx {
                // The segment ends within the cycle: time to its end.
                let t_end = if acc.abs() > 1e-12 {
                    let disc = (v * v + 2.0 * acc * dx).max(0.0);
                    ((disc.sqrt() - v) / acc).clamp(0.0, t)
                } else if v > 0.0 {
                    (dx / v).min(t)
                } else {
                    t
                };
                v = (v + acc * t_end).max(0.0);
                t -= t_end.max(1e-12);
                k += 1;
                progress = 0.0;
            } else {
                progress += ds;
                v = v_end;
                t = 0.0;
            }
        }
        let pos = match segs.get(k) {
            Some(seg) => seg.at(progress),
            None => *points.last().unwrap_or(&first),
        };
        out.push(pos);
        if out.len() > limit {
            bail!("blend: the tool did not arrive within {limit} cycles");
        }
    }
    // The planned path ends at the last line's end.
    if let Some(l) = lines.last() {
        if let Some(p) = out.last_mut() {
            *p = l.end;
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contour_error::PathIndex;

    fn limits() -> AxisLimits {
        AxisLimits {
            accel_mm_per_s2: [2000.0; 3],
            speed_mm_per_s: [1000.0; 3],
        }
    }

    #[test]
    fn naive_cam_merges_points_within_q() {
        // Points 0.001 mm off a line merge with Q = 0.01, not with Q = 0.0005.
        let pts: Vec<V3> = (0..=50)
            .map(|i| [i as f64, if i % 2 == 1 { 0.001 } else { 0.0 }, 0.0])
            .collect();
        let f = vec![50.0; pts.len()];
        assert_eq!(merge(&pts, &f, 0.01).len(), 1);
        assert_eq!(merge(&pts, &f, 0.0005).len(), 50);
        // A feed change ends a chain.
        let mut f2 = f.clone();
        f2[30] = 20.0;
        assert!(merge(&pts, &f2, 0.01).len() >= 3);
    }

    #[test]
    fn a_corner_is_blended_within_the_tolerance_and_the_end_is_reached() {
        let pts = vec![[0.0, 0.0, 0.0], [20.0, 0.0, 0.0], [20.0, 20.0, 0.0]];
        let idx = PathIndex::new(&pts);
        for p in [0.001, 0.01, 0.05] {
            let s = BlendSettings {
                tolerance_mm: p,
                ..Default::default()
            };
            let pos = commanded(&pts, &[3000.0; 3], &s, &limits(), 0.001).unwrap();
            let dev = pos.iter().map(|q| idx.distance(*q)).fold(0.0, f64::max);
            assert!(dev <= p * (1.0 + 1e-9), "P {p}: deviation {dev}");
            assert!(
                dev > 0.2 * p,
                "P {p}: the arc should use the tolerance ({dev})"
            );
            assert_eq!(*pos.last().unwrap(), [20.0, 20.0, 0.0]);
            // Speed never above the feed; acceleration within √2·A (the
            // tangential and normal shares on the arc).
            let v: Vec<V3> = pos
                .windows(2)
                .map(|w| scale(sub(w[1], w[0]), 1000.0))
                .collect();
            assert!(v.iter().all(|x| norm(*x) <= 50.0 + 1e-6));
            let a = v
                .windows(2)
                .map(|w| norm(scale(sub(w[1], w[0]), 1000.0)))
                .fold(0.0, f64::max);
            assert!(a <= 2000.0 * 1.05, "P {p}: {a}");
        }
    }

    #[test]
    fn a_larger_tolerance_passes_the_corner_faster() {
        let pts = vec![[0.0, 0.0, 0.0], [20.0, 0.0, 0.0], [20.0, 20.0, 0.0]];
        let time = |p: f64| {
            let s = BlendSettings {
                tolerance_mm: p,
                ..Default::default()
            };
            commanded(&pts, &[6000.0; 3], &s, &limits(), 0.001)
                .unwrap()
                .len()
        };
        assert!(time(0.05) < time(0.001) && time(0.01) <= time(0.001));
    }

    #[test]
    fn short_segments_cap_the_speed_at_one_segment_per_cycle() {
        // A zigzag of 0.02 mm segments (nothing to merge): at most
        // L/(1.02·Ts) ≈ 19.6 mm/s on each.
        let pts: Vec<V3> = (0..=500)
            .map(|i| [i as f64 * 0.02, if i % 2 == 1 { 0.005 } else { 0.0 }, 0.0])
            .collect();
        let s = BlendSettings {
            tolerance_mm: 0.001,
            ..Default::default()
        };
        let pos = commanded(&pts, &vec![3000.0; pts.len()], &s, &limits(), 0.001).unwrap();
        let seg = (0.02f64 * 0.02 + 0.005 * 0.005).sqrt();
        let peak = pos
            .windows(2)
            .map(|w| norm(sub(w[1], w[0])) / 0.001)
            .fold(0.0, f64::max);
        assert!(peak <= seg / 0.001 / 1.02 * 1.01, "{peak}");
    }
}
