//! [`Motion`]: the streaming planner and the per-tick executor.

use heapless::Deque;

use super::brake::{integrate, speed_crossings, Brake};
use super::config::{ConfigError, Limits, MotionConfig};
use super::q::{div, mul, reach, sqrt, ONE};
use crate::scheduler::ScheduledPoint;
use crate::units::{CurvaturePerMm, FeedMmPerMin, Point3Mm};

/// A point of the path with its scheduled feed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MotionPoint {
    /// Position, mm.
    pub pos: Point3Mm,
    /// Feed on the move ending at this point (the scheduler's), mm/min.
    pub feed: FeedMmPerMin,
    /// Path curvature at the point (for the chord-error bound), 1/mm.
    pub curvature: CurvaturePerMm,
}

impl From<&ScheduledPoint> for MotionPoint {
    fn from(p: &ScheduledPoint) -> Self {
        MotionPoint {
            pos: p.point.pos,
            feed: p.feed,
            curvature: p.curvature,
        }
    }
}

/// Why a point was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum MotionError {
    /// The buffer is full: push again after some ticks.
    Full,
    /// The path was ended; start a new one with [`Motion::restart`].
    PathEnded,
    /// Coordinates or feed out of range.
    BadPoint,
    /// [`Motion::restart`] while the tool is moving.
    Moving,
}

impl core::fmt::Display for MotionError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            MotionError::Full => "motion buffer full",
            MotionError::PathEnded => "path already ended",
            MotionError::BadPoint => "point out of range",
            MotionError::Moving => "cannot restart while moving",
        })
    }
}

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
    /// Tangential speed, mm/tick (raw Q32; see [`Motion::speed_mm_per_min`]).
    pub speed: i64,
    /// Tangential acceleration, mm/tick² (raw Q32).
    pub accel: i64,
    /// Index in the path (0 = its first point, every pushed point counts)
    /// of the last point reached.
    pub point: u32,
    /// State.
    pub state: MotionState,
}

/// What the planner derived for a buffered point (for reports and tests).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PlannedPoint {
    /// Position, mm.
    pub pos: Point3Mm,
    /// Arc length from the path start, mm.
    pub s_mm: fixed::types::I32F32,
    /// Length of the outgoing segment, mm.
    pub len_mm: fixed::types::I32F32,
    /// Speed ceiling at the point, mm/min.
    pub ceiling: FeedMmPerMin,
    /// Speed cap on the outgoing segment, mm/min.
    pub cap: FeedMmPerMin,
    /// Envelope, mm/min.
    pub envelope: FeedMmPerMin,
    /// Index in the path.
    pub index: u32,
}

/// A buffered point with what the planner derived for it (56 bytes: the
/// buffer is most of the planner's RAM).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Node {
    pos: Point3Mm,
    /// Arc length from the path start, mm (Q32).
    s: i64,
    /// Change of direction at this node per axis, `|d_out − d_in|` (Q14,
    /// rounded up).
    turn: [u16; 3],
    /// The envelope here is set by the node's own ceiling or an adjacent
    /// cap, not by the reach from the next node (module docs, "Executor").
    binding: bool,
    /// Programmed feed of the move ending here (before the override).
    feed: u32,
    /// Physical speed ceiling at the node: chord error, axis speeds of the
    /// adjacent moves and, once final, the direction changes near it.
    ceil: u32,
    /// Physical speed cap of the outgoing segment.
    cap: u32,
    /// Envelope `T` (module docs).
    env: u32,
}

/// Stored speeds (`feed`, `ceil`, `cap`, `env`): Q28 mm/tick in 32 bits,
/// rounded down (they are upper bounds).
fn st(v: i64) -> u32 {
    (v.max(0) >> 4).min(u32::MAX as i64) as u32
}

/// A stored speed in Q32.
fn ld(u: u32) -> i64 {
    (u as i64) << 4
}

/// The streaming velocity planner and interpolation executor for up to `N`
/// buffered points. See the [module documentation](super).
#[derive(Clone, Debug)]
pub struct Motion<const N: usize> {
    lim: Limits,
    nodes: Deque<Node, N>,
    /// Nodes (from the front) whose ceilings are final.
    finalized: usize,
    /// The path was ended: the newest node is the final stop.
    ended: bool,
    /// Direction of the newest segment (Q30), if any.
    last_dir: Option<[i32; 3]>,
    /// Feed override, Q16 (1.0 = 100 %).
    override_q16: i64,
    /// Executor: arc length, speed, acceleration (Q32, per-tick units).
    x: i64,
    v: i64,
    a: i64,
    hold: bool,
    /// Index (in `nodes`) of the segment the executor is on, and the
    /// direction of that segment (Q30; computed on entering it).
    seg: usize,
    seg_dir: [i32; 3],
    seg_dir_valid: bool,
    /// Path index of `nodes[0]`.
    front_index: u32,
    /// Path index of the last point reached.
    reached: u32,
    /// The last tick's step and its change (first and second differences
    /// of `x`), for the final step onto a stop.
    step: i64,
    step_change: i64,
    /// Arc length of the last node dropped to free a full buffer while
    /// still within the corner reach (`unstall`); `i64::MIN` for none.
    dropped_s: i64,
}

