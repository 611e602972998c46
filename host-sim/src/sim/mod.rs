//! The truth simulator: a master INS on a rocking (and optionally moving) ship, a
//! slave IMU at the end of a lever arm that flexure bends, the slave's sensor errors,
//! and the recording (format v1, with `truth.csv`) both would have produced.
//!
//! Truth is built from closed-form kinematics on a fine grid (`SUBSTEPS` per IMU
//! interval), then integrated into increments, so the slave's strapdown sees what a
//! real IMU would: the angular-rate and specific-force integrals, not samples.
//!
//! Effects the filter's model does not declare (scale factors, non-orthogonality,
//! g-sensitivity, master delay, lever-arm error, master velocity wave, a master
//! attitude that steps at its corrections) are injected
//! here when the scenario asks for them, and their values are written to `truth.csv`
//! as constant columns, so a diagnosis can be scored against them (the master's steps,
//! which are not constant, are in the scenario itself: `sim::master_steps`). The
//! biases' instability and the mounting's drift (random walks, `RandomWalk3`) are in
//! the biases' and the misalignment's own columns, which `truth.csv` carries at every
//! master message, and their densities in constant columns.

pub mod blind;
pub mod flexure;
pub mod master_steps;
pub mod motion;
pub mod scenario;

use crate::recording::{ImuOutput, ImuSample, MasterMsg, Recording, RecordingMeta, Site, Truth};
use flexcal_core::earth::{Local, Position};
use flexcal_core::model::LeverBending;
use flexcal_core::rotation::{exp_so3, quat_exp, right_jacobian};
use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
pub use scenario::{
    AttitudeStep, AttitudeSteps, Bending, FlexureSpec, Scenario, SmoothError, Undeclared,
    VelocityWave,
};
use std::f64::consts::PI;

/// The mounting's drift is a random walk sampled every this many seconds (rounded to
/// whole IMU intervals) and linear in between: quasi-static, as a thermal bending is.
/// Its rate is `δ/T` with `δ ~ q √T`: stepped at every IMU interval, a walk of 4.8e-5
/// rad/√s turned the slave at a white 140 °/h, which the rate matching saw as noise and
/// no thermal drift makes; on a 10 s grid blind draws of 0.5–5′ over 300 s turned it at
/// up to 5.5 °/h, steps the bias walks fit (named on 4 of 10 draws); at 60 s, up
/// to 2.3 °/h.
pub const MOUNTING_STEP_S: f64 = 60.0;

/// Fine sub-steps per IMU interval for the truth integrals.
pub const SUBSTEPS: usize = 10;
/// One milli-g (m/s²).
pub const MG: f64 = 9.806_65e-3;
/// One degree per hour (rad/s).
pub const DEG_PER_H: f64 = std::f64::consts::PI / 180.0 / 3600.0;
/// Standard gravity g (m/s²), the unit of the gyro g-sensitivity (deg/h per g).
pub const STANDARD_GRAVITY_MPS2: f64 = 9.806_65;

impl Bending {
    /// The core's bending model.
    pub fn model(self) -> LeverBending {
        match self {
            Bending::Paper => LeverBending::Paper,
            Bending::UniformArc => LeverBending::UniformArc,
        }
    }
}

/// The slave's true state at one instant.
pub struct SlaveTruth {
    /// True slave attitude `C_bs^n`.
    pub c_bs_n: Matrix3<f64>,
    /// True slave rate `ω_ib^bs` (rad/s).
    pub w_ib_bs: Vector3<f64>,
    /// True slave velocity, ENU (m/s).
    pub v_n: Vector3<f64>,
    /// True slave position.
    pub pos: Position<f64>,
}

