//! `host-sim toolpath`: a G-code or CSV toolpath as a CSV point list.

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
