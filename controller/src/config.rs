//! The machine's settings at run time: every setting with its id, unit,
//! range and default ([`SETTINGS`]), read and written over the link
//! (`HostMsg::GetSetting`/`SetSetting`) and kept in flash
//! ([`crate::store`]); the velocity planner's settings derived from them
//! ([`Config::motion_config`]).
//!
//! Ids follow Grbl's `$N` numbering where Grbl has the same setting
//! (Grbl 1.1 `settings.c`/`report.c`, the "Grbl v1.1 Configuration" wiki:
//! `$0` step pulse, `$2`-`$5` polarities, `$20`-`$27` limits and homing,
//! `$30`/`$31` spindle range, `$100`-`$132` per-axis steps/mm, rate,
//! acceleration and travel) or grblHAL's (`$14` control input polarity,
//! `$33` spindle PWM frequency, `$44`-`$46` homing passes); the settings
//! neither has are numbered from 200. Where Grbl's unit is fractional the
//! value here is an integer in thousandths ([`SettingInfo::decimals`] 3:
//! `$100 = 80000` is 80 steps/mm), so every value is an exact `i64`.
//!
//! Every value is checked against its range on arrival and on loading
//! from flash, and the planner's settings as a whole against
//! `MotionConfig::validate`: a refused value changes nothing. Settings
//! take effect ([`Apply`]) at once, at rest before the next motion (the
//! planner's, rebuilt by the background; the step generator's, rebuilt by
//! the tick once the last steps are out: [`crate::guard::Guard::apply_step_settings`]),
//! or at the next reset (the tick rate and the spindle PWM frequency,
//! whose timers are set up at start-up). Writes are accepted only with
//! the machine at rest, nothing queued and the spindle and coolant off,
//! or in an alarm once it is carried out (as Grbl refuses `$` writes
//! outside Idle and Alarm; [`crate::session`]), so "at rest" settings
//! apply at once in practice.
//!
//! With the defaults (from the build-time variables of
//! [`crate::settings`]) the planner's settings are exactly
//! [`crate::settings::MOTION_CONFIG`].

use fixed::types::{I16F16, I32F32};
use fuzzy_core::planner::{ConfigError, MotionConfig};
use fuzzy_core::units::FeedMmPerMin;
use link::PathControl;

use crate::settings::{
    AXIS_ACCEL_MM_PER_S2, AXIS_SPEED_MM_PER_MIN, CHORD_NM, FEED_MAX_MM_PER_MIN, JERK_MM_PER_S3,
    PATH_TOLERANCE_MAX_NM, SMOOTHING_TICKS, STEP_CONFIG, STEP_TIMER_HZ, TANGENTIAL_SHARE_PERCENT,
    TICK_HZ,
};
use crate::steps::{AxisConfig, StepConfig, StepConfigError, StepSettings, StepsPerMm, Timing};

/// When a changed setting takes effect.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Apply {
    /// At once.
    Now,
    /// At rest, before the next motion: the planner is rebuilt from it
    /// (rates, accelerations, jerk, chord, feed), or the step generator
    /// (steps/mm, pulse, polarity, DIR setup) once its last steps are
    /// out.
    AtRest,
    /// At the next reset (stored now): the tick rate (the tick timer, the
    /// planner's tick and the step engine's window are set up from it at
    /// start-up) and the spindle PWM frequency.
    Restart,
}

/// One setting: its id, name, unit, scale, range and when it applies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SettingInfo {
    /// The id on the link (`$N`).
    pub id: u16,
    /// What it is.
    pub name: &'static str,
    /// Its unit (of the value divided by 10^`decimals`).
    pub unit: &'static str,
    /// Decimal places in the value: the real value is `value / 10^decimals`.
    pub decimals: u8,
    /// Smallest value accepted.
    pub min: i64,
    /// Largest value accepted.
    pub max: i64,
    /// When a change takes effect.
    pub apply: Apply,
}

