//! The executor stage: the jerk-limited speed profile along the envelope,
//! one interpolation tick at a time, and the commanded position on the
//! path (module docs of [`super`]: "Executor", "Resolution").
//!
//! Input: the [`Plan`]'s finalized nodes (read only: the executor never
//! changes the plan). Output: a [`Tick`] per call, which the controller's
//! step generation (`controller/src/steps`) turns into step pulses.
//!
//! Invariants, tick to tick:
//! - tangential jerk `<= J`, tangential acceleration `<= ρA`;
//! - the committed stop from the state (`brake`) stays under the envelope,
//!   so a feed hold, an underrun or a lower override never needs more
//!   deceleration than allowed;
//! - arc length never decreases and never passes the last finalized node;
//! - the executor changes only its own state (`&mut self`: arc length,
//!   speed, acceleration, segment); limits and plan are read through
//!   `&Plan` ([`super::Motion::tick`] then lets the buffer drop the
//!   nodes left behind).
//!
//! The counterpart of Grbl's `stepper.c` (which executes the planned
//! trapezoids segment by segment); the profile is jerk-limited and chosen
//! per tick against the envelope instead.

use super::brake::{integrate, speed_crossings, Brake};
use super::lookahead::{ld, Plan};
use super::q::{div, mul, ONE};
use crate::segment::Segment;
use crate::units::{AccelMmPerTick2, Point3Mm, SpeedMmPerTick};

/// What the executor is doing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MotionState {
    /// No path, or waiting for the first segment.
    Idle,
    /// Moving along the path.
    Moving,
    /// Stopped at the end of what is planned, waiting for more points
    /// (buffer underrun), or decelerating towards it.
    Starved,
    /// Feed hold: decelerating or stopped on the path.
    Holding,
    /// At rest at the end of an ended path.
    Done,
}

/// One interpolation tick's output.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Tick {
    /// Commanded position, mm.
    pub pos: Point3Mm,
    /// Arc length travelled along the path, mm.
    pub s_mm: fixed::types::I32F32,
    /// Tangential speed (in mm/min: [`Motion::speed_mm_per_min`](super::Motion::speed_mm_per_min)).
    pub speed: SpeedMmPerTick,
    /// Tangential acceleration.
    pub accel: AccelMmPerTick2,
    /// Index in the path (0 = its first point, every pushed point counts)
    /// of the last point reached.
    pub point: u32,
    /// State.
    pub state: MotionState,
}

/// The executor's state along the path (per-tick units, Q32).
#[derive(Clone, Debug, Default)]
pub(super) struct Executor {
    /// Arc length from the path start, speed, acceleration.
    x: i64,
    v: i64,
    a: i64,
    hold: bool,
    /// Index (in the lookahead's nodes) of the segment the executor is on,
    /// and that segment's geometry (measured on entering it).
    seg: usize,
    segment: Segment,
    seg_valid: bool,
    /// Path index of the last point reached.
    reached: u32,
    /// The last tick's step and its change (first and second differences
    /// of `x`), for the final step onto a stop.
    step: i64,
    step_change: i64,
}

impl Executor {
    /// Whether the tool has no motion left.
    #[inline]
    pub(super) fn at_rest(&self) -> bool {
        self.v == 0 && self.a == 0
    }

    /// Arc length from the path start (Q32 mm).
    #[inline]
    pub(super) fn x(&self) -> i64 {
        self.x
    }

    /// Index (in the lookahead's nodes) of the current segment.
    #[inline]
    pub(super) fn seg(&self) -> usize {
        self.seg
    }

    /// The lookahead dropped its oldest node.
    #[inline]
    pub(super) fn front_dropped(&mut self) {
        self.seg -= 1;
    }

    /// Move the current segment up to where the tool stands (at rest the
    /// ticks do not advance it: past repeated points too).
    pub(super) fn catch_up(&mut self, plan: &Plan) {
        let seg = plan.seg_of(self.seg, self.x);
        if seg != self.seg {
            self.seg = seg;
            self.seg_valid = false;
        }
    }

    /// Feed hold on/off.
    pub(super) fn set_hold(&mut self, on: bool) {
        self.hold = on;
    }

