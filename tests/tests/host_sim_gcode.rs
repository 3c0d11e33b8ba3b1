//! Real G-code programs (`../shared/gcode/`) read by host-sim agree with the
//! recorded toolpaths in `tests/data/gcode/` (golden files; set
//! `HOST_SIM_BLESS=1` to rewrite them after a deliberate change), and the
//! program with expressions follows the path its expressions give.
//!
//! The programs live beside the repository (`../shared`, as in CI); where
//! they are missing the comparison is skipped with a note.

use std::path::PathBuf;

use host_sim::gcode::{self, GcodeSettings};
use host_sim::inputs;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn shared(name: &str) -> Option<PathBuf> {
    let p = root().join("../shared/gcode").join(name);
    p.exists().then_some(p)
}

#[test]
fn programs_match_their_recorded_toolpaths() {
    for (program, recorded) in [
        ("freecad_profile.nc", "freecad_profile.csv"),
        ("linuxcnc_butterfly_g52.ngc", "linuxcnc_butterfly_g52.csv"),
    ] {
        let rec_path = root().join("tests/data/gcode").join(recorded);
        let recorded_path = inputs::load(&rec_path, &GcodeSettings::default()).unwrap();
        let Some(src) = shared(program) else {
            eprintln!("SKIPPED: ../shared/gcode/{program} not found");
            continue;
        };
        let t = gcode::read(&src, &GcodeSettings::default()).unwrap();
        if std::env::var("HOST_SIM_BLESS").as_deref() == Ok("1") {
            let mut out = String::from("x,y,z,feed\n");
            for i in 0..t.len() {
                let p = t.points[i];
                let f = t.feed_caps[i].map_or(String::new(), |f| format!("{f}"));
                out.push_str(&format!("{},{},{},{}\n", p[0], p[1], p[2], f));
            }
            std::fs::write(&rec_path, out).unwrap();
            continue;
        }
        assert_eq!(t.len(), recorded_path.len(), "{program}");
        for (a, b) in t.points.iter().zip(&recorded_path.points) {
            for k in 0..3 {
                assert!((a[k] - b[k]).abs() < 1e-9, "{program}: {a:?} vs {b:?}");
            }
        }
        assert_eq!(t.feed_caps, recorded_path.feed_caps, "{program}");
    }
}

#[test]
fn recorded_toolpaths_have_the_programs_shape() {
    // FreeCAD profile: a 74.4 × 64.3 mm rounded rectangle (tool radius
    // 3.175 mm on a 68.1 × 58 mm pocket) at Z −1.62, F400.
    let t = inputs::load(
        &root().join("tests/data/gcode/freecad_profile.csv"),
        &GcodeSettings::default(),
    )
    .unwrap();
    let xs = t.points.iter().map(|p| p[0]);
    let (lo, hi) = xs.fold((f64::MAX, f64::MIN), |(a, b), x| (a.min(x), b.max(x)));
    assert!(
        (lo + 3.15).abs() < 1e-6 && (hi - 71.272).abs() < 1e-6,
        "{lo} {hi}"
    );
    assert!(t.feed_caps.iter().flatten().any(|f| *f == 400.0));
    // LinuxCNC butterfly: five NURBS blocks between ±35.4 mm in X.
    let b = inputs::load(
        &root().join("tests/data/gcode/linuxcnc_butterfly_g52.csv"),
        &GcodeSettings::default(),
    )
    .unwrap();
    let xmax = b.points.iter().map(|p| p[0]).fold(f64::MIN, f64::max);
    assert!(xmax > 30.0 && xmax < 36.0, "{xmax}");
    assert!(b.len() > 1000);
}

#[test]
fn expressions_are_evaluated() {
    let Some(src) = shared("linuxcnc_square_spiral_expr.ngc") else {
        eprintln!("SKIPPED: ../shared/gcode not found");
        return;
    };
    let t = gcode::read(&src, &GcodeSettings::default()).unwrap();
    // The program (inch) plunges to Z-.19, steps to X.01, then walks a
    // square spiral: for k = 2…6 the corners (x, .01k) (−.01k, .01k)
    // (−.01k, −.01k) and, but for the last, (.01(k+1), −.01k); then X0, Y0.
    let mut xy = vec![[0.0, 0.0], [0.01, 0.0]];
    for k in 2..=6 {
        let v = 0.01 * k as f64;
        let x = xy.last().unwrap()[0];
        xy.extend([[x, v], [-v, v], [-v, -v]]);
        if k < 6 {
            xy.push([0.01 * (k + 1) as f64, -v]);
        }
    }
    xy.extend([[0.0, -0.06], [0.0, 0.0]]);
    let got: Vec<[f64; 3]> = t.points[1..].to_vec();
    assert_eq!(got.len(), xy.len(), "{got:?}");
    for (p, e) in got.iter().zip(&xy) {
        assert!(
            (p[0] - e[0] * 25.4).abs() < 1e-9
                && (p[1] - e[1] * 25.4).abs() < 1e-9
                && (p[2] + 0.19 * 25.4).abs() < 1e-9,
            "{p:?} vs {e:?}"
        );
    }
}
