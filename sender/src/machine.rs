//! The machine around the motion, as a Grbl user meets it: alarms by name
//! (with Grbl's nearest alarm number), the machine status (alarm, homing,
//! spindle, coolant, inputs, the settings store), and the `$` settings
//! listed, read and written with the names, units and decimals of the
//! controller's own table (`controller::config::SETTINGS`).

use controller::alarm::{limit_bit, ESTOP};
use controller::config::{SettingInfo, SETTINGS};
use std::time::{Duration, Instant};

use link::{
    AlarmCode, DeviceMsg, ErrorCode, HostMsg, MachineStatus, Motion, SpindleDir, StoreResult,
};

use crate::exit::{Exit, Failure};
use crate::stream::Session;

/// An axis letter.
fn axis(a: u8) -> char {
    match a {
        0 => 'X',
        1 => 'Y',
        2 => 'Z',
        _ => '?',
    }
}

/// Axes of a mask (bit 0 X), as letters; `none` if empty.
pub fn axes_text(mask: u8) -> String {
    let s: String = (0..3).filter(|a| mask >> a & 1 != 0).map(axis).collect();
    if s.is_empty() {
        "none".into()
    } else {
        s
    }
}

/// What an alarm means, with Grbl's (or grblHAL's) nearest alarm number
/// where there is one (the table in `firmware/README.md`, "Alarms").
pub fn alarm_text(code: AlarmCode) -> String {
    match code {
        AlarmCode::EStopInput => "e-stop input active (grblHAL ALARM:10)".into(),
        AlarmCode::EStopLink => "e-stop from the host (grblHAL ALARM:10)".into(),
        AlarmCode::HardLimit { axis: a, max } => format!(
            "hard limit: {} {} switch (Grbl ALARM:1)",
            axis(a),
            if max { "max" } else { "min" }
        ),
        AlarmCode::SoftLimit => {
            "soft limit: the motion would leave the travel (Grbl ALARM:2)".into()
        }
        AlarmCode::Watchdog => "the firmware was restarted by its watchdog".into(),
        AlarmCode::StepLag => "the step output fell behind the commanded position".into(),
        AlarmCode::LinkLoss => {
            "link loss: the path stopped arriving and the link went silent".into()
        }
        AlarmCode::HomingNoSwitch { axis: a } => format!(
            "homing failed: {} switch not found within the search distance (Grbl ALARM:9)",
            axis(a)
        ),
        AlarmCode::HomingPullOff { axis: a } => format!(
            "homing failed: {} switch still active after the pull-off (Grbl ALARM:8)",
            axis(a)
        ),
        AlarmCode::HomingAborted => "homing interrupted (Grbl ALARM:6)".into(),
        AlarmCode::Fault { pc } => format!(
            "the firmware restarted after a hard fault at 0x{pc:08x} (a bug: please report it with this address and the firmware build)"
        ),
        AlarmCode::ProbeFailInitial => {
            "probe: already in the state the move watches for before it started (Grbl ALARM:4)"
                .into()
        }
        AlarmCode::ProbeFailContact => {
            "probe: no contact by the end of the move (Grbl ALARM:5)".into()
        }
    }
}

/// Whether the position may be trusted after this alarm: an alarm stops
/// without deceleration (steps may be lost), except link loss, which
/// comes after a controlled stop, and the probe's, raised at rest.
pub fn position_kept(code: AlarmCode) -> bool {
    matches!(
        code,
        AlarmCode::LinkLoss | AlarmCode::ProbeFailInitial | AlarmCode::ProbeFailContact
    )
}

/// What to do about an alarm, for messages.
pub const UNLOCK_HINT: &str =
    "clear it with `fuzzy-send unlock` (Grbl's $X) once the cause is gone";

fn store_text(s: StoreResult) -> &'static str {
    match s {
        StoreResult::Loaded => "read from flash",
        StoreResult::Empty => "nothing stored (defaults)",
        StoreResult::Corrupt => "the stored record was corrupt (last good record or defaults)",
        StoreResult::OldVersion => "stored by another firmware version (defaults)",
        StoreResult::Saved => "saved to flash",
        StoreResult::WriteFailed => "the last write to flash failed (in force until a reset)",
    }
}

/// What became of a settings write ([`link::DeviceMsg::Stored`]).
pub fn stored_text(s: StoreResult) -> &'static str {
    store_text(s)
}

