//! Host side of the firmware link, for the QEMU system tests and the
//! `stream` tool: start the firmware in QEMU, talk to it over the emulated
//! USART with the `link` protocol (credit flow control, resend on refusal),
//! and collect what it reports.

use std::collections::VecDeque;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::sync::OnceLock;
use std::thread;
use std::time::{Duration, Instant};

use fuzzy_core::scheduler::SchedulerConfig;
use fuzzy_core::units::Point3Mm;
use link::{DeviceMsg, ErrorCode, FrameReader, HostMsg, PlanEvent, Status};

/// The repository root.
pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap_or(Path::new(".."))
        .to_path_buf()
}

/// Whether QEMU is installed. Without it the firmware tests are skipped,
/// unless `FUZZY_REQUIRE_QEMU=1` (set by `scripts/test.sh`) makes that a
/// failure.
pub fn qemu_available() -> bool {
    let ok = Command::new("qemu-system-arm")
        .arg("--version")
        .stdout(Stdio::null())
        .status()
        .map(|s| s.success())
        .unwrap_or(false);
    if !ok && std::env::var("FUZZY_REQUIRE_QEMU").as_deref() == Ok("1") {
        panic!("qemu-system-arm is required (FUZZY_REQUIRE_QEMU=1) but not installed");
    }
    ok
}

/// The release firmware image, built once per test run (in `firmware/`,
/// its own workspace and target directory). `FW_ELF` overrides it.
pub fn firmware_elf() -> PathBuf {
    static ELF: OnceLock<PathBuf> = OnceLock::new();
    ELF.get_or_init(|| {
        if let Some(p) = std::env::var_os("FW_ELF") {
            return PathBuf::from(p);
        }
        let dir = repo_root().join("firmware");
        let status = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
            .args(["build", "--release", "--bin", "fuzzy-firmware"])
            .current_dir(&dir)
            // The firmware keeps its own target directory and target triple.
            .env_remove("CARGO_TARGET_DIR")
            .env_remove("CARGO_BUILD_TARGET")
            .env_remove("RUSTFLAGS")
            .status()
            .expect("run cargo for the firmware");
        assert!(status.success(), "firmware build failed");
        dir.join("target/thumbv7em-none-eabihf/release/fuzzy-firmware")
    })
    .clone()
}

/// A path's points from a CSV of `x,y,z` mm (header and `#` comments
/// skipped), quantised as the firmware receives them.
pub fn read_points(path: &Path) -> Vec<Point3Mm> {
    let text = std::fs::read_to_string(path).expect("read CSV");
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#') && !l.starts_with('x'))
        .map(|l| {
            let v: Vec<f64> = l
                .split(',')
                .map(|c| c.trim().parse().expect("number"))
                .collect();
            Point3Mm::from_f64(v[0], v[1], v[2]).expect("coordinate")
        })
        .collect()
}

/// A scheduled point as the firmware reported it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Reported {
    /// The point's sequence number.
    pub seq: u32,
    /// Its index in the path.
    pub index: u32,
    /// Its feed, mm/min, I32F32 bits.
    pub feed_bits: i64,
    /// Planner ticks generated before it entered the planner.
    pub tick: u32,
}

/// An input the firmware's velocity planner took, in the order it took
/// them (`DeviceMsg::Scheduled` and `DeviceMsg::Planned`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlanLog {
    /// The point with this sequence number went in after `tick` ticks.
    Point {
        /// Sequence number.
        seq: u32,
        /// Ticks generated before.
        tick: u32,
    },
    /// A command took effect after `tick` ticks.
    Event {
        /// Ticks generated before.
        tick: u32,
        /// What.
        event: PlanEvent,
    },
}

impl PlanLog {
    /// Ticks generated before it.
    pub fn tick(&self) -> u32 {
        match *self {
            PlanLog::Point { tick, .. } | PlanLog::Event { tick, .. } => tick,
        }
    }
}

