//! The motion pipeline of the controller, without the chip:
//!
//! ```text
//! link (USART task) ──Cmd──► [spsc] ──► Feeder (idle: fuzzy scheduler,
//!     segment preparation) ──SegItem──► [spsc] ──► tick task (interpolator,
//!     step/dir outputs)
//! ```
//!
//! The [`Feeder`] turns queued commands into scheduled points
//! (`fuzzy_core::scheduler`) and those into interpolator segments
//! (`fuzzy_core::interpolator`); [`tick`] is the whole per-tick work of the
//! timer interrupt. Both run unchanged in the cost benchmark.

use fixed::types::I32F32;
use fuzzy_core::interpolator::{Interpolator, InterpolatorConfig, Segment, TickReport};
use fuzzy_core::lin2021::{Lin2021Controller, CONTROLLER};
use fuzzy_core::scheduler::{
    PathPoint, ScheduledPoint, Scheduler, SchedulerConfig, SchedulerError,
};
use fuzzy_core::units::{FeedMmPerMin, Point3Mm};
use heapless::spsc::Consumer;

use crate::config::{
    ACCEL_MM_PER_S2, AVG, F_MAX_MM_PER_MIN, F_MIN_MM_PER_MIN, INTERP_SEGMENTS, SCHED_CAP, TICK_HZ,
    WS,
};
use crate::stepper::StepOutput;

/// The scheduler as configured for the firmware.
pub type Sched = Scheduler<&'static Lin2021Controller, WS, AVG, SCHED_CAP>;
/// The interpolator as configured for the firmware.
pub type Interp = Interpolator<INTERP_SEGMENTS>;

/// The interpolator settings of this build.
pub const INTERP_CONFIG: InterpolatorConfig = InterpolatorConfig::new(TICK_HZ, ACCEL_MM_PER_S2);

/// The default scheduler settings (before any `StartPath`).
pub const SCHED_CONFIG: SchedulerConfig = SchedulerConfig::new(
    FeedMmPerMin::from_int(F_MAX_MM_PER_MIN),
    FeedMmPerMin::from_int(F_MIN_MM_PER_MIN),
);

/// A command that travels through the queue in order with the points.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum Cmd {
    /// Start a path with these settings (ends an open path first).
    StartPath(SchedulerConfig),
    /// The next point.
    Point(PathPoint),
    /// End of the path: flush the lookahead.
    EndPath,
}

/// What the scheduler hands the tick task.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum SegItem {
    /// Move along this segment.
    Seg(Segment),
    /// The path ends here (running out is not an underrun).
    EndOfPath,
}

/// The scheduler side of the pipeline (idle priority).
pub struct Feeder {
    sched: Sched,
    last_end: Point3Mm,
    draining: bool,
    after_drain: Option<SchedulerConfig>,
}

/// What one [`Feeder`] step produced.
// Returned by value once per step and consumed at once: no heap to box into.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Output {
    /// Nothing (a point entered the lookahead, or a setting changed).
    Nothing,
    /// A scheduled point and its segment.
    Point(ScheduledPoint, SegItem),
    /// The path is complete.
    PathEnd,
}

impl Feeder {
    /// A feeder with the default settings, the tool at `start`.
    pub fn new(start: Point3Mm) -> Result<Self, SchedulerError> {
        Ok(Feeder {
            sched: Sched::new(&CONTROLLER, SCHED_CONFIG)?,
            last_end: start,
            draining: false,
            after_drain: None,
        })
    }

    /// Whether it is flushing a finished path (then [`Self::drain`], not
    /// [`Self::command`]).
    pub fn is_draining(&self) -> bool {
        self.draining
    }

    /// Points held in the lookahead.
    pub fn held(&self) -> usize {
        self.sched.held()
    }

    /// The scheduler (for measurements).
    pub fn scheduler_mut(&mut self) -> &mut Sched {
        &mut self.sched
    }

