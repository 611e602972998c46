//! ADIS16470 driver against a mock SPI device (embedded-hal-mock): start-up, burst checks,
//! `DIAG_STAT` outcomes, data-counter tracking and scaling to SI.
//!
//! Expected numbers are computed by hand from the datasheet scale factors, not from the
//! driver's constants.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use embedded_hal::spi::{ErrorKind, ErrorType, Operation, SpiDevice};
use embedded_hal_mock::eh1::delay::{CheckedDelay, NoopDelay, Transaction as D};
use embedded_hal_mock::eh1::spi::{Mock, Transaction as T};
use flexcal_firmware::imu::adis16470::{
    Adis16470, AxisMap, BurstFormat, Config, DiagStat, Error, SignedAxis,
};
use flexcal_firmware::imu::ImuSource;

const PROD_ID: u8 = 0x72;
const DIAG_STAT: u8 = 0x02;
const GLOB_CMD: u8 = 0x68;
const DEC_RATE: u8 = 0x64;
const FILT_CTRL: u8 = 0x5C;
const MSC_CTRL: u8 = 0x60;
const FIRM_REV: u8 = 0x6C;
const SERIAL_NUM: u8 = 0x74;

const DEG: f64 = std::f64::consts::PI / 180.0;
const G0: f64 = 9.806_65;

// ---- mock transaction builders (the wire protocol, written out independently) ----

fn read_reg(addr: u8, value: u16) -> Vec<T<u8>> {
    vec![
        T::transaction_start(),
        T::write_vec(vec![addr, 0x00]),
        T::transaction_end(),
        T::transaction_start(),
        T::transfer_in_place(vec![0, 0], value.to_be_bytes().to_vec()),
        T::transaction_end(),
    ]
}

fn write_byte(addr: u8, value: u8) -> Vec<T<u8>> {
    vec![
        T::transaction_start(),
        T::write_vec(vec![0x80 | addr, value]),
        T::transaction_end(),
    ]
}

fn write_reg(addr: u8, value: u16) -> Vec<T<u8>> {
    let [hi, lo] = value.to_be_bytes();
    [write_byte(addr, lo), write_byte(addr + 1, hi)].concat()
}

/// A burst: `words` are the frame before the checksum; `checksum_delta` corrupts it.
fn burst(words: &[u16], checksum_delta: u16) -> Vec<T<u8>> {
    let mut frame: Vec<u8> = words.iter().flat_map(|w| w.to_be_bytes()).collect();
    let sum = frame
        .iter()
        .fold(0u16, |s, &b| s.wrapping_add(u16::from(b)))
        .wrapping_add(checksum_delta);
    frame.extend_from_slice(&sum.to_be_bytes());
    let mut tx = vec![0u8; frame.len() + 2];
    tx[0] = 0x68;
    let mut rx = vec![0u8, 0u8];
    rx.extend_from_slice(&frame);
    vec![
        T::transaction_start(),
        T::transfer_in_place(tx, rx),
        T::transaction_end(),
    ]
}

/// A 16-bit burst frame: DIAG_STAT, gyro xyz, accel xyz, TEMP_OUT, DATA_CNTR.
fn frame16(diag: u16, gyro: [i16; 3], accel: [i16; 3], temp: i16, cntr: u16) -> Vec<u16> {
    let mut w = vec![diag];
    w.extend(gyro.iter().map(|&v| v as u16));
    w.extend(accel.iter().map(|&v| v as u16));
    w.push(temp as u16);
    w.push(cntr);
    w
}

/// A 32-bit burst frame: DIAG_STAT, (LOW, OUT) for each delta angle and delta velocity,
/// TEMP_OUT, DATA_CNTR.
fn frame32(diag: u16, dtheta: [i32; 3], dv: [i32; 3], temp: i16, cntr: u16) -> Vec<u16> {
    let mut w = vec![diag];
    for v in dtheta.iter().chain(dv.iter()) {
        let u = *v as u32;
        w.push((u & 0xFFFF) as u16);
        w.push((u >> 16) as u16);
    }
    w.push(temp as u16);
    w.push(cntr);
    w
}

