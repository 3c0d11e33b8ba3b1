//! G-code programs as CAM systems and LinuxCNC write them → moves, machine
//! events and [`toolpath::Toolpath`]s, on the host (the sender, host-sim,
//! a live front).
//!
//! The reader is an RS274/NGC interpreter in LinuxCNC's dialect: the syntax
//! ([`mod@parse`]), expressions ([`expr`]), numbered and named parameters and
//! O-word control flow ([`interp`], [`program`]), canned cycles
//! ([`cycles`]), cutter radius compensation ([`comp`]), arcs ([`arc`]) and
//! curve blocks ([`nurbs_block`]). All output is in mm, in machine
//! coordinates (program coordinates plus the work, G92 and tool offsets,
//! all zero unless configured).
//!
//! ## A whole file, or a line at a time
//!
//! [`interp::Interp`] runs against a [`machine::Machine`], which receives
//! every point and machine event ([`sink::Item`]) in program order as each
//! line completes, and answers what only a machine knows: where the tool
//! is after a move the program did not command (a jog, homing), and where
//! a probe tripped (G38.2-.5, then #5061-#5070). A whole file
//! ([`read()`], [`parse()`], [`run()`]) is the same loop over its lines against
//! [`machine::Collect`], which keeps the output and refuses probing. A live
//! front calls [`interp::Interp::start_live`], then
//! [`interp::Interp::push_line`] and [`interp::Interp::run_with`] for each
//! line it receives; an O-word structure runs once it is closed; a program
//! end resets the modes and the next line starts the next program.
//!
//! Persistent state (work offsets G54-G59.3, G28/G30 positions, G92) loads
//! from LinuxCNC's parameter file (`gcode.var_file`, [`state`]) and, for a
//! live program, is written back when it changes.
//!
//! | words | handling |
//! |---|---|
//! | G0 G1, G53 | straight moves; G0 at the configured rapid feed |
//! | G2 G3 (I J K or R, P turns) | arcs and helices within the chord tolerance; an end off the start's circle within LinuxCNC's tolerance is a spiral to it ([`arc::RadiusTolerance`]) |
//! | G5 G5.1, G5.2 … G5.3, G6.2 | cubic and quadratic splines, NURBS blocks (any plane for G5.2, G6.2) |
//! | axis words before any G0-G3 | read as G0 with a warning (`gcode.initial_motion`: `"g0"`, the default, as Grbl; `"g1"`; `"none"` refuses them, as LinuxCNC) |
//! | G17 G18 G19, G20 G21, G90 G91, G90.1 G91.1, G7 G8 | plane, units, distance modes, lathe diameter mode |
//! | F with G93 G94 G95, S | feed caps: per minute, inverse time (F × move length), per revolution (F × S) |
//! | G28 G30 (with axis words: via that point), G28.1 G30.1 | to the reference positions (`[gcode.reference_positions]`, #5161-5169, #5181-5189) |
//! | G92 G92.1 G92.2 G92.3, G52 | axis offsets (#5210-5219) |
//! | G54-G59.3, G10 L2 / L20 | work offsets (`[gcode.work_offsets]`, #5221-5390) |
//! | T, M6, M61, G43 H, G43.1, G43.2, G49, G10 L1/L10/L11 | tools (`[[gcode.tools]]`, or a LinuxCNC `tool.tbl` in `gcode.tool_table`: [`tool_table`]): offsets (length along Z), radius for compensation; G43 of a tool not in the table: length 0 and a warning (`gcode.strict_tools = true`: refused) |
//! | G40 G41 G42 G41.1 G42.1 (D) | cutter radius compensation, XY plane |
//! | G73 G74 G81-G89, G80, G98 G99, L repeats | canned cycles expanded into moves (G88 refused) |
//! | G33 | a straight move at K × S |
//! | `#n`, `#<name>`, `#<_global>`, `[expressions]`, functions, O-words | evaluated as rs274ngc defines them; `o<name> call` also finds `name.ngc` beside the program or in `gcode.subroutine_dirs` |
//! | A B C U V W | carried (offsets, references, parameters); a move that drives one is refused by name unless `gcode.extra_axes = "ignore"` |
//! | M3-M5 (with S), M7-M9, S while the spindle runs | no effect on the path; machine events in order with it (`Toolpath::events`: after which point) |
//! | G61 G61.1 G64 (P) | path control: machine events where the mode changes, before the block's motion (`MachineEvent::PathControl`): G64 P the tolerance in program units, P0 as G64 alone, Q (LinuxCNC's naive CAM tolerance, which merges nearly collinear short moves) read and ignored, since the planner takes dense short moves as they are; a live program's M2/M30 restores G64 (the sender restores it after a whole program) |
//! | M0 M1 M19 M48-M53 M62-M65 M67 M68, G4, G96 G97, comments, N, `/` lines (block delete on) | no effect on the path |
//! | `O1000` program numbers, `M98 P<n> L<passes>`, `M99` | Fanuc/Mach3 subprograms (`O<n>` … `M99`, usually after M30) on the O-word machinery; `M99` in the main program ends it (LinuxCNC's preview and grblHAL; Fanuc and Mach3 would loop) |
//! | M2 M30, a second `%` | end of program |
//! | M70-M73 | modal state saved and restored |
//! | G38.2 G38.3 G38.4 G38.5 | a probing move run by the [`machine::Machine`]: #5061-#5069 the trip position (program coordinates), #5070 whether it tripped; G38.2/.4 that do not trip are errors. Reading a file ahead of time: refused, "needs live machine state" |
//! | M66 inputs, M100-M199, `#<_hal[…]>`, `#<_ini[…]>`, G88 | refused: "needs live machine state" |
//! | `$H`, `$X`, `$32=1`, `$J=…` and other Grbl system commands | refused by name: "send it from the sender or its console"; the queries `$` `$$` `$#` `$G` `$I` `$N` are skipped with a warning ([`grbl_system`]) |
//! | anything else (G76, G70-G72, G33.1, rotation in G10, …) | **error naming the file, line and feature** |
//!
//! Every point keeps its source line, and the feed of its block (or the
//! rapid feed) as a cap. Resources are bounded ([`Limits`]): point counts
//! are checked before arcs and curves are expanded, executed lines and call
//! depth are counted, so no input aborts, panics or runs without end.

