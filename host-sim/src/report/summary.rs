//! `summary.json` and `estimates.csv` of `flexcal calibrate`.

use crate::calib::config::CalibConfig;
use crate::calib::run::{CalibResult, EstimateRow};
use crate::calib::score::Score;
use crate::cmd::TOOL_VERSION;
use serde_json::{json, Value};
use std::io::Write;
use std::path::Path;

/// The final covariance of the nine calibrated quantities, with their order and units:
/// the σ beside each estimate leave out the correlations (a horizontal accelerometer bias
/// and the tilt it mimics, a gyro bias and the heading it drifts), which decide how far a
/// combination of the estimates can be trusted and what the NEES weighs.
fn calibrated_covariance(p: &nalgebra::SMatrix<f64, 9, 9>) -> Value {
    let rows: Vec<[f64; 9]> = (0..9).map(|i| std::array::from_fn(|j| p[(i, j)])).collect();
    json!({
        "order": ["gyro_bias_x", "gyro_bias_y", "gyro_bias_z",
                  "accel_bias_x", "accel_bias_y", "accel_bias_z",
                  "misalignment_x", "misalignment_y", "misalignment_z"],
        "units": ["rad/s", "rad/s", "rad/s", "m/s^2", "m/s^2", "m/s^2", "rad", "rad", "rad"],
        "matrix": rows,
    })
}

/// The `summary.json` document of one calibration; `flexure_source` says where the
/// flexure model came from (configured, or identified from the recording).
pub fn summary_json(
    recording: &str,
    duration_s: f64,
    cfg: &CalibConfig,
    flexure_source: &str,
    res: &CalibResult,
    score: Option<&Score>,
) -> Value {
    let last = res.last();
    let gated = res.summary.gated;
    let accepted = res.summary.total - gated;
    let matching: Vec<&str> = crate::calib::run::CHANNELS
        .iter()
        .zip([
            cfg.matching_flags().velocity,
            cfg.matching_flags().attitude,
            cfg.matching_flags().angular_rate,
        ])
        .filter(|(_, on)| *on)
        .map(|(n, _)| *n)
        .collect();
    let mut v = json!({
        "tool_version": TOOL_VERSION,
        "recording": recording,
        "duration_s": duration_s,
        "precision": res.precision,
        "model": {
            "states": cfg.augmentation::<f64>().map_or(flexcal_core::model::N, |a| a.dimension()),
            "effects": cfg.effects,
            "matching": matching,
            "dynamic_lever_arm": cfg.dynamic_lever_arm,
            "flexure_ar_order": cfg.flexure_orders().into_iter().max().unwrap_or(0),
            "flexure_ar_orders": cfg.flexure_orders(),
            "flexure_models": match cfg.flexure_gauss_markov {
                Some(gm) => gm.map(|[w, z, s]| json!({"kind": "second_order_gauss_markov", "omega_rad_s": w, "damping": z, "sigma_rad": s})),
                None => cfg.flexure_axes.unwrap_or([[cfg.flexure_ar[0], cfg.flexure_ar[1], cfg.flexure_sigma_rad]; 3])
                    .map(|[a1, a2, s]| json!({"kind": "ar", "coefficients": [a1, a2], "sigma_rad": s})),
            },
            "flexure_source": flexure_source,
            "lever_arm_bending": cfg.bending,
        },
        "gyro_bias": last.gyro_bias, "gyro_bias_sigma": last.gyro_bias_sigma,
        "accel_bias": last.accel_bias, "accel_bias_sigma": last.accel_bias_sigma,
        "misalignment": last.misalignment, "misalignment_sigma": last.misalignment_sigma,
        "calibrated_covariance": calibrated_covariance(&res.final_cov9),
        "innovations": {
            "count": accepted,
            "nis_mean": res.nis_mean(),
            "nis_band": nis_band(accepted),
            "gated": gated,
        },
        "residuals": res.summary.residuals(),
        "inputs": {
            "imu_samples": res.counters.imu_samples,
            "master_matched": res.counters.master_matched,
            "master_stale": res.counters.master_stale,
            "master_out_of_order": res.counters.master_out_of_order,
            "master_dropped": res.counters.master_dropped,
            "master": res.master,
            "master_lost": res.master.map(|m| m.lost()),
        },
        "health": {
            "non_finite": res.health.non_finite,
            "variance_clamped": res.health.variance_clamped,
            "bad_innovation_variance": res.health.bad_innovation_variance,
            "max_gated_streak": res.health.max_gated_streak,
            "filter_resets": res.counters.resets,
        },
        "covariance": {
            "checks": res.covariance.checks,
            "not_positive_definite": res.covariance.not_positive_definite,
            "max_asymmetry_scaled": res.covariance.max_asymmetry,
            "min_diagonal_scaled": res.covariance.min_diagonal,
        },
    });
    if let Some(obj) = v.as_object_mut() {
        if !res.effect_rows.is_empty() {
            obj.insert("effects".into(), effects_json(res));
        }
        if let Some(s) = score {
            obj.insert("errors".into(), json!(s));
        }
    }
    v
}

