//! Puts `memory.x` (repository root) on the linker search path, and records
//! the three test shapes, quantised exactly as the host does
//! (`Point3Mm::from_f64`), as raw I32F32 bits for the cost benchmark.
use std::env;
use std::fs;
use std::path::PathBuf;

use fuzzy_core::units::Point3Mm;

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("OUT_DIR"));
    fs::copy("../memory.x", out.join("memory.x")).expect("copy ../memory.x");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=../memory.x");
    for var in [
        "FW_TICK_HZ",
        "FW_STEPS_PER_MM",
        "FW_FEED_MAX_MM_PER_MIN",
        "FW_AXIS_SPEED_MM_PER_MIN",
        "FW_AXIS_ACCEL_MM_PER_S2",
        "FW_JERK_MM_PER_S3",
        "FW_CHORD_NM",
        "FW_TANGENTIAL_SHARE_PERCENT",
    ] {
        println!("cargo:rerun-if-env-changed={var}");
    }
    for shape in ["infinity", "trident", "butterfly"] {
        let src = format!("../tests/data/shapes/{shape}.csv");
        println!("cargo:rerun-if-changed={src}");
        let text = fs::read_to_string(&src).expect("read shape");
        let mut bytes = Vec::new();
        for line in text.lines() {
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') || line.starts_with('x') {
                continue;
            }
            let v: Vec<f64> = line
                .split(',')
                .map(|c| c.trim().parse().expect("number"))
                .collect();
            let p = Point3Mm::from_f64(v[0], v[1], v[2]).expect("coordinate");
            for b in p.to_bits() {
                bytes.extend_from_slice(&b.to_le_bytes());
            }
        }
        fs::write(out.join(format!("{shape}.bin")), bytes).expect("write shape");
    }
}
