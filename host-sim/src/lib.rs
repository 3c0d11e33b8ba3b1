//! `host-sim` as a library: toolpaths in (the paper's shapes, G-code, CSV),
//! fuzzy-core's scheduler and the methods it competes with, simulated
//! machines (FANUC-like acc/dec, Cho et al.'s X-Y servo), the contour error
//! and kinematics of the predicted motion, and the paper-style table and
//! plots.
//!
//! ```text
//! toolpath ─► method (constant | chord-error | fuzzy | fuzzy-no-filter) ─► feed per block
//!          ─► interpolation every Ts ─► machine ─► actual motion ─► metrics, plots
//!          └► (fuzzy-planner | planner | grbl-like | blend) ─► positions every Ts
//!             ─► the machine's after-interpolation stage ─► actual motion
//! ```
//!
//! Every subcommand is a module with `Args` (clap) and `run`: the papers'
//! in [`experiments`] (one folder per paper: model, command, report), the
//! others in [`cli`].

pub mod cam_corpus;
pub mod cli;
pub mod config;
pub mod contour_error;
pub mod experiments;
pub mod interpolation;
pub mod machine;
pub mod methods;
pub mod metrics;
pub mod output;
pub mod planner;
pub mod plots;
pub mod simulate;

// The programs the simulator reads are the product's: G-code, CSV and the
// papers' shapes come from the interpreter's crate.
pub use gcode_interp as gcode;
pub use gcode_interp::{inputs, nurbs, path_csv, shapes, toolpath};
