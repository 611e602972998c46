//! What the filter's run says about itself: how many master messages it matched and
//! why the others were not (stale, out of order, dropped by the bounded queue, never
//! reached), resets, per-channel NIS against its χ² band, whiteness of the residuals,
//! the gated fraction, σ that did not fall from its prior, estimates beyond their
//! prior, covariance health. Thresholds and their reasons: `docs/verdict.md`.

use super::input::Scan;
use super::{g3, Finding, Severity};
use crate::calib::config::CalibConfig;
use crate::calib::residuals::ChannelResidual;
use crate::calib::run::CalibResult;
use crate::report::units::{show, ACCEL_BIAS, ANGLE, GYRO_BIAS};
use flexcal_core::engine::PENDING_DEPTH;
use flexcal_core::stats::chi2_quantile;
use serde_json::json;

/// Family-wise false-alarm level of the NIS and whiteness tests over all channel axes:
/// a consistent filter with white residuals gets a WARN from them once in 100 runs.
pub const FAMILY_ALPHA: f64 = 0.01;
/// A channel's mean NIS above this is a FAIL: its innovations are √2 times larger than
/// the filter says, so its 3σ is less than 2.1σ (the reported σ cannot be trusted).
pub const NIS_FAIL: f64 = 2.0;
/// Matched fraction of the master messages below which the run FAILs.
pub const MATCHED_FAIL: f64 = 0.5;
/// Below which it WARNs.
pub const MATCHED_WARN: f64 = 0.9;
/// Gated fraction above which the run WARNs (a consistent filter gates a 5σ innovation
/// 6e-7 of the time).
pub const GATED_WARN: f64 = 0.01;
/// Above which it FAILs.
pub const GATED_FAIL: f64 = 0.1;
/// Dropped fraction of master messages above which the run FAILs.
pub const DROPPED_FAIL: f64 = 0.01;
/// Refused (stale, out-of-order) master messages up to this fraction are a NOTE, above
/// it a WARN: a clock offset or delay can make the first message older than the
/// alignment buffer, which loses one message of thousands.
pub const REFUSED_NOTE: f64 = 0.001;
/// A σ above this fraction of its prior at the end has not fallen: the data added less
/// than a quarter of the prior's information (1/0.9² − 1 = 0.23).
pub const SIGMA_FALL: f64 = 0.9;
/// An estimate beyond this many prior σ: the prior (the sensor's grade) was wrong.
pub const PRIOR_SIGMAS: f64 = 3.0;

/// The calibrated quantities' names, prefixes and axis names.
const STATES: [&str; 3] = ["gyro bias", "accelerometer bias", "misalignment"];
const AXES: [&str; 3] = ["x", "y", "z"];

/// Every run finding of a calibration of the recording `scan` saw, with `cfg`.
pub fn check(scan: &Scan, cfg: &CalibConfig, res: &CalibResult) -> Vec<Finding> {
    let mut out = Vec::new();
    out.extend(messages(scan, res));
    if res.rows.is_empty() {
        return out;
    }
    if res.summary.total == 0 {
        out.push(Finding::new(
            Severity::Note,
            "innovations_unavailable",
            "the runner sent no innovations (the board sends estimates only): NIS, whiteness and gating not checked",
        ));
    } else {
        let residuals = res.summary.residuals();
        out.extend(nis(&residuals));
        out.extend(whiteness(&residuals));
        out.extend(gated(cfg, res));
    }
    out.extend(sigma_and_prior(cfg, res));
    out.extend(health(res));
    out
}

