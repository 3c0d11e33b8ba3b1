//! The Grbl 1.1 front's core: bytes from a sender in, Grbl's answers out,
//! the controller driven over the link. No ports here (`serve::port` has
//! them) and no clock of its own: [`Front::poll`] is called often.
//!
//! How a line runs, as Grbl runs it (`protocol.c` `protocol_main_loop`,
//! `gcode.c` `gc_execute_line`, `planner.c` `plan_buffer_line`):
//! - real-time bytes act at once, wherever they are in the stream;
//! - a G-code line goes through the live interpreter
//!   ([`gcode_interp::interp::Interp::push_line`]); its moves and machine
//!   commands join the open path on the link, and its `ok` goes out once
//!   they have all been sent within the controller's credit, so a
//!   character-counting sender is held back by the controller's queue as
//!   Grbl holds it back by its planner buffer;
//! - a synchronising line (`G4`, `G10`, `G28.1`, `G30.1`, `G38.x`, `G92`,
//!   `M0`, `M1`, `M2`, `M30`, `M6`, every `$` command that acts) waits until
//!   the motion before it has ended, runs, and is answered once the motion
//!   it made has ended too (Grbl's `protocol_buffer_synchronize`);
//! - the path on the link is ended (the scheduler's lookahead flushed, the
//!   tool brought to rest at its end) before a synchronising line and when
//!   the sender has gone quiet with every line answered: a sender that
//!   stops streaming gets the rest of its motion, as Grbl runs out its
//!   planner buffer.
//!
//! Where ours differs from Grbl's, and why, is said at each place.

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail};
use controller::settings::CMD_CREDIT;
use fuzzy_core::units::{FeedMmPerMin, Point3Mm};
use gcode_interp::interp::{Interp, Modes};
use gcode_interp::machine::{Machine, ProbeMove};
use gcode_interp::sink::Item;
use gcode_interp::toolpath::SpindleDir as InterpSpindle;
use gcode_interp::GcodeSettings;
use link::client::Client;
use link::{AlarmCode, DeviceMsg, HostMsg, MachineStatus, Motion, SpindleDir, Status};

use crate::exit::Failure;
use crate::grbl::codes::{alarm_of, interp_error, ErrorCode, Feedback};
use crate::grbl::command::{self, Command, Jog, Restore, STARTUP_LINES};
use crate::grbl::input::{Event, Line, Realtime, Receiver, RX_BUFFER_SIZE};
use crate::grbl::report::{self, MachineState, Overrides, StatusReporter};
use crate::grbl::settings::{self as grbl_settings, FrontSettings};
use crate::program::machine_cmd;
use crate::stream::{at_rest, Session};

/// Bytes of lines a sender may send beyond the receive buffer before the
/// front stops reading it ([`Front::wants_bytes`]).
pub const RX_BACKLOG_MAX: usize = 64 * 1024;
/// How long after `$H` a machine status saying the controller is not
/// homing is taken as from before the command reached it.
const HOME_SEEN_WITHIN: Duration = Duration::from_secs(1);
/// How often the controller's status is asked for.
const STATUS_PERIOD: Duration = Duration::from_millis(40);
/// How often its machine status (alarm, homing, spindle) is asked for.
const MACHINE_PERIOD: Duration = Duration::from_millis(250);
/// Quiet from the sender, every line answered, after which the open path
/// is ended so that its last points run.
const QUIET_END_PATH: Duration = Duration::from_millis(30);
/// Path commands queued on the host beyond what the controller's credit
/// takes before no further line is read: a line's commands go out, and its
/// `ok` follows, as the controller's queue drains.
const HOST_QUEUE_MAX: u32 = 64;

/// An answer waiting for its turn and its moment.
#[derive(Clone, Debug)]
struct Answer {
    text: String,
    when: Release,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Release {
    /// In order, as soon as the answers before it are out.
    Now,
    /// Once path command `seq` has been transmitted.
    Sent(u32),
    /// Once the controller is at rest with nothing queued.
    AtRest,
}

/// The open path on the link.
#[derive(Clone, Copy, Debug, Default)]
struct PathState {
    open: bool,
    /// Where the next move starts, link bits.
    here: [i64; 3],
    /// After a machine command, the next move repeats `here` first (the
    /// controller starts a new path there).
    restart: bool,
    /// The last path command queued.
    last_seq: Option<u32>,
}

/// What blocks the reading of lines.
#[derive(Clone, Debug, PartialEq)]
enum Pause {
    /// M0/M1 or M6: held until cycle start (`~`).
    Program(String),
}

/// The sender's side of the front while a line blocks it (a probing
/// move): its bytes are read meanwhile and its real-time commands act, as
/// Grbl's serial interrupt reads them during `mc_probe_cycle`; lines wait
/// in the receive buffer.
pub trait SenderIo {
    /// What the sender has sent, without waiting: `Some(0)` for nothing
    /// now, `None` once it has gone.
    fn read_now(&mut self, buf: &mut [u8]) -> Result<Option<usize>, Failure>;
    /// Text to the sender.
    fn write(&mut self, text: &str) -> Result<(), Failure>;
    /// Whether this reaches no sender ([`Detached`]).
    fn is_detached(&self) -> bool {
        false
    }
}

/// No sender side during a blocking line: its bytes and the answers wait
/// for [`Front::poll`]'s caller.
pub struct Detached;

impl SenderIo for Detached {
    fn read_now(&mut self, _: &mut [u8]) -> Result<Option<usize>, Failure> {
        Ok(Some(0))
    }

    fn write(&mut self, _: &str) -> Result<(), Failure> {
        Ok(())
    }

    fn is_detached(&self) -> bool {
        true
    }
}

/// The interpreter's machine: the open path on the link.
struct LinkMachine<'a> {
    front: &'a mut Front,
    io: &'a mut dyn SenderIo,
    /// The interpreter's warnings, for `[MSG:…]` lines.
    warnings: Vec<String>,
    /// A probing move's outcome, for `[PRB:…]` and `$#`.
    probed: Option<report::Probe>,
    /// The alarm that ended a probing move.
    probe_alarm: Option<AlarmCode>,
    /// What the controller said while a probing move ran, for the front.
    seen: Vec<DeviceMsg>,
    /// The link failed while a probing move ran.
    failure: Option<Failure>,
}

fn grid(p: [f64; 3]) -> Option<[i64; 3]> {
    let q = Point3Mm::from_f64(p[0], p[1], p[2]).filter(|q| q.within_limits())?;
    Some(q.to_bits().map(link::batch::to_grid))
}

impl<'a> LinkMachine<'a> {
    fn new(front: &'a mut Front, io: &'a mut dyn SenderIo) -> Self {
        LinkMachine {
            front,
            io,
            warnings: Vec::new(),
            probed: None,
            probe_alarm: None,
            seen: Vec::new(),
            failure: None,
        }
    }

    fn client(&mut self) -> &mut Client {
        self.front.session.conn.client_mut()
    }

