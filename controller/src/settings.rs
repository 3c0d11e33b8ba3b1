//! The controller's settings and sizes: machine limits and rates (fixed at
//! build time, each from an environment variable, e.g.
//! `FW_TICK_HZ=2000 cargo build --release`) and the capacities of its
//! queues and lookaheads.
//!
//! The firmware, its cost benchmark and the host tests all read these
//! constants from here; the host tests also check the firmware's `Hello`
//! against them (a firmware built with other variables than the tests
//! fails that check instead of comparing different machines).

use core::mem::MaybeUninit;
use fixed::types::{I16F16, I32F32};
use fuzzy_core::lin2021::Lin2021Compact;

use fuzzy_core::planner::{ConfigError, Motion, MotionConfig};
use fuzzy_core::scheduler::{Scheduler, SchedulerConfig};
use fuzzy_core::units::FeedMmPerMin;

use crate::steps::{AxisConfig, StepConfig, StepsPerMm};

/// `value` parsed as a decimal `u32`, or `default` if absent or invalid.
const fn env_u32(value: Option<&str>, default: u32) -> u32 {
    let Some(s) = value else { return default };
    let b = s.as_bytes();
    if b.is_empty() || b.len() > 9 {
        return default;
    }
    let mut v = 0u32;
    let mut i = 0;
    while i < b.len() {
        let d = b[i];
        if !d.is_ascii_digit() {
            return default;
        }
        v = v * 10 + (d - b'0') as u32;
        i += 1;
    }
    v
}

/// Interpolation tick rate, Hz (`FW_TICK_HZ`, default 1000; 10 to 20 000).
pub const TICK_HZ: u32 = clamp(env_u32(option_env!("FW_TICK_HZ"), 1000), 10, 20_000);
/// Motor steps per mm, every axis unless overridden (`FW_STEPS_PER_MM`,
/// default 100; decimals allowed, e.g. `53.333`, to 1/1000).
pub const STEPS_PER_MM: StepsPerMm = steps_per_mm(option_env!("FW_STEPS_PER_MM"), 100_000);
/// Steps per mm per axis (`FW_STEPS_PER_MM_X`, `_Y`, `_Z`; default
/// [`STEPS_PER_MM`]).
pub const AXIS_STEPS_PER_MM: [StepsPerMm; 3] = [
    steps_per_mm(option_env!("FW_STEPS_PER_MM_X"), STEPS_PER_MM_MILLI),
    steps_per_mm(option_env!("FW_STEPS_PER_MM_Y"), STEPS_PER_MM_MILLI),
    steps_per_mm(option_env!("FW_STEPS_PER_MM_Z"), STEPS_PER_MM_MILLI),
];
const STEPS_PER_MM_MILLI: u32 = env_milli(option_env!("FW_STEPS_PER_MM"), 100_000);
/// The step timer's clock, Hz: TIM2 on the F4 (APB1 at 42 MHz, timers at
/// twice that). Every step time is in its counts; the tick period must be
/// a whole number of them.
pub const STEP_TIMER_HZ: u32 = 84_000_000;
/// The step generator's settings: steps/mm and polarity per axis
/// (`FW_STEP_INVERT`, `FW_DIR_INVERT`: a bit per axis, X = 1, Y = 2,
/// Z = 4), pulse width (`FW_STEP_PULSE_NS`, default 2500), direction setup
/// (`FW_DIR_SETUP_NS`, 5000), coalescing window (`FW_STEP_COALESCE_NS`,
/// 1000), reversal filter (`FW_REVERSAL_FILTER_NS`, 0 = off); defaults
/// and ranges in [`crate::steps::config`]. Checked at start-up.
pub const STEP_CONFIG: StepConfig = {
    let step_inv = env_u32(option_env!("FW_STEP_INVERT"), 0);
    let dir_inv = env_u32(option_env!("FW_DIR_INVERT"), 0);
    let mut c = StepConfig::new(STEPS_PER_MM);
    let mut i = 0;
    while i < 3 {
        c.axes[i] = AxisConfig {
            steps_per_mm: AXIS_STEPS_PER_MM[i],
            invert_step: step_inv & (1 << i) != 0,
            invert_dir: dir_inv & (1 << i) != 0,
        };
        i += 1;
    }
    c.pulse_ns = env_u32(option_env!("FW_STEP_PULSE_NS"), c.pulse_ns);
    c.dir_setup_ns = env_u32(option_env!("FW_DIR_SETUP_NS"), c.dir_setup_ns);
    c.coalesce_ns = env_u32(option_env!("FW_STEP_COALESCE_NS"), c.coalesce_ns);
    c.reversal_filter_ns = env_u32(option_env!("FW_REVERSAL_FILTER_NS"), c.reversal_filter_ns);
    c
};

