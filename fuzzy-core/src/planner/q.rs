//! The planner's arithmetic: raw I32F32 (`i64`, 32 fractional bits) in
//! per-tick units (mm, mm/tick, mm/tick², mm/tick³), so integrating over a
//! tick needs no multiplication by the period. Every operation saturates.

use crate::softfloat::Sf;

/// 1.0 in Q32.
pub(crate) const ONE: i64 = 1 << 32;

/// Saturating `a·b` (Q32), rounded toward zero. The magnitudes multiply
/// as `u64 × u64 → u128` (four `UMULL`s on a Cortex-M4; a 128-bit multiply
/// of sign-extended operands compiles to a much longer chain there).
#[inline]
pub(crate) fn mul(a: i64, b: i64) -> i64 {
    let neg = (a ^ b) < 0;
    let p = a.unsigned_abs() as u128 * b.unsigned_abs() as u128;
    if p >> 95 != 0 {
        return if neg { i64::MIN } else { i64::MAX };
    }
    let m = (p >> 32) as i64;
    if neg {
        -m
    } else {
        m
    }
}

/// `1/6` in Q32.
pub(crate) const SIXTH: i64 = 715_827_883;

/// Saturating `a/b` (Q32); `b = 0` gives ±max. Relative error below
/// 2^-31 (a soft-float quotient on the hardware's 32-bit divide: an exact
/// 96/64-bit division is a ~1000-instruction loop on a Cortex-M4). One
/// call with the soft-float steps inlined in it: the planner divides
/// several times per tick.
#[inline(never)]
pub(crate) fn div(a: i64, b: i64) -> i64 {
    if b == 0 {
        return if a >= 0 { i64::MAX } else { i64::MIN };
    }
    let (x, y) = (
        Sf::from_u64_inline(a.unsigned_abs()),
        Sf::from_u64_inline(b.unsigned_abs()),
    );
    let q = match x.div_inline(y) {
        Some(q) => q.to_i64_scaled_inline(32),
        None => i64::MAX,
    };
    if (a < 0) != (b < 0) {
        -q
    } else {
        q
    }
}

/// `√a` (Q32) for `a >= 0` (negative gives 0).
#[inline]
pub(crate) fn sqrt(a: i64) -> i64 {
    if a <= 0 {
        return 0;
    }
    // √(raw·2^-32) = √raw · 2^-16, i.e. raw result √raw · 2^16.
    Sf::from_u64(a as u64).sqrt().to_i64_scaled(16)
}

/// `√(t² + 2·a·d)` (all Q32, negative inputs taken as 0): the speed
/// reached from `t` after `d` at `a`. The sum is kept in Q64 (`u128`):
/// in Q32, squares of slow speeds (below 2^-16 mm/tick) round to zero.
#[inline]
pub(crate) fn reach(t: i64, a: i64, d: i64) -> i64 {
    let t = t.max(0) as u128;
    let sum = (t * t).saturating_add(2 * a.max(0) as u128 * d.max(0) as u128);
    let bits = 128 - sum.leading_zeros() as i32;
    // Bring the sum under 2^64 by an even shift, kept in the exponent.
    let shift = if bits > 64 { (bits - 63) & !1 } else { 0 };
    Sf::from_u64_exp((sum >> shift) as u64, shift)
        .sqrt()
        .to_i64_scaled(0)
}

/// The sum under [`reach`]'s root, `t² + 2ad` (Q64, saturating).
#[inline(always)]
fn reach_sum(t: i64, a: i64, d: i64) -> u128 {
    let tu = t.max(0) as u128;
    (tu * tu).saturating_add(2 * a.max(0) as u128 * d.max(0) as u128)
}

/// Whether `(w + 2)² <= S·(1 − 2^-26)`: then `w + 2 <= √S·(1 − 2^-27)`,
/// below [`reach`] for certain (which truncates each step to 32
/// significant bits and rounds its root to the last bit, so it lies
/// within `√S·2^-29 + 1` of `√S`).
#[inline(always)]
fn surely_below_root(w: i64, sum: u128) -> bool {
    let hi = w.max(0) as u128 + 2;
    hi * hi <= sum - (sum >> 26)
}

