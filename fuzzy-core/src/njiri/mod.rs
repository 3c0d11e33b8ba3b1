//! The force-feedback feed-override controller of Njiri, Ikua & Nyakoe,
//! "Feedrate optimization for ball-end milling of sculptured surfaces using
//! fuzzy logic controller" (2011, WASET Int. J. of Mechanical and
//! Mechatronics Engineering vol. 5 no. 8), section II: the controller as
//! data on the generic engine ([`data`]) and the step a firmware calls once
//! per spindle revolution ([`law`]).
//!
//! | paper | here |
//! |---|---|
//! | II.A: inputs ΔX = F_Xref − F_X, Δ²X = ΔX(k+1) − ΔX(k), ΔY, Δ²Y | [`ForceOverride::step`] |
//! | "the actual feedrate is computed by multiplying the preprogrammed feedrate by the FRPO" | [`OverrideLaw`] (below) |
//! | II.B: three triangular terms Ne Ze Po on ±1.5 N (Fig. 7) | [`ERROR_TERMS`] |
//! | II.B: FRPO 0-150 %, five trapezoids NS NM Ze PM PL (Fig. 8) | [`FRPO_TERMS`] |
//! | II.C, Table I: 81 rules, only 1-9 and 81 printed | [`consequent`], [`RULES`] |
//! | II.D, eq. 9: min for AND; Mamdani; centre of gravity | [`SYSTEM`] (exact centroid) |
//! | III.A: F_x = 120 N, F_y = 40 N reference peaks | [`OverrideConfig::PAPER`] |
//!
//! # Choices where the paper is incomplete
//!
//! **Rule table (Table I).** Rules 1-9 and 81 are printed; the numbering runs
//! through the terms with Δ²Y fastest (rule `n` has the base-3 digits of
//! `n − 1` as (ΔX, Δ²X, ΔY, Δ²Y) with Ne = 0, Ze = 1, Po = 2). Counting
//! Ne = −1, Ze = 0, Po = +1 and summing the four antecedents gives
//! `s ∈ [−4, 4]`; the printed rules are exactly
//!
//! | s | −4, −3 | −2 | −1, 0 | 1 | 2 | 3, 4 |
//! |---|---|---|---|---|---|---|
//! | FRPO | NS | NM | Ze | *Ze* | *PM* | PL |
//!
//! where rules 1-9 fix `s ≤ 0` (rules 2 and 4, 3 and 7, 6 and 8 show that
//! an error and its change weigh the same), rule 81 fixes `s = 4`, and the
//! italic entries follow by the symmetry of the paper's stated logic
//! ("when cutting force exceeded the reference … reduced the table feed …
//! when the force was below the reference … increased the feedrate"): Ne and
//! Po are mirror images, so `s` and `−s` give mirrored terms (NS ↔ PL,
//! NM ↔ PM, Ze ↔ Ze). X and Y weigh the same because rules 1-9, which vary
//! only Y, give the same outputs as the sum with X's part. [`consequent`]
//! is the generator; a test checks that it reproduces the printed rules.
//!
//! **Membership functions (Figures 7-8 lost).** Inputs: Ne = `trimf(−1.5,
//! −1.5, 0)`, Ze = `trimf(−1.5, 0, 1.5)`, Po = `trimf(0, 1.5, 1.5)`, a
//! partition of ±1.5 N with shoulders at the ends; inputs beyond ±1.5 N are
//! clamped (a 30 N excess counts as fully Ne). Output (percent of the
//! programmed feed): the names say "negative"/"zero"/"positive", i.e. *less
//! than / equal to / more than the programmed feed*, so Ze is centred on
//! 100 %: NS `(0, 0, 10, 30)`, NM `(10, 30, 80, 95)`, Ze `(80, 95, 105,
//! 120)`, PM `(105, 120, 130, 145)`, PL `(130, 145, 150, 150)`. A partition
//! (the exact closed-form centroid applies); Ze alone gives exactly 100 %,
//! NS alone ≈ 11 %, PL alone ≈ 143 %. With max aggregation the output is
//! not strictly monotone in each input: Ze is the consequent of both
//! `s = −1` and `s = 0`, and where two such rules cross the strength of Ze
//! dips (by up to 1.6 % of override on a 0.1 N grid, tested); a larger
//! error in either direction still always moves the override that way.
//!
//! **How FRPO drives the feed.** The paper: "the actual feedrate is computed
//! by multiplying the preprogrammed feedrate by the FRPO". Taken literally
//! ([`OverrideLaw::Absolute`]: override = FRPO) the loop cannot hold a
//! force: the inputs saturate at ±1.5 N while the force moves by ~1.5 N per
//! percent of override, a loop gain of about 70, and the closed loop in
//! host-sim jumps between NS and PL. The paper's result (the override
//! *settles* at 78 % with the force *held* at 120 N) is what an
//! error/change-of-error controller gives in velocity form, the classical
//! reading of such a rule base (the terms are changes: NS … PL about
//! Ze = "no change"): [`OverrideLaw::Incremental`],
//! `override(k) = override(k−1) + g·(FRPO(k) − 100 %)`, clamped to 0-150 %,
//! with `g` = 0.05 by default (at most −4.4 % / +2.2 % per revolution, from
//! NS's and PL's centroids): in host-sim's loop (one revolution of delay,
//! 64 ms acc/dec) a gain of 0.1 leaves a limit cycle around the equilibrium
//! and 0.05 settles (`host-sim njiri --gain 0.1` against the default).
//! Both laws are here; the default is the incremental one. At the first
//! sample there is no previous error: Δ² = 0.
//!
//! The controller is meant to run once per spindle revolution on the peak
//! forces of that revolution ([`PeakWindow`] collects them from raw
//! samples): the paper controls *peak* cutting forces.

pub mod data;
pub mod law;

pub use data::*;
pub use law::*;
