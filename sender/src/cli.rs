//! The command line: `send`, `jog`, `status`, `monitor`, `stop`, `estop`,
//! `unlock`, `home`, `settings`, each over the link chosen by `--port`/`--tcp`/`--unix`/`--sim`.

use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::time::{Duration, Instant};

use clap::{Args, Parser, Subcommand};
use gcode_interp::GcodeSettings;
use link::Status;

use crate::actions::Script;
use crate::display::{BarDisplay, LogDisplay};
use crate::exit::{Exit, Failure};
use crate::machine;
use crate::program;
use crate::record::Recorder;
use crate::stream::{self, Display, Handshake, Options, Outcome, Session, SettingsCheck};
use crate::terminal::{Inputs, Interrupts, Keys};
use crate::transport::{self, Target, DEFAULT_BAUD};
use crate::view::{bits_f64, state_name, View};

/// Keys while a program runs (shown at the start and in `--help`).
pub const KEYS_HELP: &str = "keys: space hold/resume, + / - override ±10 % (10-200 %), Esc or Ctrl-C controlled stop, ! e-stop (alarm: no deceleration, `fuzzy-send unlock` after)";

/// Run a program on a motion board running the fuzzy firmware (or on the
/// firmware in QEMU, or on the controller simulated on the host).
#[derive(Parser, Debug)]
#[command(name = "fuzzy-send", version, after_help = AFTER_HELP)]
pub struct Cli {
    /// Where the controller is.
    #[command(flatten)]
    pub link: LinkArgs,
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

const AFTER_HELP: &str = "\
Keys while a program runs (when stdin is a terminal):
  space      feed hold / resume
  + / -      feed override ±10 % (10-200 %)
  Esc, Ctrl-C  controlled stop: the motion stops on the path, the rest is dropped
  !          e-stop: the controller's alarm state (the step output stops at the
             next tick with no deceleration, drivers released); `unlock` after
Without a terminal the run is unattended: a status line a second on stderr,
Ctrl-C stops under control.

Exit codes: 0 done, 2 bad command line or script, 3 refused input (nothing
sent), 4 link lost, 5 refused by the controller (settings, busy, a refused
command), 6 stopped by the user, 7 alarm (e-stop, limit, homing failure,
link loss: `unlock`), 1 other errors.";

/// The link to the controller (exactly one of `--port`, `--tcp`,
/// `--unix`, `--sim`).
#[derive(Args, Debug, Clone)]
pub struct LinkArgs {
    /// Serial port of the board (/dev/ttyACM0, /dev/ttyUSB0, COM3).
    #[arg(long, global = true)]
    pub port: Option<String>,
    /// TCP address (the QEMU firmware's `cargo run`: 127.0.0.1:7878).
    #[arg(long, global = true)]
    pub tcp: Option<String>,
    /// Unix socket (QEMU's `-serial unix:PATH,server=on`).
    #[arg(long, global = true)]
    pub unix: Option<PathBuf>,
    /// The controller simulated on the host (the firmware's code, no
    /// board), at this many times real time (`--sim` or `--sim=SPEED`).
    #[arg(long, global = true, num_args = 0..=1, require_equals = true, default_missing_value = "1", value_name = "SPEED")]
    pub sim: Option<f64>,
    /// With `--sim`: the simulated probe touches the plane z = Z (machine
    /// coordinates, mm), so that G38.2-.5 have something to find; `Z,SX,SY`
    /// tilts it: z = Z + SX·x + SY·y (slopes in mm/mm), a stock to
    /// auto-level against.
    #[arg(
        long,
        global = true,
        value_name = "Z[,SX,SY]",
        allow_hyphen_values = true
    )]
    pub sim_probe_z: Option<String>,
    /// Baud rate of the serial port.
    #[arg(long, global = true, default_value_t = DEFAULT_BAUD)]
    pub baud: u32,
    /// Silence after which the link counts as lost, s.
    #[arg(long, global = true, default_value_t = 5.0, value_name = "S")]
    pub link_timeout: f64,
}

/// `Z` or `Z,SX,SY`: the simulated probe plane's height at the origin
/// and its slopes along x and y.
fn probe_plane(text: &str) -> Option<[f64; 3]> {
    let v: Vec<f64> = text
        .split(',')
        .map(|t| t.trim().parse::<f64>().ok().filter(|v| v.is_finite()))
        .collect::<Option<_>>()?;
    match v[..] {
        [z] => Some([z, 0.0, 0.0]),
        [z, sx, sy] if sx.abs() <= 1.0 && sy.abs() <= 1.0 => Some([z, sx, sy]),
        _ => None,
    }
}

impl LinkArgs {
    /// The target.
    pub fn target(&self) -> Result<Target, Failure> {
        let given = self.port.is_some() as u8
            + self.tcp.is_some() as u8
            + self.unix.is_some() as u8
            + self.sim.is_some() as u8;
        if given > 1 {
            return Err(Failure::new(
                Exit::Usage,
                "give one link: --port, --tcp, --unix or --sim",
            ));
        }
        if self.sim_probe_z.is_some() && self.sim.is_none() {
            return Err(Failure::new(Exit::Usage, "--sim-probe-z needs --sim"));
        }
        if let Some(p) = &self.port {
            return Ok(Target::Serial {
                port: p.clone(),
                baud: self.baud,
            });
        }
        if let Some(a) = &self.tcp {
            return Ok(Target::Tcp(a.clone()));
        }
        if let Some(u) = &self.unix {
            return Ok(Target::Unix(u.clone()));
        }
        if let Some(s) = self.sim {
            let probe = match &self.sim_probe_z {
                Some(text) => Some(probe_plane(text).ok_or_else(|| {
                    Failure::new(
                        Exit::Usage,
                        format!("--sim-probe-z {text}: give Z or Z,SX,SY (mm, mm/mm)"),
                    )
                })?),
                None => None,
            };
            return Ok(Target::Sim {
                speed: s,
                probe_mm: probe,
            });
        }
        Err(Failure::new(
            Exit::Usage,
            "no link: give --port, --tcp, --unix or --sim",
        ))
    }

