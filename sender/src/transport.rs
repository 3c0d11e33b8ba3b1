//! Where the controller is: a serial port (a board over USB-serial or
//! USB CDC), TCP (the QEMU firmware's `cargo run` puts USART1 on
//! `127.0.0.1:7878`), a Unix socket (QEMU's `-serial unix:PATH,server=on`),
//! or the controller simulated on the host (`controller::sim`, see
//! [`crate::sim`]). Each opens into the two halves of a byte stream for
//! `link::client::Connection`.

use std::io::{self, Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::os::unix::net::UnixStream;
use std::path::PathBuf;
use std::time::Duration;

use crate::exit::{Exit, Failure};
use crate::sim::{self, SimHandle};

/// The default baud rate of a serial port: the rate the firmware's USART
/// runs at when built with the host's settings
/// (`controller::settings::LINK_BAUD`).
pub const DEFAULT_BAUD: u32 = controller::settings::LINK_BAUD;

/// Where to connect.
#[derive(Clone, Debug, PartialEq)]
pub enum Target {
    /// A serial port at a baud rate.
    Serial {
        /// The port (`/dev/ttyACM0`, `/dev/ttyUSB0`, `COM3`).
        port: String,
        /// Baud rate.
        baud: u32,
    },
    /// A TCP address.
    Tcp(String),
    /// A Unix socket.
    Unix(PathBuf),
    /// The controller on the host, at this many times real time.
    Sim {
        /// Speed-up over real time.
        speed: f64,
        /// The plane the simulated probe touches, machine coordinates:
        /// z = `[0]` + `[1]`·x + `[2]`·y, mm (none: the probe input never
        /// trips).
        probe_mm: Option<[f64; 3]>,
    },
}

impl std::fmt::Display for Target {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Target::Serial { port, baud } => write!(f, "{port} at {baud} baud"),
            Target::Tcp(a) => write!(f, "tcp {a}"),
            Target::Unix(p) => write!(f, "unix socket {}", p.display()),
            Target::Sim { speed, .. } => write!(f, "the simulated controller (×{speed})"),
        }
    }
}

impl Target {
    /// What may be wrong when the controller does not answer, for this
    /// kind of link.
    pub fn no_answer_hint(&self) -> &'static str {
        match self {
            Target::Serial { .. } => {
                "is it powered and running the firmware; are the port and baud rate right?"
            }
            Target::Tcp(_) | Target::Unix(_) => {
                "the port is busy or nothing serves it: QEMU serves one client at a time (is another fuzzy-send connected?), and the firmware must be running there"
            }
            Target::Sim { .. } => "the simulated controller stopped",
        }
    }
}

/// The plane z = `z0 + sx·x + sy·y` as a probe surface: a 2 × 2 height
/// map (bilinear, so exact for a plane) over ±2 m, level at `z0` beyond.
fn tilted_plane(z0: f64, sx: f64, sy: f64) -> controller::sim::ProbeSurface {
    use controller::sim::{HeightMap, ProbeSurface};
    if sx == 0.0 && sy == 0.0 {
        return ProbeSurface::plane(z0);
    }
    const HALF_MM: f64 = 2000.0;
    let z = |x: f64, y: f64| z0 + sx * x + sy * y;
    ProbeSurface {
        z_mm: z0,
        map: Some(HeightMap {
            origin_mm: [-HALF_MM, -HALF_MM],
            step_mm: [2.0 * HALF_MM, 2.0 * HALF_MM],
            nx: 2,
            z_mm: vec![
                z(-HALF_MM, -HALF_MM),
                z(HALF_MM, -HALF_MM),
                z(-HALF_MM, HALF_MM),
                z(HALF_MM, HALF_MM),
            ],
        }),
    }
}

/// The two halves of an open link.
pub struct Opened {
    /// Bytes to the controller.
    pub writer: Box<dyn Write + Send>,
    /// Bytes from the controller.
    pub reader: Box<dyn Read + Send>,
    /// The simulated controller, when [`Target::Sim`].
    pub sim: Option<SimHandle>,
}

/// A reader that waits through read timeouts (a serial port returns
/// `TimedOut` when nothing came within its timeout; the connection's
/// reader thread must not take that for the end of the stream).
pub struct Patient<R>(pub R);

impl<R: Read> Read for Patient<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        loop {
            match self.0.read(buf) {
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::TimedOut
                            | io::ErrorKind::WouldBlock
                            | io::ErrorKind::Interrupted
                    ) => {}
                r => return r,
            }
        }
    }
}

