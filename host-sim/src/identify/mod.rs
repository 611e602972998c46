//! Identification of the flexure AR(p) model on the desktop (paper section 2.1): order by AIC
//! or BIC, conditional least squares from the core's [`ArIdentifier`], Ljung-Box whiteness
//! check of the chosen order, and the exact Gaussian maximum likelihood (eq. 11) as a
//! refinement ([`exact`]).
//!
//! The pieces, usable on their own (the calibrator can call them):
//! - [`flexure_sequence`] turns a recording into the per-axis sequence to identify
//!   ([`SequenceKind`]: the paper's gyro differences, our integrated rate difference, or the
//!   simulator's truth);
//! - [`identify_series`] identifies one series;
//! - [`read_series_csv`] reads one column of a CSV file as a series;
//! - [`report`] renders results as `identify.json` (the contract of `formats/outputs.md`), as
//!   the AIC/BIC table of the paper's Table 3, and as the one-step-prediction figure (Fig. 3).
//!
//! # Conventions
//!
//! - The series is made zero-mean first (its mean is reported), as the model has no intercept.
//! - All orders `0..=max_order` are fitted on the same residuals, `k = max_order+1 ..= n` of each
//!   gap-free segment (the first `max_order` samples of a segment are initial conditions):
//!   `σ²_p = RSS_p / n_res`, `aic = n_res ln σ² + 2p`, `bic = n_res ln σ² + p ln n_res`, with
//!   `n_res` the number of residuals. The core identifier is instantiated with
//!   `P_MAX = max_order` for exactly that reason.
//! - The Ljung-Box test of order `p` uses that order's residuals over the same range, `m` lags
//!   and `m − p` degrees of freedom; autocorrelation products never straddle a gap.
//! - Orders the condition test rejects (lag numerically dependent on the lower ones) are
//!   reported as failures and never selected.

pub mod exact;
pub mod report;
pub mod sequence;
pub mod series_csv;

pub use exact::{exact_log_likelihood, exact_ml, ExactMl};
pub use sequence::{
    flexure_sequence, flexure_sequence_with, FlexureSequence, SequenceKind, SequenceOptions,
};
pub use series_csv::{parse_series_csv, read_series_csv, SeriesColumn};

pub use flexcal_core::ident::Criterion;
use flexcal_core::ident::{ar_residuals, ljung_box, ArIdentifier, FitError};
use flexcal_core::stats;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// Largest order [`identify_series`] accepts (the largest `P_MAX` it instantiates).
pub const MAX_ORDER: usize = 12;

/// What to identify and how to judge it.
#[derive(Debug, Clone, PartialEq)]
pub struct IdentifyOptions {
    /// Largest order fitted, `0..=MAX_ORDER`.
    pub max_order: usize,
    /// Criterion that selects the order.
    pub criterion: Criterion,
    /// Ljung-Box lags `m` (must exceed `max_order`).
    pub lags: usize,
    /// Ljung-Box significance level `α`, in `(0, 1)`.
    pub alpha: f64,
    /// Remove the mean before fitting (the model has no intercept).
    pub demean: bool,
    /// Refine the selected order by exact maximum likelihood.
    pub exact_ml: bool,
}

impl Default for IdentifyOptions {
    /// The command line's defaults: orders 0..=6, AIC, 20 lags, α = 0.05, demeaned, exact ML.
    fn default() -> Self {
        Self {
            max_order: 6,
            criterion: Criterion::Aic,
            lags: 20,
            alpha: 0.05,
            demean: true,
            exact_ml: true,
        }
    }
}

/// Name of a criterion as written in `identify.json` and accepted on the command line.
pub fn criterion_name(c: Criterion) -> &'static str {
    match c {
        Criterion::Aic => "aic",
        Criterion::Bic => "bic",
    }
}

/// A Ljung-Box test result (owned, `f64`).
#[derive(Debug, Clone, PartialEq)]
pub struct LjungBoxReport {
    /// Lags `m`.
    pub lags: usize,
    /// Statistic `Q = n (n+2) Σ η_i² / (n − i)`.
    pub q: f64,
    /// Degrees of freedom `m − p`.
    pub dof: usize,
    /// `χ²_{1−α}(dof)`.
    pub critical: f64,
    /// Significance `α`.
    pub alpha: f64,
    /// `q ≤ critical`: whiteness not rejected.
    pub white: bool,
    /// `Pr(χ²(dof) > q)`.
    pub p_value: f64,
    /// Residuals tested.
    pub n: usize,
}

