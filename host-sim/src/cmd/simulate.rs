//! `flexcal simulate`: run a scenario and write its recording, plus the calibrate
//! configuration that declares the scenario's model (`calibrate.toml`).

use crate::calib::config::CalibConfig;
use crate::recording::write_recording;
use crate::sim::{simulate, Scenario};
use std::path::PathBuf;

/// Arguments of `flexcal simulate`.
#[derive(clap::Args)]
pub struct Args {
    /// Built-in scenario (paper, moored, matched) or a scenario TOML file.
    #[arg(long, default_value = "moored")]
    pub scenario: String,
    /// Output recording directory.
    #[arg(long)]
    pub out: PathBuf,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Override the scenario's duration (s).
    #[arg(long)]
    pub duration: Option<f64>,
}

/// Runs `flexcal simulate`.
pub fn run(a: &Args) -> Result<(), String> {
    let mut sc = Scenario::load(&a.scenario)?;
    if let Some(d) = a.duration {
        sc.duration_s = d;
        sc.validate()?;
    }
    let out = simulate(&sc, a.seed);
    write_recording(&a.out, &out.recording).map_err(|e| e.to_string())?;
    let declared = CalibConfig::declared_for(&sc, 1.0 / sc.master.rate_hz);
    let text = toml::to_string(&declared).map_err(|e| e.to_string())?;
    let cfg_path = a.out.join("calibrate.toml");
    std::fs::write(
        &cfg_path,
        format!(
            "# The model scenario `{}` declares (written by flexcal simulate).\n{text}",
            sc.name
        ),
    )
    .map_err(|e| format!("{}: {e}", cfg_path.display()))?;
    println!(
        "simulated `{}` (seed {}, {} s): {} IMU samples, {} master messages -> {}",
        sc.name,
        a.seed,
        sc.duration_s,
        out.recording.imu.len(),
        out.recording.master.len(),
        a.out.display()
    );
    Ok(())
}
