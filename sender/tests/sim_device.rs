//! The sender's streaming loop against the whole controller on the host
//! (`controller::sim::VirtualDevice`, the firmware's own code) through an
//! in-process byte stream (`sender::sim`): programs run to their end with
//! the host's feeds bit for bit and the tool on the last point; scripted
//! hold, resume, override, stop; an e-stop (the alarm, exit 7) and an
//! unlock; a cut link, a silent link, a
//! lossy link; a controller already running (resync), a busy one, and
//! `stop` clearing it.

use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use controller::config::Config;
use controller::store::{self, MemFlash};
use gcode_interp::GcodeSettings;
use link::{AlarmCode, DeviceMsg, HostMsg, Motion, PlanEvent, Status};
use sender::actions::{Action, Script};
use sender::exit::Exit;
use sender::program::{self, Item, Jog, Program};
use sender::record::Recorder;
use sender::sim::{self, SimHandle};
use sender::stream::{Actions, NoActions, Options, Outcome, Quiet, Session, SettingsCheck};
use sender::view::bits_f64;

const T: Duration = Duration::from_secs(3);

fn repo(rel: &str) -> String {
    format!("{}/../{rel}", env!("CARGO_MANIFEST_DIR"))
}

fn load(spec: &str) -> Program {
    program::load(spec, &GcodeSettings::default()).unwrap()
}

fn opts() -> Options {
    let mut o = Options::new(program::scheduler_config(5000.0, 60.0).unwrap());
    o.status_period = Duration::from_millis(20);
    o.link_timeout = Duration::from_secs(3);
    o.hello_wait = Duration::from_millis(300);
    o.stop_timeout = Duration::from_secs(10);
    o.reports = true;
    o
}

fn temp(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("sender-sim-{}-{name}", std::process::id()))
}

fn session(h: &SimHandle, rec: Recorder) -> Session {
    let s = h.connect().unwrap();
    Session::new(Box::new(s.try_clone().unwrap()), Box::new(s), rec)
}

/// Handshake, then run `p` with `actions`.
fn run(s: &mut Session, p: &Program, actions: &mut dyn Actions) -> Outcome {
    let o = opts();
    let hs = s.handshake(&o).unwrap();
    s.run(p, &hs, &o, actions, &mut Quiet)
}

/// Every message from the controller in a record.
fn received(path: &Path) -> Vec<DeviceMsg> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter_map(|l| {
            let v: serde_json::Value = serde_json::from_str(l).unwrap();
            v.get("rx")
                .map(|m| serde_json::from_value(m.clone()).unwrap())
        })
        .collect()
}

fn statuses(msgs: &[DeviceMsg]) -> Vec<Status> {
    msgs.iter()
        .filter_map(|m| match m {
            DeviceMsg::Status(s) => Some(*s),
            _ => None,
        })
        .collect()
}

fn events(msgs: &[DeviceMsg]) -> Vec<PlanEvent> {
    msgs.iter()
        .filter_map(|m| match m {
            DeviceMsg::Planned { event, .. } => Some(*event),
            _ => None,
        })
        .collect()
}

/// Points in the program's last path (after its last machine command, if
/// any: they end the path).
fn last_path_len(p: &Program) -> usize {
    p.items()
        .iter()
        .rev()
        .take_while(|i| matches!(i, Item::Point { .. }))
        .count()
}

fn assert_done(o: &Outcome, p: &Program) {
    assert_eq!(o.exit, Exit::Done, "{}", o.message);
    let s = &o.summary;
    let points = p
        .items()
        .iter()
        .filter(|i| matches!(i, Item::Point { .. }))
        .count();
    assert_eq!(s.scheduled as usize, points, "every point scheduled");
    assert_eq!(s.machine_applied, s.machine_sent, "every machine command");
    assert!(s.machine_off_point.is_empty(), "{:?}", s.machine_off_point);
    assert_eq!(s.feed_mismatches, 0, "{:?}", s.mismatch_examples);
    assert!(s.ended_on_last_point, "{:?}", s.last_status);
}

#[test]
fn a_gcode_file_and_a_shape_run_to_their_end_exactly() {
    let (h, p) = (
        sim::start(4.0).unwrap(),
        load(&repo("tests/data/short_segments.ngc")),
    );
    let mut s = session(&h, Recorder::none());
    let o = run(&mut s, &p, &mut NoActions);
    assert_done(&o, &p);
    // The same device, a second program: it is already running (no
    // hello), the sequence resumes.
    let t = load("trident");
    let mut s2 = session(&h, Recorder::none());
    let o2 = opts();
    let hs = s2.handshake(&o2).unwrap();
    assert_eq!(hs.settings, SettingsCheck::Unchecked);
    assert!(hs.hello.is_none());
    assert!(
        hs.status.next_seq as usize >= p.len() + 2,
        "{:?}",
        hs.status
    );
    let out = s2.run(&t, &hs, &o2, &mut NoActions, &mut Quiet);
    assert_done(&out, &t);
    let r = h.finish();
    assert_eq!(
        r.last_position.map(|q| q.to_bits()),
        t.points.last().map(|q| q.pos.to_bits()),
        "the axes were told the last point"
    );
}

