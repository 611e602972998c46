#!/usr/bin/env bash
# No-panic check of the firmware release image.
#
#   firmware/check-no-panic.sh            build the image (cargo fw-build) and check it
#   firmware/check-no-panic.sh <elf>      check an image built already
#
# Approach: inspect the symbol table of the very image CI runs in QEMU (and that would be
# flashed). Every Rust panic path -- explicit panic!, unwrap/expect, slice indexing,
# arithmetic checks, core::fmt errors -- ends in `core::panicking::panic_fmt`, which calls the
# `#[panic_handler]` (`rust_begin_unwind`). With LTO and --gc-sections the linker drops both
# when nothing can reach them, so their absence proves that no panic path survived.
#
# Why this and not the link-time trick (a panic handler calling an undefined symbol so that
# linking fails): that needs a second, differently-built image, fails with an obscure linker
# error, and checks a variant rather than the shipped binary. Here the tool is `readelf` from
# binutils, which reads ELF files of any architecture and is present wherever the host
# toolchain links (cc needs binutils); no cargo-binutils, no llvm-tools download.
#
# When it fails, find the culprit with, e.g.:
#   llvm-objdump -d --demangle <elf> | grep -B30 'bl.*panic'
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/.." && pwd)"

if [[ $# -ge 1 ]]; then
  elf="$1"
else
  (cd "$root" && cargo fw-build)
  elf="${CARGO_TARGET_DIR:-$root/target}/thumbv7em-none-eabihf/firmware/flexcal-firmware"
fi

if ! command -v readelf >/dev/null 2>&1; then
  echo "check-no-panic: readelf not found (install binutils)" >&2
  exit 2
fi
if [[ ! -f "$elf" ]]; then
  echo "check-no-panic: no image at $elf" >&2
  exit 2
fi

# Names as stored (legacy `_ZN...` or v0 `_R...` mangling both keep identifiers readable).
symbols="$(readelf -sW "$elf" | awk '$4 == "FUNC" || $4 == "OBJECT" { print $8 }')"

# Guard against a vacuous pass: a stripped image has no symbols to inspect.
if ! grep -qx 'Reset' <<<"$symbols"; then
  echo "check-no-panic: $elf has no symbol table (stripped?); cannot check" >&2
  exit 2
fi

pattern='rust_begin_unwind|panicking|panic_bounds_check|unwrap_failed|expect_failed|slice_(start_|end_)?index_.*fail|str_index_overflow_fail'
if hits="$(grep -E "$pattern" <<<"$symbols")"; then
  echo "check-no-panic: FAILED, panic machinery is linked into $elf:" >&2
  # Demangled if this readelf can (binutils >= 2.36), raw names otherwise.
  readelf -sW -C "$elf" 2>/dev/null | grep -E "$pattern" >&2 || printf '%s\n' "$hits" >&2
  exit 1
fi
echo "check-no-panic: ok, no panic path in $elf ($(wc -l <<<"$symbols") symbols inspected)"
