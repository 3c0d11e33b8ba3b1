//! `host-sim controller`: export the controller, evaluate it on CSV inputs.

use crate::output::FileOrStdout;
use std::io::Write;
use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use fuzzy_core::fuzzy::export::{write_fcl, write_fis};
use fuzzy_core::lin2021::{CONTROLLER, SYSTEM};
use fuzzy_core::units::Fx;

/// Arguments of `controller`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// `controller` subcommands.
#[derive(clap::Subcommand, Debug)]
pub enum Command {
    /// Write a controller as a MATLAB/Octave `.fis` file or as IEC 61131-7
    /// FCL (exact Q16.16 parameters; both load unchanged in Octave's
    /// fuzzy-logic-toolkit and fuzzylite 6). Defuzzification as fuzzy-core
    /// evaluates it: Lin's and Njiri's are Mamdani with the exact centroid
    /// integral (closed form; MATLAB/Octave sample 101 points, fuzzylite
    /// 100 slices: a few 1e-4 of the range apart); Cho's is Mamdani with
    /// the 101-sample sum of eq. 11 (Gaussian terms: no closed form), so a
    /// tool that integrates differs by about 6e-3 of the range; Nagata's
    /// two are zero-order Sugeno (weighted average, no centroid).
    Export {
        /// Which controller.
        #[arg(long, value_enum, default_value_t = Which::Lin2021)]
        controller: Which,
        /// `fis` (MATLAB, Octave fuzzy-logic-toolkit, fuzzylite) or `fcl`
        /// (IEC 61131-7; jFuzzyLogic, fuzzylite).
        #[arg(long, value_enum, default_value_t = Format::Fis)]
        format: Format,
        /// Output file (default: standard output).
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
    /// Evaluate the fixed-point controller on a CSV of inputs
    /// (`curvature_per_mm,variation_normalised` per row) and print the feed
    /// fraction, to compare with MATLAB's `evalfis` or another tool.
    Eval {
        /// Input CSV; a header row is skipped.
        input: PathBuf,
        /// `exact` (the integral, our scheduler's) or `sampled` (101 samples,
        /// MATLAB's and Octave's `evalfis` default).
        #[arg(long, value_enum, default_value_t = Centroid::Exact)]
        centroid: Centroid,
        /// Output CSV (default: standard output).
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
}

/// The controllers of the papers (fuzzy-core's definitions).
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Which {
    /// Lin, Lin & Wang 2021: curvature and its variation → feed fraction
    /// (Mamdani, centroid).
    Lin2021,
    /// Njiri et al.: force errors and their changes → FRPO (Mamdani,
    /// centroid).
    Njiri,
    /// Nagata et al.: CL segment length d(i) → feed (zero-order Sugeno).
    NagataLength,
    /// Nagata et al.: length increment Δd(i) → compensation (zero-order
    /// Sugeno).
    NagataIncrement,
    /// Cho, Lee & Jeon: contour error and its change → feed change
    /// (Mamdani, centroid; Table 3.1 completed).
    Cho,
}

/// `def` in `format`.
fn export_text<const NI: usize>(
    def: &fuzzy_core::fuzzy::SystemDef<'_, NI>,
    format: Format,
) -> Result<String> {
    let mut text = String::new();
    match format {
        Format::Fis => write_fis(&mut text, def)?,
        Format::Fcl => write_fcl(&mut text, def)?,
    }
    Ok(text)
}

/// The text of controller `which` in `format`.
pub fn export(which: Which, format: Format) -> Result<String> {
    match which {
        Which::Lin2021 => export_text(&SYSTEM, format),
        Which::Njiri => export_text(&fuzzy_core::njiri::SYSTEM, format),
        Which::NagataLength => export_text(&fuzzy_core::nagata::FEED_SYSTEM, format),
        Which::NagataIncrement => export_text(&fuzzy_core::nagata::COMPENSATION_SYSTEM, format),
        Which::Cho => export_text(&fuzzy_core::cho::SYSTEM, format),
    }
}

/// Export format.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum Format {
    /// MATLAB/Octave `.fis`.
    Fis,
    /// IEC 61131-7 Fuzzy Control Language.
    Fcl,
}

/// Centroid definition.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum Centroid {
    /// Exact integral.
    Exact,
    /// 101 equally spaced samples (MATLAB).
    Sampled,
}

fn output(path: &Option<PathBuf>) -> Result<FileOrStdout> {
    FileOrStdout::create(path.as_deref())
}

/// Run a `controller` subcommand.
pub fn run(args: &Args) -> Result<()> {
    match &args.command {
        Command::Export {
            controller,
            format,
            output: path,
        } => {
            let text = export(*controller, *format)?;
            let mut out = output(path)?;
            out.write_all(text.as_bytes())?;
            out.finish()?;
        }
        Command::Eval {
            input,
            centroid,
            output: path,
        } => {
            let text = std::fs::read_to_string(input)
                .with_context(|| format!("reading {}", input.display()))?;
            let mut out = output(path)?;
            writeln!(out, "curvature_per_mm,variation,fraction,fired")?;
            let (lo0, hi0): (f64, f64) =
                (SYSTEM.inputs[0].min.to_num(), SYSTEM.inputs[0].max.to_num());
            let (lo1, hi1): (f64, f64) =
                (SYSTEM.inputs[1].min.to_num(), SYSTEM.inputs[1].max.to_num());
            let mut clamped = 0usize;
            for (i, line) in text.lines().enumerate() {
                let line_no = i + 1;
                let fields: Vec<&str> = line.split(',').map(str::trim).collect();
                if line.trim().is_empty()
                    || line.starts_with('#')
                    || (i == 0 && fields[0].parse::<f64>().is_err())
                {
                    continue;
                }
                if fields.len() != 2 {
                    bail!(
                        "{}:{line_no}: expected curvature,variation",
                        input.display()
                    );
                }
                let parse = |s: &str| -> Result<Fx> {
                    let v: f64 = s.parse().with_context(|| {
                        format!("{}:{line_no}: {s:?} is not a number", input.display())
                    })?;
                    Fx::checked_from_num(v).with_context(|| {
                        format!(
                            "{}:{line_no}: {v} outside the Q16.16 range",
                            input.display()
                        )
                    })
                };
                let x = [parse(fields[0])?, parse(fields[1])?];
                let (k, d): (f64, f64) = (x[0].to_num(), x[1].to_num());
                if k < lo0 || k > hi0 || d < lo1 || d > hi1 {
                    clamped += 1;
                }
                let e = match centroid {
                    Centroid::Exact => CONTROLLER.evaluate(x),
                    Centroid::Sampled => CONTROLLER.evaluate_sampled(x),
                };
                writeln!(out, "{k},{d},{},{}", e.output.to_num::<f64>(), e.fired)?;
            }
            out.finish()?;
            if clamped > 0 {
                eprintln!(
                    "note: {clamped} inputs outside the universes were clamped (MATLAB evaluates them unclamped; compare inside)"
                );
            }
        }
    }
    Ok(())
}
