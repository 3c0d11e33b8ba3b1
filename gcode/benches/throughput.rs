//! The interpreter's throughput: lines a second on programs of the
//! repository, read whole and fed a line at a time (as a live front feeds
//! it), the median of repeated runs.
//!
//! `cargo bench -p gcode-interp --bench throughput`

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use gcode_interp::interp::Interp;
use gcode_interp::machine::Collect;
use gcode_interp::GcodeSettings;

fn median(mut v: Vec<Duration>) -> Duration {
    v.sort();
    v[v.len() / 2]
}

fn time(runs: usize, mut f: impl FnMut() -> usize) -> (Duration, usize) {
    let mut points = 0;
    let t: Vec<Duration> = (0..runs)
        .map(|_| {
            let t0 = Instant::now();
            points = std::hint::black_box(f());
            t0.elapsed()
        })
        .collect();
    (median(t), points)
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let files: Vec<PathBuf> = [
        "tests/data/short_segments.ngc",
        "tests/data/cam/surface_ball_end.ngc",
        "tests/data/cam/pocket_arcs.ngc",
        "tests/data/cam/short_arcs.ngc",
    ]
    .iter()
    .map(|f| root.join(f))
    .collect();
    let settings = Arc::new(GcodeSettings::default());
    println!(
        "{:<24} {:>7} {:>8} {:>14} {:>14}",
        "program", "lines", "points", "whole lines/s", "live lines/s"
    );
    for f in files {
        let text = std::fs::read_to_string(&f).expect("a repository program");
        let lines = text.lines().count();
        let (whole, points) = time(15, || {
            let mut it = Interp::new(settings.clone(), None).unwrap();
            it.load_main(&text, None).unwrap();
            let mut c = Collect::default();
            it.run_with(&mut c).unwrap();
            c.points.len()
        });
        let (live, _) = time(15, || {
            let mut it = Interp::new(settings.clone(), None).unwrap();
            it.start_live();
            let mut c = Collect::default();
            for l in text.lines() {
                it.push_line(l).unwrap();
                it.run_with(&mut c).unwrap();
            }
            c.points.len()
        });
        let rate = |d: Duration| lines as f64 / d.as_secs_f64();
        println!(
            "{:<24} {:>7} {:>8} {:>14.0} {:>14.0}",
            f.file_name().unwrap().to_string_lossy(),
            lines,
            points,
            rate(whole),
            rate(live)
        );
    }
}