impl<const N: usize> Motion<N> {
    const VALID: () = assert!(
        N >= 4 && N < u16::MAX as usize,
        "Motion needs room for 4 to 65534 points"
    );

    /// A planner for the machine described by `config`.
    pub fn new(config: MotionConfig) -> Result<Self, ConfigError> {
        #[allow(clippy::let_unit_value)]
        let () = Self::VALID;
        let lim = config.compile()?;
        Ok(Motion {
            lim,
            nodes: Deque::new(),
            finalized: 0,
            ended: false,
            last_dir: None,
            override_q16: 1 << 16,
            x: 0,
            v: 0,
            a: 0,
            hold: false,
            seg: 0,
            seg_dir: [0; 3],
            seg_dir_valid: false,
            front_index: 0,
            reached: 0,
            step: 0,
            step_change: 0,
            dropped_s: i64::MIN,
        })
    }

    /// The finalized points still buffered, oldest first, with their
    /// effective ceilings and caps (override applied).
    pub fn planned(&self) -> impl Iterator<Item = PlannedPoint> + '_ {
        (0..self.finalized).filter_map(move |i| {
            let n = self.nodes.get(i)?;
            let len = self.nodes.get(i + 1).map_or(0, |m| m.s - n.s);
            Some(PlannedPoint {
                pos: n.pos,
                s_mm: fixed::types::I32F32::from_bits(n.s),
                len_mm: fixed::types::I32F32::from_bits(len),
                ceiling: self.speed_mm_per_min(self.ceil_eff(i)),
                cap: self.speed_mm_per_min(if i + 1 < self.finalized {
                    self.cap_eff(i)
                } else {
                    0
                }),
                envelope: self.speed_mm_per_min(ld(n.env)),
                index: self.front_index.wrapping_add(i as u32),
            })
        })
    }

    /// The tangential acceleration limit `ρ·min_a A_a`, mm/s².
    pub fn accel_limit_mm_s2(&self) -> fixed::types::I32F32 {
        let t = self.lim.tick_us as i128;
        let per_s2 = (self.lim.accel as i128 * 1_000_000_000_000)
            .checked_div(t * t)
            .unwrap_or(0);
        fixed::types::I32F32::from_bits(per_s2.clamp(0, i64::MAX as i128) as i64)
    }

    /// Points that can still be pushed.
    pub fn free(&self) -> usize {
        N - self.nodes.len()
    }

    /// Whether the executor has no motion left (idle, starved at rest, held
    /// at rest, or done).
    pub fn at_rest(&self) -> bool {
        self.v == 0 && self.a == 0
    }

    /// Convert a speed in mm/tick (raw Q32, as in [`Tick::speed`]) to mm/min.
    pub fn speed_mm_per_min(&self, speed: i64) -> FeedMmPerMin {
        let per_min = (speed as i128 * self.lim.tick_to_feed_q16 as i128) >> 16;
        FeedMmPerMin(fixed::types::I32F32::from_bits(
            per_min.clamp(0, i64::MAX as i128) as i64,
        ))
    }

    /// Start a new path where the tool is (at rest): what is buffered is
    /// dropped, and the new path's first point (index 0) is the tool's
    /// position, so the tool never jumps; the first pushed point is index 1
    /// (or merges into index 0 if it is the same position). Before any
    /// point was pushed, the next pushed point is where the tool is.
    pub fn restart(&mut self) -> Result<(), MotionError> {
        if !self.at_rest() {
            return Err(MotionError::Moving);
        }
        let here = (!self.nodes.is_empty()).then(|| self.position());
        self.nodes.clear();
        self.finalized = 0;
        self.ended = false;
        self.last_dir = None;
        self.x = 0;
        self.seg = 0;
        self.seg_dir_valid = false;
        self.front_index = 0;
        self.reached = 0;
        self.step = 0;
        self.step_change = 0;
        self.dropped_s = i64::MIN;
        if let Some(pos) = here {
            let _ = self.nodes.push_back(Node {
                pos,
                ceil: st(self.lim.creep),
                cap: u32::MAX,
                feed: u32::MAX,
                ..Node::default()
            });
        }
        Ok(())
    }

    /// Feed hold on/off: on, the tool decelerates (jerk-limited, within the
    /// acceleration limit) to rest on the path; off, it continues.
    pub fn set_hold(&mut self, on: bool) {
        self.hold = on;
    }

    /// Feed override, percent of the programmed feed (clamped to 1-1000;
    /// the feed stays within the configured maximum and every physical
    /// limit). Re-plans the envelope of the buffered points (`O(N)`, once).
    /// A lower override slows the tool at the acceleration limit.
    pub fn set_override(&mut self, percent: u16) {
        let p = percent.clamp(1, 1000) as i64;
        self.override_q16 = (p << 16) / 100;
        if self.finalized > 0 {
            self.rebuild_envelope();
        }
    }

    /// Add the next point. The first point of a path is where the tool is.
    pub fn push(&mut self, p: MotionPoint) -> Result<(), MotionError> {
        if self.ended {
            return Err(MotionError::PathEnded);
        }
        if !p.pos.within_limits() || !p.feed.within_limits() || p.curvature.0 < 0 {
            return Err(MotionError::BadPoint);
        }
        if self.nodes.is_full() {
            return Err(MotionError::Full);
        }
        let lim = &self.lim;
        let feed = self.to_tick_speed(p.feed).min(lim.feed_max);
        // Chord error: v·Ts <= 2·sqrt(2δ/κ − δ²).
        let kappa = p.curvature.0.to_bits();
        let mut own = i64::MAX;
        if kappa > 0 {
            let r = div(2 * lim.chord, kappa) - mul(lim.chord, lim.chord);
            if r > 0 {
                own = 2 * sqrt(r);
            }
        }
        let mut node = Node {
            pos: p.pos,
            feed: st(feed),
            ceil: st(own),
            cap: u32::MAX,
            ..Node::default()
        };
        if let Some(last) = self.nodes.back_mut() {
            let b = p.pos.to_bits();
            let l = last.pos.to_bits();
            let d = zip3(b, l, i64::saturating_sub);
            let Some((dir, len)) = unit(d) else {
                // A zero-length move: a node at the same place (the change
                // of direction is counted at the later one).
                node.s = last.s;
                node.ceil = node.ceil.min(last.ceil);
                last.cap = u32::MAX;
                last.turn = [0; 3];
                let _ = self.nodes.push_back(node); // not full (checked)
                self.finalize(false, false);
                return Ok(());
            };
            let seg = st(axis_cap(&lim.axis_speed, dir));
            last.cap = seg;
            last.ceil = last.ceil.min(seg);
            node.ceil = node.ceil.min(seg);
            node.s = last.s.saturating_add(len);
            if let Some(prev) = self.last_dir {
                last.turn = zip3(dir, prev, |d, p| {
                    let t = (d as i64 - p as i64).unsigned_abs(); // Q30
                    (t.div_ceil(1 << 16)).min(u16::MAX as u64) as u16 // Q14, up
                });
            }
            self.last_dir = Some(dir);
        }
        let _ = self.nodes.push_back(node); // not full (checked)
        self.finalize(false, false);
        Ok(())
    }

    /// The path ends at the last pushed point: plan the final stop there.
    pub fn end_path(&mut self) {
        self.ended = true;
        self.finalize(true, false);
    }

    fn to_tick_speed(&self, f: FeedMmPerMin) -> i64 {
        let v = (f.0.to_bits() as i128 * self.lim.feed_to_tick_q48 as i128) >> 48;
        v.clamp(0, i64::MAX as i128) as i64
    }

    /// A programmed feed with the override, within the feed limit.
    fn fed(&self, feed: u32) -> i64 {
        ((ld(feed) * self.override_q16) >> 16).min(self.lim.feed_max)
    }

    /// The effective ceiling at node `i`: physical, and the programmed
    /// feeds of both adjacent moves.
    fn ceil_eff(&self, i: usize) -> i64 {
        let Some(n) = self.nodes.get(i) else {
            return 0;
        };
        let mut c = ld(n.ceil);
        if !self.is_path_start(i) {
            c = c.min(self.fed(n.feed));
        }
        if let Some(m) = self.nodes.get(i + 1) {
            c = c.min(self.fed(m.feed));
        }
        c
    }

    /// The effective cap of segment `i` (to node `i + 1`).
    fn cap_eff(&self, i: usize) -> i64 {
        match (self.nodes.get(i), self.nodes.get(i + 1)) {
            (Some(n), Some(m)) => ld(n.cap).min(self.fed(m.feed)),
            _ => 0,
        }
    }

    /// Whether node `i` is the first point of the path (the tool starts
    /// there at rest).
    fn is_path_start(&self, i: usize) -> bool {
        i == 0 && self.nodes.get(0).is_some_and(|n| n.s == 0)
    }

    /// Fix the ceilings of the nodes whose corner window is complete, extend
    /// the envelope over them. `force`: fix the next one even if its window
    /// is not complete (`unstall`), no faster than a tick's travel short of
    /// the newest node, whose turn is not known yet (vertices farther than
    /// a tick's travel do not count: module docs, "Ceilings").
    fn finalize(&mut self, all: bool, force: bool) {
        let reach = self.lim.reach;
        loop {
            let i = self.finalized;
            let len = self.nodes.len();
            if i >= len {
                break;
            }
            let newest_s = self.nodes.back().map_or(0, |n| n.s);
            let Some(si) = self.nodes.get(i).map(|n| n.s) else {
                break;
            };
            // The window ahead must hold nodes whose turn is known (all but
            // the newest).
            let forced = force && !all && i + 1 < len;
            if !all && !forced && newest_s <= si.saturating_add(reach) {
                break;
            }
            let last_of_path = all && i + 1 == len;
            let ceil = if self.is_path_start(i) || last_of_path {
                self.lim.creep
            } else {
                self.nodes
                    .get(i)
                    .map_or(0, |n| ld(n.ceil))
                    .min(self.turn_limit(i))
                    .min(if forced { newest_s - si } else { i64::MAX })
                    // Nor does a vertex dropped within the reach behind.
                    .min(si.saturating_sub(self.dropped_s))
                    .max(self.lim.corner_creep)
            };
            if let Some(n) = self.nodes.get_mut(i) {
                n.ceil = st(ceil);
                if last_of_path {
                    n.cap = 0;
                }
            }
            if i > 0 {
                self.set_cap(i - 1);
            }
            self.finalized = i + 1;
            self.extend_envelope(i);
            if forced {
                break;
            }
        }
    }

    /// A full buffer whose unfinalized points all lie within the corner
    /// reach of the next one never completes a corner window: with the tool
    /// at rest on the end of what is planned, fix the next point anyway
    /// (`finalize`, forced), or, when only the newest is left, drop the
    /// oldest point behind the tool to make room (the ceilings fixed after
    /// that stay a tick's travel short of it). The tool then moves on,
    /// stopping at each point, instead of waiting forever.
    fn unstall(&mut self) {
        let tail_s = self
            .finalized
            .checked_sub(1)
            .and_then(|t| self.nodes.get(t))
            .map_or(0, |n| n.s);
        if !self.nodes.is_full() || self.ended || !self.at_rest() || self.x < tail_s {
            return;
        }
        if self.finalized + 1 < self.nodes.len() {
            self.finalize(false, true);
            return;
        }
        // (At rest the segment is not advanced: past repeated points too.)
        let seg = self.seg_of(self.seg, self.x);
        if seg != self.seg {
            self.seg = seg;
            self.seg_dir_valid = false;
        }
        if self.seg > 0 {
            if let Some(n) = self.nodes.pop_front() {
                self.dropped_s = n.s;
                self.seg -= 1;
                self.finalized -= 1;
                self.front_index = self.front_index.wrapping_add(1);
            }
        }
    }

    /// The largest speed at node `i` for which the direction changes near it
    /// keep every axis within its corner share `(1 − ρ)·A_a` (module docs,
    /// "Ceilings"): with `U` the travel of a tick (the speed) and `δ_k` each
    /// vertex's distance from node `i`,
    /// `Σ_k |Δd_k,a|·(U − δ_k)⁺ <= (1 − ρ)·A_a·Ts²`. The left side is
    /// piecewise linear and increasing in `U`; the vertices are taken in
    /// order of distance while the bound still holds at the next one, then
    /// `U` is solved on the last piece.
    fn turn_limit(&self, i: usize) -> i64 {
        let Some(n) = self.nodes.get(i) else {
            return 0;
        };
        let lim = &self.lim;
        // Per axis: S = Σ|Δd| (Q14), W = Σ|Δd|·δ (Q32 mm) over the vertices
        // taken; the bound at travel U is S·U − W.
        let mut sum = n.turn.map(i64::from);
        let mut weighted = [0i64; 3];
        // |d_a| of the outgoing segment (Q14, rounded up; 1 if it has no
        // length): every segment the stencil reaches has
        // |d_a| <= out_a + S_a (its direction is the outgoing one plus the
        // direction changes in between).
        let out = match self.nodes.get(i + 1) {
            Some(m) if m.s > n.s => {
                let (p, q) = (n.pos.to_bits(), m.pos.to_bits());
                let len = (m.s - n.s) as u64;
                // In 32 bits (the hardware divide): the length scaled to at
                // most 2^17, each component rounded up, the length down.
                let k = (64 - len.leading_zeros()).saturating_sub(17);
                let l32 = (len >> k) as u32;
                zip3(p, q, |p, q| {
                    let c = (q.saturating_sub(p).unsigned_abs() >> k).min(1 << 17) as u32 + 1;
                    i64::from((c << 14).checked_div(l32).unwrap_or(1 << 14)) + 1
                })
            }
            _ => [1 << 14; 3],
        };
        let (mut left, mut right) = (i.checked_sub(1), i + 1);
        loop {
            // The nearer of the next vertices on either side, within reach.
            let dl = left
                .and_then(|l| self.nodes.get(l))
                .map(|m| n.s - m.s)
                .filter(|&d| d <= lim.reach);
            let dr = self
                .nodes
                .get(right)
                .map(|m| m.s - n.s)
                .filter(|&d| d <= lim.reach);
            let (d, from_left) = match (dl, dr) {
                (Some(a), Some(b)) if a <= b => (a, true),
                (Some(a), None) => (a, true),
                (_, Some(b)) => (b, false),
                (None, None) => break,
            };
            // At travel U = d the next vertex starts to count: stop if the
            // bound is already broken there (the solution lies before it).
            // (The share is computed only where the demand exceeds its
            // least value, the fixed `(1 − ρ)·A_a`.)
            let broken = zip3(sum, weighted, |s, w| {
                ((s as i128 * d as i128) >> 14) - w as i128
            })
            .iter()
            .zip(lim.corner_accel.iter().zip(lim.axis_accel.iter()))
            .zip(sum.iter().zip(out.iter()))
            .any(|((&need, (&c, &a)), (&s, &o))| {
                need > c as i128 && need > axis_share(lim.accel, a, c, o, s) as i128
            });
            if broken {
                break;
            }
            let m = if from_left {
                let l = left.unwrap_or(0);
                left = l.checked_sub(1);
                self.nodes.get(l)
            } else {
                right += 1;
                self.nodes.get(right - 1)
            };
            if let Some(m) = m {
                for ((s, w), &t) in sum.iter_mut().zip(weighted.iter_mut()).zip(m.turn.iter()) {
                    *s += i64::from(t);
                    *w = w.saturating_add(((i64::from(t) as i128 * d as i128) >> 14) as i64);
                }
            }
        }
        // U = (B + W) / S on the last piece, the least over the axes.
        let mut u = i64::MAX;
        let share = corner_share(lim, out, sum);
        for ((&s, &w), &c) in sum.iter().zip(weighted.iter()).zip(share.iter()) {
            if s > 0 {
                u = u.min(div(c.saturating_add(w), s << 18)); // Σ Q14 → Q32
            }
        }
        u
    }

    /// The cap of the segment from node `i` to `i + 1` (both ceilings final).
    fn set_cap(&mut self, i: usize) {
        let (Some(a), Some(b)) = (self.nodes.get(i).copied(), self.nodes.get(i + 1).copied())
        else {
            return;
        };
        let mut c = ld(a.cap);
        if b.s - a.s < self.lim.reach {
            // A short segment lies inside its end points' corner reach.
            if !self.is_path_start(i) {
                c = c.min(ld(a.ceil));
            }
            if !(self.ended && i + 2 == self.nodes.len()) {
                c = c.min(ld(b.ceil));
            }
        }
        if let Some(n) = self.nodes.get_mut(i) {
            n.cap = st(c.max(self.lim.creep));
        }
    }

    /// `√(T² + 2·D_env·d)`: the envelope a distance `d` before a point of
    /// envelope `T`.
    fn reach_from(&self, t: i64, d: i64) -> i64 {
        reach(t, self.lim.envelope_decel, d)
    }

    /// The envelope at node `i` from its own limits and node `i + 1`'s
    /// (if final): `(T, binding)`.
    fn envelope_of(&self, i: usize) -> (i64, bool) {
        let Some(n) = self.nodes.get(i) else {
            return (0, true);
        };
        let mut own = self.ceil_eff(i);
        if i > 0 {
            own = own.min(self.cap_eff(i - 1));
        }
        if i + 1 < self.finalized {
            own = own.min(self.cap_eff(i));
            if let Some(m) = self.nodes.get(i + 1) {
                let r = self.reach_from(ld(m.env), m.s - n.s);
                return (own.min(r), own < r);
            }
        }
        (own, true)
    }

    /// Node `f` was finalized: set its envelope and lower the envelope
    /// backwards while it changes (typically a few nodes; `N` at most).
    fn extend_envelope(&mut self, f: usize) {
        let mut i = f;
        loop {
            let (t, binding) = self.envelope_of(i);
            let Some(n) = self.nodes.get_mut(i) else {
                break;
            };
            let changed = n.env != st(t) || n.binding != binding;
            n.env = st(t);
            n.binding = binding;
            if i == 0 || (!changed && i + 1 < f) {
                break;
            }
            i -= 1;
        }
    }

    /// The envelope of every finalized node, from the tail back (after an
    /// override change).
    fn rebuild_envelope(&mut self) {
        let mut i = self.finalized;
        while i > 0 {
            i -= 1;
            let (t, binding) = self.envelope_of(i);
            if let Some(n) = self.nodes.get_mut(i) {
                n.env = st(t);
                n.binding = binding;
            }
        }
    }

    /// The envelope at arc length `x` on segment `k`: under the segment's
    /// cap, within reach of the next node's envelope, and of a stop at the
    /// end of what is planned.
    fn env_at(&self, k: usize, x: i64) -> i64 {
        if k + 1 >= self.finalized {
            return 0;
        }
        let (Some(next), Some(tail)) = (self.nodes.get(k + 1), self.nodes.get(self.finalized - 1))
        else {
            return 0;
        };
        self.cap_eff(k)
            .min(self.reach_from(ld(next.env), next.s - x))
            .min(self.reach_from(self.lim.creep, tail.s - x))
    }

    /// Segment index (in `nodes`) containing arc length `x`, searching from `from`.
    fn seg_of(&self, from: usize, x: i64) -> usize {
        let mut k = from;
        while k + 1 < self.finalized && self.nodes.get(k + 1).is_some_and(|n| n.s <= x) {
            k += 1;
        }
        k
    }

    /// Whether the committed stop from `(x, v, a)` on segment `k` stays under
    /// the envelope (module docs, "Executor").
    fn safe(&self, k: usize, x: i64, v: i64, a: i64) -> bool {
        let lim = &self.lim;
        let (j, acc) = (lim.jerk, lim.accel);
        if v > self.env_at(k, x) {
            return false;
        }
        // Still able to end the deceleration smoothly: v >= a²/2J.
        if a < 0 && v < mul(div(-a, j), -a) / 2 {
            return false;
        }
        let tpk = if a > 0 { div(a, j) } else { 0 };
        let vmax = v + mul(tpk, a.max(0)) / 2;
        if vmax > self.cap_eff(k) {
            return false;
        }
        let b = Brake::new(v, a, acc, j);
        let stop = Stop { b, x, k };
        match b.reaches(a, lim.envelope_decel) {
            None => self.points_ok(&stop, 0, b.total, vmax),
            Some(t_env) => {
                if !self.points_ok(&stop, 0, t_env, vmax) {
                    return false;
                }
                let tf = b.final_ramp_start().max(t_env);
                let (vf, _, _) = b.walk(tf);
                if !self.points_ok(&stop, tf, b.total, vf) {
                    return false;
                }
                let (vb, _, xb) = b.walk(t_env);
                let xe = x.saturating_add(xb);
                vb <= self.env_at(self.seg_of(k, xe), xe)
            }
        }
    }

    /// The nodes the stop reaches between times `t0` and `t1` (its speed
    /// there at most `upper`) are all planned, and it passes each binding
    /// one no faster than its envelope (the others are covered by the next
    /// binding node or the end of the stretch: module docs).
    fn points_ok(&self, c: &Stop, t0: i64, t1: i64, upper: i64) -> bool {
        let x0 = if t0 > 0 {
            c.x.saturating_add(c.b.walk(t0).2)
        } else {
            c.x
        };
        let x1 = c.x.saturating_add(c.b.walk(t1).2);
        let tail = self.finalized.saturating_sub(1);
        let mut i = c.k + 1;
        while let Some(n) = self.nodes.get(i) {
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

    /// One interpolation tick.
    pub fn tick(&mut self) -> Tick {
        let state = self.advance();
        self.drop_passed();
        let pos = self.position();
        Tick {
            pos,
            s_mm: fixed::types::I32F32::from_bits(self.x),
            speed: self.v,
            accel: self.a,
            point: self.reached,
            state,
        }
    }

    fn advance(&mut self) -> MotionState {
        self.unstall();
        if self.finalized < 2 {
            return if self.ended && self.finalized >= 1 {
                MotionState::Done
            } else {
                MotionState::Idle
            };
        }
        let tail = self.finalized - 1;
        let s_tail = self.nodes.get(tail).map_or(0, |n| n.s);
        let done = self.ended && tail + 1 == self.nodes.len();
        if self.x >= s_tail && self.at_rest() {
            // At rest on the end of what is planned (which may be a run of
            // points at the same place): all of them are reached.
            self.reached = self.front_index.wrapping_add(tail as u32);
            return if done {
                MotionState::Done
            } else {
                MotionState::Starved
            };
        }
        let k = self.seg;
        let (j, acc) = (self.lim.jerk, self.lim.accel);
        let mut next = None;
        if !self.hold
            && s_tail - self.x <= self.v.max(j / 16)
            && self.v <= self.lim.creep
            && self.a.abs() <= j
            && self.last_step_ok(s_tail - self.x)
        {
            // Within one tick at the current (creep) speed of the stop, or
            // J·Ts³/16 short of it at rest: step onto it.
            next = Some((s_tail, 0, 0));
        } else if !self.hold {
            // Near rest, finer moves let the tool creep up to a stop point.
            let slow = self.v <= 4 * self.lim.creep;
            let jerks = [j, j / 8, j / 64, 0];
            for (c, &jerk) in jerks.iter().enumerate() {
                if (c == 1 || c == 2) && !slow {
                    continue;
                }
                next = self.candidate(k, &step_phases(self.a, jerk, acc));
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
            let hi_a = (self.a + j).min(acc);
            let (lo, hi) = match next {
                _ if j <= acc / 8 => (0, 0),
                None => ((self.a - j).max(-acc), self.a),
                Some((_, _, a2)) if a2 == self.a => (self.a, hi_a),
                _ => (0, 0),
            };
            let (mut lo, mut hi) = (lo, hi);
            // Zero first where the range holds it: the halving's own points
            // need not include it, and then at a ceiling the acceleration
            // alternates between them from tick to tick instead of settling.
            let zero_first = lo < 0 && hi > 0;
            for h in 0..HALVINGS + usize::from(zero_first) {
                if hi - lo <= 1 {
                    break;
                }
                let a_end = if h == 0 && zero_first {
                    0
                } else {
                    lo + (hi - lo) / 2
                };
                match self.candidate(k, &ramp_phases(self.a, a_end, j)) {
                    Some(c) => {
                        next = Some(c);
                        lo = a_end;
                    }
                    None => hi = a_end,
                }
            }
        }
        // None safe (a phase change inside the tick, or a lower override),
        // or feed hold: follow the committed stop (jerk within ±J).
        let a_prev = self.a;
        let (x2, v2, a2) = next.unwrap_or_else(|| {
            let b = Brake::new(self.v, self.a, acc, j);
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
        if self.x >= s_tail {
            // On the end of what is planned (stepped onto at creep speed).
            self.v = 0;
            self.a = 0;
        }
        let seg = self.seg_of(self.seg, self.x);
        if seg != self.seg {
            self.seg = seg;
            self.seg_dir_valid = false;
        }
        let reached = if self.x >= s_tail { tail } else { seg };
        self.reached = self.front_index.wrapping_add(reached as u32);
        if self.hold {
            MotionState::Holding
        } else if self.x >= s_tail {
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
    fn candidate(&self, k: usize, phases: &[(i64, i64); 2]) -> Option<(i64, i64, i64)> {
        let (v2, a2, dx) = integrate(self.v, self.a, phases, ONE);
        if dx < 0 {
            return None; // would reverse
        }
        let x2 = self.x.saturating_add(dx);
        (self.crossings_ok(k, phases, v2, x2) && self.safe(self.seg_of(k, x2), x2, v2, a2))
            .then_some((x2, v2, a2))
    }

    /// Whether a last step of `d` onto a stop, then rest, keeps the third
    /// differences of the arc length (the discrete jerk: this step's, the
    /// next tick's and the one after) within the jerk limit.
    fn last_step_ok(&self, d: i64) -> bool {
        let j = self.lim.jerk;
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
    fn crossings_ok(&self, k: usize, phases: &[(i64, i64)], v2: i64, x2: i64) -> bool {
        let jerk = phases.first().map_or(0, |p| p.1);
        let mut vhi = self.v.max(v2);
        if jerk < 0 && self.a > 0 {
            let peak = mul(self.a, div(self.a, -jerk)) / 2;
            vhi = vhi.max(self.v.saturating_add(peak));
        }
        let mut i = k + 1;
        while let Some(n) = self.nodes.get(i) {
            if n.s > x2 {
                break;
            }
            if i + 1 >= self.finalized {
                return false;
            }
            let limit = ld(n.env);
            if limit < vhi {
                // The speed is at most `limit` on one interval of the tick:
                // the node must be passed inside it.
                let mut t = [0i64; 4];
                let c = speed_crossings(self.v, self.a, phases, limit, &mut t);
                let (lo, hi) = if self.v <= limit {
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

    /// Drop nodes more than the corner reach behind the executor.
    fn drop_passed(&mut self) {
        while self.seg > 0 && self.finalized > 2 {
            let Some(second) = self.nodes.get(1) else {
                break;
            };
            if second.s >= self.x.saturating_sub(self.lim.reach) {
                break;
            }
            let _ = self.nodes.pop_front();
            self.seg -= 1;
            self.finalized -= 1;
            self.front_index = self.front_index.wrapping_add(1);
        }
    }

    /// The commanded position: node + direction × offset.
    fn position(&mut self) -> Point3Mm {
        // Scalars, not whole-`Node` or whole-`Point3Mm` copies: those
        // compiled to the image's only `memmove` call (1.5 KB of library
        // code on the target).
        let Some(n) = self.nodes.get(self.seg) else {
            return Point3Mm::ORIGIN;
        };
        let (p, n_s) = (n.pos.to_bits(), n.s);
        let Some(m) = self.nodes.get(self.seg + 1) else {
            return Point3Mm::from_bits(p[0], p[1], p[2]);
        };
        let (q, m_s) = (m.pos.to_bits(), m.s);
        if !self.seg_dir_valid {
            self.seg_dir = unit(zip3(q, p, i64::saturating_sub)).map_or([0; 3], |(d, _)| d);
            self.seg_dir_valid = true;
        }
        if self.x >= m_s {
            return Point3Mm::from_bits(q[0], q[1], q[2]);
        }
        let off = (self.x - n_s).max(0);
        let dir = self.seg_dir;
        let [x, y, z] = zip3(p, dir, |p, d| {
            p.saturating_add(((d as i128 * off as i128) >> 30) as i64)
        });
        Point3Mm::from_bits(x, y, z)
    }
}

/// How often the executor halves the range of a tick's end acceleration
/// between the last safe candidate and the first unsafe one.
const HALVINGS: usize = 3;

/// A committed stop from arc length `x` on segment `k`.
struct Stop {
    b: Brake,
    x: i64,
    k: usize,
}

/// `[f(a0, b0), f(a1, b1), f(a2, b2)]`, without indexing (no bounds checks
/// left for the panic-free link check).
#[inline]
fn zip3<A: Copy, B: Copy, C>(a: [A; 3], b: [B; 3], mut f: impl FnMut(A, B) -> C) -> [C; 3] {
    let [a0, a1, a2] = a;
    let [b0, b1, b2] = b;
    [f(a0, b0), f(a1, b1), f(a2, b2)]
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

/// What each axis leaves for direction changes, `A_a − ρ·min A·τ_a`, with
/// `τ_a = min(1, out_a + sum_a)` (both Q14) bounding `|d_a|` of every
/// segment in the stencil: the tangential part of the second difference
/// on axis `a` is at most the executor's `ρ·min A` (near vertices) times
/// `|d_a|`. At least the fixed share `(1 − ρ)·A_a`.
fn corner_share(lim: &Limits, out: [i64; 3], sum: [i64; 3]) -> [i64; 3] {
    let [o0, o1, o2] = out;
    let [s0, s1, s2] = sum;
    let [a0, a1, a2] = lim.axis_accel;
    let [c0, c1, c2] = lim.corner_accel;
    [
        axis_share(lim.accel, a0, c0, o0, s0),
        axis_share(lim.accel, a1, c1, o1, s1),
        axis_share(lim.accel, a2, c2, o2, s2),
    ]
}

/// One axis of [`corner_share`]: `max(A_a − ρ·min A·τ_a, (1 − ρ)·A_a)`.
#[inline]
fn axis_share(tangential: i64, axis: i64, fixed: i64, out: i64, sum: i64) -> i64 {
    // `tangential` < 2^46 (at most 10^6 mm/s² over a 100 ms tick) and
    // τ <= 2^14 (Q14): the product fits 64 bits.
    let tau = out.saturating_add(sum).min(1 << 14);
    (axis - ((tangential * tau) >> 14)).max(fixed)
}

/// The speed allowed by per-axis limits along direction `d` (Q30 unit).
fn axis_cap(axis: &[i64; 3], d: [i32; 3]) -> i64 {
    let mut c = i64::MAX;
    for (&v, &dk) in axis.iter().zip(d.iter()) {
        let comp = (dk as i64).unsigned_abs() as i64;
        if comp > 0 {
            // v·|d_k| <= V_k  ⇒  v <= V_k / |d_k|, |d_k| in Q30.
            c = c.min(div(v, comp << 2));
        }
    }
    c
}

/// Unit vector (Q30) and length (Q32) of a raw I32F32 difference; `None`
/// for zero.
fn unit(d: [i64; 3]) -> Option<([i32; 3], i64)> {
    let m = d.iter().map(|c| c.unsigned_abs()).max()?;
    if m == 0 {
        return None;
    }
    // Scale so components fit 31 bits, length via the soft float.
    let shift = (64 - m.leading_zeros() as i32 - 30).max(0);
    let n = d.map(|c| c >> shift);
    let sq: u64 = n.iter().map(|&c| (c * c) as u64).sum();
    let len_scaled = crate::softfloat::Sf::from_u64(sq).sqrt();
    let len = len_scaled.scale2(shift).to_i64_scaled(0);
    let dir = n.map(|c| {
        let q = crate::softfloat::Sf::from_u64(c.unsigned_abs())
            .div(len_scaled)
            .map_or(0, |q| q.to_i64_scaled(30).min(1 << 30));
        (if c < 0 { -q } else { q }) as i32
    });
    Some((dir, len))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_node_is_56_bytes() {
        // The buffer is most of the planner's RAM (firmware budget).
        assert_eq!(core::mem::size_of::<Node>(), 56);
    }
}
