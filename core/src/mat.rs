//! Panic-free element access for fixed-size matrices. Indices in the engine are
//! compile-time layout constants, so out-of-range never happens; these helpers make
//! that a property of the code rather than of the caller (no panic path, by lint).

use crate::real::Real;
use nalgebra::SMatrix;

/// A zero matrix written as its array: nalgebra's `zeros()` builds it from an iterator,
/// which the board's size-optimized image does through a temporary and a copy (the
/// time update's three `6 × S` matrices and the matching's measurement rows: 2.5k
/// instructions per master update, `bench-board`, `docs/performance.md`).
#[inline(always)]
pub fn zeros<T: Real, const R: usize, const C: usize>() -> SMatrix<T, R, C> {
    SMatrix::from_data(nalgebra::ArrayStorage([[T::zero(); R]; C]))
}

/// Element `(i, j)`, or zero outside the matrix.
#[inline]
pub fn get<T: Real, const R: usize, const C: usize>(m: &SMatrix<T, R, C>, i: usize, j: usize) -> T {
    m.get((i, j)).copied().unwrap_or_else(T::zero)
}

/// Sets element `(i, j)`; does nothing outside the matrix.
#[inline]
pub fn set<T: Real, const R: usize, const C: usize>(
    m: &mut SMatrix<T, R, C>,
    i: usize,
    j: usize,
    v: T,
) {
    if let Some(e) = m.get_mut((i, j)) {
        *e = v;
    }
}

/// Sets the symmetric 2×2 block on rows/columns `(i, j)` from a 2×2 matrix.
#[inline]
pub fn set_pair<T: Real, const R: usize>(
    m: &mut SMatrix<T, R, R>,
    i: usize,
    j: usize,
    b: &nalgebra::Matrix2<T>,
) {
    set(m, i, i, get(b, 0, 0));
    set(m, i, j, get(b, 0, 1));
    set(m, j, i, get(b, 1, 0));
    set(m, j, j, get(b, 1, 1));
}

/// Element `i` of a vector, or zero outside it.
#[inline]
pub fn vget<T: Real, const R: usize>(v: &nalgebra::SVector<T, R>, i: usize) -> T {
    v.get(i).copied().unwrap_or_else(T::zero)
}
