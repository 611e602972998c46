//! Blind scenarios: a scenario drawn at random, seeded, from stated ranges, so that a
//! calibration can be scored on data whose model nobody handed the filter.
//!
//! `flexcal simulate --blind` writes the recording with **no** `calibrate.toml`; what
//! was drawn goes to a separate scenario file (`--drawn`, outside the recording), which
//! only scoring reads. Everything is drawn from the seed alone: the same seed gives the
//! same scenario and the same recording.
//!
//! The ranges ([`RANGES`] documents them; `docs/model-learning.md` copies the table):
//! noise levels log-uniform over 0.1–10× the built-in `moored` values; the master's
//! output errors one of none, white (0.1–10× the defaults) or smooth (first-order
//! Gauss-Markov, σ up to 30″ and 0.05 m/s, τ 20–200 s); the flexure per axis
//! (ω 0.5–2.5 rad/s, ζ 0.1–0.5, σ 0.3–3′); the lever arm (each axis ±20 m); the motion
//! (moored or under way); the IMU rate (100, 200 or 400 Hz) and the master rate (10, 20,
//! 50 or 100 Hz). Biases and misalignment are drawn from the built-in model's priors
//! (1 °/h, 1 mg, 1° per axis), which a learner may keep or widen.

use super::scenario::{
    Bending, FlexureSpec, ImuSpec, LeverArmSpec, MasterSpec, MotionSpec, Scenario, SiteSpec,
    SmoothError, Undeclared,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// The built-in (`moored`) gyro angle random walk (deg/√h) the noise draws scale.
pub const DEFAULT_GYRO_ARW_DEG_RH: f64 = 0.005;
/// The built-in accelerometer velocity random walk (m/s/√h).
pub const DEFAULT_ACCEL_VRW_MPS_RH: f64 = 0.003;
/// The built-in master velocity noise (m/s).
pub const DEFAULT_VELOCITY_NOISE_MPS: f64 = 0.01;
/// The built-in master attitude noise (deg).
pub const DEFAULT_ATTITUDE_NOISE_DEG: f64 = 0.005;
/// The built-in master rate noise (deg/h).
pub const DEFAULT_RATE_NOISE_DEG_H: f64 = 20.0;

/// The stated ranges of a blind draw, one line each (`name: range`), for reports.
pub const RANGES: [&str; 12] = [
    "gyro ARW: 0.1-10x 0.005 deg/rt-h, log-uniform",
    "accel VRW: 0.1-10x 0.003 m/s/rt-h, log-uniform",
    "master errors: none | white | smooth, equally likely",
    "white master: velocity 0.1-10x 0.01 m/s, attitude 0.1-10x 0.005 deg, rate 0.1-10x 20 deg/h, log-uniform",
    "smooth master: Gauss-Markov, attitude 3-30 arcsec, velocity 0.005-0.05 m/s, tau 20-200 s",
    "flexure per axis: omega 0.5-2.5 rad/s, damping 0.1-0.5, sigma 0.3-3 arcmin",
    "lever arm: each axis uniform in [-20, 20] m, uniform-arc bending",
    "biases: N(0, 1 deg/h) gyro, N(0, 1 mg) accel per axis; misalignment N(0, 1 deg) per axis",
    "motion: roll 5-15 deg / 6-14 s, pitch 2-6 deg / 5-12 s, yaw 1-4 deg / 4-10 s; speed 0 (half) or 1-8 m/s",
    "site: latitude -60..60 deg, longitude -180..180 deg",
    "IMU rate: 100 | 200 | 400 Hz; master rate: 10 | 20 | 50 | 100 Hz (at most the IMU rate)",
    "undeclared effects: only when asked (--effect, one or more), each sized from its own range (bias instabilities: a random walk wandering 0.3-3 deg/h or mg over the run; mounting drift: 0.5-5 arcmin; log-uniform)",
];

/// An undeclared effect a blind draw may carry, sized from its range.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum BlindEffect {
    /// Master output delay: 10, 20 or 50 ms.
    TimeDelay,
    /// Surveyed lever arm off by 0.5 m in a random direction.
    LeverArmError,
    /// Gyro scale factors, 100–800 ppm per axis, random sign.
    GyroScaleFactor,
    /// Accelerometer scale factors, 100–800 ppm per axis, random sign.
    AccelScaleFactor,
    /// Gyro non-orthogonality, 100–800 µrad per pair, random sign.
    GyroNonorthogonality,
    /// Accelerometer non-orthogonality, 100–800 µrad per pair, random sign.
    AccelNonorthogonality,
    /// Gyro g-sensitivity 0.5 °/h/g on the diagonal, random sign.
    GyroGSensitivity,
    /// Master clock drift: the delay grows from 0 at the start to 10–50 ms (uniform)
    /// at the end of the run (`undeclared.master_delay_rate` = that / duration).
    ClockDrift,
    /// Gyro bias instability: each axis's bias a random walk that wanders 0.3–3 °/h
    /// (1σ, log-uniform) over the run (`slave_imu.gyro_bias_rw_deg_h_rh`).
    GyroBiasInstability,
    /// Accelerometer bias instability: each axis's bias a random walk that wanders
    /// 0.3–3 mg (1σ, log-uniform) over the run (`slave_imu.accel_bias_rw_mg_rh`).
    AccelBiasInstability,
    /// Mounting drift (thermal bending): the misalignment a random walk that wanders
    /// 0.5–5′ (1σ per axis, log-uniform) over the run
    /// (`undeclared.misalignment_rw_arcmin_rh`).
    MisalignmentDrift,
}

