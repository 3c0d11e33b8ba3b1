//! `host-sim`: fuzzy-core's feed scheduler on a PC. Toolpaths in (the
//! paper's shapes, G-code, CSV), feeds scheduled by fuzzy-core and by the
//! methods it competes with, the motion predicted on simulated machines,
//! and the paper-style comparison table and plots out.
//!
//! Every scheduling subcommand calls `fuzzy-core`, the same code the
//! firmware runs. This file only parses and dispatches: each subcommand is
//! a library module with `Args` and `run`, the papers' in
//! `host_sim::experiments`, the others in `host_sim::cli`.

use clap::{Parser, Subcommand};

use host_sim::cli;
use host_sim::experiments::{cho, dat_phuc2024, lin2021, nagata, njiri};

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
    Compare(lin2021::command::Args),
    /// One toolpath, method, maximum feed and machine: motion and schedule
    /// as CSV, metrics as JSON, plots.
    Simulate(cli::simulate::Args),
    /// The velocity planner (fuzzy-core, `[planner]`) on toolpaths: cycle
    /// time vs the time-optimal reference, peak axis velocity and
    /// acceleration and tangential acceleration and jerk against their
    /// limits, chord deviation; writes the speed profile (plot), the ticks
    /// and the plan (CSV), the figures (JSON, plan.txt).
    Plan(cli::plan::Args),
    /// Cho, Lee & Jeon's contour-error fuzzy feed control on the X-Y servo
    /// model (Tables 4.1-4.2): circle and corner, cycle time against the
    /// best constant feed with the same peak contour error (Table 4.3).
    Cho(cho::command::Args),
    /// Dat & Phuc's corner compensation: extra points and a slower feed
    /// near sharp corners, chosen with the machine model so the predicted
    /// path meets the corner; corner error before and after.
    Corner(dat_phuc2024::command::Args),
    /// Schedule the feed along a path given as CSV (x,y,z in mm, optional
    /// feed cap in mm/min) and write one row per point.
    Schedule(cli::schedule::Args),
    /// Export or evaluate the fuzzy controller.
    Controller(cli::controller::Args),
    /// Write one of the paper's test shapes (NURBS, 2001 points) as CSV.
    Shape(cli::shape::Args),
    /// Turn a G-code or CSV toolpath into a CSV point list (x,y,z in mm and
    /// the programmed feed in mm/min: what `schedule` and `simulate` read).
    Toolpath(cli::toolpath::Args),
    /// Print the default configuration (every key of the TOML file).
    Config(cli::config::Args),
    /// Njiri et al.'s force-feedback feed override in a closed loop with a
    /// ball-end milling force model: the depth-of-cut step experiment.
    Njiri(njiri::command::Args),
    /// Nagata et al.'s fuzzy post-processor: CL data → G-code with F words
    /// (optionally X A Z for a rotary unit), machining time vs a constant
    /// feed, read-back check.
    Nagata(nagata::command::Args),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    if let Err(e) = host_sim::output::remove_on_interrupt() {
        eprintln!("warning: {e:#}");
    }
    let result = match cli.command {
        Command::Compare(a) => lin2021::command::run(&a),
        Command::Simulate(a) => cli::simulate::run(&a),
        Command::Plan(a) => cli::plan::run(&a),
        Command::Cho(a) => cho::command::run(&a),
        Command::Corner(a) => dat_phuc2024::command::run(&a),
        Command::Schedule(a) => cli::schedule::run(&a),
        Command::Controller(a) => cli::controller::run(&a),
        Command::Shape(a) => cli::shape::run(&a),
        Command::Toolpath(a) => cli::toolpath::run(&a),
        Command::Config(a) => cli::config::run(&a),
        Command::Njiri(a) => njiri::command::run(&a),
        Command::Nagata(a) => nagata::command::run(&a),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
