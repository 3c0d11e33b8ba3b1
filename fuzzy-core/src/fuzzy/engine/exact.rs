//! [`ExactController`]: a [`Controller`] reduced to the fast path
//! (the fast path, `partition_grid.rs`), for a firmware whose system always takes it.

use super::super::system::{ConfigError, SystemDef};
use super::{Controller, Evaluation, FuzzyInference};
use crate::units::Fx;

/// A controller for a firmware, for a system that always takes
/// [`Controller::evaluate`]'s fast path (rules a complete grid with min AND,
/// every input a partition of triangles/trapezoids, the output a chain
/// with min implication: the exact closed-form centroid, as for
/// `lin2021::SYSTEM` and `njiri::SYSTEM`). The sampled output table (`NO`
/// × `S` degrees in flash) and the centroid scratch (`S` words of RAM per
/// user) serve only [`Controller::evaluate_sampled`] and the general path,
/// so here they have 2 samples and inference runs only the fast path
/// ([`Controller::evaluate_exact`]): same outputs as the full controller,
/// bit for bit, without the general path's code. A system the fast path
/// does not cover is refused ([`ConfigError::NotExact`]).
#[derive(Clone, Debug)]
pub struct ExactController<'a, const NI: usize, const NT: usize, const NO: usize> {
    controller: Controller<'a, NI, NT, NO, 2>,
}

impl<'a, const NI: usize, const NT: usize, const NO: usize> ExactController<'a, NI, NT, NO> {
    /// Validate `def` and compile it; [`ConfigError::NotExact`] if the
    /// system does not take the fast path.
    pub const fn new(def: &'a SystemDef<'a, NI>) -> Result<Self, ConfigError> {
        match Controller::new(def) {
            Ok(c) => {
                if c.fast_path() {
                    Ok(ExactController { controller: c })
                } else {
                    Err(ConfigError::NotExact)
                }
            }
            Err(e) => Err(e),
        }
    }

    /// The compiled controller (2 centroid samples).
    pub const fn controller(&self) -> &Controller<'a, NI, NT, NO, 2> {
        &self.controller
    }

    /// One inference (inputs clamped to their universes).
    pub fn evaluate(&self, inputs: [Fx; NI]) -> Evaluation {
        self.controller.infer_partition_grid(inputs)
    }
}

impl<const NI: usize, const NT: usize, const NO: usize> FuzzyInference<NI>
    for ExactController<'_, NI, NT, NO>
{
    type Scratch = ExactScratch<NO>;
    fn infer(&self, scratch: &mut ExactScratch<NO>, inputs: [Fx; NI]) -> Evaluation {
        self.controller
            .infer_partition_grid_in(&mut scratch.strength, inputs)
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

#[cfg(test)]
mod tests {
    use super::super::super::rule::Rule;
    use super::super::super::system::AndMethod;
    use super::*;

    /// Lin's and Njiri's systems take the fast path and are accepted; a
    /// system that does not is refused, though `Controller` compiles it.
    #[test]
    fn only_systems_on_the_fast_path_are_accepted() {
        let lin = ExactController::<2, 6, 7>::new(&crate::lin2021::SYSTEM).unwrap();
        assert!(lin.controller().fast_path());
        let njiri = ExactController::<4, 3, 7>::new(&crate::njiri::SYSTEM).unwrap();
        assert!(njiri.controller().fast_path());
        // Cho's Gaussian terms are no partition.
        assert!(Controller::<2, 5, 5>::new(&crate::cho::SYSTEM).is_ok());
        assert_eq!(
            ExactController::<2, 5, 5>::new(&crate::cho::SYSTEM).err(),
            Some(ConfigError::NotExact)
        );
        // Lin's system with product AND, or with a rule missing (no grid).
        let product = SystemDef {
            and: AndMethod::Product,
            ..crate::lin2021::SYSTEM
        };
        let rules: [Rule<2>; 29] = core::array::from_fn(|i| crate::lin2021::RULES[i]);
        let incomplete = SystemDef {
            rules: &rules,
            ..crate::lin2021::SYSTEM
        };
        for def in [&product, &incomplete] {
            assert!(Controller::<2, 6, 7>::new(def).is_ok());
            assert_eq!(
                ExactController::<2, 6, 7>::new(def).err(),
                Some(ConfigError::NotExact)
            );
        }
        // An invalid system keeps its own error.
        let empty = SystemDef {
            rules: &[],
            ..crate::lin2021::SYSTEM
        };
        assert_eq!(
            ExactController::<2, 6, 7>::new(&empty).err(),
            Some(ConfigError::NoRules)
        );
    }
}
