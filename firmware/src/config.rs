//! Build-time settings. Each can be changed without editing code through an
//! environment variable at build time, e.g.
//! `FW_TICK_HZ=2000 cargo build --release`.

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

/// Interpolator tick rate, Hz (`FW_TICK_HZ`, default 1000).
pub const TICK_HZ: u32 = env_u32(option_env!("FW_TICK_HZ"), 1000);
/// Tangential acceleration limit, mm/s² (`FW_ACCEL_MM_PER_S2`, default 1000).
pub const ACCEL_MM_PER_S2: u32 = env_u32(option_env!("FW_ACCEL_MM_PER_S2"), 1000);
/// Motor steps per mm, every axis (`FW_STEPS_PER_MM`, default 100).
pub const STEPS_PER_MM: u32 = env_u32(option_env!("FW_STEPS_PER_MM"), 100);
/// Most step pulses per axis in one tick (more are carried to the next tick
/// and counted as lag).
pub const MAX_STEPS_PER_TICK: u32 = 64;

/// Default maximum feed before a `StartPath`, mm/min.
pub const F_MAX_MM_PER_MIN: i32 = 3000;
/// Default minimum feed before a `StartPath`, mm/min.
pub const F_MIN_MM_PER_MIN: i32 = 60;

/// Lookahead window of the scheduler, points (the paper's WS).
pub const WS: usize = 30;
/// Average filter length, feeds.
pub const AVG: usize = 9;
/// Points the scheduler holds (must exceed `1 + WS + AVG/2`).
pub const SCHED_CAP: usize = 40;

/// Link command queue (USART task → scheduler), slots; the credit window
/// is its free room (`heapless::spsc::Queue<_, N>` holds `N − 1`).
pub const CMD_QUEUE: usize = 33;
/// The credit: commands the host may have outstanding (the queue's room).
pub const CMD_CREDIT: u32 = CMD_QUEUE as u32 - 1;
/// Scheduled segments in flight from the scheduler to the tick task.
pub const SEG_QUEUE: usize = 8;
/// Segments the interpolator itself holds (its stopping lookahead).
pub const INTERP_SEGMENTS: usize = 24;
/// Transmit buffer, bytes.
pub const TX_BUFFER: usize = 1024;
/// Send a credit update after this many commands were taken from the queue.
pub const CREDIT_BATCH: u32 = 8;
