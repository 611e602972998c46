//! Driver for the Analog Devices ADIS16470 IMU over an embedded-hal 1.0 [`SpiDevice`].
//!
//! In the style of eldruin's drivers: generic over the bus, one [`Error`] generic over the
//! bus error, no chip-select handling of its own (that is the `SpiDevice`'s business), and
//! the waits the device needs between transfers go through a caller-given [`DelayNs`].
//!
//! # Bus
//! SPI mode 3 (CPOL = 1, CPHA = 1), MSB first, 8-bit words; SCLK ≤ 1 MHz, the burst-read
//! limit (registers alone allow 2 MHz). A register read is two transfers (command word,
//! then the answer, each with chip select toggled) separated by the stall time; a write
//! sends one byte per transfer. A burst read is one transfer: the command word 0x6800,
//! then the frame.
//!
//! # Data path
//! [`Adis16470::init`] checks `PROD_ID`, resets the device, runs the sensor self-test,
//! writes and reads back `DEC_RATE`, `FILT_CTRL` and `MSC_CTRL`, and clears `DIAG_STAT`.
//! Each [`ImuSource::poll`] then reads one burst, and rejects it on a wrong checksum, an
//! all-zero frame (nobody answering: its checksum would pass) or a rejecting `DIAG_STAT`
//! flag ([`DiagBit::outcome`]). `DATA_CNTR` tells a new sample from a repeated one and
//! counts the samples missed in between.
//!
//! # Increments
//! With [`BurstFormat::Deltas32`] (the default) the increments are the device's own delta
//! angle and delta velocity; with [`BurstFormat::Rates16`] they are rate × nominal period.
//! After `k` missed samples the increment of the one read sample is scaled by `k + 1`
//! (rates held over the gap, which the engine sees as a longer interval) and
//! [`Stats::skipped`] grows by `k`.
//!
//! # Time
//! `t` comes from the sensor's own clock: the number of output periods since the first
//! sample after `init` (unwrapped `DATA_CNTR`) × the nominal period
//! ([`Config::period_s`]); the first sample has `t = 0`. The application maps this time onto
//! its own clock if it needs to (one offset).

pub mod registers;

mod config;

use embedded_hal::{delay::DelayNs, spi::SpiDevice};
use flexcal_core::engine::ImuIncrement;
use nalgebra::Vector3;

pub use config::{AxisMap, BurstFormat, Config, SignedAxis};
pub use registers::{DiagBit, DiagOutcome, DiagStat, PRODUCT_ID};

use crate::imu::ImuSource;
use registers::{addr, scale, timing};

/// Everything that can go wrong talking to the ADIS16470.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(all(target_arch = "arm", target_os = "none"), derive(defmt::Format))]
#[non_exhaustive]
pub enum Error<E> {
    /// The SPI device failed.
    Spi(E),
    /// A burst frame's checksum did not match its bytes; the sample is dropped.
    Checksum {
        /// The checksum word the device sent.
        received: u16,
        /// The 16-bit sum of the frame's bytes.
        computed: u16,
    },
    /// A burst frame of all zero bytes: the device did not answer (unpowered, MISO stuck
    /// low). Such a frame would pass the checksum, so it is rejected on its own.
    BlankFrame,
    /// `DIAG_STAT` had a flag whose outcome is [`DiagOutcome::Reject`]; the sample is dropped.
    Diag(DiagStat),
    /// `DATA_CNTR` repeated more often in a row than [`Config::stale_limit`] allows: the
    /// device stopped producing samples, or it is polled without a data-ready signal and a
    /// limit of 0.
    StaleSample,
    /// The sensor self-test failed (`DIAG_STAT` as read after it).
    SelfTestFailed(DiagStat),
    /// `PROD_ID` was not 0x4056 (the value read is given): wrong part or no device.
    BadProductId(u16),
    /// A configuration register read back differently from what was written.
    ConfigMismatch {
        /// Register address.
        register: u8,
        /// Value written.
        wrote: u16,
        /// Value read back.
        read: u16,
    },
    /// [`BurstFormat::Deltas32`] was asked for but the device ignores `MSC_CTRL` bits 8–9;
    /// use [`BurstFormat::Rates16`].
    BurstFormatUnsupported,
    /// A [`Config`] field is out of range.
    InvalidConfig,
    /// `poll` before a successful `init`.
    NotInitialized,
}

