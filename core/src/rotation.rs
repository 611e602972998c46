//! Rotations: quaternion, direction cosine matrix and rotation vector, with the
//! SO(3) exponential/logarithm and right Jacobian the error model needs.
//!
//! Quaternions are nalgebra's `UnitQuaternion`, which is Hamilton with the scalar
//! part `w` first in `Quaternion::new(w, i, j, k)`, and `q * v` computes `q ⊗ v ⊗ q*`:
//! exactly the recording format's `q_b^n` convention.

use crate::mat::{mul3, vec4, vget, zip3};
use crate::real::Real;
use nalgebra::{Matrix3, Quaternion, Rotation3, UnitQuaternion, Vector3};

/// Skew-symmetric cross-product matrix: `skew(a) * b == a × b`.
#[inline]
pub fn skew<T: Real>(a: &Vector3<T>) -> Matrix3<T> {
    let z = T::zero();
    Matrix3::new(z, -a.z, a.y, a.z, z, -a.x, -a.y, a.x, z)
}

/// Rotation matrix of rotation vector `a` (rad): `Exp(a)` of recording-v1.
#[inline]
pub fn exp_so3<T: Real>(a: &Vector3<T>) -> Matrix3<T> {
    quat_exp(a).to_rotation_matrix().into_inner()
}

/// Unit quaternion of rotation vector `a` (rad).
#[inline]
pub fn quat_exp<T: Real>(a: &Vector3<T>) -> UnitQuaternion<T> {
    let angle = a.norm_squared().sqrt_fast();
    let (w, k) = if angle < T::of(T::QUAT_EXP_SERIES_BELOW) {
        half_angle_series(angle)
    } else {
        let half = angle * T::of(0.5);
        let (s, c) = half.sin_cos_fast();
        // sin(x/2)/x, with its Taylor series near zero so tiny vectors stay exact.
        let k = if angle < T::of(1e-4) {
            T::of(0.5) - angle * angle / T::of(48.0)
        } else {
            s / angle
        };
        (c, k)
    };
    UnitQuaternion::new_unchecked(Quaternion::new(w, a.x * k, a.y * k, a.z * k))
}

/// `(cos(a/2), sin(a/2)/a)` of an angle `a` (rad) by their Taylor series to `a⁴`, for
/// `a` below [`Real::QUAT_EXP_SERIES_BELOW`] (`f32` only: 0.05 rad). The first terms left
/// out, `a⁶/46 080` and `a⁶/645 120`, bound the truncation: below 3.4·10⁻¹³ and 2.4·10⁻¹⁴
/// at 0.05 rad, far under `f32`'s half ulp (tested against the closed form in `f64`).
#[inline]
pub fn half_angle_series<T: Real>(a: T) -> (T, T) {
    let x = a * a;
    let w = T::one() - x * (T::one() / T::of(8.0) - x * (T::one() / T::of(384.0)));
    let k = T::of(0.5) - x * (T::one() / T::of(48.0) - x * (T::one() / T::of(3_840.0)));
    (w, k)
}

/// Rotation vector (rad) of a unit quaternion, angle in [0, π]: `Log(q)`.
#[inline]
pub fn quat_log<T: Real>(q: &UnitQuaternion<T>) -> Vector3<T> {
    // Use the hemisphere with w >= 0 so the angle is at most π.
    let (w, v) = if q.w < T::zero() {
        (-q.w, -q.imag())
    } else {
        (q.w, q.imag())
    };
    let s = v.norm_squared().sqrt_fast();
    // angle = 2 atan2(s, w); factor = angle / s, with its series near zero.
    let factor = if s < T::of(1e-4) {
        T::of(2.0) / w * (T::one() - s * s / (T::of(3.0) * w * w))
    } else {
        T::of(2.0) * s.atan2(w) / s
    };
    v * factor
}

/// Rotation vector (rad) of a rotation matrix: `Log(C)`.
#[inline]
pub fn log_so3<T: Real>(c: &Matrix3<T>) -> Vector3<T> {
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*c));
    quat_log(&q)
}

/// Right Jacobian of SO(3): `Exp(φ + δ) ≈ Exp(φ) Exp(J_r(φ) δ)` for small `δ`.
pub fn right_jacobian<T: Real>(phi: &Vector3<T>) -> Matrix3<T> {
    let a = phi.norm_squared().sqrt_fast();
    let k = skew(phi);
    let (c1, c2) = if a < T::of(1e-3) {
        (
            T::of(0.5) - a * a / T::of(24.0),
            T::one() / T::of(6.0) - a * a / T::of(120.0),
        )
    } else if a < T::of(T::RIGHT_JACOBIAN_SERIES_BELOW) {
        right_jacobian_series(a)
    } else {
        let a2 = a * a;
        let (s, c) = a.sin_cos_fast();
        ((T::one() - c) / a2, (a - s) / (a2 * a))
    };
    // `Matrix3::identity() - k * c1 + k * k * c2`, each element's arithmetic as
    // nalgebra's operations form it, written out (its five loops cost the board ≈ 500
    // instructions a call).
    zip3(&k, &mul3(&k, &k), |i, j, kij, kkij| {
        (identity::<T>(i, j) - kij * c1) + kkij * c2
    })
}

