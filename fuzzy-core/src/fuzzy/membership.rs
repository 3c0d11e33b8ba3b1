//! Membership functions: triangle, trapezoid, Gaussian, generalised bell,
//! and the constant consequent of zero-order Sugeno systems.
//!
//! The definitions are MATLAB's (`trimf`, `trapmf`, `gaussmf`, `gbellmf`,
//! `constant`), edge cases included, so that a controller exported with
//! [`crate::fuzzy::export`] evaluates the same in MATLAB, Octave's
//! fuzzy-logic-toolkit and fuzzylite. Degrees are Q16.16 in `[0, 1]`.
//!
//! A definition is compiled once (`CompiledMf::compile`) into a form that
//! needs no division per evaluation (reciprocal slopes, `1/σ`, `log2 a`).

use crate::numerics::explog::{exp2_neg_q30, log2_q32, LOG2E_Q30};
use crate::units::Fx;

/// 1.0 as a raw Q16.16 degree.
pub(crate) const ONE: i32 = 1 << 16;

/// A membership function (or a Sugeno constant), parameters in the unit of
/// its variable.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MembershipFn {
    /// MATLAB `trimf [a b c]`: 0 at `a`, 1 at `b`, 0 at `c` (`a <= b <= c`;
    /// `a = b` or `b = c` give a shoulder that is 1 at `b`).
    Triangle {
        /// Left foot.
        a: Fx,
        /// Peak.
        b: Fx,
        /// Right foot.
        c: Fx,
    },
    /// MATLAB `trapmf [a b c d]`: rises on `[a, b]`, 1 on `[b, c]`, falls on
    /// `[c, d]` (`a <= b <= c <= d`).
    Trapezoid {
        /// Left foot.
        a: Fx,
        /// Left shoulder.
        b: Fx,
        /// Right shoulder.
        c: Fx,
        /// Right foot.
        d: Fx,
    },
    /// MATLAB `gaussmf [sigma c]`: `exp(−(x − c)² / (2σ²))`, `σ > 0`.
    /// Nagata et al. eq. 7 (`exp(log 0.5 · (x−p)² q²)`) is this with
    /// `σ = 1 / (q·sqrt(2 ln 2))`; Cho et al. eq. 3.1 (`exp(−(x−b)²/a)`) with
    /// `σ = sqrt(a/2)`.
    Gaussian {
        /// Standard deviation (> 0).
        sigma: Fx,
        /// Centre.
        center: Fx,
    },
    /// MATLAB `gbellmf [a b c]`: `1 / (1 + |(x − c)/a|^(2b))`, `a ≠ 0`,
    /// `b > 0`.
    Bell {
        /// Half width `a` (degree 0.5 at `c ± a`).
        width: Fx,
        /// Slope exponent `b`.
        slope: Fx,
        /// Centre `c`.
        center: Fx,
    },
    /// A zero-order Sugeno consequent: the crisp value itself (MATLAB
    /// `constant`). Only valid as an output term of a Sugeno system.
    Constant(Fx),
}

/// Why a membership function is invalid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum MfError {
    /// Triangle/trapezoid breakpoints are not in non-decreasing order.
    Unordered,
    /// Gaussian `σ <= 0`.
    NonPositiveSigma,
    /// Bell `a = 0` or `b <= 0`.
    BadBell,
}

impl MembershipFn {
    /// Triangle from parameter literals, at compile time:
    /// `MembershipFn::tri("0", "0.05", "0.15")`.
    pub const fn tri(a: &str, b: &str, c: &str) -> Self {
        MembershipFn::Triangle {
            a: Fx::lit(a),
            b: Fx::lit(b),
            c: Fx::lit(c),
        }
    }

    /// Trapezoid from parameter literals, at compile time.
    pub const fn trap(a: &str, b: &str, c: &str, d: &str) -> Self {
        MembershipFn::Trapezoid {
            a: Fx::lit(a),
            b: Fx::lit(b),
            c: Fx::lit(c),
            d: Fx::lit(d),
        }
    }

    /// Gaussian from parameter literals (`sigma`, `center`), at compile time.
    pub const fn gauss(sigma: &str, center: &str) -> Self {
        MembershipFn::Gaussian {
            sigma: Fx::lit(sigma),
            center: Fx::lit(center),
        }
    }

    /// Generalised bell from parameter literals (`a`, `b`, `c`), at compile
    /// time.
    pub const fn bell(width: &str, slope: &str, center: &str) -> Self {
        MembershipFn::Bell {
            width: Fx::lit(width),
            slope: Fx::lit(slope),
            center: Fx::lit(center),
        }
    }

