//! The least variance the accelerometer bias along the specific force can honestly have,
//! set by the product of the tilt and bias errors across it.
//!
//! The slave's velocity error rate is `C (Exp(ψ)(f + ∇) − f)` (ψ the attitude error, ∇ the
//! accelerometer bias error); Φ keeps `C(ψ × f + ∇)`. Across `f` the velocity fixes only
//! `ψ × f + ∇`, so where the ship's motion is too small to part them (a calm sea, a bench),
//! the tilt error follows the cross bias error, `ψ⊥ = u × ∇ / |f|` (`u = f/|f|`). What Φ
//! leaves out, `[ψ×]∇ + ½[ψ×]²f`, is then `½|∇⊥|²/|f|` along `u`: the channel along the
//! specific force measures `uᵀ∇ + ½|∇⊥|²/|f|`, and a linear filter credits all of it to
//! `uᵀ∇`. It also knows `u` only through its estimated attitude, off by ψ, so along its
//! own sharp direction the error is `−½|∇⊥|²/|f|`. Either way the bias along the specific
//! force is not known better than that product, whatever the vertical velocity says: on a
//! calm-sea draw handed its truth the filter claimed 1.2e-6 m/s² for an error of 8.6e-6
//! (NEES 98; docs/model-learning.md, "Session 12").
//!
//! For `∇⊥` normal with covariance `Σ⊥` (P(∇) across `u`), `½|∇⊥|²/|f|` has mean
//! `½ tr Σ⊥/|f|` and variance `½ tr(Σ⊥²)/|f|²`; its mean square, the floor here, is
//! `(¼ (tr Σ⊥)² + ½ tr(Σ⊥²)) / |f|²` (a Gaussian second-order filter's `2 tr(A P A P)`
//! with the mean added, since the mean is not taken out: it is one-signed, and its sign
//! along the filter's direction is the estimate's). The direction is P(∇)'s sharpest, its
//! least eigenvector: where the floor can bind it is the specific force's, and it is
//! found without the attitude (an accelerating or rolling body moves `u` off it).

use crate::mat::mul3v;
use crate::real::Real;
use nalgebra::{Matrix3, Vector3};

/// The floor on the accelerometer bias along one direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BiasFloor<T> {
    /// Unit direction of the bias combination (slave body).
    pub direction_b: Vector3<T>,
    /// The least variance of the combination (m²/s⁴).
    pub variance: T,
}

/// The floor of the bias combination along P(∇)'s least eigenvector. `p_ba`: the
/// accelerometer bias error covariance (m²/s⁴, slave body); `f_norm`: the specific
/// force's magnitude over the period (m/s²). `None` for a non-positive or non-finite
/// `f_norm` or a `p_ba` with no least direction (zero or not finite).
pub fn floor<T: Real>(p_ba: &Matrix3<T>, f_norm: T) -> Option<BiasFloor<T>> {
    if !(f_norm > T::zero() && f_norm.is_finite()) {
        return None;
    }
    let u = least_direction(p_ba)?;
    let pu = mul3v(p_ba, &u);
    let along = u.dot(&pu);
    // Σ⊥ = Π P Π, Π = I − u uᵀ: tr Σ⊥ = tr P − uᵀPu, tr Σ⊥² = tr P² − 2|Pu|² + (uᵀPu)².
    let tr_perp = p_ba.trace() - along;
    let tr_perp_sq = p_ba.norm_squared() - pu.norm_squared() * T::of(2.0) + along * along;
    let variance = (tr_perp * tr_perp * T::of(0.25) + tr_perp_sq * T::of(0.5)) / (f_norm * f_norm);
    variance.is_finite().then_some(BiasFloor {
        direction_b: u,
        variance,
    })
}

