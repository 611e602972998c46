//! The outputs of `flexcal diagnose`: `diagnosis.json` (the contract of
//! `shared/formats/outputs.md`), `report.md` and its plots.

use super::evaluate::ModelEval;
use super::process_noise::InstabilityTest;
use super::spectrum::{autocorrelation, welch};
use super::{CandidateTest, Diagnosis, Round};
use crate::calib::run::{Innovation, CHANNELS};
use crate::calib::score::score;
use crate::cmd::TOOL_VERSION;
use crate::plot::{Band, Figure, Panel, Series};
use crate::recording::{Recording, Truth};
use crate::report::summary::summary_json;
use flexcal_core::augment::Effect;
use flexcal_core::stats::chi2_quantile;
use serde_json::{json, Value};
use std::fmt::Write as _;
use std::path::Path;

/// Lags of the autocorrelation plots and of the reported structure.
const ACF_LAGS: usize = 200;

/// The truth of an effect's states from `truth.csv` (the simulator's own columns).
pub fn effect_truth(effect: Effect, truth: &Truth) -> Option<Vec<f64>> {
    let names: &[&str] = match effect {
        Effect::GyroScaleFactor => &["sgx", "sgy", "sgz"],
        Effect::AccelScaleFactor => &["sax", "say", "saz"],
        Effect::GyroMisalignment => &["ngxy", "ngxz", "ngyz"],
        Effect::AccelMisalignment => &["naxy", "naxz", "nayz"],
        Effect::TimeDelay => &["tau"],
        Effect::ClockDrift => &["tau", "tau_rate"],
        Effect::LeverArmError => &["drx", "dry", "drz"],
        Effect::GyroGSensitivity => &[
            "gs11", "gs12", "gs13", "gs21", "gs22", "gs23", "gs31", "gs32", "gs33",
        ],
        // No constant truth: the bending error has no column, the master's smooth
        // errors vary in time.
        Effect::LeverArmCoupling | Effect::MasterAttitudeError | Effect::MasterVelocityError => {
            return None
        }
    };
    names
        .iter()
        .map(|n| truth.column(n).and_then(|c| c.last().copied()))
        .collect()
}

/// The drawn density of a process noise in `truth.csv` (`bg_rw`, `ba_rw`, `mu_rw`), if the
/// simulator wrote one.
pub fn instability_truth(t: &InstabilityTest, truth: &Truth) -> Option<f64> {
    let column = match t.key {
        "gyro_bias_rw" => "bg_rw",
        "accel_bias_rw" => "ba_rw",
        "misalignment_rw_rad_rs" => "mu_rw",
        _ => return None,
    };
    truth.column(column).and_then(|c| c.last().copied())
}

/// A process noise's test in one sentence: the density found, the evidence, the
/// decision, and the truth with the error in σ where `truth.csv` has it.
pub fn instability_line(t: &InstabilityTest, truth: Option<&Truth>) -> String {
    if let Some(e) = t.error.as_ref().filter(|_| t.likelihood_ratio.is_nan()) {
        return format!("{}: not tested: {e}", t.effect);
    }
    let sigma = t
        .sigma
        .map_or("(σ unresolved)".to_string(), |s| format!("± {}", fmt_g(s)));
    let first = t.first_part_estimate.map_or(String::new(), |v| {
        format!(
            "; estimated on the first part alone {}, held-out likelihood ratio {}",
            fmt_g(v),
            fmt_g(t.holdout_likelihood_ratio.unwrap_or(f64::NAN))
        )
    });
    let decision = if t.named {
        format!("named, the final model carries it{first}")
    } else if t.likelihood_ratio.is_nan() || t.likelihood_ratio <= t.threshold {
        "not significant".to_string()
    } else if t.sigma.is_none() {
        "not named: its size is not resolved (no curvature at the best density)".to_string()
    } else if !t.plausible() {
        format!(
            "not named: implausible, it wanders {} prior σ of its state over the recording (at most {})",
            fmt_g(t.wander_over_prior),
            super::process_noise::PLAUSIBLE_WANDER
        )
    } else if !t.gains_on_every_axis() {
        format!(
            "not named: one density serves three axes, and it does not gain on each of its channel's (per axis {})",
            t.axis_gains().map_or("–".into(), |g| fmt_vec(&g))
        )
    } else if let Some(e) = &t.error {
        format!("not named: the held-out check failed: {e}")
    } else {
        format!("not named: it does not predict the held-out part better by the threshold{first}")
    };
    let truth = truth
        .and_then(|tr| instability_truth(t, tr))
        .map_or(String::new(), |v| {
            let z = t.sigma.map_or(String::new(), |s| {
                format!(", {:+.2}σ", (t.estimate - v) / s)
            });
            format!("; truth {}{z}", fmt_g(v))
        });
    let pass = if t.pass > 1 {
        format!(
            ", tested again with the densities named before it carried (pass {})",
            t.pass
        )
    } else {
        String::new()
    };
    format!(
        "{}: {} = {} {sigma} {} (LR {} against none, threshold {}; the model had {}{pass}): {decision}{truth}",
        t.effect,
        t.key,
        fmt_g(t.estimate),
        t.unit,
        fmt_g(t.likelihood_ratio),
        fmt_g(t.threshold),
        fmt_g(t.before)
    )
}

/// A named process noise in `diagnosis.json`'s `effects_found`, in the blocks' shape:
/// one-element estimate and σ, the likelihood ratio as its evidence.
fn instability_json(t: &InstabilityTest, truth: Option<&Truth>) -> Value {
    let mut v = json!({
        "name": t.effect,
        "estimate": [t.estimate],
        "sigma": [t.sigma.unwrap_or(f64::NAN)],
        "unit": t.unit,
        "evidence": {
            "statistic": "likelihood_ratio",
            "value": t.likelihood_ratio,
            "threshold": t.threshold,
            "dof": 1,
            "likelihood_ratio": t.likelihood_ratio,
            "holdout_likelihood_ratio": t.holdout_likelihood_ratio,
        },
    });
    if let (Some(tr), Some(obj)) = (
        truth.and_then(|tr| instability_truth(t, tr)),
        v.as_object_mut(),
    ) {
        obj.insert("truth".into(), json!([tr]));
        let z = t.sigma.map_or(f64::NAN, |s| (t.estimate - tr) / s);
        obj.insert("error_over_sigma".into(), json!([z]));
    }
    v
}

