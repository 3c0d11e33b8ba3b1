//! Floating-point (`f64`) reference implementations, written independently
//! of the fixed-point code, for tests and host reports (feature `std`).
//!
//! - [`curvature`]: eq. 4-9 literally: chord lengths (eq. 5), the 2×2
//!   systems of eq. 7-8 solved with their inverse for each axis, eq. 9 from
//!   the derivatives; the same documented treatment of sharp turns and
//!   reversals as [`crate::curvature`].
//! - [`Mamdani`]: any [`SystemDef`] evaluated in `f64` from its parameters,
//!   MATLAB's membership functions, and the centroid as an exact integral of
//!   the piecewise-linear aggregate (breakpoints collected and integrated
//!   exactly; a different method from the fixed-point closed form) or, for
//!   Gaussian/bell outputs or on request, a sampled sum.
//! - [`schedule`]: the whole Lin et al. pipeline (curvature, window, fuzzy
//!   feed, average, caps) in `f64`.
//! - [`topp`]: the time-optimal traversal of a toolpath under the true
//!   per-axis limits, the yardstick of the velocity planner.

use crate::fuzzy::{
    AndMethod, Antecedent, Connective, Implication, Inference, MembershipFn, OrMethod,
    SugenoOutput, SystemDef,
};
use crate::scheduler::SchedulerConfig;

pub mod topp;

