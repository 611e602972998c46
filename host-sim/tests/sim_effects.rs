//! The simulator's injected effects that the filter's 21-state model does not
//! contain (accelerometer non-orthogonality, gyro g-sensitivity, master delay, master
//! clock drift, lever-arm error, master velocity wave, the biases' instability) against hand computations, their values in
//! `truth.csv`, and a default scenario's output unchanged bit for bit.
//!
//! Most checks simulate a scenario twice, with and without one effect, with all noise,
//! biases and flexure off, so the difference is the effect alone.

use flexcal_core::rotation::exp_so3;
use flexcal_sim::recording::{read_recording, write_recording, MasterMsg, Recording};
use flexcal_sim::sim::{
    simulate, FlexureSpec, Scenario, VelocityWave, DEG_PER_H, MOUNTING_STEP_S,
    STANDARD_GRAVITY_MPS2,
};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use std::f64::consts::PI;

/// `moored` without noise, biases or flexure, so that runs differ only by what a test
/// changes.
fn quiet() -> Scenario {
    let mut sc = Scenario::load("moored").unwrap();
    sc.duration_s = 20.0;
    sc.flexure = FlexureSpec::None;
    sc.slave_imu.gyro_bias_deg_h = [0.0; 3];
    sc.slave_imu.accel_bias_mg = [0.0; 3];
    sc.slave_imu.gyro_arw_deg_rh = 0.0;
    sc.slave_imu.accel_vrw_mps_rh = 0.0;
    sc.master.velocity_noise_mps = 0.0;
    sc.master.attitude_noise_deg = 0.0;
    sc.master.rate_noise_deg_h = 0.0;
    sc
}

fn run(sc: &Scenario) -> Recording {
    sc.validate().unwrap();
    simulate(sc, 11).recording
}

fn q(m: &MasterMsg) -> UnitQuaternion<f64> {
    let [w, x, y, z] = m.q_bm_n;
    UnitQuaternion::new_unchecked(Quaternion::new(w, x, y, z))
}

