//! Nested Cholesky solution of the normal equations `D_p a = d_p` for every order `p` at once.
//!
//! With the regressors ordered by lag (1, 2, …, P), the normal matrix `D_p` of order `p` is the
//! leading `p × p` block of `D_P`, so the Cholesky factor `L_p` of `D_p` is the leading block of
//! `L_P`, and the forward-substituted right-hand side `z = L⁻¹ d` is nested the same way. Hence
//! one factorization gives, for every order, the residual sum of squares
//! `RSS_p = d_00 − Σ_{i<p} z_i²` and, after one back substitution `L_pᵀ a = z_{0..p}`, the
//! coefficients. Cost O(P³) per call, no allocation.
//!
//! Condition test: the pivot of column `j`, divided by the diagonal entry it came from,
//! `r_j = (D_jj − Σ_k L_jk²) / D_jj`, is the fraction of the sum of squares of lag `j+1` that the
//! lower lags leave unexplained (one minus a squared multiple correlation). If `r_j` is not above
//! the tolerance, lag `j+1` is (numerically) a linear combination of the lower lags, `D_p` is
//! singular or ill-conditioned for every `p ≥ j+1`, and the factorization stops there: those
//! orders are reported as errors and nothing is divided by the bad pivot.

use crate::real::Real;

/// Reads `m[i][j]`; out-of-range reads (impossible by construction) give zero.
#[inline]
pub(crate) fn at<T: Copy + Default, const P: usize>(m: &[[T; P]; P], i: usize, j: usize) -> T {
    m.get(i).and_then(|r| r.get(j)).copied().unwrap_or_default()
}

/// Writes `m[i][j]`; out-of-range writes (impossible by construction) are ignored.
#[inline]
pub(crate) fn put<T, const P: usize>(m: &mut [[T; P]; P], i: usize, j: usize, v: T) {
    if let Some(x) = m.get_mut(i).and_then(|r| r.get_mut(j)) {
        *x = v;
    }
}

/// Reads `v[i]`, zero when out of range.
#[inline]
pub(crate) fn el<T: Copy + Default, const P: usize>(v: &[T; P], i: usize) -> T {
    v.get(i).copied().unwrap_or_default()
}

/// The nested factorization of one set of normal equations.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Nested<T, const P: usize> {
    /// Lower Cholesky factor; columns `0..good` are valid.
    l: [[T; P]; P],
    /// `z = L⁻¹ d`, entries `0..good` valid.
    z: [T; P],
    /// Number of lags that passed the condition test: orders `0..=good` are solvable.
    pub good: usize,
    /// Pivot ratio of each accepted column (for diagnostics), and of the rejected one at `good`.
    pub ratio: [T; P],
}

impl<T: Real, const P: usize> Nested<T, P> {
    /// Factorizes the symmetric matrix given by its upper triangle `s` (`s[i][j]`, `i ≤ j`),
    /// right-hand side `d`, with pivot-ratio tolerance `tol`.
    pub(crate) fn factor(s: &[[T; P]; P], d: &[T; P], tol: T) -> Self {
        let zero = T::zero();
        let mut l = [[zero; P]; P];
        let mut z = [zero; P];
        let mut ratio = [zero; P];
        let sym = |i: usize, j: usize| if i <= j { at(s, i, j) } else { at(s, j, i) };
        let mut good = 0;
        for j in 0..P {
            let djj = sym(j, j);
            let mut pivot = djj;
            for k in 0..j {
                let ljk = at(&l, j, k);
                pivot -= ljk * ljk;
            }
            let r = if djj > zero { pivot / djj } else { zero };
            if let Some(x) = ratio.get_mut(j) {
                *x = r;
            }
            if !r.is_finite() || r <= tol || !pivot.is_finite() {
                break;
            }
            let ljj = pivot.sqrt();
            put(&mut l, j, j, ljj);
            for i in (j + 1)..P {
                let mut v = sym(i, j);
                for k in 0..j {
                    v -= at(&l, i, k) * at(&l, j, k);
                }
                put(&mut l, i, j, v / ljj);
            }
            let mut zj = el(d, j);
            for k in 0..j {
                zj -= at(&l, j, k) * el(&z, k);
            }
            if let Some(x) = z.get_mut(j) {
                *x = zj / ljj;
            }
            good = j + 1;
        }
        Self { l, z, good, ratio }
    }

    /// `Σ_{i<p} z_i²`: the sum of squares explained by the first `p` lags.
    pub(crate) fn explained(&self, p: usize) -> T {
        self.z
            .iter()
            .take(p.min(self.good))
            .fold(T::zero(), |acc, &v| acc + v * v)
    }

    /// Coefficients `a_1..a_p` of order `p ≤ good` (back substitution), zero-padded to `P`.
    pub(crate) fn coefficients(&self, p: usize) -> [T; P] {
        let p = p.min(self.good);
        let mut a = [T::zero(); P];
        for i in (0..p).rev() {
            let mut v = el(&self.z, i);
            for k in (i + 1)..p {
                v -= at(&self.l, k, i) * el(&a, k);
            }
            if let Some(x) = a.get_mut(i) {
                *x = v / at(&self.l, i, i);
            }
        }
        a
    }

    /// Smallest accepted pivot ratio among lags `1..=p` (1 for `p = 0`).
    pub(crate) fn min_ratio(&self, p: usize) -> T {
        self.ratio
            .iter()
            .take(p.min(self.good))
            .fold(T::one(), |m, &r| if r < m { r } else { m })
    }
}
