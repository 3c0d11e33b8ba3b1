//! Step generation with real timing: each tick's setpoint becomes, per
//! axis, a plan of step crossings at exact times ([`plan`], in the tick),
//! which a hardware timer's compare interrupt turns into pin edges
//! ([`engine`]), keeping pulse width, low time and direction setup, and
//! reporting every step it could not emit within its tick ([`report`]).
//!
//! | module | what |
//! |---|---|
//! | [`config`] | settings (steps/mm and polarity per axis, pulse, setup, coalescing, reversal filter), checked, in timer counts |
//! | [`plan`] | setpoint → per-axis crossing count, direction, first time, interval (the tick) |
//! | [`engine`] | plans → timed pin edges (the step timer interrupt) |
//! | [`queue`] | the plan queue from the tick to the engine, lock-free |
//! | [`report`] | lag and late-plan counters shared by the two, faults |
//! | `sim` | (feature `std`) the engine under a simulated timer, every edge recorded |
//!
//! The pipeline in time: the tick at `t_k` plans the move to setpoint `k`
//! (the position at the end of tick `k`) and queues it; the engine runs it
//! over the window `[t_k + 1.5 T, t_k + 2.5 T]` (`T` one tick), so the
//! motion on the pins is the setpoints' linear interpolation delayed by
//! 1.5 ticks.

pub mod config;
pub mod engine;
pub mod plan;
pub mod queue;
pub mod report;
#[cfg(feature = "std")]
pub mod sim;

pub use config::{AxisConfig, StepConfig, StepConfigError, StepSettings, StepsPerMm, Timing};
pub use engine::{Due, Edges, StepEngine};
pub use plan::{Planner, TickPlan};
pub use queue::{PlanQueue, PlanRx, PlanTx};
pub use report::{StepFault, StepReport, StepShared};
