//! Progress of a command that can take more than a few seconds, on stderr, drawn only
//! when stderr is a terminal (indicatif hides it otherwise, so CI logs stay quiet): the
//! phase and the elapsed time, with a bar, the percentage and the time left when the
//! phase's total is known (bytes of the slave file read, Monte Carlo runs done).

use indicatif::{ProgressBar, ProgressStyle};
use std::time::Duration;

/// A running phase indicator; finished and cleared when dropped.
pub struct Progress(ProgressBar);

/// Style of a phase whose total is not known.
const SPINNER: &str = "{spinner} {msg} ({elapsed})";
/// Style of a phase whose total is known.
const BAR: &str = "{spinner} {msg} [{bar:30}] {percent}% ({elapsed}, about {eta} left)";

impl Progress {
    /// Starts the indicator with its first phase.
    pub fn start(phase: &str) -> Self {
        let bar = ProgressBar::new_spinner();
        let p = Self(bar);
        p.phase(phase);
        p.0.enable_steady_tick(Duration::from_millis(200));
        p
    }

    fn style(&self, template: &str) {
        if let Ok(style) = ProgressStyle::with_template(template) {
            self.0.set_style(style.progress_chars("=> "));
        }
    }

    /// Says which phase the command is in now (its total not known).
    pub fn phase(&self, phase: &str) {
        self.0.set_message(phase.to_string());
        self.style(SPINNER);
    }

    /// Starts a phase of `total` steps, none done yet.
    pub fn counted(&self, phase: &str, total: u64) {
        self.0.set_message(phase.to_string());
        self.0.set_length(total);
        self.0.set_position(0);
        self.style(BAR);
    }

    /// Steps done in a counted phase.
    pub fn set(&self, done: u64) {
        self.0.set_position(done);
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.0.finish_and_clear();
    }
}
