//! `host-sim nagata`: the post-processor on a CL file or the generated
//! zigzag relief path ([`super::relief`]), the machining time of its
//! program against a constant feed on the FANUC-like machine model, and the
//! read-back check. Prints a summary; with `--out DIR` writes
//! `program.nc`, `moves.csv` (d, Δd, F, ΔF, F̃ per move: the paper's Fig. 5)
//! `summary.json` and `fig5.svg` (F̃ per move against the constant feed:
//! the paper's Fig. 5).

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::{ensure, Context, Result};
use serde::Serialize;

use super::relief::{zigzag, ReliefSpec};
use super::{feeds, read_cl, verify, write_gcode, Move, PostConfig};
use crate::machine::MachineConfig;

/// Command-line settings (defaults: the module's choices).
#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// CL data (CSV x,y,z or APT GOTO/ lines); default: the generated
    /// zigzag relief path.
    #[arg(long, value_name = "FILE")]
    pub cl: Option<PathBuf>,
    /// F_min, mm/min.
    #[arg(long, default_value_t = 300.0)]
    pub f_min: f64,
    /// F_max, mm/min.
    #[arg(long, default_value_t = 1500.0)]
    pub f_max: f64,
    /// Clamp F̃ to [F_min, F_max].
    #[arg(long)]
    pub clamp: bool,
    /// Forced feed on pick-feed moves, mm/min.
    #[arg(long, default_value_t = 600.0)]
    pub pick_feed_speed: f64,
    /// The constant feed compared with, mm/min.
    #[arg(long, default_value_t = 600.0)]
    pub constant_feed: f64,
    /// Map y to the rotary axis A (eq. 1): emit X A Z.
    #[arg(long)]
    pub rotary: bool,
    /// Generated path: pick feed (row spacing), mm.
    #[arg(long, default_value_t = 1.0)]
    pub pick_mm: f64,
    /// Generated path: CAM chord tolerance, mm.
    #[arg(long, default_value_t = 0.01)]
    pub tolerance_mm: f64,
    /// Write program.nc, moves.csv and summary.json here.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

/// The figures of a run.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct Summary {
    /// Where the CL data came from.
    pub source: String,
    /// CL points.
    pub cl_points: usize,
    /// Cutting moves.
    pub cutting_moves: usize,
    /// Pick-feed moves.
    pub pick_feed_moves: usize,
    /// Path length, mm.
    pub length_mm: f64,
    /// Smallest, mean (over moves) and largest F word on cutting moves, mm/min.
    pub feed_min_mean_max_mm_per_min: [f64; 3],
    /// Machining time with the fuzzy feeds, s (machine model).
    pub time_fuzzy_s: f64,
    /// Machining time at the constant feed, s (machine model).
    pub time_constant_s: f64,
    /// `1 − fuzzy/constant`, %.
    pub reduction_pct: f64,
    /// Same without acc/dec (length / feed per move), s.
    pub ideal_time_fuzzy_s: f64,
    /// Same without acc/dec, s.
    pub ideal_time_constant_s: f64,
    /// Largest position (or angle) difference after reading back, mm (°).
    pub readback_position_error: f64,
    /// Largest feed difference after reading back, mm/min.
    pub readback_feed_error_mm_per_min: f64,
    /// Machine model used for the times.
    pub machine: String,
    /// What the paper reports.
    pub paper_reduction_pct: f64,
}

/// Machining time of the CL moves at `feeds` (per move) on `machine`, s.
pub fn machining_time_s(
    machine: &MachineConfig,
    points: &[[f64; 3]],
    move_feeds: &[f64],
) -> Result<f64> {
    ensure!(move_feeds.len() + 1 == points.len(), "one feed per move");
    let ts = 0.001;
    machine.validate(ts)?;
    // Feed of the block ending at point i; point 0 has none.
    let mut f = Vec::with_capacity(points.len());
    f.push(move_feeds.first().copied().unwrap_or(0.0));
    f.extend_from_slice(move_feeds);
    Ok(machine.simulate(points, &f, ts).cycle_time_s())
}

/// Everything a run produced.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    /// The CL points.
    pub points: Vec<[f64; 3]>,
    /// The NC moves with their feeds.
    pub moves: Vec<Move>,
    /// The G-code program.
    pub program: String,
    /// The figures.
    pub summary: Summary,
}

