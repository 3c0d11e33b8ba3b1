//! The sender as a user runs it: the `fuzzy-send` binary against the
//! firmware in QEMU (`netduinoplus2`, `-icount shift=0`, USART1 on a Unix
//! socket that QEMU serves; the sender connects with `--unix`):
//!
//! - a G-code program from the repository runs to its end, exit 0, and the
//!   firmware's motion is the host's bit for bit: every scheduled feed,
//!   and the setpoints (the host replays the planner inputs the firmware
//!   reported, recorded by the sender's `--record`, through the
//!   controller's own planning code, `system_tests::planned`, and compares
//!   the firmware's setpoint checksum and position at every status), the
//!   tool exactly on the last point;
//! - hold, resume, override and a controlled stop from a script (the key
//!   handling path without a terminal): exit 6, the same bit-exact replay
//!   with the events, the tool at rest where the firmware's stop report
//!   says (read back with `fuzzy-send status --json`);
//! - QEMU killed mid-path: exit 4 within seconds;
//! - the sender killed mid-path: the firmware stops on the path under
//!   control within 2 s (a feed hold on the link's silence, or an
//!   underrun stop); the next sender finds it busy (exit 5),
//!   `fuzzy-send stop` clears it (exit 0), and a program runs on the
//!   firmware that is already running (no hello: the sequence is resumed;
//!   no planner reports: the end found from the status), exit 0, the tool
//!   exactly on its last point;
//! - a refused G-code line: exit 3, `FILE:LINE: message`, nothing sent
//!   (the sender never connects);
//! - `monitor` prints status lines until Ctrl-C, exit 0;
//! - a scripted e-stop mid-path: the firmware's alarm, exit 7 with its
//!   cause and position; the next program refused in alarm (exit 7,
//!   nothing sent); `status` names the alarm; `unlock` (exit 0); a `$`
//!   setting written (in force; QEMU's flash does not keep it: exit 0 with
//!   a warning) and read back; `home` refused with homing off (exit 5); a
//!   program then runs (exit 0) with the changed setting listed, and a
//!   `jog` after it ends where its words say from where the tool was.
//!
//! Needs `qemu-system-arm` (skipped without it unless
//! `FUZZY_REQUIRE_QEMU=1`). Every QEMU and sender run has a deadline.

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::Mutex;

use std::thread;
use std::time::{Duration, Instant};
use system_tests::binaries::fuzzy_send;

use controller::settings::MOTION_CONFIG;
use fuzzy_core::scheduler::PathPoint;
use link::{DeviceMsg, MachineCmd, Motion, PlanEvent, Status};
use system_tests::firmware::{
    firmware_elf, on_grid, qemu_available, repo_root, spawn_qemu, PlanLog,
};
use system_tests::planned;

/// One QEMU test at a time: each QEMU takes a core, and `-icount` slows
/// the guest's clock on a loaded host.
static QEMU_SLOT: Mutex<()> = Mutex::new(());

/// The firmware in QEMU, serving USART1 on a Unix socket (the guest
/// starts when the first client connects). Killed on drop.
struct Qemu {
    child: Child,
    sock: PathBuf,
}

impl Qemu {
    fn start(name: &str) -> Qemu {
        let elf = firmware_elf();
        let dir = repo_root().join("firmware/target/qemu-logs");
        std::fs::create_dir_all(&dir).expect("log dir");
        let sock =
            std::env::temp_dir().join(format!("fuzzy-send-{}-{name}.sock", std::process::id()));
        let _ = std::fs::remove_file(&sock);
        let log = std::fs::File::create(dir.join(format!("sender-{name}.defmt"))).expect("log");
        let child = spawn_qemu(&elf, &sock, log);
        let deadline = Instant::now() + Duration::from_secs(10);
        while !sock.exists() {
            assert!(
                Instant::now() < deadline,
                "QEMU did not open {}",
                sock.display()
            );
            thread::sleep(Duration::from_millis(20));
        }
        Qemu { child, sock }
    }