/// The conditional least-squares fit of one order.
#[derive(Debug, Clone, PartialEq)]
pub struct OrderRow {
    /// Order `p`.
    pub p: usize,
    /// `σ² = RSS / n`.
    pub sigma2: f64,
    /// `n ln σ² + 2p`.
    pub aic: f64,
    /// `n ln σ² + p ln n`.
    pub bic: f64,
    /// `a_1 … a_p`.
    pub coefficients: Vec<f64>,
    /// Smallest Cholesky pivot ratio of the normal equations (1 for `p = 0`).
    pub min_pivot_ratio: f64,
    /// Ljung-Box test of this order's residuals (`None` if it could not be computed).
    pub ljung_box: Option<LjungBoxReport>,
}

/// An order that could not be fitted, and why.
#[derive(Debug, Clone, PartialEq)]
pub struct OrderFailure {
    /// Order `p`.
    pub p: usize,
    /// Why (from the core's condition and data checks).
    pub reason: String,
}

/// Everything [`identify_series`] finds.
#[derive(Debug, Clone, PartialEq)]
pub struct IdentifyReport {
    /// The options used.
    pub options: IdentifyOptions,
    /// Finite samples in the series.
    pub samples: usize,
    /// Gap-free segments (1 without gaps).
    pub segments: usize,
    /// Residuals used by every order, `n` of the criteria.
    pub n: usize,
    /// The mean removed before fitting (0 when not demeaned).
    pub mean_removed: f64,
    /// Orders fitted, increasing.
    pub orders: Vec<OrderRow>,
    /// Orders that could not be fitted.
    pub failures: Vec<OrderFailure>,
    /// The order the chosen criterion selects.
    pub selected_order: usize,
    /// The order AIC selects.
    pub selected_aic: usize,
    /// The order BIC selects.
    pub selected_bic: usize,
    /// Ljung-Box test of the selected order.
    pub ljung_box: LjungBoxReport,
    /// Exact maximum likelihood of the selected order (if requested and possible).
    pub exact_ml: Option<ExactMl>,
    /// Why the exact maximum likelihood is missing, if it was requested.
    pub exact_ml_error: Option<String>,
}

impl IdentifyReport {
    /// The fit of order `p`, if it was fitted.
    pub fn order(&self, p: usize) -> Option<&OrderRow> {
        self.orders.iter().find(|r| r.p == p)
    }

    /// The fit of the selected order.
    pub fn selected(&self) -> Option<&OrderRow> {
        self.order(self.selected_order)
    }
}

/// The maximal runs of finite samples of `x`.
pub fn finite_segments(x: &[f64]) -> Vec<&[f64]> {
    x.split(|v| !v.is_finite())
        .filter(|s| !s.is_empty())
        .collect()
}

/// One order's outcome, independent of `P_MAX`.
type RawFit = Result<(Vec<f64>, f64, f64, f64, f64, usize), String>;

fn describe(e: &FitError<f64>) -> String {
    match e {
        FitError::NotEnoughData { residuals, needed } => {
            format!("not enough data: {residuals} residuals, {needed} needed")
        }
        FitError::ZeroVariance => "the series is identically zero".to_string(),
        FitError::IllConditioned { lag, pivot_ratio } => format!(
            "ill-conditioned: lag {lag} is numerically a combination of the lower lags \
             (pivot ratio {pivot_ratio:.3e}); decimate the series or lower --max-order"
        ),
        FitError::NonFinite => "non-finite sums (overflow)".to_string(),
    }
}

fn describe_lb(e: &flexcal_core::ident::LjungBoxError) -> String {
    use flexcal_core::ident::LjungBoxError as E;
    match e {
        E::NoDegreesOfFreedom { lags, fitted } => {
            format!("Ljung-Box: {lags} lags do not exceed the {fitted} fitted parameters")
        }
        E::TooFewResiduals { n, lags } => {
            format!("Ljung-Box: {n} residuals, not more than {lags} lags (use fewer --lags)")
        }
        E::NonFinite => "Ljung-Box: non-finite residuals".to_string(),
        E::ZeroVariance => "Ljung-Box: the residuals are all zero".to_string(),
        E::InvalidAlpha => "Ljung-Box: alpha must lie strictly between 0 and 1".to_string(),
    }
}

/// Fits every order `0..=P` with the core identifier (common residual range `k > P`).
fn fit_all<const P: usize>(x: &[f64]) -> Vec<RawFit> {
    let mut id = ArIdentifier::<f64, P>::new();
    for &v in x {
        id.push(v);
    }
    id.fit_all()
        .iter()
        .map(|r| match r {
            Ok(f) => Ok((
                f.coefficients().to_vec(),
                f.sigma2,
                f.aic,
                f.bic,
                f.min_pivot_ratio,
                f.residuals,
            )),
            Err(e) => Err(describe(e)),
        })
        .collect()
}

