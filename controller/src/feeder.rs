//! Commands into the fuzzy scheduler: the first stage of the controller's
//! motion path (`Cmd` → [`Feeder`] → `ScheduledPoint` → `planning`).
//!
//! A path is `StartPath`, its points, `EndPath`. The scheduler releases a
//! point once its lookahead is complete; at `EndPath` it is drained, one
//! point per call, then [`Feeder::take_path_end`] says the path is
//! complete, once. A `StartPath`
//! that arrives while a path is still open ends that path first (its
//! lookahead is drained), then the new settings take effect.

use fixed::types::I32F32;
use fuzzy_core::scheduler::{PathPoint, ScheduledPoint, SchedulerConfig, SchedulerError};
use fuzzy_core::units::FeedMmPerMin;

use crate::command::Cmd;
use crate::settings::{Sched, SCHED_CONFIG};

/// The scheduler side of the motion path.
pub struct Feeder {
    sched: Sched,
    draining: bool,
    /// The drained path's end, not yet taken ([`Feeder::take_path_end`]).
    ended: bool,
    after_drain: Option<SchedulerConfig>,
}

impl Feeder {
    /// A feeder with the default settings ([`SCHED_CONFIG`]).
    pub fn new() -> Result<Self, SchedulerError> {
        Ok(Feeder {
            sched: Sched::new(&fuzzy_core::lin2021::COMPACT, SCHED_CONFIG)?,
            draining: false,
            ended: false,
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

    /// Take the next queued command: the point whose lookahead it
    /// completed, if any.
    // Inlined, and the scheduler's own result type: the scheduled point
    // is written straight into the caller's slot.
    #[inline(always)]
    pub fn command(&mut self, cmd: Cmd) -> Result<Option<ScheduledPoint>, SchedulerError> {
        match cmd {
            Cmd::Point { pos, feed_cap, tag } => self.sched.push(PathPoint {
                pos,
                feed_cap: (feed_cap >= 0).then_some(FeedMmPerMin(I32F32::from_bits(feed_cap))),
                tag,
            }),
            // A machine command or a probing move ends the path (the
            // background holds it until the motion reaches it).
            Cmd::EndPath | Cmd::Machine { .. } | Cmd::Probe { .. } => {
                self.sched.finish();
                self.draining = true;
                Ok(None)
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
                Ok(None)
            }
        }
    }

    /// While draining: the next point of the finished path; `None` once it
    /// is complete (then [`Self::take_path_end`] says so, once).
    #[inline(always)]
    pub fn drain(&mut self) -> Option<ScheduledPoint> {
        if !self.draining {
            return None;
        }
        let next = self.sched.drain();
        if next.is_none() {
            self.draining = false;
            self.ended = true;
            if let Some(c) = self.after_drain.take() {
                // Validated when it was queued.
                let _ = self.sched.set_config(c);
            }
        }
        next
    }

    /// Whether a path was completed since the last call: its last point
    /// was released.
    pub fn take_path_end(&mut self) -> bool {
        core::mem::take(&mut self.ended)
    }

    /// Drop the path (an abort): the points in the lookahead, a pending
    /// change of settings. Returns how many points were dropped.
    pub fn abort(&mut self) -> u32 {
        let held = self.sched.held() as u32;
        self.sched.abort();
        self.draining = false;
        self.ended = false;
        self.after_drain = None;
        held
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fuzzy_core::units::Point3Mm;

    fn point(i: u32) -> Cmd {
        Cmd::Point {
            pos: Point3Mm::from_bits(i as i64 * (1 << 30), 0, 0),
            feed_cap: -1,
            tag: i,
        }
    }

    /// What comes out, in order: `Some(point)`, `None` for a path's end.
    fn run(f: &mut Feeder, cmds: &[Cmd]) -> Vec<Option<ScheduledPoint>> {
        let mut out = Vec::new();
        let mut take = |f: &mut Feeder, p: Option<ScheduledPoint>| {
            out.extend(p.map(Some));
            if f.take_path_end() {
                out.push(None);
            }
        };
        for c in cmds {
            while f.is_draining() {
                let p = f.drain();
                take(f, p);
            }
            let p = f.command(*c).unwrap();
            take(f, p);
        }
        while f.is_draining() {
            let p = f.drain();
            take(f, p);
        }
        out
    }

    #[test]
    fn every_point_comes_out_once_in_order_then_the_path_end() {
        let mut f = Feeder::new().unwrap();
        let cmds: Vec<Cmd> = core::iter::once(Cmd::StartPath(SCHED_CONFIG))
            .chain((0..100).map(point))
            .chain([Cmd::EndPath])
            .collect();
        let out = run(&mut f, &cmds);
        assert_eq!(out.len(), 101);
        for (i, o) in out[..100].iter().enumerate() {
            let s = o.unwrap_or_else(|| panic!("{i}: a path end"));
            assert_eq!((s.point.tag, s.index), (i as u32, i as u32));
        }
        assert_eq!(out[100], None, "the path's end");
        assert_eq!(f.held(), 0);
        assert!(!f.is_draining());
    }

    #[test]
    fn a_start_path_ends_the_open_path_first_then_applies_its_settings() {
        let mut f = Feeder::new().unwrap();
        let slow = SchedulerConfig::new(FeedMmPerMin::from_int(600), FeedMmPerMin::from_int(60));
        let mut cmds: Vec<Cmd> = (0..50).map(point).collect();
        cmds.push(Cmd::StartPath(slow));
        cmds.extend((50..60).map(point));
        cmds.push(Cmd::EndPath);
        let out = run(&mut f, &cmds);
        let ends: Vec<usize> = out
            .iter()
            .enumerate()
            .filter(|(_, o)| o.is_none())
            .map(|(i, _)| i)
            .collect();
        assert_eq!(ends, vec![50, 61], "two paths");
        let s = out[51].expect("a point");
        assert_eq!(s.index, 0, "the second path starts its own indices");
        assert!(s.feed.to_f64() <= 600.0, "with its own F_max");
    }

    #[test]
    fn an_abort_drops_the_lookahead_and_a_new_path_starts_clean() {
        let mut f = Feeder::new().unwrap();
        let out = run(&mut f, &(0..20).map(point).collect::<Vec<_>>());
        assert!(out.is_empty(), "all still in the lookahead");
        assert_eq!(f.abort(), 20);
        assert_eq!(f.held(), 0);
        let out = run(&mut f, &[point(100), point(101), Cmd::EndPath]);
        let idx: Vec<u32> = out.iter().flatten().map(|s| s.index).collect();
        assert_eq!(idx, vec![0, 1], "indices restart");
    }

    #[test]
    fn bad_settings_are_refused_and_change_nothing() {
        let mut f = Feeder::new().unwrap();
        let bad = SchedulerConfig::new(FeedMmPerMin::from_int(0), FeedMmPerMin::from_int(0));
        assert!(f.command(Cmd::StartPath(bad)).is_err());
        let out = run(&mut f, &[point(0), point(1), Cmd::EndPath]);
        assert_eq!(out.len(), 3);
    }
}
