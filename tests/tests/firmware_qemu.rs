//! The firmware, running in QEMU (`netduinoplus2`, an STM32F405, with
//! `-icount shift=0`), driven over its emulated USART with the `link`
//! protocol:
//!
//! - the paper's ∞, trident and butterfly paths: the feeds the firmware
//!   schedules equal `fuzzy-core`'s on the host bit for bit, and the tool
//!   ends exactly on the last point;
//! - underrun: a path that stops arriving ends in a stop within the
//!   acceleration, at the last scheduled point, and resumes without a jump;
//! - feed hold and resume; feed override; corrupted frames.
//!
//! Needs `qemu-system-arm`; skipped without it unless `FUZZY_REQUIRE_QEMU=1`
//! (set by `scripts/test.sh`). Each QEMU is killed when its test ends, and
//! every wait has a deadline, so a hung firmware fails instead of hanging.

use std::time::Duration;

use fuzzy_core::lin2021::CONTROLLER;
use fuzzy_core::scheduler::{PathPoint, Scheduler, SchedulerConfig};
use fuzzy_core::units::{FeedMmPerMin, Point3Mm};
use link::{ErrorCode, HostMsg, Motion, Status};
use system_tests::firmware::{qemu_available, read_points, repo_root, Firmware};

const F_MAX: i32 = 3000;
const F_MIN: i32 = 60;

fn config() -> SchedulerConfig {
    SchedulerConfig::new(FeedMmPerMin::from_int(F_MAX), FeedMmPerMin::from_int(F_MIN))
}

/// The host's schedule: (index, feed bits) per point.
fn host_feeds(points: &[Point3Mm]) -> Vec<(u32, i64)> {
    let mut s: Scheduler<_, 30, 9, 40> = Scheduler::new(&CONTROLLER, config()).unwrap();
    let mut out = Vec::new();
    s.run(points.iter().map(|p| PathPoint::at(*p)), |o| {
        out.push((o.index, o.feed.0.to_bits()))
    })
    .unwrap();
    out
}

/// A straight line along x from 0, `n` points `step_mm` apart.
fn line(n: usize, step_mm: f64) -> Vec<Point3Mm> {
    (0..n)
        .map(|i| Point3Mm::from_f64(i as f64 * step_mm, 0.0, 0.0).unwrap())
        .collect()
}

fn feed(s: &Status) -> f64 {
    s.feed_mm_per_min as f64 / 4294967296.0
}

fn pos(s: &Status) -> [f64; 3] {
    s.pos_mm.map(|b| b as f64 / 4294967296.0)
}

/// Consecutive status samples: the feed never changes faster than the
/// acceleration limit allows (mm/min per tick = a · 60 / tick rate), and
/// the position never moves farther than the fastest feed allows.
fn check_smooth(samples: &[Status], hello: (u32, u32), max_feed: f64) {
    let (hz, accel) = (hello.0 as f64, hello.1 as f64);
    let dfeed_per_tick = accel * 60.0 / hz;
    for w in samples.windows(2) {
        let dt = w[1].ticks.wrapping_sub(w[0].ticks) as f64;
        let df = (feed(&w[1]) - feed(&w[0])).abs();
        assert!(
            df <= dfeed_per_tick * dt + 1e-6,
            "feed {} -> {} in {dt} ticks (limit {dfeed_per_tick}/tick)",
            feed(&w[0]),
            feed(&w[1])
        );
        let (a, b) = (pos(&w[0]), pos(&w[1]));
        let d = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
        let most = max_feed / 60.0 / hz * dt;
        assert!(
            d <= most + 1e-6,
            "moved {d} mm in {dt} ticks (at most {most})"
        );
    }
}

