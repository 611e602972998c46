//! Scenarios: what the truth simulator simulates, as TOML files or built-ins.
//!
//! Units are in the key names. Built-ins: `paper` (the paper's section 4 as printed),
//! `moored` (plausible flexure; only the errors the 21-state model declares) and
//! `matched` (like `moored`, but the flexure truth *is* the filter's AR(2) model, so
//! the filter's model matches the truth exactly: the Monte Carlo consistency case).
//!
//! Effects the filter's 21-state model does not contain, for testing the diagnosis
//! of a misfit, are opt-in: the slave IMU's scale factors, non-orthogonality and
//! g-sensitivity (`[slave_imu]`), and the master's output delay, a wrong surveyed
//! lever arm and a velocity wave (`[undeclared]`). All default to zero (absent).

use serde::{Deserialize, Serialize};

/// A complete simulation scenario.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Scenario name (reports).
    pub name: String,
    /// Simulated time (s).
    pub duration_s: f64,
    /// Master INS position at the start.
    pub site: SiteSpec,
    /// Master motion.
    pub motion: MotionSpec,
    /// Lever arm and how flexure bends it.
    pub lever_arm: LeverArmSpec,
    /// Flexure truth.
    pub flexure: FlexureSpec,
    /// Mounting misalignment μ (deg, rotation vector).
    pub misalignment_deg: [f64; 3],
    /// Slave IMU.
    pub slave_imu: ImuSpec,
    /// Master INS output.
    pub master: MasterSpec,
    /// Effects outside the slave IMU that the filter's model does not declare.
    /// Absent: none.
    #[serde(default)]
    pub undeclared: Undeclared,
}

/// Site of the master at the start.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SiteSpec {
    /// Latitude (deg).
    pub lat_deg: f64,
    /// Longitude (deg).
    pub lon_deg: f64,
    /// Height (m).
    pub height_m: f64,
}

/// Master motion: cosine roll, pitch and yaw about a mean heading, and a constant
/// velocity (zero: moored). Attitude is `C_bm^n = Rz(yaw) Rx(pitch) Ry(roll)`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MotionSpec {
    /// Roll amplitude (deg) about the forward axis.
    pub roll_amp_deg: f64,
    /// Roll period (s).
    pub roll_period_s: f64,
    /// Pitch amplitude (deg) about the right axis.
    pub pitch_amp_deg: f64,
    /// Pitch period (s).
    pub pitch_period_s: f64,
    /// Yaw amplitude (deg) about up.
    pub yaw_amp_deg: f64,
    /// Yaw period (s).
    pub yaw_period_s: f64,
    /// Mean yaw (deg, counter-clockwise from north about up).
    #[serde(default)]
    pub heading_deg: f64,
    /// Speed over ground along the mean heading (m/s).
    #[serde(default)]
    pub speed_mps: f64,
}

/// Lever arm r0 and the bending model R.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct LeverArmSpec {
    /// r0 from master to slave, master body frame (m).
    pub r0_m: [f64; 3],
    /// `"paper"` (eq. 21 as printed) or `"uniform_arc"` (R = −½[r0×]).
    pub bending: Bending,
}

/// The bending model of the lever arm.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Bending {
    /// Eq. (21) as printed.
    Paper,
    /// Uniform circular bend.
    UniformArc,
}

/// Flexure truth, the same on each axis.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum FlexureSpec {
    /// No flexure.
    None,
    /// A discrete AR(2) process `θ_k = a1 θ_{k−1} + a2 θ_{k−2} + η` at `period_s`,
    /// linear between samples (its rate is then exactly the backward difference).
    Ar {
        /// `[a1, a2]`.
        coefficients: [f64; 2],
        /// σ of η (deg).
        sigma_deg: f64,
        /// Sample period (s).
        period_s: f64,
    },
    /// Second-order Gauss-Markov `θ̈ + 2ζω θ̇ + ω² θ = w`, exactly discretized on the
    /// simulator's fine grid, with stationary σ of θ.
    GaussMarkov {
        /// Stationary σ of θ (arcmin).
        sigma_arcmin: f64,
        /// Natural frequency ω (rad/s).
        omega_rad_s: f64,
        /// Damping ratio ζ.
        damping: f64,
    },
    /// The same second-order Gauss-Markov model with its own natural frequency,
    /// damping and size on each slave axis (x, y, z): a hull bends differently about
    /// each axis.
    GaussMarkovAxes {
        /// Stationary σ of θ per axis (arcmin).
        sigma_arcmin: [f64; 3],
        /// Natural frequency ω per axis (rad/s).
        omega_rad_s: [f64; 3],
        /// Damping ratio ζ per axis.
        damping: [f64; 3],
    },
}

