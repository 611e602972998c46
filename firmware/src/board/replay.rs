//! Replay mode (`mode=replay` on the semihosting command line): the application between a
//! byte transport and the engine.
//!
//! Transports (the same link frames, the same [`App`]):
//! - **USART1** (default): polled RX/TX on the STM32F405's USART1, which QEMU netduinoplus2
//!   connects to its first `-serial`. This is the board's link. At start the board sends one
//!   Status frame ("ready"): the host must not send before it, since bytes that reach a
//!   disabled USART are lost.
//! - **semihosting files** (`in=<path> out=<path>` on the command line): the host's files read
//!   and written in 4 KiB blocks through semihosting. QEMU's USART model takes one byte per
//!   main-loop turn (about 15 kB/s of wall time here), so long recordings replay through
//!   this bulk path in the tests; it exercises the same decoder, application and engine.
//!
//! The run ends when the host's End message has been handled (final Estimates and Status
//! sent): `key value` measurements on the semihosting stdout, exit status 0. Input that ends
//! without End is a failure (exit 1).
//!
//! Timing: SysTick counts the core clock (24 bits, wrapping; each interval measured here is
//! far shorter than a wrap). Under QEMU `-icount shift=0` every instruction advances virtual
//! time by 1 ns, so the counts are deterministic (conversion in `docs/firmware.md`).

use cortex_m::peripheral::{syst::SystClkSource, SYST};
use flexcal_core::probe::Phase;
use flexcal_firmware::app::App;

use super::hw;
use super::profile;
use super::semihost::{self, HostFile};
use super::serial::Serial;

const SYST_MASK: u32 = 0x00FF_FFFF;
/// Block size of the semihosting file transport. Its two blocks are on the stack for the
/// whole run, under the application's deepest frames: 512 B each (2 × 4 KiB before, 7 kB
/// of the declared model's RAM budget) costs one semihosting call per 512 bytes, a few
/// instructions per master update (`docs/performance.md`).
const BLOCK: usize = 512;

/// A byte transport.
trait Port {
    /// Received bytes into the front of `buf` (at most its length): how many (`Ok(0)`:
    /// none yet), `Err(())` if the input has ended.
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, ()>;
    /// Sends (or queues) bytes.
    fn send(&mut self, bytes: &[u8]);
    /// Sends what is queued.
    fn flush(&mut self);
    /// Receive overruns (bytes lost on the line).
    fn overruns(&self) -> u32;
}

impl Port for Serial {
    /// One byte at most: the polled USART holds one.
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, ()> {
        match (self.try_read(), buf.first_mut()) {
            (Some(b), Some(slot)) => {
                *slot = b;
                Ok(1)
            }
            _ => Ok(0),
        }
    }
    fn send(&mut self, bytes: &[u8]) {
        self.write_all(bytes);
    }
    fn flush(&mut self) {}
    fn overruns(&self) -> u32 {
        Serial::overruns(self)
    }
}

struct Files {
    input: HostFile,
    output: HostFile,
    tx: [u8; BLOCK],
    tx_len: usize,
}

impl Port for Files {
    /// A block of the input file (its end: `Err`).
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, ()> {
        match self.input.read(buf) {
            0 => Err(()),
            n => Ok(n),
        }
    }
    fn send(&mut self, bytes: &[u8]) {
        if self.tx_len + bytes.len() > BLOCK {
            self.flush();
        }
        match self.tx.get_mut(self.tx_len..self.tx_len + bytes.len()) {
            Some(dst) => {
                dst.copy_from_slice(bytes);
                self.tx_len += bytes.len();
            }
            None => self.output.write_all(bytes),
        }
    }
    fn flush(&mut self) {
        self.output
            .write_all(self.tx.get(..self.tx_len).unwrap_or(&[]));
        self.tx_len = 0;
    }
    fn overruns(&self) -> u32 {
        0
    }
}

/// Runs the replay until the host's End message; never returns.
pub fn run(syst: Option<SYST>) -> ! {
    // Served in place (`as_mut`): moving the transport out of the `Option` copied it.
    let mut files = open_files();
    match files.as_mut() {
        Some(f) => {
            defmt::info!("replay: link frames from semihosting files");
            serve(f, syst)
        }
        None => {
            defmt::info!("replay: link frames on USART1");
            serve(&mut Serial::init(), syst)
        }
    }
}

/// The semihosting file transport if the command line names `in=` and `out=` (exits on a
/// file that cannot be opened), else `None` (USART1). Not inlined: its 512 B of path
/// buffers are gone before [`serve`] runs, instead of staying in [`run`]'s frame under it.
#[inline(never)]
fn open_files() -> Option<Files> {
    let mut in_path = [0_u8; 256];
    let mut out_path = [0_u8; 256];
    match (
        semihost::arg_value(b"in=", &mut in_path),
        semihost::arg_value(b"out=", &mut out_path),
    ) {
        (Some(i), Some(o)) => {
            let input = in_path.get(..i).and_then(|p| HostFile::open(p, false));
            let output = out_path.get(..o).and_then(|p| HostFile::open(p, true));
            match (input, output) {
                (Some(input), Some(output)) => Some(Files {
                    input,
                    output,
                    tx: [0; BLOCK],
                    tx_len: 0,
                }),
                _ => {
                    semihost::line("flexcal-firmware replay FAILED (cannot open in=/out= files)");
                    semihost::exit(false)
                }
            }
        }
        _ => None,
    }
}

