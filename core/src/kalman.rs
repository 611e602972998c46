//! A fixed-size Kalman filter with the habits of PX4's EKF2 (sequential scalar updates,
//! variances held to floors, innovation gating by test ratio, every anomaly counted in
//! health flags), its covariance kept as UD factors (Bierman's update, Thornton's time
//! update) so that it stays positive definite in `f32` whatever the correlations.
//!
//! States are held *scaled*: `x = S x_s` with `S = diag(scale)`, where the scales are
//! the initial standard deviations. In f32 a gyro bias variance of 1e-13 and a
//! velocity variance of 1e-2 would otherwise share one covariance matrix; scaled,
//! every diagonal starts at 1. Scaling does not help with correlations near 1 (a state
//! known far better than the states it is tied to): the factors carry those (see
//! [`Kalman`]).

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
    /// engine's layouts have at most 33 states; so is the count, 3 B a row less of the
    /// time update's stack than a `usize`).
    cols: [[u8; N]; R],
    count: [u8; R],
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

    /// Every row zero (none listed), for a caller that writes each of them with
    /// [`Transition::set_row_at`] or [`Transition::set_row`]: built where it is declared
    /// (the identity's rows of [`Transition::new`], written after the zeroing, made the
    /// board copy the whole value once more).
    #[inline(always)]
    pub fn zeroed(index: [usize; R]) -> Self {
        Self {
            index,
            values: [[T::zero(); N]; R],
            cols: [[0; N]; R],
            count: [0; R],
        }
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
        // Only the listed columns can be non-zero (every other was never written or was
        // written zero): clearing them clears the row, without a pass over all N.
        for &c in cols.get(..usize::from(*count)).unwrap_or(&[]) {
            if let Some(e) = dst.get_mut(usize::from(c)) {
                *e = T::zero();
            }
        }
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
        *count = u8::try_from(n).unwrap_or(u8::MAX);
    }

    /// Rows `0..m` all zero, none of their columns listed (the listed ones cleared, as
    /// [`Transition::set_row_at`] clears a row), for [`Transition::push_column`].
    pub fn clear_rows(&mut self, m: usize) {
        let rows = self
            .values
            .iter_mut()
            .zip(&self.cols)
            .zip(self.count.iter_mut());
        for ((dst, cols), count) in rows.take(m) {
            for &c in cols.get(..usize::from(*count)).unwrap_or(&[]) {
                if let Some(e) = dst.get_mut(usize::from(c)) {
                    *e = T::zero();
                }
            }
            *count = 0;
        }
    }

    /// Column `j` of rows `0..6` set to `column`, `j` listed in each row where it is not
    /// zero: after [`Transition::clear_rows`], columns pushed in ascending order give the
    /// rows [`Transition::set_row_at`] gives from the same values (the error model builds
    /// Φ's first six rows, δv's and ψ's, a column at a time).
    #[inline(always)]
    pub fn push_column(&mut self, j: usize, column: &[T; LANES]) {
        if j < N {
            let (values, cols) = (self.values.as_flattened_mut(), self.cols.as_flattened_mut());
            push_column_n(values, cols, &mut self.count, (N, j), column);
        }
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

/// The filter: scaled state, and the scaled covariance as its UD factors (Bierman),
/// dimension `N`.
///
/// `P_s = U D Uᵀ`, `U` unit upper triangular, `D` diagonal and never negative: `D_j` is the
/// variance of state `j` given the states after it, and `U(i, j)` how state `i` follows
/// state `j`. A state known far better than the states it is tied to (a precise master
/// attitude ties ψ to the misalignment and the flexure to 1 − 10⁻⁸) keeps its small
/// conditional variance in `D`, where a plain `P` in `f32` (ε 6·10⁻⁸) loses it in the
/// rounding of `P_ψψ ≈ P_μμ`: `P` built from the factors is positive semi-definite by
/// construction, whatever the precision.
///
/// The filter holds its states in an internal order, the *static* states (an identity
/// transition and no process noise: the misalignment, biases without a random walk, the
/// constant effects) last, where the time update leaves their factors without arithmetic
/// (see [`orthogonalize`]); every index of its interface is the caller's
/// ([`Kalman::restart_factored`] takes which states are static).
#[derive(Clone, Debug)]
pub struct Kalman<T: Real, const N: usize> {
    /// Internal position of each state (the caller's index).
    pos: [u8; N],
    /// The state at each internal position: `pos`'s inverse.
    state_at: [u8; N],
    /// The scaled state; this and every field below in the internal order.
    xs: SVector<T, N>,
    /// `U(i, j)` at `i N + j` (row-major: row `i` of U contiguous, as `f = Uᵀ h` and
    /// Bierman's sweep read it, and as the time update's Gram-Schmidt matrix starts),
    /// the unit diagonal and zeros below it stored too (nalgebra's element `(j, i)`).
    u: SMatrix<T, N, N>,
    /// `D_j`.
    d: SVector<T, N>,
    scale: SVector<T, N>,
    /// `1 / scale`, so that scaling Φ and Q takes no division.
    inv_scale: SVector<T, N>,
    floor: T,
    /// Health counters.
    pub health: Health,
}

/// A filter's factors borrowed for any `n` ([`Kalman::parts`]): the covariance reads and
/// the rank-one addition of the engine's tilt–bias floor, one copy for the board's two
/// layouts (one per size, inlined into each layout's time update, cost ≈ 0.9 kB of flash;
/// docs/performance.md, "What issue12-s21 changed"). Each the arithmetic of the
/// [`Kalman`] method of its name, which calls the same code.
pub(crate) struct Parts<'a, T> {
    u: &'a mut [T],
    d: &'a mut [T],
    xs: &'a [T],
    scale: &'a [T],
    inv_scale: &'a [T],
    pos: &'a [u8],
    health: &'a mut Health,
}

impl<T: Real> Parts<'_, T> {
    /// [`Kalman::cov`].
    pub(crate) fn cov(&self, i: usize, j: usize) -> T {
        let n = self.pos.len();
        let internal = |i: usize| self.pos.get(i).map_or(n, |&p| usize::from(p));
        let (a, b) = (internal(i), internal(j));
        let (u, d) = (&*self.u, &*self.d);
        match (self.scale.get(a), self.scale.get(b)) {
            (Some(sa), Some(sb)) if a == b => scaled_diag_n(u, d, n, a) * *sa * *sb,
            (Some(sa), Some(sb)) => scaled_off_n(u, d, n, (a, b)) * *sa * *sb,
            _ => T::zero(),
        }
    }

    /// [`Kalman::variance_along`], `h` and `f` two `n`-element temporaries (zero) lent by
    /// the caller.
    pub(crate) fn variance_along(&self, c: &[(usize, T)], hf: [&mut [T]; 2]) -> Option<T> {
        let factors = (&*self.u, self.xs, self.scale, self.pos);
        variance_along_n(self.d, factors, c, hf)
    }

    /// [`Kalman::add_rank_one`], `v` an `n`-element temporary lent by the caller (its
    /// contents are not read: it is zeroed first).
    pub(crate) fn add_rank_one(&mut self, c: &[(usize, T)], alpha: T, v: &mut [T]) {
        v.fill(T::zero());
        let (u, d, inv_scale, pos, health) = (
            &mut *self.u,
            &mut *self.d,
            self.inv_scale,
            self.pos,
            &mut *self.health,
        );
        let n = pos.len();
        let internal = |i: usize| pos.get(i).map_or(n, |&p| usize::from(p));
        // c in the internal order, scaled as a covariance's column (P_s = S⁻¹ P S⁻¹).
        let mut in_range = alpha >= T::zero() && alpha.is_finite();
        for &(i, ci) in c {
            let a = internal(i);
            match (v.get_mut(a), inv_scale.get(a)) {
                (Some(e), Some(&inv)) => *e += ci * inv,
                _ => in_range = false,
            }
        }
        if !in_range {
            health.non_finite += 1;
            return;
        }
        let mut a = alpha;
        for j in (0..n).rev() {
            let s = v.get(j).copied().unwrap_or_else(T::zero);
            let Some(dj) = d.get_mut(j) else { continue };
            if s == T::zero() {
                continue;
            }
            let dn = *dj + a * s * s;
            let positive = dn > T::zero() && dn.is_finite();
            if !positive {
                continue;
            }
            let b = a * s / dn;
            a = a * *dj / dn;
            *dj = dn;
            for (i, vi) in v.iter_mut().enumerate().take(j) {
                if let Some(uij) = u.get_mut(i * n + j) {
                    *vi -= s * *uij;
                    *uij += b * *vi;
                }
            }
        }
    }
}

/// `P_s(b, b) = D_b + Σ_{k>b} U(b, k)² D_k` ([`Kalman::scaled_diag`]), U `n × n` row-major.
#[inline(always)]
fn scaled_diag_n<T: Real>(u: &[T], d: &[T], n: usize, b: usize) -> T {
    let mut acc = T::zero() + d.get(b).copied().unwrap_or_else(T::zero);
    let row = u.get(b * n + b + 1..(b + 1) * n).unwrap_or(&[]);
    for (&ubk, &dk) in row.iter().zip(d.get(b + 1..).unwrap_or(&[])) {
        acc += ubk * ubk * dk;
    }
    acc
}

/// `P_s(i, j)` off the diagonal (`i ≠ j`; [`Kalman::scaled_at`]), U `n × n` row-major.
#[inline(always)]
fn scaled_off_n<T: Real>(u: &[T], d: &[T], n: usize, (i, j): (usize, usize)) -> T {
    let (a, b) = (i.min(j), i.max(j));
    // k = b first (U(b, b) = 1: `U(a, b) · 1 · D_b` is `U(a, b) · D_b`), then rows a
    // and b of U after column b, read as slices: the same terms in the same order.
    let (Some(&uab), Some(&db)) = (u.get(a * n + b), d.get(b)) else {
        return T::zero();
    };
    let mut acc = T::zero() + uab * db;
    let ra = u.get(a * n + b + 1..(a + 1) * n).unwrap_or(&[]);
    let rb = u.get(b * n + b + 1..(b + 1) * n).unwrap_or(&[]);
    for ((&uak, &ubk), &dk) in ra.iter().zip(rb).zip(d.get(b + 1..).unwrap_or(&[])) {
        acc += uak * ubk * dk;
    }
    acc
}

/// [`Kalman::variance_along`] on the factors of any `n` (`D` and [`project`]'s `(U, x_s,
/// s, pos)`), `h` and `f` two `n`-element temporaries (zero).
#[inline(always)]
fn variance_along_n<T: Real>(
    d: &[T],
    factors: (&[T], &[T], &[T], &[u8]),
    c: &[(usize, T)],
    [h, f]: [&mut [T]; 2],
) -> Option<T> {
    for &(i, ci) in c {
        *h.get_mut(i)? += ci;
    }
    project(f, (h, 0, 0), factors);
    // Over slices (nalgebra's iterator cost the board ≈ 20 instructions an element).
    let mut acc = T::zero();
    for (&dk, &fk) in d.iter().zip(f.iter()) {
        acc += dk * fk * fk;
    }
    Some(acc)
}

/// [`Transition::push_column`] on the rows' storage flattened, `n` columns a row, `j < n`:
/// one copy for every state dimension. The six rows written out, each element at a
/// fixed row offset (a loop over the rows cost the board 20 instructions an element).
#[inline(never)]
fn push_column_n<T: Real>(
    values: &mut [T],
    cols: &mut [u8],
    count: &mut [u8],
    (n, j): (usize, usize),
    column: &[T; LANES],
) {
    let mut put = |r: usize, v: T| {
        if let (Some(e), Some(c)) = (values.get_mut(r * n + j), count.get_mut(r)) {
            *e = v;
            if v != T::zero() {
                // The count read once (a store into `cols` could be one into it).
                let k = *c;
                if let Some(l) = cols.get_mut(r * n + usize::from(k)) {
                    *l = j as u8;
                }
                *c = k.wrapping_add(1);
            }
        }
    };
    let [v0, v1, v2, v3, v4, v5] = *column;
    put(0, v0);
    put(1, v1);
    put(2, v2);
    put(3, v3);
    put(4, v4);
    put(5, v5);
}

