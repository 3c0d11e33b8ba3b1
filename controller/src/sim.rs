//! The whole controller on the host (feature `std`): the firmware's tasks
//! as methods of one value, bytes in and out, ticks when the caller says.
//! The same code as the firmware's (`firmware/src/main.rs` wires these
//! calls to the chip); only the scheduling of the tasks is the caller's.
//!
//! [`VirtualDevice::run_tick`] does what a firmware tick period does: the
//! background until it has nothing left to do (on the target it runs many
//! passes per tick), then the tick itself: the inputs sampled (a simulated
//! e-stop, limit switches at positions of the simulated axes, in steps, and
//! a probe touching a [`ProbeSurface`]), [`Guard::tick`] and the executor. The axes are the firmware's
//! step generator run by the tick ([`SoftSteps`], as under QEMU) with the
//! settings' steps/mm and step timing: homing moves, stops and switches
//! go through the same step engine as on a board.

use link::{FrameReader, HostMsg, StoreResult};

use fuzzy_core::units::Point3Mm;

use crate::alarm::{Latch, ESTOP};
use crate::background::{Background, MachineIo, Notice, StartError};
use crate::command::Cmd;
use crate::config::Config;
use crate::guard::{switch_input, Guard};
use crate::planning::Setpoint;
use crate::probe::PROBE;
use crate::ring::{Consumer, Producer, Ring};
use crate::session::DeviceLink;
use crate::settings::{Plan, CMD_QUEUE, SETPOINT_RING};
use crate::spindle::MachineOutputs;
use crate::stepper::{first_window, SoftSteps, StepOutput, StepPins, StepQueue};
use crate::steps::{Edges, PlanQueue, Planner, StepEngine, StepReport, StepSettings, StepShared};
use crate::store::{self, MemFlash, Store};
use crate::tick::TickExecutor;

/// Step pins that count each axis's steps (rising step edges, signed by
/// the direction pin, polarity applied).
#[derive(Clone, Copy, Debug, Default)]
pub struct CountPins {
    invert_step: u8,
    invert_dir: u8,
    level: u8,
    /// Steps per axis the pins showed.
    pub steps: [i64; 3],
}

impl StepPins for CountPins {
    fn write(&mut self, e: Edges) {
        let before = self.level;
        self.level = (self.level | e.set) & !e.clear;
        for (i, n) in self.steps.iter_mut().enumerate() {
            let on = |l: u8| (l ^ self.invert_step) & 1 << i != 0;
            if on(self.level) && !on(before) {
                // DIR high is forward, unless inverted (`$3`).
                let forward = (self.level ^ self.invert_dir << 3) & 8 << i != 0;
                *n += if forward { 1 } else { -1 };
            }
        }
    }

    fn set_polarity(&mut self, invert_step: u8, invert_dir: u8) {
        self.invert_step = invert_step;
        self.invert_dir = invert_dir;
    }
}

/// The simulated axes: the positions the tick sent (the step output's
/// coordinates) and the step generator that moves them.
pub struct Recorded {
    /// The commanded positions, in order: every one, or with
    /// [`VirtualDevice::keep_last`] the newest ones (`dropped` before
    /// them).
    pub positions: Vec<Point3Mm>,
    /// Positions sent before `positions[0]` and no longer kept.
    pub dropped: usize,
    /// Keep at least this many of the newest positions, at most twice as
    /// many (`None`: all).
    keep: Option<usize>,
    steps: SoftSteps<'static, CountPins>,
}

