//! Monte Carlo consistency (issue 2, acceptance 3): with the filter's model matching
//! the truth exactly (`matched`: the flexure truth is the filter's own AR(2)), 50 runs
//! have their mean NEES inside the 95% χ² band, and the RMS over runs of the final error
//! over the filter's σ (gyro bias, accelerometer bias, misalignment) is at most 1.3.
//!
//! Runs of 120 s keep the suite fast; the same check over the full 600 s is
//! `flexcal montecarlo --scenario matched --runs 50 --out DIR` (docs/results.md).

use flexcal_sim::calib::config::CalibConfig;
use flexcal_sim::calib::run::Precision;
use flexcal_sim::cmd::montecarlo::{aggregate, one_run};
use flexcal_sim::sim::Scenario;

#[test]
fn matched_model_is_consistent_over_50_runs() {
    let mut sc = Scenario::load("matched").unwrap();
    sc.duration_s = 120.0;
    let cfg = CalibConfig::declared_for(&sc, 0.01);
    let runs: Vec<_> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..2u64)
            .map(|half| {
                let (sc, cfg) = (&sc, &cfg);
                s.spawn(move || {
                    (0..25u64)
                        .map(|i| one_run(sc, cfg, 1 + half * 25 + i, Precision::F64).unwrap())
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().unwrap())
            .collect()
    });
    assert_eq!(runs.len(), 50);
    let agg = aggregate(&runs);
    println!("mean NEES {:.3}, band {:?}", agg.nees_mean, agg.nees_band);
    assert!(
        agg.nees_mean >= agg.nees_band[0] && agg.nees_mean <= agg.nees_band[1],
        "mean NEES {} outside {:?}",
        agg.nees_mean,
        agg.nees_band
    );
    for i in 0..9 {
        let ratio = agg.normalized_rms[i];
        println!(
            "state {i}: rms {:.3e}, mean sigma {:.3e}, RMS of error/sigma {ratio:.3}",
            agg.rms[i], agg.mean_sigma[i]
        );
        assert!(
            ratio <= 1.3,
            "state {i}: RMS of error/σ {ratio:.2} (RMS error {}, mean σ {})",
            agg.rms[i],
            agg.mean_sigma[i]
        );
    }
}