/// Slave IMU errors and rate. Biases and scale factors are per axis.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ImuSpec {
    /// Output rate (Hz).
    pub rate_hz: f64,
    /// Gyro bias (deg/h).
    pub gyro_bias_deg_h: [f64; 3],
    /// Accelerometer bias (mg, 1 mg = 9.80665e-3 m/s²).
    pub accel_bias_mg: [f64; 3],
    /// Gyro scale factor error (ppm).
    #[serde(default)]
    pub gyro_scale_ppm: [f64; 3],
    /// Accelerometer scale factor error (ppm).
    #[serde(default)]
    pub accel_scale_ppm: [f64; 3],
    /// Gyro axis non-orthogonality: `[xy, xz, yz]` small angles (µrad), symmetric:
    /// the gyro measures `(I + S_g + N_g) ω` with
    /// `N_g = [[0, xy, xz], [xy, 0, yz], [xz, yz, 0]] · 1e-6`.
    #[serde(default)]
    pub gyro_nonorthogonality_urad: [f64; 3],
    /// Accelerometer axis non-orthogonality: `[xy, xz, yz]` small angles (µrad),
    /// symmetric, the gyro's convention: the accelerometer measures `(I + S_a + N_a) f`
    /// with `N_a = [[0, xy, xz], [xy, 0, yz], [xz, yz, 0]] · 1e-6`.
    #[serde(default)]
    pub accel_nonorthogonality_urad: [f64; 3],
    /// Gyro g-sensitivity `G`, a 3×3 matrix row by row (deg/h per g,
    /// g = 9.80665 m/s²): the gyro measures `ω + G f` in addition to its other errors,
    /// `f` the true specific force in the slave body frame.
    #[serde(default)]
    pub gyro_g_sensitivity_deg_h_per_g: [f64; 9],
    /// Gyro angle random walk (deg/√h).
    pub gyro_arw_deg_rh: f64,
    /// Accelerometer velocity random walk (m/s/√h).
    pub accel_vrw_mps_rh: f64,
    /// Gyro bias instability as a rate random walk (deg/h/√h, per axis): the bias
    /// wanders from `gyro_bias_deg_h` by a Wiener process of this density, σ = RRW·√t
    /// after t hours (the filter's `gyro_bias_rw`, rad/s/√s, is this × DEG_PER_H / 60).
    /// Zero: a constant bias.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub gyro_bias_rw_deg_h_rh: f64,
    /// Accelerometer bias instability as a random walk (mg/√h, per axis): the
    /// accelerometer's counterpart of `gyro_bias_rw_deg_h_rh` (the filter's
    /// `accel_bias_rw`, m/s²/√s, is this × MG / 60). Zero: a constant bias.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub accel_bias_rw_mg_rh: f64,
}

/// Whether a value is exactly zero (an absent effect, not written).
fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// Master INS output.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MasterSpec {
    /// Message rate (Hz).
    pub rate_hz: f64,
    /// Whether messages carry the angular rate.
    pub gives_rate: bool,
    /// White noise on velocity (m/s, per axis).
    pub velocity_noise_mps: f64,
    /// White noise on attitude (deg, per axis).
    pub attitude_noise_deg: f64,
    /// White noise on the angular rate (deg/h, per axis).
    pub rate_noise_deg_h: f64,
    /// A slow, correlated error of the master's attitude and velocity (a real INS's
    /// errors are smooth, not white), if any.
    #[serde(default)]
    pub smooth_error: Option<SmoothError>,
}

