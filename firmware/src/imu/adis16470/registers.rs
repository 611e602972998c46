//! ADIS16470 register map, SPI command words, scale factors and timing (datasheet Rev. C).
//!
//! Only what the driver uses is named here. Every register is 16 bits wide and is addressed
//! by its lower byte (the upper byte is at `address + 1`).

/// Register addresses (lower byte).
pub mod addr {
    /// Status and error flags (`DIAG_STAT`).
    pub const DIAG_STAT: u8 = 0x02;
    /// New-sample counter (`DATA_CNTR`), incremented once per output sample, wraps at 0xFFFF.
    pub const DATA_CNTR: u8 = 0x22;
    /// Bartlett window filter size (`FILT_CTRL`, bits \[2:0\]).
    pub const FILT_CTRL: u8 = 0x5C;
    /// Miscellaneous control (`MSC_CTRL`): data-ready polarity, sync mode, compensation,
    /// burst content.
    pub const MSC_CTRL: u8 = 0x60;
    /// Decimation (`DEC_RATE`): output rate = 2000 SPS / (`DEC_RATE` + 1).
    pub const DEC_RATE: u8 = 0x64;
    /// Global commands (`GLOB_CMD`): self-test, software reset, ...
    pub const GLOB_CMD: u8 = 0x68;
    /// Firmware revision (`FIRM_REV`), BCD major.minor.
    pub const FIRM_REV: u8 = 0x6C;
    /// Product identification (`PROD_ID`).
    pub const PROD_ID: u8 = 0x72;
    /// Serial number (`SERIAL_NUM`).
    pub const SERIAL_NUM: u8 = 0x74;
}

/// `PROD_ID` of an ADIS16470 (16470 decimal).
pub const PRODUCT_ID: u16 = 0x4056;

/// First word of a burst read (DIN = 0x6800). The response starts one word later.
pub const BURST_COMMAND: [u8; 2] = [0x68, 0x00];

/// `GLOB_CMD` bit 2: sensor self-test; the result lands in `DIAG_STAT` bit 5.
pub const GLOB_CMD_SELF_TEST: u8 = 1 << 2;
/// `GLOB_CMD` bit 7: software reset.
pub const GLOB_CMD_SOFTWARE_RESET: u8 = 1 << 7;

/// `MSC_CTRL` bit 0: data-ready pin active high.
pub const MSC_DR_POLARITY_HIGH: u16 = 1 << 0;
/// `MSC_CTRL` bit 6: point-of-percussion alignment (accelerometers referred to one point).
pub const MSC_POINT_OF_PERCUSSION: u16 = 1 << 6;
/// `MSC_CTRL` bit 7: linear-g compensation of the gyroscopes.
pub const MSC_LINEAR_G_COMP: u16 = 1 << 7;
/// `MSC_CTRL` bit 8 (`BURST_SEL`): the burst carries delta angle/velocity instead of rates.
pub const MSC_BURST_SEL: u16 = 1 << 8;
/// `MSC_CTRL` bit 9 (`BURST32`): the burst carries 32-bit (LOW + OUT) inertial words.
pub const MSC_BURST32: u16 = 1 << 9;
/// Factory default `MSC_CTRL` (internal clock, compensations on, data ready active high).
pub const MSC_DEFAULT: u16 = MSC_LINEAR_G_COMP | MSC_POINT_OF_PERCUSSION | MSC_DR_POLARITY_HIGH;

/// Largest `DEC_RATE`.
pub const DEC_RATE_MAX: u16 = 1999;
/// Largest `FILT_CTRL` setting the driver accepts (Bartlett window size B = 0..=6).
pub const FILT_CTRL_MAX: u8 = 6;
/// Internal sample rate before decimation, samples per second.
pub const INTERNAL_RATE_HZ: f64 = 2000.0;

/// Scale factors to SI units.
pub mod scale {
    use core::f32::consts::PI;

    const DEG: f32 = PI / 180.0;
    /// Standard gravity used to express the accelerometer's `g` in m/s².
    pub const G0: f32 = 9.806_65;

    /// Gyroscope, 16-bit `x_GYRO_OUT`: 0.1 °/s per LSB, in rad/s per LSB.
    pub const GYRO_16: f32 = 0.1 * DEG;
    /// Gyroscope, 32-bit (`x_GYRO_OUT:x_GYRO_LOW`): 0.1/65536 °/s per LSB, in rad/s per LSB.
    pub const GYRO_32: f32 = GYRO_16 / 65_536.0;
    /// Accelerometer, 16-bit `x_ACCL_OUT`: 1.25 mg per LSB, in m/s² per LSB.
    pub const ACCEL_16: f32 = 1.25e-3 * G0;
    /// Accelerometer, 32-bit: 1.25/65536 mg per LSB, in m/s² per LSB.
    pub const ACCEL_32: f32 = ACCEL_16 / 65_536.0;
    /// Delta angle, 32-bit: ±2160° full scale, 2160°/2^31 per LSB, in rad per LSB.
    pub const DELTA_ANGLE_32: f32 = 2160.0 * DEG / 2_147_483_648.0;
    /// Delta velocity, 32-bit: ±400 m/s full scale, 400/2^31 m/s per LSB.
    pub const DELTA_VELOCITY_32: f32 = 400.0 / 2_147_483_648.0;
    /// Temperature `TEMP_OUT`: 0.1 °C per LSB, 0 LSB = 0 °C.
    pub const TEMPERATURE: f32 = 0.1;
}

