//! The quantities the learner estimates, how each maps onto a [`CalibConfig`], and the
//! flexure kept as a continuous second-order Gauss-Markov model per axis (natural
//! frequency, damping, stationary σ), which the configuration carries as the AR(2) of
//! the filter period.

use crate::calib::config::CalibConfig;
use flexcal_core::augment::Effect;
use flexcal_core::flexure::ArAxis;

/// A continuous flexure model of one axis: `θ̈ + 2ζω θ̇ + ω² θ = w`, stationary σ of θ.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct FlexureAxis {
    /// Natural frequency ω (rad/s).
    pub omega_rad_s: f64,
    /// Damping ratio ζ.
    pub damping: f64,
    /// Stationary σ of θ (rad).
    pub sigma_rad: f64,
}

impl FlexureAxis {
    /// The AR(2) `[a1, a2, σ_η]` of the filter period `t` (s).
    pub fn ar(&self, t: f64) -> [f64; 3] {
        let a = ArAxis::from_gauss_markov(self.omega_rad_s, self.damping, self.sigma_rad, t);
        [a.a1, a.a2, a.sigma_rad]
    }

    /// The continuous model of an AR(2) `[a1, a2, σ_η]` at period `t`, when its poles
    /// are complex and stable (an under-damped second-order system); `None` otherwise.
    pub fn from_ar([a1, a2, sigma]: [f64; 3], t: f64) -> Option<Self> {
        let r2 = -a2;
        if !(r2 > 0.0 && r2 < 1.0) {
            return None;
        }
        let r = r2.sqrt();
        let c = a1 / (2.0 * r);
        if c.is_nan() || c.abs() >= 1.0 {
            return None;
        }
        let wd = c.acos() / t;
        let zw = -r.ln() / t;
        let omega = (wd * wd + zw * zw).sqrt();
        let g0 = (1.0 - a2) / ((1.0 + a2) * ((1.0 - a2) * (1.0 - a2) - a1 * a1));
        (g0 > 0.0 && omega > 0.0).then(|| Self {
            omega_rad_s: omega,
            damping: zw / omega,
            sigma_rad: sigma * g0.sqrt(),
        })
    }
}

/// The built-in flexure when a configuration's AR has no continuous equivalent: the
/// `moored` scenario's (ω = 1 rad/s, ζ = 0.3, 1 arcmin).
pub const DEFAULT_FLEXURE: FlexureAxis = FlexureAxis {
    omega_rad_s: 1.0,
    damping: 0.3,
    sigma_rad: 2.908_882_086_657_216e-4,
};

/// The floor of the master's white velocity noise on the horizontal axes (m/s), kept
/// above the f32 resolution: horizontal velocity is where the tilt and the horizontal
/// accelerometer biases meet, the direction in which the filter handed its own truth is
/// already overconfident (session 10: accelerometer y against misalignment x, 2.04
/// against 1). Floored at the resolution on every axis (blind Monte Carlo, 50 × 600 s,
/// docs/model-learning.md session 11) the noiseless and smooth masters' NIS came to 1
/// (velocity in band 38–46 % → 68–72 % of runs) but that direction's RMS/σ rose 1.22 →
/// 1.38 and the mean NEES 9.95 → 10.34 (seeds 12 and 41: 8.0 → 32.4, 8.8 → 19.2).
pub const HORIZONTAL_VELOCITY_FLOOR_MPS: f64 = 1e-3;

/// The floor of the master's white velocity noise on each ENU axis (m/s): on the
/// vertical the f32 resolution of the velocities compared ([`velocity_resolution_floor`]),
/// horizontally at least [`HORIZONTAL_VELOCITY_FLOOR_MPS`].
pub fn velocity_noise_floor(master_v_n_mps: impl Iterator<Item = [f64; 3]>) -> [f64; 3] {
    let [e, n, u] = velocity_resolution_floor(master_v_n_mps);
    [
        e.max(HORIZONTAL_VELOCITY_FLOOR_MPS),
        n.max(HORIZONTAL_VELOCITY_FLOOR_MPS),
        u,
    ]
}

