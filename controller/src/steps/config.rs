//! Step generation settings (per axis: steps/mm and pin polarity; for all
//! axes: pulse width, direction setup time, coalescing window, reversal
//! filter), checked, and their values in timer counts.
//!
//! Defaults and why:
//! - pulse width 2.5 µs: the slowest common driver class, optocoupled
//!   external drives (DM542/DM556-class: PUL ≥ 2.5 µs), takes it; chip
//!   drivers need less (A4988 1 µs, DRV8825 1.9 µs, TMC22xx 0.1 µs). The
//!   shortest low time equals the pulse width, so the highest step rate is
//!   `1 / (2 · pulse)`: 200 kHz at the default;
//! - direction setup 5 µs: the same external drives ask DIR to lead PUL by
//!   5 µs (A4988 0.2 µs, DRV8825 0.65 µs, TMC22xx 0.02 µs). DIR is set as
//!   soon as the next step's direction is known (at the falling edge of
//!   the last step the other way, or when the tick that reverses is
//!   planned), so the setup time only delays a step that reverses within
//!   `pulse + max(pulse, setup)` of the step before it;
//! - coalescing 1 µs: a rising edge may go out up to this much before its
//!   exact time, so that edges close together share one timer interrupt
//!   (pulse, gap and setup minimums are never shortened);
//! - reversal filter off: see [`StepConfig::reversal_filter_ns`].

/// Steps per mm, Q16.16 (1/65 536 step per mm, up to 65 535.99): the
/// commanded position in steps is `floor(mm × steps/mm)` computed exactly.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StepsPerMm(pub u32);

impl StepsPerMm {
    /// A whole number of steps per mm.
    pub const fn from_int(n: u16) -> Self {
        StepsPerMm((n as u32) << 16)
    }

    /// `milli` / 1000 steps per mm, rounded to the nearest 1/65 536.
    pub const fn from_milli(milli: u32) -> Self {
        let q = ((milli as u64) << 16) + 500;
        let v = q / 1000;
        StepsPerMm(if v > u32::MAX as u64 {
            u32::MAX
        } else {
            v as u32
        })
    }

    /// As `f64` (tests, reports).
    pub fn to_f64(self) -> f64 {
        self.0 as f64 / 65536.0
    }
}

/// One axis's step output.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AxisConfig {
    /// Steps per mm (must be above zero).
    pub steps_per_mm: StepsPerMm,
    /// The step pin is active low (idle high, the pulse low).
    pub invert_step: bool,
    /// The direction pin is high for negative motion.
    pub invert_dir: bool,
}

impl AxisConfig {
    /// `steps_per_mm`, both pins active high.
    pub const fn new(steps_per_mm: StepsPerMm) -> Self {
        AxisConfig {
            steps_per_mm,
            invert_step: false,
            invert_dir: false,
        }
    }
}

/// The step generator's settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StepConfig {
    /// X, Y, Z.
    pub axes: [AxisConfig; 3],
    /// Step pulse width, ns ([`PULSE_NS`]); the shortest low time between
    /// two pulses is the same.
    pub pulse_ns: u32,
    /// Direction setup time: DIR changes at least this long before the next
    /// rising step edge, ns ([`DIR_SETUP_NS`]). DIR changes only while the
    /// step pin is inactive, so its hold time after a step is the pulse
    /// width.
    pub dir_setup_ns: u32,
    /// A rising edge may go out up to this long before its exact time to
    /// share a timer interrupt with another edge, ns ([`COALESCE_NS`]).
    pub coalesce_ns: u32,
    /// Reversal filter, ns (0: off; at most one tick): a step followed by
    /// a step back within this time is not emitted at all, both steps
    /// cancelled (Klipper's step+dir+step filter, `SDS_FILTER_TIME` =
    /// 750 µs in `klippy/chelper/stepcompress.c`, for drivers such as the
    /// TMC2208 in stealthChop that fault on it). Off by default: the step
    /// count then equals the commanded position at every tick end; with it
    /// on, a tick that ends between the two steps of a cancelled pair ends
    /// one step short of the commanded position (the pair's), and no
    /// other.
    pub reversal_filter_ns: u32,
}

