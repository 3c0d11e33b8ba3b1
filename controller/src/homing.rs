//! The homing cycle (Grbl's `$H`): per axis, seek the limit switch at the
//! seek rate, back off, locate it again at the slow locate feed, pull off;
//! then that axis's machine coordinate is set. Following Grbl 1.1
//! (`grbl/limits.c`, `limits_go_home`, with `N_HOMING_LOCATE_CYCLE` 1):
//! - the passes (`$44`-`$46`, grblHAL's; Grbl's `HOMING_CYCLE_0..2`,
//!   default Z, then X and Y) run in order; unlike Grbl, the axes of a
//!   pass home one after another (X, Y, Z order), not together;
//! - towards the maximum unless the axis's bit of `$23` is set; the seek
//!   searches 1.5 × the travel (`HOMING_AXIS_SEARCH_SCALAR`), the locate 5
//!   × the pull-off (`HOMING_AXIS_LOCATE_SCALAR`), both moves away are the
//!   pull-off (`$27`) at the seek rate (`$25`), the locate at `$24`;
//! - on the switch the axis stops at once (Grbl's homing axis lock: the
//!   tick halts, [`crate::alarm::Phase::Halt`]), at the seek rate too: the
//!   locate pass at the slow feed is what sets the position;
//! - between moves the tool rests for the ring's depth plus the input
//!   debounce (Grbl's `$26` delay), so that the switch's state is read
//!   with the tool at rest at the move's end;
//! - failures as Grbl's alarms 8 and 9: the switch not found within the
//!   search ([`AlarmCode::HomingNoSwitch`]), still active after a move
//!   away ([`AlarmCode::HomingPullOff`]);
//! - the pull-off point becomes `−pull-off` (homing towards the maximum)
//!   or `−travel + pull-off` (towards the minimum) in Grbl's machine space
//!   `[−travel, 0]` ([`crate::config::Config::travel_bits`]).
//!
//! Moves are trapezoidal at the axis's acceleration (`$120`-`$122`), in
//! per-tick fixed point (I32F32 mm, mm/tick, mm/tick²); the cycle produces
//! the setpoints the background puts in the ring in place of the planner's.

use fuzzy_core::planner::MotionState;
use fuzzy_core::units::Point3Mm;
use link::AlarmCode;

use crate::alarm::limit_bit;
use crate::config::{Config, Key};
use crate::planning::Setpoint;
use crate::settings::SETPOINT_RING;

/// Which move of an axis's cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// Towards the switch at the seek rate.
    Seek,
    /// Away by the pull-off.
    BackOff,
    /// Towards the switch at the locate feed.
    Locate,
    /// Away by the pull-off: the axis's home.
    PullOff,
}

impl Stage {
    fn approach(self) -> bool {
        matches!(self, Stage::Seek | Stage::Locate)
    }
}

/// One straight move of one axis, trapezoidal, in per-tick units (Q32).
#[derive(Clone, Copy, Debug)]
struct Move {
    axis: usize,
    /// +1 or −1.
    sign: i64,
    /// Distance left, mm (Q32).
    left: i64,
    /// Speed, mm/tick (Q32).
    v: i64,
    rate: i64,
    accel: i64,
}

impl Move {
    /// The next tick's step along the move (0 once done).
    fn step(&mut self) -> i64 {
        if self.left <= 0 {
            self.v = 0;
            return 0;
        }
        // Decelerate when the stopping distance v²/2a reaches what is left.
        let stop = (self.v as i128 * self.v as i128 / (2 * self.accel.max(1)) as i128) as i64;
        self.v = if stop >= self.left {
            (self.v - self.accel).max(self.accel)
        } else {
            (self.v + self.accel).min(self.rate)
        };
        let d = self.v.min(self.left);
        self.left -= d;
        d * self.sign
    }
}

