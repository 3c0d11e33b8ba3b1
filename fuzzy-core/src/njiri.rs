//! The force-feedback feed-override controller of Njiri, Ikua & Nyakoe,
//! "Feedrate optimization for ball-end milling of sculptured surfaces using
//! fuzzy logic controller" (2011), section II, as data on the generic engine,
//! and the step function a firmware calls once per spindle revolution.
//!
//! | paper | here |
//! |---|---|
//! | II.A: inputs ΔX = F_Xref − F_X, Δ²X = ΔX(k+1) − ΔX(k), ΔY, Δ²Y | [`ForceOverride::step`] |
//! | II.B: three triangular terms Ne Ze Po on ±1.5 N (Fig. 7) | [`ERROR_TERMS`] |
//! | II.B: FRPO 0-150 %, five trapezoids NS NM Ze PM PL (Fig. 8) | [`FRPO_TERMS`] |
//! | II.C, Table I: 81 rules, only 1-9 and 81 printed | [`consequent`], [`RULES`] |
//! | II.D, eq. 9: min for AND; Mamdani; centre of gravity | [`SYSTEM`] (exact centroid) |
//! | III.B: F_x = 120 N, F_y = 40 N reference peaks | [`OverrideConfig::PAPER`] |
//!
//! # Choices where the paper is incomplete
//!
//! **Rule table (Table I).** Rules 1-9 and 81 are printed; the numbering runs
//! through the terms with Δ²Y fastest (rule `n` has the base-3 digits of
//! `n − 1` as (ΔX, Δ²X, ΔY, Δ²Y) with Ne = 0, Ze = 1, Po = 2). Counting
//! Ne = −1, Ze = 0, Po = +1 and summing the four antecedents gives
//! `s ∈ [−4, 4]`; the printed rules are exactly
//!
//! | s | −4, −3 | −2 | −1, 0 | 1 | 2 | 3, 4 |
//! |---|---|---|---|---|---|---|
//! | FRPO | NS | NM | Ze | *Ze* | *PM* | PL |
//!
//! where rules 1-9 fix `s ≤ 0` (rules 2 and 4, 3 and 7, 6 and 8 show that
//! an error and its change weigh the same), rule 81 fixes `s = 4`, and the
//! italic entries follow by the symmetry of the paper's stated logic
//! ("when cutting force exceeded the reference … reduced the table feed …
//! when the force was below the reference … increased the feedrate"): Ne and
//! Po are mirror images, so `s` and `−s` give mirrored terms (NS ↔ PL,
//! NM ↔ PM, Ze ↔ Ze). X and Y weigh the same because rules 1-9, which vary
//! only Y, give the same outputs as the sum with X's part. [`consequent`]
//! is the generator; a test checks that it reproduces the printed rules.
//!
//! **Membership functions (Figures 7-8 lost).** Inputs: Ne = `trimf(−1.5,
//! −1.5, 0)`, Ze = `trimf(−1.5, 0, 1.5)`, Po = `trimf(0, 1.5, 1.5)`, a
//! partition of ±1.5 N with shoulders at the ends; inputs beyond ±1.5 N are
//! clamped (a 30 N excess counts as fully Ne). Output (percent of the
//! programmed feed): the names say "negative"/"zero"/"positive", i.e. *less
//! than / equal to / more than the programmed feed*, so Ze is centred on
//! 100 %: NS `(0, 0, 10, 30)`, NM `(10, 30, 80, 95)`, Ze `(80, 95, 105,
//! 120)`, PM `(105, 120, 130, 145)`, PL `(130, 145, 150, 150)`. A partition
//! (the exact closed-form centroid applies); Ze alone gives exactly 100 %,
//! NS alone ≈ 11 %, PL alone ≈ 143 %. With max aggregation the output is
//! not strictly monotone in each input: Ze is the consequent of both
//! `s = −1` and `s = 0`, and where two such rules cross the strength of Ze
//! dips (by up to 1.6 % of override on a 0.1 N grid, tested); a larger
//! error in either direction still always moves the override that way.
//!
//! **How FRPO drives the feed.** The paper: "the actual feedrate is computed
//! by multiplying the preprogrammed feedrate by the FRPO". Taken literally
//! ([`OverrideLaw::Absolute`]: override = FRPO) the loop cannot hold a
//! force: the inputs saturate at ±1.5 N while the force moves by ~1.5 N per
//! percent of override, a loop gain of about 70, and the closed loop in
//! host-sim jumps between NS and PL. The paper's result (the override
//! *settles* at 78 % with the force *held* at 120 N) is what an
//! error/change-of-error controller gives in velocity form, the classical
//! reading of such a rule base (the terms are changes: NS … PL about
//! Ze = "no change"): [`OverrideLaw::Incremental`],
//! `override(k) = override(k−1) + g·(FRPO(k) − 100 %)`, clamped to 0-150 %,
//! with `g` = 0.05 by default (at most −4.4 % / +2.2 % per revolution):
//! in host-sim's loop (one revolution of delay, 64 ms acc/dec) g = 0.1
//! leaves a ±1.7 % limit cycle around the equilibrium and g = 0.05 settles
//! within 4 s. Both laws are here; the default is the incremental one. At the first sample
//! there is no previous error: Δ² = 0.
//!
//! The controller is meant to run once per spindle revolution on the peak
//! forces of that revolution ([`PeakWindow`] collects them from raw
//! samples): the paper controls *peak* cutting forces.

