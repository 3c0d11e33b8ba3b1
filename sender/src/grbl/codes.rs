//! Grbl's numbered responses: `error:N` ([`ErrorCode`]), `ALARM:N`
//! ([`Alarm`]) and the `[MSG:…]` feedback texts ([`Feedback`]); our
//! controller's alarms mapped onto Grbl's ([`alarm_of`]) and the G-code
//! interpreter's error texts onto Grbl's error numbers ([`error_of_interp`]).
//!
//! Numbers and texts: Grbl 1.1h `grbl/report.h` (`STATUS_*`, `ALARM_*`,
//! `MESSAGE_*`), `doc/csv/error_codes_en_US.csv`,
//! `doc/csv/alarm_codes_en_US.csv` and `grbl/report.c`
//! (`report_feedback_message`); the e-stop alarm from grblHAL `alarms.h`
//! (`Alarm_EStop = 10`).

use core::fmt;

use link::AlarmCode;

/// A Grbl 1.1 error number, answered as `error:N` in place of `ok`
/// (`grbl/report.h` `STATUS_*`; 18 and 19 are unused in Grbl 1.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
#[non_exhaustive]
pub enum ErrorCode {
    /// 1: a G-code word without its letter.
    ExpectedCommandLetter = 1,
    /// 2: a missing or malformed number.
    BadNumberFormat = 2,
    /// 3: a `$` command not recognised or not supported.
    InvalidStatement = 3,
    /// 4: a negative value where a positive one is expected.
    NegativeValue = 4,
    /// 5: homing is not enabled (`$22`).
    SettingDisabled = 5,
    /// 6: step pulse below 3 µs.
    SettingStepPulseMin = 6,
    /// 7: settings read failed, defaults restored.
    SettingReadFail = 7,
    /// 8: the `$` command needs the machine idle.
    IdleError = 8,
    /// 9: G-code is locked out in the alarm or jog state.
    SystemGcLock = 9,
    /// 10: soft limits need homing enabled.
    SoftLimitError = 10,
    /// 11: the line is longer than the line buffer.
    Overflow = 11,
    /// 12: the step rate would exceed the maximum.
    MaxStepRateExceeded = 12,
    /// 13: the safety door is open.
    CheckDoor = 13,
    /// 14: a startup or build-info line too long to store.
    LineLengthExceeded = 14,
    /// 15: the jog target leaves the machine travel.
    TravelExceeded = 15,
    /// 16: a `$J` without `=` or with prohibited G-code.
    InvalidJogCommand = 16,
    /// 17: laser mode needs a PWM output.
    SettingDisabledLaser = 17,
    /// 20: unsupported or invalid G-code command.
    GcodeUnsupportedCommand = 20,
    /// 21: two commands of one modal group in a block.
    GcodeModalGroupViolation = 21,
    /// 22: feed rate not set.
    GcodeUndefinedFeedRate = 22,
    /// 23: the command needs an integer value.
    GcodeCommandValueNotInteger = 23,
    /// 24: two commands that use axis words in a block.
    GcodeAxisCommandConflict = 24,
    /// 25: a word repeated in a block.
    GcodeWordRepeated = 25,
    /// 26: no axis words where the command needs them.
    GcodeNoAxisWords = 26,
    /// 27: invalid line number.
    GcodeInvalidLineNumber = 27,
    /// 28: a required value word is missing.
    GcodeValueWordMissing = 28,
    /// 29: G59.x work coordinate systems are not supported.
    GcodeUnsupportedCoordSys = 29,
    /// 30: G53 only with G0 and G1.
    GcodeG53InvalidMotionMode = 30,
    /// 31: axis words that nothing uses.
    GcodeAxisWordsExist = 31,
    /// 32: an arc without an in-plane axis word.
    GcodeNoAxisWordsInPlane = 32,
    /// 33: invalid motion target.
    GcodeInvalidTarget = 33,
    /// 34: invalid arc radius.
    GcodeArcRadiusError = 34,
    /// 35: an arc without an in-plane offset word.
    GcodeNoOffsetsInPlane = 35,
    /// 36: unused value words.
    GcodeUnusedWords = 36,
    /// 37: G43.1 offset not on the tool length axis.
    GcodeG43DynamicAxisError = 37,
    /// 38: tool number above the maximum.
    GcodeMaxValueExceeded = 38,
}

