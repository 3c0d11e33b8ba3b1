//! The sender's session with a controller over any byte stream
//! (`link::client::Connection`: sequence numbers, credit and go-back-N
//! resends are the link client's): the handshake and settings check, the
//! streaming loop with the operator's actions and the live view, and the
//! decisions that end a run (done, link lost, refused, stopped).

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use controller::alarm::Latch;
use controller::config::{Config, Key, SETTINGS};
use controller::session::DeviceLink;
use controller::settings::{Plan, CMD_CREDIT};
use fuzzy_core::scheduler::SchedulerConfig;
use link::client::{Connection, Hello, SILENCE};
use link::{
    AlarmCode, DeviceMsg, ErrorCode, HostMsg, MachineCmd, MachineStatus, Motion, PlanEvent, Status,
    StoreResult,
};

use crate::actions::{Action, Effect, Operator, StopKind};
use crate::exit::{Exit, Failure};
use crate::program::{cmd_text, Item, Program};
use crate::record::Recorder;
use crate::view::{bits_f64, Eta, View};

/// How a run is paced and checked.
#[derive(Clone, Copy, Debug)]
pub struct Options {
    /// The scheduler's F_max and F_min for the path.
    pub config: SchedulerConfig,
    /// How often to ask for a status while streaming.
    pub status_period: Duration,
    /// Silence from the controller after which the link counts as lost.
    pub link_timeout: Duration,
    /// How long a controlled stop may take to be confirmed.
    pub stop_timeout: Duration,
    /// How long to wait for a hello after connecting (a controller that
    /// just reset sends one; one already running does not).
    pub hello_wait: Duration,
    /// Refuse a controller whose settings differ from the host's.
    pub check_settings: bool,
    /// An override to set before streaming, percent.
    pub initial_override: Option<u16>,
    /// After the run, set the controller's override back to what it was
    /// before [`Options::initial_override`] (a jog runs at its own feed,
    /// as Grbl's jogs ignore the feed override, and leaves the override
    /// of the programs as it found it).
    pub restore_override: bool,
    /// Ask the controller to report every input of its planner (the
    /// scheduled feeds, checked against the host's schedule bit for bit,
    /// and the events; about 23 bytes a point back over the link).
    pub reports: bool,
    /// The most motion to have queued ahead of the tool, in the
    /// controller's time (the program's time at the host-scheduled feeds
    /// and the override in force): what runs on if the host goes away.
    /// Enough for the status polls to see the tool's progress and the
    /// points to follow it; `None`: as much as the credit takes.
    pub ahead: Option<Duration>,
}

impl Options {
    /// Defaults for a path with this scheduler configuration.
    pub fn new(config: SchedulerConfig) -> Self {
        Options {
            config,
            status_period: Duration::from_millis(200),
            link_timeout: Duration::from_secs(5),
            stop_timeout: Duration::from_secs(30),
            hello_wait: Duration::from_millis(500),
            check_settings: true,
            initial_override: None,
            restore_override: false,
            reports: false,
            ahead: Some(AHEAD),
        }
    }
}

/// The default motion queued ahead of the tool ([`Options::ahead`]): five
/// status periods, and the planner's braking distance at the machine's
/// feeds many times over.
pub const AHEAD: Duration = Duration::from_secs(1);

/// Where the run shows itself (a progress bar, a log, nothing).
pub trait Display {
    /// The current view (called often; throttle as needed).
    fn show(&mut self, view: &View);
    /// A message for the operator.
    fn note(&mut self, text: &str);
    /// The run ended: leave what is shown in place.
    fn finish(&mut self) {}
}

/// A display that shows nothing.
pub struct Quiet;

impl Display for Quiet {
    fn show(&mut self, _: &View) {}
    fn note(&mut self, _: &str) {}
}

/// Where operator actions come from (keys, a script, Ctrl-C).
pub trait Actions {
    /// The actions due now, `elapsed` since streaming started, with
    /// `reached` points of the program reached.
    fn poll(&mut self, elapsed: Duration, reached: u32) -> Vec<Action>;
}

/// No actions.
pub struct NoActions;

impl Actions for NoActions {
    fn poll(&mut self, _: Duration, _: u32) -> Vec<Action> {
        Vec::new()
    }
}

impl Actions for crate::actions::Script {
    fn poll(&mut self, elapsed: Duration, reached: u32) -> Vec<Action> {
        self.due(elapsed, reached)
    }
}

/// The settings check of the handshake: the controller's `$` settings are
/// read ([`Handshake::config`]); its hello (sent at reset) must be what
/// the controller crate, as the host was built, derives from them (the
/// tick rate, the feed maximum, the planner's tangential acceleration
/// from the axes' limits and the planner size): then the host's model of
/// it (the schedule checked by `--verify`, the feed maximum of the ETA
/// and the default F_max) is the controller's.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SettingsCheck {
    /// The controller's hello is what its settings give on the host.
    Matched,
    /// No hello came (the controller was already running): its settings
    /// were read, not checked against a hello.
    Unchecked,
    /// They differ (only with the check off; else the handshake fails).
    Differ(Vec<String>),
}

/// What the handshake found.
#[derive(Clone, Debug)]
pub struct Handshake {
    /// The hello, if the controller just reset.
    pub hello: Option<Hello>,
    /// Its status.
    pub status: Status,
    /// Its machine status (alarm, homing, spindle).
    pub machine: MachineStatus,
    /// The settings check.
    pub settings: SettingsCheck,
    /// The controller's `$` settings, as read (`None`: it did not answer
    /// every query; the check then assumes the defaults).
    pub config: Option<Config>,
    /// The settings that differ from the defaults, `$N=value (name, unit)`.
    pub changed: Vec<String>,
    /// The credit of an empty command queue.
    pub credit_size: u32,
}

impl Handshake {
    /// The controller's feed maximum ($201), mm/min: from its settings as
    /// read, else its hello, else the host's default.
    pub fn feed_max_mm_per_min(&self) -> f64 {
        match (&self.config, self.hello) {
            (Some(c), _) => c.get(Key::FeedMax) as f64,
            (None, Some(h)) => h.feed_max_mm_per_min as f64,
            (None, None) => crate::program::machine_feed_max(),
        }
    }
}

/// The hello a controller with the default settings sends (built with the
/// host's `FW_*` settings, no `$` setting changed).
pub fn expected_hello() -> Option<Hello> {
    expected_hello_for(&Config::DEFAULT)
}

/// The hello a controller with the settings `config` sends, as the host's
/// build of the controller crate computes it (`DeviceLink::hello`, the
/// planner built from `config`).
pub fn expected_hello_for(config: &Config) -> Option<Hello> {
    static LATCH: Latch = Latch::new();
    let plan = Box::new(Plan::new(config.motion_config()).ok()?);
    match DeviceLink::new(&LATCH, *config, StoreResult::Empty).hello(&plan) {
        DeviceMsg::Hello {
            tick_hz,
            accel_mm_per_s2,
            feed_max_mm_per_min,
            planner_points,
            ..
        } => Some(Hello {
            tick_hz,
            accel_mm_per_s2,
            feed_max_mm_per_min,
            planner_points,
        }),
        _ => None,
    }
}

/// The settings of `config` that differ from the defaults, as
/// `$N=value (name, unit)`.
pub fn changed_settings(config: &Config) -> Vec<String> {
    SETTINGS
        .iter()
        .zip(config.values().iter().zip(Config::DEFAULT.values()))
        .filter(|(_, (v, d))| v != d)
        .map(|(info, (v, _))| crate::machine::setting_line(info, *v))
        .collect()
}

/// How a controller's hello differs from the one expected, one line each.
pub fn settings_differences(got: &Hello, want: &Hello) -> Vec<String> {
    let mut d = Vec::new();
    let mut cmp = |what: &str, g: u32, w: u32, unit: &str| {
        if g != w {
            d.push(format!("{what}: controller {g} {unit}, host {w} {unit}"));
        }
    };
    cmp("tick rate", got.tick_hz, want.tick_hz, "Hz");
    cmp(
        "planner points",
        got.planner_points as u32,
        want.planner_points as u32,
        "points",
    );
    cmp(
        "feed maximum",
        got.feed_max_mm_per_min,
        want.feed_max_mm_per_min,
        "mm/min",
    );
    cmp(
        "tangential acceleration",
        got.accel_mm_per_s2,
        want.accel_mm_per_s2,
        "mm/s²",
    );
    d
}

