//! The subcommands that belong to no paper, one module each with `Args`
//! (clap) and `run` (the papers' are in [`crate::experiments`], same
//! pattern), and the options they share ([`MachineArgs`], [`OutputFiles`]).
//!
//! | command | module |
//! |---|---|
//! | `simulate` | [`simulate`] |
//! | `plan` | [`plan`] |
//! | `schedule` | [`schedule`] |
//! | `controller export\|eval` | [`controller`] |
//! | `shape` | [`shape`] |
//! | `toolpath` | [`toolpath`] |
//! | `config` | [`config`] |

pub mod config;
pub mod controller;
pub mod plan;
pub mod schedule;
pub mod shape;
pub mod simulate;
pub mod toolpath;

use std::path::PathBuf;

use anyhow::Result;

use crate::config::SimConfig;
use crate::experiments::dat_phuc2024::fanuc::FanucMode;
use crate::machine::MachineConfig;
use crate::methods::VariationNormalisation;
use crate::plots::Formats;

/// Which machine to simulate (overrides the configuration file's).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum MachineChoice {
    /// FANUC-like, conventional mode: linear acc/dec after interpolation,
    /// parameter 1622 (64 ms).
    FanucConventional,
    /// FANUC-like, high-accuracy contour control: acc/dec before
    /// interpolation (1660, 1772, 1783) and after (1769).
    FanucHighAccuracy,
    /// Cho et al.'s X-Y servo model (Tables 4.1-4.2).
    ServoXy,
}

/// Machine and method settings.
#[derive(clap::Args, Debug, Clone)]
pub struct MachineArgs {
    /// TOML configuration of machine, methods and G-code reading (see
    /// `host-sim config` for every key and its default). Options below
    /// override it.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Machine to simulate (default: the configuration's, else
    /// fanuc-conventional).
    #[arg(long, value_enum)]
    pub machine: Option<MachineChoice>,
    /// Interpolation period Ts, ms (also the planner's tick).
    #[arg(long)]
    pub interpolation_period_ms: Option<f64>,
    /// Fuzzy scheduler: lookahead window WS, points (10, 20, 30, 40, 60, 90).
    #[arg(long)]
    pub lookahead: Option<usize>,
    /// Fuzzy scheduler: average filter length, points (1, 5, 9, 15, 21, 31).
    #[arg(long)]
    pub average: Option<usize>,
    /// Fuzzy scheduler: Dκ normalisation, `per-path` (the paper's, offline)
    /// or `fixed` (streaming, `[0, clip]`).
    #[arg(long, value_enum)]
    pub variation: Option<VariationNormalisation>,
    /// Fuzzy scheduler: Dκ clip, 1/mm (paper: 3).
    #[arg(long)]
    pub variation_clip: Option<f64>,
    /// Fuzzy scheduler: minimum feed F_min, mm/min.
    #[arg(long)]
    pub f_min: Option<f64>,
}

impl MachineArgs {
    /// The configuration: file (or defaults), then the options.
    pub fn config(&self) -> Result<SimConfig> {
        let mut c = match &self.config {
            Some(p) => SimConfig::read(p)?,
            None => SimConfig::default(),
        };
        if let Some(m) = self.machine {
            c.machine = match (m, &c.machine) {
                (MachineChoice::ServoXy, MachineConfig::ServoXy(_)) => c.machine.clone(),
                (MachineChoice::ServoXy, _) => MachineConfig::ServoXy(Default::default()),
                (mode, MachineConfig::Fanuc(f)) => {
                    MachineConfig::Fanuc(crate::experiments::dat_phuc2024::fanuc::FanucConfig {
                        mode: fanuc_mode(mode),
                        ..f.clone()
                    })
                }
                (mode, _) => {
                    MachineConfig::Fanuc(crate::experiments::dat_phuc2024::fanuc::FanucConfig {
                        mode: fanuc_mode(mode),
                        ..Default::default()
                    })
                }
            };
        }
        if let Some(t) = self.interpolation_period_ms {
            c.interpolation_period_ms = t;
            c.planner.tick_us = (t * 1000.0).round().clamp(0.0, u32::MAX as f64) as u32;
        }
        let f = &mut c.methods.fuzzy;
        if let Some(w) = self.lookahead {
            f.lookahead_points = w;
        }
        if let Some(a) = self.average {
            f.average_points = a;
        }
        if let Some(v) = self.variation {
            f.variation = v;
        }
        if let Some(v) = self.variation_clip {
            f.variation_clip_per_mm = v;
        }
        if let Some(v) = self.f_min {
            f.f_min_mm_per_min = v;
        }
        c.validate()?;
        Ok(c)
    }
}

fn fanuc_mode(m: MachineChoice) -> FanucMode {
    if m == MachineChoice::FanucHighAccuracy {
        FanucMode::HighAccuracy
    } else {
        FanucMode::Conventional
    }
}

/// Where results go.
#[derive(clap::Args, Debug, Clone)]
pub struct OutputFiles {
    /// Results directory (created; files in it are replaced).
    #[arg(long, default_value = "results")]
    pub out_dir: PathBuf,
    /// Plot formats.
    #[arg(long, value_enum, default_value_t = Formats::Both)]
    pub plot_format: Formats,
}

impl OutputFiles {
    /// Plot formats.
    pub fn formats(&self) -> Formats {
        self.plot_format
    }
}
