//! Master motion: cosine roll, pitch and yaw about a mean heading, at a constant
//! velocity, with analytic attitude and body rate.

use super::scenario::MotionSpec;
use nalgebra::{Matrix3, Vector3};
use std::f64::consts::PI;

/// Attitude and rate of the master body at one instant.
#[derive(Clone, Copy, Debug)]
pub struct MasterAttitude {
    /// `C_bm^n` (ENU ← right-forward-up).
    pub c_bm_n: Matrix3<f64>,
    /// Body rate relative to the navigation frame, `ω_nb^bm` (rad/s).
    pub w_nb_bm: Vector3<f64>,
}

fn rx(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)
}
fn ry(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)
}
fn rz(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

/// Angle and rate of `amp cos(2π t / period)`.
fn cosine(amp_deg: f64, period_s: f64, t: f64) -> (f64, f64) {
    let w = 2.0 * PI / period_s;
    let a = amp_deg.to_radians();
    (a * (w * t).cos(), -a * w * (w * t).sin())
}

impl MotionSpec {
    /// Attitude `C_bm^n = Rz(yaw) Rx(pitch) Ry(roll)` and `ω_nb^bm` at time `t`.
    pub fn attitude(&self, t: f64) -> MasterAttitude {
        let (roll, droll) = cosine(self.roll_amp_deg, self.roll_period_s, t);
        let (pitch, dpitch) = cosine(self.pitch_amp_deg, self.pitch_period_s, t);
        let (yaw0, dyaw) = cosine(self.yaw_amp_deg, self.yaw_period_s, t);
        let yaw = yaw0 + self.heading_deg.to_radians();
        let (a, b, c) = (rz(yaw), rx(pitch), ry(roll));
        // C = A B C': ω = C'ᵀ Bᵀ ω_A + C'ᵀ ω_B + ω_C for rotations about fixed axes.
        let w = c.transpose() * b.transpose() * Vector3::new(0.0, 0.0, dyaw)
            + c.transpose() * Vector3::new(dpitch, 0.0, 0.0)
            + Vector3::new(0.0, droll, 0.0);
        MasterAttitude {
            c_bm_n: a * b * c,
            w_nb_bm: w,
        }
    }

    /// Constant velocity over ground, ENU (m/s), along the mean heading.
    pub fn velocity_n(&self) -> Vector3<f64> {
        let h = self.heading_deg.to_radians();
        Vector3::new(-h.sin(), h.cos(), 0.0) * self.speed_mps
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use flexcal_core::rotation::log_so3;

    #[test]
    fn body_rate_is_derivative_of_attitude() {
        let m = MotionSpec {
            roll_amp_deg: 13.0,
            roll_period_s: 10.0,
            pitch_amp_deg: 5.0,
            pitch_period_s: 8.0,
            yaw_amp_deg: 3.0,
            yaw_period_s: 6.0,
            heading_deg: 30.0,
            speed_mps: 0.0,
        };
        for t in [0.3, 1.7, 4.2] {
            let h = 1e-5;
            let a0 = m.attitude(t - h).c_bm_n;
            let a1 = m.attitude(t + h).c_bm_n;
            let w_fd = log_so3(&(a0.transpose() * a1)) / (2.0 * h);
            assert!((w_fd - m.attitude(t).w_nb_bm).norm() < 1e-8);
        }
    }
}
