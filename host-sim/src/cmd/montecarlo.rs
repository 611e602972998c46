//! `flexcal montecarlo`: placeholder until written.

/// Arguments of `flexcal montecarlo`.
#[derive(clap::Args)]
pub struct Args {}

/// Runs `flexcal montecarlo`.
pub fn run(_a: &Args) -> Result<(), String> {
    Err("montecarlo: not built yet".into())
}