    fn open_path(&mut self) {
        let path = self.front.path;
        if !path.open {
            let (f_max, f_min) = (self.front.f_max_bits, self.front.f_min_bits);
            self.client().start_path(f_max, f_min);
            self.client().point(path.here, None);
            self.front.path.open = true;
            self.front.path.restart = false;
        } else if path.restart {
            self.client().point(path.here, None);
            self.front.path.restart = false;
        }
    }

    /// The sender's bytes and the answers while a probing move runs (see
    /// [`SenderIo`]): real-time commands act at once; a soft reset or the
    /// sender going away stops the move ([`Front::interrupted`]).
    fn pump_sender(&mut self) -> Result<(), Failure> {
        if self.io.is_detached() {
            return Ok(());
        }
        let mut buf = [0u8; 512];
        while self.front.wants_bytes() {
            match self.io.read_now(&mut buf)? {
                Some(0) => break,
                Some(n) => self.front.on_bytes(&buf[..n])?,
                None => {
                    self.front.interrupt()?;
                    break;
                }
            }
        }
        let out = self.front.take_output();
        if !out.is_empty() {
            self.io.write(&out)?;
        }
        Ok(())
    }

    /// Run the probing move queued as `seq` (`HostMsg::Probe`) to its
    /// end, polling the link (statuses asked for as [`Front::poll`]
    /// does, so that the controller's link-silence hold, `$209`, does not
    /// take it for a host gone): where it tripped, or `None`. Everything
    /// else received is kept for the front ([`Self::seen`]). Bounded by
    /// the move's time at its feed, with a margin.
    fn await_probe(&mut self, seq: u32, p: &ProbeMove) -> anyhow::Result<Option<[f64; 3]>> {
        let here = self.front.path.here.map(crate::view::bits_f64);
        let dist = (0..3)
            .map(|i| (p.target_mm[i] - here[i]).powi(2))
            .sum::<f64>()
            .sqrt();
        let secs = dist / p.feed_mm_per_min.max(1.0) * 60.0;
        let deadline = Instant::now() + Duration::from_secs_f64(2.0 * secs + 10.0);
        let mut next_status = Instant::now();
        let fail = |f: Failure| anyhow!("G38: {}", f.message);
        loop {
            let now = Instant::now();
            if now > deadline {
                bail!("line {}: G38: no probe report from the controller", p.line);
            }
            if let Err(f) = self.pump_sender() {
                let e = fail(f.clone());
                self.failure = Some(f);
                return Err(e);
            }
            if self.front.interrupted {
                bail!("line {}: G38: stopped by a reset", p.line);
            }
            if now >= next_status {
                let r = self.front.session.send(&HostMsg::StatusQuery);
                if let Err(f) = r {
                    let e = fail(f.clone());
                    self.failure = Some(f);
                    return Err(e);
                }
                next_status = now + STATUS_PERIOD;
            }
            let r = self
                .front
                .session
                .conn
                .transmit()
                .map_err(Failure::from)
                .and_then(|_| self.front.session.recv(Duration::from_millis(5)));
            let m = match r {
                Ok(Some(m)) => m,
                Ok(None) => continue,
                Err(f) => {
                    let e = fail(f.clone());
                    self.failure = Some(f);
                    return Err(e);
                }
            };
            match m {
                DeviceMsg::Probed {
                    seq: s,
                    pos_mm,
                    tripped,
                } if s == seq => {
                    let at = pos_mm.map(crate::view::bits_f64);
                    self.probed = Some(report::Probe {
                        position_mm: at,
                        succeeded: tripped,
                    });
                    return Ok(tripped.then_some(at));
                }
                DeviceMsg::Alarm { code, pos_mm, .. } => {
                    self.seen.push(m);
                    self.probe_alarm = Some(code);
                    if code == AlarmCode::ProbeFailContact {
                        // Grbl reports where the cycle ended (`mc_probe_cycle`
                        // then `report_probe_parameters`).
                        self.probed = Some(report::Probe {
                            position_mm: pos_mm.map(crate::view::bits_f64),
                            succeeded: false,
                        });
                    }
                    bail!(
                        "line {}: G38.{}: {}",
                        p.line,
                        p.kind.minor(),
                        crate::machine::alarm_text(code)
                    );
                }
                DeviceMsg::Status(st) => {
                    // For the status reports answered meanwhile.
                    self.front.status = st;
                    self.seen.push(m);
                }
                DeviceMsg::Machine(ms) => {
                    self.front.machine = ms;
                    self.seen.push(m);
                }
                _ => self.seen.push(m),
            }
        }
    }
}

impl Machine for LinkMachine<'_> {
    fn emit(&mut self, item: Item) -> anyhow::Result<()> {
        match item {
            Item::Point { pos_mm, cap, line } => {
                let bits = grid(pos_mm)
                    .ok_or_else(|| anyhow!("line {line}: a coordinate beyond ±100 m"))?;
                let Some(cap) = cap else {
                    // Where the tool is (the start, or after a probe or a
                    // jog): the next move starts here.
                    self.front.path.here = bits;
                    return Ok(());
                };
                if bits == self.front.path.here || self.front.check {
                    self.front.path.here = bits;
                    return Ok(());
                }
                let cap_bits = FeedMmPerMin::from_f64(cap).0.to_bits();
                if controller::command::point_from_link(0, bits, Some(cap_bits)).is_none() {
                    bail!("line {line}: a feed or coordinate the controller refuses");
                }
                self.open_path();
                self.front.path.last_seq = Some(self.client().point(bits, Some(cap_bits)));
                self.front.path.here = bits;
            }
            Item::Event { line, event } => {
                let cmd = machine_cmd(&event).ok_or_else(|| {
                    anyhow!("line {line}: {event:?}: beyond what the controller takes")
                })?;
                if self.front.check {
                    return Ok(());
                }
                self.open_path();
                self.front.path.last_seq = Some(self.client().machine(cmd));
                self.front.path.restart = true;
            }
            Item::Warning { text, .. } => self.warnings.push(text),
        }
        Ok(())
    }

    /// A probing move (Grbl's `mc_probe_cycle`): the open path ends, the
    /// controller runs the move from rest (`HostMsg::Probe`) and reports
    /// where the probe tripped; this waits for it, polling the link and
    /// serving the sender's real-time bytes meanwhile (status reports,
    /// hold, resume, overrides; a soft reset stops the move), as Grbl
    /// does during `mc_probe_cycle`. Grbl
    /// then syncs its parser to where the tool stopped, past the trip by
    /// the deceleration; here the interpreter takes the trip position, and
    /// the next path starts there (the controller moves the tool back by
    /// the overtravel first), so that `G10 L20 Z0` after a probe sets the
    /// zero where the probe touched. In check mode (`$C`) nothing moves and
    /// the target is taken, as Grbl's `GC_PROBE_CHECK_MODE`.
    fn probe(&mut self, p: &ProbeMove) -> anyhow::Result<Option<[f64; 3]>> {
        let line = p.line;
        let minor = p.kind.minor();
        if self.front.check {
            return Ok(Some(p.target_mm));
        }
        let target = grid(p.target_mm)
            .ok_or_else(|| anyhow!("line {line}: G38.{minor}: a coordinate beyond ±100 m"))?;
        let feed = FeedMmPerMin::from_f64(p.feed_mm_per_min).0.to_bits();
        if controller::probe::probe_from_link(0, target, feed, true, true).is_none() {
            bail!("line {line}: G38.{minor}: a feed or coordinate the controller refuses");
        }
        if self.front.path.open {
            self.client().end_path();
            self.front.path.open = false;
            self.front.path.restart = false;
        }
        let (toward, error) = (p.kind.toward(), p.kind.error_if_not_tripped());
        let seq = self.client().probe(target, feed, toward, error);
        self.front.path.last_seq = Some(seq);
        self.await_probe(seq, p)
    }
}

