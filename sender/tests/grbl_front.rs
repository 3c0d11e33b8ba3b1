//! The Grbl 1.1 front against the whole controller on the host
//! (`sender::sim`, the firmware's code), without a sender: what a Grbl
//! sender sends, byte for byte, and what it must get back.

use std::time::{Duration, Instant};

use gcode_interp::GcodeSettings;
use sender::program;
use sender::record::Recorder;
use sender::serve::front::Front;
use sender::sim::{self, SimHandle};
use sender::stream::{Options, Session};

struct Rig {
    front: Front,
    out: String,
    sim: SimHandle,
}

fn rig(speed: f64) -> Rig {
    rig_with(speed, |_| {})
}

/// [`rig`] with `setup` run on the simulated controller first.
fn rig_with(
    speed: f64,
    setup: impl FnOnce(&mut controller::sim::VirtualDevice) + Send + 'static,
) -> Rig {
    rig_full(speed, setup, GcodeSettings::default())
}

/// [`rig_with`], the interpreter set by `gcode`.
fn rig_full(
    speed: f64,
    setup: impl FnOnce(&mut controller::sim::VirtualDevice) + Send + 'static,
    gcode: GcodeSettings,
) -> Rig {
    let h = sim::start_with(speed, setup).unwrap();
    let s = h.connect().unwrap();
    let mut session = Session::new(
        Box::new(s.try_clone().unwrap()),
        Box::new(s),
        Recorder::none(),
    );
    let mut o = Options::new(program::scheduler_config(5000.0, 60.0).unwrap());
    o.link_timeout = Duration::from_secs(3);
    o.hello_wait = Duration::from_millis(300);
    o.check_settings = false;
    let hs = session.handshake(&o).unwrap();
    let feed_max = hs.feed_max_mm_per_min();
    let mut front = Front::new(
        session,
        hs.status,
        hs.machine,
        hs.credit_size,
        gcode,
        feed_max,
    )
    .unwrap();
    front.connected();
    Rig {
        front,
        out: String::new(),
        sim: h,
    }
}

impl Rig {
    fn send(&mut self, bytes: &[u8]) {
        self.front.on_bytes(bytes).unwrap();
    }

    /// Poll until `done` holds for what came back since the last take, or
    /// the timeout; what came back.
    fn until(&mut self, timeout: Duration, done: impl Fn(&str) -> bool) -> String {
        let t0 = Instant::now();
        loop {
            self.front.poll().unwrap();
            self.out.push_str(&self.front.take_output());
            if done(&self.out) {
                return std::mem::take(&mut self.out);
            }
            assert!(
                t0.elapsed() < timeout,
                "timed out; got so far: {:?}",
                self.out
            );
        }
    }

    /// A status report.
    fn status(&mut self) -> String {
        self.send(b"?");
        let r = self.until(Duration::from_secs(2), |o| o.contains('>'));
        let s = r.find('<').unwrap();
        let e = r[s..].find('>').unwrap();
        r[s..s + e + 1].to_string()
    }

