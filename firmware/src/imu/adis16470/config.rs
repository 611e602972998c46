//! Driver configuration: output rate, filter, burst content and the mounting (axis map).

use nalgebra::Vector3;

use super::registers::{DEC_RATE_MAX, FILT_CTRL_MAX, INTERNAL_RATE_HZ};

/// What a burst read carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(all(target_arch = "arm", target_os = "none"), derive(defmt::Format))]
pub enum BurstFormat {
    /// 32-bit delta angle and delta velocity (`MSC_CTRL` `BURST_SEL` = 1, `BURST32` = 1):
    /// the device's own integrals over each output period, computed at the internal
    /// 2000 SPS before decimation, at a resolution of 2160°/2³¹ and 400 m/s / 2³¹ per LSB.
    /// The default: the engine integrates increments, and these lose nothing between two
    /// reads. `init` reads `MSC_CTRL` back and fails with
    /// [`Error::BurstFormatUnsupported`](super::Error::BurstFormatUnsupported) on a device
    /// (firmware) that ignores the two bits; fall back to [`BurstFormat::Rates16`] then.
    Deltas32,
    /// The 16-bit burst of rates and accelerations every ADIS16470 firmware has (0.1 °/s and
    /// 1.25 mg per LSB): each is multiplied by the nominal output period into an increment
    /// (rectangle rule). A fallback: the 16-bit delta burst is not offered at all, because its
    /// LSB (0.066°, 0.012 m/s) is far coarser than one period's increment and the lost
    /// fraction is not carried to the next sample.
    Rates16,
}

/// A sensor axis with a sign: where one slave body axis points in the sensor's frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(all(target_arch = "arm", target_os = "none"), derive(defmt::Format))]
pub enum SignedAxis {
    /// Sensor +X.
    PosX,
    /// Sensor −X.
    NegX,
    /// Sensor +Y.
    PosY,
    /// Sensor −Y.
    NegY,
    /// Sensor +Z.
    PosZ,
    /// Sensor −Z.
    NegZ,
}

impl SignedAxis {
    const fn unit(self) -> [i8; 3] {
        match self {
            SignedAxis::PosX => [1, 0, 0],
            SignedAxis::NegX => [-1, 0, 0],
            SignedAxis::PosY => [0, 1, 0],
            SignedAxis::NegY => [0, -1, 0],
            SignedAxis::PosZ => [0, 0, 1],
            SignedAxis::NegZ => [0, 0, -1],
        }
    }

    fn pick(self, v: &Vector3<f32>) -> f32 {
        match self {
            SignedAxis::PosX => v.x,
            SignedAxis::NegX => -v.x,
            SignedAxis::PosY => v.y,
            SignedAxis::NegY => -v.y,
            SignedAxis::PosZ => v.z,
            SignedAxis::NegZ => -v.z,
        }
    }
}

/// How the ADIS16470 is mounted: which sensor axis is each slave body axis
/// (right, forward, up).
///
/// The ADIS16470 axes are those of the datasheet's inertial sensor direction reference
/// figure (right-handed). The default [`AxisMap::IDENTITY`] assumes the sensor mounted with
/// its +X to the slave's right, +Y forward and +Z up. Check a mounting on the bench: at rest
/// and level, the up component of the specific force (`dv_b.z / dt`) reads about +9.8 m/s².
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(all(target_arch = "arm", target_os = "none"), derive(defmt::Format))]
pub struct AxisMap {
    right: SignedAxis,
    forward: SignedAxis,
    up: SignedAxis,
}

impl AxisMap {
    /// Sensor X right, Y forward, Z up.
    pub const IDENTITY: AxisMap = AxisMap {
        right: SignedAxis::PosX,
        forward: SignedAxis::PosY,
        up: SignedAxis::PosZ,
    };

    /// The map whose slave right, forward and up axes are the given sensor axes; `None`
    /// unless it is a proper rotation (distinct axes and `right × forward = up`).
    pub const fn new(right: SignedAxis, forward: SignedAxis, up: SignedAxis) -> Option<Self> {
        let [r0, r1, r2] = right.unit();
        let [f0, f1, f2] = forward.unit();
        let [u0, u1, u2] = up.unit();
        let (c0, c1, c2) = (r1 * f2 - r2 * f1, r2 * f0 - r0 * f2, r0 * f1 - r1 * f0);
        if c0 == u0 && c1 == u1 && c2 == u2 {
            Some(AxisMap { right, forward, up })
        } else {
            None
        }
    }

    /// A sensor-frame vector in the slave body frame (right, forward, up).
    pub fn to_body(&self, v: &Vector3<f32>) -> Vector3<f32> {
        Vector3::new(self.right.pick(v), self.forward.pick(v), self.up.pick(v))
    }
}

impl Default for AxisMap {
    fn default() -> Self {
        Self::IDENTITY
    }
}

/// Driver settings written at `init`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(all(target_arch = "arm", target_os = "none"), derive(defmt::Format))]
pub struct Config {
    /// `DEC_RATE`: output rate = 2000 SPS / (`dec_rate` + 1); 0..=1999. Default 4 (400 Hz).
    pub dec_rate: u16,
    /// `FILT_CTRL` Bartlett window size, 0..=6 (0 = off). Default 0: decimation already
    /// averages, and delta outputs need no smoothing.
    pub filter_size: u8,
    /// What the burst carries. Default [`BurstFormat::Deltas32`].
    pub burst: BurstFormat,
    /// Mounting: sensor axes → slave body axes. Default [`AxisMap::IDENTITY`].
    pub axes: AxisMap,
    /// How many consecutive polls may see the same `DATA_CNTR` (no new sample yet) before
    /// `poll` reports [`Error::StaleSample`](super::Error::StaleSample). 0 means every repeat
    /// is an error: use 0 when polling on the data-ready signal, and about
    /// `loop rate / output rate` (plus margin) when polling blindly. Default 0.
    pub stale_limit: u16,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            dec_rate: 4,
            filter_size: 0,
            burst: BurstFormat::Deltas32,
            axes: AxisMap::IDENTITY,
            stale_limit: 0,
        }
    }
}

impl Config {
    /// Whether every field is in the device's range.
    pub const fn is_valid(&self) -> bool {
        self.dec_rate <= DEC_RATE_MAX && self.filter_size <= FILT_CTRL_MAX
    }

    /// Nominal output period (s), from the internal 2000 SPS clock and `dec_rate`.
    ///
    /// The internal clock's tolerance is a scale error on the time stamps of
    /// `ImuSource::poll`; an external sync mode would remove it (not implemented).
    pub fn period_s(&self) -> f64 {
        (f64::from(self.dec_rate) + 1.0) / INTERNAL_RATE_HZ
    }
}
