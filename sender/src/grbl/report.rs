//! Every line the front sends, formatted as Grbl 1.1 formats it; each
//! ends in `\r\n` (`grbl/report.c` `report_util_line_feed`).
//!
//! Sources: Grbl 1.1h `grbl/report.c` (each function named below),
//! `grbl/print.c` (`printFloat`, `printFloat_CoordValue`,
//! `printFloat_RateValue`), `grbl/config.h` (`N_DECIMAL_*`,
//! `REPORT_*_REFRESH_*_COUNT`, override limits), `grbl/protocol.c`
//! (`protocol_exec_rt_system`: overrides), `doc/markdown/interface.md`.

use super::codes::{Alarm, ErrorCode, Feedback};
use super::input::Realtime;

/// The Grbl version the front announces (`grbl.h` `GRBL_VERSION`).
pub const GRBL_VERSION: &str = "1.1h";

/// The machine state of the status report (`report_realtime_status`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MachineState {
    /// `Idle`.
    Idle,
    /// `Run` (Grbl's `STATE_CYCLE`).
    Run,
    /// `Hold:0` once stopped and ready to resume, `Hold:1` while stopping.
    Hold {
        /// The hold has come to rest.
        complete: bool,
    },
    /// `Jog` (also while a jog is cancelled).
    Jog,
    /// `Alarm`.
    Alarm,
    /// `Door:N`.
    Door(DoorState),
    /// `Check` (`$C` check mode).
    Check,
    /// `Home`.
    Home,
    /// `Sleep`.
    Sleep,
}

/// The safety door's sub-state (`report_realtime_status`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DoorState {
    /// `Door:0`: closed, ready to resume.
    Closed,
    /// `Door:1`: open, holding.
    Ajar,
    /// `Door:2`: retracting.
    Retracting,
    /// `Door:3`: restoring after the door closed.
    Restoring,
}

impl MachineState {
    /// The state as the status report writes it.
    pub fn name(self) -> &'static str {
        match self {
            MachineState::Idle => "Idle",
            MachineState::Run => "Run",
            MachineState::Hold { complete: true } => "Hold:0",
            MachineState::Hold { complete: false } => "Hold:1",
            MachineState::Jog => "Jog",
            MachineState::Alarm => "Alarm",
            MachineState::Door(DoorState::Closed) => "Door:0",
            MachineState::Door(DoorState::Ajar) => "Door:1",
            MachineState::Door(DoorState::Retracting) => "Door:2",
            MachineState::Door(DoorState::Restoring) => "Door:3",
            MachineState::Check => "Check",
            MachineState::Home => "Home",
            MachineState::Sleep => "Sleep",
        }
    }

    /// Grbl's "busy" states, whose WCO and Ov fields refresh less often
    /// (`STATE_HOMING | STATE_CYCLE | STATE_HOLD | STATE_JOG |
    /// STATE_SAFETY_DOOR`).
    pub fn busy(self) -> bool {
        matches!(
            self,
            MachineState::Home
                | MachineState::Run
                | MachineState::Hold { .. }
                | MachineState::Jog
                | MachineState::Door(_)
        )
    }
}

/// A number as Grbl's `printFloat` prints it: rounded half up at
/// `decimals` places, `-` for any negative value (so −0.0001 prints
/// `-0.000`, as in Grbl); NaN prints as 0, infinities saturate.
pub fn grbl_float(value: f64, decimals: u8) -> String {
    let decimals = decimals.min(9);
    let scale = 10u64.pow(u32::from(decimals));
    let negative = value < 0.0;
    // `as` saturates and maps NaN to 0.
    let a = (value.abs() * scale as f64 + 0.5) as u64;
    let sign = if negative { "-" } else { "" };
    if decimals == 0 {
        format!("{sign}{a}")
    } else {
        format!(
            "{sign}{}.{:0width$}",
            a / scale,
            a % scale,
            width = usize::from(decimals)
        )
    }
}

/// Millimetres per inch.
pub const MM_PER_INCH: f64 = 25.4;

/// A coordinate in mm, printed in the report units (`$13`): 3 decimals
/// in mm, 4 in inches (`printFloat_CoordValue`, `N_DECIMAL_COORDVALUE_*`).
pub fn coord(mm: f64, inches: bool) -> String {
    if inches {
        grbl_float(mm / MM_PER_INCH, 4)
    } else {
        grbl_float(mm, 3)
    }
}

/// A rate in mm/min, printed in the report units: 0 decimals in mm/min, 1
/// in in/min (`printFloat_RateValue`, `N_DECIMAL_RATEVALUE_*`).
pub fn rate(mm_per_min: f64, inches: bool) -> String {
    if inches {
        grbl_float(mm_per_min / MM_PER_INCH, 1)
    } else {
        grbl_float(mm_per_min, 0)
    }
}