/// The f32 resolution of the velocities the board compares on each ENU axis (m/s): a
/// velocity held in f32 is rounded to within half a unit in the last place of its size,
/// a uniform error of σ = ulp/√12, and the matching subtracts two of them (the master's
/// and the slave's), so √2 of that at the largest |v| the master reports on the axis.
/// Never below the bound of [`Param::VelocityNoise`]. At 8 m/s: 3.9e-7 m/s.
pub fn velocity_resolution_floor(master_v_n_mps: impl Iterator<Item = [f64; 3]>) -> [f64; 3] {
    let mut largest = [0.0_f64; 3];
    for v in master_v_n_mps {
        for (l, x) in largest.iter_mut().zip(v) {
            if x.is_finite() {
                *l = l.max(x.abs());
            }
        }
    }
    let lo = Param::VelocityNoise(0).bounds().0;
    largest.map(|v| {
        let size = v as f32;
        let ulp = f64::from(f32::from_bits(size.to_bits() + 1) - size);
        (ulp / 12f64.sqrt() * std::f64::consts::SQRT_2).max(lo)
    })
}

/// Axis `k` of a per-axis value (NaN for an axis that does not exist).
fn axis(v: &[f64; 3], k: usize) -> f64 {
    v.get(k).copied().unwrap_or(f64::NAN)
}

/// Sets axis `k` of a per-axis value (nothing for an axis that does not exist).
fn set_axis(v: &mut [f64; 3], k: usize, value: f64) {
    if let Some(slot) = v.get_mut(k) {
        *slot = value;
    }
}

/// One learned quantity.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Param {
    /// Velocity matching noise of an ENU axis (m/s).
    VelocityNoise(usize),
    /// Attitude matching noise of a slave body axis (rad).
    AttitudeNoise(usize),
    /// The master's angular-rate noise on a slave body axis (rad/s).
    RateNoise(usize),
    /// The master's rate noise as the lever arm carries it into the velocity matching
    /// (rad/s); zero: none.
    LeverArmRateNoise,
    /// Gyro angle random walk (rad/√s).
    GyroArw,
    /// Accelerometer velocity random walk (m/s/√s).
    AccelVrw,
    /// Gyro bias instability as a random walk (rad/s/√s).
    GyroBiasRw,
    /// Accelerometer bias instability as a random walk (m/s²/√s).
    AccelBiasRw,
    /// Misalignment random walk (rad/√s).
    MisalignmentRw,
    /// Initial σ of the gyro bias (rad/s): the sensor's grade.
    InitialGyroBias,
    /// Initial σ of the accelerometer bias (m/s²).
    InitialAccelBias,
    /// Initial σ of the mounting misalignment (rad).
    InitialMisalignment,
    /// Stationary σ of the master's smooth attitude error (rad); zero: none (the
    /// `master_attitude_error` block is carried only when it is not zero).
    MasterAttitudeError,
    /// Stationary σ of the master's smooth velocity error (m/s); zero: none.
    MasterVelocityError,
    /// Correlation time of the master's smooth errors (s).
    MasterErrorCorrelation,
    /// Flexure natural frequency of a slave axis (rad/s).
    FlexureOmega(usize),
    /// Flexure damping ratio of a slave axis.
    FlexureDamping(usize),
    /// Flexure stationary σ of a slave axis (rad).
    FlexureSigma(usize),
}

impl Param {
    /// Name in `summary.json` and `model.toml` comments.
    pub fn name(&self) -> String {
        const AX: [&str; 3] = ["x", "y", "z"];
        const ENU: [&str; 3] = ["e", "n", "u"];
        let ax = |k: &usize| AX.get(*k).copied().unwrap_or("?");
        let enu = |k: &usize| ENU.get(*k).copied().unwrap_or("?");
        match self {
            Param::VelocityNoise(k) => format!("velocity_noise_mps_{}", enu(k)),
            Param::AttitudeNoise(k) => format!("attitude_noise_rad_{}", ax(k)),
            Param::RateNoise(k) => format!("rate_noise_radps_{}", ax(k)),
            Param::LeverArmRateNoise => "lever_arm_rate_noise_radps".into(),
            Param::GyroArw => "gyro_arw_rad_rs".into(),
            Param::AccelVrw => "accel_vrw_mps_rs".into(),
            Param::GyroBiasRw => "gyro_bias_rw".into(),
            Param::AccelBiasRw => "accel_bias_rw".into(),
            Param::MisalignmentRw => "misalignment_rw_rad_rs".into(),
            Param::InitialGyroBias => "initial_gyro_bias_radps".into(),
            Param::InitialAccelBias => "initial_accel_bias_mps2".into(),
            Param::InitialMisalignment => "initial_misalignment_rad".into(),
            Param::MasterAttitudeError => "master_attitude_error_rad".into(),
            Param::MasterVelocityError => "master_velocity_error_mps".into(),
            Param::MasterErrorCorrelation => "master_error_correlation_s".into(),
            Param::FlexureOmega(k) => format!("flexure_omega_rad_s_{}", ax(k)),
            Param::FlexureDamping(k) => format!("flexure_damping_{}", ax(k)),
            Param::FlexureSigma(k) => format!("flexure_sigma_rad_{}", ax(k)),
        }
    }