/// Path commands the controller holds in its queue (not yet scheduled),
/// from its status and the credit of an empty queue.
pub fn queued(s: &Status, credit_size: u32) -> u32 {
    credit_size.saturating_sub(s.window_end.wrapping_sub(s.next_seq))
}

/// Whether a controller is at rest with nothing to do: idle (the planner
/// done: it keeps the points the tool rests on), nothing in its queue or
/// its scheduler's lookahead.
pub fn at_rest(s: &Status, credit_size: u32) -> bool {
    s.motion == Motion::Idle && s.points_held == 0 && queued(s, credit_size) == 0
}

/// Whether a controller is in the middle of a path.
pub fn busy(s: &Status, credit_size: u32) -> bool {
    !at_rest(s, credit_size)
}

/// Whether the controller is in its alarm state (by its status or its
/// machine status), and the alarm's cause if known.
fn hs_alarm(s: &Status, m: &MachineStatus) -> Option<Option<AlarmCode>> {
    (s.motion == Motion::Alarm || m.alarm.is_some()).then_some(m.alarm)
}

/// What a run did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Summary {
    /// Since streaming started.
    pub elapsed: Duration,
    /// The controller's last status.
    pub last_status: Option<Status>,
    /// Points the controller reported scheduled.
    pub scheduled: u32,
    /// Of those, how many differ from the host's schedule (index or feed
    /// bits).
    pub feed_mismatches: u32,
    /// The first few mismatches: (point index, controller feed, host
    /// feed), mm/min.
    pub mismatch_examples: Vec<(usize, f64, f64)>,
    /// Whether the tool ended exactly on the path's last point.
    pub ended_on_last_point: bool,
    /// The controller's hello was checked against the host's build
    /// ([`SettingsCheck::Matched`]).
    pub build_checked: bool,
    /// Go-backs of the link client during the run.
    pub resends: u32,
    /// The controller's underrun stops during the run (its status counts
    /// them since power-up: the difference from the handshake's).
    pub underruns: u32,
    /// Frames the controller refused during the run (likewise).
    pub bad_frames: u32,
    /// Refusals the controller reported (line noise, credit, sequence).
    pub refusals: u32,
    /// The controller's stop report, when a stop ended the run.
    pub aborted: Option<DeviceMsg>,
    /// The alarm that ended the run: its cause and where the tool stopped.
    pub alarm: Option<(AlarmCode, [i64; 3])>,
    /// Machine commands (spindle, coolant) sent in the path.
    pub machine_sent: u32,
    /// Of those, reported applied by the controller.
    pub machine_applied: u32,
    /// The first few applied at another point count than expected: (the
    /// command's index in the program, the controller's count, the
    /// host's).
    pub machine_off_point: Vec<(usize, u32, u32)>,
}

/// How a run ended.
#[derive(Clone, Debug, PartialEq)]
pub struct Outcome {
    /// The exit code.
    pub exit: Exit,
    /// What to tell the user.
    pub message: String,
    /// What it did.
    pub summary: Summary,
}

/// Points the controller's scheduler holds back for its lookahead before
/// it releases one (its latency, and one more: counted short, the motion
/// queued ahead would be overestimated and streaming could wait for a
/// tool that waits for it).
const SCHEDULER_DELAY_POINTS: usize = controller::settings::Sched::LATENCY + 1;

/// Blocks behind the planner's point that the tool may still be on (the
/// setpoint ring's ticks at full feed over the shortest blocks).
const BLOCKS_BEHIND: usize = 64;

/// What of the program is queued to the link client.
#[derive(Clone, Copy, Debug, Default)]
struct Queued {
    /// The next item to queue.
    next: usize,
    /// Points queued since the last machine command.
    path_points: usize,
    /// The last item whose point the controller can reach with what is
    /// queued.
    released: Option<usize>,
    /// The path's end is queued.
    ended: bool,
}

/// Largest number of messages handled before looking at actions again.
const DRAIN_MAX: usize = 512;
/// A hold, resume or override not reflected by the status this long after
/// it was sent is sent again.
const RESEND_CONTROL: Duration = Duration::from_secs(1);
/// A stop not confirmed this long after it was sent is sent again.
const RESEND_STOP: Duration = Duration::from_secs(2);
/// A finished path whose tool rests off its last point counts as done
/// after this long (with a warning).
const SETTLE: Duration = Duration::from_secs(2);

/// A session with one controller.
pub struct Session {
    pub(crate) conn: Connection,
    rec: Recorder,
    t0: Instant,
    last_rx: Instant,
    raw_hello: Option<DeviceMsg>,
    no_answer_hint: &'static str,
}

impl Session {
    /// Over the two halves of a byte stream.
    pub fn new(writer: Box<dyn Write + Send>, reader: Box<dyn Read + Send>, rec: Recorder) -> Self {
        Session {
            conn: Connection::new(writer, reader),
            rec,
            t0: Instant::now(),
            last_rx: Instant::now(),
            raw_hello: None,
            no_answer_hint:
                "is it powered and running the firmware; are the port and baud rate right?",
        }
    }

    /// What the message for a controller that does not answer suggests
    /// (by the kind of link: `transport::Target::no_answer_hint`).
    pub fn set_no_answer_hint(&mut self, hint: &'static str) {
        self.no_answer_hint = hint;
    }

    /// The link client (sequence numbers, credit).
    pub fn connection(&self) -> &Connection {
        &self.conn
    }

    /// Flush the record; its first write error, if any.
    pub fn finish_record(&mut self) -> std::io::Result<()> {
        self.rec.finish()
    }

    fn t_s(&self) -> f64 {
        self.t0.elapsed().as_secs_f64()
    }

    pub(crate) fn recv(&mut self, timeout: Duration) -> Result<Option<DeviceMsg>, Failure> {
        let m = self.conn.recv(timeout).map_err(|e| {
            Failure::new(
                Exit::LinkLost,
                format!("{e}: the controller or its link went away"),
            )
        })?;
        if let Some(m) = &m {
            self.last_rx = Instant::now();
            let t = self.t_s();
            self.rec.received(t, m);
            if matches!(m, DeviceMsg::Hello { .. }) {
                self.raw_hello = Some(*m);
            }
        }
        Ok(m)
    }

    pub(crate) fn send(&mut self, m: &HostMsg) -> Result<(), Failure> {
        let t = self.t_s();
        if !matches!(m, HostMsg::StatusQuery | HostMsg::MachineQuery) {
            self.rec.sent(t, m);
        }
        self.conn
            .send(m)
            .map_err(|e| Failure::new(Exit::LinkLost, e.to_string()))
    }

    /// A lone delimiter on the wire (`Connection::send_delimiter`).
    pub(crate) fn send_delimiter(&mut self) -> Result<(), Failure> {
        self.conn
            .send_delimiter()
            .map_err(|e| Failure::new(Exit::LinkLost, e.to_string()))
    }

    /// Ask for the status until one comes within `timeout` (every
    /// 500 ms, or at once after a refusal of line noise: the query may
    /// have gone down with it; each query after the first follows a
    /// delimiter); other messages go to `seen`.
    pub fn status_within(
        &mut self,
        timeout: Duration,
        mut seen: impl FnMut(&DeviceMsg),
    ) -> Result<Status, Failure> {
        let deadline = Instant::now() + timeout;
        let mut again = false;
        loop {
            if core::mem::replace(&mut again, true) {
                self.send_delimiter()?;
            }
            self.send(&HostMsg::StatusQuery)?;
            let ask_again = Instant::now() + Duration::from_millis(500);
            while let Some(left) = ask_again.checked_duration_since(Instant::now()) {
                match self.recv(left.min(Duration::from_millis(50)))? {
                    Some(DeviceMsg::Status(s)) => return Ok(s),
                    // The query may have gone down with line noise: ask
                    // again at once.
                    Some(m @ DeviceMsg::Error { code, .. }) if code.is_line_noise() => {
                        seen(&m);
                        break;
                    }
                    Some(m) => seen(&m),
                    None => {}
                }
            }
            if Instant::now() >= deadline {
                return Err(Failure::new(
                    Exit::LinkLost,
                    format!(
                        "no answer from the controller within {:.1} s ({})",
                        timeout.as_secs_f64(),
                        self.no_answer_hint
                    ),
                ));
            }
        }
    }

