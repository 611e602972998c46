//! Identification of the flexure AR(p) model (paper section 2.1, eqs. 4-12) and its whiteness
//! check (Ljung-Box), sample by sample, in fixed memory, for `f32` (board) and `f64` (desktop).
//!
//! # Model and estimator
//!
//! `θ_k = a_1 θ_{k−1} + … + a_p θ_{k−p} + ε_k` (eq. 4), zero mean, no intercept: remove the mean
//! (or a known offset) before feeding the identifier if the series has one.
//! The coefficients are the conditional least-squares estimate, which is the maximum of the
//! Gaussian likelihood conditional on the first samples and the large-sample equivalent of the
//! paper's exact maximum likelihood (eqs. 5-11): minimize `S(A) = AᵀDA − 2Aᵀd + d_00` (eqs. 7-8),
//! i.e. solve `D a = d`, where `d_ij` are sums of lagged products.
//!
//! # Sample range (one convention for every order)
//!
//! All orders `p = 0..=P_MAX` use the **same residuals**, `k = P_MAX+1 ..= n` (1-based; the first
//! `P_MAX` samples serve only as initial conditions). For order `p` the coefficients are exactly
//! the ordinary least-squares regression of `x_k` on `(x_{k−1}, …, x_{k−p})` over that range,
//! `σ²_p = RSS_p / (n − P_MAX)`, and the lagged-product sums are
//! `d_ij = Σ_{k=P_MAX+1}^{n} x_{k−i} x_{k−j}`, `i, j = 0..=P_MAX`.
//! Why: AIC and BIC compare log-likelihoods, which is only meaningful on the same observations;
//! with a per-order range, lower orders would be scored on more (and different) data and `n`
//! would differ between the compared values. The common range also makes the normal equations
//! of all orders nested, so one Cholesky factorization solves them all (see `solve`). The price,
//! `P_MAX − p` unused residuals for order `p`, is negligible for `n ≫ P_MAX`.
//!
//! A non-finite sample is treated as a gap: it is not accumulated and the lag history restarts,
//! so the next `P_MAX` finite samples are initial conditions again (residual windows never
//! straddle a gap).
//!
//! # Forgetting
//!
//! With a forgetting factor `λ ∈ (0, 1)`, all sums are multiplied by `λ` before each new residual
//! window is added, so a window of age `m` has weight `λ^m`, and the residual count `n` in `σ²`,
//! AIC and BIC becomes the effective count `Σ λ^m = (1 − λ^N)/(1 − λ)` (memory ≈ `1/(1 − λ)`).
//! `λ = 1` (the default) is plain least squares and `n` is then exactly the residual count.
//!
//! # Criteria (as in `formats/outputs.md`)
//!
//! `aic = n ln σ² + 2p`, `bic = n ln σ² + p ln n`, `σ² = RSS / n`, `n` the number of residuals
//! used (the effective count under forgetting). If a series is predicted exactly by some order
//! (a noiseless sine, a constant), `RSS` would be rounding noise or negative; it is floored at
//! `ε · d_00` (`ε` the machine epsilon of `T`) so that `ln σ²` stays finite and very negative.
//!
//! # Condition test
//!
//! Cholesky pivot ratio: for lag `j`, the fraction of its sum of squares not explained by lags
//! `1..j−1` must exceed `pivot_tolerance` (default `sqrt(ε)`: `3.5e-4` for f32, `1.5e-8` for f64,
//! i.e. the solve may lose at most about half the digits). Otherwise order `j` and all higher
//! orders (whose normal matrices contain this one) are reported as
//! [`FitError::IllConditioned`]. On the board (f32), a strongly oversampled flexure (poles near
//! 1) can fail this at order 2; decimate before identifying, or identify in f64.

mod ljung_box;
mod solve;

pub use ljung_box::{
    ar_residuals, ljung_box, ArResiduals, LjungBox, LjungBoxAccumulator, LjungBoxError,
};

use crate::real::Real;
use solve::{at, put, Nested};

/// Which information criterion chooses the order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Criterion {
    /// Akaike, `n ln σ² + 2p` (the paper's eq. 12); tends to over-fit slightly.
    Aic,
    /// Schwarz/Bayesian, `n ln σ² + p ln n`; consistent (picks the true order as `n → ∞`).
    Bic,
}

