//! The data sequences the identifier can be fed from a recording, one per slave body axis,
//! sampled at the filter period `T` (a whole number of master periods).
//!
//! - [`SequenceKind::GyroDifference`], the paper's (its ref. \[16\]): differences of successive
//!   slave gyro outputs, `D_k = ω̄_s,k − ω̄_s,k−1`, where `ω̄_s,k` is the slave's mean angular
//!   rate over period `k` (the sum of its increments divided by `T`). Differencing removes the
//!   slow part of the ship's motion, but what is left is the second difference of the flexure
//!   angle, `(θ_k − 2θ_{k−1} + θ_{k−2})/T`, plus the ship's `ω̇ T`: not the flexure angle, and not
//!   an AR process of the flexure's order (differencing adds unit-root moving-average terms).
//! - [`SequenceKind::RateIntegrated`], ours: the rate seen by the slave but not by the master,
//!   integrated to an angle. Per period, `Δω_k = ω̄_s,k − ω̄_m,k` with `ω̄_m,k` the master's mean
//!   rate (trapezoid of its messages' `ω_ib^bm`, or, without them, the rotation between its
//!   attitudes plus the navigation frame's rate). To first order in the small angles,
//!   `Δω = θ̇ + ε + ω_m × (μ + θ) + (scale and non-orthogonality) ω_m + noise`: the bias `ε`
//!   and every term linear in `ω_m` (misalignment `μ`, scale factors, non-orthogonality) are
//!   removed by a least-squares regression of each axis on `[1, ω̄_m,x, ω̄_m,y, ω̄_m,z]`, the
//!   result is integrated (`θ̂_k = θ̂_{k−1} + T r_k`) and its linear trend removed. The
//!   flexure's own coupling `ω_m × θ` is then subtracted with the first-pass `θ̂` and the
//!   regression and integration repeated once. What remains is `θ_k` plus the integrated
//!   sensor noise (a slow random walk).
//! - [`SequenceKind::Truth`]: the simulator's true flexure angle (`thx, thy, thz` of
//!   `truth.csv`) at the same instants: the reference the other two are judged against.
//!
//! Sample `k` belongs to the period boundary `t_k` (a master message time); a period whose
//! slave increments or master messages are missing or irregular becomes a gap (NaN), and the
//! integrated sequence restarts (and is detrended) separately on each side of a gap.

use crate::recording::Recording;
use flexcal_core::rotation::{dcm, exp_so3, log_so3};
use nalgebra::{Matrix4, Vector3, Vector4};

/// Which sequence to identify from a recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SequenceKind {
    /// The master-to-slave rate difference, cleaned of bias and of terms linear in the
    /// master rate, integrated to an angle and detrended (ours; the default).
    RateIntegrated,
    /// Differences of successive slave gyro outputs (the paper's reference 16).
    GyroDifference,
    /// The true flexure angle from `truth.csv` (simulated recordings only).
    Truth,
}

impl SequenceKind {
    /// Every kind, default first.
    pub const ALL: [SequenceKind; 3] = [
        SequenceKind::RateIntegrated,
        SequenceKind::GyroDifference,
        SequenceKind::Truth,
    ];

    /// The name used on the command line and in `identify.json`.
    pub fn name(self) -> &'static str {
        match self {
            SequenceKind::RateIntegrated => "rate-integrated",
            SequenceKind::GyroDifference => "gyro-difference",
            SequenceKind::Truth => "truth",
        }
    }

    /// What the sequence's samples are, with their unit.
    pub fn unit(self) -> &'static str {
        match self {
            SequenceKind::RateIntegrated | SequenceKind::Truth => "rad",
            SequenceKind::GyroDifference => "rad/s",
        }
    }
}