/// Rotation angle between two attitudes (rad), accurate near zero.
fn angle(a: &UnitQuaternion<f64>, b: &UnitQuaternion<f64>) -> f64 {
    2.0 * (a.inverse() * b).imag().norm()
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// The master at stamp `t` of a run delayed by τ = 0.02 s (two master periods) is the
/// undelayed master at `t − τ`: attitude, rate, velocity and position. The stamps and
/// the slave IMU do not change, and the first messages (`t − τ < 0`) are emitted from
/// the closed-form motion.
#[test]
fn master_delay_shifts_master_truth_back_by_tau() {
    let mut base = quiet();
    // Moving, so that the delayed position and transport rate are exercised too.
    base.motion.heading_deg = 30.0;
    base.motion.speed_mps = 6.0;
    let mut late = base.clone();
    late.undeclared.master_delay_s = 0.02;
    let (b, l) = (run(&base), run(&late));
    assert_eq!(b.imu, l.imu);
    assert_eq!(b.master.len(), l.master.len());
    let shift = 2; // 0.02 s at 100 Hz
    for (k, m) in l.master.iter().enumerate() {
        assert_eq!(m.t, b.master[k].t);
        let Some(k0) = k.checked_sub(shift) else {
            continue;
        };
        let m0 = &b.master[k0];
        assert!(angle(&q(m), &q(m0)) < 1e-12, "attitude at {}", m.t);
        let w = max_diff(
            &m.omega_ib_bm_radps.unwrap(),
            &m0.omega_ib_bm_radps.unwrap(),
        );
        assert!(w < 1e-13, "rate at {}: {w}", m.t);
        assert!(
            max_diff(&m.v_n_mps, &m0.v_n_mps) < 1e-15,
            "velocity at {}",
            m.t
        );
        // 1e-9 deg ≈ 0.1 mm.
        let p = max_diff(
            &[m.lat_deg, m.lon_deg, m.height_m],
            &[m0.lat_deg, m0.lon_deg, m0.height_m],
        );
        assert!(p < 1e-9, "position at {}: {p}", m.t);
    }
    // The delay is not a small effect at these rates: the test above can tell.
    assert!(angle(&q(&l.master[500]), &q(&b.master[500])) > 1e-4);
    // Messages before τ: the truth of negative times.
    for (k, m) in l.master.iter().take(shift).enumerate() {
        let t_valid = k as f64 * 0.01 - 0.02;
        let c = late.motion.attitude(t_valid).c_bm_n;
        let expected = UnitQuaternion::from_matrix(&c);
        assert!(angle(&q(m), &expected) < 1e-12, "message {k}");
    }
}

/// A delay that appears in service (`master_delay_from_s`): the messages stamped before
/// the onset are the undelayed run's, those from it on the run's delayed by τ, message
/// for message; the slave IMU does not change; `tau_from` is in the truth.
#[test]
fn master_delay_appears_at_its_onset() {
    let base = quiet();
    let mut late = base.clone();
    late.undeclared.master_delay_s = 0.02;
    let mut onset = late.clone();
    onset.undeclared.master_delay_from_s = Some(3.0);
    let (b, l, o) = (run(&base), run(&late), run(&onset));
    assert_eq!(b.imu, o.imu);
    let mut before = 0;
    for ((mo, mb), ml) in o.master.iter().zip(&b.master).zip(&l.master) {
        let want = if mo.t < 3.0 { mb } else { ml };
        before += usize::from(mo.t < 3.0);
        assert_eq!(mo.q_bm_n, want.q_bm_n, "attitude at {}", mo.t);
        assert_eq!(
            mo.omega_ib_bm_radps, want.omega_ib_bm_radps,
            "rate at {}",
            mo.t
        );
    }
    assert_eq!(before, 300, "3 s of 100 Hz on time");
    assert!(
        angle(&q(&o.master[500]), &q(&b.master[500])) > 1e-4,
        "late after it"
    );
    let from = o.truth.as_ref().and_then(|t| t.column("tau_from"));
    assert!(from.expect("tau_from").iter().all(|v| *v == 3.0));
    assert!(b
        .truth
        .as_ref()
        .and_then(|t| t.column("tau_from"))
        .is_none());
}

/// A drifting master clock (`master_delay_rate` τ̇, here with an offset τ₀ too): the
/// message stamped `t` is the master of `t − τ₀ − τ̇ t`. Its attitude at every stamp is
/// the closed-form motion's there; where the delay is a whole number of master periods
/// (τ̇ = 0.002 s/s, τ₀ = 0.005 s: 0.02 s at t = 7.5 s, 0.03 s at t = 12.5 s) the whole
/// message — attitude, rate, velocity, position — is the undelayed run's that many
/// periods earlier. The stamps and the slave IMU do not change.
#[test]
fn clock_drift_delays_the_master_by_its_growing_delay() {
    let mut base = quiet();
    base.motion.heading_deg = 30.0;
    base.motion.speed_mps = 6.0;
    let mut drift = base.clone();
    drift.undeclared.master_delay_s = 0.005;
    drift.undeclared.master_delay_rate = 0.002;
    let (b, d) = (run(&base), run(&drift));
    assert_eq!(b.imu, d.imu);
    assert_eq!(b.master.len(), d.master.len());
    for (k, m) in d.master.iter().enumerate() {
        assert_eq!(m.t, b.master[k].t);
        let tau = 0.005 + 0.002 * m.t;
        let c = drift.motion.attitude(m.t - tau).c_bm_n;
        let expected = UnitQuaternion::from_matrix(&c);
        assert!(angle(&q(m), &expected) < 1e-12, "attitude at {}", m.t);
    }
    for (t, shift) in [(7.5, 2), (12.5, 3)] {
        let k = (t * 100.0_f64).round() as usize;
        let (m, m0) = (&d.master[k], &b.master[k - shift]);
        assert!((m.t - t).abs() < 1e-9);
        assert!(angle(&q(m), &q(m0)) < 1e-12, "attitude at {t}");
        let w = max_diff(
            &m.omega_ib_bm_radps.unwrap(),
            &m0.omega_ib_bm_radps.unwrap(),
        );
        assert!(w < 1e-13, "rate at {t}: {w}");
        assert!(max_diff(&m.v_n_mps, &m0.v_n_mps) < 1e-15);
        let p = max_diff(
            &[m.lat_deg, m.lon_deg, m.height_m],
            &[m0.lat_deg, m0.lon_deg, m0.height_m],
        );
        assert!(p < 1e-9, "position at {t}: {p}");
        // Not the constant delay's message: the drift moved it by a period or more.
        assert!(angle(&q(m), &q(&b.master[k])) > 1e-4);
    }
}

/// A master early by 0.02 s (τ = −0.02, a clock offset's sign) is the undelayed master
/// two periods *later*: its attitude at stamp `t` is the base run's at `t + 0.02`.
#[test]
fn master_early_shifts_master_truth_forward() {
    let base = quiet();
    let mut early = base.clone();
    early.undeclared.master_delay_s = -0.02;
    let (b, e) = (run(&base), run(&early));
    assert_eq!(b.imu, e.imu);
    for (k, m) in e.master.iter().enumerate().take(b.master.len() - 2) {
        assert_eq!(m.t, b.master[k].t);
        let m2 = &b.master[k + 2];
        assert!(angle(&q(m), &q(m2)) < 1e-12, "attitude at {}", m.t);
    }
}

/// A lever-arm error δr moves the true slave, not the declared arm: the slave's
/// increments are those of a scenario whose surveyed arm is `r0 + δr`, the metadata
/// still says `r0`, and the change of the slave velocity over one IMU interval is
/// the change of `C_bm^n (ω_eb^bm × δr)`, resolved in the slave body.
#[test]
fn lever_arm_error_moves_truth_not_metadata() {
    let base = quiet();
    let dr = [0.3, -0.3, 0.25];
    let mut wrong = base.clone();
    wrong.undeclared.lever_arm_error_m = dr;
    let mut surveyed = base.clone();
    surveyed.lever_arm.r0_m = [10.0 + 0.3, 4.0 - 0.3, 15.0 + 0.25];
    let (b, w, s) = (run(&base), run(&wrong), run(&surveyed));

    assert_eq!(w.meta.lever_arm_m, base.lever_arm.r0_m);
    assert_eq!(s.meta.lever_arm_m, surveyed.lever_arm.r0_m);
    assert_eq!(w.imu, s.imu);
    assert_eq!(w.master, s.master);
    assert_eq!(w.master, b.master);

    // The slave velocity changes by u(t) = C_bm^n (ω_nb^bm × δr) (moored: ω_en = 0, so
    // ω_eb = ω_nb). Over an interval the specific force integral in ENU changes by
    // Δu + 2ω_ie × u h (Coriolis) − Δg h, Δg = (0, 0, 3.086e-6 Δh) m/s² the free-air
    // change of gravity with the slave's height change Δh = (C_bm^n δr)_up. Resolved in
    // the slave body at mid-interval. Left out: the transport-rate terms (the slave
    // moves at up to 3 m/s at the end of its 18 m arm), below 4e-10 m/s per interval.
    let dr = Vector3::from(dr);
    let u = |t: f64| {
        let m = base.motion.attitude(t);
        m.c_bm_n * m.w_nb_bm.cross(&dr)
    };
    let lat = base.site.lat_deg.to_radians();
    let w_ie = Vector3::new(0.0, lat.cos(), lat.sin()) * 7.292_115e-5;
    let mu = Vector3::from(base.misalignment_deg).map(f64::to_radians);
    let h = 1.0 / base.slave_imu.rate_hz;
    let mut largest: f64 = 0.0;
    for i in (1..b.imu.len()).step_by(97) {
        let (t0, t1) = (b.imu[i - 1].t, b.imu[i].t);
        let mid = 0.5 * (t0 + t1);
        assert!((t1 - t0 - h).abs() < 1e-12);
        let c_bm_n = base.motion.attitude(mid).c_bm_n;
        let dh = (c_bm_n * dr).z;
        let f_n = u(t1) - u(t0) + (w_ie * 2.0).cross(&u(mid)) * h
            - Vector3::new(0.0, 0.0, 3.086e-6 * dh) * h;
        let expected = (c_bm_n * exp_so3(&mu)).transpose() * f_n;
        let got = Vector3::from(w.imu[i].dv_mps) - Vector3::from(b.imu[i].dv_mps);
        assert!(
            (got - expected).norm() < 1e-9,
            "interval ending {t1}: {got:?} vs {expected:?}"
        );
        largest = largest.max(expected.norm());
    }
    assert!(largest > 1e-4, "the effect is measurable: {largest}");
}

/// The wave `a sin(2π t / T)` is in the master's velocity at each stamp t, and nothing
/// else changes.
#[test]
fn velocity_wave_has_amplitude_and_phase() {
    let base = quiet();
    let mut waved = base.clone();
    let amplitude = [0.01, 0.03, -0.02];
    waved.undeclared.master_velocity_wave = Some(VelocityWave {
        amplitude_mps: amplitude,
        period_s: 37.0,
    });
    let (b, w) = (run(&base), run(&waved));
    assert_eq!(b.imu, w.imu);
    for (mb, mw) in b.master.iter().zip(&w.master) {
        let s = (2.0 * PI * mw.t / 37.0).sin();
        for (k, a) in amplitude.iter().enumerate() {
            let d = mw.v_n_mps[k] - mb.v_n_mps[k];
            assert!((d - a * s).abs() < 1e-15, "t {} axis {k}", mw.t);
        }
        assert_eq!(mb.q_bm_n, mw.q_bm_n);
        assert_eq!(mb.omega_ib_bm_radps, mw.omega_ib_bm_radps);
    }
    // A quarter period in (t = 9.25 s, stamp 925): the crest, +amplitude.
    let (mb, mw) = (&b.master[925], &w.master[925]);
    assert!((mw.t - 9.25).abs() < 1e-12);
    assert!((mw.v_n_mps[1] - mb.v_n_mps[1] - 0.03).abs() < 1e-15);
    assert!((mw.v_n_mps[0] - mb.v_n_mps[0] - 0.01).abs() < 1e-15);
}

/// Gyro g-sensitivity adds `G_si Δv` to each angle increment (`G` row by row in deg/h
/// per g) and accelerometer non-orthogonality `[xy, xz, yz]` adds `N_a Δv` to each
/// velocity increment, with `Δv` the true increment: hand-computed per component.
#[test]
fn g_sensitivity_and_accel_nonorthogonality_change_increments() {
    let base = quiet();
    let mut erred = base.clone();
    let g = [1.0, 2.0, 3.0, -4.0, 5.0, -6.0, 7.0, 8.0, 9.0];
    let [xy, xz, yz] = [100.0, -200.0, 300.0];
    erred.slave_imu.gyro_g_sensitivity_deg_h_per_g = g;
    erred.slave_imu.accel_nonorthogonality_urad = [xy, xz, yz];
    let (b, e) = (run(&base), run(&erred));
    let k = PI / 180.0 / 3600.0 / 9.80665;
    let (xy, xz, yz) = (xy * 1e-6, xz * 1e-6, yz * 1e-6);
    for i in [0, 1, 777, 3999] {
        let (sb, se) = (&b.imu[i], &e.imu[i]);
        // Without errors the quiet increments are the true ones.
        let [fx, fy, fz] = sb.dv_mps;
        let dth = [
            k * (g[0] * fx + g[1] * fy + g[2] * fz),
            k * (g[3] * fx + g[4] * fy + g[5] * fz),
            k * (g[6] * fx + g[7] * fy + g[8] * fz),
        ];
        let dv = [xy * fy + xz * fz, xy * fx + yz * fz, xz * fx + yz * fy];
        for a in 0..3 {
            let got = se.dtheta_rad[a] - sb.dtheta_rad[a];
            assert!(
                (got - dth[a]).abs() < 1e-18,
                "dθ[{a}] of {i}: {got} vs {}",
                dth[a]
            );
            assert!(dth[a].abs() > 1e-9);
            let got = se.dv_mps[a] - sb.dv_mps[a];
            assert!(
                (got - dv[a]).abs() < 1e-16,
                "dv[{a}] of {i}: {got} vs {}",
                dv[a]
            );
            assert!(dv[a].abs() > 1e-8);
        }
    }
    assert_eq!(b.master, e.master);
}

/// Every injected value is in `truth.csv`, constant, in SI units, after the 15
/// existing columns, and survives writing and reading the recording.
#[test]
fn truth_columns_hold_injected_values() {
    let mut sc = quiet();
    sc.duration_s = 2.0;
    let imu = &mut sc.slave_imu;
    imu.gyro_scale_ppm = [100.0, -200.0, 300.0];
    imu.accel_scale_ppm = [-50.0, 60.0, 70.0];
    imu.gyro_nonorthogonality_urad = [10.0, 20.0, -30.0];
    imu.accel_nonorthogonality_urad = [-40.0, 50.0, 60.0];
    imu.gyro_g_sensitivity_deg_h_per_g = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0];
    sc.undeclared.master_delay_s = 0.02;
    sc.undeclared.master_delay_rate = 1e-4;
    sc.undeclared.lever_arm_error_m = [0.3, -0.3, 0.25];
    let rec = run(&sc);
    let dir = tempfile::tempdir().unwrap();
    write_recording(dir.path(), &rec).unwrap();
    let back = read_recording(dir.path()).unwrap();
    assert_eq!(back.truth, rec.truth);
    let truth = back.truth.unwrap();

    let existing = [
        "bgx", "bgy", "bgz", "bax", "bay", "baz", "mux", "muy", "muz", "thx", "thy", "thz", "thdx",
        "thdy", "thdz",
    ];
    let k = DEG_PER_H / STANDARD_GRAVITY_MPS2;
    let added: [(&str, f64); 26] = [
        ("sgx", 100e-6),
        ("sgy", -200e-6),
        ("sgz", 300e-6),
        ("sax", -50e-6),
        ("say", 60e-6),
        ("saz", 70e-6),
        ("ngxy", 10e-6),
        ("ngxz", 20e-6),
        ("ngyz", -30e-6),
        ("naxy", -40e-6),
        ("naxz", 50e-6),
        ("nayz", 60e-6),
        ("gs11", 1.0 * k),
        ("gs12", 2.0 * k),
        ("gs13", 3.0 * k),
        ("gs21", 4.0 * k),
        ("gs22", 5.0 * k),
        ("gs23", 6.0 * k),
        ("gs31", 7.0 * k),
        ("gs32", 8.0 * k),
        ("gs33", 9.0 * k),
        ("tau", 0.02),
        ("tau_rate", 1e-4),
        ("drx", 0.3),
        ("dry", -0.3),
        ("drz", 0.25),
    ];
    let names: Vec<&str> = existing
        .iter()
        .copied()
        .chain(added.iter().map(|a| a.0))
        .collect();
    assert_eq!(truth.names, names);
    assert_eq!(truth.len(), rec.master.len());
    for (name, value) in added {
        let col = truth.column(name).unwrap();
        for &v in col {
            assert!(
                (v - value).abs() <= 1e-15 * value.abs(),
                "{name}: {v} vs {value}"
            );
        }
    }
    // The unit: 1 deg/h per g in rad/s per m/s².
    assert!((k / (PI / 180.0 / 3600.0 / 9.80665) - 1.0).abs() < 1e-15);
}

