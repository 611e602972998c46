//! `flexcal diagnose`: find the structure the declared model leaves in its residuals,
//! name the effect that explains it, add that effect's states and show the difference.
//!
//! The loop (`docs/diagnosis.md` justifies each choice):
//! 1. Calibrate with the declared model; keep every whitened innovation.
//! 2. For every candidate effect not yet in the model, calibrate again with its block
//!    of states added. Its evidence is the Wald statistic `x̂ᵀ P⁻¹ x̂` of the block at the
//!    end (χ²(k) if the effect is absent, k its number of states) and the drop of the
//!    innovations' −2 log-likelihood (the likelihood ratio, which also pays the prior's
//!    Occam factor). A candidate is significant when both exceed the χ²(k) quantile at
//!    `alpha / (budget × candidates)`: Bonferroni over every test the loop may make, so
//!    the chance of reporting any effect on a complete model is at most `alpha`.
//! 3. Add the significant candidate whose likelihood ratio exceeds its threshold most,
//!    and repeat until none is significant or `budget` effects are in.
//! 4. Whatever structure the final residuals still show (NIS out of band, Ljung-Box
//!    whiteness rejected) is reported as unexplained, with its dominant period.
//!
//! Before and after, a held-out check: the calibration estimated on the first part of the
//! recording is frozen and predicts the innovations of the rest.

pub mod evaluate;
pub mod report;
pub mod spectrum;

use crate::calib::config::CalibConfig;
use crate::recording::Recording;
use evaluate::{evaluate_model, ModelEval};
use flexcal_core::augment::{Effect, MAX_EFFECTS};
use flexcal_core::stats::chi2_isf;

/// What the diagnosis may do.
#[derive(Clone, Debug)]
pub struct Options {
    /// Candidate effects (default: every effect of the vocabulary).
    pub candidates: Vec<Effect>,
    /// Most effects added.
    pub budget: usize,
    /// Family-wise false-alarm level: the chance of reporting any effect when the
    /// declared model is complete.
    pub alpha: f64,
    /// Fraction of the recording the held-out check estimates on.
    pub holdout_fraction: f64,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            candidates: Effect::ALL.to_vec(),
            budget: 3,
            alpha: 0.01,
            holdout_fraction: 0.7,
        }
    }
}

impl Options {
    /// Checks the options.
    pub fn validate(&self) -> Result<(), String> {
        if self.budget == 0 || self.budget > MAX_EFFECTS {
            return Err(format!(
                "budget must be 1..={MAX_EFFECTS} effects, got {}",
                self.budget
            ));
        }
        if !(self.alpha > 0.0 && self.alpha < 1.0) {
            return Err(format!("alpha must be in (0, 1), got {}", self.alpha));
        }
        if !(self.holdout_fraction > 0.1 && self.holdout_fraction < 0.95) {
            return Err(format!(
                "holdout fraction must be in (0.1, 0.95), got {}",
                self.holdout_fraction
            ));
        }
        if self.candidates.is_empty() {
            return Err("no candidate effects".into());
        }
        Ok(())
    }

    /// The χ²(k) threshold every test uses: level `alpha / (budget × candidates)`.
    pub fn threshold(&self, dof: usize) -> f64 {
        let tests = (self.budget * self.candidates.len()) as f64;
        chi2_isf(self.alpha / tests, dof as f64)
    }
}

/// One candidate's test in one round.
#[derive(Clone, Debug, serde::Serialize)]
pub struct CandidateTest {
    /// The effect's name.
    pub effect: &'static str,
    /// Its number of states (degrees of freedom).
    pub dof: usize,
    /// Wald statistic of its block at the end of the augmented run.
    pub wald: f64,
    /// Drop of the innovations' −2 log-likelihood when it is added.
    pub likelihood_ratio: f64,
    /// χ²(dof) threshold both must exceed.
    pub threshold: f64,
    /// Whether both exceed it.
    pub significant: bool,
    /// Final estimate of its states (SI unit of the effect).
    pub estimate: Vec<f64>,
    /// Their σ.
    pub sigma: Vec<f64>,
    /// Why it could not be tested, when it could not.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

/// One round of the search: every candidate tested against the current model.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Round {
    /// Effects in the model this round tested against.
    pub model: Vec<&'static str>,
    /// The tests, in candidate order.
    pub tests: Vec<CandidateTest>,
    /// The effect added, if any.
    pub added: Option<&'static str>,
}

