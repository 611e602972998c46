//! The calibrator's configuration: the model the filter declares (noise, flexure,
//! lever-arm bending, matching channels, initial uncertainty), as a TOML file.
//! Units are in the key names; every key has a default (the `moored` scenario's
//! declared model), so a file only says what differs.

use crate::learn::params::Param;
use crate::sim::{self, FlexureSpec, Scenario};
use flexcal_core::augment::{AugmentError, Augmentation, Effect, MAX_EFFECTS};
use flexcal_core::engine::{EngineConfig, InitialSigma, Matching, MeasurementNoise};

use flexcal_core::flexure::{ArAxis, AxisModel, FlexureModel, SecondOrderAxis};
use flexcal_core::model::{LeverBending, ProcessNoise};
use flexcal_core::real::Real;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// The effect of a `diagnosis.json` name, or an error listing the vocabulary.
pub fn parse_effect(name: &str) -> Result<Effect, String> {
    Effect::from_name(name).ok_or_else(|| {
        let known: Vec<&str> = Effect::ALL.iter().map(|e| e.name()).collect();
        format!("unknown effect `{name}` ({})", known.join(", "))
    })
}

/// A per-axis σ in a configuration file: one number (every axis) or an array of three.
fn per_axis<'de, D: serde::Deserializer<'de>>(d: D) -> Result<[f64; 3], D::Error> {
    struct PerAxis;
    impl<'de> serde::de::Visitor<'de> for PerAxis {
        type Value = [f64; 3];
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("a number (every axis) or an array of three numbers [x, y, z]")
        }
        fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<[f64; 3], E> {
            Ok([v; 3])
        }
        fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<[f64; 3], E> {
            Ok([v as f64; 3])
        }
        fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<[f64; 3], E> {
            Ok([v as f64; 3])
        }
        fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<[f64; 3], A::Error> {
            let mut out = [0.0; 3];
            for (k, slot) in out.iter_mut().enumerate() {
                *slot = seq
                    .next_element()?
                    .ok_or_else(|| serde::de::Error::invalid_length(k, &self))?;
            }
            if seq.next_element::<f64>()?.is_some() {
                return Err(serde::de::Error::invalid_length(4, &self));
            }
            Ok(out)
        }
    }
    d.deserialize_any(PerAxis)
}