/// The mounting drift's wander over a blind run, 1σ per axis (arcmin): log-uniform.
pub const MISALIGNMENT_WANDER_ARCMIN: (f64, f64) = (0.5, 5.0);

/// The bias instabilities' wander over a blind run, 1σ per axis, in units of the
/// drawn biases' own σ (1 °/h, 1 mg): log-uniform in this range.
pub const BIAS_WANDER_OVER_RUN: (f64, f64) = (0.3, 3.0);

/// A random walk's density (per √h) that wanders a log-uniform draw from `(lo, hi)`
/// (1σ, the walk's unit) over `duration_s`.
fn walk_density(rng: &mut impl Rng, (lo, hi): (f64, f64), duration_s: f64) -> f64 {
    log_uniform(rng, lo, hi) / (duration_s.max(1.0) / 3600.0).sqrt()
}

/// The clock drift's delay at the end of a blind run (s): uniform in this range.
pub const CLOCK_DRIFT_END_DELAY_S: (f64, f64) = (0.010, 0.050);

/// Log-uniform in `[lo, hi]`.
fn log_uniform(rng: &mut impl Rng, lo: f64, hi: f64) -> f64 {
    (rng.gen_range(lo.ln()..=hi.ln())).exp()
}

fn normal3(rng: &mut impl Rng, sigma: f64) -> [f64; 3] {
    [0; 3].map(|_| sigma * rng.sample::<f64, _>(StandardNormal))
}

fn uniform3(rng: &mut impl Rng, lo: f64, hi: f64) -> [f64; 3] {
    [0; 3].map(|_| rng.gen_range(lo..=hi))
}

/// Magnitudes in `[lo, hi]` with random signs.
fn signed3(rng: &mut impl Rng, lo: f64, hi: f64) -> [f64; 3] {
    [0; 3].map(|_| {
        let m = rng.gen_range(lo..=hi);
        if rng.gen_bool(0.5) {
            m
        } else {
            -m
        }
    })
}

/// Draws a blind scenario of `duration_s` from `seed` (see the module doc), with the
/// undeclared `effect` when given.
pub fn draw(seed: u64, duration_s: f64, effect: Option<BlindEffect>) -> Scenario {
    draw_effects(seed, duration_s, effect.as_slice())
}

