//! The verdict of a Monte Carlo: is the filter's σ right over many seeds? The mean NEES
//! of the 9 calibrated states against the χ² band of the mean, each state's RMS of the
//! error over σ (run by run) against its χ² bound for the number of runs, and the single runs whose NEES is
//! outside the single-run χ²(9) band. Thresholds: `docs/verdict.md`.

use super::{g3, Finding, Severity};
use flexcal_core::stats::chi2_quantile;
use serde_json::json;

/// Family-wise level of the RMS/σ tests over the 9 states.
pub const RATIO_ALPHA: f64 = 0.01;

/// The largest RMS error over σ that a consistent filter exceeds on any of the 9
/// states with probability `RATIO_ALPHA` over `n` runs: (RMS/σ)² is χ²(n)/n, tested
/// at `RATIO_ALPHA` / 9 each (Bonferroni). 1.50 for 20 runs, 1.31 for 50.
pub fn ratio_bound(n: usize) -> f64 {
    let n = n.max(1) as f64;
    (chi2_quantile(1.0 - RATIO_ALPHA / 9.0, n) / n).sqrt()
}
/// Two-sided level of the single-run NEES band.
pub const SINGLE_RUN_ALPHA: f64 = 0.01;
/// Mean NEES above this multiple of its band's upper end: FAIL (σ too small by > √2).
pub const NEES_FAIL_FACTOR: f64 = 2.0;

/// The single-run band of a χ²(9) NEES at `SINGLE_RUN_ALPHA`.
pub fn single_run_band() -> [f64; 2] {
    [
        chi2_quantile(SINGLE_RUN_ALPHA / 2.0, 9.0),
        chi2_quantile(1.0 - SINGLE_RUN_ALPHA / 2.0, 9.0),
    ]
}

/// Findings of a Monte Carlo: `nees` per run (with its seed), the band of the mean,
/// and per state its name and RMS of error over σ.
pub fn check(
    seeds_nees: &[(u64, f64)],
    mean_band: [f64; 2],
    ratios: &[(&str, f64)],
) -> Vec<Finding> {
    let mut out = Vec::new();
    let n = seeds_nees.len();
    let mean = seeds_nees.iter().map(|r| r.1).sum::<f64>() / n.max(1) as f64;
    if !(mean_band[0]..=mean_band[1]).contains(&mean) {
        let sev = if mean > NEES_FAIL_FACTOR * mean_band[1] || !mean.is_finite() {
            Severity::Fail
        } else {
            Severity::Warn
        };
        out.push(
            Finding::new(
                sev,
                "nees_out_of_band",
                format!(
                    "mean NEES {} of {n} runs is outside the 95% band of the mean [{}, {}]: the filter's σ is {}",
                    g3(mean),
                    g3(mean_band[0]),
                    g3(mean_band[1]),
                    if mean > mean_band[1] { "too small (overconfident)" } else { "too large (pessimistic)" }
                ),
            )
            .num("nees_mean", mean)
            .num("band_lo", mean_band[0])
            .num("band_hi", mean_band[1]),
        );
    }
    let bound = ratio_bound(n);
    let over: Vec<(&str, f64)> = ratios
        .iter()
        .filter(|(_, r)| r.is_nan() || *r > bound)
        .copied()
        .collect();
    if !over.is_empty() {
        let list: Vec<String> = over
            .iter()
            .map(|(s, r)| format!("{s} {}", g3(*r)))
            .collect();
        out.push(
            Finding::new(
                Severity::Warn,
                "rms_over_sigma",
                format!(
                    "RMS of error over σ above {} (what a consistent filter exceeds on one of the 9 states once in 100 Monte Carlos of {n} runs) on {}: {}",
                    g3(bound),
                    over.len(),
                    list.join(", ")
                ),
            )
            .num("bound", bound)
            .val(
                "states",
                json!(over
                    .iter()
                    .map(|(s, r)| json!({"state": s, "ratio": r}))
                    .collect::<Vec<_>>()),
            ),
        );
    }
    let band = single_run_band();
    let outside: Vec<(u64, f64)> = seeds_nees
        .iter()
        .filter(|(_, v)| !(band[0]..=band[1]).contains(v))
        .copied()
        .collect();
    // Expected: SINGLE_RUN_ALPHA of the runs; more than twice that plus 2 is a WARN
    // (for 50 runs: 4 or more, which a consistent filter gives with probability 0.002).
    let expected = SINGLE_RUN_ALPHA * n as f64;
    if !outside.is_empty() {
        let sev = if outside.len() as f64 > 2.0 * expected + 2.0 {
            Severity::Warn
        } else {
            Severity::Note
        };
        out.push(
            Finding::new(
                sev,
                "single_run_nees",
                format!(
                    "{} of {n} runs have a NEES outside the single-run χ²(9) band [{}, {}] (expected {}): seeds {}",
                    outside.len(),
                    g3(band[0]),
                    g3(band[1]),
                    g3(expected),
                    outside.iter().map(|(s, _)| s.to_string()).collect::<Vec<_>>().join(", ")
                ),
            )
            .num("outside", outside.len() as f64)
            .num("expected", expected)
            .num("band_lo", band[0])
            .num("band_hi", band[1]),
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ratio_bound_shrinks_with_runs() {
        let (b20, b50) = (ratio_bound(20), ratio_bound(50));
        // χ²(20) and χ²(50) quantiles at 1 − 0.01/9 are 44.98 and 86.21.
        assert!(
            (b20 - 1.4997).abs() < 0.001 && (b50 - 1.3131).abs() < 0.001,
            "{b20} {b50}"
        );
    }
}