pub mod arc;
pub mod comp;
pub mod cycles;
pub mod expr;
pub mod grbl_system;
pub mod inputs;
pub mod interp;
pub mod machine;
pub mod nurbs;
pub mod nurbs_block;
pub mod parse;
pub mod path_csv;
pub mod program;
pub mod shapes;
pub mod sink;
pub mod state;
pub mod text;
pub mod tool_table;
pub mod toolpath;

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};

use crate::toolpath::Toolpath;

/// How G-code is turned into a toolpath.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GcodeSettings {
    /// Largest distance between an arc (or NURBS) and its chords, mm.
    pub chord_tolerance_mm: f64,
    /// Feed of G0 moves, mm/min (the paper's machine: 48 m/min, Table 1).
    pub rapid_feed_mm_per_min: f64,
    /// Where the tool is when the program starts, machine coordinates, mm.
    pub start_mm: [f64; 3],
    /// Skip lines starting with `/` (LinuxCNC's block delete switch).
    pub block_delete: bool,
    /// What to do with a move that drives A B C U V W (or an E word).
    pub extra_axes: ExtraAxes,
    /// Retract between pecks of G73/G83 without a D word, mm.
    pub peck_clearance_mm: f64,
    /// The motion mode when the program starts: what axis words before the
    /// first G0/G1/G2/G3 do ([`InitialMotion`]).
    pub initial_motion: InitialMotion,
    /// Tool loaded when the program starts (0: none).
    pub initial_tool: u32,
    /// Where `o<name> call` looks for `name.ngc` after the program's own
    /// directory.
    pub subroutine_dirs: Vec<PathBuf>,
    /// G28 and G30 positions.
    pub reference_positions: ReferencePositions,
    /// G54-G59.3 offsets.
    pub work_offsets: WorkOffsets,
    /// The tool table.
    pub tools: Vec<ToolEntry>,
    /// LinuxCNC's parameter file (`.var`): work offsets, G28/G30 and G92
    /// read from it at the start (over `work_offsets` and
    /// `reference_positions`) and, for a live program, written back when
    /// they change.
    pub var_file: Option<PathBuf>,
    /// A tool table file in LinuxCNC's format ([`tool_table`], values in
    /// mm), read when a program starts; its tools are added to `tools` (a
    /// tool in both is an error). Relative to the configuration file's
    /// folder when read from one.
    pub tool_table: Option<PathBuf>,
    /// Refuse `G43 H<n>` (or `G43` after `T<n> M6`) for a tool that is
    /// not in the table, as LinuxCNC does ("Requested tool %d not found in
    /// the tool table": `interp_find.cc`, `Interp::find_tool_index`). Off
    /// (the default): its offsets are taken as 0 with a warning, as a
    /// controller with a fixed-size table reads a slot nobody set (grblHAL
    /// `gcode.c`, `gc_execute_line`, G43: every entry below `n_tools`
    /// exists and is zero until set). CAM posts (Fusion 360, Mach3,
    /// LinuxCNC) emit `T1 M6` `G43 H1` whatever the machine's table holds,
    /// and a toolpath with the tool's length unknown is still the path
    /// programmed, shifted along Z by that length. G41/G42 of an unknown
    /// tool stay refused: a radius of 0 would change the path's shape.
    pub strict_tools: bool,
    /// Resource bounds.
    pub limits: Limits,
}

