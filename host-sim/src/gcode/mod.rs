//! G-code programs as CAM systems write them → a [`Toolpath`].
//!
//! Parsing (blocks, words, comments, line numbers) is the `gcode` crate's;
//! this module interprets the words. Numbers are re-read from the source
//! text in `f64` (the crate keeps `f32`, which would put ~4 µm of noise on a
//! 100 mm coordinate and spoil three-point curvature on short segments).
//!
//! | words | handling |
//! |---|---|
//! | G0 G1 | straight moves; G0 at the configured rapid feed |
//! | G2 G3 (I J K or R, P turns) | arcs and helices, as points within the chord tolerance ([`arc`]) |
//! | G5.2 … G5.3 (X Y P L) | LinuxCNC NURBS blocks ([`nurbs_block`]) |
//! | G17 G18 G19 | arc plane |
//! | G20 G21 | inch / mm (all output in mm) |
//! | G90 G91, G90.1 G91.1 | absolute / incremental coordinates and arc centres |
//! | F (G94) | feed in units per minute, a cap on the following blocks |
//! | N, comments, `%` | ignored |
//! | M, S, T, H, D words; G4 (dwell), G40, G43, G49, G54-G59.3, G61, G61.1, G64, G80, G94 | **documented skip**: no effect on the path (work and tool offsets are taken as zero; the simulator's own acc/dec replaces the blending modes; dwells do not stop the simulated tool) |
//! | anything else (cutter compensation G41/G42, canned cycles, G28, inverse-time feed, expressions `[…]`, parameters `#`, O-words …) | **error naming the line** |
//!
//! The tool starts at the configured position (the origin by default).
//! Every point keeps its source line, and the feed of its block (or the
//! rapid feed) as a cap.

pub mod arc;
pub mod nurbs_block;

use std::path::Path;

use anyhow::{anyhow, bail, Context, Result};
use serde::{Deserialize, Serialize};

use crate::toolpath::Toolpath;
use arc::{Centre, Plane};

/// How G-code is turned into a toolpath.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GcodeSettings {
    /// Largest distance between an arc (or NURBS) and its chords, mm.
    pub chord_tolerance_mm: f64,
    /// Feed of G0 moves, mm/min (the paper's machine: 48 m/min, Table 1).
    pub rapid_feed_mm_per_min: f64,
    /// Where the tool is when the program starts, mm.
    pub start_mm: [f64; 3],
}

impl Default for GcodeSettings {
    fn default() -> Self {
        GcodeSettings {
            chord_tolerance_mm: 0.001,
            rapid_feed_mm_per_min: 48_000.0,
            start_mm: [0.0; 3],
        }
    }
}

/// Modal state of the interpreter.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Motion {
    Rapid,
    Linear,
    ArcCw,
    ArcCcw,
}

struct State {
    pos: [f64; 3],
    mm_per_unit: f64,
    absolute: bool,
    arc_centre_absolute: bool,
    plane: Plane,
    motion: Option<Motion>,
    feed_mm_per_min: Option<f64>,
}

/// One word of a block: letter, value (f64 from the source), 1-based line.
#[derive(Clone, Copy, Debug)]
struct Word {
    letter: char,
    value: f64,
}

/// The words of one block.
struct Block {
    line: u32,
    g: Vec<(u32, u32)>, // (major, minor·10)
    words: Vec<Word>,
}

impl Block {
    fn get(&self, letter: char) -> Option<f64> {
        self.words
            .iter()
            .find(|w| w.letter == letter)
            .map(|w| w.value)
    }
}

/// Read `value` from the source text of an argument (`X-1.25`), falling
/// back to the crate's `f32`.
fn word_value(src: &str, span: gcode::core::Span, fallback: f32) -> f64 {
    src.get(span.start..span.start + span.length)
        .and_then(|t| t.get(1..))
        .and_then(|t| t.trim().parse::<f64>().ok())
        .unwrap_or(fallback as f64)
}

