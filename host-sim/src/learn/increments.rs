//! The slave IMU's white noise read from its own increments, before any filter runs:
//! the top of the increment spectrum, where the motion has no power left.
//!
//! A gyro's angle random walk N (rad/√s) is a white rate noise of one-sided density
//! `2 N²` ((rad/s)²/Hz). What else the slave gyro measures at high frequency is the
//! flexure's rate: far above its natural frequency a second-order Gauss-Markov angle's
//! rate moves as a random walk (density `q = 4ζω³σ²`), whose spectrum falls as `1/f²`,
//! and the ship's motion is far below. The increments read that rate as its *means*
//! over the IMU intervals, whose spectrum near the Nyquist frequency is not `1/f²`
//! ([`interval_mean_random_walk`]). So the rate spectrum over the top half of the band
//! is fitted as `a + b·x(f)`, `x` that shape (least squares on the Welch estimate), and
//! `N = √(a/2)`. The same fit on one accelerometer axis gives an *upper bound* of the
//! velocity random walk only: the flexure's angular acceleration acting on the lever arm
//! (`R θ̈`) is itself white in the slave's specific force, 40–6·10⁵ times the
//! accelerometer's noise on blind draws, so it cannot be told from that noise on one axis.
//! Nor can the slave's gyros remove it: they read the flexure's rate as interval means,
//! the accelerometer its changes between interval ends, and the two are coherent only
//! to `3(1 + cos x) / (2(2 + cos x))`, `x = 2πf·dt`: the part left is 30–5·10⁵ times the
//! noise over the band (`docs/model-learning.md`, session 21). What reads it is the
//! arm's own direction: a bending `R = −[r0]×/2` moves the slave across its arm, never
//! along it, so the accelerometers' band, white plus a part of rank two, has its least
//! eigenvector along the arm, and there the accelerometer's white density, once the
//! bending that the flexure angle and the vehicle's rate turn into that direction are
//! taken out ([`IncrementNoise::accel_vrw_mps_rs`]).

use crate::diagnose::spectrum::{band_cross_density, band_limited, welch};
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
    /// The velocity random walk (m/s/√s): the accelerometers' white density along the
    /// lever arm, where the flexure's bending puts nothing
    /// ([`along_arm_white_density`]). On 30 blind draws within 2.6 % of the draw
    /// (median 0.6 %), and within 11 % on ten draws with a VRW a tenth of the default
    /// under the largest flexures, where the per-axis floors were 6–2 000× the draw
    /// (`docs/model-learning.md`, session 21). An upper bound where the bending moves the
    /// slave along its arm too, or a vibration fills all three axes.
    pub accel_vrw_mps_rs: f64,
    /// Whether [`Self::accel_vrw_mps_rs`] is only an upper bound: the band along the arm
    /// is not white plus the red part, or nothing is left of it once the turned bending
    /// is taken out (the measured vehicle recording: its band falls 100-fold from 25 to
    /// 45 Hz).
    pub accel_vrw_is_upper_bound: bool,
    /// Lower edge of the fitted band (Hz).
    pub band_from_hz: f64,
    /// Upper edge of the fitted band (Hz).
    pub band_to_hz: f64,
}

impl IncrementNoise {
    /// The gyro angle random walk as one number (rad/√s): the median of the axes whose
    /// white level was read, when that is under every other axis's bound; else the
    /// median axis. The flexure's rate fills the band of the axes it moves most (blind
    /// draw 25: y and z only bounds, 17× and 11× the draw, x read within 3 %).
    pub fn gyro_arw(&self) -> f64 {
        self.read_axes()
            .unwrap_or_else(|| median3(self.gyro_arw_rad_rs))
    }

    /// The median of the read axes, if any and consistent with the bounds.
    fn read_axes(&self) -> Option<f64> {
        let pairs = self
            .gyro_arw_rad_rs
            .iter()
            .zip(self.gyro_arw_is_upper_bound);
        let mut read: Vec<f64> = pairs.clone().filter(|p| !p.1).map(|p| *p.0).collect();
        read.sort_by(f64::total_cmp);
        let m = match read.len() {
            0 => return None,
            2 => (read[0] + read[1]) / 2.0,
            n => read[n / 2],
        };
        pairs.filter(|p| p.1).all(|p| m <= *p.0).then_some(m)
    }

