//! The measurement columns of the augmented blocks (`flexcal_core::augment`) against
//! finite differences of the nonlinear matching residuals, built from the simulator's
//! truth kinematics: a master delayed by τ, and a lever arm longer than declared by δr.
//!
//! Delay: the slave is matched at t (τ̂ = 0) with the master of t − τ; the central
//! difference over τ = ±1e-4 s of the velocity, attitude and rate residuals must equal
//! the columns `augment::add_measurement` builds from the master's carried acceleration
//! (`augment::carried_acceleration`), its rate relative to the navigation frame and its
//! angular acceleration (here from the truth, in the engine from the master's past rates
//! and velocities). With a flexing slave the velocity column must still match, and the
//! slave's own acceleration (the column before session 11) must not. Second-order
//! terms are ~ω̈τ/ω̇ ≈ 1e-4 relative: tolerance 1e-3 of the column's largest entry.
//! Lever-arm error: the residual is linear in δr, so the difference must match to 1e-9.
//! Gyro g-sensitivity: the slave's gyro senses `ω + G f`, `f` its true specific force
//! (from finite differences of its truth velocity); the rate residual's difference over
//! each entry of `G` must equal the rate column built from the master's carried force
//! (`augment::carried_specific_force`), to 1e-3 of the column's largest entry; with a
//! flexing slave the column stays the carried force, which the slave's own force (the
//! column before session 12) misses by the bending arm's acceleration.
//! Clock drift: the master of `t − τ₀ − τ̇ (t − t₀)`; the central differences over τ₀
//! (±1e-4 s) and over τ̇ (±1e-4 s / (t − t₀), the same delay change) against the drift's
//! two columns, with the same tolerance as the delay's.

use flexcal_core::augment::{self, Augmentation, Channel, Effect, Signature};
use flexcal_core::earth::{self, Position};
use flexcal_core::model::{self, N};
use flexcal_core::rotation::exp_so3;
use flexcal_sim::sim::motion::MasterAttitude;
use flexcal_sim::sim::scenario::MotionSpec;
use flexcal_sim::sim::{slave_truth, Fixed, SlaveTruth};
use nalgebra::{SVector, Vector3};

const S: usize = N + 9;

fn motion() -> MotionSpec {
    MotionSpec {
        roll_amp_deg: 13.0,
        roll_period_s: 10.0,
        pitch_amp_deg: 5.0,
        pitch_period_s: 8.0,
        yaw_amp_deg: 3.0,
        yaw_period_s: 6.0,
        heading_deg: 20.0,
        speed_mps: 6.0,
    }
}

fn fixed(r0: Vector3<f64>) -> Fixed {
    Fixed {
        mu: Vector3::new(0.01, -0.005, 0.02),
        r0,
        r_bend: nalgebra::Matrix3::zeros(),
        v_m: motion().velocity_n(),
    }
}

fn pos() -> Position<f64> {
    Position {
        lat_rad: 0.65,
        lon_rad: 2.1,
        height_m: 10.0,
    }
}

/// The master's rates at an attitude: (ω_ib^bm, ω_eb^bm).
fn master_rates(m: &MasterAttitude, v_m: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let p = pos();
    let w_ie = earth::earth_rate_n(p.lat_rad);
    let w_en = earth::transport_rate_n(&p, v_m);
    let c_n_bm = m.c_bm_n.transpose();
    (
        m.w_nb_bm + c_n_bm * (w_ie + w_en),
        m.w_nb_bm + c_n_bm * w_en,
    )
}

fn slave(fx: &Fixed, t: f64) -> SlaveTruth {
    let z = Vector3::zeros();
    slave_truth(fx, &motion().attitude(t), &pos(), &z, &z)
}

/// Velocity, attitude and rate residuals of the slave at `t` against the master of
/// `t − tau`, with the declared lever arm `r0_declared`.
fn residuals(fx: &Fixed, r0_declared: &Vector3<f64>, t: f64, tau: f64) -> [Vector3<f64>; 3] {
    let s = slave(fx, t);
    let m = motion().attitude(t - tau);
    let (w_ib, w_eb) = master_rates(&m, &fx.v_m);
    [
        model::velocity_residual(&s.v_n, &fx.v_m, &m.c_bm_n, &w_eb, r0_declared),
        model::attitude_residual(&fx.mu, &m.c_bm_n, &s.c_bs_n),
        model::rate_residual(&s.w_ib_bs, &fx.mu, &w_ib),
    ]
}

