//! `host-sim cho` end to end.

use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_host-sim"))
}

#[test]
fn cho_prints_the_table_and_writes_its_files() {
    let d = std::env::temp_dir().join(format!("host-sim-cho-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    let o = bin()
        .args(["cho", "--contours", "circle", "--both-tables", "--out-dir"])
        .arg(&d)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("circle  completed") && out.contains("circle  printed"),
        "{out}"
    );
    for f in [
        "table.txt",
        "cho.json",
        "circle_completed_fuzzy.csv",
        "circle_printed_constant.csv",
    ] {
        assert!(d.join(f).exists(), "{f}");
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("cho.json")).unwrap()).unwrap();
    let t = json[0]["fuzzy"]["cycle_time_s"].as_f64().unwrap();
    assert!(t > 1.5 && t < 4.0, "{t}");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn cho_rejects_bad_arguments() {
    for args in [
        vec!["cho", "--bound-um", "0"],
        vec!["cho", "--f-max", "10"],
        vec!["cho", "--contours", "square"],
    ] {
        let o = bin().args(&args).output().unwrap();
        assert!(!o.status.success(), "{args:?}");
    }
    let o = bin().args(["cho", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&o.stdout);
    for opt in [
        "--contours",
        "--bound-um",
        "--printed-rules",
        "--f-max",
        "--out-dir",
    ] {
        assert!(help.contains(opt), "{opt}");
    }
}
