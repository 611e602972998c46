//! Model learning on blind recordings: scenarios drawn from their seed
//! (`flexcal_sim::sim::blind`), the filter told nothing about them. The learned model
//! must calibrate consistently where the built-in default does not, and land near the
//! values drawn. The 50-run, 600 s figures of `docs/model-learning.md` come from
//! `flexcal montecarlo --blind` (command there); these tests use a few short runs.

use flexcal_core::stats::chi2_quantile;
use flexcal_sim::calib::run::{run, Precision};
use flexcal_sim::calib::score::score;
use flexcal_sim::learn::increments::increment_noise;
use flexcal_sim::learn::params::{ModelParams, Param};
use flexcal_sim::learn::truth::{param_errors, Quantity};
use flexcal_sim::learn::{default_start, learn, start_from_nothing, LearnOptions, Learned};
use flexcal_sim::recording::Recording;
use flexcal_sim::sim::{blind, simulate, Scenario};

const DURATION_S: f64 = 180.0;

fn learned(seed: u64) -> (Scenario, Recording, Learned) {
    let sc = blind::draw(seed, DURATION_S, None);
    let rec = simulate(&sc, seed).recording;
    let (start, inc) = start_from_nothing(&rec);
    let opts = LearnOptions {
        window_s: DURATION_S,
        ..LearnOptions::default()
    };
    let l = learn(&rec, &start, "built-in default", inc.ok(), &opts).expect("learn");
    (sc, rec, l)
}

fn nees(rec: &Recording, cfg: &flexcal_sim::calib::config::CalibConfig) -> f64 {
    let res = run(rec, cfg, Precision::F64).expect("calibrate");
    score(&res, rec.truth.as_ref().expect("truth"))
        .expect("score")
        .nees_mean
}

/// Seeds whose draws cover the three kinds of master (white, noiseless, smooth): see
/// `master_kinds_of_the_test_seeds`.
const SEEDS: [u64; 3] = [1, 8, 13];

#[test]
fn master_kinds_of_the_test_seeds() {
    let kinds: Vec<&str> = SEEDS
        .iter()
        .map(|&s| {
            let m = blind::draw(s, DURATION_S, None).master;
            match (m.smooth_error.is_some(), m.velocity_noise_mps > 0.0) {
                (true, _) => "smooth",
                (false, true) => "white",
                (false, false) => "noiseless",
            }
        })
        .collect();
    assert_eq!(kinds, ["white", "smooth", "noiseless"]);
}

/// On each seed: the learned model is adopted, its NEES of the 9 calibrated states
/// (χ²(9) when consistent) stays under the 99.9 % quantile, which the built-in default
/// exceeds on most of these draws; the flexure's natural frequency lands within 10 % of
/// the draw in the median over the axes.
#[test]
fn learned_model_calibrates_blind_recordings_consistently() {
    let bound = chi2_quantile(0.999, 9.0);
    let mut default_over = 0;
    let mut omega_errors = Vec::new();
    for seed in SEEDS {
        let (sc, rec, l) = learned(seed);
        let with_learned = nees(&rec, &l.config);
        let with_default = nees(&rec, &default_start(&rec, None));
        eprintln!(
            "seed {seed} ({}): NEES learned {with_learned:.1}, default {with_default:.1}, adopted {}",
            sc.name, l.adopted
        );
        assert!(l.adopted, "seed {seed}: the learned model was not adopted");
        assert!(
            with_learned < bound,
            "seed {seed}: NEES {with_learned:.1} over the 99.9% bound {bound:.1}"
        );
        if with_default > bound {
            default_over += 1;
        }
        for e in param_errors(&ModelParams::from_config(&l.learned_config), &l.values, &sc) {
            if let Quantity::Learned(Param::FlexureOmega(_)) = e.param {
                omega_errors.push(e.relative_error.abs());
            }
        }
    }
    // The bound on the flexure's natural frequency is on the median (10 %),
    // checked here over the 9 axes: one axis's ω from the moments of 160 s of θ̂ (some 20
    // periods of a lightly damped mode) scatters by tens of per cent (seed 1: +32 %).
    // The gyro's angle random walk is not checked here: read from the increments' white
    // floor, it is right in the median of 20 blind runs (2.5 %, docs/model-learning.md)
    // but 2–3× too large on seeds 8 and 13, where the flexure's rate fills that band.
    let mut v = omega_errors;
    v.sort_by(f64::total_cmp);
    let omega = v[v.len() / 2];
    assert!(
        omega <= 0.10,
        "median flexure ω error {:.1}% over {v:?}",
        100.0 * omega
    );
    assert!(
        default_over >= 2,
        "the built-in default was consistent on {} of {} seeds: these draws do not test learning",
        SEEDS.len() - default_over,
        SEEDS.len()
    );
}

/// The velocity random walk read from a blind draw's increments (the reading sees only
/// the recording; the draw scores it) is within 5 % where the accelerometers' least band
/// eigenvalue alone was 65–70 % high (seeds 11 and 14: a VRW 0.14–0.19× the default
/// under flexures of up to 3′), and within 15 % with seed 10's VRW set to a tenth of the
/// default (the least eigenvalue alone 260 % high, read −11 %) (`docs/model-learning.md`,
/// session 21). Not a bound there, it is the learner's start (session 22).
#[test]
fn velocity_random_walk_read_from_blind_increments_within_5_percent_and_15_at_a_tenth() {
    let small = |seed| {
        let mut sc = blind::draw(seed, 600.0, None);
        sc.slave_imu.accel_vrw_mps_rh = 0.1 * blind::DEFAULT_ACCEL_VRW_MPS_RH;
        sc
    };
    let cases = [
        (blind::draw(11, 600.0, None), 11, 0.05),
        (blind::draw(14, 600.0, None), 14, 0.05),
        (small(10), 10, 0.15),
    ];
    for (sc, seed, tolerance) in cases {
        let rec = simulate(&sc, seed).recording;
        let inc = increment_noise(&rec, 200_000).expect("increments");
        assert!(!inc.accel_vrw_is_upper_bound, "seed {seed}: only a bound");
        let read = inc.accel_vrw_mps_rs;
        let drawn = sc.slave_imu.accel_vrw_mps_rh / 60.0;
        let error = read / drawn - 1.0;
        eprintln!(
            "seed {seed}: VRW read {read:.3e}, drawn {drawn:.3e} ({:+.1} %)",
            100.0 * error
        );
        assert!(
            error.abs() < tolerance,
            "seed {seed}: {:+.1} %",
            100.0 * error
        );
        let start = default_start(&rec, Some(&inc)).accel_vrw_mps_rs;
        assert_eq!(start, read, "seed {seed}: the learner's start");
    }
}
