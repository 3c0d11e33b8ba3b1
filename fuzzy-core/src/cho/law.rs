//! Cho et al.'s feed law (eq. 3.2-3.3): the contour error and its change
//! scaled by the gains of section IV, the controller's output `u`, and
//! `F(k) = F(k−1) + g_dF·u` within `f_min..f_max`; its `f64` reference.

use fixed::types::I32F32;

use super::data::ChoController;
use crate::fuzzy::Scratch;
use crate::units::{FeedMmPerMin, Fx, FEED_LIMIT_MM_PER_MIN};

/// Settings of the feed law.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FeedLawConfig {
    /// Contour-error bound `ε_max`, mm (`g_e = 1/ε_max`).
    pub bound: I32F32,
    /// `K`: `g_ce = K/ε_max` (module docs).
    pub change_ticks: u16,
    /// `g_dF`: the feed change per tick at controller output 1.
    pub output_gain: FeedMmPerMin,
    /// Lowest feed.
    pub f_min: FeedMmPerMin,
    /// Highest feed.
    pub f_max: FeedMmPerMin,
}

/// Why a [`FeedLawConfig`] is unusable.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum FeedLawError {
    /// The bound is not within 0.1 µm..1 mm.
    Bound,
    /// `K` is 0.
    ChangeTicks,
    /// The output gain is not within `(0, f_max]`.
    OutputGain,
    /// Not `0 <= f_min <= f_max <= FEED_LIMIT_MM_PER_MIN`, or the initial
    /// feed outside `[f_min, f_max]`.
    FeedRange,
}

impl core::fmt::Display for FeedLawError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            FeedLawError::Bound => "contour-error bound outside 0.1 µm..1 mm",
            FeedLawError::ChangeTicks => "the error-change horizon K must be at least 1 tick",
            FeedLawError::OutputGain => "output gain g_dF must be > 0 and at most f_max",
            FeedLawError::FeedRange => {
                "feeds must satisfy 0 <= f_min <= initial <= f_max <= 1e6 mm/min"
            }
        })
    }
}

impl FeedLawConfig {
    /// Section IV's setting for an error bound in mm: `K = 10`, `g_dF =
    /// 0.35 mm/s` (21 mm/min) per tick, feeds within `f_min..f_max`.
    pub fn paper(bound: I32F32, f_min: FeedMmPerMin, f_max: FeedMmPerMin) -> Self {
        FeedLawConfig {
            bound,
            change_ticks: 10,
            output_gain: FeedMmPerMin::from_int(21),
            f_min,
            f_max,
        }
    }

    /// Check the settings.
    pub fn validate(&self) -> Result<(), FeedLawError> {
        let b = self.bound.to_bits();
        // 0.1 µm = 429.5 raw; 1 mm = 2^32 raw.
        if !(430..=1 << 32).contains(&b) {
            return Err(FeedLawError::Bound);
        }
        if self.change_ticks == 0 {
            return Err(FeedLawError::ChangeTicks);
        }
        let lim = FeedMmPerMin::from_int(FEED_LIMIT_MM_PER_MIN);
        if self.f_min.0 < 0 || self.f_min > self.f_max || self.f_max > lim {
            return Err(FeedLawError::FeedRange);
        }
        if self.output_gain.0 <= 0 || self.output_gain > self.f_max {
            return Err(FeedLawError::OutputGain);
        }
        Ok(())
    }
}

/// One tick of the feed law.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FeedStep {
    /// `F(k)`, the feed for the next knot point.
    pub feed: FeedMmPerMin,
    /// `ΔF(k)` as applied (after the `f_min..f_max` clamp).
    pub delta: FeedMmPerMin,
    /// The normalised inputs `e`, `Δe` (clamped to `[−1, 1]`).
    pub inputs: [Fx; 2],
    /// The controller's output `u`.
    pub output: Fx,
}

/// Eq. 3.2-3.3 around a compiled controller: feed in, contour error in,
/// next feed out. No allocation; the controller's scratch area lives here.
#[derive(Clone, Debug)]
pub struct FeedLaw<'c> {
    controller: &'c ChoController,
    scratch: Scratch<101>,
    config: FeedLawConfig,
    /// `g_e` in 1/mm.
    gain_e: I32F32,
    /// `g_ce` in 1/mm.
    gain_ce: I32F32,
    feed: FeedMmPerMin,
    last_error: Option<I32F32>,
}

