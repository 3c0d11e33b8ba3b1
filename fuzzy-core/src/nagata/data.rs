//! Nagata et al.'s reasoners as data: the Gaussian sets of eq. 7, Table 1's
//! constants (as fractions, module docs), the two Sugeno systems of eq. 2-5
//! and their compiled controllers.

use crate::fuzzy::{
    AndMethod, Controller, Inference, MembershipFn, OrMethod, Rule, SugenoOutput, SystemDef, Term,
    Variable,
};
use crate::units::Fx;

/// Segment length `d(i)`, mm: Ã₁ … Ã₆, eq. 7 with q = 0.2
/// (σ = 1/(0.2·√(2 ln 2)) mm), centres 0-25 mm every 5 mm.
pub const LENGTH_TERMS: [Term<'static>; 6] = [
    Term::new("A1", MembershipFn::gauss("4.246609", "0")),
    Term::new("A2", MembershipFn::gauss("4.246609", "5")),
    Term::new("A3", MembershipFn::gauss("4.246609", "10")),
    Term::new("A4", MembershipFn::gauss("4.246609", "15")),
    Term::new("A5", MembershipFn::gauss("4.246609", "20")),
    Term::new("A6", MembershipFn::gauss("4.246609", "25")),
];

/// Length increment `Δd(i)`, mm: B̃₁ … B̃₆, eq. 7 with q = 0.1
/// (σ = 1/(0.1·√(2 ln 2)) mm), centres −25-25 mm every 10 mm.
pub const INCREMENT_TERMS: [Term<'static>; 6] = [
    Term::new("B1", MembershipFn::gauss("8.493218", "-25")),
    Term::new("B2", MembershipFn::gauss("8.493218", "-15")),
    Term::new("B3", MembershipFn::gauss("8.493218", "-5")),
    Term::new("B4", MembershipFn::gauss("8.493218", "5")),
    Term::new("B5", MembershipFn::gauss("8.493218", "15")),
    Term::new("B6", MembershipFn::gauss("8.493218", "25")),
];

/// Table 1, `cⱼᴬ = F_min + kⱼ·F_base`: the `kⱼ`.
pub const FEED_CONSTANTS: [Term<'static>; 6] = [
    Term::new("c1A", MembershipFn::constant("0.1")),
    Term::new("c2A", MembershipFn::constant("0.2")),
    Term::new("c3A", MembershipFn::constant("0.4")),
    Term::new("c4A", MembershipFn::constant("0.6")),
    Term::new("c5A", MembershipFn::constant("0.8")),
    Term::new("c6A", MembershipFn::constant("1")),
];

/// Table 1, `cⱼᴮ = kⱼ·F_min`: the `kⱼ`.
pub const COMPENSATION_CONSTANTS: [Term<'static>; 6] = [
    Term::new("c1B", MembershipFn::constant("-0.5")),
    Term::new("c2B", MembershipFn::constant("-0.2")),
    Term::new("c3B", MembershipFn::constant("-0.1")),
    Term::new("c4B", MembershipFn::constant("0.1")),
    Term::new("c5B", MembershipFn::constant("0.2")),
    Term::new("c6B", MembershipFn::constant("0.5")),
];

/// Rule `j`: IF the input is set `j` THEN constant `j` (L = 6).
const RULES: [Rule<1>; 6] = [
    Rule::and([0], 0),
    Rule::and([1], 1),
    Rule::and([2], 2),
    Rule::and([3], 3),
    Rule::and([4], 4),
    Rule::and([5], 5),
];

/// The feed reasoner (eq. 2, 4): `d(i)` in mm → `u_A`, the feed as a
/// fraction of F_base above F_min.
pub const FEED_SYSTEM: SystemDef<'static, 1> = SystemDef {
    name: "nagata_feed",
    inference: Inference::Sugeno {
        output: SugenoOutput::WeightedAverage,
    },
    and: AndMethod::Min,
    or: OrMethod::Max,
    inputs: [Variable {
        name: "d",
        unit: "mm",
        min: Fx::lit("0"),
        max: Fx::lit("25"),
        terms: &LENGTH_TERMS,
    }],
    output: Variable {
        name: "uA",
        unit: "F = F_min + uA*F_base",
        min: Fx::lit("0"),
        max: Fx::lit("1"),
        terms: &FEED_CONSTANTS,
    },
    rules: &RULES,
    default_output: Fx::lit("0.1"),
};

/// The compensation reasoner (eq. 3, 5): `Δd(i)` in mm → `u_B`, the
/// compensation as a fraction of F_min.
pub const COMPENSATION_SYSTEM: SystemDef<'static, 1> = SystemDef {
    name: "nagata_compensation",
    inference: Inference::Sugeno {
        output: SugenoOutput::WeightedAverage,
    },
    and: AndMethod::Min,
    or: OrMethod::Max,
    inputs: [Variable {
        name: "dd",
        unit: "mm",
        min: Fx::lit("-25"),
        max: Fx::lit("25"),
        terms: &INCREMENT_TERMS,
    }],
    output: Variable {
        name: "uB",
        unit: "dF = uB*F_min",
        min: Fx::lit("-0.5"),
        max: Fx::lit("0.5"),
        terms: &COMPENSATION_CONSTANTS,
    },
    rules: &RULES,
    default_output: Fx::lit("0"),
};

/// A compiled Nagata reasoner: 1 input of 6 terms, 6 constants (Sugeno: no
/// centroid samples).
pub type NagataController = Controller<'static, 1, 6, 6, 1>;

/// The feed reasoner, built at compile time (a static's initializer is
/// evaluated by the compiler: an invalid table fails the build, it cannot
/// panic at run time).
pub static FEED_CONTROLLER: NagataController = match Controller::new(&FEED_SYSTEM) {
    Ok(c) => c,
    Err(_) => panic!("nagata::FEED_SYSTEM is invalid"),
};

/// The compensation reasoner, built at compile time (as the feed
/// reasoner).
pub static COMPENSATION_CONTROLLER: NagataController = match Controller::new(&COMPENSATION_SYSTEM) {
    Ok(c) => c,
    Err(_) => panic!("nagata::COMPENSATION_SYSTEM is invalid"),
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sigma_is_eq7_q() {
        // exp(log 0.5 · (x − p)² q²) = 0.5 at |x − p| = 1/q.
        for (terms, q) in [(&LENGTH_TERMS, 0.2), (&INCREMENT_TERMS, 0.1)] {
            let MembershipFn::Gaussian { sigma, center } = terms[2].mf else {
                panic!()
            };
            let x = center + Fx::from_num(1.0 / q);
            let mu: f64 = terms[2].mf.degree(x).unwrap().to_num();
            assert!((mu - 0.5).abs() < 1e-4, "{mu}");
            let s: f64 = sigma.to_num();
            assert!((s - 1.0 / (q * (2.0 * 2f64.ln()).sqrt())).abs() < 1e-5);
        }
    }
}
