//! The firmware, running in QEMU (`netduinoplus2`, an STM32F405, with
//! `-icount shift=0`), driven over its emulated USART with the `link`
//! protocol:
//!
//! - the paper's ∞, trident and butterfly paths: the feeds the firmware
//!   schedules equal `fuzzy-core`'s on the host bit for bit, and the tool
//!   ends exactly on the last point;
//! - underrun: a path that stops arriving ends in a stop within the
//!   acceleration, at the last scheduled point, and resumes without a jump;
//! - feed hold and resume; feed override; Njiri et al.'s force loop fed
//!   force samples over the link; corrupted frames;
//! - in every test, the planned motion: the firmware reports every input
//!   of its velocity planner with its tick and a checksum of its
//!   setpoints; the host replays the same inputs into its own planner
//!   (`system_tests::planned`), requires the same setpoints bit for bit
//!   (checksum at every status, executed position), and checks them
//!   against the per-axis speed and acceleration limits and the tangential
//!   acceleration and jerk limits;
//! - probing: the probe input tripped mid-move through QEMU's USART2 (the
//!   image's stand-in for its pins), the trip reported where the steps
//!   were, the tool stopped under control short of the target;
//! - the link at real wire rates: four programs at 115 200 and 921 600
//!   baud through a pipe paced in the firmware's own time
//!   (`system_tests::firmware::GuestClock`), bytes a point each way
//!   printed; line noise without a delimiter skipped at the next one;
//! - the cost benchmark (`firmware/src/bin/cost.rs`, 0.05 mm line, shapes,
//!   with and without hold/override/starvation events) prints checksums
//!   of its commanded positions, which the host recomputes with the same
//!   code (`controller::replay`).
//!
//! Needs `qemu-system-arm`; skipped without it unless `FUZZY_REQUIRE_QEMU=1`
//! (set by `scripts/test.sh`). Each QEMU is killed when its test ends, and
//! every wait has a deadline, so a hung firmware fails instead of hanging.
//! The deadlines are generous: under `-icount` a loaded host slows the
//! guest's clock (a 6 s motion took over 30 s with 2 cores shared by
//! several builds).

use std::time::{Duration, Instant};

use controller::replay::{self, NoClock, Replay};
use controller::settings::{Plan, Sched, MOTION_CONFIG, PLANNER_POINTS};
use fuzzy_core::lin2021::COMPACT;
use fuzzy_core::scheduler::{PathPoint, SchedulerConfig};
use fuzzy_core::units::{FeedMmPerMin, Point3Mm, SpeedMmPerTick};
use link::client::Hello;
use link::{ErrorCode, HostMsg, Motion, Status};
use system_tests::firmware::{on_grid, qemu_available, read_points, repo_root, Firmware};
use system_tests::planned::{self, Peaks};

const F_MAX: i32 = 3000;
const F_MIN: i32 = 60;

fn config() -> SchedulerConfig {
    SchedulerConfig::new(FeedMmPerMin::from_int(F_MAX), FeedMmPerMin::from_int(F_MIN))
}

/// The host's schedule (the controller's scheduler): (index, feed bits)
/// per point.
fn host_feeds(points: &[PathPoint]) -> Vec<(u32, i64)> {
    let mut s = Sched::new(&COMPACT, config()).unwrap();
    let mut out = Vec::new();
    s.run(points.iter().copied(), |o| {
        out.push((o.index, o.feed.0.to_bits()))
    })
    .unwrap();
    out
}

/// A straight line along x from 0, `n` points `step_mm` apart, on the
/// link's grid.
fn line(n: usize, step_mm: f64) -> Vec<PathPoint> {
    let pts: Vec<PathPoint> = (0..n)
        .map(|i| PathPoint::at(Point3Mm::from_f64(i as f64 * step_mm, 0.0, 0.0).unwrap()))
        .collect();
    on_grid(&pts)
}

