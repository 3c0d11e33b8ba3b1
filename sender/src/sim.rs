//! The controller simulated on the host (`controller::sim::VirtualDevice`:
//! the firmware's own code) behind an in-process byte stream, paced to
//! real time (or a multiple of it): the sender's tests run against it,
//! and `fuzzy-send send FILE --sim` is a dry run without a board.
//!
//! A thread owns the device: each tick period it takes the bytes that
//! arrived (the receive interrupt), runs the tick (background passes, then
//! the tick) and puts what the device transmits on the stream.

use std::io::{self, Read, Write};
use std::net::Shutdown;
use std::os::unix::net::UnixStream;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, Sender};
use std::sync::{Arc, Mutex};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use controller::settings::TICK_HZ;
use controller::sim::VirtualDevice;
use controller::store::MemFlash;
use fuzzy_core::units::Point3Mm;

/// Newest entries of each of the device's records kept (positions,
/// notices, output changes): their memory stays bounded however long the
/// simulated run.
const KEEP_RECORDS: usize = 1024;

/// What the simulated controller did, when its thread ends.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SimReport {
    /// Ticks run.
    pub ticks: u64,
    /// The last position sent to the axes.
    pub last_position: Option<Point3Mm>,
    /// Positions sent to the axes.
    pub positions: usize,
    /// The tick at which the last bytes from a host arrived.
    pub last_heard_tick: u64,
    /// The tick at which the axes last moved.
    pub last_move_tick: u64,
    /// The spindle and coolant outputs at the end.
    pub outputs: Option<controller::spindle::MachineOutputs>,
}

/// The simulated controller's thread.
pub struct SimHandle {
    stop: Arc<AtomicBool>,
    /// The device's clock may start.
    go: Arc<AtomicBool>,
    streams: Sender<UnixStream>,
    /// The device's end of the current stream.
    current: Mutex<Option<UnixStream>>,
    thread: Option<JoinHandle<SimReport>>,
}

impl SimHandle {
    /// A new connection to the running device (the previous one is
    /// dropped, as when a host program exits and another starts): the
    /// host's end.
    pub fn connect(&self) -> io::Result<UnixStream> {
        let (host, device) = UnixStream::pair()?;
        device.set_nonblocking(true)?;
        let keep = device.try_clone()?;
        self.streams
            .send(device)
            .map_err(|_| io::Error::other("the simulated controller stopped"))?;
        if let Ok(mut c) = self.current.lock() {
            *c = Some(keep);
        }
        // The clock starts with the first connection (as QEMU's
        // `wait=on`): its hello goes to that host.
        self.go.store(true, Ordering::Relaxed);
        Ok(host)
    }

    /// Cut the link (as a pulled cable): the host sees its stream close,
    /// the device keeps running.
    pub fn cut(&self) {
        if let Ok(c) = self.current.lock() {
            if let Some(s) = c.as_ref() {
                let _ = s.shutdown(Shutdown::Both);
            }
        }
    }

    /// Stop the device and report what it did.
    pub fn finish(mut self) -> SimReport {
        self.stop.store(true, Ordering::Relaxed);
        self.thread
            .take()
            .and_then(|t| t.join().ok())
            .unwrap_or_default()
    }
}

