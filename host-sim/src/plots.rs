//! Plots with `plotters`, as PNG and/or SVG:
//!
//! - feed, tangential acceleration and jerk against time, one line per
//!   method (Lin et al. Figures 14-29 show one method per figure; one chart
//!   per maximum feed with every method reads better);
//! - curvature κ and curvature variation Dκ along the path (Figures 8-10);
//! - the path with the contour error magnified: each actual position is
//!   drawn at its nearest point of the commanded path plus the error vector
//!   times a magnification (the factor is in the title), as Cho et al.
//!   draw their contouring results (×200, ×600).
//!
//! Long series are thinned to at most [`MAX_POINTS`] points by keeping the
//! minimum and maximum of each bucket, so spikes (jerk!) survive.
//!
//! Text needs a TrueType font: DejaVu Sans or Liberation Sans from the usual
//! system folders (Debian: `fonts-dejavu-core`), or the file named by the
//! environment variable `HOST_SIM_FONT`.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use anyhow::{anyhow, bail, Result};
use plotters::coord::Shift;
use plotters::prelude::*;

use crate::methods::Method;
use crate::output;
use crate::simulate::{Prepared, RunResult};

/// Most points drawn per series.
pub const MAX_POINTS: usize = 4000;

/// Output formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Formats {
    /// PNG only.
    Png,
    /// SVG only.
    Svg,
    /// Both.
    Both,
}

impl Formats {
    fn extensions(self) -> &'static [&'static str] {
        match self {
            Formats::Png => &["png"],
            Formats::Svg => &["svg"],
            Formats::Both => &["png", "svg"],
        }
    }
}

const FONT_CANDIDATES: [&str; 5] = [
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/usr/share/fonts/liberation-sans/LiberationSans-Regular.ttf",
];

/// Register a sans-serif font with plotters once.
fn ensure_font() -> Result<()> {
    static FONT: OnceLock<std::result::Result<(), String>> = OnceLock::new();
    FONT.get_or_init(|| {
        let mut paths: Vec<PathBuf> = Vec::new();
        if let Ok(p) = std::env::var("HOST_SIM_FONT") {
            paths.push(p.into());
        }
        paths.extend(FONT_CANDIDATES.iter().map(PathBuf::from));
        for p in paths {
            if let Ok(bytes) = std::fs::read(&p) {
                let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                if plotters::style::register_font("sans-serif", FontStyle::Normal, bytes).is_ok() {
                    return Ok(());
                }
            }
        }
        Err("no TrueType font found for plot text: install fonts-dejavu-core, set HOST_SIM_FONT=/path/to/font.ttf, or pass --no-plots".into())
    })
    .clone()
    .map_err(|e| anyhow!(e))
}

/// Thin `(x, y)` to at most `MAX_POINTS` keeping each bucket's extremes.
pub fn thin(xy: &[(f64, f64)]) -> Vec<(f64, f64)> {
    if xy.len() <= MAX_POINTS {
        return xy.to_vec();
    }
    let per = xy.len().div_ceil(MAX_POINTS / 2);
    let mut out = Vec::with_capacity(MAX_POINTS + 2);
    for chunk in xy.chunks(per) {
        let (mut lo, mut hi) = (0, 0);
        for (i, p) in chunk.iter().enumerate() {
            if p.1 < chunk[lo].1 {
                lo = i;
            }
            if p.1 > chunk[hi].1 {
                hi = i;
            }
        }
        let (a, b) = if lo <= hi { (lo, hi) } else { (hi, lo) };
        out.push(chunk[a]);
        if b != a {
            out.push(chunk[b]);
        }
    }
    out
}

fn colour(m: Method) -> RGBColor {
    match m {
        Method::Constant => RGBColor(120, 120, 120),
        Method::ChordError => RGBColor(31, 119, 180),
        Method::Fuzzy => RGBColor(214, 39, 40),
        Method::FuzzyNoFilter => RGBColor(255, 127, 14),
        Method::FuzzyPlanner => RGBColor(44, 160, 44),
        Method::Planner => RGBColor(148, 103, 189),
        Method::GrblLike => RGBColor(140, 86, 75),
        Method::Blend => RGBColor(23, 190, 207),
    }
}

