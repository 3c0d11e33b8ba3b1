//! The general path: any rules (weights, OR, NOT, incomplete or repeated
//! grids), any membership functions, Mamdani with the exact chain centroid
//! when the output allows it or the `S`-sample centroid of eq. 11, and
//! zero-order Sugeno.

use super::super::membership::ONE;
use super::super::rule::{Antecedent, Connective};
use super::super::system::{AndMethod, Implication, Inference, OrMethod, SugenoOutput};
use super::{saturate_i32, Controller, Evaluation, Scratch};
use crate::numerics::wide::divlu;
use crate::units::Fx;

impl<'a, const NI: usize, const NT: usize, const NO: usize, const S: usize>
    Controller<'a, NI, NT, NO, S>
{
    pub(super) fn infer_impl(
        &self,
        scratch: &mut Scratch<S>,
        inputs: [Fx; NI],
        sampled: bool,
    ) -> Evaluation {
        if !sampled && self.fast_path() {
            return self.infer_partition_grid(inputs);
        }
        let def = self.def;
        let mamdani = matches!(def.inference, Inference::Mamdani { .. });
        let mut strength = [0i32; NO];
        let (mut num, mut den) = (0i64, 0i64);
        let mut best = 0i32;
        // 2. (below) Rule strengths are collected per output term.
        let mut fire = |then: u8, w: i32| {
            best = best.max(w);
            if mamdani {
                if let Some(s) = strength.get_mut(then as usize) {
                    *s = (*s).max(w);
                }
            } else {
                let c = self.constants.get(then as usize).copied().unwrap_or(0);
                num = num.saturating_add(w as i64 * c as i64);
                den += w as i64;
            }
        };
        if let Some(grid) = &self.grid {
            // 1. Fuzzification, keeping only the non-zero terms.
            let mut term = [[0u8; NT]; NI];
            let mut degree = [[0i32; NT]; NI];
            let mut count = [0usize; NI];
            let mut combos = 1usize;
            for (i, x) in inputs.iter().enumerate() {
                let (Some(mfs), Some(&(lo, hi)), Some(&n)) = (
                    self.inputs.get(i),
                    self.input_range.get(i),
                    self.input_terms.get(i),
                ) else {
                    continue;
                };
                let (Some(term), Some(degree), Some(count)) =
                    (term.get_mut(i), degree.get_mut(i), count.get_mut(i))
                else {
                    continue;
                };
                let x = x.to_bits().max(lo).min(hi);
                // In a partition only the term whose span holds x and the next
                // can be non-zero: skip to it.
                let first = if self.partition.get(i).copied().unwrap_or(false) {
                    mfs.iter()
                        .take(n as usize)
                        .position(|mf| mf.upper_end() >= x)
                        .unwrap_or(0)
                } else {
                    0
                };
                let last = if first > 0 || self.partition.get(i).copied().unwrap_or(false) {
                    (first + 2).min(n as usize)
                } else {
                    n as usize
                };
                for (t, mf) in mfs.iter().enumerate().take(last).skip(first) {
                    let m = mf.degree(x);
                    if m > 0 {
                        if let (Some(ts), Some(ds)) = (term.get_mut(*count), degree.get_mut(*count))
                        {
                            *ts = t as u8;
                            *ds = m;
                            *count += 1;
                        }
                    }
                }
                combos *= *count;
            }
            // 2. Only combinations of non-zero terms can fire (at most 2^NI for
            // partitions): decode each combination's digits in mixed radix.
            for combo in 0..combos {
                let mut rest = combo;
                let mut w = ONE;
                let mut code = 0usize;
                for (((term, degree), &n), &stride) in term
                    .iter()
                    .zip(degree.iter())
                    .zip(count.iter())
                    .zip(self.stride.iter())
                {
                    let digit = rest % n.max(1);
                    rest /= n.max(1);
                    let m = degree.get(digit).copied().unwrap_or(0);
                    w = match def.and {
                        AndMethod::Min => w.min(m),
                        AndMethod::Product => ((w as i64 * m as i64 + (1 << 15)) >> 16) as i32,
                    };
                    code += term.get(digit).copied().unwrap_or(0) as usize * stride as usize;
                }
                if w > 0 {
                    fire(grid.get(code).copied().unwrap_or(0), w);
                }
            }
        } else {
            // 1. Fuzzification.
            let mut mu = [[0i32; NT]; NI];
            for (row, (x, ((mfs, &(lo, hi)), &n))) in mu.iter_mut().zip(
                inputs.iter().zip(
                    self.inputs
                        .iter()
                        .zip(self.input_range.iter())
                        .zip(self.input_terms.iter()),
                ),
            ) {
                let x = x.to_bits().max(lo).min(hi);
                for (m, mf) in row.iter_mut().zip(mfs.iter()).take(n as usize) {
                    *m = mf.degree(x);
                }
            }
            // 2. Every rule.
            for rule in def.rules {
                let mut w = rule_strength(def.and, def.or, rule.connective, &rule.when, &mu);
                if w <= 0 {
                    continue;
                }
                let weight = rule.weight.to_bits();
                if weight != ONE {
                    w = ((w as i64 * weight as i64 + (1 << 15)) >> 16) as i32;
                    if w <= 0 {
                        continue;
                    }
                }
                fire(rule.then, w);
            }
        }
        let fired = best > 0;
        let default = Evaluation {
            output: def.default_output,
            fired: false,
            strength: Fx::ZERO,
        };
        if !fired {
            return default;
        }
        let out = match def.inference {
            Inference::Mamdani { implication } => {
                let v = match (&self.chain, sampled) {
                    (Some(chain), false) => chain.centroid_q30(&strength, 0, NO).map(|u| {
                        let span = (self.out_max as i64 - self.out_min as i64) as u64;
                        let offset = (span * u as u64 + (1 << 29)) >> 30;
                        saturate_i32(self.out_min as i64 + offset as i64)
                    }),
                    _ => self.centroid(scratch, &strength, implication),
                };
                match v {
                    Some(v) => v,
                    None => return default,
                }
            }
            Inference::Sugeno {
                output: SugenoOutput::WeightedAverage,
            } => {
                if den == 0 {
                    return default;
                }
                let half = den / 2;
                // (checked: no overflow trap on i64::MIN / −1)
                let q = if num >= 0 {
                    num.saturating_add(half).checked_div(den)
                } else {
                    num.saturating_sub(half).checked_div(den)
                };
                saturate_i32(q.unwrap_or(if (num < 0) == (den < 0) {
                    i64::MAX
                } else {
                    i64::MIN
                }))
            }
            Inference::Sugeno {
                output: SugenoOutput::WeightedSum,
            } => saturate_i32((num + (1 << 15)) >> 16),
        };
        Evaluation {
            output: Fx::from_bits(out),
            fired,
            strength: Fx::from_bits(best),
        }
    }

    /// Centroid of the aggregated output (raw), `None` if the aggregate is
    /// zero at every sample. Only the samples where some fired term is
    /// non-zero are touched.
    fn centroid(
        &self,
        scratch: &mut Scratch<S>,
        strength: &[i32; NO],
        implication: Implication,
    ) -> Option<i32> {
        // Union of the fired terms' supports, [lo, hi).
        let (mut lo, mut hi) = (usize::MAX, 0usize);
        for (&(a, b), &s) in self.support.iter().zip(strength.iter()) {
            if s > 0 && a <= b {
                lo = lo.min(a as usize);
                hi = hi.max(b as usize + 1);
            }
        }
        let window = scratch.agg.get_mut(lo..hi)?;
        for ((row, &(a, b)), &s) in self
            .table
            .iter()
            .zip(self.support.iter())
            .zip(strength.iter())
        {
            if s <= 0 || a > b {
                continue;
            }
            let (a, end) = (a as usize, b as usize + 1);
            let (Some(dst), Some(src)) = (window.get_mut(a - lo..end - lo), row.get(a..end)) else {
                continue;
            };
            match implication {
                Implication::Min => {
                    for (d, &m) in dst.iter_mut().zip(src) {
                        let v = if m < s { m } else { s };
                        if v > *d {
                            *d = v;
                        }
                    }
                }
                Implication::Product => {
                    for (d, &m) in dst.iter_mut().zip(src) {
                        let v = ((m as i64 * s as i64 + (1 << 15)) >> 16) as i32;
                        if v > *d {
                            *d = v;
                        }
                    }
                }
            }
        }
        // S <= 256 and degrees <= 2^16: both sums fit 32 bits.
        let (mut sum, mut moment) = (0u32, 0u32);
        let mut i = lo as u32;
        // A plain counter: a tighter loop on the target than `zip` with a range.
        #[allow(clippy::explicit_counter_loop)]
        for u in window.iter_mut() {
            let v = *u as u32;
            sum = sum.wrapping_add(v);
            moment = moment.wrapping_add(i.wrapping_mul(v));
            i += 1;
            *u = 0; // leave the scratch cleared
        }
        if sum == 0 {
            return None;
        }
        // centroid = min + (max − min) · moment / (sum · (S − 1)), eq. 11;
        // moment <= sum·(S − 1), so the Q31 ratio fits 32 bits.
        let den = sum.wrapping_mul(S as u32 - 1);
        let (p_q31, _) = divlu(moment >> 1, (moment & 1) << 31, den);
        let span = (self.out_max as i64 - self.out_min as i64) as u64;
        let offset = (span * p_q31 as u64 + (1 << 30)) >> 31;
        Some(saturate_i32(self.out_min as i64 + offset as i64))
    }
}

