//! `host-sim simulate`: one toolpath, one method, one maximum feed, one
//! machine: the commanded and predicted motion sample by sample, the
//! metrics, the plots.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, Result};

use crate::inputs;
use crate::methods::Method;
use crate::plots;
use crate::shapes::Shape;
use crate::simulate::{self, Prepared};

use crate::cli::{MachineArgs, OutputFiles};

/// Arguments of `simulate`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Toolpath: a built-in shape name (infinity, trident, butterfly) or a
    /// file (G-code or CSV).
    pub input: String,
    /// Scheduling method.
    #[arg(long, value_enum, default_value_t = Method::Fuzzy)]
    pub method: Method,
    /// Maximum feed F_max, mm/min.
    #[arg(long, default_value_t = 3000.0)]
    pub f_max: f64,
    /// Do not draw plots.
    #[arg(long)]
    pub no_plots: bool,
    /// Machine and method settings.
    #[command(flatten)]
    pub machine: MachineArgs,
    /// Where to write the results.
    #[command(flatten)]
    pub out: OutputFiles,
}

/// A built-in shape or a file.
pub fn load(input: &str, config: &crate::config::SimConfig) -> Result<Prepared> {
    let path = match <Shape as clap::ValueEnum>::from_str(input, true) {
        Ok(s) => s.toolpath()?,
        Err(_) => inputs::load(&PathBuf::from(input), &config.gcode)?,
    };
    Ok(Prepared::new(path))
}

/// Run `simulate`.
pub fn run(args: &Args) -> Result<()> {
    let config = args.machine.config()?;
    let prepared = load(&args.input, &config)?;
    let r = simulate::run(&prepared, args.method, args.f_max, &config)?;
    let dir = &args.out.out_dir;
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let stem = format!(
        "{}_{}_{}",
        prepared.path.name,
        args.method.name(),
        args.f_max
    );
    let traj = dir.join(format!("{stem}_motion.csv"));
    let mut w = crate::output::Output::create(&traj)?;
    writeln!(
        w,
        "t_s,cmd_x_mm,cmd_y_mm,cmd_z_mm,x_mm,y_mm,z_mm,contour_error_mm,feed_mm_per_min"
    )?;
    for (k, p) in r.motion.actual.iter().enumerate() {
        let c = r.motion.commanded.get(k).copied().unwrap_or(*p);
        let v = r.kinematics.speed_mm_per_s.get(k).copied().unwrap_or(0.0) * 60.0;
        writeln!(
            w,
            "{},{},{},{},{},{},{},{},{}",
            k as f64 * r.motion.ts_s,
            c[0],
            c[1],
            c[2],
            p[0],
            p[1],
            p[2],
            r.contour_error_mm[k],
            v
        )?;
    }
    w.finish()?;
    let sched = dir.join(format!("{stem}_schedule.csv"));
    let mut w = crate::output::Output::create(&sched)?;
    writeln!(
        w,
        "line,x_mm,y_mm,z_mm,curvature_per_mm,variation_per_mm,feed_mm_per_min"
    )?;
    for (i, p) in prepared.path.points.iter().enumerate() {
        writeln!(
            w,
            "{},{},{},{},{},{},{}",
            prepared.path.lines[i],
            p[0],
            p[1],
            p[2],
            r.schedule.curvature_per_mm.get(i).copied().unwrap_or(0.0),
            r.schedule.variation_per_mm.get(i).copied().unwrap_or(0.0),
            r.schedule.feeds_mm_per_min[i]
        )?;
    }
    w.finish()?;
    crate::output::write(
        dir.join(format!("{stem}_metrics.json")),
        serde_json::to_string_pretty(&r.metrics)?,
    )?;
    if !args.no_plots {
        plots::all(dir, &prepared, &[&r], args.out.formats())?;
    }
    println!("{}", serde_json::to_string_pretty(&r.metrics)?);
    eprintln!("written to {}", dir.display());
    Ok(())
}