#[test]
fn without_reports_the_end_is_found_from_the_status_alone() {
    // The same closed path twice (it starts and ends at the origin, and
    // the second run begins with the first run's point count), then a
    // G-code program.
    let h = sim::start(8.0).unwrap();
    let mut o = opts();
    o.reports = false;
    for spec in ["infinity", "infinity", &repo("tests/data/gcode/pocket.ngc")] {
        let p = load(spec);
        let mut s = session(&h, Recorder::none());
        let hs = s.handshake(&o).unwrap();
        let out = s.run(&p, &hs, &o, &mut NoActions, &mut Quiet);
        assert_eq!(out.exit, Exit::Done, "{spec}: {}", out.message);
        assert_eq!(out.summary.scheduled, 0, "{spec}: no reports");
        assert!(out.summary.ended_on_last_point, "{spec}");
        let st = out.summary.last_status.unwrap();
        assert_eq!(st.point_reached as usize, last_path_len(&p), "{spec}");
        assert_eq!(out.summary.machine_applied as usize, p.events.len());
    }
}

#[test]
fn a_fresh_controllers_settings_are_checked() {
    let (h, p) = (sim::start(10.0).unwrap(), load("infinity"));
    let mut s = session(&h, Recorder::none());
    let o = opts();
    let hs = s.handshake(&o).unwrap();
    assert_eq!(hs.settings, SettingsCheck::Matched);
    assert!(hs.hello.is_some());
    assert_done(&s.run(&p, &hs, &o, &mut NoActions, &mut Quiet), &p);
}

/// A board with `$` settings changed and stored (X acceleration, the
/// machine's feed maximum): its hello differs from the defaults' but is
/// what its settings give, so the check passes; the changed settings are
/// listed, the default F_max and the ETA take its feed maximum, and the
/// program runs with the host's schedule bit for bit.
#[test]
fn a_controller_with_changed_settings_is_checked_against_them() {
    let mut flash = MemFlash::default();
    let (_, _, mut st) = store::load(&flash);
    let mut c = Config::DEFAULT;
    c.set(120, 400).unwrap();
    c.set(201, 4000).unwrap();
    assert_eq!(st.save(&mut flash, &c), link::StoreResult::Saved);
    let h = sim::start_from(8.0, flash, |_| {}).unwrap();
    let mut s = session(&h, Recorder::none());
    let o = opts();
    let hs = s.handshake(&o).unwrap();
    let hello = hs.hello.expect("fresh from reset");
    assert_ne!(
        Some(hello),
        sender::stream::expected_hello(),
        "not the defaults' hello"
    );
    assert_eq!(hs.settings, SettingsCheck::Matched);
    assert_eq!(hs.config, Some(c));
    assert_eq!(hs.changed.len(), 2, "{:?}", hs.changed);
    assert!(hs.changed[0].starts_with("$120=400 "), "{:?}", hs.changed);
    assert_eq!(hs.feed_max_mm_per_min(), 4000.0);
    let p = load("infinity");
    assert_done(&s.run(&p, &hs, &o, &mut NoActions, &mut Quiet), &p);
    // A hello that does not follow from the settings (another build) is
    // refused.
    let other = link::client::Hello {
        accel_mm_per_s2: hello.accel_mm_per_s2 + 1,
        ..hello
    };
    let d = sender::stream::settings_differences(&other, &hello);
    assert_eq!(d.len(), 1, "{d:?}");
}

#[test]
fn scripted_hold_resume_and_override_act_on_the_motion() {
    let h = sim::start(3.0).unwrap();
    let p = load("butterfly");
    let rec = temp("hold.jsonl");
    let mut s = session(&h, Recorder::create(&rec).unwrap());
    let mut script = Script::parse(
        "at point 400: hold\nafter 300 ms: resume\nat point 900: override 50\nat point 1400: override +10\nafter 100 ms: toggle\nafter 300 ms: space\n",
    )
    .unwrap();
    let o = run(&mut s, &p, &mut script);
    s.finish_record().unwrap();
    assert_done(&o, &p);
    assert!(script.is_done());
    let msgs = received(&rec);
    let ev = events(&msgs);
    let want = [
        PlanEvent::Hold,
        PlanEvent::Resume,
        PlanEvent::Override(50),
        PlanEvent::Override(60),
        PlanEvent::Hold,
        PlanEvent::Resume,
        PlanEvent::EndPath,
    ];
    let got: Vec<PlanEvent> = ev.iter().copied().filter(|e| want.contains(e)).collect();
    assert_eq!(got, want, "the planner took them in order: {ev:?}");
    let st = statuses(&msgs);
    assert!(
        st.iter()
            .any(|s| s.motion == Motion::Held && s.feed_mm_per_min == 0),
        "stopped in the hold"
    );
    assert!(st.iter().any(|s| s.override_percent == 50));
    assert_eq!(o.summary.last_status.unwrap().override_percent, 60);
}

