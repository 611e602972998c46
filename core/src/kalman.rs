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

/// A transition Φ (physical units) that is the identity except on `R` rows: each of those
/// rows dense over the `N` states, with the list of its non-zero columns. The error model's
/// Φ has this shape (only δv, ψ and the flexure states have dynamics), and the covariance
/// propagation then touches only those rows and columns.
#[derive(Clone, Copy, Debug)]
pub struct Transition<T, const N: usize, const R: usize> {
    /// State index of each row that is not the identity's (distinct).
    index: [usize; R],
    /// Those rows: `Φ(index[r], j)` at `values[r][j]`.
    values: [[T; N]; R],
    /// Non-zero columns of each row, ascending; `count[r]` of them (a byte each: the
    /// engine's layouts have at most 33 states).
    cols: [[u8; N]; R],
    count: [usize; R],
}

impl<T: Real, const N: usize, const R: usize> Transition<T, N, R> {
    /// The identity, with rows `index` to be set by [`Transition::set_row`].
    pub fn new(index: [usize; R]) -> Self {
        let mut t = Self {
            index,
            values: [[T::zero(); N]; R],
            cols: [[0; N]; R],
            count: [0; R],
        };
        for (((&i, row), cols), count) in index
            .iter()
            .zip(t.values.iter_mut())
            .zip(t.cols.iter_mut())
            .zip(t.count.iter_mut())
        {
            if let (Some(e), Some(c)) = (row.get_mut(i), cols.first_mut()) {
                *e = T::one();
                *c = i as u8;
                *count = 1;
            }
        }
        t
    }

    /// Row `r` from `row` (dense), its non-zero columns listed.
    pub fn set_row(&mut self, r: usize, row: &[T; N]) {
        let mut at = [0usize; N];
        let mut n = 0;
        for (j, &v) in row.iter().enumerate() {
            if v != T::zero() {
                if let Some(a) = at.get_mut(n) {
                    *a = j;
                }
                n += 1;
            }
        }
        let at = at.get(..n).unwrap_or(&[]);
        self.set_row_at(r, at, |j| row.get(j).copied().unwrap_or_else(T::zero));
    }

    /// Row `r` written in place, zero except at the columns `at` (ascending, distinct),
    /// where it is `value(j)`; the non-zero ones are listed. The same row as
    /// [`Transition::set_row`] of the dense row, without a row-sized temporary or a scan of
    /// all `N` columns (the error model builds Φ's rows this way).
    pub fn set_row_at(&mut self, r: usize, at: &[usize], mut value: impl FnMut(usize) -> T) {
        let (Some(dst), Some(cols), Some(count)) = (
            self.values.get_mut(r),
            self.cols.get_mut(r),
            self.count.get_mut(r),
        ) else {
            return;
        };
        dst.fill(T::zero());
        let mut n = 0;
        for &j in at {
            let v = value(j);
            if let Some(e) = dst.get_mut(j) {
                *e = v;
                if v != T::zero() {
                    if let Some(c) = cols.get_mut(n) {
                        *c = j as u8;
                    }
                    n += 1;
                }
            }
        }
        *count = n;
    }

    /// Element `(i, j)` of Φ.
    pub fn get(&self, i: usize, j: usize) -> T {
        match self.index.iter().position(|&k| k == i) {
            Some(r) => self
                .values
                .get(r)
                .and_then(|row| row.get(j))
                .copied()
                .unwrap_or_else(T::zero),
            None if i == j && i < N => T::one(),
            None => T::zero(),
        }
    }
}

/// A process noise Q (physical units): its diagonal and `P` symmetric off-diagonal pairs.
#[derive(Clone, Copy, Debug)]
pub struct Noise<T, const N: usize, const P: usize> {
    /// `Q(i, i)`.
    pub diag: [T; N],
    /// `(i, j, Q(i, j))` with `i ≠ j`; `Q(j, i)` is the same.
    pub pairs: [(usize, usize, T); P],
}

/// The filter: scaled state and covariance of dimension `N`.
///
/// Only the upper triangle of the scaled covariance (`(i, j)`, `i ≤ j`) is kept: every
/// operation reads and writes that triangle, so the matrix is symmetric by construction and
/// each update does half the work.
#[derive(Clone, Debug)]
pub struct Kalman<T: Real, const N: usize> {
    xs: SVector<T, N>,
    /// Column-major; meaningful on and above the diagonal only.
    ps: SMatrix<T, N, N>,
    scale: SVector<T, N>,
    /// `1 / scale`, so that scaling Φ and Q takes no division.
    inv_scale: SVector<T, N>,
    floor: T,
    /// Health counters.
    pub health: Health,
}

/// Position of `(i, j)` in the stored triangle (column-major, `min ≤ max`).
#[inline(always)]
fn upper<const N: usize>(i: usize, j: usize) -> usize {
    if i <= j {
        j * N + i
    } else {
        i * N + j
    }
}