/// Constant parts of the truth.
pub struct Fixed {
    /// Mounting misalignment μ (rad).
    pub mu: Vector3<f64>,
    /// True static lever arm r0, master body (m): the surveyed arm plus the scenario's
    /// `undeclared.lever_arm_error_m`.
    pub r0: Vector3<f64>,
    /// Bending matrix R of r = r0 + Rθ, from the true r0 (m/rad).
    pub r_bend: Matrix3<f64>,
    /// Master velocity, ENU (m/s).
    pub v_m: Vector3<f64>,
}

/// The slave's true attitude, rate, velocity and position, given the master's
/// attitude and position and the flexure angle and (left-limit) rate.
pub fn slave_truth(
    fx: &Fixed,
    master: &motion::MasterAttitude,
    pos_m: &Position<f64>,
    theta: &Vector3<f64>,
    theta_rate: &Vector3<f64>,
) -> SlaveTruth {
    slave_truth_at(fx, master, &Local::at(pos_m), theta, theta_rate, None)
}

/// The mounting misalignment at one instant when it drifts (`MOUNTING_STEP_S`): its
/// value (rad) and its rate (rad/s), which the slave's gyros sense as the flexure's.
struct Mounting {
    mu: Vector3<f64>,
    mu_rate: Vector3<f64>,
}

/// [`slave_truth`] with the Earth model at the master's position (`earth_m`: its trig
/// evaluated once, the free functions' values bit for bit in `f64`), for the simulator's
/// sub-steps, which share one position; `mounting`: a drifting misalignment in place of
/// `fx.mu`.
fn slave_truth_at(
    fx: &Fixed,
    master: &motion::MasterAttitude,
    earth_m: &Local<f64>,
    theta: &Vector3<f64>,
    theta_rate: &Vector3<f64>,
    mounting: Option<&Mounting>,
) -> SlaveTruth {
    let phi = mounting.map_or(fx.mu, |m| m.mu) + theta;
    // The body turns with the flexure and with the mounting's drift.
    let turn_rate = mounting.map_or(*theta_rate, |m| theta_rate + m.mu_rate);
    let c_bs_bm = exp_so3(&phi);
    let w_ie = earth_m.earth_rate_n();
    let w_en = earth_m.transport_rate_n(&fx.v_m);
    let c_n_bm = master.c_bm_n.transpose();
    let w_ib_bm = master.w_nb_bm + c_n_bm * (w_ie + w_en);
    let w_eb_bm = master.w_nb_bm + c_n_bm * w_en;
    // r = r0 + Rθ, ṙ = R θ̇, v_s = v_m + C_bm^n (ω_eb × r + ṙ).
    let r = fx.r0 + fx.r_bend * theta;
    let v_n = fx.v_m + master.c_bm_n * (w_eb_bm.cross(&r) + fx.r_bend * theta_rate);
    SlaveTruth {
        c_bs_n: master.c_bm_n * c_bs_bm,
        w_ib_bs: c_bs_bm.transpose() * w_ib_bm + right_jacobian(&phi) * turn_rate,
        v_n,
        pos: earth_m.offset_position(&(master.c_bm_n * r)),
    }
}

/// Whether two positions are the same bits (`==` would take −0 for +0, whose sines
/// differ in sign): the Earth model of one serves the other.
fn same_bits(a: &Position<f64>, b: &Position<f64>) -> bool {
    a.lat_rad.to_bits() == b.lat_rad.to_bits()
        && a.lon_rad.to_bits() == b.lon_rad.to_bits()
        && a.height_m.to_bits() == b.height_m.to_bits()
}

/// What a simulation produced.
pub struct SimOutput {
    /// The recording (with truth).
    pub recording: Recording,
}