/// Firing strength of one rule (raw Q16.16, before its weight). An AND rule
/// stops at its first zero condition (most rules of a partition).
fn rule_strength<const NI: usize, const NT: usize>(
    and: AndMethod,
    or: OrMethod,
    connective: Connective,
    when: &[Antecedent; NI],
    mu: &[[i32; NT]; NI],
) -> i32 {
    let mut acc: Option<i32> = None;
    for (ante, row) in when.iter().zip(mu.iter()) {
        let d = match *ante {
            Antecedent::Any => continue,
            Antecedent::Is(t) => row.get(t as usize).copied().unwrap_or(0),
            Antecedent::IsNot(t) => ONE - row.get(t as usize).copied().unwrap_or(0),
        };
        if d == 0 && connective == Connective::And {
            return 0;
        }
        acc = Some(match acc {
            None => d,
            Some(a) => match connective {
                Connective::And => match and {
                    AndMethod::Min => a.min(d),
                    AndMethod::Product => ((a as i64 * d as i64 + (1 << 15)) >> 16) as i32,
                },
                Connective::Or => match or {
                    OrMethod::Max => a.max(d),
                    OrMethod::ProbOr => a + d - ((a as i64 * d as i64 + (1 << 15)) >> 16) as i32,
                },
            },
        });
    }
    // A rule with no conditions always fires fully (MATLAB does the same).
    acc.unwrap_or(ONE).clamp(0, ONE)
}