/// Identification read at `init`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(all(target_arch = "arm", target_os = "none"), derive(defmt::Format))]
pub struct DeviceInfo {
    /// `PROD_ID` (0x4056).
    pub product_id: u16,
    /// `FIRM_REV`, BCD: 0x0104 is version 1.04.
    pub firmware_revision: u16,
    /// `SERIAL_NUM`.
    pub serial_number: u16,
}

/// Counters since `init` (saturating).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(all(target_arch = "arm", target_os = "none"), derive(defmt::Format))]
pub struct Stats {
    /// New samples delivered.
    pub samples: u32,
    /// Samples the data counter says were produced but never read.
    pub skipped: u32,
    /// Polls that saw a repeated data counter (no new sample).
    pub repeats: u32,
    /// Frames dropped for a wrong checksum.
    pub checksum_errors: u32,
    /// Frames dropped for a rejecting `DIAG_STAT` flag (or all zero).
    pub rejected: u32,
    /// Frames used despite a warning `DIAG_STAT` flag.
    pub diag_warnings: u32,
}

/// The inertial content of one burst, in sensor axes and SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Motion {
    /// From [`BurstFormat::Rates16`].
    Rates {
        /// Angular rate (rad/s).
        gyro: Vector3<f32>,
        /// Specific force (m/s²).
        accel: Vector3<f32>,
    },
    /// From [`BurstFormat::Deltas32`], over one output period.
    Deltas {
        /// Delta angle (rad).
        dtheta: Vector3<f32>,
        /// Delta velocity (m/s).
        dv: Vector3<f32>,
    },
}

/// One checked burst frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// `DIAG_STAT` as carried by the burst (only warning flags get this far).
    pub diag: DiagStat,
    /// `DATA_CNTR`.
    pub data_cntr: u16,
    /// Internal temperature (°C).
    pub temperature_c: f32,
    /// Rates or deltas, sensor axes.
    pub motion: Motion,
}

/// ADIS16470 on an SPI device `SPI`, waiting with `D`.
pub struct Adis16470<SPI, D> {
    spi: SPI,
    delay: D,
    config: Config,
    initialized: bool,
    last_cntr: Option<u16>,
    periods: u64,
    repeats_in_row: u16,
    stats: Stats,
}

/// Bytes of a 16-bit burst after the command word: 10 words.
const FRAME16: usize = 20;
/// Bytes of a 32-bit burst after the command word: 16 words.
const FRAME32: usize = 32;