/// Step pulse width range, ns.
pub const PULSE_NS: core::ops::RangeInclusive<u32> = 100..=20_000;
/// Direction setup time range, ns.
pub const DIR_SETUP_NS: core::ops::RangeInclusive<u32> = 100..=20_000;
/// Coalescing window range, ns.
pub const COALESCE_NS: core::ops::RangeInclusive<u32> = 0..=1_000;
/// Longest window (tick) in timer counts: 2^24 (keeps every product of
/// the plan's arithmetic within 64 bits).
pub const MAX_WINDOW_COUNTS: u32 = 1 << 24;

impl StepConfig {
    /// The defaults (module docs) with `steps_per_mm` on every axis.
    pub const fn new(steps_per_mm: StepsPerMm) -> Self {
        StepConfig {
            axes: [AxisConfig::new(steps_per_mm); 3],
            pulse_ns: 2_500,
            dir_setup_ns: 5_000,
            coalesce_ns: 1_000,
            reversal_filter_ns: 0,
        }
    }

    /// The settings in counts of a `timer_hz` timer for a `tick_hz` tick,
    /// or why they cannot be used.
    pub const fn timing(&self, timer_hz: u32, tick_hz: u32) -> Result<Timing, StepConfigError> {
        if tick_hz == 0 || timer_hz == 0 || timer_hz % tick_hz != 0 {
            return Err(StepConfigError::TickNotWholeCounts);
        }
        let window = timer_hz / tick_hz;
        if window > MAX_WINDOW_COUNTS {
            return Err(StepConfigError::TickTooLong);
        }
        let mut i = 0;
        let mut invert_step = 0u8;
        let mut invert_dir = 0u8;
        while i < 3 {
            let a = &self.axes[i];
            if a.steps_per_mm.0 == 0 {
                return Err(StepConfigError::StepsPerMm(i as u8));
            }
            invert_step |= (a.invert_step as u8) << i;
            invert_dir |= (a.invert_dir as u8) << i;
            i += 1;
        }
        if self.pulse_ns < *PULSE_NS.start() || self.pulse_ns > *PULSE_NS.end() {
            return Err(StepConfigError::PulseWidth);
        }
        if self.dir_setup_ns < *DIR_SETUP_NS.start() || self.dir_setup_ns > *DIR_SETUP_NS.end() {
            return Err(StepConfigError::DirSetup);
        }
        if self.coalesce_ns > *COALESCE_NS.end() {
            return Err(StepConfigError::Coalesce);
        }
        let pulse = ns_to_counts(self.pulse_ns, timer_hz);
        let setup = ns_to_counts(self.dir_setup_ns, timer_hz);
        let coalesce = ns_to_counts(self.coalesce_ns, timer_hz);
        let filter = ns_to_counts(self.reversal_filter_ns, timer_hz);
        if filter > window {
            return Err(StepConfigError::ReversalFilter);
        }
        // A step held back by a reversal stays inside its own tick.
        let longest_hold = pulse + if pulse > setup { pulse } else { setup };
        if window < 2 * (longest_hold + coalesce) {
            return Err(StepConfigError::TickTooShort);
        }
        Ok(Timing {
            window,
            pulse,
            low: pulse,
            setup,
            early: coalesce,
            filter,
            batch: ns_to_counts(ENGINE_BATCH_NS, timer_hz),
            pull_slack: ns_to_counts(
                ENGINE_BATCH_NS + ENGINE_PULL_NS - ENGINE_TOLERANCE_NS,
                timer_hz,
            ),
            window_slack: ns_to_counts(
                ENGINE_BATCH_NS + ENGINE_WINDOW_NS - ENGINE_TOLERANCE_NS,
                timer_hz,
            ),
            invert_step,
            invert_dir,
            timer_hz,
        })
    }
}

