//! A fixed-size Kalman filter with the habits of PX4's EKF2: sequential scalar updates,
//! only the non-zero parts of the transition used in the covariance propagation,
//! symmetry forced, variances clamped to floors, innovation gating by test ratio,
//! and every anomaly counted in health flags.
//!
//! States are held *scaled*: `x = S x_s` with `S = diag(scale)`, where the scales are
//! the initial standard deviations. In f32 a gyro bias variance of 1e-13 and a
//! velocity variance of 1e-2 would otherwise share one covariance matrix; scaled,
//! every diagonal starts at 1, which is what keeps f32 symmetric positive definite.

use crate::mat::{self, vget};
use crate::real::Real;
use nalgebra::{SMatrix, SVector};

/// Health counters and flags of the filter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Health {
    /// Scalar measurements applied.
    pub updates: u32,
    /// Scalar measurements rejected by the innovation gate.
    pub gated: u32,
    /// Longest run of consecutive gated measurements.
    pub max_gated_streak: u32,
    /// Current run of consecutive gated measurements.
    pub gated_streak: u32,
    /// Inputs or results that were not finite (the step was refused).
    pub non_finite: u32,
    /// Times a variance fell below its floor and was clamped.
    pub variance_clamped: u32,
    /// Times the innovation variance was not positive (the update was refused).
    pub bad_innovation_variance: u32,
}

/// Result of one scalar update.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScalarUpdate<T> {
    /// Innovation `z − h x` (measurement units).
    pub innovation: T,
    /// Innovation variance `h P hᵀ + r`.
    pub variance: T,
    /// Test ratio `ν² / (gate² s)`: above 1 the measurement was rejected.
    pub test_ratio: T,
    /// Whether the measurement was applied.
    pub accepted: bool,
}

/// The filter: scaled state and covariance of dimension `N`.
#[derive(Clone, Debug)]
pub struct Kalman<T: Real, const N: usize> {
    xs: SVector<T, N>,
    ps: SMatrix<T, N, N>,
    scale: SVector<T, N>,
    floor: T,
    /// Health counters.
    pub health: Health,
}

impl<T: Real, const N: usize> Kalman<T, N> {
    /// Creates the filter from the initial covariance `p0` (physical units); the state
    /// scales are the square roots of its diagonal (a zero diagonal gets scale 1).
    /// `variance_floor` is the smallest allowed *scaled* variance, e.g. 1e-10.
    pub fn new(p0: &SMatrix<T, N, N>, variance_floor: T) -> Self {
        let scale = SVector::<T, N>::from_fn(|i, _| {
            let d = p0[(i, i)];
            if d > T::zero() && d.is_finite() {
                d.sqrt()
            } else {
                T::one()
            }
        });
        let ps = SMatrix::<T, N, N>::from_fn(|i, j| {
            mat::get(p0, i, j) / (vget(&scale, i) * vget(&scale, j))
        });
        Self {
            xs: SVector::zeros(),
            ps,
            scale,
            floor: variance_floor,
            health: Health::default(),
        }
    }

    /// State estimate in physical units.
    pub fn state(&self) -> SVector<T, N> {
        self.xs.component_mul(&self.scale)
    }

    /// Covariance element (physical units).
    pub fn cov(&self, i: usize, j: usize) -> T {
        match (self.ps.get((i, j)), self.scale.get(i), self.scale.get(j)) {
            (Some(p), Some(si), Some(sj)) => *p * *si * *sj,
            _ => T::zero(),
        }
    }

    /// Covariance in physical units (for reports and tests; O(N²)).
    pub fn covariance(&self) -> SMatrix<T, N, N> {
        SMatrix::from_fn(|i, j| self.cov(i, j))
    }

    /// Standard deviation of state `i` (physical units).
    pub fn sigma(&self, i: usize) -> T {
        self.cov(i, i).max(T::zero()).sqrt()
    }