/// `dst[i] += a · src[i]` over the shorter of the two. A plain loop: on the board
/// (Cortex-M4, size-optimized) it runs at 6 instructions an element with post-incremented
/// loads and stores, where four a turn took 27 and its remainder loop's set-up cost more
/// again ("What issue12-s11 changed"); each element's arithmetic is the same.
#[inline(always)]
fn axpy<T: Real>(dst: &mut [T], a: T, src: &[T]) {
    for (d, &s) in dst.iter_mut().zip(src) {
        *d += a * s;
    }
}

/// `Σ a[i] b[i]` over the shorter of the two, in order, one product a loop turn. A plain
/// loop: the Gram-Schmidt's rows are short (a pivot's W or Q part, 6–12 elements), and
/// four products a turn in two partial sums, with the remainder's loop, cost the board
/// more in set-up than they saved ("What issue12-s22 changed" in `docs/performance.md`;
/// the sums' rounding differs from that form's, within the f32-against-f64 bound).
#[inline(always)]
fn dot<T: Real>(a: &[T], b: &[T]) -> T {
    let mut s0 = T::zero();
    for (&x, &y) in a.iter().zip(b) {
        s0 += x * y;
    }
    s0
}

/// `c[i] = d[i] w[i]` over the shortest of the three, and `dot(w, c)` over those (the
/// same products summed in the same order as [`dot`]): one pass instead of two (the
/// Gram-Schmidt's pivots, each row's two parts). A plain loop, as [`dot`].
#[inline(always)]
fn weigh<T: Real>(w: &[T], d: &[T], c: &mut [T]) -> T {
    let mut s0 = T::zero();
    for ((&x, &y), z) in w.iter().zip(d).zip(c.iter_mut()) {
        *z = y * x;
        s0 += x * *z;
    }
    s0
}

/// `dst ← src` (the shorter of the two), four elements a turn: the board's `memcpy` took
/// ≈ 5 instructions an element (105 for a 21-state row), a four-element block is a
/// load-multiple and a store-multiple. Out of line: one copy for the board's layouts.
#[inline(never)]
fn copy_words<T: Real>(dst: &mut [T], src: &[T]) {
    let mut d4 = dst.chunks_exact_mut(4);
    let mut s4 = src.chunks_exact(4);
    for (d, s) in (&mut d4).zip(&mut s4) {
        if let ([d0, d1, d2, d3], [s0, s1, s2, s3]) = (d, s) {
            (*d0, *d1, *d2, *d3) = (*s0, *s1, *s2, *s3);
        }
    }
    for (d, &s) in d4.into_remainder().iter_mut().zip(s4.remainder()) {
        *d = s;
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

/// Whether two lists of column indices are equal: four bytes a comparison (`==` on the
/// slices called `memcmp`, a byte a turn: ≈ 70 instructions a pair of Φ's rows on the
/// board, eight pairs a time update).
#[inline(always)]
fn same_columns(a: &[u8], b: &[u8]) -> bool {
    if a.len() != b.len() {
        return false;
    }
    let (a4, b4) = (a.chunks_exact(4), b.chunks_exact(4));
    let tail = a4
        .remainder()
        .iter()
        .zip(b4.remainder())
        .all(|(x, y)| x == y);
    let word = |c: &[u8]| <[u8; 4]>::try_from(c).map_or(0, u32::from_le_bytes);
    tail && a4.zip(b4).all(|(x, y)| word(x) == word(y))
}

/// Two rows `i`, `i + 1` of Bierman's update over the same columns: for every column `k`
/// of `r0` and `r1`, `U(·, k) ← U(·, k) + λ_k b` and then `b ← b + U(·, k)_old g_k`, each
/// row's `b` starting as the columns before left it; returns the two `b` at the end (rows
/// of `P h`). Each element's arithmetic is the column sweep's (λ and g do not depend on U,
/// so the columns' passes over U can be taken a row at a time, in the same order along
/// each row); λ_k and g_k read once for both rows. A plain loop, one column a turn: on
/// the board (Cortex-M4, size-optimized) it runs at 13 instructions a column with
/// post-incremented loads and stores, where four columns a turn took 60 and their
/// remainder loop's set-up ≈ 20 a pair ("What issue12-s11 changed").
#[inline(always)]
fn bierman_rows<T: Real>(
    r0: &mut [T],
    r1: &mut [T],
    lambda: &[T],
    g: &[T],
    (mut b0, mut b1): (T, T),
) -> (T, T) {
    for (((p, q), &l), &gk) in r0.iter_mut().zip(r1.iter_mut()).zip(lambda).zip(g) {
        let (u0, v0) = (*p, *q);
        *p = u0 + l * b0;
        b0 += u0 * gk;
        *q = v0 + l * b1;
        b1 += v0 * gk;
    }
    (b0, b1)
}

/// [`bierman_rows`] for three rows, each from `b = 0`: each element's arithmetic the
/// column sweep's, λ_k and g_k read once for the three rows.
#[inline(always)]
fn bierman_rows3<T: Real>([r0, r1, r2]: [&mut [T]; 3], lambda: &[T], g: &[T]) -> [T; 3] {
    let (mut b0, mut b1, mut b2) = (T::zero(), T::zero(), T::zero());
    let rows = r0.iter_mut().zip(r1.iter_mut()).zip(r2.iter_mut());
    for (((p, q), w), (&l, &gk)) in rows.zip(lambda.iter().zip(g)) {
        let (u0, v0, w0) = (*p, *q, *w);
        *p = u0 + l * b0;
        b0 += u0 * gk;
        *q = v0 + l * b1;
        b1 += v0 * gk;
        *w = w0 + l * b2;
        b2 += w0 * gk;
    }
    [b0, b1, b2]
}

/// The process noise's part of the weighted Gram-Schmidt matrix of a time update: `Q`'s
/// UD factors `Q = U_Q D_Q U_Qᵀ`, row-major, only the columns with a positive weight kept
/// (most states take no process noise: their columns would only add zeros).
struct NoisePart<T, const N: usize> {
    /// Row `i`: `U_Q(i, cols[t])` at `t`; zero before `first[i]`.
    w: [[T; N]; N],
    /// `D_Q` of the kept columns.
    dq: [T; N],
    /// The kept columns' states, ascending, `n` of them.
    cols: [u8; N],
    n: usize,
    /// First kept column at or after state `i`.
    first: [u8; N],
}

impl<T: Real, const N: usize> NoisePart<T, N> {
    /// All zero, for [`NoisePart::factor`] to fill in place (built and returned by value,
    /// the factors cost the board a copy of the whole value, 1.6k instructions a time
    /// update).
    #[inline(always)]
    fn zeroed() -> Self {
        Self {
            w: [[T::zero(); N]; N],
            dq: [T::zero(); N],
            cols: [0; N],
            n: 0,
            first: [0; N],
        }
    }

    /// From `Q`'s upper triangle (row-major, written by `fill` into `self` as
    /// [`NoisePart::zeroed`] built it): factored, a column's non-zeros found and only they
    /// eliminated (Q is a diagonal and a few pairs). A pivot that is not positive (a `Q`
    /// only semi-definite there) takes no column. `fill` also marks, per column, the rows
    /// above the diagonal it may have written (bit `i` of `above[j]`; the diagonal needs
    /// no mark): a column's non-zeros are looked for among those and the elimination's
    /// fill-in only, not along all the rows above it (a strided scan of the whole
    /// triangle per time update, 1.7k instructions on the board).
    #[inline(always)]
    fn factor(&mut self, fill: impl FnOnce(&mut [[T; N]; N], &mut [u64; N])) {
        const { assert!(N <= 64, "a column's rows are the bits of a u64") };
        let q = self;
        let mut above = [0u64; N];
        fill(&mut q.w, &mut above);
        let mut weight = [T::zero(); N];
        // Column j's non-zero rows, the first `n` (written before they are read).
        let mut nz = [0u8; N];
        for j in (0..N).rev() {
            let mut rows = above.get(j).copied().unwrap_or(0);
            let (Some(wj), Some(d)) = (q.w.get_mut(j), weight.get_mut(j)) else {
                continue;
            };
            let Some(e) = wj.get_mut(j) else {
                continue;
            };
            let dj = *e;
            if rows == 0 {
                // No row above marked (most columns: Q is a diagonal and a few pairs):
                // nothing to eliminate, the column's weight only.
                *d = if dj > T::zero() { dj } else { T::zero() };
                *e = T::one();
                continue;
            }
            let mut n = 0;
            // The marked rows in ascending order, each kept if its value is not zero
            // (the same list as a scan of every row above j).
            while rows != 0 {
                let i = rows.trailing_zeros() as usize;
                rows &= rows - 1;
                if q.at(i, j) != T::zero() {
                    if let Some(e) = nz.get_mut(n) {
                        *e = i as u8;
                    }
                    n += 1;
                }
            }
            let nz = nz.get(..n).unwrap_or(&[]);
            let pos = dj > T::zero();
            if pos {
                for (a, &i) in nz.iter().enumerate() {
                    let qi = q.at(usize::from(i), j);
                    for &k in nz.get(a..).unwrap_or(&[]) {
                        let qk = q.at(usize::from(k), j);
                        if let Some(e) =
                            q.w.get_mut(usize::from(i))
                                .and_then(|r| r.get_mut(usize::from(k)))
                        {
                            *e -= qi * qk / dj;
                        }
                        if k != i {
                            mark(&mut above, usize::from(i), usize::from(k));
                        }
                    }
                }
            }
            for &i in nz {
                if let Some(e) = q.w.get_mut(usize::from(i)).and_then(|r| r.get_mut(j)) {
                    *e = if pos { *e / dj } else { T::zero() };
                }
            }
            if let (Some(d), Some(e)) =
                (weight.get_mut(j), q.w.get_mut(j).and_then(|r| r.get_mut(j)))
            {
                *d = if pos { dj } else { T::zero() };
                *e = T::one();
            }
        }
        // Keep the weighted columns, moved left in each row (a kept column's index is at
        // least its position, so moving in ascending order reads before it writes). A
        // state's first kept column at or after it is the number kept before it.
        for ((m, &wm), f) in weight.iter().enumerate().zip(q.first.iter_mut()) {
            *f = q.n as u8;
            if wm > T::zero() {
                if let (Some(c), Some(d)) = (q.cols.get_mut(q.n), q.dq.get_mut(q.n)) {
                    *c = m as u8;
                    *d = wm;
                }
                let t = q.n;
                // Rows after m are zero at m and at t ≤ m (U_Q is upper triangular). A
                // column already in its place (every weighted column before it is too:
                // the error model's, whose noisy states come first) is not moved.
                for row in q.w.iter_mut().take(if t < m { m + 1 } else { 0 }) {
                    if let Some(v) = row.get(m).copied() {
                        if let Some(e) = row.get_mut(t) {
                            *e = v;
                        }
                    }
                }
                q.n += 1;
            }
        }
    }

    fn at(&self, i: usize, j: usize) -> T {
        self.w
            .get(i)
            .and_then(|r| r.get(j))
            .copied()
            .unwrap_or_else(T::zero)
    }
}

/// Marks row `i` of column `j` (`i < j`) as possibly not zero, for [`NoisePart::factor`].
#[inline(always)]
fn mark<const N: usize>(above: &mut [u64; N], i: usize, j: usize) {
    if let Some(m) = above.get_mut(j) {
        *m |= 1u64.checked_shl(i as u32).unwrap_or(0);
    }
}

/// Column-major unit upper triangular `U` (entries above the diagonal) turned in place
/// into its rows, row-major: row `i` at `i N`, `1` on the diagonal, zeros before it (the
/// filter's storage, and the rows of `W = Φ U` where Φ is the identity). The time
/// update's Gram-Schmidt leaves U column-major; a start factors P₀ column-major. The
/// columns from `t0` on are left as they are: the Gram-Schmidt's static columns, which
/// stay in U's rows (see [`orthogonalize`]; `N` for all).
#[inline(always)]
fn rows_of_u<T: Real, const N: usize>(u: &mut [T], t0: usize) {
    rows_of_u_n(u, N, t0);
}

/// [`rows_of_u`] for any `n` (one copy for the board's two layouts and its four callers).
#[inline(never)]
fn rows_of_u_n<T: Real>(u: &mut [T], n: usize, t0: usize) {
    let t0 = t0.min(n);
    for i in 0..t0 {
        // Row i's place (its diagonal to column t0) and the rows below it, whose element
        // i is column i of U: moved up, zeroed.
        let (top, below) = u.split_at_mut(((i + 1) * n).min(u.len()));
        let Some((diag, row)) = top
            .get_mut(i * n + i..i * n + t0)
            .and_then(|r| r.split_first_mut())
        else {
            continue;
        };
        *diag = T::one();
        for (e, r) in row.iter_mut().zip(below.chunks_exact_mut(n.max(1))) {
            if let Some(lower) = r.get_mut(i) {
                *e = *lower;
                *lower = T::zero();
            }
        }
    }
}

/// The modified weighted Gram-Schmidt orthogonalization (Thornton) of
/// `W = [W_1 | W_Q]` with weights `diag(D, D_Q)`: the rows of `W_1` in `u` (row-major,
/// row `i` zero before column `lo[i]`), `D` in `d`, `W_Q` in `q`. The rows from the last
/// up, each earlier row made `Dw`-orthogonal to it, give `U` and `D` with
/// `U D Uᵀ = W Dw Wᵀ`: once row `j` is used its place in `u` takes column `j` of `U`, so
/// `u` ends column-major (the caller turns it into the filter's rows with [`rows_of_u`]:
/// W's rows are still read when their column of `U` is known). Each `D_j` below `floor`
/// is raised to it; returns how many were.
///
/// States from `t0` on are *static*: their rows of W are U's (Φ the identity there) and
/// take no noise. Their pivots then leave D and their rows as they are, and take each
/// earlier row's entry in their column as is (the row of U after the orthogonalization
/// against them is the unit row, so `a_ij = w_ij`): those columns of `U` are W's, left
/// where they are, in U's rows, with no arithmetic and no copy (the 33-state layout's
/// calibration constants; [`rows_of_u`] leaves them). Only the columns before `t0` end
/// column-major.
#[inline(always)]
fn orthogonalize<T: Real, const N: usize>(
    u: &mut [T],
    lo: &mut [u8; N],
    q: &mut NoisePart<T, N>,
    d: &mut [T],
    floor: T,
    t0: usize,
) -> u32 {
    let mut scratch = [[T::zero(); N]; 4];
    let [dw, cu, cq, col] = &mut scratch;
    let w = Gram {
        u,
        lo,
        qw: q.w.as_flattened_mut(),
        dq: &q.dq,
        first: &q.first,
        nq: q.n,
        d,
    };
    orthogonalize_n(w, [dw, cu, cq, col], floor, t0)
}

/// What [`orthogonalize_n`] works on: `n` = `lo.len()` states.
struct Gram<'a, T> {
    /// W_1's rows, row-major `n × n`.
    u: &'a mut [T],
    /// Where each row of W_1 starts being non-zero.
    lo: &'a mut [u8],
    /// W_Q's rows, row-major `n × n`, the first `nq` columns used.
    qw: &'a mut [T],
    dq: &'a [T],
    first: &'a [u8],
    nq: usize,
    d: &'a mut [T],
}

/// [`orthogonalize`] for any `n` (the board's two layouts share one copy), its four
/// `n`-element temporaries lent by the caller.
#[inline(never)]
fn orthogonalize_n<T: Real>(w: Gram<'_, T>, scratch: [&mut [T]; 4], floor: T, t0: usize) -> u32 {
    let Gram {
        u,
        lo,
        qw,
        dq,
        first,
        nq,
        d,
    } = w;
    let [dw, cu, cq, col] = scratch;
    let n = lo.len();
    for (e, &v) in dw.iter_mut().zip(d.iter()) {
        *e = v;
    }
    let mut clamped = 0;
    let t0 = t0.min(n);
    for j in (0..t0).rev() {
        let l = lo.get(j).map_or(n, |&v| usize::from(v));
        let fq = first.get(j).map_or(nq, |&v| usize::from(v));
        let (top, rest) = u.split_at_mut((j * n).min(u.len()));
        let (qtop, qrest) = qw.split_at_mut((j * n).min(qw.len()));
        let (wj, qj) = (
            rest.get(l..t0).unwrap_or(&[]),
            qrest.get(fq..nq).unwrap_or(&[]),
        );
        // c = Dw w_j over the row's non-zeros, and w_j · c.
        let dj =
            weigh(wj, dw.get(l..).unwrap_or(&[]), cu) + weigh(qj, dq.get(fq..).unwrap_or(&[]), cq);
        if dj > T::zero() {
            // Every row above j writes its element of column j below.
            let inv = T::one() / dj;
            let pivot = Pivot {
                w: wj,
                q: qj,
                cw: cu.get(..wj.len()).unwrap_or(&[]),
                cq: cq.get(..qj.len()).unwrap_or(&[]),
                l: l as u8,
            };
            // The earlier rows three at a time (the last two as a pair, one alone): each
            // of the pivot's elements read once for them (its loops' set-up, as costly as
            // their arithmetic, paid once per group).
            let mut rows = top
                .chunks_exact_mut(n.max(1))
                .zip(qtop.chunks_exact_mut(n.max(1)))
                .zip(lo.iter_mut())
                .zip(col.iter_mut())
                .map(|(((wi, qi), lo_i), uij)| {
                    let wi = wi.get_mut(l..t0).unwrap_or(&mut []);
                    (wi, qi.get_mut(fq..nq).unwrap_or(&mut []), lo_i, uij)
                });
            while let Some((w0, q0, lo0, u0)) = rows.next() {
                let Some((w1, q1, lo1, u1)) = rows.next() else {
                    let a = (dot(w0, pivot.cw) + dot(q0, pivot.cq)) * inv;
                    *u0 = a;
                    pivot.reduce(w0, q0, lo0, a);
                    break;
                };
                if let Some((w2, q2, lo2, u2)) = rows.next() {
                    let (w_0, w_1, w_2) = dot3([&*w0, &*w1, &*w2], pivot.cw);
                    let (q_0, q_1, q_2) = dot3([&*q0, &*q1, &*q2], pivot.cq);
                    let (a0, a1, a2) = ((w_0 + q_0) * inv, (w_1 + q_1) * inv, (w_2 + q_2) * inv);
                    (*u0, *u1, *u2) = (a0, a1, a2);
                    // Three comparisons written out: `[a0, a1, a2].iter().all(..)` was a
                    // loop over the array stored on the stack (≈ 0.4k instructions an
                    // update on the board).
                    let z = T::zero();
                    if a0 != z && a1 != z && a2 != z {
                        axpy3([w0, w1, w2], [a0, a1, a2], pivot.w);
                        axpy3([q0, q1, q2], [a0, a1, a2], pivot.q);
                        *lo0 = (*lo0).min(pivot.l);
                        *lo1 = (*lo1).min(pivot.l);
                        *lo2 = (*lo2).min(pivot.l);
                    } else {
                        pivot.reduce(w0, q0, lo0, a0);
                        pivot.reduce(w1, q1, lo1, a1);
                        pivot.reduce(w2, q2, lo2, a2);
                    }
                    continue;
                }
                let (w_0, w_1) = dot2(w0, w1, pivot.cw);
                let (q_0, q_1) = dot2(q0, q1, pivot.cq);
                let (a0, a1) = ((w_0 + q_0) * inv, (w_1 + q_1) * inv);
                (*u0, *u1) = (a0, a1);
                if a0 != T::zero() && a1 != T::zero() {
                    axpy2(w0, w1, -a0, -a1, pivot.w);
                    axpy2(q0, q1, -a0, -a1, pivot.q);
                    *lo0 = (*lo0).min(pivot.l);
                    *lo1 = (*lo1).min(pivot.l);
                } else {
                    pivot.reduce(w0, q0, lo0, a0);
                    pivot.reduce(w1, q1, lo1, a1);
                }
            }
        } else {
            col.fill(T::zero());
        }
        // Row j is used: its place takes column j of U.
        if let (Some(dst), Some(src)) = (rest.get_mut(..j), col.get(..j)) {
            copy_words(dst, src);
        }
        if let Some(e) = d.get_mut(j) {
            *e = if dj < floor {
                clamped += 1;
                floor
            } else {
                dj
            };
        }
    }
    clamped
}

/// The pivot row `j` of a Gram-Schmidt step: its W and Q parts over their non-zeros, the
/// same weighted (`D_w w_j`), and where its W part starts.
struct Pivot<'a, T> {
    w: &'a [T],
    q: &'a [T],
    cw: &'a [T],
    cq: &'a [T],
    l: u8,
}

