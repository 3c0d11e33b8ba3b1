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
use std::sync::{mpsc, Arc};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use controller::settings::TICK_HZ;
use controller::sim::VirtualDevice;
use fuzzy_core::units::Point3Mm;

/// What the simulated controller did, when its thread ends.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SimReport {
    /// Ticks run.
    pub ticks: u64,
    /// The last position sent to the axes.
    pub last_position: Option<Point3Mm>,
    /// Positions sent to the axes.
    pub positions: usize,
}

/// The simulated controller's thread.
pub struct SimHandle {
    stop: Arc<AtomicBool>,
    device_end: UnixStream,
    thread: Option<JoinHandle<SimReport>>,
}

impl SimHandle {
    /// Cut the link (as a pulled cable): the host sees its stream close,
    /// the device keeps running.
    pub fn cut(&self) {
        let _ = self.device_end.shutdown(Shutdown::Both);
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

/// Start a simulated controller at `speed` × real time; the host's end of
/// its stream.
pub fn spawn(speed: f64) -> io::Result<(UnixStream, SimHandle)> {
    if !(speed.is_finite() && speed > 0.0 && speed <= 1000.0) {
        return Err(io::Error::other(format!(
            "simulation speed {speed}: must be in (0, 1000]"
        )));
    }
    let (host, device) = UnixStream::pair()?;
    device.set_nonblocking(true)?;
    let dev_io = device.try_clone()?;
    let stop = Arc::new(AtomicBool::new(false));
    let stop2 = stop.clone();
    // The device holds leaked queues with lifetimes tied to it: it is
    // built on its own thread, and only its report crosses back.
    let (ready_tx, ready_rx) = mpsc::channel();
    let thread = thread::Builder::new()
        .name("sim-controller".into())
        .spawn(move || match VirtualDevice::new() {
            Ok(d) => {
                let _ = ready_tx.send(Ok(()));
                run(d, dev_io, speed, &stop2)
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
    Ok((
        host,
        SimHandle {
            stop,
            device_end: device,
            thread: Some(thread),
        },
    ))
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

fn run(mut dev: VirtualDevice, mut io_: UnixStream, speed: f64, stop: &AtomicBool) -> SimReport {
    let start = Instant::now();
    let mut ticks: u64 = 0;
    let mut buf = [0u8; 4096];
    let mut connected = true;
    let hz = TICK_HZ as f64 * speed;
    while !stop.load(Ordering::Relaxed) {
        let due = (start.elapsed().as_secs_f64() * hz) as u64;
        if ticks >= due {
            thread::sleep(Duration::from_micros(300));
            continue;
        }
        // At most a few ticks' worth at once, so the link is served often.
        for _ in 0..(due - ticks).min(16) {
            while connected {
                match io_.read(&mut buf) {
                    Ok(0) => connected = false,
                    Ok(n) => dev.receive(&buf[..n]),
                    Err(e) if e.kind() == io::ErrorKind::WouldBlock => break,
                    Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                    Err(_) => connected = false,
                }
            }
            dev.run_tick();
            ticks += 1;
            let out = dev.transmit();
            if connected && !out.is_empty() && !write_all(&mut io_, &out, stop) {
                connected = false;
            }
        }
    }
    SimReport {
        ticks,
        last_position: dev.axes.positions.last().copied(),
        positions: dev.axes.positions.len(),
    }
}