    fn link_args(&self) -> Vec<String> {
        vec!["--unix".into(), self.sock.display().to_string()]
    }
}

impl Drop for Qemu {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let _ = std::fs::remove_file(&self.sock);
    }
}

/// A finished sender run.
struct Ran {
    status: ExitStatus,
    stdout: String,
    stderr: String,
    took: Duration,
}

impl Ran {
    fn code(&self) -> Option<i32> {
        self.status.code()
    }
}

/// A sender run in progress: stdout and stderr collected on threads.
struct Running {
    child: Child,
    started: Instant,
    out: thread::JoinHandle<String>,
    err: thread::JoinHandle<String>,
}

fn spawn_sender(args: &[String]) -> Running {
    let mut child = Command::new(fuzzy_send())
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start fuzzy-send");
    let mut o = child.stdout.take().expect("stdout");
    let mut e = child.stderr.take().expect("stderr");
    Running {
        child,
        started: Instant::now(),
        out: thread::spawn(move || {
            let mut s = String::new();
            let _ = o.read_to_string(&mut s);
            s
        }),
        err: thread::spawn(move || {
            let mut s = String::new();
            let _ = e.read_to_string(&mut s);
            s
        }),
    }
}

impl Running {
    /// Wait for the exit, killing the sender after `limit`.
    fn wait(mut self, limit: Duration) -> Ran {
        let status = loop {
            if let Some(s) = self.child.try_wait().expect("wait for fuzzy-send") {
                break s;
            }
            if self.started.elapsed() > limit {
                let _ = self.child.kill();
                let _ = self.child.wait();
                let err = self.err.join().unwrap_or_default();
                panic!("fuzzy-send still running after {limit:?}; stderr:\n{err}");
            }
            thread::sleep(Duration::from_millis(10));
        };
        let took = self.started.elapsed();
        Ran {
            status,
            stdout: self.out.join().unwrap_or_default(),
            stderr: self.err.join().unwrap_or_default(),
            took,
        }
    }
}

fn sender(args: &[String], limit: Duration) -> Ran {
    spawn_sender(args).wait(limit)
}

fn strings(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| s.to_string()).collect()
}

fn temp(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("fuzzy-send-{}-{name}", std::process::id()))
}

/// What a `--record` file holds.
#[derive(Default)]
struct Record {
    start_seq: u32,
    f_max_bits: i64,
    f_min_bits: i64,
    /// (seq, position bits, feed cap bits) in order.
    points: Vec<(u32, [i64; 3], Option<i64>)>,
    /// Machine commands of the path: (seq, what) in order.
    machine: Vec<(u32, MachineCmd)>,
    rx: Vec<DeviceMsg>,
}

fn read_record(path: &Path) -> Record {
    let text = std::fs::read_to_string(path).expect("the record");
    let mut r = Record::default();
    for line in text.lines() {
        let v: serde_json::Value = serde_json::from_str(line).expect("a JSON line");
        if let Some(p) = v.get("path") {
            r.start_seq = p["start_seq"].as_u64().expect("start_seq") as u32;
            r.f_max_bits = p["f_max_bits"].as_i64().expect("f_max_bits");
            r.f_min_bits = p["f_min_bits"].as_i64().expect("f_min_bits");
        } else if let Some(p) = v.get("point") {
            let pos: [i64; 3] = serde_json::from_value(p["pos_bits"].clone()).expect("pos_bits");
            r.points.push((
                p["seq"].as_u64().expect("seq") as u32,
                pos,
                p["cap_bits"].as_i64(),
            ));
        } else if let Some(m) = v.get("machine") {
            r.machine.push((
                m["seq"].as_u64().expect("seq") as u32,
                serde_json::from_value(m["cmd"].clone()).expect("a MachineCmd"),
            ));
        } else if let Some(m) = v.get("rx") {
            r.rx.push(serde_json::from_value(m.clone()).expect("a DeviceMsg"));
        }
    }
    r
}