impl<T: Real> Pivot<'_, T> {
    /// An earlier row (its W and Q parts over the pivot's columns, where it starts) made
    /// orthogonal to the pivot, `a` its projection on it: `w_i ← w_i − a w_j` if `a ≠ 0`.
    #[inline(never)]
    fn reduce(&self, w: &mut [T], q: &mut [T], lo: &mut u8, a: T) {
        if a != T::zero() {
            axpy(w, -a, self.w);
            axpy(q, -a, self.q);
            *lo = (*lo).min(self.l);
        }
    }
}

/// `(dot(a, c), dot(b, c))`, each bit for bit [`dot`]'s (the same products summed in the
/// same order), over the shortest of the three, `c` read once for both. A plain loop, as
/// [`dot`].
#[inline(always)]
fn dot2<T: Real>(a: &[T], b: &[T], c: &[T]) -> (T, T) {
    let (mut s0, mut s1) = (T::zero(), T::zero());
    for ((&x, &y), &w) in a.iter().zip(b).zip(c) {
        s0 += x * w;
        s1 += y * w;
    }
    (s0, s1)
}

/// [`dot2`] for three rows: each dot bit for bit [`dot`]'s, `c` read once for the three.
/// A plain loop, as [`dot`].
#[inline(always)]
fn dot3<T: Real>([a, b, e]: [&[T]; 3], c: &[T]) -> (T, T, T) {
    let z = T::zero();
    let (mut s0, mut s1, mut s2) = (z, z, z);
    for (((&x, &y), &v), &w) in a.iter().zip(b).zip(e).zip(c) {
        s0 += x * w;
        s1 += y * w;
        s2 += v * w;
    }
    (s0, s1, s2)
}

/// `d_k ← d_k − a_k src` for three rows (each element's arithmetic [`axpy`]'s with `−a_k`),
/// `src` read once for the three.
#[inline(always)]
fn axpy3<T: Real>([d0, d1, d2]: [&mut [T]; 3], [a0, a1, a2]: [T; 3], src: &[T]) {
    let (a0, a1, a2) = (-a0, -a1, -a2);
    for (((p, q), r), &s) in d0.iter_mut().zip(d1.iter_mut()).zip(d2.iter_mut()).zip(src) {
        *p += a0 * s;
        *q += a1 * s;
        *r += a2 * s;
    }
}

/// [`axpy`] on two rows with the same `src`, each element's arithmetic its own: `src`
/// read once for both. A plain loop, as [`axpy`].
#[inline(always)]
fn axpy2<T: Real>(d0: &mut [T], d1: &mut [T], a0: T, a1: T, src: &[T]) {
    for ((p, q), &s) in d0.iter_mut().zip(d1.iter_mut()).zip(src) {
        *p += a0 * s;
        *q += a1 * s;
    }
}

/// Rows of Φ that [`Kalman::phi_u_rows`] forms together when they share their columns
/// (the error model's δv and ψ: six rows over the same twelve columns and the augmented
/// ones), each U row read once for all of them.
const LANES: usize = 6;

/// `dst[e LANES + q] += f[q] · src[e]` for each lane `q` over the shorter of `dst`'s
/// `LANES`-element chunks and `src`: [`axpy`] on `LANES` rows at once, each element's
/// arithmetic its own. The rows are held column by column (chunk `e` the rows' elements
/// `e`), so one pointer walks all of them and each `src[e]` is read once: on the board two
/// pointers and six multiply-adds an element, where [`axpy2`] takes three pointers for two.
#[inline(always)]
fn axpy_lanes<T: Real>(dst: &mut [T], f: &[T; LANES], src: &[T]) {
    let [f0, f1, f2, f3, f4, f5] = *f;
    for (d, &s) in dst.chunks_exact_mut(LANES).zip(src) {
        if let [d0, d1, d2, d3, d4, d5] = d {
            *d0 += f0 * s;
            *d1 += f1 * s;
            *d2 += f2 * s;
            *d3 += f3 * s;
            *d4 += f4 * s;
            *d5 += f5 * s;
        }
    }
}

