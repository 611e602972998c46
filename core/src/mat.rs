//! Panic-free element access for fixed-size matrices. Indices in the engine are
//! compile-time layout constants, so out-of-range never happens; these helpers make
//! that a property of the code rather than of the caller (no panic path, by lint).
//!
//! And the 3 × 3 products, transposes and element-wise sums the engine forms at every
//! master update, written out with nalgebra's arithmetic in nalgebra's order (the same
//! bits, tested): on the board, built for size, nalgebra's generic loops cost several
//! times the arithmetic (issue12-s15: 2.9k instructions a master update).

use crate::real::Real;
use nalgebra::{Matrix3, SMatrix, UnitQuaternion, Vector3, Vector4};

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

/// Element `i` of a vector, or zero outside it (from its slice).
#[inline]
pub fn vget<T: Real, const R: usize>(v: &nalgebra::SVector<T, R>, i: usize) -> T {
    v.as_slice().get(i).copied().unwrap_or_else(T::zero)
}

/// Column `j` of `b` times `a`: element `i` is `(a_i0 b_0 + a_i1 b_1) + a_i2 b_2`, the
/// order in which nalgebra's products form it (a column of `a` at a time: `1 · a_:0 ·
/// b_0`, then `1 · a_:k · b_k + 1 · y` for k = 1, 2; the ones are exact).
#[inline(always)]
fn times_column<T: Real>(a: &[[T; 3]; 3], b: &[T; 3]) -> [T; 3] {
    let ([[x0, x1, x2], [y0, y1, y2], [z0, z1, z2]], [b0, b1, b2]) = (a, b);
    [
        *x0 * *b0 + *y0 * *b1 + *z0 * *b2,
        *x1 * *b0 + *y1 * *b1 + *z1 * *b2,
        *x2 * *b0 + *y2 * *b1 + *z2 * *b2,
    ]
}

/// `a b` for 3 × 3 matrices, each element as nalgebra's `a * b` forms it (see
/// [`times_column`]), written out: nalgebra's generic loops cost the board (built for
/// size) several times the 27 multiply-adds.
pub fn mul3<T: Real>(a: &Matrix3<T>, b: &Matrix3<T>) -> Matrix3<T> {
    let (a, [b0, b1, b2]) = (&a.data.0, &b.data.0);
    Matrix3::from_data(nalgebra::ArrayStorage([
        times_column(a, b0),
        times_column(a, b1),
        times_column(a, b2),
    ]))
}

/// `a v`, each element as nalgebra's `a * v` forms it (see [`times_column`]), written
/// out (nalgebra's loop cost the board ≈ 150 instructions a product).
pub fn mul3v<T: Real>(a: &Matrix3<T>, v: &Vector3<T>) -> Vector3<T> {
    Vector3::from_data(nalgebra::ArrayStorage([times_column(
        &a.data.0,
        &v.data.0[0],
    )]))
}

/// `aᵀ`, its elements moved (nalgebra's `transpose` is a loop on the board).
#[inline(always)]
pub fn transpose3<T: Real>(a: &Matrix3<T>) -> Matrix3<T> {
    let [[a00, a10, a20], [a01, a11, a21], [a02, a12, a22]] = a.data.0;
    Matrix3::from_data(nalgebra::ArrayStorage([
        [a00, a01, a02],
        [a10, a11, a12],
        [a20, a21, a22],
    ]))
}

/// `−a`, element by element (nalgebra's negation is a loop on the board).
#[inline(always)]
pub fn neg3<T: Real>(a: &Matrix3<T>) -> Matrix3<T> {
    zip3(a, a, |_, _, x, _| -x)
}

/// The vector `(f(0), f(1), f(2))`: nalgebra's element-wise vector sums and scalings
/// written out, each element's arithmetic as nalgebra's operations form it (each
/// operation a loop of three on the board, through memory). `f` reads its operands with
/// [`vget`], whose checks fold away at the constant indices.
#[inline(always)]
pub fn vec3<T: Real>(f: impl Fn(usize) -> T) -> Vector3<T> {
    Vector3::new(f(0), f(1), f(2))
}

/// [`vec3`] for four elements (a quaternion's coordinates).
#[inline(always)]
pub fn vec4<T: Real>(f: impl Fn(usize) -> T) -> Vector4<T> {
    Vector4::new(f(0), f(1), f(2), f(3))
}

