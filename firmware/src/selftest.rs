//! Start-up self-test: real arithmetic through [`flexcal_core::real::Real`], checked against
//! values known independently of this code.
//!
//! It proves on the target that the floating-point path the engine relies on (hardware f32
//! on the Cortex-M4F, the engine's own `sin`/`cos` and square root, `libm`'s other functions) gives
//! the right numbers, and it gives the QEMU test something real to wait for. The same
//! generic code runs in `f32` on the board and in `f32` and `f64` in the host tests.
//!
//! Three checks:
//! - the engine's own elementary functions (`Real::sqrt_fast`, the FPU's `vsqrt.f32` on the
//!   board, bit for bit equal to `libm`'s correctly rounded square root; `Real::sin_cos_fast`
//!   close to `libm`'s `f64` sine and cosine, rounded);
//! - WGS-84 normal gravity (Somigliana's closed formula) at the equator and at a pole,
//!   against the published defining values γe and γp;
//! - the step response of a first-order low-pass filter run recursively for `N` steps,
//!   against its closed form `1 - (1 - a)^N`.

use flexcal_core::real::Real;
use nalgebra::ComplexField;

/// WGS-84 normal gravity at the equator, m/s² (defining value).
pub const GAMMA_EQUATOR: f64 = 9.780_325_335_9;
/// WGS-84 normal gravity at the poles, m/s² (published value).
pub const GAMMA_POLE: f64 = 9.832_184_937_8;
/// Somigliana's constant `k = (b γp) / (a γe) - 1` for WGS-84.
const SOMIGLIANA_K: f64 = 0.001_931_852_652_41;
/// WGS-84 first eccentricity squared.
const ECC2: f64 = 0.006_694_379_990_13;

/// Gain of the low-pass filter in the step-response check.
const LOW_PASS_GAIN: f64 = 0.05;
/// Number of recursive steps in the step-response check.
const LOW_PASS_STEPS: u16 = 20;

/// Which self-test check failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(all(target_arch = "arm", target_os = "none"), derive(defmt::Format))]
#[non_exhaustive]
pub enum SelftestError {
    /// A computed value was NaN or infinite.
    NotFinite,
    /// Normal gravity disagrees with the published WGS-84 values.
    Gravity,
    /// The recursive low-pass filter disagrees with its closed form.
    LowPass,
    /// `Real::sqrt_fast` or `Real::sin_cos_fast` disagrees with the library's function.
    Elementary,
}

/// The values the self-test computed (all checked before this is returned).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SelftestReport<R> {
    /// Normal gravity at the equator, m/s².
    pub gravity_equator: R,
    /// Normal gravity at a pole, m/s².
    pub gravity_pole: R,
    /// Normal gravity at 45° latitude, m/s² (reported, not checked against a table).
    pub gravity_45: R,
    /// Output of the low-pass filter after `LOW_PASS_STEPS` steps of a unit step.
    pub low_pass: R,
}

/// WGS-84 normal gravity on the ellipsoid at geodetic latitude `lat` (radians), m/s²; the
/// sine is the engine's own (`Real::sin_cos_fast`).
///
/// Somigliana's formula `γ = γe (1 + k sin²φ) / sqrt(1 - e² sin²φ)`. Total for finite input:
/// the square root's argument is at least `1 - e² > 0`.
pub fn normal_gravity<R: Real>(lat: R) -> R {
    let s = lat.sin_cos_fast().0;
    let s2 = s * s;
    R::of(GAMMA_EQUATOR) * (R::one() + R::of(SOMIGLIANA_K) * s2)
        / (R::one() - R::of(ECC2) * s2).sqrt()
}

/// Unit-step response of `y += a (1 - y)` after `steps` steps from `y = 0`.
pub fn low_pass_step_response<R: Real>(gain: R, steps: u16) -> R {
    let mut y = R::zero();
    for _ in 0..steps {
        y += gain * (R::one() - y);
    }
    y
}

/// Arguments of the elementary-function check: zero, tiny, around one, large, angles.
const ELEMENTARY_ARGS: [f64; 8] = [0.0, 1e-30, 0.3, 0.5, 2.0, 3.0, 123.456, 1e10];

