//! The machine around the motion as the background pass drives it
//! ([`MachineIo`]): the spindle and coolant outputs, the settings store in
//! flash (the watchdog's timeout lengthened over an erase), and the
//! background's notices as log lines.

use controller::background::{MachineIo, Notice};
use controller::config::Config;
use controller::spindle::MachineOutputs;
use controller::store::Store;
use link::StoreResult;

use crate::board::{Outputs, SettingsFlash, Watchdog};

/// The spindle, coolant and settings store, as the background drives
/// them.
pub struct Machine {
    outputs: Outputs,
    flash: SettingsFlash,
    store: Store,
    watchdog: Watchdog,
}

impl Machine {
    /// The outputs, the settings sector with its store, the (started)
    /// watchdog.
    pub fn new(outputs: Outputs, flash: SettingsFlash, store: Store, watchdog: Watchdog) -> Self {
        Machine {
            outputs,
            flash,
            store,
            watchdog,
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

    fn save(&mut self, c: &Config) -> StoreResult {
        // An erase stalls the core for up to 2 s: the watchdog waits.
        self.watchdog.long(true);
        let r = self.store.save(&mut self.flash, c);
        self.watchdog.long(false);
        r
    }
}

/// A background notice as a log line.
pub fn log(n: Notice) {
    match n {
        Notice::PathScheduled => defmt::info!("path scheduled"),
        Notice::Alarm(code) => defmt::warn!("alarm: {}", code),
        other => defmt::error!("{}", other),
    }
}
