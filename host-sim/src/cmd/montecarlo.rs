//! `flexcal montecarlo`: many seeds of one scenario, calibrated with the model the
//! scenario declares; RMS final errors against the filter's mean σ, and the mean
//! NEES of the 9 calibrated states against its 95% χ² band.
//!
//! With `--blind` each seed draws its own scenario (`crate::sim::blind`) and the filter
//! is told nothing: the model is learned from each recording (`crate::learn`), and the
//! same recordings are calibrated with the built-in default for comparison
//! (`super::montecarlo_blind`).

use crate::calib::config::CalibConfig;
use crate::calib::run::{run as calibrate, Precision};
use crate::calib::score::score;
use crate::cmd::common::{ModelArgs, ScenarioArgs};
use crate::cmd::TOOL_VERSION;
use crate::plot::{Band, Figure, Panel, Series};
use crate::sim::{simulate, Scenario};
use flexcal_core::stats::chi2_quantile;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use serde_json::json;
use std::path::PathBuf;

/// Arguments of `flexcal montecarlo`.
#[derive(clap::Args)]
pub struct Args {
    /// Scenario, duration, first seed.
    #[command(flatten)]
    pub scenario: ScenarioArgs,
    /// Number of runs (seeds `seed .. seed + runs`).
    #[arg(long, default_value_t = 50)]
    pub runs: usize,
    /// Output directory.
    #[arg(long)]
    pub out: PathBuf,
    /// Numeric precision of the engine.
    #[arg(long, value_enum, default_value = "f64")]
    pub precision: Precision,
    /// Model switches (`--identify-flexure` identifies the flexure from each run's
    /// recording instead of using the scenario's true model).
    #[command(flatten)]
    pub model: ModelArgs,
}

/// One run's final errors (9: gyro bias, accel bias, misalignment), σ and NEES.
#[derive(Clone, Copy, Debug)]
pub struct RunResult {
    /// Seed.
    pub seed: u64,
    /// Errors, SI.
    pub error: [f64; 9],
    /// Filter σ, SI.
    pub sigma: [f64; 9],
    /// NEES of the 9 states.
    pub nees: f64,
    /// NIS mean.
    pub nis: f64,
}

/// Aggregate of a Monte Carlo: per state RMS error and mean σ, the RMS of the errors
/// normalized by each run's own σ, and NEES statistics.
#[derive(Clone, Debug)]
pub struct Aggregate {
    /// RMS error per state (the state's unit).
    pub rms: [f64; 9],
    /// Mean σ per state (the state's unit).
    pub mean_sigma: [f64; 9],
    /// RMS over runs of each run's error over that run's σ: the consistency ratio ("RMS/σ").
    /// Its square is χ²(runs)/runs for a consistent filter whatever each run's σ, which
    /// `rms / mean_sigma` is only when every run has the same σ: a blind Monte Carlo's runs
    /// differ in σ by orders of magnitude, and there the plain ratio is set by the few
    /// runs with the largest σ.
    pub normalized_rms: [f64; 9],
    /// Mean NEES over runs.
    pub nees_mean: f64,
    /// 95% band of the mean NEES: χ²(9R) quantiles / R.
    pub nees_band: [f64; 2],
}

/// Runs one seed: simulate, calibrate with the declared model, score.
pub fn one_run(
    sc: &Scenario,
    cfg: &CalibConfig,
    seed: u64,
    precision: Precision,
) -> Result<RunResult, String> {
    let rec = simulate(sc, seed).recording;
    let mut cfg = cfg.clone();
    if cfg.identify_flexure {
        let source = crate::cmd::calibrate::choose_flexure(&rec, &mut cfg);
        if cfg.flexure_axes.is_none() {
            return Err(format!("seed {seed}: {source}"));
        }
    }
    Ok(score_run(&rec, &cfg, seed, precision)?.0)
}

/// Calibrates a simulated recording with `cfg` and scores it against its truth; the
/// run's result comes back too, for its innovations.
pub fn score_run(
    rec: &crate::recording::Recording,
    cfg: &CalibConfig,
    seed: u64,
    precision: Precision,
) -> Result<(RunResult, crate::calib::run::CalibResult), String> {
    let res = calibrate(rec, cfg, precision)?;
    let truth = rec.truth.as_ref().ok_or("simulation wrote no truth")?;
    let s = score(&res, truth).ok_or("no estimates to score")?;
    let last = res.last();
    let mut error = [0.0; 9];
    let mut sigma = [0.0; 9];
    error[0..3].copy_from_slice(&s.gyro_bias);
    error[3..6].copy_from_slice(&s.accel_bias);
    error[6..9].copy_from_slice(&s.misalignment);
    sigma[0..3].copy_from_slice(&last.gyro_bias_sigma);
    sigma[3..6].copy_from_slice(&last.accel_bias_sigma);
    sigma[6..9].copy_from_slice(&last.misalignment_sigma);
    let nis = res.nis_mean();
    Ok((
        RunResult {
            seed,
            error,
            sigma,
            nees: s.nees_mean,
            nis,
        },
        res,
    ))
}

