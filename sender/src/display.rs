//! Where a run shows itself: a progress bar with the live status line
//! (indicatif, on a terminal), or one log line a second (unattended).

use std::io::Write;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::stream::Display;
use crate::view::View;

/// Status lines to a writer (stderr when unattended), one per `period`,
/// and every note at once.
pub struct LogDisplay<W: Write> {
    out: W,
    period: Duration,
    next: Option<Instant>,
}

impl<W: Write> LogDisplay<W> {
    /// A line every `period`.
    pub fn new(out: W, period: Duration) -> Self {
        LogDisplay {
            out,
            period,
            next: None,
        }
    }

    /// The writer (for tests).
    pub fn into_inner(self) -> W {
        self.out
    }
}

impl<W: Write> Display for LogDisplay<W> {
    fn show(&mut self, view: &View) {
        let now = Instant::now();
        if self.next.is_some_and(|t| now < t) {
            return;
        }
        self.next = Some(now + self.period);
        let _ = writeln!(self.out, "{}", view.log_line());
    }

    fn note(&mut self, text: &str) {
        let _ = writeln!(self.out, "{text}");
    }
}

/// Scale of the bar's position: µm of path.
const BAR_UNITS_PER_MM: f64 = 1000.0;

/// A progress bar over the path length with the status line under it
/// (stderr), redrawn ten times a second.
pub struct BarDisplay {
    bar: ProgressBar,
}

impl BarDisplay {
    /// For a path of `total_mm`; `help` is shown above the bar.
    pub fn new(total_mm: f64, help: &str) -> Self {
        let bar = ProgressBar::with_draw_target(
            Some((total_mm * BAR_UNITS_PER_MM).max(1.0) as u64),
            ProgressDrawTarget::stderr_with_hz(10),
        );
        let style = ProgressStyle::with_template(
            "{prefix} [{elapsed_precise}] {wide_bar:.cyan/blue} {percent:>3}%\n{msg}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> ");
        bar.set_style(style);
        if !help.is_empty() {
            bar.println(help);
        }
        BarDisplay { bar }
    }
}

impl Display for BarDisplay {
    fn show(&mut self, view: &View) {
        self.bar
            .set_position((view.done_mm * BAR_UNITS_PER_MM).max(0.0) as u64);
        self.bar.set_message(view.line());
    }

    fn note(&mut self, text: &str) {
        self.bar.println(text);
    }

    /// Leave the bar where it is (the summary follows below it).
    fn finish(&mut self) {
        self.bar.abandon();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_log_writes_a_line_per_period_and_every_note() {
        let mut d = LogDisplay::new(Vec::new(), Duration::from_secs(3600));
        let v = View::default();
        d.show(&v);
        d.show(&v);
        d.note("a note");
        let text = String::from_utf8(d.into_inner()).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 2, "{text}");
        assert!(lines[0].contains("Idle"), "{text}");
        assert_eq!(lines[1], "a note");
    }
}
