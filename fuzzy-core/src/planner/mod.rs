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
//! period; in the public [`Tick`] typed as [`SpeedMmPerTick`](crate::units::SpeedMmPerTick) and
//! [`AccelMmPerTick2`](crate::units::AccelMmPerTick2) ([`Motion::speed_mm_per_min`] converts with the
//! configured period). Buffered speeds are stored in 32 bits as Q28 (below
//! 16 mm/tick), rounded down (they are upper bounds).
//!
//! # Stages
//! One stage per file, each handing one type to the next, as Grbl's
//! `planner.c` hands its blocks to `stepper.c`:
//!
//! | file | stage | takes | hands on |
//! |---|---|---|---|
//! | `lookahead.rs` | the point buffer, ceilings, caps, backward envelope | [`MotionPoint`] | the finalized nodes (`Lookahead`, read only) |
//! | `executor.rs` | the per-tick jerk-limited profile, its committed stop (`brake.rs`), the position | `&Lookahead` | [`Tick`] |
//! | `controller/src/steps` (firmware side) | exact step times per tick | the tick's setpoint | step pulses |
//!
//! Shared by the stages: `fuzzy-core/src/segment.rs` (one move's unit
//! direction and length, on the same scaled difference as the scheduler's
//! curvature chords: the lookahead measures each move when it is pushed and sums the
//! lengths into the arc lengths the executor follows; the executor measures
//! the segment it enters again with the same function, from the same two
//! node positions, rather than the buffer keeping 12 more bytes per node),
//! `config.rs` ([`MotionConfig`] compiled
//! once into per-tick limits), `q.rs` (Q32 arithmetic). `motion.rs` holds
//! [`Motion`], the one entry point over both stages. The configuration is
//! read through `&`; the only `&mut` per tick is the executor's state (arc
//! length, speed, acceleration, segment) and the buffer dropping the nodes
//! the executor has left behind. Each stage file states its invariants at
//! its top.
//!
//! # Ceilings (per point) and caps (per segment)
//! At each point the speed may not exceed:
//! - the programmed (scheduled) feed of both adjacent moves, times the
//!   override, within the configured maximum feed;
//! - per-axis velocity on both adjacent segments (`v·|d_a| <= V_a`);
//! - the direction changes near it: the commanded positions form a polyline,
//!   and a tick's second difference of axis `a` at a tool position `c`
//!   (steps of `u = v·Ts` either side) is the tangential change plus
//!   `Σ_k Δd_k,a · w_k`, where each vertex `k` within `u` of `c` weighs
//!   `w_k = u − |s_k − c|` (a hat: the travel between the vertex and the far
//!   end of the stencil). Near vertices the executor keeps the tangential
//!   acceleration within `ρ·min A`, so its part on axis `a` is at most
//!   `ρ·min A·τ_a`, where `τ_a` bounds `|d_a|` of every segment in the
//!   stencil: the outgoing segment's `|d_a|` plus the `|Δd_k,a|` of the
//!   vertices counted (the segments' directions differ by those), capped
//!   at one. That leaves `B_a = A_a − ρ·min A·τ_a` (at least
//!   `(1 − ρ)·A_a`) for the direction changes: `Σ_k |Δd_k,a|·(u − |s_k − c|)⁺ <= B_a·Ts²`
//!   (the per-axis box shared as the local geometry allows: an axis
//!   along the normal, where the tangent has no component, gets nearly
//!   all of `A_a` for the turn). As a function of `c` that sum is piecewise
//!   linear with its peaks at vertices, so checking it with `c` at every
//!   point is enough: the ceiling is the largest `v` meeting it at the point
//!   (vertices taken in order of distance, `u` solved on the last linear
//!   piece). It is exact at a single sharp corner (`v·|Δd_a| <= B_a·Ts`:
//!   what one tick can turn) and gives `v²κ·|n_a| <= A_a − ρ·min A·|t_a|`
//!   on a densely sampled curve (normal `n`, tangent `t`). The speed is
//!   taken as equal on both sides of the stencil (the acceleration within
//!   a tick is neglected in the weights: a relative `ρ·A·Ts/v`; the property tests check the
//!   resulting per-axis acceleration);
//! - the chord-error bound of the interpolation period,
//!   `v <= (2/Ts)·√(2δ/κ − δ²)` (the chord of one tick on a circle of
//!   curvature κ deviates at most δ);
//! - at the start and end of a path the creep speed `J·Ts²/2`, i.e. a stop;
//!   on an exact path (`exact_path`, G61) also at every vertex where the
//!   path turns (beyond the rounding of collinear moves), as LinuxCNC's
//!   exact path mode stops at every junction that is not collinear (its
//!   G61 documentation): a polyline arc stops at each of its points.
//!
//! A segment shorter than the corner reach (2.5 ticks at the maximum feed,
//! also how far ahead a point waits for its neighbours before its ceiling
//! is final) inherits its end points' ceilings (they hold along it), but
//! never below 2/5 of its length per tick: up to that speed no stencil
//! inside it holds both its end points, so each point of it sees the one
//! nearer vertex and what lies beyond it, as on a segment longer than the
//! reach (the same 2.5 ticks; without smoothing: the window's reach is
//! longer).
//! A full buffer whose unfinalized points all lie within the reach (very
//! dense or repeated points) would wait forever: then, with the tool at
//! rest on the end of what is planned, the next point is fixed anyway, its
//! speed a tick's travel short of the newest point (whose turn is not known
//! yet), and when only the newest is left the oldest point behind the tool
//! is dropped (later ceilings stay a tick's travel short of it): the tool
//! stops at each such point but never stalls.
//!
//! # Smoothing (corner blending)
//! With `smoothing_ticks = n > 1` (by default the most ticks that validate:
//! `smoothing_ticks = 0`, [`MotionConfig::smoothing`]) the commanded position is the mean of the
//! executor's last `n` positions (`smoothing.rs`: a moving-average FIR
//! filter on the interpolated positions, as Klipper's input shaper and
//! axis smoothing weigh the motion over a time window,
//! `klippy/chelper/kin_shaper.c`, `kin_smooth_axis.c`; the box itself is
//! the linear "acc/dec after interpolation" of FANUC-style controls, whose
//! contour error Dat & Phuc 2024 analyse; here its deviation is bounded in
//! the lookahead instead of predicted afterwards). A corner is then turned over
//! `n` ticks instead of one, so it may be passed up to `n` times faster for
//! the same per-axis acceleration, and the tool cuts it by a bounded
//! amount. The output's second and third differences are means of the
//! executor's, so every bound of the executor's positions still holds; the
//! direction-change ceiling is replaced by the window test of
//! `Lookahead::window_probe` (per axis: the mean of `n` ticks' hats is a
//! trapezoid, checked at its corners `s_i ± (n − 1)·U/2`; and the blend's
//! deviation from the polyline `g_n·Σ‖Δd_k‖·(U − 2δ_k/n)⁺ <= δ`, the
//! chord tolerance, `g_n = (2n² + 1 + n mod 2)/(16n)`, below), solved for the speed by
//! safeguarded Newton steps on its piecewise-linear conditions
//! (`Lookahead::window_limit`). A vertex weighs the step that crosses it (the sum of its hats
//! over the ticks is that step): the node's own taken as `u` (the change
//! of speed within a tick neglected, as in the single-tick corner limit),
//! its neighbours' within the window (`n + 1` steps) at most
//! `U = u + n·ρA` (the window margin); the deviation's points lie within
//! `n` steps of the crossing, `U_dev = u + (2n − 1)·ρA/2` for every
//! vertex. The deviation kernel is
//! exact for a single vertex and on a densely sampled curve; for vertices
//! closer than the window it is checked, not proven (the property tests
//! hold every commanded position within the tolerance of the polyline).
//! The deviation bounded is that of the commanded moves from the
//! polyline's vertices, blend and chord of a tick together (the split of
//! the tolerance between them is the geometry's, not a fixed share): the
//! points of the move between two averaged positions are themselves
//! averages of `n + 1` positions (weights `(1 − t)/n, 1/n, …, 1/n, t/n`),
//! and the kernel checked is the largest of theirs. On a circle at `n = 2`
//! that is `u²κ/8` for the averaged positions plus `u²κ/8` for the chord
//! between them, `u²κ/4` in all; at a single corner `9/32·u·‖Δd‖` (at
//! `t = 1/4`) against `u·‖Δd‖/4` for the positions alone. The chord bound
//! from the curvature stays as without smoothing (it is weaker).
//! The corner reach grows to `(n + 1)` ticks at the maximum feed plus the
//! margin. With smoothing the position trails the tick's arc length, speed
//! and acceleration (the executor's) by `(n − 1)/2` ticks, and a stop ends
//! (`MotionState::Done`, [`Motion::at_rest`]) only when the mean has
//! reached the point exactly (`n − 1` ticks after the executor).
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
//! lower override), the executor follows the committed stop exactly, unless
//! the acceleration is within a tick's jerk of zero and the tick that ends
//! at zero acceleration is safe: a tick's jerk steps the acceleration by
//! `J·Ts`, so from an acceleration off that grid zero is out of reach, and
//! at a ceiling the tool would hunt between a step above zero and the
//! stop's step below it from tick to tick. When
//! a tick's jerk is large against the acceleration bound (`J·Ts > ρA/8`),
//! the steps between candidates are too coarse (at `J·Ts >= ρA` a tick goes
//! from no acceleration to full), and riding a ceiling would alternate
//! between full acceleration and the stop from tick to tick; there the
//! executor also halves the range of the tick's end acceleration three
//! times between the last safe candidate and the first unsafe one, trying
//! zero first where the range holds it, each end acceleration reached at
//! the jerk limit and then held (the jerk then is within `±J` as well, and
//! the tool settles on a ceiling with zero acceleration); above a hold it
//! goes on halving (up to eight times) until one is safe, so that the speed
//! settles on the ceiling itself rather than up to an eighth of a tick's
//! speed change below it. At any jerk limit it also halves below the hold
//! while the committed stop ends within a tick's travel of the end of what
//! is planned, so that the stop lands on that point instead of short of it
//! (a creep of several ticks otherwise, whose length varies with every
//! limit: cycles not monotone in the limits). Hence
//! tangential jerk `<= J`, tangential acceleration `<= ρA`, and every
//! physical ceiling respected (a lower override is reached at the
//! acceleration limit, as in Grbl). The per-axis jerk of a polyline is not
//! bounded by any speed profile (each vertex is a direction step within one
//! tick); this planner bounds the tangential jerk, as issue 6 allows.
//!
//! At a stop (the end of a path, or of what is buffered) the tool arrives at
//! creep speed (`min(J·Ts, ρ·A)·Ts/2`) or less (or rests within
//! `min(J·Ts³/2, ρA·Ts²)` of it) and steps onto the point, only when that last step, and the rest
//! after it, keep the third difference of the arc length within `J·Ts³`. A corner is never passed
//! slower than the creep speed, nor faster than a reversal allows within
//! the corner share (so the tool never stalls on one).
//!
//! # Resolution
//! Positions, speeds and accelerations are Q32 per tick (2^-32 mm ≈ 0.23
//! pm). The per-tick jerk is rounded down to an even number of quanta, so a
//! tick at full jerk changes the speed by exactly `J/2` and a stop's final
//! ramp keeps `v − a²/2J` (the distance from the curve on which speed and
//! acceleration reach zero together) constant. Where that ramp begins part
//! way through a tick, the acceleration is rounded to a quantum, which moves
//! the state off the curve by up to `|a|/J` quanta of speed (at most `ρA/J`
//! per tick, e.g. 20 at 1 kHz with the defaults); the stop sheds that in its
//! last tick, so the arc length's third difference may exceed `J·Ts³` by
//! that many quanta (4.7 pm at the defaults, 0.009 % of `J`). The
//! tangential jerk of the planned profile itself never exceeds `J`.
//! `ConfigError::Resolution` refuses a jerk below 256 quanta per tick.
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
mod executor;
mod lookahead;
mod motion;
mod q;
mod smoothing;

pub use config::{ConfigError, MotionConfig, SMOOTHING_AUTO_MAX, SMOOTHING_MAX};
pub use executor::{MotionState, Tick};
pub use lookahead::{MotionError, MotionPoint, PlannedPoint};
pub use motion::Motion;
