//! What the interpreter needs from the machine it drives: a place for its
//! output, and the live state a program may ask for (where the tool is
//! after a jog or a probe, where a probe tripped).
//!
//! A whole file read ahead of time runs against [`Collect`], which keeps
//! the output and refuses what needs a machine; a live front (a console, a
//! Grbl-speaking sender) implements [`Machine`] over its controller.

use anyhow::{bail, Result};

use crate::interp::NEEDS_MACHINE;
use crate::sink::Item;
use crate::toolpath::MachineEvent;

/// G38.2-G38.5 (LinuxCNC's and Grbl's meanings).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProbeKind {
    /// G38.2: toward the piece, an error if the probe does not trip.
    Toward,
    /// G38.3: toward the piece, no error.
    TowardNoError,
    /// G38.4: away from the piece, an error if the probe does not clear.
    Away,
    /// G38.5: away from the piece, no error.
    AwayNoError,
}

impl ProbeKind {
    /// From the code's tenths (2-5).
    pub fn from_minor(m: u32) -> Option<Self> {
        match m {
            2 => Some(ProbeKind::Toward),
            3 => Some(ProbeKind::TowardNoError),
            4 => Some(ProbeKind::Away),
            5 => Some(ProbeKind::AwayNoError),
            _ => None,
        }
    }

    /// The code's tenths.
    pub fn minor(self) -> u32 {
        match self {
            ProbeKind::Toward => 2,
            ProbeKind::TowardNoError => 3,
            ProbeKind::Away => 4,
            ProbeKind::AwayNoError => 5,
        }
    }

    /// Stops when the probe input becomes active (G38.2, G38.3); the others
    /// stop when it becomes inactive.
    pub fn toward(self) -> bool {
        matches!(self, ProbeKind::Toward | ProbeKind::TowardNoError)
    }

    /// Reaching the target without a change of the input is an error.
    pub fn error_if_not_tripped(self) -> bool {
        matches!(self, ProbeKind::Toward | ProbeKind::Away)
    }
}

/// A probing move: straight from where the tool is to `target_mm` at
/// `feed_mm_per_min`, stopping when the probe input changes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProbeMove {
    /// G38.2-.5.
    pub kind: ProbeKind,
    /// The end of the move if the probe never changes, machine
    /// coordinates, mm.
    pub target_mm: [f64; 3],
    /// Feed, mm/min.
    pub feed_mm_per_min: f64,
    /// Source line.
    pub line: u32,
}

/// The machine an interpreter drives.
pub trait Machine {
    /// The next piece of output, in program order.
    fn emit(&mut self, item: Item) -> Result<()>;

    /// Where the tool is, machine coordinates, mm, if it moved other than as
    /// the program commanded since the last call (a jog, homing, a probe
    /// run outside the program); asked before each line.
    fn moved_to(&mut self) -> Option<[f64; 3]> {
        None
    }

    /// Run a probing move once everything emitted before it has run: where
    /// the probe input changed, machine coordinates, mm, or `None` if the
    /// tool reached the target without a change. An error stops the
    /// program (the machine's alarm).
    fn probe(&mut self, p: &ProbeMove) -> Result<Option<[f64; 3]>> {
        bail!(
            "line {}: G38.{} probing {NEEDS_MACHINE} (where the probe trips)",
            p.line,
            p.kind.minor()
        )
    }
}

/// The output of a program read ahead of time, as the vectors of a
/// [`crate::toolpath::Toolpath`]; nothing that needs a machine.
#[derive(Debug, Default)]
pub struct Collect {
    /// Points, mm, the start first.
    pub points: Vec<[f64; 3]>,
    /// Feed caps, mm/min.
    pub caps: Vec<Option<f64>>,
    /// Source lines.
    pub lines: Vec<u32>,
    /// Machine commands: after which point, source line, what.
    pub events: Vec<(usize, u32, MachineEvent)>,
    /// Warnings: source line, text.
    pub warnings: Vec<(u32, String)>,
}

impl Machine for Collect {
    fn emit(&mut self, item: Item) -> Result<()> {
        match item {
            Item::Point { pos_mm, cap, line } => {
                self.points.push(pos_mm);
                self.caps.push(cap);
                self.lines.push(line);
            }
            Item::Event { line, event } => {
                let at = self.points.len().saturating_sub(1);
                self.events.push((at, line, event));
            }
            Item::Warning { line, text } => self.warnings.push((line, text)),
        }
        Ok(())
    }
}