    /// Send `msg` (again every 500 ms, within `timeout`) until the reply
    /// `pick` takes comes, or a refusal (its code; sequence and credit
    /// refusals are the link client's); other messages go to `seen`.
    pub fn ask<T>(
        &mut self,
        msg: &HostMsg,
        timeout: Duration,
        mut pick: impl FnMut(&DeviceMsg) -> Option<T>,
        mut seen: impl FnMut(&DeviceMsg),
    ) -> Result<Result<T, ErrorCode>, Failure> {
        let deadline = Instant::now() + timeout;
        let mut resend = false;
        loop {
            if core::mem::replace(&mut resend, true) {
                self.send_delimiter()?;
            }
            self.send(msg)?;
            let again = Instant::now() + Duration::from_millis(500);
            while let Some(left) = again.checked_duration_since(Instant::now()) {
                let Some(m) = self.recv(left.min(Duration::from_millis(50)))? else {
                    continue;
                };
                if let Some(t) = pick(&m) {
                    return Ok(Ok(t));
                }
                if let DeviceMsg::Error { code, .. } = m {
                    // Line noise is not this request's refusal (it may
                    // have gone down with it): ask again at once.
                    if code.is_line_noise() {
                        seen(&m);
                        break;
                    }
                    if !matches!(code, ErrorCode::OutOfSequence | ErrorCode::NoCredit) {
                        return Ok(Err(code));
                    }
                }
                seen(&m);
            }
            if Instant::now() >= deadline {
                return Err(Failure::new(
                    Exit::LinkLost,
                    format!(
                        "no answer from the controller within {:.1} s ({})",
                        timeout.as_secs_f64(),
                        self.no_answer_hint
                    ),
                ));
            }
        }
    }

    /// Set the feed override (percent) and wait for the controller's
    /// acknowledgement.
    pub fn set_override(&mut self, percent: u16, timeout: Duration) -> Result<(), Failure> {
        let ack = |m: &DeviceMsg| matches!(m, DeviceMsg::Ack { .. }).then_some(());
        self.ask(&HostMsg::Override { percent }, timeout, ack, |_| {})?
            .map_err(|code| {
                Failure::new(
                    Exit::Controller,
                    format!("the controller refused the override {percent} % ({code:?})"),
                )
            })
    }

    /// The machine status (alarm, homing, spindle, coolant, inputs, the
    /// settings store).
    pub fn machine_within(&mut self, timeout: Duration) -> Result<MachineStatus, Failure> {
        let pick = |m: &DeviceMsg| match *m {
            DeviceMsg::Machine(s) => Some(s),
            _ => None,
        };
        self.ask(&HostMsg::MachineQuery, timeout, pick, |_| {})?
            .map_err(|code| {
                Failure::new(
                    Exit::Controller,
                    format!("the controller refused the machine status query ({code:?})"),
                )
            })
    }

    /// Connect to the controller: its hello if it just reset, its status,
    /// the link client resynchronised to its sequence, its settings
    /// checked against the host's.
    pub fn handshake(&mut self, opts: &Options) -> Result<Handshake, Failure> {
        let deadline = Instant::now() + opts.hello_wait;
        while let Some(left) = deadline.checked_duration_since(Instant::now()) {
            if let Some(DeviceMsg::Hello { .. }) = self.recv(left)? {
                break;
            }
        }
        let status = self.status_within(opts.link_timeout, |_| {})?;
        let machine = self.machine_within(opts.link_timeout)?;
        // A board that resets when its port opens may say hello late.
        let hello = self.conn.client().hello();
        // Whether it just reset or was running: continue its sequence.
        self.conn.client_mut().resync(&status);
        let credit_size = match self.raw_hello {
            Some(DeviceMsg::Hello { window_end, .. }) if hello.is_some() => window_end,
            _ => CMD_CREDIT,
        };
        let config = self.read_config(opts.link_timeout)?;
        let changed = config.as_ref().map_or_else(Vec::new, changed_settings);
        let want = expected_hello_for(config.as_ref().unwrap_or(&Config::DEFAULT));
        let settings = match (hello, want) {
            (Some(h), Some(want)) => {
                let mut d = settings_differences(&h, &want);
                if config.is_none() {
                    d.push("its $ settings could not all be read: the defaults assumed".into());
                }
                if d.is_empty() {
                    SettingsCheck::Matched
                } else if opts.check_settings {
                    return Err(Failure::new(
                        Exit::Controller,
                        format!(
                            "the controller's hello is not what its $ settings give on the host ({}): the firmware and the sender must be built from the same tree with the same FW_* settings, or pass --no-check",
                            d.join("; ")
                        ),
                    ));
                } else {
                    SettingsCheck::Differ(d)
                }
            }
            _ => SettingsCheck::Unchecked,
        };
        Ok(Handshake {
            hello,
            status,
            machine,
            settings,
            config,
            changed,
            credit_size,
        })
    }

    /// Every `$` setting of the controller, if it answers each and they
    /// are valid together (`Config::from_values`); `None` if it refuses a
    /// query (then nothing can be compared).
    fn read_config(&mut self, timeout: Duration) -> Result<Option<Config>, Failure> {
        let mut values = *Config::DEFAULT.values();
        for (v, info) in values.iter_mut().zip(SETTINGS.iter()) {
            let pick = |m: &DeviceMsg| match *m {
                DeviceMsg::Setting { id, value } if id == info.id => Some(value),
                _ => None,
            };
            match self.ask(&HostMsg::GetSetting { id: info.id }, timeout, pick, |_| {})? {
                Ok(x) => *v = x,
                Err(_) => return Ok(None),
            }
        }
        Ok(Config::from_values(values))
    }

    /// A controlled stop of whatever the controller runs: abort, wait for
    /// its report.
    pub fn stop(&mut self, opts: &Options) -> Result<DeviceMsg, Failure> {
        let s = self.status_within(opts.link_timeout, |_| {})?;
        self.conn.client_mut().resync(&s);
        let msg = self.conn.client_mut().abort();
        self.send(&msg)?;
        let deadline = Instant::now() + opts.stop_timeout;
        let mut resend = Instant::now() + RESEND_STOP;
        loop {
            if let Some(a) = self.conn.client().aborted() {
                return Ok(a);
            }
            let now = Instant::now();
            if now > deadline {
                return Err(Failure::new(
                    Exit::LinkLost,
                    "the controller did not confirm the stop",
                ));
            }
            if now > resend {
                self.send(&msg)?;
                resend = now + RESEND_STOP;
            }
            self.recv(Duration::from_millis(50))?;
        }
    }

    /// Stream `program` to the controller after [`Session::handshake`],
    /// until it is done, stopped, refused or the link is lost.
    pub fn run(
        &mut self,
        program: &Program,
        hs: &Handshake,
        opts: &Options,
        actions: &mut dyn Actions,
        display: &mut dyn Display,
    ) -> Outcome {
        let mut run = Run::new(program, hs, opts);
        let resends0 = self.conn.client().resends();
        let mut r = run.go(self, actions, display);
        let before = hs.status.override_percent;
        let changed = opts.initial_override.is_some_and(|p| p != before);
        let lost = matches!(&r, Err(f) if f.exit == Exit::LinkLost);
        if opts.restore_override && changed && !lost {
            if let Err(f) = self.set_override(before, opts.link_timeout) {
                let note = format!(
                    "; the feed override could not be set back to {before} %: {}",
                    f.message
                );
                match &mut r {
                    Ok((_, m)) => m.push_str(&note),
                    Err(e) => e.message.push_str(&note),
                }
            }
        }
        let mut summary = run.summary;
        summary.elapsed = run.t_start.elapsed();
        summary.last_status = self.conn.client().last_status();
        summary.resends = self.conn.client().resends().wrapping_sub(resends0);
        summary.build_checked = hs.settings == SettingsCheck::Matched;
        if let Some(st) = summary.last_status {
            summary.underruns = st.underruns.wrapping_sub(hs.status.underruns);
            summary.bad_frames = st.bad_frames.wrapping_sub(hs.status.bad_frames);
        }
        match r {
            Ok((exit, message)) => Outcome {
                exit,
                message,
                summary,
            },
            Err(f) => Outcome {
                exit: f.exit,
                message: f.message,
                summary,
            },
        }
    }
}