/// `value` as thousandths of a decimal number (`"80"`, `"53.333"`), or
/// `default` if absent or invalid (more than three decimals, above
/// 65 535).
const fn env_milli(value: Option<&str>, default: u32) -> u32 {
    let Some(s) = value else { return default };
    let b = s.as_bytes();
    let (mut int, mut frac, mut frac_digits, mut dot) = (0u32, 0u32, 0u32, false);
    let mut i = 0;
    if b.is_empty() {
        return default;
    }
    while i < b.len() {
        let d = b[i];
        if d == b'.' && !dot {
            dot = true;
        } else if d.is_ascii_digit() {
            if dot {
                if frac_digits == 3 {
                    return default;
                }
                frac = frac * 10 + (d - b'0') as u32;
                frac_digits += 1;
            } else {
                if int > 65_535 {
                    return default;
                }
                int = int * 10 + (d - b'0') as u32;
            }
        } else {
            return default;
        }
        i += 1;
    }
    while frac_digits < 3 {
        frac *= 10;
        frac_digits += 1;
    }
    if int > 65_535 {
        return default;
    }
    int * 1000 + frac
}

const fn steps_per_mm(value: Option<&str>, default_milli: u32) -> StepsPerMm {
    StepsPerMm::from_milli(env_milli(value, default_milli))
}

/// Largest feed the machine runs (programmed feed × override is capped to
/// it; a path's F_max above it is accepted and scheduled, the motion is
/// capped), mm/min (`FW_FEED_MAX_MM_PER_MIN`, default 5000).
pub const FEED_MAX_MM_PER_MIN: u32 = env_u32(option_env!("FW_FEED_MAX_MM_PER_MIN"), 5000);
/// Per-axis speed limit, mm/min (`FW_AXIS_SPEED_MM_PER_MIN`, default 10 000).
pub const AXIS_SPEED_MM_PER_MIN: u32 = env_u32(option_env!("FW_AXIS_SPEED_MM_PER_MIN"), 10_000);
/// Per-axis acceleration limit, mm/s² (`FW_AXIS_ACCEL_MM_PER_S2`, default
/// 2000; the tangential acceleration gets [`TANGENTIAL_SHARE_PERCENT`] of it).
pub const AXIS_ACCEL_MM_PER_S2: u32 = env_u32(option_env!("FW_AXIS_ACCEL_MM_PER_S2"), 2000);
/// Tangential jerk limit, mm/s³ (`FW_JERK_MM_PER_S3`, default 50 000).
pub const JERK_MM_PER_S3: u32 = env_u32(option_env!("FW_JERK_MM_PER_S3"), 50_000);
/// Chord tolerance of one tick's straight move, nm (`FW_CHORD_NM`, default
/// 1000 = 1 µm).
pub const CHORD_NM: u32 = env_u32(option_env!("FW_CHORD_NM"), 1000);
/// Share of the axis acceleration for tangential acceleration, percent (the
/// rest is kept for changes of direction; `FW_TANGENTIAL_SHARE_PERCENT`,
/// default 50).
pub const TANGENTIAL_SHARE_PERCENT: u32 = env_u32(option_env!("FW_TANGENTIAL_SHARE_PERCENT"), 50);

/// Ticks the commanded position is averaged over (1 = off, up to
/// `fuzzy_core::planner::SMOOTHING_MAX`; 0 = the most that fit the chord
/// tolerance, tick and acceleration; `FW_SMOOTHING_TICKS`, default 0):
/// corners blended within the chord tolerance and passed faster (`$208`).
pub const SMOOTHING_TICKS: u8 = clamp(env_u32(option_env!("FW_SMOOTHING_TICKS"), 0), 0, 8) as u8;

