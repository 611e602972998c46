//! Time alignment: a bounded buffer of the slave's solution at every IMU step, so a
//! master message is matched against the slave *at the message's time of validity*,
//! never at its arrival.

use crate::mat::{vec3, vget};
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

/// The slave's raw gyro rate at a time, and how its white noise is scaled.
#[derive(Clone, Copy, Debug)]
pub struct RateAt<T: Real> {
    /// Raw (not bias-corrected) rate, slave body (rad/s).
    pub raw_b: Vector3<T>,
    /// Raw specific force at the same time, interpolated the same way, slave body (m/s²).
    pub f_raw_b: Vector3<T>,
    /// Σ wᵢ²/dtᵢ over the interpolation weights (1/s): the rate's noise variance is
    /// the gyro angle-random-walk density squared times this. In `T`, as the variance it
    /// scales (in software `f64` on the board: two divisions, ≈ 0.5k instructions an
    /// update).
    pub noise_gain: T,
    /// How far the interpolated rate departs from the rate *at* its time when the rate
    /// diffuses (s): a rate that moves as a random walk of density `q` (rad²/s³) leaves a
    /// departure of variance `q` times this ([`departure_gain`]). The flexure's rate does,
    /// inside the IMU intervals (`flexure::AxisModel::rate_diffusion`). In `T`: single
    /// precision on the board (in software `f64` it cost 12k instructions an update).
    pub departure_gain: T,
}