/// The machine status in a few lines.
pub fn machine_text(m: &MachineStatus) -> String {
    let alarm = match m.alarm {
        Some(c) => format!("ALARM: {} ({UNLOCK_HINT})", alarm_text(c)),
        None => "none".into(),
    };
    let spindle = match m.spindle {
        SpindleDir::Off => "off".to_string(),
        SpindleDir::Cw => format!("clockwise (M3) at {} rpm", m.speed_rpm),
        SpindleDir::Ccw => format!("counter-clockwise (M4) at {} rpm", m.speed_rpm),
    };
    let coolant = match (m.flood, m.mist) {
        (false, false) => "off",
        (true, false) => "flood (M8)",
        (false, true) => "mist (M7)",
        (true, true) => "flood and mist",
    };
    let mut inputs = Vec::new();
    if m.inputs & ESTOP != 0 {
        inputs.push("e-stop".to_string());
    }
    for a in 0..3u8 {
        for (end, max) in [("min", false), ("max", true)] {
            if m.inputs & limit_bit(a as usize, max) != 0 {
                inputs.push(format!("{} {end}", axis(a)));
            }
        }
    }
    let inputs = if inputs.is_empty() {
        "none active".to_string()
    } else {
        format!("{} active", inputs.join(", "))
    };
    format!(
        "alarm: {alarm}\nalarms since boot: {}\nhoming: {}homed axes {}\nspindle: {spindle}\ncoolant: {coolant}\ninputs: {inputs}\nsettings: {}{}\n",
        m.alarms,
        if m.homing { "running, " } else { "" },
        axes_text(m.homed),
        store_text(m.store),
        if m.restart_needed {
            "; a changed setting takes effect at the next reset"
        } else {
            ""
        }
    )
}

/// The setting with this id.
pub fn setting(id: u16) -> Option<&'static SettingInfo> {
    SETTINGS.iter().find(|s| s.id == id)
}

/// What to tell a user whose shell may have expanded an unquoted `$N`
/// (`$100` reaches the program as `00`: `$1` is the shell's first
/// positional argument, usually empty).
const QUOTE_HINT: &str =
    "an unquoted `$100` reaches fuzzy-send as `00` (the shell expands `$1`): quote it, '$100', or drop the `$`: 100";

/// A setting's id from `N` or `$N`. A bare `$`, an empty id and ids with
/// a leading zero are refused: they are what a shell leaves of an
/// unquoted `$N`, and taken as numbers they would name another setting.
pub fn parse_id(s: &str) -> Result<u16, String> {
    let t = s.trim();
    let t = t.strip_prefix('$').unwrap_or(t);
    if t.is_empty() {
        return Err(format!("{s:?}: no setting number; {QUOTE_HINT}"));
    }
    if t.len() > 1 && t.starts_with('0') {
        return Err(format!(
            "{s:?}: a setting number with a leading zero; {QUOTE_HINT}"
        ));
    }
    let id: u16 = t
        .parse()
        .map_err(|_| format!("{s:?}: a setting is a number, `N` or `$N`"))?;
    if setting(id).is_none() {
        return Err(format!(
            "${id}: no such setting (`fuzzy-send settings` lists them)"
        ));
    }
    Ok(id)
}

/// A raw value in the setting's unit (`decimals` places), exactly.
pub fn format_value(info: &SettingInfo, raw: i64) -> String {
    if info.decimals == 0 {
        return raw.to_string();
    }
    let scale = 10i64.pow(info.decimals as u32);
    let sign = if raw < 0 { "-" } else { "" };
    let a = raw.unsigned_abs();
    let s = scale as u64;
    format!("{sign}{}.{:0w$}", a / s, a % s, w = info.decimals as usize)
}