/// Every [`ErrorCode`], in number order.
pub const ERROR_CODES: [ErrorCode; 36] = {
    use ErrorCode::*;
    [
        ExpectedCommandLetter,
        BadNumberFormat,
        InvalidStatement,
        NegativeValue,
        SettingDisabled,
        SettingStepPulseMin,
        SettingReadFail,
        IdleError,
        SystemGcLock,
        SoftLimitError,
        Overflow,
        MaxStepRateExceeded,
        CheckDoor,
        LineLengthExceeded,
        TravelExceeded,
        InvalidJogCommand,
        SettingDisabledLaser,
        GcodeUnsupportedCommand,
        GcodeModalGroupViolation,
        GcodeUndefinedFeedRate,
        GcodeCommandValueNotInteger,
        GcodeAxisCommandConflict,
        GcodeWordRepeated,
        GcodeNoAxisWords,
        GcodeInvalidLineNumber,
        GcodeValueWordMissing,
        GcodeUnsupportedCoordSys,
        GcodeG53InvalidMotionMode,
        GcodeAxisWordsExist,
        GcodeNoAxisWordsInPlane,
        GcodeInvalidTarget,
        GcodeArcRadiusError,
        GcodeNoOffsetsInPlane,
        GcodeUnusedWords,
        GcodeG43DynamicAxisError,
        GcodeMaxValueExceeded,
    ]
};

impl ErrorCode {
    /// Its number (`error:N`).
    pub const fn number(self) -> u8 {
        self as u8
    }

    /// The error of a number, if Grbl 1.1 defines it.
    pub fn from_number(n: u8) -> Option<ErrorCode> {
        ERROR_CODES.iter().copied().find(|e| e.number() == n)
    }

