//! flexcal-sim: the desktop side of flexcal (simulator, recordings, calibrator, reports).

pub mod calib;
pub mod cmd;
pub mod diagnose;
pub mod identify;
pub mod learn;
pub mod plot;
pub mod recording;
pub mod report;
pub mod sim;
pub mod verdict;
