//! Nagata, Kuribayashi, Kusumoto & Watanabe's post-processor (sections 2-4):
//! CL data (x, y, z points of a zigzag path) → NC data (G-code) with a
//! fuzzy F word on every cutting move, the forced pick-feed speed on
//! pick-feed moves, and optionally the rotary-unit mapping of eq. 1
//! (X A Z instead of X Y Z).
//!
//! The feed generator is fuzzy-core's ([`fuzzy_core::nagata`]: eq. 2-7,
//! Table 1), the code a controller would run.
//!
//! | paper | here |
//! |---|---|
//! | eq. 1: `a(i) = 360·(y(i) − y_min)/y_length` | [`rotary_angles`] |
//! | section 3: `d(i)`, `Δd(i)`, eq. 2-7 | [`feeds`] via [`fuzzy_core::nagata::FeedGenerator`] |
//! | section 4: 600 mm/min forced on every pick-feed motion | [`PostConfig::pick_feed_mm_per_min`] |
//! | section 4: machining time vs constant 600 mm/min (−20 %) | `host-sim nagata` ([`command`]) on the FANUC-like machine model |
//!
//! # Choices where the paper is silent
//!
//! - **Which moves are pick feeds.** The CL path is a zigzag with the pick
//!   feed along y (section 2: "the pick feed direction is parallel to … the
//!   y-direction"), so a CL step that changes y is a pick-feed move, every
//!   other step a cutting move.
//! - **Indices.** The move `p(i) → p(i+1)` gets `F̃(i)` from `d(i)` and
//!   `Δd(i) = d(i+1) − d(i)` over the raw CL sequence (a pick-feed step
//!   counts as the next step: the last cut of a row sees the short pick feed
//!   ahead and slows); the last move has `Δd = 0`.
//! - **F_min, F_max** ("estimated in advance", not printed): 300 and 1500
//!   mm/min by default — below and above the constant 600 mm/min the paper
//!   compares with, so that short segments (curved or edged parts, where
//!   the chipping is) are cut slower than the constant feed and long ones
//!   faster. The time reduction depends on them and on the part (README).
//! - **Rotary output.** The F word is written unchanged in X A Z blocks
//!   (the paper does not say how it converts the feed for the rotary unit);
//!   the machining time is computed on the flat X Y Z path.
//! - **Program frame.** `G21 G90 G94 G17`, a retract to 5 mm above the
//!   highest CL point, a rapid to above the first point, the plunge at the
//!   pick-feed speed, the CL moves, a retract, `M30`. Coordinates with 4
//!   decimals (0.1 µm), angles with 4 (0.0001°, finer than the rotary
//!   unit's 0.0027°), feeds with 1.

pub mod command;
pub mod relief;

use std::fmt::Write as _;

use anyhow::{bail, ensure, Context, Result};
use fuzzy_core::nagata::{segment_lengths, FeedGenerator, FeedLimits, FeedRange};
use fuzzy_core::units::{FeedMmPerMin, Point3Mm};

/// Settings of the post-processor.
#[derive(Clone, Debug, PartialEq)]
pub struct PostConfig {
    /// F_min, mm/min.
    pub f_min_mm_per_min: f64,
    /// F_max, mm/min.
    pub f_max_mm_per_min: f64,
    /// Clamp F̃ to [F_min, F_max] (the paper does not).
    pub clamp: bool,
    /// Forced feed on pick-feed moves, mm/min (paper: 600).
    pub pick_feed_mm_per_min: f64,
    /// Map y to the rotary axis A (eq. 1).
    pub rotary: bool,
}

impl Default for PostConfig {
    fn default() -> Self {
        PostConfig {
            f_min_mm_per_min: 300.0,
            f_max_mm_per_min: 1500.0,
            clamp: false,
            pick_feed_mm_per_min: 600.0,
            rotary: false,
        }
    }
}

/// One NC move: `p(i) → p(i+1)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Move {
    /// Target point (CL), mm.
    pub to: [f64; 3],
    /// Rotary angle of the target (eq. 1), degrees, when mapping.
    pub a_deg: Option<f64>,
    /// Pick-feed move (forced feed).
    pub pick_feed: bool,
    /// `d(i)`, mm.
    pub d_mm: f64,
    /// `Δd(i)`, mm.
    pub dd_mm: f64,
    /// `F(i)` (eq. 4), mm/min (0 on pick feeds).
    pub base_mm_per_min: f64,
    /// `ΔF(i)` (eq. 5), mm/min (0 on pick feeds).
    pub compensation_mm_per_min: f64,
    /// The F word, mm/min.
    pub feed_mm_per_min: f64,
}