    /// The short text (the CSV's "Error Message in v1.0-" column).
    pub const fn short(self) -> &'static str {
        use ErrorCode::*;
        match self {
            ExpectedCommandLetter => "Expected command letter",
            BadNumberFormat => "Bad number format",
            InvalidStatement => "Invalid statement",
            NegativeValue => "Value < 0",
            SettingDisabled => "Setting disabled",
            SettingStepPulseMin => "Value < 3 usec",
            SettingReadFail => "EEPROM read fail. Using defaults",
            IdleError => "Not idle",
            SystemGcLock => "G-code lock",
            SoftLimitError => "Homing not enabled",
            Overflow => "Line overflow",
            MaxStepRateExceeded => "Step rate > 30kHz",
            CheckDoor => "Check Door",
            LineLengthExceeded => "Line length exceeded",
            TravelExceeded => "Travel exceeded",
            InvalidJogCommand => "Invalid jog command",
            SettingDisabledLaser => "Setting disabled",
            GcodeUnsupportedCommand => "Unsupported command",
            GcodeModalGroupViolation => "Modal group violation",
            GcodeUndefinedFeedRate => "Undefined feed rate",
            GcodeCommandValueNotInteger => "Invalid gcode ID:23",
            GcodeAxisCommandConflict => "Invalid gcode ID:24",
            GcodeWordRepeated => "Invalid gcode ID:25",
            GcodeNoAxisWords => "Invalid gcode ID:26",
            GcodeInvalidLineNumber => "Invalid gcode ID:27",
            GcodeValueWordMissing => "Invalid gcode ID:28",
            GcodeUnsupportedCoordSys => "Invalid gcode ID:29",
            GcodeG53InvalidMotionMode => "Invalid gcode ID:30",
            GcodeAxisWordsExist => "Invalid gcode ID:31",
            GcodeNoAxisWordsInPlane => "Invalid gcode ID:32",
            GcodeInvalidTarget => "Invalid gcode ID:33",
            GcodeArcRadiusError => "Invalid gcode ID:34",
            GcodeNoOffsetsInPlane => "Invalid gcode ID:35",
            GcodeUnusedWords => "Invalid gcode ID:36",
            GcodeG43DynamicAxisError => "Invalid gcode ID:37",
            GcodeMaxValueExceeded => "Invalid gcode ID:38",
        }
    }

    /// The description (the CSV's "Error Description" column).
    pub const fn description(self) -> &'static str {
        use ErrorCode::*;
        match self {
            ExpectedCommandLetter => "G-code words consist of a letter and a value. Letter was not found.",
            BadNumberFormat => "Missing the expected G-code word value or numeric value format is not valid.",
            InvalidStatement => "Grbl '$' system command was not recognized or supported.",
            NegativeValue => "Negative value received for an expected positive value.",
            SettingDisabled => "Homing cycle failure. Homing is not enabled via settings.",
            SettingStepPulseMin => "Minimum step pulse time must be greater than 3usec.",
            SettingReadFail => "An EEPROM read failed. Auto-restoring affected EEPROM to default values.",
            IdleError => "Grbl '$' command cannot be used unless Grbl is IDLE. Ensures smooth operation during a job.",
            SystemGcLock => "G-code commands are locked out during alarm or jog state.",
            SoftLimitError => "Soft limits cannot be enabled without homing also enabled.",
            Overflow => "Max characters per line exceeded. Received command line was not executed.",
            MaxStepRateExceeded => "Grbl '$' setting value cause the step rate to exceed the maximum supported.",
            CheckDoor => "Safety door detected as opened and door state initiated.",
            LineLengthExceeded => "Build info or startup line exceeded EEPROM line length limit. Line not stored.",
            TravelExceeded => "Jog target exceeds machine travel. Jog command has been ignored.",
            InvalidJogCommand => "Jog command has no '=' or contains prohibited g-code.",
            SettingDisabledLaser => "Laser mode requires PWM output.",
            GcodeUnsupportedCommand => "Unsupported or invalid g-code command found in block.",
            GcodeModalGroupViolation => "More than one g-code command from same modal group found in block.",
            GcodeUndefinedFeedRate => "Feed rate has not yet been set or is undefined.",
            GcodeCommandValueNotInteger => "G-code command in block requires an integer value.",
            GcodeAxisCommandConflict => "More than one g-code command that requires axis words found in block.",
            GcodeWordRepeated => "Repeated g-code word found in block.",
            GcodeNoAxisWords => "No axis words found in block for g-code command or current modal state which requires them.",
            GcodeInvalidLineNumber => "Line number value is invalid.",
            GcodeValueWordMissing => "G-code command is missing a required value word.",
            GcodeUnsupportedCoordSys => "G59.x work coordinate systems are not supported.",
            GcodeG53InvalidMotionMode => "G53 only allowed with G0 and G1 motion modes.",
            GcodeAxisWordsExist => "Axis words found in block when no command or current modal state uses them.",
            GcodeNoAxisWordsInPlane => "G2 and G3 arcs require at least one in-plane axis word.",
            GcodeInvalidTarget => "Motion command target is invalid.",
            GcodeArcRadiusError => "Arc radius value is invalid.",
            GcodeNoOffsetsInPlane => "G2 and G3 arcs require at least one in-plane offset word.",
            GcodeUnusedWords => "Unused value words found in block.",
            GcodeG43DynamicAxisError => "G43.1 dynamic tool length offset is not assigned to configured tool length axis.",
            GcodeMaxValueExceeded => "Tool number greater than max supported value.",
        }
    }
}

impl fmt::Display for ErrorCode {
    /// `error:N`, without the line end.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "error:{}", self.number())
    }
}