    /// Scaled covariance (dimensionless; what the numerics act on).
    pub fn scaled_covariance(&self) -> &SMatrix<T, N, N> {
        &self.ps
    }

    /// Sets the states listed in `indices` to zero after their estimate has been fed
    /// back into the nominal solution (closed loop).
    pub fn reset_states(&mut self, indices: core::ops::Range<usize>) {
        for i in indices {
            if let Some(x) = self.xs.get_mut(i) {
                *x = T::zero();
            }
        }
    }

    /// Freezes the states in `indices` at their current estimate: their rows and
    /// columns of the covariance are zeroed and their variances set to the floor, so
    /// later updates leave them (practically) unchanged. Used to estimate on one part of
    /// a recording and predict the innovations of the rest.
    pub fn freeze(&mut self, indices: core::ops::Range<usize>) {
        for i in indices {
            for j in 0..N {
                mat::set(&mut self.ps, i, j, T::zero());
                mat::set(&mut self.ps, j, i, T::zero());
            }
            mat::set(&mut self.ps, i, i, self.floor);
        }
    }

    /// Time update `x ← Φ x`, `P ← Φ P Φᵀ + Q` (physical-unit Φ and Q), using only the
    /// non-zero entries of Φ and computing one triangle of the symmetric result.
    pub fn predict(&mut self, phi: &SMatrix<T, N, N>, q: &SMatrix<T, N, N>) {
        // Plain slices throughout (matrices are column-major: (i, j) at j·N + i); nalgebra's
        // element iterators are not inlined in the size-optimized board image.
        let scale = self.scale.as_slice();
        let sc = |i: usize| scale.get(i).copied().unwrap_or_else(T::one);
        // Non-zeros of the scaled transition Φ_s = S⁻¹ Φ S per row, as (column, value),
        // columns ascending (one pass over Φ's columns in order).
        let mut nz: [[(usize, T); N]; N] = [[(0, T::zero()); N]; N];
        let mut counts = [0usize; N];
        for (j, col) in phi.as_slice().chunks_exact(N).enumerate() {
            for (i, ((&v, row), c)) in col
                .iter()
                .zip(nz.iter_mut())
                .zip(counts.iter_mut())
                .enumerate()
            {
                if v != T::zero() {
                    if let Some(slot) = row.get_mut(*c) {
                        *slot = (j, v * sc(j) / sc(i));
                    }
                    *c += 1;
                }
            }
        }
        let mut xs_new = SVector::<T, N>::zeros();
        for ((x, row), &c) in xs_new
            .as_mut_slice()
            .iter_mut()
            .zip(nz.iter())
            .zip(counts.iter())
        {
            *x = sparse_dot(row, c, self.xs.as_slice());
        }
        // Row i of A = Φ_s P_s is a sum of whole rows of P_s: a[i] = Σ_j Φ_s(i, j) P_s(j, ·),
        // j ascending. P_s is exactly symmetric (every update writes both triangles from
        // one value), so row j is column j: the column-major storage's j-th chunk.
        let mut a = [[T::zero(); N]; N];
        for ((arow, row), &c) in a.iter_mut().zip(nz.iter()).zip(counts.iter()) {
            for &(j, f) in row.get(..c).unwrap_or(&[]) {
                if let Some(prow) = self.ps.as_slice().chunks_exact(N).nth(j) {
                    for (e, &p) in arow.iter_mut().zip(prow.iter()) {
                        *e += f * p;
                    }
                }
            }
        }
        // P' = A Φ_sᵀ + Q_s, upper triangle then mirrored.
        let mut p_new = SMatrix::<T, N, N>::zeros();
        let qv = q.as_slice();
        let pn = p_new.as_mut_slice();
        for (i, arow) in a.iter().enumerate() {
            for (j, (row, &c)) in nz.iter().zip(counts.iter()).enumerate().skip(i) {
                let qij = qv.get(j * N + i).copied().unwrap_or_else(T::zero);
                let qs = if qij != T::zero() {
                    qij / (sc(i) * sc(j))
                } else {
                    T::zero()
                };
                let v = sparse_dot(row, c, arow) + qs;
                if let Some(e) = pn.get_mut(j * N + i) {
                    *e = v;
                }
                if let Some(e) = pn.get_mut(i * N + j) {
                    *e = v;
                }
            }
        }
        if xs_new
            .as_slice()
            .iter()
            .chain(p_new.as_slice().iter())
            .all(|v| v.is_finite())
        {
            self.xs = xs_new;
            self.ps = p_new;
            self.clamp_variances();
        } else {
            self.health.non_finite += 1;
        }
    }

