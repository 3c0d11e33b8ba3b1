//! Lin et al.'s controller as data: the term sets of section 2.7.1 A (chosen,
//! module docs), rules R1-R30 of section 2.7.1 B, the system and its two
//! compiled forms.

use crate::fuzzy::{
    AndMethod, Controller, ExactController, Implication, Inference, MembershipFn, OrMethod, Rule,
    SystemDef, Term, Variable,
};
use crate::units::Fx;

/// Curvature term indices.
pub mod curvature_terms {
    /// Zero (straight).
    pub const ZO: u8 = 0;
    /// Very small.
    pub const VS: u8 = 1;
    /// Small.
    pub const S: u8 = 2;
    /// Medium.
    pub const M: u8 = 3;
    /// Big.
    pub const B: u8 = 4;
    /// Very big.
    pub const VB: u8 = 5;
}

/// Curvature-variation term indices.
pub mod variation_terms {
    /// Zero change.
    pub const ZO: u8 = 0;
    /// Low.
    pub const L: u8 = 1;
    /// Medium.
    pub const M: u8 = 2;
    /// High.
    pub const H: u8 = 3;
    /// Very high.
    pub const VH: u8 = 4;
}

/// Feed term indices (fractions of the maximum feed).
pub mod feed_terms {
    /// Extremely slow.
    pub const VLF: u8 = 0;
    /// Slow.
    pub const LF: u8 = 1;
    /// Medium.
    pub const MF: u8 = 2;
    /// High.
    pub const HF: u8 = 3;
    /// Very high.
    pub const VHF: u8 = 4;
    /// Extremely high.
    pub const VVHF: u8 = 5;
    /// Top feed.
    pub const TF: u8 = 6;
    /// R25/R26's "VVLF", read as the slowest set (see the module docs).
    pub const VVLF: u8 = VLF;
}

/// Curvature κ (1/mm): ZO VS S M B VB.
pub const CURVATURE_TERMS: [Term<'static>; 6] = [
    Term::new("ZO", MembershipFn::tri("-0.05", "0", "0.05")),
    Term::new("VS", MembershipFn::tri("0", "0.05", "0.15")),
    Term::new("S", MembershipFn::tri("0.05", "0.15", "0.4")),
    Term::new("M", MembershipFn::tri("0.15", "0.4", "1")),
    Term::new("B", MembershipFn::tri("0.4", "1", "3")),
    Term::new("VB", MembershipFn::tri("1", "3", "5")),
];

/// Normalised curvature variation Dκ (`[0, 1]`): ZO L M H VH.
pub const VARIATION_TERMS: [Term<'static>; 5] = [
    Term::new("ZO", MembershipFn::tri("-0.25", "0", "0.25")),
    Term::new("L", MembershipFn::tri("0", "0.25", "0.5")),
    Term::new("M", MembershipFn::tri("0.25", "0.5", "0.75")),
    Term::new("H", MembershipFn::tri("0.5", "0.75", "1")),
    Term::new("VH", MembershipFn::tri("0.75", "1", "1.25")),
];

/// Feed as a fraction of the maximum feed: VLF LF MF HF VHF VVHF TF.
pub const FEED_TERMS: [Term<'static>; 7] = [
    Term::new("VLF", MembershipFn::tri("-0.05", "0.1", "0.25")),
    Term::new("LF", MembershipFn::tri("0.1", "0.25", "0.4")),
    Term::new("MF", MembershipFn::tri("0.25", "0.4", "0.55")),
    Term::new("HF", MembershipFn::tri("0.4", "0.55", "0.7")),
    Term::new("VHF", MembershipFn::tri("0.55", "0.7", "0.85")),
    Term::new("VVHF", MembershipFn::tri("0.7", "0.85", "1")),
    Term::new("TF", MembershipFn::tri("0.85", "1", "1.15")),
];

const fn r(k: u8, dk: u8, feed: u8) -> Rule<2> {
    Rule::and([k, dk], feed)
}

/// R1-R30 of section 2.7.1 B, in the paper's order.
pub const RULES: [Rule<2>; 30] = {
    use curvature_terms as K;
    use feed_terms as F;
    use variation_terms as D;
    [
        r(K::ZO, D::ZO, F::TF),   // R1
        r(K::VS, D::ZO, F::VVHF), // R2
        r(K::S, D::ZO, F::VHF),   // R3
        r(K::M, D::ZO, F::HF),    // R4
        r(K::B, D::ZO, F::MF),    // R5
        r(K::VB, D::ZO, F::VLF),  // R6
        r(K::ZO, D::L, F::TF),    // R7
        r(K::VS, D::L, F::VVHF),  // R8
        r(K::S, D::L, F::HF),     // R9
        r(K::M, D::L, F::HF),     // R10
        r(K::B, D::L, F::LF),     // R11
        r(K::VB, D::L, F::VLF),   // R12
        r(K::ZO, D::M, F::VVHF),  // R13
        r(K::VS, D::M, F::VHF),   // R14
        r(K::S, D::M, F::HF),     // R15
        r(K::M, D::M, F::MF),     // R16
        r(K::B, D::M, F::LF),     // R17
        r(K::VB, D::M, F::VLF),   // R18
        r(K::ZO, D::H, F::VVHF),  // R19
        r(K::VS, D::H, F::VHF),   // R20
        r(K::S, D::H, F::HF),     // R21
        r(K::M, D::H, F::MF),     // R22
        r(K::B, D::H, F::VLF),    // R23
        r(K::VB, D::H, F::VLF),   // R24
        r(K::ZO, D::VH, F::VVLF), // R25 ("VVLF", read as VLF)
        r(K::VS, D::VH, F::VVLF), // R26 ("VVLF", read as VLF)
        r(K::S, D::VH, F::MF),    // R27
        r(K::M, D::VH, F::MF),    // R28
        r(K::B, D::VH, F::VLF),   // R29
        r(K::VB, D::VH, F::VLF),  // R30
    ]
};

