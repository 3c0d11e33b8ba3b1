//! One pin map per target board: which pin does what, the crystal, where
//! the settings live in flash. The chip code (`crate::board`) reads the map
//! selected by the cargo features; porting to another F405/F407 board is a
//! new file here.
//!
//! | feature | board | file |
//! |---|---|---|
//! | `qemu` (default) | QEMU's `netduinoplus2` (STM32F405: USART1, no GPIO model) | [`qemu`] |
//! | `board` | STM32F4-Discovery (STM32F407VG, 8 MHz crystal) | [`discovery`] |
//! | `board,skr2` | BigTreeTech SKR 2 (STM32F407VG, 8 MHz crystal, 32 KiB bootloader) | [`skr2`] |
//!
//! Inputs have the internal pull-up and are read active low: a switch that
//! closes to ground (normally open) is active, an unwired input inactive
//! (Grbl's default; `$5`/`$14` invert for normally closed switches).

pub mod discovery;
pub mod qemu;
pub mod skr2;

/// A GPIO pin: port (0 = A … 8 = I) and number.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PinId {
    /// Port, 0 = GPIOA.
    pub port: u8,
    /// Pin number, 0-15.
    pub n: u8,
}

/// A pin of port A-E.
pub const fn pa(n: u8) -> PinId {
    PinId { port: 0, n }
}
/// Port B.
pub const fn pb(n: u8) -> PinId {
    PinId { port: 1, n }
}
/// Port C.
pub const fn pc(n: u8) -> PinId {
    PinId { port: 2, n }
}
/// Port D.
pub const fn pd(n: u8) -> PinId {
    PinId { port: 3, n }
}
/// Port E.
pub const fn pe(n: u8) -> PinId {
    PinId { port: 4, n }
}

/// A timer channel driving a pin (the spindle's PWM): TIM3 on every board
/// here (APB1 timer clock, 84 MHz).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PwmPin {
    /// The pin.
    pub pin: PinId,
    /// Its alternate function (TIM3: AF2).
    pub af: u8,
    /// TIM3 channel, 1-4.
    pub channel: u8,
}

/// The flash sector the settings are kept in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SettingsSector {
    /// Its address.
    pub addr: u32,
    /// Its number (FLASH_CR.SNB).
    pub number: u8,
    /// Its size, bytes.
    pub bytes: u32,
}

/// Everything pin- and board-specific.
#[derive(Clone, Copy, Debug)]
pub struct PinMap {
    /// The board's name (logged at start-up).
    pub name: &'static str,
    /// The crystal, Hz (the PLL is derived from it).
    pub hse_hz: u32,
    /// The link: USART1 transmit and receive pins (AF7).
    pub link_tx: PinId,
    /// USART1 receive.
    pub link_rx: PinId,
    /// Step outputs, X Y Z.
    pub step: [PinId; 3],
    /// Direction outputs.
    pub dir: [PinId; 3],
    /// Driver enable outputs (one pin may serve every axis).
    pub enable: &'static [PinId],
    /// Limit switches per axis, `[min, max]` (one pin may be both ends).
    pub limits: [[Option<PinId>; 2]; 3],
    /// The e-stop input.
    pub estop: Option<PinId>,
    /// The probe input (G38.2-.5; `$6` its polarity).
    pub probe: Option<PinId>,
    /// Spindle enable output.
    pub spindle_enable: Option<PinId>,
    /// Spindle direction output (high: counter-clockwise, M4).
    pub spindle_dir: Option<PinId>,
    /// Spindle speed, PWM.
    pub spindle_pwm: Option<PwmPin>,
    /// Flood coolant output (M8).
    pub flood: Option<PinId>,
    /// Mist coolant output (M7).
    pub mist: Option<PinId>,
    /// Outputs driven high at start-up (a board's driver power switch).
    pub power_on: &'static [PinId],
    /// Where the settings live.
    pub settings: SettingsSector,
}

#[cfg(all(feature = "qemu", not(feature = "board")))]
pub use qemu::MAP;

#[cfg(all(feature = "board", not(feature = "skr2")))]
pub use discovery::MAP;

#[cfg(all(feature = "board", feature = "skr2"))]
pub use skr2::MAP;

#[cfg(not(any(feature = "qemu", feature = "board")))]
compile_error!(
    "select a target: feature `qemu` (default) or `board` (with `skr2` for the BTT SKR 2)"
);