/// The biases' instability: `truth.csv`'s bias columns take steps whose variance is the
/// random walk's density² × the master period (per axis, 200 s at 100 Hz: 60 000 steps,
/// the ratio's standard error 0.6 %), and the increments carry the walked bias — the
/// IMU interval after a message holds `(b(t) − b(0)) dt` more than the same run without
/// the walk (same seed: the walk draws from a stream of its own, so nothing else moves).
#[test]
fn bias_instability_walks_the_biases_at_its_density_into_the_increments() {
    let mut steady = quiet();
    steady.duration_s = 200.0;
    steady.slave_imu.gyro_bias_deg_h = [1.0, -2.0, 3.0];
    steady.slave_imu.accel_bias_mg = [-1.0, 2.0, -3.0];
    let mut walking = steady.clone();
    walking.slave_imu.gyro_bias_rw_deg_h_rh = 36.0;
    walking.slave_imu.accel_bias_rw_mg_rh = 60.0;
    let (a, b) = (run(&steady), run(&walking));
    let truth = b.truth.as_ref().unwrap();
    let period_h = 1.0 / walking.master.rate_hz / 3600.0;
    let groups = [
        (["bgx", "bgy", "bgz"], 36.0 * DEG_PER_H),
        (["bax", "bay", "baz"], 60.0 * 9.806_65e-3),
    ];
    for (names, density) in groups {
        let steps: Vec<f64> = names
            .iter()
            .flat_map(|n| {
                let col = truth.column(n).unwrap();
                col.windows(2).map(|w| w[1] - w[0]).collect::<Vec<_>>()
            })
            .collect();
        let var = steps.iter().map(|d| d * d).sum::<f64>() / steps.len() as f64;
        let ratio = var / (density * density * period_h);
        assert!(
            (ratio - 1.0).abs() < 0.03,
            "{names:?}: variance ratio {ratio}"
        );
    }
    let dt = 1.0 / walking.slave_imu.rate_hz;
    let per_master = (walking.slave_imu.rate_hz / walking.master.rate_hz).round() as usize;
    let (bg0, ba0) = (
        Vector3::from(steady.slave_imu.gyro_bias_deg_h) * DEG_PER_H,
        Vector3::from(steady.slave_imu.accel_bias_mg) * 9.806_65e-3,
    );
    let column = |n: &str| truth.column(n).unwrap();
    for k in [1, 10, 1000, truth.len() - 2] {
        // Message k is stamped at the end of IMU interval k·per_master (index − 1); the
        // next interval (index k·per_master) runs on the bias the message reports.
        let (i, j) = (k * per_master, k);
        let (wa, wb) = (&a.imu[i], &b.imu[i]);
        for axis in 0..3 {
            let g = (wb.dtheta_rad[axis] - wa.dtheta_rad[axis]) / dt;
            let f = (wb.dv_mps[axis] - wa.dv_mps[axis]) / dt;
            let gt = column(["bgx", "bgy", "bgz"][axis])[j] - bg0[axis];
            let ft = column(["bax", "bay", "baz"][axis])[j] - ba0[axis];
            assert!(
                (g - gt).abs() < 1e-9 * gt.abs() + 1e-15,
                "gyro {axis} at {k}: {g} vs {gt}"
            );
            assert!(
                (f - ft).abs() < 1e-9 * ft.abs() + 1e-12,
                "accel {axis} at {k}: {f} vs {ft}"
            );
        }
    }
    let density = |n: &str| truth.column(n).and_then(|c| c.first().copied());
    assert_eq!(density("bg_rw"), Some(36.0 * DEG_PER_H / 60.0));
    assert_eq!(density("ba_rw"), Some(60.0 * 9.806_65e-3 / 60.0));
    assert_eq!(a.truth.as_ref().unwrap().column("bg_rw"), None);
    // Nothing else moved: the master and the rest of the truth are the same bits.
    assert_eq!(a.master, b.master);
    assert_eq!(truth.column("mux"), a.truth.as_ref().unwrap().column("mux"));
}