/// `q v` for a unit quaternion, as nalgebra's `q * v` forms it (`t = 2 (q_v × v)`,
/// then `t w + q_v × t + v`), its element-wise operations written out.
#[inline(always)]
pub fn rotate3<T: Real>(q: &UnitQuaternion<T>, v: &Vector3<T>) -> Vector3<T> {
    let (qv, w, two) = (q.imag(), q.w, T::of(2.0));
    let c = qv.cross(v);
    let t = vec3(|i| vget(&c, i) * two);
    let cross = qv.cross(&t);
    vec3(|i| (vget(&t, i) * w + vget(&cross, i)) + vget(v, i))
}

/// `a ∘ b` element by element, `f(i, j, a_ij, b_ij)`: nalgebra's element-wise sums and
/// scalings of 3 × 3 matrices, each element's arithmetic written out once (each
/// operation a loop of its own on the board). Plain loops: `array::from_fn` left its
/// closure out of line there.
#[inline(always)]
pub fn zip3<T: Real>(
    a: &Matrix3<T>,
    b: &Matrix3<T>,
    f: impl Fn(usize, usize, T, T) -> T,
) -> Matrix3<T> {
    let mut out = *a;
    for (j, (oc, bc)) in out.data.0.iter_mut().zip(&b.data.0).enumerate() {
        for (i, (o, &bij)) in oc.iter_mut().zip(bc).enumerate() {
            *o = f(i, j, *o, bij);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rotation::{inverse_right_jacobian_small, right_jacobian, skew};

    /// Matrices and vectors of both signs and many magnitudes (zeros among them).
    fn samples<T: Real>() -> impl Iterator<Item = (Matrix3<T>, Matrix3<T>, Vector3<T>)> {
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let m = (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            match x % 7 {
                0 => 0.0,
                1 => m * 1e-6,
                2 => m * 1e3,
                _ => m,
            }
        };
        (0..2000).map(move |_| {
            let a = Matrix3::from_fn(|_, _| T::of(next()));
            let b = Matrix3::from_fn(|_, _| T::of(next()));
            let v = Vector3::from_fn(|_, _| T::of(next()));
            (a, b, v)
        })
    }

    fn same_bits<T: Real>(x: &[T], y: &[T]) -> bool {
        x.iter()
            .zip(y)
            .all(|(a, b)| a.to_f64().to_bits() == b.to_f64().to_bits())
    }

    /// The written-out products are nalgebra's bit for bit, in both types.
    fn products_are_nalgebras<T: Real>() {
        for (a, b, v) in samples::<T>() {
            assert!(same_bits(mul3(&a, &b).as_slice(), (a * b).as_slice()));
            assert!(same_bits(mul3v(&a, &v).as_slice(), (a * v).as_slice()));
            assert!(same_bits(
                transpose3(&a).as_slice(),
                a.transpose().as_slice()
            ));
            assert!(same_bits(neg3(&a).as_slice(), (-a).as_slice()));
            let sum = zip3(&a, &b, |_, _, x, y| -x + y);
            assert!(same_bits(sum.as_slice(), (-a + b).as_slice()));
            let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                T::one(),
                a.m11,
                a.m21,
                a.m31,
            ));
            assert!(same_bits(rotate3(&q, &v).as_slice(), (q * v).as_slice()));
            let phi = v * T::of(1e-2);
            let k = skew(&phi);
            // The closed forms' coefficients, as `right_jacobian` takes them.
            let (c1, c2) = (T::of(0.49), T::of(0.16));
            let jr = zip3(&k, &mul3(&k, &k), |i, j, kij, kkij| {
                let id = if i == j { T::one() } else { T::zero() };
                (id - kij * c1) + kkij * c2
            });
            let dense = Matrix3::identity() - k * c1 + k * k * c2;
            assert!(same_bits(jr.as_slice(), dense.as_slice()));
            let inv = Matrix3::identity() + k * T::of(0.5) + k * k * T::of(1.0 / 12.0);
            assert!(same_bits(
                inverse_right_jacobian_small(&phi).as_slice(),
                inv.as_slice()
            ));
            assert!(right_jacobian(&phi).iter().all(|e| e.is_finite()));
        }
    }

    #[test]
    fn products_are_nalgebras_bit_for_bit() {
        products_are_nalgebras::<f64>();
        products_are_nalgebras::<f32>();
    }
}