/// The front of one controller.
pub struct Front {
    session: Session,
    credit_size: u32,
    f_max_bits: i64,
    f_min_bits: i64,
    /// Out of its place only while it runs a line (`gcode`).
    interp: Option<Interp>,
    /// The work offset when the interpreter last ran, for status reports
    /// while it runs.
    wco_mm: [f64; 3],
    /// A soft reset, or the sender gone, while a line blocked: the line
    /// ends and the reset follows.
    interrupted: bool,
    rx: Receiver,
    lines: VecDeque<Line>,
    /// Bytes of the lines waiting (the `Bf:` figure's RX part).
    line_bytes: usize,
    out: String,
    answers: VecDeque<Answer>,
    path: PathState,
    pause: Option<Pause>,
    check: bool,
    /// A feed hold asked for (`!`), until cycle start.
    held: bool,
    jog: bool,
    /// Queued motion was dropped (soft reset, jog cancel): no line runs
    /// until the tool is at rest and its position read back, so the next
    /// move starts where it stopped.
    resync: bool,
    homing: bool,
    /// When `$H` was sent, until the controller reports its homing.
    home_sent: Option<Instant>,
    alarm: Option<AlarmCode>,
    /// The alarm is reported; lines are refused until `$X`, `$H` or a
    /// reset.
    locked: bool,
    status: Status,
    machine: MachineStatus,
    next_status: Instant,
    next_machine: Instant,
    last_input: Instant,
    overrides: Overrides,
    reporter: StatusReporter,
    front: FrontSettings,
    probe: report::Probe,
    /// Grbl's startup lines (`$N0`, `$N1`), run after the welcome.
    startup: [String; STARTUP_LINES as usize],
    /// Where they are kept across restarts: beside the interpreter's
    /// `.var` file (`gcode.var_file`, `--var-file`), if any.
    startup_file: Option<std::path::PathBuf>,
}

impl Front {
    /// A front over a connected, handshaken session.
    pub fn new(
        session: Session,
        status: Status,
        machine: MachineStatus,
        credit_size: u32,
        gcode: GcodeSettings,
        feed_max_mm_per_min: f64,
    ) -> Result<Front, Failure> {
        let gcode_var_file = gcode.var_file.clone();
        let mut interp = Interp::new(Arc::new(gcode), None)
            .map_err(|e| Failure::new(crate::exit::Exit::Input, format!("{e:#}")))?;
        interp.start_live();
        let here = status.pos_mm.map(crate::view::bits_f64);
        interp.set_position_mm(here);
        let f_max_bits = FeedMmPerMin::from_f64(feed_max_mm_per_min).0.to_bits();
        let f_min_bits = FeedMmPerMin::from_f64(controller::settings::F_MIN_MM_PER_MIN as f64)
            .0
            .to_bits();
        let now = Instant::now();
        let alarm = machine.alarm;
        let startup_file = gcode_var_file.map(|p| {
            let mut name = p.into_os_string();
            name.push(".grbl-startup");
            std::path::PathBuf::from(name)
        });
        let startup = startup_file
            .as_deref()
            .map(read_startup_lines)
            .unwrap_or_default();
        Ok(Front {
            session,
            credit_size,
            f_max_bits,
            f_min_bits,
            wco_mm: interp.work_offset_mm(),
            interp: Some(interp),
            interrupted: false,
            rx: Receiver::new(),
            lines: VecDeque::new(),
            line_bytes: 0,
            out: String::new(),
            answers: VecDeque::new(),
            path: PathState {
                here: status.pos_mm.map(link::batch::to_grid),
                ..PathState::default()
            },
            pause: None,
            check: false,
            held: false,
            jog: false,
            resync: false,
            homing: false,
            home_sent: None,
            alarm,
            locked: alarm.is_some(),
            status,
            machine,
            next_status: now,
            next_machine: now,
            last_input: now,
            overrides: Overrides::default(),
            reporter: StatusReporter::new(),
            front: FrontSettings::default(),
            probe: report::Probe::default(),
            startup,
            startup_file,
        })
    }

    fn interp(&mut self) -> &mut Interp {
        self.interp
            .as_mut()
            .expect("the interpreter is out of place only while it runs a line")
    }

    fn interp_ref(&self) -> &Interp {
        self.interp
            .as_ref()
            .expect("the interpreter is out of place only while it runs a line")
    }

    /// A soft reset or the sender gone while a line blocks the front (a
    /// probing move): the motion stops under control now, the reset itself
    /// follows once the line has returned.
    fn interrupt(&mut self) -> Result<(), Failure> {
        if !self.interrupted {
            self.interrupted = true;
            self.cancel_motion()?;
        }
        Ok(())
    }

    /// The controller's last status.
    pub fn controller_status(&self) -> Status {
        self.status
    }

    /// What to write to the sender now.
    pub fn take_output(&mut self) -> String {
        std::mem::take(&mut self.out)
    }

    /// A sender connected: Grbl's welcome (senders wait for it or for a
    /// status report), and the alarm if one holds.
    pub fn connected(&mut self) {
        self.out.push_str(&report::welcome());
        if let Some(code) = self.alarm {
            self.report_alarm(code);
        }
        self.run_startup_lines();
    }

    /// Grbl's `system_execute_startup`: each stored startup line through
    /// the interpreter, answered `>line:ok` or `>line:error:N`; not in the
    /// alarm state.
    fn run_startup_lines(&mut self) {
        if self.locked {
            return;
        }
        for n in 0..self.startup.len() {
            let line = self.startup[n].clone();
            if line.is_empty() {
                continue;
            }
            let answer = match self.run_quietly(&line) {
                Ok(()) => report::ok(),
                Err(e) => report::error(interp_error(&format!("{e:#}")).0),
            };
            self.out.push_str(&format!(">{line}:{answer}"));
        }
    }

    /// One G-code line through the interpreter outside the sender's
    /// stream (a startup line, a restore): its moves join the path as a
    /// line's do; nothing is answered.
    fn run_quietly(&mut self, text: &str) -> anyhow::Result<()> {
        let mut interp = self.interp.take().expect("in place between lines");
        let r = match interp.push_line(text) {
            Ok(true) => {
                let mut io = Detached;
                let mut m = LinkMachine::new(self, &mut io);
                interp.run_with(&mut m).map(|_| ())
            }
            Ok(false) => Err(anyhow!("an O-word structure left open")),
            Err(e) => Err(e),
        };
        self.wco_mm = interp.work_offset_mm();
        self.interp = Some(interp);
        r
    }