/// The last point's position bits.
fn end_of(pts: &[PathPoint]) -> [i64; 3] {
    pts.last().unwrap().pos.to_bits()
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
fn check_smooth(samples: &[Status], hello: Hello, max_feed: f64) {
    let (hz, accel) = (hello.tick_hz as f64, hello.accel_mm_per_s2 as f64);
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

/// A path as streamed: its settings, points and their sequence numbers.
struct Sent {
    config: SchedulerConfig,
    pts: Vec<PathPoint>,
    seqs: Vec<u32>,
}

impl Sent {
    fn stream(fw: &mut Firmware, config: SchedulerConfig, pts: &[PathPoint]) -> Sent {
        fw.start_path(&config);
        let seqs = fw.points(pts);
        Sent {
            config,
            pts: pts.to_vec(),
            seqs,
        }
    }
}

/// The planner settings the host replays with: the firmware's, read over
/// the link (`GetSetting`), checked against its hello.
fn replay_config(fw: &mut Firmware) -> fuzzy_core::planner::MotionConfig {
    let c = fw.settings().motion_config();
    let h = fw.hello();
    assert_eq!(h.tick_hz, 1_000_000 / c.tick_us, "tick rate");
    assert_eq!(h.planner_points as usize, PLANNER_POINTS);
    assert_eq!(h.feed_max_mm_per_min as f64, c.feed_max.to_f64());
    c
}

/// Every scheduled feed equals the host's bit for bit; the host's replay of
/// the planner's inputs gives the firmware's setpoints bit for bit (at
/// every status seen, after a final one); the setpoints respect every
/// limit. Returns the replay's peaks from tick `from`.
fn verify(
    name: &str,
    fw: &mut Firmware,
    paths: &[Sent],
    from: usize,
) -> (planned::Replayed, Peaks) {
    let config = replay_config(fw);
    let mut points = std::collections::HashMap::new();
    for p in paths {
        points.extend(planned::schedule(p.config, &p.pts, &p.seqs));
    }
    for r in &fw.rec.scheduled {
        let h = points
            .get(&r.seq)
            .unwrap_or_else(|| panic!("{name}: seq {} not a point", r.seq));
        assert_eq!(
            (r.index, r.feed_bits),
            (h.index, h.feed.0.to_bits()),
            "{name}: seq {}: firmware feed {} host {} mm/min",
            r.seq,
            r.feed_bits as f64 / 4294967296.0,
            h.feed.to_f64()
        );
    }
    fw.status();
    let upto = fw
        .rec
        .statuses
        .iter()
        .map(|s| s.generated_ticks)
        .max()
        .unwrap_or(0);
    let rep = planned::replay(config, &points, &fw.rec.plan_log, upto);
    // The hello gives the settings at boot (the defaults in QEMU, whose
    // flash keeps nothing).
    let hello_accel = fw.hello().accel_mm_per_s2 as f64;
    if config == MOTION_CONFIG {
        assert!(
            (rep.accel_mm_s2.ceil() - hello_accel).abs() < 1.0,
            "{name}: acceleration limit {} vs hello {hello_accel}",
            rep.accel_mm_s2,
        );
    }
    let n = rep.check_statuses(name, &fw.rec.statuses);
    let p = planned::peaks(
        &rep.ticks[from.min(rep.ticks.len())..],
        &config,
        rep.accel_mm_s2,
    );
    planned::check_limits(name, &p, &config);
    println!(
        "{name}: {} setpoints identical to the host's ({n} statuses); peaks/limits: axis speed {:.3}, axis accel {:.3}, tangential accel {:.3}, jerk {:.3} (step onto a stop point {:.3}); top feed {:.1} mm/min",
        rep.ticks.len(),
        p.axis_vel,
        p.axis_acc,
        p.tang_acc,
        p.jerk,
        p.stop_step_jerk,
        p.feed_max
    );
    (rep, p)
}

fn run_shape(name: &str) -> String {
    let pts = on_grid(&read_points(
        &repo_root().join(format!("tests/data/shapes/{name}.csv")),
    ));
    let want = host_feeds(&pts);
    let mut fw = Firmware::start(name);
    let sent = Sent::stream(&mut fw, config(), &pts);
    let first = sent.seqs[0];
    fw.end_path();
    fw.flush(Duration::from_secs(240));
    let goal = end_of(&pts);
    let end = fw.poll_until(Duration::from_millis(200), Duration::from_secs(240), |s| {
        s.motion == Motion::Idle && s.pos_mm == goal
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
    assert_eq!(last.pos_mm, end_of(&pts), "{name}: end point");
    assert_eq!(last.bad_frames, 0);
    assert_eq!(last.empty_ticks, 0, "{name}: the planner fell behind");
    assert!(fw.alive(), "{name}: QEMU exited");
    let (rep, _) = verify(name, &mut fw, &[sent], 0);
    assert_eq!(rep.ticks.last().unwrap().pos.to_bits(), goal);
    format!(
        "{name}: {} points bit-exact; {} setpoints bit-exact; underruns {}, resends {}, worst tick {} cycles = {} instructions, stack {} bytes",
        want.len(),
        rep.ticks.len(),
        last.underruns,
        fw.client().resends(),
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
    let sent = 150;
    let mut paths = vec![Sent::stream(&mut fw, config(), &pts[..sent])];
    fw.flush(Duration::from_secs(120));
    // The scheduler releases a point once its lookahead is complete: the
    // last one released is `sent - 1 - LATENCY`. The velocity planner
    // stops at the last point whose corner it could plan: the one before
    // the last it holds (a point's speed ceiling needs the direction after
    // it).
    let latency = 35;
    let stop = fw.poll_until(Duration::from_millis(5), Duration::from_secs(120), |s| {
        s.motion == Motion::Starved && s.feed_mm_per_min == 0
    });
    check_smooth(&stop, fw.hello(), F_MAX as f64);
    let s = *stop.last().unwrap();
    let released = fw.rec.scheduled.len();
    assert_eq!(released, sent - latency, "points released by the scheduler");
    let last_known = pts[released - 2].pos.to_bits();
    assert_eq!(
        s.pos_mm,
        last_known,
        "stopped at the last plannable point, x = {} mm",
        pos(&s)[0]
    );
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
    let seqs = fw.points(&pts[sent..]);
    paths[0].pts.extend_from_slice(&pts[sent..]);
    paths[0].seqs.extend(seqs);
    fw.end_path();
    let mut seen = vec![fw.status()];
    fw.flush(Duration::from_secs(120));
    seen.extend(
        fw.poll_until(Duration::from_millis(5), Duration::from_secs(120), |s| {
            s.motion == Motion::Idle && s.pos_mm == end_of(&pts)
        }),
    );
    check_smooth(&seen, fw.hello(), F_MAX as f64);
    assert!(seen.iter().any(|s| feed(s) > 2900.0));
    let (rep, _) = verify("underrun", &mut fw, &paths, 0);
    // The host's run stops at the same point, at rest, starved.
    let stopped = rep
        .ticks
        .iter()
        .position(|t| {
            t.state == fuzzy_core::planner::MotionState::Starved && t.speed == SpeedMmPerTick::ZERO
        })
        .expect("a starved stop in the replay");
    assert_eq!(rep.ticks[stopped].pos.to_bits(), last_known);
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
    let paths = [Sent::stream(&mut fw, config(), &pts)];
    fw.end_path();
    fw.flush(Duration::from_secs(120));
    let cruise = fw.poll_until(Duration::from_millis(10), Duration::from_secs(120), |s| {
        // (The planner stores speeds rounded down: within 0.1 %.)
        feed(s) >= F_MAX as f64 * 0.999
    });
    let underruns = cruise.last().unwrap().underruns;
    fw.send(&HostMsg::Hold);
    let mut stop = vec![*cruise.last().unwrap()];
    stop.extend(
        fw.poll_until(Duration::from_millis(5), Duration::from_secs(60), |s| {
            s.motion == Motion::Held && s.feed_mm_per_min == 0
        }),
    );
    check_smooth(&stop, fw.hello(), F_MAX as f64);
    let stopped = *stop.last().unwrap();
    let ticks = stopped.ticks - stop[0].ticks;
    // 50 mm/s at 1000 mm/s² takes 50 ms: at least that many ticks.
    assert!(ticks >= 50, "stopped in {ticks} ticks");
    // Corner smoothing averages the last few setpoints: the position
    // settles within that window (a few ticks) after the speed reads 0.
    std::thread::sleep(Duration::from_millis(50));
    let held = fw.status();
    assert!(
        (pos(&held)[0] - pos(&stopped)[0]).abs() < 1e-3,
        "settled within a micrometre of where the speed reached 0"
    );
    std::thread::sleep(Duration::from_millis(300));
    let still = fw.status();
    assert_eq!(still.pos_mm, held.pos_mm, "held still");
    assert_eq!(still.motion, Motion::Held);
    fw.send(&HostMsg::Resume);
    let mut go = vec![still];
    go.extend(
        fw.poll_until(Duration::from_millis(5), Duration::from_secs(120), |s| {
            s.motion == Motion::Idle
        }),
    );
    check_smooth(&go, fw.hello(), F_MAX as f64);
    assert_eq!(go.last().unwrap().pos_mm, end_of(&pts));
    assert_eq!(
        stop.last().unwrap().underruns,
        underruns,
        "a hold is not an underrun"
    );
    let (rep, _) = verify("hold", &mut fw, &paths, 0);
    assert!(rep
        .ticks
        .iter()
        .any(|t| t.state == fuzzy_core::planner::MotionState::Holding
            && t.speed == SpeedMmPerTick::ZERO));
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
    let paths = [Sent::stream(&mut fw, config(), &pts)];
    fw.end_path();
    // No flush first: the polls below keep streaming (the controller holds
    // about 165 points, 82 mm, so the stream lasts as long as the motion).
    // Within 0.1 % (the planner stores speeds rounded down).
    let near = |f: f64| move |s: &Status| (feed(s) - f).abs() < f * 1e-3;
    fw.poll_until(
        Duration::from_millis(10),
        Duration::from_secs(120),
        near(3000.0),
    );
    fw.send(&HostMsg::Override { percent: 50 });
    let mut seen = fw.poll_until(
        Duration::from_millis(5),
        Duration::from_secs(60),
        near(1500.0),
    );
    assert_eq!(seen.last().unwrap().override_percent, 50);
    // Out of range: refused, nothing changes.
    let errors = fw.rec.errors.len();
    fw.send(&HostMsg::Override { percent: 5 });
    fw.send(&HostMsg::Override { percent: 201 });
    let s = fw.status();
    assert_eq!(s.override_percent, 50);
    assert_eq!(
        fw.rec.errors[errors..]
            .iter()
            .map(|e| e.0)
            .collect::<Vec<_>>(),
        vec![ErrorCode::OutOfRange, ErrorCode::OutOfRange]
    );
    seen.push(s);
    // 200 % of 3000 is beyond the machine's 5000 mm/min: capped there.
    fw.send(&HostMsg::Override { percent: 200 });
    seen.extend(fw.poll_until(
        Duration::from_millis(5),
        Duration::from_secs(60),
        near(fw.hello().feed_max_mm_per_min as f64),
    ));
    check_smooth(&seen, fw.hello(), fw.hello().feed_max_mm_per_min as f64);
    fw.send(&HostMsg::Override { percent: 100 });
    let end = fw.poll_until(Duration::from_millis(20), Duration::from_secs(120), |s| {
        s.motion == Motion::Idle
    });
    assert_eq!(end.last().unwrap().pos_mm, end_of(&pts));
    let (_, p) = verify("override", &mut fw, &paths, 0);
    assert!(p.feed_max <= fw.hello().feed_max_mm_per_min as f64 + 1e-6);
    println!("override: 100 % -> 50 % (1500 mm/min) -> 200 % (capped at 5000 mm/min); 5 % and 201 % refused");
}

/// Njiri et al.'s force-feedback override in the firmware
/// (`HostMsg::Force`, `fuzzy_core::njiri`, the paper's references 120 N
/// and 40 N): peak forces at the references leave the override at 100 %;
/// above them every sample lowers it (and the feed follows); back at the
/// references it settles (one step up on the falling force, then holds);
/// a negative force is refused. The planner takes each change as an
/// override, so the host's replay and the limit checks still hold.
#[test]
fn force_samples_drive_the_feed_override() {
    if !qemu_available() {
        return;
    }
    let q16 = |n: f64| (n * 65536.0).round() as i32;
    let force = |fx: f64, fy: f64| HostMsg::Force {
        fx_n_q16: q16(fx),
        fy_n_q16: q16(fy),
    };
    let pts = line(900, 0.5);
    let mut fw = Firmware::start("force");
    let paths = [Sent::stream(&mut fw, config(), &pts)];
    fw.end_path();
    let near = |f: f64| move |s: &Status| (feed(s) - f).abs() < f * 1e-3;
    let mut seen = fw.poll_until(
        Duration::from_millis(10),
        Duration::from_secs(120),
        near(3000.0),
    );
    let full = feed(seen.last().unwrap());
    // Let idle take every sample sent so far (samples are not queued: a
    // sample replaces one not yet taken), streaming meanwhile.
    let settle = |fw: &mut Firmware| {
        let until = std::time::Instant::now() + Duration::from_millis(150);
        fw.poll_until(Duration::from_millis(20), Duration::from_secs(60), |_| {
            std::time::Instant::now() >= until
        })
    };
    // At the references: no change.
    for _ in 0..5 {
        fw.send(&force(120.0, 40.0));
        seen.extend(settle(&mut fw));
        assert_eq!(seen.last().unwrap().override_percent, 100);
    }
    // Above the references: each sample lowers the override.
    let mut last = 100;
    for k in 0..8 {
        fw.send(&force(150.0, 50.0));
        seen.extend(
            fw.poll_until(Duration::from_millis(5), Duration::from_secs(60), |s| {
                s.override_percent < last
            }),
        );
        let now = seen.last().unwrap().override_percent;
        assert!(
            now < last && now + 5 >= last,
            "sample {k}: {last} % -> {now} %"
        );
        last = now;
    }
    assert!(last <= 90, "{last} %");
    // The feed follows (the programmed feed × override, within 0.2 %).
    let want = full * last as f64 / 100.0;
    seen.extend(
        fw.poll_until(Duration::from_millis(5), Duration::from_secs(60), |s| {
            (feed(s) - want).abs() < want * 2e-3
        }),
    );
    // Back at the references: one step up on the falling force, then it
    // holds.
    fw.send(&force(120.0, 40.0));
    seen.extend(settle(&mut fw));
    let back = seen.last().unwrap().override_percent;
    assert!(back >= last && back < 100, "{last} % -> {back} %");
    for _ in 0..5 {
        fw.send(&force(120.0, 40.0));
        seen.extend(settle(&mut fw));
        assert_eq!(seen.last().unwrap().override_percent, back);
    }
    // A negative force: refused, nothing changes.
    let errors = fw.rec.errors.len();
    fw.send(&HostMsg::Force {
        fx_n_q16: -1,
        fy_n_q16: q16(40.0),
    });
    let s = fw.status();
    assert_eq!(s.override_percent, back);
    assert_eq!(
        fw.rec.errors[errors..]
            .iter()
            .map(|e| e.0)
            .collect::<Vec<_>>(),
        vec![ErrorCode::OutOfRange]
    );
    seen.push(s);
    check_smooth(&seen, fw.hello(), fw.hello().feed_max_mm_per_min as f64);
    let end = fw.poll_until(Duration::from_millis(20), Duration::from_secs(120), |s| {
        s.motion == Motion::Idle
    });
    assert_eq!(end.last().unwrap().pos_mm, end_of(&pts));
    verify("force", &mut fw, &paths, 0);
    println!("force: at the references 100 %; 8 samples above (150 N, 50 N) -> {last} %; back at the references {back} %, held; a negative force refused");
}

/// A 100 mm line of 0.05 mm segments streamed over the link at F_max 5000
/// mm/min: the firmware keeps up (no empty tick), its motion is the host's
/// bit for bit and within every limit, and it ends on the last point. The
/// feed it reaches depends on how fast the host streams (1667 points/s for
/// 5000 mm/min): it is printed (4998 mm/min measured on an idle host), and
/// at least 1000 mm/min is required, so that a loaded host does not fail
/// the test (the on-target planner's own figure is checked
/// deterministically by `cost_benchmark_plans_the_same_bits_as_the_host`).
#[test]
fn short_segments_stream_through_the_planner() {
    if !qemu_available() {
        return;
    }
    let pts = line(2001, 0.05);
    let cfg = SchedulerConfig::new(FeedMmPerMin::from_int(5000), FeedMmPerMin::from_int(60));
    let mut fw = Firmware::start("short");
    let paths = [Sent::stream(&mut fw, cfg, &pts)];
    fw.end_path();
    let goal = end_of(&pts);
    let seen = fw.poll_until(Duration::from_millis(20), Duration::from_secs(240), |s| {
        s.motion == Motion::Idle && s.pos_mm == goal
    });
    let last = *seen.last().unwrap();
    assert_eq!(last.empty_ticks, 0, "the planner fell behind the tick");
    let top = seen.iter().map(feed).fold(0.0, f64::max);
    let (rep, p) = verify("short", &mut fw, &paths, 0);
    assert_eq!(rep.ticks.last().unwrap().pos.to_bits(), goal);
    assert!(p.feed_max >= 1000.0, "top feed {} mm/min", p.feed_max);
    println!(
        "short segments: 2000 x 0.05 mm streamed, top feed {:.0} mm/min (status samples {top:.0}), {} underruns, {} resends",
        p.feed_max, last.underruns, fw.client().resends()
    );
}

/// Encode a message, then let `f` damage the frame.
fn damaged(msg: &HostMsg, f: impl FnOnce(&mut Vec<u8>)) -> Vec<u8> {
    let mut buf = [0u8; link::FRAME_MAX];
    let n = link::encode(msg, &mut buf).unwrap();
    let mut v = buf[..n].to_vec();
    f(&mut v);
    v
}

/// A frame with a valid CRC around an arbitrary message (the host's tag
/// byte first).
fn raw_frame(message: &[u8]) -> Vec<u8> {
    let mut payload = vec![<HostMsg as link::Message>::TAG];
    payload.extend_from_slice(message);
    let crc = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC).checksum(&payload);
    let mut body = payload.clone();
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
    let pts = on_grid(&read_points(
        &repo_root().join("tests/data/shapes/trident.csv"),
    ));
    let pts = &pts[..400];
    let want = host_feeds(pts);
    let mut fw = Firmware::start("corrupt");
    let paths = [Sent::stream(&mut fw, config(), pts)];
    let first = paths[0].seqs[0];
    fw.end_path();
    // Stream, and every 50 commands throw in bad frames of every kind.
    let mut round = 0u32;
    let mut expect = Vec::new();
    while !fw.all_acked() {
        fw.transmit();
        fw.pump(Duration::from_millis(20));
        let seq = fw.client().acked();
        if seq >= round * 50 + 10 && round < 6 {
            round += 1;
            let good = HostMsg::Point {
                seq,
                pos_mm: pts[(seq - first).min(pts.len() as u32 - 1) as usize]
                    .pos
                    .to_bits(),
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
                // A hold with a byte after it: not taken.
                (raw_frame(&[4, 0]), ErrorCode::Malformed),
                // A controller's message sent to the controller.
                (
                    {
                        let mut f = [0u8; link::FRAME_MAX];
                        let n = link::encode_device(
                            &link::DeviceMsg::Error {
                                code: ErrorCode::Crc,
                                expected_seq: 0,
                            },
                            &mut f,
                        )
                        .unwrap();
                        f[..n].to_vec()
                    },
                    ErrorCode::Misdirected,
                ),
                // Out of range: a coordinate of 1 km, a 500 % override.
                (
                    damaged(
                        &HostMsg::Point {
                            // The next one expected once those in flight
                            // are in (an older seq would be taken for a
                            // resend and acknowledged again).
                            seq: fw.client().send_next(),
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
                            seq: fw.client().send_next() + 5,
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
    let goal = end_of(pts);
    let end = fw.poll_until(Duration::from_millis(100), Duration::from_secs(120), |s| {
        s.motion == Motion::Idle && s.pos_mm == goal
    });
    let got = fw.scheduled_in_order();
    assert_eq!(got.len(), want.len(), "every acknowledged point scheduled");
    for (i, (g, w)) in got.iter().zip(&want).enumerate() {
        assert_eq!(g.seq, first + i as u32);
        assert_eq!((g.index, g.feed_bits), *w, "point {i}");
    }
    let codes: Vec<ErrorCode> = fw.rec.errors.iter().map(|e| e.0).collect();
    for code in &expect {
        assert!(codes.contains(code), "no {code:?} reply; got {codes:?}");
    }
    let last = end.last().unwrap();
    // The out-of-range point carries the sequence number expected when it
    // was made; if a go-back moved the stream behind it meanwhile, it is
    // taken for a resend (acknowledged, not counted): one per round at most.
    assert!(
        last.bad_frames as usize + round as usize >= expect.len(),
        "{} bad frames counted, {} sent: {codes:?}",
        last.bad_frames,
        expect.len()
    );
    assert_eq!(last.pos_mm, end_of(pts));
    assert!(
        !fw.rec.plan_log.iter().any(|e| matches!(
            e,
            system_tests::firmware::PlanLog::Event {
                event: link::PlanEvent::Hold,
                ..
            }
        )),
        "the hold with a trailing byte was not taken"
    );
    verify("corrupt", &mut fw, &paths, 0);
    println!(
        "corrupted frames: {} bad frames sent, {} refused, {} resends; all {} points scheduled bit-exact",
        expect.len(),
        last.bad_frames,
        fw.client().resends(),
        want.len()
    );
}

/// The cost benchmark in QEMU (`firmware/src/bin/cost.rs`: a 100 mm line of
/// 0.05 mm segments at 5000 mm/min, the three shapes, then the shapes with
/// a feed hold, override changes and a starved stretch) against the same
/// runs on the host: the checksums of every commanded position and the
/// scheduled feeds are equal, so the planner computes the same bits on the
/// Cortex-M4 as on the host. On the host, the same runs also check every
/// limit, and that the 0.05 mm line holds 5000 mm/min.
#[test]
fn cost_benchmark_plans_the_same_bits_as_the_host() {
    if !qemu_available() {
        return;
    }
    let dir = repo_root().join("firmware");
    let ok = std::process::Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
        .args(["build", "--release", "--bin", "cost"])
        .current_dir(&dir)
        .env_remove("CARGO_TARGET_DIR")
        .env_remove("CARGO_BUILD_TARGET")
        .env_remove("RUSTFLAGS")
        .status()
        .expect("cargo")
        .success();
    assert!(ok, "cost benchmark build failed");
    let out = std::process::Command::new("timeout")
        .args(["-k", "5", "300", "qemu-system-arm", "-cpu", "cortex-m4"])
        .args([
            "-machine",
            "netduinoplus2",
            "-display",
            "none",
            "-monitor",
            "none",
        ])
        .args([
            "-semihosting-config",
            "enable=on,target=native",
            "-serial",
            "null",
        ])
        .args(["-icount", "shift=0", "-kernel"])
        .arg(dir.join("target/thumbv7em-none-eabihf/release/cost"))
        .output()
        .expect("qemu-system-arm");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "cost benchmark failed: {text}");
    let field = |run: &str, key: &str| -> String {
        let line = text
            .lines()
            .find(|l| l.starts_with(&format!("cost {run} ")))
            .unwrap_or_else(|| panic!("no `cost {run}` line in {text}"));
        line.split_whitespace()
            .find_map(|kv| kv.strip_prefix(&format!("{key}=")))
            .unwrap_or_else(|| panic!("no {key} in {line}"))
            .to_string()
    };

    let mcfg = MOTION_CONFIG;
    let mut plan: Box<Plan> = Box::new(Plan::new(mcfg).unwrap());
    let accel = plan.accel_limit_mm_s2().to_num::<f64>();
    let mut bench = Replay::new(&mut plan, Point3Mm::ORIGIN).unwrap();
    let mut run = |name: &str,
                   cfg: SchedulerConfig,
                   pts: &mut dyn Iterator<Item = Point3Mm>,
                   events: bool| {
        let mut ticks = Vec::new();
        let r = bench
            .run(cfg, pts, events, &mut NoClock, |_, t| ticks.push(*t))
            .unwrap_or_else(|e| panic!("{name}: {e:?}"));
        let run = format!("{name}{}", if events { "+events" } else { "" });
        assert_eq!(
            field(&run, "positions"),
            format!("{:#018x}", r.positions),
            "{run}: commanded positions differ between the Cortex-M4 and the host"
        );
        assert_eq!(
            field(&run, "feed_sum"),
            r.feed_sum.to_string(),
            "{run}: feeds"
        );
        assert_eq!(field(&run, "ticks"), r.ticks.to_string(), "{run}: ticks");
        let p = planned::peaks(&ticks, &mcfg, accel);
        planned::check_limits(&run, &p, &mcfg);
        println!(
            "{run}: {} ticks bit-exact with the target; peaks/limits: axis speed {:.3}, axis accel {:.3}, tangential accel {:.3}, jerk {:.3} (step onto a stop point {:.3}); top feed {:.1} mm/min",
            r.ticks, p.axis_vel, p.axis_acc, p.tang_acc, p.jerk, p.stop_step_jerk, p.feed_max
        );
        (r, p)
    };
    let five = SchedulerConfig::new(FeedMmPerMin::from_int(5000), FeedMmPerMin::from_int(60));
    let (line, p) = run("line", five, &mut replay::line(2000), false);
    // 0.05 mm segments hold the programmed 5000 mm/min (within the planner's
    // rounding of stored speeds) at 1 kHz, and the run ends on the last point.
    assert!(
        p.feed_max >= 5000.0 * 0.999,
        "line: top feed {}",
        p.feed_max
    );
    assert_eq!(line.end, replay::line(2000).last().unwrap());
    let shapes: Vec<(&str, Vec<Point3Mm>)> = ["infinity", "trident", "butterfly"]
        .into_iter()
        .map(|n| {
            (
                n,
                read_points(&repo_root().join(format!("tests/data/shapes/{n}.csv")))
                    .into_iter()
                    .map(|p| p.pos)
                    .collect(),
            )
        })
        .collect();
    for events in [false, true] {
        for (name, pts) in &shapes {
            let (r, _) = run(name, config(), &mut pts.iter().copied(), events);
            assert_eq!(r.end, *pts.last().unwrap(), "{name}: end point");
        }
    }
}

/// An abort in the middle of a path (`HostMsg::Abort`): the tool stops on
/// the path within the limits (checked on the replay), everything queued
/// is dropped and reported (`DeviceMsg::Aborted`), and a path sent right
/// after runs from where the tool stopped to its end.
#[test]
fn an_abort_mid_path_stops_flushes_and_the_next_path_runs() {
    if !qemu_available() {
        return;
    }
    let pts = line(600, 0.5);
    let mut fw = Firmware::start("abort");
    let mut paths = vec![Sent::stream(&mut fw, config(), &pts)];
    fw.end_path();
    let cruise = fw.poll_until(Duration::from_millis(10), Duration::from_secs(120), |s| {
        feed(s) >= F_MAX as f64 * 0.999
    });
    let at = pos(cruise.last().unwrap())[0];
    fw.abort();
    let back = vec![PathPoint::at(Point3Mm::from_f64(-5.0, 0.0, 0.0).unwrap())];
    paths.push(Sent::stream(&mut fw, config(), &back));
    fw.end_path();
    fw.flush(Duration::from_secs(60));
    let goal = end_of(&back);
    let end = fw.poll_until(Duration::from_millis(20), Duration::from_secs(120), |s| {
        s.motion == Motion::Idle && s.pos_mm == goal
    });
    let Some(link::DeviceMsg::Aborted {
        commands,
        points,
        pos_mm,
    }) = fw.rec.aborted.last().copied()
    else {
        panic!("no abort report")
    };
    let stop = pos_mm[0] as f64 / 4294967296.0;
    assert!(
        stop > at && stop < at + 10.0,
        "stopped at {stop} (abort at {at})"
    );
    assert!(
        commands + points > 100,
        "{commands} commands, {points} points dropped"
    );
    assert_eq!(end.last().unwrap().underruns, 0);
    let (rep, _) = verify("abort", &mut fw, &paths, 0);
    let furthest = rep.ticks.iter().map(|t| t.pos.to_bits()[0]).max().unwrap();
    assert_eq!(furthest, pos_mm[0], "nothing beyond the stop");
    println!(
        "abort: at x = {at:.3} mm at 3000 mm/min, stopped at {stop:.3} mm; {commands} queued commands and {points} points dropped; the next path ran to x = -5"
    );
}

/// Line noise at full rate (no delimiter for 100 kB, then a flood of
/// frames too short to hold a CRC), then a status query: answered, and the
/// replies to the noise were rate-limited.
#[test]
fn a_flood_of_noise_then_a_status_query_is_answered() {
    if !qemu_available() {
        return;
    }
    let mut fw = Firmware::start("flood");
    fw.send_raw(&vec![0x55u8; 100_000]);
    let shorts: Vec<u8> = std::iter::repeat_n([0x02u8, 0x11, 0x00], 20_000)
        .flatten()
        .collect();
    fw.send_raw(&shorts);
    fw.send_raw(&[0]);
    // QEMU works through the 160 kB first: slow on a loaded machine.
    let s = fw.status_within(Duration::from_secs(60));
    assert!(s.bad_frames >= 20_000, "{s:?}");
    let replies = fw.rec.errors.len();
    assert!(replies < 1000, "{replies} replies to 20 001 bad frames");
    // And the link still carries a path.
    let pts = line(100, 0.5);
    let paths = [Sent::stream(&mut fw, config(), &pts)];
    fw.end_path();
    fw.flush(Duration::from_secs(60));
    let goal = end_of(&pts);
    fw.poll_until(Duration::from_millis(20), Duration::from_secs(120), |s| {
        s.motion == Motion::Idle && s.pos_mm == goal
    });
    verify("flood", &mut fw, &paths, 0);
    println!("flood: 100 kB without a delimiter, 10 000 empty frames, 5 000 short frames: status answered, {replies} error replies (rate-limited)");
}

/// 100 kB of line noise without a delimiter, then a status query: the
/// firmware skips the run at a comparison a byte and refuses it once
/// (`TooLong`); the query, lost in the run (it ends it), is asked again
/// at once after a delimiter by the link client and answered within 2 s
/// of QEMU taking in the last byte of noise. How long the run takes to
/// get in is QEMU's: its USART takes a byte only once the firmware has
/// read the last, each through QEMU's main loop, the same with and
/// without `-icount` (printed, with the firmware's ticks over it; a
/// board at 921 600 baud takes 1.1 s of wire time for it).
#[test]
fn a_run_of_noise_without_a_delimiter_then_status_is_answered_at_once() {
    if !qemu_available() {
        return;
    }
    let mut fw = Firmware::start("noise-run");
    let before = fw.status();
    let errors = fw.rec.errors.len();
    let t0 = Instant::now();
    fw.send_raw(&vec![0x55u8; 100_000]);
    while fw.unread_by_firmware().expect("QEMU's socket in `ss -x`") > 0 {
        assert!(
            t0.elapsed() < Duration::from_secs(120),
            "QEMU stopped taking bytes"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    let taken_in = t0.elapsed();
    let t1 = Instant::now();
    let s = fw.status_within(Duration::from_secs(2));
    let answered = t1.elapsed();
    let codes: Vec<ErrorCode> = fw.rec.errors[errors..].iter().map(|e| e.0).collect();
    assert_eq!(codes, [ErrorCode::TooLong], "one refusal for the run");
    assert!(
        answered < Duration::from_secs(2),
        "answered after {answered:?}"
    );
    println!(
        "noise run: 100 kB without a delimiter taken in by QEMU in {:.2} s ({:.0} kB/s; {} firmware ticks), then status answered in {} ms, {} refusal",
        taken_in.as_secs_f64(),
        100.0 / taken_in.as_secs_f64(),
        s.ticks.wrapping_sub(before.ticks),
        answered.as_millis(),
        codes.len()
    );
}

/// Points every `step_mm` along an arc of radius `r_mm` (in XY, from
/// (r, 0)), `n` of them, on the link's grid.
fn arc(n: usize, r_mm: f64, step_mm: f64) -> Vec<PathPoint> {
    let pts: Vec<PathPoint> = (0..n)
        .map(|i| {
            let a = i as f64 * step_mm / r_mm;
            PathPoint::at(Point3Mm::from_f64(r_mm * a.cos(), r_mm * a.sin(), 0.0).unwrap())
        })
        .collect();
    on_grid(&pts)
}

/// A program of the wire test: its settings and points.
struct WireProgram {
    name: &'static str,
    config: SchedulerConfig,
    pts: Vec<PathPoint>,
}

impl WireProgram {
    /// The top feed of the host's schedule (the controller's scheduler):
    /// what the motion reaches with the points there in time.
    fn scheduled(&self) -> f64 {
        let mut s = Sched::new(&COMPACT, self.config).unwrap();
        let mut top = 0f64;
        s.run(self.pts.iter().copied(), |o| top = top.max(o.feed.to_f64()))
            .unwrap();
        top
    }

    /// The feed the program asks for: F_max, or the highest feed cap
    /// below it.
    fn programmed(&self) -> f64 {
        let f_max = self.config.f_max.to_f64();
        let caps = self
            .pts
            .iter()
            .filter_map(|p| p.feed_cap.map(|f| f.to_f64()));
        caps.fold(None, |m: Option<f64>, c| Some(m.map_or(c, |m| m.max(c))))
            .map_or(f_max, |c| c.min(f_max))
    }
}

/// The wire test's programs: the 0.05 mm line and the trident at F_max
/// 5000 mm/min, an arc sampled every 0.02 mm at 3000 mm/min, and a CAM
/// finishing pass through the G-code interpreter as the sender loads it
/// (its F words as feed caps, F_max the machine's 5000 mm/min).
fn wire_programs() -> Vec<WireProgram> {
    let f = |v: i32| SchedulerConfig::new(FeedMmPerMin::from_int(v), FeedMmPerMin::from_int(60));
    let trident = on_grid(&read_points(
        &repo_root().join("tests/data/shapes/trident.csv"),
    ));
    let cam = repo_root().join("tests/data/cam/surface_ball_end.ngc");
    let surface = sender::program::load(
        cam.to_str().unwrap(),
        &gcode_interp::GcodeSettings::default(),
    )
    .unwrap_or_else(|e| panic!("{e:?}"));
    vec![
        WireProgram {
            name: "0.05 mm line",
            config: f(5000),
            pts: line(2001, 0.05),
        },
        WireProgram {
            name: "trident",
            config: f(5000),
            pts: trident,
        },
        WireProgram {
            name: "arc every 0.02 mm",
            config: f(3000),
            pts: arc(2001, 10.0, 0.02),
        },
        WireProgram {
            name: "surface_ball_end.ngc",
            config: f(5000),
            pts: surface.points,
        },
    ]
}

/// The link at real wire rates, the planner's reports off as a sender
/// runs it: each program of [`wire_programs`] at 115 200 and 921 600
/// baud. The pipe between the host and QEMU is paced each way at
/// `baud / 10` bytes a second through a bucket of 16 bytes (a UART's
/// FIFO: idle time is not saved up for a burst) in the firmware's own
/// time, not the wall clock's: QEMU runs under `-icount shift=0`, whose
/// clock follows the emulation (well behind the wall clock's, and
/// slower while the guest is busy), so the pipe reads the firmware's
/// clock from the tick counter of the statuses the host polls (every
/// 100 ms of firmware time, as a sender polls every 200 ms) and
/// extrapolates it (`system_tests::firmware::GuestClock`). `-icount`
/// stays because it keeps the firmware's clock its own: without it a
/// loaded host starves the guest and its ticks fall behind the wall
/// clock, and the motion with them, so a wall-clock pace would again be
/// too fast for the motion (the rates measured: `firmware/README.md`). The pace is estimated, so the test checks it after the
/// fact: bytes each way over each run against the wire's rate over the
/// run's firmware time (the tick counter), at most 5 % over.
///
/// Asserts: no empty tick (the planner never fell behind the tick, wire
/// or no wire), at 921 600 no underrun, every path ends on its last
/// point. Prints per program and baud: bytes a point each way (status
/// polls apart), the points a second the wire carries at that (the
/// busier direction), the top feed reached against the host's schedule's
/// and the programmed one,
/// underruns, the pipe's use of the wire each way and the clock's rate.
#[test]
fn the_link_carries_dense_paths_at_real_wire_rates() {
    if !qemu_available() {
        return;
    }
    let programs = wire_programs();
    let mut frame = [0u8; link::FRAME_MAX];
    let query_len = link::encode(&HostMsg::StatusQuery, &mut frame).unwrap() as u64;
    let mut lines = Vec::new();
    for baud in [115_200u32, 921_600] {
        let name = format!("wire-{baud}");
        let wire = baud as f64 / 10.0;
        let mut fw = Firmware::start_at(&name, Some(baud));
        let clock = fw.guest_clock().expect("a paced link");
        let hz = fw.hello().tick_hz as f64;
        fw.send(&HostMsg::Reports { planner: false });
        for p in &programs {
            let s0 = fw.status();
            let (i0, w0, t0) = (fw.rec.statuses.len() - 1, Instant::now(), clock.now_s());
            let at0 = *fw.rec.wire_at_status.last().unwrap();
            let (sent0, in0) = (fw.bytes_sent(), fw.rec.bytes_in);
            fw.start_path(&p.config);
            fw.points(&p.pts);
            fw.end_path();
            let goal = end_of(&p.pts);
            let (mut queries, mut next_query) = (0u64, t0);
            let mut top = 0f64;
            let deadline = Instant::now() + Duration::from_secs(300);
            let last = loop {
                fw.transmit();
                let now = clock.now_s();
                if now >= next_query {
                    fw.send(&HostMsg::StatusQuery);
                    queries += 1;
                    next_query = now + 0.1;
                }
                if let Some(link::DeviceMsg::Status(s)) = fw.pump(Duration::from_millis(1)) {
                    top = top.max(feed(&s));
                    if s.motion == Motion::Idle && s.pos_mm == goal && fw.all_acked() {
                        break s;
                    }
                }
                assert!(
                    Instant::now() < deadline,
                    "{name} {}: not done; log {}",
                    p.name,
                    fw.log.display()
                );
            };
            let at1 = *fw.rec.wire_at_status.last().unwrap();
            let secs = last.ticks.wrapping_sub(s0.ticks) as f64 / hz;
            let ratio = (clock.now_s() - t0) / w0.elapsed().as_secs_f64();
            let n = p.pts.len() as f64;
            let up = (fw.bytes_sent() - sent0 - queries * query_len) as f64 / n;
            let b = fw.rec.bytes_in;
            let down_status = b.statuses - in0.statuses;
            let down = (b.acks - in0.acks + b.errors - in0.errors + b.other - in0.other) as f64 / n;
            let use_up = (at1.0 - at0.0) as f64 / (wire * secs);
            let use_down = (at1.1 - at0.1) as f64 / (wire * secs);
            let underruns = last.underruns - s0.underruns;
            let statuses = fw.rec.statuses.len() - i0;
            assert_eq!(
                last.empty_ticks, 0,
                "{name} {}: the planner fell behind the tick",
                p.name
            );
            if baud == 921_600 {
                assert_eq!(underruns, 0, "{name} {}: starved", p.name);
            }
            for (dir, u) in [("to the device", use_up), ("to the host", use_down)] {
                assert!(
                    u <= 1.05,
                    "{name} {}: the pipe ran {u:.2} times the wire's rate {dir}",
                    p.name
                );
            }
            lines.push(format!(
                "{baud} baud, {}: {} points, {up:.2} bytes a point to the device, {down:.2} back (+{:.0} B/s of status replies) = {:.0} points/s on the wire; top feed {top:.0} mm/min (scheduled {:.0}, programmed {:.0}), {underruns} underruns; {secs:.2} s of firmware time, the pipe at {:.0} % / {:.0} % of the wire, clock {ratio:.2} of the wall's, {statuses} statuses",
                p.name,
                p.pts.len(),
                down_status as f64 / secs,
                wire / up.max(down),
                p.scheduled(),
                p.programmed(),
                use_up * 100.0,
                use_down * 100.0,
            ));
        }
    }
    for l in lines {
        println!("{l}");
    }
}

/// The last `DeviceMsg::Alarm`: its code and where the tool stopped.
fn last_alarm(fw: &Firmware) -> Option<(link::AlarmCode, [i64; 3])> {
    fw.rec.alarms.iter().rev().find_map(|m| match *m {
        link::DeviceMsg::Alarm { code, pos_mm, .. } => Some((code, pos_mm)),
        _ => None,
    })
}

/// An e-stop over the link at full feed (`HostMsg::EStop`): the firmware
/// enters its alarm state at once (no deceleration: the position stops
/// changing from one tick to the next), reports the alarm with where the
/// tool stopped, refuses path commands, and no motion follows however long
/// it waits; after `HostMsg::Unlock` a new path runs from the stop to its
/// end. The planner's setpoints stay the host's bit for bit throughout
/// (its rebuild at the stop is reported, `PlanEvent::Reset`), and within
/// the limits up to the stop.
#[test]
fn a_link_e_stop_stops_the_motion_until_unlocked() {
    if !qemu_available() {
        return;
    }
    let pts = line(400, 0.5);
    let mut fw = Firmware::start("estop");
    let mut paths = vec![Sent::stream(&mut fw, config(), &pts)];
    fw.end_path();
    let cruise = fw.poll_until(Duration::from_millis(10), Duration::from_secs(120), |s| {
        feed(s) >= F_MAX as f64 * 0.999
    });
    let before = *cruise.last().unwrap();
    fw.send(&HostMsg::EStop);
    fw.poll_until(Duration::from_millis(5), Duration::from_secs(30), |s| {
        s.motion == Motion::Alarm
    });
    // Wait for the report (the tick has stopped the steps and said where),
    // then stand: nothing moves.
    let deadline = std::time::Instant::now() + Duration::from_secs(10);
    while last_alarm(&fw).is_none() {
        assert!(std::time::Instant::now() < deadline, "no alarm report");
        fw.pump(Duration::from_millis(20));
    }
    let (code, stop) = last_alarm(&fw).unwrap();
    let at_alarm = fw.status();
    assert_eq!(code, link::AlarmCode::EStopLink);
    let stop_x = stop[0] as f64 / 4294967296.0;
    // At 50 mm/s the message reaches the tick within a few ms: no ramp.
    // The steps run 1.5 ticks (0.075 mm) behind the setpoints the status
    // reports, and stop where they are.
    assert!(
        stop_x >= pos(&before)[0] - 0.15 && stop_x < pos(&before)[0] + 1.0,
        "stopped at {stop_x} (e-stop sent at {})",
        pos(&before)[0]
    );
    std::thread::sleep(Duration::from_millis(300));
    let still = fw.status();
    assert_eq!(still.motion, Motion::Alarm);
    assert_eq!(still.pos_mm, stop, "no motion in the alarm state");
    assert_eq!(still.pos_mm, at_alarm.pos_mm);
    assert_eq!(still.feed_mm_per_min, 0);
    let m = fw.machine_status();
    assert_eq!((m.alarm, m.alarms), (Some(link::AlarmCode::EStopLink), 1));
    // Path commands are refused until the unlock.
    let errors = fw.rec.errors.len();
    fw.resync();
    fw.start_path(&config());
    fw.transmit();
    std::thread::sleep(Duration::from_millis(100));
    let still = fw.status();
    assert!(
        fw.rec.errors[errors..]
            .iter()
            .any(|e| e.0 == ErrorCode::Alarm),
        "{:?}",
        &fw.rec.errors[errors..]
    );
    assert_eq!(still.pos_mm, stop);
    // Unlocked: the next path runs from the stop.
    fw.resync();
    fw.send(&HostMsg::Unlock);
    fw.poll_until(Duration::from_millis(10), Duration::from_secs(10), |s| {
        s.motion == Motion::Idle
    });
    let back = vec![PathPoint::at(Point3Mm::from_f64(-5.0, 0.0, 0.0).unwrap())];
    paths.push(Sent::stream(&mut fw, config(), &back));
    fw.end_path();
    fw.flush(Duration::from_secs(60));
    let goal = end_of(&back);
    fw.poll_until(Duration::from_millis(20), Duration::from_secs(120), |s| {
        s.motion == Motion::Idle && s.pos_mm == goal
    });
    // The replay: every checksum, the executed positions up to the stop,
    // the limits up to the stop (the stop itself is an emergency stop).
    let config = replay_config(&mut fw);
    let mut points = std::collections::HashMap::new();
    for p in &paths {
        points.extend(planned::schedule(p.config, &p.pts, &p.seqs));
    }
    fw.status();
    let upto = fw
        .rec
        .statuses
        .iter()
        .map(|s| s.generated_ticks)
        .max()
        .unwrap_or(0);
    let rep = planned::replay(config, &points, &fw.rec.plan_log, upto);
    let n = rep.check_checksums("estop", &fw.rec.statuses);
    let moving: Vec<Status> = fw
        .rec
        .statuses
        .iter()
        .take_while(|s| s.motion != Motion::Alarm)
        .copied()
        .collect();
    rep.check_statuses("estop", &moving);
    let reset_at = fw
        .rec
        .plan_log
        .iter()
        .find_map(|e| match *e {
            system_tests::firmware::PlanLog::Event {
                tick,
                event: link::PlanEvent::Reset { pos_mm },
            } => Some((tick, pos_mm)),
            _ => None,
        })
        .expect("the planner's rebuild reported");
    assert_eq!(reset_at.1, stop, "rebuilt where the tool stopped");
    // No ramp: the tool was at full feed where its steps stopped, between
    // two setpoints of the line along X.
    let at_stop = rep
        .ticks
        .windows(2)
        .find(|w| {
            let (a, b) = (w[0].pos.to_bits(), w[1].pos.to_bits());
            a[0].min(b[0]) <= stop[0] && stop[0] <= a[0].max(b[0]) && a[1..] == stop[1..]
        })
        .map(|w| w[1])
        .expect("the stop lies on the path");
    let v = at_stop.speed.to_mm_per_s_f64(1e-3) * 60.0;
    assert!(v > 2990.0, "{v} mm/min at the stop");
    let p = planned::peaks(&rep.ticks[..reset_at.0 as usize], &config, rep.accel_mm_s2);
    planned::check_limits("estop", &p, &config);
    assert_eq!(rep.ticks.last().unwrap().pos.to_bits(), goal);
    println!(
        "e-stop: sent at x = {:.3} mm at 3000 mm/min, stopped at {stop_x:.3} mm from {v:.0} mm/min (no ramp), no motion for 300 ms, path commands refused; unlocked, the next path ran to x = -5; {n} checksums bit-exact",
        pos(&before)[0]
    );
}

/// Settings over the link: read, written, refused out of range, unknown,
/// or while moving; QEMU's flash is ROM, so the boot reports a corrupt
/// store (the defaults) and a write reports `WriteFailed` (the value is in
/// force until the reset). A lower acceleration written at rest shapes the
/// next path, and the host's replay with the settings read back is still
/// bit-exact.
/// Wait (at most 5 s) until the firmware reports `result` for its settings
/// store (QEMU's flash keeps nothing: `Corrupt` at boot, `WriteFailed` after
/// a save).
fn wait_for_store(fw: &mut Firmware, result: link::StoreResult) {
    let deadline = std::time::Instant::now() + Duration::from_secs(5);
    while !fw.rec.machine.contains(&link::DeviceMsg::Stored(result)) {
        assert!(std::time::Instant::now() < deadline, "{:?}", fw.rec.machine);
        fw.pump(Duration::from_millis(20));
    }
}

#[test]
fn settings_are_read_and_written_over_the_link() {
    if !qemu_available() {
        return;
    }
    use link::StoreResult;
    let mut fw = Firmware::start("settings");
    wait_for_store(&mut fw, StoreResult::Corrupt);
    assert_eq!(fw.get_setting(120), Ok(2000));
    assert_eq!(
        fw.get_setting(100),
        Ok(100_000),
        "100 steps/mm, in thousandths"
    );
    assert_eq!(fw.get_setting(9999), Err(ErrorCode::UnknownSetting));
    assert_eq!(fw.set_setting(120, 0), Err(ErrorCode::OutOfRange));
    assert_eq!(fw.set_setting(204, 100), Err(ErrorCode::OutOfRange));
    assert_eq!(fw.get_setting(120), Ok(2000), "nothing changed");
    for a in [120, 121, 122] {
        assert_eq!(fw.set_setting(a, 500), Ok(500));
    }
    // Step settings at rest: in force for the next path, no reset.
    assert_eq!(fw.set_setting(100, 80_000), Ok(80_000));
    assert_eq!(fw.set_setting(0, 4_000), Ok(4_000));
    wait_for_store(&mut fw, StoreResult::WriteFailed);
    assert_eq!(fw.get_setting(121), Ok(500), "in force");
    assert_eq!(fw.machine_status().store, StoreResult::WriteFailed);
    let pts = line(120, 0.5);
    let paths = [Sent::stream(&mut fw, config(), &pts)];
    fw.end_path();
    fw.poll_until(Duration::from_millis(10), Duration::from_secs(60), |s| {
        s.motion == Motion::Running
    });
    assert_eq!(fw.set_setting(120, 600), Err(ErrorCode::Busy));
    let goal = end_of(&pts);
    fw.poll_until(Duration::from_millis(20), Duration::from_secs(120), |s| {
        s.motion == Motion::Idle && s.pos_mm == goal
    });
    let s = fw.status();
    assert_eq!(
        (s.step_lag_ticks, s.step_late_ticks),
        (0, 0),
        "the step engine rebuilt at rest: nothing carried or late"
    );
    assert!(
        !fw.machine_status().restart_needed,
        "step settings apply without a reset"
    );
    let (rep, p) = verify("settings", &mut fw, &paths, 0);
    assert!(
        (rep.accel_mm_s2 - 250.0).abs() < 0.5,
        "half of 500 mm/s² tangential: {}",
        rep.accel_mm_s2
    );
    assert!(p.tang_acc > 0.9, "the path used the new limit: {p:?}");
    // The tick rate takes effect at a reset: pending once changed, not
    // once written back to the rate running.
    let restart_pending = |fw: &mut Firmware, want: bool| {
        let deadline = std::time::Instant::now() + Duration::from_secs(5);
        while fw.machine_status().restart_needed != want {
            assert!(std::time::Instant::now() < deadline, "restart {want}");
            fw.pump(Duration::from_millis(20));
        }
    };
    assert_eq!(fw.set_setting(200, 2000), Ok(2000));
    restart_pending(&mut fw, true);
    assert_eq!(fw.set_setting(200, 1000), Ok(1000));
    restart_pending(&mut fw, false);
    println!(
        "settings: read, written (ROM: WriteFailed, in force), refused out of range, unknown and while moving; steps/mm and pulse width written at rest in force without a reset (no lag, no late plan); the path ran at 500 mm/s² per axis, replay bit-exact with the settings read back; the tick rate pending a reset once changed, not once written back"
    );
}

/// M3 S12000 between two paths and M5 after the second, carried in the
/// path stream (`HostMsg::Machine`): each is reported (`DeviceMsg::Applied`)
/// with the path index the tool had reached, at rest at the end of the path
/// before it (Grbl's spindle sync), the second path only after the
/// spin-up delay; the motion stays bit-exact.
/// Corner smoothing set over the link (`$208`, 0 by default: the most that
/// fit, two ticks here): a window too long for the chord tolerance is
/// refused, two ticks are taken, and a zigzag of sharp corners runs with
/// them bit for bit as the host replays it (the replay reads `$208` back),
/// within every limit.
#[test]
fn corner_smoothing_set_over_the_link_runs_bit_for_bit() {
    if !qemu_available() {
        return;
    }
    use link::StoreResult;
    let mut fw = Firmware::start("smoothing");
    wait_for_store(&mut fw, StoreResult::Corrupt);
    assert_eq!(fw.get_setting(208), Ok(0), "the most that fit by default");
    assert_eq!(fw.set_setting(208, 3), Err(ErrorCode::OutOfRange));
    assert_eq!(fw.set_setting(208, 2), Ok(2));
    let pts: Vec<PathPoint> = (0..60)
        .map(|i| {
            let y = if i % 2 == 0 { 0.0 } else { 0.2 };
            PathPoint::at(Point3Mm::from_f64(i as f64 * 0.3, y, 0.0).unwrap())
        })
        .collect();
    let pts = on_grid(&pts);
    let paths = [Sent::stream(&mut fw, config(), &pts)];
    fw.end_path();
    let goal = end_of(&pts);
    fw.poll_until(Duration::from_millis(20), Duration::from_secs(240), |s| {
        s.motion == Motion::Idle && s.pos_mm == goal
    });
    let config = replay_config(&mut fw);
    assert_eq!(config.smoothing_ticks, 2);
    let (rep, _) = verify("smoothing", &mut fw, &paths, 0);
    assert_eq!(rep.ticks.last().unwrap().pos.to_bits(), goal);
}

#[test]
fn spindle_commands_are_reported_at_their_path_index() {
    if !qemu_available() {
        return;
    }
    use link::{DeviceMsg, MachineCmd, SpindleDir};
    let mut fw = Firmware::start("spindle");
    assert_eq!(fw.set_setting(207, 100), Ok(100));
    let a = line(41, 0.5);
    let b: Vec<PathPoint> = line(81, 0.5).into_iter().skip(41).collect();
    // The machine command ends the first path: the points after it are a
    // path of their own (same scheduler settings).
    let sent_a = Sent::stream(&mut fw, config(), &a[1..]);
    let m3 = fw.machine(MachineCmd::Spindle {
        dir: SpindleDir::Cw,
        speed_rpm: 12_000,
    });
    let sent_b = Sent {
        config: config(),
        pts: b.clone(),
        seqs: fw.points(&b),
    };
    let m5 = fw.machine(MachineCmd::Spindle {
        dir: SpindleDir::Off,
        speed_rpm: 0,
    });
    fw.end_path();
    fw.flush(Duration::from_secs(60));
    let goal = end_of(&b);
    fw.poll_until(Duration::from_millis(20), Duration::from_secs(120), |s| {
        s.motion == Motion::Idle && s.pos_mm == goal
    });
    let deadline = std::time::Instant::now() + Duration::from_secs(5);
    while fw.rec.applied.len() < 2 {
        assert!(std::time::Instant::now() < deadline, "{:?}", fw.rec.applied);
        fw.pump(Duration::from_millis(20));
    }
    let applied: Vec<(u32, MachineCmd, u32, u32)> = fw
        .rec
        .applied
        .iter()
        .filter_map(|m| match *m {
            DeviceMsg::Applied {
                seq,
                cmd,
                point,
                tick,
            } => Some((seq, cmd, point, tick)),
            _ => None,
        })
        .collect();
    assert_eq!(applied[0].0, m3);
    assert_eq!(
        applied[0].2, 40,
        "M3 after the 40th point of the first path"
    );
    assert_eq!(applied[1].0, m5);
    assert_eq!(applied[1].2, 40, "M5 after the 40th point of the second");
    assert_eq!(
        applied[0].1,
        MachineCmd::Spindle {
            dir: SpindleDir::Cw,
            speed_rpm: 12_000
        }
    );
    // The second path's first point entered the planner only after the
    // spin-up delay (100 ticks at 1 kHz).
    let first_b = fw
        .rec
        .scheduled
        .iter()
        .find(|r| r.seq == sent_b.seqs[0])
        .copied()
        .expect("scheduled");
    assert!(
        first_b.tick >= applied[0].3 + 100,
        "second path at tick {} after M3 at {}",
        first_b.tick,
        applied[0].3
    );
    // Between the paths the tool rested at the first one's end.
    let (rep, _) = verify("spindle", &mut fw, &[sent_a, sent_b], 0);
    let t3 = applied[0].3 as usize;
    assert_eq!(rep.ticks[t3 - 1].pos.to_bits(), end_of(&a));
    assert_eq!(rep.ticks[t3 - 1].speed, SpeedMmPerTick::ZERO);
    let t5 = applied[1].3 as usize;
    assert_eq!(rep.ticks[t5 - 1].pos.to_bits(), goal);
    println!(
        "spindle: M3 S12000 applied at path index 40 (tick {}), the second path after the 100 ms spin-up (tick {}), M5 at index 40 of the second (tick {})",
        applied[0].3, first_b.tick, applied[1].3
    );
}

/// A program's path control in the path stream (`G64 P0.01` then `G61`):
/// each takes effect at rest at the end of the path before it, the planner
/// rebuilt with its settings (`PlanEvent::PathControl`), and the host's
/// replay of those settings gives the firmware's setpoints bit for bit.
#[test]
fn path_control_in_the_stream_runs_bit_for_bit() {
    if !qemu_available() {
        return;
    }
    use link::{MachineCmd, PathControl};
    let mut fw = Firmware::start("path-control");
    let zigzag = |from: usize| -> Vec<PathPoint> {
        let pts: Vec<PathPoint> = (from..from + 30)
            .map(|i| {
                let y = if i % 2 == 0 { 0.0 } else { 0.2 };
                PathPoint::at(Point3Mm::from_f64(i as f64 * 0.3, y, 0.0).unwrap())
            })
            .collect();
        on_grid(&pts)
    };
    let (a, b) = (zigzag(0), zigzag(30));
    fw.machine(MachineCmd::PathControl(PathControl::Tolerance {
        nm: 10_000,
    }));
    let sent_a = Sent::stream(&mut fw, config(), &a[1..]);
    fw.machine(MachineCmd::PathControl(PathControl::Exact));
    let sent_b = Sent {
        config: config(),
        pts: b.clone(),
        seqs: fw.points(&b),
    };
    fw.end_path();
    fw.flush(Duration::from_secs(60));
    let goal = end_of(&b);
    fw.poll_until(Duration::from_millis(20), Duration::from_secs(240), |s| {
        s.motion == Motion::Idle && s.pos_mm == goal
    });
    let events = fw
        .rec
        .plan_log
        .iter()
        .filter(|e| {
            matches!(
                e,
                system_tests::firmware::PlanLog::Event {
                    event: link::PlanEvent::PathControl { .. },
                    ..
                }
            )
        })
        .count();
    assert_eq!(events, 2, "both rebuilds reported");
    let (rep, _) = verify("path control", &mut fw, &[sent_a, sent_b], 0);
    assert_eq!(rep.ticks.last().unwrap().pos.to_bits(), goal);
    println!("path control: G64 P0.01 then G61 in the stream, bit for bit");
}

/// A probing move (G38.2) in QEMU, the probe input tripped mid-move by
/// the test (`Firmware::set_inputs`, QEMU's USART2): `DeviceMsg::Probed`
/// reports a trip between the last position reported before the input was
/// set and the first one after (the steps run behind the setpoints a
/// status reports, by 1.5 ticks and the tick it was read at), the tool
/// comes to rest past it under control and short of the target, and the
/// planner's setpoints stay the host's bit for bit. The input still active,
/// the next probe toward it fails at once (`ALARM:4`).
#[test]
fn a_probe_tripped_mid_move_reports_where_the_steps_were() {
    if !qemu_available() {
        return;
    }
    let mut fw = Firmware::start("probe");
    let feed_mm_min = 300.0;
    let seq = fw.probe([0.0, 0.0, -5.0], feed_mm_min, true, true);
    fw.transmit();
    fw.poll_until(Duration::from_millis(5), Duration::from_secs(60), |s| {
        pos(s)[2] < -1.0
    });
    let before = fw.status();
    fw.set_inputs(controller::probe::PROBE);
    let after = fw.status();
    let deadline = std::time::Instant::now() + Duration::from_secs(30);
    while fw.rec.probed.is_empty() {
        assert!(
            std::time::Instant::now() < deadline,
            "no probe report; log: {}",
            fw.log.display()
        );
        fw.pump(Duration::from_millis(20));
    }
    let link::DeviceMsg::Probed {
        seq: s,
        pos_mm,
        tripped,
    } = fw.rec.probed[0]
    else {
        unreachable!()
    };
    assert_eq!((s, tripped), (seq, true));
    let z = pos_mm[2] as f64 / 4294967296.0;
    let tick_mm = feed_mm_min / 60.0 / fw.hello().tick_hz as f64;
    let (z0, z1) = (pos(&before)[2], pos(&after)[2]);
    assert!(
        z <= z0 + 3.0 * tick_mm && z >= z1 - 3.0 * tick_mm,
        "tripped at {z}: statuses {z0} before, {z1} after"
    );
    assert_eq!((pos_mm[0], pos_mm[1]), (0, 0));
    let rest = fw.poll_until(Duration::from_millis(10), Duration::from_secs(30), |s| {
        s.motion == Motion::Idle
    });
    let rest = pos(rest.last().unwrap())[2];
    assert!(rest < z && rest > -5.0, "at rest at {rest}, tripped at {z}");
    assert!(last_alarm(&fw).is_none());
    let config = replay_config(&mut fw);
    let mut points = std::collections::HashMap::new();
    let bits = |v: f64| (v * 4294967296.0).round() as i64;
    points.insert(
        seq,
        planned::probe_point(seq, [0, 0, bits(-5.0)], bits(feed_mm_min)),
    );
    fw.status();
    let upto = fw
        .rec
        .statuses
        .iter()
        .map(|s| s.generated_ticks)
        .max()
        .unwrap_or(0);
    let rep = planned::replay(config, &points, &fw.rec.plan_log, upto);
    // A status answered before the background's first pass has published
    // nothing yet (no tick generated, no checksum).
    let statuses: Vec<Status> = fw
        .rec
        .statuses
        .iter()
        .filter(|s| s.generated_ticks > 0)
        .copied()
        .collect();
    rep.check_statuses("probe", &statuses);
    // Still touching: the next probe toward it fails before moving.
    fw.probe([0.0, 0.0, -5.0], feed_mm_min, true, true);
    fw.transmit();
    let deadline = std::time::Instant::now() + Duration::from_secs(30);
    while last_alarm(&fw).is_none() {
        assert!(std::time::Instant::now() < deadline, "no alarm");
        fw.pump(Duration::from_millis(20));
    }
    let (code, at) = last_alarm(&fw).unwrap();
    assert_eq!(code, link::AlarmCode::ProbeFailInitial);
    // Where the steps are: the setpoint within a step (100 steps/mm).
    assert!((at[2] as f64 / 4294967296.0 - rest).abs() <= 0.01);
    println!(
        "probe in QEMU: tripped at z = {z:.4} (statuses {z0:.4} / {z1:.4}), at rest at {rest:.4}"
    );
}