fn msc_for(burst: BurstFormat) -> u16 {
    match burst {
        BurstFormat::Deltas32 => 0x03C1,
        BurstFormat::Rates16 => 0x00C1,
    }
}

/// The whole start-up of a healthy device.
fn init_ok(config: &Config) -> Vec<T<u8>> {
    let msc = msc_for(config.burst);
    [
        read_reg(PROD_ID, 0x4056),
        write_byte(GLOB_CMD, 0x80),
        write_byte(GLOB_CMD, 0x04),
        read_reg(DIAG_STAT, 0x0000),
        write_reg(DEC_RATE, config.dec_rate),
        read_reg(DEC_RATE, config.dec_rate),
        write_reg(FILT_CTRL, u16::from(config.filter_size)),
        read_reg(FILT_CTRL, u16::from(config.filter_size)),
        write_reg(MSC_CTRL, msc),
        read_reg(MSC_CTRL, msc),
        read_reg(DIAG_STAT, 0x0000),
        read_reg(FIRM_REV, 0x0104),
        read_reg(SERIAL_NUM, 0x1234),
    ]
    .concat()
}

fn rates_config() -> Config {
    Config {
        burst: BurstFormat::Rates16,
        ..Config::default()
    }
}

/// An initialised driver whose mock expects `then` after start-up.
fn started(config: Config, then: Vec<T<u8>>) -> Adis16470<Mock<u8>, NoopDelay> {
    let spi = Mock::new(&[init_ok(&config), then].concat());
    let mut imu = Adis16470::new(spi, NoopDelay::new(), config);
    let info = imu.init().unwrap();
    assert_eq!(info.product_id, 0x4056);
    assert_eq!(info.firmware_revision, 0x0104);
    assert_eq!(info.serial_number, 0x1234);
    imu
}

fn finish(imu: Adis16470<Mock<u8>, NoopDelay>) {
    let (mut spi, _) = imu.release();
    spi.done();
}

fn close(a: f32, b: f64, rel: f64) {
    let a = f64::from(a);
    assert!(
        (a - b).abs() <= rel * b.abs().max(1e-30),
        "{a} vs {b} (rel {rel})"
    );
}

// ---- start-up ----

#[test]
fn init_configures_a_good_device() {
    for config in [Config::default(), rates_config()] {
        finish(started(config, vec![]));
    }
}

#[test]
fn wrong_product_id_stops_start_up() {
    let mut spi = Mock::new(&read_reg(PROD_ID, 0x4057));
    let mut imu = Adis16470::new(spi.clone(), NoopDelay::new(), Config::default());
    assert_eq!(imu.init(), Err(Error::BadProductId(0x4057)));
    // Nothing is written to a device that is not an ADIS16470, and it cannot be polled.
    assert_eq!(imu.poll().err(), Some(Error::NotInitialized));
    spi.done();
}

#[test]
fn self_test_failure_is_reported() {
    let tx = [
        read_reg(PROD_ID, 0x4056),
        write_byte(GLOB_CMD, 0x80),
        write_byte(GLOB_CMD, 0x04),
        read_reg(DIAG_STAT, 0x0020),
    ]
    .concat();
    let mut spi = Mock::new(&tx);
    let mut imu = Adis16470::new(spi.clone(), NoopDelay::new(), Config::default());
    assert_eq!(imu.init(), Err(Error::SelfTestFailed(DiagStat(0x0020))));
    spi.done();
}

#[test]
fn device_without_delta_burst_is_told_apart() {
    // MSC_CTRL reads back without BURST_SEL/BURST32: the firmware ignores them.
    let config = Config::default();
    let tx = [
        read_reg(PROD_ID, 0x4056),
        write_byte(GLOB_CMD, 0x80),
        write_byte(GLOB_CMD, 0x04),
        read_reg(DIAG_STAT, 0x0000),
        write_reg(DEC_RATE, config.dec_rate),
        read_reg(DEC_RATE, config.dec_rate),
        write_reg(FILT_CTRL, 0),
        read_reg(FILT_CTRL, 0),
        write_reg(MSC_CTRL, 0x03C1),
        read_reg(MSC_CTRL, 0x00C1),
    ]
    .concat();
    let mut spi = Mock::new(&tx);
    let mut imu = Adis16470::new(spi.clone(), NoopDelay::new(), config);
    assert_eq!(imu.init(), Err(Error::BurstFormatUnsupported));
    spi.done();
}