/// The path after a machine command: it starts at the program's point
/// `base` (repeated), its point count is the controller's
/// `point_reached`, which still shows the previous path's count `stale`
/// until the new path begins.
#[derive(Clone, Copy, Debug)]
struct Segment {
    base: usize,
    stale: u32,
    begun: bool,
}

/// The state of one run.
struct Run<'a> {
    program: &'a Program,
    /// What goes between the path's start and end (`Program::items`).
    items: Vec<Item>,
    /// The point count each machine command should take effect at.
    applied_at: Vec<u32>,
    /// The path after the last machine command applied, if one was.
    segment: Option<Segment>,
    opts: &'a Options,
    credit_size: u32,
    /// Host schedule by point index: (index in the path, feed bits).
    host: Vec<Option<(u32, i64)>>,
    eta: Eta,
    operator: Operator,
    status0: Status,
    machine0: MachineStatus,
    stale_reached: u32,
    started: bool,
    end_planned: bool,
    rest_since: Option<Instant>,
    first_point_seq: u32,
    end_seq: u32,
    start_seq: u32,
    t_start: Instant,
    summary: Summary,
    /// A path command of ours was refused for an alarm: when.
    alarm_refused: Option<Instant>,
    /// The machine status was asked for after that.
    machine_asked: bool,
    /// The last status.
    last_status: Status,
    /// The most points of the program reached so far: progress shown
    /// never goes back (a status can come before the report of the
    /// machine command that began its path).
    progress: u32,
    /// The last machine command applied, while the path after it has not
    /// begun (the controller at rest, waiting for it).
    waiting_on: Option<MachineCmd>,
    /// Program time to each point (s at 100 %: `Program::cum_time_s`).
    cum_s: Vec<f64>,
    /// The most of the path done so far: mm, and s of the program.
    progress_along: (f64, f64),
    /// What is queued so far.
    ahead: Queued,
}

impl<'a> Run<'a> {
    fn new(program: &'a Program, hs: &Handshake, opts: &'a Options) -> Self {
        let feed_max = hs.feed_max_mm_per_min();
        let host = program.host_schedule(opts.config);
        let feeds = program.feeds_by_point(&host);
        let cum_s = program.cum_time_s(&feeds, feed_max);
        let eta = Eta::new(cum_s.last().copied().unwrap_or(0.0));
        let items = program.items();
        // The point count each machine command should find its path at:
        // the points since the previous one (none: the same path).
        let mut applied_at = vec![0; program.events.len()];
        let mut n = 0;
        let mut last = 0;
        for it in &items {
            match *it {
                Item::Point { .. } => n += 1,
                Item::Machine { index } => {
                    if n > 0 {
                        last = n;
                    }
                    if let Some(a) = applied_at.get_mut(index) {
                        *a = last;
                    }
                    n = 0;
                }
            }
        }
        Run {
            program,
            items,
            applied_at,
            segment: None,
            opts,
            credit_size: hs.credit_size,
            host,
            eta,
            operator: Operator::new(opts.initial_override.unwrap_or(hs.status.override_percent)),
            status0: hs.status,
            machine0: hs.machine,
            stale_reached: hs.status.point_reached,
            started: hs.status.point_reached == 0,
            end_planned: false,
            rest_since: None,
            first_point_seq: 0,
            end_seq: 0,
            start_seq: 0,
            t_start: Instant::now(),
            summary: Summary::default(),
            alarm_refused: None,
            machine_asked: false,
            last_status: hs.status,
            progress: 0,
            waiting_on: None,
            cum_s,
            progress_along: (0.0, 0.0),
            ahead: Queued::default(),
        }
    }

    /// How an alarm ended the run: its cause, where the tool stopped (and
    /// the program's point and line reached), what to do.
    fn alarm_message(
        &self,
        code: AlarmCode,
        pos_mm: [i64; 3],
        stopping: Option<StopKind>,
    ) -> String {
        let [x, y, z] = pos_mm.map(bits_f64);
        let at = match self.reached(&self.last_status) {
            Some(r) if r > 0 => {
                let i = r as usize - 1;
                match self.program.line_of(i) {
                    Some(l) => format!(
                        " after point {r} of {} (input line {l})",
                        self.program.len()
                    ),
                    None => format!(" after point {r} of {}", self.program.len()),
                }
            }
            _ => String::new(),
        };
        let lead = match stopping {
            Some(StopKind::EStop) => "E-STOP: ",
            _ => "",
        };
        let pos = if crate::machine::position_kept(code) {
            "stopped under control"
        } else {
            "stopped with no deceleration (steps may be lost: re-home or check the position)"
        };
        format!(
            "{lead}ALARM: {}; the tool {pos} at X{x:.3} Y{y:.3} Z{z:.3}{at}; the rest of the program was dropped; {}",
            crate::machine::alarm_text(code),
            crate::machine::UNLOCK_HINT
        )
    }

    /// Points of our program reached, once the controller is on it.
    fn reached(&self, s: &Status) -> Option<u32> {
        if !self.started {
            return None;
        }
        let r = match self.segment {
            None => s.point_reached,
            Some(g) if !g.begun && s.point_reached == g.stale => g.base as u32 + 1,
            Some(g) => (g.base as u32).saturating_add(s.point_reached),
        };
        Some(r.min(self.program.len() as u32))
    }

    /// Whether the controller, at this status, had received every command
    /// of ours up to the path's end, taken them all from its queue, and
    /// passed every point on from its scheduler's lookahead.
    fn consumed(&self, st: &Status) -> bool {
        let after_end = self.end_seq.wrapping_add(1);
        let received = st.next_seq.wrapping_sub(after_end) as i32 >= 0;
        received && queued(st, self.credit_size) == 0 && st.points_held == 0
    }

    /// Where the tool is along the program, from the controller's
    /// position: the path length (mm) and the program's time (s at
    /// 100 %) to it, between points too. The tool is on one of the blocks
    /// just behind the point the planner reached (it runs a few ticks
    /// ahead, which may span many short blocks): the nearest of those
    /// to the position, the latest of equally near ones.
    fn along(&self, st: &Status) -> (f64, f64) {
        let r = match self.reached(st) {
            Some(r) if r > 0 => r as usize,
            _ => return (0.0, 0.0),
        };
        let p = &self.program.points;
        let pos = st.pos_mm.map(bits_f64);
        let mut best: Option<(f64, usize, f64)> = None;
        let last = (r + 1).min(p.len().saturating_sub(1));
        for k in r.saturating_sub(BLOCKS_BEHIND).max(1)..=last {
            let (Some(a), Some(b)) = (p.get(k - 1), p.get(k)) else {
                continue;
            };
            let (a, b) = (a.pos.to_f64(), b.pos.to_f64());
            let ab = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let l2: f64 = ab.iter().map(|x| x * x).sum();
            let ap = [pos[0] - a[0], pos[1] - a[1], pos[2] - a[2]];
            let frac = if l2 > 0.0 {
                ((0..3).map(|i| ap[i] * ab[i]).sum::<f64>() / l2).clamp(0.0, 1.0)
            } else {
                1.0
            };
            let d2: f64 = (0..3).map(|i| (ap[i] - frac * ab[i]).powi(2)).sum();
            if best.is_none_or(|(bd2, _, _)| d2 <= bd2 + 1e-12) {
                best = Some((d2, k, frac));
            }
        }
        let Some((_, k, frac)) = best else {
            return (
                self.program.length_to_mm(r - 1),
                self.cum_s.get(r - 1).copied().unwrap_or(0.0),
            );
        };
        let lerp = |v0: f64, v1: f64| v0 + frac * (v1 - v0);
        let mm = lerp(
            self.program.length_to_mm(k - 1),
            self.program.length_to_mm(k),
        );
        let t0 = self.cum_s.get(k - 1).copied().unwrap_or(0.0);
        let t1 = self.cum_s.get(k).copied().unwrap_or(t0);
        (mm, lerp(t0, t1))
    }

