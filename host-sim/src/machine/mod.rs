//! Simulated machines: commanded blocks and feeds in, predicted actual tool
//! motion out, both sampled at the interpolation period.
//!
//! - the acc/dec of a FANUC control (Dat & Phuc 2024), in its conventional
//!   and high-accuracy modes: [`crate::experiments::dat_phuc2024::fanuc`];
//! - Cho, Lee & Jeon's X-Y servo model (Tables 4.1-4.2):
//!   [`crate::experiments::cho::servo_xy`];
//! - [`accdec`]: the acc/dec filters both use.

pub mod accdec;

use crate::experiments::cho::servo_xy;
use crate::experiments::dat_phuc2024::fanuc;

use serde::{Deserialize, Serialize};

/// Commanded and actual motion, sampled every `ts_s` from `t = 0`.
#[derive(Clone, Debug, PartialEq)]
pub struct Motion {
    /// Sampling period (the interpolation period), s.
    pub ts_s: f64,
    /// Interpolated (commanded) positions, mm; held at the end point once
    /// the interpolation is done.
    pub commanded: Vec<[f64; 3]>,
    /// Predicted actual tool positions, mm.
    pub actual: Vec<[f64; 3]>,
}

impl Motion {
    /// A run's motion: the commanded positions held at their last point
    /// while the machine settles, so both series have the same length.
    pub fn padded(ts_s: f64, mut commanded: Vec<[f64; 3]>, actual: Vec<[f64; 3]>) -> Motion {
        if let Some(&end) = commanded.last() {
            commanded.resize(actual.len().max(commanded.len()), end);
        }
        Motion {
            ts_s,
            commanded,
            actual,
        }
    }

    /// Time from the start until the tool has arrived at the end, s.
    pub fn cycle_time_s(&self) -> f64 {
        (self.actual.len().saturating_sub(1)) as f64 * self.ts_s
    }
}

/// Which machine, with its parameters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum MachineConfig {
    /// The FANUC-like acc/dec machine.
    Fanuc(fanuc::FanucConfig),
    /// Cho et al.'s X-Y servo.
    ServoXy(servo_xy::ServoXyConfig),
}

impl Default for MachineConfig {
    fn default() -> Self {
        MachineConfig::Fanuc(Default::default())
    }
}

impl MachineConfig {
    /// A short label for reports.
    pub fn label(&self) -> String {
        match self {
            MachineConfig::Fanuc(f) => match f.mode {
                fanuc::FanucMode::Conventional => {
                    format!("fanuc-conventional (T1622 {} ms)", f.p1622_time_constant_ms)
                }
                fanuc::FanucMode::HighAccuracy => format!(
                    "fanuc-high-accuracy (T1769 {} ms, dF1783 {} mm/min)",
                    f.p1769_time_constant_ms, f.p1783_corner_feed_difference_mm_per_min
                ),
            },
            MachineConfig::ServoXy(_) => "servo-xy (Cho et al.)".into(),
        }
    }

    /// Check the parameters for interpolation period `ts_s`.
    pub fn validate(&self, ts_s: f64) -> anyhow::Result<()> {
        match self {
            MachineConfig::Fanuc(f) => f.validate(),
            MachineConfig::ServoXy(s) => s.validate(ts_s),
        }
    }

    /// The machine's acc/dec time constants, summed, s: at least the time
    /// its filters add after the interpolation ends.
    pub fn time_constants_s(&self) -> f64 {
        match self {
            MachineConfig::Fanuc(f) => match f.mode {
                fanuc::FanucMode::Conventional => f.p1622_time_constant_ms / 1000.0,
                fanuc::FanucMode::HighAccuracy => {
                    (f.p1769_time_constant_ms + f.p1772_bell_time_ms) / 1000.0
                }
            },
            MachineConfig::ServoXy(s) => s.accdec_time_constant_ms / 1000.0,
        }
    }

    /// Run the machine on `points` with `feeds_mm_per_min[i]` for the block
    /// ending at point `i`.
    pub fn simulate(&self, points: &[[f64; 3]], feeds_mm_per_min: &[f64], ts_s: f64) -> Motion {
        match self {
            MachineConfig::Fanuc(f) => f.simulate(points, feeds_mm_per_min, ts_s),
            MachineConfig::ServoXy(s) => s.simulate(points, feeds_mm_per_min, ts_s),
        }
    }
}