/// `dst[i] += a · src[i]` over the shorter of the two, four at a time: the board's image is
/// optimized for size, which does not unroll, and the loop overhead would otherwise cost as
/// much as the multiply-add itself. Each element's arithmetic is the same as the plain loop's.
#[inline(always)]
fn axpy<T: Real>(dst: &mut [T], a: T, src: &[T]) {
    let n = dst.len().min(src.len());
    let (dst, src) = (
        dst.get_mut(..n).unwrap_or(&mut []),
        src.get(..n).unwrap_or(&[]),
    );
    let mut d4 = dst.chunks_exact_mut(4);
    let mut s4 = src.chunks_exact(4);
    for (d, s) in (&mut d4).zip(&mut s4) {
        if let ([d0, d1, d2, d3], [s0, s1, s2, s3]) = (d, s) {
            *d0 += a * *s0;
            *d1 += a * *s1;
            *d2 += a * *s2;
            *d3 += a * *s3;
        }
    }
    for (d, &s) in d4.into_remainder().iter_mut().zip(s4.remainder()) {
        *d += a * s;
    }
}

/// `acc[m] += f · P(k, m)` for every `m`, from the upper triangle `ps` (column-major, N×N):
/// row k of P is column k above the diagonal and row k of the stored triangle from it on.
#[inline(always)]
fn add_row<T: Real, const N: usize>(acc: &mut [T; N], f: T, ps: &[T], k: usize) {
    let (head, tail) = acc.split_at_mut(k.min(N));
    axpy(head, f, ps.get(k * N..).unwrap_or(&[]));
    // Row k from the diagonal on: one element per column, N apart.
    axpy_strided::<T, N>(tail, f, ps.get(k * N + k..).unwrap_or(&[]));
}

/// `dst[m] += a · src[m N]` for every `m` of `dst`: a row of the stored triangle, which
/// is one element per column ([`each_strided`]).
#[inline(always)]
fn axpy_strided<T: Real, const N: usize>(dst: &mut [T], a: T, src: &[T]) {
    each_strided::<T, N>(dst, src, |d, p| *d += a * p);
}

/// `op(&mut dst[m], src[m N])` for every `m` of `dst` (`src` holds at least
/// `(dst.len() − 1) N + 1` elements; beyond what it holds, `dst` is left). Four at a time,
/// each group's reach checked once, so the loop is loads and the operation (the plain loop
/// checked every index and cost twice the contiguous one).
#[inline(always)]
fn each_strided<T: Real, const N: usize>(dst: &mut [T], src: &[T], mut op: impl FnMut(&mut T, T)) {
    let mut s = src;
    let mut d4 = dst.chunks_exact_mut(4);
    for d in &mut d4 {
        let w = s.get(..=3 * N).unwrap_or(&[]);
        if let ([d0, d1, d2, d3], Some(&p0), Some(&p1), Some(&p2), Some(&p3)) =
            (d, w.first(), w.get(N), w.get(2 * N), w.get(3 * N))
        {
            op(d0, p0);
            op(d1, p1);
            op(d2, p2);
            op(d3, p3);
        }
        s = s.get(4 * N..).unwrap_or(&[]);
    }
    for d in d4.into_remainder() {
        if let Some(&p) = s.first() {
            op(d, p);
        }
        s = s.get(N..).unwrap_or(&[]);
    }
}

/// `dst[m N] = src[m]` for every `m` of `src` (as far as `dst` reaches): a row of the
/// stored triangle written, four at a time like [`each_strided`].
#[inline(always)]
fn store_strided<T: Real, const N: usize>(dst: &mut [T], src: &[T]) {
    let mut d = dst;
    let mut s4 = src.chunks_exact(4);
    for s in &mut s4 {
        let w = d.get_mut(..=3 * N).unwrap_or(&mut []);
        if let ([p0, p1, p2, p3], Some(w0)) = (s, w.first_mut()) {
            *w0 = *p0;
            if let Some(w1) = w.get_mut(N) {
                *w1 = *p1;
            }
            if let Some(w2) = w.get_mut(2 * N) {
                *w2 = *p2;
            }
            if let Some(w3) = w.get_mut(3 * N) {
                *w3 = *p3;
            }
        }
        d = d.get_mut(4 * N..).unwrap_or(&mut []);
    }
    for &p in s4.remainder() {
        if let Some(e) = d.first_mut() {
            *e = p;
        }
        d = d.get_mut(N..).unwrap_or(&mut []);
    }
}