impl Record {
    fn statuses(&self) -> Vec<Status> {
        self.rx
            .iter()
            .filter_map(|m| match m {
                DeviceMsg::Status(s) => Some(*s),
                _ => None,
            })
            .collect()
    }

    fn plan_log(&self) -> Vec<PlanLog> {
        self.rx
            .iter()
            .filter_map(|m| match *m {
                DeviceMsg::Scheduled { seq, tick, .. } => Some(PlanLog::Point { seq, tick }),
                DeviceMsg::Planned { tick, event } => Some(PlanLog::Event { tick, event }),
                _ => None,
            })
            .collect()
    }

    fn events(&self) -> Vec<PlanEvent> {
        self.rx
            .iter()
            .filter_map(|m| match m {
                DeviceMsg::Planned { event, .. } => Some(*event),
                _ => None,
            })
            .collect()
    }
}

/// The sent path against the host's own reading of the file (on the
/// link's grid), then the
/// firmware's run against the host's: every scheduled feed, and the
/// planner's setpoints replayed through the controller's code (checksum
/// and position at every status, and `extra` statuses taken after the
/// run), within every limit. Returns the replay.
fn verify(name: &str, file: &Path, rec: &Record, extra: &[Status]) -> planned::Replayed {
    // As a sender streams them: on the link's grid; the spindle and
    // coolant words in order with them, each after its point, and after
    // those the point again (the next path's start, no feed cap).
    let read = host_sim::inputs::load(file, &host_sim::config::SimConfig::default().gcode)
        .expect("the host reads the file");
    let host: Vec<PathPoint> = on_grid(&read.path_points());
    let mut want: Vec<PathPoint> = Vec::new();
    let mut want_machine = Vec::new();
    for (i, h) in host.iter().enumerate() {
        want.push(*h);
        let here: Vec<_> = read.events.iter().filter(|e| e.0 == i).collect();
        for (_, _, e) in &here {
            want_machine.push(sender::program::machine_cmd(e).expect("a command the link carries"));
        }
        if !here.is_empty() && i + 1 < host.len() {
            want.push(PathPoint {
                feed_cap: None,
                ..*h
            });
        }
    }
    assert_eq!(rec.points.len(), want.len(), "{name}: points sent");
    for (i, ((_, pos, cap), h)) in rec.points.iter().zip(&want).enumerate() {
        assert_eq!(*pos, h.pos.to_bits(), "{name}: point {i} sent as read");
        assert_eq!(
            *cap,
            h.feed_cap.map(|f| f.0.to_bits()),
            "{name}: cap of point {i}"
        );
    }
    let sent_machine: Vec<MachineCmd> = rec.machine.iter().map(|m| m.1).collect();
    assert_eq!(sent_machine, want_machine, "{name}: machine commands sent");
    // Every path command in order from the start: points and machine
    // commands take consecutive sequence numbers.
    let mut seqs_all: Vec<u32> = rec
        .points
        .iter()
        .map(|p| p.0)
        .chain(rec.machine.iter().map(|m| m.0))
        .collect();
    seqs_all.sort_unstable();
    assert!(
        seqs_all
            .iter()
            .enumerate()
            .all(|(k, q)| *q == rec.start_seq + 1 + k as u32),
        "{name}: sequence numbers"
    );
    // Each machine command took effect (in order) with the tool at rest.
    let applied: Vec<(u32, MachineCmd)> = rec
        .rx
        .iter()
        .filter_map(|m| match *m {
            DeviceMsg::Applied { seq, cmd, .. } => Some((seq, cmd)),
            _ => None,
        })
        .collect();
    assert!(
        rec.machine.starts_with(&applied),
        "{name}: applied in order: {applied:?}"
    );
    let config = controller::command::config_from_link(rec.f_max_bits, rec.f_min_bits)
        .expect("the path's settings");
    // A machine command ends the path: each path is scheduled on its own.
    let mut points = std::collections::HashMap::new();
    let mut from = 0;
    for k in 1..=rec.points.len() {
        let cut = k == rec.points.len()
            || rec
                .machine
                .iter()
                .any(|m| m.0 > rec.points[k - 1].0 && m.0 < rec.points[k].0);
        if cut {
            let seqs: Vec<u32> = rec.points[from..k].iter().map(|p| p.0).collect();
            points.extend(planned::schedule(config, &want[from..k], &seqs));
            from = k;
        }
    }
    let mut scheduled = 0;
    for m in &rec.rx {
        if let DeviceMsg::Scheduled {
            seq,
            index,
            feed_mm_per_min,
            ..
        } = *m
        {
            let h = points
                .get(&seq)
                .unwrap_or_else(|| panic!("{name}: seq {seq} not a point"));
            assert_eq!(
                (index, feed_mm_per_min),
                (h.index, h.feed.0.to_bits()),
                "{name}: seq {seq}: firmware feed {} host {} mm/min",
                feed_mm_per_min as f64 / 4294967296.0,
                h.feed.to_f64()
            );
            scheduled += 1;
        }
    }
    // A status answered before the firmware's first background pass has
    // its figures still zero (nothing published yet): nothing to compare.
    let mut statuses: Vec<Status> = rec
        .statuses()
        .into_iter()
        .filter(|s| !(s.ticks == 0 && s.generated_ticks == 0 && s.positions_checksum == 0))
        .collect();
    statuses.extend_from_slice(extra);
    let upto = statuses
        .iter()
        .map(|s| s.generated_ticks)
        .max()
        .unwrap_or(0);
    let rep = planned::replay(MOTION_CONFIG, &points, &rec.plan_log(), upto);
    let n = rep.check_statuses(name, &statuses);
    let p = planned::peaks(&rep.ticks, &MOTION_CONFIG, rep.accel_mm_s2);
    planned::check_limits(name, &p, &MOTION_CONFIG);
    println!(
        "{name}: {} points ({} read, {} again after machine commands) and {} machine commands sent as read, {} applied; {scheduled} feeds and {} setpoints bit-exact with the host ({n} statuses)",
        want.len(),
        host.len(),
        want.len() - host.len(),
        rec.machine.len(),
        applied.len(),
        rep.ticks.len()
    );
    rep
}

