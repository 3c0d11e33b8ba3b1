//! The motion controller: an RTIC 1.x application. This file only wires
//! the chip to the `controller` crate, where the logic lives (and is
//! tested on the host).
//!
//! | task | runs on | priority | does |
//! |---|---|---|---|
//! | `step` | TIM2 compare 1 (board only) | 4 (highest) | the batch of step/dir edges due now to the pins, then the next batch from the step engine and the compare set to its time ([`controller::steps::engine`]) |
//! | `tick` | SysTick (default 1 kHz) | 3 | next setpoint from the ring to the step output: the tick's step plan queued to the engine ([`controller::tick`], [`controller::stepper::StepQueue`]); under QEMU the engine itself run over the tick's window ([`controller::stepper::SoftSteps`]) |
//! | `link_rx` | USART1 receive | 2 | bytes → frames → the link session ([`controller::session`]) |
//! | `idle` | background | 0 | transmit, then one background pass ([`controller::background`]) |
//!
//! Queues (`controller::ring`, lock-free): commands link → idle (their free
//! room is the host's credit), setpoints idle → tick; step plans tick →
//! step go through `controller::steps::PlanQueue` (atomics, no critical
//! section), and the engine's figures come back through atomics
//! (`controller::steps::StepShared`). The link's shared
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
        Plan, CMD_QUEUE, MOTION_CONFIG, SETPOINT_RING, STEP_CONFIG, STEP_TIMER_HZ, TICK_HZ,
    };
    #[cfg(not(feature = "qemu"))]
    use controller::stepper::StepPins;
    use controller::stepper::{first_window, StepQueue};
    use controller::steps::{PlanQueue, Planner, StepEngine, StepShared};
    // (Imported in both builds: RTIC names the types of cfg'd resources.)
    #[allow(unused_imports)]
    use controller::steps::Due;
    use controller::tick::TickExecutor;
    use fuzzy_core::units::Point3Mm;
    use fuzzy_firmware::board::{self, UsartRx, UsartTx};
    #[allow(unused_imports)]
    use fuzzy_firmware::board::{StepGpio, StepTimer};
    use fuzzy_firmware::measure::{self, StackProbe};
    use link::{FrameReader, HostMsg};

    #[shared]
    struct Shared {
        link: DeviceLink,
        exec: TickExecutor,
        port: UsartTx,
    }

    /// The tick's step output: plans to the step timer's engine on a
    /// board, the engine run by the tick itself under QEMU.
    #[cfg(not(feature = "qemu"))]
    type Steps = StepQueue<'static>;
    #[cfg(feature = "qemu")]
    type Steps = controller::stepper::SoftSteps<'static, board::StepGpio>;

    #[local]
    struct Local {
        sp_rx: Consumer<'static, Setpoint, SETPOINT_RING>,
        steps: Steps,
        #[cfg(not(feature = "qemu"))]
        engine: StepEngine<'static>,
        #[cfg(not(feature = "qemu"))]
        step_timer: StepTimer,
        #[cfg(not(feature = "qemu"))]
        step_pins: StepGpio,
        #[cfg(not(feature = "qemu"))]
        pending: Due,
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
        plans: PlanQueue = PlanQueue::new(),
        step_shared: StepShared = StepShared::new(),
    ])]
    fn init(cx: init::Context) -> (Shared, Local, init::Monotonics) {
        let mut core = cx.core;
        #[allow(unused_mut)] // the pins and timer move out on a board
        let mut b = board::init(cx.device);
        let timing = match STEP_CONFIG.timing(STEP_TIMER_HZ, TICK_HZ) {
            Ok(t) => t,
            Err(e) => {
                defmt::error!("bad step settings: {}", e);
                fuzzy_firmware::fail()
            }
        };
        let (plan_tx, plan_rx) = cx.local.plans.split();
        let shared: &'static StepShared = cx.local.step_shared;
        let planner = Planner::new(
            STEP_CONFIG.axes.map(|a| a.steps_per_mm),
            &timing,
            Point3Mm::ORIGIN,
        );
        let start = planner.position();
        let queue = StepQueue::new(planner, plan_tx, shared);
        // The first tick comes one period after SysTick starts (below);
        // the engine's first window 1.5 ticks after that.
        #[cfg(not(feature = "qemu"))]
        let (steps, engine, pending) = {
            let first = first_window(
                b.step_timer.now().wrapping_add(timing.window),
                timing.window,
            );
            let mut engine = StepEngine::new(timing, plan_rx, shared, start, first);
            b.step_pins.write(engine.idle_edges());
            let pending = engine.due();
            if b.step_timer.arm(pending.at) {
                // Cannot happen (half a tick ahead); the interrupt is then
                // simply late.
                defmt::warn!("step timer armed late");
            }
            (queue, engine, pending)
        };
        #[cfg(feature = "qemu")]
        let steps = {
            let engine = StepEngine::new(
                timing,
                plan_rx,
                shared,
                start,
                first_window(0, timing.window),
            );
            controller::stepper::SoftSteps::new(queue, engine, b.step_pins)
        };
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
                steps,
                #[cfg(not(feature = "qemu"))]
                engine,
                #[cfg(not(feature = "qemu"))]
                step_timer: b.step_timer,
                #[cfg(not(feature = "qemu"))]
                step_pins: b.step_pins,
                #[cfg(not(feature = "qemu"))]
                pending,
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

    /// The step edges due now, then the next batch: pins first, so that
    /// every edge follows its compare match by the same few cycles; the
    /// engine is told the counter read after the write (never earlier
    /// than the edges), which keeps every minimum. A batch already due
    /// when the compare is set is written at once (late by the engine's
    /// own time); a stale interrupt (nothing due yet) only clears the flag.
    #[cfg(not(feature = "qemu"))]
    #[task(binds = TIM2, priority = 4, local = [engine, step_timer, step_pins, pending])]
    fn step(cx: step::Context) {
        let l = cx.local;
        if !l.step_timer.reached(l.pending.at) {
            l.step_timer.clear();
            return;
        }
        l.step_pins.write(l.pending.edges);
        loop {
            l.engine.done(l.step_timer.now());
            *l.pending = l.engine.due();
            if !l.step_timer.arm(l.pending.at) {
                return;
            }
            l.step_pins.write(l.pending.edges);
        }
    }

    /// The next setpoint to the step output, every timer period.
    #[task(binds = SysTick, priority = 3, local = [sp_rx, steps], shared = [exec])]
    fn tick(mut cx: tick::Context) {
        let t0 = measure::cycles_in_period();
        let local = cx.local;
        // The step timer alone is above it: no actual lock.
        cx.shared.exec.lock(|e| {
            e.tick(local.sp_rx, local.steps);
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