/// How long connecting may take.
const CONNECT_TIMEOUT: Duration = Duration::from_secs(5);

fn link_lost(what: &Target, e: impl std::fmt::Display) -> Failure {
    Failure::new(Exit::LinkLost, format!("cannot open {what}: {e}"))
}

/// Open the link.
pub fn open(target: &Target) -> Result<Opened, Failure> {
    match target {
        Target::Serial { port, baud } => {
            let p = serialport::new(port, *baud)
                .timeout(Duration::from_millis(100))
                .open_native()
                .map_err(|e| link_lost(target, e))?;
            let r = p.try_clone_native().map_err(|e| link_lost(target, e))?;
            Ok(Opened {
                writer: Box::new(p),
                reader: Box::new(Patient(r)),
                sim: None,
            })
        }
        Target::Tcp(addr) => {
            let addrs: Vec<_> = addr
                .to_socket_addrs()
                .map_err(|e| link_lost(target, e))?
                .collect();
            let mut last = None;
            for a in addrs {
                match TcpStream::connect_timeout(&a, CONNECT_TIMEOUT) {
                    Ok(s) => {
                        // Small frames: send each at once.
                        s.set_nodelay(true).map_err(|e| link_lost(target, e))?;
                        let r = s.try_clone().map_err(|e| link_lost(target, e))?;
                        return Ok(Opened {
                            writer: Box::new(s),
                            reader: Box::new(r),
                            sim: None,
                        });
                    }
                    Err(e) => last = Some(e),
                }
            }
            Err(link_lost(
                target,
                last.map_or("no address".to_string(), |e| e.to_string()),
            ))
        }
        Target::Unix(path) => {
            let s = UnixStream::connect(path).map_err(|e| link_lost(target, e))?;
            let r = s.try_clone().map_err(|e| link_lost(target, e))?;
            Ok(Opened {
                writer: Box::new(s),
                reader: Box::new(r),
                sim: None,
            })
        }
        Target::Sim { speed, probe_mm } => {
            let probe = probe_mm.map(|[z, sx, sy]| tilted_plane(z, sx, sy));
            let (s, h) = sim::spawn_with(*speed, move |d| d.probe = probe)
                .map_err(|e| link_lost(target, e))?;
            let r = s.try_clone().map_err(|e| link_lost(target, e))?;
            Ok(Opened {
                writer: Box::new(s),
                reader: Box::new(r),
                sim: Some(h),
            })
        }
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_tilted_probe_plane_is_exact_where_it_is_probed() {
        let p = tilted_plane(-3.25, 0.02, -0.01);
        for (x, y) in [(0.0, 0.0), (3.5, -2.25), (11.5, 1.75), (-250.0, 900.0)] {
            let want = -3.25 + 0.02 * x - 0.01 * y;
            assert!((p.height(x, y) - want).abs() < 1e-9, "({x}, {y})");
        }
        assert_eq!(
            tilted_plane(1.0, 0.0, 0.0),
            controller::sim::ProbeSurface::plane(1.0)
        );
    }

    use super::*;

    struct Flaky(Vec<io::Result<usize>>);

    impl Read for Flaky {
        fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
            let r = self.0.remove(0);
            if let Ok(n) = r {
                buf[..n].fill(7);
            }
            r
        }
    }

    #[test]
    fn a_patient_reader_waits_through_timeouts_but_not_errors() {
        let mut r = Patient(Flaky(vec![
            Err(io::ErrorKind::TimedOut.into()),
            Err(io::ErrorKind::WouldBlock.into()),
            Ok(3),
            Err(io::ErrorKind::BrokenPipe.into()),
            Ok(0),
        ]));
        let mut b = [0u8; 8];
        assert_eq!(r.read(&mut b).unwrap(), 3);
        assert_eq!(
            r.read(&mut b).unwrap_err().kind(),
            io::ErrorKind::BrokenPipe
        );
        assert_eq!(r.read(&mut b).unwrap(), 0);
    }

    #[test]
    fn nothing_listening_is_a_lost_link() {
        let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = l.local_addr().unwrap().to_string();
        drop(l);
        let e = open(&Target::Tcp(addr)).err().unwrap();
        assert_eq!(e.exit, Exit::LinkLost);
        let e = open(&Target::Serial {
            port: "/dev/no-such-port".into(),
            baud: DEFAULT_BAUD,
        })
        .err()
        .unwrap();
        assert_eq!(e.exit, Exit::LinkLost);
        assert!(e.message.contains("/dev/no-such-port"), "{e}");
    }
}
