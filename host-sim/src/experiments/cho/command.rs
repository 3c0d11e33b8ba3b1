//! `host-sim cho`: Cho, Lee & Jeon's contour-error feed control on the X-Y
//! servo model, against the best constant feed (Table 4.3).

use std::path::PathBuf;

use anyhow::{Context, Result};

use super::feed_control::{self as cho, ChoSettings, Contour};
use crate::config::SimConfig;
use crate::machine::MachineConfig;

/// Arguments of `cho`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Contours to run (the paper's circle of radius 20 mm and its
    /// +45°→−45° corner).
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = Contour::ALL)]
    pub contours: Vec<Contour>,
    /// Contour-error bound, µm (default: the paper's, 5 for the circle and
    /// 4.5 for the corner).
    #[arg(long)]
    pub bound_um: Option<f64>,
    /// Use only the eight rules printed in Table 3.1 (default: the completed
    /// 5×5 table).
    #[arg(long)]
    pub printed_rules: bool,
    /// Run both rule tables.
    #[arg(long, conflicts_with = "printed_rules")]
    pub both_tables: bool,
    /// K: the change of contour error is scaled by g_ce = K/bound (the
    /// paper says only "scaled as contour error bound"), ticks.
    #[arg(long, default_value_t = 10)]
    pub change_ticks: u16,
    /// Highest feed the controller may reach, mm/min.
    #[arg(long, default_value_t = 6000.0)]
    pub f_max: f64,
    /// TOML configuration: its `[machine]` table, if `kind = "servo_xy"`,
    /// gives the servo parameters (default: Tables 4.1-4.2).
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Write table.txt, cho.json and one trace CSV per run here.
    #[arg(long)]
    pub out_dir: Option<PathBuf>,
}

/// Run `cho`.
pub fn run(args: &Args) -> Result<()> {
    let servo = match &args.config {
        Some(p) => match SimConfig::read(p)?.machine {
            MachineConfig::ServoXy(s) => s,
            MachineConfig::Fanuc(_) => Default::default(),
        },
        None => Default::default(),
    };
    anyhow::ensure!(
        args.f_max.is_finite() && args.f_max > 60.0 && args.f_max <= 60000.0,
        "--f-max must be in (60, 60000] mm/min"
    );
    if let Some(b) = args.bound_um {
        anyhow::ensure!(
            b.is_finite() && (0.1..=1000.0).contains(&b),
            "--bound-um must be in [0.1, 1000]"
        );
    }
    anyhow::ensure!(args.change_ticks >= 1, "--change-ticks must be at least 1");
    let tables: Vec<bool> = if args.both_tables {
        vec![false, true]
    } else {
        vec![args.printed_rules]
    };
    let mut rows = Vec::new();
    for &c in &args.contours {
        for &printed in &tables {
            let mut s = ChoSettings::paper(c);
            s.printed_rules = printed;
            s.f_max_mm_per_min = args.f_max;
            s.change_ticks = args.change_ticks;
            if let Some(b) = args.bound_um {
                s.bound_mm = b * 1e-3;
            }
            rows.push(cho::compare(&servo, c, &s)?);
        }
    }
    let text = cho::table(&rows);
    print!("{text}");
    if let Some(dir) = &args.out_dir {
        std::fs::create_dir_all(dir).with_context(|| format!("{}", dir.display()))?;
        crate::output::write(dir.join("table.txt"), &text)?;
        crate::output::write(dir.join("cho.json"), serde_json::to_string_pretty(&rows)?)?;
        for r in &rows {
            let tag = if r.printed_rules {
                "printed"
            } else {
                "completed"
            };
            for (name, run) in [("fuzzy", &r.fuzzy), ("constant", &r.constant)] {
                let mut csv =
                    String::from("t_s,feed_mm_per_min,online_error_mm,exact_error_mm,x_mm,y_mm\n");
                for row in &run.trace {
                    csv.push_str(&format!(
                        "{:.3},{:.3},{:.7},{:.7},{:.6},{:.6}\n",
                        row[0], row[1], row[2], row[3], row[4], row[5]
                    ));
                }
                let f = dir.join(format!("{}_{tag}_{name}.csv", r.contour.name()));
                crate::output::write(&f, csv).with_context(|| format!("{}", f.display()))?;
            }
        }
    }
    Ok(())
}
