//! The machine around the motion as the background pass drives it
//! ([`MachineIo`]): the spindle and coolant outputs, the settings store in
//! flash (the watchdog's timeout lengthened over an erase, an e-stop
//! pressed while the core stalls on it latched and raised after it), and
//! the background's notices as log lines.

use controller::alarm::Latch;
use controller::background::{MachineIo, Notice};
use controller::config::Config;
use controller::spindle::MachineOutputs;
use controller::store::Store;
use link::{AlarmCode, StoreResult};

use crate::board::{self, Outputs, SettingsFlash, Watchdog};

/// The spindle, coolant and settings store, as the background drives
/// them.
pub struct Machine {
    outputs: Outputs,
    flash: SettingsFlash,
    store: Store,
    watchdog: Watchdog,
    latch: &'static Latch,
}

impl Machine {
    /// The outputs, the settings sector with its store, the (started)
    /// watchdog, the alarm state.
    pub fn new(
        outputs: Outputs,
        flash: SettingsFlash,
        store: Store,
        watchdog: Watchdog,
        latch: &'static Latch,
    ) -> Self {
        Machine {
            outputs,
            flash,
            store,
            watchdog,
            latch,
        }
    }

    /// Reload the watchdog (once an idle pass).
    pub fn feed_watchdog(&mut self) {
        self.watchdog.feed();
    }
}

impl MachineIo for Machine {
    fn outputs(&mut self, o: MachineOutputs) {
        self.outputs.set(o);
    }

    /// Taken only with nothing moving and the outputs off
    /// (`controller::session`): the core stalls on the flash while a
    /// sector is erased, the tick with it; the watchdog waits, and a
    /// change of the e-stop pin meanwhile trips the alarm after it (the
    /// tick sees only the level it then has; `firmware/README.md`, flash
    /// settings).
    fn save(&mut self, c: &Config) -> StoreResult {
        let _ = board::estop_changed();
        self.watchdog.long(true);
        let r = self.store.save(&mut self.flash, c);
        self.watchdog.long(false);
        if board::estop_changed() {
            self.latch.trip(AlarmCode::EStopInput);
        }
        r
    }
}

/// A background notice as a log line.
pub fn log(n: Notice) {
    match n {
        Notice::PathScheduled => defmt::info!("path scheduled"),
        Notice::Alarm(code) => defmt::warn!("alarm: {}", code),
        Notice::LinkSilent => defmt::warn!("link silent while moving: feed hold"),
        other => defmt::error!("{}", other),
    }
}
