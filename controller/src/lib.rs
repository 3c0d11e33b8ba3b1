//! The motion controller's logic without the chip: everything the firmware
//! does that is not pin, timer or UART wiring, built and tested on the host
//! and built for `thumbv7em-none-eabihf` by the firmware.
//!
//! ```text
//! link bytes ─► link::FrameReader ─► session: DeviceLink::on_frame ─► [ring: Cmd] ─► background:
//!   feeder (fuzzy scheduler) ─► planning (velocity planner, ticks ahead) ─► [ring: Setpoint]
//!   ─► tick: TickExecutor ─► stepper/steps: tick plan ─► [ring: TickPlan]
//!   ─► step timer: StepEngine ─► step/dir pins
//! ```
//!
//! | module | what |
//! |---|---|
//! | [`settings`] | build-time defaults of the machine settings, sizes of every queue and lookahead |
//! | [`config`] | the machine settings at run time: ids, units, ranges, the planner's settings from them |
//! | [`store`] | the settings in a flash sector: versioned, CRC-checked records |
//! | [`command`] | the path commands queued from the link to the scheduler, checked on arrival |
//! | [`feeder`] | commands into the fuzzy scheduler (first stage) |
//! | [`planning`] | scheduled points into the velocity planner, setpoints out, the feeding policy (second stage) |
//! | [`controls`] | hold, resume, override and Njiri et al.'s force loop |
//! | [`fault`] | the last hard fault, kept across the reset and reported at the next boot |
//! | [`tick`] | the tick's work: next setpoint to the step output, counters |
//! | [`stepper`] | the step output the tick drives: plans to a timer-driven engine, or the engine run in software (QEMU) |
//! | [`steps`] | step generation with real timing: per-tick plans of exact step times, the engine a step timer's interrupt runs (pulse width, low time, DIR setup, polarity, per-axis steps/mm), lag reported |
//! | [`session`] | the device side of the link: sequence, credit, replies (sans-IO) |
//! | [`tx`] | the transmit buffer and the background's reserve in it |
//! | [`alarm`] | the alarm state and the tick's stops, shared by every task (lock-free) |
//! | [`guard`] | the tick's safety work: inputs debounced, e-stop and hard limits, the stop within the tick |
//! | [`homing`] | the homing cycle: seek, back off, locate, pull off, machine coordinates |
//! | [`probe`] | the probe input and the probing move (G38.2-.5): the trip latched where the steps were |
//! | [`spindle`] | spindle and coolant commands of the path stream, PWM duty |
//! | [`background`] | one pass of the firmware's idle loop |
//! | [`ring`] | lock-free single-producer single-consumer ring, panic-free |
//! | [`checksum`] | FNV-1a over commanded positions |
//! | [`replay`] | whole paths in a fixed order: the cost benchmark and its host twin |
//! | `sim` | (feature `std`) the whole controller on the host: the firmware's tasks as methods |
//!
//! The firmware's tasks call into these, nothing else: `tick` calls
//! [`tick::TickExecutor::tick`], the USART interrupt feeds
//! [`session::DeviceLink::on_frame`], idle runs
//! [`background::Background::step`]. Every lock the firmware takes is
//! passed in as an `rtic_core::Mutex` (RTIC's resource proxies implement
//! it; host tests use a plain one).
#![cfg_attr(not(any(test, feature = "std")), no_std)]
#![deny(missing_docs)]

pub mod alarm;
pub mod background;
pub mod checksum;
pub mod command;
pub mod config;
pub mod controls;
pub mod fault;
pub mod feeder;
pub mod guard;
pub mod homing;
pub mod planning;
pub mod probe;
pub mod replay;
pub mod ring;
pub mod session;
pub mod settings;
#[cfg(feature = "std")]
pub mod sim;
pub mod spindle;
pub mod stepper;
pub mod steps;
pub mod store;
pub mod tick;
pub mod tx;