use crate::fuzzy::{
    AndMethod, Controller, ExactController, FuzzyInference, Implication, Inference, MembershipFn,
    OrMethod, Rule, SystemDef, Term, Variable,
};
use crate::units::Fx;

/// Input term indices (each of ΔX, Δ²X, ΔY, Δ²Y).
pub mod input_terms {
    /// Negative: force above the reference (or rising).
    pub const NE: u8 = 0;
    /// Zero.
    pub const ZE: u8 = 1;
    /// Positive: force below the reference (or falling).
    pub const PO: u8 = 2;
}

/// Output (FRPO) term indices, from the slowest to the fastest feed.
pub mod frpo_terms {
    /// "Negative small": the lowest override.
    pub const NS: u8 = 0;
    /// "Negative medium".
    pub const NM: u8 = 1;
    /// Zero change: 100 %.
    pub const ZE: u8 = 2;
    /// Positive medium.
    pub const PM: u8 = 3;
    /// Positive large: the highest override.
    pub const PL: u8 = 4;
}

/// Force error and change of force error, N: Ne Ze Po over ±1.5 N
/// (section II.B, Figure 7).
pub const ERROR_TERMS: [Term<'static>; 3] = [
    Term::new("Ne", MembershipFn::tri("-1.5", "-1.5", "0")),
    Term::new("Ze", MembershipFn::tri("-1.5", "0", "1.5")),
    Term::new("Po", MembershipFn::tri("0", "1.5", "1.5")),
];

/// Feed-rate percentage override, %: NS NM Ze PM PL over 0-150 %
/// (section II.B, Figure 8; breakpoints chosen, see the module docs).
pub const FRPO_TERMS: [Term<'static>; 5] = [
    Term::new("NS", MembershipFn::trap("0", "0", "10", "30")),
    Term::new("NM", MembershipFn::trap("10", "30", "80", "95")),
    Term::new("Ze", MembershipFn::trap("80", "95", "105", "120")),
    Term::new("PM", MembershipFn::trap("105", "120", "130", "145")),
    Term::new("PL", MembershipFn::trap("130", "145", "150", "150")),
];

/// The consequent of the rule whose antecedents are `when` (term indices of
/// ΔX, Δ²X, ΔY, Δ²Y): the generator of Table I (module docs). Out-of-range
/// indices count as Po.
pub const fn consequent(when: [u8; 4]) -> u8 {
    let mut s: i32 = 0;
    let mut i = 0;
    while i < 4 {
        let t = if when[i] > 2 { 2 } else { when[i] };
        s += t as i32 - 1;
        i += 1;
    }
    if s <= -3 {
        frpo_terms::NS
    } else if s == -2 {
        frpo_terms::NM
    } else if s <= 1 {
        frpo_terms::ZE
    } else if s == 2 {
        frpo_terms::PM
    } else {
        frpo_terms::PL
    }
}

