//! `flexcal diagnose` on simulations that carry one undeclared effect each (a master
//! clock drift among them), on the complete model (false alarms), and on an effect
//! outside the candidate list.
//! The figures of `docs/diagnosis.md` come from the same runs at 300 s
//! (`flexcal diagnose`, commands there); these tests use 120 s recordings.
//!
//! Why these hand the filter its model: they test the candidate search alone (the
//! Wald and likelihood-ratio tests, the held-out and structure checks), which needs the
//! declared noise and flexure right so that what is left is the effect; each test's name
//! says `given_the_declared_model`. That the model itself can be learned from data that
//! declares nothing is tested on blind draws (`learn_blind.rs`, `docs/model-learning.md`),
//! and so is the whole path of a diagnosis with nothing declared, on blind recordings
//! (a master delay, a lever-arm error, scale factors, a gyro bias instability: the tests
//! that call `blind_diagnosis`).

use flexcal_core::augment::Effect;
use flexcal_sim::calib::config::CalibConfig;
use flexcal_sim::diagnose::report::{effect_truth, master_rate_hz, structure};
use flexcal_sim::diagnose::{diagnose, Diagnosis, Options};
use flexcal_sim::recording::Recording;
use flexcal_sim::sim::{simulate, Scenario};

const DURATION_S: f64 = 120.0;

fn scenario(name: &str) -> Scenario {
    let path = format!("{}/../scenarios/{name}", env!("CARGO_MANIFEST_DIR"));
    let mut sc = Scenario::load(if name.ends_with(".toml") { &path } else { name })
        .unwrap_or_else(|e| panic!("{e}"));
    sc.duration_s = DURATION_S;
    sc
}

/// Simulates and diagnoses with the model the scenario declares (what `simulate` writes
/// beside the recording as `calibrate.toml`).
fn run(sc: &Scenario, seed: u64) -> (Recording, Diagnosis) {
    let rec = simulate(sc, seed).recording;
    let cfg = CalibConfig::declared_for(sc, 1.0 / sc.master.rate_hz);
    let d = diagnose(&rec, &cfg, &Options::default()).expect("diagnose");
    (rec, d)
}

fn found(d: &Diagnosis) -> Vec<&'static str> {
    d.found.iter().map(|t| t.effect).collect()
}

/// Asserts the effect was found and every state is within 3σ of the truth.
fn assert_within_3_sigma(d: &Diagnosis, rec: &Recording, effect: Effect) {
    let t = d
        .found
        .iter()
        .find(|t| t.effect == effect.name())
        .unwrap_or_else(|| panic!("{} not found: {:?}", effect.name(), found(d)));
    let truth = effect_truth(effect, rec.truth.as_ref().expect("truth")).expect("truth columns");
    for ((e, s), tr) in t.estimate.iter().zip(&t.sigma).zip(&truth) {
        assert!(
            (e - tr).abs() <= 3.0 * s,
            "{}: estimate {e:e} ± {s:e}, truth {tr:e} ({:.1}σ)",
            effect.name(),
            (e - tr) / s
        );
    }
}

fn unexplained(d: &Diagnosis, rec: &Recording) -> Vec<(&'static str, usize, f64)> {
    structure(&d.after, d.options.alpha, master_rate_hz(rec))
        .into_iter()
        .filter(|s| s.rejected)
        .map(|s| (s.channel, s.axis, s.peak_hz))
        .collect()
}

