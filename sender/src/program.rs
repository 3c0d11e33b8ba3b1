//! The program to send: a G-code or CSV file (host-sim's readers, so every
//! G-code feature host-sim reads can be sent) or a built-in shape, checked
//! point by point with the controller's own acceptance rules before
//! anything is sent, and its feeds scheduled on the host with the
//! controller's scheduler (for the ETA and to check the feeds the
//! controller reports).

use std::fmt;
use std::path::{Path, PathBuf};

use clap::ValueEnum;
use controller::command::{config_from_link, point_from_link, Cmd, MIN_FEED_MM_PER_MIN};
use controller::feeder::Feeder;
use controller::settings::FEED_MAX_MM_PER_MIN;
use fuzzy_core::scheduler::{PathPoint, ScheduledPoint, SchedulerConfig};
use fuzzy_core::units::{FeedMmPerMin, Point3Mm};
use gcode_interp::shapes::Shape;
use gcode_interp::toolpath::{MachineEvent, PathMode};
use gcode_interp::GcodeSettings;
use link::batch::to_grid;
use link::{MachineCmd, PathControl, SpindleDir};

/// Where a program came from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Source {
    /// A file (G-code or CSV, by extension).
    File(PathBuf),
    /// A built-in shape (`gcode_interp::shapes`).
    Shape(Shape),
    /// A jog move ([`Jog`]).
    Jog,
}

/// A program ready to send: points in path order (the first is where the
/// program assumes the tool starts), each with its source line, on the
/// link's grid ([`on_grid`]).
#[derive(Clone, Debug)]
pub struct Program {
    /// A short name (file stem or shape name).
    pub name: String,
    /// Where it came from.
    pub source: Source,
    /// The points as the controller receives them (tags: index).
    pub points: Vec<PathPoint>,
    /// The source line of each point (0: none, e.g. the start position).
    pub lines: Vec<u32>,
    /// Path length up to each point, mm.
    pub cum_mm: Vec<f64>,
    /// For each point given to [`Program::new`], the index of the point it
    /// became (merged points share one).
    kept_at: Vec<usize>,
    /// Machine commands (spindle, coolant) in program order, each after a
    /// point.
    pub events: Vec<Event>,
}

/// A machine command of the program (M3/M4/M5 with S, M7/M8/M9): it takes
/// effect once the tool has reached point `after` (the controller ends
/// the path there, waits until the tool is at rest, applies it; the
/// points after it form a new path).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Event {
    /// The index of the point it comes after.
    pub after: usize,
    /// Its source line (0: none).
    pub line: u32,
    /// What.
    pub cmd: MachineCmd,
}

/// What goes between the path's `StartPath` and `EndPath`, in order
/// ([`Program::items`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Item {
    /// Point `index` of the program; `repeat`: sent again as the first
    /// point of the path after a machine command (where the tool rests:
    /// the scheduler's new path starts from it, as a program starts from
    /// the tool's position).
    Point {
        /// Index in [`Program::points`].
        index: usize,
        /// A repeat of the point before a machine command.
        repeat: bool,
    },
    /// Machine command `index` of [`Program::events`].
    Machine {
        /// Index in [`Program::events`].
        index: usize,
    },
}

/// How a G-code machine word becomes the link's command: the speed in
/// whole rpm (rounded; an off spindle is sent with 0), a dwell in whole
/// ms (rounded; `None` beyond [`link::DWELL_MAX_MS`]).
pub fn machine_cmd(e: &MachineEvent) -> Option<MachineCmd> {
    Some(match *e {
        MachineEvent::Spindle { dir, rpm } => {
            let dir = match dir {
                gcode_interp::toolpath::SpindleDir::Off => SpindleDir::Off,
                gcode_interp::toolpath::SpindleDir::Cw => SpindleDir::Cw,
                gcode_interp::toolpath::SpindleDir::Ccw => SpindleDir::Ccw,
            };
            if !(rpm.is_finite() && (0.0..=u32::MAX as f64).contains(&rpm)) {
                return None;
            }
            let speed_rpm = if dir == SpindleDir::Off {
                0
            } else {
                rpm.round() as u32
            };
            MachineCmd::Spindle { dir, speed_rpm }
        }
        MachineEvent::Coolant { flood, mist } => MachineCmd::Coolant { flood, mist },
        MachineEvent::Dwell { s } => {
            let ms = (s * 1000.0).round();
            if !(ms.is_finite() && (0.0..=link::DWELL_MAX_MS as f64).contains(&ms)) {
                return None;
            }
            MachineCmd::Dwell { ms: ms as u32 }
        }
        MachineEvent::PathControl(m) => MachineCmd::PathControl(match m {
            PathMode::Exact => PathControl::Exact,
            PathMode::Blend(None) => PathControl::Blend,
            // mm → nm, at least 1 (the controller bounds it by $210).
            PathMode::Blend(Some(mm)) => PathControl::Tolerance {
                nm: (mm * 1e6).round().clamp(1.0, u32::MAX as f64) as u32,
            },
        }),
    })
}

