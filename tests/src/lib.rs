//! System tests across crates.
//!
//! [`firmware`] is the host side of the firmware link: it starts the
//! firmware in QEMU and streams paths to it (used by `tests/firmware_qemu.rs`
//! and the `stream` tool).

pub mod firmware;
