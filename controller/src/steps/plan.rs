//! A tick's setpoint into each axis's step plan: how many step boundaries
//! the axis crosses in the tick, which way, and exactly when.
//!
//! The setpoint of tick k is the position at the end of tick k; between
//! two setpoints the ideal trajectory is their linear interpolation. An
//! axis at `s0` steps (fractional) at the tick's start and `s1` at its end
//! crosses boundary `b` at `t = T · (b − s0) / (s1 − s0)`; within a tick
//! these times are equally spaced, so a plan is the count, the direction,
//! the first time and the interval (Grbl's `segment_t` in spirit:
//! `grbl/stepper.c` prepares, per segment, a step count and a constant
//! step rate outside the step interrupt, `st_prep_buffer`; the times here
//! are exact, as Klipper's `itersolve.c` computes each step's time from
//! the motion, not Grbl's Bresenham approximation).
//!
//! The count is `floor(mm × steps/mm)` (boundary `b` is crossed when the
//! step position goes from below `b` to `b` or above, or back from `b` to
//! below it). Times are integer timer counts after the window start: the
//! exact time rounded up, at least 1, so that a step belongs to the tick
//! whose end it precedes (or equals): crossing `i` is at
//! `ceil((T · a + i · T · 2^32) / dq)`, `a` the distance to the first
//! boundary and `dq` the tick's travel (both in 2^-32 steps), kept as the
//! rounded-up time and how far it was rounded (`c · dq − numerator`) and
//! stepped Bresenham-style by the interval's quotient and remainder,
//! without drift.
//! Everything is 64-bit: `T ≤ 2^24` counts, `a ≤ 2^32`, travel capped at
//! [`MAX_STEPS_PER_TICK`] steps.

use fuzzy_core::units::Point3Mm;

use super::config::{StepsPerMm, Timing};

/// Most steps one axis plans in one tick; more (a jump, not motion: far
/// above what [`Timing::max_rate_hz`] emits) are planned at once and the
/// engine carries and reports the rest as lag.
pub const MAX_STEPS_PER_TICK: u32 = 1 << 20;

/// One axis's steps in one tick.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AxisPlan {
    /// Commanded position at the tick's start, whole steps
    /// (`floor(s0)`).
    pub start: i64,
    /// Boundaries crossed.
    pub steps: u32,
    /// Towards positive positions.
    pub forward: bool,
    /// First crossing: `T · a / dq` rounded up, counts after the window's
    /// start (0 for a crossing at the very start: the engine emits it one
    /// count in).
    pub first: u32,
    /// How far the rounding went up: `first · dq − T · a` (below `dq`).
    pub first_short: u64,
    /// Interval `T · 2^32 / dq`: quotient (counts) and remainder.
    pub interval: u32,
    /// Remainder of the interval.
    pub interval_rem: u64,
    /// The divisor: the tick's travel, 2^-32 steps.
    pub dq: u64,
}

/// Every axis's steps in one tick.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TickPlan {
    /// X, Y, Z.
    pub axes: [AxisPlan; 3],
}

/// Position in steps with 32 fractional bits: `mm × steps/mm` exactly
/// (Q32.32 × Q16.16, 128-bit product), its low 16 bits dropped (so that
/// `>> 32` is still the exact floor), saturated to ±2^62 so differences
/// never overflow.
pub fn steps_q32(mm_bits: i64, spm: StepsPerMm) -> i64 {
    let p = (mm_bits as i128 * spm.0 as i128) >> 16;
    p.clamp(-(1i128 << 62), 1i128 << 62) as i64
}

/// `floor(mm × steps/mm)`: the commanded position in whole steps.
pub fn whole_steps(mm_bits: i64, spm: StepsPerMm) -> i64 {
    steps_q32(mm_bits, spm) >> 32
}

/// The plan of one axis moving from `q0` to `q1` (2^-32 steps) in a tick
/// of `window` counts.
pub fn plan_axis(q0: i64, q1: i64, window: u32) -> AxisPlan {
    let n0 = q0 >> 32;
    let n1 = q1 >> 32;
    let mut p = AxisPlan {
        start: n0,
        ..AxisPlan::default()
    };
    if n0 == n1 {
        return p;
    }
    let forward = n1 > n0;
    // Distance to the first boundary and the travel, both > 0 and a ≤ dq.
    let (a, dq, steps) = if forward {
        (
            ((n0 + 1) << 32).wrapping_sub(q0) as u64,
            q1.wrapping_sub(q0) as u64,
            n1.wrapping_sub(n0) as u64,
        )
    } else {
        (
            q0.wrapping_sub(n0 << 32) as u64,
            q0.wrapping_sub(q1) as u64,
            n0.wrapping_sub(n1) as u64,
        )
    };
    let t = window.min(super::config::MAX_WINDOW_COUNTS) as u64;
    p.forward = forward;
    if steps > MAX_STEPS_PER_TICK as u64 {
        // Not motion: every step at the window's start; the rest are the
        // engine's to catch up (its resync reports them as lag).
        p.steps = MAX_STEPS_PER_TICK;
        p.first = 0;
        p.dq = 1;
        return p;
    }
    p.steps = steps as u32;
    p.dq = dq;
    let num = t * a;
    let Some(first) = num.checked_div(dq) else {
        return p;
    };
    let rem = num - first * dq;
    if rem == 0 {
        p.first = first as u32;
    } else {
        p.first = first as u32 + 1;
        p.first_short = dq - rem;
    }
    if steps >= 2 {
        let inc = t << 32;
        if let Some(q) = inc.checked_div(dq) {
            p.interval = q as u32;
            p.interval_rem = inc - q * dq;
        }
    }
    p
}

