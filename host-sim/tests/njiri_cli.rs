//! `host-sim njiri`: Njiri et al.'s depth-of-cut step experiment from the
//! command line (section III.B, Fig. 12-13).

use std::path::PathBuf;
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_host-sim"))
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("host-sim-njiri-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn summary(dir: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
}

#[test]
fn paper_experiment_settles_near_78_percent_at_the_reference_force() {
    let dir = tmp("paper");
    let out = bin().arg("njiri").arg("--out").arg(&dir).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("override 76.3 %"), "{text}");
    let s = summary(&dir);
    let o = s["settled_override_pct"].as_f64().unwrap();
    assert!((o - 78.0).abs() < 3.0, "{s}");
    let fx = s["settled_peak_n"][0].as_f64().unwrap();
    assert!((fx - 120.0).abs() < 1.0, "{s}");
    let feed = s["settled_feed_mm_per_min"].as_f64().unwrap();
    assert!((feed - 23.4).abs() < 1.0, "{s}");
    // One row per revolution (0.2 s) for 20 s, and a header.
    assert!(dir.join("fig13.svg").is_file());
    let csv = std::fs::read_to_string(dir.join("revolutions.csv")).unwrap();
    assert_eq!(csv.lines().count(), 101);
    assert!(csv.starts_with("t_s,x_mm,depth_mm,feed_mm_per_min,peak_fx_n"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn without_control_the_force_rises_with_the_depth() {
    let dir = tmp("open");
    let out = bin()
        .args(["njiri", "--no-control", "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(out.status.success());
    let s = summary(&dir);
    assert_eq!(s["settled_override_pct"].as_f64(), Some(100.0));
    assert!(s["settled_peak_n"][0].as_f64().unwrap() > 140.0, "{s}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_arguments_fail() {
    for args in [
        &["njiri", "--gain", "0"][..],
        &["njiri", "--depth-after", "9"],
        &["njiri", "--ref-fx", "-1"],
        &["njiri", "--duration", "0"],
    ] {
        let out = bin().args(args).output().unwrap();
        assert!(!out.status.success(), "{args:?}");
        assert!(String::from_utf8_lossy(&out.stderr).contains("error"));
    }
}
