//! Fixed-point, allocation-free fuzzy feedrate scheduling for CNC motion
//! controllers, after Lin, Lin & Wang, "Using Fuzzy Control for Feedrate
//! Scheduling of Computer Numerical Control Machine Tools" (2021), and a
//! generic fuzzy engine for the other controllers of the project.
//!
//! Data flows one way ([`scheduler::Scheduler`]):
//!
//! | stage | module | paper |
//! |---|---|---|
//! | curvature from three points | [`curvature`] | eq. 4-9 |
//! | lookahead curvature variation | [`lookahead`] | eq. 10 |
//! | Mamdani controller, centroid | [`lin2021`] on [`fuzzy`] | 2.7.1, Table 6, eq. 11 |
//! | average filter | [`average`] | 2.7.2 |
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
pub mod contour;
pub mod curvature;
mod fixmath;
pub mod fuzzy;
pub mod lin2021;
pub mod lookahead;
pub mod nagata;
pub mod njiri;
pub mod planner;
#[cfg(feature = "std")]
pub mod reference;
mod ring;
pub mod scheduler;
mod softfloat;
pub mod units;
