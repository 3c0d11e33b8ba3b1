//! Where the interpreter's moves become points: the polyline, its feed caps
//! and source lines, with a bound on the number of points checked before
//! anything is allocated (so an arc of a billion turns is refused, not
//! attempted).

use anyhow::{bail, Result};

use crate::text::short;

use super::arc::{self, Centre, Plane, RadiusTolerance};
use crate::toolpath::{MachineEvent, PathMode, SpindleDir};

/// Most warnings a [`Sink`] keeps.
pub const MAX_WARNINGS: usize = 10_000;

/// One piece of the interpreter's output, in program order.
#[derive(Clone, Debug, PartialEq)]
pub enum Item {
    /// The tool moves in a straight line to `pos_mm` (machine coordinates);
    /// the first item of a run is the start, with no cap and line 0.
    Point {
        /// Where, mm.
        pos_mm: [f64; 3],
        /// The feed cap of the move, mm/min (`None`: the start).
        cap: Option<f64>,
        /// Source line.
        line: u32,
    },
    /// A machine command once the tool has reached the last point.
    Event {
        /// Source line.
        line: u32,
        /// What.
        event: MachineEvent,
    },
    /// Something read other than as written (an unknown tool taken as
    /// length 0, a Grbl query skipped …).
    Warning {
        /// Source line.
        line: u32,
        /// What.
        text: String,
    },
}

/// The points of a program so far (those not yet handed out).
pub struct Sink {
    /// Points, mm (machine coordinates).
    pub points: Vec<[f64; 3]>,
    /// Feed cap of the block ending at each point, mm/min.
    pub caps: Vec<Option<f64>>,
    /// Source line of each point.
    pub lines: Vec<u32>,
    /// Most points allowed (`gcode.limits.max_points`).
    pub max_points: usize,
    /// Largest chord error of arcs and curves, mm.
    pub tolerance_mm: f64,
    /// Spindle and coolant commands: after which point, source line, what.
    pub events: Vec<(usize, u32, MachineEvent)>,
    /// How far an arc's end may be off its circle (follows G20/G21).
    pub arc_tolerance: RadiusTolerance,
    /// What was read other than as written (a tool taken as length 0, a
    /// Grbl query skipped): source line, text.
    pub warnings: Vec<(u32, String)>,
    spindle: SpindleDir,
    rpm: f64,
    flood: bool,
    mist: bool,
    /// Warnings made so far, handed out or not.
    warned: usize,
    path: PathMode,
    /// Points handed out and dropped before `points[0]`.
    base: usize,
    /// Points of `points` already handed out.
    sent: usize,
}

impl Sink {
    /// A path starting at `start`.
    pub fn new(start: [f64; 3], max_points: usize, tolerance_mm: f64) -> Self {
        Sink {
            points: vec![start],
            caps: vec![None],
            lines: vec![0],
            max_points,
            tolerance_mm,
            events: Vec::new(),
            arc_tolerance: RadiusTolerance::MM,
            warnings: Vec::new(),
            warned: 0,
            spindle: SpindleDir::Off,
            rpm: 0.0,
            flood: false,
            mist: false,
            path: PathMode::default(),
            base: 0,
            sent: 0,
        }
    }

    /// Spindle and coolant off and the path control back to G64 (a
    /// program's end), as events only for what is not so already.
    pub fn all_off(&mut self, line: u32) {
        self.path_control(line, PathMode::default());
        if self.spindle != SpindleDir::Off {
            self.m_word(line, 5, self.rpm);
        }
        if self.flood || self.mist {
            self.m_word(line, 9, self.rpm);
        }
    }

    /// The tool is at `p` without a move of the program (a probe, a jog):
    /// the next move starts there. Call once everything is handed out.
    pub fn restart_at(&mut self, p: [f64; 3]) {
        if self.sent == self.points.len() {
            if let Some(last) = self.points.last_mut() {
                *last = p;
                return;
            }
        }
        self.points.push(p);
        self.caps.push(None);
        self.lines.push(0);
    }

    /// The spindle as the program left it.
    pub fn spindle(&self) -> SpindleDir {
        self.spindle
    }

    /// Flood and mist coolant as the program left them.
    pub fn coolant(&self) -> (bool, bool) {
        (self.flood, self.mist)
    }

    /// Points made so far, handed out or not.
    pub fn total_points(&self) -> usize {
        self.base + self.points.len()
    }

    /// Hand out the points and events made since the last call, in order,
    /// keeping only the last point (where the next move starts).
    pub fn drain(&mut self, out: &mut impl FnMut(Item)) {
        for (line, text) in std::mem::take(&mut self.warnings) {
            out(Item::Warning { line, text });
        }
        let mut events = std::mem::take(&mut self.events).into_iter().peekable();
        for k in self.sent..self.points.len() {
            while let Some((_, line, event)) = events.next_if(|e| e.0 < self.base + k) {
                out(Item::Event { line, event });
            }
            out(Item::Point {
                pos_mm: self.points[k],
                cap: self.caps[k],
                line: self.lines[k],
            });
        }
        for (_, line, event) in events {
            out(Item::Event { line, event });
        }
        let keep_from = self.points.len().saturating_sub(1);
        self.points.drain(..keep_from);
        self.caps.drain(..keep_from);
        self.lines.drain(..keep_from);
        self.base += keep_from;
        self.sent = self.points.len();
    }

