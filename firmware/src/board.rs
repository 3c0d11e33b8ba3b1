//! Everything that knows the chip and the board: clocks, the link USART, the
//! interpolator timer, the step/direction pins. Porting to another STM32 or
//! another pin-out means a new file like this one, nothing else.
//!
//! Board: STM32F405/F407 (STM32F4-Discovery, Netduino Plus 2, most F4 CNC
//! and printer boards), and QEMU's `netduinoplus2` (feature `qemu`).
//!
//! | what | peripheral | pins |
//! |---|---|---|
//! | link, 921 600 8N1 (`FW_LINK_BAUD`) | USART1 | PA9 TX, PA10 RX (AF7) |
//! | interpolator tick | SysTick (core timer, exception) | |
//! | X step / dir | GPIOE | PE0 / PE1 |
//! | Y step / dir | GPIOE | PE2 / PE3 |
//! | Z step / dir | GPIOE | PE4 / PE5 |
//!
//! QEMU 7.2 does not model the F4's RCC (its ready bits never set) nor GPIO
//! (writes are ignored): with feature `qemu` the clock set-up is skipped.
//! Its TIM2-5 model does not keep a steady period (measured: ~150 updates
//! per second for a 1 kHz set-up), so the interpolator ticks on SysTick, the
//! core's own timer, which QEMU models exactly at 168 MHz; it does the same
//! on the board (see [`crate::measure`]). Everything else is the same code
//! on both.

use core::convert::Infallible;

use controller::settings::LINK_BAUD;
use stm32f4::stm32f405 as pac;

/// Core clock, Hz (also SysTick's, our cycle counter).
pub const SYSCLK_HZ: u32 = 168_000_000;

/// USART1's clock (APB2), Hz.
const APB2_HZ: u32 = 84_000_000;

/// The link's rate must come within 1 % (a UART tolerates about 2 % in
/// all, both ends together).
const _: () = assert!(
    controller::settings::baud_error_ppm(APB2_HZ, LINK_BAUD).abs() < 10_000,
    "FW_LINK_BAUD is more than 1 % off on an 84 MHz APB2"
);

/// The peripherals the application uses, set up.
pub struct Board {
    /// Link receive side (used in the USART interrupt).
    pub rx: UsartRx,
    /// Link transmit side (used by the idle loop).
    pub tx: UsartTx,
    /// Step/direction pins, X, Y, Z.
    pub axes: [(Pin, Pin); 3],
}

/// Clocks, pins and USART1 (receive interrupt enabled; RTIC unmasks it in
/// the NVIC).
pub fn init(dp: pac::Peripherals) -> Board {
    clocks(&dp);
    let rcc = &dp.RCC;
    // GPIOA, GPIOE; USART1.
    rcc.ahb1enr
        .modify(|r, w| unsafe { w.bits(r.bits() | (1 << 0) | (1 << 4)) });
    rcc.apb2enr
        .modify(|r, w| unsafe { w.bits(r.bits() | (1 << 4)) });

    // PA9/PA10 alternate function 7 (USART1).
    let gpioa = &dp.GPIOA;
    gpioa.moder.modify(|r, w| unsafe {
        w.bits((r.bits() & !(0b1111 << 18)) | (0b10 << 18) | (0b10 << 20))
    });
    gpioa
        .afrh
        .modify(|r, w| unsafe { w.bits((r.bits() & !(0xFF << 4)) | (7 << 4) | (7 << 8)) });
    // PE0..PE5 push-pull outputs, low.
    let gpioe = &dp.GPIOE;
    gpioe.bsrr.write(|w| unsafe { w.bits(0x3F << 16) });
    gpioe
        .moder
        .modify(|r, w| unsafe { w.bits((r.bits() & !0xFFF) | 0b0101_0101_0101) });

    // USART1: 8N1 at LINK_BAUD, receive interrupt.
    let usart = &dp.USART1;
    let brr = controller::settings::usart_brr(APB2_HZ, LINK_BAUD);
    usart.brr.write(|w| unsafe { w.bits(brr) });
    // UE | RXNEIE | TE | RE
    usart
        .cr1
        .write(|w| unsafe { w.bits((1 << 13) | (1 << 5) | (1 << 3) | (1 << 2)) });

    let pin = |n: u32| Pin { mask: 1 << n };
    Board {
        rx: UsartRx(()),
        tx: UsartTx(()),
        axes: [(pin(0), pin(1)), (pin(2), pin(3)), (pin(4), pin(5))],
    }
}