#[test]
fn paper_scale_factors_are_found_and_the_residuals_become_consistent_given_the_declared_model() {
    let (rec, d) = run(&scenario("paper"), 1);
    assert_within_3_sigma(&d, &rec, Effect::GyroScaleFactor);
    assert_within_3_sigma(&d, &rec, Effect::AccelScaleFactor);
    assert_eq!(
        d.found.len(),
        2,
        "only the two scale factors: {:?}",
        found(&d)
    );
    let n = d.after.result.innovations.len() as f64;
    let band = [
        flexcal_core::stats::chi2_quantile(0.005, n) / n,
        flexcal_core::stats::chi2_quantile(0.995, n) / n,
    ];
    let nis = d.after.result.nis_mean();
    assert!(
        nis > band[0] && nis < band[1],
        "NIS after {nis} outside {band:?}"
    );
    assert!(
        unexplained(&d, &rec).is_empty(),
        "{:?}",
        unexplained(&d, &rec)
    );
    // The z accelerometer bias error the scale factor caused (200 ppm × g) is gone.
    let tr = rec.truth.as_ref().expect("truth");
    let before = flexcal_sim::calib::score::score(&d.before.result, tr).expect("score");
    let after = flexcal_sim::calib::score::score(&d.after.result, tr).expect("score");
    assert!(
        before.accel_bias[2].abs() > 1.5e-3,
        "{:?}",
        before.accel_bias
    );
    assert!(after.accel_bias[2].abs() < 3e-4, "{:?}", after.accel_bias);
    assert!(after.nees_mean < 30.0 && before.nees_mean > 1e3);
}

#[test]
fn master_delays_of_10_20_and_50_ms_are_found_given_the_declared_model() {
    for tau in [0.01, 0.02, 0.05] {
        let mut sc = scenario("moored-delay-20ms.toml");
        sc.undeclared.master_delay_s = tau;
        let (rec, d) = run(&sc, 2);
        assert_eq!(found(&d), ["time_delay"], "τ = {tau}");
        assert_within_3_sigma(&d, &rec, Effect::TimeDelay);
        assert!(
            unexplained(&d, &rec).is_empty(),
            "τ = {tau}: {:?}",
            unexplained(&d, &rec)
        );
        // The held-out velocity residual shrinks to the master's noise.
        let rms = |m: &flexcal_sim::diagnose::evaluate::ModelEval| {
            m.holdout.as_ref().expect("holdout").channels[0].rms
        };
        assert!(rms(&d.after) < rms(&d.before), "τ = {tau}");
    }
}

/// A master clock drifting 0 → 25 ms over 300 s (`moored-clock-drift.toml`, 83.3 ppm)
/// is named `clock_drift`, not the constant delay, its delay at the start and its rate
/// within 3σ of the truth, and the residuals are left without structure. 300 s, not the
/// 120 s of the others: at 120 s the delay at the start carries the delay's own bias on
/// a complete model (`docs/diagnosis.md`, Open: up to 0.6 ms at 120 s) — −0.57 ± 0.18 ms
/// here, −3.2σ, while named right.
#[test]
fn a_drifting_master_clock_is_found_given_the_declared_model() {
    let mut sc = scenario("moored-clock-drift.toml");
    sc.duration_s = 300.0;
    // Asked for: `clock_drift` is not among the default candidates (`Effect::OPT_IN`).
    let rec = simulate(&sc, 2).recording;
    let cfg = CalibConfig::declared_for(&sc, 1.0 / sc.master.rate_hz);
    let mut opts = Options::default();
    opts.candidates.extend(Effect::OPT_IN);
    let d = diagnose(&rec, &cfg, &opts).expect("diagnose");
    assert_eq!(found(&d), ["clock_drift"]);
    assert_within_3_sigma(&d, &rec, Effect::ClockDrift);
    assert!(
        unexplained(&d, &rec).is_empty(),
        "{:?}",
        unexplained(&d, &rec)
    );
}

#[test]
fn a_lever_arm_error_of_half_a_metre_is_found_given_the_declared_model() {
    let (rec, d) = run(&scenario("moored-lever-error.toml"), 3);
    assert_eq!(found(&d), ["lever_arm_error"]);
    assert_within_3_sigma(&d, &rec, Effect::LeverArmError);
    assert!(
        unexplained(&d, &rec).is_empty(),
        "{:?}",
        unexplained(&d, &rec)
    );
}

