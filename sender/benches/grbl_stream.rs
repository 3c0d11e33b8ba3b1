//! Streaming through the Grbl front as a character-counting sender streams
//! (bCNC and UGS: at most 128 bytes sent and not yet answered), against
//! the controller simulated on the host: lines a second, the cycle time
//! against the programmed feed, and underruns (the controller ran out of
//! path while the front had it open).
//!
//! `cargo bench -p sender --bench grbl_stream`

use std::collections::VecDeque;
use std::path::Path;
use std::time::{Duration, Instant};

use gcode_interp::GcodeSettings;
use sender::program;
use sender::record::Recorder;
use sender::serve::front::Front;
use sender::sim;
use sender::stream::{Options, Session};

/// Bytes a character-counting sender keeps in flight.
const SENDER_BUFFER: usize = 128;

fn front(speed: f64) -> (Front, sim::SimHandle) {
    let h = sim::start(speed).expect("the simulated controller");
    let s = h.connect().expect("a stream");
    let mut session = Session::new(
        Box::new(s.try_clone().expect("a stream")),
        Box::new(s),
        Recorder::none(),
    );
    let mut o = Options::new(program::scheduler_config(5000.0, 60.0).expect("limits"));
    o.hello_wait = Duration::from_millis(300);
    o.check_settings = false;
    let hs = session.handshake(&o).expect("a handshake");
    let feed_max = hs.feed_max_mm_per_min();
    let f = Front::new(
        session,
        hs.status,
        hs.machine,
        hs.credit_size,
        GcodeSettings::default(),
        feed_max,
    )
    .expect("a front");
    (f, h)
}

struct Run {
    lines: usize,
    answered_s: f64,
    done_s: f64,
    underruns: u32,
    errors: usize,
}

/// Stream `lines` with character counting; the time the last `ok` came and
/// the time the controller came to rest.
fn stream(speed: f64, lines: &[String]) -> Run {
    let (mut f, _h) = front(speed);
    f.connected();
    let u0 = {
        f.poll().expect("poll");
        f.controller_status().underruns
    };
    let t0 = Instant::now();
    let mut in_flight: VecDeque<usize> = VecDeque::new();
    let mut used = 0;
    let mut next = 0;
    let mut answered = 0;
    let mut errors = 0;
    let mut out = String::new();
    let mut answered_s = 0.0;
    loop {
        while next < lines.len() && used + lines[next].len() < SENDER_BUFFER {
            let l = format!("{}\n", lines[next]);
            f.on_bytes(l.as_bytes()).expect("bytes");
            used += l.len();
            in_flight.push_back(l.len());
            next += 1;
        }
        f.poll().expect("poll");
        out.push_str(&f.take_output());
        while let Some(end) = out.find("\r\n") {
            let reply: String = out.drain(..end + 2).collect();
            if reply.starts_with("ok") || reply.starts_with("error") {
                errors += usize::from(reply.starts_with("error"));
                answered += 1;
                used -= in_flight.pop_front().unwrap_or(0);
            }
        }
        if answered == lines.len() && answered_s == 0.0 {
            answered_s = t0.elapsed().as_secs_f64();
        }
        if answered == lines.len() {
            f.on_bytes(b"?").expect("bytes");
            f.poll().expect("poll");
            let o = f.take_output();
            if o.contains("<Idle") {
                break;
            }
        }
        assert!(t0.elapsed() < Duration::from_secs(600), "no end");
    }
    Run {
        lines: lines.len(),
        answered_s,
        done_s: t0.elapsed().as_secs_f64(),
        underruns: f.controller_status().underruns - u0,
        errors,
    }
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    // 2000 moves of 0.05 mm along X at 5000 mm/min: 1667 lines a second
    // for the motion not to wait for the sender.
    let mut short = vec!["G21 G90 G1 F5000".to_string()];
    short.extend((1..=2000).map(|i| format!("X{:.2}", i as f64 * 0.05)));
    let ideal_s = 100.0 / (5000.0 / 60.0);
    let dense: Vec<String> =
        std::fs::read_to_string(root.join("tests/data/cam/surface_ball_end.ngc"))
            .expect("the repository's program")
            .lines()
            .map(str::to_string)
            .collect();
    println!(
        "{:<34} {:>6} {:>8} {:>11} {:>10} {:>9} {:>6}",
        "program", "lines", "speed", "lines/s", "answered", "at rest", "underruns"
    );
    for (name, lines, speed) in [
        ("2000 x 0.05 mm at F5000", &short, 1.0),
        ("surface_ball_end.ngc (F6000 cap)", &dense, 1.0),
        ("surface_ball_end.ngc", &dense, 50.0),
    ] {
        let r = stream(speed, lines);
        println!(
            "{:<34} {:>6} {:>7}x {:>11.0} {:>9.2}s {:>8.2}s {:>6}{}",
            name,
            r.lines,
            speed,
            r.lines as f64 / r.answered_s,
            r.answered_s,
            r.done_s,
            r.underruns,
            if r.errors > 0 {
                format!(" ({} errors)", r.errors)
            } else {
                String::new()
            }
        );
    }
    println!("the 2000-line move at F5000 would take {ideal_s:.2} s at its programmed feed without acceleration");
}
