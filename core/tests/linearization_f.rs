//! The error-state transition against the nonlinear mechanization.
//!
//! For every navigation and sensor state, the slave's strapdown is run twice over
//! the same true IMU increments: once from the true state, once with that state
//! perturbed (±h). The central difference of the resulting errors, divided by h, is
//! a column of the true transition; it must equal the model's Φ column. The sensor
//! error blocks the diagnosis can add (scale factors, non-orthogonality, g-sensitivity)
//! are checked the same way, the perturbed run's IMU distorted by them.
//!
//! Tolerances: the model's Φ is linearized at the mid-period attitude while the
//! attitude turns by |ω|T (≈ 1.5e-4 rad over 1 ms, 1.5e-3 over 10 ms) during the
//! period; that leaves the attitude-dependent blocks accurate to about (|ω|T)²
//! relative, and the third-order Taylor series of Φ to (‖F‖T)⁴/24. Entries can be
//! small by cancellation inside a block (e.g. [f×] with f mostly vertical), so the
//! tolerance is relative to the largest entry of the 3×3 block of Φ − I: 2e-4 of
//! it, plus an absolute 1e-6 per second of period in the entry's own units. That is
//! below the Coriolis (1.5e-4 /s) and transport-rate (3e-5 /s at 200 m/s) terms, so
//! a sign or frame error in any block fails the test.

#![allow(
    clippy::indexing_slicing,
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic
)]

use flexcal_core::augment::{Augmentation, Effect};
use flexcal_core::earth::Position;
use flexcal_core::flexure::{ArAxis, AxisModel, FlexureModel};
use flexcal_core::model::{self, IntervalMeans};
use flexcal_core::rotation::{dcm, nlerp, quat_exp, quat_log};
use flexcal_core::strapdown::{Increments, NavState, Strapdown};
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

const NAV: usize = 15;

struct Case {
    w_b: Vector3<f64>,
    f_b: Vector3<f64>,
    start: NavState<f64>,
}

fn case() -> Case {
    Case {
        w_b: Vector3::new(0.05, -0.12, 0.08),
        f_b: Vector3::new(0.7, -0.4, 9.9),
        start: NavState {
            q_b_n: quat_exp(&Vector3::new(0.2, -0.1, 0.7)),
            v_n: Vector3::new(200.0, 150.0, 3.0),
            pos: Position {
                lat_rad: 1.1,
                lon_rad: 2.0,
                height_m: 300.0,
            },
        },
    }
}

/// The sensor error the augmented states of `x` put on the true rate `w` and force `f`:
/// (gyro error, accelerometer error), per the conventions of `flexcal_core::augment`.
fn sensor_errors<const S: usize>(
    aug: &Augmentation<f64>,
    x: &SVector<f64, S>,
    w: &Vector3<f64>,
    f: &Vector3<f64>,
) -> (Vector3<f64>, Vector3<f64>) {
    let (mut dw, mut df) = (Vector3::zeros(), Vector3::zeros());
    let sym = |o: usize| {
        Matrix3::new(
            0.0,
            x[o],
            x[o + 1],
            x[o],
            0.0,
            x[o + 2],
            x[o + 1],
            x[o + 2],
            0.0,
        )
    };
    for b in aug.blocks() {
        let o = b.offset;
        let v3 = Vector3::new(x[o], x[o + 1], x[o + 2]);
        match b.effect {
            Effect::GyroScaleFactor => dw += v3.component_mul(w),
            Effect::GyroMisalignment => dw += sym(o) * w,
            Effect::AccelScaleFactor => df += v3.component_mul(f),
            Effect::AccelMisalignment => df += sym(o) * f,
            Effect::GyroGSensitivity => {
                dw += Matrix3::from_row_slice(&x.as_slice()[o..o + 9]) * f;
            }
            _ => {}
        }
    }
    (dw, df)
}