/// Eq. 1 for every point: `360·(y − y_min)/(y_max − y_min)`.
pub fn rotary_angles(points: &[[f64; 3]]) -> Result<Vec<f64>> {
    let (lo, hi) = points
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p[1]), hi.max(p[1]))
        });
    let len = hi - lo;
    ensure!(
        len.is_finite() && len > 0.0,
        "rotary mapping needs CL points spread along y (y_length = 0)"
    );
    Ok(points.iter().map(|p| 360.0 * (p[1] - lo) / len).collect())
}

fn fixed_point(p: &[f64; 3]) -> Result<Point3Mm> {
    Point3Mm::from_f64(p[0], p[1], p[2])
        .filter(|q| q.within_limits())
        .with_context(|| format!("CL point {p:?} is beyond the coordinate range"))
}

/// The moves of the CL data with their feeds.
pub fn feeds(points: &[[f64; 3]], cfg: &PostConfig) -> Result<Vec<Move>> {
    ensure!(points.len() >= 2, "CL data need at least two points");
    let f = |v: f64, what: &str| {
        ensure!(v.is_finite() && v > 0.0, "{what} must be positive");
        Ok(FeedMmPerMin::from_f64(v))
    };
    let limits = FeedLimits {
        f_min: f(cfg.f_min_mm_per_min, "F_min")?,
        f_max: f(cfg.f_max_mm_per_min, "F_max")?,
    };
    f(cfg.pick_feed_mm_per_min, "pick-feed speed")?;
    let range = if cfg.clamp {
        FeedRange::Clamp
    } else {
        FeedRange::Paper
    };
    let generator = FeedGenerator::new(limits, range).map_err(|e| anyhow::anyhow!("{e}"))?;
    let fixed: Vec<Point3Mm> = points.iter().map(fixed_point).collect::<Result<_>>()?;
    let angles = if cfg.rotary {
        Some(rotary_angles(points)?)
    } else {
        None
    };
    let mut out = Vec::with_capacity(points.len() - 1);
    for i in 0..points.len() - 1 {
        let (d, dd) = segment_lengths(&fixed[i], &fixed[i + 1], fixed.get(i + 2));
        let pick = (points[i + 1][1] - points[i][1]).abs() > 1e-9;
        let (base, comp, feed) = if pick {
            (0.0, 0.0, cfg.pick_feed_mm_per_min)
        } else {
            let r = generator.feed(d, dd);
            (
                r.base.to_f64(),
                r.compensation.to_num::<f64>(),
                r.feed.to_f64(),
            )
        };
        out.push(Move {
            to: points[i + 1],
            a_deg: angles.as_ref().map(|a| a[i + 1]),
            pick_feed: pick,
            d_mm: d.to_num(),
            dd_mm: dd.to_num(),
            base_mm_per_min: base,
            compensation_mm_per_min: comp,
            feed_mm_per_min: feed,
        });
    }
    Ok(out)
}

/// Safe height of the program: 5 mm above the highest CL point.
pub fn safe_z(points: &[[f64; 3]]) -> f64 {
    points
        .iter()
        .map(|p| p[2])
        .fold(f64::NEG_INFINITY, f64::max)
        + 5.0
}

/// The NC program (module docs: frame and formats).
pub fn write_gcode(points: &[[f64; 3]], moves: &[Move], cfg: &PostConfig) -> Result<String> {
    ensure!(
        moves.len() + 1 == points.len(),
        "moves do not match the CL points"
    );
    let mut s = String::new();
    let zs = safe_z(points);
    let p0 = points[0];
    let second = |a: Option<f64>, y: f64| match a {
        Some(a) => format!("A{a:.4}"),
        None => format!("Y{y:.4}"),
    };
    let a0 = if cfg.rotary {
        rotary_angles(points)?.first().copied()
    } else {
        None
    };
    let _ = writeln!(s, "%");
    let _ = writeln!(
        s,
        "(Nagata et al. fuzzy post-processor: {} CL points, F_min {} F_max {} mm/min, pick feed {} mm/min{})",
        points.len(),
        cfg.f_min_mm_per_min,
        cfg.f_max_mm_per_min,
        cfg.pick_feed_mm_per_min,
        if cfg.rotary { ", y mapped to A (eq. 1)" } else { "" }
    );
    let _ = writeln!(s, "G21 G90 G94 G17");
    let _ = writeln!(s, "G0 Z{zs:.4}");
    let _ = writeln!(s, "G0 X{:.4} {}", p0[0], second(a0, p0[1]));
    let _ = writeln!(s, "G1 Z{:.4} F{:.1}", p0[2], cfg.pick_feed_mm_per_min);
    for m in moves {
        let _ = writeln!(
            s,
            "G1 X{:.4} {} Z{:.4} F{:.1}",
            m.to[0],
            second(m.a_deg, m.to[1]),
            m.to[2],
            m.feed_mm_per_min
        );
    }
    let _ = writeln!(s, "G0 Z{zs:.4}");
    let _ = writeln!(s, "M30");
    let _ = writeln!(s, "%");
    Ok(s)
}

