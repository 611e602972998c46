//! `sin` and `cos` evaluated in `f32`, for the board's latitude and rotation angles.
//!
//! `libm`'s `sinf`/`cosf`/`tanf` reduce and evaluate in `f64`, which the Cortex-M4F does in
//! software (hundreds of instructions a call). Here: Cody–Waite reduction by π/2 in `f32`
//! (π/2 split in three parts, the first two with 11 significant bits so that `k · part` is
//! exact for |k| < 2¹³), then Taylor polynomials on [−π/4, π/4] (sin to x⁹: truncation
//! below (π/4)¹¹/11! = 1.8·10⁻⁹; cos to x¹⁰: below (π/4)¹²/12! = 1.2·10⁻¹⁰, both far under
//! f32's half ulp), evaluated by Horner. Measured against `f64` (tests below): within
//! 2 ulp of the rounded exact value on |x| ≤ 1000. Beyond |x| = 1000 (never an angle of
//! this engine) and for non-finite input the library's `f64` `sin`/`cos` answer, rounded
//! to `f32`: the board links them anyway (normal gravity, the flexure's transition), where
//! `sinf`/`cosf` were 3.7 kB of flash for this fallback and the self-test alone.

/// First part of π/2 (11 significant bits).
const PIO2_HI: f32 = 1.570_312_5;
/// Second part of π/2 (11 significant bits).
const PIO2_MID: f32 = 4.837_513e-4;
/// Third part of π/2: `π/2 − PIO2_HI − PIO2_MID` rounded to f32.
const PIO2_LO: f32 = 7.549_79e-8;
/// Largest |x| reduced here (|k| ≤ 637 < 2¹³ keeps `k · PIO2_HI`, `k · PIO2_MID` exact).
const REDUCE_MAX: f32 = 1000.0;

/// `sin r` for |r| ≤ π/4 + a little (Taylor to r⁹).
#[inline]
fn sin_poly(r: f32) -> f32 {
    let r2 = r * r;
    let p = -1.0 / 6.0 + r2 * (1.0 / 120.0 + r2 * (-1.0 / 5_040.0 + r2 * (1.0 / 362_880.0)));
    r + r * r2 * p
}

/// `cos r` for |r| ≤ π/4 + a little (Taylor to r¹⁰).
#[inline]
fn cos_poly(r: f32) -> f32 {
    let r2 = r * r;
    let p = 1.0 / 24.0 + r2 * (-1.0 / 720.0 + r2 * (1.0 / 40_320.0 + r2 * (-1.0 / 3_628_800.0)));
    // 1 − r²/2 + r⁴ p, the large terms last.
    let half_r2 = 0.5 * r2;
    (1.0 - half_r2) + r2 * r2 * p
}

/// `(sin x, cos x)` of `x` (rad), in `f32`.
pub fn sin_cos(x: f32) -> (f32, f32) {
    // NaN compares false: it goes to the library too.
    let reducible = x.abs() <= REDUCE_MAX;
    if !reducible {
        let xd = f64::from(x);
        let (s, c) = libm::sincos(xd);
        return (s as f32, c as f32);
    }
    // Nearest multiple of π/2 (ties away from zero); `as` saturates, never panics.
    let kf = x * core::f32::consts::FRAC_2_PI;
    let k = (kf + 0.5_f32.copysign(kf)) as i32;
    let kr = k as f32;
    let r = ((x - kr * PIO2_HI) - kr * PIO2_MID) - kr * PIO2_LO;
    let (s, c) = (sin_poly(r), cos_poly(r));
    match k & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Distance in units in the last place between an f32 and the exact (f64) value's
    /// rounding to f32.
    fn ulps(got: f32, exact: f64) -> i64 {
        let want = exact as f32;
        let key = |v: f32| {
            let b = v.to_bits() as i32;
            i64::from(if b < 0 { i32::MIN - b } else { b })
        };
        (key(got) - key(want)).abs()
    }

    #[test]
    fn within_two_ulp_of_f64_over_the_reduced_range() {
        let mut worst = (0_i64, 0_i64);
        let n = 400_000;
        for i in 0..=n {
            // Dense over ±7 (latitudes, rotation angles), sparser out to ±1000.
            let t = i as f64 / n as f64 * 2.0 - 1.0;
            for x in [(t * 7.0) as f32, (t * 1000.0) as f32] {
                let (s, c) = sin_cos(x);
                let xe = f64::from(x);
                worst.0 = worst.0.max(ulps(s, xe.sin()));
                worst.1 = worst.1.max(ulps(c, xe.cos()));
            }
        }
        assert!(
            worst.0 <= 2 && worst.1 <= 2,
            "worst ulps (sin, cos): {worst:?}"
        );
    }

    #[test]
    fn small_angles_and_signs() {
        for x in [
            0.0_f32,
            1e-30,
            -1e-30,
            1e-8,
            -3e-5,
            0.01,
            core::f32::consts::FRAC_PI_4,
        ] {
            let (s, c) = sin_cos(x);
            let xe = f64::from(x);
            assert!(
                ulps(s, xe.sin()) <= 1 && ulps(c, xe.cos()) <= 1,
                "{x}: {s} {c}"
            );
        }
    }

    #[test]
    fn outside_the_range_the_library_answers() {
        let (s, c) = sin_cos(f32::NAN);
        assert!(s.is_nan() && c.is_nan());
        let (s, c) = sin_cos(f32::INFINITY);
        assert!(s.is_nan() && c.is_nan());
        let (s, c) = sin_cos(2.0e5);
        assert!(ulps(s, 2.0e5_f64.sin()) <= 1 && ulps(c, 2.0e5_f64.cos()) <= 1);
    }
}