/// [`axpy_lanes`] with two sources: `dst[e LANES + q] += f[q] · s[e]`, then
/// `+= g[q] · t[e]` (each element's two terms in that order, as two passes add them),
/// over the shortest; `s` and `t` read once for the six lanes, each lane's element loaded
/// and stored once for both.
#[inline(always)]
fn axpy_lanes2<T: Real>(dst: &mut [T], (f, s): (&[T; LANES], &[T]), (g, t): (&[T; LANES], &[T])) {
    let [f0, f1, f2, f3, f4, f5] = *f;
    let [g0, g1, g2, g3, g4, g5] = *g;
    for ((d, &x), &y) in dst.chunks_exact_mut(LANES).zip(s).zip(t) {
        if let [d0, d1, d2, d3, d4, d5] = d {
            *d0 = *d0 + f0 * x + g0 * y;
            *d1 = *d1 + f1 * x + g1 * y;
            *d2 = *d2 + f2 * x + g2 * y;
            *d3 = *d3 + f3 * x + g3 * y;
            *d4 = *d4 + f4 * x + g4 * y;
            *d5 = *d5 + f5 * x + g5 * y;
        }
    }
}

/// `LANES` consecutive rows of `dst` (each `n` long) from `lanes`, where they are held
/// column by column (see [`axpy_lanes`]): one pass, each chunk of `LANES` read once and
/// its elements stored into the six rows (a row at a time, each element's lane read
/// through a bounds check, cost the board ≈ 5 instructions an element). Out of line: one
/// copy for the board's layouts.
#[inline(never)]
fn unlace<T: Real>(dst: &mut [T], n: usize, lanes: &[T]) {
    let mut rows = dst.chunks_exact_mut(n.max(1));
    let six = (
        rows.next(),
        rows.next(),
        rows.next(),
        rows.next(),
        rows.next(),
        rows.next(),
    );
    if let (Some(d0), Some(d1), Some(d2), Some(d3), Some(d4), Some(d5)) = six {
        let rows = d0.iter_mut().zip(d1.iter_mut()).zip(d2.iter_mut());
        let rows = rows
            .zip(d3.iter_mut())
            .zip(d4.iter_mut())
            .zip(d5.iter_mut());
        for ((((((a, b), c), d), e), f), lane) in rows.zip(lanes.chunks_exact(LANES)) {
            if let [v0, v1, v2, v3, v4, v5] = lane {
                (*a, *b, *c, *d, *e, *f) = (*v0, *v1, *v2, *v3, *v4, *v5);
            }
        }
    }
}

/// `LANES` rows of `W_1 = Φ_s U` that share their columns `cols` (the caller's index;
/// `pos` its internal positions), held column by column in `flat` (zero, `LANES × n`; see
/// [`axpy_lanes`]): for each column `k` at `a`, the rows' factors `Φ(r, k) s_a / s_r`
/// (`vals` the rows of Φ, `inv` their `1 / s_r`) times U's row `a` from its diagonal
/// (`u` row-major `n × n`), and `Φ x`'s terms. Two columns a pass where two come: each
/// element gets the first one's term and then the second's, as two passes give it (the
/// elements from the later diagonal on in one pass, [`axpy_lanes2`], those before it from
/// the earlier row alone). Returns the rows' first column (internal) and `Φ x`. Out of
/// line: one copy for the board's layouts.
#[inline(never)]
fn lanes_group<T: Real>(
    (flat, u, n): (&mut [T], &[T], usize),
    (cols, pos): (&[u8], &[u8]),
    (sc, xs): (&[T], &[T]),
    ([v0, v1, v2, v3, v4, v5], [i0, i1, i2, i3, i4, i5]): ([&[T]; LANES], [T; LANES]),
) -> (u8, [T; LANES]) {
    let at = |v: &[T], i: usize| v.get(i).copied().unwrap_or_else(T::zero);
    let (mut lo, mut xn) = (n as u8, [T::zero(); LANES]);
    let mut held: Option<(usize, [T; LANES])> = None;
    for &k in cols {
        let k = usize::from(k);
        let a = pos.get(k).map_or(n, |&a| usize::from(a));
        lo = lo.min(a as u8);
        let (sa, xa) = (at(sc, a), at(xs, a));
        let f = [
            at(v0, k) * sa * i0,
            at(v1, k) * sa * i1,
            at(v2, k) * sa * i2,
            at(v3, k) * sa * i3,
            at(v4, k) * sa * i4,
            at(v5, k) * sa * i5,
        ];
        let [x0, x1, x2, x3, x4, x5] = &mut xn;
        let [f0, f1, f2, f3, f4, f5] = f;
        *x0 += f0 * xa;
        *x1 += f1 * xa;
        *x2 += f2 * xa;
        *x3 += f3 * xa;
        *x4 += f4 * xa;
        *x5 += f5 * xa;
        let Some((a0, f0)) = held.take() else {
            held = Some((a, f));
            continue;
        };
        let m = a0.max(a);
        let (ae, fe) = if a0 < a { (a0, &f0) } else { (a, &f) };
        if let (Some(dst), Some(src)) = (
            flat.get_mut(ae * LANES..m * LANES),
            u.get(ae * n + ae..ae * n + m),
        ) {
            axpy_lanes(dst, fe, src);
        }
        if let (Some(dst), Some(s), Some(t)) = (
            flat.get_mut(m * LANES..),
            u.get(a0 * n + m..(a0 + 1) * n),
            u.get(a * n + m..(a + 1) * n),
        ) {
            axpy_lanes2(dst, (&f0, s), (&f, t));
        }
    }
    if let Some((a, f)) = held {
        let src = u.get(a * n + a..(a + 1) * n).unwrap_or(&[]);
        axpy_lanes(flat.get_mut(a * LANES..).unwrap_or(&mut []), &f, src);
    }
    (lo, xn)
}

/// Puts the factors into the order `state_at` (the state at each new position; `pos` its
/// inverse, `n` of each) if `U` stays upper triangular in it (no `U(i, j) ≠ 0` with
/// `pos i > pos j`): `u` (column-major `n × n`, entries above the diagonal) and each of
/// `vectors` are then permuted as they are (the same `P`, no arithmetic) and it returns
/// true; otherwise nothing changes. Not generic over `n`, so the board's two layouts share
/// one copy.
fn static_last<T: Real>(u: &mut [T], vectors: [&mut [T]; 3], pos: &[u8], state_at: &[u8]) -> bool {
    let n = pos.len();
    let at = |p: &[u8], i: usize| p.get(i).map_or(0, |&v| usize::from(v));
    let get = |u: &[T], i: usize, j: usize| u.get(i + j * n).copied().unwrap_or_else(T::zero);
    if n > 64 {
        return false;
    }
    for j in 0..n {
        for i in 0..j {
            if get(u, i, j) != T::zero() && at(pos, i) > at(pos, j) {
                return false;
            }
        }
    }
    // U(i, j) mirrored into the lower triangle (never read), then read back from there into
    // its place (pos i, pos j); pairs that change sides are zero (checked above).
    for j in 0..n {
        for i in 0..j {
            let v = get(u, i, j);
            if let Some(e) = u.get_mut(j + i * n) {
                *e = v;
            }
        }
    }
    for b in 0..n {
        for a in 0..b {
            let (i, k) = (at(state_at, a), at(state_at, b));
            let v = if i < k { get(u, k, i) } else { T::zero() };
            if let Some(e) = u.get_mut(a + b * n) {
                *e = v;
            }
        }
    }
    // The vectors along the permutation's cycles: v[a] ← v[state_at a].
    for v in vectors {
        let mut done = 0u64;
        for start in 0..n {
            let mut a = start;
            let first = v.get(start).copied().unwrap_or_else(T::zero);
            while done >> a & 1 == 0 {
                done |= 1 << a;
                let src = at(state_at, a);
                let x = if src == start {
                    first
                } else {
                    v.get(src).copied().unwrap_or_else(T::zero)
                };
                if let Some(e) = v.get_mut(a) {
                    *e = x;
                }
                a = src;
            }
        }
    }
    true
}

impl<T: Real, const N: usize> Kalman<T, N> {
    /// Creates the filter from the initial covariance `p0` (physical units, symmetric
    /// positive definite); the state scales are the square roots of its diagonal (a zero
    /// diagonal gets scale 1). `variance_floor` is the smallest allowed *scaled*
    /// conditional variance `D_j`, e.g. 1e-10.
    pub fn new(p0: &SMatrix<T, N, N>, variance_floor: T) -> Self {
        let mut k = Self::unstarted(variance_floor);
        k.restart(variance_floor, |p| p.copy_from(p0));
        k
    }

    /// A filter with zero state and covariance and unit scales, for [`Kalman::restart`] to
    /// start (all zeros and ones, so it can be written straight into its place; U's stored
    /// unit diagonal too is left to the start: with `D = 0` the covariance is zero either
    /// way). `SMatrix::identity()` or `mat::zeros()` for U here made the board's
    /// `configure_*` hold a second `N × N` matrix in its frame (+1.8 kB declared, +4.4 kB
    /// at 33 states; the stack's peak +288 B and +1.6 kB).
    #[inline(always)]
    pub fn unstarted(variance_floor: T) -> Self {
        Self {
            pos: core::array::from_fn(|i| i as u8),
            state_at: core::array::from_fn(|i| i as u8),
            xs: SVector::zeros(),
            u: SMatrix::zeros(),
            d: SVector::zeros(),
            scale: SVector::repeat(T::one()),
            inv_scale: SVector::repeat(T::one()),
            floor: variance_floor,
            health: Health::default(),
        }
    }

    /// Starts the filter again in place from the initial covariance that `fill_p0` writes
    /// (physical units, symmetric, positive definite in `T`) into the matrix it is given,
    /// which is this filter's own storage (no `N × N` temporary), factored there. The
    /// health counters are kept. A covariance whose correlations `T` cannot carry is not
    /// positive definite once rounded: give its factors ([`Kalman::restart_factored`]).
    /// The internal order is the caller's.
    pub fn restart(&mut self, variance_floor: T, fill_p0: impl FnOnce(&mut SMatrix<T, N, N>)) {
        self.pos = core::array::from_fn(|i| i as u8);
        self.state_at = self.pos;
        fill_p0(&mut self.u);
        self.set_scales(|u, _, i| mat::get(u, i, i));
        let (sc, u) = (self.scale, &mut self.u);
        for j in 0..N {
            for i in 0..=j {
                let v = mat::get(u, i, j) / (vget(&sc, i) * vget(&sc, j));
                mat::set(u, i, j, v);
            }
        }
        // U D Uᵀ of the upper triangle, in place: column j from the last, its pivot the
        // variance given the later states, the earlier block reduced by it.
        for j in (0..N).rev() {
            let dj = mat::get(&self.u, j, j);
            let pos = dj > T::zero();
            for i in 0..j {
                let pij = mat::get(&self.u, i, j);
                if pos {
                    for k in 0..=i {
                        let pkj = mat::get(&self.u, k, j);
                        let v = mat::get(&self.u, k, i) - pkj * pij / dj;
                        mat::set(&mut self.u, k, i, v);
                    }
                }
            }
            for i in 0..j {
                let v = if pos {
                    mat::get(&self.u, i, j) / dj
                } else {
                    T::zero()
                };
                mat::set(&mut self.u, i, j, v);
            }
            if let Some(e) = self.d.get_mut(j) {
                *e = dj.max(T::zero());
            }
        }
        rows_of_u::<T, N>(self.u.as_mut_slice(), N);
        self.xs.fill(T::zero());
        self.floor = variance_floor;
    }

