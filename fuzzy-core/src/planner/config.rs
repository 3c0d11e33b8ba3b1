//! Machine limits, and their compiled per-tick form.

use fixed::types::I32F32;

use super::q;
use crate::units::{FeedMmPerMin, Fx};

/// The machine's limits and the planner's settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MotionConfig {
    /// Interpolation period `Ts`, µs (1000 = 1 kHz).
    pub tick_us: u32,
    /// Largest programmed feed the planner will see (sets the reach of
    /// corner limits; larger feeds are capped to it), mm/min.
    pub feed_max: FeedMmPerMin,
    /// Per-axis maximum velocity (X, Y, Z), mm/min.
    pub axis_speed_max: [FeedMmPerMin; 3],
    /// Per-axis maximum acceleration (X, Y, Z), mm/s².
    pub axis_accel_max_mm_s2: [u32; 3],
    /// Maximum tangential jerk, mm/s³.
    pub jerk_max_mm_s3: u32,
    /// Largest deviation of the straight move between two interpolation
    /// points from a curve of the path's curvature (chord error δ), mm.
    pub chord_tolerance_mm: I32F32,
    /// Share of each axis' acceleration given to tangential acceleration;
    /// the rest is reserved for the changes of direction at the path's
    /// vertices (`0 < ρ < 1`, default 0.5).
    pub tangential_share: Fx,
    /// Commanded positions averaged over this many ticks (1 = off, at most
    /// [`SMOOTHING_MAX`]; 0 = the most, up to [`SMOOTHING_AUTO_MAX`], that
    /// validates with the tolerance, tick and acceleration,
    /// [`MotionConfig::smoothing`]): corners are
    /// blended within the chord tolerance and may be passed faster (module
    /// docs of [`super`], "Smoothing").
    pub smoothing_ticks: u8,
    /// Exact path (G61, G61.1): no smoothing, and every vertex where the
    /// path turns is passed at the creep speed, a stop (module docs of
    /// [`super`], "Ceilings"); collinear points are not.
    pub exact_path: bool,
}

/// The longest position average, ticks.
pub const SMOOTHING_MAX: u8 = 8;

/// The longest average `smoothing_ticks = 0` picks: beyond it the window's
/// margins (`n·ρA` a step) cost more on dense paths than the wider blend
/// gains (README, "Velocity planner": cycle times against `n`).
pub const SMOOTHING_AUTO_MAX: u8 = 4;

impl Default for MotionConfig {
    /// 1 kHz, 5000 mm/min, 10 m/min and 2000 mm/s² per axis, 50 000 mm/s³,
    /// chord tolerance 1 µm, ρ = 0.5, smoothing over as many ticks as
    /// validate (2 with these limits).
    fn default() -> Self {
        MotionConfig {
            tick_us: 1000,
            feed_max: FeedMmPerMin::from_int(5000),
            axis_speed_max: [FeedMmPerMin::from_int(10_000); 3],
            axis_accel_max_mm_s2: [2000; 3],
            jerk_max_mm_s3: 50_000,
            chord_tolerance_mm: I32F32::from_bits(4_294_967), // 0.001 mm
            tangential_share: Fx::lit("0.5"),
            smoothing_ticks: 0,
            exact_path: false,
        }
    }
}

/// Why a [`MotionConfig`] is refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ConfigError {
    /// Tick period outside 50 µs-100 ms.
    TickPeriod,
    /// A speed, acceleration or jerk limit is zero, negative or too large.
    Limit,
    /// Chord tolerance not in (0, 1] mm.
    ChordTolerance,
    /// Tangential share not in (0, 1).
    Share,
    /// Smoothing not in 1 to [`SMOOTHING_MAX`] ticks, or too long for the
    /// chord tolerance: a reversal passed at the least corner speed would
    /// be blended wider than the tolerance (fewer ticks, a shorter tick, a
    /// lower acceleration or a larger tolerance).
    Smoothing,
    /// The limits are too fine or too coarse for the tick period: the
    /// jerk per tick (`J·Ts³`) is below 2^-24 mm, or the largest feed per
    /// tick exceeds 16 mm. Lower (or raise) the tick rate.
    Resolution,
}