fn run_shape(name: &str) -> String {
    let pts = read_points(&repo_root().join(format!("tests/data/shapes/{name}.csv")));
    let want = host_feeds(&pts);
    let mut fw = Firmware::start(name);
    let first = fw.start_path(&config()) + 1;
    fw.points(&pts);
    fw.end_path();
    fw.flush(Duration::from_secs(240));
    let end = fw.poll_until(Duration::from_millis(200), Duration::from_secs(240), |s| {
        s.motion == Motion::Idle && s.segments_done as usize >= want.len()
    });
    let last = *end.last().unwrap();
    let got = fw.scheduled_in_order();
    assert_eq!(got.len(), want.len(), "{name}: points scheduled");
    for (i, (g, w)) in got.iter().zip(&want).enumerate() {
        assert_eq!(g.seq, first + i as u32, "{name}: point {i} out of order");
        assert_eq!(g.index, w.0, "{name}: index of point {i}");
        assert_eq!(
            g.feed_bits,
            w.1,
            "{name}: feed of point {i}: firmware {} host {} mm/min",
            g.feed_bits as f64 / 4294967296.0,
            w.1 as f64 / 4294967296.0
        );
    }
    assert_eq!(
        last.pos_mm,
        pts.last().unwrap().to_bits(),
        "{name}: end point"
    );
    assert_eq!(last.bad_frames, 0);
    assert!(fw.alive(), "{name}: QEMU exited");
    format!(
        "{name}: {} points bit-exact; underruns {}, resends {}, worst tick {} cycles = {} instructions, stack {} bytes",
        want.len(),
        last.underruns,
        fw.resends,
        last.worst_tick_cycles,
        last.worst_tick_cycles as u64 * 1000 / 168,
        last.stack_used_bytes
    )
}

#[test]
fn shapes_are_scheduled_bit_for_bit_like_the_host() {
    if !qemu_available() {
        return;
    }
    // One QEMU per shape, side by side.
    let handles: Vec<_> = ["infinity", "trident", "butterfly"]
        .into_iter()
        .map(|n| std::thread::spawn(move || run_shape(n)))
        .collect();
    for h in handles {
        match h.join() {
            Ok(line) => println!("{line}"),
            Err(e) => std::panic::resume_unwind(e),
        }
    }
}

#[test]
fn underrun_stops_within_the_acceleration_and_resumes_without_a_jump() {
    if !qemu_available() {
        return;
    }
    let pts = line(400, 0.5);
    let mut fw = Firmware::start("underrun");
    fw.start_path(&config());
    let sent = 150;
    fw.points(&pts[..sent]);
    fw.flush(Duration::from_secs(30));
    // The scheduler releases a point once its lookahead is complete: the
    // last one released is `sent - 1 - LATENCY`.
    let latency = 35;
    let last_known = pts[sent - 1 - latency].to_bits();
    let stop = fw.poll_until(Duration::from_millis(5), Duration::from_secs(30), |s| {
        s.motion == Motion::Starved && s.feed_mm_per_min == 0
    });
    check_smooth(&stop, fw.hello, F_MAX as f64);
    let s = *stop.last().unwrap();
    assert_eq!(s.pos_mm, last_known, "stopped at the last scheduled point");
    // (At least: a host stalled by a loaded machine may starve it earlier.)
    assert!(s.underruns >= 1);
    assert!(
        stop.iter().any(|s| feed(s) > 2900.0),
        "it was running at full feed before"
    );
    // Standing still while starved.
    std::thread::sleep(Duration::from_millis(200));
    assert_eq!(fw.status().pos_mm, last_known);
    // The rest arrives: it moves on from there to the end.
    fw.points(&pts[sent..]);
    fw.end_path();
    let mut seen = vec![fw.status()];
    fw.flush(Duration::from_secs(30));
    seen.extend(
        fw.poll_until(Duration::from_millis(5), Duration::from_secs(30), |s| {
            s.motion == Motion::Idle && s.pos_mm == pts.last().unwrap().to_bits()
        }),
    );
    check_smooth(&seen, fw.hello, F_MAX as f64);
    assert!(seen.iter().any(|s| feed(s) > 2900.0));
    println!(
        "underrun: stopped at x = {} mm, resumed; {} samples checked",
        pos(&s)[0],
        stop.len() + seen.len()
    );
}

