//! The protocol layer of a Grbl 1.1 front for our controller, so that the
//! senders CNC users run (cncjs, bCNC, UGS, gSender, Candle) can drive
//! it: bytes in, Grbl's text out, no I/O, no clock, no link session. The
//! server (pty or TCP) owns the connection and its receive buffer; the
//! front wires these parts to the controller link and the G-code
//! interpreter.
//!
//! ```text
//! bytes ─► input::Receiver ─► Event::Realtime(Realtime) ─► hold/resume/reset/overrides, status
//!                          └► Event::Line(Line) ─► command::parse(text, state)
//!                                                   ├► Command::Gcode ─► interpreter ─► ok | error (codes::error_of_interp)
//!                                                   ├► Command::SetSetting ─► settings::write ─► controller | front
//!                                                   └► $$ $# $G $I $N $J= $H $X $C … ─► report::*
//! controller alarms ─► codes::alarm_of ─► report::alarm (+ report::message)
//! status ─► report::StatusReporter::report ─► <Idle|MPos:…|FS:…|WCO:…>
//! ```
//!
//! Each Grbl behaviour cites its source (Grbl 1.1h, `gnea/grbl`; grblHAL
//! `grblHAL/core` where it differs) beside the code, with the choice made
//! where the source is ambiguous or where we differ.
//!
//! # Public API
//!
//! | module | item | what |
//! |---|---|---|
//! | [`input`] | [`input::Receiver`] | bytes to events: `new`, `grbl_strict`, `push(u8)`, `feed(&[u8])`, `pending`, `clear` |
//! | | [`input::Event`] | `Realtime(Realtime)` or `Line(Line)` |
//! | | [`input::Realtime`] | the real-time commands, `from_byte`, `byte` |
//! | | [`input::Line`] | `text` (cleaned as Grbl), `raw`, `overflow` (→ error 11), `raw_truncated` |
//! | | [`input::LINE_BUFFER_SIZE`], [`input::RX_BUFFER_SIZE`] | 256 (Grbl 80), 1024 (Grbl 128; the server's buffer, reported in `Bf:`, `[OPT:]`) |
//! | [`command`] | [`command::parse`] | a cleaned line in a state → [`command::Command`] or a Grbl error |
//! | | [`command::parse_jog`], [`command::Jog`] | `$J=` checked by Grbl's jog rules |
//! | | [`command::read_float`] | Grbl's number syntax |
//! | [`codes`] | [`codes::ErrorCode`] | errors 1-38: `number`, `from_number`, `short`, `description`, `Display` `error:N` |
//! | | [`codes::Alarm`] | alarms 1-10 (10: grblHAL's e-stop), same methods, `ALARM:N` |
//! | | [`codes::Feedback`] | Grbl's `[MSG:]` texts |
//! | | [`codes::alarm_of`] | `link::AlarmCode` → [`codes::GrblAlarm`] (number + message), total |
//! | | [`codes::error_of_interp`], [`codes::interp_error`] | the interpreter's error text → error number (and the text for `[MSG:]`) |
//! | [`report`] | `welcome`, `ok`, `error`, `alarm`, `feedback`, `message`, `error_with_message`, `help` | one response line each |
//! | | `setting`, `startup_line`, `startup_result` | `$n=v`, `$Nn=line`, `>line:ok` |
//! | | `version`, `options` ([`report::BuildInfo`], [`report::Options`]) | `[VER:]`, `[OPT:]` for `$I` |
//! | | `gcode_modes` ([`report::Modal`]) | `[GC:…]` for `$G` |
//! | | `parameters`, `probe` ([`report::Parameters`], [`report::Probe`]) | `$#` lines, `[PRB:]` |
//! | | [`report::StatusReporter`], `status_report_full` ([`report::Status`]) | `<…>` with `$10` and Grbl's WCO/Ov refresh |
//! | | [`report::MachineState`], [`report::Overrides`] | states, override steps and limits |
//! | | `grbl_float`, `coord`, `rate` | Grbl's number format (3/4 decimals mm/inch) |
//! | [`settings`] | [`settings::GRBL_SETTINGS`], `lookup`, `ids` | Grbl's settings mapped on ours |
//! | | `listing`, `value_text` | `$$` |
//! | | `write` → [`settings::Write`] or [`settings::Refusal`] | `$n=v` checked and converted; `refusal_of_link` |
//!
//! # What is supported (as Grbl's wiki lists it)
//!
//! | Grbl | here |
//! |---|---|
//! | `?` `!` `~` 0x18 | picked out anywhere ([`input`]); acting on them is the front's |
//! | 0x84 door, 0x85 jog cancel | picked out; the front acts (door needs an input: `+` in `[OPT:]` only then) |
//! | 0x87 full status | picked out (grblHAL); [`report::status_report_full`] |
//! | 0x90-0x9D overrides | picked out; [`report::Overrides::apply`] with Grbl's steps and limits |
//! | 0x9E spindle stop, 0xA0/0xA1 coolant | picked out; the front acts |
//! | line cleaning, comments, overflow (error 11) | as Grbl, 255 characters; CR LF one line end (grblHAL) |
//! | `ok` / `error:N` per line, errors 1-38 | yes, with `[MSG:]` before errors from the interpreter and settings |
//! | `ALARM:N` 1-9, 10 (grblHAL e-stop) | ours mapped total ([`codes::alarm_of`]); 4, 5, 7 raised by the front |
//! | `$` help, `$$`, `$#`, `$G`, `$I`, `$N` | formatted; `$#` G54-G59 only (no G59.1-.3, as Grbl) |
//! | `$x=val` | Grbl's numbers mapped on ours ([`settings`]); ours beyond Grbl's listed too |
//! | `$Nx=line`, `$I=` | parsed; storing and running them is the front's |
//! | `$C`, `$X`, `$H`, `$HX/Y/Z`, `$SLP`, `$RST=$#*` | parsed with Grbl's state checks |
//! | `$J=` | Grbl's jog rules (errors 16, 22, 36 …); soft limits (15) are the front's |
//! | status `<…>`: states, MPos/WPos (`$10`), Bf, Ln, FS, Pn, WCO, Ov, A | yes; WCO/Ov every 10-30 reports and on change, as Grbl |
//! | `$13` inches | reports in inches (4 decimals), settings stay mm, as Grbl |
//! | `[PRB:]`, `>line:ok`, `[VER:]`, `[OPT:]` | formatted |
//! | `[echo:]` | no (off in Grbl by default) |
//! | G-code | the interpreter's (LinuxCNC dialect, wider than Grbl's) |
//!
//! Ours, not Grbl's: the receiver keeps UTF-8 characters whole, so a
//! character of a comment is not taken for a real-time command
//! ([`input::Receiver`]); setting ids are digits only; `$Nn` checks n.

pub mod codes;
pub mod command;
pub mod input;
pub mod report;
pub mod settings;