/// The master's smooth output error: a first-order Gauss-Markov process per axis,
/// `x_{k+1} = e^{−T/τ} x_k + σ √(1 − e^{−2T/τ}) n_k` at the master period T, started
/// stationary, added to the attitude (a small rotation, navigation frame) and to the
/// velocity (ENU) of every message.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SmoothError {
    /// Stationary σ of the attitude error per axis (arcsec).
    pub attitude_arcsec: f64,
    /// Stationary σ of the velocity error per axis (m/s).
    pub velocity_mps: f64,
    /// Correlation time τ (s).
    pub correlation_s: f64,
}

/// Effects outside the slave IMU that the filter's 21-state model has no state for
/// (`[undeclared]` in a scenario file). The default is none of them.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct Undeclared {
    /// Delay τ of the master's output (s, in [−1, 1]): the message stamped `t` carries
    /// the attitude, velocity, position and angular rate that were true at `t − τ`
    /// (then the noise, as without delay). The slave IMU and all stamps are unchanged.
    /// Negative: the master's tags are early — with either sign, beyond the filter's
    /// reach, a clock offset between the two units (`calib::prefilter`).
    pub master_delay_s: f64,
    /// Drift of the master's clock (s/s, in [−0.01, 0.01]): the delay grows with the
    /// stamp, the message stamped `t` is the master at `t − τ(t)`,
    /// `τ(t) = master_delay_s + master_delay_rate * t` (the recording starts at t = 0).
    /// A clock drift (the `clock_drift` effect).
    pub master_delay_rate: f64,
    /// Time (s, from the recording's start) at which the delay appears, if it does not
    /// from the start: the messages stamped before it are on time, those from it on are
    /// late by `master_delay_s + master_delay_rate * t` (a delay that appears in service,
    /// `docs/diagnosis.md`, "The board watches itself").
    pub master_delay_from_s: Option<f64>,
    /// Drift of the mounting misalignment as a random walk (arcmin/√h, per axis): a
    /// quasi-static bending (thermal) that turns the slave on its mounting, σ =
    /// density·√t after t hours from `misalignment_deg` (the filter's
    /// `misalignment_rw_rad_rs` is this in rad/√s: × π/180/60/60), sampled every
    /// `sim::MOUNTING_STEP_S` and linear in between. The slave's gyros sense the turn.
    /// Zero: a fixed mounting.
    #[serde(skip_serializing_if = "is_zero")]
    pub misalignment_rw_arcmin_rh: f64,
    /// Error of the surveyed lever arm, master body frame (m): the true static arm is
    /// `lever_arm.r0_m + lever_arm_error_m`, and the truth (slave velocity, position,
    /// bending matrix R) uses it, while the recording still declares `lever_arm.r0_m`.
    pub lever_arm_error_m: [f64; 3],
    /// A sinusoid added to the master's output velocity, if any.
    pub master_velocity_wave: Option<VelocityWave>,
    /// The attitude error of a master that is itself a consumer-grade filter: a drift
    /// between its corrections and a step at each correction, if any.
    pub master_attitude_steps: Option<AttitudeSteps>,
}

/// The output attitude error `E(t)` of a master that corrects itself in steps (a
/// consumer-grade attitude filter): a rotation of the navigation frame (ENU) applied on
/// the left of every message's attitude, `q_rep = E(t) q_true`. It starts at zero,
/// turns at `initial_drift_deg_s` until the first step, and at each step's time `t_s`
/// (the master's time tags: every message stamped `t ≥ t_s` has it) jumps by the
/// step's rotation, `E(t_s+) = Exp(rotation) E(t_s−)`, then turns at that step's drift
/// rate: `E(t) = Exp(d_k (t − t_k)) E(t_k+)`. The drift accumulates across the steps.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct AttitudeSteps {
    /// Rate of the error before the first step (deg/s, rotation vector rate, ENU).
    pub initial_drift_deg_s: [f64; 3],
    /// The steps in time order.
    pub steps: Vec<AttitudeStep>,
}

