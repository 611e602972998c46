//! The size of the structure left in whitened innovations, not only its significance.
//!
//! Ljung-Box on tens of thousands of samples rejects whiteness for any structure at all
//! and says nothing of how much there is. What a structure is worth is the share of the
//! innovation variance predictable from the innovations' own past: fit an AR(p) model to
//! the whitened innovations `w = ν/√s` (Levinson-Durbin on their autocovariance about
//! zero, so a mean offset counts as predictable too) and take `1 − σ²_pred / σ²`, the
//! prediction error variance against the mean square. For white innovations each of the
//! p partial autocorrelations is ≈ N(0, 1/n), so the fitted share is ≈ p/n by chance
//! alone (`n Σ κ² ~ χ²(p)`, the Box-Pierce statistic of the partial autocorrelations):
//! that expectation is subtracted, the rest is the *excess* share, the structure's size.

use super::report::whitened;
use crate::calib::run::{Innovation, CHANNELS};

/// Shortest span of the AR fit's lags (s): the structure the diagnosis looks for sits at
/// the ship's motion and the flexure's periods (seconds), so the predictor must see
/// about that far back.
pub const AR_SPAN_S: f64 = 2.0;
/// Fewest lags of the AR fit.
pub const MIN_ORDER: usize = 20;
/// Most lags of the AR fit (its cost is n × p per axis).
pub const MAX_ORDER: usize = 200;

/// The AR order for innovations at `rate_hz`: `AR_SPAN_S` of lags within
/// [`MIN_ORDER`, `MAX_ORDER`].
pub fn ar_order(rate_hz: f64) -> usize {
    let p = (AR_SPAN_S * rate_hz).round();
    if p.is_finite() && p > 0.0 {
        (p as usize).clamp(MIN_ORDER, MAX_ORDER)
    } else {
        MIN_ORDER
    }
}

/// Share of the mean square of `w` predictable by a linear AR(`order`) predictor fitted
/// to `w` itself (Yule-Walker through Levinson-Durbin on the biased autocovariance about
/// zero, which keeps the Toeplitz matrix positive semi-definite). `None` when `w` has at
/// most `2 × order` samples or no energy.
pub fn predictable_share(w: &[f64], order: usize) -> Option<f64> {
    let n = w.len();
    if order == 0 || n <= 2 * order {
        return None;
    }
    let c = autocovariance(w, order);
    let c0 = *c.first()?;
    if !(c0 > 0.0 && c0.is_finite()) {
        return None;
    }
    let mut a = vec![0.0; order + 1];
    let mut prev = vec![0.0; order + 1];
    let mut err = c0;
    for k in 1..=order {
        let acc = c[k] - (1..k).map(|j| a[j] * c[k - j]).sum::<f64>();
        let kappa = (acc / err).clamp(-1.0, 1.0);
        prev.copy_from_slice(&a);
        for j in 1..k {
            a[j] = prev[j] - kappa * prev[k - j];
        }
        a[k] = kappa;
        err *= 1.0 - kappa * kappa;
        if err <= 0.0 {
            return Some(1.0);
        }
    }
    Some((1.0 - err / c0).clamp(0.0, 1.0))
}

/// Lags whose sums `autocovariance` accumulates in one pass over the samples.
const LAG_BLOCK: usize = 8;

/// The biased autocovariance about zero of `w` at lags `0..=order`:
/// `c[k] = Σ_{i < n−k} w[i] w[i+k] / n`. Each lag's sum is accumulated in index order,
/// so the values are those of summing it on its own, bit for bit; `LAG_BLOCK` lags are
/// summed side by side in one pass (independent additions the processor overlaps, each
/// sample read once per block instead of once per lag: the fit's n × p cost, 9 % of a
/// 600 s `diagnose`, docs/performance.md).
fn autocovariance(w: &[f64], order: usize) -> Vec<f64> {
    let n = w.len();
    let own_sum = |lag: usize| {
        let later = w.get(lag..).unwrap_or_default();
        w.iter().zip(later).map(|(a, b)| a * b).sum::<f64>()
    };
    let mut c = Vec::with_capacity(order + 1);
    let mut first = 0;
    while first + LAG_BLOCK <= order + 1 {
        // `-0.0`: where `Iterator::sum` of `f64` starts (an empty sum is `-0.0`).
        let mut acc = [-0.0f64; LAG_BLOCK];
        // Indices every lag of the block has: the block's largest lag sets the end.
        let later = w.get(first..).unwrap_or_default();
        for (a, window) in w.iter().zip(later.windows(LAG_BLOCK)) {
            for (s, b) in acc.iter_mut().zip(window) {
                *s += a * b;
            }
        }
        // The remaining indices of the block's shorter lags, still in index order.
        let common = n.saturating_sub(first + LAG_BLOCK - 1);
        for (j, s) in acc.iter_mut().enumerate() {
            let tail = w.get(common..).unwrap_or_default();
            let later = w.get(common + first + j..).unwrap_or_default();
            *s = tail.iter().zip(later).fold(*s, |s, (a, b)| s + a * b);
        }
        c.extend(acc.iter().map(|s| s / n as f64));
        first += LAG_BLOCK;
    }
    c.extend((first..=order).map(|lag| own_sum(lag) / n as f64));
    c
}

