//! Progress of a command that can take more than a few seconds: a spinner on stderr
//! with the phase and the elapsed time, drawn only when stderr is a terminal (indicatif
//! hides it otherwise, so CI logs stay quiet). The steps of a run are not counted, so
//! it says what is being done and for how long, not a fraction.

use indicatif::{ProgressBar, ProgressStyle};
use std::time::Duration;

/// A running phase indicator; finished and cleared when dropped.
pub struct Progress(ProgressBar);

impl Progress {
    /// Starts the indicator with its first phase.
    pub fn start(phase: &str) -> Self {
        let bar = ProgressBar::new_spinner();
        if let Ok(style) = ProgressStyle::with_template("{spinner} {msg} ({elapsed})") {
            bar.set_style(style);
        }
        bar.set_message(phase.to_string());
        bar.enable_steady_tick(Duration::from_millis(200));
        Self(bar)
    }

    /// Says which phase the command is in now.
    pub fn phase(&self, phase: &str) {
        self.0.set_message(phase.to_string());
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.0.finish_and_clear();
    }
}
