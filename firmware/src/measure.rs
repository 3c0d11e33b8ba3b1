//! Time and measurement with SysTick (the DWT cycle counter reads 0 in
//! QEMU; with `-icount shift=0` SysTick advances 168 counts per 1000
//! instructions there):
//! - in the application SysTick is the interpolator's periodic timer
//!   ([`start_tick_timer`]); a tick's own cost is the count elapsed in the
//!   current period when it ends ([`cycles_in_period`], interrupt entry
//!   included);
//! - in the cost benchmark it runs free as a cycle counter
//!   ([`start_cycle_counter`], [`cycles`]).
//!
//! And the stack high-water mark: cortex-m-rt's `paint-stack` fills the
//! stack with [`STACK_PAINT`] at reset; [`StackProbe`] finds how deep it was
//! scrubbed.

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::{syst::SystClkSource, SYST};

/// SysTick counts down over 24 bits.
const SYST_MASK: u32 = 0x00FF_FFFF;

/// Start SysTick as a free-running cycle counter (core clock, no interrupt).
pub fn start_cycle_counter(syst: &mut SYST) {
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(SYST_MASK);
    syst.clear_current();
    syst.enable_counter();
}

/// Start SysTick as the periodic tick at `hz` (core clock), with its
/// exception enabled.
pub fn start_tick_timer(syst: &mut SYST, hz: u32) {
    let reload = (crate::board::SYSCLK_HZ / hz.max(1)).clamp(2, SYST_MASK + 1) - 1;
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(reload);
    syst.clear_current();
    syst.enable_interrupt();
    syst.enable_counter();
}

/// Core cycles since the current SysTick period began (periodic mode).
#[inline(always)]
pub fn cycles_in_period() -> u32 {
    SYST::get_reload().wrapping_sub(SYST::get_current())
}

/// Cycles from `start` (a [`cycles_in_period`] reading) to now, across at
/// most one reload (without `-icount`, QEMU's SysTick follows host time
/// and a preempted QEMU can see one).
#[inline(always)]
pub fn cycles_in_period_since(start: u32) -> u32 {
    let now = cycles_in_period();
    if now >= start {
        now - start
    } else {
        now.wrapping_add(SYST::get_reload())
            .wrapping_add(1)
            .wrapping_sub(start)
    }
}

/// `cycles` as a share of one SysTick period (periodic mode), per mille,
/// saturating.
#[inline]
pub fn permille_of_period(cycles: u32) -> u16 {
    let period = SYST::get_reload() as u64 + 1;
    let p = (cycles as u64 * 1000).checked_div(period).unwrap_or(0);
    p.min(u16::MAX as u64) as u16
}

/// Cycles now (24-bit, wrapping; free-running mode).
#[inline(always)]
pub fn cycles() -> u32 {
    SYST_MASK - (SYST::get_current() & SYST_MASK)
}

/// Cycles from `start` to now (valid below 2^24 cycles, 100 ms).
#[inline(always)]
pub fn cycles_since(start: u32) -> u32 {
    cycles().wrapping_sub(start) & SYST_MASK
}

/// Instructions for a SysTick count under QEMU `-icount shift=0`
/// (1 ns per instruction, SysTick at 168 MHz).
pub const fn qemu_instructions(cycles: u64) -> u64 {
    cycles * 1000 / 168
}

static TICKS: AtomicU32 = AtomicU32::new(0);
static TICK_US: AtomicU32 = AtomicU32::new(1000);

/// Count an interpolator tick (for the log timestamps).
pub fn count_tick() {
    TICKS.fetch_add(1, Ordering::Relaxed);
}

/// Set the tick period, µs.
pub fn set_tick_period_us(us: u32) {
    TICK_US.store(us, Ordering::Relaxed);
}

/// Time since start at tick resolution, µs.
pub fn uptime_us() -> u32 {
    TICKS
        .load(Ordering::Relaxed)
        .wrapping_mul(TICK_US.load(Ordering::Relaxed))
}

/// The word cortex-m-rt paints the stack with.
pub const STACK_PAINT: u32 = 0xCCCC_CCCC;

extern "C" {
    static _stack_start: u32;
    static _stack_end: u32;
}

/// Finds the stack high-water mark a few words at a time (the scan of the
/// whole painted area would hold up the idle loop for ~1 ms): it scans the
/// painted area from its bottom up to the first scrubbed word, records the
/// depth, and starts again.
pub struct StackProbe {
    next: usize,
    high_water_bytes: u32,
}

impl Default for StackProbe {
    fn default() -> Self {
        Self::new()
    }
}

impl StackProbe {
    /// A probe that has seen nothing yet.
    pub const fn new() -> Self {
        StackProbe {
            next: 0,
            high_water_bytes: 0,
        }
    }

    fn bounds() -> (usize, usize) {
        // Linker symbols: only their addresses are used.
        (
            core::ptr::addr_of!(_stack_end) as usize,
            core::ptr::addr_of!(_stack_start) as usize,
        )
    }

    /// Scan up to `words` more words; returns the deepest stack use seen,
    /// bytes.
    pub fn step(&mut self, words: usize) -> u32 {
        let (bottom, top) = Self::bounds();
        if self.next < bottom || self.next >= top {
            self.next = bottom;
        }
        for _ in 0..words {
            // SAFETY: an aligned word inside the stack region (checked
            // against its bounds just above), read only.
            let w = unsafe { core::ptr::read_volatile(self.next as *const u32) };
            if w != STACK_PAINT {
                let used = (top - self.next) as u32;
                self.high_water_bytes = self.high_water_bytes.max(used);
                self.next = bottom;
                break;
            }
            self.next += 4;
            if self.next >= top {
                self.next = bottom;
                break;
            }
        }
        self.high_water_bytes
    }

    /// Scan the whole painted area now; returns the deepest use, bytes.
    pub fn full_scan(&mut self) -> u32 {
        let (bottom, top) = Self::bounds();
        self.next = bottom;
        self.step((top - bottom) / 4)
    }

    /// The deepest use found so far, bytes.
    pub fn high_water_bytes(&self) -> u32 {
        self.high_water_bytes
    }
}