/// The tick's side of step generation: each setpoint into a [`TickPlan`]
/// (from the previous setpoint to this one).
#[derive(Clone, Copy, Debug)]
pub struct Planner {
    spm: [StepsPerMm; 3],
    window: u32,
    /// The previous setpoint, 2^-32 steps.
    last: [i64; 3],
}

impl Planner {
    /// At `start`, with `timing`'s tick and `spm` steps/mm per axis.
    pub fn new(spm: [StepsPerMm; 3], timing: &Timing, start: Point3Mm) -> Self {
        let b = start.to_bits();
        Planner {
            spm,
            window: timing.window,
            last: [
                steps_q32(b[0], spm[0]),
                steps_q32(b[1], spm[1]),
                steps_q32(b[2], spm[2]),
            ],
        }
    }

    /// The commanded position of `pos`, whole steps per axis.
    pub fn whole_steps(&self, pos: Point3Mm) -> [i64; 3] {
        let b = pos.to_bits();
        let s = self.spm;
        [
            whole_steps(b[0], s[0]),
            whole_steps(b[1], s[1]),
            whole_steps(b[2], s[2]),
        ]
    }

    /// Where the last plan ended, whole steps.
    pub fn position(&self) -> [i64; 3] {
        self.last.map(|q| q >> 32)
    }

    /// The plan of the tick that ends at `pos`.
    pub fn plan(&mut self, pos: Point3Mm) -> TickPlan {
        let mut plan = TickPlan::default();
        let axes = plan.axes.iter_mut().zip(self.last.iter_mut());
        for ((a, last), (bits, spm)) in axes.zip(pos.to_bits().into_iter().zip(self.spm)) {
            let q1 = steps_q32(bits, spm);
            *a = plan_axis(*last, q1, self.window);
            *last = q1;
        }
        plan
    }

    /// Start again from `steps` (whole steps per axis, where the engine
    /// stopped): the next plan runs from there. Returns the position in mm
    /// whose commanded position is exactly `steps` (the smallest, rounded
    /// up to 2^-32 mm), which the next setpoints start from.
    pub fn rebase(&mut self, steps: [i64; 3]) -> Point3Mm {
        let mut bits = [0i64; 3];
        for ((b, q), (s, spm)) in bits
            .iter_mut()
            .zip(self.last.iter_mut())
            .zip(steps.into_iter().zip(self.spm))
        {
            let d = spm.0.max(1) as i128;
            let n = (s as i128) << 48;
            let up = n.div_euclid(d) + i128::from(n.rem_euclid(d) != 0);
            *b = up.clamp(i64::MIN as i128, i64::MAX as i128) as i64;
            *q = steps_q32(*b, spm);
        }
        let [x, y, z] = bits;
        Point3Mm::from_bits(x, y, z)
    }