fn words_of(src: &str, b: &gcode::Block) -> Result<Block> {
    let line = b.span.line as u32 + 1;
    let mut out = Block {
        line,
        g: Vec::new(),
        words: Vec::new(),
    };
    let mut push = |letter: char, value: &gcode::Value, span| -> Result<()> {
        let letter = letter.to_ascii_uppercase();
        let v = match value {
            gcode::Value::Literal(x) => word_value(src, span, *x),
            gcode::Value::Variable(name) => {
                bail!(
                    "line {line}: parameter #{name} is not supported (no expressions or variables)"
                )
            }
            _ => bail!("line {line}: unsupported value for {letter}"),
        };
        if !v.is_finite() {
            bail!("line {line}: {letter} is not a finite number");
        }
        if out.words.iter().any(|w| w.letter == letter) {
            bail!("line {line}: word {letter} appears twice");
        }
        out.words.push(Word { letter, value: v });
        Ok(())
    };
    for code in &b.codes {
        match code {
            gcode::Code::General(g) => {
                let minor = g.number.minor().map_or(0, |m| m.get());
                out.g.push((g.number.major(), minor));
                for a in &g.args {
                    push(a.letter, &a.value, a.span)?;
                }
            }
            gcode::Code::Miscellaneous(m) => {
                // M words: documented skip (spindle, coolant, program end…);
                // their arguments are ignored with them.
                let _ = m;
            }
            gcode::Code::ToolChange(_) => {} // T: documented skip
            _ => bail!("line {line}: unsupported code"),
        }
    }
    for w in &b.word_addresses {
        push(w.letter, &w.value, w.span)?;
    }
    Ok(out)
}

