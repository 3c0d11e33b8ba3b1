//! Feasible motion: a streaming, acceleration- and jerk-limited velocity
//! planner over the scheduled feed, and the interpolation executor that
//! follows it tick by tick.
//!
//! The fuzzy scheduler says how fast the tool *should* go at each point;
//! [`Motion`] makes the motion physically feasible. Points go in (with their
//! scheduled feed and curvature: [`MotionPoint`]); every tick
//! ([`Motion::tick`]) a commanded position comes out. None of this is from
//! the seed papers (Lin et al. hand their feeds to the CNC's own
//! acc/dec control, whose path error Dat & Phuc analyse); it is what a
//! motion controller needs around them.
//!
//! Units: per-tick, raw Q32 (`i64`, 32 fractional bits): mm, mm/tick,
//! mm/tick², mm/tick³, so integrating a tick needs no multiplication by the
//! period. Buffered speeds are stored in 32 bits as Q28 (below 16 mm/tick),
//! rounded down (they are upper bounds).
//!
//! # Ceilings (per point) and caps (per segment)
//! At each point the speed may not exceed:
//! - the programmed (scheduled) feed of both adjacent moves, times the
//!   override, within the configured maximum feed;
//! - per-axis velocity on both adjacent segments (`v·|d_a| <= V_a`);
//! - the direction changes near it: the commanded positions form a polyline,
//!   and a vertex passed at speed `v` changes axis `a`'s velocity by
//!   `v·|Δd_a|` within one tick. The vertices within 2.5 ticks of travel *at
//!   that speed* (both sides) share the reserve `(1 − ρ)·A_a` of each axis'
//!   acceleration: `v·Σ|Δd_a| <= (1 − ρ)·A_a·Ts`, solved for the largest
//!   `v` (the sum grows with the window, so vertices are taken in order of
//!   distance). This is safe for every tick (a tick's second difference
//!   weighs each vertex within one tick of travel by at most `v·Ts`, and
//!   the ticks touching a vertex reach 2 ticks either side; 2.5 covers
//!   the speed changing within them) and exact at a single sharp corner
//!   (it slows the tool to what one tick can turn); on a densely sampled
//!   curve it is conservative: the centripetal acceleration `v²κ` stays
//!   below `(1 − ρ)·A/5`;
//! - the chord-error bound of the interpolation period,
//!   `v <= (2/Ts)·√(2δ/κ − δ²)` (the chord of one tick on a circle of
//!   curvature κ deviates at most δ);
//! - at the start and end of a path the creep speed `J·Ts²/2`, i.e. a stop.
//!
//! A segment shorter than the corner reach (2.5 ticks at the maximum feed)
//! also inherits its end points' ceilings (they hold along it).
//!
//! # Envelope (backward pass)
//! `T_i = min(ceilings, caps, √(T_{i+1}² + 2·D_env·L_i))`,
//! `D_env = 0.95·ρ·A`: from `T_i` every later ceiling stays reachable with
//! deceleration `D_env`. The end of what is buffered is a stop: the
//! envelope at arc length `x` is also at most `√(creep² + 2·D_env·(s_tail −
//! x))`, computed on the fly, so a buffer underrun or a feed hold never needs
//! more deceleration than allowed and a new point costs only the update of
//! the envelope it lowers (backwards while values change; `N` at most, and
//! typically a few nodes). A node is *binding* when its envelope is set by
//! its own ceiling or caps rather than by the reach from the next node.
//!
//! # Executor (forward, jerk-limited)
//! Each tick the executor tries jerk `+J` (near rest also `J/8`, `J/64`),
//! then `0` (acceleration clamped to `±ρA`), and keeps the first whose
//! result is *safe*: the committed stop from there (jerk down to `−ρA`,
//! hold, jerk back to zero so that speed and acceleration reach zero
//! together: `brake`) stays under the envelope. Where the stop decelerates
//! harder than `D_env` its speed falls faster than the envelope, so only
//! the stretches where it decelerates less (its start, up to `D_env`, and
//! its final ramp) need checking, and within them only the binding nodes:
//! along a non-binding node's segment the envelope falls at `D_env`, faster
//! than the stop, so the next binding node or the end of the stretch is the
//! tighter check (the end of the first stretch is checked against the
//! envelope there). A node's check is exact: the stop's speed rises then
//! falls, so it exceeds a limit on one time interval, found from the
//! quadratic of each constant-jerk phase, and the node's distance must lie
//! outside it. Nodes crossed within the tick are checked the same way. When
//! no candidate is safe (a phase change inside the tick, a feed hold, a
//! lower override), the executor follows the committed stop exactly. Hence
//! tangential jerk `<= J`, tangential acceleration `<= ρA`, and every
//! physical ceiling respected (a lower override is reached at the
//! acceleration limit, as in Grbl). The per-axis jerk of a polyline is not
//! bounded by any speed profile (each vertex is a direction step within one
//! tick); this planner bounds the tangential jerk, as issue 6 allows.
//!
//! At a stop (the end of a path, or of what is buffered) the tool arrives at
//! creep speed or less and steps onto the point (a speed step of at most
//! `J·Ts²/2`).
//!
//! # Cost
//! Per point: a window over the vertices within the corner reach, a few
//! divisions and square roots, and the envelope update. Per tick: one or two
//! candidate checks, each a stop (three phases) and the binding nodes
//! within its start and end ramps. Arithmetic is 64-bit with 32×32-bit
//! products and soft-float quotients and roots on the hardware's 32-bit
//! divide (`q`): no 128-bit division. Measured on the Cortex-M4 target in
//! `firmware/` (README there).

mod brake;
mod config;
mod motion;
mod q;

pub use config::{ConfigError, MotionConfig};
pub use motion::{Motion, MotionError, MotionPoint, MotionState, PlannedPoint, Tick};