fn status_json(q: &Qemu) -> Status {
    let mut a = q.link_args();
    a.extend(strings(&["status", "--json"]));
    let r = sender(&a, Duration::from_secs(30));
    assert_eq!(r.code(), Some(0), "status: {}", r.stderr);
    serde_json::from_str(r.stdout.trim()).expect("a status as JSON")
}

#[test]
fn a_gcode_program_runs_to_its_end_bit_exact_with_the_host() {
    if !qemu_available() {
        return;
    }
    let _slot = QEMU_SLOT.lock().unwrap_or_else(|e| e.into_inner());
    let file = repo_root().join("tests/data/gcode/pocket.ngc");
    let rec_path = temp("pocket.jsonl");
    let q = Qemu::start("pocket");
    let mut a = q.link_args();
    a.extend([
        "send".into(),
        file.display().to_string(),
        "--verify".into(),
        "--record".into(),
        rec_path.display().to_string(),
    ]);
    let r = sender(&a, Duration::from_secs(120));
    assert_eq!(r.code(), Some(0), "stderr:\n{}", r.stderr);
    for want in [
        "fresh from reset",
        "settings match the host's",
        "done: ",
        "every feed equal to the host's schedule bit for bit",
        "machine: 2 spindle/coolant commands sent in the path, 2 applied by the controller, each with the tool at rest at its point",
    ] {
        assert!(r.stderr.contains(want), "{want:?} not in:\n{}", r.stderr);
    }
    assert!(
        r.stderr.contains("] "),
        "status lines while unattended:\n{}",
        r.stderr
    );
    let rec = read_record(&rec_path);
    let last = *rec.statuses().last().expect("statuses");
    assert_eq!(last.motion, Motion::Idle);
    let end = rec.points.last().expect("points").1;
    assert_eq!(last.pos_mm, end, "the tool on the last point");
    assert_eq!(last.empty_ticks, 0, "the planner never fell behind");
    assert!(rec.events().contains(&PlanEvent::EndPath));
    let rep = verify("pocket", &file, &rec, &[]);
    assert_eq!(rep.ticks.last().expect("ticks").pos.to_bits(), end);
    println!("pocket: fuzzy-send took {:.1} s", r.took.as_secs_f64());
}

