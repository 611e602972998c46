//! The engine's handling of its inputs: what it refuses and counts, and that no
//! sequence of inputs, however malformed, makes it panic or lose finiteness.

#![allow(
    clippy::indexing_slicing,
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic
)]

use flexcal_core::earth::{self, Position};
use flexcal_core::engine::{
    Engine, EngineConfig, EngineError, ImuIncrement, InitialSigma, MasterNav, Matching,
    MeasurementNoise, StepReports, PENDING_DEPTH,
};
use flexcal_core::flexure::{ArAxis, AxisModel, FlexureModel};
use flexcal_core::model::{LeverBending, ProcessNoise};
use nalgebra::{UnitQuaternion, Vector3};
use proptest::prelude::*;

const LAT: f64 = 0.6;

fn config() -> EngineConfig<f64> {
    EngineConfig {
        filter_period_s: 0.01,
        matching: Matching {
            velocity: true,
            attitude: true,
            angular_rate: true,
        },
        lever_arm_m: Vector3::new(1.0, 2.0, 0.5),
        bending: LeverBending::UniformArc,
        dynamic_lever_arm: true,
        flexure: FlexureModel {
            axes: [AxisModel::Ar(ArAxis {
                a1: 1.9,
                a2: -0.91,
                sigma_rad: 1e-6,
            }); 3],
            period_s: 0.01,
        },
        process_noise: ProcessNoise {
            accel_vrw: 1e-4,
            gyro_arw: 1e-6,
            gyro_bias_rw: 0.0,
            accel_bias_rw: 0.0,
            misalignment_rw: 0.0,
        },
        measurement_noise: MeasurementNoise::uniform(0.01, 1e-4, 1e-4),
        initial_sigma: InitialSigma {
            velocity_mps: 0.1,
            misalignment_rad: 0.02,
            gyro_bias_radps: 5e-6,
            accel_bias_mps2: 5e-3,
            flexure_rad: 1e-3,
        },
        initial_misalignment_rad: Vector3::zeros(),
        gate_sigma: 5.0,
        variance_floor: 1e-9,
        augmentation: flexcal_core::augment::Augmentation::none(),
        initial_delay_s: 0.0,
    }
}

/// A level IMU at rest: specific force +g up, Earth rate.
fn imu_at(t: f64, dt: f64) -> ImuIncrement<f64> {
    let g = earth::normal_gravity(LAT, 0.0);
    ImuIncrement {
        t,
        dtheta_b: earth::earth_rate_n(LAT) * dt,
        dv_b: Vector3::new(0.0, 0.0, g) * dt,
    }
}

fn master_at(t: f64) -> MasterNav<f64> {
    MasterNav {
        t,
        q_bm_n: UnitQuaternion::identity(),
        v_n: Vector3::zeros(),
        pos: Position {
            lat_rad: LAT,
            lon_rad: 0.0,
            height_m: 0.0,
        },
        w_ib_bm: Some(earth::earth_rate_n(LAT)),
    }
}

/// Runs `seconds` of a stationary slave and master, masters at 100 Hz.
fn run_static(engine: &mut Engine<f64>, seconds: f64) {
    run_span(engine, 0, seconds, UnitQuaternion::identity());
}

/// From IMU sample `first` on, `seconds` of a stationary slave, masters at 100 Hz
/// reporting attitude `q_master`.
fn run_span(engine: &mut Engine<f64>, first: usize, seconds: f64, q_master: UnitQuaternion<f64>) {
    let n = (seconds * 200.0) as usize;
    for i in first..=first + n {
        let t = i as f64 * 0.005;
        engine
            .push_imu(imu_at(t, 0.005), &mut StepReports::new())
            .unwrap();
        if i % 2 == 0 {
            engine
                .push_master(
                    MasterNav {
                        q_bm_n: q_master,
                        ..master_at(t)
                    },
                    &mut StepReports::new(),
                )
                .unwrap();
        }
    }
}

#[test]
fn a_channel_that_keeps_rejecting_resets_the_filter_once() {
    let mut e = Engine::<f64>::new(config()).unwrap();
    run_static(&mut e, 10.0);
    assert_eq!(e.counters().resets, 0);
    // The master re-aligns: its attitude steps by 3° about up, far outside the gate.
    let step = UnitQuaternion::from_scaled_axis(Vector3::new(0.0, 0.0, 3f64.to_radians()));
    run_span(&mut e, 2001, 5.0, step);
    assert_eq!(e.counters().resets, 1, "{:?}", e.counters());
    let gated_after_reset = e.health().gated;
    run_span(&mut e, 3002, 5.0, step);
    // After the reset the filter accepts the re-aligned master again.
    assert_eq!(e.health().gated, gated_after_reset, "{:?}", e.health());
    assert_eq!(e.counters().resets, 1);
    assert!(e.estimates().gyro_bias.iter().all(|v| v.is_finite()));
}

