//! The comparison as text (the layout of Lin et al. Tables 10-12, with the
//! kinematic peaks added), CSV and JSON.

use std::fmt::Write as _;

use anyhow::Result;

use serde::Serialize;

use crate::experiments::lin2021::compare::{Claim, Knob, Matched, ParetoPoint, Report, Row};

/// The table and the claims as plain text.
pub fn text(report: &Report) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "machine: {}", report.machine);
    let _ = writeln!(
        s,
        "{:<12} {:<16} {:>8} {:>9} {:>9} {:>9} {:>9} {:>8} {:>9} {:>10} {:>9} {:>9} {:>10} {:>10}",
        "path",
        "method",
        "Fmax",
        "time",
        "err max",
        "err min",
        "err mean",
        "peak F",
        "acc tan",
        "jerk tan",
        "acc X",
        "acc Y",
        "jerk X",
        "jerk Y"
    );
    let _ = writeln!(
        s,
        "{:<12} {:<16} {:>8} {:>9} {:>9} {:>9} {:>9} {:>8} {:>9} {:>10} {:>9} {:>9} {:>10} {:>10}",
        "",
        "",
        "mm/min",
        "s",
        "mm",
        "mm",
        "mm",
        "mm/min",
        "mm/s²",
        "mm/s³",
        "mm/s²",
        "mm/s²",
        "mm/s³",
        "mm/s³"
    );
    for r in &report.rows {
        let m = &r.metrics;
        let _ = writeln!(
            s,
            "{:<12} {:<16} {:>8.0} {:>9.3} {:>9.4} {:>9.4} {:>9.4} {:>8.0} {:>9.0} {:>10.0} {:>9.0} {:>9.0} {:>10.0} {:>10.0}",
            r.path,
            r.method,
            r.f_max_mm_per_min,
            m.cycle_time_s,
            m.contour_error_max_mm,
            m.contour_error_min_mm,
            m.contour_error_mean_mm,
            m.peak_feed_mm_per_min,
            m.peak_tangential_acc_mm_per_s2,
            m.peak_tangential_jerk_mm_per_s3,
            m.peak_axis_acc_mm_per_s2[0],
            m.peak_axis_acc_mm_per_s2[1],
            m.peak_axis_jerk_mm_per_s3[0],
            m.peak_axis_jerk_mm_per_s3[1],
        );
    }
    let constant: Vec<&Claim> = report
        .claims
        .iter()
        .filter(|c| c.baseline == "constant")
        .collect();
    if !constant.is_empty() {
        let _ = writeln!(
            s,
            "\nfuzzy (and fuzzy-planner) vs constant feed (paper: 43 % lower max error at equal time, 49 % shorter time at equal max error)"
        );
        let _ = writeln!(
            s,
            "{:<12} {:<14} {:>8} {:>9} {:>9} | {:>9} {:>9} {:>8} | {:>9} {:>9} {:>8}",
            "path",
            "method",
            "Fmax",
            "time s",
            "err mm",
            "const F",
            "const mm",
            "err -%",
            "const F",
            "const s",
            "time -%"
        );
        for c in constant {
            let _ = writeln!(
                s,
                "{:<12} {:<14} {:>8.0} {:>9.3} {:>9.4} | {} | {}",
                c.path,
                c.method,
                c.f_max_mm_per_min,
                c.fuzzy_cycle_time_s,
                c.fuzzy_contour_error_max_mm,
                matched_text(&c.equal_time, true, c.error_reduction()),
                matched_text(&c.equal_error, false, c.time_reduction()),
            );
        }
    }
    let baselines: Vec<&Claim> = report
        .claims
        .iter()
        .filter(|c| c.baseline != "constant")
        .collect();
    if !baselines.is_empty() {
        let _ = writeln!(
            s,
            "\nfuzzy-planner vs each baseline: error ratio E_fp/E_b at equal cycle time (goal <= 0.60 against the best), time ratio T_fp/T_b at equal max error (goal <= 0.80); the baseline's feed is searched, else its tolerance (T)"
        );
        let _ = writeln!(
            s,
            "{:<12} {:>6} {:<17} {:>8} {:>8} | {:>9} {:>9} {:>7} | {:>9} {:>9} {:>7}",
            "path",
            "Fmax",
            "baseline",
            "same F:s",
            "mm",
            "F (tol)",
            "err mm",
            "E ratio",
            "F (tol)",
            "time s",
            "T ratio"
        );
        for c in &baselines {
            let _ = writeln!(
                s,
                "{:<12} {:>6.0} {:<17} {:>8.3} {:>8.4} | {} | {}",
                c.path,
                c.f_max_mm_per_min,
                c.baseline_label(),
                c.baseline_cycle_time_s,
                c.baseline_contour_error_max_mm,
                ratio_text(&c.equal_time, true, c.error_ratio),
                ratio_text(&c.equal_error, false, c.time_ratio),
            );
        }
        let _ = writeln!(s, "\nagainst the best baseline (lowest error at equal time; shortest time at equal error):");
        for b in best(report) {
            let _ = writeln!(
                s,
                "{:<12} {:>6.0}  error ratio {} ({})  time ratio {} ({})",
                b.path,
                b.f_max_mm_per_min,
                b.error_ratio.map_or("  -  ".into(), |r| format!("{r:.2}")),
                b.error_baseline,
                b.time_ratio.map_or("  -  ".into(), |r| format!("{r:.2}")),
                b.time_baseline,
            );
        }
    }
    s
}

