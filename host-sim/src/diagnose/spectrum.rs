//! Spectra and autocorrelations of whitened innovations: where the structure left in
//! the residuals sits in frequency and in lag. A white sequence has a flat spectrum at
//! its variance and an autocorrelation inside ±1.96/√n beyond lag 0.

type Complex64 = nalgebra::Complex<f64>;

/// Shortest Welch segment (samples).
pub const MIN_SEGMENT: usize = 256;
/// Longest Welch segment (samples).
pub const MAX_SEGMENT: usize = 16384;

/// The Welch segment for `n` samples: the largest power of two up to `n / 2` (at least
/// three half-overlapping segments, so slow structure still has a few cycles' resolution),
/// within [`MIN_SEGMENT`, `MAX_SEGMENT`].
pub fn segment_len(n: usize) -> usize {
    let mut seg = MIN_SEGMENT;
    while seg * 2 <= n / 2 && seg * 2 <= MAX_SEGMENT {
        seg *= 2;
    }
    seg
}

/// In-place radix-2 FFT (length a power of two).
fn fft(x: &mut [Complex64]) {
    let n = x.len();
    if n <= 1 {
        return;
    }
    let mut j = 0;
    for i in 1..n {
        let mut bit = n >> 1;
        while j & bit != 0 {
            j ^= bit;
            bit >>= 1;
        }
        j |= bit;
        if i < j {
            x.swap(i, j);
        }
    }
    let mut len = 2;
    while len <= n {
        let w = Complex64::from_polar(1.0, -2.0 * std::f64::consts::PI / len as f64);
        for start in (0..n).step_by(len) {
            let mut wk = Complex64::new(1.0, 0.0);
            for k in 0..len / 2 {
                let a = x[start + k];
                let b = x[start + k + len / 2] * wk;
                x[start + k] = a + b;
                x[start + k + len / 2] = a - b;
                wk *= w;
            }
        }
        len <<= 1;
    }
}

/// A one-sided power spectral density estimate.
#[derive(Clone, Debug, Default)]
pub struct Psd {
    /// Frequencies (Hz).
    pub freq_hz: Vec<f64>,
    /// Density normalized to the white level: 1 everywhere for white noise of any variance
    /// equal to the mean square of the input (so a whitened innovation's PSD is ≈ 1).
    pub level: Vec<f64>,
}

impl Psd {
    /// The frequency (Hz) of the largest level above the lowest bin, and that level.
    pub fn peak(&self) -> Option<(f64, f64)> {
        self.freq_hz
            .iter()
            .zip(&self.level)
            .skip(1)
            .max_by(|a, b| a.1.total_cmp(b.1))
            .map(|(f, l)| (*f, *l))
    }
}

/// Welch estimate (Hann window, half overlap, segment [`segment_len`]) of the PSD of `x`
/// sampled at `rate_hz`, normalized so that white noise gives 1 (the density divided by
/// `2σ²/rate`, σ² the mean square of `x`). Empty when `x` is shorter than one segment.
pub fn welch(x: &[f64], rate_hz: f64) -> Psd {
    let n = segment_len(x.len());
    if x.len() < n || rate_hz <= 0.0 {
        return Psd::default();
    }
    let (window, w2) = hann(n);
    let mut acc = vec![0.0; n / 2 + 1];
    let mut segments = 0usize;
    let mut start = 0;
    while start + n <= x.len() {
        let buf = windowed_spectrum(&x[start..start + n], &window);
        for (a, c) in acc.iter_mut().zip(buf.iter()) {
            *a += c.norm_sqr();
        }
        segments += 1;
        start += n / 2;
    }
    let ms = x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64;
    // |X_k|² / Σw² is the periodogram in units of σ² per bin (mean σ² for white noise).
    let scale = 1.0 / (segments as f64 * w2 * ms.max(f64::MIN_POSITIVE));
    Psd {
        freq_hz: (0..=n / 2).map(|k| k as f64 * rate_hz / n as f64).collect(),
        level: acc.iter().map(|a| a * scale).collect(),
    }
}