/// The signature at `t`, the clock's reference t₀ = 0 (`clock_dt` = t).
fn signature(fx: &Fixed, t: f64) -> Signature<f64> {
    let h = 1e-4;
    let s = slave(fx, t);
    let m = motion().attitude(t);
    let (w_ib, w_eb) = master_rates(&m, &fx.v_m);
    let w_ib_at = |tt: f64| master_rates(&motion().attitude(tt), &fx.v_m).0;
    let w_dot = (w_ib_at(t + h) - w_ib_at(t - h)) / (2.0 * h);
    let p = pos();
    let w_in = earth::earth_rate_n(p.lat_rad) + earth::transport_rate_n(&p, &s.v_n);
    // The master moves at a constant velocity: its own acceleration is zero.
    let v_dot_n = augment::carried_acceleration(
        &Vector3::zeros(),
        &m.c_bm_n,
        &m.w_nb_bm,
        &w_eb,
        &w_dot,
        &fx.r0,
    );
    let f_carried_bs = augment::carried_specific_force(
        &v_dot_n,
        &earth::gravity_n(&p),
        &(earth::earth_rate_n(p.lat_rad) * 2.0 + earth::transport_rate_n(&p, &s.v_n)).cross(&s.v_n),
        &(exp_so3(&fx.mu).transpose() * m.c_bm_n.transpose()),
    );
    Signature {
        c_bm_n: m.c_bm_n,
        w_eb_bm: w_eb,
        lever_v_n: m.c_bm_n * w_eb.cross(&fx.r0),
        v_dot_n,
        w_nb_bs: s.w_ib_bs - s.c_bs_n.transpose() * w_in,
        w_dot_bs: exp_so3(&fx.mu).transpose() * w_dot,
        w_ib_bs: s.w_ib_bs,
        w_carried_bs: exp_so3(&fx.mu).transpose() * w_ib,
        f_bs: Vector3::zeros(),
        f_carried_bs,
        c_bs_n: s.c_bs_n,
        theta: Vector3::zeros(),
        theta_rate: Vector3::zeros(),
        clock_dt: t,
    }
}

fn columns(
    aug: &Augmentation<f64>,
    channel: Channel,
    sig: &Signature<f64>,
) -> [SVector<f64, S>; 3] {
    let mut rows = [SVector::<f64, S>::zeros(); 3];
    augment::add_measurement(&mut rows, aug, channel, sig);
    rows
}

#[test]
fn delay_columns_match_the_delayed_master() {
    let fx = fixed(Vector3::new(10.0, 4.0, 15.0));
    let aug = Augmentation::none().with(Effect::TimeDelay, 0.1).unwrap();
    let o = aug.offset(Effect::TimeDelay).unwrap();
    for t in [1.3, 4.7, 8.2] {
        let sig = signature(&fx, t);
        let h = 1e-4;
        let zp = residuals(&fx, &fx.r0, t, h);
        let zm = residuals(&fx, &fx.r0, t, -h);
        let names = ["velocity", "attitude", "angular rate"];
        for (c, channel) in [Channel::Velocity, Channel::Attitude, Channel::AngularRate]
            .into_iter()
            .enumerate()
        {
            let fd = (zp[c] - zm[c]) / (2.0 * h);
            let rows = columns(&aug, channel, &sig);
            let col = Vector3::new(rows[0][o], rows[1][o], rows[2][o]);
            let tol = 1e-3 * col.amax() + 1e-12;
            assert!(
                (fd - col).amax() <= tol,
                "{} delay column at t = {t}: model {col:?}, finite difference {fd:?}",
                names[c]
            );
        }
    }
}