/// [`draw`] with several undeclared effects at once, each sized from its own range in
/// the order given (one effect draws exactly what [`draw`] draws).
pub fn draw_effects(seed: u64, duration_s: f64, effects: &[BlindEffect]) -> Scenario {
    // A stream of its own: the simulation's seed is the same number, its stream not.
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0xb1_17d0_5eed);
    let imu_rate: f64 = [100.0, 200.0, 400.0][rng.gen_range(0..3)];
    let master_rate: f64 = [10.0, 20.0, 50.0, 100.0][rng.gen_range(0..4)];
    let gyro_arw = DEFAULT_GYRO_ARW_DEG_RH * log_uniform(&mut rng, 0.1, 10.0);
    let accel_vrw = DEFAULT_ACCEL_VRW_MPS_RH * log_uniform(&mut rng, 0.1, 10.0);
    let (white, smooth) = match rng.gen_range(0..3) {
        0 => ([0.0; 3], None),
        1 => (
            [
                DEFAULT_VELOCITY_NOISE_MPS * log_uniform(&mut rng, 0.1, 10.0),
                DEFAULT_ATTITUDE_NOISE_DEG * log_uniform(&mut rng, 0.1, 10.0),
                DEFAULT_RATE_NOISE_DEG_H * log_uniform(&mut rng, 0.1, 10.0),
            ],
            None,
        ),
        _ => (
            [0.0; 3],
            Some(SmoothError {
                attitude_arcsec: rng.gen_range(3.0..=30.0),
                velocity_mps: rng.gen_range(0.005..=0.05),
                correlation_s: rng.gen_range(20.0..=200.0),
            }),
        ),
    };
    let flexure = FlexureSpec::GaussMarkovAxes {
        sigma_arcmin: uniform3(&mut rng, 0.3, 3.0),
        omega_rad_s: uniform3(&mut rng, 0.5, 2.5),
        damping: uniform3(&mut rng, 0.1, 0.5),
    };
    let under_way = rng.gen_bool(0.5);
    let motion = MotionSpec {
        roll_amp_deg: rng.gen_range(5.0..=15.0),
        roll_period_s: rng.gen_range(6.0..=14.0),
        pitch_amp_deg: rng.gen_range(2.0..=6.0),
        pitch_period_s: rng.gen_range(5.0..=12.0),
        yaw_amp_deg: rng.gen_range(1.0..=4.0),
        yaw_period_s: rng.gen_range(4.0..=10.0),
        heading_deg: rng.gen_range(0.0..360.0),
        speed_mps: if under_way {
            rng.gen_range(1.0..=8.0)
        } else {
            0.0
        },
    };
    let site = SiteSpec {
        lat_deg: rng.gen_range(-60.0..=60.0),
        lon_deg: rng.gen_range(-180.0..=180.0),
        height_m: 0.0,
    };
    let lever = uniform3(&mut rng, -20.0, 20.0);
    let gyro_bias = normal3(&mut rng, 1.0);
    let accel_bias = normal3(&mut rng, 1.0);
    let misalignment = normal3(&mut rng, 1.0);
    let mut imu = ImuSpec {
        rate_hz: imu_rate,
        gyro_bias_deg_h: gyro_bias,
        accel_bias_mg: accel_bias,
        gyro_scale_ppm: [0.0; 3],
        accel_scale_ppm: [0.0; 3],
        gyro_nonorthogonality_urad: [0.0; 3],
        accel_nonorthogonality_urad: [0.0; 3],
        gyro_g_sensitivity_deg_h_per_g: [0.0; 9],
        gyro_arw_deg_rh: gyro_arw,
        accel_vrw_mps_rh: accel_vrw,
        gyro_bias_rw_deg_h_rh: 0.0,
        accel_bias_rw_mg_rh: 0.0,
    };
    let mut undeclared = Undeclared::default();
    for effect in effects {
        match effect {
            BlindEffect::TimeDelay => {
                undeclared.master_delay_s = [0.010, 0.020, 0.050][rng.gen_range(0..3)];
            }
            BlindEffect::LeverArmError => {
                let d = normal3(&mut rng, 1.0);
                let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt().max(1e-12);
                undeclared.lever_arm_error_m = d.map(|v| 0.5 * v / n);
            }
            BlindEffect::GyroScaleFactor => imu.gyro_scale_ppm = signed3(&mut rng, 100.0, 800.0),
            BlindEffect::AccelScaleFactor => imu.accel_scale_ppm = signed3(&mut rng, 100.0, 800.0),
            BlindEffect::GyroNonorthogonality => {
                imu.gyro_nonorthogonality_urad = signed3(&mut rng, 100.0, 800.0)
            }
            BlindEffect::AccelNonorthogonality => {
                imu.accel_nonorthogonality_urad = signed3(&mut rng, 100.0, 800.0)
            }
            BlindEffect::GyroGSensitivity => {
                let s = signed3(&mut rng, 0.5, 0.5);
                imu.gyro_g_sensitivity_deg_h_per_g =
                    [s[0], 0.0, 0.0, 0.0, s[1], 0.0, 0.0, 0.0, s[2]];
            }
            BlindEffect::ClockDrift => {
                let (lo, hi) = CLOCK_DRIFT_END_DELAY_S;
                undeclared.master_delay_rate = rng.gen_range(lo..=hi) / duration_s.max(1.0);
            }
            BlindEffect::GyroBiasInstability => {
                imu.gyro_bias_rw_deg_h_rh = walk_density(&mut rng, BIAS_WANDER_OVER_RUN, duration_s)
            }
            BlindEffect::AccelBiasInstability => {
                imu.accel_bias_rw_mg_rh = walk_density(&mut rng, BIAS_WANDER_OVER_RUN, duration_s)
            }
            BlindEffect::MisalignmentDrift => {
                undeclared.misalignment_rw_arcmin_rh =
                    walk_density(&mut rng, MISALIGNMENT_WANDER_ARCMIN, duration_s)
            }
        }
    }
    let names: Vec<&str> = effects.iter().map(|e| effect_name(*e)).collect();
    Scenario {
        name: if names.is_empty() {
            format!("blind-{seed}")
        } else {
            format!("blind-{seed}-{}", names.join("+"))
        },
        duration_s,
        site,
        motion,
        lever_arm: LeverArmSpec {
            r0_m: lever,
            bending: Bending::UniformArc,
        },
        flexure,
        misalignment_deg: misalignment,
        slave_imu: imu,
        master: MasterSpec {
            rate_hz: master_rate.min(imu_rate),
            gives_rate: true,
            velocity_noise_mps: white[0],
            attitude_noise_deg: white[1],
            rate_noise_deg_h: white[2],
            smooth_error: smooth,
        },
        undeclared,
    }
}