    /// `$RST=…` (`settings_restore`): the controller's settings to its
    /// defaults (and the front's), the work offsets and G28/G30 to zero,
    /// or both with the startup lines. The settings are written one at a
    /// time, again while any was refused for a combination not yet
    /// reached (`$31` below `$30`); what is still refused is reported.
    fn restore(&mut self, what: Restore) -> Result<String, Failure> {
        if matches!(what, Restore::Settings | Restore::All) {
            self.front = FrontSettings::default();
            self.reporter.flag_wco();
            let defaults = controller::config::Config::DEFAULT;
            let mut left: Vec<(u16, i64)> = self
                .controller_settings()?
                .into_iter()
                .filter_map(|(id, v)| {
                    let d = defaults.by_id(id).ok()?;
                    (d != v).then_some((id, d))
                })
                .collect();
            let mut last = String::new();
            while !left.is_empty() {
                let before = left.len();
                let mut refused = Vec::new();
                for (id, d) in left {
                    if let Err(e) = self.session.set_setting(id, d, Duration::from_secs(3)) {
                        last = format!("${id}: {}", e.message);
                        refused.push((id, d));
                    }
                }
                left = refused;
                if left.len() == before {
                    return Ok(report::error_with_message(
                        ErrorCode::InvalidStatement,
                        &last,
                    ));
                }
            }
        }
        if matches!(what, Restore::Parameters | Restore::All) {
            let mut lines: Vec<String> = (1..=6).map(|p| format!("G10 L2 P{p} X0 Y0 Z0")).collect();
            lines.push("#5161=0 #5162=0 #5163=0 #5181=0 #5182=0 #5183=0".into());
            for l in lines {
                if let Err(e) = self.run_quietly(&l) {
                    let (code, text) = interp_error(&format!("{e:#}"));
                    return Ok(report::error_with_message(code, &text));
                }
            }
            self.reporter.flag_wco();
        }
        if what == Restore::All {
            for n in 0..self.startup.len() {
                if let Err(e) = self.store_startup_line(n, String::new()) {
                    return Ok(report::error_with_message(ErrorCode::InvalidStatement, &e));
                }
            }
        }
        Ok(report::feedback(Feedback::RestoreDefaults) + &report::ok())
    }

