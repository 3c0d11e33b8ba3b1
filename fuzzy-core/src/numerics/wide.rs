//! 64-bit integers on a 32-bit core: shifts and divisions written with
//! 32-bit instructions (module docs of [`super`] for why and what they cost).
//!
//! The Cortex-M4 divides 32 bits by 32 bits in hardware (`UDIV`); a 64-bit
//! division is a library call, and so is a variable 64-bit shift at the
//! firmware's `opt-level = "z"`. The divisions
//! here are long division in base 2^16 on `UDIV` (Hacker's Delight,
//! `divlu`); the shifts split the word in two. All are `const fn`.

/// `(x >> s) as u32` (the low word of a logical right shift), `s` in
/// `0..64` (0 beyond), with 32-bit shifts only.
#[inline(always)]
pub const fn shr_u64_low(x: u64, s: u32) -> u32 {
    let (hi, lo) = ((x >> 32) as u32, x as u32);
    if s == 0 {
        lo
    } else if s < 32 {
        (hi << (32 - s)) | (lo >> s)
    } else if s < 64 {
        hi >> (s - 32)
    } else {
        0
    }
}

/// `(x >> s) as i32` (the low word of an arithmetic right shift), `s` in
/// `0..64` (the sign beyond), with 32-bit shifts only.
#[inline(always)]
pub const fn sar_i64_low(x: i64, s: u32) -> i32 {
    let (hi, lo) = ((x >> 32) as i32, x as u32);
    if s == 0 {
        lo as i32
    } else if s < 32 {
        (((hi as u32) << (32 - s)) | (lo >> s)) as i32
    } else if s < 64 {
        hi >> (s - 32)
    } else {
        hi >> 31
    }
}

/// `(x as u64) << s` for `s` in `0..=32` (`x << 32` beyond), with 32-bit
/// shifts only.
#[inline(always)]
pub const fn shl_u32_wide(x: u32, s: u32) -> u64 {
    if s == 0 {
        x as u64
    } else if s < 32 {
        (((x >> (32 - s)) as u64) << 32) | (x << s) as u64
    } else {
        (x as u64) << 32
    }
}

/// `(u1·2^32 + u0) / v` and the remainder, for `u1 < v` (so the quotient fits
/// 32 bits). Hacker's Delight, `divlu`, with 32-bit hardware divisions only.
pub const fn divlu(u1: u32, u0: u32, v: u32) -> (u32, u32) {
    if v == 0 || u1 >= v {
        return (u32::MAX, 0); // outside the contract: saturate
    }
    const B: u32 = 1 << 16;
    let s = v.leading_zeros();
    let v = v << s;
    let (vn1, vn0) = (v >> 16, v & 0xFFFF);
    let un32 = if s == 0 {
        u1
    } else {
        (u1 << s) | (u0 >> (32 - s))
    };
    let un10 = u0 << s;
    let (un1, un0) = (un10 >> 16, un10 & 0xFFFF);
    // vn1 >= 2^15 (v is normalised); checked to keep the code panic-free.
    let mut q1 = match un32.checked_div(vn1) {
        Some(q) => q,
        None => return (u32::MAX, 0),
    };
    let mut rhat = un32 - q1 * vn1;
    while q1 >= B || q1 * vn0 > (rhat << 16) + un1 {
        q1 -= 1;
        rhat += vn1;
        if rhat >= B {
            break;
        }
    }
    let un21 = (un32 << 16)
        .wrapping_add(un1)
        .wrapping_sub(q1.wrapping_mul(v));
    let mut q0 = match un21.checked_div(vn1) {
        Some(q) => q,
        None => return (u32::MAX, 0),
    };
    let mut rhat = un21 - q0 * vn1;
    while q0 >= B || q0 * vn0 > (rhat << 16) + un0 {
        q0 -= 1;
        rhat += vn1;
        if rhat >= B {
            break;
        }
    }
    let r = (un21 << 16)
        .wrapping_add(un0)
        .wrapping_sub(q0.wrapping_mul(v))
        >> s;
    ((q1 << 16) + q0, r)
}

