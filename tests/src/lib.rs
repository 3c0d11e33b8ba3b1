//! System tests across crates.
//!
//! [`firmware`] is the host side of the firmware link: it starts the
//! firmware in QEMU and streams paths to it (used by `tests/firmware_qemu.rs`
//! and the `stream` tool). [`planned`] recomputes the firmware's planned
//! motion on the host from what the firmware reports, and checks it.

pub mod firmware;
pub mod planned;
