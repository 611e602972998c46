//! Exact Gaussian maximum likelihood for a zero-mean AR(p) (the paper's eqs. 5-11), as a
//! refinement of the conditional least-squares estimate.
//!
//! # Likelihood
//!
//! For a stationary Gaussian AR(p) `u_k = a_1 u_{k−1} + … + a_p u_{k−p} + ε_k`,
//! `ε_k ~ N(0, σ²)`, the sample `u = (u_1 … u_n)` has covariance `σ² Γ(a)`, and eq. (11) is the
//! likelihood with `σ²` profiled out: `ℓ(a) = −½ ln|Γ| − (n/2) ln(uᵀ Γ⁻¹ u / n) + c`
//! (the paper's `M = Γ⁻¹`). It is evaluated in O(n p) by the innovations form of the
//! Levinson-Durbin recursion, parametrized by the partial autocorrelations `r_1 … r_p`
//! (reflection coefficients):
//!
//! - the order-`j` one-step predictors `φ^{(j)}` follow from the `r` by the step-up recursion
//!   `φ^{(j)}_j = r_j`, `φ^{(j)}_i = φ^{(j−1)}_i − r_j φ^{(j−1)}_{j−i}`, and `a = φ^{(p)}`;
//! - with unit innovation variance, the prediction-error variances are
//!   `v_p = 1`, `v_{j−1} = v_j / (1 − r_j²)`;
//! - sample `t ≤ p` has innovation `e_t = u_t − Σ_{i<t} φ^{(t−1)}_i u_{t−i}` with variance
//!   `v_{t−1}`, later samples the AR residual `ε_t` with variance 1, so
//!   `uᵀ Γ⁻¹ u = Σ_{t≤p} e_t² / v_{t−1} + Σ_{t>p} ε_t²` and `ln|Γ| = Σ_{t≤p} ln v_{t−1}`.
//!
//! The model is stationary exactly when every `|r_j| < 1`, so the search runs over
//! `z_j = atanh(r_j)`, unconstrained: stationarity holds by construction.
//! A series split by gaps is a set of independent segments; their log-likelihoods add, with
//! one common `σ²`.
//!
//! # Search
//!
//! Nelder-Mead in `z`, started at the conditional least-squares estimate (moved just inside
//! the stationary region if it lies outside), restarted from its own best point until a restart
//! no longer improves. The result is never worse than the start: the start is a vertex.

/// Largest `|r_j|` used to start from a non-stationary conditional estimate.
const R_START_MAX: f64 = 0.9999;
/// Nelder-Mead evaluation budget per order.
const MAX_EVALUATIONS_PER_DIM: usize = 600;
/// Restarts of the simplex from its best point.
const MAX_RESTARTS: usize = 6;

/// The exact maximum-likelihood fit of one AR order.
#[derive(Debug, Clone, PartialEq)]
pub struct ExactMl {
    /// `a_1 … a_p` maximizing the exact likelihood (always stationary).
    pub coefficients: Vec<f64>,
    /// Partial autocorrelations `r_1 … r_p` of that model, each in `(−1, 1)`.
    pub pacf: Vec<f64>,
    /// `σ̂² = uᵀ Γ⁻¹ u / n` at the maximum (eq. 10).
    pub sigma2: f64,
    /// The exact Gaussian log-likelihood at the maximum, constants included:
    /// `−(n/2)(ln 2π + 1 + ln σ̂²) − ½ ln|Γ|`.
    pub log_likelihood: f64,
    /// The same exact log-likelihood at the conditional least-squares start, or `None` when
    /// that estimate is not stationary (its exact likelihood does not exist).
    pub start_log_likelihood: Option<f64>,
    /// Samples `n` in the likelihood (every finite sample of every segment).
    pub n: usize,
    /// Likelihood evaluations spent.
    pub evaluations: usize,
    /// Whether the last simplex met its tolerance within the budget.
    pub converged: bool,
}