/// The settings, in the order of [`SETTINGS`] (and of the stored record).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
#[allow(missing_docs)] // each is documented in SETTINGS
pub enum Key {
    StepPulse,
    StepInvert,
    DirInvert,
    EnableInvert,
    LimitInvert,
    EStopInvert,
    SoftLimits,
    HardLimits,
    Homing,
    HomingDirInvert,
    HomingFeed,
    HomingSeek,
    Debounce,
    HomingPullOff,
    SpindleMax,
    SpindleMin,
    SpindlePwmHz,
    HomingPass1,
    HomingPass2,
    HomingPass3,
    StepsPerMmX,
    StepsPerMmY,
    StepsPerMmZ,
    RateX,
    RateY,
    RateZ,
    AccelX,
    AccelY,
    AccelZ,
    TravelX,
    TravelY,
    TravelZ,
    TickHz,
    FeedMax,
    Jerk,
    Chord,
    TangentialShare,
    DirSetup,
    LinkLoss,
    SpinUp,
    Smoothing,
    LinkSilence,
    PathToleranceMax,
    ProbeInvert,
}

/// How many settings there are.
pub const COUNT: usize = 44;

const fn s(
    id: u16,
    name: &'static str,
    unit: &'static str,
    decimals: u8,
    (min, max): (i64, i64),
    apply: Apply,
) -> SettingInfo {
    SettingInfo {
        id,
        name,
        unit,
        decimals,
        min,
        max,
        apply,
    }
}

const RATE: (i64, i64) = (1, 1_000_000);
const ACCEL: (i64, i64) = (1, 1_000_000);
/// 0.001 to 65 535 steps/mm (the step planner's Q16.16).
const STEPS: (i64, i64) = (1, 65_535_000);
/// 0.001 mm to 100 m.
const TRAVEL: (i64, i64) = (1, 100_000_000);

/// Every setting, in [`Key`] order.
pub const SETTINGS: [SettingInfo; COUNT] = [
    s(
        0,
        "step pulse width",
        "µs",
        3,
        (100, 20_000),
        Apply::AtRest,
    ),
    s(
        2,
        "step pulse invert, mask (bit 0 X, 1 Y, 2 Z)",
        "mask",
        0,
        (0, 7),
        Apply::AtRest,
    ),
    s(
        3,
        "direction invert, mask",
        "mask",
        0,
        (0, 7),
        Apply::AtRest,
    ),
    s(
        4,
        "driver enable invert (0: low enables, as Grbl and A4988/DRV8825/TMC drivers; 1: high enables)",
        "bool",
        0,
        (0, 1),
        Apply::Now,
    ),
    s(
        5,
        "limit inputs invert, mask (bit 0 X min, 1 X max, …, 5 Z max; 0: a switch closing to ground is active, 1: an open one, normally closed)",
        "mask",
        0,
        (0, 63),
        Apply::Now,
    ),
    s(
        14,
        "e-stop input invert (0: closing to ground is active; 1: opening, a normally closed e-stop)",
        "bool",
        0,
        (0, 1),
        Apply::Now,
    ),
    s(
        20,
        "soft limits (travel checked)",
        "bool",
        0,
        (0, 1),
        Apply::Now,
    ),
    s(
        21,
        "hard limits (a limit switch raises an alarm)",
        "bool",
        0,
        (0, 1),
        Apply::Now,
    ),
    s(
        22,
        "homing cycle enabled, and required before motion",
        "bool",
        0,
        (0, 1),
        Apply::Now,
    ),
    s(
        23,
        "homing direction invert, mask (0: towards max)",
        "mask",
        0,
        (0, 7),
        Apply::Now,
    ),
    s(
        24,
        "homing locate feed",
        "mm/min",
        0,
        (1, 100_000),
        Apply::Now,
    ),
    s(
        25,
        "homing seek rate",
        "mm/min",
        0,
        (1, 100_000),
        Apply::Now,
    ),
    s(
        26,
        "input debounce, samples at the tick rate",
        "ticks",
        0,
        (1, 255),
        Apply::Now,
    ),
    s(27, "homing pull-off", "mm", 3, (10, 100_000), Apply::Now),
    s(
        30,
        "spindle speed at full PWM",
        "rpm",
        0,
        (1, 1_000_000),
        Apply::Now,
    ),
    s(
        31,
        "spindle speed at the least PWM",
        "rpm",
        0,
        (0, 1_000_000),
        Apply::Now,
    ),
    s(
        33,
        "spindle PWM frequency",
        "Hz",
        0,
        (10, 100_000),
        Apply::Restart,
    ),
    s(
        44,
        "homing pass 1, axes mask",
        "mask",
        0,
        (0, 7),
        Apply::Now,
    ),
    s(
        45,
        "homing pass 2, axes mask",
        "mask",
        0,
        (0, 7),
        Apply::Now,
    ),
    s(
        46,
        "homing pass 3, axes mask",
        "mask",
        0,
        (0, 7),
        Apply::Now,
    ),
    s(100, "X steps/mm", "steps/mm", 3, STEPS, Apply::AtRest),
    s(101, "Y steps/mm", "steps/mm", 3, STEPS, Apply::AtRest),
    s(102, "Z steps/mm", "steps/mm", 3, STEPS, Apply::AtRest),
    s(110, "X max rate", "mm/min", 0, RATE, Apply::AtRest),
    s(111, "Y max rate", "mm/min", 0, RATE, Apply::AtRest),
    s(112, "Z max rate", "mm/min", 0, RATE, Apply::AtRest),
    s(120, "X acceleration", "mm/s²", 0, ACCEL, Apply::AtRest),
    s(121, "Y acceleration", "mm/s²", 0, ACCEL, Apply::AtRest),
    s(122, "Z acceleration", "mm/s²", 0, ACCEL, Apply::AtRest),
    s(130, "X max travel", "mm", 3, TRAVEL, Apply::Now),
    s(131, "Y max travel", "mm", 3, TRAVEL, Apply::Now),
    s(132, "Z max travel", "mm", 3, TRAVEL, Apply::Now),
    s(200, "tick rate", "Hz", 0, (10, 20_000), Apply::Restart),
    s(201, "machine max feed", "mm/min", 0, RATE, Apply::AtRest),
    s(
        202,
        "tangential jerk",
        "mm/s³",
        0,
        (1, u32::MAX as i64),
        Apply::AtRest,
    ),
    s(
        203,
        "chord tolerance",
        "nm",
        0,
        (1, 1_000_000),
        Apply::AtRest,
    ),
    s(
        204,
        "tangential share of the acceleration",
        "%",
        0,
        (1, 99),
        Apply::AtRest,
    ),
    s(
        205,
        "direction setup before a step",
        "µs",
        3,
        (100, 20_000),
        Apply::AtRest,
    ),
    s(
        206,
        "link-loss timeout while starved (0: off)",
        "ms",
        0,
        (0, 600_000),
        Apply::Now,
    ),
    s(
        207,
        "spindle spin-up delay after M3/M4",
        "ms",
        0,
        (0, 60_000),
        Apply::Now,
    ),
    s(
        208,
        "corner smoothing: commanded positions averaged over this many ticks (1: off; 0: the most that fit the tolerance, tick and acceleration; corners blended within the chord tolerance)",
        "ticks",
        0,
        (0, 8),
        Apply::AtRest,
    ),
    s(
        209,
        "link silence while moving before a feed hold (0: off; a host streaming a path asks for a status several times a second)",
        "ms",
        0,
        (0, 600_000),
        Apply::Now,
    ),
    s(
        210,
        "largest path tolerance a program may set (G64 P)",
        "nm",
        0,
        (1, 1_000_000),
        Apply::Now,
    ),
    s(
        6,
        "probe input invert (0: closing to ground is active; 1: opening)",
        "bool",
        0,
        (0, 1),
        Apply::Now,
    ),
];