/// The antecedents of rule `n` of Table I (1-based): the base-3 digits of
/// `n − 1`, ΔX most significant. `n` outside 1..=81 wraps.
pub const fn antecedents(n: usize) -> [u8; 4] {
    let k = (n + 80) % 81;
    [
        (k / 27 % 3) as u8,
        (k / 9 % 3) as u8,
        (k / 3 % 3) as u8,
        (k % 3) as u8,
    ]
}

/// Table I, all 81 rules in the paper's order (rule `n` at index `n − 1`).
pub const RULES: [Rule<4>; 81] = {
    let mut rules = [Rule::and([0; 4], 0); 81];
    let mut n = 1;
    while n <= 81 {
        let when = antecedents(n);
        rules[n - 1] = Rule::and(when, consequent(when));
        n += 1;
    }
    rules
};

const fn force_input(name: &'static str) -> Variable<'static> {
    Variable {
        name,
        unit: "N",
        min: Fx::lit("-1.5"),
        max: Fx::lit("1.5"),
        terms: &ERROR_TERMS,
    }
}

/// The whole controller as data (section II): Mamdani, min AND (eq. 9), min
/// implication, max aggregation, centre of gravity.
pub const SYSTEM: SystemDef<'static, 4> = SystemDef {
    name: "njiri2011_frpo",
    inference: Inference::Mamdani {
        implication: Implication::Min,
    },
    and: AndMethod::Min,
    or: OrMethod::Max,
    inputs: [
        force_input("dX"),
        force_input("d2X"),
        force_input("dY"),
        force_input("d2Y"),
    ],
    output: Variable {
        name: "FRPO",
        unit: "%",
        min: Fx::lit("0"),
        max: Fx::lit("150"),
        terms: &FRPO_TERMS,
    },
    rules: &RULES,
    // Unreachable (the input terms are partitions), and harmless: no change.
    default_output: Fx::lit("100"),
};

/// The compiled controller type: 4 inputs of 3 terms, 5 output terms.
pub type NjiriController = Controller<'static, 4, 3, 5>;

/// The compiled controller, built at compile time.
pub static CONTROLLER: NjiriController = match Controller::new(&SYSTEM) {
    Ok(c) => c,
    Err(_) => panic!("njiri::SYSTEM is invalid"),
};

/// The controller as a firmware holds it ([`COMPACT`]): [`SYSTEM`] always
/// takes the engine's fast path (a complete rule grid with min AND, inputs
/// partitions, the output a chain: exact centroid), so the sampled table
/// and scratch are left out ([`ExactController`]); up to 7 output terms (5
/// used), so that the centroid code is the one [`crate::lin2021::COMPACT`]
/// uses. Same outputs as [`CONTROLLER`], bit for bit (tested).
pub type NjiriCompact = ExactController<'static, 4, 3, 7>;

/// [`NjiriCompact`] built at compile time.
pub static COMPACT: NjiriCompact = match ExactController::new(&SYSTEM) {
    Ok(c) => c,
    Err(_) => panic!("njiri::SYSTEM is invalid"),
};

/// A force in newtons, Q16.16 (±32767 N, resolution 15 µN).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ForceN(pub Fx);

impl ForceN {
    /// From newtons as `f64` (saturating; NaN gives 0).
    pub fn from_f64(v: f64) -> Self {
        if v.is_nan() {
            return ForceN(Fx::ZERO);
        }
        ForceN(Fx::saturating_from_num(v))
    }

    /// The value in newtons.
    pub fn to_f64(self) -> f64 {
        self.0.to_num()
    }
}

/// A feed override in percent of the programmed feed, Q16.16.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct OverridePct(pub Fx);

