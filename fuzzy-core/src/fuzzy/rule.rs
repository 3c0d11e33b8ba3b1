//! Fuzzy rules as `const` data.

use crate::units::Fx;

/// One input's condition in a rule.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Antecedent {
    /// The input does not take part ("don't care"; MATLAB's `0`).
    Any,
    /// The input is the term with this index (0-based; MATLAB's `k+1`).
    Is(u8),
    /// The input is not the term with this index (complement `1 − μ`;
    /// MATLAB's `−(k+1)`).
    IsNot(u8),
}

/// How a rule combines its antecedents.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Connective {
    /// All conditions (the system's AND method).
    And,
    /// Any condition (the system's OR method).
    Or,
}

/// `IF input_1 is … AND/OR … THEN output is then` with a weight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rule<const NI: usize> {
    /// One condition per input.
    pub when: [Antecedent; NI],
    /// Output term index (0-based).
    pub then: u8,
    /// Rule weight in `[0, 1]` (scales the firing strength).
    pub weight: Fx,
    /// How the conditions combine.
    pub connective: Connective,
}

impl<const NI: usize> Rule<NI> {
    /// An AND rule of weight 1 where every input is named by its term index.
    pub const fn and(terms: [u8; NI], then: u8) -> Self {
        let mut when = [Antecedent::Any; NI];
        let mut i = 0;
        while i < NI {
            when[i] = Antecedent::Is(terms[i]);
            i += 1;
        }
        Rule {
            when,
            then,
            weight: Fx::ONE,
            connective: Connective::And,
        }
    }

    /// A rule with explicit conditions, weight 1, AND.
    pub const fn when(when: [Antecedent; NI], then: u8) -> Self {
        Rule {
            when,
            then,
            weight: Fx::ONE,
            connective: Connective::And,
        }
    }
}
