//! Process-noise effects: the slave's bias instabilities and a drifting mounting. They
//! add no state and change no measurement's mean; they let a state the model holds
//! constant wander (a random walk of the gyro biases, of the accelerometer biases, of the
//! misalignment), so a block's Wald statistic cannot find them. Each is tested by the
//! likelihood, as the blocks are by their likelihood ratio: its random walk's density is
//! searched on the whole recording with the final model (a ladder of sizes, then a
//! parabola in its logarithm, as the model learner searches it on its window), and the
//! drop of the innovations' −2 log-likelihood from a density of zero is the statistic.
//!
//! Zero is on the boundary of a density's range: with no instability the statistic is
//! ½χ²(0) + ½χ²(1) (Self and Liang, 1987), so its threshold at level `a` is the χ²(1)
//! quantile at `2a`; each test takes the level a block's test takes
//! (`Options::threshold`: `alpha / (budget × candidates)`). A significant density is named
//! only where it also predicts the held-out part better by that same threshold (the
//! gain replicated on data its estimate never saw), and is then carried by the final
//! model. A block needs only a positive held-out gain; a walk follows any slow error
//! the learned model leaves, and on 30 clean blind draws (111–140) three walks were named
//! with held-out gains of 1.5, 3.8 and 30 (`docs/diagnosis.md`, "Process noise").
//!
//! The held-out check of a density is not the blocks' (a calibration frozen after the
//! held-out fraction, `evaluate::holdout`): frozen, a random walk stops, and what it is
//! for — following a state that wanders — is gone. A density is a model parameter like
//! a noise level, so it is checked as one: estimated on the first part of the recording
//! alone (the same search on that part), then the filter runs over the whole recording
//! with it and with none, and the innovations of the rest, which the estimate never saw,
//! are compared by their −2 log-likelihood. On blind draw 201 (a gyro bias walking
//! 7.2e-7 rad/s/√s, 300 s) the frozen check rejected the density the whole recording
//! estimated within 0.6σ (held-out −546 against a likelihood ratio of 1 792;
//! `docs/diagnosis.md`, "Process noise").

use super::Options;
use crate::calib::config::CalibConfig;
use crate::calib::run::{run_with, CalibResult, Precision, RunOptions};
use crate::learn::search::{parabola_vertex, Likelihood};
use crate::recording::Recording;
use flexcal_core::stats::chi2_isf;
use rayon::prelude::*;

/// A process noise the diagnosis tests.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Instability {
    /// Gyro bias random walk (`gyro_bias_rw`, rad/s/√s).
    GyroBias,
    /// Accelerometer bias random walk (`accel_bias_rw`, m/s²/√s).
    AccelBias,
    /// Mounting misalignment random walk (`misalignment_rw_rad_rs`, rad/√s): a
    /// quasi-static drift of the mounting (thermal bending).
    Misalignment,
}

impl Instability {
    /// Every process noise tested, in report order.
    pub const ALL: [Instability; 3] = [
        Instability::GyroBias,
        Instability::AccelBias,
        Instability::Misalignment,
    ];