/// A colour per method, a second shade for a tighter tolerance.
pub fn variant_colour(m: Method, tolerance_mm: Option<f64>) -> RGBColor {
    match (m, tolerance_mm) {
        (Method::GrblLike, Some(t)) if t < 0.005 => RGBColor(227, 119, 194),
        (Method::Blend, Some(t)) if t < 0.005 => RGBColor(188, 189, 34),
        _ => colour(m),
    }
}

fn range(series: &[Vec<(f64, f64)>]) -> ((f64, f64), (f64, f64)) {
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for s in series {
        for &(x, y) in s {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
    }
    if x0 > x1 {
        return ((0.0, 1.0), (0.0, 1.0));
    }
    if x1 - x0 < 1e-12 {
        x1 = x0 + 1.0;
    }
    let pad = ((y1 - y0) * 0.05).max(1e-9);
    ((x0, x1), (y0 - pad, y1 + pad))
}

type Series = (String, RGBColor, Vec<(f64, f64)>);

fn panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let data: Vec<Vec<(f64, f64)>> = series.iter().map(|s| s.2.clone()).collect();
    let ((x0, x1), (y0, y1)) = range(&data);
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 18))
        .margin(8)
        .x_label_area_size(32)
        .y_label_area_size(70)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|e| anyhow!("plot: {e}"))?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .label_style(("sans-serif", 13))
        .draw()
        .map_err(|e| anyhow!("plot: {e}"))?;
    for (name, c, pts) in series {
        let c = *c;
        chart
            .draw_series(LineSeries::new(pts.iter().copied(), c.stroke_width(1)))
            .map_err(|e| anyhow!("plot: {e}"))?
            .label(name.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2)));
    }
    if series.len() > 1 {
        chart
            .configure_series_labels()
            .border_style(BLACK)
            .background_style(WHITE.mix(0.8))
            .label_font(("sans-serif", 13))
            .draw()
            .map_err(|e| anyhow!("plot: {e}"))?;
    }
    Ok(())
}

/// A figure of stacked panels: each `(title, x label, y label, series)`.
pub struct Figure {
    /// Overall size, pixels.
    pub size: (u32, u32),
    /// Panels, top to bottom.
    pub panels: Vec<(String, String, String, Vec<Series>)>,
    /// Equal axis scales (for path plots).
    pub equal_axes: bool,
}

fn draw_figure<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, fig: &Figure) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(|e| anyhow!("plot: {e}"))?;
    let areas = root.split_evenly((fig.panels.len().max(1), 1));
    for (area, (title, xl, yl, series)) in areas.iter().zip(&fig.panels) {
        if fig.equal_axes {
            path_panel(area, title, series)?;
        } else {
            panel(area, title, xl, yl, series)?;
        }
    }
    Ok(())
}

fn path_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    title: &str,
    series: &[Series],
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let data: Vec<Vec<(f64, f64)>> = series.iter().map(|s| s.2.clone()).collect();
    let ((x0, x1), (y0, y1)) = range(&data);
    // Equal scales: widen the narrower range to the area's aspect ratio.
    let (w, h) = area.dim_in_pixel();
    let (w, h) = ((w as f64 - 80.0).max(1.0), (h as f64 - 60.0).max(1.0));
    let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    let scale = ((x1 - x0) / w).max((y1 - y0) / h);
    let (hx, hy) = (scale * w / 2.0, scale * h / 2.0);
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 18))
        .margin(8)
        .x_label_area_size(32)
        .y_label_area_size(50)
        .build_cartesian_2d(cx - hx..cx + hx, cy - hy..cy + hy)
        .map_err(|e| anyhow!("plot: {e}"))?;
    chart
        .configure_mesh()
        .x_desc("X (mm)")
        .y_desc("Y (mm)")
        .label_style(("sans-serif", 13))
        .draw()
        .map_err(|e| anyhow!("plot: {e}"))?;
    for (name, c, pts) in series {
        let c = *c;
        chart
            .draw_series(LineSeries::new(pts.iter().copied(), c.stroke_width(1)))
            .map_err(|e| anyhow!("plot: {e}"))?
            .label(name.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE.mix(0.8))
        .label_font(("sans-serif", 13))
        .draw()
        .map_err(|e| anyhow!("plot: {e}"))?;
    Ok(())
}