    /// Keep startup line `n` (and write the file, if there is one).
    fn store_startup_line(&mut self, n: usize, line: String) -> Result<(), String> {
        self.startup[n] = line;
        if let Some(path) = &self.startup_file {
            let text: String = self.startup.iter().map(|l| format!("{l}\n")).collect();
            std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))?;
        }
        Ok(())
    }

    /// The sender went away (port closed, process killed): whatever moves
    /// stops under control on the path and the rest is dropped, as a soft
    /// reset would; nothing more is read from it.
    pub fn disconnected(&mut self) -> Result<(), Failure> {
        self.soft_reset(false)
    }

    /// Bytes from the sender.
    pub fn on_bytes(&mut self, bytes: &[u8]) -> Result<(), Failure> {
        let events: Vec<Event> = self.rx.feed(bytes).collect();
        if self.rx.pending() > 0 {
            // Part of a line: more is coming.
            self.last_input = Instant::now();
        }
        for e in events {
            match e {
                Event::Realtime(r) => self.realtime(r)?,
                Event::Line(l) => {
                    // Lines, not real-time bytes (a sender polls `?` all
                    // the time), say the sender is streaming.
                    self.last_input = Instant::now();
                    self.line_bytes += l.raw.len() + 1;
                    self.lines.push_back(l);
                }
            }
        }
        Ok(())
    }

    /// Whether the front takes more bytes now. Past the receive buffer
    /// (`Bf:` reads 0) it still reads, so that real-time bytes behind a
    /// flood of lines act at once, as Grbl's serial interrupt takes them
    /// with its buffer full; the lines wait here (where Grbl would drop
    /// them) up to [`RX_BACKLOG_MAX`], beyond which they wait in the port.
    pub fn wants_bytes(&self) -> bool {
        self.line_bytes + self.rx.pending() < RX_BACKLOG_MAX
    }

    /// Do what can be done now: the link, the lines, the answers. A line
    /// that blocks (a probing move) holds the sender's bytes and the
    /// answers until it ends: [`Front::poll_with`] serves them meanwhile.
    pub fn poll(&mut self) -> Result<(), Failure> {
        self.poll_with(&mut Detached)
    }

    /// [`Front::poll`], with the sender's side served while a line blocks.
    pub fn poll_with(&mut self, io: &mut dyn SenderIo) -> Result<(), Failure> {
        self.link_io()?;
        self.run_lines(io)?;
        self.end_path_when_quiet();
        self.session.conn.transmit().map_err(Failure::from)?;
        self.release_answers();
        Ok(())
    }

    fn link_io(&mut self) -> Result<(), Failure> {
        let now = Instant::now();
        if now >= self.next_status {
            self.session.send(&HostMsg::StatusQuery)?;
            self.next_status = now + STATUS_PERIOD;
        }
        if now >= self.next_machine {
            self.session.send(&HostMsg::MachineQuery)?;
            self.next_machine = now + MACHINE_PERIOD;
        }
        self.session.conn.transmit().map_err(Failure::from)?;
        let mut wait = Duration::from_millis(2);
        for _ in 0..256 {
            let Some(m) = self.session.recv(wait)? else {
                break;
            };
            wait = Duration::ZERO;
            self.on_message(&m);
        }
        Ok(())
    }

    fn on_message(&mut self, m: &DeviceMsg) {
        match *m {
            DeviceMsg::Status(s) => {
                self.status = s;
                if self.resync && self.at_rest_now() {
                    self.resync = false;
                    self.sync_position();
                }
                // A status from before the jog reached the controller is
                // not its end.
                if self.jog
                    && at_rest(&s, self.credit_size)
                    && !self.path.open
                    && s.next_seq == self.queue_end()
                {
                    self.jog = false;
                    self.sync_position();
                }
            }
            DeviceMsg::Machine(ms) => {
                self.machine = ms;
                // A machine status asked before `$H` reached the controller
                // does not end the cycle: until the controller says it homes
                // (or the time for that has passed, a refusal), it does.
                if ms.homing || ms.alarm.is_some() {
                    self.home_sent = None;
                }
                let unseen = self
                    .home_sent
                    .is_some_and(|t| t.elapsed() < HOME_SEEN_WITHIN);
                self.homing = ms.homing || unseen;
                if let Some(code) = ms.alarm {
                    if self.alarm != Some(code) {
                        self.on_alarm(code);
                    }
                } else {
                    self.alarm = None;
                }
            }
            DeviceMsg::Alarm { code, .. } if self.alarm != Some(code) => self.on_alarm(code),
            DeviceMsg::Homed { pos_mm, .. } => {
                self.homing = false;
                self.home_sent = None;
                self.interp()
                    .set_position_mm(pos_mm.map(crate::view::bits_f64));
                self.path.here = pos_mm.map(link::batch::to_grid);
            }
            _ => {}
        }
    }

    /// An alarm: reported once, the path and the lines waiting dropped,
    /// lines refused (`error:9`) until it is cleared (Grbl's
    /// `mc_reset` and `STATE_ALARM`).
    fn on_alarm(&mut self, code: AlarmCode) {
        self.alarm = Some(code);
        self.locked = true;
        // `$X` reads the position back.
        self.resync = false;
        self.report_alarm(code);
        self.path = PathState {
            here: self.status.pos_mm.map(link::batch::to_grid),
            ..PathState::default()
        };
        self.flush_answers();
    }

    fn report_alarm(&mut self, code: AlarmCode) {
        let a = alarm_of(code);
        self.out.push_str(&report::alarm(a.alarm));
        if let Some(m) = a.message {
            self.out.push_str(&report::message(&m));
        }
        self.out.push_str(&report::feedback(Feedback::AlarmLock));
    }

    /// Send every answer waiting, in order (the motion they waited for
    /// was dropped).
    fn flush_answers(&mut self) {
        while let Some(a) = self.answers.pop_front() {
            self.out.push_str(&a.text);
        }
    }

    fn sync_position(&mut self) {
        let here = self.status.pos_mm.map(crate::view::bits_f64);
        self.interp().set_position_mm(here);
        self.path.here = self.status.pos_mm.map(link::batch::to_grid);
    }

    fn realtime(&mut self, r: Realtime) -> Result<(), Failure> {
        match r {
            Realtime::StatusReport | Realtime::StatusReportAll => {
                let s = self.grbl_status();
                let text = if r == Realtime::StatusReportAll {
                    report::status_report_full(&s, self.front.status_mask, self.front.report_inches)
                } else {
                    self.reporter
                        .report(&s, self.front.status_mask, self.front.report_inches)
                };
                self.out.push_str(&text);
            }
            Realtime::FeedHold => {
                if !self.held && self.alarm.is_none() {
                    self.held = true;
                    self.session.send(&HostMsg::Hold)?;
                    if self.jog {
                        // Grbl: a hold during a jog cancels it.
                        self.cancel_motion()?;
                    }
                }
            }
            Realtime::CycleStart => {
                if self.held {
                    self.held = false;
                    self.session.send(&HostMsg::Resume)?;
                }
                if let Some(Pause::Program(_)) = self.pause.take() {
                    self.out.push_str(&report::message("resumed"));
                }
            }
            Realtime::Reset if self.interp.is_none() => self.interrupt()?,
            Realtime::Reset => self.soft_reset(true)?,
            Realtime::JogCancel => {
                if self.jog {
                    self.cancel_motion()?;
                }
            }
            Realtime::SafetyDoor => {
                // No door input: a door request holds the feed, as `!`.
                self.realtime(Realtime::FeedHold)?;
            }
            other => {
                let before = self.overrides;
                if self.overrides.apply(other) {
                    self.reporter.flag_overrides();
                    self.send_overrides(before)?;
                }
            }
        }
        Ok(())
    }

    /// The overrides that differ from `before` to the controller: feed and
    /// spindle act there at once; the rapid override is only reported
    /// (the controller does not tell rapids from feeds).
    fn send_overrides(&mut self, before: Overrides) -> Result<(), Failure> {
        if self.overrides.feed != before.feed {
            let percent = u16::from(self.overrides.feed);
            self.session.send(&HostMsg::Override { percent })?;
        }
        if self.overrides.spindle != before.spindle {
            let percent = u16::from(self.overrides.spindle);
            self.session.send(&HostMsg::SpindleOverride { percent })?;
        }
        Ok(())
    }

    /// Stop what moves under control on the path and drop what is queued
    /// (the controller's abort), keeping the lines and modes.
    fn cancel_motion(&mut self) -> Result<(), Failure> {
        let m = self.session.conn.client_mut().abort();
        self.session.send(&m)?;
        self.path.open = false;
        self.path.restart = false;
        self.held = false;
        self.resync = true;
        Ok(())
    }

    /// Grbl's soft reset (0x18, `mc_reset`): the motion stops under control
    /// on the path, everything queued and waiting is dropped, the modes are
    /// reset (offsets kept), the welcome is sent again. An alarm the
    /// controller holds stays. Grbl also raises `ALARM:3` when it resets
    /// during motion; ours stops under control and keeps its position, so
    /// it does not lock the machine.
    fn soft_reset(&mut self, welcome: bool) -> Result<(), Failure> {
        let moving = !at_rest(&self.status, self.credit_size) || self.path.open;
        if moving || self.session.conn.client().unacked() > 0 {
            self.cancel_motion()?;
        }
        self.lines.clear();
        self.line_bytes = 0;
        self.rx.clear();
        self.answers.clear();
        self.pause = None;
        self.jog = false;
        self.check = false;
        if self.held {
            self.session.send(&HostMsg::Resume)?;
            self.held = false;
        }
        if self.overrides != Overrides::default() {
            let before = std::mem::take(&mut self.overrides);
            self.send_overrides(before)?;
        }
        let here = self.status.pos_mm.map(crate::view::bits_f64);
        self.interp().abort(here);
        self.wco_mm = self.interp_ref().work_offset_mm();
        self.path = PathState {
            here: self.status.pos_mm.map(link::batch::to_grid),
            ..PathState::default()
        };
        if welcome {
            self.out.push_str(&report::welcome());
            if let Some(code) = self.alarm {
                self.report_alarm(code);
            }
            self.run_startup_lines();
        }
        Ok(())
    }

    /// The machine state as Grbl names it.
    fn state(&self) -> MachineState {
        if self.alarm.is_some() || self.status.motion == Motion::Alarm {
            return MachineState::Alarm;
        }
        if self.homing || self.status.motion == Motion::Homing {
            return MachineState::Home;
        }
        if self.check {
            return MachineState::Check;
        }
        let moving = matches!(self.status.motion, Motion::Running | Motion::Starved);
        if self.held || self.status.motion == Motion::Held {
            return MachineState::Hold {
                complete: !moving && self.status.feed_mm_per_min == 0,
            };
        }
        if self.pause.is_some() && !moving && !self.path.open {
            return MachineState::Hold { complete: true };
        }
        if self.jog {
            return MachineState::Jog;
        }
        // A status from before the last commands reached the controller
        // (its next expected sequence number behind ours) is not rest.
        if moving
            || self.path.open
            || !at_rest(&self.status, self.credit_size)
            || self.session.conn.client().unacked() > 0
            || self.status.next_seq != self.queue_end()
        {
            return MachineState::Run;
        }
        MachineState::Idle
    }

    fn grbl_status(&self) -> report::Status {
        let free = self
            .session
            .conn
            .client()
            .window_end()
            .wrapping_sub(self.queue_end()) as i32;
        report::Status {
            state: self.state(),
            mpos_mm: self.status.pos_mm.map(crate::view::bits_f64),
            wco_mm: self
                .interp
                .as_ref()
                .map_or(self.wco_mm, |i| i.work_offset_mm()),
            planner_free: free.clamp(0, u16::MAX as i32) as u16,
            rx_free: RX_BUFFER_SIZE.saturating_sub(self.line_bytes + self.rx.pending()) as u16,
            line: None,
            feed_mm_per_min: crate::view::bits_f64(self.status.feed_mm_per_min),
            // What the spindle runs at, as Grbl's `sys.spindle_speed`.
            spindle_rpm: f64::from(self.machine.speed_rpm) * f64::from(self.overrides.spindle)
                / 100.0,
            pins: report::Pins {
                limits: [
                    self.machine.inputs & 0b0000_0110 != 0,
                    self.machine.inputs & 0b0001_1000 != 0,
                    self.machine.inputs & 0b0110_0000 != 0,
                ],
                reset: self.machine.inputs & 1 != 0,
                probe: self.machine.inputs & controller::probe::PROBE != 0,
                ..report::Pins::default()
            },
            overrides: self.overrides,
            spindle: match self.machine.spindle {
                SpindleDir::Off => report::Spindle::Off,
                SpindleDir::Cw => report::Spindle::Cw,
                SpindleDir::Ccw => report::Spindle::Ccw,
            },
            flood: self.machine.flood,
            mist: self.machine.mist,
        }
    }

    fn queue_end(&self) -> u32 {
        self.session.conn.client().queue_end()
    }

    /// Path commands queued and not yet transmitted (waiting for credit).
    fn host_queue(&self) -> u32 {
        let c = self.session.conn.client();
        (c.queue_end().wrapping_sub(c.send_next()) as i32).max(0) as u32
    }

    fn at_rest_now(&self) -> bool {
        !self.homing
            && !self.path.open
            && self.session.conn.client().unacked() == 0
            && at_rest(&self.status, self.credit_size)
            && self.status.next_seq == self.queue_end()
    }

    fn answer(&mut self, text: String, when: Release) {
        self.answers.push_back(Answer { text, when });
    }

    fn release_answers(&mut self) {
        let sent = self.session.conn.client().send_next();
        let rest = self.at_rest_now();
        while let Some(a) = self.answers.front() {
            let go = match a.when {
                Release::Now => true,
                Release::Sent(seq) => sent.wrapping_sub(seq) as i32 > 0,
                Release::AtRest => rest,
            };
            if !go {
                break;
            }
            if let Some(a) = self.answers.pop_front() {
                self.out.push_str(&a.text);
            }
        }
    }

    /// The sender has gone quiet with every line answered: end the path
    /// so that its last points run. A line whose `ok` waits for the
    /// controller's credit keeps the path open: the sender waits for that
    /// `ok`, it has not stopped streaming.
    fn end_path_when_quiet(&mut self) {
        if self.path.open
            && self.lines.is_empty()
            && self.answers.is_empty()
            && self.rx.pending() == 0
            && self.last_input.elapsed() >= QUIET_END_PATH
        {
            self.end_path();
        }
    }

    fn end_path(&mut self) {
        if self.path.open {
            self.path.last_seq = Some(self.session.conn.client_mut().end_path());
            self.path.open = false;
            self.path.restart = false;
        }
    }

    fn run_lines(&mut self, io: &mut dyn SenderIo) -> Result<(), Failure> {
        while let Some(line) = self.lines.front() {
            if self.pause.is_some() || self.resync || self.host_queue() > HOST_QUEUE_MAX {
                return Ok(());
            }
            // A line waiting for the machine blocks the ones after it.
            if self.answers.iter().any(|a| a.when == Release::AtRest) {
                return Ok(());
            }
            if needs_rest(line) && !self.at_rest_now() {
                self.end_path();
                return Ok(());
            }
            let Some(line) = self.lines.pop_front() else {
                break;
            };
            self.line_bytes = self.line_bytes.saturating_sub(line.raw.len() + 1);
            self.run_line(&line, io)?;
        }
        Ok(())
    }

    fn run_line(&mut self, line: &Line, io: &mut dyn SenderIo) -> Result<(), Failure> {
        if line.overflow {
            self.answer(report::error(ErrorCode::Overflow), Release::Now);
            return Ok(());
        }
        let cmd = match command::parse(&line.text, self.state()) {
            Ok(c) => c,
            Err(e) => {
                self.answer(report::error(e), Release::Now);
                return Ok(());
            }
        };
        match cmd {
            Command::Empty => self.answer(report::ok(), Release::Now),
            Command::Gcode(text) => self.gcode(&text, io)?,
            Command::Help => {
                self.answer(report::help() + &report::ok(), Release::Now);
            }
            Command::Settings => {
                let text = self.settings_listing()?;
                self.answer(text + &report::ok(), Release::Now);
            }
            Command::Parameters => {
                let text = report::parameters(&self.parameters(), self.front.report_inches);
                self.answer(text + &report::ok(), Release::Now);
            }
            Command::ParserState => {
                let text = report::gcode_modes(&self.modal(), self.front.report_inches);
                self.answer(text + &report::ok(), Release::Now);
            }
            Command::BuildInfo => {
                let text = report::version(&build_info()) + &report::options(&self.options());
                self.answer(text + &report::ok(), Release::Now);
            }
            Command::CheckMode => {
                self.check = !self.check;
                let f = if self.check {
                    Feedback::Enabled
                } else {
                    Feedback::Disabled
                };
                if !self.check {
                    // Grbl resets on leaving check mode.
                    self.soft_reset(false)?;
                }
                self.answer(report::feedback(f) + &report::ok(), Release::Now);
            }
            Command::Unlock => {
                if self.alarm.is_some() || self.locked {
                    let ok = self.session.conn.client().alarm().is_some() || self.alarm.is_some();
                    if ok {
                        self.session.send(&HostMsg::Unlock)?;
                    }
                    self.alarm = None;
                    self.locked = false;
                    self.sync_position();
                    self.answer(
                        report::feedback(Feedback::AlarmUnlock) + &report::ok(),
                        Release::Now,
                    );
                } else {
                    self.answer(report::ok(), Release::Now);
                }
            }
            Command::Home { axes } => {
                self.session.send(&HostMsg::Home { axes })?;
                self.homing = true;
                self.home_sent = Some(Instant::now());
                self.alarm = None;
                self.locked = false;
                self.answer(report::ok(), Release::AtRest);
            }
            Command::Jog(j) => self.jog(&j)?,
            Command::SetSetting { id, value } => {
                let text = self.set_setting(id, value)?;
                self.answer(text, Release::Now);
            }
            Command::Restore(what) => {
                let text = self.restore(what)?;
                self.answer(text, Release::Now);
            }
            Command::StartupLines => {
                let mut text: String = self
                    .startup
                    .iter()
                    .enumerate()
                    .map(|(n, l)| format!("$N{n}={l}\r\n"))
                    .collect();
                text.push_str(&report::ok());
                self.answer(text, Release::Now);
            }
            Command::SetStartupLine { n, line } => {
                // Grbl runs the line first and keeps it only if it ran.
                let line = line.trim().to_string();
                let text = match self.run_quietly(&line) {
                    Err(e) => {
                        let (code, text) = interp_error(&format!("{e:#}"));
                        report::error_with_message(code, &text)
                    }
                    Ok(()) => match self.store_startup_line(usize::from(n), line) {
                        Ok(()) => report::ok(),
                        Err(e) => report::error_with_message(ErrorCode::InvalidStatement, &e),
                    },
                };
                self.answer(text, Release::Now);
            }
            Command::Sleep | Command::SetBuildInfo(_) => {
                // Kept by neither the controller nor the front.
                self.answer(
                    report::message("not supported by this controller")
                        + &report::error(ErrorCode::InvalidStatement),
                    Release::Now,
                );
            }
        }
        Ok(())
    }

    fn gcode(&mut self, text: &str, io: &mut dyn SenderIo) -> Result<(), Failure> {
        if self.locked {
            self.answer(report::error(ErrorCode::SystemGcLock), Release::Now);
            return Ok(());
        }
        let ready = match self.interp().push_line(text) {
            Ok(r) => r,
            Err(e) => {
                self.refuse_gcode(&e);
                return Ok(());
            }
        };
        if !ready {
            // Inside an O-word structure: it runs when it closes.
            self.answer(report::ok(), Release::Now);
            return Ok(());
        }
        let mut interp = self.interp.take().expect("in place between lines");
        self.wco_mm = interp.work_offset_mm();
        let before = self.path.last_seq;
        let mut m = LinkMachine::new(self, io);
        let r = interp.run_with(&mut m);
        let warnings = std::mem::take(&mut m.warnings);
        let (probed, probe_alarm) = (m.probed, m.probe_alarm);
        let (seen, failure) = (std::mem::take(&mut m.seen), m.failure.take());
        self.wco_mm = interp.work_offset_mm();
        self.interp = Some(interp);
        let after = self.path.last_seq;
        if let Some(f) = failure {
            return Err(f);
        }
        for msg in &seen {
            self.on_message(msg);
        }
        if std::mem::take(&mut self.interrupted) {
            // The line and everything after it dropped, as Grbl's reset
            // drops them (no answer for it).
            return self.soft_reset(true);
        }
        for w in warnings {
            self.answer(report::message(&w), Release::Now);
        }
        if let Some(p) = probed {
            // Before the line's `ok`, kept for `$#` (Grbl's
            // `report_probe_parameters`).
            self.probe = p;
            let text = report::probe(&p, self.front.report_inches);
            self.answer(text, Release::Now);
        }
        if let Err(e) = r {
            if probe_alarm.is_some() {
                // Grbl: the alarm, then the line's `ok`; the lines after
                // it are refused until `$X`.
                self.answer(report::ok(), Release::Now);
            } else {
                self.refuse_gcode(&e);
            }
            return Ok(());
        }
        let words = words_of(text);
        if let Some(msg) = pause_of(&words, &self.interp_ref().modes()) {
            self.end_path();
            self.pause = Some(Pause::Program(msg.clone()));
            self.answer(report::message(&msg) + &report::ok(), Release::AtRest);
            return Ok(());
        }
        if is_sync(&words) {
            self.end_path();
            let mut ok = report::ok();
            if words.iter().any(|w| w == "M2" || w == "M30") {
                ok = report::feedback(Feedback::ProgramEnd) + &ok;
            }
            self.answer(ok, Release::AtRest);
            return Ok(());
        }
        match after.filter(|_| after != before) {
            Some(seq) => self.answer(report::ok(), Release::Sent(seq)),
            None => self.answer(report::ok(), Release::Now),
        }
        Ok(())
    }

    fn refuse_gcode(&mut self, e: &anyhow::Error) {
        let (code, text) = interp_error(&format!("{e:#}"));
        self.answer(report::error_with_message(code, &text), Release::Now);
    }

    /// `$J=`: one straight move at its own feed (clamped to the machine's
    /// maximum, as Grbl clamps it), from where the tool is, in a path of
    /// its own; the parser's modes are not changed (`jog.c`).
    fn jog(&mut self, j: &Jog) -> Result<(), Failure> {
        if self.locked {
            self.answer(report::error(ErrorCode::SystemGcLock), Release::Now);
            return Ok(());
        }
        let modes = self.interp_ref().modes();
        let inches = j.inches.unwrap_or(modes.inches);
        let incremental = j.incremental.unwrap_or(!modes.absolute);
        let scale = if inches { 25.4 } else { 1.0 };
        let here = self.interp_ref().position_mm();
        let wco = self.interp_ref().work_offset_mm();
        let mut target = here;
        for i in 0..3 {
            if let Some(v) = j.axes[i] {
                let mm = v * scale;
                target[i] = if j.machine {
                    mm
                } else if incremental {
                    here[i] + mm
                } else {
                    mm + wco[i]
                };
            }
        }
        let max = crate::view::bits_f64(self.f_max_bits);
        let feed = j.feed_mm_per_min(modes.inches).min(max);
        let (Some(from), Some(to)) = (grid(here), grid(target)) else {
            self.answer(report::error(ErrorCode::TravelExceeded), Release::Now);
            return Ok(());
        };
        if feed <= 0.0 || !feed.is_finite() {
            self.answer(
                report::error(ErrorCode::GcodeUndefinedFeedRate),
                Release::Now,
            );
            return Ok(());
        }
        if from == to {
            self.answer(report::ok(), Release::Now);
            return Ok(());
        }
        self.end_path();
        let cap = FeedMmPerMin::from_f64(feed).0.to_bits();
        let c = self.session.conn.client_mut();
        c.start_path(cap.max(self.f_min_bits), self.f_min_bits);
        c.point(from, None);
        let seq = c.point(to, Some(cap));
        c.end_path();
        self.path.here = to;
        self.interp().set_position_mm(target);
        self.jog = true;
        self.answer(report::ok(), Release::Sent(seq));
        Ok(())
    }

    fn modal(&self) -> report::Modal {
        let m: Modes = self.interp_ref().modes();
        report::Modal {
            motion: motion_mode(m.motion),
            wcs: m.coord.min(5) as u8,
            plane: (m.plane - 17) as u8,
            inches: m.inches,
            incremental: !m.absolute,
            inverse_time: m.inverse_time,
            program_flow: None,
            spindle: match m.spindle {
                InterpSpindle::Off => report::Spindle::Off,
                InterpSpindle::Cw => report::Spindle::Cw,
                InterpSpindle::Ccw => report::Spindle::Ccw,
            },
            mist: m.mist,
            flood: m.flood,
            tool: m.tool,
            feed_mm_per_min: m.feed * if m.inches { 25.4 } else { 1.0 },
            spindle_rpm: m.rpm,
        }
    }

    fn parameters(&self) -> report::Parameters {
        let p = |base: u32| {
            [
                self.interp_ref().param(base),
                self.interp_ref().param(base + 1),
                self.interp_ref().param(base + 2),
            ]
        };
        let mut wcs = [[0.0; 3]; 6];
        for (k, w) in wcs.iter_mut().enumerate() {
            *w = p(5221 + 20 * k as u32);
        }
        report::Parameters {
            wcs,
            g28: p(5161),
            g30: p(5181),
            g92: p(5211),
            tlo: self.interp_ref().modes().tool_length_mm,
            probe: self.probe,
        }
    }

    fn options(&self) -> report::Options {
        report::Options {
            variable_spindle: true,
            line_numbers: false,
            mist: true,
            homing_single_axis: true,
            no_homing_lock: false,
            safety_door: false,
            planner_blocks: self.credit_size.min(u16::MAX as u32) as u16,
            rx_buffer: RX_BUFFER_SIZE as u16,
        }
    }

    /// The controller's settings by id (read over the link).
    fn controller_settings(&mut self) -> Result<Vec<(u16, i64)>, Failure> {
        Ok(self
            .session
            .settings(Duration::from_secs(2))?
            .into_iter()
            .map(|(info, v)| (info.id, v))
            .collect())
    }

    fn settings_listing(&mut self) -> Result<String, Failure> {
        let values = self.controller_settings()?;
        let get = |id: u16| values.iter().find(|(i, _)| *i == id).map(|(_, v)| *v);
        Ok(grbl_settings::listing(&get, &self.front))
    }

    fn set_setting(&mut self, id: u16, value: f64) -> Result<String, Failure> {
        let values = self.controller_settings()?;
        let get = |id: u16| values.iter().find(|(i, _)| *i == id).map(|(_, v)| *v);
        match grbl_settings::write(id, value, &get, &mut self.front) {
            Ok(grbl_settings::Write::Front { flag_wco }) => {
                if flag_wco {
                    self.reporter.flag_wco();
                }
                Ok(report::ok())
            }
            Ok(grbl_settings::Write::Unchanged) => Ok(report::ok()),
            Ok(grbl_settings::Write::Controller(writes)) => {
                for (id, raw) in writes {
                    if let Err(e) = self.session.set_setting(id, raw, Duration::from_secs(3)) {
                        return Ok(report::error_with_message(
                            ErrorCode::InvalidStatement,
                            &e.message,
                        ));
                    }
                }
                Ok(report::ok())
            }
            Err(r) => Ok(report::error_with_message(r.code, &r.message)),
        }
    }
}

