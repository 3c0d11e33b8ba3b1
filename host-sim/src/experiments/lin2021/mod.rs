//! Lin, Lin & Wang (2021), *Using Fuzzy Control for Feedrate Scheduling of
//! CNC Machine Tools*: the paper-style comparison of Tables 10-12 and the
//! abstract's two claims. The scheduler itself is fuzzy-core's
//! ([`fuzzy_core::lin2021`], [`fuzzy_core::scheduler`]); the methods it is
//! compared with are in [`crate::methods`].
//!
//! - [`compare`]: the runs (paths × methods × maximum feeds) and the claims;
//! - [`command`]: `host-sim compare`;
//! - [`report`]: the table, `claims.csv`, `report.json`.

pub mod command;
pub mod compare;
pub mod report;