/// A Grbl alarm number, pushed as `ALARM:N` (`grbl/report.h` `ALARM_*`,
/// `doc/csv/alarm_codes_en_US.csv`).
///
/// 10 is ambiguous: Grbl 1.1h's CSV gives it to a dual-axis homing
/// failure, grblHAL (`alarms.h`) to the e-stop (and moves dual-axis
/// homing to 15). We follow grblHAL: our controllers have an e-stop and no
/// dual-axis homing, and the senders with a grblHAL path (gSender, ioSender)
/// show 10 as an e-stop.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
#[non_exhaustive]
pub enum Alarm {
    /// 1: a limit switch was hit.
    HardLimit = 1,
    /// 2: the target is outside the machine travel.
    SoftLimit = 2,
    /// 3: reset (or a stop) while in motion.
    AbortCycle = 3,
    /// 4: the probe was not in its expected state before the cycle.
    ProbeFailInitial = 4,
    /// 5: the probe did not trip within the travel (G38.2, G38.4).
    ProbeFailContact = 5,
    /// 6: homing was reset.
    HomingFailReset = 6,
    /// 7: the safety door opened during homing.
    HomingFailDoor = 7,
    /// 8: the pull-off did not clear the switch.
    HomingFailPulloff = 8,
    /// 9: the switch was not found within the search distance.
    HomingFailApproach = 9,
    /// 10: e-stop (grblHAL's number).
    EStop = 10,
}

/// Every [`Alarm`], in number order.
pub const ALARMS: [Alarm; 10] = {
    use Alarm::*;
    [
        HardLimit,
        SoftLimit,
        AbortCycle,
        ProbeFailInitial,
        ProbeFailContact,
        HomingFailReset,
        HomingFailDoor,
        HomingFailPulloff,
        HomingFailApproach,
        EStop,
    ]
};

impl Alarm {
    /// Its number (`ALARM:N`).
    pub const fn number(self) -> u8 {
        self as u8
    }

    /// The alarm of a number.
    pub fn from_number(n: u8) -> Option<Alarm> {
        ALARMS.iter().copied().find(|a| a.number() == n)
    }

    /// The description (the CSV's "Alarm Description"; 10 from grblHAL
    /// `alarms.c`).
    pub const fn description(self) -> &'static str {
        use Alarm::*;
        match self {
            HardLimit => "Hard limit has been triggered. Machine position is likely lost due to sudden halt. Re-homing is highly recommended.",
            SoftLimit => "Soft limit alarm. G-code motion target exceeds machine travel. Machine position retained. Alarm may be safely unlocked.",
            AbortCycle => "Reset while in motion. Machine position is likely lost due to sudden halt. Re-homing is highly recommended.",
            ProbeFailInitial => "Probe fail. Probe is not in the expected initial state before starting probe cycle when G38.2 and G38.3 is not triggered and G38.4 and G38.5 is triggered.",
            ProbeFailContact => "Probe fail. Probe did not contact the workpiece within the programmed travel for G38.2 and G38.4.",
            HomingFailReset => "Homing fail. The active homing cycle was reset.",
            HomingFailDoor => "Homing fail. Safety door was opened during homing cycle.",
            HomingFailPulloff => "Homing fail. Pull off travel failed to clear limit switch. Try increasing pull-off setting or check wiring.",
            HomingFailApproach => "Homing fail. Could not find limit switch within search distances. Try increasing max travel, decreasing pull-off distance, or check wiring.",
            EStop => "EStop asserted. Clear and reset",
        }
    }
}

impl fmt::Display for Alarm {
    /// `ALARM:N`, without the line end.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "ALARM:{}", self.number())
    }
}

/// Grbl's feedback messages, sent as `[MSG:text]` (`grbl/report.c`
/// `report_feedback_message`, numbers from `report.h` `MESSAGE_*`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Feedback {
    /// After an alarm that needs a reset (hard limit, abort).
    ResetToContinue,
    /// After the welcome line in the alarm state.
    AlarmLock,
    /// `$X` in the alarm state.
    AlarmUnlock,
    /// `$C` turned check mode on.
    Enabled,
    /// `$C` turned check mode off.
    Disabled,
    /// The safety door is open.
    SafetyDoorAjar,
    /// A limit switch is active at start-up.
    CheckLimits,
    /// M2 or M30.
    ProgramEnd,
    /// `$RST=`.
    RestoreDefaults,
    /// The spindle is restored after a door or park.
    SpindleRestore,
    /// `$SLP`.
    SleepMode,
}

