//! What a cleaned line asks for: a `$` system command or a G-code block
//! ([`parse`]), with Grbl's checks of the machine state and Grbl's error
//! numbers, and the `$J=` jog rules ([`Jog`]).
//!
//! Sources: Grbl 1.1h `grbl/system.c` (`system_execute_line`: the `$`
//! commands, their order of checks), `grbl/protocol.c`
//! (`protocol_main_loop`: G-code locked out in alarm and jog),
//! `grbl/gcode.c` (`gc_execute_line`: word parsing and the jog checks),
//! `grbl/nuts_bolts.c` (`read_float`), `grbl/settings.c`
//! (`settings_store_global_setting`: negative values), `grbl/jog.c`.

use super::codes::ErrorCode;
use super::report::MachineState;

/// Startup lines kept (`$N0`, `$N1`: Grbl's `N_STARTUP_LINE`).
pub const STARTUP_LINES: u8 = 2;

/// What `$RST=` restores.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Restore {
    /// `$RST=$`: settings to their defaults.
    Settings,
    /// `$RST=#`: G54-G59, G28, G30 to zero.
    Parameters,
    /// `$RST=*`: both, and the startup lines and build info.
    All,
}

/// A line's meaning.
#[derive(Clone, Debug, PartialEq)]
pub enum Command {
    /// A blank or comment-only line: `ok` (for the sender's count).
    Empty,
    /// `$`: the help line.
    Help,
    /// `$$`: the settings.
    Settings,
    /// `$#`: the offsets and the probe result.
    Parameters,
    /// `$G`: the parser state.
    ParserState,
    /// `$I`: the build info.
    BuildInfo,
    /// `$I=text`: store the build-info text.
    SetBuildInfo(String),
    /// `$N`: the startup lines.
    StartupLines,
    /// `$Nn=line`: store a startup line, once the interpreter has
    /// accepted it (Grbl runs it through its parser first; an empty line
    /// clears it).
    SetStartupLine {
        /// Which, below [`STARTUP_LINES`].
        n: u8,
        /// The G-code block.
        line: String,
    },
    /// `$C`: check mode on, or off (Grbl resets when it leaves check
    /// mode) when the state is already [`MachineState::Check`].
    CheckMode,
    /// `$X`: unlock (takes effect in the alarm state only; `ok` in any).
    Unlock,
    /// `$H` (all axes: mask 0) or `$HX`, `$HY`, `$HZ` (bit 0 X, 1 Y,
    /// 2 Z: Grbl's `HOMING_SINGLE_AXIS_COMMANDS`, report `H` in `[OPT:]`).
    Home {
        /// Axes, a bit mask; 0 for the whole cycle.
        axes: u8,
    },
    /// `$J=…`: a jog.
    Jog(Jog),
    /// `$SLP`: sleep.
    Sleep,
    /// `$RST=…`.
    Restore(Restore),
    /// `$n=value`: write a setting ([`super::settings`] maps and checks it).
    SetSetting {
        /// The id.
        id: u16,
        /// The value as written.
        value: f64,
    },
    /// Anything not starting with `$`: a G-code block for the interpreter.
    Gcode(String),
}

/// A `$J=` jog, checked by Grbl's jog rules. Words not given keep the
/// parser's modes (Grbl copies `gc_state.modal`), and the jog changes no
/// mode (`gc_execute_line`: "G-code parser state is not updated").
#[derive(Clone, Debug, PartialEq)]
pub struct Jog {
    /// The block after `$J=` (cleaned), for the interpreter or a log.
    pub body: String,
    /// G20 (`Some(true)`) or G21 in the block.
    pub inches: Option<bool>,
    /// G91 (`Some(true)`) or G90 in the block.
    pub incremental: Option<bool>,
    /// G53: the axis words are machine coordinates.
    pub machine: bool,
    /// X, Y, Z as written (block units); `None`: not given.
    pub axes: [Option<f64>; 3],
    /// F as written (block units per minute; Grbl ignores G93 for jogs).
    pub feed: f64,
    /// N, if given.
    pub line_number: Option<u32>,
}

impl Jog {
    /// The feed in mm/min, given the parser's units when the block has no
    /// G20/G21 (Grbl scales F by 25.4 in inches).
    pub fn feed_mm_per_min(&self, modal_inches: bool) -> f64 {
        if self.inches.unwrap_or(modal_inches) {
            self.feed * 25.4
        } else {
            self.feed
        }
    }
}