/// The real part of the one-sided cross-spectral density matrix ((unit)²/Hz) of three
/// channels sampled at `rate_hz`, averaged over the bins in `[from, to]` Hz (Welch: Hann
/// window, half overlap, segment [`segment_len`], each segment's mean removed). Over a
/// band where the channels are white it is their covariance density: `2 Σ / rate` for
/// white noise of covariance `Σ`. `None` when the channels are shorter than one segment,
/// of unequal length, or the band holds no bin.
pub fn band_cross_density(
    x: [&[f64]; 3],
    rate_hz: f64,
    from: f64,
    to: f64,
) -> Option<nalgebra::Matrix3<f64>> {
    let len = x[0].len();
    let n = segment_len(len);
    if len < n || x.iter().any(|c| c.len() != len) || !(rate_hz.is_finite() && rate_hz > 0.0) {
        return None;
    }
    let bins: Vec<usize> = (1..n / 2)
        .filter(|&k| (from..=to).contains(&(k as f64 * rate_hz / n as f64)))
        .collect();
    if bins.is_empty() {
        return None;
    }
    let (window, w2) = hann(n);
    let mut acc = nalgebra::Matrix3::zeros();
    let mut segments = 0usize;
    let mut start = 0;
    while start + n <= len {
        let spectra = x.map(|c| windowed_spectrum(&c[start..start + n], &window));
        for &k in &bins {
            acc += nalgebra::Matrix3::from_fn(|i, j| (spectra[i][k] * spectra[j][k].conj()).re);
        }
        segments += 1;
        start += n / 2;
    }
    // One-sided density of a bin: 2 |X_k|² / (rate Σw²).
    Some(acc * (2.0 / (rate_hz * w2 * (segments * bins.len()) as f64)))
}

/// `x` (sampled at `rate_hz`) band-limited to `[from, to]` Hz: each Hann-windowed,
/// half-overlapping segment (length [`segment_len`], its mean removed) keeps only the
/// bins of the band, and the segments are added back (the windows sum to one). Only the
/// stretch every window covers twice is returned (the first and last half segment
/// dropped), where the filter is the same at every sample: a signal's ends do not ring
/// into the band as they would through one FFT of the whole record. `None` when `x` is
/// shorter than two segments.
pub fn band_limited(x: &[f64], rate_hz: f64, from: f64, to: f64) -> Option<Vec<f64>> {
    let n = segment_len(x.len());
    if x.len() < 2 * n || !(rate_hz.is_finite() && rate_hz > 0.0) {
        return None;
    }
    let (window, _) = hann(n);
    let in_band = |k: usize| {
        let f = k.min(n - k) as f64 * rate_hz / n as f64;
        k > 0 && (from..=to).contains(&f)
    };
    let mut out = vec![0.0; x.len()];
    let mut start = 0;
    while start + n <= x.len() {
        let mut buf = windowed_spectrum(&x[start..start + n], &window);
        for (k, c) in buf.iter_mut().enumerate() {
            if !in_band(k) {
                *c = Complex64::new(0.0, 0.0);
            }
        }
        // The inverse transform as the conjugate of the forward one of the conjugate.
        buf.iter_mut().for_each(|c| *c = c.conj());
        fft(&mut buf);
        for (o, c) in out[start..start + n].iter_mut().zip(&buf) {
            *o += c.re / n as f64;
        }
        start += n / 2;
    }
    Some(out[n / 2..start].to_vec())
}

/// The Hann window of `n` samples and the sum of its squares.
fn hann(n: usize) -> (Vec<f64>, f64) {
    let window: Vec<f64> = (0..n)
        .map(|i| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / n as f64).cos())
        .collect();
    let w2 = window.iter().map(|w| w * w).sum();
    (window, w2)
}

/// The FFT of one segment, its mean removed and the window applied.
fn windowed_spectrum(seg: &[f64], window: &[f64]) -> Vec<Complex64> {
    let mean = seg.iter().sum::<f64>() / seg.len() as f64;
    let mut buf: Vec<Complex64> = seg
        .iter()
        .zip(window)
        .map(|(v, w)| Complex64::new((v - mean) * w, 0.0))
        .collect();
    fft(&mut buf);
    buf
}

