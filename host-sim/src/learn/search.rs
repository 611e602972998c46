//! Maximum likelihood of the innovations by a bounded coordinate search.
//!
//! The filter's innovations `ν_k` with predicted variances `s_k` give the exact
//! Gaussian log-likelihood of the data under the model (the prediction-error
//! decomposition): `−2 ln L = Σ ln s_k + ν_k²/s_k + const`. Each quantity is searched in
//! turn on a log scale: the likelihood at ×¼, ×½, ×2, ×4 of the current value (evaluated
//! in parallel), the walk continued while the edge keeps winning, then a parabola through
//! the best point and its neighbours. A second sweep refines with half the step. The
//! parabola's curvature is the observed information, whose inverse square root is the
//! σ of the log-value. A process noise that may be absent (bias instability, a drifting
//! misalignment) starts from a ladder of sizes that includes zero.
//!
//! Flexure quantities come three at a time (one per slave axis): each trial value is
//! applied to the three axes at once, and each axis takes the value its own channels'
//! likelihood prefers (attitude and angular rate of that axis, which that axis's
//! flexure drives); the combination is kept only if the total likelihood agrees.

use super::flexure::flexure_from_estimates;
use super::params::{ModelParams, Param};
use crate::calib::run::{run, run_with, CalibResult, Precision, RunOptions};
use crate::recording::Recording;
use rayon::prelude::*;

/// A likelihood evaluation reads the innovations only.
const INNOVATIONS_ONLY: RunOptions = RunOptions {
    freeze_at_s: None,
    innovations_only: true,
};

/// −2 log-likelihood of one run, in total and per channel axis (`[channel][axis]`).
#[derive(Clone, Copy, Debug, Default)]
pub struct Likelihood {
    /// Sum over every scalar innovation of `ln s + ν²/s`.
    pub total: f64,
    /// The same per channel (velocity, attitude, angular rate) and axis.
    pub by_channel: [[f64; 3]; 3],
}

impl Likelihood {
    /// Of a calibration run's innovations.
    pub fn of(res: &CalibResult) -> Self {
        let mut l = Self::default();
        for i in &res.innovations {
            let term = i.variance.ln() + i.value * i.value / i.variance;
            l.total += term;
            if let Some(slot) = l
                .by_channel
                .get_mut(i.channel)
                .and_then(|c| c.get_mut(i.axis))
            {
                *slot += term;
            }
        }
        l
    }

    /// The part one slave axis's flexure drives: attitude and angular rate of that axis.
    fn axis(&self, k: usize) -> f64 {
        let at = |c: usize| {
            self.by_channel
                .get(c)
                .and_then(|a| a.get(k))
                .copied()
                .unwrap_or(0.0)
        };
        at(1) + at(2)
    }
}

/// One quantity's outcome.
#[derive(Clone, Debug, serde::Serialize)]
pub struct LearnedValue {
    /// The quantity.
    pub param: Param,
    /// Its name.
    pub name: String,
    /// Where the search started.
    pub start: f64,
    /// The learned value.
    pub value: f64,
    /// σ of the learned value from the likelihood's curvature (same unit), when the
    /// curvature was positive; `None` at a bound or a flat likelihood.
    pub sigma: Option<f64>,
    /// Log-likelihood gained while this quantity moved (½ of the −2 ln L drop).
    pub log_likelihood_gain: f64,
}

/// The search's bookkeeping.
pub struct Search<'a> {
    rec: &'a Recording,
    /// The current model.
    pub model: ModelParams,
    /// Its likelihood.
    pub current: Likelihood,
    /// Filter runs so far.
    pub evaluations: usize,
    /// Per quantity: start, value, σ, gain.
    pub values: Vec<LearnedValue>,
}

fn evaluate(rec: &Recording, m: &ModelParams) -> Option<Likelihood> {
    let res = run_with(rec, &m.config(), Precision::F64, &INNOVATIONS_ONLY).ok()?;
    let l = Likelihood::of(&res);
    l.total.is_finite().then_some(l)
}

impl<'a> Search<'a> {
    /// Starts from `model`, evaluated once.
    pub fn new(rec: &'a Recording, model: ModelParams) -> Result<Self, String> {
        let current = evaluate(rec, &model)
            .ok_or("the starting model does not run on the recording (no finite likelihood)")?;
        Ok(Self {
            rec,
            model,
            current,
            evaluations: 1,
            values: Vec::new(),
        })
    }

