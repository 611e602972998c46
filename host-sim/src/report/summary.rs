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
    /// The row being set out, its allocation kept from row to row.
    line: Vec<u8>,
}

/// The file's buffer: 31 MB for a 600 s run leave it in about a hundred writes
/// instead of four thousand at the default 8 KiB.
const ESTIMATES_BUFFER: usize = 1 << 18;

impl EstimatesCsv {
    /// Creates the file and writes its header.
    pub fn create(path: &Path) -> std::io::Result<Self> {
        let mut f =
            std::io::BufWriter::with_capacity(ESTIMATES_BUFFER, std::fs::File::create(path)?);
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
        Ok(Self {
            f,
            line: Vec::with_capacity(24 * 24 + 1),
        })
    }

    /// Writes one row: `t` as `{}` writes it, every other number as `{:e}` does
    /// ([`push_exp`]: the same bytes, in a fifth of the time).
    pub fn row(&mut self, r: &EstimateRow) -> std::io::Result<()> {
        write!(self.f, "{}", r.t)?;
        let line = &mut self.line;
        line.clear();
        for (_, get) in FIELDS {
            let (v, s) = get(r);
            for &x in v.iter().chain(s.iter()) {
                line.push(b',');
                push_exp(line, x);
            }
        }
        line.push(b'\n');
        self.f.write_all(line)
    }

    /// Flushes the file.
    pub fn finish(mut self) -> std::io::Result<()> {
        self.f.flush()
    }
}

/// Appends `x` as `format!("{x:e}")` writes it: the shortest digits that read back as
/// `x`, in scientific notation (`-1.25e-7`, `3e0`, `0e0`, `NaN`, `inf`). The digits come
/// from `zmij` (Schubfach: the shortest round-trip digits, the nearest to `x` among
/// them, as the standard library's), set out in `{:e}`'s notation; `write!` through the
/// formatting machinery took a fifth of a 600 s `calibrate` (estimates.csv has 24 such
/// numbers a row, a row per filter update). The test below holds the two to the byte.
///
/// Where `x` lies exactly halfway between two candidates of the shortest length the two
/// part (the standard library rounds such a tie up, zmij to even: `662936471232937.25`
/// is `6.629364712329373e14` to the one, `…372e14` to the other). A tie needs `x`'s
/// exact decimal expansion to end within 18 significant digits; for `x = m 2^q`, `m`
/// odd, `q < 0`, that expansion has the digits of `m 5^−q`, more than 18 of them once
/// `m 5^−q ≥ 10^18`. Every other `x` (integers, large and short binary fractions) is
/// written by `write!` (never one of estimates.csv's, whose magnitudes are below 1).
pub fn push_exp(out: &mut Vec<u8>, x: f64) {
    if !x.is_finite() || x == 0.0 || !no_tie(x) {
        let _ = write!(out, "{x:e}");
        return;
    }
    let mut buf = zmij::Buffer::new();
    let text = buf.format_finite(x).as_bytes();
    let (negative, text) = match text.split_first() {
        Some((b'-', rest)) => (true, rest),
        _ => (false, text),
    };
    // zmij writes `ddd.ddd`, `0.000ddd` or `d.ddde±N`.
    let (mantissa, mut exp) = match text.iter().position(|&b| b == b'e') {
        Some(at) => match parse_exp(&text[at + 1..]) {
            // `d` or `d.ddd` (no trailing zero: the digits are the shortest), as `{:e}`
            // writes it; only the exponent differs (`e-06` against `e-6`).
            Some(e) if text.first().is_some_and(|d| (b'1'..=b'9').contains(d)) => {
                if negative {
                    out.push(b'-');
                }
                out.extend_from_slice(&text[..at]);
                push_exponent(out, e);
                return;
            }
            Some(e) => (&text[..at], e),
            None => {
                let _ = write!(out, "{x:e}");
                return;
            }
        },
        None => (text, 0),
    };
    let point = mantissa
        .iter()
        .position(|&b| b == b'.')
        .unwrap_or(mantissa.len());
    let mut digits = [0u8; 40];
    let mut n = 0;
    let mut lead = true;
    for (k, &b) in mantissa.iter().enumerate() {
        if b == b'.' {
            continue;
        }
        if lead && b == b'0' {
            continue;
        }
        if lead {
            // The first significant digit's power of ten.
            exp += if k < point {
                (point - k - 1) as i32
            } else {
                -((k - point) as i32)
            };
            lead = false;
        }
        if let Some(d) = digits.get_mut(n) {
            *d = b;
            n += 1;
        }
    }
    while n > 1 && digits[n - 1] == b'0' {
        n -= 1;
    }
    if n == 0 {
        let _ = write!(out, "{x:e}");
        return;
    }
    if negative {
        out.push(b'-');
    }
    out.push(digits[0]);
    if n > 1 {
        out.push(b'.');
        out.extend_from_slice(&digits[1..n]);
    }
    push_exponent(out, exp);
}