/// Runs `steps` IMU intervals of `dt` from `start` with errors `x` (δv, ψ, ·, ε, ∇)
/// and returns the error state against the unperturbed run.
fn propagate<const S: usize>(
    c: &Case,
    aug: &Augmentation<f64>,
    x: &SVector<f64, S>,
    steps: usize,
    dt: f64,
) -> (SVector<f64, S>, NavState<f64>) {
    let (dw, df) = sensor_errors(aug, x, &c.w_b, &c.f_b);
    // Returns the error state and the true state at the end of the period.
    let block = |b: usize| Vector3::new(x[b], x[b + 1], x[b + 2]);
    let mut truth = Strapdown::new(c.start);
    let mut est = Strapdown::new(NavState {
        q_b_n: c.start.q_b_n * quat_exp(&block(model::PSI)),
        v_n: c.start.v_n + block(model::V),
        pos: c.start.pos,
    });
    for _ in 0..steps {
        let inc = Increments {
            dtheta_b: c.w_b * dt,
            dv_b: c.f_b * dt,
            dt,
        };
        truth.step(&inc);
        est.step(&Increments {
            dtheta_b: inc.dtheta_b + (block(model::BG) + dw) * dt,
            dv_b: inc.dv_b + (block(model::BA) + df) * dt,
            dt,
        });
    }
    let mut e = *x;
    let dv = est.nav.v_n - truth.nav.v_n;
    let psi = quat_log(&(truth.nav.q_b_n.inverse() * est.nav.q_b_n));
    for k in 0..3 {
        e[model::V + k] = dv[k];
        e[model::PSI + k] = psi[k];
    }
    (e, truth.nav)
}

fn check<const S: usize>(aug: &Augmentation<f64>, steps: usize, dt: f64) {
    assert_eq!(aug.dimension(), S);
    let c = case();
    let t = steps as f64 * dt;
    // Perturbation sizes per block: small enough that second-order terms vanish in the
    // central difference, large enough to stay above f64 rounding.
    // Augmented sensor-error blocks: 1e-4 (scale factors, angles), 1e-6 rad/s per m/s²
    // (g-sensitivity: about 1e-5 rad/s at 1 g, like the bias's).
    let nav_h = [
        1e-2, 1e-2, 1e-2, 1e-5, 1e-5, 1e-5, 1e-5, 1e-5, 1e-5, 1e-5, 1e-5, 1e-5, 1e-3, 1e-3, 1e-3,
    ];
    let g_sens = aug.offset(Effect::GyroGSensitivity);
    let h = |j: usize| match (nav_h.get(j), g_sens) {
        (Some(&v), _) => v,
        (None, Some(o)) if (o..o + 9).contains(&j) => 1e-6,
        _ => 1e-4,
    };
    // Columns: the navigation and sensor states and the augmented blocks (the flexure
    // block has no column in the mechanization).
    let columns: Vec<usize> = (0..NAV).chain(model::N..S).collect();
    let mut fd = SMatrix::<f64, S, S>::zeros();
    let mut end = c.start;
    for &j in &columns {
        let mut xp = SVector::<f64, S>::zeros();
        xp[j] = h(j);
        let (ep, nav) = propagate(&c, aug, &xp, steps, dt);
        let (em, _) = propagate(&c, aug, &(-xp), steps, dt);
        end = nav;
        fd.set_column(j, &((ep - em) / (2.0 * h(j))));
    }
    let mid = nlerp(&c.start.q_b_n, &end.q_b_n, 0.5);
    let means = IntervalMeans {
        f_b: c.f_b,
        f_g_b: c.f_b,
        w_ib_b: c.w_b,
        c_b_n: dcm(&mid),
        v_n: end.v_n,
        pos: end.pos,
    };
    let flex = FlexureModel {
        axes: [AxisModel::Ar(ArAxis {
            a1: 0.0,
            a2: 0.0,
            sigma_rad: 0.0,
        }); 3],
        period_s: t,
    };
    let phi = model::transition::<f64, S>(&means, &flex, aug, t);
    let name = |i: usize| match i {
        0..NAV => ["dv", "psi", "mu", "bg", "ba"][i / 3].to_string(),
        _ => aug
            .blocks()
            .find(|b| (b.offset..b.offset + b.effect.states()).contains(&i))
            .map_or("pad".into(), |b| b.effect.name().to_string()),
    };
    for i in 0..NAV {
        for &j in &columns {
            let (m, d) = (phi.get(i, j), fd[(i, j)]);
            // The column block: three states of the declared model, or the whole
            // augmented effect (g-sensitivity's nine columns share one scale).
            let cols = aug
                .blocks()
                .find(|b| (b.offset..b.offset + b.effect.states()).contains(&j))
                .map_or(j / 3 * 3..j / 3 * 3 + 3, |b| {
                    b.offset..b.offset + b.effect.states()
                });
            let block_max = (0..3)
                .flat_map(|a| cols.clone().map(move |b| (i / 3 * 3 + a, b)))
                .map(|(r, c)| (phi.get(r, c) - if r == c { 1.0 } else { 0.0 }).abs())
                .fold(0.0, f64::max);
            let tol = 2e-4 * block_max + 1e-6 * t;
            assert!(
                (m - d).abs() <= tol,
                "Φ[{}{}, {}{}] over {t} s: model {m:.6e}, finite difference {d:.6e} (tolerance {tol:.1e})",
                name(i),
                i % 3,
                name(j),
                j % 3
            );
        }
    }
}