    fn eval_all(&mut self, models: &[ModelParams]) -> Vec<Option<Likelihood>> {
        self.evaluations += models.len();
        let rec = self.rec;
        models.par_iter().map(|m| evaluate(rec, m)).collect()
    }

    fn record(&mut self, p: Param, start: f64, sigma: Option<f64>, gain_neg2: f64) {
        let value = self.model.get(p);
        if let Some(v) = self.values.iter_mut().find(|v| v.param == p) {
            v.value = value;
            v.sigma = sigma;
            v.log_likelihood_gain += gain_neg2 / 2.0;
        } else {
            self.values.push(LearnedValue {
                param: p,
                name: p.name(),
                start,
                value,
                sigma,
                log_likelihood_gain: gain_neg2 / 2.0,
            });
        }
    }

    /// A trial model: `params` each set to `f(current value)`.
    fn trial(&self, params: &[Param], f: impl Fn(Param, f64) -> f64) -> ModelParams {
        let mut m = self.model.clone();
        for &p in params {
            m.set(p, f(p, self.model.get(p)));
        }
        m
    }

    /// For a process noise at zero: tries a ladder of sizes around `scale`; keeps the
    /// best (zero included).
    fn ladder(&mut self, p: Param, scale: f64) {
        let start = self.model.get(p);
        if start > 0.0 {
            return;
        }
        self.best_of(p, start, &[1e-3, 1e-2, 1e-1, 1.0].map(|k| k * scale));
    }

    /// Evaluates `p` at each of `values`, keeps the best if it beats the current model,
    /// and records the gain from `start`.
    fn best_of(&mut self, p: Param, start: f64, values: &[f64]) {
        let models: Vec<ModelParams> = values.iter().map(|&v| self.trial(&[p], |_, _| v)).collect();
        let results = self.eval_all(&models);
        let before = self.current.total;
        if let Some((m, l)) = models
            .into_iter()
            .zip(results)
            .filter_map(|(m, l)| l.map(|l| (m, l)))
            .min_by(|a, b| a.1.total.total_cmp(&b.1.total))
        {
            if l.total < self.current.total {
                self.model = m;
                self.current = l;
            }
        }
        self.record(p, start, None, before - self.current.total);
    }

    /// Searches one quantity (or one per axis, `params` of the same kind) on a log scale
    /// with step `h` (natural log units).
    pub fn line(&mut self, params: &[Param], h: f64) {
        let weights = vec![1.0; params.len()];
        self.line_search(params, &weights, params.len() > 1, h);
    }

    /// Searches one direction on a log scale: a step `o·h` moves each `params[k]` by
    /// `exp(weights[k]·o·h)`, all together, judged by the total likelihood. Where two
    /// quantities are resolved only in a combination (a Gauss-Markov error's σ and
    /// correlation time τ over a window shorter than τ, which sees its diffusion
    /// `2σ²/τ`), a line along that combination's level set moves where coordinate
    /// lines cannot.
    pub fn line_along(&mut self, params: &[(Param, f64)], h: f64) {
        let (ps, ws): (Vec<Param>, Vec<f64>) = params.iter().copied().unzip();
        self.line_search(&ps, &ws, false, h);
    }