/// Calibration configuration (TOML).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct CalibConfig {
    /// Filter period (s); the flexure AR coefficients belong to this period.
    pub filter_period_s: f64,
    /// Matching channels: any of "velocity", "attitude", "angular_rate".
    pub matching: Vec<String>,
    /// Model the flexure-bent lever arm (false: the paper's baseline).
    pub dynamic_lever_arm: bool,
    /// Lever-arm bending model: "paper" or "uniform_arc".
    pub bending: sim::Bending,
    /// Flexure AR(2) coefficients `[a1, a2]` at the filter period (same on each axis).
    pub flexure_ar: [f64; 2],
    /// σ of the flexure AR driving noise (rad).
    pub flexure_sigma_rad: f64,
    /// Identify the flexure model from the recording before calibrating (true), or
    /// use `flexure_ar` / `flexure_axes` as given (false).
    pub identify_flexure: bool,
    /// Per-axis flexure models `[a1, a2, σ_rad]` (slave x, y, z); when present they
    /// replace `flexure_ar` and `flexure_sigma_rad`. Identification fills them in.
    pub flexure_axes: Option<[[f64; 3]; 3]>,
    /// Per-axis second-order Gauss-Markov flexure `[ω rad/s, ζ, σ_θ rad]` (slave x, y,
    /// z), sampled exactly at the filter period (`flexcal_core::flexure`); when present
    /// it replaces the AR models. The model learner writes it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub flexure_gauss_markov: Option<[[f64; 3]; 3]>,
    /// Gyro angle random walk (rad/√s).
    pub gyro_arw_rad_rs: f64,
    /// Accelerometer velocity random walk (m/s/√s).
    pub accel_vrw_mps_rs: f64,
    /// Gyro bias random walk (rad/s/√s).
    pub gyro_bias_rw: f64,
    /// Accelerometer bias random walk (m/s²/√s).
    pub accel_bias_rw: f64,
    /// Mounting misalignment random walk (rad/√s): lets the misalignment follow a slow
    /// drift (thermal bending, a master whose attitude error wanders). Zero: constant.
    pub misalignment_rw_rad_rs: f64,
    /// Velocity matching noise (m/s, ENU `[e, n, u]`; one number: every axis).
    #[serde(deserialize_with = "per_axis")]
    pub velocity_noise_mps: [f64; 3],
    /// Attitude matching noise (rad, slave body `[x, y, z]`; one number: every axis).
    #[serde(deserialize_with = "per_axis")]
    pub attitude_noise_rad: [f64; 3],
    /// The master's angular-rate noise (rad/s, slave body `[x, y, z]`; one number: every
    /// axis); the slave gyro's part of the rate-matching noise is derived from
    /// `gyro_arw_rad_rs`.
    #[serde(deserialize_with = "per_axis")]
    pub rate_noise_radps: [f64; 3],
    /// σ of the master's rate noise as the lever arm carries it into the velocity
    /// matching (rad/s, ≥ 0). Absent: the RMS of `rate_noise_radps`. Apart because what
    /// the rate matching's noise holds beyond the master's own does not move the
    /// master's lever-arm velocity (`flexcal_core::engine::MeasurementNoise`); the model
    /// learner sets it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lever_arm_rate_noise_radps: Option<f64>,
    /// Initial σ of the velocity error (m/s).
    pub initial_velocity_mps: f64,
    /// Initial σ of the misalignment (rad).
    pub initial_misalignment_rad: f64,
    /// Initial σ of the gyro bias (rad/s).
    pub initial_gyro_bias_radps: f64,
    /// Initial σ of the accelerometer bias (m/s²).
    pub initial_accel_bias_mps2: f64,
    /// Initial σ of the flexure angle when its model is not stationary (rad).
    pub initial_flexure_rad: f64,
    /// Innovation gate (σ).
    pub gate_sigma: f64,
    /// Effects the filter carries beyond the declared 21 states, by their names in
    /// `diagnosis.json` (e.g. `["time_delay"]`): what `flexcal diagnose` recommends.
    pub effects: Vec<String>,
    /// Stationary σ of the master's smooth attitude error (rad, per ENU axis) when
    /// `effects` has `master_attitude_error` (a Gauss-Markov process of correlation
    /// time `flexcal_core::augment::MASTER_ERROR_CORRELATION_S`).
    pub master_attitude_error_rad: f64,
    /// Stationary σ of the master's smooth velocity error (m/s, per ENU axis) when
    /// `effects` has `master_velocity_error`.
    pub master_velocity_error_mps: f64,
    /// Correlation time of the master's smooth errors (s), both blocks.
    pub master_error_correlation_s: f64,
    /// Starting value of the master delay (s) when `effects` has `time_delay`: a
    /// previous estimate, so the delay's linearization holds from the start.
    pub initial_delay_s: f64,
    /// The mounting the filter starts from, `μ̂₀` (rotation vector of `C_bs^bm`, rad):
    /// its misalignment states are errors about it. Absent: found before the filter
    /// (`calib::mounting`, `calib::prefilter`) for a learned model and a declared
    /// configuration alike; zero when the motion does not show it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mounting_estimate_rad: Option<[f64; 3]>,
    /// How late the master's time tags are on the slave's (s; negative: early): every
    /// master message stamped `t` is handed to the filter stamped `t − offset`. Absent:
    /// found from the body rates before the filter (`calib::prefilter`) and applied
    /// when the engine could not follow it as a delay.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub master_clock_offset_s: Option<f64>,
    /// Steps of the master's attitude taken out before the filter, each
    /// `[t_s, x, y, z]`: the master's time tag of the first message after it (s, its own
    /// tags) and the jump as a rotation vector, ENU (rad) (`calib::master_steps`).
    /// Absent: searched before the filter (from the master's own rate) and taken out;
    /// `[]`: none taken out, none searched.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub master_attitude_steps: Option<Vec<[f64; 4]>>,
    /// Treat this configuration as the starting point of a model learned from the
    /// recording (`flexcal calibrate`, `diagnose`, `montecarlo` learn first), instead of
    /// the fixed truth about the data (false, the default for a file).
    pub tune: bool,
}