/// The defaults, in [`Key`] order (the planner's from the build-time
/// variables).
const DEFAULTS: [i64; COUNT] = [
    STEP_CONFIG.pulse_ns as i64,
    mask_of(STEP_CONFIG.axes, false),
    mask_of(STEP_CONFIG.axes, true),
    0,
    0,
    0,
    0, // soft limits off (as Grbl)
    0, // hard limits off (as Grbl: unwired inputs must not raise alarms)
    0, // homing off
    0,
    25,  // locate feed (Grbl's default)
    500, // seek rate (Grbl's default)
    3,
    1000, // pull-off 1 mm (Grbl's default)
    1000, // spindle max rpm (Grbl's default)
    0,
    5000, // PWM frequency (grblHAL's default)
    4,    // pass 1: Z (Grbl's HOMING_CYCLE_0)
    3,    // pass 2: X and Y (Grbl's HOMING_CYCLE_1)
    0,
    milli_of(STEP_CONFIG.axes[0].steps_per_mm),
    milli_of(STEP_CONFIG.axes[1].steps_per_mm),
    milli_of(STEP_CONFIG.axes[2].steps_per_mm),
    AXIS_SPEED_MM_PER_MIN as i64,
    AXIS_SPEED_MM_PER_MIN as i64,
    AXIS_SPEED_MM_PER_MIN as i64,
    AXIS_ACCEL_MM_PER_S2 as i64,
    AXIS_ACCEL_MM_PER_S2 as i64,
    AXIS_ACCEL_MM_PER_S2 as i64,
    200_000, // travel 200 mm (Grbl's default)
    200_000,
    200_000,
    TICK_HZ as i64,
    FEED_MAX_MM_PER_MIN as i64,
    JERK_MM_PER_S3 as i64,
    CHORD_NM as i64,
    TANGENTIAL_SHARE_PERCENT as i64,
    STEP_CONFIG.dir_setup_ns as i64,
    5000, // link-loss timeout 5 s
    1000, // spin-up 1 s
    SMOOTHING_TICKS as i64,
    1000, // a feed hold after 1 s of link silence while moving
    PATH_TOLERANCE_MAX_NM as i64,
    0, // probe: closing to ground is active (Grbl's $6 = 0)
];