impl<SPI, D, E> Adis16470<SPI, D>
where
    SPI: SpiDevice<u8, Error = E>,
    D: DelayNs,
{
    /// A driver that has not touched the bus yet; call [`Adis16470::init`] next.
    pub fn new(spi: SPI, delay: D, config: Config) -> Self {
        Adis16470 {
            spi,
            delay,
            config,
            initialized: false,
            last_cntr: None,
            periods: 0,
            repeats_in_row: 0,
            stats: Stats::default(),
        }
    }

    /// The configuration.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// Replaces the configuration; it takes effect at the next [`Adis16470::init`].
    pub fn set_config(&mut self, config: Config) {
        self.config = config;
        self.initialized = false;
    }

    /// Counters since `init`.
    pub fn stats(&self) -> Stats {
        self.stats
    }

    /// Gives the SPI device and the delay back.
    pub fn release(self) -> (SPI, D) {
        (self.spi, self.delay)
    }

    /// Start-up: waits the power-on time, checks `PROD_ID`, software reset, sensor
    /// self-test, configuration writes with read-back, clears `DIAG_STAT`, reads the
    /// identification. Resets the counters and the sample clock.
    pub fn init(&mut self) -> Result<DeviceInfo, Error<E>> {
        self.initialized = false;
        if !self.config.is_valid() {
            return Err(Error::InvalidConfig);
        }
        self.delay.delay_ms(timing::RESET_MS);
        let product_id = self.read_register(addr::PROD_ID)?;
        if product_id != PRODUCT_ID {
            return Err(Error::BadProductId(product_id));
        }
        self.write_byte(addr::GLOB_CMD, registers::GLOB_CMD_SOFTWARE_RESET)?;
        self.delay.delay_ms(timing::RESET_MS);
        self.self_test()?;

        self.write_checked(addr::DEC_RATE, self.config.dec_rate, 0x07FF)?;
        self.write_checked(addr::FILT_CTRL, u16::from(self.config.filter_size), 0x0007)?;
        let burst_bits = match self.config.burst {
            BurstFormat::Deltas32 => registers::MSC_BURST_SEL | registers::MSC_BURST32,
            BurstFormat::Rates16 => 0,
        };
        let msc = registers::MSC_DEFAULT | burst_bits;
        match self.write_checked(addr::MSC_CTRL, msc, 0x03FF) {
            Err(Error::ConfigMismatch { read, .. }) if read & burst_bits != burst_bits => {
                return Err(Error::BurstFormatUnsupported)
            }
            other => other?,
        }

        // Reading DIAG_STAT clears the flags latched during start-up.
        let diag = DiagStat(self.read_register(addr::DIAG_STAT)?);
        if diag.outcome() == Some(DiagOutcome::Reject) {
            return Err(Error::Diag(diag));
        }
        let firmware_revision = self.read_register(addr::FIRM_REV)?;
        let serial_number = self.read_register(addr::SERIAL_NUM)?;

        self.last_cntr = None;
        self.periods = 0;
        self.repeats_in_row = 0;
        self.stats = Stats::default();
        self.initialized = true;
        Ok(DeviceInfo {
            product_id,
            firmware_revision,
            serial_number,
        })
    }

    /// Sensor self-test (`GLOB_CMD` bit 2), then `DIAG_STAT`: bit 5 set is
    /// [`Error::SelfTestFailed`], another rejecting flag is [`Error::Diag`].
    pub fn self_test(&mut self) -> Result<(), Error<E>> {
        self.write_byte(addr::GLOB_CMD, registers::GLOB_CMD_SELF_TEST)?;
        self.delay.delay_ms(timing::SELF_TEST_MS);
        let diag = DiagStat(self.read_register(addr::DIAG_STAT)?);
        if diag.has(DiagBit::SensorFailure) {
            return Err(Error::SelfTestFailed(diag));
        }
        if diag.outcome() == Some(DiagOutcome::Reject) {
            return Err(Error::Diag(diag));
        }
        Ok(())
    }

    /// Reads a 16-bit register (`address` is its lower byte): the command word, a stall,
    /// the answer, a stall.
    pub fn read_register(&mut self, address: u8) -> Result<u16, Error<E>> {
        self.spi
            .write(&[address & 0x7F, 0x00])
            .map_err(Error::Spi)?;
        self.delay.delay_us(timing::STALL_US);
        let mut answer = [0u8; 2];
        self.spi
            .transfer_in_place(&mut answer)
            .map_err(Error::Spi)?;
        self.delay.delay_us(timing::STALL_US);
        Ok(u16::from_be_bytes(answer))
    }

    /// Writes a 16-bit register, lower byte first, one byte per transfer, each followed by
    /// a stall. Writing `GLOB_CMD` this way runs commands: prefer the driver's methods.
    pub fn write_register(&mut self, address: u8, value: u16) -> Result<(), Error<E>> {
        let [high, low] = value.to_be_bytes();
        self.write_byte(address, low)?;
        self.write_byte(address.wrapping_add(1), high)
    }

    fn write_byte(&mut self, address: u8, value: u8) -> Result<(), Error<E>> {
        self.spi
            .write(&[0x80 | (address & 0x7F), value])
            .map_err(Error::Spi)?;
        self.delay.delay_us(timing::STALL_US);
        Ok(())
    }

    /// Writes a configuration register, waits for it to take effect, reads it back.
    fn write_checked(&mut self, address: u8, value: u16, mask: u16) -> Result<(), Error<E>> {
        self.write_register(address, value)?;
        self.delay.delay_us(timing::CONFIG_UPDATE_US);
        let read = self.read_register(address)?;
        if read & mask == value & mask {
            Ok(())
        } else {
            Err(Error::ConfigMismatch {
                register: address,
                wrote: value,
                read,
            })
        }
    }

    /// Reads and checks one burst frame (checksum, all-zero frame, `DIAG_STAT`), scaled to
    /// SI in sensor axes. Does not track `DATA_CNTR`: that is [`ImuSource::poll`]'s job.
    pub fn read_sample(&mut self) -> Result<Sample, Error<E>> {
        match self.config.burst {
            BurstFormat::Rates16 => {
                let frame = self.burst::<{ FRAME16 + 2 }>()?;
                self.check_frame(&frame)?;
                let [diag, gx, gy, gz, ax, ay, az, temp, cntr, _sum] = be_words::<10>(&frame);
                let v16 = |x: u16, y: u16, z: u16, k: f32| {
                    Vector3::new(signed16(x), signed16(y), signed16(z)) * k
                };
                self.accept_diag(DiagStat(diag))?;
                Ok(Sample {
                    diag: DiagStat(diag),
                    data_cntr: cntr,
                    temperature_c: signed16(temp) * scale::TEMPERATURE,
                    motion: Motion::Rates {
                        gyro: v16(gx, gy, gz, scale::GYRO_16),
                        accel: v16(ax, ay, az, scale::ACCEL_16),
                    },
                })
            }
            BurstFormat::Deltas32 => {
                let frame = self.burst::<{ FRAME32 + 2 }>()?;
                self.check_frame(&frame)?;
                // The lower (LOW) word of each 32-bit value comes first, then the upper (OUT).
                let [diag, inertial @ .., temp, cntr, _sum] = be_words::<16>(&frame);
                let [gxl, gxh, gyl, gyh, gzl, gzh, axl, axh, ayl, ayh, azl, azh] = inertial;
                let v32 = |x: (u16, u16), y: (u16, u16), z: (u16, u16), k: f32| {
                    Vector3::new(signed32(x), signed32(y), signed32(z)) * k
                };
                self.accept_diag(DiagStat(diag))?;
                Ok(Sample {
                    diag: DiagStat(diag),
                    data_cntr: cntr,
                    temperature_c: signed16(temp) * scale::TEMPERATURE,
                    motion: Motion::Deltas {
                        dtheta: v32((gxh, gxl), (gyh, gyl), (gzh, gzl), scale::DELTA_ANGLE_32),
                        dv: v32((axh, axl), (ayh, ayl), (azh, azl), scale::DELTA_VELOCITY_32),
                    },
                })
            }
        }
    }

    /// One burst transfer of `N` bytes: the command word, then the frame.
    fn burst<const N: usize>(&mut self) -> Result<[u8; N], Error<E>> {
        let mut buf = [0u8; N];
        if let Some((command, _)) = buf.split_first_chunk_mut::<2>() {
            *command = registers::BURST_COMMAND;
        }
        self.spi.transfer_in_place(&mut buf).map_err(Error::Spi)?;
        self.delay.delay_us(timing::STALL_US);
        Ok(buf)
    }

    /// Rejects an all-zero frame and a wrong checksum. `buf` starts with the command word's
    /// two don't-care bytes; the checksum is the frame's last word and covers every byte
    /// before it.
    fn check_frame(&mut self, buf: &[u8]) -> Result<(), Error<E>> {
        let frame = buf.get(2..).unwrap_or_default();
        if frame.iter().all(|&b| b == 0) {
            self.stats.rejected = self.stats.rejected.saturating_add(1);
            return Err(Error::BlankFrame);
        }
        let data_len = frame.len().saturating_sub(2);
        let computed = frame
            .iter()
            .take(data_len)
            .fold(0u16, |s, &b| s.wrapping_add(u16::from(b)));
        let received = match frame.get(data_len..) {
            Some(&[hi, lo]) => u16::from_be_bytes([hi, lo]),
            _ => !computed,
        };
        if received != computed {
            self.stats.checksum_errors = self.stats.checksum_errors.saturating_add(1);
            return Err(Error::Checksum { received, computed });
        }
        Ok(())
    }

    fn accept_diag(&mut self, diag: DiagStat) -> Result<(), Error<E>> {
        match diag.outcome() {
            None => Ok(()),
            Some(DiagOutcome::Warn) => {
                self.stats.diag_warnings = self.stats.diag_warnings.saturating_add(1);
                warn!("ADIS16470 DIAG_STAT warning {=u16:#06x}", diag.0);
                Ok(())
            }
            Some(DiagOutcome::Reject) => {
                self.stats.rejected = self.stats.rejected.saturating_add(1);
                Err(Error::Diag(diag))
            }
        }
    }
}

