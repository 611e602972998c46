//! The scalar type the engine is generic over: `f32` on the board, `f64` on the desktop.

use nalgebra::RealField;

/// A floating-point scalar the whole engine is written against (one source for f32 and f64).
pub trait Real: RealField + Copy + Default + core::fmt::Debug {
    /// Converts an `f64` constant or configuration value into this scalar (rounding for f32).
    fn of(x: f64) -> Self;
    /// Widens this scalar to `f64` (exact for both f32 and f64).
    fn to_f64(self) -> f64;
}

impl Real for f32 {
    #[inline]
    fn of(x: f64) -> Self {
        x as f32
    }
    #[inline]
    fn to_f64(self) -> f64 {
        f64::from(self)
    }
}

impl Real for f64 {
    #[inline]
    fn of(x: f64) -> Self {
        x
    }
    #[inline]
    fn to_f64(self) -> f64 {
        self
    }
}