/// Parse a cleaned line ([`super::input::Line::text`]) in a machine
/// state, with Grbl's checks in Grbl's order.
///
/// State checks (`system_execute_line`, `protocol_main_loop`):
/// - G-code: error 9 in `Alarm` and `Jog`, and in `Sleep` (ours: Grbl
///   reads no line while asleep, until a reset);
/// - `$J=`: `Idle` or `Jog`, else 8, checked before its syntax;
/// - `$$`: not in `Run` or `Hold`; `$G`, `$X`, `$` any time; `$C` from
///   `Idle` (or `Check`, to leave it);
/// - `$#`, `$H`, `$I`, `$N`, `$SLP`, `$RST=`, `$n=`: `Idle` or `Alarm`,
///   checked before their syntax; storing `$Nn=` in `Idle` only.
///
/// What needs more than the line (homing enabled, door open, the setting
/// table) is the caller's: `$H` with homing off is error 5, with the door
/// open 13; `$X` with the door open 13.
///
/// Our stricter parts: a setting id must be digits (Grbl reads a float and
/// truncates `$1.5=` to `$1`): a sign or a point gives 3; ids up to 65535
/// (Grbl: 255). `$Nn=` wants n below [`STARTUP_LINES`] (3 otherwise;
/// Grbl does not check it).
pub fn parse(line: &str, state: MachineState) -> Result<Command, ErrorCode> {
    use MachineState as S;
    let b = line.as_bytes();
    if b.is_empty() {
        return Ok(Command::Empty);
    }
    if b[0] != b'$' {
        return match state {
            S::Alarm | S::Jog | S::Sleep => Err(ErrorCode::SystemGcLock),
            _ => Ok(Command::Gcode(line.to_string())),
        };
    }
    let idle_or_alarm = matches!(state, S::Idle | S::Alarm);
    let rest = &b[1..];
    match rest.first() {
        None => Ok(Command::Help),
        Some(b'J') => {
            if !matches!(state, S::Idle | S::Jog) {
                return Err(ErrorCode::IdleError);
            }
            if rest.get(1) != Some(&b'=') {
                return Err(ErrorCode::InvalidStatement);
            }
            parse_jog(&line[3..]).map(Command::Jog)
        }
        Some(&c @ (b'$' | b'G' | b'C' | b'X')) => {
            if rest.len() != 1 {
                return Err(ErrorCode::InvalidStatement);
            }
            match c {
                b'$' if matches!(state, S::Run | S::Hold { .. }) => Err(ErrorCode::IdleError),
                b'$' => Ok(Command::Settings),
                b'G' => Ok(Command::ParserState),
                b'C' if state == S::Check || state == S::Idle => Ok(Command::CheckMode),
                b'C' => Err(ErrorCode::IdleError),
                _ => Ok(Command::Unlock),
            }
        }
        Some(&c) => {
            if !idle_or_alarm {
                return Err(ErrorCode::IdleError);
            }
            if !c.is_ascii() {
                return Err(ErrorCode::InvalidStatement);
            }
            let tail = &line[2..];
            match c {
                b'#' if tail.is_empty() => Ok(Command::Parameters),
                b'#' => Err(ErrorCode::InvalidStatement),
                b'H' => match tail {
                    "" => Ok(Command::Home { axes: 0 }),
                    "X" => Ok(Command::Home { axes: 1 }),
                    "Y" => Ok(Command::Home { axes: 2 }),
                    "Z" => Ok(Command::Home { axes: 4 }),
                    _ => Err(ErrorCode::InvalidStatement),
                },
                b'S' if tail == "LP" => Ok(Command::Sleep),
                b'S' => Err(ErrorCode::InvalidStatement),
                b'I' if tail.is_empty() => Ok(Command::BuildInfo),
                b'I' => match tail.strip_prefix('=') {
                    Some(text) => Ok(Command::SetBuildInfo(text.to_string())),
                    None => Err(ErrorCode::InvalidStatement),
                },
                b'R' => match tail {
                    "ST=$" => Ok(Command::Restore(Restore::Settings)),
                    "ST=#" => Ok(Command::Restore(Restore::Parameters)),
                    "ST=*" => Ok(Command::Restore(Restore::All)),
                    _ => Err(ErrorCode::InvalidStatement),
                },
                b'N' if tail.is_empty() => Ok(Command::StartupLines),
                b'N' => {
                    if state != S::Idle {
                        return Err(ErrorCode::IdleError);
                    }
                    let (n, after) = read_index(tail)?;
                    let line = after.strip_prefix('=').ok_or(ErrorCode::InvalidStatement)?;
                    let n = u8::try_from(n)
                        .ok()
                        .filter(|&n| n < STARTUP_LINES)
                        .ok_or(ErrorCode::InvalidStatement)?;
                    Ok(Command::SetStartupLine {
                        n,
                        line: line.to_string(),
                    })
                }
                _ => {
                    let (id, after) = read_index(&line[1..])?;
                    let after = after.strip_prefix('=').ok_or(ErrorCode::InvalidStatement)?;
                    let (value, used) = read_float(after).ok_or(ErrorCode::BadNumberFormat)?;
                    if used != after.len() {
                        return Err(ErrorCode::InvalidStatement);
                    }
                    let id = u16::try_from(id).map_err(|_| ErrorCode::InvalidStatement)?;
                    if value < 0.0 {
                        return Err(ErrorCode::NegativeValue);
                    }
                    Ok(Command::SetSetting { id, value })
                }
            }
        }
    }
}