impl Drop for SimHandle {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Start a simulated controller at `speed` × real time and connect to it:
/// the host's end of its stream.
pub fn spawn(speed: f64) -> io::Result<(UnixStream, SimHandle)> {
    spawn_with(speed, |_| {})
}

/// [`spawn`], with `setup` run on the fresh device first (as in
/// [`start_with`]).
pub fn spawn_with(
    speed: f64,
    setup: impl FnOnce(&mut VirtualDevice) + Send + 'static,
) -> io::Result<(UnixStream, SimHandle)> {
    let h = start_with(speed, setup)?;
    let s = h.connect()?;
    Ok((s, h))
}

/// Start a simulated controller at `speed` × real time, fresh from reset;
/// its clock starts with the first [`SimHandle::connect`], which gets its
/// hello.
pub fn start(speed: f64) -> io::Result<SimHandle> {
    start_with(speed, |_| {})
}

/// [`start`], with `setup` run on the fresh device first (limit switches
/// on its axes, an active e-stop input: `controller::sim::VirtualDevice`'s
/// fields).
pub fn start_with(
    speed: f64,
    setup: impl FnOnce(&mut VirtualDevice) + Send + 'static,
) -> io::Result<SimHandle> {
    start_from(speed, MemFlash::default(), setup)
}

/// [`start_with`], the device reading its settings from `flash` at
/// start-up (as a board with settings stored).
pub fn start_from(
    speed: f64,
    flash: MemFlash,
    setup: impl FnOnce(&mut VirtualDevice) + Send + 'static,
) -> io::Result<SimHandle> {
    if !(speed.is_finite() && speed > 0.0 && speed <= 1000.0) {
        return Err(io::Error::other(format!(
            "simulation speed {speed}: must be in (0, 1000]"
        )));
    }
    let (streams, rx) = mpsc::channel();
    let stop = Arc::new(AtomicBool::new(false));
    let stop2 = stop.clone();
    let go = Arc::new(AtomicBool::new(false));
    let go2 = go.clone();
    // The device holds leaked queues with lifetimes tied to it: it is
    // built on its own thread, and only its report crosses back.
    let (ready_tx, ready_rx) = mpsc::channel();
    let thread = thread::Builder::new()
        .name("sim-controller".into())
        .spawn(move || match VirtualDevice::with_flash(flash) {
            Ok(mut d) => {
                // Only the last position is read (the report): a run of
                // hours keeps no more than a few of each record.
                d.keep_last(KEEP_RECORDS);
                setup(&mut d);
                let _ = ready_tx.send(Ok(()));
                while !go2.load(Ordering::Relaxed) && !stop2.load(Ordering::Relaxed) {
                    thread::sleep(Duration::from_micros(100));
                }
                run(d, rx, speed, &stop2)
            }
            Err(e) => {
                let _ = ready_tx.send(Err(format!("{e:?}")));
                SimReport::default()
            }
        })?;
    ready_rx
        .recv()
        .map_err(|_| io::Error::other("the simulated controller did not start"))?
        .map_err(|e| io::Error::other(format!("the simulated controller did not start: {e}")))?;
    Ok(SimHandle {
        stop,
        go,
        streams,
        current: Mutex::new(None),
        thread: Some(thread),
    })
}

/// Write all of `bytes` to a non-blocking stream; false if it closed.
fn write_all(s: &mut UnixStream, mut bytes: &[u8], stop: &AtomicBool) -> bool {
    while !bytes.is_empty() {
        match s.write(bytes) {
            Ok(0) => return false,
            Ok(n) => bytes = &bytes[n..],
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                if stop.load(Ordering::Relaxed) {
                    return false;
                }
                thread::sleep(Duration::from_micros(200));
            }
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(_) => return false,
        }
    }
    true
}

fn run(
    mut dev: VirtualDevice,
    streams: Receiver<UnixStream>,
    speed: f64,
    stop: &AtomicBool,
) -> SimReport {
    let start = Instant::now();
    let mut ticks: u64 = 0;
    let mut buf = [0u8; 4096];
    // The wire: bytes go out only while a host is connected (a real
    // board's transmitter runs on regardless).
    let mut io_: Option<UnixStream> = None;
    let hz = TICK_HZ as f64 * speed;
    // The host's silence in real time, not the device's: a host that asks
    // for a status every 200 ms stays alive at any speed.
    let mut heard = Instant::now();
    let (mut last_heard_tick, mut last_move_tick) = (0, 0);
    let mut last_pos = None;
    while !stop.load(Ordering::Relaxed) {
        if let Some(s) = streams.try_iter().last() {
            io_ = Some(s);
        }
        let due = (start.elapsed().as_secs_f64() * hz) as u64;
        if ticks >= due {
            thread::sleep(Duration::from_micros(300));
            continue;
        }
        // At most a few ticks' worth at once, so the link is served often.
        for _ in 0..(due - ticks).min(16) {
            let mut closed = false;
            if let Some(s) = io_.as_mut() {
                loop {
                    match s.read(&mut buf) {
                        Ok(0) => {
                            closed = true;
                            break;
                        }
                        Ok(n) => {
                            heard = Instant::now();
                            last_heard_tick = ticks;
                            dev.receive(&buf[..n]);
                        }
                        Err(e) if e.kind() == io::ErrorKind::WouldBlock => break,
                        Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                        Err(_) => {
                            closed = true;
                            break;
                        }
                    }
                }
            }
            let silent_us = heard.elapsed().as_micros().min(u32::MAX as u128 / 2) as u32;
            dev.set_host_silence_us(silent_us);
            dev.run_tick();
            ticks += 1;
            let pos = dev.axes.positions.last().copied();
            if pos != last_pos {
                last_pos = pos;
                last_move_tick = ticks;
            }
            let out = dev.transmit();
            if let Some(s) = io_.as_mut() {
                if !closed && !out.is_empty() && !write_all(s, &out, stop) {
                    closed = true;
                }
            }
            if closed {
                io_ = None;
            }
        }
    }
    SimReport {
        ticks,
        last_position: dev.axes.last(),
        positions: dev.axes.sent(),
        last_heard_tick,
        last_move_tick,
        outputs: dev.machine.outputs.last().map(|o| o.1),
    }
}
