//! Runtime of the board image: entry point, panic and fault handlers.
//!
//! Modes, chosen by the semihosting command line (QEMU `-semihosting-config ...,arg=<word>`):
//! - default: the start-up self-test, then exit (the CI smoke test);
//! - `mode=replay`: the self-test, then the application on USART1 (`replay.rs`): link frames
//!   in, estimates and status frames out, until the host's End message; then measurements
//!   (`key value` lines) on stdout and exit 0.
//!
//! Output channels (all through Arm semihosting, i.e. QEMU or an attached debug probe):
//! - defmt log frames go to the host's **stderr** (`logger`), binary, decoded with
//!   `defmt-print -e <elf>`;
//! - one plain-text result line goes to the host's **stdout** (`semihost::line`):
//!   `flexcal-firmware selftest ok`, or `... FAILED`, `... PANIC`, `... HARDFAULT`,
//!   `... UNEXPECTED IRQ`. The QEMU test reads this line; it needs no decoder, and the two
//!   streams never interleave.
//! - the end of the run is a semihosting exit: status 0 after a passed self-test, nonzero
//!   (QEMU exits with 1) after a failure, a panic, a HardFault or an unexpected interrupt.
//!   Nothing ends in an endless loop under QEMU.
//!
//! Semihosting needs a host: on a real board without a probe attached, the first
//! semihosting call faults. The later firmware work must put this channel behind a feature
//! (QEMU/CI) and use defmt-rtt on the bench.

use cortex_m_rt::{entry, exception, ExceptionFrame};

mod hw;
mod logger;
mod profile;
mod replay;
mod semihost;
mod serial;

#[entry]
fn main() -> ! {
    // First, before anything deepens the stack: the high-water mark is read at the end.
    hw::paint_stack();
    let syst = cortex_m::Peripherals::take().map(|p| p.SYST);
    defmt::info!("flexcal-firmware {=str} start", env!("CARGO_PKG_VERSION"));

    #[cfg(feature = "fault-injection")]
    semihost::inject_fault_from_cmdline();

    match flexcal_firmware::selftest::run::<f32>() {
        Ok(report) => {
            defmt::info!(
                "selftest ok: gravity equator {=f32}, pole {=f32}, 45 deg {=f32} m/s^2; low-pass {=f32}",
                report.gravity_equator,
                report.gravity_pole,
                report.gravity_45,
                report.low_pass
            );
            semihost::line("flexcal-firmware selftest ok");
            if semihost::has_arg(b"mode=replay") {
                replay::run(syst)
            }
            semihost::exit(true)
        }
        Err(e) => {
            defmt::error!("selftest failed: {}", e);
            semihost::line("flexcal-firmware selftest FAILED");
            semihost::exit(false)
        }
    }
}

/// Any panic ends the run with a failure exit.
///
/// The default image has no reachable panic path (`firmware/check-no-panic.sh` fails the
/// build if this handler is linked in); it is here for the `fault-injection` build and as
/// the required `#[panic_handler]`.
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    match info.location() {
        Some(loc) => defmt::error!(
            "panic at {=str}:{=u32}: {}",
            loc.file(),
            loc.line(),
            defmt::Display2Format(&info.message())
        ),
        None => defmt::error!("panic: {}", defmt::Display2Format(&info.message())),
    }
    semihost::line("flexcal-firmware PANIC");
    semihost::exit(false)
}

/// HardFault (and the faults escalated to it: UsageFault, BusFault and MemManage are not
/// enabled) ends the run with a failure exit.
#[allow(unsafe_code)] // the attribute requires the handler to be an `unsafe fn`
#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    defmt::error!(
        "HardFault: pc={=u32:#010x} lr={=u32:#010x} xpsr={=u32:#010x}",
        frame.pc(),
        frame.lr(),
        frame.xpsr()
    );
    semihost::line("flexcal-firmware HARDFAULT");
    semihost::exit(false)
}

/// An interrupt or exception without a handler ends the run with a failure exit (the
/// cortex-m-rt default would spin forever).
#[allow(unsafe_code)] // the attribute requires the handler to be an `unsafe fn`
#[exception]
unsafe fn DefaultHandler(irqn: i16) {
    defmt::error!("unexpected interrupt/exception, IRQn {=i16}", irqn);
    semihost::line("flexcal-firmware UNEXPECTED IRQ");
    semihost::exit(false)
}