/// Element `(i, j)` of the identity.
#[inline(always)]
fn identity<T: Real>(i: usize, j: usize) -> T {
    if i == j {
        T::one()
    } else {
        T::zero()
    }
}

/// Inverse right Jacobian of SO(3) for a small rotation vector `a` (rad):
/// `Log(Exp(a) Exp(δ)) ≈ a + J_r⁻¹(a) δ`, by its series `I + ½[a×] + (1/12)[a×]²`. The
/// first term left out, `|a|⁴/720` relative, is below `f32`'s resolution for `|a|` under
/// 0.05 rad; it serves the attitude residual's predicted value (a flexure angle, a few
/// milliradians).
#[inline]
pub fn inverse_right_jacobian_small<T: Real>(a: &Vector3<T>) -> Matrix3<T> {
    let k = skew(a);
    // `Matrix3::identity() + k * ½ + k * k * (1/12)`, written out as in
    // [`right_jacobian`].
    let (half, twelfth) = (T::of(0.5), T::of(1.0 / 12.0));
    zip3(&k, &mul3(&k, &k), |i, j, kij, kkij| {
        (identity::<T>(i, j) + kij * half) + kkij * twelfth
    })
}

/// `((1 − cos a)/a², (a − sin a)/a³)` of an angle `a` (rad) by their Taylor series to
/// `a⁶`, for `a` below [`Real::RIGHT_JACOBIAN_SERIES_BELOW`] (`f32` only: 0.5 rad, where
/// the closed forms lose up to half their digits to cancellation in `f32`). The first
/// terms left out, `a⁸/3 628 800` and `a⁸/39 916 800`, bound the truncation: below
/// 1.1·10⁻⁹ and 9.8·10⁻¹¹ at 0.5 rad, under `f32`'s half ulp of ½ and ⅙ (tested against
/// the closed form in `f64`).
#[inline]
pub fn right_jacobian_series<T: Real>(a: T) -> (T, T) {
    let x = a * a;
    let inv = |d: f64| T::of(1.0 / d);
    let c1 = inv(2.0) - x * (inv(24.0) - x * (inv(720.0) - x * inv(40_320.0)));
    let c2 = inv(6.0) - x * (inv(120.0) - x * (inv(5_040.0) - x * inv(362_880.0)));
    (c1, c2)
}

/// Normalized linear interpolation between two attitudes, `s` in [0, 1]: accurate to
/// second order in the angle between them, which is what a few-millisecond gap needs.
pub fn nlerp<T: Real>(q0: &UnitQuaternion<T>, q1: &UnitQuaternion<T>, s: T) -> UnitQuaternion<T> {
    let b = if q0.coords.dot(&q1.coords) < T::zero() {
        vec4(|i| -vget(&q1.coords, i))
    } else {
        q1.coords
    };
    // `q0 (1 − s) + b s`, element by element as nalgebra's operations form it.
    let w0 = T::one() - s;
    normalize(&Quaternion::from(vec4(|i| {
        vget(&q0.coords, i) * w0 + vget(&b, i) * s
    })))
}

/// The unit quaternion of `q`'s direction: nalgebra's `UnitQuaternion::new_normalize`
/// (the same division by the norm, the same bits in `f64`), with [`Real::sqrt_fast`]
/// (the FPU's square root on the board, not `libm`'s software one).
#[inline]
pub fn normalize<T: Real>(q: &Quaternion<T>) -> UnitQuaternion<T> {
    let n = q.coords.norm_squared().sqrt_fast();
    UnitQuaternion::new_unchecked(Quaternion::from(vec4(|i| vget(&q.coords, i) / n)))
}

