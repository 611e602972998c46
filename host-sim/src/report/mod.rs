//! Outputs of a calibration: `summary.json` and `estimates.csv` (the contract in
//! `shared/formats/outputs.md`), `report.md` for people, and SVG plots of every
//! estimate with its ±3σ band, in the engineering units of `units`.

pub mod markdown;
pub mod plots;
pub mod stream;
pub mod summary;
pub mod units;
