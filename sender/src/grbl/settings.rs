//! Grbl's `$` settings on our controller: which of Grbl's numbers are
//! ours unchanged, which are converted, which the front keeps, which are
//! fixed ([`GRBL_SETTINGS`]); the `$$` listing ([`listing`]) and the
//! checks of a `$n=value` write ([`write()`]).
//!
//! Our controller numbers its settings as Grbl does where it has the same
//! setting (`controller/src/config.rs`), in integers scaled by
//! `SettingInfo::decimals`; Grbl's are floats (`grbl/settings.c`
//! `settings_store_global_setting`, `grbl/report.c`
//! `report_grbl_settings`).
//!
//! | `$` | Grbl | here |
//! |---|---|---|
//! | 0 | step pulse, µs (integer) | ours `$0` (0.001 µs steps; fractions shown) |
//! | 1 | step idle delay, ms | fixed 255 (drivers stay enabled; ours disable them in an alarm only) |
//! | 2, 3 | step, direction invert masks | ours |
//! | 4 | step enable invert | ours |
//! | 5 | limit pins invert (0/1) | ours, a mask per switch (bit 0 X min … 5 Z max): 1 is written as 63 (all), 63 read as 1; 2-62 pass as masks |
//! | 6 | probe pin invert | ours |
//! | 10 | status report mask | the front's |
//! | 11 | junction deviation, mm | fixed 0.010 (Grbl's default; ours corners by `$203` chord tolerance and `$208` smoothing) |
//! | 12 | arc tolerance, mm | the front's (the interpreter's chord tolerance) |
//! | 13 | report inches | the front's |
//! | 20-25, 27 | limits and homing | ours |
//! | 26 | homing debounce, ms | ours `$26` in ticks of `$200` Hz, converted |
//! | 30, 31 | spindle rpm max, min | ours |
//! | 32 | laser mode | fixed 0 |
//! | 100-132 | steps/mm, mm/min, mm/s², mm | ours (acceleration in mm/s² both) |
//!
//! Ours that Grbl lacks are listed after Grbl's in `$$` and written
//! likewise: `$14` e-stop invert, `$33` spindle PWM Hz, `$44`-`$46` homing
//! passes (grblHAL's numbers and meanings), `$200`-`$208`.
//!
//! Refusals: a fixed setting accepts its own value (`ok`, so a sender
//! restoring a Grbl backup goes on) and refuses any other with error 3,
//! as Grbl refuses an unknown one; a value outside our range is error 3
//! too (Grbl 1.1 has no range error; grblHAL's is 52, which Grbl senders
//! do not know), each with a `[MSG:]` saying why. Grbl's own checks kept:
//! negative values 4 ([`super::command::parse`]), soft limits without
//! homing 10, and `$22=0` also clearing `$20`. Grbl's 3 µs floor on `$0`
//! (error 6) is not kept: ours allows 0.1 µs.

use controller::config::{index_of, SETTINGS};

use super::codes::ErrorCode;
use super::report::{grbl_float, MASK_MPOS};

/// How a Grbl setting is printed by Grbl (`report_grbl_settings`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Print {
    /// An integer (`report_util_uint8_setting`); ours with fractions
    /// show them.
    Int,
    /// Three decimals (`N_DECIMAL_SETTINGVALUE`).
    Float,
    /// No decimals (`N_DECIMAL_RPMVALUE`).
    Rpm,
    /// Ours, not Grbl's: with its own decimals.
    Native,
}

/// Where a Grbl setting's value lives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Source {
    /// Our controller's setting of the same number and unit.
    Same,
    /// `$5`: Grbl's 0/1 against our per-switch mask.
    LimitInvert,
    /// `$26`: Grbl's milliseconds against our ticks of the `$200` rate.
    DebounceMs,
    /// Kept by the front.
    Front(FrontKey),
    /// Fixed: reported, not stored.
    Fixed(f64),
}

/// The settings the front keeps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrontKey {
    /// `$10`.
    StatusMask,
    /// `$12`.
    ArcTolerance,
    /// `$13`.
    ReportInches,
}