impl Default for CalibConfig {
    fn default() -> Self {
        let moored = Scenario::load("moored").ok();
        match moored {
            Some(sc) => Self::declared_for(&sc, 0.01),
            None => Self::declared_fallback(),
        }
    }
}

impl CalibConfig {
    fn declared_fallback() -> Self {
        Self {
            filter_period_s: 0.01,
            matching: vec!["velocity".into(), "attitude".into(), "angular_rate".into()],
            dynamic_lever_arm: true,
            bending: sim::Bending::UniformArc,
            flexure_ar: [0.0, 0.0],
            flexure_sigma_rad: 1e-4,
            identify_flexure: true,
            flexure_axes: None,
            flexure_gauss_markov: None,
            gyro_arw_rad_rs: 1e-5,
            accel_vrw_mps_rs: 1e-4,
            gyro_bias_rw: 0.0,
            accel_bias_rw: 0.0,
            misalignment_rw_rad_rs: 0.0,
            velocity_noise_mps: [0.01; 3],
            attitude_noise_rad: [1e-4; 3],
            rate_noise_radps: [1e-4; 3],
            lever_arm_rate_noise_radps: None,
            initial_velocity_mps: 0.1,
            initial_misalignment_rad: 1f64.to_radians(),
            initial_gyro_bias_radps: 1.0 * sim::DEG_PER_H,
            initial_accel_bias_mps2: 1.0 * sim::MG,
            initial_flexure_rad: 1e-3,
            gate_sigma: 5.0,
            effects: Vec::new(),
            master_attitude_error_rad: Effect::MasterAttitudeError.default_prior_sigma(),
            master_velocity_error_mps: Effect::MasterVelocityError.default_prior_sigma(),
            master_error_correlation_s: flexcal_core::augment::MASTER_ERROR_CORRELATION_S,
            initial_delay_s: 0.0,
            mounting_estimate_rad: None,
            master_clock_offset_s: None,
            master_attitude_steps: None,
            tune: false,
        }
    }

