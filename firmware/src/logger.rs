//! The defmt transport under QEMU: frames written to semihosting stdout
//! (QEMU's stdout), decoded on the host by `defmt-print`.
//!
//! Written here rather than taken from `defmt-semihosting` because that
//! crate keeps panicking branches (re-entrancy asserts) that the
//! `panic-never` check refuses; this one drops a nested frame instead.

use core::cell::UnsafeCell;
use core::sync::atomic::{AtomicBool, Ordering};

use cortex_m_semihosting::hio::{self, HostStream};

#[defmt::global_logger]
struct Logger;

/// A static touched only while `TAKEN` is held inside a critical section.
struct Guarded<T>(UnsafeCell<T>);

// SAFETY: single core; every access happens between `acquire` and
// `release`, inside the critical section and with `TAKEN` held.
unsafe impl<T> Sync for Guarded<T> {}

static TAKEN: AtomicBool = AtomicBool::new(false);
/// Set while a nested frame (a fault handler logging mid-frame) is dropped.
static NESTED: AtomicBool = AtomicBool::new(false);
static ENCODER: Guarded<defmt::Encoder> = Guarded(UnsafeCell::new(defmt::Encoder::new()));
static STREAM: Guarded<Option<HostStream>> = Guarded(UnsafeCell::new(None));
static RESTORE: Guarded<critical_section::RestoreState> =
    Guarded(UnsafeCell::new(critical_section::RestoreState::invalid()));

fn out(stream: &mut Option<HostStream>, bytes: &[u8]) {
    if stream.is_none() {
        *stream = hio::hstdout().ok();
    }
    if let Some(s) = stream.as_mut() {
        let _ = s.write_all(bytes);
    }
}

// SAFETY: defmt's contract: `acquire` and `release` bracket each frame and
// `write` is called only in between; we hold a critical section meanwhile.
unsafe impl defmt::Logger for Logger {
    fn acquire() {
        // SAFETY: released in `release`.
        let restore = unsafe { critical_section::acquire() };
        if TAKEN.swap(true, Ordering::Acquire) {
            NESTED.store(true, Ordering::Relaxed);
            // SAFETY: pairs with the acquire just above.
            unsafe { critical_section::release(restore) };
            return;
        }
        // SAFETY: TAKEN held, interrupts masked.
        unsafe {
            *RESTORE.0.get() = restore;
            (*ENCODER.0.get()).start_frame(|b| out(&mut *STREAM.0.get(), b));
        }
    }

    unsafe fn flush() {}

    unsafe fn release() {
        if NESTED.swap(false, Ordering::Relaxed) {
            return;
        }
        // SAFETY: after `acquire`: TAKEN held, interrupts masked.
        unsafe {
            (*ENCODER.0.get()).end_frame(|b| out(&mut *STREAM.0.get(), b));
            let restore = *RESTORE.0.get();
            TAKEN.store(false, Ordering::Release);
            critical_section::release(restore);
        }
    }

    unsafe fn write(bytes: &[u8]) {
        if NESTED.load(Ordering::Relaxed) {
            return;
        }
        // SAFETY: between `acquire` and `release`.
        unsafe { (*ENCODER.0.get()).write(bytes, |b| out(&mut *STREAM.0.get(), b)) }
    }
}
