//! Cho et al.'s controller as data: the Gaussian terms of eq. 3.1, Table 3.1
//! (the eight printed cells and the completed table, module docs), the two
//! systems and their compiled controllers.

use crate::fuzzy::{
    AndMethod, Controller, Implication, Inference, MembershipFn, OrMethod, Rule, SystemDef, Term,
    Variable,
};
use crate::units::Fx;

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
