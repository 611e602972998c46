//! Plain-text line and exit status over Arm semihosting.

use cortex_m_semihosting::{debug, hio};

/// Writes `text` and a newline to the host's stdout (semihosting `:tt` opened for write).
///
/// Raw bytes, no `core::fmt`: formatting machinery would add panic paths to the image.
/// Errors are ignored: there is nowhere to report them.
pub fn line(text: &str) {
    if let Ok(mut out) = hio::hstdout() {
        let _ = out.write_all(text.as_bytes());
        let _ = out.write_all(b"\n");
    }
}

/// Writes `key value` and a newline to the host's stdout (`value` in decimal, no
/// `core::fmt`).
pub fn line_kv(key: &str, value: u64) {
    line_kv_named("", key, value);
}

/// A `key value` line whose key is `prefix` followed by `name` (e.g. `profile-` + a phase).
pub fn line_kv_named(prefix: &str, name: &str, value: u64) {
    let mut digits = [0u8; 20];
    let mut n = value;
    let mut i = digits.len();
    loop {
        i -= 1;
        if let Some(d) = digits.get_mut(i) {
            *d = b'0' + (n % 10) as u8;
        }
        n /= 10;
        if n == 0 || i == 0 {
            break;
        }
    }
    if let Ok(mut out) = hio::hstdout() {
        let _ = out.write_all(prefix.as_bytes());
        let _ = out.write_all(name.as_bytes());
        let _ = out.write_all(b" ");
        let _ = out.write_all(digits.get(i..).unwrap_or(&[]));
        let _ = out.write_all(b"\n");
    }
}

/// The value of the first `key=value` word of the semihosting command line with this
/// `key=` prefix, copied into `out`; its length, or `None`.
pub fn arg_value(prefix: &[u8], out: &mut [u8]) -> Option<usize> {
    let mut buf = [0_u8; 512];
    let word = cmdline(&mut buf)
        .split(|b| *b == b' ')
        .find(|w| w.starts_with(prefix))?;
    let value = word.get(prefix.len()..)?;
    out.get_mut(..value.len())?.copy_from_slice(value);
    Some(value.len())
}

/// A host file opened over semihosting (`SYS_OPEN`), for bulk link input and output.
pub struct HostFile {
    fd: usize,
}

impl HostFile {
    /// Opens `path` for binary reading (`write == false`) or binary writing (truncated).
    #[allow(unsafe_code)]
    pub fn open(path: &[u8], write: bool) -> Option<Self> {
        let mut name = [0_u8; 512];
        name.get_mut(..path.len())?.copy_from_slice(path);
        // The name must be NUL-terminated; `name` is zeroed beyond `path`.
        if path.len() >= name.len() {
            return None;
        }
        // Modes (Arm semihosting): 1 = "rb", 5 = "wb".
        let mode: usize = if write { 5 } else { 1 };
        let block = [name.as_ptr() as usize, mode, path.len()];
        // SAFETY: SYS_OPEN reads the NUL-terminated name and the 3-word block, both valid for
        // the call.
        let fd = unsafe { cortex_m_semihosting::syscall(cortex_m_semihosting::nr::OPEN, &block) };
        (fd as isize != -1).then_some(Self { fd })
    }

    /// Reads up to `buf.len()` bytes; returns how many (0 at the end of the file or on error).
    #[allow(unsafe_code)]
    pub fn read(&mut self, buf: &mut [u8]) -> usize {
        let block = [self.fd, buf.as_mut_ptr() as usize, buf.len()];
        // SAFETY: SYS_READ writes at most `buf.len()` bytes into `buf`, valid and exclusive for
        // the call; it returns the number of bytes *not* read.
        let not_read =
            unsafe { cortex_m_semihosting::syscall(cortex_m_semihosting::nr::READ, &block) };
        buf.len().saturating_sub(not_read)
    }

    /// Writes all of `bytes` (errors ignored: nowhere to report them).
    #[allow(unsafe_code)]
    pub fn write_all(&mut self, bytes: &[u8]) {
        let block = [self.fd, bytes.as_ptr() as usize, bytes.len()];
        // SAFETY: SYS_WRITE reads `bytes.len()` bytes from `bytes`, valid for the call.
        let _ = unsafe { cortex_m_semihosting::syscall(cortex_m_semihosting::nr::WRITE, &block) };
    }
}

/// Whether the semihosting command line (QEMU `-semihosting-config ...,arg=<word>`) has
/// the word `word`.
pub fn has_arg(word: &[u8]) -> bool {
    let mut buf = [0_u8; 512];
    cmdline(&mut buf).split(|b| *b == b' ').any(|w| w == word)
}

/// Ends the run: semihosting `SYS_EXIT` with `ADP_Stopped_ApplicationExit` on success (QEMU
/// exits with status 0), `ADP_Stopped_RunTimeErrorUnknown` otherwise (QEMU exits with 1).
pub fn exit(success: bool) -> ! {
    debug::exit(if success {
        debug::EXIT_SUCCESS
    } else {
        debug::EXIT_FAILURE
    });
    // Only reached if a debugger resumes after the exit request.
    loop {
        cortex_m::asm::wfi();
    }
}

/// `fault-injection` builds only: reads the semihosting command line (QEMU
/// `-semihosting-config ...,arg=<word>`) and, given the word `fault=panic` or
/// `fault=hardfault`, provokes that failure so the QEMU tests can check the exit path.
#[cfg(feature = "fault-injection")]
pub fn inject_fault_from_cmdline() {
    let mut buf = [0_u8; 256];
    let cmdline = cmdline(&mut buf);
    for word in cmdline.split(|b| *b == b' ') {
        match word {
            b"fault=panic" => {
                defmt::warn!("fault injection: panic");
                #[allow(clippy::panic)]
                {
                    panic!("injected panic");
                }
            }
            b"fault=hardfault" => {
                defmt::warn!("fault injection: HardFault (undefined instruction)");
                // UsageFault (not enabled) escalates to HardFault.
                cortex_m::asm::udf();
            }
            _ => {}
        }
    }
}

/// Semihosting `SYS_GET_CMDLINE`: the host's command line for this program, at most
/// `buf.len() - 1` bytes, or nothing if the host has none.
#[allow(unsafe_code)]
fn cmdline(buf: &mut [u8]) -> &[u8] {
    // Parameter block: buffer address, buffer size; the host overwrites the size with the
    // length written (without the terminating NUL).
    let mut block = [buf.as_mut_ptr() as usize, buf.len()];
    // SAFETY: GET_CMDLINE writes at most `buf.len()` bytes into `buf` and one word into
    // `block[1]`; both are valid, exclusive and outlive the call.
    let status = unsafe {
        cortex_m_semihosting::syscall1(
            cortex_m_semihosting::nr::GET_CMDLINE,
            block.as_mut_ptr() as usize,
        )
    };
    let [_, len] = block;
    if status != 0 {
        return &[];
    }
    buf.get(..len).unwrap_or(&[])
}
