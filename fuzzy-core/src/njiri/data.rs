//! Njiri et al.'s controller as data: the terms of section II.B, Table I
//! (generator and rules), the system of section II.D and its two compiled
//! forms.

use crate::fuzzy::{
    AndMethod, Controller, ExactController, Implication, Inference, MembershipFn, OrMethod, Rule,
    SystemDef, Term, Variable,
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fuzzy::FuzzyInference;
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

    /// The firmware's compact build infers exactly like [`CONTROLLER`].
    #[test]
    fn compact_controller_is_bit_for_bit_the_same() {
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
        let mut raw = crate::test_rng::xorshift64(0x2545_F491_4F6C_DD1D);
        let mut next = || (raw() >> 11) as f64 / (1u64 << 53) as f64 * 4.0 - 2.0;
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
