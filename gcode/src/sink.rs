//! Where the interpreter's moves become points: the polyline, its feed caps
//! and source lines, with a bound on the number of points checked before
//! anything is allocated (so an arc of a billion turns is refused, not
//! attempted).

use anyhow::{bail, Result};

use super::arc::{self, Centre, Plane, RadiusTolerance};
use crate::toolpath::{MachineEvent, SpindleDir};

/// Most warnings a [`Sink`] keeps.
pub const MAX_WARNINGS: usize = 10_000;

/// The points of a program so far.
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
            spindle: SpindleDir::Off,
            rpm: 0.0,
            flood: false,
            mist: false,
        }
    }

    /// A warning about line `line`; after [`MAX_WARNINGS`] of them, one
    /// saying that the rest were dropped (a loop may repeat a warning
    /// without end).
    pub fn warn(&mut self, line: u32, text: impl Into<String>) {
        match self.warnings.len() {
            n if n < MAX_WARNINGS => self.warnings.push((line, text.into())),
            MAX_WARNINGS => self.warnings.push((
                line,
                format!("more than {MAX_WARNINGS} warnings: the rest are not kept"),
            )),
            _ => {}
        }
    }

    fn event(&mut self, line: u32, e: MachineEvent) {
        let at = self.points.len().saturating_sub(1);
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
        self.max_points.saturating_sub(self.points.len())
    }

    /// Fail unless `n` more points fit.
    pub fn check_room(&self, n: f64, line: u32, what: &str) -> Result<()> {
        if n.is_nan() || n > self.room() as f64 {
            bail!(
                "line {line}: {what} needs {} points; with the {} already made that is more than gcode.limits.max_points = {}",
                if n.is_finite() { format!("{n:.0}") } else { "unboundedly many".into() },
                self.points.len(),
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