/// Curvature magnitude at `p2` of `p1 → p2 → p3` (1/mm) by eq. 4-9; `None`
/// for coincident points. Reversals give `f64::INFINITY`.
pub fn curvature(p1: [f64; 3], p2: [f64; 3], p3: [f64; 3]) -> Option<f64> {
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let norm = |a: [f64; 3]| (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    let (u, v) = (sub(p2, p1), sub(p3, p2));
    // Eq. 5.
    let (ta, tb) = (norm(u), norm(v));
    if ta == 0.0 || tb == 0.0 {
        return None;
    }
    // Eq. 7-8 for each axis: x1 = a1 − a2 ta + a3 ta², x3 = a1 + a2 tb + a3 tb²,
    // a1 = x2, i.e. [−ta ta²; tb tb²]·[a2; a3] = [x1 − x2; x3 − x2].
    let det = -ta * tb * tb - ta * ta * tb;
    let mut d1 = [0.0; 3]; // a2, b2, c2
    let mut d2 = [0.0; 3]; // a3, b3, c3
    for k in 0..3 {
        let (r1, r3) = (p1[k] - p2[k], p3[k] - p2[k]);
        d1[k] = (tb * tb * r1 - ta * ta * r3) / det;
        d2[k] = (-tb * r1 - ta * r3) / det;
    }
    // Eq. 9 (|r' × r''| / |r'|³ with r' = (a2, b2, c2), r'' = 2(a3, b3, c3)).
    let cross = [
        d1[1] * 2.0 * d2[2] - d1[2] * 2.0 * d2[1],
        d1[2] * 2.0 * d2[0] - d1[0] * 2.0 * d2[2],
        d1[0] * 2.0 * d2[1] - d1[1] * 2.0 * d2[0],
    ];
    let k9 = norm(cross) / norm(d1).powi(3);
    // Sharp turns and reversals, as documented in `crate::curvature`.
    let cos = (u[0] * v[0] + u[1] * v[1] + u[2] * v[2]) / (ta * tb);
    let sin = norm([
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ]) / (ta * tb);
    if sin == 0.0 {
        return Some(if cos > 0.0 { 0.0 } else { f64::INFINITY });
    }
    if cos < 0.0 {
        let tan_half = sin / (1.0 + cos);
        let corner = -cos * 2.0 * tan_half / ta.min(tb);
        return Some(k9.max(corner));
    }
    Some(k9)
}

/// MATLAB's membership functions in `f64`.
pub fn degree(mf: &MembershipFn, x: f64) -> f64 {
    let (p, _) = mf.params();
    let p: Vec<f64> = p.iter().map(|v| v.to_num::<f64>()).collect();
    match mf {
        MembershipFn::Triangle { .. } => {
            let (a, b, c) = (p[0], p[1], p[2]);
            if x == b {
                1.0
            } else if x <= a || x >= c {
                0.0
            } else if x < b {
                (x - a) / (b - a)
            } else {
                (c - x) / (c - b)
            }
        }
        MembershipFn::Trapezoid { .. } => {
            let (a, b, c, d) = (p[0], p[1], p[2], p[3]);
            let y1 = if x >= b {
                1.0
            } else if x < a {
                0.0
            } else {
                (x - a) / (b - a)
            };
            let y2 = if x <= c {
                1.0
            } else if x > d {
                0.0
            } else {
                (d - x) / (d - c)
            };
            y1.min(y2)
        }
        MembershipFn::Gaussian { .. } => (-(x - p[1]).powi(2) / (2.0 * p[0] * p[0])).exp(),
        MembershipFn::Bell { .. } => 1.0 / (1.0 + ((x - p[2]) / p[0]).abs().powf(2.0 * p[1])),
        MembershipFn::Constant(_) => 0.0,
    }
}

/// The vertices of a piecewise-linear membership function (`None` for
/// Gaussian and bell).
fn vertices(mf: &MembershipFn) -> Option<Vec<f64>> {
    let (p, n) = mf.params();
    match mf {
        MembershipFn::Triangle { .. } | MembershipFn::Trapezoid { .. } => {
            Some(p.iter().take(n).map(|v| v.to_num::<f64>()).collect())
        }
        _ => None,
    }
}

/// A [`SystemDef`] evaluated in `f64`.
pub struct Mamdani<'d, 'a, const NI: usize> {
    def: &'d SystemDef<'a, NI>,
}

impl<'d, 'a, const NI: usize> Mamdani<'d, 'a, NI> {
    /// The reference evaluator of `def`.
    pub fn new(def: &'d SystemDef<'a, NI>) -> Self {
        Mamdani { def }
    }

    /// Rule strengths per output term (inputs clamped to their universes).
    pub fn strengths(&self, x: [f64; NI]) -> Vec<f64> {
        let def = self.def;
        let mut s = vec![0.0f64; def.output.terms.len()];
        for r in def.rules {
            let mut acc: Option<f64> = None;
            for (i, a) in r.when.iter().enumerate() {
                let v = x[i].clamp(def.inputs[i].min.to_num(), def.inputs[i].max.to_num());
                let d = match a {
                    Antecedent::Any => continue,
                    Antecedent::Is(t) => degree(&def.inputs[i].terms[*t as usize].mf, v),
                    Antecedent::IsNot(t) => 1.0 - degree(&def.inputs[i].terms[*t as usize].mf, v),
                };
                acc = Some(match (acc, r.connective) {
                    (None, _) => d,
                    (Some(a), Connective::And) => match def.and {
                        AndMethod::Min => a.min(d),
                        AndMethod::Product => a * d,
                    },
                    (Some(a), Connective::Or) => match def.or {
                        OrMethod::Max => a.max(d),
                        OrMethod::ProbOr => a + d - a * d,
                    },
                });
            }
            let w = acc.unwrap_or(1.0) * r.weight.to_num::<f64>();
            let k = r.then as usize;
            match def.inference {
                Inference::Mamdani { .. } => s[k] = s[k].max(w),
                Inference::Sugeno { .. } => s[k] += w, // sums per constant
            }
        }
        s
    }

    fn aggregate(&self, s: &[f64], x: f64) -> f64 {
        let imp = match self.def.inference {
            Inference::Mamdani { implication } => implication,
            Inference::Sugeno { .. } => Implication::Min,
        };
        self.def
            .output
            .terms
            .iter()
            .zip(s)
            .map(|(t, &w)| {
                let m = degree(&t.mf, x);
                match imp {
                    Implication::Min => m.min(w),
                    Implication::Product => m * w,
                }
            })
            .fold(0.0, f64::max)
    }

    /// The output: exact centroid integral for piecewise-linear outputs,
    /// a 20 001-sample sum otherwise; Sugeno weighted average or sum. `None`
    /// when no rule fires.
    pub fn evaluate(&self, x: [f64; NI]) -> Option<f64> {
        let def = self.def;
        let s = self.strengths(x);
        if s.iter().all(|&w| w <= 0.0) {
            return None;
        }
        if let Inference::Sugeno { output } = def.inference {
            let consts: Vec<f64> = def
                .output
                .terms
                .iter()
                .map(|t| t.mf.params().0[0].to_num())
                .collect();
            let num: f64 = s.iter().zip(&consts).map(|(w, c)| w * c).sum();
            let den: f64 = s.iter().sum();
            return Some(match output {
                SugenoOutput::WeightedAverage => num / den,
                SugenoOutput::WeightedSum => num,
            });
        }
        let (lo, hi): (f64, f64) = (def.output.min.to_num(), def.output.max.to_num());
        let pwl: Option<Vec<Vec<f64>>> = def.output.terms.iter().map(|t| vertices(&t.mf)).collect();
        let prod = matches!(
            def.inference,
            Inference::Mamdani {
                implication: Implication::Product
            }
        );
        match pwl {
            Some(verts) if !prod => Some(self.exact_centroid(&s, &verts, lo, hi)),
            _ => self.sampled(x, 20_001),
        }
    }

    /// The centroid as MATLAB computes it: `n` equally spaced samples of the
    /// output range (eq. 11 as a finite sum).
    pub fn sampled(&self, x: [f64; NI], n: usize) -> Option<f64> {
        let s = self.strengths(x);
        let (lo, hi): (f64, f64) = (self.def.output.min.to_num(), self.def.output.max.to_num());
        let (mut num, mut den) = (0.0, 0.0);
        for i in 0..n {
            let v = lo + (hi - lo) * i as f64 / (n - 1) as f64;
            let u = self.aggregate(&s, v);
            num += v * u;
            den += u;
        }
        (den > 0.0).then(|| num / den)
    }

    /// ∫x·u/∫u for a piecewise-linear aggregate: between consecutive
    /// breakpoints (vertices, clip points, crossings of any two edges) the
    /// aggregate is linear, so the trapezoid rule on them is exact.
    fn exact_centroid(&self, s: &[f64], verts: &[Vec<f64>], lo: f64, hi: f64) -> f64 {
        let mut xs = vec![lo, hi];
        // Edges as (x0, y0, x1, y1), each term's clip line as a flat edge.
        let mut edges = Vec::new();
        for (v, &w) in verts.iter().zip(s) {
            if w <= 0.0 {
                continue;
            }
            let ys: Vec<f64> = if v.len() == 3 {
                vec![0.0, 1.0, 0.0]
            } else {
                vec![0.0, 1.0, 1.0, 0.0]
            };
            for j in 0..v.len() {
                xs.push(v[j]);
                if j + 1 < v.len() && v[j + 1] > v[j] {
                    edges.push((v[j], ys[j], v[j + 1], ys[j + 1]));
                }
            }
            edges.push((lo, w, hi, w));
        }
        for (i, a) in edges.iter().enumerate() {
            for b in &edges[i + 1..] {
                // Intersection of the two segments' lines within both spans.
                let (ka, kb) = ((a.3 - a.1) / (a.2 - a.0), (b.3 - b.1) / (b.2 - b.0));
                if (ka - kb).abs() < 1e-300 {
                    continue;
                }
                let x = (b.1 - a.1 + ka * a.0 - kb * b.0) / (ka - kb);
                if x > a.0.max(b.0) && x < a.2.min(b.2) {
                    xs.push(x);
                }
            }
        }
        xs.retain(|&x| x >= lo && x <= hi);
        xs.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
        xs.dedup();
        let (mut area, mut moment) = (0.0, 0.0);
        for w in xs.windows(2) {
            let (x0, x1) = (w[0], w[1]);
            // Just inside the interval, to avoid the vertical edges of
            // shoulders (MATLAB's value at a single point has no area).
            let eps = (x1 - x0) * 1e-12;
            let (y0, y1) = (self.aggregate(s, x0 + eps), self.aggregate(s, x1 - eps));
            let h = x1 - x0;
            area += h * (y0 + y1) / 2.0;
            moment += h * (y0 * (2.0 * x0 + x1) + y1 * (x0 + 2.0 * x1)) / 6.0;
        }
        moment / area
    }
}

/// One point of the `f64` pipeline.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefPoint {
    /// κ, 1/mm.
    pub curvature: f64,
    /// Dκ, 1/mm.
    pub variation: f64,
    /// Controller output (fraction of `F_max`).
    pub fraction: f64,
    /// Feed before the average filter, mm/min.
    pub fuzzy_feed: f64,
    /// Scheduled feed, mm/min.
    pub feed: f64,
}