/// The startup lines kept in `path` (a line each; none if it is missing).
fn read_startup_lines(path: &std::path::Path) -> [String; STARTUP_LINES as usize] {
    let mut lines: [String; STARTUP_LINES as usize] = Default::default();
    if let Ok(text) = std::fs::read_to_string(path) {
        for (slot, l) in lines.iter_mut().zip(text.lines()) {
            *slot = l.trim().to_string();
        }
    }
    lines
}

/// Grbl's motion mode of the interpreter's (`None`: G80).
fn motion_mode(code: Option<f64>) -> report::MotionMode {
    use report::MotionMode as M;
    match code {
        Some(0.0) => M::Rapid,
        Some(1.0) => M::Linear,
        Some(2.0) => M::ArcCw,
        Some(3.0) => M::ArcCcw,
        Some(c) if (38.15..38.55).contains(&c) => M::Probe(((c - 38.0) * 10.0).round() as u8),
        _ => M::Cancel,
    }
}

/// The words of a cleaned line (`G4`, `P1`, `M30`), each with its number
/// written short (`G04` → `G4`, `M00` → `M0`); expressions are left whole.
fn words_of(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let b = text.as_bytes();
    let mut i = 0;
    while i < b.len() {
        let c = b[i] as char;
        if c.is_ascii_alphabetic() {
            let mut j = i + 1;
            while j < b.len() && (b[j].is_ascii_digit() || b[j] == b'.') {
                j += 1;
            }
            let num = &text[i + 1..j];
            let short = num
                .parse::<f64>()
                .map_or_else(|_| num.to_string(), |v| format!("{v}"));
            out.push(format!("{}{short}", c.to_ascii_uppercase()));
            i = j.max(i + 1);
        } else {
            i += 1;
        }
    }
    out
}

