//! What travels from the link to the scheduler, in order: path commands,
//! checked when they arrive so that an acknowledged command is never
//! refused later, and never accepted when it could not make progress.

use fixed::types::I32F32;
use fuzzy_core::scheduler::{PathPoint, SchedulerConfig};
use fuzzy_core::units::{FeedMmPerMin, Point3Mm};

/// A command that travels through the queue in order with the points
/// (40 bytes: the queue's slots are most of the link's RAM).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Cmd {
    /// Start a path with these settings (ends an open path first).
    StartPath(SchedulerConfig),
    /// The next point.
    Point {
        /// Position.
        pos: Point3Mm,
        /// Feed cap, mm/min (I32F32 bits; negative: none).
        feed_cap: i64,
        /// Its sequence number.
        tag: u32,
    },
    /// End of the path: flush the lookahead.
    EndPath,
    /// A machine command (spindle, coolant): ends the open path and takes
    /// effect once the tool is at rest at its end (`crate::spindle`).
    Machine {
        /// Its sequence number.
        seq: u32,
        /// What.
        cmd: link::MachineCmd,
    },
    /// A probing move ([`crate::probe::ProbeCmd`], its fields inline so
    /// that the command keeps its size): ends the open path, runs once the
    /// tool is at rest at its end.
    Probe {
        /// The end of the move.
        target: Point3Mm,
        /// Its feed.
        feed: FeedMmPerMin,
        /// Its sequence number.
        seq: u32,
        /// Stop on the input becoming active, else inactive.
        toward: bool,
        /// No trip by the target is an alarm.
        error_if_missed: bool,
    },
}

impl From<crate::probe::ProbeCmd> for Cmd {
    fn from(p: crate::probe::ProbeCmd) -> Cmd {
        Cmd::Probe {
            target: p.target,
            feed: p.feed,
            seq: p.seq,
            toward: p.toward,
            error_if_missed: p.error_if_missed,
        }
    }
}

impl Cmd {
    /// A point command.
    pub fn point(p: PathPoint) -> Cmd {
        Cmd::Point {
            pos: p.pos,
            feed_cap: p.feed_cap.map_or(-1, |f| f.0.to_bits()),
            tag: p.tag,
        }
    }
}

/// The slowest feed a path may ask for, mm/min: a feed cap or an F_max
/// below it is refused (a path one bit of feed above zero would be
/// accepted and then never finish). Grbl keeps the same floor
/// (`MINIMUM_FEED_RATE`, 1.0 mm/min, `grbl/config.h`); the scheduler's
/// slowest output is then a tenth of it, at which the planner still
/// advances by thousands of position quanta a tick.
pub const MIN_FEED_MM_PER_MIN: FeedMmPerMin = FeedMmPerMin::from_int(1);

/// A point from the link's raw fields, if every value is in range for the
/// scheduler (so that an acknowledged point is never refused later) and its
/// feed cap, if any, at least [`MIN_FEED_MM_PER_MIN`].
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
            if !f.within_limits() || f < MIN_FEED_MM_PER_MIN {
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

/// Scheduler settings from the link's raw fields, if valid and F_max is
/// at least [`MIN_FEED_MM_PER_MIN`].
pub fn config_from_link(f_max_bits: i64, f_min_bits: i64) -> Option<SchedulerConfig> {
    let c = SchedulerConfig::new(
        FeedMmPerMin(I32F32::from_bits(f_max_bits)),
        FeedMmPerMin(I32F32::from_bits(f_min_bits)),
    );
    (c.f_max >= MIN_FEED_MM_PER_MIN && c.validate().is_ok()).then_some(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_point_round_trips_through_its_command() {
        let p = point_from_link(7, [1 << 32, -(3 << 31), 5], Some(1200 << 32)).unwrap();
        let Cmd::Point { pos, feed_cap, tag } = Cmd::point(p) else {
            panic!("not a point")
        };
        assert_eq!(pos.to_bits(), [1 << 32, -(3 << 31), 5]);
        assert_eq!(feed_cap, 1200 << 32);
        assert_eq!(tag, 7);
        let Cmd::Point { feed_cap, .. } = Cmd::point(PathPoint {
            feed_cap: None,
            ..p
        }) else {
            panic!("not a point")
        };
        assert_eq!(feed_cap, -1, "no cap");
    }

    #[test]
    fn a_command_stays_within_its_queue_slot() {
        assert!(core::mem::size_of::<Cmd>() <= 40);
    }

    #[test]
    fn out_of_range_values_are_refused() {
        // Beyond ±100 m.
        assert!(point_from_link(0, [200_000 << 32, 0, 0], None).is_none());
        // A negative feed cap.
        assert!(point_from_link(0, [0; 3], Some(-1)).is_none());
        // F_min above F_max, zero F_max.
        assert!(config_from_link(60 << 32, 3000 << 32).is_none());
        assert!(config_from_link(0, 0).is_none());
        assert!(config_from_link(3000 << 32, 60 << 32).is_some());
    }

    #[test]
    fn feeds_that_could_not_make_progress_are_refused() {
        // One bit above zero, and just under the floor.
        assert!(config_from_link(1, 0).is_none());
        assert!(config_from_link((1 << 32) - 1, 0).is_none());
        assert!(config_from_link(1 << 32, 0).is_some());
        assert!(point_from_link(0, [0; 3], Some(1)).is_none());
        assert!(point_from_link(0, [0; 3], Some(0)).is_none());
        assert!(point_from_link(0, [0; 3], Some(1 << 32)).is_some());
    }
}
