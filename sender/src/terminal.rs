//! The operator's inputs during a run: keys from a terminal (raw mode,
//! restored when the run ends), a script, and Ctrl-C as a signal when no
//! terminal reads keys; all merged into one [`Actions`] source.

use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::mpsc::{self, Receiver};
use std::sync::Arc;
use std::thread::{self, JoinHandle};
use std::time::Duration;

use crossterm::event::{self, Event};
use rustix::termios;

use crate::actions::{from_key, Action, Script};
use crate::stream::Actions;

/// Keys read from the terminal on a thread, while this lives (raw mode
/// on; restored on drop).
pub struct Keys {
    rx: Receiver<Action>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Keys {
    /// Start reading keys (stdin must be a terminal). Raw mode, except
    /// that output keeps its line discipline (a newline returns the
    /// carriage), so the progress bar and notes print as usual.
    pub fn start() -> std::io::Result<Keys> {
        crossterm::terminal::enable_raw_mode()?;
        let tty = std::io::stdin();
        if let Ok(mut t) = termios::tcgetattr(&tty) {
            t.output_modes |= termios::OutputModes::OPOST | termios::OutputModes::ONLCR;
            let _ = termios::tcsetattr(&tty, termios::OptionalActions::Now, &t);
        }
        let (tx, rx) = mpsc::channel();
        let stop = Arc::new(AtomicBool::new(false));
        let stop2 = stop.clone();
        let thread = thread::spawn(move || {
            while !stop2.load(Ordering::Relaxed) {
                match event::poll(Duration::from_millis(50)) {
                    Ok(true) => {}
                    Ok(false) => continue,
                    Err(_) => return,
                }
                if let Ok(Event::Key(k)) = event::read() {
                    if let Some(a) = from_key(&k) {
                        if tx.send(a).is_err() {
                            return;
                        }
                    }
                }
            }
        });
        Ok(Keys {
            rx,
            stop,
            thread: Some(thread),
        })
    }
}

impl Drop for Keys {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        let _ = crossterm::terminal::disable_raw_mode();
    }
}

/// Ctrl-C (SIGINT) presses, counted.
#[derive(Clone, Default)]
pub struct Interrupts(Arc<AtomicU32>);

impl Interrupts {
    /// Count SIGINT from now on (once per process).
    pub fn install() -> Self {
        let i = Interrupts::default();
        let c = i.0.clone();
        let _ = ctrlc::set_handler(move || {
            c.fetch_add(1, Ordering::Relaxed);
        });
        i
    }

    /// Presses so far.
    pub fn count(&self) -> u32 {
        self.0.load(Ordering::Relaxed)
    }
}

/// Keys, a script and Ctrl-C, merged.
pub struct Inputs {
    /// Keys from a terminal.
    pub keys: Option<Keys>,
    /// A script of timed actions.
    pub script: Option<Script>,
    /// Ctrl-C presses.
    pub interrupts: Interrupts,
    seen: u32,
}

impl Inputs {
    /// From these sources.
    pub fn new(keys: Option<Keys>, script: Option<Script>, interrupts: Interrupts) -> Self {
        let seen = interrupts.count();
        Inputs {
            keys,
            script,
            interrupts,
            seen,
        }
    }
}

impl Actions for Inputs {
    fn poll(&mut self, elapsed: Duration, reached: u32) -> Vec<Action> {
        let mut out = Vec::new();
        let n = self.interrupts.count();
        for _ in self.seen..n {
            out.push(Action::Stop);
        }
        self.seen = n;
        if let Some(k) = &self.keys {
            out.extend(k.rx.try_iter());
        }
        if let Some(s) = self.script.as_mut() {
            out.extend(s.due(elapsed, reached));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interrupts_and_the_script_merge() {
        let i = Interrupts::default();
        let mut inputs = Inputs::new(
            None,
            Some(Script::parse("at 1 s: hold\n").unwrap()),
            i.clone(),
        );
        assert!(inputs.poll(Duration::ZERO, 0).is_empty());
        i.0.fetch_add(2, Ordering::Relaxed);
        assert_eq!(
            inputs.poll(Duration::from_secs(1), 0),
            vec![Action::Stop, Action::Stop, Action::Hold]
        );
        assert!(inputs.poll(Duration::from_secs(2), 0).is_empty());
    }
}
