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
#[cfg(feature = "fault-injection")]
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
