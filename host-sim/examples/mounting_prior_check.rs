//! How well the coarse mounting's error bound (`CoarseMounting::sigma_bound_rad`, the
//! misalignment prior a learned model starts from) covers the fit's actual error, on
//! blind draws: per seed the fit's error (rad, the angle to the drawn misalignment), the
//! bound, the two halves' angle, and the error per axis (`|error|/√3`) over the bound;
//! then their RMS, median and largest (`docs/model-learning.md`, session 8).
//!
//!     cargo run --release -p flexcal-sim --example mounting_prior_check -- 1 50

use flexcal_sim::calib::mounting::coarse_mounting;
use flexcal_sim::sim::{blind, simulate};
use nalgebra::{Rotation3, Vector3};

/// The mounting's window (s), as the learner reads it; the draws last a little longer.
const WINDOW_S: f64 = 60.0;

fn main() -> Result<(), String> {
    let seeds: Vec<u64> = std::env::args()
        .skip(1)
        .map(|s| s.parse::<u64>().map_err(|e| format!("seed `{s}`: {e}")))
        .collect::<Result<_, _>>()?;
    let [first, last] = seeds[..] else {
        return Err("usage: mounting_prior_check FIRST_SEED LAST_SEED".into());
    };
    let mut ratios = Vec::new();
    for seed in first..=last {
        let sc = blind::draw(seed, WINDOW_S + 5.0, None);
        let rec = simulate(&sc, seed).recording;
        let truth = Rotation3::new(Vector3::from(sc.misalignment_deg).map(f64::to_radians));
        match coarse_mounting(&rec, WINDOW_S) {
            Ok(m) => {
                let found = Rotation3::new(Vector3::from(m.rotation_vector_rad));
                let error = (found.transpose() * truth).scaled_axis().norm();
                let bound = m.sigma_bound_rad();
                let ratio = error / 3f64.sqrt() / bound;
                ratios.push(ratio);
                println!(
                    "seed {seed}: error {error:.2e} rad, bound {bound:.2e} rad, halves {:.2e} rad, error per axis / bound {ratio:.2}",
                    m.split_half_rad
                );
            }
            Err(e) => println!("seed {seed}: no mounting found: {e}"),
        }
    }
    ratios.sort_by(f64::total_cmp);
    let (Some(median), Some(largest)) = (ratios.get(ratios.len() / 2), ratios.last()) else {
        return Err("no mounting found on any seed".into());
    };
    let rms = (ratios.iter().map(|r| r * r).sum::<f64>() / ratios.len() as f64).sqrt();
    println!(
        "{} seeds: error per axis / bound RMS {rms:.2}, median {median:.2}, largest {largest:.2}",
        ratios.len()
    );
    Ok(())
}
