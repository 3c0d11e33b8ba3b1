//! Any bytes as a G-code program: the reader returns a toolpath or an
//! error, never panics, aborts or runs without end (its bounds are set low
//! so each input stays fast).
#![no_main]

use gcode_interp::{self as gcode, GcodeSettings, Limits};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let settings = GcodeSettings {
        limits: Limits {
            max_points: 200_000,
            max_executed_lines: 50_000,
            max_call_depth: 10,
        },
        ..Default::default()
    };
    let _ = gcode::parse("fuzz", &String::from_utf8_lossy(data), &settings);
});
