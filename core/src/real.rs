//! The scalar type the engine is generic over: `f32` on the board, `f64` on the desktop.
//!
//! Besides conversions, the trait carries the elementary functions the engine evaluates at
//! every master update (latitude trig, rotation angles, square roots). For `f64` they are
//! exactly the library's (`libm`/`std`), so the desktop's `f64` arithmetic and the
//! simulator's truth are what they were. For `f32` they are evaluated in `f32`
//! ([`trig32`]) and with the FPU's square root on the board ([`sqrt32`]): `libm`'s `sinf`,
//! `cosf` and `tanf` compute internally in `f64`, which the Cortex-M4F has no hardware for
//! (about 31k instructions per update in software, `docs/performance.md`).

mod sqrt32;
pub mod trig32;

use nalgebra::{ComplexField, RealField};

/// A floating-point scalar the whole engine is written against (one source for f32 and f64).
pub trait Real: RealField + Copy + Default + core::fmt::Debug {
    /// Below this angle (rad) `rotation::quat_exp` uses its longer Taylor series
    /// (`rotation::half_angle_series`) instead of sin and cos: 0 for `f64` (never: its
    /// arithmetic stays that of the closed form), 0.05 rad for `f32`.
    const QUAT_EXP_SERIES_BELOW: f64;
    /// Below this angle (rad) `rotation::right_jacobian` uses its longer Taylor series
    /// (`rotation::right_jacobian_series`): 0 for `f64`, 0.5 rad for `f32`, where the closed
    /// form `(1 − cos a)/a²` loses digits to cancellation anyway.
    const RIGHT_JACOBIAN_SERIES_BELOW: f64;
    /// Veltkamp's splitter `2^⌈p/2⌉ + 1` (`p` the significand's bits): `c x − (c x − x)`
    /// is `x`'s upper half, whose products are exact (the strapdown's error-free g·dt).
    const SPLITTER: f64;

    /// Converts an `f64` constant or configuration value into this scalar (rounding for f32).
    fn of(x: f64) -> Self;
    /// Widens this scalar to `f64` (exact for both f32 and f64).
    fn to_f64(self) -> f64;
    /// `(sin x, cos x)` of an angle in radians. `f64`: the library's `sin` and `cos`;
    /// `f32`: [`trig32::sin_cos`] (within 2 ulp of the exact value's rounding, tested).
    fn sin_cos_fast(self) -> (Self, Self);
    /// `tan x` from a known `(sin x, cos x)` of the same `x`. `f64`: the library's `tan`
    /// of `x` (its arithmetic unchanged); `f32`: `sin / cos` (one division).
    fn tan_from(self, sin: Self, cos: Self) -> Self;
    /// Square root, correctly rounded in both types. `f64`: the library's; `f32` on the
    /// board: the FPU's `vsqrt.f32` ([`sqrt32`]); `f32` elsewhere: the library's.
    fn sqrt_fast(self) -> Self;
}

impl Real for f32 {
    const QUAT_EXP_SERIES_BELOW: f64 = 0.05;
    const RIGHT_JACOBIAN_SERIES_BELOW: f64 = 0.5;
    const SPLITTER: f64 = 4097.0;

    #[inline]
    fn of(x: f64) -> Self {
        x as f32
    }
    #[inline]
    fn to_f64(self) -> f64 {
        f64::from(self)
    }
    #[inline]
    fn sin_cos_fast(self) -> (Self, Self) {
        trig32::sin_cos(self)
    }
    #[inline]
    fn tan_from(self, sin: Self, cos: Self) -> Self {
        sin / cos
    }
    #[inline]
    fn sqrt_fast(self) -> Self {
        sqrt32::sqrt(self)
    }
}

impl Real for f64 {
    const QUAT_EXP_SERIES_BELOW: f64 = 0.0;
    const RIGHT_JACOBIAN_SERIES_BELOW: f64 = 0.0;
    const SPLITTER: f64 = 134_217_729.0;

    #[inline]
    fn of(x: f64) -> Self {
        x
    }
    #[inline]
    fn to_f64(self) -> f64 {
        self
    }
    #[inline]
    fn sin_cos_fast(self) -> (Self, Self) {
        (ComplexField::sin(self), ComplexField::cos(self))
    }
    #[inline]
    fn tan_from(self, _sin: Self, _cos: Self) -> Self {
        ComplexField::tan(self)
    }
    #[inline]
    fn sqrt_fast(self) -> Self {
        ComplexField::sqrt(self)
    }
}
