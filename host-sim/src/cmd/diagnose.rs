//! `flexcal diagnose`: calibrate with the declared model, find the structure its
//! residuals keep, add the candidate effect that explains it, repeat; write
//! `diagnosis.json`, `report.md` and plots.

use crate::calib::config::{parse_effect, CalibConfig};
use crate::cmd::calibrate::{prepare_config, Prepared};
use crate::cmd::common::ModelArgs;
use crate::diagnose::{diagnose, report, Options};
use crate::recording::read_recording;
use flexcal_core::augment::Effect;
use std::path::PathBuf;

/// Arguments of `flexcal diagnose`.
#[derive(clap::Args)]
pub struct Args {
    /// Recording directory (format v1).
    pub rec_dir: PathBuf,
    /// Output directory.
    #[arg(long)]
    pub out: PathBuf,
    /// Declared model (TOML). Default: `REC_DIR/calibrate.toml` when the simulator wrote
    /// one, else the built-in configuration.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Candidate effects, comma separated (default: the vocabulary but its opt-in effects,
    /// `clock_drift`, which are searched only when named here).
    #[arg(long, value_delimiter = ',')]
    pub candidates: Vec<String>,
    /// Most effects added.
    #[arg(long, default_value_t = 3)]
    pub budget: usize,
    /// Family-wise false-alarm level.
    #[arg(long, default_value_t = 0.01)]
    pub alpha: f64,
    /// Fraction of the recording the held-out check estimates on.
    #[arg(long, default_value_t = 0.7)]
    pub holdout_fraction: f64,
}

/// The model the search starts from, and where its `time_delay` candidate starts: a
/// model learned with a delay found before the filter compensated is diagnosed without
/// it, the delay left to the candidate, started from it, so that the delay is found,
/// sized and judged by the search's own rules, not assumed.
fn searched_model(prepared: &Prepared) -> (CalibConfig, Option<f64>) {
    let mut cfg = prepared.cfg.clone();
    if prepared.learned_with_delay_s.is_some() {
        cfg.initial_delay_s = 0.0;
    }
    (cfg, prepared.learned_with_delay_s)
}

/// The learned model the search may learn again where it competes with a candidate
/// (`diagnose::Options::learned`): the searched model when it was learned from the
/// recording and adopted; none when it is the user's (the fixed truth) or the start kept.
fn learned_model(prepared: &Prepared, searched: &CalibConfig) -> Option<CalibConfig> {
    prepared
        .learned
        .as_ref()
        .filter(|l| l.adopted)
        .map(|_| searched.clone())
}

/// The model the search starts from and the options its learning gives it
/// (`searched_model`, `learned_model`, and the learning for `Options::relearn`); the
/// rest of the options at their defaults.
pub fn search_start(prepared: &Prepared) -> (CalibConfig, Options) {
    let (cfg, delay_start_s) = searched_model(prepared);
    let opts = Options {
        delay_start_s,
        learned: learned_model(prepared, &cfg),
        relearn: prepared.learned.clone(),
        ..Options::default()
    };
    (cfg, opts)
}

