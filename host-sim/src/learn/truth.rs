//! Scoring a learned model against the scenario a blind simulation drew: which learned
//! quantities have a true value in the draw, and how far the learner landed from it.
//!
//! A quantity has a truth only where the draw has a white-noise equivalent: the slave's
//! angle and velocity random walks always; the master's velocity, attitude and rate
//! noise only when the draw made them white and non-zero (a noiseless master has none,
//! and the learner stops at its floor); a smooth master's stationary σ of attitude and
//! velocity error and their correlation time when the draw made it smooth; the
//! flexure's natural frequency, damping and size per axis for a Gauss-Markov flexure.

use super::params::{ModelParams, Param};
use super::search::LearnedValue;
use crate::sim::{FlexureSpec, Scenario, DEG_PER_H};

/// A scored quantity: one the learner searches, or one derived from several of them.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
#[serde(untagged)]
pub enum Quantity {
    /// A quantity of the learned model.
    Learned(Param),
    /// The driving-noise density `√(2σ²/τ)` of a smooth master error (rad/√s or
    /// m/s/√s): over a record not many times longer than τ the likelihood resolves this
    /// combination (the error's diffusion) and hardly σ and τ apart, which walk along
    /// its level set (`docs/model-learning.md`, session 11).
    SmoothDensity(SmoothDensity),
}

/// The channel of a smooth master error's driving-noise density.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SmoothDensity {
    /// Attitude (rad/√s).
    MasterAttitudeErrorDensity,
    /// Velocity (m/s/√s).
    MasterVelocityErrorDensity,
}

/// One learned quantity against the value drawn.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct ParamError {
    /// The quantity.
    pub param: Quantity,
    /// Its value in the draw (the learner's unit).
    pub truth: f64,
    /// The learned value.
    pub learned: f64,
    /// `learned / truth − 1`.
    pub relative_error: f64,
    /// The learner's own σ of the value relative to the value (likelihood curvature or
    /// innovation count), when it has one: large means the data hardly tell.
    pub relative_sigma: Option<f64>,
}

/// The quantities the draw gives a true value for, in the learner's units.
pub fn drawn_values(sc: &Scenario) -> Vec<(Param, f64)> {
    let mut v = vec![
        (
            Param::GyroArw,
            sc.slave_imu.gyro_arw_deg_rh.to_radians() / 60.0,
        ),
        (Param::AccelVrw, sc.slave_imu.accel_vrw_mps_rh / 60.0),
    ];
    let m = &sc.master;
    if let Some(e) = &m.smooth_error {
        v.push((
            Param::MasterAttitudeError,
            (e.attitude_arcsec / 3600.0).to_radians(),
        ));
        v.push((Param::MasterVelocityError, e.velocity_mps));
        v.push((Param::MasterErrorCorrelation, e.correlation_s));
    } else {
        // The draw is one σ for the three axes of a channel; each axis is learned.
        for k in 0..3 {
            for (p, value) in [
                (Param::VelocityNoise(k), m.velocity_noise_mps),
                (Param::AttitudeNoise(k), m.attitude_noise_deg.to_radians()),
                (Param::RateNoise(k), m.rate_noise_deg_h * DEG_PER_H),
            ] {
                if value > 0.0 && (p != Param::RateNoise(k) || m.gives_rate) {
                    v.push((p, value));
                }
            }
        }
        let rate = m.rate_noise_deg_h * DEG_PER_H;
        if rate > 0.0 && m.gives_rate {
            v.push((Param::LeverArmRateNoise, rate));
        }
    }
    let axes = match sc.flexure {
        FlexureSpec::GaussMarkov {
            sigma_arcmin,
            omega_rad_s,
            damping,
        } => Some(([sigma_arcmin; 3], [omega_rad_s; 3], [damping; 3])),
        FlexureSpec::GaussMarkovAxes {
            sigma_arcmin,
            omega_rad_s,
            damping,
        } => Some((sigma_arcmin, omega_rad_s, damping)),
        FlexureSpec::None | FlexureSpec::Ar { .. } => None,
    };
    if let Some((sigma, omega, zeta)) = axes {
        for k in 0..3 {
            v.push((Param::FlexureOmega(k), omega[k]));
            v.push((Param::FlexureDamping(k), zeta[k]));
            v.push((Param::FlexureSigma(k), (sigma[k] / 60.0).to_radians()));
        }
    }
    v
}

/// The learned model against the draw, quantity by quantity, with the learner's own σ
/// from `values` where it has one.
pub fn param_errors(
    learned: &ModelParams,
    values: &[LearnedValue],
    sc: &Scenario,
) -> Vec<ParamError> {
    let mut errors: Vec<ParamError> = drawn_values(sc)
        .into_iter()
        .map(|(param, truth)| {
            let l = learned.get(param);
            let relative_sigma = values
                .iter()
                .find(|v| v.param == param)
                .and_then(|v| v.sigma)
                .filter(|_| l > 0.0)
                .map(|s| s / l);
            ParamError {
                param: Quantity::Learned(param),
                truth,
                learned: l,
                relative_error: l / truth - 1.0,
                relative_sigma,
            }
        })
        .collect();
    if let Some(e) = &sc.master.smooth_error {
        let density = |sigma: f64, tau: f64| (2.0 * sigma * sigma / tau).sqrt();
        let tau = learned.get(Param::MasterErrorCorrelation);
        for (which, param, truth_sigma) in [
            (
                SmoothDensity::MasterAttitudeErrorDensity,
                Param::MasterAttitudeError,
                (e.attitude_arcsec / 3600.0).to_radians(),
            ),
            (
                SmoothDensity::MasterVelocityErrorDensity,
                Param::MasterVelocityError,
                e.velocity_mps,
            ),
        ] {
            let truth = density(truth_sigma, e.correlation_s);
            let l = density(learned.get(param), tau);
            errors.push(ParamError {
                param: Quantity::SmoothDensity(which),
                truth,
                learned: l,
                relative_error: l / truth - 1.0,
                relative_sigma: None,
            });
        }
    }
    errors
}