#[test]
fn feed_hold_decelerates_and_resume_continues() {
    if !qemu_available() {
        return;
    }
    let pts = line(300, 0.5);
    let mut fw = Firmware::start("hold");
    fw.start_path(&config());
    fw.points(&pts);
    fw.end_path();
    fw.flush(Duration::from_secs(30));
    let cruise = fw.poll_until(Duration::from_millis(10), Duration::from_secs(30), |s| {
        feed(s) >= F_MAX as f64 - 0.01
    });
    let underruns = cruise.last().unwrap().underruns;
    fw.send(&HostMsg::Hold);
    let mut stop = vec![*cruise.last().unwrap()];
    stop.extend(
        fw.poll_until(Duration::from_millis(5), Duration::from_secs(10), |s| {
            s.motion == Motion::Held && s.feed_mm_per_min == 0
        }),
    );
    check_smooth(&stop, fw.hello, F_MAX as f64);
    let held = *stop.last().unwrap();
    let ticks = held.ticks - stop[0].ticks;
    // 50 mm/s at 1000 mm/s² takes 50 ms: at least that many ticks.
    assert!(ticks >= 50, "stopped in {ticks} ticks");
    std::thread::sleep(Duration::from_millis(300));
    let still = fw.status();
    assert_eq!(still.pos_mm, held.pos_mm, "held still");
    assert_eq!(still.motion, Motion::Held);
    fw.send(&HostMsg::Resume);
    let mut go = vec![still];
    go.extend(
        fw.poll_until(Duration::from_millis(5), Duration::from_secs(30), |s| {
            s.motion == Motion::Idle
        }),
    );
    check_smooth(&go, fw.hello, F_MAX as f64);
    assert_eq!(go.last().unwrap().pos_mm, pts.last().unwrap().to_bits());
    assert_eq!(
        stop.last().unwrap().underruns,
        underruns,
        "a hold is not an underrun"
    );
    println!(
        "hold: stopped in {ticks} ticks at x = {} mm, resumed to the end",
        pos(&held)[0]
    );
}

#[test]
fn feed_override_scales_the_feed() {
    if !qemu_available() {
        return;
    }
    let pts = line(600, 0.5);
    let mut fw = Firmware::start("override");
    fw.start_path(&config());
    fw.points(&pts);
    fw.end_path();
    fw.flush(Duration::from_secs(30));
    let near = |f: f64| move |s: &Status| (feed(s) - f).abs() < 0.05;
    fw.poll_until(
        Duration::from_millis(10),
        Duration::from_secs(30),
        near(3000.0),
    );
    fw.send(&HostMsg::Override { percent: 50 });
    let mut seen = fw.poll_until(
        Duration::from_millis(5),
        Duration::from_secs(10),
        near(1500.0),
    );
    assert_eq!(seen.last().unwrap().override_percent, 50);
    // Out of range: refused, nothing changes.
    let errors = fw.errors.len();
    fw.send(&HostMsg::Override { percent: 5 });
    fw.send(&HostMsg::Override { percent: 201 });
    let s = fw.status();
    assert_eq!(s.override_percent, 50);
    assert_eq!(
        fw.errors[errors..].iter().map(|e| e.0).collect::<Vec<_>>(),
        vec![ErrorCode::OutOfRange, ErrorCode::OutOfRange]
    );
    seen.push(s);
    fw.send(&HostMsg::Override { percent: 200 });
    seen.extend(fw.poll_until(
        Duration::from_millis(5),
        Duration::from_secs(10),
        near(6000.0),
    ));
    check_smooth(&seen, fw.hello, 2.0 * F_MAX as f64);
    fw.send(&HostMsg::Override { percent: 100 });
    let end = fw.poll_until(Duration::from_millis(20), Duration::from_secs(30), |s| {
        s.motion == Motion::Idle
    });
    assert_eq!(end.last().unwrap().pos_mm, pts.last().unwrap().to_bits());
    println!("override: 100 % -> 50 % (1500 mm/min) -> 200 % (6000 mm/min); 5 % and 201 % refused");
}

/// Encode a message, then let `f` damage the frame.
fn damaged(msg: &HostMsg, f: impl FnOnce(&mut Vec<u8>)) -> Vec<u8> {
    let mut buf = [0u8; link::FRAME_MAX];
    let n = link::encode(msg, &mut buf).unwrap();
    let mut v = buf[..n].to_vec();
    f(&mut v);
    v
}

/// A frame with a valid CRC around an arbitrary payload.
fn raw_frame(payload: &[u8]) -> Vec<u8> {
    let crc = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC).checksum(payload);
    let mut body = payload.to_vec();
    body.extend(crc.to_le_bytes());
    let mut out = vec![0u8; body.len() + 2 + body.len() / 254];
    let n = cobs::encode(&body, &mut out);
    out.truncate(n);
    out.push(0);
    out
}

