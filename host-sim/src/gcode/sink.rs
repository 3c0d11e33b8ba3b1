//! Where the interpreter's moves become points: the polyline, its feed caps
//! and source lines, with a bound on the number of points checked before
//! anything is allocated (so an arc of a billion turns is refused, not
//! attempted).

use anyhow::{bail, Result};

use super::arc::{self, Centre, Plane};

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
        )
        .map_err(|e| anyhow::anyhow!("line {line}: {e}"))?;
        for p in pts {
            self.push(p, cap, line)?;
        }
        Ok(())
    }
}
