//! The streaming feed scheduler of Lin et al. (2021), Figure 1 / section 2.6-2.7:
//!
//! ```text
//! points → curvature (eq. 4-9) → lookahead Dκ (eq. 10) → fuzzy controller
//!        (section 2.7.1, eq. 11) → average filter (2.7.2) → (point, feed)
//! ```
//!
//! The same code runs on the controller and on the host: integer arithmetic
//! only, no allocation, no panics, deterministic to the bit.
//!
//! # Streaming and latency
//! [`Scheduler::push`] takes one point and returns at most one scheduled
//! point: the one whose lookahead just completed. A point is released
//! `2 + (WS − 1) + AVG/2` points after it was pushed (the curvature needs the
//! next point, and the first point's curvature is the second's; the window
//! needs `WS − 1` more curvatures; the centred average needs `AVG/2` more
//! feeds). [`Scheduler::finish`] marks the end of the path; then
//! [`Scheduler::drain`] releases the held points one by one, the lookahead
//! window and the filter shrinking to what is left. When the last point is
//! out the scheduler is ready for the next path.
//!
//! The points themselves wait in one ring of `CAP` entries (written once at
//! push, read once at release); the stages pass only curvatures and feeds.
//! `CAP` must exceed the latency; a too small `CAP` is a compile error.
//!
//! # Points
//! - exact duplicates of the previous point add no motion and have no
//!   curvature; they are merged into it (counted, reported by `push`), like
//!   the zero-length blocks Grbl drops;
//! - the first and last points get the curvature of their only neighbour
//!   (one-sided estimate); a path of one or two points is straight (κ = 0);
//! - coordinates beyond ±[`COORD_LIMIT_MM`] and negative or oversized feed
//!   caps are refused with an error; nothing already accepted is affected.
//!
//! # Feed
//! `F = max(F_min, fraction · F_max)` for the controller's output fraction
//! (clamped to `[0, 1]`), averaged, then limited by the point's own cap (a
//! programmed `F` word): the cap is a hard limit, applied after the filter.

use fixed::types::I32F32;

use crate::average::{AverageFilter, Released};
use crate::curvature::{curvature_of_chords, Chord};
use crate::fuzzy::FuzzyInference;
use crate::lin2021::{Normaliser, VariationScale};
use crate::lookahead::{LookaheadWindow, Windowed};
use crate::ring::Ring;
use crate::units::{curvature_to_fx, CurvaturePerMm, FeedMmPerMin, Fx, Point3Mm, COORD_LIMIT_MM};

/// A point of the commanded path.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PathPoint {
    /// Position, mm.
    pub pos: Point3Mm,
    /// Largest feed allowed on the way to this point (the programmed `F`),
    /// mm/min; `None` for no limit beyond `F_max`.
    pub feed_cap: Option<FeedMmPerMin>,
    /// Caller's tag, returned untouched (a G-code line, a link sequence
    /// number).
    pub tag: u32,
}

impl PathPoint {
    /// A point without feed cap or tag.
    pub const fn at(pos: Point3Mm) -> Self {
        PathPoint {
            pos,
            feed_cap: None,
            tag: 0,
        }
    }
}

/// A point with its scheduled feed and how it was obtained.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ScheduledPoint {
    /// The point as pushed.
    pub point: PathPoint,
    /// Index of the point in its path (duplicates merged), from 0.
    pub index: u32,
    /// κ (eq. 9), 1/mm.
    pub curvature: CurvaturePerMm,
    /// Dκ (eq. 10), 1/mm, before normalisation.
    pub variation: CurvaturePerMm,
    /// The controller's output (fraction of `F_max`, eq. 11).
    pub fraction: Fx,
    /// `max(F_min, fraction · F_max)`, before the average filter.
    pub fuzzy_feed: FeedMmPerMin,
    /// The scheduled feed: averaged, then capped.
    pub feed: FeedMmPerMin,
    /// Whether some rule fired (otherwise the controller's default was used).
    pub fired: bool,
}