impl Feedback {
    /// The text between `[MSG:` and `]`.
    pub const fn text(self) -> &'static str {
        use Feedback::*;
        match self {
            ResetToContinue => "Reset to continue",
            AlarmLock => "'$H'|'$X' to unlock",
            AlarmUnlock => "Caution: Unlocked",
            Enabled => "Enabled",
            Disabled => "Disabled",
            SafetyDoorAjar => "Check Door",
            CheckLimits => "Check Limits",
            ProgramEnd => "Pgm End",
            RestoreDefaults => "Restoring defaults",
            SpindleRestore => "Restoring spindle",
            SleepMode => "Sleeping",
        }
    }
}

/// One of our alarms as a Grbl sender sees it: the `ALARM:N` and, where
/// the number alone would mislead, a `[MSG:…]` text to send after it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GrblAlarm {
    /// The number.
    pub alarm: Alarm,
    /// What it was, in our terms.
    pub message: Option<String>,
}

const AXIS: [char; 3] = ['X', 'Y', 'Z'];

fn axis_name(axis: u8) -> String {
    match AXIS.get(usize::from(axis)) {
        Some(c) => c.to_string(),
        None => format!("axis {axis}"),
    }
}

/// Our controller's alarm as Grbl's number, with a message where it adds
/// something (the axis, or what happened when Grbl has no such alarm).
///
/// | ours | Grbl | why |
/// |---|---|---|
/// | `EStopInput`, `EStopLink` | 10 | grblHAL `Alarm_EStop` |
/// | `HardLimit` | 1 | |
/// | `SoftLimit` | 2 | |
/// | `HomingAborted` | 6 | homing reset |
/// | `HomingPullOff` | 8 | |
/// | `HomingNoSwitch` | 9 | |
/// | `ProbeFailInitial`, `ProbeFailContact` | 4, 5 | |
/// | `Watchdog`, `StepLag`, `LinkLoss`, `Fault` | 3 | Grbl has none; 3 ("abort during cycle": position likely lost, re-home) says what the operator must do |
///
/// Grbl's 7 (door during homing) has no alarm of ours: the door is the
/// front's, which raises it itself. A `match` without a wildcard: a new alarm of the controller
/// does not compile until it is mapped here.
pub fn alarm_of(code: AlarmCode) -> GrblAlarm {
    let (alarm, message) = match code {
        AlarmCode::EStopInput => (Alarm::EStop, Some("E-stop input active".to_string())),
        AlarmCode::EStopLink => (
            Alarm::EStop,
            Some("E-stop requested by the host".to_string()),
        ),
        AlarmCode::HardLimit { axis, max } => (
            Alarm::HardLimit,
            Some(format!(
                "Hard limit {} {}",
                axis_name(axis),
                if max { "max" } else { "min" }
            )),
        ),
        AlarmCode::SoftLimit => (Alarm::SoftLimit, None),
        AlarmCode::Watchdog => (
            Alarm::AbortCycle,
            Some("Watchdog reset: the controller restarted, re-home".to_string()),
        ),
        AlarmCode::StepLag => (
            Alarm::AbortCycle,
            Some("Step lag: step output fell behind the commanded position, re-home".to_string()),
        ),
        AlarmCode::LinkLoss => (
            Alarm::AbortCycle,
            Some("Link loss: the controller stopped for want of path".to_string()),
        ),
        AlarmCode::HomingNoSwitch { axis } => (
            Alarm::HomingFailApproach,
            Some(format!("Homing {}: switch not found", axis_name(axis))),
        ),
        AlarmCode::HomingPullOff { axis } => (
            Alarm::HomingFailPulloff,
            Some(format!(
                "Homing {}: switch still active after pull-off",
                axis_name(axis)
            )),
        ),
        AlarmCode::HomingAborted => (Alarm::HomingFailReset, None),
        AlarmCode::ProbeFailInitial => (Alarm::ProbeFailInitial, None),
        AlarmCode::ProbeFailContact => (Alarm::ProbeFailContact, None),
        AlarmCode::Fault { pc } => (
            Alarm::AbortCycle,
            Some(format!(
                "Controller fault at pc 0x{pc:08x}: firmware restarted, please report"
            )),
        ),
    };
    GrblAlarm { alarm, message }
}