fn axes(v: &[f64; 3], inches: bool) -> String {
    format!(
        "{},{},{}",
        coord(v[0], inches),
        coord(v[1], inches),
        coord(v[2], inches)
    )
}

/// The welcome line, on start-up and after a soft reset
/// (`report_init_message`; the senders detect `Grbl` and the version:
/// cncjs `GrblLineParserResultStartup`, bCNC `parseLine`, gSender).
pub fn welcome() -> String {
    format!("\r\nGrbl {GRBL_VERSION} ['$' for help]\r\n")
}

/// `ok` (`report_status_message`).
pub fn ok() -> String {
    "ok\r\n".to_string()
}

/// `error:N` (`report_status_message`).
pub fn error(code: ErrorCode) -> String {
    format!("{code}\r\n")
}

/// `ALARM:N` (`report_alarm_message`).
pub fn alarm(alarm: Alarm) -> String {
    format!("{alarm}\r\n")
}

/// One of Grbl's feedback messages (`report_feedback_message`).
pub fn feedback(message: Feedback) -> String {
    format!("[MSG:{}]\r\n", message.text())
}

/// `[MSG:text]` with any text: made safe for the senders' line parsers
/// (ASCII only: a few symbols spelled out, other characters `?`; control
/// characters as spaces, `[` `]` as `(` `)`, so the line stays one
/// bracketed line).
pub fn message(text: &str) -> String {
    let mut s = String::with_capacity(text.len() + 8);
    s.push_str("[MSG:");
    for c in text.chars() {
        match c {
            '[' => s.push('('),
            ']' => s.push(')'),
            ' '..='~' => s.push(c),
            '≥' => s.push_str(">="),
            '≤' => s.push_str("<="),
            '²' => s.push('2'),
            '³' => s.push('3'),
            'µ' | 'μ' => s.push('u'),
            '—' | '–' | '−' => s.push('-'),
            '…' => s.push_str("..."),
            '·' | '×' => s.push('*'),
            c if c.is_control() => s.push(' '),
            _ => s.push('?'),
        }
    }
    s.push_str("]\r\n");
    s
}

/// `[MSG:text]` then `error:N`: the error with what went wrong (see
/// [`super::codes::error_of_interp`] on why the message is safe).
pub fn error_with_message(code: ErrorCode, text: &str) -> String {
    format!("{}{}", message(text), error(code))
}

/// The `$` help line (`report_grbl_help`).
pub fn help() -> String {
    "[HLP:$$ $# $G $I $N $x=val $Nx=line $J=line $SLP $C $X $H ~ ! ? ctrl-x]\r\n".to_string()
}

/// A setting line of `$$`, `$N=value` (`report_util_setting_prefix`);
/// the value formatted by [`super::settings`].
pub fn setting(id: u16, value: &str) -> String {
    format!("${id}={value}\r\n")
}

/// A startup line of `$N`, `$Nn=line` (`report_startup_line`).
pub fn startup_line(n: u8, line: &str) -> String {
    format!("$N{n}={line}\r\n")
}

/// A startup line run at reset or after homing, `>line:ok` or
/// `>line:error:N`, on one line so that a streaming sender does not count
/// its `ok` (`report_execute_startup_message`).
pub fn startup_result(line: &str, result: Result<(), ErrorCode>) -> String {
    match result {
        Ok(()) => format!(">{line}:ok\r\n"),
        Err(e) => format!(">{line}:{e}\r\n"),
    }
}

/// What `$I` reports.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BuildInfo {
    /// The build date, `YYYYMMDD` (Grbl's `GRBL_VERSION_BUILD`).
    pub date: String,
    /// The name after the `:` when the user stored none with `$I=`.
    pub firmware: String,
    /// The user's `$I=` text (Grbl's build-info line), empty if none.
    pub user: String,
}

/// The `[VER:]` line (`report_build_info`): `[VER:1.1h.DATE:NAME]`,
/// NAME the user's `$I=` text, or our firmware's name.
///
/// Grbl writes `[VER:version.build:user]`. Our firmware is named in the
/// user part and not in the build part (`1.1h.fuzzy.DATE`): UGS's
/// `GrblVersion` pattern takes one `.date` of `[0-9a-z]+` after the
/// version and then wants `:` or `]`, so a second dotted part would fail
/// its match. Characters other than ASCII letters, digits, space and
/// `-_.` are left out of NAME.
pub fn version(info: &BuildInfo) -> String {
    let name = if info.user.is_empty() {
        &info.firmware
    } else {
        &info.user
    };
    let clean = |s: &str, extra: &[char]| -> String {
        s.chars()
            .filter(|c| c.is_ascii_alphanumeric() || extra.contains(c))
            .collect()
    };
    format!(
        "[VER:{GRBL_VERSION}.{}:{}]\r\n",
        clean(&info.date, &[]),
        clean(name, &[' ', '-', '_', '.'])
    )
}