/// Jogs (`fuzzy-send jog`) as the controller runs them: each from where the
/// tool is (a relative one, then one to machine coordinates naming one
/// axis), ending exactly on their target; with soft limits on, a jog out
/// of the travel is refused with nothing moved; a scripted stop cancels
/// one under control on its line.
#[test]
fn jogs_start_where_the_tool_is_and_soft_limits_refuse_one_out_of_travel() {
    let h = sim::start(4.0).unwrap();
    let mut s = session(&h, Recorder::none());
    let o = opts();
    let jog = |s: &mut Session, words: &[&str], actions: &mut dyn Actions| {
        let hs = s.handshake(&o).unwrap();
        let here = hs.status.pos_mm.map(bits_f64);
        let j = Jog::parse(words).unwrap();
        let p = program::jog(&j, here, &GcodeSettings::default()).unwrap();
        assert_eq!(p.points.len(), 2, "{words:?}: one straight move");
        let target = j.target_mm(here);
        (s.run(&p, &hs, &o, actions, &mut Quiet), p, target)
    };
    let at = |s: &mut Session| s.status_within(T, |_| {}).unwrap().pos_mm.map(bits_f64);
    let (out, p, target) = jog(&mut s, &["X-10", "y-2.5", "F3000"], &mut NoActions);
    assert_done(&out, &p);
    assert_eq!(target, [-10.0, -2.5, 0.0]);
    assert_eq!(at(&mut s), target);
    let (out, p, target) = jog(&mut s, &["G90", "Z-1.5", "F600"], &mut NoActions);
    assert_done(&out, &p);
    assert_eq!(target, [-10.0, -2.5, -1.5], "the axes not named stay");
    assert_eq!(at(&mut s), target);
    // Soft limits: machine space [−200, 0] per axis at the defaults.
    assert_eq!(
        s.set_setting(20, 1, T).unwrap(),
        Some(link::StoreResult::Saved)
    );
    let (out, _, _) = jog(&mut s, &["X12", "F3000"], &mut NoActions);
    assert_eq!(out.exit, Exit::Controller, "{}", out.message);
    assert!(out.message.contains("OutOfTravel"), "{}", out.message);
    assert_eq!(at(&mut s), [-10.0, -2.5, -1.5], "nothing moved");
    // A long jog stopped part way (Ctrl-C or Esc in the sender): it ends
    // at rest on its line, short of the target.
    let mut script = Script::parse("at 0.3 s: stop\n").unwrap();
    let (out, _, target) = jog(&mut s, &["X-150", "F1000"], &mut script);
    assert_eq!(out.exit, Exit::UserStop, "{}", out.message);
    let deadline = Instant::now() + Duration::from_secs(5);
    let end = loop {
        let st = s.status_within(T, |_| {}).unwrap();
        if st.motion == Motion::Idle {
            break st.pos_mm.map(bits_f64);
        }
        assert!(Instant::now() < deadline, "{st:?}");
        std::thread::sleep(Duration::from_millis(20));
    };
    assert!(end[0] < -10.0 && end[0] > target[0], "{end:?}");
    assert_eq!(&end[1..], &[-2.5, -1.5], "on the jog's line");
    h.finish();
}

#[test]
fn a_stop_ends_under_control_on_the_path() {
    let h = sim::start(2.0).unwrap();
    let p = load("trident");
    let mut s = session(&h, Recorder::none());
    let mut script = Script::parse("at point 700: stop\n").unwrap();
    assert_eq!(script.steps()[0].action, Action::Stop);
    let o = run(&mut s, &p, &mut script);
    assert_eq!(o.exit, Exit::UserStop, "{}", o.message);
    let Some(DeviceMsg::Aborted { pos_mm, points, .. }) = o.summary.aborted else {
        panic!("no stop report: {o:?}")
    };
    assert!(points > 0, "the rest of the path was dropped");
    // The report comes when the planner is at rest; the tick executes
    // what it generated a few ticks later.
    let deadline = Instant::now() + Duration::from_secs(5);
    loop {
        let st = s.status_within(Duration::from_secs(2), |_| {}).unwrap();
        if st.pos_mm == pos_mm && st.motion == Motion::Idle {
            break;
        }
        assert!(Instant::now() < deadline, "{st:?}");
        std::thread::sleep(Duration::from_millis(20));
    }
    let r = h.finish();
    assert_eq!(
        r.last_position.map(|q| q.to_bits()),
        Some(pos_mm),
        "the tool is where the report says"
    );
    assert_ne!(Some(pos_mm), p.points.last().map(|q| q.pos.to_bits()));
}