/// Whitened innovations (ν/√s) of one channel axis, accepted or not, in time order.
pub(crate) fn whitened(innov: &[Innovation], channel: usize, axis: usize) -> (Vec<f64>, Vec<f64>) {
    innov
        .iter()
        .filter(|i| i.channel == channel && i.axis == axis && i.variance > 0.0)
        .map(|i| (i.t, i.value / i.variance.sqrt()))
        .unzip()
}

/// Structure left in one channel axis.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Structure {
    /// Channel name.
    pub channel: &'static str,
    /// Axis 0..3.
    pub axis: usize,
    /// Mean NIS.
    pub nis_mean: f64,
    /// Its band at the family-wise level.
    pub nis_band: [f64; 2],
    /// Ljung-Box p-value.
    pub whiteness_p: f64,
    /// Whether NIS or whiteness is rejected at the family-wise level.
    pub rejected: bool,
    /// Frequency of the largest spectral peak of the whitened innovations (Hz).
    pub peak_hz: f64,
    /// That peak's level over the white level.
    pub peak_level: f64,
    /// Share of the innovation variance predictable from its own past (`size`).
    pub predictable_share: f64,
    /// The structure's size: predictable variance beyond chance, in units of the
    /// filter's predicted innovation variance (`size::AxisSize::excess`).
    pub size: f64,
}

/// The structure of every channel axis of a model, tested at family-wise level `alpha`
/// (Bonferroni over the channel axes).
pub fn structure(eval: &ModelEval, alpha: f64, rate_hz: f64) -> Vec<Structure> {
    let n = eval.residuals.len().max(1) as f64;
    let a = alpha / n;
    let sizes = super::size::axis_sizes(&eval.result.innovations, rate_hz);
    let mut out: Vec<Structure> = eval
        .residuals
        .iter()
        .map(|r| {
            let c = CHANNELS.iter().position(|n| *n == r.channel).unwrap_or(0);
            let (_, w) = whitened(&eval.result.innovations, c, r.axis);
            let (peak_hz, peak_level) = welch(&w, rate_hz).peak().unwrap_or((f64::NAN, f64::NAN));
            let k = r.count as f64;
            let band = [
                chi2_quantile(a / 2.0, k) / k,
                chi2_quantile(1.0 - a / 2.0, k) / k,
            ];
            let size = sizes
                .iter()
                .find(|z| z.channel == r.channel && z.axis == r.axis);
            Structure {
                channel: r.channel,
                axis: r.axis,
                nis_mean: r.nis_mean,
                nis_band: band,
                whiteness_p: r.whiteness_p,
                rejected: r.whiteness_p < a || r.nis_mean < band[0] || r.nis_mean > band[1],
                peak_hz,
                peak_level,
                predictable_share: size.map_or(f64::NAN, |z| z.share),
                size: size.map_or(0.0, |z| z.excess),
            }
        })
        .collect();
    // Largest first: what the structure is worth, not how significant it is.
    out.sort_by(|x, y| y.size.total_cmp(&x.size));
    out
}

fn residuals_json(eval: &ModelEval) -> Value {
    let hold = eval.holdout.as_ref();
    json!({
        "nis_mean": eval.result.nis_mean(),
        "channels": eval.residuals.iter().map(|r| format!("{}_{}", r.channel, ["x", "y", "z"][r.axis.min(2)])).collect::<Vec<_>>(),
        "whiteness_p": eval.residuals.iter().map(|r| r.whiteness_p).collect::<Vec<_>>(),
        "nis_per_channel": eval.residuals.iter().map(|r| r.nis_mean).collect::<Vec<_>>(),
        "holdout_rms": hold.map(|h| h.channels.iter().map(|c| c.rms).collect::<Vec<_>>()).unwrap_or_default(),
        "holdout_nis_mean": hold.map(|h| h.nis_mean),
        "holdout_freeze_at_s": hold.map(|h| h.freeze_at_s),
        "neg2_log_likelihood": eval.neg2ll,
    })
}

fn model_json(rec_label: &str, rec: &Recording, eval: &ModelEval) -> Value {
    let duration = match (rec.imu.first(), rec.imu.last()) {
        (Some(_), Some(l)) => l.t - rec.imu_t0,
        _ => 0.0,
    };
    let sc = rec.truth.as_ref().and_then(|t| score(&eval.result, t));
    json!({
        "summary": summary_json(rec_label, duration, &eval.cfg, "configured", &eval.result, sc.as_ref()),
        "residuals": residuals_json(eval),
    })
}

fn found_json(t: &CandidateTest, truth: Option<&Truth>) -> Value {
    let effect = Effect::from_name(t.effect);
    let mut v = json!({
        "name": t.effect,
        "estimate": t.estimate,
        "sigma": t.sigma,
        "unit": effect.map_or("", |e| e.unit()),
        "evidence": {
            "statistic": "wald",
            "value": t.wald,
            "threshold": t.threshold,
            "dof": t.dof,
            "likelihood_ratio": t.likelihood_ratio,
        },
    });
    if let (Some(e), Some(tr), Some(obj)) = (effect, truth, v.as_object_mut()) {
        if let Some(truth) = effect_truth(e, tr) {
            let z: Vec<f64> = t
                .estimate
                .iter()
                .zip(&truth)
                .zip(&t.sigma)
                .map(|((e, t), s)| (e - t) / s)
                .collect();
            obj.insert("truth".into(), json!(truth));
            obj.insert("error_over_sigma".into(), json!(z));
        }
    }
    v
}

/// Master message rate of a recording (Hz), from its messages' spacing.
pub fn master_rate_hz(rec: &Recording) -> f64 {
    match (rec.master.first(), rec.master.last()) {
        (Some(a), Some(b)) if rec.master.len() > 1 && b.t > a.t => {
            (rec.master.len() - 1) as f64 / (b.t - a.t)
        }
        _ => rec.meta.master_rate_hz,
    }
}

