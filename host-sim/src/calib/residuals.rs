//! What the innovations of a calibration say about the model: per matching channel
//! and axis, the mean normalized innovation squared against its χ² band and the
//! Ljung-Box whiteness of the whitened innovations. A consistent, complete model
//! gives NIS means inside their bands and white innovations; structure left in them
//! is the trace of an effect the model lacks (the starting point of `diagnose`).
//! Everything is gathered one innovation at a time ([`InnovationSummary`]), so a run
//! of any length is judged without keeping its innovations.

use super::run::{Innovation, CHANNELS};
use flexcal_core::ident::LjungBoxAccumulator;
use flexcal_core::stats::{chi2_quantile, chi2_sf};
use serde::Serialize;

/// Ljung-Box lags used on the innovations.
pub const LAGS: usize = 20;
/// Significance level of the whiteness test and the NIS band (two-sided 95%).
pub const ALPHA: f64 = 0.05;

/// The residual statistics of one channel axis.
#[derive(Clone, Debug, Serialize)]
pub struct ChannelResidual {
    /// Channel name (`velocity`, `attitude`, `angular_rate`).
    pub channel: &'static str,
    /// Axis 0..3 (ENU for velocity, slave body for the others).
    pub axis: usize,
    /// Accepted innovations.
    pub count: usize,
    /// Mean of ν²/s over them (1 for a consistent filter).
    pub nis_mean: f64,
    /// 95% band of that mean: χ²(count) quantiles / count.
    pub nis_band: [f64; 2],
    /// Ljung-Box statistic of the whitened innovations ν/√s.
    pub ljung_box_q: f64,
    /// Its p-value (χ²(LAGS)); small means structure left in the innovations.
    pub whiteness_p: f64,
    /// Whether whiteness is accepted at level `ALPHA`.
    pub white: bool,
}

/// What the innovations of a run add up to, gathered one innovation at a time in
/// fixed memory: counts, the overall NIS and likelihood, and per channel axis the
/// sums of the NIS and of the Ljung-Box test ([`LjungBoxAccumulator`], the same sums
/// as `flexcal_core::ident::ljung_box` over the whole sequence).
#[derive(Clone, Debug, Default)]
pub struct InnovationSummary {
    /// Scalar innovations, gated or not.
    pub total: usize,
    /// Innovations rejected by the gate.
    pub gated: usize,
    /// Time of the first innovation rejected by the gate (s).
    pub first_gated_t: Option<f64>,
    accepted_nis_sum: f64,
    neg2ll: f64,
    axes: [[AxisSums; 3]; 3],
}

/// The whitened innovations `ν/√s` of one channel axis (accepted, `s > 0`).
#[derive(Clone, Debug, Default)]
struct AxisSums {
    count: usize,
    nis_sum: f64,
    non_finite: bool,
    ljung_box: LjungBoxAccumulator<f64, LAGS>,
}

impl InnovationSummary {
    /// The summary of a whole sequence.
    pub fn of(innovations: &[Innovation]) -> Self {
        let mut s = Self::default();
        for i in innovations {
            s.push(i);
        }
        s
    }

    /// Adds one scalar innovation.
    pub fn push(&mut self, i: &Innovation) {
        self.total += 1;
        self.neg2ll += i.variance.ln() + i.value * i.value / i.variance;
        if !i.accepted {
            self.gated += 1;
            self.first_gated_t.get_or_insert(i.t);
            return;
        }
        self.accepted_nis_sum += i.value * i.value / i.variance;
        let Some(axis) = self.axes.get_mut(i.channel).and_then(|c| c.get_mut(i.axis)) else {
            return;
        };
        if i.variance > 0.0 {
            let w = i.value / i.variance.sqrt();
            axis.count += 1;
            axis.nis_sum += w * w;
            axis.non_finite |= !axis.ljung_box.push(w);
        }
    }