/// A flexing slave, `θ(t) = a sin(ω t)` per axis with a bending arm: a delay moves the
/// master only, so the velocity residual's derivative over τ is still the master's
/// carried acceleration, while the slave's own acceleration also holds the bending
/// arm's `C_bm^n R θ̈` and `2 C_bm^n ω × R θ̇` (what biased the delay, docs/diagnosis.md
/// "Session 11").
#[test]
fn the_delay_velocity_column_holds_no_flexure() {
    let mut fx = fixed(Vector3::new(10.0, 4.0, 15.0));
    fx.r_bend = nalgebra::Matrix3::new(0.0, 15.0, -4.0, -15.0, 0.0, 10.0, 4.0, -10.0, 0.0);
    let amp = Vector3::new(8e-4, -6e-4, 7e-4);
    let w = Vector3::new(1.5, 2.3, 1.3);
    let theta = |t: f64| amp.component_mul(&w.map(|x| (x * t).sin()));
    let theta_rate = |t: f64| amp.component_mul(&w.component_mul(&w.map(|x| (x * t).cos())));
    let flexing = |t: f64, tau: f64| {
        let s = slave_truth(
            &fx,
            &motion().attitude(t),
            &pos(),
            &theta(t),
            &theta_rate(t),
        );
        let m = motion().attitude(t - tau);
        let (_, w_eb) = master_rates(&m, &fx.v_m);
        (
            model::velocity_residual(&s.v_n, &fx.v_m, &m.c_bm_n, &w_eb, &fx.r0),
            s.v_n,
        )
    };
    let aug = Augmentation::none().with(Effect::TimeDelay, 0.1).unwrap();
    let o = aug.offset(Effect::TimeDelay).unwrap();
    let h = 1e-4;
    let mut slave_off: f64 = 0.0;
    for t in [1.3, 4.7, 8.2] {
        let fd = (flexing(t, h).0 - flexing(t, -h).0) / (2.0 * h);
        let rows = columns(&aug, Channel::Velocity, &signature(&fx, t));
        let col = Vector3::new(rows[0][o], rows[1][o], rows[2][o]);
        let tol = 1e-3 * col.amax();
        assert!(
            (fd - col).amax() <= tol,
            "t = {t}: column {col:?}, finite difference {fd:?}"
        );
        let slave_acc = (flexing(t + h, 0.0).1 - flexing(t - h, 0.0).1) / (2.0 * h);
        slave_off = slave_off.max((fd - slave_acc).amax() / tol);
    }
    // The slave's acceleration misses by tens of the tolerance (R θ̈ ≈ 0.05 m/s²).
    assert!(
        slave_off > 10.0,
        "the slave's acceleration: {slave_off} tolerances off"
    );
}

#[test]
fn clock_drift_columns_match_a_drifting_master_clock() {
    let fx = fixed(Vector3::new(10.0, 4.0, 15.0));
    let aug = Augmentation::none().with(Effect::ClockDrift, 0.1).unwrap();
    let o = aug.offset(Effect::ClockDrift).unwrap();
    let names = ["velocity", "attitude", "angular rate"];
    // t₀ = 0: the delay of the master matched at t is τ₀ + τ̇ t.
    for t in [41.3, 94.7, 258.2] {
        let sig = signature(&fx, t);
        let h = 1e-4;
        for (state, step) in [(0, h), (1, h / t)] {
            let delay = step * if state == 0 { 1.0 } else { t };
            let zp = residuals(&fx, &fx.r0, t, delay);
            let zm = residuals(&fx, &fx.r0, t, -delay);
            for (c, channel) in [Channel::Velocity, Channel::Attitude, Channel::AngularRate]
                .into_iter()
                .enumerate()
            {
                let fd = (zp[c] - zm[c]) / (2.0 * step);
                let rows = columns(&aug, channel, &sig);
                let col = Vector3::new(rows[0][o + state], rows[1][o + state], rows[2][o + state]);
                let tol = 1e-3 * col.amax() + 1e-12;
                assert!(
                    col.amax() > 0.0 && (fd - col).amax() <= tol,
                    "{} column of state {state} at t = {t}: model {col:?}, finite difference {fd:?}",
                    names[c]
                );
            }
        }
    }
    // The drift's delay column is the time delay's.
    let delay = Augmentation::none().with(Effect::TimeDelay, 0.1).unwrap();
    let sig = signature(&fx, 4.7);
    for channel in [Channel::Velocity, Channel::Attitude, Channel::AngularRate] {
        let a = columns(&aug, channel, &sig);
        let b = columns(&delay, channel, &sig);
        for k in 0..3 {
            assert_eq!(a[k][o], b[k][delay.offset(Effect::TimeDelay).unwrap()]);
        }
    }
}

