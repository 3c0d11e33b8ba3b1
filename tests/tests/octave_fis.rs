//! Our exported `.fis` opened and evaluated by GNU Octave's
//! fuzzy-logic-toolkit (`readfis`, `evalfis`), compared with our evaluation.
//!
//! Needs `octave-cli` with the `fuzzy-logic-toolkit` package
//! (`apt-get install octave octave-fuzzy-logic-toolkit`). Without it the test
//! is skipped, unless `FUZZY_REQUIRE_OCTAVE=1` (set by `.ci/run`) makes that
//! a failure.

use std::fmt::Write as _;
use std::process::Command;

use fuzzy_core::fuzzy::export::write_fis;
use fuzzy_core::lin2021::{CONTROLLER, SYSTEM};
use fuzzy_core::units::Fx;

fn octave_available() -> bool {
    let ok = Command::new("octave-cli")
        .args(["--no-gui", "-q", "--eval", "pkg load fuzzy-logic-toolkit"])
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false);
    if !ok && std::env::var("FUZZY_REQUIRE_OCTAVE").as_deref() == Ok("1") {
        panic!("octave-cli with fuzzy-logic-toolkit is required (FUZZY_REQUIRE_OCTAVE=1) but not available");
    }
    ok
}

#[test]
fn octave_evaluates_our_exported_controller_like_we_do() {
    if !octave_available() {
        eprintln!("SKIPPED: octave-cli with fuzzy-logic-toolkit not found");
        return;
    }
    let dir = std::env::temp_dir().join(format!("fuzzy-octave-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let fis = dir.join("lin2021.fis");
    let mut text = String::new();
    write_fis(&mut text, &SYSTEM).unwrap();
    std::fs::write(&fis, text).unwrap();
    // Inputs on the Q16.16 grid (exact in both programs), inside the universes.
    let inputs: Vec<[Fx; 2]> = (0..=40)
        .flat_map(|i| (0..=20).map(move |j| [Fx::from_bits(i * 4915), Fx::from_bits(j * 3276)]))
        .collect();
    let mut csv = String::new();
    for x in &inputs {
        writeln!(csv, "{},{}", x[0].to_num::<f64>(), x[1].to_num::<f64>()).unwrap();
    }
    let input_file = dir.join("inputs.csv");
    std::fs::write(&input_file, csv).unwrap();
    let script = format!(
        "pkg load fuzzy-logic-toolkit; fis = readfis('{}'); x = dlmread('{}', ','); y = evalfis(x, fis, 101); printf('%.12f\\n', y);",
        fis.display(),
        input_file.display()
    );
    let out = Command::new("octave-cli")
        .args(["--no-gui", "-q", "--eval", &script])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let ys: Vec<f64> = stdout
        .lines()
        .filter_map(|l| l.trim().parse().ok())
        .collect();
    assert_eq!(
        ys.len(),
        inputs.len(),
        "octave output:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let (mut worst_sampled, mut worst_exact) = (0f64, 0f64);
    for (x, y) in inputs.iter().zip(&ys) {
        let sampled: f64 = CONTROLLER.evaluate_sampled(*x).output.to_num();
        let exact: f64 = CONTROLLER.evaluate(*x).output.to_num();
        worst_sampled = worst_sampled.max((sampled - y).abs());
        worst_exact = worst_exact.max((exact - y).abs());
    }
    eprintln!(
        "octave evalfis (101 points) on {} inputs: vs our 101-sample centroid max diff {:.2e}, vs our exact centroid {:.2e} (fractions of F_max)",
        inputs.len(),
        worst_sampled,
        worst_exact
    );
    // Same definition: only Q16.16 rounding separates them.
    assert!(worst_sampled < 5e-5, "{worst_sampled}");
    // Different definitions (101 samples vs the integral): within 0.2 %.
    assert!(worst_exact < 2e-3, "{worst_exact}");
    let _ = std::fs::remove_dir_all(&dir);
}
