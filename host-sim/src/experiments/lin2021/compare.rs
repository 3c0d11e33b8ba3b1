//! The paper-style comparison: every toolpath × method × maximum feed on one
//! machine (Lin et al. Tables 10-12), and the two claims of the abstract
//! measured against a constant feed:
//!
//! - **equal cycle time**: the constant feed whose cycle time equals the
//!   fuzzy scheduler's, and how much lower the fuzzy scheduler's maximum
//!   contour error is (paper: 43 %);
//! - **equal accuracy**: the constant feed whose maximum contour error
//!   equals the fuzzy scheduler's, and how much shorter the fuzzy
//!   scheduler's cycle time is (paper: 49 %).
//!
//! The same two figures are measured for `fuzzy-planner` (the fuzzy feeds
//! through fuzzy-core's velocity planner) against the same constant feed.
//!
//! Both constant feeds are found by bisection on the simulated machine
//! (cycle time falls and the maximum contour error rises with the feed);
//! the search stops when the feed is known to 0.1 %.

use anyhow::{bail, Result};
use serde::Serialize;

use crate::config::SimConfig;
use crate::methods::{self, Method};
use crate::metrics::Metrics;
use crate::simulate::{self, Prepared, RunResult};

/// One row of the table.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    /// Toolpath name.
    pub path: String,
    /// Method name.
    pub method: &'static str,
    /// Maximum feed, mm/min.
    pub f_max_mm_per_min: f64,
    /// The measurements.
    #[serde(flatten)]
    pub metrics: Metrics,
}

/// The constant feed matched to the fuzzy scheduler in one respect.
#[derive(Clone, Debug, Serialize)]
pub struct Matched {
    /// The constant feed, mm/min.
    pub feed_mm_per_min: f64,
    /// Its cycle time, s.
    pub cycle_time_s: f64,
    /// Its maximum contour error, mm.
    pub contour_error_max_mm: f64,
}

/// The abstract's two claims on one path at one maximum feed.
#[derive(Clone, Debug, Serialize)]
pub struct Claim {
    /// Toolpath name.
    pub path: String,
    /// The scheduling method compared with the constant feed (`fuzzy` or
    /// `fuzzy-planner`; the `fuzzy_*` fields are its figures).
    pub method: &'static str,
    /// The fuzzy scheduler's maximum feed, mm/min.
    pub f_max_mm_per_min: f64,
    /// Fuzzy scheduler's cycle time, s.
    pub fuzzy_cycle_time_s: f64,
    /// Fuzzy scheduler's maximum contour error, mm.
    pub fuzzy_contour_error_max_mm: f64,
    /// Constant feed with the same cycle time.
    pub equal_time: Matched,
    /// `1 − E_fuzzy / E_constant` at equal cycle time (paper: 0.43).
    pub error_reduction: f64,
    /// Constant feed with the same maximum contour error.
    pub equal_error: Matched,
    /// `1 − T_fuzzy / T_constant` at equal maximum contour error (paper:
    /// 0.49).
    pub time_reduction: f64,
}

/// Constant feed at `f`: (cycle time s, max contour error mm).
fn constant(prepared: &Prepared, f: f64, config: &SimConfig) -> Result<(f64, f64)> {
    let r = simulate::run(prepared, Method::Constant, f, config)?;
    Ok((r.metrics.cycle_time_s, r.metrics.contour_error_max_mm))
}

