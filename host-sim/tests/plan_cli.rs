//! `host-sim plan` and the `fuzzy-planner` method end to end: report, plots,
//! CSV and JSON written; errors name the file and line and write nothing;
//! the `[planner]` section reads back and is checked.

use std::path::PathBuf;
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_host-sim"))
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("host-sim-plan-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn data(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/data")
        .join(rel)
}

#[test]
fn plan_writes_report_plots_ticks_and_json() {
    let d = tmp("good");
    let gcode = data("short_segments.ngc");
    let o = bin()
        .args(["plan", "trident"])
        .arg(&gcode)
        .args(["--plot-format", "svg", "--out-dir"])
        .arg(&d)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("time-optimal reference"), "{out}");
    assert!(out.contains("within limits: yes"), "{out}");
    for f in [
        "plan.txt",
        "plan.json",
        "trident_plan.svg",
        "trident_plan_ticks.csv",
        "trident_plan_points.csv",
        "trident_plan.json",
        "short_segments_plan.svg",
        "short_segments_plan_ticks.csv",
    ] {
        assert!(d.join(f).exists(), "{f}");
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("plan.json")).unwrap()).unwrap();
    assert_eq!(json.as_array().unwrap().len(), 2);
    let t = &json[0];
    assert_eq!(t["path"], "trident");
    assert!(t["time_ratio"].as_f64().unwrap() >= 1.0);
    // One CSV row per tick, the last one at rest at the end.
    let ticks = std::fs::read_to_string(d.join("trident_plan_ticks.csv")).unwrap();
    let rows = ticks.lines().count() - 1;
    let time = t["cycle_time_s"].as_f64().unwrap();
    assert_eq!(rows, (time / 0.001).round() as usize);
    assert!(ticks.lines().last().unwrap().ends_with(",Done"));
    let points = std::fs::read_to_string(d.join("trident_plan_points.csv")).unwrap();
    assert_eq!(points.lines().count(), 2002);
}

#[test]
fn plan_errors_name_the_line_and_write_nothing() {
    let d = tmp("bad");
    let gc = d.join("bad.nc");
    std::fs::write(&gc, "G1 X1 F100\nG1 X2\nG76 X3\n").unwrap();
    let toml = d.join("bad.toml");
    std::fs::write(&toml, "[planner]\ntangential_share = 1.5\n").unwrap();
    let toml2 = d.join("tick.toml");
    std::fs::write(&toml2, "[planner]\ntick_us = 500\n").unwrap();
    for (args, needle) in [
        (vec![gc.to_str().unwrap()], "line 3"),
        (
            vec!["trident", "--config", toml.to_str().unwrap()],
            "tangential share",
        ),
        (
            vec!["trident", "--config", toml2.to_str().unwrap()],
            "tick_us",
        ),
        (vec!["trident", "--f-max=-3"], "--f-max"),
    ] {
        let out_dir = d.join("results");
        let o = bin()
            .arg("plan")
            .args(&args)
            .arg("--out-dir")
            .arg(&out_dir)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?}");
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(!out_dir.exists(), "partial report for {args:?}");
    }
}

#[test]
fn config_has_a_planner_section_that_reads_back_and_the_tick_follows_ts() {
    let d = tmp("cfg");
    let o = bin().arg("config").output().unwrap();
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    for key in [
        "[planner]",
        "tick_us = 1000",
        "feed_max_mm_per_min = 5000.0",
        "axis_speed_max_mm_per_min = [10000.0, 10000.0, 10000.0]",
        "axis_accel_max_mm_per_s2 = [2000, 2000, 2000]",
        "jerk_max_mm_per_s3 = 50000",
        "chord_tolerance_mm = 0.001",
        "tangential_share = 0.5",
        "buffer_points = 256",
    ] {
        assert!(text.contains(key), "{key}:\n{text}");
    }
    let f = d.join("c.toml");
    std::fs::write(
        &f,
        text.replace("jerk_max_mm_per_s3 = 50000", "jerk_max_mm_per_s3 = 20000"),
    )
    .unwrap();
    let o = bin()
        .args(["plan", "infinity", "--no-plots", "--config"])
        .arg(&f)
        .arg("--out-dir")
        .arg(&d)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("limit 20000 mm/s³"));
    // --interpolation-period-ms sets the planner's tick too.
    let o = bin()
        .args([
            "plan",
            "trident",
            "--no-plots",
            "--interpolation-period-ms",
            "0.5",
            "--out-dir",
        ])
        .arg(&d)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn compare_runs_the_planner_method_with_its_claims() {
    let d = tmp("cmp");
    let o = bin()
        .args([
            "compare",
            "--shapes",
            "trident",
            "--feeds",
            "3000",
            "--methods",
            "fuzzy,fuzzy-planner",
            "--plot-format",
            "svg",
            "--out-dir",
        ])
        .arg(&d)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let table = std::fs::read_to_string(d.join("table.csv")).unwrap();
    assert!(table
        .lines()
        .any(|l| l.starts_with("trident,fuzzy-planner,,3000,")));
    let claims = std::fs::read_to_string(d.join("claims.csv")).unwrap();
    assert!(claims.starts_with("path,method,"));
    assert!(claims
        .lines()
        .any(|l| l.starts_with("trident,fuzzy-planner,")));
    assert!(d
        .join("plots/trident_error_fuzzy-planner_3000.svg")
        .exists());
    // The Pareto sweep: one curve per method, five feeds each.
    let pareto = std::fs::read_to_string(d.join("pareto.csv")).unwrap();
    assert_eq!(pareto.lines().count(), 1 + 2 * 5);
    assert!(d.join("plots/pareto_trident.svg").exists());
    // The servo's limits are below the planner's defaults: said, not hidden.
    let o = bin()
        .args([
            "plan",
            "trident",
            "--no-plots",
            "--machine",
            "servo-xy",
            "--out-dir",
        ])
        .arg(&d)
        .output()
        .unwrap();
    assert!(o.status.success());
    assert!(String::from_utf8_lossy(&o.stdout).contains("current-limited acceleration"));
}