/// A number as Grbl's `read_float` reads it (`nuts_bolts.c`): an optional
/// sign, digits with at most one point, no exponent; at least one digit.
/// The value and the bytes used.
pub fn read_float(s: &str) -> Option<(f64, usize)> {
    let b = s.as_bytes();
    let mut i = 0;
    if matches!(b.first(), Some(b'-' | b'+')) {
        i = 1;
    }
    let mut digits = 0;
    let mut point = false;
    while let Some(&c) = b.get(i) {
        if c.is_ascii_digit() {
            digits += 1;
        } else if c == b'.' && !point {
            point = true;
        } else {
            break;
        }
        i += 1;
    }
    if digits == 0 {
        return None;
    }
    let text = &s[..i];
    let text = text.strip_suffix('.').unwrap_or(text);
    let text = if text.ends_with(['-', '+']) || text.is_empty() {
        "0"
    } else {
        text
    };
    text.parse::<f64>().ok().map(|v| (v, i))
}

/// A setting or startup-line index: Grbl's number (2 if there is none),
/// digits only (3 for a sign or a point). The index and what follows.
fn read_index(s: &str) -> Result<(u32, &str), ErrorCode> {
    let (_, used) = read_float(s).ok_or(ErrorCode::BadNumberFormat)?;
    let token = &s[..used];
    if !token.bytes().all(|c| c.is_ascii_digit()) {
        return Err(ErrorCode::InvalidStatement);
    }
    let n = token
        .parse::<u32>()
        .map_err(|_| ErrorCode::InvalidStatement)?;
    Ok((n, &s[used..]))
}