/// Direction cosine matrix of a unit quaternion (`C_b^n` from `q_b^n`).
#[inline]
pub fn dcm<T: Real>(q: &UnitQuaternion<T>) -> Matrix3<T> {
    q.to_rotation_matrix().into_inner()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f64, y: f64, z: f64) -> Vector3<f64> {
        Vector3::new(x, y, z)
    }

    #[test]
    fn exp_log_round_trip_over_angles() {
        for a in [
            v(0.0, 0.0, 0.0),
            v(1e-9, -2e-9, 0.0),
            v(0.3, -0.2, 0.1),
            v(3.0, 0.1, -0.2),
            v(1e-5, 0.0, 0.0),
        ] {
            let back = log_so3(&exp_so3(&a));
            assert!(
                (back - a).norm() < 1e-12 * (1.0 + a.norm()),
                "{a:?} -> {back:?}"
            );
            assert!((quat_log(&quat_exp(&a)) - a).norm() < 1e-12);
        }
    }

    #[test]
    fn exp_rotates_like_hamilton_q_b_n() {
        // A 90° rotation about z (up) turns the right axis x into the forward axis y.
        let q = quat_exp(&v(0.0, 0.0, core::f64::consts::FRAC_PI_2));
        let y = q * v(1.0, 0.0, 0.0);
        assert!((y - v(0.0, 1.0, 0.0)).norm() < 1e-15);
        assert!(
            (exp_so3(&v(0.0, 0.0, core::f64::consts::FRAC_PI_2)) * v(1.0, 0.0, 0.0) - y).norm()
                < 1e-15
        );
    }

    #[test]
    fn series_are_within_their_stated_bounds_of_the_closed_forms() {
        let n = 2_000;
        for i in 1..=n {
            // The f32 ranges of the series: up to 0.05 rad and up to 0.5 rad.
            let a = 0.05 * i as f64 / n as f64;
            let (w, k) = half_angle_series(a);
            assert!((w - (a / 2.0).cos()).abs() < 1e-12, "{a}");
            assert!((k - (a / 2.0).sin() / a).abs() < 1e-12, "{a}");
            let a = 1e-3 + (0.5 - 1e-3) * i as f64 / n as f64;
            let (c1, c2) = right_jacobian_series(a);
            // The closed forms' own cancellation error in f64 is below 1e-10 here.
            assert!((c1 - (1.0 - a.cos()) / (a * a)).abs() < 2e-9, "{a}");
            assert!((c2 - (a - a.sin()) / (a * a * a)).abs() < 2e-9, "{a}");
        }
    }

    #[test]
    fn f32_rotations_follow_f64_to_f32_precision() {
        for a in [
            v(1e-7, -2e-7, 3e-8),
            v(2e-5, 1e-5, -3e-5),
            v(3e-3, -1e-3, 2e-3),
            v(0.02, 0.03, -0.01),
            v(0.2, -0.1, 0.15),
            v(0.6, 0.3, -0.4),
            v(2.0, -1.0, 0.5),
        ] {
            let a32: Vector3<f32> = a.cast();
            let a64: Vector3<f64> = a32.cast();
            let (q32, q64) = (quat_exp(&a32), quat_exp(&a64));
            let dq = (q32.coords.cast::<f64>() - q64.coords).amax();
            assert!(dq < 2e-7, "{a:?}: quat_exp differs by {dq}");
            let dj = (right_jacobian(&a32).cast::<f64>() - right_jacobian(&a64)).amax();
            assert!(dj < 3e-7, "{a:?}: right_jacobian differs by {dj}");
        }
    }

    #[test]
    fn normalize_is_nalgebras_in_f64() {
        let q = Quaternion::new(0.9, -0.3, 0.2, 0.11);
        assert_eq!(normalize(&q), UnitQuaternion::new_normalize(q));
    }

    #[test]
    fn skew_is_cross_product() {
        let a = v(0.3, -1.2, 2.0);
        let b = v(-0.7, 0.4, 1.1);
        assert!((skew(&a) * b - a.cross(&b)).norm() < 1e-15);
    }

    #[test]
    fn right_jacobian_matches_finite_differences() {
        let phi = v(0.4, -0.3, 0.25);
        let jr = right_jacobian(&phi);
        let h = 1e-6;
        for i in 0..3 {
            let mut d = Vector3::zeros();
            d[i] = h;
            // Exp(φ)^T Exp(φ + d) = Exp(J_r d)
            let lhs = log_so3(&(exp_so3(&phi).transpose() * exp_so3(&(phi + d))));
            assert!((lhs - jr * d).norm() < 1e-11, "column {i}");
        }
        let small = right_jacobian(&v(1e-5, 2e-5, -1e-5));
        assert!((small - Matrix3::identity()).norm() < 3e-5);
    }

    #[test]
    fn nlerp_midpoint_of_small_rotation() {
        let q0 = quat_exp(&v(0.1, 0.0, 0.0));
        let q1 = quat_exp(&v(0.1, 0.02, 0.0));
        let mid = nlerp(&q0, &q1, 0.5);
        let exact = q0 * quat_exp(&(quat_log(&(q0.inverse() * q1)) * 0.5));
        assert!(mid.angle_to(&exact) < 1e-7);
    }
}