impl Default for GcodeSettings {
    fn default() -> Self {
        GcodeSettings {
            chord_tolerance_mm: 0.001,
            rapid_feed_mm_per_min: 48_000.0,
            start_mm: [0.0; 3],
            block_delete: true,
            extra_axes: ExtraAxes::Refuse,
            peck_clearance_mm: 1.0,
            initial_motion: InitialMotion::G0,
            initial_tool: 0,
            subroutine_dirs: Vec::new(),
            reference_positions: ReferencePositions::default(),
            work_offsets: WorkOffsets::default(),
            tools: Vec::new(),
            var_file: None,
            tool_table: None,
            strict_tools: false,
            limits: Limits::default(),
        }
    }
}

impl GcodeSettings {
    /// The `[gcode]` table of a TOML configuration file (host-sim's
    /// configuration has one; the file's other tables are not read here),
    /// checked; the defaults where the file has no such table.
    pub fn read_config_file(path: &Path) -> Result<Self> {
        let text =
            std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
        let mut s =
            Self::from_config_text(&text).with_context(|| format!("in {}", path.display()))?;
        if let (Some(t), Some(dir)) = (&s.tool_table, path.parent()) {
            if t.is_relative() {
                s.tool_table = Some(dir.join(t));
            }
        }
        Ok(s)
    }

    /// [`GcodeSettings::read_config_file`] of TOML text.
    pub fn from_config_text(text: &str) -> Result<Self> {
        #[derive(Deserialize)]
        struct File {
            #[serde(default)]
            gcode: GcodeSettings,
        }
        let f: File = toml::from_str(text)?;
        f.gcode.validate()?;
        Ok(f.gcode)
    }

    /// Check every value.
    pub fn validate(&self) -> Result<()> {
        anyhow::ensure!(
            self.chord_tolerance_mm.is_finite() && self.chord_tolerance_mm >= 1e-9,
            "gcode.chord_tolerance_mm must be ≥ 1e-9"
        );
        anyhow::ensure!(
            self.rapid_feed_mm_per_min.is_finite()
                && self.rapid_feed_mm_per_min > 0.0
                && self.rapid_feed_mm_per_min <= 1e6,
            "gcode.rapid_feed_mm_per_min must be in (0, 1e6]"
        );
        anyhow::ensure!(
            self.peck_clearance_mm.is_finite() && self.peck_clearance_mm >= 0.0,
            "gcode.peck_clearance_mm must be ≥ 0"
        );
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite() && x.abs() <= 1e6);
        anyhow::ensure!(
            finite(&self.start_mm),
            "gcode.start_mm must be finite, within ±1e6 mm"
        );
        anyhow::ensure!(
            finite(&self.reference_positions.g28) && finite(&self.reference_positions.g30),
            "gcode.reference_positions must be finite, within ±1e6 mm"
        );
        for (k, o) in self.work_offsets.all().iter().enumerate() {
            anyhow::ensure!(
                finite(o),
                "gcode.work_offsets.{} must be finite, within ±1e6 mm",
                WorkOffsets::NAMES[k]
            );
        }
        for t in &self.tools {
            anyhow::ensure!(
                t.diameter_mm.is_finite() && t.diameter_mm >= 0.0 && t.diameter_mm <= 1e4,
                "gcode.tools: tool {} diameter_mm must be in [0, 1e4]",
                t.number
            );
            anyhow::ensure!(
                t.length_mm.is_finite() && t.length_mm.abs() <= 1e4,
                "gcode.tools: tool {} length_mm must be within ±1e4",
                t.number
            );
        }
        anyhow::ensure!(
            (2..=1_000_000_000).contains(&self.limits.max_points),
            "gcode.limits.max_points must be in [2, 1e9]"
        );
        anyhow::ensure!(
            self.limits.max_call_depth >= 1 && self.limits.max_call_depth <= 1000,
            "gcode.limits.max_call_depth must be in [1, 1000]"
        );
        Ok(())
    }
}

