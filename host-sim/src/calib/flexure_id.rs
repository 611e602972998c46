//! Identifying the filter's flexure model from the recording itself (issue 3): the
//! rate-integrated flexure sequence at the filter period, an AR fit per axis of at
//! most the order the filter's flexure block carries (2), order by AIC, refined by
//! exact maximum likelihood, checked by Ljung-Box.

use super::config::CalibConfig;
use crate::identify::sequence::SequenceKind;
use crate::identify::{flexure_sequence, identify_series, IdentifyOptions};
use crate::recording::Recording;
use serde::Serialize;

/// The largest AR order the filter's flexure block carries (θ, θ̇ per axis).
pub const FILTER_MAX_ORDER: usize = 2;

/// What identification found on one axis.
#[derive(Clone, Debug, Serialize)]
pub struct AxisModel {
    /// Selected order (≤ 2).
    pub order: usize,
    /// `[a1, a2]` (zeros beyond the order).
    pub coefficients: [f64; 2],
    /// σ of the driving noise (rad).
    pub sigma_rad: f64,
    /// Whether the residuals passed the Ljung-Box test.
    pub white: bool,
}

/// The identified flexure model of the three axes.
#[derive(Clone, Debug, Serialize)]
pub struct IdentifiedFlexure {
    /// Per axis (slave body x, y, z).
    pub axes: [AxisModel; 3],
    /// The sequence identified from.
    pub sequence: &'static str,
}

/// Identifies the flexure model of `rec` at the configuration's filter period.
pub fn identify_flexure(rec: &Recording, cfg: &CalibConfig) -> Result<IdentifiedFlexure, String> {
    let kind = SequenceKind::RateIntegrated;
    let seq = flexure_sequence(rec, kind, cfg.filter_period_s)?;
    let opts = IdentifyOptions {
        max_order: FILTER_MAX_ORDER,
        ..IdentifyOptions::default()
    };
    let mut axes = Vec::with_capacity(3);
    for (axis, x) in seq.axes.iter().enumerate() {
        let rep = identify_series(x, &opts)
            .map_err(|e| format!("flexure identification, axis {axis}: {e}"))?;
        let row = rep.selected().ok_or_else(|| {
            format!("flexure identification, axis {axis}: no order could be fitted")
        })?;
        // The exact-ML refinement of the selected order when it converged, else the LS fit.
        let (coefs, sigma2) = match &rep.exact_ml {
            Some(ml) if ml.coefficients.len() == row.coefficients.len() => {
                (ml.coefficients.clone(), ml.sigma2)
            }
            _ => (row.coefficients.clone(), row.sigma2),
        };
        let mut c = [0.0; 2];
        for (slot, v) in c.iter_mut().zip(&coefs) {
            *slot = *v;
        }
        axes.push(AxisModel {
            order: row.p,
            coefficients: c,
            sigma_rad: sigma2.max(0.0).sqrt(),
            white: rep.ljung_box.white,
        });
    }
    let axes: [AxisModel; 3] = axes
        .try_into()
        .map_err(|_| "flexure identification: expected three axes".to_string())?;
    Ok(IdentifiedFlexure {
        axes,
        sequence: kind.name(),
    })
}
