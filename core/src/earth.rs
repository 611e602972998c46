//! WGS-84 Earth model in the East-North-Up navigation frame: radii of curvature,
//! normal gravity, Earth rate and transport rate.

use crate::real::Real;
use nalgebra::{Matrix3, Vector3};

/// WGS-84 semi-major axis (m).
pub const A: f64 = 6_378_137.0;
/// WGS-84 flattening.
pub const F: f64 = 1.0 / 298.257_223_563;
/// First eccentricity squared.
pub const E2: f64 = F * (2.0 - F);
/// Earth rotation rate (rad/s).
pub const OMEGA_IE: f64 = 7.292_115e-5;
/// Normal gravity at the equator (m/s²), Somigliana.
const GAMMA_E: f64 = 9.780_325_335_9;
/// Somigliana's constant k = (b γ_p − a γ_e) / (a γ_e).
const SOMIGLIANA_K: f64 = 0.001_931_852_652_41;
/// m = ω² a² b / GM.
const M_RATIO: f64 = 0.003_449_786_003_08;

/// Geodetic position: latitude and longitude in radians, ellipsoidal height in metres.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Position<T> {
    /// Geodetic latitude (rad).
    pub lat_rad: T,
    /// Longitude (rad).
    pub lon_rad: T,
    /// Height above the ellipsoid (m).
    pub height_m: T,
}

/// Meridian (north-south) and prime-vertical (east-west) radii of curvature (m) at a latitude.
pub fn radii<T: Real>(lat_rad: T) -> (T, T) {
    let s = lat_rad.sin();
    let w2 = T::one() - T::of(E2) * s * s;
    let w = w2.sqrt();
    let rn = T::of(A) / w;
    let rm = T::of(A * (1.0 - E2)) / (w2 * w);
    (rm, rn)
}

/// Normal gravity magnitude (m/s², positive) at latitude and height (Somigliana, with
/// the second-order free-air height correction).
pub fn normal_gravity<T: Real>(lat_rad: T, height_m: T) -> T {
    let s2 = lat_rad.sin() * lat_rad.sin();
    let g0 =
        T::of(GAMMA_E) * (T::one() + T::of(SOMIGLIANA_K) * s2) / (T::one() - T::of(E2) * s2).sqrt();
    let h = height_m;
    let lin = T::of(2.0 / A) * (T::one() + T::of(F) + T::of(M_RATIO) - T::of(2.0 * F) * s2);
    g0 * (T::one() - lin * h + T::of(3.0 / (A * A)) * h * h)
}

/// Gravity vector in ENU (m/s²): `[0, 0, −g]`.
pub fn gravity_n<T: Real>(pos: &Position<T>) -> Vector3<T> {
    Vector3::new(
        T::zero(),
        T::zero(),
        -normal_gravity(pos.lat_rad, pos.height_m),
    )
}

/// Earth rate `ω_ie^n` resolved in ENU (rad/s).
pub fn earth_rate_n<T: Real>(lat_rad: T) -> Vector3<T> {
    Vector3::new(
        T::zero(),
        T::of(OMEGA_IE) * lat_rad.cos(),
        T::of(OMEGA_IE) * lat_rad.sin(),
    )
}

/// Transport rate `ω_en^n` (rad/s) of an ENU frame carried at velocity `v_n` (m/s, ENU).
pub fn transport_rate_n<T: Real>(pos: &Position<T>, v_n: &Vector3<T>) -> Vector3<T> {
    let (rm, rn) = radii(pos.lat_rad);
    let rmh = rm + pos.height_m;
    let rnh = rn + pos.height_m;
    Vector3::new(-v_n.y / rmh, v_n.x / rnh, v_n.x * pos.lat_rad.tan() / rnh)
}

/// Jacobian `∂ω_en^n / ∂v^n` (1/m): how the transport rate changes with a velocity error.
pub fn transport_rate_jacobian<T: Real>(pos: &Position<T>) -> Matrix3<T> {
    let (rm, rn) = radii(pos.lat_rad);
    let rmh = T::one() / (rm + pos.height_m);
    let rnh = T::one() / (rn + pos.height_m);
    let z = T::zero();
    Matrix3::new(z, -rmh, z, rnh, z, z, pos.lat_rad.tan() * rnh, z, z)
}

/// Rate of change of the geodetic position (rad/s, rad/s, m/s) for a velocity in ENU.
pub fn position_rate<T: Real>(pos: &Position<T>, v_n: &Vector3<T>) -> Vector3<T> {
    let (rm, rn) = radii(pos.lat_rad);
    Vector3::new(
        v_n.y / (rm + pos.height_m),
        v_n.x / ((rn + pos.height_m) * pos.lat_rad.cos()),
        v_n.z,
    )
}

/// Moves a position by a small displacement `d_n` (m, ENU), e.g. a lever arm.
pub fn offset_position<T: Real>(pos: &Position<T>, d_n: &Vector3<T>) -> Position<T> {
    let (rm, rn) = radii(pos.lat_rad);
    Position {
        lat_rad: pos.lat_rad + d_n.y / (rm + pos.height_m),
        lon_rad: pos.lon_rad + d_n.x / ((rn + pos.height_m) * pos.lat_rad.cos()),
        height_m: pos.height_m + d_n.z,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gravity_matches_published_values() {
        // WGS-84 normal gravity: 9.7803253359 at the equator, 9.8321849378 at the poles.
        assert!((normal_gravity(0.0_f64, 0.0) - 9.780_325_335_9).abs() < 1e-9);
        assert!((normal_gravity(core::f64::consts::FRAC_PI_2, 0.0) - 9.832_184_937_8).abs() < 1e-8);
        // Free-air gradient about −3.086e-6 s^-2.
        let grad = (normal_gravity(0.7_f64, 100.0) - normal_gravity(0.7, 0.0)) / 100.0;
        assert!((grad + 3.086e-6).abs() < 0.01e-6, "{grad}");
    }

    #[test]
    fn radii_at_equator_and_pole() {
        let (rm, rn) = radii(0.0_f64);
        assert!((rn - A).abs() < 1e-6);
        assert!((rm - A * (1.0 - E2)).abs() < 1e-6);
        let (rm_p, rn_p) = radii(core::f64::consts::FRAC_PI_2);
        assert!((rm_p - rn_p).abs() < 1e-3);
    }

    #[test]
    fn transport_jacobian_is_exact_derivative() {
        let pos = Position {
            lat_rad: 0.6_f64,
            lon_rad: 2.0,
            height_m: 50.0,
        };
        let v = Vector3::new(3.0, 7.0, -0.5);
        let j = transport_rate_jacobian(&pos);
        for i in 0..3 {
            let mut dv = Vector3::zeros();
            dv[i] = 1.0;
            let fd = transport_rate_n(&pos, &(v + dv)) - transport_rate_n(&pos, &v);
            assert!((fd - j.column(i)).norm() < 1e-15);
        }
    }
}
