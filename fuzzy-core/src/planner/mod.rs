//! Feasible motion: a streaming, acceleration- and jerk-limited velocity
//! planner over the scheduled feed, and the interpolation executor that
//! follows it tick by tick.
//!
//! The fuzzy scheduler says how fast the tool *should* go at each point;
//! [`Motion`] makes the motion physically feasible. Points go in (with their
//! scheduled feed and curvature); every tick ([`Motion::tick`]) a commanded
//! position comes out.
//!
//! # Ceilings (per point) and caps (per segment)
//! At each point the speed may not exceed:
//! - the scheduled feed of both adjacent moves;
//! - per-axis velocity on both adjacent segments (`v·|d_a| <= V_a`);
//! - the direction changes near it: the commanded positions form a polyline,
//!   and a vertex passed at speed `v` changes axis `a`'s velocity by
//!   `v·|Δd_a|` within one tick. Summing the changes of all vertices within
//!   2.5 ticks of travel (at the maximum feed) and reserving `(1 − ρ)` of
//!   each axis' acceleration for them: `v·Σ|Δd_a| <= (1 − ρ)·A_a·Ts`. On a
//!   densely sampled curve this is the centripetal limit `v²κ <= (1 − ρ)A`;
//!   at a sharp corner it slows the tool to what one tick can turn;
//! - the chord-error bound of the interpolation period,
//!   `v <= (2/Ts)·√(2δ/κ − δ²)` (the chord of one tick on a circle of
//!   curvature κ deviates at most δ);
//! - at the start and end of a path (and at the end of what is buffered) the
//!   creep speed `J·Ts²/2`, i.e. a stop.
//!
//! A segment shorter than the corner reach inherits its end points' ceilings
//! (they hold along it); a longer one only at its ends.
//!
//! # Envelope (backward pass)
//! `T_i = min(ceilings, caps, √(T_{i+1}² + 2·D_env·L_i))`, `D_env = 0.95·ρ·A`:
//! from `T_i` every later ceiling stays reachable. The newest planned point
//! is a stop (`T = creep`), so an underrun or a feed hold never needs more
//! deceleration than allowed; each new point raises the tail and the update
//! runs backwards only while values change (bounded by `N`).
//!
//! # Executor (forward, jerk-limited)
//! Each tick the executor tries jerk `+J`, `0`, `−J` (acceleration clamped to
//! `±ρ·A`) and keeps the first whose result is *safe*: the committed stop
//! from there (jerk down to `−ρA`, hold, jerk back to zero so that speed and
//! acceleration reach zero together) meets no ceiling too fast. The stop is
//! checked exactly (arrival speed at each point, by bisection on its
//! distance) while its deceleration is below `D_env` (its start and its final
//! ramp); during its constant-deceleration phase it falls faster than the
//! envelope, so being under the envelope where that phase begins suffices.
//! When no candidate is safe (the stop changes phase inside the tick), the
//! executor follows the committed stop exactly. Hence, by construction:
//! tangential jerk `<= J`, tangential acceleration `<= ρA`, every ceiling
//! respected. The per-axis jerk of a polyline is not bounded by any speed
//! profile (each vertex is a direction step within one tick); this planner
//! bounds the tangential jerk, as the issue allows.
//!
//! Cost: per point, the ceiling (a window sum from running sums) and an
//! envelope update; per tick, up to three checks of the committed stop
//! against the points it can reach.

mod brake;
mod config;
mod motion;
mod q;

pub use config::{ConfigError, MotionConfig};
pub use motion::{Motion, MotionError, MotionPoint, MotionState, PlannedPoint, Tick};
