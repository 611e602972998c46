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
    radii_of_sin(lat_rad.sin())
}

/// [`radii`] from the latitude's sine.
fn radii_of_sin<T: Real>(s: T) -> (T, T) {
    let w2 = T::one() - T::of(E2) * s * s;
    let w = w2.sqrt_fast();
    let rn = T::of(A) / w;
    let rm = T::of(A * (1.0 - E2)) / (w2 * w);
    (rm, rn)
}

/// Normal gravity magnitude (m/s², positive) at latitude and height (Somigliana, with
/// the second-order free-air height correction).
pub fn normal_gravity<T: Real>(lat_rad: T, height_m: T) -> T {
    normal_gravity_of_sin(lat_rad.sin(), height_m)
}

/// [`normal_gravity`] from the latitude's sine.
fn normal_gravity_of_sin<T: Real>(s: T, height_m: T) -> T {
    let s2 = s * s;
    let g0 = T::of(GAMMA_E) * (T::one() + T::of(SOMIGLIANA_K) * s2)
        / (T::one() - T::of(E2) * s2).sqrt_fast();
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
    earth_rate_of(lat_rad.sin(), lat_rad.cos())
}

/// [`earth_rate_n`] from the latitude's sine and cosine.
fn earth_rate_of<T: Real>(sin_lat: T, cos_lat: T) -> Vector3<T> {
    Vector3::new(
        T::zero(),
        T::of(OMEGA_IE) * cos_lat,
        T::of(OMEGA_IE) * sin_lat,
    )
}

/// Transport rate `ω_en^n` (rad/s) of an ENU frame carried at velocity `v_n` (m/s, ENU).
pub fn transport_rate_n<T: Real>(pos: &Position<T>, v_n: &Vector3<T>) -> Vector3<T> {
    let (rm, rn) = radii(pos.lat_rad);
    transport_rate_of(rm, rn, pos.lat_rad.tan(), pos.height_m, v_n)
}

/// [`transport_rate_n`] from the radii and the latitude's tangent.
fn transport_rate_of<T: Real>(
    rm: T,
    rn: T,
    tan_lat: T,
    height_m: T,
    v_n: &Vector3<T>,
) -> Vector3<T> {
    let rmh = rm + height_m;
    let rnh = rn + height_m;
    Vector3::new(-v_n.y / rmh, v_n.x / rnh, v_n.x * tan_lat / rnh)
}

/// Jacobian `∂ω_en^n / ∂v^n` (1/m): how the transport rate changes with a velocity error.
pub fn transport_rate_jacobian<T: Real>(pos: &Position<T>) -> Matrix3<T> {
    let (rm, rn) = radii(pos.lat_rad);
    transport_rate_jacobian_of(rm, rn, pos.lat_rad.tan(), pos.height_m)
}

/// [`transport_rate_jacobian`] from the radii and the latitude's tangent.
fn transport_rate_jacobian_of<T: Real>(rm: T, rn: T, tan_lat: T, height_m: T) -> Matrix3<T> {
    let rmh = T::one() / (rm + height_m);
    let rnh = T::one() / (rn + height_m);
    let z = T::zero();
    Matrix3::new(z, -rmh, z, rnh, z, z, tan_lat * rnh, z, z)
}

/// Rate of change of the geodetic position (rad/s, rad/s, m/s) for a velocity in ENU.
pub fn position_rate<T: Real>(pos: &Position<T>, v_n: &Vector3<T>) -> Vector3<T> {
    let (rm, rn) = radii(pos.lat_rad);
    position_rate_of(rm, rn, pos.lat_rad.cos(), pos.height_m, v_n)
}

/// [`position_rate`] from the radii and the latitude's cosine.
fn position_rate_of<T: Real>(
    rm: T,
    rn: T,
    cos_lat: T,
    height_m: T,
    v_n: &Vector3<T>,
) -> Vector3<T> {
    Vector3::new(
        v_n.y / (rm + height_m),
        v_n.x / ((rn + height_m) * cos_lat),
        v_n.z,
    )
}

/// Moves a position by a small displacement `d_n` (m, ENU), e.g. a lever arm.
pub fn offset_position<T: Real>(pos: &Position<T>, d_n: &Vector3<T>) -> Position<T> {
    let (rm, rn) = radii(pos.lat_rad);
    offset_position_of(rm, rn, pos.lat_rad.cos(), pos, d_n)
}

/// [`offset_position`] from the radii and the latitude's cosine.
fn offset_position_of<T: Real>(
    rm: T,
    rn: T,
    cos_lat: T,
    pos: &Position<T>,
    d_n: &Vector3<T>,
) -> Position<T> {
    Position {
        lat_rad: pos.lat_rad + d_n.y / (rm + pos.height_m),
        lon_rad: pos.lon_rad + d_n.x / ((rn + pos.height_m) * cos_lat),
        height_m: pos.height_m + d_n.z,
    }
}