/// The slave IMU's deterministic errors in SI units.
struct ImuErrors {
    /// Gyro bias (rad/s).
    bg: Vector3<f64>,
    /// Accelerometer bias (m/s²).
    ba: Vector3<f64>,
    /// Gyro scale factors (dimensionless).
    sg: Vector3<f64>,
    /// Accelerometer scale factors (dimensionless).
    sa: Vector3<f64>,
    /// Gyro non-orthogonality `[xy, xz, yz]` (rad).
    ng: [f64; 3],
    /// Accelerometer non-orthogonality `[xy, xz, yz]` (rad).
    na: [f64; 3],
    /// Gyro g-sensitivity `G_si` (rad/s per m/s²).
    g_si: Matrix3<f64>,
    /// Gyro bias random walk density (rad/s/√s; zero: a constant bias).
    bg_rw: f64,
    /// Accelerometer bias random walk density (m/s²/√s).
    ba_rw: f64,
}

/// The symmetric non-orthogonality matrix of `[xy, xz, yz]`.
fn nonorthogonality([xy, xz, yz]: [f64; 3]) -> Matrix3<f64> {
    Matrix3::new(0.0, xy, xz, xy, 0.0, yz, xz, yz, 0.0)
}

impl ImuErrors {
    fn new(imu: &scenario::ImuSpec) -> Self {
        Self {
            bg: Vector3::from(imu.gyro_bias_deg_h) * DEG_PER_H,
            ba: Vector3::from(imu.accel_bias_mg) * MG,
            sg: Vector3::from(imu.gyro_scale_ppm) * 1e-6,
            sa: Vector3::from(imu.accel_scale_ppm) * 1e-6,
            ng: imu.gyro_nonorthogonality_urad.map(|v| v * 1e-6),
            na: imu.accel_nonorthogonality_urad.map(|v| v * 1e-6),
            g_si: Matrix3::from_row_slice(&imu.gyro_g_sensitivity_deg_h_per_g)
                * (DEG_PER_H / STANDARD_GRAVITY_MPS2),
            // Per √h → per √s: ÷ 60.
            bg_rw: imu.gyro_bias_rw_deg_h_rh * DEG_PER_H / 60.0,
            ba_rw: imu.accel_bias_rw_mg_rh * MG / 60.0,
        }
    }

    /// `I + S_g + N_g`: what the gyro makes of a true angle increment.
    fn gyro_matrix(&self) -> Matrix3<f64> {
        Matrix3::identity() + Matrix3::from_diagonal(&self.sg) + nonorthogonality(self.ng)
    }

    /// `I + S_a + N_a`: what the accelerometer makes of a true velocity increment.
    fn accel_matrix(&self) -> Matrix3<f64> {
        Matrix3::identity() + Matrix3::from_diagonal(&self.sa) + nonorthogonality(self.na)
    }
}

