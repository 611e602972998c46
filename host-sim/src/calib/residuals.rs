//! What the innovations of a calibration say about the model: per matching channel
//! and axis, the mean normalized innovation squared against its χ² band and the
//! Ljung-Box whiteness of the whitened innovations. A consistent, complete model
//! gives NIS means inside their bands and white innovations; structure left in them
//! is the trace of an effect the model lacks (the starting point of `diagnose`).

use super::run::{Innovation, CHANNELS};
use flexcal_core::ident::ljung_box;
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

/// Residual statistics of every channel axis present.
pub fn channel_residuals(innovations: &[Innovation]) -> Vec<ChannelResidual> {
    let mut out = Vec::new();
    for (channel, name) in CHANNELS.iter().enumerate() {
        for axis in 0..3 {
            let w: Vec<f64> = innovations
                .iter()
                .filter(|i| {
                    i.channel == channel && i.axis == axis && i.accepted && i.variance > 0.0
                })
                .map(|i| i.value / i.variance.sqrt())
                .collect();
            if w.len() <= LAGS {
                continue;
            }
            let n = w.len() as f64;
            let nis_mean = w.iter().map(|v| v * v).sum::<f64>() / n;
            let (q, p, white) = match ljung_box(&w, LAGS, 0, ALPHA) {
                Ok(lb) => (lb.q, chi2_sf(lb.q, LAGS as f64), lb.white),
                Err(_) => (f64::NAN, f64::NAN, false),
            };
            out.push(ChannelResidual {
                channel: name,
                axis,
                count: w.len(),
                nis_mean,
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
