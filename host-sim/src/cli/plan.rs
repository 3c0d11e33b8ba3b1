//! `host-sim plan`: the velocity planner on toolpaths, for users who run
//! them on a PC: cycle time against the time-optimal reference, peak ratios
//! to every limit, chord deviation; the speed profile as a plot and the
//! ticks as CSV.

use std::io::Write;
use std::path::Path;

use anyhow::{Context, Result};

use crate::config::SimConfig;
use crate::methods::{self, Method};
use crate::planner::{self, figures, plot, PlannedRun};
use crate::plots;
use crate::simulate::Prepared;

use crate::cli::{MachineArgs, OutputFiles};

/// Where the planner's upper bounds come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum FeedSource {
    /// The fuzzy scheduler at F_max (capped by programmed F words).
    Fuzzy,
    /// The programmed feeds (F words; G0 at the rapid feed), capped by
    /// F_max; F_max where the input has none (the built-in shapes).
    Programmed,
}

/// Arguments of `plan`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Toolpaths: built-in shape names (infinity, trident, butterfly) or
    /// files (G-code or CSV).
    #[arg(required = true)]
    pub inputs: Vec<String>,
    /// Feeds the planner takes as upper bounds.
    #[arg(long, value_enum, default_value_t = FeedSource::Fuzzy)]
    pub feeds: FeedSource,
    /// Maximum feed F_max, mm/min (default: the planner's
    /// `feed_max_mm_per_min`).
    #[arg(long)]
    pub f_max: Option<f64>,
    /// Do not draw the speed-profile plots.
    #[arg(long)]
    pub no_plots: bool,
    /// Machine (for the consistency notes), scheduler and planner settings
    /// (`[planner]` in the TOML file).
    #[command(flatten)]
    pub machine: MachineArgs,
    /// Where to write the results.
    #[command(flatten)]
    pub out: OutputFiles,
}

/// Run `plan`.
pub fn run(args: &Args) -> Result<()> {
    let config = args.machine.config()?;
    let f_max = args.f_max.unwrap_or(config.planner.feed_max_mm_per_min);
    anyhow::ensure!(
        f_max.is_finite() && f_max > 0.0 && f_max <= 1e6,
        "--f-max: {f_max} mm/min outside (0, 1e6]"
    );
    // Everything is computed before anything is written.
    let mut runs = Vec::new();
    for input in &args.inputs {
        let prepared = crate::cli::simulate::load(input, &config)?;
        runs.push(plan_one(&prepared, args.feeds, f_max, &config)?);
    }
    let dir = &args.out.out_dir;
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut text = String::new();
    let notes = planner::machine::limit_notes(&config);
    for n in &notes {
        text.push_str(&format!("note: {n}\n"));
    }
    let mut all = Vec::new();
    for (prepared, schedule, run, figs) in &runs {
        let name = &prepared.path.name;
        write_ticks(&dir.join(format!("{name}_plan_ticks.csv")), run)?;
        write_points(
            &dir.join(format!("{name}_plan_points.csv")),
            prepared,
            schedule,
            run,
        )?;
        crate::output::write(
            dir.join(format!("{name}_plan.json")),
            serde_json::to_string_pretty(figs)?,
        )?;
        if !args.no_plots {
            plots::write_figure(
                &dir.join(format!("{name}_plan")),
                &plot::speed_profile_figure(
                    name,
                    run,
                    &config.planner,
                    Some(&schedule.feeds_mm_per_min),
                ),
                args.out.formats(),
            )?;
        }
        text.push_str(&figures::text(figs));
        let stride = run.trace.stride();
        if stride > 1 {
            text.push_str(&format!(
                "  note: {} ticks: {name}_plan_ticks.csv holds every {stride}th and the last, the plot each stretch's extremes (the figures above are of every tick)\n",
                run.ticks
            ));
        }
        all.push(figs.clone());
    }
    text.push('\n');
    text.push_str(&figures::summary(&all));
    crate::output::write(dir.join("plan.txt"), &text)?;
    crate::output::write(dir.join("plan.json"), serde_json::to_string_pretty(&all)?)?;
    print!("{text}");
    eprintln!("written to {}", dir.display());
    Ok(())
}

type Planned = (
    Prepared,
    methods::Schedule,
    PlannedRun,
    figures::PlanFigures,
);

