//! Everything that knows the chip: clocks, the link USART, GPIO, the step
//! timer, the spindle's PWM timer, the settings' flash sector, the
//! independent watchdog. Which pin does what is the board's pin map
//! ([`crate::boards`], one file per board); porting to another STM32F4
//! board is a new pin map, porting to another chip a new file like this.
//!
//! Chip: STM32F405/F407, and QEMU's `netduinoplus2` (feature `qemu`).
//!
//! | what | peripheral |
//! |---|---|
//! | link, 921 600 8N1 (`FW_LINK_BAUD`) | USART1 (AF7), pins from the map |
//! | interpolator tick | SysTick (core timer, exception) |
//! | step timer (edges at exact times) | TIM2, 32-bit, 84 MHz, compare channel 1 interrupt (no pin) |
//! | step / direction / enable, spindle enable and direction, coolant | GPIO outputs (steps and directions at high speed, the rest low) |
//! | limit switches, e-stop, probe | GPIO inputs with pull-up, read at each tick |
//! | (QEMU) the input word set by the tests | USART2 receive, polled at each tick |
//! | spindle speed | TIM3 PWM (frequency `$33`) |
//! | settings | one flash sector (the map's), erased and programmed 32 bits at a time |
//! | watchdog | IWDG, about 250 ms (4 s while the settings sector is erased) |
//!
//! QEMU 7.2 does not model the F4's RCC (its ready bits never set) nor GPIO
//! (writes are ignored, reads 0), nor the flash interface or the IWDG
//! (ignored): with feature `qemu` the clock set-up is skipped and no input
//! is wired. Its TIM2-5 model does not keep a steady period (measured: ~150
//! updates per second for a 1 kHz set-up), so the interpolator ticks on
//! SysTick, the core's own timer, which QEMU models exactly at 168 MHz; it
//! does the same on the board (see [`crate::measure`]). Nor can TIM2 drive
//! the step engine there: QEMU 7.2 (and 10.0) count TIM2's CNT at 1 GHz of
//! virtual time but never raise a compare match (CC1IF stays clear, no
//! interrupt; measured with a probe image), so with feature `qemu` the tick
//! runs the engine itself over its window in virtual time
//! ([`controller::stepper::SoftSteps`]) and TIM2 is left off. Everything
//! else is the same code on both.

use core::sync::atomic::{AtomicBool, AtomicU16, Ordering};

use controller::settings::{LINK_BAUD, STEP_TIMER_HZ};
use controller::spindle::{pwm_compare, pwm_timer, MachineOutputs};
use controller::stepper::StepPins;
use controller::steps::Edges;
use controller::store::{Flash, FlashError};
use stm32f4::stm32f405 as pac;

use crate::boards::{PinId, MAP};

/// Core clock, Hz (also SysTick's, our cycle counter).
pub const SYSCLK_HZ: u32 = 168_000_000;

/// USART1's clock (APB2), Hz.
const APB2_HZ: u32 = 84_000_000;
/// The APB1 timers' clock (APB1 at 42 MHz, timers at twice that), Hz.
const TIM_APB1_HZ: u32 = 84_000_000;

/// The link's rate must come within 1 % (a UART tolerates about 2 % in
/// all, both ends together).
const _: () = assert!(
    controller::settings::baud_error_ppm(APB2_HZ, LINK_BAUD).abs() < 10_000,
    "FW_LINK_BAUD is more than 1 % off on an 84 MHz APB2"
);

/// TIM2's clock: APB1 (42 MHz) × 2, the timers' rule when the APB1
/// prescaler is not 1 (RM0090 §7.2).
const TIM2_HZ: u32 = TIM_APB1_HZ;

const _: () = assert!(
    TIM2_HZ == STEP_TIMER_HZ,
    "the step timer's clock in controller::settings is not TIM2's"
);
// The tick (SysTick, core clock) and the step engine's windows (TIM2) come
// from the same PLL: they stay in step if a tick is a whole number of
// counts of both (the tick rate setting is checked against the step
// timer, `controller::config`).
const _: () = assert!(SYSCLK_HZ % STEP_TIMER_HZ == 0);