    /// Sugeno constant from a literal, at compile time.
    pub const fn constant(v: &str) -> Self {
        MembershipFn::Constant(Fx::lit(v))
    }

    /// The parameters in MATLAB's order, and how many there are.
    pub fn params(&self) -> ([Fx; 4], usize) {
        match *self {
            MembershipFn::Triangle { a, b, c } => ([a, b, c, Fx::ZERO], 3),
            MembershipFn::Trapezoid { a, b, c, d } => ([a, b, c, d], 4),
            MembershipFn::Gaussian { sigma, center } => ([sigma, center, Fx::ZERO, Fx::ZERO], 2),
            MembershipFn::Bell {
                width,
                slope,
                center,
            } => ([width, slope, center, Fx::ZERO], 3),
            MembershipFn::Constant(v) => ([v, Fx::ZERO, Fx::ZERO, Fx::ZERO], 1),
        }
    }

    /// MATLAB's name of the shape (`trimf`, `trapmf`, `gaussmf`, `gbellmf`,
    /// `constant`).
    pub const fn matlab_name(&self) -> &'static str {
        match self {
            MembershipFn::Triangle { .. } => "trimf",
            MembershipFn::Trapezoid { .. } => "trapmf",
            MembershipFn::Gaussian { .. } => "gaussmf",
            MembershipFn::Bell { .. } => "gbellmf",
            MembershipFn::Constant(_) => "constant",
        }
    }

    /// Whether this is a Sugeno constant.
    pub const fn is_constant(&self) -> bool {
        matches!(self, MembershipFn::Constant(_))
    }

    /// Degree of membership of `x` (compiles on every call: for one-off
    /// evaluations; controllers keep the compiled form).
    pub fn degree(&self, x: Fx) -> Result<Fx, MfError> {
        Ok(Fx::from_bits(
            CompiledMf::compile(self)?.degree(x.to_bits()),
        ))
    }
}

/// A membership function compiled for evaluation without divisions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum CompiledMf {
    /// Trapezoid (a triangle has `b = c`); `up = 2^48/(b−a)`,
    /// `down = 2^48/(d−c)` (0 for vertical edges).
    Pwl {
        a: i32,
        b: i32,
        c: i32,
        d: i32,
        up: i64,
        down: i64,
    },
    /// Gaussian; `inv_sigma = 2^56/σ`.
    Gauss {
        center: i32,
        sigma: i32,
        inv_sigma: i64,
    },
    /// Bell; `log2 |a|` in Q32 and `2b` in Q16.
    Bell {
        center: i32,
        log2_width: i64,
        two_slope: i64,
    },
    /// Sugeno constant (raw Q16.16).
    Constant(i32),
}

/// `round(2^48 / w)` for a raw width `w > 0`, else 0.
const fn recip48(w: i64) -> i64 {
    if w <= 0 {
        0
    } else {
        ((1i64 << 48) + w / 2) / w
    }
}

impl CompiledMf {
    /// A placeholder for unused slots (never evaluated).
    pub(crate) const UNUSED: CompiledMf = CompiledMf::Constant(0);

    /// Validate and compile.
    pub(crate) const fn compile(mf: &MembershipFn) -> Result<CompiledMf, MfError> {
        match *mf {
            MembershipFn::Triangle { a, b, c } => {
                let (a, b, c) = (a.to_bits(), b.to_bits(), c.to_bits());
                if a > b || b > c {
                    return Err(MfError::Unordered);
                }
                Ok(CompiledMf::Pwl {
                    a,
                    b,
                    c: b,
                    d: c,
                    up: recip48(b as i64 - a as i64),
                    down: recip48(c as i64 - b as i64),
                })
            }
            MembershipFn::Trapezoid { a, b, c, d } => {
                let (a, b, c, d) = (a.to_bits(), b.to_bits(), c.to_bits(), d.to_bits());
                if a > b || b > c || c > d {
                    return Err(MfError::Unordered);
                }
                Ok(CompiledMf::Pwl {
                    a,
                    b,
                    c,
                    d,
                    up: recip48(b as i64 - a as i64),
                    down: recip48(d as i64 - c as i64),
                })
            }
            MembershipFn::Gaussian { sigma, center } => {
                let s = sigma.to_bits();
                if s <= 0 {
                    return Err(MfError::NonPositiveSigma);
                }
                Ok(CompiledMf::Gauss {
                    center: center.to_bits(),
                    sigma: s,
                    inv_sigma: ((1i64 << 56) + s as i64 / 2) / s as i64,
                })
            }
            MembershipFn::Bell {
                width,
                slope,
                center,
            } => {
                let (w, b) = (width.to_bits(), slope.to_bits());
                if w == 0 || b <= 0 {
                    return Err(MfError::BadBell);
                }
                Ok(CompiledMf::Bell {
                    center: center.to_bits(),
                    log2_width: log2_q32((w as i64).unsigned_abs()),
                    two_slope: 2 * b as i64,
                })
            }
            MembershipFn::Constant(v) => Ok(CompiledMf::Constant(v.to_bits())),
        }
    }

