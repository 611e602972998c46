//! Time alignment: a bounded buffer of the slave's solution at every IMU step, so a
//! master message is matched against the slave *at the message's time of validity*,
//! never at its arrival.

use crate::real::Real;
use crate::rotation::{nlerp, quat_exp};
use heapless::Deque;
use nalgebra::{UnitQuaternion, Vector3};

/// The slave's state at the end of one IMU interval, and that interval's raw gyro increment.
#[derive(Clone, Copy, Debug)]
pub struct Snapshot<T: Real> {
    /// End of the IMU interval (s, slave time base).
    pub t: f64,
    /// Slave attitude `q_bs^n` at `t`.
    pub q_b_n: UnitQuaternion<T>,
    /// Slave velocity at `t`, ENU (m/s).
    pub v_n: Vector3<T>,
    /// Raw (not bias-corrected) gyro increment over `(t − dt, t]`, slave body (rad).
    pub dtheta_raw_b: Vector3<T>,
    /// Raw accelerometer increment over the same interval, slave body (m/s).
    pub dv_raw_b: Vector3<T>,
    /// Length of the IMU interval (s).
    pub dt: f64,
}

/// The slave solution interpolated at a time of validity.
#[derive(Clone, Copy, Debug)]
pub struct SlaveAt<T: Real> {
    /// Attitude `q_bs^n`.
    pub q_b_n: UnitQuaternion<T>,
    /// Velocity, ENU (m/s).
    pub v_n: Vector3<T>,
}

/// Why the buffer could not answer for a time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AlignError {
    /// The time is older than the oldest snapshot kept (the message is stale).
    TooOld,
    /// The time is newer than the newest snapshot (the slave has not got there yet).
    NotYet,
}

/// A ring of the last `M` snapshots.
#[derive(Clone, Debug, Default)]
pub struct AlignBuffer<T: Real, const M: usize> {
    ring: Deque<Snapshot<T>, M>,
}

impl<T: Real, const M: usize> AlignBuffer<T, M> {
    /// An empty buffer.
    pub fn new() -> Self {
        Self { ring: Deque::new() }
    }

    /// Appends a snapshot, dropping the oldest when full (its time is then too old to ask for).
    pub fn push(&mut self, s: Snapshot<T>) {
        if self.ring.is_full() {
            let _ = self.ring.pop_front();
        }
        let _ = self.ring.push_back(s);
    }

    /// Time of the newest snapshot.
    pub fn newest_time(&self) -> Option<f64> {
        self.ring.back().map(|s| s.t)
    }

    /// The snapshots, oldest first.
    pub fn iter(&self) -> impl Iterator<Item = &Snapshot<T>> {
        self.ring.iter()
    }

    /// Empties the buffer (after a re-initialization).
    pub fn clear(&mut self) {
        self.ring.clear();
    }

    /// The slave solution at time `t`, interpolated between the two snapshots around it.
    pub fn at(&self, t: f64) -> Result<SlaveAt<T>, AlignError> {
        let (first, last) = match (self.ring.front(), self.ring.back()) {
            (Some(f), Some(l)) => (f, l),
            _ => return Err(AlignError::NotYet),
        };
        if t > last.t {
            return Err(AlignError::NotYet);
        }
        if t < first.t {
            return Err(AlignError::TooOld);
        }
        let mut prev = first;
        for s in self.ring.iter() {
            if s.t >= t {
                let span = s.t - prev.t;
                let w = if span > 0.0 { (t - prev.t) / span } else { 1.0 };
                let wt = T::of(w);
                let one = T::one();
                return Ok(SlaveAt {
                    q_b_n: nlerp(&prev.q_b_n, &s.q_b_n, wt),
                    v_n: prev.v_n * (one - wt) + s.v_n * wt,
                });
            }
            prev = s;
        }
        Err(AlignError::NotYet)
    }

    /// Mean raw gyro rate over `(ta, tb]` (rad/s, slave body), from the increments of
    /// the IMU intervals overlapping it, each weighted by its overlap.
    pub fn mean_raw_rate(&self, ta: f64, tb: f64) -> Result<Vector3<T>, AlignError> {
        let oldest_start = self.ring.front().map(|s| s.t - s.dt);
        match (oldest_start, self.ring.back()) {
            (Some(start), Some(last)) => {
                if ta < start - 1e-9 {
                    return Err(AlignError::TooOld);
                }
                if tb > last.t + 1e-9 {
                    return Err(AlignError::NotYet);
                }
            }
            _ => return Err(AlignError::NotYet),
        }
        if tb <= ta {
            return Err(AlignError::NotYet);
        }
        let mut sum = Vector3::zeros();
        for s in self.ring.iter() {
            let (s0, s1) = (s.t - s.dt, s.t);
            let overlap = (s1.min(tb) - s0.max(ta)).max(0.0);
            if overlap > 0.0 && s.dt > 0.0 {
                sum += s.dtheta_raw_b * T::of(overlap / s.dt);
            }
        }
        Ok(sum / T::of(tb - ta))
    }

    /// Applies a closed-loop correction to every stored snapshot: velocity minus
    /// `dv_n` (m/s), attitude rotated by `Exp(−psi_b)` (rad, body).
    pub fn correct(&mut self, dv_n: &Vector3<T>, psi_b: &Vector3<T>) {
        let r = quat_exp(&(-psi_b));
        for s in self.ring.iter_mut() {
            s.v_n -= dv_n;
            s.q_b_n *= r;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn snap(t: f64, v: f64, w: f64) -> Snapshot<f64> {
        Snapshot {
            t,
            q_b_n: quat_exp(&Vector3::new(0.0, 0.0, w * t)),
            v_n: Vector3::new(v * t, 0.0, 0.0),
            dtheta_raw_b: Vector3::new(0.0, 0.0, w * 0.005),
            dv_raw_b: Vector3::zeros(),
            dt: 0.005,
        }
    }

    #[test]
    fn interpolates_between_snapshots_and_refuses_outside() {
        let mut b = AlignBuffer::<f64, 8>::new();
        for k in 0..20 {
            b.push(snap(k as f64 * 0.005, 2.0, 0.3));
        }
        let s = b.at(0.0725).unwrap();
        assert!((s.v_n.x - 2.0 * 0.0725).abs() < 1e-12);
        assert!((crate::rotation::quat_log(&s.q_b_n).z - 0.3 * 0.0725).abs() < 1e-9);
        assert_eq!(b.at(0.01).unwrap_err(), AlignError::TooOld);
        assert_eq!(b.at(0.2).unwrap_err(), AlignError::NotYet);
    }

    #[test]
    fn mean_rate_weights_partial_intervals() {
        let mut b = AlignBuffer::<f64, 8>::new();
        for k in 1..=8 {
            b.push(snap(k as f64 * 0.005, 0.0, 0.3));
        }
        let r = b.mean_raw_rate(0.0125, 0.0325).unwrap();
        assert!((r.z - 0.3).abs() < 1e-12);
        assert_eq!(
            b.mean_raw_rate(-0.01, 0.02).unwrap_err(),
            AlignError::TooOld
        );
    }
}
