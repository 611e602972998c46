//! The slave's strapdown mechanization in ENU from IMU increments, on a moving
//! platform: attitude `q_b^n`, velocity and position, with coning and sculling
//! compensation (one previous interval, the classic "1/12" two-sample corrections).

use crate::earth::{self, Position};
use crate::real::Real;
use crate::rotation::quat_exp;
use nalgebra::{UnitQuaternion, Vector3};

/// The slave navigation solution.
#[derive(Clone, Copy, Debug)]
pub struct NavState<T: Real> {
    /// Attitude `q_bs^n` (Hamilton, scalar first): slave body to ENU.
    pub q_b_n: UnitQuaternion<T>,
    /// Velocity relative to the Earth, ENU (m/s).
    pub v_n: Vector3<T>,
    /// Geodetic position.
    pub pos: Position<T>,
}

/// One IMU interval's bias-corrected increments, in the slave body frame.
#[derive(Clone, Copy, Debug, Default)]
pub struct Increments<T: Real> {
    /// ∫ ω_ib^b dt over the interval (rad).
    pub dtheta_b: Vector3<T>,
    /// ∫ f^b dt over the interval (m/s).
    pub dv_b: Vector3<T>,
    /// Interval length (s).
    pub dt: T,
}

/// Strapdown integrator: the navigation state plus the previous increments the
/// coning and sculling corrections need.
#[derive(Clone, Copy, Debug)]
pub struct Strapdown<T: Real> {
    /// Current navigation solution.
    pub nav: NavState<T>,
    prev: Option<Increments<T>>,
}

impl<T: Real> Strapdown<T> {
    /// Starts the mechanization from a known state.
    pub fn new(nav: NavState<T>) -> Self {
        Self { nav, prev: None }
    }

    /// Forgets the previous interval (after a gap, the coning/sculling history is void).
    pub fn reset_history(&mut self) {
        self.prev = None;
    }

    /// Advances the solution by one IMU interval.
    pub fn step(&mut self, inc: &Increments<T>) {
        let twelfth = T::one() / T::of(12.0);
        let half = T::of(0.5);
        let (dth_p, dv_p) = match &self.prev {
            Some(p) => (p.dtheta_b, p.dv_b),
            None => (Vector3::zeros(), Vector3::zeros()),
        };
        let dth = inc.dtheta_b;
        let dv = inc.dv_b;
        // Coning: rotation vector of the body over the interval.
        let phi = dth + dth_p.cross(&dth) * twelfth;
        // Rotation and sculling: the velocity increment resolved in the body frame at the
        // start of the interval.
        let dv_rot = dth.cross(&dv) * half;
        let dv_scul = (dth_p.cross(&dv) + dv_p.cross(&dth)) * twelfth;
        let dv_b0 = dv + dv_rot + dv_scul;

        let nav = &mut self.nav;
        let w_ie = earth::earth_rate_n(nav.pos.lat_rad);
        let w_en = earth::transport_rate_n(&nav.pos, &nav.v_n);
        let w_in = w_ie + w_en;
        let zeta = w_in * inc.dt;
        // Specific force increment in n, with the n-frame rotation over the interval.
        let dv_sf = {
            let c_dv = nav.q_b_n * dv_b0;
            c_dv - zeta.cross(&c_dv) * half
        };
        let g = earth::gravity_n(&nav.pos);
        let coriolis = (w_ie * T::of(2.0) + w_en).cross(&nav.v_n);
        let v_old = nav.v_n;
        nav.v_n += dv_sf + (g - coriolis) * inc.dt;
        // Position with the mean velocity over the interval.
        let v_mid = (v_old + nav.v_n) * half;
        let dpos = earth::position_rate(&nav.pos, &v_mid) * inc.dt;
        nav.pos.lat_rad += dpos.x;
        nav.pos.lon_rad += dpos.y;
        nav.pos.height_m += dpos.z;
        // Attitude: body rotation on the right, n-frame rotation on the left.
        nav.q_b_n = quat_exp(&(-zeta)) * nav.q_b_n * quat_exp(&phi);
        nav.q_b_n.renormalize_fast();
        self.prev = Some(*inc);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rotation::quat_log;

    fn at_rest_state(lat: f64) -> NavState<f64> {
        NavState {
            q_b_n: UnitQuaternion::identity(),
            v_n: Vector3::zeros(),
            pos: Position { lat_rad: lat, lon_rad: 0.0, height_m: 0.0 },
        }
    }

    #[test]
    fn stationary_imu_stays_put_for_an_hour() {
        // A level IMU at rest senses −g up... i.e. specific force +g along z, and Earth rate.
        let lat = 0.6;
        let g = earth::normal_gravity(lat, 0.0);
        let w = earth::earth_rate_n(lat); // body = ENU here
        let dt = 0.005;
        let inc = Increments { dtheta_b: w * dt, dv_b: Vector3::new(0.0, 0.0, g) * dt, dt };
        let mut sd = Strapdown::new(at_rest_state(lat));
        for _ in 0..(3600.0 / dt) as usize {
            sd.step(&inc);
        }
        assert!(sd.nav.v_n.norm() < 1e-6, "{:?}", sd.nav.v_n);
        assert!(quat_log(&sd.nav.q_b_n).norm() < 1e-9);
    }

    #[test]
    fn coning_motion_keeps_attitude_accurate() {
        // Classic coning: the body axis precesses; compare with the exact attitude.
        let (alpha, w, dt) = (0.01_f64, 2.0 * core::f64::consts::PI * 2.0, 0.005);
        let exact = |t: f64| {
            // q(t) = Exp(α [cos wt, sin wt, 0]) applied as rotation vector: integrate numerically.
            quat_exp(&Vector3::new(alpha * (w * t).cos(), alpha * (w * t).sin(), 0.0))
        };
        // Generate exact increments by fine integration of ω = 2 log(q(t)^-1 q(t+h))/h.
        let steps = 2000;
        let mut sd = Strapdown::new(NavState { q_b_n: exact(0.0), v_n: Vector3::zeros(), pos: Position::default() });
        let sub = 50;
        let mut q_ref = exact(0.0);
        // The attitude update of `Strapdown::step`, without its n-frame rotation.
        for k in 0..steps {
            let mut dth = Vector3::zeros();
            for j in 0..sub {
                let t0 = k as f64 * dt + j as f64 * dt / sub as f64;
                let t1 = t0 + dt / sub as f64;
                dth += quat_log(&(exact(t0).inverse() * exact(t1)));
            }
            // Integrate the body rotation only (the Earth terms are tested above).
            q_ref = exact((k + 1) as f64 * dt);
            let phi = dth + sd.prev.map_or(Vector3::zeros(), |p| p.dtheta_b).cross(&dth) / 12.0;
            sd.nav.q_b_n = sd.nav.q_b_n * quat_exp(&phi);
            sd.prev = Some(Increments { dtheta_b: dth, dv_b: Vector3::zeros(), dt });
        }
        let err = quat_log(&(q_ref.inverse() * sd.nav.q_b_n)).norm();
        // Without the coning term the drift would be α² w t / 2 ≈ 5e-4 rad over 10 s.
        assert!(err < 2e-6, "attitude error {err}");
    }
}
