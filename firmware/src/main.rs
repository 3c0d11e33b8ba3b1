//! The motion controller: an RTIC 1.x application. This file only wires
//! the chip to the `controller` crate, where the logic lives (and is
//! tested on the host).
//!
//! | task | runs on | priority | does |
//! |---|---|---|---|
//! | `step` | TIM2 compare 1 (board only) | 4 (highest) | the batch of step/dir edges due now to the pins, then the next batch from the step engine and the compare set to its time; a stop the tick asked for first ([`fuzzy_firmware::step_output`]) |
//! | `tick` | SysTick (default 1 kHz) | 3 | inputs, alarms and stops ([`controller::guard`]), next setpoint from the ring to the step output: the tick's step plan queued to the engine ([`controller::tick`]; under QEMU the engine itself run over the tick's window), driver enable |
//! | `link_rx` | USART1 receive | 2 | bytes → frames → the link session ([`controller::session`]) |
//! | `usb` | OTG FS (feature `usb`) | 2 | the USB stack; its received bytes to `link_rx` (`fuzzy_firmware::usb`) |
//! | `idle` | background | 0 | watchdog, transmit, then one background pass ([`controller::background`]) |
//!
//! Queues (`controller::ring`, lock-free): commands link → idle (their free
//! room is the host's credit), setpoints idle → tick, step plans tick →
//! step (`controller::steps::PlanQueue`, atomics; the engine's figures and
//! stops through `controller::steps::StepShared`). The link's shared
//! state (`DeviceLink`: session, transmit buffer, controls, settings,
//! figures) is one resource of `link_rx` and `idle`; the alarm state
//! (`controller::alarm::Latch`, atomics) is shared by all three without a
//! lock. The settings are read from flash at start-up
//! (`controller::store`); a reset by the watchdog starts in the alarm
//! state.
#![no_std]
#![no_main]

use fuzzy_firmware as _;

#[rtic::app(device = stm32f4::stm32f405, peripherals = true)]
mod app {
    use core::mem::MaybeUninit;

    use controller::alarm::Latch;
    use controller::background::{Background, MachineIo, Notice};
    use controller::command::Cmd;
    use controller::config::{Config, Key};
    use controller::guard::Guard;
    use controller::planning::Setpoint;
    use controller::ring::{Consumer, Producer, Ring};
    use controller::session::DeviceLink;
    use controller::settings::{Plan, CMD_QUEUE, SETPOINT_RING};
    use controller::spindle::MachineOutputs;
    use controller::steps::{PlanQueue, StepShared};
    use controller::store::{self, Store};
    use controller::tick::TickExecutor;
    use fuzzy_core::units::Point3Mm;
    use fuzzy_firmware::board::{self, Enable, Inputs, Outputs, SettingsFlash, UsartRx, Watchdog};
    use fuzzy_firmware::measure::{self, StackProbe};
    #[allow(unused_imports)] // (RTIC names the types of cfg'd resources)
    use fuzzy_firmware::step_output::{self, StepIsr, Steps};
    use fuzzy_firmware::LinkPort;
    use link::{AlarmCode, DeviceMsg, FrameReader, HostMsg, StoreResult};

    /// The spindle, coolant and settings store, as the background drives
    /// them.
    pub struct Machine {
        outputs: Outputs,
        flash: SettingsFlash,
        store: Store,
        watchdog: Watchdog,
    }

    impl MachineIo for Machine {
        fn outputs(&mut self, o: MachineOutputs) {
            self.outputs.set(o);
        }

        fn save(&mut self, c: &Config) -> StoreResult {
            // An erase stalls the core for up to 2 s: the watchdog waits.
            self.watchdog.long(true);
            let r = self.store.save(&mut self.flash, c);
            self.watchdog.long(false);
            r
        }
    }

    #[shared]
    struct Shared {
        link: DeviceLink,
        exec: TickExecutor,
        port: LinkPort,
    }

