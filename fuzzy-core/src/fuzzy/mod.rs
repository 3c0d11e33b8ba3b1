//! A generic fuzzy inference engine: `NI` inputs, triangle / trapezoid /
//! Gaussian / generalised-bell membership functions, Mamdani (centroid) and
//! zero-order Sugeno inference, with systems written as `const` data.
//!
//! The papers' controllers are data on this engine: Lin et al.'s feed
//! controller ([`crate::lin2021`]), and the force (Njiri), segment-length
//! (Nagata) and contour-error (Cho) controllers of the other papers.
//!
//! ```
//! use fuzzy_core::fuzzy::*;
//! use fuzzy_core::units::Fx;
//!
//! const ERR: [Term; 2] = [
//!     Term::new("N", MembershipFn::tri("-2", "-1", "1")),
//!     Term::new("P", MembershipFn::tri("-1", "1", "2")),
//! ];
//! const OUT: [Term; 2] = [
//!     Term::new("DOWN", MembershipFn::tri("-2", "-1", "0")),
//!     Term::new("UP", MembershipFn::tri("0", "1", "2")),
//! ];
//! const RULES: [Rule<1>; 2] = [Rule::and([0], 1), Rule::and([1], 0)];
//! const DEF: SystemDef<'static, 1> = SystemDef {
//!     name: "demo",
//!     inference: Inference::Mamdani { implication: Implication::Min },
//!     and: AndMethod::Min,
//!     or: OrMethod::Max,
//!     inputs: [Variable { name: "error", unit: "N", min: Fx::lit("-1"), max: Fx::lit("1"), terms: &ERR }],
//!     output: Variable { name: "change", unit: "%", min: Fx::lit("-1"), max: Fx::lit("1"), terms: &OUT },
//!     rules: &RULES,
//!     default_output: Fx::ZERO,
//! };
//! static CTRL: Controller<'static, 1, 2, 2> = match Controller::new(&DEF) {
//!     Ok(c) => c,
//!     Err(_) => panic!("invalid controller"), // a compile error, never a runtime panic
//! };
//! let e = CTRL.evaluate([Fx::lit("-1")]);
//! assert!(e.fired && e.output > Fx::ZERO);
//! ```

mod centroid;
pub mod engine;
pub mod export;
pub mod membership;
pub mod rule;
pub mod system;

pub use engine::{Controller, Evaluation, ExactController, ExactScratch, FuzzyInference, Scratch};
pub use membership::{MembershipFn, MfError};
pub use rule::{Antecedent, Connective, Rule};
pub use system::{
    AndMethod, ConfigError, Implication, Inference, OrMethod, SugenoOutput, SystemDef, Term,
    VarRef, Variable,
};