/// One `$` setting as a Grbl sender sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GrblSetting {
    /// `$n`.
    pub id: u16,
    /// Its meaning (Grbl's short name).
    pub name: &'static str,
    /// Its unit, in Grbl's terms.
    pub unit: &'static str,
    /// How it is printed.
    pub print: Print,
    /// Where it lives.
    pub source: Source,
}

const fn g(
    id: u16,
    name: &'static str,
    unit: &'static str,
    print: Print,
    source: Source,
) -> GrblSetting {
    GrblSetting {
        id,
        name,
        unit,
        print,
        source,
    }
}

/// Grbl 1.1's settings, in Grbl's order.
pub const GRBL_SETTINGS: [GrblSetting; 34] = {
    use Print::*;
    use Source::*;
    [
        g(0, "step pulse", "µs", Int, Same),
        g(1, "step idle delay", "ms", Int, Fixed(255.0)),
        g(2, "step port invert", "mask", Int, Same),
        g(3, "direction port invert", "mask", Int, Same),
        g(4, "step enable invert", "bool", Int, Same),
        g(5, "limit pins invert", "bool", Int, LimitInvert),
        g(6, "probe pin invert", "bool", Int, Same),
        g(
            10,
            "status report",
            "mask",
            Int,
            Front(FrontKey::StatusMask),
        ),
        g(11, "junction deviation", "mm", Float, Fixed(0.010)),
        g(
            12,
            "arc tolerance",
            "mm",
            Float,
            Front(FrontKey::ArcTolerance),
        ),
        g(
            13,
            "report inches",
            "bool",
            Int,
            Front(FrontKey::ReportInches),
        ),
        g(20, "soft limits", "bool", Int, Same),
        g(21, "hard limits", "bool", Int, Same),
        g(22, "homing cycle", "bool", Int, Same),
        g(23, "homing dir invert", "mask", Int, Same),
        g(24, "homing feed", "mm/min", Float, Same),
        g(25, "homing seek", "mm/min", Float, Same),
        g(26, "homing debounce", "ms", Int, DebounceMs),
        g(27, "homing pull-off", "mm", Float, Same),
        g(30, "max spindle speed", "rpm", Rpm, Same),
        g(31, "min spindle speed", "rpm", Rpm, Same),
        g(32, "laser mode", "bool", Int, Fixed(0.0)),
        g(100, "X steps/mm", "steps/mm", Float, Same),
        g(101, "Y steps/mm", "steps/mm", Float, Same),
        g(102, "Z steps/mm", "steps/mm", Float, Same),
        g(110, "X max rate", "mm/min", Float, Same),
        g(111, "Y max rate", "mm/min", Float, Same),
        g(112, "Z max rate", "mm/min", Float, Same),
        g(120, "X acceleration", "mm/s^2", Float, Same),
        g(121, "Y acceleration", "mm/s^2", Float, Same),
        g(122, "Z acceleration", "mm/s^2", Float, Same),
        g(130, "X max travel", "mm", Float, Same),
        g(131, "Y max travel", "mm", Float, Same),
        g(132, "Z max travel", "mm", Float, Same),
    ]
};

/// Our setting that gives `$200` (the tick rate, Hz), for `$26`.
const TICK_HZ_ID: u16 = 200;
/// `$5` written as 1: every switch inverted.
const ALL_LIMITS: i64 = 63;

/// The settings the front keeps, with Grbl's defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrontSettings {
    /// `$10` (Grbl's default 1: MPos, no `Bf:`).
    pub status_mask: u8,
    /// `$13`.
    pub report_inches: bool,
    /// `$12`, mm (Grbl's default 0.002), for the interpreter's chord
    /// tolerance.
    pub arc_tolerance_mm: f64,
}

impl Default for FrontSettings {
    fn default() -> Self {
        FrontSettings {
            status_mask: MASK_MPOS,
            report_inches: false,
            arc_tolerance_mm: 0.002,
        }
    }
}

/// The setting `$id`: Grbl's entry, or ours with [`Print::Native`].
pub fn lookup(id: u16) -> Option<GrblSetting> {
    if let Some(s) = GRBL_SETTINGS.iter().find(|s| s.id == id) {
        return Some(*s);
    }
    let info = SETTINGS[index_of(id)?];
    Some(GrblSetting {
        id,
        name: info.name,
        unit: info.unit,
        print: Print::Native,
        source: Source::Same,
    })
}

