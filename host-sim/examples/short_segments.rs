//! Writes `tests/data/short_segments.ngc`: a toolpath of many short
//! segments, the case where lookahead planners stutter (issue 6).
//!
//! A 3-D random walk of 5000 G1 moves from the origin, each 0.02-0.2 mm
//! long (uniform), at F5000: the heading turns by a curvature that itself
//! wanders within ±0.5 /mm (radius ≥ 2 mm), every 500 moves a sharp turn of
//! 30-120° (either side), and Z undulates by ±0.5 mm over ~125 mm of
//! travel. Coordinates are written to 0.1 µm (4 decimals), as a CAM
//! post-processor would. A fixed-seed xorshift generator makes it
//! reproducible:
//!
//! ```text
//! cargo run -p host-sim --example short_segments > tests/data/short_segments.ngc
//! ```

use std::fmt::Write as _;

/// xorshift64*: uniform in [0, 1).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn main() {
    let mut rng = Rng(0x5eed_0000_0006);
    let mut out = String::from(
        "(short_segments.ngc: 5000 G1 moves of 0.02-0.2 mm, a 3-D random walk)\n\
         (written by: cargo run -p host-sim --example short_segments)\n\
         G21 G90 G17\n\
         G1 F5000\n",
    );
    let (mut x, mut y, mut s) = (0.0f64, 0.0f64, 0.0f64);
    let (mut heading, mut kappa) = (0.0f64, 0.0f64);
    for i in 1..=5000 {
        let len = 0.02 + 0.18 * rng.next();
        kappa = (kappa + 0.1 * (rng.next() - 0.5)).clamp(-0.5, 0.5);
        heading += kappa * len;
        if i % 500 == 0 {
            let turn = (30.0 + 90.0 * rng.next()).to_radians();
            heading += if rng.next() < 0.5 { turn } else { -turn };
        }
        x += len * heading.cos();
        y += len * heading.sin();
        s += len;
        let z = 0.5 * (s / 20.0).sin();
        // Rounded first, so that no "-0.0000" is written.
        let r = |v: f64| (v * 1e4).round() / 1e4 + 0.0;
        let _ = writeln!(out, "G1 X{:.4} Y{:.4} Z{:.4}", r(x), r(y), r(z));
    }
    out.push_str("M2\n");
    print!("{out}");
}
