//! One model evaluated on a recording: the calibration run, its residual statistics,
//! the innovations' likelihood and the held-out check.

use crate::calib::config::CalibConfig;
use crate::calib::residuals::{channel_residuals, ChannelResidual};
use crate::calib::run::{run, run_with, CalibResult, Precision, RunOptions, CHANNELS};
use crate::recording::Recording;
use flexcal_core::augment::Effect;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

/// Warm-start passes a model with a time delay is run for at most: each starts from the
/// previous pass's delay, so the delay's linearization holds from the first message.
pub const DELAY_PASSES: usize = 3;

/// The held-out residuals of one channel axis.
#[derive(Clone, Debug, serde::Serialize)]
pub struct HoldoutChannel {
    /// Channel name.
    pub channel: &'static str,
    /// Axis 0..3.
    pub axis: usize,
    /// RMS of the innovations after the freeze (measurement units: m/s, rad, rad/s).
    pub rms: f64,
    /// Innovations after the freeze.
    pub count: usize,
}

/// The held-out check: calibration frozen at `freeze_at_s`, innovations after it.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Holdout {
    /// Time the calibration was frozen (s).
    pub freeze_at_s: f64,
    /// Per channel axis.
    pub channels: Vec<HoldoutChannel>,
    /// Mean NIS of the innovations after the freeze.
    pub nis_mean: f64,
    /// −2 log-likelihood of the innovations after the freeze (up to a constant).
    pub neg2ll: f64,
}

/// A model and what it gives on the recording.
#[derive(Clone)]
pub struct ModelEval {
    /// The configuration (its `effects` are the model's added effects).
    pub cfg: CalibConfig,
    /// The full calibration run.
    pub result: Arc<CalibResult>,
    /// −2 log-likelihood of all innovations (up to a constant).
    pub neg2ll: f64,
    /// Per channel axis NIS and whiteness.
    pub residuals: Vec<ChannelResidual>,
    /// The held-out check (absent only for candidate runs not chosen).
    pub holdout: Option<Holdout>,
}

impl ModelEval {
    /// The model's added effects, in state order.
    pub fn effects(&self) -> Vec<Effect> {
        self.cfg
            .augmentation::<f64>()
            .map(|a| a.blocks().map(|b| b.effect).collect())
            .unwrap_or_default()
    }
}

/// Runs one model (f64). A model with a time delay (or a clock drift) is run again from
/// its own delay estimate (the drift's: the delay at its start) until that moves by less
/// than its σ (at most `DELAY_PASSES` runs). The drift's rate starts from zero each pass.
pub fn run_model(rec: &Recording, cfg: &CalibConfig) -> Result<ModelEval, String> {
    let mut cfg = cfg.clone();
    let clock = cfg.clock_effect();
    let mut result = run(rec, &cfg, Precision::F64)?;
    if let Some(clock) = clock {
        for _ in 1..DELAY_PASSES {
            let Some(d) = result
                .final_effects()
                .into_iter()
                .find(|r| r.effect == clock)
            else {
                break;
            };
            let (tau, sigma) = (d.value[0], d.sigma[0]);
            let moved = (tau - cfg.initial_delay_s).abs();
            cfg.initial_delay_s = tau.clamp(
                -flexcal_core::engine::MAX_DELAY_S,
                flexcal_core::engine::MAX_DELAY_S,
            );
            result = run(rec, &cfg, Precision::F64)?;
            if moved < sigma {
                break;
            }
        }
    }
    Ok(ModelEval {
        neg2ll: result.neg2_log_likelihood(),
        residuals: channel_residuals(&result.innovations),
        result: Arc::new(result),
        cfg,
        holdout: None,
    })
}