    /// The item with sequence number `seq` and its index.
    fn item(&self, seq: u32) -> Option<(usize, Item)> {
        let k = seq.wrapping_sub(self.first_point_seq) as usize;
        self.items.get(k).map(|i| (k, *i))
    }

    /// The index of the program's point with sequence number `seq`.
    fn point_index(&self, seq: u32) -> Option<usize> {
        match self.item(seq)? {
            (_, Item::Point { index, .. }) => Some(index),
            _ => None,
        }
    }

    fn ours(&self, seq: u32) -> bool {
        seq.wrapping_sub(self.start_seq) <= self.end_seq.wrapping_sub(self.start_seq)
    }

    fn describe_seq(&self, seq: u32) -> String {
        if seq == self.start_seq {
            "the path's start (F_max/F_min)".into()
        } else if seq == self.end_seq {
            "the path's end".into()
        } else if let Some(i) = self.point_index(seq) {
            match self.program.line_of(i) {
                Some(l) => format!("point {} (input line {l})", i + 1),
                None => format!("point {}", i + 1),
            }
        } else if let Some((_, Item::Machine { index })) = self.item(seq) {
            let e = self.program.events.get(index);
            match e {
                Some(e) if e.line > 0 => {
                    format!("{} (input line {})", cmd_text(&e.cmd), e.line)
                }
                Some(e) => cmd_text(&e.cmd),
                None => format!("sequence number {seq}"),
            }
        } else {
            format!("sequence number {seq}")
        }
    }

    fn view(&self, s: &Session, stopping: bool) -> View {
        let c = s.conn.client();
        let st = c.last_status().unwrap_or_default();
        let credit = (c.window_end().wrapping_sub(c.send_next()) as i32).max(0) as u32;
        self.view_of(st, credit, stopping)
    }

    fn view_of(&self, st: Status, credit: u32, stopping: bool) -> View {
        let reached = self.reached(&st).map(|r| r.max(self.progress));
        let r = reached.unwrap_or(0);
        let waiting = match self.waiting_on {
            Some(MachineCmd::Spindle { dir, .. }) if dir != link::SpindleDir::Off => {
                Some("Spin-up")
            }
            Some(MachineCmd::Dwell { .. }) => Some("Dwell"),
            _ => None,
        };
        View {
            status: st,
            queued: queued(&st, self.credit_size),
            credit,
            reached,
            points: self.program.len() as u32,
            done_mm: if r == 0 {
                0.0
            } else {
                self.along(&st).0.max(self.progress_along.0)
            },
            total_mm: self.program.length_mm(),
            eta: reached.map(|_| {
                let done_s = self.along(&st).1.max(self.progress_along.1);
                self.eta.left(done_s, st.override_percent.max(1))
            }),
            elapsed: self.t_start.elapsed(),
            hold_asked: self.operator.hold,
            stopping,
            waiting,
        }
    }

    /// The program's time (s at 100 %, host-scheduled feeds, dwells) to
    /// the point of item `k` (a machine command: to its point).
    fn item_time_s(&self, k: usize) -> f64 {
        let index = match self.items.get(k) {
            Some(Item::Point { index, .. }) => *index,
            Some(Item::Machine { index }) => self.program.events.get(*index).map_or(0, |e| e.after),
            None => return 0.0,
        };
        self.cum_s.get(index).copied().unwrap_or(0.0)
    }

    /// Motion the controller could run on its own with what is queued
    /// (the points its scheduler has released or will release without
    /// more: all before a machine command or the path's end, else all
    /// but its lookahead's latency), beyond where it is now: s of the
    /// program at the override in force.
    fn queued_ahead_s(&self) -> f64 {
        let st = self.last_status;
        let at = match self.reached(&st) {
            Some(r) if r > 0 => self.cum_s.get(r as usize - 1).copied().unwrap_or(0.0),
            _ => 0.0,
        };
        let frontier = self.ahead.released.map_or(0.0, |k| self.item_time_s(k));
        let ovr = st.override_percent.max(1) as f64 / 100.0;
        (frontier - at).max(0.0) / ovr
    }

    /// Queue the next items (and the path's end) while the motion the
    /// controller could run without the host stays within
    /// [`Options::ahead`]: a host that goes away leaves no more than that
    /// to run (the controller's credit bounds the count besides).
    fn queue_ahead(&mut self, s: &mut Session) {
        let limit_s = self.opts.ahead.map_or(f64::INFINITY, |d| d.as_secs_f64());
        while !self.ahead.ended && self.queued_ahead_s() <= limit_s {
            let k = self.ahead.next;
            match self.items.get(k).copied() {
                Some(item) => {
                    self.queue_item(s, item);
                    self.ahead.next += 1;
                    match item {
                        Item::Machine { .. } => {
                            self.ahead.released = Some(k);
                            self.ahead.path_points = 0;
                        }
                        Item::Point { .. } => {
                            self.ahead.path_points += 1;
                            if self.ahead.path_points > SCHEDULER_DELAY_POINTS {
                                self.ahead.released = Some(k - SCHEDULER_DELAY_POINTS);
                            }
                        }
                    }
                }
                None => {
                    self.end_seq = s.conn.client_mut().end_path();
                    self.ahead.released = self.items.len().checked_sub(1);
                    self.ahead.ended = true;
                }
            }
        }
    }

    /// One item to the link client (and the record).
    fn queue_item(&mut self, s: &mut Session, item: Item) {
        match item {
            Item::Point { index, repeat } => {
                let Some(p) = self.program.points.get(index) else {
                    return;
                };
                let bits = p.pos.to_bits();
                // A repeat starts a path: no block leads to it.
                let cap = p.feed_cap.filter(|_| !repeat).map(|f| f.0.to_bits());
                let seq = s.conn.client_mut().point(bits, cap);
                s.rec.point(
                    seq,
                    bits,
                    cap,
                    self.program.lines.get(index).copied().unwrap_or(0),
                );
            }
            Item::Machine { index } => {
                if let Some(e) = self.program.events.get(index) {
                    let seq = s.conn.client_mut().machine(e.cmd);
                    s.rec.machine(seq, &e.cmd, e.line);
                    self.summary.machine_sent += 1;
                }
            }
        }
    }

