//! The interpreter: runs a program's lines (O-word control flow, parameters)
//! and turns each block into moves, in the order of execution of the
//! RS274/NGC report (Kramer et al. 2000, §3.8, table 8) as LinuxCNC keeps it
//! (`interp_execute.cc`, `execute_block`).
//!
//! Positions are kept in machine coordinates, mm, for nine axes
//! (X Y Z A B C U V W). A program coordinate is the machine coordinate less
//! the active work offset (G54-G59.3), the G92/G52 offset and the tool
//! length offset (G43). Persistent data lives in the numbered parameters as
//! in LinuxCNC (in mm, host-sim's machine unit): #5161-5169 the G28 position,
//! #5181-5189 G30, #5210 and #5211-5219 the G92 offset, #5220 the active
//! coordinate system, #5221+20·(n−1) … the offsets of system n; selecting a
//! system reads its offsets from the parameters, as LinuxCNC does.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::{anyhow, bail, Context, Result};

use super::arc::{Centre, Plane, RadiusTolerance};
use super::comp::{Comp, Side};
use super::cycles;
use super::expr::{parameter_number, Params, MAX_PARAMETER};
use super::machine::{Machine, ProbeKind, ProbeMove};
use super::nurbs_block::{self, Collector, Collector6};
use super::parse::{Keyword, Label, Stmt};
use super::program::{File, Jump, Opened};
use super::sink::Sink;
use super::text::short;
use super::{ExtraAxes, GcodeSettings, InitialMotion};
use crate::toolpath::PathMode;

/// Axis letters in parameter order.
pub const AXES: [char; 9] = ['X', 'Y', 'Z', 'A', 'B', 'C', 'U', 'V', 'W'];
/// The phrase that marks a refusal no reader without a machine can avoid.
pub const NEEDS_MACHINE: &str = "needs live machine state";

const P_G28: usize = 5161;
const P_G30: usize = 5181;
const P_G92_ON: usize = 5210;
const P_G92: usize = 5211;
const P_COORD: usize = 5220;
const P_G54: usize = 5221;

/// Modal motion (group 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Motion {
    /// G0.
    Rapid,
    /// G1.
    Linear,
    /// G2 (`true`) or G3.
    Arc(bool),
    /// G5 cubic spline.
    Cubic,
    /// G5.1 quadratic spline.
    Quadratic,
    /// G33 spindle-synchronised motion.
    Thread,
    /// A canned cycle: G73, G74, G81-G89 (code × 10).
    Cycle(u32),
}

impl Motion {
    fn code(self) -> f64 {
        match self {
            Motion::Rapid => 0.0,
            Motion::Linear => 10.0,
            Motion::Arc(true) => 20.0,
            Motion::Arc(false) => 30.0,
            Motion::Cubic => 50.0,
            Motion::Quadratic => 51.0,
            Motion::Thread => 330.0,
            Motion::Cycle(c) => c as f64,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum FeedMode {
    PerMinute,
    InverseTime,
    PerRev,
}

/// The evaluated words of a block.
pub struct Blk {
    /// Source line.
    pub line: u32,
    /// G codes as (major, tenths).
    pub g: Vec<(u32, u32)>,
    /// M codes.
    pub m: Vec<u32>,
    /// Other words by letter (`A` = 0).
    pub w: [Option<f64>; 26],
    /// Polar radius `@` and angle `^` (degrees).
    pub polar: [Option<f64>; 2],
}

impl Blk {
    /// The value of word `c`.
    pub fn get(&self, c: char) -> Option<f64> {
        let i = (c as u8).wrapping_sub(b'A') as usize;
        self.w.get(i).copied().flatten()
    }

    fn has_g(&self, major: u32, minor: u32) -> bool {
        self.g.contains(&(major, minor))
    }

    fn has_axis(&self) -> bool {
        AXES.iter().any(|&a| self.get(a).is_some()) || self.polar.iter().any(Option::is_some)
    }
}

/// Canned-cycle state kept between blocks of one cycle mode.
#[derive(Clone, Copy, Debug, Default)]
pub struct CycleState {
    /// Normal-axis position when the cycle mode began (G98's level), mm.
    pub initial_level: Option<f64>,
    /// Sticky R, Z (normal axis), P, Q, I, J, K values (program units).
    pub r: Option<f64>,
    /// Sticky depth.
    pub z: Option<f64>,
    /// Sticky dwell.
    pub p: Option<f64>,
    /// Sticky peck.
    pub q: Option<f64>,
    /// Sticky G87 offsets.
    pub ijk: [Option<f64>; 3],
}

struct Frame {
    file: usize,
    pc: usize,
    call: Option<CallInfo>,
    locals: HashMap<String, f64>,
    repeats: HashMap<usize, i64>,
}

struct CallInfo {
    label: Label,
    saved: [f64; 30],
    modal: Option<Modal>,
    /// An `M98` call: the `O` line it started at and the passes left after
    /// this one.
    m98: Option<(usize, u64)>,
}

/// Modal state saved by M70/M73 (LinuxCNC `save_settings`).
#[derive(Clone)]
struct Modal {
    units: f64,
    absolute: bool,
    arc_absolute: bool,
    plane: Plane,
    feed: Option<f64>,
    feed_mode: FeedMode,
    coord: usize,
    retract_r: bool,
    diameter_mode: bool,
}

/// A tool of the table.
#[derive(Clone, Copy, Debug, Default)]
pub struct ToolData {
    /// Radius, mm.
    pub radius_mm: f64,
    /// Offsets X Y Z A B C U V W (Z: the length), mm (degrees for A B C).
    pub offset_mm: [f64; 9],
}

/// The modes in force ([`Interp::modes`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Modes {
    /// The motion mode as its G number (1, 2, 3, 81 …; 38.2 …), `None`
    /// after G80 or before any.
    pub motion: Option<f64>,
    /// 17, 18 or 19.
    pub plane: u32,
    /// G20.
    pub inches: bool,
    /// G90.
    pub absolute: bool,
    /// G93.
    pub inverse_time: bool,
    /// The coordinate system, 0 for G54 … 8 for G59.3.
    pub coord: usize,
    /// The tool in the spindle.
    pub tool: u32,
    /// F, program units per minute.
    pub feed: f64,
    /// S, rpm.
    pub rpm: f64,
    /// M3, M4 or M5.
    pub spindle: crate::toolpath::SpindleDir,
    /// M8.
    pub flood: bool,
    /// M7.
    pub mist: bool,
    /// The tool length offset along Z, mm.
    pub tool_length_mm: f64,
}

/// Where [`Interp::run_with`] stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stop {
    /// Every line given so far has run; more may follow
    /// ([`Interp::push_line`]).
    NeedInput,
    /// The program ended (M2, M30, a closing `%`, or the end of a whole
    /// program's text).
    Ended,
}

/// The interpreter's state.
pub struct Interp {
    pub(super) s: Arc<GcodeSettings>,
    /// Machine position, mm (rotary axes in degrees).
    pub pos: [f64; 9],
    /// mm per program unit (1 or 25.4).
    pub units: f64,
    pub(super) absolute: bool,
    arc_absolute: bool,
    /// Selected plane.
    pub plane: Plane,
    pub(super) motion: Option<Motion>,
    /// `motion` is still `gcode.initial_motion`, unused.
    motion_initial: bool,
    feed: Option<f64>,
    feed_mode: FeedMode,
    rpm: f64,
    css: bool,
    coord: usize,
    work: [f64; 9],
    g92: [f64; 9],
    tlo: [f64; 9],
    tools: HashMap<u32, ToolData>,
    current_tool: u32,
    selected_tool: u32,
    diameter_mode: bool,
    /// G99 (retract to R) instead of G98.
    pub retract_r: bool,
    /// Canned-cycle state.
    pub cycle: CycleState,
    comp: Comp,
    spline_prev: Option<[f64; 2]>,
    nurbs: Option<Collector>,
    nurbs6: Option<Collector6>,
    params: Vec<f64>,
    globals: HashMap<String, f64>,
    frames: Vec<Frame>,
    files: Vec<File>,
    subs: HashMap<Label, (usize, usize)>,
    /// Fanuc program numbers (`O1000` lines) of each file, found when an
    /// `M98` first needs them: number → line indices.
    programs: HashMap<usize, HashMap<u32, Vec<usize>>>,
    dir: Option<PathBuf>,
    saved_modal: Option<Modal>,
    value: f64,
    value_returned: bool,
    line: u32,
    executed: u64,
    /// Executed lines allowed (`max_executed_lines` beyond the source's).
    bound: u64,
    percent_seen: bool,
    any_content: bool,
    /// Lines pushed one at a time: the main program grows, a program end
    /// resets the modes instead of stopping.
    live: bool,
    /// Live lines of a control structure not yet closed.
    pending: Vec<super::parse::Line>,
    opened: Opened,
    /// A probing move the block asked for, run by the [`Machine`].
    probe: Option<ProbeMove>,
    /// The persistent parameters as last read or written.
    saved_state: String,
    /// The path so far.
    pub out: Sink,
}

impl Params for Interp {
    fn number(&self, n: u32) -> Result<f64> {
        Ok(self.params.get(n as usize).copied().unwrap_or(0.0))
    }

    fn named(&self, name: &str) -> Result<f64> {
        if let Some(v) = self.predefined(name)? {
            return Ok(v);
        }
        let found = if name.starts_with('_') {
            self.globals.get(name)
        } else {
            self.frames.last().and_then(|f| f.locals.get(name))
        };
        found
            .copied()
            .ok_or_else(|| anyhow!("parameter #<{name}> is read before it is set"))
    }

    fn exists(&self, name: &str) -> bool {
        matches!(self.predefined(name), Ok(Some(_)))
            || if name.starts_with('_') {
                self.globals.contains_key(name)
            } else {
                self.frames
                    .last()
                    .is_some_and(|f| f.locals.contains_key(name))
            }
    }
}

fn truth(b: bool) -> f64 {
    if b {
        1.0
    } else {
        0.0
    }
}

impl Interp {
    /// A fresh machine for `settings`; `dir` is where `o<name> call` looks
    /// for `name.ngc` first.
    pub fn new(s: Arc<GcodeSettings>, dir: Option<PathBuf>) -> Result<Self> {
        let mut params = vec![0.0; MAX_PARAMETER as usize + 1];
        for (k, off) in s.work_offsets.all().iter().enumerate() {
            for (i, v) in off.iter().enumerate() {
                params[P_G54 + 20 * k + i] = *v;
            }
        }
        for (i, v) in s.reference_positions.g28.iter().enumerate() {
            params[P_G28 + i] = *v;
        }
        for (i, v) in s.reference_positions.g30.iter().enumerate() {
            params[P_G30 + i] = *v;
        }
        params[P_COORD] = 1.0;
        let mut tools = HashMap::new();
        for t in &s.tools {
            let mut offset_mm = [0.0; 9];
            offset_mm[2] = t.length_mm;
            tools.insert(
                t.number,
                ToolData {
                    radius_mm: t.diameter_mm / 2.0,
                    offset_mm,
                },
            );
        }
        if let Some(path) = &s.tool_table {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("reading gcode.tool_table {}", path.display()))?;
            let table = super::tool_table::parse(&text)
                .with_context(|| format!("in gcode.tool_table {}", path.display()))?;
            for r in table {
                if tools.contains_key(&r.number) {
                    bail!(
                        "tool {} is both in gcode.tools and in gcode.tool_table {}",
                        r.number,
                        path.display()
                    );
                }
                tools.insert(
                    r.number,
                    ToolData {
                        radius_mm: r.diameter / 2.0,
                        offset_mm: r.offset,
                    },
                );
            }
        }
        let mut pos = [0.0; 9];
        pos[..3].copy_from_slice(&s.start_mm);
        let out = Sink::new(s.start_mm, s.limits.max_points, s.chord_tolerance_mm);
        let initial_tool = s.initial_tool;
        let initial_motion = match s.initial_motion {
            InitialMotion::None => None,
            InitialMotion::G0 => Some(Motion::Rapid),
            InitialMotion::G1 => Some(Motion::Linear),
        };
        let motion_initial = s.initial_motion != InitialMotion::None;
        let mut it = Interp {
            s,
            pos,
            units: 1.0,
            absolute: true,
            arc_absolute: false,
            plane: Plane::Xy,
            motion: initial_motion,
            motion_initial,
            feed: None,
            feed_mode: FeedMode::PerMinute,
            rpm: 0.0,
            css: false,
            coord: 0,
            work: [0.0; 9],
            g92: [0.0; 9],
            tlo: [0.0; 9],
            tools,
            current_tool: initial_tool,
            selected_tool: initial_tool,
            diameter_mode: false,
            retract_r: false,
            cycle: CycleState::default(),
            comp: Comp::default(),
            spline_prev: None,
            nurbs: None,
            nurbs6: None,
            params,
            globals: HashMap::new(),
            frames: Vec::new(),
            files: Vec::new(),
            subs: HashMap::new(),
            programs: HashMap::new(),
            dir,
            saved_modal: None,
            value: 0.0,
            value_returned: false,
            line: 0,
            executed: 0,
            bound: 0,
            percent_seen: false,
            any_content: false,
            live: false,
            pending: Vec::new(),
            opened: Opened::default(),
            probe: None,
            saved_state: String::new(),
            out,
        };
        if let Some(path) = it.s.var_file.clone() {
            if path.exists() {
                let text = std::fs::read_to_string(&path)
                    .with_context(|| format!("reading {}", path.display()))?;
                for (n, v) in
                    super::state::parse(&text).with_context(|| format!("in {}", path.display()))?
                {
                    it.params[n as usize] = v;
                }
            }
        }
        let system = it.params[P_COORD].round();
        it.select_coord(if (1.0..=9.0).contains(&system) {
            system as usize - 1
        } else {
            0
        });
        if it.params[P_G92_ON] != 0.0 {
            for i in 0..9 {
                it.g92[i] = it.params[P_G92 + i];
            }
        }
        it.saved_state = it.state_text();
        Ok(it)
    }