/// The Lin et al. pipeline in `f64` over a whole path (duplicates already
/// removed), lookahead `ws`, centred average over `avg` feeds, optional
/// per-point caps (mm/min).
pub fn schedule<const NI: usize>(
    points: &[[f64; 3]],
    caps: &[Option<f64>],
    def: &SystemDef<'_, NI>,
    config: &SchedulerConfig,
    ws: usize,
    avg: usize,
) -> Vec<RefPoint> {
    let n = points.len();
    let mut k = vec![0.0; n];
    for i in 1..n.saturating_sub(1) {
        k[i] = curvature(points[i - 1], points[i], points[i + 1]).unwrap_or(0.0);
    }
    if n >= 3 {
        k[0] = k[1];
        k[n - 1] = k[n - 2];
    }
    let ctrl = Mamdani::new(def);
    let (f_max, f_min) = (config.f_max.to_f64(), config.f_min.to_f64());
    let (floor, clip) = (
        config.variation.floor.to_f64(),
        config.variation.clip.to_f64(),
    );
    let mut out: Vec<RefPoint> = (0..n)
        .map(|i| {
            let dk = k[i..(i + ws).min(n)].iter().copied().fold(0.0, f64::max);
            let dk_n = (dk.clamp(floor, clip) - floor) / (clip - floor);
            let mut x = [0.0; NI];
            x[0] = k[i].min(32767.0);
            if NI > 1 {
                x[1] = dk_n;
            }
            let fraction = ctrl
                .evaluate(x)
                .unwrap_or_else(|| def.default_output.to_num())
                .clamp(0.0, 1.0);
            let fuzzy_feed = (fraction * f_max).max(f_min);
            RefPoint {
                curvature: k[i],
                variation: dk,
                fraction,
                fuzzy_feed,
                feed: 0.0,
            }
        })
        .collect();
    let h = avg / 2;
    for i in 0..n {
        let (a, b) = (i.saturating_sub(h), (i + h).min(n - 1));
        let mean = out[a..=b].iter().map(|p| p.fuzzy_feed).sum::<f64>() / (b - a + 1) as f64;
        out[i].feed = match caps.get(i).copied().flatten() {
            Some(c) => mean.min(c),
            None => mean,
        };
    }
    out
}