/// The build options of `[OPT:]`, in Grbl's order of letters
/// (`report_build_info`); the numbers are the capacities.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Options {
    /// `V` variable spindle (PWM).
    pub variable_spindle: bool,
    /// `N` line numbers (`Ln:`).
    pub line_numbers: bool,
    /// `M` mist coolant (M7).
    pub mist: bool,
    /// `H` single-axis homing (`$HX`).
    pub homing_single_axis: bool,
    /// `L`: homing not required at power-up (Grbl prints it when
    /// `HOMING_INIT_LOCK` is off).
    pub no_homing_lock: bool,
    /// `+` safety door input.
    pub safety_door: bool,
    /// Planner blocks free when empty (Grbl: `BLOCK_BUFFER_SIZE - 1`).
    pub planner_blocks: u16,
    /// Receive buffer bytes ([`super::input::RX_BUFFER_SIZE`]).
    pub rx_buffer: u16,
}

/// The `[OPT:letters,blocks,rx]` line (`report_build_info`).
pub fn options(o: &Options) -> String {
    let mut letters = String::new();
    for (on, c) in [
        (o.variable_spindle, 'V'),
        (o.line_numbers, 'N'),
        (o.mist, 'M'),
        (o.homing_single_axis, 'H'),
        (o.no_homing_lock, 'L'),
        (o.safety_door, '+'),
    ] {
        if on {
            letters.push(c);
        }
    }
    format!("[OPT:{letters},{},{}]\r\n", o.planner_blocks, o.rx_buffer)
}

/// The motion mode of `[GC:]`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MotionMode {
    /// G0.
    #[default]
    Rapid,
    /// G1.
    Linear,
    /// G2.
    ArcCw,
    /// G3.
    ArcCcw,
    /// G38.2-G38.5 (the minor number 2-5).
    Probe(u8),
    /// G80.
    Cancel,
}

/// The spindle's direction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Spindle {
    /// M5.
    #[default]
    Off,
    /// M3.
    Cw,
    /// M4.
    Ccw,
}

/// The program flow word of `[GC:]`, shown while it applies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProgramFlow {
    /// M0.
    Paused,
    /// M2.
    End,
    /// M30.
    EndRewind,
}

/// The G-code parser state reported by `$G`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Modal {
    /// Motion mode.
    pub motion: MotionMode,
    /// Work coordinate system, 0 = G54 … 5 = G59.
    pub wcs: u8,
    /// Plane, 0 = G17, 1 = G18, 2 = G19.
    pub plane: u8,
    /// G20 (else G21).
    pub inches: bool,
    /// G91 (else G90).
    pub incremental: bool,
    /// G93 (else G94).
    pub inverse_time: bool,
    /// M0/M2/M30 while in force.
    pub program_flow: Option<ProgramFlow>,
    /// M3/M4/M5.
    pub spindle: Spindle,
    /// M7.
    pub mist: bool,
    /// M8.
    pub flood: bool,
    /// T.
    pub tool: u32,
    /// F, mm/min (Grbl keeps the feed in mm and prints it in the report
    /// units of `$13`).
    pub feed_mm_per_min: f64,
    /// S, rpm.
    pub spindle_rpm: f64,
}

impl Default for Modal {
    /// Grbl's state after a reset: `G0 G54 G17 G21 G90 G94 M5 M9 T0 F0 S0`.
    fn default() -> Self {
        Modal {
            motion: MotionMode::Rapid,
            wcs: 0,
            plane: 0,
            inches: false,
            incremental: false,
            inverse_time: false,
            program_flow: None,
            spindle: Spindle::Off,
            mist: false,
            flood: false,
            tool: 0,
            feed_mm_per_min: 0.0,
            spindle_rpm: 0.0,
        }
    }
}

/// The `[GC:…]` line of `$G` (`report_gcode_modes`). Both M7 and M8 are
/// listed when on (Grbl's `ENABLE_M7` form); an out-of-range `wcs` or
/// `plane` is shown as G54 or G17.
pub fn gcode_modes(m: &Modal, report_inches: bool) -> String {
    let motion = match m.motion {
        MotionMode::Rapid => "G0".to_string(),
        MotionMode::Linear => "G1".to_string(),
        MotionMode::ArcCw => "G2".to_string(),
        MotionMode::ArcCcw => "G3".to_string(),
        MotionMode::Probe(n) => format!("G38.{n}"),
        MotionMode::Cancel => "G80".to_string(),
    };
    let wcs = 54 + u32::from(if m.wcs <= 5 { m.wcs } else { 0 });
    let plane = 17 + u32::from(if m.plane <= 2 { m.plane } else { 0 });
    let mut s = format!(
        "[GC:{motion} G{wcs} G{plane} G{} G{} G{}",
        if m.inches { 20 } else { 21 },
        if m.incremental { 91 } else { 90 },
        if m.inverse_time { 93 } else { 94 },
    );
    match m.program_flow {
        Some(ProgramFlow::Paused) => s.push_str(" M0"),
        Some(ProgramFlow::End) => s.push_str(" M2"),
        Some(ProgramFlow::EndRewind) => s.push_str(" M30"),
        None => {}
    }
    s.push_str(match m.spindle {
        Spindle::Cw => " M3",
        Spindle::Ccw => " M4",
        Spindle::Off => " M5",
    });
    if m.mist {
        s.push_str(" M7");
    }
    if m.flood {
        s.push_str(" M8");
    }
    if !m.mist && !m.flood {
        s.push_str(" M9");
    }
    s.push_str(&format!(
        " T{} F{} S{}]\r\n",
        m.tool,
        rate(m.feed_mm_per_min, report_inches),
        grbl_float(m.spindle_rpm, 0)
    ));
    s
}