    /// A warning about line `line`; after [`MAX_WARNINGS`] of them, one
    /// saying that the rest were dropped (a loop may repeat a warning
    /// without end).
    pub fn warn(&mut self, line: u32, text: impl Into<String>) {
        self.warned += 1;
        match self.warned - 1 {
            n if n < MAX_WARNINGS => self.warnings.push((line, text.into())),
            MAX_WARNINGS => self.warnings.push((
                line,
                format!("more than {MAX_WARNINGS} warnings: the rest are not kept"),
            )),
            _ => {}
        }
    }

    fn event(&mut self, line: u32, e: MachineEvent) {
        let at = (self.base + self.points.len()).saturating_sub(1);
        self.events.push((at, line, e));
    }

    /// An M word of block `line` with the spindle speed `rpm` in force:
    /// M3 M4 M5 (spindle), M7 M8 M9 (coolant) become events after the
    /// last point so far (RS274/NGC orders them before the block's
    /// motion); other M words are not machine events.
    pub fn m_word(&mut self, line: u32, m: u32, rpm: f64) {
        let spindle = match m {
            3 => Some(SpindleDir::Cw),
            4 => Some(SpindleDir::Ccw),
            5 => Some(SpindleDir::Off),
            _ => None,
        };
        if let Some(dir) = spindle {
            self.spindle = dir;
            self.rpm = rpm;
            self.event(line, MachineEvent::Spindle { dir, rpm });
            return;
        }
        let (flood, mist) = match m {
            7 => (self.flood, true),
            8 => (true, self.mist),
            9 => (false, false),
            _ => return,
        };
        self.flood = flood;
        self.mist = mist;
        self.event(line, MachineEvent::Coolant { flood, mist });
    }

    /// A dwell of `s` seconds after the last point so far (G4, or a canned
    /// cycle's P at the bottom of a hole).
    pub fn dwell(&mut self, line: u32, s: f64) {
        if s > 0.0 {
            self.event(line, MachineEvent::Dwell { s });
        }
    }

    /// The path control of block `line` (G61, G61.1, G64), an event before
    /// its motion where it changes.
    pub fn path_control(&mut self, line: u32, mode: PathMode) {
        if mode != self.path {
            self.path = mode;
            self.event(line, MachineEvent::PathControl(mode));
        }
    }

    /// An S word of block `line` that has no M3/M4/M5: a new speed of a
    /// running spindle is an event.
    pub fn s_word(&mut self, line: u32, rpm: f64) {
        if self.spindle != SpindleDir::Off && rpm != self.rpm {
            self.rpm = rpm;
            let dir = self.spindle;
            self.event(line, MachineEvent::Spindle { dir, rpm });
        }
    }

    /// How many more points fit.
    pub fn room(&self) -> usize {
        self.max_points.saturating_sub(self.total_points())
    }

    /// Fail unless `n` more points fit.
    pub fn check_room(&self, n: f64, line: u32, what: &str) -> Result<()> {
        if n.is_nan() || n > self.room() as f64 {
            bail!(
                "line {line}: {what} needs {} points; with the {} already made that is more than gcode.limits.max_points = {}",
                if n.is_finite() { short(n.round()).to_string() } else { "unboundedly many".into() },
                self.total_points(),
                self.max_points
            );
        }
        Ok(())
    }

    /// The last point.
    pub fn last(&self) -> [f64; 3] {
        *self.points.last().unwrap_or(&[0.0; 3])
    }

    /// Append one point.
    pub fn push(&mut self, p: [f64; 3], cap: Option<f64>, line: u32) -> Result<()> {
        self.check_room(1.0, line, "the path")?;
        self.points.push(p);
        self.caps.push(cap);
        self.lines.push(line);
        Ok(())
    }

    /// Append an arc from the last point (see [`arc::points`]).
    #[allow(clippy::too_many_arguments)]
    pub fn arc(
        &mut self,
        end: [f64; 3],
        centre: Centre,
        plane: Plane,
        clockwise: bool,
        extra_turns: f64,
        cap: Option<f64>,
        line: u32,
    ) -> Result<()> {
        let start = self.last();
        let pts = arc::points(
            start,
            end,
            centre,
            plane,
            clockwise,
            extra_turns,
            self.tolerance_mm,
            self.room(),
            self.arc_tolerance,
        )
        .map_err(|e| anyhow::anyhow!("line {line}: {e}"))?;
        for p in pts {
            self.push(p, cap, line)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn warnings_are_bounded() {
        let mut s = Sink::new([0.0; 3], 10, 0.001);
        for i in 0..(MAX_WARNINGS as u32 + 50) {
            s.warn(i, "w");
        }
        assert_eq!(s.warnings.len(), MAX_WARNINGS + 1);
        assert!(s.warnings[MAX_WARNINGS].1.contains("not kept"));
    }
}
