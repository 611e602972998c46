//! The calibrator on the desktop: configuration, the steps before the filter (clocks,
//! mounting, the master's attitude steps), the run over a recording, scoring against truth, and the outputs of
//! `flexcal calibrate`.

pub mod clock;
pub mod config;
pub mod flexure_id;
pub mod master_steps;
pub mod mounting;
pub mod prefilter;
pub mod residuals;
pub mod run;
pub mod score;
