//! The lookahead stage: the buffer of points, their speed ceilings and the
//! segments' caps, and the backward envelope over them (module docs of
//! [`super`]: "Ceilings", "Envelope").
//!
//! Input: [`MotionPoint`]s (position, scheduled feed, curvature), one
//! [`Segment`] measured per move. Output, read by the executor: for every
//! finalized node its arc length, envelope and whether the envelope binds
//! there, and [`Lookahead::over_env`] between nodes.
//!
//! Invariants:
//! - the nodes `0..finalized` have final ceilings (their corner window is
//!   complete) and an envelope from which every later ceiling, and a stop at
//!   the end of what is finalized, is reachable with deceleration `D_env`;
//! - stored speeds are upper bounds (rounded down to Q28);
//! - this stage only adds nodes at the back and recomputes envelopes; the
//!   executor's progress reaches it only through [`Lookahead::drop_front_behind`].
//!
//! The counterpart of Grbl's `planner.c` (its block buffer and reverse
//! pass); the corner model is this planner's own (module docs of [`super`]).

use core::fmt;

use heapless::deque::DequeInner;
use heapless::vec::{OwnedVecStorage, VecStorage, ViewVecStorage};

use super::config::Limits;
use super::q::{div, exceeds_reach, mul, reach, sqrt, surely_below_reach, ONE};
use crate::scheduler::ScheduledPoint;
use crate::segment::{zip3, Segment};
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
    /// The path was ended; start a new one with [`Motion::restart`](super::Motion::restart).
    PathEnded,
    /// Coordinates or feed out of range.
    BadPoint,
    /// [`Motion::restart`](super::Motion::restart) while the tool is moving.
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
pub(super) struct Node {
    pub(super) pos: Point3Mm,
    /// Arc length from the path start, mm (Q32).
    pub(super) s: i64,
    /// Change of direction at this node per axis, `|d_out − d_in|` (Q14,
    /// rounded up).
    turn: [u16; 3],
    /// The envelope here is set by the node's own ceiling or an adjacent
    /// cap, not by the reach from the next node (module docs, "Executor").
    pub(super) binding: bool,
    /// Programmed feed of the move ending here (before the override).
    feed: u32,
    /// Physical speed ceiling at the node: chord error, axis speeds of the
    /// adjacent moves and, once final, the direction changes near it.
    ceil: u32,
    /// Physical speed cap of the outgoing segment.
    cap: u32,
    /// Envelope `T` (module docs).
    pub(super) env: u32,
}

/// Stored speeds (`feed`, `ceil`, `cap`, `env`): Q28 mm/tick in 32 bits,
/// rounded down (they are upper bounds).
fn st(v: i64) -> u32 {
    (v.max(0) >> 4).min(u32::MAX as i64) as u32
}

/// A stored speed in Q32.
pub(super) fn ld(u: u32) -> i64 {
    (u as i64) << 4
}

/// The lookahead buffer with its points' ceilings, caps and envelope,
/// over any buffer size `S` (a [`Buffer`] of `N` points, read and planned
/// as a [`Plan`], its size a run-time value: the stage's code is compiled
/// once, in this crate, whatever `N` the caller picks).
pub(super) struct Lookahead<S: VecStorage<Node> + ?Sized> {
    lim: Limits,
    /// Nodes (from the front) whose ceilings are final.
    finalized: usize,
    /// The path was ended: the newest node is the final stop.
    ended: bool,
    /// Direction of the newest segment (Q30), if any.
    last_dir: Option<[i32; 3]>,
    /// Feed override, Q16 (1.0 = 100 %).
    override_q16: i64,
    /// Path index of `nodes[0]`.
    front_index: u32,
    /// Arc length of the last node dropped to free a full buffer while
    /// still within the corner reach ([`Lookahead::stalled`]); `i64::MIN`
    /// for none.
    dropped_s: i64,
    /// The points, oldest first (last: the only field whose size varies).
    nodes: DequeInner<Node, S>,
}

/// A lookahead of up to `N` points (what [`super::Motion`] holds).
pub(super) type Buffer<const N: usize> = Lookahead<OwnedVecStorage<Node, N>>;

/// A lookahead of any size, as the stages read and plan it.
pub(super) type Plan = Lookahead<ViewVecStorage<Node>>;

impl<const N: usize> Buffer<N> {
    /// An empty buffer for the compiled limits.
    pub(super) fn new(lim: Limits) -> Self {
        Lookahead {
            lim,
            finalized: 0,
            ended: false,
            last_dir: None,
            override_q16: 1 << 16,
            front_index: 0,
            dropped_s: i64::MIN,
            nodes: DequeInner::new(),
        }
    }

    /// The buffer with its size erased.
    #[inline]
    pub(super) fn plan(&self) -> &Plan {
        self
    }

    /// The buffer with its size erased, to plan.
    #[inline]
    pub(super) fn plan_mut(&mut self) -> &mut Plan {
        self
    }
}

impl<const N: usize> Clone for Buffer<N> {
    fn clone(&self) -> Self {
        Lookahead {
            lim: self.lim,
            finalized: self.finalized,
            ended: self.ended,
            last_dir: self.last_dir,
            override_q16: self.override_q16,
            front_index: self.front_index,
            dropped_s: self.dropped_s,
            nodes: self.nodes.clone(),
        }
    }
}