/// A G1 block read back from the program: X, Y-or-A, Z and F (modal).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParsedMove {
    /// X, Y or A, Z after the block.
    pub pos: [f64; 3],
    /// F in effect, mm/min.
    pub feed_mm_per_min: f64,
}

/// Read the program back with the `gcode` crate (the parser host-sim's
/// G-code reader uses), taking the second coordinate from A when
/// `rotary`: the feed moves (G1) in order.
pub fn parse_back(text: &str, rotary: bool) -> Result<Vec<ParsedMove>> {
    let program = gcode::parse(text)
        .map_err(|d| anyhow::anyhow!("the program does not parse: {:?}", d.iter().next()))?;
    let second = if rotary { 'A' } else { 'Y' };
    let mut pos = [f64::NAN; 3];
    let mut feed = f64::NAN;
    let mut out = Vec::new();
    for b in &program.blocks {
        for code in &b.codes {
            let gcode::Code::General(g) = code else {
                continue;
            };
            let get = |l: char| {
                g.args
                    .iter()
                    .find(|a| a.letter.to_ascii_uppercase() == l)
                    .and_then(|a| match &a.value {
                        gcode::Value::Literal(v) => {
                            // Re-read from the source in f64 (the crate keeps f32).
                            let src = text.get(a.span.start..a.span.start + a.span.length)?;
                            src.get(1..)?.trim().parse::<f64>().ok().or(Some(*v as f64))
                        }
                        _ => None,
                    })
            };
            for (k, l) in ['X', second, 'Z'].into_iter().enumerate() {
                if let Some(v) = get(l) {
                    pos[k] = v;
                }
            }
            if let Some(f) = get('F') {
                feed = f;
            }
            let (major, minor) = (g.number.major(), g.number.minor());
            if major == 1 && minor.is_none() {
                if pos.iter().any(|v| v.is_nan()) || feed.is_nan() {
                    bail!("G1 before every axis and F are known");
                }
                out.push(ParsedMove {
                    pos,
                    feed_mm_per_min: feed,
                });
            }
        }
    }
    Ok(out)
}

/// Check that `text` reads back as the CL moves with their feeds: largest
/// position error (mm, or degrees for A) and feed error (mm/min).
pub fn verify(text: &str, points: &[[f64; 3]], moves: &[Move], rotary: bool) -> Result<(f64, f64)> {
    let parsed = parse_back(text, rotary)?;
    // The first G1 is the plunge to p(0).
    ensure!(
        parsed.len() == moves.len() + 1,
        "read back {} feed moves, expected {}",
        parsed.len(),
        moves.len() + 1
    );
    let angles = if rotary {
        Some(rotary_angles(points)?)
    } else {
        None
    };
    let (mut pos_err, mut feed_err) = (0.0f64, 0.0f64);
    for (i, (p, m)) in parsed.iter().skip(1).zip(moves).enumerate() {
        let want = [
            m.to[0],
            angles.as_ref().map_or(m.to[1], |a| a[i + 1]),
            m.to[2],
        ];
        for (got, want) in p.pos.iter().zip(want) {
            pos_err = pos_err.max((got - want).abs());
        }
        feed_err = feed_err.max((p.feed_mm_per_min - m.feed_mm_per_min).abs());
    }
    Ok((pos_err, feed_err))
}