/// One sequence per slave body axis, at the period boundaries `t`.
#[derive(Debug, Clone, PartialEq)]
pub struct FlexureSequence {
    /// Which sequence this is.
    pub kind: SequenceKind,
    /// Sample period `T` (s).
    pub period_s: f64,
    /// Time of each sample (s): the period boundary it belongs to.
    pub t: Vec<f64>,
    /// Samples of the x, y and z axes (NaN marks a gap), same length as `t`.
    pub axes: [Vec<f64>; 3],
    /// How the sequence was made (e.g. where the master rate came from), for reports.
    pub notes: Vec<String>,
}

/// The period boundaries: every `m`-th master message, `m = period / master period`.
struct Grid {
    /// Indices into `rec.master` of the boundaries.
    master_idx: Vec<usize>,
    /// Master messages per period.
    m: usize,
    /// Nominal master period (s).
    master_dt: f64,
}

fn grid(rec: &Recording, period_s: f64) -> Result<Grid, String> {
    let rate = rec.meta.master_rate_hz;
    if !(period_s.is_finite() && period_s > 0.0) {
        return Err(format!(
            "period {period_s} s: must be a positive number of seconds"
        ));
    }
    if !(rate.is_finite() && rate > 0.0) {
        return Err(format!("master rate {rate} Hz is not usable"));
    }
    let ratio = period_s * rate;
    let m = ratio.round();
    if m < 1.0 || (ratio - m).abs() > 1e-6 * ratio.max(1.0) {
        return Err(format!(
            "period {period_s} s is not a whole number of master periods (1/{rate} Hz)"
        ));
    }
    let m = m as usize;
    if rec.master.len() < 2 * m + 1 {
        return Err(format!(
            "{} master messages: too few for a sequence at period {period_s} s",
            rec.master.len()
        ));
    }
    Ok(Grid {
        master_idx: (0..rec.master.len()).step_by(m).collect(),
        m,
        master_dt: 1.0 / rate,
    })
}

/// Whether a master sub-interval has the nominal length (else it is a gap).
fn regular(dt: f64, nominal: f64) -> bool {
    (dt - nominal).abs() <= 0.25 * nominal
}

/// Slave angle increments summed over each period `k = 1..` (index 0 unused: NaN), with
/// the period length; NaN when the increments do not cover the period.
fn slave_increments(rec: &Recording, g: &Grid) -> Vec<(Vector3<f64>, f64)> {
    let nan = Vector3::repeat(f64::NAN);
    let slave_rate = rec.meta.slave_rate_hz;
    let tol = 0.25 / slave_rate;
    let times: Vec<f64> = g
        .master_idx
        .iter()
        .map(|&i| rec.master.get(i).map_or(f64::NAN, |m| m.t))
        .collect();
    let mut out = vec![(nan, f64::NAN); times.len()];
    let mut i = 0usize;
    let imu = &rec.imu;
    // Skip increments that end before the first boundary.
    let first = times.first().copied().unwrap_or(f64::NAN);
    while imu.get(i).is_some_and(|s| s.t <= first + tol) {
        i += 1;
    }
    for (k, w) in times.windows(2).enumerate() {
        let [a, b] = [w.first().copied(), w.get(1).copied()].map(|v| v.unwrap_or(f64::NAN));
        let dt = b - a;
        let mut sum = Vector3::zeros();
        let mut count = 0usize;
        while let Some(s) = imu.get(i) {
            if s.t > b + tol {
                break;
            }
            sum += Vector3::from(s.dtheta_rad);
            count += 1;
            i += 1;
        }
        let expected = (dt * slave_rate).round() as usize;
        let ok = dt.is_finite()
            && regular(dt, g.m as f64 * g.master_dt)
            && count == expected
            && sum.iter().all(|v| v.is_finite());
        if let Some(slot) = out.get_mut(k + 1) {
            *slot = if ok { (sum, dt) } else { (nan, dt) };
        }
    }
    out
}

