//! Cho, Lee & Jeon, *Design of Fuzzy Logic Controllers for High-Speed and
//! High-Accuracy CNC Machines*: the X-Y servo model of Tables 4.1-4.2 and
//! the contour-error feed control against the best constant feed (Table
//! 4.3). The controller is fuzzy-core's ([`fuzzy_core::cho`],
//! [`fuzzy_core::contour`]).
//!
//! - [`servo_xy`]: the servo model (also a machine of every command,
//!   `--machine servo-xy`);
//! - [`feed_control`]: the closed loop, the constant-feed comparison and
//!   its table;
//! - [`command`]: `host-sim cho`.

pub mod command;
pub mod feed_control;
pub mod servo_xy;
