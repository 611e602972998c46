//! Rules on values that both the reader and the writer enforce, so that the
//! writer never produces a file the reader would refuse.

use super::error::ErrorKind;

/// Largest allowed deviation of a quaternion's norm from 1.
pub const QUATERNION_NORM_TOLERANCE: f64 = 1e-6;

/// Finite numbers only: recordings never hold NaN or infinities.
pub(crate) fn finite(value: f64) -> Result<f64, ErrorKind> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(ErrorKind::NonFinite {
            text: value.to_string(),
        })
    }
}

/// A nominal sampling rate: finite and positive.
pub(crate) fn rate(hz: f64) -> Result<f64, ErrorKind> {
    finite(hz)?;
    if hz > 0.0 {
        Ok(hz)
    } else {
        Err(ErrorKind::NonPositiveRate { value: hz })
    }
}

/// A geodetic latitude in degrees: finite and within [-90, 90].
pub(crate) fn latitude(deg: f64) -> Result<f64, ErrorKind> {
    finite(deg)?;
    if (-90.0..=90.0).contains(&deg) {
        Ok(deg)
    } else {
        Err(ErrorKind::OutOfRange {
            value: deg,
            min: -90.0,
            max: 90.0,
        })
    }
}

/// An attitude quaternion whose norm is 1 within [`QUATERNION_NORM_TOLERANCE`].
pub(crate) fn unit_quaternion(q: [f64; 4]) -> Result<(), ErrorKind> {
    let norm = q.iter().map(|c| c * c).sum::<f64>().sqrt();
    if (norm - 1.0).abs() <= QUATERNION_NORM_TOLERANCE {
        Ok(())
    } else {
        Err(ErrorKind::NonUnitQuaternion { norm })
    }
}

/// Checks that successive times strictly increase.
#[derive(Debug, Default)]
pub(crate) struct TimeOrder {
    prev: Option<f64>,
}

impl TimeOrder {
    /// Accepts `t` if it is later than the previous time seen.
    pub(crate) fn next(&mut self, t: f64) -> Result<(), ErrorKind> {
        if let Some(prev) = self.prev {
            if t <= prev {
                return Err(ErrorKind::TimeNotIncreasing { prev, t });
            }
        }
        self.prev = Some(t);
        Ok(())
    }
}