/// The Earth model at one position, its latitude's trig and radii evaluated once
/// ([`Real::sin_cos_fast`]: in `f32` on the board, no software `f64`). The engine builds
/// one per position it works at (the master's, each strapdown step's, the interval's
/// mean) instead of calling the free functions, which each evaluate the trig again.
/// In `f64` every method returns the same bits as the free function of the same name.
#[derive(Clone, Copy, Debug)]
pub struct Local<T> {
    /// The position (rad, rad, m).
    pub pos: Position<T>,
    sin_lat: T,
    cos_lat: T,
    tan_lat: T,
    /// Meridian radius of curvature (m).
    rm: T,
    /// Prime-vertical radius of curvature (m).
    rn: T,
}

impl<T: Real> Local<T> {
    /// Evaluates the latitude's sine, cosine, tangent and the radii at `pos`.
    pub fn at(pos: &Position<T>) -> Self {
        let (s, c) = pos.lat_rad.sin_cos_fast();
        let (rm, rn) = radii_of_sin(s);
        Self {
            pos: *pos,
            sin_lat: s,
            cos_lat: c,
            tan_lat: pos.lat_rad.tan_from(s, c),
            rm,
            rn,
        }
    }

    /// Gravity vector in ENU (m/s²): `[0, 0, −g]` ([`gravity_n`]).
    pub fn gravity_n(&self) -> Vector3<T> {
        Vector3::new(
            T::zero(),
            T::zero(),
            -normal_gravity_of_sin(self.sin_lat, self.pos.height_m),
        )
    }

    /// Earth rate `ω_ie^n` in ENU (rad/s) ([`earth_rate_n`]).
    pub fn earth_rate_n(&self) -> Vector3<T> {
        earth_rate_of(self.sin_lat, self.cos_lat)
    }

    /// Transport rate `ω_en^n` (rad/s) at velocity `v_n` (m/s, ENU) ([`transport_rate_n`]).
    pub fn transport_rate_n(&self, v_n: &Vector3<T>) -> Vector3<T> {
        transport_rate_of(self.rm, self.rn, self.tan_lat, self.pos.height_m, v_n)
    }

    /// `∂ω_en^n / ∂v^n` (1/m) ([`transport_rate_jacobian`]).
    pub fn transport_rate_jacobian(&self) -> Matrix3<T> {
        transport_rate_jacobian_of(self.rm, self.rn, self.tan_lat, self.pos.height_m)
    }

    /// Rate of the geodetic position (rad/s, rad/s, m/s) at velocity `v_n` (m/s, ENU)
    /// ([`position_rate`]).
    pub fn position_rate(&self, v_n: &Vector3<T>) -> Vector3<T> {
        position_rate_of(self.rm, self.rn, self.cos_lat, self.pos.height_m, v_n)
    }

    /// The position moved by a small displacement `d_n` (m, ENU) ([`offset_position`]).
    pub fn offset_position(&self, d_n: &Vector3<T>) -> Position<T> {
        offset_position_of(self.rm, self.rn, self.cos_lat, &self.pos, d_n)
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
    fn local_is_the_free_functions_bit_for_bit_in_f64() {
        for lat in [-1.2_f64, -0.3, 0.0, 0.000_1, 0.6, 0.785, 1.3, 1.57] {
            let pos = Position {
                lat_rad: lat,
                lon_rad: 2.0,
                height_m: 35.0,
            };
            let (v, d) = (Vector3::new(3.0, -7.0, 0.5), Vector3::new(0.4, 1.1, -0.2));
            let l = Local::at(&pos);
            assert_eq!(l.gravity_n(), gravity_n(&pos));
            assert_eq!(l.earth_rate_n(), earth_rate_n(lat));
            assert_eq!(l.transport_rate_n(&v), transport_rate_n(&pos, &v));
            assert_eq!(l.transport_rate_jacobian(), transport_rate_jacobian(&pos));
            assert_eq!(l.position_rate(&v), position_rate(&pos, &v));
            assert_eq!(l.offset_position(&d), offset_position(&pos, &d));
        }
    }

    #[test]
    fn local_in_f32_is_within_f32_rounding_of_f64() {
        for lat in [-1.2_f64, -0.3, 0.0, 0.6, 0.785, 1.3, 1.5] {
            let p64 = Position {
                lat_rad: lat,
                lon_rad: 2.0,
                height_m: 35.0,
            };
            let p32 = Position {
                lat_rad: lat as f32,
                lon_rad: 2.0,
                height_m: 35.0,
            };
            // The f32 latitude is itself rounded: compare against f64 at that latitude.
            let p64 = Position {
                lat_rad: f64::from(p32.lat_rad),
                ..p64
            };
            let v = Vector3::new(3.0, -7.0, 0.5);
            let (l32, l64) = (Local::at(&p32), Local::at(&p64));
            let rel = |a: Vector3<f32>, b: Vector3<f64>| (a.cast::<f64>() - b).norm() / b.norm();
            assert!(rel(l32.gravity_n(), l64.gravity_n()) < 3e-7);
            assert!(rel(l32.earth_rate_n(), l64.earth_rate_n()) < 3e-7);
            assert!(rel(l32.transport_rate_n(&v.cast()), l64.transport_rate_n(&v)) < 5e-7);
            assert!(rel(l32.position_rate(&v.cast()), l64.position_rate(&v)) < 5e-7);
        }
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