/// Grbl's jog rules (`gc_execute_line` with `GC_PARSER_JOG_MOTION`,
/// `jog.c`), in Grbl's order:
/// 1. each word is a letter then a number (1, 2); a G or M code Grbl
///    does not know is 20, a fraction where none is allowed 23, two of a
///    modal group 21; a value word Grbl does not know (A, B, C, …) 20,
///    one given twice 25, a negative F or N 4;
/// 2. no F: 22 (F is required, G93 ignored);
/// 3. value words other than X Y Z F N (I J K L P R S T): 36;
/// 4. G or M codes other than G20/G21, G90/G91 and G53: 16.
///
/// Where Grbl would reach an earlier check of another command first
/// (e.g. G4 without P, 28), the result here is 16: the block is refused
/// either way. Soft limits (15) need the machine, and are the caller's.
pub fn parse_jog(body: &str) -> Result<Jog, ErrorCode> {
    let mut jog = Jog {
        body: body.to_string(),
        inches: None,
        incremental: None,
        machine: false,
        axes: [None; 3],
        feed: 0.0,
        line_number: None,
    };
    let mut feed = None;
    let mut groups = 0u32; // Grbl's command_words: one bit per modal group.
    let mut prohibited = false;
    let mut unused = false;
    let mut seen = [false; 26];
    let b = body.as_bytes();
    let mut i = 0;
    while i < b.len() {
        let letter = b[i];
        if !letter.is_ascii_uppercase() {
            return Err(ErrorCode::ExpectedCommandLetter);
        }
        i += 1;
        let (value, used) = read_float(&body[i..]).ok_or(ErrorCode::BadNumberFormat)?;
        i += used;
        let int = value.trunc();
        let mantissa = (100.0 * (value - int)).round();
        match letter {
            b'G' | b'M' => {
                let (group, allowed) = if letter == b'G' {
                    g_group(int, mantissa)?
                } else {
                    m_group(int, mantissa)?
                };
                if groups & (1 << group) != 0 {
                    return Err(ErrorCode::GcodeModalGroupViolation);
                }
                groups |= 1 << group;
                if !allowed {
                    prohibited = true;
                }
                match (letter, int as i64) {
                    (b'G', 20) => jog.inches = Some(true),
                    (b'G', 21) => jog.inches = Some(false),
                    (b'G', 90) => jog.incremental = Some(false),
                    (b'G', 91) if mantissa == 0.0 => jog.incremental = Some(true),
                    (b'G', 53) => jog.machine = true,
                    _ => {}
                }
            }
            _ => {
                if !b"FIJKLNPRSTXYZ".contains(&letter) {
                    return Err(ErrorCode::GcodeUnsupportedCommand);
                }
                let k = usize::from(letter - b'A');
                if seen[k] {
                    return Err(ErrorCode::GcodeWordRepeated);
                }
                seen[k] = true;
                match letter {
                    b'F' | b'N' | b'P' | b'S' | b'T' if value < 0.0 => {
                        return Err(ErrorCode::NegativeValue)
                    }
                    b'F' => feed = Some(value),
                    b'N' => {
                        // Grbl's MAX_LINE_NUMBER.
                        if value > 10_000_000.0 {
                            return Err(ErrorCode::GcodeInvalidLineNumber);
                        }
                        jog.line_number = Some(value as u32);
                    }
                    b'X' => jog.axes[0] = Some(value),
                    b'Y' => jog.axes[1] = Some(value),
                    b'Z' => jog.axes[2] = Some(value),
                    _ => unused = true,
                }
            }
        }
    }
    jog.feed = feed.ok_or(ErrorCode::GcodeUndefinedFeedRate)?;
    if unused {
        return Err(ErrorCode::GcodeUnusedWords);
    }
    if prohibited {
        return Err(ErrorCode::InvalidJogCommand);
    }
    Ok(jog)
}

// Grbl's modal groups (`gcode.h` `MODAL_GROUP_*`).
const G_NON_MODAL: u32 = 0;
const G_MOTION: u32 = 1;
const G_PLANE: u32 = 2;
const G_DISTANCE: u32 = 3;
const G_ARC_DISTANCE: u32 = 4;
const G_FEED_MODE: u32 = 5;
const G_UNITS: u32 = 6;
const G_CUTTER: u32 = 7;
const G_TOOL_LENGTH: u32 = 8;
const G_WCS: u32 = 9;
const G_CONTROL: u32 = 10;
const M_STOP: u32 = 11;
const M_SPINDLE: u32 = 12;
const M_COOLANT: u32 = 13;
const M_OVERRIDE: u32 = 14;

/// A G code's modal group and whether a jog may have it
/// (`gc_execute_line`'s `case 'G'`).
fn g_group(int: f64, mantissa: f64) -> Result<(u32, bool), ErrorCode> {
    let m = mantissa as i64;
    let (group, allowed, fraction_ok) = match int as i64 {
        _ if !(0.0..=255.0).contains(&int) => return Err(ErrorCode::GcodeUnsupportedCommand),
        53 => (G_NON_MODAL, true, false),
        4 | 10 => (G_NON_MODAL, false, false),
        28 | 30 | 92 => {
            if m != 0 && m != 10 {
                return Err(ErrorCode::GcodeUnsupportedCommand);
            }
            (G_NON_MODAL, false, true)
        }
        0..=3 | 80 => (G_MOTION, false, false),
        38 => {
            if !matches!(m, 20 | 30 | 40 | 50) {
                return Err(ErrorCode::GcodeUnsupportedCommand);
            }
            (G_MOTION, false, true)
        }
        17..=19 => (G_PLANE, false, false),
        90 | 91 if m == 0 => (G_DISTANCE, true, false),
        90 | 91 => {
            if m != 10 || int == 90.0 {
                return Err(ErrorCode::GcodeUnsupportedCommand);
            }
            (G_ARC_DISTANCE, false, true)
        }
        93 | 94 => (G_FEED_MODE, false, false),
        20 | 21 => (G_UNITS, true, false),
        40 => (G_CUTTER, false, false),
        43 | 49 => {
            if int == 43.0 && m != 10 {
                return Err(ErrorCode::GcodeUnsupportedCommand);
            }
            (G_TOOL_LENGTH, false, true)
        }
        54..=59 => (G_WCS, false, false),
        61 => {
            if m != 0 {
                return Err(ErrorCode::GcodeUnsupportedCommand);
            }
            (G_CONTROL, false, false)
        }
        _ => return Err(ErrorCode::GcodeUnsupportedCommand),
    };
    if m > 0 && !fraction_ok {
        return Err(ErrorCode::GcodeCommandValueNotInteger);
    }
    Ok((group, allowed))
}