/// A running firmware (QEMU) and the host end of its link. QEMU is killed
/// when this is dropped.
pub struct Firmware {
    child: Option<Child>,
    writer: Box<dyn Write + Send>,
    rx: Receiver<DeviceMsg>,
    /// Every queued command, by sequence number.
    outbox: Vec<HostMsg>,
    /// Next sequence number to transmit.
    pub send_next: u32,
    /// The controller's next expected sequence number.
    pub acked: u32,
    /// The controller's credit limit (exclusive).
    pub window_end: u32,
    /// Scheduled points reported, in order of arrival.
    pub scheduled: Vec<Reported>,
    /// Errors reported, with the sequence number then expected.
    pub errors: Vec<(ErrorCode, u32)>,
    /// The last status received.
    pub last_status: Option<Status>,
    /// The hello: tick rate, acceleration.
    pub hello: (u32, u32),
    /// The hello: the machine's maximum feed, mm/min.
    pub feed_max: u32,
    /// The hello: points the velocity planner buffers.
    pub planner_points: u16,
    /// Every input of the firmware's planner, in order.
    pub plan_log: Vec<PlanLog>,
    /// Every status received, in order.
    pub statuses: Vec<Status>,
    /// Resends after a refusal or a silence.
    pub resends: u32,
    /// Where the firmware's defmt log goes.
    pub log: PathBuf,
}

impl Firmware {
    /// Start the firmware in QEMU (`-icount shift=0`, so SysTick figures
    /// are instruction counts) and wait for its hello. `name` names the
    /// socket and the log file.
    pub fn start(name: &str) -> Firmware {
        let elf = firmware_elf();
        let dir = repo_root().join("firmware/target/qemu-logs");
        std::fs::create_dir_all(&dir).expect("log dir");
        let sock =
            std::env::temp_dir().join(format!("fuzzy-fw-{}-{name}.sock", std::process::id()));
        let _ = std::fs::remove_file(&sock);
        let log = dir.join(format!("{name}.defmt"));
        let log_file = std::fs::File::create(&log).expect("log file");
        let child = Command::new("qemu-system-arm")
            .args(["-cpu", "cortex-m4", "-machine", "netduinoplus2"])
            .args(["-display", "none", "-monitor", "none"])
            .args(["-semihosting-config", "enable=on,target=native"])
            .args(["-icount", "shift=0"])
            .arg("-serial")
            .arg(format!("unix:{},server=on,wait=on", sock.display()))
            .arg("-kernel")
            .arg(&elf)
            .stdin(Stdio::null())
            .stdout(log_file)
            .stderr(Stdio::null())
            .spawn()
            .expect("start qemu-system-arm");
        let deadline = Instant::now() + Duration::from_secs(10);
        let stream = loop {
            match std::os::unix::net::UnixStream::connect(&sock) {
                Ok(s) => break s,
                Err(e) if Instant::now() > deadline => panic!("QEMU socket: {e}"),
                Err(_) => thread::sleep(Duration::from_millis(20)),
            }
        };
        let _ = std::fs::remove_file(&sock);
        let reader = stream.try_clone().expect("socket clone");
        let mut fw = Firmware::over(Box::new(stream), Box::new(reader), Some(child), log);
        fw.wait_hello(Duration::from_secs(10));
        fw
    }

    /// The host end over any byte stream (e.g. TCP to `cargo run`'s QEMU).
    pub fn over(
        writer: Box<dyn Write + Send>,
        mut reader: Box<dyn Read + Send>,
        child: Option<Child>,
        log: PathBuf,
    ) -> Firmware {
        let (tx, rx) = mpsc::channel();
        thread::spawn(move || {
            let mut frames = FrameReader::new();
            let mut buf = [0u8; 4096];
            while let Ok(n) = reader.read(&mut buf) {
                if n == 0 {
                    break;
                }
                for b in &buf[..n] {
                    match frames.push::<DeviceMsg>(*b) {
                        Some(Ok(m)) if tx.send(m).is_err() => return,
                        Some(Ok(_)) => {}
                        Some(Err(e)) => eprintln!("host: bad frame from the firmware: {e:?}"),
                        None => {}
                    }
                }
            }
        });
        Firmware {
            child,
            writer,
            rx,
            outbox: Vec::new(),
            send_next: 0,
            acked: 0,
            window_end: 0,
            scheduled: Vec::new(),
            errors: Vec::new(),
            last_status: None,
            hello: (0, 0),
            feed_max: 0,
            planner_points: 0,
            plan_log: Vec::new(),
            statuses: Vec::new(),
            resends: 0,
            log,
        }
    }