    /// Poll until the status reads Idle.
    fn idle(&mut self, timeout: Duration) -> String {
        let t0 = Instant::now();
        loop {
            let s = self.status();
            if s.starts_with("<Idle") {
                return s;
            }
            assert!(t0.elapsed() < timeout, "not idle: {s}");
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

fn count(s: &str, what: &str) -> usize {
    s.matches(what).count()
}

#[test]
fn the_welcome_and_build_info_are_what_senders_look_for() {
    let mut r = rig(10.0);
    let w = r.until(Duration::from_secs(1), |o| o.contains("Grbl"));
    assert!(w.contains("Grbl 1.1"), "{w}");
    r.send(b"$I\n");
    let i = r.until(Duration::from_secs(2), |o| o.contains("ok"));
    assert!(i.contains("[VER:1.1"), "{i}");
    assert!(i.contains("[OPT:"), "{i}");
    r.send(b"$G\n");
    let g = r.until(Duration::from_secs(2), |o| o.contains("ok"));
    assert!(g.contains("[GC:G0 G54 G17 G21 G90 G94"), "{g}");
}

#[test]
fn a_program_streams_with_one_ok_per_line_and_ends_where_it_should() {
    let mut r = rig(20.0);
    r.until(Duration::from_secs(1), |o| o.contains("Grbl"));
    let prog = "G21 G90\nG1 X10 F3000\nG1 Y5\n(comment)\nG2 X15 Y10 I5 J0\nG0 Z2\n";
    r.send(prog.as_bytes());
    let oks = r.until(Duration::from_secs(10), |o| count(o, "ok\r\n") == 6);
    assert!(!oks.contains("error"), "{oks}");
    let s = r.idle(Duration::from_secs(20));
    assert!(s.contains("MPos:15.000,10.000,2.000"), "{s}");
}

#[test]
fn a_dwell_is_answered_after_the_motion_before_it() {
    let mut r = rig(10.0);
    r.until(Duration::from_secs(1), |o| o.contains("Grbl"));
    r.send(b"G1 X20 F3000\nG4 P0.1\n");
    r.until(Duration::from_secs(10), |o| count(o, "ok\r\n") == 1);
    // The second ok only once the tool is at X20 and the dwell is done.
    r.until(Duration::from_secs(10), |o| count(o, "ok\r\n") == 1);
    let s = r.status();
    assert!(s.contains("MPos:20.000,0.000,0.000"), "{s}");
}

#[test]
fn real_time_bytes_act_mid_line_and_leave_the_line_whole() {
    let mut r = rig(10.0);
    r.until(Duration::from_secs(1), |o| o.contains("Grbl"));
    r.send(b"G1 X3?0 F3000\n");
    let got = r.until(Duration::from_secs(5), |o| {
        o.contains('>') && o.contains("ok")
    });
    assert!(got.contains("<Idle") || got.contains("<Run"), "{got}");
    let s = r.idle(Duration::from_secs(10));
    assert!(s.contains("MPos:30.000"), "{s}");
    // Feed override +10 % shows in Ov.
    r.send(&[0x91]);
    let mut seen = String::new();
    for _ in 0..12 {
        seen = r.status();
        if seen.contains("Ov:110") {
            break;
        }
    }
    assert!(seen.contains("Ov:110,100,100"), "{seen}");
}

#[test]
fn errors_carry_grbls_numbers() {
    let mut r = rig(10.0);
    r.until(Duration::from_secs(1), |o| o.contains("Grbl"));
    r.send(b"G76 X1\n");
    let e = r.until(Duration::from_secs(2), |o| o.contains("error:"));
    assert!(e.contains("error:20"), "{e}");
    r.send(b"G0 X1 X2\n");
    let e = r.until(Duration::from_secs(2), |o| o.contains("error:"));
    assert!(e.contains("error:25"), "{e}");
    r.send(b"$J=X10\n");
    let e = r.until(Duration::from_secs(2), |o| o.contains("error:"));
    assert!(e.contains("error:"), "{e}");
    // Each line had exactly one answer, in order: a good line still runs.
    r.send(b"G0 X1\n");
    r.until(Duration::from_secs(2), |o| o.contains("ok"));
}

#[test]
fn a_soft_reset_stops_the_motion_and_says_welcome_again() {
    let mut r = rig(5.0);
    r.until(Duration::from_secs(1), |o| o.contains("Grbl"));
    r.send(b"G1 X200 F1000\n");
    r.until(Duration::from_secs(5), |o| o.contains("ok"));
    let t0 = Instant::now();
    while !r.status().starts_with("<Run|MPos:1") {
        assert!(t0.elapsed() < Duration::from_secs(10));
    }
    r.send(&[0x18]);
    let w = r.until(Duration::from_secs(2), |o| o.contains("Grbl"));
    assert!(w.contains("Grbl 1.1"), "{w}");
    let s = r.idle(Duration::from_secs(10));
    let x: f64 = s
        .split("MPos:")
        .nth(1)
        .and_then(|t| t.split(',').next())
        .and_then(|v| v.parse().ok())
        .unwrap();
    assert!(x > 0.0 && x < 200.0, "{s}");
    // The machine takes a new program at once.
    r.send(b"G90 G0 X0\n");
    r.until(Duration::from_secs(5), |o| o.contains("ok"));
    let s = r.idle(Duration::from_secs(20));
    assert!(s.contains("MPos:0.000,0.000,0.000"), "{s}");
}

#[test]
fn a_jog_moves_from_where_the_tool_is_and_a_cancel_stops_it() {
    let mut r = rig(10.0);
    r.until(Duration::from_secs(1), |o| o.contains("Grbl"));
    r.send(b"$J=G91 X5 Y-2 F2000\n");
    r.until(Duration::from_secs(5), |o| o.contains("ok"));
    let s = r.idle(Duration::from_secs(10));
    assert!(s.contains("MPos:5.000,-2.000,0.000"), "{s}");
    // A program after the jog starts from there.
    r.send(b"G91 G1 X1 F1000\n");
    r.until(Duration::from_secs(5), |o| o.contains("ok"));
    let s = r.idle(Duration::from_secs(10));
    assert!(s.contains("MPos:6.000,-2.000,0.000"), "{s}");
}

#[test]
fn work_offsets_show_in_wco_and_in_the_parameters() {
    let mut r = rig(10.0);
    r.until(Duration::from_secs(1), |o| o.contains("Grbl"));
    r.send(b"G0 X10 Y20\nG10 L20 P1 X0 Y0\n");
    r.until(Duration::from_secs(10), |o| count(o, "ok\r\n") == 2);
    r.send(b"$#\n");
    let p = r.until(Duration::from_secs(2), |o| o.contains("ok"));
    assert!(p.contains("[G54:10.000,20.000,0.000]"), "{p}");
    let mut s = String::new();
    for _ in 0..12 {
        s = r.status();
        if s.contains("WCO:") {
            break;
        }
    }
    assert!(s.contains("WCO:10.000,20.000,0.000"), "{s}");
}

fn mpos(status: &str) -> [f64; 3] {
    let p: Vec<f64> = status
        .split("MPos:")
        .nth(1)
        .and_then(|t| t.split('|').next())
        .map(|t| {
            t.trim_end_matches('>')
                .split(',')
                .map(|v| v.parse().unwrap())
                .collect()
        })
        .unwrap();
    [p[0], p[1], p[2]]
}

impl Rig {
    /// Statuses until `done` holds for one; those that moved, and that one.
    fn statuses_until(&mut self, timeout: Duration, done: impl Fn(&str) -> bool) -> Vec<String> {
        let t0 = Instant::now();
        let mut all: Vec<String> = Vec::new();
        loop {
            let s = self.status();
            let end = done(&s);
            if end || all.last().map(|l| mpos(l)) != Some(mpos(&s)) {
                all.push(s);
            }
            if end {
                return all;
            }
            assert!(t0.elapsed() < timeout, "timed out: {all:?}");
        }
    }
}

#[test]
fn a_move_sent_right_after_a_soft_reset_starts_where_the_tool_stopped() {
    let mut r = rig(1.0);
    r.until(Duration::from_secs(1), |o| o.contains("Grbl"));
    r.send(b"G21 G90 G1 X50 F3000\n");
    let t0 = Instant::now();
    while mpos(&r.status())[0] < 10.0 {
        assert!(t0.elapsed() < Duration::from_secs(10));
    }
    // The reset stops the tool on its line a little further on; a
    // sender's next line goes out at once.
    r.send(&[0x18]);
    r.send(b"G0 Y10\n");
    let seen = r.statuses_until(Duration::from_secs(20), |s| {
        s.starts_with("<Idle") && mpos(s)[1] == 10.0
    });
    let end = mpos(seen.last().unwrap());
    let furthest = seen.iter().map(|s| mpos(s)[0]).fold(0.0, f64::max);
    // G0 Y10 moves Y only: X stays where the reset stopped it.
    assert_eq!(end[0], furthest, "{seen:?}");
    for s in &seen {
        let p = mpos(s);
        assert!(p[1] == 0.0 || p[0] == end[0], "X moved with Y: {seen:?}");
    }
}

/// Lines beyond the receive buffer (a sender that does not count
/// characters): `Bf:` reports it full, the front still reads, and a feed
/// hold behind 1.3 kB of waiting lines acts at once (Grbl's serial
/// interrupt takes real-time bytes with its buffer full); after `~` every
/// line is answered once, in order, and the program ends where it should.
#[test]
fn a_hold_behind_a_full_receive_buffer_acts_at_once() {
    let mut r = rig(10.0);
    r.until(Duration::from_secs(1), |o| o.contains("Grbl"));
    r.send(b"$10=3\n");
    r.until(Duration::from_secs(2), |o| o.contains("ok"));
    let mut prog = String::from("G21 G90 G1 X5 F600\nG4 P1\n");
    for i in 1..=120 {
        prog.push_str(&format!("G1 X{} Y{:.1}\n", (i % 2) * 5, f64::from(i) * 0.1));
    }
    assert!(prog.len() > 1300);
    r.send(prog.as_bytes());
    r.send(b"!");
    // Everything that comes back is kept, to count the oks.
    let mut all = String::new();
    let status = |r: &mut Rig, all: &mut String| -> String {
        let from = all.len();
        r.send(b"?");
        let t0 = Instant::now();
        loop {
            r.front.poll().unwrap();
            all.push_str(&r.front.take_output());
            if let Some(i) = all[from..].find('<') {
                if let Some(j) = all[from + i..].find('>') {
                    return all[from + i..from + i + j + 1].to_string();
                }
            }
            assert!(t0.elapsed() < Duration::from_secs(2), "{all}");
        }
    };
    let s = status(&mut r, &mut all);
    assert!(s.starts_with("<Hold"), "{s}");
    assert!(
        s.contains("Bf:") && (s.contains(",0|") || s.contains(",0>")),
        "{s}"
    );
    assert!(r.front.wants_bytes(), "still reading");
    // Held: the tool stops and stays.
    std::thread::sleep(Duration::from_millis(300));
    let a = mpos(&status(&mut r, &mut all));
    std::thread::sleep(Duration::from_millis(200));
    assert_eq!(a, mpos(&status(&mut r, &mut all)));
    r.send(b"~");
    let t0 = Instant::now();
    let s = loop {
        let s = status(&mut r, &mut all);
        if s.starts_with("<Idle") && count(&all, "ok\r\n") == 122 {
            break s;
        }
        assert!(t0.elapsed() < Duration::from_secs(60), "{s} {all}");
        std::thread::sleep(Duration::from_millis(20));
    };
    assert!(!all.contains("error"), "{all}");
    assert_eq!(mpos(&s), [0.0, 12.0, 0.0], "{s}");
}

/// A sender that goes away mid-program (its port closed) stops the motion
/// under control and drops the rest; the next sender gets the welcome and
/// the controller's true state, and its first move starts where the tool
/// stopped.
#[test]
fn a_sender_reconnecting_mid_program_finds_the_machine_stopped() {
    let mut r = rig(1.0);
    r.until(Duration::from_secs(1), |o| o.contains("Grbl"));
    r.send(b"G21 G90 G1 X40 F3000\nY10\nX0\nY0\n");
    let t0 = Instant::now();
    while mpos(&r.status())[0] < 5.0 {
        assert!(t0.elapsed() < Duration::from_secs(10));
    }
    r.front.disconnected().unwrap();
    let _ = r.front.take_output();
    r.out.clear();
    // Nobody polls: the front runs on.
    let t0 = Instant::now();
    while t0.elapsed() < Duration::from_millis(1500) {
        r.front.poll().unwrap();
        std::thread::sleep(Duration::from_millis(2));
    }
    let _ = r.front.take_output();
    r.front.connected();
    let w = r.until(Duration::from_secs(1), |o| o.contains("Grbl"));
    assert!(!w.contains("ALARM"), "{w}");
    let s = r.idle(Duration::from_secs(5));
    let at = mpos(&s);
    assert!(
        at[0] > 5.0 && at[0] < 40.0 && at[1] == 0.0,
        "stopped on the first line: {s}"
    );
    r.send(b"G91 G0 Y2\n");
    r.until(Duration::from_secs(5), |o| o.contains("ok"));
    let s = r.idle(Duration::from_secs(10));
    assert_eq!(mpos(&s), [at[0], 2.0, 0.0], "{s}");
}

#[test]
fn a_jog_after_a_jog_cancel_starts_where_the_tool_stopped() {
    let mut r = rig(1.0);
    r.until(Duration::from_secs(1), |o| o.contains("Grbl"));
    r.send(b"$J=G91 X20 F1000\n");
    let t0 = Instant::now();
    while mpos(&r.status())[0] < 2.0 {
        assert!(t0.elapsed() < Duration::from_secs(10));
    }
    // Jog cancel and the next jog at once, as a sender's jog buttons do.
    r.send(&[0x85]);
    r.send(b"$J=G91 Y5 F1000\n");
    let seen = r.statuses_until(Duration::from_secs(20), |s| {
        s.starts_with("<Idle") && mpos(s)[1] == 5.0
    });
    let end = mpos(seen.last().unwrap());
    let furthest = seen.iter().map(|s| mpos(s)[0]).fold(0.0, f64::max);
    assert!(end[0] < 20.0, "the cancelled jog went on: {seen:?}");
    assert_eq!(end[0], furthest, "{seen:?}");
}

/// From its `ok` to its end a jog reads `Jog`: a status the controller
/// sent before the jog reached it (at rest) does not end it. So a jog
/// cancel right after it cancels it, and the next jog is taken, not
/// refused as "not idle" (cncjs's continuous jogging).
#[test]
fn a_jog_reads_jog_from_its_ok_to_its_end() {
    for _ in 0..5 {
        let mut r = rig(1.0);
        r.until(Duration::from_secs(1), |o| o.contains("Grbl"));
        r.send(b"$J=G91 X20 F600\n");
        r.until(Duration::from_secs(2), |o| o.contains("ok"));
        let t0 = Instant::now();
        while t0.elapsed() < Duration::from_millis(150) {
            let s = r.status();
            assert!(s.starts_with("<Jog"), "{s}");
        }
        r.send(&[0x85]);
        r.send(b"$J=G91 Y1 F600\n");
        let out = r.until(Duration::from_secs(2), |o| {
            o.contains("ok") || o.contains("error")
        });
        assert!(!out.contains("error"), "{out}");
        let s = r.idle(Duration::from_secs(20));
        let p = mpos(&s);
        assert!(p[0] < 5.0 && p[1] == 1.0, "{s}");
    }
}

#[test]
fn real_time_bytes_written_as_utf8_characters_act() {
    // cncjs and bCNC write 0x85 and the overrides as strings: C2 85, C2 91.
    let mut r = rig(1.0);
    r.until(Duration::from_secs(1), |o| o.contains("Grbl"));
    r.send("\u{91}".as_bytes());
    let s = r.statuses_until(Duration::from_secs(2), |s| s.contains("Ov:"));
    assert!(s.last().unwrap().contains("Ov:110,100,100"), "{s:?}");
    r.send(b"$J=G91 X20 F1000\n");
    let t0 = Instant::now();
    while mpos(&r.status())[0] < 2.0 {
        assert!(t0.elapsed() < Duration::from_secs(10));
    }
    r.send("\u{85}".as_bytes());
    let seen = r.statuses_until(Duration::from_secs(10), |s| s.starts_with("<Idle"));
    let end = mpos(seen.last().unwrap());
    assert!(end[0] < 10.0, "the jog was not cancelled: {seen:?}");
}

/// The `[PRB:x,y,z:n]` line in `out`: the position and the flag.
fn prb(out: &str) -> ([f64; 3], u8) {
    let s = out
        .find("[PRB:")
        .unwrap_or_else(|| panic!("no PRB in {out:?}"))
        + 5;
    let e = s + out[s..].find(']').unwrap();
    let (xyz, n) = out[s..e].rsplit_once(':').unwrap();
    let v: Vec<f64> = xyz.split(',').map(|c| c.parse().unwrap()).collect();
    ([v[0], v[1], v[2]], n.parse().unwrap())
}

/// G38.2 against a plate at z = -3.25 (the simulated probe surface): the
/// trip in `[PRB:…:1]` (machine coordinates) before the line's `ok`,
/// within one step (0.01 mm); `G10 L20 P1 Z0` there and `G0 Z1` land
/// 1 mm above the plate; `$#` keeps the result.
#[test]
fn g38_2_reports_the_trip_and_sets_a_work_zero_on_the_plate() {
    let mut r = rig_with(10.0, |d| {
        d.probe = Some(controller::sim::ProbeSurface::plane(-3.25))
    });
    r.until(Duration::from_secs(1), |o| o.contains("Grbl"));
    r.send(b"G38.2 Z-10 F100\n");
    let out = r.until(Duration::from_secs(30), |o| o.contains("ok"));
    let (at, n) = prb(&out);
    assert_eq!(n, 1, "{out}");
    assert!(
        out.find("[PRB:").unwrap() < out.find("ok").unwrap(),
        "{out}"
    );
    assert!(
        (at[2] + 3.25).abs() <= 0.01 + 1e-9 && at[0] == 0.0 && at[1] == 0.0,
        "{out}"
    );
    assert!(!out.contains("ALARM"), "{out}");
    r.send(b"G10 L20 P1 Z0\nG0 Z1\n");
    r.until(Duration::from_secs(20), |o| count(o, "ok\r\n") == 2);
    let s = r.idle(Duration::from_secs(20));
    let z = mpos(&s)[2];
    assert!((z - (at[2] + 1.0)).abs() < 1e-6, "{s}");
    assert!((z + 2.25).abs() <= 0.01 + 1e-9, "1 mm above the plate: {s}");
    r.send(b"$#\n");
    let p = r.until(Duration::from_secs(2), |o| o.contains("ok"));
    assert_eq!(prb(&p), (at, 1), "{p}");
}

/// Spindle overrides (0x9A +10 %, 0x9C +1 %, 0x9B -10 %) act on the
/// controller's spindle output at once, the programmed speed kept; `FS:`
/// reports the speed it runs at (Grbl's `sys.spindle_speed`). Rapid
/// overrides are only reported.
#[test]
fn spindle_overrides_act_on_the_spindle_output() {
    let mut r = rig(10.0);
    r.until(Duration::from_secs(1), |o| o.contains("Grbl"));
    r.send(b"$30=10000\n$31=0\nM3 S5000\nG4 P0.1\n");
    r.until(Duration::from_secs(10), |o| count(o, "ok\r\n") == 4);
    r.send(&[0x9A, 0x9A, 0x9C, 0x9B, 0x96]);
    let s = r.until(Duration::from_secs(2), |_| true);
    assert!(!s.contains("error"), "{s}");
    // `Ov:` comes when it changes, the spindle figure with the machine
    // status the front polls.
    let (mut ov, mut fs) = (false, false);
    let t0 = Instant::now();
    while !(ov && fs) {
        let st = r.status();
        ov |= st.contains("Ov:100,50,111");
        fs |= st.contains("FS:0,5550");
        assert!(t0.elapsed() < Duration::from_secs(5), "{st}");
        std::thread::sleep(Duration::from_millis(20));
    }
    r.send(b"G4 P0.1\n");
    r.until(Duration::from_secs(10), |o| o.contains("ok"));
    let out = r.sim.finish().outputs.unwrap();
    let c = {
        let mut c = controller::config::Config::DEFAULT;
        c.set(30, 10_000).unwrap();
        c.set(31, 0).unwrap();
        c
    };
    assert!(out.spindle_on);
    assert_eq!(
        out.duty_q16,
        controller::spindle::duty_q16(5550, &c),
        "{out:?}"
    );
}

/// grblHAL's manual tool change with a tool-length probe, as a sender's
/// macro runs it: `T2 M6` holds with a message naming the tool until
/// cycle start (`~`); then `G38.2` down to the tool setter, and `G43.1 Z`
/// with the difference from the reference tool (the macro's arithmetic,
/// here in the interpreter's expression from `#5063`); `$#` shows the
/// `[TLO:]`, and a move to work Z0 lands the new tool's tip there
/// (machine z = Z0 + TLO); `G49` cancels it.
#[test]
fn a_manual_tool_change_with_a_tool_length_probe() {
    let mut r = rig_with(10.0, |d| {
        d.probe = Some(controller::sim::ProbeSurface::plane(-3.25))
    });
    r.until(Duration::from_secs(1), |o| o.contains("Grbl"));
    r.send(b"G21 G90 G1 X2 F3000\nT2 M6\n");
    let held = r.until(Duration::from_secs(10), |o| o.contains("[MSG:"));
    assert!(held.contains('2'), "the message names the tool: {held}");
    std::thread::sleep(Duration::from_millis(100));
    assert!(r.status().starts_with("<Hold"), "held for the change");
    r.send(b"~");
    r.until(Duration::from_secs(5), |o| o.contains("resumed"));
    // The reference tool touched the setter at -3.0 before: this one is
    // 0.25 mm longer.
    r.send(b"G38.2 Z-10 F200\nG43.1 Z[#5063 + 3.0]\nG0 Z0\n");
    let out = r.until(Duration::from_secs(30), |o| count(o, "ok\r\n") == 3);
    assert!(!out.contains("error") && !out.contains("ALARM"), "{out}");
    let (at, n) = prb(&out);
    assert_eq!(n, 1, "{out}");
    let s = r.idle(Duration::from_secs(20));
    let tlo = at[2] + 3.0;
    assert!((tlo + 0.25).abs() <= 0.01 + 1e-9, "{out}");
    assert!((mpos(&s)[2] - tlo).abs() < 1e-6, "the tip at work Z0: {s}");
    r.send(b"$#\n");
    let p = r.until(Duration::from_secs(2), |o| o.contains("ok"));
    assert!(p.contains(&format!("[TLO:{tlo:.3}]")), "{p}");
    r.send(b"G49\nG0 Z0\n");
    r.until(Duration::from_secs(10), |o| count(o, "ok\r\n") == 2);
    let s = r.idle(Duration::from_secs(20));
    assert!(mpos(&s)[2].abs() < 1e-9, "{s}");
}

/// Grbl's startup lines: `$N0=` runs the line and keeps it, `$N` lists
/// them, a bad one is refused and not kept, and after a soft reset the
/// welcome is followed by `>line:ok` with the line in force.
#[test]
fn startup_lines_run_after_the_welcome() {
    let mut r = rig(10.0);
    r.until(Duration::from_secs(1), |o| o.contains("Grbl"));
    r.send(b"$N0=G20 G91\n");
    assert_eq!(
        r.until(Duration::from_secs(2), |o| o.contains("ok")),
        "ok\r\n"
    );
    r.send(b"$N1=G1 X\n");
    let e = r.until(Duration::from_secs(2), |o| o.contains("error"));
    assert!(e.contains("error:"), "{e}");
    r.send(b"$N\n");
    let l = r.until(Duration::from_secs(2), |o| o.contains("ok"));
    assert_eq!(
        l, "$N0=G20G91\r\n$N1=\r\nok\r\n",
        "kept as Grbl keeps it, cleaned"
    );
    r.send(b"G21 G90\n");
    r.until(Duration::from_secs(2), |o| o.contains("ok"));
    r.send(&[0x18]);
    let w = r.until(Duration::from_secs(2), |o| o.contains(">G20G91:ok"));
    assert!(w.find("Grbl").unwrap() < w.find(">G20").unwrap(), "{w}");
    r.send(b"$G\n");
    let g = r.until(Duration::from_secs(2), |o| o.contains("ok"));
    assert!(g.contains("G20") && g.contains("G91"), "{g}");
}

/// With a `.var` file the startup lines are kept beside it and run at
/// the next start; `$RST=*` clears them.
#[test]
fn startup_lines_are_kept_across_restarts_beside_the_var_file() {
    let dir = std::env::temp_dir().join(format!("fuzzy-startup-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let settings = GcodeSettings {
        var_file: Some(dir.join("front.var")),
        ..GcodeSettings::default()
    };
    let mut r = rig_full(10.0, |_| {}, settings.clone());
    r.until(Duration::from_secs(1), |o| o.contains("Grbl"));
    r.send(b"$N1=G55\n");
    r.until(Duration::from_secs(2), |o| o.contains("ok"));
    drop(r);
    let mut r = rig_full(10.0, |_| {}, settings.clone());
    let w = r.until(Duration::from_secs(2), |o| o.contains(">G55:ok"));
    assert!(w.contains("Grbl"), "{w}");
    r.send(b"$RST=*\n");
    r.until(Duration::from_secs(10), |o| o.contains("ok"));
    drop(r);
    let mut r = rig_full(10.0, |_| {}, settings);
    r.send(b"$N\n");
    let l = r.until(Duration::from_secs(2), |o| o.contains("ok"));
    assert!(
        l.contains("$N0=\r\n$N1=\r\nok") && !l.contains(">G55"),
        "{l}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `$RST=#` zeroes G54-G59, G28 and G30; `$RST=$` puts every setting
/// back to its default (the controller's and the front's), as
/// `settings_restore` does.
#[test]
fn restore_resets_offsets_and_settings() {
    let mut r = rig(10.0);
    r.until(Duration::from_secs(1), |o| o.contains("Grbl"));
    r.send(b"$$\n");
    let defaults = r.until(Duration::from_secs(3), |o| o.contains("ok"));
    r.send(b"G10 L2 P1 X5 Y6 Z7\nG10 L2 P3 X1\n#5161=2\n$0=5\n$10=2\n$30=2000\n$31=1500\n");
    r.until(Duration::from_secs(5), |o| count(o, "ok\r\n") == 7);
    r.send(b"$#\n");
    let p = r.until(Duration::from_secs(2), |o| o.contains("ok"));
    assert!(
        p.contains("[G54:5.000,6.000,7.000]") && p.contains("[G28:2.000,"),
        "{p}"
    );
    r.send(b"$RST=#\n");
    let a = r.until(Duration::from_secs(5), |o| o.contains("ok"));
    assert!(a.contains("[MSG:Restoring defaults]"), "{a}");
    r.send(b"$#\n");
    let p = r.until(Duration::from_secs(2), |o| o.contains("ok"));
    for c in ["G54", "G56", "G28", "G30"] {
        assert!(p.contains(&format!("[{c}:0.000,0.000,0.000]")), "{p}");
    }
    r.send(b"$RST=$\n");
    let a = r.until(Duration::from_secs(10), |o| {
        o.contains("ok") || o.contains("error")
    });
    assert!(
        a.contains("[MSG:Restoring defaults]") && a.contains("ok"),
        "{a}"
    );
    r.send(b"$$\n");
    let now = r.until(Duration::from_secs(3), |o| o.contains("ok"));
    assert_eq!(now, defaults);
}

/// `$H` against the simulated switches (X 3, Y 5, Z 2 mm, max ends):
/// `Home` while it runs, its `ok` only once the cycle has ended (Grbl
/// answers `$H` after `mc_homing_cycle`), the tool at −pull-off; `$H`
/// with homing off is refused with a message.
#[test]
fn homing_answers_once_the_cycle_has_ended() {
    let mut r = rig_with(10.0, |d| {
        for (axis, at_mm) in [(0, 3.0), (1, 5.0), (2, 2.0)] {
            d.switches.push(controller::sim::SimSwitch {
                axis,
                max: true,
                at_steps: (at_mm * 100.0) as i64,
            });
        }
    });
    r.until(Duration::from_secs(1), |o| o.contains("Grbl"));
    r.send(b"$22=1\n$26=2\n");
    r.until(Duration::from_secs(3), |o| count(o, "ok\r\n") == 2);
    r.send(b"$H\n");
    let t0 = Instant::now();
    let mut seen_home = false;
    let mut out = String::new();
    while !out.contains("ok") {
        r.front.poll().unwrap();
        out.push_str(&r.front.take_output());
        if !out.contains("ok") {
            r.send(b"?");
            let got = r.until(Duration::from_secs(2), |o| o.contains('>'));
            let (a, b) = (got.find('<').unwrap(), got.find('>').unwrap());
            let s = got[a..=b].to_string();
            // What came with it (the ok, before or after the report).
            out.push_str(&got[..a]);
            out.push_str(&got[b + 1..]);
            if s.contains("<Home") {
                seen_home = true;
            }
            // Before its ok: homing, or (the ok goes out at the next
            // poll) at rest where the cycle ends.
            assert!(
                s.contains("<Home") || s.contains("<Idle|MPos:-1.000,-1.000,-1.000"),
                "neither homing nor homed before its ok: {s}"
            );
        }
        assert!(t0.elapsed() < Duration::from_secs(30), "{out}");
    }
    assert!(seen_home, "{out:?}");
    let s = r.idle(Duration::from_secs(5));
    assert_eq!(mpos(&s), [-1.0, -1.0, -1.0], "{s}");
}

/// A sender's side scripted in time: bytes handed over once due, what
/// the front writes kept.
struct Script {
    t0: Instant,
    inputs: std::collections::VecDeque<(Duration, Vec<u8>)>,
    out: String,
}

impl sender::serve::front::SenderIo for Script {
    fn read_now(&mut self, buf: &mut [u8]) -> Result<Option<usize>, sender::exit::Failure> {
        match self.inputs.front() {
            Some((at, _)) if self.t0.elapsed() >= *at => {
                let (_, b) = self.inputs.pop_front().unwrap();
                buf[..b.len()].copy_from_slice(&b);
                Ok(Some(b.len()))
            }
            _ => Ok(Some(0)),
        }
    }

    fn write(&mut self, text: &str) -> Result<(), sender::exit::Failure> {
        self.out.push_str(text);
        Ok(())
    }
}

/// While a probing move runs (the front blocked on its line), the
/// sender's real-time bytes still act, as Grbl's serial interrupt takes
/// them during `mc_probe_cycle`: `?` is answered with `Run` and the tool
/// moving, `!` holds it, `~` resumes, and a soft reset (0x18) stops it
/// under control: no `ok` and no alarm for the line, the welcome again, the
/// tool at rest between its start and the target.
#[test]
fn real_time_bytes_act_while_a_probe_moves() {
    let mut r = rig_with(10.0, |d| {
        d.probe = Some(controller::sim::ProbeSurface::plane(-50.0))
    });
    r.until(Duration::from_secs(1), |o| o.contains("Grbl"));
    let ms = Duration::from_millis;
    let mut io = Script {
        t0: Instant::now(),
        inputs: [
            (ms(150), b"?".to_vec()),
            (ms(250), b"!".to_vec()),
            (ms(600), b"?".to_vec()),
            (ms(700), b"~".to_vec()),
            (ms(850), b"?".to_vec()),
            (ms(900), vec![0x18]),
        ]
        .into(),
        out: String::new(),
    };
    r.send(b"G38.2 Z-10 F60\n");
    let t0 = Instant::now();
    while !io.out.contains("Grbl") {
        r.front.poll_with(&mut io).unwrap();
        io.out.push_str(&r.front.take_output());
        assert!(t0.elapsed() < Duration::from_secs(10), "{:?}", io.out);
    }
    let out = std::mem::take(&mut io.out);
    let reports: Vec<&str> = out.split("\r\n").filter(|l| l.starts_with('<')).collect();
    assert_eq!(reports.len(), 3, "{out}");
    assert!(reports[0].starts_with("<Run"), "{out}");
    assert!(mpos(reports[0])[2] < 0.0, "moving: {out}");
    assert!(reports[1].starts_with("<Hold"), "{out}");
    assert!(reports[2].starts_with("<Run"), "{out}");
    assert!(!out.contains("ok") && !out.contains("ALARM"), "{out}");
    let s = r.idle(Duration::from_secs(10));
    let z = mpos(&s)[2];
    assert!(z < 0.0 && z > -10.0, "{s}");
    // The front takes lines again, from where the tool stopped.
    r.send(b"G91 G0 Z1\n");
    r.until(Duration::from_secs(5), |o| o.contains("ok"));
    let s = r.idle(Duration::from_secs(10));
    assert!((mpos(&s)[2] - (z + 1.0)).abs() < 1e-9, "{s}");
}

/// A probe that never trips: G38.2 raises Grbl's `ALARM:5` (then
/// `[PRB:…:0]` where it stopped, and the line's `ok`), G38.3 only reports
/// `[PRB:…:0]`; one that starts tripped raises `ALARM:4`.
#[test]
fn g38_failures_raise_grbls_probe_alarms() {
    let plane = |h: f64| {
        move |d: &mut controller::sim::VirtualDevice| {
            d.probe = Some(controller::sim::ProbeSurface::plane(h))
        }
    };
    let mut r = rig_with(10.0, plane(-20.0));
    r.until(Duration::from_secs(1), |o| o.contains("Grbl"));
    r.send(b"G38.3 Z-1 F300\n");
    let out = r.until(Duration::from_secs(30), |o| o.contains("ok"));
    assert_eq!(prb(&out), ([0.0, 0.0, -1.0], 0), "{out}");
    assert!(!out.contains("ALARM"), "{out}");
    r.send(b"G38.2 Z-2 F300\n");
    let out = r.until(Duration::from_secs(30), |o| o.contains("ok"));
    assert!(out.contains("ALARM:5"), "{out}");
    assert_eq!(prb(&out), ([0.0, 0.0, -2.0], 0), "{out}");
    assert!(r.status().starts_with("<Alarm"));

    let mut r = rig_with(10.0, plane(1.0));
    r.until(Duration::from_secs(1), |o| o.contains("Grbl"));
    for _ in 0..10 {
        if r.status().contains("Pn:P") {
            break;
        }
    }
    assert!(r.status().contains("Pn:P"), "the probe shows as a pin");
    r.send(b"G38.2 Z-2 F100\n");
    let out = r.until(Duration::from_secs(30), |o| o.contains("ok"));
    assert!(out.contains("ALARM:4"), "{out}");
    assert!(!out.contains("[PRB:"), "{out}");
}
