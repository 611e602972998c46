//! `flexcal montecarlo --blind`: every seed draws its own scenario
//! (`crate::sim::blind`), and the filter is told nothing about it. Each recording is
//! calibrated twice: with the model learned from it (`crate::learn`, started from the
//! built-in default exactly as `calibrate` does with no configuration), and with the
//! built-in default itself. Both are scored against the truth (NEES, RMS/σ, per-channel
//! NIS in its band), and the learned quantities against the values drawn
//! (`crate::learn::truth`). The verdict (PASS/WARN/FAIL, `crate::verdict::ensemble`)
//! judges the learned arm: what a user with no configuration gets.

use super::montecarlo::{
    aggregate, ensemble_verdict, ratio_figure, score_run, Aggregate, Args, RunResult, NAMES,
};
use crate::calib::residuals::channel_residuals;
use crate::cmd::TOOL_VERSION;
use crate::learn::params::ModelParams;
use crate::learn::truth::{median_by_kind, param_errors, ParamError, IDENTIFIABLE_RELATIVE_SIGMA};
use crate::learn::{default_start, learn, start_from_nothing, LearnOptions};
use crate::sim::{blind, simulate};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rayon::prelude::*;
use serde_json::{json, Value};

/// One blind seed, calibrated with the learned model and with the built-in default.
#[derive(Clone, Debug)]
pub struct BlindRun {
    /// Seed (of the draw and of the simulation).
    pub seed: u64,
    /// With the learned model.
    pub learned: RunResult,
    /// With the built-in default.
    pub default: RunResult,
    /// Per channel axis: the NIS mean with the learned model and with the default.
    pub nis: Vec<ChannelNis>,
    /// What the master's errors were drawn as: `none`, `white` or `smooth`.
    pub master_kind: &'static str,
    /// The learned quantities against the draw.
    pub params: Vec<ParamError>,
    /// Whether the learned model passed its held-out check (else the start was kept).
    pub adopted: bool,
    /// Wall time of the learning (s).
    pub learn_seconds: f64,
}

/// One channel axis's mean NIS in a blind run, each with its 95 % band (kept as values,
/// so that a run outside its band shows by how much).
#[derive(Clone, Debug)]
pub struct ChannelNis {
    /// `channel/axis`.
    pub name: String,
    /// With the learned model: mean NIS and band.
    pub learned: (f64, [f64; 2]),
    /// With the built-in default (none when its run has no such axis).
    pub default: Option<(f64, [f64; 2])>,
}

fn inside((m, b): (f64, [f64; 2])) -> bool {
    m >= b[0] && m <= b[1]
}

/// Runs one blind seed.
pub fn blind_run(a: &Args, seed: u64) -> Result<BlindRun, String> {
    let sc = a.scenario.load_for_seed(seed)?;
    let rec = simulate(&sc, seed).recording;
    let (mut start, inc) = start_from_nothing(&rec);
    a.model.apply(&mut start)?;
    let l = learn(
        &rec,
        &start,
        "built-in default",
        inc.ok(),
        &LearnOptions::default(),
    )
    .map_err(|e| format!("seed {seed}: learning: {e}"))?;
    let (learned, learned_res) = score_run(&rec, &l.config, seed, a.precision)?;
    let mut built_in = default_start(&rec, None);
    a.model.apply(&mut built_in)?;
    let (default, default_res) = score_run(&rec, &built_in, seed, a.precision)?;
    let with_default = channel_residuals(&default_res.innovations);
    let nis = channel_residuals(&learned_res.innovations)
        .into_iter()
        .map(|c| ChannelNis {
            name: format!("{}/{}", c.channel, c.axis),
            learned: (c.nis_mean, c.nis_band),
            default: with_default
                .iter()
                .find(|d| d.channel == c.channel && d.axis == c.axis)
                .map(|d| (d.nis_mean, d.nis_band)),
        })
        .collect();
    let master_kind = match (&sc.master.smooth_error, sc.master.velocity_noise_mps > 0.0) {
        (Some(_), _) => "smooth",
        (None, true) => "white",
        (None, false) => "none",
    };
    Ok(BlindRun {
        seed,
        learned,
        default,
        nis,
        master_kind,
        params: param_errors(&ModelParams::from_config(&l.learned_config), &l.values, &sc),
        adopted: l.adopted,
        learn_seconds: l.seconds,
    })
}

