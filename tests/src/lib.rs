//! System tests across crates.
