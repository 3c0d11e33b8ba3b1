//! The command line end to end: malformed input gets an error with file and
//! line, a non-zero exit and no report; a good run writes every output.

use std::path::PathBuf;
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_host-sim"))
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("host-sim-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn malformed_inputs_fail_with_file_and_line_and_write_nothing() {
    let d = tmp("bad");
    let csv = d.join("bad.csv");
    std::fs::write(&csv, "0,0,0\n1,0,0\n2,zz,0\n").unwrap();
    let gc = d.join("bad.nc");
    std::fs::write(&gc, "G1 X1 F100\nG1 X2\nG76 X3\n").unwrap();
    let toml = d.join("bad.toml");
    std::fs::write(
        &toml,
        "[machine]\nkind = \"fanuc\"\np1622_time_constant = 64\n",
    )
    .unwrap();
    for (args, needle) in [
        (vec!["--path", csv.to_str().unwrap()], "line 3"),
        (vec!["--path", gc.to_str().unwrap()], "line 3"),
        (vec!["--config", toml.to_str().unwrap()], "bad.toml"),
    ] {
        let out_dir = d.join("results");
        let o = bin()
            .arg("compare")
            .args(&args)
            .args(["--feeds", "1000", "--no-plots", "--out-dir"])
            .arg(&out_dir)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?}");
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(
            !out_dir.join("table.txt").exists(),
            "partial report for {args:?}"
        );
    }
}

#[test]
fn compare_writes_table_claims_json_and_plots() {
    let d = tmp("good");
    let o = bin()
        .args([
            "compare",
            "--shapes",
            "trident",
            "--feeds",
            "3000",
            "--methods",
            "constant,fuzzy",
            "--plot-format",
            "svg",
            "--out-dir",
        ])
        .arg(&d)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in [
        "table.txt",
        "table.csv",
        "claims.csv",
        "report.json",
        "config.toml",
    ] {
        assert!(d.join(f).exists(), "{f}");
    }
    let table = std::fs::read_to_string(d.join("table.csv")).unwrap();
    assert_eq!(table.lines().count(), 3);
    let claims = std::fs::read_to_string(d.join("claims.csv")).unwrap();
    assert_eq!(claims.lines().count(), 2);
    assert!(d.join("plots/trident_kinematics_3000.svg").exists());
    assert!(d.join("plots/trident_error_fuzzy_3000.svg").exists());
    assert!(d.join("plots/trident_curvature.svg").exists());
}

#[test]
fn every_option_is_explained() {
    for sub in ["compare", "simulate", "schedule", "toolpath", "plan"] {
        let o = bin().args([sub, "--help"]).output().unwrap();
        let help = String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success());
        // Every long option carries a description, on its line or the next.
        let lines: Vec<&str> = help.lines().collect();
        for (i, line) in lines.iter().enumerate() {
            let t = line.trim_start();
            if !t.starts_with("--") && !t.starts_with("-h") {
                continue;
            }
            let same = t.split_once("  ").map_or("", |x| x.1).trim();
            let next = lines.get(i + 1).map_or("", |l| l.trim());
            assert!(
                !same.is_empty() || (!next.is_empty() && !next.starts_with('-')),
                "{sub}: {line}"
            );
        }
    }
}

#[test]
fn config_prints_a_file_that_reads_back() {
    let d = tmp("cfg");
    let o = bin().arg("config").output().unwrap();
    assert!(o.status.success());
    let f = d.join("c.toml");
    std::fs::write(&f, &o.stdout).unwrap();
    let o = bin()
        .args([
            "simulate",
            "infinity",
            "--f-max",
            "1000",
            "--no-plots",
            "--config",
        ])
        .arg(&f)
        .arg("--out-dir")
        .arg(&d)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(d.join("infinity_fuzzy_1000_motion.csv").exists());
}