/// The `diagnosis.json` document.
pub fn diagnosis_json(d: &Diagnosis, rec_label: &str, rec: &Recording, command: &str) -> Value {
    let rate = master_rate_hz(rec);
    let truth = rec.truth.as_ref();
    let left: Vec<Structure> = structure(&d.after, d.options.alpha, rate)
        .into_iter()
        .filter(|s| s.rejected)
        .collect();
    json!({
        "tool_version": TOOL_VERSION,
        "recording": rec_label,
        "command": command,
        "effects_found": d
            .found
            .iter()
            .map(|t| found_json(t, truth))
            .chain(d.instabilities.iter().filter(|t| t.named).map(|t| instability_json(t, truth)))
            .collect::<Vec<_>>(),
        "process_noise": d.instabilities,
        "unexplained_structure": left,
        "noise_corrected": d.noise,
        "before": model_json(rec_label, rec, &d.before),
        "after": model_json(rec_label, rec, &d.after),
        "search": {
            "candidates": d.options.candidates.iter().map(|e| e.name()).collect::<Vec<_>>(),
            "budget": d.options.budget,
            "alpha": d.options.alpha,
            "tests": d.options.budget * d.options.candidates.len(),
            "rule": "a candidate is significant when the Wald statistic of its block and the likelihood ratio both exceed the chi-square(dof) quantile at alpha / tests; of the significant, the one whose likelihood ratio exceeds its threshold most, whose held-out likelihood ratio is positive and which does not grow the structure's size (predictable innovation variance) beyond its chance level, nor leave more than half of it where the structure dominates a channel axis (more than half its variance predictable), is added; where a significant runner-up's likelihood ratio over its threshold lies within the chi-square(1) threshold of the chosen one's, the whole model is learned again with each and the runner-up is adopted instead, on its model learned again, when that model predicts the held-out part better than the current one and than the chosen one's by more than that margin (or the chosen one's does not), its effect significant in it; a backward pass then drops an adopted effect whose likelihood ratio against the final set without it is at most its threshold or whose held-out likelihood ratio is not positive",
            "dropped": d.dropped,
            "rounds": rounds_json(d),
        },
        "supported_not_adopted": supported_not_adopted(d),
        "recommended_config": recommended_config(&d.after.cfg),
    })
}

/// The configuration keys the diagnosis changed or the steps before the filter found:
/// what a user's configuration needs to reproduce the final model. The clock shift, the
/// mounting, the master's attitude steps taken out and the process noises' densities
/// are there when they were used (absent keys: nothing found), so a run with the
/// recommended keys starts where the diagnosis did.
fn recommended_config(cfg: &crate::calib::config::CalibConfig) -> Value {
    let mut v = json!({
        "effects": cfg.effects,
        "initial_delay_s": cfg.initial_delay_s,
        "velocity_noise_mps": cfg.velocity_noise_mps,
        "attitude_noise_rad": cfg.attitude_noise_rad,
        "rate_noise_radps": cfg.rate_noise_radps,
    });
    if let Some(o) = v.as_object_mut() {
        if let Some(s) = cfg.master_clock_offset_s {
            o.insert("master_clock_offset_s".into(), json!(s));
        }
        if let Some(m) = cfg.mounting_estimate_rad {
            o.insert("mounting_estimate_rad".into(), json!(m));
        }
        if let Some(steps) = cfg.master_attitude_steps.as_ref().filter(|s| !s.is_empty()) {
            o.insert("master_attitude_steps".into(), json!(steps));
        }
        // The process noises the model carries (named by the diagnosis, or learned).
        for q in super::process_noise::Instability::ALL {
            let v = q.get(cfg);
            if v > 0.0 {
                o.insert(q.key().into(), json!(v));
            }
        }
    }
    v
}

/// What the search decided about candidate `t` of `round` and why, in one sentence:
/// which test a non-significant candidate failed; for a significant one, adopted, or
/// rejected by the held-out check or the explained-structure check, or ranked below
/// the adopted one. The same rules as `crate::diagnose::diagnose`, read back from the
/// statistics it recorded.
pub fn decision(t: &CandidateTest, round: &Round) -> String {
    if let Some(e) = &t.error {
        return format!("not tested: {e}");
    }
    if !t.significant {
        let mut why = Vec::new();
        if t.wald.is_nan() || t.wald <= t.threshold {
            why.push(format!("Wald {} ≤ {}", fmt_g(t.wald), fmt_g(t.threshold)));
        }
        if t.likelihood_ratio.is_nan() || t.likelihood_ratio <= t.threshold {
            why.push(format!(
                "likelihood ratio {} ≤ {}",
                fmt_g(t.likelihood_ratio),
                fmt_g(t.threshold)
            ));
        }
        if let Some(e) = Effect::from_name(t.effect) {
            if !t.above_floor {
                why.push(format!(
                    "estimate below its resolution floor {}",
                    fmt_g(e.resolution_floor())
                ));
            }
            if !t.plausible {
                why.push(format!(
                    "implausible: beyond {} prior σ ({})",
                    crate::diagnose::PLAUSIBLE_PRIORS,
                    fmt_g(crate::diagnose::PLAUSIBLE_PRIORS * e.default_prior_sigma())
                ));
            }
        }
        if let Some((g, thr)) = t.gain_over_delay.filter(|(g, thr)| g.is_nan() || g <= thr) {
            why.push(format!(
                "its likelihood over the delay's {} ≤ {}",
                fmt_g(g),
                fmt_g(thr)
            ));
        }
        if let Some((w, thr)) = t.rate_test.filter(|(w, thr)| w.is_nan() || w <= thr) {
            why.push(format!(
                "the drift's rate alone: Wald {} ≤ {}",
                fmt_g(w),
                fmt_g(thr)
            ));
        }
        return format!("not significant: {}", why.join("; "));
    }
    let relearned_adopted = round
        .relearned_candidate
        .as_ref()
        .filter(|c| c.effect == t.effect)
        .and_then(|c| c.relearned.as_ref())
        .is_some_and(|x| x.kept);
    if relearned_adopted && round.added == Some(t.effect) {
        return "adopted once the whole model was learned again with it (none adopted as the model stood)".into();
    }
    if let Some(x) = round.rivals.as_ref() {
        if x.rival.effect == t.effect && x.chosen == t.effect {
            return format!(
                "adopted over `{}`, which led it by less than {} in likelihood: {}",
                x.leader.effect,
                fmt_g(x.margin),
                rivals_outcome(x)
            );
        }
        if (x.leader.effect == t.effect || x.rival.effect == t.effect) && x.chosen != t.effect {
            return format!(
                "not adopted: it and `{}` explained the structure alike (within {} in likelihood): {}",
                x.chosen,
                fmt_g(x.margin),
                rivals_outcome(x)
            );
        }
    }
    if let Some(r) = &t.refit {
        let note = refit_note(r);
        let stands = r.significant && r.holdout_likelihood_ratio > 0.0;
        if round.added == Some(t.effect) {
            return if stands {
                format!("adopted once {note}")
            } else {
                format!("adopted: significant, predicts the held-out part better and does not grow the structure's size; {note}: not kept")
            };
        }
        if !r.significant {
            return format!("{note}: no longer significant");
        }
        return format!(
            "{note}: {}",
            rejection(r.holdout_likelihood_ratio, r.size_after, round)
        );
    }
    let unrefit = t
        .refit_error
        .as_ref()
        .map(|e| format!(" (the learned quantities that compete with it could not be learned again with it: {e})"))
        .unwrap_or_default();
    if round.added == Some(t.effect) {
        return format!("adopted: significant, predicts the held-out part better and does not grow the structure's size{unrefit}");
    }
    let why = rejection(
        t.holdout_likelihood_ratio.unwrap_or(f64::NAN),
        t.size_after,
        round,
    );
    format!("{why}{unrefit}")
}