/// `v > reach(t, a, d)`, decided from the squares where they are clear
/// of the root's rounding, with the root only where they are not: the
/// same answer, mostly without the square root. `(v − 2)² > S·(1 + 2^-26)`
/// (so `v − 2 > √S·(1 + 2^-28)`) means `v` exceeds it
/// (`S = t² + 2ad`), [`surely_below_root`] that it does not.
#[inline]
pub(crate) fn exceeds_reach(v: i64, t: i64, a: i64, d: i64) -> bool {
    if v <= 0 {
        return false;
    }
    let sum = reach_sum(t, a, d);
    let lo = (v as u128).saturating_sub(2);
    if lo * lo > sum.saturating_add(sum >> 26) {
        return true;
    }
    if surely_below_root(v, sum) {
        return false;
    }
    v > reach(t, a, d)
}

/// Whether `own < reach(t, a, d)` for certain, without the root.
#[inline]
pub(crate) fn surely_below_reach(own: i64, t: i64, a: i64, d: i64) -> bool {
    surely_below_root(own, reach_sum(t, a, d))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn f(v: i64) -> f64 {
        v as f64 / ONE as f64
    }
    fn q(v: f64) -> i64 {
        (v * ONE as f64).round() as i64
    }

    #[test]
    fn arithmetic_matches_f64() {
        for (a, b) in [(1.5, 2.25), (-3.0, 0.001), (1e-6, 1e-4), (30000.0, 0.5)] {
            assert!((f(mul(q(a), q(b))) - a * b).abs() < 1e-8);
            let (qa, qb) = (f(q(a)), f(q(b))); // the inputs as quantised
                                               // Relative error, plus half a step of the Q32 result.
            assert!(
                (f(div(q(a), q(b))) - qa / qb).abs() <= 1e-9 * (qa / qb).abs() + 2f64.powi(-32)
            );
        }
        for a in [0.0, 1e-9, 0.25, 2.0, 1e6] {
            assert!(
                (f(sqrt(q(a))) - f64::sqrt(f(q(a)))).abs() < 1e-8 * (1.0 + a.sqrt()),
                "{a}"
            );
        }
        assert_eq!(mul(i64::MAX, 2 << 32), i64::MAX);
        assert_eq!(div(ONE, 0), i64::MAX);
        assert_eq!(sqrt(-5), 0);
        // reach keeps slow speeds: raw speeds of a few thousand (squares
        // far below one Q32 step) and the full range.
        for (t, a, d) in [
            (0i64, 2684i64, 461_097i64),
            (167, 2684, 20),
            (1 << 40, 1 << 20, 1 << 42),
            (0, 0, 0),
        ] {
            let exact = ((t as f64).powi(2) + 2.0 * a as f64 * d as f64).sqrt();
            let got = reach(t, a, d) as f64;
            assert!(
                (got - exact).abs() <= 1e-9 * exact + 1.0,
                "{t} {a} {d}: {got} vs {exact}"
            );
        }
        assert_eq!(reach(i64::MAX, i64::MAX, i64::MAX), i64::MAX);
    }

    #[test]
    fn the_reach_comparisons_agree_with_the_root() {
        // Pseudo-random speeds, accelerations and distances over the
        // planner's range, and speeds on and next to each root.
        let mut next = crate::test_rng::xorshift64(0x9e37_79b9_7f4a_7c15);
        for _ in 0..200_000 {
            let t = (next() >> (28 + next() % 36)) as i64;
            let a = (next() >> (30 + next() % 34)) as i64;
            let d = (next() >> (24 + next() % 40)) as i64;
            let r = reach(t, a, d);
            let off = (next() % 9) as i64 - 4;
            for v in [
                r + off,
                (next() >> (28 + next() % 36)) as i64,
                r >> 1,
                0,
                -3,
            ] {
                assert_eq!(exceeds_reach(v, t, a, d), v > r, "{v} {t} {a} {d}");
            }
            for own in [
                r - 3,
                r,
                t - 3,
                t - (t >> 20),
                (next() >> (28 + next() % 36)) as i64,
            ] {
                if surely_below_reach(own, t, a, d) {
                    assert!(own < r, "{own} {t} {a} {d}");
                }
            }
        }
    }
}