#[test]
fn a_stationary_pair_calibrates_to_zero_errors() {
    let mut e = Engine::<f64>::new(config()).unwrap();
    run_static(&mut e, 20.0);
    let est = e.estimates();
    assert!(
        est.gyro_bias.norm() < 3.0 * est.gyro_bias_sigma.norm(),
        "{est:?}"
    );
    assert!(est.misalignment.norm() < 1e-5, "{est:?}");
    let c = e.counters();
    assert_eq!(c.master_matched, 2000);
    assert_eq!(c.master_stale + c.master_out_of_order + c.master_dropped, 0);
    assert!(c.predictions >= 1999);
    assert_eq!(e.health().non_finite, 0);
}

#[test]
fn refuses_non_finite_and_backward_imu_samples() {
    let mut e = Engine::<f64>::new(config()).unwrap();
    e.push_imu(imu_at(0.0, 0.005), &mut StepReports::new())
        .unwrap();
    let mut bad = imu_at(0.005, 0.005);
    bad.dv_b.x = f64::NAN;
    assert_eq!(
        e.push_imu(bad, &mut StepReports::new()).unwrap_err(),
        EngineError::NonFinite
    );
    e.push_imu(imu_at(0.005, 0.005), &mut StepReports::new())
        .unwrap();
    assert_eq!(
        e.push_imu(imu_at(0.005, 0.005), &mut StepReports::new())
            .unwrap_err(),
        EngineError::ImuTimeNotIncreasing
    );
    assert_eq!(
        e.push_imu(imu_at(0.001, 0.005), &mut StepReports::new())
            .unwrap_err(),
        EngineError::ImuTimeNotIncreasing
    );
    // The engine goes on after a refusal.
    e.push_imu(imu_at(0.010, 0.005), &mut StepReports::new())
        .unwrap();
    assert_eq!(e.counters().imu_samples, 2);
}

#[test]
fn refuses_out_of_order_and_counts_stale_masters() {
    let mut e = Engine::<f64>::new(config()).unwrap();
    run_static(&mut e, 2.0);
    assert_eq!(
        e.push_master(master_at(1.0), &mut StepReports::new())
            .unwrap_err(),
        EngineError::MasterOutOfOrder
    );
    assert_eq!(e.counters().master_out_of_order, 1);
    let mut nan = master_at(2.5);
    nan.v_n.y = f64::INFINITY;
    assert_eq!(
        e.push_master(nan, &mut StepReports::new()).unwrap_err(),
        EngineError::NonFinite
    );
    // A message newer than the last, but older than the alignment buffer, is stale.
    let mut e2 = Engine::<f64>::new(config()).unwrap();
    e2.push_imu(imu_at(0.0, 0.005), &mut StepReports::new())
        .unwrap();
    e2.push_imu(imu_at(0.005, 0.005), &mut StepReports::new())
        .unwrap();
    e2.push_master(master_at(0.0), &mut StepReports::new())
        .unwrap();
    for i in 2..400 {
        e2.push_imu(imu_at(i as f64 * 0.005, 0.005), &mut StepReports::new())
            .unwrap();
    }
    e2.push_master(master_at(0.1), &mut StepReports::new())
        .unwrap();
    assert_eq!(e2.counters().master_stale, 1);
}

#[test]
fn too_many_waiting_masters_drop_the_oldest_and_say_so() {
    let mut e = Engine::<f64>::new(config()).unwrap();
    e.push_imu(imu_at(0.0, 0.005), &mut StepReports::new())
        .unwrap();
    let mut last = Ok(());
    for k in 0..=PENDING_DEPTH {
        last = e
            .push_master(master_at(1.0 + k as f64 * 0.01), &mut StepReports::new())
            .map(|_| ());
    }
    assert_eq!(last.unwrap_err(), EngineError::PendingOverflow);
    assert_eq!(e.counters().master_dropped, 1);
}

