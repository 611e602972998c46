//! A drawn scenario simulated and calibrated with its own model, **handed its truth on
//! purpose** (the model as the simulator declares it, the mounting as drawn): for the
//! tests that check the filter's own models, not the learner.

use std::path::Path;
use std::process::Command;

/// Simulates `scenario` (a scenario TOML) with `seed` in `dir`, appends the drawn
/// mounting to the declared model, calibrates with it, and returns `summary.json`.
#[allow(dead_code)] // Not every test that shares this module calls both.
pub fn calibrate(dir: &Path, scenario: &str, seed: u64) -> serde_json::Value {
    calibrate_edited(dir, scenario, seed, |c| c)
}

/// [`calibrate`] with the declared model passed through `edit` first (the channels
/// matched, the effects asked for, the priors).
#[allow(dead_code)] // Not every test that shares this module calls each.
pub fn calibrate_edited(
    dir: &Path,
    scenario: &str,
    seed: u64,
    edit: impl Fn(String) -> String,
) -> serde_json::Value {
    calibrate_edited_with(dir, scenario, seed, edit, &[])
}

/// [`calibrate_edited`] with more arguments for `flexcal calibrate` (`--precision f32`).
/// The calibration's outputs are in `dir/cal`.
pub fn calibrate_edited_with(
    dir: &Path,
    scenario: &str,
    seed: u64,
    edit: impl Fn(String) -> String,
    args: &[&str],
) -> serde_json::Value {
    let flexcal = || Command::new(env!("CARGO_BIN_EXE_flexcal"));
    let path = dir.join("scenario.toml");
    std::fs::write(&path, scenario).unwrap();
    let rec = dir.join("rec");
    let st = flexcal()
        .args(["simulate", "--seed", &seed.to_string(), "--scenario"])
        .arg(&path)
        .arg("--out")
        .arg(&rec)
        .status()
        .unwrap();
    assert!(st.success());
    let drawn: toml::Value = toml::from_str(scenario).unwrap();
    let mu: Vec<String> = drawn["misalignment_deg"]
        .as_array()
        .unwrap()
        .iter()
        .map(|d| format!("{:?}", d.as_float().unwrap().to_radians()))
        .collect();
    let mut config = std::fs::read_to_string(rec.join("calibrate.toml")).unwrap();
    config.push_str(&format!("\nmounting_estimate_rad = [{}]\n", mu.join(", ")));
    let config = edit(config);
    let config_path = dir.join("truth.toml");
    std::fs::write(&config_path, config).unwrap();
    let out = dir.join("cal");
    let st = flexcal()
        .arg("calibrate")
        .arg(&rec)
        .args(args)
        .arg("--config")
        .arg(&config_path)
        .arg("--out")
        .arg(&out)
        .status()
        .unwrap();
    assert!(st.success());
    serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap()
}