/// The held-out check of a model: frozen after `fraction` of the master messages' span.
pub fn holdout(rec: &Recording, cfg: &CalibConfig, fraction: f64) -> Result<Holdout, String> {
    let (t0, t1) = match (rec.master.first(), rec.master.last()) {
        (Some(a), Some(b)) => (a.t, b.t),
        _ => return Err("the recording has no master messages".into()),
    };
    let freeze_at_s = t0 + fraction * (t1 - t0);
    let res = run_with(
        rec,
        cfg,
        Precision::F64,
        &RunOptions {
            freeze_at_s: Some(freeze_at_s),
            innovations_only: true,
        },
    )?;
    let after: Vec<_> = res
        .innovations
        .iter()
        .filter(|i| i.t >= freeze_at_s && i.variance > 0.0)
        .collect();
    let mut channels = Vec::new();
    for (c, name) in CHANNELS.iter().enumerate() {
        for axis in 0..3 {
            let v: Vec<f64> = after
                .iter()
                .filter(|i| i.channel == c && i.axis == axis)
                .map(|i| i.value)
                .collect();
            if v.is_empty() {
                continue;
            }
            channels.push(HoldoutChannel {
                channel: name,
                axis,
                rms: (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt(),
                count: v.len(),
            });
        }
    }
    let nis_mean = if after.is_empty() {
        f64::NAN
    } else {
        after
            .iter()
            .map(|i| i.value * i.value / i.variance)
            .sum::<f64>()
            / after.len() as f64
    };
    let neg2ll = after
        .iter()
        .map(|i| i.variance.ln() + i.value * i.value / i.variance)
        .sum();
    Ok(Holdout {
        freeze_at_s,
        channels,
        nis_mean,
        neg2ll,
    })
}

/// `eval` with its held-out check.
pub fn with_holdout(
    rec: &Recording,
    mut eval: ModelEval,
    fraction: f64,
) -> Result<ModelEval, String> {
    eval.holdout = Some(holdout(rec, &eval.cfg, fraction)?);
    Ok(eval)
}

/// Runs and checks one model. Without a clock effect the run leaves the configuration
/// as it is, so the held-out run needs nothing from it and the two run side by side (on
/// a second thread); with one, the held-out run starts from the delay the run found.
pub fn evaluate_model(
    rec: &Recording,
    cfg: &CalibConfig,
    fraction: f64,
) -> Result<ModelEval, String> {
    if cfg.clock_effect().is_some() {
        return with_holdout(rec, run_model(rec, cfg)?, fraction);
    }
    let (eval, holdout) = std::thread::scope(|s| {
        let h = s.spawn(|| holdout(rec, cfg, fraction));
        let eval = run_model(rec, cfg);
        let holdout = h
            .join()
            .unwrap_or_else(|_| Err("a held-out run panicked".to_string()));
        (eval, holdout)
    });
    let mut eval = eval?;
    eval.holdout = Some(holdout?);
    Ok(eval)
}

/// `f` of every job `0..order.len()`, on as many threads as the machine has (at most one
/// a job), each thread taking the next job of `order` as it finishes one: the longest
/// first, so that no thread waits on a long job started last. The results are in job
/// order, `None` for a job whose run panicked.
fn in_parallel<R: Send>(order: &[usize], f: impl Fn(usize) -> R + Sync) -> Vec<Option<R>> {
    let threads = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
        .clamp(1, order.len().max(1));
    let next = AtomicUsize::new(0);
    let slots: Vec<Mutex<Option<R>>> = order.iter().map(|_| Mutex::new(None)).collect();
    std::thread::scope(|s| {
        let workers: Vec<_> = (0..threads)
            .map(|_| {
                s.spawn(|| {
                    while let Some(&job) = order.get(next.fetch_add(1, Ordering::Relaxed)) {
                        let r = f(job);
                        if let Some(mut slot) = slots.get(job).and_then(|m| m.lock().ok()) {
                            *slot = Some(r);
                        }
                    }
                })
            })
            .collect();
        // A panicked worker's job stays `None`; the others go on taking jobs.
        for w in workers {
            let _ = w.join();
        }
    });
    slots
        .into_iter()
        .map(|m| m.into_inner().ok().flatten())
        .collect()
}

/// Runs the current model with each candidate added, on as many threads as the machine
/// has (`in_parallel`; results in candidate order).
pub fn run_candidates(
    rec: &Recording,
    current: &ModelEval,
    candidates: &[Effect],
    delay_start_s: Option<f64>,
) -> Result<Vec<Result<ModelEval, String>>, String> {
    let configs: Vec<CalibConfig> = candidates
        .iter()
        .map(|e| {
            let mut c = current.cfg.clone();
            // The clock drift carries the delay: with `time_delay` in the model it
            // replaces it, from the delay found (`initial_delay_s`, warm-started).
            if *e == Effect::ClockDrift {
                c.effects.retain(|x| x != Effect::TimeDelay.name());
            }
            c.effects.push(e.name().to_string());
            if let (true, Some(d), false) = (
                e.is_clock(),
                delay_start_s,
                current
                    .cfg
                    .effects
                    .iter()
                    .any(|x| x == Effect::TimeDelay.name()),
            ) {
                c.initial_delay_s = d;
            }
            c
        })
        .collect();
    // Clock effects run up to `DELAY_PASSES` times: started first, then the larger blocks.
    let mut order: Vec<usize> = (0..candidates.len()).collect();
    order.sort_by_key(|&k| {
        candidates
            .get(k)
            .map(|e| (!e.is_clock(), std::cmp::Reverse(e.states())))
    });
    Ok(in_parallel(&order, |k| match configs.get(k) {
        Some(c) => run_model(rec, c),
        None => Err("not run".to_string()),
    })
    .into_iter()
    .map(|o| o.unwrap_or_else(|| Err("a candidate run panicked".to_string())))
    .collect())
}
