//! The firmware in QEMU for the system tests: start it, talk to it over
//! the emulated USART through the link's host client
//! (`link::client::Connection`: sequence numbers, credit, go-back-N), and
//! record what it reports.

use std::collections::VecDeque;
use std::io::{Read, Write};
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{mpsc, Arc, Mutex, OnceLock};
use std::thread;
use std::time::{Duration, Instant};

use controller::config::{Config, COUNT, SETTINGS};
use fuzzy_core::scheduler::{PathPoint, SchedulerConfig};
use link::client::{Client, Connection, Hello, LinkError};
use link::{DeviceMsg, ErrorCode, HostMsg, MachineCmd, MachineStatus, PlanEvent, Status};

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

/// A path from a CSV of `x,y,z[,feed cap]` (mm, mm/min), in I32F32
/// (`host_sim::path_csv`, errors name the line).
pub fn read_points(path: &Path) -> Vec<PathPoint> {
    host_sim::path_csv::read(path).unwrap_or_else(|e| panic!("{e:#}"))
}

/// Points rounded to the link's 2⁻¹⁶ mm grid (`link::batch::to_grid`), as
/// a sender streams them: then they travel in compact `Points` batches and
/// the firmware holds exactly these bits.
pub fn on_grid(pts: &[PathPoint]) -> Vec<PathPoint> {
    pts.iter()
        .map(|p| {
            let g = p.pos.to_bits().map(link::batch::to_grid);
            PathPoint {
                pos: fuzzy_core::units::Point3Mm::from_bits(g[0], g[1], g[2]),
                ..*p
            }
        })
        .collect()
}

/// The firmware's clock as the host sees it: the tick counter of every
/// status received ([`Records`] feeds it), extrapolated to now at the
/// rate it ran against the wall clock over the last 1.5 s. Under
/// `-icount` QEMU's clock follows the emulation's speed (well behind the
/// wall clock's on a loaded machine, and slower while the guest is
/// busy), so a pace in firmware time needs this. Monotonic;
/// before two statuses it assumes [`GuestClock::FIRST_RATE`], slower
/// than any run measured, so a pipe paced by it starts too slow rather
/// than too fast.
#[derive(Clone)]
pub struct GuestClock(Arc<Mutex<ClockState>>);

struct ClockState {
    tick_hz: f64,
    /// (arrival, firmware seconds) of recent statuses.
    samples: VecDeque<(Instant, f64)>,
    /// The last reading handed out.
    last: f64,
    /// Where readings start before any status.
    t0: Instant,
}

impl GuestClock {
    /// The rate (firmware seconds a wall second) assumed before two
    /// statuses.
    pub const FIRST_RATE: f64 = 0.2;
    /// Statuses older than this (wall) are not used for the rate.
    const WINDOW: Duration = Duration::from_millis(1500);