impl<S: VecStorage<Node> + ?Sized> fmt::Debug for Lookahead<S> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Lookahead")
            .field("lim", &self.lim)
            .field("finalized", &self.finalized)
            .field("ended", &self.ended)
            .field("last_dir", &self.last_dir)
            .field("override_q16", &self.override_q16)
            .field("front_index", &self.front_index)
            .field("dropped_s", &self.dropped_s)
            .field("nodes", &&self.nodes)
            .finish()
    }
}

impl Plan {
    /// The compiled limits (configuration, fixed for the planner's life).
    #[inline]
    pub(super) fn lim(&self) -> &Limits {
        &self.lim
    }

    /// Node `i` (0 = the oldest buffered).
    #[inline]
    pub(super) fn node(&self, i: usize) -> Option<&Node> {
        self.nodes.get(i)
    }

    /// Buffered nodes.
    #[inline]
    pub(super) fn len(&self) -> usize {
        self.nodes.storage_len()
    }

    /// Nodes (from the front) whose ceilings and envelope are final.
    #[inline]
    pub(super) fn finalized(&self) -> usize {
        self.finalized
    }

    /// Whether the path was ended.
    #[inline]
    pub(super) fn ended(&self) -> bool {
        self.ended
    }

    /// Path index of node 0.
    #[inline]
    pub(super) fn front_index(&self) -> u32 {
        self.front_index
    }

    /// Points that can still be pushed.
    pub(super) fn free(&self) -> usize {
        self.nodes.storage_capacity() - self.nodes.storage_len()
    }

