//! Ljung-Box portmanteau test of residual whiteness (paper section 2.1, item 5).
//!
//! `η_i = Σ_{k=1}^{n−i} ε_k ε_{k+i} / Σ_{k=1}^{n} ε_k²` (the paper's residual autocorrelation,
//! taken about zero, not about the sample mean: AR residuals of a zero-mean model are zero-mean
//! under the hypothesis), `Q = n (n+2) Σ_{i=1}^{m} η_i² / (n − i)`, and under `H0` (white
//! residuals) `Q ~ χ²(m − r)` with `r` the number of fitted parameters (`p` for an AR(p)).
//! `H0` is rejected ("not white") when `Q > χ²_{1−α}(m − r)`.
//!
//! Two ways to compute it:
//! - [`ljung_box`] over a slice of residuals (desktop), with [`ar_residuals`] to produce them
//!   from the series and the fitted coefficients without allocating;
//! - [`ArResiduals`] feeding a [`LjungBoxAccumulator`] sample by sample in fixed memory (board).
//!
//! The critical value and p-value use [`crate::stats`] in `f64` (software double on the board).

use crate::real::Real;
use crate::stats;

/// The outcome of a Ljung-Box test.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LjungBox<T> {
    /// The statistic `Q = n (n+2) Σ η_i² / (n − i)`.
    pub q: T,
    /// Number of autocorrelation lags `m`.
    pub lags: usize,
    /// Degrees of freedom `m − r`.
    pub dof: usize,
    /// Critical value `χ²_{1−α}(dof)`.
    pub critical: T,
    /// Significance level `α`.
    pub alpha: T,
    /// `q ≤ critical`: whiteness not rejected at level `α`.
    pub white: bool,
    /// `Pr(χ²(dof) > q)`.
    pub p_value: T,
    /// Number of residuals `n`.
    pub n: usize,
}

/// Why a Ljung-Box test could not be computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LjungBoxError {
    /// `m ≤ r`: no degrees of freedom left (use more lags than fitted parameters).
    NoDegreesOfFreedom {
        /// Lags `m`.
        lags: usize,
        /// Fitted parameters `r`.
        fitted: usize,
    },
    /// `n ≤ m`: too few residuals for the requested number of lags.
    TooFewResiduals {
        /// Residuals `n`.
        n: usize,
        /// Lags `m`.
        lags: usize,
    },
    /// A residual (or an intermediate sum) is not finite.
    NonFinite,
    /// All residuals are zero: autocorrelations are undefined.
    ZeroVariance,
    /// `α` is not inside `(0, 1)`.
    InvalidAlpha,
}

/// Shared final step: `c0 = Σ ε²`, `c` the lagged sums `Σ ε_k ε_{k+i}`, `i = 1..=lags`.
fn finish<T: Real>(
    n: usize,
    c0: T,
    c: impl Iterator<Item = T>,
    lags: usize,
    fitted: usize,
    alpha: T,
) -> Result<LjungBox<T>, LjungBoxError> {
    if !(alpha > T::zero() && alpha < T::one()) {
        return Err(LjungBoxError::InvalidAlpha);
    }
    if lags <= fitted {
        return Err(LjungBoxError::NoDegreesOfFreedom { lags, fitted });
    }
    if n <= lags {
        return Err(LjungBoxError::TooFewResiduals { n, lags });
    }
    if !c0.is_finite() {
        return Err(LjungBoxError::NonFinite);
    }
    if c0 <= T::zero() {
        return Err(LjungBoxError::ZeroVariance);
    }
    let nf = T::of(n as f64);
    let mut sum = T::zero();
    for (i, ci) in (1..=lags).zip(c) {
        let eta = ci / c0;
        sum += eta * eta / T::of((n - i) as f64);
    }
    let q = nf * (nf + T::of(2.0)) * sum;
    if !q.is_finite() {
        return Err(LjungBoxError::NonFinite);
    }
    let dof = lags - fitted;
    let dof_f = dof as f64;
    let critical = stats::chi2_isf(alpha.to_f64(), dof_f);
    let p_value = stats::chi2_sf(q.to_f64(), dof_f);
    Ok(LjungBox {
        q,
        lags,
        dof,
        critical: T::of(critical),
        alpha,
        white: q.to_f64() <= critical,
        p_value: T::of(p_value),
        n,
    })
}

/// Ljung-Box test over a slice of residuals with `lags` autocorrelations, `fitted` estimated
/// parameters (the AR order) and significance `alpha` (e.g. 0.05). O(n · lags), no allocation.
pub fn ljung_box<T: Real>(
    residuals: &[T],
    lags: usize,
    fitted: usize,
    alpha: T,
) -> Result<LjungBox<T>, LjungBoxError> {
    if residuals.iter().any(|e| !e.is_finite()) {
        return Err(LjungBoxError::NonFinite);
    }
    let c0 = residuals.iter().fold(T::zero(), |s, &e| s + e * e);
    let lagged = (1..=lags).map(|i| {
        residuals
            .iter()
            .zip(residuals.iter().skip(i))
            .fold(T::zero(), |s, (&a, &b)| s + a * b)
    });
    finish(residuals.len(), c0, lagged, lags, fitted, alpha)
}

