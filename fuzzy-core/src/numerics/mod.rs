//! The integer arithmetic every module of the crate shares, and the policy
//! behind it.
//!
//! # Integer-only on the target
//!
//! Nothing in `fuzzy-core` computes in floating point outside the `f64`
//! references (feature `std`) and the tests. The Cortex-M4F does have an
//! FPU, but a single-precision one: `f32`'s 24-bit mantissa cannot hold a
//! position of metres to the 2^-32 mm of [`Point3Mm`](crate::units::Point3Mm)
//! (49 bits at the 100 m limit), nor the curvature of eq. 9, whose
//! intermediate products span chords from 1 µm to metres. `f64` could, but
//! on this FPU every `f64` operation is a library call (table below). And
//! integer arithmetic gives the same bits on every machine: the firmware
//! and the host simulator schedule and plan identically, which the system
//! tests check bit for bit.
//!
//! So a value is fixed point where one format covers its range (positions
//! and curvatures I32F32, fuzzy degrees and values Q16.16 [`Fx`](crate::units::Fx),
//! the exact centroid Q29/Q30, the planner's speeds Q32 per tick), and a
//! soft float ([`softfloat::Sf`], 32-bit mantissa) where a ratio spans too
//! many decades for one format. Overflow saturates or is reported, never
//! wraps; a division by zero returns the value its function documents,
//! never traps.
//!
//! | module | what |
//! |---|---|
//! | [`wide`] | 64-bit shifts and divisions with 32-bit instructions |
//! | [`explog`] | `2^-y` and `log2`, for the Gaussian and bell membership functions |
//! | [`softfloat`] | the soft float [`Sf`](softfloat::Sf): product, quotient, sum, roots |
//! | [`sqrt`] | the integer square roots |
//!
//! The planner's Q32-per-tick helpers (`mul`, `div`, `sqrt` and `reach` in
//! `planner/q.rs`) belong here too; they join when the planner's rewrite
//! lands.
//!
//! # Cost
//!
//! Measured on the Cortex-M4 target under QEMU `-icount shift=0`, release
//! build (`opt-level = "z"`, fat LTO): mean instructions per operation over
//! 256 pseudo-random inputs within its contract, the call included where the
//! compiler keeps one. The `compiler` rows are what the plain Rust operator
//! compiles to, for comparison.
//!
//! | operation | instructions |
//! |---|---:|
//! | `u64 / u64`, 32-bit divisor (compiler) | 322 |
//! | [`wide::div_u64_u32`] | 59 |
//! | [`wide::div_narrow`] (quotient < 2^32) | 49 |
//! | [`wide::div_u64_small`] (divisor < 2^16) | 14 |
//! | `u64 >> s`, variable `s` (compiler) | 12 |
//! | [`wide::shr_u64_low`] | 11 |
//! | [`explog::exp2_neg_q30`] | 62 |
//! | [`explog::log2_q32`] | 74 |
//! | [`sqrt::isqrt_u64`] | 116 |
//! | [`sqrt::isqrt_u128`] | 2724 |
//! | [`Sf::from_u64`](softfloat::Sf::from_u64) | 30 |
//! | [`Sf::mul`](softfloat::Sf::mul) | 7 |
//! | [`Sf::div`](softfloat::Sf::div) | 73 |
//! | [`Sf::add`](softfloat::Sf::add) | 62 |
//! | [`Sf::sqrt`](softfloat::Sf::sqrt) | 120 |
//! | [`Sf::rsqrt`](softfloat::Sf::rsqrt) | 70 |
//! | [`Sf::to_i64_scaled`](softfloat::Sf::to_i64_scaled) | 11 |
//! | `f64` add (compiler) | 116 |
//! | `f64` multiply (compiler) | 87 |
//! | `f64` divide (compiler) | 137 |
//! | `f32` multiply (FPU) | 4 |
//! | `f32` divide (FPU) | 4 |
//!
//! Printed by `firmware/src/bin/numerics_cost.rs` (its docs give the QEMU
//! command).

pub mod explog;
pub mod softfloat;
pub mod sqrt;
pub mod wide;