    fn link_timeout(&self) -> Result<Duration, Failure> {
        if self.link_timeout.is_finite() && (0.5..=3600.0).contains(&self.link_timeout) {
            Ok(Duration::from_secs_f64(self.link_timeout))
        } else {
            Err(Failure::new(
                Exit::Usage,
                "--link-timeout must be within 0.5-3600 s",
            ))
        }
    }
}

/// The commands.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Send a program and watch it run.
    Send(SendArgs),
    /// Speak Grbl 1.1 to the senders CNC users run (cncjs, bCNC, Universal
    /// G-Code Sender, gSender, Candle) on a pseudo-terminal and/or a TCP
    /// port, driving the controller: G-code interpreted live, real-time
    /// commands, `$` settings, status reports. Until Ctrl-C.
    Serve(ServeArgs),
    /// Jog (Grbl's `$J=`): one straight move from where the tool is, given
    /// as G-code words, relative unless `G90`: `jog X10 Y-2.5 F1000`,
    /// `jog G90 Z5 F300`. Watched as `send`; Ctrl-C or Esc cancels it
    /// with a controlled stop on the path.
    Jog(JogArgs),
    /// Print the controller's status once.
    Status {
        /// As JSON (`link::Status`).
        #[arg(long)]
        json: bool,
    },
    /// Print a status line every period until Ctrl-C.
    Monitor {
        /// Between lines, s.
        #[arg(long, default_value_t = 1.0, value_name = "S")]
        period: f64,
    },
    /// Controlled stop of whatever the controller runs (abort: the motion
    /// stops on the path, everything queued is dropped).
    Stop,
    /// Emergency stop (the alarm state: the step output stops at the next
    /// tick with no deceleration, the drivers are released, everything
    /// queued is dropped) until `unlock`.
    Estop,
    /// Leave the alarm state (Grbl's `$X`); refused while the e-stop input
    /// is active.
    Unlock,
    /// Run the homing cycle (Grbl's `$H`; needs `$22=1`) and wait for its
    /// end.
    Home {
        /// Axes to home (e.g. `Z`, `XY`); default: the configured passes
        /// (`$44`-`$46`).
        #[arg(long, value_name = "AXES")]
        axes: Option<String>,
        /// Longest the cycle may take, s (then it is aborted).
        #[arg(long, default_value_t = 120.0, value_name = "S")]
        timeout: f64,
    },
    /// The `$` settings: list them all (as Grbl's `$$`), read or write one.
    Settings {
        /// What (default: list).
        #[command(subcommand)]
        action: Option<SettingsAction>,
    },
}

/// `settings`.
#[derive(Subcommand, Debug)]
pub enum SettingsAction {
    /// Every setting as `$N=value (name, unit)`.
    List,
    /// One setting.
    Get {
        /// `N` or `$N`.
        id: String,
    },
    /// Write one (at rest or in an alarm only); the controller checks it
    /// (out of range: nothing changes) and stores it in flash.
    Set {
        /// `N` or `$N`.
        id: String,
        /// In the setting's unit (`80.5` steps/mm; decimals as listed).
        value: String,
    },
}

/// `serve`.
#[derive(Args, Debug)]
pub struct ServeArgs {
    /// A symlink to the pseudo-terminal, for the sender's port list
    /// (e.g. /tmp/ttyFUZZY; replaced if it is a symlink already).
    #[arg(long, value_name = "PATH")]
    pub pty_link: Option<PathBuf>,
    /// No pseudo-terminal (TCP only).
    #[arg(long)]
    pub no_pty: bool,
    /// Also listen for a sender on this TCP port of 127.0.0.1 (bCNC, UGS
    /// and gSender connect over TCP too).
    #[arg(long, value_name = "PORT")]
    pub grbl_tcp: Option<u16>,
    /// A TOML file whose `[gcode]` table sets how G-code is read.
    #[arg(long, value_name = "TOML")]
    pub config: Option<PathBuf>,
    /// Work offsets, G28/G30 and G92 kept across restarts in this file
    /// (LinuxCNC's `.var` format); overrides `gcode.var_file`.
    #[arg(long, value_name = "PATH")]
    pub var_file: Option<PathBuf>,
}