    /// The model a scenario declares, at filter period `t` (s): its noise levels, its
    /// bending model and its flexure (an AR truth as its AR(2) at `t`; a Gauss-Markov
    /// truth as its exact second-order mode, `flexure_gauss_markov`, beside the AR(2)
    /// with the same poles and variance). Sensor errors the model has no
    /// states for (scale factors, non-orthogonality) are *not* declared. A master
    /// noise below the model learner's floor (a noiseless or smooth master) is
    /// declared at that floor (`learn::params::Param::bounds`): the filter cannot run
    /// with zero measurement noise, and the floor stands for what the slave's own
    /// unmodelled errors add to every match.
    pub fn declared_for(sc: &Scenario, t: f64) -> Self {
        let arw = sc.slave_imu.gyro_arw_deg_rh.to_radians() / 60.0;
        let gauss_markov = |sigma_arcmin: f64, omega_rad_s: f64, damping: f64| {
            let ar = ArAxis::from_gauss_markov(
                omega_rad_s,
                damping,
                (sigma_arcmin / 60.0).to_radians(),
                t,
            );
            [ar.a1, ar.a2, ar.sigma_rad]
        };
        let flexure_axes = match sc.flexure {
            FlexureSpec::GaussMarkovAxes {
                sigma_arcmin,
                omega_rad_s,
                damping,
            } => Some([0, 1, 2].map(|k| gauss_markov(sigma_arcmin[k], omega_rad_s[k], damping[k]))),
            _ => None,
        };
        let (flexure_ar, flexure_sigma_rad) = match sc.flexure {
            FlexureSpec::None => ([0.0, 0.0], 1e-9),
            FlexureSpec::Ar {
                coefficients,
                sigma_deg,
                ..
            } => (coefficients, sigma_deg.to_radians()),
            FlexureSpec::GaussMarkov {
                sigma_arcmin,
                omega_rad_s,
                damping,
            } => {
                let [a1, a2, s] = gauss_markov(sigma_arcmin, omega_rad_s, damping);
                ([a1, a2], s)
            }
            // Per axis in `flexure_axes`; the uniform fields keep the x axis.
            FlexureSpec::GaussMarkovAxes { .. } => {
                let [a1, a2, s] = flexure_axes.map(|a| a[0]).unwrap_or([0.0, 0.0, 1e-9]);
                ([a1, a2], s)
            }
        };
        // A Gauss-Markov truth is declared as itself, sampled exactly: the AR(2) with its
        // poles and variance carries the mean rate over the period where the rate
        // matching sees the rate at its end (`flexcal_core::flexure`), which on blind seed
        // 116 (50 Hz master, ω 1.6–2.3 rad/s) took the truth model to NEES 94 and a 46′
        // misalignment error, against 7.1 with the exact mode.
        let arcmin = |a: f64| (a / 60.0).to_radians();
        let flexure_gauss_markov = match sc.flexure {
            FlexureSpec::GaussMarkov {
                sigma_arcmin,
                omega_rad_s,
                damping,
            } => Some([[omega_rad_s, damping, arcmin(sigma_arcmin)]; 3]),
            FlexureSpec::GaussMarkovAxes {
                sigma_arcmin,
                omega_rad_s,
                damping,
            } => Some([0, 1, 2].map(|k| [omega_rad_s[k], damping[k], arcmin(sigma_arcmin[k])])),
            _ => None,
        };
        let mut matching = vec!["velocity".to_string(), "attitude".to_string()];
        if sc.master.gives_rate {
            matching.push("angular_rate".into());
        }
        // The master's rate noise; the engine adds the gyro's part from the ARW.
        let rate_noise = sc.master.rate_noise_deg_h * sim::DEG_PER_H;
        // A smooth master error is declared as the Gauss-Markov blocks that model it.
        let fallback = Self::declared_fallback();
        let (mut effects, mut smooth_att, mut smooth_vel, mut smooth_tau) = (
            Vec::new(),
            fallback.master_attitude_error_rad,
            fallback.master_velocity_error_mps,
            fallback.master_error_correlation_s,
        );
        if let Some(e) = &sc.master.smooth_error {
            smooth_tau = e.correlation_s;
            if e.attitude_arcsec > 0.0 {
                effects.push(Effect::MasterAttitudeError.name().to_string());
                smooth_att = (e.attitude_arcsec / 3600.0).to_radians();
            }
            if e.velocity_mps > 0.0 {
                effects.push(Effect::MasterVelocityError.name().to_string());
                smooth_vel = e.velocity_mps;
            }
        }
        Self {
            filter_period_s: t,
            matching,
            dynamic_lever_arm: true,
            bending: sc.lever_arm.bending,
            flexure_ar,
            flexure_sigma_rad,
            identify_flexure: false,
            flexure_axes,
            flexure_gauss_markov,
            gyro_arw_rad_rs: arw,
            accel_vrw_mps_rs: sc.slave_imu.accel_vrw_mps_rh / 60.0,
            gyro_bias_rw: 0.0,
            accel_bias_rw: 0.0,
            velocity_noise_mps: [at_floor(Param::VelocityNoise(0), sc.master.velocity_noise_mps);
                3],
            attitude_noise_rad: [at_floor(
                Param::AttitudeNoise(0),
                sc.master.attitude_noise_deg.to_radians(),
            ); 3],
            rate_noise_radps: [at_floor(Param::RateNoise(0), rate_noise); 3],
            effects,
            master_attitude_error_rad: smooth_att,
            master_velocity_error_mps: smooth_vel,
            master_error_correlation_s: smooth_tau,
            ..fallback
        }
    }

