//! Where a Grbl sender connects: a pseudo-terminal that looks like a
//! serial port (as Klipper's host exposes its printer, `klippy/util.py`
//! `create_pty`; and as cncjs's Grbl simulator is reached through socat),
//! or a TCP port on 127.0.0.1 (bCNC, UGS and gSender connect over TCP too).
//!
//! The pty is raw and 8-bit clean (`cfmakeraw` on its slave side), the
//! master non-blocking. The server keeps no slave descriptor open, so a
//! read of the master tells whether a sender has the port open: `EAGAIN`
//! with one, `EIO` with none (Linux). A sender closing the port (or dying)
//! is therefore seen at once, like a TCP peer closing.

use std::fs::File;
use std::io::{self, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::os::fd::OwnedFd;
use std::path::{Path, PathBuf};

use rustix::pty::{grantpt, openpt, ptsname, unlockpt, OpenptFlags};

/// What a read of a port found.
#[derive(Debug, PartialEq, Eq)]
pub enum Got {
    /// Bytes.
    Data(usize),
    /// Nothing now; a sender is connected.
    Nothing,
    /// No sender is connected (none yet, or it went away).
    NoSender,
}

/// A port senders connect to.
pub trait Port {
    /// Read what is there without waiting.
    fn read_now(&mut self, buf: &mut [u8]) -> io::Result<Got>;
    /// Write to the connected sender (dropped if there is none).
    fn send(&mut self, bytes: &[u8]) -> io::Result<()>;
    /// Where senders connect, for the operator.
    fn describe(&self) -> String;
}

/// A pseudo-terminal.
pub struct Pty {
    master: File,
    path: String,
    link: Option<PathBuf>,
}

impl Pty {
    /// Open a raw pty; `link`: a symlink to its slave (e.g. `/tmp/ttyFUZZY`),
    /// replaced if it is a symlink already.
    pub fn open(link: Option<&Path>) -> io::Result<Pty> {
        let master: OwnedFd = openpt(OpenptFlags::RDWR | OpenptFlags::NOCTTY)?;
        grantpt(&master)?;
        unlockpt(&master)?;
        let path = ptsname(&master, Vec::new())?
            .into_string()
            .map_err(|_| io::Error::other("pty name is not UTF-8"))?;
        {
            // Raw on the slave side, set once: it stays for every opener.
            let slave = std::fs::OpenOptions::new()
                .read(true)
                .write(true)
                .custom_flags_noctty()
                .open(&path)?;
            let mut t = rustix::termios::tcgetattr(&slave)?;
            t.make_raw();
            rustix::termios::tcsetattr(&slave, rustix::termios::OptionalActions::Now, &t)?;
        }
        rustix::fs::fcntl_setfl(
            &master,
            rustix::fs::fcntl_getfl(&master)? | rustix::fs::OFlags::NONBLOCK,
        )?;
        let link = match link {
            Some(l) => {
                if l.symlink_metadata()
                    .is_ok_and(|m| m.file_type().is_symlink())
                {
                    std::fs::remove_file(l)?;
                }
                std::os::unix::fs::symlink(&path, l)?;
                Some(l.to_path_buf())
            }
            None => None,
        };
        Ok(Pty {
            master: File::from(master),
            path,
            link,
        })
    }

    /// The slave's path (`/dev/pts/N`).
    pub fn path(&self) -> &str {
        &self.path
    }
}

impl Drop for Pty {
    fn drop(&mut self) {
        if let Some(l) = &self.link {
            let _ = std::fs::remove_file(l);
        }
    }
}

/// `O_NOCTTY` on an `OpenOptions`.
trait NoCtty {
    fn custom_flags_noctty(&mut self) -> &mut Self;
}

impl NoCtty for std::fs::OpenOptions {
    fn custom_flags_noctty(&mut self) -> &mut Self {
        use std::os::unix::fs::OpenOptionsExt;
        self.custom_flags(rustix::fs::OFlags::NOCTTY.bits() as i32)
    }
}

impl Port for Pty {
    fn read_now(&mut self, buf: &mut [u8]) -> io::Result<Got> {
        match self.master.read(buf) {
            Ok(0) => Ok(Got::NoSender),
            Ok(n) => Ok(Got::Data(n)),
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => Ok(Got::Nothing),
            Err(e) if e.kind() == io::ErrorKind::Interrupted => Ok(Got::Nothing),
            // EIO: no process has the slave open.
            Err(e) if e.raw_os_error() == Some(rustix::io::Errno::IO.raw_os_error()) => {
                Ok(Got::NoSender)
            }
            Err(e) => Err(e),
        }
    }

    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        let mut rest = bytes;
        let mut tries = 0;
        while !rest.is_empty() {
            match self.master.write(rest) {
                Ok(n) => rest = &rest[n..],
                Err(e) if e.kind() == io::ErrorKind::WouldBlock && tries < 200 => {
                    // The sender is not reading: wait a little, then drop.
                    tries += 1;
                    std::thread::sleep(std::time::Duration::from_millis(5));
                }
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => return Ok(()),
                Err(e) if e.raw_os_error() == Some(rustix::io::Errno::IO.raw_os_error()) => {
                    return Ok(())
                }
                Err(e) => return Err(e),
            }
        }
        Ok(())
    }

    fn describe(&self) -> String {
        match &self.link {
            Some(l) => format!("{} (-> {})", l.display(), self.path),
            None => self.path.clone(),
        }
    }
}

