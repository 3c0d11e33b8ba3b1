//! Start-up: the chip set up, the settings read from flash, the alarm a
//! fault or a watchdog reset left, the queues split, the planner built in
//! its slot, the background, the link's hello, the step output and the
//! tick timer started; every task's state handed back ([`App`]) for the
//! RTIC resources.

use core::mem::MaybeUninit;

use controller::alarm::Latch;
use controller::background::Background;
use controller::command::Cmd;
use controller::config::Key;
use controller::planning::Setpoint;
use controller::ring::Ring;
use controller::session::DeviceLink;
use controller::settings::{self, Plan, CMD_QUEUE, SETPOINT_RING};
use controller::steps::{PlanQueue, StepShared};
use controller::store;
use controller::tick::TickExecutor;
use fuzzy_core::units::Point3Mm;
use link::{AlarmCode, DeviceMsg};

use crate::idle::Idle;
use crate::link_port::{self, LinkPort, LinkRx};
use crate::machine::Machine;
use crate::step_output::{self, StepIsr};
use crate::tick::Tick;
use crate::{board, fail, measure};

/// The static storage the application lives in (RTIC's `init` locals).
pub struct Slots {
    /// The command queue, link → background.
    pub cmds: &'static mut Ring<Cmd, CMD_QUEUE>,
    /// The setpoint ring, background → tick.
    pub setpoints: &'static mut Ring<Setpoint, SETPOINT_RING>,
    /// The planner.
    pub plan: &'static mut MaybeUninit<Plan>,
    /// The alarm state.
    pub latch: &'static Latch,
    /// The step plan queue, tick → step engine.
    pub plans: &'static mut PlanQueue,
    /// The step engine's figures and stops.
    pub step_shared: &'static StepShared,
}

/// Every task's state, started.
pub struct App {
    /// The link's shared state (receive interrupt and background).
    pub link: DeviceLink,
    /// The tick's state (tick, and status replies).
    pub exec: TickExecutor,
    /// Where replies go.
    pub port: LinkPort,
    /// The tick's own.
    pub tick: Tick,
    /// The step timer's interrupt (nothing under QEMU; the tick's too, to
    /// apply new step settings).
    pub step_isr: StepIsr,
    /// The receive interrupt's own.
    pub link_rx: LinkRx,
    /// The background's own.
    pub idle: Idle,
}

/// Start everything (module docs); SysTick is started last. A bad setting
/// or a failed start stops here (logged).
pub fn start(
    device: stm32f4::stm32f405::Peripherals,
    syst: &mut cortex_m::peripheral::SYST,
    slots: Slots,
) -> App {
    let mut b = board::init(device);
    let latch = slots.latch;
    let (config, stored, store) = store::load(&b.flash);
    // A fault before this boot names the alarm (the watchdog reset
    // that followed it is its consequence).
    if let Some(code) = crate::take_fault() {
        latch.trip(code);
    }
    if b.watchdog_reset {
        latch.trip(AlarmCode::Watchdog);
    }
    let (cmd_tx, cmd_rx) = slots.cmds.split();
    let (mut sp_tx, sp_rx) = slots.setpoints.split();
    let Ok(plan) = settings::plan_in(slots.plan, config.motion_config()) else {
        defmt::error!("bad planner settings");
        fail()
    };
    let mut background = match Background::new(plan, Point3Mm::ORIGIN, latch, config) {
        Ok(bg) => bg,
        Err(e) => {
            defmt::error!("cannot start: {}", e);
            fail()
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
    // Right before SysTick starts (the engine's windows follow it).
    let started = step_output::start(
        &config,
        slots.plans,
        slots.step_shared,
        b.step_pins,
        b.step_timer,
    );
    let (steps, step_isr) = match started {
        Ok(s) => s,
        Err(e) => {
            defmt::error!("bad step settings: {}", e);
            fail()
        }
    };
    measure::start_tick_timer(syst, config.tick_hz());
    defmt::info!(
        "fuzzy feed controller on {=str}: {}; settings {}; crystal {=bool}",
        crate::boards::MAP.name,
        hello,
        stored,
        b.crystal
    );
    App {
        link,
        exec: TickExecutor::new(Point3Mm::ORIGIN),
        port: link_port::open(b.tx),
        tick: Tick::new(sp_rx, steps, b.inputs, b.enable, latch),
        step_isr,
        link_rx: LinkRx::new(b.rx, cmd_tx),
        idle: Idle::new(
            cmd_rx,
            sp_tx,
            background,
            Machine::new(b.outputs, b.flash, store, b.watchdog, latch),
        ),
    }
}
