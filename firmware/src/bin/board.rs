//! flexcal on the real board: STM32F405 with an ADIS16470 on SPI1, logs over defmt-RTT.
//!
//! Build (CI does, `.ci/run`; it need not run anywhere to be checked):
//!
//! ```text
//! cargo build -p flexcal-firmware --profile firmware --target thumbv7em-none-eabihf --features board --bin flexcal-board
//! ```
//!
//! and flash/read with a probe (`probe-rs run --chip STM32F405RGTx <elf>`).
//!
//! Wiring (SPI1, alternate function 5): PA5 SCK, PA6 MISO (ADIS DOUT), PA7 MOSI (ADIS DIN),
//! PA4 chip select (plain GPIO, driven by `ExclusiveDevice`). SPI mode 3 at 1 MHz, the
//! ADIS16470's burst-read limit.
//!
//! Clocks: the internal 16 MHz HSI through the PLL to 168 MHz, so no crystal is assumed;
//! with a crystal, use `rcc::Config::hse(...)`. The IMU's time stamps come from its own
//! sample clock, not from the MCU's.
//!
//! Driver errors are logged with `Debug2Format`: the bus error (`embedded-hal-bus`
//! `DeviceError` around the HAL's SPI error) has no `defmt::Format`.
//!
//! The loop is deliberately minimal (the application loop lives in the library): it polls
//! the IMU about every 500 µs, with no data-ready line, and logs once a second.
#![no_std]
#![no_main]
#![deny(unsafe_code)]

use cortex_m_rt::entry;
use defmt_rtt as _;
use embedded_hal::delay::DelayNs;
use embedded_hal_bus::spi::ExclusiveDevice;
use flexcal_firmware::imu::adis16470::{Adis16470, BurstFormat, Config, Error};
use flexcal_firmware::imu::ImuSource;
use stm32f4xx_hal::{
    pac,
    prelude::*,
    rcc,
    spi::{Mode, Phase, Polarity, Spi},
};

/// Loop period (µs): a few polls per 2.5 ms IMU output period.
const POLL_US: u32 = 500;
/// IMU output samples between two log lines (400 Hz → one per second).
const LOG_EVERY: u32 = 400;

#[entry]
fn main() -> ! {
    defmt::info!("flexcal-board {=str} start", env!("CARGO_PKG_VERSION"));
    let (Some(dp), Some(cp)) = (pac::Peripherals::take(), cortex_m::Peripherals::take()) else {
        halt("peripherals already taken")
    };

    let mut rcc = dp.RCC.freeze(rcc::Config::hsi().sysclk(168.MHz()));
    let gpioa = dp.GPIOA.split(&mut rcc);
    let mut cs = gpioa.pa4.into_push_pull_output();
    cs.set_high();
    let mode = Mode {
        polarity: Polarity::IdleHigh,
        phase: Phase::CaptureOnSecondTransition,
    };
    let spi = Spi::new(
        dp.SPI1,
        (Some(gpioa.pa5), Some(gpioa.pa6), Some(gpioa.pa7)),
        mode,
        1.MHz(),
        &mut rcc,
    );
    // Three clocks for three waits: SysTick for the `SpiDevice`'s own delay operations
    // (none are used; `ExclusiveDevice::new_no_delay` would add a panic path for them),
    // TIM5 (32-bit, 1 µs resolution) for the IMU's stall and start-up waits, TIM2 to pace
    // the loop.
    let Ok(device) = ExclusiveDevice::new(spi, cs, cp.SYST.delay(&rcc.clocks));
    let imu_delay = dp.TIM5.delay_us(&mut rcc);
    let mut loop_delay = dp.TIM2.delay_us(&mut rcc);

    let mut config = Config {
        // Blind polling: allow ~4 output periods without a new sample before StaleSample.
        stale_limit: 20,
        ..Config::default()
    };
    let mut imu = Adis16470::new(device, imu_delay, config);
    loop {
        match imu.init() {
            Ok(info) => {
                defmt::info!(
                    "ADIS16470 ok: firmware {=u16:#06x}, serial {=u16}, burst {}",
                    info.firmware_revision,
                    info.serial_number,
                    config.burst
                );
                break;
            }
            Err(Error::BurstFormatUnsupported) => {
                defmt::warn!("ADIS16470 has no 32-bit delta burst; using 16-bit rates");
                config.burst = BurstFormat::Rates16;
                imu.set_config(config);
            }
            Err(e) => {
                defmt::error!("ADIS16470 start-up failed: {}", defmt::Debug2Format(&e));
                loop_delay.delay_ms(1000);
            }
        }
    }

    let mut since_log = 0u32;
    loop {
        match imu.poll() {
            Ok(Some(inc)) => {
                since_log += 1;
                if since_log >= LOG_EVERY {
                    since_log = 0;
                    let s = imu.stats();
                    defmt::info!(
                        "t {=f64} s  dtheta [{=f32} {=f32} {=f32}] rad  dv [{=f32} {=f32} {=f32}] m/s  samples {=u32} skipped {=u32} rejected {=u32}",
                        inc.t,
                        inc.dtheta_b.x,
                        inc.dtheta_b.y,
                        inc.dtheta_b.z,
                        inc.dv_b.x,
                        inc.dv_b.y,
                        inc.dv_b.z,
                        s.samples,
                        s.skipped,
                        s.rejected
                    );
                }
            }
            Ok(None) => {}
            Err(Error::StaleSample) => {
                defmt::error!("ADIS16470 stopped producing samples; restarting it");
                if let Err(e) = imu.init() {
                    defmt::error!("ADIS16470 restart failed: {}", defmt::Debug2Format(&e));
                }
            }
            Err(e) => defmt::warn!("ADIS16470 sample dropped: {}", defmt::Debug2Format(&e)),
        }
        loop_delay.delay_us(POLL_US);
    }
}

/// Logs why and stops (waits for interrupts forever; a watchdog or the probe resets).
fn halt(why: &str) -> ! {
    defmt::error!("halt: {=str}", why);
    loop {
        cortex_m::asm::wfi();
    }
}

/// A panic logs its message and halts. (Nothing here is meant to panic: the workspace's
/// clippy lints forbid unwrap/expect/indexing.)
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    defmt::error!("panic: {}", defmt::Display2Format(&info.message()));
    loop {
        cortex_m::asm::wfi();
    }
}
