//! Progress: indicatif bars on a terminal, plain lines otherwise (CI logs, pipes).

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;

/// Reports progress of a run.
pub struct Progress {
    bar: Option<ProgressBar>,
    quiet: bool,
}

impl Progress {
    /// A bar over `total` combinations when stderr is a terminal, else plain lines.
    pub fn new(total: u64, quiet: bool) -> Self {
        let bar = if !quiet && std::io::stderr().is_terminal() {
            let b = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
            b.set_style(
                ProgressStyle::with_template(
                    "{elapsed_precise} [{bar:30}] {pos}/{len} rows, {per_sec}, ETA {eta} {msg}",
                )
                .expect("template")
                .progress_chars("=> "),
            );
            // Redraw while a long build or pass runs, so the clock never freezes.
            b.enable_steady_tick(std::time::Duration::from_millis(250));
            Some(b)
        } else {
            None
        };
        Progress { bar, quiet }
    }

    /// A status message (what is running now).
    pub fn step(&self, msg: &str) {
        match &self.bar {
            Some(b) => b.set_message(msg.to_string()),
            None if !self.quiet => eprintln!("  {msg}"),
            None => {}
        }
    }

    /// A line that stays (a finished row, a note).
    pub fn line(&self, msg: &str) {
        match &self.bar {
            Some(b) => b.println(msg),
            None if !self.quiet => eprintln!("{msg}"),
            None => {}
        }
    }

    /// A finished row: one line in plain mode (the bar counts it on a terminal).
    pub fn row(&self, msg: &str) {
        if self.bar.is_none() && !self.quiet {
            eprintln!("{msg}");
        }
    }

    /// Count one row done (written or skipped) on the bar.
    pub fn inc(&self) {
        if let Some(b) = &self.bar {
            b.inc(1);
        }
    }

    /// Clear the bar from the terminal (the run is over).
    pub fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}