#[cfg(test)]
mod tests {
    use super::super::super::membership::MembershipFn;
    use super::super::super::rule::Rule;
    use super::super::super::system::{SystemDef, Term, Variable};
    use super::super::fixture::DEF;
    use super::*;

    #[test]
    fn no_rule_fired_gives_default() {
        const ONLY_P: [Rule<1>; 1] = [Rule::and([2], 0)];
        let def = SystemDef {
            rules: &ONLY_P,
            default_output: Fx::lit("1.5"),
            ..DEF
        };
        let c: Controller<'_, 1, 3, 3> = Controller::new(&def).unwrap();
        let e = c.evaluate([-Fx::ONE]);
        assert!(!e.fired);
        assert_eq!(e.output, Fx::lit("1.5"));
    }

    #[test]
    fn sugeno_weighted_average() {
        const CONSTS: [Term<'static>; 3] = [
            Term::new("a", MembershipFn::constant("10")),
            Term::new("b", MembershipFn::constant("20")),
            Term::new("c", MembershipFn::constant("40")),
        ];
        const R: [Rule<1>; 3] = [Rule::and([0], 0), Rule::and([1], 1), Rule::and([2], 2)];
        let def = SystemDef {
            inference: Inference::Sugeno {
                output: SugenoOutput::WeightedAverage,
            },
            output: Variable {
                name: "y",
                unit: "",
                min: Fx::lit("0"),
                max: Fx::lit("50"),
                terms: &CONSTS,
            },
            rules: &R,
            ..DEF
        };
        let c: Controller<'_, 1, 3, 3, 1> = Controller::new(&def).unwrap();
        assert_eq!(c.evaluate([Fx::ZERO]).output, Fx::from_num(20));
        assert_eq!(c.evaluate([Fx::lit("0.5")]).output, Fx::from_num(30));
        assert_eq!(c.evaluate([Fx::lit("-0.25")]).output, Fx::from_num(17.5));
    }

    #[test]
    fn grid_and_generic_rule_paths_agree() {
        use crate::lin2021::{CONTROLLER, RULES, SYSTEM};
        assert!(CONTROLLER.grid.is_some());
        assert_eq!(CONTROLLER.partition, [true, true]);
        // The same rules with one duplicated (weight 1, same consequent):
        // not a grid any more, same result.
        let mut rules = [RULES[0]; 31];
        rules[..30].copy_from_slice(&RULES);
        let def = SystemDef {
            rules: &rules,
            ..SYSTEM
        };
        let generic: Controller<'_, 2, 6, 7> = Controller::new(&def).unwrap();
        assert!(generic.grid.is_none());
        let mut scratch = Scratch::new();
        for i in 0..=60 {
            for j in 0..=40 {
                let x = [
                    Fx::from_num(i as f64 * 0.05),
                    Fx::from_num(j as f64 * 0.025),
                ];
                assert_eq!(
                    CONTROLLER.evaluate_with(&mut scratch, x),
                    generic.evaluate(x),
                    "{x:?}"
                );
            }
        }
        assert!(scratch.agg.iter().all(|&a| a == 0));
    }

    #[test]
    fn sampled_centroid_is_close_to_the_exact_one() {
        use crate::lin2021::CONTROLLER;
        for i in 0..=30 {
            for j in 0..=20 {
                let x = [Fx::from_num(i as f64 * 0.1), Fx::from_num(j as f64 * 0.05)];
                let a: f64 = CONTROLLER.evaluate(x).output.to_num();
                let b: f64 = CONTROLLER.evaluate_sampled(x).output.to_num();
                assert!((a - b).abs() < 5e-4, "{x:?}: exact {a}, sampled {b}");
            }
        }
    }
}
