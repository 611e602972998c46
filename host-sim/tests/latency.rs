//! Time alignment under link latency: master messages matched at their time of
//! validity give the *same* estimates whether they reach the engine at once, a
//! fixed 50 ms late, or with random jitter up to 250 ms (within the engine's
//! IMU hold of 64 samples = 0.32 s at 200 Hz).

use flexcal_core::earth::Position;
use flexcal_core::engine::{Engine, Estimates, ImuIncrement, MasterNav, StepReports};
use flexcal_sim::calib::config::CalibConfig;
use flexcal_sim::recording::Recording;
use flexcal_sim::sim::{simulate, Scenario};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};

fn master(m: &flexcal_sim::recording::MasterMsg) -> MasterNav<f64> {
    let q = m.q_bm_n;
    MasterNav {
        t: m.t,
        q_bm_n: UnitQuaternion::new_normalize(Quaternion::new(q[0], q[1], q[2], q[3])),
        v_n: Vector3::from(m.v_n_mps),
        pos: Position {
            lat_rad: m.lat_deg.to_radians(),
            lon_rad: m.lon_deg.to_radians(),
            height_m: m.height_m,
        },
        w_ib_bm: m.omega_ib_bm_radps.map(Vector3::from),
    }
}

/// Runs the engine with each master message handed over once the IMU stream has
/// passed `t_v + delay(k)` (delays must keep the messages in order).
fn run(rec: &Recording, cfg: &CalibConfig, delay: impl Fn(usize) -> f64) -> (Estimates<f64>, u32) {
    let mut e = Engine::<f64>::new(cfg.engine_config::<f64>(rec.meta.lever_arm_m)).unwrap();
    e.push_imu(
        ImuIncrement {
            t: rec.imu_t0,
            dtheta_b: Vector3::zeros(),
            dv_b: Vector3::zeros(),
        },
        &mut StepReports::new(),
    )
    .unwrap();
    let mut next = 0;
    for s in &rec.imu {
        e.push_imu(
            ImuIncrement {
                t: s.t,
                dtheta_b: Vector3::from(s.dtheta_rad),
                dv_b: Vector3::from(s.dv_mps),
            },
            &mut StepReports::new(),
        )
        .unwrap();
        while let Some(m) = rec.master.get(next) {
            if m.t + delay(next) > s.t {
                break;
            }
            e.push_master(master(m), &mut StepReports::new()).unwrap();
            next += 1;
        }
    }
    for m in &rec.master[next..] {
        e.push_master(master(m), &mut StepReports::new()).unwrap();
    }
    e.flush(&mut StepReports::new());
    (e.estimates(), e.counters().master_matched)
}

#[test]
fn estimates_do_not_depend_on_master_latency() {
    let mut sc = Scenario::load("moored").unwrap();
    sc.duration_s = 60.0;
    let rec = simulate(&sc, 7).recording;
    let cfg = CalibConfig::declared_for(&sc, 0.01);
    let (prompt, n0) = run(&rec, &cfg, |_| 0.0);
    let (late, n1) = run(&rec, &cfg, |_| 0.05);
    // Jitter that keeps the order: a random delay, never less than the previous one
    // minus the master period.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let jitter: Vec<f64> = (0..rec.master.len())
        .map(|_| rng.gen_range(0.0..0.25))
        .collect();
    let mut ordered = jitter.clone();
    for k in 1..ordered.len() {
        ordered[k] = ordered[k].max(ordered[k - 1] - 0.01);
    }
    let (jittered, n2) = run(&rec, &cfg, |k| ordered[k]);
    assert_eq!(
        n0,
        rec.master.len() as u32 - 1,
        "every message but the first (it initializes) is matched"
    );
    assert_eq!((n1, n2), (n0, n0));
    for other in [&late, &jittered] {
        assert_eq!(prompt.gyro_bias, other.gyro_bias);
        assert_eq!(prompt.accel_bias, other.accel_bias);
        assert_eq!(prompt.misalignment, other.misalignment);
        assert_eq!(prompt.gyro_bias_sigma, other.gyro_bias_sigma);
    }
}