/// Sample autocorrelation of `x` at lags `0..=max_lag` (lag 0 is 1).
pub fn autocorrelation(x: &[f64], max_lag: usize) -> Vec<f64> {
    let n = x.len();
    if n < 2 {
        return Vec::new();
    }
    let mean = x.iter().sum::<f64>() / n as f64;
    let c0: f64 = x.iter().map(|v| (v - mean) * (v - mean)).sum();
    if c0 <= 0.0 {
        return Vec::new();
    }
    (0..=max_lag.min(n - 1))
        .map(|k| {
            x.iter()
                .zip(&x[k..])
                .map(|(a, b)| (a - mean) * (b - mean))
                .sum::<f64>()
                / c0
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_distr::StandardNormal;

    #[test]
    fn white_noise_is_flat_and_a_sine_peaks_at_its_frequency() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let white: Vec<f64> = (0..20_000).map(|_| rng.sample(StandardNormal)).collect();
        let p = welch(&white, 100.0);
        let mean = p.level.iter().skip(1).sum::<f64>() / (p.level.len() - 1) as f64;
        assert!((mean - 1.0).abs() < 0.05, "white level {mean}");
        let acf = autocorrelation(&white, 20);
        assert_eq!(acf[0], 1.0);
        assert!(acf[1..].iter().all(|r| r.abs() < 3.0 / (20_000f64).sqrt()));
        let sine: Vec<f64> = white
            .iter()
            .enumerate()
            .map(|(k, v)| v + 0.5 * (2.0 * std::f64::consts::PI * 2.5 * k as f64 / 100.0).sin())
            .collect();
        let (f, level) = welch(&sine, 100.0).peak().unwrap();
        assert!((f - 2.5).abs() < 0.1 && level > 20.0, "{f} {level}");
    }

    #[test]
    fn band_cross_density_of_white_channels_is_their_covariance_density() {
        // x, y = x + z, z: covariance [[1, 1, 0], [1, 2, 1], [0, 1, 1]] at 100 Hz.
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let mut normal = move || rng.sample::<f64, _>(StandardNormal);
        let (x, z): (Vec<f64>, Vec<f64>) = (0..100_000).map(|_| (normal(), normal())).unzip();
        let y: Vec<f64> = x.iter().zip(&z).map(|(a, b)| a + b).collect();
        let s = band_cross_density([&x, &y, &z], 100.0, 10.0, 40.0).unwrap();
        let want = nalgebra::Matrix3::new(1.0, 1.0, 0.0, 1.0, 2.0, 1.0, 0.0, 1.0, 1.0) * 0.02;
        assert!((s - want).abs().max() < 0.001, "{s}");
        // No bin in the band, unequal lengths, too short: none.
        assert!(band_cross_density([&x, &y, &z], 100.0, 60.0, 70.0).is_none());
        assert!(band_cross_density([&x, &y, &z[..10]], 100.0, 10.0, 40.0).is_none());
        assert!(band_cross_density([&x[..10], &y[..10], &z[..10]], 100.0, 10.0, 40.0).is_none());
    }

    #[test]
    fn band_limiting_keeps_a_tone_in_the_band_and_drops_one_outside() {
        let tone = |f: f64, k: usize| (2.0 * std::f64::consts::PI * f * k as f64 / 100.0).sin();
        let x: Vec<f64> = (0..40_000)
            .map(|k| 5.0 * tone(0.3, k) + tone(30.0, k))
            .collect();
        let b = band_limited(&x, 100.0, 25.0, 45.0).unwrap();
        // The middle of the record: the in-band tone, its mean square ½, the other gone.
        let ms = b.iter().map(|v| v * v).sum::<f64>() / b.len() as f64;
        assert!((ms - 0.5).abs() < 0.01, "{ms}");
        assert!(band_limited(&x[..100], 100.0, 25.0, 45.0).is_none());
    }

    #[test]
    fn fft_matches_a_direct_dft() {
        let x: Vec<Complex64> = (0..16)
            .map(|k| Complex64::new((k as f64 * 0.7).sin(), (k as f64 * 0.3).cos()))
            .collect();
        let mut y = x.clone();
        fft(&mut y);
        for (k, yk) in y.iter().enumerate() {
            let d: Complex64 = x
                .iter()
                .enumerate()
                .map(|(j, xj)| {
                    xj * Complex64::from_polar(
                        1.0,
                        -2.0 * std::f64::consts::PI * (j * k) as f64 / 16.0,
                    )
                })
                .sum();
            assert!((d - yk).norm() < 1e-12);
        }
    }
}
