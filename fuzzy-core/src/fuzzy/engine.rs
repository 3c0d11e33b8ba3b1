//! The compiled fuzzy controller: validation once, then allocation-free,
//! division-light evaluation.
//!
//! Inference (Mamdani or zero-order Sugeno, see [`Inference`]):
//! 1. fuzzification: each input is clamped to its universe and every term's
//!    degree is computed;
//! 2. rule strength: AND (min or product) / OR (max or probabilistic) of the
//!    antecedents, times the rule weight (Lin et al. use min for AND);
//! 3. Mamdani: each output term is clipped (min) or scaled (product) by the
//!    strongest rule naming it, the terms are aggregated with max, and the
//!    centroid of the aggregate is taken over `S` equally spaced samples of
//!    the output universe (Lin et al. eq. 11; `S = 101` is MATLAB's and
//!    Octave's default, so an exported controller gives the same output there);
//!    Sugeno: the weighted average (or sum) of the rules' constants.
//!
//! When no rule fires the output is [`SystemDef::default_output`] and
//! [`Evaluation::fired`] is false.
//!
//! A `Controller` can be built in a `const` or `static` (its constructor is a
//! `const fn`): the output membership table then lives in flash and an invalid
//! definition is a compile error.

use super::centroid::Chain;
use super::membership::{CompiledMf, ONE};
use super::rule::{Antecedent, Connective};
use super::system::{
    AndMethod, ConfigError, Implication, Inference, OrMethod, SugenoOutput, SystemDef, VarRef,
};
use crate::fixmath::divlu;
use crate::units::Fx;

/// The result of one inference.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Evaluation {
    /// Crisp output, in the output variable's unit.
    pub output: Fx,
    /// Whether any rule fired (otherwise `output` is the default).
    pub fired: bool,
    /// The largest rule firing strength, in `[0, 1]`.
    pub strength: Fx,
}

/// Anything that maps `NI` crisp inputs to one crisp output, with a
/// caller-owned scratch area (so that repeated inferences need not clear
/// large buffers).
pub trait FuzzyInference<const NI: usize> {
    /// Working memory kept between inferences.
    type Scratch: Default;
    /// One inference.
    fn infer(&self, scratch: &mut Self::Scratch, inputs: [Fx; NI]) -> Evaluation;
}

impl<const NI: usize, T: FuzzyInference<NI> + ?Sized> FuzzyInference<NI> for &T {
    type Scratch = T::Scratch;
    fn infer(&self, scratch: &mut Self::Scratch, inputs: [Fx; NI]) -> Evaluation {
        (**self).infer(scratch, inputs)
    }
}

/// Working memory of a Mamdani centroid over `S` samples: all zero between
/// inferences, so each inference clears only the samples it touched.
#[derive(Clone, Debug)]
pub struct Scratch<const S: usize> {
    agg: [i32; S],
}

impl<const S: usize> Scratch<S> {
    /// A cleared scratch area.
    pub const fn new() -> Self {
        Scratch { agg: [0; S] }
    }
}

impl<const S: usize> Default for Scratch<S> {
    fn default() -> Self {
        Self::new()
    }
}

/// Largest rule grid (product of the inputs' term counts) compiled into a
/// lookup table.
const GRID_MAX: usize = 256;