    /// The persistent parameters as a `.var` file's text.
    pub fn state_text(&self) -> String {
        super::state::format(|n| self.params[n as usize])
    }

    /// Write the persistent parameters to `gcode.var_file` if they changed
    /// since it was read or last written.
    pub fn save_state(&mut self) -> Result<()> {
        let Some(path) = self.s.var_file.clone() else {
            return Ok(());
        };
        let text = self.state_text();
        if text != self.saved_state {
            super::state::write_atomically(&path, &text)?;
            self.saved_state = text;
        }
        Ok(())
    }

    fn select_coord(&mut self, k: usize) {
        self.coord = k;
        self.params[P_COORD] = (k + 1) as f64;
        for i in 0..9 {
            self.work[i] = self.params[P_G54 + 20 * k + i];
        }
    }

    /// Offset from program to machine coordinates of axis `i`, mm.
    fn offset(&self, i: usize) -> f64 {
        self.work[i] + self.g92[i] + self.tlo[i]
    }

    fn axis_scale(&self, i: usize) -> f64 {
        if (3..6).contains(&i) {
            1.0 // degrees
        } else {
            self.units
        }
    }

    /// Program coordinate of axis `i`, mm (offsets removed, no diameter
    /// mode).
    pub(super) fn program_mm(&self, i: usize) -> f64 {
        self.pos[i] - self.offset(i)
    }

    /// Program coordinate of axis `i` (program units).
    fn program(&self, i: usize) -> f64 {
        let v = (self.pos[i] - self.offset(i)) / self.axis_scale(i);
        if i == 0 && self.diameter_mode {
            2.0 * v
        } else {
            v
        }
    }

    fn predefined(&self, name: &str) -> Result<Option<f64>> {
        if let Some(rest) = name.strip_prefix("_abs_") {
            if let Some(i) = AXES
                .iter()
                .position(|a| a.to_ascii_lowercase().to_string() == rest)
            {
                return Ok(Some(self.pos[i] / self.axis_scale(i)));
            }
        }
        if name.starts_with("_hal[") || name.starts_with("_ini[") {
            bail!("#<{name}> {NEEDS_MACHINE} (a HAL pin or INI value of a running LinuxCNC)");
        }
        let v = match name {
            "_x" | "_y" | "_z" | "_a" | "_b" | "_c" | "_u" | "_v" | "_w" => {
                let c = name.as_bytes()[1].to_ascii_uppercase() as char;
                let i = AXES.iter().position(|&a| a == c).unwrap_or(0);
                self.program(i)
            }
            "_line" => self.line as f64,
            "_motion_mode" => self.motion.map_or(800.0, |m| m.code()),
            "_plane" => match self.plane {
                Plane::Xy => 170.0,
                Plane::Zx => 180.0,
                Plane::Yz => 190.0,
            },
            "_ccomp" => match self.comp.side() {
                None => 400.0,
                Some(Side::Left) => 410.0,
                Some(Side::Right) => 420.0,
            },
            "_metric" => truth(self.units == 1.0),
            "_imperial" => truth(self.units != 1.0),
            "_absolute" => truth(self.absolute),
            "_incremental" => truth(!self.absolute),
            "_inverse_time" => truth(self.feed_mode == FeedMode::InverseTime),
            "_units_per_minute" => truth(self.feed_mode == FeedMode::PerMinute),
            "_units_per_rev" => truth(self.feed_mode == FeedMode::PerRev),
            "_coord_system" => [
                540.0, 550.0, 560.0, 570.0, 580.0, 590.0, 591.0, 592.0, 593.0,
            ][self.coord.min(8)],
            "_tool_offset" => truth(self.tlo.iter().any(|v| *v != 0.0)),
            "_retract_r_plane" => truth(self.retract_r),
            "_retract_old_z" => truth(!self.retract_r),
            "_spindle_rpm_mode" => truth(!self.css),
            "_spindle_css_mode" => truth(self.css),
            "_ijk_absolute_mode" => truth(self.arc_absolute),
            "_lathe_diameter_mode" => truth(self.diameter_mode),
            "_lathe_radius_mode" => truth(!self.diameter_mode),
            "_spindle_on" | "_spindle_cw" | "_mist" | "_flood" | "_feed_hold" => 0.0,
            "_speed_override" | "_feed_override" | "_adaptive_feed" => 0.0,
            "_feed" => self.feed.unwrap_or(0.0),
            "_rpm" => self.rpm,
            "_current_tool" | "_current_pocket" => self.current_tool as f64,
            "_selected_tool" | "_selected_pocket" => self.selected_tool as f64,
            "_value" => self.value,
            "_value_returned" => truth(self.value_returned),
            "_call_level" => self.frames.len().saturating_sub(1) as f64,
            "_remap_level" => 0.0,
            // Running in task (not a preview): programs that skip work in
            // previews behave as on the machine.
            "_task" => 1.0,
            "_vmajor" => 2.9,
            "_vminor" => 0.0,
            _ => return Ok(None),
        };
        Ok(Some(v))
    }

    /// Load the main program: its whole text, run by [`Interp::run`] or
    /// [`Interp::run_with`].
    pub fn load_main(&mut self, src: &str, path: Option<PathBuf>) -> Result<()> {
        let f = File::parse(src, path)?;
        for (label, &i) in &f.subs {
            self.subs.insert(label.clone(), (0, i));
        }
        self.files.push(f);
        self.start_main();
        Ok(())
    }

    /// Take the program a line at a time ([`Interp::push_line`]), as a
    /// console or a sender streams it: a program end resets the modes
    /// (RS274/NGC §3.6.1) and the next line starts the next program.
    pub fn start_live(&mut self) {
        self.live = true;
        self.files.push(File::empty());
        self.start_main();
    }

    fn start_main(&mut self) {
        self.frames.push(Frame {
            file: 0,
            pc: 0,
            call: None,
            locals: HashMap::new(),
            repeats: HashMap::new(),
        });
    }

    /// One more line of a live program (after [`Interp::start_live`]); it
    /// runs at the next [`Interp::run_with`]. The lines of an O-word
    /// structure (`sub`, `if`, loops) wait until it is closed, so that it
    /// runs as a whole, as LinuxCNC's MDI does. `Ok(false)`: waiting.
    pub fn push_line(&mut self, text: &str) -> Result<bool> {
        if !self.live {
            bail!("push_line needs a live interpreter (start_live)");
        }
        let number = self.files[0]
            .lines
            .last()
            .map_or(1, |l| l.number.saturating_add(1))
            .max(
                self.pending
                    .last()
                    .map_or(1, |l| l.number.saturating_add(1)),
            );
        let l = super::parse::line(text, number)?;
        self.opened.step(&l);
        self.pending.push(l);
        if !self.opened.closed() {
            return Ok(false);
        }
        let lines = std::mem::take(&mut self.pending);
        let base = self.files[0].lines.len();
        let added = self.files[0].append(lines)?;
        for (label, i) in added {
            self.subs.insert(label, (0, base + i));
        }
        Ok(true)
    }

    /// The modes in force, as a status report shows them (Grbl's `$G`).
    pub fn modes(&self) -> Modes {
        Modes {
            motion: self.motion.map(|m| m.code() / 10.0),
            plane: match self.plane {
                Plane::Xy => 17,
                Plane::Zx => 18,
                Plane::Yz => 19,
            },
            inches: self.units != 1.0,
            absolute: self.absolute,
            inverse_time: self.feed_mode == FeedMode::InverseTime,
            coord: self.coord,
            tool: self.current_tool,
            feed: self.feed.unwrap_or(0.0),
            rpm: self.rpm,
            spindle: self.out.spindle(),
            flood: self.out.coolant().0,
            mist: self.out.coolant().1,
            tool_length_mm: self.tlo[2],
        }
    }

    /// Numbered parameter `n` (0 outside the table).
    pub fn param(&self, n: u32) -> f64 {
        self.params.get(n as usize).copied().unwrap_or(0.0)
    }

    /// What is added to a program coordinate to make the machine
    /// coordinate (work offset, G92 and tool length), X Y Z, mm: Grbl's
    /// `WCO`.
    pub fn work_offset_mm(&self) -> [f64; 3] {
        [self.offset(0), self.offset(1), self.offset(2)]
    }

    /// Where the tool is, machine coordinates, mm.
    pub fn position_mm(&self) -> [f64; 3] {
        [self.pos[0], self.pos[1], self.pos[2]]
    }

    /// The tool is at `pos_mm` (machine coordinates): after a jog, a
    /// probe or homing, which the program did not command.
    pub fn set_position_mm(&mut self, pos_mm: [f64; 3]) {
        self.pos[..3].copy_from_slice(&pos_mm);
        self.out.restart_at(pos_mm);
    }

    /// Run a whole program (after [`Interp::load_main`]) to its end, its
    /// output left in [`Interp::out`].
    pub fn run(&mut self) -> Result<()> {
        self.run_lines()?;
        self.finish(self.line)
    }

    /// Run what has been given (a whole program, or the live lines so far)
    /// until it ends or needs more lines, handing every point and event to
    /// `machine` in order as each line completes; probing moves run there.
    pub fn run_with(&mut self, machine: &mut dyn Machine) -> Result<Stop> {
        let flush = |out: &mut Sink, m: &mut dyn Machine| -> Result<()> {
            let mut r = Ok(());
            out.drain(&mut |item| {
                if r.is_ok() {
                    r = m.emit(item);
                }
            });
            r
        };
        loop {
            if let Some(p) = machine.moved_to() {
                self.set_position_mm(p);
            }
            let r = self.run_one();
            if let Some(req) = self.probe.take() {
                flush(&mut self.out, machine)?;
                let got = machine.probe(&req);
                self.probe_done(&req, got)?;
            }
            match r? {
                Some(Stop::NeedInput) => {
                    flush(&mut self.out, machine)?;
                    return Ok(Stop::NeedInput);
                }
                Some(Stop::Ended) => {
                    if self.live {
                        self.finish(self.line)?;
                        flush(&mut self.out, machine)?;
                        self.end_of_program();
                        continue;
                    }
                    self.finish(self.line)?;
                    flush(&mut self.out, machine)?;
                    return Ok(Stop::Ended);
                }
                None => {
                    flush(&mut self.out, machine)?;
                    if self.live {
                        self.save_state()?;
                    }
                }
            }
        }
    }

    fn run_lines(&mut self) -> Result<()> {
        loop {
            match self.run_one()? {
                Some(_) => return Ok(()),
                None => {
                    if self.probe.is_some() {
                        let l = self.line;
                        bail!("line {l}: G38 probing {NEEDS_MACHINE} (where the probe trips)");
                    }
                }
            }
        }
    }