    #[local]
    struct Local {
        sp_rx: Consumer<'static, Setpoint, SETPOINT_RING>,
        steps: Steps,
        #[cfg(not(feature = "qemu"))]
        step_isr: StepIsr,
        guard: Guard,
        inputs: Inputs,
        enable: Enable,
        latch: &'static Latch,
        rx: UsartRx,
        reader: FrameReader,
        cmd_tx: Producer<'static, Cmd, CMD_QUEUE>,
        cmd_rx: Consumer<'static, Cmd, CMD_QUEUE>,
        sp_tx: Producer<'static, Setpoint, SETPOINT_RING>,
        background: Background<'static>,
        machine: Machine,
    }

    #[init(local = [
        cmds: Ring<Cmd, CMD_QUEUE> = Ring::new(),
        setpoints: Ring<Setpoint, SETPOINT_RING> = Ring::new(),
        plan: MaybeUninit<Plan> = MaybeUninit::uninit(),
        latch_slot: Latch = Latch::new(),
        plans: PlanQueue = PlanQueue::new(),
        step_shared: StepShared = StepShared::new(),
    ])]
    fn init(cx: init::Context) -> (Shared, Local, init::Monotonics) {
        let mut core = cx.core;
        let mut b = board::init(cx.device);
        let latch: &'static Latch = cx.local.latch_slot;
        let (config, stored, store) = store::load(&b.flash);
        // A fault before this boot names the alarm (the watchdog reset
        // that followed it is its consequence).
        if let Some(code) = fuzzy_firmware::take_fault() {
            latch.trip(code);
        }
        if b.watchdog_reset {
            latch.trip(AlarmCode::Watchdog);
        }
        let (cmd_tx, cmd_rx) = cx.local.cmds.split();
        let (mut sp_tx, sp_rx) = cx.local.setpoints.split();
        let Some(plan) = new_plan(cx.local.plan, &config) else {
            defmt::error!("bad planner settings");
            fuzzy_firmware::fail()
        };
        let mut background = match Background::new(plan, Point3Mm::ORIGIN, latch, config) {
            Ok(bg) => bg,
            Err(e) => {
                defmt::error!("cannot start: {}", e);
                fuzzy_firmware::fail()
            }
        };
        // Setpoints ready before the first tick.
        background.fill(&mut sp_tx);
        let mut link = DeviceLink::new(latch, config, stored);
        let hello = link.hello(background.planning().motion());
        link.tx.send(&hello, 0);
        link.tx.send(&DeviceMsg::Stored(stored), 0);
        b.outputs
            .start_pwm(config.get(Key::SpindlePwmHz).clamp(1, 100_000) as u32);
        b.watchdog.start();
        measure::set_tick_period_us(config.tick_us());
        let (pins, timer) = (b.step_pins, b.step_timer);
        // Right before SysTick starts (the engine's windows follow it).
        #[allow(unused_variables)]
        let (steps, step_isr) =
            match step_output::start(&config, cx.local.plans, cx.local.step_shared, pins, timer) {
                Ok(s) => s,
                Err(e) => {
                    defmt::error!("bad step settings: {}", e);
                    fuzzy_firmware::fail()
                }
            };
        measure::start_tick_timer(&mut core.SYST, config.tick_hz());
        defmt::info!(
            "fuzzy feed controller on {=str}: {}; settings {}; crystal {=bool}",
            fuzzy_firmware::boards::MAP.name,
            hello,
            stored,
            b.crystal
        );
        (
            Shared {
                link,
                exec: TickExecutor::new(Point3Mm::ORIGIN),
                port: link_port(b.tx),
            },
            Local {
                sp_rx,
                steps,
                #[cfg(not(feature = "qemu"))]
                step_isr,
                guard: Guard::new(),
                inputs: b.inputs,
                enable: b.enable,
                latch,
                rx: b.rx,
                reader: FrameReader::new(),
                cmd_tx,
                cmd_rx,
                sp_tx,
                background,
                machine: Machine {
                    outputs: b.outputs,
                    flash: b.flash,
                    store,
                    watchdog: b.watchdog,
                },
            },
            init::Monotonics(),
        )
    }

    #[cfg(not(feature = "usb"))]
    fn link_port(tx: board::UsartTx) -> LinkPort {
        tx
    }

    #[cfg(feature = "usb")]
    fn link_port(_: board::UsartTx) -> LinkPort {
        match fuzzy_firmware::usb::UsbPort::take() {
            Some(p) => p,
            None => {
                defmt::error!("USB set-up failed");
                fuzzy_firmware::fail()
            }
        }
    }

    /// The next byte from the host.
    #[cfg(not(feature = "usb"))]
    fn next_byte(rx: &mut UsartRx, _: &mut impl rtic::Mutex<T = LinkPort>) -> Option<u8> {
        rx.read()
    }

    /// The next byte from the host.
    #[cfg(feature = "usb")]
    fn next_byte(_: &mut UsartRx, port: &mut impl rtic::Mutex<T = LinkPort>) -> Option<u8> {
        port.lock(|p| p.read())
    }

    /// The planner, built in its static slot (6.5 KB: one temporary on
    /// init's stack, not two).
    fn new_plan(slot: &'static mut MaybeUninit<Plan>, c: &Config) -> Option<&'static mut Plan> {
        Some(slot.write(Plan::new(c.motion_config()).ok()?))
    }

    /// The step timer's compare match (or a stop's kick).
    #[cfg(not(feature = "qemu"))]
    #[task(binds = TIM2, priority = 4, local = [step_isr])]
    fn step(cx: step::Context) {
        cx.local.step_isr.on_interrupt();
    }

    /// Inputs and stops, then the next setpoint to the step output, every
    /// timer period.
    #[task(binds = SysTick, priority = 3, local = [sp_rx, steps, guard, inputs, enable, latch], shared = [exec])]
    fn tick(mut cx: tick::Context) {
        let t0 = measure::cycles_in_period();
        let local = cx.local;
        let latch: &Latch = local.latch;
        let raw = local.inputs.read();
        // The step timer alone is above it: no actual lock.
        cx.shared.exec.lock(|e| {
            let on = local.guard.tick(raw, latch, e, local.sp_rx, local.steps);
            local.enable.set(on, latch.guard_config().enable_invert);
            local.guard.check_lag(latch, &e.steps);
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
        while let Some(byte) = next_byte(local.rx, &mut sh.port) {
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

    /// The USB stack (feature `usb`): enumeration and transfers, then the
    /// received bytes to `link_rx` (pended: the same path as the USART's).
    #[cfg(feature = "usb")]
    #[task(binds = OTG_FS, priority = 2, shared = [port])]
    fn usb(mut cx: usb::Context) {
        cx.shared.port.lock(|p| p.poll());
        rtic::pend(stm32f4::stm32f405::Interrupt::USART1);
    }

    /// Background: watchdog, transmit, one pass, sleep when there is
    /// nothing to do (a tick frees a ring slot, a byte brings a command).
    #[idle(local = [cmd_rx, sp_tx, background, machine, probe: StackProbe = StackProbe::new()], shared = [link, port])]
    fn idle(cx: idle::Context) -> ! {
        let (local, mut sh) = (cx.local, cx.shared);
        loop {
            local.machine.watchdog.feed();
            let pending = (&mut sh.link, &mut sh.port).lock(|l, p| l.tx.drain(|b| p.try_write(b)));
            let stack = local.probe.step(256);
            let busy = local.background.step(
                &mut sh.link,
                local.cmd_rx,
                local.sp_tx,
                local.machine,
                measure::uptime_us(),
                stack,
                log,
            );
            if !busy && pending == 0 && !local.cmd_rx.ready() && !local.sp_tx.ready() {
                rtic::export::wfi();
            }
        }
    }

    fn log(n: Notice) {
        match n {
            Notice::PathScheduled => defmt::info!("path scheduled"),
            Notice::Alarm(code) => defmt::warn!("alarm: {}", code),
            other => defmt::error!("{}", other),
        }
    }
}