/// Lines that wait for the motion before them to end (Grbl's
/// `protocol_buffer_synchronize` callers: `G4` (`mc_dwell`), `G10`,
/// `G28.1`/`G30.1` and `$`-commands write settings, `G38.x` probes from
/// rest, `M0`/`M1`/`M2`/`M30` end or pause the program; `G92` here too, as
/// the offset is applied to the position where the motion ends; `M6` as
/// grblHAL's manual tool change).
fn is_sync(words: &[String]) -> bool {
    words.iter().any(|w| {
        matches!(
            w.as_str(),
            "G4" | "G10"
                | "G28.1"
                | "G30.1"
                | "G92"
                | "G92.1"
                | "G38.2"
                | "G38.3"
                | "G38.4"
                | "G38.5"
                | "M0"
                | "M1"
                | "M2"
                | "M30"
                | "M6"
        )
    })
}

fn needs_rest(line: &Line) -> bool {
    if line.text.starts_with('$') {
        // Queries answer from the front's state; the rest act on the
        // machine.
        return !matches!(line.text.as_str(), "$" | "$G" | "$#" | "$I" | "$N")
            && !line.text.starts_with("$J=");
    }
    is_sync(&words_of(&line.text))
}

/// `M0`, `M1` (an optional stop, taken as `M0`: Grbl 1.1 ignores `M1`
/// unless built with it; a sender that sends it wants the stop) and `M6`
/// (grblHAL's manual tool change): the program holds until cycle start.
fn pause_of(words: &[String], modes: &Modes) -> Option<String> {
    if words.iter().any(|w| w == "M6") {
        return Some(format!(
            "Change tool T{}, then cycle start (~) to continue",
            modes.tool
        ));
    }
    if words.iter().any(|w| w == "M0" || w == "M1") {
        return Some("Program paused (M0): cycle start (~) to continue".into());
    }
    None
}

fn build_info() -> report::BuildInfo {
    report::BuildInfo {
        date: env!("CARGO_PKG_VERSION").replace('.', ""),
        firmware: "fuzzy-feed".into(),
        user: String::new(),
    }
}

/// Default credit when the controller did not say.
pub const DEFAULT_CREDIT: u32 = CMD_CREDIT;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn words_are_read_short() {
        assert_eq!(words_of("G04P1"), vec!["G4", "P1"]);
        assert_eq!(words_of("M00"), vec!["M0"]);
        assert!(words_of("G38.2Z-10F100").contains(&"G38.2".to_string()));
        assert!(is_sync(&words_of("G10L20P1Z0")));
        assert!(!is_sync(&words_of("G1X10F100")));
        assert!(is_sync(&words_of("M30")));
    }
}