/// A scripted e-stop mid-path: `HostMsg::EStop`, the controller's alarm
/// (exit 7, the cause and where the tool stopped); the next program is
/// refused while in alarm, with nothing sent; after an unlock it runs.
#[test]
fn an_estop_is_the_alarm_until_unlocked() {
    let h = sim::start(2.0).unwrap();
    let p = load("trident");
    let rec = temp("estop.jsonl");
    let mut s = session(&h, Recorder::create(&rec).unwrap());
    let mut script = Script::parse("at point 700: estop\n").unwrap();
    assert_eq!(script.steps()[0].action, Action::EStop);
    let o = run(&mut s, &p, &mut script);
    s.finish_record().unwrap();
    assert_eq!(o.exit, Exit::Alarm, "{}", o.message);
    assert_eq!(o.exit.code(), 7);
    assert!(
        o.message.contains("E-STOP") && o.message.contains("e-stop from the host"),
        "{}",
        o.message
    );
    assert!(o.message.contains("unlock"), "{}", o.message);
    let Some((code, pos_mm)) = o.summary.alarm else {
        panic!("no alarm: {o:?}")
    };
    assert_eq!(code, AlarmCode::EStopLink);
    assert!(o.summary.aborted.is_none(), "not a controlled stop");
    // It was moving when it stopped: the last status before the alarm
    // had a feed (no ramp down to rest on the path).
    let st = statuses(&received(&rec));
    let before = st.iter().rev().find(|s| s.motion != Motion::Alarm).unwrap();
    assert!(before.feed_mm_per_min > 0, "{before:?}");
    // In alarm: the status and machine status say so, a program is refused.
    let mut s2 = session(&h, Recorder::none());
    let st = s2.status_within(Duration::from_secs(2), |_| {}).unwrap();
    assert_eq!(st.motion, Motion::Alarm);
    assert_eq!(st.pos_mm, pos_mm, "stopped where the report says");
    let ms = s2.machine_within(Duration::from_secs(2)).unwrap();
    assert_eq!(ms.alarm, Some(AlarmCode::EStopLink));
    let refused = run(&mut s2, &p, &mut NoActions);
    assert_eq!(refused.exit, Exit::Alarm, "{}", refused.message);
    assert!(
        refused.message.contains("nothing was sent"),
        "{}",
        refused.message
    );
    // Unlocked: idle, and the program runs from where the tool stopped.
    let ms = s2.unlock(Duration::from_secs(2)).unwrap();
    assert_eq!(ms.alarm, None);
    let mut s3 = session(&h, Recorder::none());
    let t = load("infinity");
    assert_done(&run(&mut s3, &t, &mut NoActions), &t);
    let r = h.finish();
    assert_eq!(
        r.last_position.map(|q| q.to_bits()),
        t.points.last().map(|q| q.pos.to_bits())
    );
}

/// Cuts the link once the controller reports `point` reached.
struct CutAt<'a> {
    h: &'a SimHandle,
    point: u32,
    at: Option<Instant>,
}

impl Actions for CutAt<'_> {
    fn poll(&mut self, _: Duration, reached: u32) -> Vec<Action> {
        if reached >= self.point && self.at.is_none() {
            self.h.cut();
            self.at = Some(Instant::now());
        }
        Vec::new()
    }
}

#[test]
fn a_cut_link_is_link_lost_at_once_and_a_busy_controller_is_refused_then_stopped() {
    let h = sim::start(2.0).unwrap();
    let p = load("trident");
    let mut s = session(&h, Recorder::none());
    let mut cut = CutAt {
        h: &h,
        point: 500,
        at: None,
    };
    let o = run(&mut s, &p, &mut cut);
    assert_eq!(o.exit, Exit::LinkLost, "{}", o.message);
    let after = cut.at.unwrap().elapsed();
    assert!(after < Duration::from_secs(1), "noticed after {after:?}");
    // The controller went on alone and starved: a new sender finds it
    // busy and refuses to start another path over it.
    let mut s2 = session(&h, Recorder::none());
    let o2 = run(&mut s2, &p, &mut NoActions);
    assert_eq!(o2.exit, Exit::Controller, "{}", o2.message);
    assert!(o2.message.contains("busy"), "{}", o2.message);
    // `stop` clears it; then the program runs.
    let mut s3 = session(&h, Recorder::none());
    let a = s3.stop(&opts()).unwrap();
    assert!(matches!(a, DeviceMsg::Aborted { .. }));
    let mut s4 = session(&h, Recorder::none());
    let t = load("infinity");
    assert_done(&run(&mut s4, &t, &mut NoActions), &t);
}

/// A stream that goes silent on `freeze` (both ways) without closing.
#[derive(Clone)]
struct Gate<S> {
    inner: S,
    frozen: Arc<AtomicBool>,
}

impl<S: Read> Read for Gate<S> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        loop {
            if self.frozen.load(Ordering::Relaxed) {
                std::thread::sleep(Duration::from_millis(50));
                continue;
            }
            return self.inner.read(buf);
        }
    }
}

impl<S: Write> Write for Gate<S> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        if self.frozen.load(Ordering::Relaxed) {
            return Ok(buf.len());
        }
        self.inner.write(buf)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

struct FreezeAt {
    frozen: Arc<AtomicBool>,
    point: u32,
    at: Option<Instant>,
}

impl Actions for FreezeAt {
    fn poll(&mut self, _: Duration, reached: u32) -> Vec<Action> {
        if reached >= self.point && self.at.is_none() {
            self.frozen.store(true, Ordering::Relaxed);
            self.at = Some(Instant::now());
        }
        Vec::new()
    }
}