/// Master messages: matched, refused, dropped, never reached; resets.
fn messages(scan: &Scan, res: &CalibResult) -> Vec<Finding> {
    let c = &res.counters;
    let total = scan.master_total();
    let never = scan.master_after_slave();
    let matched = c.master_matched as usize;
    let frac = matched as f64 / total.max(1) as f64;
    let counts = |f: Finding| {
        f.num("master_total", total as f64)
            .num("matched", matched as f64)
            .num("stale", c.master_stale as f64)
            .num("out_of_order", c.master_out_of_order as f64)
            .num("dropped_by_queue", c.master_dropped as f64)
            .num("after_last_slave_sample", never as f64)
    };
    let mut out = Vec::new();
    // Said even when nothing was matched: it is then the reason.
    if c.master_dropped > 0 {
        let frac = c.master_dropped as f64 / total as f64;
        out.push(counts(Finding::new(
            if frac > DROPPED_FAIL { Severity::Fail } else { Severity::Warn },
            "queue_dropped",
            format!(
                "{} master messages ({:.2}%) were dropped by the engine's {PENDING_DEPTH}-message master queue: they arrived faster than the slave's time reached them (a clock offset, or a master ahead of the slave)",
                c.master_dropped,
                100.0 * frac
            ),
        )));
    }
    if res.rows.is_empty() || matched == 0 {
        out.push(counts(Finding::new(
            Severity::Fail,
            "nothing_estimated",
            format!("no master message was matched (0 of {total}): the estimates are the prior, 0 ± its σ, and say nothing about the sensor"),
        )));
        return out;
    }
    let sev = if frac < MATCHED_FAIL {
        Some(Severity::Fail)
    } else if frac < MATCHED_WARN {
        Some(Severity::Warn)
    } else {
        None
    };
    if let Some(sev) = sev {
        out.push(counts(Finding::new(
            sev,
            "matched_fraction_low",
            format!(
                "{matched} of {total} master messages ({:.1}%) were matched: {} stale, {} out of order, {} dropped by the {PENDING_DEPTH}-message queue, {never} after the last slave sample",
                100.0 * frac,
                c.master_stale,
                c.master_out_of_order,
                c.master_dropped
            ),
        )));
    }
    for (n, code, what) in [
        (
            c.master_stale,
            "master_stale",
            "older than the slave's alignment buffer",
        ),
        (
            c.master_out_of_order,
            "master_out_of_order",
            "not later than the message before",
        ),
    ] {
        if n > 0 {
            let sev = if f64::from(n) > REFUSED_NOTE * total as f64 {
                Severity::Warn
            } else {
                Severity::Note
            };
            out.push(counts(Finding::new(
                sev,
                code,
                format!("{n} master messages were refused: {what}"),
            )));
        }
    }
    if c.resets > 0 {
        out.push(
            Finding::new(
                Severity::Warn,
                "filter_reset",
                format!(
                    "the filter was re-initialized {} time(s) after a channel rejected 20 master messages in a row; estimates before a reset were thrown away",
                    c.resets
                ),
            )
            .num("resets", c.resets as f64)
            .num("max_gated_streak", res.health.max_gated_streak as f64),
        );
    }
    out
}

/// The two-sided band of a mean of `n` χ²(1) at family-wise level `FAMILY_ALPHA`
/// over `k` tests (Bonferroni).
pub fn nis_band(n: usize, k: usize) -> [f64; 2] {
    let a = FAMILY_ALPHA / k.max(1) as f64;
    let n = n as f64;
    [
        chi2_quantile(a / 2.0, n) / n,
        chi2_quantile(1.0 - a / 2.0, n) / n,
    ]
}

fn name(r: &ChannelResidual) -> String {
    format!("{} {}", r.channel, AXES.get(r.axis).copied().unwrap_or("?"))
}

fn nis(residuals: &[ChannelResidual]) -> Vec<Finding> {
    let k = residuals.len();
    let mut out = Vec::new();
    for r in residuals {
        let band = nis_band(r.count, k);
        if (band[0]..=band[1]).contains(&r.nis_mean) {
            continue;
        }
        let high = r.nis_mean > band[1];
        let sev = if r.nis_mean > NIS_FAIL {
            Severity::Fail
        } else {
            Severity::Warn
        };
        out.push(
            Finding::new(
                sev,
                "nis_out_of_band",
                format!(
                    "{}: mean NIS {} outside its band [{}, {}] ({} innovations): the filter's σ is {} than its innovations show",
                    name(r),
                    g3(r.nis_mean),
                    g3(band[0]),
                    g3(band[1]),
                    r.count,
                    if high { "smaller (overconfident)" } else { "larger (pessimistic)" }
                ),
            )
            .at(name(r))
            .num("nis_mean", r.nis_mean)
            .num("band_lo", band[0])
            .num("band_hi", band[1])
            .num("count", r.count as f64),
        );
    }
    out
}

fn whiteness(residuals: &[ChannelResidual]) -> Option<Finding> {
    let limit = FAMILY_ALPHA / residuals.len().max(1) as f64;
    let bad: Vec<&ChannelResidual> = residuals
        .iter()
        .filter(|r| r.whiteness_p.is_nan() || r.whiteness_p < limit)
        .collect();
    if bad.is_empty() {
        return None;
    }
    let list: Vec<String> = bad
        .iter()
        .map(|r| format!("{} (p {})", name(r), g3(r.whiteness_p)))
        .collect();
    Some(
        Finding::new(
            Severity::Warn,
            "residuals_not_white",
            format!(
                "{} of {} channel axes keep structure in their residuals (Ljung-Box, {} lags, p < {}): {}; the model lacks something (`flexcal diagnose` looks for what)",
                bad.len(),
                residuals.len(),
                crate::calib::residuals::LAGS,
                g3(limit),
                list.join(", ")
            ),
        )
        .num("p_limit", limit)
        .val(
            "channels",
            json!(bad
                .iter()
                .map(|r| json!({"channel": name(r), "p": r.whiteness_p, "q": r.ljung_box_q}))
                .collect::<Vec<_>>()),
        ),
    )
}