/// Converts partial autocorrelations `r_1 … r_p` into AR coefficients `a_1 … a_p` (step-up).
pub fn pacf_to_ar(r: &[f64]) -> Vec<f64> {
    let mut phi: Vec<f64> = Vec::with_capacity(r.len());
    for &rj in r {
        let prev = phi.clone();
        for (i, v) in phi.iter_mut().enumerate() {
            // φ^{(j)}_i = φ^{(j−1)}_i − r_j φ^{(j−1)}_{j−i}, i = 1..j−1 (here 0-based).
            let mirror = prev.get(prev.len() - 1 - i).copied().unwrap_or(0.0);
            *v -= rj * mirror;
        }
        phi.push(rj);
    }
    phi
}

/// Converts AR coefficients into partial autocorrelations (step-down); `None` when the model
/// is not stationary (some `|r_j| ≥ 1`) or a coefficient is not finite.
pub fn ar_to_pacf(a: &[f64]) -> Option<Vec<f64>> {
    let mut phi = a.to_vec();
    let mut r = vec![0.0; a.len()];
    for j in (0..a.len()).rev() {
        let rj = *phi.get(j)?;
        if !rj.is_finite() || rj.abs() >= 1.0 {
            return None;
        }
        *r.get_mut(j)? = rj;
        let d = 1.0 - rj * rj;
        let lower: Vec<f64> = (0..j)
            .map(|i| {
                let mirror = phi.get(j - 1 - i).copied().unwrap_or(0.0);
                (phi.get(i).copied().unwrap_or(0.0) + rj * mirror) / d
            })
            .collect();
        phi = lower;
    }
    Some(r)
}

/// Sufficient pieces of the exact likelihood: `(uᵀΓ⁻¹u, ln|Γ|, n)` in unit innovation variance.
fn quadratic_and_logdet(segments: &[&[f64]], r: &[f64]) -> Option<(f64, f64, usize)> {
    let p = r.len();
    if r.iter().any(|v| !v.is_finite() || v.abs() >= 1.0) {
        return None;
    }
    // Predictors of every order 0..=p and the variances v_0..v_p (v_p = 1).
    let mut predictors: Vec<Vec<f64>> = Vec::with_capacity(p + 1);
    predictors.push(Vec::new());
    for j in 1..=p {
        predictors.push(pacf_to_ar(r.get(..j)?));
    }
    let mut v = vec![1.0; p + 1];
    for j in (1..=p).rev() {
        let rj = *r.get(j - 1)?;
        *v.get_mut(j - 1)? = *v.get(j)? / (1.0 - rj * rj);
    }
    let mut quad = 0.0;
    let mut logdet = 0.0;
    let mut n = 0usize;
    for seg in segments {
        for (t, &ut) in seg.iter().enumerate() {
            // Order of the predictor available for this sample: min(t, p).
            let j = t.min(p);
            let phi = predictors.get(j)?;
            let past = seg.get(..t)?;
            let pred: f64 = past
                .iter()
                .rev()
                .zip(phi.iter())
                .map(|(&x, &a)| a * x)
                .sum();
            let e = ut - pred;
            let vj = *v.get(j)?;
            quad += e * e / vj;
            logdet += vj.ln();
            n += 1;
        }
    }
    Some((quad, logdet, n))
}

/// The exact Gaussian log-likelihood (σ² profiled out, constants included) of the AR model with
/// partial autocorrelations `r`, and its `σ̂²`; `None` if not stationary, no data, or degenerate.
pub fn exact_log_likelihood_pacf(segments: &[&[f64]], r: &[f64]) -> Option<(f64, f64)> {
    let (quad, logdet, n) = quadratic_and_logdet(segments, r)?;
    if n == 0 || !quad.is_finite() || quad <= 0.0 || !logdet.is_finite() {
        return None;
    }
    let nf = n as f64;
    let sigma2 = quad / nf;
    let ll = -0.5 * nf * ((2.0 * std::f64::consts::PI).ln() + 1.0 + sigma2.ln()) - 0.5 * logdet;
    Some((ll, sigma2))
}