/// One correction of a consumer-grade master (`AttitudeSteps`).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct AttitudeStep {
    /// Time of the step on the master's time tags (s).
    pub t_s: f64,
    /// The jump of the output attitude, a rotation vector in ENU (deg).
    pub rotation_deg: [f64; 3],
    /// The error's rate after it, until the next step (deg/s, ENU).
    pub drift_deg_s: [f64; 3],
}

impl AttitudeSteps {
    /// Checks values a simulation cannot run with; errors name the key and the step.
    fn validate(&self) -> Result<(), String> {
        let finite = |v: &[f64; 3]| v.iter().all(|x| x.is_finite());
        if !finite(&self.initial_drift_deg_s) {
            return Err(format!(
                "`undeclared.master_attitude_steps.initial_drift_deg_s` must be finite numbers, got {:?}",
                self.initial_drift_deg_s
            ));
        }
        let mut before = f64::NEG_INFINITY;
        for (k, s) in self.steps.iter().enumerate() {
            if !(s.t_s.is_finite() && s.t_s > before) {
                return Err(format!(
                    "`undeclared.master_attitude_steps.steps[{k}].t_s` must be a finite time after the step before, got {}",
                    s.t_s
                ));
            }
            if !(finite(&s.rotation_deg) && finite(&s.drift_deg_s)) {
                return Err(format!(
                    "`undeclared.master_attitude_steps.steps[{k}]`: rotation and drift must be finite numbers, got {:?} and {:?}",
                    s.rotation_deg, s.drift_deg_s
                ));
            }
            before = s.t_s;
        }
        Ok(())
    }
}

/// A sinusoidal error of the master's output velocity: the message stamped `t` gets
/// `amplitude_mps · sin(2π t / period_s)` added (ENU).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct VelocityWave {
    /// Amplitude per ENU axis (m/s).
    pub amplitude_mps: [f64; 3],
    /// Period (s).
    pub period_s: f64,
}

const PAPER: &str = include_str!("../../../scenarios/paper.toml");
const MOORED: &str = include_str!("../../../scenarios/moored.toml");
const MATCHED: &str = include_str!("../../../scenarios/matched.toml");

/// Names of the built-in scenarios.
pub const BUILT_IN: [&str; 3] = ["paper", "moored", "matched"];

impl Scenario {
    /// A built-in scenario by name, or a TOML file by path.
    pub fn load(name_or_path: &str) -> Result<Self, String> {
        let (text, origin) = match name_or_path {
            "paper" => (PAPER.to_string(), "built-in `paper`".to_string()),
            "moored" => (MOORED.to_string(), "built-in `moored`".to_string()),
            "matched" => (MATCHED.to_string(), "built-in `matched`".to_string()),
            path => (
                std::fs::read_to_string(path).map_err(|e| {
                    format!(
                        "scenario `{path}`: not a built-in ({}) and not a readable file: {e}",
                        BUILT_IN.join(", ")
                    )
                })?,
                path.to_string(),
            ),
        };
        let s: Scenario = toml::from_str(&text).map_err(|e| format!("scenario {origin}: {e}"))?;
        s.validate()
            .map_err(|e| format!("scenario {origin}: {e}"))?;
        Ok(s)
    }