/// An M code's modal group (`case 'M'`): none is allowed in a jog.
fn m_group(int: f64, mantissa: f64) -> Result<(u32, bool), ErrorCode> {
    if mantissa > 0.0 {
        return Err(ErrorCode::GcodeCommandValueNotInteger);
    }
    let group = match int as i64 {
        _ if !(0.0..=255.0).contains(&int) => return Err(ErrorCode::GcodeUnsupportedCommand),
        0 | 1 | 2 | 30 => M_STOP,
        3..=5 => M_SPINDLE,
        7..=9 => M_COOLANT,
        56 => M_OVERRIDE,
        _ => return Err(ErrorCode::GcodeUnsupportedCommand),
    };
    Ok((group, false))
}

#[cfg(test)]
mod tests {
    use super::*;
    use ErrorCode::*;
    use MachineState as S;

    fn idle(line: &str) -> Result<Command, ErrorCode> {
        parse(line, S::Idle)
    }

    #[test]
    fn system_commands() {
        assert_eq!(idle(""), Ok(Command::Empty));
        assert_eq!(idle("$"), Ok(Command::Help));
        assert_eq!(idle("$$"), Ok(Command::Settings));
        assert_eq!(idle("$#"), Ok(Command::Parameters));
        assert_eq!(idle("$G"), Ok(Command::ParserState));
        assert_eq!(idle("$I"), Ok(Command::BuildInfo));
        assert_eq!(idle("$I=MILL"), Ok(Command::SetBuildInfo("MILL".into())));
        assert_eq!(idle("$N"), Ok(Command::StartupLines));
        assert_eq!(idle("$C"), Ok(Command::CheckMode));
        assert_eq!(idle("$X"), Ok(Command::Unlock));
        assert_eq!(idle("$H"), Ok(Command::Home { axes: 0 }));
        assert_eq!(idle("$HZ"), Ok(Command::Home { axes: 4 }));
        assert_eq!(idle("$SLP"), Ok(Command::Sleep));
        assert_eq!(idle("$RST=$"), Ok(Command::Restore(Restore::Settings)));
        assert_eq!(idle("$RST=#"), Ok(Command::Restore(Restore::Parameters)));
        assert_eq!(idle("$RST=*"), Ok(Command::Restore(Restore::All)));
        assert_eq!(
            idle("$N0=G20G54"),
            Ok(Command::SetStartupLine {
                n: 0,
                line: "G20G54".into()
            })
        );
        assert_eq!(
            idle("$N1="),
            Ok(Command::SetStartupLine {
                n: 1,
                line: String::new()
            })
        );
        assert_eq!(idle("G0X1"), Ok(Command::Gcode("G0X1".into())));
    }

    #[test]
    fn system_command_errors() {
        for bad in [
            "$$$", "$GX", "$CX", "$XX", "$#1", "$HA", "$HXY", "$SL", "$SLPX", "$IX",
        ] {
            assert_eq!(idle(bad), Err(InvalidStatement), "{bad}");
        }
        for bad in [
            "$RST", "$RST=", "$RST=$$", "$RST=A", "$J", "$JX", "$N2=G0", "$N0G0",
        ] {
            assert_eq!(idle(bad), Err(InvalidStatement), "{bad}");
        }
        assert_eq!(idle("$NA=G0"), Err(BadNumberFormat));
        assert_eq!(idle("$Z"), Err(BadNumberFormat));
    }

