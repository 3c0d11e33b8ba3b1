//! The paper-style comparison: every toolpath × method × maximum feed on one
//! machine (Lin et al. Tables 10-12), the two claims of the abstract against
//! a constant feed, the same two figures for fuzzy + planner against the
//! planners a user would otherwise run, and the Pareto sweep.
//!
//! - **Equal cycle time**: the baseline's setting whose cycle time equals
//!   the fuzzy run's, and the ratio of the maximum contour errors
//!   (`E_fuzzy / E_baseline`; paper, against the constant feed: 1 − 0.43).
//! - **Equal accuracy**: the baseline's setting whose maximum contour error
//!   equals the fuzzy run's, and the ratio of the cycle times
//!   (`T_fuzzy / T_baseline`; paper: 1 − 0.49).
//!
//! The setting searched is the baseline's maximum feed (programmed F words
//! still cap it); where no feed matches (a baseline slower than the fuzzy
//! run at any feed, or whose error never gets as low or as high), its
//! tolerance is searched instead at the run's maximum feed (Grbl's junction
//! deviation, LinuxCNC's P), and where that fails too the figure is absent
//! and the reason is reported. Cycle time falls and the maximum contour
//! error rises with either setting; the search brackets the target by
//! halving/doubling and bisects (log scale) until the setting is known to
//! 0.1 %.
//!
//! The baselines of fuzzy + planner: `planner` (the same planner at the
//! programmed feed), `grbl-like` (δ = 0.01 and 0.002 mm by default) and
//! `blend` (P = 0.01 mm). The **Pareto sweep** runs every method over a
//! range of maximum feeds and records (cycle time, maximum contour error):
//! a method whose points lie left of and below another's dominates it.

use anyhow::Result;
use serde::Serialize;

use crate::config::SimConfig;
use crate::methods::{self, Method};
use crate::metrics::Metrics;
use crate::simulate::{self, Prepared, RunResult};

/// A method with its tolerance where it has one (Grbl's junction
/// deviation, LinuxCNC's P), mm.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Variant {
    /// The method.
    pub method: Method,
    /// Its tolerance, mm (`None`: the method has none, or the
    /// configuration's).
    pub tolerance_mm: Option<f64>,
}

impl Variant {
    /// A method without a tolerance override.
    pub fn plain(method: Method) -> Self {
        Variant {
            method,
            tolerance_mm: None,
        }
    }

    /// The configuration for this variant.
    pub fn config(&self, base: &SimConfig) -> SimConfig {
        match self.tolerance_mm {
            Some(t) => SimConfig {
                methods: self.method.with_tolerance(&base.methods, t),
                ..base.clone()
            },
            None => base.clone(),
        }
    }

    /// Name with its tolerance (as the configuration gives it).
    pub fn label(&self, base: &SimConfig) -> String {
        let t = self
            .tolerance_mm
            .or_else(|| self.method.tolerance_mm(&base.methods));
        simulate::label(self.method, t)
    }
}

/// `methods` with one variant per tolerance for `grbl-like` and `blend`.
pub fn variants(methods_: &[Method], grbl_mm: &[f64], blend_mm: &[f64]) -> Vec<Variant> {
    let mut out = Vec::new();
    for &m in methods_ {
        let tols = match m {
            Method::GrblLike => grbl_mm,
            Method::Blend => blend_mm,
            _ => &[][..],
        };
        if tols.is_empty() {
            out.push(Variant::plain(m));
        } else {
            out.extend(tols.iter().map(|&t| Variant {
                method: m,
                tolerance_mm: Some(t),
            }));
        }
    }
    out
}

/// One row of the table.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    /// Toolpath name.
    pub path: String,
    /// Method name.
    pub method: &'static str,
    /// The method's tolerance, mm.
    pub tolerance_mm: Option<f64>,
    /// Maximum feed, mm/min.
    pub f_max_mm_per_min: f64,
    /// The measurements.
    #[serde(flatten)]
    pub metrics: Metrics,
}

/// Which setting of a baseline matched.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Knob {
    /// Its maximum feed.
    Feed,
    /// Its tolerance, at the fuzzy run's maximum feed.
    Tolerance,
}