/// The outcome of a diagnosis.
pub struct Diagnosis {
    /// The declared model, evaluated.
    pub before: ModelEval,
    /// The final model, evaluated (equal to `before` when nothing was added).
    pub after: ModelEval,
    /// The search rounds.
    pub rounds: Vec<Round>,
    /// Added effects with the test that added them, in order.
    pub found: Vec<CandidateTest>,
    /// The options used.
    pub options: Options,
}

/// Runs the diagnosis of a recording with its declared configuration.
pub fn diagnose(
    rec: &Recording,
    declared: &CalibConfig,
    opts: &Options,
) -> Result<Diagnosis, String> {
    opts.validate()?;
    let before = evaluate_model(rec, declared, opts.holdout_fraction)?;
    let mut current = before.clone();
    let mut rounds = Vec::new();
    let mut found = Vec::new();
    while found.len() < opts.budget {
        let present = current.cfg.augmentation::<f64>()?;
        let untried: Vec<Effect> = opts
            .candidates
            .iter()
            .copied()
            .filter(|e| present.offset(*e).is_none())
            .collect();
        if untried.is_empty() {
            break;
        }
        let runs = evaluate::run_candidates(rec, &current, &untried)?;
        let mut tests = Vec::new();
        let mut best: Option<(f64, usize)> = None;
        for (k, (effect, outcome)) in untried.iter().zip(runs.iter()).enumerate() {
            let dof = effect.states();
            let threshold = opts.threshold(dof);
            let test = match outcome {
                Ok(run) => {
                    let last = run
                        .result
                        .final_effects()
                        .into_iter()
                        .find(|r| r.effect == *effect);
                    let (wald, estimate, sigma) = last
                        .map(|r| (r.wald, r.value, r.sigma))
                        .unwrap_or((f64::NAN, Vec::new(), Vec::new()));
                    let lr = current.neg2ll - run.neg2ll;
                    let significant = wald > threshold && lr > threshold;
                    // Among the significant, the one whose likelihood gains most over its
                    // threshold: with several candidates explaining the same signature
                    // (an accelerometer scale factor and a lever-arm error both act on
                    // the lever arm's accelerations), the better fit is the better name.
                    let excess = lr - threshold;
                    if significant && best.is_none_or(|(b, _)| excess > b) {
                        best = Some((excess, k));
                    }
                    CandidateTest {
                        effect: effect.name(),
                        dof,
                        wald,
                        likelihood_ratio: lr,
                        threshold,
                        significant,
                        estimate,
                        sigma,
                        error: None,
                    }
                }
                Err(e) => CandidateTest {
                    effect: effect.name(),
                    dof,
                    wald: f64::NAN,
                    likelihood_ratio: f64::NAN,
                    threshold,
                    significant: false,
                    estimate: Vec::new(),
                    sigma: Vec::new(),
                    error: Some(e.clone()),
                },
            };
            tests.push(test);
        }
        let model: Vec<&'static str> = present.blocks().map(|b| b.effect.name()).collect();
        let Some((_, k)) = best else {
            rounds.push(Round {
                model,
                tests,
                added: None,
            });
            break;
        };
        let (Some(effect), Some(Ok(run))) = (untried.get(k), runs.into_iter().nth(k)) else {
            break;
        };
        let test = tests.get(k).cloned();
        rounds.push(Round {
            model,
            tests,
            added: Some(effect.name()),
        });
        current = evaluate::with_holdout(rec, run, opts.holdout_fraction)?;
        found.extend(test);
    }
    Ok(Diagnosis {
        before,
        after: current,
        rounds,
        found,
        options: opts.clone(),
    })
}