    /// Run the next line: `None` when it ran and more may follow.
    fn run_one(&mut self) -> Result<Option<Stop>> {
        if self.bound == 0 {
            let source_lines: u64 = self.files.iter().map(|f| f.lines.len() as u64).sum();
            self.bound = self
                .s
                .limits
                .max_executed_lines
                .saturating_add(source_lines);
        }
        let Some(fr) = self.frames.last() else {
            return Ok(Some(Stop::Ended));
        };
        let (fi, pc) = (fr.file, fr.pc);
        let Some(l) = self.files[fi].lines.get(pc) else {
            if self.frames.len() > 1 {
                let label = self
                    .frames
                    .last()
                    .and_then(|f| f.call.as_ref().map(|c| c.label.clone()));
                bail!(
                    "{}: the file ended inside subroutine {}",
                    self.where_(fi),
                    label.map_or(String::new(), |l| l.to_string())
                );
            }
            return Ok(Some(if self.live {
                Stop::NeedInput
            } else {
                Stop::Ended
            }));
        };
        let line = l.number;
        self.line = line;
        self.executed += 1;
        if self.executed > self.bound {
            bail!(
                "line {line}: stopped after executing {} lines (gcode.limits.max_executed_lines = {} beyond the program's own lines): an endless O-word loop?",
                self.executed - 1,
                self.s.limits.max_executed_lines
            );
        }
        if self.live && self.frames.len() == 1 {
            // A live program's lines count once each, as a file's do.
            self.bound = self.bound.saturating_add(1);
        }
        if let Some(f) = self.frames.last_mut() {
            f.pc += 1;
        }
        let stmt = l.stmt.clone();
        let block_delete = l.block_delete;
        let r = match &stmt {
            Stmt::Skipped(why) => {
                self.out.warn(line, why.clone());
                Ok(true)
            }
            Stmt::Percent => {
                if self.percent_seen || self.any_content {
                    return Ok(Some(Stop::Ended));
                }
                self.percent_seen = true;
                Ok(true)
            }
            Stmt::OWord {
                label,
                keyword,
                args,
            } => {
                self.any_content = true;
                self.oword(fi, pc, label, *keyword, args).map(|()| true)
            }
            Stmt::Block {
                words,
                assigns,
                abort,
            } => {
                if block_delete && self.s.block_delete {
                    Ok(true)
                } else {
                    if !words.is_empty() || !assigns.is_empty() {
                        self.any_content = true;
                    }
                    self.block(line, words, assigns, abort.as_deref())
                }
            }
        };
        match r {
            Ok(true) => Ok(None),
            Ok(false) => Ok(Some(Stop::Ended)),
            Err(e) => {
                let e = if e.to_string().starts_with("line ") {
                    e
                } else {
                    e.context(format!("line {line}"))
                };
                if fi > 0 {
                    return Err(e.context(self.where_(fi)));
                }
                Err(e)
            }
        }
    }

    /// A live program's end (M2, M30, `%`): the modes RS274/NGC resets
    /// (Kramer et al. §3.6.1; LinuxCNC's `convert_stop`, Grbl's
    /// `gc_execute_line` program-flow case): G54, G17, G90, G94, the motion
    /// mode G1, spindle and coolant off. The G92 offset is kept, as Grbl
    /// keeps it (RS274/NGC and LinuxCNC clear it: a live front speaks
    /// Grbl's dialect). The next line starts the next program.
    fn end_of_program(&mut self) {
        self.select_coord(0);
        self.plane = Plane::Xy;
        self.absolute = true;
        self.feed_mode = FeedMode::PerMinute;
        self.motion = Some(Motion::Linear);
        self.cycle = CycleState::default();
        self.percent_seen = false;
        self.any_content = false;
        self.frames.truncate(1);
        if let Some(f) = self.frames.last_mut() {
            f.pc = self.files[0].lines.len();
        }
        self.out.all_off(self.line);
    }

    /// A live program is abandoned (Grbl's soft reset, the machine stopped
    /// where `pos_mm` says): lines of an open structure, calls, curve
    /// blocks and compensation dropped, the modes reset as at a program
    /// end but the motion mode G0 and no feed (Grbl's `gc_init`; offsets,
    /// parameters and tools kept). Spindle and coolant are the machine's:
    /// the caller knows whether the reset stopped them.
    pub fn abort(&mut self, pos_mm: [f64; 3]) {
        self.pending.clear();
        self.opened = Opened::default();
        self.nurbs = None;
        self.nurbs6 = None;
        self.comp = Comp::default();
        self.probe = None;
        self.end_of_program();
        self.motion = Some(Motion::Rapid);
        self.feed = None;
        self.units = 1.0;
        self.tlo = [0.0; 9];
        self.spline_prev = None;
        self.out = Sink::new(pos_mm, self.s.limits.max_points, self.s.chord_tolerance_mm);
        self.pos[..3].copy_from_slice(&pos_mm);
    }

    /// Apply a probing move's outcome (LinuxCNC's `convert_probe`, Grbl's
    /// `gc_execute_line` probe case): #5061-#5069 the trip position in
    /// program coordinates, #5070 1 if it tripped; the tool where the
    /// machine says it is.
    fn probe_done(&mut self, req: &ProbeMove, got: Result<Option<[f64; 3]>>) -> Result<()> {
        let line = req.line;
        let got = got.map_err(|e| {
            if e.to_string().starts_with("line ") {
                e
            } else {
                anyhow!("line {line}: G38.{}: {e:#}", req.kind.minor())
            }
        })?;
        let (tripped, at) = match got {
            Some(p) => (true, p),
            None => (false, req.target_mm),
        };
        let mut pos = self.pos;
        pos[..3].copy_from_slice(&at);
        self.pos = pos;
        self.out.restart_at(at);
        for i in 0..9 {
            self.params[5061 + i] = self.program(i);
        }
        self.params[5070] = truth(tripped);
        if !tripped && req.kind.error_if_not_tripped() {
            bail!(
                "line {line}: G38.{}: the probe did not {} before the end of the move",
                req.kind.minor(),
                if req.kind.toward() { "trip" } else { "clear" }
            );
        }
        Ok(())
    }

    fn where_(&self, fi: usize) -> String {
        match &self.files[fi].path {
            Some(p) => format!("in subroutine file {}", p.display()),
            None => "in the program".into(),
        }
    }

    /// End of program: close open curves and compensation.
    fn finish(&mut self, line: u32) -> Result<()> {
        if let Some(c) = &self.nurbs {
            bail!("line {}: G5.2 block not closed by G5.3", c.line());
        }
        if self.nurbs6.is_some() {
            bail!("line {line}: G6.2 block not completed by its closing knots");
        }
        self.comp.flush(&mut self.out, line)
    }

    // ----- O-words -----

    fn eval_args(&self, args: &[super::expr::Expr]) -> Result<Vec<f64>> {
        args.iter().map(|a| a.eval(self)).collect()
    }

    fn jump(&self, fi: usize, pc: usize) -> Result<Jump> {
        self.files[fi]
            .jumps
            .get(&pc)
            .copied()
            .ok_or_else(|| anyhow!("O-word structure not found"))
    }

    fn goto(&mut self, pc: usize) {
        if let Some(f) = self.frames.last_mut() {
            f.pc = pc;
        }
    }

    fn oword(
        &mut self,
        fi: usize,
        pc: usize,
        label: &Label,
        kw: Keyword,
        args: &[super::expr::Expr],
    ) -> Result<()> {
        match kw {
            Keyword::Sub => {
                let Jump::SubEnd(end) = self.jump(fi, pc)? else {
                    bail!("{label} sub without its endsub");
                };
                self.goto(end + 1);
            }
            Keyword::EndSub | Keyword::Return => {
                let v = self.eval_args(args)?;
                self.ret(label, kw == Keyword::EndSub, v.first().copied())?;
            }
            Keyword::Call => {
                let v = self.eval_args(args)?;
                self.call(label, &v)?;
            }
            Keyword::If => {
                let mut at = pc;
                let mut cond = self.eval_args(args)?[0] != 0.0;
                loop {
                    let Jump::Branch { next, end } = self.jump(fi, at)? else {
                        bail!("{label} if without its endif");
                    };
                    if cond {
                        self.goto(at + 1);
                        break;
                    }
                    if next == end {
                        self.goto(end + 1);
                        break;
                    }
                    match &self.files[fi].lines[next].stmt {
                        Stmt::OWord {
                            keyword: Keyword::ElseIf,
                            args,
                            ..
                        } => {
                            let args = args.clone();
                            cond = self.eval_args(&args)?[0] != 0.0;
                            at = next;
                        }
                        _ => {
                            // else
                            self.goto(next + 1);
                            break;
                        }
                    }
                }
            }
            Keyword::ElseIf | Keyword::Else => {
                // Reached after a taken branch: leave the structure.
                let end = match self.jump(fi, pc)? {
                    Jump::Branch { end, .. } | Jump::Else { end } => end,
                    _ => bail!("{label} {} out of place", kw.name()),
                };
                self.goto(end + 1);
            }
            Keyword::EndIf | Keyword::Do | Keyword::Program => {}
            Keyword::While => match self.jump(fi, pc)? {
                Jump::LoopStart { end } => {
                    if self.eval_args(args)?[0] == 0.0 {
                        self.goto(end + 1);
                    }
                }
                Jump::LoopEnd { start } => {
                    if self.eval_args(args)?[0] != 0.0 {
                        self.goto(start + 1);
                    }
                }
                _ => bail!("{label} while out of place"),
            },
            Keyword::EndWhile => {
                let Jump::LoopEnd { start } = self.jump(fi, pc)? else {
                    bail!("{label} endwhile out of place");
                };
                self.goto(start);
            }
            Keyword::Repeat => {
                let Jump::LoopStart { end } = self.jump(fi, pc)? else {
                    bail!("{label} repeat without its endrepeat");
                };
                let n = self.eval_args(args)?[0];
                if !n.is_finite() {
                    bail!("{label} repeat count {n} is not a number");
                }
                let n = n.round().clamp(-1.0, i64::MAX as f64) as i64;
                if n <= 0 {
                    self.goto(end + 1);
                } else if let Some(f) = self.frames.last_mut() {
                    f.repeats.insert(pc, n);
                }
            }
            Keyword::EndRepeat => {
                let Jump::LoopEnd { start } = self.jump(fi, pc)? else {
                    bail!("{label} endrepeat out of place");
                };
                if let Some(f) = self.frames.last_mut() {
                    let left = f.repeats.get(&start).copied().unwrap_or(1) - 1;
                    if left > 0 {
                        f.repeats.insert(start, left);
                        f.pc = start + 1;
                    } else {
                        f.repeats.remove(&start);
                    }
                }
            }
            Keyword::Break | Keyword::Continue => {
                let Jump::InLoop { start } = self.jump(fi, pc)? else {
                    bail!("{label} {} outside a loop", kw.name());
                };
                let Jump::LoopStart { end } = self.jump(fi, start)? else {
                    bail!("{label} loop without its end");
                };
                let opener = self.files[fi].oword(start).map(|(_, k)| k);
                if kw == Keyword::Break {
                    if let Some(f) = self.frames.last_mut() {
                        f.repeats.remove(&start);
                    }
                    self.goto(end + 1);
                } else {
                    match opener {
                        Some(Keyword::While) => self.goto(start),
                        // do … while and repeat: their closing line decides.
                        _ => self.goto(end),
                    }
                }
            }
        }
        Ok(())
    }

