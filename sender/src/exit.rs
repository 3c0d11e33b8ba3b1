//! Exit codes: how a run ended, for scripts that call the sender.
//!
//! | code | meaning |
//! |---|---|
//! | 0 | the program ran to its end (or `status`/`monitor`/`stop` succeeded) |
//! | 1 | another error (e.g. the record file could not be written) |
//! | 2 | bad command line (clap) or script |
//! | 3 | refused input: the file cannot be read, or a line the reader or the controller's rules refuse; nothing was sent |
//! | 4 | link lost: no connection, the connection closed, or the controller stopped answering |
//! | 5 | refused by the controller: its settings differ from the host's, it is busy with another path, or it refused a command |
//! | 6 | stopped by the user under control (Esc, Ctrl-C, or a script's `stop`) |
//! | 7 | alarm: the controller is in its alarm state (an e-stop, `!` or a script's `estop` included, a limit, a failed homing cycle, link loss); `fuzzy-send unlock` clears it |

use std::fmt;

/// How a run ended (the process's exit code is the discriminant).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Exit {
    /// The program ran to its end.
    Done = 0,
    /// Another error.
    Error = 1,
    /// Bad command line or script.
    Usage = 2,
    /// Refused input: nothing was sent.
    Input = 3,
    /// The link was lost or never came up.
    LinkLost = 4,
    /// The controller refused: settings, busy, or a refused command.
    Controller = 5,
    /// Stopped by the user under control.
    UserStop = 6,
    /// The controller is in its alarm state.
    Alarm = 7,
}

impl Exit {
    /// The process exit code.
    pub fn code(self) -> u8 {
        self as u8
    }
}

impl fmt::Display for Exit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Exit::Done => "done",
            Exit::Error => "error",
            Exit::Usage => "usage",
            Exit::Input => "refused input",
            Exit::LinkLost => "link lost",
            Exit::Controller => "refused by the controller",
            Exit::UserStop => "stopped by the user",
            Exit::Alarm => "alarm",
        })
    }
}

/// A failure: its exit code and what to tell the user.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Failure {
    /// The exit code.
    pub exit: Exit,
    /// The message.
    pub message: String,
}

impl Failure {
    /// A failure with this code.
    pub fn new(exit: Exit, message: impl Into<String>) -> Self {
        Failure {
            exit,
            message: message.into(),
        }
    }
}

impl fmt::Display for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({})", self.message, self.exit)
    }
}

impl std::error::Error for Failure {}

impl From<link::client::LinkError> for Failure {
    fn from(e: link::client::LinkError) -> Self {
        Failure::new(Exit::LinkLost, e.to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_are_distinct_and_documented() {
        let all = [
            Exit::Done,
            Exit::Error,
            Exit::Usage,
            Exit::Input,
            Exit::LinkLost,
            Exit::Controller,
            Exit::UserStop,
            Exit::Alarm,
        ];
        let mut codes: Vec<u8> = all.iter().map(|e| e.code()).collect();
        codes.sort();
        codes.dedup();
        assert_eq!(codes.len(), all.len());
        let doc = include_str!("exit.rs");
        for e in all {
            assert!(
                doc.contains(&format!("//! | {} |", e.code())),
                "code {} is in the table",
                e.code()
            );
        }
    }
}