#[test]
fn corrupted_frames_are_refused_and_no_acknowledged_point_is_lost() {
    if !qemu_available() {
        return;
    }
    let pts = read_points(&repo_root().join("tests/data/shapes/trident.csv"));
    let pts = &pts[..400];
    let want = host_feeds(pts);
    let mut fw = Firmware::start("corrupt");
    let first = fw.start_path(&config()) + 1;
    fw.points(pts);
    fw.end_path();
    // Stream, and every 50 commands throw in bad frames of every kind.
    let mut round = 0u32;
    let mut expect = Vec::new();
    while !fw.all_acked() {
        fw.transmit();
        fw.pump(Duration::from_millis(20));
        let seq = fw.acked;
        if seq >= round * 50 + 10 && round < 6 {
            round += 1;
            let good = HostMsg::Point {
                seq,
                pos_mm: pts[(seq - first).min(pts.len() as u32 - 1) as usize].to_bits(),
                feed_cap_mm_per_min: None,
            };
            let bad: Vec<(Vec<u8>, ErrorCode)> = vec![
                // A bit flipped: CRC.
                (damaged(&good, |v| v[3] ^= 0x04), ErrorCode::Crc),
                // Truncated: the tail lost, delimiter kept.
                (
                    damaged(&good, |v| {
                        let n = v.len();
                        v.drain(n - 5..n - 1);
                    }),
                    ErrorCode::Crc,
                ),
                // Too short to hold a CRC.
                (vec![0x03, 0x11, 0x22, 0x00], ErrorCode::TooShort),
                // Line noise longer than any frame.
                (
                    (0..300u32)
                        .map(|i| (i.wrapping_mul(2_654_435_761) >> 24) as u8 | 1)
                        .chain([0])
                        .collect(),
                    ErrorCode::TooLong,
                ),
                // A message we do not know (valid CRC).
                (raw_frame(&[42, 1, 2, 3]), ErrorCode::UnknownMessage),
                // A known message with its fields missing.
                (raw_frame(&[2]), ErrorCode::Malformed),
                // Out of range: a coordinate of 1 km, a 500 % override.
                (
                    damaged(
                        &HostMsg::Point {
                            // The next one expected once those in flight
                            // are in (an older seq would be taken for a
                            // resend and acknowledged again).
                            seq: fw.send_next,
                            pos_mm: [1_000_000i64 << 32, 0, 0],
                            feed_cap_mm_per_min: None,
                        },
                        |_| {},
                    ),
                    ErrorCode::OutOfRange,
                ),
                (
                    damaged(&HostMsg::Override { percent: 500 }, |_| {}),
                    ErrorCode::OutOfRange,
                ),
                // A point from the future: out of sequence.
                (
                    damaged(
                        &HostMsg::Point {
                            seq: fw.send_next + 5,
                            pos_mm: [0; 3],
                            feed_cap_mm_per_min: None,
                        },
                        |_| {},
                    ),
                    ErrorCode::OutOfSequence,
                ),
            ];
            for (bytes, code) in bad {
                fw.send_raw(&bytes);
                expect.push(code);
            }
        }
    }
    fw.flush(Duration::from_secs(60));
    let end = fw.poll_until(Duration::from_millis(100), Duration::from_secs(120), |s| {
        s.motion == Motion::Idle && s.segments_done as usize >= want.len()
    });
    let got = fw.scheduled_in_order();
    assert_eq!(got.len(), want.len(), "every acknowledged point scheduled");
    for (i, (g, w)) in got.iter().zip(&want).enumerate() {
        assert_eq!(g.seq, first + i as u32);
        assert_eq!((g.index, g.feed_bits), *w, "point {i}");
    }
    let codes: Vec<ErrorCode> = fw.errors.iter().map(|e| e.0).collect();
    for code in &expect {
        assert!(codes.contains(code), "no {code:?} reply; got {codes:?}");
    }
    let last = end.last().unwrap();
    assert!(
        last.bad_frames as usize >= expect.len(),
        "{} bad frames counted, {} sent: {codes:?}",
        last.bad_frames,
        expect.len()
    );
    assert_eq!(last.pos_mm, pts.last().unwrap().to_bits());
    println!(
        "corrupted frames: {} bad frames sent, {} refused, {} resends; all {} points scheduled bit-exact",
        expect.len(),
        last.bad_frames,
        fw.resends,
        want.len()
    );
}