fn fit_dispatch(x: &[f64], max_order: usize) -> Option<Vec<RawFit>> {
    Some(match max_order {
        0 => fit_all::<0>(x),
        1 => fit_all::<1>(x),
        2 => fit_all::<2>(x),
        3 => fit_all::<3>(x),
        4 => fit_all::<4>(x),
        5 => fit_all::<5>(x),
        6 => fit_all::<6>(x),
        7 => fit_all::<7>(x),
        8 => fit_all::<8>(x),
        9 => fit_all::<9>(x),
        10 => fit_all::<10>(x),
        11 => fit_all::<11>(x),
        12 => fit_all::<12>(x),
        _ => return None,
    })
}

/// Residuals of the AR model `a` over the common range (`skip` leading residuals per segment).
fn residual_segments(segments: &[&[f64]], a: &[f64], max_order: usize) -> Vec<Vec<f64>> {
    let skip = max_order.saturating_sub(a.len());
    segments
        .iter()
        .map(|s| ar_residuals(s, a).skip(skip).collect::<Vec<f64>>())
        .filter(|r| !r.is_empty())
        .collect()
}

/// Ljung-Box over residual segments: the core's slice test for one segment, the same formula
/// with per-segment lagged sums otherwise (products never straddle a gap).
fn ljung_box_segments(
    res: &[Vec<f64>],
    lags: usize,
    fitted: usize,
    alpha: f64,
) -> Result<LjungBoxReport, String> {
    let to_report = |lb: flexcal_core::ident::LjungBox<f64>| LjungBoxReport {
        lags: lb.lags,
        q: lb.q,
        dof: lb.dof,
        critical: lb.critical,
        alpha: lb.alpha,
        white: lb.white,
        p_value: lb.p_value,
        n: lb.n,
    };
    if let [one] = res {
        return ljung_box(one, lags, fitted, alpha)
            .map(to_report)
            .map_err(|e| describe_lb(&e));
    }
    let n: usize = res.iter().map(Vec::len).sum();
    if lags <= fitted {
        return Err(format!(
            "Ljung-Box: {lags} lags do not exceed the {fitted} fitted parameters"
        ));
    }
    if n <= lags {
        return Err(format!(
            "Ljung-Box: {n} residuals, not more than {lags} lags"
        ));
    }
    let c0: f64 = res.iter().flatten().map(|e| e * e).sum();
    if !(c0 > 0.0 && c0.is_finite()) {
        return Err("Ljung-Box: residuals all zero or not finite".to_string());
    }
    let nf = n as f64;
    let mut sum = 0.0;
    for i in 1..=lags {
        let ci: f64 = res
            .iter()
            .map(|s| {
                s.iter()
                    .zip(s.iter().skip(i))
                    .map(|(a, b)| a * b)
                    .sum::<f64>()
            })
            .sum();
        let eta = ci / c0;
        sum += eta * eta / (nf - i as f64);
    }
    let q = nf * (nf + 2.0) * sum;
    let dof = lags - fitted;
    let critical = stats::chi2_isf(alpha, dof as f64);
    Ok(LjungBoxReport {
        lags,
        q,
        dof,
        critical,
        alpha,
        white: q <= critical,
        p_value: stats::chi2_sf(q, dof as f64),
        n,
    })
}