/// The polarity mask of the build-time step settings (`dir`: the
/// direction pins', else the step pins').
const fn mask_of(axes: [AxisConfig; 3], dir: bool) -> i64 {
    let mut m = 0;
    let mut i = 0;
    while i < 3 {
        if (dir && axes[i].invert_dir) || (!dir && axes[i].invert_step) {
            m |= 1 << i;
        }
        i += 1;
    }
    m
}

/// Q16.16 steps/mm in thousandths, rounded to nearest (exact for the
/// build-time values, which come from thousandths).
const fn milli_of(s: StepsPerMm) -> i64 {
    (s.0 as i64 * 1000 + (1 << 15)) >> 16
}

/// Why a setting was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SettingError {
    /// No setting has this id.
    Unknown,
    /// Outside its range, or the settings together are invalid (the
    /// planner's, the spindle's range).
    OutOfRange,
}

/// Where a setting's id is in [`SETTINGS`].
pub fn index_of(id: u16) -> Option<usize> {
    SETTINGS.iter().position(|s| s.id == id)
}

/// Every setting's value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Config {
    values: [i64; COUNT],
}

impl Default for Config {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// `v` as a `u32`, saturating.
fn u32_of(v: i64) -> u32 {
    v.clamp(0, u32::MAX as i64) as u32
}

impl Config {
    /// The defaults.
    pub const DEFAULT: Config = Config { values: DEFAULTS };

    /// A value by key.
    pub fn get(&self, k: Key) -> i64 {
        self.values.get(k as usize).copied().unwrap_or(0)
    }

    /// A value by link id.
    pub fn by_id(&self, id: u16) -> Result<i64, SettingError> {
        let i = index_of(id).ok_or(SettingError::Unknown)?;
        self.values.get(i).copied().ok_or(SettingError::Unknown)
    }

    /// Every value, in [`Key`] order (the stored record's).
    pub fn values(&self) -> &[i64; COUNT] {
        &self.values
    }

    /// Settings from stored values, if every one is in range and they are
    /// valid together.
    pub fn from_values(values: [i64; COUNT]) -> Option<Config> {
        let c = Config { values };
        let each = SETTINGS
            .iter()
            .zip(values)
            .all(|(s, v)| (s.min..=s.max).contains(&v));
        (each && c.check().is_ok()).then_some(c)
    }

    /// Set `id` to `value` if it is in range and the settings stay valid
    /// together; nothing changes otherwise. Returns the setting.
    pub fn set(&mut self, id: u16, value: i64) -> Result<SettingInfo, SettingError> {
        let i = index_of(id).ok_or(SettingError::Unknown)?;
        let info = SETTINGS.get(i).copied().ok_or(SettingError::Unknown)?;
        if !(info.min..=info.max).contains(&value) {
            return Err(SettingError::OutOfRange);
        }
        let mut next = *self;
        *next.values.get_mut(i).ok_or(SettingError::Unknown)? = value;
        next.check().map_err(|_| SettingError::OutOfRange)?;
        *self = next;
        Ok(info)
    }

    /// These settings with those that apply only at a reset
    /// ([`Apply::Restart`]) as in `running` (the settings the controller
    /// started with): the settings in force until the next reset.
    pub fn in_force(&self, running: &Config) -> Config {
        let mut c = *self;
        for ((v, r), s) in c.values.iter_mut().zip(running.values).zip(SETTINGS) {
            if s.apply == Apply::Restart {
                *v = r;
            }
        }
        c
    }

