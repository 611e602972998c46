//! `flexcal simulate`: run a scenario and write its recording, plus the calibrate
//! configuration that declares the scenario's model (`calibrate.toml`).

use crate::calib::config::CalibConfig;
use crate::cmd::common::ScenarioArgs;
use crate::recording::write_recording;
use crate::sim::simulate;
use std::path::PathBuf;

/// Arguments of `flexcal simulate`.
#[derive(clap::Args)]
pub struct Args {
    /// Scenario, duration, seed.
    #[command(flatten)]
    pub scenario: ScenarioArgs,
    /// Output recording directory.
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs `flexcal simulate`.
pub fn run(a: &Args) -> Result<(), String> {
    let sc = a.scenario.load()?;
    let seed = a.scenario.seed;
    let out = simulate(&sc, seed);
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
        seed,
        sc.duration_s,
        out.recording.imu.len(),
        out.recording.master.len(),
        a.out.display()
    );
    Ok(())
}