/// What the cycle wants after a setpoint.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Event {
    /// Carry on.
    None,
    /// Watch this input and halt the tick when it is active (an approach
    /// starts), or stop watching (`None`).
    Watch(Option<u8>),
    /// Failed: raise this alarm.
    Failed(AlarmCode),
    /// Every axis is homed: the tool rests at the last setpoint.
    Done,
}

/// A homing cycle in progress.
#[derive(Clone, Copy, Debug)]
pub struct Cycle {
    /// Axes still to home, in order (bit masks of the passes, X first
    /// within one).
    queue: [u8; 3],
    axis: usize,
    stage: Stage,
    mv: Move,
    /// Ticks of rest left after the move.
    dwell: u32,
    rest_ticks: u32,
    pos: Point3Mm,
    /// Axes homed so far.
    homed: u8,
    started: bool,
    seek: i64,
    locate: i64,
    pull_off: i64,
    /// Axes homing towards their minimum (`$23`).
    to_min: u8,
    /// Travel per axis, mm (Q32).
    travel: [i64; 3],
    /// Acceleration per axis, mm/tick² (Q32).
    accel: [i64; 3],
}

/// mm/min as mm/tick (Q32).
fn per_tick(mm_per_min: i64, tick_us: u32) -> i64 {
    (((mm_per_min as i128) << 32) * tick_us as i128 / 60_000_000) as i64
}

impl Cycle {
    /// A cycle over `axes` (0: every pass of the settings) from `pos`;
    /// `None` if no axis is to be homed.
    pub fn new(config: &Config, axes: u8, pos: Point3Mm) -> Option<Cycle> {
        let mut queue = config.homing_passes();
        if axes != 0 {
            // Named axes keep the passes' order; those in no pass go last.
            let listed = queue.iter().fold(0, |m, p| m | p);
            for p in queue.iter_mut() {
                *p &= axes;
            }
            queue[2] |= axes & !listed & 7;
        }
        let first = first_axis(&queue)?;
        let t = config.tick_us();
        let mut c = Cycle {
            queue,
            axis: first,
            stage: Stage::Seek,
            mv: Move {
                axis: first,
                sign: 1,
                left: 0,
                v: 0,
                rate: 0,
                accel: 1,
            },
            dwell: 0,
            rest_ticks: SETPOINT_RING as u32 + config.get(Key::Debounce) as u32 + 1,
            pos,
            homed: 0,
            started: false,
            seek: per_tick(config.get(Key::HomingSeek), t).max(1),
            locate: per_tick(config.get(Key::HomingFeed), t).max(1),
            pull_off: config.pull_off_bits(),
            to_min: (config.get(Key::HomingDirInvert) & 7) as u8,
            travel: [0, 1, 2].map(|a| config.travel_len_bits(a)),
            accel: [Key::AccelX, Key::AccelY, Key::AccelZ].map(|k| {
                let t = t as i128;
                let a = ((config.get(k) as i128) << 32) * t * t / 1_000_000_000_000;
                (a as i64).max(1)
            }),
        };
        c.begin(Stage::Seek);
        Some(c)
    }

    /// The axis being homed.
    pub fn axis(&self) -> usize {
        self.axis
    }

    /// The move under way.
    pub fn stage(&self) -> Stage {
        self.stage
    }

    /// Axes homed so far.
    pub fn homed(&self) -> u8 {
        self.homed
    }

    /// The switch of the axis being homed.
    fn switch(&self) -> u8 {
        limit_bit(self.axis, !self.homes_to_min(self.axis))
    }

    fn homes_to_min(&self, a: usize) -> bool {
        self.to_min & 1 << a != 0
    }

    fn begin(&mut self, stage: Stage) {
        let a = self.axis.min(2);
        let towards: i64 = if self.homes_to_min(a) { -1 } else { 1 };
        let (sign, left, rate) = match stage {
            Stage::Seek => (towards, self.travel[a].saturating_mul(3) / 2, self.seek),
            Stage::BackOff | Stage::PullOff => (-towards, self.pull_off, self.seek),
            Stage::Locate => (towards, self.pull_off.saturating_mul(5), self.locate),
        };
        self.stage = stage;
        self.mv = Move {
            axis: a,
            sign,
            left,
            v: 0,
            rate,
            accel: self.accel[a],
        };
        self.dwell = self.rest_ticks;
    }