/// Moves of axes beyond X Y Z.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ExtraAxes {
    /// Refuse the move, naming the axis.
    Refuse,
    /// Keep X Y Z, drop the others.
    Ignore,
}

/// The motion mode a program starts in (`gcode.initial_motion`).
///
/// Axis words before any motion code (`T1 M6` then `Z10`): rs274ngc
/// refuses them (LinuxCNC starts in G80, no motion mode:
/// `rs274ngc_pre.cc`, `Interp::init`; `interp_internal.cc`,
/// `Interp::enhance_block`: "Cannot use axis values without a g code that
/// uses them"); Grbl starts in G0 (`grbl/gcode.c`, `gc_init` clears the
/// state and `MOTION_MODE_SEEK` is 0, "Default: Must be zero"), and so does
/// grblHAL (`gcode.c`, `gc_init`; `gcode.h`, `MotionMode_Seek = 0`). The default is G0: this controller's
/// programs come through a sender from Grbl users and Grbl posts, and a
/// file Grbl runs should run here with the same moves; the first such line
/// is reported as a warning, so the choice is visible. `none` reads as
/// LinuxCNC. Only the start is affected: after G80 axis words are refused
/// again, as in both peers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InitialMotion {
    /// No motion mode: axis words before a motion code are refused.
    None,
    /// G0.
    G0,
    /// G1.
    G1,
}

/// G28 and G30 positions, machine coordinates, mm (X Y Z).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ReferencePositions {
    /// G28 (#5161-5163).
    pub g28: [f64; 3],
    /// G30 (#5181-5183).
    pub g30: [f64; 3],
}

/// Work offsets, mm (X Y Z): machine = program + offset.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
#[allow(missing_docs)]
pub struct WorkOffsets {
    pub g54: [f64; 3],
    pub g55: [f64; 3],
    pub g56: [f64; 3],
    pub g57: [f64; 3],
    pub g58: [f64; 3],
    pub g59: [f64; 3],
    pub g59_1: [f64; 3],
    pub g59_2: [f64; 3],
    pub g59_3: [f64; 3],
}

impl WorkOffsets {
    /// Keys in order.
    pub const NAMES: [&'static str; 9] = [
        "g54", "g55", "g56", "g57", "g58", "g59", "g59_1", "g59_2", "g59_3",
    ];

    /// All nine, G54 first.
    pub fn all(&self) -> [[f64; 3]; 9] {
        [
            self.g54, self.g55, self.g56, self.g57, self.g58, self.g59, self.g59_1, self.g59_2,
            self.g59_3,
        ]
    }
}

/// One tool of the table.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToolEntry {
    /// T number.
    pub number: u32,
    /// Diameter, mm (cutter compensation uses half).
    #[serde(default)]
    pub diameter_mm: f64,
    /// Length offset along Z for G43, mm.
    #[serde(default)]
    pub length_mm: f64,
}

/// Most memory a toolpath point takes while a program is read, bytes: the
/// interpreter's point, feed cap and source line (44 bytes) with the
/// reserve of their growing vectors (up to as much again), merged into the
/// toolpath in place ([`Toolpath::with_events`]). `host-sim/README.md`
/// shows the peak resident size of `host-sim toolpath` per point.
pub const BYTES_PER_POINT: usize = 96;

/// Memory the default [`Limits::max_points`] allows the points of a
/// program, bytes.
pub const DEFAULT_POINTS_MEMORY: usize = 1 << 30;

/// Resource bounds of the reader.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Limits {
    /// Most points in the toolpath (arcs and curves are checked before
    /// they are expanded); the default is [`DEFAULT_POINTS_MEMORY`] /
    /// [`BYTES_PER_POINT`]: each point costs the reader at most
    /// `BYTES_PER_POINT`.
    pub max_points: usize,
    /// Most lines executed beyond the program's own line count (loops and
    /// calls repeat lines).
    pub max_executed_lines: u64,
    /// Deepest nesting of O-word calls (LinuxCNC: 10).
    pub max_call_depth: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_points: DEFAULT_POINTS_MEMORY / BYTES_PER_POINT,
            max_executed_lines: 20_000_000,
            max_call_depth: 10,
        }
    }
}

