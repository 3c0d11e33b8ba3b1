//! The motion controller: an RTIC 1.x application. This file only wires
//! the chip to the `controller` crate, where the logic lives (and is
//! tested on the host).
//!
//! | task | runs on | priority | does |
//! |---|---|---|---|
//! | `tick` | SysTick (default 1 kHz) | 3 (highest) | next setpoint from the ring to the step/dir outputs ([`controller::tick`]) |
//! | `link_rx` | USART1 receive | 2 | bytes → frames → the link session ([`controller::session`]) |
//! | `idle` | background | 0 | transmit, then one background pass ([`controller::background`]) |
//!
//! Queues (`controller::ring`, lock-free): commands link → idle (their free
//! room is the host's credit), setpoints idle → tick. The link's shared
//! state (`DeviceLink`: session, transmit buffer, controls, figures) is one
//! resource of `link_rx` and `idle`.
#![no_std]
#![no_main]

use fuzzy_firmware as _;

#[rtic::app(device = stm32f4::stm32f405, peripherals = true)]
mod app {
    use core::mem::MaybeUninit;

    use controller::background::{Background, Notice};
    use controller::command::Cmd;
    use controller::planning::Setpoint;
    use controller::ring::{Consumer, Producer, Ring};
    use controller::session::DeviceLink;
    use controller::settings::{
        Plan, CMD_QUEUE, MOTION_CONFIG, SETPOINT_RING, STEPS_PER_MM, TICK_HZ,
    };
    use controller::stepper::Axes;
    use controller::tick::TickExecutor;
    use fuzzy_core::units::Point3Mm;
    use fuzzy_firmware::board::{self, Pin, UsartRx, UsartTx};
    use fuzzy_firmware::measure::{self, StackProbe};
    use link::{FrameReader, HostMsg};

    #[shared]
    struct Shared {
        link: DeviceLink,
        exec: TickExecutor,
        port: UsartTx,
    }

    #[local]
    struct Local {
        sp_rx: Consumer<'static, Setpoint, SETPOINT_RING>,
        axes: Axes<Pin, Pin>,
        rx: UsartRx,
        reader: FrameReader,
        cmd_tx: Producer<'static, Cmd, CMD_QUEUE>,
        cmd_rx: Consumer<'static, Cmd, CMD_QUEUE>,
        sp_tx: Producer<'static, Setpoint, SETPOINT_RING>,
        background: Background<'static>,
    }

    #[init(local = [
        cmds: Ring<Cmd, CMD_QUEUE> = Ring::new(),
        setpoints: Ring<Setpoint, SETPOINT_RING> = Ring::new(),
        plan: MaybeUninit<Plan> = MaybeUninit::uninit(),
    ])]
    fn init(cx: init::Context) -> (Shared, Local, init::Monotonics) {
        let mut core = cx.core;
        let b = board::init(cx.device);
        let (cmd_tx, cmd_rx) = cx.local.cmds.split();
        let (mut sp_tx, sp_rx) = cx.local.setpoints.split();
        let Some(plan) = new_plan(cx.local.plan) else {
            defmt::error!("bad planner settings");
            fuzzy_firmware::fail()
        };
        let mut background = match Background::new(plan, Point3Mm::ORIGIN) {
            Ok(bg) => bg,
            Err(e) => {
                defmt::error!("cannot start: {}", e);
                fuzzy_firmware::fail()
            }
        };
        // Setpoints ready before the first tick.
        background.fill(&mut sp_tx);
        let mut link = DeviceLink::new();
        let hello = link.hello(background.planning().motion());
        link.tx.send(&hello, 0);
        measure::set_tick_period_us(1_000_000 / TICK_HZ);
        measure::start_tick_timer(&mut core.SYST, TICK_HZ);
        defmt::info!("fuzzy feed controller: {}", hello);
        (
            Shared {
                link,
                exec: TickExecutor::new(Point3Mm::ORIGIN),
                port: b.tx,
            },
            Local {
                sp_rx,
                axes: Axes::new(b.axes, STEPS_PER_MM, Point3Mm::ORIGIN),
                rx: b.rx,
                reader: FrameReader::new(),
                cmd_tx,
                cmd_rx,
                sp_tx,
                background,
            },
            init::Monotonics(),
        )
    }

    /// The planner, built in its static slot (6.5 KB: one temporary on
    /// init's stack, not two).
    fn new_plan(slot: &'static mut MaybeUninit<Plan>) -> Option<&'static mut Plan> {
        Some(slot.write(Plan::new(MOTION_CONFIG).ok()?))
    }

    /// The next setpoint to the outputs, every timer period.
    #[task(binds = SysTick, priority = 3, local = [sp_rx, axes], shared = [exec])]
    fn tick(mut cx: tick::Context) {
        let t0 = measure::cycles_in_period();
        let local = cx.local;
        // The highest priority: no actual lock.
        cx.shared.exec.lock(|e| {
            e.tick(local.sp_rx, local.axes);
            // From entry to here (the wake-up latency is not the tick's
            // cost, and under QEMU's -icount it depends on host timing).
            e.worst_cycles = e.worst_cycles.max(measure::cycles_in_period_since(t0));
        });
        measure::count_tick();
    }

    /// Every received byte; frames to the session as they complete, each
    /// reply started on the wire at once (so that replies go out even while
    /// a flood of bytes keeps the background from running).
    #[task(binds = USART1, priority = 2, local = [rx, reader, cmd_tx], shared = [link, exec, port])]
    fn link_rx(cx: link_rx::Context) {
        let (local, mut sh) = (cx.local, cx.shared);
        while let Some(byte) = local.rx.read() {
            let Some(frame) = local.reader.push::<HostMsg>(byte) else {
                continue;
            };
            let exec = &mut sh.exec;
            let now = measure::uptime_us();
            let refused = sh
                .link
                .lock(|l| l.on_frame(frame, local.cmd_tx, now, || exec.lock(|e| *e)));
            if let Some(code) = refused {
                defmt::warn!("frame refused: {}", code);
            }
            (&mut sh.link, &mut sh.port).lock(|l, p| l.tx.drain(|b| p.try_write(b)));
        }
    }

    /// Background: transmit, one pass, sleep when there is nothing to do
    /// (a tick frees a ring slot, a byte brings a command).
    #[idle(local = [cmd_rx, sp_tx, background, probe: StackProbe = StackProbe::new()], shared = [link, port])]
    fn idle(cx: idle::Context) -> ! {
        let (local, mut sh) = (cx.local, cx.shared);
        loop {
            let pending = (&mut sh.link, &mut sh.port).lock(|l, p| l.tx.drain(|b| p.try_write(b)));
            let stack = local.probe.step(256);
            let busy = local
                .background
                .step(&mut sh.link, local.cmd_rx, local.sp_tx, stack, log);
            if !busy && pending == 0 && !local.cmd_rx.ready() && !local.sp_tx.ready() {
                rtic::export::wfi();
            }
        }
    }

    fn log(n: Notice) {
        match n {
            Notice::PathScheduled => defmt::info!("path scheduled"),
            other => defmt::error!("{}", other),
        }
    }
}
