//! Any bytes into the controller's link (`controller::sim::VirtualDevice`:
//! the firmware's own frame reader and session), with a few ticks between
//! chunks: nothing panics, every reply the device sends decodes, and a
//! status query after a delimiter is always answered.
#![no_main]

use std::sync::Mutex;

use controller::sim::VirtualDevice;
use libfuzzer_sys::fuzz_target;
use link::{DeviceMsg, FrameReader, HostMsg, FRAME_MAX};

/// One device for the whole run (a fresh one per input would leak its
/// queues): its state carries over, as a real board's does.
static DEVICE: Mutex<Option<VirtualDevice>> = Mutex::new(None);

fuzz_target!(|data: &[u8]| {
    let mut guard = DEVICE.lock().unwrap_or_else(|e| e.into_inner());
    let dev = guard.get_or_insert_with(|| VirtualDevice::new().expect("device"));
    let mut replies = FrameReader::new();
    for chunk in data.chunks(64) {
        dev.receive(chunk);
        dev.run_tick();
        for b in dev.transmit() {
            if let Some(m) = replies.push::<DeviceMsg>(b) {
                assert!(m.is_ok(), "the device sent a frame that does not decode");
            }
        }
    }
    let mut query = [0u8; FRAME_MAX + 1];
    let n = link::encode(&HostMsg::StatusQuery, &mut query[1..]).expect("encode");
    dev.receive(&query[..n + 1]);
    let answered = dev
        .transmit()
        .into_iter()
        .filter_map(|b| replies.push::<DeviceMsg>(b))
        .any(|m| matches!(m, Ok(DeviceMsg::Status(_))));
    assert!(answered, "no status after a delimiter and a query");
});
