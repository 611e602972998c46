//! The rate matching's noise with a flexing slave and a noiseless master
//! (docs/model-learning.md, "Session 13"): blind draw 25 (a 10 Hz master with no noise
//! of its own, a 400 Hz slave IMU, flexure modes of 1.2–2.4 rad/s), **handed its truth on
//! purpose** (the model as simulated, the mounting as drawn): the check is of the
//! filter's measurement model, not of the learner. The slave's rate is a mean over IMU
//! intervals, the flexure state the rate at one instant; a second-order mode's rate
//! diffuses between the two (`flexure::AxisModel::rate_diffusion`,
//! `align::departure_gain`). Without that noise the rate NIS was 1.48, 3.56 and
//! 8.17 here and the NEES of the nine calibrated states 109.4.

mod truth_handed;

/// Blind draw 25 at 300 s (`flexcal simulate --blind --seed 25 --duration 300 --drawn F`).
const NOISELESS_MASTER_DRAW_25: &str = r#"name = "blind-25"
duration_s = 300.0
misalignment_deg = [1.2904446810236196, 0.6034974347876233, -0.9364944531128434]

[site]
lat_deg = 16.133834216289074
lon_deg = 151.43662939253636
height_m = 0.0

[motion]
roll_amp_deg = 9.794105122069158
roll_period_s = 9.589692857996205
pitch_amp_deg = 2.6498510352446667
pitch_period_s = 9.438658220753304
yaw_amp_deg = 1.171418414844856
yaw_period_s = 6.6687587226941485
heading_deg = 238.41367742403784
speed_mps = 0.0

[lever_arm]
r0_m = [0.7684084053912024, -8.001216329869266, 6.308120233961706]
bending = "uniform_arc"

[flexure]
kind = "gauss_markov_axes"
sigma_arcmin = [0.7890244560324784, 2.762837044119867, 2.4135643492778565]
omega_rad_s = [1.2121563717018469, 2.402402261360834, 2.237152853554688]
damping = [0.1648396966596717, 0.2725340768430832, 0.18352888491608826]

[slave_imu]
rate_hz = 400.0
gyro_bias_deg_h = [0.36440084581900034, 0.9409439360175836, -0.00945856736162544]
accel_bias_mg = [-0.5426766032182859, 0.9492356295388901, -1.3681654932231309]
gyro_scale_ppm = [0.0, 0.0, 0.0]
accel_scale_ppm = [0.0, 0.0, 0.0]
gyro_nonorthogonality_urad = [0.0, 0.0, 0.0]
accel_nonorthogonality_urad = [0.0, 0.0, 0.0]
gyro_g_sensitivity_deg_h_per_g = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
gyro_arw_deg_rh = 0.0006394027248176684
accel_vrw_mps_rh = 0.0007565348262711159

[master]
rate_hz = 10.0
gives_rate = true
velocity_noise_mps = 0.0
attitude_noise_deg = 0.0
rate_noise_deg_h = 0.0

[undeclared]
master_delay_s = 0.0
master_delay_rate = 0.0
lever_arm_error_m = [0.0, 0.0, 0.0]
"#;

#[test]
fn rate_matching_against_a_noiseless_master_is_not_overconfident_handed_its_model() {
    let tmp = tempfile::tempdir().unwrap();
    let s = truth_handed::calibrate(tmp.path(), NOISELESS_MASTER_DRAW_25, 25);
    // Each rate axis's mean NIS at most its band's upper edge (one-sided: the master's
    // white floors keep the truth model pessimistic elsewhere, 0.79–0.91 here).
    for r in s["residuals"].as_array().unwrap() {
        if r["channel"].as_str() == Some("angular_rate") {
            let (nis, axis) = (r["nis_mean"].as_f64().unwrap(), r["axis"].as_u64().unwrap());
            let count = r["count"].as_f64().unwrap();
            // The mean of `count` χ²(1) draws: σ √(2 / count); 3σ above 1.
            let upper = 1.0 + 3.0 * (2.0 / count).sqrt();
            assert!(
                nis < upper,
                "angular_rate {axis}: NIS {nis:.2} over {upper:.3}"
            );
        }
    }
    // χ²(9)'s 0.999 quantile is 27.88.
    let nees = s["errors"]["nees_mean"].as_f64().unwrap();
    assert!(nees < 27.88, "NEES {nees:.1}");
}
