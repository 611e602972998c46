//! `report.md` of `flexcal calibrate` and `flexcal replay`: the verdict in a line, the
//! final estimates in engineering units (`units`) with σ (and the error against the
//! truth when the recording has one), the verdict's findings, per-channel NIS and whiteness, the model used
//! (lever arm, flexure, noise, effects carried) and links to the plots. A page for a
//! navigation engineer; `summary.json` holds the same in SI for machines.

use super::units::{of_effect_unit, sig3, Unit, ACCEL_BIAS, ANGLE, ARW, GYRO_BIAS, VRW};
use crate::calib::config::CalibConfig;
use crate::calib::run::CalibResult;
use crate::calib::score::Score;
use crate::recording::RecordingMeta;
use crate::verdict::run::nis_band;
use crate::verdict::{Level, Severity, Verdict};
use std::fmt::Write;

/// What the report is about, besides the run itself.
pub struct ReportInput<'a> {
    /// The recording as given on the command line.
    pub label: &'a str,
    /// The recording's description.
    pub meta: &'a RecordingMeta,
    /// Master messages in the recording.
    pub master_total: usize,
    /// Its duration (s).
    pub duration_s: f64,
    /// The configuration run.
    pub cfg: &'a CalibConfig,
    /// Where the model came from (a file, learned, built-in).
    pub model_origin: String,
    /// Where the flexure model came from.
    pub flexure_source: &'a str,
    /// Errors against the truth, when known.
    pub score: Option<&'a Score>,
    /// The plot files written beside the report.
    pub plots: &'a [String],
}

/// The text of `report.md`.
pub fn report_md(r: &ReportInput<'_>, res: &CalibResult, verdict: &Verdict) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# Calibration of `{}`\n", r.label);
    let _ = writeln!(
        s,
        "{} s of data, {:?} engine, model: {}.\n",
        sig3(r.duration_s),
        res.precision,
        r.model_origin
    );
    verdict_summary(&mut s, verdict);
    estimates_section(&mut s, r, res);
    verdict_section(&mut s, verdict);
    residuals_section(&mut s, res);
    model_section(&mut s, r, res);
    let _ = writeln!(s, "## Plots\n");
    for p in r.plots {
        let _ = writeln!(s, "![{p}]({p})\n");
    }
    s
}

/// The verdict in one line at the top: its level and the codes of its warnings and
/// failures with their counts (the findings themselves follow the estimates).
fn verdict_summary(s: &mut String, v: &Verdict) {
    let word = match v.level() {
        Level::Pass => "PASS",
        Level::Warn => "WARN",
        Level::Fail => "FAIL",
    };
    let mut codes: Vec<(&str, usize)> = Vec::new();
    for f in v.findings.iter().filter(|f| f.severity >= Severity::Warn) {
        match codes.iter_mut().find(|(c, _)| *c == f.code) {
            Some((_, n)) => *n += 1,
            None => codes.push((f.code, 1)),
        }
    }
    let list: Vec<String> = codes
        .iter()
        .map(|(c, n)| {
            if *n > 1 {
                format!("`{c}` ×{n}")
            } else {
                format!("`{c}`")
            }
        })
        .collect();
    let _ = writeln!(
        s,
        "## Verdict: **{word}**{}\n",
        if list.is_empty() {
            String::new()
        } else {
            format!(" — {}", list.join(", "))
        }
    );
}

fn verdict_section(s: &mut String, v: &Verdict) {
    let _ = writeln!(s, "## Findings\n");
    if v.findings.is_empty() {
        let _ = writeln!(s, "No finding.\n");
        return;
    }
    let _ = writeln!(s, "| | code | finding | where |\n|---|---|---|---|");
    let mut sorted: Vec<_> = v.findings.iter().collect();
    sorted.sort_by_key(|f| std::cmp::Reverse(f.severity));
    for f in sorted {
        let _ = writeln!(
            s,
            "| {} | `{}` | {} | {} |",
            f.severity.word(),
            f.code,
            f.message.replace('|', "\\|"),
            f.location.replace('|', "\\|")
        );
    }
    let _ = writeln!(s, "\nThe codes and their thresholds: `docs/verdict.md`.\n");
}

/// `value ± σ` in a unit.
fn pm(v: f64, sigma: f64, u: Unit) -> String {
    format!("{} ± {}", sig3(v * u.scale), sig3(sigma * u.scale))
}