/// The baseline run matched to the fuzzy run in one respect.
#[derive(Clone, Debug, Serialize)]
pub struct Matched {
    /// Which setting was searched.
    pub knob: Knob,
    /// The baseline's maximum feed, mm/min.
    pub feed_mm_per_min: f64,
    /// The baseline's tolerance, mm (if it has one).
    pub tolerance_mm: Option<f64>,
    /// Its cycle time, s.
    pub cycle_time_s: f64,
    /// Its maximum contour error, mm.
    pub contour_error_max_mm: f64,
}

/// The two figures of one fuzzy run against one baseline.
#[derive(Clone, Debug, Serialize)]
pub struct Claim {
    /// Toolpath name.
    pub path: String,
    /// The fuzzy method (`fuzzy` or `fuzzy-planner`; the `fuzzy_*` fields
    /// are its figures).
    pub method: &'static str,
    /// The fuzzy run's maximum feed, mm/min.
    pub f_max_mm_per_min: f64,
    /// The baseline method.
    pub baseline: &'static str,
    /// The baseline's tolerance as configured (before any search), mm.
    pub baseline_tolerance_mm: Option<f64>,
    /// Fuzzy run's cycle time, s.
    pub fuzzy_cycle_time_s: f64,
    /// Fuzzy run's maximum contour error, mm.
    pub fuzzy_contour_error_max_mm: f64,
    /// The baseline's cycle time at the same maximum feed, s.
    pub baseline_cycle_time_s: f64,
    /// The baseline's maximum contour error at the same maximum feed, mm.
    pub baseline_contour_error_max_mm: f64,
    /// Baseline with the same cycle time (`None`: not reachable).
    pub equal_time: Option<Matched>,
    /// `E_fuzzy / E_baseline` at equal cycle time.
    pub error_ratio: Option<f64>,
    /// Baseline with the same maximum contour error (`None`: not
    /// reachable).
    pub equal_error: Option<Matched>,
    /// `T_fuzzy / T_baseline` at equal maximum contour error.
    pub time_ratio: Option<f64>,
    /// Where no setting gives the baseline the fuzzy run's cycle time
    /// because it is already at least as fast at the same maximum feed (and
    /// cannot go faster): `E_fuzzy / E_baseline` there, a lower bound of the
    /// error ratio.
    pub error_ratio_at_least: Option<f64>,
    /// Where no setting gives the baseline the fuzzy run's error because it
    /// is already at least as accurate at the same maximum feed:
    /// `T_fuzzy / T_baseline` there, a lower bound of the time ratio.
    pub time_ratio_at_least: Option<f64>,
}

impl Claim {
    /// `1 − E_fuzzy / E_baseline` at equal time (paper, against the
    /// constant feed: 0.43).
    pub fn error_reduction(&self) -> Option<f64> {
        self.error_ratio.map(|r| 1.0 - r)
    }

    /// `1 − T_fuzzy / T_baseline` at equal error (paper: 0.49).
    pub fn time_reduction(&self) -> Option<f64> {
        self.time_ratio.map(|r| 1.0 - r)
    }

    /// The baseline's label (name and tolerance).
    pub fn baseline_label(&self) -> String {
        match self.baseline_tolerance_mm {
            Some(t) => format!("{} {t}", self.baseline),
            None => self.baseline.to_string(),
        }
    }
}

/// (cycle time s, max contour error mm) of `variant` at `f` with the
/// tolerance `tol` (if given).
fn measure(
    prepared: &Prepared,
    variant: Variant,
    f: f64,
    tol: Option<f64>,
    config: &SimConfig,
) -> Result<(f64, f64)> {
    let v = Variant {
        tolerance_mm: tol.or(variant.tolerance_mm),
        ..variant
    };
    let r = simulate::run(prepared, v.method, f, &v.config(config))?;
    Ok((r.metrics.cycle_time_s, r.metrics.contour_error_max_mm))
}

