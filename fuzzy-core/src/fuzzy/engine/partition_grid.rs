//! The fast path: rules a complete grid with min AND, every input a
//! partition (at most two neighbouring terms non-zero), the output a chain
//! with min implication. At most `2^NI` rules can fire; each adds its
//! strength to its consequent and the chain's closed-form centroid
//! ([`super::super::centroid`]) gives the output. [`Controller::evaluate`]
//! takes it whenever it applies, [`super::ExactController`] always.

use super::super::membership::ONE;
use super::{saturate_i32, Controller, Evaluation};
use crate::units::Fx;

impl<'a, const NI: usize, const NT: usize, const NO: usize, const S: usize>
    Controller<'a, NI, NT, NO, S>
{
    /// Input `i` at `x` (raw, clamped to the universe) on a partition: the
    /// first term that can be non-zero, its degree and the next term's (0
    /// when there is none).
    #[inline(always)]
    fn candidates(&self, i: usize, x: Fx) -> (usize, i32, i32) {
        let (Some(mfs), Some(upper), Some(&terms), Some(&(lo, hi))) = (
            self.inputs.get(i),
            self.upper.get(i),
            self.input_terms.get(i),
            self.input_range.get(i),
        ) else {
            return (0, 0, 0);
        };
        let n = (terms as usize).min(NT);
        let x = x.to_bits().max(lo).min(hi);
        let mut j = 0;
        while j + 1 < n && upper.get(j).is_some_and(|&u| u < x) {
            j += 1;
        }
        // A `match`, so that the degree is computed here, not in a closure.
        let first = match mfs.get(j) {
            Some(mf) => mf.degree(x),
            None => 0,
        };
        let next = match mfs.get(j + 1) {
            Some(mf) if j + 1 < n => mf.degree(x),
            _ => 0,
        };
        (j, first, next)
    }

    /// The common case in a few plain loops: with partitioned inputs at most
    /// two neighbouring terms per input are non-zero, so at most `2^NI` rules
    /// fire; each adds its strength to its consequent; the chain's closed-form
    /// centroid follows. Same results as the general path, bit for bit.
    pub(super) fn infer_partition_grid(&self, inputs: [Fx; NI]) -> Evaluation {
        self.infer_partition_grid_in(&mut [0; NO], inputs)
    }

    /// [`Self::infer_partition_grid`] with the consequents' strengths in
    /// `strength`, which must be all zero and is left all zero, so that a
    /// caller keeps one array across inferences instead of clearing a new
    /// one each time ([`super::ExactScratch`]).
    pub(super) fn infer_partition_grid_in(
        &self,
        strength: &mut [i32; NO],
        inputs: [Fx; NI],
    ) -> Evaluation {
        let def = self.def;
        let default = Evaluation {
            output: def.default_output,
            fired: false,
            strength: Fx::ZERO,
        };
        let (Some(grid), Some(chain)) = (&self.grid, &self.chain) else {
            return default;
        };
        // Each fired rule adds its strength to its consequent (max);
        // `lowest..=highest` is the range of fired consequents.
        let mut f = Fired {
            strength,
            lowest: NO,
            highest: 0,
            best: 0,
        };
        if NI == 2 {
            // Two inputs (Lin's controller, the scheduler's hot path): the
            // four candidate rules written out.
            let input = |i: usize| inputs.get(i).copied().unwrap_or(Fx::ZERO);
            let stride = |i: usize| self.stride.get(i).copied().unwrap_or(0) as usize;
            let (j0, a0, b0) = self.candidates(0, input(0));
            let (j1, a1, b1) = self.candidates(1, input(1));
            let (s0, s1) = (stride(0), stride(1));
            let base = j0 * s0 + j1 * s1;
            f.fire(grid, a0.min(a1), base);
            if b0 > 0 {
                f.fire(grid, b0.min(a1), base + s0);
            }
            if b1 > 0 {
                f.fire(grid, a0.min(b1), base + s1);
                if b0 > 0 {
                    f.fire(grid, b0.min(b1), base + s0 + s1);
                }
            }
        } else {
            // Per input: the first candidate term and the two degrees.
            // `base` is the grid index of the rule made of every input's
            // first candidate; `second` has bit i set when input i's second
            // candidate is non-zero, so the rules worth visiting are the
            // sub-masks of `second`.
            let mut base = 0usize;
            let mut second = 0usize;
            let mut deg = [[0i32; 2]; NI];
            for (i, ((d, &x), &step)) in deg
                .iter_mut()
                .zip(inputs.iter())
                .zip(self.stride.iter())
                .enumerate()
            {
                let (j, first, next) = self.candidates(i, x);
                base += j * step as usize;
                *d = [first, next];
                if next > 0 {
                    second |= 1 << i;
                }
            }
            let mut mask = second;
            loop {
                let mut w = ONE;
                let mut code = base;
                for (i, (d, &step)) in deg.iter().zip(self.stride.iter()).enumerate() {
                    if (mask >> i) & 1 != 0 {
                        w = w.min(d[1]);
                        code += step as usize;
                    } else {
                        w = w.min(d[0]);
                    }
                }
                f.fire(grid, w, code);
                if mask == 0 {
                    break;
                }
                mask = (mask - 1) & second;
            }
        }
        let best = f.best;
        if best == 0 || f.lowest > f.highest {
            return default;
        }
        let centroid = chain.centroid_q30(f.strength, f.lowest, f.highest);
        // Clear what fired: every fired consequent is in lowest..=highest.
        // (`black_box` keeps these few stores from becoming a `memset` call.)
        let zero = core::hint::black_box(0);
        for s in f.strength.iter_mut().take(f.highest + 1).skip(f.lowest) {
            *s = zero;
        }
        match centroid {
            Some(u) => {
                let span = (self.out_max as i64 - self.out_min as i64) as u64;
                let offset = (span * u as u64 + (1 << 29)) >> 30;
                Evaluation {
                    output: Fx::from_bits(saturate_i32(self.out_min as i64 + offset as i64)),
                    fired: true,
                    strength: Fx::from_bits(best),
                }
            }
            None => default,
        }
    }
}

