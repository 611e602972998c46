//! Arguments several subcommands share, and what they do to a scenario or a
//! calibration configuration.

use crate::calib::config::CalibConfig;
use crate::sim::Scenario;

/// Which scenario to simulate, for how long, with which seed.
#[derive(clap::Args)]
pub struct ScenarioArgs {
    /// Built-in scenario (paper, moored, matched) or a scenario TOML file.
    #[arg(long)]
    pub scenario: String,
    /// Override the scenario's duration (s).
    #[arg(long)]
    pub duration: Option<f64>,
    /// Random seed (the first seed of a Monte Carlo).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

impl ScenarioArgs {
    /// The scenario, with the duration override applied and checked.
    pub fn load(&self) -> Result<Scenario, String> {
        let mut sc = Scenario::load(&self.scenario)?;
        if let Some(d) = self.duration {
            sc.duration_s = d;
            sc.validate()?;
        }
        Ok(sc)
    }
}

/// Switches of the filter's model that the command line may override.
#[derive(clap::Args, Default)]
pub struct ModelArgs {
    /// Leave the flexure-bent lever arm out of the model (the paper's baseline).
    #[arg(long)]
    pub no_dynamic_lever_arm: bool,
    /// Identify the flexure model from the recording even when the configuration
    /// fixes it (`identify_flexure = true` in the configuration does the same).
    #[arg(long)]
    pub identify_flexure: bool,
    /// Effects to carry beyond the declared model, comma separated, by their
    /// `diagnosis.json` names (e.g. `time_delay,lever_arm_error`); added to the
    /// configuration's `effects`.
    #[arg(long, value_delimiter = ',')]
    pub effects: Vec<String>,
}

impl ModelArgs {
    /// Applies the switches to a configuration; an unknown or repeated effect is an error.
    pub fn apply(&self, cfg: &mut CalibConfig) -> Result<(), String> {
        if self.no_dynamic_lever_arm {
            cfg.dynamic_lever_arm = false;
        }
        if self.identify_flexure {
            cfg.identify_flexure = true;
        }
        cfg.effects.extend(self.effects.iter().cloned());
        cfg.augmentation::<f64>().map(|_| ())
    }
}