/// Aggregates runs.
pub fn aggregate(runs: &[RunResult]) -> Aggregate {
    let n = runs.len().max(1) as f64;
    let mut rms = [0.0; 9];
    let mut mean_sigma = [0.0; 9];
    let mut normalized_rms = [0.0; 9];
    for r in runs {
        for i in 0..9 {
            rms[i] += r.error[i] * r.error[i] / n;
            mean_sigma[i] += r.sigma[i] / n;
            normalized_rms[i] += (r.error[i] / r.sigma[i]).powi(2) / n;
        }
    }
    let rms = rms.map(f64::sqrt);
    let normalized_rms = normalized_rms.map(f64::sqrt);
    let nees_mean = runs.iter().map(|r| r.nees).sum::<f64>() / n;
    let dof = 9.0 * n;
    Aggregate {
        rms,
        mean_sigma,
        normalized_rms,
        nees_mean,
        nees_band: [chi2_quantile(0.025, dof) / n, chi2_quantile(0.975, dof) / n],
    }
}

/// The calibrated states' names, in the order of [`RunResult::error`].
pub const NAMES: [&str; 9] = [
    "bgx", "bgy", "bgz", "bax", "bay", "baz", "mux", "muy", "muz",
];

/// RMS of the normalized error (each run's error over its own σ) for each calibrated state as a bar chart, one labelled bar per
/// state in the order of `NAMES` (1: the filter's σ is right; dashed, the verdict's bound
/// for `runs` runs, `verdict::ensemble::ratio_bound`). A bar is a band from 0 to its
/// value over [i − 0.4, i + 0.4].
pub fn ratio_figure(scenario: &str, agg: &Aggregate, runs: usize) -> Figure {
    let bound = crate::verdict::ensemble::ratio_bound(runs);
    let bars: Vec<Band> = NAMES
        .iter()
        .enumerate()
        .map(|(i, name)| {
            let r = agg.normalized_rms[i];
            let x = i as f64;
            Band {
                name: format!("{name} {r:.2}"),
                x: vec![x - 0.4, x + 0.4],
                lo: vec![0.0, 0.0],
                hi: vec![r, r],
            }
        })
        .collect();
    let x = vec![-0.5, NAMES.len() as f64 - 0.5];
    let line = |name: &str, v: f64| Series {
        name: name.into(),
        x: x.clone(),
        y: vec![v; x.len()],
    };
    Figure {
        title: format!("Monte Carlo `{scenario}` ({runs} runs): RMS of error/σ per state"),
        x_label: format!("state 0..8: {}", NAMES.join(", ")),
        panels: vec![Panel {
            title: "RMS of the final error over the filter's σ, run by run".into(),
            y_label: "ratio".into(),
            series: vec![],
            bands: bars,
            dashed: vec![
                line("1 (consistent)", 1.0),
                line(&format!("{bound:.2} (bound for {runs} runs)"), bound),
            ],
        }],
    }
}

/// The verdict of a Monte Carlo (`crate::verdict::ensemble`): its runs' NEES against the
/// band of the mean, and each state's RMS of error over σ (`Aggregate::normalized_rms`).
pub fn ensemble_verdict(runs: &[RunResult], agg: &Aggregate) -> crate::verdict::Verdict {
    let ratios: Vec<(&str, f64)> = NAMES
        .iter()
        .enumerate()
        .map(|(i, n)| (*n, agg.normalized_rms[i]))
        .collect();
    let seeds_nees: Vec<(u64, f64)> = runs.iter().map(|r| (r.seed, r.nees)).collect();
    crate::verdict::Verdict {
        findings: crate::verdict::ensemble::check(&seeds_nees, agg.nees_band, &ratios),
    }
}