#[test]
fn a_silent_link_is_link_lost_after_the_timeout() {
    let h = sim::start(2.0).unwrap();
    let p = load("trident");
    let raw = h.connect().unwrap();
    let frozen = Arc::new(AtomicBool::new(false));
    let w = Gate {
        inner: raw.try_clone().unwrap(),
        frozen: frozen.clone(),
    };
    let r = Gate {
        inner: raw,
        frozen: frozen.clone(),
    };
    let mut s = Session::new(Box::new(w), Box::new(r), Recorder::none());
    let mut o = opts();
    o.link_timeout = Duration::from_secs(1);
    let hs = s.handshake(&o).unwrap();
    let mut freeze = FreezeAt {
        frozen,
        point: 300,
        at: None,
    };
    let out = s.run(&p, &hs, &o, &mut freeze, &mut Quiet);
    assert_eq!(out.exit, Exit::LinkLost, "{}", out.message);
    assert!(out.message.contains("no answer"), "{}", out.message);
    let after = freeze.at.unwrap().elapsed();
    assert!(
        after >= Duration::from_secs(1) && after < Duration::from_secs(3),
        "{after:?}"
    );
}

/// Drops every `every`-th frame the host writes.
struct Lossy<W> {
    inner: W,
    n: usize,
    every: usize,
    dropped: Arc<std::sync::atomic::AtomicUsize>,
}

impl<W: Write> Write for Lossy<W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.n += 1;
        if self.n % self.every == 0 {
            self.dropped.fetch_add(1, Ordering::Relaxed);
            return Ok(buf.len());
        }
        self.inner.write(buf)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

#[test]
fn a_lossy_link_resends_and_the_path_is_still_exact() {
    let h = sim::start(4.0).unwrap();
    let p = load("infinity");
    let raw = h.connect().unwrap();
    let dropped = Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let w = Lossy {
        inner: raw.try_clone().unwrap(),
        n: 0,
        every: 11,
        dropped: dropped.clone(),
    };
    let mut s = Session::new(Box::new(w), Box::new(raw), Recorder::none());
    let o = run(&mut s, &p, &mut NoActions);
    assert_done(&o, &p);
    assert!(dropped.load(Ordering::Relaxed) > 5);
    assert!(o.summary.resends > 0, "{:?}", o.summary);
}

#[test]
fn a_lost_override_is_sent_again() {
    // Drop exactly the first override frame.
    struct DropOverride<W> {
        inner: W,
        done: bool,
    }
    impl<W: Write> Write for DropOverride<W> {
        fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
            let mut r = link::FrameReader::new();
            let is_override = buf
                .iter()
                .filter_map(|b| r.push::<HostMsg>(*b))
                .any(|m| matches!(m, Ok(HostMsg::Override { .. })));
            if is_override && !self.done {
                self.done = true;
                return Ok(buf.len());
            }
            self.inner.write(buf)
        }
        fn flush(&mut self) -> io::Result<()> {
            self.inner.flush()
        }
    }
    let h = sim::start(2.0).unwrap();
    let p = load("infinity");
    let raw = h.connect().unwrap();
    let w = DropOverride {
        inner: raw.try_clone().unwrap(),
        done: false,
    };
    let mut s = Session::new(Box::new(w), Box::new(raw), Recorder::none());
    let mut script = Script::parse("at point 100: override 150\n").unwrap();
    let o = run(&mut s, &p, &mut script);
    assert_done(&o, &p);
    assert_eq!(o.summary.last_status.unwrap().override_percent, 150);
}

/// Spindle and coolant words of a G-code program go in the path as machine
/// commands, in order: each ends the path, takes effect with the tool at
/// rest at its point (the controller's `Applied`, at the host's point
/// count), and the rest runs as new paths; every feed is still the host's
/// schedule bit for bit (the host schedules the same paths), the tool ends
/// on the last point, and the machine is off again at the end.
#[test]
fn spindle_and_coolant_words_take_effect_in_order_at_their_points() {
    let dir = temp("words");
    std::fs::create_dir_all(&dir).unwrap();
    let f = dir.join("words.ngc");
    std::fs::write(
        &f,
        "G21 G90 G17\nM3 S8000\nM8\nG1 X5 F2000\nG1 X5 Y5\nS9000\nG1 X0 Y5\nG2 X0 Y0 I0 J-2.5\nM9\nM5\n",
    )
    .unwrap();
    let p = load(&f.to_string_lossy());
    let cmds: Vec<String> = p.events.iter().map(|e| program::cmd_text(&e.cmd)).collect();
    assert_eq!(cmds, ["M3 S8000", "M8", "M3 S9000", "M9", "M5"]);
    let h = sim::start(10.0).unwrap();
    let rec = temp("words.jsonl");
    let mut s = session(&h, Recorder::create(&rec).unwrap());
    let o = run(&mut s, &p, &mut NoActions);
    s.finish_record().unwrap();
    assert_done(&o, &p);
    assert_eq!(o.summary.machine_sent, 5);
    let applied: Vec<link::MachineCmd> = received(&rec)
        .iter()
        .filter_map(|m| match m {
            DeviceMsg::Applied { cmd, .. } => Some(*cmd),
            _ => None,
        })
        .collect();
    let want: Vec<link::MachineCmd> = p.events.iter().map(|e| e.cmd).collect();
    assert_eq!(applied, want, "applied in program order");
    let ms = s.machine_within(Duration::from_secs(2)).unwrap();
    assert_eq!(ms.spindle, link::SpindleDir::Off);
    assert!(!ms.flood && !ms.mist);
    let text = sender::cli::summary_text(&o).join("\n");
    assert!(text.contains("5 spindle/coolant commands sent"), "{text}");
}