/// `x` clamped to `[−1, 1]` as Q16.16.
fn unit(x: I32F32) -> Fx {
    Fx::saturating_from_num(x.clamp(-I32F32::ONE, I32F32::ONE))
}

impl<'c> FeedLaw<'c> {
    /// A feed law starting at `initial` (within `f_min..f_max`).
    pub fn new(
        controller: &'c ChoController,
        config: FeedLawConfig,
        initial: FeedMmPerMin,
    ) -> Result<Self, FeedLawError> {
        config.validate()?;
        if initial < config.f_min || initial > config.f_max {
            return Err(FeedLawError::FeedRange);
        }
        // 1/ε_max: ε_max >= 0.1 µm keeps it below 10^7, well within I32F32.
        let gain_e = I32F32::ONE
            .checked_div(config.bound)
            .ok_or(FeedLawError::Bound)?;
        let gain_ce = gain_e.saturating_mul_int(config.change_ticks as i64);
        Ok(FeedLaw {
            controller,
            scratch: Scratch::new(),
            config,
            gain_e,
            gain_ce,
            feed: initial,
            last_error: None,
        })
    }

    /// The current feed `F(k−1)`.
    pub fn feed(&self) -> FeedMmPerMin {
        self.feed
    }

    /// The settings.
    pub fn config(&self) -> &FeedLawConfig {
        &self.config
    }

    /// One tick: the contour error `ε_c(k)` (signed, mm) in, `F(k)` out.
    /// The first tick has `Δε_c = 0`.
    pub fn step(&mut self, contour_error: I32F32) -> FeedStep {
        let change = match self.last_error {
            Some(prev) => contour_error.saturating_sub(prev),
            None => I32F32::ZERO,
        };
        self.last_error = Some(contour_error);
        let inputs = [
            unit(contour_error.saturating_mul(self.gain_e)),
            unit(change.saturating_mul(self.gain_ce)),
        ];
        let u = self
            .controller
            .evaluate_with(&mut self.scratch, inputs)
            .output;
        let delta = self
            .config
            .output_gain
            .0
            .saturating_mul(I32F32::from_num(u));
        let next = self
            .feed
            .0
            .saturating_add(delta)
            .clamp(self.config.f_min.0, self.config.f_max.0);
        let applied = next - self.feed.0;
        self.feed = FeedMmPerMin(next);
        FeedStep {
            feed: self.feed,
            delta: FeedMmPerMin(applied),
            inputs,
            output: u,
        }
    }
}

/// The feed law in `f64` with the reference Mamdani evaluator (feature
/// `std`), for tests and host reports.
#[cfg(feature = "std")]
pub mod reference {
    use crate::fuzzy::SystemDef;
    use crate::reference::Mamdani;