#[test]
fn lever_arm_error_column_matches_a_longer_arm() {
    let r0 = Vector3::new(10.0, 4.0, 15.0);
    let aug = Augmentation::none()
        .with(Effect::LeverArmError, 2.0)
        .unwrap();
    let o = aug.offset(Effect::LeverArmError).unwrap();
    let t = 2.9;
    let sig = signature(&fixed(r0), t);
    let rows = columns(&aug, Channel::Velocity, &sig);
    for k in 0..3 {
        let h = 1e-3;
        let mut dr = Vector3::zeros();
        dr[k] = h;
        let zp = residuals(&fixed(r0 + dr), &r0, t, 0.0)[0];
        let zm = residuals(&fixed(r0 - dr), &r0, t, 0.0)[0];
        let fd = (zp - zm) / (2.0 * h);
        let col = Vector3::new(rows[0][o + k], rows[1][o + k], rows[2][o + k]);
        assert!(
            (fd - col).amax() <= 1e-9,
            "δr[{k}]: model {col:?}, finite difference {fd:?}"
        );
    }
    // The attitude and rate rows do not see the arm.
    for channel in [Channel::Attitude, Channel::AngularRate] {
        let rows = columns(&aug, channel, &sig);
        assert!(rows.iter().all(|r| r.iter().all(|v| *v == 0.0)));
    }
}

/// The master's smooth-error blocks against the matching residuals with the master's
/// output perturbed as the blocks say: attitude `Exp(φ_m) C_bm^n`, velocity `v_m + δv_m`.
#[test]
fn master_error_columns_match_a_perturbed_master() {
    let fx = fixed(Vector3::new(10.0, 4.0, 15.0));
    let aug = Augmentation::none()
        .with(Effect::MasterAttitudeError, 5e-5)
        .unwrap()
        .with(Effect::MasterVelocityError, 0.02)
        .unwrap();
    let oa = aug.offset(Effect::MasterAttitudeError).unwrap();
    let ov = aug.offset(Effect::MasterVelocityError).unwrap();
    for t in [1.3, 4.7] {
        let sig = signature(&fx, t);
        let s = slave(&fx, t);
        let m = motion().attitude(t);
        let (_, w_eb) = master_rates(&m, &fx.v_m);
        let att = columns(&aug, Channel::Attitude, &sig);
        let vel = columns(&aug, Channel::Velocity, &sig);
        let h = 1e-6;
        for k in 0..3 {
            let mut d = Vector3::zeros();
            d[k] = h;
            let z = |phi: Vector3<f64>| {
                model::attitude_residual(&fx.mu, &(exp_so3(&phi) * m.c_bm_n), &s.c_bs_n)
            };
            let fd = (z(d) - z(-d)) / (2.0 * h);
            let col = Vector3::new(att[0][oa + k], att[1][oa + k], att[2][oa + k]);
            assert!(
                (fd - col).amax() <= 1e-3,
                "φ_m[{k}] at t = {t}: model {col:?}, finite difference {fd:?}"
            );
            // The master's attitude also carries the lever arm's velocity to the slave.
            let zv_phi = |phi: Vector3<f64>| {
                let c = exp_so3(&phi) * m.c_bm_n;
                model::velocity_residual(&s.v_n, &fx.v_m, &c, &w_eb, &fx.r0)
            };
            let fd = (zv_phi(d) - zv_phi(-d)) / (2.0 * h);
            let col = Vector3::new(vel[0][oa + k], vel[1][oa + k], vel[2][oa + k]);
            assert!(
                sig.lever_v_n.norm() > 0.1 && (fd - col).amax() <= 1e-6 * sig.lever_v_n.norm(),
                "φ_m[{k}] in the velocity at t = {t}: model {col:?}, finite difference {fd:?}"
            );
            let zv = |dv: Vector3<f64>| {
                model::velocity_residual(&s.v_n, &(fx.v_m + dv), &m.c_bm_n, &w_eb, &fx.r0)
            };
            let fd = (zv(d) - zv(-d)) / (2.0 * h);
            let col = Vector3::new(vel[0][ov + k], vel[1][ov + k], vel[2][ov + k]);
            assert!(
                (fd - col).amax() <= 1e-9,
                "δv_m[{k}] at t = {t}: model {col:?}, finite difference {fd:?}"
            );
            // The master's velocity error is not seen in its attitude.
            assert_eq!(att[0][ov + k], 0.0);
        }
    }
}

