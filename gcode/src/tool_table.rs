//! LinuxCNC's tool table file (`tool.tbl`, `[EMCIO]TOOL_TABLE`): read and
//! written back.
//!
//! One tool a line, words separated by spaces or tabs, letters in either
//! case, a comment after `;` (LinuxCNC `src/emc/tooldata/tooldata_common.cc`,
//! `tooldata_read_entry`; the format in `docs/src/gcode/tool-compensation.adoc`):
//!
//! ```text
//! T1  P1  D6.35 Z+25.0 ;6.35 mm end mill
//! ```
//!
//! | word | meaning |
//! |---|---|
//! | T | tool number (whole, ≥ 0) |
//! | P | pocket (whole, ≥ 0) |
//! | X Y Z A B C U V W | tool offsets, machine units (Z: the length G43 applies) |
//! | D | diameter, machine units (cutter compensation uses half) |
//! | I J | front and back angle, degrees (lathe) |
//! | Q | orientation, 0-9 (lathe) |
//!
//! The machine unit is mm here (the controller's and host-sim's), as
//! LinuxCNC reads the file in `[TRAJ]LINEAR_UNITS`: a table from an inch
//! machine needs its values converted.
//!
//! Where we differ: LinuxCNC prints "Unrecognized line skipped" and goes on
//! (`tooldata_load`); we refuse the file naming the line, since a skipped
//! tool would then be measured as length 0. A line without T, a tool listed
//! twice, or a number that is not one is refused too (LinuxCNC's `sscanf`
//! reads `T1.5` as T1; we do not guess). LinuxCNC splits words on spaces
//! only, though its documentation allows tabs: we take both.
//! [`format`] writes lines as LinuxCNC's `tooldata_save` does
//! (`tooldata_format_toolline` with zero values left out), so a table we
//! read and write back reads the same in LinuxCNC.

use anyhow::{bail, Result};

/// One line of the table.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ToolRecord {
    /// T: tool number.
    pub number: u32,
    /// P: pocket.
    pub pocket: u32,
    /// X Y Z A B C U V W offsets, machine units (mm; degrees for A B C).
    pub offset: [f64; 9],
    /// D: diameter, mm.
    pub diameter: f64,
    /// I: front angle, degrees.
    pub front_angle: f64,
    /// J: back angle, degrees.
    pub back_angle: f64,
    /// Q: orientation.
    pub orientation: u32,
    /// The text after `;`, if any.
    pub comment: Option<String>,
}

const OFFSET_LETTERS: [char; 9] = ['X', 'Y', 'Z', 'A', 'B', 'C', 'U', 'V', 'W'];

/// Parse a tool table; errors name the line.
pub fn parse(text: &str) -> Result<Vec<ToolRecord>> {
    let mut out: Vec<ToolRecord> = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let n = i + 1;
        let (body, comment) = match raw.split_once(';') {
            Some((b, c)) => (b, Some(c.trim_end().to_string())),
            None => (raw, None),
        };
        if body.trim().is_empty() {
            continue; // blank, or a comment line
        }
        let mut r = ToolRecord {
            comment: comment.filter(|c| !c.is_empty()),
            ..ToolRecord::default()
        };
        let mut seen = Vec::new();
        for word in body.split_whitespace() {
            let mut chars = word.chars();
            let letter = chars.next().unwrap_or(' ').to_ascii_uppercase();
            let value = chars.as_str();
            if seen.contains(&letter) {
                bail!("tool table line {n}: word {letter} twice");
            }
            seen.push(letter);
            let real = || -> Result<f64> {
                match value.parse::<f64>() {
                    Ok(v) if v.is_finite() && v.abs() <= 1e6 => Ok(v),
                    _ => bail!(
                        "tool table line {n}: {word:?} is not {letter} and a number within ±1e6"
                    ),
                }
            };
            let whole = || -> Result<u32> {
                value
                    .strip_prefix('+')
                    .unwrap_or(value)
                    .parse::<u32>()
                    .map_err(|_| {
                        anyhow::anyhow!(
                            "tool table line {n}: {word:?} is not {letter} and a whole number ≥ 0"
                        )
                    })
            };
            match letter {
                'T' => r.number = whole()?,
                'P' => r.pocket = whole()?,
                'Q' => r.orientation = whole()?,
                'D' => r.diameter = real()?,
                'I' => r.front_angle = real()?,
                'J' => r.back_angle = real()?,
                c => match OFFSET_LETTERS.iter().position(|&a| a == c) {
                    Some(k) => r.offset[k] = real()?,
                    None => bail!(
                        "tool table line {n}: {word:?} is not a tool table word (T P X Y Z A B C U V W D I J Q, a comment after ';')"
                    ),
                },
            }
        }
        if !seen.contains(&'T') {
            bail!("tool table line {n}: no T word (the tool number)");
        }
        if out.iter().any(|t| t.number == r.number) {
            bail!("tool table line {n}: tool {} is listed twice", r.number);
        }
        out.push(r);
    }
    Ok(out)
}