/// The offline time-optimal traversal of a planned path under a tangential
/// acceleration limit (no jerk limit): forward-backward passes of
/// `v² <= v_next² + 2·A·ds` over a grid of step `ds_mm`, with the planner's
/// point ceilings at the points and its segment caps along the segments,
/// starting and ending at rest. The cycle time in seconds.
///
/// `points`: `(s_mm, ceiling_mm_s, cap_mm_s)` along the path (the cap of the
/// segment after the point).
pub fn time_optimal_s(points: &[(f64, f64, f64)], accel_mm_s2: f64, ds_mm: f64) -> f64 {
    let Some(&(s_end, _, _)) = points.last() else {
        return 0.0;
    };
    let m = ((s_end / ds_mm).ceil() as usize).max(1) + 1;
    let h = s_end / (m - 1) as f64;
    let mut cap = vec![f64::INFINITY; m];
    let mut seg = 0;
    for (k, c) in cap.iter_mut().enumerate() {
        let s = k as f64 * h;
        while seg + 1 < points.len() && points[seg + 1].0 <= s {
            seg += 1;
        }
        *c = points[seg].2;
    }
    for &(s, ceil, _) in points {
        let k = ((s / h).round() as usize).min(m - 1);
        cap[k] = cap[k].min(ceil);
    }
    let mut v2: Vec<f64> = cap.iter().map(|c| c * c).collect();
    v2[0] = 0.0;
    v2[m - 1] = 0.0;
    for k in (0..m - 1).rev() {
        v2[k] = v2[k].min(v2[k + 1] + 2.0 * accel_mm_s2 * h);
    }
    for k in 1..m {
        v2[k] = v2[k].min(v2[k - 1] + 2.0 * accel_mm_s2 * h);
    }
    let v: Vec<f64> = v2.iter().map(|x| x.sqrt()).collect();
    v.windows(2)
        .map(|w| h / ((w[0] + w[1]) / 2.0).max(1e-12))
        .sum()
}
