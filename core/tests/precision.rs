//! The strapdown in f32 (the board) tracks the strapdown in f64 (the desktop) when both
//! integrate the same increments (rounded to f32, as the board receives them): 600 s of
//! the `moored` ship's rocking at 200 Hz with the `moored` IMU's white noise, 600 s at
//! rest with that noise, and 600 s at rest without noise.
//!
//! Bounds, as what the filter would make of a difference over T = 600 s: an attitude
//! difference δψ reads as a gyro bias δψ / T, a vertical velocity difference δv as an
//! accelerometer bias δv / T. On `moored` the gyro-bias σ is 6e-8 rad/s and the
//! vertical accelerometer-bias σ 3e-6 m/s². The bounds — attitude 1e-7 rad at any time
//! (≤ 1.7e-10 rad/s, 0.3 % of σ), vertical velocity 1e-5 m/s (1.7e-8 m/s², 0.6 % of σ),
//! horizontal 1e-4 m/s (the horizontal accelerometer-bias σ is ≈ 1e-4 m/s²) — hold with
//! a margin: measured 3.7e-8 rad, 1.5e-7 m/s and 4.1e-5 m/s rocking; 4.9e-8 rad,
//! 1.1e-6 m/s and 7.9e-7 m/s at rest. The plain f32 attitude product
//! `q ← Exp(−ζ) q Exp(φ)` drifts 5.3e-4 rad here (rocking) and 4.5e-4 rad (at rest):
//! ≈ 1 % of the Earth rate, 15σ of gyro bias. (The original strapdown on the `moored`
//! recording's increments: 1.9e-4 rad and 0.6 m/s in 600 s.)

#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use flexcal_core::earth::{self, Position};
use flexcal_core::real::Real;
use flexcal_core::rotation::{quat_exp, quat_log};
use flexcal_core::strapdown::{Increments, NavState, Strapdown};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;

const LAT: f64 = 0.654_498_469_497_873_6; // 37.5°
const DT: f64 = 0.005;

/// The `moored` motion: roll 13° / 10 s about forward (y), pitch 5° / 8 s about right
/// (x), yaw 3° / 6 s about up, `q_b^n = Rz(yaw) Rx(pitch) Ry(roll)`.
fn attitude(t: f64) -> UnitQuaternion<f64> {
    use core::f64::consts::TAU;
    let a = |amp_deg: f64, period: f64, phase: f64| {
        amp_deg.to_radians() * (TAU * t / period + phase).cos()
    };
    quat_exp(&Vector3::new(0.0, 0.0, a(3.0, 6.0, 0.3)))
        * quat_exp(&Vector3::new(a(5.0, 8.0, 1.1), 0.0, 0.0))
        * quat_exp(&Vector3::new(0.0, a(13.0, 10.0, 0.0), 0.0))
}

/// Increments of an IMU at a fixed point with attitude `att(t)`: the body rotation
/// relative to n (from the attitude on a fine grid) plus the Earth rate, and the
/// specific force that holds it still (−g resolved in the body).
fn increments(
    att: impl Fn(f64) -> UnitQuaternion<f64>,
    seconds: f64,
    noisy: bool,
) -> Vec<Increments<f64>> {
    // The `moored` slave IMU's white noise: ARW 0.005°/√h, VRW 0.003 m/s/√h.
    let (arw, vrw) = if noisy {
        (0.005_f64.to_radians() / 60.0, 0.003 / 60.0)
    } else {
        (0.0, 0.0)
    };
    let mut rng = StdRng::seed_from_u64(7);
    let mut white = |sigma: f64| {
        Vector3::from_fn(|_, _| sigma * DT.sqrt() * rng.sample::<f64, _>(StandardNormal))
    };
    let w_ie = earth::earth_rate_n(LAT);
    let g = earth::normal_gravity(LAT, 0.0);
    let n = (seconds / DT).round() as usize;
    let sub = 4;
    let h = DT / sub as f64;
    (0..n)
        .map(|k| {
            let mut dth = Vector3::zeros();
            let mut dv = Vector3::zeros();
            for j in 0..sub {
                let t0 = k as f64 * DT + j as f64 * h;
                let (q0, q1, qm) = (att(t0), att(t0 + h), att(t0 + 0.5 * h));
                dth += quat_log(&(q0.inverse() * q1)) + qm.inverse() * w_ie * h;
                dv += qm.inverse() * Vector3::new(0.0, 0.0, g) * h;
            }
            // Rounded to f32 (what the board receives), so both precisions integrate
            // exactly the same increments and differ only by their arithmetic.
            let r = |v: Vector3<f64>| v.map(|x| f64::from(x as f32));
            Increments {
                dtheta_b: r(dth + white(arw)),
                dv_b: r(dv + white(vrw)),
                dt: DT,
            }
        })
        .collect()
}