/// The main PLL's factors for 168 MHz from a crystal: `(M, N, P, Q)` with
/// the VCO input at 2 MHz (1 MHz for crystals that are not a multiple of
/// 2 MHz), the VCO at 336 MHz, P = 2, Q = 7 (48 MHz for USB). RM0090
/// §6.3.2 (`RCC_PLLCFGR`): 2 ≤ M ≤ 63, VCO input 1-2 MHz, 50 ≤ N ≤ 432,
/// VCO output 100-432 MHz; checked at compile time for the map's crystal.
pub const fn pll(hse_hz: u32) -> (u32, u32, u32, u32) {
    let input = if hse_hz % 2_000_000 == 0 {
        2_000_000
    } else {
        1_000_000
    };
    let m = hse_hz / input;
    let n = 336_000_000 / input;
    (m, n, 2, 7)
}

const PLL: (u32, u32, u32, u32) = pll(MAP.hse_hz);
const _: () = {
    let (m, n, p, q) = PLL;
    assert!(MAP.hse_hz % 1_000_000 == 0, "the crystal must be whole MHz");
    assert!(m >= 2 && m <= 63, "PLLM out of range");
    assert!(MAP.hse_hz / m >= 1_000_000 && MAP.hse_hz / m <= 2_000_000);
    assert!(n >= 50 && n <= 432, "PLLN out of range");
    let vco = MAP.hse_hz / m * n;
    assert!(vco >= 100_000_000 && vco <= 432_000_000, "VCO out of range");
    assert!(vco / p == SYSCLK_HZ, "not 168 MHz");
    assert!(vco / q == 48_000_000);
};

/// Memory-mapped registers.
mod reg {
    pub const RCC: u32 = 0x4002_3800;
    pub const FLASH: u32 = 0x4002_3C00;
    pub const IWDG: u32 = 0x4000_3000;
    pub const TIM3: u32 = 0x4000_0400;
    pub const GPIO: u32 = 0x4002_0000;

    #[inline(always)]
    pub fn read(addr: u32) -> u32 {
        // SAFETY: a peripheral register of this chip, read as a word.
        unsafe { core::ptr::read_volatile(addr as *const u32) }
    }

    #[inline(always)]
    pub fn write(addr: u32, v: u32) {
        // SAFETY: a peripheral register of this chip, written as a word;
        // each register is written by one owner (see the callers).
        unsafe { core::ptr::write_volatile(addr as *mut u32, v) }
    }

    #[inline(always)]
    pub fn modify(addr: u32, f: impl FnOnce(u32) -> u32) {
        write(addr, f(read(addr)));
    }
}

/// A port's register block address.
const fn port(p: PinId) -> u32 {
    reg::GPIO + 0x400 * p.port as u32
}

/// GPIO mode of a pin (MODER): 0 input, 1 output, 2 alternate function.
fn set_mode(p: PinId, mode: u32) {
    let s = 2 * p.n as u32;
    reg::modify(port(p), |r| (r & !(0b11 << s)) | (mode & 3) << s);
}

/// An output pin, push-pull, low at first; `fast`: the high speed setting
/// (OSPEEDR 0b10: edges of a few ns for step pulses), else low speed.
fn output(p: PinId, fast: bool) {
    write_pin(p, false);
    let s = 2 * p.n as u32;
    reg::modify(port(p) + 0x08, |r| {
        (r & !(0b11 << s)) | if fast { 0b10 << s } else { 0 }
    });
    set_mode(p, 1);
}

/// An input with the pull-up.
fn input(p: PinId) {
    let s = 2 * p.n as u32;
    reg::modify(port(p) + 0x0C, |r| (r & !(0b11 << s)) | 0b01 << s);
    set_mode(p, 0);
}

/// Alternate function `af` on a pin.
fn alternate(p: PinId, af: u32, fast: bool) {
    let (at, s) = if p.n < 8 {
        (0x20, 4 * p.n as u32)
    } else {
        (0x24, 4 * (p.n as u32 - 8))
    };
    reg::modify(port(p) + at, |r| (r & !(0xF << s)) | (af & 0xF) << s);
    let o = 2 * p.n as u32;
    reg::modify(port(p) + 0x08, |r| {
        (r & !(0b11 << o)) | if fast { 0b10 << o } else { 0 }
    });
    set_mode(p, 2);
}

