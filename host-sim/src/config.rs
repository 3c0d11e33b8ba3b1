//! The TOML configuration of a simulation: interpolation period, machine and
//! methods (including the fuzzy controller's settings). Every field has a
//! default (`host-sim config` prints them all); unknown keys are errors, so
//! a typo cannot silently fall back to a default.

use std::path::Path;

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};

use crate::gcode::GcodeSettings;
use crate::machine::MachineConfig;
use crate::methods::MethodSettings;
use crate::planner::PlannerSettings;

/// Default of `max_motion_samples`: 2.8 h of motion at 1 ms, about 1.5 GB
/// for the commanded and actual positions and the measures taken of them.
pub const DEFAULT_MAX_MOTION_SAMPLES: u64 = 10_000_000;

/// Default of `max_plan_ticks`: 27.8 h of motion at 1 ms. `plan` keeps
/// no tick beyond a bounded record, so this bounds its running time
/// (host-sim/README.md, "Memory of long runs"), not its memory.
pub const DEFAULT_MAX_PLAN_TICKS: u64 = 100_000_000;

/// A whole configuration file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SimConfig {
    /// Interpolation period Ts, ms (FANUC 30i: 1 ms).
    pub interpolation_period_ms: f64,
    /// Most samples (interpolation periods) one simulated motion may have;
    /// a run that would need more is refused before it allocates.
    pub max_motion_samples: u64,
    /// Most ticks `plan` runs one toolpath for; a longer run is refused
    /// before it starts.
    pub max_plan_ticks: u64,
    /// The simulated machine.
    pub machine: MachineConfig,
    /// The scheduling methods' settings.
    pub methods: MethodSettings,
    /// How G-code becomes a toolpath.
    pub gcode: GcodeSettings,
    /// The velocity planner of the `fuzzy-planner` method and of `plan`
    /// (fuzzy-core's `MotionConfig`).
    pub planner: PlannerSettings,
}

impl Default for SimConfig {
    fn default() -> Self {
        SimConfig {
            interpolation_period_ms: 1.0,
            max_motion_samples: DEFAULT_MAX_MOTION_SAMPLES,
            max_plan_ticks: DEFAULT_MAX_PLAN_TICKS,
            machine: MachineConfig::default(),
            methods: MethodSettings::default(),
            gcode: GcodeSettings::default(),
            planner: PlannerSettings::default(),
        }
    }
}

impl SimConfig {
    /// Interpolation period, s.
    pub fn ts_s(&self) -> f64 {
        self.interpolation_period_ms / 1000.0
    }

    /// Parse TOML text (errors carry TOML's line and column).
    pub fn parse(text: &str) -> Result<Self> {
        let c: SimConfig = toml::from_str(text)?;
        c.validate()?;
        Ok(c)
    }

    /// Read a TOML file.
    pub fn read(path: &Path) -> Result<Self> {
        let text =
            std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
        Self::parse(&text).with_context(|| format!("in {}", path.display()))
    }

    /// The configuration as TOML.
    pub fn to_toml(&self) -> String {
        toml::to_string(self).unwrap_or_default()
    }

    /// Check every value.
    pub fn validate(&self) -> Result<()> {
        anyhow::ensure!(
            self.interpolation_period_ms.is_finite()
                && self.interpolation_period_ms >= 0.01
                && self.interpolation_period_ms <= 100.0,
            "interpolation_period_ms must be in [0.01, 100]"
        );
        anyhow::ensure!(
            self.max_motion_samples >= 1000,
            "max_motion_samples must be at least 1000"
        );
        anyhow::ensure!(
            self.max_plan_ticks >= 1000,
            "max_plan_ticks must be at least 1000"
        );
        self.machine.validate(self.ts_s())?;
        self.planner.validate(self.ts_s())?;
        self.methods.grbl_like.validate()?;
        self.methods.blend.validate()?;
        let f = &self.methods.fuzzy;
        anyhow::ensure!(
            f.f_min_mm_per_min.is_finite() && f.f_min_mm_per_min >= 0.0,
            "methods.fuzzy.f_min_mm_per_min must be ≥ 0"
        );
        anyhow::ensure!(
            crate::methods::SUPPORTED_WS.contains(&f.lookahead_points),
            "methods.fuzzy.lookahead_points must be one of {:?}",
            crate::methods::SUPPORTED_WS
        );
        anyhow::ensure!(
            crate::methods::SUPPORTED_AVG.contains(&f.average_points),
            "methods.fuzzy.average_points must be one of {:?}",
            crate::methods::SUPPORTED_AVG
        );
        anyhow::ensure!(
            f.variation_clip_per_mm.is_finite()
                && f.variation_clip_per_mm > 0.0
                && f.variation_clip_per_mm <= 32767.0,
            "methods.fuzzy.variation_clip_per_mm must be in (0, 32767]"
        );
        self.gcode.validate()?;
        let g = &self.gcode;
        anyhow::ensure!(
            g.chord_tolerance_mm.is_finite() && g.chord_tolerance_mm > 0.0,
            "gcode.chord_tolerance_mm must be > 0"
        );
        anyhow::ensure!(
            g.rapid_feed_mm_per_min.is_finite()
                && g.rapid_feed_mm_per_min > 0.0
                && g.rapid_feed_mm_per_min <= 1e6,
            "gcode.rapid_feed_mm_per_min must be in (0, 1e6]"
        );
        let c = &self.methods.chord_error;
        anyhow::ensure!(
            c.tolerance_mm.is_finite() && c.tolerance_mm > 0.0,
            "methods.chord_error.tolerance_mm must be > 0"
        );
        anyhow::ensure!(
            c.max_acceleration_mm_per_s2.is_finite() && c.max_acceleration_mm_per_s2 > 0.0,
            "methods.chord_error.max_acceleration_mm_per_s2 must be > 0"
        );
        anyhow::ensure!(
            c.f_min_mm_per_min.is_finite() && c.f_min_mm_per_min > 0.0,
            "methods.chord_error.f_min_mm_per_min must be > 0"
        );
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiments::dat_phuc2024::fanuc::FanucMode;

    #[test]
    fn defaults_round_trip_through_toml() {
        let c = SimConfig::default();
        assert_eq!(SimConfig::parse(&c.to_toml()).unwrap(), c);
    }

    #[test]
    fn partial_files_take_defaults_and_typos_are_errors() {
        let c = SimConfig::parse(
            "[machine]\nkind = \"fanuc\"\nmode = \"high_accuracy\"\np1769_time_constant_ms = 8\n",
        )
        .unwrap();
        match c.machine {
            MachineConfig::Fanuc(f) => {
                assert_eq!(f.mode, FanucMode::HighAccuracy);
                assert_eq!(f.p1769_time_constant_ms, 8.0);
                assert_eq!(f.p1622_time_constant_ms, 64.0);
            }
            _ => panic!(),
        }
        let e = format!(
            "{:#}",
            SimConfig::parse("[machine]\nkind = \"fanuc\"\np1662 = 3\n").unwrap_err()
        );
        assert!(e.contains("line 3") || e.contains("p1662"), "{e}");
        assert!(SimConfig::parse("[methods.fuzzy]\nlookahead_points = 7\n").is_err());
        let c = SimConfig::parse("[machine]\nkind = \"servo_xy\"\ncounts_per_mm = 50\n").unwrap();
        assert!(matches!(c.machine, MachineConfig::ServoXy(ref s) if s.counts_per_mm == 50.0));
    }
}
