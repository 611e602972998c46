//! Outputs of a calibration: `summary.json` and `estimates.csv` (the contract in
//! `shared/formats/outputs.md`) and SVG plots of every estimate with its ±3σ band.

pub mod plots;
pub mod summary;