/// Chance level of the excess, in its standard deviations: an axis whose excess is
/// below `MATERIAL_SDS` × √(2p)/n of its mean square (white innovations give
/// `n Σ κ² ~ χ²(p)`, standard deviation √(2p)) has no material structure.
pub const MATERIAL_SDS: f64 = 3.0;

/// The size of the structure of one channel axis.
#[derive(Clone, Debug, serde::Serialize)]
pub struct AxisSize {
    /// Channel name.
    pub channel: &'static str,
    /// Axis 0..3.
    pub axis: usize,
    /// Whitened innovations used.
    pub count: usize,
    /// AR order of the fit.
    pub order: usize,
    /// Mean square of the whitened innovations (the axis's NIS, accepted or not).
    pub mean_square: f64,
    /// Share of the innovation variance predictable from its past (`predictable_share`).
    pub share: f64,
    /// What white innovations give by chance: `order / count`.
    pub white_share: f64,
    /// The structure's size: `(share − white_share) × mean_square`, the predictable
    /// variance beyond chance in units of the filter's predicted innovation variance,
    /// counted only where it is material (above `MATERIAL_SDS` chance deviations), else 0.
    /// In those units an effect that removes variance from an axis cannot make the
    /// structure left on it look larger, as a share of a smaller total would.
    pub excess: f64,
}

/// The structure's size on every channel axis of a run's innovations (accepted or not,
/// `s > 0`), in channel then axis order; axes with too few innovations are left out.
pub fn axis_sizes(innovations: &[Innovation], rate_hz: f64) -> Vec<AxisSize> {
    let order = ar_order(rate_hz);
    let mut out = Vec::new();
    for (c, name) in CHANNELS.iter().enumerate() {
        for axis in 0..3 {
            let (_, w) = whitened(innovations, c, axis);
            let Some(share) = predictable_share(&w, order) else {
                continue;
            };
            let n = w.len() as f64;
            let mean_square = w.iter().map(|v| v * v).sum::<f64>() / n;
            let white_share = order as f64 / n;
            let chance_sd = (2.0 * order as f64).sqrt() / n;
            let beyond = share - white_share;
            out.push(AxisSize {
                channel: name,
                axis,
                count: w.len(),
                order,
                mean_square,
                share,
                white_share,
                excess: if beyond > MATERIAL_SDS * chance_sd {
                    beyond * mean_square
                } else {
                    0.0
                },
            });
        }
    }
    out
}

/// The chance level of the summed size: `MATERIAL_SDS` chance deviations of each axis's
/// share (√(2p)/n), in its mean square's units, summed over the axes.
pub fn chance_level(sizes: &[AxisSize]) -> f64 {
    sizes
        .iter()
        .map(|s| MATERIAL_SDS * (2.0 * s.order as f64).sqrt() / s.count as f64 * s.mean_square)
        .sum()
}

/// Beyond this share of an axis's innovation variance predictable from its past (over
/// chance), the structure dominates the axis: something the model lacks is larger than
/// the model's own noise there. Below it, structure of the size a learned model's own
/// approximations leave (up to 0.25 on clean blind recordings, `docs/diagnosis.md`).
pub const DOMINANT_SHARE: f64 = 0.5;

/// Whether the structure dominates any channel axis (`DOMINANT_SHARE`).
pub fn dominated(sizes: &[AxisSize]) -> bool {
    sizes
        .iter()
        .any(|s| s.share - s.white_share > DOMINANT_SHARE)
}

