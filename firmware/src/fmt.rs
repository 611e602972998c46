//! Logging shim for library code (the idea of embassy's `fmt.rs`).
//!
//! Library modules write `info!("x = {=f32}", x)` and never name defmt (`lib.rs` declares
//! this module first, with `#[macro_use]`).
//! On the board (`target_arch = "arm"`, `target_os = "none"`) each macro forwards to the
//! defmt macro of the same name, so the format strings use defmt syntax (`{=f32}`, `{}`,
//! ...) and the arguments must implement `defmt::Format`. On the host the macros expand to
//! nothing but a borrow of each argument: host builds and tests need no defmt logger, and
//! variables used only for logging raise no `unused` warnings.
//!
//! Arguments should be plain reads: on the host they are evaluated, on the board they may
//! not be (defmt drops statements below the `DEFMT_LOG` level at compile time).

#![allow(unused_macros)]

#[cfg(all(target_arch = "arm", target_os = "none"))]
macro_rules! trace {
    ($($arg:tt)+) => { ::defmt::trace!($($arg)+) };
}
#[cfg(all(target_arch = "arm", target_os = "none"))]
macro_rules! debug {
    ($($arg:tt)+) => { ::defmt::debug!($($arg)+) };
}
#[cfg(all(target_arch = "arm", target_os = "none"))]
macro_rules! info {
    ($($arg:tt)+) => { ::defmt::info!($($arg)+) };
}
#[cfg(all(target_arch = "arm", target_os = "none"))]
macro_rules! warn {
    ($($arg:tt)+) => { ::defmt::warn!($($arg)+) };
}
#[cfg(all(target_arch = "arm", target_os = "none"))]
macro_rules! error {
    ($($arg:tt)+) => { ::defmt::error!($($arg)+) };
}

#[cfg(not(all(target_arch = "arm", target_os = "none")))]
macro_rules! trace {
    ($fmt:literal $(, $arg:expr)* $(,)?) => {{ $( let _ = &$arg; )* }};
}
#[cfg(not(all(target_arch = "arm", target_os = "none")))]
macro_rules! debug {
    ($fmt:literal $(, $arg:expr)* $(,)?) => {{ $( let _ = &$arg; )* }};
}
#[cfg(not(all(target_arch = "arm", target_os = "none")))]
macro_rules! info {
    ($fmt:literal $(, $arg:expr)* $(,)?) => {{ $( let _ = &$arg; )* }};
}
#[cfg(not(all(target_arch = "arm", target_os = "none")))]
macro_rules! warn {
    ($fmt:literal $(, $arg:expr)* $(,)?) => {{ $( let _ = &$arg; )* }};
}
#[cfg(not(all(target_arch = "arm", target_os = "none")))]
macro_rules! error {
    ($fmt:literal $(, $arg:expr)* $(,)?) => {{ $( let _ = &$arg; )* }};
}

// The macros are in textual scope for every module declared after `#[macro_use] mod fmt;`
// in lib.rs. (A `pub(crate) use` re-export cannot work: `warn` clashes with the built-in
// attribute of that name.)

#[cfg(test)]
mod tests {
    #[test]
    fn macros_compile_to_nothing_on_the_host() {
        let x = 1.5_f32;
        let name = "gyro";
        trace!("trace");
        debug!("x = {=f32}", x);
        info!("{=str}: {=f32}", name, x);
        warn!("x = {=f32}, y = {=u32},", x, 3_u32);
        error!("error {}", name);
    }
}
