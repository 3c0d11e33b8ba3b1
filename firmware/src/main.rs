//! The motion controller: an RTIC 1.x application. This file only wires
//! the tasks to their work: start-up in [`fuzzy_firmware::start`], each
//! task's body in the module named in the table; the logic is the
//! `controller` crate's (tested on the host).
//!
//! | task | runs on | priority | does |
//! |---|---|---|---|
//! | `step` | TIM2 compare 1 (board only) | 4 (highest) | the batch of step/dir edges due now to the pins, then the next batch from the step engine and the compare set to its time; a stop the tick asked for first ([`fuzzy_firmware::step_output`]) |
//! | `tick` | SysTick (default 1 kHz) | 3 | ([`fuzzy_firmware::tick`]) inputs, alarms and stops ([`controller::guard`]), next setpoint from the ring to the step output: the tick's step plan queued to the engine ([`controller::tick`]; under QEMU the engine itself run over the tick's window), driver enable |
//! | `link_rx` | USART1 receive | 2 | ([`fuzzy_firmware::link_port`]) bytes → frames → the link session ([`controller::session`]) |
//! | `usb` | OTG FS (feature `usb`) | 2 | the USB stack; its received bytes to `link_rx` (`fuzzy_firmware::usb`) |
//! | `idle` | background | 0 | ([`fuzzy_firmware::idle`]) watchdog, transmit, then one background pass ([`controller::background`]) |
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
    use controller::command::Cmd;
    use controller::planning::Setpoint;
    use controller::ring::Ring;
    use controller::session::DeviceLink;
    use controller::settings::{Plan, CMD_QUEUE, SETPOINT_RING};
    use controller::steps::StepSettings;
    use controller::steps::{PlanQueue, StepShared};
    use controller::tick::TickExecutor;
    use fuzzy_firmware::idle::Idle;
    use fuzzy_firmware::link_port::{LinkPort, LinkRx};
    use fuzzy_firmware::start::{self, Slots};
    use fuzzy_firmware::step_output::StepIsr;
    use fuzzy_firmware::tick::Tick;

    #[shared]
    struct Shared {
        link: DeviceLink,
        exec: TickExecutor,
        port: LinkPort,
        step_settings: Option<StepSettings>,
        step_isr: StepIsr,
    }

    #[local]
    struct Local {
        tick: Tick,
        link_rx: LinkRx,
        idle: Idle,
    }

    #[init(local = [
        cmds: Ring<Cmd, CMD_QUEUE> = Ring::new(),
        setpoints: Ring<Setpoint, SETPOINT_RING> = Ring::new(),
        plan: MaybeUninit<Plan> = MaybeUninit::uninit(),
        latch: Latch = Latch::new(),
        plans: PlanQueue = PlanQueue::new(),
        step_shared: StepShared = StepShared::new(),
    ])]
    fn init(cx: init::Context) -> (Shared, Local, init::Monotonics) {
        let mut core = cx.core;
        let l = cx.local;
        let slots = Slots {
            cmds: l.cmds,
            setpoints: l.setpoints,
            plan: l.plan,
            latch: l.latch,
            plans: l.plans,
            step_shared: l.step_shared,
        };
        let app = start::start(cx.device, &mut core.SYST, slots);
        let shared = Shared {
            link: app.link,
            exec: app.exec,
            port: app.port,
            step_settings: None,
            step_isr: app.step_isr,
        };
        let local = Local {
            tick: app.tick,
            link_rx: app.link_rx,
            idle: app.idle,
        };
        (shared, local, init::Monotonics())
    }

    /// The step timer's compare match (or a stop's kick).
    #[cfg(not(feature = "qemu"))]
    #[task(binds = TIM2, priority = 4, shared = [step_isr])]
    fn step(mut cx: step::Context) {
        cx.shared.step_isr.lock(|s| s.on_interrupt());
    }

    /// Inputs and stops, then the next setpoint to the step output, every
    /// timer period.
    #[task(binds = SysTick, priority = 3, local = [tick], shared = [exec, step_settings, step_isr])]
    fn tick(cx: tick::Context) {
        let mut sh = cx.shared;
        cx.local
            .tick
            .run(&mut sh.exec, &mut sh.step_settings, &mut sh.step_isr);
    }

    /// Every received byte: frames to the session, replies to the wire.
    #[task(binds = USART1, priority = 2, local = [link_rx], shared = [link, exec, port])]
    fn link_rx(cx: link_rx::Context) {
        let mut sh = cx.shared;
        cx.local
            .link_rx
            .on_interrupt(&mut sh.link, &mut sh.exec, &mut sh.port);
    }

    /// The USB stack (feature `usb`): enumeration and transfers, then the
    /// received bytes to `link_rx` (pended: the same path as the USART's).
    #[cfg(feature = "usb")]
    #[task(binds = OTG_FS, priority = 2, shared = [port])]
    fn usb(mut cx: usb::Context) {
        cx.shared.port.lock(|p| p.poll());
        rtic::pend(stm32f4::stm32f405::Interrupt::USART1);
    }

    /// Background: watchdog, transmit, one pass, sleep when idle.
    #[idle(local = [idle], shared = [link, port, step_settings])]
    fn idle(cx: idle::Context) -> ! {
        let mut sh = cx.shared;
        cx.local
            .idle
            .run(&mut sh.link, &mut sh.port, &mut sh.step_settings)
    }
}