    fn find_sub(&mut self, label: &Label) -> Result<(usize, usize)> {
        if let Some(&at) = self.subs.get(label) {
            return Ok(at);
        }
        let Label::Name(name) = label else {
            bail!("{label} call: no {label} sub in the program");
        };
        let mut dirs: Vec<PathBuf> = self.dir.iter().cloned().collect();
        dirs.extend(self.s.subroutine_dirs.iter().cloned());
        for d in &dirs {
            let p = d.join(format!("{name}.ngc"));
            if p.is_file() {
                let text = std::fs::read_to_string(&p)
                    .with_context(|| format!("reading {}", p.display()))?;
                let f = File::parse(&text, Some(p.clone()))
                    .with_context(|| format!("in subroutine file {}", p.display()))?;
                let fi = self.files.len();
                if !f.subs.contains_key(label) {
                    bail!("{label} call: {} does not define {label} sub", p.display());
                }
                for (l, &i) in &f.subs {
                    self.subs.entry(l.clone()).or_insert((fi, i));
                }
                self.files.push(f);
                return self
                    .subs
                    .get(label)
                    .copied()
                    .ok_or_else(|| anyhow!("{label} not found"));
            }
        }
        bail!(
            "{label} call: no {label} sub in the program, and no {name}.ngc in {} (gcode.subroutine_dirs)",
            if dirs.is_empty() {
                "any directory".to_string()
            } else {
                dirs.iter()
                    .map(|d| d.display().to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            }
        )
    }

    fn call(&mut self, label: &Label, args: &[f64]) -> Result<()> {
        let (fi, at) = self.find_sub(label)?;
        let depth = self.frames.len();
        if depth > self.s.limits.max_call_depth {
            bail!(
                "{label} call: more than gcode.limits.max_call_depth = {} nested calls (endless recursion?)",
                self.s.limits.max_call_depth
            );
        }
        let mut saved = [0.0; 30];
        saved.copy_from_slice(&self.params[1..=30]);
        for i in 0..30 {
            self.params[1 + i] = args.get(i).copied().unwrap_or(0.0);
        }
        self.value_returned = false;
        self.frames.push(Frame {
            file: fi,
            pc: at + 1,
            call: Some(CallInfo {
                label: label.clone(),
                saved,
                modal: None,
                m98: None,
            }),
            locals: HashMap::new(),
            repeats: HashMap::new(),
        });
        Ok(())
    }

    fn ret(&mut self, label: &Label, endsub: bool, value: Option<f64>) -> Result<()> {
        let Some(f) = self.frames.last() else {
            bail!("{label} return outside a call");
        };
        let Some(c) = &f.call else {
            bail!("{label} return or endsub reached outside a call");
        };
        if c.m98.is_some() {
            bail!(
                "{label} {}: the Fanuc subprogram O{} called by M98 ends with M99 (LinuxCNC: \"Fanuc 'O....' subroutine definition must end with 'M99'\")",
                if endsub { "endsub" } else { "return" },
                match &c.label {
                    Label::Number(n) => n.to_string(),
                    Label::Name(s) => s.clone(),
                }
            );
        }
        if endsub && &c.label != label {
            bail!("{label} return inside {} sub", c.label);
        }
        let f = self.frames.pop().unwrap_or_else(|| unreachable!());
        let c = f.call.unwrap_or_else(|| unreachable!());
        self.params[1..=30].copy_from_slice(&c.saved);
        if let Some(m) = c.modal {
            self.restore(&m)?;
        }
        self.value = value.unwrap_or(0.0);
        self.value_returned = value.is_some();
        Ok(())
    }

    fn modal(&self) -> Modal {
        Modal {
            units: self.units,
            absolute: self.absolute,
            arc_absolute: self.arc_absolute,
            plane: self.plane,
            feed: self.feed,
            feed_mode: self.feed_mode,
            coord: self.coord,
            retract_r: self.retract_r,
            diameter_mode: self.diameter_mode,
        }
    }

    fn restore(&mut self, m: &Modal) -> Result<()> {
        self.units = m.units;
        self.out.arc_tolerance = RadiusTolerance::for_units(self.units);
        self.absolute = m.absolute;
        self.arc_absolute = m.arc_absolute;
        self.plane = m.plane;
        self.feed = m.feed;
        self.feed_mode = m.feed_mode;
        if m.coord != self.coord {
            self.select_coord(m.coord);
        }
        self.retract_r = m.retract_r;
        self.diameter_mode = m.diameter_mode;
        Ok(())
    }

    // ----- blocks -----

    /// Evaluate and execute one block; `false` ends the program.
    fn block(
        &mut self,
        line: u32,
        words: &[super::parse::Word],
        assigns: &[(super::expr::ParamRef, super::expr::Expr)],
        abort: Option<&str>,
    ) -> Result<bool> {
        // A line after the program's end that did not parse, reached after
        // all (a subprogram defined after M30).
        let file = self.frames.last().map_or(0, |f| f.file);
        if let Some(e) = self.files.get(file).and_then(|f| f.unparsed.get(&line)) {
            bail!("{e}");
        }
        if let Some(msg) = abort {
            bail!("line {line}: the program aborts here: (abort, {msg})");
        }
        let mut b = Blk {
            line,
            g: Vec::new(),
            m: Vec::new(),
            w: [None; 26],
            polar: [None; 2],
        };
        for w in words {
            let v = w
                .value
                .eval(self)
                .map_err(|e| anyhow!("line {line}: {}: {e:#}", w.letter))?;
            if !v.is_finite() {
                bail!("line {line}: {} is not a finite number", w.letter);
            }
            match w.letter {
                'G' => {
                    let t = (v * 10.0).round();
                    if (v * 10.0 - t).abs() > 1e-6 || !(0.0..=9999.0).contains(&t) {
                        bail!("line {line}: G{} is not a G-code", short(v));
                    }
                    let (major, minor) = (t as u32 / 10, t as u32 % 10);
                    if b.g.contains(&(major, minor)) {
                        bail!("line {line}: G{} appears twice", short(v));
                    }
                    b.g.push((major, minor));
                }
                'M' => {
                    if v.fract() != 0.0 || !(0.0..=1000.0).contains(&v) {
                        bail!("line {line}: M{} is not an M-code", short(v));
                    }
                    b.m.push(v as u32);
                }
                '$' => {
                    if v.fract() != 0.0 || v < -1.0 {
                        bail!("line {line}: spindle ${} is not a spindle number", short(v));
                    }
                }
                '@' | '^' => {
                    let k = usize::from(w.letter == '^');
                    if b.polar[k].is_some() {
                        bail!("line {line}: word {} appears twice", w.letter);
                    }
                    b.polar[k] = Some(v);
                }
                c => {
                    let i = (c as u8 - b'A') as usize;
                    if b.w[i].is_some() {
                        bail!("line {line}: word {c} appears twice");
                    }
                    b.w[i] = Some(v);
                }
            }
        }
        // Assignments take effect after the line's values are read.
        let mut sets = Vec::with_capacity(assigns.len());
        for (p, e) in assigns {
            let v = e.eval(self).map_err(|e| anyhow!("line {line}: {e:#}"))?;
            let target = match p {
                super::expr::ParamRef::Number(n) => {
                    let n =
                        parameter_number(n.eval(self)?).map_err(|e| anyhow!("line {line}: {e}"))?;
                    Err(n)
                }
                super::expr::ParamRef::Named(s) => Ok(s.clone()),
            };
            sets.push((target, v));
        }
        for (t, v) in sets {
            match t {
                Err(n) => self.params[n as usize] = v,
                Ok(name) => {
                    if self.predefined(&name).ok().flatten().is_some() {
                        bail!("line {line}: #<{name}> is read-only");
                    }
                    if name.starts_with('_') {
                        self.globals.insert(name, v);
                    } else if let Some(f) = self.frames.last_mut() {
                        f.locals.insert(name, v);
                    }
                }
            }
        }
        if b.g.is_empty() && b.m.is_empty() && b.w.iter().all(Option::is_none) {
            return Ok(true);
        }
        self.execute(&b)
    }

    fn check_letters(&self, b: &Blk) -> Result<()> {
        if b.get('E').is_some() && self.s.extra_axes == ExtraAxes::Refuse {
            bail!(
                "line {}: word E (a 3D printer's extruder) is not a milling axis; set gcode.extra_axes = \"ignore\" to read X Y Z and drop it",
                b.line
            );
        }
        check_modal_groups(b)
    }

    fn execute(&mut self, b: &Blk) -> Result<bool> {
        let line = b.line;
        self.check_letters(b)?;
        // Curve blocks in progress take their continuation lines.
        if self.nurbs.is_some() {
            return self.nurbs_line(b).map(|()| true);
        }
        if self.nurbs6.is_some() && (b.g.is_empty() || b.has_g(6, 2)) && b.m.is_empty() {
            return self.nurbs6_line(b).map(|()| true);
        }
        if self.nurbs6.is_some() {
            bail!("line {line}: G6.2 block not completed by its closing knots before this line");
        }
        // Classify G codes.
        let mut motion_word: Option<Motion> = None;
        let mut probe: Option<ProbeKind> = None;
        let mut nonmodal: Option<(u32, u32)> = None;
        let mut g53 = false;
        let mut set_motion = |m: Motion, b: &Blk| -> Result<()> {
            if motion_word.is_some() {
                bail!("line {}: two motion codes in one block", b.line);
            }
            motion_word = Some(m);
            Ok(())
        };
        for &(g, m) in &b.g {
            match (g, m) {
                (0, 0) => set_motion(Motion::Rapid, b)?,
                (1, 0) => set_motion(Motion::Linear, b)?,
                (2, 0) => set_motion(Motion::Arc(true), b)?,
                (3, 0) => set_motion(Motion::Arc(false), b)?,
                (5, 0) => set_motion(Motion::Cubic, b)?,
                (5, 1) => set_motion(Motion::Quadratic, b)?,
                (33, 0) => set_motion(Motion::Thread, b)?,
                (73, 0) | (74, 0) | (81..=89, 0) => set_motion(Motion::Cycle(g * 10), b)?,
                (4, 0)
                | (10, 0)
                | (28, 0)
                | (28, 1)
                | (30, 0)
                | (30, 1)
                | (52, 0)
                | (92, 0)
                | (92, 1)
                | (92, 2)
                | (92, 3) => {
                    if let Some(o) = nonmodal {
                        bail!("line {line}: G{} and G{g}.{m} in one block", o.0);
                    }
                    nonmodal = Some((g, m));
                }
                (53, 0) => g53 = true,
                (5, 2) | (5, 3) | (6, 2) | (80, 0) => {}
                (17, 0) | (18, 0) | (19, 0) | (20, 0) | (21, 0) | (7, 0) | (8, 0) => {}
                (40, 0) | (41, 0) | (42, 0) | (41, 1) | (42, 1) => {}
                (43, 0) | (43, 1) | (43, 2) | (49, 0) => {}
                (54..=58, 0) | (59, 0..=3) => {}
                (61, 0) | (61, 1) | (64, 0) => {}
                (90, 0) | (91, 0) | (90, 1) | (91, 1) | (93, 0) | (94, 0) | (95, 0) => {}
                (96, 0) | (97, 0) | (98, 0) | (99, 0) => {}
                (38, 2..=5) => probe = ProbeKind::from_minor(m),
                (76, 0) => bail!("line {line}: G76 threading cycle is not supported"),
                (70..=72, _) => bail!("line {line}: G{g} lathe contour cycle is not supported"),
                (33, 1) => bail!("line {line}: G33.1 rigid tapping is not supported"),
                (17..=19, 1) => bail!("line {line}: G{g}.1 planes (UV, WU, VW) are not supported"),
                (g, 0) => bail!("line {line}: G{g} is not supported"),
                (g, m) => bail!("line {line}: G{g}.{m} is not supported"),
            }
        }
        // Order of execution (Kramer et al. table 8).
        if b.has_g(93, 0) {
            self.feed_mode = FeedMode::InverseTime;
        }
        if b.has_g(94, 0) {
            self.feed_mode = FeedMode::PerMinute;
        }
        if b.has_g(95, 0) {
            self.feed_mode = FeedMode::PerRev;
        }
        if let Some(f) = b.get('F') {
            if f < 0.0 {
                bail!("line {line}: feed F{} is negative", short(f));
            }
            self.feed = Some(f);
        }
        if let Some(s) = b.get('S') {
            if s < 0.0 {
                bail!("line {line}: spindle speed S{} is negative", short(s));
            }
            self.rpm = s;
            if !b.m.iter().any(|m| matches!(m, 3..=5)) {
                self.out.s_word(line, s);
            }
        }
        if let Some(t) = b.get('T') {
            if t < 0.0 || t.fract() != 0.0 {
                bail!("line {line}: tool T{} is not a whole number ≥ 0", short(t));
            }
            self.selected_tool = t as u32;
        }
        for &m in &b.m {
            match m {
                6 => self.current_tool = self.selected_tool,
                61 => {
                    let q = b
                        .get('Q')
                        .ok_or_else(|| anyhow!("line {line}: M61 needs a Q word"))?;
                    if q < 0.0 || q.fract() != 0.0 {
                        bail!("line {line}: M61 Q{} is not a tool number", short(q));
                    }
                    self.current_tool = q as u32;
                    self.selected_tool = q as u32;
                }
                0 | 1 | 2 | 30 | 60 => {}
                // After the block's motion (see `Interp::m98`).
                98 | 99 => {}
                3..=5 => self.out.m_word(line, m, self.rpm),
                // After the spindle words (RS274/NGC's order of execution).
                7..=9 | 19 | 48..=53 => {}
                62..=65 | 67 | 68 => {}
                66 => bail!("line {line}: M66 (wait for an input) {NEEDS_MACHINE}"),
                70 => self.saved_modal = Some(self.modal()),
                71 => self.saved_modal = None,
                72 => {
                    let m = self
                        .saved_modal
                        .clone()
                        .ok_or_else(|| anyhow!("line {line}: M72 without a state saved by M70"))?;
                    self.restore(&m)?;
                }
                73 => {
                    let m = self.modal();
                    match self.frames.last_mut().and_then(|f| f.call.as_mut()) {
                        Some(c) => c.modal = Some(m),
                        None => bail!("line {line}: M73 outside a subroutine"),
                    }
                }
                100..=199 => {
                    bail!("line {line}: M{m} runs a user program on the machine: {NEEDS_MACHINE}")
                }
                m => bail!("line {line}: M{m} is not supported"),
            }
        }
        for &m in b.m.iter().filter(|m| matches!(m, 7..=9)) {
            self.out.m_word(line, m, self.rpm);
        }
        if b.has_g(4, 0) && b.get('P').is_none() {
            bail!("line {line}: G4 dwell without a P word");
        }
        if b.has_g(4, 0) && b.get('P').is_some_and(|p| !(p.is_finite() && p >= 0.0)) {
            bail!("line {line}: G4 dwell P must be a time of 0 s or more");
        }
        for &(g, m) in &b.g {
            match (g, m) {
                (17, 0) => self.plane = Plane::Xy,
                (18, 0) => self.plane = Plane::Zx,
                (19, 0) => self.plane = Plane::Yz,
                (20, 0) | (21, 0) => {
                    self.units = if g == 20 { 25.4 } else { 1.0 };
                    self.out.arc_tolerance = RadiusTolerance::for_units(self.units);
                }
                (7, 0) => self.diameter_mode = true,
                (8, 0) => self.diameter_mode = false,
                (96, 0) => self.css = true,
                (97, 0) => self.css = false,
                (61, 0 | 1) => self.out.path_control(line, PathMode::Exact),
                (64, 0) => {
                    // P in program units; P0 as no P; Q (LinuxCNC's naive
                    // CAM tolerance) is read and ignored (crate docs).
                    let p = match b.get('P') {
                        Some(p) if !(p.is_finite() && p >= 0.0) => {
                            bail!(
                                "line {line}: G64 P{} is not a tolerance of 0 or more",
                                short(p)
                            )
                        }
                        Some(p) if p > 0.0 => Some(p * self.units),
                        _ => None,
                    };
                    self.out.path_control(line, PathMode::Blend(p));
                }
                _ => {}
            }
        }
        // Cutter compensation.
        if b.has_g(40, 0) {
            self.comp.off(&mut self.out, line)?;
        }
        for (g, m, side) in [
            (41, 0, Side::Left),
            (42, 0, Side::Right),
            (41, 1, Side::Left),
            (42, 1, Side::Right),
        ] {
            if b.has_g(g, m) {
                if self.plane != Plane::Xy {
                    bail!("line {line}: cutter compensation outside the XY plane (G17) is not supported");
                }
                let radius = if m == 1 {
                    b.get('D').ok_or_else(|| {
                        anyhow!("line {line}: G{g}.1 needs a D word (the diameter)")
                    })? * self.units
                        / 2.0
                } else {
                    let t = match b.get('D') {
                        Some(d) if d >= 0.0 && d.fract() == 0.0 => d as u32,
                        Some(d) => bail!("line {line}: D{} is not a tool number", short(d)),
                        None => self.current_tool,
                    };
                    match self.tools.get(&t) {
                        Some(td) => td.radius_mm,
                        None if t == 0 => 0.0,
                        None => bail!(
                            "line {line}: G{g}: tool {t} is not in the tool table (gcode.tools)"
                        ),
                    }
                };
                if radius < 0.0 {
                    bail!("line {line}: cutter compensation with a negative radius");
                }
                self.comp.on(side, radius, line)?;
            }
        }
        // Tool length offset.
        if b.has_g(49, 0) {
            self.tlo = [0.0; 9];
        }
        if b.has_g(43, 0) || b.has_g(43, 2) {
            let t = match b.get('H') {
                Some(h) if h >= 0.0 && h.fract() == 0.0 => h as u32,
                Some(h) => bail!("line {line}: H{} is not a tool number", short(h)),
                None => self.current_tool,
            };
            let off = match self.tools.get(&t) {
                Some(td) => td.offset_mm,
                None if t == 0 => [0.0; 9],
                None if self.s.strict_tools => bail!(
                    "line {line}: G43: tool {t} is not in the tool table (gcode.tools, gcode.tool_table; gcode.strict_tools is on)"
                ),
                None => {
                    // See `GcodeSettings::strict_tools`.
                    self.out.warn(
                        line,
                        format!("G43: tool {t} is not in the tool table: its length is taken as 0 (give it in gcode.tool_table or gcode.tools; gcode.strict_tools = true refuses this)"),
                    );
                    [0.0; 9]
                }
            };
            if b.has_g(43, 0) {
                self.tlo = [0.0; 9];
            }
            for (v, o) in self.tlo.iter_mut().zip(off) {
                *v += o;
            }
        }
        if b.has_g(43, 1) {
            self.tlo = [0.0; 9];
            for (i, a) in AXES.iter().enumerate() {
                if let Some(v) = b.get(*a) {
                    self.tlo[i] = v * self.axis_scale(i);
                }
            }
        }
        // Coordinate system.
        for &(g, m) in &b.g {
            let k = match (g, m) {
                (54..=58, 0) => (g - 54) as usize,
                (59, 0) => 5,
                (59, 1..=3) => 5 + m as usize,
                _ => continue,
            };
            if self.comp.side().is_some() {
                bail!("line {line}: changing the coordinate system with cutter compensation on");
            }
            self.select_coord(k);
        }
        // Distance modes, retract mode.
        for &(g, m) in &b.g {
            match (g, m) {
                (90, 0) => self.absolute = true,
                (91, 0) => self.absolute = false,
                (90, 1) => self.arc_absolute = true,
                (91, 1) => self.arc_absolute = false,
                (98, 0) => self.retract_r = false,
                (99, 0) => self.retract_r = true,
                _ => {}
            }
        }
        // Non-modal codes that use axis words.
        if let Some((g, m)) = nonmodal {
            if motion_word.is_some() && b.has_axis() && g != 4 {
                bail!("line {line}: G{g} and a motion code both use the axis words");
            }
            self.nonmodal(b, g, m)?;
        }
        if b.has_g(80, 0) {
            if motion_word.is_some() {
                bail!("line {line}: G80 and a motion code in one block");
            }
            if b.has_axis() && nonmodal.is_none() {
                bail!("line {line}: G80 with axis words");
            }
            self.motion = None;
            self.motion_initial = false;
            self.cycle = CycleState::default();
        }
        if b.has_g(5, 3) {
            bail!("line {line}: G5.3 without G5.2");
        }
        if b.has_g(5, 2) {
            if motion_word.is_some() {
                bail!("line {line}: G5.2 and a motion code in one block");
            }
            self.comp_check(line, "G5.2")?;
            let start = [self.pos[0], self.pos[1], self.pos[2]];
            self.nurbs = Some(Collector::new(start, self.plane, line));
            self.nurbs_line(b)?;
            return Ok(true);
        }
        if b.has_g(6, 2) {
            self.comp_check(line, "G6.2")?;
            let p = b
                .get('P')
                .ok_or_else(|| anyhow!("line {line}: G6.2 needs the order P on its first line"))?;
            self.nurbs6 = Some(Collector6::new(p, line)?);
            self.nurbs6_line(b)?;
            return Ok(true);
        }
        // Motion.
        let axis_words_used = nonmodal.is_some_and(|(g, _)| g != 4);
        if let Some(kind) = probe {
            if motion_word.is_some() || axis_words_used {
                bail!(
                    "line {line}: G38.{} and another motion in one block",
                    kind.minor()
                );
            }
            return self.probe_block(b, kind).map(|()| true);
        }
        if let Some(m) = motion_word {
            if let (Some(Motion::Cycle(_)), false) = (self.motion, matches!(m, Motion::Cycle(_))) {
                self.cycle = CycleState::default();
            }
            if self.motion != Some(m) {
                if let Motion::Cycle(_) = m {
                    self.cycle.initial_level = None;
                }
            }
            self.motion = Some(m);
            self.motion_initial = false;
        }
        if b.has_axis() && !axis_words_used {
            let Some(m) = self.motion else {
                bail!("line {line}: axis words without a motion mode (G0/G1/G2/G3; before the first, gcode.initial_motion = \"g0\" reads them as G0 as Grbl does)");
            };
            if self.motion_initial {
                self.motion_initial = false;
                self.out.warn(
                    line,
                    format!(
                        "axis words before any motion code: read as {} (gcode.initial_motion; \"none\" refuses them as LinuxCNC does)",
                        if m == Motion::Rapid { "G0" } else { "G1" }
                    ),
                );
            }
            if g53 && !matches!(m, Motion::Rapid | Motion::Linear) {
                bail!("line {line}: G53 needs G0 or G1");
            }
            if g53 && !self.absolute {
                bail!("line {line}: G53 in incremental mode (G91)");
            }
            self.motion_block(b, m, g53)?;
        }
        let (m98, m99) = (b.m.contains(&98), b.m.contains(&99));
        if (m98 || m99) && b.m.iter().any(|&m| m == 2 || m == 30) || m98 && m99 {
            bail!("line {line}: M98, M99, M2 and M30 end or leave the block's program: one of them per block");
        }
        if m98 {
            self.m98(b)?;
        }
        if m99 {
            return self.m99(b);
        }
        if b.m.iter().any(|&m| m == 2 || m == 30) {
            return Ok(false);
        }
        Ok(true)
    }

    /// A G38.2-.5 block: the probing move the [`Machine`] runs (it is not
    /// modal here: each probe is its own block, as senders write them).
    fn probe_block(&mut self, b: &Blk, kind: ProbeKind) -> Result<()> {
        let line = b.line;
        self.comp_check(line, "G38 probing")?;
        if !b.has_axis() {
            bail!("line {line}: G38.{} needs an axis word", kind.minor());
        }
        if self.feed_mode == FeedMode::InverseTime {
            bail!(
                "line {line}: G38.{} in inverse time mode (G93)",
                kind.minor()
            );
        }
        let target = self.target(b, false)?;
        self.check_extra_axes(&target, line)?;
        let to = [target[0], target[1], target[2]];
        if to == self.position_mm() {
            bail!(
                "line {line}: G38.{}: the probe move ends where it starts",
                kind.minor()
            );
        }
        let feed = self.feed_cap(line, super::dist3(&self.pos, &target))?;
        self.comp.flush(&mut self.out, line)?;
        self.probe = Some(ProbeMove {
            kind,
            target_mm: to,
            feed_mm_per_min: feed,
            line,
        });
        Ok(())
    }

    /// `M98 P<n> [L<passes>]`: run the Fanuc subprogram `O<n>` (an `O<n>`
    /// line, its end the first `M99` executed) `L` times (default 1; `L0`
    /// skips the call). As LinuxCNC does it (`interp_read.cc`,
    /// `Interp::read_o`; `interp_o_word.cc`, `Interp::execute_call`,
    /// `CT_NGC_M98_SUB`): #1-#30 are passed through, not saved and
    /// restored as `o… call` does, and `O<n>` is looked for in the calling
    /// file, then in the main program (LinuxCNC then looks for a file named
    /// `<n>.ngc`; we do not). LinuxCNC takes M98 only as the first word of
    /// a line; we take it anywhere in a block and call after the block's
    /// motion, where grblHAL does (`gcode.c`, `gc_execute_line`,
    /// `MacroCall_NonModal98`, after the motion and before program flow).
    /// Fanuc can pack the passes into P (`P30100`: 3 × O100); LinuxCNC,
    /// grblHAL and Mach3 read P as the number and L as the passes, so do we.
    /// Passes and nesting are bounded by `gcode.limits`.
    fn m98(&mut self, b: &Blk) -> Result<()> {
        let line = b.line;
        let p = b
            .get('P')
            .ok_or_else(|| anyhow!("line {line}: M98 needs P, the program number to call"))?;
        if !(p >= 0.0 && p.fract() == 0.0 && p <= u32::MAX as f64) {
            bail!("line {line}: M98 P{p} is not a program number");
        }
        let n = p as u32;
        let passes = match b.get('L') {
            None => 1,
            Some(l) if l >= 0.0 && l.fract() == 0.0 => l.min(u64::MAX as f64) as u64,
            Some(l) => bail!("line {line}: M98 L{l} is not a number of passes"),
        };
        if passes == 0 {
            return Ok(());
        }
        let depth = self.frames.len();
        if depth > self.s.limits.max_call_depth {
            bail!(
                "line {line}: M98 P{n}: more than gcode.limits.max_call_depth = {} nested calls (endless recursion?)",
                self.s.limits.max_call_depth
            );
        }
        let here = self.frames.last().map_or(0, |f| f.file);
        let mut found = None;
        for fi in [here, 0] {
            if let Some(at) = self.find_program(fi, n, line)? {
                found = Some((fi, at));
                break;
            }
        }
        let Some((fi, at)) = found else {
            let hint = if n >= 10_000 && b.get('L').is_none() {
                format!(" (Fanuc's P that packs passes and number, P{}{:04} for {} × O{}, is not read: write M98 P{} L{})", n / 10_000, n % 10_000, n / 10_000, n % 10_000, n % 10_000, n / 10_000)
            } else {
                String::new()
            };
            bail!("line {line}: M98 P{n}: no O{n} line (a Fanuc subprogram: O{n} … M99) in the program{hint}");
        };
        self.frames.push(Frame {
            file: fi,
            pc: at + 1,
            call: Some(CallInfo {
                label: Label::Number(n),
                saved: [0.0; 30],
                modal: None,
                m98: Some((at, passes - 1)),
            }),
            locals: HashMap::new(),
            repeats: HashMap::new(),
        });
        Ok(())
    }

    /// The line of `O<n>` in file `fi`, if there is one; two are an error.
    fn find_program(&mut self, fi: usize, n: u32, line: u32) -> Result<Option<usize>> {
        let Some(file) = self.files.get(fi) else {
            return Ok(None);
        };
        let index = self.programs.entry(fi).or_insert_with(|| {
            let mut m: HashMap<u32, Vec<usize>> = HashMap::new();
            for i in 0..file.lines.len() {
                if let Some((Label::Number(k), Keyword::Program)) = file.oword(i) {
                    m.entry(*k).or_default().push(i);
                }
            }
            m
        });
        match index.get(&n).map(Vec::as_slice) {
            None | Some([]) => Ok(None),
            Some([at]) => Ok(Some(*at)),
            Some([a, b, ..]) => bail!(
                "line {line}: M98 P{n}: O{n} is on lines {} and {}",
                file.lines[*a].number,
                file.lines[*b].number
            ),
        }
    }

    /// `M99`: the end of a pass of an `M98` subprogram (the next pass, or
    /// back to the caller). In the main program it ends the program: a
    /// Fanuc or Mach3 control would start the program over, endlessly (a
    /// bar feeder's loop); LinuxCNC loops only in its task with
    /// `[RS274NGC]FEATURES` bit 5 and ends the program elsewhere, its
    /// preview included (`interp_convert.cc`, `Interp::convert_stop`,
    /// `loop_on_main_m99`), and so does grblHAL (`gcode.c`,
    /// `gc_execute_line`, `ProgramFlow_Return` without a macro to return
    /// from). A toolpath is one pass. `M99` inside an `o… sub` is an
    /// error, as in LinuxCNC (`interp_o_word.cc`,
    /// `Interp::convert_control_functions`).
    fn m99(&mut self, b: &Blk) -> Result<bool> {
        let line = b.line;
        if b.get('P').is_some() {
            bail!("line {line}: M99 P (return to a numbered line of the caller) is not supported");
        }
        let Some(f) = self.frames.last_mut() else {
            return Ok(false);
        };
        let Some(c) = f.call.as_mut() else {
            return Ok(false); // the main program
        };
        match c.m98.as_mut() {
            None => bail!(
                "line {line}: M99 inside {} sub, which ends with {} endsub or {} return (LinuxCNC: \"'O.... endsub' or 'O.... return' must follow 'O.... sub'\")",
                c.label,
                c.label,
                c.label
            ),
            Some((at, left)) if *left > 0 => {
                *left -= 1;
                f.pc = *at + 1;
            }
            Some(_) => {
                self.frames.pop();
            }
        }
        Ok(true)
    }

    fn comp_check(&self, line: u32, what: &str) -> Result<()> {
        if self.comp.side().is_some() {
            bail!("line {line}: {what} with cutter compensation on is not supported");
        }
        Ok(())
    }

    fn nonmodal(&mut self, b: &Blk, g: u32, m: u32) -> Result<()> {
        let line = b.line;
        match (g, m) {
            // P in seconds (RS274/NGC, LinuxCNC and Grbl alike).
            (4, 0) => self.out.dwell(line, b.get('P').unwrap_or(0.0)),
            (28, 0) | (30, 0) => {
                self.comp_check(line, &format!("G{g}"))?;
                let base = if g == 28 { P_G28 } else { P_G30 };
                if b.has_axis() {
                    let mid = self.target(b, false)?;
                    self.move_to(mid, None, line)?;
                    let mut end = self.pos;
                    for (i, a) in AXES.iter().enumerate() {
                        if b.get(*a).is_some() {
                            end[i] = self.params[base + i];
                        }
                    }
                    self.move_to(end, None, line)?;
                } else {
                    let mut end = self.pos;
                    for (i, e) in end.iter_mut().enumerate() {
                        *e = self.params[base + i];
                    }
                    self.move_to(end, None, line)?;
                }
            }
            (28, 1) | (30, 1) => {
                let base = if g == 28 { P_G28 } else { P_G30 };
                for i in 0..9 {
                    self.params[base + i] = self.pos[i];
                }
            }
            (92, 0) => {
                if !b.has_axis() {
                    if b.get('E').is_some() && self.s.extra_axes == ExtraAxes::Ignore {
                        return Ok(()); // `G92 E0`: an extruder reset, dropped
                    }
                    bail!("line {line}: G92 without axis words");
                }
                for (i, a) in AXES.iter().enumerate() {
                    if let Some(v) = b.get(*a) {
                        let v = if i == 0 && self.diameter_mode {
                            v / 2.0
                        } else {
                            v
                        };
                        self.g92[i] =
                            self.pos[i] - self.work[i] - self.tlo[i] - v * self.axis_scale(i);
                    }
                }
                self.store_g92();
            }
            (52, 0) => {
                for (i, a) in AXES.iter().enumerate() {
                    if let Some(v) = b.get(*a) {
                        self.g92[i] = v * self.axis_scale(i);
                    }
                }
                self.store_g92();
            }
            (92, 1) => {
                self.g92 = [0.0; 9];
                self.store_g92();
                self.params[P_G92_ON] = 0.0;
            }
            (92, 2) => self.g92 = [0.0; 9],
            (92, 3) => {
                for i in 0..9 {
                    self.g92[i] = self.params[P_G92 + i];
                }
            }
            (10, 0) => self.g10(b)?,
            _ => {}
        }
        Ok(())
    }

    fn store_g92(&mut self) {
        for i in 0..9 {
            self.params[P_G92 + i] = self.g92[i];
        }
        self.params[P_G92_ON] = truth(self.g92.iter().any(|v| *v != 0.0));
    }

    fn g10(&mut self, b: &Blk) -> Result<()> {
        let line = b.line;
        let l = b
            .get('L')
            .ok_or_else(|| anyhow!("line {line}: G10 needs an L word"))?;
        let p = b
            .get('P')
            .ok_or_else(|| anyhow!("line {line}: G10 needs a P word"))?;
        if p.fract() != 0.0 || p < 0.0 {
            bail!("line {line}: G10 P{} is not a whole number", short(p));
        }
        match l as u32 {
            2 | 20 => {
                if !(0.0..=9.0).contains(&p) {
                    bail!(
                        "line {line}: G10 L{} P{}: coordinate systems are P0 (active) to P9",
                        short(l),
                        short(p)
                    );
                }
                if b.get('R').is_some_and(|r| r != 0.0) {
                    bail!("line {line}: coordinate-system rotation (G10 R) is not supported");
                }
                let k = if p == 0.0 { self.coord } else { p as usize - 1 };
                for (i, a) in AXES.iter().enumerate() {
                    if let Some(v) = b.get(*a) {
                        let v = if i == 0 && self.diameter_mode {
                            v / 2.0
                        } else {
                            v
                        };
                        let mm = v * self.axis_scale(i);
                        self.params[P_G54 + 20 * k + i] = if l as u32 == 2 {
                            mm
                        } else {
                            self.pos[i] - self.g92[i] - self.tlo[i] - mm
                        };
                    }
                }
                if k == self.coord {
                    self.select_coord(k);
                }
            }
            1 | 10 | 11 => {
                let t = self.tools.entry(p as u32).or_default();
                if let Some(r) = b.get('R') {
                    t.radius_mm = r * self.units;
                }
                if let Some(z) = b.get('Z') {
                    t.offset_mm[2] = if l as u32 == 1 {
                        z * self.units
                    } else {
                        // The length that makes the current Z read `z`.
                        self.pos[2] - self.work[2] - self.g92[2] - z * self.units
                    };
                }
            }
            _ => bail!("line {line}: G10 L{} is not supported", short(l)),
        }
        Ok(())
    }

    /// The machine target of a block's axis words.
    pub(super) fn target(&self, b: &Blk, g53: bool) -> Result<[f64; 9]> {
        let mut t = self.pos;
        if b.polar.iter().any(Option::is_some) {
            // LinuxCNC's polar words (`find_ends`): radius and angle about
            // the program origin in the XY plane; G91 adds to the current
            // radius and angle.
            let line = b.line;
            if self.plane != Plane::Xy || g53 {
                bail!("line {line}: polar coordinates (@ ^) need the XY plane and no G53");
            }
            if b.get('X').is_some() || b.get('Y').is_some() {
                bail!("line {line}: polar coordinates (@ ^) with X or Y");
            }
            let (x, y) = (self.program(0), self.program(1));
            let (r0, a0) = (x.hypot(y), y.atan2(x).to_degrees());
            let (r, a) = if self.absolute {
                (b.polar[0].unwrap_or(r0), b.polar[1].unwrap_or(a0))
            } else {
                (
                    r0 + b.polar[0].unwrap_or(0.0),
                    a0 + b.polar[1].unwrap_or(0.0),
                )
            };
            let (s, c) = a.to_radians().sin_cos();
            t[0] = r * c * self.units + self.offset(0);
            t[1] = r * s * self.units + self.offset(1);
        }
        for (i, a) in AXES.iter().enumerate() {
            if let Some(v) = b.get(*a) {
                let v = if i == 0 && self.diameter_mode {
                    v / 2.0
                } else {
                    v
                };
                let mm = v * self.axis_scale(i);
                t[i] = if g53 {
                    mm
                } else if self.absolute {
                    mm + self.offset(i)
                } else {
                    self.pos[i] + mm
                };
            }
        }
        Ok(t)
    }

    /// The feed cap of a feed move of `length_mm`, mm/min.
    pub(super) fn feed_cap(&self, line: u32, length_mm: f64) -> Result<f64> {
        let f = self
            .feed
            .filter(|f| *f > 0.0)
            .ok_or_else(|| anyhow!("line {line}: feed move without a feed (no F word yet)"))?;
        let cap = match self.feed_mode {
            FeedMode::PerMinute => f * self.units,
            FeedMode::InverseTime => f * length_mm,
            FeedMode::PerRev => {
                if self.css {
                    bail!("line {line}: feed per revolution (G95) under constant surface speed (G96) {NEEDS_MACHINE} (the spindle speed follows the radius)");
                }
                if self.rpm <= 0.0 {
                    bail!("line {line}: feed per revolution (G95) without a spindle speed (S)");
                }
                f * self.units * self.rpm
            }
        };
        Ok(cap.min(1e6))
    }

    fn check_extra_axes(&self, target: &[f64; 9], line: u32) -> Result<()> {
        if self.s.extra_axes == ExtraAxes::Ignore {
            return Ok(());
        }
        for i in 3..9 {
            if (target[i] - self.pos[i]).abs() > 1e-9 {
                bail!(
                    "line {line}: the move drives the {} axis; host-sim's toolpath has X Y Z only (set gcode.extra_axes = \"ignore\" to keep X Y Z and drop A B C U V W)",
                    AXES[i]
                );
            }
        }
        Ok(())
    }

    /// A straight move to `target` (rapid when `cap` is `None`),
    /// uncompensated.
    pub(super) fn move_to(&mut self, target: [f64; 9], cap: Option<f64>, line: u32) -> Result<()> {
        self.check_extra_axes(&target, line)?;
        let cap = Some(cap.unwrap_or(self.s.rapid_feed_mm_per_min));
        self.out
            .push([target[0], target[1], target[2]], cap, line)?;
        self.pos = target;
        Ok(())
    }

    /// A straight feed move of a canned cycle.
    pub(super) fn feed_to(&mut self, target: [f64; 9], line: u32) -> Result<()> {
        let len = super::dist3(&self.pos, &target);
        let cap = self.feed_cap(line, len)?;
        self.move_to(target, Some(cap), line)
    }

    fn motion_block(&mut self, b: &Blk, m: Motion, g53: bool) -> Result<()> {
        let line = b.line;
        let target = self.target(b, g53)?;
        match m {
            Motion::Rapid | Motion::Linear | Motion::Thread => {
                self.check_extra_axes(&target, line)?;
                let cap = match m {
                    Motion::Rapid => None,
                    Motion::Thread => {
                        let k = b
                            .get('K')
                            .ok_or_else(|| anyhow!("line {line}: G33 needs the pitch K"))?;
                        if self.rpm <= 0.0 {
                            bail!("line {line}: G33 without a spindle speed (S)");
                        }
                        Some((k.abs() * self.units * self.rpm).min(1e6))
                    }
                    _ => Some(self.feed_cap(line, super::dist3(&self.pos, &target))?),
                };
                let cap_mm = cap.unwrap_or(self.s.rapid_feed_mm_per_min);
                let to = [target[0], target[1], target[2]];
                if self.comp.side().is_some() && !g53 {
                    self.comp.line(&mut self.out, to, cap_mm, line)?;
                } else {
                    self.comp.flush(&mut self.out, line)?;
                    self.out.push(to, Some(cap_mm), line)?;
                }
                self.pos = target;
                self.spline_prev = None;
            }
            Motion::Arc(cw) => {
                self.check_arc_words(b)?;
                self.check_extra_axes(&target, line)?;
                let (a, bb, _) = self.plane.axes();
                let centre = if let Some(r) = b.get('R') {
                    Centre::Radius(r * self.units)
                } else {
                    let mut c = [0.0; 3];
                    let ijk = [b.get('I'), b.get('J'), b.get('K')];
                    for k in 0..3 {
                        c[k] = match (ijk[k], self.arc_absolute) {
                            (Some(v), false) => self.pos[k] + v * self.units,
                            (Some(v), true) => v * self.units + self.offset(k),
                            (None, _) => self.pos[k],
                        };
                    }
                    if ijk[a].is_none() && ijk[bb].is_none() {
                        bail!("line {line}: arc without R or an offset (I J K) in the plane");
                    }
                    Centre::Point(c)
                };
                let turns = match b.get('P') {
                    None => 0.0,
                    Some(p) if p >= 1.0 && p.fract() == 0.0 => p - 1.0,
                    Some(p) => bail!("line {line}: arc P{} must be a whole number ≥ 1", short(p)),
                };
                let to = [target[0], target[1], target[2]];
                // Length for inverse-time feed: estimated from the chord and
                // turns (exact length is known only after expansion).
                let approx_len = super::dist3(&self.pos, &target).max(1e-9);
                let cap = self.feed_cap(line, approx_len)?;
                if self.comp.side().is_some() {
                    self.comp
                        .arc(&mut self.out, to, centre, cw, turns, cap, line)?;
                } else {
                    self.comp.flush(&mut self.out, line)?;
                    self.out
                        .arc(to, centre, self.plane, cw, turns, Some(cap), line)?;
                }
                self.pos = target;
                self.spline_prev = None;
            }
            Motion::Cubic | Motion::Quadratic => {
                if self.plane != Plane::Xy {
                    bail!("line {line}: G5/G5.1 splines need the XY plane (G17)");
                }
                self.comp_check(line, "a G5 spline")?;
                self.check_extra_axes(&target, line)?;
                let p0 = [self.pos[0], self.pos[1], self.pos[2]];
                let p3 = [target[0], target[1], target[2]];
                let ij = match (b.get('I'), b.get('J')) {
                    (None, None) => match (m, self.spline_prev) {
                        (Motion::Cubic, Some(pq)) => [-pq[0], -pq[1]],
                        _ => bail!("line {line}: the first G5 (and every G5.1) needs I and J"),
                    },
                    (i, j) => [i.unwrap_or(0.0) * self.units, j.unwrap_or(0.0) * self.units],
                };
                let p1 = [p0[0] + ij[0], p0[1] + ij[1], p0[2]];
                let pts = if m == Motion::Cubic {
                    let pq = [
                        b.get('P')
                            .ok_or_else(|| anyhow!("line {line}: G5 needs P and Q"))?
                            * self.units,
                        b.get('Q')
                            .ok_or_else(|| anyhow!("line {line}: G5 needs P and Q"))?
                            * self.units,
                    ];
                    self.spline_prev = Some(pq);
                    let p2 = [p3[0] + pq[0], p3[1] + pq[1], p3[2]];
                    nurbs_block::bezier(
                        &[p0, p1, p2, p3],
                        self.s.chord_tolerance_mm,
                        self.out.room(),
                    )
                } else {
                    self.spline_prev = None;
                    nurbs_block::bezier(&[p0, p1, p3], self.s.chord_tolerance_mm, self.out.room())
                }
                .map_err(|e| anyhow!("line {line}: spline {e}"))?;
                let cap = self.feed_cap(line, super::dist3(&self.pos, &target))?;
                for p in pts {
                    self.out.push(p, Some(cap), line)?;
                }
                self.pos = target;
            }
            Motion::Cycle(code) => {
                self.comp_check(line, "a canned cycle")?;
                cycles::run(self, b, code)?;
            }
        }
        Ok(())
    }

    /// The centre words of a G2/G3 block, as rs274ngc's `convert_arc`
    /// checks them: R or offsets, not both, and no offset along the axis
    /// normal to the plane.
    fn check_arc_words(&self, b: &Blk) -> Result<()> {
        let line = b.line;
        let ijk = ['I', 'J', 'K'].map(|c| b.get(c).is_some());
        if b.get('R').is_some() && ijk.iter().any(|&w| w) {
            bail!("line {line}: mixed radius-ijk format for arc (R with I, J or K)");
        }
        let (_, _, normal) = self.plane.axes();
        // A zero offset along the normal is taken: posts write it (FreeCAD's
        // `G2 … I J K0.000` in G17), Grbl ignores it (`gc_execute_line`
        // clears I J K whatever the plane); rs274ngc refuses any.
        let along_normal = b.get(['I', 'J', 'K'][normal]).is_some_and(|v| v != 0.0);
        if along_normal {
            let (word, plane) = match self.plane {
                Plane::Xy => ('K', "xy (G17)"),
                Plane::Zx => ('J', "xz (G18)"),
                Plane::Yz => ('I', "yz (G19)"),
            };
            bail!("line {line}: {word} word given for arc in {plane} plane");
        }
        Ok(())
    }

    /// A finished spline's points as moves at `cap`; the tool ends on
    /// the last.
    fn emit_curve(&mut self, pts: Vec<[f64; 3]>, cap: f64, line: u32) -> Result<()> {
        let last = *pts
            .last()
            .unwrap_or(&[self.pos[0], self.pos[1], self.pos[2]]);
        for p in pts {
            self.out.push(p, Some(cap), line)?;
        }
        self.pos[..3].copy_from_slice(&last);
        Ok(())
    }

    fn nurbs_line(&mut self, b: &Blk) -> Result<()> {
        let line = b.line;
        let Some(c) = self.nurbs.as_ref() else {
            return Ok(());
        };
        let plane = c.plane();
        if b.has_g(5, 3) {
            let c = self.nurbs.take().unwrap_or_else(|| unreachable!());
            let cap = self.feed_cap(line, 0.0)?;
            let pts = c.finish(self.s.chord_tolerance_mm, self.out.room())?;
            return self.emit_curve(pts, cap, line);
        }
        if b.g.iter().any(|g| *g != (5, 2)) || !b.m.is_empty() {
            bail!("line {line}: only control points may follow G5.2 until G5.3");
        }
        let (a, bb, _) = plane.axes();
        let allowed = [AXES[a], AXES[bb], 'P', 'L', 'F'];
        for (i, v) in b.w.iter().enumerate() {
            let ch = (b'A' + i as u8) as char;
            if v.is_some() && !allowed.contains(&ch) {
                bail!("line {line}: word {ch} is not allowed in a NURBS block");
            }
        }
        if let Some(f) = b.get('F') {
            self.feed = Some(f);
        }
        if b.get(AXES[a]).is_none() && b.get(AXES[bb]).is_none() {
            if b.g.is_empty() && b.w.iter().all(Option::is_none) {
                return Ok(());
            }
            if b.has_g(5, 2) {
                // `G5.2 P L` alone: the start point's weight and the order.
                if let Some(c) = self.nurbs.as_mut() {
                    c.set_start(b.get('P'), b.get('L'), line)?;
                }
                return Ok(());
            }
            bail!(
                "line {line}: a NURBS control point needs {} or {}",
                AXES[a],
                AXES[bb]
            );
        }
        let last = c.last();
        let mut p = last;
        for k in [a, bb] {
            if let Some(v) = b.get(AXES[k]) {
                let mm = v * self.units;
                p[k] = if self.absolute {
                    mm + self.offset(k)
                } else {
                    last[k] + mm
                };
            }
        }
        let (pw, lw) = (b.get('P'), b.get('L'));
        if let Some(c) = self.nurbs.as_mut() {
            c.add(p, pw, lw, line)?;
        }
        Ok(())
    }

    fn nurbs6_line(&mut self, b: &Blk) -> Result<()> {
        let line = b.line;
        let (a, bb, _) = self.plane.axes();
        for (i, v) in b.w.iter().enumerate() {
            let ch = (b'A' + i as u8) as char;
            if v.is_some() && ![AXES[a], AXES[bb], 'P', 'Q', 'R', 'K', 'F'].contains(&ch) {
                bail!("line {line}: word {ch} is not allowed in a G6.2 block");
            }
        }
        if b.w.iter().all(Option::is_none) {
            return Ok(());
        }
        if let Some(f) = b.get('F') {
            self.feed = Some(f);
        }
        let k = b
            .get('K')
            .ok_or_else(|| anyhow!("line {line}: every G6.2 line needs a knot K"))?;
        let point = match (b.get(AXES[a]), b.get(AXES[bb])) {
            (Some(_), Some(_)) => {
                let t = self.target(b, false)?;
                let w = b
                    .get('R')
                    .ok_or_else(|| anyhow!("line {line}: a G6.2 control point needs a weight R"))?;
                Some(([t[0], t[1], t[2]], w))
            }
            (None, None) => None,
            _ => bail!(
                "line {line}: a G6.2 control point needs both {} and {}",
                AXES[a],
                AXES[bb]
            ),
        };
        let done = match self.nurbs6.as_mut() {
            Some(c) => c.add(point, k, line)?,
            None => false,
        };
        if done {
            let c = self.nurbs6.take().unwrap_or_else(|| unreachable!());
            let cap = self.feed_cap(line, 0.0)?;
            let pts = c.finish(self.s.chord_tolerance_mm, self.out.room())?;
            self.emit_curve(pts, cap, line)?;
            self.motion = None;
            self.motion_initial = false;
        }
        Ok(())
    }
}

/// rs274ngc's modal group of G`g`.`m` (`interp_array.cc`, `gees`), for
/// the codes it knows: at most one code of a group in a block. G80 is in
/// the motion group but never conflicts there (rs274ngc drops it beside
/// another motion code; [`Interp::execute`] refuses that pair by name).
fn g_group(g: u32, m: u32) -> Option<(u8, &'static str)> {
    Some(match (g, m) {
        (4 | 10 | 52 | 53 | 92, 0) | (28 | 30, 0 | 1) | (5 | 6, 3) => (0, "non-modal"),
        (0..=3 | 33 | 73 | 74 | 76 | 70 | 80..=89, 0)
        | (5 | 6, 0..=2)
        | (33, 1)
        | (38, 2..=5)
        | (71 | 72, 0..=2) => (1, "motion"),
        (17..=19, 0 | 1) => (2, "plane"),
        (90 | 91, 0) => (3, "distance mode"),
        (90 | 91, 1) => (4, "arc distance mode"),
        (93..=95, 0) => (5, "feed mode"),
        (20 | 21, 0) => (6, "units"),
        (40, 0) | (41 | 42, 0 | 1) => (7, "cutter compensation"),
        (43, 0..=2) | (49, 0) => (8, "tool length offset"),
        (98 | 99, 0) => (10, "canned-cycle return"),
        (54..=58, 0) | (59, 0..=3) => (12, "coordinate system"),
        (61, 0 | 1) | (64, 0) => (13, "path control"),
        (96 | 97, 0) => (14, "spindle speed mode"),
        (7 | 8, 0) => (15, "lathe diameter mode"),
        (92, 1..=3) => (16, "G92 offset"),
        _ => return None,
    })
}

/// rs274ngc's modal group of M`m` (`interp_array.cc`, `ems`).
fn m_group(m: u32) -> Option<(u8, &'static str)> {
    Some(match m {
        0..=2 | 30 | 60 | 99 => (4, "stopping"),
        62..=68 => (5, "digital and analog I/O"),
        6 | 61 => (6, "tool change"),
        3..=5 | 19 | 70..=73 => (7, "spindle and modal state"),
        7..=9 => (8, "coolant"),
        48..=53 => (9, "override switches"),
        100..=199 => (10, "user-defined"),
        _ => return None,
    })
}

/// Most M codes in one block (rs274ngc's `MAX_EMS`).
const MAX_M_CODES: usize = 4;

/// At most one G code and one M code of each modal group, and at most
/// [`MAX_M_CODES`] M codes, in a block: with rs274ngc's messages
/// (`read_g`, `read_m`, `check_m_codes`).
fn check_modal_groups(b: &Blk) -> Result<()> {
    let line = b.line;
    let g_name = |(g, m): (u32, u32)| {
        if m == 0 {
            format!("G{g}")
        } else {
            format!("G{g}.{m}")
        }
    };
    for (k, &code) in b.g.iter().enumerate() {
        if code == (80, 0) {
            continue;
        }
        let Some((group, name)) = g_group(code.0, code.1) else {
            continue;
        };
        let other = b.g[..k]
            .iter()
            .find(|&&o| o != (80, 0) && g_group(o.0, o.1).is_some_and(|(g, _)| g == group));
        if let Some(&o) = other {
            bail!(
                "line {line}: two G-codes used from same modal group ({name}): {} and {}",
                g_name(o),
                g_name(code)
            );
        }
    }
    if b.m.len() > MAX_M_CODES {
        bail!(
            "line {line}: too many M-codes on line ({}; at most {MAX_M_CODES})",
            b.m.len()
        );
    }
    for (k, &code) in b.m.iter().enumerate() {
        let Some((group, name)) = m_group(code) else {
            continue;
        };
        let other = b.m[..k]
            .iter()
            .find(|&&o| m_group(o).is_some_and(|(g, _)| g == group));
        if let Some(&o) = other {
            bail!("line {line}: two M-codes used from same modal group ({name}): M{o} and M{code}");
        }
    }
    Ok(())
}

/// The directory of a program file, for its subroutine files.
pub fn program_dir(path: &Path) -> Option<PathBuf> {
    path.parent().map(Path::to_path_buf)
}

#[cfg(test)]
mod tests {
    use crate::toolpath::Toolpath;
    use crate::{parse, run, GcodeSettings};