/// A machine command as G-code, for messages.
pub fn cmd_text(c: &MachineCmd) -> String {
    match *c {
        MachineCmd::Spindle { dir, speed_rpm } => match dir {
            SpindleDir::Off => "M5".into(),
            SpindleDir::Cw => format!("M3 S{speed_rpm}"),
            SpindleDir::Ccw => format!("M4 S{speed_rpm}"),
        },
        MachineCmd::Coolant { flood, mist } => match (flood, mist) {
            (false, false) => "M9".into(),
            (true, false) => "M8".into(),
            (false, true) => "M7".into(),
            (true, true) => "M7 M8".into(),
        },
        MachineCmd::Dwell { ms } => format!("G4 P{}", ms as f64 / 1000.0),
        MachineCmd::PathControl(PathControl::Exact) => "G61".into(),
        MachineCmd::PathControl(PathControl::Blend) => "G64".into(),
        MachineCmd::PathControl(PathControl::Tolerance { nm }) => {
            format!("G64 P{}", nm as f64 / 1e6)
        }
    }
}

/// Input the sender refuses: where (file and line, when the reader names
/// one) and the reader's message.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct InputError {
    /// The file (or the argument, for a shape name).
    pub file: String,
    /// The line, if the reader named one.
    pub line: Option<u32>,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(l) => write!(f, "{}:{l}: {}", self.file, self.message),
            None => write!(f, "{}: {}", self.file, self.message),
        }
    }
}

impl std::error::Error for InputError {}

/// The line number in a reader's message (`line 12: …` or `… line 12 …`):
/// the message without that prefix, and the number.
fn split_line(message: &str) -> (Option<u32>, String) {
    let Some(at) = message.find("line ") else {
        return (None, message.to_string());
    };
    let digits: String = message[at + 5..]
        .chars()
        .take_while(|c| c.is_ascii_digit())
        .collect();
    let Ok(line) = digits.parse::<u32>() else {
        return (None, message.to_string());
    };
    let rest = &message[at + 5 + digits.len()..];
    if at == 0 {
        let rest = rest.trim_start_matches([':', ',']).trim_start();
        (Some(line), rest.to_string())
    } else {
        (Some(line), message.to_string())
    }
}

impl InputError {
    /// From a reader's error: the innermost message naming a line wins
    /// (the readers put `in FILE` around `line N: …`).
    fn from_reader(file: &str, e: &anyhow::Error) -> Self {
        let inner = e.chain().last().map(|c| c.to_string()).unwrap_or_default();
        let (line, message) = split_line(&inner);
        if line.is_some() {
            return InputError {
                file: file.to_string(),
                line,
                message,
            };
        }
        // No line in the root cause: look through the whole chain.
        let full = format!("{e:#}");
        let (line, _) = split_line(&full);
        InputError {
            file: file.to_string(),
            line,
            message: inner,
        }
    }
}

/// Shape names, for messages.
fn shape_names() -> String {
    Shape::ALL
        .iter()
        .map(|s| s.name())
        .collect::<Vec<_>>()
        .join(", ")
}

/// `p` with its coordinates rounded to the link's grid
/// (`link::batch::to_grid`, 2⁻¹⁶ mm): such points travel in compact
/// `Points` batches, and the controller holds exactly these bits.
pub fn on_grid(p: PathPoint) -> PathPoint {
    let [x, y, z] = p.pos.to_bits().map(to_grid);
    PathPoint {
        pos: Point3Mm::from_bits(x, y, z),
        ..p
    }
}