/// `∫ g(u)² du` (s) for the interpolated rate `w0 m_p + w1 m_s` (`m` the mean rate over
/// an interval: `(−p_dt, 0]` and `(gap, gap + s_dt]`, times from the end of the first,
/// `gap ≥ 0`) read at `a`, `0 < a ≤ gap + s_dt`, against the rate at `a`, when the rate
/// is a random walk: the departure is `∫ g(u) dW(u)`, `g(u)` the kernel's mass after `u`
/// for `u > a` and minus its mass up to `u` for `u < a` (with `w0 + w1 = 1` it jumps by
/// 1 at `a`). `g` is linear on each piece between the intervals' ends and `a`, so each
/// integrates exactly as `L (g₀² + g₀g₁ + g₁²) / 3`.
fn departure_gain<T: Real>(p_dt: T, w0: T, gap: T, s_dt: T, w1: T, a: T) -> T {
    let zero = T::zero();
    let piece = |l: T, g0: T, g1: T| l.max(zero) * (g0 * g0 + g0 * g1 + g1 * g1) / T::of(3.0);
    // Before a: over the first interval g goes 0 → −w0, over the gap it stays −w0, then
    // over the second interval up to a it goes on by −w1 per s_dt.
    let into_s = (a - gap).max(zero);
    let before = piece(p_dt, zero, -w0)
        + piece(gap.min(a), -w0, -w0)
        + piece(into_s, -w0, -(w0 + w1 * into_s / s_dt));
    // After a: w1 over what is left of the gap, then down to 0 over the rest of the second.
    let rest = (gap + s_dt - a).min(s_dt);
    before + piece(gap - a, w1, w1) + piece(rest, w1 * rest / s_dt, zero)
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

    /// `t`, or the newest snapshot's time where `t` is past it (none held: `t`). For a
    /// time of validity let through within a rounding slack of the newest sample.
    pub fn at_most_newest(&self, t: f64) -> f64 {
        match self.ring.back() {
            Some(s) if t > s.t => s.t,
            _ => t,
        }
    }

    /// The snapshots, oldest first.
    pub fn iter(&self) -> impl Iterator<Item = &Snapshot<T>> {
        self.ring.iter()
    }

    /// Empties the buffer (after a re-initialization).
    pub fn clear(&mut self) {
        self.ring.clear();
    }

    /// Number of snapshots kept.
    pub fn len(&self) -> usize {
        self.ring.len()
    }

    /// `true` if no snapshot is kept.
    pub fn is_empty(&self) -> bool {
        self.ring.is_empty()
    }

    /// Drops the snapshots at or before `t` (the oldest ones: snapshots are kept in time
    /// order).
    pub fn drop_until(&mut self, t: f64) {
        while self.ring.front().is_some_and(|s| s.t <= t) {
            let _ = self.ring.pop_front();
        }
    }

    /// Removes and returns the oldest snapshot.
    pub fn pop_oldest(&mut self) -> Option<Snapshot<T>> {
        self.ring.pop_front()
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
        // Times increase along the ring and `t` is usually close to the newest, so the
        // first snapshot at or after `t` (`s`) and the one before it (`prev`; `s` itself
        // when it is the oldest) are found from the back.
        let (mut s, mut prev) = (last, None);
        for x in self.ring.iter().rev() {
            if x.t >= t {
                s = x;
            } else {
                prev = Some(x);
                break;
            }
        }
        let prev = prev.unwrap_or(s);
        // The weight's times are differences (small) in `f64`, its division in `T` (a
        // software `f64` division on the board).
        let span = s.t - prev.t;
        let wt = if span > 0.0 {
            T::of(t - prev.t) / T::of(span)
        } else {
            T::one()
        };
        let one = T::one();
        Ok(SlaveAt {
            q_b_n: nlerp(&prev.q_b_n, &s.q_b_n, wt),
            v_n: prev.v_n * (one - wt) + s.v_n * wt,
        })
    }

    /// Raw gyro rate at time `t` (rad/s, slave body): the straight line through the
    /// mean rates of the IMU interval containing `t` and the one before it (each mean
    /// belongs to its interval's midpoint), evaluated at `t`. Each master message thus
    /// uses its own two intervals, so successive rate matches share no data and their
    /// noise stays white.
    pub fn rate_at(&self, t: f64) -> Result<RateAt<T>, AlignError> {
        if self.ring.back().is_none_or(|s| t > s.t) {
            return Err(AlignError::NotYet);
        }
        // The first interval (of positive length) ending at or after `t`, and the one
        // before it, searched from the back (times increase along the ring).
        let (mut next, mut prev): (Option<&Snapshot<T>>, Option<&Snapshot<T>>) = (None, None);
        for x in self.ring.iter().rev().filter(|s| s.dt > 0.0) {
            if x.t >= t {
                next = Some(x);
            } else {
                prev = Some(x);
                break;
            }
        }
        let Some(s) = next else {
            return Err(AlignError::NotYet);
        };
        let Some(p) = prev else {
            return Err(AlignError::TooOld);
        };
        // The midpoints' times in `f64`, the weights from their differences in `T` (as
        // `at`'s).
        let (m0, m1) = (p.t - p.dt / 2.0, s.t - s.dt / 2.0);
        let lambda = if m1 > m0 {
            T::of(t - m0) / T::of(m1 - m0)
        } else {
            T::one()
        };
        // `(x / dt_p) (1 − λ) + (y / dt_s) λ`, element by element as nalgebra's vector
        // operations form it (a loop each on the board).
        let (w0, w1, dt0, dt1) = (T::one() - lambda, lambda, T::of(p.dt), T::of(s.dt));
        let mix = |x: &Vector3<T>, y: &Vector3<T>| {
            vec3(|i| (vget(x, i) / dt0) * w0 + (vget(y, i) / dt1) * w1)
        };
        Ok(RateAt {
            raw_b: mix(&p.dtheta_raw_b, &s.dtheta_raw_b),
            f_raw_b: mix(&p.dv_raw_b, &s.dv_raw_b),
            noise_gain: w0 * w0 / dt0 + w1 * w1 / dt1,
            departure_gain: departure_gain(
                dt0,
                w0,
                T::of((s.t - s.dt - p.t).max(0.0)),
                dt1,
                w1,
                T::of(t - p.t),
            ),
        })
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

    /// [`Self::correct`] for the snapshots a later time `t' > t` can still be
    /// interpolated from: those at or after `t` and the last one before it. Older
    /// snapshots keep their values (only their raw increments are read again).
    pub fn correct_since(&mut self, t: f64, dv_n: &Vector3<T>, psi_b: &Vector3<T>) {
        let r = quat_exp(&(-psi_b));
        for s in self.ring.iter_mut().rev() {
            // (Element by element, as nalgebra's `-=`: a loop of its own on the board.)
            s.v_n = vec3(|i| vget(&s.v_n, i) - vget(dv_n, i));
            s.q_b_n *= r;
            if s.t < t {
                break;
            }
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
    fn correct_since_corrects_what_later_times_interpolate_from() {
        let mut all = AlignBuffer::<f64, 8>::new();
        for k in 0..8 {
            all.push(snap(k as f64 * 0.005, 2.0, 0.3));
        }
        let mut since = all.clone();
        let (dv, psi) = (
            Vector3::new(0.1, -0.2, 0.3),
            Vector3::new(1e-3, -2e-3, 3e-3),
        );
        all.correct(&dv, &psi);
        since.correct_since(0.0175, &dv, &psi);
        // From the last snapshot before t = 0.0175 (t = 0.015) on: corrected alike.
        for (a, b) in all.iter().zip(since.iter()) {
            if a.t >= 0.015 {
                assert_eq!((a.v_n, a.q_b_n), (b.v_n, b.q_b_n));
            } else {
                assert_ne!(a.v_n, b.v_n);
            }
        }
        for t in [0.0175, 0.02, 0.0301, 0.035] {
            let (a, b) = (all.at(t).unwrap(), since.at(t).unwrap());
            assert_eq!((a.v_n, a.q_b_n), (b.v_n, b.q_b_n));
        }
    }

    #[test]
    fn rate_at_interpolates_a_linear_rate_exactly() {
        let mut b = AlignBuffer::<f64, 8>::new();
        // ω(t) = 0.3 + 2 t: the mean over (t−dt, t] is ω at the midpoint.
        for k in 1..=8 {
            let t = k as f64 * 0.005;
            let mid = t - 0.0025;
            let mut s = snap(t, 0.0, 0.0);
            s.dtheta_raw_b = Vector3::new(0.0, 0.0, (0.3 + 2.0 * mid) * 0.005);
            b.push(s);
        }
        for t in [0.02, 0.0215, 0.04] {
            let r = b.rate_at(t).unwrap();
            assert!((r.raw_b.z - (0.3 + 2.0 * t)).abs() < 1e-12, "t = {t}");
        }
        // At an interval's end the line is extrapolated by half a sample: weights −0.5, 1.5.
        let g = b.rate_at(0.04).unwrap().noise_gain;
        assert!((g - (0.25 + 2.25) / 0.005).abs() < 1e-9);
        assert_eq!(b.rate_at(0.005).unwrap_err(), AlignError::TooOld);
        assert_eq!(b.rate_at(0.05).unwrap_err(), AlignError::NotYet);
    }

    /// `departure_gain` against the departure's variance computed another way: the
    /// double integral `∬ K(u) K(v) c(u, v)` of the kernel against the covariance of a
    /// unit random walk pinned at `a` (`min(|u − a|, |v − a|)` on one side, 0 across), on
    /// a fine grid; read inside the second interval, at its end (the extrapolated rate the
    /// engine reads at a master time), and with a gap between the intervals (inside it
    /// and past it).
    #[test]
    fn departure_gain_is_the_pinned_random_walks_variance() {
        const N_GRID: usize = 1400;
        for (p_dt, gap, s_dt, w1, a) in [
            (0.0025, 0.0, 0.0025, 1.3, 0.0005),
            (0.0025, 0.0, 0.0025, 1.5, 0.0025),
            (0.0025, 0.0, 0.0050, 0.7, 0.0020),
            (0.0025, 0.0010, 0.0025, 0.9, 0.0004),
            (0.0025, 0.0010, 0.0025, 1.2, 0.0030),
        ] {
            let w0 = 1.0 - w1;
            let density = |u: f64| {
                if u > -p_dt && u <= 0.0 {
                    w0 / p_dt
                } else if u > gap && u <= gap + s_dt {
                    w1 / s_dt
                } else {
                    0.0
                }
            };
            let (lo, hi) = (-p_dt, gap + s_dt);
            let h = (hi - lo) / N_GRID as f64;
            let grid: [f64; N_GRID] = core::array::from_fn(|i| lo + (i as f64 + 0.5) * h);
            let mut var = 0.0;
            for &u in &grid {
                for &v in &grid {
                    let same_side = (u - a) * (v - a) > 0.0;
                    let c = if same_side {
                        (u - a).abs().min((v - a).abs())
                    } else {
                        0.0
                    };
                    var += density(u) * density(v) * c * h * h;
                }
            }
            let g = departure_gain(p_dt, w0, gap, s_dt, w1, a);
            assert!(
                (g - var).abs() < 2e-3 * var,
                "{p_dt} {gap} {s_dt} {w1} {a}: {g} against {var}"
            );
        }
        // Two equal intervals read at their common end with weights ½: T/6 (the limit of
        // `a` → 0 from inside the second).
        let g: f64 = departure_gain(0.01, 0.5, 0.0, 0.01, 0.5, 1e-12);
        assert!((g - 0.01 / 6.0).abs() < 1e-12);
    }
}
