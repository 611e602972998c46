//! IMU sources: where the slave's increments come from.
//!
//! On the board the source is the SPI sensor ([`adis16470::Adis16470`]); in QEMU, where
//! there is no sensor, the application replays increments received over the link. Both
//! implement [`ImuSource`], so everything after the source is the same code.

pub mod adis16470;

/// Where the slave's IMU increments come from: the SPI sensor, or replay over the link.
pub trait ImuSource {
    /// The source's error.
    type Error;
    /// The next IMU increment if one is ready (never blocks).
    fn poll(&mut self) -> Result<Option<flexcal_core::engine::ImuIncrement<f32>>, Self::Error>;
}
