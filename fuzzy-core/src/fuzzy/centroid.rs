//! The exact centroid (Lin et al. eq. 11 taken to its limit,
//! `∫ x·μ(x) dx / ∫ μ(x) dx`) of a Mamdani output whose terms are triangles
//! or trapezoids forming a *chain*, in closed form.
//!
//! A chain: the terms, in order, lie inside the output universe; each
//! overlaps at most its neighbours, and where term `k` and term `k+1`
//! overlap, `k` is on its falling edge and `k+1` on its rising edge. Every
//! partition of the universe into triangles/trapezoids (the usual layout,
//! MATLAB's default, Lin's, Njiri's) is a chain.
//!
//! With min implication the aggregate is `u(x) = maxₖ min(sₖ, μₖ(x))`. In a
//! chain at most two terms are non-zero at any `x`, so
//! `max(p, q) = p + q − min(p, q)` gives
//!
//! ```text
//! ∫u = Σₖ ∫min(sₖ, μₖ) − Σ_pairs ∫min(min(sₖ, sₖ₊₁), μₖ, μₖ₊₁)
//! ```
//!
//! (and the same for `∫x·u`). A trapezoid `(a, b, c, d)` clipped at `s` has
//! area `s·(p + (w₁ + w₂)(1 − s/2))` and first moment
//! `s/2·[(d − s w₂)² − (a + s w₁)²] + s²(a w₁ + d w₂)/2 + s³(w₁² − w₂²)/3`
//! (`w₁ = b − a`, `w₂ = d − c`, `p = c − b`). `min(μₖ, μₖ₊₁)` over the overlap
//! is a triangle from `aₖ₊₁` to `dₖ` peaking at the edges' crossing with
//! height `h`, so its clipped integrals are `h` times a unit triangle's
//! clipped at `min(1, σ/h)`. Each fired term and each fired pair costs a
//! dozen 32×32-bit multiplications: no sampling, no scratch memory.
//!
//! Coordinates are normalised to the universe (`u = (x − min)/(max − min)`)
//! in Q29 (`i32`): every operand stays below 4 whatever the universe, so each
//! product is one 32×32→64-bit multiplication; the result is exact to ~1e-8
//! of the range. MATLAB's default (101 samples) approximates the same
//! integral; `tests/controller_accuracy.rs` prints how far the two differ
//! for Lin's controller.

use crate::numerics::wide::div_narrow;

/// 1.0 in Q29.
const ONE: i32 = 1 << 29;
/// 1/3 in Q29.
const THIRD: i32 = 178_956_971;

/// `a·b` in Q29 (operands and result below 4 in magnitude).
#[inline(always)]
const fn mul(a: i32, b: i32) -> i32 {
    ((a as i64 * b as i64) >> 29) as i32
}

/// A trapezoid in normalised coordinates (Q29, all in `[0, 1]`), with the
/// parts of its clipped integrals that do not depend on the clip level.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Tz {
    a: i32,
    d: i32,
    /// Rising and falling widths, plateau width.
    w1: i32,
    w2: i32,
    p: i32,
    /// `(a·w1 + d·w2) / 2`.
    k2: i32,
    /// `(w1² − w2²) / 3`.
    k3: i32,
    /// Centre, for a symmetric term (whose clipped moment is centre × area).
    center: Option<i32>,
}

impl Tz {
    const ZERO: Tz = Tz {
        a: 0,
        d: 0,
        w1: 0,
        w2: 0,
        p: 0,
        k2: 0,
        k3: 0,
        center: None,
    };

    /// `tol`: the widths' difference (Q29) below which the term counts as
    /// symmetric: one Q16.16 step of the definition, so decimal breakpoints
    /// such as 0.1 and 0.25 (rounded to Q16.16) still give symmetric sets.
    /// The centroid error of that is below 2^-16 of the term's width.
    const fn new(a: i32, b: i32, c: i32, d: i32, tol: i32) -> Tz {
        let (w1, w2) = (b - a, d - c);
        let center = if (w1 - w2).abs() <= tol {
            Some(a + (d - a) / 2)
        } else {
            None
        };
        Tz {
            a,
            d,
            w1,
            w2,
            p: c - b,
            k2: (mul(a, w1) + mul(d, w2)) / 2,
            k3: mul(mul(w1, w1) - mul(w2, w2), THIRD),
            center,
        }
    }

    /// Area and first moment of `min(s, μ)` (Q29, `s` in Q29):
    /// `s·(p + (w1 + w2)(1 − s/2))` and
    /// `s/2·[(d − s w2)² − (a + s w1)²] + s²(a w1 + d w2)/2 + s³(w1² − w2²)/3`.
    /// Every intermediate stays within ±2 (the widths sum to at most 1, the
    /// coordinates are in `[0, 1]`).
    #[inline(always)]
    const fn clipped(&self, s: i32) -> (i32, i32) {
        let area = mul(s, self.p + mul(self.w1 + self.w2, ONE - s / 2));
        if let Some(c) = self.center {
            return (area, mul(c, area));
        }
        let e1 = self.d - mul(s, self.w2);
        let e2 = self.a + mul(s, self.w1);
        let t1 = mul(s / 2, mul(e1 - e2, e1 + e2));
        let s2 = mul(s, s);
        let t2 = mul(s2, self.k2);
        let t3 = if self.k3 == 0 {
            0
        } else {
            mul(mul(s2, s), self.k3)
        };
        (area, t1 + t2 + t3)
    }
}

