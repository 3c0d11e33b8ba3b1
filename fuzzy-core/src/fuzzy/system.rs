//! A fuzzy system as data: variables, terms, rules and methods.

use super::membership::{MembershipFn, MfError};
use super::rule::Rule;
use crate::units::Fx;

/// A linguistic term: a name and its membership function.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Term<'a> {
    /// Short name (`"ZO"`, `"VB"`, …).
    pub name: &'a str,
    /// Its membership function.
    pub mf: MembershipFn,
}

impl<'a> Term<'a> {
    /// A term.
    pub const fn new(name: &'a str, mf: MembershipFn) -> Self {
        Term { name, mf }
    }
}

/// An input or output variable: its universe of discourse and terms.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Variable<'a> {
    /// Name (an identifier: exported as is to `.fis` and FCL).
    pub name: &'a str,
    /// Unit of the crisp value (documentation and exports' comments).
    pub unit: &'a str,
    /// Lower end of the universe. Inputs are clamped to `[min, max]`; the
    /// Mamdani centroid samples the output on `[min, max]`.
    pub min: Fx,
    /// Upper end of the universe.
    pub max: Fx,
    /// The terms, referred to by index from the rules.
    pub terms: &'a [Term<'a>],
}

/// AND of antecedents (MATLAB `AndMethod`, FCL `AND`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AndMethod {
    /// `min(a, b)`.
    Min,
    /// `a·b`.
    Product,
}

/// OR of antecedents (MATLAB `OrMethod`, FCL `OR`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum OrMethod {
    /// `max(a, b)`.
    Max,
    /// Probabilistic OR `a + b − a·b`.
    ProbOr,
}

/// Mamdani implication (MATLAB `ImpMethod`, FCL `ACT`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Implication {
    /// Clip the consequent at the firing strength.
    Min,
    /// Scale the consequent by the firing strength.
    Product,
}

/// Zero-order Sugeno output (MATLAB `DefuzzMethod` of a Sugeno system).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SugenoOutput {
    /// `Σ wᵢ cᵢ / Σ wᵢ` (`wtaver`; Nagata et al. eq. 4-5).
    WeightedAverage,
    /// `Σ wᵢ cᵢ` (`wtsum`).
    WeightedSum,
}

/// The inference scheme.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Inference {
    /// Mamdani: implication per rule, max aggregation, centroid of the
    /// output sampled at the controller's `S` points over the output range
    /// (Lin et al. eq. 11; MATLAB's `centroid` with `NumSamplePoints = S`).
    Mamdani {
        /// How a rule's strength shapes its consequent.
        implication: Implication,
    },
    /// Zero-order Sugeno: output terms are [`MembershipFn::Constant`].
    Sugeno {
        /// How the constants combine.
        output: SugenoOutput,
    },
}

/// A complete fuzzy system with `NI` inputs and one output, as data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SystemDef<'a, const NI: usize> {
    /// Name (an identifier).
    pub name: &'a str,
    /// Mamdani or Sugeno.
    pub inference: Inference,
    /// AND method.
    pub and: AndMethod,
    /// OR method.
    pub or: OrMethod,
    /// Inputs.
    pub inputs: [Variable<'a>; NI],
    /// The output.
    pub output: Variable<'a>,
    /// Rules.
    pub rules: &'a [Rule<NI>],
    /// The output when no rule fires (all strengths 0): FCL's `DEFAULT`.
    /// MATLAB returns the middle of the output range instead; a controller
    /// whose terms cover the whole input universe always fires.
    pub default_output: Fx,
}

/// Which variable a configuration error is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum VarRef {
    /// Input number (0-based).
    Input(u8),
    /// The output.
    Output,
}

/// Why a fuzzy system cannot be compiled.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ConfigError {
    /// A variable has no terms.
    NoTerms(VarRef),
    /// A variable has more terms than the controller type holds.
    TooManyTerms(VarRef),
    /// `min >= max`.
    EmptyRange(VarRef),
    /// A membership function is invalid.
    BadMembership {
        /// The variable.
        var: VarRef,
        /// The term index.
        term: u8,
        /// What is wrong.
        why: MfError,
    },
    /// A Sugeno constant used as an input term or a Mamdani output term, or
    /// a membership function used as a Sugeno output term.
    WrongTermKind {
        /// The variable.
        var: VarRef,
        /// The term index.
        term: u8,
    },
    /// There are no rules.
    NoRules,
    /// A rule names a term that does not exist.
    RuleTermOutOfRange {
        /// Rule index (0-based).
        rule: u16,
        /// The variable.
        var: VarRef,
    },
    /// A rule weight outside `[0, 1]`.
    BadWeight {
        /// Rule index (0-based).
        rule: u16,
    },
    /// The Mamdani centroid needs `2 <= S <= 256` samples.
    BadSampleCount,
    /// More than 1024 rules.
    TooManyRules,
    /// `default_output` outside the output range.
    DefaultOutOfRange,
    /// [`ExactController`](super::ExactController) only: the system does not
    /// take the engine's fast path (rules a complete grid of AND rules of
    /// weight 1 with min AND, every input a partition of triangles and
    /// trapezoids, the output terms a chain with min implication).
    NotExact,
}

impl core::fmt::Display for VarRef {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            VarRef::Input(i) => write!(f, "input {}", i + 1),
            VarRef::Output => f.write_str("output"),
        }
    }
}

impl core::fmt::Display for ConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            ConfigError::NoTerms(v) => write!(f, "{v} has no terms"),
            ConfigError::TooManyTerms(v) => {
                write!(f, "{v} has more terms than the controller holds")
            }
            ConfigError::EmptyRange(v) => write!(f, "{v}: range min must be below max"),
            ConfigError::BadMembership { var, term, why } => {
                write!(
                    f,
                    "{var}, term {}: invalid membership function ({why:?})",
                    term + 1
                )
            }
            ConfigError::WrongTermKind { var, term } => {
                write!(f, "{var}, term {}: constants only as Sugeno outputs, membership functions elsewhere", term + 1)
            }
            ConfigError::NoRules => f.write_str("the system has no rules"),
            ConfigError::RuleTermOutOfRange { rule, var } => {
                write!(f, "rule {}: no such term for {var}", rule + 1)
            }
            ConfigError::BadWeight { rule } => {
                write!(f, "rule {}: weight outside [0, 1]", rule + 1)
            }
            ConfigError::BadSampleCount => f.write_str("centroid needs 2 to 256 sample points"),
            ConfigError::TooManyRules => f.write_str("more than 1024 rules"),
            ConfigError::DefaultOutOfRange => {
                f.write_str("default output outside the output range")
            }
            ConfigError::NotExact => f.write_str(
                "not an exact controller: needs a complete rule grid with min AND, \
                 partitioned inputs and a chain of output terms with min implication",
            ),
        }
    }
}