/// Bisection on the constant feed (log scale) for `target` of the quantity
/// picked by `which` (0: time, decreasing in the feed; 1: error,
/// increasing).
fn match_constant(
    prepared: &Prepared,
    config: &SimConfig,
    which: usize,
    target: f64,
    hint_mm_per_min: f64,
) -> Result<Matched> {
    let eval = |f: f64| -> Result<f64> {
        let v = constant(prepared, f, config)?;
        Ok(if which == 0 { v.0 } else { v.1 })
    };
    let increasing = which == 1;
    // Bracket around the hint.
    let (mut lo, mut hi) = (hint_mm_per_min, hint_mm_per_min);
    let below = |v: f64| if increasing { v < target } else { v > target };
    for _ in 0..60 {
        if below(eval(lo)?) {
            break;
        }
        lo /= 2.0;
    }
    for _ in 0..60 {
        if !below(eval(hi)?) || hi >= 1e6 {
            break;
        }
        hi = (hi * 2.0).min(1e6);
    }
    if !below(eval(lo)?) || below(eval(hi)?) {
        bail!(
            "no constant feed matches {} {target} on {}",
            if which == 0 {
                "cycle time"
            } else {
                "max contour error"
            },
            prepared.path.name
        );
    }
    while hi / lo > 1.001 {
        let mid = (lo * hi).sqrt();
        if below(eval(mid)?) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let f = (lo * hi).sqrt();
    let (t, e) = constant(prepared, f, config)?;
    Ok(Matched {
        feed_mm_per_min: f,
        cycle_time_s: t,
        contour_error_max_mm: e,
    })
}

/// Measure both claims for the fuzzy run `fuzzy` (method `fuzzy` or
/// `fuzzy-planner`) on `prepared`.
pub fn claim(prepared: &Prepared, fuzzy: &RunResult, config: &SimConfig) -> Result<Claim> {
    let (tf, ef) = (
        fuzzy.metrics.cycle_time_s,
        fuzzy.metrics.contour_error_max_mm,
    );
    let hint = fuzzy.f_max_mm_per_min;
    let equal_time = match_constant(prepared, config, 0, tf, hint)?;
    let equal_error = match_constant(prepared, config, 1, ef, hint)?;
    Ok(Claim {
        path: prepared.path.name.clone(),
        method: fuzzy.method.name(),
        f_max_mm_per_min: fuzzy.f_max_mm_per_min,
        fuzzy_cycle_time_s: tf,
        fuzzy_contour_error_max_mm: ef,
        error_reduction: 1.0 - ef / equal_time.contour_error_max_mm,
        time_reduction: 1.0 - tf / equal_error.cycle_time_s,
        equal_time,
        equal_error,
    })
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
    /// Claims, path by path and feed by feed (when `fuzzy` or
    /// `fuzzy-planner` ran).
    pub claims: Vec<Claim>,
}

/// Run every path × feed × method; `keep` gets each full run (for plots),
/// `tick` is called once per run and once per claim.
pub fn batch(
    paths: &[Prepared],
    methods_: &[Method],
    feeds_mm_per_min: &[f64],
    config: &SimConfig,
    with_claims: bool,
    mut keep: impl FnMut(&Prepared, &RunResult),
    mut tick: impl FnMut(&str),
) -> Result<Report> {
    let mut rows = Vec::new();
    let mut claims = Vec::new();
    for p in paths {
        for &f in feeds_mm_per_min {
            for &m in methods_ {
                tick(&format!("{} {} {f}", p.path.name, m.name()));
                let r = simulate::run(p, m, f, config)?;
                rows.push(Row {
                    path: p.path.name.clone(),
                    method: m.name(),
                    f_max_mm_per_min: f,
                    metrics: r.metrics.clone(),
                });
                if with_claims && has_claims(m) {
                    tick(&format!("{} claims {f}", p.path.name));
                    claims.push(claim(p, &r, config)?);
                }
                keep(p, &r);
            }
        }
    }
    Ok(Report {
        machine: config.machine.label(),
        config: config.clone(),
        rows,
        claims,
    })
}

/// Number of `tick` calls [`batch`] makes.
pub fn batch_steps(paths: usize, methods_: &[Method], feeds: usize, with_claims: bool) -> u64 {
    let claimed = methods_.iter().filter(|m| has_claims(**m)).count();
    let per = methods_.len() + if with_claims { claimed } else { 0 };
    (paths * feeds * per) as u64
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

    #[test]
    fn claims_on_a_path_with_one_tight_bend_favour_the_scheduler() {
        // A long straight, a tight half circle (R 2 mm), a long straight: a
        // constant feed must crawl everywhere to be as accurate as the
        // scheduler is, which slows only at the bend.
        let mut pts: Vec<[f64; 3]> = (0..200).map(|i| [i as f64 * 0.25, 0.0, 0.0]).collect();
        for i in 1..60 {
            let t = i as f64 / 60.0 * std::f64::consts::PI;
            pts.push([49.75 + 2.0 * t.sin(), 2.0 - 2.0 * t.cos(), 0.0]);
        }
        pts.extend((0..200).map(|i| [49.75 - i as f64 * 0.25, 4.0, 0.0]));
        let p = Prepared::new(Toolpath::from_points("hairpin", pts).unwrap());
        let config = SimConfig::default();
        let fuzzy = simulate::run(&p, Method::Fuzzy, 3000.0, &config).unwrap();
        let c = claim(&p, &fuzzy, &config).unwrap();
        assert!(
            (c.equal_time.cycle_time_s - c.fuzzy_cycle_time_s).abs() < 0.01,
            "{c:?}"
        );
        assert!(
            (c.equal_error.contour_error_max_mm / c.fuzzy_contour_error_max_mm - 1.0).abs() < 0.01,
            "{c:?}"
        );
        assert!(c.error_reduction > 0.2 && c.time_reduction > 0.2, "{c:?}");
    }
}