    /// The line search of [`Search::line`] and [`Search::line_along`]: per axis (each
    /// axis picks by its own channels) or as one direction (picked by the total).
    fn line_search(&mut self, params: &[Param], weights: &[f64], per_axis: bool, h: f64) {
        let starts: Vec<f64> = params.iter().map(|&p| self.model.get(p)).collect();
        if params.iter().any(|&p| self.model.get(p) <= 0.0) {
            return; // a vanished process noise stays at zero (the ladder chose it)
        }
        let before = self.current.total;
        let weight = |k: usize| weights.get(k).copied().unwrap_or(1.0);
        // The factor a step of `o` applies to `p`.
        let factor = |p: Param, o: f64| {
            let w = params.iter().position(|&q| q == p).map_or(1.0, weight);
            (w * o * h).exp()
        };
        // Offsets (in steps) tried around the current centre, and what each gave.
        let mut tried: Vec<(f64, Likelihood)> = vec![(0.0, self.current)];
        let mut centre = 0.0;
        for _ in 0..4 {
            let offsets: Vec<f64> = [-2.0, -1.0, 1.0, 2.0]
                .iter()
                .map(|o| centre + o)
                .filter(|o| !tried.iter().any(|(t, _)| (t - o).abs() < 1e-9))
                .collect();
            let models: Vec<ModelParams> = offsets
                .iter()
                .map(|&o| self.trial(params, |p, v| v * factor(p, o)))
                .collect();
            let results = self.eval_all(&models);
            for (o, l) in offsets.into_iter().zip(results) {
                if let Some(l) = l {
                    tried.push((o, l));
                }
            }
            let best = tried
                .iter()
                .min_by(|a, b| a.1.total.total_cmp(&b.1.total))
                .map(|t| t.0)
                .unwrap_or(0.0);
            let lo = tried.iter().map(|t| t.0).fold(f64::INFINITY, f64::min);
            let hi = tried.iter().map(|t| t.0).fold(f64::NEG_INFINITY, f64::max);
            centre = best;
            // Stop once the best has tried neighbours on both sides.
            if best > lo && best < hi {
                break;
            }
        }
        let pick = |score: &dyn Fn(&Likelihood) -> f64| -> (f64, Option<f64>) {
            let mut pts: Vec<(f64, f64)> = tried.iter().map(|(o, l)| (*o, score(l))).collect();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            let (ib, _) = pts
                .iter()
                .enumerate()
                .min_by(|a, b| a.1 .1.total_cmp(&b.1 .1))
                .map(|(i, p)| (i, *p))
                .unwrap_or((0, (0.0, 0.0)));
            let best = pts.get(ib).map(|p| p.0).unwrap_or(0.0);
            match (
                ib.checked_sub(1).and_then(|i| pts.get(i)),
                pts.get(ib),
                pts.get(ib + 1),
            ) {
                (Some(a), Some(b), Some(c)) => parabola_vertex(*a, *b, *c, h)
                    .map(|(v, curv)| (v, Some(curv)))
                    .unwrap_or((best, None)),
                _ => (best, None),
            }
        };
        // Each axis picks by its own channels; one quantity by the total.
        let picks: Vec<(f64, Option<f64>)> = if per_axis {
            (0..params.len())
                .map(|k| pick(&|l: &Likelihood| l.axis(k)))
                .collect()
        } else {
            vec![pick(&|l: &Likelihood| l.total)]
        };
        // One direction: every quantity takes its pick.
        let pick_of = |k: usize| {
            picks
                .get(if per_axis { k } else { 0 })
                .copied()
                .unwrap_or((0.0, None))
        };
        let mut candidate = self.model.clone();
        for (k, &p) in params.iter().enumerate() {
            let (o, _) = pick_of(k);
            candidate.set(p, self.model.get(p) * factor(p, o));
        }
        let best_tried = tried
            .iter()
            .min_by(|a, b| a.1.total.total_cmp(&b.1.total))
            .copied();
        if let Some(l) = self.eval_all(std::slice::from_ref(&candidate))[0] {
            if l.total < self.current.total && best_tried.is_none_or(|(_, bt)| l.total <= bt.total)
            {
                self.model = candidate;
                self.current = l;
            } else if let Some((o, bt)) = best_tried {
                if bt.total < self.current.total {
                    self.model = self.trial(params, |p, v| v * factor(p, o));
                    self.current = bt;
                }
            }
        }
        let gain = (before - self.current.total) / params.len() as f64;
        for (k, &p) in params.iter().enumerate() {
            // σ of the log-value → σ of the value (first order).
            let sigma = pick_of(k)
                .1
                .map(|curv| weight(k).abs() * self.model.get(p) / curv.sqrt());
            self.record(p, starts.get(k).copied().unwrap_or(0.0), sigma, gain);
        }
    }

    /// Replaces the flexure of the axes given (from the filter's own estimate,
    /// `super::flexure`) and re-evaluates: the flexure is identified, not searched.
    pub fn identify_flexure(&mut self) {
        let cfg = self.model.config();
        self.evaluations += 1;
        let Ok(res) = run(self.rec, &cfg, Precision::F64) else {
            return;
        };
        let axes = flexure_from_estimates(&res.rows, cfg.filter_period_s);
        let starts = self.model.flexure;
        let mut m = self.model.clone();
        for (k, a) in axes.iter().enumerate() {
            if let (Some(a), Some(slot)) = (a, m.flexure.get_mut(k)) {
                *slot = *a;
            }
        }
        let Some(l) = self.eval_all(std::slice::from_ref(&m))[0] else {
            return;
        };
        let gain = (self.current.total - l.total) / 9.0;
        self.model = m;
        self.current = l;
        for (k, st) in starts.iter().enumerate() {
            for (p, start) in [
                (Param::FlexureOmega(k), st.omega_rad_s),
                (Param::FlexureDamping(k), st.damping),
                (Param::FlexureSigma(k), st.sigma_rad),
            ] {
                self.record(p, start, None, gain);
            }
        }
    }