    /// Starts the filter again in place from the initial covariance's factors, which
    /// `fill` writes (physical units) into this filter's own storage: `U` (unit upper
    /// triangular: only its entries above the diagonal are read) and `D` (not negative), so
    /// that `P₀ = U D Uᵀ`. Nothing of `P₀` is formed: its small conditional variances
    /// (ψ given the misalignment and the flexure, the master's attitude noise) stay exact.
    ///
    /// The states `is_static` names (an identity transition and no process noise at every
    /// time update) are then held last (see [`Kalman`]), if the factors allow it: none of
    /// them tied to a later state (`U(i, j) ≠ 0`, `i` static, `j` not), which would leave
    /// `U` not triangular in that order. Otherwise the order stays the caller's. Either
    /// way the filter is the same; the order only decides what a time update costs.
    pub fn restart_factored(
        &mut self,
        variance_floor: T,
        is_static: impl Fn(usize) -> bool,
        fill: impl FnOnce(&mut SMatrix<T, N, N>, &mut SVector<T, N>),
    ) {
        self.pos = core::array::from_fn(|i| i as u8);
        self.state_at = self.pos;
        self.u.fill(T::zero());
        self.d.fill(T::zero());
        fill(&mut self.u, &mut self.d);
        self.set_scales(|u, d, i| {
            let mut v = vget(d, i);
            for k in i + 1..N {
                let uik = mat::get(u, i, k);
                v += uik * uik * vget(d, k);
            }
            v
        });
        let (sc, inv) = (self.scale, self.inv_scale);
        for j in 0..N {
            let sj = vget(&sc, j);
            if let Some(e) = self.d.get_mut(j) {
                *e = (*e * vget(&inv, j) * vget(&inv, j)).max(T::zero());
            }
            for i in 0..j {
                let v = mat::get(&self.u, i, j) * sj * vget(&inv, i);
                mat::set(&mut self.u, i, j, v);
            }
        }
        self.xs.fill(T::zero());
        self.floor = variance_floor;
        self.order_static_last(is_static);
        rows_of_u::<T, N>(self.u.as_mut_slice(), N);
    }

    /// Moves the states `is_static` names behind the others (see [`static_last`]).
    fn order_static_last(&mut self, is_static: impl Fn(usize) -> bool) {
        let mut pos = [0u8; N];
        let mut state_at = [0u8; N];
        let mut n = 0;
        for pass in [false, true] {
            for (i, p) in pos.iter_mut().enumerate() {
                if is_static(i) == pass {
                    *p = n as u8;
                    if let Some(e) = state_at.get_mut(n) {
                        *e = i as u8;
                    }
                    n += 1;
                }
            }
        }
        let vectors = [
            self.d.as_mut_slice(),
            self.scale.as_mut_slice(),
            self.inv_scale.as_mut_slice(),
        ];
        if static_last(self.u.as_mut_slice(), vectors, &pos, &state_at) {
            self.pos = pos;
            self.state_at = state_at;
        }
    }

    /// Internal position of state `i` (`N` outside the filter).
    #[inline(always)]
    fn internal(&self, i: usize) -> usize {
        self.pos.get(i).map_or(N, |&p| usize::from(p))
    }

    /// The scales `s_i = √P_ii` (1 where that is zero or not finite) and their reciprocals,
    /// `var(u, d, i)` giving `P_ii` from the storage as filled.
    fn set_scales(&mut self, var: impl Fn(&SMatrix<T, N, N>, &SVector<T, N>, usize) -> T) {
        for i in 0..N {
            let v = var(&self.u, &self.d, i);
            let s = if v > T::zero() && v.is_finite() {
                v.sqrt_fast()
            } else {
                T::one()
            };
            if let (Some(e), Some(f)) = (self.scale.get_mut(i), self.inv_scale.get_mut(i)) {
                *e = s;
                *f = T::one() / s;
            }
        }
    }

    /// State estimate in physical units.
    pub fn state(&self) -> SVector<T, N> {
        SVector::from_fn(|i, _| self.state_at(i))
    }

    /// State `i`'s estimate in physical units: [`Kalman::state`]'s element `i`, without
    /// forming the others (the board's identifier reads three states per update).
    pub fn state_at(&self, i: usize) -> T {
        let a = self.internal(i);
        vget(&self.xs, a) * vget(&self.scale, a)
    }

    /// States `b`, `b + 1`, `b + 2` (physical units): a block of [`Kalman::state`] without
    /// forming the others (the engine's feedback and estimates read five blocks of 21).
    #[inline(never)]
    pub fn state3(&self, b: usize) -> nalgebra::Vector3<T> {
        nalgebra::Vector3::new(self.state_at(b), self.state_at(b + 1), self.state_at(b + 2))
    }

    /// Scaled covariance element `P_s(i, j) = Σ_{k ≥ max(i, j)} U(i, k) D_k U(j, k)` (O(N)),
    /// `i` and `j` the internal positions.
    fn scaled_at(&self, i: usize, j: usize) -> T {
        if i == j {
            return self.scaled_diag(i);
        }
        scaled_off_n(self.u.as_slice(), self.d.as_slice(), N, (i, j))
    }

    /// [`Self::scaled_at`] on the diagonal, `P_s(b, b) = D_b + Σ_{k>b} U(b, k)² D_k`:
    /// the same terms added in the same order (`1 · 1 · D_b` is `D_b`), row `b` of U
    /// read with a stride instead of through a bounds check and a diagonal test per
    /// element (the σ of every estimate the engine reports is one of these).
    fn scaled_diag(&self, b: usize) -> T {
        scaled_diag_n(self.u.as_slice(), self.d.as_slice(), N, b)
    }

    /// Covariance element (physical units).
    pub fn cov(&self, i: usize, j: usize) -> T {
        let (a, b) = (self.internal(i), self.internal(j));
        match (self.scale.get(a), self.scale.get(b)) {
            (Some(sa), Some(sb)) => self.scaled_at(a, b) * *sa * *sb,
            _ => T::zero(),
        }
    }

    /// Scaled covariance element `P_s(i, j)`.
    fn scaled(&self, i: usize, j: usize) -> T {
        self.scaled_at(self.internal(i), self.internal(j))
    }

    /// Covariance in physical units (for reports and tests; O(N³)).
    pub fn covariance(&self) -> SMatrix<T, N, N> {
        SMatrix::from_fn(|i, j| self.cov(i, j))
    }

    /// Standard deviation of state `i` (physical units).
    pub fn sigma(&self, i: usize) -> T {
        // `cov(i, i)`'s arithmetic (`P_s(a, a) · s_a · s_a`) without its two lookups and
        // its test for the diagonal (a call per reported σ).
        let a = self.internal(i);
        let var = self
            .scale
            .get(a)
            .map_or(T::zero(), |&s| self.scaled_diag(a) * s * s);
        // Not below zero: a comparison (`max` is a software `fmaxf` call on the board,
        // twelve σ an update).
        let var = if var > T::zero() { var } else { T::zero() };
        var.sqrt_fast()
    }

    /// Scaled covariance (dimensionless; what the numerics act on), formed from the
    /// factors (O(N³), for checks and reports).
    pub fn scaled_covariance(&self) -> SMatrix<T, N, N> {
        SMatrix::from_fn(|i, j| self.scaled(i, j))
    }

    /// Scaled variance `P_s(i, i)` (O(N)).
    pub fn scaled_variance(&self, i: usize) -> T {
        self.scaled(i, i)
    }

    /// The smallest conditional variance `D_j` (scaled): the covariance is positive
    /// definite exactly when it is positive.
    pub fn min_conditional_variance(&self) -> T {
        self.d
            .iter()
            .copied()
            .reduce(T::min)
            .unwrap_or_else(T::zero)
    }

    /// Sets the states listed in `indices` to zero after their estimate has been fed
    /// back into the nominal solution (closed loop).
    pub fn reset_states(&mut self, indices: core::ops::Range<usize>) {
        for i in indices {
            if let Some(x) = self.xs.get_mut(self.internal(i)) {
                *x = T::zero();
            }
        }
    }

    /// Freezes the states in `indices` at their current estimate: their rows and
    /// columns of the covariance are zeroed and their variances set to the floor, so
    /// later updates leave them (practically) unchanged. Used to estimate on one part of
    /// a recording and predict the innovations of the rest. (A time update with Φ zero on
    /// those rows and Q the floor there, the estimate kept.)
    pub fn freeze(&mut self, indices: core::ops::Range<usize>) {
        let floor = self.floor;
        let pos = self.pos;
        let internal = indices.filter_map(|i| pos.get(i).map(|&a| usize::from(a)));
        let mut q = NoisePart::<T, N>::zeroed();
        q.factor(|w, _| {
            for i in internal.clone() {
                if let Some(e) = w.get_mut(i).and_then(|r| r.get_mut(i)) {
                    *e = floor;
                }
            }
        });
        let u = self.u.as_mut_slice();
        let mut lo: [u8; N] = core::array::from_fn(|i| i as u8);
        for i in internal {
            if let (Some(row), Some(l)) = (u.get_mut(i * N..(i + 1) * N), lo.get_mut(i)) {
                row.fill(T::zero());
                *l = N as u8;
            }
        }
        orthogonalize(u, &mut lo, &mut q, self.d.as_mut_slice(), floor, N);
        rows_of_u::<T, N>(u, N);
    }

    /// Scales state `i` by `d > 0`: `x_i ← d x_i`, row and column `i` of P by `d` (`P_ii`
    /// by `d²`): `D_i` by `d²`, row `i` of U by `d` and its column by `1 / d`. The
    /// transition of a state that decays on its own (a first-order Gauss-Markov state,
    /// `d = e^{−t/τ}`) and that no other row of Φ reads: then `Φ = Φ_rest · D` with `D`
    /// this scaling, and applying it before [`Self::predict`] with `Φ_rest` is the full
    /// time update, at O(N) instead of a row of Φ. A `d` whose reciprocal is not finite
    /// is refused (counted as non-finite).
    pub fn decay(&mut self, i: usize, d: T) {
        let inv = T::one() / d;
        let i = self.internal(i);
        if i >= N || !(d > T::zero() && inv.is_finite()) {
            self.health.non_finite += 1;
            return;
        }
        if let Some(x) = self.xs.get_mut(i) {
            *x *= d;
        }
        if let Some(e) = self.d.get_mut(i) {
            *e *= d * d;
        }
        for j in 0..N {
            let f = if j > i { d } else { inv };
            if j != i {
                let (r, c) = (i.min(j), i.max(j));
                // U(r, c) is nalgebra's element (c, r) (row-major).
                let v = mat::get(&self.u, c, r) * f;
                mat::set(&mut self.u, c, r, v);
            }
        }
    }

    /// `cᵀ P c` (physical units; `c` by its non-zeros `(state, value)`), from the factors
    /// as `Σ_k D_k (Uᵀ S c)_k²` (`Uᵀ S c` by [`project`], the update's `f = Uᵀ h`): a
    /// variance far below the states' own (a combination the data fix much better than
    /// its parts) without the cancellation of forming `P`. `None` if a state is out of
    /// range.
    pub fn variance_along(&self, c: &[(usize, T)]) -> Option<T> {
        let (mut h, mut f) = ([T::zero(); N], [T::zero(); N]);
        let factors = (
            self.u.as_slice(),
            self.xs.as_slice(),
            self.scale.as_slice(),
            self.pos.as_slice(),
        );
        variance_along_n(self.d.as_slice(), factors, c, [&mut h, &mut f])
    }

    /// `P ← P + α c cᵀ` (physical units; `c` by its non-zeros `(state, value)`, `α ≥ 0`)
    /// in the factors, by Agee and Turner's rank-one update (Bierman, *Factorization
    /// Methods for Discrete Sequential Estimation*, 1977, ch. V): from the last internal
    /// position down, each `D_j` takes its share of `α` and the column of U above it the
    /// part of `c` it leaves; positions above the highest non-zero are untouched. The
    /// state estimate does not change. A negative or non-finite `α`, or a state out of
    /// range, is refused (counted as non-finite).
    pub fn add_rank_one(&mut self, c: &[(usize, T)], alpha: T) {
        let mut v = [T::zero(); N];
        self.parts().add_rank_one(c, alpha, &mut v);
    }