/// Every id `$$` lists: Grbl's and ours, in order.
pub fn ids() -> Vec<u16> {
    let mut v: Vec<u16> = GRBL_SETTINGS
        .iter()
        .map(|s| s.id)
        .chain(SETTINGS.iter().map(|s| s.id))
        .collect();
    v.sort_unstable();
    v.dedup();
    v
}

fn scale(id: u16) -> Option<(u8, f64)> {
    let info = SETTINGS[index_of(id)?];
    Some((info.decimals, 10f64.powi(i32::from(info.decimals))))
}

/// A value with up to `decimals` places, trailing zeros dropped.
fn trimmed(v: f64, decimals: u8) -> String {
    let s = grbl_float(v, decimals);
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// The value of `$id` as `$$` prints it, from our controller's values
/// (`ctrl`: raw, by id) and the front's; `None` for an unknown id or a
/// value the controller did not give.
pub fn value_text(
    id: u16,
    ctrl: &dyn Fn(u16) -> Option<i64>,
    front: &FrontSettings,
) -> Option<String> {
    let s = lookup(id)?;
    let v = match s.source {
        Source::Fixed(v) => v,
        Source::Front(FrontKey::StatusMask) => f64::from(front.status_mask),
        Source::Front(FrontKey::ReportInches) => f64::from(u8::from(front.report_inches)),
        Source::Front(FrontKey::ArcTolerance) => front.arc_tolerance_mm,
        Source::Same => {
            let (_, k) = scale(id)?;
            ctrl(id)? as f64 / k
        }
        Source::LimitInvert => match ctrl(id)? {
            ALL_LIMITS => 1.0,
            m => m as f64,
        },
        Source::DebounceMs => {
            let ticks = ctrl(id)? as f64;
            let hz = ctrl(TICK_HZ_ID)? as f64;
            if hz <= 0.0 {
                return None;
            }
            (ticks * 1000.0 / hz).round()
        }
    };
    Some(match s.print {
        Print::Int => trimmed(v, 3),
        Print::Float => grbl_float(v, 3),
        Print::Rpm => grbl_float(v, 0),
        Print::Native => {
            let d = scale(id).map_or(0, |(d, _)| d);
            grbl_float(v, d)
        }
    })
}

/// The `$$` lines (each `$n=value\r\n`; the `ok` is the caller's);
/// settings whose value the controller did not give are left out.
pub fn listing(ctrl: &dyn Fn(u16) -> Option<i64>, front: &FrontSettings) -> String {
    ids()
        .into_iter()
        .filter_map(|id| value_text(id, ctrl, front).map(|v| super::report::setting(id, &v)))
        .collect()
}

/// What a `$n=value` write does.
#[derive(Clone, Debug, PartialEq)]
pub enum Write {
    /// Send these (id, raw value) to the controller, in order; `ok` once
    /// it has taken them (its refusal: [`refusal_of_link`]).
    Controller(Vec<(u16, i64)>),
    /// Stored in the front's settings; `ok`. `flag_wco`: `$13` changed the
    /// report units, send `WCO:` next
    /// ([`super::report::StatusReporter::flag_wco`]; Grbl
    /// `system_flag_wco_change`).
    Front {
        /// Send `WCO:` in the next report.
        flag_wco: bool,
    },
    /// A fixed setting written with its own value: `ok`, nothing to do.
    Unchanged,
}

/// A refused write: `[MSG:message]` then `error:code`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Refusal {
    /// The error.
    pub code: ErrorCode,
    /// Why.
    pub message: String,
}

fn refuse(code: ErrorCode, message: String) -> Refusal {
    Refusal { code, message }
}