/// 300 s (the scenario's own is 600 s). The delay's estimate on the complete model is
/// biased by a few tenths of a millisecond (`docs/diagnosis.md`, Open, with the command);
/// the delay's 0.5 ms resolution floor keeps that from being reported.
#[test]
fn the_complete_model_raises_at_most_one_false_alarm_in_20_seeds_given_the_declared_model() {
    let mut sc = scenario("moored");
    sc.duration_s = 300.0;
    let mut alarms = Vec::new();
    let mut max_ratio: f64 = 0.0;
    for seed in 100..120 {
        let (_, d) = run(&sc, seed);
        for r in &d.rounds {
            for t in &r.tests {
                max_ratio = max_ratio.max(t.wald.min(t.likelihood_ratio) / t.threshold);
            }
        }
        if !d.found.is_empty() {
            alarms.push((seed, found(&d)));
        }
    }
    eprintln!("false alarms: {alarms:?}; largest min(Wald, LR)/threshold {max_ratio:.3}");
    assert!(alarms.len() <= 1, "{alarms:?}");
}

#[test]
fn an_effect_outside_the_candidates_is_reported_as_unexplained_given_the_declared_model() {
    // A 37 s oscillation of the master's north velocity: no candidate has that signature.
    let (rec, d) = run(&scenario("moored-wave.toml"), 4);
    assert!(d.found.is_empty(), "forced onto {:?}", found(&d));
    let left = unexplained(&d, &rec);
    let north = left
        .iter()
        .find(|(c, a, _)| *c == "velocity" && *a == 1)
        .unwrap_or_else(|| panic!("velocity north not reported: {left:?}"));
    // 1/37 s = 0.027 Hz; the Welch bins of a 120 s record are 0.024 Hz apart.
    assert!(
        (north.2 - 1.0 / 37.0).abs() < 0.025,
        "peak at {} Hz",
        north.2
    );
}

/// The whole path of `flexcal diagnose` with no configuration on a blind recording
/// carrying a master delay: the clocks compared before the filter, the model learned
/// with the delay they find compensated, the search started from the model without it.
/// Learned without the delay, the model took its signature into the flexure and the
/// master's error (blind seed 102, 300 s: a 50 ms delay estimated 10.5 ± 0.15 ms). The
/// bound is what the learned model reaches, measured on seeds 101–107 at 300 s
/// (`docs/model-learning.md`, "Blind `diagnose` after session 6"): within 2.1 ms, while
/// the filter's own σ (0.004–0.2 ms) does not cover the learned model's error.
#[test]
fn a_master_delay_is_found_on_a_blind_recording_with_the_model_learned_from_it() {
    use flexcal_sim::cmd::calibrate::prepare_config;
    use flexcal_sim::cmd::common::ModelArgs;
    use flexcal_sim::cmd::diagnose::search_start;
    use flexcal_sim::sim::blind::{draw, BlindEffect};
    let seed = 102;
    let sc = draw(seed, DURATION_S, Some(BlindEffect::TimeDelay));
    let tau = sc.undeclared.master_delay_s;
    let rec = simulate(&sc, seed).recording;
    // No configuration: an empty folder holds no calibrate.toml beside the recording.
    let empty = tempfile::tempdir().expect("temp dir");
    let prepared =
        prepare_config(&rec, empty.path(), None, &ModelArgs::default()).expect("prepare");
    let (cfg, opts) = search_start(&prepared);
    let learned_with = prepared
        .learned_with_delay_s
        .expect("the clocks see the delay");
    assert!(
        (learned_with - tau).abs() < 5e-3,
        "before the filter {learned_with} s, drawn {tau} s"
    );
    let d = diagnose(&rec, &cfg, &opts).expect("diagnose");
    let t = d
        .found
        .iter()
        .find(|t| t.effect == Effect::TimeDelay.name())
        .unwrap_or_else(|| panic!("time_delay not found: {:?}", found(&d)));
    let estimate = t.estimate.first().copied().unwrap_or(f64::NAN);
    assert!(
        (estimate - tau).abs() < 2.5e-3,
        "estimate {estimate} s, drawn {tau} s"
    );
}