    /// The factors borrowed for any `n` ([`Parts`]).
    pub(crate) fn parts(&mut self) -> Parts<'_, T> {
        Parts {
            u: self.u.as_mut_slice(),
            d: self.d.as_mut_slice(),
            xs: self.xs.as_slice(),
            scale: self.scale.as_slice(),
            inv_scale: self.inv_scale.as_slice(),
            pos: &self.pos,
            health: &mut self.health,
        }
    }

    /// Time update `x ← Φ x`, `P ← Φ P Φᵀ + Q` (physical-unit Φ and Q), in the factors:
    /// `W = [Φ U | U_Q]` with the weights `diag(D, D_Q)` orthogonalized row by row
    /// (Thornton's modified weighted Gram-Schmidt) gives the new `U` and `D`. Φ U is
    /// formed only on Φ's non-identity rows (each over its non-zero columns), and each
    /// row of W is zero before its first column, which the orthogonalization skips. A
    /// step with a non-finite input is refused.
    pub fn predict<const R: usize, const P: usize>(
        &mut self,
        phi: &Transition<T, N, R>,
        q: &Noise<T, N, P>,
    ) {
        let (inv, pos) = (self.inv_scale.as_slice(), &self.pos);
        let at = |v: &[T], i: usize| v.get(i).copied().unwrap_or_else(T::zero);
        let internal = |i: usize| pos.get(i).map_or(N, |&a| usize::from(a));
        let (q_diag, q_pairs) = (&q.diag, &q.pairs);
        // Q_s = S⁻¹ Q S⁻¹ on the upper triangle (internal order), factored; the sum of
        // what went in says whether it is finite before anything changes.
        let mut check = T::zero();
        // The states with noise (a bit each, N ≤ 64), marked as Q is written.
        let bit = |j: usize| 1u64.checked_shl(u32::try_from(j).unwrap_or(u32::MAX));
        let mut dynamic = 0u64;
        let mut q = NoisePart::<T, N>::zeroed();
        q.factor(|w, above| {
            for (i, &qd) in q_diag.iter().enumerate() {
                if qd != T::zero() {
                    dynamic |= bit(i).unwrap_or(0);
                }
                let a = internal(i);
                let v = qd * at(inv, a) * at(inv, a);
                check += v;
                if let Some(e) = w.get_mut(a).and_then(|row| row.get_mut(a)) {
                    *e = v;
                }
            }
            for &(i, j, v) in q_pairs.iter() {
                if v != T::zero() {
                    dynamic |= bit(i).unwrap_or(0) | bit(j).unwrap_or(0);
                }
                let (a, b) = (internal(i), internal(j));
                let v = v * at(inv, a) * at(inv, b);
                check += v;
                if let Some(e) = w.get_mut(a.min(b)).and_then(|row| row.get_mut(a.max(b))) {
                    *e += v;
                }
                if a != b {
                    mark(above, a.min(b), a.max(b));
                }
            }
        });
        if !check.is_finite() {
            self.health.non_finite += 1;
            return;
        }
        let Some(mut lo) = self.phi_u_rows(phi) else {
            self.health.non_finite += 1;
            return;
        };
        // The static states at the end of the internal order (see [`orthogonalize`]):
        // the states with noise (marked above, as Q was written: a loop of their own
        // cost the board ≈ 0.3k instructions a time update) or a row of Φ, then the
        // internal order walked back to the first marked (a scan of Q's pairs and Φ's
        // rows per state cost the board 0.9k instructions a time update).
        for &j in phi.index.iter() {
            dynamic |= bit(j).unwrap_or(0);
        }
        let mut t0 = N;
        while let Some(a) = t0.checked_sub(1) {
            let j = self.state_at.get(a).map_or(N, |&i| usize::from(i));
            // A state past 64 (none: N ≤ 64) would count as dynamic.
            if bit(j).is_none_or(|m| dynamic & m != 0) {
                break;
            }
            t0 = a;
        }
        self.health.variance_clamped += orthogonalize(
            self.u.as_mut_slice(),
            &mut lo,
            &mut q,
            self.d.as_mut_slice(),
            self.floor,
            t0,
        );
        rows_of_u::<T, N>(self.u.as_mut_slice(), t0);
    }

    /// The time update's `x ← Φ x` and the first part of its Gram-Schmidt matrix,
    /// `W_1 = Φ_s U` (Φ_s(i, k) = Φ(i, k) s_k / s_i), written in U's place, row-major
    /// (see [`orthogonalize`]); returns where each row's non-zeros start. U is turned into
    /// its rows first (the rows of W where Φ is the identity's); the rows of Φ that are
    /// not, over their non-zero columns, are formed from them (contiguous) and then written
    /// over them. `None` (U turned back, nothing changed) if one of those rows or `Φ x` is
    /// not finite. Rows and columns in the internal order.
    #[inline(always)]
    fn phi_u_rows<const R: usize>(&mut self, phi: &Transition<T, N, R>) -> Option<[u8; N]> {
        let (sc, inv, pos) = (self.scale.as_slice(), self.inv_scale.as_slice(), self.pos);
        let at = |v: &[T], i: usize| v.get(i).copied().unwrap_or_else(T::zero);
        let internal = |i: usize| pos.get(i).map_or(N, |&a| usize::from(a));
        let mut active = [[T::zero(); N]; R];
        let mut active_lo = [N as u8; R];
        let mut x_new = [T::zero(); R];
        let mut check = T::zero();
        let u = self.u.as_mut_slice();
        let xs = self.xs.as_slice();
        // Φ's row r over its columns: (its state's 1 / s_i, the columns).
        let row_of = |r: usize| {
            let i = phi.index.get(r).map_or(N, |&i| internal(i));
            let n = phi.count.get(r).map_or(0, |&n| usize::from(n));
            let cols = phi.cols.get(r).and_then(|c| c.get(..n)).unwrap_or(&[]);
            (at(inv, i), cols, phi.values.get(r))
        };
        // `LANES` rows at a time where they share their columns (δv's and ψ's six rows),
        // held column by column in their rows' place of `active` (see [`axpy_lanes`]);
        // else two where two do, else one. Each U row is read once for the rows taken
        // together, each row's elements computed as alone. Bit r of `lanes_at`: rows r to
        // r + LANES were taken together.
        const { assert!(R <= 64, "the rows taken together are the bits of a u64") };
        let mut lanes_at = 0u64;
        let mut r = 0;
        while r < R {
            let (inv0, cols0, vals0) = row_of(r);
            let run =
                r + LANES <= R && (r + 1..r + LANES).all(|q| same_columns(cols0, row_of(q).1));
            let vals = phi.values.get(r..r + LANES);
            let vals = vals.and_then(|v| <&[[T; N]; LANES]>::try_from(v).ok());
            if let (true, Some(rows), Some([v0, v1, v2, v3, v4, v5])) =
                (run, active.get_mut(r..r + LANES), vals)
            {
                let flat = rows.as_flattened_mut();
                let inv6 = core::array::from_fn(|q| row_of(r + q).0);
                let (lo, xn) = lanes_group(
                    (flat, u, N),
                    (cols0, pos.as_slice()),
                    (sc, xs),
                    ([v0, v1, v2, v3, v4, v5], inv6),
                );
                for &x in &xn {
                    check += x;
                }
                check = sum_into(check, flat);
                for (q, &x) in xn.iter().enumerate() {
                    if let (Some(l), Some(e)) = (active_lo.get_mut(r + q), x_new.get_mut(r + q)) {
                        *l = lo;
                        *e = x;
                    }
                }
                lanes_at |= 1 << r;
                r += LANES;
                continue;
            }
            let (inv1, cols1, vals1) = row_of(r + 1);
            let pair = r + 1 < R && same_columns(cols0, cols1);
            let (first, rest) = active.split_at_mut((r + 1).min(R));
            let (Some(row0), Some(vals0)) = (first.last_mut(), vals0) else {
                break;
            };
            let (mut lo0, mut xn0) = (active_lo.get(r).copied().unwrap_or(N as u8), T::zero());
            let (mut lo1, mut xn1) = (lo0, T::zero());
            match (pair, rest.first_mut(), vals1) {
                (true, Some(row1), Some(vals1)) => {
                    for &k in cols0 {
                        let (k, a) = (usize::from(k), internal(usize::from(k)));
                        lo0 = lo0.min(a as u8);
                        lo1 = lo1.min(a as u8);
                        let (sa, xa) = (at(sc, a), at(xs, a));
                        let f0 = at(vals0, k) * sa * inv0;
                        let f1 = at(vals1, k) * sa * inv1;
                        xn0 += f0 * xa;
                        xn1 += f1 * xa;
                        let src = u.get(a * N + a..(a + 1) * N).unwrap_or(&[]);
                        let (d0, d1) = (row0.get_mut(a..), row1.get_mut(a..));
                        axpy2(d0.unwrap_or(&mut []), d1.unwrap_or(&mut []), f0, f1, src);
                    }
                    check += xn0;
                    check = sum_into(check, row0);
                    check += xn1;
                    check = sum_into(check, row1);
                }
                _ => {
                    for &k in cols0 {
                        let (k, a) = (usize::from(k), internal(usize::from(k)));
                        lo0 = lo0.min(a as u8);
                        let f = at(vals0, k) * at(sc, a) * inv0;
                        xn0 += f * at(xs, a);
                        let src = u.get(a * N + a..(a + 1) * N).unwrap_or(&[]);
                        axpy(row0.get_mut(a..).unwrap_or(&mut []), f, src);
                    }
                    check += xn0;
                    check = sum_into(check, row0);
                }
            }
            let rows = if pair {
                [(r, lo0, xn0), (r + 1, lo1, xn1)]
            } else {
                [(r, lo0, xn0); 2]
            };
            for (q, lo, xn) in rows {
                if let (Some(l), Some(x)) = (active_lo.get_mut(q), x_new.get_mut(q)) {
                    *l = lo;
                    *x = xn;
                }
            }
            r += if pair { 2 } else { 1 };
        }
        if !check.is_finite() {
            return None;
        }
        for (&xn, &i) in x_new.iter().zip(phi.index.iter()) {
            if let Some(x) = self.xs.get_mut(internal(i)) {
                *x = xn;
            }
        }
        let mut lo: [u8; N] = core::array::from_fn(|i| i as u8);
        for (&l, &i) in active_lo.iter().zip(phi.index.iter()) {
            if let Some(e) = lo.get_mut(internal(i)) {
                *e = l;
            }
        }
        let mut r = 0;
        while r < R {
            let row_at = |q: usize| {
                let i = phi.index.get(q).map_or(N, |&i| internal(i));
                i * N..(i + 1) * N
            };
            if lanes_at >> r & 1 != 0 {
                // The rows taken together, column by column, into their rows of U: in one
                // pass where those are consecutive (δv's and ψ's), else a row at a time.
                let rows = active.get(r..r + LANES).unwrap_or(&[]);
                let lanes = rows.as_flattened();
                let i0 = phi.index.get(r).map_or(N, |&i| internal(i));
                let next =
                    (1..LANES).all(|q| phi.index.get(r + q).map(|&i| internal(i)) == Some(i0 + q));
                if let (true, Some(dst)) = (next, u.get_mut(i0 * N..(i0 + LANES) * N)) {
                    unlace(dst, N, lanes);
                    r += LANES;
                    continue;
                }
                for q in 0..LANES {
                    if let Some(dst) = u.get_mut(row_at(r + q)) {
                        for (d, lane) in dst.iter_mut().zip(lanes.chunks_exact(LANES)) {
                            if let Some(&v) = lane.get(q) {
                                *d = v;
                            }
                        }
                    }
                }
                r += LANES;
            } else {
                if let (Some(dst), Some(row)) = (u.get_mut(row_at(r)), active.get(r)) {
                    copy_words(dst, row);
                }
                r += 1;
            }
        }
        Some(lo)
    }

    /// Sequential scalar update with measurement row `h` (physical units), measurement
    /// `z`, noise variance `r`, and gate `gate` in standard deviations, in the factors
    /// (Bierman): `f = Uᵀ h` over h's non-zeros, `g = D f`, the innovation variance
    /// `r + Σ f_j g_j` (a sum of terms that are not negative: no cancellation, where
    /// `h P hᵀ` of a precise measurement cancels to below `f32`'s resolution), then D and
    /// λ column by column and U three rows at a time (the column sweep's arithmetic, see
    /// [`bierman_rows`]). Each conditional variance below the floor is raised to it.
    pub fn update_scalar(&mut self, h: &SVector<T, N>, z: T, r: T, gate: T) -> ScalarUpdate<T> {
        self.update_scalar_on(h, (0, 0), z, r, gate)
    }

    /// [`Kalman::update_scalar`] with `h`'s candidate columns given, `(marked, from)`:
    /// bit `c` of `marked` set for each column `c` below 32 (the caller's index) where `h`
    /// may be non-zero, and every column from `from` on (a zero among them is skipped as
    /// before), so the update reads `h` there only instead of scanning all `N` (the engine
    /// knows its rows' blocks: 7–10 non-zeros of 21). The arithmetic, and its order, are
    /// [`Kalman::update_scalar`]'s: `h`'s non-zeros are taken in the caller's order
    /// either way (the marked columns are to be below `from`).
    pub fn update_scalar_on(
        &mut self,
        h: &SVector<T, N>,
        cols: (u32, usize),
        z: T,
        r: T,
        gate: T,
    ) -> ScalarUpdate<T> {
        let mut scratch = [[T::zero(); N]; 2];
        let [f, g] = &mut scratch;
        let k = Factors {
            xs: self.xs.as_mut_slice(),
            u: self.u.as_mut_slice(),
            d: self.d.as_mut_slice(),
            scale: self.scale.as_slice(),
            pos: &self.pos,
            floor: self.floor,
            health: &mut self.health,
        };
        update_n(k, (h.as_slice(), cols), (z, r, gate), [f, g])
    }
}