/// HSE 8 MHz → PLL → 168 MHz core, APB1 42 MHz, APB2 84 MHz, 5 flash wait
/// states. Waits for the ready bits (so it is skipped under QEMU, which
/// never sets them).
#[cfg(not(feature = "qemu"))]
fn clocks(dp: &pac::Peripherals) {
    let (rcc, flash) = (&dp.RCC, &dp.FLASH);
    rcc.cr
        .modify(|r, w| unsafe { w.bits(r.bits() | (1 << 16)) }); // HSEON
    while rcc.cr.read().bits() & (1 << 17) == 0 {} // HSERDY
                                                   // PLLM 8, PLLN 336, PLLP 2 (0b00), PLLSRC HSE, PLLQ 7.
    rcc.pllcfgr
        .write(|w| unsafe { w.bits(8 | (336 << 6) | (1 << 22) | (7 << 24)) });
    rcc.cr
        .modify(|r, w| unsafe { w.bits(r.bits() | (1 << 24)) }); // PLLON
    while rcc.cr.read().bits() & (1 << 25) == 0 {} // PLLRDY
                                                   // 5 wait states, prefetch, instruction and data caches.
    flash
        .acr
        .write(|w| unsafe { w.bits(5 | (1 << 8) | (1 << 9) | (1 << 10)) });
    // AHB /1, APB1 /4, APB2 /2, system clock PLL.
    rcc.cfgr
        .write(|w| unsafe { w.bits((0b101 << 10) | (0b100 << 13) | 0b10) });
    while (rcc.cfgr.read().bits() >> 2) & 0b11 != 0b10 {}
}

/// Nothing to do under QEMU: its model runs the core at 168 MHz already.
#[cfg(feature = "qemu")]
fn clocks(_dp: &pac::Peripherals) {}

fn usart() -> &'static pac::usart1::RegisterBlock {
    // SAFETY: USART1's registers; RX and TX use disjoint bits (RXNE/DR read
    // in the interrupt, TXE/DR write in idle), each side owned once.
    unsafe { &*pac::USART1::ptr() }
}

/// Receive side of the link USART.
pub struct UsartRx(());

impl UsartRx {
    /// A received byte, if any (clears RXNE); overrun and framing flags are
    /// cleared by the same read sequence.
    pub fn read(&mut self) -> Option<u8> {
        let u = usart();
        let sr = u.sr.read().bits();
        if sr & (1 << 5) != 0 || sr & 0b1111 != 0 {
            // RXNE, or ORE/NF/FE/PE: reading DR clears them.
            let b = u.dr.read().bits() as u8;
            if sr & (1 << 5) != 0 {
                return Some(b);
            }
        }
        None
    }
}

/// Transmit side of the link USART.
pub struct UsartTx(());

impl UsartTx {
    /// Send `byte` if the transmit register is empty; `false` if busy.
    pub fn try_write(&mut self, byte: u8) -> bool {
        let u = usart();
        if u.sr.read().bits() & (1 << 7) == 0 {
            return false;
        }
        u.dr.write(|w| unsafe { w.bits(byte as u32) });
        true
    }
}

/// One GPIOE output pin (step or direction), an `embedded-hal` pin.
pub struct Pin {
    mask: u32,
}

impl embedded_hal::digital::ErrorType for Pin {
    type Error = Infallible;
}

impl embedded_hal::digital::OutputPin for Pin {
    fn set_low(&mut self) -> Result<(), Infallible> {
        // SAFETY: BSRR writes are atomic set/reset of our own pins only.
        unsafe { (*pac::GPIOE::ptr()).bsrr.write(|w| w.bits(self.mask << 16)) };
        Ok(())
    }

    fn set_high(&mut self) -> Result<(), Infallible> {
        // SAFETY: as above.
        unsafe { (*pac::GPIOE::ptr()).bsrr.write(|w| w.bits(self.mask)) };
        Ok(())
    }
}