    /// The cross-checks: the planner takes its settings, the step
    /// generator its settings with the tick rate, the spindle's range is
    /// not empty.
    fn check(&self) -> Result<(), ConfigError> {
        if self.get(Key::SpindleMin) >= self.get(Key::SpindleMax) {
            return Err(ConfigError::Limit);
        }
        if self.step_timing().is_err() {
            return Err(ConfigError::Limit);
        }
        self.motion_config().validate()
    }

    /// A bit of a mask setting.
    fn bit(&self, k: Key, b: usize) -> bool {
        (self.get(k) >> b) & 1 != 0
    }

    /// Whether setting `k` is on (booleans).
    pub fn on(&self, k: Key) -> bool {
        self.get(k) != 0
    }

    /// The velocity planner's settings (with the defaults:
    /// [`crate::settings::MOTION_CONFIG`], bit for bit).
    pub fn motion_config(&self) -> MotionConfig {
        let feed = |k: Key| FeedMmPerMin::from_int(self.get(k).clamp(1, 1_000_000) as i32);
        let share = self.get(Key::TangentialShare).clamp(0, 100) as i32;
        MotionConfig {
            tick_us: 1_000_000 / u32_of(self.get(Key::TickHz)).max(1),
            feed_max: feed(Key::FeedMax),
            axis_speed_max: [feed(Key::RateX), feed(Key::RateY), feed(Key::RateZ)],
            axis_accel_max_mm_s2: [Key::AccelX, Key::AccelY, Key::AccelZ]
                .map(|k| u32_of(self.get(k))),
            jerk_max_mm_s3: u32_of(self.get(Key::Jerk)),
            chord_tolerance_mm: chord_of_nm(u32_of(self.get(Key::Chord))),
            tangential_share: I16F16::from_bits((share << 16) / 100),
            smoothing_ticks: self.get(Key::Smoothing).clamp(0, 8) as u8,
            exact_path: false,
        }
    }

    /// The planner's settings a program's path control asks for, in place
    /// of the machine's ([`PathSettings::apply`] to [`Self::motion_config`]):
    /// G64 the machine's (`$203`, `$208`); G64 P its tolerance, within
    /// 1 nm and `$210`, with the smoothing `$208` sets if it fits that
    /// tolerance, else the most that fits; G61 an exact path.
    pub fn path_settings(&self, control: PathControl) -> PathSettings {
        let chord_nm = u32_of(self.get(Key::Chord));
        let smoothing_ticks = self.get(Key::Smoothing).clamp(0, 8) as u8;
        let machine = PathSettings {
            chord_nm,
            smoothing_ticks,
            exact: false,
        };
        match control {
            PathControl::Blend => machine,
            PathControl::Tolerance { nm } => {
                let max = u32_of(self.get(Key::PathToleranceMax)).max(1);
                let mut p = PathSettings {
                    chord_nm: nm.clamp(1, max),
                    ..machine
                };
                if p.apply(self.motion_config()).validate().is_err() {
                    p.smoothing_ticks = 0;
                }
                p
            }
            PathControl::Exact => PathSettings {
                exact: true,
                ..machine
            },
        }
    }

    /// The tick rate, Hz.
    pub fn tick_hz(&self) -> u32 {
        u32_of(self.get(Key::TickHz)).max(1)
    }

    /// The tick period, µs.
    pub fn tick_us(&self) -> u32 {
        1_000_000 / self.tick_hz()
    }

    /// Steps per mm of axis `a`, in thousandths.
    pub fn steps_per_mm_milli(&self, a: usize) -> u32 {
        let k = [Key::StepsPerMmX, Key::StepsPerMmY, Key::StepsPerMmZ];
        u32_of(self.get(k[a.min(2)]))
    }

    /// Steps per mm of axis `a` (`$100`-`$102`), as the step generator
    /// takes them.
    pub fn steps_per_mm(&self, a: usize) -> StepsPerMm {
        StepsPerMm::from_milli(self.steps_per_mm_milli(a))
    }

    /// The step generator's settings: steps/mm per axis (`$100`-`$102`),
    /// step and direction polarity (`$2`, `$3`), pulse width (`$0`),
    /// direction setup (`$205`); the coalescing window and reversal
    /// filter stay the build's ([`crate::settings::STEP_CONFIG`]).
    pub fn step_config(&self) -> StepConfig {
        let mut c = STEP_CONFIG;
        for (i, a) in c.axes.iter_mut().enumerate() {
            *a = AxisConfig {
                steps_per_mm: self.steps_per_mm(i),
                invert_step: self.bit(Key::StepInvert, i),
                invert_dir: self.bit(Key::DirInvert, i),
            };
        }
        c.pulse_ns = u32_of(self.get(Key::StepPulse));
        c.dir_setup_ns = u32_of(self.get(Key::DirSetup));
        c
    }