    /// The matching noise of every channel axis by covariance matching: the filter is
    /// run, each axis's variance `r` is moved toward a mean NIS of 1, and again,
    /// `iterations` times or until every axis's mean NIS is within `NIS_TOLERANCE` of
    /// 1 (`next_variance` says how each step is taken). The nine axes move together,
    /// which a coordinate search cannot do where they share noise (the master's rate
    /// noise enters the velocity matching through the lever arm). Per axis, not per
    /// channel: the flexure's share of the attitude and rate innovations differs per
    /// axis (a white master at 10 Hz, blind seed 3, had rate NIS 0.81, 0.90, 1.25 on
    /// x, y, z with one σ per channel). The σ of each value is that of a variance read
    /// from its innovations, `σ/√(2n)`. On `rec` (the search's window, or the whole
    /// recording for the final pass).
    pub fn match_noise(&mut self, rec: &Recording, iterations: usize) {
        self.match_noise_of(rec, iterations, [true; 3]);
    }

    /// [`Search::match_noise`] on the chosen channels only (velocity, attitude, angular
    /// rate); the others keep their noise.
    pub fn match_noise_of(&mut self, rec: &Recording, iterations: usize, channels: [bool; 3]) {
        let chosen = |k: usize| channels.get(k / 3).copied().unwrap_or(false);
        let params: [Param; 9] = [0, 1, 2, 3, 4, 5, 6, 7, 8].map(|i| match i / 3 {
            0 => Param::VelocityNoise(i % 3),
            1 => Param::AttitudeNoise(i % 3),
            _ => Param::RateNoise(i % 3),
        });
        let starts = params.map(|p| self.model.get(p));
        let before = self.current.total;
        let mut counts = [0usize; 9];
        let mut previous: [Option<(f64, f64)>; 9] = [None; 9];
        for _ in 0..iterations {
            self.evaluations += 1;
            let Ok(res) = run_with(rec, &self.model.config(), Precision::F64, &INNOVATIONS_ONLY)
            else {
                break;
            };
            let mut nis_sum = [0.0f64; 9];
            let mut slope = [0.0f64; 9];
            counts = [0; 9];
            for i in res
                .innovations
                .iter()
                .filter(|i| i.accepted && i.variance > 0.0 && i.axis < 3)
            {
                let k = i.channel * 3 + i.axis;
                if let (Some(n), Some(q), Some(c)) =
                    (counts.get_mut(k), nis_sum.get_mut(k), slope.get_mut(k))
                {
                    let s = i.variance;
                    *n += 1;
                    *q += i.value * i.value / s;
                    *c += i.value * i.value / (s * s);
                }
            }
            let nis: [f64; 9] = std::array::from_fn(|k| nis_sum[k] / counts[k].max(1) as f64);
            if (0..9).all(|k| !chosen(k) || counts[k] == 0 || (nis[k] - 1.0).abs() < NIS_TOLERANCE)
            {
                break;
            }
            for (k, &p) in params.iter().enumerate() {
                let sigma = self.model.get(p);
                let r = sigma * sigma;
                // d(mean NIS)/dr at this r (∂s/∂r = 1).
                let derivative = -slope[k] / counts[k].max(1) as f64;
                if chosen(k) && counts[k] > 0 && r > 0.0 {
                    let next = next_variance(r, nis[k], derivative, previous[k]);
                    previous[k] = Some((r, nis[k]));
                    self.model.set(p, next.sqrt());
                }
            }
        }
        if std::ptr::eq(rec, self.rec) {
            if let Some(l) = evaluate(rec, &self.model) {
                self.evaluations += 1;
                self.current = l;
            }
        }
        let matched = (0..9).filter(|&k| chosen(k)).count().max(1);
        let gain = (before - self.current.total) / matched as f64;
        for (k, &p) in params.iter().enumerate() {
            if chosen(k) && counts[k] > 0 {
                let v = self.model.get(p);
                let sigma = v / (2.0 * counts[k] as f64).sqrt();
                self.record(p, starts[k], Some(sigma), gain);
            }
        }
    }