/// The overlap of two neighbouring terms: `min(μₖ, μₖ₊₁)` is the triangle
/// `tent` scaled by `height`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Overlap {
    tent: Tz,
    height: i32,
    /// `2^58 / height`.
    inv_height: i64,
}

/// The closed-form centroid of a chain of up to `NO` terms.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Chain<const NO: usize> {
    terms: [Tz; NO],
    /// `overlaps[k]`: terms `k` and `k+1`.
    overlaps: [Option<Overlap>; NO],
    n: usize,
}

/// `(x − min)/span` in Q29 (for `min <= x <= min + span`).
const fn norm(x: i32, min: i32, span: i64) -> i32 {
    (((x as i64 - min as i64) as i128) << 29).wrapping_div(span as i128) as i32
}

impl<const NO: usize> Chain<NO> {
    /// The chain of `n` output terms given as raw Q16.16 `(a, b, c, d)`, or
    /// `None` when they do not form one inside `[min, max]`.
    pub(crate) const fn new(
        pwl: &[(i32, i32, i32, i32); NO],
        n: usize,
        min: i32,
        max: i32,
    ) -> Option<Self> {
        if n == 0 || n > NO || min >= max {
            return None;
        }
        let span = max as i64 - min as i64;
        // One Q16.16 step in normalised Q29 units, plus rounding.
        let tol = ((1i64 << 29) / span) as i32 + 2;
        let mut chain = Chain {
            terms: [Tz::ZERO; NO],
            overlaps: [None; NO],
            n,
        };
        let mut k = 0;
        while k < n {
            let (a, b, c, d) = pwl[k];
            if a < min || d > max || a > b || b > c || c > d {
                return None;
            }
            chain.terms[k] = Tz::new(
                norm(a, min, span),
                norm(b, min, span),
                norm(c, min, span),
                norm(d, min, span),
                tol,
            );
            if k + 2 < n && pwl[k + 2].0 < d {
                return None; // overlaps a term beyond its neighbour
            }
            if k + 1 < n {
                let (a2, b2, _, d2) = pwl[k + 1];
                if a2 < a || d2 < d {
                    return None; // not in order
                }
                if a2 < d {
                    // Overlap: k must be falling and k+1 rising throughout.
                    if c > a2 || b2 < d {
                        return None;
                    }
                    let (dk, ck) = (norm(d, min, span), norm(c, min, span));
                    let (an, bn) = (norm(a2, min, span), norm(b2, min, span));
                    let (w_fall, w_rise) = ((dk - ck) as i128, (bn - an) as i128);
                    // f(x) = (d − x)/w_fall meets g(x) = (x − a2)/w_rise at x*.
                    let x_star =
                        ((dk as i128 * w_rise + an as i128 * w_fall) / (w_rise + w_fall)) as i32;
                    let height = (((dk - x_star) as i128) << 29).wrapping_div(w_fall) as i32;
                    if height <= 0 {
                        return None;
                    }
                    chain.overlaps[k] = Some(Overlap {
                        tent: Tz::new(an, x_star, x_star, dk, tol),
                        height,
                        inv_height: (1i64 << 58) / height as i64,
                    });
                }
            }
            k += 1;
        }
        Some(chain)
    }

    /// The centroid as a fraction of the universe (Q30) for the terms'
    /// strengths (raw Q16.16); `None` when the aggregate is empty. Only
    /// terms `first..=last` are visited: the caller promises the others
    /// have strength 0 (they would add nothing).
    pub(crate) fn centroid_q30(
        &self,
        strength: &[i32; NO],
        first: usize,
        last: usize,
    ) -> Option<i64> {
        let end = self.n.min(NO).min(last.saturating_add(1));
        // 32-bit sums: after term k they hold the union of the clipped terms
        // first..=k (area and moment at most 1, 2^29 in Q29) plus at most one
        // term not yet reduced by its overlap (another 2^29), so they stay
        // below 2^31; saturating anyway (one instruction on the Cortex-M4).
        let (mut area, mut moment) = (0i32, 0i32);
        // Strengths in Q29, and the previous one for the overlap term (0
        // before `first`).
        let mut prev = 0i32;
        let mut k = first;
        while k < end {
            let s = strength[k].clamp(0, 1 << 16) << 13;
            if s > 0 {
                let (a, m) = self.terms[k].clipped(s);
                area = area.saturating_add(a);
                moment = moment.saturating_add(m);
            }
            // Subtract ∫min(σ, μₖ₋₁, μₖ) with σ = min(sₖ₋₁, sₖ).
            let sigma = prev.min(s);
            if sigma > 0 && k > 0 {
                if let Some(ov) = &self.overlaps[k - 1] {
                    // Clip level of the unit-height tent: σ/h, at most 1.
                    let t = if sigma >= ov.height {
                        ONE
                    } else {
                        ((sigma as i64 * ov.inv_height) >> 29) as i32
                    };
                    let (a, m) = ov.tent.clipped(t);
                    area = area.saturating_sub(mul(ov.height, a));
                    moment = moment.saturating_sub(mul(ov.height, m));
                }
            }
            prev = s;
            k += 1;
        }
        if area <= 0 {
            return None;
        }
        // moment/area in Q30 (at most 2^30): area <= 2 in Q29 < 2^31 and
        // moment <= area, so the high word of moment·2^30 is below area
        // and one 64-by-32-bit long division gives the quotient.
        let moment = (moment.clamp(0, area) as u64) << 30;
        let area = area as u32;
        Some(div_narrow(moment, area) as i64)
    }
}