/// The gain `k_i = ph_i / s` (given `inv_s = 1 / s`) and the state step
/// `x_i += k_i ν`, four elements per loop turn (each element's arithmetic the plain loop's).
#[inline(always)]
fn gain_step<T: Real>(k: &mut [T], x: &mut [T], ph: &[T], inv_s: T, innovation: T) {
    let mut k4 = k.chunks_exact_mut(4);
    let mut x4 = x.chunks_exact_mut(4);
    let mut p4 = ph.chunks_exact(4);
    for ((kc, xc), pc) in (&mut k4).zip(&mut x4).zip(&mut p4) {
        if let ([k0, k1, k2, k3], [x0, x1, x2, x3], [p0, p1, p2, p3]) = (kc, xc, pc) {
            *k0 = *p0 * inv_s;
            *k1 = *p1 * inv_s;
            *k2 = *p2 * inv_s;
            *k3 = *p3 * inv_s;
            *x0 += *k0 * innovation;
            *x1 += *k1 * innovation;
            *x2 += *k2 * innovation;
            *x3 += *k3 * innovation;
        }
    }
    let rest = k4
        .into_remainder()
        .iter_mut()
        .zip(x4.into_remainder().iter_mut());
    for ((ki, xi), &pi) in rest.zip(p4.remainder().iter()) {
        *ki = pi * inv_s;
        *xi += *ki * innovation;
    }
}

/// `acc + v[0] + v[1] + …`, added in that order, four per loop turn (only the sum's
/// finiteness is used: a step with a non-finite result is refused).
#[inline(always)]
fn sum_into<T: Real>(mut acc: T, v: &[T]) -> T {
    let mut v4 = v.chunks_exact(4);
    for c in &mut v4 {
        if let [a, b, c, d] = c {
            acc = acc + *a + *b + *c + *d;
        }
    }
    for &x in v4.remainder() {
        acc += x;
    }
    acc
}

/// Rows of Φ that [`Kalman::predict`] propagates together when they share their columns.
const GROUP: usize = 6;

/// `acc_d[m] += f_d · P(k, m)` for the `GROUP` rows `d` and every `m`, from the upper
/// triangle `ps` (column-major, N×N): row k of P gathered once, then each element of it
/// multiplied into all the rows (each element's arithmetic is [`add_row`]'s).
#[inline(always)]
fn add_row_group<T: Real, const N: usize>(
    acc: &mut [[T; N]; GROUP],
    f: &[T; GROUP],
    ps: &[T],
    k: usize,
) {
    let mut row = [T::zero(); N];
    let (head, tail) = row.split_at_mut(k.min(N));
    if let Some(src) = ps.get(k * N..k * N + head.len()) {
        head.copy_from_slice(src);
    }
    each_strided::<T, N>(tail, ps.get(k * N + k..).unwrap_or(&[]), |e, p| *e = p);
    let [a0, a1, a2, a3, a4, a5] = acc;
    let [f0, f1, f2, f3, f4, f5] = *f;
    let rows = a0.iter_mut().zip(a1.iter_mut()).zip(a2.iter_mut());
    let rows = rows
        .zip(a3.iter_mut())
        .zip(a4.iter_mut())
        .zip(a5.iter_mut());
    for ((((((e0, e1), e2), e3), e4), e5), &p) in rows.zip(row.iter()) {
        *e0 += f0 * p;
        *e1 += f1 * p;
        *e2 += f2 * p;
        *e3 += f3 * p;
        *e4 += f4 * p;
        *e5 += f5 * p;
    }
}

/// `P ← P − k phᵀ` on the upper triangle `ps` (column-major, N×N): column `j`, rows
/// `i ≤ j`, `P(i, j) += (−ph_j) k_i`; each diagonal clamped to `floor` once written.
/// Returns how many were clamped. Four columns at a time, sharing the loads of `k` and the
/// loop (per column, setting up a loop cost about as much as its multiply-adds): their
/// rows 0..=j together, then the three rows of the staggered top; the last `N mod 4`
/// columns one by one.
#[inline(always)]
fn rank_one_downdate<T: Real, const N: usize>(
    ps: &mut [T],
    ph: &[T; N],
    k: &[T; N],
    floor: T,
) -> u32 {
    let mut clamped = 0;
    let mut clamp = |d: Option<&mut T>| {
        if let Some(d) = d {
            if *d < floor {
                *d = floor;
                clamped += 1;
            }
        }
    };
    let at = |v: &[T; N], i: usize| v.get(i).copied().unwrap_or_else(T::zero);
    let mut quads = ps.chunks_exact_mut(4 * N);
    let mut j = 0;
    for quad in &mut quads {
        let (c0, rest) = quad.split_at_mut(N);
        let (c1, rest) = rest.split_at_mut(N);
        let (c2, c3) = rest.split_at_mut(N);
        let (n0, n1, n2, n3) = (-at(ph, j), -at(ph, j + 1), -at(ph, j + 2), -at(ph, j + 3));
        // Rows 0..=j of the four columns; `t*` are the rows below, from j + 1 on.
        let (h0, _) = c0.split_at_mut((j + 1).min(N));
        let (h1, t1) = c1.split_at_mut((j + 1).min(N));
        let (h2, t2) = c2.split_at_mut((j + 1).min(N));
        let (h3, t3) = c3.split_at_mut((j + 1).min(N));
        let rows = h0.iter_mut().zip(h1.iter_mut()).zip(h2.iter_mut());
        for (((x0, x1), x2), (x3, &ki)) in rows.zip(h3.iter_mut().zip(k.iter())) {
            *x0 += n0 * ki;
            *x1 += n1 * ki;
            *x2 += n2 * ki;
            *x3 += n3 * ki;
        }
        if let ([y1, ..], [y2, z2, ..], [y3, z3, w3, ..]) = (t1, t2, t3) {
            let (k1, k2, k3) = (at(k, j + 1), at(k, j + 2), at(k, j + 3));
            *y1 += n1 * k1;
            *y2 += n2 * k1;
            *y3 += n3 * k1;
            *z2 += n2 * k2;
            *z3 += n3 * k2;
            *w3 += n3 * k3;
            clamp(Some(y1));
            clamp(Some(z2));
            clamp(Some(w3));
        }
        clamp(h0.last_mut());
        j += 4;
    }
    for col in quads.into_remainder().chunks_exact_mut(N) {
        if let Some(col) = col.get_mut(..=j) {
            axpy(col, -at(ph, j), k);
            clamp(col.last_mut());
        }
        j += 1;
    }
    clamped
}

