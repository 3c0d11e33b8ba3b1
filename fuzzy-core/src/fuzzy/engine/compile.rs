//! [`Controller::new`]: validation of a [`SystemDef`] and everything the
//! inference paths read precomputed (compiled membership functions and their
//! supports, the output's sample table or Sugeno constants, the rule grid,
//! the partition flags, the exact centroid's chain), all in a `const fn`.

use super::super::centroid::Chain;
use super::super::membership::{CompiledMf, ONE};
use super::super::rule::{Antecedent, Connective};
use super::super::system::{AndMethod, ConfigError, Implication, Inference, SystemDef, VarRef};
use super::{Controller, GRID_MAX};

const fn input_ref(i: usize) -> VarRef {
    VarRef::Input(if i > 255 { 255 } else { i as u8 })
}

impl<'a, const NI: usize, const NT: usize, const NO: usize, const S: usize>
    Controller<'a, NI, NT, NO, S>
{
    /// Validate `def` and compile it.
    pub const fn new(def: &'a SystemDef<'a, NI>) -> Result<Self, ConfigError> {
        let mut c = Controller {
            def,
            inputs: [[CompiledMf::UNUSED; NT]; NI],
            upper: [[i32::MAX; NT]; NI],
            input_terms: [0; NI],
            input_range: [(0, 0); NI],
            output_terms: 0,
            out_min: def.output.min.to_bits(),
            out_max: def.output.max.to_bits(),
            constants: [0; NO],
            table: [[0; S]; NO],
            support: [(1, 0); NO],
            grid: None,
            stride: [0; NI],
            partition: [false; NI],
            chain: None,
        };
        if def.rules.is_empty() {
            return Err(ConfigError::NoRules);
        }
        if def.rules.len() > 1024 {
            return Err(ConfigError::TooManyRules);
        }
        // Inputs.
        let mut i = 0;
        while i < NI {
            let v = &def.inputs[i];
            let n = v.terms.len();
            if n == 0 {
                return Err(ConfigError::NoTerms(input_ref(i)));
            }
            if n > NT || n > 255 {
                return Err(ConfigError::TooManyTerms(input_ref(i)));
            }
            if v.min.to_bits() >= v.max.to_bits() {
                return Err(ConfigError::EmptyRange(input_ref(i)));
            }
            c.input_terms[i] = n as u8;
            c.input_range[i] = (v.min.to_bits(), v.max.to_bits());
            let mut t = 0;
            while t < n {
                let mf = &v.terms[t].mf;
                if mf.is_constant() {
                    return Err(ConfigError::WrongTermKind {
                        var: input_ref(i),
                        term: t as u8,
                    });
                }
                c.inputs[i][t] = match CompiledMf::compile(mf) {
                    Ok(m) => m,
                    Err(why) => {
                        return Err(ConfigError::BadMembership {
                            var: input_ref(i),
                            term: t as u8,
                            why,
                        })
                    }
                };
                c.upper[i][t] = c.inputs[i][t].upper_end();
                t += 1;
            }
            i += 1;
        }
        // Output.
        let out = &def.output;
        let n = out.terms.len();
        if n == 0 {
            return Err(ConfigError::NoTerms(VarRef::Output));
        }
        if n > NO || n > 255 {
            return Err(ConfigError::TooManyTerms(VarRef::Output));
        }
        if c.out_min >= c.out_max {
            return Err(ConfigError::EmptyRange(VarRef::Output));
        }
        let d = def.default_output.to_bits();
        if d < c.out_min || d > c.out_max {
            return Err(ConfigError::DefaultOutOfRange);
        }
        c.output_terms = n as u8;
        let mamdani = matches!(def.inference, Inference::Mamdani { .. });
        if mamdani && (S < 2 || S > 256) {
            return Err(ConfigError::BadSampleCount);
        }
        let span = c.out_max as i64 - c.out_min as i64;
        let mut k = 0;
        while k < n {
            let mf = &out.terms[k].mf;
            if mf.is_constant() == mamdani {
                return Err(ConfigError::WrongTermKind {
                    var: VarRef::Output,
                    term: k as u8,
                });
            }
            let m = match CompiledMf::compile(mf) {
                Ok(m) => m,
                Err(why) => {
                    return Err(ConfigError::BadMembership {
                        var: VarRef::Output,
                        term: k as u8,
                        why,
                    })
                }
            };
            if mamdani {
                let mut s = 0;
                let (mut lo, mut hi) = (1u16, 0u16);
                while s < S {
                    // x_s = min + s·(max − min)/(S − 1), rounded to Q16.16.
                    let x =
                        c.out_min as i64 + (s as i64 * span + (S as i64 - 1) / 2) / (S as i64 - 1);
                    let mu = m.degree(x as i32);
                    c.table[k][s] = mu;
                    if mu > 0 {
                        if lo > hi {
                            lo = s as u16;
                        }
                        hi = s as u16;
                    }
                    s += 1;
                }
                c.support[k] = (lo, hi);
            } else {
                c.constants[k] = m.constant();
            }
            k += 1;
        }
        // Rules.
        let mut r = 0;
        while r < def.rules.len() {
            let rule = &def.rules[r];
            let w = rule.weight.to_bits();
            if w < 0 || w > ONE {
                return Err(ConfigError::BadWeight { rule: r as u16 });
            }
            if rule.then as usize >= n {
                return Err(ConfigError::RuleTermOutOfRange {
                    rule: r as u16,
                    var: VarRef::Output,
                });
            }
            let mut i = 0;
            while i < NI {
                match rule.when[i] {
                    Antecedent::Any => {}
                    Antecedent::Is(t) | Antecedent::IsNot(t) => {
                        if t >= c.input_terms[i] {
                            return Err(ConfigError::RuleTermOutOfRange {
                                rule: r as u16,
                                var: input_ref(i),
                            });
                        }
                    }
                }
                i += 1;
            }
            r += 1;
        }
        c.grid = Self::compile_grid(def, &c.input_terms, &mut c.stride);
        let mut i = 0;
        while i < NI {
            c.partition[i] = is_partition(&c.inputs[i], c.input_terms[i] as usize);
            i += 1;
        }
        if let Inference::Mamdani {
            implication: Implication::Min,
        } = def.inference
        {
            let mut pwl = [(0, 0, 0, 0); NO];
            let mut all_pwl = true;
            let mut k = 0;
            while k < n {
                match CompiledMf::compile(&out.terms[k].mf) {
                    Ok(CompiledMf::Pwl { a, b, c, d, .. }) => pwl[k] = (a, b, c, d),
                    _ => all_pwl = false,
                }
                k += 1;
            }
            if all_pwl {
                c.chain = Chain::new(&pwl, n, c.out_min, c.out_max);
            }
        }
        Ok(c)
    }

    /// The consequent table of a complete rule grid, or `None`.
    const fn compile_grid(
        def: &SystemDef<'a, NI>,
        terms: &[u8; NI],
        stride: &mut [u16; NI],
    ) -> Option<[u8; GRID_MAX]> {
        let mut size = 1usize;
        let mut i = 0;
        while i < NI {
            stride[i] = size as u16;
            size *= terms[i] as usize;
            if size > GRID_MAX {
                return None;
            }
            i += 1;
        }
        if def.rules.len() != size {
            return None;
        }
        let mut grid = [0u8; GRID_MAX];
        let mut seen = [false; GRID_MAX];
        let mut r = 0;
        while r < def.rules.len() {
            let rule = &def.rules[r];
            if rule.weight.to_bits() != ONE || !matches!(rule.connective, Connective::And) {
                return None;
            }
            let mut code = 0usize;
            let mut i = 0;
            while i < NI {
                match rule.when[i] {
                    Antecedent::Is(t) => code += t as usize * stride[i] as usize,
                    _ => return None,
                }
                i += 1;
            }
            if code >= GRID_MAX || seen[code] {
                return None;
            }
            seen[code] = true;
            grid[code] = rule.then;
            r += 1;
        }
        Some(grid)
    }

    /// Whether [`Self::infer_partition_grid`] applies: grid rules with min AND,
    /// every input a partition, the output a chain (min implication).
    pub(super) const fn fast_path(&self) -> bool {
        let mut ok =
            self.grid.is_some() && self.chain.is_some() && matches!(self.def.and, AndMethod::Min);
        let mut i = 0;
        while i < NI {
            ok = ok && self.partition[i];
            i += 1;
        }
        ok
    }
}