impl<SPI, D, E> ImuSource for Adis16470<SPI, D>
where
    SPI: SpiDevice<u8, Error = E>,
    D: DelayNs,
{
    type Error = Error<E>;

    /// Reads one burst. `Ok(None)` when `DATA_CNTR` repeated and [`Config::stale_limit`]
    /// allows it (no new sample yet); [`Error::StaleSample`] beyond that. A frame that
    /// fails its checks is an error and leaves the counter tracking untouched, so the next
    /// good sample counts it as skipped.
    fn poll(&mut self) -> Result<Option<ImuIncrement<f32>>, Self::Error> {
        if !self.initialized {
            return Err(Error::NotInitialized);
        }
        let sample = self.read_sample()?;
        let periods = match self.last_cntr {
            None => 1,
            Some(last) => {
                let d = sample.data_cntr.wrapping_sub(last);
                if d == 0 {
                    self.stats.repeats = self.stats.repeats.saturating_add(1);
                    if self.repeats_in_row >= self.config.stale_limit {
                        return Err(Error::StaleSample);
                    }
                    self.repeats_in_row = self.repeats_in_row.saturating_add(1);
                    return Ok(None);
                }
                let skipped = d - 1;
                if skipped > 0 {
                    self.stats.skipped = self.stats.skipped.saturating_add(u32::from(skipped));
                    warn!("ADIS16470 skipped {=u16} sample(s)", skipped);
                }
                self.periods = self.periods.saturating_add(u64::from(d));
                d
            }
        };
        self.last_cntr = Some(sample.data_cntr);
        self.repeats_in_row = 0;
        self.stats.samples = self.stats.samples.saturating_add(1);

        let period = self.config.period_s();
        let n = f32::from(periods);
        let (dtheta, dv) = match sample.motion {
            Motion::Deltas { dtheta, dv } => (dtheta * n, dv * n),
            Motion::Rates { gyro, accel } => {
                let dt = (period * f64::from(periods)) as f32;
                (gyro * dt, accel * dt)
            }
        };
        Ok(Some(ImuIncrement {
            t: self.periods as f64 * period,
            dtheta_b: self.config.axes.to_body(&dtheta),
            dv_b: self.config.axes.to_body(&dv),
        }))
    }
}

/// The big-endian 16-bit words of a burst buffer, after its two command bytes.
fn be_words<const W: usize>(buf: &[u8]) -> [u16; W] {
    let mut out = [0u16; W];
    let frame = buf.get(2..).unwrap_or_default();
    for (word, pair) in out.iter_mut().zip(frame.chunks_exact(2)) {
        if let &[hi, lo] = pair {
            *word = u16::from_be_bytes([hi, lo]);
        }
    }
    out
}

/// A two's complement 16-bit word as `f32`.
fn signed16(w: u16) -> f32 {
    f32::from(i16::from_ne_bytes(w.to_ne_bytes()))
}

/// A two's complement 32-bit value from its (upper `OUT`, lower `LOW`) words as `f32`.
fn signed32((high, low): (u16, u16)) -> f32 {
    let raw = (u32::from(high) << 16) | u32::from(low);
    i32::from_ne_bytes(raw.to_ne_bytes()) as f32
}
