//! `flexcal simulate`: run a scenario and write its recording, plus the calibrate
//! configuration that declares the scenario's model (`calibrate.toml`). A blind
//! scenario (`--blind`) writes no `calibrate.toml`: what it drew goes to a scenario
//! file outside the recording (`--drawn`), for scoring only.

use crate::calib::config::CalibConfig;
use crate::cmd::common::ScenarioArgs;
use crate::recording::write_recording;
use crate::sim::master_steps::{draw_steps, StepTimes};
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
    /// How late the master's time tags are on the slave's (s, in [−1, 1]; negative:
    /// early): a clock offset, injected as `undeclared.master_delay_s`. Overrides the
    /// scenario's (a blind draw's too, and the drawn file says so).
    #[arg(long, allow_hyphen_values = true)]
    pub clock_offset: Option<f64>,
    /// The slave's mounting on the master, `x,y,z` (rotation vector of `C_bs^bm`,
    /// degrees): overrides the scenario's `misalignment_deg` (a blind draw's too).
    #[arg(long, value_delimiter = ',', num_args = 1, allow_hyphen_values = true)]
    pub mounting_deg: Option<Vec<f64>>,
    /// A master whose attitude steps at its corrections.
    #[command(flatten)]
    pub master_steps: MasterStepArgs,
}

/// The options of a master that corrects its attitude in steps.
#[derive(clap::Args, Default)]
pub struct MasterStepArgs {
    /// A master that corrects its attitude in steps (a consumer-grade filter): each
    /// step a rotation of this many degrees about an axis drawn from the seed, at
    /// `--master-step-times` or at drawn times (`--master-step-every`). Injected as
    /// `undeclared.master_attitude_steps` (a blind draw's drawn file lists every step).
    #[arg(long)]
    pub master_step_deg: Option<f64>,
    /// The steps' times on the master's tags (s, comma separated).
    #[arg(long, value_delimiter = ',', requires = "master_step_deg")]
    pub master_step_times: Option<Vec<f64>>,
    /// Mean interval between drawn steps (s; each interval uniform in 0.5–1.5× it).
    #[arg(long, requires = "master_step_deg", default_value_t = 30.0)]
    pub master_step_every: f64,
    /// The master's attitude error between the steps turns at this rate about an axis
    /// drawn per interval (deg/s).
    #[arg(long, requires = "master_step_deg", default_value_t = 0.0)]
    pub master_drift_deg_s: f64,
}

/// The scenario with the command line's overrides (clock offset, mounting, master
/// steps), checked.
fn with_overrides(mut sc: crate::sim::Scenario, a: &Args) -> Result<crate::sim::Scenario, String> {
    if let Some(tau) = a.clock_offset {
        sc.undeclared.master_delay_s = tau;
    }
    if let Some(m) = &a.mounting_deg {
        let [x, y, z] = m[..] else {
            return Err(format!(
                "--mounting-deg wants three numbers x,y,z (degrees), got {}",
                m.len()
            ));
        };
        sc.misalignment_deg = [x, y, z];
    }
    let st = &a.master_steps;
    if let Some(size) = st.master_step_deg {
        let times = match &st.master_step_times {
            Some(t) => StepTimes::Stated(t.clone()),
            None => StepTimes::Drawn {
                mean_interval_s: st.master_step_every,
            },
        };
        sc.undeclared.master_attitude_steps = Some(draw_steps(
            a.scenario.seed,
            sc.duration_s,
            size,
            &times,
            st.master_drift_deg_s,
        )?);
    }
    sc.validate()?;
    Ok(sc)
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
    let sc = with_overrides(a.scenario.load()?, a)?;
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
    if let Some(st) = &sc.undeclared.master_attitude_steps {
        let times: Vec<String> = st.steps.iter().map(|s| format!("{:.1}", s.t_s)).collect();
        println!(
            "  master attitude: {} steps at [{}] s (each listed in the scenario's undeclared.master_attitude_steps)",
            st.steps.len(),
            times.join(", ")
        );
    }
    Ok(())
}
