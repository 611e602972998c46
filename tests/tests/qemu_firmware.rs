//! The firmware image, run in QEMU's `netduinoplus2` (an STM32F405, the reference board's
//! chip).
//!
//! Each test builds the image with cargo (`firmware` profile, `thumbv7em-none-eabihf`) in its
//! own target directory under the workspace's `target/` (a nested cargo must not wait on the lock of the
//! cargo running these tests, and the two image variants must not overwrite each other's
//! binary while the other runs it), then runs it in `qemu-system-arm` with a time limit.
//!
//! What the image tells: a plain-text result line on stdout (semihosting), binary defmt
//! frames on stderr, and the exit status (semihosting `SYS_EXIT`: 0 for success, 1 for any
//! failure). See `firmware/src/board/mod.rs`.
//!
//! `qemu-system-arm` missing is a failure, not a silent pass; set `FLEXCAL_SKIP_QEMU=1` to
//! skip these tests on a machine without it.

use std::io::Read;
use std::path::Path;
use std::process::{Command, ExitStatus, Stdio};
use std::thread;
use std::time::{Duration, Instant};

mod support;

use support::{build_image, qemu_available_or_skip};

/// Wall-clock limit for one QEMU run (the self-test itself takes well under a second).
const QEMU_TIMEOUT: Duration = Duration::from_secs(60);

struct Run {
    status: ExitStatus,
    stdout: String,
    /// defmt frames (binary); decode with `defmt-print -e <elf>`.
    stderr: Vec<u8>,
}

/// Runs `elf` in QEMU netduinoplus2 with the given semihosting arguments; kills it after
/// [`QEMU_TIMEOUT`].
fn run_in_qemu(elf: &Path, semihosting_args: &[&str]) -> Run {
    let mut semihosting = String::from("enable=on,target=native,arg=flexcal-firmware");
    for a in semihosting_args {
        semihosting.push_str(",arg=");
        semihosting.push_str(a);
    }
    let mut child = Command::new("qemu-system-arm")
        .args([
            "-cpu",
            "cortex-m4",
            "-machine",
            "netduinoplus2",
            "-nographic",
        ])
        .args(["-semihosting-config", &semihosting])
        .arg("-kernel")
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("cannot start qemu-system-arm");

    let mut out_pipe = child.stdout.take().expect("stdout is piped");
    let mut err_pipe = child.stderr.take().expect("stderr is piped");
    let out_reader = thread::spawn(move || {
        let mut buf = Vec::new();
        let _ = out_pipe.read_to_end(&mut buf);
        buf
    });
    let err_reader = thread::spawn(move || {
        let mut buf = Vec::new();
        let _ = err_pipe.read_to_end(&mut buf);
        buf
    });

    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().expect("cannot wait for qemu") {
            break Some(status);
        }
        if start.elapsed() > QEMU_TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        thread::sleep(Duration::from_millis(20));
    };
    let stdout = String::from_utf8_lossy(&out_reader.join().expect("stdout reader")).into_owned();
    let stderr = err_reader.join().expect("stderr reader");
    let Some(status) = status else {
        panic!("firmware did not end within {QEMU_TIMEOUT:?} in QEMU (killed); stdout:\n{stdout}");
    };
    Run {
        status,
        stdout,
        stderr,
    }
}

fn assert_line(run: &Run, line: &str) {
    assert!(
        run.stdout.lines().any(|l| l.trim_end() == line),
        "expected the line {line:?} on stdout; status {}, stdout:\n{}\nstderr ({} bytes, defmt):\n{}",
        run.status,
        run.stdout,
        run.stderr.len(),
        String::from_utf8_lossy(&run.stderr)
    );
}

#[test]
fn release_image_passes_its_selftest_in_qemu() {
    if !qemu_available_or_skip() {
        return;
    }
    let elf = build_image("qemu-firmware", &[]);
    let run = run_in_qemu(&elf, &[]);
    assert_line(&run, "flexcal-firmware selftest ok");
    assert_eq!(run.status.code(), Some(0), "exit status {}", run.status);
    // The defmt log went to stderr: at least the start and result frames.
    assert!(!run.stderr.is_empty(), "no defmt frames on stderr");
}

#[test]
fn panic_and_hardfault_end_the_run_with_a_failure_exit() {
    if !qemu_available_or_skip() {
        return;
    }
    // The `fault-injection` image provokes a failure named on its semihosting command line.
    let elf = build_image("qemu-firmware-faults", &["fault-injection"]);

    let run = run_in_qemu(&elf, &[]);
    assert_line(&run, "flexcal-firmware selftest ok");
    assert_eq!(run.status.code(), Some(0), "no fault asked: {}", run.status);

    let run = run_in_qemu(&elf, &["fault=panic"]);
    assert_line(&run, "flexcal-firmware PANIC");
    assert_eq!(run.status.code(), Some(1), "after a panic: {}", run.status);

    let run = run_in_qemu(&elf, &["fault=hardfault"]);
    assert_line(&run, "flexcal-firmware HARDFAULT");
    assert_eq!(
        run.status.code(),
        Some(1),
        "after a HardFault: {}",
        run.status
    );
}