/// The exact Gaussian log-likelihood (σ² profiled out) of AR coefficients `a` on the segments,
/// with its `σ̂²`; `None` for a non-stationary model or degenerate data.
pub fn exact_log_likelihood(segments: &[&[f64]], a: &[f64]) -> Option<(f64, f64)> {
    exact_log_likelihood_pacf(segments, &ar_to_pacf(a)?)
}

/// Maximizes the exact likelihood of an AR(`start.len()`) model on the segments, starting from
/// the conditional least-squares coefficients `start`.
pub fn exact_ml(segments: &[&[f64]], start: &[f64]) -> Result<ExactMl, String> {
    let p = start.len();
    let start_ll = exact_log_likelihood(segments, start).map(|(ll, _)| ll);
    let r0: Vec<f64> = match ar_to_pacf(start) {
        Some(r) => r,
        None => {
            // Shrink towards zero until stationary (always reached: a = 0 is stationary).
            let mut s = 1.0;
            loop {
                s *= 0.95;
                let shrunk: Vec<f64> = start.iter().map(|&a| a * s).collect();
                if let Some(r) = ar_to_pacf(&shrunk) {
                    break r;
                }
                if s < 1e-6 {
                    break vec![0.0; p];
                }
            }
        }
    };
    let z0: Vec<f64> = r0
        .iter()
        .map(|&r| r.clamp(-R_START_MAX, R_START_MAX).atanh())
        .collect();
    let objective = |z: &[f64]| -> f64 {
        let r: Vec<f64> = z.iter().map(|v| v.tanh()).collect();
        match exact_log_likelihood_pacf(segments, &r) {
            Some((ll, _)) => -ll,
            None => f64::INFINITY,
        }
    };
    if !objective(&z0).is_finite() {
        return Err(format!(
            "exact likelihood undefined at the start (order {p}): too few samples or zero variance"
        ));
    }
    let mut evaluations = 0usize;
    let mut best = z0;
    let mut best_f = objective(&best);
    let mut converged = p == 0;
    if p > 0 {
        for _ in 0..MAX_RESTARTS {
            let out = nelder_mead(&objective, &best, 0.2, MAX_EVALUATIONS_PER_DIM * p);
            evaluations += out.evaluations;
            converged = out.converged;
            let improved = out.f < best_f - 1e-9 * (1.0 + best_f.abs());
            if out.f < best_f {
                best = out.x;
                best_f = out.f;
            }
            if !improved {
                break;
            }
        }
    }
    let r: Vec<f64> = best.iter().map(|v| v.tanh()).collect();
    let (ll, sigma2) = exact_log_likelihood_pacf(segments, &r)
        .ok_or_else(|| format!("exact likelihood undefined at the optimum (order {p})"))?;
    let n = segments.iter().map(|s| s.len()).sum();
    Ok(ExactMl {
        coefficients: pacf_to_ar(&r),
        pacf: r,
        sigma2,
        log_likelihood: ll,
        start_log_likelihood: start_ll,
        n,
        evaluations: evaluations + 2,
        converged,
    })
}

/// Outcome of one Nelder-Mead run.
struct NmResult {
    x: Vec<f64>,
    f: f64,
    evaluations: usize,
    converged: bool,
}