/// Why one order could not be fitted. The other orders are unaffected unless stated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FitError<T> {
    /// Fewer residuals than the order needs (`order + 1` at least, counted both as windows and
    /// as effective count under forgetting); too few samples pushed.
    NotEnoughData {
        /// Residual windows accumulated so far (samples beyond the first `P_MAX`).
        residuals: usize,
        /// Residual windows this order needs.
        needed: usize,
    },
    /// The series is identically zero over the range: `σ²` would be zero for every order.
    ZeroVariance,
    /// Lag `lag` is numerically a linear combination of the lower lags (pivot ratio not above
    /// the tolerance); this order and every higher one cannot be solved reliably.
    IllConditioned {
        /// The first offending lag (1-based).
        lag: usize,
        /// Its pivot ratio (fraction of its sum of squares unexplained by the lower lags).
        pivot_ratio: T,
    },
    /// The accumulated sums overflowed or are otherwise not finite (e.g. samples near `T::MAX`).
    NonFinite,
}

/// The fit of one order `p`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrderFit<T, const P_MAX: usize> {
    /// The order `p`.
    pub order: usize,
    /// `a_1 … a_p` in the first `p` entries; the rest are zero (use [`OrderFit::coefficients`]).
    pub coefficients: [T; P_MAX],
    /// Residual variance `σ² = RSS / n`.
    pub sigma2: T,
    /// Number of residuals used, `n` (the effective count `Σ λ^age` under forgetting).
    pub n: T,
    /// Residual windows actually accumulated (integer count, ignores forgetting).
    pub residuals: usize,
    /// `n ln σ² + 2p`.
    pub aic: T,
    /// `n ln σ² + p ln n`.
    pub bic: T,
    /// Smallest Cholesky pivot ratio among lags `1..=p` (1 for `p = 0`): how close to singular.
    pub min_pivot_ratio: T,
}

impl<T: Real, const P_MAX: usize> OrderFit<T, P_MAX> {
    /// The meaningful coefficients `a_1 … a_p`.
    pub fn coefficients(&self) -> &[T] {
        self.coefficients
            .get(..self.order)
            .unwrap_or(&self.coefficients)
    }

    /// The value of the given criterion for this order.
    pub fn criterion(&self, c: Criterion) -> T {
        match c {
            Criterion::Aic => self.aic,
            Criterion::Bic => self.bic,
        }
    }
}

/// One fit result per order.
pub type FitResult<T, const P_MAX: usize> = Result<OrderFit<T, P_MAX>, FitError<T>>;

/// The fits of every order `0..=P_MAX` over the same residual range.
#[derive(Clone, Copy, Debug)]
pub struct Fits<T, const P_MAX: usize> {
    order0: FitResult<T, P_MAX>,
    higher: [FitResult<T, P_MAX>; P_MAX],
}

impl<T: Real, const P_MAX: usize> Fits<T, P_MAX> {
    /// The result for order `p`, or `None` if `p > P_MAX`.
    pub fn order(&self, p: usize) -> Option<&FitResult<T, P_MAX>> {
        match p {
            0 => Some(&self.order0),
            _ => self.higher.get(p - 1),
        }
    }

    /// All results in increasing order `0, 1, …, P_MAX`.
    pub fn iter(&self) -> impl Iterator<Item = &FitResult<T, P_MAX>> {
        core::iter::once(&self.order0).chain(self.higher.iter())
    }

    /// The successfully fitted order that minimizes the criterion (lowest order on ties), or
    /// `None` if no order could be fitted.
    pub fn select(&self, criterion: Criterion) -> Option<usize> {
        self.best(criterion).map(|f| f.order)
    }

    /// The fit of the order [`Fits::select`] chooses.
    pub fn best(&self, criterion: Criterion) -> Option<&OrderFit<T, P_MAX>> {
        let mut best: Option<&OrderFit<T, P_MAX>> = None;
        for f in self.iter().filter_map(|r| r.as_ref().ok()) {
            let v = f.criterion(criterion);
            if !v.is_finite() {
                continue;
            }
            match best {
                Some(b) if b.criterion(criterion) <= v => {}
                _ => best = Some(f),
            }
        }
        best
    }
}

/// Recursive AR identifier: push samples one at a time, fit every order `0..=P_MAX` on demand.
///
/// Memory: the `(P_MAX+1)²/2` lagged-product sums (upper triangle) plus a ring of the last
/// `P_MAX` samples; O(P_MAX²) work per sample, O(P_MAX³) per [`ArIdentifier::fit_all`].
#[derive(Clone, Copy, Debug)]
pub struct ArIdentifier<T: Real, const P_MAX: usize> {
    lambda: T,
    pivot_tol: T,
    /// `hist[i] = x_{k−1−i}`: the last `P_MAX` samples, newest first.
    hist: [T; P_MAX],
    /// Consecutive finite samples in `hist` (saturates at `P_MAX`).
    filled: usize,
    /// `d_00 = Σ x_k²`.
    s00: T,
    /// `s0[j] = d_{0,j+1} = Σ x_k x_{k−1−j}`.
    s0: [T; P_MAX],
    /// `s[i][j] = d_{i+1,j+1}` for `i ≤ j` (upper triangle only).
    s: [[T; P_MAX]; P_MAX],
    /// Residual windows accumulated.
    count: usize,
    /// Effective residual count `Σ λ^age`.
    weight: T,
    /// Samples pushed (finite or not).
    samples: usize,
    /// Non-finite samples seen (gaps).
    rejected: usize,
}