    /// [`Self::step_config`] in counts of the step timer
    /// ([`crate::settings::STEP_TIMER_HZ`]) at this tick rate, or why the
    /// two do not go together (a tick rate that is not a whole number of
    /// timer counts, a tick too short for the pulse and setup times).
    pub fn step_timing(&self) -> Result<Timing, StepConfigError> {
        self.step_config().timing(STEP_TIMER_HZ, self.tick_hz())
    }

    /// [`Self::step_timing`] with the steps/mm: what the step generator's
    /// two halves take.
    pub fn step_settings(&self) -> Result<StepSettings, StepConfigError> {
        Ok(StepSettings {
            timing: self.step_timing()?,
            steps_per_mm: [0, 1, 2].map(|a| self.steps_per_mm(a)),
        })
    }

    /// Axis `a`'s travel, I32F32 bits `(min, max)`: Grbl's machine space,
    /// `[−travel, 0]` whichever way the axis homes (`grbl/system.c`,
    /// `system_check_travel_limits`, without `HOMING_FORCE_SET_ORIGIN`):
    /// the switch is at 0 when homing towards the maximum, at −travel
    /// towards the minimum.
    pub fn travel_bits(&self, a: usize) -> (i64, i64) {
        (-self.travel_len_bits(a), 0)
    }

    /// Axis `a`'s travel length, I32F32 bits.
    pub fn travel_len_bits(&self, a: usize) -> i64 {
        let k = [Key::TravelX, Key::TravelY, Key::TravelZ];
        milli_to_bits(self.get(k[a.min(2)]))
    }

    /// The homing pull-off, I32F32 bits.
    pub fn pull_off_bits(&self) -> i64 {
        milli_to_bits(self.get(Key::HomingPullOff))
    }

    /// Whether axis `a` homes towards its minimum.
    pub fn homes_to_min(&self, a: usize) -> bool {
        self.bit(Key::HomingDirInvert, a)
    }

    /// Whether `pos` (I32F32 bits per axis) lies within the travel, if
    /// soft limits are on (always, if off).
    pub fn within_travel(&self, pos: [i64; 3]) -> bool {
        if !self.on(Key::SoftLimits) {
            return true;
        }
        (0..3).all(|a| {
            let (lo, hi) = self.travel_bits(a);
            (lo..=hi).contains(&pos[a])
        })
    }

    /// How far `pos` (I32F32 bits per axis) lies outside the travel, the
    /// largest excess of any axis (0 inside, or with soft limits off).
    pub fn travel_excess(&self, pos: [i64; 3]) -> i64 {
        if !self.on(Key::SoftLimits) {
            return 0;
        }
        (0..3)
            .map(|a| {
                let (lo, hi) = self.travel_bits(a);
                let x = pos.get(a).copied().unwrap_or(0);
                lo.saturating_sub(x).max(x.saturating_sub(hi)).max(0)
            })
            .max()
            .unwrap_or(0)
    }

    /// The homing passes: axis masks in order (empty passes skipped by the
    /// cycle).
    pub fn homing_passes(&self) -> [u8; 3] {
        [Key::HomingPass1, Key::HomingPass2, Key::HomingPass3].map(|k| (self.get(k) & 7) as u8)
    }

    /// The input polarity: bit 0 e-stop, bits 1..=6 the limit switches (X
    /// min, X max, Y min, Y max, Z min, Z max), bit 7 the probe (`$6`), set
    /// where the input is active low.
    pub fn input_invert(&self) -> u8 {
        (self.get(Key::EStopInvert) as u8 & 1)
            | ((self.get(Key::LimitInvert) as u8 & 63) << 1)
            | ((self.get(Key::ProbeInvert) as u8 & 1) << 7)
    }
}

/// A chord tolerance in nm as the planner takes it (I32F32 mm, rounded
/// down).
pub fn chord_of_nm(nm: u32) -> I32F32 {
    I32F32::from_bits(((nm.min(1 << 30) as i64) << 32) / 1_000_000)
}

/// The planner's settings a path control changes
/// ([`Config::path_settings`]; reported as `PlanEvent::PathControl`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PathSettings {
    /// Chord tolerance, nm.
    pub chord_nm: u32,
    /// Smoothing ticks as set (0: the most that fit).
    pub smoothing_ticks: u8,
    /// Exact path.
    pub exact: bool,
}

