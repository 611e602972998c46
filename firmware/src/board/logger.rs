//! defmt global logger: rzCOBS frames over semihosting to the host's **stderr**.
//!
//! Why not the `defmt-semihosting` crate (0.4)? It writes to the host's stdout, where the
//! plain-text result line goes, and its logger `panic!`s on reentrant use, which would put a
//! panic path into every image (`check-no-panic.sh` rejects that). This one is small, writes
//! to stderr, and drops a frame logged reentrantly (from a fault handler that interrupted a
//! log statement) instead of panicking.
//!
//! Single core: the critical section is PRIMASK (interrupts masked between `acquire` and
//! `release`). Only HardFault/NMI can then re-enter, and those frames are dropped.
#![allow(unsafe_code)]

use core::cell::UnsafeCell;
use core::sync::atomic::{AtomicU8, Ordering};

use cortex_m::register::primask;
use cortex_m_semihosting::hio::{self, HostStream};

#[defmt::global_logger]
struct Logger;

/// Nesting depth of `acquire` calls: 0 idle, 1 a frame is open, >1 reentrant (dropped).
static DEPTH: AtomicU8 = AtomicU8::new(0);

struct State {
    encoder: defmt::Encoder,
    /// Interrupts were enabled before the outermost `acquire`.
    restore_interrupts: bool,
    /// The semihosting stream, opened on first use.
    stream: Option<HostStream>,
}

struct Shared(UnsafeCell<State>);

// SAFETY: `State` is only touched at depth 1 with interrupts masked, on a single core.
unsafe impl Sync for Shared {}

static STATE: Shared = Shared(UnsafeCell::new(State {
    encoder: defmt::Encoder::new(),
    restore_interrupts: false,
    stream: None,
}));

fn emit(stream: &mut Option<HostStream>, bytes: &[u8]) {
    if stream.is_none() {
        *stream = hio::hstderr().ok();
    }
    if let Some(s) = stream {
        let _ = s.write_all(bytes);
    }
}

// SAFETY (trait contract): `acquire`/`release` bracket every frame and mask interrupts, so
// frames never interleave; reentrant calls write nothing.
unsafe impl defmt::Logger for Logger {
    fn acquire() {
        let enabled = primask::read().is_active();
        cortex_m::interrupt::disable();
        if DEPTH.fetch_add(1, Ordering::Acquire) != 0 {
            // Reentrant (fault handler, NMI): interrupts were already masked by the outer
            // acquire; drop this frame.
            return;
        }
        // SAFETY: depth 1, interrupts masked, single core: exclusive access.
        let state = unsafe { &mut *STATE.0.get() };
        state.restore_interrupts = enabled;
        let State {
            encoder, stream, ..
        } = state;
        encoder.start_frame(|b| emit(stream, b));
    }

    unsafe fn flush() {
        // Semihosting writes are synchronous: nothing is buffered on the target.
    }

    unsafe fn release() {
        if DEPTH.load(Ordering::Relaxed) != 1 {
            // End of a dropped reentrant frame (or a stray release): just unwind the depth.
            let _ = DEPTH.fetch_update(Ordering::Relaxed, Ordering::Relaxed, |d| d.checked_sub(1));
            return;
        }
        // SAFETY: depth 1, interrupts masked, single core: exclusive access.
        let state = unsafe { &mut *STATE.0.get() };
        let State {
            encoder,
            stream,
            restore_interrupts,
        } = state;
        encoder.end_frame(|b| emit(stream, b));
        let enable = *restore_interrupts;
        DEPTH.store(0, Ordering::Release);
        if enable {
            // SAFETY: restores the state found by the matching `acquire`; no critical
            // section of ours is open any more.
            unsafe { cortex_m::interrupt::enable() };
        }
    }

    unsafe fn write(bytes: &[u8]) {
        if DEPTH.load(Ordering::Relaxed) != 1 {
            return;
        }
        // SAFETY: depth 1, interrupts masked, single core: exclusive access.
        let state = unsafe { &mut *STATE.0.get() };
        let State {
            encoder, stream, ..
        } = state;
        encoder.write(bytes, |b| emit(stream, b));
    }
}