/// A value typed by the user (`80`, `80.5`, `-3.25`) in the setting's
/// unit, as the raw integer (thousandths where the setting has 3
/// decimals): exact, no rounding; more decimals than the setting has, a
/// number that is not one, or a value outside its range are refused.
pub fn parse_value(info: &SettingInfo, s: &str) -> Result<i64, String> {
    let t = s.trim();
    let (neg, body) = match t.strip_prefix('-') {
        Some(b) => (true, b),
        None => (false, t.strip_prefix('+').unwrap_or(t)),
    };
    let (int, frac) = body.split_once('.').unwrap_or((body, ""));
    let digits = |d: &str| !d.is_empty() && d.chars().all(|c| c.is_ascii_digit());
    if !digits(int) || !(frac.is_empty() || digits(frac)) {
        return Err(format!("{s:?} is not a number"));
    }
    let frac = frac.trim_end_matches('0');
    if frac.len() > info.decimals as usize {
        return Err(format!(
            "{s:?}: ${} takes at most {} decimal places",
            info.id, info.decimals
        ));
    }
    let scale = 10i128.pow(info.decimals as u32);
    let f: i128 = if frac.is_empty() {
        0
    } else {
        frac.parse::<i128>()
            .map_err(|_| format!("{s:?} is not a number"))?
            * 10i128.pow((info.decimals as usize - frac.len()) as u32)
    };
    let i: i128 = int
        .parse::<i128>()
        .map_err(|_| format!("{s:?}: too large"))?;
    let v = i
        .checked_mul(scale)
        .and_then(|x| x.checked_add(f))
        .ok_or_else(|| format!("{s:?}: too large"))?;
    let v = if neg { -v } else { v };
    if v < info.min as i128 || v > info.max as i128 {
        return Err(format!(
            "${} = {s}: outside its range {} to {} {}",
            info.id,
            format_value(info, info.min),
            format_value(info, info.max),
            info.unit
        ));
    }
    Ok(v as i64)
}

/// One line of the settings list, as Grbl's `$$`: `$N=value (name, unit)`.
pub fn setting_line(info: &SettingInfo, raw: i64) -> String {
    format!(
        "${}={} ({}, {})",
        info.id,
        format_value(info, raw),
        info.name,
        info.unit
    )
}

/// What a write did: `$0 = 5.000 µs (was 2.500; step pulse width)`.
pub fn written_line(info: &SettingInfo, raw: i64, was: i64) -> String {
    format!(
        "${} = {} {} (was {}; {})",
        info.id,
        format_value(info, raw),
        info.unit,
        format_value(info, was),
        info.name
    )
}

/// The settings a write of `id` is checked against by the controller
/// (`Config::from_values`' cross-checks), for its refusal: what must hold.
pub fn cross_check(id: u16) -> Option<&'static str> {
    Some(match id {
        30 | 31 => "$31 (the spindle speed at the least PWM) must stay below $30 (the speed at full PWM)",
        0 | 205 | 200 => "the step pulse ($0) and the direction setup ($205) must fit within a tick ($200), a whole number of step timer counts",
        110..=112 | 120..=122 | 201..=204 | 208 => "the planner must take the rates ($110-$112), accelerations ($120-$122), feed maximum ($201), jerk ($202), chord tolerance ($203), tangential share ($204) and smoothing ($208) together",
        _ => return None,
    })
}

/// How a homing cycle ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HomeResult {
    /// These axes were homed; the tool rests at `pos_mm` (machine
    /// coordinates).
    Homed {
        /// Axes, a mask.
        axes: u8,
        /// I32F32 bits per axis.
        pos_mm: [i64; 3],
    },
    /// The cycle failed with this alarm, the tool stopped there.
    Alarm {
        /// Why.
        code: AlarmCode,
        /// I32F32 bits per axis.
        pos_mm: [i64; 3],
    },
}

fn refused(what: &str, code: ErrorCode) -> Failure {
    let why = match code {
        ErrorCode::Busy => " (busy: it takes this only at rest with nothing queued; let the path finish or `fuzzy-send stop`)",
        ErrorCode::Alarm => " (in alarm: `fuzzy-send unlock` first)",
        ErrorCode::InputActive => " (the e-stop input is active: release it first)",
        ErrorCode::OutputsOn => " (the spindle or coolant is on: settings are written to flash only with them off; M5, M9)",
        ErrorCode::UnknownSetting => " (no such setting)",
        ErrorCode::OutOfRange => " (out of range, or invalid with the other settings: nothing changed)",
        _ => "",
    };
    Failure::new(
        Exit::Controller,
        format!("the controller refused {what}: {code:?}{why}"),
    )
}

