//! The filter's own consistency in a calm sea (docs/model-learning.md, "Session 12"):
//! blind draw 3's model with the ship's motion at 1°, 0.5°, 0.3°, **handed its truth on
//! purpose** (the model as simulated, the mounting as drawn): the check is of the
//! filter's linearization, not of the learner. In a calm sea the velocity parts the tilt
//! from the horizontal biases only as `ψ × f + ∇`, and the tilt–bias product
//! `½|∇⊥|²/g` that Φ leaves out sits on the vertical bias; without the floor of
//! `flexcal_core::tilt_bias` the filter claimed 1.2e-6 m/s² there for an error of 8.6e-6
//! (NEES 98.0 of the nine calibrated states).

mod truth_handed;

use nalgebra::{SMatrix, SVector, SymmetricEigen};

/// Blind draw 3 (`flexcal simulate --blind --seed 3`), its motion amplitudes set to a
/// calm sea.
const CALM_SEA_DRAW_3: &str = r#"name = "blind-3"
duration_s = 600.0
misalignment_deg = [-0.2699244253222339, -1.8876445760360818, 0.8369006603420414]

[site]
lat_deg = 8.425117859302716
lon_deg = -104.63987938512757
height_m = 0.0

[motion]
roll_amp_deg = 1.0
roll_period_s = 10.066257486016394
pitch_amp_deg = 0.5
pitch_period_s = 5.312682874385356
yaw_amp_deg = 0.3
yaw_period_s = 8.128689403403481
heading_deg = 292.63348955626776
speed_mps = 1.4685623334055422

[lever_arm]
r0_m = [-6.7803998130549985, 13.538996640647788, -15.369394145666977]
bending = "uniform_arc"

[flexure]
kind = "gauss_markov_axes"
sigma_arcmin = [1.9329484519587985, 2.268935330036983, 2.560617310230516]
omega_rad_s = [1.1400312056592417, 1.9987165704261975, 1.5363392569917405]
damping = [0.47548521469957494, 0.13791945424676327, 0.29416456551952175]

[slave_imu]
rate_hz = 400.0
gyro_bias_deg_h = [-0.1764005065866252, -0.9312939825114541, -0.5800603099767493]
accel_bias_mg = [1.4322307307526883, -2.0152515702488354, 1.0563461219855474]
gyro_scale_ppm = [0.0, 0.0, 0.0]
accel_scale_ppm = [0.0, 0.0, 0.0]
gyro_nonorthogonality_urad = [0.0, 0.0, 0.0]
accel_nonorthogonality_urad = [0.0, 0.0, 0.0]
gyro_g_sensitivity_deg_h_per_g = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
gyro_arw_deg_rh = 0.004323713386966502
accel_vrw_mps_rh = 0.0009062172663472043

[master]
rate_hz = 10.0
gives_rate = true
velocity_noise_mps = 0.013967742854233547
attitude_noise_deg = 0.010945824742731987
rate_noise_deg_h = 29.681814301531393

[undeclared]
master_delay_s = 0.0
master_delay_rate = 0.0
lever_arm_error_m = [0.0, 0.0, 0.0]
"#;

#[test]
fn calm_sea_handed_its_truth_is_consistent_in_its_sharpest_direction() {
    let tmp = tempfile::tempdir().unwrap();
    let s = truth_handed::calibrate(tmp.path(), CALM_SEA_DRAW_3, 3);
    let e = &s["errors"];
    let err: Vec<f64> = ["gyro_bias", "accel_bias", "misalignment"]
        .iter()
        .flat_map(|k| {
            e[*k]
                .as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
        })
        .collect();
    let err = SVector::<f64, 9>::from_vec(err);
    let rows = s["calibrated_covariance"]["matrix"].as_array().unwrap();
    let p = SMatrix::<f64, 9, 9>::from_fn(|i, j| rows[i][j].as_f64().unwrap());
    // The sharpest direction of the correlation matrix: the vertical bias on this draw.
    let sig = SVector::<f64, 9>::from_fn(|i, _| p[(i, i)].sqrt());
    let corr = SMatrix::<f64, 9, 9>::from_fn(|i, j| p[(i, j)] / (sig[i] * sig[j]));
    let eig = SymmetricEigen::new(corr);
    let k = eig.eigenvalues.imin();
    let z = err.component_div(&sig);
    let along = eig.eigenvectors.column(k).dot(&z) / eig.eigenvalues[k].sqrt();
    assert!(along.abs() < 3.0, "sharpest direction at {along:.1} σ");
    // χ²(9)'s 0.999 quantile is 27.88; without the floor this draw gives 98.0.
    let nees = e["nees_mean"].as_f64().unwrap();
    assert!(nees < 27.88, "NEES {nees:.1}");
}