    /// The finalized points still buffered, oldest first, with their
    /// effective ceilings and caps (override applied).
    pub(super) fn planned(&self) -> impl Iterator<Item = PlannedPoint> + '_ {
        (0..self.finalized).filter_map(move |i| {
            let n = self.nodes.get(i)?;
            let len = self.nodes.get(i + 1).map_or(0, |m| m.s - n.s);
            Some(PlannedPoint {
                pos: n.pos,
                s_mm: fixed::types::I32F32::from_bits(n.s),
                len_mm: fixed::types::I32F32::from_bits(len),
                ceiling: self.feed_of(self.ceil_eff(i)),
                cap: self.feed_of(if i + 1 < self.finalized {
                    self.cap_eff(i)
                } else {
                    0
                }),
                envelope: self.feed_of(ld(n.env)),
                index: self.front_index.wrapping_add(i as u32),
            })
        })
    }

    /// A speed in mm/tick (Q32) in mm/min.
    pub(super) fn feed_of(&self, speed: i64) -> FeedMmPerMin {
        let per_min = (speed as i128 * self.lim.tick_to_feed_q16 as i128) >> 16;
        FeedMmPerMin(fixed::types::I32F32::from_bits(
            per_min.clamp(0, i64::MAX as i128) as i64,
        ))
    }

    /// Drop what is buffered and start a new path; with `here`, its first
    /// point (index 0) is there, at rest.
    pub(super) fn restart(&mut self, here: Option<Point3Mm>) {
        self.nodes.clear();
        self.finalized = 0;
        self.ended = false;
        self.last_dir = None;
        self.front_index = 0;
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
    }

    /// Set the feed override (Q16) and re-plan the envelope.
    pub(super) fn set_override_q16(&mut self, q16: i64) {
        self.override_q16 = q16;
        if self.finalized > 0 {
            self.rebuild_envelope();
        }
    }

    /// Drop the oldest node when the second one lies more than the corner
    /// reach behind arc length `x` (and more than two stay finalized);
    /// whether one was dropped.
    pub(super) fn drop_front_behind(&mut self, x: i64) -> bool {
        if self.finalized <= 2 {
            return false;
        }
        let Some(second) = self.nodes.get(1) else {
            return false;
        };
        if second.s >= x.saturating_sub(self.lim.reach) {
            return false;
        }
        let _ = self.nodes.pop_front();
        self.finalized -= 1;
        self.front_index = self.front_index.wrapping_add(1);
        true
    }

    /// Add the next point (module docs of [`super::motion`]).
    pub(super) fn push(&mut self, p: MotionPoint) -> Result<(), MotionError> {
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
        if kappa > 0 && !chord_free(lim, kappa) {
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
            let Some(Segment { dir, len }) = Segment::between(last.pos, p.pos) else {
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
            let seg = st(axis_cap(&lim.axis_speed, lim.unbinding, dir));
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
    pub(super) fn end_path(&mut self) {
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
    pub(super) fn ceil_eff(&self, i: usize) -> i64 {
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
    pub(super) fn cap_eff(&self, i: usize) -> i64 {
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
    /// is not complete ([`Lookahead::stalled`]), no faster than a tick's
    /// travel short of the newest node, whose turn is not known yet
    /// (vertices farther than a tick's travel do not count: module docs,
    /// "Ceilings"; with smoothing, than the window's reach:
    /// [`Self::short_of`]).
    fn finalize(&mut self, all: bool, force: bool) {
        let reach = self.lim.reach;
        loop {
            let i = self.finalized;
            let len = self.nodes.storage_len();
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
                let turn = if self.lim.exact && self.nodes.get(i).is_some_and(turns) {
                    0
                } else if self.lim.smoothing > 1 {
                    self.window_limit(i)
                } else {
                    self.turn_limit(i)
                };
                self.nodes
                    .get(i)
                    .map_or(0, |n| ld(n.ceil))
                    .min(turn)
                    .min(if forced {
                        self.short_of(newest_s - si)
                    } else {
                        i64::MAX
                    })
                    // Nor does a vertex dropped within the reach behind.
                    .min(self.short_of(si.saturating_sub(self.dropped_s)))
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

    /// The largest speed whose corner test reaches less than `d` mm: a
    /// tick's travel (`d` itself), or with smoothing the window's reach
    /// `n·(u + m) < d`.
    fn short_of(&self, d: i64) -> i64 {
        let n = i64::from(self.lim.smoothing);
        if n > 1 {
            (d / n).saturating_sub(self.lim.window_margin).max(0)
        } else {
            d
        }
    }

    /// A full buffer whose unfinalized points all lie within the corner
    /// reach of the next one never completes a corner window: whether the
    /// buffer is full, the path not ended, and arc length `x` (the tool's,
    /// at rest) on the end of what is planned. [`super::Motion`] then fixes
    /// the next point anyway ([`Lookahead::force_next`]) or, when only the
    /// newest is left, drops the oldest point behind the tool to make room
    /// ([`Lookahead::drop_stalled_front`]; the ceilings fixed after that stay
    /// a tick's travel short of it). The tool moves on, stopping at each
    /// point, instead of waiting forever.
    pub(super) fn stalled(&self, x: i64) -> bool {
        let tail_s = self
            .finalized
            .checked_sub(1)
            .and_then(|t| self.nodes.get(t))
            .map_or(0, |n| n.s);
        self.nodes.is_full() && !self.ended && x >= tail_s
    }

    /// Whether a node other than the newest waits to be finalized.
    pub(super) fn can_force(&self) -> bool {
        self.finalized + 1 < self.nodes.storage_len()
    }

    /// Finalize the next node although its corner window is not complete.
    pub(super) fn force_next(&mut self) {
        self.finalize(false, true);
    }

    /// Drop the oldest node of a stalled buffer; whether one was dropped.
    pub(super) fn drop_stalled_front(&mut self) -> bool {
        let Some(n) = self.nodes.pop_front() else {
            return false;
        };
        self.dropped_s = n.s;
        self.finalized = self.finalized.saturating_sub(1);
        self.front_index = self.front_index.wrapping_add(1);
        true
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
        let out = self.out_dir(i);
        // The next vertex on either side and its distance (`FAR`: none
        // within reach); a side not taken keeps its vertex.
        const FAR: i64 = i64::MAX;
        let dist = |k: Option<usize>| -> i64 {
            match k.and_then(|k| self.nodes.get(k)) {
                Some(m) => {
                    // (Arc lengths grow along the buffer.)
                    let d = if m.s < n.s { n.s - m.s } else { m.s - n.s };
                    if d <= lim.reach {
                        d
                    } else {
                        FAR
                    }
                }
                None => FAR,
            }
        };
        let (mut left, mut right) = (i.checked_sub(1), i + 1);
        let (mut dl, mut dr) = (dist(left), dist(Some(right)));
        loop {
            // The nearer, the left one on a tie.
            let from_left = dl <= dr;
            let d = if from_left { dl } else { dr };
            if d == FAR {
                break;
            }
            // At travel U = d the next vertex starts to count: stop if the
            // bound is already broken there (the solution lies before it).
            // (The share is computed only where the demand exceeds its
            // least value, the fixed `(1 − ρ)·A_a`; where nothing turned
            // yet there is no demand.)
            if sum != [0; 3] {
                let mut broken = false;
                for a in 0..3 {
                    let need = mul_q14(sum[a], d) as i128 - weighted[a] as i128;
                    let c = lim.corner_accel[a];
                    if need > c as i128
                        && need
                            > axis_share(lim.accel, lim.axis_accel[a], c, out[a], sum[a]) as i128
                    {
                        broken = true;
                        break;
                    }
                }
                if broken {
                    break;
                }
            }
            let k = if from_left {
                let l = left.unwrap_or(0);
                left = l.checked_sub(1);
                dl = dist(left);
                l
            } else {
                right += 1;
                dr = dist(Some(right));
                right - 1
            };
            if let Some(m) = self.nodes.get(k) {
                for ((s, w), &t) in sum.iter_mut().zip(weighted.iter_mut()).zip(m.turn.iter()) {
                    let t = i64::from(t);
                    *s += t;
                    *w = w.saturating_add(mul_q14(t, d) as i64);
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

    /// `|d_a|` of the segment leaving node `i` (Q14, rounded up; 1 if it
    /// has no length): every segment a stencil around the node reaches has
    /// `|d_a| <= out_a + S_a` (its direction is the outgoing one plus the
    /// direction changes `S_a` in between).
    fn out_dir(&self, i: usize) -> [i64; 3] {
        match (self.nodes.get(i), self.nodes.get(i + 1)) {
            (Some(n), Some(m)) if m.s > n.s => {
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
        }
    }

    /// With the commanded positions averaged over `n > 1` ticks: the
    /// largest speed at node `i` (at most its ceiling so far and the feed
    /// limit, the top) that passes the window test
    /// ([`Self::window_probe`], slack `>= 0`). The slack is the least of
    /// seven conditions, each piecewise linear and decreasing in the speed,
    /// so the root is bracketed and found by safeguarded Newton steps: each
    /// probe also gives every condition's slope, and the next probe is
    /// where the linear pieces through it reach zero (an eighth of the
    /// resolution below, so that it passes), which is the root itself when
    /// no piece ends in between; where that point lies outside the
    /// bracket, the secant of the bracket's ends or its middle. The first
    /// probe is an eighth above the previous node's final ceiling where
    /// that lies below the top (on a curve the neighbours' limits are
    /// close: the probe's window is shorter than the top's), else the top.
    /// The search ends when a passing probe's pieces reach zero within the
    /// resolution (`top/4096`) or the bracket is that narrow. Only a speed
    /// the test passed is returned (or 0).
    #[inline(never)]
    fn window_limit(&self, i: usize) -> i64 {
        let top = self
            .nodes
            .get(i)
            .map_or(0, |n| ld(n.ceil))
            .min(self.lim.feed_max);
        // The outgoing direction does not depend on the speed: once.
        let out = self.out_dir(i);
        let resolution = (top >> 12).max(1);
        let start = i
            .checked_sub(1)
            .filter(|&k| !self.is_path_start(k))
            .and_then(|k| self.nodes.get(k))
            .map(|m| {
                let c = ld(m.ceil);
                c.saturating_add(c / 8).saturating_add(resolution)
            })
            .filter(|&g| g < top)
            .unwrap_or(top);
        let (mut lo, mut hi) = (0i64, top);
        // The slack at `lo` (unknown until a probe passed: 0 is not
        // probed, a speed of 0 is what the caller's floor replaces) and
        // at `hi` (unknown until the top was probed).
        let (mut f_lo, mut f_hi) = (None::<i64>, None::<i64>);
        let mut next = Some(start);
        for _ in 0..=WINDOW_STEPS {
            let span = hi - lo;
            if span <= resolution {
                break;
            }
            let x = match (next, f_lo, f_hi) {
                (Some(x), _, _) if x > lo && (x < hi || (x == hi && f_hi.is_none())) => x,
                (_, _, None) => hi,
                // f_lo >= 0 > f_hi: the secant's root, a sixteenth of the
                // span inside it.
                (_, Some(fl), Some(fh)) => {
                    let t = div(fl, fl.saturating_sub(fh)).clamp(ONE / 16, ONE - ONE / 16);
                    lo + mul(span, t).clamp(1, span - 1)
                }
                (_, None, Some(_)) => lo + span / 2,
            };
            let p = self.window_probe(i, out, x);
            if p.slack >= 0 {
                if x >= top {
                    return top;
                }
                lo = x;
                f_lo = Some(p.slack);
                next = match p.zero {
                    Some(z) if z - x > resolution => Some((z - resolution / 8).min(top)),
                    Some(_) => break,
                    None => None,
                };
            } else {
                hi = x;
                f_hi = Some(p.slack);
                next = p.zero.map(|z| z - resolution / 8);
            }
        }
        lo
    }

    /// The window test of passing node `i` at speed `u` (travel per tick):
    /// how far the averaged positions stay within the per-axis acceleration
    /// and the moves between them within the chord tolerance of the
    /// polyline's vertices (`slack >= 0`: within; module docs of [`super`], "Smoothing"), and where the
    /// conditions' linear pieces through `u` reach zero ([`Probe`]).
    /// Within the window the speed is taken as at most
    /// `U = u + m` (the window margin). The average of `n` ticks' second
    /// differences weighs a vertex at distance `e` from the window's centre
    /// by a trapezoid (the mean of `n` hats `(U − |e − jU|)⁺`): `U/n` up to
    /// `(n − 1)·U/2`, zero from `(n + 1)·U/2`. Summed over vertices it is
    /// piecewise linear, concave only at the trapezoids' upper corners, so
    /// its largest values lie there: the node checks its own two corners,
    /// `s_i ± (n − 1)·U/2`, where a vertex `D` away on the same side weighs
    /// `min(U, n·U − D)⁺` and one on the other side `(U − D)⁺`
    /// (both times `n`; the node's own vertex weighs `u`, the step that
    /// crosses it): `Σ_k |Δd_k,a|·w_k <= n·B_a` at each corner, with
    /// `B_a` the axis' corner share. Every term grows with `U`.
    /// The deviation is that of the commanded moves, not only of the
    /// commanded positions: a point of the move between two averaged
    /// positions, a fraction `t` on, is the average of `n + 1` positions
    /// weighed `(1 − t)/n, 1/n, …, 1/n, t/n`, which deviates from the
    /// polyline at most `g_n·U·‖Δd‖` at a single vertex under its weighted
    /// middle (the weighted distance of the points beyond the middle, per
    /// `U`, largest at `t = 1/4` or `1/2`: `g_n = (2n² + 1 + n mod 2)/(16n)`,
    /// 9/32 at `n = 2`), falling to zero where the vertex leaves it
    /// (`n·U/2` away: the kernel is convex there, so the line bounds it);
    /// summed over the vertices: `g_n·Σ_k ‖Δd_k‖·(U_dev − 2δ_k/n)⁺ <= δ`, with the points'
    /// spacing `U_dev = u + (2n − 1)·ρA/2` (within `n` steps of the
    /// crossing). This bounds the blend and the chord of a tick together. `‖Δd‖` is bounded by the largest component plus half the
    /// others.
    /// `out` is [`Self::out_dir`] of the node.
    #[inline(never)]
    fn window_probe(&self, i: usize, out: [i64; 3], u: i64) -> Probe {
        let lim = &self.lim;
        let Some(node) = self.nodes.get(i) else {
            return Probe {
                slack: -1,
                zero: None,
            };
        };
        let n = i64::from(lim.smoothing);
        let ue = u.saturating_add(lim.window_margin);
        let far = ue.saturating_mul(n);
        // The node's own vertex weighs the step that crosses it, taken as
        // `u` (as the single-tick corner limit takes it: the change of speed
        // within the tick is neglected). The deviation's points lie within
        // `n` steps of that one: `U_dev = u + (2n − 1)·ρA/2`.
        let u_dev = u.saturating_add((2 * n - 1) * lim.accel / 2);
        if ue > WINDOW_SPEED_MAX || u_dev > WINDOW_SPEED_MAX {
            // Beyond any configuration's feed: failed (the sums below
            // would not be proven to fit).
            return Probe {
                slack: -1,
                zero: None,
            };
        }
        let mut acc = WindowSums::default();
        let w = WindowWeights {
            n,
            u,
            ue,
            far,
            u_dev,
        };
        acc.count(&w, 0, &node.turn, true);
        let mut k = i;
        while k > 0 {
            k -= 1;
            let Some(m) = self.nodes.get(k) else { break };
            let d = node.s - m.s;
            if d > far {
                break;
            }
            acc.count(&w, d, &m.turn, false);
        }
        let mut k = i + 1;
        while let Some(m) = self.nodes.get(k) {
            let d = m.s - node.s;
            if d > far {
                break;
            }
            acc.count(&w, d, &m.turn, true);
            k += 1;
        }
        let WindowSums {
            ahead,
            behind,
            ahead_slope,
            behind_slope,
            sum,
            dev,
            dev_slope,
        } = acc;
        // Each condition's budget less its demand (mm; the deviation's
        // scaled by `16n²`) and the demand's slope (Q14; the deviation's
        // scaled alike).
        let g = 2 * n * n + 1 + n % 2;
        let dev_slack = (16 * (n * n) as i128 * lim.chord as i128 - dev as i128 * g as i128)
            .clamp(i64::MIN as i128, i64::MAX as i128) as i64;
        let share = corner_share(lim, out, sum);
        let mut conditions = [(dev_slack, dev_slope.saturating_mul(g * n)); 7];
        for (a, pair) in conditions.chunks_exact_mut(2).enumerate().take(3) {
            let budget = share[a].saturating_mul(n);
            if let [on_ahead, on_behind] = pair {
                *on_ahead = (budget.saturating_sub(ahead[a]), ahead_slope[a]);
                *on_behind = (budget.saturating_sub(behind[a]), behind_slope[a]);
            }
        }
        let slack = conditions.iter().map(|c| c.0).fold(i64::MAX, i64::min);
        Probe {
            slack,
            zero: linear_zero(u, slack >= 0, &conditions),
        }
    }

    /// The cap of the segment from node `i` to `i + 1` (both ceilings final).
    fn set_cap(&mut self, i: usize) {
        let (Some(a), Some(b)) = (self.nodes.get(i).copied(), self.nodes.get(i + 1).copied())
        else {
            return;
        };
        let mut c = ld(a.cap);
        let len = b.s - a.s;
        if len < self.lim.cap_reach {
            // A short segment lies inside its end points' corner reach.
            let mut ends = i64::MAX;
            if !self.is_path_start(i) {
                ends = ends.min(ld(a.ceil));
            }
            if !(self.ended && i + 2 == self.nodes.storage_len()) {
                ends = ends.min(ld(b.ceil));
            }
            // Up to 2/5 of its length per tick a tick's stencil inside it
            // (`±u`) never holds both its end points, so at every point of
            // it the single nearer vertex counts, as on a long segment
            // (module docs, "Ceilings"). Without smoothing only: the
            // window's reach is longer.
            if self.lim.smoothing == 1 {
                ends = ends.max(len * 2 / 5);
            }
            c = c.min(ends);
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
                let (t, d) = (ld(m.env), m.s - n.s);
                if surely_below_reach(own, t, self.lim.envelope_decel, d) {
                    return (own, true);
                }
                let r = self.reach_from(t, d);
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

    /// Whether speed `v` at arc length `x` on segment `k` exceeds the
    /// envelope there: the segment's cap, the reach of the next node's
    /// envelope, and of a stop at the end of what is planned (nothing is
    /// under the envelope past the end). Each bound is computed only while
    /// `v` is within the ones before.
    pub(super) fn over_env(&self, k: usize, x: i64, v: i64) -> bool {
        if k + 1 >= self.finalized {
            return v > 0;
        }
        let (Some(next), Some(tail)) = (self.nodes.get(k + 1), self.nodes.get(self.finalized - 1))
        else {
            return v > 0;
        };
        let decel = self.lim.envelope_decel;
        v > self.cap_eff(k)
            || exceeds_reach(v, ld(next.env), decel, next.s - x)
            || exceeds_reach(v, self.lim.creep, decel, tail.s - x)
    }

    /// A node in `from..=to` with no node before it (from `from`) at arc
    /// length `x` or past it: `from` itself when the node a few places on
    /// is already there (a short walk is cheaper), else the first such node
    /// (`to` if none before it is) by bisection: arc lengths grow along the
    /// buffer.
    pub(super) fn first_at_or_after(&self, from: usize, to: usize, x: i64) -> usize {
        const WALK: usize = 6;
        let probe = from.saturating_add(WALK);
        if probe >= to || self.nodes.get(probe).is_none_or(|n| n.s >= x) {
            return from;
        }
        let (mut lo, mut hi) = (probe + 1, to);
        while lo < hi {
            let mid = lo + (hi - lo) / 2;
            match self.nodes.get(mid) {
                Some(n) if n.s < x => lo = mid + 1,
                _ => hi = mid,
            }
        }
        lo
    }

    /// Segment index (in `nodes`) containing arc length `x`, searching from `from`.
    pub(super) fn seg_of(&self, from: usize, x: i64) -> usize {
        let mut k = from;
        while k + 1 < self.finalized && self.nodes.get(k + 1).is_some_and(|n| n.s <= x) {
            k += 1;
        }
        k
    }
}

/// `x·d >> 14` for `x, d >= 0`, exactly (`u128`; a 32-bit multiply where
/// both fit: every distance below 1 mm, so every corner reach below it).
#[inline(always)]
fn mul_q14(x: i64, d: i64) -> u128 {
    let (x, d) = (x.max(0) as u64, d.max(0) as u64);
    if (x | d) >> 32 == 0 {
        ((x as u32 as u64 * d as u32 as u64) >> 14) as u128
    } else {
        (x as u128 * d as u128) >> 14
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

/// Most steps of [`Lookahead::window_limit`]'s root search.
const WINDOW_STEPS: usize = 10;

/// The largest speed (travel per tick, raw Q32: 256 mm) for which
/// [`Lookahead::window_probe`]'s sums are proven to fit 64 bits: a weight
/// at most this, a direction change at most 2^15 (Q14), at most 2^16
/// vertices.
const WINDOW_SPEED_MAX: i64 = 1 << 40;

/// The speeds [`Lookahead::window_probe`] weighs vertices with.
struct WindowWeights {
    /// Ticks averaged.
    n: i64,
    /// The step crossing the node.
    u: i64,
    /// The steps within the window, `u + m`.
    ue: i64,
    /// The window's reach, `n·ue`.
    far: i64,
    /// The deviation's point spacing.
    u_dev: i64,
}

/// What [`Lookahead::window_probe`] sums over the vertices in the window
/// (per axis in arrays: a struct per axis compiles to a longer loop on
/// the Cortex-M4).
#[derive(Default)]
struct WindowSums {
    /// Per axis: the demand at the corner ahead and behind (mm), and its
    /// slope in `u` (Q14).
    ahead: [i64; 3],
    behind: [i64; 3],
    ahead_slope: [i64; 3],
    behind_slope: [i64; 3],
    /// Per axis: Σ|Δd| of the vertices counted (Q14).
    sum: [i64; 3],
    /// Σ‖Δd‖·weight for the deviation, and its slope (Σ‖Δd‖ of the
    /// vertices it weighs).
    dev: i64,
    dev_slope: i64,
}

impl WindowSums {
    /// Count the vertex `d` from the node (ahead or behind it) with
    /// direction change `turn`. Every weight is at most
    /// [`WINDOW_SPEED_MAX`] (checked by the caller), so no sum overflows.
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // five arrays, one index
    fn count(&mut self, w: &WindowWeights, d: i64, turn: &[u16; 3], is_ahead: bool) {
        let cap = if d == 0 { w.u } else { w.ue };
        // Each weight and its slope in `u` (the cap's is 1, the far
        // corner's `n`).
        let to_far = w.far - d;
        let same = if to_far <= 0 {
            (0, 0)
        } else if to_far < cap {
            (to_far, w.n)
        } else {
            (cap, 1)
        };
        let other = if cap > d { (cap - d, 1) } else { (0, 0) };
        let ((wa, ka), (wb, kb)) = if is_ahead {
            (same, other)
        } else {
            (other, same)
        };
        for a in 0..3 {
            let t = i64::from(turn[a]);
            self.ahead[a] += (t * wa) >> 14;
            self.behind[a] += (t * wb) >> 14;
            self.ahead_slope[a] += t * ka;
            self.behind_slope[a] += t * kb;
            self.sum[a] += t;
        }
        // `n·(U_dev − 2δ/n)⁺`, without a division.
        let wd = w.u_dev * w.n - 2 * d;
        if wd > 0 {
            let l2 = l2_bound(turn);
            self.dev += (l2 * wd) >> 14;
            self.dev_slope += l2;
        }
    }
}

/// The window test at one speed ([`Lookahead::window_probe`]).
struct Probe {
    /// The least condition's budget less its demand (`>= 0`: passed).
    slack: i64,
    /// Where the conditions' linear pieces through this speed reach zero:
    /// when it failed, the largest speed at which every failing one
    /// passes; when it passed, the least speed above it at which one fails
    /// (`None`: a failing condition does not change with the speed here,
    /// or no condition grows with it).
    zero: Option<i64>,
}

/// [`Probe::zero`] of conditions `(slack, slope)` at speed `u` (slope:
/// the demand's growth per speed, Q14, `>= 0`). Failed: the failing
/// condition farthest from zero in speed, `u − ⌈|slack|/slope⌉ − 1`;
/// passed: the nearest, `u + ⌊slack/slope⌋`. The ratios are compared
/// exactly (`i128` products), one quotient taken.
fn linear_zero(u: i64, passed: bool, conditions: &[(i64, i64); 7]) -> Option<i64> {
    // The winning (distance, slope): distance `|slack|`, compared as
    // `d₁/s₁ > d₂/s₂` ⇔ `d₁·s₂ > d₂·s₁`.
    let mut best: Option<(i64, i64)> = None;
    for &(slack, slope) in conditions {
        if passed {
            if slope <= 0 {
                continue;
            }
            let b = (slack.max(0), slope);
            best = match best {
                Some(c) if (c.0 as i128 * b.1 as i128) <= (b.0 as i128 * c.1 as i128) => Some(c),
                _ => Some(b),
            };
        } else if slack < 0 {
            if slope <= 0 {
                return None;
            }
            let b = (slack.saturating_neg(), slope);
            best = match best {
                Some(c) if (c.0 as i128 * b.1 as i128) >= (b.0 as i128 * c.1 as i128) => Some(c),
                _ => Some(b),
            };
        }
    }
    let (dist, slope) = best?;
    // `dist·2^14/slope`: `div` is Q32, the slope Q14.
    let du = div(dist, slope) >> 18;
    Some(if passed {
        u.saturating_add(du)
    } else {
        u.saturating_sub(du.saturating_add(1))
    })
}

/// Whether the path turns at node `n` on an exact path (G61): a change
/// of direction beyond the rounding of collinear moves (a component above
/// 2^-13), where the tool stops.
fn turns(n: &Node) -> bool {
    n.turn.iter().any(|&t| t > 2)
}

/// An upper bound of the Euclidean length of a direction change (Q14):
/// its largest component plus half the other two (`a >= b, c` gives
/// `(a + (b + c)/2)² >= a² + b² + c²`).
fn l2_bound(t: &[u16; 3]) -> i64 {
    let [x, y, z] = t.map(i64::from);
    let m = x.max(y).max(z);
    m + (x + y + z - m + 1) / 2
}

/// Whether the chord bound at curvature `kappa` (> 0) lies above the
/// feed bound for certain ([`Limits::chord_free`]): `κ·(H² + δ²) < 2δ`,
/// with margins for the product's and the bound's rounding.
fn chord_free(lim: &Limits, kappa: i64) -> bool {
    let two_delta = 2 * lim.chord;
    mul(kappa, lim.chord_free).saturating_add(2) < two_delta - (two_delta >> 20)
}

/// The speed allowed by per-axis limits along direction `d` (Q30 unit).
/// An axis whose limit lies above `unbinding` ([`Limits::unbinding`])
/// cannot bind (`|d_k| <= 1`): no division.
fn axis_cap(axis: &[i64; 3], unbinding: i64, d: [i32; 3]) -> i64 {
    let mut c = i64::MAX;
    for (&v, &dk) in axis.iter().zip(d.iter()) {
        let comp = (dk as i64).unsigned_abs() as i64;
        if comp > 0 && v <= unbinding {
            // v·|d_k| <= V_k  ⇒  v <= V_k / |d_k|, |d_k| in Q30.
            c = c.min(div(v, comp << 2));
        }
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_node_is_56_bytes() {
        // The buffer is most of the planner's RAM (firmware budget).
        assert_eq!(core::mem::size_of::<Node>(), 56);
    }

    /// The chord bound as `push` computes it where it is not skipped.
    fn chord_bound(lim: &Limits, kappa: i64) -> i64 {
        let r = div(2 * lim.chord, kappa) - mul(lim.chord, lim.chord);
        if r > 0 {
            2 * sqrt(r)
        } else {
            i64::MAX
        }
    }

    #[test]
    fn skipped_bounds_lie_above_the_feed_bound() {
        // Feeds, ticks and tolerances over their ranges; curvatures from
        // straight to sharp, densely near the threshold.
        let mut next = crate::test_rng::xorshift64(0x2545_f491_4f6c_dd1d);
        let mut skipped = [0u32; 2];
        for _ in 0..2000 {
            let cfg = crate::planner::MotionConfig {
                tick_us: 50 + (next() % 20_000) as u32,
                feed_max: FeedMmPerMin::from_int(1 + (next() % 60_000) as i32),
                axis_speed_max: [0; 3]
                    .map(|_| FeedMmPerMin::from_int(1 + (next() % 60_000) as i32)),
                chord_tolerance_mm: fixed::types::I32F32::from_bits(
                    1 + (next() % (1 << 28)) as i64,
                ),
                ..Default::default()
            };
            let Ok(lim) = cfg.compile() else { continue };
            let fmax = lim.feed_max;
            // Stored and loaded as the node keeps it.
            let kept = |v: i64| ld(st(v));
            let mut kappa = 1i64 << (next() % 50);
            for _ in 0..40 {
                if chord_free(&lim, kappa) {
                    skipped[0] += 1;
                    assert!(kept(chord_bound(&lim, kappa)) >= fmax, "{cfg:?} {kappa}");
                }
                kappa += kappa / 16 + 1;
            }
            for _ in 0..40 {
                let d = [0; 3].map(|_| (next() % (1 << 30)) as i32 - (1 << 29));
                let Some(seg) = Segment::between_bits([0; 3], d.map(i64::from)) else {
                    continue;
                };
                let full = axis_cap(&lim.axis_speed, i64::MAX, seg.dir);
                let fast = axis_cap(&lim.axis_speed, lim.unbinding, seg.dir);
                if fast != full {
                    skipped[1] += 1;
                    assert!(kept(fast) >= fmax && kept(full) >= fmax, "{cfg:?} {d:?}");
                }
            }
        }
        assert!(skipped.iter().all(|&n| n > 1000), "{skipped:?}");
    }

    /// The largest speed passing the window test, by bisection to the
    /// quantum (the slack is decreasing in the speed): the reference for
    /// [`Lookahead::window_limit`]'s root search.
    fn window_root_bisected(plan: &Plan, i: usize) -> i64 {
        let top = plan
            .nodes
            .get(i)
            .map_or(0, |n| ld(n.ceil))
            .min(plan.lim.feed_max);
        let out = plan.out_dir(i);
        let passes = |u: i64| plan.window_probe(i, out, u).slack >= 0;
        if passes(top) {
            return top;
        }
        let (mut lo, mut hi) = (0i64, top);
        while hi - lo > 1 {
            let x = lo + (hi - lo) / 2;
            if passes(x) {
                lo = x;
            } else {
                hi = x;
            }
        }
        lo
    }

    #[test]
    fn the_window_root_search_passes_and_finds_the_root() {
        // Random polylines (segments 2 µm to 2 mm, sharp and gentle turns,
        // dense runs) under random smoothing configurations; every node's
        // ceiling candidate against the bisected root.
        let mut next = crate::test_rng::xorshift64(0x9e37_79b9_7f4a_7c15);
        let (mut nodes, mut close, mut worst) = (0u32, 0u32, 0f64);
        for case in 0..300 {
            let cfg = crate::planner::MotionConfig {
                tick_us: [250, 500, 1000][(next() % 3) as usize],
                feed_max: FeedMmPerMin::from_int(500 + (next() % 10_000) as i32),
                axis_accel_max_mm_s2: [0; 3].map(|_| 200 + (next() % 3000) as u32),
                chord_tolerance_mm: fixed::types::I32F32::from_bits(
                    (1 << 22) + (next() % (1 << 26)) as i64,
                ),
                smoothing_ticks: 2 + (next() % 3) as u8,
                ..Default::default()
            };
            let Ok(lim) = cfg.compile() else { continue };
            let mut buf: Buffer<64> = Buffer::new(lim);
            let mut pos = [0i64; 3];
            let mut dir = [1.0f64, 0.0, 0.0];
            let dense = case % 3 == 0;
            for _ in 0..60 {
                let len_mm = if dense {
                    0.002 + (next() % 1000) as f64 * 2e-5
                } else {
                    0.002 * (1000f64).powf((next() % 1000) as f64 / 1000.0)
                };
                let turn = if dense { 0.05 } else { 2.5 };
                for d in dir.iter_mut() {
                    *d += ((next() % 2001) as f64 / 1000.0 - 1.0) * turn;
                }
                let norm = dir.iter().map(|d| d * d).sum::<f64>().sqrt().max(1e-9);
                for (p, d) in pos.iter_mut().zip(dir.iter()) {
                    *p += (d / norm * len_mm * 4_294_967_296.0) as i64;
                }
                let point = MotionPoint {
                    pos: Point3Mm::from_bits(pos[0], pos[1], pos[2]),
                    feed: FeedMmPerMin::from_int(60_000),
                    curvature: CurvaturePerMm::default(),
                };
                if buf.plan_mut().push(point).is_err() {
                    break;
                }
            }
            let plan = buf.plan();
            for i in 1..plan.len().saturating_sub(1) {
                let r = plan.window_limit(i);
                let reference = window_root_bisected(plan, i);
                let out = plan.out_dir(i);
                assert!(
                    r == 0 || plan.window_probe(i, out, r).slack >= 0,
                    "{cfg:?} node {i}: {r} fails the test"
                );
                assert!(
                    r <= reference,
                    "{cfg:?} node {i}: {r} above the root {reference}"
                );
                nodes += 1;
                let short = (reference - r) as f64 / reference.max(1) as f64;
                worst = worst.max(short);
                if short <= 1.0 / 1024.0 {
                    close += 1;
                }
            }
        }
        std::eprintln!(
            "window root: {close} of {nodes} within 1/1024 of the root, worst {worst:.4}"
        );
        assert!(nodes > 5000, "{nodes}");
        assert!(close as f64 >= 0.99 * nodes as f64, "{close} of {nodes}");
    }
}