/// The kind of a quantity in the acceptance table (per-axis quantities pooled).
pub fn kind(q: Quantity) -> &'static str {
    let p = match q {
        Quantity::Learned(p) => p,
        Quantity::SmoothDensity(SmoothDensity::MasterAttitudeErrorDensity) => {
            return "master attitude error density (smooth)"
        }
        Quantity::SmoothDensity(SmoothDensity::MasterVelocityErrorDensity) => {
            return "master velocity error density (smooth)"
        }
    };
    match p {
        Param::GyroArw => "gyro angle random walk",
        Param::AccelVrw => "accel velocity random walk",
        Param::VelocityNoise(_) => "master velocity noise (white)",
        Param::AttitudeNoise(_) => "master attitude noise (white)",
        Param::RateNoise(_) => "master rate noise (white)",
        Param::MasterAttitudeError => "master attitude error (smooth)",
        Param::MasterVelocityError => "master velocity error (smooth)",
        Param::MasterErrorCorrelation => "master error correlation time",
        Param::FlexureOmega(_) => "flexure natural frequency",
        Param::FlexureDamping(_) => "flexure damping",
        Param::FlexureSigma(_) => "flexure sigma",
        Param::GyroBiasRw
        | Param::AccelBiasRw
        | Param::MisalignmentRw
        | Param::InitialGyroBias
        | Param::InitialAccelBias
        | Param::InitialMisalignment => "other",
        Param::LeverArmRateNoise => "master rate noise in the lever-arm velocity",
    }
}

/// The learner's relative σ under which the data are said to tell a value.
pub const IDENTIFIABLE_RELATIVE_SIGMA: f64 = 0.2;

/// One kind's median |relative error| over many runs.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct KindMedian {
    /// The kind ([`kind`]).
    pub quantity: &'static str,
    /// Median over every value of the kind.
    pub median: f64,
    /// How many values.
    pub count: usize,
    /// Median over the values the learner resolved (its own relative σ at most
    /// [`IDENTIFIABLE_RELATIVE_SIGMA`]); NaN when none.
    pub median_resolved: f64,
    /// How many of those.
    pub count_resolved: usize,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    match n {
        0 => f64::NAN,
        _ if n % 2 == 1 => v[n / 2],
        _ => (v[n / 2 - 1] + v[n / 2]) / 2.0,
    }
}

/// Median of |relative error| per kind over many runs (all values, and those the learner
/// resolved), in the order of first appearance.
pub fn median_by_kind(errors: &[ParamError]) -> Vec<KindMedian> {
    let mut kinds: Vec<&'static str> = Vec::new();
    for e in errors {
        if !kinds.contains(&kind(e.param)) {
            kinds.push(kind(e.param));
        }
    }
    kinds
        .into_iter()
        .map(|k| {
            let of_kind = || errors.iter().filter(move |e| kind(e.param) == k);
            let all: Vec<f64> = of_kind().map(|e| e.relative_error.abs()).collect();
            let resolved: Vec<f64> = of_kind()
                .filter(|e| {
                    e.relative_sigma
                        .is_some_and(|r| r <= IDENTIFIABLE_RELATIVE_SIGMA)
                })
                .map(|e| e.relative_error.abs())
                .collect();
            KindMedian {
                quantity: k,
                count: all.len(),
                median: median(all),
                count_resolved: resolved.len(),
                median_resolved: median(resolved),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::config::CalibConfig;
    use crate::sim::blind;

    #[test]
    fn a_model_declared_from_the_draw_scores_zero_error() {
        for seed in 0..20 {
            let sc = blind::draw(seed, 60.0, None);
            let cfg = CalibConfig::declared_for(&sc, 1.0 / sc.master.rate_hz);
            let m = ModelParams::from_config(&cfg);
            for e in param_errors(&m, &[], &sc) {
                assert!(
                    e.relative_error.abs() < 1e-9,
                    "seed {seed}: {:?} {} vs {}",
                    e.param,
                    e.learned,
                    e.truth
                );
            }
        }
    }

    #[test]
    fn medians_pool_the_axes() {
        let e = |param, relative_error, relative_sigma| ParamError {
            param: Quantity::Learned(param),
            truth: 1.0,
            learned: 1.0 + relative_error,
            relative_error,
            relative_sigma,
        };
        let m = median_by_kind(&[
            e(Param::FlexureOmega(0), 0.1, Some(0.05)),
            e(Param::FlexureOmega(1), -0.3, None),
            e(Param::FlexureOmega(2), 0.2, Some(0.5)),
            e(Param::GyroArw, 0.05, Some(0.01)),
        ]);
        assert_eq!(m[0].quantity, "flexure natural frequency");
        assert_eq!((m[0].median, m[0].count), (0.2, 3));
        assert_eq!((m[0].median_resolved, m[0].count_resolved), (0.1, 1));
        assert_eq!((m[1].median, m[1].count), (0.05, 1));
    }
}
