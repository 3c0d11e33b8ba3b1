//! [`Motion`]: the planner's one entry point, the lookahead and the executor
//! behind one buffer. Points go in through [`Motion::push`] (the lookahead),
//! ticks come out of [`Motion::tick`] (the executor); the only traffic
//! between the stages is the executor reading the plan and, once a tick,
//! the buffer dropping what the executor has left behind.

use super::config::{ConfigError, MotionConfig};
use super::executor::Executor;
use super::lookahead::Buffer;
use super::smoothing::Smoother;
use super::{MotionError, MotionPoint, MotionState, PlannedPoint, Tick};
use crate::units::{FeedMmPerMin, SpeedMmPerTick};

/// The streaming velocity planner and interpolation executor for up to `N`
/// buffered points. See the [module documentation](super).
#[derive(Clone, Debug)]
pub struct Motion<const N: usize> {
    plan: Buffer<N>,
    exec: Executor,
    smooth: Smoother,
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
            smooth: Smoother::new(lim.smoothing),
            plan: Buffer::new(lim),
            exec: Executor::default(),
        })
    }

    /// The finalized points still buffered, oldest first, with their
    /// effective ceilings and caps (override applied).
    pub fn planned(&self) -> impl Iterator<Item = PlannedPoint> + '_ {
        self.plan.plan().planned()
    }

    /// The tangential acceleration limit `ρ·min_a A_a`, mm/s².
    pub fn accel_limit_mm_s2(&self) -> fixed::types::I32F32 {
        let lim = self.plan.plan().lim();
        let t = lim.tick_us as i128;
        let per_s2 = (lim.accel as i128 * 1_000_000_000_000)
            .checked_div(t * t)
            .unwrap_or(0);
        fixed::types::I32F32::from_bits(per_s2.clamp(0, i64::MAX as i128) as i64)
    }

    /// Points that can still be pushed.
    pub fn free(&self) -> usize {
        self.plan.plan().free()
    }

    /// Whether the tool has no motion left (idle, starved at rest, held
    /// at rest, or done), the smoothed position included.
    pub fn at_rest(&self) -> bool {
        self.exec.at_rest() && self.smooth.settled()
    }

    /// A speed per tick (as in [`Tick::speed`]) in mm/min.
    pub fn speed_mm_per_min(&self, speed: SpeedMmPerTick) -> FeedMmPerMin {
        self.plan.plan().feed_of(speed.to_bits())
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
        let here = (self.plan.plan().len() > 0).then(|| self.exec.position(self.plan.plan()));
        self.plan.plan_mut().restart(here);
        self.exec.restart();
        Ok(())
    }

    /// Feed hold on/off: on, the tool decelerates (jerk-limited, within the
    /// acceleration limit) to rest on the path; off, it continues.
    pub fn set_hold(&mut self, on: bool) {
        self.exec.set_hold(on);
    }

    /// Feed override, percent of the programmed feed (clamped to 1-1000;
    /// the feed stays within the configured maximum and every physical
    /// limit). Re-plans the envelope of the buffered points (`O(N)`, once).
    /// A lower override slows the tool at the acceleration limit.
    pub fn set_override(&mut self, percent: u16) {
        let p = percent.clamp(1, 1000) as i64;
        self.plan.plan_mut().set_override_q16((p << 16) / 100);
    }

    /// Add the next point. The first point of a path is where the tool is.
    pub fn push(&mut self, p: MotionPoint) -> Result<(), MotionError> {
        self.plan.plan_mut().push(p)
    }

    /// The path ends at the last pushed point: plan the final stop there.
    pub fn end_path(&mut self) {
        self.plan.plan_mut().end_path();
    }

    /// One interpolation tick. With smoothing the position is the mean of
    /// the executor's last positions, and the tick's arc length, speed and
    /// acceleration are the executor's (ahead of the position by half the
    /// window); the state stays `Moving` until the mean has caught up.
    pub fn tick(&mut self) -> Tick {
        self.unstall();
        let mut state = self.exec.advance(self.plan.plan());
        self.drop_passed();
        let raw = self.exec.position(self.plan.plan());
        if self.plan.plan().len() == 0 {
            self.smooth.reset();
        }
        let pos = self.smooth.filter(raw);
        if !self.smooth.settled()
            && matches!(
                state,
                MotionState::Done | MotionState::Starved | MotionState::Idle
            )
        {
            state = MotionState::Moving;
        }
        self.exec.output(pos, state)
    }

    /// Free a full buffer stalled within the corner reach, with the tool
    /// at rest (`Lookahead::stalled`).
    fn unstall(&mut self) {
        if !self.exec.at_rest() || !self.plan.plan().stalled(self.exec.x()) {
            return;
        }
        if self.plan.plan().can_force() {
            self.plan.plan_mut().force_next();
            return;
        }
        self.exec.catch_up(self.plan.plan());
        if self.exec.seg() > 0 && self.plan.plan_mut().drop_stalled_front() {
            self.exec.front_dropped();
        }
    }

    /// Drop nodes more than the corner reach behind the executor.
    fn drop_passed(&mut self) {
        while self.exec.seg() > 0 && self.plan.plan_mut().drop_front_behind(self.exec.x()) {
            self.exec.front_dropped();
        }
    }
}