/// Read CL data: CSV (`x,y,z` per line; `#` comments and a header line
/// allowed) or APT-style `GOTO/x,y,z` lines (other lines ignored).
pub fn read_cl(text: &str) -> Result<Vec<[f64; 3]>> {
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let body = if let Some(rest) = line.strip_prefix("GOTO/") {
            rest
        } else if line.contains('/') || line.chars().next().is_some_and(|c| c.is_alphabetic()) {
            continue; // APT statements other than GOTO, or a CSV header
        } else {
            line
        };
        let v: Vec<f64> = body
            .split(',')
            .take(3)
            .map(|t| t.trim().parse::<f64>())
            .collect::<std::result::Result<_, _>>()
            .with_context(|| format!("CL line {}: {line:?}", n + 1))?;
        ensure!(
            v.len() == 3 && v.iter().all(|c| c.is_finite()),
            "CL line {}: need x,y,z",
            n + 1
        );
        out.push([v[0], v[1], v[2]]);
    }
    ensure!(out.len() >= 2, "CL data need at least two points");
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small() -> Vec<[f64; 3]> {
        vec![
            [0.0, 0.0, 0.0],
            [20.0, 0.0, 0.0],
            [20.5, 0.0, 0.2],
            [21.0, 0.0, 0.0],
            [30.0, 0.0, 0.0],
            [30.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ]
    }

    #[test]
    fn pick_feeds_are_forced_and_cuts_follow_segment_length() {
        let p = small();
        let m = feeds(&p, &PostConfig::default()).unwrap();
        assert_eq!(m.len(), 6);
        assert!(m[4].pick_feed && m[4].feed_mm_per_min == 600.0);
        assert!(m.iter().filter(|m| m.pick_feed).count() == 1);
        // The long first cut faster than the short ones around the bump.
        assert!(m[0].feed_mm_per_min > 1000.0, "{:?}", m[0]);
        assert!(m[1].feed_mm_per_min < 600.0, "{:?}", m[1]);
        assert!((m[0].d_mm - 20.0).abs() < 1e-9);
        // Δd(i) = d(i+1) − d(i); the last move has Δd = 0.
        assert!((m[0].dd_mm - (m[1].d_mm - 20.0)).abs() < 1e-6);
        assert_eq!(m[5].dd_mm, 0.0);
        // Eq. 6.
        for c in m.iter().filter(|m| !m.pick_feed) {
            let sum = c.base_mm_per_min + c.compensation_mm_per_min;
            assert!((c.feed_mm_per_min - sum).abs() < 1e-3, "{c:?}");
        }
    }

    #[test]
    fn rotary_mapping_is_eq1() {
        let p = vec![[0.0, 2.0, 0.0], [1.0, 4.0, 0.0], [2.0, 12.0, 1.0]];
        assert_eq!(rotary_angles(&p).unwrap(), vec![0.0, 72.0, 360.0]);
        assert!(rotary_angles(&[[0.0; 3], [1.0, 0.0, 0.0]]).is_err());
    }

    #[test]
    fn program_reads_back_in_both_modes() {
        let p = small();
        for rotary in [false, true] {
            let cfg = PostConfig {
                rotary,
                ..PostConfig::default()
            };
            let m = feeds(&p, &cfg).unwrap();
            let g = write_gcode(&p, &m, &cfg).unwrap();
            assert_eq!(g.contains(" A"), rotary, "{g}");
            let (pe, fe) = verify(&g, &p, &m, rotary).unwrap();
            assert!(pe <= 5.1e-5 && fe <= 0.051, "{pe} {fe}");
        }
        // The project's own G-code reader takes the X Y Z program.
        let cfg = PostConfig::default();
        let m = feeds(&p, &cfg).unwrap();
        let g = write_gcode(&p, &m, &cfg).unwrap();
        let t = crate::gcode::parse("n", &g, &Default::default()).unwrap();
        assert_eq!(t.points.last(), Some(&[0.0, 1.0, safe_z(&p)]));
    }

    #[test]
    fn cl_formats() {
        let csv = "x,y,z\n# c\n0,0,0\n1,2,3\n";
        assert_eq!(read_cl(csv).unwrap(), vec![[0.0; 3], [1.0, 2.0, 3.0]]);
        let apt = "PARTNO/X\nGOTO/0,0,0\nFEDRAT/600\nGOTO/1.5,2,3\nFINI\n";
        assert_eq!(read_cl(apt).unwrap(), vec![[0.0; 3], [1.5, 2.0, 3.0]]);
        assert!(read_cl("0,0\n1,1\n").is_err());
        assert!(read_cl("0,0,0\n").is_err());
    }
}