    /// Whether [`Self::gyro_arw`] is only an upper bound: no axis's white level was read
    /// (consistently) and the median axis's band was not white plus red.
    pub fn gyro_arw_is_upper_bound(&self) -> bool {
        if self.read_axes().is_some() {
            return false;
        }
        let m = median3(self.gyro_arw_rad_rs);
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

/// The shape of the one-sided density of a random walk's means over intervals of `dt`
/// (s), read every `dt`: `(2 + cos 2πf·dt) / (3 (sin(πf·dt)/(π·dt))²)`, which is `1/f²`
/// at low frequency (the density is `2q/(2π)²` times it, `q` the walk's density).
/// Successive means differ by an MA(1): variance `⅔ q dt`, lag-one covariance `⅙ q dt`.
/// Over the band the gyro's white floor is read from (`fs/4` to `0.45 fs`) it falls to
/// 0.69–0.82 of `1/f²`; fitted with `1/f²` instead, the flexure's rate is partly taken
/// for white noise: blind draw 25's x axis read its ARW 22 % low, 3 % with this shape
/// (`docs/model-learning.md`, session 14).
pub fn interval_mean_random_walk(dt: f64) -> impl Fn(f64) -> f64 {
    move |f: f64| {
        let u = std::f64::consts::PI * f * dt;
        let s = u.sin() / (std::f64::consts::PI * dt);
        (2.0 + (2.0 * u).cos()) / (3.0 * s * s)
    }
}

/// The white level `a` of `psd(f) ≈ a + b·red(f)` fitted by least squares over the bins
/// in `[from, to]` Hz (`b` is the red part: the flexure's rate); with no red part, the
/// band's mean. Where the band does not follow that shape or the red part fills it
/// (`a` under a tenth of the mean, and not resolved by the fit's own scatter), the
/// band's mean density, flagged as an upper bound. On the accelerometer too, where the
/// level read is itself only a bound of the velocity random walk (module doc).
fn white_level(
    freq_hz: &[f64],
    density: &[f64],
    from: f64,
    to: f64,
    red: impl Fn(f64) -> f64,
) -> WhiteLevel {
    let bound = |density| WhiteLevel {
        density,
        upper_bound: true,
    };
    // The band's bins and the red part's shape there.
    let bins: Vec<(f64, f64)> = freq_hz
        .iter()
        .zip(density)
        .filter(|(&f, _)| f >= from && f <= to && f > 0.0)
        .map(|(&f, &d)| (red(f), d))
        .filter(|(x, _)| x.is_finite())
        .collect();
    // Normal equations of the two-term model.
    let (mut s11, mut s12, mut s22, mut r1, mut r2) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for &(x, d) in &bins {
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
    // The standard error of `a` from the fit's own scatter (bins taken as independent).
    let rss: f64 = bins.iter().map(|&(x, d)| (d - a - b * x).powi(2)).sum();
    let se_a = (rss / (s11 - 2.0).max(1.0) * s22 / det).sqrt();
    if a < 0.1 * mean && !(a > 0.0 && se_a <= RESOLVED_WHITE_LEVEL * a) {
        // A band that is not white plus red (vibration peaks on a vehicle send the fit
        // negative), or one the red part fills so that its scatter hides the white
        // level: the mean density, an upper bound. A white level under a tenth of the
        // band that the fit resolves is read (under a flexing rate read as interval
        // means: `a_flexing_rate_read_as_interval_means_leaves_the_white_level`).
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

/// The largest standard error, relative to itself, of a white level under a tenth of
/// its band that is still read as the white level rather than a bound (of the density:
/// 10 % of the angle random walk).
const RESOLVED_WHITE_LEVEL: f64 = 0.2;

/// `1/f²`.
fn inverse_square(f: f64) -> f64 {
    1.0 / (f * f)
}

/// The accelerometers' white density ((m/s²)²/Hz) along the lever arm, from their
/// increments `dv` over `dt` (module doc). The direction is the least eigenvector of
/// the band's cross-spectral density; along it two things besides the noise are left,
/// each taken out: the bending turned into it by the flexure angle itself (white:
/// [`turning_leak`]) and the bending's rate turned by the vehicle's (`ω × R θ̇`, read as
/// interval means of a random walk: the red part of [`white_level`]). Where the band
/// along the arm is not white plus that red part (a vehicle's vibration, a sensor's
/// roll-off: [`white_level`]'s bound) or what is left is not positive, the least
/// eigenvalue, flagged as an upper bound. `None` when the recording is too short for two
/// segments or the band holds no bin.
fn along_arm_white_density(dv: [&[f64]; 3], dt: f64, from: f64, to: f64) -> Option<WhiteLevel> {
    let fs = 1.0 / dt;
    let s = band_cross_density(dv, fs, from, to)? / (dt * dt);
    let eigen = s.symmetric_eigen();
    let mut order = [0, 1, 2];
    order.sort_by(|&a, &b| eigen.eigenvalues[a].total_cmp(&eigen.eigenvalues[b]));
    let least = eigen.eigenvalues[order[0]];
    // The increments along the arm first, then across it.
    let projected = order.map(|k| {
        let e = eigen.eigenvectors.column(k);
        (0..dv[0].len())
            .map(|i| e[0] * dv[0][i] + e[1] * dv[1][i] + e[2] * dv[2][i])
            .collect::<Vec<f64>>()
    });
    let (f, d) = rate_density(&projected[0], dt);
    let along = white_level(&f, &d, from, to, interval_mean_random_walk(dt));
    let white = along.density - turning_leak(&projected, fs, from, to)? * least;
    Some(if along.upper_bound || white <= 0.0 {
        WhiteLevel {
            density: least,
            upper_bound: true,
        }
    } else {
        WhiteLevel {
            density: white,
            upper_bound: false,
        }
    })
}

/// The fraction of the band power along the arm (`z[0]`) that is the bending across it
/// (`z[1]`, `z[2]`) turned into it by the flexure angle. The flexure turns the arm's
/// direction by `θ⊥`, so along it lies `c(t)·u(t)`, `u` the bending's white part across
/// the arm, `c ∝ θ⊥` slow against the band; it is white itself and the band's white
/// level holds it. A product of a slow factor and a Gaussian `u` shows in the fourth
/// moments: with `p` the band-limited increments along the arm, `E[p² u_k²] −
/// E[p²] E[u_k²] = 2 E[c_k²] E[u_k²]²` (Isserlis; the noise along the arm independent of
/// `u`), and the part of `E[p²]` it makes is `Σ_k E[c_k²] E[u_k²]`. `None` when the
/// recording is too short for [`band_limited`] or a direction holds no power.
fn turning_leak(z: &[Vec<f64>; 3], fs: f64, from: f64, to: f64) -> Option<f64> {
    let [p, u1, u2] = [&z[0], &z[1], &z[2]].map(|c| band_limited(c, fs, from, to));
    let (p, u) = (p?, [u1?, u2?]);
    let mean = |v: &mut dyn Iterator<Item = f64>| {
        let (sum, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
        sum / n.max(1) as f64
    };
    let p2 = mean(&mut p.iter().map(|v| v * v));
    let mut leak = 0.0;
    for u in &u {
        let u2 = mean(&mut u.iter().map(|v| v * v));
        let p2u2 = mean(&mut p.iter().zip(u).map(|(a, b)| a * a * b * b));
        if !(u2.is_finite() && u2 > 0.0) {
            return None;
        }
        leak += (p2u2 - p2 * u2) / (2.0 * u2);
    }
    (p2 > 0.0).then(|| (leak / p2).clamp(0.0, 1.0))
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
    let dv: [Vec<f64>; 3] = [0, 1, 2].map(|k| imu.iter().map(|s| s.dv_mps[k]).collect());
    for k in 0..3 {
        let g: Vec<f64> = imu.iter().map(|s| s.dtheta_rad[k]).collect();
        let (f, d) = rate_density(&g, dt);
        let w = white_level(&f, &d, from, to, interval_mean_random_walk(dt));
        gyro[k] = (w.density / 2.0).sqrt();
        gyro_bound[k] = w.upper_bound;
        let (f, d) = rate_density(&dv[k], dt);
        // The accelerometer's band holds the flexure's angular acceleration at the lever
        // arm, white itself: its floor is a bound whatever the red part's shape.
        accel[k] = (white_level(&f, &d, from, to, inverse_square).density / 2.0).sqrt();
    }
    // Where the arm's direction cannot be read (no power across it, a record too short
    // to band-limit), the per-axis floors' median, a bound: the gyro's reading stands.
    let along =
        along_arm_white_density([&dv[0], &dv[1], &dv[2]], dt, from, to).unwrap_or(WhiteLevel {
            density: 2.0 * median3(accel).powi(2),
            upper_bound: true,
        });
    Ok(IncrementNoise {
        gyro_arw_rad_rs: gyro,
        gyro_arw_is_upper_bound: gyro_bound,
        accel_floor_mps_rs: accel,
        accel_vrw_mps_rs: (along.density.max(0.0) / 2.0).sqrt(),
        accel_vrw_is_upper_bound: along.upper_bound,
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
        let a = white_level(&f, &d, 50.0, 180.0, inverse_square);
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
        let w = white_level(&f, &d, 50.0, 90.0, inverse_square);
        assert!(!w.upper_bound);
        let n = (w.density / 2.0).sqrt();
        // 40 000 samples, ~60 bins × ~9 segments averaged: a few per cent.
        assert!((n / n_arw - 1.0).abs() < 0.05, "{n}");
    }

    /// Gyro increments of a white rate noise (ARW `n_arw`) plus a rate that moves as a
    /// random walk of density `q` over short times and returns to zero over 0.5 s (a
    /// flexure mode far above its frequency), integrated over each interval in ten
    /// sub-steps as the simulator does.
    fn flexing_gyro(n_arw: f64, q: f64, dt: f64, n: usize, seed: u64) -> Vec<f64> {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut normal = move || rng.sample::<f64, _>(rand_distr::StandardNormal);
        let h = dt / 10.0;
        let mut r = 0.0;
        (0..n)
            .map(|_| {
                let mut x = 0.0;
                for _ in 0..10 {
                    let next = r * (1.0 - h / 0.5) + (q * h).sqrt() * normal();
                    x += 0.5 * (r + next) * h;
                    r = next;
                }
                x + n_arw * dt.sqrt() * normal()
            })
            .collect()
    }

    #[test]
    fn a_flexing_rate_read_as_interval_means_leaves_the_white_level() {
        // Blind draw 25's x axis: ARW 1.86e-7 rad/√s, the mode's q ≈ 6e-8 rad²/s³, 400 Hz
        // (its red part 4.5× the white floor at 100 Hz).
        let (n_arw, q, dt) = (1.86e-7, 6e-8, 0.0025);
        let x = flexing_gyro(n_arw, q, dt, 200_000, 7);
        let (f, d) = rate_density(&x, dt);
        let (from, to) = (0.25 / dt, 0.45 / dt);
        let exact = white_level(&f, &d, from, to, interval_mean_random_walk(dt));
        let n = (exact.density / 2.0).sqrt();
        assert!(!exact.upper_bound && (n / n_arw - 1.0).abs() < 0.05, "{n}");
        // The 1/f² shape takes part of the red part for white noise, or all of it.
        let naive = white_level(&f, &d, from, to, inverse_square);
        let m = (naive.density / 2.0).sqrt();
        assert!(naive.upper_bound || (m / n_arw - 1.0).abs() > 0.1, "{m}");
        // A red part ten times larger: the white level is under a tenth of the band's
        // mean (7 %), and still read where the fit's scatter resolves it (its standard
        // error 15 % of it), within acceptance 2's 20 % for a noise density: +17 % here,
        // the bins of a Welch estimate are not independent and the scatter understates
        // the error.
        let x = flexing_gyro(n_arw, 10.0 * q, dt, 200_000, 8);
        let (f, d) = rate_density(&x, dt);
        let mean = {
            let band: Vec<f64> = f
                .iter()
                .zip(&d)
                .filter(|(&f, _)| f >= from && f <= to)
                .map(|(_, &d)| d)
                .collect();
            band.iter().sum::<f64>() / band.len() as f64
        };
        let w = white_level(&f, &d, from, to, interval_mean_random_walk(dt));
        let n = (w.density / 2.0).sqrt();
        assert!(2.0 * n_arw * n_arw < 0.1 * mean, "{mean}");
        assert!(!w.upper_bound && (n / n_arw - 1.0).abs() < 0.2, "{n}");
    }

    /// Accelerometer increments over `dt`: a white noise of VRW `vrw` on every axis, and a
    /// bending across the arm `r` (white, `across` times the noise's density on each of
    /// its axes) turned by a slow angle (`turn` rad, about x and y at 0.2 and 0.13 Hz), as
    /// the flexure angle turns its own bending.
    fn bent_accelerometers(vrw: f64, across: f64, turn: f64, n: usize) -> [Vec<f64>; 3] {
        use nalgebra::Vector3;
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let mut normal3 = move || Vector3::from_fn(|_, _| rng.sample(rand_distr::StandardNormal));
        let dt = 0.005f64;
        let arm = Vector3::new(1.0, 2.0, -2.0) / 3.0;
        let sigma = vrw * dt.sqrt();
        let samples: Vec<Vector3<f64>> = (0..n)
            .map(|i| {
                let t = i as f64 * dt;
                let bend = normal3().cross(&arm) * (sigma * across.sqrt());
                let angle = Vector3::new(
                    (2.0 * std::f64::consts::PI * 0.2 * t).sin(),
                    (2.0 * std::f64::consts::PI * 0.13 * t).cos(),
                    0.0,
                ) * turn;
                normal3() * sigma + bend + angle.cross(&bend)
            })
            .collect();
        [0, 1, 2].map(|k| samples.iter().map(|v| v[k]).collect())
    }

    #[test]
    fn the_white_density_along_the_arm_is_read_under_a_bending_across_it() {
        // A bending 10⁴ times the noise across the arm, turned by 15 mrad: along the arm
        // it leaves about twice the noise's own density.
        let (vrw, dt, n) = (1e-5, 0.005, 120_000);
        let dv = bent_accelerometers(vrw, 1e4, 0.015, n);
        let (from, to) = (50.0, 90.0);
        let w = along_arm_white_density([&dv[0], &dv[1], &dv[2]], dt, from, to).expect("a band");
        let read = (w.density / 2.0).sqrt();
        assert!(
            !w.upper_bound && (read / vrw - 1.0).abs() < 0.05,
            "read {read:e}"
        );
        // The least eigenvalue alone holds the turned bending; one axis holds the bending.
        let s = band_cross_density([&dv[0], &dv[1], &dv[2]], 1.0 / dt, from, to).unwrap();
        let least = (s.symmetric_eigenvalues().min() / (dt * dt) / 2.0).sqrt();
        assert!(least / vrw - 1.0 > 0.3, "least eigenvalue {least:e}");
        let (f, d) = rate_density(&dv[0], dt);
        let floor = (white_level(&f, &d, from, to, inverse_square).density / 2.0).sqrt();
        assert!(floor > 30.0 * vrw, "floor {floor:e}");
        // Unturned, the least eigenvalue is the noise, and so is the reading.
        let dv = bent_accelerometers(vrw, 1e4, 0.0, n);
        let w = along_arm_white_density([&dv[0], &dv[1], &dv[2]], dt, from, to).unwrap();
        let read = (w.density / 2.0).sqrt();
        assert!(
            !w.upper_bound && (read / vrw - 1.0).abs() < 0.05,
            "read unturned {read:e}"
        );
    }

    #[test]
    fn white_accelerometers_read_their_own_density() {
        // No bending at all: the least of three equal white densities.
        let (vrw, dt) = (3e-4, 0.005);
        let dv = bent_accelerometers(vrw, 0.0, 0.0, 60_000);
        let w = along_arm_white_density([&dv[0], &dv[1], &dv[2]], dt, 50.0, 90.0).unwrap();
        let read = (w.density / 2.0).sqrt();
        assert!(
            !w.upper_bound && (read / vrw - 1.0).abs() < 0.05,
            "read {read:e}"
        );
    }

    #[test]
    fn the_read_axes_give_the_random_walk_where_the_others_are_bounds() {
        let inc = |gyro_arw_rad_rs, gyro_arw_is_upper_bound| IncrementNoise {
            gyro_arw_rad_rs,
            gyro_arw_is_upper_bound,
            accel_floor_mps_rs: [0.0; 3],
            accel_vrw_mps_rs: 0.0,
            accel_vrw_is_upper_bound: true,
            band_from_hz: 100.0,
            band_to_hz: 180.0,
        };
        // Blind draw 25: x read, y and z bounds 17× and 11× above it.
        let i = inc([1.8e-7, 3.2e-6, 2.1e-6], [false, true, true]);
        assert_eq!(i.gyro_arw(), 1.8e-7);
        assert!(!i.gyro_arw_is_upper_bound());
        // Two read: their mean; all read: the median.
        let i = inc([1.8e-7, 2.2e-7, 2.1e-6], [false, false, true]);
        assert!((i.gyro_arw() - 2.0e-7).abs() < 1e-20);
        assert_eq!(inc([1.0, 3.0, 2.0], [false; 3]).gyro_arw(), 2.0);
        // A read value above another axis's bound is not trusted: the median, a bound.
        let i = inc([5e-6, 3.2e-6, 2.1e-6], [false, true, true]);
        assert_eq!(i.gyro_arw(), 3.2e-6);
        assert!(i.gyro_arw_is_upper_bound());
        // None read: the median axis, a bound.
        let i = inc([1e-6, 3e-6, 2e-6], [true; 3]);
        assert_eq!(i.gyro_arw(), 2e-6);
        assert!(i.gyro_arw_is_upper_bound());
    }

    #[test]
    fn interval_mean_shape_is_inverse_square_at_low_frequency() {
        let x = interval_mean_random_walk(0.0025);
        assert!((x(1.0) - 1.0).abs() < 1e-4, "{}", x(1.0));
        // At the Nyquist frequency (200 Hz): (2 − 1) / (3 (1/(π dt))²) = 1/3 of π² / 200².
        let nyq = std::f64::consts::PI.powi(2) / 3.0 * 0.0025 * 0.0025;
        assert!((x(200.0) / nyq - 1.0).abs() < 1e-9, "{}", x(200.0));
    }

    #[test]
    fn bands_not_white_plus_red_give_only_an_upper_bound() {
        let f: Vec<f64> = (1..200).map(|k| k as f64).collect();
        // White floor 0.01 under a red part worth ~1 at 100 Hz, each bin scattered by
        // ±5 % as a Welch estimate of ~400 segments is: the floor is not read.
        let red: Vec<f64> = f
            .iter()
            .map(|f| (0.01 + 1e4 / (f * f)) * (1.0 + 0.05 * (2.3 * f).sin()))
            .collect();
        let w = white_level(&f, &red, 50.0, 180.0, inverse_square);
        assert!(w.upper_bound, "{w:?}");
        // Without the scatter the fit resolves it exactly, and reads it.
        let clean: Vec<f64> = f.iter().map(|f| 0.01 + 1e4 / (f * f)).collect();
        let w = white_level(&f, &clean, 50.0, 180.0, inverse_square);
        assert!(!w.upper_bound && (w.density - 0.01).abs() < 1e-9, "{w:?}");
        // A resonance's skirt, falling as 1/f⁴ across the band: not white plus red.
        let skirt: Vec<f64> = f.iter().map(|f| 0.2 + 1e8 / f.powi(4)).collect();
        let w = white_level(&f, &skirt, 50.0, 180.0, inverse_square);
        assert!(w.upper_bound && w.density > 0.2, "{w:?}");
    }
}
