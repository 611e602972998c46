//! flexcal firmware, board binary (STM32F405; the same image runs in QEMU `netduinoplus2`).
//!
//! Build and run with `cargo fw-build` / `cargo fw-run` (aliases in `.cargo/config.toml`).
//! The program logic lives in the library; this binary only owns the runtime: reset entry,
//! panic/fault handlers, the defmt transport and the semihosting text/exit channel (see
//! `board/mod.rs`).
//!
//! Modes: the start-up self-test (default), and `mode=replay` on the semihosting command line:
//! the application (`flexcal_firmware::app`) on USART1, link frames in, estimates out, until
//! the host's End message (`board/replay.rs`, `docs/firmware.md`).
//!
//! On the host this file compiles to a stub, so `cargo build/test --workspace` work on a desk.
#![cfg_attr(all(target_arch = "arm", target_os = "none"), no_std, no_main)]
#![deny(unsafe_code)]

#[cfg(all(target_arch = "arm", target_os = "none"))]
mod board;

#[cfg(not(all(target_arch = "arm", target_os = "none")))]
fn main() {
    std::eprintln!(
        "flexcal-firmware is the board image (thumbv7em-none-eabihf); \
         run it under QEMU with `cargo fw-run`"
    );
    std::process::exit(2);
}
