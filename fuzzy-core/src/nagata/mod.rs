//! The fuzzy feed generator of Nagata, Kuribayashi, Kusumoto & Watanabe,
//! "Feed Rate Control Using Fuzzy Reasoning for NC Machine Tools" (undated;
//! it cites work up to 2002), section 3: two zero-order Sugeno reasoners as
//! data on the generic engine ([`data`]), one on the CL segment length
//! `d(i) = ‖p(i+1) − p(i)‖` and one on its increment `Δd(i) = d(i+1) −
//! d(i)`, added into the feed of segment `i` ([`law`]).
//!
//! | paper | here |
//! |---|---|
//! | rules `IF d(i) is Ãⱼ THEN F(i) = cⱼᴬ`, eq. 2, 4 | [`FEED_SYSTEM`] |
//! | rules `IF Δd(i) is B̃ⱼ THEN ΔF(i) = cⱼᴮ`, eq. 3, 5 | [`COMPENSATION_SYSTEM`] |
//! | eq. 6: `F̃(i) = F(i) + ΔF(i)` | [`FeedGenerator::feed`] |
//! | eq. 7: Gaussian `exp(log 0.5 · (x − p)² q²)`, q = 0.2 and 0.1 | [`LENGTH_TERMS`], [`INCREMENT_TERMS`] |
//! | Table 1: consequents from F_min, F_max, F_base = F_max − F_min | [`FEED_CONSTANTS`], [`COMPENSATION_CONSTANTS`] |
//!
//! The post-processor around it (CL data in, NC data out, eq. 1's rotary
//! mapping, the forced pick-feed speed) runs on the PC: `host-sim nagata`,
//! host-sim's `nagata` experiment.
//!
//! # Choices where the paper is incomplete
//!
//! **Consequents as data.** Table 1's constants depend on F_min and F_max,
//! which the user sets, while a [`SystemDef`](crate::fuzzy::SystemDef) is `const` data. Because a
//! weighted average (eq. 4-5) is linear in the constants, the systems here
//! output *fractions*: the feed reasoner gives `u_A = Σωc/Σω` with
//! `c ∈ {0.1, 0.2, 0.4, 0.6, 0.8, 1}` and `F(i) = F_min + F_base·u_A`; the
//! compensation reasoner gives `u_B` with `c ∈ {−0.5, −0.2, −0.1, 0.1, 0.2,
//! 0.5}` and `ΔF(i) = F_min·u_B`. Exactly Table 1, and the systems export to
//! `.fis` as they are.
//!
//! **Membership centres (Figure 3 lost).** Only the widths survive: eq. 7
//! with `q` = 0.2 for `d` and 0.1 for `Δd` is MATLAB's `gaussmf` with
//! `σ = 1/(q·√(2 ln 2))` = 4.2466 mm and 8.4932 mm, and a degree of 0.5 at
//! `1/q` = 5 mm and 10 mm from the centre. We space the six centres by
//! exactly `1/q`, so neighbouring sets cross at 0.5 as in a triangle
//! partition: `d` centres 0, 5, 10, 15, 20, 25 mm (universe `[0, 25]` mm:
//! longer segments count as 25 mm, i.e. "long", F_max); `Δd` centres −25,
//! −15, −5, 5, 15, 25 mm (universe `[−25, 25]` mm), symmetric like Table 1's
//! `cᴮ`, so `Δd = 0` gives `ΔF = 0`. With sets this wide the reasoners are
//! smooth ramps: `F` rises from F_min + 0.14 F_base at `d = 0` to
//! F_min + 0.92 F_base at 25 mm, `ΔF` from −0.33 F_min to +0.33 F_min.
//!
//! **Range of the result.** The paper notes that F̃ may exceed F_max and
//! fall below F_min. [`FeedRange::Paper`] keeps that (F̃ always lies in
//! `[F_min + 0.1 F_base − 0.5 F_min, F_max + 0.5 F_min]`, positive);
//! [`FeedRange::Clamp`] clamps to `[F_min, F_max]` for a machine whose
//! limits those are.
//!
//! **The last segment** has no `d(i+1)`: Δd = 0 there (see
//! [`segment_lengths`]).

pub mod data;
pub mod law;

pub use data::*;
pub use law::*;