/// The master's mean angular rate `ω_ib^bm` over each period `k = 1..` (index 0: NaN).
fn master_mean_rates(rec: &Recording, g: &Grid) -> (Vec<Vector3<f64>>, &'static str) {
    let nan = Vector3::repeat(f64::NAN);
    let mut out = vec![nan; g.master_idx.len()];
    let from_rate = rec.master_has_rate();
    for (k, slot) in out.iter_mut().enumerate().skip(1) {
        let Some(&end) = g.master_idx.get(k) else {
            continue;
        };
        let start = end.saturating_sub(g.m);
        let mut sum = Vector3::zeros();
        let mut ok = true;
        for j in start + 1..=end {
            let (Some(m0), Some(m1)) = (rec.master.get(j - 1), rec.master.get(j)) else {
                ok = false;
                break;
            };
            let dt = m1.t - m0.t;
            if !regular(dt, g.master_dt) {
                ok = false;
                break;
            }
            let w = if from_rate {
                match (m0.omega_ib_bm_radps, m1.omega_ib_bm_radps) {
                    (Some(w0), Some(w1)) => (Vector3::from(w0) + Vector3::from(w1)) * 0.5,
                    _ => nan,
                }
            } else {
                // Rotation of the master body relative to inertial space over the interval:
                // C_bm^i(j−1)ᵀ C_bm^i(j) = C_bm^n(j−1)ᵀ Exp(ω_in^n dt) C_bm^n(j).
                let q = |m: &crate::recording::MasterMsg| dcm(&m.attitude());
                let w_in = m0.nav_frame_rate_n();
                let rel = q(m0).transpose() * exp_so3(&(w_in * dt)) * q(m1);
                log_so3(&rel) / dt
            };
            if !w.iter().all(|v| v.is_finite()) {
                ok = false;
                break;
            }
            sum += w;
        }
        if ok {
            *slot = sum / g.m as f64;
        }
    }
    let source = if from_rate {
        "master rate: trapezoid of the messages' omega_ib^bm"
    } else {
        "master rate: rotation between successive master attitudes (no rate in the messages)"
    };
    (out, source)
}

/// How [`flexure_sequence_with`] builds the sequences.
#[derive(Debug, Clone, PartialEq)]
pub struct SequenceOptions {
    /// Cut-off (Hz) of the zero-phase low-pass filter applied to the master's mean rate
    /// before it is subtracted ([`SequenceKind::RateIntegrated`]); 0 disables it. The master
    /// sees only the rigid ship motion, whose bandwidth is low, so the filter removes the
    /// master's rate noise (which would otherwise integrate into a random walk with a step
    /// larger than the flexure's own innovation) without touching the flexure, which the
    /// master never sees. It must stay above the ship's motion: anything the ship does above
    /// it leaks into the sequence. Periods within half a filter length of the ends or of a gap
    /// become gaps.
    pub master_lowpass_hz: f64,
}

impl Default for SequenceOptions {
    /// A 2 Hz cut-off: ten times a ship's roll frequency, 4 % of the noise band at 100 Hz.
    fn default() -> Self {
        Self {
            master_lowpass_hz: 2.0,
        }
    }
}

/// Taps of a linear-phase low-pass FIR filter with cut-off `fc` (in cycles per sample,
/// `0 < fc < 0.5`): a sinc windowed by a 4-term Blackman-Harris window (side lobes below
/// −92 dB, pass-band ripple far below 1e-5), `2 half + 1` taps with `half ≈ 3 / fc`
/// (a transition band of about 1.3 fc), normalized to unit gain at zero frequency.
fn lowpass_taps(fc: f64) -> Vec<f64> {
    let half = (3.0 / fc).ceil() as usize;
    let len = 2 * half + 1;
    let (a0, a1, a2, a3) = (0.35875, 0.48829, 0.14128, 0.01168);
    let tau = 2.0 * std::f64::consts::PI;
    let mut taps: Vec<f64> = (0..len)
        .map(|i| {
            let m = i as f64 - half as f64;
            let sinc = if m == 0.0 {
                2.0 * fc
            } else {
                (tau * fc * m).sin() / (std::f64::consts::PI * m)
            };
            let x = i as f64 / (len - 1) as f64;
            let w =
                a0 - a1 * (tau * x).cos() + a2 * (2.0 * tau * x).cos() - a3 * (3.0 * tau * x).cos();
            sinc * w
        })
        .collect();
    let sum: f64 = taps.iter().sum();
    taps.iter_mut().for_each(|t| *t /= sum);
    taps
}