/// Set an output's level (BSRR: atomic, this pin only).
fn write_pin(p: PinId, high: bool) {
    let m = 1u32 << p.n;
    reg::write(port(p) + 0x18, if high { m } else { m << 16 });
}

/// An input's level.
fn read_pin(p: PinId) -> bool {
    reg::read(port(p) + 0x10) & 1 << p.n != 0
}

/// The peripherals the application uses, set up.
pub struct Board {
    /// Link receive side (used in the USART interrupt).
    pub rx: UsartRx,
    /// Link transmit side (used by the idle loop).
    pub tx: UsartTx,
    /// The same pins, written a batch at a time (the step engine's).
    pub step_pins: StepGpio,
    /// The step timer (running, its interrupt enabled in the peripheral;
    /// RTIC unmasks it). Not started under QEMU.
    pub step_timer: StepTimer,
    /// Limit switches and e-stop (read by the tick).
    pub inputs: Inputs,
    /// Driver enable output (set by the tick).
    pub enable: Enable,
    /// Spindle and coolant outputs.
    pub outputs: Outputs,
    /// The settings' flash sector.
    pub flash: SettingsFlash,
    /// The independent watchdog (started by [`Watchdog::start`]).
    pub watchdog: Watchdog,
    /// The last reset was the watchdog's.
    pub watchdog_reset: bool,
    /// The crystal started (else the PLL runs from the 16 MHz HSI).
    pub crystal: bool,
}

/// Clocks, pins and USART1 (receive interrupt enabled; RTIC unmasks it in
/// the NVIC). Outputs start low, the drivers disabled.
pub fn init(_dp: pac::Peripherals) -> Board {
    let crystal = clocks();
    // GPIOA-E; TIM2, TIM3; USART1.
    reg::modify(reg::RCC + 0x30, |r| r | 0x1F);
    reg::modify(reg::RCC + 0x40, |r| r | 1 << 1 | 1);
    reg::modify(reg::RCC + 0x44, |r| r | 1 << 14 | 1 << 4);
    // The reset's cause (IWDGRSTF), then clear the flags (RMVF).
    let csr = reg::read(reg::RCC + 0x74);
    reg::modify(reg::RCC + 0x74, |r| r | 1 << 24);
    let watchdog_reset = csr & 1 << 29 != 0;

    alternate(MAP.link_tx, 7, false);
    alternate(MAP.link_rx, 7, false);
    for p in MAP.step.iter().chain(&MAP.dir) {
        output(*p, true);
    }
    let enable = Enable(());
    // Disabled (low enables, the default polarity).
    enable.set(false, false);
    for p in MAP.enable {
        output(*p, false);
    }
    enable.set(false, false);
    let outputs = [MAP.spindle_enable, MAP.spindle_dir, MAP.flood, MAP.mist];
    for p in outputs.into_iter().flatten() {
        output(p, false);
    }
    for p in MAP.power_on {
        output(*p, false);
        write_pin(*p, true);
    }
    let inputs = MAP.limits.iter().flatten().chain([&MAP.estop, &MAP.probe]);
    for p in inputs.flatten() {
        input(*p);
    }
    if let Some(p) = MAP.estop {
        estop_latch(p);
    }
    if let Some(pwm) = MAP.spindle_pwm {
        output(pwm.pin, false);
    }

    // USART1: 8N1 at LINK_BAUD, receive interrupt.
    let usart = usart();
    let brr = controller::settings::usart_brr(APB2_HZ, LINK_BAUD);
    usart.brr.write(|w| unsafe { w.bits(brr) });
    // UE | RXNEIE | TE | RE
    usart
        .cr1
        .write(|w| unsafe { w.bits((1 << 13) | (1 << 5) | (1 << 3) | (1 << 2)) });

    #[cfg(not(feature = "qemu"))]
    StepTimer::start();
    #[cfg(feature = "qemu")]
    test_inputs::init();

    Board {
        rx: UsartRx(()),
        tx: UsartTx(()),
        step_pins: StepGpio(()),
        step_timer: StepTimer(()),
        inputs: Inputs(()),
        enable,
        outputs: Outputs(()),
        flash: SettingsFlash(()),
        watchdog: Watchdog(()),
        watchdog_reset,
        crystal,
    }
}