    /// The effect's name in reports (the literature's: bias instability, a drifting
    /// mounting).
    pub fn name(self) -> &'static str {
        match self {
            Instability::GyroBias => "gyro_bias_instability",
            Instability::AccelBias => "accel_bias_instability",
            Instability::Misalignment => "misalignment_drift",
        }
    }

    /// The configuration key of its density.
    pub fn key(self) -> &'static str {
        match self {
            Instability::GyroBias => "gyro_bias_rw",
            Instability::AccelBias => "accel_bias_rw",
            Instability::Misalignment => "misalignment_rw_rad_rs",
        }
    }

    /// The density's unit.
    pub fn unit(self) -> &'static str {
        match self {
            Instability::GyroBias => "rad/s/√s",
            Instability::AccelBias => "m/s²/√s",
            Instability::Misalignment => "rad/√s",
        }
    }

    /// The density in `cfg`.
    pub fn get(self, cfg: &CalibConfig) -> f64 {
        match self {
            Instability::GyroBias => cfg.gyro_bias_rw,
            Instability::AccelBias => cfg.accel_bias_rw,
            Instability::Misalignment => cfg.misalignment_rw_rad_rs,
        }
    }

    /// `cfg` with the density `v`.
    pub fn with(self, cfg: &CalibConfig, v: f64) -> CalibConfig {
        let mut c = cfg.clone();
        match self {
            Instability::GyroBias => c.gyro_bias_rw = v,
            Instability::AccelBias => c.accel_bias_rw = v,
            Instability::Misalignment => c.misalignment_rw_rad_rs = v,
        }
        c
    }

    /// The channel whose three axes the walk drives directly (`CHANNELS` index), if one
    /// does: an accelerometer bias's walk integrates into each velocity axis, the
    /// mounting's turns each attitude axis. A gyro bias's walk reaches the channels
    /// through tilt and heading in shares the motion sets (blind draw 105, drawn 1.5e-7
    /// rad/s/√s: a likelihood ratio of 1 024 of which the attitude axes hold 11, −3.5
    /// and 16): none.
    fn channel(self) -> Option<usize> {
        match self {
            Instability::GyroBias => None,
            Instability::Misalignment => Some(1),
            Instability::AccelBias => Some(0),
        }
    }

    /// The density that moves the state by its prior σ over `span_s`: the centre of the
    /// ladder the search starts from (the model learner's `per_window` size).
    fn scale(self, cfg: &CalibConfig, span_s: f64) -> f64 {
        let prior = match self {
            Instability::GyroBias => cfg.initial_gyro_bias_radps,
            Instability::AccelBias => cfg.initial_accel_bias_mps2,
            Instability::Misalignment => cfg.initial_misalignment_rad,
        };
        prior / span_s.max(1.0).sqrt()
    }
}

/// A walk whose wander over the recording (`density × √span`) exceeds this many prior
/// σ of its state is not taken for an instability (prior-data conflict, as a block's
/// estimate beyond `PLAUSIBLE_PRIORS`): looser than a block's 3, for a sensor's in-run
/// wander may exceed its turn-on spread (the blind draws wander 0.3–3), but not by the
/// 40 prior σ of the gyro walk that follows the 37 s master velocity wave of
/// `tests/diagnose.rs` (1.8e-5 rad/s/√s over 120 s against 1 °/h).
pub const PLAUSIBLE_WANDER: f64 = 10.0;

/// The ladder's sizes, per `Instability::scale`.
const LADDER: [f64; 4] = [1e-2, 1e-1, 1.0, 10.0];
/// The line search's step in the density's natural logarithm (a factor of 2).
const STEP: f64 = std::f64::consts::LN_2;
/// Steps the line search walks at most past the ladder's best.
const WALKS: usize = 4;

/// One process noise's test.
#[derive(Clone, Debug, serde::Serialize)]
pub struct InstabilityTest {
    /// The effect's name (`Instability::name`).
    pub effect: &'static str,
    /// Its density's configuration key.
    pub key: &'static str,
    /// The density's unit.
    pub unit: &'static str,
    /// The selection's pass the test was made in (1: against the final model; later:
    /// with the densities named before it carried).
    pub pass: usize,
    /// The density the model carried before the test (the model learner's, or the
    /// declared one).
    pub before: f64,
    /// The density the likelihood prefers on the whole recording (0: none).
    pub estimate: f64,
    /// Its σ from the likelihood's curvature in the logarithm, when that was resolved.
    pub sigma: Option<f64>,
    /// −2 log-likelihood at density 0 minus at the estimate.
    pub likelihood_ratio: f64,
    /// The walk's wander over the recording in prior σ of its state (`density × √span
    /// / prior σ`); beyond `PLAUSIBLE_WANDER` it is not significant.
    pub wander_over_prior: f64,
    /// The same per channel (velocity, attitude, angular rate) and axis (absent where
    /// the profile found nothing better than none).
    pub channel_gains: Option<[[f64; 3]; 3]>,
    /// Its threshold: the χ²(1) quantile at twice the level (boundary mixture).
    pub threshold: f64,
    /// The density estimated on the recording's first part alone (the held-out check's;
    /// 0 where that part's likelihood prefers none; absent when the test was not
    /// significant, or a run failed: `error`).
    pub first_part_estimate: Option<f64>,
    /// −2 log-likelihood of the rest's innovations with none minus with the first
    /// part's estimate (absent as `first_part_estimate`).
    pub holdout_likelihood_ratio: Option<f64>,
    /// Whether the effect is named: significant, resolved, and predicting the held-out
    /// part better by the threshold.
    pub named: bool,
    /// Filter runs the test made.
    pub runs: usize,
    /// A run that failed, if any.
    pub error: Option<String>,
}