impl OverridePct {
    /// 100 %: the programmed feed.
    pub const PROGRAMMED: OverridePct = OverridePct(Fx::lit("100"));
    /// The lower end of the FRPO range, 0 %.
    pub const MIN: OverridePct = OverridePct(Fx::ZERO);
    /// The upper end of the FRPO range, 150 %.
    pub const MAX: OverridePct = OverridePct(Fx::lit("150"));

    /// The value in percent.
    pub fn to_f64(self) -> f64 {
        self.0.to_num()
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for ForceN {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(f, "{=f32} N", self.0.to_num::<f32>())
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for OverridePct {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(f, "{=f32} %", self.0.to_num::<f32>())
    }
}

/// How the controller's FRPO becomes the feed override (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum OverrideLaw {
    /// The paper's sentence taken literally: override = FRPO.
    Absolute,
    /// Velocity form: `override += gain · (FRPO − 100 %)`, clamped to
    /// 0-150 %.
    Incremental {
        /// Fraction of the FRPO's departure from 100 % applied per step,
        /// in `(0, 1]`.
        gain: Fx,
    },
}

/// Settings of [`ForceOverride`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct OverrideConfig {
    /// Reference peak forces `[F_x, F_y]` (section III.A: 120 N and 40 N).
    pub reference: [ForceN; 2],
    /// How FRPO drives the override.
    pub law: OverrideLaw,
    /// The override before the first step (and after [`ForceOverride::reset`]).
    pub initial: OverridePct,
}

impl OverrideConfig {
    /// The paper's references, the incremental law with gain 0.05, starting
    /// at the programmed feed.
    pub const PAPER: OverrideConfig = OverrideConfig {
        reference: [ForceN(Fx::lit("120")), ForceN(Fx::lit("40"))],
        law: OverrideLaw::Incremental {
            gain: Fx::lit("0.05"),
        },
        initial: OverridePct::PROGRAMMED,
    };

    /// Check the settings.
    pub fn validate(&self) -> Result<(), OverrideError> {
        if self.reference.iter().any(|r| r.0 <= Fx::ZERO) {
            return Err(OverrideError::BadReference);
        }
        if let OverrideLaw::Incremental { gain } = self.law {
            if gain <= Fx::ZERO || gain > Fx::ONE {
                return Err(OverrideError::BadGain);
            }
        }
        if self.initial < OverridePct::MIN || self.initial > OverridePct::MAX {
            return Err(OverrideError::BadInitial);
        }
        Ok(())
    }
}

impl Default for OverrideConfig {
    fn default() -> Self {
        Self::PAPER
    }
}

/// Why an [`OverrideConfig`] is refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum OverrideError {
    /// A reference force is not positive.
    BadReference,
    /// The incremental gain is outside `(0, 1]`.
    BadGain,
    /// The initial override is outside 0-150 %.
    BadInitial,
}

impl core::fmt::Display for OverrideError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            OverrideError::BadReference => "reference peak forces must be positive",
            OverrideError::BadGain => "incremental gain must be in (0, 1]",
            OverrideError::BadInitial => "initial override must be within 0-150 %",
        })
    }
}

/// What one step saw and decided (for logs and plots).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StepTrace {
    /// Controller inputs ΔX, Δ²X, ΔY, Δ²Y in N, before clamping to ±1.5 N.
    pub inputs: [Fx; 4],
    /// The controller's crisp output (FRPO), %.
    pub frpo: OverridePct,
    /// The override after this step, %.
    pub override_pct: OverridePct,
}

/// The closed-loop override: feed it the peak forces of each revolution,
/// apply the returned override to the programmed feed. `no_std`, no
/// allocation, no panics; about 0.5 KiB on [`CONTROLLER`] (mostly the
/// centroid scratch), under 100 bytes on [`COMPACT`].
#[derive(Clone, Debug)]
pub struct ForceOverride<'c, C: FuzzyInference<4> = NjiriController> {
    controller: &'c C,
    config: OverrideConfig,
    scratch: C::Scratch,
    previous_error: Option<[Fx; 2]>,
    override_pct: OverridePct,
    last: StepTrace,
}