/// Write `fig` as `stem.png` and/or `stem.svg`.
pub fn write_figure(stem: &Path, fig: &Figure, formats: Formats) -> Result<()> {
    ensure_font()?;
    for ext in formats.extensions() {
        let path = stem.with_extension(ext);
        output::write_by_path(&path, |tmp| {
            if *ext == "png" {
                let root = BitMapBackend::new(tmp, fig.size).into_drawing_area();
                draw_figure(&root, fig)?;
                root.present()
                    .map_err(|e| anyhow!("writing {}: {e}", path.display()))
            } else {
                let root = SVGBackend::new(tmp, fig.size).into_drawing_area();
                draw_figure(&root, fig)?;
                root.present()
                    .map_err(|e| anyhow!("writing {}: {e}", path.display()))
            }
        })?;
    }
    Ok(())
}

fn label(r: &RunResult) -> String {
    r.label()
}

/// Feed, acceleration and jerk against time for `runs` (same path, same
/// F_max).
pub fn kinematics_figure(path_name: &str, f_max: f64, runs: &[&RunResult]) -> Figure {
    let series = |f: &dyn Fn(&RunResult) -> Vec<(f64, f64)>| -> Vec<Series> {
        runs.iter()
            .map(|r| {
                (
                    label(r),
                    variant_colour(r.method, r.tolerance_mm),
                    thin(&f(r)),
                )
            })
            .collect()
    };
    let t = |k: usize, ts: f64| k as f64 * ts;
    let feed = series(&|r| {
        r.kinematics
            .speed_mm_per_s
            .iter()
            .enumerate()
            .map(|(k, v)| (t(k, r.motion.ts_s), v * 60.0 / 1000.0))
            .collect()
    });
    let acc = series(&|r| {
        r.kinematics
            .tangential_acc_mm_per_s2
            .iter()
            .enumerate()
            .map(|(k, a)| (t(k, r.motion.ts_s), a / 1000.0))
            .collect()
    });
    let jerk = series(&|r| {
        r.kinematics
            .tangential_jerk_mm_per_s3
            .iter()
            .enumerate()
            .map(|(k, j)| (t(k, r.motion.ts_s), j / 1000.0))
            .collect()
    });
    Figure {
        size: (1100, 1000),
        equal_axes: false,
        panels: vec![
            (
                format!("{path_name}, F_max {f_max} mm/min: (a) feed"),
                "time (s)".into(),
                "feed (m/min)".into(),
                feed,
            ),
            (
                "(b) tangential acceleration".into(),
                "time (s)".into(),
                "acc (m/s²)".into(),
                acc,
            ),
            (
                "(c) tangential jerk".into(),
                "time (s)".into(),
                "jerk (m/s³)".into(),
                jerk,
            ),
        ],
    }
}

/// Curvature and curvature variation along the path (from a fuzzy run).
pub fn curvature_figure(path_name: &str, run: &RunResult) -> Figure {
    let k: Vec<(f64, f64)> = run
        .schedule
        .curvature_per_mm
        .iter()
        .enumerate()
        .map(|(i, k)| (i as f64, *k))
        .collect();
    let dk: Vec<(f64, f64)> = run
        .schedule
        .variation_per_mm
        .iter()
        .enumerate()
        .map(|(i, k)| (i as f64, *k))
        .collect();
    let c = RGBColor(31, 119, 180);
    Figure {
        size: (1100, 700),
        equal_axes: false,
        panels: vec![
            (
                format!("{path_name}: (a) curvature κ (eq. 9)"),
                "point".into(),
                "κ (1/mm)".into(),
                vec![("κ".into(), c, thin(&k))],
            ),
            (
                "(b) curvature variation Dκ (eq. 10)".into(),
                "point".into(),
                "Dκ (1/mm)".into(),
                vec![("Dκ".into(), c, thin(&dk))],
            ),
        ],
    }
}