#[test]
fn scripted_hold_resume_override_and_stop() {
    if !qemu_available() {
        return;
    }
    let _slot = QEMU_SLOT.lock().unwrap_or_else(|e| e.into_inner());
    let file = repo_root().join("tests/data/shapes/trident.csv");
    let rec_path = temp("script.jsonl");
    let script = temp("script.txt");
    // The hold lasts long enough in wall time for QEMU, whose clock runs
    // slower than the wall's on a loaded machine, to bring the tool to rest.
    std::fs::write(
        &script,
        "at point 300: hold\nafter 3 s: resume\nat point 700: override 50\nat point 900: override +10\nat point 1200: stop\n",
    )
    .expect("script");
    let q = Qemu::start("script");
    let mut a = q.link_args();
    a.extend([
        "send".into(),
        file.display().to_string(),
        "--script".into(),
        script.display().to_string(),
        "--verify".into(),
        "--record".into(),
        rec_path.display().to_string(),
    ]);
    let r = sender(&a, Duration::from_secs(120));
    assert_eq!(
        r.code(),
        Some(6),
        "stopped by the user; stderr:\n{}",
        r.stderr
    );
    assert!(r.stderr.contains("stopped by the user"), "{}", r.stderr);
    let rec = read_record(&rec_path);
    let ev = rec.events();
    let want = [
        PlanEvent::Hold,
        PlanEvent::Resume,
        PlanEvent::Override(50),
        PlanEvent::Override(60),
        PlanEvent::Abort,
    ];
    let got: Vec<PlanEvent> = ev.iter().copied().filter(|e| want.contains(e)).collect();
    assert_eq!(got, want, "the planner took them in order: {ev:?}");
    let st = rec.statuses();
    assert!(
        st.iter()
            .any(|s| s.motion == Motion::Held && s.feed_mm_per_min == 0),
        "stopped in the hold"
    );
    let Some(DeviceMsg::Aborted { pos_mm, points, .. }) = rec
        .rx
        .iter()
        .copied()
        .find(|m| matches!(m, DeviceMsg::Aborted { .. }))
    else {
        panic!("no stop report")
    };
    assert!(points > 0, "the rest of the path was dropped");
    // At rest where the report says (the report comes when the planner is
    // at rest; the tick executes its last setpoints a few ticks later),
    // the motion the host's.
    let deadline = Instant::now() + Duration::from_secs(30);
    let after = loop {
        let s = status_json(&q);
        if s.motion == Motion::Idle {
            break s;
        }
        assert!(Instant::now() < deadline, "not at rest: {s:?}");
        thread::sleep(Duration::from_millis(50));
    };
    assert_eq!(after.pos_mm, pos_mm);
    assert_ne!(Some(pos_mm), rec.points.last().map(|p| p.1));
    verify("script", &file, &rec, &[after]);
}

