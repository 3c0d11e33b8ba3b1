//! The link over USB: a CDC-ACM serial port on the F4's OTG FS core (PA11
//! DM, PA12 DP, alternate function 10), what most F4 motion boards (the
//! STM32F4-Discovery's CN5, the BTT SKR 2's USB-C) connect with, as
//! grblHAL does. The host sees `/dev/ttyACM0` (Linux), `/dev/cu.usbmodem…`
//! (macOS) or a COM port, and the sender opens it like any serial port
//! (its baud rate is ignored: USB full speed carries the bytes).
//!
//! The crates: `usb-device` (the device stack), `synopsys-usb-otg` (the
//! driver of the Synopsys core the F4 has, given its registers here:
//! [`OtgFs`]), `usbd-serial` (the CDC-ACM class). The OTG interrupt polls
//! the stack ([`UsbPort::poll`]) and pends the link's receive task, which
//! reads the bytes ([`UsbPort::read`]) through the same frame reader and
//! session as the USART's; replies go out through [`UsbPort::try_write`].
//!
//! Clocks: the PLL's Q output is 48 MHz (`board::pll`), which the core
//! needs; VBUS sensing is off (self-powered boards do not wire PA9 to
//! VBUS, and on the Discovery PA9 carries a capacitor).

use stm32f4::stm32f405 as pac;
use synopsys_usb_otg::UsbPeripheral;
use usb_device::bus::UsbBusAllocator;
use usb_device::device::{StringDescriptors, UsbDevice, UsbDeviceBuilder, UsbVidPid};
use usbd_serial::SerialPort;

/// The OTG FS core (one: made only by [`UsbPort::take`]).
pub struct OtgFs(());

impl OtgFs {
    /// The core, its pins (PA11/PA12, alternate function 10, high speed)
    /// set up.
    fn new() -> Self {
        crate::board::usb_pins();
        OtgFs(())
    }
}

// SAFETY: the register block address is the OTG FS core's (RM0090 table 1,
// 0x5000_0000), its FIFO RAM 1.25 KB (320 words) with 4 bidirectional
// endpoints (RM0090 34.4); one value exists ([`UsbPort::take`] runs
// once), and `board::init` reaches the chip by register address and never
// touches this core.
unsafe impl UsbPeripheral for OtgFs {
    const REGISTERS: *const () = pac::OTG_FS_GLOBAL::ptr() as *const ();
    const HIGH_SPEED: bool = false;
    const FIFO_DEPTH_WORDS: usize = 320;
    const ENDPOINT_COUNT: usize = 4;

    fn enable() {
        crate::board::usb_clock_on();
    }

    fn ahb_frequency_hz(&self) -> u32 {
        crate::board::AHB_HZ
    }
}

/// The bus driver.
pub type UsbBus = synopsys_usb_otg::UsbBus<OtgFs>;

/// Endpoint memory of the driver, words.
pub const EP_MEMORY_WORDS: usize = 320;

/// pid.codes' test PID under its open VID: for development; a product
/// needs its own ([`VID_PID`]).
pub const VID_PID: UsbVidPid = UsbVidPid(0x1209, 0x0001);

/// The CDC-ACM port and the device stack.
pub struct UsbPort {
    dev: UsbDevice<'static, UsbBus>,
    serial: SerialPort<'static, UsbBus>,
    buf: [u8; 64],
    len: usize,
    at: usize,
}

impl UsbPort {
    /// The port, once (`None` after the first call): the OTG core taken,
    /// its endpoint memory and bus allocator in static slots.
    pub fn take() -> Option<Self> {
        let mem: &'static mut [u32; EP_MEMORY_WORDS] =
            cortex_m::singleton!(: [u32; EP_MEMORY_WORDS] = [0; EP_MEMORY_WORDS])?;
        let core = OtgFs::new();
        let alloc: &'static UsbBusAllocator<UsbBus> = cortex_m::singleton!(
            : UsbBusAllocator<UsbBus> = UsbBus::new(core, mem)
        )?;
        Self::new(alloc)
    }

    /// The port on `alloc` (a static: the stack keeps references to it).
    fn new(alloc: &'static UsbBusAllocator<UsbBus>) -> Option<Self> {
        let serial = SerialPort::new(alloc);
        let strings = StringDescriptors::default()
            .manufacturer("fuzzy-feed")
            .product("fuzzy feed controller")
            .serial_number(crate::boards::MAP.name);
        let dev = UsbDeviceBuilder::new(alloc, VID_PID)
            .strings(&[strings])
            .ok()?
            .device_class(usbd_serial::USB_CLASS_CDC)
            .max_packet_size_0(64)
            .ok()?
            .build();
        Some(UsbPort {
            dev,
            serial,
            buf: [0; 64],
            len: 0,
            at: 0,
        })
    }

    /// Run the stack (from the OTG interrupt): enumeration, and the
    /// endpoints' transfers.
    pub fn poll(&mut self) {
        self.dev.poll(&mut [&mut self.serial]);
    }

    /// The next received byte, if any.
    pub fn read(&mut self) -> Option<u8> {
        if self.at >= self.len {
            self.at = 0;
            self.len = self.serial.read(&mut self.buf).unwrap_or(0);
        }
        let b = *self.buf.get(self.at..self.len)?.first()?;
        self.at += 1;
        Some(b)
    }

    /// Queue `byte` for the host; `false` if the class's buffer is full
    /// (the host not reading, or the port not open).
    pub fn try_write(&mut self, byte: u8) -> bool {
        matches!(self.serial.write(&[byte]), Ok(1))
    }
}
