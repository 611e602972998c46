//! `flexcal identify`: placeholder module owned by the identification work.

/// Arguments of `flexcal identify`.
#[derive(clap::Args)]
pub struct Args {}

/// Runs `flexcal identify`.
pub fn run(_args: &Args) -> Result<(), String> {
    Err("identify: not built yet".into())
}