    fn err(src: &str) -> String {
        match parse("t", src, &GcodeSettings::default()) {
            Ok(_) => panic!("{src:?} was accepted"),
            Err(e) => format!("{e:#}"),
        }
    }

    #[test]
    fn two_codes_of_one_modal_group_are_refused() {
        for src in [
            "G20 G21",
            "G90 G91",
            "G90.1 G91.1",
            "G54 G55",
            "G54 G59.3",
            "G93 G94",
            "G98 G99",
            "G17 G18",
            "G40 G41",
            "G43 G49",
            "G61 G64",
            "G96 G97 S100",
            "G7 G8",
            "G0 G1 X1",
            "G1 G2 X1 R1",
            "G1 G81 X1 Z-1 R1",
            "G4 G10 L2 P1 X0",
            "G28 G53 X0",
            "G92.1 G92.2",
        ] {
            let e = err(&format!("G1 X1 F100\n{src}\n"));
            assert!(
                e.contains("line 2: two G-codes used from same modal group"),
                "{src}: {e}"
            );
        }
        for src in [
            "M3 M4",
            "M3 M5",
            "M7 M8",
            "M0 M2",
            "M2 M30",
            "M6 M61 Q1",
            "M48 M49",
            "M70 M3",
        ] {
            let e = err(&format!("G1 X1 F100\n{src}\n"));
            assert!(
                e.contains("line 2: two M-codes used from same modal group"),
                "{src}: {e}"
            );
        }
        let e = err("G1 X1 F100\nM3 M7 M6 M0 M48\n");
        assert!(e.contains("line 2: too many M-codes"), "{e}");
    }

