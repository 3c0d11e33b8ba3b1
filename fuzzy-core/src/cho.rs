//! The contour-error feed controller of Cho, Lee & Jeon, "Design of Fuzzy
//! Logic Controllers for High-Speed and High-Accuracy CNC machines" (seed
//! 004), as data on the generic engine, and the feed law around it.
//!
//! Every interpolation tick `k` the contour error `ε_c(k)` (online, from
//! [`crate::contour`]) and its change `Δε_c(k) = ε_c(k) − ε_c(k−1)`
//! (eq. 3.2) are scaled by gains set from the contour-error bound, the
//! Mamdani controller gives a normalised feed change `u(k)`, and
//!
//! ```text
//! ΔF(k) = g_dF · u(k),    F(k) = F(k−1) + ΔF(k)          (eq. 3.3)
//! ```
//!
//! is the feed the interpolator uses for the next knot point (Fig. 3.1).
//!
//! # The controller (section 3)
//!
//! - **Membership** (eq. 3.1): `μ(x) = exp(−(x − b)²/a)`, for the inputs and
//!   the output. The paper calls it "bell shape"; the equation is a
//!   Gaussian (MATLAB `gaussmf` with `σ = √(a/2)`), not MATLAB's
//!   generalised bell `gbellmf`, and we follow the equation. The paper gives
//!   neither `a` nor `b`: five terms NB NS ZO PS PB per variable, centres
//!   `b = −1, −0.5, 0, 0.5, 1` on normalised universes `[−1, 1]`, and
//!   `a = 0.09` (`σ = 0.2121`), so neighbours cross at degree 0.5.
//! - **Inputs** `e = g_e·ε_c`, `Δe = g_ce·Δε_c`, with "the gain g_e for the
//!   error and the gain g_ce for the change of contour error … scaled as
//!   contour error bound" (section IV): `g_e = 1/ε_max`, so PB is the bound
//!   itself, and `g_ce = K/ε_max`, so PB of the change is an error that
//!   would cross the whole bound in `K` ticks. `K` is not in the paper; we
//!   chose `K = 10` ticks (10 ms at host-sim's 1 ms period, about the servo's
//!   response time, 1/ω_n ≈ 3 ms, times three). Inputs are clamped to
//!   `[−1, 1]`: an error beyond the bound counts as PB.
//! - **Output** `u ∈ [−1, 1]`, five terms as the inputs, Mamdani with min
//!   AND, min implication, max aggregation and the centroid over 101 samples
//!   (MATLAB's default; the exact closed form of the engine needs
//!   piecewise-linear output terms). `g_dF = 0.35` (section IV): the paper
//!   gives no unit; we take the feed in mm/s, so `|ΔF| ≤ 0.35 mm/s` per
//!   tick, i.e. the feed changes by at most 350 mm/s² at 1 ms.
//!
//! # Table 3.1: what survives and what we chose
//!
//! The seed's Table 3.1 lost its column headers and 17 of its 25 cells.
//! Eight cells survive, which matches section IV's "eight fuzzy if-then
//! control rules" (section 3.3 says 6). The rows are `Δε` = PB, PS, ZE, NS,
//! NB from top to bottom; we read the columns `ε` in the same order, PB..NB.
//! Then the printed cells say: a small error that **shrinks** (ε and Δε of
//! opposite signs) raises the feed a lot (PB), one that **grows** (same
//! signs) raises it a little (PS), a zero error raises it a lot, a big
//! steady error lowers it (NS). Read the other way round (columns NB..PB)
//! they would raise the feed hardest while the error grows, against the
//! paper's aim of holding the error within the bound.
//!
//! The eight rules alone ([`RULES_PRINTED`]) leave the controller without
//! an answer for a big error that keeps growing (PB/PS: the cell is empty,
//! only neighbours fire weakly and the feed is held, not lowered), so the
//! default ([`RULES`]) completes the table by the same logic, keeping the
//! eight printed cells: the output falls as `|ε|` grows and as the error's
//! growth `sign(ε)·Δε` grows, and the table is odd-symmetric
//! (`(ε, Δε)` and `(−ε, −Δε)` give the same output, as the printed cells
//! are), so that only the error's size and whether it grows matter.
//!
//! ```text
//!            ε:  PB   PS   ZO   NS   NB
//!   Δε = PB      NB   ZO   PS   PB   PS
//!        PS      NB  [PS] [PB] [PB]  ZO
//!        ZO     [NS]  PS   PB   PS  [NS]
//!        NS      ZO  [PB] [PB] [PS]  NB
//!        NB      PS   PB   PS   ZO   NB        [..]: printed in the paper
//! ```
//!
//! host-sim's `cho` subcommand runs both tables.

use fixed::types::I32F32;