/// The Grbl error number for an error of the G-code interpreter
/// (`gcode_interp`'s message text, `{:#}` of its `anyhow::Error`), found
/// by phrases of its messages (`gcode/src/interp.rs`, `parse.rs`,
/// `arc.rs`); 20 (unsupported command) when none matches.
///
/// Where Grbl (`grbl/gcode.c` `gc_execute_line`) splits a case finer than
/// the phrase tells, the more common number is chosen: a G or M code
/// given twice is 21 (Grbl flags a command word seen twice as a modal
/// group violation), a value word twice is 25; an R arc that cannot reach
/// its end is 34, every other arc definition error 33.
///
/// The interpreter's text, sent as `[MSG:…]` before `error:N`
/// ([`super::report::error_with_message`]), says more than the number.
/// Grbl 1.1 sends no message with an error; grblHAL does, and the senders
/// read `[…]` lines apart from responses (cncjs
/// `GrblLineParserResultFeedback`, bCNC `parseLine` tests `[` before
/// `ok`), so it is safe.
pub fn error_of_interp(message: &str) -> ErrorCode {
    use ErrorCode::*;
    let m = message;
    let has = |p: &str| m.contains(p);
    if has("appears twice") {
        if has("word ") {
            GcodeWordRepeated
        } else {
            GcodeModalGroupViolation
        }
    } else if has("both use the axis words") {
        GcodeAxisCommandConflict
    } else if has("in one block") {
        GcodeModalGroupViolation
    } else if has("is not a finite number")
        || has("value expected")
        || has("number expected")
        || has("without a number")
    {
        BadNumberFormat
    } else if has("unexpected") && has("word letter") {
        ExpectedCommandLetter
    } else if has("is negative") {
        NegativeValue
    } else if has("axis words without a motion mode") || has("G80 with axis words") {
        GcodeAxisWordsExist
    } else if has("without a feed") {
        GcodeUndefinedFeedRate
    } else if has("G53 needs G0 or G1") {
        GcodeG53InvalidMotionMode
    } else if has("shorter than half the chord") {
        GcodeArcRadiusError
    } else if has("arc without R or an offset") {
        GcodeNoOffsetsInPlane
    } else if has("R-format arc") || has("arc radius") || has("arc centre") {
        GcodeInvalidTarget
    } else if has("needs an axis word") || has("without axis words") {
        GcodeNoAxisWords
    } else if has("coordinate systems are P0") {
        GcodeUnsupportedCoordSys
    } else if (has("needs a") && has(" word")) || has("without a P word") || has("needs an L word")
    {
        GcodeValueWordMissing
    } else {
        GcodeUnsupportedCommand
    }
}