/// The step engine's time for one batch on a 168 MHz STM32F4, about
/// (the `cost steps3x` figures in firmware/README.md at 1.65 cycles an
/// instruction): [`Timing::batch`], by which it counts the batches due
/// before an axis's next edge.
pub const ENGINE_BATCH_NS: u32 = 2_700;
/// Spare time the engine wants before the next edges (less the batches
/// due before them) to change windows ahead of a window's end, beyond a
/// batch. Tuned on the loaded interrupt model of `tests/step_timing.rs`:
/// the change itself takes longer (up to about 4 µs), so it may make the
/// next edge late by up to [`ENGINE_TOLERANCE_NS`]; asking for all of it
/// finds no gap at all at about 100 kHz, and the change then comes at its
/// deadline, a quarter window on, wherever the edges are.
pub const ENGINE_WINDOW_NS: u32 = 2_300;
/// The same for taking the next plan off the queue.
pub const ENGINE_PULL_NS: u32 = 2_750;
/// How late a window change or a plan taken may make the next edge.
pub const ENGINE_TOLERANCE_NS: u32 = 1_700;

/// `ns` in counts of a `hz` timer, rounded up.
pub const fn ns_to_counts(ns: u32, hz: u32) -> u32 {
    let c = (ns as u64 * hz as u64).div_ceil(1_000_000_000);
    if c > u32::MAX as u64 {
        u32::MAX
    } else {
        c as u32
    }
}

/// Why step settings were refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum StepConfigError {
    /// Steps per mm of this axis (0 X, 1 Y, 2 Z) is zero.
    StepsPerMm(u8),
    /// Pulse width outside [`PULSE_NS`].
    PulseWidth,
    /// Direction setup outside [`DIR_SETUP_NS`].
    DirSetup,
    /// Coalescing window outside [`COALESCE_NS`].
    Coalesce,
    /// Reversal filter longer than a tick.
    ReversalFilter,
    /// The tick period is not a whole number of timer counts.
    TickNotWholeCounts,
    /// The tick is longer than [`MAX_WINDOW_COUNTS`].
    TickTooLong,
    /// The tick is too short for the pulse, setup and coalescing times.
    TickTooShort,
}

impl core::fmt::Display for StepConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            StepConfigError::StepsPerMm(a) => write!(f, "steps/mm of axis {a} is zero"),
            StepConfigError::PulseWidth => f.write_str("step pulse width outside 0.1-20 µs"),
            StepConfigError::DirSetup => f.write_str("direction setup outside 0.1-20 µs"),
            StepConfigError::Coalesce => f.write_str("coalescing window above 1 µs"),
            StepConfigError::ReversalFilter => f.write_str("reversal filter longer than a tick"),
            StepConfigError::TickNotWholeCounts => {
                f.write_str("tick period is not a whole number of step timer counts")
            }
            StepConfigError::TickTooLong => f.write_str("tick period too long for the step timer"),
            StepConfigError::TickTooShort => {
                f.write_str("tick period too short for the pulse and setup times")
            }
        }
    }
}

/// The step generator's settings as its two halves take them: the
/// planner (in the tick) its steps/mm and window, the engine (the step
/// timer's interrupt) the timing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StepSettings {
    /// Pulse, setup, polarity, window, in counts.
    pub timing: Timing,
    /// Steps per mm, per axis.
    pub steps_per_mm: [StepsPerMm; 3],
}