/// What [`update_n`] works on: the filter's fields (internal order), `n` = `pos.len()`.
struct Factors<'a, T> {
    xs: &'a mut [T],
    /// U, row-major `n × n`.
    u: &'a mut [T],
    d: &'a mut [T],
    scale: &'a [T],
    pos: &'a [u8],
    floor: T,
    health: &'a mut Health,
}

/// [`Kalman::update_scalar_on`] for any `n` (the board's two layouts share one copy): `h`
/// in the caller's order and its candidate columns (marked, and all from a column on),
/// `(z, r, gate)`, two
/// `n`-element temporaries (zero) lent by the caller.
#[inline(never)]
fn update_n<T: Real>(
    k: Factors<'_, T>,
    (h, (marked, past)): (&[T], (u32, usize)),
    (z, r, gate): (T, T, T),
    scratch: [&mut [T]; 2],
) -> ScalarUpdate<T> {
    let Factors {
        xs,
        u,
        d,
        scale,
        pos,
        floor,
        health,
    } = k;
    let [f, g] = scratch;
    let n = pos.len();
    let hx = project(f, (h, marked, past), (u, xs, scale, pos));
    // f's first and last non-zero: `g = D f` and `s` over them only (outside, f = +0, so
    // g's zeros as lent are `D f`'s, and `s + f g = s + 0 = s`).
    let lo = f.iter().position(|&v| v != T::zero()).unwrap_or(n);
    let hi = f.iter().rposition(|&v| v != T::zero()).map_or(0, |j| j + 1);
    // An all-zero f (lo = n, hi = 0) is an empty range: the update goes on as before.
    let hi = hi.max(lo);
    let mut s = r;
    let (Some(gs), Some(fs), Some(ds)) = (g.get_mut(lo..hi), f.get(lo..hi), d.get(lo..hi)) else {
        return ScalarUpdate {
            innovation: z - hx,
            variance: s,
            test_ratio: T::zero(),
            accepted: false,
        };
    };
    for ((gj, &fj), &dj) in gs.iter_mut().zip(fs).zip(ds) {
        *gj = dj * fj;
        s += fj * *gj;
    }
    let innovation = z - hx;
    let refused = ScalarUpdate {
        innovation,
        variance: s,
        test_ratio: T::zero(),
        accepted: false,
    };
    if !(z.is_finite() && r.is_finite() && s.is_finite() && innovation.is_finite()) {
        health.non_finite += 1;
        return refused;
    }
    if s <= T::zero() {
        health.bad_innovation_variance += 1;
        return refused;
    }
    let test_ratio = innovation * innovation / (gate * gate * s);
    if test_ratio > T::one() {
        health.gated += 1;
        health.gated_streak += 1;
        health.max_gated_streak = health.max_gated_streak.max(health.gated_streak);
        return ScalarUpdate {
            test_ratio,
            ..refused
        };
    }
    health.gated_streak = 0;
    // Bierman: α from r up, D_j and λ_j (in f_j's place) column by column; they do not
    // depend on U. A column with f_j = 0 is the identity's step (λ_j = 0, g_j = 0); the
    // columns before the first and after the last other one are left out.
    let mut alpha = r;
    let mut clamped = 0;
    let (Some(fs), Some(ds), Some(gs)) = (f.get_mut(lo..hi), d.get_mut(lo..hi), g.get(lo..hi))
    else {
        return refused;
    };
    let columns = fs.iter_mut().zip(ds.iter_mut()).zip(gs);
    if r > T::zero() {
        // α starts at r > 0 and does not fall (each term f_j g_j = D_j f_j² ≥ 0, the same
        // terms in the same order as s, which is finite): the two tests of the general
        // loop below hold at every column, and are left out (≈ 6 instructions a column
        // on the board). The same operations otherwise.
        for ((fj, dj), &gj) in columns {
            let v = *fj;
            if v != T::zero() {
                let prev = alpha;
                alpha += v * gj;
                let mut dn = *dj;
                dn *= prev / alpha;
                *fj = -v / prev;
                if dn < floor {
                    dn = floor;
                    clamped += 1;
                }
                *dj = dn;
            }
        }
    } else {
        for ((fj, dj), &gj) in columns {
            let v = *fj;
            if v != T::zero() {
                let prev = alpha;
                alpha += v * gj;
                let mut dn = *dj;
                if alpha > T::zero() {
                    dn *= prev / alpha;
                }
                *fj = if prev > T::zero() {
                    -v / prev
                } else {
                    T::zero()
                };
                if dn < floor {
                    dn = floor;
                    clamped += 1;
                }
                *dj = dn;
            }
        }
    }
    // Then U and the state ([`sweep`]).
    sweep(u, xs, (f, g), (lo, hi), innovation / s);
    health.variance_clamped += clamped;
    health.updates += 1;
    ScalarUpdate {
        innovation,
        variance: s,
        test_ratio,
        accepted: true,
    }
}

/// `f = Uᵀ h` into `f` (zero, `n` long) over h's candidate columns (see
/// [`Kalman::update_scalar_on`]); returns `h x`. Its own function: inlined into
/// [`update_n`] its loop's registers spilled into the rest's (a few hundred instructions
/// an update on the board).
#[inline(never)]
fn project<T: Real>(
    f: &mut [T],
    (h, mut marked, mut past): (&[T], u32, usize),
    (u, xs, scale, pos): (&[T], &[T], &[T], &[u8]),
) -> T {
    let n = pos.len();
    // Every slice cut to its length in `n` (one length for all: fewer registers and
    // checks per non-zero).
    let (Some(h), Some(f), Some(scale), Some(xs)) =
        (h.get(..n), f.get_mut(..n), scale.get(..n), xs.get(..n))
    else {
        return T::zero();
    };
    // f = Uᵀ h over h's non-zeros in the caller's order (a row of U each, from its
    // diagonal on: f_i += v · 1, then row i after its diagonal), and h x. Two rows at a
    // time, as the non-zeros come: each element of f read and written once for both, its
    // two terms added in that order (the rows from the first one's start: U's stored zeros
    // before a row's diagonal add zeros, which leave f as it is: f starts at +0 and a sum
    // is −0 only of two −0).
    let mut hx = T::zero();
    let mut first: Option<(usize, T)> = None;
    loop {
        let c = if marked != 0 {
            let c = marked.trailing_zeros();
            marked &= marked - 1;
            usize::try_from(c).unwrap_or(usize::MAX)
        } else if past < n {
            past += 1;
            past - 1
        } else {
            break;
        };
        let (Some(&hk), Some(&p)) = (h.get(c), pos.get(c)) else {
            continue;
        };
        if hk != T::zero() {
            let i = usize::from(p);
            let v = hk * scale.get(i).copied().unwrap_or_else(T::zero);
            hx += v * xs.get(i).copied().unwrap_or_else(T::zero);
            let Some((i0, v0)) = first.take() else {
                first = Some((i, v));
                continue;
            };
            // From the first diagonal: U(i, i) = 1 is stored, and v · 1 = v exactly.
            let m = i0.min(i);
            if let (Some(fs), Some(r0), Some(r1)) = (
                f.get_mut(m..),
                u.get(i0 * n + m..(i0 + 1) * n),
                u.get(i * n + m..(i + 1) * n),
            ) {
                for ((e, &a), &b) in fs.iter_mut().zip(r0).zip(r1) {
                    *e += v0 * a;
                    *e += v * b;
                }
            }
        }
    }
    // An odd last non-zero alone.
    if let Some((i, v)) = first {
        if let (Some(fs), Some(row)) = (f.get_mut(i..), u.get(i * n + i..(i + 1) * n)) {
            axpy(fs, v, row);
        }
    }
    hx
}

