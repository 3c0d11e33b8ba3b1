//! The background loop (RTIC's `idle`): the watchdog fed, replies
//! transmitted, one background pass ([`controller::background`]), sleep
//! when there is nothing to do.

use controller::background::Background;
use controller::command::Cmd;
use controller::planning::Setpoint;
use controller::ring::{Consumer, Producer};
use controller::session::DeviceLink;
use controller::settings::{CMD_QUEUE, SETPOINT_RING};
use controller::steps::StepSettings;
use rtic::Mutex;

use crate::link_port::{self, LinkPort};
use crate::machine::{self, Machine};
use crate::measure::{self, StackProbe};

/// What only the background uses.
pub struct Idle {
    cmds: Consumer<'static, Cmd, CMD_QUEUE>,
    setpoints: Producer<'static, Setpoint, SETPOINT_RING>,
    background: Background<'static>,
    machine: Machine,
    probe: StackProbe,
}

impl Idle {
    /// Commands from `cmds`, setpoints into `setpoints`.
    pub fn new(
        cmds: Consumer<'static, Cmd, CMD_QUEUE>,
        setpoints: Producer<'static, Setpoint, SETPOINT_RING>,
        background: Background<'static>,
        machine: Machine,
    ) -> Self {
        Idle {
            cmds,
            setpoints,
            background,
            machine,
            probe: StackProbe::new(),
        }
    }

    /// The loop; it sleeps until an interrupt when nothing is left to do
    /// (a tick frees a ring slot, a byte brings a command). Step settings
    /// changed over the link go to the tick through `step_settings`.
    pub fn run(
        &mut self,
        link: &mut impl Mutex<T = DeviceLink>,
        port: &mut impl Mutex<T = LinkPort>,
        step_settings: &mut impl Mutex<T = Option<StepSettings>>,
    ) -> ! {
        loop {
            self.machine.feed_watchdog();
            let pending = link_port::transmit(link, port);
            let stack = self.probe.step(256);
            let busy = self.background.step(
                link,
                &mut self.cmds,
                &mut self.setpoints,
                &mut self.machine,
                measure::uptime_us(),
                stack,
                machine::log,
            );
            if let Some(s) = self.background.take_step_settings() {
                step_settings.lock(|p| *p = Some(s));
            }
            if !busy && pending == 0 && !self.cmds.ready() && !self.setpoints.ready() {
                cortex_m::asm::wfi();
            }
        }
    }
}