fn matched_text(m: &Option<Matched>, error: bool, reduction: Option<f64>) -> String {
    match (m, reduction) {
        (Some(m), Some(r)) => format!(
            "{:>9.0} {:>9.4} {:>8.1}",
            m.feed_mm_per_min,
            if error {
                m.contour_error_max_mm
            } else {
                m.cycle_time_s
            },
            100.0 * r
        ),
        _ => format!("{:>9} {:>9} {:>8}", "-", "-", "-"),
    }
}

fn ratio_text(m: &Option<Matched>, error: bool, ratio: Option<f64>) -> String {
    match (m, ratio) {
        (Some(m), Some(r)) => {
            let setting = match m.knob {
                Knob::Feed => format!("{:.0}", m.feed_mm_per_min),
                Knob::Tolerance => format!("T{:.4}", m.tolerance_mm.unwrap_or(0.0)),
            };
            format!(
                "{:>9} {:>9.4} {:>7.2}",
                setting,
                if error {
                    m.contour_error_max_mm
                } else {
                    m.cycle_time_s
                },
                r
            )
        }
        _ => format!("{:>9} {:>9} {:>7}", "none", "-", "-"),
    }
}

/// fuzzy-planner against its best baseline on one path and feed.
#[derive(Clone, Debug, Serialize)]
pub struct Best {
    /// Toolpath name.
    pub path: String,
    /// Maximum feed, mm/min.
    pub f_max_mm_per_min: f64,
    /// `E_fp / E_b` at equal time against the baseline with the lowest
    /// error there (`None`: no baseline matched).
    pub error_ratio: Option<f64>,
    /// That baseline.
    pub error_baseline: String,
    /// `T_fp / T_b` at equal error against the baseline with the shortest
    /// time there.
    pub time_ratio: Option<f64>,
    /// That baseline.
    pub time_baseline: String,
}

fn bound_label(c: &Claim, bound: bool) -> String {
    if bound {
        format!(
            "{}, at least: it is better in both at the same F_max",
            c.baseline_label()
        )
    } else {
        c.baseline_label()
    }
}