/// Checked settings in timer counts, what the planner and engine use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Timing {
    /// One tick, counts.
    pub window: u32,
    /// Pulse width, counts.
    pub pulse: u32,
    /// Shortest low time between pulses, counts.
    pub low: u32,
    /// Direction setup, counts.
    pub setup: u32,
    /// Most a rising edge may lead its exact time, counts.
    pub early: u32,
    /// Reversal filter, counts (0: off).
    pub filter: u32,
    /// The engine's time for a batch ([`ENGINE_BATCH_NS`]), counts.
    pub batch: u32,
    /// Time to spare before the next edges for the engine to take the
    /// next plan (a batch and the take, less the tolerance), counts.
    pub pull_slack: u32,
    /// The same to change windows ahead of the window's end, counts.
    pub window_slack: u32,
    /// Axes (bit per axis) whose step pin is active low.
    pub invert_step: u8,
    /// Axes whose direction pin is high for negative motion.
    pub invert_dir: u8,
    /// The timer's clock, Hz.
    pub timer_hz: u32,
}

impl Timing {
    /// Highest step rate one axis can emit, steps per second.
    pub const fn max_rate_hz(&self) -> u32 {
        self.timer_hz / (self.pulse + self.low)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HZ: u32 = 84_000_000;

    #[test]
    fn the_defaults_in_counts_of_an_84_mhz_timer() {
        let t = StepConfig::new(StepsPerMm::from_int(100))
            .timing(HZ, 1000)
            .unwrap();
        assert_eq!(t.window, 84_000);
        assert_eq!(t.pulse, 210); // 2.5 µs
        assert_eq!(t.setup, 420); // 5 µs
        assert_eq!(t.early, 84);
        assert_eq!(t.filter, 0);
        assert_eq!(t.max_rate_hz(), 200_000);
        // The shortest pulse rounds up: 100 ns → 9 counts (107 ns).
        assert_eq!(ns_to_counts(100, HZ), 9);
    }

    #[test]
    fn out_of_range_settings_are_refused() {
        let ok = StepConfig::new(StepsPerMm::from_int(100));
        let check = |c: StepConfig, tick: u32| c.timing(HZ, tick).err();
        assert_eq!(check(ok, 1000), None);
        for (pulse, bad) in [(99, true), (100, false), (20_000, false), (20_001, true)] {
            let c = StepConfig {
                pulse_ns: pulse,
                ..ok
            };
            assert_eq!(check(c, 1000).is_some(), bad, "{pulse}");
        }
        for (setup, bad) in [(99, true), (100, false), (20_000, false), (20_001, true)] {
            let c = StepConfig {
                dir_setup_ns: setup,
                ..ok
            };
            assert_eq!(check(c, 1000).is_some(), bad, "{setup}");
        }
        let c = StepConfig {
            coalesce_ns: 1001,
            ..ok
        };
        assert_eq!(check(c, 1000), Some(StepConfigError::Coalesce));
        let c = StepConfig {
            reversal_filter_ns: 1_000_001,
            ..ok
        };
        assert_eq!(check(c, 1000), Some(StepConfigError::ReversalFilter));
        let c = StepConfig {
            reversal_filter_ns: 750_000,
            ..ok
        };
        assert_eq!(check(c, 1000), None);
        let mut c = ok;
        c.axes[2].steps_per_mm = StepsPerMm(0);
        assert_eq!(check(c, 1000), Some(StepConfigError::StepsPerMm(2)));
        assert_eq!(check(ok, 1024), Some(StepConfigError::TickNotWholeCounts));
        assert_eq!(check(ok, 0), Some(StepConfigError::TickNotWholeCounts));
        assert_eq!(check(ok, 1), Some(StepConfigError::TickTooLong));
        // 20 kHz: 50 µs ticks hold the defaults, not 20 µs pulses.
        assert_eq!(check(ok, 20_000), None);
        let c = StepConfig {
            pulse_ns: 20_000,
            ..ok
        };
        assert_eq!(check(c, 20_000), Some(StepConfigError::TickTooShort));
    }

    #[test]
    fn steps_per_mm_from_thousandths() {
        assert_eq!(StepsPerMm::from_milli(80_000), StepsPerMm::from_int(80));
        let s = StepsPerMm::from_milli(53_333);
        assert!((s.to_f64() - 53.333).abs() < 1e-4);
    }
}