/// Check `$id=value` (a value ≥ 0, as [`super::command::parse`] gives)
/// against the table and our ranges; front settings are stored in
/// `front`. `ctrl` gives our controller's current raw values (for `$22`
/// before `$20`, `$200` for `$26`).
pub fn write(
    id: u16,
    value: f64,
    ctrl: &dyn Fn(u16) -> Option<i64>,
    front: &mut FrontSettings,
) -> Result<Write, Refusal> {
    let Some(s) = lookup(id) else {
        return Err(refuse(
            ErrorCode::InvalidStatement,
            format!("${id} is not a setting"),
        ));
    };
    if !value.is_finite() || value < 0.0 {
        return Err(refuse(ErrorCode::NegativeValue, format!("${id}: negative")));
    }
    // Grbl's integer settings take the integer part (`trunc`).
    let int = value.trunc();
    match s.source {
        Source::Fixed(v) => {
            if (value - v).abs() < 1e-9 {
                Ok(Write::Unchanged)
            } else {
                Err(refuse(
                    ErrorCode::InvalidStatement,
                    format!("${id} ({}) is fixed at {} here", s.name, trimmed(v, 3)),
                ))
            }
        }
        Source::Front(key) => {
            match key {
                FrontKey::StatusMask => {
                    if int > 255.0 {
                        return Err(refuse(
                            ErrorCode::InvalidStatement,
                            format!("${id}: 0 to 255"),
                        ));
                    }
                    front.status_mask = int as u8;
                }
                FrontKey::ReportInches => front.report_inches = int != 0.0,
                FrontKey::ArcTolerance => {
                    if value < 1e-6 {
                        return Err(refuse(
                            ErrorCode::InvalidStatement,
                            format!("${id}: at least 0.000001 mm"),
                        ));
                    }
                    front.arc_tolerance_mm = value;
                }
            }
            Ok(Write::Front {
                flag_wco: key == FrontKey::ReportInches,
            })
        }
        Source::LimitInvert => {
            let raw = if int == 1.0 { ALL_LIMITS } else { int as i64 };
            in_range(id, raw).map(|raw| Write::Controller(vec![(id, raw)]))
        }
        Source::DebounceMs => {
            let hz = ctrl(TICK_HZ_ID).filter(|&hz| hz > 0).ok_or_else(|| {
                refuse(
                    ErrorCode::InvalidStatement,
                    format!("${id}: the tick rate ${TICK_HZ_ID} is unknown"),
                )
            })?;
            let ticks = (value * hz as f64 / 1000.0).round().max(1.0);
            in_range(id, ticks as i64).map(|raw| Write::Controller(vec![(id, raw)]))
        }
        Source::Same => {
            let Some((decimals, k)) = scale(id) else {
                return Err(refuse(
                    ErrorCode::InvalidStatement,
                    format!("${id} is not a setting"),
                ));
            };
            let unit = SETTINGS[index_of(id).unwrap_or(0)].unit;
            let raw = if unit == "bool" {
                i64::from(int != 0.0)
            } else if decimals == 0 && s.print == Print::Int {
                int as i64
            } else {
                (value * k).round() as i64
            };
            let raw = in_range(id, raw)?;
            match (id, raw) {
                (20, 1) if ctrl(22) == Some(0) => Err(refuse(
                    ErrorCode::SoftLimitError,
                    "soft limits need homing ($22=1)".to_string(),
                )),
                (22, 0) if ctrl(20).is_some_and(|v| v != 0) => {
                    Ok(Write::Controller(vec![(22, 0), (20, 0)]))
                }
                _ => Ok(Write::Controller(vec![(id, raw)])),
            }
        }
    }
}

/// `raw` if within our range of `$id`, else error 3 with the range.
fn in_range(id: u16, raw: i64) -> Result<i64, Refusal> {
    let Some(i) = index_of(id) else {
        return Err(refuse(
            ErrorCode::InvalidStatement,
            format!("${id} is not a setting"),
        ));
    };
    let info = SETTINGS[i];
    if (info.min..=info.max).contains(&raw) {
        return Ok(raw);
    }
    let k = 10f64.powi(i32::from(info.decimals));
    Err(refuse(
        ErrorCode::InvalidStatement,
        format!(
            "${id}: {} to {} {}",
            trimmed(info.min as f64 / k, info.decimals),
            trimmed(info.max as f64 / k, info.decimals),
            info.unit
        ),
    ))
}

