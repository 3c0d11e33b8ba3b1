//! STM32F4-Discovery (STM32F407VGT6, 8 MHz crystal on HSE).
//!
//! Every pin here is free on the board: ST's user manual UM1472
//! ("Discovery kit with STM32F407VG MCU", the table of MCU pins against
//! board functions; the LEDs, button, USB, audio DAC and its I2C and reset
//! also in Zephyr's board file, `zephyrproject-rtos/zephyr`,
//! `boards/st/stm32f4_disco/stm32f4_disco.dts`) gives PE0/PE1 to the
//! accelerometer's interrupts, PE3 to
//! its chip select, PA5-PA7 to its SPI, PA9 to USB VBUS (with a 4.7 µF
//! capacitor, which rounds a UART's edges), PA10-PA12 to USB OTG, PA0 to
//! the user button, PA4, PC7, PC10, PC12 to the audio DAC's I2S, PB6/PB9 to
//! its I2C, PD4 to its reset, PD5 and PC0 to USB power, PD12-PD15 to the
//! LEDs, PC3 and PB10 to the microphone, PA13/PA14/PB3 to the debugger,
//! PB2 is BOOT1. So the link is USART1 remapped to PB6/PB7 (AF7; PB6 is the
//! DAC's I2C clock, whose data line PB9 stays idle, so the DAC never sees
//! an I2C start), the axes and the driver enable on port E from PE7, the
//! switches and the machine outputs on port D, PA1 and PA2, the spindle's PWM on
//! PB0 (TIM3 channel 3, AF2).
//!
//! | function | pin |
//! |---|---|
//! | link TX / RX (USART1, AF7) | PB6 / PB7 |
//! | X step / dir | PE7 / PE8 |
//! | Y step / dir | PE9 / PE10 |
//! | Z step / dir | PE11 / PE12 |
//! | driver enable (all axes) | PE14 |
//! | X min / max limit | PD0 / PD1 |
//! | Y min / max limit | PD2 / PD3 |
//! | Z min / max limit | PD6 / PD7 |
//! | e-stop | PA1 |
//! | probe | PA2 |
//! | spindle enable / direction | PD8 / PD9 |
//! | spindle PWM (TIM3 CH3, AF2) | PB0 |
//! | coolant flood / mist | PD10 / PD11 |
//! | settings | flash sector 1, 0x0800_4000, 16 KiB |

use super::{pa, pb, pd, pe, PinMap, PwmPin, SettingsSector};

/// The Discovery's pins.
pub const MAP: PinMap = PinMap {
    name: "STM32F4-Discovery",
    hse_hz: 8_000_000,
    link_tx: pb(6),
    link_rx: pb(7),
    step: [pe(7), pe(9), pe(11)],
    dir: [pe(8), pe(10), pe(12)],
    enable: &[pe(14)],
    limits: [
        [Some(pd(0)), Some(pd(1))],
        [Some(pd(2)), Some(pd(3))],
        [Some(pd(6)), Some(pd(7))],
    ],
    estop: Some(pa(1)),
    probe: Some(pa(2)),
    spindle_enable: Some(pd(8)),
    spindle_dir: Some(pd(9)),
    spindle_pwm: Some(PwmPin {
        pin: pb(0),
        af: 2,
        channel: 3,
    }),
    flood: Some(pd(10)),
    mist: Some(pd(11)),
    power_on: &[],
    settings: SettingsSector {
        addr: 0x0800_4000,
        number: 1,
        bytes: 16 * 1024,
    },
};