impl<T: Real, const N: usize> Kalman<T, N> {
    /// Creates the filter from the initial covariance `p0` (physical units, symmetric); the
    /// state scales are the square roots of its diagonal (a zero diagonal gets scale 1).
    /// `variance_floor` is the smallest allowed *scaled* variance, e.g. 1e-10.
    pub fn new(p0: &SMatrix<T, N, N>, variance_floor: T) -> Self {
        let mut k = Self::unstarted(variance_floor);
        k.restart(variance_floor, |p| p.copy_from(p0));
        k
    }

    /// A filter with zero state and covariance and unit scales, for [`Kalman::restart`] to
    /// start (all zeros and ones, so it can be written straight into its place).
    #[inline(always)]
    pub fn unstarted(variance_floor: T) -> Self {
        Self {
            xs: SVector::zeros(),
            ps: SMatrix::zeros(),
            scale: SVector::repeat(T::one()),
            inv_scale: SVector::repeat(T::one()),
            floor: variance_floor,
            health: Health::default(),
        }
    }

    /// Starts the filter again in place, as [`Kalman::new`] would build it from the initial
    /// covariance that `fill_p0` writes (physical units, symmetric) into the matrix it is
    /// given, which is this filter's own storage: no `N × N` temporary (the board
    /// reconfigures its engine this way). The health counters are kept.
    pub fn restart(&mut self, variance_floor: T, fill_p0: impl FnOnce(&mut SMatrix<T, N, N>)) {
        fill_p0(&mut self.ps);
        for (i, (s, inv)) in self
            .scale
            .iter_mut()
            .zip(self.inv_scale.iter_mut())
            .enumerate()
        {
            let d = mat::get(&self.ps, i, i);
            *s = if d > T::zero() && d.is_finite() {
                d.sqrt_fast()
            } else {
                T::one()
            };
            *inv = T::one() / *s;
        }
        for j in 0..N {
            for i in 0..N {
                let v = mat::get(&self.ps, i, j) / (vget(&self.scale, i) * vget(&self.scale, j));
                mat::set(&mut self.ps, i, j, v);
            }
        }
        self.xs.fill(T::zero());
        self.floor = variance_floor;
    }

    /// State estimate in physical units.
    pub fn state(&self) -> SVector<T, N> {
        self.xs.component_mul(&self.scale)
    }