/// `true` if `Real::sqrt_fast` equals the library's square root bit for bit on
/// [`ELEMENTARY_ARGS`], and `Real::sin_cos_fast` is within `tol` of the library's `f64` sine
/// and cosine on those below 1000 rad (the range `sin_cos_fast` reduces itself; beyond it, it
/// is the library's). In `f64`, not `R`: the board links no `sinf`/`cosf` (3.7 kB of flash).
fn elementary_functions_agree<R: Real>(tol: R) -> bool {
    ELEMENTARY_ARGS.iter().all(|&x| {
        let x = R::of(x);
        let root_ok = x.sqrt_fast() == x.sqrt();
        let trig_ok = x >= R::of(1000.0) || {
            let (s, c) = x.sin_cos_fast();
            let xd = x.to_f64();
            let (sd, cd) = ComplexField::sin_cos(xd);
            close(s, R::of(sd), tol) && close(c, R::of(cd), tol)
        };
        root_ok && trig_ok
    })
}

/// `|a - b| <= tol * max(1, |b|)`, false for NaN.
fn close<R: Real>(a: R, b: R, tol: R) -> bool {
    (a - b).abs() <= tol * R::one().max(b.abs())
}

/// Runs the checks in precision `R`, logging each result through the `fmt` shim.
///
/// # Errors
/// The first check that fails, as a [`SelftestError`].
pub fn run<R: Real>() -> Result<SelftestReport<R>, SelftestError> {
    // A few ulps per operation: the formulas have fewer than 20 rounding steps each.
    let tol = R::default_epsilon() * R::of(64.0);
    // γp is published to 11 significant digits: in f64 the reference, not the arithmetic,
    // limits the agreement.
    let tol_gravity = tol.max(R::of(1e-10));

    let gravity_equator = normal_gravity(R::zero());
    let gravity_pole = normal_gravity(R::frac_pi_2());
    let gravity_45 = normal_gravity(R::frac_pi_4());
    debug!(
        "selftest: gravity equator {=f64}, pole {=f64}, 45 deg {=f64} m/s^2",
        gravity_equator.to_f64(),
        gravity_pole.to_f64(),
        gravity_45.to_f64()
    );

    let gain = R::of(LOW_PASS_GAIN);
    let low_pass = low_pass_step_response(gain, LOW_PASS_STEPS);
    let low_pass_expected = R::one() - (R::one() - gain).powi(i32::from(LOW_PASS_STEPS));
    debug!(
        "selftest: low-pass {=f64}, closed form {=f64}",
        low_pass.to_f64(),
        low_pass_expected.to_f64()
    );

    if !elementary_functions_agree(tol) {
        error!("selftest: elementary functions off");
        return Err(SelftestError::Elementary);
    }
    let values = [gravity_equator, gravity_pole, gravity_45, low_pass];
    if !values.iter().all(|v| v.is_finite()) {
        error!("selftest: non-finite value");
        return Err(SelftestError::NotFinite);
    }
    let ordered = gravity_equator < gravity_45 && gravity_45 < gravity_pole;
    if !ordered
        || !close(gravity_equator, R::of(GAMMA_EQUATOR), tol_gravity)
        || !close(gravity_pole, R::of(GAMMA_POLE), tol_gravity)
    {
        error!("selftest: normal gravity off");
        return Err(SelftestError::Gravity);
    }
    if !close(low_pass, low_pass_expected, tol) {
        error!("selftest: low-pass off");
        return Err(SelftestError::LowPass);
    }
    info!("selftest: all checks passed");
    Ok(SelftestReport {
        gravity_equator,
        gravity_pole,
        gravity_45,
        low_pass,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn passes_in_f32_and_f64() {
        let r32 = run::<f32>().unwrap();
        let r64 = run::<f64>().unwrap();
        assert!((f64::from(r32.gravity_45) - r64.gravity_45).abs() < 1e-5);
        assert!((f64::from(r32.low_pass) - r64.low_pass).abs() < 1e-6);
    }

    #[test]
    fn gravity_matches_the_published_values_in_f64() {
        let g_eq = normal_gravity(0.0_f64);
        let g_pole = normal_gravity(core::f64::consts::FRAC_PI_2);
        assert!((g_eq - GAMMA_EQUATOR).abs() < 1e-12);
        // γp is published to 10 digits; the formula reproduces it to that precision.
        assert!((g_pole - GAMMA_POLE).abs() < 1e-9);
        // Symmetric in latitude.
        assert_eq!(normal_gravity(0.3_f64), normal_gravity(-0.3_f64));
    }

    #[test]
    fn low_pass_matches_the_closed_form() {
        let y = low_pass_step_response(0.05_f64, 20);
        assert!((y - (1.0 - 0.95_f64.powi(20))).abs() < 1e-14);
        assert_eq!(low_pass_step_response(0.5_f64, 0), 0.0);
    }

    #[test]
    fn close_rejects_nan() {
        assert!(!close(f64::NAN, 1.0, 1.0));
        assert!(close(1.0_f32, 1.0 + 1e-7, 1e-6));
    }
}
