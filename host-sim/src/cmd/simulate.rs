//! `flexcal simulate`: run a scenario and write its recording, plus the calibrate
//! configuration that declares the scenario's model (`calibrate.toml`). A blind
//! scenario (`--blind`) writes no `calibrate.toml`: what it drew goes to a scenario
//! file outside the recording (`--drawn`), for scoring only.

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
    /// With `--blind`: where the drawn scenario is written (a scenario TOML that
    /// `--scenario` reproduces the recording from). Default: `OUT.drawn.toml` beside
    /// the recording directory, not in it.
    #[arg(long, requires = "blind")]
    pub drawn: Option<PathBuf>,
}

/// Where a blind draw is written by default: `OUT.drawn.toml`, beside `OUT`.
pub fn default_drawn_path(out: &std::path::Path) -> PathBuf {
    let mut name = out
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_else(|| "recording".into());
    name.push(".drawn.toml");
    out.with_file_name(name)
}

/// Runs `flexcal simulate`.
pub fn run(a: &Args) -> Result<(), String> {
    let sc = a.scenario.load()?;
    let seed = a.scenario.seed;
    let out = simulate(&sc, seed);
    write_recording(&a.out, &out.recording).map_err(|e| e.to_string())?;
    if a.scenario.blind {
        let path = a
            .drawn
            .clone()
            .unwrap_or_else(|| default_drawn_path(&a.out));
        let text = toml::to_string(&sc).map_err(|e| e.to_string())?;
        std::fs::write(
            &path,
            format!(
                "# Blind scenario drawn by flexcal simulate --blind (seed {seed}): the truth, for scoring only.\n{text}"
            ),
        )
        .map_err(|e| format!("{}: {e}", path.display()))?;
        println!("drawn scenario (truth, for scoring) -> {}", path.display());
    } else {
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
    }
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
