//! `host-sim schedule`: the pipeline over a CSV path.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Result;
use fuzzy_core::lin2021::{Lin2021Controller, VariationScale, CONTROLLER};
use fuzzy_core::scheduler::{Scheduler, SchedulerConfig};
use fuzzy_core::units::{CurvaturePerMm, FeedMmPerMin};

use crate::output::FileOrStdout;
use crate::path_csv;

/// Arguments of `schedule`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Path as CSV: x,y,z in mm, optional 4th column feed cap in mm/min.
    pub input: PathBuf,
    /// Maximum feed F_max, mm/min (a straight line runs at it).
    #[arg(long, default_value_t = 3000.0)]
    pub f_max: f64,
    /// Minimum feed F_min, mm/min (the schedule never goes below it).
    #[arg(long, default_value_t = 60.0)]
    pub f_min: f64,
    /// Curvature variation Dκ (1/mm) that counts as "very high" (normalised
    /// to 1); the paper clips at 3.
    #[arg(long, default_value_t = 3.0)]
    pub variation_clip: f64,
    /// Output CSV (default: standard output).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
}

/// Run `schedule`.
pub fn run(args: &Args) -> Result<()> {
    let points = path_csv::read(&args.input)?;
    let config = SchedulerConfig {
        f_max: FeedMmPerMin::from_f64(args.f_max),
        f_min: FeedMmPerMin::from_f64(args.f_min),
        variation: VariationScale {
            floor: CurvaturePerMm::ZERO,
            clip: CurvaturePerMm::from_f64(args.variation_clip),
        },
    };
    let mut scheduler: Scheduler<&Lin2021Controller, 30, 9, 40> =
        Scheduler::new(&CONTROLLER, config).map_err(|e| anyhow::anyhow!("{e}"))?;
    let mut rows = Vec::with_capacity(points.len());
    scheduler
        .run(points.iter().copied(), |p| rows.push(p))
        .map_err(|(i, e)| anyhow::anyhow!("line {}: {e}", points.get(i).map_or(0, |p| p.tag)))?;
    let mut out = FileOrStdout::create(args.output.as_deref())?;
    writeln!(out, "line,x_mm,y_mm,z_mm,curvature_per_mm,variation_per_mm,fraction,fuzzy_feed_mm_per_min,feed_mm_per_min")?;
    for r in &rows {
        let [x, y, z] = r.point.pos.to_f64();
        writeln!(
            out,
            "{},{x},{y},{z},{},{},{},{},{}",
            r.point.tag,
            r.curvature.to_f64(),
            r.variation.to_f64(),
            r.fraction.to_num::<f64>(),
            r.fuzzy_feed.to_f64(),
            r.feed.to_f64()
        )?;
    }
    out.finish()?;
    if scheduler.merged_duplicates() > 0 {
        eprintln!(
            "note: {} duplicate points merged",
            scheduler.merged_duplicates()
        );
    }
    Ok(())
}