impl<'c, C: FuzzyInference<4>> ForceOverride<'c, C> {
    /// A controller with `config` (checked) on `controller` (normally
    /// [`CONTROLLER`], or [`COMPACT`] in a firmware).
    pub fn new(controller: &'c C, config: OverrideConfig) -> Result<Self, OverrideError> {
        config.validate()?;
        Ok(ForceOverride {
            controller,
            config,
            scratch: C::Scratch::default(),
            previous_error: None,
            override_pct: config.initial,
            last: StepTrace::default(),
        })
    }

    /// The settings.
    pub fn config(&self) -> &OverrideConfig {
        &self.config
    }

    /// The current override, %.
    pub fn override_pct(&self) -> OverridePct {
        self.override_pct
    }

    /// What the last step saw and decided.
    pub fn last_step(&self) -> StepTrace {
        self.last
    }

    /// Forget the history: the next step has Δ² = 0 and the override is the
    /// initial one again.
    pub fn reset(&mut self) {
        self.previous_error = None;
        self.override_pct = self.config.initial;
        self.last = StepTrace::default();
    }

    /// One sampling interval: `peak` = measured peak forces `[F_x, F_y]` of
    /// the last revolution (magnitudes, N). Returns the override to apply, %
    /// (always within 0-150 %).
    pub fn step(&mut self, peak: [ForceN; 2]) -> OverridePct {
        let r = self.config.reference;
        // Section II.A: ΔX = F_Xref − F_X, Δ²X = ΔX(k+1) − ΔX(k).
        let e = [
            r[0].0.saturating_sub(peak[0].0),
            r[1].0.saturating_sub(peak[1].0),
        ];
        let de = match self.previous_error {
            Some(p) => [e[0].saturating_sub(p[0]), e[1].saturating_sub(p[1])],
            None => [Fx::ZERO; 2],
        };
        self.previous_error = Some(e);
        let inputs = [e[0], de[0], e[1], de[1]];
        let frpo = self
            .controller
            .infer(&mut self.scratch, inputs)
            .output
            .clamp(OverridePct::MIN.0, OverridePct::MAX.0);
        let next = match self.config.law {
            OverrideLaw::Absolute => frpo,
            OverrideLaw::Incremental { gain } => {
                let change = gain.saturating_mul(frpo - OverridePct::PROGRAMMED.0);
                self.override_pct.0.saturating_add(change)
            }
        }
        .clamp(OverridePct::MIN.0, OverridePct::MAX.0);
        self.override_pct = OverridePct(next);
        self.last = StepTrace {
            inputs,
            frpo: OverridePct(frpo),
            override_pct: self.override_pct,
        };
        self.override_pct
    }
}

/// Peak force magnitudes over a window of raw samples (one spindle
/// revolution): what [`ForceOverride::step`] takes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PeakWindow {
    peak: [Fx; 2],
    samples: u32,
}

impl PeakWindow {
    /// An empty window.
    pub const fn new() -> Self {
        PeakWindow {
            peak: [Fx::ZERO; 2],
            samples: 0,
        }
    }

    /// Add one sample `[F_x, F_y]` (signed, N).
    pub fn push(&mut self, f: [ForceN; 2]) {
        for (p, v) in self.peak.iter_mut().zip(f) {
            *p = (*p).max(v.0.saturating_abs());
        }
        self.samples = self.samples.saturating_add(1);
    }

    /// Number of samples since the last [`Self::take`].
    pub fn samples(&self) -> u32 {
        self.samples
    }

