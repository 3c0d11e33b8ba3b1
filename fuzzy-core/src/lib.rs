//! Fixed-point, allocation-free fuzzy feedrate scheduling for CNC motion
//! controllers, after Lin, Lin & Wang, "Using Fuzzy Control for Feedrate
//! Scheduling of Computer Numerical Control Machine Tools" (2021), and a
//! generic fuzzy engine for the other controllers of the project.
//!
//! One home per paper: each seed paper's controller lives in a module of its
//! own, with the paper's data (terms, rules, system definitions, the compiled
//! controllers) in `data` apart from its control law in `law`. Lin et al.'s
//! pipeline stages are top-level modules, because they are the product's
//! pipeline ([`scheduler::Scheduler`] runs them in this order):
//!
//! | paper | module | equations, tables |
//! |---|---|---|
//! | Lin, Lin & Wang 2021 | [`curvature`] | eq. 4-9: three-point curvature |
//! | | [`lookahead`] | eq. 10: curvature variation Dκ |
//! | | [`lin2021`] ([`data`](lin2021::data), [`law`](lin2021::law)) on [`fuzzy`] | §2.7.1, Table 6, rules R1-R30, eq. 11; Dκ normalisation |
//! | | [`average`] | §2.7.2: average filter |
//! | | [`scheduler`] | Fig. 1, §2.6-2.7: the stages in a stream, `F = max(F_min, u·F_max)` |
//! | Njiri, Ikua & Nyakoe 2011 (WASET vol. 5 no. 8) | [`njiri`] ([`data`](njiri::data), [`law`](njiri::law)) | §II.A-D, Table I, eq. 9, Fig. 7-8; §III.A references |
//! | Nagata, Kuribayashi, Kusumoto & Watanabe, undated (cites work up to 2002) | [`nagata`] ([`data`](nagata::data), [`law`](nagata::law)) | §3, eq. 2-7, Table 1 |
//! | Cho, Lee & Jeon, undated (cites work up to 2000) | [`cho`] ([`data`](cho::data), [`law`](cho::law), [`contour`](cho::contour)) | §2.2 contour error, eq. 3.1-3.3, Table 3.1, §IV gains |
//! | Dat & Phuc 2024 | none: host-sim only (`host-sim/src/experiments/dat_phuc2024`) | |
//!
//! Underneath: the generic fuzzy engine ([`fuzzy`]), the velocity planner
//! ([`planner`]), the geometry of a straight move shared by the curvature
//! and the planner (`segment`), the integer arithmetic every module shares and its policy
//! ([`numerics`]: integer-only on the target, a cost table), typed units
//! ([`units`]) and, with feature `std`, `f64` references (`reference`).
//!
//! `no_std`, no heap (fixed rings, `heapless`, const generics), no floating point on the
//! target, no panics: errors are values. The firmware and the host simulator
//! run this same code and get the same bits.
//!
//! Units: positions in mm ([`units::Point3Mm`], I32F32), curvature in 1/mm
//! ([`units::CurvaturePerMm`]), feed in mm/min ([`units::FeedMmPerMin`]),
//! fuzzy values in Q16.16 ([`units::Fx`]).
//!
//! ```
//! use fuzzy_core::lin2021::CONTROLLER;
//! use fuzzy_core::scheduler::{PathPoint, Scheduler, SchedulerConfig};
//! use fuzzy_core::units::{FeedMmPerMin, Point3Mm};
//!
//! let config = SchedulerConfig::new(FeedMmPerMin::from_int(3000), FeedMmPerMin::from_int(60));
//! let mut s: Scheduler<_> = Scheduler::new(&CONTROLLER, config).unwrap();
//! let path = (0..200).map(|i| {
//!     let a = i as f64 * 0.01;
//!     PathPoint::at(Point3Mm::from_f64(20.0 * a.cos(), 20.0 * a.sin(), 0.0).unwrap())
//! });
//! let mut feeds = Vec::new();
//! s.run(path, |p| feeds.push(p.feed.to_f64())).unwrap();
//! assert_eq!(feeds.len(), 200);
//! ```
#![cfg_attr(not(any(test, feature = "std")), no_std)]
#![deny(missing_docs)]

pub mod average;
pub mod cho;
pub mod curvature;
pub mod fuzzy;
pub mod lin2021;
pub mod lookahead;
pub mod nagata;
pub mod njiri;
pub mod numerics;
pub mod planner;
#[cfg(feature = "std")]
pub mod reference;
mod ring;
pub mod scheduler;
mod segment;
#[cfg(test)]
mod test_rng;
pub mod units;

// The planner (`planner/q.rs`) names the soft float
// `crate::softfloat` until its helpers join `numerics`.
pub(crate) use numerics::softfloat;