fn serve<P: Port>(port: &mut P, syst: Option<SYST>) -> ! {
    let mut syst = syst;
    // Profiling takes SysTick for its interrupt: the per-byte timing below is then not kept.
    let profiling = semihost::has_arg(b"profile");
    if let Some(s) = syst.as_mut() {
        if profiling {
            profile::start(s);
        } else {
            s.set_clock_source(SystClkSource::Core);
            s.set_reload(SYST_MASK);
            s.clear_current();
            s.enable_counter();
        }
    }
    let mut app = App::new();
    // "Ready": the host waits for this frame before it sends.
    app.send_status_now(&mut |frame: &[u8]| port.send(frame));
    port.flush();
    let mut bytes: u64 = 0;
    let mut busy_ticks: u64 = 0;
    let mut max_ticks: u32 = 0;
    // What the transport delivers at once (a block of the file; a byte of the USART) goes
    // to the application as one run, timed as one.
    let mut rx = [0_u8; BLOCK];
    loop {
        let got = match port.read(&mut rx) {
            Ok(0) => continue,
            Ok(n) => rx.get(..n).unwrap_or(&[]),
            Err(()) => {
                port.flush();
                semihost::line("flexcal-firmware replay FAILED (input ended without End)");
                semihost::exit(false)
            }
        };
        let t0 = SYST::get_current();
        let taken = app.push_bytes_until_end(got, &mut |frame: &[u8]| port.send(frame));
        let dt = t0.wrapping_sub(SYST::get_current()) & SYST_MASK;
        busy_ticks += u64::from(dt);
        max_ticks = max_ticks.max(dt);
        bytes += taken as u64;
        if app.ended() {
            break;
        }
    }
    port.flush();
    report(
        &app,
        port.overruns(),
        bytes,
        busy_ticks,
        max_ticks,
        profiling,
    )
}

/// The run's figures on the semihosting stdout and the log, then exit 0. Not generic over
/// the transport: one copy in the image, not one per transport (1.9 kB of flash each).
#[inline(never)]
fn report(
    app: &App,
    overruns: u32,
    bytes: u64,
    busy_ticks: u64,
    max_ticks: u32,
    profiling: bool,
) -> ! {
    let c = app.counters();
    let link = app.link_counters();
    for (axis, fit) in app.flexure_fit().iter().enumerate() {
        if let Some(f) = fit {
            let [a1, a2] = f.coefficients;
            defmt::info!(
                "flexure axis {=usize}: AR({=usize}) a1 {=f32} a2 {=f32} sigma {=f32} rad ({=usize} residuals)",
                axis,
                f.order,
                a1,
                a2,
                f.sigma_rad,
                f.residuals
            );
        }
    }
    defmt::info!(
        "replay end: {=u32} master updates, {=u32} estimates, {=u32} effects, {=u32} status, {=u32} frames, {=u32} refused",
        c.master_updates,
        c.estimates_sent,
        c.effects_sent,
        c.status_sent,
        link.decoder.frames,
        link.decoder.errors()
    );
    if c.config_too_large != 0 {
        defmt::warn!(
            "{=u32} config(s) refused: layout larger than the board's {=usize} states",
            c.config_too_large,
            flexcal_firmware::app::FIRMWARE_MAX_STATES
        );
    }
    semihost::line("flexcal-firmware replay ok");
    semihost::line_kv("bytes", bytes);
    semihost::line_kv("frames", u64::from(link.decoder.frames));
    semihost::line_kv("frame-errors", u64::from(link.decoder.errors()));
    semihost::line_kv("master-updates", u64::from(c.master_updates));
    semihost::line_kv("imu-refused", u64::from(c.imu_refused));
    semihost::line_kv("master-refused", u64::from(c.master_refused));
    semihost::line_kv("config-refused", u64::from(c.config_refused));
    semihost::line_kv("config-too-large", u64::from(c.config_too_large));
    // State dimension of the engine that ran (21: declared model; 33: a layout with effects).
    semihost::line_kv(
        "engine-states",
        app.engine().map_or(0, |e| e.dimension() as u64),
    );
    semihost::line_kv("effects-sent", u64::from(c.effects_sent));
    semihost::line_kv("no-engine", u64::from(c.no_engine));
    semihost::line_kv("uart-overruns", u64::from(overruns));
    for fit in app.flexure_fit() {
        semihost::line_kv("flexure-ar-order", fit.map_or(99, |f| f.order as u64));
    }
    if profiling {
        semihost::line_kv("profile-period-ticks", u64::from(profile::PERIOD_TICKS));
        for phase in Phase::ALL {
            semihost::line_kv_named("profile-", phase.name(), u64::from(profile::samples(phase)));
        }
    } else {
        semihost::line_kv("systick-busy", busy_ticks);
        semihost::line_kv("systick-max-per-read", u64::from(max_ticks));
    }
    semihost::line_kv("stack-high-water-bytes", hw::stack_high_water() as u64);
    semihost::line_kv("stack-capacity-bytes", hw::stack_capacity() as u64);
    semihost::line_kv("app-state-bytes", core::mem::size_of::<App>() as u64);
    semihost::exit(true)
}
