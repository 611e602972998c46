//! Puts the workspace's `memory.x` (the STM32F405 memory map) on the linker search path.
//!
//! cortex-m-rt's `link.x` does `INCLUDE memory.x`, and the linker looks for it on its search
//! path. Copying it into `OUT_DIR` works from a clean clone, from any working directory and
//! with any `--target-dir`, unlike a relative `-L` in `.cargo/config.toml`.

use std::{env, fs, path::PathBuf};

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    let target_os = env::var("CARGO_CFG_TARGET_OS").unwrap_or_default();
    if target_os != "none" {
        // Host build: the binary is a stub, nothing to link for the board.
        return;
    }
    let manifest_dir = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").unwrap_or_default());
    let memory_x = manifest_dir.join("..").join("memory.x");
    println!("cargo:rerun-if-changed={}", memory_x.display());
    let out_dir = PathBuf::from(env::var_os("OUT_DIR").unwrap_or_default());
    if let Err(e) = fs::copy(&memory_x, out_dir.join("memory.x")) {
        // A build script reports a hard error by failing; this is not the engine.
        println!("cargo:warning=cannot copy {}: {e}", memory_x.display());
        std::process::exit(1);
    }
    println!("cargo:rustc-link-search={}", out_dir.display());
}