/// Scheduler settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SchedulerConfig {
    /// Maximum feed `F_max`, mm/min (the paper's "maximum feedrate").
    pub f_max: FeedMmPerMin,
    /// Minimum feed `F_min`, mm/min: the schedule never goes below it.
    pub f_min: FeedMmPerMin,
    /// Normalisation of Dκ.
    pub variation: VariationScale,
}

impl SchedulerConfig {
    /// `F_max` and `F_min` in mm/min, the paper's Dκ normalisation.
    pub const fn new(f_max: FeedMmPerMin, f_min: FeedMmPerMin) -> Self {
        SchedulerConfig {
            f_max,
            f_min,
            variation: VariationScale::PAPER,
        }
    }

    /// Check the settings.
    pub fn validate(&self) -> Result<(), SchedulerError> {
        if !self.f_max.within_limits() || self.f_max.0 <= 0 {
            return Err(SchedulerError::BadConfig(
                "F_max must be in (0, 1e6] mm/min",
            ));
        }
        if self.f_min.0 < 0 || self.f_min > self.f_max {
            return Err(SchedulerError::BadConfig("F_min must be in [0, F_max]"));
        }
        if !self.variation.is_valid() {
            return Err(SchedulerError::BadConfig(
                "variation scale needs 0 <= floor < clip <= 32767 /mm",
            ));
        }
        Ok(())
    }
}

/// Why the scheduler refused something.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum SchedulerError {
    /// A coordinate beyond ±[`COORD_LIMIT_MM`].
    CoordinateOutOfRange,
    /// A feed cap below 0 or above the feed limit.
    FeedCapOutOfRange,
    /// The path was finished; drain it before starting the next.
    PathFinishing,
    /// No room for another point (only with a `CAP` below the latency, which
    /// the compiler refuses).
    BufferFull,
    /// Invalid settings.
    BadConfig(&'static str),
}

impl core::fmt::Display for SchedulerError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            SchedulerError::CoordinateOutOfRange => {
                write!(f, "coordinate beyond ±{COORD_LIMIT_MM} mm")
            }
            SchedulerError::FeedCapOutOfRange => f.write_str("feed cap outside [0, 1e6] mm/min"),
            SchedulerError::PathFinishing => {
                f.write_str("path finished: drain it before pushing the next")
            }
            SchedulerError::BufferFull => f.write_str("scheduler buffer full"),
            SchedulerError::BadConfig(why) => write!(f, "bad scheduler configuration: {why}"),
        }
    }
}

/// Stage 1: curvature at each point (eq. 4-9), two points of latency. It
/// sees positions only and emits one curvature per point, in order.
///
/// Plain fields with a count instead of `Option`s: the stage runs once per
/// point, and a count is tested once where each `Option` would be copied
/// and tested.
#[derive(Clone, Copy, Debug, Default)]
struct CurvatureStage {
    /// Distinct points seen on this path, saturating at 3 (`before` is
    /// valid from 2, `last` from 1).
    seen: u8,
    /// The two newest distinct points.
    before: Point3Mm,
    last: Point3Mm,
    /// Chord `before → last` (valid when `seen >= 2`; never `None` then,
    /// since consecutive points are distinct).
    chord: Option<Chord>,
    /// Curvature of `before`, not yet emitted (valid when `has_held`).
    held: CurvaturePerMm,
    has_held: bool,
    /// Points accepted and not yet emitted (0..=2).
    pending: u8,
    /// While flushing: the curvature the last point inherits.
    tail: CurvaturePerMm,
}

impl CurvatureStage {
    fn is_duplicate(&self, p: &Point3Mm) -> bool {
        self.seen > 0 && self.last == *p
    }

    /// Add a point distinct from the previous one; returns the curvature of
    /// the point two places back.
    fn push(&mut self, p: Point3Mm) -> Option<CurvaturePerMm> {
        self.pending += 1;
        let mut out = None;
        if self.seen > 0 {
            // Both points passed the ±100 m check.
            let chord_out = Chord::between_in_range(&self.last, &p);
            if self.seen >= 2 {
                if let (Some(chord_in), Some(chord_out)) = (&self.chord, &chord_out) {
                    let (a, b) = (self.before.to_bits(), p.to_bits());
                    let span = [
                        b[0].wrapping_sub(a[0]),
                        b[1].wrapping_sub(a[1]),
                        b[2].wrapping_sub(a[2]),
                    ];
                    let k = curvature_of_chords(chord_in, chord_out, span);
                    // The first point has no curvature of its own: it takes
                    // its neighbour's (one-sided estimate).
                    out = Some(if self.has_held { self.held } else { k });
                    self.held = k;
                    self.has_held = true;
                    self.pending -= 1;
                }
            }
            self.before = self.last;
            self.chord = chord_out;
        }
        self.last = p;
        self.seen = self.seen.saturating_add(1).min(3);
        out
    }