/// Stops the run once `limit` has passed: a run that never ends shows as
/// a user stop instead of a hung test.
struct Deadline {
    limit: Duration,
    fired: bool,
}

impl Actions for Deadline {
    fn poll(&mut self, elapsed: Duration, _: u32) -> Vec<Action> {
        if elapsed > self.limit && !self.fired {
            self.fired = true;
            return vec![Action::Stop];
        }
        Vec::new()
    }
}

/// `n` moves along X from `x0` mm, 1 mm each, as G-code lines.
fn moves(x0: u32, n: u32) -> String {
    (1..=n).map(|k| format!("G1 X{} F1000\n", x0 + k)).collect()
}

/// Programs with machine commands between, before and after their moves,
/// the path after a command ending at the point count the previous path
/// ended at (which the status then shows throughout): each ends with exit
/// 0 within a bounded time, with statuses as far apart as the binary's.
#[test]
fn programs_with_machine_commands_anywhere_run_to_their_end() {
    let mut programs = Vec::new();
    for cmd in ["G4 P0.1", "M3 S1000", "M8"] {
        for n in 1..=3 {
            for m in 1..=3 {
                programs.push(format!("{}{cmd}\n{}", moves(0, n), moves(n, m)));
            }
        }
        programs.push(format!("{cmd}\n{}", moves(0, 2)));
        programs.push(format!("{}{cmd}\n", moves(0, 2)));
        programs.push(format!("{cmd}\n{}{cmd}\n", moves(0, 1)));
    }
    for (n, m) in [(1, 1), (2, 2), (1, 3), (3, 1)] {
        programs.push(format!(
            "{}G4 P0.05\nM8\nM3 S1000\n{}M9\nM5\n",
            moves(0, n),
            moves(n, m)
        ));
    }
    // Back to where the command was, and back to the start.
    programs.push("G1 X1 F1000\nG1 X2\nG4 P0.1\nG1 X3\nG1 X2\n".into());
    programs.push("G1 X1 F1000\nG4 P0.1\nG1 X0\n".into());
    let dir = temp("commands");
    std::fs::create_dir_all(&dir).unwrap();
    let h = sim::start(20.0).unwrap();
    let mut o = opts();
    o.reports = false;
    o.status_period = Duration::from_millis(200);
    for (k, body) in programs.iter().enumerate() {
        let f = dir.join(format!("p{k}.ngc"));
        std::fs::write(&f, format!("G21 G90\n{body}")).unwrap();
        let p = load(&f.to_string_lossy());
        let mut s = session(&h, Recorder::none());
        let hs = s.handshake(&o).unwrap();
        let mut limit = Deadline {
            limit: Duration::from_secs(10),
            fired: false,
        };
        let t = Instant::now();
        let out = s.run(&p, &hs, &o, &mut limit, &mut Quiet);
        assert_eq!(out.exit, Exit::Done, "{body}: {}", out.message);
        assert!(t.elapsed() < Duration::from_secs(10), "{body}");
        assert_eq!(out.summary.machine_applied as usize, p.events.len());
        assert!(out.summary.ended_on_last_point, "{body}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// The summary's counters are the run's own: frames refused and
/// underruns before it (the controller counts them since power-up) are
/// not the run's.
#[test]
fn the_summary_counts_this_run_only() {
    let h = sim::start(10.0).unwrap();
    let raw = h.connect().unwrap();
    let mut noise = raw.try_clone().unwrap();
    let mut s = Session::new(
        Box::new(raw.try_clone().unwrap()),
        Box::new(raw),
        Recorder::none(),
    );
    let o = opts();
    s.handshake(&o).unwrap();
    // Two frames of garbage (delimited by 0), refused by the controller.
    noise.write_all(&[1, 2, 3, 0, 9, 9, 9, 9, 0]).unwrap();
    let before = s.status_within(T, |_| {}).unwrap();
    assert!(before.bad_frames >= 1, "{before:?}");
    let p = load("infinity");
    let hs = s.handshake(&o).unwrap();
    let out = s.run(&p, &hs, &o, &mut NoActions, &mut Quiet);
    assert_done(&out, &p);
    assert_eq!(out.summary.bad_frames, 0);
    assert_eq!(out.summary.resends, 0);
    assert!(out.summary.last_status.unwrap().bad_frames >= 1);
    let text = sender::cli::summary_text(&out).join("\n");
    assert!(text.contains("this run: link 0 resends"), "{text}");
    assert!(text.contains("0 bad frames"), "{text}");
}

/// As in Grbl: a feed override lasts from one program to the next, and a
/// jog runs at its own feed whatever the override, which it leaves as it
/// found it.
#[test]
fn an_override_lasts_across_programs_and_jogs_ignore_it() {
    let h = sim::start(4.0).unwrap();
    let p = load("infinity");
    let mut s = session(&h, Recorder::none());
    let mut o = opts();
    o.initial_override = Some(150);
    let hs = s.handshake(&o).unwrap();
    assert_done(&s.run(&p, &hs, &o, &mut NoActions, &mut Quiet), &p);
    // The next program finds it in force.
    let o = opts();
    let hs = s.handshake(&o).unwrap();
    assert_eq!(hs.status.override_percent, 150);
    // A jog at F1000: at 100 % while it runs, 150 % again after.
    let rec = temp("jog-override.jsonl");
    let mut s = session(&h, Recorder::create(&rec).unwrap());
    let mut o = opts();
    o.initial_override = Some(100);
    o.restore_override = true;
    let hs = s.handshake(&o).unwrap();
    let j = Jog::parse(&["X-5", "F1000"]).unwrap();
    let jp = program::jog(
        &j,
        hs.status.pos_mm.map(bits_f64),
        &GcodeSettings::default(),
    )
    .unwrap();
    let out = s.run(&jp, &hs, &o, &mut NoActions, &mut Quiet);
    s.finish_record().unwrap();
    assert_done(&out, &jp);
    let st = statuses(&received(&rec));
    let moving: Vec<&Status> = st.iter().filter(|s| s.motion == Motion::Running).collect();
    assert!(!moving.is_empty());
    for m in moving {
        assert_eq!(m.override_percent, 100, "{m:?}");
        assert!(bits_f64(m.feed_mm_per_min) <= 1000.0 + 1e-6, "{m:?}");
    }
    assert_eq!(s.status_within(T, |_| {}).unwrap().override_percent, 150);
    std::fs::remove_file(&rec).ok();
}

/// Silences the host's writes after `at` (a killed sender: nothing more
/// reaches the controller, whose reports still come).
struct Kill {
    at: Duration,
    dead: Arc<AtomicBool>,
}

impl Actions for Kill {
    fn poll(&mut self, elapsed: Duration, _: u32) -> Vec<Action> {
        if elapsed >= self.at {
            self.dead.store(true, Ordering::Relaxed);
        }
        Vec::new()
    }
}

/// What runs on after the host goes silent `at` into `spec`, on a
/// controller in real time with `$209` (the feed hold on silence while
/// moving) at `silence_ms` and the sender's queue bounded by `ahead`:
/// the seconds from the last byte the controller heard to the last
/// motion, and the alarm that ended the run.
fn run_after_silence(
    spec: &str,
    at: Duration,
    silence_ms: i64,
    ahead: Option<Duration>,
) -> (f64, Outcome) {
    let h = sim::start(1.0).unwrap();
    let p = load(spec);
    let raw = h.connect().unwrap();
    let dead = Arc::new(AtomicBool::new(false));
    let w = Gate {
        inner: raw.try_clone().unwrap(),
        frozen: dead.clone(),
    };
    let mut s = Session::new(Box::new(w), Box::new(raw), Recorder::none());
    s.set_setting(209, silence_ms, T).unwrap();
    s.set_setting(206, 500, T).unwrap();
    let mut o = opts();
    o.reports = false;
    o.status_period = Duration::from_millis(200);
    o.link_timeout = Duration::from_secs(30);
    o.ahead = ahead;
    let hs = s.handshake(&o).unwrap();
    let out = s.run(&p, &hs, &o, &mut Kill { at, dead }, &mut Quiet);
    let r = h.finish();
    let ran_s = r.last_move_tick.saturating_sub(r.last_heard_tick) as f64
        / controller::settings::TICK_HZ as f64;
    (ran_s, out)
}

/// The host goes silent mid-path (a killed sender): the sender keeps
/// about `AHEAD` of motion queued, and the controller holds the motion
/// after `$209` of silence and then raises the link-loss alarm, the tool
/// at rest on the path. Prints the figures of `sender/README.md`.
#[test]
fn a_host_gone_mid_path_leaves_little_motion_to_run() {
    let ahead = sender::stream::AHEAD;
    for (spec, at_s) in [
        (repo("tests/data/short_segments.ngc"), 1.5),
        (repo("tests/data/gcode/pocket.ngc"), 1.5),
    ] {
        let at = Duration::from_secs_f64(at_s);
        let name = Path::new(&spec)
            .file_name()
            .unwrap()
            .to_string_lossy()
            .into_owned();
        let (queued_s, out) = run_after_silence(&spec, at, 0, Some(ahead));
        assert_eq!(
            out.summary.alarm.map(|a| a.0),
            Some(AlarmCode::LinkLoss),
            "{name}: {}",
            out.message
        );
        let (unbounded_s, _) = run_after_silence(&spec, at, 0, None);
        let (stop_s, out) = run_after_silence(&spec, at, 1000, Some(ahead));
        assert_eq!(
            out.summary.alarm.map(|a| a.0),
            Some(AlarmCode::LinkLoss),
            "{name}: {}",
            out.message
        );
        println!(
            "{name}: silent from {at_s:.1} s: motion queued ahead {queued_s:.2} s (the sender's bound {:.1} s; without it {unbounded_s:.2} s); with the hold after 1 s of silence ($209=1000), the last host byte to rest {stop_s:.2} s",
            ahead.as_secs_f64()
        );
        assert!(queued_s < ahead.as_secs_f64() + 0.5, "{name}: {queued_s}");
        assert!(stop_s < 1.3, "{name}: {stop_s}");
    }
}

/// The simulated controller a thousand times faster than real time: the
/// host's status every 200 ms is 200 s of its time, and the motion queued
/// ahead (1 s of its time) runs out between two polls again and again.
/// The link's silence counts in the host's time, so no link-loss alarm
/// comes of it, and the program runs to its end.
#[test]
fn a_simulation_far_faster_than_the_host_raises_no_false_link_loss() {
    let h = sim::start(1000.0).unwrap();
    let p = load("trident");
    let mut s = session(&h, Recorder::none());
    let mut o = opts();
    o.status_period = Duration::from_millis(200);
    let hs = s.handshake(&o).unwrap();
    let out = s.run(&p, &hs, &o, &mut NoActions, &mut Quiet);
    assert_done(&out, &p);
    assert!(
        out.summary.underruns > 0,
        "the host fell behind: {:?}",
        out.summary
    );
}

/// Line noise without a delimiter from an earlier host (100 kB), then a
/// new connection: the controller ends the noise at the connection's
/// first delimiter and answers its first status query (not only a
/// retry), and keeps answering.
#[test]
fn a_connection_after_noise_without_a_delimiter_is_answered_at_once() {
    let h = sim::start(1.0).unwrap();
    let mut noisy = h.connect().unwrap();
    noisy.write_all(&vec![0x55u8; 100_000]).unwrap();
    std::thread::sleep(Duration::from_millis(200));
    let mut s = session(&h, Recorder::none());
    for _ in 0..3 {
        let t = Instant::now();
        let st = s.status_within(T, |_| {}).unwrap();
        assert!(
            t.elapsed() < Duration::from_millis(400),
            "the first query is answered: {:?}",
            t.elapsed()
        );
        assert!(st.bad_frames >= 1, "the noise was one bad frame: {st:?}");
    }
}

/// 100 kB of line noise without a delimiter mid-session, then `status`:
/// the first query goes down with the noise (one refusal, `TooLong`), the
/// sender asks again at once after a delimiter and is answered, well
/// within its timeout (not after the 500 ms it waits on a silent link).
#[test]
fn status_after_a_run_of_noise_is_answered_within_the_timeout() {
    let h = sim::start(1.0).unwrap();
    let stream = h.connect().unwrap();
    let mut noise = stream.try_clone().unwrap();
    let mut s = Session::new(
        Box::new(stream.try_clone().unwrap()),
        Box::new(stream),
        Recorder::none(),
    );
    s.status_within(T, |_| {}).unwrap();
    noise.write_all(&vec![0x55u8; 100_000]).unwrap();
    let t0 = Instant::now();
    let mut refusals = Vec::new();
    let st = s
        .status_within(T, |m| {
            if let DeviceMsg::Error { code, .. } = m {
                refusals.push(*code)
            }
        })
        .unwrap();
    let took = t0.elapsed();
    assert_eq!(
        refusals,
        vec![link::ErrorCode::TooLong],
        "one refusal for the run"
    );
    assert!(st.bad_frames >= 1);
    // At once: not after the 500 ms a silent query waits before it is
    // asked again.
    assert!(took < Duration::from_millis(300), "answered after {took:?}");
    println!("status after 100 kB of noise answered in {took:?}");
}

/// What the sender puts on the wire a point, reports off as it runs by
/// default, against the controller on the host (the firmware's own
/// session and credit): the 0.05 mm line and a CAM finishing pass
/// (printed; status queries counted in). The figure to check against a
/// wire's rate is the firmware's QEMU test's (`firmware/README.md`).
#[test]
fn bytes_a_point_the_sender_puts_on_the_wire() {
    let line = std::env::temp_dir().join(format!("sender-sim-{}-line.csv", std::process::id()));
    let rows: String = (0..2001)
        .map(|i| format!("{:.2},0,0\n", i as f64 * 0.05))
        .collect();
    std::fs::write(&line, rows).unwrap();
    for spec in [
        line.to_str().unwrap().to_string(),
        repo("tests/data/cam/surface_ball_end.ngc"),
    ] {
        let p = load(&spec);
        let h = sim::start(10.0).unwrap();
        let mut s = session(&h, Recorder::none());
        let mut o = opts();
        o.reports = false;
        o.status_period = Duration::from_millis(200 / 10);
        let hs = s.handshake(&o).unwrap();
        let before = s.connection().bytes_sent();
        let out = s.run(&p, &hs, &o, &mut NoActions, &mut Quiet);
        assert_eq!(out.exit, Exit::Done, "{}", out.message);
        let per = (s.connection().bytes_sent() - before) as f64 / p.points.len() as f64;
        println!(
            "{}: {} points, {per:.2} bytes a point from the sender",
            p.name,
            p.points.len()
        );
        assert!(per < 8.5, "{per:.2} bytes a point");
    }
    let _ = std::fs::remove_file(&line);
}