/// Runs `flexcal montecarlo`.
pub fn run(a: &Args) -> Result<(), String> {
    if a.runs == 0 {
        return Err("--runs must be at least 1".into());
    }
    if a.scenario.blind {
        return super::montecarlo_blind::run(a);
    }
    let sc = a.scenario.load()?;
    let mut cfg = CalibConfig::declared_for(&sc, 1.0 / sc.master.rate_hz);
    a.model.apply(&mut cfg)?;
    let bar = ProgressBar::new(a.runs as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} runs, {elapsed} elapsed, ETA {eta}")
            .map_err(|e| e.to_string())?,
    );
    let results: Result<Vec<RunResult>, String> = (0..a.runs as u64)
        .into_par_iter()
        .map(|i| {
            let r = one_run(&sc, &cfg, a.scenario.seed + i, a.precision);
            bar.inc(1);
            r
        })
        .collect();
    bar.finish_and_clear();
    let runs = results?;
    let agg = aggregate(&runs);
    std::fs::create_dir_all(&a.out).map_err(|e| format!("{}: {e}", a.out.display()))?;
    let states: Vec<_> = (0..9)
        .map(|i| json!({ "state": NAMES[i], "rms_error": agg.rms[i], "mean_sigma": agg.mean_sigma[i], "ratio": agg.normalized_rms[i] }))
        .collect();
    let doc = json!({
        "tool_version": TOOL_VERSION,
        "scenario": sc.name,
        "runs": runs.len(),
        "first_seed": a.scenario.seed,
        "duration_s": sc.duration_s,
        "precision": a.precision,
        "dynamic_lever_arm": cfg.dynamic_lever_arm,
        "flexure": if cfg.identify_flexure { "identified per run" } else { "the scenario's true model" },
        "states": states,
        "nees": { "mean": agg.nees_mean, "band_95": agg.nees_band, "dof_per_run": 9,
                  "inside": agg.nees_mean >= agg.nees_band[0] && agg.nees_mean <= agg.nees_band[1] },
        "nis_mean": runs.iter().map(|r| r.nis).sum::<f64>() / runs.len().max(1) as f64,
        "per_run": runs.iter().map(|r| json!({"seed": r.seed, "nees": r.nees, "nis_mean": r.nis, "error": r.error, "sigma": r.sigma})).collect::<Vec<_>>(),
    });
    let verdict = ensemble_verdict(&runs, &agg);
    let mut doc = doc;
    verdict.insert_into(&mut doc);
    super::common::write_json(&a.out.join("montecarlo.json"), &doc)?;
    let x: Vec<f64> = runs.iter().map(|r| r.seed as f64).collect();
    let single = crate::verdict::ensemble::single_run_band();
    let fig = Figure {
        title: format!(
            "Monte Carlo `{}`: final NEES of the 9 calibrated states per run",
            sc.name
        ),
        x_label: "seed".into(),
        panels: vec![Panel {
            title: format!(
                "single runs against the single-run χ²(9) 99% band [{:.2}, {:.2}]; mean {:.2}, 95% band of the mean [{:.2}, {:.2}]",
                single[0], single[1], agg.nees_mean, agg.nees_band[0], agg.nees_band[1]
            ),
            y_label: "NEES".into(),
            series: vec![Series {
                name: "NEES of one run".into(),
                x: x.clone(),
                y: runs.iter().map(|r| r.nees).collect(),
            }],
            bands: vec![Band {
                name: "single-run 99% band".into(),
                x: x.clone(),
                lo: vec![single[0]; x.len()],
                hi: vec![single[1]; x.len()],
            }],
            dashed: vec![Series {
                name: format!("mean {:.2}", agg.nees_mean),
                x: x.clone(),
                y: vec![agg.nees_mean; x.len()],
            }],
        }],
    };
    fig.write(&a.out.join("nees.svg"))
        .map_err(|e| e.to_string())?;
    ratio_figure(&sc.name, &agg, runs.len())
        .write(&a.out.join("rms_over_sigma.svg"))
        .map_err(|e| e.to_string())?;
    println!(
        "Monte Carlo `{}`: {} runs of {} s ({:?})",
        sc.name,
        runs.len(),
        sc.duration_s,
        a.precision
    );
    println!("  state  unit    rms error   mean sigma   RMS of error/sigma");
    for (i, ((name, rms), sigma)) in NAMES.iter().zip(agg.rms).zip(agg.mean_sigma).enumerate() {
        use crate::report::units::{sig3, ACCEL_BIAS, ANGLE, GYRO_BIAS};
        let u = [GYRO_BIAS, ACCEL_BIAS, ANGLE][i / 3];
        println!(
            "  {name:5}  {:<6} {:>10}   {:>10}   {:6.3}",
            u.name,
            sig3(rms * u.scale),
            sig3(sigma * u.scale),
            agg.normalized_rms[i]
        );
    }
    println!(
        "  mean NEES {:.3} (95% band [{:.3}, {:.3}])",
        agg.nees_mean, agg.nees_band[0], agg.nees_band[1]
    );
    verdict.conclude()
}