/// The truth columns that are constant in time, by name: the slave IMU's scale
/// factors (`sg*`, `sa*`), non-orthogonality (`ng*`, `na*`, rad), gyro g-sensitivity
/// (`gs11`..`gs33` row by row, rad/s per m/s²), the master delay at t = 0 (`tau`, s)
/// and its rate (`tau_rate`, s/s), the lever-arm error (`dr*`, m, master body), the
/// delay's onset (`tau_from`, s) when it does not start with the recording, and the
/// biases' random walk densities (`bg_rw`, rad/s/√s; `ba_rw`, m/s²/√s) and the
/// mounting's (`mu_rw`, rad/√s) when they walk.
fn constant_truth(e: &ImuErrors, und: &Undeclared, mu_rw: f64) -> Vec<(&'static str, f64)> {
    const GS: [&str; 9] = [
        "gs11", "gs12", "gs13", "gs21", "gs22", "gs23", "gs31", "gs32", "gs33",
    ];
    let vec3 = |names: [&'static str; 3], v: [f64; 3]| names.into_iter().zip(v);
    vec3(["sgx", "sgy", "sgz"], e.sg.into())
        .chain(vec3(["sax", "say", "saz"], e.sa.into()))
        .chain(vec3(["ngxy", "ngxz", "ngyz"], e.ng))
        .chain(vec3(["naxy", "naxz", "nayz"], e.na))
        // nalgebra stores column by column: transpose to read G row by row.
        .chain(GS.into_iter().zip(e.g_si.transpose().iter().copied()))
        .chain([
            ("tau", und.master_delay_s),
            ("tau_rate", und.master_delay_rate),
        ])
        .chain(vec3(["drx", "dry", "drz"], und.lever_arm_error_m))
        // The delay's onset, when it does not start with the recording (`tau` from then).
        .chain(und.master_delay_from_s.map(|from| ("tau_from", from)))
        .chain((e.bg_rw > 0.0).then_some(("bg_rw", e.bg_rw)))
        .chain((e.ba_rw > 0.0).then_some(("ba_rw", e.ba_rw)))
        .chain((mu_rw > 0.0).then_some(("mu_rw", mu_rw)))
        .collect()
}

/// The master's smooth error (`scenario::SmoothError`) as it evolves message by
/// message, from a random stream of its own (the white noises' draws are the same
/// with or without it).
struct SmoothMasterError {
    rng: ChaCha8Rng,
    /// `e^{−T/τ}`.
    decay: f64,
    /// Stationary σ of the attitude (rad) and velocity (m/s) errors.
    sigma: (f64, f64),
    /// Current attitude error, navigation frame (rad), and velocity error, ENU (m/s).
    state: (Vector3<f64>, Vector3<f64>),
}

impl SmoothMasterError {
    fn new(e: &scenario::SmoothError, period_s: f64, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5a5a_0f0f_3c3c_9696);
        let sigma = ((e.attitude_arcsec / 3600.0).to_radians(), e.velocity_mps);
        let state = (gauss3(&mut rng, sigma.0), gauss3(&mut rng, sigma.1));
        Self {
            rng,
            decay: (-period_s / e.correlation_s).exp(),
            sigma,
            state,
        }
    }

    /// The error of the next message: (attitude, velocity).
    fn next(&mut self) -> (Vector3<f64>, Vector3<f64>) {
        let now = self.state;
        let k = (1.0 - self.decay * self.decay).sqrt();
        self.state = (
            now.0 * self.decay + gauss3(&mut self.rng, self.sigma.0 * k),
            now.1 * self.decay + gauss3(&mut self.rng, self.sigma.1 * k),
        );
        now
    }
}

/// A quantity that wanders as a Wiener process per axis (a bias's instability, a
/// mounting's drift), stepped once per its interval (an IMU interval for the biases, a
/// `MOUNTING_STEP_S` segment for the mounting) from a random stream of its own (the
/// white noises' draws and the other walks' are the same with or without it); constant,
/// and drawing nothing, where its density is zero.
struct RandomWalk3 {
    rng: ChaCha8Rng,
    /// σ of one interval's step.
    step: f64,
    /// The value at the current interval's start.
    value: Vector3<f64>,
}

impl RandomWalk3 {
    /// From `initial`, at `density` per √s, stepped every `dt_s`; `stream` tells the
    /// walks of one seed apart.
    fn new(initial: Vector3<f64>, density: f64, dt_s: f64, seed: u64, stream: u64) -> Self {
        Self {
            rng: ChaCha8Rng::seed_from_u64(seed ^ stream),
            step: density * dt_s.sqrt(),
            value: initial,
        }
    }

    /// The step of the current interval (zero without a walk); the value moves to the
    /// next interval's start.
    fn step(&mut self) -> Vector3<f64> {
        let d = if self.step > 0.0 {
            gauss3(&mut self.rng, self.step)
        } else {
            Vector3::zeros()
        };
        self.value += d;
        d
    }
}

fn gauss3(rng: &mut impl Rng, sigma: f64) -> Vector3<f64> {
    Vector3::from_fn(|_, _| sigma * rng.sample::<f64, _>(StandardNormal))
}