#[test]
fn inconsistent_configuration_is_refused() {
    let mut c = config();
    c.flexure.period_s = 0.02;
    assert_eq!(Engine::<f64>::new(c).unwrap_err(), EngineError::BadConfig);
    let mut c = config();
    c.filter_period_s = f64::NAN;
    assert_eq!(Engine::<f64>::new(c).unwrap_err(), EngineError::BadConfig);
}

#[derive(Clone, Debug)]
enum Input {
    Imu(f64, [f64; 6]),
    Master(f64, [f64; 4], [f64; 3], bool),
}

fn any_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        8 => -1e3..1e3f64,
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(-1e300),
        1 => Just(0.0),
    ]
}

fn any_input() -> impl Strategy<Value = Input> {
    prop_oneof![
        (0.0..10.0f64, proptest::array::uniform6(any_f64())).prop_map(|(t, v)| Input::Imu(t, v)),
        (
            0.0..10.0f64,
            proptest::array::uniform4(any_f64()),
            proptest::array::uniform3(any_f64()),
            any::<bool>()
        )
            .prop_map(|(t, q, v, r)| Input::Master(t, q, v, r)),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 128, ..ProptestConfig::default() })]
    /// Any sequence of inputs: no panic, and the estimates stay finite.
    #[test]
    fn arbitrary_inputs_never_panic(mut inputs in proptest::collection::vec(any_input(), 0..300), sort in any::<bool>()) {
        if sort {
            inputs.sort_by(|a, b| {
                let t = |i: &Input| match i { Input::Imu(t, _) | Input::Master(t, ..) => *t };
                t(a).total_cmp(&t(b))
            });
        }
        let mut e = Engine::<f64>::new(config()).unwrap();
        for i in inputs {
            match i {
                Input::Imu(t, v) => {
                    let _ = e.push_imu(ImuIncrement { t, dtheta_b: Vector3::new(v[0], v[1], v[2]) * 1e-3, dv_b: Vector3::new(v[3], v[4], v[5]) * 1e-2 }, &mut StepReports::new());
                }
                Input::Master(t, q, v, r) => {
                    let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(q[0], q[1], q[2], q[3]));
                    let _ = e.push_master(MasterNav {
                        t,
                        q_bm_n: q,
                        v_n: Vector3::from(v),
                        pos: Position { lat_rad: LAT, lon_rad: 0.0, height_m: 0.0 },
                        w_ib_bm: r.then(|| Vector3::new(0.01, 0.0, 0.0)),
                    }, &mut StepReports::new());
                }
            }
        }
        let est = e.estimates();
        prop_assert!(est.gyro_bias.iter().chain(est.gyro_bias_sigma.iter()).all(|v| v.is_finite()));
        prop_assert!(est.misalignment.iter().all(|v| v.is_finite()));
    }
}

/// The engine starts its filter from P₀'s factors (`U`, `D`, not a formed P₀, which `f32`
/// cannot carry with a precise master attitude); they must multiply out to the P₀ of
/// `docs/error-model.md`: ψ = −J_r(μ̂₀)(δμ + θ₀) plus the master's attitude noise, each flexure
/// axis at its AR(2) stationary covariance (θ and θ̇ correlated), the rest diagonal.
/// Formed here densely, in f64, from those definitions.
#[test]
fn initial_factor_is_the_formed_covariance() {
    use flexcal_core::model::{BA, BG, MU, N, PSI, TH, THD, V};
    let mut cfg = config();
    cfg.initial_misalignment_rad = Vector3::new(0.01, -0.03, 0.02);
    cfg.measurement_noise = MeasurementNoise::uniform(0.01, 2e-6, 1e-4);
    let engine = Engine::<f64>::new(cfg).unwrap();
    let s = &cfg.initial_sigma;
    // x = A y: y the independent parts (δv, n, δμ, b_g, b_a, θ, θ̇), ψ = −J (δμ + θ) + n.
    let mut py = nalgebra::SMatrix::<f64, N, N>::zeros();
    for (b, sd) in [
        (V, s.velocity_mps),
        (PSI, 2e-6),
        (MU, s.misalignment_rad),
        (BG, s.gyro_bias_radps),
        (BA, s.accel_bias_mps2),
    ] {
        for k in 0..3 {
            py[(b + k, b + k)] = sd * sd;
        }
    }
    for (k, axis) in cfg.flexure.axes.iter().enumerate() {
        let c = axis.stationary_covariance(cfg.flexure.period_s).unwrap();
        assert!(c[(0, 1)] != 0.0, "θ and θ̇ correlated: the case under test");
        let (i, j) = (TH + k, THD + k);
        py[(i, i)] = c[(0, 0)];
        py[(i, j)] = c[(0, 1)];
        py[(j, i)] = c[(1, 0)];
        py[(j, j)] = c[(1, 1)];
    }
    let jr = flexcal_core::rotation::right_jacobian(&cfg.initial_misalignment_rad);
    let mut a = nalgebra::SMatrix::<f64, N, N>::identity();
    for r in 0..3 {
        for c in 0..3 {
            a[(PSI + r, MU + c)] = -jr[(r, c)];
            a[(PSI + r, TH + c)] = -jr[(r, c)];
        }
    }
    let p0 = a * py * a.transpose();
    let p = engine.filter().covariance();
    for i in 0..N {
        for j in 0..N {
            let tol = 1e-12 * (p0[(i, i)] * p0[(j, j)]).sqrt();
            assert!(
                (p[(i, j)] - p0[(i, j)]).abs() <= tol,
                "P₀({i}, {j}): {} from the factors, {} formed",
                p[(i, j)],
                p0[(i, j)]
            );
        }
    }
}