/// The structure's size summed over the channel axes (`AxisSize::excess`).
pub fn total_excess(sizes: &[AxisSize]) -> f64 {
    sizes.iter().map(|s| s.excess).sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_distr::StandardNormal;

    fn white(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        (0..n).map(|_| rng.sample(StandardNormal)).collect()
    }

    /// The lag-blocked sums are each lag's own sum in index order, bit for bit, at
    /// every order (block sizes and remainders) and every length (tails shorter than a
    /// block, down to lags beyond the samples).
    #[test]
    fn blocked_autocovariance_is_each_lags_own_sum() {
        for (n, seed) in [(3, 1), (9, 2), (17, 3), (1000, 4)] {
            let w = white(n, seed);
            for order in [0, 1, 7, 8, 9, 16, 20, 23] {
                let c = autocovariance(&w, order);
                assert_eq!(c.len(), order + 1);
                for (k, got) in c.iter().enumerate() {
                    let lag = w.get(k..).unwrap_or_default();
                    let want = w.iter().zip(lag).map(|(a, b)| a * b).sum::<f64>() / n as f64;
                    assert_eq!(
                        got.to_bits(),
                        want.to_bits(),
                        "n {n}, order {order}, lag {k}"
                    );
                }
            }
        }
    }

    #[test]
    fn white_innovations_have_only_the_chance_share() {
        let n = 20_000;
        for (seed, order) in [(1, 20), (2, 20), (3, 200)] {
            let s = predictable_share(&white(n, seed), order).expect("share");
            let expect = order as f64 / n as f64;
            // n Σ κ² ~ χ²(p): its standard deviation √(2p) / n; 5 of them.
            let tol = 5.0 * (2.0 * order as f64).sqrt() / n as f64;
            assert!((s - expect).abs() < tol, "order {order}: {s} vs {expect}");
        }
    }

    #[test]
    fn an_ar1_sequence_has_its_predictable_share() {
        // x_t = φ x_{t−1} + e_t: the one-step predictable share is φ².
        for phi in [0.1, 0.5, 0.9] {
            let e = white(50_000, 7);
            let mut x = Vec::with_capacity(e.len());
            let mut prev = 0.0;
            for v in e {
                prev = phi * prev + v;
                x.push(prev);
            }
            let s = predictable_share(&x, 20).expect("share");
            assert!((s - phi * phi).abs() < 0.01, "φ = {phi}: {s}");
        }
    }

    #[test]
    fn a_mean_offset_counts_as_predictable() {
        // A constant m on unit white noise, p lags: the best predictor averages the lags,
        // its error is 1 + m² / (1 + p m²) against the mean square 1 + m².
        let (m, p) = (0.5f64, 20);
        let x: Vec<f64> = white(50_000, 9).iter().map(|v| v + m).collect();
        let s = predictable_share(&x, p).expect("share");
        let m2 = m * m;
        let expect = 1.0 - (1.0 + m2 / (1.0 + p as f64 * m2)) / (1.0 + m2);
        assert!((s - expect).abs() < 0.01, "{s} vs {expect}");
    }

    #[test]
    fn too_short_or_empty_input_has_no_share() {
        assert!(predictable_share(&[1.0; 10], 20).is_none());
        assert!(predictable_share(&[0.0; 100], 20).is_none());
        assert!(predictable_share(&white(100, 1), 0).is_none());
    }

    fn innovations(w: &[f64]) -> Vec<Innovation> {
        w.iter()
            .enumerate()
            .map(|(k, v)| Innovation {
                t: k as f64 * 0.1,
                channel: 0,
                axis: 1,
                value: 2.0 * v,
                variance: 4.0,
                accepted: true,
            })
            .collect()
    }

    #[test]
    fn white_axes_have_no_size_and_a_dominant_ar1_is_sized_and_dominates() {
        let w = white(20_000, 4);
        let sizes = axis_sizes(&innovations(&w), 10.0);
        assert_eq!(sizes.len(), 1);
        assert_eq!(total_excess(&sizes), 0.0, "{sizes:?}");
        assert!(!dominated(&sizes));
        // AR(1) with φ = 0.8: 0.64 of its variance 1/(1 − 0.64) predictable.
        let mut prev = 0.0;
        let ar: Vec<f64> = w
            .iter()
            .map(|e| {
                prev = 0.8 * prev + e;
                prev
            })
            .collect();
        let sizes = axis_sizes(&innovations(&ar), 10.0);
        let want = 0.64 / (1.0 - 0.64);
        assert!(
            (total_excess(&sizes) - want).abs() < 0.05 * want,
            "{sizes:?}"
        );
        assert!(dominated(&sizes));
        assert!(chance_level(&sizes) < 0.01 * want);
    }

    #[test]
    fn the_order_spans_two_seconds_within_its_bounds() {
        assert_eq!(ar_order(10.0), MIN_ORDER);
        assert_eq!(ar_order(50.0), 100);
        assert_eq!(ar_order(400.0), MAX_ORDER);
        assert_eq!(ar_order(f64::NAN), MIN_ORDER);
    }
}