    fn wait_hello(&mut self, timeout: Duration) {
        let deadline = Instant::now() + timeout;
        while self.hello.0 == 0 {
            assert!(Instant::now() < deadline, "no hello from the firmware");
            self.pump(Duration::from_millis(100));
        }
    }

    /// Send one frame.
    pub fn send(&mut self, msg: &HostMsg) {
        let mut f = [0u8; link::FRAME_MAX];
        let n = link::encode(msg, &mut f).expect("encode");
        self.send_raw(&f[..n]);
    }

    /// Send raw bytes (for corrupted frames).
    pub fn send_raw(&mut self, bytes: &[u8]) {
        self.writer.write_all(bytes).expect("write to the firmware");
        self.writer.flush().expect("flush");
    }

    /// Handle one message from the firmware if one comes within `timeout`;
    /// returns it.
    pub fn pump(&mut self, timeout: Duration) -> Option<DeviceMsg> {
        let m = match self.rx.recv_timeout(timeout) {
            Ok(m) => m,
            Err(RecvTimeoutError::Timeout) => return None,
            Err(RecvTimeoutError::Disconnected) => {
                let status = self
                    .child
                    .as_mut()
                    .and_then(|c| c.try_wait().ok().flatten());
                panic!(
                    "the firmware's link closed (QEMU exit status {status:?}); log: {}",
                    self.log.display()
                )
            }
        };
        match m {
            DeviceMsg::Hello {
                tick_hz,
                accel_mm_per_s2,
                window_end,
                feed_max_mm_per_min,
                planner_points,
            } => {
                self.hello = (tick_hz, accel_mm_per_s2);
                self.feed_max = feed_max_mm_per_min;
                self.planner_points = planner_points;
                self.window_end = self.window_end.max(window_end);
            }
            DeviceMsg::Ack {
                next_seq,
                window_end,
            } => {
                self.acked = self.acked.max(next_seq);
                self.window_end = self.window_end.max(window_end);
            }
            DeviceMsg::Scheduled {
                seq,
                index,
                feed_mm_per_min,
                tick,
            } => {
                self.scheduled.push(Reported {
                    seq,
                    index,
                    feed_bits: feed_mm_per_min,
                    tick,
                });
                self.plan_log.push(PlanLog::Point { seq, tick });
            }
            DeviceMsg::Planned { tick, event } => {
                self.plan_log.push(PlanLog::Event { tick, event })
            }
            DeviceMsg::Status(s) => {
                self.acked = self.acked.max(s.next_seq);
                self.window_end = self.window_end.max(s.window_end);
                self.last_status = Some(s);
                self.statuses.push(s);
            }
            DeviceMsg::Error { code, expected_seq } => {
                self.errors.push((code, expected_seq));
                if matches!(code, ErrorCode::OutOfSequence | ErrorCode::NoCredit)
                    && expected_seq < self.send_next
                {
                    // Go back: resend from what the controller expects.
                    self.send_next = expected_seq.max(self.acked);
                    self.resends += 1;
                }
            }
        }
        Some(m)
    }

    /// Ask for the status and wait for it.
    pub fn status(&mut self) -> Status {
        for _ in 0..20 {
            self.send(&HostMsg::StatusQuery);
            let deadline = Instant::now() + Duration::from_millis(500);
            while Instant::now() < deadline {
                if let Some(DeviceMsg::Status(s)) = self.pump(Duration::from_millis(50)) {
                    return s;
                }
            }
        }
        panic!("no status from the firmware; log: {}", self.log.display())
    }

    /// Queue commands (sequence numbers assigned here, in order); sent by
    /// [`Self::transmit`] within the credit.
    pub fn queue_path_cmd(&mut self, make: impl FnOnce(u32) -> HostMsg) -> u32 {
        let seq = self.outbox.len() as u32;
        self.outbox.push(make(seq));
        seq
    }