    /// Degree of membership of raw Q16.16 `x`, raw Q16.16 in `[0, 1]`.
    /// A Sugeno constant has no degree; it gives 0. The piecewise-linear case
    /// is inlined into the caller; the others are not.
    #[inline(always)]
    pub(crate) const fn degree(&self, x: i32) -> i32 {
        match *self {
            CompiledMf::Pwl {
                a,
                b,
                c,
                d,
                up,
                down,
            } => {
                // On an edge the distance to its foot is in [0, 2^32) and
                // the reciprocal non-negative: an unsigned 32×64-bit product,
                // and only the upper clamp can apply.
                if x < a || x > d {
                    0
                } else if x < b {
                    edge_degree(x.wrapping_sub(a) as u32, up)
                } else if x <= c {
                    ONE
                } else {
                    edge_degree(d.wrapping_sub(x) as u32, down)
                }
            }
            _ => self.smooth_degree(x),
        }
    }

    /// Degree of a Gaussian or bell term (out of line: rarely on hot paths).
    #[inline(never)]
    const fn smooth_degree(&self, x: i32) -> i32 {
        match *self {
            CompiledMf::Pwl { .. } => 0,
            CompiledMf::Gauss {
                center,
                sigma,
                inv_sigma,
            } => {
                let z = x as i64 - center as i64;
                // exp(−12.5) is below half a Q16 unit: 0 beyond 5σ.
                if z.unsigned_abs() >= 5 * sigma as u64 {
                    return 0;
                }
                let t = (z * inv_sigma) >> 32; // z/σ in Q24
                let e = ((t * t) >> 25) as u64; // (z/σ)²/2 in Q24
                let y = (e * LOG2E_Q30) >> 22; // in bits (Q32)
                ((exp2_neg_q30(y) as i64 + (1 << 13)) >> 14) as i32
            }
            CompiledMf::Bell {
                center,
                log2_width,
                two_slope,
            } => {
                let z = (x as i64 - center as i64).unsigned_abs();
                if z == 0 {
                    return ONE;
                }
                // s = 2b · log2|(x − c)/a| (Q32); degree = 1/(1 + 2^s).
                let l = log2_q32(z) - log2_width;
                let s = (l as i128 * two_slope as i128) >> 16;
                let lim = 40i128 << 32;
                if s >= lim {
                    return 0;
                }
                if s <= -lim {
                    return ONE;
                }
                let q = exp2_neg_q30(s.unsigned_abs() as u64) as u64; // 2^−|s| in Q30
                let den = (1u64 << 30) + q;
                let mu_q30 = if s >= 0 {
                    (q << 30) / den
                } else {
                    (1u64 << 60) / den
                };
                ((mu_q30 + (1 << 13)) >> 14) as i32
            }
            CompiledMf::Constant(_) => 0,
        }
    }

    /// The right end of the term's support (raw), `i32::MAX` if unbounded.
    #[inline(always)]
    pub(crate) const fn upper_end(&self) -> i32 {
        match *self {
            CompiledMf::Pwl { d, .. } => d,
            _ => i32::MAX,
        }
    }

    /// The constant of a Sugeno consequent (raw), or 0.
    pub(crate) const fn constant(&self) -> i32 {
        match *self {
            CompiledMf::Constant(v) => v,
            _ => 0,
        }
    }
}

