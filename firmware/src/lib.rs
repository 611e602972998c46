//! flexcal firmware, library part: everything of the board program that can be tested on a desk.
//!
//! The board binary (`src/main.rs`) is a thin shell around this library: it owns the
//! hardware and the runtime (vector table, panic and fault handlers, the defmt transport),
//! and this library owns the logic. Library code logs through the macros of the `fmt`
//! module, which map to defmt on the board and to nothing on the host, so host tests link
//! without a defmt logger.
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

#[macro_use]
mod fmt;
pub mod app;
pub mod imu;
/// The replay IMU source (`src/imu/replay.rs`), an [`imu::ImuSource`]. Declared here rather
/// than in `imu/mod.rs` so the SPI driver and the replay path are edited independently.
#[path = "imu/replay.rs"]
pub mod replay;
pub mod selftest;
