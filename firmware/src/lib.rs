//! Firmware of the fuzzy feedrate motion controller: the chip's side,
//! shared by the RTIC application (`src/main.rs`) and the cost benchmark
//! (`src/bin/cost.rs`). The logic they run is the `controller` crate.
//!
//! | module | what |
//! |---|---|
//! | [`board`] | the chip: clocks, USART1, GPIO, PWM timer, flash, watchdog |
//! | [`boards`] | one pin map per board (QEMU, STM32F4-Discovery, BTT SKR 2) |
//! | [`start`] | start-up: settings, queues, planner, background, step output, tick timer |
//! | [`tick`] | the tick interrupt's work |
//! | [`link_port`] | the link's port; the receive interrupt's work, transmit |
//! | [`idle`] | the background loop |
//! | [`machine`] | spindle, coolant and the settings store as the background drives them |
//! | [`measure`] | SysTick as tick timer and cycle counter, stack high-water mark |
//! | [`step_output`] | the step engine wired to the step timer (its interrupt), or run by the tick (QEMU) |
//! | `usb` | (feature `usb`) the link as a USB CDC-ACM serial port on OTG FS |
#![no_std]
#![deny(missing_docs)]

pub mod board;
pub mod boards;
pub mod idle;
pub mod link_port;
pub mod machine;
pub mod measure;
pub mod start;
pub mod step_output;
pub mod tick;
#[cfg(feature = "usb")]
pub mod usb;

#[cfg(feature = "qemu")]
mod logger;
#[cfg(all(feature = "board", not(feature = "qemu")))]
use defmt_rtt as _;

pub use link_port::LinkPort;

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

/// The last hard fault, in RAM the start-up code leaves alone (`.uninit`):
/// read and cleared by [`take_fault`] at the next boot.
#[link_section = ".uninit.FAULT"]
static mut FAULT: core::mem::MaybeUninit<[u32; 3]> = core::mem::MaybeUninit::uninit();

/// A hard fault: the drivers and the spindle off at once (the step output
/// stops with the core), where it happened recorded for the next boot,
/// then stop (the watchdog resets the chip).
#[cortex_m_rt::exception]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    board::fault_outputs_off();
    let words = controller::fault::FaultRecord::at(frame.pc()).words();
    // SAFETY: the fault handler is the only writer; nothing else runs.
    unsafe { core::ptr::write_volatile(core::ptr::addr_of_mut!(FAULT).cast::<[u32; 3]>(), words) };
    fail()
}

/// The fault recorded before this boot, if any (then cleared): the alarm
/// to start in.
pub fn take_fault() -> Option<link::AlarmCode> {
    // SAFETY: called once from `init`, before any interrupt runs; three
    // words of RAM, any bit pattern valid.
    unsafe {
        let p = core::ptr::addr_of_mut!(FAULT).cast::<[u32; 3]>();
        let words = core::ptr::read_volatile(p);
        core::ptr::write_volatile(p, [0; 3]);
        controller::fault::FaultRecord::from_words(words).alarm()
    }
}
