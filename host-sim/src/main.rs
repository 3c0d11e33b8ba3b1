//! `host-sim`: fuzzy-core's feed scheduler on a PC. Toolpaths in (the
//! paper's shapes, G-code, CSV), feeds scheduled by fuzzy-core and by the
//! methods it competes with, the motion predicted on simulated machines,
//! and the paper-style comparison table and plots out.
//!
//! Every scheduling subcommand calls `fuzzy-core`, the same code the
//! firmware runs.

mod cho_cmd;
mod common;
mod compare_cmd;
mod controller_cmd;
mod corner_cmd;
mod plan_cmd;
mod schedule_cmd;
mod simulate_cmd;

use std::path::PathBuf;

use host_sim::config::SimConfig;
use host_sim::shapes;

use clap::{Parser, Subcommand};

/// Fuzzy feedrate scheduling (Lin, Lin & Wang 2021) on recorded toolpaths
/// and simulated machines.
#[derive(Parser, Debug)]
#[command(name = "host-sim", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// The paper-style comparison (Tables 10-12): shapes/files × methods ×
    /// maximum feeds on one machine, the fuzzy scheduler vs a constant feed
    /// at equal cycle time and at equal max contour error, and plots.
    /// Writes table.txt, table.csv, claims.csv, report.json, config.toml and
    /// plots/ to the results directory.
    Compare(compare_cmd::Args),
    /// One toolpath, method, maximum feed and machine: motion and schedule
    /// as CSV, metrics as JSON, plots.
    Simulate(simulate_cmd::Args),
    /// The velocity planner (fuzzy-core, `[planner]`) on toolpaths: cycle
    /// time vs the time-optimal reference, peak axis velocity and
    /// acceleration and tangential acceleration and jerk against their
    /// limits, chord deviation; writes the speed profile (plot), the ticks
    /// and the plan (CSV), the figures (JSON, plan.txt).
    Plan(plan_cmd::Args),
    /// Cho, Lee & Jeon's contour-error fuzzy feed control on the X-Y servo
    /// model (Tables 4.1-4.2): circle and corner, cycle time against the
    /// best constant feed with the same peak contour error (Table 4.3).
    Cho(cho_cmd::Args),
    /// Dat & Phuc's corner compensation: extra points and a slower feed
    /// near sharp corners, chosen with the machine model so the predicted
    /// path meets the corner; corner error before and after.
    Corner(corner_cmd::Args),
    /// Schedule the feed along a path given as CSV (x,y,z in mm, optional
    /// feed cap in mm/min) and write one row per point.
    Schedule(schedule_cmd::Args),
    /// Export or evaluate the fuzzy controller.
    #[command(subcommand)]
    Controller(controller_cmd::Command),
    /// Write one of the paper's test shapes (NURBS, 2001 points) as CSV.
    Shape {
        /// Which shape.
        #[arg(value_enum)]
        shape: shapes::Shape,
    },
    /// Turn a G-code or CSV toolpath into a CSV point list (x,y,z in mm and
    /// the programmed feed in mm/min: what `schedule` and `simulate` read).
    Toolpath {
        /// G-code (.nc .ngc .gcode .tap .cnc .g) or CSV file.
        input: PathBuf,
        /// TOML configuration (its `[gcode]` table: chord tolerance, rapid
        /// feed, start position).
        #[arg(long, value_name = "FILE")]
        config: Option<PathBuf>,
    },
    /// Print the default configuration (every key of the TOML file).
    Config,
    /// Njiri et al.'s force-feedback feed override in a closed loop with a
    /// ball-end milling force model: the depth-of-cut step experiment.
    Njiri(host_sim::njiri::cli::Args),
    /// Nagata et al.'s fuzzy post-processor: CL data → G-code with F words
    /// (optionally X A Z for a rotary unit), machining time vs a constant
    /// feed, read-back check.
    Nagata(host_sim::nagata::cli::Args),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Compare(args) => compare_cmd::run(&args),
        Command::Simulate(args) => simulate_cmd::run(&args),
        Command::Plan(args) => plan_cmd::run(&args),
        Command::Cho(args) => cho_cmd::run(&args),
        Command::Corner(args) => corner_cmd::run(&args),
        Command::Schedule(args) => schedule_cmd::run(&args),
        Command::Controller(cmd) => controller_cmd::run(&cmd),
        Command::Shape { shape } => {
            println!(
                "# {} (Lin et al. 2021), 2001 points, u step 0.0005\nx,y,z",
                shape.name()
            );
            for p in shape.points() {
                println!("{:.9},{:.9},{:.9}", p[0], p[1], p[2]);
            }
            Ok(())
        }
        Command::Toolpath { input, config } => toolpath(&input, config.as_deref()),
        Command::Njiri(args) => host_sim::njiri::cli::run(&args),
        Command::Nagata(args) => host_sim::nagata::cli::run(&args),
        Command::Config => {
            print!("{}", SimConfig::default().to_toml());
            Ok(())
        }
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn toolpath(input: &std::path::Path, config: Option<&std::path::Path>) -> anyhow::Result<()> {
    let c = match config {
        Some(p) => SimConfig::read(p)?,
        None => SimConfig::default(),
    };
    let t = host_sim::inputs::load(input, &c.gcode)?;
    let mut out = String::new();
    out.push_str(&format!(
        "# {} from {}, {} points, {:.3} mm; 4th column: programmed feed, mm/min\nx,y,z,feed\n",
        t.name,
        input.display(),
        t.len(),
        t.length_mm()
    ));
    for i in 0..t.len() {
        let p = t.points[i];
        let f = t.feed_caps[i].map_or(String::new(), |f| format!("{f}"));
        out.push_str(&format!("{},{},{},{}\n", p[0], p[1], p[2], f));
    }
    print!("{out}");
    Ok(())
}