/// Euclidean distance of the X Y Z parts, mm.
fn dist3(a: &[f64; 9], b: &[f64; 9]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// The points of a program before they become a [`Toolpath`] (a program
/// may have no motion at all).
#[derive(Debug)]
pub struct Program {
    /// Points, mm, the start first.
    pub points: Vec<[f64; 3]>,
    /// Feed caps, mm/min.
    pub caps: Vec<Option<f64>>,
    /// Source lines.
    pub lines: Vec<u32>,
    /// Spindle and coolant commands: after which point, source line, what.
    pub events: Vec<(usize, u32, crate::toolpath::MachineEvent)>,
    /// What was read other than as written: source line, text (in program
    /// order; one per occurrence).
    pub warnings: Vec<(u32, String)>,
}

/// Run G-code text; `dir` is where its subroutine files are.
pub fn run(src: &str, dir: Option<&Path>, settings: &GcodeSettings) -> Result<Program> {
    settings.validate()?;
    let mut it = interp::Interp::new(
        std::sync::Arc::new(settings.clone()),
        dir.map(Path::to_path_buf),
    )?;
    it.load_main(src, None)?;
    let mut out = machine::Collect::default();
    it.run_with(&mut out)?;
    Ok(Program {
        points: out.points,
        caps: out.caps,
        lines: out.lines,
        events: out.events,
        warnings: out.warnings,
    })
}

/// Parse G-code text; `name` labels the toolpath.
pub fn parse(name: &str, src: &str, settings: &GcodeSettings) -> Result<Toolpath> {
    let p = run(src, None, settings)?;
    Toolpath::with_events(name, p.points, p.caps, p.lines, p.events)
}

/// Read a G-code file; errors name the file and the line.
pub fn read(path: &Path, settings: &GcodeSettings) -> Result<Toolpath> {
    read_with_warnings(path, settings).map(|(t, _)| t)
}

/// [`read`], with the program's warnings ([`Program::warnings`]).
pub fn read_with_warnings(
    path: &Path,
    settings: &GcodeSettings,
) -> Result<(Toolpath, Vec<(u32, String)>)> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    let text = String::from_utf8_lossy(&bytes);
    let name = path
        .file_stem()
        .map_or("gcode".into(), |s| s.to_string_lossy().into_owned());
    let p = run(&text, interp::program_dir(path).as_deref(), settings)
        .with_context(|| format!("in {}", path.display()))?;
    let t = Toolpath::with_events(name, p.points, p.caps, p.lines, p.events)
        .with_context(|| format!("in {}", path.display()))?;
    Ok((t, p.warnings))
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
            ("G1 X1 F100\nG76 X2\n", "line 2"),
            ("G0 X1\nG1 X2\n", "line 2"),
            ("G1 X1 F100\n\nX[1+]\n", "line 3"),
            ("G1 X1 F100\nG3 X5 Y0 I1 J1\n", "line 2"),
            ("G1 F100 X1\nG5.2 X1 Y1 P1\nX2 Y2 P1\n", "line 2"),
            ("G1 X#<nope> F100\n", "line 1"),
            ("G1 X1 F100\nG38.2 Z-5\n", "line 2"),
            ("G1 X1 F100\nX[1/0]\n", "line 2"),
            ("G1 X1 F100\nG1 B3\n", "line 2"),
            ("G1 X1 F100\nG1 X2 E3\n", "line 2"),
        ] {
            let e = format!("{:#}", p(src).unwrap_err());
            assert!(e.contains(line), "{src:?}: {e}");
        }
    }

    #[test]
    fn spindle_and_coolant_words_are_events_at_their_point() {
        use crate::toolpath::{MachineEvent, SpindleDir};
        let t =
            p("G1 X1 F100\nM3 S1000\nG1 X2\nG1 X2\nS2000\nM8\nG1 X3\nM7\nM9 M5\nG1 X4\n").unwrap();
        let sp = |dir, rpm| MachineEvent::Spindle { dir, rpm };
        let co = |flood, mist| MachineEvent::Coolant { flood, mist };
        assert_eq!(
            t.events,
            vec![
                (1, 2, sp(SpindleDir::Cw, 1000.0)),
                // After X2 (the repeated X2 merged into it).
                (2, 5, sp(SpindleDir::Cw, 2000.0)),
                (2, 6, co(true, false)),
                (3, 8, co(true, true)),
                // RS274/NGC: the spindle before the coolant in a block.
                (3, 9, sp(SpindleDir::Off, 2000.0)),
                (3, 9, co(false, false)),
            ]
        );
        assert_eq!(t.points.len(), 5);
    }

    #[test]
    fn dwells_are_events_at_their_point() {
        use crate::toolpath::MachineEvent;
        let t = p("G1 X1 F100\nG4 P0.5\nG1 X2\nG4 P0\nG1 X3\n").unwrap();
        assert_eq!(t.events, vec![(1, 2, MachineEvent::Dwell { s: 0.5 })]);
        assert!(p("G1 X1 F100\nG4 P-1\n").is_err());
        // A drilling cycle's P: a dwell at the bottom of every hole; G81's
        // holes have none (even with a P still in force).
        let t = p("G1 Z5 F100\nG82 X1 Y1 Z-2 R1 P0.25\nX2\nG80\nG81 X3 Y3 Z-2 R1\nG80\n").unwrap();
        let dwells: Vec<_> = t
            .events
            .iter()
            .filter(|e| matches!(e.2, MachineEvent::Dwell { .. }))
            .collect();
        assert_eq!(dwells.len(), 2, "{:?}", t.events);
        for d in &dwells {
            assert_eq!(d.2, MachineEvent::Dwell { s: 0.25 });
            assert_eq!(t.points[d.0][2], -2.0, "at the bottom");
        }
        assert_eq!(
            [t.points[dwells[0].0][0], t.points[dwells[1].0][0]],
            [1.0, 2.0]
        );
    }

    #[test]
    fn axis_words_before_any_motion_code_follow_gcode_initial_motion() {
        let src = "G21 G90\nT1 M6\nZ10\nX5\nG1 X6 F100\n";
        let run_with = |m| {
            let s = GcodeSettings {
                initial_motion: m,
                ..Default::default()
            };
            run(src, None, &s)
        };
        // Default: G0 (Grbl), with one warning at the first such line.
        let p = run_with(InitialMotion::G0).unwrap();
        assert_eq!(p.points[1..3], [[0.0, 0.0, 10.0], [5.0, 0.0, 10.0]]);
        assert_eq!(p.caps[1], Some(48_000.0));
        assert_eq!(p.warnings.len(), 1);
        assert_eq!(p.warnings[0].0, 3);
        assert!(p.warnings[0].1.contains("read as G0"));
        // In inch as in mm.
        let t = parse("i", "G20\nZ1\n", &GcodeSettings::default()).unwrap();
        assert_eq!(t.points[1], [0.0, 0.0, 25.4]);
        // G1: a feed move, which needs a feed.
        let e = format!("{:#}", run_with(InitialMotion::G1).unwrap_err());
        assert!(e.contains("line 3") && e.contains("feed"), "{e}");
        // None: LinuxCNC's refusal.
        let e = format!("{:#}", run_with(InitialMotion::None).unwrap_err());
        assert!(
            e.contains("line 3: axis words without a motion mode"),
            "{e}"
        );
        // After G80 axis words are refused whatever the setting.
        assert!(p_err_line("G80\nX1\n", "line 2"));
        // The TOML names.
        let s = GcodeSettings::from_config_text("[gcode]\ninitial_motion = \"none\"\n").unwrap();
        assert_eq!(s.initial_motion, InitialMotion::None);
    }

    fn p_err_line(src: &str, line: &str) -> bool {
        p(src).is_err_and(|e| format!("{e:#}").contains(line))
    }

    #[test]
    fn path_control_words_are_events_where_they_change() {
        use crate::toolpath::{MachineEvent, PathMode};
        let pc = MachineEvent::PathControl;
        // P in program units (G20: 0.001 in = 0.0254 mm); a repeated mode
        // is no event; Q is ignored.
        let t = p("G1 X1 F100\nG64 P0.01 Q0.02\nG1 X2\nG64 P0.01\nG61\nG1 X3\nG61.1\nG64\nG20 G64 P0.001\nG1 X4\nM2\n")
            .unwrap();
        assert_eq!(
            t.events,
            vec![
                (1, 2, pc(PathMode::Blend(Some(0.01)))),
                (2, 5, pc(PathMode::Exact)),
                (3, 8, pc(PathMode::Blend(None))),
                (3, 9, pc(PathMode::Blend(Some(0.0254)))),
            ]
        );
        assert!(p("G64 P-1\n").is_err());
    }

    #[test]
    fn documented_skips_do_not_change_the_path() {
        let a = p("G1 X1 F100\nG1 X2\n").unwrap();
        let b =
            p("G54 G64 G94 G40 G49 G80\nM3 S1000 T1\nG1 X1 F100\nG4 P1\nM5\nG1 X2\nM2\n").unwrap();
        assert_eq!(a.points, b.points);
    }
}