/// What learning the competing quantities again with the candidate changed, in a clause:
/// the quantities that moved and the candidate's figures after.
fn refit_note(r: &crate::diagnose::RefitTest) -> String {
    let moved: Vec<String> = r
        .learned
        .values
        .iter()
        .filter(|v| v.value != v.start)
        .map(|v| format!("{} {} → {}", v.name, fmt_g(v.start), fmt_g(v.value)))
        .collect();
    format!(
        "the learned quantities that compete with it were learned again with it ({}; then Wald {}, likelihood ratio {}, held-out likelihood ratio {}, structure's size {})",
        if moved.is_empty() {
            "none moved".to_string()
        } else {
            moved.join(", ")
        },
        fmt_g(r.wald),
        fmt_g(r.likelihood_ratio),
        fmt_g(r.holdout_likelihood_ratio),
        fmt_g(r.size_after)
    )
}

/// Why a significant candidate that was not adopted lost, from its held-out likelihood
/// gain and the structure's size it leaves.
fn rejection(gain: f64, size_after: f64, round: &Round) -> String {
    if gain.is_nan() || gain <= 0.0 {
        return format!(
            "rejected: predicts the held-out part worse (held-out likelihood ratio {})",
            fmt_g(gain)
        );
    }
    if size_after.is_nan() || size_after > round.size + round.size_tolerance {
        return format!(
            "rejected: grows the structure's size from {} to {} (chance level {})",
            fmt_g(round.size),
            fmt_g(size_after),
            fmt_g(round.size_tolerance)
        );
    }
    let limit = crate::diagnose::EXPLAINED_FRACTION_LEFT * round.size;
    if round.dominated && size_after > limit {
        return format!(
            "rejected: the structure dominates a channel axis and it leaves {:.0}% of its size ({} of {}; at most {:.0}% allowed)",
            100.0 * size_after / round.size,
            fmt_g(size_after),
            fmt_g(round.size),
            100.0 * crate::diagnose::EXPLAINED_FRACTION_LEFT
        );
    }
    match round.added {
        Some(a) => format!("not adopted: `{a}` gains more likelihood over its threshold"),
        None => "not adopted".into(),
    }
}

/// Significant candidates of the last round that predict the held-out part better but
/// were not adopted, best likelihood gain first, with the configuration lines that would
/// carry each: what a reader may still want to try.
pub fn supported_not_adopted(d: &Diagnosis) -> Vec<Value> {
    let Some(round) = d.rounds.last() else {
        return Vec::new();
    };
    let mut v: Vec<&CandidateTest> = round
        .tests
        .iter()
        .filter(|t| {
            t.significant
                && round.added != Some(t.effect)
                && t.holdout_likelihood_ratio.is_some_and(|g| g > 0.0)
        })
        .collect();
    v.sort_by(|a, b| {
        (b.likelihood_ratio - b.threshold).total_cmp(&(a.likelihood_ratio - a.threshold))
    });
    v.into_iter()
        .map(|t| {
            let mut effects: Vec<&str> = d.after.cfg.effects.iter().map(String::as_str).collect();
            if t.effect == Effect::ClockDrift.name() {
                effects.retain(|e| *e != Effect::TimeDelay.name());
            }
            effects.push(t.effect);
            let mut cfg = json!({ "effects": effects });
            if Effect::from_name(t.effect).is_some_and(Effect::is_clock) {
                if let (Some(obj), Some(delay)) = (cfg.as_object_mut(), t.estimate.first()) {
                    obj.insert("initial_delay_s".into(), json!(delay));
                }
            }
            json!({
                "effect": t.effect,
                "estimate": t.estimate,
                "sigma": t.sigma,
                "holdout_likelihood_ratio": t.holdout_likelihood_ratio,
                "decision": decision(t, round),
                "config": cfg,
            })
        })
        .collect()
}

/// How judging two rivals on the whole model learned again with each came out, in a
/// clause: their held-out −2 ln L and whether it told them apart.
fn rivals_outcome(x: &crate::diagnose::Rivals) -> String {
    let figure = |c: &crate::diagnose::RelearnedCandidate| match c.relearned.as_ref() {
        Some(r) => format!(
            "{} (Wald {:.1}{})",
            fmt_g(r.holdout_relearned),
            r.wald,
            if r.kept { "" } else { ", not kept" }
        ),
        None => format!(
            "not learned: {}",
            c.error.as_deref().unwrap_or("no reason given")
        ),
    };
    let held_out =
        |c: &crate::diagnose::RelearnedCandidate| c.relearned.as_ref().map(|r| r.holdout_relearned);
    let by = match (held_out(&x.leader), held_out(&x.rival)) {
        (Some(a), Some(b)) => format!(" by {}", fmt_g((a - b).abs())),
        _ => String::new(),
    };
    let kept =
        |c: &crate::diagnose::RelearnedCandidate| c.relearned.as_ref().is_some_and(|r| r.kept);
    let verdict = if x.told_apart {
        format!("`{}` predicts it better{by}", x.chosen)
    } else if !kept(&x.leader) && !kept(&x.rival) {
        format!(
            "neither model learned again is kept (each predicts the held-out part worse than the current model, or its effect is not significant in it); `{}`, which led as the model stood, stays",
            x.chosen
        )
    } else {
        format!(
            "the recording does not tell them apart ({}within {}); `{}`, which led as the model stood, stays",
            if by.is_empty() { String::new() } else { format!("they differ{by}, ") },
            fmt_g(x.margin),
            x.chosen
        )
    };
    format!(
        "learned again with each, held-out -2 ln L with `{}` {}, with `{}` {}: {verdict}",
        x.leader.effect,
        figure(&x.leader),
        x.rival.effect,
        figure(&x.rival)
    )
}