/// Our controller's refusal of a setting write as a Grbl error: not at
/// rest or outputs on is 8 ("not idle"), in an alarm 9, anything else 3.
pub fn refusal_of_link(e: link::ErrorCode) -> ErrorCode {
    match e {
        link::ErrorCode::Busy | link::ErrorCode::OutputsOn => ErrorCode::IdleError,
        link::ErrorCode::Alarm => ErrorCode::SystemGcLock,
        _ => ErrorCode::InvalidStatement,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use controller::config::Config;

    fn defaults(id: u16) -> Option<i64> {
        Config::DEFAULT.by_id(id).ok()
    }

    #[test]
    fn every_grbl_setting_resolves() {
        let front = FrontSettings::default();
        for s in GRBL_SETTINGS {
            if s.source == Source::Same || s.source == Source::LimitInvert {
                assert!(index_of(s.id).is_some(), "${} is not ours", s.id);
            }
            assert!(value_text(s.id, &defaults, &front).is_some(), "${}", s.id);
        }
        // Ours that are not Grbl's are listed too.
        let ids = ids();
        for info in SETTINGS {
            assert!(ids.contains(&info.id));
        }
        assert!(ids.windows(2).all(|w| w[0] < w[1]));
        let text = listing(&defaults, &front);
        assert_eq!(text.lines().count(), ids.len());
        assert!(text.starts_with("$0="));
        assert!(text.contains("$1=255\r\n$2="));
        assert!(text.contains("$10=1\r\n"));
        assert!(text.contains("$11=0.010\r\n"));
        assert!(text.contains("$12=0.002\r\n"));
        assert!(text.contains("$32=0\r\n"));
        assert!(text.ends_with("\r\n"));
        assert_eq!(value_text(7, &defaults, &front), None);
        assert_eq!(value_text(20, &|_| None, &front), None);
    }

    fn with(values: &'static [(u16, i64)]) -> impl Fn(u16) -> Option<i64> {
        move |id| {
            values
                .iter()
                .find(|(i, _)| *i == id)
                .map(|(_, v)| *v)
                .or_else(|| defaults(id))
        }
    }

    #[test]
    fn values_printed_as_grbl() {
        let f = FrontSettings::default();
        let c = with(&[
            (0, 2500),
            (5, 63),
            (26, 3),
            (200, 1000),
            (27, 1500),
            (110, 5000),
            (30, 24000),
            (100, 80000),
        ]);
        assert_eq!(value_text(0, &c, &f).unwrap(), "2.5");
        assert_eq!(value_text(5, &c, &f).unwrap(), "1");
        assert_eq!(value_text(26, &c, &f).unwrap(), "3");
        assert_eq!(value_text(27, &c, &f).unwrap(), "1.500");
        assert_eq!(value_text(110, &c, &f).unwrap(), "5000.000");
        assert_eq!(value_text(30, &c, &f).unwrap(), "24000");
        assert_eq!(value_text(100, &c, &f).unwrap(), "80.000");
        let c = with(&[(0, 10_000), (5, 5), (26, 5), (200, 2000)]);
        assert_eq!(value_text(0, &c, &f).unwrap(), "10");
        assert_eq!(value_text(5, &c, &f).unwrap(), "5");
        assert_eq!(value_text(26, &c, &f).unwrap(), "3");
        // Ours with their own decimals.
        let c = with(&[(205, 1500), (200, 1000)]);
        assert_eq!(value_text(205, &c, &f).unwrap(), "1.500");
        assert_eq!(value_text(200, &c, &f).unwrap(), "1000");
    }

    #[test]
    fn writes() {
        let mut f = FrontSettings::default();
        let c = with(&[(200, 1000), (22, 1), (20, 0)]);
        let ctl = |id: u16, raw: i64| Ok(Write::Controller(vec![(id, raw)]));
        assert_eq!(write(0, 2.5, &c, &mut f), ctl(0, 2500));
        assert_eq!(write(2, 5.9, &c, &mut f), ctl(2, 5));
        assert_eq!(write(5, 1.0, &c, &mut f), ctl(5, 63));
        assert_eq!(write(5, 0.0, &c, &mut f), ctl(5, 0));
        assert_eq!(write(5, 12.0, &c, &mut f), ctl(5, 12));
        assert_eq!(write(21, 7.0, &c, &mut f), ctl(21, 1));
        assert_eq!(write(26, 25.0, &c, &mut f), ctl(26, 25));
        assert_eq!(write(27, 2.25, &c, &mut f), ctl(27, 2250));
        assert_eq!(write(100, 80.0005, &c, &mut f), ctl(100, 80001));
        assert_eq!(write(110, 1500.4, &c, &mut f), ctl(110, 1500));
        assert_eq!(write(120, 300.0, &c, &mut f), ctl(120, 300));
        assert_eq!(write(20, 1.0, &c, &mut f), ctl(20, 1));
        assert_eq!(write(208, 4.0, &c, &mut f), ctl(208, 4));
        // Front settings.
        assert_eq!(
            write(10, 3.0, &c, &mut f),
            Ok(Write::Front { flag_wco: false })
        );
        assert_eq!(f.status_mask, 3);
        assert_eq!(
            write(13, 1.0, &c, &mut f),
            Ok(Write::Front { flag_wco: true })
        );
        assert!(f.report_inches);
        assert_eq!(
            write(12, 0.01, &c, &mut f),
            Ok(Write::Front { flag_wco: false })
        );
        assert_eq!(f.arc_tolerance_mm, 0.01);
        // Fixed ones accept their value only.
        assert_eq!(write(1, 255.0, &c, &mut f), Ok(Write::Unchanged));
        assert_eq!(write(11, 0.01, &c, &mut f), Ok(Write::Unchanged));
        let r = write(1, 25.0, &c, &mut f).unwrap_err();
        assert_eq!(r.code, ErrorCode::InvalidStatement);
        assert!(r.message.contains("fixed at 255"), "{}", r.message);
    }

    #[test]
    fn refused_writes() {
        let mut f = FrontSettings::default();
        let c = with(&[(200, 1000), (22, 0), (20, 1)]);
        let code = |r: Result<Write, Refusal>| r.unwrap_err().code;
        assert_eq!(code(write(7, 1.0, &c, &mut f)), ErrorCode::InvalidStatement);
        assert_eq!(
            code(write(150, 1.0, &c, &mut f)),
            ErrorCode::InvalidStatement
        );
        assert_eq!(code(write(0, -1.0, &c, &mut f)), ErrorCode::NegativeValue);
        assert_eq!(
            code(write(0, f64::NAN, &c, &mut f)),
            ErrorCode::NegativeValue
        );
        let r = write(0, 0.01, &c, &mut f).unwrap_err();
        assert_eq!(r.code, ErrorCode::InvalidStatement);
        assert_eq!(r.message, "$0: 0.1 to 20 µs");
        assert_eq!(
            code(write(5, 64.0, &c, &mut f)),
            ErrorCode::InvalidStatement
        );
        assert_eq!(
            code(write(110, 1e300, &c, &mut f)),
            ErrorCode::InvalidStatement
        );
        assert_eq!(
            code(write(10, 256.0, &c, &mut f)),
            ErrorCode::InvalidStatement
        );
        assert_eq!(
            code(write(12, 0.0, &c, &mut f)),
            ErrorCode::InvalidStatement
        );
        assert_eq!(
            code(write(32, 1.0, &c, &mut f)),
            ErrorCode::InvalidStatement
        );
        // Soft limits need homing; homing off clears soft limits.
        assert_eq!(code(write(20, 1.0, &c, &mut f)), ErrorCode::SoftLimitError);
        assert_eq!(
            write(22, 0.0, &c, &mut f),
            Ok(Write::Controller(vec![(22, 0), (20, 0)]))
        );
        // $26 needs the tick rate.
        assert_eq!(
            code(write(26, 5.0, &|_| None, &mut f)),
            ErrorCode::InvalidStatement
        );
        assert_eq!(
            code(write(26, 1e9, &c, &mut f)),
            ErrorCode::InvalidStatement
        );
        assert_eq!(refusal_of_link(link::ErrorCode::Busy), ErrorCode::IdleError);
        assert_eq!(
            refusal_of_link(link::ErrorCode::OutOfRange),
            ErrorCode::InvalidStatement
        );
    }
}
