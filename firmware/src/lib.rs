//! Firmware of the fuzzy feedrate motion controller: the chip's side,
//! shared by the RTIC application (`src/main.rs`) and the cost benchmark
//! (`src/bin/cost.rs`). The logic they run is the `controller` crate.
//!
//! | module | what |
//! |---|---|
//! | [`board`] | the chip: clocks, USART1, GPIO, PWM timer, flash, watchdog |
//! | [`boards`] | one pin map per board (QEMU, STM32F4-Discovery, BTT SKR 2) |
//! | [`measure`] | SysTick as tick timer and cycle counter, stack high-water mark |
//! | `usb` | (feature `usb`) the link as a USB CDC-ACM serial port on OTG FS |
#![no_std]
#![deny(missing_docs)]

pub mod board;
pub mod boards;
pub mod measure;
#[cfg(feature = "usb")]
pub mod usb;

#[cfg(feature = "qemu")]
mod logger;
#[cfg(all(feature = "board", not(feature = "qemu")))]
use defmt_rtt as _;

/// Where the link's replies go: USART1, or with feature `usb` the USB
/// serial port (which also brings the bytes in).
#[cfg(not(feature = "usb"))]
pub type LinkPort = board::UsartTx;
/// Where the link's replies go: USART1, or with feature `usb` the USB
/// serial port (which also brings the bytes in).
#[cfg(feature = "usb")]
pub type LinkPort = usb::UsbPort;

defmt::timestamp!("{=u32:us}", measure::uptime_us());

/// Leave QEMU with a failure status (semihosting); on a board, stop.
pub fn fail() -> ! {
    #[cfg(feature = "qemu")]
    cortex_m_semihosting::debug::exit(cortex_m_semihosting::debug::EXIT_FAILURE);
    cortex_m::asm::udf()
}

/// Leave QEMU with a success status (semihosting); on a board, idle.
pub fn exit_success() -> ! {
    #[cfg(feature = "qemu")]
    cortex_m_semihosting::debug::exit(cortex_m_semihosting::debug::EXIT_SUCCESS);
    loop {
        cortex_m::asm::wfi();
    }
}

#[cfg(not(feature = "panic-never"))]
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    // Location only: formatting the message would pull in `core::fmt`.
    if let Some(l) = info.location() {
        defmt::error!("panic at {=str}:{=u32}", l.file(), l.line());
    }
    fail()
}

/// With feature `panic-never` any panic path left in the image fails the
/// link: the handler calls a function that exists nowhere.
#[cfg(feature = "panic-never")]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    extern "Rust" {
        #[link_name = "\n\nERROR: a panic path survived into the release build (panic-never check)\n\n"]
        fn panic_path_found() -> !;
    }
    // SAFETY: never runs: the symbol does not exist, so the link fails if
    // this handler is reachable.
    unsafe { panic_path_found() }
}

/// A hard fault: the drivers and the spindle off at once (the step output
/// stops with the core), then stop.
#[cortex_m_rt::exception]
unsafe fn HardFault(_frame: &cortex_m_rt::ExceptionFrame) -> ! {
    board::fault_outputs_off();
    fail()
}
