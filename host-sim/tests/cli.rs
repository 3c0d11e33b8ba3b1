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

/// Inputs that would take days of motion or gigabytes of samples are
/// refused at once, naming the limit; an output file is written whole or
/// not at all.
#[test]
fn runaway_runs_are_refused_before_they_allocate_and_leave_no_file() {
    let d = tmp("bounds");
    let slow = d.join("slow.csv");
    std::fs::write(
        &slow,
        "x,y,z,feed\n0,0,0,0.003\n10,0,0,0.003\n20,5,0,0.003\n",
    )
    .unwrap();
    let o = bin()
        .args([
            "simulate",
            "--method",
            "constant",
            "--f-max",
            "0.003",
            "--no-plots",
            "--out-dir",
        ])
        .arg(d.join("sim"))
        .arg(&slow)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(err.contains("max_motion_samples"), "{err}");
    assert!(!d.join("sim").join("slow_motion.csv").exists());

    let cfg = d.join("tc.toml");
    let text = String::from_utf8(bin().arg("config").output().unwrap().stdout).unwrap();
    let text: String = text
        .lines()
        .map(|l| {
            if l.starts_with("p1622_time_constant_ms") {
                "p1622_time_constant_ms = 1e9".to_string()
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::write(&cfg, text).unwrap();
    let o = bin()
        .args(["simulate", "infinity", "--no-plots", "--config"])
        .arg(&cfg)
        .arg("--out-dir")
        .arg(d.join("sim2"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(err.contains("time constants"), "{err}");

    // A schedule refused part way (a bad row after good ones) leaves the
    // previous output as it was and no temporary file.
    let bad = d.join("bad.csv");
    std::fs::write(&bad, "0,0,0\n1,0,0\n2,1,0\n3,1,0\n3,1,nan\n").unwrap();
    let out = d.join("out.csv");
    std::fs::write(&out, "old").unwrap();
    let o = bin()
        .arg("schedule")
        .arg(&bad)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "old");
    let good = d.join("good.csv");
    std::fs::write(&good, "0,0,0\n1,0,0\n2,1,0\n3,1,0\n").unwrap();
    let o = bin()
        .arg("schedule")
        .arg(&good)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(std::fs::read_to_string(&out).unwrap().starts_with("line,"));
    let names: Vec<String> = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(names.is_empty(), "temporary files left: {names:?}");
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