/// Wait until `ready()` within `n` polls.
#[cfg(not(feature = "qemu"))]
fn wait(mut ready: impl FnMut() -> bool, n: u32) -> bool {
    (0..n).any(|_| ready())
}

/// HSE (the map's crystal) → PLL ([`pll`]) → 168 MHz core, APB1 42 MHz,
/// APB2 84 MHz, 5 flash wait states. If the crystal does not start within
/// its timeout (RM0090 gives HSE start-up in ms), the PLL runs from the
/// 16 MHz HSI instead (the same clocks, less precise: a UART's rate is off
/// by up to 1 %). Returns whether the crystal runs. Skipped under QEMU,
/// which never sets the ready bits.
#[cfg(not(feature = "qemu"))]
fn clocks() -> bool {
    let rcc = reg::RCC;
    reg::modify(rcc, |r| r | 1 << 16); // HSEON
    let crystal = wait(|| reg::read(rcc) & 1 << 17 != 0, 2_000_000); // HSERDY
    let (m, n, p, q) = if crystal { PLL } else { pll(16_000_000) };
    // PLLP is encoded (P / 2 − 1); PLLSRC bit 22 = HSE.
    let src = if crystal { 1 << 22 } else { 0 };
    reg::write(rcc + 0x04, m | n << 6 | (p / 2 - 1) << 16 | src | q << 24);
    reg::modify(rcc, |r| r | 1 << 24); // PLLON
    if !wait(|| reg::read(rcc) & 1 << 25 != 0, 2_000_000) {
        // No PLL: stay on the 16 MHz HSI (SysTick and the link would be
        // off by 10×; nothing sane can follow). Report by the flag only.
        return false;
    }
    // 5 wait states, prefetch, instruction and data caches.
    reg::write(reg::FLASH, 5 | 1 << 8 | 1 << 9 | 1 << 10);
    // AHB /1, APB1 /4, APB2 /2, system clock PLL.
    reg::write(rcc + 0x08, (0b101 << 10) | (0b100 << 13) | 0b10);
    wait(|| (reg::read(rcc + 0x08) >> 2) & 0b11 == 0b10, 2_000_000);
    crystal
}

/// Nothing to do under QEMU: its model runs the core at 168 MHz already.
#[cfg(feature = "qemu")]
fn clocks() -> bool {
    true
}

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

/// The step and direction pins in [`Edges`] bit order (bit `i` step of
/// axis `i`, bit `3 + i` its direction).
const STEP_DIR_PINS: [PinId; 6] = [
    MAP.step[0],
    MAP.step[1],
    MAP.step[2],
    MAP.dir[0],
    MAP.dir[1],
    MAP.dir[2],
];

/// The ports those pins are on (the first `.1` entries), in order of first
/// use.
const STEP_PORTS: ([u8; 6], usize) = {
    let mut ports = [0u8; 6];
    let mut n = 0;
    let mut i = 0;
    while i < 6 {
        let p = STEP_DIR_PINS[i].port;
        let mut k = 0;
        while k < n && ports[k] != p {
            k += 1;
        }
        if k == n {
            ports[n] = p;
            n += 1;
        }
        i += 1;
    }
    (ports, n)
};

/// Per port of [`STEP_PORTS`], per [`Edges`] mask: that port's pin bits
/// (its BSRR set half).
static STEP_BSRR: [[u16; 64]; 6] = {
    let mut t = [[0u16; 64]; 6];
    let mut k = 0;
    while k < STEP_PORTS.1 {
        let mut m = 0;
        while m < 64 {
            let mut i = 0;
            while i < 6 {
                let p = STEP_DIR_PINS[i];
                if m & (1 << i) != 0 && p.port == STEP_PORTS.0[k] {
                    t[k][m] |= 1 << p.n;
                }
                i += 1;
            }
            m += 1;
        }
        k += 1;
    }
    t
};