    /// Back to the start of a new path (at rest).
    pub(super) fn restart(&mut self) {
        self.x = 0;
        self.seg = 0;
        self.seg_valid = false;
        self.reached = 0;
        self.step = 0;
        self.step_change = 0;
    }

    /// The tick's output once the position is known.
    pub(super) fn output(&self, pos: Point3Mm, state: MotionState) -> Tick {
        Tick {
            pos,
            s_mm: fixed::types::I32F32::from_bits(self.x),
            speed: SpeedMmPerTick::from_bits(self.v),
            accel: AccelMmPerTick2::from_bits(self.a),
            point: self.reached,
            state,
        }
    }

    /// Whether the committed stop from `(x, v, a)` on segment `k` stays under
    /// the envelope (module docs, "Executor").
    fn safe(&self, plan: &Plan, k: usize, x: i64, v: i64, a: i64) -> bool {
        let lim = plan.lim();
        let (j, acc) = (lim.jerk, lim.accel);
        if plan.over_env(k, x, v) {
            return false;
        }
        // `|a|/J`, shared by the checks and the stop.
        let ta = div(a.saturating_abs(), j);
        // Still able to end the deceleration smoothly: v >= a²/2J.
        if a < 0 && v < mul(ta, -a) / 2 {
            return false;
        }
        let tpk = if a > 0 { ta } else { 0 };
        let vmax = v + mul(tpk, a.max(0)) / 2;
        if vmax > plan.cap_eff(k) {
            return false;
        }
        let b = Brake::with_ramp(v, a, ta, acc, j);
        let stop = Stop { b, x, k };
        // The stop's end: where it rests.
        let x_end = x.saturating_add(b.walk(b.total).2);
        match b.reaches(a, lim.envelope_decel) {
            None => self.points_ok(plan, &stop, x, x_end, vmax),
            Some(t_env) => {
                let (vb, _, xb) = b.walk(t_env);
                let xe = x.saturating_add(xb);
                if !self.points_ok(plan, &stop, x, xe, vmax) {
                    return false;
                }
                let tf = b.final_ramp_start().max(t_env);
                let (vf, _, xf) = b.walk(tf);
                if !self.points_ok(plan, &stop, x.saturating_add(xf), x_end, vf) {
                    return false;
                }
                !plan.over_env(plan.seg_of(k, xe), xe, vb)
            }
        }
    }

    /// The nodes the stop reaches between times `t0` and `t1` (its speed
    /// there at most `upper`) are all planned, and it passes each binding
    /// one no faster than its envelope (the others are covered by the next
    /// binding node or the end of the stretch: module docs).
    fn points_ok(&self, plan: &Plan, c: &Stop, x0: i64, x1: i64, upper: i64) -> bool {
        let tail = plan.finalized().saturating_sub(1);
        // The nodes before `x0` are not checked: where the stretch starts
        // ahead of the stop's start, skip to the first one at or past it
        // (found by bisection), unless the end of what is planned comes
        // first.
        let mut i = c.k + 1;
        if let Some(t) = plan.node(tail).filter(|_| x0 > c.x) {
            if i <= tail && t.s < x0 {
                if t.s > x1 {
                    return true;
                }
                return c.b.passes_at_most(t.s - c.x, 0);
            }
            i = plan.first_at_or_after(i, tail, x0);
        }
        while let Some(n) = plan.node(i) {
            if n.s > x1 {
                break;
            }
            if i >= tail {
                // Only a stop before (or on) the end of what is planned.
                return c.b.passes_at_most(n.s - c.x, 0);
            }
            if n.s >= x0 && n.binding {
                let limit = ld(n.env);
                if limit < upper && !c.b.passes_at_most(n.s - c.x, limit) {
                    return false;
                }
            }
            i += 1;
        }
        true
    }