    fn new() -> Self {
        GuestClock(Arc::new(Mutex::new(ClockState {
            tick_hz: 1000.0,
            samples: VecDeque::new(),
            last: 0.0,
            t0: Instant::now(),
        })))
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, ClockState> {
        self.0.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The tick rate (from the hello).
    pub fn set_tick_hz(&self, hz: u32) {
        self.lock().tick_hz = hz.max(1) as f64;
    }

    /// A status with tick counter `ticks` arrived now.
    pub fn observe(&self, ticks: u32) {
        let mut c = self.lock();
        let now = Instant::now();
        let t = ticks as f64 / c.tick_hz;
        c.samples.push_back((now, t));
        while c.samples.len() > 2 && now.duration_since(c.samples[0].0) > Self::WINDOW {
            c.samples.pop_front();
        }
    }

    /// Firmware seconds a wall second, as last measured.
    pub fn rate(&self) -> f64 {
        Self::rate_of(&self.lock())
    }

    fn rate_of(c: &ClockState) -> f64 {
        match (c.samples.front(), c.samples.back()) {
            (Some(a), Some(b)) if b.0.duration_since(a.0) >= Duration::from_millis(100) => {
                ((b.1 - a.1) / b.0.duration_since(a.0).as_secs_f64()).clamp(0.01, 2.0)
            }
            _ => Self::FIRST_RATE,
        }
    }

    /// Firmware seconds now (estimated; never decreasing).
    pub fn now_s(&self) -> f64 {
        let mut c = self.lock();
        let rate = Self::rate_of(&c);
        let est = match c.samples.back() {
            Some(&(at, t)) => t + at.elapsed().as_secs_f64() * rate,
            None => c.t0.elapsed().as_secs_f64() * rate,
        };
        c.last = c.last.max(est);
        c.last
    }
}

/// Bytes through each direction of a paced pipe so far.
#[derive(Clone, Default)]
pub struct WireCount {
    /// Host to firmware.
    pub to_device: Arc<AtomicU64>,
    /// Firmware to host.
    pub to_host: Arc<AtomicU64>,
}

/// Bytes a paced pipe lets through at once, at most: a UART's receive
/// FIFO's worth. Time the pipe is idle (boot, handshake, a host waiting
/// for credit) is not saved up beyond it.
pub const WIRE_BURST_BYTES: f64 = 16.0;

/// A byte pipe at a serial wire's rate (`baud / 10` bytes a second, 8N1),
/// each way, in the firmware's time ([`GuestClock`]): a token bucket of
/// [`WIRE_BURST_BYTES`] refilled at that rate. Returns the end for the
/// host; the other end is `device`.
fn throttled(device: UnixStream, baud: u32, clock: &GuestClock, count: &WireCount) -> UnixStream {
    let (host, inner) = UnixStream::pair().expect("socket pair");
    let bytes_per_s = baud as f64 / 10.0;
    let pace = |from: UnixStream, to: UnixStream, passed: Arc<AtomicU64>| {
        let clock = clock.clone();
        let (tx, rx) = mpsc::channel::<Vec<u8>>();
        thread::spawn(move || {
            let mut from = from;
            let mut buf = [0u8; 4096];
            while let Ok(n) = from.read(&mut buf) {
                if n == 0 || tx.send(buf[..n].to_vec()).is_err() {
                    break;
                }
            }
        });
        thread::spawn(move || {
            let mut to = to;
            let mut pending = VecDeque::<u8>::new();
            let mut open = true;
            let mut tokens = 0f64;
            let mut last = clock.now_s();
            loop {
                if pending.is_empty() {
                    if !open {
                        break;
                    }
                    match rx.recv() {
                        Ok(v) => pending.extend(v),
                        Err(_) => break,
                    }
                }
                loop {
                    match rx.try_recv() {
                        Ok(v) => pending.extend(v),
                        Err(mpsc::TryRecvError::Empty) => break,
                        Err(mpsc::TryRecvError::Disconnected) => {
                            open = false;
                            break;
                        }
                    }
                }
                let now = clock.now_s();
                tokens = (tokens + (now - last) * bytes_per_s).min(WIRE_BURST_BYTES);
                last = now;
                let n = (tokens as usize).min(pending.len());
                if n > 0 {
                    let chunk: Vec<u8> = pending.drain(..n).collect();
                    if to.write_all(&chunk).is_err() {
                        return;
                    }
                    tokens -= n as f64;
                    passed.fetch_add(n as u64, Ordering::Relaxed);
                }
                if !pending.is_empty() {
                    // Until half a burst is due (in wall time at the
                    // clock's rate): short enough that the bucket does
                    // not overflow while the bytes wait.
                    let due_s = (WIRE_BURST_BYTES / 2.0 - tokens).max(1.0) / bytes_per_s;
                    let wall = due_s / clock.rate();
                    thread::sleep(Duration::from_secs_f64(wall.clamp(50e-6, 2e-3)));
                }
            }
            let _ = to.shutdown(std::net::Shutdown::Both);
        });
    };
    pace(
        device.try_clone().expect("clone"),
        inner.try_clone().expect("clone"),
        count.to_host.clone(),
    );
    pace(inner, device, count.to_device.clone());
    host
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

/// What the firmware reported, in order of arrival.
#[derive(Default)]
pub struct Records {
    /// Scheduled points reported.
    pub scheduled: Vec<Reported>,
    /// Errors reported, with the sequence number then expected.
    pub errors: Vec<(ErrorCode, u32)>,
    /// Every input of the firmware's planner, in order.
    pub plan_log: Vec<PlanLog>,
    /// Every status received.
    pub statuses: Vec<Status>,
    /// Abort reports (`DeviceMsg::Aborted`).
    pub aborted: Vec<DeviceMsg>,
    /// Alarm reports (`DeviceMsg::Alarm`).
    pub alarms: Vec<DeviceMsg>,
    /// Machine commands that took effect (`DeviceMsg::Applied`).
    pub applied: Vec<DeviceMsg>,
    /// The other machine reports: settings, machine status, homing,
    /// store.
    pub machine: Vec<DeviceMsg>,
    /// Probing moves that ended (`DeviceMsg::Probed`).
    pub probed: Vec<DeviceMsg>,
    /// Bytes of each kind of message received (their frames as sent).
    pub bytes_in: BytesIn,
    /// With a paced link: at each status received, the bytes through the
    /// pipe so far (to the device, to the host).
    pub wire_at_status: Vec<(u64, u64)>,
    paced: Option<(GuestClock, WireCount)>,
}

/// Bytes of the messages received, by kind (each frame's length on the
/// wire, delimiter included).
#[derive(Clone, Copy, Debug, Default)]
pub struct BytesIn {
    /// Acknowledgements (credit updates among them).
    pub acks: u64,
    /// Status replies.
    pub statuses: u64,
    /// Refusals.
    pub errors: u64,
    /// Everything else (the planner's reports, machine reports, hello).
    pub other: u64,
}

impl Records {
    fn record(&mut self, m: &DeviceMsg) {
        let mut frame = [0u8; link::FRAME_MAX];
        let len = link::encode_device(m, &mut frame).unwrap_or(0) as u64;
        match m {
            DeviceMsg::Ack { .. } => self.bytes_in.acks += len,
            DeviceMsg::Status(_) => self.bytes_in.statuses += len,
            DeviceMsg::Error { .. } => self.bytes_in.errors += len,
            _ => self.bytes_in.other += len,
        }
        if let (DeviceMsg::Status(s), Some((clock, count))) = (m, &self.paced) {
            clock.observe(s.ticks);
            self.wire_at_status.push((
                count.to_device.load(Ordering::Relaxed),
                count.to_host.load(Ordering::Relaxed),
            ));
        }
        match *m {
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
            DeviceMsg::Status(s) => self.statuses.push(s),
            DeviceMsg::Error { code, expected_seq } => self.errors.push((code, expected_seq)),
            DeviceMsg::Aborted { .. } => self.aborted.push(*m),
            DeviceMsg::Alarm { .. } => self.alarms.push(*m),
            DeviceMsg::Applied { .. } => self.applied.push(*m),
            DeviceMsg::Probed { .. } => self.probed.push(*m),
            DeviceMsg::Setting { .. }
            | DeviceMsg::Machine(_)
            | DeviceMsg::Homed { .. }
            | DeviceMsg::Stored(_) => self.machine.push(*m),
            DeviceMsg::Ack { .. } | DeviceMsg::Hello { .. } => {}
        }
    }
}

/// A running firmware (QEMU) and the host end of its link
/// (`link::client::Connection`), recording what the firmware reports. QEMU
/// is killed when this is dropped. Every wait has a deadline and panics
/// with the firmware's log path when it passes.
pub struct Firmware {
    child: Option<Child>,
    conn: Connection,
    /// QEMU's USART2 socket (the input word), once connected.
    inputs: Option<std::os::unix::net::UnixStream>,
    /// The link's socket path (QEMU's end is bound to it).
    sock: PathBuf,
    inputs_path: PathBuf,
    /// What the firmware reported.
    pub rec: Records,
    /// Where the firmware's defmt log goes.
    pub log: PathBuf,
}

/// Where QEMU listens for the input word the tests set (USART2, the QEMU
/// image's stand-in for its GPIO inputs) next to the link's socket `sock`.
pub fn inputs_socket(sock: &Path) -> PathBuf {
    sock.with_extension("inputs")
}

/// QEMU's netduinoplus2 running `elf` with `-icount shift=0`, USART1 on the
/// Unix socket `sock` (the guest starts when the first client connects),
/// USART2, the input word ([`Firmware::set_inputs`]), on
/// [`inputs_socket`], the semihosting (defmt) output to `log`.
pub fn spawn_qemu(elf: &Path, sock: &Path, log: std::fs::File) -> Child {
    let inputs = inputs_socket(sock);
    let _ = std::fs::remove_file(&inputs);
    Command::new("qemu-system-arm")
        .args(["-cpu", "cortex-m4", "-machine", "netduinoplus2"])
        .args(["-display", "none", "-monitor", "none"])
        .args(["-semihosting-config", "enable=on,target=native"])
        .args(["-icount", "shift=0"])
        .arg("-serial")
        .arg(format!("unix:{},server=on,wait=on", sock.display()))
        .arg("-serial")
        .arg(format!("unix:{},server=on,wait=off", inputs.display()))
        .arg("-kernel")
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(log)
        .stderr(Stdio::null())
        .spawn()
        .expect("start qemu-system-arm")
}

impl Firmware {
    /// Start the firmware in QEMU (`-icount shift=0`, so SysTick figures
    /// are instruction counts) and wait for its hello. `name` names the
    /// socket and the log file.
    pub fn start(name: &str) -> Firmware {
        Self::start_at(name, None)
    }

    /// [`Firmware::start`] with the link at a serial wire's rate (`baud`,
    /// in the firmware's time: [`GuestClock`], [`WIRE_BURST_BYTES`]), or
    /// as fast as QEMU takes bytes (`None`).
    pub fn start_at(name: &str, baud: Option<u32>) -> Firmware {
        let elf = firmware_elf();
        let dir = repo_root().join("firmware/target/qemu-logs");
        std::fs::create_dir_all(&dir).expect("log dir");
        let sock =
            std::env::temp_dir().join(format!("fuzzy-fw-{}-{name}.sock", std::process::id()));
        let _ = std::fs::remove_file(&sock);
        let log = dir.join(format!("{name}.defmt"));
        let log_file = std::fs::File::create(&log).expect("log file");
        let child = spawn_qemu(&elf, &sock, log_file);
        let deadline = Instant::now() + Duration::from_secs(10);
        let stream = loop {
            match std::os::unix::net::UnixStream::connect(&sock) {
                Ok(s) => break s,
                Err(e) if Instant::now() > deadline => panic!("QEMU socket: {e}"),
                Err(_) => thread::sleep(Duration::from_millis(20)),
            }
        };
        let _ = std::fs::remove_file(&sock);
        let mut rec = Records::default();
        let stream = match baud {
            Some(b) => {
                let (clock, count) = (GuestClock::new(), WireCount::default());
                let host = throttled(stream, b, &clock, &count);
                rec.paced = Some((clock, count));
                host
            }
            None => stream,
        };
        let reader = stream.try_clone().expect("socket clone");
        let mut fw = Firmware {
            child: Some(child),
            conn: Connection::new(Box::new(stream), Box::new(reader)),
            inputs: None,
            sock: sock.clone(),
            inputs_path: inputs_socket(&sock),
            rec,
            log,
        };
        let deadline = Instant::now() + Duration::from_secs(10);
        while fw.conn.client().hello().is_none() {
            assert!(Instant::now() < deadline, "no hello from the firmware");
            fw.pump(Duration::from_millis(100));
        }
        if let Some((clock, _)) = &fw.rec.paced {
            clock.set_tick_hz(fw.hello().tick_hz);
        }
        fw
    }

    /// Bytes sent that QEMU has not yet taken from the link's socket (the
    /// receive queue of QEMU's end, as `ss -x` reports it; `None` if it
    /// cannot be read): QEMU's USART takes one byte at a time, as the
    /// firmware reads the last.
    pub fn unread_by_firmware(&self) -> Option<u64> {
        let out = Command::new("ss").args(["-xHn"]).output().ok()?;
        let text = String::from_utf8_lossy(&out.stdout);
        let path = self.sock.to_str()?;
        // `u_str ESTAB <recv-q> <send-q> <local path> …`: QEMU's end is
        // the one bound to the path.
        text.lines().find_map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            (f.get(4) == Some(&path)).then(|| f.get(2)?.parse().ok())?
        })
    }

    /// With a paced link ([`Firmware::start_at`] with a baud rate): the
    /// firmware's clock as the pipe paces by it.
    pub fn guest_clock(&self) -> Option<GuestClock> {
        self.rec.paced.as_ref().map(|(c, _)| c.clone())
    }

    fn fail(&mut self, e: LinkError) -> ! {
        let status = self
            .child
            .as_mut()
            .and_then(|c| c.try_wait().ok().flatten());
        panic!(
            "{e} (QEMU exit status {status:?}); log: {}",
            self.log.display()
        )
    }

    /// Bytes the host sent so far.
    pub fn bytes_sent(&self) -> u64 {
        self.conn.bytes_sent()
    }

    /// The link session (sequence numbers, credit).
    pub fn client(&self) -> &Client {
        self.conn.client()
    }

    /// The firmware's hello.
    pub fn hello(&self) -> Hello {
        self.conn.client().hello().expect("hello received at start")
    }

    /// Send one frame now.
    pub fn send(&mut self, msg: &HostMsg) {
        if let Err(e) = self.conn.send(msg) {
            self.fail(e)
        }
    }

    /// Send raw bytes (for corrupted frames).
    pub fn send_raw(&mut self, bytes: &[u8]) {
        if let Err(e) = self.conn.send_raw(bytes) {
            self.fail(e)
        }
    }

    /// Handle one message from the firmware if one comes within `timeout`;
    /// returns it.
    pub fn pump(&mut self, timeout: Duration) -> Option<DeviceMsg> {
        match self.conn.recv(timeout) {
            Ok(m) => {
                if let Some(m) = &m {
                    self.rec.record(m);
                }
                m
            }
            Err(e) => self.fail(e),
        }
    }

    /// Ask for the status and wait for it.
    pub fn status(&mut self) -> Status {
        let rec = &mut self.rec;
        match self.conn.status(20, |m| rec.record(m)) {
            Ok(s) => s,
            Err(e) => self.fail(e),
        }
    }

    /// Ask for the status every 500 ms until one comes within `timeout`
    /// (after line noise the firmware may take a while to get to it).
    pub fn status_within(&mut self, timeout: Duration) -> Status {
        let rec = &mut self.rec;
        let tries = (timeout.as_millis() / 500).max(1) as u32;
        match self.conn.status(tries, |m| rec.record(m)) {
            Ok(s) => s,
            Err(e) => self.fail(e),
        }
    }

    /// Queue a path start with these settings; its sequence number.
    pub fn start_path(&mut self, config: &SchedulerConfig) -> u32 {
        let (f_max, f_min) = (config.f_max.0.to_bits(), config.f_min.0.to_bits());
        self.conn.client_mut().start_path(f_max, f_min)
    }

    /// Queue points (their feed caps go with them); their sequence
    /// numbers.
    pub fn points(&mut self, pts: &[PathPoint]) -> Vec<u32> {
        let c = self.conn.client_mut();
        pts.iter()
            .map(|p| c.point(p.pos.to_bits(), p.feed_cap.map(|f| f.0.to_bits())))
            .collect()
    }

    /// Abort now (`HostMsg::Abort`): what was queued and not sent is
    /// dropped, the next commands start a new path.
    pub fn abort(&mut self) {
        let msg = self.conn.client_mut().abort();
        self.send(&msg);
    }

    /// Queue the end of the path.
    pub fn end_path(&mut self) -> u32 {
        self.conn.client_mut().end_path()
    }

    /// Set the input word the firmware reads at each tick (its layout:
    /// bit 0 e-stop, 1-6 the limit switches, 7 the probe; 1 active), as if
    /// the pins changed: the byte goes to QEMU's USART2.
    pub fn set_inputs(&mut self, word: u8) {
        use std::io::Write;
        if self.inputs.is_none() {
            let s = std::os::unix::net::UnixStream::connect(&self.inputs_path)
                .unwrap_or_else(|e| panic!("QEMU's input socket: {e}"));
            self.inputs = Some(s);
        }
        let s = self.inputs.as_mut().expect("connected");
        s.write_all(&[word]).expect("write the input word");
    }

    /// Queue a probing move to `to` (mm) at `feed` (mm/min); its sequence
    /// number.
    pub fn probe(&mut self, to: [f64; 3], feed: f64, toward: bool, error_if_missed: bool) -> u32 {
        let bits = |v: f64| (v * 4294967296.0).round() as i64;
        self.conn
            .client_mut()
            .probe(to.map(bits), bits(feed), toward, error_if_missed)
    }

    /// Queue a machine command (spindle, coolant); its sequence number.
    pub fn machine(&mut self, cmd: MachineCmd) -> u32 {
        self.conn.client_mut().machine(cmd)
    }

    /// Read a setting: its value, or why it was refused.
    pub fn get_setting(&mut self, id: u16) -> Result<i64, ErrorCode> {
        let rec = &mut self.rec;
        match self.conn.get_setting(id, |m| rec.record(m)) {
            Ok(r) => r,
            Err(e) => self.fail(e),
        }
    }

    /// Write a setting: the value in force, or why it was refused.
    pub fn set_setting(&mut self, id: u16, value: i64) -> Result<i64, ErrorCode> {
        let rec = &mut self.rec;
        match self.conn.set_setting(id, value, |m| rec.record(m)) {
            Ok(r) => r,
            Err(e) => self.fail(e),
        }
    }

    /// Every setting as the firmware reports it: what the host replays
    /// its motion with.
    pub fn settings(&mut self) -> Config {
        let mut values = [0i64; COUNT];
        for (v, s) in values.iter_mut().zip(SETTINGS.iter()) {
            *v = self
                .get_setting(s.id)
                .unwrap_or_else(|e| panic!("setting ${}: {e:?}", s.id));
        }
        Config::from_values(values).expect("the firmware's settings are valid")
    }

    /// The machine status.
    pub fn machine_status(&mut self) -> MachineStatus {
        let rec = &mut self.rec;
        match self.conn.machine(|m| rec.record(m)) {
            Ok(s) => s,
            Err(e) => self.fail(e),
        }
    }

    /// Drop what the client still holds and continue the numbering where
    /// the firmware is (after an alarm, or refusals).
    pub fn resync(&mut self) {
        let s = self.status();
        self.conn.client_mut().resync(&s);
    }

    /// Send queued commands as the credit allows; returns how many went.
    pub fn transmit(&mut self) -> usize {
        match self.conn.transmit() {
            Ok(n) => n,
            Err(e) => self.fail(e),
        }
    }

    /// Whether every queued command was acknowledged.
    pub fn all_acked(&self) -> bool {
        self.conn.client().all_acked()
    }

    /// Stream until every queued command is acknowledged (resending what
    /// was refused or went unanswered), handling replies on the way.
    pub fn flush(&mut self, timeout: Duration) {
        let rec = &mut self.rec;
        if let Err(e) = self.conn.flush(timeout, |m| rec.record(m)) {
            let at = (self.client().acked(), self.client().unacked());
            panic!(
                "stream stalled at seq {} with {} unacknowledged ({e}); log: {}",
                at.0,
                at.1,
                self.log.display()
            );
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
        let mut v = self.rec.scheduled.clone();
        v.sort_by_key(|r| r.seq);
        v
    }
}

impl Drop for Firmware {
    fn drop(&mut self) {
        if let Some(mut c) = self.child.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
        let _ = std::fs::remove_file(&self.inputs_path);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::AtomicBool;

    /// Reads `n` bytes from `s`; the time it took.
    fn read_n(s: &mut UnixStream, n: usize) -> Duration {
        let t = Instant::now();
        let mut buf = vec![0u8; n];
        s.read_exact(&mut buf).expect("the pipe's bytes");
        t.elapsed()
    }

    /// The paced pipe against a firmware clock at half the wall clock's
    /// rate (statuses every 10 ms): 20 kB take the wire's time in the
    /// firmware's clock, each way; after an idle second, 1000 bytes take
    /// the wire's time less one burst (nothing saved up).
    #[test]
    fn the_pipe_keeps_the_wire_rate_in_firmware_time_and_saves_up_no_burst() {
        let clock = GuestClock::new();
        let stop = Arc::new(AtomicBool::new(false));
        let (c, halt, t0) = (clock.clone(), stop.clone(), Instant::now());
        let ticker = thread::spawn(move || {
            while !halt.load(Ordering::Relaxed) {
                c.observe((t0.elapsed().as_secs_f64() * 500.0) as u32);
                thread::sleep(Duration::from_millis(10));
            }
        });
        let (device, mut far) = UnixStream::pair().expect("socket pair");
        let count = WireCount::default();
        let mut host = throttled(device, 921_600, &clock, &count);
        thread::sleep(Duration::from_millis(300));
        let wire_s = |bytes: f64| bytes / 92_160.0;
        host.write_all(&[1u8; 20_000]).unwrap();
        let up = read_n(&mut far, 20_000).as_secs_f64() * 0.5 / wire_s(20_000.0);
        far.write_all(&[1u8; 20_000]).unwrap();
        let down = read_n(&mut host, 20_000).as_secs_f64() * 0.5 / wire_s(20_000.0);
        thread::sleep(Duration::from_secs(1));
        host.write_all(&[2u8; 1000]).unwrap();
        let after_idle =
            read_n(&mut far, 1000).as_secs_f64() * 0.5 / wire_s(1000.0 - WIRE_BURST_BYTES);
        stop.store(true, Ordering::Relaxed);
        ticker.join().unwrap();
        println!(
            "wire times taken: {up:.3} up, {down:.3} down, {after_idle:.3} after an idle second"
        );
        for (what, r) in [("up", up), ("down", down), ("after idle", after_idle)] {
            assert!(
                (0.97..1.3).contains(&r),
                "{what}: {r:.3} of the wire's time"
            );
        }
        assert_eq!(count.to_device.load(Ordering::Relaxed), 21_000);
        assert_eq!(count.to_host.load(Ordering::Relaxed), 20_000);
    }
}
