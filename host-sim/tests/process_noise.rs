//! The process-noise test of `flexcal diagnose` (`diagnose::process_noise`): a random
//! walk of the gyro biases or of the accelerometer biases is named at its density,
//! within 3σ, and nothing else is; on the same recording with steady biases nothing is
//! named. (A drifting mounting is not named: the flexure states take it in at almost no
//! cost in likelihood, `docs/diagnosis.md`, "Process noise".)
//!
//! Both run the test alone on `moored` (200 s) with the rest of the model handed to it
//! (`CalibConfig::declared_for`, which declares no random walk): the test is judged
//! apart from the model learner, which blind surveys judge with it
//! (`docs/diagnosis.md`, "Process noise").

use flexcal_sim::calib::config::CalibConfig;
use flexcal_sim::diagnose::process_noise::{test_instabilities, InstabilityTest};
use flexcal_sim::diagnose::Options;
use flexcal_sim::recording::Recording;
use flexcal_sim::sim::{simulate, Scenario, DEG_PER_H, MG};

/// `moored` for 200 s as `edit` leaves it, and the model it declares.
fn moored_with(edit: impl FnOnce(&mut Scenario)) -> (Recording, CalibConfig) {
    let mut sc = Scenario::load("moored").expect("built-in");
    sc.duration_s = 200.0;
    edit(&mut sc);
    let rec = simulate(&sc, 3).recording;
    let cfg = CalibConfig::declared_for(&sc, 1.0 / sc.master.rate_hz);
    (rec, cfg)
}

/// `moored` for 200 s with the gyro biases walking at `rrw_deg_h_rh` (°/h/√h).
fn moored(rrw_deg_h_rh: f64) -> (Recording, CalibConfig) {
    moored_with(|sc| sc.slave_imu.gyro_bias_rw_deg_h_rh = rrw_deg_h_rh)
}

/// Asserts `effect` alone is named, within 3σ of `truth`.
fn assert_named_alone_within_3_sigma(tests: &[InstabilityTest], effect: &str, truth: f64) {
    assert_eq!(named(tests), vec![effect], "{tests:#?}");
    let t = tests.iter().find(|t| t.effect == effect).expect("tested");
    let sigma = t.sigma.expect("resolved");
    assert!(
        (t.estimate - truth).abs() < 3.0 * sigma,
        "{effect}: {} ± {sigma} against {truth}",
        t.estimate
    );
    assert!(t.likelihood_ratio > t.threshold);
}

fn span(rec: &Recording) -> f64 {
    match (rec.master.first(), rec.master.last()) {
        (Some(a), Some(b)) => b.t - a.t,
        _ => 0.0,
    }
}

fn named(tests: &[InstabilityTest]) -> Vec<&'static str> {
    tests.iter().filter(|t| t.named).map(|t| t.effect).collect()
}

/// 8.5 °/h/√h: the gyro biases wander 2 °/h (1σ) over the 200 s.
#[test]
fn a_gyro_bias_instability_is_named_within_3_sigma_handed_the_rest_of_its_model() {
    let rrw = 8.5;
    let (rec, cfg) = moored(rrw);
    let (tests, carried) = test_instabilities(&rec, &cfg, &Options::default(), span(&rec));
    assert_named_alone_within_3_sigma(&tests, "gyro_bias_instability", rrw * DEG_PER_H / 60.0);
    let t = tests.first().expect("the gyro's test");
    assert_eq!(carried.map(|c| c.gyro_bias_rw), Some(t.estimate));
}

/// 10 mg/√h: the accelerometer biases wander 2.4 mg (1σ) over the 200 s.
#[test]
fn an_accelerometer_bias_instability_is_named_within_3_sigma_handed_the_rest_of_its_model() {
    let rw = 10.0;
    let (rec, cfg) = moored_with(|sc| sc.slave_imu.accel_bias_rw_mg_rh = rw);
    let (tests, _) = test_instabilities(&rec, &cfg, &Options::default(), span(&rec));
    assert_named_alone_within_3_sigma(&tests, "accel_bias_instability", rw * MG / 60.0);
}

/// The same recording with steady biases: nothing named, the model unchanged.
#[test]
fn no_instability_is_named_on_steady_biases_handed_the_rest_of_its_model() {
    let (rec, cfg) = moored(0.0);
    let (tests, carried) = test_instabilities(&rec, &cfg, &Options::default(), span(&rec));
    assert!(named(&tests).is_empty(), "{tests:#?}");
    assert!(carried.is_none());
    assert_eq!(tests.len(), 3);
}