/// Identifies an AR model of the series `x` (NaN marks a gap): fits orders `0..=max_order`,
/// selects one by the criterion, tests its residuals, and refines it by exact ML.
pub fn identify_series(x: &[f64], opts: &IdentifyOptions) -> Result<IdentifyReport, String> {
    if opts.max_order > MAX_ORDER {
        return Err(format!(
            "max order {} exceeds the largest supported order {MAX_ORDER}",
            opts.max_order
        ));
    }
    if !(opts.alpha > 0.0 && opts.alpha < 1.0) {
        return Err(format!(
            "alpha {} must lie strictly between 0 and 1",
            opts.alpha
        ));
    }
    if opts.lags <= opts.max_order {
        return Err(format!(
            "{} Ljung-Box lags must exceed the max order {} (degrees of freedom m - p)",
            opts.lags, opts.max_order
        ));
    }
    let samples = x.iter().filter(|v| v.is_finite()).count();
    if samples == 0 {
        return Err("the series has no finite sample".to_string());
    }
    let mean = if opts.demean {
        x.iter().filter(|v| v.is_finite()).sum::<f64>() / samples as f64
    } else {
        0.0
    };
    let y: Vec<f64> = x.iter().map(|v| v - mean).collect();
    let segments = finite_segments(&y);
    let raw = fit_dispatch(&y, opts.max_order)
        .ok_or_else(|| format!("max order {} is not supported", opts.max_order))?;
    let mut orders = Vec::new();
    let mut failures = Vec::new();
    let mut n_res = 0usize;
    for (p, r) in raw.into_iter().enumerate() {
        match r {
            Ok((coefficients, sigma2, aic, bic, min_pivot_ratio, residuals)) => {
                n_res = residuals;
                let res = residual_segments(&segments, &coefficients, opts.max_order);
                let lb = ljung_box_segments(&res, opts.lags, p, opts.alpha).ok();
                orders.push(OrderRow {
                    p,
                    sigma2,
                    aic,
                    bic,
                    coefficients,
                    min_pivot_ratio,
                    ljung_box: lb,
                });
            }
            Err(reason) => failures.push(OrderFailure { p, reason }),
        }
    }
    if orders.is_empty() {
        let why = failures
            .first()
            .map_or_else(String::new, |f| f.reason.clone());
        return Err(format!(
            "no AR order could be fitted ({samples} samples, max order {}): {why}",
            opts.max_order
        ));
    }
    let select = |c: Criterion| -> usize {
        let value = |r: &OrderRow| match c {
            Criterion::Aic => r.aic,
            Criterion::Bic => r.bic,
        };
        orders
            .iter()
            .filter(|r| value(r).is_finite())
            .fold(None::<&OrderRow>, |best, r| match best {
                Some(b) if value(b) <= value(r) => Some(b),
                _ => Some(r),
            })
            .map_or(0, |r| r.p)
    };
    let selected_aic = select(Criterion::Aic);
    let selected_bic = select(Criterion::Bic);
    let selected_order = match opts.criterion {
        Criterion::Aic => selected_aic,
        Criterion::Bic => selected_bic,
    };
    let chosen = orders
        .iter()
        .find(|r| r.p == selected_order)
        .ok_or("internal: selected order not fitted")?;
    let ljung = match &chosen.ljung_box {
        Some(lb) => lb.clone(),
        None => {
            let res = residual_segments(&segments, &chosen.coefficients, opts.max_order);
            ljung_box_segments(&res, opts.lags, selected_order, opts.alpha)?
        }
    };
    let (exact, exact_err) = if opts.exact_ml {
        match exact_ml(&segments, &chosen.coefficients) {
            Ok(e) => (Some(e), None),
            Err(e) => (None, Some(e)),
        }
    } else {
        (None, None)
    };
    Ok(IdentifyReport {
        options: opts.clone(),
        samples,
        segments: segments.len(),
        n: n_res,
        mean_removed: mean,
        orders,
        failures,
        selected_order,
        selected_aic,
        selected_bic,
        ljung_box: ljung,
        exact_ml: exact,
        exact_ml_error: exact_err,
    })
}

/// The continuous second-order system `θ̈ + 2ζω_n θ̇ + ω_n² θ = w` whose sampled poles
/// (`e^{sT}`) are those of the AR(2) `a1, a2` at period `t`: `(ω_n, ζ)` in rad/s, or `None`
/// when the poles are not a complex pair inside the unit circle (no such system).
/// This is how AR(2) models near the unit circle are compared: their coefficients all look
/// like `[2, −1]`, their frequency and damping do not.
pub fn ar2_second_order(a1: f64, a2: f64, t: f64) -> Option<(f64, f64)> {
    let disc = a1 * a1 + 4.0 * a2;
    if !(disc < 0.0 && a2 > -1.0 && t > 0.0) {
        return None;
    }
    let r = (-a2).sqrt();
    let theta = (a1 / (2.0 * r)).clamp(-1.0, 1.0).acos();
    let sigma = -r.ln() / t;
    let wd = theta / t;
    let wn = wd.hypot(sigma);
    (wn > 0.0 && wn.is_finite()).then(|| (wn, sigma / wn))
}

/// One-step predictions `x̂_k = Σ a_i x_{k−i}` of the series (NaN where fewer than `p`
/// finite predecessors exist): the identified model's tracking of a series (the paper's Fig. 3).
pub fn one_step_prediction(x: &[f64], a: &[f64]) -> Vec<f64> {
    (0..x.len())
        .map(|k| {
            if k < a.len() {
                return f64::NAN;
            }
            let past = x.get(k - a.len()..k).unwrap_or_default();
            past.iter().rev().zip(a.iter()).map(|(&v, &c)| c * v).sum()
        })
        .collect()
}

/// A stationary Gaussian AR series `x_k = Σ a_i x_{k−i} + σ e_k` of length `n`, after a
/// burn-in long enough to forget the zero start (for tests and the documented experiments).
pub fn simulate_ar(a: &[f64], sigma: f64, n: usize, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let burn = 20_000;
    let mut hist = vec![0.0; a.len()];
    let mut out = Vec::with_capacity(n);
    for k in 0..burn + n {
        let e: f64 = StandardNormal.sample(&mut rng);
        let v: f64 = hist.iter().zip(a.iter()).map(|(h, c)| h * c).sum::<f64>() + sigma * e;
        if !hist.is_empty() {
            hist.rotate_right(1);
            if let Some(h) = hist.first_mut() {
                *h = v;
            }
        }
        if k >= burn {
            out.push(v);
        }
    }
    out
}
