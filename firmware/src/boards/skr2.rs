//! BigTreeTech SKR 2 (rev A: STM32F407VGT6, 8 MHz crystal), with BTT's
//! bootloader in the first 32 KiB (the application at 0x0800_8000, flashed
//! as `firmware.bin` from the SD card).
//!
//! Pins from grblHAL's map of this board (`grblHAL/STM32F4xx`,
//! `boards/btt_skr_2.0_map.h`, commit b7bcf17; its `platformio.ini`
//! environments `btt_skr_2_*` link with `STM32F407VGTX_BL32K_FLASH.ld`,
//! which keeps the settings in sector 11, 0x080E_0000): motor sockets X, Y,
//! Z; one limit connector per axis (grblHAL's "X-", "Y-", "Z-"; here the
//! same pin serves both ends: which end is the homing end is `$23`, as in
//! Grbl); the e-stop on EXP2-4 (grblHAL's reset/e-stop input); the probe on
//! PE4 (grblHAL's `AUXINPUT1`, "Probe", the Z-probe connector); the spindle
//! on EXP1-2 (PWM) and the FAN1/FAN2 MOSFETs (enable, direction), coolant
//! on PB3/PB4; PC13 switches the drivers' power on ("safe power").
//!
//! | function | pin |
//! |---|---|
//! | link TX / RX (USART1 on the TFT header, AF7) | PA9 / PA10 |
//! | X step / dir / enable | PE2 / PE1 / PE3 |
//! | Y step / dir / enable | PD5 / PD4 / PD6 |
//! | Z step / dir / enable | PA15 / PA8 / PD1 |
//! | X / Y / Z limit | PC1 / PC3 / PC0 |
//! | e-stop (EXP2-4) | PA4 |
//! | probe | PE4 |
//! | spindle enable (FAN1) / direction (FAN2) | PB6 / PB5 |
//! | spindle PWM (EXP1-2, TIM3 CH3, AF2) | PB0 |
//! | coolant flood / mist | PB3 / PB4 |
//! | driver power on | PC13 |
//! | settings | flash sector 11, 0x080E_0000, 128 KiB |

use super::{pa, pb, pc, pd, pe, PinMap, PwmPin, SettingsSector};

/// The SKR 2's pins.
pub const MAP: PinMap = PinMap {
    name: "BTT SKR 2",
    hse_hz: 8_000_000,
    link_tx: pa(9),
    link_rx: pa(10),
    step: [pe(2), pd(5), pa(15)],
    dir: [pe(1), pd(4), pa(8)],
    enable: &[pe(3), pd(6), pd(1)],
    limits: [
        [Some(pc(1)), Some(pc(1))],
        [Some(pc(3)), Some(pc(3))],
        [Some(pc(0)), Some(pc(0))],
    ],
    estop: Some(pa(4)),
    probe: Some(pe(4)),
    spindle_enable: Some(pb(6)),
    spindle_dir: Some(pb(5)),
    spindle_pwm: Some(PwmPin {
        pin: pb(0),
        af: 2,
        channel: 3,
    }),
    flood: Some(pb(3)),
    mist: Some(pb(4)),
    power_on: &[pc(13)],
    settings: SettingsSector {
        addr: 0x080E_0000,
        number: 11,
        bytes: 128 * 1024,
    },
};
