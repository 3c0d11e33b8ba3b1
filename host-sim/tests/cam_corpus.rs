//! The committed CAM programs of `tests/data/cam/` are what
//! `host_sim::cam_corpus` generates (regenerate with
//! `cargo run -p host-sim --example cam_corpus`), host-sim reads them, and
//! they have the shape their README describes.

use std::path::PathBuf;

use host_sim::gcode::GcodeSettings;
use host_sim::inputs;

fn dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tests/data/cam")
}

#[test]
fn committed_programs_are_the_generated_ones_and_read_back() {
    for (name, text) in host_sim::cam_corpus::programs() {
        let committed = std::fs::read_to_string(dir().join(name)).unwrap();
        assert!(committed == text, "{name} differs from the generator");
        let t = inputs::load(&dir().join(name), &GcodeSettings::default()).unwrap();
        assert!(t.len() > 100, "{name}: {} points", t.len());
    }
}

#[test]
fn the_surfacing_pass_has_thousands_of_short_3d_segments() {
    let t = inputs::load(
        &dir().join("surface_ball_end.ngc"),
        &GcodeSettings::default(),
    )
    .unwrap();
    // Cutting segments (below the safe height, after the plunge).
    let segs: Vec<f64> = (1..t.len())
        .filter(|&i| t.points[i][2] < 0.0 && t.points[i - 1][2] < 0.0)
        .map(|i| t.block_length_mm(i))
        .filter(|l| *l > 1e-9)
        .collect();
    assert!(segs.len() > 2000, "{}", segs.len());
    let (lo, hi) = segs
        .iter()
        .fold((f64::MAX, 0.0f64), |(a, b), l| (a.min(*l), b.max(*l)));
    // Along the rows 0.01-0.5 mm; the stepovers are 0.8 mm (and a little
    // more where z changes).
    assert!(lo >= 0.0099 && hi <= 0.81, "{lo} {hi}");
    let short = segs.iter().filter(|l| **l <= 0.5 + 1e-9).count();
    assert!(short + 25 >= segs.len(), "{short} of {}", segs.len());
    let zs: Vec<f64> = t.points.iter().map(|p| p[2]).filter(|z| *z < 0.0).collect();
    let (zmin, zmax) = zs
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), z| (a.min(*z), b.max(*z)));
    assert!(zmax - zmin > 2.0, "a 3-D surface: z {zmin}..{zmax}");
}