    /// Covariance element (physical units).
    pub fn cov(&self, i: usize, j: usize) -> T {
        match (
            self.ps.as_slice().get(upper::<N>(i, j)),
            self.scale.get(i),
            self.scale.get(j),
        ) {
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
        self.cov(i, i).max(T::zero()).sqrt_fast()
    }

    /// Scaled covariance (dimensionless; what the numerics act on), both triangles filled
    /// from the stored one (O(N²), for checks and reports).
    pub fn scaled_covariance(&self) -> SMatrix<T, N, N> {
        let ps = self.ps.as_slice();
        SMatrix::from_fn(|i, j| ps.get(upper::<N>(i, j)).copied().unwrap_or_else(T::zero))
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

    /// Scales state `i` by `d`: `x_i ← d x_i`, row and column `i` of P by `d` (`P_ii` by
    /// `d²`). The transition of a state that decays on its own (a first-order Gauss-Markov
    /// state, `d = e^{−t/τ}`) and that no other row of Φ reads: then
    /// `Φ = Φ_rest · D` with `D` this scaling, and applying it before [`Self::predict`]
    /// with `Φ_rest` is the full time update, at O(N) instead of a row of Φ.
    pub fn decay(&mut self, i: usize, d: T) {
        if i >= N {
            return;
        }
        if let Some(x) = self.xs.get_mut(i) {
            *x *= d;
        }
        let ps = self.ps.as_mut_slice();
        for j in 0..N {
            if let Some(e) = ps.get_mut(upper::<N>(i, j)) {
                *e *= if j == i { d * d } else { d };
            }
        }
    }

    /// Time update `x ← Φ x`, `P ← Φ P Φᵀ + Q` (physical-unit Φ and Q). Only the rows and
    /// columns of Φ's non-identity rows change (with `A` those rows: `P_as ← Φ_a P` on the
    /// other columns, `P_aa ← (Φ_a P) Φ_aᵀ`), each product over the rows' non-zero columns;
    /// the rest of P only takes its diagonal Q. A step with a non-finite result is refused.
    pub fn predict<const R: usize, const P: usize>(
        &mut self,
        phi: &Transition<T, N, R>,
        q: &Noise<T, N, P>,
    ) {
        let (sc, inv) = (self.scale.as_slice(), self.inv_scale.as_slice());
        let at = |v: &[T], i: usize| v.get(i).copied().unwrap_or_else(T::zero);
        let mut active = [false; N];
        for &i in phi.index.iter() {
            if let Some(a) = active.get_mut(i) {
                *a = true;
            }
        }
        // Scaled rows Φ_s(i, k) = Φ(i, k) s_k / s_i, compact over the non-zero columns.
        let mut fs = [[T::zero(); N]; R];
        // B = Φ_s,a P_s (the active rows of Φ P), and Φ_s,a x_s.
        let mut b = [[T::zero(); N]; R];
        let mut x_new = [T::zero(); R];
        let ps = self.ps.as_slice();
        let mut check = T::zero();
        for (r, (frow, xn)) in fs.iter_mut().zip(x_new.iter_mut()).enumerate() {
            let (Some(&i), Some(vals), Some(cols), Some(&n)) = (
                phi.index.get(r),
                phi.values.get(r),
                phi.cols.get(r),
                phi.count.get(r),
            ) else {
                continue;
            };
            let inv_i = at(inv, i);
            for (&k, f) in cols.get(..n).unwrap_or(&[]).iter().zip(frow.iter_mut()) {
                let k = usize::from(k);
                *f = at(vals, k) * at(sc, k) * inv_i;
                *xn += *f * at(self.xs.as_slice(), k);
            }
        }
        // B row by row, over each row's columns ascending; six rows with the same columns
        // (δv and ψ's) in one pass over each row of P, which reads it once for all six.
        let cols_of = |r: usize| {
            let n = phi.count.get(r).copied().unwrap_or(0);
            phi.cols.get(r).and_then(|c| c.get(..n)).unwrap_or(&[])
        };
        let mut r = 0;
        while r < R {
            let cols = cols_of(r);
            let six = (r + 1..r + GROUP).all(|q| q < R && cols_of(q) == cols);
            let group = b
                .get_mut(r..r + GROUP)
                .and_then(|g| <&mut [[T; N]; GROUP]>::try_from(g).ok());
            match (six, group) {
                (true, Some(rows)) => {
                    for (c, &k) in cols.iter().enumerate() {
                        let f: [T; GROUP] = core::array::from_fn(|d| {
                            fs.get(r + d)
                                .and_then(|row| row.get(c))
                                .copied()
                                .unwrap_or_else(T::zero)
                        });
                        add_row_group(rows, &f, ps, usize::from(k));
                    }
                    r += GROUP;
                }
                _ => {
                    if let (Some(brow), Some(frow)) = (b.get_mut(r), fs.get(r)) {
                        for (&k, &f) in cols.iter().zip(frow.iter()) {
                            add_row(brow, f, ps, usize::from(k));
                        }
                    }
                    r += 1;
                }
            }
        }
        for (brow, &xn) in b.iter().zip(x_new.iter()) {
            check += xn;
            check = sum_into(check, brow);
        }
        // P_aa = B Φ_s,aᵀ on the upper triangle (pairs r ≤ q), with Q_s added.
        let mut paa = [[T::zero(); R]; R];
        for (qq, (frow, (cols, &n))) in fs
            .iter()
            .zip(phi.cols.iter().zip(phi.count.iter()))
            .enumerate()
        {
            for (r, brow) in b.iter().enumerate().take(qq + 1) {
                let mut acc = T::zero();
                for (&k, &f) in cols.get(..n).unwrap_or(&[]).iter().zip(frow.iter()) {
                    acc += at(brow, usize::from(k)) * f;
                }
                if let Some(e) = paa.get_mut(r).and_then(|row| row.get_mut(qq)) {
                    *e = acc;
                }
            }
        }
        let pos = |i: usize| phi.index.iter().position(|&k| k == i);
        let qs = |i: usize, j: usize, v: T| v * at(inv, i) * at(inv, j);
        let mut diag_static = [T::zero(); N];
        for (i, ((d, &qd), &a)) in diag_static
            .iter_mut()
            .zip(q.diag.iter())
            .zip(active.iter())
            .enumerate()
        {
            let v = if qd != T::zero() {
                qs(i, i, qd)
            } else {
                T::zero()
            };
            if a {
                if let Some(e) = pos(i).and_then(|r| paa.get_mut(r).and_then(|row| row.get_mut(r)))
                {
                    *e += v;
                }
            } else {
                *d = at(ps, i * N + i) + v;
                check += *d;
            }
        }
        let mut pairs_static = [(0usize, T::zero()); P];
        for (&(i, j, v), slot) in q.pairs.iter().zip(pairs_static.iter_mut()) {
            let v = qs(i, j, v);
            match (pos(i), pos(j)) {
                (Some(r), Some(c)) => {
                    let (r, c) = (r.min(c), r.max(c));
                    if let Some(e) = paa.get_mut(r).and_then(|row| row.get_mut(c)) {
                        *e += v;
                    }
                }
                // One active: the new value is that row's, in `b`.
                (Some(r), None) | (None, Some(r)) => {
                    let other = if pos(i).is_some() { j } else { i };
                    if let Some(e) = b.get_mut(r).and_then(|row| row.get_mut(other)) {
                        *e += v;
                        check += v;
                    }
                }
                (None, None) => {
                    let k = upper::<N>(i, j);
                    *slot = (k, at(ps, k) + v);
                    check += slot.1;
                }
            }
        }
        for (r, row) in paa.iter().enumerate() {
            for &v in row.iter().skip(r) {
                check += v;
            }
        }
        if !check.is_finite() {
            self.health.non_finite += 1;
            return;
        }
        // Write back: the active rows whole from B (their static columns are final), then
        // the active block from P_aa over B's values there, then the rest's Q.
        let ps = self.ps.as_mut_slice();
        for (brow, (&xn, &i)) in b.iter().zip(x_new.iter().zip(phi.index.iter())) {
            if let Some(x) = self.xs.get_mut(i) {
                *x = xn;
            }
            // Row i of P: columns j < i are the top of stored column i (contiguous), j ≥ i
            // row i of the stored triangle (one element per column).
            let (left, right) = brow.split_at(i.min(N));
            if let Some(dst) = ps.get_mut(i * N..i * N + left.len()) {
                dst.copy_from_slice(left);
            }
            store_strided::<T, N>(ps.get_mut(i * N + i..).unwrap_or(&mut []), right);
        }
        for (r, (row, &i)) in paa.iter().zip(phi.index.iter()).enumerate() {
            for (&v, &j) in row.iter().zip(phi.index.iter()).skip(r) {
                if let Some(e) = ps.get_mut(upper::<N>(i, j)) {
                    *e = v;
                }
            }
        }
        for (i, (&d, &a)) in diag_static.iter().zip(active.iter()).enumerate() {
            if !a {
                if let Some(e) = ps.get_mut(i * N + i) {
                    *e = d;
                }
            }
        }
        for (k, v) in pairs_static {
            if v != T::zero() {
                if let Some(e) = ps.get_mut(k) {
                    *e = v;
                }
            }
        }
        self.clamp_variances();
    }

    /// Sequential scalar update with measurement row `h` (physical units), measurement
    /// `z`, noise variance `r`, and gate `gate` in standard deviations. Works over the
    /// non-zero entries of `h` (a matching row has at most a dozen) and the stored triangle.
    pub fn update_scalar(&mut self, h: &SVector<T, N>, z: T, r: T, gate: T) -> ScalarUpdate<T> {
        // h's non-zeros (scaled h_j = h_j s_j), their columns listed (a byte each).
        let (hs, sc) = (h.as_slice(), self.scale.as_slice());
        let mut nz = [0u8; N];
        let mut n_nz = 0;
        for (j, (&hj, &sj)) in hs.iter().zip(sc.iter()).enumerate() {
            if hj * sj != T::zero() {
                if let Some(c) = nz.get_mut(n_nz) {
                    *c = j as u8;
                }
                n_nz += 1;
            }
        }
        let nz = nz.get(..n_nz).unwrap_or(&[]);
        let scaled_h = |j: usize| {
            hs.get(j).copied().unwrap_or_else(T::zero) * sc.get(j).copied().unwrap_or_else(T::zero)
        };
        // P h: row j of P times the scaled h_j, summed over the non-zeros (P symmetric).
        let mut ph = [T::zero(); N];
        let ps = self.ps.as_slice();
        for &j in nz {
            let j = usize::from(j);
            add_row(&mut ph, scaled_h(j), ps, j);
        }
        let (mut hph, mut hx) = (T::zero(), T::zero());
        for &j in nz {
            let j = usize::from(j);
            let at = |v: &[T]| v.get(j).copied().unwrap_or_else(T::zero);
            let v = scaled_h(j);
            hph += v * at(&ph);
            hx += v * at(self.xs.as_slice());
        }
        let s = hph + r;
        let innovation = z - hx;
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
        let inv_s = T::one() / s;
        let mut k = [T::zero(); N];
        gain_step(&mut k, self.xs.as_mut_slice(), &ph, inv_s, innovation);
        // P ← P − K (P h)ᵀ on the upper triangle, the diagonal clamped to the floor.
        let clamped = rank_one_downdate::<T, N>(self.ps.as_mut_slice(), &ph, &k, self.floor);
        self.health.variance_clamped += clamped;
        self.health.updates += 1;
        ScalarUpdate {
            innovation,
            variance: s,
            test_ratio,
            accepted: true,
        }
    }

    fn clamp_variances(&mut self) {
        let ps = self.ps.as_mut_slice();
        for i in 0..N {
            if let Some(d) = ps.get_mut(i * N + i) {
                if *d < self.floor {
                    *d = self.floor;
                    self.health.variance_clamped += 1;
                }
            }
        }
    }
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
        // Φ = [[1, 0.1], [0, 1]]: row 0 is not the identity's.
        let mut phi = Transition::<f64, 2, 1>::new([0]);
        phi.set_row(0, &[1.0, 0.1]);
        let q = Noise::<f64, 2, 0> {
            diag: [0.01, 0.02],
            pairs: [],
        };
        kf.predict(&phi, &q);
        let dense = Matrix2::new(1.0, 0.1, 0.0, 1.0);
        let qd = Matrix2::new(0.01, 0.0, 0.0, 0.02);
        assert!((kf.state() - dense * x).norm() < 1e-12);
        assert!((kf.covariance() - (dense * p * dense.transpose() + qd)).norm() < 1e-12);
    }

    #[test]
    fn decay_then_predict_equals_dense_propagation() {
        // State 2 decays by d and no other row reads it: Φ = Φ_rest · diag(1, 1, d).
        let p0 = nalgebra::Matrix3::new(4.0, 1.0, 0.5, 1.0, 9.0, 0.3, 0.5, 0.3, 2.0);
        let mut kf = Kalman::<f64, 3>::new(&p0, 1e-12);
        kf.update_scalar(&nalgebra::Vector3::new(1.0, 0.0, 1.0), 1.0, 0.5, 100.0);
        let (x, p) = (kf.state(), kf.covariance());
        let d = 0.9;
        let mut phi = Transition::<f64, 3, 1>::new([0]);
        phi.set_row(0, &[1.0, 0.1, 0.0]);
        let q = Noise::<f64, 3, 0> {
            diag: [0.01, 0.02, 0.03],
            pairs: [],
        };
        kf.decay(2, d);
        kf.predict(&phi, &q);
        let dense = nalgebra::Matrix3::new(1.0, 0.1, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, d);
        let qd = nalgebra::Matrix3::from_diagonal(&nalgebra::Vector3::from(q.diag));
        assert!((kf.state() - dense * x).norm() < 1e-12);
        assert!((kf.covariance() - (dense * p * dense.transpose() + qd)).norm() < 1e-12);
    }

    #[test]
    fn predict_with_active_blocks_and_pairs_equals_dense_propagation() {
        // Four states: rows 0 and 2 not the identity's, a Q pair on (2, 3) and one on (1, 3).
        let p0 = nalgebra::Matrix4::new(
            4.0, 1.0, 0.5, 0.2, 1.0, 9.0, 0.3, 0.1, 0.5, 0.3, 2.0, 0.4, 0.2, 0.1, 0.4, 1.0,
        );
        let mut kf = Kalman::<f64, 4>::new(&p0, 1e-12);
        kf.update_scalar(&nalgebra::Vector4::new(1.0, 0.0, 1.0, 0.0), 1.0, 0.5, 100.0);
        let (x, p) = (kf.state(), kf.covariance());
        let mut phi = Transition::<f64, 4, 2>::new([0, 2]);
        phi.set_row(0, &[1.0, 0.1, 0.0, 0.3]);
        phi.set_row(1, &[0.0, 0.2, 0.9, 0.05]);
        let q = Noise::<f64, 4, 2> {
            diag: [0.01, 0.02, 0.03, 0.04],
            pairs: [(2, 3, 0.005), (1, 3, 0.002)],
        };
        kf.predict(&phi, &q);
        let dense = nalgebra::Matrix4::from_fn(|i, j| phi.get(i, j));
        let mut qd = nalgebra::Matrix4::from_diagonal(&nalgebra::Vector4::from(q.diag));
        for (i, j, v) in q.pairs {
            qd[(i, j)] = v;
            qd[(j, i)] = v;
        }
        assert!((kf.state() - dense * x).norm() < 1e-12);
        assert!((kf.covariance() - (dense * p * dense.transpose() + qd)).norm() < 1e-12);
        let ps = kf.scaled_covariance();
        assert_eq!(ps, ps.transpose());
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
        let mut phi = Transition::<f32, 2, 1>::new([0]);
        phi.set_row(0, &[f32::INFINITY, 0.0]);
        let q = Noise::<f32, 2, 0> {
            diag: [0.0; 2],
            pairs: [],
        };
        kf.predict(&phi, &q);
        assert_eq!(kf.health.non_finite, 2);
        assert_eq!(kf.covariance(), Matrix2::identity());
    }

    /// A symmetric positive definite 9 × 9 covariance with unequal scales and every
    /// element non-zero: `A Aᵀ + diag`, `A` filled from a fixed sequence.
    fn p0_nine() -> nalgebra::SMatrix<f64, 9, 9> {
        let a = nalgebra::SMatrix::<f64, 9, 9>::from_fn(|i, j| {
            (((i * 7 + j * 3) % 11) as f64 - 5.0) * 0.1 * (1.0 + i as f64)
        });
        a * a.transpose() + nalgebra::SMatrix::<f64, 9, 9>::from_diagonal_element(0.5)
    }

    #[test]
    fn scalar_update_on_nine_states_equals_the_dense_formula() {
        // Nine states: two groups of four columns and one alone in the downdate, h with
        // zeros (a sparse row) and non-zeros on both sides of the diagonal.
        let p0 = p0_nine();
        let mut kf = Kalman::<f64, 9>::new(&p0, 1e-12);
        let h = nalgebra::SVector::<f64, 9>::from_column_slice(&[
            0.0, 1.0, 0.0, 0.0, -0.5, 0.0, 2.0, 0.0, 0.3,
        ]);
        let (z, r) = (0.7, 0.2);
        let u = kf.update_scalar(&h, z, r, 1e6);
        assert!(u.accepted);
        let ph = p0 * h;
        let s = h.dot(&ph) + r;
        let k = ph / s;
        let x = k * z;
        let p = p0 - k * ph.transpose();
        // Rounding only: relative to the matrices' size (entries up to ~10²).
        assert!((kf.state() - x).norm() < 1e-12 * x.norm());
        assert!((kf.covariance() - p).norm() < 1e-12 * p.norm());
        let ps = kf.scaled_covariance();
        assert_eq!(ps, ps.transpose());
    }

    #[test]
    fn predict_with_six_rows_sharing_their_columns_equals_dense_propagation() {
        // Rows 0–5 share their columns (propagated together), row 6 (state 8) has its own;
        // a Q pair between an active and a static state.
        let p0 = p0_nine();
        let mut kf = Kalman::<f64, 9>::new(&p0, 1e-12);
        kf.update_scalar(
            &nalgebra::SVector::<f64, 9>::from_column_slice(&[
                1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0,
            ]),
            1.0,
            0.5,
            1e6,
        );
        let (x, p) = (kf.state(), kf.covariance());
        let mut phi = Transition::<f64, 9, 7>::new([0, 1, 2, 3, 4, 5, 8]);
        for r in 0..6 {
            let mut row = [0.0; 9];
            for (j, e) in row.iter_mut().enumerate() {
                if j < 6 || j == 7 {
                    *e = if j == r {
                        1.0
                    } else {
                        0.01 * (1 + r + 2 * j) as f64
                    };
                }
            }
            phi.set_row(r, &row);
        }
        phi.set_row_at(6, &[6, 8], |j| if j == 6 { 0.2 } else { 0.9 });
        let q = Noise::<f64, 9, 1> {
            diag: [0.01, 0.02, 0.03, 0.04, 0.05, 0.06, 0.07, 0.08, 0.09],
            pairs: [(8, 6, 0.004)],
        };
        kf.predict(&phi, &q);
        let dense = nalgebra::SMatrix::<f64, 9, 9>::from_fn(|i, j| phi.get(i, j));
        let mut qd =
            nalgebra::SMatrix::<f64, 9, 9>::from_diagonal(&nalgebra::SVector::from(q.diag));
        for (i, j, v) in q.pairs {
            qd[(i, j)] = v;
            qd[(j, i)] = v;
        }
        let (x1, p1) = (dense * x, dense * p * dense.transpose() + qd);
        assert!((kf.state() - x1).norm() < 1e-12 * x1.norm());
        assert!((kf.covariance() - p1).norm() < 1e-12 * p1.norm());
        let ps = kf.scaled_covariance();
        assert_eq!(ps, ps.transpose());
    }
}