/// Whether the first `n` compiled terms form a sorted partition: piecewise
/// linear, each term's left foot at or right of the previous term's right
/// shoulder and its left shoulder at or right of the previous term's right
/// foot, so that at most two consecutive terms are non-zero anywhere and the
/// first term with `x <= d` is the first that can be non-zero.
const fn is_partition<const NT: usize>(terms: &[CompiledMf; NT], n: usize) -> bool {
    let mut k = 0;
    while k < n {
        let CompiledMf::Pwl { a, b, d, .. } = terms[k] else {
            return false;
        };
        if k > 0 {
            let CompiledMf::Pwl { c: pc, d: pd, .. } = terms[k - 1] else {
                return false;
            };
            if a < pc || b < pd || d < pd {
                return false;
            }
            // Two vertical edges meeting at one x would make both terms 1
            // there, and a third one possibly non-zero.
            if a == b && pc == pd && a == pd {
                return false;
            }
        }
        k += 1;
    }
    true
}

#[cfg(test)]
mod tests {
    use super::super::super::rule::Rule;
    use super::super::fixture::DEF;
    use super::*;
    use crate::units::Fx;

    #[test]
    fn invalid_definitions_are_rejected() {
        const BAD_RULE: [Rule<1>; 1] = [Rule::and([3], 0)];
        let def = SystemDef {
            rules: &BAD_RULE,
            ..DEF
        };
        assert_eq!(
            Controller::<'_, 1, 3, 3>::new(&def).err(),
            Some(ConfigError::RuleTermOutOfRange {
                rule: 0,
                var: VarRef::Input(0)
            })
        );
        assert_eq!(
            Controller::<'_, 1, 2, 3>::new(&DEF).err(),
            Some(ConfigError::TooManyTerms(VarRef::Input(0)))
        );
        assert_eq!(
            Controller::<'_, 1, 3, 3, 1>::new(&DEF).err(),
            Some(ConfigError::BadSampleCount)
        );
        let def = SystemDef {
            default_output: Fx::lit("7"),
            ..DEF
        };
        assert_eq!(
            Controller::<'_, 1, 3, 3>::new(&def).err(),
            Some(ConfigError::DefaultOutOfRange)
        );
        let def = SystemDef { rules: &[], ..DEF };
        assert_eq!(
            Controller::<'_, 1, 3, 3>::new(&def).err(),
            Some(ConfigError::NoRules)
        );
    }
}
