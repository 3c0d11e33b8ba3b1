//! The planned speed profile against arc length: the speed the tool runs,
//! under the envelope the planner kept, under each point's ceiling and each
//! segment's cap; and the per-axis accelerations against their limits.

use plotters::style::RGBColor;

use super::{PlannedRun, PlannerSettings};
use crate::plots::{thin, Figure};

/// The figure for `run` on path `name`; `scheduled` (mm/min per point, if
/// given) is the feed the planner took as upper bound.
pub fn speed_profile_figure(
    name: &str,
    run: &PlannedRun,
    settings: &PlannerSettings,
    scheduled: Option<&[f64]>,
) -> Figure {
    let per_min = |v: f64| v * 60.0;
    // Ceilings above the maximum feed (straight lines) are drawn at it.
    let top = settings.feed_max_mm_per_min;
    let ceiling: Vec<(f64, f64)> = run
        .points
        .iter()
        .map(|p| (p.s_mm, per_min(p.ceiling_mm_per_s).min(top)))
        .collect();
    let mut cap = Vec::with_capacity(2 * run.points.len());
    for w in run.points.windows(2) {
        let c = per_min(w[0].cap_mm_per_s).min(top);
        cap.push((w[0].s_mm, c));
        cap.push((w[1].s_mm, c));
    }
    let envelope: Vec<(f64, f64)> = run
        .points
        .iter()
        .map(|p| (p.s_mm, per_min(p.envelope_mm_per_s).min(top)))
        .collect();
    // The feed of the block ending at each point, drawn along the block.
    let mut feed = Vec::new();
    if let Some(sch) = scheduled {
        for w in run.points.windows(2) {
            let f = sch.get(w[1].index).copied().unwrap_or(0.0).min(top);
            feed.push((w[0].s_mm, f));
            feed.push((w[1].s_mm, f));
        }
    }
    // From the record: every tick, or each stretch's extremes on a long
    // run (both what `thin` keeps of the whole series).
    let buckets = run.trace.buckets();
    let speed: Vec<(f64, f64)> = buckets
        .iter()
        .flat_map(|b| b.speed.in_order())
        .map(|(s, v)| (s, per_min(v)))
        .collect();
    let axes = ["X", "Y", "Z"];
    let colours = [
        RGBColor(31, 119, 180),
        RGBColor(214, 39, 40),
        RGBColor(44, 160, 44),
    ];
    let moving: Vec<usize> = (0..3).filter(|&a| run.trace.moved(a)).collect();
    let acc: Vec<_> = moving
        .iter()
        .map(|&a| {
            let lim = settings.axis_accel_max_mm_per_s2[a] as f64;
            let xy: Vec<(f64, f64)> = buckets
                .iter()
                .filter_map(|b| b.axis_accel.as_ref())
                .flat_map(|e| e[a].in_order())
                .map(|(s, acc)| (s, acc / lim))
                .collect();
            (format!("{} / {lim} mm/s²", axes[a]), colours[a], thin(&xy))
        })
        .collect();
    Figure {
        size: (1200, 900),
        equal_axes: false,
        panels: vec![
            (
                format!(
                    "{name}: planned speed ({:.3} s; lookahead {} points)",
                    run.cycle_time_s(),
                    settings.buffer_points
                ),
                "arc length (mm)".into(),
                "speed (mm/min)".into(),
                [
                    (
                        "scheduled feed".into(),
                        RGBColor(148, 103, 189),
                        thin(&feed),
                    ),
                    ("segment cap".into(), RGBColor(170, 170, 170), thin(&cap)),
                    (
                        "point ceiling".into(),
                        RGBColor(255, 127, 14),
                        thin(&ceiling),
                    ),
                    ("envelope".into(), RGBColor(44, 160, 44), thin(&envelope)),
                    ("speed".into(), RGBColor(31, 119, 180), thin(&speed)),
                ]
                .into_iter()
                .filter(|s| !s.2.is_empty())
                .collect(),
            ),
            (
                "per-axis acceleration / limit (from the commanded positions)".into(),
                "arc length (mm)".into(),
                "a / A".into(),
                acc,
            ),
        ],
    }
}