/// For each path and feed, fuzzy-planner against the best baseline in each
/// respect (the constant feed excluded).
pub fn best(report: &Report) -> Vec<Best> {
    let mut out: Vec<Best> = Vec::new();
    for c in report.claims.iter().filter(|c| c.baseline != "constant") {
        let i = match out
            .iter()
            .position(|b| b.path == c.path && b.f_max_mm_per_min == c.f_max_mm_per_min)
        {
            Some(i) => i,
            None => {
                out.push(Best {
                    path: c.path.clone(),
                    f_max_mm_per_min: c.f_max_mm_per_min,
                    error_ratio: None,
                    error_baseline: "none".into(),
                    time_ratio: None,
                    time_baseline: "none".into(),
                });
                out.len() - 1
            }
        };
        let b = &mut out[i];
        // The best baseline has the lowest error at equal time, i.e. the
        // highest ratio E_fp/E_b; likewise for time.
        // A baseline already faster (more accurate) at the same feed with
        // no setting matching counts with its lower bound.
        if let Some(r) = c.error_ratio.or(c.error_ratio_at_least) {
            if b.error_ratio.is_none_or(|x| r > x) {
                b.error_ratio = Some(r);
                b.error_baseline = bound_label(c, c.error_ratio.is_none());
            }
        }
        if let Some(r) = c.time_ratio.or(c.time_ratio_at_least) {
            if b.time_ratio.is_none_or(|x| r > x) {
                b.time_ratio = Some(r);
                b.time_baseline = bound_label(c, c.time_ratio.is_none());
            }
        }
    }
    out
}

/// The table as CSV (one row per path × method × feed).
pub fn rows_csv(rows: &[Row]) -> Result<String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record([
        "path",
        "method",
        "tolerance_mm",
        "f_max_mm_per_min",
        "cycle_time_s",
        "contour_error_max_mm",
        "contour_error_min_mm",
        "contour_error_mean_mm",
        "peak_feed_mm_per_min",
        "peak_tangential_acc_mm_per_s2",
        "peak_tangential_jerk_mm_per_s3",
        "peak_acc_x_mm_per_s2",
        "peak_acc_y_mm_per_s2",
        "peak_acc_z_mm_per_s2",
        "peak_jerk_x_mm_per_s3",
        "peak_jerk_y_mm_per_s3",
        "peak_jerk_z_mm_per_s3",
        "axis_acc_ratio",
        "axis_jerk_ratio",
        "time_at_feed_s",
    ])?;
    for r in rows {
        let m = &r.metrics;
        let mut rec = vec![r.path.clone(), r.method.to_string(), opt(r.tolerance_mm)];
        rec.extend(
            [
                r.f_max_mm_per_min,
                m.cycle_time_s,
                m.contour_error_max_mm,
                m.contour_error_min_mm,
                m.contour_error_mean_mm,
                m.peak_feed_mm_per_min,
                m.peak_tangential_acc_mm_per_s2,
                m.peak_tangential_jerk_mm_per_s3,
                m.peak_axis_acc_mm_per_s2[0],
                m.peak_axis_acc_mm_per_s2[1],
                m.peak_axis_acc_mm_per_s2[2],
                m.peak_axis_jerk_mm_per_s3[0],
                m.peak_axis_jerk_mm_per_s3[1],
                m.peak_axis_jerk_mm_per_s3[2],
                m.axis_acc_ratio,
                m.axis_jerk_ratio,
                m.time_at_feed_s,
            ]
            .iter()
            .map(|v| format!("{v}")),
        );
        w.write_record(&rec)?;
    }
    Ok(String::from_utf8(w.into_inner()?)?)
}

fn opt(v: Option<f64>) -> String {
    v.map_or(String::new(), |v| format!("{v}"))
}