    /// The plan of a tick that holds the position.
    pub fn hold(&self) -> TickPlan {
        let mut plan = TickPlan::default();
        for (a, q) in plan.axes.iter_mut().zip(self.last) {
            a.start = q >> 32;
        }
        plan
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rebase_lands_on_the_step_exactly() {
        let timing = crate::steps::StepConfig::new(StepsPerMm::from_int(80))
            .timing(84_000_000, 1000)
            .unwrap();
        let spm = [80_000, 53_333, 3_200_000].map(StepsPerMm::from_milli);
        let mut p = Planner::new(spm, &timing, Point3Mm::ORIGIN);
        for steps in [
            [0, 0, 0],
            [1, -1, 7],
            [12_345, -98_765, -3],
            [-80, 53, 3200],
        ] {
            let mm = p.rebase(steps);
            assert_eq!(p.position(), steps);
            assert_eq!(p.whole_steps(mm), steps);
            let plan = p.plan(mm);
            assert!(plan.axes.iter().all(|a| a.steps == 0), "{plan:?}");
        }
    }

    /// Crossing times of a plan, counts after the window start, as the
    /// engine steps them.
    fn times(p: &AxisPlan) -> Vec<u32> {
        let (mut c, mut short) = (p.first as u64, p.first_short);
        let mut out = Vec::new();
        for _ in 0..p.steps {
            out.push(c.max(1) as u32);
            c += p.interval as u64;
            if short >= p.interval_rem {
                short -= p.interval_rem;
            } else {
                short = short + p.dq - p.interval_rem;
                c += 1;
            }
        }
        out
    }

    /// The exact crossing times (f64 reference), counts.
    fn exact(q0: i64, q1: i64, window: u32) -> Vec<f64> {
        let (s0, s1) = (q0 as f64 / 2f64.powi(32), q1 as f64 / 2f64.powi(32));
        let (n0, n1) = ((q0 >> 32), (q1 >> 32));
        let t = window as f64;
        if n1 > n0 {
            (n0 + 1..=n1)
                .map(|b| t * (b as f64 - s0) / (s1 - s0))
                .collect()
        } else {
            (n1 + 1..=n0)
                .rev()
                .map(|b| t * (s0 - b as f64) / (s0 - s1))
                .collect()
        }
    }

    fn check(q0: i64, q1: i64, window: u32) {
        let p = plan_axis(q0, q1, window);
        let got = times(&p);
        let want = exact(q0, q1, window);
        assert_eq!(got.len(), want.len(), "{q0} {q1}");
        assert_eq!(p.start, q0 >> 32);
        for (g, w) in got.iter().zip(&want) {
            // Never early; rounded up to a count (at least 1); f64 carries
            // ~1e-6 counts here.
            let g = *g as f64;
            assert!(
                g >= w - 1e-6 && g < w.max(0.0) + 1.0 + 1e-6,
                "{q0} {q1}: {g} vs {w}"
            );
            assert!(g >= 1.0 && g <= window as f64);
        }
    }

    #[test]
    fn crossing_times_are_the_exact_times_rounded_up() {
        let one = 1i64 << 32;
        check(0, 10 * one, 84_000);
        check(10 * one, 0, 84_000);
        check(one / 3, 5 * one + one / 7, 84_000);
        check(-one / 3, -5 * one - one / 7, 84_000);
        check(one - 1, one, 84_000);
        check(one, one - 1, 84_000);
        check(0, 1, 84_000);
        check(123_456_789_012, 123_456_789_012 + 400 * one + 17, 84_000);
        check(0, 3000 * one, 4200);
    }

    #[test]
    fn a_step_exactly_at_the_ticks_end_belongs_to_it() {
        let one = 1i64 << 32;
        // 0 → 2 steps: boundaries 1 and 2 at T/2 and T.
        let p = plan_axis(0, 2 * one, 1000);
        assert_eq!(times(&p), vec![500, 1000]);
        // 2 → 0 steps: boundary 2 is left at once (count 1), 1 at T/2;
        // arriving at 0 is not a crossing.
        let p = plan_axis(2 * one, 0, 1000);
        assert_eq!(times(&p), vec![1, 500]);
        assert_eq!((p.steps, p.forward), (2, false));
    }

    #[test]
    fn commanded_steps_are_the_exact_floor() {
        let spm = StepsPerMm::from_milli(53_333);
        for mm in [-1000.25f64, -0.001, 0.0, 0.0123, 17.5, 99_999.0] {
            let bits = (mm * 2f64.powi(32)).round() as i64;
            let exact = (bits as i128 * spm.0 as i128) >> 48;
            assert_eq!(whole_steps(bits, spm) as i128, exact, "{mm}");
        }
        // Saturated far outside any machine, never wrapped.
        let q = steps_q32(i64::MAX, StepsPerMm(u32::MAX));
        assert_eq!(q, 1 << 62);
    }

    #[test]
    fn a_jump_is_capped_not_wrapped() {
        let p = plan_axis(0, 1 << 62, 84_000);
        assert_eq!(p.steps, MAX_STEPS_PER_TICK);
        assert!(p.forward);
    }

    #[test]
    fn the_planner_chains_ticks() {
        let t = super::super::config::StepConfig::new(StepsPerMm::from_int(100))
            .timing(84_000_000, 1000)
            .unwrap();
        let spm = [
            StepsPerMm::from_int(100),
            StepsPerMm::from_int(200),
            StepsPerMm::from_milli(80_500),
        ];
        let mut pl = Planner::new(spm, &t, Point3Mm::ORIGIN);
        let a = pl.plan(Point3Mm::from_f64(1.0, 1.0, 1.0).unwrap());
        assert_eq!(
            [a.axes[0].steps, a.axes[1].steps, a.axes[2].steps],
            [100, 200, 80]
        );
        let b = pl.plan(Point3Mm::from_f64(0.5, 1.0, 2.0).unwrap());
        assert_eq!(b.axes[0].start, 100);
        assert_eq!((b.axes[0].steps, b.axes[0].forward), (50, false));
        assert_eq!(b.axes[1].steps, 0);
        assert_eq!(b.axes[2].start, 80);
        assert_eq!(b.axes[2].steps, 161 - 80);
        assert_eq!(pl.hold().axes[2].start, 161);
    }
}