    /// The peak magnitudes and an empty window; `None` if no sample came.
    pub fn take(&mut self) -> Option<[ForceN; 2]> {
        let out = (self.samples > 0).then_some([ForceN(self.peak[0]), ForceN(self.peak[1])]);
        *self = PeakWindow::new();
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use frpo_terms as O;
    use input_terms::{NE, PO, ZE};

    /// Table I as printed: rules 1-9 and 81.
    const PRINTED: [(usize, [u8; 4], u8); 10] = [
        (1, [NE, NE, NE, NE], O::NS),
        (2, [NE, NE, NE, ZE], O::NS),
        (3, [NE, NE, NE, PO], O::NM),
        (4, [NE, NE, ZE, NE], O::NS),
        (5, [NE, NE, ZE, ZE], O::NM),
        (6, [NE, NE, ZE, PO], O::ZE),
        (7, [NE, NE, PO, NE], O::NM),
        (8, [NE, NE, PO, ZE], O::ZE),
        (9, [NE, NE, PO, PO], O::ZE),
        (81, [PO, PO, PO, PO], O::PL),
    ];

    #[test]
    fn generator_reproduces_the_printed_rules() {
        for (n, when, then) in PRINTED {
            assert_eq!(antecedents(n), when, "rule {n}");
            assert_eq!(RULES[n - 1], Rule::and(when, then), "rule {n}");
        }
    }

    #[test]
    fn table_is_complete_and_mirror_symmetric() {
        assert_eq!(RULES.len(), 81);
        let mirror = |t: u8| 2 - t;
        for (i, r) in RULES.iter().enumerate() {
            assert_eq!(
                antecedents(i + 1),
                RULES[i].when.map(|a| match a {
                    crate::fuzzy::Antecedent::Is(t) => t,
                    _ => 9,
                })
            );
            // Swapping Ne and Po everywhere mirrors the output.
            let when = antecedents(i + 1).map(mirror);
            assert_eq!(consequent(when), 4 - r.then, "rule {}", i + 1);
        }
        // Every input combination appears once: the engine compiles a grid.
        let mut seen = [false; 81];
        for n in 1..=81 {
            let a = antecedents(n);
            let k = a[0] as usize * 27 + a[1] as usize * 9 + a[2] as usize * 3 + a[3] as usize;
            assert!(!seen[k]);
            seen[k] = true;
        }
    }

    fn frpo(x: [f64; 4]) -> f64 {
        CONTROLLER.evaluate(x.map(Fx::from_num)).output.to_num()
    }

    #[test]
    fn force_above_reference_lowers_the_feed() {
        assert!(CONTROLLER.has_exact_centroid());
        assert!((frpo([0.0; 4]) - 100.0).abs() < 1e-3);
        // All Ne: NS alone.
        let ns = frpo([-1.5; 4]);
        assert!(ns < 15.0, "{ns}");
        // All Po: PL alone.
        let pl = frpo([1.5; 4]);
        assert!(pl > 140.0, "{pl}");
        // Beyond the universe: clamped.
        assert_eq!(frpo([-30.0; 4]), ns);
        // Each input pushes the right way: the same inputs with one of them
        // at +1.5 N never give a lower override than with it at −1.5 N, and
        // in between the output dips by at most 1.6 % (max aggregation: where
        // two rules with the same consequent cross, that term's strength
        // dips; module docs).
        let grid: Vec<f64> = (-6..=6).map(|k| k as f64 * 0.25).collect();
        for i in 0..4 {
            for &a in &grid {
                for &b in &grid {
                    for &c in &grid {
                        let mut others = [a, b, c].into_iter();
                        let mut x: [f64; 4] = core::array::from_fn(|k| {
                            if k == i {
                                0.0
                            } else {
                                others.next().unwrap_or(0.0)
                            }
                        });
                        x[i] = -1.5;
                        let lo = frpo(x);
                        x[i] = 1.5;
                        assert!(frpo(x) >= lo, "input {i}: {x:?}");
                        let mut last = -1.0;
                        for k in -15..=15 {
                            x[i] = k as f64 * 0.1;
                            let y = frpo(x);
                            assert!(y >= last - 1.6, "input {i}: {x:?}");
                            last = y;
                        }
                    }
                }
            }
        }
    }

    fn step_all(c: &mut ForceOverride<'_>, fx: f64, fy: f64) -> f64 {
        c.step([ForceN::from_f64(fx), ForceN::from_f64(fy)])
            .to_f64()
    }

    #[test]
    fn incremental_law_reduces_on_excess_and_holds_at_reference() {
        let mut c = ForceOverride::new(&CONTROLLER, OverrideConfig::PAPER).unwrap();
        assert_eq!(step_all(&mut c, 120.0, 40.0), 100.0);
        assert_eq!(step_all(&mut c, 120.0, 40.0), 100.0);
        let o = step_all(&mut c, 150.0, 50.0);
        assert!(o < 96.0, "{o}");
        let t = c.last_step();
        assert_eq!(t.inputs[0], Fx::from_num(-30));
        assert_eq!(t.inputs[1], Fx::from_num(-30));
        // Far below: increases, but never beyond 150 %.
        for _ in 0..200 {
            step_all(&mut c, 10.0, 5.0);
        }
        assert_eq!(c.override_pct(), OverridePct::MAX);
        c.reset();
        assert_eq!(c.override_pct(), OverridePct::PROGRAMMED);
    }

    /// The firmware's compact build infers exactly like [`CONTROLLER`], and
    /// the override loop on it steps through the same values.
    #[test]
    fn compact_controller_is_bit_for_bit_the_same() {
        assert!(COMPACT.is_exact());
        let xs = [
            -2.0, -1.5, -1.1, -0.75, -0.3, 0.0, 0.2, 0.6, 1.0, 1.4, 1.5, 3.0,
        ];
        // One scratch kept across inferences, as the firmware does.
        let mut scratch = crate::fuzzy::ExactScratch::default();
        for a in xs {
            for b in xs {
                for c in xs {
                    for d in [-1.5, -0.4, 0.0, 0.9, 1.5] {
                        let x = [a, b, c, d].map(Fx::from_num);
                        let want = CONTROLLER.evaluate(x);
                        assert_eq!(COMPACT.infer(&mut scratch, x), want, "{x:?}");
                    }
                }
            }
        }
        let mut big = ForceOverride::new(&CONTROLLER, OverrideConfig::PAPER).unwrap();
        let mut small = ForceOverride::new(&COMPACT, OverrideConfig::PAPER).unwrap();
        assert!(core::mem::size_of_val(&small) < 100);
        for k in 0..300 {
            let f = [
                ForceN::from_f64(100.0 + (k % 37) as f64 * 1.3),
                ForceN::from_f64(35.0 + (k % 11) as f64 * 0.9),
            ];
            assert_eq!(big.step(f), small.step(f), "step {k}");
        }
    }

    #[test]
    fn absolute_law_is_the_frpo() {
        let cfg = OverrideConfig {
            law: OverrideLaw::Absolute,
            ..OverrideConfig::PAPER
        };
        let mut c = ForceOverride::new(&CONTROLLER, cfg).unwrap();
        // First step (Δ² = 0): ΔX, ΔY Ne, Δ²X, Δ²Y Ze: NM.
        let o = step_all(&mut c, 125.0, 45.0);
        assert_eq!(o, c.last_step().frpo.to_f64());
        assert!(o > 30.0 && o < 80.0, "{o}");
        // Rising further: all Ne, NS.
        assert!(step_all(&mut c, 135.0, 55.0) < 15.0);
    }

    #[test]
    fn bad_settings_are_refused() {
        let p = OverrideConfig::PAPER;
        let bad = [
            OverrideConfig {
                reference: [ForceN(Fx::ZERO), ForceN(Fx::ONE)],
                ..p
            },
            OverrideConfig {
                law: OverrideLaw::Incremental { gain: Fx::ZERO },
                ..p
            },
            OverrideConfig {
                law: OverrideLaw::Incremental {
                    gain: Fx::from_num(2),
                },
                ..p
            },
            OverrideConfig {
                initial: OverridePct(Fx::from_num(151)),
                ..p
            },
        ];
        for b in bad {
            assert!(ForceOverride::new(&CONTROLLER, b).is_err(), "{b:?}");
        }
    }

    #[test]
    fn peak_window() {
        let mut w = PeakWindow::new();
        assert_eq!(w.take(), None);
        for (x, y) in [(10.0, -3.0), (-120.5, 2.0), (60.0, 41.0)] {
            w.push([ForceN::from_f64(x), ForceN::from_f64(y)]);
        }
        assert_eq!(w.samples(), 3);
        assert_eq!(
            w.take(),
            Some([ForceN::from_f64(120.5), ForceN::from_f64(41.0)])
        );
        assert_eq!(w.samples(), 0);
        w.push([ForceN(Fx::MIN), ForceN(Fx::ZERO)]);
        assert_eq!(w.take().unwrap()[0].0, Fx::MAX);
    }

    /// The controller in `f64`, straight from the module docs: triangles on
    /// ±1.5 N (inputs clamped), the sum rule of Table I, min AND, min
    /// implication, max aggregation, centroid by numerical integration.
    fn reference_frpo(x: [f64; 4]) -> f64 {
        let tri = |a: f64, b: f64, c: f64, v: f64| {
            if v < a || v > c {
                0.0
            } else if v <= b {
                if b == a {
                    1.0
                } else {
                    (v - a) / (b - a)
                }
            } else if c == b {
                1.0
            } else {
                (c - v) / (c - b)
            }
        };
        let trap = |a: f64, b: f64, c: f64, d: f64, v: f64| {
            if v < a || v > d {
                0.0
            } else if v < b {
                (v - a) / (b - a)
            } else if v <= c {
                1.0
            } else {
                (d - v) / (d - c)
            }
        };
        let input = |t: usize, v: f64| {
            let v = v.clamp(-1.5, 1.5);
            match t {
                0 => tri(-1.5, -1.5, 0.0, v),
                1 => tri(-1.5, 0.0, 1.5, v),
                _ => tri(0.0, 1.5, 1.5, v),
            }
        };
        let out = |t: usize, y: f64| match t {
            0 => trap(-1.0, 0.0, 10.0, 30.0, y),
            1 => trap(10.0, 30.0, 80.0, 95.0, y),
            2 => trap(80.0, 95.0, 105.0, 120.0, y),
            3 => trap(105.0, 120.0, 130.0, 145.0, y),
            _ => trap(130.0, 145.0, 150.0, 151.0, y),
        };
        let mut strength = [0.0f64; 5];
        for k in 0..81usize {
            let t = [k / 27 % 3, k / 9 % 3, k / 3 % 3, k % 3];
            let w = (0..4).map(|i| input(t[i], x[i])).fold(1.0, f64::min);
            let sum: i32 = t.iter().map(|&v| v as i32 - 1).sum();
            let then = match sum {
                -4 | -3 => 0,
                -2 => 1,
                -1..=1 => 2,
                2 => 3,
                _ => 4,
            };
            strength[then] = strength[then].max(w);
        }
        let (mut num, mut den) = (0.0, 0.0);
        let n = 30_000;
        for i in 0..=n {
            let y = 150.0 * i as f64 / n as f64;
            let mu = (0..5)
                .map(|t| strength[t].min(out(t, y)))
                .fold(0.0, f64::max);
            num += mu * y;
            den += mu;
        }
        num / den
    }

    #[test]
    fn matches_the_f64_reference() {
        // A deterministic spread of inputs over and beyond the universe.
        let mut state = 0x2545_F491_4F6C_DD1Du64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 * 4.0 - 2.0
        };
        let mut worst = 0.0f64;
        for _ in 0..400 {
            let x = [next(), next(), next(), next()];
            let d = (frpo(x) - reference_frpo(x)).abs();
            worst = worst.max(d);
        }
        for x in [[0.0; 4], [-1.5; 4], [1.5; 4], [-0.75, 0.0, 0.3, -1.2]] {
            worst = worst.max((frpo(x) - reference_frpo(x)).abs());
        }
        assert!(worst < 0.05, "largest difference {worst} %");
    }
}
