//! `host-sim njiri`: the closed-loop experiment of Njiri et al. (section
//! III.B) from the command line. Prints a summary; with `--out DIR` writes
//! `revolutions.csv` (one row per spindle revolution), `summary.json` and
//! `fig13.svg` (override, feed and peak forces against time: the paper's
//! Fig. 12-13).

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::{Context, Result};
use serde::Serialize;

use super::{law, run as run_experiment, Experiment, Outcome};

/// Command-line settings (defaults: the paper's experiment).
#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// Constant feed, no controller (the paper's Fig. 12 baseline).
    #[arg(long)]
    pub no_control: bool,
    /// Use the FRPO directly as the override (the paper's sentence taken
    /// literally; oscillates, see fuzzy_core::njiri).
    #[arg(long)]
    pub absolute: bool,
    /// Gain of the incremental override law, (0, 1].
    #[arg(long, default_value_t = 0.05)]
    pub gain: f64,
    /// Programmed feed, mm/min.
    #[arg(long, default_value_t = 30.0)]
    pub feed: f64,
    /// Reference peak F_x, N.
    #[arg(long, default_value_t = 120.0)]
    pub ref_fx: f64,
    /// Reference peak F_y, N.
    #[arg(long, default_value_t = 40.0)]
    pub ref_fy: f64,
    /// Radial depth of cut before the step, mm.
    #[arg(long, default_value_t = 1.0)]
    pub depth_before: f64,
    /// Radial depth of cut after the step, mm.
    #[arg(long, default_value_t = 1.5)]
    pub depth_after: f64,
    /// Depth exponent of the F_y model (F_x: 0.5); below 0.5, F_y grows
    /// less with the depth than F_x.
    #[arg(long, default_value_t = 0.5)]
    pub depth_exponent_y: f64,
    /// Simulated time, s.
    #[arg(long, default_value_t = 20.0)]
    pub duration: f64,
    /// Peak-to-peak noise on each measured peak force, N.
    #[arg(long, default_value_t = 0.0)]
    pub noise: f64,
    /// Write revolutions.csv and summary.json here.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

/// What `summary.json` holds.
#[derive(Serialize, Debug)]
struct Summary {
    controlled: bool,
    law: String,
    programmed_feed_mm_per_min: f64,
    reference_n: [f64; 2],
    depth_mm: [f64; 2],
    peak_before_step_n: Option<[f64; 2]>,
    settled_from_s: f64,
    settled_override_pct: f64,
    settled_override_range_pct: (f64, f64),
    settled_feed_mm_per_min: f64,
    settled_peak_n: [f64; 2],
    settled_peak_max_n: [f64; 2],
    settling_time_s: Option<f64>,
    paper_override_pct: f64,
}

/// The experiment the arguments describe.
pub fn experiment(a: &Args) -> Result<Experiment> {
    let mut e = Experiment::paper()?;
    e.controlled = !a.no_control;
    e.control.law = law(a.absolute, a.gain)?;
    anyhow::ensure!(
        a.ref_fx.is_finite() && a.ref_fy.is_finite() && a.ref_fx > 0.0 && a.ref_fy > 0.0,
        "reference forces must be positive"
    );
    e.control.reference = [
        fuzzy_core::njiri::ForceN::from_f64(a.ref_fx),
        fuzzy_core::njiri::ForceN::from_f64(a.ref_fy),
    ];
    e.programmed_feed_mm_per_min = a.feed;
    e.depth_before_mm = a.depth_before;
    e.depth_after_mm = a.depth_after;
    e.model.depth_exponent[1] = a.depth_exponent_y;
    e.duration_s = a.duration;
    e.noise_n = a.noise;
    e.validate()?;
    Ok(e)
}

/// The revolutions as CSV.
pub fn revolutions_csv(o: &Outcome) -> String {
    let mut s = String::from(
        "t_s,x_mm,depth_mm,feed_mm_per_min,peak_fx_n,peak_fy_n,frpo_pct,override_pct\n",
    );
    for r in &o.revolutions {
        let _ = writeln!(
            s,
            "{:.3},{:.5},{:.3},{:.4},{:.3},{:.3},{:.3},{:.3}",
            r.t_s,
            r.x_mm,
            r.depth_mm,
            r.feed_mm_per_min,
            r.peak_n[0],
            r.peak_n[1],
            r.frpo_pct,
            r.override_pct
        );
    }
    s
}