/// The same starting state in both precisions: the f32-rounded attitude and position.
fn start<T: Real>(q: &UnitQuaternion<f64>) -> NavState<T> {
    let q32 = UnitQuaternion::new_normalize(Quaternion::from(q.coords.map(|x| x as f32)));
    let r = |x: f64| T::of(f64::from(x as f32));
    NavState {
        q_b_n: UnitQuaternion::new_unchecked(Quaternion::from(
            q32.coords.map(|x| T::of(f64::from(x))),
        )),
        v_n: Vector3::zeros(),
        pos: Position {
            lat_rad: r(LAT),
            lon_rad: r(2.1),
            height_m: T::zero(),
        },
    }
}

fn to_f32(inc: &Increments<f64>) -> Increments<f32> {
    Increments {
        dtheta_b: inc.dtheta_b.map(|x| x as f32),
        dv_b: inc.dv_b.map(|x| x as f32),
        dt: inc.dt as f32,
    }
}

fn widen(q: &UnitQuaternion<f32>) -> UnitQuaternion<f64> {
    UnitQuaternion::new_unchecked(Quaternion::from(q.coords.map(f64::from)))
}

/// Largest f32-vs-f64 attitude difference (rad, body frame) over the run, the final
/// one, and the final velocity difference (m/s).
struct Divergence {
    max_attitude: f64,
    final_attitude: Vector3<f64>,
    final_velocity: Vector3<f64>,
}

fn run(incs: &[Increments<f64>], q0: &UnitQuaternion<f64>) -> Divergence {
    let mut s64 = Strapdown::<f64>::new(start(q0));
    let mut s32 = Strapdown::<f32>::new(start(q0));
    let mut max_attitude: f64 = 0.0;
    let mut d = Vector3::zeros();
    for inc in incs {
        s64.step_timed(inc, DT);
        s32.step_timed(&to_f32(inc), DT);
        d = quat_log(&(s64.nav.q_b_n.inverse() * widen(&s32.nav.q_b_n)));
        max_attitude = max_attitude.max(d.norm());
    }
    let final_velocity = s32.nav.v_n.map(f64::from) - s64.nav.v_n;
    Divergence {
        max_attitude,
        final_attitude: d,
        final_velocity,
    }
}

/// The straightforward f32 update `q ← Exp(−ζ) q Exp(φ)` (what the strapdown did
/// before): its drift shows the test can see the error it guards against.
fn naive_attitude_drift(incs: &[Increments<f64>], q0: &UnitQuaternion<f64>) -> f64 {
    let zeta = earth::earth_rate_n(LAT) * DT;
    let zeta32 = zeta.map(|x| x as f32);
    let mut q64 = *q0;
    let mut q32 = UnitQuaternion::new_normalize(Quaternion::from(q0.coords.map(|x| x as f32)));
    let mut prev: Option<Vector3<f64>> = None;
    for inc in incs {
        let phi = inc.dtheta_b + prev.map_or(Vector3::zeros(), |p| p.cross(&inc.dtheta_b) / 12.0);
        prev = Some(inc.dtheta_b);
        q64 = quat_exp(&(-zeta)) * q64 * quat_exp(&phi);
        q64.renormalize_fast();
        q32 = quat_exp(&(-zeta32)) * q32 * quat_exp(&phi.map(|x| x as f32));
        q32.renormalize_fast();
    }
    quat_log(&(q64.inverse() * widen(&q32))).norm()
}

