//! The feedrate controller of Lin, Lin & Wang (2021), section 2.7, as data
//! on the generic engine ([`data`]): 6 curvature sets × 5
//! curvature-variation sets, the 30 rules R1-R30, min AND and implication,
//! max aggregation, centroid (eq. 11), output as a fraction of the maximum
//! feed; and the normalisation of Dκ to the controller's input ([`law`]).
//! The other stages of the paper's pipeline are the crate's top-level
//! modules (table in the crate docs).
//!
//! # Choices where the paper is incomplete
//!
//! **Membership breakpoints.** Figure 5 is lost; the text only says the sets
//! are triangular, the curvature is not normalised (1/mm) and the variation
//! is clipped at 3 and normalised to `[0, 1]`. We chose:
//!
//! - curvature κ (1/mm), universe `[0, 3]`, peaks on a roughly geometric
//!   scale `0, 0.05, 0.15, 0.4, 1, 3` (radii ∞, 20 mm, 6.7 mm, 2.5 mm, 1 mm,
//!   0.33 mm), each triangle's feet at its neighbours' peaks (a partition:
//!   degrees sum to 1, so some rule always fires). Geometric because the
//!   contour error of a machine following a curve grows with `F²·κ`, so equal
//!   steps in feed need equal *ratios* of curvature. The scale covers the
//!   curvatures of the paper's sampled test shapes (2000 points, u step
//!   0.0005): the ∞ shape stays within ZO..M, the trident spans VS..VB, the
//!   butterfly reaches every set. The top set saturates at 3 /mm, the
//!   paper's clip.
//! - curvature variation Dκ, normalised `min(Dκ, 3)/3` (see
//!   [`VariationScale`]), five uniform triangles at `0, 0.25, 0.5, 0.75, 1`
//!   (end sets mirrored beyond the universe so they are whole triangles).
//! - feed fraction: seven triangles of equal width, peaks
//!   `0.10, 0.25, 0.40, 0.55, 0.70, 0.85, 1.00`, feet at the neighbours'
//!   peaks, universe `[−0.05, 1.20]`: the 101 centroid samples (step
//!   0.0125) fall on every peak and foot, and every set lies whole inside the
//!   universe, so TF alone gives 1.0 (a straight line runs at `F_max`) and VLF
//!   alone 0.10. Equal widths matter: the centroid weights each clipped set by
//!   its area, so narrow slow sets beside wide fast ones would let a weakly
//!   firing fast rule outvote a strongly firing slow one (with geometric
//!   output peaks the feed drops from MF to VLF across a sliver of the Dκ
//!   range). The geometric curvature scale above already makes the feed fall
//!   roughly as `κ^(-1/2)` along the rules' diagonal.
//!
//! All of it is data ([`SYSTEM`]): a different [`SystemDef`](crate::fuzzy::SystemDef) with the same
//! shape can be passed to the [`crate::scheduler::Scheduler`].
//!
//! **"VVLF" in R25 and R26.** The rules name an output set VVLF that is not
//! among the seven (Table 6, garbled, agrees with the rule list). We read it
//! as the slowest set, VLF: these rules fire on a straight or gently curved
//! stretch (κ ZO/VS) with a very sharp feature ahead (Dκ VH), which is exactly
//! where the paper wants the tool to "decelerate early before entering the
//! high-curvature area" (Figure 6). Reading it as a typo for VVHF would make
//! the tool approach the sharpest features at near full speed. The rule table
//! stays non-monotone where the paper's is (R27/R28: κ S/M with Dκ VH give
//! MF, faster than R25/R26); we keep the published rules.
//!
//! **No rule fires**: impossible with these partitions; the default output
//! is 0, i.e. the configured minimum feed.

pub mod data;
pub mod law;

pub use data::*;
pub use law::*;