impl<T: Real, const P_MAX: usize> Default for ArIdentifier<T, P_MAX> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real, const P_MAX: usize> ArIdentifier<T, P_MAX> {
    /// An empty identifier without forgetting (`λ = 1`) and the default pivot tolerance.
    pub fn new() -> Self {
        let zero = T::zero();
        Self {
            lambda: T::one(),
            pivot_tol: T::default_epsilon().sqrt(),
            hist: [zero; P_MAX],
            filled: 0,
            s00: zero,
            s0: [zero; P_MAX],
            s: [[zero; P_MAX]; P_MAX],
            count: 0,
            weight: zero,
            samples: 0,
            rejected: 0,
        }
    }

    /// An empty identifier with exponential forgetting factor `lambda`, so that it tracks
    /// slowly changing dynamics with a memory of about `1/(1 − λ)` samples.
    /// `None` unless `0 < lambda ≤ 1`.
    pub fn with_forgetting(lambda: T) -> Option<Self> {
        if lambda > T::zero() && lambda <= T::one() {
            let mut s = Self::new();
            s.lambda = lambda;
            Some(s)
        } else {
            None
        }
    }

    /// Sets the pivot-ratio tolerance of the condition test (see the module docs); returns
    /// `false` and keeps the old value unless `0 ≤ tol < 1`.
    pub fn set_pivot_tolerance(&mut self, tol: T) -> bool {
        if tol >= T::zero() && tol < T::one() {
            self.pivot_tol = tol;
            true
        } else {
            false
        }
    }

    /// The pivot-ratio tolerance in use.
    pub fn pivot_tolerance(&self) -> T {
        self.pivot_tol
    }

    /// The forgetting factor `λ` (1 = none).
    pub fn forgetting(&self) -> T {
        self.lambda
    }

    /// Forgets all data (keeps `λ` and the tolerance).
    pub fn reset(&mut self) {
        let (lambda, tol) = (self.lambda, self.pivot_tol);
        *self = Self::new();
        self.lambda = lambda;
        self.pivot_tol = tol;
    }

    /// Samples pushed so far, including non-finite ones.
    pub fn samples(&self) -> usize {
        self.samples
    }

    /// Non-finite samples seen (each one a gap that restarts the lag history).
    pub fn rejected(&self) -> usize {
        self.rejected
    }

    /// Residual windows accumulated (samples that had `P_MAX` finite predecessors).
    pub fn residual_count(&self) -> usize {
        self.count
    }

    /// The `n` used in `σ²`, AIC and BIC: the residual count, or `Σ λ^age` with forgetting.
    pub fn effective_count(&self) -> T {
        if self.lambda == T::one() {
            T::of(self.count as f64)
        } else {
            self.weight
        }
    }

    /// Adds one sample `x_k`. Returns `false` (and starts a gap) if `x` is not finite.
    pub fn push(&mut self, x: T) -> bool {
        self.samples = self.samples.saturating_add(1);
        if !x.is_finite() {
            self.rejected = self.rejected.saturating_add(1);
            self.filled = 0;
            return false;
        }
        if self.filled >= P_MAX {
            let lam = self.lambda;
            if lam != T::one() {
                self.s00 *= lam;
                self.s0.iter_mut().for_each(|v| *v *= lam);
                self.s.iter_mut().flatten().for_each(|v| *v *= lam);
            }
            self.s00 += x * x;
            for (acc, &h) in self.s0.iter_mut().zip(self.hist.iter()) {
                *acc += x * h;
            }
            for (i, (row, &hi)) in self.s.iter_mut().zip(self.hist.iter()).enumerate() {
                for (acc, &hj) in row.iter_mut().zip(self.hist.iter()).skip(i) {
                    *acc += hi * hj;
                }
            }
            self.count = self.count.saturating_add(1);
            self.weight = self.weight * lam + T::one();
        }
        if P_MAX > 0 {
            self.hist.rotate_right(1);
            if let Some(h) = self.hist.first_mut() {
                *h = x;
            }
        }
        self.filled = (self.filled + 1).min(P_MAX);
        true
    }