/// `send`.
#[derive(Args, Debug)]
pub struct SendArgs {
    /// G-code (.nc .ngc .gcode .tap .cnc .g), CSV (x,y,z[,feed]) or a
    /// built-in shape (infinity, trident, butterfly).
    pub file: String,
    /// Largest scheduled feed, mm/min (default: the controller's feed
    /// maximum).
    #[arg(long, value_name = "MM_PER_MIN")]
    pub f_max: Option<f64>,
    /// Smallest scheduled feed, mm/min.
    #[arg(long, value_name = "MM_PER_MIN", default_value_t = controller::settings::F_MIN_MM_PER_MIN as f64)]
    pub f_min: f64,
    /// Feed override to start with, percent (10-200; default: the
    /// controller's).
    #[arg(long = "override", value_name = "PERCENT", value_parser = clap::value_parser!(u16).range(10..=200))]
    pub override_percent: Option<u16>,
    /// Timed actions (`at 2.0 s: hold`, `after 1 s: resume`, `at point
    /// 500: override 50`, `at 5 s: stop`), one a line; `-` reads stdin.
    #[arg(long, value_name = "FILE")]
    pub script: Option<PathBuf>,
    /// Write what was sent and every message from the controller to this
    /// file (JSON lines).
    #[arg(long, value_name = "FILE")]
    pub record: Option<PathBuf>,
    /// Send even if the controller's settings differ from the host's.
    #[arg(long)]
    pub no_check: bool,
    /// Have the controller report every feed it schedules (and its
    /// planner's events) and check each against the host's schedule bit
    /// for bit; costs about 23 bytes a point of the link's return channel.
    #[arg(long)]
    pub verify: bool,
    /// A TOML file whose `[gcode]` table sets how the file is read (chord
    /// tolerance of arcs, rapid feed, offsets, tools; host-sim's
    /// configuration files have the same table; other tables are ignored).
    #[arg(long, value_name = "TOML")]
    pub config: Option<PathBuf>,
    /// Status lines instead of a progress bar, even on a terminal.
    #[arg(long)]
    pub log: bool,
}

/// `jog`.
#[derive(Args, Debug)]
pub struct JogArgs {
    /// The move: axis words (X, Y, Z), the feed F (required), and G90
    /// (machine coordinates) or G91 (relative, the default), G20 (inches)
    /// or G21 (mm, the default).
    // A word starts with its letter (`X-10`), never with `-`: options,
    // the link's included, may come before, between or after the words.
    #[arg(required = true, value_name = "WORD")]
    pub words: Vec<String>,
    /// Send even if the controller's settings differ from the host's.
    #[arg(long)]
    pub no_check: bool,
    /// Status lines instead of a progress bar, even on a terminal.
    #[arg(long)]
    pub log: bool,
}

fn say(text: &str) {
    eprintln!("fuzzy-send: {text}");
}

/// Run a parsed command line; the exit code.
pub fn run(cli: Cli) -> Exit {
    match dispatch(cli) {
        Ok(e) => e,
        Err(f) => {
            say(&f.message);
            f.exit
        }
    }
}

fn dispatch(cli: Cli) -> Result<Exit, Failure> {
    let target = cli.link.target()?;
    let link_timeout = cli.link.link_timeout()?;
    match cli.command {
        Command::Send(a) => send(a, &target, link_timeout),
        Command::Serve(a) => serve(a, &target, link_timeout),
        Command::Jog(a) => jog(a, &target, link_timeout),
        Command::Status { json } => status(&target, link_timeout, json),
        Command::Monitor { period } => monitor(&target, link_timeout, period),
        Command::Stop => stop(&target, link_timeout),
        Command::Estop => estop(&target, link_timeout),
        Command::Unlock => unlock(&target, link_timeout),
        Command::Home { axes, timeout } => home(&target, link_timeout, axes.as_deref(), timeout),
        Command::Settings { action } => settings(
            &target,
            link_timeout,
            action.unwrap_or(SettingsAction::List),
        ),
    }
}

/// An axis mask from letters (`XZ`); empty: 0 (the configured passes).
pub fn parse_axes(s: &str) -> Result<u8, Failure> {
    let mut m = 0;
    for c in s.chars() {
        m |= match c.to_ascii_uppercase() {
            'X' => 1,
            'Y' => 2,
            'Z' => 4,
            ',' | ' ' => 0,
            _ => {
                return Err(Failure::new(
                    Exit::Usage,
                    format!("--axes {s:?}: letters X, Y, Z"),
                ))
            }
        };
    }
    Ok(m)
}

fn estop(target: &Target, link_timeout: Duration) -> Result<Exit, Failure> {
    let (mut s, _sim) = connect(target, Recorder::none())?;
    let pick = |m: &link::DeviceMsg| match *m {
        link::DeviceMsg::Alarm { code, pos_mm, .. } => Some((code, pos_mm)),
        _ => None,
    };
    // Acknowledged at once; the alarm's report follows when the
    // controller has carried it out (none if it already was in alarm).
    let mut alarm = None;
    s.ask(
        &link::HostMsg::EStop,
        link_timeout,
        |m| match m {
            link::DeviceMsg::Ack { .. } => Some(()),
            _ => None,
        },
        |m| {
            if let Some(a) = pick(m) {
                alarm = Some(a);
            }
        },
    )?
    .map_err(|c| {
        Failure::new(
            Exit::Controller,
            format!("the controller refused the e-stop ({c:?})"),
        )
    })?;
    let ms = s.machine_within(link_timeout)?;
    let st = s.status_within(link_timeout, |m| {
        if let Some(a) = pick(m) {
            alarm = Some(a);
        }
    })?;
    let code = alarm.map(|a| a.0).or(ms.alarm);
    let [x, y, z] = alarm.map_or(st.pos_mm, |a| a.1).map(bits_f64);
    say(&format!(
        "ALARM: {}; the tool is at X{x:.3} Y{y:.3} Z{z:.3}; {}",
        code.map_or("(not reported)".into(), machine::alarm_text),
        machine::UNLOCK_HINT
    ));
    Ok(Exit::Alarm)
}

