//! Helpers the QEMU tests share: where the workspace is, whether QEMU is there, and
//! building the firmware image with a nested cargo.

#![allow(dead_code)] // each test crate uses its own subset

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// The board's target triple.
pub const TARGET: &str = "thumbv7em-none-eabihf";
/// The workspace root (tests/ is one level below it).
pub fn workspace_root() -> PathBuf {
    // tests/ is one level below the workspace root.
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("tests/ has a parent")
        .to_path_buf()
}

/// `true` if the QEMU tests should run; panics if QEMU is missing and skipping was not asked.
pub fn qemu_available_or_skip() -> bool {
    let found = Command::new("qemu-system-arm")
        .arg("--version")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .map(|s| s.success())
        .unwrap_or(false);
    if found {
        return true;
    }
    if std::env::var("FLEXCAL_SKIP_QEMU").as_deref() == Ok("1") {
        eprintln!("qemu-system-arm not found; skipped because FLEXCAL_SKIP_QEMU=1");
        return false;
    }
    panic!(
        "qemu-system-arm not found on PATH: the firmware QEMU tests cannot run. \
         Install it (Debian/Ubuntu: `apt-get install -y qemu-system-arm`) \
         or set FLEXCAL_SKIP_QEMU=1 to skip these tests."
    );
}

/// Where the firmware images are built: `$FLEXCAL_QEMU_TARGET_DIR` when set (e.g. to keep
/// a checkout's tree clean or share the images between checkouts), else `target/`.
pub fn image_target_base() -> PathBuf {
    match std::env::var_os("FLEXCAL_QEMU_TARGET_DIR") {
        Some(dir) if !dir.is_empty() => PathBuf::from(dir),
        _ => workspace_root().join("target"),
    }
}

/// Builds the firmware image (the `firmware` profile, as `cargo fw-build`) into `<target>/<target_subdir>` (`<target>`: see
/// [`image_target_base`]) and returns the ELF path.
pub fn build_image(target_subdir: &str, features: &[&str]) -> PathBuf {
    let root = workspace_root();
    let target_dir = image_target_base().join(target_subdir);
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.current_dir(&root)
        .args([
            "build",
            "-p",
            "flexcal-firmware",
            "--profile",
            "firmware",
            "--target",
            TARGET,
        ])
        .arg("--target-dir")
        .arg(&target_dir)
        .stdin(Stdio::null());
    if !features.is_empty() {
        cmd.args(["--features", &features.join(",")]);
    }
    // The board flags come from .cargo/config.toml; flags meant for the host build (or a
    // target dir/jobserver of the outer cargo) must not leak into this one.
    for var in [
        "RUSTFLAGS",
        "CARGO_ENCODED_RUSTFLAGS",
        "CARGO_BUILD_RUSTFLAGS",
        "CARGO_BUILD_TARGET",
        "CARGO_TARGET_DIR",
        "CARGO_BUILD_TARGET_DIR",
        "CARGO_MAKEFLAGS",
        "MAKEFLAGS",
        "MFLAGS",
    ] {
        cmd.env_remove(var);
    }
    let out = cmd.output().expect("cannot start cargo");
    assert!(
        out.status.success(),
        "firmware build failed ({}):\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    let elf = target_dir
        .join(TARGET)
        .join("firmware")
        .join("flexcal-firmware");
    assert!(elf.is_file(), "no firmware image at {}", elf.display());
    elf
}
