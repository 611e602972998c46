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
    /// Per axis, whether that value is the band's mean density, an upper bound, because
    /// the band is not white plus the flexure's red part (vibration peaks, or a white
    /// floor under a tenth of the band: the flexure's rate fills it).
    pub gyro_arw_is_upper_bound: [bool; 3],
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

    /// Whether [`Self::gyro_arw`] is only an upper bound: its median axis's band was
    /// not white plus red.
    pub fn gyro_arw_is_upper_bound(&self) -> bool {
        let m = self.gyro_arw();
        self.gyro_arw_rad_rs
            .iter()
            .zip(self.gyro_arw_is_upper_bound)
            .any(|(v, bound)| *v == m && bound)
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

/// A white level and whether it is only an upper bound (see [`white_level`]).
#[derive(Clone, Copy, Debug, PartialEq)]
struct WhiteLevel {
    density: f64,
    upper_bound: bool,
}

/// The white level `a` of `psd(f) ≈ a + b/f²` fitted by least squares over the bins in
/// `[from, to]` Hz (`b` is the red part: the flexure's rate); with no red part, the
/// band's mean. Where the band does not follow that shape or the red part fills it
/// (`a` under a tenth of the mean), the band's mean density, flagged as an upper bound.
fn white_level(freq_hz: &[f64], density: &[f64], from: f64, to: f64) -> WhiteLevel {
    let bound = |density| WhiteLevel {
        density,
        upper_bound: true,
    };
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
        return bound(if s11 > 0.0 { r1 / s11 } else { 0.0 });
    }
    let a = (r1 * s22 - r2 * s12) / det;
    let b = (s11 * r2 - s12 * r1) / det;
    let mean = r1 / s11;
    if a < 0.1 * mean {
        // A band that is not white plus red (vibration peaks on a vehicle send the fit
        // negative), or one the red part fills: the mean density, an upper bound.
        bound(mean)
    } else if b < 0.0 {
        // No red part: the band is white, its mean density the white level.
        WhiteLevel {
            density: mean,
            upper_bound: false,
        }
    } else {
        WhiteLevel {
            density: a,
            upper_bound: false,
        }
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
    let mut gyro_bound = [false; 3];
    let mut accel = [0.0; 3];
    for k in 0..3 {
        let g: Vec<f64> = imu.iter().map(|s| s.dtheta_rad[k]).collect();
        let (f, d) = rate_density(&g, dt);
        let w = white_level(&f, &d, from, to);
        gyro[k] = (w.density / 2.0).sqrt();
        gyro_bound[k] = w.upper_bound;
        let a: Vec<f64> = imu.iter().map(|s| s.dv_mps[k]).collect();
        let (f, d) = rate_density(&a, dt);
        accel[k] = (white_level(&f, &d, from, to).density / 2.0).sqrt();
    }
    Ok(IncrementNoise {
        gyro_arw_rad_rs: gyro,
        gyro_arw_is_upper_bound: gyro_bound,
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
        assert!((a.density - 3.0).abs() < 1e-9 && !a.upper_bound, "{a:?}");
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
        let w = white_level(&f, &d, 50.0, 90.0);
        assert!(!w.upper_bound);
        let n = (w.density / 2.0).sqrt();
        // 40 000 samples, ~60 bins × ~9 segments averaged: a few per cent.
        assert!((n / n_arw - 1.0).abs() < 0.05, "{n}");
    }

    #[test]
    fn bands_not_white_plus_red_give_only_an_upper_bound() {
        let f: Vec<f64> = (1..200).map(|k| k as f64).collect();
        // White floor 0.01 under a red part worth ~1 at 100 Hz: the floor is not read.
        let red: Vec<f64> = f.iter().map(|f| 0.01 + 1e4 / (f * f)).collect();
        let w = white_level(&f, &red, 50.0, 180.0);
        assert!(w.upper_bound, "{w:?}");
        // A resonance's skirt, falling as 1/f⁴ across the band: not white plus red.
        let skirt: Vec<f64> = f.iter().map(|f| 0.2 + 1e8 / f.powi(4)).collect();
        let w = white_level(&f, &skirt, 50.0, 180.0);
        assert!(w.upper_bound && w.density > 0.2, "{w:?}");
    }
}
