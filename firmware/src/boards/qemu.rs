//! QEMU's `netduinoplus2` (STM32F405RG): the image the system tests run.
//! QEMU 7.2 models USART1 (its first serial port) but no GPIO (reads 0,
//! writes ignored), so no input is wired here (a pin reading 0 would be an
//! active switch): the tests set the input word through USART2 instead
//! (`crate::board`, `Inputs::read`); the outputs are the Discovery's,
//! which QEMU ignores. The
//! settings sector is the Discovery's: QEMU's flash is ROM, so a write does
//! not land (reported as `StoreResult::WriteFailed`), and at start-up the
//! sector reads zeros (`StoreResult::Corrupt`: the defaults).

use super::{pa, PinMap};

/// The QEMU image's pins.
pub const MAP: PinMap = PinMap {
    name: "QEMU netduinoplus2",
    link_tx: pa(9),
    link_rx: pa(10),
    limits: [[None; 2]; 3],
    estop: None,
    probe: None,
    ..super::discovery::MAP
};