impl Session {
    /// Leave the alarm state (Grbl's `$X`): the machine status after it.
    /// Refused while the e-stop input is active.
    pub fn unlock(&mut self, timeout: Duration) -> Result<MachineStatus, Failure> {
        let ack = |m: &DeviceMsg| matches!(m, DeviceMsg::Ack { .. }).then_some(());
        self.ask(&HostMsg::Unlock, timeout, ack, |_| {})?
            .map_err(|c| refused("the unlock", c))?;
        // The background carries it out: wait until the status leaves
        // the alarm.
        let deadline = Instant::now() + timeout;
        loop {
            let st = self.status_within(timeout, |_| {})?;
            if st.motion != Motion::Alarm {
                self.conn.client_mut().resync(&st);
                return self.machine_within(timeout);
            }
            if Instant::now() > deadline {
                return Err(Failure::new(
                    Exit::Alarm,
                    "the controller acknowledged the unlock but stayed in its alarm state",
                ));
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Run the homing cycle (Grbl's `$H`) on `axes` (0: the configured
    /// passes) and wait up to `timeout` for its end.
    pub fn home(
        &mut self,
        axes: u8,
        link_timeout: Duration,
        timeout: Duration,
    ) -> Result<HomeResult, Failure> {
        let msg = HostMsg::Home { axes };
        self.send(&msg)?;
        let deadline = Instant::now() + timeout;
        let mut started = false;
        let mut next_status = Instant::now() + Duration::from_millis(500);
        let mut last_rx = Instant::now();
        loop {
            if let Some(m) = self.recv(Duration::from_millis(50))? {
                last_rx = Instant::now();
                match m {
                    DeviceMsg::Ack { .. } => started = true,
                    DeviceMsg::Error { code, .. }
                        if !started
                            && !matches!(code, ErrorCode::OutOfSequence | ErrorCode::NoCredit) =>
                    {
                        let mut f = refused("the homing cycle", code);
                        if code == ErrorCode::Rejected {
                            f.message.push_str(": homing is not enabled ($22=0); wire the switches, then `fuzzy-send settings set 22 1`");
                        }
                        return Err(f);
                    }
                    DeviceMsg::Homed { axes, pos_mm } => {
                        return Ok(HomeResult::Homed { axes, pos_mm })
                    }
                    DeviceMsg::Alarm { code, pos_mm, .. } => {
                        return Ok(HomeResult::Alarm { code, pos_mm })
                    }
                    DeviceMsg::Status(st) => {
                        if st.motion == Motion::Homing {
                            started = true;
                        } else if !started {
                            // The command was lost: send it again.
                            self.send(&msg)?;
                        }
                    }
                    _ => {}
                }
            }
            let now = Instant::now();
            if now >= next_status {
                self.send(&HostMsg::StatusQuery)?;
                next_status = now + Duration::from_millis(500);
            }
            if last_rx.elapsed() > link_timeout {
                return Err(Failure::new(
                    Exit::LinkLost,
                    format!(
                        "no answer from the controller for {:.1} s during homing",
                        link_timeout.as_secs_f64()
                    ),
                ));
            }
            if now > deadline {
                // Stop the cycle: an abort interrupts it (HomingAborted).
                let m = self.conn.client_mut().abort();
                self.send(&m)?;
                return Err(Failure::new(
                    Exit::Controller,
                    format!(
                        "the homing cycle did not end within {:.0} s (--timeout): it was aborted",
                        timeout.as_secs_f64()
                    ),
                ));
            }
        }
    }

    /// Read setting `id`.
    pub fn get_setting(&mut self, id: u16, timeout: Duration) -> Result<i64, Failure> {
        let pick = |m: &DeviceMsg| match *m {
            DeviceMsg::Setting { id: i, value } if i == id => Some(value),
            _ => None,
        };
        self.ask(&HostMsg::GetSetting { id }, timeout, pick, |_| {})?
            .map_err(|c| refused(&format!("reading ${id}"), c))
    }

    /// Every setting of the controller's table, in its order: (setting,
    /// value).
    pub fn settings(&mut self, timeout: Duration) -> Result<Vec<(SettingInfo, i64)>, Failure> {
        SETTINGS
            .iter()
            .map(|s| Ok((*s, self.get_setting(s.id, timeout)?)))
            .collect()
    }

    /// Write setting `id`: the controller's reply must carry the value
    /// written; then its report of the flash write (it stores every
    /// accepted write), if one comes within `timeout`.
    pub fn set_setting(
        &mut self,
        id: u16,
        value: i64,
        timeout: Duration,
    ) -> Result<Option<StoreResult>, Failure> {
        let pick = |m: &DeviceMsg| match *m {
            DeviceMsg::Setting { id: i, value } if i == id => Some(value),
            _ => None,
        };
        // A store report before the reply is not this write's (the one
        // sent at start-up).
        let got = self
            .ask(&HostMsg::SetSetting { id, value }, timeout, pick, |_| {})?
            .map_err(|c| {
                let mut f = refused(&format!("${id}={value}"), c);
                if let (ErrorCode::OutOfRange, Some(rule)) = (c, cross_check(id)) {
                    f.message.push_str(": ");
                    f.message.push_str(rule);
                }
                f
            })?;
        let mut stored = None;
        if got != value {
            return Err(Failure::new(
                Exit::Controller,
                format!("${id}: wrote {value}, the controller answered {got}"),
            ));
        }
        let deadline = Instant::now() + timeout;
        while stored.is_none() && Instant::now() < deadline {
            if let Some(DeviceMsg::Stored(r)) = self.recv(Duration::from_millis(50))? {
                stored = Some(r);
            }
        }
        Ok(stored)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use controller::config::Config;

    #[test]
    fn values_print_and_parse_exactly_in_the_settings_unit() {
        let steps = setting(100).unwrap();
        assert_eq!(steps.decimals, 3);
        assert_eq!(format_value(steps, 80_000), "80.000");
        assert_eq!(format_value(steps, 1), "0.001");
        assert_eq!(parse_value(steps, "80").unwrap(), 80_000);
        assert_eq!(parse_value(steps, "80.5").unwrap(), 80_500);
        assert_eq!(parse_value(steps, "0.001").unwrap(), 1);
        assert_eq!(parse_value(steps, "12.3450").unwrap(), 12_345);
        assert!(parse_value(steps, "0.0001")
            .unwrap_err()
            .contains("decimal"));
        assert!(parse_value(steps, "0").unwrap_err().contains("range"));
        assert!(parse_value(steps, "8x").is_err());
        assert!(parse_value(steps, ".5").is_err());
        let rate = setting(110).unwrap();
        assert_eq!(parse_value(rate, "5000").unwrap(), 5000);
        assert!(parse_value(rate, "5000.5").is_err());
        for s in SETTINGS.iter() {
            let v = Config::DEFAULT.by_id(s.id).unwrap();
            assert_eq!(parse_value(s, &format_value(s, v)), Ok(v), "${}", s.id);
        }
        assert_eq!(
            setting_line(steps, 80_000),
            "$100=80.000 (X steps/mm, steps/mm)"
        );
    }

    #[test]
    fn ids_parse_with_or_without_the_dollar() {
        assert_eq!(parse_id("$22"), Ok(22));
        assert_eq!(parse_id("130"), Ok(130));
        assert!(parse_id("$1").unwrap_err().contains("no such setting"));
        assert!(parse_id("x").is_err());
        // What a shell leaves of an unquoted `$100`, `$1`, `$`.
        for bad in ["00", "$00", "05", "", "$", " $ "] {
            let e = parse_id(bad).unwrap_err();
            assert!(
                e.contains("'$100'") && e.contains("drop the `$`"),
                "{bad:?}: {e}"
            );
        }
        assert_eq!(parse_id("0"), Ok(0));
        assert_eq!(parse_id("$0"), Ok(0));
    }

    #[test]
    fn a_write_says_what_it_wrote_and_what_was_there() {
        let pulse = setting(0).unwrap();
        let line = written_line(pulse, 5_000, 2_500);
        assert!(line.starts_with("$0 = 5"), "{line}");
        assert!(
            line.contains(pulse.unit) && line.contains("(was 2.5"),
            "{line}"
        );
    }

    #[test]
    fn alarms_and_the_machine_status_read_as_grbl_users_expect() {
        assert!(alarm_text(AlarmCode::HardLimit { axis: 1, max: true }).contains("Y max"));
        assert!(alarm_text(AlarmCode::HardLimit { axis: 1, max: true }).contains("ALARM:1"));
        assert!(alarm_text(AlarmCode::EStopLink).contains("e-stop"));
        let m = MachineStatus {
            alarm: Some(AlarmCode::EStopInput),
            alarms: 2,
            homed: 0b101,
            inputs: 1 | (1 << 4),
            spindle: SpindleDir::Cw,
            speed_rpm: 12000,
            flood: true,
            ..MachineStatus::default()
        };
        let t = machine_text(&m);
        for want in [
            "ALARM: e-stop input",
            "unlock",
            "homed axes XZ",
            "M3) at 12000 rpm",
            "flood (M8)",
            "e-stop, Y max active",
        ] {
            assert!(t.contains(want), "{want:?} not in {t}");
        }
        assert!(machine_text(&MachineStatus::default()).contains("alarm: none"));
    }
}
