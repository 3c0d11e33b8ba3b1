//! The contour-error feed controller of Cho, Lee & Jeon, "Design of Fuzzy
//! Logic Controllers for High-Speed and High-Accuracy CNC machines"
//! (undated; it cites work up to 2000): the controller as data on the
//! generic engine ([`data`]), the feed law around it ([`law`]) and the
//! online contour-error estimate it needs ([`contour`]).
//!
//! | paper | here |
//! |---|---|
//! | section 2.2: contour error from "two closest points" in a variable window | [`contour::ContourTracker`] |
//! | eq. 3.1: membership `exp(−(x − b)²/a)`, five terms per variable | [`TERMS`] |
//! | Table 3.1: 8 legible cells of 25 | [`RULES_PRINTED`], completed in [`RULES`] |
//! | section 3: Mamdani, min AND, centroid | [`SYSTEM`], [`CONTROLLER`] |
//! | eq. 3.2-3.3, section IV: gains, `F(k) = F(k−1) + g_dF·u(k)` | [`FeedLaw`], [`FeedLawConfig::paper`] |
//!
//! Every interpolation tick `k` the contour error `ε_c(k)` (online, from
//! [`contour`]) and its change `Δε_c(k) = ε_c(k) − ε_c(k−1)`
//! (eq. 3.2) are scaled by gains set from the contour-error bound, the
//! Mamdani controller gives a normalised feed change `u(k)`, and
//!
//! ```text
//! ΔF(k) = g_dF · u(k),    F(k) = F(k−1) + ΔF(k)          (eq. 3.3)
//! ```
//!
//! is the feed the interpolator uses for the next knot point (Fig. 3.1).
//!
//! # The controller (section 3)
//!
//! - **Membership** (eq. 3.1): `μ(x) = exp(−(x − b)²/a)`, for the inputs and
//!   the output. The paper calls it "bell shape"; the equation is a
//!   Gaussian (MATLAB `gaussmf` with `σ = √(a/2)`), not MATLAB's
//!   generalised bell `gbellmf`, and we follow the equation. The paper gives
//!   neither `a` nor `b`: five terms NB NS ZO PS PB per variable, centres
//!   `b = −1, −0.5, 0, 0.5, 1` on normalised universes `[−1, 1]`, and
//!   `a = 0.09` (`σ = 0.2121`), so neighbours cross at degree 0.5.
//! - **Inputs** `e = g_e·ε_c`, `Δe = g_ce·Δε_c`, with "the gain g_e for the
//!   error and the gain g_ce for the change of contour error … scaled as
//!   contour error bound" (section IV): `g_e = 1/ε_max`, so PB is the bound
//!   itself, and `g_ce = K/ε_max`, so PB of the change is an error that
//!   would cross the whole bound in `K` ticks. `K` is not in the paper; we
//!   chose `K = 10` ticks (10 ms at host-sim's 1 ms period, about the servo's
//!   response time, 1/ω_n ≈ 3 ms, times three). Inputs are clamped to
//!   `[−1, 1]`: an error beyond the bound counts as PB.
//! - **Output** `u ∈ [−1, 1]`, five terms as the inputs, Mamdani with min
//!   AND, min implication, max aggregation and the centroid over 101 samples
//!   (MATLAB's default; the exact closed form of the engine needs
//!   piecewise-linear output terms). `g_dF = 0.35` (section IV): the paper
//!   gives no unit; we take the feed in mm/s, so `|ΔF| ≤ 0.35 mm/s` per
//!   tick, i.e. the feed changes by at most 350 mm/s² at 1 ms.
//!
//! # Table 3.1: what survives and what we chose
//!
//! The paper's Table 3.1 (as we have it) lost its column headers and 17 of its 25 cells.
//! Eight cells survive, which matches section IV's "eight fuzzy if-then
//! control rules" (section 3.3 says 6). The rows are `Δε` = PB, PS, ZE, NS,
//! NB from top to bottom; we read the columns `ε` in the same order, PB..NB.
//! Then the printed cells say: a small error that **shrinks** (ε and Δε of
//! opposite signs) raises the feed a lot (PB), one that **grows** (same
//! signs) raises it a little (PS), a zero error raises it a lot, a big
//! steady error lowers it (NS). Read the other way round (columns NB..PB)
//! they would raise the feed hardest while the error grows, against the
//! paper's aim of holding the error within the bound.
//!
//! The eight rules alone ([`RULES_PRINTED`]) leave the controller without
//! an answer for a big error that keeps growing (PB/PS: the cell is empty,
//! only neighbours fire weakly and the feed is held, not lowered), so the
//! default ([`RULES`]) completes the table by the same logic, keeping the
//! eight printed cells: the output falls as `|ε|` grows and as the error's
//! growth `sign(ε)·Δε` grows, and the table is odd-symmetric
//! (`(ε, Δε)` and `(−ε, −Δε)` give the same output, as the printed cells
//! are), so that only the error's size and whether it grows matter.
//!
//! ```text
//!            ε:  PB   PS   ZO   NS   NB
//!   Δε = PB      NB   ZO   PS   PB   PS
//!        PS      NB  [PS] [PB] [PB]  ZO
//!        ZO     [NS]  PS   PB   PS  [NS]
//!        NS      ZO  [PB] [PB] [PS]  NB
//!        NB      PS   PB   PS   ZO   NB        [..]: printed in the paper
//! ```
//!
//! host-sim's `cho` subcommand runs both tables.

pub mod contour;
pub mod data;
pub mod law;

pub use contour::{ContourError, ContourEstimate, ContourTracker};
pub use data::*;
pub use law::*;