/// The fired rules of one inference: each adds its strength to its
/// consequent (max); `lowest..=highest` is the range of fired consequents,
/// `best` the largest strength.
struct Fired<'s, const NO: usize> {
    strength: &'s mut [i32; NO],
    lowest: usize,
    highest: usize,
    best: i32,
}

impl<const NO: usize> Fired<'_, NO> {
    /// Rule `code` of `grid` fired with strength `w` (inlined: it runs for
    /// each candidate rule of every inference).
    #[inline(always)]
    fn fire(&mut self, grid: &[u8], w: i32, code: usize) {
        if w > 0 {
            let then = grid.get(code).copied().unwrap_or(0) as usize;
            if let Some(s) = self.strength.get_mut(then) {
                *s = (*s).max(w);
                self.lowest = self.lowest.min(then);
                self.highest = self.highest.max(then);
            }
            self.best = self.best.max(w);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::super::rule::Antecedent;
    use super::super::super::MembershipFn;
    use super::super::Scratch;
    use super::*;

    /// ∫x·u/∫u of the aggregate by a 20 001-point trapezoid rule, in f64.
    fn dense_centroid(c: &Controller<'_, 2, 6, 7>, x: [Fx; 2]) -> f64 {
        let def = c.def();
        let deg = |mf: &MembershipFn, v: f64| -> f64 {
            let (p, _) = mf.params();
            let (a, b, cc): (f64, f64, f64) = (p[0].to_num(), p[1].to_num(), p[2].to_num());
            if v <= a || v >= cc {
                0.0
            } else if v <= b {
                (v - a) / (b - a)
            } else {
                (cc - v) / (cc - b)
            }
        };
        let xs: Vec<f64> = x.iter().map(|v| v.to_num::<f64>()).collect();
        let mut strength = [0f64; 7];
        for r in def.rules {
            let mut w: f64 = 1.0;
            for (i, a) in r.when.iter().enumerate() {
                if let Antecedent::Is(t) = a {
                    let v = xs[i].clamp(def.inputs[i].min.to_num(), def.inputs[i].max.to_num());
                    let mf = &def.inputs[i].terms[*t as usize].mf;
                    // Triangles whose feet equal their peak (shoulders) still
                    // give 1 at the peak.
                    let (p, _) = mf.params();
                    let d = if v == p[1].to_num::<f64>() {
                        1.0
                    } else {
                        deg(mf, v)
                    };
                    w = w.min(d);
                }
            }
            strength[r.then as usize] = strength[r.then as usize].max(w);
        }
        let (lo, hi): (f64, f64) = (def.output.min.to_num(), def.output.max.to_num());
        let n = 20_000;
        let (mut area, mut mom) = (0.0, 0.0);
        for i in 0..=n {
            let v = lo + (hi - lo) * i as f64 / n as f64;
            let u = def
                .output
                .terms
                .iter()
                .zip(strength.iter())
                .map(|(t, s)| deg(&t.mf, v).min(*s))
                .fold(0.0, f64::max);
            let wgt = if i == 0 || i == n { 0.5 } else { 1.0 };
            area += wgt * u;
            mom += wgt * u * v;
        }
        mom / area
    }

    #[test]
    fn fast_path_matches_the_general_path() {
        use crate::lin2021::CONTROLLER;
        assert!(CONTROLLER.fast_path());
        // The general path: same controller with the partition flags off.
        let mut general = CONTROLLER.clone();
        general.partition = [false, false];
        assert!(!general.fast_path());
        let mut scratch = Scratch::new();
        for i in -5..=70 {
            for j in -3..=45 {
                let x = [Fx::from_bits(i * 2900 + 17), Fx::from_bits(j * 1600 + 3)];
                assert_eq!(
                    CONTROLLER.evaluate_with(&mut scratch, x),
                    general.evaluate_with(&mut scratch, x),
                    "{x:?}"
                );
            }
        }
    }

    #[test]
    fn exact_centroid_matches_a_dense_integral() {
        use crate::lin2021::CONTROLLER;
        assert!(CONTROLLER.has_exact_centroid());
        let mut worst: f64 = 0.0;
        for i in 0..=15 {
            for j in 0..=10 {
                let x = [
                    Fx::from_num(i as f64 * 0.2 * (i as f64 * 0.2) / 3.0),
                    Fx::from_num(j as f64 * 0.1),
                ];
                let got: f64 = CONTROLLER.evaluate(x).output.to_num();
                worst = worst.max((got - dense_centroid(&CONTROLLER, x)).abs());
            }
        }
        assert!(worst < 2e-5, "worst {worst}");
    }
}