#[test]
fn killing_qemu_mid_path_is_link_lost_at_once() {
    if !qemu_available() {
        return;
    }
    let _slot = QEMU_SLOT.lock().unwrap_or_else(|e| e.into_inner());
    let rec_path = temp("kill.jsonl");
    let mut q = Qemu::start("kill");
    let mut a = q.link_args();
    a.extend([
        "send".into(),
        repo_root()
            .join("tests/data/shapes/trident.csv")
            .display()
            .to_string(),
        "--verify".into(),
        "--record".into(),
        rec_path.display().to_string(),
    ]);
    let run = spawn_sender(&a);
    // Mid-path: the firmware has scheduled a few hundred points.
    let deadline = Instant::now() + Duration::from_secs(60);
    loop {
        let n = std::fs::read_to_string(&rec_path)
            .map(|t| t.matches("\"Scheduled\"").count())
            .unwrap_or(0);
        if n >= 300 {
            break;
        }
        assert!(Instant::now() < deadline, "the path did not get going");
        thread::sleep(Duration::from_millis(20));
    }
    let killed = Instant::now();
    let _ = q.child.kill();
    let _ = q.child.wait();
    let r = run.wait(Duration::from_secs(60));
    let after = killed.elapsed();
    assert_eq!(r.code(), Some(4), "link lost; stderr:\n{}", r.stderr);
    assert!(
        after < Duration::from_secs(3),
        "exited {after:?} after QEMU died"
    );
    assert!(r.stderr.contains("link"), "{}", r.stderr);
    println!(
        "kill: exit 4, {:.0} ms after QEMU died",
        after.as_secs_f64() * 1e3
    );
}

#[test]
fn a_busy_firmware_is_refused_stopped_and_runs_the_next_program() {
    if !qemu_available() {
        return;
    }
    let _slot = QEMU_SLOT.lock().unwrap_or_else(|e| e.into_inner());
    let rec_path = temp("busy.jsonl");
    let q = Qemu::start("busy");
    let mut a = q.link_args();
    a.extend([
        "send".into(),
        repo_root()
            .join("tests/data/shapes/trident.csv")
            .display()
            .to_string(),
        "--verify".into(),
        "--record".into(),
        rec_path.display().to_string(),
    ]);
    let mut run = spawn_sender(&a);
    let deadline = Instant::now() + Duration::from_secs(60);
    loop {
        let n = std::fs::read_to_string(&rec_path)
            .map(|t| t.matches("\"Scheduled\"").count())
            .unwrap_or(0);
        if n >= 200 {
            break;
        }
        assert!(Instant::now() < deadline, "the path did not get going");
        thread::sleep(Duration::from_millis(20));
    }
    // The sender dies without a word: the firmware holds the motion after
    // a second of silence ($209), or runs out of the second of path the
    // sender kept queued ahead first (an underrun stop); either way it
    // rests on the path under control within two seconds, and stays.
    let _ = run.child.kill();
    let _ = run.wait(Duration::from_secs(10));
    thread::sleep(Duration::from_secs(2));
    let starved = status_json(&q);
    assert!(
        matches!(starved.motion, Motion::Held | Motion::Starved) && starved.feed_mm_per_min == 0,
        "no controlled stop: {starved:?}"
    );
    assert_eq!(starved.empty_ticks, 0, "{starved:?}");
    thread::sleep(Duration::from_millis(300));
    assert_eq!(status_json(&q).pos_mm, starved.pos_mm, "standing still");
    let file = repo_root().join("tests/data/gcode/pocket.ngc");
    let mut send = q.link_args();
    // Without `--verify`: no planner reports, the end found from the
    // status alone.
    send.extend(["send".into(), file.display().to_string()]);
    let r = sender(&send, Duration::from_secs(60));
    assert_eq!(r.code(), Some(5), "busy; stderr:\n{}", r.stderr);
    assert!(r.stderr.contains("busy"), "{}", r.stderr);
    assert!(r.stderr.contains("already running"), "{}", r.stderr);
    let mut stop = q.link_args();
    stop.push("stop".into());
    let r = sender(&stop, Duration::from_secs(60));
    assert_eq!(r.code(), Some(0), "stop; stderr:\n{}", r.stderr);
    assert!(r.stderr.contains("stopped at"), "{}", r.stderr);
    let r = sender(&send, Duration::from_secs(120));
    assert_eq!(r.code(), Some(0), "the next program; stderr:\n{}", r.stderr);
    assert!(r.stderr.contains("already running"), "{}", r.stderr);
    assert!(r.stderr.contains("done: "), "{}", r.stderr);
    // The program started where the tool stopped (G-code starts where
    // the tool is) and ended exactly on its last point.
    let end = status_json(&q);
    let read = host_sim::inputs::load(&file, &host_sim::config::SimConfig::default().gcode)
        .expect("read")
        .path_points();
    let last = on_grid(&read).last().expect("a point").pos.to_bits();
    assert_eq!(end.pos_mm, last, "on the last point, on the grid");
    // Monitor: status lines until Ctrl-C.
    let mut m = q.link_args();
    m.extend(strings(&["monitor", "--period", "0.2"]));
    let mon = spawn_sender(&m);
    thread::sleep(Duration::from_millis(1500));
    let pid = mon.child.id().to_string();
    let _ = Command::new("kill").args(["-INT", &pid]).status();
    let r = mon.wait(Duration::from_secs(10));
    assert_eq!(r.code(), Some(0), "monitor; stderr:\n{}", r.stderr);
    assert!(r.stdout.lines().count() >= 2, "{}", r.stdout);
    assert!(r.stdout.contains("Idle"), "{}", r.stdout);
}