    /// One tick of the profile: the jerk chosen, the state integrated, the
    /// segment and the last point reached updated.
    pub(super) fn advance(&mut self, plan: &Plan) -> MotionState {
        if plan.finalized() < 2 {
            return if plan.ended() && plan.finalized() >= 1 {
                MotionState::Done
            } else {
                MotionState::Idle
            };
        }
        let tail = plan.finalized() - 1;
        let s_tail = plan.node(tail).map_or(0, |n| n.s);
        let done = plan.ended() && tail + 1 == plan.len();
        if self.x >= s_tail && self.at_rest() {
            // At rest on the end of what is planned (which may be a run of
            // points at the same place): all of them are reached.
            self.reached = plan.front_index().wrapping_add(tail as u32);
            return if done {
                MotionState::Done
            } else {
                MotionState::Starved
            };
        }
        let k = self.seg;
        let (j, acc) = (plan.lim().jerk, plan.lim().accel);
        let mut next = None;
        // The committed stop, where it was built to decide on halvings.
        let mut stop = None;
        if !self.hold
            && s_tail - self.x <= self.v.max((j / 2).min(acc))
            && self.v <= plan.lim().creep
            && self.a.abs() <= j
            && self.last_step_ok(plan, s_tail - self.x)
        {
            // Within one tick at the current (creep) speed of the stop, or
            // at rest short of it by what a step from rest to rest may take
            // (its third differences reach twice the step: J·Ts³/2, as
            // `last_step_ok` checks; its second difference the step itself:
            // at most ρA·Ts²): step onto it.
            next = Some((s_tail, 0, 0));
        } else if !self.hold {
            // Near rest, finer moves let the tool creep up to a stop point.
            let slow = self.v <= 4 * plan.lim().creep;
            let jerks = [j, j / 8, j / 64, 0];
            for (c, &jerk) in jerks.iter().enumerate() {
                if (c == 1 || c == 2) && !slow {
                    continue;
                }
                next = self.candidate(plan, k, &step_phases(self.a, jerk, acc));
                if next.is_some() {
                    break;
                }
            }
            // Between the candidates: the end-of-tick acceleration halved
            // three times between the last safe one and the first unsafe,
            // so that at a high jerk limit (a tick's `J` larger than the
            // acceleration bound) the speed settles on a ceiling instead of
            // alternating between full acceleration and the committed stop.
            // Below holding the acceleration when nothing was safe; above
            // it when only that was. Only when a tick's jerk moves the
            // acceleration by more than an eighth of its bound: at lower
            // jerk limits the candidates are fine enough.
            //
            // Above the hold, while no halving has been safe, they go on up
            // to `HALVINGS_ABOVE_HOLD` times: otherwise the speed can stay
            // below a ceiling by up to an eighth of the bound's speed change
            // per tick, creeping towards it at the hold's acceleration for
            // a whole segment (and more so at a higher jerk limit, which
            // would make the cycle longer).
            //
            // At lower jerk limits, too, below the hold when the committed
            // stop ends within a tick's travel of the end of what is
            // planned: there the halvings bring the stop onto that point
            // instead of short of it, which would leave a creep of several
            // ticks (whose length varies with every limit).
            let fine = j > acc / 8;
            let hi_a = (self.a + j).min(acc);
            let lands_near = |stop: &mut Option<Brake>| {
                let b = stop.insert(Brake::new(self.v, self.a, acc, j));
                let end = self.x.saturating_add(b.distance());
                end >= s_tail.saturating_sub(self.v.max(1))
            };
            let (lo, hi, most) = match next {
                None if fine || lands_near(&mut stop) => ((self.a - j).max(-acc), self.a, HALVINGS),
                Some((_, _, a2)) if fine && a2 == self.a => (self.a, hi_a, HALVINGS_ABOVE_HOLD),
                _ => (0, 0, 0),
            };
            let (mut lo, mut hi) = (lo, hi);
            // Zero first where the range holds it: the halving's own points
            // need not include it, and then at a ceiling the acceleration
            // alternates between them from tick to tick instead of settling.
            let zero_first = lo < 0 && hi > 0;
            let mut safe = false;
            for h in 0..most + usize::from(zero_first) {
                if hi - lo <= 1 || (safe && h >= HALVINGS + usize::from(zero_first)) {
                    break;
                }
                let a_end = if h == 0 && zero_first {
                    0
                } else {
                    lo + (hi - lo) / 2
                };
                match self.candidate(plan, k, &ramp_phases(self.a, a_end, j)) {
                    Some(c) => {
                        next = Some(c);
                        lo = a_end;
                        safe = true;
                    }
                    None => hi = a_end,
                }
            }
            // Nothing safe, no halvings, and the acceleration within a
            // tick's jerk of zero: end the tick at zero acceleration if that
            // is safe. A tick's jerk steps the acceleration by `J·Ts`, so
            // from an acceleration off that grid zero is out of reach, and at
            // a ceiling the tool would hunt from tick to tick between a step
            // above zero and the stop's step below it.
            if next.is_none() && most == 0 && self.a != 0 && self.a.abs() <= j {
                next = self.candidate(plan, k, &ramp_phases(self.a, 0, j));
            }
        }
        // None safe (a phase change inside the tick, or a lower override),
        // or feed hold: follow the committed stop (jerk within ±J).
        let a_prev = self.a;
        let (x2, v2, a2) = next.unwrap_or_else(|| {
            let b = stop.unwrap_or_else(|| Brake::new(self.v, self.a, acc, j));
            let (v2, a2, dx) = b.walk(ONE);
            (self.x.saturating_add(dx.max(0)), v2, a2)
        });
        let x_new = x2.min(s_tail);
        let step = x_new - self.x;
        self.step_change = step - self.step;
        self.step = step;
        self.x = x_new;
        self.v = v2;
        self.a = a2;
        if self.v == 0 && self.a < 0 {
            // At rest: the deceleration ends. Stops are entered only from
            // v >= a²/2J, so what is left is rounding; it is released at
            // the jerk limit.
            self.a = (a_prev + j).min(0);
        }
        if self.x >= s_tail && a_prev.abs() <= j {
            // On the end of what is planned (stepped onto at creep speed, or
            // a stop landing on it): at rest. From a deceleration larger
            // than a tick's jerk that would break the jerk limit, so there
            // the stop's last tick keeps its speed and acceleration (the
            // position cannot pass the end) and comes to rest in the next.
            self.v = 0;
            self.a = 0;
        }
        self.catch_up(plan);
        let reached = if self.x >= s_tail { tail } else { self.seg };
        self.reached = plan.front_index().wrapping_add(reached as u32);
        if self.hold {
            MotionState::Holding
        } else if self.x >= s_tail && self.at_rest() {
            if done {
                MotionState::Done
            } else {
                MotionState::Starved
            }
        } else {
            MotionState::Moving
        }
    }