    fn go(
        &mut self,
        s: &mut Session,
        actions: &mut dyn Actions,
        display: &mut dyn Display,
    ) -> Result<(Exit, String), Failure> {
        let cfg = self.opts.config;
        let (f_max, f_min) = (cfg.f_max.0.to_bits(), cfg.f_min.0.to_bits());
        if let Some(code) = hs_alarm(&self.status0, &self.machine0) {
            return Err(Failure::new(
                Exit::Alarm,
                format!(
                    "the controller is in its alarm state: {}; nothing was sent; {}",
                    code.map_or("(cause not reported)".into(), crate::machine::alarm_text),
                    crate::machine::UNLOCK_HINT
                ),
            ));
        }
        if busy(&self.status0, self.credit_size) {
            let st = &self.status0;
            return Err(Failure::new(
                Exit::Controller,
                format!(
                    "the controller is busy with a path (state {}, {} points planned, {} held, {} commands queued): let it finish, or stop it with `fuzzy-send stop`",
                    crate::view::state_name(st.motion),
                    st.planned_points,
                    st.points_held,
                    queued(st, self.credit_size)
                ),
            ));
        }
        s.send(&HostMsg::Reports {
            planner: self.opts.reports,
        })?;
        if self.opts.initial_override.is_some() {
            s.send(&HostMsg::Override {
                percent: self.operator.override_percent,
            })?;
        }
        let c = s.conn.client_mut();
        self.start_seq = c.start_path(f_max, f_min);
        self.first_point_seq = self.start_seq.wrapping_add(1);
        let t = s.t_s();
        s.rec
            .path(t, self.start_seq, f_max, f_min, self.program.len());
        self.end_seq = self.first_point_seq.wrapping_add(self.items.len() as u32);
        self.queue_ahead(s);
        self.t_start = Instant::now();

        let mut next_status = Instant::now();
        let mut last_acked = s.conn.client().acked();
        let mut ack_progress = Instant::now();
        let mut silence_pending = false;
        let mut stopping: Option<(HostMsg, StopKind, Instant, Instant)> = None;
        let mut control_sent = Instant::now();
        loop {
            let now = Instant::now();
            let elapsed = self.t_start.elapsed();
            // Operator actions.
            let st = s.conn.client().last_status().unwrap_or_default();
            let reached = self.reached(&st).unwrap_or(0);
            for a in actions.poll(elapsed, reached) {
                match self.operator.apply(a) {
                    Effect::Send(m) => {
                        s.send(&m)?;
                        control_sent = Instant::now();
                    }
                    Effect::Stop(kind) => {
                        let m = match kind {
                            StopKind::Stop => s.conn.client_mut().abort(),
                            StopKind::EStop => HostMsg::EStop,
                        };
                        s.send(&m)?;
                        display.note(match kind {
                            StopKind::Stop => "stopping: the motion stops on the path, the rest of the program is dropped",
                            StopKind::EStop => "E-STOP: the step output stops at the next tick, with no deceleration; the drivers are released",
                        });
                        stopping = Some((m, kind, Instant::now(), Instant::now()));
                    }
                    Effect::Leave => {
                        return Ok((
                            Exit::UserStop,
                            "left before the controller confirmed the stop (it stops on its own)"
                                .into(),
                        ))
                    }
                    Effect::None => {}
                }
            }
            if stopping.is_none() {
                self.queue_ahead(s);
                s.conn.transmit().map_err(Failure::from)?;
            }
            // Messages from the controller.
            let mut wait = Duration::from_millis(5);
            for _ in 0..DRAIN_MAX {
                let Some(m) = s.recv(wait)? else { break };
                wait = Duration::ZERO;
                if let Some(done) = self.on_message(&m, stopping.map(|x| x.1))? {
                    return Ok(done);
                }
                if let DeviceMsg::Status(st) = m {
                    if silence_pending {
                        s.conn.client_mut().on_silence(&st);
                        silence_pending = false;
                        ack_progress = Instant::now();
                    }
                    if stopping.is_none() {
                        if let Some(d) = self.check_done(s, &st) {
                            return Ok(d);
                        }
                        self.reconcile(s, &st, &mut control_sent)?;
                    }
                }
            }
            // Refused for an alarm and no report of it: ask for the machine
            // status (it names the alarm).
            if let Some(t) = self.alarm_refused {
                if !self.machine_asked && t.elapsed() > Duration::from_millis(500) {
                    s.send(&HostMsg::MachineQuery)?;
                    self.machine_asked = true;
                }
            }
            // Sent and not acknowledged for a while: resend from where the
            // controller is, after its status.
            let c = s.conn.client();
            if c.acked() != last_acked {
                last_acked = c.acked();
                ack_progress = now;
            }
            let in_flight = c.send_next().wrapping_sub(c.acked()) as i32 > 0;
            if in_flight && ack_progress.elapsed() > SILENCE && !silence_pending {
                silence_pending = true;
                s.send(&HostMsg::StatusQuery)?;
                next_status = Instant::now() + self.opts.status_period;
            }
            if Instant::now() >= next_status {
                s.send(&HostMsg::StatusQuery)?;
                next_status = Instant::now() + self.opts.status_period;
            }
            if s.last_rx.elapsed() > self.opts.link_timeout {
                return Err(Failure::new(
                    Exit::LinkLost,
                    format!(
                        "no answer from the controller for {:.1} s",
                        self.opts.link_timeout.as_secs_f64()
                    ),
                ));
            }
            if let Some((m, _, since, last)) = stopping.as_mut() {
                if since.elapsed() > self.opts.stop_timeout {
                    return Err(Failure::new(
                        Exit::LinkLost,
                        format!(
                            "the controller did not confirm the stop within {:.0} s",
                            self.opts.stop_timeout.as_secs_f64()
                        ),
                    ));
                }
                if last.elapsed() > RESEND_STOP {
                    *last = Instant::now();
                    let m = *m;
                    s.send(&m)?;
                }
            }
            display.show(&self.view(s, stopping.is_some()));
        }
    }

    /// One message; `Some` when it ends the run.
    fn on_message(
        &mut self,
        m: &DeviceMsg,
        stopping: Option<StopKind>,
    ) -> Result<Option<(Exit, String)>, Failure> {
        match *m {
            DeviceMsg::Scheduled {
                seq,
                index,
                feed_mm_per_min,
                ..
            } => {
                if let Some((k, Item::Point { index: i, .. })) = self.item(seq) {
                    self.started = true;
                    self.summary.scheduled += 1;
                    let host = self.host.get(k).copied().flatten();
                    if host != Some((index, feed_mm_per_min)) {
                        self.summary.feed_mismatches += 1;
                        if self.summary.mismatch_examples.len() < 5 {
                            self.summary.mismatch_examples.push((
                                i,
                                bits_f64(feed_mm_per_min),
                                host.map_or(f64::NAN, |h| bits_f64(h.1)),
                            ));
                        }
                    }
                }
            }
            DeviceMsg::Planned {
                event: PlanEvent::EndPath,
                ..
            } if self.started => self.end_planned = true,
            DeviceMsg::Applied {
                seq, point, cmd, ..
            } => {
                if let Some((_, Item::Machine { index })) = self.item(seq) {
                    self.waiting_on = Some(cmd);
                    self.started = true;
                    self.summary.machine_applied += 1;
                    let want = self.applied_at.get(index).copied().unwrap_or(0);
                    if point != want && self.summary.machine_off_point.len() < 5 {
                        self.summary.machine_off_point.push((index, point, want));
                    }
                    let base = self.program.events.get(index).map_or(0, |e| e.after);
                    self.segment = Some(Segment {
                        base,
                        stale: point,
                        begun: false,
                    });
                    // The path's end that counts is the last one's.
                    self.end_planned = false;
                }
            }
            DeviceMsg::Status(st) => {
                self.last_status = st;
                // The new path's count may end where the previous one's did
                // (statuses can miss every count between): a status with
                // every command of ours taken and the lookahead empty also
                // says it began, since the controller takes nothing after a
                // path's first point until that point is in the planner.
                let consumed = self.consumed(&st);
                if let Some(g) = self.segment.as_mut() {
                    if st.point_reached != g.stale || consumed {
                        g.begun = true;
                        self.waiting_on = None;
                    }
                }
                if st.point_reached != self.stale_reached {
                    self.started = true;
                }
                let counts = matches!(st.motion, Motion::Running | Motion::Starved);
                let t = self.t_start.elapsed().as_secs_f64();
                let r = self.reached(&st).unwrap_or(0);
                let (done_mm, done_s) = self.along(&st);
                self.eta.update(t, done_s, st.override_percent, counts);
                self.progress = self.progress.max(r);
                self.progress_along = (
                    self.progress_along.0.max(done_mm),
                    self.progress_along.1.max(done_s),
                );
            }
            DeviceMsg::Error { code, expected_seq } => {
                self.summary.refusals += 1;
                let ours = self.ours(expected_seq) && stopping.is_none();
                if code == ErrorCode::Alarm && ours {
                    // The alarm's report follows (or the machine status
                    // names it, if the report was missed).
                    self.alarm_refused.get_or_insert_with(Instant::now);
                } else if matches!(
                    code,
                    ErrorCode::OutOfRange
                        | ErrorCode::Rejected
                        | ErrorCode::OutOfTravel
                        | ErrorCode::NotHomed
                        | ErrorCode::Busy
                ) && ours
                {
                    let why = match code {
                        ErrorCode::OutOfTravel => {
                            ": outside the machine's travel (soft limits, $20 and $130-$132)"
                        }
                        ErrorCode::NotHomed => {
                            ": homing is required before motion ($22): run `fuzzy-send home`"
                        }
                        ErrorCode::Busy => ": the controller is busy (a homing cycle)",
                        _ => "",
                    };
                    return Err(Failure::new(
                        Exit::Controller,
                        format!(
                            "the controller refused {} ({code:?}){why}",
                            self.describe_seq(expected_seq)
                        ),
                    ));
                }
            }
            DeviceMsg::Alarm { code, pos_mm, .. } => {
                self.summary.alarm = Some((code, pos_mm));
                return Ok(Some((
                    Exit::Alarm,
                    self.alarm_message(code, pos_mm, stopping),
                )));
            }
            DeviceMsg::Machine(ms) if self.alarm_refused.is_some() => {
                if let Some(code) = ms.alarm {
                    let pos = self.last_status.pos_mm;
                    self.summary.alarm = Some((code, pos));
                    return Ok(Some((Exit::Alarm, self.alarm_message(code, pos, stopping))));
                }
            }
            DeviceMsg::Aborted { pos_mm, .. } => {
                self.summary.aborted = Some(*m);
                let [x, y, z] = pos_mm.map(bits_f64);
                let what = format!(
                    "stopped at X{x:.3} Y{y:.3} Z{z:.3}; the rest of the program was dropped"
                );
                return Ok(Some(match stopping {
                    Some(StopKind::Stop) => {
                        (Exit::UserStop, format!("stopped by the user: {what}"))
                    }
                    // An e-stop ends with the alarm's report, not this.
                    Some(StopKind::EStop) => (Exit::UserStop, format!("stopped: {what}")),
                    None => (
                        Exit::Controller,
                        format!("the controller aborted the path: {what}"),
                    ),
                }));
            }
            DeviceMsg::Hello { .. } => {
                return Err(Failure::new(
                    Exit::Controller,
                    "the controller reset during the run (its hello came again): the path is lost",
                ))
            }
            _ => {}
        }
        Ok(None)
    }