/// Residuals `ε_k = x_k − Σ_{i=1}^{p} a_i x_{k−i}` for `k = p..n` (0-based; the first `p` samples
/// have no residual), `p = coefficients.len()`, lazily and without allocation.
pub fn ar_residuals<'a, T: Real>(
    x: &'a [T],
    coefficients: &'a [T],
) -> impl Iterator<Item = T> + 'a {
    let p = coefficients.len();
    x.iter().enumerate().skip(p).map(move |(k, &xk)| {
        // ε_k = x_k − Σ a_i x_{k−i}: walk back from x_{k−1} (the samples before k, reversed).
        let past = x.get(..k).unwrap_or_default();
        past.iter()
            .rev()
            .zip(coefficients.iter())
            .fold(xk, |e, (&xv, &a)| e - a * xv)
    })
}

/// Online AR residuals for the board: holds an order-`p ≤ P` model and the last `p` samples.
#[derive(Clone, Copy, Debug)]
pub struct ArResiduals<T, const P: usize> {
    coefficients: [T; P],
    order: usize,
    /// `hist[i] = x_{k−1−i}`, newest first.
    hist: [T; P],
    filled: usize,
}

impl<T: Real, const P: usize> ArResiduals<T, P> {
    /// A residual generator for the model `a_1 … a_p` (`p = coefficients.len()`); `None` if
    /// `p > P` or a coefficient is not finite.
    pub fn new(coefficients: &[T]) -> Option<Self> {
        if coefficients.len() > P || coefficients.iter().any(|c| !c.is_finite()) {
            return None;
        }
        let mut a = [T::zero(); P];
        for (dst, &src) in a.iter_mut().zip(coefficients.iter()) {
            *dst = src;
        }
        Some(Self {
            coefficients: a,
            order: coefficients.len(),
            hist: [T::zero(); P],
            filled: 0,
        })
    }

    /// The model order `p`.
    pub fn order(&self) -> usize {
        self.order
    }

    /// Feeds `x_k`; returns `ε_k` once `p` finite predecessors exist. A non-finite sample
    /// returns `None` and restarts the history (a gap).
    pub fn push(&mut self, x: T) -> Option<T> {
        if !x.is_finite() {
            self.filled = 0;
            return None;
        }
        let out = if self.filled >= self.order {
            let pred = self
                .coefficients
                .iter()
                .zip(self.hist.iter())
                .take(self.order)
                .fold(T::zero(), |s, (&a, &h)| s + a * h);
            Some(x - pred)
        } else {
            None
        };
        if P > 0 {
            self.hist.rotate_right(1);
            if let Some(h) = self.hist.first_mut() {
                *h = x;
            }
        }
        self.filled = (self.filled + 1).min(P);
        out
    }
}

/// Streaming Ljung-Box accumulator with `LAGS` autocorrelation lags, in fixed memory.
///
/// Keeps `Σ ε²`, `Σ ε_k ε_{k+i}` for `i = 1..=LAGS` and the last `LAGS` residuals; each push
/// costs O(LAGS). After `n` pushes the sums equal those of [`ljung_box`] on the same `n`
/// residuals. A non-finite residual is skipped and restarts the lag history (a gap: products
/// never straddle it), and is counted in [`LjungBoxAccumulator::rejected`].
#[derive(Clone, Copy, Debug)]
pub struct LjungBoxAccumulator<T, const LAGS: usize> {
    /// `ring[i] = ε_{k−1−i}`, newest first.
    ring: [T; LAGS],
    filled: usize,
    c0: T,
    c: [T; LAGS],
    n: usize,
    rejected: usize,
}

impl<T: Real, const LAGS: usize> Default for LjungBoxAccumulator<T, LAGS> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real, const LAGS: usize> LjungBoxAccumulator<T, LAGS> {
    /// An empty accumulator.
    pub fn new() -> Self {
        Self {
            ring: [T::zero(); LAGS],
            filled: 0,
            c0: T::zero(),
            c: [T::zero(); LAGS],
            n: 0,
            rejected: 0,
        }
    }

    /// Forgets everything.
    pub fn reset(&mut self) {
        *self = Self::new();
    }

    /// Residuals accumulated.
    pub fn count(&self) -> usize {
        self.n
    }

    /// Non-finite residuals skipped.
    pub fn rejected(&self) -> usize {
        self.rejected
    }

    /// Adds one residual `ε_k`; returns `false` (a gap) if it is not finite.
    pub fn push(&mut self, e: T) -> bool {
        if !e.is_finite() {
            self.rejected = self.rejected.saturating_add(1);
            self.filled = 0;
            return false;
        }
        self.c0 += e * e;
        for (acc, &prev) in self.c.iter_mut().zip(self.ring.iter()).take(self.filled) {
            *acc += prev * e;
        }
        if LAGS > 0 {
            self.ring.rotate_right(1);
            if let Some(r) = self.ring.first_mut() {
                *r = e;
            }
        }
        self.filled = (self.filled + 1).min(LAGS);
        self.n = self.n.saturating_add(1);
        true
    }

    /// The test with all `LAGS` lags, `fitted` estimated parameters and significance `alpha`.
    pub fn result(&self, fitted: usize, alpha: T) -> Result<LjungBox<T>, LjungBoxError> {
        finish(self.n, self.c0, self.c.iter().copied(), LAGS, fitted, alpha)
    }
}