    #[test]
    fn setting_writes() {
        assert_eq!(
            idle("$110=500"),
            Ok(Command::SetSetting {
                id: 110,
                value: 500.0
            })
        );
        assert_eq!(
            idle("$27=1.5"),
            Ok(Command::SetSetting { id: 27, value: 1.5 })
        );
        assert_eq!(
            idle("$0=+10"),
            Ok(Command::SetSetting { id: 0, value: 10.0 })
        );
        assert_eq!(
            idle("$12=.002"),
            Ok(Command::SetSetting {
                id: 12,
                value: 0.002
            })
        );
        assert_eq!(
            idle("$12=2."),
            Ok(Command::SetSetting { id: 12, value: 2.0 })
        );
        assert_eq!(
            idle("$208=4"),
            Ok(Command::SetSetting {
                id: 208,
                value: 4.0
            })
        );
        assert_eq!(idle("$0=-1"), Err(NegativeValue));
        assert_eq!(idle("$0="), Err(BadNumberFormat));
        assert_eq!(idle("$0=X"), Err(BadNumberFormat));
        assert_eq!(idle("$0=1.2.3"), Err(InvalidStatement));
        assert_eq!(idle("$0=1E3"), Err(InvalidStatement));
        assert_eq!(idle("$0"), Err(InvalidStatement));
        assert_eq!(idle("$1.5=3"), Err(InvalidStatement));
        assert_eq!(idle("$-1=3"), Err(InvalidStatement));
        assert_eq!(idle("$70000=3"), Err(InvalidStatement));
        assert_eq!(idle("$99999999999999999999=3"), Err(InvalidStatement));
        assert_eq!(idle("$=3"), Err(BadNumberFormat));
    }

    #[test]
    fn state_checks() {
        // G-code.
        for s in [S::Alarm, S::Jog, S::Sleep] {
            assert_eq!(parse("G0X1", s), Err(SystemGcLock), "{s:?}");
            assert_eq!(parse("", s), Ok(Command::Empty));
        }
        assert!(parse("G0X1", S::Check).is_ok());
        assert!(parse("G0X1", S::Run).is_ok());
        // $J: state before syntax.
        assert_eq!(parse("$JX", S::Alarm), Err(IdleError));
        assert!(parse("$J=X1F10", S::Jog).is_ok());
        assert_eq!(parse("$J=X1F10", S::Run), Err(IdleError));
        // $$ blocked in a cycle or hold only.
        assert_eq!(parse("$$", S::Run), Err(IdleError));
        assert_eq!(parse("$$", S::Hold { complete: true }), Err(IdleError));
        assert_eq!(parse("$$", S::Alarm), Ok(Command::Settings));
        assert_eq!(parse("$$X", S::Run), Err(InvalidStatement));
        // $G, $X, $ any time.
        for s in [S::Run, S::Alarm, S::Jog, S::Home, S::Sleep] {
            assert_eq!(parse("$G", s), Ok(Command::ParserState));
            assert_eq!(parse("$X", s), Ok(Command::Unlock));
            assert_eq!(parse("$", s), Ok(Command::Help));
        }
        // $C from Idle or to leave Check.
        assert_eq!(parse("$C", S::Check), Ok(Command::CheckMode));
        assert_eq!(parse("$C", S::Alarm), Err(IdleError));
        // The rest in Idle or Alarm, before syntax.
        for line in [
            "$#", "$H", "$I", "$N", "$SLP", "$RST=$", "$10=1", "$#X", "$Q",
        ] {
            assert_eq!(parse(line, S::Run), Err(IdleError), "{line}");
            assert_eq!(parse(line, S::Check), Err(IdleError), "{line}");
        }
        assert_eq!(parse("$H", S::Alarm), Ok(Command::Home { axes: 0 }));
        assert_eq!(
            parse("$10=1", S::Alarm),
            Ok(Command::SetSetting { id: 10, value: 1.0 })
        );
        // Storing a startup line: Idle only.
        assert_eq!(parse("$N0=G20", S::Alarm), Err(IdleError));
        assert_eq!(parse("$N", S::Alarm), Ok(Command::StartupLines));
    }

    fn jog(body: &str) -> Result<Jog, ErrorCode> {
        match idle(&format!("$J={body}")) {
            Ok(Command::Jog(j)) => Ok(j),
            Ok(c) => panic!("{c:?}"),
            Err(e) => Err(e),
        }
    }