/// The mounting's drift: sampled every `MOUNTING_STEP_S` (60 s) and linear in between,
/// `truth.csv`'s misalignment columns take steps of variance density² × 60 s from one
/// segment to the next (6 000 s: 300 steps, the ratio's standard error 8.2 %) and lie on
/// the line between; its density is written as `mu_rw`, and the slave's gyros sense the
/// turn: between two messages, the slave's true rotation `C_bs^n = C_bm^n Exp(μ)` (no
/// flexure) less the same run's without the drift is what the two IMU increments
/// between them add less theirs (to 1 % of the turn: the increments' order and the
/// frame's rotation are second order). The master and the biases are the same bits.
#[test]
fn misalignment_drift_walks_the_mounting_and_the_gyros_sense_it() {
    let mut steady = quiet();
    steady.duration_s = 6000.0;
    steady.slave_imu.rate_hz = 100.0;
    let mut drifting = steady.clone();
    drifting.undeclared.misalignment_rw_arcmin_rh = 60.0;
    let (a, b) = (run(&steady), run(&drifting));
    let truth = b.truth.as_ref().unwrap();
    let density = 60.0f64.to_radians() / 3600.0;
    assert_eq!(
        truth.column("mu_rw").and_then(|c| c.first().copied()),
        Some(density)
    );
    let per_segment = (MOUNTING_STEP_S * drifting.master.rate_hz).round() as usize;
    let names = ["mux", "muy", "muz"];
    let mut steps = Vec::new();
    for n in names {
        let col = truth.column(n).unwrap();
        let knots: Vec<f64> = col.iter().step_by(per_segment).copied().collect();
        steps.extend(knots.windows(2).map(|w| w[1] - w[0]));
        // Between two knots, on the line.
        let (k0, k1) = (col[3 * per_segment], col[4 * per_segment]);
        let mid = col[3 * per_segment + per_segment / 4];
        assert!(
            (mid - (k0 + 0.25 * (k1 - k0))).abs() < 1e-15,
            "{n}: off the line"
        );
    }
    let var = steps.iter().map(|d| d * d).sum::<f64>() / steps.len() as f64;
    let ratio = var / (density * density * MOUNTING_STEP_S);
    assert!(
        (ratio - 1.0).abs() < 0.3,
        "variance ratio {ratio} over {} steps",
        steps.len()
    );
    // The slave's attitude at message k of run `r` (its truth: the master's, turned by μ).
    let slave = |r: &Recording, k: usize| {
        let tr = r.truth.as_ref().unwrap();
        let mu = Vector3::from_fn(|i, _| tr.column(names[i]).unwrap()[k]);
        q(&r.master[k]) * UnitQuaternion::from_scaled_axis(mu)
    };
    let per_master = (drifting.slave_imu.rate_hz / drifting.master.rate_hz).round() as usize;
    let sensed = |r: &Recording, k: usize| -> Vector3<f64> {
        (k * per_master..(k + 1) * per_master)
            .map(|i| Vector3::from(r.imu[i].dtheta_rad))
            .sum()
    };
    // Within the first 50 s: later, the two runs' mountings differ by up to a degree, and
    // the master's turn seen in the two bodies differs by that much of it, whose second
    // order (5 % of the drift's turn after 6 000 s) is not what this checks.
    for k in [1, 100, 1000, 5000] {
        let turn = |r: &Recording| (slave(r, k).inverse() * slave(r, k + 1)).scaled_axis();
        let moved = turn(&b) - turn(&a);
        let felt = sensed(&b, k) - sensed(&a, k);
        assert!(
            (felt - moved).norm() < 0.01 * moved.norm(),
            "message {k}: the gyros felt {felt:?}, the slave turned {moved:?}"
        );
    }
    assert_eq!(a.master, b.master);
    let at = a.truth.as_ref().unwrap();
    assert_eq!(truth.column("bgx"), at.column("bgx"));
    assert_eq!(at.column("mu_rw"), None);
}