/// Parse G-code text; `name` labels the toolpath.
pub fn parse(name: &str, src: &str, settings: &GcodeSettings) -> Result<Toolpath> {
    let program = gcode::parse(src).map_err(|d| {
        let first = d.iter().next();
        match first {
            Some(diag) => {
                let line = diag.span.line + 1;
                let text = src.lines().nth(diag.span.line).unwrap_or("").trim();
                let hint = if text.contains('[') || text.contains('#') {
                    " (expressions and parameters are not supported)"
                } else {
                    ""
                };
                anyhow!("line {line}: cannot parse {text:?}: {diag}{hint}")
            }
            None => anyhow!("cannot parse the program"),
        }
    })?;
    let mut st = State {
        pos: settings.start_mm,
        mm_per_unit: 1.0,
        absolute: true,
        arc_centre_absolute: false,
        plane: Plane::Xy,
        motion: None,
        feed_mm_per_min: None,
    };
    let mut points = vec![settings.start_mm];
    let mut caps: Vec<Option<f64>> = vec![None];
    let mut lines = vec![0u32];
    let mut nurbs: Option<nurbs_block::Collector> = None;
    for b in &program.blocks {
        let blk = words_of(src, b)?;
        let line = blk.line;
        if let Some(c) = nurbs.as_mut() {
            if blk.g.contains(&(5, 3)) {
                let c = nurbs.take().unwrap_or_else(|| unreachable!());
                let feed = st.feed_mm_per_min.ok_or_else(|| {
                    anyhow!("line {line}: NURBS block without a feed (no F word yet)")
                })?;
                let pts = c.finish(settings.chord_tolerance_mm)?;
                for p in pts {
                    points.push(p);
                    caps.push(Some(feed));
                    lines.push(line);
                }
                st.pos = *points.last().unwrap_or(&st.pos);
                continue;
            }
            if !blk.g.is_empty() {
                bail!("line {line}: only control points (X Y P) may follow G5.2 until G5.3");
            }
            c.add(&st, &blk)?;
            continue;
        }
        // Modal settings first (RS274/NGC order of execution).
        let mut motion_word = None;
        for &(g, m) in &blk.g {
            match (g, m) {
                (0, 0) => motion_word = Some(Motion::Rapid),
                (1, 0) => motion_word = Some(Motion::Linear),
                (2, 0) => motion_word = Some(Motion::ArcCw),
                (3, 0) => motion_word = Some(Motion::ArcCcw),
                (5, 2) => {
                    if st.plane != Plane::Xy {
                        bail!("line {line}: G5.2 needs the XY plane (G17)");
                    }
                    let mut c = nurbs_block::Collector::new(st.pos, line);
                    c.add(&st, &blk)?;
                    nurbs = Some(c);
                }
                (5, 3) => bail!("line {line}: G5.3 without G5.2"),
                (17, 0) => st.plane = Plane::Xy,
                (18, 0) => st.plane = Plane::Zx,
                (19, 0) => st.plane = Plane::Yz,
                (20, 0) => st.mm_per_unit = 25.4,
                (21, 0) => st.mm_per_unit = 1.0,
                (90, 0) => st.absolute = true,
                (91, 0) => st.absolute = false,
                (90, 1) => st.arc_centre_absolute = true,
                (91, 1) => st.arc_centre_absolute = false,
                // Documented skips (module docs).
                (4, 0)
                | (40, 0)
                | (43, 0)
                | (49, 0)
                | (54..=59, _)
                | (61, 0)
                | (61, 1)
                | (64, 0)
                | (80, 0)
                | (94, 0) => {}
                (g, 0) => bail!("line {line}: G{g} is not supported"),
                (g, m) => bail!("line {line}: G{g}.{m} is not supported"),
            }
        }
        if nurbs.is_some() {
            continue;
        }
        for w in &blk.words {
            if !matches!(
                w.letter,
                'X' | 'Y'
                    | 'Z'
                    | 'I'
                    | 'J'
                    | 'K'
                    | 'R'
                    | 'F'
                    | 'P'
                    | 'S'
                    | 'T'
                    | 'H'
                    | 'D'
                    | 'L'
                    | 'Q'
            ) {
                bail!("line {line}: word {} is not supported", w.letter);
            }
        }
        if let Some(f) = blk.get('F') {
            if f <= 0.0 {
                bail!("line {line}: feed F{f} must be positive");
            }
            st.feed_mm_per_min = Some(f * st.mm_per_unit);
        }
        if let Some(m) = motion_word {
            st.motion = Some(m);
        }
        let has_axis = ['X', 'Y', 'Z'].iter().any(|l| blk.get(*l).is_some());
        let dwell = blk.g.contains(&(4, 0));
        if !has_axis || dwell {
            continue;
        }
        let Some(motion) = st.motion else {
            bail!("line {line}: axis words without a motion mode (G0/G1/G2/G3)");
        };
        let mut target = st.pos;
        for (k, l) in ['X', 'Y', 'Z'].iter().enumerate() {
            if let Some(v) = blk.get(*l) {
                let v = v * st.mm_per_unit;
                target[k] = if st.absolute { v } else { st.pos[k] + v };
            }
        }
        let cap = match motion {
            Motion::Rapid => settings.rapid_feed_mm_per_min,
            _ => st
                .feed_mm_per_min
                .ok_or_else(|| anyhow!("line {line}: feed move without a feed (no F word yet)"))?,
        };
        let new_points = match motion {
            Motion::Rapid | Motion::Linear => vec![target],
            Motion::ArcCw | Motion::ArcCcw => {
                let centre = if let Some(r) = blk.get('R') {
                    Centre::Radius(r * st.mm_per_unit)
                } else {
                    let mut c = if st.arc_centre_absolute {
                        [0.0; 3]
                    } else {
                        st.pos
                    };
                    for (k, l) in ['I', 'J', 'K'].iter().enumerate() {
                        if let Some(v) = blk.get(*l) {
                            c[k] += v * st.mm_per_unit;
                        } else if st.arc_centre_absolute {
                            c[k] = st.pos[k];
                        }
                    }
                    Centre::Point(c)
                };
                let turns = blk.get('P').map_or(Ok(0), |p| {
                    if p >= 1.0 && p.fract() == 0.0 {
                        Ok(p as u32 - 1)
                    } else {
                        Err(anyhow!("line {line}: arc P{p} must be a whole number ≥ 1"))
                    }
                })?;
                arc::points(
                    st.pos,
                    target,
                    centre,
                    st.plane,
                    motion == Motion::ArcCw,
                    turns,
                    settings.chord_tolerance_mm,
                )
                .map_err(|e| anyhow!("line {line}: {e}"))?
            }
        };
        for p in new_points {
            points.push(p);
            caps.push(Some(cap));
            lines.push(line);
        }
        st.pos = target;
    }
    if let Some(c) = nurbs {
        bail!("line {}: G5.2 block not closed by G5.3", c.line());
    }
    Toolpath::new(name, points, caps, lines)
}