/// What judging a round's two rivals did (`Round::rivals`), in one sentence; `None`
/// when the round had none.
pub fn rivals_line(r: &Round) -> Option<String> {
    let x = r.rivals.as_ref()?;
    Some(format!(
        "`{}` and `{}` explained the structure alike as the model stood (within {} in likelihood); {}",
        x.leader.effect,
        x.rival.effect,
        fmt_g(x.margin),
        rivals_outcome(x)
    ))
}

/// What a round's relearn (`Round::relearned`, or `Round::relearned_candidate`) did, in
/// one sentence; `None` when the model was not learned again in the round.
pub fn relearn_line(r: &Round) -> Option<String> {
    if let Some(c) = r.relearned_candidate.as_ref() {
        return Some(relearned_candidate_line(c));
    }
    let added = r.added?;
    if let Some(why) = r.not_relearned.as_ref() {
        return Some(format!(
            "the whole model not learned again with {added}: {why}"
        ));
    }
    let x = r.relearned.as_ref()?;
    Some(format!(
        "the whole model learned again with {added} ({:.1} s, {} filter runs): held-out -2 ln L {} as adopted, {} learned again; Wald {:.1}; {}",
        x.seconds,
        x.evaluations,
        fmt_g(x.holdout_replaced),
        fmt_g(x.holdout_relearned),
        x.wald,
        if x.kept {
            "kept (predicts the held-out part better, the effect still significant)"
        } else {
            "not kept, the model as adopted stays"
        }
    ))
}

/// What judging a candidate on the whole model learned again with it did, in one sentence.
fn relearned_candidate_line(c: &crate::diagnose::RelearnedCandidate) -> String {
    let effect = c.effect;
    let Some(x) = c.relearned.as_ref() else {
        return format!(
            "none adopted as the model stood; the whole model could not be learned again with {effect}: {}",
            c.error.as_deref().unwrap_or("no reason given")
        );
    };
    format!(
        "none adopted as the model stood; the whole model learned again with {effect} ({:.1} s, {} filter runs), judged with a master delay of {:.1} ms: held-out -2 ln L {} without it, {} learned again with it; Wald {:.1}, likelihood ratio {:.1}; {}",
        x.seconds,
        x.evaluations,
        x.delay_judged_s * 1e3,
        fmt_g(x.holdout_replaced),
        fmt_g(x.holdout_relearned),
        x.wald,
        x.likelihood_ratio,
        if x.kept {
            "adopted (predicts the held-out part better, significant)"
        } else {
            "not adopted"
        }
    )
}

/// The search rounds as recorded, each test with its `decision`.
fn rounds_json(d: &Diagnosis) -> Value {
    let mut v = serde_json::to_value(&d.rounds).unwrap_or(Value::Null);
    if let Some(rounds) = v.as_array_mut() {
        for (rv, r) in rounds.iter_mut().zip(&d.rounds) {
            if let Some(tests) = rv.get_mut("tests").and_then(Value::as_array_mut) {
                for (tv, t) in tests.iter_mut().zip(&r.tests) {
                    if let Some(obj) = tv.as_object_mut() {
                        obj.insert("decision".into(), json!(decision(t, r)));
                    }
                }
            }
        }
    }
    v
}

/// A per-axis value, `x, y, z` in `fmt_g`'s form.
fn fmt_axes(v: &[f64; 3]) -> String {
    v.map(fmt_g).join(", ")
}

fn fmt_g(v: f64) -> String {
    if !v.is_finite() {
        return format!("{v}");
    }
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if (1e-3..1e5).contains(&a) {
        format!("{v:.4}")
    } else {
        format!("{v:.3e}")
    }
}

fn fmt_vec(v: &[f64]) -> String {
    let parts: Vec<String> = v.iter().map(|x| fmt_g(*x)).collect();
    format!("[{}]", parts.join(", "))
}