/// The scenario files with one undeclared effect load, and differ from `moored` only
/// by name and that effect.
#[test]
fn scenario_files_load() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenarios/");
    let moored = Scenario::load("moored").unwrap();
    let load = |file: &str| Scenario::load(&format!("{dir}{file}")).unwrap();

    let mut expected = moored.clone();
    expected.name = "moored-delay-20ms".into();
    expected.undeclared.master_delay_s = 0.02;
    assert_eq!(load("moored-delay-20ms.toml"), expected);

    let mut expected = moored.clone();
    expected.name = "moored-clock-drift".into();
    expected.duration_s = 300.0;
    expected.undeclared.master_delay_rate = 0.025 / 300.0;
    assert_eq!(load("moored-clock-drift.toml"), expected);

    let mut expected = moored.clone();
    expected.name = "moored-lever-error".into();
    expected.undeclared.lever_arm_error_m = [0.3, -0.3, 0.25];
    assert_eq!(load("moored-lever-error.toml"), expected);

    let mut expected = moored.clone();
    expected.name = "moored-wave".into();
    expected.undeclared.master_velocity_wave = Some(VelocityWave {
        amplitude_mps: [0.0, 0.03, 0.0],
        period_s: 37.0,
    });
    assert_eq!(load("moored-wave.toml"), expected);

    let mut expected = moored.clone();
    expected.name = "moored-delay-onset".into();
    expected.duration_s = 240.0;
    expected.undeclared.master_delay_s = 0.02;
    expected.undeclared.master_delay_from_s = Some(120.0);
    assert_eq!(load("moored-delay-onset.toml"), expected);
}