/// Run the post-processor and the comparison.
pub fn evaluate(a: &Args) -> Result<Run> {
    let (points, source) = match &a.cl {
        Some(p) => {
            let text =
                std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?;
            (
                read_cl(&text).with_context(|| format!("in {}", p.display()))?,
                p.display().to_string(),
            )
        }
        None => {
            let spec = ReliefSpec {
                pick_feed_mm: a.pick_mm,
                tolerance_mm: a.tolerance_mm,
                ..ReliefSpec::default()
            };
            (
                zigzag(&spec)?,
                format!(
                    "generated zigzag relief {}×{} mm, pick {} mm, tolerance {} mm",
                    spec.width_mm, spec.length_mm, spec.pick_feed_mm, spec.tolerance_mm
                ),
            )
        }
    };
    ensure!(
        a.constant_feed.is_finite() && a.constant_feed > 0.0,
        "constant feed must be positive"
    );
    let cfg = PostConfig {
        f_min_mm_per_min: a.f_min,
        f_max_mm_per_min: a.f_max,
        clamp: a.clamp,
        pick_feed_mm_per_min: a.pick_feed_speed,
        rotary: a.rotary,
    };
    let moves = feeds(&points, &cfg)?;
    let program = write_gcode(&points, &moves, &cfg)?;
    let (pe, fe) = verify(&program, &points, &moves, a.rotary)?;
    let machine = MachineConfig::default();
    let fuzzy: Vec<f64> = moves.iter().map(|m| m.feed_mm_per_min).collect();
    let constant = vec![a.constant_feed; moves.len()];
    let t_f = machining_time_s(&machine, &points, &fuzzy)?;
    let t_c = machining_time_s(&machine, &points, &constant)?;
    let ideal = |f: &[f64]| {
        moves
            .iter()
            .zip(f)
            .map(|(m, f)| m.d_mm / f * 60.0)
            .sum::<f64>()
    };
    let cuts: Vec<f64> = moves
        .iter()
        .filter(|m| !m.pick_feed)
        .map(|m| m.feed_mm_per_min)
        .collect();
    let n = cuts.len().max(1) as f64;
    let summary = Summary {
        source,
        cl_points: points.len(),
        cutting_moves: cuts.len(),
        pick_feed_moves: moves.len() - cuts.len(),
        length_mm: moves.iter().map(|m| m.d_mm).sum(),
        feed_min_mean_max_mm_per_min: [
            cuts.iter().copied().fold(f64::INFINITY, f64::min),
            cuts.iter().sum::<f64>() / n,
            cuts.iter().copied().fold(0.0, f64::max),
        ],
        time_fuzzy_s: t_f,
        time_constant_s: t_c,
        reduction_pct: 100.0 * (1.0 - t_f / t_c),
        ideal_time_fuzzy_s: ideal(&fuzzy),
        ideal_time_constant_s: ideal(&constant),
        readback_position_error: pe,
        readback_feed_error_mm_per_min: fe,
        machine: machine.label(),
        paper_reduction_pct: 20.0,
    };
    Ok(Run {
        points,
        moves,
        program,
        summary,
    })
}

/// The moves as CSV.
pub fn moves_csv(moves: &[Move]) -> String {
    let mut s = String::from(
        "i,x,y,z,a_deg,pick_feed,d_mm,dd_mm,f_mm_per_min,df_mm_per_min,feed_mm_per_min\n",
    );
    for (i, m) in moves.iter().enumerate() {
        let _ = writeln!(
            s,
            "{},{:.4},{:.4},{:.4},{},{},{:.4},{:.4},{:.2},{:.2},{:.2}",
            i,
            m.to[0],
            m.to[1],
            m.to[2],
            m.a_deg.map_or(String::new(), |a| format!("{a:.4}")),
            u8::from(m.pick_feed),
            m.d_mm,
            m.dd_mm,
            m.base_mm_per_min,
            m.compensation_mm_per_min,
            m.feed_mm_per_min
        );
    }
    s
}

/// Run the subcommand.
pub fn run(a: &Args) -> Result<()> {
    let Run {
        moves,
        program,
        summary: s,
        ..
    } = evaluate(a)?;
    println!("Nagata et al. fuzzy post-processor: {}", s.source);
    println!(
        "{} CL points: {} cutting moves, {} pick-feed moves at {} mm/min, {:.1} mm",
        s.cl_points, s.cutting_moves, s.pick_feed_moves, a.pick_feed_speed, s.length_mm
    );
    println!(
        "F words on cutting moves (F_min {}, F_max {}{}): min {:.1}, mean {:.1}, max {:.1} mm/min",
        a.f_min,
        a.f_max,
        if a.clamp { ", clamped" } else { "" },
        s.feed_min_mean_max_mm_per_min[0],
        s.feed_min_mean_max_mm_per_min[1],
        s.feed_min_mean_max_mm_per_min[2]
    );
    println!(
        "machining time ({}): fuzzy {:.1} s, constant {} mm/min {:.1} s, reduction {:.1} % (paper: about 20 %)",
        s.machine, s.time_fuzzy_s, a.constant_feed, s.time_constant_s, s.reduction_pct
    );
    println!(
        "without acc/dec: fuzzy {:.1} s, constant {:.1} s",
        s.ideal_time_fuzzy_s, s.ideal_time_constant_s
    );
    println!(
        "read back: {} G1 moves, largest position error {:.2e} {}, feed error {:.2e} mm/min",
        moves.len() + 1,
        s.readback_position_error,
        if a.rotary { "mm/°" } else { "mm" },
        s.readback_feed_error_mm_per_min
    );
    if let Some(dir) = &a.out {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        crate::output::write(dir.join("program.nc"), &program)?;
        crate::output::write(dir.join("moves.csv"), moves_csv(&moves))?;
        crate::output::write(
            dir.join("summary.json"),
            serde_json::to_string_pretty(&s)? + "\n",
        )?;
        figure(&moves, a.constant_feed, &dir.join("fig5"))?;
        println!("wrote {}", dir.display());
    }
    Ok(())
}

/// Fig. 5: the F word of every move, and the constant feed.
fn figure(moves: &[Move], constant: f64, stem: &std::path::Path) -> Result<()> {
    use crate::plots::{write_figure, Figure, Formats};
    use plotters::style::{BLUE, RED};
    let f: Vec<(f64, f64)> = moves
        .iter()
        .enumerate()
        .map(|(i, m)| (i as f64, m.feed_mm_per_min))
        .collect();
    let n = moves.len() as f64;
    let fig = Figure {
        size: (1000, 450),
        panels: vec![(
            "Fuzzy feed rate per NC block (pick feeds at the forced speed)".into(),
            "block".into(),
            "mm/min".into(),
            vec![
                ("F~(i)".into(), BLUE, f),
                ("constant".into(), RED, vec![(0.0, constant), (n, constant)]),
            ],
        )],
        equal_axes: false,
    };
    write_figure(stem, &fig, Formats::Svg)
}