    /// Moves `p` back to `value` unless the likelihood resolved where it went (its σ known
    /// and at most `max_relative_sigma` of the value). Over a flat likelihood the search
    /// wanders to a bound, and a value no evidence supports must not replace the start:
    /// a velocity random walk walked down to its floor made a blind run's tilt and
    /// accelerometer bias overconfident (blind seed 4, 600 s: NEES 108, 28.6 with the
    /// start kept; `docs/model-learning.md`).
    pub fn keep_only_if_resolved(&mut self, p: Param, value: f64, max_relative_sigma: f64) {
        let now = self.model.get(p);
        let resolved = self
            .values
            .iter()
            .find(|v| v.param == p)
            .and_then(|v| v.sigma)
            .is_some_and(|sigma| sigma <= max_relative_sigma * now);
        if !resolved {
            self.set_back(p, value);
        }
    }

    /// Moves `p` back to `bound` if the search took it above: a bound that other
    /// evidence sets (the gyro increments' white floor above the angle random walk).
    pub fn at_most(&mut self, p: Param, bound: f64) {
        if self.model.get(p) > bound {
            self.set_back(p, bound);
        }
    }

    /// Sets `p` to `value` (its likelihood evaluated), unless it is there already.
    fn set_back(&mut self, p: Param, value: f64) {
        if self.model.get(p) == value {
            return;
        }
        let model = self.trial(&[p], |_, _| value);
        let before = self.current.total;
        if let Some(l) = self.eval_all(std::slice::from_ref(&model))[0] {
            self.model = model;
            self.current = l;
            self.record(p, value, None, before - l.total);
        }
    }

    /// A quantity that starts at a value another one implies and may be much smaller
    /// or absent: the current value against zero and 10⁻³, 10⁻², 10⁻¹ of it, the best
    /// kept, then (if it is not zero) a line.
    pub fn shrinking(&mut self, p: Param, h: f64) {
        let start = self.model.get(p);
        if start > 0.0 {
            self.best_of(p, start, &[0.0, 1e-3, 1e-2, 1e-1].map(|k| k * start));
        }
        if self.model.get(p) > 0.0 {
            self.line(&[p], h);
        }
    }

    /// A process noise that may be absent: the ladder, then (if it is not zero) a line.
    pub fn vanishing(&mut self, p: Param, scale: f64, h: f64) {
        self.ladder(p, scale);
        if self.model.get(p) > 0.0 {
            self.line(&[p], h);
        }
    }
}

/// One covariance-matching step of a channel axis's variance `r` (its mean NIS `nis`,
/// `d nis/dr` = `derivative`, the previous step's `(r, nis)`): the mean NIS falls with
/// `r`, convexly. With a previous point whose NIS differs, a secant in log r against
/// log NIS. Else, above 1, Newton's step on `nis − 1`, which on a convex decreasing
/// function stops short of the root and never passes it; below 1, `r·nis`, which is
/// exact when `r` is all of `s` and stops short when the states' share `h P hᵀ` is
/// not. Measured (`docs/model-learning.md`): σ scaled by √NIS four times left blind
/// seed 4's rate NIS at 0.962–0.976 (band ±1.1 %); a Fisher-scoring step (the
/// likelihood's, weights 1/s²) took seed 6's vertical velocity from NIS 1.045 to
/// 0.411; Newton's step on both sides overshot below 1 and left seed 6's attitude at
/// 1.38–1.45. A step is bounded to a factor of 100 either way.
fn next_variance(r: f64, nis: f64, derivative: f64, previous: Option<(f64, f64)>) -> f64 {
    let secant = previous.and_then(|(r0, nis0)| {
        let slope = (nis.ln() - nis0.ln()) / (r.ln() - r0.ln());
        (slope < 0.0 && slope.is_finite()).then(|| (r.ln() - nis.ln() / slope).exp())
    });
    let next = match secant {
        Some(v) => v,
        None if nis > 1.0 && derivative < 0.0 => r + (nis - 1.0) / -derivative,
        None => r * nis,
    };
    if next.is_finite() {
        next.clamp(r / 100.0, r * 100.0)
    } else {
        r
    }
}

/// How close to 1 every channel's mean NIS must come for covariance matching to stop.
pub const NIS_TOLERANCE: f64 = 0.005;