/// `n / d` (floor) when the quotient fits 32 bits (`n < d · 2^32`, i.e. the
/// high word of `n` is below `d`): one long division, without
/// [`div_u64_u32`]'s first step. Outside the contract: `u32::MAX`.
#[inline(always)]
pub const fn div_narrow(n: u64, d: u32) -> u32 {
    divlu((n >> 32) as u32, n as u32, d).0
}

/// `n / d` (floor) for a divisor below 2^16 (the average filter's window
/// length): long division in base 2^16 where every partial dividend is below
/// `d · 2^16`, so three hardware `UDIV`s and no correction steps. Larger
/// divisors go to [`div_u64_u32`]; `u64::MAX` for `d = 0`.
#[inline(always)]
pub const fn div_u64_small(n: u64, d: u32) -> u64 {
    if d == 0 || d >= 1 << 16 {
        return div_u64_u32(n, d);
    }
    let (hi, lo) = ((n >> 32) as u32, n as u32);
    let (q2, r) = (hi / d, hi % d);
    let mid = (r << 16) | (lo >> 16);
    let (q1, r) = (mid / d, mid % d);
    let low = (r << 16) | (lo & 0xFFFF);
    ((q2 as u64) << 32) | ((q1 << 16) + low / d) as u64
}

/// `n / d` (floor) for a 32-bit divisor; `u64::MAX` for `d = 0`.
pub const fn div_u64_u32(n: u64, d: u32) -> u64 {
    if d == 0 {
        return u64::MAX;
    }
    let (hi, lo) = ((n >> 32) as u32, n as u32);
    let (q_hi, r) = (hi / d, hi % d);
    let (q_lo, _) = divlu(r, lo, d);
    ((q_hi as u64) << 32) | q_lo as u64
}
#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn div_matches_u64_division(n in any::<u64>(), d in 1u32..) {
            prop_assert_eq!(div_u64_u32(n, d), n / d as u64);
        }

        #[test]
        fn div_small_matches_u64_division(n in any::<u64>(), d in 0u32..70_000) {
            let want = if d == 0 { u64::MAX } else { n / d as u64 };
            prop_assert_eq!(div_u64_small(n, d), want);
        }

        #[test]
        fn div_narrow_matches(n in any::<u64>(), d in 1u32..) {
            let n = n % ((d as u64) << 32); // the contract: quotient < 2^32
            prop_assert_eq!(div_narrow(n, d) as u64, n / d as u64);
        }

        #[test]
        fn divlu_matches(u1 in any::<u32>(), u0 in any::<u32>(), v in 1u32..) {
            let u1 = u1 % v;
            let n = ((u1 as u64) << 32) | u0 as u64;
            prop_assert_eq!(divlu(u1, u0, v), ((n / v as u64) as u32, (n % v as u64) as u32));
        }
    }

    proptest! {
        #[test]
        fn narrow_shifts_match_u64_shifts(x in any::<u64>(), s in 0u32..70) {
            let want = if s < 64 { (x >> s) as u32 } else { 0 };
            prop_assert_eq!(shr_u64_low(x, s), want);
            let xi = x as i64;
            let want = if s < 64 { (xi >> s) as i32 } else { (xi >> 63) as i32 };
            prop_assert_eq!(sar_i64_low(xi, s), want);
            let w = x as u32;
            let want = (w as u64) << s.min(32);
            prop_assert_eq!(shl_u32_wide(w, s), want);
        }
    }

    #[test]
    fn div_edges() {
        for (n, d) in [
            (0u64, 1u32),
            (u64::MAX, 1),
            (u64::MAX, u32::MAX),
            (u64::MAX, 0x8000_0000),
            (1 << 63, 3),
            (12345, 0x1_0000),
            (u64::MAX, 0xFFFF),
        ] {
            assert_eq!(div_u64_u32(n, d), n / d as u64, "{n} / {d}");
        }
        assert_eq!(div_u64_u32(5, 0), u64::MAX);
    }
}
