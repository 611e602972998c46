//! The board's sampling profiler (`profile` on the semihosting command line, with QEMU
//! `-icount shift=0`): SysTick interrupts every [`PERIOD_TICKS`] core-clock ticks and its
//! handler counts one sample for the phase the board is in (`flexcal_core::probe`). Under
//! `-icount` the interrupts fall at exact instruction counts, so the split is deterministic;
//! its resolution is one period (about 3 000 instructions) per sample, and the handler's own
//! few dozen instructions per sample land in the phase it interrupted (proportional, so
//! the split is not skewed).
//!
//! Instructions of a phase = samples × `PERIOD_TICKS` / 0.168 (ticks at 168 MHz of virtual
//! time, 1 ns per instruction): `host-sim/src/cmd/replay.rs` converts and prints them.

use core::sync::atomic::{AtomicU32, Ordering};
use cortex_m::peripheral::{syst::SystClkSource, SYST};
use cortex_m_rt::exception;
use flexcal_core::probe::{self, Phase, PHASES};

/// Sampling period in core-clock ticks (a prime, so no loop of the program aliases with it).
pub const PERIOD_TICKS: u32 = 499;

static SAMPLES: [AtomicU32; PHASES] = [const { AtomicU32::new(0) }; PHASES];

/// Starts sampling: SysTick on the core clock, reloaded every `PERIOD_TICKS`, its interrupt on.
pub fn start(syst: &mut SYST) {
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(PERIOD_TICKS - 1);
    syst.clear_current();
    syst.enable_interrupt();
    syst.enable_counter();
}

/// Samples counted in `phase` so far.
pub fn samples(phase: Phase) -> u32 {
    SAMPLES
        .get(phase as usize)
        .map_or(0, |s| s.load(Ordering::Relaxed))
}

/// One sample of the current phase (only this handler writes the counters).
#[exception]
fn SysTick() {
    if let Some(s) = SAMPLES.get(probe::current() as usize) {
        s.store(s.load(Ordering::Relaxed).wrapping_add(1), Ordering::Relaxed);
    }
}