/// A compiled fuzzy system with `NI` inputs of at most `NT` terms each, an
/// output of at most `NO` terms, and (Mamdani) `S` centroid samples.
#[derive(Clone, Debug)]
pub struct Controller<'a, const NI: usize, const NT: usize, const NO: usize, const S: usize = 101> {
    def: &'a SystemDef<'a, NI>,
    inputs: [[CompiledMf; NT]; NI],
    /// Right end of each input term's support (raw; `i32::MAX` if
    /// unbounded or unused): the partition path's scan for the active terms
    /// reads these instead of matching on every term.
    upper: [[i32; NT]; NI],
    input_terms: [u8; NI],
    input_range: [(i32, i32); NI],
    output_terms: u8,
    out_min: i32,
    out_max: i32,
    /// Sugeno constants (raw).
    constants: [i32; NO],
    /// Mamdani: degree of each output term at each sample (raw Q16.16).
    table: [[i32; S]; NO],
    /// First and last sample with a non-zero degree (`(1, 0)` if none).
    support: [(u16, u16); NO],
    /// When the rules are a complete grid (each combination of input terms
    /// exactly once, AND, weight 1): the consequent of each combination, at
    /// index `Σ term_i · stride_i`.
    grid: Option<[u8; GRID_MAX]>,
    /// Mixed-radix strides of the grid.
    stride: [u16; NI],
    /// Per input: whether its terms are a sorted partition of triangles and
    /// trapezoids (each term's feet on its neighbours' shoulders), so that at
    /// most two consecutive terms are non-zero at any input.
    partition: [bool; NI],
    /// The exact closed-form centroid, when the output terms form a chain
    /// (see [`super::centroid`]) and the implication is min.
    chain: Option<Chain<NO>>,
}

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

    /// The definition this controller was compiled from.
    pub const fn def(&self) -> &'a SystemDef<'a, NI> {
        self.def
    }

    /// Degree of input `input`'s term `term` at `x` (for plots and tests);
    /// 0 for a term that does not exist.
    pub fn input_degree(&self, input: usize, term: usize, x: Fx) -> Fx {
        let mf = self.inputs.get(input).and_then(|t| t.get(term));
        Fx::from_bits(mf.map_or(0, |m| m.degree(x.to_bits())))
    }

    /// The `S` sample positions of the Mamdani centroid (raw Q16.16).
    pub fn sample_position(&self, s: usize) -> Fx {
        let span = self.out_max as i64 - self.out_min as i64;
        let den = (S as i64 - 1).max(1);
        Fx::from_bits((self.out_min as i64 + (s as i64 * span + (den / 2)) / den) as i32)
    }

    /// One inference: inputs in their variables' units (clamped to their
    /// universes). Uses a fresh scratch area; repeated callers should keep
    /// one and call [`Self::evaluate_with`].
    pub fn evaluate(&self, inputs: [Fx; NI]) -> Evaluation {
        self.evaluate_with(&mut Scratch::new(), inputs)
    }

    /// One inference with a caller-kept scratch area (left cleared).
    pub fn evaluate_with(&self, scratch: &mut Scratch<S>, inputs: [Fx; NI]) -> Evaluation {
        self.infer_impl(scratch, inputs, false)
    }

    /// One inference whose Mamdani centroid is always the `S`-sample sum of
    /// eq. 11 (MATLAB's `centroid` with `NumSamplePoints = S`), for
    /// comparing with MATLAB/Octave output to the last digit. [`Self::evaluate`]
    /// computes the exact integral when it can.
    pub fn evaluate_sampled(&self, inputs: [Fx; NI]) -> Evaluation {
        self.infer_impl(&mut Scratch::new(), inputs, true)
    }

    /// The inference of [`Self::evaluate`] when it takes its fast path
    /// (rules a complete grid with min AND, every input a partition, the
    /// output a chain with min implication: the exact centroid), else
    /// `None`. Bit for bit [`Self::evaluate`]'s result, without the code of
    /// the general path: for a firmware whose controller always qualifies.
    pub fn evaluate_exact(&self, inputs: [Fx; NI]) -> Option<Evaluation> {
        self.fast_path().then(|| self.infer_partition_grid(inputs))
    }

    /// Whether the exact closed-form centroid is used (chain of
    /// triangles/trapezoids, min implication).
    pub fn has_exact_centroid(&self) -> bool {
        self.chain.is_some()
    }

    /// Whether [`Self::infer_partition_grid`] applies: grid rules with min AND,
    /// every input a partition, the output a chain (min implication).
    const fn fast_path(&self) -> bool {
        let mut ok =
            self.grid.is_some() && self.chain.is_some() && matches!(self.def.and, AndMethod::Min);
        let mut i = 0;
        while i < NI {
            ok = ok && self.partition[i];
            i += 1;
        }
        ok
    }

    /// Input `i` at `x` (raw, clamped to the universe) on a partition: the
    /// first term that can be non-zero, its degree and the next term's (0
    /// when there is none).
    #[inline(always)]
    fn candidates(&self, i: usize, x: Fx) -> (usize, i32, i32) {
        let (Some(mfs), Some(upper), Some(&terms), Some(&(lo, hi))) = (
            self.inputs.get(i),
            self.upper.get(i),
            self.input_terms.get(i),
            self.input_range.get(i),
        ) else {
            return (0, 0, 0);
        };
        let n = (terms as usize).min(NT);
        let x = x.to_bits().max(lo).min(hi);
        let mut j = 0;
        while j + 1 < n && upper.get(j).is_some_and(|&u| u < x) {
            j += 1;
        }
        // `match`, not `map_or`: the latter stayed an out-of-line call.
        let first = match mfs.get(j) {
            Some(mf) => mf.degree(x),
            None => 0,
        };
        let next = match mfs.get(j + 1) {
            Some(mf) if j + 1 < n => mf.degree(x),
            _ => 0,
        };
        (j, first, next)
    }

    /// The common case in a few plain loops: with partitioned inputs at most
    /// two neighbouring terms per input are non-zero, so at most `2^NI` rules
    /// fire; each adds its strength to its consequent; the chain's closed-form
    /// centroid follows. Same results as the general path, bit for bit.
    fn infer_partition_grid(&self, inputs: [Fx; NI]) -> Evaluation {
        self.infer_partition_grid_in(&mut [0; NO], inputs)
    }

    /// [`Self::infer_partition_grid`] with the consequents' strengths in
    /// `strength`, which must be all zero and is left all zero (a fresh
    /// local array cost a `memset` call per inference on the target).
    fn infer_partition_grid_in(&self, strength: &mut [i32; NO], inputs: [Fx; NI]) -> Evaluation {
        let def = self.def;
        let default = Evaluation {
            output: def.default_output,
            fired: false,
            strength: Fx::ZERO,
        };
        let (Some(grid), Some(chain)) = (&self.grid, &self.chain) else {
            return default;
        };
        // Each fired rule adds its strength to its consequent (max);
        // `lowest..=highest` is the range of fired consequents.
        let mut f = Fired {
            strength,
            lowest: NO,
            highest: 0,
            best: 0,
        };
        if NI == 2 {
            // Two inputs (Lin's controller, the scheduler's hot path): the
            // four candidate rules written out.
            let input = |i: usize| inputs.get(i).copied().unwrap_or(Fx::ZERO);
            let stride = |i: usize| self.stride.get(i).copied().unwrap_or(0) as usize;
            let (j0, a0, b0) = self.candidates(0, input(0));
            let (j1, a1, b1) = self.candidates(1, input(1));
            let (s0, s1) = (stride(0), stride(1));
            let base = j0 * s0 + j1 * s1;
            f.fire(grid, a0.min(a1), base);
            if b0 > 0 {
                f.fire(grid, b0.min(a1), base + s0);
            }
            if b1 > 0 {
                f.fire(grid, a0.min(b1), base + s1);
                if b0 > 0 {
                    f.fire(grid, b0.min(b1), base + s0 + s1);
                }
            }
        } else {
            // Per input: the first candidate term and the two degrees.
            // `base` is the grid index of the rule made of every input's
            // first candidate; `second` has bit i set when input i's second
            // candidate is non-zero, so the rules worth visiting are the
            // sub-masks of `second`.
            let mut base = 0usize;
            let mut second = 0usize;
            let mut deg = [[0i32; 2]; NI];
            for (i, ((d, &x), &step)) in deg
                .iter_mut()
                .zip(inputs.iter())
                .zip(self.stride.iter())
                .enumerate()
            {
                let (j, first, next) = self.candidates(i, x);
                base += j * step as usize;
                *d = [first, next];
                if next > 0 {
                    second |= 1 << i;
                }
            }
            let mut mask = second;
            loop {
                let mut w = ONE;
                let mut code = base;
                for (i, (d, &step)) in deg.iter().zip(self.stride.iter()).enumerate() {
                    if (mask >> i) & 1 != 0 {
                        w = w.min(d[1]);
                        code += step as usize;
                    } else {
                        w = w.min(d[0]);
                    }
                }
                f.fire(grid, w, code);
                if mask == 0 {
                    break;
                }
                mask = (mask - 1) & second;
            }
        }
        let best = f.best;
        if best == 0 || f.lowest > f.highest {
            return default;
        }
        let centroid = chain.centroid_q30(f.strength, f.lowest, f.highest);
        // Every fired consequent is in lowest..=highest. (The zero goes
        // through `black_box` so that the loop stays a few stores instead
        // of becoming a `memset` call.)
        let zero = core::hint::black_box(0);
        for s in f.strength.iter_mut().take(f.highest + 1).skip(f.lowest) {
            *s = zero;
        }
        match centroid {
            Some(u) => {
                let span = (self.out_max as i64 - self.out_min as i64) as u64;
                let offset = (span * u as u64 + (1 << 29)) >> 30;
                Evaluation {
                    output: Fx::from_bits(saturate_i32(self.out_min as i64 + offset as i64)),
                    fired: true,
                    strength: Fx::from_bits(best),
                }
            }
            None => default,
        }
    }

    fn infer_impl(&self, scratch: &mut Scratch<S>, inputs: [Fx; NI], sampled: bool) -> Evaluation {
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
        // S <= 256 and degrees <= 2^16: both sums fit 32 bits. (A plain
        // counter: `zip` with a range compiles to worse code here.)
        let (mut sum, mut moment) = (0u32, 0u32);
        let mut i = lo as u32;
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

impl<const NI: usize, const NT: usize, const NO: usize, const S: usize> FuzzyInference<NI>
    for Controller<'_, NI, NT, NO, S>
{
    type Scratch = Scratch<S>;
    fn infer(&self, scratch: &mut Scratch<S>, inputs: [Fx; NI]) -> Evaluation {
        self.evaluate_with(scratch, inputs)
    }
}

/// A controller for a firmware, when its system always takes
/// [`Controller::evaluate`]'s fast path (rules a complete grid with min AND,
/// every input a partition of triangles/trapezoids, the output a chain
/// with min implication: the exact closed-form centroid, as for
/// `lin2021::SYSTEM` and `njiri::SYSTEM`). The sampled output table (`NO` ×
/// 101 samples, 2-3 KiB of flash) and the centroid scratch (404 bytes of RAM
/// per user) serve only [`Controller::evaluate_sampled`] and the general
/// path, so here they have 2 samples and inference calls only
/// [`Controller::evaluate_exact`]: same outputs as the full controller, bit
/// for bit, without the general path's code. Were the fast path not to
/// apply ([`Self::is_exact`] says; the users test it), every output would
/// be the default output.
#[derive(Clone, Debug)]
pub struct ExactController<'a, const NI: usize, const NT: usize, const NO: usize> {
    controller: Controller<'a, NI, NT, NO, 2>,
    /// Whether the fast path applies (decided once, at construction).
    exact: bool,
}