impl Recorded {
    /// The step generator with `config`'s step settings, at the origin
    /// (its queue and figures leaked: a few hundred bytes).
    fn new(config: &Config) -> Result<Self, StartError> {
        let s = config.step_settings().map_err(StartError::StepSettings)?;
        let timing = s.timing;
        let plans: &'static mut PlanQueue = Box::leak(Box::default());
        let shared: &'static StepShared = Box::leak(Box::default());
        let (tx, rx) = plans.split();
        let planner = Planner::new(s.steps_per_mm, &timing, Point3Mm::ORIGIN);
        let start = planner.position();
        let engine = StepEngine::new(timing, rx, shared, start, first_window(0, timing.window));
        let pins = CountPins {
            invert_step: timing.invert_step,
            invert_dir: timing.invert_dir,
            ..CountPins::default()
        };
        Ok(Recorded {
            positions: Vec::new(),
            dropped: 0,
            keep: None,
            steps: SoftSteps::new(StepQueue::new(planner, tx, shared), engine, pins),
        })
    }

    /// Positions sent so far (kept or not).
    pub fn sent(&self) -> usize {
        self.dropped + self.positions.len()
    }

    /// The last position sent.
    pub fn last(&self) -> Option<Point3Mm> {
        self.positions.last().copied()
    }

    /// Each axis's position in steps: the steps emitted (the engine's
    /// count, checked against the pins').
    pub fn steps(&self) -> [i64; 3] {
        self.steps.engine().position()
    }

    /// The steps the pins showed.
    pub fn pin_steps(&self) -> [i64; 3] {
        self.steps.pins().steps
    }
}

impl StepOutput for Recorded {
    fn update(&mut self, pos: Point3Mm) {
        if let Some(n) = self.keep {
            // Dropped in halves: each position is moved at most once.
            if self.positions.len() >= 2 * n {
                let old = self.positions.len() - n;
                self.positions.drain(..old);
                self.dropped += old;
            }
        }
        self.positions.push(pos);
        self.steps.update(pos);
    }
    fn hold(&mut self) {
        self.steps.hold();
    }
    fn report(&self) -> StepReport {
        self.steps.report()
    }
    fn stop(&mut self, at: Point3Mm) -> Option<Point3Mm> {
        self.steps.stop(at)
    }
    fn reconfigure(&mut self, s: &StepSettings, at: Point3Mm) -> bool {
        self.steps.reconfigure(s, at)
    }
}

/// A limit switch on a simulated axis: closed from `at_steps` on (towards
/// the axis's `max` end, or its minimum end).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SimSwitch {
    /// Axis, 0 X.
    pub axis: usize,
    /// At the axis's maximum end.
    pub max: bool,
    /// Where it closes, steps of the step output.
    pub at_steps: i64,
}

/// What the simulated probe touches: the tool at or below it (machine
/// coordinates) makes the probe input active.
#[derive(Clone, Debug, PartialEq)]
pub struct ProbeSurface {
    /// The plane z = `z_mm` (where there is no map, or outside it).
    pub z_mm: f64,
    /// Heights on a grid over the plane, if any.
    pub map: Option<HeightMap>,
}

/// Heights on a rectangular grid, bilinear between its nodes.
#[derive(Clone, Debug, PartialEq)]
pub struct HeightMap {
    /// The first node's x and y, mm.
    pub origin_mm: [f64; 2],
    /// The spacing of the nodes in x and y, mm (positive).
    pub step_mm: [f64; 2],
    /// Nodes along x.
    pub nx: usize,
    /// The heights, mm, row by row (`nx` a row, rows along y).
    pub z_mm: Vec<f64>,
}

impl HeightMap {
    /// The height at `(x, y)`, bilinear; `None` outside the grid.
    pub fn height(&self, x: f64, y: f64) -> Option<f64> {
        let nx = self.nx;
        let ny = self.z_mm.len().checked_div(nx)?;
        let u = (x - self.origin_mm[0]) / self.step_mm[0];
        let v = (y - self.origin_mm[1]) / self.step_mm[1];
        let (umax, vmax) = ((nx.max(1) - 1) as f64, (ny.max(1) - 1) as f64);
        if !(0.0..=umax).contains(&u) || !(0.0..=vmax).contains(&v) {
            return None;
        }
        let (i, j) = (
            (u as usize).min(nx.saturating_sub(2)),
            (v as usize).min(ny.saturating_sub(2)),
        );
        let (fu, fv) = (u - i as f64, v - j as f64);
        let z = |a: usize, b: usize| self.z_mm.get(b * nx + a).copied().unwrap_or(0.0);
        let (i1, j1) = ((i + 1).min(nx - 1), (j + 1).min(ny - 1));
        let bottom = z(i, j) * (1.0 - fu) + z(i1, j) * fu;
        let top = z(i, j1) * (1.0 - fu) + z(i1, j1) * fu;
        Some(bottom * (1.0 - fv) + top * fv)
    }
}