/// Bisection (log scale) on a setting `x` in `[lo_bound, hi_bound]` for
/// `target` of the quantity picked by `error` (false: time, decreasing in
/// `x`; true: max contour error, increasing), bracketed from `hint` by
/// factors of `step`, until the bracket is narrower than the factor
/// `precision`. `None` when the target is outside what the setting
/// reaches.
#[allow(clippy::too_many_arguments)]
fn search(
    eval: &dyn Fn(f64) -> Result<(f64, f64)>,
    error: bool,
    target: f64,
    hint: f64,
    lo_bound: f64,
    hi_bound: f64,
    step: f64,
    precision: f64,
) -> Result<Option<(f64, f64, f64)>> {
    let q = |x: f64| -> Result<f64> {
        let v = eval(x)?;
        Ok(if error { v.1 } else { v.0 })
    };
    let below = |v: f64| if error { v < target } else { v > target };
    let (mut lo, mut hi) = (hint, hint);
    for _ in 0..60 {
        if below(q(lo)?) || lo <= lo_bound {
            break;
        }
        lo = (lo / step).max(lo_bound);
    }
    for _ in 0..60 {
        if !below(q(hi)?) || hi >= hi_bound {
            break;
        }
        hi = (hi * step).min(hi_bound);
    }
    if !below(q(lo)?) || below(q(hi)?) {
        return Ok(None);
    }
    while hi / lo > precision {
        let mid = (lo * hi).sqrt();
        if below(q(mid)?) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let x = (lo * hi).sqrt();
    let (t, e) = eval(x)?;
    Ok(Some((x, t, e)))
}

/// Match `baseline` to the fuzzy run `fuzzy` on `prepared`: its feed, then
/// its tolerance, for the cycle time (`error = false`) or the maximum
/// contour error (`error = true`).
fn match_baseline(
    prepared: &Prepared,
    fuzzy: &RunResult,
    baseline: Variant,
    config: &SimConfig,
    error: bool,
    at_f_max: Option<(f64, f64)>,
) -> Result<Option<Matched>> {
    let target = if error {
        fuzzy.metrics.contour_error_max_mm
    } else {
        fuzzy.metrics.cycle_time_s
    };
    let f0 = fuzzy.f_max_mm_per_min;
    let by_feed = |f: f64| measure(prepared, baseline, f, None, config);
    // The constant feed as the paper's claims were first measured (0.1 %,
    // from F_max by halving/doubling); the baselines from a guess of the
    // matching feed (time ∝ 1/F, error ∝ F²) to 0.5 %, which keeps the
    // ratios to ±0.01.
    let (hint, step, precision) = match (baseline.method, at_f_max) {
        (Method::Constant, _) | (_, None) => (f0, 2.0, 1.001),
        (_, Some((tb, eb))) => {
            let guess = if error {
                f0 * (target / eb.max(1e-12)).sqrt()
            } else {
                f0 * tb / target.max(1e-12)
            };
            (guess.clamp(f0 / 64.0, 64.0 * f0), 1.25, 1.005)
        }
    };
    if let Some((f, t, e)) = search(&by_feed, error, target, hint, 0.0, 1e6, step, precision)? {
        return Ok(Some(Matched {
            knob: Knob::Feed,
            feed_mm_per_min: f,
            tolerance_mm: baseline
                .tolerance_mm
                .or_else(|| baseline.method.tolerance_mm(&config.methods)),
            cycle_time_s: t,
            contour_error_max_mm: e,
        }));
    }
    let Some(t0) = baseline
        .tolerance_mm
        .or_else(|| baseline.method.tolerance_mm(&config.methods))
    else {
        return Ok(None);
    };
    let by_tol = |x: f64| measure(prepared, baseline, f0, Some(x), config);
    Ok(
        search(&by_tol, error, target, t0, 1e-5, 5.0, 2.0, 1.005)?.map(|(x, t, e)| Matched {
            knob: Knob::Tolerance,
            feed_mm_per_min: f0,
            tolerance_mm: Some(x),
            cycle_time_s: t,
            contour_error_max_mm: e,
        }),
    )
}

/// Both figures of the fuzzy run `fuzzy` against `baseline`.
pub fn claim_against(
    prepared: &Prepared,
    fuzzy: &RunResult,
    baseline: Variant,
    config: &SimConfig,
) -> Result<Claim> {
    let (tf, ef) = (
        fuzzy.metrics.cycle_time_s,
        fuzzy.metrics.contour_error_max_mm,
    );
    let (tb, eb) = measure(prepared, baseline, fuzzy.f_max_mm_per_min, None, config)?;
    let at = Some((tb, eb));
    let equal_time = match_baseline(prepared, fuzzy, baseline, config, false, at)?;
    let equal_error = match_baseline(prepared, fuzzy, baseline, config, true, at)?;
    Ok(Claim {
        path: prepared.path.name.clone(),
        method: fuzzy.method.name(),
        f_max_mm_per_min: fuzzy.f_max_mm_per_min,
        baseline: baseline.method.name(),
        baseline_tolerance_mm: baseline
            .tolerance_mm
            .or_else(|| baseline.method.tolerance_mm(&config.methods)),
        fuzzy_cycle_time_s: tf,
        fuzzy_contour_error_max_mm: ef,
        baseline_cycle_time_s: tb,
        baseline_contour_error_max_mm: eb,
        error_ratio: equal_time.as_ref().map(|m| ef / m.contour_error_max_mm),
        time_ratio: equal_error.as_ref().map(|m| tf / m.cycle_time_s),
        error_ratio_at_least: (equal_time.is_none() && tb <= tf).then(|| ef / eb),
        time_ratio_at_least: (equal_error.is_none() && eb <= ef).then(|| tf / tb),
        equal_time,
        equal_error,
    })
}

/// Both claims of the abstract for the fuzzy run `fuzzy` against the
/// constant feed.
pub fn claim(prepared: &Prepared, fuzzy: &RunResult, config: &SimConfig) -> Result<Claim> {
    claim_against(prepared, fuzzy, Variant::plain(Method::Constant), config)
}

/// One point of the Pareto sweep.
#[derive(Clone, Debug, Serialize)]
pub struct ParetoPoint {
    /// Toolpath name.
    pub path: String,
    /// Method name.
    pub method: &'static str,
    /// The method's tolerance, mm.
    pub tolerance_mm: Option<f64>,
    /// Maximum feed, mm/min.
    pub f_max_mm_per_min: f64,
    /// Cycle time, s.
    pub cycle_time_s: f64,
    /// Maximum contour error, mm.
    pub contour_error_max_mm: f64,
}

/// What a batch produces.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// The machine's label.
    pub machine: String,
    /// The configuration used.
    #[serde(skip)]
    pub config: SimConfig,
    /// Table rows, path by path, feed by feed, method by method.
    pub rows: Vec<Row>,
    /// Claims, path by path and feed by feed: `fuzzy` and `fuzzy-planner`
    /// against the constant feed, `fuzzy-planner` against each baseline.
    pub claims: Vec<Claim>,
    /// The Pareto sweep, path by path, method by method, feed by feed.
    pub pareto: Vec<ParetoPoint>,
}