/// The run of `cfg` on `rec` that reads the innovations only.
fn innovations(rec: &Recording, cfg: &CalibConfig) -> Option<CalibResult> {
    let opts = RunOptions {
        freeze_at_s: None,
        innovations_only: true,
    };
    run_with(rec, cfg, Precision::F64, &opts).ok()
}

/// −2 log-likelihood of the innovations of `cfg` on `rec`, in total and per channel axis
/// (`None` where the run fails or the total is not finite).
fn neg2ll(rec: &Recording, cfg: &CalibConfig) -> Option<Likelihood> {
    let l = Likelihood::of(&innovations(rec, cfg)?);
    l.total.is_finite().then_some(l)
}

/// −2 log-likelihood of the innovations of `cfg` on `rec` stamped at or after `from_s`,
/// the filter run over the whole recording.
fn neg2ll_from(rec: &Recording, cfg: &CalibConfig, from_s: f64) -> Option<f64> {
    let total: f64 = innovations(rec, cfg)?
        .innovations
        .iter()
        .filter(|i| i.t >= from_s && i.variance > 0.0)
        .map(|i| i.variance.ln() + i.value * i.value / i.variance)
        .sum();
    total.is_finite().then_some(total)
}

/// The held-out check of density `q` (module doc): its estimate on the recording's first
/// `fraction` of the master messages' span, and the −2 log-likelihood of the rest's
/// innovations with none minus with that estimate. `Ok(None)` where the first part's
/// likelihood prefers none (nothing to carry over); runs made beside.
fn holdout_gain(
    rec: &Recording,
    cfg: &CalibConfig,
    q: Instability,
    fraction: f64,
) -> (Result<Option<(f64, f64)>, String>, usize) {
    let (Some(first), Some(last)) = (rec.master.first(), rec.master.last()) else {
        return (Err("the recording has no master messages".into()), 0);
    };
    let split_s = first.t + fraction * (last.t - first.t);
    let part = crate::learn::window(rec, split_s - rec.imu_t0);
    let Some(p) = profile(&part, cfg, q, split_s - first.t) else {
        return (
            Err("the model does not run on the recording's first part".into()),
            0,
        );
    };
    let mut runs = p.runs;
    let estimate = p.best.0;
    if estimate <= 0.0 {
        return (Ok(None), runs);
    }
    let (without, with) = rayon::join(
        || neg2ll_from(rec, &q.with(cfg, 0.0), split_s),
        || neg2ll_from(rec, &q.with(cfg, estimate), split_s),
    );
    runs += 2;
    match (without, with) {
        (Some(a), Some(b)) => (Ok(Some((estimate, a - b))), runs),
        _ => (
            Err("a run over the whole recording failed or was not finite".into()),
            runs,
        ),
    }
}

/// The density's profile: −2 ln L at zero and at the best density found, the best
/// density and its σ; runs made.
struct Profile {
    at_zero: Likelihood,
    best: (f64, Likelihood),
    sigma: Option<f64>,
    runs: usize,
}

/// Index of the smallest −2 ln L of `tried`.
fn argmin(tried: &[(f64, Likelihood)]) -> Option<usize> {
    tried
        .iter()
        .enumerate()
        .min_by(|a, b| a.1 .1.total.total_cmp(&b.1 .1.total))
        .map(|(i, _)| i)
}