use crate::fuzzy::{
    AndMethod, Controller, Implication, Inference, MembershipFn, OrMethod, Rule, Scratch,
    SystemDef, Term, Variable,
};
use crate::units::{FeedMmPerMin, Fx, FEED_LIMIT_MM_PER_MIN};

/// Term indices, the same for the inputs and the output.
pub mod terms {
    /// Negative big.
    pub const NB: u8 = 0;
    /// Negative small.
    pub const NS: u8 = 1;
    /// Zero.
    pub const ZO: u8 = 2;
    /// Positive small.
    pub const PS: u8 = 3;
    /// Positive big.
    pub const PB: u8 = 4;
}

/// `σ = √(a/2)` of eq. 3.1 with `a = 0.09`.
const SIGMA: &str = "0.212132";

/// Five Gaussian terms (eq. 3.1) on `[−1, 1]`: NB NS ZO PS PB.
pub const TERMS: [Term<'static>; 5] = [
    Term::new("NB", MembershipFn::gauss(SIGMA, "-1")),
    Term::new("NS", MembershipFn::gauss(SIGMA, "-0.5")),
    Term::new("ZO", MembershipFn::gauss(SIGMA, "0")),
    Term::new("PS", MembershipFn::gauss(SIGMA, "0.5")),
    Term::new("PB", MembershipFn::gauss(SIGMA, "1")),
];

const fn r(e: u8, de: u8, out: u8) -> Rule<2> {
    Rule::and([e, de], out)
}

/// The eight cells of Table 3.1 that survive (module docs).
pub const RULES_PRINTED: [Rule<2>; 8] = {
    use terms::*;
    [
        r(PS, PS, PS),
        r(ZO, PS, PB),
        r(NS, PS, PB),
        r(PB, ZO, NS),
        r(NB, ZO, NS),
        r(PS, NS, PB),
        r(ZO, NS, PB),
        r(NS, NS, PS),
    ]
};

/// Table 3.1 completed (module docs): the eight printed cells first, then
/// the seventeen we chose.
pub const RULES: [Rule<2>; 25] = {
    use terms::*;
    let chosen = [
        // Δε = PB.
        r(PB, PB, NB),
        r(PS, PB, ZO),
        r(ZO, PB, PS),
        r(NS, PB, PB),
        r(NB, PB, PS),
        // Δε = PS, ZO, NS: the outer columns and the centre.
        r(PB, PS, NB),
        r(NB, PS, ZO),
        r(PS, ZO, PS),
        r(ZO, ZO, PB),
        r(NS, ZO, PS),
        r(PB, NS, ZO),
        r(NB, NS, NB),
        // Δε = NB.
        r(PB, NB, PS),
        r(PS, NB, PB),
        r(ZO, NB, PS),
        r(NS, NB, ZO),
        r(NB, NB, NB),
    ];
    let mut all = [RULES_PRINTED[0]; 25];
    let mut i = 0;
    while i < all.len() {
        all[i] = if i < RULES_PRINTED.len() {
            RULES_PRINTED[i]
        } else {
            chosen[i - RULES_PRINTED.len()]
        };
        i += 1;
    }
    all
};

const fn system(name: &'static str, rules: &'static [Rule<2>]) -> SystemDef<'static, 2> {
    SystemDef {
        name,
        inference: Inference::Mamdani {
            implication: Implication::Min,
        },
        and: AndMethod::Min,
        or: OrMethod::Max,
        inputs: [
            Variable {
                name: "contour_error",
                unit: "fraction of the error bound",
                min: Fx::lit("-1"),
                max: Fx::lit("1"),
                terms: &TERMS,
            },
            Variable {
                name: "error_change",
                unit: "fraction of the error bound per K ticks",
                min: Fx::lit("-1"),
                max: Fx::lit("1"),
                terms: &TERMS,
            },
        ],
        output: Variable {
            name: "feed_change",
            unit: "fraction of g_dF",
            min: Fx::lit("-1"),
            max: Fx::lit("1"),
            terms: &TERMS,
        },
        rules,
        default_output: Fx::lit("0"),
    }
}

/// The controller with the completed Table 3.1 (the default).
pub const SYSTEM: SystemDef<'static, 2> = system("cho2002_feed", &RULES);

/// The controller with only the eight printed rules.
pub const SYSTEM_PRINTED: SystemDef<'static, 2> = system("cho2002_feed_printed", &RULES_PRINTED);

/// The compiled controller type: 2 inputs of 5 terms, 5 output terms, 101
/// centroid samples.
pub type ChoController = Controller<'static, 2, 5, 5, 101>;

/// [`SYSTEM`] compiled at build time.
pub static CONTROLLER: ChoController = match Controller::new(&SYSTEM) {
    Ok(c) => c,
    Err(_) => panic!("cho::SYSTEM is invalid"),
};

