//! What the operator sees: the live status line (state, position, feed,
//! override, buffer levels, progress, ETA) and the ETA estimate.

use std::fmt::Write as _;
use std::time::Duration;

use link::{Motion, Status};

/// I32F32 bits to f64.
pub fn bits_f64(b: i64) -> f64 {
    b as f64 / 4294967296.0
}

/// One look at the run, for the status line.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct View {
    /// The controller's last status.
    pub status: Status,
    /// Path commands the controller has queued (not yet scheduled).
    pub queued: u32,
    /// Commands the host may still send within the credit.
    pub credit: u32,
    /// Points of the program reached (from 1), `None` before the
    /// controller started on it.
    pub reached: Option<u32>,
    /// Points in the program.
    pub points: u32,
    /// Path length reached and in all, mm.
    pub done_mm: f64,
    /// Path length in all, mm.
    pub total_mm: f64,
    /// Estimated time left.
    pub eta: Option<Duration>,
    /// Since streaming started.
    pub elapsed: Duration,
    /// A feed hold is asked for (the controller may still be stopping).
    pub hold_asked: bool,
    /// A stop is under way.
    pub stopping: bool,
    /// What the controller waits for at rest between two paths, shown
    /// instead of its `Idle` (`Spin-up` after M3/M4, `Dwell`).
    pub waiting: Option<&'static str>,
}

/// The motion state as shown.
pub fn state_name(m: Motion) -> &'static str {
    match m {
        Motion::Idle => "Idle",
        Motion::Running => "Run",
        Motion::Held => "Hold",
        Motion::Starved => "Starved",
        Motion::Alarm => "Alarm",
        Motion::Homing => "Home",
    }
}

/// `m:ss` (or `h:mm:ss`).
pub fn clock(d: Duration) -> String {
    let s = d.as_secs();
    if s >= 3600 {
        format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
    } else {
        format!("{}:{:02}", s / 60, s % 60)
    }
}