impl core::fmt::Display for ConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            ConfigError::TickPeriod => "tick period must be 50 µs to 100 ms",
            ConfigError::Limit => "speed, acceleration and jerk limits must be positive and finite",
            ConfigError::ChordTolerance => "chord tolerance must be in (0, 1] mm",
            ConfigError::Share => "tangential share must be in (0, 1)",
            ConfigError::Smoothing => {
                "smoothing must be 1 to 8 ticks, and short enough for the chord tolerance at this acceleration and tick"
            }
            ConfigError::Resolution => {
                "jerk per tick below 2^-24 mm or feed per tick above 16 mm: change the tick rate"
            }
        })
    }
}

/// The limits in per-tick units (raw Q32): mm, mm/tick, mm/tick², mm/tick³.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Limits {
    /// Feed bound.
    pub feed_max: i64,
    /// Per-axis speed.
    pub axis_speed: [i64; 3],
    /// Per-axis acceleration reserved for direction changes, `(1 − ρ)·A_a`.
    pub corner_accel: [i64; 3],
    /// Per-axis acceleration `A_a`.
    pub axis_accel: [i64; 3],
    /// Tangential acceleration limit `ρ·min_a A_a`.
    pub accel: i64,
    /// Deceleration of the envelope (`0.95 ·` [`Self::accel`]).
    pub envelope_decel: i64,
    /// Tangential jerk.
    pub jerk: i64,
    /// Chord tolerance, mm.
    pub chord: i64,
    /// A speed bound at or above this lies above `feed_max` by more than
    /// a quotient's and the stored speeds' rounding: it cannot bind, and
    /// `Lookahead::push` skips computing it (`feed_max·(1 + 1/512) + 64`
    /// quanta).
    pub unbinding: i64,
    /// The chord bound cannot lie below the feed bound (the stored ceilings
    /// included) where `κ·chord_free < 2δ`: `chord_free` is `H² + δ²` with
    /// margins, `2H` = [`Self::unbinding`] (`Lookahead::push` then skips
    /// the bound's division and root); `i64::MAX` where the margins would
    /// not hold.
    pub chord_free: i64,
    /// Reach of a point's corner limit (2.5 ticks at `feed_max`; with
    /// smoothing over `n` ticks, `(n + 1)` ticks at `feed_max` plus the
    /// window margin), mm.
    pub reach: i64,
    /// Segments shorter than this inherit their end points' ceilings
    /// (2.5 ticks at `feed_max`), mm.
    pub cap_reach: i64,
    /// Ticks averaged into the commanded position (1 = off).
    pub smoothing: u32,
    /// Exact path: every vertex that turns is a stop.
    pub exact: bool,
    /// With smoothing: how much faster than across a vertex the tool may
    /// step within a window holding it (`n + 1` steps), `n·ρ·min A` per tick.
    pub window_margin: i64,
    /// Creep speed through a stop point (`min(J·Ts, A)·Ts/2`): arriving no
    /// faster, the final deceleration is at most `J·Ts` and `A`, so stopping
    /// is jerk- and acceleration-limited (at long ticks `J·Ts` can exceed `A`).
    pub creep: i64,
    /// The least speed through a corner (`Motion::finalize`): the creep
    /// speed, but no faster than a reversal (`Σ|Δd_a| = 2`) allows within
    /// the corner share `(1 − ρ)·A_a` of every axis.
    pub corner_creep: i64,
    /// mm/min (raw I32F32) → mm/tick (Q32): `× tick_us / 60e6`, as a Q48
    /// factor (a multiplication instead of a 128-bit division per point).
    pub feed_to_tick_q48: i64,
    /// mm/tick (Q32) → mm/min: `× 60e6 / tick_us`, Q16.
    pub tick_to_feed_q16: i64,
    /// The tick period, µs.
    pub tick_us: u32,
}