/// What to compute besides the table.
#[derive(Clone, Debug, Default)]
pub struct Options {
    /// Measure the claims (against the constant feed, and against the
    /// baselines below).
    pub claims: bool,
    /// The baselines `fuzzy-planner` is matched with.
    pub baselines: Vec<Variant>,
    /// Maximum feeds of the Pareto sweep (empty: no sweep), mm/min.
    pub pareto_feeds_mm_per_min: Vec<f64>,
    /// Paths processed at once (threads; at least 1).
    pub jobs: usize,
}

/// The default baselines of fuzzy + planner: `planner`, `grbl-like` at
/// δ = 0.01 and 0.002 mm, `blend` at P = 0.01 mm.
pub fn default_baselines() -> Vec<Variant> {
    vec![
        Variant::plain(Method::Planner),
        Variant {
            method: Method::GrblLike,
            tolerance_mm: Some(0.01),
        },
        Variant {
            method: Method::GrblLike,
            tolerance_mm: Some(0.002),
        },
        Variant {
            method: Method::Blend,
            tolerance_mm: Some(0.01),
        },
    ]
}

/// What one path gives.
struct PathResult {
    rows: Vec<Row>,
    claims: Vec<Claim>,
    pareto: Vec<ParetoPoint>,
}

fn one_path(
    p: &Prepared,
    variants_: &[Variant],
    feeds_mm_per_min: &[f64],
    config: &SimConfig,
    opts: &Options,
    tick: &(dyn Fn(&str) + Sync),
    runs_done: &(dyn Fn(&Prepared, &[RunResult]) -> Result<()> + Sync),
) -> Result<PathResult> {
    let mut rows = Vec::new();
    let mut claims = Vec::new();
    let mut runs = Vec::new();
    for &f in feeds_mm_per_min {
        for v in variants_ {
            let c = v.config(config);
            tick(&format!("{} {} {f}", p.path.name, v.label(config)));
            let r = simulate::run(p, v.method, f, &c)?;
            rows.push(Row {
                path: p.path.name.clone(),
                method: v.method.name(),
                tolerance_mm: r.tolerance_mm,
                f_max_mm_per_min: f,
                metrics: r.metrics.clone(),
            });
            if opts.claims && has_claims(v.method) {
                tick(&format!(
                    "{} {} vs constant {f}",
                    p.path.name,
                    v.method.name()
                ));
                claims.push(claim(p, &r, config)?);
                if v.method == Method::FuzzyPlanner {
                    for b in &opts.baselines {
                        tick(&format!("{} vs {} {f}", p.path.name, b.label(config)));
                        claims.push(claim_against(p, &r, *b, config)?);
                    }
                }
            }
            runs.push(r);
        }
    }
    runs_done(p, &runs)?;
    drop(runs);
    let mut pareto = Vec::new();
    for v in variants_ {
        let c = v.config(config);
        let tol = v
            .tolerance_mm
            .or_else(|| v.method.tolerance_mm(&config.methods));
        for &f in &opts.pareto_feeds_mm_per_min {
            tick(&format!("{} pareto {} {f}", p.path.name, v.label(config)));
            // A feed of the table is not run twice.
            let done = rows.iter().find(|r| {
                r.method == v.method.name() && r.tolerance_mm == tol && r.f_max_mm_per_min == f
            });
            let (t, e) = match done {
                Some(r) => (r.metrics.cycle_time_s, r.metrics.contour_error_max_mm),
                None => {
                    let r = simulate::run(p, v.method, f, &c)?;
                    (r.metrics.cycle_time_s, r.metrics.contour_error_max_mm)
                }
            };
            pareto.push(ParetoPoint {
                path: p.path.name.clone(),
                method: v.method.name(),
                tolerance_mm: tol,
                f_max_mm_per_min: f,
                cycle_time_s: t,
                contour_error_max_mm: e,
            });
        }
    }
    Ok(PathResult {
        rows,
        claims,
        pareto,
    })
}