fn gated(cfg: &CalibConfig, res: &CalibResult) -> Option<Finding> {
    let (n, g) = (res.summary.total, res.summary.gated);
    let frac = g as f64 / n.max(1) as f64;
    let sev = if frac > GATED_FAIL {
        Severity::Fail
    } else if frac > GATED_WARN {
        Severity::Warn
    } else {
        return None;
    };
    let first = res.summary.first_gated_t.unwrap_or(f64::NAN);
    Some(
        Finding::new(
            sev,
            "gated_fraction_high",
            format!(
                "{g} of {n} innovations ({:.2}%) were rejected by the {}σ gate, the first at t = {} s: the data do not follow the model there",
                100.0 * frac,
                g3(cfg.gate_sigma),
                g3(first)
            ),
        )
        .num("gated", g as f64)
        .num("innovations", n as f64)
        .num("first_t_s", first),
    )
}

/// σ not falling on a state the matching observes, and estimates beyond their prior.
fn sigma_and_prior(cfg: &CalibConfig, res: &CalibResult) -> Vec<Finding> {
    let m = cfg.matching_flags();
    let attitude = m.attitude || m.angular_rate;
    let observed = [attitude, m.velocity, attitude];
    let prior = [
        cfg.initial_gyro_bias_radps,
        cfg.initial_accel_bias_mps2,
        cfg.initial_misalignment_rad,
    ];
    let last = res.last();
    let values = [last.gyro_bias, last.accel_bias, last.misalignment];
    let sigmas = [
        last.gyro_bias_sigma,
        last.accel_bias_sigma,
        last.misalignment_sigma,
    ];
    let units = [GYRO_BIAS, ACCEL_BIAS, ANGLE];
    // The misalignment's prior is centred on the mounting the filter started from (the
    // representation of that rotation nearest the estimate: a half turn has two).
    let mounting = crate::calib::mounting::nearest_equivalent(
        cfg.mounting_estimate_rad.unwrap_or([0.0; 3]),
        last.misalignment,
    );
    let centres = [[0.0; 3], [0.0; 3], mounting];
    let mut out = Vec::new();
    for q in 0..3 {
        for a in 0..3 {
            let (x, s, s0) = (values[q][a], sigmas[q][a], prior[q]);
            let c = centres[q][a];
            let what = format!("{} {}", STATES[q], AXES[a]);
            let u = units[q];
            if observed[q] && s > SIGMA_FALL * s0 {
                out.push(
                    Finding::new(
                        Severity::Warn,
                        "sigma_not_falling",
                        format!(
                            "{what}: σ {} is still {:.0}% of its prior {}, though the matching ({}) observes it: the motion did not excite it, or the run was too short",
                            show(s, u),
                            100.0 * s / s0,
                            show(s0, u),
                            cfg.matching.join(", ")
                        ),
                    )
                    .at(what.clone())
                    .num("sigma", s)
                    .num("prior_sigma", s0),
                );
            }
            if (x - c).abs() > PRIOR_SIGMAS * s0 {
                out.push(
                    Finding::new(
                        Severity::Warn,
                        "estimate_beyond_prior",
                        format!(
                            "{what}: estimate {} is {} prior σ from {} (prior σ {}): the configuration's sensor grade does not fit this sensor",
                            show(x, u),
                            g3((x - c).abs() / s0),
                            if c == 0.0 { "0".to_string() } else { show(c, u) },
                            show(s0, u)
                        ),
                    )
                    .at(what)
                    .num("estimate", x)
                    .num("prior_sigma", s0),
                );
            }
        }
    }
    out
}

/// Covariance and filter health events.
fn health(res: &CalibResult) -> Vec<Finding> {
    let h = &res.health;
    let c = &res.covariance;
    let mut out = Vec::new();
    for (n, sev, code, what) in [
        (
            c.not_positive_definite as u32,
            Severity::Fail,
            "covariance_not_pd",
            "checks found the covariance not positive definite",
        ),
        (
            h.non_finite,
            Severity::Fail,
            "non_finite",
            "filter steps were refused for non-finite inputs or results",
        ),
        (
            h.bad_innovation_variance,
            Severity::Warn,
            "bad_innovation_variance",
            "updates were refused for a non-positive innovation variance",
        ),
        (
            h.variance_clamped,
            Severity::Warn,
            "variance_clamped",
            "variances fell below their floor and were clamped",
        ),
    ] {
        if n > 0 {
            out.push(
                Finding::new(sev, code, format!("{n} {what}"))
                    .num("count", n as f64)
                    .num("checks", c.checks as f64),
            );
        }
    }
    out
}
