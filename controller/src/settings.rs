//! The controller's settings and sizes: machine limits and rates (fixed at
//! build time, each from an environment variable, e.g.
//! `FW_TICK_HZ=2000 cargo build --release`) and the capacities of its
//! queues and lookaheads.
//!
//! The firmware, its cost benchmark and the host tests all read these
//! constants from here; the host tests also check the firmware's `Hello`
//! against them (a firmware built with other variables than the tests
//! fails that check instead of comparing different machines).

use fixed::types::{I16F16, I32F32};
use fuzzy_core::lin2021::Lin2021Compact;
use fuzzy_core::planner::{Motion, MotionConfig};
use fuzzy_core::scheduler::{Scheduler, SchedulerConfig};
use fuzzy_core::units::FeedMmPerMin;

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
/// Motor steps per mm, every axis (`FW_STEPS_PER_MM`, default 100).
pub const STEPS_PER_MM: u32 = env_u32(option_env!("FW_STEPS_PER_MM"), 100);
/// Most step pulses per axis in one tick (more are carried to the next tick
/// and counted as lag).
pub const MAX_STEPS_PER_TICK: u32 = 64;

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