/// [`error_of_interp`] and the text for its `[MSG:]`: the interpreter's
/// own line count (`line N: `), which means nothing to the sender, left
/// out.
pub fn interp_error(message: &str) -> (ErrorCode, String) {
    let text = message
        .strip_prefix("line ")
        .and_then(|rest| {
            let digits = rest.bytes().take_while(u8::is_ascii_digit).count();
            rest.get(digits..)
                .filter(|_| digits > 0)
                .and_then(|r| r.strip_prefix(": "))
        })
        .unwrap_or(message);
    (error_of_interp(message), text.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn error_numbers_round_trip() {
        for e in ERROR_CODES {
            assert_eq!(ErrorCode::from_number(e.number()), Some(e));
            assert!(!e.short().is_empty() && !e.description().is_empty());
        }
        assert_eq!(ErrorCode::from_number(18), None);
        assert_eq!(ErrorCode::from_number(39), None);
        assert_eq!(ErrorCode::Overflow.to_string(), "error:11");
        assert_eq!(ErrorCode::GcodeMaxValueExceeded.number(), 38);
    }

    #[test]
    fn alarm_numbers_round_trip() {
        for (i, a) in ALARMS.iter().enumerate() {
            assert_eq!(usize::from(a.number()), i + 1);
            assert_eq!(Alarm::from_number(a.number()), Some(*a));
        }
        assert_eq!(Alarm::EStop.to_string(), "ALARM:10");
        assert_eq!(Alarm::from_number(0), None);
    }

    #[test]
    fn every_controller_alarm_maps() {
        let all = [
            (AlarmCode::EStopInput, 10),
            (AlarmCode::EStopLink, 10),
            (AlarmCode::HardLimit { axis: 1, max: true }, 1),
            (AlarmCode::SoftLimit, 2),
            (AlarmCode::Watchdog, 3),
            (AlarmCode::StepLag, 3),
            (AlarmCode::LinkLoss, 3),
            (AlarmCode::HomingNoSwitch { axis: 2 }, 9),
            (AlarmCode::HomingPullOff { axis: 0 }, 8),
            (AlarmCode::HomingAborted, 6),
            (AlarmCode::Fault { pc: 0x0800_1234 }, 3),
        ];
        for (code, n) in all {
            let g = alarm_of(code);
            assert_eq!(g.alarm.number(), n, "{code:?}");
            if n == 3 {
                assert!(g.message.is_some(), "{code:?} needs its own text");
            }
        }
        let g = alarm_of(AlarmCode::HardLimit { axis: 1, max: true });
        assert_eq!(g.message.as_deref(), Some("Hard limit Y max"));
        let g = alarm_of(AlarmCode::HomingNoSwitch { axis: 200 });
        assert_eq!(
            g.message.as_deref(),
            Some("Homing axis 200: switch not found")
        );
        let g = alarm_of(AlarmCode::Fault { pc: 0x0800_1234 });
        assert!(g.message.unwrap().contains("0x08001234"));
    }

    #[test]
    fn interp_errors_map() {
        use ErrorCode::*;
        let cases = [
            (
                "line 1: G76 threading cycle is not supported",
                GcodeUnsupportedCommand,
            ),
            ("line 1: G1 appears twice", GcodeModalGroupViolation),
            ("line 1: word X appears twice", GcodeWordRepeated),
            (
                "line 1: two motion codes in one block",
                GcodeModalGroupViolation,
            ),
            (
                "line 1: G92 and a motion code both use the axis words",
                GcodeAxisCommandConflict,
            ),
            ("line 1: X is not a finite number", BadNumberFormat),
            (
                "line 1: a value expected at the end of the line (at \"\")",
                BadNumberFormat,
            ),
            (
                "line 1: axis words without a motion mode (G0/G1/G2/G3)",
                GcodeAxisWordsExist,
            ),
            (
                "line 1: feed move without a feed (no F word yet)",
                GcodeUndefinedFeedRate,
            ),
            (
                "line 1: arc radius 1 mm is shorter than half the chord (2 mm)",
                GcodeArcRadiusError,
            ),
            (
                "line 1: arc radius differs at start (1 mm) and end (2 mm)",
                GcodeInvalidTarget,
            ),
            (
                "line 1: arc without R or an offset (I J K) in the plane",
                GcodeNoOffsetsInPlane,
            ),
            ("line 1: G53 needs G0 or G1", GcodeG53InvalidMotionMode),
            ("line 1: feed F-1 is negative", NegativeValue),
            ("line 1: G4 dwell without a P word", GcodeValueWordMissing),
            ("line 1: G10 needs an L word", GcodeValueWordMissing),
            ("line 1: G38.2 needs an axis word", GcodeNoAxisWords),
            (
                "line 1: unexpected '@' (a word letter, '#' or a comment expected)",
                ExpectedCommandLetter,
            ),
            (
                "line 1: M66 (wait for an input) needs live machine state",
                GcodeUnsupportedCommand,
            ),
            ("", GcodeUnsupportedCommand),
        ];
        for (text, code) in cases {
            assert_eq!(error_of_interp(text), code, "{text}");
        }
        assert_eq!(
            interp_error("line 12: G1 appears twice"),
            (GcodeModalGroupViolation, "G1 appears twice".to_string())
        );
        assert_eq!(interp_error("line x: y").1, "line x: y");
        assert_eq!(interp_error("line 3").1, "line 3");
        assert_eq!(interp_error("division by zero").1, "division by zero");
    }
}
