//! `host-sim toolpath`: a G-code or CSV toolpath as a CSV point list.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Result;

use crate::config::SimConfig;

/// Arguments of `toolpath`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// G-code (.nc .ngc .gcode .tap .cnc .g) or CSV file.
    pub input: PathBuf,
    /// TOML configuration (its `[gcode]` table: chord tolerance, rapid
    /// feed, start position).
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
}

/// Run `toolpath`: print x,y,z and the programmed feed of every point.
pub fn run(args: &Args) -> Result<()> {
    let c = match &args.config {
        Some(p) => SimConfig::read(p)?,
        None => SimConfig::default(),
    };
    let input = &args.input;
    let (t, warnings) = crate::inputs::load_with_warnings(input, &c.gcode)?;
    print_warnings(input, &warnings);
    // Written as it is formatted: the text of millions of points is not
    // held in memory; a closed stdout ends the run with an error.
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    write!(
        out,
        "# {} from {}, {} points, {:.3} mm; 4th column: programmed feed, mm/min\nx,y,z,feed\n",
        t.name,
        input.display(),
        t.len(),
        t.length_mm()
    )?;
    for (p, cap) in t.points.iter().zip(&t.feed_caps) {
        write!(out, "{},{},{},", p[0], p[1], p[2])?;
        if let Some(f) = cap {
            write!(out, "{f}")?;
        }
        writeln!(out)?;
    }
    out.flush()?;
    Ok(())
}

/// Each distinct warning once, at its first line, with how many times it
/// came (to stderr: stdout is the point list).
fn print_warnings(input: &std::path::Path, warnings: &[(u32, String)]) {
    let mut seen: Vec<(u32, &str, usize)> = Vec::new();
    for (line, text) in warnings {
        match seen.iter_mut().find(|s| s.1 == text) {
            Some(s) => s.2 += 1,
            None => seen.push((*line, text, 1)),
        }
    }
    for (line, text, n) in seen {
        let more = if n > 1 {
            format!(" ({n} times)")
        } else {
            String::new()
        };
        eprintln!("warning: {}: line {line}: {text}{more}", input.display());
    }
}