/// The effect's name in `docs/diagnosis.md`'s vocabulary.
pub fn effect_name(e: BlindEffect) -> &'static str {
    match e {
        BlindEffect::TimeDelay => "time_delay",
        BlindEffect::LeverArmError => "lever_arm_error",
        BlindEffect::GyroScaleFactor => "gyro_scale_factor",
        BlindEffect::AccelScaleFactor => "accel_scale_factor",
        BlindEffect::GyroNonorthogonality => "gyro_nonorthogonality",
        BlindEffect::AccelNonorthogonality => "accel_nonorthogonality",
        BlindEffect::GyroGSensitivity => "gyro_g_sensitivity",
        BlindEffect::ClockDrift => "clock_drift",
        BlindEffect::GyroBiasInstability => "gyro_bias_instability",
        BlindEffect::AccelBiasInstability => "accel_bias_instability",
        BlindEffect::MisalignmentDrift => "misalignment_drift",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_seed_draws_one_valid_scenario() {
        for seed in 0..200 {
            let a = draw(seed, 60.0, None);
            assert_eq!(
                a,
                draw(seed, 60.0, None),
                "seed {seed} draws twice the same"
            );
            a.validate().expect("a drawn scenario validates");
        }
        assert_ne!(draw(1, 60.0, None), draw(2, 60.0, None));
    }

    #[test]
    fn draws_cover_their_ranges() {
        let draws: Vec<Scenario> = (0..300).map(|s| draw(s, 60.0, None)).collect();
        let arw: Vec<f64> = draws.iter().map(|s| s.slave_imu.gyro_arw_deg_rh).collect();
        let lo = arw.iter().cloned().fold(f64::INFINITY, f64::min);
        let hi = arw.iter().cloned().fold(0.0, f64::max);
        let d = DEFAULT_GYRO_ARW_DEG_RH;
        assert!((0.1 * d..0.2 * d).contains(&lo), "smallest ARW {lo}");
        assert!((5.0 * d..=10.0 * d).contains(&hi), "largest ARW {hi}");
        let kinds = |f: &dyn Fn(&MasterSpec) -> bool| draws.iter().filter(|s| f(&s.master)).count();
        let noiseless = kinds(&|m| m.velocity_noise_mps == 0.0 && m.smooth_error.is_none());
        let smooth = kinds(&|m| m.smooth_error.is_some());
        assert!(
            noiseless > 60 && smooth > 60,
            "{noiseless} noiseless, {smooth} smooth"
        );
        for s in &draws {
            let ratio = s.slave_imu.rate_hz / s.master.rate_hz;
            assert_eq!(ratio, ratio.round(), "{}", s.name);
        }
    }

    #[test]
    fn an_effect_is_drawn_in_its_range_and_nothing_else() {
        let s = draw(5, 60.0, Some(BlindEffect::TimeDelay));
        assert!([0.010, 0.020, 0.050].contains(&s.undeclared.master_delay_s));
        assert_eq!(s.slave_imu.gyro_scale_ppm, [0.0; 3]);
        let s = draw(5, 60.0, Some(BlindEffect::GyroScaleFactor));
        assert!(s
            .slave_imu
            .gyro_scale_ppm
            .iter()
            .all(|v| (100.0..=800.0).contains(&v.abs())));
        assert_eq!(s.undeclared.master_delay_s, 0.0);
        let s = draw(5, 60.0, Some(BlindEffect::LeverArmError));
        let n: f64 = s.undeclared.lever_arm_error_m.iter().map(|v| v * v).sum();
        assert!((n.sqrt() - 0.5).abs() < 1e-12);
        assert_eq!(s.undeclared.master_delay_rate, 0.0);
        for seed in 0..50 {
            let s = draw(seed, 300.0, Some(BlindEffect::ClockDrift));
            let end = s.undeclared.master_delay_rate * 300.0;
            assert!(
                (0.010..=0.050).contains(&end),
                "seed {seed}: {end} s at the end"
            );
            assert_eq!(s.undeclared.master_delay_s, 0.0);
            s.validate().expect("a clock drift draw validates");
            // The instabilities wander 0.3–3 bias σ over the run, each alone.
            let s = draw(seed, 300.0, Some(BlindEffect::GyroBiasInstability));
            let wander = s.slave_imu.gyro_bias_rw_deg_h_rh * (300.0f64 / 3600.0).sqrt();
            assert!((0.3..=3.0).contains(&wander), "seed {seed}: {wander} deg/h");
            assert_eq!(s.slave_imu.accel_bias_rw_mg_rh, 0.0);
            let s = draw(seed, 600.0, Some(BlindEffect::AccelBiasInstability));
            let wander = s.slave_imu.accel_bias_rw_mg_rh * (600.0f64 / 3600.0).sqrt();
            assert!(
                (0.3..=3.0 + 1e-12).contains(&wander),
                "seed {seed}: {wander} mg"
            );
            assert_eq!(s.slave_imu.gyro_bias_rw_deg_h_rh, 0.0);
            let s = draw(seed, 300.0, Some(BlindEffect::MisalignmentDrift));
            let wander = s.undeclared.misalignment_rw_arcmin_rh * (300.0f64 / 3600.0).sqrt();
            assert!(
                (0.5..=5.0 + 1e-12).contains(&wander),
                "seed {seed}: {wander}′"
            );
            assert_eq!(s.slave_imu.accel_bias_rw_mg_rh, 0.0);
        }
    }

    #[test]
    fn two_effects_are_drawn_together_and_one_draws_as_before() {
        let one = draw(5, 60.0, Some(BlindEffect::TimeDelay));
        assert_eq!(draw_effects(5, 60.0, &[BlindEffect::TimeDelay]), one);
        let two = draw_effects(
            5,
            60.0,
            &[BlindEffect::TimeDelay, BlindEffect::LeverArmError],
        );
        assert_eq!(two.undeclared.master_delay_s, one.undeclared.master_delay_s);
        let n: f64 = two.undeclared.lever_arm_error_m.iter().map(|v| v * v).sum();
        assert!((n.sqrt() - 0.5).abs() < 1e-12);
        assert_eq!(two.name, "blind-5-time_delay+lever_arm_error");
        two.validate().expect("a two-effect draw validates");
    }
}