fn unlock(target: &Target, link_timeout: Duration) -> Result<Exit, Failure> {
    let (mut s, _sim) = connect(target, Recorder::none())?;
    let before = s.machine_within(link_timeout)?;
    let after = s.unlock(link_timeout)?;
    let st = s.status_within(link_timeout, |_| {})?;
    let [x, y, z] = st.pos_mm.map(bits_f64);
    match before.alarm {
        Some(code) => say(&format!(
            "unlocked ({} cleared): {} at X{x:.3} Y{y:.3} Z{z:.3}{}",
            machine::alarm_text(code),
            state_name(st.motion),
            if machine::position_kept(code) {
                ""
            } else {
                "; the position may be off after a stop with no deceleration: home, or check it"
            }
        )),
        None => say(&format!(
            "not in alarm: nothing to unlock ({} at X{x:.3} Y{y:.3} Z{z:.3})",
            state_name(st.motion)
        )),
    }
    if after.homed == 0 && before.alarm.is_some() {
        say("no axis is homed");
    }
    Ok(Exit::Done)
}

fn home(
    target: &Target,
    link_timeout: Duration,
    axes: Option<&str>,
    timeout: f64,
) -> Result<Exit, Failure> {
    let axes = parse_axes(axes.unwrap_or(""))?;
    if !(timeout.is_finite() && (1.0..=3600.0).contains(&timeout)) {
        return Err(Failure::new(
            Exit::Usage,
            "--timeout must be within 1-3600 s",
        ));
    }
    let (mut s, _sim) = connect(target, Recorder::none())?;
    say(&format!(
        "homing {} (timeout {timeout:.0} s)",
        if axes == 0 {
            "the configured passes".to_string()
        } else {
            machine::axes_text(axes)
        }
    ));
    match s.home(axes, link_timeout, Duration::from_secs_f64(timeout))? {
        machine::HomeResult::Homed { axes, pos_mm } => {
            let [x, y, z] = pos_mm.map(bits_f64);
            say(&format!(
                "homed {}: the tool rests at X{x:.3} Y{y:.3} Z{z:.3} (machine coordinates)",
                machine::axes_text(axes)
            ));
            Ok(Exit::Done)
        }
        machine::HomeResult::Alarm { code, pos_mm } => {
            let [x, y, z] = pos_mm.map(bits_f64);
            Err(Failure::new(
                Exit::Alarm,
                format!(
                    "ALARM: {}; the tool stopped at X{x:.3} Y{y:.3} Z{z:.3}; {}",
                    machine::alarm_text(code),
                    machine::UNLOCK_HINT
                ),
            ))
        }
    }
}

fn settings(
    target: &Target,
    link_timeout: Duration,
    action: SettingsAction,
) -> Result<Exit, Failure> {
    // Arguments are checked before connecting.
    let parsed = match &action {
        SettingsAction::List => None,
        SettingsAction::Get { id } => Some((machine::parse_id(id), None)),
        SettingsAction::Set { id, value } => Some((machine::parse_id(id), Some(value.as_str()))),
    };
    let parsed = match parsed {
        None => None,
        Some((id, v)) => {
            let id = id.map_err(|e| Failure::new(Exit::Usage, e))?;
            let info = machine::setting(id)
                .ok_or_else(|| Failure::new(Exit::Usage, format!("${id}: no such setting")))?;
            let raw = v
                .map(|v| machine::parse_value(info, v).map_err(|e| Failure::new(Exit::Usage, e)))
                .transpose()?;
            Some((info, raw))
        }
    };
    let (mut s, _sim) = connect(target, Recorder::none())?;
    let mut out = std::io::stdout();
    match parsed {
        None => {
            for (info, v) in s.settings(link_timeout)? {
                let _ = writeln!(out, "{}", machine::setting_line(&info, v));
            }
        }
        Some((info, None)) => {
            let v = s.get_setting(info.id, link_timeout)?;
            let _ = writeln!(out, "{}", machine::setting_line(info, v));
        }
        Some((info, Some(raw))) => {
            let was = s.get_setting(info.id, link_timeout)?;
            let stored = s.set_setting(info.id, raw, link_timeout)?;
            let _ = writeln!(out, "{}", machine::written_line(info, raw, was));
            // A setting taken at reset is in force if it is the value the
            // controller runs with (it says whether a reset is pending).
            let pending = match info.apply {
                controller::config::Apply::Restart => {
                    s.machine_within(link_timeout)?.restart_needed
                }
                _ => false,
            };
            let when = if pending {
                "; takes effect at the next reset"
            } else {
                "; in force"
            };
            // The value is taken either way: a store that failed is a
            // warning, not a refusal (QEMU's flash keeps nothing).
            match stored {
                Some(link::StoreResult::Saved) => say(&format!("written{when}; saved to flash")),
                Some(link::StoreResult::WriteFailed) => say(&format!(
                    "written{when}; WARNING: not saved, the flash write failed: lost at the next reset"
                )),
                Some(r) => say(&format!(
                    "written{when}; WARNING: not saved ({})",
                    machine::stored_text(r)
                )),
                None => say(&format!(
                    "written{when}; the controller did not report the flash write"
                )),
            }
        }
    }
    let _ = out.flush();
    Ok(Exit::Done)
}

fn connect(
    target: &Target,
    rec: Recorder,
) -> Result<(Session, Option<crate::sim::SimHandle>), Failure> {
    let o = transport::open(target)?;
    let mut s = Session::new(o.writer, o.reader, rec);
    s.set_no_answer_hint(target.no_answer_hint());
    Ok((s, o.sim))
}

