//! DIAGNOSTIC (temporary)
use flexcal_core::earth::Position;
use flexcal_core::real::Real;
use flexcal_core::rotation::{quat_exp, quat_log};
use flexcal_core::strapdown::{Increments, NavState, Strapdown};
use flexcal_sim::sim::{simulate, Scenario};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};

fn nav0<T: Real>(m: &flexcal_sim::recording::MasterMsg) -> NavState<T> {
    let q = m.q_bm_n.map(T::of);
    NavState {
        q_b_n: UnitQuaternion::new_normalize(Quaternion::new(q[0], q[1], q[2], q[3])),
        v_n: Vector3::from(m.v_n_mps.map(T::of)),
        pos: Position {
            lat_rad: T::of(m.lat_deg.to_radians()),
            lon_rad: T::of(m.lon_deg.to_radians()),
            height_m: T::of(m.height_m),
        },
    }
}

fn q64<T: Real>(q: &UnitQuaternion<T>) -> UnitQuaternion<f64> {
    UnitQuaternion::new_unchecked(Quaternion::new(
        q.w.to_f64(),
        q.i.to_f64(),
        q.j.to_f64(),
        q.k.to_f64(),
    ))
}

#[test]
#[ignore]
fn diag_strapdown() {
    let sc = Scenario::load("moored").unwrap();
    let rec = simulate(&sc, 1).recording;
    let bg = [0.2f64, -0.2, 0.2].map(|v| v * std::f64::consts::PI / 180.0 / 3600.0);
    let m0 = &rec.master[0];
    let mut s64 = Strapdown::<f64>::new(nav0(m0));
    let mut s32 = Strapdown::<f32>::new(nav0(m0));
    // attitude-only replicas: body-only and earth-only in f32 vs f64
    let mut qa64 = s64.nav.q_b_n;
    let mut qa32 = s32.nav.q_b_n;
    let mut qe64 = s64.nav.q_b_n;
    let mut qe32 = s32.nav.q_b_n;
    let mut t_prev = rec.imu_t0;
    let mut k = 0;
    let w_ie = flexcal_core::earth::earth_rate_n(s64.nav.pos.lat_rad);
    for s in &rec.imu {
        if s.t <= m0.t {
            t_prev = s.t;
            continue;
        }
        let dt = s.t - t_prev;
        t_prev = s.t;
        let dth = Vector3::from(s.dtheta_rad) - Vector3::from(bg) * dt;
        let inc64 = Increments {
            dtheta_b: dth,
            dv_b: Vector3::from(s.dv_mps),
            dt,
        };
        let inc32 = Increments {
            dtheta_b: dth.map(|v| v as f32),
            dv_b: inc64.dv_b.map(|v| v as f32),
            dt: dt as f32,
        };
        s64.step(&inc64);
        s32.step(&inc32);
        qa64 *= quat_exp(&dth);
        qa64.renormalize_fast();
        qa32 *= quat_exp(&inc32.dtheta_b);
        qa32.renormalize_fast();
        let z = w_ie * dt;
        qe64 = quat_exp(&(-z)) * qe64;
        qe64.renormalize_fast();
        qe32 = quat_exp(&(-z.map(|v| v as f32))) * qe32;
        qe32.renormalize_fast();
        k += 1;
        if k % 12000 == 0 {
            let d = quat_log(&(s64.nav.q_b_n.inverse() * q64(&s32.nav.q_b_n)));
            let da = quat_log(&(qa64.inverse() * q64(&qa32)));
            let de = quat_log(&(qe64.inverse() * q64(&qe32)));
            let dv = s32.nav.v_n.map(|v| v as f64) - s64.nav.v_n;
            println!("t={:6.1} full dpsi_b={:+.2e} {:+.2e} {:+.2e} | body-only {:+.2e} {:+.2e} {:+.2e} | earth-only {:+.2e} {:+.2e} {:+.2e} | dv {:+.2e} {:+.2e} {:+.2e}",
                s.t, d.x, d.y, d.z, da.x, da.y, da.z, de.x, de.y, de.z, dv.x, dv.y, dv.z);
        }
    }
}

#[test]
#[ignore]
fn diag_gravity() {
    let lat = 37.5f64.to_radians();
    let g64 = flexcal_core::earth::normal_gravity(lat, 0.0);
    let g32 = flexcal_core::earth::normal_gravity(lat as f32, 0.0f32);
    println!("g64 {g64} g32 {g32} diff {:e}", g32 as f64 - g64);
    let w64 = flexcal_core::earth::earth_rate_n(lat);
    let w32 = flexcal_core::earth::earth_rate_n(lat as f32);
    println!(
        "w diff {:e} {:e}",
        w32.y as f64 - w64.y,
        w32.z as f64 - w64.z
    );
}

#[test]
#[ignore]
fn diag_gravity_lat() {
    let mut worst: f64 = 0.0;
    let mut sum = 0.0;
    let mut n = 0.0;
    for i in 0..900 {
        let lat = (i as f64 * 0.1).to_radians();
        let g64 = flexcal_core::earth::normal_gravity(lat, 0.0);
        let g32 = flexcal_core::earth::normal_gravity(lat as f32, 0.0f32);
        let e = (g32 * 0.005f32) as f64 / 0.005 - g64;
        worst = worst.max(e.abs());
        sum += e * e;
        n += 1.0;
        if i % 75 == 0 {
            println!("lat {:5.1} err {:+.2e}", i as f64 * 0.1, e);
        }
    }
    println!("worst {worst:e} rms {:e}", (sum / n).sqrt());
}