/// Minimizes `f` by the Nelder-Mead simplex method (standard coefficients 1, 2, ½, ½) from `x0`
/// with initial steps `step` along each axis; `x0` is a vertex, so the result is never worse.
fn nelder_mead(f: &dyn Fn(&[f64]) -> f64, x0: &[f64], step: f64, max_eval: usize) -> NmResult {
    let d = x0.len();
    let mut simplex: Vec<(Vec<f64>, f64)> = Vec::with_capacity(d + 1);
    simplex.push((x0.to_vec(), f(x0)));
    for i in 0..d {
        let mut x = x0.to_vec();
        if let Some(v) = x.get_mut(i) {
            *v += step;
        }
        let fx = f(&x);
        simplex.push((x, fx));
    }
    let mut evaluations = d + 1;
    let mut converged = false;
    let by_value = |a: &(Vec<f64>, f64), b: &(Vec<f64>, f64)| a.1.total_cmp(&b.1);
    while evaluations < max_eval {
        simplex.sort_by(by_value);
        let (Some(first), Some(last)) = (simplex.first(), simplex.last()) else {
            break;
        };
        let (f_best, f_worst) = (first.1, last.1);
        let spread = simplex
            .iter()
            .flat_map(|(x, _)| x.iter().zip(first.0.iter()).map(|(a, b)| (a - b).abs()))
            .fold(0.0_f64, f64::max);
        if (f_worst - f_best).abs() <= 1e-12 * (1.0 + f_best.abs()) && spread < 1e-7 {
            converged = true;
            break;
        }
        let worst = last.0.clone();
        let centroid: Vec<f64> = (0..d)
            .map(|j| {
                simplex
                    .iter()
                    .take(d)
                    .map(|(x, _)| x.get(j).copied().unwrap_or(0.0))
                    .sum::<f64>()
                    / d as f64
            })
            .collect();
        let towards = |t: f64| -> Vec<f64> {
            centroid
                .iter()
                .zip(worst.iter())
                .map(|(c, w)| c + t * (w - c))
                .collect()
        };
        let f_second = simplex.get(d.saturating_sub(1)).map_or(f_worst, |v| v.1);
        let xr = towards(-1.0);
        let fr = f(&xr);
        evaluations += 1;
        let replace = if fr < f_best {
            let xe = towards(-2.0);
            let fe = f(&xe);
            evaluations += 1;
            Some(if fe < fr { (xe, fe) } else { (xr, fr) })
        } else if fr < f_second {
            Some((xr, fr))
        } else {
            let (xc, fc) = if fr < f_worst {
                let xc = towards(-0.5);
                let fc = f(&xc);
                (xc, fc)
            } else {
                let xc = towards(0.5);
                let fc = f(&xc);
                (xc, fc)
            };
            evaluations += 1;
            if fc < fr.min(f_worst) {
                Some((xc, fc))
            } else {
                None
            }
        };
        match replace {
            Some(v) => {
                if let Some(slot) = simplex.last_mut() {
                    *slot = v;
                }
            }
            None => {
                // Shrink towards the best vertex.
                let best = first.0.clone();
                for (x, fx) in simplex.iter_mut().skip(1) {
                    for (xi, bi) in x.iter_mut().zip(best.iter()) {
                        *xi = bi + 0.5 * (*xi - bi);
                    }
                    *fx = f(x);
                    evaluations += 1;
                }
            }
        }
    }
    simplex.sort_by(by_value);
    let (x, fx) = simplex
        .into_iter()
        .next()
        .unwrap_or_else(|| (x0.to_vec(), f(x0)));
    NmResult {
        x,
        f: fx,
        evaluations,
        converged,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pacf_round_trip() {
        let a = [1.2, -0.5, 0.1];
        let r = ar_to_pacf(&a).unwrap_or_default();
        let back = pacf_to_ar(&r);
        for (x, y) in a.iter().zip(back.iter()) {
            assert!((x - y).abs() < 1e-12);
        }
        assert!(ar_to_pacf(&[1.0, 0.1]).is_none());
    }

    #[test]
    fn ar1_likelihood_matches_closed_form() {
        let u = [0.3, -0.2, 0.5, 0.1, -0.4];
        let a = 0.6_f64;
        let quad = u[0] * u[0] * (1.0 - a * a)
            + u.windows(2).map(|w| (w[1] - a * w[0]).powi(2)).sum::<f64>();
        let n = u.len() as f64;
        let expect = -0.5 * n * ((2.0 * std::f64::consts::PI).ln() + 1.0 + (quad / n).ln())
            + 0.5 * (1.0 - a * a).ln();
        let (ll, s2) = exact_log_likelihood(&[&u], &[a]).unwrap_or((0.0, 0.0));
        assert!((ll - expect).abs() < 1e-12 && (s2 - quad / n).abs() < 1e-15);
    }
}