    /// Whether the quantity may be exactly zero (a process noise that may be absent):
    /// its search starts from a ladder of sizes that includes zero.
    pub fn may_vanish(&self) -> bool {
        matches!(
            self,
            Param::GyroBiasRw
                | Param::AccelBiasRw
                | Param::MisalignmentRw
                | Param::LeverArmRateNoise
                | Param::MasterAttitudeError
                | Param::MasterVelocityError
        )
    }

    /// Bounds of the search (inclusive), in the quantity's unit.
    pub fn bounds(&self) -> (f64, f64) {
        match self {
            // Floors, per axis: a noiseless or smooth master must not drive the matching
            // noise to zero. Velocity, per axis from the recording
            // ([`ModelParams::velocity_floor_mps`], [`velocity_noise_floor`]): vertically
            // the board's f32 resolution of the velocities it compares (never below 1e-8
            // m/s), horizontally 1 mm/s. Until session 11 the vertical floor was 1 mm/s
            // too, above what a noiseless master's velocity innovations hold (a 50 Hz
            // master and a 7e-6 m/s/√s accelerometer: 1e-6 m/s between messages): it held
            // their vertical NIS at 0.02–0.3 and hid the velocity random walk (blind seed
            // 14: 7× too large).
            // Attitude 2 µrad ≈ 0.4″: at the f32 resolution instead (1e-7 rad) the
            // noiseless masters' attitude NIS come to 1, but on the measured vehicle
            // recording the heading noise falls to that floor and the search then takes
            // a 0.14° smooth master error with τ at its 2000 s bound, and the
            // accelerometer y bias 17 mg away from the configuration run's
            // (docs/model-learning.md, session 11). Rate 1e-7 rad/s (0.02 °/h).
            Param::VelocityNoise(_) => (1e-8, 10.0),
            Param::AttitudeNoise(_) => (2e-6, 0.1),
            Param::RateNoise(_) => (1e-7, 0.1),
            Param::LeverArmRateNoise => (0.0, 0.1),
            Param::GyroArw => (1e-8, 1e-1),
            Param::AccelVrw => (1e-6, 1.0),
            Param::GyroBiasRw => (0.0, 1e-3),
            Param::AccelBiasRw => (0.0, 1e-1),
            Param::MisalignmentRw => (0.0, 1e-2),
            // Initial σ: from 0.01 °/h to 10 °/s, 1 µg to 1 g, 1″ to 45°; the learner
            // never takes them below where it started (`ModelParams::prior_floor`).
            Param::InitialGyroBias => (5e-8, 0.2),
            Param::InitialAccelBias => (1e-5, 10.0),
            Param::InitialMisalignment => (5e-6, 0.8),
            Param::MasterAttitudeError => (0.0, 1e-2),
            Param::MasterVelocityError => (0.0, 1.0),
            Param::MasterErrorCorrelation => (5.0, 2000.0),
            Param::FlexureOmega(_) => (0.05, 30.0),
            Param::FlexureDamping(_) => (0.02, 0.95),
            Param::FlexureSigma(_) => (1e-6, 0.05),
        }
    }
}

/// The model being learned: the configuration's quantities in the learner's own form.
#[derive(Clone, Debug, PartialEq)]
pub struct ModelParams {
    /// The configuration everything else comes from (matching, lever arm, priors...).
    pub base: CalibConfig,
    /// Continuous flexure per slave axis.
    pub flexure: [FlexureAxis; 3],
    /// The initial σ (gyro bias, accelerometer bias, misalignment) the search started
    /// from: a floor. One recording holds one draw of each constant, whose likelihood
    /// would shrink its prior to its own size (and the filter would then be
    /// overconfident on the next); a prior may widen to fit a sensor of a worse grade,
    /// never narrow.
    pub prior_floor: [f64; 3],
    /// The floor of the master's white velocity noise per ENU axis (m/s): the f32
    /// resolution of the velocities the board compares on that axis
    /// ([`velocity_resolution_floor`]); the bound of [`Param::VelocityNoise`] until a
    /// recording sets it.
    pub velocity_floor_mps: [f64; 3],
}