impl<'a, const NI: usize, const NT: usize, const NO: usize> ExactController<'a, NI, NT, NO> {
    /// Validate `def` and compile it.
    pub const fn new(def: &'a SystemDef<'a, NI>) -> Result<Self, ConfigError> {
        match Controller::new(def) {
            Ok(c) => Ok(ExactController {
                exact: c.fast_path(),
                controller: c,
            }),
            Err(e) => Err(e),
        }
    }

    /// The compiled controller (2 centroid samples).
    pub const fn controller(&self) -> &Controller<'a, NI, NT, NO, 2> {
        &self.controller
    }

    /// Whether the fast path applies (else every output is the default).
    pub fn is_exact(&self) -> bool {
        self.exact
    }

    /// One inference (inputs clamped to their universes).
    pub fn evaluate(&self, inputs: [Fx; NI]) -> Evaluation {
        if self.exact {
            self.controller.infer_partition_grid(inputs)
        } else {
            Evaluation {
                output: self.controller.def.default_output,
                fired: false,
                strength: Fx::ZERO,
            }
        }
    }
}

impl<const NI: usize, const NT: usize, const NO: usize> FuzzyInference<NI>
    for ExactController<'_, NI, NT, NO>
{
    type Scratch = ExactScratch<NO>;
    fn infer(&self, scratch: &mut ExactScratch<NO>, inputs: [Fx; NI]) -> Evaluation {
        if self.exact {
            self.controller
                .infer_partition_grid_in(&mut scratch.strength, inputs)
        } else {
            self.evaluate(inputs)
        }
    }
}