/// Values a simulation cannot run with are refused, naming the key; unknown keys in
/// `[undeclared]` are refused by the parser.
#[test]
fn undeclared_values_are_validated() {
    let check = |edit: &dyn Fn(&mut Scenario), key: &str| {
        let mut sc = Scenario::load("moored").unwrap();
        edit(&mut sc);
        let err = sc.validate().unwrap_err();
        assert!(err.contains(key), "{err}");
    };
    // A negative delay is a master early on the slave (a clock offset), down to −1 s.
    for tau in [-1.001, 1.5, f64::NAN, f64::INFINITY] {
        check(
            &|sc| sc.undeclared.master_delay_s = tau,
            "`undeclared.master_delay_s`",
        );
    }
    for rate in [-0.0101, 0.02, f64::NAN] {
        check(
            &|sc| sc.undeclared.master_delay_rate = rate,
            "`undeclared.master_delay_rate`",
        );
    }
    for from in [-0.5, f64::NAN, f64::INFINITY] {
        check(
            &|sc| sc.undeclared.master_delay_from_s = Some(from),
            "`undeclared.master_delay_from_s`",
        );
    }
    check(
        &|sc| sc.undeclared.lever_arm_error_m = [0.0, f64::NAN, 0.0],
        "`undeclared.lever_arm_error_m`",
    );
    for period_s in [0.0, -1.0, f64::NAN] {
        check(
            &|sc| {
                sc.undeclared.master_velocity_wave = Some(VelocityWave {
                    amplitude_mps: [0.0, 0.03, 0.0],
                    period_s,
                })
            },
            "`undeclared.master_velocity_wave.period_s`",
        );
    }
    check(
        &|sc| {
            sc.undeclared.master_velocity_wave = Some(VelocityWave {
                amplitude_mps: [0.0, f64::INFINITY, 0.0],
                period_s: 37.0,
            })
        },
        "`undeclared.master_velocity_wave.amplitude_mps`",
    );
    let mut sc = Scenario::load("moored").unwrap();
    sc.undeclared.master_delay_s = 1.0;
    assert!(sc.validate().is_ok());

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.toml");
    let text = include_str!("../../scenarios/moored.toml");
    std::fs::write(&path, format!("{text}\n[undeclared]\nmaster_delay = 0.1\n")).unwrap();
    assert!(Scenario::load(path.to_str().unwrap()).is_err());
    std::fs::write(
        &path,
        format!("{text}\n[undeclared]\nmaster_delay_s = 2.0\n"),
    )
    .unwrap();
    let err = Scenario::load(path.to_str().unwrap()).unwrap_err();
    assert!(err.contains("`undeclared.master_delay_s`"), "{err}");
}

