//! The accelerometer's velocity random walk read from the slave's increments against
//! the blind draw's: per recording the drawn VRW, the per-axis white floor (the median
//! axis, an upper bound) and the reading along the arm
//! (`IncrementNoise::accel_vrw_mps_rs`, marked where it is only a bound), with their
//! relative errors, then the median and largest |error| of each
//! (`docs/model-learning.md`, session 21). Each recording `DIR` is scored against the
//! drawn scenario `simulate --blind` wrote beside it, `DIR.drawn.toml`; the reading
//! itself sees only the recording.
//!
//!     cargo run --release -p flexcal-sim --example vrw_from_increments -- DIR...

use flexcal_sim::learn::increments::increment_noise;
use flexcal_sim::recording::read_recording;
use flexcal_sim::sim::scenario::Scenario;
use std::path::Path;

/// (drawn, floor, reading) in m/s/√s for one recording, and whether the reading is
/// only a bound.
fn measure(dir: &str) -> Result<(f64, f64, f64, bool), String> {
    let rec = read_recording(Path::new(dir)).map_err(|e| format!("{dir}: {e}"))?;
    let drawn = Scenario::load(&format!("{}.drawn.toml", dir.trim_end_matches('/')))?;
    let inc = increment_noise(&rec, 200_000)?;
    Ok((
        drawn.slave_imu.accel_vrw_mps_rh / 60.0,
        inc.accel_floor(),
        inc.accel_vrw_mps_rs,
        inc.accel_vrw_is_upper_bound,
    ))
}

/// Median and largest of `v` (empty: zeros).
fn median_max(mut v: Vec<f64>) -> (f64, f64) {
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => (0.0, 0.0),
        n => (v[n / 2], v[n - 1]),
    }
}

fn main() {
    let mut floor_err = Vec::new();
    let mut read_err = Vec::new();
    println!("| recording | drawn VRW (m/s/√s) | floor | error | reading | error |");
    println!("|---|---|---|---|---|---|");
    for dir in std::env::args().skip(1) {
        match measure(&dir) {
            Ok((drawn, floor, read, bound)) => {
                let (ef, er) = (floor / drawn - 1.0, read / drawn - 1.0);
                println!(
                    "| {dir} | {drawn:.3e} | {floor:.3e} | {:+.0} % | {read:.3e}{} | {:+.1} % |",
                    100.0 * ef,
                    if bound { " (bound)" } else { "" },
                    100.0 * er
                );
                floor_err.push(ef.abs());
                read_err.push(er.abs());
            }
            Err(e) => eprintln!("{e}"),
        }
    }
    let (fm, fx) = median_max(floor_err);
    let (rm, rx) = median_max(read_err);
    println!(
        "median |error|: floor {:.1} %, reading {:.1} %; largest: floor {:.0} %, reading {:.1} %",
        100.0 * fm,
        100.0 * rm,
        100.0 * fx,
        100.0 * rx
    );
}