/// Vertex of the parabola through three points `(offset, −2 ln L)` spaced by one step,
/// and the observed information of the log-value there (½ d²(−2 ln L)/du², u in natural
/// log units: step `h`). `None` when the points are not convex.
pub(crate) fn parabola_vertex(
    a: (f64, f64),
    b: (f64, f64),
    c: (f64, f64),
    h: f64,
) -> Option<(f64, f64)> {
    let (x0, x1, x2) = (a.0, b.0, c.0);
    let (y0, y1, y2) = (a.1, b.1, c.1);
    let d01 = (y1 - y0) / (x1 - x0);
    let d12 = (y2 - y1) / (x2 - x1);
    let second = 2.0 * (d12 - d01) / (x2 - x0); // d²y/dx², x in steps
    if !(second > 0.0 && second.is_finite()) {
        return None;
    }
    // The derivative is d01 at the midpoint of x0 and x1 and falls at rate `second`.
    let v = ((x0 + x1) / 2.0 - d01 / second).clamp(x0, x2);
    let info = 0.5 * second / (h * h);
    Some((v, info))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parabola_finds_the_vertex_and_the_curvature() {
        // y = 3 (x − 0.4)² + 1 in steps of h = 0.5: d²y/du² = 6 / h².
        let y = |x: f64| 3.0 * (x - 0.4) * (x - 0.4) + 1.0;
        let (v, info) =
            parabola_vertex((-1.0, y(-1.0)), (0.0, y(0.0)), (1.0, y(1.0)), 0.5).expect("convex");
        assert!((v - 0.4).abs() < 1e-12, "{v}");
        assert!((info - 0.5 * 6.0 / 0.25).abs() < 1e-9, "{info}");
    }

    /// The mean NIS of an axis whose innovation variance is `hph + r_true` while the
    /// filter assumes `hph + r`: convex and decreasing in `r`, 1 at `r_true`.
    fn nis_of(r: f64, hph: f64, r_true: f64) -> (f64, f64) {
        let s = hph + r;
        ((hph + r_true) / s, -(hph + r_true) / (s * s))
    }

    /// Steps until the NIS is within 1e-3 of 1 (at most 20), from `r`.
    fn steps_to_converge(mut r: f64, hph: f64, r_true: f64) -> (usize, f64) {
        let mut previous = None;
        for k in 0..20 {
            let (nis, d) = nis_of(r, hph, r_true);
            if (nis - 1.0).abs() < 1e-3 {
                return (k, r);
            }
            let next = next_variance(r, nis, d, previous);
            previous = Some((r, nis));
            r = next;
        }
        (20, r)
    }

    #[test]
    fn covariance_matching_reaches_nis_one_where_the_states_dominate() {
        // The states carry 90 % of the innovation variance: √NIS scaling crawls here.
        let (hph, r_true) = (9.0, 1.0);
        for start in [0.05, 0.5, 2.0, 20.0] {
            let (k, r) = steps_to_converge(start, hph, r_true);
            assert!(k <= 6, "from {start}: {k} steps, r = {r}");
            assert!((r - r_true).abs() < 0.02, "from {start}: r = {r}");
        }
    }

    #[test]
    fn first_step_from_above_one_never_passes_the_root() {
        // NIS above 1 (r too small): Newton's step on a convex decreasing NIS stops short.
        let (hph, r_true) = (3.0, 5.0);
        let r = 0.5;
        let (nis, d) = nis_of(r, hph, r_true);
        let next = next_variance(r, nis, d, None);
        assert!(next > r && next <= r_true, "{next}");
        // Below 1 (r too large): r·NIS stops short too.
        let r = 50.0;
        let (nis, d) = nis_of(r, hph, r_true);
        let next = next_variance(r, nis, d, None);
        assert!(next < r && next >= r_true, "{next}");
    }

    #[test]
    fn covariance_matching_steps_are_bounded_and_finite() {
        assert_eq!(next_variance(1.0, f64::NAN, -1.0, None), 1.0);
        assert_eq!(next_variance(1.0, 1e9, -1e-12, None), 100.0);
        assert_eq!(next_variance(1.0, 1e-9, -1.0, None), 0.01);
    }

    #[test]
    fn concave_points_give_no_vertex() {
        assert!(parabola_vertex((-1.0, 0.0), (0.0, 1.0), (1.0, 0.0), 1.0).is_none());
    }
}