/// `flexcal diagnose`'s whole path with no configuration on blind draw `seed` (300 s, as
/// the surveys that traced these draws) carrying a lever-arm error: the draw's arm error
/// and the diagnosis.
fn blind_lever_arm_diagnosis(seed: u64) -> ([f64; 3], Diagnosis) {
    use flexcal_sim::sim::blind::{draw, BlindEffect};
    let sc = draw(seed, 300.0, Some(BlindEffect::LeverArmError));
    (sc.undeclared.lever_arm_error_m, blind_diagnosis(&sc, seed))
}

/// `flexcal diagnose`'s whole path with no configuration (the model learned from the
/// recording) on blind scenario `sc` simulated with `seed`.
fn blind_diagnosis(sc: &Scenario, seed: u64) -> Diagnosis {
    use flexcal_sim::cmd::calibrate::prepare_config;
    use flexcal_sim::cmd::common::ModelArgs;
    use flexcal_sim::cmd::diagnose::search_start;
    let rec = simulate(sc, seed).recording;
    let empty = tempfile::tempdir().expect("temp dir");
    let prepared =
        prepare_config(&rec, empty.path(), None, &ModelArgs::default()).expect("prepare");
    let (cfg, opts) = search_start(&prepared);
    diagnose(&rec, &cfg, &opts).expect("diagnose")
}

/// Asserts the diagnosis found the lever-arm error alone, within 3σ of `truth` (m).
fn assert_lever_arm_alone_within_3_sigma(d: &Diagnosis, truth: [f64; 3]) {
    assert_eq!(found(d), vec![Effect::LeverArmError.name()]);
    let t = d.found.first().expect("one effect");
    assert_eq!((t.estimate.len(), t.sigma.len()), (3, 3));
    for ((e, s), t) in t.estimate.iter().zip(&t.sigma).zip(truth) {
        assert!((e - t).abs() < 3.0 * s, "{e} ± {s} m, drawn {t} m");
    }
}

/// Blind draw 102 with a lever-arm error (300 s, no configuration, a white master of
/// 5 mm/s): learned without the effect, the model takes the lever arm's velocity as a
/// smooth master velocity error (0.21 m/s, τ 1 920 s), against which the lever arm grew
/// the structure's size and was rejected (`gyro_scale_factor` and `gyro_misalignment`
/// adopted instead). With the competing quantities learned again with it
/// (`learn::refit_competing`), the lever arm is adopted, alone, within 3σ of the draw
/// (`docs/diagnosis.md`, "Session 15").
#[test]
fn a_lever_arm_error_the_learned_master_error_took_is_found_once_learned_again() {
    // At 120 s the lever arm passes without the refit.
    let (truth, d) = blind_lever_arm_diagnosis(102);
    let t = d.found.first().expect("one effect");
    assert!(t.refit.is_some(), "adopted without the refit: {t:?}");
    assert_lever_arm_alone_within_3_sigma(&d, truth);
}

/// Blind draw 103 with a lever-arm error (300 s, no configuration; a 10 Hz master with
/// smooth errors only, a 10.8 m arm): learned with the arm in the data and not in the
/// layout, the model predicted the held-out part worse than the built-in start (−2 ln L
/// 14 820 against −111 375) and was not adopted, and the arm, read against the start,
/// came out 7.6σ off in x (0.177 for 0.231 m). Learned again from the start with the arm
/// in the layout (`learn::relearn_with`), the model is kept and the arm is within 3σ
/// (`docs/diagnosis.md`, "Session 17").
#[test]
fn a_lever_arm_error_read_against_the_start_is_found_once_the_whole_model_is_learned_again() {
    let (truth, d) = blind_lever_arm_diagnosis(103);
    let relearned = d
        .rounds
        .first()
        .and_then(|r| r.relearned.as_ref())
        .expect("the model learned again after round 1");
    assert!(
        relearned.kept,
        "the model learned again not kept: {relearned:?}"
    );
    assert_lever_arm_alone_within_3_sigma(&d, truth);
}

