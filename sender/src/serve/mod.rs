//! `fuzzy-send serve`: a Grbl 1.1 front for the controller, so that the
//! senders CNC users run (cncjs, bCNC, UGS, gSender, Candle) drive it.

pub mod port;
