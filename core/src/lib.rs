//! flexcal-core: the engine shared by the slave IMU board (f32) and the desktop (f64).
//!
//! Everything here is `no_std`, allocation-free and panic-free on any input.
//! Conventions (those of `recording-v1`): navigation frame `n` is East-North-Up at
//! the master INS; body frames are right-forward-up; quaternions are Hamilton,
//! scalar first, `q_b^n` rotating body vectors into `n`.
#![no_std]
#![deny(unsafe_code)]
#![cfg_attr(
    test,
    allow(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing
    )
)]

pub mod align;
pub mod augment;
pub mod earth;
pub mod engine;
pub mod flexure;
pub mod ident;
pub mod kalman;
pub mod link;
pub mod mat;
pub mod model;
pub mod probe;
pub mod real;
pub mod rotation;
pub mod stats;
pub mod strapdown;
pub mod tilt_bias;
pub mod watch;