/// The claims as CSV: one row per fuzzy run and baseline (empty fields:
/// not matched).
pub fn claims_csv(claims: &[Claim]) -> Result<String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record([
        "path",
        "method",
        "f_max_mm_per_min",
        "baseline",
        "baseline_tolerance_mm",
        "fuzzy_cycle_time_s",
        "fuzzy_contour_error_max_mm",
        "baseline_cycle_time_s",
        "baseline_contour_error_max_mm",
        "equal_time_knob",
        "equal_time_feed_mm_per_min",
        "equal_time_tolerance_mm",
        "equal_time_contour_error_max_mm",
        "error_ratio",
        "error_reduction",
        "equal_error_knob",
        "equal_error_feed_mm_per_min",
        "equal_error_tolerance_mm",
        "equal_error_cycle_time_s",
        "time_ratio",
        "time_reduction",
    ])?;
    let knob = |m: &Option<Matched>| match m.as_ref().map(|m| m.knob) {
        Some(Knob::Feed) => "feed".to_string(),
        Some(Knob::Tolerance) => "tolerance".to_string(),
        None => String::new(),
    };
    for c in claims {
        let et = c.equal_time.as_ref();
        let ee = c.equal_error.as_ref();
        w.write_record([
            c.path.clone(),
            c.method.to_string(),
            format!("{}", c.f_max_mm_per_min),
            c.baseline.to_string(),
            opt(c.baseline_tolerance_mm),
            format!("{}", c.fuzzy_cycle_time_s),
            format!("{}", c.fuzzy_contour_error_max_mm),
            format!("{}", c.baseline_cycle_time_s),
            format!("{}", c.baseline_contour_error_max_mm),
            knob(&c.equal_time),
            opt(et.map(|m| m.feed_mm_per_min)),
            opt(et.and_then(|m| m.tolerance_mm)),
            opt(et.map(|m| m.contour_error_max_mm)),
            opt(c.error_ratio),
            opt(c.error_reduction()),
            knob(&c.equal_error),
            opt(ee.map(|m| m.feed_mm_per_min)),
            opt(ee.and_then(|m| m.tolerance_mm)),
            opt(ee.map(|m| m.cycle_time_s)),
            opt(c.time_ratio),
            opt(c.time_reduction()),
        ])?;
    }
    Ok(String::from_utf8(w.into_inner()?)?)
}

/// The Pareto sweep as CSV.
pub fn pareto_csv(points: &[ParetoPoint]) -> Result<String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record([
        "path",
        "method",
        "tolerance_mm",
        "f_max_mm_per_min",
        "cycle_time_s",
        "contour_error_max_mm",
    ])?;
    for p in points {
        w.write_record([
            p.path.clone(),
            p.method.to_string(),
            opt(p.tolerance_mm),
            format!("{}", p.f_max_mm_per_min),
            format!("{}", p.cycle_time_s),
            format!("{}", p.contour_error_max_mm),
        ])?;
    }
    Ok(String::from_utf8(w.into_inner()?)?)
}

/// Everything as JSON (machine label, configuration, rows, claims, the
/// best baseline per path and feed, the Pareto sweep).
pub fn json(report: &Report) -> Result<String> {
    let v = serde_json::json!({
        "machine": report.machine,
        "config": report.config,
        "rows": report.rows,
        "claims": report.claims,
        "best_baseline": best(report),
        "pareto": report.pareto,
    });
    Ok(serde_json::to_string_pretty(&v)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::Metrics;

    #[test]
    fn every_format_has_every_row() {
        let report = Report {
            machine: "m".into(),
            config: Default::default(),
            rows: vec![Row {
                path: "p".into(),
                method: "fuzzy",
                tolerance_mm: None,
                f_max_mm_per_min: 3000.0,
                metrics: Metrics {
                    cycle_time_s: 1.5,
                    ..Default::default()
                },
            }],
            claims: vec![],
            pareto: vec![],
        };
        assert!(text(&report).contains("fuzzy"));
        let c = rows_csv(&report.rows).unwrap();
        assert_eq!(c.lines().count(), 2);
        assert!(c.lines().nth(1).unwrap().starts_with("p,fuzzy,,3000,1.5,"));
        let j: serde_json::Value = serde_json::from_str(&json(&report).unwrap()).unwrap();
        assert_eq!(j["rows"][0]["cycle_time_s"], 1.5);
        assert_eq!(j["config"]["interpolation_period_ms"], 1.0);
    }
}