fn estimates_section(s: &mut String, r: &ReportInput<'_>, res: &CalibResult) {
    let last = res.last();
    let _ = writeln!(
        s,
        "## Final estimates (t = {} s)\n\nSlave body axes (x right, y forward, z up); ± one σ.\n",
        sig3(last.t)
    );
    let truth_cols = if r.score.is_some() {
        " error x, y, z (estimate − truth) | error / σ |"
    } else {
        ""
    };
    let _ = writeln!(s, "| quantity | unit | x | y | z |{truth_cols}");
    let _ = writeln!(
        s,
        "|---|---|---|---|---|{}",
        if r.score.is_some() { "---|---|" } else { "" }
    );
    let rows = [
        (
            "gyro bias",
            GYRO_BIAS,
            last.gyro_bias,
            last.gyro_bias_sigma,
            r.score.map(|s| s.gyro_bias),
        ),
        (
            "accelerometer bias",
            ACCEL_BIAS,
            last.accel_bias,
            last.accel_bias_sigma,
            r.score.map(|s| s.accel_bias),
        ),
        (
            "misalignment μ",
            ANGLE,
            last.misalignment,
            last.misalignment_sigma,
            r.score.map(|s| s.misalignment),
        ),
        (
            "flexure θ (last)",
            ANGLE,
            last.flexure,
            last.flexure_sigma,
            None,
        ),
    ];
    for (name, u, v, sg, err) in rows {
        let _ = write!(
            s,
            "| {name} | {} | {} | {} | {} |",
            u.name,
            pm(v[0], sg[0], u),
            pm(v[1], sg[1], u),
            pm(v[2], sg[2], u)
        );
        if r.score.is_some() {
            match err {
                Some(e) => {
                    let _ = write!(
                        s,
                        " {} | {} |",
                        e.map(|x| sig3(x * u.scale)).join(", "),
                        (0..3)
                            .map(|i| sig3(e[i] / sg[i]))
                            .collect::<Vec<_>>()
                            .join(", ")
                    );
                }
                None => {
                    let _ = write!(s, " – | – |");
                }
            }
        }
        let _ = writeln!(s);
    }
    for e in res.final_effects() {
        let u = of_effect_unit(e.effect.unit());
        let vals: Vec<String> = e
            .value
            .iter()
            .zip(&e.sigma)
            .map(|(v, sg)| pm(*v, *sg, u))
            .collect();
        let _ = writeln!(
            s,
            "| effect `{}` | {} | {} | | |{}",
            e.effect.name(),
            u.name,
            vals.join("; "),
            if r.score.is_some() {
                " – | – |"
            } else {
                ""
            }
        );
    }
    if let Some(sc) = r.score {
        let _ = writeln!(
            s,
            "\nNEES of the 9 calibrated states at the end: {} (χ²(9): 95% of consistent runs in [2.70, 19.0]).",
            sig3(sc.nees_mean)
        );
    }
    let _ = writeln!(s);
}

fn residuals_section(s: &mut String, res: &CalibResult) {
    let _ = writeln!(s, "## Innovations per channel\n");
    let residuals = res.summary.residuals();
    if residuals.is_empty() {
        let _ = writeln!(
            s,
            "No innovation statistics: the runner sent none (the board sends estimates only), or too few.\n"
        );
        return;
    }
    let k = residuals.len();
    let _ = writeln!(
        s,
        "Mean NIS against its band (family-wise 1% over the {k} channel axes) and Ljung-Box whiteness ({} lags) of the whitened innovations.\n",
        crate::calib::residuals::LAGS
    );
    let _ = writeln!(
        s,
        "| channel | axis | innovations | mean NIS | band | whiteness p | |\n|---|---|---|---|---|---|---|"
    );
    let limit = crate::verdict::run::FAMILY_ALPHA / k as f64;
    for r in &residuals {
        let band = nis_band(r.count, k);
        let nis_ok = (band[0]..=band[1]).contains(&r.nis_mean);
        let white = r.whiteness_p >= limit;
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | [{}, {}] | {} | {} |",
            r.channel,
            ["x", "y", "z"].get(r.axis).unwrap_or(&"?"),
            r.count,
            sig3(r.nis_mean),
            sig3(band[0]),
            sig3(band[1]),
            sig3(r.whiteness_p),
            match (nis_ok, white) {
                (true, true) => "ok",
                (false, true) => "NIS out of band",
                (true, false) => "not white",
                (false, false) => "NIS out of band, not white",
            }
        );
    }
    let _ = writeln!(
        s,
        "\n{} of {} scalar innovations gated.\n",
        res.summary.gated, res.summary.total
    );
}

