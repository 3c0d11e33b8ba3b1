//! The comparison as text (the layout of Lin et al. Tables 10-12, with the
//! kinematic peaks added), CSV and JSON.

use std::fmt::Write as _;

use anyhow::Result;

use crate::experiments::lin2021::compare::{Claim, Report, Row};

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
    if !report.claims.is_empty() {
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
        for c in &report.claims {
            let _ = writeln!(
                s,
                "{:<12} {:<14} {:>8.0} {:>9.3} {:>9.4} | {:>9.0} {:>9.4} {:>8.1} | {:>9.0} {:>9.3} {:>8.1}",
                c.path,
                c.method,
                c.f_max_mm_per_min,
                c.fuzzy_cycle_time_s,
                c.fuzzy_contour_error_max_mm,
                c.equal_time.feed_mm_per_min,
                c.equal_time.contour_error_max_mm,
                100.0 * c.error_reduction,
                c.equal_error.feed_mm_per_min,
                c.equal_error.cycle_time_s,
                100.0 * c.time_reduction,
            );
        }
    }
    s
}

/// The table as CSV (one row per path × method × feed).
pub fn rows_csv(rows: &[Row]) -> Result<String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record([
        "path",
        "method",
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
    ])?;
    for r in rows {
        let m = &r.metrics;
        let mut rec = vec![r.path.clone(), r.method.to_string()];
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
            ]
            .iter()
            .map(|v| format!("{v}")),
        );
        w.write_record(&rec)?;
    }
    Ok(String::from_utf8(w.into_inner()?)?)
}

/// The claims as CSV.
pub fn claims_csv(claims: &[Claim]) -> Result<String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record([
        "path",
        "method",
        "f_max_mm_per_min",
        "fuzzy_cycle_time_s",
        "fuzzy_contour_error_max_mm",
        "equal_time_constant_feed_mm_per_min",
        "equal_time_constant_contour_error_max_mm",
        "error_reduction",
        "equal_error_constant_feed_mm_per_min",
        "equal_error_constant_cycle_time_s",
        "time_reduction",
    ])?;
    for c in claims {
        let mut rec = vec![c.path.clone(), c.method.to_string()];
        rec.extend(
            [
                c.f_max_mm_per_min,
                c.fuzzy_cycle_time_s,
                c.fuzzy_contour_error_max_mm,
                c.equal_time.feed_mm_per_min,
                c.equal_time.contour_error_max_mm,
                c.error_reduction,
                c.equal_error.feed_mm_per_min,
                c.equal_error.cycle_time_s,
                c.time_reduction,
            ]
            .iter()
            .map(|v| format!("{v}")),
        );
        w.write_record(&rec)?;
    }
    Ok(String::from_utf8(w.into_inner()?)?)
}

/// Everything as JSON (machine label, configuration, rows, claims).
pub fn json(report: &Report) -> Result<String> {
    let v = serde_json::json!({
        "machine": report.machine,
        "config": report.config,
        "rows": report.rows,
        "claims": report.claims,
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
                f_max_mm_per_min: 3000.0,
                metrics: Metrics {
                    cycle_time_s: 1.5,
                    ..Default::default()
                },
            }],
            claims: vec![],
        };
        assert!(text(&report).contains("fuzzy"));
        let c = rows_csv(&report.rows).unwrap();
        assert_eq!(c.lines().count(), 2);
        assert!(c.lines().nth(1).unwrap().starts_with("p,fuzzy,3000,1.5,"));
        let j: serde_json::Value = serde_json::from_str(&json(&report).unwrap()).unwrap();
        assert_eq!(j["rows"][0]["cycle_time_s"], 1.5);
        assert_eq!(j["config"]["interpolation_period_ms"], 1.0);
    }
}