/// Load `spec`: an existing file (G-code `.nc .ngc .gcode .tap .cnc .g` or
/// `.csv`, through `gcode_interp::inputs::load` with the `[gcode]`
/// settings), else a shape name.
pub fn load(spec: &str, settings: &GcodeSettings) -> Result<Program, InputError> {
    let path = Path::new(spec);
    let (t, source) = if path.exists() {
        let t = gcode_interp::inputs::load(path, settings)
            .map_err(|e| InputError::from_reader(spec, &e))?;
        (t, Source::File(path.to_path_buf()))
    } else {
        match Shape::from_str(spec, true) {
            Ok(shape) => {
                let t = shape
                    .toolpath()
                    .map_err(|e| InputError::from_reader(spec, &e))?;
                (t, Source::Shape(shape))
            }
            Err(_) => {
                return Err(InputError {
                    file: spec.to_string(),
                    line: None,
                    message: format!("no such file, nor a built-in shape ({})", shape_names()),
                })
            }
        }
    };
    from_toolpath(t, source, spec)
}

/// A program from a toolpath read from `spec`.
fn from_toolpath(
    t: gcode_interp::toolpath::Toolpath,
    source: Source,
    spec: &str,
) -> Result<Program, InputError> {
    let blocks_mm = (0..t.len()).map(|i| t.block_length_mm(i)).collect();
    let points = t.path_points();
    let mut events = Vec::with_capacity(t.events.len());
    for (after, line, e) in &t.events {
        let cmd = machine_cmd(e).ok_or_else(|| InputError {
            file: spec.to_string(),
            line: (*line > 0).then_some(*line),
            message: match e {
                MachineEvent::Dwell { s } => format!(
                    "G4 P{s}: a dwell longer than the controller takes ({} s)",
                    link::DWELL_MAX_MS / 1000
                ),
                _ => format!("{e:?}: a spindle speed the controller cannot take"),
            },
        })?;
        events.push(Event {
            after: *after,
            line: *line,
            cmd,
        });
    }
    // The controller keeps a path control until told otherwise: the next
    // program starts in G64 (as a live program's M2 restores it).
    let last_control = events.iter().rev().find_map(|e| match e.cmd {
        MachineCmd::PathControl(c) => Some(c),
        _ => None,
    });
    if last_control.is_some_and(|c| c != PathControl::Blend) {
        events.push(Event {
            after: t.len().saturating_sub(1),
            line: 0,
            cmd: MachineCmd::PathControl(PathControl::Blend),
        });
    }
    Program::new(t.name, source, points, t.lines, blocks_mm, spec).map(|p| p.with_events(events))
}

/// A jog (Grbl's `$J=`): one straight move at its own feed from where the
/// tool is, relative (`G91`, the default, as `$J=G91 …`) or to machine
/// coordinates (`G90`), in mm (`G21`) or inches (`G20`). Axes not named
/// stay where they are. It runs as a one-move program: the controller's
/// soft limits, homing requirement and alarms apply as to any motion, and
/// a stop (Ctrl-C, `stop`) cancels it under control on the path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Jog {
    /// The axis words (X, Y, Z), in the move's unit.
    pub axes: [Option<f64>; 3],
    /// `F`, in the move's unit per minute.
    pub feed: f64,
    /// `G90`: the words are machine coordinates.
    pub absolute: bool,
    /// `G20`: inches.
    pub inches: bool,
}