impl ProbeSurface {
    /// The plane z = `z_mm`.
    pub fn plane(z_mm: f64) -> Self {
        ProbeSurface { z_mm, map: None }
    }

    /// The surface's height at `(x, y)`, mm.
    pub fn height(&self, x: f64, y: f64) -> f64 {
        self.map
            .as_ref()
            .and_then(|m| m.height(x, y))
            .unwrap_or(self.z_mm)
    }

    /// Whether a tool at `pos_mm` touches it (at or below).
    pub fn touches(&self, pos_mm: [f64; 3]) -> bool {
        pos_mm[2] <= self.height(pos_mm[0], pos_mm[1])
    }
}

/// The spindle, coolant and store of the virtual machine.
#[derive(Clone, Debug, Default)]
pub struct SimMachine {
    /// The flash sector of the settings.
    pub flash: MemFlash,
    store: Option<Store>,
    /// Every change of the spindle and coolant outputs, with the number of
    /// positions sent to the axes before it.
    pub outputs: Vec<(usize, MachineOutputs)>,
    /// Positions sent so far (kept by the device).
    sent: usize,
}

impl MachineIo for SimMachine {
    fn outputs(&mut self, o: MachineOutputs) {
        if self.outputs.last().map(|l| l.1) != Some(o) {
            self.outputs.push((self.sent, o));
        }
    }
    fn save(&mut self, c: &Config) -> StoreResult {
        let mut s = match self.store {
            Some(s) => s,
            None => store::load(&self.flash).2,
        };
        let r = s.save(&mut self.flash, c);
        self.store = Some(s);
        r
    }
}

/// Drop the oldest entries of `v` beyond the newest `n`, once it holds
/// twice as many.
fn trim<T>(v: &mut Vec<T>, n: usize) {
    if v.len() >= 2 * n {
        v.drain(..v.len() - n);
    }
}

/// Background passes per tick at most (a pass that does work is followed
/// by another, as the firmware's idle loop does).
const PASSES_PER_TICK: usize = 64;

/// The controller with its queues, on the host.
pub struct VirtualDevice {
    link: DeviceLink,
    exec: TickExecutor,
    guard: Guard,
    latch: &'static Latch,
    reader: FrameReader,
    background: Background<'static>,
    cmd_tx: Producer<'static, Cmd, CMD_QUEUE>,
    cmd_rx: Consumer<'static, Cmd, CMD_QUEUE>,
    sp_tx: Producer<'static, Setpoint, SETPOINT_RING>,
    sp_rx: Consumer<'static, Setpoint, SETPOINT_RING>,
    /// Tick periods since reset (the device's clock).
    periods: u32,
    tick_us: u32,
    /// What the axes were told.
    pub axes: Recorded,
    /// What the background reported.
    pub notices: Vec<Notice>,
    /// The spindle, coolant and settings flash.
    pub machine: SimMachine,
    /// The e-stop input is active.
    pub estop: bool,
    /// Limit switches on the axes.
    pub switches: Vec<SimSwitch>,
    /// What the probe touches (none: the probe input stays inactive).
    pub probe: Option<ProbeSurface>,
    /// The drivers were enabled at the last tick.
    pub drivers_enabled: bool,
    /// Step settings from the background, for the tick.
    step_settings: Option<StepSettings>,
    /// How many notices and output changes to keep ([`Self::keep_last`]).
    keep: Option<usize>,
}

