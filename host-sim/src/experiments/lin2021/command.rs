//! `host-sim compare`: the paper-style table, the claims against the
//! constant feed and against the baselines, the Pareto sweep and the plots
//! for paths × methods × maximum feeds on one machine.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};

use super::compare::{self, Options, ParetoPoint, Variant};
use super::report;
use crate::cli::{MachineArgs, OutputFiles};
use crate::inputs;
use crate::methods::Method;
use crate::plots;
use crate::shapes::Shape;
use crate::simulate::{Prepared, RunResult};

/// The toolpaths `compare` runs when none is named: the paper's shapes,
/// our CAM programs (`tests/data/cam/`) and the shared real programs
/// (`../shared/gcode/`), relative to the working directory (the
/// repository's root, as `./scripts/run.sh` runs it); missing files are
/// skipped with a note.
pub const DEFAULT_PROGRAMS: [&str; 5] = [
    "tests/data/cam/surface_ball_end.ngc",
    "tests/data/cam/pocket_arcs.ngc",
    "tests/data/cam/short_arcs.ngc",
    "../shared/gcode/freecad_profile.nc",
    "../shared/gcode/linuxcnc_butterfly_g52.ngc",
];

/// Arguments of `compare`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Built-in shapes of Lin et al. to run (default, when neither
    /// `--shapes` nor `--path` is given: all three and the programs of
    /// [`DEFAULT_PROGRAMS`] that exist).
    #[arg(long, value_enum, value_delimiter = ',')]
    pub shapes: Vec<Shape>,
    /// Toolpath files to run as well: G-code (.nc, .ngc, .gcode, .tap, .cnc)
    /// or CSV point lists (.csv).
    #[arg(long = "path", value_name = "FILE")]
    pub paths: Vec<PathBuf>,
    /// Maximum feeds F_max to run, mm/min (the constant method runs at
    /// F_max; programmed F words still cap every method).
    #[arg(long, value_delimiter = ',', default_values_t = [3000.0, 5000.0])]
    pub feeds: Vec<f64>,
    /// Methods to compare.
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = Method::ALL)]
    pub methods: Vec<Method>,
    /// Junction deviations of the `grbl-like` rows and baselines, mm (empty:
    /// the configuration's `[methods.grbl_like]`).
    #[arg(long, value_delimiter = ',', default_values_t = [0.01, 0.002])]
    pub grbl_deviations_mm: Vec<f64>,
    /// Tolerances P of the `blend` rows and baselines, mm (empty: the
    /// configuration's `[methods.blend]`).
    #[arg(long, value_delimiter = ',', default_values_t = [0.01])]
    pub blend_tolerances_mm: Vec<f64>,
    /// Skip the searches for the baseline settings matching the fuzzy runs'
    /// cycle time and max contour error (the claims).
    #[arg(long)]
    pub no_claims: bool,
    /// Maximum feeds of the Pareto sweep, mm/min (the planner methods stop
    /// at `[planner] feed_max_mm_per_min`, 5000 by default).
    #[arg(long, value_delimiter = ',', default_values_t = [1500.0, 2000.0, 3000.0, 4000.0, 5000.0])]
    pub pareto_feeds: Vec<f64>,
    /// Skip the Pareto sweep.
    #[arg(long)]
    pub no_pareto: bool,
    /// Do not draw plots.
    #[arg(long)]
    pub no_plots: bool,
    /// Paths run at once (default: the number of cores).
    #[arg(long)]
    pub jobs: Option<usize>,
    /// Machine and method settings.
    #[command(flatten)]
    pub machine: MachineArgs,
    /// Where to write the results.
    #[command(flatten)]
    pub out: OutputFiles,
}

fn check_feeds(name: &str, feeds: &[f64]) -> Result<()> {
    for f in feeds {
        anyhow::ensure!(
            f.is_finite() && *f > 0.0 && *f <= 1e6,
            "{name}: {f} mm/min outside (0, 1e6]"
        );
    }
    Ok(())
}