/// `report.md`.
pub fn report_md(d: &Diagnosis, rec_label: &str, rec: &Recording, command: &str) -> String {
    let mut s = String::new();
    let rate = master_rate_hz(rec);
    let _ = writeln!(s, "# Diagnosis of `{rec_label}`\n");
    let _ = writeln!(s, "Command: `{command}`\n");
    let _ = writeln!(
        s,
        "Rule: a candidate is significant when the Wald statistic of its block and the drop of the innovations' −2 log-likelihood both exceed the χ²(k) quantile at α / (budget × candidates) = {} / ({} × {}); of the significant, the one with the largest likelihood gain over its threshold that also predicts the held-out part of the recording better is added (`docs/diagnosis.md`).\n",
        d.options.alpha,
        d.options.budget,
        d.options.candidates.len()
    );
    if !d.noise.is_empty() {
        let _ = writeln!(
            s,
            "## Measurement noise corrected first\n\nThe declared noise was too large (NIS below its band, which no missing effect can cause, and which hides effects from every test); scaled by √NIS before the search:\n\n| key | declared | corrected | NIS with declared |\n|---|---|---|---|"
        );
        for c in &d.noise {
            let _ = writeln!(
                s,
                "| `{}` | {} | {} | {} |",
                c.key,
                fmt_axes(&c.declared),
                fmt_axes(&c.corrected),
                fmt_g(c.declared_nis)
            );
        }
        let _ = writeln!(s);
    }
    let _ = writeln!(s, "## Effects found\n");
    let significant = d
        .rounds
        .iter()
        .flat_map(|r| &r.tests)
        .filter(|t| t.significant)
        .count();
    if d.found.is_empty() && significant == 0 {
        let _ = writeln!(s, "None: no candidate is significant.\n");
    } else if d.found.is_empty() {
        let _ = writeln!(
            s,
            "None adopted: {significant} candidate(s) are significant, and each was rejected for the reason given in its row of the search below.\n"
        );
    } else {
        let _ = writeln!(
            s,
            "| effect | estimate | σ | unit | Wald | likelihood ratio | threshold | truth | (est − truth)/σ |\n|---|---|---|---|---|---|---|---|---|"
        );
        for t in &d.found {
            let e = Effect::from_name(t.effect);
            let truth = e.and_then(|e| rec.truth.as_ref().and_then(|tr| effect_truth(e, tr)));
            let z: Option<Vec<f64>> = truth.as_ref().map(|tr| {
                t.estimate
                    .iter()
                    .zip(tr)
                    .zip(&t.sigma)
                    .map(|((e, t), s)| (e - t) / s)
                    .collect()
            });
            let _ = writeln!(
                s,
                "| `{}` | {} | {} | {} | {} | {} | {} | {} | {} |",
                t.effect,
                fmt_vec(&t.estimate),
                fmt_vec(&t.sigma),
                e.map_or("", |e| e.unit()),
                fmt_g(t.wald),
                fmt_g(t.likelihood_ratio),
                fmt_g(t.threshold),
                truth.as_deref().map_or("–".into(), fmt_vec),
                z.as_deref().map_or("–".into(), fmt_vec),
            );
        }
        let _ = writeln!(s);
    }
    let _ = writeln!(
        s,
        "## Process noise\n\nEach random walk's density searched on the whole recording with the final model, tested against none by its likelihood ratio (threshold: the χ²(1) quantile at twice a block's level, zero being on the boundary), named when, estimated on the first part alone, it also predicts the rest's innovations better by the same threshold (the filter running over the whole recording):\n"
    );
    for t in &d.instabilities {
        let _ = writeln!(s, "- {}", instability_line(t, rec.truth.as_ref()));
    }
    let _ = writeln!(s);
    let supported = supported_not_adopted(d);
    if !supported.is_empty() {
        let _ = writeln!(
            s,
            "## Supported by the held-out check, not adopted\n\nThese significant candidates predict the held-out part better but were not adopted (the decision says why); to carry one anyway, add its configuration lines:\n\n| effect | estimate ± σ | held-out likelihood ratio | configuration |\n|---|---|---|---|"
        );
        for v in &supported {
            let nums = |k: &str| -> Vec<f64> {
                v[k].as_array()
                    .map(|a| a.iter().filter_map(Value::as_f64).collect())
                    .unwrap_or_default()
            };
            let cfg = v["config"]
                .as_object()
                .map(|o| {
                    o.iter()
                        .map(|(k, x)| format!("`{k} = {x}`"))
                        .collect::<Vec<_>>()
                        .join(", ")
                })
                .unwrap_or_default();
            let _ = writeln!(
                s,
                "| `{}` | {} ± {} | {} | {cfg} |",
                v["effect"].as_str().unwrap_or("?"),
                fmt_vec(&nums("estimate")),
                fmt_vec(&nums("sigma")),
                v["holdout_likelihood_ratio"]
                    .as_f64()
                    .map_or("–".into(), fmt_g)
            );
        }
        let _ = writeln!(s);
    }
    let _ = writeln!(s, "## Search\n");
    for (k, r) in d.rounds.iter().enumerate() {
        let _ = writeln!(
            s,
            "Round {} (model: declared{}): {}\n",
            k + 1,
            r.model
                .iter()
                .map(|m| format!(" + `{m}`"))
                .collect::<String>(),
            match (r.added, r.tests.iter().filter(|t| t.significant).count()) {
                (Some(a), _) => format!("adds `{a}`"),
                (None, 0) => "nothing significant".to_string(),
                (None, n) => format!("{n} significant, none adopted (decisions below)"),
            }
        );
        let _ = writeln!(
            s,
            "Structure's size of this round's model (predictable innovation variance beyond chance, summed over the channel axes): {} (chance level {}).\n\n| candidate | k | estimate ± σ | Wald | likelihood ratio | threshold | size with it | held-out likelihood ratio | decision |\n|---|---|---|---|---|---|---|---|---|",
            fmt_g(r.size),
            fmt_g(r.size_tolerance)
        );
        for t in &r.tests {
            let _ = writeln!(
                s,
                "| `{}` | {} | {} ± {} | {} | {} | {} | {} | {} | {} |",
                t.effect,
                t.dof,
                fmt_vec(&t.estimate),
                fmt_vec(&t.sigma),
                fmt_g(t.wald),
                fmt_g(t.likelihood_ratio),
                fmt_g(t.threshold),
                fmt_g(t.size_after),
                t.holdout_likelihood_ratio.map_or("–".to_string(), fmt_g),
                decision(t, r)
            );
        }
        if let Some(line) = rivals_line(r) {
            let _ = writeln!(s, "\nThen {line}.");
        }
        if let Some(line) = relearn_line(r) {
            let _ = writeln!(s, "\nThen {line}.");
        }
        let _ = writeln!(s);
    }
    if !d.dropped.is_empty() {
        let _ = writeln!(
            s,
            "Backward pass: dropped from the final set, where it no longer earns its place:\n\n| effect | likelihood ratio against the set without it | threshold | held-out likelihood ratio |\n|---|---|---|---|"
        );
        for x in &d.dropped {
            let _ = writeln!(
                s,
                "| `{}` | {} | {} | {} |",
                x.effect,
                fmt_g(x.likelihood_ratio),
                fmt_g(x.threshold),
                fmt_g(x.holdout_likelihood_ratio)
            );
        }
        let _ = writeln!(s);
    }
    let _ = writeln!(s, "## Before and after\n");
    let _ = writeln!(s, "| | before (declared) | after |\n|---|---|---|");
    let effects = |m: &ModelEval| {
        let e = m.effects();
        if e.is_empty() {
            "declared".to_string()
        } else {
            format!(
                "declared + {}",
                e.iter().map(|e| e.name()).collect::<Vec<_>>().join(" + ")
            )
        }
    };
    let _ = writeln!(
        s,
        "| model | {} | {} |",
        effects(&d.before),
        effects(&d.after)
    );
    let _ = writeln!(
        s,
        "| NIS mean | {} | {} |",
        fmt_g(d.before.result.nis_mean()),
        fmt_g(d.after.result.nis_mean())
    );
    let hold_nis = |m: &ModelEval| m.holdout.as_ref().map_or(f64::NAN, |h| h.nis_mean);
    let _ = writeln!(
        s,
        "| held-out NIS mean | {} | {} |",
        fmt_g(hold_nis(&d.before)),
        fmt_g(hold_nis(&d.after))
    );
    for (b, a) in d.before.residuals.iter().zip(&d.after.residuals) {
        let _ = writeln!(
            s,
            "| {} {} whiteness p / NIS | {} / {} | {} / {} |",
            b.channel,
            ["x", "y", "z"][b.axis.min(2)],
            fmt_g(b.whiteness_p),
            fmt_g(b.nis_mean),
            fmt_g(a.whiteness_p),
            fmt_g(a.nis_mean)
        );
    }
    if let (Some(hb), Some(ha)) = (&d.before.holdout, &d.after.holdout) {
        for (b, a) in hb.channels.iter().zip(&ha.channels) {
            let _ = writeln!(
                s,
                "| {} {} held-out RMS | {} | {} |",
                b.channel,
                ["x", "y", "z"][b.axis.min(2)],
                fmt_g(b.rms),
                fmt_g(a.rms)
            );
        }
    }
    if let Some(tr) = rec.truth.as_ref() {
        let (sb, sa) = (score(&d.before.result, tr), score(&d.after.result, tr));
        if let (Some(b), Some(a)) = (sb, sa) {
            let dph = 180.0 / std::f64::consts::PI * 3600.0;
            let mg = 1.0 / 9.806_65e-3;
            let am = 180.0 / std::f64::consts::PI * 60.0;
            let _ = writeln!(
                s,
                "| gyro bias error (deg/h) | {} | {} |",
                fmt_vec(&b.gyro_bias.map(|v| v * dph)),
                fmt_vec(&a.gyro_bias.map(|v| v * dph))
            );
            let _ = writeln!(
                s,
                "| accel bias error (mg) | {} | {} |",
                fmt_vec(&b.accel_bias.map(|v| v * mg)),
                fmt_vec(&a.accel_bias.map(|v| v * mg))
            );
            let _ = writeln!(
                s,
                "| misalignment error (arcmin) | {} | {} |",
                fmt_vec(&b.misalignment.map(|v| v * am)),
                fmt_vec(&a.misalignment.map(|v| v * am))
            );
            let _ = writeln!(
                s,
                "| NEES (9 states) | {} | {} |",
                fmt_g(b.nees_mean),
                fmt_g(a.nees_mean)
            );
        }
    }
    let _ = writeln!(s, "\n## Structure left unexplained\n");
    let left: Vec<Structure> = structure(&d.after, d.options.alpha, rate)
        .into_iter()
        .filter(|s| s.rejected)
        .collect();
    if left.is_empty() {
        let _ = writeln!(
            s,
            "None: every channel's NIS is inside its band and its innovations are white at the family-wise level α = {}.",
            d.options.alpha
        );
    } else {
        let _ = writeln!(
            s,
            "No candidate explains what follows (it is reported, not forced onto the nearest effect), largest first by its size — the innovation variance predictable from the innovations' own past beyond chance, in units of the predicted variance:\n\n| channel | size | predictable share | NIS | band | whiteness p | spectral peak (Hz) | peak / white level |\n|---|---|---|---|---|---|---|---|"
        );
        for l in &left {
            let _ = writeln!(
                s,
                "| {} {} | {} | {} | {} | [{}, {}] | {} | {} | {} |",
                l.channel,
                ["x", "y", "z"][l.axis.min(2)],
                fmt_g(l.size),
                fmt_g(l.predictable_share),
                fmt_g(l.nis_mean),
                fmt_g(l.nis_band[0]),
                fmt_g(l.nis_band[1]),
                fmt_g(l.whiteness_p),
                fmt_g(l.peak_hz),
                fmt_g(l.peak_level)
            );
        }
    }
    let _ = writeln!(
        s,
        "\n## Plots\n\n![residuals](residuals.svg)\n\n![spectra](spectra.svg)\n\n![autocorrelation](autocorrelation.svg)\n"
    );
    if !d.found.is_empty() {
        let _ = writeln!(s, "![effects](effects.svg)\n");
    }
    s
}

