//! The master delay read from attitude and rate together (docs/diagnosis.md, "Session
//! 14"): blind draw 129's model (a 20 Hz master with no white noise, a 400 Hz slave IMU,
//! second-order flexure modes of 1.2–2.4 rad/s), **handed its truth on purpose**: the
//! check is of the delay's columns, not of the learner. The flexure states can mimic a
//! delay (`ω τ` in attitude, `ω̇ τ` in rate is a flexure trajectory); the two channels
//! must see the delay as one column and its derivative. The rate column was the slope
//! of a parabola through the master's past rates (6.3 % large and 16 ms late at the
//! ship's 1.14 rad/s yaw) and zero until those rates covered their window: the pair
//! read that as information, and a 20 ms delay as 10.4 and 8.1 ms at σ 0.09 ms.

mod truth_handed;

/// Blind draw 129 (`flexcal simulate --blind --seed 129 --duration 300 --drawn F`) with
/// a 20 ms master delay.
const DRAW_129_DELAYED_20_MS: &str = r#"name = "blind-129"
duration_s = 300.0
misalignment_deg = [0.05526177036931871, -0.014106949214624822, 1.116809029429044]

[site]
lat_deg = -54.914830439390386
lon_deg = 160.95547439863316
height_m = 0.0

[motion]
roll_amp_deg = 8.235943469788293
roll_period_s = 12.909175830611876
pitch_amp_deg = 3.1584663484853497
pitch_period_s = 11.645301260977352
yaw_amp_deg = 3.490055761957562
yaw_period_s = 5.513719214485025
heading_deg = 109.92583196278571
speed_mps = 5.397448702386011

[lever_arm]
r0_m = [18.945076185216372, -2.773912324421733, -4.441132325004947]
bending = "uniform_arc"

[flexure]
kind = "gauss_markov_axes"
sigma_arcmin = [0.5371663418343896, 0.8042249288865344, 1.324495448039248]
omega_rad_s = [1.1531728790983808, 2.363889739425527, 1.4398823874811197]
damping = [0.27249519899297003, 0.3315211353505718, 0.20202501349309065]

[slave_imu]
rate_hz = 400.0
gyro_bias_deg_h = [-1.3068094512953599, -0.31298448730435885, -1.198698595946023]
accel_bias_mg = [0.16346869286835722, -0.06537422191618911, 0.13988188849998517]
gyro_scale_ppm = [0.0, 0.0, 0.0]
accel_scale_ppm = [0.0, 0.0, 0.0]
gyro_nonorthogonality_urad = [0.0, 0.0, 0.0]
accel_nonorthogonality_urad = [0.0, 0.0, 0.0]
gyro_g_sensitivity_deg_h_per_g = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
gyro_arw_deg_rh = 0.0007356695906555124
accel_vrw_mps_rh = 0.0008205174770093207

[master]
rate_hz = 20.0
gives_rate = true
velocity_noise_mps = 0.0
attitude_noise_deg = 0.0
rate_noise_deg_h = 0.0

[master.smooth_error]
attitude_arcsec = 9.537225869379128
velocity_mps = 0.0266230538236931
correlation_s = 179.0667089056773

[undeclared]
master_delay_s = 0.02
master_delay_rate = 0.0
lever_arm_error_m = [0.0, 0.0, 0.0]
"#;

/// Draw 129 reduced to one axis and no noise: the ship yawing only, no flexure in the
/// data (0.001′ and 0.00001′), no gyro bias or noise, no smooth master error, no
/// mounting, a 5 ms delay.
fn draw_129_yaw_only_noise_free_5_ms() -> String {
    [
        ("misalignment_deg", "[0.0, 0.0, 0.0]"),
        ("roll_amp_deg", "0.0"),
        ("pitch_amp_deg", "0.0"),
        ("sigma_arcmin", "[0.001, 0.001, 0.00001]"),
        ("gyro_bias_deg_h", "[0.0, 0.0, 0.0]"),
        ("gyro_arw_deg_rh", "0.0000001"),
        ("attitude_arcsec", "0.0"),
        ("velocity_mps", "0.0"),
        ("master_delay_s", "0.005"),
    ]
    .iter()
    .fold(DRAW_129_DELAYED_20_MS.to_string(), |s, (key, value)| {
        set(&s, key, &format!("{key} = {value}"))
    })
}

/// The estimated delay and its σ (s) from a summary with one effect.
fn delay(summary: &serde_json::Value) -> (f64, f64) {
    let e = &summary["effects"][0];
    (
        e["estimate"][0].as_f64().unwrap(),
        e["sigma"][0].as_f64().unwrap(),
    )
}

/// The declared model with the delay added to its effects (a smooth master's error
/// states kept).
fn with_delay(config: &str) -> String {
    config
        .lines()
        .map(|l| match l.strip_prefix("effects = [") {
            Some("]") => "effects = [\"time_delay\"]".to_string(),
            Some(rest) => format!("effects = [\"time_delay\", {rest}"),
            None => l.to_string(),
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// Replaces the declared model's line that starts with `key =` by `line`.
fn set(config: &str, key: &str, line: &str) -> String {
    config
        .lines()
        .map(|l| {
            if l.starts_with(&format!("{key} =")) {
                line.to_string()
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn a_20_ms_delay_is_found_with_every_channel_matched_handed_its_model() {
    let tmp = tempfile::tempdir().unwrap();
    let s =
        truth_handed::calibrate_edited(tmp.path(), DRAW_129_DELAYED_20_MS, 1, |c| with_delay(&c));
    let (tau, sigma) = delay(&s);
    // Before: 10.4 ± 0.09 ms on this seed.
    assert!(
        (tau - 0.02).abs() < 3.0 * sigma,
        "delay {:.2} ± {:.2} ms for 20 ms",
        tau * 1e3,
        sigma * 1e3
    );
}

#[test]
fn attitude_and_rate_together_claim_no_more_than_a_reference_filter_handed_its_model() {
    let tmp = tempfile::tempdir().unwrap();
    let s =
        truth_handed::calibrate_edited(tmp.path(), &draw_129_yaw_only_noise_free_5_ms(), 1, |c| {
            let c = set(
                &c,
                "matching",
                "matching = [\"attitude\", \"angular_rate\"]",
            );
            let c = with_delay(&c);
            // The filter keeps draw 129's yaw mode (1.3245′), which the data do not have.
            let c = set(
                &c,
                "flexure_gauss_markov",
                "flexure_gauss_markov = [[1.1531728790983808, 0.27249519899297003, 2.9e-7], \
             [2.363889739425527, 0.3315211353505718, 2.9e-7], \
             [1.4398823874811197, 0.20202501349309065, 3.852801082660392e-4]]",
            );
            let c = set(&c, "flexure_axes", "");
            let c = set(
                &c,
                "initial_misalignment_rad",
                "initial_misalignment_rad = 1e-9",
            );
            set(
                &c,
                "initial_gyro_bias_radps",
                "initial_gyro_bias_radps = 1e-12",
            )
        });
    let (tau, sigma) = delay(&s);
    // `python3 scripts/delay-1d-reference.py` (one axis, the mode sampled exactly, apart
    // from the engine) gives σ 0.684 ms on this motion with attitude, rate or both.
    // Before: 0.22 ± 0.11 ms.
    assert!(
        (0.5e-3..0.9e-3).contains(&sigma),
        "σ {:.3} ms against the reference's 0.684",
        sigma * 1e3
    );
    assert!(
        (tau - 0.005).abs() < 3.0 * sigma,
        "delay {:.2} ± {:.2} ms for 5 ms",
        tau * 1e3,
        sigma * 1e3
    );
}