impl ModelParams {
    /// The learner's form of a configuration (its flexure converted per axis; an AR with
    /// no continuous equivalent starts from [`DEFAULT_FLEXURE`]).
    pub fn from_config(cfg: &CalibConfig) -> Self {
        let uniform = [cfg.flexure_ar[0], cfg.flexure_ar[1], cfg.flexure_sigma_rad];
        let axes = cfg.flexure_axes.unwrap_or([uniform; 3]);
        let t = cfg.filter_period_s;
        let flexure = match cfg.flexure_gauss_markov {
            Some(gm) => gm.map(|[omega_rad_s, damping, sigma_rad]| FlexureAxis {
                omega_rad_s,
                damping,
                sigma_rad,
            }),
            None => axes.map(|a| FlexureAxis::from_ar(a, t).unwrap_or(DEFAULT_FLEXURE)),
        };
        Self {
            flexure,
            prior_floor: [
                cfg.initial_gyro_bias_radps,
                cfg.initial_accel_bias_mps2,
                cfg.initial_misalignment_rad,
            ],
            velocity_floor_mps: [Param::VelocityNoise(0).bounds().0; 3],
            base: cfg.clone(),
        }
    }

    /// The configuration these values make: the flexure per axis as the second-order
    /// Gauss-Markov process it is, sampled exactly (`flexcal_core::flexure`; the AR(2)
    /// with its poles overstates θ's one-step variance 1.6× and carries the mean rate
    /// over the interval where the rate matching sees the rate at its end),
    /// identification off (the model is learned).
    pub fn config(&self) -> CalibConfig {
        let mut c = self.base.clone();
        c.flexure_axes = None;
        c.flexure_gauss_markov = Some(
            self.flexure
                .map(|f| [f.omega_rad_s, f.damping, f.sigma_rad]),
        );
        c.identify_flexure = false;
        c.tune = false;
        c
    }

    /// The value of a quantity.
    pub fn get(&self, p: Param) -> f64 {
        let c = &self.base;
        let fx = |k: usize| self.flexure.get(k).copied().unwrap_or(DEFAULT_FLEXURE);
        match p {
            Param::VelocityNoise(k) => axis(&c.velocity_noise_mps, k),
            Param::AttitudeNoise(k) => axis(&c.attitude_noise_rad, k),
            Param::RateNoise(k) => axis(&c.rate_noise_radps, k),
            Param::LeverArmRateNoise => c.lever_arm_rate_noise(),
            Param::GyroArw => c.gyro_arw_rad_rs,
            Param::AccelVrw => c.accel_vrw_mps_rs,
            Param::GyroBiasRw => c.gyro_bias_rw,
            Param::AccelBiasRw => c.accel_bias_rw,
            Param::MisalignmentRw => c.misalignment_rw_rad_rs,
            Param::InitialGyroBias => c.initial_gyro_bias_radps,
            Param::InitialAccelBias => c.initial_accel_bias_mps2,
            Param::InitialMisalignment => c.initial_misalignment_rad,
            Param::MasterAttitudeError => {
                self.carried(Effect::MasterAttitudeError, c.master_attitude_error_rad)
            }
            Param::MasterVelocityError => {
                self.carried(Effect::MasterVelocityError, c.master_velocity_error_mps)
            }
            Param::MasterErrorCorrelation => c.master_error_correlation_s,
            Param::FlexureOmega(k) => fx(k).omega_rad_s,
            Param::FlexureDamping(k) => fx(k).damping,
            Param::FlexureSigma(k) => fx(k).sigma_rad,
        }
    }

    /// `value` when the configuration carries `effect`'s block, else zero.
    fn carried(&self, effect: Effect, value: f64) -> f64 {
        if self.base.effects.iter().any(|e| e == effect.name()) {
            value
        } else {
            0.0
        }
    }

    /// Adds `effect` to the configuration's effects, or removes it.
    fn carry(&mut self, effect: Effect, on: bool) {
        let effects = &mut self.base.effects;
        let present = effects.iter().any(|e| e == effect.name());
        if on && !present {
            effects.push(effect.name().to_string());
        } else if !on && present {
            effects.retain(|e| e != effect.name());
        }
    }