/// The step/direction pins of the map: a batch of edges is one BSRR write
/// per port, the pins of a port changing on the same bus cycle (every pin
/// of a batch, on a board with them on one port).
pub struct StepGpio(());

impl StepGpio {
    /// The pins (set up by [`init`]); more than one writes the same pins
    /// (the cost benchmark's second engine).
    pub fn new() -> Self {
        StepGpio(())
    }
}

impl Default for StepGpio {
    fn default() -> Self {
        Self::new()
    }
}

impl StepPins for StepGpio {
    /// Port by port, each index a constant (so that the map's port count
    /// decides the code, without a loop).
    #[inline(always)]
    fn write(&mut self, e: Edges) {
        step_port::<0>(e);
        step_port::<1>(e);
        step_port::<2>(e);
        step_port::<3>(e);
        step_port::<4>(e);
        step_port::<5>(e);
    }
}

/// Port `K` of [`STEP_PORTS`] (nothing past the map's count): its BSRR
/// written if `e` changes one of its pins.
#[inline(always)]
fn step_port<const K: usize>(e: Edges) {
    if K >= STEP_PORTS.1 {
        return;
    }
    let (Some(port), Some(bits)) = (STEP_PORTS.0.get(K), STEP_BSRR.get(K)) else {
        return;
    };
    let set = bits.get((e.set & 63) as usize).copied().unwrap_or(0) as u32;
    let clear = bits.get((e.clear & 63) as usize).copied().unwrap_or(0) as u32;
    if set | clear != 0 {
        reg::write(reg::GPIO + 0x400 * *port as u32 + 0x18, set | (clear << 16));
    }
}

/// EXTI (RM0090 §12.3) and SYSCFG (§9.2) register blocks.
const EXTI: u32 = 0x4001_3C00;
const SYSCFG: u32 = 0x4001_3800;

/// The e-stop pin's line of EXTI (line `n` for pin `n`, its port chosen
/// in SYSCFG_EXTICR), on both edges, unmasked in EXTI (so that the
/// pending bit is set) but never enabled in the NVIC: no interrupt, a
/// latch of any change of the pin, kept while the core stalls on a flash
/// erase ([`estop_changed`]).
fn estop_latch(p: PinId) {
    let line = p.n as u32 & 15;
    let cr = SYSCFG + 0x08 + 4 * (line / 4);
    let shift = 4 * (line % 4);
    reg::modify(cr, |r| {
        (r & !(0xF << shift)) | (p.port as u32 & 0xF) << shift
    });
    reg::modify(EXTI + 0x08, |r| r | 1 << line);
    reg::modify(EXTI + 0x0C, |r| r | 1 << line);
    reg::modify(EXTI, |r| r | 1 << line);
    reg::write(EXTI + 0x14, 1 << line);
}

/// Whether the e-stop pin changed since the last call (its EXTI pending
/// bit, then cleared); `false` on a map without an e-stop.
pub fn estop_changed() -> bool {
    let Some(p) = MAP.estop else {
        return false;
    };
    let bit = 1u32 << (p.n as u32 & 15);
    let pending = reg::read(EXTI + 0x14) & bit != 0;
    reg::write(EXTI + 0x14, bit);
    pending
}

/// The input word of the QEMU image, which has no GPIO: the last byte a
/// test wrote to USART2 (QEMU's second `-serial`), in the layout of
/// [`Inputs::read`]. One status register read a tick, no interrupt; with
/// no second serial nothing arrives and the word stays 0.
#[cfg(feature = "qemu")]
mod test_inputs {
    use core::sync::atomic::{AtomicU8, Ordering};

    use super::reg;

    const USART2: u32 = 0x4000_4400;
    static WORD: AtomicU8 = AtomicU8::new(0);

    /// USART2 on, receiver on (QEMU drops what arrives otherwise).
    pub fn init() {
        reg::modify(reg::RCC + 0x40, |r| r | 1 << 17);
        reg::write(USART2 + 0x0C, (1 << 13) | (1 << 2));
    }

