//! The compiled fuzzy controller: validation once, then allocation-free,
//! division-light evaluation.
//!
//! Inference (Mamdani or zero-order Sugeno, see [`Inference`](super::Inference)):
//! 1. fuzzification: each input is clamped to its universe and every term's
//!    degree is computed;
//! 2. rule strength: AND (min or product) / OR (max or probabilistic) of the
//!    antecedents, times the rule weight (Lin et al. use min for AND);
//! 3. Mamdani: each output term is clipped (min) or scaled (product) by the
//!    strongest rule naming it, the terms are aggregated with max, and the
//!    centroid of the aggregate is taken over `S` equally spaced samples of
//!    the output universe (Lin et al. eq. 11; `S = 101` is MATLAB's and
//!    Octave's default, so an exported controller gives the same output there),
//!    or exactly, in closed form, when the output terms form a chain
//!    (`centroid.rs`; [`Controller::evaluate_sampled`] always samples);
//!    Sugeno: the weighted average (or sum) of the rules' constants.
//!
//! When no rule fires the output is [`SystemDef::default_output`] and
//! [`Evaluation::fired`] is false.
//!
//! A `Controller` can be built in a `const` or `static` (its constructor is a
//! `const fn`): the output membership table then lives in flash and an invalid
//! definition is a compile error.
//!
//! The engine by path, one file each:
//!
//! | file | what |
//! |---|---|
//! | `compile.rs` | [`Controller::new`]: validation, and what it precomputes (compiled membership functions, the output's sample table or constants, the rule grid, the partition flags, the exact centroid's chain) |
//! | `partition_grid.rs` | the fast path: rules a complete grid with min AND, inputs partitions, output a chain: at most `2^NI` rules fire, exact centroid |
//! | `general.rs` | every other system: arbitrary rules (weights, OR, NOT), any membership functions, Sugeno; the chain's exact centroid where the output allows it, else the `S`-sample centroid of eq. 11 (and always for [`Controller::evaluate_sampled`]) |
//! | `exact.rs` | [`ExactController`]: the fast path alone, for a firmware |

use super::centroid::Chain;
use super::membership::CompiledMf;
use super::system::SystemDef;
use crate::units::Fx;

mod compile;
mod exact;
mod general;
mod partition_grid;

pub use exact::{ExactController, ExactScratch};

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

impl<'a, const NI: usize, const NT: usize, const NO: usize, const S: usize>
    Controller<'a, NI, NT, NO, S>
{
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
}

impl<const NI: usize, const NT: usize, const NO: usize, const S: usize> FuzzyInference<NI>
    for Controller<'_, NI, NT, NO, S>
{
    type Scratch = Scratch<S>;
    fn infer(&self, scratch: &mut Scratch<S>, inputs: [Fx; NI]) -> Evaluation {
        self.evaluate_with(scratch, inputs)
    }
}

fn saturate_i32(v: i64) -> i32 {
    v.clamp(i32::MIN as i64, i32::MAX as i64) as i32
}

/// A one-input Mamdani system shared by the engine's tests.
#[cfg(test)]
mod fixture {
    use super::super::membership::MembershipFn;
    use super::super::rule::Rule;
    use super::super::system::{
        AndMethod, Implication, Inference, OrMethod, SystemDef, Term, Variable,
    };
    use super::Controller;
    use crate::units::Fx;

    pub(super) const IN_TERMS: [Term<'static>; 3] = [
        Term::new("N", MembershipFn::tri("-2", "-1", "0")),
        Term::new("Z", MembershipFn::tri("-1", "0", "1")),
        Term::new("P", MembershipFn::tri("0", "1", "2")),
    ];
    pub(super) const OUT_TERMS: [Term<'static>; 3] = [
        Term::new("LO", MembershipFn::tri("-1", "0", "1")),
        Term::new("MID", MembershipFn::tri("0", "1", "2")),
        Term::new("HI", MembershipFn::tri("1", "2", "3")),
    ];
    pub(super) const RULES: [Rule<1>; 3] =
        [Rule::and([0], 2), Rule::and([1], 1), Rule::and([2], 0)];
    pub(super) const DEF: SystemDef<'static, 1> = SystemDef {
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
    pub(super) static CTRL: Controller<'static, 1, 3, 3> = match Controller::new(&DEF) {
        Ok(c) => c,
        Err(_) => panic!("invalid test controller"),
    };
}

#[cfg(test)]
mod tests {
    use super::fixture::CTRL;
    use super::*;

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
}