/// Bierman's U three rows at a time (contiguous; the last one or two as a pair or alone),
/// each row's `b_i = (P h)_i` ending in its state's step `x_i += step b_i` (K = P h / s,
/// x ← x + K ν); `λ` and `g` from [`update_n`]'s column pass, `lo..hi` the columns with
/// `f ≠ 0`. The rows i to i + 2 all from a column at or before max(lo, i), b from zero:
/// a row through its own column (U(i, i) = 1 stored, kept as 1 + λ_i 0) takes
/// b_i = 0 + g_i, its value at the column sweep's column i; through the columns before
/// it (zeros stored, b = 0) it stays as it was, and so do the columns before lo
/// (λ = g = 0, the identity's steps).
#[inline(never)]
fn sweep<T: Real>(
    u: &mut [T],
    xs: &mut [T],
    (lambda, g): (&[T], &[T]),
    (lo, hi): (usize, usize),
    step: T,
) {
    let n = xs.len();
    let hi = hi.min(n);
    // λ and g cut at `hi` once (a triple's columns are then `from..`: one check each).
    let (Some(lambda), Some(g), Some(g_all)) = (lambda.get(..hi), g.get(..hi), g.get(..n)) else {
        return;
    };
    let mut triples = u.chunks_exact_mut((3 * n).max(1));
    let mut x3 = xs.chunks_exact_mut(3);
    let mut first = 0;
    for (rows, x) in (&mut triples).zip(&mut x3) {
        // (Past hi, no slice: b stays zero, as over the empty columns.)
        let from = lo.max(first);
        first += 3;
        // The three rows' columns from..hi, at from, n + from and 2n + from.
        let (r0, rest) = rows.split_at_mut(n.min(rows.len()));
        let (r1, r2) = rest.split_at_mut(n.min(rest.len()));
        let b = match (
            r0.get_mut(from..hi),
            r1.get_mut(from..hi),
            r2.get_mut(from..hi),
            lambda.get(from..),
            g.get(from..),
        ) {
            (Some(r0), Some(r1), Some(r2), Some(ls), Some(gs)) => {
                bierman_rows3([r0, r1, r2], ls, gs)
            }
            _ => [T::zero(); 3],
        };
        if let ([x0, x1, x2], [b0, b1, b2]) = (x, b) {
            *x0 += step * b0;
            *x1 += step * b1;
            *x2 += step * b2;
        }
    }
    // The last one or two rows (n not a multiple of three): a pair as the triples, or one,
    // which has no column after its own.
    let start = n - n % 3;
    let (rows, x) = (triples.into_remainder(), x3.into_remainder());
    if let [x0, x1] = x {
        let from = lo.max(start).min(hi);
        let (top, bottom) = rows.split_at_mut(n.min(rows.len()));
        if let (Some(r0), Some(r1), Some(ls), Some(gs)) = (
            top.get_mut(from..hi),
            bottom.get_mut(from..hi),
            lambda.get(from..),
            g.get(from..),
        ) {
            let (b0, b1) = bierman_rows(r0, r1, ls, gs, (T::zero(), T::zero()));
            *x0 += step * b0;
            *x1 += step * b1;
        }
    } else if let (Some(x), Some(&gi)) = (x.first_mut(), g_all.get(start)) {
        *x += step * gi;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix2, Vector2};

    #[test]
    fn pushed_columns_equal_rows_set_at() {
        // Rows 0..6 of a 7 × 8 Φ from columns (zeros among them), against `set_row_at`.
        let at = [0usize, 2, 3, 5, 7];
        let v = |i: usize, j: usize| {
            if (i + j) % 3 == 0 {
                0.0
            } else {
                (i * 7 + j) as f64
            }
        };
        let rows = [0, 1, 2, 3, 4, 5, 7];
        let mut by_row = Transition::<f64, 8, 7>::zeroed(rows);
        for i in 0..6 {
            by_row.set_row_at(i, &at, |j| v(i, j));
        }
        let mut by_col = Transition::<f64, 8, 7>::zeroed(rows);
        by_col.set_row_at(1, &[1, 4], |_| 9.0);
        by_col.clear_rows(6);
        for &j in &at {
            by_col.push_column(j, &core::array::from_fn(|i| v(i, j)));
        }
        assert_eq!(by_col.values, by_row.values);
        assert_eq!(by_col.cols, by_row.cols);
        assert_eq!(by_col.count, by_row.count);
    }

    #[test]
    fn same_columns_is_slice_equality() {
        let a: [u8; 11] = [0, 1, 2, 3, 4, 5, 9, 12, 15, 18, 21];
        for n in 0..=a.len() {
            for m in 0..=a.len() {
                assert_eq!(same_columns(&a[..n], &a[..m]), n == m);
            }
            for k in 0..n {
                let mut b = a;
                b[k] ^= 0x40;
                assert!(!same_columns(&a[..n], &b[..n]));
            }
        }
    }

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
        let (x1, p1) = dense_propagation(&phi, &q, &x, &p);
        assert!((kf.state() - x1).norm() < 1e-12);
        assert!((kf.covariance() - p1).norm() < 1e-12);
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
    /// A 9-state filter from `p0_nine` after one scalar update (measurement row `h`,
    /// value 1, variance 0.5): its factors are no longer diagonal, and its state not zero.
    fn nine_after_one_update(h: [f64; 9]) -> Kalman<f64, 9> {
        let mut kf = Kalman::<f64, 9>::new(&p0_nine(), 1e-12);
        kf.update_scalar(
            &nalgebra::SVector::<f64, 9>::from_column_slice(&h),
            1.0,
            0.5,
            1e6,
        );
        kf
    }

    /// The reference a sparse predict is checked against: `Φ x` and `Φ P Φᵀ + Q` with
    /// Φ and Q formed densely.
    fn dense_propagation<const N: usize, const R: usize, const K: usize>(
        phi: &Transition<f64, N, R>,
        q: &Noise<f64, N, K>,
        x: &SVector<f64, N>,
        p: &SMatrix<f64, N, N>,
    ) -> (SVector<f64, N>, SMatrix<f64, N, N>) {
        let dense = SMatrix::<f64, N, N>::from_fn(|i, j| phi.get(i, j));
        let mut qd = SMatrix::<f64, N, N>::from_diagonal(&SVector::from(q.diag));
        for (i, j, v) in q.pairs {
            qd[(i, j)] = v;
            qd[(j, i)] = v;
        }
        (dense * x, dense * p * dense.transpose() + qd)
    }

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
        let mut kf = nine_after_one_update([1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
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
        let (x1, p1) = dense_propagation(&phi, &q, &x, &p);
        assert!((kf.state() - x1).norm() < 1e-12 * x1.norm());
        assert!((kf.covariance() - p1).norm() < 1e-12 * p1.norm());
        let ps = kf.scaled_covariance();
        assert_eq!(ps, ps.transpose());
    }

    #[test]
    fn freeze_zeroes_the_rows_and_columns_and_keeps_the_rest() {
        let p0 = p0_nine();
        let mut kf = Kalman::<f64, 9>::new(&p0, 1e-6);
        kf.update_scalar(
            &nalgebra::SVector::<f64, 9>::from_column_slice(&[
                1.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0,
            ]),
            1.0,
            0.5,
            1e6,
        );
        let (x, p) = (kf.state(), kf.scaled_covariance());
        kf.freeze(2..5);
        let ps = kf.scaled_covariance();
        for i in 0..9 {
            for j in 0..9 {
                let frozen = (2..5).contains(&i) || (2..5).contains(&j);
                let want = match (frozen, i == j) {
                    (true, true) => 1e-6,
                    (true, false) => 0.0,
                    (false, _) => p[(i, j)],
                };
                assert!(
                    (ps[(i, j)] - want).abs() < 1e-12,
                    "({i}, {j}): {}",
                    ps[(i, j)]
                );
            }
        }
        assert_eq!(kf.state(), x);
    }

    #[test]
    fn predict_with_static_states_at_the_end_equals_dense_propagation() {
        // States 5–8 are static (identity rows, no noise) and read by the active rows 0
        // and 2: their columns of U are moved into place, not orthogonalized.
        let mut kf = nine_after_one_update([1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.3, 1.0, 0.0]);
        let (x, p) = (kf.state(), kf.covariance());
        let mut phi = Transition::<f64, 9, 2>::new([0, 2]);
        phi.set_row(0, &[1.0, 0.1, 0.0, 0.0, 0.0, 0.2, 0.0, 0.05, 0.0]);
        phi.set_row(1, &[0.0, 0.2, 0.9, 0.0, 0.0, 0.0, 0.4, 0.0, 0.1]);
        let q = Noise::<f64, 9, 1> {
            diag: [0.01, 0.02, 0.03, 0.04, 0.05, 0.0, 0.0, 0.0, 0.0],
            pairs: [(1, 3, 0.002)],
        };
        kf.predict(&phi, &q);
        let (x1, p1) = dense_propagation(&phi, &q, &x, &p);
        assert!((kf.state() - x1).norm() < 1e-12 * x1.norm());
        assert!((kf.covariance() - p1).norm() < 1e-12 * p1.norm());
    }

    /// Factors of a 9-state `P₀` with ties (`U(i, j)`, `i < j`) and the states 2, 3 and 6
    /// static; `tie` one more entry of U.
    fn restart_nine(
        kf: &mut Kalman<f64, 9>,
        is_static: impl Fn(usize) -> bool,
        tie: (usize, usize),
    ) {
        kf.restart_factored(1e-12, is_static, |u, d| {
            for (i, j, v) in [
                (0, 2, 0.4),
                (0, 5, -0.3),
                (1, 3, 0.7),
                (4, 5, 0.2),
                (7, 8, 0.5),
            ] {
                u[(i, j)] = v;
            }
            u[tie] += 0.25;
            for (k, e) in d.iter_mut().enumerate() {
                *e = 0.5 + 0.3 * k as f64;
            }
        });
    }

    #[test]
    fn static_states_held_last_give_the_same_filter() {
        let is_static = |i: usize| matches!(i, 2 | 3 | 6);
        let mut last = Kalman::<f64, 9>::unstarted(1e-12);
        let mut plain = Kalman::<f64, 9>::unstarted(1e-12);
        restart_nine(&mut last, is_static, (1, 4));
        restart_nine(&mut plain, |_| false, (1, 4));
        assert_eq!(last.pos, [0, 1, 6, 7, 2, 3, 8, 4, 5]);
        let mut phi = Transition::<f64, 9, 2>::new([0, 5]);
        phi.set_row(0, &[1.0, 0.1, 0.3, 0.0, 0.0, 0.2, 0.05, 0.0, 0.0]);
        phi.set_row(1, &[0.0, 0.0, 0.0, 0.4, 0.1, 0.9, 0.0, 0.0, 0.2]);
        let q = Noise::<f64, 9, 1> {
            diag: [0.01, 0.02, 0.0, 0.0, 0.03, 0.04, 0.0, 0.05, 0.06],
            pairs: [(8, 4, 0.003)],
        };
        let h1 =
            SVector::<f64, 9>::from_column_slice(&[1.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.3, 1.0, 0.0]);
        let h2 =
            SVector::<f64, 9>::from_column_slice(&[0.0, 1.0, 0.0, -0.4, 0.0, 1.0, 0.0, 0.0, 0.2]);
        let same = |a: &Kalman<f64, 9>, b: &Kalman<f64, 9>| {
            let (pa, pb) = (a.covariance(), b.covariance());
            assert!((pa - pb).norm() < 1e-12 * pb.norm(), "{pa} {pb}");
            assert!((a.state() - b.state()).norm() < 1e-12 * b.state().norm());
            for i in 0..9 {
                assert!((a.sigma(i) - b.sigma(i)).abs() < 1e-12 * b.sigma(i));
            }
        };
        for kf in [&mut last, &mut plain] {
            kf.update_scalar(&h1, 1.0, 0.5, 1e6);
            kf.decay(4, 0.9);
            kf.predict(&phi, &q);
            kf.update_scalar(&h2, -0.5, 0.3, 1e6);
        }
        same(&last, &plain);
        for kf in [&mut last, &mut plain] {
            kf.reset_states(1..3);
            kf.freeze(2..4);
            kf.predict(&phi, &q);
        }
        same(&last, &plain);
    }

    #[test]
    fn rank_one_addition_equals_the_dense_sum() {
        // Static states held last (internal order differs from the caller's), a scaled
        // filter after an update, and c touching a static and a dynamic state.
        let mut kf = Kalman::<f64, 9>::unstarted(1e-12);
        restart_nine(&mut kf, |i| matches!(i, 2 | 3 | 6), (1, 4));
        let h =
            SVector::<f64, 9>::from_column_slice(&[1.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.3, 1.0, 0.0]);
        kf.update_scalar(&h, 1.0, 0.5, 1e6);
        let (x, p) = (kf.state(), kf.covariance());
        let c = [(3, 0.8), (6, -0.6), (1, 0.25)];
        let cv =
            SVector::<f64, 9>::from_fn(|i, _| c.iter().filter(|e| e.0 == i).map(|e| e.1).sum());
        let along = kf.variance_along(&c).unwrap();
        assert!((along - (cv.transpose() * p * cv)[0]).abs() < 1e-12 * p.norm());
        kf.add_rank_one(&c, 0.37);
        let want = p + cv * cv.transpose() * 0.37;
        assert!(
            (kf.covariance() - want).norm() < 1e-12 * want.norm(),
            "{}",
            kf.covariance()
        );
        assert_eq!(kf.state(), x);
        assert_eq!(kf.health.non_finite, 0);
        kf.add_rank_one(&c, -1.0);
        kf.add_rank_one(&[(9, 1.0)], 1.0);
        assert_eq!(kf.health.non_finite, 2);
        assert!((kf.covariance() - want).norm() < 1e-12 * want.norm());
    }

    #[test]
    fn variance_along_a_sharp_combination_keeps_its_precision_in_f32() {
        // Two states known to 1e-2 apart and their difference to 1e-6 (a ratio of 1e-8,
        // below f32's ε of P's elements): the factors give the difference's variance.
        let p0 = Matrix2::new(1e-4, 0.0, 0.0, 1e-4);
        let mut kf = Kalman::<f32, 2>::new(&p0, 1e-30);
        kf.update_scalar(&Vector2::new(1.0, -1.0), 0.0, 1e-12, 1e6);
        let v = kf.variance_along(&[(0, 1.0), (1, -1.0)]).unwrap();
        assert!((v / 1e-12 - 1.0).abs() < 1e-3, "{v}");
        // |c|⁴ = 4: the difference's variance grows by 4 α.
        kf.add_rank_one(&[(0, 1.0), (1, -1.0)], 3e-12);
        let v = kf.variance_along(&[(0, 1.0), (1, -1.0)]).unwrap();
        assert!((v / 13e-12 - 1.0).abs() < 1e-3, "{v}");
    }

    #[test]
    fn a_static_state_tied_to_a_later_one_keeps_the_callers_order() {
        // U(2, 5): state 2 follows state 5, so 2 cannot move behind it.
        let mut kf = Kalman::<f64, 9>::unstarted(1e-12);
        restart_nine(&mut kf, |i| matches!(i, 2 | 3 | 6), (2, 5));
        assert_eq!(kf.pos, core::array::from_fn(|i| i as u8));
    }
}