fn base_options(link_timeout: Duration) -> Result<Options, Failure> {
    let cfg = program::scheduler_config(
        program::machine_feed_max(),
        controller::settings::F_MIN_MM_PER_MIN as f64,
    )
    .map_err(|e| Failure::new(Exit::Error, e))?;
    let mut o = Options::new(cfg);
    o.link_timeout = link_timeout;
    Ok(o)
}

/// A status in a few lines.
pub fn status_text(s: &Status) -> String {
    let [x, y, z] = s.pos_mm.map(bits_f64);
    format!(
        "state: {}\nposition: X{x:.4} Y{y:.4} Z{z:.4} mm\nfeed: {:.1} mm/min, override {} %\nplanner: {} points, scheduler lookahead: {} points\nsequence: next {}, credit to {}\npath: point {} reached, {} underruns since power-up\nlink: {} bad frames since power-up\nticks: {} ({} moving on this path, {} empty)\nsteps: {} ticks short (worst {} steps), {} late ticks\n",
        state_name(s.motion),
        bits_f64(s.feed_mm_per_min),
        s.override_percent,
        s.planned_points,
        s.points_held,
        s.next_seq,
        s.window_end,
        s.point_reached,
        s.underruns,
        s.bad_frames,
        s.ticks,
        s.moving_ticks,
        s.empty_ticks,
        s.step_lag_ticks,
        s.step_lag_max_steps,
        s.step_late_ticks,
    )
}

fn status(target: &Target, link_timeout: Duration, json: bool) -> Result<Exit, Failure> {
    let (mut s, _sim) = connect(target, Recorder::none())?;
    let st = s.status_within(link_timeout, |_| {})?;
    let ms = s.machine_within(link_timeout)?;
    if json {
        let text =
            serde_json::to_string(&st).map_err(|e| Failure::new(Exit::Error, e.to_string()))?;
        println!("{text}");
    } else {
        print!("{}{}", status_text(&st), machine::machine_text(&ms));
    }
    Ok(Exit::Done)
}

fn monitor(target: &Target, link_timeout: Duration, period: f64) -> Result<Exit, Failure> {
    if !(period.is_finite() && (0.05..=3600.0).contains(&period)) {
        return Err(Failure::new(
            Exit::Usage,
            "--period must be within 0.05-3600 s",
        ));
    }
    let stop = Interrupts::install();
    let (mut s, _sim) = connect(target, Recorder::none())?;
    let t0 = Instant::now();
    let period = Duration::from_secs_f64(period);
    let mut out = std::io::stdout();
    while stop.count() == 0 {
        let st = s.status_within(link_timeout, |_| {})?;
        let v = View {
            status: st,
            queued: stream::queued(&st, controller::settings::CMD_CREDIT),
            reached: Some(st.point_reached),
            elapsed: t0.elapsed(),
            ..View::default()
        };
        let mut line = v.line();
        if st.motion == link::Motion::Alarm {
            let ms = s.machine_within(link_timeout)?;
            line.push_str(&format!(
                "  ALARM: {}",
                ms.alarm
                    .map_or("(not reported)".into(), machine::alarm_text)
            ));
        }
        let _ = writeln!(out, "[{:>7.1} s] {line}", v.elapsed.as_secs_f64());
        let _ = out.flush();
        let until = Instant::now() + period;
        while Instant::now() < until && stop.count() == 0 {
            std::thread::sleep(Duration::from_millis(20));
        }
    }
    Ok(Exit::Done)
}

fn stop(target: &Target, link_timeout: Duration) -> Result<Exit, Failure> {
    let (mut s, _sim) = connect(target, Recorder::none())?;
    let opts = base_options(link_timeout)?;
    let a = s.stop(&opts)?;
    if let link::DeviceMsg::Aborted { pos_mm, .. } = a {
        let [x, y, z] = pos_mm.map(bits_f64);
        say(&format!(
            "stopped at X{x:.3} Y{y:.3} Z{z:.3}; everything queued was dropped"
        ));
    }
    Ok(Exit::Done)
}

fn read_script(path: &PathBuf) -> Result<Script, Failure> {
    let text = if path.as_os_str() == "-" {
        std::io::read_to_string(std::io::stdin())
    } else {
        std::fs::read_to_string(path)
    }
    .map_err(|e| Failure::new(Exit::Usage, format!("{}: {e}", path.display())))?;
    Script::parse(&text).map_err(|e| Failure::new(Exit::Usage, format!("{}: {e}", path.display())))
}

fn describe_handshake(hs: &Handshake) -> String {
    let mut s = match hs.hello {
        Some(h) => format!(
            "controller fresh from reset: {} Hz ticks, {} planner points, feed max {} mm/min, acceleration {} mm/s²",
            h.tick_hz, h.planner_points, h.feed_max_mm_per_min, h.accel_mm_per_s2
        ),
        None => format!(
            "controller already running (sequence resumed at {})",
            hs.status.next_seq
        ),
    };
    match &hs.settings {
        SettingsCheck::Matched => s.push_str("; settings match the host's (its hello is what its $ settings give)"),
        SettingsCheck::Unchecked if hs.config.is_some() => s.push_str("; $ settings read"),
        SettingsCheck::Unchecked => s.push_str(
            "; settings not checked (its hello went out at reset, and it did not answer every $ query)",
        ),
        SettingsCheck::Differ(d) => {
            s.push_str("; WARNING, settings differ (--no-check): ");
            s.push_str(&d.join("; "));
        }
    }
    if !hs.changed.is_empty() {
        s.push_str(&format!(
            "; {} $ settings differ from the defaults: {}",
            hs.changed.len(),
            hs.changed.join(", ")
        ));
    }
    if hs.machine.restart_needed {
        s.push_str("; a changed setting takes effect only at the next reset");
    }
    s
}