    /// Queue a path start with these settings.
    pub fn start_path(&mut self, config: &SchedulerConfig) -> u32 {
        let (f_max, f_min) = (config.f_max.0.to_bits(), config.f_min.0.to_bits());
        self.queue_path_cmd(|seq| HostMsg::StartPath {
            seq,
            f_max_mm_per_min: f_max,
            f_min_mm_per_min: f_min,
        })
    }

    /// Queue points; returns their sequence numbers.
    pub fn points(&mut self, pts: &[Point3Mm]) -> Vec<u32> {
        pts.iter()
            .map(|p| {
                let pos = p.to_bits();
                self.queue_path_cmd(|seq| HostMsg::Point {
                    seq,
                    pos_mm: pos,
                    feed_cap_mm_per_min: None,
                })
            })
            .collect()
    }

    /// Queue the end of the path.
    pub fn end_path(&mut self) -> u32 {
        self.queue_path_cmd(|seq| HostMsg::EndPath { seq })
    }

    /// Send queued commands as the credit allows; returns how many went.
    pub fn transmit(&mut self) -> usize {
        let mut n = 0;
        while (self.send_next as usize) < self.outbox.len() && self.send_next < self.window_end {
            let msg = self.outbox[self.send_next as usize];
            self.send(&msg);
            self.send_next += 1;
            n += 1;
        }
        n
    }

    /// Whether every queued command was acknowledged.
    pub fn all_acked(&self) -> bool {
        self.acked as usize >= self.outbox.len()
    }

    /// Stream until every queued command is acknowledged (resending what
    /// was refused or went unanswered), handling replies on the way.
    pub fn flush(&mut self, timeout: Duration) {
        let deadline = Instant::now() + timeout;
        let mut quiet_since = Instant::now();
        while !self.all_acked() {
            assert!(
                Instant::now() < deadline,
                "stream stalled at seq {} of {}; log: {}",
                self.acked,
                self.outbox.len(),
                self.log.display()
            );
            if self.transmit() > 0 {
                quiet_since = Instant::now();
            }
            if self.pump(Duration::from_millis(20)).is_some() {
                quiet_since = Instant::now();
            } else if quiet_since.elapsed() > Duration::from_millis(500) {
                // Lost replies: ask where the controller is, resend from there.
                let s = self.status();
                if s.next_seq < self.send_next {
                    self.send_next = s.next_seq;
                    self.resends += 1;
                }
                quiet_since = Instant::now();
            }
        }
    }

    /// Poll the status every `period` until `done` holds for it (or
    /// timeout); returns every status seen.
    pub fn poll_until(
        &mut self,
        period: Duration,
        timeout: Duration,
        mut done: impl FnMut(&Status) -> bool,
    ) -> Vec<Status> {
        let deadline = Instant::now() + timeout;
        let mut seen = Vec::new();
        loop {
            self.transmit();
            let s = self.status();
            seen.push(s);
            if done(&s) {
                return seen;
            }
            assert!(
                Instant::now() < deadline,
                "timed out waiting; last status {s:?}; log: {}",
                self.log.display()
            );
            let until = Instant::now() + period;
            while Instant::now() < until {
                // Keep streaming as the credit comes back.
                if self.pump(Duration::from_millis(2)).is_some() {
                    self.transmit();
                }
            }
        }
    }

    /// Whether QEMU is still running (not crashed into a failure exit).
    pub fn alive(&mut self) -> bool {
        match self.child.as_mut() {
            Some(c) => matches!(c.try_wait(), Ok(None)),
            None => true,
        }
    }

    /// Scheduled points by sequence number (the arrival order is already
    /// the path order; this checks there is no repeat).
    pub fn scheduled_in_order(&self) -> Vec<Reported> {
        let mut v: VecDeque<Reported> = self.scheduled.iter().copied().collect();
        v.make_contiguous().sort_by_key(|r| r.seq);
        v.into()
    }
}

impl Drop for Firmware {
    fn drop(&mut self) {
        if let Some(mut c) = self.child.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}