    /// The state after a tick of `phases` from segment `k`, if it moves
    /// forwards, passes the nodes it crosses within their envelope and is
    /// safe.
    #[inline(never)]
    fn candidate(
        &self,
        plan: &Plan,
        k: usize,
        phases: &[(i64, i64); 2],
    ) -> Option<(i64, i64, i64)> {
        let (v2, a2, dx) = integrate(self.v, self.a, phases, ONE);
        if dx < 0 {
            return None; // would reverse
        }
        let x2 = self.x.saturating_add(dx);
        (self.crossings_ok(plan, k, phases, v2, x2)
            && self.safe(plan, plan.seg_of(k, x2), x2, v2, a2))
        .then_some((x2, v2, a2))
    }

    /// Whether a last step of `d` onto a stop, then rest, keeps the third
    /// differences of the arc length (the discrete jerk: this step's, the
    /// next tick's and the one after) within the jerk limit.
    fn last_step_ok(&self, plan: &Plan, d: i64) -> bool {
        let j = plan.lim().jerk;
        let change = d - self.step;
        (change - self.step_change).abs() <= j && (d + change).abs() <= j && d <= j
    }

    /// Nodes crossed during a tick of `phases` (one jerk, held once the
    /// acceleration bound is reached): each is passed no faster than its
    /// envelope; the end of what is planned is not passed. The speed is at
    /// most `max(v, v2)`, or, at a negative jerk from `a > 0`, its peak
    /// `v + a²/2|j|`. A speed convex in time (jerk >= 0) is at most the
    /// limit on one interval; a concave one that starts under the limit and
    /// rises over it is taken as under it only before the first crossing
    /// (conservative).
    fn crossings_ok(&self, plan: &Plan, k: usize, phases: &[(i64, i64)], v2: i64, x2: i64) -> bool {
        let jerk = phases.first().map_or(0, |p| p.1);
        let mut vhi = self.v.max(v2);
        if jerk < 0 && self.a > 0 {
            let peak = mul(self.a, div(self.a, -jerk)) / 2;
            vhi = vhi.max(self.v.saturating_add(peak));
        }
        let mut i = k + 1;
        while let Some(n) = plan.node(i) {
            if n.s > x2 {
                break;
            }
            if i + 1 >= plan.finalized() {
                return false;
            }
            let limit = ld(n.env);
            if limit < vhi {
                // The speed is at most `limit` on one interval of the tick:
                // the node must be passed inside it. A speed starting on
                // the limit and rising is over it from the start (the
                // crossing at time zero is not among the roots).
                let mut t = [0i64; 4];
                let c = speed_crossings(self.v, self.a, phases, limit, &mut t);
                let rising = self.a > 0 || (self.a == 0 && jerk > 0);
                let under = self.v < limit || (self.v == limit && !rising);
                let (lo, hi) = if under {
                    if c == 0 && v2 > limit {
                        return false; // a crossing lost to rounding
                    }
                    (0, if c >= 1 { t[0] } else { ONE })
                } else if c >= 1 {
                    (t[0], if c >= 2 { t[1] } else { ONE })
                } else {
                    return false;
                };
                let d = n.s - self.x;
                if d < integrate(self.v, self.a, phases, lo).2
                    || d > integrate(self.v, self.a, phases, hi).2
                {
                    return false;
                }
            }
            i += 1;
        }
        true
    }

