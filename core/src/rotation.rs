//! Rotations: quaternion, direction cosine matrix and rotation vector, with the
//! SO(3) exponential/logarithm and right Jacobian the error model needs.
//!
//! Quaternions are nalgebra's `UnitQuaternion`, which is Hamilton with the scalar
//! part `w` first in `Quaternion::new(w, i, j, k)`, and `q * v` computes `q ⊗ v ⊗ q*`:
//! exactly the recording format's `q_b^n` convention.

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
    let angle = a.norm();
    let half = angle * T::of(0.5);
    // sin(x/2)/x, with its Taylor series near zero so tiny vectors stay exact.
    let k = if angle < T::of(1e-4) {
        T::of(0.5) - angle * angle / T::of(48.0)
    } else {
        half.sin() / angle
    };
    UnitQuaternion::new_unchecked(Quaternion::new(half.cos(), a.x * k, a.y * k, a.z * k))
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
    let s = v.norm();
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
    let a = phi.norm();
    let k = skew(phi);
    let (c1, c2) = if a < T::of(1e-3) {
        (
            T::of(0.5) - a * a / T::of(24.0),
            T::one() / T::of(6.0) - a * a / T::of(120.0),
        )
    } else {
        let a2 = a * a;
        ((T::one() - a.cos()) / a2, (a - a.sin()) / (a2 * a))
    };
    Matrix3::identity() - k * c1 + k * k * c2
}

/// Normalized linear interpolation between two attitudes, `s` in [0, 1]: accurate to
/// second order in the angle between them, which is what a few-millisecond gap needs.
pub fn nlerp<T: Real>(q0: &UnitQuaternion<T>, q1: &UnitQuaternion<T>, s: T) -> UnitQuaternion<T> {
    let b = if q0.coords.dot(&q1.coords) < T::zero() {
        -q1.coords
    } else {
        q1.coords
    };
    let c = q0.coords * (T::one() - s) + b * s;
    UnitQuaternion::new_normalize(Quaternion::from(c))
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