impl View {
    /// Fraction of the path done (by length), 0..=1.
    pub fn fraction(&self) -> f64 {
        if self.total_mm > 0.0 {
            (self.done_mm / self.total_mm).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    /// The status line: state, position, feed, override, buffer levels,
    /// progress, ETA.
    pub fn line(&self) -> String {
        let s = &self.status;
        let [x, y, z] = s.pos_mm.map(bits_f64);
        let mut state = state_name(s.motion).to_string();
        if self.stopping {
            state = "Stop".into();
        } else if let (Some(w), Motion::Idle) = (self.waiting, s.motion) {
            state = w.into();
        } else if self.hold_asked && s.motion != Motion::Held {
            state.push('>');
            state.push_str("Hold");
        }
        let mut out = format!(
            "{state:<8} X{x:9.3} Y{y:9.3} Z{z:8.3}  F{:6.0}  ovr {:3}%  plan {:3} held {:2} queue {:2} credit {:2}",
            bits_f64(s.feed_mm_per_min),
            s.override_percent,
            s.planned_points,
            s.points_held,
            self.queued,
            self.credit,
        );
        // Without a program (`monitor`) there is no count to show it of.
        match (self.reached, self.points) {
            (Some(r), 0) => {
                let _ = write!(out, "  pt {r}");
            }
            (Some(r), n) => {
                let _ = write!(out, "  pt {r}/{n}");
            }
            (None, n) => {
                let _ = write!(out, "  pt -/{n}");
            }
        }
        match self.eta {
            Some(e) => {
                let _ = write!(out, "  ETA {}", clock(e));
            }
            None => out.push_str("  ETA -"),
        }
        out
    }

    /// A log line for unattended runs: elapsed time, progress, the status
    /// line.
    pub fn log_line(&self) -> String {
        format!(
            "[{:>7.1} s] {:5.1} %  {}",
            self.elapsed.as_secs_f64(),
            self.fraction() * 100.0,
            self.line()
        )
    }
}

/// The time left, from the host's schedule: the program's time (the
/// blocks at their scheduled feeds, capped to the machine's, and the
/// dwells) from where the tool is to the end, divided by the override,
/// times how much slower than that estimate the run has been so far (the
/// estimate has no acceleration; the factor learns it). Where the tool is
/// is the program's time done, `done_s`: to its position along the path,
/// between points too.
#[derive(Clone, Debug)]
pub struct Eta {
    /// The program's time at 100 %, s.
    total_s: f64,
    /// The estimate for what was done, at the overrides in force, s.
    est_done_s: f64,
    /// The time it took (moving or starved, not held), s.
    actual_s: f64,
    last: Option<(f64, f64)>,
}

/// Estimated seconds of progress needed before the run's own pace is
/// trusted.
const LEARN_AFTER_S: f64 = 0.5;

impl Eta {
    /// For a program of `total_s` at 100 % (`Program::cum_time_s`' last).
    pub fn new(total_s: f64) -> Self {
        Eta {
            total_s,
            est_done_s: 0.0,
            actual_s: 0.0,
            last: None,
        }
    }

    /// A status at `t_s` (s since the start): `done_s` of the program
    /// done, with this override, moving or not (held).
    pub fn update(&mut self, t_s: f64, done_s: f64, override_percent: u16, counts: bool) {
        if let Some((t0, d0)) = self.last {
            if counts {
                let pct = override_percent.max(1) as f64 / 100.0;
                self.est_done_s += (done_s - d0).max(0.0) / pct;
                self.actual_s += (t_s - t0).max(0.0);
            }
        }
        self.last = Some((t_s, done_s));
    }

    /// How much slower than the estimate the run is.
    pub fn pace(&self) -> f64 {
        if self.est_done_s < LEARN_AFTER_S {
            1.0
        } else {
            (self.actual_s / self.est_done_s).clamp(1.0, 50.0)
        }
    }

    /// Time left with `done_s` of the program done, at this override.
    pub fn left(&self, done_s: f64, override_percent: u16) -> Duration {
        let rest = (self.total_s - done_s).max(0.0);
        let pct = override_percent.max(1) as f64 / 100.0;
        Duration::from_secs_f64((rest / pct * self.pace()).min(1e7))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_line_shows_state_position_feed_buffers_and_eta() {
        let v = View {
            status: Status {
                motion: Motion::Running,
                pos_mm: [12i64 << 32, -(3i64 << 31), 0],
                feed_mm_per_min: 2500i64 << 32,
                override_percent: 80,
                planned_points: 112,
                points_held: 35,
                ..Status::default()
            },
            queued: 12,
            credit: 3,
            reached: Some(120),
            points: 2001,
            done_mm: 10.0,
            total_mm: 40.0,
            eta: Some(Duration::from_secs(75)),
            elapsed: Duration::from_millis(2500),
            hold_asked: false,
            stopping: false,
            waiting: None,
        };
        let l = v.line();
        for want in [
            "Run",
            "X   12.000",
            "Y   -1.500",
            "F  2500",
            "ovr  80%",
            "plan 112",
            "held 35",
            "queue 12",
            "credit  3",
            "pt 120/2001",
            "ETA 1:15",
        ] {
            assert!(l.contains(want), "{want:?} not in {l:?}");
        }
        assert!(
            v.log_line().starts_with("[    2.5 s]  25.0 %"),
            "{}",
            v.log_line()
        );
        let held = View {
            hold_asked: true,
            reached: None,
            eta: None,
            ..v
        };
        assert!(held.line().starts_with("Run>Hold"), "{}", held.line());
        assert!(held.line().contains("pt -/2001") && held.line().ends_with("ETA -"));
        assert_eq!(clock(Duration::from_secs(3725)), "1:02:05");
        // At rest for a spin-up: said so, not `Idle`.
        let spin = View {
            status: Status::default(),
            waiting: Some("Spin-up"),
            ..v
        };
        assert!(spin.line().starts_with("Spin-up"), "{}", spin.line());
        // `monitor`: no program, no count of points.
        let monitor = View {
            reached: Some(1),
            points: 0,
            ..View::default()
        };
        assert!(monitor.line().contains("pt 1  "), "{}", monitor.line());
        assert!(!monitor.line().contains("1/0"), "{}", monitor.line());
    }

    #[test]
    fn the_eta_follows_the_override_and_learns_the_pace() {
        // Ten seconds of program at 100 %.
        let mut e = Eta::new(10.0);
        assert_eq!(e.left(0.0, 100), Duration::from_secs(10));
        assert_eq!(e.left(5.0, 100), Duration::from_secs(5));
        assert_eq!(e.left(5.0, 50), Duration::from_secs(10));
        // Between points: half a second more done, half a second less.
        assert_eq!(e.left(5.5, 100), Duration::from_millis(4500));
        // The run takes twice the estimate: 2 s of program in 4 s.
        e.update(0.0, 0.0, 100, true);
        e.update(4.0, 2.0, 100, true);
        assert!((e.pace() - 2.0).abs() < 1e-9);
        assert_eq!(e.left(2.0, 100), Duration::from_secs(16));
        // A hold does not count.
        e.update(100.0, 2.0, 100, false);
        assert!((e.pace() - 2.0).abs() < 1e-9);
        // At 200 % the estimate halves: 2 s more in 2 s is the same pace.
        e.update(102.0, 4.0, 200, true);
        assert!((e.pace() - 2.0).abs() < 1e-9, "{}", e.pace());
        assert_eq!(e.left(10.0, 100), Duration::ZERO);
    }
}