#[test]
fn transition_matches_mechanization_over_one_imu_step() {
    check::<{ model::N }>(&Augmentation::none(), 1, 1e-3);
}

#[test]
fn transition_matches_mechanization_over_one_filter_period() {
    check::<{ model::N }>(&Augmentation::none(), 2, 5e-3);
}

fn sensor_layout() -> Augmentation<f64> {
    let mut aug = Augmentation::none();
    for e in [
        Effect::GyroScaleFactor,
        Effect::GyroMisalignment,
        Effect::AccelScaleFactor,
        Effect::AccelMisalignment,
    ] {
        aug = aug.with(e, 1e-3).unwrap();
    }
    aug
}

#[test]
fn scale_factor_and_nonorthogonality_columns_match_mechanization() {
    check::<33>(&sensor_layout(), 1, 1e-3);
    check::<33>(&sensor_layout(), 2, 5e-3);
}

#[test]
fn g_sensitivity_columns_match_mechanization() {
    let aug = Augmentation::none()
        .with(Effect::GyroGSensitivity, 1e-4)
        .unwrap();
    check::<30>(&aug, 2, 5e-3);
}

/// The master's smooth-error blocks: Φ's other rows do not read them and their own rows
/// stay the identity's in `transition` (their decay `e^{−t/τ}` is applied apart, by
/// `Kalman::decay`, checked against a dense propagation in `core/src/kalman.rs`).
#[test]
fn master_error_blocks_are_outside_the_other_rows_of_the_transition() {
    let tau = 37.0;
    let aug = Augmentation::none()
        .with(Effect::MasterAttitudeError, 5e-5)
        .unwrap()
        .with(Effect::MasterVelocityError, 0.02)
        .unwrap()
        .with_master_error_correlation(tau)
        .unwrap();
    let c = case();
    let means = IntervalMeans {
        f_b: c.f_b,
        f_g_b: c.f_b,
        w_ib_b: c.w_b,
        c_b_n: dcm(&c.start.q_b_n),
        v_n: c.start.v_n,
        pos: c.start.pos,
    };
    let t = 0.1;
    let flex = FlexureModel {
        axes: [AxisModel::Ar(ArAxis {
            a1: 0.5,
            a2: -0.1,
            sigma_rad: 1e-4,
        }); 3],
        period_s: t,
    };
    let phi = model::transition::<f64, 27>(&means, &flex, &aug, t);
    for i in 0..27 {
        for j in model::N..27 {
            let expected = if i == j { 1.0 } else { 0.0 };
            assert_eq!(phi.get(i, j), expected, "Φ[{i}, {j}]");
        }
    }
    let (states, decay) = flexcal_core::augment::gauss_markov_states(&aug, t);
    assert!(states.eq(model::N..27));
    assert_eq!(decay, (-t / tau).exp());
}