/// Blind draw 103 with a master delay and a lever-arm error drawn together (300 s, no
/// configuration; 50 ms found before the filter and compensated in the learning, a
/// 0.5 m arm error on a 10.8 m arm, a 10 Hz master with smooth errors only): both
/// found, each within 3σ of the draw in the final model. Until the declared delay was
/// matched off the filter epochs (`docs/diagnosis.md`, "A declared delay matched off
/// the epochs"), the learning read the flexure states up to a period stale and took the
/// arm into its flexure (1.58 mrad about x, 0.23 drawn); only the whole model learned
/// again with the arm (session 18's `judge_relearned`) found both. Now the delay is
/// adopted in round 1 (50.0 ± 0.14 ms) and the arm in round 2.
#[test]
fn a_delay_and_a_lever_arm_drawn_together_are_both_found_within_3_sigma() {
    use flexcal_sim::sim::blind::{draw_effects, BlindEffect};
    let seed = 103;
    let sc = draw_effects(
        seed,
        300.0,
        &[BlindEffect::TimeDelay, BlindEffect::LeverArmError],
    );
    let d = blind_diagnosis(&sc, seed);
    let mut names = found(&d);
    names.sort_unstable();
    let mut drawn = vec![Effect::TimeDelay.name(), Effect::LeverArmError.name()];
    drawn.sort_unstable();
    assert_eq!(names, drawn);
    for t in &d.found {
        let truth: Vec<f64> = if t.effect == Effect::TimeDelay.name() {
            vec![sc.undeclared.master_delay_s]
        } else {
            sc.undeclared.lever_arm_error_m.to_vec()
        };
        assert_eq!(t.estimate.len(), truth.len(), "{}", t.effect);
        for ((e, s), w) in t.estimate.iter().zip(&t.sigma).zip(&truth) {
            assert!(
                (e - w).abs() < 3.0 * s,
                "{}: {e} ± {s}, drawn {w}",
                t.effect
            );
        }
    }
}

/// Blind draw `seed` (300 s, no effect drawn) calibrated with its own model (handed to
/// the filter on purpose: these check the effects' columns, not the learner) and
/// `effect` asked for, matched on `matching` (the draw's channels when `None`): the
/// effect's estimate and σ per state.
fn declared_effect_on_draw(
    seed: u64,
    effect: Effect,
    matching: Option<&[&str]>,
) -> (Vec<f64>, Vec<f64>) {
    use flexcal_sim::calib::run::{run as calibrate, Precision};
    use flexcal_sim::sim::blind::draw;
    let sc = draw(seed, 300.0, None);
    let rec = simulate(&sc, seed).recording;
    let mut cfg = CalibConfig::declared_for(&sc, 1.0 / sc.master.rate_hz);
    if let Some(channels) = matching {
        cfg.matching = channels.iter().map(|c| c.to_string()).collect();
    }
    cfg.effects = vec![effect.name().to_string()];
    cfg.mounting_estimate_rad = Some(sc.misalignment_deg.map(f64::to_radians));
    let res = calibrate(&rec, &cfg, Precision::F64).expect("calibrate");
    let e = res
        .final_effects()
        .into_iter()
        .find(|e| e.effect == effect)
        .expect("the effect's block");
    (e.value, e.sigma)
}

/// Blind draw 107 (300 s, no delay) calibrated with its own model and the delay asked
/// for, matched on `matching`: the delay's estimate and σ (s).
fn declared_delay_on_draw_107(matching: &[&str]) -> (f64, f64) {
    let (value, sigma) = declared_effect_on_draw(107, Effect::TimeDelay, Some(matching));
    let (tau, sigma) = (value[0], sigma[0]);
    eprintln!(
        "{matching:?}: delay {:.4} ± {:.4} ms",
        tau * 1e3,
        sigma * 1e3
    );
    (tau, sigma)
}