    /// Whether the status says the path is done: every command
    /// acknowledged and taken from the queue, the scheduler's lookahead
    /// empty (so every point went to the planner, whose point count is
    /// now this path's), the planner past the last point, the tool at
    /// rest on it; with reports on, the planner also reported the path's
    /// end. (A tool at rest that is not on the last point is accepted
    /// after [`SETTLE`], with a warning in the summary.)
    fn check_done(&mut self, s: &Session, st: &Status) -> Option<(Exit, String)> {
        let c = s.conn.client();
        let last = self.program.points.last().map(|p| p.pos.to_bits());
        let on_last = last == Some(st.pos_mm);
        let drained = c.all_acked() && queued(st, self.credit_size) == 0 && st.points_held == 0;
        if drained {
            self.started = true;
        }
        let rest = drained
            && st.motion == Motion::Idle
            && self.summary.machine_applied as usize >= self.program.events.len()
            && self.reached(st).unwrap_or(0) as usize >= self.program.len()
            && (self.end_planned || !self.opts.reports);
        if !rest {
            self.rest_since = None;
            return None;
        }
        let since = *self.rest_since.get_or_insert_with(Instant::now);
        if !on_last && since.elapsed() < SETTLE {
            return None;
        }
        self.summary.ended_on_last_point = on_last;
        let [x, y, z] = st.pos_mm.map(bits_f64);
        Some((
            Exit::Done,
            format!(
                "done: {} points, {:.1} mm in {:.1} s; ended at X{x:.3} Y{y:.3} Z{z:.3}",
                self.program.len(),
                self.program.length_mm(),
                self.t_start.elapsed().as_secs_f64()
            ),
        ))
    }

