//! The flexure model per axis from the filter's own flexure estimate θ̂.
//!
//! A second-order Gauss-Markov angle (`θ̈ + 2ζω θ̇ + ω² θ = w`) has, whatever its
//! damping, `var(θ̇) / var(θ) = ω²`, and the autocorrelation
//! `ρ(τ) = e^{−ζωτ} (cos ω_d τ + ζω/ω_d sin ω_d τ)`, `ω_d = ω√(1 − ζ²)`. So ω comes from
//! the ratio of the σ of a smoothed derivative of θ̂ to the σ of θ̂, and ζ from the
//! least-squares fit of ρ over the first two periods. The filtered θ̂ tracks the true
//! flexure closely when the attitude and rate matching resolve it (their noise well
//! below the flexure's σ), whatever flexure model the filter ran with.
//!
//! Why not the innovations' likelihood for these: the filter carries the flexure as an
//! AR(2) at its period, while a sampled continuous second-order process is an
//! ARMA(2,1); the likelihood's optimum of the AR(2) is shifted from the physical
//! natural frequency (by a third on the `docs/model-learning.md` example), while the
//! moments above are those of the physical process.

use super::params::{FlexureAxis, Param};
use crate::calib::run::EstimateRow;

/// Half-width of the central difference that smooths θ̂'s derivative (samples of θ̂).
const DERIVATIVE_HALF_WIDTH_S: f64 = 0.05;

/// The flexure model of each slave axis from θ̂ sampled every `period_s`; `None` for an
/// axis whose θ̂ is too short (fewer than 8 of its periods) or flat.
pub fn flexure_from_estimates(rows: &[EstimateRow], period_s: f64) -> [Option<FlexureAxis>; 3] {
    [0, 1, 2].map(|k| {
        let theta: Vec<f64> = rows.iter().map(|r| r.flexure[k]).collect();
        axis_model(&theta, period_s)
    })
}

fn mean_var(x: &[f64]) -> (f64, f64) {
    let n = x.len().max(1) as f64;
    let m = x.iter().sum::<f64>() / n;
    (m, x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / n)
}

fn axis_model(theta: &[f64], t: f64) -> Option<FlexureAxis> {
    // The first tenth is the filter's convergence.
    let theta = theta.get(theta.len() / 10..)?;
    let h = ((DERIVATIVE_HALF_WIDTH_S / t).round() as usize).max(1);
    let rate: Vec<f64> = theta
        .windows(2 * h + 1)
        .map(|w| (w[2 * h] - w[0]) / (2.0 * h as f64 * t))
        .collect();
    let (mean, var) = mean_var(theta);
    let (_, var_rate) = mean_var(&rate);
    if !(var > 0.0 && var_rate > 0.0) {
        return None;
    }
    let omega = (var_rate / var).sqrt();
    let (lo, hi) = Param::FlexureOmega(0).bounds();
    let omega = omega.clamp(lo, hi);
    // Two periods of lags, at least 8 periods of data.
    let period = 2.0 * std::f64::consts::PI / omega;
    let max_lag = ((2.0 * period / t).round() as usize).max(4);
    if theta.len() < 4 * max_lag {
        return None;
    }
    let centred: Vec<f64> = theta.iter().map(|v| v - mean).collect();
    let n = centred.len() as f64;
    let acf: Vec<f64> = (0..=max_lag)
        .map(|lag| {
            centred
                .iter()
                .zip(&centred[lag..])
                .map(|(a, b)| a * b)
                .sum::<f64>()
                / (n * var)
        })
        .collect();
    let (zlo, zhi) = Param::FlexureDamping(0).bounds();
    let misfit = |zeta: f64| -> f64 {
        let wd = omega * (1.0 - zeta * zeta).sqrt();
        acf.iter()
            .enumerate()
            .map(|(lag, r)| {
                let tau = lag as f64 * t;
                let model = (-zeta * omega * tau).exp()
                    * ((wd * tau).cos() + zeta * omega / wd * (wd * tau).sin());
                (r - model) * (r - model)
            })
            .sum()
    };
    // Golden-section search of the damping within its bounds.
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut a, mut b) = (zlo, zhi);
    for _ in 0..40 {
        let c = b - g * (b - a);
        let d = a + g * (b - a);
        if misfit(c) < misfit(d) {
            b = d;
        } else {
            a = c;
        }
    }
    Some(FlexureAxis {
        omega_rad_s: omega,
        damping: (a + b) / 2.0,
        sigma_rad: var.sqrt(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn recovers_a_sampled_gauss_markov_process() {
        // Simulate θ̈ + 2ζω θ̇ + ω² θ = w finely (1 ms, semi-implicit Euler), sample at 10 ms.
        let (omega, zeta, sigma) = (1.5f64, 0.2, 5e-4);
        let q = 4.0 * zeta * omega.powi(3) * sigma * sigma;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let dt = 1e-3;
        let (mut th, mut thd) = (0.0f64, 0.0f64);
        let mut samples = Vec::new();
        for i in 0..2_000_000 {
            let w: f64 = rng.sample(rand_distr::StandardNormal);
            thd += (-2.0 * zeta * omega * thd - omega * omega * th) * dt + (q * dt).sqrt() * w;
            th += thd * dt;
            if i % 10 == 0 {
                samples.push(th);
            }
        }
        let m = axis_model(&samples, 0.01).expect("model");
        // 2000 s ≈ 480 periods: moments to a few per cent.
        assert!((m.omega_rad_s / omega - 1.0).abs() < 0.05, "{m:?}");
        assert!((m.sigma_rad / sigma - 1.0).abs() < 0.1, "{m:?}");
        assert!((m.damping - zeta).abs() < 0.06, "{m:?}");
    }

    #[test]
    fn flat_or_short_estimates_give_nothing() {
        assert!(axis_model(&[0.0; 1000], 0.01).is_none());
        assert!(axis_model(&[1.0, -1.0, 1.0], 0.01).is_none());
    }
}