    /// The word, after the last byte received.
    pub fn read() -> u8 {
        if reg::read(USART2) & 1 << 5 != 0 {
            WORD.store(reg::read(USART2 + 0x04) as u8, Ordering::Relaxed);
        }
        WORD.load(Ordering::Relaxed)
    }
}

/// The limit switches, the e-stop and the probe.
pub struct Inputs(());

impl Inputs {
    /// The input word (`controller::alarm` layout: bit 0 e-stop, then X
    /// min, X max, … Z max; bit 7 the probe, `controller::probe::PROBE`),
    /// 1 where the pin is low (pulled to ground: a closed normally-open
    /// switch), 0 where unwired.
    pub fn read(&mut self) -> u8 {
        let mut w = 0u8;
        if let Some(p) = MAP.estop {
            w |= !read_pin(p) as u8;
        }
        if let Some(p) = MAP.probe {
            w |= (!read_pin(p) as u8) << 7;
        }
        #[cfg(feature = "qemu")]
        {
            w |= test_inputs::read();
        }
        for (a, ends) in MAP.limits.iter().enumerate() {
            for (e, p) in ends.iter().enumerate() {
                if let Some(p) = p {
                    w |= (!read_pin(*p) as u8) << (1 + 2 * a + e);
                }
            }
        }
        w
    }
}

/// The polarity the fault handler drives the enable outputs with.
static ENABLE_INVERT: AtomicBool = AtomicBool::new(false);

/// The driver enable outputs.
pub struct Enable(());

impl Enable {
    /// Drivers on or off; `invert` is `$4` (0: low enables, as Grbl and
    /// A4988/DRV8825/TMC drivers; 1: high enables).
    pub fn set(&self, enabled: bool, invert: bool) {
        ENABLE_INVERT.store(invert, Ordering::Relaxed);
        for p in MAP.enable {
            write_pin(*p, enabled == invert);
        }
    }
}

/// TIM2 as the step engine's clock: free-running 32-bit up-counter at
/// 84 MHz, compare channel 1 (frozen: no pin) raising the interrupt.
pub struct StepTimer(());

fn tim2() -> &'static pac::tim2::RegisterBlock {
    // SAFETY: TIM2's registers; only the step timer task (and init) use
    // them.
    unsafe { &*pac::TIM2::ptr() }
}

impl StepTimer {
    /// No prescaler, full 32-bit period, compare 1 interrupt, counting.
    #[cfg(not(feature = "qemu"))]
    fn start() {
        let t = tim2();
        t.psc.write(|w| unsafe { w.bits(0) });
        t.arr.write(|w| w.bits(u32::MAX));
        t.egr.write(|w| unsafe { w.bits(1) }); // UG: load PSC
        t.sr.write(|w| unsafe { w.bits(0) });
        t.dier.write(|w| unsafe { w.bits(1 << 1) }); // CC1IE
        t.cr1.write(|w| unsafe { w.bits(1) }); // CEN
    }

    /// The counter.
    #[inline(always)]
    pub fn now(&self) -> u32 {
        tim2().cnt.read().bits()
    }

    /// Whether the counter has reached `at`.
    #[inline(always)]
    pub fn reached(&self, at: u32) -> bool {
        (self.now().wrapping_sub(at) as i32) >= 0
    }

    /// Interrupt at `at`; `true` if the counter is already there (then
    /// no interrupt is due: the caller handles it now).
    #[inline]
    pub fn arm(&mut self, at: u32) -> bool {
        let t = tim2();
        t.sr.write(|w| unsafe { w.bits(!(1u32 << 1)) }); // clear CC1IF
        t.ccr1().write(|w| w.bits(at));
        self.reached(at)
    }

    /// Run the step interrupt now (it preempts the caller: its priority
    /// is the highest), e.g. for a stop to take effect before the caller
    /// goes on (`controller::stepper::StepQueue::with_kick`).
    pub fn kick() {
        cortex_m::peripheral::NVIC::pend(pac::Interrupt::TIM2);
        cortex_m::asm::dsb();
        cortex_m::asm::isb();
    }

