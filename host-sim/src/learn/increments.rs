//! The slave IMU's white noise read from its own increments, before any filter runs:
//! the top of the increment spectrum, where the motion has no power left.
//!
//! A gyro's angle random walk N (rad/√s) is a white rate noise of one-sided density
//! `2 N²` ((rad/s)²/Hz). What else the slave gyro measures at high frequency is the
//! flexure's rate: a second-order Gauss-Markov angle has a rate spectrum falling as
//! `1/f²` above its natural frequency, and the ship's motion is far below. So the
//! rate spectrum over the top half of the band is fitted as `a + b/f²` (least squares
//! on the Welch estimate) and `N = √(a/2)`. The same fit on the accelerometer gives
//! an *upper bound* of the velocity random walk only: the flexure's angular
//! acceleration acting on the lever arm (`R θ̈`) is itself white in the slave's
//! specific force, so it cannot be told from the accelerometer's noise there; the
//! likelihood search decides the velocity random walk (`super::search`).

use crate::diagnose::spectrum::welch;
use crate::recording::Recording;

/// White-noise floors of the slave IMU from its increments.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct IncrementNoise {
    /// Gyro angle random walk per axis (rad/√s).
    pub gyro_arw_rad_rs: [f64; 3],
    /// Accelerometer white floor per axis (m/s/√s): an upper bound of the velocity
    /// random walk (see the module doc).
    pub accel_floor_mps_rs: [f64; 3],
    /// Lower edge of the fitted band (Hz).
    pub band_from_hz: f64,
    /// Upper edge of the fitted band (Hz).
    pub band_to_hz: f64,
}

impl IncrementNoise {
    /// The gyro angle random walk as one number: the median axis (rad/√s).
    pub fn gyro_arw(&self) -> f64 {
        median3(self.gyro_arw_rad_rs)
    }

    /// The accelerometer floor as one number: the median axis (m/s/√s).
    pub fn accel_floor(&self) -> f64 {
        median3(self.accel_floor_mps_rs)
    }
}

fn median3(mut v: [f64; 3]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[1]
}

/// The white level `a` of `psd(f) ≈ a + b/f²` fitted by least squares over the bins in
/// `[from, to]` Hz (`b` is the red part: the flexure's rate). Where the band does not
/// follow that shape, the band's mean density (an upper bound).
fn white_level(freq_hz: &[f64], density: &[f64], from: f64, to: f64) -> f64 {
    // Normal equations of the two-term model.
    let (mut s11, mut s12, mut s22, mut r1, mut r2) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (&f, &d) in freq_hz.iter().zip(density) {
        if f < from || f > to || f <= 0.0 {
            continue;
        }
        let x = 1.0 / (f * f);
        s11 += 1.0;
        s12 += x;
        s22 += x * x;
        r1 += d;
        r2 += d * x;
    }
    let det = s11 * s22 - s12 * s12;
    if s11 < 2.0 || det.abs() <= f64::EPSILON * s11 * s22 {
        return if s11 > 0.0 { r1 / s11 } else { 0.0 };
    }
    let a = (r1 * s22 - r2 * s12) / det;
    let b = (s11 * r2 - s12 * r1) / det;
    let mean = r1 / s11;
    if b < 0.0 || a < 0.1 * mean {
        // No red part in the band, or a band that is not white plus red (vibration
        // peaks on a vehicle): the mean density, an upper bound of the white level.
        mean
    } else {
        a
    }
}

/// One-sided density ((unit/s)²/Hz) of the rate `x_k / dt` of one increment axis.
fn rate_density(x: &[f64], dt: f64) -> (Vec<f64>, Vec<f64>) {
    let rate: Vec<f64> = x.iter().map(|v| v / dt).collect();
    let fs = 1.0 / dt;
    let psd = welch(&rate, fs);
    let ms = rate.iter().map(|v| v * v).sum::<f64>() / rate.len().max(1) as f64;
    // `welch` normalizes to the white level 2σ²/fs: undo it.
    let scale = 2.0 * ms / fs;
    let density = psd.level.iter().map(|l| l * scale).collect();
    (psd.freq_hz, density)
}

/// The white floors of the slave's gyro and accelerometer from the increments of the
/// first `max_samples` samples, fitted over `[fs/4, 0.45 fs]`. Errors when the
/// recording is too short for a spectrum or its IMU period is not constant enough.
pub fn increment_noise(rec: &Recording, max_samples: usize) -> Result<IncrementNoise, String> {
    let n = rec.imu.len().min(max_samples);
    let imu = rec.imu.get(..n).unwrap_or(&rec.imu);
    if n < 1024 {
        return Err(format!(
            "{n} slave samples are too few to read the IMU noise from the increments (1024 needed)"
        ));
    }
    let span = imu[n - 1].t - imu[0].t;
    let dt = span / (n - 1) as f64;
    if !(dt.is_finite() && dt > 0.0) {
        return Err("the slave timestamps do not advance".into());
    }
    let fs = 1.0 / dt;
    let (from, to) = (0.25 * fs, 0.45 * fs);
    let mut gyro = [0.0; 3];
    let mut accel = [0.0; 3];
    for k in 0..3 {
        let g: Vec<f64> = imu.iter().map(|s| s.dtheta_rad[k]).collect();
        let (f, d) = rate_density(&g, dt);
        gyro[k] = (white_level(&f, &d, from, to) / 2.0).sqrt();
        let a: Vec<f64> = imu.iter().map(|s| s.dv_mps[k]).collect();
        let (f, d) = rate_density(&a, dt);
        accel[k] = (white_level(&f, &d, from, to) / 2.0).sqrt();
    }
    Ok(IncrementNoise {
        gyro_arw_rad_rs: gyro,
        accel_floor_mps_rs: accel,
        band_from_hz: from,
        band_to_hz: to,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn white_plus_red_fit_recovers_the_white_level() {
        let f: Vec<f64> = (1..200).map(|k| k as f64).collect();
        let d: Vec<f64> = f.iter().map(|f| 3.0 + 500.0 / (f * f)).collect();
        let a = white_level(&f, &d, 50.0, 180.0);
        assert!((a - 3.0).abs() < 1e-9, "{a}");
    }

    #[test]
    fn white_noise_density_gives_its_random_walk() {
        // Rate noise of ARW N at 200 Hz: increments N √dt · g.
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let (n_arw, dt) = (2e-6, 0.005f64);
        let x: Vec<f64> = (0..40_000)
            .map(|_| n_arw * dt.sqrt() * rng.sample::<f64, _>(rand_distr::StandardNormal))
            .collect();
        let (f, d) = rate_density(&x, dt);
        let n = (white_level(&f, &d, 50.0, 90.0) / 2.0).sqrt();
        // 40 000 samples, ~60 bins × ~9 segments averaged: a few per cent.
        assert!((n / n_arw - 1.0).abs() < 0.05, "{n}");
    }
}
