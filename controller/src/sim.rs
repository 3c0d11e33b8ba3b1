//! The whole controller on the host (feature `std`): the firmware's tasks
//! as methods of one value, bytes in and out, ticks when the caller says.
//! The same code as the firmware's (`firmware/src/main.rs` wires these
//! calls to the chip); only the scheduling of the tasks is the caller's.
//!
//! [`VirtualDevice::run_tick`] does what a firmware tick period does: the
//! background until it has nothing left to do (on the target it runs many
//! passes per tick), then the tick itself.

use link::{FrameReader, HostMsg};

use fuzzy_core::units::Point3Mm;

use crate::background::{Background, Notice, StartError};
use crate::command::Cmd;
use crate::planning::Setpoint;
use crate::ring::{Consumer, Producer, Ring};
use crate::session::DeviceLink;
use crate::settings::{Plan, CMD_QUEUE, MOTION_CONFIG, SETPOINT_RING};
use crate::stepper::StepOutput;
use crate::tick::TickExecutor;

/// Positions the tick sent to the axes.
#[derive(Clone, Debug, Default)]
pub struct Recorded {
    /// Every commanded position, in order.
    pub positions: Vec<Point3Mm>,
}

impl StepOutput for Recorded {
    fn update(&mut self, pos: Point3Mm) {
        self.positions.push(pos);
    }
}

/// Background passes per tick at most (a pass that does work is followed
/// by another, as the firmware's idle loop does).
const PASSES_PER_TICK: usize = 64;

/// The controller with its queues, on the host.
pub struct VirtualDevice {
    link: DeviceLink,
    exec: TickExecutor,
    reader: FrameReader,
    background: Background<'static>,
    cmd_tx: Producer<'static, Cmd, CMD_QUEUE>,
    cmd_rx: Consumer<'static, Cmd, CMD_QUEUE>,
    sp_tx: Producer<'static, Setpoint, SETPOINT_RING>,
    sp_rx: Consumer<'static, Setpoint, SETPOINT_RING>,
    /// What the axes were told.
    pub axes: Recorded,
    /// What the background reported.
    pub notices: Vec<Notice>,
}

impl VirtualDevice {
    /// Fresh from reset, at the origin, its hello in the transmit buffer.
    /// (Its queues and planner are leaked: a few tens of KB a device.)
    pub fn new() -> Result<Self, StartError> {
        let cmds: &'static mut Ring<Cmd, CMD_QUEUE> = Box::leak(Box::new(Ring::new()));
        let sps: &'static mut Ring<Setpoint, SETPOINT_RING> = Box::leak(Box::new(Ring::new()));
        let plan = Plan::new(MOTION_CONFIG).map_err(StartError::PlannerSettings)?;
        let plan: &'static mut Plan = Box::leak(Box::new(plan));
        let (cmd_tx, cmd_rx) = cmds.split();
        let (mut sp_tx, sp_rx) = sps.split();
        let mut background = Background::new(plan, Point3Mm::ORIGIN)?;
        background.fill(&mut sp_tx);
        let mut link = DeviceLink::new();
        let hello = link.hello(background.planning().motion());
        link.tx.send(&hello, 0);
        Ok(VirtualDevice {
            link,
            exec: TickExecutor::new(Point3Mm::ORIGIN),
            reader: FrameReader::new(),
            background,
            cmd_tx,
            cmd_rx,
            sp_tx,
            sp_rx,
            axes: Recorded::default(),
            notices: Vec::new(),
        })
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

    /// The device's clock: ticks so far × the tick period, µs (wrapping).
    pub fn now_us(&self) -> u32 {
        self.exec.ticks.wrapping_mul(MOTION_CONFIG.tick_us)
    }

    /// One background pass; whether it did work.
    pub fn background_pass(&mut self) -> bool {
        let notices = &mut self.notices;
        let stack = 0;
        self.background.step(
            &mut rtic_core::Exclusive(&mut self.link),
            &mut self.cmd_rx,
            &mut self.sp_tx,
            stack,
            |n| notices.push(n),
        )
    }

    /// The tick interrupt.
    pub fn tick(&mut self) {
        self.exec.tick(&mut self.sp_rx, &mut self.axes);
    }

    /// A tick period: background passes until idle, then the tick.
    pub fn run_tick(&mut self) {
        for _ in 0..PASSES_PER_TICK {
            if !self.background_pass() {
                break;
            }
        }
        self.tick();
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

    /// The shared link state (session, figures).
    pub fn link(&self) -> &DeviceLink {
        &self.link
    }

    /// The background (its planning stage).
    pub fn background(&self) -> &Background<'static> {
        &self.background
    }
}