/// Searches one density on `rec` with the rest of `cfg` fixed: zero and the ladder, then
/// steps of `STEP` in the logarithm around the ladder's best until it has a tried
/// neighbour on each side, and the parabola's vertex through the best and its neighbours.
fn profile(rec: &Recording, cfg: &CalibConfig, q: Instability, span_s: f64) -> Option<Profile> {
    let scale = q.scale(cfg, span_s);
    let mut values: Vec<f64> = std::iter::once(0.0)
        .chain(LADDER.iter().map(|k| k * scale))
        .collect();
    let current = q.get(cfg);
    if current > 0.0 {
        values.push(current);
    }
    let eval = |vs: &[f64]| -> Vec<Option<Likelihood>> {
        vs.par_iter()
            .map(|&v| neg2ll(rec, &q.with(cfg, v)))
            .collect()
    };
    let first = eval(&values);
    let mut runs = values.len();
    let at_zero = first.first().copied().flatten()?;
    let (start, start_l) = values
        .iter()
        .zip(&first)
        .skip(1)
        .filter_map(|(v, l)| l.map(|l| (*v, l)))
        .min_by(|a, b| a.1.total.total_cmp(&b.1.total))?;
    if start_l.total >= at_zero.total {
        return Some(Profile {
            at_zero,
            best: (0.0, at_zero),
            sigma: None,
            runs,
        });
    }
    // Offsets in steps of `STEP` from the ladder's best, and what each gave.
    let mut tried: Vec<(f64, Likelihood)> = vec![(0.0, start_l)];
    let mut centre = 0.0;
    for _ in 0..WALKS {
        let offsets: Vec<f64> = [-1.0, 1.0]
            .iter()
            .map(|o| centre + o)
            .filter(|o| !tried.iter().any(|(t, _)| (t - o).abs() < 1e-9))
            .collect();
        let vs: Vec<f64> = offsets.iter().map(|o| start * (o * STEP).exp()).collect();
        runs += vs.len();
        for (o, l) in offsets.iter().zip(eval(&vs)) {
            if let Some(l) = l {
                tried.push((*o, l));
            }
        }
        tried.sort_by(|a, b| a.0.total_cmp(&b.0));
        let Some(ib) = argmin(&tried) else {
            break;
        };
        centre = tried.get(ib).map_or(0.0, |t| t.0);
        if ib > 0 && ib + 1 < tried.len() {
            break;
        }
    }
    let ib = argmin(&tried)?;
    let (best_o, best_l) = *tried.get(ib)?;
    let point = |t: &(f64, Likelihood)| (t.0, t.1.total);
    let vertex = match (
        ib.checked_sub(1).and_then(|i| tried.get(i)),
        tried.get(ib + 1),
    ) {
        (Some(a), Some(c)) => parabola_vertex(point(a), (best_o, best_l.total), point(c), STEP),
        _ => None,
    };
    let Some((o, info)) = vertex else {
        return Some(Profile {
            at_zero,
            best: (start * (best_o * STEP).exp(), best_l),
            sigma: None,
            runs,
        });
    };
    let v = start * (o * STEP).exp();
    runs += 1;
    let best = match neg2ll(rec, &q.with(cfg, v)) {
        Some(l) if l.total <= best_l.total => (v, l),
        _ => (start * (best_o * STEP).exp(), best_l),
    };
    // σ of the logarithm → σ of the density (first order).
    let sigma = Some(best.0 / info.sqrt());
    Some(Profile {
        at_zero,
        best,
        sigma,
        runs,
    })
}

/// The likelihood ratio a density must exceed: the χ²(1) quantile at twice a block's
/// level `alpha / (budget × candidates)` (zero on the boundary: module doc).
pub fn boundary_threshold(opts: &Options) -> f64 {
    let level = opts.alpha / (opts.budget * opts.candidates.len()) as f64;
    chi2_isf(2.0 * level, 1.0)
}