/// FNV-1a over the bits of each value: a digest that does not change between Rust
/// releases (unlike `DefaultHasher`).
fn fnv(h: &mut u64, x: f64) {
    for b in x.to_bits().to_le_bytes() {
        *h ^= u64::from(b);
        *h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
}

/// Digests of the IMU samples, the master messages and the truth's first 15 columns.
fn digests(rec: &Recording) -> [u64; 3] {
    const START: u64 = 0xcbf2_9ce4_8422_2325;
    let mut imu = START;
    for s in &rec.imu {
        fnv(&mut imu, s.t);
        s.dtheta_rad
            .iter()
            .chain(&s.dv_mps)
            .for_each(|&x| fnv(&mut imu, x));
    }
    let mut master = START;
    for m in &rec.master {
        let position = [m.lat_deg, m.lon_deg, m.height_m];
        fnv(&mut master, m.t);
        m.q_bm_n
            .iter()
            .chain(&m.v_n_mps)
            .chain(&position)
            .chain(m.omega_ib_bm_radps.iter().flatten())
            .for_each(|&x| fnv(&mut master, x));
    }
    let mut truth = START;
    let table = rec.truth.as_ref().unwrap();
    table.t.iter().for_each(|&x| fnv(&mut truth, x));
    for column in table.columns.iter().take(15) {
        column.iter().for_each(|&x| fnv(&mut truth, x));
    }
    [imu, master, truth]
}

/// The built-ins (no `[undeclared]`, no g-sensitivity, no accelerometer
/// non-orthogonality) simulate bit for bit what they did before these effects
/// existed. Digests captured on x86-64 Linux before the change; they depend on the
/// platform's `sin`/`cos`, so a new platform may need them captured again.
#[test]
fn built_ins_are_bit_identical_to_before() {
    let cases = [
        (
            "moored",
            7,
            [0xe179d52c8e9f879c, 0xc2015e97d8258fbb, 0x3a29770047a3b1b6],
        ),
        (
            "paper",
            3,
            [0x461e53588986dc6a, 0x621ad06271f540ad, 0x166dc7d0f514d583],
        ),
        (
            "matched",
            5,
            [0x5cb548db043edd99, 0xca2fe38b6c327c28, 0x1ea3a915c07b1d3c],
        ),
    ];
    for (name, seed, expected) in cases {
        let mut sc = Scenario::load(name).unwrap();
        sc.duration_s = 20.0;
        let got = digests(&simulate(&sc, seed).recording);
        assert_eq!(got, expected, "{name}: {got:#018x?}");
    }
}