/// The largest path tolerance a program may set with G64 P, nm
/// (`FW_PATH_TOLERANCE_MAX_NM`, default 100 000 = 0.1 mm; `$210`).
pub const PATH_TOLERANCE_MAX_NM: u32 = clamp(
    env_u32(option_env!("FW_PATH_TOLERANCE_MAX_NM"), 100_000),
    1,
    1_000_000,
);

/// The velocity planner's settings (`fuzzy_core::planner`); with the
/// defaults this is `MotionConfig::default()`. Checked at start-up.
pub const MOTION_CONFIG: MotionConfig = MotionConfig {
    tick_us: 1_000_000 / TICK_HZ,
    feed_max: FeedMmPerMin::from_int(clamp(FEED_MAX_MM_PER_MIN, 1, 1_000_000) as i32),
    axis_speed_max: [FeedMmPerMin::from_int(clamp(AXIS_SPEED_MM_PER_MIN, 1, 1_000_000) as i32); 3],
    axis_accel_max_mm_s2: [AXIS_ACCEL_MM_PER_S2; 3],
    jerk_max_mm_s3: JERK_MM_PER_S3,
    chord_tolerance_mm: I32F32::from_bits(((CHORD_NM as i64) << 32) / 1_000_000),
    tangential_share: I16F16::from_bits(
        ((clamp(TANGENTIAL_SHARE_PERCENT, 0, 100) as i32) << 16) / 100,
    ),
    smoothing_ticks: SMOOTHING_TICKS,
    exact_path: false,
};

/// Points the velocity planner buffers (its lookahead). 112 points of
/// 0.05 mm (5.6 mm) hold 5000 mm/min on a straight line at 1 kHz with the
/// default limits; a point takes 56 bytes.
pub const PLANNER_POINTS: usize = 112;
/// Setpoint ring from the planner (idle) to the tick interrupt, slots
/// (`ring::Ring<_, N>` holds `N − 1`): the planner runs this
/// many ticks ahead, so feed hold, resume and override take effect within
/// `SETPOINT_RING − 1` ticks.
pub const SETPOINT_RING: usize = 17;

/// Default maximum feed before a `StartPath`, mm/min.
pub const F_MAX_MM_PER_MIN: i32 = 3000;
/// Default minimum feed before a `StartPath`, mm/min.
pub const F_MIN_MM_PER_MIN: i32 = 60;
/// The default scheduler settings (before any `StartPath`).
pub const SCHED_CONFIG: SchedulerConfig = SchedulerConfig::new(
    FeedMmPerMin::from_int(F_MAX_MM_PER_MIN),
    FeedMmPerMin::from_int(F_MIN_MM_PER_MIN),
);

/// Lookahead window of the scheduler, points (the paper's WS).
pub const WS: usize = 30;
/// Average filter length, feeds.
pub const AVG: usize = 9;
/// Points the scheduler holds (must exceed `1 + WS + AVG/2`).
pub const SCHED_CAP: usize = 36;

/// The fuzzy scheduler as the controller runs it: Lin et al.'s controller
/// without its sampled-centroid table (the same outputs bit for bit).
pub type Sched = Scheduler<&'static Lin2021Compact, WS, AVG, SCHED_CAP>;

/// The velocity planner as the controller runs it.
pub type Plan = Motion<PLANNER_POINTS>;

/// The planner with settings `c`, built in `slot` (a `static` in the
/// firmware: the planner is 6.5 KB, so it is built once on the caller's
/// stack and moved once, not copied again into its place).
pub fn plan_in(slot: &mut MaybeUninit<Plan>, c: MotionConfig) -> Result<&mut Plan, ConfigError> {
    Ok(slot.write(Plan::new(c)?))
}

/// Link command queue (USART task → scheduler), slots; the credit window
/// is its free room (`ring::Ring<_, N>` holds `N − 1`). 96 points are six
/// full `Points` frames in flight: the link stays busy across a USB-serial
/// adapter's round trip of a few ms (48 bytes a slot).
pub const CMD_QUEUE: usize = 97;
/// The credit: commands the host may have outstanding (the queue's room).
pub const CMD_CREDIT: u32 = CMD_QUEUE as u32 - 1;
/// Link baud rate, 8N1 (`FW_LINK_BAUD`, default 921 600: common USB-serial
/// adapters take it, and the F4's USART1 on an 84 MHz APB2 makes it within
/// 0.16 %: [`usart_brr`]).
pub const LINK_BAUD: u32 = env_u32(option_env!("FW_LINK_BAUD"), 921_600);