/// Read a G-code file; errors name the file and the line.
pub fn read(path: &Path, settings: &GcodeSettings) -> Result<Toolpath> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let name = path
        .file_stem()
        .map_or("gcode".into(), |s| s.to_string_lossy().into_owned());
    parse(&name, &text, settings).with_context(|| format!("in {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(src: &str) -> Result<Toolpath> {
        parse("t", src, &GcodeSettings::default())
    }

    #[test]
    fn lines_modal_words_units_and_increments() {
        let t = p(
            "N10 G21 G90 (start)\nG0 X10 Y0 ; rapid\nG1 Y5 F600\nG91 X-2\nG20 G90 G1 X1 F10\n%\n",
        )
        .unwrap();
        assert_eq!(
            t.points,
            vec![
                [0.0; 3],
                [10.0, 0.0, 0.0],
                [10.0, 5.0, 0.0],
                [8.0, 5.0, 0.0],
                [25.4, 5.0, 0.0]
            ]
        );
        assert_eq!(t.lines, vec![0, 2, 3, 4, 5]);
        assert_eq!(
            t.feed_caps,
            vec![None, Some(48_000.0), Some(600.0), Some(600.0), Some(254.0)]
        );
    }

    #[test]
    fn numbers_keep_full_precision() {
        let t = p("G1 X70.342 Y60.210 F100\n").unwrap();
        assert_eq!(t.points[1], [70.342, 60.210, 0.0]);
    }

    #[test]
    fn arcs_ijk_and_r() {
        let t = p("G0 X10 Y0\nG3 X0 Y10 I-10 J0 F500\nG2 X10 Y0 R10\n").unwrap();
        assert!(t.len() > 20);
        for q in &t.points[2..] {
            // Both arcs lie on the radius-10 circle around the origin (the
            // second: R10, clockwise, the short way back).
            let r = q[0].hypot(q[1]);
            assert!((r - 10.0).abs() < 1e-9, "{q:?}");
        }
        assert_eq!(*t.lines.last().unwrap(), 3);
    }

    #[test]
    fn errors_name_the_line() {
        for (src, line) in [
            ("G1 X1 F100\nG41 X2\n", "line 2"),
            ("G0 X1\nG1 X2\n", "line 2"),
            ("G1 X1 F100\n\nX[1+2]\n", "line 3"),
            ("G1 X1 F100\nG3 X5 Y0 I1 J1\n", "line 2"),
            ("G1 F100 X1\nG5.2 X1 Y1 P1\nX2 Y2 P1\n", "line 2"),
            ("G1 X#1 F100\n", "line 1"),
            ("G1 X1 F100\nG28\n", "line 2"),
        ] {
            let e = format!("{:#}", p(src).unwrap_err());
            assert!(e.contains(line), "{src:?}: {e}");
        }
    }

    #[test]
    fn documented_skips_do_not_change_the_path() {
        let a = p("G1 X1 F100\nG1 X2\n").unwrap();
        let b =
            p("G54 G64 G94 G40 G49 G80\nM3 S1000 T1\nG1 X1 F100\nG4 P1\nM5\nG1 X2\nM2\n").unwrap();
        assert_eq!(a.points, b.points);
    }
}