/// Working memory of an [`ExactController`]: the consequents' strengths,
/// all zero between inferences.
#[derive(Clone, Debug)]
pub struct ExactScratch<const NO: usize> {
    strength: [i32; NO],
}

impl<const NO: usize> Default for ExactScratch<NO> {
    fn default() -> Self {
        ExactScratch { strength: [0; NO] }
    }
}

/// The fired rules of one inference: each adds its strength to its
/// consequent (max); `lowest..=highest` is the range of fired consequents,
/// `best` the largest strength.
struct Fired<'s, const NO: usize> {
    strength: &'s mut [i32; NO],
    lowest: usize,
    highest: usize,
    best: i32,
}

impl<const NO: usize> Fired<'_, NO> {
    /// Rule `code` of `grid` fired with strength `w` (inlined: a closure
    /// here stayed an out-of-line call per rule).
    #[inline(always)]
    fn fire(&mut self, grid: &[u8], w: i32, code: usize) {
        if w > 0 {
            let then = grid.get(code).copied().unwrap_or(0) as usize;
            if let Some(s) = self.strength.get_mut(then) {
                *s = (*s).max(w);
                self.lowest = self.lowest.min(then);
                self.highest = self.highest.max(then);
            }
            self.best = self.best.max(w);
        }
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

fn saturate_i32(v: i64) -> i32 {
    v.clamp(i32::MIN as i64, i32::MAX as i64) as i32
}

#[cfg(test)]
mod tests {
    use super::super::membership::MembershipFn;
    use super::super::rule::Rule;
    use super::super::system::{Term, Variable};
    use super::*;

    const IN_TERMS: [Term<'static>; 3] = [
        Term::new("N", MembershipFn::tri("-2", "-1", "0")),
        Term::new("Z", MembershipFn::tri("-1", "0", "1")),
        Term::new("P", MembershipFn::tri("0", "1", "2")),
    ];
    const OUT_TERMS: [Term<'static>; 3] = [
        Term::new("LO", MembershipFn::tri("-1", "0", "1")),
        Term::new("MID", MembershipFn::tri("0", "1", "2")),
        Term::new("HI", MembershipFn::tri("1", "2", "3")),
    ];
    const RULES: [Rule<1>; 3] = [Rule::and([0], 2), Rule::and([1], 1), Rule::and([2], 0)];
    const DEF: SystemDef<'static, 1> = SystemDef {
        name: "inverse",
        inference: Inference::Mamdani {
            implication: Implication::Min,
        },
        and: AndMethod::Min,
        or: OrMethod::Max,
        inputs: [Variable {
            name: "x",
            unit: "",
            min: Fx::lit("-1"),
            max: Fx::lit("1"),
            terms: &IN_TERMS,
        }],
        output: Variable {
            name: "y",
            unit: "",
            min: Fx::lit("0"),
            max: Fx::lit("2"),
            terms: &OUT_TERMS,
        },
        rules: &RULES,
        default_output: Fx::lit("0"),
    };
    static CTRL: Controller<'static, 1, 3, 3> = match Controller::new(&DEF) {
        Ok(c) => c,
        Err(_) => panic!("invalid test controller"),
    };

    #[test]
    fn symmetric_controller_has_symmetric_output() {
        // A single rule at full strength gives its set's (sampled) centroid.
        let mid = CTRL.evaluate([Fx::ZERO]);
        assert!(mid.fired);
        assert_eq!(mid.output, Fx::ONE);
        for i in 1..=100 {
            let x = Fx::from_num(i as f64 / 100.0);
            let a = CTRL.evaluate([x]).output.to_num::<f64>();
            let b = CTRL.evaluate([-x]).output.to_num::<f64>();
            assert!((a - 1.0 + (b - 1.0)).abs() < 4e-5, "x = {x}: {a} vs {b}");
            assert!(a < 1.0 && b > 1.0);
        }
    }

    #[test]
    fn inputs_are_clamped_to_the_universe() {
        assert_eq!(CTRL.evaluate([Fx::from_num(5)]), CTRL.evaluate([Fx::ONE]));
        assert_eq!(CTRL.evaluate([Fx::MIN]), CTRL.evaluate([-Fx::ONE]));
    }

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

    /// ∫x·u/∫u of the aggregate by a 20 001-point trapezoid rule, in f64.
    fn dense_centroid(c: &Controller<'_, 2, 6, 7>, x: [Fx; 2]) -> f64 {
        let def = c.def();
        let deg = |mf: &MembershipFn, v: f64| -> f64 {
            let (p, _) = mf.params();
            let (a, b, cc): (f64, f64, f64) = (p[0].to_num(), p[1].to_num(), p[2].to_num());
            if v <= a || v >= cc {
                0.0
            } else if v <= b {
                (v - a) / (b - a)
            } else {
                (cc - v) / (cc - b)
            }
        };
        let xs: Vec<f64> = x.iter().map(|v| v.to_num::<f64>()).collect();
        let mut strength = [0f64; 7];
        for r in def.rules {
            let mut w: f64 = 1.0;
            for (i, a) in r.when.iter().enumerate() {
                if let Antecedent::Is(t) = a {
                    let v = xs[i].clamp(def.inputs[i].min.to_num(), def.inputs[i].max.to_num());
                    let mf = &def.inputs[i].terms[*t as usize].mf;
                    // Triangles whose feet equal their peak (shoulders) still
                    // give 1 at the peak.
                    let (p, _) = mf.params();
                    let d = if v == p[1].to_num::<f64>() {
                        1.0
                    } else {
                        deg(mf, v)
                    };
                    w = w.min(d);
                }
            }
            strength[r.then as usize] = strength[r.then as usize].max(w);
        }
        let (lo, hi): (f64, f64) = (def.output.min.to_num(), def.output.max.to_num());
        let n = 20_000;
        let (mut area, mut mom) = (0.0, 0.0);
        for i in 0..=n {
            let v = lo + (hi - lo) * i as f64 / n as f64;
            let u = def
                .output
                .terms
                .iter()
                .zip(strength.iter())
                .map(|(t, s)| deg(&t.mf, v).min(*s))
                .fold(0.0, f64::max);
            let wgt = if i == 0 || i == n { 0.5 } else { 1.0 };
            area += wgt * u;
            mom += wgt * u * v;
        }
        mom / area
    }

    /// `ExactController` decides its fast path once, as `fast_path` would,
    /// and falls back on the default output when it does not apply.
    #[test]
    fn exact_controller_flag_matches_fast_path() {
        let lin = ExactController::<2, 6, 7>::new(&crate::lin2021::SYSTEM).unwrap();
        assert!(lin.is_exact() && lin.controller().fast_path());
        let njiri = ExactController::<4, 3, 7>::new(&crate::njiri::SYSTEM).unwrap();
        assert!(njiri.is_exact() && njiri.controller().fast_path());
        // Cho's bell-shaped terms are no partition: no fast path.
        let cho = ExactController::<2, 5, 5>::new(&crate::cho::SYSTEM).unwrap();
        assert!(!cho.is_exact() && !cho.controller().fast_path());
        let e = cho.evaluate([Fx::from_num(0.3), Fx::from_num(0.2)]);
        assert!(!e.fired);
        assert_eq!(e.output, crate::cho::SYSTEM.default_output);
    }

    #[test]
    fn fast_path_matches_the_general_path() {
        use crate::lin2021::CONTROLLER;
        assert!(CONTROLLER.fast_path());
        // The general path: same controller with the partition flags off.
        let mut general = CONTROLLER.clone();
        general.partition = [false, false];
        assert!(!general.fast_path());
        let mut scratch = Scratch::new();
        for i in -5..=70 {
            for j in -3..=45 {
                let x = [Fx::from_bits(i * 2900 + 17), Fx::from_bits(j * 1600 + 3)];
                assert_eq!(
                    CONTROLLER.evaluate_with(&mut scratch, x),
                    general.evaluate_with(&mut scratch, x),
                    "{x:?}"
                );
            }
        }
    }

    #[test]
    fn exact_centroid_matches_a_dense_integral() {
        use crate::lin2021::CONTROLLER;
        assert!(CONTROLLER.has_exact_centroid());
        let mut worst: f64 = 0.0;
        for i in 0..=15 {
            for j in 0..=10 {
                let x = [
                    Fx::from_num(i as f64 * 0.2 * (i as f64 * 0.2) / 3.0),
                    Fx::from_num(j as f64 * 0.1),
                ];
                let got: f64 = CONTROLLER.evaluate(x).output.to_num();
                worst = worst.max((got - dense_centroid(&CONTROLLER, x)).abs());
            }
        }
        assert!(worst < 2e-5, "worst {worst}");
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