impl Jog {
    /// From G-code words (`X10`, `y-2.5`, `F1000`, `G90`, `G91`, `G20`,
    /// `G21`; case-insensitive, in any order; later modes win). `F` and one
    /// axis at least are required, as in Grbl's jog.
    pub fn parse<S: AsRef<str>>(words: &[S]) -> Result<Jog, String> {
        let mut j = Jog {
            axes: [None; 3],
            feed: f64::NAN,
            absolute: false,
            inches: false,
        };
        for w in words {
            let w = w.as_ref().trim();
            let mut chars = w.chars();
            let Some(letter) = chars.next() else { continue };
            let rest = chars.as_str();
            let value: f64 = rest
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite())
                .ok_or_else(|| format!("`{w}`: not a word with a number (X10, F1000, G91)"))?;
            match letter.to_ascii_uppercase() {
                'X' => j.axes[0] = Some(value),
                'Y' => j.axes[1] = Some(value),
                'Z' => j.axes[2] = Some(value),
                'F' => j.feed = value,
                'G' => match rest {
                    "90" => j.absolute = true,
                    "91" => j.absolute = false,
                    "20" => j.inches = true,
                    "21" => j.inches = false,
                    _ => return Err(format!("`{w}`: a jog takes G90, G91, G20 or G21 only")),
                },
                _ => return Err(format!("`{w}`: a jog takes X, Y, Z, F and G words only")),
            }
        }
        if j.axes.iter().all(Option::is_none) {
            return Err("a jog needs an axis word (X, Y or Z)".into());
        }
        if j.feed.is_nan() || j.feed <= 0.0 {
            return Err("a jog needs a feed above zero (F, mm/min or in/min)".into());
        }
        Ok(j)
    }

    /// Where the move ends from `here` (mm).
    pub fn target_mm(&self, here: [f64; 3]) -> [f64; 3] {
        let unit = if self.inches { 25.4 } else { 1.0 };
        let mut t = here;
        for (k, w) in self.axes.iter().enumerate() {
            if let Some(v) = w {
                t[k] = if self.absolute {
                    v * unit
                } else {
                    here[k] + v * unit
                };
            }
        }
        t
    }

    /// The feed, mm/min.
    pub fn feed_mm_per_min(&self) -> f64 {
        self.feed * if self.inches { 25.4 } else { 1.0 }
    }
}

/// The program of `jog` from `here` (mm): its words as the G-code block
/// `G21|G20 G91|G90 G1 X… F…` (the values as given), read with the tool at
/// `here` by the same reader as a file, so that the axes not named stay
/// exactly where they are.
pub fn jog(j: &Jog, here: [f64; 3], settings: &GcodeSettings) -> Result<Program, InputError> {
    let err = |message: String| InputError {
        file: "jog".into(),
        line: None,
        message,
    };
    if j.target_mm(here) == here {
        return Err(err("the jog ends where the tool is".into()));
    }
    let mut block = format!(
        "{} {} G1",
        if j.inches { "G20" } else { "G21" },
        if j.absolute { "G90" } else { "G91" }
    );
    for (letter, w) in ['X', 'Y', 'Z'].iter().zip(j.axes) {
        if let Some(v) = w {
            block.push_str(&format!(" {letter}{v}"));
        }
    }
    block.push_str(&format!(" F{}\n", j.feed));
    let mut c = settings.clone();
    c.start_mm = here;
    let t =
        gcode_interp::parse("jog", &block, &c).map_err(|e| InputError::from_reader("jog", &e))?;
    let p = from_toolpath(t, Source::Jog, "jog")?;
    if p.len() < 2 {
        return Err(err("the jog is shorter than the link's grid".into()));
    }
    Ok(p)
}

impl Program {
    /// From a toolpath's points, source lines and block lengths: every
    /// point checked as the controller checks a point command
    /// (`controller::command::point_from_link`), so that nothing the
    /// controller would refuse is sent.
    pub fn new(
        name: String,
        source: Source,
        points: Vec<PathPoint>,
        lines: Vec<u32>,
        blocks_mm: Vec<f64>,
        file: &str,
    ) -> Result<Self, InputError> {
        // On the link's grid, consecutive points that became one merged
        // (the scheduler would merge them: indices here and there agree).
        let mut kept = Vec::with_capacity(points.len());
        let mut kept_lines = Vec::with_capacity(points.len());
        let mut kept_mm: Vec<f64> = Vec::with_capacity(points.len());
        let mut kept_at = Vec::with_capacity(points.len());
        for ((p, line), b) in points.into_iter().zip(lines).zip(blocks_mm) {
            let p = on_grid(p);
            if kept.last().is_some_and(|q: &PathPoint| q.pos == p.pos) {
                if let Some(m) = kept_mm.last_mut() {
                    *m += b;
                }
                kept_at.push(kept.len().saturating_sub(1));
                continue;
            }
            kept_at.push(kept.len());
            kept.push(p);
            kept_lines.push(line);
            kept_mm.push(b);
        }
        let (points, lines, blocks_mm) = (kept, kept_lines, kept_mm);
        for (p, &line) in points.iter().zip(&lines) {
            let bits = p.pos.to_bits();
            let cap = p.feed_cap.map(|f| f.0.to_bits());
            if point_from_link(0, bits, cap).is_none() {
                let why = match p.feed_cap {
                    Some(f) if f < MIN_FEED_MM_PER_MIN => format!(
                        "feed {} mm/min is below the controller's minimum of {} mm/min",
                        f.to_f64(),
                        MIN_FEED_MM_PER_MIN.to_f64()
                    ),
                    _ => "a value the controller refuses (coordinate or feed out of range)"
                        .to_string(),
                };
                return Err(InputError {
                    file: file.to_string(),
                    line: (line > 0).then_some(line),
                    message: why,
                });
            }
        }
        let mut s = 0.0;
        let cum_mm = blocks_mm
            .iter()
            .map(|b| {
                s += b;
                s
            })
            .collect();
        Ok(Program {
            name,
            source,
            points,
            lines,
            cum_mm,
            events: Vec::new(),
            kept_at,
        })
    }