    #[test]
    fn codes_of_different_groups_share_a_block() {
        let s = GcodeSettings::default();
        for src in [
            "G21 G90 G17 G94 G54 G40 G49 G64 G98 G1 X1 F100\n",
            "G1 X1 F100\nM3 S1000 M8 M6\n",
            "G1 X1 F100\nG53 G0 Z0\n",
            "G1 X1 F100\nG4 P0 G1 X2\n",
        ] {
            assert!(parse("t", src, &s).is_ok(), "{src}");
        }
    }

    #[test]
    fn huge_values_print_short_in_messages() {
        for (src, shown) in [
            ("G[10**300]", "G1e300"),
            ("M[10**300]", "M1e300"),
            ("G1 X1 F[0-10**300]", "F-1e300"),
            ("T[0-10**300]", "T-1e300"),
            ("X#[10**300]", "parameter number 1e300"),
            ("X[ln[0-10**300]]", "LN of -1e300"),
            ("G1 X1 F100\nG81 X1 Z-1 R1 L[0-10**300]", "L-1e300"),
            ("G1 X1 F100\nG10 L2 P[10**300]", "P1e300"),
            ("G1 X1 F100\nG2 X2 Y0 P[0-10**300] I1", "P-1e300"),
            ("G1 X1 F100\nG2 X3 Y0 P[10**300] I1", "sweeping 1e300 turns"),
        ] {
            let e = err(&format!("{src}\n"));
            assert!(e.contains(shown) && e.len() < 200, "{src}: {e}");
        }
    }