/// The IMU at the master's rate, the first master at the IMU clock's start: that master
/// waits for a sample after its time, so the sample that completes the first filter
/// period is already in the buffer when it starts the solution, and the next master is
/// matched in the same call. The period must be predicted before that match: matched on
/// the initial covariance, the slave's attitude (given the misalignment and the flexure,
/// known to the master's noise at the start) was taken as still known to that noise, and
/// the first innovation's variance was the measurement noise alone (blind seed 41 handed
/// its truth, attitude matched alone at 1e-7 rad: NEES 195, 40.5 with the period predicted;
/// `docs/model-learning.md`).
#[test]
fn the_first_period_is_predicted_before_the_second_master_is_matched() {
    let mut cfg = config();
    cfg.matching = Matching {
        velocity: false,
        attitude: true,
        angular_rate: false,
    };
    cfg.measurement_noise = MeasurementNoise::uniform(0.01, 1e-7, 1e-4);
    let mut e = Engine::<f64>::new(cfg).unwrap();
    let mut reports = StepReports::new();
    e.push_imu(imu_at(0.0, 0.01), &mut reports).unwrap();
    e.push_imu(imu_at(0.01, 0.01), &mut reports).unwrap();
    e.push_master(master_at(0.0), &mut reports).unwrap();
    assert_eq!(e.counters().predictions, 0, "{:?}", e.counters());
    e.push_master(master_at(0.01), &mut reports).unwrap();
    assert_eq!(e.counters().predictions, 1, "{:?}", e.counters());
    let first = reports
        .iter()
        .find_map(|r| r.attitude)
        .expect("the master at 0.01 s is matched");
    // Over one period the flexure (σ 1e-6 rad per step) and the gyro's random walk
    // (1e-8 rad) move the slave's attitude: far more than the 1e-7 rad noise alone.
    for u in first {
        assert!(u.variance > 10.0 * 1e-14, "{u:?}");
    }
}