/// A delay column must hold what a delay moves and nothing the current innovation
/// carries. The slave's own gyro also senses its flexure; built from it, the attitude
/// column of `time_delay` carried the flexure's rate of the moment, which the filter has
/// not predicted and which is in the same innovation: an errors-in-variables bias
/// (`docs/diagnosis.md`, "Session 10"). Blind draw 107's scenario (20 Hz master, 100 Hz
/// IMU, a flexure of 2.6–2.8′ on every axis, no delay) calibrated with its own model
/// (handed to the filter on purpose: the learned model's mismatch is not what this
/// tests) and the delay asked for, matched on attitude, and on attitude and rate: the
/// delay must be within 3σ of zero. With the slave's rate in the column (and the flexure
/// read back a whole period when the delay crossed zero): +2.15 ± 0.16 ms and +5.45 ±
/// 0.11 ms. The velocity column has its own test below.
#[test]
fn a_flexing_slave_shows_no_master_delay_through_attitude_and_rate_given_the_declared_model() {
    let mut failures = Vec::new();
    for matching in [&["attitude"][..], &["attitude", "angular_rate"][..]] {
        let (tau, sigma) = declared_delay_on_draw_107(matching);
        if tau.abs() > 3.0 * sigma {
            failures.push((matching, tau, sigma));
        }
    }
    assert!(failures.is_empty(), "{failures:?}");
}

/// The velocity column of `time_delay` is the rate of change of the master's carried
/// velocity (`augment::carried_acceleration`: its lever-arm part from the master's rates,
/// its own acceleration from a line through its past velocities). Built from the slave's
/// sensed acceleration it carried the bending arm's `R θ̈` of the moment, also in the
/// velocity innovation (`docs/diagnosis.md`, "Session 11"). Blind draw 107's scenario as
/// above, its own model, matched on velocity alone: the delay must be within 3σ of zero
/// (the slave's acceleration in the column: +3.43 ± 0.07 ms, 50σ).
#[test]
fn a_flexing_slave_shows_no_master_delay_through_velocity_given_the_declared_model() {
    let (tau, sigma) = declared_delay_on_draw_107(&["velocity"]);
    assert!(tau.abs() <= 3.0 * sigma, "delay {tau} s ± {sigma} s");
}

/// The lever-arm columns take the master's rate from a parabola through its previous
/// rates (`engine::rate_instrument`), not from the rate of the message they match: that
/// rate's noise is in the velocity residual through the arm (`C [n×] r0`), and a column
/// built from it is correlated with it. Blind draw 101 (no effect; a 12 m arm along x, a
/// 100 Hz master with 184 °/h of rate noise, a flexure whose rate can carry most of the
/// arm's velocity), calibrated with its own model (handed to the filter on purpose: the
/// check is of the column, not of the learner) and the lever-arm error asked for: every
/// axis within 3σ of zero. With the current rate in the column: x −3.7 ± 0.46 cm (−8σ),
/// z +1.1 ± 0.17 cm (`docs/diagnosis.md`, "Session 16").
#[test]
fn a_noisy_master_rate_on_a_long_arm_makes_no_lever_arm_error_given_the_declared_model() {
    let (value, sigma) = declared_effect_on_draw(101, Effect::LeverArmError, None);
    for (v, s) in value.iter().zip(&sigma) {
        assert!(v.abs() <= 3.0 * s, "lever arm {value:?} ± {sigma:?} m");
    }
}