    /// Sets a quantity, clamped to its bounds.
    pub fn set(&mut self, p: Param, value: f64) {
        let (lo, hi) = p.bounds();
        let floor = match p {
            Param::InitialGyroBias => self.prior_floor[0],
            Param::InitialAccelBias => self.prior_floor[1],
            Param::InitialMisalignment => self.prior_floor[2],
            Param::VelocityNoise(k) => axis(&self.velocity_floor_mps, k),
            _ => lo,
        };
        let v = value.clamp(floor.clamp(lo, hi), hi);
        let c = &mut self.base;
        match p {
            Param::VelocityNoise(k) => set_axis(&mut c.velocity_noise_mps, k, v),
            Param::AttitudeNoise(k) => set_axis(&mut c.attitude_noise_rad, k, v),
            Param::RateNoise(k) => set_axis(&mut c.rate_noise_radps, k, v),
            Param::LeverArmRateNoise => c.lever_arm_rate_noise_radps = Some(v),
            Param::GyroArw => c.gyro_arw_rad_rs = v,
            Param::AccelVrw => c.accel_vrw_mps_rs = v,
            Param::GyroBiasRw => c.gyro_bias_rw = v,
            Param::AccelBiasRw => c.accel_bias_rw = v,
            Param::MisalignmentRw => c.misalignment_rw_rad_rs = v,
            Param::InitialGyroBias => c.initial_gyro_bias_radps = v,
            Param::InitialAccelBias => c.initial_accel_bias_mps2 = v,
            Param::InitialMisalignment => c.initial_misalignment_rad = v,
            Param::MasterAttitudeError => {
                c.master_attitude_error_rad = v;
                self.carry(Effect::MasterAttitudeError, v > 0.0);
            }
            Param::MasterVelocityError => {
                c.master_velocity_error_mps = v;
                self.carry(Effect::MasterVelocityError, v > 0.0);
            }
            Param::MasterErrorCorrelation => c.master_error_correlation_s = v,
            Param::FlexureOmega(k) => {
                if let Some(f) = self.flexure.get_mut(k) {
                    f.omega_rad_s = v;
                }
            }
            Param::FlexureDamping(k) => {
                if let Some(f) = self.flexure.get_mut(k) {
                    f.damping = v;
                }
            }
            Param::FlexureSigma(k) => {
                if let Some(f) = self.flexure.get_mut(k) {
                    f.sigma_rad = v;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flexure_round_trips_through_its_ar() {
        let f = FlexureAxis {
            omega_rad_s: 1.3,
            damping: 0.22,
            sigma_rad: 4e-4,
        };
        let back = FlexureAxis::from_ar(f.ar(0.01), 0.01).expect("under-damped");
        assert!((back.omega_rad_s / 1.3 - 1.0).abs() < 1e-9);
        assert!((back.damping / 0.22 - 1.0).abs() < 1e-9);
        assert!((back.sigma_rad / 4e-4 - 1.0).abs() < 1e-9);
    }

    #[test]
    fn the_velocity_floor_is_the_f32_resolution_of_each_axis() {
        // 8 m/s east: f32's unit in the last place there is 2^-20 m/s.
        let f = velocity_resolution_floor([[8.0, -0.5, 0.0], [-7.9, 0.25, 0.0]].into_iter());
        let ulp8 = 2f64.powi(-20);
        assert!(
            (f[0] - ulp8 * (2.0_f64 / 12.0).sqrt()).abs() < 1e-15,
            "{f:?}"
        );
        assert!(
            (f[1] - 2f64.powi(-24) * (2.0_f64 / 12.0).sqrt()).abs() < 1e-15,
            "{f:?}"
        );
        assert_eq!(f[2], Param::VelocityNoise(2).bounds().0);
        // The learner's floor keeps the horizontal axes at 1 mm/s.
        let g = velocity_noise_floor([[8.0, -0.5, 0.0]].into_iter());
        assert_eq!(
            g,
            [
                HORIZONTAL_VELOCITY_FLOOR_MPS,
                HORIZONTAL_VELOCITY_FLOOR_MPS,
                f[2]
            ]
        );
        // The search keeps each axis at or above its own floor.
        let mut m = ModelParams::from_config(&CalibConfig::default());
        m.velocity_floor_mps = f;
        m.set(Param::VelocityNoise(0), 0.0);
        m.set(Param::VelocityNoise(2), 0.0);
        assert_eq!(m.get(Param::VelocityNoise(0)), f[0]);
        assert_eq!(m.get(Param::VelocityNoise(2)), f[2]);
    }

    #[test]
    fn set_clamps_to_bounds() {
        let mut m = ModelParams::from_config(&CalibConfig::default());
        m.set(Param::AttitudeNoise(1), 0.0);
        assert_eq!(
            m.get(Param::AttitudeNoise(1)),
            Param::AttitudeNoise(1).bounds().0
        );
        assert_eq!(m.get(Param::AttitudeNoise(0)), m.base.attitude_noise_rad[0]);
        m.set(Param::FlexureDamping(2), 5.0);
        assert_eq!(m.get(Param::FlexureDamping(2)), 0.95);
        // A prior never narrows below where the search started.
        let start = m.get(Param::InitialGyroBias);
        m.set(Param::InitialGyroBias, start / 10.0);
        assert_eq!(m.get(Param::InitialGyroBias), start);
        m.set(Param::InitialGyroBias, start * 10.0);
        assert_eq!(m.get(Param::InitialGyroBias), start * 10.0);
    }
}
