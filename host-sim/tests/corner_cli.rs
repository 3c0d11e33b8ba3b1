//! `host-sim corner` end to end, on the synthetic corner and the shared
//! FreeCAD profile program.

use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_host-sim"))
}

#[test]
fn corner_compensates_the_synthetic_corner_and_the_freecad_profile() {
    let d = std::env::temp_dir().join(format!("host-sim-corner-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    let nc = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../shared/gcode/freecad_profile.nc"
    );
    let mut cmd = bin();
    cmd.args(["corner", "--modes", "conventional", "--out-dir"])
        .arg(&d);
    let have_nc = std::path::Path::new(nc).exists();
    if have_nc {
        cmd.args(["--path", nc]);
    }
    let o = cmd.output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("corner 90° F900"), "{out}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("corner.json")).unwrap()).unwrap();
    let rows = json.as_array().unwrap();
    assert_eq!(rows.len(), if have_nc { 2 } else { 1 });
    for r in rows {
        let before = r["corner_error_before_mm"].as_f64().unwrap();
        let after = r["corner_error_after_mm"].as_f64().unwrap();
        assert!(after <= 0.0021 && before > after, "{r}");
    }
    assert!(std::fs::read_dir(&d).unwrap().any(|e| e
        .unwrap()
        .path()
        .extension()
        .is_some_and(|x| x == "nc")));
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn corner_rejects_bad_arguments() {
    for args in [
        vec!["corner", "--angle-deg", "180"],
        vec!["corner", "--feed", "0"],
        vec!["corner", "--tolerance-um", "-1"],
        vec!["corner", "--path", "/nonexistent.nc"],
    ] {
        let o = bin().args(&args).output().unwrap();
        assert!(!o.status.success(), "{args:?}");
    }
}
