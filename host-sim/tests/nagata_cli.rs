//! `host-sim nagata`: Nagata et al.'s post-processor from the command line
//! (sections 2-4): G-code with F words, the rotary mapping, the machining
//! time against a constant 600 mm/min, and the program read back.

use std::path::PathBuf;
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_host-sim"))
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("host-sim-nagata-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn summary(dir: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
}

#[test]
fn relief_path_is_faster_than_constant_600_and_reads_back() {
    let dir = tmp("relief");
    let out = bin().arg("nagata").arg("--out").arg(&dir).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let s = summary(&dir);
    let r = s["reduction_pct"].as_f64().unwrap();
    assert!(r > 15.0 && r < 30.0, "{s}");
    assert_eq!(s["pick_feed_moves"].as_u64(), Some(40));
    assert!(s["readback_position_error"].as_f64().unwrap() <= 5.1e-5);
    assert!(s["readback_feed_error_mm_per_min"].as_f64().unwrap() <= 0.051);
    // The program goes through the project's own G-code reader with the
    // F words as feed caps.
    let nc = dir.join("program.nc");
    let out = bin().arg("toolpath").arg(&nc).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let csv = String::from_utf8(out.stdout).unwrap();
    let feeds: Vec<f64> = csv
        .lines()
        .skip(2)
        .filter_map(|l| l.split(',').nth(3)?.parse().ok())
        .collect();
    assert!(feeds.contains(&600.0));
    assert!(feeds.iter().any(|f| *f > 1000.0) && feeds.iter().any(|f| *f < 600.0));
    assert!(dir.join("fig5.svg").is_file());
    let moves = std::fs::read_to_string(dir.join("moves.csv")).unwrap();
    assert_eq!(
        moves.lines().count(),
        s["cl_points"].as_u64().unwrap() as usize
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn rotary_output_uses_a_from_eq1() {
    let dir = tmp("rotary");
    let cl = dir.join("cl.csv");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        &cl,
        "x,y,z\n0,0,0\n10,0,0\n10,0.5,0\n0,0.5,0.5\n0,1,0.5\n10,1,0\n",
    )
    .unwrap();
    let out_dir = dir.join("out");
    let out = bin()
        .args(["nagata", "--rotary", "--cl"])
        .arg(&cl)
        .arg("--out")
        .arg(&out_dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let nc = std::fs::read_to_string(out_dir.join("program.nc")).unwrap();
    let g1: Vec<&str> = nc.lines().filter(|l| l.starts_with("G1 X")).collect();
    assert_eq!(g1.len(), 5);
    assert!(
        g1[1].contains("A180.0000") && g1[1].contains("F600.0"),
        "{nc}"
    );
    assert!(g1[4].contains("A360.0000"), "{nc}");
    assert!(!nc.contains(" Y"), "{nc}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_inputs_fail() {
    let dir = tmp("bad");
    std::fs::create_dir_all(&dir).unwrap();
    let flat = dir.join("flat.csv");
    std::fs::write(&flat, "0,0,0\n1,0,0\n").unwrap();
    let broken = dir.join("broken.csv");
    std::fs::write(&broken, "0,0,0\n1,x,0\n").unwrap();
    for args in [
        vec![
            "nagata".into(),
            "--f-min".into(),
            "900".into(),
            "--f-max".into(),
            "600".into(),
        ],
        vec![
            "nagata".into(),
            "--rotary".into(),
            "--cl".into(),
            flat.display().to_string(),
        ],
        vec!["nagata".into(), "--cl".into(), broken.display().to_string()],
        vec!["nagata".into(), "--pick-mm".into(), "0".into()],
    ] {
        let out = bin().args(&args).output().unwrap();
        assert!(!out.status.success(), "{args:?}");
        assert!(
            String::from_utf8_lossy(&out.stderr).contains("error"),
            "{args:?}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