/// The whole controller as data.
pub const SYSTEM: SystemDef<'static, 2> = SystemDef {
    name: "lin2021_feed",
    inference: Inference::Mamdani {
        implication: Implication::Min,
    },
    and: AndMethod::Min,
    or: OrMethod::Max,
    inputs: [
        Variable {
            name: "curvature",
            unit: "1/mm",
            min: Fx::lit("0"),
            max: Fx::lit("3"),
            terms: &CURVATURE_TERMS,
        },
        Variable {
            name: "variation",
            unit: "normalised Dk",
            min: Fx::lit("0"),
            max: Fx::lit("1"),
            terms: &VARIATION_TERMS,
        },
    ],
    output: Variable {
        name: "feed",
        unit: "fraction of F_max",
        min: Fx::lit("-0.05"),
        max: Fx::lit("1.2"),
        terms: &FEED_TERMS,
    },
    rules: &RULES,
    default_output: Fx::lit("0"),
};

/// The compiled controller type: 2 inputs, ≤ 6 terms each, 7 output terms,
/// 101 centroid samples.
pub type Lin2021Controller = Controller<'static, 2, 6, 7, 101>;

/// The compiled controller, built at compile time (its output membership
/// table lives in flash on the target).
pub static CONTROLLER: Lin2021Controller = match Controller::new(&SYSTEM) {
    Ok(c) => c,
    Err(_) => panic!("lin2021::SYSTEM is invalid"),
};

/// The controller as a firmware holds it: [`SYSTEM`] always takes the
/// engine's fast path (a complete rule grid with min AND, inputs
/// partitions, the output a chain: exact centroid), so the sampled output
/// table (7 × 101 degrees), the centroid scratch (101 words) and the general
/// inference path are left out ([`ExactController`]). Same outputs as [`CONTROLLER`], bit for
/// bit (tested); not for [`Controller::evaluate_sampled`] (Octave checks).
pub type Lin2021Compact = ExactController<'static, 2, 6, 7>;

/// [`Lin2021Compact`] built at compile time.
pub static COMPACT: Lin2021Compact = match ExactController::new(&SYSTEM) {
    Ok(c) => c,
    Err(_) => panic!("lin2021::SYSTEM is invalid"),
};

#[cfg(test)]
mod tests {
    use super::*;

    /// The firmware's compact build infers exactly like [`CONTROLLER`].
    #[test]
    fn compact_controller_is_bit_for_bit_the_same() {
        for i in -10..=340 {
            for j in -10..=130 {
                let x = [
                    Fx::from_num(i) / 100,
                    Fx::from_num(j) / 100 + Fx::from_bits(i * 7),
                ];
                assert_eq!(COMPACT.evaluate(x), CONTROLLER.evaluate(x), "{x:?}");
            }
        }
    }

    /// Through the scheduler's interface (one scratch kept across
    /// inferences) the compact controller gives the same outputs, and the
    /// scratch is left cleared.
    #[test]
    fn compact_controller_with_kept_scratch_is_the_same() {
        use crate::fuzzy::{ExactScratch, FuzzyInference};
        let mut scratch = ExactScratch::default();
        for i in (-10..=340).step_by(3) {
            for j in -10..=130 {
                let x = [Fx::from_num(i) / 100, Fx::from_num(j) / 100];
                assert_eq!(
                    COMPACT.infer(&mut scratch, x),
                    CONTROLLER.evaluate(x),
                    "{x:?}"
                );
            }
        }
        assert!(format!("{scratch:?}").contains("[0, 0, 0, 0, 0, 0, 0]"));
    }

    fn feed(k: f64, dk_norm: f64) -> f64 {
        CONTROLLER
            .evaluate([Fx::from_num(k), Fx::from_num(dk_norm)])
            .output
            .to_num()
    }

    #[test]
    fn straight_path_runs_at_full_feed_and_sharp_curves_slow() {
        assert_eq!(feed(0.0, 0.0), 1.0);
        assert!((feed(3.0, 1.0) - 0.10).abs() < 1e-4);
        // Along ZO/ZO..VB/ZO the feed falls monotonically.
        let mut last = 2.0;
        for i in 0..=300 {
            let f = feed(i as f64 / 100.0, 0.0);
            assert!(f <= last + 1e-9, "κ = {}", i as f64 / 100.0);
            last = f;
        }
    }

    #[test]
    fn every_input_fires_some_rule() {
        for i in 0..=60 {
            for j in 0..=20 {
                let e = CONTROLLER
                    .evaluate([Fx::from_num(i as f64 * 0.05), Fx::from_num(j as f64 * 0.05)]);
                assert!(e.fired);
                assert!(e.output >= Fx::lit("0.1") - Fx::from_bits(2) && e.output <= Fx::ONE);
            }
        }
    }

    #[test]
    fn sharp_feature_ahead_slows_a_straight() {
        assert!(
            (feed(0.0, 1.0) - 0.10).abs() < 1e-4,
            "R25: VVLF read as VLF"
        );
        assert!(feed(0.0, 1.0) < feed(0.0, 0.0));
    }
}