/// The USART's BRR for `baud` from a `pclk_hz` peripheral clock with
/// 16× oversampling (RM0090 §30.3.4: `USARTDIV = f_PCLK / (16 · baud)`,
/// mantissa and four fraction bits, i.e. `f_PCLK / baud` rounded).
pub const fn usart_brr(pclk_hz: u32, baud: u32) -> u32 {
    let baud = if baud == 0 { 1 } else { baud };
    (pclk_hz + baud / 2) / baud
}

/// The baud rate BRR `brr` gives from `pclk_hz`, and its error from `baud`
/// in parts per million.
pub const fn baud_error_ppm(pclk_hz: u32, baud: u32) -> i64 {
    let brr = usart_brr(pclk_hz, baud);
    let brr = if brr == 0 { 1 } else { brr };
    let actual = pclk_hz as i64 * 1_000_000 / brr as i64;
    let want = if baud == 0 { 1 } else { baud as i64 };
    (actual - want * 1_000_000) / want
}

/// Transmit buffer, bytes.
pub const TX_BUFFER: usize = 512;
/// Send a credit update after this many commands were taken from the queue.
pub const CREDIT_BATCH: u32 = 16;

/// `v` within `lo..=hi` (a `const` `Ord::clamp`).
const fn clamp(v: u32, lo: u32, hi: u32) -> u32 {
    if v < lo {
        lo
    } else if v > hi {
        hi
    } else {
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_planner_is_built_in_its_slot_with_the_settings_given() {
        let mut slot = Box::new(MaybeUninit::<Plan>::uninit());
        let c = MotionConfig {
            axis_accel_max_mm_s2: [500; 3],
            ..MOTION_CONFIG
        };
        let plan = plan_in(&mut slot, c).expect("valid settings");
        let direct = Plan::new(c).unwrap().accel_limit_mm_s2();
        assert_eq!(plan.accel_limit_mm_s2(), direct);
        assert_ne!(
            direct,
            Plan::new(MOTION_CONFIG).unwrap().accel_limit_mm_s2()
        );
        let bad = MotionConfig {
            feed_max: FeedMmPerMin::ZERO,
            ..MOTION_CONFIG
        };
        assert!(plan_in(&mut slot, bad).is_err());
    }

    #[test]
    fn decimal_steps_per_mm() {
        assert_eq!(env_milli(Some("80"), 1), 80_000);
        assert_eq!(env_milli(Some("53.333"), 1), 53_333);
        assert_eq!(env_milli(Some("0.5"), 1), 500);
        assert_eq!(env_milli(Some("1.2345"), 1), 1);
        assert_eq!(env_milli(Some("70000"), 1), 1);
        assert_eq!(env_milli(Some("8x"), 1), 1);
        assert_eq!(env_milli(None, 7), 7);
        assert!(STEP_CONFIG.timing(STEP_TIMER_HZ, TICK_HZ).is_ok());
    }

    #[test]
    fn the_link_rates_come_within_a_percent_on_an_84_mhz_apb2() {
        // 921 600: BRR 91 (5 + 11/16), 923 077 baud, +0.16 %.
        assert_eq!(usart_brr(84_000_000, 921_600), 91);
        assert_eq!(baud_error_ppm(84_000_000, 921_600), 1602);
        // 115 200: BRR 729 (45 + 9/16), 115 226 baud, +0.02 %.
        assert_eq!(usart_brr(84_000_000, 115_200), 729);
        assert!(baud_error_ppm(84_000_000, 115_200).abs() < 300);
        for baud in [9_600, 57_600, 230_400, 250_000, 460_800, 500_000, 1_000_000] {
            assert!(baud_error_ppm(84_000_000, baud).abs() < 10_000, "{baud}");
        }
        assert!(baud_error_ppm(84_000_000, LINK_BAUD).abs() < 10_000);
    }
}