/// What became of the master messages, in lines for the printed summary: the
/// account, then a warning when any message handed to the engine was lost (made no
/// update and started nothing).
pub fn master_lines(res: &CalibResult) -> Vec<String> {
    let Some(m) = res.master else {
        return Vec::new();
    };
    let mut out = vec![format!(
        "master messages: {} given, {} matched, {} started the solution; lost: {} dropped by the {}-message queue, {} due but unmatched, {} left queued, {} stale, {} out of order, {} non-finite; outside the slave's samples: {} before, {} after",
        m.given,
        m.matched,
        m.initialized,
        m.dropped_by_queue,
        flexcal_core::engine::PENDING_DEPTH,
        m.unmatched,
        m.left_pending,
        m.stale,
        m.out_of_order,
        m.non_finite,
        m.before_slave_start,
        m.after_slave_end
    )];
    if m.lost() > 0 {
        out.push(format!(
            "WARNING: {} of {} master messages ({:.1}%) made no filter update: see the counts above",
            m.lost(),
            m.given,
            100.0 * f64::from(m.lost()) / f64::from(m.given.max(1))
        ));
    }
    out
}

/// The final estimate of each augmented effect: name, unit, values, σ and the Wald
/// statistic of its block.
pub fn effects_json(res: &CalibResult) -> Value {
    res.final_effects()
        .iter()
        .map(|e| {
            json!({
                "name": e.effect.name(),
                "unit": e.effect.unit(),
                "estimate": e.value,
                "sigma": e.sigma,
                "wald": e.wald,
            })
        })
        .collect()
}

/// 95% band of the mean NIS of `n` scalar innovations of a consistent filter.
fn nis_band(n: usize) -> [f64; 2] {
    if n == 0 {
        return [0.0, 0.0];
    }
    let n = n as f64;
    [
        flexcal_core::stats::chi2_quantile(0.025, n) / n,
        flexcal_core::stats::chi2_quantile(0.975, n) / n,
    ]
}

/// `estimates.csv` being written, one row per filter update as the run goes.
pub struct EstimatesCsv {
    f: std::io::BufWriter<std::fs::File>,
}

impl EstimatesCsv {
    /// Creates the file and writes its header.
    pub fn create(path: &Path) -> std::io::Result<Self> {
        let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
        let mut header = vec!["t".to_string()];
        for (p, _) in FIELDS {
            for a in ["x", "y", "z"] {
                header.push(format!("{p}{a}"));
            }
            for a in ["x", "y", "z"] {
                header.push(format!("{p}{a}_sigma"));
            }
        }
        writeln!(f, "{}", header.join(","))?;
        Ok(Self { f })
    }

    /// Writes one row.
    pub fn row(&mut self, r: &EstimateRow) -> std::io::Result<()> {
        write!(self.f, "{}", r.t)?;
        for (_, get) in FIELDS {
            let (v, s) = get(r);
            for x in v.iter().chain(s.iter()) {
                write!(self.f, ",{x:e}")?;
            }
        }
        writeln!(self.f)
    }

    /// Flushes the file.
    pub fn finish(mut self) -> std::io::Result<()> {
        self.f.flush()
    }
}

/// Writes `estimates.csv` from rows held in memory.
pub fn write_estimates_csv(path: &Path, rows: &[EstimateRow]) -> std::io::Result<()> {
    let mut csv = EstimatesCsv::create(path)?;
    for r in rows {
        csv.row(r)?;
    }
    csv.finish()
}

type Getter = fn(&EstimateRow) -> ([f64; 3], [f64; 3]);

/// Column prefixes of estimates.csv with their getters.
pub const FIELDS: [(&str, Getter); 4] = [
    ("bg", |r| (r.gyro_bias, r.gyro_bias_sigma)),
    ("ba", |r| (r.accel_bias, r.accel_bias_sigma)),
    ("mu", |r| (r.misalignment, r.misalignment_sigma)),
    ("th", |r| (r.flexure, r.flexure_sigma)),
];