    /// At the end of a path: the curvatures of the remaining points, one per
    /// call (the last point inherits its neighbour's; a path of one or two
    /// points is straight). Resets itself when done.
    fn flush(&mut self) -> Option<CurvaturePerMm> {
        if self.pending == 0 {
            *self = CurvatureStage::default();
            return None;
        }
        self.pending -= 1;
        if self.has_held {
            self.has_held = false;
            self.tail = self.held;
            return Some(self.held);
        }
        Some(self.tail)
    }
}

/// A point in flight, as pushed. Plain scalars written field by field: a
/// whole `PathPoint` moved is a `memcpy` call on the target.
#[derive(Clone, Copy, Debug, Default)]
struct Held {
    pos: [i64; 3],
    /// The feed cap's raw bits; negative for none (caps are checked to be
    /// within `[0, 1e6]` mm/min).
    cap: i64,
    tag: u32,
}

/// What the feed stage keeps about a point while it is in the average
/// filter.
#[derive(Clone, Copy, Debug, Default)]
struct Decided {
    curvature: CurvaturePerMm,
    variation: CurvaturePerMm,
    fraction: Fx,
    fired: bool,
}

/// The whole pipeline for a two-input controller `C` (curvature in 1/mm,
/// normalised Dκ), a lookahead of `WS` points (the paper's window size,
/// default 30), a centred average over `AVG` feeds (odd, default 9) and room
/// for `CAP` points in flight (more than [`Self::LATENCY`]).
#[derive(Clone, Debug)]
pub struct Scheduler<
    C: FuzzyInference<2>,
    const WS: usize = 30,
    const AVG: usize = 9,
    const CAP: usize = 40,
> {
    controller: C,
    scratch: C::Scratch,
    config: SchedulerConfig,
    /// `config.variation`, prepared.
    normaliser: Normaliser,
    points: Ring<Held, CAP>,
    curvature: CurvatureStage,
    window: LookaheadWindow<(), WS>,
    filter: AverageFilter<Decided, AVG>,
    finishing: bool,
    next_index: u32,
    released: u32,
    merged: u32,
}

/// `fraction · feed` for a fraction in `[0, 1]` (exact floor).
fn scale_feed(feed: FeedMmPerMin, fraction: Fx) -> FeedMmPerMin {
    let bits = feed.0.to_bits();
    let f = fraction.to_bits().clamp(0, 1 << 16) as i64;
    let (hi, lo) = (bits >> 16, bits & 0xFFFF);
    FeedMmPerMin(I32F32::from_bits(hi * f + ((lo * f) >> 16)))
}