    #[test]
    fn arc_centre_words_are_checked_as_rs274ngc() {
        let e = err("G1 X1 F100\nG2 X2 Y1 R1 I1\n");
        assert!(e.contains("line 2: mixed radius-ijk format for arc"), "{e}");
        let e = err("G1 X1 F100\nG18 G2 X2 Z1 I1 J1\n");
        assert!(
            e.contains("line 2: J word given for arc in xz (G18) plane"),
            "{e}"
        );
        let e = err("G1 X1 F100\nG2 X2 Y1 I1 K1\n");
        assert!(e.contains("line 2: K word given for arc in xy"), "{e}");
        assert!(parse(
            "t",
            "G1 X1 F100\nG2 X2 Y1 I0 J1 K0.000\n",
            &GcodeSettings::default()
        )
        .is_ok());
        let e = err("G1 X1 F100\nG19 G2 Y2 Z1 I1 K1\n");
        assert!(e.contains("line 2: I word given for arc in yz"), "{e}");
        // The offsets of the plane are fine.
        let s = GcodeSettings::default();
        assert!(parse("t", "G1 X1 F100\nG18 G2 X3 Z0 I1 K0\n", &s).is_ok());
    }

    fn p(src: &str) -> anyhow::Result<Toolpath> {
        crate::parse("t", src, &GcodeSettings::default())
    }

