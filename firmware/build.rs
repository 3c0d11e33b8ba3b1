//! Puts `memory.x` (repository root; `memory-bl32k.x` for the BTT SKR 2,
//! feature `skr2`) on the linker search path, and records
//! the three test shapes, quantised exactly as the host does
//! (`Point3Mm::from_f64`), as raw I32F32 bits for the cost benchmark. (The
//! `FW_*` settings are read, and tracked, by the `controller` crate.)
use std::env;
use std::fs;
use std::path::PathBuf;

use fuzzy_core::units::Point3Mm;

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("OUT_DIR"));
    // The BTT SKR 2's image sits behind its 32 KiB bootloader.
    let memory = if env::var_os("CARGO_FEATURE_SKR2").is_some() {
        "memory-bl32k.x"
    } else {
        "../memory.x"
    };
    fs::copy(memory, out.join("memory.x")).expect("copy memory.x");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=../memory.x");
    println!("cargo:rerun-if-changed=memory-bl32k.x");
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