    /// Take the next queued command. At most one output per call, so the
    /// caller needs room for one segment and one report.
    pub fn command(&mut self, cmd: Cmd) -> Result<Output, SchedulerError> {
        match cmd {
            Cmd::Point(p) => match self.sched.push(p)? {
                Some(s) => Ok(self.released(s)),
                None => Ok(Output::Nothing),
            },
            Cmd::EndPath => {
                self.sched.finish();
                self.draining = true;
                Ok(Output::Nothing)
            }
            Cmd::StartPath(config) => {
                config.validate()?;
                if self.sched.held() > 0 {
                    // An open path ends where the new one starts.
                    self.sched.finish();
                    self.draining = true;
                    self.after_drain = Some(config);
                } else {
                    self.sched.set_config(config)?;
                }
                Ok(Output::Nothing)
            }
        }
    }

    /// While draining: the next point of the finished path, then
    /// [`Output::PathEnd`] once.
    pub fn drain(&mut self) -> Output {
        if !self.draining {
            return Output::Nothing;
        }
        match self.sched.drain() {
            Some(s) => self.released(s),
            None => {
                self.draining = false;
                if let Some(c) = self.after_drain.take() {
                    // Validated when it was queued.
                    let _ = self.sched.set_config(c);
                }
                Output::PathEnd
            }
        }
    }

    /// A released point becomes a segment from the previous one.
    fn released(&mut self, s: ScheduledPoint) -> Output {
        let end = s.point.pos;
        let item = match Segment::between(self.last_end, end, s.feed, s.point.tag, &INTERP_CONFIG) {
            Ok(seg) => SegItem::Seg(seg),
            // Impossible: the scheduler refuses such points.
            Err(_) => SegItem::EndOfPath,
        };
        self.last_end = end;
        Output::Point(s, item)
    }
}

/// Feed hold, resume and override requests from the link, taken by the
/// next tick.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Controls {
    /// `Some(true)`: hold; `Some(false)`: resume.
    pub hold: Option<bool>,
    /// New feed override, percent (already range-checked).
    pub override_percent: Option<u16>,
}

/// One interpolator tick: take the segments the scheduler finished (as many
/// as fit), apply hold/resume/override, advance, drive the outputs.
pub fn tick<O: StepOutput>(
    interp: &mut Interp,
    segments: &mut Consumer<'_, SegItem>,
    controls: &mut Controls,
    outputs: &mut O,
) -> TickReport {
    while interp.free() > 0 {
        match segments.dequeue() {
            // Cannot fail: there is room (checked just above).
            Some(SegItem::Seg(s)) => {
                let _ = interp.push(s);
            }
            Some(SegItem::EndOfPath) => interp.end_path(),
            None => break,
        }
    }
    if let Some(hold) = controls.hold.take() {
        if hold {
            interp.hold();
        } else {
            interp.resume();
        }
    }
    if let Some(p) = controls.override_percent.take() {
        interp.set_override(p);
    }
    let r = interp.tick();
    outputs.update(r.position);
    r
}

/// A point from the link's raw fields, if every value is in range for the
/// scheduler (so that an acknowledged point is never refused later).
pub fn point_from_link(
    seq: u32,
    pos_mm: [i64; 3],
    feed_cap_mm_per_min: Option<i64>,
) -> Option<PathPoint> {
    let pos = Point3Mm::from_bits(pos_mm[0], pos_mm[1], pos_mm[2]);
    if !pos.within_limits() {
        return None;
    }
    let feed_cap = match feed_cap_mm_per_min {
        Some(bits) => {
            let f = FeedMmPerMin(I32F32::from_bits(bits));
            if !f.within_limits() {
                return None;
            }
            Some(f)
        }
        None => None,
    };
    Some(PathPoint {
        pos,
        feed_cap,
        tag: seq,
    })
}

/// Scheduler settings from the link's raw fields, if valid.
pub fn config_from_link(f_max_bits: i64, f_min_bits: i64) -> Option<SchedulerConfig> {
    let c = SchedulerConfig::new(
        FeedMmPerMin(I32F32::from_bits(f_max_bits)),
        FeedMmPerMin(I32F32::from_bits(f_min_bits)),
    );
    c.validate().ok().map(|_| c)
}