/// The slave starts from the master's attitude and velocity as reported, so when the
/// layout carries the master's smooth errors the slave's starting errors hold them:
/// ψ₀ gains `Ĉ_bs^nᵀ φ_m` and δv₀ gains δv_m. P₀ must say so (cov(ψ, φ_m) = Ĉᵀ σ²,
/// cov(δv, δv_m) = σ² I); left independent, the filter took the start's tilt as known to
/// the white noise while it was off by the master's slow error (blind seeds handed their
/// truth: `docs/model-learning.md`, session 9).
#[test]
fn the_start_holds_the_masters_smooth_errors_of_that_instant() {
    use flexcal_core::augment::{Augmentation, Effect};
    use flexcal_core::model::{PSI, V};
    const S: usize = 27;
    let (sa, sv) = (1e-4, 0.02);
    let mut cfg = config();
    cfg.augmentation = Augmentation::none()
        .with(Effect::MasterAttitudeError, sa)
        .unwrap()
        .with(Effect::MasterVelocityError, sv)
        .unwrap();
    let (oa, ov) = (
        cfg.augmentation
            .offset(Effect::MasterAttitudeError)
            .unwrap(),
        cfg.augmentation
            .offset(Effect::MasterVelocityError)
            .unwrap(),
    );
    let q = UnitQuaternion::from_euler_angles(0.2, -0.1, 0.7);
    let mut e = Engine::<f64, S>::new(cfg).unwrap();
    let mut reports = StepReports::new();
    // As `run_span` feeds it (IMU at 200 Hz, masters at 100 Hz), until the solution starts.
    for i in 0..20 {
        let t = i as f64 * 0.005;
        e.push_imu(imu_at(t, 0.005), &mut reports).unwrap();
        if i % 2 == 0 {
            e.push_master(
                MasterNav {
                    q_bm_n: q,
                    ..master_at(t)
                },
                &mut reports,
            )
            .unwrap();
        }
        if e.master_fate().initialized > 0 {
            break;
        }
    }
    assert_eq!(e.master_fate().initialized, 1, "{:?}", e.master_fate());
    // The start's period is predicted and the next master matched in the same call.
    // At rest the prediction rotates ψ by the Earth's rate and decays φ_m by e^{−T/τ}
    // (parts in 10⁻⁴); with the start so tied, the attitude innovation ψ + J(δμ + θ) −
    // Ĉᵀφ_m and the velocity innovation δv − δv_m do not depend on the master's errors,
    // so the update leaves these covariances as P₀ has them. Without the tie the first
    // one is a third of Ĉᵀσ² here.
    assert!(e.counters().predictions <= 1, "{:?}", e.counters());
    assert!(e.counters().master_matched <= 1, "{:?}", e.counters());
    let p = e.filter().covariance();
    let c_bs_n = q.to_rotation_matrix().into_inner(); // μ̂₀ = 0
    for r in 0..3 {
        for c in 0..3 {
            let want = c_bs_n[(c, r)] * sa * sa;
            let got = p[(PSI + r, oa + c)];
            assert!(
                (got - want).abs() <= 1e-3 * sa * sa,
                "cov(ψ{r}, φ_m{c}) {got}, want {want}"
            );
            let want = if r == c { sv * sv } else { 0.0 };
            let got = p[(V + r, ov + c)];
            assert!(
                (got - want).abs() <= 1e-3 * sv * sv,
                "cov(δv{r}, δv_m{c}) {got}, want {want}"
            );
        }
    }
}

/// A rigid flexure axis (σ = 0: a stiff mount, or no flexure about the axis) is held out
/// of the filter: its θ and θ̇ stay zero with their unit placeholder variance, tied to no
/// other state, and the engine reports θ known (σ 0). Carried as states of zero variance
/// they took the scale of a zero variance (1), the floor then lifted them by an absolute
/// 1e-9 rad² every time update and update (clamped variances from the first period), and
/// they diffused into the estimation (docs/diagnosis.md, "The rigid flexure axis"). A
/// second-order axis with σ = 0 and a stationary AR(2) without driving noise alike.
#[test]
fn a_rigid_flexure_axis_is_held_out_of_the_filter() {
    use flexcal_core::flexure::SecondOrderAxis;
    use flexcal_core::model::{N, TH, THD};
    let mut cfg = config();
    cfg.flexure.axes[1] =
        AxisModel::SecondOrder(SecondOrderAxis::new(1.0, 0.2, 0.0, 0.01).unwrap());
    cfg.flexure.axes[2] = AxisModel::Ar(ArAxis {
        a1: 1.9,
        a2: -0.91,
        sigma_rad: 0.0,
    });
    assert!(!cfg.flexure.axes[0].is_rigid());
    assert!(cfg.flexure.axes[1].is_rigid() && cfg.flexure.axes[2].is_rigid());
    let mut e = Engine::<f64>::new(cfg).unwrap();
    run_static(&mut e, 20.0);
    let h = e.health();
    assert_eq!((h.non_finite, h.variance_clamped), (0, 0), "{h:?}");
    assert_eq!(e.counters().resets, 0);
    let p = e.filter().covariance();
    for k in [1, 2] {
        for i in [TH + k, THD + k] {
            assert_eq!(e.filter().state_at(i), 0.0, "state {i}");
            for j in 0..N {
                let inert = if i == j { 1.0 } else { 0.0 };
                assert_eq!(p[(i, j)], inert, "P({i}, {j})");
            }
        }
    }
    let est = e.estimates();
    assert_eq!((est.flexure_sigma[1], est.flexure_sigma[2]), (0.0, 0.0));
    assert!(est.flexure_sigma[0] > 0.0, "{est:?}");
    assert!(
        est.gyro_bias.norm() < 3.0 * est.gyro_bias_sigma.norm(),
        "{est:?}"
    );
    assert!(est.misalignment.norm() < 1e-5, "{est:?}");
}