/// The commanded path and the actual path with its error magnified.
pub fn error_figure(prepared: &Prepared, run: &RunResult) -> Figure {
    let pts = &prepared.path.points;
    let (mut lo, mut hi) = ([f64::MAX; 2], [f64::MIN; 2]);
    for p in pts {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let extent = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1e-9);
    let emax = run.metrics.contour_error_max_mm.max(1e-12);
    // Largest error drawn as 4 % of the path's extent, rounded to 1-2-5.
    let raw = 0.04 * extent / emax;
    let decade = 10f64.powf(raw.log10().floor());
    let mag = [5.0, 2.0, 1.0]
        .iter()
        .map(|m| m * decade)
        .find(|m| *m <= raw)
        .unwrap_or(decade)
        .max(1.0);
    let commanded: Vec<(f64, f64)> = pts.iter().map(|p| (p[0], p[1])).collect();
    let actual: Vec<(f64, f64)> = run
        .motion
        .actual
        .iter()
        .map(|p| {
            let (_, q) = prepared.index.nearest(*p);
            (q[0] + mag * (p[0] - q[0]), q[1] + mag * (p[1] - q[1]))
        })
        .collect();
    Figure {
        size: (900, 800),
        equal_axes: true,
        panels: vec![(
            format!(
                "{}, {}, F_max {}: contour error ×{mag} (max {:.4} mm)",
                prepared.path.name,
                run.method.name(),
                run.f_max_mm_per_min,
                run.metrics.contour_error_max_mm
            ),
            String::new(),
            String::new(),
            vec![
                ("commanded".into(), RGBColor(0, 0, 0), thin_path(&commanded)),
                (
                    format!("actual, error ×{mag}"),
                    colour(run.method),
                    thin_path(&actual),
                ),
            ],
        )],
    }
}

/// Thin a path (keep every k-th point, and the last).
fn thin_path(p: &[(f64, f64)]) -> Vec<(f64, f64)> {
    if p.len() <= MAX_POINTS * 2 {
        return p.to_vec();
    }
    let step = p.len().div_ceil(MAX_POINTS * 2);
    let mut out: Vec<(f64, f64)> = p.iter().step_by(step).copied().collect();
    if let Some(l) = p.last() {
        out.push(*l);
    }
    out
}

/// Every plot for one path: kinematics per F_max, curvature, error of each
/// fuzzy and constant run.
pub fn all(dir: &Path, prepared: &Prepared, runs: &[&RunResult], formats: Formats) -> Result<()> {
    if runs.is_empty() {
        bail!("no runs to plot for {}", prepared.path.name);
    }
    let name = &prepared.path.name;
    let mut feeds: Vec<f64> = runs.iter().map(|r| r.f_max_mm_per_min).collect();
    feeds.sort_by(f64::total_cmp);
    feeds.dedup();
    for f in &feeds {
        let same: Vec<&RunResult> = runs
            .iter()
            .copied()
            .filter(|r| r.f_max_mm_per_min == *f)
            .collect();
        write_figure(
            &dir.join(format!("{name}_kinematics_{f}")),
            &kinematics_figure(name, *f, &same),
            formats,
        )?;
        // The baselines are on the kinematics and Pareto figures.
        for r in same
            .iter()
            .filter(|r| !matches!(r.method, Method::Planner | Method::GrblLike | Method::Blend))
        {
            write_figure(
                &dir.join(format!("{name}_error_{}_{f}", r.method.name())),
                &error_figure(prepared, r),
                formats,
            )?;
        }
    }
    let fuzzy = runs
        .iter()
        .find(|r| matches!(r.method, Method::Fuzzy | Method::FuzzyNoFilter))
        .unwrap_or(&runs[0]);
    // grbl-like and blend compute no curvature.
    if !fuzzy.schedule.curvature_per_mm.is_empty() {
        write_figure(
            &dir.join(format!("{name}_curvature")),
            &curvature_figure(name, fuzzy),
            formats,
        )?;
    }
    Ok(())
}