    /// With these machine commands (their `after` an index of the points
    /// given to [`Program::new`], renumbered as points merged).
    pub fn with_events(mut self, events: Vec<Event>) -> Self {
        let last = self.points.len().saturating_sub(1);
        self.events = events
            .into_iter()
            .map(|e| Event {
                after: self.kept_at.get(e.after).copied().unwrap_or(last),
                ..e
            })
            .collect();
        self
    }

    /// The stream between `StartPath` and `EndPath`: every point, each
    /// machine command after its point, and after a machine command that
    /// more points follow, its point again (the new path's start).
    pub fn items(&self) -> Vec<Item> {
        let mut out = Vec::with_capacity(self.points.len() + 2 * self.events.len());
        let mut ev = self.events.iter().enumerate().peekable();
        for index in 0..self.points.len() {
            out.push(Item::Point {
                index,
                repeat: false,
            });
            let mut any = false;
            while let Some((k, _)) = ev.next_if(|(_, e)| e.after <= index) {
                out.push(Item::Machine { index: k });
                any = true;
            }
            if any && index + 1 < self.points.len() {
                out.push(Item::Point {
                    index,
                    repeat: true,
                });
            }
        }
        out.extend(ev.map(|(k, _)| Item::Machine { index: k }));
        out
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether there are none (never, for a loaded program).
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Path length, mm.
    pub fn length_mm(&self) -> f64 {
        self.cum_mm.last().copied().unwrap_or(0.0)
    }

    /// Path length up to point index `i` (clamped), mm.
    pub fn length_to_mm(&self, i: usize) -> f64 {
        match self.cum_mm.len() {
            0 => 0.0,
            n => self.cum_mm[i.min(n - 1)],
        }
    }

    /// The source line of the point with index `i`, if it has one.
    pub fn line_of(&self, i: usize) -> Option<u32> {
        self.lines.get(i).copied().filter(|&l| l > 0)
    }

    /// Every point of [`Program::items`] as the controller's scheduler
    /// schedules it: the controller's own first stage
    /// (`controller::feeder::Feeder`, the firmware's sizes) fed the same
    /// commands (a machine command ends the path, as there): its index in
    /// its path and feed, I32F32 bits, by item.
    pub fn host_schedule(&self, config: SchedulerConfig) -> Vec<Option<(u32, i64)>> {
        let items = self.items();
        let mut out = vec![None; items.len()];
        let Ok(mut f) = Feeder::new() else {
            return out;
        };
        let mut put = |s: Option<ScheduledPoint>| {
            if let Some(o) = s {
                if let Some(slot) = out.get_mut(o.point.tag as usize) {
                    *slot = Some((o.index, o.feed.0.to_bits()));
                }
            }
        };
        let drain = |f: &mut Feeder, put: &mut dyn FnMut(Option<ScheduledPoint>)| {
            while f.is_draining() {
                put(f.drain());
            }
            f.take_path_end();
        };
        if f.command(Cmd::StartPath(config)).is_err() {
            return out;
        }
        for (k, item) in items.iter().enumerate() {
            match *item {
                Item::Point { index, repeat } => {
                    let Some(p) = self.points.get(index) else {
                        continue;
                    };
                    let p = PathPoint {
                        tag: k as u32,
                        // The new path's start: no block leads to it.
                        feed_cap: if repeat { None } else { p.feed_cap },
                        ..*p
                    };
                    if let Ok(s) = f.command(Cmd::point(p)) {
                        put(s);
                    }
                }
                Item::Machine { index } => {
                    let cmd = self.events.get(index).map(|e| e.cmd);
                    if let Some(cmd) = cmd {
                        let _ = f.command(Cmd::Machine { seq: 0, cmd });
                        drain(&mut f, &mut put);
                    }
                }
            }
        }
        let _ = f.command(Cmd::EndPath);
        drain(&mut f, &mut put);
        out
    }

    /// The host's feeds by point (the first scheduling of each point, not
    /// its repeat), from [`Program::host_schedule`].
    pub fn feeds_by_point(&self, by_item: &[Option<(u32, i64)>]) -> Vec<Option<i64>> {
        let mut out = vec![None; self.points.len()];
        for (item, f) in self.items().iter().zip(by_item) {
            if let Item::Point {
                index,
                repeat: false,
            } = *item
            {
                if let Some(slot) = out.get_mut(index) {
                    *slot = f.map(|x| x.1);
                }
            }
        }
        out
    }

    /// Time of each block (`p[i-1] → p[i]`) at the scheduled feeds capped
    /// to the machine's maximum, at 100 % override, without acceleration,
    /// plus every dwell (G4 P, a drilling cycle's P) where it happens:
    /// cumulative, s, by point index (a dwell after point `i` counts from
    /// point `i + 1` on).
    pub fn cum_time_s(&self, feeds: &[Option<i64>], feed_max_mm_per_min: f64) -> Vec<f64> {
        let mut out = Vec::with_capacity(self.points.len());
        let mut t = 0.0;
        // Dwell seconds that start at each point.
        let mut dwell_s = vec![0.0; self.points.len()];
        for e in &self.events {
            if let (MachineCmd::Dwell { ms }, Some(d)) = (e.cmd, dwell_s.get_mut(e.after + 1)) {
                *d += ms as f64 / 1000.0;
            }
        }
        for (i, dwell) in dwell_s.iter().enumerate() {
            t += dwell;
            let len = self.length_to_mm(i)
                - if i == 0 {
                    0.0
                } else {
                    self.length_to_mm(i - 1)
                };
            let f = feeds
                .get(i)
                .copied()
                .flatten()
                .map_or(feed_max_mm_per_min, |b| b as f64 / 4294967296.0)
                .min(feed_max_mm_per_min)
                .max(1e-3);
            t += len / f * 60.0;
            out.push(t);
        }
        out
    }
}

/// The scheduler settings for `--f-max`/`--f-min` (mm/min), if the
/// controller would take them (`controller::command::config_from_link`).
pub fn scheduler_config(f_max: f64, f_min: f64) -> Result<SchedulerConfig, String> {
    let ok = |v: f64| v.is_finite() && (0.0..=1e6).contains(&v);
    if !ok(f_max) || !ok(f_min) {
        return Err(format!(
            "--f-max {f_max} / --f-min {f_min}: feeds must be within [0, 1e6] mm/min"
        ));
    }
    let (a, b) = (
        FeedMmPerMin::from_f64(f_max).0.to_bits(),
        FeedMmPerMin::from_f64(f_min).0.to_bits(),
    );
    config_from_link(a, b).ok_or_else(|| {
        format!("--f-max {f_max} / --f-min {f_min}: the controller needs 1 ≤ F_min ≤ F_max (F_max at least 1 mm/min)")
    })
}

/// The machine's feed maximum the host was built for, mm/min.
pub fn machine_feed_max() -> f64 {
    FEED_MAX_MM_PER_MIN as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_jog_is_read_from_its_words_and_starts_where_the_tool_is() {
        let j = Jog::parse(&["x1.5", "Z-2", "F600"]).unwrap();
        assert_eq!(j.axes, [Some(1.5), None, Some(-2.0)]);
        assert_eq!(j.target_mm([10.0, 20.0, -1.0]), [11.5, 20.0, -3.0]);
        let a = Jog::parse(&["G91", "G90", "Y-5", "F100"]).unwrap();
        assert_eq!(a.target_mm([10.0, 20.0, -1.0]), [10.0, -5.0, -1.0]);
        let inch = Jog::parse(&["G20", "X1", "F10"]).unwrap();
        assert_eq!(inch.target_mm([0.0; 3]), [25.4, 0.0, 0.0]);
        assert_eq!(inch.feed_mm_per_min(), 254.0);
        for bad in [
            &["X1"][..],
            &["F100"],
            &["X1", "F0"],
            &["X1", "F100", "G1"],
            &["X1", "F100", "S5"],
            &["Xa", "F100"],
            &["X1", "Fnan"],
        ] {
            assert!(Jog::parse(bad).is_err(), "{bad:?}");
        }
        let here = [3.0, -4.0, 0.5];
        let p = jog(&j, here, &GcodeSettings::default()).unwrap();
        assert_eq!(p.source, Source::Jog);
        assert_eq!(p.points.len(), 2);
        let start = p.points[0].pos.to_f64();
        assert!(
            (0..3).all(|k| (start[k] - here[k]).abs() < 1e-6),
            "{start:?}"
        );
        let end = p.points[1].pos.to_f64();
        assert!(
            (end[0] - 4.5).abs() < 1e-6 && (end[2] + 1.5).abs() < 1e-6,
            "{end:?}"
        );
        assert!((p.length_mm() - (1.5f64.powi(2) + 4.0).sqrt()).abs() < 1e-6);
        let no_move = Jog::parse(&["G90", "X3", "F100"]).unwrap();
        assert!(jog(&no_move, here, &GcodeSettings::default()).is_err());
    }

    fn repo(rel: &str) -> String {
        format!("{}/../{rel}", env!("CARGO_MANIFEST_DIR"))
    }

    #[test]
    fn a_reader_error_becomes_file_line_message() {
        let dir = std::env::temp_dir().join(format!("sender-prog-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("bad.ngc");
        std::fs::write(&f, "G21 G90\nG1 X1 F100\nG999 X2\n").unwrap();
        let spec = f.to_string_lossy().into_owned();
        let e = load(&spec, &GcodeSettings::default()).unwrap_err();
        assert_eq!(e.file, spec);
        assert_eq!(e.line, Some(3), "{e}");
        assert!(!e.message.starts_with("line"), "{e}");
        assert!(e.to_string().starts_with(&format!("{spec}:3: ")), "{e}");
    }

    #[test]
    fn a_feed_below_the_controllers_minimum_is_refused_with_its_line() {
        let dir = std::env::temp_dir().join(format!("sender-prog-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("slow.ngc");
        std::fs::write(&f, "G21 G90\nG1 X1 F100\nG1 X2 F0.5\n").unwrap();
        let e = load(&f.to_string_lossy(), &GcodeSettings::default()).unwrap_err();
        assert_eq!(e.line, Some(3), "{e}");
        assert!(e.message.contains("minimum"), "{e}");
    }

    #[test]
    fn split_line_finds_the_number() {
        assert_eq!(split_line("line 12: bad"), (Some(12), "bad".into()));
        assert_eq!(
            split_line("at line 7 the arc"),
            (Some(7), "at line 7 the arc".into())
        );
        assert_eq!(split_line("no number"), (None, "no number".into()));
        assert_eq!(split_line("line x"), (None, "line x".into()));
    }

    #[test]
    fn files_and_shapes_load_and_unknown_names_are_refused() {
        let g = GcodeSettings::default();
        let p = load(&repo("tests/data/short_segments.ngc"), &g).unwrap();
        assert!(p.len() > 4000);
        assert_eq!(p.points[0].pos.to_bits(), [0; 3], "starts at the origin");
        assert!(p
            .points
            .iter()
            .all(|q| q.pos.to_bits().iter().all(|&c| link::batch::on_grid(c))));
        assert!(p.points.windows(2).all(|w| w[0].pos != w[1].pos));
        assert!(p.line_of(1).is_some());
        let c = load(&repo("tests/data/shapes/trident.csv"), &g).unwrap();
        assert!(c.len() > 1000);
        let s = load("Trident", &g).unwrap();
        assert_eq!(s.source, Source::Shape(Shape::Trident));
        assert!((s.length_mm() - c.length_mm()).abs() < 1e-3);
        let e = load("no-such-thing", &g).unwrap_err();
        assert!(e.message.contains("trident"), "{e}");
        assert_eq!(e.line, None);
    }

    #[test]
    fn host_feeds_cover_every_point_and_time_adds_up() {
        let p = load("trident", &GcodeSettings::default()).unwrap();
        let cfg = scheduler_config(3000.0, 60.0).unwrap();
        let sched = p.host_schedule(cfg);
        assert!(sched.iter().all(|f| f.is_some()));
        let feeds: Vec<Option<i64>> = sched.iter().map(|f| f.map(|x| x.1)).collect();
        let t = p.cum_time_s(&feeds, 5000.0);
        assert_eq!(t.len(), p.len());
        assert!(t.windows(2).all(|w| w[1] >= w[0]));
        // At most F_max: at least length / F_max.
        assert!(t[t.len() - 1] >= p.length_mm() / 3000.0 * 60.0 - 1e-9);
    }

    #[test]
    fn dwells_count_in_the_time_from_the_point_after_them() {
        let dir = std::env::temp_dir().join(format!("sender-dwell-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("dwell.ngc");
        // 1 mm at F60: 1 s a block; a 2.5 s dwell after the first block.
        std::fs::write(&f, "G21 G90\nG1 X1 F60\nG4 P2.5\nG1 X2\nG1 X3\n").unwrap();
        let p = load(&f.to_string_lossy(), &GcodeSettings::default()).unwrap();
        std::fs::remove_dir_all(&dir).ok();
        let feeds = vec![Some(60i64 << 32); p.len()];
        let t = p.cum_time_s(&feeds, 5000.0);
        assert_eq!(t.len(), 4);
        let want = [0.0, 1.0, 4.5, 5.5];
        for (got, want) in t.iter().zip(want) {
            assert!((got - want).abs() < 1e-6, "{t:?}");
        }
    }

    #[test]
    fn machine_words_go_between_the_points_and_the_next_path_restarts_at_its_point() {
        let dir = std::env::temp_dir().join(format!("sender-prog-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("words.ngc");
        // M3 before any move, M8 with it; S while running after X1; a
        // repeated X1 merged; M9 M5 at the end.
        std::fs::write(
            &f,
            "G21 G90\nM3 S1000.4\nM8\nG1 X1 F100\nG1 X1\nS2000\nG1 X2\nM9 M5\n",
        )
        .unwrap();
        let p = load(&f.to_string_lossy(), &GcodeSettings::default()).unwrap();
        assert_eq!(p.len(), 3);
        let texts: Vec<(usize, u32, String)> = p
            .events
            .iter()
            .map(|e| (e.after, e.line, cmd_text(&e.cmd)))
            .collect();
        let t = |a, l, s: &str| (a, l, s.to_string());
        assert_eq!(
            texts,
            vec![
                t(0, 2, "M3 S1000"),
                t(0, 3, "M8"),
                t(1, 6, "M3 S2000"),
                t(2, 8, "M5"),
                t(2, 8, "M9"),
            ]
        );
        let pt = |index, repeat| Item::Point { index, repeat };
        let m = |index| Item::Machine { index };
        assert_eq!(
            p.items(),
            vec![
                pt(0, false),
                m(0),
                m(1),
                pt(0, true),
                pt(1, false),
                m(2),
                pt(1, true),
                pt(2, false),
                m(3),
                m(4),
            ]
        );
        // Every point item is scheduled, each path on its own (the repeat
        // is its path's index 0).
        let sched = p.host_schedule(scheduler_config(3000.0, 60.0).unwrap());
        let idx: Vec<Option<u32>> = sched.iter().map(|s| s.map(|x| x.0)).collect();
        assert_eq!(
            idx,
            vec![
                Some(0),
                None,
                None,
                Some(0),
                Some(1),
                None,
                Some(0),
                Some(1),
                None,
                None
            ]
        );
        assert!(p.feeds_by_point(&sched).iter().all(|f| f.is_some()));
    }

    #[test]
    fn scheduler_settings_are_checked_as_the_controller_does() {
        assert!(scheduler_config(3000.0, 60.0).is_ok());
        assert!(scheduler_config(60.0, 3000.0).is_err());
        assert!(scheduler_config(0.5, 0.0).is_err());
        assert!(scheduler_config(f64::NAN, 0.0).is_err());
    }
}