    /// Mean normalized innovation squared over the accepted innovations (expect 1); 0
    /// when none was accepted.
    pub fn nis_mean(&self) -> f64 {
        let accepted = self.total - self.gated;
        if accepted == 0 {
            0.0
        } else {
            self.accepted_nis_sum / accepted as f64
        }
    }

    /// −2 log-likelihood of the innovations (up to the constant `n ln 2π`):
    /// `Σ ln s + ν²/s` over every scalar innovation, gated or not.
    pub fn neg2_log_likelihood(&self) -> f64 {
        self.neg2ll
    }

    /// Residual statistics of every channel axis with more than [`LAGS`] innovations.
    pub fn residuals(&self) -> Vec<ChannelResidual> {
        let mut out = Vec::new();
        for (name, axes) in CHANNELS.iter().zip(&self.axes) {
            for (axis, sums) in axes.iter().enumerate() {
                if sums.count <= LAGS {
                    continue;
                }
                let n = sums.count as f64;
                let lb = if sums.non_finite {
                    None
                } else {
                    sums.ljung_box.result(0, ALPHA).ok()
                };
                let (q, p, white) = match lb {
                    Some(lb) => (lb.q, chi2_sf(lb.q, LAGS as f64), lb.white),
                    None => (f64::NAN, f64::NAN, false),
                };
                out.push(ChannelResidual {
                    channel: name,
                    axis,
                    count: sums.count,
                    nis_mean: sums.nis_sum / n,
                    nis_band: [
                        chi2_quantile(ALPHA / 2.0, n) / n,
                        chi2_quantile(1.0 - ALPHA / 2.0, n) / n,
                    ],
                    ljung_box_q: q,
                    whiteness_p: p,
                    white,
                });
            }
        }
        out
    }
}

/// Residual statistics of every channel axis present.
pub fn channel_residuals(innovations: &[Innovation]) -> Vec<ChannelResidual> {
    InnovationSummary::of(innovations).residuals()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_distr::StandardNormal;

    fn innovations(values: &[f64]) -> Vec<Innovation> {
        values
            .iter()
            .enumerate()
            .map(|(k, &v)| Innovation {
                t: k as f64,
                channel: 0,
                axis: 0,
                value: 2.0 * v,
                variance: 4.0,
                accepted: true,
            })
            .collect()
    }

    #[test]
    fn one_at_a_time_equals_the_whole_sequence() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let x: Vec<f64> = (0..3000)
            .map(|k| rng.sample::<f64, _>(StandardNormal) + 0.3 * (k as f64 * 0.1).sin())
            .collect();
        let r = &channel_residuals(&innovations(&x))[0];
        let whole = flexcal_core::ident::ljung_box(&x, LAGS, 0, ALPHA).unwrap();
        assert!(
            (r.ljung_box_q - whole.q).abs() <= 1e-9 * whole.q,
            "{r:?} {whole:?}"
        );
        let nis = x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64;
        assert!((r.nis_mean - nis).abs() <= 1e-12 * nis, "{r:?}");
    }

    #[test]
    fn white_consistent_innovations_pass_and_structure_fails() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let white: Vec<f64> = (0..5000).map(|_| rng.sample(StandardNormal)).collect();
        let r = &channel_residuals(&innovations(&white))[0];
        assert!(
            r.white && r.nis_mean > r.nis_band[0] && r.nis_mean < r.nis_band[1],
            "{r:?}"
        );
        // A slow sinusoid added: not white any more.
        let coloured: Vec<f64> = white
            .iter()
            .enumerate()
            .map(|(k, v)| v + 0.5 * (k as f64 * 0.05).sin())
            .collect();
        let r = &channel_residuals(&innovations(&coloured))[0];
        assert!(!r.white && r.whiteness_p < 1e-6, "{r:?}");
        // Too small variances: NIS above its band.
        let big: Vec<f64> = white.iter().map(|v| 1.5 * v).collect();
        let r = &channel_residuals(&innovations(&big))[0];
        assert!(r.nis_mean > r.nis_band[1], "{r:?}");
    }
}