    /// Reads a configuration file.
    pub fn load(path: &std::path::Path) -> Result<Self, String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("config `{}`: {e}", path.display()))?;
        let c: Self =
            toml::from_str(&text).map_err(|e| format!("config `{}`: {e}", path.display()))?;
        c.validate()
            .map_err(|e| format!("config `{}`: {e}", path.display()))?;
        Ok(c)
    }

    /// Checks values the filter cannot run with.
    pub fn validate(&self) -> Result<(), String> {
        for m in &self.matching {
            if !["velocity", "attitude", "angular_rate"].contains(&m.as_str()) {
                return Err(format!(
                    "`matching`: unknown channel `{m}` (velocity, attitude, angular_rate)"
                ));
            }
        }
        for (k, axes) in [
            ("velocity_noise_mps", self.velocity_noise_mps),
            ("attitude_noise_rad", self.attitude_noise_rad),
            ("rate_noise_radps", self.rate_noise_radps),
        ] {
            if let Some((axis, v)) = axes
                .iter()
                .enumerate()
                .find(|(_, v)| !(v.is_finite() && **v > 0.0))
            {
                return Err(format!(
                    "`{k}` must be positive numbers, got {v} on axis {axis}"
                ));
            }
        }
        let positive = [
            ("filter_period_s", self.filter_period_s),
            ("gate_sigma", self.gate_sigma),
            ("initial_velocity_mps", self.initial_velocity_mps),
            ("initial_misalignment_rad", self.initial_misalignment_rad),
            ("initial_gyro_bias_radps", self.initial_gyro_bias_radps),
            ("initial_accel_bias_mps2", self.initial_accel_bias_mps2),
        ];
        for (k, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("`{k}` must be a positive number, got {v}"));
            }
        }
        if let Some(v) = self.lever_arm_rate_noise_radps {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!(
                    "`lever_arm_rate_noise_radps` must be a number ≥ 0 rad/s, got {v}"
                ));
            }
        }
        if let Some(axes) = self.flexure_gauss_markov {
            for (k, [w, z, sigma]) in axes.iter().enumerate() {
                if SecondOrderAxis::new(*w, *z, *sigma, self.filter_period_s).is_none() {
                    return Err(format!(
                        "`flexure_gauss_markov` axis {k}: [{w}, {z}, {sigma}] is no damped mode \
                         at the filter period (ω > 0 rad/s, ζ > 0, σ ≥ 0 rad)"
                    ));
                }
            }
        }
        if let Some(m) = self.mounting_estimate_rad {
            let norm = m.iter().map(|v| v * v).sum::<f64>().sqrt();
            // A half turn may come out of the logarithm a rounding above π.
            if !(norm.is_finite() && norm <= std::f64::consts::PI + 1e-9) {
                return Err(format!(
                    "`mounting_estimate_rad` must be a rotation vector of at most π rad, got {m:?}"
                ));
            }
        }
        if self.master_clock_offset_s.is_some_and(|v| !v.is_finite()) {
            return Err(format!(
                "`master_clock_offset_s` must be a number of seconds, got {:?}",
                self.master_clock_offset_s
            ));
        }
        if let Some(steps) = &self.master_attitude_steps {
            let mut before = f64::NEG_INFINITY;
            for (k, s) in steps.iter().enumerate() {
                if !(s.iter().all(|v| v.is_finite()) && s[0] > before) {
                    return Err(format!(
                        "`master_attitude_steps[{k}]` must be finite [t_s, x, y, z] after the step before, got {s:?}"
                    ));
                }
                before = s[0];
            }
        }
        let max = flexcal_core::engine::MAX_DELAY_S;
        if !(self.initial_delay_s.is_finite() && self.initial_delay_s.abs() <= max) {
            return Err(format!(
                "`initial_delay_s` must be within ±{max} s, got {}",
                self.initial_delay_s
            ));
        }
        self.augmentation::<f64>().map(|_| ())
    }

    /// The layout of `effects`, each with its default prior σ (the master's smooth
    /// errors with their configured stationary σ).
    pub fn augmentation<T: Real>(&self) -> Result<Augmentation<T>, String> {
        let mut aug = Augmentation::none()
            .with_master_error_correlation(T::of(self.master_error_correlation_s))
            .map_err(|_| {
                format!(
                    "`master_error_correlation_s` must be a positive number of seconds, got {}",
                    self.master_error_correlation_s
                )
            })?;
        for name in &self.effects {
            let effect = parse_effect(name).map_err(|e| format!("`effects`: {e}"))?;
            let prior = match effect {
                Effect::MasterAttitudeError => self.master_attitude_error_rad,
                Effect::MasterVelocityError => self.master_velocity_error_mps,
                _ => effect.default_prior_sigma(),
            };
            aug = aug.with(effect, T::of(prior)).map_err(|e| match e {
                AugmentError::Duplicate => format!(
                    "`effects`: `{name}` is listed twice (or with the other clock block: `time_delay` and `clock_drift` model the same clock)"
                ),
                AugmentError::Full => format!(
                    "`effects`: at most {MAX_EFFECTS} effects at a time, got {}",
                    self.effects.len()
                ),
                AugmentError::BadPrior => format!("`effects`: bad prior σ for `{name}`"),
            })?;
        }
        Ok(aug)
    }

    /// The clock effect its `effects` carry (`time_delay` before `clock_drift`, which
    /// replaces it in a layout), if any: the effect whose delay the model starts from
    /// `initial_delay_s`.
    pub fn clock_effect(&self) -> Option<Effect> {
        [Effect::TimeDelay, Effect::ClockDrift]
            .into_iter()
            .find(|c| self.effects.iter().any(|e| e == c.name()))
    }

    /// The AR order of each axis's flexure model (trailing zero coefficients dropped; a
    /// second-order Gauss-Markov axis has two states, order 2).
    pub fn flexure_orders(&self) -> [usize; 3] {
        if self.flexure_gauss_markov.is_some() {
            return [2; 3];
        }
        let uniform = [
            self.flexure_ar[0],
            self.flexure_ar[1],
            self.flexure_sigma_rad,
        ];
        self.flexure_axes
            .unwrap_or([uniform; 3])
            .map(|[a1, a2, _]| {
                if a2 != 0.0 {
                    2
                } else if a1 != 0.0 {
                    1
                } else {
                    0
                }
            })
    }

    /// σ of the master's rate noise the lever arm carries into the velocity matching
    /// (rad/s): `lever_arm_rate_noise_radps`, else the RMS of the rate noise over the
    /// axes (exactly the rate noise when the axes are alike).
    pub fn lever_arm_rate_noise(&self) -> f64 {
        self.lever_arm_rate_noise_radps.unwrap_or_else(|| {
            flexcal_core::engine::axes_rms(&Vector3::from(self.rate_noise_radps))
        })
    }

    /// The matching channels as flags.
    pub fn matching_flags(&self) -> Matching {
        let has = |n: &str| self.matching.iter().any(|m| m == n);
        Matching {
            velocity: has("velocity"),
            attitude: has("attitude"),
            angular_rate: has("angular_rate"),
        }
    }

    /// The engine configuration in precision `T`, for a recording with lever arm `r0_m`.
    /// An invalid `effects` list (which `validate` reports) carries no effect.
    pub fn engine_config<T: Real>(&self, r0_m: [f64; 3]) -> EngineConfig<T> {
        let c = T::of;
        let uniform = [
            self.flexure_ar[0],
            self.flexure_ar[1],
            self.flexure_sigma_rad,
        ];
        let per_axis = self.flexure_axes.unwrap_or([uniform; 3]);
        let ar = per_axis.map(|[a1, a2, sigma]| {
            AxisModel::Ar(ArAxis {
                a1: c(a1),
                a2: c(a2),
                sigma_rad: c(sigma),
            })
        });
        // A second-order axis `validate` refuses keeps the AR model.
        let axes = match self.flexure_gauss_markov {
            Some(gm) => [0, 1, 2].map(|k| {
                let [w, z, sigma] = gm[k];
                SecondOrderAxis::new(c(w), c(z), c(sigma), c(self.filter_period_s))
                    .map_or(ar[k], AxisModel::SecondOrder)
            }),
            None => ar,
        };
        EngineConfig {
            filter_period_s: self.filter_period_s,
            matching: self.matching_flags(),
            lever_arm_m: Vector3::new(c(r0_m[0]), c(r0_m[1]), c(r0_m[2])),
            bending: match self.bending {
                sim::Bending::Paper => LeverBending::Paper,
                sim::Bending::UniformArc => LeverBending::UniformArc,
            },
            dynamic_lever_arm: self.dynamic_lever_arm,
            flexure: FlexureModel {
                axes,
                period_s: c(self.filter_period_s),
            },
            process_noise: ProcessNoise {
                accel_vrw: c(self.accel_vrw_mps_rs),
                gyro_arw: c(self.gyro_arw_rad_rs),
                gyro_bias_rw: c(self.gyro_bias_rw),
                accel_bias_rw: c(self.accel_bias_rw),
                misalignment_rw: c(self.misalignment_rw_rad_rs),
            },
            measurement_noise: MeasurementNoise {
                velocity_mps: Vector3::from(self.velocity_noise_mps.map(c)),
                attitude_rad: Vector3::from(self.attitude_noise_rad.map(c)),
                rate_radps: Vector3::from(self.rate_noise_radps.map(c)),
                lever_arm_rate_radps: c(self.lever_arm_rate_noise()),
            },
            initial_sigma: InitialSigma {
                velocity_mps: c(self.initial_velocity_mps),
                misalignment_rad: c(self.initial_misalignment_rad),
                gyro_bias_radps: c(self.initial_gyro_bias_radps),
                accel_bias_mps2: c(self.initial_accel_bias_mps2),
                flexure_rad: c(self.initial_flexure_rad),
            },
            initial_misalignment_rad: Vector3::from(
                self.mounting_estimate_rad.unwrap_or([0.0; 3]).map(c),
            ),
            gate_sigma: c(self.gate_sigma),
            // The smallest scaled variance: 1e-9 keeps f32 positive definite; f64 can go
            // lower, which a sharply observed augmented state (a delay known to µs) needs.
            variance_floor: c(if std::mem::size_of::<T>() >= 8 {
                1e-12
            } else {
                1e-9
            }),
            augmentation: self.augmentation().unwrap_or_default(),
            initial_delay_s: self.initial_delay_s,
        }
    }
}

