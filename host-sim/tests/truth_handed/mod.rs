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

#[allow(dead_code)] // Not every test that shares this module uses it.
/// Blind draw 108 (`flexcal simulate --blind --seed 108 --duration 300 --effect
/// gyro-scale-factor`), its scale factor and smooth master errors set to zero: a
/// noiseless master, a 16, 9.4, 12 m arm, the flexure 2.8′, 2.6′, 1.7′ about x, y, z.
pub const DRAW_108_NO_SCALE_FACTOR: &str = r#"
name = "blind-108-gyro_scale_factor"
duration_s = 300.0
misalignment_deg = [-0.8232958861164283, 1.7981044435974831, -0.5486930663024753]

[site]
lat_deg = -26.319820891899084
lon_deg = 72.96403011425264
height_m = 0.0

[motion]
roll_amp_deg = 14.24958690550754
roll_period_s = 9.868693973223746
pitch_amp_deg = 4.8373890673342945
pitch_period_s = 5.29454229110231
yaw_amp_deg = 2.827227978319735
yaw_period_s = 7.867775017023879
heading_deg = 325.6126614293045
speed_mps = 1.244602536097151

[lever_arm]
r0_m = [-16.007615461588127, -9.373449498153981, -12.16958344427799]
bending = "uniform_arc"

[flexure]
kind = "gauss_markov_axes"
sigma_arcmin = [2.8161009839470856, 2.569872341345773, 1.6955511127018716]
omega_rad_s = [1.514507117723859, 0.7605946308200422, 2.018573388290898]
damping = [0.15556366960054444, 0.2202553275336961, 0.3090745302255048]

[slave_imu]
rate_hz = 400.0
gyro_bias_deg_h = [0.6894084559973646, -0.8641955229726633, -0.31226940046524365]
accel_bias_mg = [0.2165892986287669, -0.17778605960999277, 0.3124787730763435]
gyro_scale_ppm = [0.0, 0.0, 0.0]
accel_scale_ppm = [0.0, 0.0, 0.0]
gyro_nonorthogonality_urad = [0.0, 0.0, 0.0]
accel_nonorthogonality_urad = [0.0, 0.0, 0.0]
gyro_g_sensitivity_deg_h_per_g = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
gyro_arw_deg_rh = 0.003372460993305398
accel_vrw_mps_rh = 0.0013526620210295938

[master]
rate_hz = 100.0
gives_rate = true
velocity_noise_mps = 0.0
attitude_noise_deg = 0.0
rate_noise_deg_h = 0.0

[master.smooth_error]
attitude_arcsec = 0.0
velocity_mps = 0.0
correlation_s = 64.11472924290587

[undeclared]
master_delay_s = 0.0
master_delay_rate = 0.0
lever_arm_error_m = [0.0, 0.0, 0.0]
"#;