    /// Clear a compare flag that needs no handling.
    #[inline]
    pub fn clear(&mut self) {
        tim2().sr.write(|w| unsafe { w.bits(!(1u32 << 1)) });
    }
}

/// A fault: drivers and spindle off (from the fault handler; the outputs'
/// registers are written directly).
pub fn fault_outputs_off() {
    let invert = ENABLE_INVERT.load(Ordering::Relaxed);
    for p in MAP.enable {
        write_pin(*p, invert);
    }
    for p in [MAP.spindle_enable, MAP.flood, MAP.mist]
        .into_iter()
        .flatten()
    {
        write_pin(p, false);
    }
    reg::write(reg::TIM3 + 0x3C, 0);
}

/// TIM3's auto-reload once the PWM runs.
static PWM_ARR: AtomicU16 = AtomicU16::new(0);

/// The spindle and coolant outputs.
pub struct Outputs(());

impl Outputs {
    /// Start the spindle's PWM at `hz` (`$33`), duty 0.
    pub fn start_pwm(&mut self, hz: u32) {
        let Some(pwm) = MAP.spindle_pwm else { return };
        let (psc, arr) = pwm_timer(TIM_APB1_HZ, hz);
        let t = reg::TIM3;
        reg::write(t + 0x28, psc as u32);
        reg::write(t + 0x2C, arr as u32);
        let ccr = t + 0x30 + 4 * pwm.channel as u32;
        reg::write(ccr, 0);
        // PWM mode 1 with preload on the channel (OCxM = 110, OCxPE).
        let (ccmr, s) = match pwm.channel {
            1 => (t + 0x18, 0),
            2 => (t + 0x18, 8),
            3 => (t + 0x1C, 0),
            _ => (t + 0x1C, 8),
        };
        reg::modify(ccmr, |r| (r & !(0xFF << s)) | (0b110 << 4 | 1 << 3) << s);
        reg::modify(t + 0x20, |r| r | 1 << (4 * (pwm.channel as u32 - 1)));
        reg::write(t + 0x14, 1); // UG: load PSC and ARR
        reg::write(t, 1 << 7 | 1); // ARPE | CEN
        PWM_ARR.store(arr, Ordering::Relaxed);
        alternate(pwm.pin, pwm.af as u32, false);
    }

    /// Set the outputs.
    pub fn set(&mut self, o: MachineOutputs) {
        let pins = [
            (MAP.spindle_enable, o.spindle_on),
            (MAP.spindle_dir, o.ccw),
            (MAP.flood, o.flood),
            (MAP.mist, o.mist),
        ];
        for (p, on) in pins {
            if let Some(p) = p {
                write_pin(p, on);
            }
        }
        if let Some(pwm) = MAP.spindle_pwm {
            let arr = PWM_ARR.load(Ordering::Relaxed);
            let ccr = reg::TIM3 + 0x30 + 4 * pwm.channel as u32;
            reg::write(ccr, pwm_compare(o.duty_q16, arr) as u32);
        }
    }
}

/// The flash sector of the settings (the map's), for `controller::store`.
pub struct SettingsFlash(());

/// FLASH_SR: BSY.
const FLASH_BSY: u32 = 1 << 16;
/// FLASH_SR: the error flags (OPERR, WRPERR, PGAERR, PGPERR, PGSERR).
const FLASH_ERRORS: u32 = 0b1111_0010;

impl SettingsFlash {
    fn unlock(&mut self) {
        let cr = reg::FLASH + 0x10;
        if reg::read(cr) & 1 << 31 != 0 {
            reg::write(reg::FLASH + 0x04, 0x4567_0123);
            reg::write(reg::FLASH + 0x04, 0xCDEF_89AB);
        }
    }

