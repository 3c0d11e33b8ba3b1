//! The tests' deterministic pseudo-random source (Marsaglia's 64-bit
//! xorshift, shifts 13, 7, 17): the same sequence on every machine.

/// Successive 64-bit values from `seed` (non-zero).
pub(crate) fn xorshift64(seed: u64) -> impl FnMut() -> u64 {
    let mut x = seed;
    move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        x
    }
}