/// The table as LinuxCNC writes it: `T P`, then the words that are not
/// zero (`D X Y Z A B C U V W I J` as `%+f`, `Q`), then `;comment`.
pub fn format(tools: &[ToolRecord]) -> String {
    let mut s = String::new();
    for t in tools {
        s.push_str(&format!("T{:<3} P{:<3}", t.number, t.pocket));
        let mut real = |letter: char, v: f64| {
            if v != 0.0 {
                s.push_str(&format!(" {letter}{v:+.6}"));
            }
        };
        real('D', t.diameter);
        for (k, &a) in OFFSET_LETTERS.iter().enumerate() {
            real(a, t.offset[k]);
        }
        real('I', t.front_angle);
        real('J', t.back_angle);
        if t.orientation != 0 {
            s.push_str(&format!(" Q{}", t.orientation));
        }
        if let Some(c) = &t.comment {
            s.push_str(&format!(" ;{c}"));
        }
        s.push('\n');
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_linuxcnc_s_sample_table() {
        // The lines of LinuxCNC's sim tables (configs/sim/axis/panelui-demo/
        // tool.tbl and others; those machines are in inches).
        let t = parse(
            "T1 P1 D0.125000 Z+0.511000 ;1/8 end mill\nT2 P2 D0.062500 Z+0.100000 ;1/16 end mill\n; a comment line\n\nt99999\tp99999 z+0.1 x-1.5 q3 i80 j-10\n",
        )
        .unwrap();
        assert_eq!(t.len(), 3);
        assert_eq!(t[0].number, 1);
        assert_eq!(t[0].diameter, 0.125);
        assert_eq!(t[0].offset[2], 0.511);
        assert_eq!(t[0].comment.as_deref(), Some("1/8 end mill"));
        assert_eq!(t[2].number, 99999);
        assert_eq!(t[2].pocket, 99999);
        assert_eq!(t[2].offset[0], -1.5);
        assert_eq!(
            (t[2].orientation, t[2].front_angle, t[2].back_angle),
            (3, 80.0, -10.0)
        );
        assert_eq!(t[2].comment, None);
    }

    #[test]
    fn written_back_as_linuxcnc_writes_it_and_read_the_same() {
        let t = parse("T1 P1 D6.35 Z+25.0 ;6.35 mm end mill\nT12 P3 X-0.5 Z0 Q2\n").unwrap();
        let s = format(&t);
        assert_eq!(
            s,
            "T1   P1   D+6.350000 Z+25.000000 ;6.35 mm end mill\nT12  P3   X-0.500000 Q2\n"
        );
        assert_eq!(parse(&s).unwrap(), t);
    }

    #[test]
    fn bad_lines_are_refused_by_line() {
        for (src, what) in [
            ("T1 P1\nT2 P2 E5\n", "line 2"),
            ("T1 P1\nP2 Z1\n", "line 2: no T"),
            ("T1 P1\nT1 P2\n", "listed twice"),
            ("T1.5 P1\n", "line 1"),
            ("T1 P1 Zabc\n", "line 1"),
            ("T1 P1 Z1 Z2\n", "twice"),
            ("T-1 P1\n", "line 1"),
            ("T1 P1 Dnan\n", "line 1"),
            ("T1 P1 Z1e9\n", "line 1"),
        ] {
            let e = parse(src).unwrap_err().to_string();
            assert!(e.contains(what), "{src:?}: {e}");
        }
        assert!(parse("").unwrap().is_empty());
    }

    fn run(src: &str, s: &crate::GcodeSettings) -> anyhow::Result<crate::Program> {
        crate::run(src, None, s)
    }

    #[test]
    fn g43_of_an_unknown_tool_is_length_0_with_a_warning_unless_strict() {
        let src = "G21 G90\nT1 M6\nG43 H1\nG0 X1 Z5\nG43\nG0 Z6\nM30\n";
        let p = run(src, &crate::GcodeSettings::default()).unwrap();
        assert_eq!(p.points.last().unwrap(), &[1.0, 0.0, 6.0]);
        assert_eq!(p.warnings.len(), 2);
        assert_eq!(p.warnings[0].0, 3);
        assert!(p.warnings[0].1.contains("tool 1 is not in the tool table"));
        assert_eq!(p.warnings[1].0, 5);
        let strict = crate::GcodeSettings {
            strict_tools: true,
            ..Default::default()
        };
        let e = format!("{:#}", run(src, &strict).unwrap_err());
        assert!(e.contains("line 3") && e.contains("tool 1"), "{e}");
        // T0 (no tool) is length 0 either way, without a word.
        assert!(run("T0 M6\nG43 H0\n", &strict).unwrap().warnings.is_empty());
    }

    #[test]
    fn a_tool_table_file_gives_g43_and_g41_their_tools_in_mm_and_inch_programs() {
        let dir = tempfile::tempdir().unwrap();
        let tbl = dir.path().join("tool.tbl");
        std::fs::write(&tbl, "T1 P1 D6.0 Z+25.0 ;end mill\nT2 P2 X-0.5 Z+10\n").unwrap();
        let s = crate::GcodeSettings {
            tool_table: Some(tbl.clone()),
            strict_tools: true,
            tools: vec![crate::ToolEntry {
                number: 3,
                diameter_mm: 2.0,
                length_mm: 7.0,
            }],
            ..Default::default()
        };
        // Machine Z = program Z + tool length (mm, whatever G20/G21).
        let p = run("G21\nT1 M6 G43 H1\nG0 X0 Y0 Z5\n", &s).unwrap();
        assert_eq!(p.points.last().unwrap(), &[0.0, 0.0, 30.0]);
        let p = run("G20\nT1 M6 G43 H1\nG0 X0 Y0 Z1\n", &s).unwrap();
        assert_eq!(p.points.last().unwrap(), &[0.0, 0.0, 50.4]);
        // Every offset of the tool applies (a lathe tool's X), and the
        // gcode.tools entries stay.
        let p = run("G21\nG43 H2\nG0 X1 Z0\nG43 H3\nG0 Z0\n", &s).unwrap();
        assert_eq!(p.points[1], [0.5, 0.0, 10.0]);
        // (X stays where it is: only Z is programmed.)
        assert_eq!(p.points[2], [0.5, 0.0, 7.0]);
        // D from the file: G41 offsets by half of it.
        let p = run(
            "G21 F100\nG0 X0 Y-10\nT1 M6\nG41 D1\nG1 X0 Y0\nX20\nG40\n",
            &s,
        )
        .unwrap();
        assert!(
            p.points.iter().any(|q| (q[0] + 3.0).abs() < 1e-9),
            "{:?}",
            p.points
        );
        // A tool in both places, a missing file, a bad line: refused.
        let both = crate::GcodeSettings {
            tools: vec![crate::ToolEntry {
                number: 1,
                diameter_mm: 0.0,
                length_mm: 0.0,
            }],
            ..s.clone()
        };
        assert!(format!("{:#}", run("G0 X1\n", &both).unwrap_err()).contains("both"));
        let missing = crate::GcodeSettings {
            tool_table: Some(dir.path().join("nope.tbl")),
            ..Default::default()
        };
        assert!(run("G0 X1\n", &missing).is_err());
        std::fs::write(&tbl, "T1 P1 Z1\nT2 P2 K3\n").unwrap();
        let e = format!("{:#}", run("G0 X1\n", &s).unwrap_err());
        assert!(e.contains("line 2") && e.contains("tool.tbl"), "{e}");
    }

    #[test]
    fn the_setting_is_relative_to_the_configuration_file() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("tool.tbl"), "T5 P1 Z+2\n").unwrap();
        let cfg = dir.path().join("machine.toml");
        std::fs::write(&cfg, "[gcode]\ntool_table = \"tool.tbl\"\n").unwrap();
        let s = crate::GcodeSettings::read_config_file(&cfg).unwrap();
        assert_eq!(s.tool_table, Some(dir.path().join("tool.tbl")));
        let p = run("G43 H5\nG0 Z0\n", &s).unwrap();
        assert_eq!(p.points.last().unwrap(), &[0.0, 0.0, 2.0]);
    }
}
