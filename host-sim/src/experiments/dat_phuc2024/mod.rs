//! Dat & Phuc (2024), acc/dec-aware corner compensation on a FANUC control:
//! the machine model of section 2.1 and the compensation of section 3.
//!
//! - [`fanuc`]: the FANUC-like machine (conventional and high-accuracy
//!   modes; also the default machine of every command);
//! - [`before_interpolation`]: the high-accuracy mode's acc/dec before
//!   interpolation (parameters 1783, 1660, 1772);
//! - [`corner_comp`]: the corner compensation, its corner error and table;
//! - [`command`]: `host-sim corner`.

pub mod before_interpolation;
pub mod command;
pub mod corner_comp;
pub mod fanuc;