/// The probe result (`report_probe_parameters`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Probe {
    /// Where the probe tripped (or the cycle ended), machine
    /// coordinates, mm.
    pub position_mm: [f64; 3],
    /// The last probe cycle tripped.
    pub succeeded: bool,
}

/// The `[PRB:x,y,z:0|1]` line, pushed before the `ok` of a G38 line and
/// part of `$#` (`report_probe_parameters`).
pub fn probe(p: &Probe, report_inches: bool) -> String {
    format!(
        "[PRB:{}:{}]\r\n",
        axes(&p.position_mm, report_inches),
        u8::from(p.succeeded)
    )
}

/// What `$#` reports, mm.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Parameters {
    /// G54 … G59 offsets.
    pub wcs: [[f64; 3]; 6],
    /// G28 position.
    pub g28: [f64; 3],
    /// G30 position.
    pub g30: [f64; 3],
    /// G92 offset.
    pub g92: [f64; 3],
    /// Tool length offset (G43.1), on Z.
    pub tlo: f64,
    /// The probe result.
    pub probe: Probe,
}

/// The `$#` lines: `[G54:]` … `[G59:]`, `[G28:]`, `[G30:]`, `[G92:]`,
/// `[TLO:]`, `[PRB:]` (`report_ngc_parameters`); the `ok` is the caller's.
pub fn parameters(p: &Parameters, report_inches: bool) -> String {
    let mut s = String::new();
    for (i, o) in p.wcs.iter().enumerate() {
        s.push_str(&format!("[G{}:{}]\r\n", 54 + i, axes(o, report_inches)));
    }
    s.push_str(&format!("[G28:{}]\r\n", axes(&p.g28, report_inches)));
    s.push_str(&format!("[G30:{}]\r\n", axes(&p.g30, report_inches)));
    s.push_str(&format!("[G92:{}]\r\n", axes(&p.g92, report_inches)));
    s.push_str(&format!("[TLO:{}]\r\n", coord(p.tlo, report_inches)));
    s.push_str(&probe(&p.probe, report_inches));
    s
}

/// Feed, rapid and spindle overrides, percent, with Grbl's steps and
/// limits (`protocol_exec_rt_system`, `config.h`: feed and spindle 10-200 %
/// by 10 and 1, rapid 100/50/25 %).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Overrides {
    /// Feed, %.
    pub feed: u8,
    /// Rapid, %.
    pub rapid: u8,
    /// Spindle, %.
    pub spindle: u8,
}

impl Default for Overrides {
    fn default() -> Self {
        Overrides {
            feed: 100,
            rapid: 100,
            spindle: 100,
        }
    }
}

impl Overrides {
    /// Least feed or spindle override, %.
    pub const MIN: u8 = 10;
    /// Greatest feed or spindle override, %.
    pub const MAX: u8 = 200;

    /// Apply an override command; `true` if a value changed. Other
    /// commands change nothing.
    pub fn apply(&mut self, rt: Realtime) -> bool {
        use Realtime::*;
        let step = |v: u8, d: i16| -> u8 {
            (i16::from(v) + d).clamp(i16::from(Self::MIN), i16::from(Self::MAX)) as u8
        };
        let before = *self;
        match rt {
            FeedOvrReset => self.feed = 100,
            FeedOvrCoarsePlus => self.feed = step(self.feed, 10),
            FeedOvrCoarseMinus => self.feed = step(self.feed, -10),
            FeedOvrFinePlus => self.feed = step(self.feed, 1),
            FeedOvrFineMinus => self.feed = step(self.feed, -1),
            RapidOvrReset => self.rapid = 100,
            RapidOvrMedium => self.rapid = 50,
            RapidOvrLow => self.rapid = 25,
            SpindleOvrReset => self.spindle = 100,
            SpindleOvrCoarsePlus => self.spindle = step(self.spindle, 10),
            SpindleOvrCoarseMinus => self.spindle = step(self.spindle, -10),
            SpindleOvrFinePlus => self.spindle = step(self.spindle, 1),
            SpindleOvrFineMinus => self.spindle = step(self.spindle, -1),
            _ => {}
        }
        *self != before
    }
}