/// Per channel axis: the fraction of runs whose NIS is in its band (learned, default).
pub fn nis_fractions(runs: &[BlindRun]) -> Vec<(String, f64, f64)> {
    let mut names: Vec<String> = Vec::new();
    for c in runs.iter().flat_map(|r| &r.nis) {
        if !names.contains(&c.name) {
            names.push(c.name.clone());
        }
    }
    names
        .into_iter()
        .map(|n| {
            let of = |in_band: fn(&ChannelNis) -> bool| {
                let v: Vec<bool> = runs
                    .iter()
                    .filter_map(|r| r.nis.iter().find(|c| c.name == n).map(in_band))
                    .collect();
                v.iter().filter(|b| **b).count() as f64 / v.len().max(1) as f64
            };
            let learned = of(|c| inside(c.learned));
            let default = of(|c| c.default.is_some_and(inside));
            (n, learned, default)
        })
        .collect()
}

fn arm_json(agg: &Aggregate, runs: &[RunResult], nis: Vec<(String, f64)>) -> Value {
    let states: Vec<_> = (0..9)
        .map(|i| json!({ "state": NAMES[i], "rms_error": agg.rms[i], "mean_sigma": agg.mean_sigma[i], "ratio": agg.normalized_rms[i] }))
        .collect();
    json!({
        "states": states,
        "nees": { "mean": agg.nees_mean, "band_95": agg.nees_band, "dof_per_run": 9,
                  "inside": agg.nees_mean >= agg.nees_band[0] && agg.nees_mean <= agg.nees_band[1] },
        "nis_mean": runs.iter().map(|r| r.nis).sum::<f64>() / runs.len().max(1) as f64,
        "nis_in_band_fraction": nis.into_iter().map(|(c, f)| json!({"channel": c, "fraction": f})).collect::<Vec<_>>(),
    })
}

