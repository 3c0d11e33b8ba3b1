//! Spindle and coolant: the machine commands of the path stream
//! (`HostMsg::Machine`: M3/M4/M5 with S, M7/M8/M9) and the outputs they
//! set.
//!
//! Synchronisation, as Grbl's: a spindle or coolant change waits for the
//! motion before it to end (`grbl/spindle_control.c`, `spindle_sync`, and
//! `coolant_control.c`, `coolant_sync`: `protocol_buffer_synchronize`
//! empties the planner first). Here a machine command ends the open path
//! (the scheduler's lookahead is drained, the planner stops on the last
//! point before the command), takes effect once the tool is at rest there
//! (reported with the path index reached: `DeviceMsg::Applied`), and the
//! points after it form a new path. After a spindle start or a change of
//! direction (M3/M4) the next path waits the spin-up delay (`$207`), as a
//! G4 dwell would; a speed change alone or M5 does not wait.
//!
//! The speed becomes a PWM duty as Grbl's linear model
//! (`spindle_compute_pwm_value`): at or above the maximum speed (`$30`)
//! full duty, S0 off, up to the minimum speed (`$31`) the least duty, and
//! linear in between.

use link::{MachineCmd, SpindleDir};

use crate::config::{Config, Key};

/// What the spindle and coolant outputs are set to.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MachineOutputs {
    /// Spindle enable.
    pub spindle_on: bool,
    /// Spindle direction: counter-clockwise (M4).
    pub ccw: bool,
    /// PWM duty, 0 (off) to 65 535 (full).
    pub duty_q16: u16,
    /// Flood coolant (M8).
    pub flood: bool,
    /// Mist coolant (M7).
    pub mist: bool,
}

/// The least duty of a running spindle (Grbl's `SPINDLE_PWM_MIN_VALUE`, 1
/// of 255).
pub const MIN_DUTY_Q16: u16 = 257;

/// The PWM duty for `rpm` (module docs).
pub fn duty_q16(rpm: u32, c: &Config) -> u16 {
    let (lo, hi) = (c.get(Key::SpindleMin), c.get(Key::SpindleMax));
    let rpm = rpm as i64;
    if rpm == 0 {
        0
    } else if rpm >= hi || lo >= hi {
        u16::MAX
    } else if rpm <= lo {
        MIN_DUTY_Q16
    } else {
        let span = (u16::MAX - MIN_DUTY_Q16) as i64;
        let d = MIN_DUTY_Q16 as i64 + ((rpm - lo) * span).checked_div(hi - lo).unwrap_or(0);
        d.clamp(MIN_DUTY_Q16 as i64, u16::MAX as i64) as u16
    }
}

/// A 16-bit timer's prescaler and auto-reload (`PSC`, `ARR`, registers'
/// values: the counter counts `ARR + 1` at `timer_hz / (PSC + 1)`) for a
/// PWM period of `pwm_hz`, with the finest duty resolution (the smallest
/// prescaler whose count fits 16 bits). The frequency is met to the
/// rounding of the count.
pub fn pwm_timer(timer_hz: u32, pwm_hz: u32) -> (u16, u16) {
    let f = pwm_hz.max(1) as u64;
    let counts = timer_hz as u64 / f;
    let psc = counts.div_ceil(65_536).clamp(1, 65_536);
    let arr = ((timer_hz as u64 + (psc * f) / 2) / (psc * f)).clamp(2, 65_536) - 1;
    ((psc - 1) as u16, arr as u16)
}

/// The compare value for `duty_q16` of a period of `arr + 1` counts.
pub fn pwm_compare(duty_q16: u16, arr: u16) -> u16 {
    if duty_q16 == u16::MAX {
        // Full on: the compare beyond the count.
        return arr.saturating_add(1).max(arr);
    }
    ((duty_q16 as u32 * (arr as u32 + 1)) >> 16) as u16
}

/// The spindle's and coolant's state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Spindle {
    /// Direction, or off.
    pub dir: SpindleDir,
    /// Programmed speed, rpm.
    pub speed_rpm: u32,
    /// Flood coolant.
    pub flood: bool,
    /// Mist coolant.
    pub mist: bool,
    /// Speed override, percent of the programmed speed (`HostMsg::
    /// SpindleOverride`, Grbl's 0x99-0x9D): the output runs at the
    /// programmed speed times this, as Grbl's `spindle_set_speed` scales
    /// by `sys.spindle_speed_ovr`; it outlasts an M5 and an alarm (as
    /// Grbl's lasts until a reset, which the host sends as 100 %).
    pub override_percent: u16,
}

impl Default for Spindle {
    fn default() -> Self {
        Spindle {
            dir: SpindleDir::Off,
            speed_rpm: 0,
            flood: false,
            mist: false,
            override_percent: 100,
        }
    }
}

impl Spindle {
    /// Whether the spindle or a coolant output is on.
    pub fn any_on(&self) -> bool {
        self.dir != SpindleDir::Off || self.flood || self.mist
    }