/// Runs the scenario with a seed.
///
/// With `undeclared.master_delay_s` = τ > 0 the master message stamped `t` is the
/// master truth at `t − τ`, from the closed-form motion (attitude, rate), the
/// constant velocity, and the position at `t` moved back by `v τ`; with a clock drift
/// (`master_delay_rate` = τ̇) the delay is `τ + τ̇ t`; with `master_delay_from_s` the
/// messages stamped before that time are on time. The first messages,
/// whose `t − τ` is negative, are emitted too: the motion is defined for all times.
pub fn simulate(sc: &Scenario, seed: u64) -> SimOutput {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let imu_dt = 1.0 / sc.slave_imu.rate_hz;
    let h = imu_dt / SUBSTEPS as f64;
    let n_imu = (sc.duration_s * sc.slave_imu.rate_hz).round() as usize;
    let imu_per_master = (sc.slave_imu.rate_hz / sc.master.rate_hz).round() as usize;
    let substeps = n_imu * SUBSTEPS;
    let flex = flexure::FlexureTruth::generate(&sc.flexure, substeps, h, &mut rng);
    let und = &sc.undeclared;
    let r0 = Vector3::from(sc.lever_arm.r0_m) + Vector3::from(und.lever_arm_error_m);
    let fx = Fixed {
        mu: Vector3::from(sc.misalignment_deg).map(f64::to_radians),
        r0,
        r_bend: sc.lever_arm.bending.model().matrix(&r0),
        v_m: sc.motion.velocity_n(),
    };
    let imu = &sc.slave_imu;
    let err = ImuErrors::new(imu);
    // The increment of an interval takes the biases at its start; the mounting drifts
    // linearly across each of its segments (`MOUNTING_STEP_S`, `Mounting`), continuous
    // from one to the next.
    let mut gyro_bias = RandomWalk3::new(err.bg, err.bg_rw, imu_dt, seed, 0x0b1a_5eed_d1f7_7a1c);
    let mut accel_bias = RandomWalk3::new(err.ba, err.ba_rw, imu_dt, seed, 0x0acc_5eed_b1a5_0001);
    let mu_rw = und.misalignment_rw_arcmin_rh.to_radians() / 60.0 / 60.0;
    let segment = ((MOUNTING_STEP_S / imu_dt).round() as usize).max(1);
    let segment_s = segment as f64 * imu_dt;
    let mut mounting = RandomWalk3::new(fx.mu, mu_rw, segment_s, seed, 0x0d21_f7ed_0f0f_1234);
    let drifting = mu_rw > 0.0;
    // The current segment's start and step.
    let (mut mu_start, mut mu_step) = (fx.mu, Vector3::zeros());
    let gyro_err = err.gyro_matrix();
    let accel_err = err.accel_matrix();
    let arw = imu.gyro_arw_deg_rh.to_radians() / 60.0; // rad/√s
    let vrw = imu.accel_vrw_mps_rh / 60.0; // m/s/√s

    let mut pos_m = Position {
        lat_rad: sc.site.lat_deg.to_radians(),
        lon_rad: sc.site.lon_deg.to_radians(),
        height_m: sc.site.height_m,
    };
    let mut imu_out = Vec::with_capacity(n_imu);
    let mut master_out = Vec::with_capacity(n_imu / imu_per_master + 1);
    // Truth columns that vary in time; the constant ones are appended at the end.
    let varying_names = [
        "bgx", "bgy", "bgz", "bax", "bay", "baz", "mux", "muy", "muz", "thx", "thy", "thz", "thdx",
        "thdy", "thdz",
    ];
    let mut truth_t = Vec::new();
    let mut truth_cols: Vec<Vec<f64>> = vec![Vec::new(); varying_names.len()];

    // The Earth model at the master's position, evaluated again only when it moves.
    let mut earth_m = Local::at(&pos_m);
    let boundary = |s: usize, earth_m: &Local<f64>, mounting: Option<&Mounting>| {
        let t = s as f64 * h;
        let m = sc.motion.attitude(t);
        let (th, thd) = flex.at_boundary(s);
        (
            m,
            th,
            thd,
            slave_truth_at(&fx, &m, earth_m, &th, &thd, mounting),
        )
    };
    let (_, _, _, mut prev) = boundary(0, &earth_m, None);
    let (tau0, tau_rate) = (und.master_delay_s, und.master_delay_rate);
    let mut smooth = sc
        .master
        .smooth_error
        .as_ref()
        .map(|e| SmoothMasterError::new(e, 1.0 / sc.master.rate_hz, seed));
    let steps = und
        .master_attitude_steps
        .as_ref()
        .map(master_steps::StepError::new);
    // The message stamped `t`, from the master's truth at `t − τ` (`pos_t`: at `t`).
    // `(bg, ba, mu)`: the slave's gyro and accelerometer biases and its mounting
    // misalignment at `t` (truth columns).
    let mut emit_master = |t: f64,
                           earth_t: &Local<f64>,
                           th: &Vector3<f64>,
                           thd: &Vector3<f64>,
                           (bg, ba, mu): (Vector3<f64>, Vector3<f64>, Vector3<f64>),
                           rng: &mut ChaCha8Rng| {
        let tau = if und.master_delay_from_s.is_some_and(|from| t < from) {
            0.0
        } else {
            tau0 + tau_rate * t
        };
        let m = sc.motion.attitude(t - tau);
        let pos = Local::at(&earth_t.offset_position(&(-fx.v_m * tau)));
        let w_ie = pos.earth_rate_n();
        let w_en = pos.transport_rate_n(&fx.v_m);
        let pos = pos.pos;
        let w_ib_bm = m.w_nb_bm + m.c_bm_n.transpose() * (w_ie + w_en);
        let mut q = UnitQuaternion::from_matrix(&m.c_bm_n)
            * quat_exp(&gauss3(rng, sc.master.attitude_noise_deg.to_radians()));
        let mut v = fx.v_m + gauss3(rng, sc.master.velocity_noise_mps);
        if let Some(s) = smooth.as_mut() {
            let (att_n, vel_n) = s.next();
            q = quat_exp(&att_n) * q;
            v += vel_n;
        }
        if let Some(e) = &steps {
            q = e.at(t) * q;
        }
        if let Some(wave) = &und.master_velocity_wave {
            v += Vector3::from(wave.amplitude_mps) * (2.0 * PI * t / wave.period_s).sin();
        }
        let w = w_ib_bm + gauss3(rng, sc.master.rate_noise_deg_h * DEG_PER_H);
        master_out.push(MasterMsg {
            t,
            q_bm_n: [q.w, q.i, q.j, q.k],
            v_n_mps: [v.x, v.y, v.z],
            lat_deg: pos.lat_rad.to_degrees(),
            lon_deg: pos.lon_rad.to_degrees(),
            height_m: pos.height_m,
            omega_ib_bm_radps: sc.master.gives_rate.then_some([w.x, w.y, w.z]),
        });
        truth_t.push(t);
        let vals = [bg, ba, mu, *th, *thd];
        for (b, v) in vals.iter().enumerate() {
            for k in 0..3 {
                truth_cols[3 * b + k].push(v[k]);
            }
        }
    };
    {
        let (th, thd) = flex.at_boundary(0);
        let now = (gyro_bias.value, accel_bias.value, fx.mu);
        emit_master(0.0, &earth_m, &th, &thd, now, &mut rng);
    }
    for i in 1..=n_imu {
        let (bg, ba) = (gyro_bias.value, accel_bias.value);
        gyro_bias.step();
        accel_bias.step();
        let into = (i - 1) % segment;
        if into == 0 {
            mu_start = mounting.value;
            mu_step = mounting.step();
        }
        // The mounting `k` sub-steps (fractional) into the interval, when it drifts.
        let mounting_at = |k: f64| {
            drifting.then(|| Mounting {
                mu: mu_start + mu_step * ((into as f64 + k / SUBSTEPS as f64) / segment as f64),
                mu_rate: mu_step / segment_s,
            })
        };
        let mu_end = if drifting {
            mu_start + mu_step * ((into + 1) as f64 / segment as f64)
        } else {
            fx.mu
        };
        let mut dth = Vector3::zeros();
        let mut dv = Vector3::zeros();
        for j in 0..SUBSTEPS {
            let s = (i - 1) * SUBSTEPS + j;
            let t_mid = (s as f64 + 0.5) * h;
            let m_mid = sc.motion.attitude(t_mid);
            let (th_mid, thd_mid) = flex.at_mid(s);
            let mid = slave_truth_at(
                &fx,
                &m_mid,
                &earth_m,
                &th_mid,
                &thd_mid,
                mounting_at(j as f64 + 0.5).as_ref(),
            );
            // Advance the master position over the sub-step.
            let dp = earth_m.position_rate(&fx.v_m) * h;
            pos_m.lat_rad += dp.x;
            pos_m.lon_rad += dp.y;
            pos_m.height_m += dp.z;
            if !same_bits(&pos_m, &earth_m.pos) {
                earth_m = Local::at(&pos_m);
            }
            let (_, _, _, next) = boundary(s + 1, &earth_m, mounting_at(j as f64 + 1.0).as_ref());
            // ∫ f^n dt = Δv − ∫ (g − (2ω_ie + ω_en) × v) dt, rotated to the body at mid-step.
            let earth_mid = Local::at(&mid.pos);
            let w_ie = earth_mid.earth_rate_n();
            let w_en = earth_mid.transport_rate_n(&mid.v_n);
            let g = earth_mid.gravity_n();
            let f_n_int = (next.v_n - prev.v_n) - (g - (w_ie * 2.0 + w_en).cross(&mid.v_n)) * h;
            dv += mid.c_bs_n.transpose() * f_n_int;
            dth += mid.w_ib_bs * h;
            prev = next;
        }
        let t = i as f64 * imu_dt;
        // The g-sensitivity adds G_si ∫ f dt: the true Δv, before the accelerometer's errors.
        let dth_meas =
            gyro_err * dth + err.g_si * dv + bg * imu_dt + gauss3(&mut rng, arw * imu_dt.sqrt());
        let dv_meas = accel_err * dv + ba * imu_dt + gauss3(&mut rng, vrw * imu_dt.sqrt());
        imu_out.push(ImuSample {
            t,
            dtheta_rad: dth_meas.into(),
            dv_mps: dv_meas.into(),
        });
        if i % imu_per_master == 0 {
            let s = i * SUBSTEPS;
            let (th, thd) = flex.at_boundary(s);
            let now = (gyro_bias.value, accel_bias.value, mu_end);
            emit_master(t, &earth_m, &th, &thd, now, &mut rng);
        }
    }
    let rows = truth_t.len();
    let mut truth_names: Vec<String> = varying_names.iter().map(|s| s.to_string()).collect();
    for (name, value) in constant_truth(&err, und, mu_rw) {
        truth_names.push(name.to_string());
        truth_cols.push(vec![value; rows]);
    }
    let recording = Recording {
        meta: RecordingMeta {
            site: Site {
                lat_deg: sc.site.lat_deg,
                lon_deg: sc.site.lon_deg,
                height_m: sc.site.height_m,
            },
            // As surveyed: the truth's arm differs by `undeclared.lever_arm_error_m`.
            lever_arm_m: sc.lever_arm.r0_m,
            slave_rate_hz: sc.slave_imu.rate_hz,
            slave_output: ImuOutput::Increments,
            master_rate_hz: sc.master.rate_hz,
            notes: Some(format!(
                "simulated by flexcal: scenario `{}`, seed {seed}",
                sc.name
            )),
        },
        imu_t0: 0.0,
        imu: imu_out,
        master: master_out,
        truth: Some(Truth {
            names: truth_names,
            t: truth_t,
            columns: truth_cols,
        }),
    };
    SimOutput { recording }
}
