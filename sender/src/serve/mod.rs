//! `fuzzy-send serve`: a Grbl 1.1 front for the controller, so that the
//! senders CNC users run (cncjs, bCNC, UGS, gSender, Candle) drive it.
//!
//! ```text
//! sender ─ pty (/dev/pts/N, a symlink such as /tmp/ttyFUZZY) ─┐
//!        ─ TCP 127.0.0.1:PORT ──────────────────────────────────┴► Front ─► link ─► controller
//!             (Grbl 1.1: lines, real-time bytes, ok/error, status)    (live G-code interpreter)
//! ```
//!
//! [`port`] holds the ports, [`front`] the protocol's state and the
//! controller's; [`serve`] runs them until Ctrl-C.

pub mod front;
pub mod port;

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use gcode_interp::GcodeSettings;

use crate::exit::{Exit, Failure};
use crate::stream::{Options, Session};
use front::{Front, SenderIo};
use port::{Got, Port};

/// Where senders connect and how G-code is read.
#[derive(Clone, Debug, Default)]
pub struct ServeOptions {
    /// No pseudo-terminal.
    pub no_pty: bool,
    /// A symlink to the pty's slave (`/tmp/ttyFUZZY`).
    pub pty_link: Option<PathBuf>,
    /// A TCP port on 127.0.0.1.
    pub tcp_port: Option<u16>,
    /// The interpreter's settings.
    pub gcode: GcodeSettings,
}

/// A port and whether a sender has it open.
struct Served {
    port: Box<dyn Port>,
    connected: bool,
}

/// The connected senders while a line blocks the front (a probing
/// move): their bytes read, the answers written. A sender that connects
/// meanwhile is greeted once the line has ended.
struct Attached<'a>(&'a mut [Served]);

impl SenderIo for Attached<'_> {
    fn read_now(&mut self, buf: &mut [u8]) -> Result<Option<usize>, Failure> {
        let mut any = false;
        for p in self.0.iter_mut().filter(|p| p.connected) {
            let got = p
                .port
                .read_now(buf)
                .map_err(|e| Failure::new(Exit::Error, format!("{}: {e}", p.port.describe())))?;
            match got {
                Got::Data(n) => return Ok(Some(n)),
                Got::Nothing => any = true,
                Got::NoSender => p.connected = false,
            }
        }
        Ok(any.then_some(0))
    }

    fn write(&mut self, text: &str) -> Result<(), Failure> {
        for p in self.0.iter_mut().filter(|p| p.connected) {
            p.port
                .send(text.as_bytes())
                .map_err(|e| Failure::new(Exit::Error, format!("{}: {e}", p.port.describe())))?;
        }
        Ok(())
    }
}

/// Serve senders over `session` (connected, not yet handshaken) until
/// `stop` is set; `ready` is told where senders connect.
pub fn serve(
    mut session: Session,
    opts: &Options,
    serve: ServeOptions,
    stop: Arc<AtomicBool>,
    mut ready: impl FnMut(&[String]),
) -> Result<Exit, Failure> {
    let hs = session.handshake(opts)?;
    let mut ports: Vec<Served> = Vec::new();
    if !serve.no_pty {
        let p = port::Pty::open(serve.pty_link.as_deref())
            .map_err(|e| Failure::new(Exit::Error, format!("opening a pty: {e}")))?;
        ports.push(Served {
            port: Box::new(p),
            connected: false,
        });
    }
    if let Some(tcp) = serve.tcp_port {
        let t = port::Tcp::bind(tcp)
            .map_err(|e| Failure::new(Exit::Error, format!("listening on 127.0.0.1:{tcp}: {e}")))?;
        ports.push(Served {
            port: Box::new(t),
            connected: false,
        });
    }
    if ports.is_empty() {
        return Err(Failure::new(
            Exit::Usage,
            "nothing to serve: drop --no-pty or give --grbl-tcp PORT",
        ));
    }
    let feed_max = hs.feed_max_mm_per_min();
    let mut front = Front::new(
        session,
        hs.status,
        hs.machine,
        hs.credit_size,
        serve.gcode,
        feed_max,
    )?;
    ready(&ports.iter().map(|p| p.port.describe()).collect::<Vec<_>>());
    let mut buf = [0u8; 4096];
    while !stop.load(Ordering::Relaxed) {
        for p in ports.iter_mut() {
            if !front.wants_bytes() {
                break;
            }
            let got = p
                .port
                .read_now(&mut buf)
                .map_err(|e| Failure::new(Exit::Error, format!("{}: {e}", p.port.describe())))?;
            match got {
                Got::Data(n) => {
                    if !p.connected {
                        p.connected = true;
                        front.connected();
                    }
                    front.on_bytes(&buf[..n])?;
                }
                Got::Nothing => {
                    if !p.connected {
                        p.connected = true;
                        front.connected();
                    }
                }
                Got::NoSender => {
                    if p.connected {
                        p.connected = false;
                        front.disconnected()?;
                    }
                }
            }
        }
        let mut io = Attached(&mut ports);
        front.poll_with(&mut io)?;
        let out = front.take_output();
        if !out.is_empty() {
            io.write(&out)?;
        }
        if !ports.iter().any(|p| p.connected) {
            std::thread::sleep(Duration::from_millis(2));
        }
    }
    front.disconnected()?;
    for _ in 0..50 {
        front.poll()?;
        std::thread::sleep(Duration::from_millis(2));
    }
    Ok(Exit::Done)
}
