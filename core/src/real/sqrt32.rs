//! `f32` square root: the FPU's `vsqrt.f32` on the board, the library's elsewhere.
//!
//! Both are IEEE 754 square roots, correctly rounded, so the board and the desk get the
//! same bits. Stable Rust offers no `f32::sqrt` without `std` and no intrinsic for
//! `vsqrt.f32`; nalgebra's `f32` square root on `no_std` is `libm::sqrtf`, which is
//! software (about 50 instructions a call, 45 calls per master update before this module).
//!
//! The board path is the one `unsafe` block of `flexcal-core`, audited here: the assembly
//! reads its input from a core register and writes its result to one, touches no memory
//! and no stack, and uses the FPU register `s15`, which it saves in a core register first
//! and restores before it ends, so no register the compiler allocates is changed behind
//! its back. `vsqrt.f32` of a negative number or NaN gives NaN (and sets only the sticky
//! invalid-operation flag of FPSCR, which nothing reads), as the library does; it cannot
//! trap (the M4F's FPU exceptions are not enabled). The target `thumbv7em-none-eabihf`
//! (`target_abi = "eabihf"`) always has the single-precision FPU. Rust's `sreg` register
//! class would be neater but requires the `vfp2` feature, which implies double
//! precision, which the M4F does not have.

/// `√x`, correctly rounded (NaN for `x < 0` or NaN).
#[cfg(all(target_arch = "arm", target_os = "none", target_abi = "eabihf"))]
#[inline]
#[allow(unsafe_code)]
pub fn sqrt(x: f32) -> f32 {
    let bits: u32;
    // SAFETY: see the module documentation: registers only, `s15` saved and restored.
    unsafe {
        core::arch::asm!(
            "vmov {saved}, s15",
            "vmov s15, {x}",
            "vsqrt.f32 s15, s15",
            "vmov {r}, s15",
            "vmov s15, {saved}",
            x = in(reg) x.to_bits(),
            r = lateout(reg) bits,
            saved = out(reg) _,
            options(pure, nomem, nostack),
        );
    }
    f32::from_bits(bits)
}

/// `√x`, correctly rounded (NaN for `x < 0` or NaN).
#[cfg(not(all(target_arch = "arm", target_os = "none", target_abi = "eabihf")))]
#[inline]
pub fn sqrt(x: f32) -> f32 {
    nalgebra::ComplexField::sqrt(x)
}