/// Run the subcommand.
pub fn run(a: &Args) -> Result<()> {
    let e = experiment(a)?;
    let o = run_experiment(&e)?;
    let s = &o.settled;
    let law = if !e.controlled {
        "none (constant feed)".to_string()
    } else if a.absolute {
        "absolute (override = FRPO)".to_string()
    } else {
        format!("incremental, gain {}", a.gain)
    };
    println!("Njiri et al. force-feedback override: {law}");
    println!(
        "programmed feed {} mm/min, reference F_x {} N, F_y {} N, depth {} → {} mm",
        e.programmed_feed_mm_per_min, a.ref_fx, a.ref_fy, e.depth_before_mm, e.depth_after_mm
    );
    if let Some(b) = o.before_step {
        println!(
            "before the step (t = {:.1} s): peak F_x {:.1} N, F_y {:.1} N, override {:.1} %",
            b.t_s, b.peak_n[0], b.peak_n[1], b.override_pct
        );
    }
    println!(
        "settled (t ≥ {:.1} s): override {:.1} % (range {:.1}-{:.1} %), feed {:.2} mm/min, \
         peak F_x {:.1} N (max {:.1}), F_y {:.1} N (max {:.1})",
        s.from_s,
        s.override_pct,
        s.override_range_pct.0,
        s.override_range_pct.1,
        s.feed_mm_per_min,
        s.peak_n[0],
        s.peak_max_n[0],
        s.peak_n[1],
        s.peak_max_n[1]
    );
    match s.settling_time_s {
        Some(t) => println!("override within ±1.5 % of its final mean {t:.1} s after the step"),
        None => println!("override does not settle"),
    }
    println!("paper (Fig. 13): override ≈ 78 % (23.4 mm/min), peak force held near the reference");
    if let Some(dir) = &a.out {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        crate::output::write(dir.join("revolutions.csv"), revolutions_csv(&o))?;
        let summary = Summary {
            controlled: e.controlled,
            law,
            programmed_feed_mm_per_min: e.programmed_feed_mm_per_min,
            reference_n: [a.ref_fx, a.ref_fy],
            depth_mm: [e.depth_before_mm, e.depth_after_mm],
            peak_before_step_n: o.before_step.map(|b| b.peak_n),
            settled_from_s: s.from_s,
            settled_override_pct: s.override_pct,
            settled_override_range_pct: s.override_range_pct,
            settled_feed_mm_per_min: s.feed_mm_per_min,
            settled_peak_n: s.peak_n,
            settled_peak_max_n: s.peak_max_n,
            settling_time_s: s.settling_time_s,
            paper_override_pct: 78.0,
        };
        crate::output::write(
            dir.join("summary.json"),
            serde_json::to_string_pretty(&summary)? + "\n",
        )?;
        figure(&o, [a.ref_fx, a.ref_fy], &dir.join("fig13"))?;
        println!("wrote {}", dir.display());
    }
    Ok(())
}

/// Fig. 13: override and feed, and the peak forces with their references,
/// against time.
fn figure(o: &Outcome, reference: [f64; 2], stem: &std::path::Path) -> Result<()> {
    use crate::plots::{write_figure, Figure, Formats};
    use plotters::style::{BLACK, BLUE, RED};
    let t = |f: &dyn Fn(&super::Revolution) -> f64| -> Vec<(f64, f64)> {
        o.revolutions.iter().map(|r| (r.t_s, f(r))).collect()
    };
    let end = o.revolutions.last().map_or(0.0, |r| r.t_s);
    let flat = |v: f64| vec![(0.0, v), (end, v)];
    let fig = Figure {
        size: (900, 900),
        panels: vec![
            (
                "Feed-rate override".into(),
                "t (s)".into(),
                "%".into(),
                vec![
                    ("override".into(), BLUE, t(&|r| r.override_pct)),
                    ("FRPO".into(), RED, t(&|r| r.frpo_pct)),
                ],
            ),
            (
                "Table feed".into(),
                "t (s)".into(),
                "mm/min".into(),
                vec![("feed".into(), BLUE, t(&|r| r.feed_mm_per_min))],
            ),
            (
                "Peak cutting forces".into(),
                "t (s)".into(),
                "N".into(),
                vec![
                    ("F_x".into(), BLUE, t(&|r| r.peak_n[0])),
                    ("F_y".into(), RED, t(&|r| r.peak_n[1])),
                    ("references".into(), BLACK, flat(reference[0])),
                    ("".into(), BLACK, flat(reference[1])),
                ],
            ),
        ],
        equal_axes: false,
    };
    write_figure(stem, &fig, Formats::Svg)
}