/// `e` and `exp` as `{:e}` writes them (`e-7`, `e12`, `e0`).
fn push_exponent(out: &mut Vec<u8>, exp: i32) {
    out.push(b'e');
    if exp < 0 {
        out.push(b'-');
    }
    let e = exp.unsigned_abs();
    if e >= 100 {
        out.push(b'0' + (e / 100) as u8);
    }
    if e >= 10 {
        out.push(b'0' + (e / 10 % 10) as u8);
    }
    out.push(b'0' + (e % 10) as u8);
}

/// `±N` (zmij's exponent) as a number; `None` if it is not one.
fn parse_exp(text: &[u8]) -> Option<i32> {
    let (negative, digits) = match text.split_first()? {
        (b'-', rest) => (true, rest),
        (b'+', rest) => (false, rest),
        _ => (false, text),
    };
    if digits.is_empty() || digits.len() > 4 {
        return None;
    }
    let mut e = 0i32;
    for &d in digits {
        if !d.is_ascii_digit() {
            return None;
        }
        e = e * 10 + i32::from(d - b'0');
    }
    Some(if negative { -e } else { e })
}

/// Whether `x` (finite, not zero) has more than 18 significant digits in its exact
/// decimal expansion ([`push_exp`]): `m 5^−q ≥ 10^18` for `x = ±m 2^q`, `m` odd, `q < 0`,
/// checked as `⌊log₂ m⌋ + (−q) log₂ 5 ≥ 60` (log₂ 10¹⁸ = 59.79).
fn no_tie(x: f64) -> bool {
    const LOG2_5: f64 = 2.321_928_094_887_362;
    let bits = x.to_bits();
    let biased = ((bits >> 52) & 0x7ff) as i32;
    let frac = bits & ((1u64 << 52) - 1);
    let (m, q) = if biased == 0 {
        (frac, -1074)
    } else {
        (frac | (1u64 << 52), biased - 1075)
    };
    if m == 0 {
        return false;
    }
    let tz = m.trailing_zeros();
    let (m, q) = (m >> tz, q + tz as i32);
    q < 0 && f64::from(63 - m.leading_zeros()) + f64::from(-q) * LOG2_5 >= 60.0
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

#[cfg(test)]
mod tests {
    use super::push_exp;

    fn check(x: f64) {
        let mut out = Vec::new();
        push_exp(&mut out, x);
        assert_eq!(
            String::from_utf8(out).unwrap(),
            format!("{x:e}"),
            "{:#x}",
            x.to_bits()
        );
    }

    #[test]
    fn push_exp_writes_what_format_e_writes() {
        for x in [
            0.0,
            -0.0,
            1.0,
            -1.0,
            10.0,
            0.1,
            0.01,
            123.0,
            1234.5,
            1e7,
            1e15,
            1e16,
            1e17,
            1.5e-5,
            1e-5,
            1e-6,
            1e-7,
            1e22,
            1e23,
            5e-324,
            f64::MIN_POSITIVE,
            f64::MAX,
            f64::MIN,
            f64::EPSILON,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            0.3,
            2.0 / 3.0,
            9.80665,
            4.847539298591189e-6,
        ] {
            check(x);
        }
        // Random bit patterns (every exponent), and numbers of estimates.csv's range.
        let mut s = 0x9e37_79b9_7f4a_7c15_u64;
        for k in 0..200_000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let x = f64::from_bits(s);
            check(x);
            let y = (s >> 11) as f64 / (1u64 << 53) as f64;
            check(y * 10f64.powi((k % 30) - 20));
            check(-y * 10f64.powi((k % 9) - 3) / 7.0);
        }
    }
}