/// `min(1, round(dist · recip / 2^32))` in Q16.16 for `recip = 2^48/width`
/// (`recip >= 0`; 0 for a vertical edge), for `dist` below the edge's
/// width (so the product stays below 2^49).
#[inline(always)]
const fn edge_degree(dist: u32, recip: i64) -> i32 {
    let v = (dist as u64)
        .wrapping_mul(recip as u64)
        .wrapping_add(1 << 31)
        >> 32;
    if v > ONE as u64 {
        ONE
    } else {
        v as i32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn deg(mf: MembershipFn, x: f64) -> f64 {
        mf.degree(Fx::from_num(x)).unwrap().to_num()
    }

    #[test]
    fn triangle_follows_trimf() {
        let t = MembershipFn::tri("0", "1", "3");
        for (x, want) in [
            (-1.0, 0.0),
            (0.0, 0.0),
            (0.5, 0.5),
            (1.0, 1.0),
            (2.0, 0.5),
            (3.0, 0.0),
            (4.0, 0.0),
        ] {
            assert!((deg(t, x) - want).abs() < 2e-5, "x = {x}");
        }
        // Shoulders: a = b is 1 at b, 0 left of it.
        let left = MembershipFn::tri("0", "0", "1");
        assert_eq!(deg(left, 0.0), 1.0);
        assert_eq!(deg(left, -0.001), 0.0);
        let right = MembershipFn::tri("0", "1", "1");
        assert_eq!(deg(right, 1.0), 1.0);
        assert_eq!(deg(right, 1.001), 0.0);
    }

    #[test]
    fn trapezoid_follows_trapmf() {
        let t = MembershipFn::trap("-1", "0", "1", "3");
        for (x, want) in [
            (-2.0, 0.0),
            (-0.5, 0.5),
            (0.0, 1.0),
            (0.7, 1.0),
            (1.0, 1.0),
            (2.0, 0.5),
            (3.0, 0.0),
        ] {
            assert!((deg(t, x) - want).abs() < 2e-5, "x = {x}");
        }
    }

    #[test]
    fn gaussian_and_bell_match_f64() {
        let g = MembershipFn::gauss("0.3", "1");
        let b = MembershipFn::bell("0.5", "2", "1");
        let b_frac = MembershipFn::bell("0.7", "1.3", "-0.2");
        for i in -300..=300 {
            let x = i as f64 / 100.0;
            let xq: f64 = Fx::from_num(x).to_num();
            let g_want = (-(xq - 1.0f64).powi(2) / (2.0 * 0.3f64.powi(2))).exp();
            assert!((deg(g, x) - g_want).abs() < 3e-5, "gauss x = {x}");
            let s: f64 = Fx::lit("0.5").to_num();
            let b_want = 1.0 / (1.0 + ((xq - 1.0) / s).abs().powf(4.0));
            assert!((deg(b, x) - b_want).abs() < 3e-5, "bell x = {x}");
            let (w, sl, c): (f64, f64, f64) = (
                Fx::lit("0.7").to_num(),
                Fx::lit("1.3").to_num(),
                Fx::lit("-0.2").to_num(),
            );
            let want = 1.0 / (1.0 + ((xq - c) / w).abs().powf(2.0 * sl));
            assert!((deg(b_frac, x) - want).abs() < 3e-5, "bell x = {x}");
        }
    }

    #[test]
    fn invalid_parameters_are_rejected() {
        assert_eq!(
            MembershipFn::tri("1", "0", "2").degree(Fx::ZERO),
            Err(MfError::Unordered)
        );
        assert_eq!(
            MembershipFn::trap("0", "2", "1", "3").degree(Fx::ZERO),
            Err(MfError::Unordered)
        );
        assert_eq!(
            MembershipFn::gauss("0", "0").degree(Fx::ZERO),
            Err(MfError::NonPositiveSigma)
        );
        assert_eq!(
            MembershipFn::bell("0", "2", "0").degree(Fx::ZERO),
            Err(MfError::BadBell)
        );
        assert_eq!(
            MembershipFn::bell("1", "-1", "0").degree(Fx::ZERO),
            Err(MfError::BadBell)
        );
    }

    #[test]
    fn extreme_inputs_stay_in_range() {
        let mfs = [
            MembershipFn::tri("-32768", "0", "32767"),
            MembershipFn::trap("-32768", "-1", "1", "32767"),
            MembershipFn::gauss("0.0001", "0"),
            MembershipFn::gauss("32767", "0"),
            MembershipFn::bell("0.0001", "100", "0"),
            MembershipFn::bell("32767", "0.01", "-32768"),
        ];
        for mf in mfs {
            for x in [i32::MIN, -1, 0, 1, i32::MAX] {
                let d = CompiledMf::compile(&mf).unwrap().degree(x);
                assert!((0..=ONE).contains(&d), "{mf:?} at {x}: {d}");
            }
        }
    }
}