/// Input pins shown in `Pn:` (`report_realtime_status`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Pins {
    /// `P` probe.
    pub probe: bool,
    /// `X`, `Y`, `Z` limit switches (either end).
    pub limits: [bool; 3],
    /// `D` safety door.
    pub door: bool,
    /// `R` reset (our e-stop input is shown here).
    pub reset: bool,
    /// `H` feed hold.
    pub hold: bool,
    /// `S` cycle start.
    pub start: bool,
}

/// One real-time status: the values of a `<…>` report.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Status {
    /// The state.
    pub state: MachineState,
    /// Machine position, mm.
    pub mpos_mm: [f64; 3],
    /// Work coordinate offset (G54… + G92 + tool length on Z), mm:
    /// work position = machine position − WCO.
    pub wco_mm: [f64; 3],
    /// Planner blocks free (`Bf:` first number).
    pub planner_free: u16,
    /// Receive buffer bytes free (`Bf:` second number).
    pub rx_free: u16,
    /// Line number of the block in motion (`Ln:`), if any.
    pub line: Option<u32>,
    /// Feed now, mm/min.
    pub feed_mm_per_min: f64,
    /// Spindle speed now, rpm.
    pub spindle_rpm: f64,
    /// Active inputs.
    pub pins: Pins,
    /// Overrides.
    pub overrides: Overrides,
    /// Spindle output.
    pub spindle: Spindle,
    /// Flood coolant output.
    pub flood: bool,
    /// Mist coolant output.
    pub mist: bool,
}

/// `$10` bit 0: report the machine position (`MPos`), else the work
/// position (`WPos`) (`BITFLAG_RT_STATUS_POSITION_TYPE`).
pub const MASK_MPOS: u8 = 1;
/// `$10` bit 1: report `Bf:` (`BITFLAG_RT_STATUS_BUFFER_STATE`).
pub const MASK_BUFFER: u8 = 2;

/// Reports between WCO fields in a busy state (`REPORT_WCO_REFRESH_BUSY_COUNT`).
pub const WCO_REFRESH_BUSY: u8 = 30;
/// … in an idle state (`REPORT_WCO_REFRESH_IDLE_COUNT`).
pub const WCO_REFRESH_IDLE: u8 = 10;
/// Reports between Ov fields in a busy state (`REPORT_OVR_REFRESH_BUSY_COUNT`).
pub const OVR_REFRESH_BUSY: u8 = 20;
/// … in an idle state (`REPORT_OVR_REFRESH_IDLE_COUNT`).
pub const OVR_REFRESH_IDLE: u8 = 10;

/// The status reports of one connection: Grbl's counters that decide
/// when `WCO:` and `Ov:` (with `A:`) are included
/// (`report_realtime_status`, `sys.report_wco_counter`,
/// `sys.report_ovr_counter`).
///
/// As in Grbl: both counters start at 0 (after a reset), so the first
/// report has `WCO:`; a report with `WCO:` sets the Ov counter to 1 if it
/// was 0, so `Ov:` comes in the next report, never in the same one; then
/// each comes every 10 reports idle, every 30 (WCO) or 20 (Ov) busy. A
/// change sends the field in the next report: Grbl zeroes the counter
/// where the value changes (`system_flag_wco_change`; overrides, spindle
/// and coolant in `protocol.c`, `spindle_control.c`,
/// `coolant_control.c`); here [`StatusReporter::report`] compares each
/// status with the last one, which gives the same reports.
#[derive(Clone, Debug, Default)]
pub struct StatusReporter {
    wco_counter: u8,
    ovr_counter: u8,
    last: Option<([f64; 3], Overrides, Spindle, bool, bool)>,
}

impl StatusReporter {
    /// The counters as after a reset.
    pub fn new() -> StatusReporter {
        StatusReporter::default()
    }

    /// Send `WCO:` in the next report (`system_flag_wco_change`, e.g. on
    /// a `$13` change, which changes its units but not its value).
    pub fn flag_wco(&mut self) {
        self.wco_counter = 0;
    }

    /// Send `Ov:` in the next report.
    pub fn flag_overrides(&mut self) {
        self.ovr_counter = 0;
    }

    /// The `<…>` report of `status`, with `$10` = `mask` and `$13` =
    /// `report_inches`, advancing the counters.
    pub fn report(&mut self, status: &Status, mask: u8, report_inches: bool) -> String {
        let now = (
            status.wco_mm,
            status.overrides,
            status.spindle,
            status.flood,
            status.mist,
        );
        if let Some((wco, ovr, sp, fl, mi)) = self.last {
            if wco != now.0 {
                self.wco_counter = 0;
            }
            if ovr != now.1 || sp != now.2 || fl != now.3 || mi != now.4 {
                self.ovr_counter = 0;
            }
        }
        self.last = Some(now);
        let busy = status.state.busy();
        let wco = if self.wco_counter > 0 {
            self.wco_counter -= 1;
            false
        } else {
            self.wco_counter = if busy {
                WCO_REFRESH_BUSY
            } else {
                WCO_REFRESH_IDLE
            } - 1;
            if self.ovr_counter == 0 {
                self.ovr_counter = 1;
            }
            true
        };
        let ovr = if self.ovr_counter > 0 {
            self.ovr_counter -= 1;
            false
        } else {
            self.ovr_counter = if busy {
                OVR_REFRESH_BUSY
            } else {
                OVR_REFRESH_IDLE
            } - 1;
            true
        };
        format_status(status, mask, report_inches, wco, ovr)
    }
}