/// `value × tick_us^k / (den · 10^(6k))` in Q32, for converting to per-tick
/// units, in `u64` (this runs once, at start-up, but an `i128` division
/// costs 2 KiB of flash on a Cortex-M4).
///
/// Each of the `k` factors `tick_us / 10^6` is applied exactly rounded down
/// (`x = q·10^6 + r`: `x·t/10^6 = q·t + ⌊r·t/10^6⌋`), then `den`. The result is
/// ⌊value·t^k/(den·10^(6k))⌋ itself when `k = 1` or when `t` divides 10^6
/// (every tick rate of whole kHz fractions, the default 1000 µs included),
/// and otherwise at most one quantum below it: each rounding loses less
/// than one quantum, scaled down by `t/10^6 ≤ 0.1` at each later step.
/// Saturates at `i64::MAX`.
fn per_tick(value_q32: u64, tick_us: u32, k: u32, den: u64) -> i64 {
    const MICRO: u64 = 1_000_000;
    let t = tick_us as u64;
    let mut x = value_q32;
    for _ in 0..k {
        let (q, r) = (x / MICRO, x % MICRO);
        x = q.saturating_mul(t).saturating_add(r * t / MICRO);
    }
    let q = x.checked_div(den).unwrap_or(0);
    q.min(i64::MAX as u64) as i64
}

/// `⌊2^48 · tick_us / 60e6⌋` (exact) in `u64`: `2^48·t` needs 66 bits, so
/// the quotient is taken in two 16- and 32-bit steps.
fn feed_to_tick_q48(tick_us: u32) -> i64 {
    const D: u64 = 60_000_000;
    let n = (tick_us as u64) << 32;
    let (q, r) = (n / D, n % D);
    ((q << 16) + (r << 16) / D) as i64
}