impl VirtualDevice {
    /// Fresh from reset with nothing stored, at the origin, its hello in
    /// the transmit buffer. (Its queues and planner are leaked: a few
    /// tens of KB a device.)
    pub fn new() -> Result<Self, StartError> {
        Self::with_flash(MemFlash::default())
    }

    /// Fresh from reset with the settings stored in `flash` (as the
    /// firmware reads them at start-up).
    pub fn with_flash(flash: MemFlash) -> Result<Self, StartError> {
        let (config, stored, store) = store::load(&flash);
        let cmds: &'static mut Ring<Cmd, CMD_QUEUE> = Box::leak(Box::new(Ring::new()));
        let sps: &'static mut Ring<Setpoint, SETPOINT_RING> = Box::leak(Box::new(Ring::new()));
        let latch: &'static Latch = Box::leak(Box::new(Latch::new()));
        let plan = Plan::new(config.motion_config()).map_err(StartError::PlannerSettings)?;
        let plan: &'static mut Plan = Box::leak(Box::new(plan));
        let (cmd_tx, cmd_rx) = cmds.split();
        let (mut sp_tx, sp_rx) = sps.split();
        let mut background = Background::new(plan, Point3Mm::ORIGIN, latch, config)?;
        background.fill(&mut sp_tx);
        let mut link = DeviceLink::new(latch, config, stored);
        let hello = link.hello(background.planning().motion());
        link.tx.send(&hello, 0);
        link.tx.send(&link::DeviceMsg::Stored(stored), 0);
        Ok(VirtualDevice {
            link,
            exec: TickExecutor::new(Point3Mm::ORIGIN),
            guard: Guard::new(),
            latch,
            reader: FrameReader::new(),
            background,
            cmd_tx,
            cmd_rx,
            sp_tx,
            sp_rx,
            periods: 0,
            tick_us: config.tick_us(),
            axes: Recorded::new(&config)?,
            notices: Vec::new(),
            machine: SimMachine {
                flash,
                store: Some(store),
                ..SimMachine::default()
            },
            estop: false,
            switches: Vec::new(),
            probe: None,
            drivers_enabled: true,
            step_settings: None,
            keep: None,
        })
    }

    /// Keep only about the newest `n` (at least 1) of what the device
    /// records as it runs (the axes' positions, the background's notices,
    /// the changes of the spindle and coolant outputs), for runs of hours
    /// where nobody reads the older ones: otherwise the record grows by a
    /// position every tick.
    pub fn keep_last(&mut self, n: usize) {
        let n = n.max(1);
        self.axes.keep = Some(n);
        self.keep = Some(n);
    }

    /// Bytes from the wire (the receive interrupt), at the time of the
    /// current tick.
    pub fn receive(&mut self, bytes: &[u8]) {
        let now_us = self.now_us();
        for &b in bytes {
            if let Some(frame) = self.reader.push::<HostMsg>(b) {
                let exec = self.exec;
                self.link.on_frame(frame, &mut self.cmd_tx, now_us, || exec);
            }
        }
    }

    /// How long the host has been silent, in the host's own time (µs),
    /// where it runs apart from the device's (a simulation faster than
    /// real time: a host asking for a status every 200 ms of its time
    /// would seem silent for seconds of the device's). The link silence
    /// checks (`$206`, `$209`) then count the host's time.
    pub fn set_host_silence_us(&mut self, silent_us: u32) {
        self.link.last_rx_us = self.now_us().wrapping_sub(silent_us);
    }

    /// The device's clock: tick periods so far × the tick period, µs
    /// (wrapping).
    pub fn now_us(&self) -> u32 {
        self.periods.wrapping_mul(self.tick_us)
    }

    /// One background pass; whether it did work.
    pub fn background_pass(&mut self) -> bool {
        let notices = &mut self.notices;
        let stack = 0;
        let now_us = self.periods.wrapping_mul(self.tick_us);
        self.machine.sent = self.axes.sent();
        let busy = self.background.step(
            &mut rtic_core::Exclusive(&mut self.link),
            &mut self.cmd_rx,
            &mut self.sp_tx,
            &mut self.machine,
            now_us,
            stack,
            |n| notices.push(n),
        );
        if let Some(s) = self.background.take_step_settings() {
            self.step_settings = Some(s);
        }
        busy
    }

