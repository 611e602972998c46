//! The model a run used, said aloud: where it came from (a file, learned from the
//! recording, the built-in default), every default a configuration file left to the
//! code, and whether the declared IMU noise fits what the slave's own increments show.
//! Thresholds: `docs/verdict.md`.

use super::{g3, Finding, Severity};
use crate::calib::config::CalibConfig;
use crate::learn::increments::IncrementNoise;
use crate::learn::Learned;
use crate::report::units::{show, ARW, VRW};
use serde_json::json;
use std::path::Path;

/// Keys whose default is the built-in `moored` (FOG-grade, ship) model: leaving one of
/// them out of a file declares a sensor or master the file never described (WARN). The
/// other keys default to "off" (no effects, no tuning, constant misalignment): NOTE.
pub const MODEL_KEYS: [&str; 17] = [
    "filter_period_s",
    "matching",
    "flexure_ar",
    "flexure_sigma_rad",
    "gyro_arw_rad_rs",
    "accel_vrw_mps_rs",
    "gyro_bias_rw",
    "accel_bias_rw",
    "velocity_noise_mps",
    "attitude_noise_rad",
    "rate_noise_radps",
    "initial_velocity_mps",
    "initial_misalignment_rad",
    "initial_gyro_bias_radps",
    "initial_accel_bias_mps2",
    "initial_flexure_rad",
    "gate_sigma",
];

/// A declared IMU noise more than this factor from the increments' (either way): WARN.
pub const NOISE_FACTOR: f64 = 3.0;

/// The keys of a configuration file that it leaves to their defaults, with the value
/// each took. Optional keys without a default value (`flexure_axes`) are not listed.
pub fn defaults_taken(path: &Path) -> Result<Vec<(String, toml::Value)>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let given: toml::Table =
        toml::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
    let all = toml::Value::try_from(CalibConfig::default()).map_err(|e| e.to_string())?;
    let all = all.as_table().cloned().unwrap_or_default();
    Ok(all
        .into_iter()
        .filter(|(k, _)| !given.contains_key(k))
        .collect())
}

/// Findings on where the model came from: the file's defaults, or the learning.
pub fn origin(config_file: Option<&Path>, learned: Option<&Learned>) -> Vec<Finding> {
    let mut out = Vec::new();
    if let Some(path) = config_file {
        match defaults_taken(path) {
            Ok(d) => out.extend(defaults_findings(path, &d)),
            Err(e) => out.push(Finding::new(
                Severity::Warn,
                "config_unread",
                format!("the configuration's keys could not be listed: {e}"),
            )),
        }
    }
    match (config_file, learned) {
        (_, Some(l)) if !l.adopted && l.start_origin.starts_with("built-in") => {
            out.push(
                Finding::new(
                    Severity::Warn,
                    "model_builtin",
                    "no configuration was given and the learned model was not adopted: the run used the built-in default (the `moored` scenario's FOG-grade ship model, noise from the increments), which may not fit this sensor; give --config",
                )
                .num("held_out_neg2ll_learned", l.holdout.learned.neg2ll)
                .num("held_out_neg2ll_start", l.holdout.start.neg2ll),
            );
        }
        (_, Some(l)) => out.push(
            Finding::new(
                Severity::Note,
                "model_learned",
                format!(
                    "the model was learned from the recording, starting from the {} ({})",
                    l.start_origin,
                    if l.adopted {
                        "adopted: it predicts the held-out part better"
                    } else {
                        "not adopted: the start is kept"
                    }
                ),
            )
            .num("log_likelihood_gain", l.log_likelihood_gain),
        ),
        (Some(p), None) => out.push(
            Finding::new(
                Severity::Note,
                "model_file",
                format!("the model is the configuration file {}, taken as given", p.display()),
            )
            .at(p.display().to_string()),
        ),
        (None, None) => out.push(Finding::new(
            Severity::Warn,
            "model_builtin",
            "the run used the built-in default model (the `moored` scenario's FOG-grade ship model), which may not fit this sensor; give --config",
        )),
    }
    out
}

fn defaults_findings(path: &Path, d: &[(String, toml::Value)]) -> Vec<Finding> {
    let (model, other): (Vec<_>, Vec<_>) = d
        .iter()
        .partition(|(k, _)| MODEL_KEYS.contains(&k.as_str()));
    let list = |v: &[&(String, toml::Value)]| {
        v.iter()
            .map(|(k, val)| format!("{k} = {val}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let obj = |v: &[&(String, toml::Value)]| {
        json!(v
            .iter()
            .map(|(k, val)| (k.clone(), json!(val)))
            .collect::<serde_json::Map<_, _>>())
    };
    let mut out = Vec::new();
    if !model.is_empty() {
        out.push(
            Finding::new(
                Severity::Warn,
                "config_default_model",
                format!(
                    "the configuration leaves {} model key(s) to the built-in FOG-grade ship model: {}",
                    model.len(),
                    list(&model)
                ),
            )
            .at(path.display().to_string())
            .val("defaults", obj(&model)),
        );
    }
    if !other.is_empty() {
        out.push(
            Finding::new(
                Severity::Note,
                "config_default",
                format!("defaults taken: {}", list(&other)),
            )
            .at(path.display().to_string())
            .val("defaults", obj(&other)),
        );
    }
    out
}

/// The declared gyro angle random walk and accelerometer velocity random walk against
/// the white floors of the slave's increments (`crate::learn::increments`). The gyro's
/// floor is its angle random walk: far from it either way is a mismatch. The
/// accelerometer's floor also holds what does not accumulate into velocity (quantization,
/// vibration), so it only bounds the velocity random walk from above: a declared value
/// far above it is a mismatch, one below it is not.
pub fn noise_fit(cfg: &CalibConfig, inc: &IncrementNoise) -> Vec<Finding> {
    let mut out = Vec::new();
    for (key, declared, measured, two_sided, unit) in [
        (
            "gyro_arw_rad_rs",
            cfg.gyro_arw_rad_rs,
            inc.gyro_arw(),
            true,
            ARW,
        ),
        (
            "accel_vrw_mps_rs",
            cfg.accel_vrw_mps_rs,
            inc.accel_floor(),
            false,
            VRW,
        ),
    ] {
        let ratio = declared / measured;
        let low = if two_sided { 1.0 / NOISE_FACTOR } else { 0.0 };
        if !(ratio.is_finite() && ratio > 0.0) || (low..=NOISE_FACTOR).contains(&ratio) {
            continue;
        }
        out.push(
            Finding::new(
                Severity::Warn,
                "config_noise_mismatch",
                format!(
                    "`{key}` declares {} but the slave's increments show a white floor of {} ({}-{} Hz): {} times {}",
                    show(declared, unit),
                    show(measured, unit),
                    g3(inc.band_from_hz),
                    g3(inc.band_to_hz),
                    g3(if ratio > 1.0 { ratio } else { 1.0 / ratio }),
                    if ratio > 1.0 { "larger" } else { "smaller" }
                ),
            )
            .at(key.to_string())
            .num("declared", declared)
            .num("from_increments", measured)
            .num("ratio", ratio),
        );
    }
    out
}
