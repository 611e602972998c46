//! The outputs of `flexcal diagnose`: `diagnosis.json` (the contract of
//! `shared/formats/outputs.md`), `report.md` and its plots.

use super::evaluate::ModelEval;
use super::spectrum::{autocorrelation, welch};
use super::{CandidateTest, Diagnosis};
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

/// Whitened innovations (ν/√s) of one channel axis, accepted or not, in time order.
fn whitened(innov: &[Innovation], channel: usize, axis: usize) -> (Vec<f64>, Vec<f64>) {
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
}

/// The structure of every channel axis of a model, tested at family-wise level `alpha`
/// (Bonferroni over the channel axes).
pub fn structure(eval: &ModelEval, alpha: f64, rate_hz: f64) -> Vec<Structure> {
    let n = eval.residuals.len().max(1) as f64;
    let a = alpha / n;
    eval.residuals
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
            Structure {
                channel: r.channel,
                axis: r.axis,
                nis_mean: r.nis_mean,
                nis_band: band,
                whiteness_p: r.whiteness_p,
                rejected: r.whiteness_p < a || r.nis_mean < band[0] || r.nis_mean > band[1],
                peak_hz,
                peak_level,
            }
        })
        .collect()
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
        "effects_found": d.found.iter().map(|t| found_json(t, truth)).collect::<Vec<_>>(),
        "unexplained_structure": left,
        "noise_corrected": d.noise,
        "before": model_json(rec_label, rec, &d.before),
        "after": model_json(rec_label, rec, &d.after),
        "search": {
            "candidates": d.options.candidates.iter().map(|e| e.name()).collect::<Vec<_>>(),
            "budget": d.options.budget,
            "alpha": d.options.alpha,
            "tests": d.options.budget * d.options.candidates.len(),
            "rule": "a candidate is significant when the Wald statistic of its block and the likelihood ratio both exceed the chi-square(dof) quantile at alpha / tests; of the significant, the one whose likelihood ratio exceeds its threshold most and whose held-out likelihood ratio is positive is added",
            "rounds": d.rounds,
        },
        "recommended_config": {
            "effects": d.after.cfg.effects,
            "initial_delay_s": d.after.cfg.initial_delay_s,
            "velocity_noise_mps": d.after.cfg.velocity_noise_mps,
            "attitude_noise_rad": d.after.cfg.attitude_noise_rad,
            "rate_noise_radps": d.after.cfg.rate_noise_radps,
        },
    })
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
                fmt_g(c.declared),
                fmt_g(c.corrected),
                fmt_g(c.declared_nis)
            );
        }
        let _ = writeln!(s);
    }
    let _ = writeln!(s, "## Effects found\n");
    if d.found.is_empty() {
        let _ = writeln!(s, "None: no candidate is significant.\n");
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
            r.added
                .map_or("nothing significant".to_string(), |a| format!("adds `{a}`"))
        );
        let _ = writeln!(
            s,
            "Structure statistic of this round's model: {}.\n\n| candidate | k | estimate ± σ | Wald | likelihood ratio | threshold | significant | structure left | held-out likelihood ratio |\n|---|---|---|---|---|---|---|---|---|",
            fmt_g(r.structure)
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
                match &t.error {
                    Some(e) => format!("not tested: {e}"),
                    None => if t.significant { "yes" } else { "no" }.to_string(),
                },
                fmt_g(t.structure_after),
                t.holdout_likelihood_ratio.map_or("–".to_string(), |h| {
                    format!("{}{}", fmt_g(h), if h > 0.0 { "" } else { " (rejected)" })
                })
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
            "No candidate explains what follows (it is reported, not forced onto the nearest effect):\n\n| channel | NIS | band | whiteness p | spectral peak (Hz) | peak / white level |\n|---|---|---|---|---|---|"
        );
        for l in &left {
            let _ = writeln!(
                s,
                "| {} {} | {} | [{}, {}] | {} | {} | {} |",
                l.channel,
                ["x", "y", "z"][l.axis.min(2)],
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
