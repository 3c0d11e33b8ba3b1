//! `host-sim compare`: the paper-style table, the two claims and the plots
//! for paths × methods × maximum feeds on one machine.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};

use crate::experiments::lin2021::compare;
use crate::experiments::lin2021::report;
use crate::inputs;
use crate::methods::Method;
use crate::plots;
use crate::shapes::Shape;
use crate::simulate::{Prepared, RunResult};

use crate::cli::{MachineArgs, OutputFiles};

/// Arguments of `compare`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Built-in shapes of Lin et al. to run (default: all three unless
    /// toolpath files are given).
    #[arg(long, value_enum, value_delimiter = ',')]
    pub shapes: Vec<Shape>,
    /// Toolpath files to run as well: G-code (.nc, .ngc, .gcode, .tap, .cnc)
    /// or CSV point lists (.csv).
    #[arg(long = "path", value_name = "FILE")]
    pub paths: Vec<PathBuf>,
    /// Maximum feeds F_max to run, mm/min (the constant method runs at
    /// F_max; programmed F words still cap every method).
    #[arg(long, value_delimiter = ',', default_values_t = [1500.0, 3000.0, 6000.0])]
    pub feeds: Vec<f64>,
    /// Methods to compare.
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = Method::ALL)]
    pub methods: Vec<Method>,
    /// Skip the search for the constant feeds matching the fuzzy scheduler's
    /// cycle time and max contour error (the claims).
    #[arg(long)]
    pub no_claims: bool,
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

/// Run `compare`.
pub fn run(args: &Args) -> Result<()> {
    let config = args.machine.config()?;
    let mut paths: Vec<Prepared> = Vec::new();
    let shapes: Vec<Shape> = if args.shapes.is_empty() && args.paths.is_empty() {
        Shape::ALL.to_vec()
    } else {
        args.shapes.clone()
    };
    for s in shapes {
        paths.push(Prepared::new(s.toolpath()?));
    }
    for p in &args.paths {
        paths.push(Prepared::new(inputs::load(p, &config.gcode)?));
    }
    for f in &args.feeds {
        anyhow::ensure!(
            f.is_finite() && *f > 0.0 && *f <= 1e6,
            "--feeds: {f} mm/min outside (0, 1e6]"
        );
    }
    let with_claims = !args.no_claims;
    let steps = compare::batch_steps(paths.len(), &args.methods, args.feeds.len(), with_claims);
    let bar = ProgressBar::new(steps);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} {elapsed} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut kept: Vec<(String, RunResult)> = Vec::new();
    let keep_runs = !args.no_plots;
    let report = compare::batch(
        &paths,
        &args.methods,
        &args.feeds,
        &config,
        with_claims,
        |p, r| {
            if keep_runs {
                kept.push((p.path.name.clone(), r.clone()));
            }
        },
        |msg| {
            bar.inc(1);
            bar.set_message(msg.to_string());
        },
    );
    bar.finish_and_clear();
    let report = report?;
    // Everything computed: now write (a failure above leaves no report).
    let dir = &args.out.out_dir;
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let text = report::text(&report);
    write(dir, "table.txt", &text)?;
    write(dir, "table.csv", &report::rows_csv(&report.rows)?)?;
    write(dir, "claims.csv", &report::claims_csv(&report.claims)?)?;
    write(dir, "report.json", &report::json(&report)?)?;
    write(dir, "config.toml", &config.to_toml())?;
    if keep_runs {
        let plot_dir = dir.join("plots");
        std::fs::create_dir_all(&plot_dir)?;
        for p in &paths {
            let runs: Vec<&RunResult> = kept
                .iter()
                .filter(|(n, _)| *n == p.path.name)
                .map(|(_, r)| r)
                .collect();
            plots::all(&plot_dir, p, &runs, args.out.formats())?;
        }
    }
    print!("{text}");
    eprintln!("written to {}", dir.display());
    Ok(())
}

fn write(dir: &Path, name: &str, text: &str) -> Result<()> {
    let p = dir.join(name);
    std::fs::write(&p, text).with_context(|| format!("writing {}", p.display()))
}