    /// Eq. 3.2-3.3 in `f64`: errors in mm, feeds in mm/min.
    pub struct FeedLaw<'d> {
        system: Mamdani<'d, 'static, 2>,
        /// `1/ε_max`, 1/mm.
        pub gain_e: f64,
        /// `K/ε_max`, 1/mm.
        pub gain_ce: f64,
        /// `g_dF`, mm/min per tick.
        pub output_gain: f64,
        /// Feed range, mm/min.
        pub range: (f64, f64),
        /// `F(k−1)`, mm/min.
        pub feed: f64,
        last: Option<f64>,
        /// Centroid samples (`None`: the reference's exact/fine centroid).
        pub samples: Option<usize>,
    }

    impl<'d> FeedLaw<'d> {
        /// A law for `system` with bound `bound_mm`, horizon `k` ticks, gain
        /// `g_df` (mm/min per tick), feed range and initial feed (mm/min).
        pub fn new(
            system: &'d SystemDef<'static, 2>,
            bound_mm: f64,
            k: f64,
            g_df: f64,
            range: (f64, f64),
            initial: f64,
        ) -> Self {
            FeedLaw {
                system: Mamdani::new(system),
                gain_e: 1.0 / bound_mm,
                gain_ce: k / bound_mm,
                output_gain: g_df,
                range,
                feed: initial,
                last: None,
                samples: Some(101),
            }
        }

        /// One tick: error in mm, returns (feed mm/min, controller output).
        pub fn step(&mut self, error_mm: f64) -> (f64, f64) {
            let change = self.last.map_or(0.0, |p| error_mm - p);
            self.last = Some(error_mm);
            let x = [
                (error_mm * self.gain_e).clamp(-1.0, 1.0),
                (change * self.gain_ce).clamp(-1.0, 1.0),
            ];
            let u = match self.samples {
                Some(n) => self.system.sampled(x, n),
                None => self.system.evaluate(x),
            }
            .unwrap_or(0.0);
            self.feed = (self.feed + self.output_gain * u).clamp(self.range.0, self.range.1);
            (self.feed, u)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::data::{CONTROLLER, CONTROLLER_PRINTED, SYSTEM, SYSTEM_PRINTED};
    use super::*;

    #[test]
    fn the_law_integrates_and_clamps() {
        let cfg = FeedLawConfig::paper(
            I32F32::from_num(0.005),
            FeedMmPerMin::from_int(60),
            FeedMmPerMin::from_int(3000),
        );
        let mut law = FeedLaw::new(&CONTROLLER, cfg, FeedMmPerMin::from_int(60)).unwrap();
        // Zero error: the feed climbs by up to 21 mm/min a tick, to f_max.
        let mut last = law.feed();
        for _ in 0..400 {
            let s = law.step(I32F32::ZERO);
            assert!(s.feed >= last && s.delta.0 <= I32F32::from_num(21));
            last = s.feed;
        }
        assert_eq!(law.feed(), FeedMmPerMin::from_int(3000));
        // An error above the bound: down, never below f_min.
        for _ in 0..1000 {
            let s = law.step(I32F32::from_num(0.01));
            assert!(s.feed >= FeedMmPerMin::from_int(60));
        }
        assert_eq!(law.feed(), FeedMmPerMin::from_int(60));
        assert_eq!(
            FeedLaw::new(&CONTROLLER, cfg, FeedMmPerMin::from_int(10)).err(),
            Some(FeedLawError::FeedRange)
        );
        let bad = FeedLawConfig {
            bound: I32F32::ZERO,
            ..cfg
        };
        assert_eq!(bad.validate(), Err(FeedLawError::Bound));
    }
    /// The fixed-point law against the `f64` reference law (same system,
    /// same 101-sample centroid) over an error trace that rises through the
    /// bound and falls back: feeds within 0.1 mm/min of each other.
    #[cfg(feature = "std")]
    #[test]
    fn the_law_matches_the_f64_reference() {
        let bound = 0.005;
        let cfg = FeedLawConfig::paper(
            I32F32::from_num(bound),
            FeedMmPerMin::from_int(60),
            FeedMmPerMin::from_int(6000),
        );
        for (sys, ctl) in [
            (&SYSTEM, &CONTROLLER),
            (&SYSTEM_PRINTED, &CONTROLLER_PRINTED),
        ] {
            let mut law = FeedLaw::new(ctl, cfg, FeedMmPerMin::from_int(600)).unwrap();
            let mut r = reference::FeedLaw::new(sys, bound, 10.0, 21.0, (60.0, 6000.0), 600.0);
            for k in 0..2000 {
                let t = k as f64 / 2000.0;
                // −1.2 .. +1.4 bounds, with a wiggle so that Δε changes sign.
                let e =
                    bound * (1.4 * (std::f64::consts::PI * t).sin() - 0.2 + 0.3 * (40.0 * t).sin());
                let s = law.step(I32F32::from_num(e));
                let (f, u) = r.step(e);
                assert!(
                    (s.output.to_num::<f64>() - u).abs() < 2e-3,
                    "k {k}: {s:?} vs {u}"
                );
                assert!(
                    (s.feed.0.to_num::<f64>() - f).abs() < 0.1,
                    "k {k}: {s:?} vs {f}"
                );
                r.feed = s.feed.0.to_num(); // keep the two on one trajectory
            }
        }
    }
}