/// Zero-phase filtering of `x` by the symmetric `taps`; NaN wherever the window reaches a
/// non-finite sample or an end.
fn filter_symmetric(x: &[f64], taps: &[f64]) -> Vec<f64> {
    let half = taps.len() / 2;
    (0..x.len())
        .map(|k| {
            if k < half || k + half >= x.len() {
                return f64::NAN;
            }
            x.get(k - half..=k + half).map_or(f64::NAN, |w| {
                w.iter().zip(taps.iter()).map(|(a, b)| a * b).sum()
            })
        })
        .collect()
}

/// Splits `0..len` into maximal runs where `ok(i)` holds.
fn runs(len: usize, ok: impl Fn(usize) -> bool) -> Vec<std::ops::Range<usize>> {
    let mut out = Vec::new();
    let mut start = None;
    for i in 0..len {
        match (ok(i), start) {
            (true, None) => start = Some(i),
            (false, Some(s)) => {
                out.push(s..i);
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        out.push(s..len);
    }
    out
}

/// Least-squares fit of `y` on the regressor rows `x` (rows with a non-finite value skipped);
/// returns the residuals (NaN where skipped). Columns are scaled to unit norm and near-null
/// directions dropped, so collinear regressors (a still ship) do not blow up.
fn regress_out(x: &[Vector4<f64>], y: &[f64]) -> Vec<f64> {
    let usable = |i: usize| -> bool {
        matches!((x.get(i), y.get(i)), (Some(r), Some(v)) if v.is_finite() && r.iter().all(|c| c.is_finite()))
    };
    let mut xtx = Matrix4::<f64>::zeros();
    let mut xty = Vector4::<f64>::zeros();
    for i in 0..y.len() {
        if let (true, Some(r), Some(&v)) = (usable(i), x.get(i), y.get(i)) {
            xtx += r * r.transpose();
            xty += r * v;
        }
    }
    let d = Vector4::from_fn(|i, _| {
        let s = xtx[(i, i)];
        if s > 0.0 {
            1.0 / s.sqrt()
        } else {
            0.0
        }
    });
    let scaled = Matrix4::from_fn(|i, j| xtx[(i, j)] * d[i] * d[j]);
    let rhs = Vector4::from_fn(|i, _| xty[i] * d[i]);
    let beta = scaled
        .svd(true, true)
        .solve(&rhs, 1e-10)
        .map(|b| b.component_mul(&d))
        .unwrap_or_else(|_| Vector4::zeros());
    (0..y.len())
        .map(|i| match (usable(i), x.get(i), y.get(i)) {
            (true, Some(r), Some(&v)) => v - r.dot(&beta),
            _ => f64::NAN,
        })
        .collect()
}

/// Removes the least-squares line `c0 + c1 k` from `v[range]`.
fn detrend(v: &mut [f64], range: std::ops::Range<usize>) {
    let Some(seg) = v.get_mut(range) else {
        return;
    };
    let n = seg.len() as f64;
    if n < 2.0 {
        seg.iter_mut().for_each(|x| *x = 0.0);
        return;
    }
    let km = (n - 1.0) / 2.0;
    let ym = seg.iter().sum::<f64>() / n;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (k, &y) in seg.iter().enumerate() {
        let dk = k as f64 - km;
        sxy += dk * (y - ym);
        sxx += dk * dk;
    }
    let slope = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    for (k, y) in seg.iter_mut().enumerate() {
        *y -= ym + slope * (k as f64 - km);
    }
}

/// Integrates the per-period rates `r[k]` (k ≥ 1, over `dt[k]`) to angles at the boundaries,
/// restarting after each gap, and detrends each run. Index 0 of `r` is unused.
fn integrate_detrended(r: &[f64], dt: &[f64]) -> Vec<f64> {
    let len = r.len();
    let mut theta = vec![f64::NAN; len];
    // A boundary k is usable when period k+1 or period k is finite; a run of finite periods
    // k = a..b gives angles at boundaries a−1..=b.
    let ok = |k: usize| r.get(k).is_some_and(|v| v.is_finite()) && k >= 1;
    for run in runs(len, ok) {
        let start = run.start - 1;
        if let Some(t0) = theta.get_mut(start) {
            *t0 = 0.0;
        }
        let mut acc = 0.0;
        for k in run.clone() {
            acc += r.get(k).copied().unwrap_or(0.0) * dt.get(k).copied().unwrap_or(0.0);
            if let Some(t) = theta.get_mut(k) {
                *t = acc;
            }
        }
        detrend(&mut theta, start..run.end);
    }
    theta
}

/// Builds the sequence of the given kind from a recording, at period `period_s` (a whole
/// number of master periods; typically the filter period, `1 / master_rate_hz`), with the
/// default [`SequenceOptions`].
pub fn flexure_sequence(
    rec: &Recording,
    kind: SequenceKind,
    period_s: f64,
) -> Result<FlexureSequence, String> {
    flexure_sequence_with(rec, kind, period_s, &SequenceOptions::default())
}

/// [`flexure_sequence`] with explicit options.
pub fn flexure_sequence_with(
    rec: &Recording,
    kind: SequenceKind,
    period_s: f64,
    opts: &SequenceOptions,
) -> Result<FlexureSequence, String> {
    let g = grid(rec, period_s)?;
    let t: Vec<f64> = g
        .master_idx
        .iter()
        .map(|&i| rec.master.get(i).map_or(f64::NAN, |m| m.t))
        .collect();
    let len = t.len();
    let mut notes = Vec::new();
    let axes: [Vec<f64>; 3] = match kind {
        SequenceKind::Truth => {
            let truth = rec
                .truth
                .as_ref()
                .ok_or("sequence `truth` needs a recording with truth.csv (a simulated one)")?;
            let mut axes = [
                vec![f64::NAN; len],
                vec![f64::NAN; len],
                vec![f64::NAN; len],
            ];
            for (a, name) in ["thx", "thy", "thz"].iter().enumerate() {
                let col = truth
                    .column(name)
                    .ok_or_else(|| format!("truth.csv has no column `{name}`"))?;
                let tol = 0.25 * g.master_dt;
                let Some(dst) = axes.get_mut(a) else {
                    continue;
                };
                for (slot, &tk) in dst.iter_mut().zip(t.iter()) {
                    let i = truth.t.partition_point(|&x| x < tk - tol);
                    if let (Some(&ti), Some(&v)) = (truth.t.get(i), col.get(i)) {
                        if (ti - tk).abs() <= tol {
                            *slot = v;
                        }
                    }
                }
            }
            notes.push("true flexure angle thx, thy, thz from truth.csv".to_string());
            axes
        }
        SequenceKind::GyroDifference => {
            let inc = slave_increments(rec, &g);
            let rate: Vec<Vector3<f64>> = inc.iter().map(|(s, dt)| s / *dt).collect();
            let mut axes = [
                vec![f64::NAN; len],
                vec![f64::NAN; len],
                vec![f64::NAN; len],
            ];
            for k in 2..len {
                if let (Some(w1), Some(w0)) = (rate.get(k), rate.get(k - 1)) {
                    let d = w1 - w0;
                    for (a, ax) in axes.iter_mut().enumerate() {
                        if let Some(slot) = ax.get_mut(k) {
                            *slot = d[a];
                        }
                    }
                }
            }
            notes.push(
                "D_k = mean slave rate over period k minus that over period k-1 (paper ref. [16])"
                    .to_string(),
            );
            axes
        }
        SequenceKind::RateIntegrated => {
            let inc = slave_increments(rec, &g);
            let (mut wm, source) = master_mean_rates(rec, &g);
            notes.push(source.to_string());
            let fc = opts.master_lowpass_hz * period_s;
            if opts.master_lowpass_hz > 0.0 {
                if fc.is_nan() || fc >= 0.5 {
                    return Err(format!(
                        "master low-pass cut-off {} Hz is not below the Nyquist frequency {} Hz",
                        opts.master_lowpass_hz,
                        0.5 / period_s
                    ));
                }
                let taps = lowpass_taps(fc);
                let cols = [0, 1, 2].map(|a| {
                    let x: Vec<f64> = wm.iter().map(|w| w[a]).collect();
                    filter_symmetric(&x, &taps)
                });
                for (k, w) in wm.iter_mut().enumerate() {
                    *w = Vector3::from_fn(|a, _| {
                        cols.get(a)
                            .and_then(|c| c.get(k))
                            .copied()
                            .unwrap_or(f64::NAN)
                    });
                }
                notes.push(format!(
                    "master rate low-passed at {} Hz (zero-phase FIR, {} taps)",
                    opts.master_lowpass_hz,
                    taps.len()
                ));
            }
            notes.push(
                "per axis: regression on [1, master rate] removed, integrated, linear trend removed, \
                 omega_m x theta coupling subtracted and repeated once"
                    .to_string(),
            );
            let dt: Vec<f64> = inc.iter().map(|(_, dt)| *dt).collect();
            let dw: Vec<Vector3<f64>> = inc
                .iter()
                .zip(wm.iter())
                .map(|((s, dt), w)| s / *dt - w)
                .collect();
            let regressors: Vec<Vector4<f64>> = wm
                .iter()
                .map(|w| Vector4::new(1.0, w.x, w.y, w.z))
                .collect();
            let pass = |dw: &[Vector3<f64>]| -> [Vec<f64>; 3] {
                [0, 1, 2].map(|a| {
                    let y: Vec<f64> = dw.iter().map(|v| v[a]).collect();
                    let r = regress_out(&regressors, &y);
                    integrate_detrended(&r, &dt)
                })
            };
            let first = pass(&dw);
            // Subtract ω_m × θ̂ (θ̂ at mid-period: mean of the two boundaries).
            let corrected: Vec<Vector3<f64>> = (0..len)
                .map(|k| {
                    let th = |i: usize| {
                        Vector3::from_fn(|a, _| {
                            first
                                .get(a)
                                .and_then(|v| v.get(i))
                                .copied()
                                .unwrap_or(f64::NAN)
                        })
                    };
                    let mid = if k >= 1 {
                        (th(k) + th(k - 1)) * 0.5
                    } else {
                        th(k)
                    };
                    let w = wm.get(k).copied().unwrap_or(Vector3::repeat(f64::NAN));
                    dw.get(k).copied().unwrap_or(Vector3::repeat(f64::NAN)) - w.cross(&mid)
                })
                .collect();
            pass(&corrected)
        }
    };
    // Trim leading and trailing gaps common to all axes.
    let finite_at = |k: usize| axes.iter().any(|a| a.get(k).is_some_and(|v| v.is_finite()));
    let first = (0..len).find(|&k| finite_at(k));
    let last = (0..len).rev().find(|&k| finite_at(k));
    let (Some(first), Some(last)) = (first, last) else {
        return Err(format!(
            "sequence `{}`: no usable period in the recording (slave increments or master messages missing)",
            kind.name()
        ));
    };
    let cut = |v: &[f64]| v.get(first..=last).map(<[f64]>::to_vec).unwrap_or_default();
    let [x, y, z] = &axes;
    Ok(FlexureSequence {
        kind,
        period_s,
        t: cut(&t),
        axes: [cut(x), cut(y), cut(z)],
        notes,
    })
}