    #[test]
    fn jogs() {
        let j = jog("G91X10.5Y-2F1000").unwrap();
        assert_eq!(j.body, "G91X10.5Y-2F1000");
        assert_eq!(j.incremental, Some(true));
        assert_eq!(j.inches, None);
        assert_eq!(j.axes, [Some(10.5), Some(-2.0), None]);
        assert_eq!(j.feed, 1000.0);
        let j = jog("G20G90G53Z1F10N5").unwrap();
        assert_eq!(
            (j.inches, j.incremental, j.machine),
            (Some(true), Some(false), true)
        );
        assert_eq!(j.line_number, Some(5));
        assert_eq!(j.feed_mm_per_min(false), 254.0);
        assert_eq!(jog("G21X1F10").unwrap().feed_mm_per_min(true), 10.0);
        assert_eq!(jog("X1F10").unwrap().feed_mm_per_min(true), 254.0);
        // No axis words: a jog that goes nowhere, as in Grbl.
        assert!(jog("F100").is_ok());
    }

    #[test]
    fn jog_errors() {
        let cases = [
            ("X10", GcodeUndefinedFeedRate),
            ("G91X10", GcodeUndefinedFeedRate),
            ("G1X10F100", InvalidJogCommand),
            ("G0X10F100", InvalidJogCommand),
            ("G4P1F100", GcodeUnusedWords),
            ("G28F100", InvalidJogCommand),
            ("G54X1F100", InvalidJogCommand),
            ("G93X1F100", InvalidJogCommand),
            ("G91.1X1F100", InvalidJogCommand),
            ("M3X1F100", InvalidJogCommand),
            ("X1F100S1000", GcodeUnusedWords),
            ("X1F100I1", GcodeUnusedWords),
            ("X1F100T1", GcodeUnusedWords),
            ("X1X2F100", GcodeWordRepeated),
            ("X1F100F200", GcodeWordRepeated),
            ("G90G91X1F100", GcodeModalGroupViolation),
            ("G20G21X1F100", GcodeModalGroupViolation),
            ("G53G53X1F100", GcodeModalGroupViolation),
            ("A1F100", GcodeUnsupportedCommand),
            ("G5X1F100", GcodeUnsupportedCommand),
            ("G90.1X1F100", GcodeUnsupportedCommand),
            ("G38.1X1F100", GcodeUnsupportedCommand),
            ("G20.5X1F100", GcodeCommandValueNotInteger),
            ("M3.5X1F100", GcodeCommandValueNotInteger),
            ("M6X1F100", GcodeUnsupportedCommand),
            ("X1F-100", NegativeValue),
            ("X1F100N-1", NegativeValue),
            ("X1F100N99999999", GcodeInvalidLineNumber),
            ("1X", ExpectedCommandLetter),
            ("X", BadNumberFormat),
            ("X-F1", BadNumberFormat),
            ("G-99999999999X1F1", GcodeUnsupportedCommand),
            // `e` is not a word letter: no exponents.
            ("G1e300X1F1", ExpectedCommandLetter),
        ];
        for (body, code) in cases {
            assert_eq!(jog(body), Err(code), "{body}");
        }
        assert_eq!(idle("$\u{e9}"), Err(InvalidStatement));
        assert_eq!(idle("$J=X\u{e9}F1"), Err(BadNumberFormat));
    }

    #[test]
    fn no_panic_on_any_line() {
        let alphabet = b"$JGCXHNIRST=#*.-+0123456789FYZM ";
        let mut x: u32 = 0x9E37_79B9;
        for _ in 0..50_000 {
            let mut s = String::new();
            for _ in 0..(x % 12) {
                x ^= x << 13;
                x ^= x >> 17;
                x ^= x << 5;
                s.push(char::from(alphabet[(x as usize) % alphabet.len()]));
            }
            x = x.wrapping_add(1);
            for st in [S::Idle, S::Alarm, S::Jog, S::Run, S::Check] {
                let _ = parse(&s, st);
            }
        }
        assert_eq!(read_float("-"), None);
        assert_eq!(read_float("-.5"), Some((-0.5, 3)));
        assert_eq!(read_float("1.2.3"), Some((1.2, 3)));
    }
}
