//! Instructions per operation of `fuzzy_core::numerics` on the target, and
//! for comparison the compiler's own 64-bit division and shift and `f32` /
//! `f64` arithmetic: the cost table in `fuzzy-core/src/numerics/mod.rs`.
//!
//! Run under QEMU with `-icount shift=0` (one instruction per ns; SysTick
//! at 168 MHz counts 168 per 1000 instructions), from `firmware/`:
//!
//! ```text
//! cargo build --release --bin numerics_cost
//! qemu-system-arm -cpu cortex-m4 -machine netduinoplus2 -display none \
//!   -monitor none -semihosting-config enable=on,target=native -serial null \
//!   -icount shift=0 -kernel target/thumbv7em-none-eabihf/release/numerics_cost
//! ```
//!
//! Each operation runs once on each of [`N`] fixed pseudo-random inputs
//! within its contract (a range that holds in the crate's own uses), each
//! input and result through `black_box`; the same loop returning its input
//! unchanged is measured too and subtracted, so a figure is the operation
//! itself, its call included where the compiler keeps one. Output: one
//! `numerics <operation> <instructions>` line per row (mean over the
//! inputs, rounded), on semihosting stdout.
#![no_std]
#![no_main]

use core::hint::black_box;

use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use fuzzy_core::numerics::softfloat::Sf;
use fuzzy_core::numerics::{explog, sqrt, wide};
use fuzzy_firmware::measure::{self, cycles, cycles_since, qemu_instructions};

/// Inputs per operation.
const N: usize = 256;

/// A fixed xorshift sequence.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
}

/// SysTick counts for `f` over every input.
#[inline(never)]
fn run<T, R>(inputs: &[T; N], mut f: impl FnMut(&T) -> R) -> u32 {
    let start = cycles();
    for x in inputs.iter() {
        black_box(f(black_box(x)));
    }
    cycles_since(start)
}

/// Mean instructions of `f` per input, less the loop's own (`identity`).
fn per_op<T, R, I>(inputs: &[T; N], identity: impl FnMut(&T) -> I, f: impl FnMut(&T) -> R) -> u64 {
    let base = run(inputs, identity) as u64;
    let op = run(inputs, f) as u64;
    let n = N as u64;
    (qemu_instructions(op.saturating_sub(base)) + n / 2) / n
}

fn row(name: &str, instructions: u64) {
    hprintln!("numerics {} {}", name, instructions);
}

#[entry]
fn main() -> ! {
    let Some(mut cp) = cortex_m::Peripherals::take() else {
        fuzzy_firmware::fail()
    };
    measure::start_cycle_counter(&mut cp.SYST);
    let mut rng = Rng(0x2545_F491_4F6C_DD1D);

    // 64-bit dividends, 32-bit divisors (at least 2^16: the general case).
    let div: [(u64, u32); N] = core::array::from_fn(|_| {
        let n = rng.next();
        let d = (rng.next() as u32) | 1 << 16;
        (n, d)
    });
    let id = |p: &(u64, u32)| p.0;
    row("u64_div_compiler", per_op(&div, id, |&(n, d)| n / d as u64));
    row(
        "wide::div_u64_u32",
        per_op(&div, id, |&(n, d)| wide::div_u64_u32(n, d)),
    );
    // Quotients within 32 bits.
    let narrow: [(u64, u32); N] = div.map(|(n, d)| (n % ((d as u64) << 32), d));
    row(
        "wide::div_narrow",
        per_op(&narrow, id, |&(n, d)| wide::div_narrow(n, d)),
    );
    // Divisors below 2^16 (the average filter's window length).
    let small: [(u64, u32); N] = div.map(|(n, d)| (n, d & 0xFFFF | 1));
    row(
        "wide::div_u64_small",
        per_op(&small, id, |&(n, d)| wide::div_u64_small(n, d)),
    );

    // Variable shifts by 0..64.
    let shifts: [(u64, u32); N] = div.map(|(n, d)| (n, d % 64));
    row(
        "u64_shr_compiler",
        per_op(&shifts, id, |&(x, s)| (x >> s) as u32),
    );
    row(
        "wide::shr_u64_low",
        per_op(&shifts, id, |&(x, s)| wide::shr_u64_low(x, s)),
    );

    // 2^-y for y in [0, 32), log2 of any v >= 1.
    let y: [(u64, u32); N] = div.map(|(n, _)| (n >> 27, 0));
    row(
        "explog::exp2_neg_q30",
        per_op(&y, id, |&(y, _)| explog::exp2_neg_q30(y)),
    );
    let v: [(u64, u32); N] = div.map(|(n, _)| (n | 1, 0));
    row(
        "explog::log2_q32",
        per_op(&v, id, |&(v, _)| explog::log2_q32(v)),
    );

    // Integer roots.
    row(
        "sqrt::isqrt_u64",
        per_op(&div, id, |&(n, _)| sqrt::isqrt_u64(n)),
    );
    let wide_sq: [(u128, u32); N] =
        div.map(|(n, d)| ((n as u128) << 64 | (n ^ d as u64) as u128, 0));
    row(
        "sqrt::isqrt_u128",
        per_op(
            &wide_sq,
            |p: &(u128, u32)| p.0,
            |&(n, _)| sqrt::isqrt_u128(n),
        ),
    );

    // Soft floats over ±2^40.
    let sf: [(Sf, Sf); N] = div.map(|(n, d)| {
        (
            Sf::from_u64_exp(n | 1, (d % 81) as i32 - 40),
            Sf::from_u64_exp((n >> 17) | 1, (d >> 8) as i32 % 81 - 40),
        )
    });
    let sid = |p: &(Sf, Sf)| p.0;
    row("Sf::from_u64", per_op(&div, id, |&(n, _)| Sf::from_u64(n)));
    row("Sf::mul", per_op(&sf, sid, |&(a, b)| a.mul(b)));
    row("Sf::div", per_op(&sf, sid, |&(a, b)| a.div(b)));
    row("Sf::add", per_op(&sf, sid, |&(a, b)| a.add(b)));
    row("Sf::sqrt", per_op(&sf, sid, |&(a, _)| a.sqrt()));
    row("Sf::rsqrt", per_op(&sf, sid, |&(a, _)| a.rsqrt()));
    row(
        "Sf::to_i64_scaled",
        per_op(&sf, sid, |&(a, _)| a.to_i64_scaled(0)),
    );

    // The FPU: single precision in hardware, double in software.
    let fl: [(f64, f64); N] = div.map(|(n, d)| ((n >> 11) as f64 + 0.5, d as f64 + 0.25));
    let fid = |p: &(f64, f64)| p.0;
    row("f64_add", per_op(&fl, fid, |&(a, b)| a + b));
    row("f64_mul", per_op(&fl, fid, |&(a, b)| a * b));
    row("f64_div", per_op(&fl, fid, |&(a, b)| a / b));
    let fs: [(f32, f32); N] = fl.map(|(a, b)| (a as f32, b as f32));
    let f32id = |p: &(f32, f32)| p.0;
    row("f32_mul", per_op(&fs, f32id, |&(a, b)| a * b));
    row("f32_div", per_op(&fs, f32id, |&(a, b)| a / b));

    fuzzy_firmware::exit_success()
}
