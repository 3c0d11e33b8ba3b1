//! `host-sim` as a library: the built-in test shapes, path input, and the
//! pieces the command-line tool is made of, for system tests and other tools.

pub mod nurbs;
pub mod path_csv;
pub mod shapes;