    /// Send a hold, resume or override again if the controller's status
    /// does not show it a while after it was sent (a lost frame).
    fn reconcile(
        &mut self,
        s: &mut Session,
        st: &Status,
        sent: &mut Instant,
    ) -> Result<(), Failure> {
        if sent.elapsed() < RESEND_CONTROL {
            return Ok(());
        }
        let o = self.operator;
        let m = if st.override_percent != o.override_percent {
            Some(HostMsg::Override {
                percent: o.override_percent,
            })
        } else if o.hold && st.motion == Motion::Running {
            Some(HostMsg::Hold)
        } else if !o.hold && st.motion == Motion::Held {
            Some(HostMsg::Resume)
        } else {
            None
        };
        if let Some(m) = m {
            s.send(&m)?;
            *sent = Instant::now();
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gcode_interp::GcodeSettings;

    fn program() -> Program {
        crate::program::load("trident", &GcodeSettings::default()).unwrap()
    }

    fn handshake(status: Status) -> Handshake {
        Handshake {
            hello: None,
            status,
            machine: MachineStatus::default(),
            config: None,
            changed: Vec::new(),
            settings: SettingsCheck::Unchecked,
            credit_size: CMD_CREDIT,
        }
    }

    /// A run whose path starts at sequence number 10.
    fn run<'a>(p: &'a Program, o: &'a Options) -> Run<'a> {
        let mut r = Run::new(p, &handshake(Status::default()), o);
        r.start_seq = 10;
        r.first_point_seq = 11;
        r.end_seq = 11 + p.len() as u32;
        r
    }

    #[test]
    fn how_messages_end_a_run() {
        let p = program();
        let o = Options::new(crate::program::scheduler_config(5000.0, 60.0).unwrap());
        let mut r = run(&p, &o);
        let refused = |code, expected_seq| DeviceMsg::Error { code, expected_seq };
        // Line noise and credit refusals are the link client's business.
        for code in [
            ErrorCode::Crc,
            ErrorCode::OutOfSequence,
            ErrorCode::NoCredit,
        ] {
            assert_eq!(r.on_message(&refused(code, 12), None), Ok(None));
        }
        // A refused point of ours ends the run, naming the point.
        let e = r
            .on_message(&refused(ErrorCode::OutOfRange, 12), None)
            .unwrap_err();
        assert_eq!(e.exit, Exit::Controller);
        assert!(e.message.contains("point 2"), "{e}");
        assert!(r
            .on_message(&refused(ErrorCode::Rejected, 10), None)
            .unwrap_err()
            .message
            .contains("start"));
        // Not ours (another path's sequence numbers): not a reason.
        assert_eq!(
            r.on_message(&refused(ErrorCode::OutOfRange, 3), None),
            Ok(None)
        );
        // A stop report: the user's stop, or the controller's own abort.
        let aborted = DeviceMsg::Aborted {
            commands: 1,
            points: 2,
            pos_mm: [1 << 32, 0, 0],
        };
        let (exit, msg) = r
            .on_message(&aborted, Some(StopKind::Stop))
            .unwrap()
            .unwrap();
        assert_eq!(exit, Exit::UserStop);
        assert!(msg.contains("X1.000"), "{msg}");
        let (exit, _) = r.on_message(&aborted, None).unwrap().unwrap();
        assert_eq!(exit, Exit::Controller);
        // An alarm: exit 7, its cause and where the tool stopped.
        let alarm = DeviceMsg::Alarm {
            code: link::AlarmCode::HardLimit { axis: 0, max: true },
            pos_mm: [5 << 32, 0, 0],
            next_seq: 40,
        };
        let (exit, msg) = r.on_message(&alarm, None).unwrap().unwrap();
        assert_eq!(exit, Exit::Alarm);
        assert!(
            msg.contains("X max switch") && msg.contains("X5.000") && msg.contains("unlock"),
            "{msg}"
        );
        // A refusal for the alarm waits for its report.
        let mut r = run(&p, &o);
        assert_eq!(r.on_message(&refused(ErrorCode::Alarm, 12), None), Ok(None));
        assert!(r.alarm_refused.is_some());
        let ms = DeviceMsg::Machine(MachineStatus {
            alarm: Some(link::AlarmCode::EStopInput),
            ..MachineStatus::default()
        });
        let (exit, msg) = r.on_message(&ms, None).unwrap().unwrap();
        assert_eq!(exit, Exit::Alarm);
        assert!(msg.contains("e-stop input"), "{msg}");
        // Homing required, or outside the travel: refused, named.
        let e = r
            .on_message(&refused(ErrorCode::NotHomed, 11), None)
            .unwrap_err();
        assert_eq!(e.exit, Exit::Controller);
        assert!(e.message.contains("fuzzy-send home"), "{e}");
        // A hello during the run: the controller reset.
        let hello = DeviceMsg::Hello {
            tick_hz: 1000,
            accel_mm_per_s2: 1000,
            window_end: 12,
            feed_max_mm_per_min: 5000,
            planner_points: 112,
        };
        assert_eq!(
            r.on_message(&hello, None).unwrap_err().exit,
            Exit::Controller
        );
    }

    #[test]
    fn reported_feeds_are_checked_against_the_hosts_schedule() {
        let p = program();
        let o = Options::new(crate::program::scheduler_config(3000.0, 60.0).unwrap());
        let mut r = run(&p, &o);
        let (index, feed) = r.host[5].unwrap();
        let sched = |feed_mm_per_min| DeviceMsg::Scheduled {
            seq: 16,
            index,
            feed_mm_per_min,
            tick: 0,
        };
        r.on_message(&sched(feed), None).unwrap();
        assert_eq!((r.summary.scheduled, r.summary.feed_mismatches), (1, 0));
        assert!(
            r.started,
            "a report of our point: the controller is on our path"
        );
        r.on_message(&sched(feed + 1), None).unwrap();
        assert_eq!((r.summary.scheduled, r.summary.feed_mismatches), (2, 1));
        assert_eq!(r.summary.mismatch_examples[0].0, 5);
    }

    #[test]
    fn progress_waits_for_the_controller_to_leave_the_previous_path() {
        let p = program();
        let o = Options::new(crate::program::scheduler_config(3000.0, 60.0).unwrap());
        let old = Status {
            point_reached: 138,
            ..Status::default()
        };
        let mut r = Run::new(&p, &handshake(old), &o);
        assert_eq!(r.reached(&old), None, "still the previous path's count");
        r.on_message(&DeviceMsg::Status(old), None).unwrap();
        assert_eq!(r.reached(&old), None);
        let new = Status {
            point_reached: 3,
            ..old
        };
        r.on_message(&DeviceMsg::Status(new), None).unwrap();
        assert_eq!(r.reached(&new), Some(3));
        let fresh = Run::new(&p, &handshake(Status::default()), &o);
        assert_eq!(fresh.reached(&Status::default()), Some(0));
    }

    #[test]
    fn a_path_after_a_machine_command_ending_at_the_previous_count_is_seen_to_begin() {
        let dir = std::env::temp_dir().join(format!("sender-stream-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("dwell.ngc");
        std::fs::write(&f, "G21 G90\nG1 X1 F1000\nG4 P0.1\nG1 X2\n").unwrap();
        let p = crate::program::load(&f.to_string_lossy(), &GcodeSettings::default()).unwrap();
        std::fs::remove_dir_all(&dir).ok();
        let o = Options::new(crate::program::scheduler_config(3000.0, 60.0).unwrap());
        let mut r = run(&p, &o);
        r.end_seq = 11 + r.items.len() as u32;
        // The first path ends at count 2 (start and X1), the dwell applies.
        let applied = DeviceMsg::Applied {
            seq: 13,
            cmd: link::MachineCmd::Dwell { ms: 100 },
            point: 2,
            tick: 0,
        };
        r.on_message(&applied, None).unwrap();
        let waiting = Status {
            point_reached: 2,
            next_seq: r.end_seq + 1,
            window_end: r.end_seq + 1 + CMD_CREDIT - 1,
            points_held: 1,
            ..Status::default()
        };
        r.on_message(&DeviceMsg::Status(waiting), None).unwrap();
        assert_eq!(r.reached(&waiting), Some(2), "the dwell runs");
        assert_eq!(r.view_of(waiting, 0, false).waiting, Some("Dwell"));
        // The second path (X1 again, X2) also ends at count 2.
        let done = Status {
            points_held: 0,
            window_end: r.end_seq + 1 + CMD_CREDIT,
            ..waiting
        };
        r.on_message(&DeviceMsg::Status(done), None).unwrap();
        assert_eq!(r.reached(&done), Some(3));
        assert_eq!(r.view_of(done, 0, false).waiting, None);
    }

    #[test]
    fn progress_and_eta_follow_the_tool_along_a_long_line() {
        let dir = std::env::temp_dir().join(format!("sender-line-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("line.ngc");
        // 100 mm at F600: 10 s.
        std::fs::write(&f, "G21 G90\nG1 X100 F600\n").unwrap();
        let p = crate::program::load(&f.to_string_lossy(), &GcodeSettings::default()).unwrap();
        std::fs::remove_dir_all(&dir).ok();
        let o = Options::new(crate::program::scheduler_config(3000.0, 60.0).unwrap());
        let mut r = run(&p, &o);
        let at = |x: f64| Status {
            point_reached: 1,
            motion: Motion::Running,
            override_percent: 100,
            pos_mm: [(x * 4294967296.0) as i64, 0, 0],
            ..Status::default()
        };
        for (x, left_s) in [(25.0, 7.5), (50.0, 5.0), (90.0, 1.0)] {
            r.on_message(&DeviceMsg::Status(at(x)), None).unwrap();
            let v = r.view_of(at(x), 0, false);
            assert!((v.done_mm - x).abs() < 1e-6, "{x}: {}", v.done_mm);
            let eta = v.eta.unwrap().as_secs_f64();
            assert!((eta - left_s).abs() < 1e-3, "{x}: ETA {eta}");
        }
    }

    #[test]
    fn progress_shown_never_goes_back() {
        let p = program();
        let o = Options::new(crate::program::scheduler_config(3000.0, 60.0).unwrap());
        let mut r = run(&p, &o);
        let at = |point_reached| Status {
            point_reached,
            motion: Motion::Running,
            ..Status::default()
        };
        r.on_message(&DeviceMsg::Status(at(50)), None).unwrap();
        let v = r.view_of(at(50), 0, false);
        assert_eq!(v.reached, Some(50));
        r.on_message(&DeviceMsg::Status(at(48)), None).unwrap();
        let w = r.view_of(at(48), 0, false);
        assert_eq!(w.reached, Some(50));
        assert_eq!(w.done_mm, v.done_mm);
    }

    #[test]
    fn the_expected_hello_is_the_controllers_own() {
        let h = expected_hello().unwrap();
        assert_eq!(h.tick_hz, controller::settings::TICK_HZ);
        assert_eq!(
            h.planner_points as usize,
            controller::settings::PLANNER_POINTS
        );
        assert_eq!(
            h.feed_max_mm_per_min,
            controller::settings::FEED_MAX_MM_PER_MIN
        );
        assert!(settings_differences(&h, &h).is_empty());
        let other = Hello {
            tick_hz: 2000,
            planner_points: 64,
            ..h
        };
        let d = settings_differences(&other, &h);
        assert_eq!(d.len(), 2, "{d:?}");
        assert!(d[0].contains("tick rate: controller 2000 Hz"), "{d:?}");
    }

    #[test]
    fn queue_and_busy_come_from_the_status() {
        let idle = Status {
            next_seq: 100,
            window_end: 112,
            ..Status::default()
        };
        assert_eq!(queued(&idle, 12), 0);
        assert!(!busy(&idle, 12));
        let resting = Status {
            planned_points: 2,
            ..idle
        };
        assert!(!busy(&resting, 12), "the points the tool rests on");
        assert!(busy(
            &Status {
                motion: Motion::Starved,
                ..idle
            },
            12
        ));
        let q = Status {
            window_end: 105,
            ..idle
        };
        assert_eq!(queued(&q, 12), 7);
        assert!(busy(&q, 12));
        let held = Status {
            points_held: 3,
            ..idle
        };
        assert!(busy(&held, 12));
        let wrap = Status {
            next_seq: u32::MAX - 1,
            window_end: 10,
            ..idle
        };
        assert_eq!(queued(&wrap, 12), 0);
    }
}