/// One-second RMS of a whitened sequence.
fn moving_rms(t: &[f64], w: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let (mut xs, mut ys) = (Vec::new(), Vec::new());
    let (mut start, mut acc, mut n) = (t.first().copied().unwrap_or(0.0), 0.0, 0usize);
    for (ti, wi) in t.iter().zip(w) {
        if ti - start >= 1.0 && n > 0 {
            xs.push(start + 0.5);
            ys.push((acc / n as f64).sqrt());
            start = *ti;
            acc = 0.0;
            n = 0;
        }
        acc += wi * wi;
        n += 1;
    }
    (xs, ys)
}

/// Writes `residuals.svg`, `spectra.svg`, `autocorrelation.svg` and `effects.svg`.
pub fn write_plots(dir: &Path, d: &Diagnosis, rec: &Recording) -> std::io::Result<()> {
    let rate = master_rate_hz(rec);
    let axes = ["x", "y", "z"];
    let models = [("before", &d.before), ("after", &d.after)];
    // Residuals: 1 s RMS of the whitened innovations.
    let mut panels = Vec::new();
    for (c, ch) in CHANNELS.iter().enumerate() {
        for (label, m) in models {
            let series: Vec<Series> = (0..3)
                .filter_map(|a| {
                    let (t, w) = whitened(&m.result.innovations, c, a);
                    (!w.is_empty()).then(|| {
                        let (x, y) = moving_rms(&t, &w);
                        Series {
                            name: axes[a].into(),
                            x,
                            y,
                        }
                    })
                })
                .collect();
            if series.is_empty() {
                continue;
            }
            let x = series[0].x.clone();
            panels.push(Panel {
                title: format!("{ch}, {label}"),
                y_label: "RMS of ν/√s".into(),
                dashed: vec![Series {
                    name: "1".into(),
                    y: vec![1.0; x.len()],
                    x,
                }],
                series,
                bands: vec![],
            });
        }
    }
    Figure {
        title: "Whitened innovations, 1 s RMS".into(),
        x_label: "t (s)".into(),
        panels,
    }
    .write(&dir.join("residuals.svg"))?;
    // Spectra and autocorrelations, averaged over the axes.
    let mut spec_panels = Vec::new();
    let mut acf_panels = Vec::new();
    for (c, ch) in CHANNELS.iter().enumerate() {
        let mut spec = Vec::new();
        let mut acfs = Vec::new();
        let mut n_min = usize::MAX;
        for (label, m) in models {
            let mut sum: Vec<f64> = Vec::new();
            let mut freq = Vec::new();
            let mut acf_sum: Vec<f64> = Vec::new();
            let mut k = 0;
            for a in 0..3 {
                let (_, w) = whitened(&m.result.innovations, c, a);
                let p = welch(&w, rate);
                if p.level.is_empty() {
                    continue;
                }
                n_min = n_min.min(w.len());
                let r = autocorrelation(&w, ACF_LAGS);
                if sum.is_empty() {
                    sum = vec![0.0; p.level.len()];
                    acf_sum = vec![0.0; r.len()];
                    freq = p.freq_hz.clone();
                }
                sum.iter_mut().zip(&p.level).for_each(|(s, l)| *s += l);
                acf_sum.iter_mut().zip(&r).for_each(|(s, l)| *s += l);
                k += 1;
            }
            if k == 0 {
                continue;
            }
            spec.push(Series {
                name: label.into(),
                x: freq.iter().skip(1).copied().collect(),
                y: sum
                    .iter()
                    .skip(1)
                    .map(|s| 10.0 * (s / k as f64).log10())
                    .collect(),
            });
            acfs.push(Series {
                name: label.into(),
                x: (1..acf_sum.len()).map(|l| l as f64 / rate).collect(),
                y: acf_sum.iter().skip(1).map(|s| s / k as f64).collect(),
            });
        }
        if spec.is_empty() {
            continue;
        }
        spec_panels.push(Panel {
            title: ch.to_string(),
            y_label: "dB over white".into(),
            series: spec,
            bands: vec![],
            dashed: vec![],
        });
        let bound = 1.96 / (n_min as f64).sqrt();
        let lag_x: Vec<f64> = acfs.first().map(|s| s.x.clone()).unwrap_or_default();
        acf_panels.push(Panel {
            title: ch.to_string(),
            y_label: "autocorrelation".into(),
            series: acfs,
            bands: vec![Band {
                name: "±1.96/√n (white)".into(),
                lo: vec![-bound; lag_x.len()],
                hi: vec![bound; lag_x.len()],
                x: lag_x,
            }],
            dashed: vec![],
        });
    }
    Figure {
        title: "Spectra of the whitened innovations (axis mean, Welch)".into(),
        x_label: "frequency (Hz)".into(),
        panels: spec_panels,
    }
    .write(&dir.join("spectra.svg"))?;
    Figure {
        title: "Autocorrelation of the whitened innovations (axis mean)".into(),
        x_label: "lag (s)".into(),
        panels: acf_panels,
    }
    .write(&dir.join("autocorrelation.svg"))?;
    // The added effects' estimates with ±3σ, from the final model's run.
    if !d.found.is_empty() {
        let mut panels = Vec::new();
        for e in d.after.effects() {
            let rows: Vec<_> = d
                .after
                .result
                .effect_rows
                .iter()
                .filter(|r| r.effect == e)
                .collect();
            let t: Vec<f64> = rows.iter().map(|r| r.t).collect();
            let truth = rec.truth.as_ref().and_then(|tr| effect_truth(e, tr));
            for k in 0..e.states() {
                let y: Vec<f64> = rows.iter().map(|r| r.value[k]).collect();
                let s: Vec<f64> = rows.iter().map(|r| r.sigma[k]).collect();
                panels.push(Panel {
                    title: format!("{} [{k}]", e.name()),
                    y_label: e.unit().into(),
                    bands: vec![Band {
                        name: "±3σ".into(),
                        x: t.clone(),
                        lo: y.iter().zip(&s).map(|(v, s)| v - 3.0 * s).collect(),
                        hi: y.iter().zip(&s).map(|(v, s)| v + 3.0 * s).collect(),
                    }],
                    dashed: truth
                        .as_ref()
                        .map(|tr| {
                            vec![Series {
                                name: "truth".into(),
                                x: t.clone(),
                                y: vec![tr[k]; t.len()],
                            }]
                        })
                        .unwrap_or_default(),
                    series: vec![Series {
                        name: "estimate".into(),
                        x: t.clone(),
                        y,
                    }],
                });
            }
        }
        Figure {
            title: "Estimates of the added effects".into(),
            x_label: "t (s)".into(),
            panels,
        }
        .write(&dir.join("effects.svg"))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::recommended_config;
    use crate::calib::config::CalibConfig;

    #[test]
    fn the_recommended_keys_carry_the_clock_shift_the_mounting_and_the_steps_when_used() {
        let mut cfg = CalibConfig {
            master_attitude_steps: Some(Vec::new()),
            ..CalibConfig::default()
        };
        let none = recommended_config(&cfg);
        assert!(none.get("master_clock_offset_s").is_none());
        assert!(none.get("mounting_estimate_rad").is_none());
        assert!(none.get("master_attitude_steps").is_none());
        cfg.master_clock_offset_s = Some(-0.4);
        cfg.mounting_estimate_rad = Some([0.0, 0.0, std::f64::consts::FRAC_PI_2]);
        cfg.master_attitude_steps = Some(vec![[31.5, 0.1, -0.05, 0.02]]);
        let used = recommended_config(&cfg);
        assert_eq!(used["master_attitude_steps"][0][0], 31.5);
        assert_eq!(used["master_clock_offset_s"], -0.4);
        assert_eq!(
            used["mounting_estimate_rad"][2],
            std::f64::consts::FRAC_PI_2
        );
    }
}
