//! The link's port: USART1, or with feature `usb` the USB serial port
//! ([`LinkPort`]); the receive interrupt's work ([`LinkRx`]: bytes to
//! frames to the session, each reply started on the wire at once) and the
//! transmit side ([`transmit`]).

use controller::command::Cmd;
use controller::ring::Producer;
use controller::session::DeviceLink;
use controller::settings::CMD_QUEUE;
use controller::tick::TickExecutor;
use link::{FrameReader, HostMsg};
use rtic::mutex::prelude::*;

use crate::board::{UsartRx, UsartTx};
use crate::measure;

/// Where the link's replies go: USART1, or with feature `usb` the USB
/// serial port (which also brings the bytes in).
#[cfg(not(feature = "usb"))]
pub type LinkPort = UsartTx;
/// Where the link's replies go: USART1, or with feature `usb` the USB
/// serial port (which also brings the bytes in).
#[cfg(feature = "usb")]
pub type LinkPort = crate::usb::UsbPort;

/// The port replies go to (USART1's transmit side).
#[cfg(not(feature = "usb"))]
pub fn open(tx: UsartTx) -> LinkPort {
    tx
}

/// The port replies go to (the USB serial port; a failed set-up stops).
#[cfg(feature = "usb")]
pub fn open(_: UsartTx) -> LinkPort {
    match crate::usb::UsbPort::take() {
        Some(p) => p,
        None => {
            defmt::error!("USB set-up failed");
            crate::fail()
        }
    }
}

/// Framed replies to the port as far as it takes them; bytes left.
pub fn transmit(
    link: &mut impl Mutex<T = DeviceLink>,
    port: &mut impl Mutex<T = LinkPort>,
) -> usize {
    (link, port).lock(|l, p| l.tx.drain(|b| p.try_write(b)))
}

/// The receive interrupt's state: the USART's receive side, the frame
/// reader, the command queue's writing end.
pub struct LinkRx {
    rx: UsartRx,
    reader: FrameReader,
    cmds: Producer<'static, Cmd, CMD_QUEUE>,
}

impl LinkRx {
    /// Nothing received yet.
    pub fn new(rx: UsartRx, cmds: Producer<'static, Cmd, CMD_QUEUE>) -> Self {
        LinkRx {
            rx,
            reader: FrameReader::new(),
            cmds,
        }
    }

    /// Every byte received: frames to the session as they complete, each
    /// reply started on the wire at once (so that replies go out even
    /// while a flood of bytes keeps the background from running).
    pub fn on_interrupt(
        &mut self,
        link: &mut impl Mutex<T = DeviceLink>,
        exec: &mut impl Mutex<T = TickExecutor>,
        port: &mut impl Mutex<T = LinkPort>,
    ) {
        while let Some(byte) = self.next_byte(port) {
            let Some(frame) = self.reader.push::<HostMsg>(byte) else {
                continue;
            };
            let now = measure::uptime_us();
            let cmds = &mut self.cmds;
            let refused = link.lock(|l| l.on_frame(frame, cmds, now, || exec.lock(|e| *e)));
            if let Some(code) = refused {
                defmt::warn!("frame refused: {}", code);
            }
            transmit(link, port);
        }
    }

    /// The next byte from the host.
    #[cfg(not(feature = "usb"))]
    fn next_byte(&mut self, _: &mut impl Mutex<T = LinkPort>) -> Option<u8> {
        self.rx.read()
    }

    /// The next byte from the host.
    #[cfg(feature = "usb")]
    fn next_byte(&mut self, port: &mut impl Mutex<T = LinkPort>) -> Option<u8> {
        let _ = &self.rx;
        port.lock(|p| p.read())
    }
}
