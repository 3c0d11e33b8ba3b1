//! System tests across crates.
//!
//! [`firmware`] starts the firmware in QEMU and talks to it through the
//! link's host client (`tests/firmware_qemu.rs`, `tests/sender_qemu.rs`).
//! [`planned`] recomputes the firmware's planned motion on the host from
//! what the firmware reports, and checks it.

pub mod binaries;
pub mod firmware;
pub mod planned;