/// Run every path × feed × variant (and the claims and the sweep `opts`
/// asks for); `runs_done` gets each path's full runs (for plots) before
/// they are dropped, `tick` is called once per step ([`batch_steps`]).
/// Paths run on `opts.jobs` threads; the report keeps the paths' order.
pub fn batch(
    paths: &[Prepared],
    variants_: &[Variant],
    feeds_mm_per_min: &[f64],
    config: &SimConfig,
    opts: &Options,
    tick: &(dyn Fn(&str) + Sync),
    runs_done: &(dyn Fn(&Prepared, &[RunResult]) -> Result<()> + Sync),
) -> Result<Report> {
    let jobs = opts.jobs.max(1).min(paths.len().max(1));
    let next = std::sync::atomic::AtomicUsize::new(0);
    let results: Vec<std::sync::Mutex<Option<Result<PathResult>>>> =
        paths.iter().map(|_| std::sync::Mutex::new(None)).collect();
    std::thread::scope(|s| {
        for _ in 0..jobs {
            s.spawn(|| loop {
                let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                let Some(p) = paths.get(i) else { break };
                let r = one_path(
                    p,
                    variants_,
                    feeds_mm_per_min,
                    config,
                    opts,
                    tick,
                    runs_done,
                );
                let failed = r.is_err();
                if let Ok(mut slot) = results[i].lock() {
                    *slot = Some(r);
                }
                if failed {
                    // Stop taking paths: the batch fails anyway.
                    next.store(paths.len(), std::sync::atomic::Ordering::Relaxed);
                }
            });
        }
    });
    let mut report = Report {
        machine: config.machine.label(),
        config: config.clone(),
        rows: Vec::new(),
        claims: Vec::new(),
        pareto: Vec::new(),
    };
    for (slot, p) in results.into_iter().zip(paths) {
        let r = slot
            .into_inner()
            .map_err(|_| anyhow::anyhow!("{}: a worker panicked", p.path.name))?;
        let Some(r) = r else { continue };
        let r = r?;
        report.rows.extend(r.rows);
        report.claims.extend(r.claims);
        report.pareto.extend(r.pareto);
    }
    Ok(report)
}