/// Runs `flexcal diagnose`.
pub fn run(a: &Args) -> Result<(), String> {
    let progress = crate::cmd::progress::Progress::start("reading the recording");
    let rec = read_recording(&a.rec_dir).map_err(|e| e.to_string())?;
    progress.phase("preparing the declared model");
    // The declared model: no switches (the search adds the effects).
    let prepared = prepare_config(&rec, &a.rec_dir, a.config.as_deref(), &ModelArgs::default())?;
    let (cfg, learned) = search_start(&prepared);
    let candidates = if a.candidates.is_empty() {
        Effect::ALL.to_vec()
    } else {
        a.candidates
            .iter()
            .map(|n| parse_effect(n).map_err(|e| format!("--candidates: {e}")))
            .collect::<Result<Vec<_>, _>>()?
    };
    let opts = Options {
        candidates,
        budget: a.budget,
        alpha: a.alpha,
        holdout_fraction: a.holdout_fraction,
        ..learned
    };
    progress.phase(&format!(
        "searching {} candidates (budget {})",
        opts.candidates.len(),
        opts.budget
    ));
    let d = diagnose(&rec, &cfg, &opts)?;
    progress.phase("checking and writing the outputs");
    std::fs::create_dir_all(&a.out).map_err(|e| format!("{}: {e}", a.out.display()))?;
    let label = a.rec_dir.display().to_string();
    let command: String = std::env::args().collect::<Vec<_>>().join(" ");
    let mut scan = crate::verdict::input::Scan::of_dir(&a.rec_dir)?;
    let mut verdict = crate::verdict::of_calibration(
        &mut scan,
        prepared.config_file.as_deref(),
        prepared.learned.as_ref(),
        &d.after.cfg,
        &d.after.result,
    );
    let left: Vec<String> = report::structure(&d.after, opts.alpha, report::master_rate_hz(&rec))
        .into_iter()
        .filter(|s| s.rejected)
        .map(|s| {
            format!(
                "{} {}",
                s.channel,
                ["x", "y", "z"].get(s.axis).unwrap_or(&"?")
            )
        })
        .collect();
    if !left.is_empty() {
        verdict.extend([crate::verdict::Finding::new(
            crate::verdict::Severity::Warn,
            "structure_unexplained",
            format!(
                "{} channel axes keep structure that no candidate of the vocabulary explains: {}",
                left.len(),
                left.join(", ")
            ),
        )
        .num("channels", left.len() as f64)]);
    }
    let mut doc = report::diagnosis_json(&d, &label, &rec, &command);
    verdict.insert_into(&mut doc);
    super::common::write_json(&a.out.join("diagnosis.json"), &doc)?;
    let md = report::report_md(&d, &label, &rec, &command);
    let path = a.out.join("report.md");
    std::fs::write(&path, md).map_err(|e| format!("{}: {e}", path.display()))?;
    report::write_plots(&a.out, &d, &rec).map_err(|e| e.to_string())?;
    drop(progress);
    println!("diagnosed {label} -> {}", a.out.display());
    if d.found.is_empty() && !d.instabilities.iter().any(|t| t.named) {
        println!("  no effect found");
    }
    for t in &d.found {
        use crate::report::units::{list, of_effect_unit};
        let u =
            Effect::from_name(t.effect).map_or(of_effect_unit(""), |e| of_effect_unit(e.unit()));
        println!(
            "  {} ({}): [{}] ± [{}] (Wald {:.1}, LR {:.1}, threshold {:.1})",
            t.effect,
            u.name,
            list(&t.estimate, u),
            list(&t.sigma, u),
            t.wald,
            t.likelihood_ratio,
            t.threshold
        );
    }
    for (k, r) in d.rounds.iter().enumerate() {
        for t in r.tests.iter().filter(|t| t.significant) {
            println!(
                "  round {}: {} (Wald {:.1}, LR {:.1}, threshold {:.1}): {}",
                k + 1,
                t.effect,
                t.wald,
                t.likelihood_ratio,
                t.threshold,
                report::decision(t, r)
            );
        }
        if let Some(line) = report::rivals_line(r) {
            println!("  round {}: {line}", k + 1);
        }
        if let Some(line) = report::relearn_line(r) {
            println!("  round {}: {line}", k + 1);
        }
    }
    for t in &d.instabilities {
        println!(
            "  process noise: {}",
            report::instability_line(t, rec.truth.as_ref())
        );
    }
    for x in &d.dropped {
        println!(
            "  backward pass: dropped {} (likelihood ratio against the set without it {:.1}, threshold {:.1}, held-out {:.1})",
            x.effect, x.likelihood_ratio, x.threshold, x.holdout_likelihood_ratio
        );
    }
    println!("  channels with unexplained structure: {}", left.len());
    verdict.conclude()
}