/// One density's test against the model `cfg` (the others as `cfg` carries them): its
/// profile, and the held-out check where it is significant.
fn test_one(
    rec: &Recording,
    cfg: &CalibConfig,
    q: Instability,
    threshold: f64,
    span_s: f64,
    pass: usize,
) -> InstabilityTest {
    let mut t = InstabilityTest {
        effect: q.name(),
        key: q.key(),
        unit: q.unit(),
        pass,
        before: q.get(cfg),
        estimate: f64::NAN,
        sigma: None,
        likelihood_ratio: f64::NAN,
        channel_gains: None,
        wander_over_prior: f64::NAN,
        threshold,
        first_part_estimate: None,
        holdout_likelihood_ratio: None,
        named: false,
        runs: 0,
        error: None,
    };
    let Some(p) = profile(rec, cfg, q, span_s) else {
        t.error = Some("the model does not run on the recording at density 0".into());
        return t;
    };
    t.runs = p.runs;
    t.estimate = p.best.0;
    t.sigma = p.sigma;
    t.likelihood_ratio = p.at_zero.total - p.best.1.total;
    t.wander_over_prior = t.estimate / q.scale(cfg, span_s);
    if t.estimate > 0.0 {
        let (a, b) = (p.at_zero.by_channel, p.best.1.by_channel);
        t.channel_gains = Some([0, 1, 2].map(|c| [0, 1, 2].map(|k| a[c][k] - b[c][k])));
    }
    t
}

impl InstabilityTest {
    /// The gain on each axis of the channel the walk drives directly
    /// (`Instability::channel`; none when it drives none or `channel_gains` is absent).
    /// One density serves the three axes, so a walk gains on each; a slow error on one
    /// axis that a walk only follows (the 37 s master velocity wave of
    /// `tests/diagnose.rs`: an accelerometer walk's likelihood ratio 34 902, all of it
    /// from the north velocity) does not.
    pub fn axis_gains(&self) -> Option<[f64; 3]> {
        let channel = Instability::ALL
            .iter()
            .find(|q| q.name() == self.effect)?
            .channel()?;
        self.channel_gains?.get(channel).copied()
    }

    /// Whether the walk gains on every axis of the channel it drives directly
    /// (`axis_gains`; an axis the recording does not match gains exactly 0); true for a
    /// walk that drives none (`Instability::channel`); false without `channel_gains`.
    pub fn gains_on_every_axis(&self) -> bool {
        self.channel_gains.is_some()
            && self
                .axis_gains()
                .is_none_or(|g| g.iter().all(|&x| x >= 0.0))
    }

    /// Whether the walk's wander is within `PLAUSIBLE_WANDER` prior σ.
    pub fn plausible(&self) -> bool {
        self.wander_over_prior <= PLAUSIBLE_WANDER
    }

    /// Significant: the likelihood ratio above its threshold, the size resolved and
    /// plausible, and a gain on every axis of its channel.
    pub fn significant(&self) -> bool {
        self.likelihood_ratio > self.threshold
            && self.sigma.is_some()
            && self.plausible()
            && self.gains_on_every_axis()
    }
}