/// One curve of a Pareto figure: label, colour, (cycle time s, max contour
/// error mm) per maximum feed.
pub type ParetoCurve = (String, RGBColor, Vec<(f64, f64)>);

fn pareto_draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    curves: &[ParetoCurve],
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(|e| anyhow!("plot: {e}"))?;
    let pts = curves.iter().flat_map(|c| c.2.iter()).filter(|p| p.1 > 0.0);
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in pts {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if x0 > x1 {
        bail!("plot: no points");
    }
    let (x0, x1) = (x0 * 0.95, x1 * 1.05 + 1e-9);
    let (y0, y1) = (y0 / 1.3, y1 * 1.3 + 1e-12);
    let mut chart = ChartBuilder::on(root)
        .caption(title, ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(36)
        .y_label_area_size(70)
        .build_cartesian_2d(x0..x1, (y0..y1).log_scale())
        .map_err(|e| anyhow!("plot: {e}"))?;
    chart
        .configure_mesh()
        .x_desc("cycle time (s)")
        .y_desc("max contour error (mm)")
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .label_style(("sans-serif", 13))
        .draw()
        .map_err(|e| anyhow!("plot: {e}"))?;
    for (name, c, pts) in curves {
        let c = *c;
        let pts: Vec<(f64, f64)> = pts.iter().copied().filter(|p| p.1 > 0.0).collect();
        chart
            .draw_series(LineSeries::new(pts.iter().copied(), c.stroke_width(2)))
            .map_err(|e| anyhow!("plot: {e}"))?
            .label(name.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2)));
        chart
            .draw_series(pts.iter().map(|p| Circle::new(*p, 3, c.filled())))
            .map_err(|e| anyhow!("plot: {e}"))?;
    }
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE.mix(0.8))
        .label_font(("sans-serif", 13))
        .draw()
        .map_err(|e| anyhow!("plot: {e}"))?;
    Ok(())
}

/// Max contour error (log scale) against cycle time, one curve per method
/// over the maximum feeds of the sweep: left of and below is better.
pub fn write_pareto(
    stem: &Path,
    title: &str,
    curves: &[ParetoCurve],
    formats: Formats,
) -> Result<()> {
    ensure_font()?;
    let size = (1000, 700);
    for ext in formats.extensions() {
        let path = stem.with_extension(ext);
        output::write_by_path(&path, |tmp| {
            if *ext == "png" {
                let root = BitMapBackend::new(tmp, size).into_drawing_area();
                pareto_draw(&root, title, curves)?;
                root.present()
                    .map_err(|e| anyhow!("writing {}: {e}", path.display()))
            } else {
                let root = SVGBackend::new(tmp, size).into_drawing_area();
                pareto_draw(&root, title, curves)?;
                root.present()
                    .map_err(|e| anyhow!("writing {}: {e}", path.display()))
            }
        })?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thinning_keeps_spikes() {
        let mut xy: Vec<(f64, f64)> = (0..100_000).map(|i| (i as f64, 0.0)).collect();
        xy[54_321].1 = 7.0;
        xy[77_777].1 = -3.0;
        let t = thin(&xy);
        assert!(t.len() <= MAX_POINTS + 2);
        assert!(t.iter().any(|p| p.1 == 7.0) && t.iter().any(|p| p.1 == -3.0));
        assert!(t.windows(2).all(|w| w[0].0 <= w[1].0));
    }
}
