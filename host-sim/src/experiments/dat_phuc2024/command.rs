//! `host-sim corner`: Dat & Phuc's corner compensation, corner error before
//! and after, on a synthetic corner and on G-code programs, with FANUC's
//! high-accuracy contour control off and on.

use std::path::PathBuf;

use anyhow::{Context, Result};

use crate::config::SimConfig;
use crate::experiments::dat_phuc2024::corner_comp::{self, CornerSettings};
use crate::experiments::dat_phuc2024::fanuc::{FanucConfig, FanucMode};
use crate::machine::MachineConfig;

/// Arguments of `corner`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Turn of the synthetic corner, degrees (paper: 90).
    #[arg(long, default_value_t = 90.0)]
    pub angle_deg: f64,
    /// Feed of the synthetic corner, mm/min (paper: 900).
    #[arg(long, default_value_t = 900.0)]
    pub feed: f64,
    /// Leg length of the synthetic corner, mm.
    #[arg(long, default_value_t = 10.0)]
    pub leg_mm: f64,
    /// G-code or CSV programs to compensate as well (blocks without a
    /// programmed feed run at --feed).
    #[arg(long = "path", value_name = "FILE")]
    pub paths: Vec<PathBuf>,
    /// Skip the synthetic corner.
    #[arg(long)]
    pub no_synthetic: bool,
    /// FANUC modes: high-accuracy contour control off (conventional) and on.
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = [FanucMode::Conventional, FanucMode::HighAccuracy])]
    pub modes: Vec<FanucMode>,
    /// Corner error to meet, µm.
    #[arg(long, default_value_t = 2.0)]
    pub tolerance_um: f64,
    /// Command every sharp corner at this feed instead of searching for the
    /// highest feed that meets the tolerance, mm/min (paper, Fig. 14: 5).
    #[arg(long)]
    pub corner_feed: Option<f64>,
    /// Smallest turn that counts as a corner, degrees.
    #[arg(long, default_value_t = 30.0)]
    pub min_angle_deg: f64,
    /// TOML configuration: its `[machine]` FANUC parameters (the mode is set
    /// by --modes) and `[gcode]` settings.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Write table.txt, corner.json and the compensated G-code here.
    #[arg(long)]
    pub out_dir: Option<PathBuf>,
}

/// Run `corner`.
pub fn run(args: &Args) -> Result<()> {
    let sim = match &args.config {
        Some(p) => SimConfig::read(p)?,
        None => SimConfig::default(),
    };
    let fanuc = match &sim.machine {
        MachineConfig::Fanuc(f) => f.clone(),
        MachineConfig::ServoXy(_) => FanucConfig::default(),
    };
    anyhow::ensure!(
        args.feed.is_finite() && args.feed > 0.0 && args.feed <= 1e5,
        "--feed must be in (0, 100000] mm/min"
    );
    anyhow::ensure!(
        args.angle_deg.is_finite() && args.angle_deg > 0.0 && args.angle_deg < 180.0,
        "--angle-deg must be in (0, 180)"
    );
    anyhow::ensure!(
        args.leg_mm.is_finite() && args.leg_mm > 0.01 && args.leg_mm <= 1000.0,
        "--leg-mm must be in (0.01, 1000]"
    );
    anyhow::ensure!(
        args.tolerance_um.is_finite() && args.tolerance_um > 0.0,
        "--tolerance-um must be > 0"
    );
    if let Some(f) = args.corner_feed {
        anyhow::ensure!(
            f.is_finite() && f > 0.0 && f <= 1e5,
            "--corner-feed must be in (0, 100000] mm/min"
        );
    }
    let settings = CornerSettings {
        fixed_feed_mm_per_min: args.corner_feed,
        min_angle_deg: args.min_angle_deg,
        tolerance_mm: args.tolerance_um * 1e-3,
        ..Default::default()
    };
    let mut cases: Vec<(String, Vec<[f64; 3]>, Vec<f64>)> = Vec::new();
    if !args.no_synthetic {
        let pts = corner_comp::corner_path(args.angle_deg, args.leg_mm);
        let feeds = vec![args.feed; pts.len()];
        cases.push((
            format!("corner {}° F{}", args.angle_deg, args.feed),
            pts,
            feeds,
        ));
    }
    for p in &args.paths {
        let t = crate::inputs::load(p, &sim.gcode)?;
        let feeds = t.feed_caps.iter().map(|c| c.unwrap_or(args.feed)).collect();
        cases.push((t.name.clone(), t.points.clone(), feeds));
    }
    let ts = sim.ts_s();
    let mut rows = Vec::new();
    let mut programs = Vec::new();
    for (name, pts, feeds) in &cases {
        for &mode in &args.modes {
            let machine = MachineConfig::Fanuc(FanucConfig {
                mode,
                ..fanuc.clone()
            });
            let (o, c) = corner_comp::evaluate(name, pts, feeds, &machine, ts, &settings)
                .with_context(|| name.clone())?;
            programs.push((name.clone(), mode, c));
            rows.push(o);
        }
    }
    let text = corner_comp::table(&rows);
    print!("{text}");
    if let Some(dir) = &args.out_dir {
        std::fs::create_dir_all(dir).with_context(|| format!("{}", dir.display()))?;
        crate::output::write(dir.join("table.txt"), &text)?;
        crate::output::write(
            dir.join("corner.json"),
            serde_json::to_string_pretty(&rows)?,
        )?;
        for (i, (name, mode, c)) in programs.iter().enumerate() {
            let stem: String = name
                .chars()
                .map(|ch| if ch.is_ascii_alphanumeric() { ch } else { '_' })
                .collect();
            let mode = match mode {
                FanucMode::Conventional => "conventional",
                FanucMode::HighAccuracy => "high_accuracy",
            };
            let f = dir.join(format!("{i}_{stem}_{mode}.nc"));
            crate::output::write(&f, corner_comp::gcode(c))
                .with_context(|| format!("{}", f.display()))?;
        }
    }
    Ok(())
}