/// Runs `flexcal montecarlo --blind`.
pub fn run(a: &Args) -> Result<(), String> {
    let bar = ProgressBar::new(a.runs as u64);
    if std::env::var_os("CI").is_some() {
        bar.set_draw_target(ProgressDrawTarget::hidden());
    }
    bar.set_style(
        ProgressStyle::with_template(
            "{bar:40} {pos}/{len} blind runs, {elapsed} elapsed, ETA {eta}",
        )
        .map_err(|e| e.to_string())?,
    );
    let results: Result<Vec<BlindRun>, String> = (0..a.runs as u64)
        .into_par_iter()
        .map(|i| {
            let r = blind_run(a, a.scenario.seed + i);
            bar.inc(1);
            r
        })
        .collect();
    bar.finish_and_clear();
    let runs = results?;
    let learned: Vec<RunResult> = runs.iter().map(|r| r.learned).collect();
    let default: Vec<RunResult> = runs.iter().map(|r| r.default).collect();
    let (agg_l, agg_d) = (aggregate(&learned), aggregate(&default));
    let nis = nis_fractions(&runs);
    let all_params: Vec<ParamError> = runs.iter().flat_map(|r| r.params.clone()).collect();
    let medians = median_by_kind(&all_params);
    let duration = a
        .scenario
        .duration
        .unwrap_or(crate::cmd::common::BLIND_DURATION_S);
    std::fs::create_dir_all(&a.out).map_err(|e| format!("{}: {e}", a.out.display()))?;
    let doc = json!({
        "tool_version": TOOL_VERSION,
        "scenario": "blind",
        "effect": (!a.scenario.effect.is_empty()).then(|| {
            a.scenario.effect.iter().map(|e| blind::effect_name(*e)).collect::<Vec<_>>().join("+")
        }),
        "ranges": blind::RANGES,
        "runs": runs.len(),
        "first_seed": a.scenario.seed,
        "duration_s": duration,
        "precision": a.precision,
        "learned": arm_json(&agg_l, &learned, nis.iter().map(|(c, l, _)| (c.clone(), *l)).collect()),
        "default": arm_json(&agg_d, &default, nis.iter().map(|(c, _, d)| (c.clone(), *d)).collect()),
        "learned_adopted_runs": runs.iter().filter(|r| r.adopted).count(),
        "learn_seconds_mean": runs.iter().map(|r| r.learn_seconds).sum::<f64>() / runs.len().max(1) as f64,
        "parameters": medians,
        "per_run": runs.iter().map(|r| json!({
            "seed": r.seed, "adopted": r.adopted, "master": r.master_kind,
            "nis": r.nis.iter().map(|c| json!({"channel": c.name, "learned": c.learned.0, "default": c.default.map(|d| d.0), "band": c.learned.1})).collect::<Vec<_>>(),
            "learned": {"nees": r.learned.nees, "nis_mean": r.learned.nis, "error": r.learned.error, "sigma": r.learned.sigma},
            "default": {"nees": r.default.nees, "nis_mean": r.default.nis, "error": r.default.error, "sigma": r.default.sigma},
            "parameters": r.params,
        })).collect::<Vec<_>>(),
    });
    // The verdict judges the learned model (what a user with no configuration gets).
    let verdict = ensemble_verdict(&learned, &agg_l);
    let mut doc = doc;
    verdict.insert_into(&mut doc);
    super::common::write_json(&a.out.join("montecarlo.json"), &doc)?;
    ratio_figure("blind, learned model", &agg_l, runs.len())
        .write(&a.out.join("rms_over_sigma_learned.svg"))
        .map_err(|e| e.to_string())?;
    ratio_figure("blind, built-in default", &agg_d, runs.len())
        .write(&a.out.join("rms_over_sigma_default.svg"))
        .map_err(|e| e.to_string())?;
    println!(
        "Blind Monte Carlo: {} runs of {duration} s ({:?}), each scenario drawn from its seed; the filter told nothing",
        runs.len(),
        a.precision
    );
    println!(
        "  learned model adopted (held-out check) in {} of {} runs; learning took {:.1} s per run on average",
        runs.iter().filter(|r| r.adopted).count(),
        runs.len(),
        runs.iter().map(|r| r.learn_seconds).sum::<f64>() / runs.len() as f64
    );
    println!("  state   RMS/σ learned   RMS/σ built-in default");
    for (i, name) in NAMES.iter().enumerate() {
        println!(
            "  {name:5}   {:8.3}        {:8.3}",
            agg_l.normalized_rms[i], agg_d.normalized_rms[i]
        );
    }
    for (name, agg) in [("learned", &agg_l), ("built-in default", &agg_d)] {
        println!(
            "  mean NEES, {name}: {:.3} (95% band [{:.3}, {:.3}])",
            agg.nees_mean, agg.nees_band[0], agg.nees_band[1]
        );
    }
    println!("  channel          NIS in band: learned   built-in default");
    for (c, l, d) in &nis {
        println!("  {c:16} {:>20.0}%   {:>10.0}%", 100.0 * l, 100.0 * d);
    }
    println!(
        "  learned vs drawn: median |relative error| (all; where the learner's own σ is within {:.0}%)",
        100.0 * IDENTIFIABLE_RELATIVE_SIGMA
    );
    for m in &medians {
        println!(
            "  {:32} {:6.1}% of {:3}   {:6.1}% of {:3}",
            m.quantity,
            100.0 * m.median,
            m.count,
            100.0 * m.median_resolved,
            m.count_resolved
        );
    }
    verdict.conclude()
}
