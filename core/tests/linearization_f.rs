//! The error-state transition against the nonlinear mechanization.
//!
//! For every navigation and sensor state, the slave's strapdown is run twice over
//! the same true IMU increments: once from the true state, once with that state
//! perturbed (±h). The central difference of the resulting errors, divided by h, is
//! a column of the true transition; it must equal the model's Φ column.
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

use flexcal_core::earth::Position;
use flexcal_core::flexure::{ArAxis, FlexureModel};
use flexcal_core::model::{self, IntervalMeans};
use flexcal_core::rotation::{dcm, nlerp, quat_exp, quat_log};
use flexcal_core::strapdown::{Increments, NavState, Strapdown};
use nalgebra::{SMatrix, SVector, Vector3};

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

/// Runs `steps` IMU intervals of `dt` from `start` with errors `x` (δv, ψ, ·, ε, ∇)
/// and returns the error state against the unperturbed run.
fn propagate(
    c: &Case,
    x: &SVector<f64, NAV>,
    steps: usize,
    dt: f64,
) -> (SVector<f64, NAV>, NavState<f64>) {
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
            dtheta_b: inc.dtheta_b + block(model::BG) * dt,
            dv_b: inc.dv_b + block(model::BA) * dt,
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

fn check(steps: usize, dt: f64) {
    let c = case();
    let t = steps as f64 * dt;
    // Perturbation sizes per block: small enough that second-order terms vanish in the
    // central difference, large enough to stay above f64 rounding.
    let h = [
        1e-2, 1e-2, 1e-2, 1e-5, 1e-5, 1e-5, 1e-5, 1e-5, 1e-5, 1e-5, 1e-5, 1e-5, 1e-3, 1e-3, 1e-3,
    ];
    let mut fd = SMatrix::<f64, NAV, NAV>::zeros();
    let mut end = c.start;
    for j in 0..NAV {
        let mut xp = SVector::<f64, NAV>::zeros();
        xp[j] = h[j];
        let (ep, nav) = propagate(&c, &xp, steps, dt);
        let (em, _) = propagate(&c, &(-xp), steps, dt);
        end = nav;
        fd.set_column(j, &((ep - em) / (2.0 * h[j])));
    }
    let mid = nlerp(&c.start.q_b_n, &end.q_b_n, 0.5);
    let means = IntervalMeans {
        f_b: c.f_b,
        w_ib_b: c.w_b,
        c_b_n: dcm(&mid),
        v_n: end.v_n,
        pos: end.pos,
    };
    let flex = FlexureModel {
        axes: [ArAxis {
            a1: 0.0,
            a2: 0.0,
            sigma_rad: 0.0,
        }; 3],
        period_s: t,
    };
    let phi = model::transition(&means, &flex, t);
    let names = ["dv", "psi", "mu", "bg", "ba"];
    for i in 0..NAV {
        for j in 0..NAV {
            let (m, d) = (phi[(i, j)], fd[(i, j)]);
            let block_max = (0..3)
                .flat_map(|a| (0..3).map(move |b| (i / 3 * 3 + a, j / 3 * 3 + b)))
                .map(|(r, c)| (phi[(r, c)] - if r == c { 1.0 } else { 0.0 }).abs())
                .fold(0.0, f64::max);
            let tol = 2e-4 * block_max + 1e-6 * t;
            assert!(
                (m - d).abs() <= tol,
                "Φ[{}{}, {}{}] over {t} s: model {m:.6e}, finite difference {d:.6e} (tolerance {tol:.1e})",
                names[i / 3],
                i % 3,
                names[j / 3],
                j % 3
            );
        }
    }
}

#[test]
fn transition_matches_mechanization_over_one_imu_step() {
    check(1, 1e-3);
}

#[test]
fn transition_matches_mechanization_over_one_filter_period() {
    check(2, 5e-3);
}