#[test]
fn a_refused_gcode_line_is_named_and_nothing_is_sent() {
    let dir = temp("refused");
    std::fs::create_dir_all(&dir).expect("dir");
    let listener = std::os::unix::net::UnixListener::bind(dir.join("link.sock"))
        .or_else(|_| {
            let _ = std::fs::remove_file(dir.join("link.sock"));
            std::os::unix::net::UnixListener::bind(dir.join("link.sock"))
        })
        .expect("a socket to watch");
    listener.set_nonblocking(true).expect("non-blocking");
    for (name, text, line, what) in [
        (
            "unknown.ngc",
            "G21 G90\nG0 X1\nG1 X2 F300\nG999 X3\nG1 X4\n",
            4,
            "",
        ),
        (
            "slow.ngc",
            "G21 G90\nG1 X1 F300\nG1 X2 F0.2\n",
            3,
            "minimum",
        ),
    ] {
        let file = dir.join(name);
        std::fs::write(&file, text).expect("write");
        let args = vec![
            "--unix".into(),
            dir.join("link.sock").display().to_string(),
            "send".into(),
            file.display().to_string(),
        ];
        let r = sender(&args, Duration::from_secs(30));
        assert_eq!(
            r.code(),
            Some(3),
            "{name}: refused input; stderr:\n{}",
            r.stderr
        );
        let want = format!("{}:{line}: ", file.display());
        assert!(
            r.stderr.contains(&want),
            "{name}: {want:?} not in:\n{}",
            r.stderr
        );
        assert!(
            r.stderr.contains(what),
            "{name}: {what:?} not in:\n{}",
            r.stderr
        );
        assert!(
            matches!(listener.accept(), Err(e) if e.kind() == std::io::ErrorKind::WouldBlock),
            "{name}: the sender connected"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_estop_is_the_alarm_until_unlocked_and_settings_are_read_and_written() {
    if !qemu_available() {
        return;
    }
    let _slot = QEMU_SLOT.lock().unwrap_or_else(|e| e.into_inner());
    let q = Qemu::start("estop");
    let script = temp("estop.txt");
    std::fs::write(&script, "at point 300: estop\n").expect("script");
    let rec_path = temp("estop.jsonl");
    let file = repo_root().join("tests/data/shapes/trident.csv");
    let mut a = q.link_args();
    a.extend([
        "send".into(),
        file.display().to_string(),
        "--script".into(),
        script.display().to_string(),
        "--record".into(),
        rec_path.display().to_string(),
    ]);
    let r = sender(&a, Duration::from_secs(120));
    assert_eq!(r.code(), Some(7), "alarm; stderr:\n{}", r.stderr);
    assert!(
        r.stderr.contains("ALARM: e-stop from the host") && r.stderr.contains("unlock"),
        "{}",
        r.stderr
    );
    let rec = read_record(&rec_path);
    let alarm = rec.rx.iter().find_map(|m| match *m {
        DeviceMsg::Alarm { code, pos_mm, .. } => Some((code, pos_mm)),
        _ => None,
    });
    let (code, pos) = alarm.expect("the firmware reported the alarm");
    assert_eq!(code, link::AlarmCode::EStopLink);
    let st = status_json(&q);
    assert_eq!(st.motion, Motion::Alarm);
    assert_eq!(st.pos_mm, pos, "stopped where the report says");
    let pocket = repo_root().join("tests/data/gcode/pocket.ngc");
    let mut send = q.link_args();
    send.extend(["send".into(), pocket.display().to_string()]);
    let r = sender(&send, Duration::from_secs(60));
    assert_eq!(r.code(), Some(7), "refused in alarm; stderr:\n{}", r.stderr);
    assert!(r.stderr.contains("nothing was sent"), "{}", r.stderr);
    let run = |args: &[&str]| {
        let mut a = q.link_args();
        a.extend(strings(args));
        sender(&a, Duration::from_secs(60))
    };
    let r = run(&["status"]);
    assert_eq!(r.code(), Some(0), "{}", r.stderr);
    assert!(
        r.stdout.contains("state: Alarm") && r.stdout.contains("ALARM: e-stop from the host"),
        "{}",
        r.stdout
    );
    let r = run(&["unlock"]);
    assert_eq!(r.code(), Some(0), "unlock; stderr:\n{}", r.stderr);
    assert!(r.stderr.contains("unlocked"), "{}", r.stderr);
    assert_eq!(status_json(&q).motion, Motion::Idle);
    // A setting: in force at once; QEMU's flash model does not keep it,
    // which is a warning, not a refusal.
    let r = run(&["settings", "set", "120", "1500"]);
    assert!(
        r.stdout.starts_with("$120 = 1500 mm/s² (was "),
        "{}",
        r.stdout
    );
    assert_eq!(r.code(), Some(0), "set; stderr:\n{}", r.stderr);
    assert!(
        r.stderr.contains("saved to flash") || r.stderr.contains("not saved"),
        "{}",
        r.stderr
    );
    println!(
        "settings set on QEMU: exit {:?}: {}",
        r.code(),
        r.stderr.trim()
    );
    let r = run(&["settings", "get", "$120"]);
    assert_eq!(r.code(), Some(0), "{}", r.stderr);
    assert!(r.stdout.starts_with("$120=1500 "), "{}", r.stdout);
    let r = run(&["settings"]);
    assert_eq!(r.code(), Some(0), "{}", r.stderr);
    assert_eq!(r.stdout.lines().count(), controller::config::SETTINGS.len());
    let r = run(&["home"]);
    assert_eq!(r.code(), Some(5), "home with $22=0; stderr:\n{}", r.stderr);
    assert!(r.stderr.contains("$22=0"), "{}", r.stderr);
    // A program runs again, its changed setting listed.
    let r = sender(&send, Duration::from_secs(120));
    assert_eq!(r.code(), Some(0), "after unlock; stderr:\n{}", r.stderr);
    assert!(r.stderr.contains("$120=1500"), "{}", r.stderr);
    assert!(r.stderr.contains("done: "), "{}", r.stderr);
    // A jog from where the pocket ended: relative, Z not named stays.
    let before = status_json(&q).pos_mm;
    let r = run(&["jog", "--log", "X-1.5", "Y0.25", "F600"]);
    assert_eq!(r.code(), Some(0), "jog; stderr:\n{}", r.stderr);
    let after = status_json(&q).pos_mm;
    let mm = |b: i64| b as f64 / 4294967296.0;
    assert!(
        (mm(after[0]) - mm(before[0]) + 1.5).abs() < 1e-6
            && (mm(after[1]) - mm(before[1]) - 0.25).abs() < 1e-6
            && after[2] == before[2],
        "jog from {before:?} ended at {after:?}"
    );
    println!(
        "estop: exit 7 at X{:.3} Y{:.3}, unlock, $120 written and read back, pocket after it in {:.1} s, a jog after that",
        pos[0] as f64 / 4294967296.0,
        pos[1] as f64 / 4294967296.0,
        r.took.as_secs_f64()
    );
}