/// The slave's true specific force, slave body (m/s²): `v̇ − g + (2ω_ie + ω_en) × v`
/// from central differences of its truth velocity, rotated by its truth attitude.
fn true_specific_force(truth: &dyn Fn(f64) -> SlaveTruth, t: f64) -> Vector3<f64> {
    let h = 1e-4;
    let s = truth(t);
    let p = pos();
    let v_dot = (truth(t + h).v_n - truth(t - h).v_n) / (2.0 * h);
    let w = earth::earth_rate_n(p.lat_rad) * 2.0 + earth::transport_rate_n(&p, &s.v_n);
    s.c_bs_n.transpose() * (v_dot - earth::gravity_n(&p) + w.cross(&s.v_n))
}

/// The g-sensitivity's rate column against the rate residual of a gyro that senses
/// `ω + G f`: a rigid slave (the carried force is the slave's own), and a flexing one
/// (the column is still the carried force; the slave's force holds the bending arm's
/// acceleration, docs/diagnosis.md "Session 12").
#[test]
fn g_sensitivity_rate_column_is_the_carried_specific_force() {
    let rigid = fixed(Vector3::new(10.0, 4.0, 15.0));
    let mut flexing = fixed(Vector3::new(10.0, 4.0, 15.0));
    flexing.r_bend = nalgebra::Matrix3::new(0.0, 15.0, -4.0, -15.0, 0.0, 10.0, 4.0, -10.0, 0.0);
    let amp = Vector3::new(8e-4, -6e-4, 7e-4);
    let w = Vector3::new(1.5, 2.3, 1.3);
    let aug = Augmentation::none()
        .with(Effect::GyroGSensitivity, 1e-5)
        .unwrap();
    let o = aug.offset(Effect::GyroGSensitivity).unwrap();
    for (fx, a) in [(&rigid, 0.0), (&flexing, 1.0)] {
        let theta = |t: f64| amp.component_mul(&w.map(|x| (x * t).sin())) * a;
        let theta_rate =
            |t: f64| amp.component_mul(&w.component_mul(&w.map(|x| (x * t).cos()))) * a;
        let truth =
            |t: f64| slave_truth(fx, &motion().attitude(t), &pos(), &theta(t), &theta_rate(t));
        let (mut slave_off, mut rigid_off): (f64, f64) = (0.0, 0.0);
        for t in [1.3, 4.7, 8.2] {
            let f_true = true_specific_force(&truth, t);
            let s = truth(t);
            let m = motion().attitude(t);
            let (w_ib, _) = master_rates(&m, &fx.v_m);
            let rows = columns(&aug, Channel::AngularRate, &signature(fx, t));
            let tol = 1e-3 * f_true.amax();
            for i in 0..3 {
                for j in 0..3 {
                    let z = |g: f64| {
                        let mut meas = s.w_ib_bs;
                        meas[i] += g * f_true[j];
                        model::rate_residual(&meas, &fx.mu, &w_ib)
                    };
                    let h = 1e-6;
                    let fd = (z(h) - z(-h)) / (2.0 * h);
                    let col = Vector3::new(
                        rows[0][o + 3 * i + j],
                        rows[1][o + 3 * i + j],
                        rows[2][o + 3 * i + j],
                    );
                    if a == 0.0 {
                        rigid_off = rigid_off.max((fd - col).amax() / tol);
                        assert!(
                            (fd - col).amax() <= tol,
                            "G[{i}][{j}] at t = {t}: column {col:?}, finite difference {fd:?}"
                        );
                    } else {
                        slave_off = slave_off.max((fd - col).amax() / tol);
                    }
                }
            }
        }
        eprintln!("flexure ×{a}: the column is {rigid_off:.3} (rigid) / {slave_off:.1} (flexing) tolerances off");
        if a != 0.0 {
            // The flexing slave's force differs from the carried one by the bending
            // arm's acceleration (R θ̈ ≈ 0.05 m/s² against ~10 m/s²): ~6 tolerances.
            assert!(
                slave_off > 3.0,
                "the slave's force: {slave_off} tolerances off"
            );
        }
    }
}