    #[test]
    fn fanuc_program_numbers_and_m98_subprograms() {
        // A Mach3/Fanuc file: % framing, O header with a name, the
        // subprogram after M30, called three times.
        let src = "%\nO0001 (MAIN)\nG21 G90 G0 X0 Y0 Z0\nM98 P1000 L3\nG0 X0 Y0\nM30\nO1000 (STEP)\nG91 G1 X1 F100\nG90\nM99\n%\n";
        let t = p(src).unwrap();
        let xs: Vec<f64> = t.points.iter().map(|q| q[0]).collect();
        assert_eq!(xs, vec![0.0, 1.0, 2.0, 3.0, 0.0]);
        assert_eq!(t.lines, vec![0, 8, 8, 8, 5]);
        // Inch: the subprogram runs in the caller's units.
        let t = p(&src.replace("G21", "G20")).unwrap();
        assert_eq!(t.points[3][0], 3.0 * 25.4);
        // No L: once; L0: not at all; a block's motion before its call.
        let t = p("G0 X0\nG0 X5 M98 P7\nM30\nO7\nG1 Y1 F10\nM99\n").unwrap();
        assert_eq!(t.points[1..], [[5.0, 0.0, 0.0], [5.0, 1.0, 0.0]]);
        let t = p("G0 X1\nM98 P7 L0\nM30\nO7\nG1 Y1 F10\nM99\n").unwrap();
        assert_eq!(t.points.len(), 2);
        // Nested subprograms, #1 passed through (not saved as o-call does).
        let t = p("#1=2\nM98 P1\nG0 X#1\nM30\nO1\nM98 P2 L2\nM99\nO2\n#1=[#1+1]\nM99\n").unwrap();
        assert_eq!(t.points.last().unwrap()[0], 4.0);
        // A program without M30 that runs into its subprogram: the O line
        // is passed, and M99 in the main program ends it.
        let t = p("G0 X1\nO100\nG0 X2\nM99\nG0 X3\n").unwrap();
        assert_eq!(t.points.last().unwrap()[0], 2.0);
    }

    #[test]
    fn fanuc_subprogram_errors_name_the_line() {
        for (src, want) in [
            ("G0 X1\nM98 P5\nM30\n", "line 2: M98 P5: no O5"),
            ("M98\n", "line 1: M98 needs P"),
            ("M98 P1.5\n", "line 1"),
            ("M98 P1 L-1\nM30\nO1\nM99\n", "line 1"),
            ("M98 P30100\nM30\nO100\nM99\n", "M98 P100 L3"),
            ("M98 P1\nM30\nO1\nG0 X1\n", "ended inside subroutine"),
            ("M98 P1\nM30\no2 sub\nO1\no2 endsub\n", "ends with M99"),
            (
                "o1 call\nM30\no1 sub\nM99\no1 endsub\n",
                "line 4: M99 inside o1 sub",
            ),
            ("M98 P1\nM30\nO1\nM99 P10\n", "line 4"),
            ("M98 P1 M30\n", "line 1"),
            ("M98 P1\nM30\nO1\nM99\nO1\nM99\n", "lines 3 and 5"),
            // Endless recursion stops at the call depth.
            ("M98 P1\nM30\nO1\nM98 P1\nM99\n", "max_call_depth"),
        ] {
            let e = err(src);
            assert!(e.contains(want), "{src:?}: {e}");
        }
        // Passes are bounded by the executed-lines limit.
        let s = GcodeSettings {
            limits: crate::Limits {
                max_executed_lines: 1000,
                ..Default::default()
            },
            ..Default::default()
        };
        let e = run("M98 P1 L100000000000\nM30\nO1\nM99\n", None, &s).unwrap_err();
        assert!(format!("{e:#}").contains("max_executed_lines"), "{e:#}");
    }
}