/// The unit least eigenvector of a symmetric positive semi-definite 3 × 3 matrix, from
/// its adjugate (`det(P) P⁻¹`, whose largest eigenvector it is, with eigenvalue the
/// product of the two others): the adjugate's column of largest diagonal, once more
/// through the adjugate. Exact where the least eigenvalue is well below the others, the
/// only case the floor can bind.
fn least_direction<T: Real>(p: &Matrix3<T>) -> Option<Vector3<T>> {
    let e = |i: usize, j: usize| p.get((i, j)).copied().unwrap_or_else(T::zero);
    let cof = |a: usize, b: usize, c: usize, d: usize| e(a, c) * e(b, d) - e(a, d) * e(b, c);
    let adj = Matrix3::new(
        cof(1, 2, 1, 2),
        -cof(0, 2, 1, 2),
        cof(0, 1, 1, 2),
        -cof(1, 2, 0, 2),
        cof(0, 2, 0, 2),
        -cof(0, 1, 0, 2),
        cof(1, 2, 0, 1),
        -cof(0, 2, 0, 1),
        cof(0, 1, 0, 1),
    );
    let k = (0..3).fold(0, |best, k| {
        if adj.get((k, k)) > adj.get((best, best)) {
            k
        } else {
            best
        }
    });
    let v = adj * adj.column(k);
    // (`norm()` is libm's software `sqrtf` on the board; `sqrt_fast` the FPU's, both
    // correctly rounded.)
    let n = v.norm_squared().sqrt_fast();
    (n > T::zero() && n.is_finite()).then(|| v / n)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// P(∇) with eigenvalues `l` along the columns of a rotation.
    fn with_eigen(l: [f64; 3], r: &Matrix3<f64>) -> Matrix3<f64> {
        r * Matrix3::from_diagonal(&Vector3::from(l)) * r.transpose()
    }

    fn tilted() -> Matrix3<f64> {
        *nalgebra::Rotation3::from_scaled_axis(Vector3::new(0.03, -0.02, 1.1)).matrix()
    }

    #[test]
    fn the_direction_is_the_least_eigenvector() {
        let r = tilted();
        let p = with_eigen([6.4e-5, 4.4e-5, 1.4e-12], &r);
        let fl = floor(&p, 9.8).unwrap();
        let want = r.column(2).into_owned();
        assert!(
            (fl.direction_b.dot(&want).abs() - 1.0).abs() < 1e-12,
            "{}",
            fl.direction_b
        );
    }

    #[test]
    fn the_floor_is_the_mean_square_of_half_the_cross_bias_squared_over_f() {
        // Σ⊥ = diag(a, b): E[(½(x² + y²)/f)²] = (¼(a + b)² + ½(a² + b²))/f², checked
        // against its own Monte Carlo-free moments: x², y² have means a, b and variances
        // 2a², 2b².
        let (a, b, f) = (6.4e-5, 4.4e-5, 9.8);
        let p = with_eigen([a, b, 1e-13], &tilted());
        let fl = floor(&p, f).unwrap();
        let mean = 0.5 * (a + b) / f;
        let var = 0.25 * (2.0 * a * a + 2.0 * b * b) / (f * f);
        assert!(
            (fl.variance / (mean * mean + var) - 1.0).abs() < 1e-9,
            "{}",
            fl.variance
        );
    }

    #[test]
    fn a_calm_sea_horizontal_bias_of_one_milli_g_floors_the_vertical_near_one_point_four_micro_g() {
        let s = 9.80665e-3;
        let p = with_eigen([s * s, s * s, 1e-14], &Matrix3::identity());
        let fl = floor(&p, 9.80665).unwrap();
        // 2 σ⁴ / g²: √ = √2 σ²/g = 1.387e-5 m/s².
        assert!((fl.variance.sqrt() / (2f64.sqrt() * s * s / 9.80665) - 1.0).abs() < 1e-9);
    }

    #[test]
    fn degenerate_inputs_give_no_floor() {
        let p = with_eigen([1e-4, 1e-4, 1e-12], &Matrix3::identity());
        assert!(floor(&p, 0.0).is_none());
        assert!(floor(&p, f64::NAN).is_none());
        assert!(floor(&Matrix3::zeros(), 9.8).is_none());
        assert!(floor(&(p * f64::INFINITY), 9.8).is_none());
    }

    #[test]
    fn f32_finds_the_same_direction_and_floor() {
        let p = with_eigen([6.4e-5, 4.4e-5, 1.4e-12], &tilted());
        let d = floor(&p, 9.8).unwrap();
        let s = floor(&p.map(|x| x as f32), 9.8f32).unwrap();
        let dir = s.direction_b.map(f64::from);
        // The angle between them (f32's unit vector is unit to ~1e-7 only).
        assert!(
            dir.cross(&d.direction_b).norm() < 1e-5,
            "{dir} {}",
            d.direction_b
        );
        assert!((f64::from(s.variance) / d.variance - 1.0).abs() < 1e-5);
    }
}