impl PathSettings {
    /// `base` with these settings.
    pub fn apply(&self, base: MotionConfig) -> MotionConfig {
        MotionConfig {
            chord_tolerance_mm: chord_of_nm(self.chord_nm),
            smoothing_ticks: self.smoothing_ticks,
            exact_path: self.exact,
            ..base
        }
    }

    /// The event reporting them, the planner rebuilt at `pos_mm`.
    pub fn event(&self, pos_mm: [i64; 3]) -> link::PlanEvent {
        link::PlanEvent::PathControl {
            pos_mm,
            chord_nm: self.chord_nm,
            smoothing_ticks: self.smoothing_ticks,
            exact: self.exact,
        }
    }
}

/// Thousandths of a mm as I32F32 bits (exact to 2⁻³² mm, rounded down).
pub fn milli_to_bits(milli: i64) -> i64 {
    ((milli as i128) << 32).div_euclid(1000) as i64
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::settings::MOTION_CONFIG;

    #[test]
    fn the_defaults_give_the_build_time_planner_settings_bit_for_bit() {
        assert_eq!(Config::DEFAULT.motion_config(), MOTION_CONFIG);
        assert_eq!(Config::DEFAULT.tick_hz(), TICK_HZ);
        assert_eq!(Config::DEFAULT.step_config(), STEP_CONFIG);
        assert!(Config::from_values(DEFAULTS).is_some(), "defaults in range");
    }

    #[test]
    fn ids_are_unique_and_keys_follow_the_table() {
        for (i, a) in SETTINGS.iter().enumerate() {
            assert!(SETTINGS[i + 1..].iter().all(|b| b.id != a.id), "${}", a.id);
            assert!(a.min <= a.max);
        }
        assert_eq!(SETTINGS[Key::SpinUp as usize].id, 207);
        assert_eq!(SETTINGS[Key::Smoothing as usize].id, 208);
        assert_eq!(SETTINGS[Key::PathToleranceMax as usize].id, 210);
        assert_eq!(SETTINGS[Key::StepsPerMmX as usize].id, 100);
        assert_eq!(SETTINGS[Key::TravelZ as usize].id, 132);
        assert_eq!(SETTINGS[Key::HomingPass1 as usize].id, 44);
    }

    #[test]
    fn out_of_range_and_unknown_settings_change_nothing() {
        let mut c = Config::DEFAULT;
        assert_eq!(c.set(9999, 1), Err(SettingError::Unknown));
        assert_eq!(c.set(110, 0), Err(SettingError::OutOfRange));
        assert_eq!(c.set(204, 100), Err(SettingError::OutOfRange));
        assert_eq!(c.set(0, 50), Err(SettingError::OutOfRange), "0.05 µs pulse");
        // In range alone, but the spindle's range would be empty.
        assert_eq!(c.set(31, 1000), Err(SettingError::OutOfRange));
        // In range alone, but the planner refuses it: a jerk of 1 mm/s³
        // is below its resolution at 1 kHz (J·Ts³ < 2⁻²⁴ mm).
        assert_eq!(c.set(202, 1), Err(SettingError::OutOfRange));
        assert_eq!(c, Config::DEFAULT, "nothing changed");
        assert_eq!(c.set(202, 20_000).map(|i| i.apply), Ok(Apply::AtRest));
        let mut d = Config::DEFAULT;
        d.set(202, 20_000).unwrap();
        assert_eq!(c, d);
        assert_eq!(c.set(120, 500).map(|i| i.apply), Ok(Apply::AtRest));
        assert_eq!(c.motion_config().axis_accel_max_mm_s2[0], 500);
        assert_eq!(c.by_id(120), Ok(500));
    }

    #[test]
    fn corner_smoothing_is_checked_against_the_tolerance() {
        let mut c = Config::DEFAULT;
        assert_eq!(c.motion_config().smoothing_ticks, 0);
        assert_eq!(c.motion_config().smoothing(), Ok(2), "the most that fit");
        assert_eq!(c.set(208, 2).map(|i| i.apply), Ok(Apply::AtRest));
        assert_eq!(c.motion_config().smoothing_ticks, 2);
        // Three ticks would blend a reversal wider than 1 µm at 1 kHz and
        // 2000 mm/s²: refused; at 10 µm it fits.
        assert_eq!(c.set(208, 3), Err(SettingError::OutOfRange));
        assert_eq!(c.set(208, 9), Err(SettingError::OutOfRange));
        assert_eq!(c.motion_config().smoothing_ticks, 2);
        c.set(203, 10_000).unwrap();
        assert_eq!(c.set(208, 3).map(|i| i.apply), Ok(Apply::AtRest));
    }

    #[test]
    fn a_programs_path_control_within_the_machines_bound() {
        let c = Config::DEFAULT;
        let base = c.motion_config();
        let machine = c.path_settings(PathControl::Blend);
        assert_eq!(machine.apply(base), base);
        // G64 P0.01: 10 µm, within $210; the smoothing that fits it.
        let p = c.path_settings(PathControl::Tolerance { nm: 10_000 });
        assert_eq!((p.chord_nm, p.smoothing_ticks, p.exact), (10_000, 0, false));
        assert_eq!(p.apply(base).smoothing(), Ok(4));
        // Beyond $210: the bound.
        let p = c.path_settings(PathControl::Tolerance { nm: u32::MAX });
        assert_eq!(p.chord_nm, PATH_TOLERANCE_MAX_NM);
        // $208 = 2 does not fit 0.2 µm: the most that does.
        let mut d = c;
        d.set(208, 2).unwrap();
        let p = d.path_settings(PathControl::Tolerance { nm: 200 });
        assert_eq!(p.smoothing_ticks, 0);
        assert_eq!(p.apply(base).smoothing(), Ok(1));
        assert!(p.apply(base).validate().is_ok());
        // G61: exact, no smoothing.
        let e = c.path_settings(PathControl::Exact).apply(base);
        assert!(e.exact_path);
        assert_eq!(e.smoothing(), Ok(1));
    }

    #[test]
    fn the_step_settings_come_from_the_dollar_settings_and_are_checked_with_the_tick() {
        let mut c = Config::DEFAULT;
        c.set(100, 80_000).unwrap();
        c.set(102, 53_333).unwrap();
        c.set(0, 4_000).unwrap();
        c.set(2, 0b100).unwrap();
        c.set(3, 0b010).unwrap();
        c.set(205, 650).unwrap();
        let s = c.step_config();
        assert_eq!(s.axes[0].steps_per_mm, StepsPerMm::from_int(80));
        assert_eq!(s.axes[2].steps_per_mm, StepsPerMm::from_milli(53_333));
        assert_eq!((s.pulse_ns, s.dir_setup_ns), (4_000, 650));
        let pol = s.axes.map(|a| (a.invert_step, a.invert_dir));
        assert_eq!(pol, [(false, false), (false, true), (true, false)]);
        assert_eq!(c.step_timing().unwrap().pulse, 336, "4 µs at 84 MHz");
        let before = c;
        // 999 Hz is not a whole number of step timer counts: the planner
        // takes it, the step generator does not.
        let mut v = c.values;
        v[Key::TickHz as usize] = 999;
        assert!(Config { values: v }.motion_config().validate().is_ok());
        assert!(Config { values: v }.step_timing().is_err());
        assert!(Config::from_values(v).is_none());
        assert_eq!(c.set(200, 999), Err(SettingError::OutOfRange));
        assert_eq!(c.set(205, 50), Err(SettingError::OutOfRange));
        assert_eq!(c.set(100, 65_536_000), Err(SettingError::OutOfRange));
        assert_eq!(c, before, "nothing changed");
    }

    #[test]
    fn the_travel_is_grbls_machine_space() {
        let mut c = Config::DEFAULT;
        let mm = |x: f64| (x * 4294967296.0) as i64;
        assert_eq!(c.travel_bits(0), (mm(-200.0), 0));
        assert!(c.within_travel([mm(500.0), 0, 0]), "soft limits off");
        c.set(20, 1).unwrap();
        assert!(!c.within_travel([mm(0.5), 0, 0]));
        assert!(c.within_travel([mm(-200.0), mm(-0.5), 0]));
        c.set(23, 0b010).unwrap();
        assert_eq!(c.travel_bits(1), (mm(-200.0), 0), "Grbl's machine space");
        c.set(131, 50_500).unwrap();
        assert!(c.within_travel([mm(-1.0), mm(-50.5), 0]));
        assert!(!c.within_travel([mm(-1.0), mm(-50.6), 0]));
    }
}
