//! Flexure truth: samples on a knot grid, linear in between, so the rate on each
//! interval `(t_{k−1}, t_k]` is exactly `(θ_k − θ_{k−1}) / Δ`.

use super::scenario::FlexureSpec;
use flexcal_core::flexure::ArAxis;
use nalgebra::{Matrix2, Vector3};
use rand::Rng;
use rand_distr::StandardNormal;

/// The flexure of three axes sampled every `knot_steps` simulator sub-steps.
pub struct FlexureTruth {
    knots: Vec<Vector3<f64>>,
    knot_steps: usize,
    knot_dt: f64,
}

impl FlexureTruth {
    /// Draws a flexure history covering `substeps` sub-steps of length `h` (s),
    /// starting in the stationary distribution.
    pub fn generate(spec: &FlexureSpec, substeps: usize, h: f64, rng: &mut impl Rng) -> Self {
        let mut n = |s: f64| -> f64 { s * rng.sample::<f64, _>(StandardNormal) };
        match *spec {
            FlexureSpec::None => Self {
                knots: vec![Vector3::zeros(); 2],
                knot_steps: substeps.max(1),
                knot_dt: h * substeps.max(1) as f64,
            },
            FlexureSpec::Ar {
                coefficients: [a1, a2],
                sigma_deg,
                period_s,
            } => {
                let knot_steps = ((period_s / h).round() as usize).max(1);
                let count = substeps / knot_steps + 2;
                let sigma = sigma_deg.to_radians();
                let ar = ArAxis {
                    a1,
                    a2,
                    sigma_rad: sigma,
                };
                // Start stationary: (θ_0, θ_{−1}) from the AR(2) stationary covariance.
                let (g0, g1) = match ar.stationary_covariance(period_s) {
                    Some(c) => (c[(0, 0)], c[(0, 0)] - c[(0, 1)] * period_s),
                    None => (0.0, 0.0),
                };
                let mut knots = Vec::with_capacity(count);
                let mut prev = Vector3::zeros();
                let mut cur = Vector3::zeros();
                for axis in 0..3 {
                    // Draw (θ_{−1}, θ_0) with covariance [[g0, g1], [g1, g0]].
                    let x = n(g0.max(0.0).sqrt());
                    let rho = if g0 > 0.0 { g1 / g0 } else { 0.0 };
                    let y = rho * x + n((g0 * (1.0 - rho * rho)).max(0.0).sqrt());
                    prev[axis] = x;
                    cur[axis] = y;
                }
                knots.push(cur);
                for _ in 1..count {
                    let next = Vector3::from_fn(|i, _| a1 * cur[i] + a2 * prev[i] + n(sigma));
                    prev = cur;
                    cur = next;
                    knots.push(cur);
                }
                Self {
                    knots,
                    knot_steps,
                    knot_dt: knot_steps as f64 * h,
                }
            }
            FlexureSpec::GaussMarkov {
                sigma_arcmin,
                omega_rad_s,
                damping,
            } => Self::gauss_markov(
                [sigma_arcmin; 3],
                [omega_rad_s; 3],
                [damping; 3],
                substeps,
                h,
                rng,
            ),
            FlexureSpec::GaussMarkovAxes {
                sigma_arcmin,
                omega_rad_s,
                damping,
            } => Self::gauss_markov(sigma_arcmin, omega_rad_s, damping, substeps, h, rng),
        }
    }

    /// Second-order Gauss-Markov flexure per axis (σ in arcmin, ω in rad/s, ζ), exactly
    /// discretized on the sub-step grid (Φ to fourth order in ωh ≈ 1e-3), started
    /// stationary.
    fn gauss_markov(
        sigma_arcmin: [f64; 3],
        omega_rad_s: [f64; 3],
        damping: [f64; 3],
        substeps: usize,
        h: f64,
        rng: &mut impl Rng,
    ) -> Self {
        let mut n = |s: f64| -> f64 { s * rng.sample::<f64, _>(StandardNormal) };
        let sigma = sigma_arcmin.map(|s| (s / 60.0).to_radians());
        // θ̈ = −ω²θ − 2ζω θ̇ + w, stationary var(θ) = q/(4ζω³), var(θ̇) = ω² var(θ).
        let axis = |k: usize| {
            let (s, w, z) = (sigma[k], omega_rad_s[k], damping[k]);
            let q = 4.0 * z * w.powi(3) * s * s;
            let f = Matrix2::new(0.0, 1.0, -w * w, -2.0 * z * w);
            let fh = f * h;
            let phi = Matrix2::identity()
                + fh
                + fh * fh / 2.0
                + fh * fh * fh / 6.0
                + fh * fh * fh * fh / 24.0;
            let qd = Matrix2::new(h.powi(3) / 3.0, h * h / 2.0, h * h / 2.0, h) * q;
            let l = qd.cholesky().map(|c| c.l()).unwrap_or_else(Matrix2::zeros);
            (phi, l)
        };
        let models = [axis(0), axis(1), axis(2)];
        let mut knots = Vec::with_capacity(substeps + 2);
        let mut states: Vec<nalgebra::Vector2<f64>> = (0..3)
            .map(|k| nalgebra::Vector2::new(n(sigma[k]), n(sigma[k] * omega_rad_s[k])))
            .collect();
        knots.push(Vector3::from_fn(|i, _| states[i][0]));
        for _ in 0..substeps + 1 {
            for (s, (phi, l)) in states.iter_mut().zip(&models) {
                let e = nalgebra::Vector2::new(n(1.0), n(1.0));
                *s = phi * *s + l * e;
            }
            knots.push(Vector3::from_fn(|i, _| states[i][0]));
        }
        Self {
            knots,
            knot_steps: 1,
            knot_dt: h,
        }
    }

    /// θ and the left-limit rate θ̇ at sub-step boundary `s` (time `s h`): the rate
    /// of the knot interval ending at or after that time.
    pub fn at_boundary(&self, s: usize) -> (Vector3<f64>, Vector3<f64>) {
        let k = s.div_ceil(self.knot_steps).max(1);
        self.on_interval(k, s)
    }

    /// θ at the middle of sub-step `(s, s+1]` and the rate on it.
    pub fn at_mid(&self, s: usize) -> (Vector3<f64>, Vector3<f64>) {
        let k = s / self.knot_steps + 1;
        let (a, b) = (self.knot(k - 1), self.knot(k));
        let rate = (b - a) / self.knot_dt;
        let into = s as f64 + 0.5 - ((k - 1) * self.knot_steps) as f64;
        (
            a + rate * (into * self.knot_dt / self.knot_steps as f64),
            rate,
        )
    }

    fn knot(&self, k: usize) -> Vector3<f64> {
        self.knots
            .get(k)
            .or(self.knots.last())
            .copied()
            .unwrap_or_else(Vector3::zeros)
    }

    /// θ at boundary `s` on knot interval `k` (between knots k−1 and k) and its rate.
    fn on_interval(&self, k: usize, s: usize) -> (Vector3<f64>, Vector3<f64>) {
        let (a, b) = (self.knot(k - 1), self.knot(k));
        let rate = (b - a) / self.knot_dt;
        let into = s as f64 - ((k - 1) * self.knot_steps) as f64;
        (
            a + rate * (into * self.knot_dt / self.knot_steps as f64),
            rate,
        )
    }
}