#[test]
fn config_read_back_mismatch_is_reported() {
    let config = rates_config();
    let tx = [
        read_reg(PROD_ID, 0x4056),
        write_byte(GLOB_CMD, 0x80),
        write_byte(GLOB_CMD, 0x04),
        read_reg(DIAG_STAT, 0x0000),
        write_reg(DEC_RATE, 4),
        read_reg(DEC_RATE, 0),
    ]
    .concat();
    let mut spi = Mock::new(&tx);
    let mut imu = Adis16470::new(spi.clone(), NoopDelay::new(), config);
    assert_eq!(
        imu.init(),
        Err(Error::ConfigMismatch {
            register: DEC_RATE,
            wrote: 4,
            read: 0
        })
    );
    spi.done();
}

#[test]
fn invalid_config_never_touches_the_bus() {
    let mut spi = Mock::new(&[]);
    let config = Config {
        dec_rate: 2000,
        ..Config::default()
    };
    let mut imu = Adis16470::new(spi.clone(), NoopDelay::new(), config);
    assert_eq!(imu.init(), Err(Error::InvalidConfig));
    spi.done();
}

/// The stall time between the two transfers of a register read goes through the delay.
#[test]
fn register_read_keeps_the_stall_time() {
    let mut spi = Mock::new(&read_reg(PROD_ID, 0x4056));
    let mut delay = CheckedDelay::new(&[D::blocking_delay_us(16), D::blocking_delay_us(16)]);
    let mut imu = Adis16470::new(spi.clone(), delay.clone(), Config::default());
    assert_eq!(imu.read_register(PROD_ID), Ok(0x4056));
    spi.done();
    delay.done();
}

// ---- SPI error ----

/// An SPI device whose every transfer fails.
struct BrokenSpi;

impl ErrorType for BrokenSpi {
    type Error = ErrorKind;
}