/// Asserts the bounds of the module docs on a run, and prints what it measured.
fn check(name: &str, d: &Divergence) {
    let v = d.final_velocity;
    println!(
        "{name}: max attitude difference {:.2e} rad (final {:.2e}), velocity difference E {:+.2e} N {:+.2e} U {:+.2e} m/s",
        d.max_attitude,
        d.final_attitude.norm(),
        v.x,
        v.y,
        v.z
    );
    assert!(
        d.max_attitude < 1e-7,
        "{name}: f32 attitude drifted {:e} rad from f64",
        d.max_attitude
    );
    assert!(
        v.xy().norm() < 1e-4,
        "{name}: f32 horizontal velocity drifted {v:?} m/s from f64"
    );
    assert!(
        v.z.abs() < 1e-5,
        "{name}: f32 vertical velocity drifted {v:?} m/s from f64"
    );
}

#[test]
fn f32_tracks_f64_over_600_s_of_rocking() {
    let incs = increments(attitude, 600.0, true);
    check("rocking 600 s", &run(&incs, &attitude(0.0)));
    let naive = naive_attitude_drift(&incs, &attitude(0.0));
    println!("rocking 600 s: the plain f32 product drifts {naive:.2e} rad");
    assert!(
        naive > 1e-5,
        "the plain update drifts only {naive:e} rad: the test would not see it"
    );
}

#[test]
fn f32_tracks_f64_for_600_s_at_rest() {
    // Tilted and turned, so no quaternion component is 0 or 1.
    let q = quat_exp(&Vector3::new(0.05, -0.2, 0.7));
    check("at rest 600 s", &run(&increments(|_| q, 600.0, true), &q));
}

#[test]
fn f32_keeps_the_earth_rate_at_rest_without_noise() {
    // Constant increments: every rounding repeats. The attitude must still keep the
    // Earth rate (the plain product loses ≈ 1 % of it). The velocity is not bounded
    // here: with inputs identical to the last bit, the f32 rounding of `q · Δv`
    // (≈ 2e-9 m/s) is the same every step, 4e-7 m/s²; any real accelerometer's noise
    // (here 3.5e-6 m/s, a thousand ULPs, per sample) makes it random.
    let q = quat_exp(&Vector3::new(0.05, -0.2, 0.7));
    let incs = increments(|_| q, 600.0, false);
    let d = run(&incs, &q);
    println!(
        "at rest 600 s, noise-free: max attitude difference {:.2e} rad",
        d.max_attitude
    );
    assert!(
        d.max_attitude < 1e-7,
        "f32 attitude drifted {:e} rad from f64",
        d.max_attitude
    );
    let naive = naive_attitude_drift(&incs, &q);
    println!("at rest 600 s, noise-free: the plain f32 product drifts {naive:.2e} rad");
    assert!(
        naive > 1e-5,
        "the plain update drifts only {naive:e} rad: the test would not see it"
    );
}

#[test]
fn closed_loop_corrections_are_not_lost_in_f32() {
    // A thousand corrections of 1e-9 rad each (far below one f32 ULP of the quaternion)
    // must add up to 1e-6 rad, as in f64.
    let q = attitude(1.7);
    let mut s64 = Strapdown::<f64>::new(start(&q));
    let mut s32 = Strapdown::<f32>::new(start(&q));
    let psi = Vector3::new(1e-9, -1e-9, 0.5e-9);
    let dv = Vector3::new(1e-9, 2e-9, -1e-9);
    for _ in 0..1000 {
        s64.correct(&dv, &psi);
        s32.correct(&dv.map(|x| x as f32), &psi.map(|x| x as f32));
    }
    let turned = quat_log(&(widen(&start::<f32>(&q).q_b_n).inverse() * widen(&s32.nav.q_b_n)));
    assert!(
        (turned + psi * 1000.0).norm() < 1e-7,
        "f32 turned by {turned:?}"
    );
    let d = quat_log(&(s64.nav.q_b_n.inverse() * widen(&s32.nav.q_b_n))).norm();
    assert!(d < 1e-7, "f32 differs from f64 by {d:e} rad");
    assert!((s32.nav.v_n.map(f64::from) - s64.nav.v_n).norm() < 1e-9);
}