/// A declared measurement noise no smaller than the learner's floor for `p`.
fn at_floor(p: Param, declared: f64) -> f64 {
    declared.max(p.bounds().0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<CalibConfig, String> {
        let c: CalibConfig = toml::from_str(text).map_err(|e| e.to_string())?;
        c.validate()?;
        Ok(c)
    }

    #[test]
    fn channel_noise_is_one_number_or_three() {
        let one = parse("velocity_noise_mps = 0.02\nrate_noise_radps = 1").unwrap();
        assert_eq!(one.velocity_noise_mps, [0.02; 3]);
        assert_eq!(one.rate_noise_radps, [1.0; 3]);
        let three = parse("attitude_noise_rad = [1e-4, 2e-4, 3e-4]").unwrap();
        assert_eq!(three.attitude_noise_rad, [1e-4, 2e-4, 3e-4]);
        let e = three.engine_config::<f64>([0.0; 3]);
        assert_eq!(
            e.measurement_noise.attitude_rad,
            Vector3::new(1e-4, 2e-4, 3e-4)
        );
        // What the learner writes reads back the same.
        let back = parse(&toml::to_string(&three).unwrap()).unwrap();
        assert_eq!(back, three);
    }

    #[test]
    fn bad_channel_noise_names_the_key_and_the_axis() {
        let short = parse("velocity_noise_mps = [0.1, 0.2]").unwrap_err();
        assert!(
            short.contains("velocity_noise_mps") && short.contains("three"),
            "{short}"
        );
        let long = parse("velocity_noise_mps = [0.1, 0.2, 0.3, 0.4]").unwrap_err();
        assert!(long.contains("velocity_noise_mps"), "{long}");
        let text = parse("velocity_noise_mps = \"fast\"").unwrap_err();
        assert!(text.contains("a number (every axis)"), "{text}");
        let zero = parse("rate_noise_radps = [1e-4, 0, 1e-4]").unwrap_err();
        assert!(
            zero.contains("`rate_noise_radps`") && zero.contains("axis 1"),
            "{zero}"
        );
    }

    #[test]
    fn a_noiseless_master_is_declared_at_the_learner_floor_and_loads() {
        // Blind draws until one has a master with no white noise (none or smooth).
        let sc = (1..)
            .map(|seed| crate::sim::blind::draw(seed, 60.0, None))
            .find(|sc| sc.master.velocity_noise_mps == 0.0 && sc.master.attitude_noise_deg == 0.0)
            .unwrap();
        let declared = CalibConfig::declared_for(&sc, 1.0 / sc.master.rate_hz);
        let back = parse(&toml::to_string(&declared).unwrap()).unwrap();
        assert_eq!(
            back.velocity_noise_mps,
            [Param::VelocityNoise(0).bounds().0; 3]
        );
        assert_eq!(
            back.attitude_noise_rad,
            [Param::AttitudeNoise(0).bounds().0; 3]
        );
        assert!(back
            .rate_noise_radps
            .iter()
            .all(|r| *r >= Param::RateNoise(0).bounds().0));
    }
}
