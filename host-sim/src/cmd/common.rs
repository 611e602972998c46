//! Arguments several subcommands share, what they do to a scenario or a calibration
//! configuration, and how the commands write their JSON.

use crate::calib::config::CalibConfig;
use crate::sim::blind::{self, BlindEffect};
use crate::sim::Scenario;
use std::path::Path;

/// Writes `doc` to `path` as pretty JSON with a final newline; an error names the file.
pub fn write_json(path: &Path, doc: &impl serde::Serialize) -> Result<(), String> {
    let text = serde_json::to_string_pretty(doc).map_err(|e| e.to_string())?;
    std::fs::write(path, text + "\n").map_err(|e| format!("{}: {e}", path.display()))
}

/// Which scenario to simulate, for how long, with which seed.
#[derive(clap::Args)]
pub struct ScenarioArgs {
    /// Built-in scenario (paper, moored, matched) or a scenario TOML file.
    #[arg(long, required_unless_present = "blind", conflicts_with = "blind")]
    pub scenario: Option<String>,
    /// A blind scenario instead: drawn from the seed within stated ranges
    /// (`docs/model-learning.md`), its model handed to nobody (each Monte Carlo run
    /// draws its own).
    #[arg(long)]
    pub blind: bool,
    /// With `--blind`: the undeclared effects the draw carries (comma separated or
    /// repeated, each at most once).
    #[arg(long, value_enum, requires = "blind", value_delimiter = ',')]
    pub effect: Vec<BlindEffect>,
    /// Override the scenario's duration (s); a blind scenario lasts 600 s unless told.
    #[arg(long)]
    pub duration: Option<f64>,
    /// Random seed (the first seed of a Monte Carlo).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

/// The duration of a blind scenario when none is given (s).
pub const BLIND_DURATION_S: f64 = 600.0;

impl ScenarioArgs {
    /// The scenario of `seed`: the named one (the same for every seed), or the blind
    /// draw of that seed; the duration override applied and checked.
    pub fn load_for_seed(&self, seed: u64) -> Result<Scenario, String> {
        if let Some((k, e)) = (1..self.effect.len()).find_map(|k| {
            self.effect[..k]
                .contains(&self.effect[k])
                .then_some((k, self.effect[k]))
        }) {
            return Err(format!(
                "--effect: {} given twice (entry {})",
                blind::effect_name(e),
                k + 1
            ));
        }
        let mut sc = match &self.scenario {
            Some(name) if !self.blind => Scenario::load(name)?,
            _ => blind::draw_effects(
                seed,
                self.duration.unwrap_or(BLIND_DURATION_S),
                &self.effect,
            ),
        };
        if let Some(d) = self.duration {
            sc.duration_s = d;
            sc.validate()?;
        }
        Ok(sc)
    }

    /// The scenario of the first seed (see [`Self::load_for_seed`]).
    pub fn load(&self) -> Result<Scenario, String> {
        self.load_for_seed(self.seed)
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
    /// Hand the filter the master's attitude as recorded: no step searched or taken
    /// out before the filter (`master_attitude_steps = []`; `calib::master_steps`).
    #[arg(long)]
    pub keep_master_steps: bool,
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
        if self.keep_master_steps {
            cfg.master_attitude_steps = Some(Vec::new());
        }
        cfg.augmentation::<f64>().map(|_| ())
    }
}