/// Tests the process noises on `rec` against the final model `cfg` (see the module doc)
/// by forward selection, as the blocks are chosen: every density is tested; of the
/// significant, the one whose likelihood ratio exceeds its threshold most is named if it
/// passes the held-out check (else the next), the model then carries it, and the others
/// that were significant are tested again with it, until none is named. The densities
/// compete: a gyro bias walking 6.9e-7 rad/s/√s on `moored` (200 s) made the
/// accelerometer's random walk significant too when each was tested alone (likelihood
/// ratio 1 004 against the gyro's 1 147; `tests/process_noise.rs`). Returns each
/// density's last test and, when any is named, the model carrying the named densities
/// (each at its estimate; the others as they were).
pub fn test_instabilities(
    rec: &Recording,
    cfg: &CalibConfig,
    opts: &Options,
    span_s: f64,
) -> (Vec<InstabilityTest>, Option<CalibConfig>) {
    let threshold = boundary_threshold(opts);
    let mut carried = cfg.clone();
    let mut changed = false;
    let mut tests: Vec<InstabilityTest> = Vec::new();
    let mut to_test: Vec<Instability> = Instability::ALL.to_vec();
    for pass in 1..=Instability::ALL.len() {
        let mut fresh: Vec<InstabilityTest> = to_test
            .iter()
            .map(|&q| test_one(rec, &carried, q, threshold, span_s, pass))
            .collect();
        let mut ranked: Vec<(f64, usize)> = fresh
            .iter()
            .enumerate()
            .filter(|(_, t)| t.significant())
            .map(|(k, t)| (t.likelihood_ratio - t.threshold, k))
            .collect();
        ranked.sort_by(|a, b| b.0.total_cmp(&a.0));
        let mut named = None;
        for &(_, k) in &ranked {
            let (Some(t), Some(&q)) = (fresh.get_mut(k), to_test.get(k)) else {
                continue;
            };
            let (gain, runs) = holdout_gain(rec, &carried, q, opts.holdout_fraction);
            t.runs += runs;
            match gain {
                Ok(Some((first, gain))) => {
                    t.first_part_estimate = Some(first);
                    t.holdout_likelihood_ratio = Some(gain);
                    t.named = gain > threshold;
                }
                Ok(None) => {
                    t.first_part_estimate = Some(0.0);
                    t.holdout_likelihood_ratio = Some(0.0);
                }
                Err(e) => t.error = Some(e),
            }
            if t.named {
                carried = q.with(&carried, t.estimate);
                changed = true;
                named = Some(k);
                break;
            }
        }
        // Each density's latest test replaces its earlier one.
        let significant: Vec<Instability> = ranked
            .iter()
            .filter(|(_, k)| Some(*k) != named)
            .filter_map(|(_, k)| to_test.get(*k).copied())
            .collect();
        for t in fresh {
            tests.retain(|x| x.effect != t.effect);
            tests.push(t);
        }
        if named.is_none() || significant.is_empty() {
            break;
        }
        to_test = significant;
    }
    tests.sort_by_key(|t| Instability::ALL.iter().position(|q| q.name() == t.effect));
    (tests, changed.then_some(carried))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A test of `q` with likelihood ratio `lr`, wander `wander` (prior σ) and the gains
    /// `velocity` on the velocity axes (the other channels' zero).
    fn test_with(q: Instability, lr: f64, wander: f64, velocity: [f64; 3]) -> InstabilityTest {
        InstabilityTest {
            effect: q.name(),
            key: q.key(),
            unit: q.unit(),
            pass: 1,
            before: 0.0,
            estimate: 1e-4,
            sigma: Some(1e-5),
            likelihood_ratio: lr,
            channel_gains: Some([velocity, [0.0; 3], [0.0; 3]]),
            wander_over_prior: wander,
            threshold: 11.17,
            first_part_estimate: None,
            holdout_likelihood_ratio: None,
            named: false,
            runs: 0,
            error: None,
        }
    }

    #[test]
    fn a_walk_is_significant_only_above_threshold_plausible_and_gaining_on_every_axis() {
        let accel = Instability::AccelBias;
        let gains = [40.0, 30.0, 0.0];
        assert!(test_with(accel, 100.0, 2.0, gains).significant());
        assert!(!test_with(accel, 11.0, 2.0, gains).significant());
        assert!(!test_with(accel, 100.0, PLAUSIBLE_WANDER + 0.1, gains).significant());
        // The master velocity wave: all of it on the north velocity.
        let wave = [-40.6, 34_276.0, -21.4];
        assert!(!test_with(accel, 34_902.0, 0.9, wave).significant());
        // A gyro walk drives no channel directly: no per-axis rule.
        assert_eq!(
            test_with(Instability::GyroBias, 100.0, 2.0, wave).axis_gains(),
            None
        );
        assert!(test_with(Instability::GyroBias, 100.0, 2.0, wave).significant());
        // No gains: the profile found nothing better than none.
        let mut none = test_with(accel, 100.0, 2.0, gains);
        none.channel_gains = None;
        assert!(!none.significant());
        let mut unresolved = test_with(accel, 100.0, 2.0, gains);
        unresolved.sigma = None;
        assert!(!unresolved.significant());
    }

    #[test]
    fn the_boundary_threshold_is_chi2_1_at_twice_the_level() {
        // α 0.01 over 3 × 8 tests: level 4.17e-4, the χ²(1) quantile at 8.33e-4.
        let opts = Options::default();
        let thr = boundary_threshold(&opts);
        assert!((thr - 11.1655).abs() < 1e-3, "{thr}");
        // Below a one-state block's (12.46): half the null mass sits at zero.
        assert!(thr < opts.threshold(1));
    }
}