/// Run `compare`.
pub fn run(args: &Args) -> Result<()> {
    let config = args.machine.config()?;
    let mut paths: Vec<Prepared> = Vec::new();
    let defaults = args.shapes.is_empty() && args.paths.is_empty();
    let shapes: Vec<Shape> = if defaults {
        Shape::ALL.to_vec()
    } else {
        args.shapes.clone()
    };
    for s in shapes {
        paths.push(Prepared::new(s.toolpath()?));
    }
    let mut files: Vec<PathBuf> = args.paths.clone();
    if defaults {
        for p in DEFAULT_PROGRAMS {
            if Path::new(p).exists() {
                files.push(p.into());
            } else {
                eprintln!("note: {p} not found, skipped");
            }
        }
    }
    for p in &files {
        paths.push(Prepared::new(inputs::load(p, &config.gcode)?));
    }
    check_feeds("--feeds", &args.feeds)?;
    check_feeds("--pareto-feeds", &args.pareto_feeds)?;
    for t in args
        .grbl_deviations_mm
        .iter()
        .chain(&args.blend_tolerances_mm)
    {
        anyhow::ensure!(
            t.is_finite() && *t > 0.0 && *t <= 10.0,
            "tolerance {t} mm outside (0, 10]"
        );
    }
    let variants = compare::variants(
        &args.methods,
        &args.grbl_deviations_mm,
        &args.blend_tolerances_mm,
    );
    // The baselines: the planner, Grbl and LinuxCNC variants among the
    // methods compared.
    let baselines: Vec<Variant> = variants
        .iter()
        .copied()
        .filter(|v| matches!(v.method, Method::Planner | Method::GrblLike | Method::Blend))
        .collect();
    let opts = Options {
        claims: !args.no_claims,
        baselines,
        pareto_feeds_mm_per_min: if args.no_pareto {
            vec![]
        } else {
            args.pareto_feeds.clone()
        },
        jobs: args
            .jobs
            .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get())),
    };
    let steps = compare::batch_steps(paths.len(), &variants, args.feeds.len(), &opts);
    let bar = ProgressBar::new(steps);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} {elapsed} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let dir = &args.out.out_dir;
    let plot_dir = dir.join("plots");
    let formats = args.out.formats();
    let keep_runs = !args.no_plots;
    if keep_runs {
        std::fs::create_dir_all(&plot_dir)
            .with_context(|| format!("creating {}", plot_dir.display()))?;
    }
    let report = compare::batch(
        &paths,
        &variants,
        &args.feeds,
        &config,
        &opts,
        &|msg| {
            bar.inc(1);
            bar.set_message(msg.to_string());
        },
        &|p: &Prepared, runs: &[RunResult]| {
            if keep_runs {
                let runs: Vec<&RunResult> = runs.iter().collect();
                plots::all(&plot_dir, p, &runs, formats)?;
            }
            Ok(())
        },
    );
    bar.finish_and_clear();
    let report = report?;
    // Everything computed: now write (a failure above leaves no report).
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let text = report::text(&report);
    write(dir, "table.txt", &text)?;
    write(dir, "table.csv", &report::rows_csv(&report.rows)?)?;
    write(dir, "claims.csv", &report::claims_csv(&report.claims)?)?;
    write(dir, "report.json", &report::json(&report)?)?;
    write(dir, "config.toml", &config.to_toml())?;
    if !report.pareto.is_empty() {
        write(dir, "pareto.csv", &report::pareto_csv(&report.pareto)?)?;
        if keep_runs {
            for p in &paths {
                pareto_plot(&plot_dir, &p.path.name, &report.pareto, formats)?;
            }
        }
    }
    print!("{text}");
    eprintln!("written to {}", dir.display());
    Ok(())
}

fn pareto_plot(
    dir: &Path,
    name: &str,
    points: &[ParetoPoint],
    formats: plots::Formats,
) -> Result<()> {
    let mut curves: Vec<plots::ParetoCurve> = Vec::new();
    for p in points.iter().filter(|p| p.path == name) {
        let label = crate::simulate::label(method_of(p.method), p.tolerance_mm);
        let colour = plots::variant_colour(method_of(p.method), p.tolerance_mm);
        match curves.iter_mut().find(|c| c.0 == label) {
            Some(c) => c.2.push((p.cycle_time_s, p.contour_error_max_mm)),
            None => curves.push((
                label,
                colour,
                vec![(p.cycle_time_s, p.contour_error_max_mm)],
            )),
        }
    }
    if curves.is_empty() {
        return Ok(());
    }
    let stem: String = name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    plots::write_pareto(
        &dir.join(format!("pareto_{stem}")),
        &format!("{name}: max contour error vs cycle time (F_max sweep; left and below is better)"),
        &curves,
        formats,
    )
}

fn method_of(name: &str) -> Method {
    Method::ALL
        .into_iter()
        .find(|m| m.name() == name)
        .unwrap_or(Method::Constant)
}

fn write(dir: &Path, name: &str, text: &str) -> Result<()> {
    let p = dir.join(name);
    crate::output::write(&p, text).with_context(|| format!("writing {}", p.display()))
}