/// Waits required by the device between and after SPI transfers.
///
/// The datasheet figures are minimums; these carry margin. A `DelayNs` given by the caller
/// provides them (the driver never busy-waits on its own).
pub mod timing {
    /// Stall time between two 16-bit transfers outside a burst (datasheet t_STALL = 16 µs).
    /// Also kept after every burst, so back-to-back polls never violate it.
    pub const STALL_US: u32 = 16;
    /// After a write to `DEC_RATE`, `FILT_CTRL` or `MSC_CTRL`, before the next access
    /// (the slowest of them, `MSC_CTRL`, needs about 200 µs).
    pub const CONFIG_UPDATE_US: u32 = 200;
    /// Power-on start-up and software-reset recovery time (datasheet: about 250 ms; ADI's
    /// own drivers wait up to 310 ms).
    pub const RESET_MS: u32 = 310;
    /// Sensor self-test duration (datasheet: about 14 ms; drivers wait 20–24 ms).
    pub const SELF_TEST_MS: u32 = 30;
}

/// `DIAG_STAT`, the device's status and error flags, with each bit's meaning.
///
/// Bits clear when the register is read (a burst read reads it). What the driver does with
/// each bit is [`DiagBit::outcome`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(all(target_arch = "arm", target_os = "none"), derive(defmt::Format))]
pub struct DiagStat(pub u16);

/// One flag of [`DiagStat`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(all(target_arch = "arm", target_os = "none"), derive(defmt::Format))]
pub enum DiagBit {
    /// Bit 1: a data path overran; the device needs a reset.
    DataPathOverrun,
    /// Bit 2: the last flash memory update failed (only after a flash update command).
    FlashUpdateFailure,
    /// Bit 3: an SPI transfer did not have a multiple of 16 SCLK cycles.
    SpiCommunicationError,
    /// Bit 4: supply below 2.8 V, data processing stopped.
    StandbyMode,
    /// Bit 5: an inertial sensor failed its self-test.
    SensorFailure,
    /// Bit 6: the flash memory test (calibration data CRC) failed.
    MemoryFailure,
    /// Bit 7: the sampling clock does not synchronize with the external clock (scaled sync).
    ClockError,
    /// Bit 0 or bits 15:8: not used by the device; set means the frame is suspect.
    Reserved,
}

/// What a [`DiagBit`] does to the sample that carries it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(all(target_arch = "arm", target_os = "none"), derive(defmt::Format))]
pub enum DiagOutcome {
    /// The sample is used; the flag is counted and logged.
    Warn,
    /// The sample is rejected with [`Error::Diag`](super::Error::Diag); the next good
    /// sample counts it as skipped. Persisting flags call for a re-`init`.
    Reject,
}

impl DiagBit {
    /// All named bits, in bit order (reserved last).
    pub const ALL: [DiagBit; 8] = [
        DiagBit::DataPathOverrun,
        DiagBit::FlashUpdateFailure,
        DiagBit::SpiCommunicationError,
        DiagBit::StandbyMode,
        DiagBit::SensorFailure,
        DiagBit::MemoryFailure,
        DiagBit::ClockError,
        DiagBit::Reserved,
    ];

    /// The bit's mask in `DIAG_STAT`.
    pub const fn mask(self) -> u16 {
        match self {
            DiagBit::DataPathOverrun => 1 << 1,
            DiagBit::FlashUpdateFailure => 1 << 2,
            DiagBit::SpiCommunicationError => 1 << 3,
            DiagBit::StandbyMode => 1 << 4,
            DiagBit::SensorFailure => 1 << 5,
            DiagBit::MemoryFailure => 1 << 6,
            DiagBit::ClockError => 1 << 7,
            DiagBit::Reserved => 0xFF01,
        }
    }

    /// The defined outcome of this flag on a sample.
    ///
    /// - `FlashUpdateFailure`: concerns a flash write the driver never issues; the inertial
    ///   data are unaffected → [`DiagOutcome::Warn`].
    /// - `SpiCommunicationError`: latched by an earlier malformed transfer; this frame passed
    ///   its checksum → [`DiagOutcome::Warn`] (the counter shows a bus problem).
    /// - `DataPathOverrun`, `StandbyMode`, `SensorFailure`, `MemoryFailure`, `ClockError`:
    ///   the inertial data or their timing cannot be trusted → [`DiagOutcome::Reject`].
    /// - `Reserved`: a bit the device never sets; with a valid checksum the frame is still
    ///   suspect → [`DiagOutcome::Reject`].
    pub const fn outcome(self) -> DiagOutcome {
        match self {
            DiagBit::FlashUpdateFailure | DiagBit::SpiCommunicationError => DiagOutcome::Warn,
            DiagBit::DataPathOverrun
            | DiagBit::StandbyMode
            | DiagBit::SensorFailure
            | DiagBit::MemoryFailure
            | DiagBit::ClockError
            | DiagBit::Reserved => DiagOutcome::Reject,
        }
    }
}

impl DiagStat {
    /// Whether `bit` is set.
    pub const fn has(self, bit: DiagBit) -> bool {
        self.0 & bit.mask() != 0
    }

    /// No flag set.
    pub const fn is_clear(self) -> bool {
        self.0 == 0
    }

    /// The combined outcome: `None` when clear, else the worst outcome of the set bits.
    pub fn outcome(self) -> Option<DiagOutcome> {
        let mut worst = None;
        for bit in DiagBit::ALL {
            if self.has(bit) {
                match bit.outcome() {
                    DiagOutcome::Reject => return Some(DiagOutcome::Reject),
                    DiagOutcome::Warn => worst = Some(DiagOutcome::Warn),
                }
            }
        }
        worst
    }
}