/// The summary lines after a run.
pub fn summary_text(o: &Outcome) -> Vec<String> {
    let s = &o.summary;
    let mut out = Vec::new();
    if s.scheduled > 0 {
        if s.feed_mismatches == 0 {
            out.push(format!(
                "feeds: {} points scheduled by the controller, every feed equal to the host's schedule bit for bit",
                s.scheduled
            ));
        } else {
            let ex: Vec<String> = s
                .mismatch_examples
                .iter()
                .map(|(i, c, h)| format!("point {}: controller {c} host {h} mm/min", i + 1))
                .collect();
            out.push(format!(
                "WARNING: {} of {} scheduled feeds differ from the host's schedule (firmware built with other settings?): {}{}",
                s.feed_mismatches,
                s.scheduled,
                ex.join(", "),
                if s.build_checked {
                    ""
                } else {
                    "; the firmware's build was not checked (the controller's hello, sent at its reset, went out before this connection): reset it and run again to check it"
                }
            ));
        }
    }
    if s.machine_sent > 0 {
        let mut l = format!(
            "machine: {} spindle/coolant commands sent in the path, {} applied by the controller",
            s.machine_sent, s.machine_applied
        );
        if s.machine_off_point.is_empty() {
            if s.machine_applied > 0 {
                l.push_str(", each with the tool at rest at its point");
            }
        } else {
            let ex: Vec<String> = s
                .machine_off_point
                .iter()
                .map(|(i, c, h)| format!("command {}: controller point {c}, host {h}", i + 1))
                .collect();
            l = format!(
                "WARNING: {l}, some at another point than the host's: {}",
                ex.join(", ")
            );
        }
        out.push(l);
    }
    if o.exit == Exit::Done && !s.ended_on_last_point {
        out.push("WARNING: the tool did not end exactly on the path's last point".into());
    }
    if s.last_status.is_some() {
        out.push(format!(
            "this run: link {} resends, {} refusals reported; controller {} underruns, {} bad frames",
            s.resends, s.refusals, s.underruns, s.bad_frames
        ));
    }
    out
}

fn send(a: SendArgs, target: &Target, link_timeout: Duration) -> Result<Exit, Failure> {
    // Everything that can be refused is checked before connecting.
    let settings = match &a.config {
        Some(p) => GcodeSettings::read_config_file(p)
            .map_err(|e| Failure::new(Exit::Input, format!("{e:#}")))?,
        None => GcodeSettings::default(),
    };
    let script = a.script.as_ref().map(read_script).transpose()?;
    let program =
        program::load(&a.file, &settings).map_err(|e| Failure::new(Exit::Input, e.to_string()))?;
    let run = RunArgs {
        f_max: a.f_max,
        f_min: a.f_min,
        override_percent: a.override_percent,
        script,
        record: a.record.clone(),
        no_check: a.no_check,
        verify: a.verify,
        log: a.log,
        jog: false,
    };
    let file = a.file.clone();
    run_program(run, target, link_timeout, move |here| {
        // A G-code program starts where the tool is.
        if matches!(program.source, program::Source::File(_))
            && here != settings.start_mm
            && !file.to_ascii_lowercase().ends_with(".csv")
        {
            let mut c = settings.clone();
            c.start_mm = here;
            return program::load(&file, &c).map_err(|e| Failure::new(Exit::Input, e.to_string()));
        }
        Ok(program)
    })
}

fn serve(a: ServeArgs, target: &Target, link_timeout: Duration) -> Result<Exit, Failure> {
    let mut gcode = match &a.config {
        Some(p) => GcodeSettings::read_config_file(p)
            .map_err(|e| Failure::new(Exit::Input, format!("{e:#}")))?,
        None => GcodeSettings::default(),
    };
    if a.var_file.is_some() {
        gcode.var_file = a.var_file.clone();
    }
    let (s, _sim) = connect(target, Recorder::none())?;
    let mut opts = base_options(link_timeout)?;
    opts.check_settings = false;
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let flag = stop.clone();
    ctrlc::set_handler(move || flag.store(true, std::sync::atomic::Ordering::Relaxed))
        .map_err(|e| Failure::new(Exit::Error, format!("Ctrl-C handler: {e}")))?;
    let serve_opts = crate::serve::ServeOptions {
        no_pty: a.no_pty,
        pty_link: a.pty_link,
        tcp_port: a.grbl_tcp,
        gcode,
    };
    crate::serve::serve(s, &opts, serve_opts, stop, |ports| {
        for p in ports {
            say(&format!("Grbl 1.1 front on {p}"));
        }
        say("connect a sender (cncjs, bCNC, UGS, gSender) there; Ctrl-C to stop");
    })
}

fn jog(a: JogArgs, target: &Target, link_timeout: Duration) -> Result<Exit, Failure> {
    let j = program::Jog::parse(&a.words).map_err(|e| Failure::new(Exit::Usage, e))?;
    let run = RunArgs {
        // The jog's own feed bounds the schedule (a straight move is
        // scheduled at its programmed feed).
        f_max: Some(j.feed_mm_per_min().min(program::machine_feed_max())),
        f_min: (controller::settings::F_MIN_MM_PER_MIN as f64).min(j.feed_mm_per_min().max(1.0)),
        // As Grbl's jogs: at the feed given, whatever the override.
        override_percent: Some(100),
        script: None,
        record: None,
        no_check: a.no_check,
        verify: false,
        log: a.log,
        jog: true,
    };
    run_program(run, target, link_timeout, move |here| {
        program::jog(&j, here, &GcodeSettings::default())
            .map_err(|e| Failure::new(Exit::Input, e.to_string()))
    })
}