    /// Sequential scalar update with measurement row `h` (physical units), measurement
    /// `z`, noise variance `r`, and gate `gate` in standard deviations.
    pub fn update_scalar(&mut self, h: &SVector<T, N>, z: T, r: T, gate: T) -> ScalarUpdate<T> {
        let mut hs = SVector::<T, N>::zeros();
        // P h over the non-zero entries of h only (a matching row has at most 12).
        let mut hnz = [(0usize, T::zero()); N];
        let mut n_h = 0usize;
        for (j, ((o, &hj), &sj)) in hs
            .as_mut_slice()
            .iter_mut()
            .zip(h.as_slice().iter())
            .zip(self.scale.as_slice().iter())
            .enumerate()
        {
            *o = hj * sj;
            if *o != T::zero() {
                if let Some(slot) = hnz.get_mut(n_h) {
                    *slot = (j, *o);
                }
                n_h += 1;
            }
        }
        let mut ph = SVector::<T, N>::zeros();
        for &(j, hj) in hnz.get(..n_h).unwrap_or(&[]) {
            if let Some(pcol) = self.ps.as_slice().chunks_exact(N).nth(j) {
                for (y, &p) in ph.as_mut_slice().iter_mut().zip(pcol.iter()) {
                    *y += p * hj;
                }
            }
        }
        let s = hs.dot(&ph) + r;
        let innovation = z - hs.dot(&self.xs);
        let refused = ScalarUpdate {
            innovation,
            variance: s,
            test_ratio: T::zero(),
            accepted: false,
        };
        if !(z.is_finite() && r.is_finite() && s.is_finite() && innovation.is_finite()) {
            self.health.non_finite += 1;
            return refused;
        }
        if s <= T::zero() {
            self.health.bad_innovation_variance += 1;
            return refused;
        }
        let test_ratio = innovation * innovation / (gate * gate * s);
        if test_ratio > T::one() {
            self.health.gated += 1;
            self.health.gated_streak += 1;
            self.health.max_gated_streak =
                self.health.max_gated_streak.max(self.health.gated_streak);
            return ScalarUpdate {
                test_ratio,
                ..refused
            };
        }
        self.health.gated_streak = 0;
        // K = P h / s.
        let mut k = [T::zero(); N];
        for ((ki, &phi), x) in k
            .iter_mut()
            .zip(ph.as_slice().iter())
            .zip(self.xs.as_mut_slice().iter_mut())
        {
            *ki = phi / s;
            *x += *ki * innovation;
        }
        // P ← P − K (P h)ᵀ, symmetric by construction; one triangle computed (column j,
        // rows i ≤ j) and mirrored.
        let ps = self.ps.as_mut_slice();
        for (j, &phj) in ph.as_slice().iter().enumerate() {
            for (i, &ki) in k.get(..=j).unwrap_or(&[]).iter().enumerate() {
                let (ij, ji) = (j * N + i, i * N + j);
                let v = ps.get(ij).copied().unwrap_or_else(T::zero) - ki * phj;
                if let Some(e) = ps.get_mut(ij) {
                    *e = v;
                }
                if let Some(e) = ps.get_mut(ji) {
                    *e = v;
                }
            }
        }
        self.clamp_variances();
        self.health.updates += 1;
        ScalarUpdate {
            innovation,
            variance: s,
            test_ratio,
            accepted: true,
        }
    }