impl SpiDevice for BrokenSpi {
    fn transaction(&mut self, _: &mut [Operation<'_, u8>]) -> Result<(), ErrorKind> {
        Err(ErrorKind::ModeFault)
    }
}

#[test]
fn spi_error_is_passed_through() {
    let mut imu = Adis16470::new(BrokenSpi, NoopDelay::new(), Config::default());
    assert_eq!(imu.init(), Err(Error::Spi(ErrorKind::ModeFault)));
    assert_eq!(imu.read_sample(), Err(Error::Spi(ErrorKind::ModeFault)));
    assert_eq!(imu.poll().err(), Some(Error::NotInitialized));
}

// ---- scaling ----

#[test]
fn rates_burst_scaled_to_si() {
    // 0.1 °/s and 1.25 mg per LSB; 400 Hz output (DEC_RATE = 4): 2.5 ms per sample.
    let w = frame16(0, [100, -50, 20_000], [0, -400, 800], 250, 7);
    let mut imu = started(rates_config(), burst(&w, 0));
    let inc = imu.poll().unwrap().unwrap();
    let dt = 0.0025;
    assert_eq!(inc.t, 0.0);
    close(inc.dtheta_b.x, 10.0 * DEG * dt, 1e-6); // 100 LSB = 10 °/s
    close(inc.dtheta_b.y, -5.0 * DEG * dt, 1e-6); // -50 LSB = -5 °/s
    close(inc.dtheta_b.z, 2000.0 * DEG * dt, 1e-6); // full scale
    assert_eq!(inc.dv_b.x, 0.0);
    close(inc.dv_b.y, -0.5 * G0 * dt, 1e-6); // -400 LSB = -0.5 g
    close(inc.dv_b.z, 1.0 * G0 * dt, 1e-6); // 800 LSB = 1 g
    finish(imu);
}

#[test]
fn delta_burst_scaled_to_si() {
    // 32-bit deltas: 2160°/2^31 and 400 m/s / 2^31 per LSB.
    let w = frame32(
        0,
        [0x0001_0000, -0x0000_8000, 1],
        [0, 0x0002_8000, -0x7FFF_FFFF],
        -123,
        41,
    );
    let mut imu = started(Config::default(), [burst(&w, 0), burst(&w, 0)].concat());
    let s = imu.read_sample().unwrap();
    close(s.temperature_c, -12.3, 1e-6);
    let inc = imu.poll().unwrap().unwrap();
    let lsb_angle = 2160.0 * DEG / 2_147_483_648.0;
    let lsb_vel = 400.0 / 2_147_483_648.0;
    close(inc.dtheta_b.x, 65_536.0 * lsb_angle, 1e-6); // = 2160/32768 ° = 1.150 mrad
    close(inc.dtheta_b.x, 1.150_488e-3, 1e-5);
    close(inc.dtheta_b.y, -32_768.0 * lsb_angle, 1e-6);
    close(inc.dtheta_b.z, lsb_angle, 1e-6);
    assert_eq!(inc.dv_b.x, 0.0);
    close(inc.dv_b.y, 163_840.0 * lsb_vel, 1e-6); // 0.030 517 578 m/s
    close(inc.dv_b.y, 0.030_517_578, 1e-6);
    close(inc.dv_b.z, -400.0, 1e-6); // full scale
    finish(imu);
}

#[test]
fn axis_map_moves_sensor_axes_to_right_forward_up() {
    // Sensor mounted with +Y to the right, +X forward, -Z up (upside down, turned).
    let axes = AxisMap::new(SignedAxis::PosY, SignedAxis::PosX, SignedAxis::NegZ).unwrap();
    let config = Config {
        axes,
        ..rates_config()
    };
    let w = frame16(0, [10, 20, 30], [100, 200, 300], 0, 1);
    let mut imu = started(config, burst(&w, 0));
    let inc = imu.poll().unwrap().unwrap();
    let dt = 0.0025;
    close(inc.dtheta_b.x, 2.0 * DEG * dt, 1e-6); // sensor y: 20 LSB = 2 °/s
    close(inc.dtheta_b.y, 1.0 * DEG * dt, 1e-6); // sensor x
    close(inc.dtheta_b.z, -3.0 * DEG * dt, 1e-6); // -sensor z
    close(inc.dv_b.z, -300.0 * 1.25e-3 * G0 * dt, 1e-6);
    finish(imu);
}

#[test]
fn axis_map_refuses_a_reflection_or_repeated_axis() {
    assert!(AxisMap::new(SignedAxis::PosX, SignedAxis::PosY, SignedAxis::NegZ).is_none());
    assert!(AxisMap::new(SignedAxis::PosX, SignedAxis::PosX, SignedAxis::PosZ).is_none());
    assert_eq!(
        AxisMap::new(SignedAxis::PosX, SignedAxis::PosY, SignedAxis::PosZ),
        Some(AxisMap::IDENTITY)
    );
}

// ---- frame checks ----

#[test]
fn checksum_failure_drops_the_sample() {
    let good = frame16(0, [1, 2, 3], [4, 5, 6], 7, 100);
    let next = frame16(0, [1, 2, 3], [4, 5, 6], 7, 101);
    let mut imu = started(rates_config(), [burst(&good, 1), burst(&next, 0)].concat());
    match imu.poll() {
        Err(Error::Checksum { received, computed }) => assert_eq!(received, computed + 1),
        other => panic!("{other:?}"),
    }
    assert_eq!(imu.stats().checksum_errors, 1);
    // The dropped frame did not start the clock: the next good one is the first sample.
    let inc = imu.poll().unwrap().unwrap();
    assert_eq!(inc.t, 0.0);
    finish(imu);
}

#[test]
fn all_zero_frame_is_not_a_sample() {
    let mut imu = started(rates_config(), burst(&[0; 9], 0));
    assert_eq!(imu.poll().err(), Some(Error::BlankFrame));
    finish(imu);
}

/// Every `DIAG_STAT` bit in a burst has its defined outcome: bits 2 (flash update failure)
/// and 3 (SPI communication error) are warnings, the sample is used; every other bit
/// (1 overrun, 4 standby, 5 sensor failure, 6 memory failure, 7 clock error, reserved 0 and
/// 15:8) rejects the sample.
#[test]
fn each_diag_stat_bit_has_its_outcome() {
    for bit in 0..16u16 {
        let diag = 1u16 << bit;
        let w = frame16(diag, [1, 1, 1], [1, 1, 1], 0, 5);
        let mut imu = started(rates_config(), burst(&w, 0));
        let warn_only = bit == 2 || bit == 3;
        let got = imu.poll();
        if warn_only {
            assert!(matches!(got, Ok(Some(_))), "bit {bit}: {got:?}");
            assert_eq!(imu.stats().diag_warnings, 1, "bit {bit}");
        } else {
            assert_eq!(got.err(), Some(Error::Diag(DiagStat(diag))), "bit {bit}");
            assert_eq!(imu.stats().rejected, 1, "bit {bit}");
        }
        finish(imu);
    }
}

// ---- data counter ----

#[test]
fn repeated_data_counter_is_stale() {
    let w = frame16(0, [1, 2, 3], [4, 5, 6], 0, 9);
    let mut imu = started(rates_config(), [burst(&w, 0), burst(&w, 0)].concat());
    assert!(imu.poll().unwrap().is_some());
    assert_eq!(imu.poll().err(), Some(Error::StaleSample));
    assert_eq!(imu.stats().repeats, 1);
    finish(imu);
}

#[test]
fn repeats_within_the_stale_limit_mean_not_ready_yet() {
    let config = Config {
        stale_limit: 1,
        ..rates_config()
    };
    let a = frame16(0, [1, 2, 3], [4, 5, 6], 0, 9);
    let b = frame16(0, [1, 2, 3], [4, 5, 6], 0, 10);
    let tx = [
        burst(&a, 0),
        burst(&a, 0),
        burst(&b, 0),
        burst(&b, 0),
        burst(&b, 0),
    ]
    .concat();
    let mut imu = started(config, tx);
    assert!(imu.poll().unwrap().is_some());
    assert!(matches!(imu.poll(), Ok(None))); // first repeat: allowed
    let inc = imu.poll().unwrap().unwrap(); // new sample resets the run
    assert_eq!(inc.t, 0.0025);
    assert!(matches!(imu.poll(), Ok(None)));
    assert_eq!(imu.poll().err(), Some(Error::StaleSample)); // second in a row: too many
    finish(imu);
}

#[test]
fn skipped_sample_is_counted_and_bridged() {
    let a = frame16(0, [100, 0, 0], [0, 0, 800], 0, 10);
    let b = frame16(0, [100, 0, 0], [0, 0, 800], 0, 12); // sample 11 never read
    let mut imu = started(rates_config(), [burst(&a, 0), burst(&b, 0)].concat());
    let first = imu.poll().unwrap().unwrap();
    let second = imu.poll().unwrap().unwrap();
    assert_eq!(first.t, 0.0);
    assert_eq!(second.t, 2.0 * 0.0025);
    // The rate is held over the two periods.
    close(second.dtheta_b.x, 10.0 * DEG * 0.005, 1e-6);
    close(second.dv_b.z, G0 * 0.005, 1e-6);
    let stats = imu.stats();
    assert_eq!((stats.samples, stats.skipped), (2, 1));
    finish(imu);
}

#[test]
fn data_counter_wraps() {
    let a = frame16(0, [0; 3], [0, 0, 1], 0, 0xFFFF);
    let b = frame16(0, [0; 3], [0, 0, 1], 0, 0x0000);
    let mut imu = started(rates_config(), [burst(&a, 0), burst(&b, 0)].concat());
    imu.poll().unwrap().unwrap();
    let inc = imu.poll().unwrap().unwrap();
    assert_eq!(inc.t, 0.0025);
    assert_eq!(imu.stats().skipped, 0);
    finish(imu);
}