    /// Checks values a simulation cannot run with.
    pub fn validate(&self) -> Result<(), String> {
        let positive = [
            ("duration_s", self.duration_s),
            ("slave_imu.rate_hz", self.slave_imu.rate_hz),
            ("master.rate_hz", self.master.rate_hz),
            ("motion.roll_period_s", self.motion.roll_period_s),
            ("motion.pitch_period_s", self.motion.pitch_period_s),
            ("motion.yaw_period_s", self.motion.yaw_period_s),
        ];
        for (key, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("`{key}` must be a positive number, got {v}"));
            }
        }
        let ratio = self.slave_imu.rate_hz / self.master.rate_hz;
        if (ratio - ratio.round()).abs() > 1e-9 || ratio < 1.0 {
            return Err(format!(
                "`slave_imu.rate_hz` ({}) must be an integer multiple of `master.rate_hz` ({})",
                self.slave_imu.rate_hz, self.master.rate_hz
            ));
        }
        let densities = [
            (
                "slave_imu.gyro_bias_rw_deg_h_rh",
                self.slave_imu.gyro_bias_rw_deg_h_rh,
            ),
            (
                "slave_imu.accel_bias_rw_mg_rh",
                self.slave_imu.accel_bias_rw_mg_rh,
            ),
        ];
        for (key, v) in densities {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!("`{key}` must be a number ≥ 0, got {v}"));
            }
        }
        if let Some(e) = &self.master.smooth_error {
            let ok = |v: f64| v.is_finite() && v >= 0.0;
            let tau_ok = e.correlation_s.is_finite() && e.correlation_s > 0.0;
            if !(ok(e.attitude_arcsec) && ok(e.velocity_mps) && tau_ok) {
                return Err(format!(
                    "`master.smooth_error` needs σ ≥ 0 and a positive correlation time, got {e:?}"
                ));
            }
        }
        if let FlexureSpec::GaussMarkovAxes {
            sigma_arcmin,
            omega_rad_s,
            damping,
        } = self.flexure
        {
            for k in 0..3 {
                let (s, w, z) = (sigma_arcmin[k], omega_rad_s[k], damping[k]);
                if !(s.is_finite() && s >= 0.0 && w.is_finite() && w > 0.0 && z > 0.0 && z < 1.0) {
                    return Err(format!(
                        "`flexure` axis {k}: needs σ ≥ 0, ω > 0 and 0 < ζ < 1, got σ {s}, ω {w}, ζ {z}"
                    ));
                }
            }
        }
        if let FlexureSpec::Ar { period_s, .. } = self.flexure {
            let k = period_s * self.slave_imu.rate_hz;
            if !(period_s > 0.0 && (k - k.round()).abs() < 1e-9 && k >= 1.0) {
                return Err(format!(
                    "`flexure.period_s` ({period_s}) must be a positive multiple of the IMU period"
                ));
            }
        }
        self.undeclared.validate()
    }
}

impl Undeclared {
    /// Checks values a simulation cannot run with; errors name the key.
    fn validate(&self) -> Result<(), String> {
        let tau = self.master_delay_s;
        if !(tau.is_finite() && (-1.0..=1.0).contains(&tau)) {
            return Err(format!(
                "`undeclared.master_delay_s` must be a number in [-1, 1] s, got {tau}"
            ));
        }
        let rate = self.master_delay_rate;
        if !(rate.is_finite() && (-0.01..=0.01).contains(&rate)) {
            return Err(format!(
                "`undeclared.master_delay_rate` must be a number in [-0.01, 0.01] s/s, got {rate}"
            ));
        }
        if let Some(from) = self.master_delay_from_s {
            if !(from.is_finite() && from >= 0.0) {
                return Err(format!(
                    "`undeclared.master_delay_from_s` must be a time ≥ 0 s, got {from}"
                ));
            }
        }
        let mu_rw = self.misalignment_rw_arcmin_rh;
        if !(mu_rw.is_finite() && mu_rw >= 0.0) {
            return Err(format!(
                "`undeclared.misalignment_rw_arcmin_rh` must be a number ≥ 0, got {mu_rw}"
            ));
        }
        if let Some(v) = self.lever_arm_error_m.iter().find(|v| !v.is_finite()) {
            return Err(format!(
                "`undeclared.lever_arm_error_m` must be finite numbers, got {v}"
            ));
        }
        if let Some(st) = &self.master_attitude_steps {
            st.validate()?;
        }
        if let Some(wave) = &self.master_velocity_wave {
            let period = wave.period_s;
            if !(period.is_finite() && period > 0.0) {
                return Err(format!(
                    "`undeclared.master_velocity_wave.period_s` must be a positive number, got {period}"
                ));
            }
            if let Some(v) = wave.amplitude_mps.iter().find(|v| !v.is_finite()) {
                return Err(format!(
                    "`undeclared.master_velocity_wave.amplitude_mps` must be finite numbers, got {v}"
                ));
            }
        }
        Ok(())
    }
}