/// How `send` and `jog` run their program.
struct RunArgs {
    f_max: Option<f64>,
    f_min: f64,
    override_percent: Option<u16>,
    script: Option<Script>,
    record: Option<PathBuf>,
    no_check: bool,
    verify: bool,
    log: bool,
    /// A jog: the override before it is set back after it.
    jog: bool,
}

/// Connect, hand the program `build` makes from the tool's position
/// (mm) to the controller, and watch it run (keys on a terminal, the
/// script otherwise); the exit code.
fn run_program(
    a: RunArgs,
    target: &Target,
    link_timeout: Duration,
    build: impl FnOnce([f64; 3]) -> Result<program::Program, Failure>,
) -> Result<Exit, Failure> {
    program::scheduler_config(a.f_max.unwrap_or(program::machine_feed_max()), a.f_min)
        .map_err(|e| Failure::new(Exit::Usage, e))?;
    let rec = match &a.record {
        Some(p) => Recorder::create(p)
            .map_err(|e| Failure::new(Exit::Error, format!("{}: {e}", p.display())))?,
        None => Recorder::none(),
    };

    let (mut session, _sim) = connect(target, rec)?;
    let mut opts = base_options(link_timeout)?;
    opts.check_settings = !a.no_check;
    opts.initial_override = a.override_percent;
    opts.restore_override = a.jog;
    opts.reports = a.verify;
    // The simulated controller's time runs `speed` times the host's: the
    // motion ahead must last as long in the host's time.
    if let Target::Sim { speed, .. } = target {
        opts.ahead = Some(stream::AHEAD.mul_f64(speed.max(1.0)));
    }
    let hs = session.handshake(&opts)?;
    // From here on Ctrl-C is a controlled stop (before, it ends the
    // sender at once: nothing was sent).
    let interrupts = Interrupts::install();
    say(&format!(
        "connected to {target}: {}",
        describe_handshake(&hs)
    ));
    let f_max = a.f_max.unwrap_or_else(|| hs.feed_max_mm_per_min());
    opts.config =
        program::scheduler_config(f_max, a.f_min).map_err(|e| Failure::new(Exit::Usage, e))?;
    let program = build(hs.status.pos_mm.map(bits_f64))?;
    let ovr = hs.status.override_percent;
    if a.override_percent.is_none() && ovr != 100 {
        say(&format!(
            "feed override {ovr} % in force, as left by an earlier run (it lasts until the controller resets, as in Grbl): --override 100 runs at the programmed feeds"
        ));
    }
    say(&format!(
        "sending {}: {} points, {:.1} mm, F_max {} mm/min, F_min {} mm/min",
        program.name,
        program.len(),
        program.length_mm(),
        opts.config.f_max.to_f64(),
        opts.config.f_min.to_f64()
    ));

    let interactive = std::io::stdin().is_terminal() && a.script.is_none();
    let bar = !a.log && std::io::stderr().is_terminal();
    let mut display: Box<dyn Display> = if bar {
        Box::new(BarDisplay::new(
            program.length_mm(),
            if interactive { KEYS_HELP } else { "" },
        ))
    } else {
        let mut d = LogDisplay::new(std::io::stderr(), Duration::from_secs(1));
        if interactive {
            d.note(KEYS_HELP);
        }
        Box::new(d)
    };
    let keys = if interactive {
        match Keys::start() {
            Ok(k) => Some(k),
            Err(e) => {
                say(&format!("keys unavailable ({e}): running unattended"));
                None
            }
        }
    } else {
        None
    };
    let mut inputs = Inputs::new(keys, a.script, interrupts);
    let outcome = session.run(&program, &hs, &opts, &mut inputs, display.as_mut());
    display.finish();
    // Leave raw mode before the summary.
    drop(inputs);
    say(&outcome.message);
    for l in summary_text(&outcome) {
        say(&l);
    }
    if let Err(e) = session.finish_record() {
        say(&format!("the record could not be written: {e}"));
        if outcome.exit == Exit::Done {
            return Ok(Exit::Error);
        }
    }
    Ok(outcome.exit)
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_simulated_probe_plane_is_z_or_z_and_two_slopes() {
        assert_eq!(probe_plane("-3.25"), Some([-3.25, 0.0, 0.0]));
        assert_eq!(probe_plane("-3.25,0.02,-0.01"), Some([-3.25, 0.02, -0.01]));
        for bad in ["", "x", "1,2", "1,2,3", "1,0.1,0.1,0.1", "nan"] {
            assert_eq!(probe_plane(bad), None, "{bad}");
        }
    }

    use super::*;
    use crate::stream::Summary;

    fn outcome(exit: Exit, summary: Summary) -> Outcome {
        Outcome {
            exit,
            message: String::new(),
            summary,
        }
    }

    #[test]
    fn the_summary_says_whether_the_run_was_exact() {
        let good = Summary {
            scheduled: 10,
            ended_on_last_point: true,
            last_status: Some(Status::default()),
            ..Summary::default()
        };
        let t = summary_text(&outcome(Exit::Done, good.clone()));
        assert!(t[0].contains("bit for bit"), "{t:?}");
        assert!(!t.iter().any(|l| l.contains("WARNING")), "{t:?}");
        let bad = Summary {
            feed_mismatches: 1,
            mismatch_examples: vec![(4, 100.0, 101.0)],
            ended_on_last_point: false,
            ..good
        };
        let t = summary_text(&outcome(Exit::Done, bad.clone()));
        assert!(
            t[0].starts_with("WARNING: 1 of 10") && t[0].contains("point 5"),
            "{t:?}"
        );
        assert!(t[1].contains("last point"), "{t:?}");
        // Mismatches with the build unchecked: how to check it.
        assert!(t[0].contains("reset it and run again"), "{t:?}");
        let checked = Summary {
            build_checked: true,
            ..bad.clone()
        };
        let t = summary_text(&outcome(Exit::Done, checked));
        assert!(!t[0].contains("reset"), "{t:?}");
        // A stopped run is not expected on the last point.
        let t = summary_text(&outcome(Exit::UserStop, bad));
        assert!(!t.iter().any(|l| l.contains("last point")), "{t:?}");
    }

    #[test]
    fn a_running_controller_is_described_without_advice_to_reset_it() {
        let hs = Handshake {
            hello: None,
            status: Status::default(),
            machine: link::MachineStatus::default(),
            settings: SettingsCheck::Unchecked,
            config: Some(controller::config::Config::DEFAULT),
            changed: Vec::new(),
            credit_size: controller::settings::CMD_CREDIT,
        };
        let d = describe_handshake(&hs);
        assert!(
            d.contains("already running") && d.contains("settings read"),
            "{d}"
        );
        assert!(!d.contains("reset"), "{d}");
    }

    #[test]
    fn one_link_at_most() {
        let c = Cli::try_parse_from([
            "fuzzy-send",
            "send",
            "x.nc",
            "--port",
            "/dev/x",
            "--tcp",
            "a:1",
        ])
        .unwrap();
        assert_eq!(c.link.target().unwrap_err().exit, Exit::Usage);
        let c = Cli::try_parse_from(["fuzzy-send", "--sim=3", "send", "x.nc"]).unwrap();
        assert_eq!(
            c.link.target().unwrap(),
            Target::Sim {
                speed: 3.0,
                probe_mm: None
            }
        );
        let c = Cli::try_parse_from(["fuzzy-send", "status", "--port", "/dev/x"]).unwrap();
        assert_eq!(
            c.link.target().unwrap(),
            Target::Serial {
                port: "/dev/x".into(),
                baud: DEFAULT_BAUD
            }
        );
        assert!(
            Cli::try_parse_from(["fuzzy-send", "send", "x", "--override", "300", "--sim"]).is_err()
        );
    }

    fn jog_words(c: &Cli) -> Vec<String> {
        match &c.command {
            Command::Jog(a) => a.words.clone(),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn the_link_options_go_anywhere_even_after_a_jogs_words() {
        let tcp = Target::Tcp("127.0.0.1:7878".into());
        let words = ["X-10", "Y2.5", "F1000"];
        for argv in [
            &["jog", "X-10", "Y2.5", "F1000", "--tcp", "127.0.0.1:7878"][..],
            &["jog", "--tcp", "127.0.0.1:7878", "X-10", "Y2.5", "F1000"],
            &["--tcp", "127.0.0.1:7878", "jog", "X-10", "Y2.5", "F1000"],
            &["jog", "X-10", "--tcp=127.0.0.1:7878", "Y2.5", "F1000"],
        ] {
            let c = Cli::try_parse_from(std::iter::once("fuzzy-send").chain(argv.iter().copied()))
                .unwrap_or_else(|e| panic!("{argv:?}: {e}"));
            assert_eq!(c.link.target().unwrap(), tcp, "{argv:?}");
            assert_eq!(jog_words(&c), words, "{argv:?}");
        }
        let c = Cli::try_parse_from([
            "fuzzy-send",
            "jog",
            "G90",
            "z-1",
            "--log",
            "F300",
            "--sim=5",
            "--link-timeout",
            "2",
        ])
        .unwrap();
        assert_eq!(jog_words(&c), ["G90", "z-1", "F300"]);
        assert_eq!(
            c.link.target().unwrap(),
            Target::Sim {
                speed: 5.0,
                probe_mm: None
            }
        );
        assert_eq!(c.link.link_timeout, 2.0);
        assert!(matches!(c.command, Command::Jog(JogArgs { log: true, .. })));
        // After `--`, words are words.
        let c = Cli::try_parse_from(["fuzzy-send", "--sim", "jog", "--", "X1", "--x"]).unwrap();
        assert_eq!(jog_words(&c), ["X1", "--x"]);
        // Every command takes them after its own arguments.
        for argv in [
            &["settings", "set", "100", "80", "--port", "/dev/x"][..],
            &["settings", "get", "100", "--port", "/dev/x"],
            &["status", "--json", "--port", "/dev/x"],
            &["monitor", "--period", "2", "--port", "/dev/x"],
            &["home", "--axes", "Z", "--port", "/dev/x"],
            &["send", "x.nc", "--verify", "--port", "/dev/x"],
        ] {
            let c = Cli::try_parse_from(std::iter::once("fuzzy-send").chain(argv.iter().copied()))
                .unwrap_or_else(|e| panic!("{argv:?}: {e}"));
            assert!(
                matches!(c.link.target(), Ok(Target::Serial { .. })),
                "{argv:?}"
            );
        }
    }
}