    fn clamp_variances(&mut self) {
        for i in 0..N {
            if mat::get(&self.ps, i, i) < self.floor {
                mat::set(&mut self.ps, i, i, self.floor);
                self.health.variance_clamped += 1;
            }
        }
    }
}

/// `Σ f · v[j]` over the first `count` `(j, f)` of `row`, in order, from zero.
#[inline(always)]
fn sparse_dot<T: Real>(row: &[(usize, T)], count: usize, v: &[T]) -> T {
    let mut acc = T::zero();
    for &(j, f) in row.get(..count).unwrap_or(&[]) {
        if let Some(&x) = v.get(j) {
            acc += f * x;
        }
    }
    acc
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix2, Vector2};

    #[test]
    fn scalar_updates_equal_batch_update() {
        let p0 = Matrix2::new(4.0, 1.0, 1.0, 9.0);
        let mut kf = Kalman::<f64, 2>::new(&p0, 1e-12);
        let h1 = Vector2::new(1.0, 0.0);
        let h2 = Vector2::new(1.0, 1.0);
        kf.update_scalar(&h1, 1.0, 0.5, 100.0);
        kf.update_scalar(&h2, 2.0, 0.25, 100.0);
        // Batch information form.
        let h = nalgebra::Matrix2::new(1.0, 0.0, 1.0, 1.0);
        let r = Matrix2::new(0.5, 0.0, 0.0, 0.25);
        let s = h * p0 * h.transpose() + r;
        let k = p0 * h.transpose() * s.try_inverse().unwrap();
        let x = k * Vector2::new(1.0, 2.0);
        let p = (Matrix2::identity() - k * h) * p0;
        assert!((kf.state() - x).norm() < 1e-12);
        assert!((kf.covariance() - p).norm() < 1e-12);
    }

    #[test]
    fn predict_equals_dense_propagation() {
        let p0 = Matrix2::new(4.0, 1.0, 1.0, 9.0);
        let mut kf = Kalman::<f64, 2>::new(&p0, 1e-12);
        kf.update_scalar(&Vector2::new(1.0, 0.0), 1.0, 0.5, 100.0);
        let (x, p) = (kf.state(), kf.covariance());
        let phi = Matrix2::new(1.0, 0.1, 0.0, 1.0);
        let q = Matrix2::new(0.01, 0.0, 0.0, 0.02);
        kf.predict(&phi, &q);
        assert!((kf.state() - phi * x).norm() < 1e-12);
        assert!((kf.covariance() - (phi * p * phi.transpose() + q)).norm() < 1e-12);
    }

    #[test]
    fn gate_rejects_outliers_and_counts_them() {
        let mut kf = Kalman::<f64, 2>::new(&Matrix2::identity(), 1e-12);
        let h = Vector2::new(1.0, 0.0);
        let u = kf.update_scalar(&h, 100.0, 1.0, 5.0);
        assert!(!u.accepted);
        assert_eq!(kf.health.gated, 1);
        assert_eq!(kf.state(), Vector2::zeros());
    }

    #[test]
    fn non_finite_input_is_refused() {
        let mut kf = Kalman::<f32, 2>::new(&Matrix2::identity(), 1e-10);
        let u = kf.update_scalar(&Vector2::new(1.0, 0.0), f32::NAN, 1.0, 5.0);
        assert!(!u.accepted);
        assert_eq!(kf.health.non_finite, 1);
        kf.predict(
            &Matrix2::new(f32::INFINITY, 0.0, 0.0, 1.0),
            &Matrix2::zeros(),
        );
        assert_eq!(kf.health.non_finite, 2);
        assert_eq!(kf.covariance(), Matrix2::identity());
    }
}