/// [`SYSTEM_PRINTED`] compiled at build time.
pub static CONTROLLER_PRINTED: ChoController = match Controller::new(&SYSTEM_PRINTED) {
    Ok(c) => c,
    Err(_) => panic!("cho::SYSTEM_PRINTED is invalid"),
};

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
    use super::terms::*;
    use super::*;

    fn out(e: f64, de: f64) -> f64 {
        CONTROLLER
            .evaluate([Fx::from_num(e), Fx::from_num(de)])
            .output
            .to_num()
    }

    fn cell(rules: &[Rule<2>], e: u8, de: u8) -> Option<u8> {
        rules
            .iter()
            .find(|r| r.when == Rule::and([e, de], 0).when)
            .map(|r| r.then)
    }

    #[test]
    fn the_completed_table_keeps_the_printed_cells_and_fills_the_grid() {
        for p in RULES_PRINTED {
            assert_eq!(RULES.iter().filter(|r| r.when == p.when).count(), 1);
            assert!(RULES.contains(&p), "{p:?}");
        }
        for e in 0..5 {
            for de in 0..5 {
                assert!(cell(&RULES, e, de).is_some(), "({e}, {de})");
            }
        }
    }

    #[test]
    fn the_table_is_odd_symmetric() {
        for rules in [&RULES[..], &RULES_PRINTED[..]] {
            for rl in rules {
                let (crate::fuzzy::Antecedent::Is(e), crate::fuzzy::Antecedent::Is(de)) =
                    (rl.when[0], rl.when[1])
                else {
                    panic!("{rl:?}")
                };
                assert_eq!(cell(rules, 4 - e, 4 - de), Some(rl.then), "{rl:?}");
            }
        }
    }

    #[test]
    fn the_table_lowers_the_feed_as_the_error_grows() {
        // For ε >= 0 (ZO, PS, PB) and any Δε, the output term does not rise
        // with ε; for any ε >= 0 it does not rise with Δε.
        for de in 0..5 {
            let col: [u8; 3] = [ZO, PS, PB].map(|e| cell(&RULES, e, de).unwrap());
            if de >= ZO {
                assert!(col[0] >= col[1] && col[1] >= col[2], "Δε {de}: {col:?}");
            }
        }
        for e in [PS, PB] {
            let row: [u8; 5] = [NB, NS, ZO, PS, PB].map(|de| cell(&RULES, e, de).unwrap());
            assert!(row.windows(2).all(|w| w[0] >= w[1]), "ε {e}: {row:?}");
        }
    }

    #[test]
    fn crisp_behaviour() {
        // No error: speed up; at the bound and steady: slow down; at the
        // bound and growing: slow down hard.
        assert!(out(0.0, 0.0) > 0.6);
        assert!(out(1.0, 0.0) < -0.3);
        assert!(out(1.0, 0.5) < out(1.0, 0.0));
        assert!(out(-1.0, -0.5) < out(1.0, 0.0) + 1e-4);
        // Shrinking error at half the bound: speed up more than growing.
        assert!(out(0.5, -0.5) > out(0.5, 0.5));
        // Somewhere between half the bound and the bound, the law holds
        // the feed (the error it regulates to).
        let hold = (50..=100)
            .map(|i| i as f64 / 100.0)
            .find(|&e| out(e, 0.0) <= 0.0)
            .unwrap();
        assert!(hold > 0.6 && hold < 0.95, "{hold}");
        // Odd symmetry of the crisp map.
        for (e, de) in [(0.3, 0.2), (0.8, -0.4), (0.1, 0.9)] {
            assert!((out(e, de) - out(-e, -de)).abs() < 2e-4, "({e}, {de})");
        }
    }

    #[test]
    fn the_printed_rules_alone_hold_the_feed_at_a_growing_big_error() {
        let e = CONTROLLER_PRINTED.evaluate([Fx::ONE, Fx::lit("0.5")]);
        assert!(e.output.abs() < Fx::lit("0.2"), "{e:?}");
        assert!(out(1.0, 0.5) < -0.5);
    }

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

    /// The crisp map against the reference's exact centroid: the 101-sample
    /// centroid is within 1 % of the output range.
    #[cfg(feature = "std")]
    #[test]
    fn sampled_centroid_is_close_to_the_exact_one() {
        let m = crate::reference::Mamdani::new(&SYSTEM);
        for i in -10..=10 {
            for j in -10..=10 {
                let x = [i as f64 / 10.0, j as f64 / 10.0];
                let exact = m.evaluate(x).unwrap();
                assert!((out(x[0], x[1]) - exact).abs() < 0.02, "{x:?}: {exact}");
            }
        }
    }
}