/// A report with every field, `WCO:` and `Ov:` included, the counters
/// untouched: the answer to grblHAL's 0x87 ([`Realtime::StatusReportAll`]).
pub fn status_report_full(status: &Status, mask: u8, report_inches: bool) -> String {
    format_status(status, mask, report_inches, true, true)
}

fn format_status(s: &Status, mask: u8, inches: bool, wco: bool, ovr: bool) -> String {
    let mut r = format!("<{}", s.state.name());
    if mask & MASK_MPOS != 0 {
        r.push_str(&format!("|MPos:{}", axes(&s.mpos_mm, inches)));
    } else {
        let w = [
            s.mpos_mm[0] - s.wco_mm[0],
            s.mpos_mm[1] - s.wco_mm[1],
            s.mpos_mm[2] - s.wco_mm[2],
        ];
        r.push_str(&format!("|WPos:{}", axes(&w, inches)));
    }
    if mask & MASK_BUFFER != 0 {
        r.push_str(&format!("|Bf:{},{}", s.planner_free, s.rx_free));
    }
    if let Some(n) = s.line.filter(|&n| n > 0) {
        r.push_str(&format!("|Ln:{n}"));
    }
    r.push_str(&format!(
        "|FS:{},{}",
        rate(s.feed_mm_per_min, inches),
        grbl_float(s.spindle_rpm, 0)
    ));
    let p = &s.pins;
    let mut pn = String::new();
    for (on, c) in [
        (p.probe, 'P'),
        (p.limits[0], 'X'),
        (p.limits[1], 'Y'),
        (p.limits[2], 'Z'),
        (p.door, 'D'),
        (p.reset, 'R'),
        (p.hold, 'H'),
        (p.start, 'S'),
    ] {
        if on {
            pn.push(c);
        }
    }
    if !pn.is_empty() {
        r.push_str(&format!("|Pn:{pn}"));
    }
    if wco {
        r.push_str(&format!("|WCO:{}", axes(&s.wco_mm, inches)));
    }
    if ovr {
        let o = s.overrides;
        r.push_str(&format!("|Ov:{},{},{}", o.feed, o.rapid, o.spindle));
        let mut a = String::new();
        match s.spindle {
            Spindle::Cw => a.push('S'),
            Spindle::Ccw => a.push('C'),
            Spindle::Off => {}
        }
        if s.flood {
            a.push('F');
        }
        if s.mist {
            a.push('M');
        }
        if !a.is_empty() {
            r.push_str(&format!("|A:{a}"));
        }
    }
    r.push_str(">\r\n");
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    fn status(state: MachineState) -> Status {
        Status {
            state,
            mpos_mm: [10.0, -2.5, 0.0],
            wco_mm: [5.0, 0.0, -1.0],
            planner_free: 15,
            rx_free: 1024,
            line: None,
            feed_mm_per_min: 0.0,
            spindle_rpm: 0.0,
            pins: Pins::default(),
            overrides: Overrides::default(),
            spindle: Spindle::Off,
            flood: false,
            mist: false,
        }
    }

    #[test]
    fn numbers_as_grbl() {
        assert_eq!(grbl_float(0.0, 3), "0.000");
        assert_eq!(grbl_float(1.0005, 3), "1.001");
        assert_eq!(grbl_float(-2.5, 3), "-2.500");
        assert_eq!(grbl_float(-0.0001, 3), "-0.000");
        assert_eq!(grbl_float(1234.6, 0), "1235");
        assert_eq!(grbl_float(f64::NAN, 3), "0.000");
        assert!(!grbl_float(f64::INFINITY, 3).is_empty());
        assert!(!grbl_float(f64::NEG_INFINITY, 9).is_empty());
        assert_eq!(coord(25.4, true), "1.0000");
        assert_eq!(coord(25.4, false), "25.400");
        assert_eq!(rate(254.0, true), "10.0");
        assert_eq!(rate(1000.4, false), "1000");
    }

    #[test]
    fn simple_lines() {
        assert_eq!(welcome(), "\r\nGrbl 1.1h ['$' for help]\r\n");
        assert_eq!(ok(), "ok\r\n");
        assert_eq!(error(ErrorCode::Overflow), "error:11\r\n");
        assert_eq!(alarm(Alarm::EStop), "ALARM:10\r\n");
        assert_eq!(
            feedback(Feedback::AlarmLock),
            "[MSG:'$H'|'$X' to unlock]\r\n"
        );
        assert_eq!(setting(110, "500.000"), "$110=500.000\r\n");
        assert_eq!(startup_line(0, "G20G54"), "$N0=G20G54\r\n");
        assert_eq!(startup_result("G20G54", Ok(())), ">G20G54:ok\r\n");
        assert_eq!(
            startup_result("G5", Err(ErrorCode::GcodeUnsupportedCommand)),
            ">G5:error:20\r\n"
        );
        assert_eq!(
            error_with_message(ErrorCode::GcodeArcRadiusError, "radius ≥ 1 mm [x]\nµ€"),
            "[MSG:radius >= 1 mm (x) u?]\r\nerror:34\r\n"
        );
    }

    #[test]
    fn build_info() {
        let info = BuildInfo {
            date: "20260801".into(),
            firmware: "fuzzy-feed".into(),
            user: String::new(),
        };
        assert_eq!(version(&info), "[VER:1.1h.20260801:fuzzy-feed]\r\n");
        let user = BuildInfo {
            user: "Mill 1]\r".into(),
            ..info
        };
        assert_eq!(version(&user), "[VER:1.1h.20260801:Mill 1]\r\n");
        let o = Options {
            variable_spindle: true,
            line_numbers: true,
            mist: true,
            homing_single_axis: true,
            no_homing_lock: false,
            safety_door: false,
            planner_blocks: 15,
            rx_buffer: 1024,
        };
        assert_eq!(options(&o), "[OPT:VNMH,15,1024]\r\n");
        assert_eq!(options(&Options::default()), "[OPT:,0,0]\r\n");
    }

    #[test]
    fn gc_line() {
        assert_eq!(
            gcode_modes(&Modal::default(), false),
            "[GC:G0 G54 G17 G21 G90 G94 M5 M9 T0 F0 S0]\r\n"
        );
        let m = Modal {
            motion: MotionMode::Probe(2),
            wcs: 1,
            plane: 2,
            inches: true,
            incremental: true,
            inverse_time: true,
            program_flow: Some(ProgramFlow::Paused),
            spindle: Spindle::Ccw,
            mist: true,
            flood: true,
            tool: 3,
            feed_mm_per_min: 254.0,
            spindle_rpm: 12000.0,
        };
        assert_eq!(
            gcode_modes(&m, true),
            "[GC:G38.2 G55 G19 G20 G91 G93 M0 M4 M7 M8 T3 F10.0 S12000]\r\n"
        );
        let odd = Modal {
            wcs: 9,
            plane: 7,
            ..Modal::default()
        };
        assert!(gcode_modes(&odd, false).starts_with("[GC:G0 G54 G17 "));
    }

    #[test]
    fn parameter_lines() {
        let mut p = Parameters::default();
        p.wcs[0] = [1.0, 2.0, 3.0];
        p.g92 = [0.5, 0.0, 0.0];
        p.tlo = -1.25;
        p.probe = Probe {
            position_mm: [1.0, 2.0, -3.0],
            succeeded: true,
        };
        let s = parameters(&p, false);
        let lines: Vec<&str> = s.split("\r\n").collect();
        assert_eq!(lines[0], "[G54:1.000,2.000,3.000]");
        assert_eq!(lines[5], "[G59:0.000,0.000,0.000]");
        assert_eq!(lines[6], "[G28:0.000,0.000,0.000]");
        assert_eq!(lines[7], "[G30:0.000,0.000,0.000]");
        assert_eq!(lines[8], "[G92:0.500,0.000,0.000]");
        assert_eq!(lines[9], "[TLO:-1.250]");
        assert_eq!(lines[10], "[PRB:1.000,2.000,-3.000:1]");
        assert_eq!(lines.len(), 12);
    }

    #[test]
    fn every_state_name() {
        use MachineState::*;
        let all = [
            (Idle, "Idle"),
            (Run, "Run"),
            (Hold { complete: true }, "Hold:0"),
            (Hold { complete: false }, "Hold:1"),
            (Jog, "Jog"),
            (Alarm, "Alarm"),
            (Door(DoorState::Closed), "Door:0"),
            (Door(DoorState::Ajar), "Door:1"),
            (Door(DoorState::Retracting), "Door:2"),
            (Door(DoorState::Restoring), "Door:3"),
            (Check, "Check"),
            (Home, "Home"),
            (Sleep, "Sleep"),
        ];
        for (state, name) in all {
            let r = status_report_full(&status(state), MASK_MPOS, false);
            assert!(r.starts_with(&format!("<{name}|MPos:")), "{r}");
        }
    }

    #[test]
    fn masks_and_fields() {
        let s = status(MachineState::Idle);
        let mut rep = StatusReporter::new();
        // $10=1: MPos; first report after reset has WCO.
        assert_eq!(
            rep.report(&s, 1, false),
            "<Idle|MPos:10.000,-2.500,0.000|FS:0,0|WCO:5.000,0.000,-1.000>\r\n"
        );
        // Then Ov, never with WCO.
        assert_eq!(
            rep.report(&s, 0, false),
            "<Idle|WPos:5.000,-2.500,1.000|FS:0,0|Ov:100,100,100>\r\n"
        );
        // $10=2: WPos with Bf.
        assert_eq!(
            rep.report(&s, 2, false),
            "<Idle|WPos:5.000,-2.500,1.000|Bf:15,1024|FS:0,0>\r\n"
        );
        // $10=3 and inches.
        assert_eq!(
            rep.report(&s, 3, true),
            "<Idle|MPos:0.3937,-0.0984,0.0000|Bf:15,1024|FS:0.0,0>\r\n"
        );
        let full = Status {
            line: Some(42),
            feed_mm_per_min: 1500.0,
            spindle_rpm: 9000.0,
            pins: Pins {
                probe: true,
                limits: [true, false, true],
                door: true,
                reset: true,
                hold: true,
                start: true,
            },
            spindle: Spindle::Cw,
            flood: true,
            mist: true,
            ..status(MachineState::Run)
        };
        assert_eq!(
            status_report_full(&full, 3, false),
            "<Run|MPos:10.000,-2.500,0.000|Bf:15,1024|Ln:42|FS:1500,9000|Pn:PXZDRHS\
             |WCO:5.000,0.000,-1.000|Ov:100,100,100|A:SFM>\r\n"
        );
        let ccw = Status {
            spindle: Spindle::Ccw,
            ..status(MachineState::Idle)
        };
        assert!(status_report_full(&ccw, 1, false).ends_with("|Ov:100,100,100|A:C>\r\n"));
    }

    fn fields(r: &str) -> (bool, bool) {
        (r.contains("|WCO:"), r.contains("|Ov:"))
    }

    #[test]
    fn wco_and_ov_refresh() {
        let idle = status(MachineState::Idle);
        let mut rep = StatusReporter::new();
        let got: Vec<(bool, bool)> = (0..22)
            .map(|_| fields(&rep.report(&idle, 1, false)))
            .collect();
        // WCO at 0, 10, 20; Ov the report after each.
        for (i, f) in got.iter().enumerate() {
            assert_eq!(f.0, i % 10 == 0, "report {i}");
            assert_eq!(f.1, i % 10 == 1, "report {i}");
        }
        // Busy: WCO every 30.
        let run = status(MachineState::Run);
        let mut rep = StatusReporter::new();
        let wco: Vec<usize> = (0..61)
            .filter(|_| fields(&rep.report(&run, 1, false)).0)
            .collect();
        assert_eq!(wco.len(), 3);
        // A change is reported at once.
        let mut rep = StatusReporter::new();
        rep.report(&idle, 1, false);
        rep.report(&idle, 1, false);
        assert_eq!(fields(&rep.report(&idle, 1, false)), (false, false));
        let moved = Status {
            wco_mm: [0.0; 3],
            ..idle
        };
        assert_eq!(fields(&rep.report(&moved, 1, false)), (true, false));
        let mut ov = moved;
        assert!(ov.overrides.apply(Realtime::FeedOvrCoarsePlus));
        rep.report(&moved, 1, false);
        assert_eq!(fields(&rep.report(&ov, 1, false)), (false, true));
        let flood = Status { flood: true, ..ov };
        let r = rep.report(&flood, 1, false);
        assert!(r.contains("|Ov:110,100,100|A:F>"), "{r}");
        rep.flag_wco();
        assert!(fields(&rep.report(&flood, 1, false)).0);
        rep.flag_overrides();
        rep.report(&flood, 1, false);
    }

    #[test]
    fn overrides_as_grbl() {
        let mut o = Overrides::default();
        for _ in 0..20 {
            o.apply(Realtime::FeedOvrCoarsePlus);
        }
        assert_eq!(o.feed, 200);
        assert!(!o.apply(Realtime::FeedOvrFinePlus));
        for _ in 0..30 {
            o.apply(Realtime::FeedOvrCoarseMinus);
        }
        assert_eq!(o.feed, 10);
        o.apply(Realtime::FeedOvrReset);
        o.apply(Realtime::FeedOvrFineMinus);
        assert_eq!(o.feed, 99);
        o.apply(Realtime::RapidOvrLow);
        assert_eq!(o.rapid, 25);
        o.apply(Realtime::RapidOvrMedium);
        assert_eq!(o.rapid, 50);
        o.apply(Realtime::SpindleOvrCoarseMinus);
        o.apply(Realtime::SpindleOvrFinePlus);
        assert_eq!(o.spindle, 91);
        assert!(!o.apply(Realtime::StatusReport));
        assert!(o.apply(Realtime::SpindleOvrReset));
        assert!(o.apply(Realtime::RapidOvrReset));
    }
}