    /// Solves the normal equations of every order `0..=P_MAX` over the common residual range
    /// and scores them with AIC and BIC.
    pub fn fit_all(&self) -> Fits<T, P_MAX> {
        let count = self.count;
        let n = self.effective_count();
        let not_enough = |p: usize| FitError::NotEnoughData {
            residuals: count,
            needed: p + 1,
        };
        let sums_finite = self.s00.is_finite()
            && self.s0.iter().all(|v| v.is_finite())
            && self.s.iter().flatten().all(|v| v.is_finite());

        // Full symmetric copy is not needed: the solver reads the upper triangle.
        let nested = Nested::factor(&self.s, &self.s0, self.pivot_tol);
        let floor = self.s00 * T::default_epsilon();
        let ln_n = n.ln();

        let fit = |p: usize| -> FitResult<T, P_MAX> {
            // Also with forgetting: a memory shorter than p + 1 windows cannot determine p
            // coefficients.
            if count < p + 1 || n < T::of((p + 1) as f64) {
                return Err(not_enough(p));
            }
            if !sums_finite {
                return Err(FitError::NonFinite);
            }
            if self.s00 <= T::zero() {
                return Err(FitError::ZeroVariance);
            }
            if p > nested.good {
                return Err(FitError::IllConditioned {
                    lag: nested.good + 1,
                    pivot_ratio: nested.ratio.get(nested.good).copied().unwrap_or_default(),
                });
            }
            let rss = self.s00 - nested.explained(p);
            let rss = if rss > floor { rss } else { floor };
            let sigma2 = rss / n;
            let pf = T::of(p as f64);
            let nl = n * sigma2.ln();
            let fit = OrderFit {
                order: p,
                coefficients: nested.coefficients(p),
                sigma2,
                n,
                residuals: count,
                aic: nl + pf * T::of(2.0),
                bic: nl + pf * ln_n,
                min_pivot_ratio: nested.min_ratio(p),
            };
            let finite = fit.sigma2.is_finite()
                && fit.aic.is_finite()
                && fit.bic.is_finite()
                && fit.coefficients.iter().all(|c| c.is_finite());
            if finite {
                Ok(fit)
            } else {
                Err(FitError::NonFinite)
            }
        };

        let mut higher = [Err(FitError::ZeroVariance); P_MAX];
        for (p, slot) in higher.iter_mut().enumerate() {
            *slot = fit(p + 1);
        }
        Fits {
            order0: fit(0),
            higher,
        }
    }

    /// The fit of one order (convenience over [`ArIdentifier::fit_all`]); `None` if `p > P_MAX`.
    pub fn fit(&self, p: usize) -> Option<FitResult<T, P_MAX>> {
        self.fit_all().order(p).copied()
    }

    /// The symmetric matrix of lagged-product sums `d_ij`, `i, j = 1..=P_MAX` (eq. 8's `D` for
    /// the largest order), for inspection and tests.
    pub fn normal_matrix(&self) -> [[T; P_MAX]; P_MAX] {
        let mut m = self.s;
        for i in 0..P_MAX {
            for j in 0..i {
                put(&mut m, i, j, at(&self.s, j, i));
            }
        }
        m
    }

    /// The right-hand side `d_{0j}`, `j = 1..=P_MAX`, and `d_00` (eq. 8's `d`, and the sum of
    /// squares of the regressand).
    pub fn normal_rhs(&self) -> ([T; P_MAX], T) {
        (self.s0, self.s00)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn order_zero_only_and_reset() {
        let mut id = ArIdentifier::<f32, 0>::new();
        for x in [1.0f32, -2.0, 3.0] {
            assert!(id.push(x));
        }
        let fits = id.fit_all();
        let f = fits.order(0).unwrap().unwrap();
        assert_eq!(f.residuals, 3);
        assert!((f.sigma2 - 14.0 / 3.0).abs() < 1e-6);
        assert_eq!(fits.select(Criterion::Bic), Some(0));
        assert!(fits.order(1).is_none());
        id.reset();
        assert_eq!(id.residual_count(), 0);
        assert_eq!(
            id.fit(0),
            Some(Err(FitError::NotEnoughData {
                residuals: 0,
                needed: 1
            }))
        );
    }

    #[test]
    fn normal_equations_are_the_lagged_sums() {
        // x = 1, 2, 3, 4 with P_MAX = 1: windows k = 2..4 → d00 = 4+9+16, d01 = 2+6+12, d11 = 1+4+9.
        let mut id = ArIdentifier::<f64, 1>::new();
        for x in [1.0, 2.0, 3.0, 4.0] {
            id.push(x);
        }
        let (d, d00) = id.normal_rhs();
        assert_eq!((d00, d[0], id.normal_matrix()[0][0]), (29.0, 20.0, 14.0));
        let f = id.fit(1).unwrap().unwrap();
        assert!((f.coefficients[0] - 20.0 / 14.0).abs() < 1e-15);
        assert!((f.sigma2 - (29.0 - 400.0 / 14.0) / 3.0).abs() < 1e-14);
        assert!(!id.set_pivot_tolerance(1.0) && id.set_pivot_tolerance(0.0));
    }
}
