//! The desk's speed (issue 12, acceptance 4): criterion benchmarks of the engine's step on
//! its own, of `calibrate`'s run and of the simulator, on the built-in `moored` scenario
//! (seed 1, the model it declares). Figures and how to read them: docs/performance.md,
//! "The desk".
//!
//! ```sh
//! cargo bench -p flexcal-sim --bench desk
//! ```
//!
//! - `engine/moored_10s_f64`, `…_f32`: 10 s of `moored` (2 000 IMU samples, 1 000 master
//!   updates) pushed through a new [`Engine`] (21 states), inputs converted beforehand:
//!   the filter alone, without the calibrator's reports.
//! - `calibrate/moored_60s_f64`: [`run`] on 60 s, in memory: `calibrate` without reading
//!   and writing its files.
//! - `simulate/moored_60s`: [`simulate`] of 60 s (the truth, the slave's IMU and the
//!   master's messages).

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use flexcal_core::engine::{Engine, ImuIncrement, MasterNav, StepReports};
use flexcal_core::real::Real;
use flexcal_sim::calib::config::CalibConfig;
use flexcal_sim::calib::run::{master_nav, run, Precision};
use flexcal_sim::recording::Recording;
use flexcal_sim::sim::{simulate, Scenario};
use nalgebra::Vector3;
use std::hint::black_box;
use std::time::Duration;

/// `moored`, cut to `seconds`, simulated with seed 1, and the configuration it declares.
fn moored(seconds: f64) -> (Scenario, Recording, CalibConfig) {
    let mut sc = Scenario::load("moored").expect("the built-in scenario");
    sc.duration_s = seconds;
    let rec = simulate(&sc, 1).recording;
    let cfg = CalibConfig::declared_for(&sc, 0.01);
    (sc, rec, cfg)
}

/// One input of the engine, in the order the calibrator hands them over.
enum Input<T: Real> {
    Imu(ImuIncrement<T>),
    Master(MasterNav<T>),
}

/// The recording's samples and messages in the calibrator's order: each master message
/// after the first IMU sample at or past its time.
fn inputs<T: Real>(rec: &Recording) -> Vec<Input<T>> {
    let mut out = vec![Input::Imu(ImuIncrement {
        t: rec.imu_t0,
        dtheta_b: Vector3::zeros(),
        dv_b: Vector3::zeros(),
    })];
    let mut masters = rec.master.iter().filter(|m| m.t >= rec.imu_t0).peekable();
    for s in &rec.imu {
        out.push(Input::Imu(ImuIncrement {
            t: s.t,
            dtheta_b: Vector3::from(s.dtheta_rad.map(T::of)),
            dv_b: Vector3::from(s.dv_mps.map(T::of)),
        }));
        while let Some(m) = masters.next_if(|m| m.t <= s.t) {
            out.push(Input::Master(master_nav(m)));
        }
    }
    out
}

fn engine_step<T: Real>(c: &mut Criterion, name: &str) {
    let (_, rec, cfg) = moored(10.0);
    let inputs = inputs::<T>(&rec);
    let config = cfg.engine_config::<T>(rec.meta.lever_arm_m);
    c.bench_function(name, |b| {
        b.iter_batched_ref(
            || Engine::<T>::new(config).expect("the declared configuration"),
            |engine| {
                let mut reports = StepReports::new();
                for input in &inputs {
                    let _ = match input {
                        Input::Imu(i) => engine.push_imu(*i, &mut reports),
                        Input::Master(m) => engine.push_master(*m, &mut reports),
                    };
                    black_box(&reports);
                }
            },
            BatchSize::LargeInput,
        )
    });
}

fn engine(c: &mut Criterion) {
    engine_step::<f64>(c, "engine/moored_10s_f64");
    engine_step::<f32>(c, "engine/moored_10s_f32");
}

fn calibrate(c: &mut Criterion) {
    let (_, rec, cfg) = moored(60.0);
    c.bench_function("calibrate/moored_60s_f64", |b| {
        b.iter(|| run(black_box(&rec), &cfg, Precision::F64).expect("calibration"))
    });
}

fn simulator(c: &mut Criterion) {
    let (sc, _, _) = moored(60.0);
    c.bench_function("simulate/moored_60s", |b| {
        b.iter(|| simulate(black_box(&sc), 1))
    });
}

criterion_group! {
    name = desk;
    // Runs of 10–100 ms each: ten samples in six seconds (enough for the 55 runs that ten
    // samples of a 0.1 s run take) keep the whole under a minute.
    config = Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(6));
    targets = engine, calibrate, simulator
}
criterion_main!(desk);
