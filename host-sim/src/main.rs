//! `host-sim`: fuzzy-core's feed scheduler on a PC. Recorded toolpaths in,
//! scheduled feeds out; the controller exported for MATLAB/Octave/fuzzylite
//! and evaluated on CSV inputs for comparison with those tools.
//!
//! Every subcommand calls `fuzzy-core`, the same code the firmware runs.

mod controller_cmd;
mod schedule_cmd;

use host_sim::shapes;

use clap::{Parser, Subcommand};

/// Fuzzy feedrate scheduling (Lin, Lin & Wang 2021) on recorded toolpaths.
#[derive(Parser, Debug)]
#[command(name = "host-sim", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
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
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
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
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
