//! `fuzzy-send`: run a program on a motion board with the fuzzy firmware,
//! as Grbl users do with UGS, bCNC, cncjs or `stream.py`.
//!
//! ```text
//! FILE ─► program (host-sim's readers, the controller's acceptance rules, the host's schedule)
//!      ─► stream: handshake, settings check, link::client::Connection (credit, go-back-N)
//!         ◄─ actions (keys, script, Ctrl-C) ─► hold / resume / override / abort / e-stop
//!      ─► view (status line, progress, ETA) ─► display (bar or log) ─► exit code
//! ```
//!
//! | module | what |
//! |---|---|
//! | [`program`] | the input: G-code, CSV or a shape; checked, scheduled on the host |
//! | [`stream`] | the session with the controller: handshake, the streaming loop, how a run ends |
//! | [`actions`] | operator requests: keys, scripts, hold/override/stop/e-stop state |
//! | [`machine`] | alarms, the machine status, homing, unlock and the `$` settings |
//! | [`view`] | the status line and the ETA |
//! | [`display`] | progress bar (indicatif) or log lines |
//! | [`terminal`] | keys from a terminal (crossterm), Ctrl-C, merged inputs |
//! | [`transport`] | serial port, TCP, Unix socket, or the simulated controller |
//! | [`sim`] | the controller on the host (`controller::sim`) behind a byte stream |
//! | [`record`] | the JSON-lines record of a run |
//! | [`exit`] | exit codes |
//! | [`grbl`] | a Grbl 1.1 front's protocol layer (sans-IO): input, commands, codes, reports, settings |
//! | [`cli`] | the command line |

pub mod actions;
pub mod cli;
pub mod display;
pub mod exit;
pub mod grbl;
pub mod machine;
pub mod program;
pub mod record;
pub mod serve;
pub mod sim;
pub mod stream;
pub mod terminal;
pub mod transport;
pub mod view;