    /// Wait for the flash to finish (at most `polls` reads); errors clear.
    fn finish(&mut self, polls: u32) -> Result<(), FlashError> {
        let sr = reg::FLASH + 0x0C;
        let done = (0..polls).any(|_| reg::read(sr) & FLASH_BSY == 0);
        let errors = reg::read(sr) & FLASH_ERRORS;
        // Flags clear by writing ones.
        reg::write(sr, errors | 1);
        // Lock again, PG/SER off.
        reg::write(reg::FLASH + 0x10, 1 << 31);
        if done && errors == 0 {
            Ok(())
        } else {
            Err(FlashError)
        }
    }
}

impl Flash for SettingsFlash {
    fn words(&self) -> usize {
        MAP.settings.bytes as usize / 4
    }

    fn read(&self, index: usize) -> u32 {
        if index >= self.words() {
            return u32::MAX;
        }
        reg::read(MAP.settings.addr + 4 * index as u32)
    }

    /// Sector erase (RM0090 §3.6.3: SER, SNB, STRT, wait BSY), 32-bit
    /// parallelism (2.7-3.6 V). The core stalls on flash reads meanwhile:
    /// 16 KiB typically 0.25 s, 128 KiB 1-2 s.
    fn erase(&mut self) -> Result<(), FlashError> {
        self.unlock();
        let cr = reg::FLASH + 0x10;
        reg::write(cr, 0b10 << 8 | (MAP.settings.number as u32) << 3 | 1 << 1);
        reg::modify(cr, |r| r | 1 << 16);
        self.finish(400_000_000)
    }

    /// Program one word (RM0090 §3.6.4: PG, PSIZE x32, write, wait BSY).
    fn program(&mut self, index: usize, value: u32) -> Result<(), FlashError> {
        if index >= self.words() {
            return Err(FlashError);
        }
        self.unlock();
        reg::write(reg::FLASH + 0x10, 0b10 << 8 | 1);
        reg::write(MAP.settings.addr + 4 * index as u32, value);
        self.finish(1_000_000)
    }
}

/// The independent watchdog (IWDG, on the 32 kHz LSI).
pub struct Watchdog(());

impl Watchdog {
    /// Set the timeout: prescaler code `pr` (LSI / 2^(pr + 2)), `reload`.
    fn configure(&mut self, pr: u32, reload: u32) {
        let k = reg::IWDG;
        // The previous update must be done (PVU, RVU) before a new one.
        let _ = (0..100_000).any(|_| reg::read(k + 0x0C) & 0b11 == 0);
        reg::write(k, 0x5555);
        reg::write(k + 0x04, pr);
        reg::write(k + 0x08, reload);
        reg::write(k, 0xAAAA);
    }

    /// Start it: about 250 ms (LSI / 32, 250 counts; the LSI varies from 17
    /// to 47 kHz, so 170-470 ms). Once started it cannot be stopped: the
    /// idle loop must [`Watchdog::feed`] it.
    pub fn start(&mut self) {
        self.configure(3, 250);
        reg::write(reg::IWDG, 0xCCCC);
    }

    /// Reload the counter.
    pub fn feed(&mut self) {
        reg::write(reg::IWDG, 0xAAAA);
    }

    /// About 4 s (for a sector erase, which stalls the core), or back to
    /// 250 ms.
    pub fn long(&mut self, on: bool) {
        if on {
            self.configure(6, 500);
        } else {
            self.configure(3, 250);
        }
    }
}

/// The AHB clock (HCLK = SYSCLK), Hz: the USB core's clock.
#[cfg(feature = "usb")]
pub const AHB_HZ: u32 = SYSCLK_HZ;

/// PA11/PA12 to the OTG FS core (alternate function 10, high speed).
#[cfg(feature = "usb")]
pub fn usb_pins() {
    use crate::boards::pa;
    alternate(pa(11), 10, true);
    alternate(pa(12), 10, true);
}

/// The OTG FS core's clock on (RCC_AHB2ENR.OTGFSEN), and the core reset
/// (RCC_AHB2RSTR.OTGFSRST).
#[cfg(feature = "usb")]
pub fn usb_clock_on() {
    reg::modify(reg::RCC + 0x34, |r| r | 1 << 7);
    reg::modify(reg::RCC + 0x14, |r| r | 1 << 7);
    reg::modify(reg::RCC + 0x14, |r| r & !(1 << 7));
}