fn model_section(s: &mut String, r: &ReportInput<'_>, res: &CalibResult) {
    let c = r.cfg;
    let l = r.meta.lever_arm_m;
    let _ = writeln!(s, "## Model\n");
    let _ = writeln!(
        s,
        "- matching: {}; filter period {} ms",
        c.matching.join(", "),
        sig3(c.filter_period_s * 1000.0)
    );
    let _ =
        writeln!(
        s,
        "- lever arm r0 (master body, m): [{}, {}, {}]; flexure-bent lever arm {} ({:?} bending)",
        sig3(l[0]),
        sig3(l[1]),
        sig3(l[2]),
        if c.dynamic_lever_arm { "modelled" } else { "not modelled" },
        c.bending
    );
    let uniform = [c.flexure_ar[0], c.flexure_ar[1], c.flexure_sigma_rad];
    let (kind, flex): (&str, Vec<String>) = match c.flexure_gauss_markov {
        Some(gm) => (
            "second-order Gauss-Markov model",
            gm.iter()
                .zip(["x", "y", "z"])
                .map(|([w, z, sg], n)| {
                    format!(
                        "{n}: ω {} rad/s, ζ {}, σ {} {}",
                        sig3(*w),
                        sig3(*z),
                        sig3(sg * ANGLE.scale),
                        ANGLE.name
                    )
                })
                .collect(),
        ),
        None => (
            "AR model",
            c.flexure_axes
                .unwrap_or([uniform; 3])
                .iter()
                .zip(["x", "y", "z"])
                .map(|([a1, a2, sg], n)| {
                    format!(
                        "{n}: a = [{a1:.6}, {a2:.6}], σ {} {}",
                        sig3(sg * ANGLE.scale),
                        ANGLE.name
                    )
                })
                .collect(),
        ),
    };
    let _ = writeln!(
        s,
        "- flexure {kind} ({}): {}",
        r.flexure_source,
        flex.join("; ")
    );
    let _ = writeln!(
        s,
        "- slave noise: gyro angle random walk {} {}, accelerometer velocity random walk {} {}",
        sig3(c.gyro_arw_rad_rs * ARW.scale),
        ARW.name,
        sig3(c.accel_vrw_mps_rs * VRW.scale),
        VRW.name
    );
    let _ = writeln!(
        s,
        "- master noise per axis: velocity {} m/s (E, N, U), attitude {} {} (x, y, z), rate {} {} (x, y, z)",
        c.velocity_noise_mps.map(sig3).join(", "),
        c.attitude_noise_rad.map(|v| sig3(v * ANGLE.scale)).join(", "),
        ANGLE.name,
        c.rate_noise_radps.map(|v| sig3(v * GYRO_BIAS.scale)).join(", "),
        GYRO_BIAS.name
    );
    let _ = writeln!(
        s,
        "- prior σ: gyro bias {} {}, accelerometer bias {} {}, misalignment {} {}",
        sig3(c.initial_gyro_bias_radps * GYRO_BIAS.scale),
        GYRO_BIAS.name,
        sig3(c.initial_accel_bias_mps2 * ACCEL_BIAS.scale),
        ACCEL_BIAS.name,
        sig3(c.initial_misalignment_rad * ANGLE.scale),
        ANGLE.name
    );
    let _ = writeln!(
        s,
        "- effects carried beyond the declared 21 states: {}",
        if c.effects.is_empty() {
            "none".to_string()
        } else {
            c.effects.join(", ")
        }
    );
    let k = &res.counters;
    let _ = writeln!(
        s,
        "- inputs: {} slave samples, {} of {} master messages matched ({} stale, {} out of order, {} dropped by the queue), {} filter resets\n",
        k.imu_samples,
        k.master_matched,
        r.master_total,
        k.master_stale,
        k.master_out_of_order,
        k.master_dropped,
        k.resets
    );
}