impl<C: FuzzyInference<2>, const WS: usize, const AVG: usize, const CAP: usize>
    Scheduler<C, WS, AVG, CAP>
{
    /// Points between a push and the release of that point:
    /// `2 + (WS − 1) + AVG/2`.
    pub const LATENCY: usize = 1 + WS + AVG / 2;
    const VALID: () = assert!(
        CAP > 1 + WS + AVG / 2,
        "Scheduler: CAP must exceed 1 + WS + AVG/2"
    );

    /// A scheduler using `controller` (e.g. `&lin2021::CONTROLLER`).
    pub fn new(controller: C, config: SchedulerConfig) -> Result<Self, SchedulerError> {
        #[allow(clippy::let_unit_value)]
        let () = Self::VALID;
        config.validate()?;
        Ok(Scheduler {
            controller,
            scratch: C::Scratch::default(),
            points: Ring::new(),
            normaliser: config.variation.normaliser(),
            config,
            curvature: CurvatureStage::default(),
            window: LookaheadWindow::new(),
            filter: AverageFilter::new(),
            finishing: false,
            next_index: 0,
            released: 0,
            merged: 0,
        })
    }

    /// The settings.
    pub fn config(&self) -> &SchedulerConfig {
        &self.config
    }

    /// Change the settings; applies to points decided from now on.
    pub fn set_config(&mut self, config: SchedulerConfig) -> Result<(), SchedulerError> {
        config.validate()?;
        self.normaliser = config.variation.normaliser();
        self.config = config;
        Ok(())
    }

    /// Points accepted on this path and not yet released.
    pub fn held(&self) -> usize {
        self.next_index.wrapping_sub(self.released) as usize
    }

    /// Duplicates merged on this path.
    pub fn merged_duplicates(&self) -> u32 {
        self.merged
    }

    /// Whether [`Self::finish`] was called and the path is not drained yet.
    pub fn is_finishing(&self) -> bool {
        self.finishing
    }

    /// Add the next point of the path. Returns the point whose lookahead
    /// this completes, if any. An exact duplicate of the previous point is
    /// merged into it (`Ok(None)`, counted by [`Self::merged_duplicates`]).
    pub fn push(&mut self, point: PathPoint) -> Result<Option<ScheduledPoint>, SchedulerError> {
        if self.finishing {
            return Err(SchedulerError::PathFinishing);
        }
        if !point.pos.within_limits() {
            return Err(SchedulerError::CoordinateOutOfRange);
        }
        if point.feed_cap.is_some_and(|c| !c.within_limits()) {
            return Err(SchedulerError::FeedCapOutOfRange);
        }
        if self.curvature.is_duplicate(&point.pos) {
            self.merged = self.merged.saturating_add(1);
            return Ok(None);
        }
        let pos = point.pos;
        // Cannot fail while CAP > LATENCY (checked at compile time).
        let Some(h) = self.points.push_slot() else {
            return Err(SchedulerError::BufferFull);
        };
        let b = pos.to_bits();
        (h.pos[0], h.pos[1], h.pos[2]) = (b[0], b[1], b[2]);
        h.cap = point.feed_cap.map_or(-1, |c| c.0.to_bits());
        h.tag = point.tag;
        self.next_index = self.next_index.wrapping_add(1);
        let Some(k) = self.curvature.push(pos) else {
            return Ok(None);
        };
        let Some(w) = self.window.push((), k) else {
            return Ok(None);
        };
        Ok(self.decide(w))
    }

    /// Mark the end of the path. Then call [`Self::drain`] until it returns
    /// `None`.
    pub fn finish(&mut self) {
        self.finishing = true;
    }

    /// After [`Self::finish`]: the next held point, or `None` when the path is
    /// complete (the scheduler is then ready for a new path). Returns `None`
    /// at once if the path was not finished.
    pub fn drain(&mut self) -> Option<ScheduledPoint> {
        if !self.finishing {
            return None;
        }
        // Each pass moves one held point one stage on, so this ends.
        loop {
            if let Some(k) = self.curvature.flush() {
                if let Some(s) = self.window.push((), k).and_then(|w| self.decide(w)) {
                    return Some(s);
                }
                continue;
            }
            if let Some(w) = self.window.flush() {
                if let Some(s) = self.decide(w) {
                    return Some(s);
                }
                continue;
            }
            if let Some(r) = self.filter.flush_in_place() {
                if let Some(s) = self.complete(r) {
                    return Some(s);
                }
                continue;
            }
            self.abort();
            return None;
        }
    }

    /// Drop the path (e.g. after an emergency stop); ready for a new one.
    pub fn abort(&mut self) {
        self.points.clear();
        self.curvature = CurvatureStage::default();
        self.window.clear();
        self.filter.clear();
        self.finishing = false;
        self.next_index = 0;
        self.released = 0;
        self.merged = 0;
    }

    /// Schedule a whole path: push every point, finish, drain; `emit` gets
    /// each scheduled point in order. On a refused point, returns its
    /// position in `points` and the error; the points before it stay held
    /// (call [`Self::finish`] and [`Self::drain`], or [`Self::abort`]).
    pub fn run<I, F>(&mut self, points: I, mut emit: F) -> Result<(), (usize, SchedulerError)>
    where
        I: IntoIterator<Item = PathPoint>,
        F: FnMut(ScheduledPoint),
    {
        for (i, p) in points.into_iter().enumerate() {
            if let Some(s) = self.push(p).map_err(|e| (i, e))? {
                emit(s);
            }
        }
        self.finish();
        while let Some(s) = self.drain() {
            emit(s);
        }
        Ok(())
    }

    /// The fuzzy controller and `F_min`/`F_max` (section 2.7.1), then the
    /// average filter (2.7.2).
    fn decide(&mut self, w: Windowed<()>) -> Option<ScheduledPoint> {
        let inputs = [
            curvature_to_fx(w.curvature),
            self.normaliser.normalise(w.variation),
        ];
        let e = self.controller.infer(&mut self.scratch, inputs);
        let fraction = e.output.clamp(Fx::ZERO, Fx::ONE);
        let feed = scale_feed(self.config.f_max, fraction).max(self.config.f_min);
        let decided = Decided {
            curvature: w.curvature,
            variation: w.variation,
            fraction,
            fired: e.fired,
        };
        let r = self.filter.push_in_place(decided, feed.0.to_bits())?;
        self.complete(r)
    }

    /// The point leaving the filter, with its feed capped.
    fn complete(&mut self, r: Released) -> Option<ScheduledPoint> {
        let h = self.points.front()?;
        let d = self.filter.item(&r)?;
        let feed_cap = (h.cap >= 0).then_some(FeedMmPerMin(I32F32::from_bits(h.cap)));
        let mut feed = FeedMmPerMin(I32F32::from_bits(r.mean));
        if let Some(cap) = feed_cap {
            feed = feed.min(cap);
        }
        let out = ScheduledPoint {
            point: PathPoint {
                pos: Point3Mm::from_bits(h.pos[0], h.pos[1], h.pos[2]),
                feed_cap,
                tag: h.tag,
            },
            index: self.released,
            curvature: d.curvature,
            variation: d.variation,
            fraction: d.fraction,
            fuzzy_feed: FeedMmPerMin(I32F32::from_bits(r.raw)),
            feed,
            fired: d.fired,
        };
        self.points.drop_front();
        self.released = self.released.wrapping_add(1);
        Some(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lin2021::{Lin2021Controller, CONTROLLER};

    type Sched = Scheduler<&'static Lin2021Controller, 30, 9, 40>;

    fn sched() -> Sched {
        Scheduler::new(
            &CONTROLLER,
            SchedulerConfig::new(FeedMmPerMin::from_int(3000), FeedMmPerMin::from_int(100)),
        )
        .unwrap()
    }

    fn pt(x: f64, y: f64) -> PathPoint {
        PathPoint::at(Point3Mm::from_f64(x, y, 0.0).unwrap())
    }

    fn run(points: &[PathPoint]) -> Vec<ScheduledPoint> {
        let mut s = sched();
        let mut out = Vec::new();
        s.run(points.iter().copied(), |p| out.push(p)).unwrap();
        out
    }

    #[test]
    fn every_point_comes_out_once_in_order() {
        for n in [0usize, 1, 2, 3, 4, 10, 31, 32, 40, 100] {
            let pts: Vec<_> = (0..n)
                .map(|i| pt(i as f64, (i as f64 * 0.3).sin()))
                .collect();
            let out = run(&pts);
            assert_eq!(out.len(), n, "n = {n}");
            for (i, o) in out.iter().enumerate() {
                assert_eq!(o.index as usize, i);
                assert_eq!(o.point, pts[i]);
            }
        }
    }

    #[test]
    fn latency_is_as_documented() {
        let mut s = sched();
        let mut first = None;
        for i in 0..100 {
            if let Some(p) = s.push(pt(i as f64, 0.0)).unwrap() {
                first.get_or_insert((i, p.index));
            }
        }
        assert_eq!(first, Some((Sched::LATENCY, 0)));
        assert_eq!(s.held(), Sched::LATENCY);
    }

    #[test]
    fn straight_line_runs_at_f_max() {
        let pts: Vec<_> = (0..50).map(|i| pt(i as f64 * 0.1, 0.0)).collect();
        for o in run(&pts) {
            assert_eq!(o.curvature, CurvaturePerMm::ZERO);
            assert_eq!(o.feed, FeedMmPerMin::from_int(3000));
        }
    }

    #[test]
    fn endpoints_take_their_neighbours_curvature() {
        let r: f64 = 10.0;
        let pts: Vec<_> = (0..20)
            .map(|i| pt(r * (i as f64 * 0.02).cos(), r * (i as f64 * 0.02).sin()))
            .collect();
        let out = run(&pts);
        assert_eq!(out[0].curvature, out[1].curvature);
        assert_eq!(out[19].curvature, out[18].curvature);
        assert!((out[5].curvature.to_f64() - 0.1).abs() < 1e-4);
        // Two points: straight.
        let out = run(&pts[..2]);
        assert!(out.iter().all(|o| o.curvature == CurvaturePerMm::ZERO));
    }

    #[test]
    fn duplicates_are_merged_and_refused_points_change_nothing() {
        let mut s = sched();
        assert_eq!(s.push(pt(0.0, 0.0)), Ok(None));
        assert_eq!(s.push(pt(0.0, 0.0)), Ok(None));
        assert_eq!(
            s.push(pt(1e6, 0.0)),
            Err(SchedulerError::CoordinateOutOfRange)
        );
        let capped = PathPoint {
            feed_cap: Some(FeedMmPerMin::from_int(-5)),
            ..pt(1.0, 0.0)
        };
        assert_eq!(s.push(capped), Err(SchedulerError::FeedCapOutOfRange));
        assert_eq!(s.push(pt(1.0, 0.0)), Ok(None));
        assert_eq!(s.merged_duplicates(), 1);
        assert_eq!(s.held(), 2);
        s.finish();
        assert_eq!(s.push(pt(2.0, 0.0)), Err(SchedulerError::PathFinishing));
        assert_eq!(s.drain().map(|p| p.index), Some(0));
        assert_eq!(s.drain().map(|p| p.index), Some(1));
        assert_eq!(s.drain(), None);
        // Ready for the next path.
        assert_eq!(s.push(pt(5.0, 0.0)), Ok(None));
        assert_eq!(s.held(), 1);
    }

    #[test]
    fn feed_cap_is_a_hard_limit() {
        let pts: Vec<_> = (0..40)
            .map(|i| PathPoint {
                feed_cap: Some(FeedMmPerMin::from_int(1200)),
                ..pt(i as f64, 0.0)
            })
            .collect();
        assert!(run(&pts)
            .iter()
            .all(|o| o.feed == FeedMmPerMin::from_int(1200)
                && o.fuzzy_feed == FeedMmPerMin::from_int(3000)));
    }

    #[test]
    fn slows_before_a_sharp_corner() {
        // 60 points along x, then a 150° turn: the feed drops within WS points
        // before the corner, not only at it.
        let mut pts: Vec<_> = (0..60).map(|i| pt(i as f64 * 0.1, 0.0)).collect();
        let turn = 150f64.to_radians();
        pts.extend((1..60).map(|i| {
            pt(
                5.9 + i as f64 * 0.1 * turn.cos(),
                i as f64 * 0.1 * turn.sin(),
            )
        }));
        let out = run(&pts);
        let corner = 59;
        assert!(out[corner].curvature.to_f64() > 3.0);
        assert_eq!(out[10].feed, FeedMmPerMin::from_int(3000));
        assert!(
            out[corner - 20].feed.to_f64() < 1500.0,
            "{:?}",
            out[corner - 20].feed
        );
        assert!(out[corner - 20].curvature == CurvaturePerMm::ZERO);
    }

    #[test]
    fn config_is_validated() {
        let bad = SchedulerConfig::new(FeedMmPerMin::from_int(100), FeedMmPerMin::from_int(200));
        assert!(Sched::new(&CONTROLLER, bad).is_err());
        let bad = SchedulerConfig::new(FeedMmPerMin::ZERO, FeedMmPerMin::ZERO);
        assert!(Sched::new(&CONTROLLER, bad).is_err());
    }
}