/// Number of `tick` calls [`batch`] makes.
pub fn batch_steps(paths: usize, variants_: &[Variant], feeds: usize, opts: &Options) -> u64 {
    let claimed: usize = variants_
        .iter()
        .map(|v| match v.method {
            Method::Fuzzy => 1,
            Method::FuzzyPlanner => 1 + opts.baselines.len(),
            _ => 0,
        })
        .sum();
    let per_feed = variants_.len() + if opts.claims { claimed } else { 0 };
    (paths * (feeds * per_feed + variants_.len() * opts.pareto_feeds_mm_per_min.len())) as u64
}

/// Whether the claims are measured for method `m`.
pub fn has_claims(m: Method) -> bool {
    matches!(m, Method::Fuzzy | Method::FuzzyPlanner)
}

/// Re-export for callers that schedule without simulating.
pub use methods::schedule;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::toolpath::Toolpath;

    fn hairpin() -> Prepared {
        // A long straight, a tight half circle (R 2 mm), a long straight: a
        // constant feed must crawl everywhere to be as accurate as the
        // scheduler is, which slows only at the bend.
        let mut pts: Vec<[f64; 3]> = (0..200).map(|i| [i as f64 * 0.25, 0.0, 0.0]).collect();
        for i in 1..60 {
            let t = i as f64 / 60.0 * std::f64::consts::PI;
            pts.push([49.75 + 2.0 * t.sin(), 2.0 - 2.0 * t.cos(), 0.0]);
        }
        pts.extend((0..200).map(|i| [49.75 - i as f64 * 0.25, 4.0, 0.0]));
        Prepared::new(Toolpath::from_points("hairpin", pts).unwrap())
    }

    #[test]
    fn claims_on_a_path_with_one_tight_bend_favour_the_scheduler() {
        let p = hairpin();
        let config = SimConfig::default();
        let fuzzy = simulate::run(&p, Method::Fuzzy, 3000.0, &config).unwrap();
        let c = claim(&p, &fuzzy, &config).unwrap();
        let (et, ee) = (
            c.equal_time.clone().unwrap(),
            c.equal_error.clone().unwrap(),
        );
        assert_eq!(et.knob, Knob::Feed);
        assert!(
            (et.cycle_time_s - c.fuzzy_cycle_time_s).abs() < 0.01,
            "{c:?}"
        );
        assert!(
            (ee.contour_error_max_mm / c.fuzzy_contour_error_max_mm - 1.0).abs() < 0.01,
            "{c:?}"
        );
        assert!(
            c.error_reduction().unwrap() > 0.2 && c.time_reduction().unwrap() > 0.2,
            "{c:?}"
        );
    }

    #[test]
    fn a_baseline_is_matched_by_its_feed_or_its_tolerance() {
        let p = hairpin();
        let config = SimConfig::default();
        let fp = simulate::run(&p, Method::FuzzyPlanner, 3000.0, &config).unwrap();
        for b in default_baselines() {
            let c = claim_against(&p, &fp, b, &config).unwrap();
            for m in [&c.equal_time, &c.equal_error].into_iter().flatten() {
                let v = Variant {
                    tolerance_mm: m.tolerance_mm,
                    ..b
                };
                // The matched run reproduces its figures.
                let r = simulate::run(&p, b.method, m.feed_mm_per_min, &v.config(&config)).unwrap();
                assert_eq!(r.metrics.cycle_time_s, m.cycle_time_s);
                assert_eq!(r.metrics.contour_error_max_mm, m.contour_error_max_mm);
            }
            let et = c.equal_time.as_ref().expect("equal time");
            assert!(
                (et.cycle_time_s / c.fuzzy_cycle_time_s - 1.0).abs() < 0.02,
                "{c:?}"
            );
        }
    }

    #[test]
    fn variants_expand_the_tolerances() {
        let v = variants(
            &[Method::Fuzzy, Method::GrblLike, Method::Blend],
            &[0.01, 0.002],
            &[],
        );
        assert_eq!(v.len(), 4);
        assert_eq!(v[2].tolerance_mm, Some(0.002));
        assert_eq!(v[3].label(&SimConfig::default()), "blend 0.01");
    }
}