    /// The watch the current stage needs.
    fn watch(&self) -> Option<u8> {
        self.stage.approach().then(|| self.switch())
    }

    /// The next setpoint, and what the cycle wants (`inputs`: the debounced
    /// inputs the tick published).
    pub fn next(&mut self, inputs: u8) -> (Setpoint, Event) {
        let mut event = Event::None;
        if !self.started {
            self.started = true;
            event = Event::Watch(self.watch());
        }
        let d = self.mv.step();
        let moving = d != 0;
        if moving {
            let mut b = self.pos.to_bits();
            if let Some(c) = b.get_mut(self.mv.axis) {
                *c = c.saturating_add(d);
            }
            self.pos = Point3Mm::from_bits(b[0], b[1], b[2]);
        } else if self.dwell > 0 {
            self.dwell -= 1;
        } else {
            event = self.stage_done(inputs);
        }
        let sp = Setpoint {
            pos: self.pos,
            feed_q12: 0,
            state: if moving {
                MotionState::Moving
            } else {
                MotionState::Idle
            },
            moving,
        };
        (sp, event)
    }

    /// A move and its rest are over without a halt.
    fn stage_done(&mut self, inputs: u8) -> Event {
        let a = self.axis as u8;
        match self.stage {
            // The search ended without the switch.
            Stage::Seek | Stage::Locate => Event::Failed(AlarmCode::HomingNoSwitch { axis: a }),
            Stage::BackOff if inputs & self.switch() != 0 => {
                Event::Failed(AlarmCode::HomingPullOff { axis: a })
            }
            Stage::BackOff => {
                self.begin(Stage::Locate);
                Event::Watch(self.watch())
            }
            Stage::PullOff if inputs & self.switch() != 0 => {
                Event::Failed(AlarmCode::HomingPullOff { axis: a })
            }
            Stage::PullOff => {
                self.homed |= 1 << self.axis;
                if let Some(p) = self.queue.iter_mut().find(|p| **p != 0) {
                    *p &= !(1 << self.axis);
                }
                match first_axis(&self.queue) {
                    Some(next) => {
                        self.axis = next;
                        self.begin(Stage::Seek);
                        Event::Watch(self.watch())
                    }
                    None => Event::Done,
                }
            }
        }
    }

    /// The tick halted on the switch at `pos` (an approach found it): the
    /// move away starts there. Returns the watch for it (none).
    pub fn on_halt(&mut self, pos: Point3Mm) -> Option<u8> {
        self.pos = pos;
        match self.stage {
            Stage::Seek => self.begin(Stage::BackOff),
            Stage::Locate => self.begin(Stage::PullOff),
            // A halt outside an approach cannot come (nothing is watched):
            // the current move restarts from where the tool is.
            s => self.begin(s),
        }
        self.watch()
    }

    /// The machine coordinates of the homed axes at the cycle's end
    /// (`pos`, where the tool rests): the pull-off point of each homed
    /// axis, the others unchanged.
    pub fn home_position(&self, pos: Point3Mm) -> Point3Mm {
        let mut b = pos.to_bits();
        for (a, (c, travel)) in b.iter_mut().zip(self.travel).enumerate() {
            if self.homed & 1 << a != 0 {
                *c = if self.homes_to_min(a) {
                    self.pull_off.saturating_sub(travel)
                } else {
                    -self.pull_off
                };
            }
        }
        Point3Mm::from_bits(b[0], b[1], b[2])
    }
}

/// The first axis of the first non-empty pass.
fn first_axis(queue: &[u8; 3]) -> Option<usize> {
    let p = queue.iter().find(|p| **p != 0)?;
    (0..3).find(|a| p & 1 << a != 0)
}