/// Blind draw 107 with accelerometer scale factors (300 s, no configuration; a 19 m arm,
/// a noiseless master whose velocity noise the learner holds at its 1 mm/s floor): as
/// learned, the gyro's and the accelerometer's scale factors are within the χ²(1)
/// threshold of each other in likelihood. With the velocity random walk started at the
/// built-in 5e-5 m/s/√s (drawn 1.0e-5) the gyro's led by 2.9 (205.5 against 202.5) and
/// was adopted, 12σ off; with it read from the increments (1.016e-5) the accelerometer's
/// leads by 1.1 (211.3 against 210.2). Which of the two leads is not what tells them
/// apart: judged on the whole model learned again with each (`diagnose::Rivals`), the
/// accelerometer's predicts the held-out part better by 188 and is adopted, within 3σ of
/// the draw (`docs/diagnosis.md`, "Session 19"; `docs/model-learning.md`, "Session 22").
#[test]
fn an_accelerometer_scale_factor_a_gyro_one_rivals_is_told_apart_on_the_models_learned_again() {
    use flexcal_sim::sim::blind::{draw_effects, BlindEffect};
    let seed = 107;
    let sc = draw_effects(seed, 300.0, &[BlindEffect::AccelScaleFactor]);
    let d = blind_diagnosis(&sc, seed);
    let first = d.rounds.first().expect("round 1");
    let rivals = first.rivals.as_ref().expect("round 1 judged two rivals");
    let mut pair = [rivals.leader.effect, rivals.rival.effect];
    pair.sort_unstable();
    let mut drawn_and_rival = [
        Effect::AccelScaleFactor.name(),
        Effect::GyroScaleFactor.name(),
    ];
    drawn_and_rival.sort_unstable();
    assert_eq!(pair, drawn_and_rival);
    assert_eq!(rivals.chosen, Effect::AccelScaleFactor.name());
    assert!(rivals.told_apart, "{rivals:?}");
    assert_eq!(found(&d), vec![Effect::AccelScaleFactor.name()]);
    let t = d.found.first().expect("one effect");
    let truth = sc.slave_imu.accel_scale_ppm.map(|p| p * 1e-6);
    assert_eq!((t.estimate.len(), t.sigma.len()), (3, 3));
    for ((e, s), w) in t.estimate.iter().zip(&t.sigma).zip(truth) {
        assert!((e - w).abs() < 3.0 * s, "{e} ± {s}, drawn {w}");
    }
}

/// The process noises named by a diagnosis.
fn instabilities_named(d: &Diagnosis) -> Vec<&'static str> {
    d.instabilities
        .iter()
        .filter(|t| t.named)
        .map(|t| t.effect)
        .collect()
}

/// Blind draw 105 (300 s, no configuration) with its gyro biases walking (1.9e-7
/// rad/s/√s: 0.83 °/h over the run): the gyro's bias instability is named, alone and
/// within 3σ of the drawn density, and no block is adopted; the same draw with steady
/// biases names nothing (`docs/diagnosis.md`, "Process noise").
#[test]
fn a_gyro_bias_instability_is_named_blind_within_3_sigma_and_nothing_on_steady_biases() {
    use flexcal_sim::sim::blind::{draw, BlindEffect};
    use flexcal_sim::sim::DEG_PER_H;
    let sc = draw(105, 300.0, Some(BlindEffect::GyroBiasInstability));
    let d = blind_diagnosis(&sc, 105);
    assert!(found(&d).is_empty(), "{:?}", found(&d));
    assert_eq!(instabilities_named(&d), vec!["gyro_bias_instability"]);
    let t = d.instabilities.first().expect("the gyro's test");
    let truth = sc.slave_imu.gyro_bias_rw_deg_h_rh * DEG_PER_H / 60.0;
    let sigma = t.sigma.expect("resolved");
    assert!(
        (t.estimate - truth).abs() < 3.0 * sigma,
        "{} ± {sigma} rad/s/√s, drawn {truth}",
        t.estimate
    );
    assert_eq!(d.after.cfg.gyro_bias_rw, t.estimate);
    let steady = blind_diagnosis(&draw(105, 300.0, None), 105);
    assert!(found(&steady).is_empty(), "{:?}", found(&steady));
    assert!(
        instabilities_named(&steady).is_empty(),
        "{:#?}",
        steady.instabilities
    );
}