/// A TCP port on the loopback address: one sender at a time; a second
/// connection is refused while one is served.
pub struct Tcp {
    listener: TcpListener,
    client: Option<TcpStream>,
    /// A sender connected since the last call to [`Tcp::take_new`].
    fresh: bool,
}

impl Tcp {
    /// Listen on 127.0.0.1:`port` (0: any free port).
    pub fn bind(port: u16) -> io::Result<Tcp> {
        let listener = TcpListener::bind(("127.0.0.1", port))?;
        listener.set_nonblocking(true)?;
        Ok(Tcp {
            listener,
            client: None,
            fresh: false,
        })
    }

    /// The port listened on.
    pub fn port(&self) -> u16 {
        self.listener.local_addr().map_or(0, |a| a.port())
    }

    /// Whether a sender connected since the last call.
    pub fn take_new(&mut self) -> bool {
        std::mem::take(&mut self.fresh)
    }

    fn accept(&mut self) -> io::Result<()> {
        loop {
            match self.listener.accept() {
                Ok((s, _)) => {
                    if self.client.is_some() {
                        // One sender at a time: tell the second and close.
                        let mut s = s;
                        let _ = s.write_all(b"[MSG:busy: another sender is connected]\r\n");
                        continue;
                    }
                    s.set_nonblocking(true)?;
                    s.set_nodelay(true)?;
                    self.client = Some(s);
                    self.fresh = true;
                }
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => return Ok(()),
                Err(e) => return Err(e),
            }
        }
    }
}

impl Port for Tcp {
    fn read_now(&mut self, buf: &mut [u8]) -> io::Result<Got> {
        self.accept()?;
        let Some(c) = &mut self.client else {
            return Ok(Got::NoSender);
        };
        match c.read(buf) {
            Ok(0) => {
                self.client = None;
                Ok(Got::NoSender)
            }
            Ok(n) => Ok(Got::Data(n)),
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => Ok(Got::Nothing),
            Err(e) if e.kind() == io::ErrorKind::Interrupted => Ok(Got::Nothing),
            Err(_) => {
                self.client = None;
                Ok(Got::NoSender)
            }
        }
    }

    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        if let Some(c) = &mut self.client {
            c.set_nonblocking(false)?;
            let r = c.write_all(bytes);
            c.set_nonblocking(true)?;
            if r.is_err() {
                self.client = None;
            }
        }
        Ok(())
    }

    fn describe(&self) -> String {
        format!("tcp 127.0.0.1:{}", self.port())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pty_tells_when_a_sender_opens_and_closes_it() {
        let mut p = Pty::open(None).unwrap();
        let mut buf = [0u8; 64];
        assert_eq!(p.read_now(&mut buf).unwrap(), Got::NoSender);
        let mut s = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(p.path())
            .unwrap();
        assert_eq!(p.read_now(&mut buf).unwrap(), Got::Nothing);
        // 8-bit clean both ways: real-time bytes and CR LF pass unchanged.
        s.write_all(&[b'?', 0x85, 0x18, b'\r', b'\n', 0x9A])
            .unwrap();
        std::thread::sleep(std::time::Duration::from_millis(20));
        assert_eq!(p.read_now(&mut buf).unwrap(), Got::Data(6));
        assert_eq!(&buf[..6], &[b'?', 0x85, 0x18, b'\r', b'\n', 0x9A]);
        p.send(b"ok\r\n").unwrap();
        let mut back = [0u8; 4];
        s.read_exact(&mut back).unwrap();
        assert_eq!(&back, b"ok\r\n");
        drop(s);
        assert_eq!(p.read_now(&mut buf).unwrap(), Got::NoSender);
    }

    #[test]
    fn a_tcp_port_serves_one_sender_at_a_time() {
        let mut t = Tcp::bind(0).unwrap();
        let mut buf = [0u8; 16];
        assert_eq!(t.read_now(&mut buf).unwrap(), Got::NoSender);
        let mut a = TcpStream::connect(("127.0.0.1", t.port())).unwrap();
        std::thread::sleep(std::time::Duration::from_millis(20));
        assert_eq!(t.read_now(&mut buf).unwrap(), Got::Nothing);
        assert!(t.take_new());
        let mut b = TcpStream::connect(("127.0.0.1", t.port())).unwrap();
        std::thread::sleep(std::time::Duration::from_millis(20));
        a.write_all(b"?").unwrap();
        std::thread::sleep(std::time::Duration::from_millis(20));
        assert_eq!(t.read_now(&mut buf).unwrap(), Got::Data(1));
        let mut msg = String::new();
        b.read_to_string(&mut msg).unwrap();
        assert!(msg.contains("busy"), "{msg}");
        drop(a);
        std::thread::sleep(std::time::Duration::from_millis(20));
        assert_eq!(t.read_now(&mut buf).unwrap(), Got::NoSender);
    }
}