impl MotionConfig {
    /// Whether a planner accepts these settings (what `Motion::new`
    /// checks, without building one).
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.compile().map(|_| ())
    }

    /// The ticks the commanded positions are averaged over with these
    /// settings: `smoothing_ticks`, or with 0 the most (up to
    /// [`SMOOTHING_AUTO_MAX`]) that validates; 1 on an exact path.
    pub fn smoothing(&self) -> Result<u8, ConfigError> {
        self.compile().map(|l| l.smoothing as u8)
    }

    /// Check and compile.
    pub(crate) fn compile(&self) -> Result<Limits, ConfigError> {
        if !(50..=100_000).contains(&self.tick_us) {
            return Err(ConfigError::TickPeriod);
        }
        let share = self.tangential_share.to_bits() as i64; // Q16
        if share <= 0 || share >= 1 << 16 {
            return Err(ConfigError::Share);
        }
        let chord = self.chord_tolerance_mm.to_bits();
        if chord <= 0 || chord > q::ONE {
            return Err(ConfigError::ChordTolerance);
        }
        let feeds = [
            self.feed_max,
            self.axis_speed_max[0],
            self.axis_speed_max[1],
            self.axis_speed_max[2],
        ];
        if feeds.iter().any(|f| f.0 <= 0 || !f.within_limits())
            || self
                .axis_accel_max_mm_s2
                .iter()
                .any(|&a| a == 0 || a > 1_000_000)
            || self.jerk_max_mm_s3 == 0
        {
            return Err(ConfigError::Limit);
        }
        let t = self.tick_us;
        // mm/min → mm/tick: × tick_us / 60e6.
        // (Feeds are positive here: checked above.)
        let speed = |f: FeedMmPerMin| per_tick(f.0.to_bits().max(0) as u64, t, 1, 60);
        let accel = |a: u32| per_tick((a as u64) << 32, t, 2, 1);
        let a_min = self.axis_accel_max_mm_s2.iter().copied().min().unwrap_or(1);
        let tangential = ((accel(a_min) as i128 * share as i128) >> 16) as i64;
        let corner = self
            .axis_accel_max_mm_s2
            .map(|a| ((accel(a) as i128 * ((1 << 16) - share) as i128) >> 16) as i64);
        // Even (rounded down), so that a tick at full jerk changes the speed
        // by exactly J/2: an odd J would lose half a quantum of speed per
        // tick, and a long stop ramp would drift below v = a²/2J.
        let jerk = per_tick((self.jerk_max_mm_s3 as u64) << 32, t, 3, 1) & !1;
        let feed_max = speed(self.feed_max);
        if tangential <= 0 || jerk <= 0 || feed_max <= 0 {
            return Err(ConfigError::Limit);
        }
        // Stored speeds are Q28 in 32 bits (< 16 mm/tick); the jerk needs
        // enough bits for the stop's time-like quotients.
        let axis_max = self
            .axis_speed_max
            .iter()
            .map(|&f| speed(f))
            .max()
            .unwrap_or(0);
        if jerk < 1 << 8 || feed_max.max(axis_max) >= 15 << 32 {
            return Err(ConfigError::Resolution);
        }
        let axis_accel = self.axis_accel_max_mm_s2.map(accel);
        let unbinding = feed_max.saturating_add(feed_max / 512).saturating_add(64);
        if self.smoothing_ticks > SMOOTHING_MAX {
            return Err(ConfigError::Smoothing);
        }
        let corner_creep = (jerk.min(tangential) / 2)
            .min(corner.iter().copied().min().unwrap_or(0) / 2)
            .max(1);
        // A corner is never passed slower than `corner_creep`; the
        // deviation of a reversal there (`‖Δd‖ = 2`) from the commanded
        // moves must stay within the tolerance (module docs of [`super`],
        // "Smoothing"): `g_n·2·(creep + (2n − 1)·ρA/2) <= δ`,
        // `g_n = (2n² + 1 + n mod 2)/(16n)`.
        let fits = |n: i64| {
            let spread = 2 * corner_creep as i128 + ((2 * n - 1) * tangential) as i128;
            (2 * n * n + 1 + n % 2) as i128 * spread <= 16 * n as i128 * chord as i128
        };
        let n = match self.smoothing_ticks {
            _ if self.exact_path => 1,
            0 => (2..=i64::from(SMOOTHING_AUTO_MAX))
                .rev()
                .find(|&n| fits(n))
                .unwrap_or(1),
            k if k == 1 || fits(i64::from(k)) => i64::from(k),
            _ => return Err(ConfigError::Smoothing),
        };
        let window_margin = if n > 1 { n * tangential } else { 0 };
        let chord_free = {
            let h = unbinding / 2;
            let need = q::mul(h, h).saturating_add(q::mul(chord, chord));
            if need >= 1 << 24 {
                need.saturating_add(need >> 20).saturating_add(1)
            } else {
                i64::MAX
            }
        };
        let cap_reach = feed_max * 5 / 2;
        let reach = if n > 1 {
            cap_reach.max((n + 1) * (feed_max + window_margin))
        } else {
            cap_reach
        };
        Ok(Limits {
            feed_max,
            axis_speed: self.axis_speed_max.map(speed),
            corner_accel: corner,
            axis_accel,
            accel: tangential,
            envelope_decel: tangential - tangential / 20,
            jerk,
            chord,
            unbinding,
            chord_free,
            reach,
            cap_reach,
            smoothing: n as u32,
            exact: self.exact_path,
            window_margin,
            creep: (jerk.min(tangential) / 2).max(1),
            corner_creep,
            feed_to_tick_q48: feed_to_tick_q48(t),
            // (t ≥ 50, checked above.)
            tick_to_feed_q16: (60_000_000u64 << 16).checked_div(t as u64).unwrap_or(0) as i64,
            tick_us: t,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_compiles_to_per_tick_units() {
        let l = MotionConfig::default().compile().unwrap();
        let f = |v: i64| v as f64 / q::ONE as f64;
        assert!((f(l.feed_max) - 5000.0 / 60.0 * 1e-3).abs() < 1e-9);
        assert!((f(l.accel) - 1000.0 * 1e-6).abs() < 1e-9);
        assert!((f(l.jerk) - 50_000.0 * 1e-9).abs() < 1e-9);
        assert!((f(l.corner_accel[0]) - 1000.0 * 1e-6).abs() < 1e-9);
        assert!(l.creep > 0);
    }

    /// The `u64` conversions against the exact `i128` quotients: equal for
    /// `k = 1` and for tick periods dividing 1 s, within one quantum below
    /// otherwise.
    #[test]
    fn per_tick_matches_the_exact_quotient() {
        let exact = |v: u64, t: u32, k: u32, den: u64| -> i64 {
            let (mut n, mut d) = (v as i128, den as i128);
            for _ in 0..k {
                n *= t as i128;
                d *= 1_000_000;
            }
            (n / d).clamp(0, i64::MAX as i128) as i64
        };
        let values = [
            1u64,
            59,
            4_294_967,
            3000 << 32,
            (5000u64 << 32) + 12_345,
            1_000_000 << 32,
            (1u64 << 63) + 977,
            u32::MAX as u64 * (1 << 32),
        ];
        for t in [
            50, 125, 250, 333, 500, 999, 1000, 1024, 2000, 4096, 77_777, 100_000,
        ] {
            assert_eq!(
                feed_to_tick_q48(t) as i128,
                ((t as i128) << 48) / 60_000_000
            );
            for &v in &values {
                for (k, den) in [(1, 60), (1, 1), (2, 1), (3, 1)] {
                    let got = per_tick(v, t, k, den);
                    let want = exact(v, t, k, den);
                    if k == 1 || 1_000_000 % t == 0 {
                        assert_eq!(got, want, "v {v} t {t} k {k}");
                    } else {
                        assert!(
                            got <= want && got >= want - 1,
                            "v {v} t {t} k {k}: {got} vs {want}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn smoothing_must_fit_the_tolerance() {
        let c = MotionConfig::default();
        let with = |n: u8, tick_us: u32| {
            MotionConfig {
                smoothing_ticks: n,
                tick_us,
                ..c
            }
            .compile()
            .map(|l| l.smoothing)
        };
        assert_eq!(with(SMOOTHING_MAX + 1, 1000), Err(ConfigError::Smoothing));
        assert_eq!(with(1, 1000), Ok(1));
        assert_eq!(with(2, 1000), Ok(2));
        // At 1 kHz a reversal at the least corner speed, averaged over three
        // ticks, would leave the commanded moves farther than 1 µm from
        // the vertex; at 2 kHz it fits, five ticks do not.
        assert_eq!(with(3, 1000), Err(ConfigError::Smoothing));
        assert_eq!(with(3, 500), Ok(3));
        assert_eq!(with(4, 500), Ok(4));
        assert_eq!(with(5, 500), Err(ConfigError::Smoothing));
        // 0: the most that fits.
        assert_eq!(with(0, 1000), Ok(2));
        assert_eq!(with(0, 500), Ok(4));
        assert_eq!(c.smoothing(), Ok(2));
        let wide = MotionConfig {
            chord_tolerance_mm: I32F32::from_num(0.01),
            ..c
        };
        assert_eq!(wide.smoothing(), Ok(4));
        let exact = MotionConfig {
            exact_path: true,
            ..wide
        };
        assert_eq!(exact.smoothing(), Ok(1));
        let l = MotionConfig {
            smoothing_ticks: 1,
            ..c
        }
        .compile()
        .unwrap();
        assert_eq!((l.reach, l.window_margin), (l.cap_reach, 0));
    }

    #[test]
    fn bad_configs_are_refused() {
        let c = MotionConfig::default();
        assert_eq!(
            MotionConfig { tick_us: 10, ..c }.compile(),
            Err(ConfigError::TickPeriod)
        );
        assert_eq!(
            MotionConfig {
                tangential_share: Fx::ONE,
                ..c
            }
            .compile(),
            Err(ConfigError::Share)
        );
        assert_eq!(
            MotionConfig {
                jerk_max_mm_s3: 0,
                ..c
            }
            .compile(),
            Err(ConfigError::Limit)
        );
        assert_eq!(
            MotionConfig {
                chord_tolerance_mm: I32F32::ZERO,
                ..c
            }
            .compile(),
            Err(ConfigError::ChordTolerance)
        );
        assert_eq!(
            MotionConfig {
                feed_max: FeedMmPerMin::ZERO,
                ..c
            }
            .compile(),
            Err(ConfigError::Limit)
        );
    }
}