    /// Step settings the tick has yet to apply.
    pub fn step_settings_pending(&self) -> bool {
        self.step_settings.is_some()
    }

    /// Each axis's position in steps (the step generator's count).
    pub fn steps(&self) -> [i64; 3] {
        self.axes.steps()
    }

    /// The input word the pins would show now (before the polarity).
    fn inputs(&self) -> u8 {
        let steps = self.steps();
        let mut active = if self.estop { ESTOP } else { 0 };
        for s in &self.switches {
            active |= switch_input(s.axis, s.max, steps[s.axis], s.at_steps);
        }
        if let Some(surface) = &self.probe {
            if surface.touches(self.tool_mm()) {
                active |= PROBE;
            }
        }
        active ^ self.latch.guard_config().invert
    }

    /// Where the tool is, machine coordinates, mm: the steps emitted, with
    /// the offset homing set.
    pub fn tool_mm(&self) -> [f64; 3] {
        let (steps, offset) = (self.steps(), self.latch.offset());
        let config = self.background.config();
        core::array::from_fn(|a| {
            let spm = config.steps_per_mm(a).0 as f64 / 65536.0;
            steps[a] as f64 / spm + offset[a] as f64 / 4294967296.0
        })
    }

    /// The tick interrupt.
    pub fn tick(&mut self) {
        self.periods = self.periods.wrapping_add(1);
        let raw = self.inputs();
        self.drivers_enabled = self.guard.tick(
            raw,
            self.latch,
            &mut self.exec,
            &mut self.sp_rx,
            &mut self.axes,
        );
        self.guard.apply_step_settings(
            &mut self.step_settings,
            self.latch,
            &self.exec,
            &mut self.axes,
        );
    }

    /// A tick period: background passes until idle, then the tick.
    pub fn run_tick(&mut self) {
        for _ in 0..PASSES_PER_TICK {
            if !self.background_pass() {
                break;
            }
        }
        self.tick();
        if let Some(n) = self.keep {
            trim(&mut self.notices, n);
            trim(&mut self.machine.outputs, n);
        }
    }

    /// Everything waiting in the transmit buffer (the wire takes it all).
    pub fn transmit(&mut self) -> Vec<u8> {
        let mut out = Vec::new();
        self.link.tx.drain(|b| {
            out.push(b);
            true
        });
        out
    }

    /// The tick's state.
    pub fn exec(&self) -> &TickExecutor {
        &self.exec
    }

    /// The tick's safety state.
    pub fn guard(&self) -> &Guard {
        &self.guard
    }

    /// The alarm state shared by the tasks.
    pub fn latch(&self) -> &Latch {
        self.latch
    }

    /// The shared link state (session, figures).
    pub fn link(&self) -> &DeviceLink {
        &self.link
    }

    /// The background (its planning stage).
    pub fn background(&self) -> &Background<'static> {
        &self.background
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bounded_record_keeps_the_newest_positions_and_counts_all() {
        let mut dev = VirtualDevice::new().unwrap();
        dev.keep_last(4);
        let at = |k: i32| Point3Mm::from_f64(f64::from(k) * 1e-3, 0.0, 0.0).unwrap();
        for k in 0..1000 {
            dev.axes.update(at(k));
            assert!(dev.axes.positions.len() <= 8);
        }
        assert_eq!(dev.axes.sent(), 1000);
        assert_eq!(dev.axes.last(), Some(at(999)));
        let kept = dev.axes.positions.len();
        assert!(kept >= 4);
        assert_eq!(dev.axes.positions[kept - 4..], [996, 997, 998, 999].map(at));
        assert_eq!(dev.axes.dropped + kept, 1000);
    }
}