/// Schedule, plan and measure one toolpath.
pub fn plan_one(
    prepared: &Prepared,
    source: FeedSource,
    f_max: f64,
    config: &SimConfig,
) -> Result<Planned> {
    let path = &prepared.path;
    let (method, label) = match source {
        FeedSource::Fuzzy => (Method::Fuzzy, format!("fuzzy, F_max {f_max} mm/min")),
        FeedSource::Programmed => (
            Method::Constant,
            format!("programmed, capped at {f_max} mm/min"),
        ),
    };
    let schedule = methods::schedule(method, path, f_max, config.ts_s(), &config.methods)?;
    check_plan_ticks(&path.points, &schedule.feeds_mm_per_min, config)
        .with_context(|| format!("planning {}", path.name))?;
    let points =
        planner::motion_points(path, &schedule.feeds_mm_per_min, &schedule.curvature_per_mm)?;
    let run = planner::plan(&points, &path.lines, &config.planner)
        .with_context(|| format!("planning {}", path.name))?;
    let figs = figures::measure(&path.name, &label, &run, &config.planner);
    Ok((prepared.clone(), schedule, run, figs))
}

/// Refuse, before it starts, a plan of more than `max_plan_ticks` ticks
/// (at least as many as the path takes at its scheduled feeds).
pub fn check_plan_ticks(
    points: &[[f64; 3]],
    feeds_mm_per_min: &[f64],
    config: &SimConfig,
) -> Result<()> {
    let n = crate::simulate::motion_samples_at_least(points, feeds_mm_per_min, config);
    let max = config.max_plan_ticks;
    if n.is_nan() || n > max as f64 {
        anyhow::bail!(
            "the motion would take at least {} at the scheduled feeds, over {} ticks of {} ms: more than max_plan_ticks = {max}, which bounds the planning time (memory does not grow with the ticks); set max_plan_ticks in the --config TOML file to plan it",
            crate::simulate::duration_text(n * config.ts_s()),
            if n.is_finite() { format!("{n:.0}") } else { "infinitely many".into() },
            config.interpolation_period_ms,
        );
    }
    Ok(())
}

fn create(path: &Path) -> Result<crate::output::Output> {
    crate::output::Output::create(path)
}

/// The ticks CSV from the run's record: every tick, or on a long run every
/// `stride`-th tick and the last.
fn write_ticks(path: &Path, run: &PlannedRun) -> Result<()> {
    let mut w = create(path)?;
    writeln!(
        w,
        "t_s,s_mm,x_mm,y_mm,z_mm,speed_mm_per_min,accel_mm_per_s2,point,state"
    )?;
    let rows = run.trace.buckets().iter().map(|b| (b.tick, b.first));
    let end = run.ticks.saturating_sub(1);
    let last = (run.trace.buckets().last().map(|b| b.tick) != Some(end)).then_some((end, run.last));
    for (k, t) in rows.chain(last) {
        writeln!(
            w,
            "{},{},{},{},{},{},{},{},{:?}",
            (k + 1) as f64 * run.ts_s,
            t.s_mm,
            t.pos[0],
            t.pos[1],
            t.pos[2],
            t.speed_mm_per_s * 60.0,
            t.accel_mm_per_s2,
            t.point,
            t.state
        )?;
    }
    w.finish()
}

fn write_points(
    path: &Path,
    prepared: &Prepared,
    schedule: &methods::Schedule,
    run: &PlannedRun,
) -> Result<()> {
    let mut w = create(path)?;
    writeln!(
        w,
        "index,line,s_mm,x_mm,y_mm,z_mm,curvature_per_mm,feed_mm_per_min,ceiling_mm_per_min,cap_mm_per_min,envelope_mm_per_min"
    )?;
    for p in &run.points {
        writeln!(
            w,
            "{},{},{},{},{},{},{},{},{},{},{}",
            p.index,
            prepared.path.lines.get(p.index).copied().unwrap_or(0),
            p.s_mm,
            p.pos[0],
            p.pos[1],
            p.pos[2],
            schedule
                .curvature_per_mm
                .get(p.index)
                .copied()
                .unwrap_or(0.0),
            schedule
                .feeds_mm_per_min
                .get(p.index)
                .copied()
                .unwrap_or(0.0),
            p.ceiling_mm_per_s * 60.0,
            p.cap_mm_per_s * 60.0,
            p.envelope_mm_per_s * 60.0
        )?;
    }
    w.finish()
}
