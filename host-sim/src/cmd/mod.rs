//! The subcommands of `flexcal`, one module each.

pub mod bench_board;
pub mod calibrate;
pub mod common;
pub mod diagnose;
pub mod identify;
pub mod montecarlo;
pub mod montecarlo_blind;
pub mod paper_figures;
pub mod progress;
pub mod replay;
pub mod simulate;

/// The version written into every JSON output as `tool_version`.
pub const TOOL_VERSION: &str = env!("CARGO_PKG_VERSION");