    /// Apply `cmd`; whether the motion after it waits the spin-up delay
    /// (the spindle started or changed direction).
    pub fn apply(&mut self, cmd: MachineCmd) -> bool {
        match cmd {
            MachineCmd::Spindle { dir, speed_rpm } => {
                let spin_up = dir != SpindleDir::Off && dir != self.dir;
                self.dir = dir;
                self.speed_rpm = if dir == SpindleDir::Off { 0 } else { speed_rpm };
                spin_up
            }
            MachineCmd::Coolant { flood, mist } => {
                self.flood = flood;
                self.mist = mist;
                false
            }
            // The background waits it out, or rebuilds the planner; no
            // output changes.
            MachineCmd::Dwell { .. } | MachineCmd::PathControl(_) => false,
        }
    }

    /// Everything off (an alarm: Grbl's `mc_reset` stops the spindle and
    /// the coolant).
    pub fn stop(&mut self) {
        *self = Spindle {
            override_percent: self.override_percent,
            ..Spindle::default()
        };
    }

    /// The speed the output runs at: the programmed one with the
    /// override, rpm (saturating).
    pub fn output_rpm(&self) -> u32 {
        (self.speed_rpm as u64 * self.override_percent as u64 / 100).min(u32::MAX as u64) as u32
    }

    /// The outputs for this state.
    pub fn outputs(&self, c: &Config) -> MachineOutputs {
        let on = self.dir != SpindleDir::Off;
        MachineOutputs {
            spindle_on: on,
            ccw: self.dir == SpindleDir::Ccw,
            duty_q16: if on {
                duty_q16(self.output_rpm(), c)
            } else {
                0
            },
            flood: self.flood,
            mist: self.mist,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_duty_is_linear_between_the_speed_range_ends() {
        let mut c = Config::DEFAULT;
        c.set(30, 24_000).unwrap();
        c.set(31, 4_000).unwrap();
        assert_eq!(duty_q16(0, &c), 0, "S0 off");
        assert_eq!(duty_q16(1000, &c), MIN_DUTY_Q16);
        assert_eq!(duty_q16(24_000, &c), u16::MAX);
        assert_eq!(duty_q16(30_000, &c), u16::MAX);
        let mid = duty_q16(14_000, &c) as f64 / 65535.0;
        assert!((mid - 0.502).abs() < 0.002, "{mid}");
        let mut last = 0;
        for rpm in (4_000..=24_000).step_by(500) {
            let d = duty_q16(rpm, &c);
            assert!(d >= last);
            last = d;
        }
    }

    #[test]
    fn the_override_scales_the_output_and_outlasts_a_stop() {
        let mut c = Config::DEFAULT;
        c.set(30, 24_000).unwrap();
        c.set(31, 0).unwrap();
        let mut s = Spindle::default();
        s.apply(MachineCmd::Spindle {
            dir: SpindleDir::Cw,
            speed_rpm: 10_000,
        });
        let at = |s: &Spindle| s.outputs(&c).duty_q16;
        let full = at(&s);
        s.override_percent = 50;
        assert_eq!(s.output_rpm(), 5_000);
        assert_eq!(at(&s), duty_q16(5_000, &c));
        s.override_percent = 200;
        assert_eq!(at(&s), duty_q16(20_000, &c));
        assert!(at(&s) > full);
        assert_eq!(s.speed_rpm, 10_000, "the programmed speed is kept");
        s.stop();
        assert_eq!(s.override_percent, 200);
        assert_eq!(s.outputs(&c).duty_q16, 0);
    }

    #[test]
    fn the_pwm_timer_meets_the_frequency_with_the_finest_resolution() {
        for (hz, f) in [
            (84_000_000, 5000),
            (84_000_000, 1000),
            (84_000_000, 10),
            (84_000_000, 100_000),
        ] {
            let (psc, arr) = pwm_timer(hz, f);
            let got = hz as f64 / ((psc as f64 + 1.0) * (arr as f64 + 1.0));
            assert!((got - f as f64).abs() / (f as f64) < 1e-3, "{f} Hz: {got}");
            // One prescaler step less would overflow the count.
            assert!(psc == 0 || hz as u64 / psc as u64 / f as u64 > 65_536);
        }
        assert_eq!(pwm_timer(84_000_000, 5000), (0, 16_799));
        assert_eq!(pwm_compare(0, 999), 0);
        assert_eq!(pwm_compare(u16::MAX / 2 + 1, 999), 500);
        assert!(pwm_compare(u16::MAX, 999) > 999, "always on");
    }

    #[test]
    fn only_a_start_or_a_reversal_waits_the_spin_up() {
        let mut s = Spindle::default();
        let m = |dir, speed_rpm| MachineCmd::Spindle { dir, speed_rpm };
        assert!(s.apply(m(SpindleDir::Cw, 1000)));
        assert!(!s.apply(m(SpindleDir::Cw, 2000)), "a speed change");
        assert!(s.apply(m(SpindleDir::Ccw, 2000)), "a reversal");
        assert!(!s.apply(m(SpindleDir::Off, 2000)));
        assert_eq!(s.speed_rpm, 0);
        let c = Config::DEFAULT;
        assert_eq!(s.outputs(&c), MachineOutputs::default());
        s.apply(MachineCmd::Coolant {
            flood: true,
            mist: false,
        });
        s.apply(m(SpindleDir::Ccw, 500));
        let o = s.outputs(&c);
        assert!(o.spindle_on && o.ccw && o.flood && !o.mist);
        assert_eq!(o.duty_q16, duty_q16(500, &c));
    }
}