    /// The commanded position: node + direction × offset.
    pub(super) fn position(&mut self, plan: &Plan) -> Point3Mm {
        // Scalars, not whole-`Node` or whole-`Point3Mm` copies: those
        // compiled to the image's only `memmove` call (1.5 KB of library
        // code on the target).
        let Some(n) = plan.node(self.seg) else {
            return Point3Mm::ORIGIN;
        };
        let (p, n_s) = (n.pos.to_bits(), n.s);
        let Some(m) = plan.node(self.seg + 1) else {
            return Point3Mm::from_bits(p[0], p[1], p[2]);
        };
        let (q, m_s) = (m.pos.to_bits(), m.s);
        if !self.seg_valid {
            self.segment = Segment::between_bits(p, q).unwrap_or_default();
            self.seg_valid = true;
        }
        if self.x >= m_s {
            return Point3Mm::from_bits(q[0], q[1], q[2]);
        }
        self.segment.point_at(p, (self.x - n_s).max(0))
    }
}

/// How often the executor halves the range of a tick's end acceleration
/// between the last safe candidate and the first unsafe one.
const HALVINGS: usize = 3;

/// How often at most above a hold, while none of them has been safe.
const HALVINGS_ABOVE_HOLD: usize = 8;

/// A committed stop from arc length `x` on segment `k`.
struct Stop {
    b: Brake,
    x: i64,
    k: usize,
}

/// A tick of jerk `jerk` from acceleration `a`, holding once `±acc` is reached.
fn step_phases(a: i64, jerk: i64, acc: i64) -> [(i64, i64); 2] {
    if jerk == 0 {
        return [(ONE, 0), (0, 0)];
    }
    let bound = if jerk > 0 { acc } else { -acc };
    let room = bound - a;
    if (jerk > 0 && room <= 0) || (jerk < 0 && room >= 0) {
        return [(ONE, 0), (0, 0)];
    }
    let t = div(room, jerk);
    if t >= ONE {
        [(ONE, jerk), (0, 0)]
    } else {
        [(t, jerk), (ONE - t, 0)]
    }
}

/// A tick that ramps the acceleration from `a` to `a_end` at the jerk
/// limit, then holds it (`|a_end − a| <= jerk`; a linear ramp over the
/// whole tick otherwise). Reaching the end acceleration early changes the
/// speed least: settling onto a ceiling from `a > 0` costs `a²/2J` of speed
/// instead of a whole tick's `a·Ts/2`, which may not fit under it.
fn ramp_phases(a: i64, a_end: i64, jerk: i64) -> [(i64, i64); 2] {
    let d = a_end - a;
    let t = div(d.abs(), jerk.max(1));
    if d == 0 {
        [(ONE, 0), (0, 0)]
    } else if t >= ONE {
        [(ONE, d), (0, 0)]
    } else {
        [(t, d.signum() * jerk), (ONE - t, 0)]
    }
}
