//! The calibration engine: the slave's strapdown fed by IMU increments, master
//! messages matched at their time of validity, the error-state Kalman filter with
//! closed-loop feedback, and the estimates it produces. The same code runs on the
//! board (f32) and the desktop (f64).

use crate::align::{AlignBuffer, AlignError, RateAt, SlaveAt, Snapshot};
use crate::augment::{self, Augmentation, Channel, Effect, Signature, CLOCK_DRIFT_PRIOR_SPAN_S};
use crate::earth::{self, Position};
use crate::flexure::{AxisModel, FlexureModel};
use crate::kalman::{Health, Kalman, Parts, ScalarUpdate};
use crate::mat::{self, mul3, mul3v, transpose3, vec3, vget, zip3};
use crate::model::{
    self, IntervalMeans, LeverBending, ProcessNoise, StateMat, StateVec, BA, BG, MU, N, PSI, TH,
    THD, V,
};
use crate::probe::{self, Phase};
use crate::real::Real;
use crate::rotation::{
    dcm, exp_so3, inverse_right_jacobian_small, nlerp, quat_exp, quat_log, right_jacobian,
};
use crate::strapdown::{Increments, NavState, Strapdown};
use crate::tilt_bias;
use heapless::{Deque, Vec};
use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use rates::{PastRates, RateFit};

mod rates;

/// Slave snapshots kept for time alignment: at 200 Hz, 0.64 s of master latency.
pub const ALIGN_DEPTH: usize = 128;
/// An IMU interval this many times longer than the previous one is a gap.
const GAP_FACTOR: f64 = 2.5;
/// Consecutive master messages with a rejected measurement in one channel after which
/// the slave solution is re-initialized from the master (divergence, or a master that
/// re-aligned): the filter would otherwise keep refusing that channel for good.
pub const RESET_AFTER_GATED_MESSAGES: u32 = 20;
/// IMU samples held back waiting for the master messages of their time (at 200 Hz,
/// 0.32 s of master latency is absorbed exactly; beyond it samples go on alone).
pub const IMU_HOLD_DEPTH: usize = 64;
/// Master messages that may wait for the slave to catch up.
pub const PENDING_DEPTH: usize = 8;

/// Which matching measurements the filter uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Matching {
    /// Velocity matching (static lever arm compensated).
    pub velocity: bool,
    /// Attitude matching.
    pub attitude: bool,
    /// Angular-rate matching (needs the master's rate; skipped when a message has none).
    pub angular_rate: bool,
}

/// White measurement noise of the matching channels (standard deviations), one per
/// axis of each channel's residual: a channel's axes need not be alike (a master's
/// vertical velocity is not its horizontal one; the flexure's share of the attitude and
/// rate residuals differs per axis).
#[derive(Clone, Copy, Debug)]
pub struct MeasurementNoise<T> {
    /// Velocity matching (m/s, ENU axes).
    pub velocity_mps: Vector3<T>,
    /// Attitude matching (rad, slave body axes: the residual's).
    pub attitude_rad: Vector3<T>,
    /// The master's angular-rate noise (rad/s, slave body axes: the residual's). The
    /// slave gyro's part of the rate-matching noise is added per message from the
    /// process noise's angle random walk and the interpolation weights
    /// (`AlignBuffer::rate_at`).
    pub rate_radps: Vector3<T>,
    /// σ of the master's rate noise as the lever arm carries it into the velocity
    /// matching (rad/s, the mean over the axes), when the master gives its rate: the
    /// velocity noise adds `⅔ |r0|² σ²`. Apart from `rate_radps` because what the rate
    /// matching's noise holds beyond the master's own (model error of the slave's side)
    /// does not move the master's lever-arm velocity; [`MeasurementNoise::uniform`] and
    /// a configuration that does not say otherwise take the rate noise's RMS.
    pub lever_arm_rate_radps: T,
}

impl<T: Real> MeasurementNoise<T> {
    /// The same σ on every axis of each channel: velocity (m/s), attitude (rad), rate
    /// (rad/s).
    pub fn uniform(velocity_mps: T, attitude_rad: T, rate_radps: T) -> Self {
        Self {
            velocity_mps: Vector3::repeat(velocity_mps),
            attitude_rad: Vector3::repeat(attitude_rad),
            rate_radps: Vector3::repeat(rate_radps),
            lever_arm_rate_radps: rate_radps,
        }
    }
}

/// The root mean square over the three axes of a per-axis σ: exactly σ when the axes
/// are alike (a sum of three squares, a division by three and a square root may
/// round), so a uniform configuration computes what it did when the noise was one σ
/// per channel.
pub fn axes_rms<T: Real>(sigma: &Vector3<T>) -> T {
    if sigma.x == sigma.y && sigma.y == sigma.z {
        sigma.x
    } else {
        (sigma.norm_squared() / T::of(3.0)).sqrt()
    }
}

/// Initial standard deviations of the filter states.
#[derive(Clone, Copy, Debug)]
pub struct InitialSigma<T> {
    /// Velocity error (m/s).
    pub velocity_mps: T,
    /// Misalignment (rad).
    pub misalignment_rad: T,
    /// Gyro bias (rad/s).
    pub gyro_bias_radps: T,
    /// Accelerometer bias (m/s²).
    pub accel_bias_mps2: T,
    /// Flexure angle, used only when the flexure model is not stationary (rad).
    pub flexure_rad: T,
}

/// Everything the engine needs to know before it starts.
#[derive(Clone, Copy, Debug)]
pub struct EngineConfig<T: Real> {
    /// Filter period (s): the time update runs every period; the flexure model's
    /// coefficients must belong to this period.
    pub filter_period_s: f64,
    /// Matching channels in use.
    pub matching: Matching,
    /// Static lever arm r0 from master to slave, master body frame (m).
    pub lever_arm_m: Vector3<T>,
    /// How flexure bends the lever arm (the matrix R of r = r0 + Rθ).
    pub bending: LeverBending,
    /// Whether the flexure-bent part of the lever arm is modelled (else: paper's baseline).
    pub dynamic_lever_arm: bool,
    /// Flexure AR model at the filter period.
    pub flexure: FlexureModel<T>,
    /// Process noise densities.
    pub process_noise: ProcessNoise<T>,
    /// Measurement noise.
    pub measurement_noise: MeasurementNoise<T>,
    /// Initial uncertainty.
    pub initial_sigma: InitialSigma<T>,
    /// Initial misalignment estimate μ̂₀ (rad).
    pub initial_misalignment_rad: Vector3<T>,
    /// Innovation gate (standard deviations).
    pub gate_sigma: T,
    /// Smallest scaled variance (see `Kalman`).
    pub variance_floor: T,
    /// Effects carried beyond the declared model (states from index 21 on).
    pub augmentation: Augmentation<T>,
    /// Starting value of the master delay τ̂ (s) when the layout carries `time_delay`
    /// (e.g. a previous run's estimate: the delay's linearization is then exact from
    /// the start); ignored otherwise.
    pub initial_delay_s: f64,
}

/// One master navigation message.
#[derive(Clone, Copy, Debug)]
pub struct MasterNav<T: Real> {
    /// Time of validity (s, slave time base).
    pub t: f64,
    /// Master attitude `q_bm^n`.
    pub q_bm_n: UnitQuaternion<T>,
    /// Master velocity, ENU (m/s).
    pub v_n: Vector3<T>,
    /// Master position.
    pub pos: Position<T>,
    /// Master angular rate `ω_ib^bm` (rad/s), when the master gives it.
    pub w_ib_bm: Option<Vector3<T>>,
}

/// One slave IMU sample: increments over `(t_prev, t]`, raw (not bias-corrected).
#[derive(Clone, Copy, Debug)]
pub struct ImuIncrement<T: Real> {
    /// End of the interval (s).
    pub t: f64,
    /// ∫ ω_ib^bs dt (rad).
    pub dtheta_b: Vector3<T>,
    /// ∫ f^bs dt (m/s).
    pub dv_b: Vector3<T>,
}

/// Input the engine refused, and why.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum EngineError {
    /// An IMU sample's time did not increase.
    ImuTimeNotIncreasing,
    /// An input had a non-finite value.
    NonFinite,
    /// A master message was not newer than the previous one.
    MasterOutOfOrder,
    /// A master message's time of validity is older than the alignment buffer.
    MasterStale,
    /// Too many master messages were waiting for the slave; the oldest was dropped.
    PendingOverflow,
    /// The configuration is inconsistent (flexure period ≠ filter period, non-positive values).
    BadConfig,
    /// The augmentation needs more states than this engine's dimension has.
    TooManyStates,
}

/// The matching innovations of one master message (absent channels are `None`).
#[derive(Clone, Copy, Debug, Default)]
pub struct MatchReport<T> {
    /// Time of validity (s).
    pub t: f64,
    /// Velocity channel updates (E, N, U).
    pub velocity: Option<[ScalarUpdate<T>; 3]>,
    /// Attitude channel updates (slave body x, y, z).
    pub attitude: Option<[ScalarUpdate<T>; 3]>,
    /// Angular-rate channel updates (slave body x, y, z).
    pub angular_rate: Option<[ScalarUpdate<T>; 3]>,
}

/// Counters of what happened to the inputs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counters {
    /// IMU samples integrated.
    pub imu_samples: u32,
    /// Master messages matched.
    pub master_matched: u32,
    /// Master messages refused as stale (older than the buffer).
    pub master_stale: u32,
    /// Master messages refused as out of order.
    pub master_out_of_order: u32,
    /// Master messages dropped because too many were waiting.
    pub master_dropped: u32,
    /// Filter time updates.
    pub predictions: u32,
    /// Times the filter state was re-initialized.
    pub resets: u32,
}

/// What became of the master messages beyond [`Counters`] (kept beside the master
/// queue, not in `Counters`, so the link's `Status` is unchanged): with `Counters`'
/// matched, stale, out-of-order and dropped, every message handed to
/// [`Engine::push_master`] is counted once.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MasterFate {
    /// Refused for a non-finite time or value.
    pub non_finite: u32,
    /// Used to start (or restart, after a reset) the slave solution, not matched.
    pub initialized: u32,
    /// Taken from the queue once due, but the slave solution could not be read at
    /// their time (no IMU interval before it yet).
    pub unmatched: u32,
    /// Still waiting in the queue for the slave (at the end of a run: never matched).
    pub pending: u32,
    /// Matched (and counted in [`Counters`]) with the velocity and rate channels held:
    /// a master that gives its rate whose past rates did not yet cover the window that
    /// forms the delay's rate and velocity columns (the start, after a gap), so only
    /// the attitude was matched ([`MasterFate`]'s other fields count messages that made
    /// no update; this one counts updates that were partial).
    pub channels_held: u32,
}

/// The calibrated quantities with their standard deviations.
#[derive(Clone, Copy, Debug)]
pub struct Estimates<T> {
    /// Time of the latest filter update (s).
    pub t: f64,
    /// Gyro bias (rad/s, slave body).
    pub gyro_bias: Vector3<T>,
    /// Its standard deviation.
    pub gyro_bias_sigma: Vector3<T>,
    /// Accelerometer bias (m/s², slave body).
    pub accel_bias: Vector3<T>,
    /// Its standard deviation.
    pub accel_bias_sigma: Vector3<T>,
    /// Misalignment μ (rad, rotation vector of `C_bs^bm = Exp(μ + θ)`).
    pub misalignment: Vector3<T>,
    /// Its standard deviation.
    pub misalignment_sigma: Vector3<T>,
    /// Flexure angle θ (rad).
    pub flexure: Vector3<T>,
    /// Its standard deviation.
    pub flexure_sigma: Vector3<T>,
}

#[derive(Clone, Copy, Debug)]
struct Epoch<T: Real> {
    next_t: f64,
    /// Slave attitude at the start of the period (Φ is linearized at mid-period).
    q_start: UnitQuaternion<T>,
    dtheta: Vector3<T>,
    dv: Vector3<T>,
    dt: f64,
}

/// Where `initialize` started the slave solution: the starting master's time of validity
/// `t − τ̂` (s) and how many buffered snapshots after it still hold raw increments, for `catch_up`.
#[derive(Clone, Copy, Debug)]
struct Start {
    t: f64,
    raw_count: usize,
}

/// An IMU sample waiting for the master messages of its time.
#[derive(Clone, Copy, Debug)]
struct HeldImu<T: Real> {
    s: ImuIncrement<T>,
    /// Length of its interval (s).
    dt: f64,
    /// Whether a gap precedes it.
    gap: bool,
}

#[derive(Clone, Copy, Debug)]
struct PrevMaster<T: Real> {
    t: f64,
    q_bm_n: UnitQuaternion<T>,
}

/// One augmented effect's estimate.
#[derive(Clone, Copy, Debug)]
pub struct EffectEstimate<T> {
    /// The effect.
    pub effect: Effect,
    /// Its states (SI unit of the effect); the first `effect.states()` are used.
    pub value: [T; 9],
    /// Their standard deviations.
    pub sigma: [T; 9],
}

/// The engine. Feed it with [`Engine::push_imu`] and [`Engine::push_master`].
///
/// `S` is the dimension of the filter's state: the declared 21 states, then the blocks
/// of `EngineConfig::augmentation`; states beyond those are inert (unit variance, no
/// dynamics, never measured), so one engine size runs every layout that fits.
#[derive(Clone, Debug)]
pub struct Engine<T: Real, const S: usize = N> {
    cfg: EngineConfig<T>,
    strapdown: Option<Strapdown<T>>,
    kf: Kalman<T, S>,
    buffer: AlignBuffer<T, ALIGN_DEPTH>,
    pending: Deque<MasterNav<T>, PENDING_DEPTH>,
    held: Deque<HeldImu<T>, IMU_HOLD_DEPTH>,
    gyro_bias: Vector3<T>,
    accel_bias: Vector3<T>,
    misalignment: Vector3<T>,
    last_imu_t: Option<f64>,
    /// Length of the previous IMU interval (s), to recognize a gap.
    last_imu_dt: Option<f64>,
    epoch: Option<Epoch<T>>,
    prev_master: Option<PrevMaster<T>>,
    last_update_t: f64,
    counters: Counters,
    /// What became of the master messages `counters` does not count.
    fate: MasterFate,
    /// Per channel (velocity, attitude, rate): consecutive messages with a gated axis.
    gated_streaks: [u32; 3],
    /// Nominal master delay τ̂ (s) when the layout carries `time_delay`: a master
    /// message stamped t is matched with the slave at t − τ̂ (closed loop, like the biases).
    delay_s: f64,
    /// Nominal rate of the master delay τ̂̇ (s/s) when the layout carries `clock_drift`:
    /// the message stamped t is matched at t − τ̂ − τ̂̇ (t − t₀) (closed loop too).
    delay_rate: f64,
    /// The clock's reference t₀: the stamp of the first master message that started
    /// the solution (kept across resets, cleared by `reconfigure`).
    clock_t0: Option<f64>,
    /// Whether the calibrated quantities are frozen (`freeze_calibration`).
    frozen: bool,
    /// Whether `cfg`'s layout carries the master delay ([`Engine::has_delay`]), kept with
    /// `cfg`: asked at every IMU sample and master message, the scan of the layout's
    /// blocks cost the board ≈ 0.4k instructions a master update.
    has_delay: bool,
    /// Whether masters are matched off the filter epochs ([`matches_off_epoch`]):
    /// a delay in the layout or a declared one (`initial_delay_s`), kept with `cfg` as
    /// `has_delay`.
    off_epoch: bool,
    /// Whether `cfg`'s layout has columns that take the master's rate from its past rates
    /// ([`layout_fits_master_rate`]), kept with `cfg` as `has_delay`.
    fits_master_rate: bool,
    /// Whether `cfg`'s layout has dynamics columns made of the master's carried force
    /// ([`uses_carried_force`]), kept with `cfg` as `has_delay`.
    carried_force: bool,
    /// Which flexure axes of `cfg` are rigid ([`AxisModel::is_rigid`]: their θ, θ̇ inert),
    /// kept with `cfg` as `has_delay` (asked at every matched channel).
    rigid_axes: [bool; 3],
    /// `1e-6 · filter period` (s): how near an epoch a sample counts as reaching it
    /// (`maybe_predict`, `needed_until`); kept with `cfg` as `has_delay` (the product,
    /// software `f64` on the board, cost ≈ 0.1k instructions a master update).
    epoch_reach_s: f64,
    /// `1e-9 · filter period` (s) off the epochs ([`matches_off_epoch`]: a delay in the
    /// layout or declared), else 0: the rounding `match_ready` allows
    /// a needed epoch against the IMU time stamps; kept with `cfg` as `has_delay` (its
    /// product at every pending message ≈ 0.25k instructions a master update).
    match_slack_s: f64,
    /// The master's last angular rates (for the delay's rate column, the lever-arm
    /// columns' instrument, the g-sensitivity's rate column and the gyro scale
    /// factor's and non-orthogonality's rate columns).
    past_master_rates: PastRates<T>,
    /// Where the master's rates run without a gap ([`RateRun`]).
    rate_run: RateRun,
    /// The master's own acceleration from its past velocities (the delay's velocity column).
    master_trend: VelocityTrend<T>,
    /// The specific force the last matched master message carries to the slave, slave
    /// body (m/s², `Signature::f_carried_bs`), when the layout carries the g-sensitivity
    /// or an accelerometer block (`uses_carried_force`) and the master gives its rate:
    /// their dynamics columns until the next (none: the period's mean sensed force). 16 B
    /// in `f32`.
    g_force_bs: Option<Vector3<T>>,
}

/// The delay estimate is fed back once its σ is below this (s).
pub const DELAY_FEEDBACK_SIGMA_S: f64 = 1e-3;

/// Master angular rates kept for the slope that forms the delay's rate column.
pub const RATE_HISTORY: usize = 64;

/// Time span of the master rates the delay's rate column is fitted to (s; the 64 rates
/// of a 100 Hz master). With a quartic, the slope one 20 Hz period past the window is
/// within 0.05 % and 0.15 ms of the angular acceleration at 1.14 rad/s, 0.32 % and
/// 1.2 ms at 1.57 rad/s and 10 Hz (the parabola it replaces: 6.3 % and 16 ms at 1.14
/// rad/s and 20 Hz, which the attitude-and-rate pair read as information on the delay;
/// `python3 scripts/rate-slope-response.py`, `docs/diagnosis.md` "Session 14").
pub const RATE_WINDOW_S: f64 = 0.645;

/// Fewest master rates in `RATE_WINDOW_S` for the rate column (a quartic needs five).
pub const RATE_MIN: usize = 5;

/// Terms of the polynomial through the master's rates whose derivative at the message is
/// the delay's rate column (a quartic).
const RATE_TERMS: usize = 5;

/// How many of its noise variances a cubic or quartic term of the rate fit must exceed
/// to be kept (`c ← c max(0, 1 − κ var/c²)`, κ = 25: a term below five σ of noise is
/// dropped, one far above it kept whole). With κ = 1 a 10 ms delay against a 20 °/h,
/// 100 Hz master read 10.72 ± 0.12 ms, with 9 10.38, with 25 10.30 (the parabola
/// alone 10.29; docs/diagnosis.md "Session 14").
const RATE_TERM_SHRINK: f64 = 25.0;

/// Time constant of the exponential weights of the line through the master's past
/// velocities whose slope is the master's own acceleration in the delay's velocity
/// column (s): long against the increments of the master's smooth velocity error, which
/// a 0.645 s parabola's slope carried into a spurious delay (docs/diagnosis.md,
/// "Session 11"). The slope is used once the velocities span this long.
pub const MASTER_ACCEL_WINDOW_S: f64 = 5.0;

/// The master's velocities further apart than this (s) restart the line.
const MASTER_ACCEL_GAP_S: f64 = 1.0;

/// An exponentially weighted least-squares line through the master's past velocities
/// (time constant `MASTER_ACCEL_WINDOW_S`), kept as its weighted sums in `u = t − t_last`
/// and in the velocities less the first one (the constant part, which would cancel in
/// the slope, left out for `f32`): its slope is the master's own acceleration.
#[derive(Clone, Copy, Debug)]
struct VelocityTrend<T: Real> {
    /// Stamps of the first and the last velocity in the sums (none: `s0` = 0).
    t_first: f64,
    t_last: f64,
    /// The first velocity, ENU (m/s).
    v_ref: Vector3<T>,
    /// Σw, Σw u, Σw u²; Σw (v − v_ref), Σw u (v − v_ref).
    s0: T,
    s1: T,
    s2: T,
    sv: Vector3<T>,
    suv: Vector3<T>,
}

impl<T: Real> VelocityTrend<T> {
    fn new() -> Self {
        Self {
            t_first: 0.0,
            t_last: 0.0,
            v_ref: Vector3::zeros(),
            s0: T::zero(),
            s1: T::zero(),
            s2: T::zero(),
            sv: Vector3::zeros(),
            suv: Vector3::zeros(),
        }
    }

    /// Adds the master's velocity `v` (ENU) stamped `t`.
    fn push(&mut self, t: f64, v: &Vector3<T>) {
        let dt = t - self.t_last;
        if self.s0 <= T::zero() || !(dt > 0.0 && dt <= MASTER_ACCEL_GAP_S) {
            *self = Self::new();
            self.t_first = t;
            self.v_ref = *v;
        } else {
            // Every sum aged by 1 / (1 + d/T) (e^{−d/T} to first order, d ≪ T) and moved
            // to the new origin u → u − d.
            let d = T::of(dt);
            let w = T::one() / (T::one() + T::of(dt / MASTER_ACCEL_WINDOW_S));
            self.s2 = w * (self.s2 - T::of(2.0) * d * self.s1 + d * d * self.s0);
            self.s1 = w * (self.s1 - d * self.s0);
            self.s0 *= w;
            self.suv = (self.suv - self.sv * d) * w;
            self.sv *= w;
        }
        self.t_last = t;
        self.s0 += T::one();
        self.sv += v - self.v_ref;
    }

    /// The line's slope (m/s², ENU), once its velocities span `MASTER_ACCEL_WINDOW_S`.
    fn slope(&self) -> Option<Vector3<T>> {
        let det = self.s0 * self.s2 - self.s1 * self.s1;
        if self.t_last - self.t_first < MASTER_ACCEL_WINDOW_S || det <= T::zero() {
            return None;
        }
        Some((self.suv * self.s0 - self.sv * self.s1) / det)
    }
}

/// Largest master delay the engine follows (s): within the alignment buffer's reach.
pub const MAX_DELAY_S: f64 = 0.25;

/// Largest clock drift the engine follows (s/s): 1 %, far beyond any clock's.
pub const MAX_DELAY_RATE: f64 = 1e-2;

/// What one call of `push_imu`, `push_master` or `flush` led to: the master messages it
/// matched. Kilobytes in size (`PENDING_DEPTH` reports of nine scalar updates): the caller
/// owns one and lends it to each call, which copies nothing (returned by value it was a
/// third of the desk's run time in `memcpy`, and a stack frame on the board).
pub type StepReports<T> = Vec<MatchReport<T>, PENDING_DEPTH>;

/// Which states are static under `cfg` (the filter holds them last, where its time update
/// leaves them without arithmetic: see [`Kalman`]): the misalignment and the biases without
/// a random walk, and every augmented state but the Gauss-Markov ones (the constant effects,
/// the inert states). The others have dynamics in Φ or process noise (`model::transition`,
/// `model::process_noise`). Only the cost depends on this: the time update finds for itself
/// which states are static at each step.
fn static_states<T: Real>(cfg: &EngineConfig<T>) -> impl Fn(usize) -> bool {
    let noise = &cfg.process_noise;
    let mut mask = !0u64 << N;
    for (b, rw) in [
        (MU, noise.misalignment_rw),
        (BG, noise.gyro_bias_rw),
        (BA, noise.accel_bias_rw),
    ] {
        if rw == T::zero() {
            mask |= 0b111 << b;
        }
    }
    for b in cfg.augmentation.blocks() {
        if b.effect.is_gauss_markov() {
            for i in b.offset..b.offset + b.effect.states() {
                mask &= !1u64.checked_shl(i as u32).unwrap_or(0);
            }
        }
    }
    move |i| mask >> i.min(63) & 1 == 1
}

/// `Engine::epoch_reach_s` of `cfg`.
fn epoch_reach<T: Real>(cfg: &EngineConfig<T>) -> f64 {
    1e-6 * cfg.filter_period_s
}

/// `Engine::match_slack_s` of `cfg`.
fn match_slack<T: Real>(cfg: &EngineConfig<T>) -> f64 {
    if matches_off_epoch(cfg) {
        1e-9 * cfg.filter_period_s
    } else {
        0.0
    }
}

/// Whether `cfg`'s layout carries the master delay: `time_delay` or `clock_drift`.
fn layout_has_delay<T: Real>(cfg: &EngineConfig<T>) -> bool {
    cfg.augmentation.blocks().any(|b| b.effect.is_clock())
}

/// Whether `cfg` matches its masters off the filter epochs: its layout carries the
/// delay, or it declares one (`initial_delay_s`, e.g. the clock offset found before the
/// filter). The time of validity `t − τ` then falls between epochs, and the flexure
/// states are read back to it from the nearer epoch (`Engine::needed_until`,
/// `Engine::flexure_lag`). A declared delay matched as if at the epoch read the flexure
/// states up to a period stale, and, where `t − τ` fell on an IMU stamp, stale or a
/// period early by the rounding of the stamps: a declared 10 ms, the drawn truth, gave
/// blind draw 107 a likelihood 2.5·10⁶ worse than 9.9 ms (`docs/diagnosis.md`, "A declared
/// delay matched off the epochs").
fn matches_off_epoch<T: Real>(cfg: &EngineConfig<T>) -> bool {
    // Any bit but the sign's: the test on the bits, not a software `f64` comparison.
    layout_has_delay(cfg) || cfg.initial_delay_s.to_bits() << 1 != 0
}

/// Whether `cfg`'s layout has columns that take the master's rate from its past rates
/// ([`RateFit::value`]; its current rate where they do not cover their window): a
/// lever-arm block (`lever_arm_error`, `lever_arm_coupling`), the instrument of its
/// columns, or the gyro's scale factor or non-orthogonality, whose rate columns are the
/// rate there (`Signature::w_carried_bs`), or the accelerometer's, whose columns' carried
/// force takes the fit's angular acceleration (`Signature::f_carried_bs`: the difference
/// of two previous rates lags it by a period and a half, which read blind draw 107's
/// accelerometer factors 8σ off with a 20 Hz master and a 19 m arm).
fn layout_fits_master_rate<T: Real>(cfg: &EngineConfig<T>) -> bool {
    cfg.augmentation.blocks().any(|b| {
        matches!(
            b.effect,
            Effect::LeverArmError
                | Effect::LeverArmCoupling
                | Effect::GyroScaleFactor
                | Effect::GyroMisalignment
                | Effect::AccelScaleFactor
                | Effect::AccelMisalignment
        )
    })
}

/// Whether `cfg`'s layout has dynamics columns made of the specific force the master
/// carries to the slave without the flexure's motion (`augment::Signature::f_carried_bs`,
/// `model::IntervalMeans::f_g_b`): the g-sensitivity's, and the accelerometer scale
/// factor's and non-orthogonality's. The slave's own mean force holds the bending arm's
/// `R θ̈`, whose integral over the period is the flexure velocity the velocity innovation
/// carries unpredicted (errors in variables): blind draw 108 (a 16, 9.4, 12 m arm, a
/// smooth master velocity error) read an accelerometer y factor of 17 500 ppm where none
/// was drawn (docs/diagnosis.md "Session 19").
fn uses_carried_force<T: Real>(cfg: &EngineConfig<T>) -> bool {
    cfg.augmentation.blocks().any(|b| {
        matches!(
            b.effect,
            Effect::GyroGSensitivity | Effect::AccelScaleFactor | Effect::AccelMisalignment
        )
    })
}

/// Which of `cfg`'s flexure axes are rigid ([`AxisModel::is_rigid`]).
fn rigid_axes<T: Real>(cfg: &EngineConfig<T>) -> [bool; 3] {
    let mut rigid = [false; 3];
    for (r, axis) in rigid.iter_mut().zip(cfg.flexure.axes.iter()) {
        *r = axis.is_rigid();
    }
    rigid
}

impl<T: Real, const S: usize> Engine<T, S> {
    /// A new engine; it initializes the slave solution from the first master message.
    pub fn new(cfg: EngineConfig<T>) -> Result<Self, EngineError> {
        let mut e = Self::unconfigured(cfg);
        e.reconfigure(cfg)?;
        Ok(e)
    }

    /// An engine holding `cfg` but not started (zero covariance): only for
    /// [`Engine::new`] and for a slot that [`Engine::reconfigure`] then starts. Every
    /// field is empty or zero, so the compiler can write it straight into its place.
    #[inline(always)]
    pub fn unconfigured(cfg: EngineConfig<T>) -> Self {
        Self {
            kf: Kalman::unstarted(cfg.variance_floor),
            strapdown: None,
            buffer: AlignBuffer::new(),
            pending: Deque::new(),
            held: Deque::new(),
            gyro_bias: Vector3::zeros(),
            accel_bias: Vector3::zeros(),
            misalignment: Vector3::zeros(),
            last_imu_t: None,
            last_imu_dt: None,
            epoch: None,
            prev_master: None,
            last_update_t: 0.0,
            counters: Counters::default(),
            fate: MasterFate::default(),
            gated_streaks: [0; 3],
            delay_s: 0.0,
            delay_rate: 0.0,
            clock_t0: None,
            past_master_rates: PastRates::new(),
            rate_run: RateRun::new(),
            master_trend: VelocityTrend::new(),
            g_force_bs: None,
            frozen: false,
            has_delay: layout_has_delay(&cfg),
            off_epoch: matches_off_epoch(&cfg),
            fits_master_rate: layout_fits_master_rate(&cfg),
            carried_force: uses_carried_force(&cfg),
            rigid_axes: rigid_axes(&cfg),
            epoch_reach_s: epoch_reach(&cfg),
            match_slack_s: match_slack(&cfg),
            cfg,
        }
    }

    /// Starts this engine again with `cfg`, in place: afterwards it is what
    /// [`Engine::new`]`(cfg)` returns, built without an engine-sized temporary (the board
    /// reconfigures the engine in its `App` this way, at the depth of a small frame). On
    /// a refused configuration the engine is left as it was.
    pub fn reconfigure(&mut self, cfg: EngineConfig<T>) -> Result<(), EngineError> {
        let period_ok = cfg.filter_period_s > 0.0 && cfg.filter_period_s.is_finite();
        let flex_ok = (cfg.flexure.period_s.to_f64() - cfg.filter_period_s).abs()
            <= 1e-6 * cfg.filter_period_s;
        if !(period_ok && flex_ok && cfg.gate_sigma > T::zero()) {
            return Err(EngineError::BadConfig);
        }
        if !(cfg.initial_delay_s.is_finite() && cfg.initial_delay_s.abs() <= MAX_DELAY_S) {
            return Err(EngineError::BadConfig);
        }
        if cfg.augmentation.dimension() > S || S < N {
            return Err(EngineError::TooManyStates);
        }
        Self::restart_covariance(&mut self.kf, &cfg, None);
        self.kf.health = Health::default();
        self.strapdown = None;
        self.buffer.clear();
        self.pending.clear();
        self.held.clear();
        self.gyro_bias = Vector3::zeros();
        self.accel_bias = Vector3::zeros();
        self.misalignment = cfg.initial_misalignment_rad;
        self.last_imu_t = None;
        self.last_imu_dt = None;
        self.epoch = None;
        self.prev_master = None;
        self.last_update_t = 0.0;
        self.counters = Counters::default();
        self.fate = MasterFate::default();
        self.gated_streaks = [0; 3];
        self.delay_s = cfg.initial_delay_s;
        self.delay_rate = 0.0;
        self.clock_t0 = None;
        self.past_master_rates.clear();
        self.rate_run = RateRun::new();
        self.master_trend = VelocityTrend::new();
        self.g_force_bs = None;
        self.frozen = false;
        self.has_delay = layout_has_delay(&cfg);
        self.off_epoch = matches_off_epoch(&cfg);
        self.fits_master_rate = layout_fits_master_rate(&cfg);
        self.carried_force = uses_carried_force(&cfg);
        self.rigid_axes = rigid_axes(&cfg);
        self.epoch_reach_s = epoch_reach(&cfg);
        self.match_slack_s = match_slack(&cfg);
        self.cfg = cfg;
        Ok(())
    }

    /// The initial covariance, as its factors `P₀ = U D Uᵀ` (see [`Kalman`]). The slave's
    /// attitude is initialized from the master's through μ̂₀, so its error is
    /// ψ₀ = −J_r(μ̂₀)(δμ + θ₀) plus the master's attitude noise: ψ is correlated with δμ
    /// and θ from the start, and P₀ says so. As factors that is row ψ of U, `−J` at δμ's
    /// and θ's columns, and `D_ψ` the master's attitude noise: given the misalignment and
    /// the flexure, ψ is known to the master's precision, which a formed `P₀` in `f32`
    /// cannot carry (`P_ψψ ≈ J P_μμ Jᵀ` to 1 − 10⁻⁸ with a 2 µrad master). Each flexure
    /// axis's `(θ, θ̇)` pair: θ given θ̇. Equal to the formed `P₀` (tested,
    /// `initial_factor_is_the_formed_covariance`). Written into the filter's own storage (`u`, `d`:
    /// see [`Kalman::restart_factored`]).
    ///
    /// `start_c_bs_n`, the slave's attitude (body to ENU) when its solution starts from a
    /// master message: the slave then takes the master's attitude and velocity as
    /// reported, so with the master reporting `Exp(φ_m) C_bm^n` and `v_m + δv_m` its
    /// starting errors hold the master's smooth errors of that instant, ψ₀ gains
    /// `Ĉ_bs^nᵀ φ_m` and δv₀ gains δv_m (the sign that makes the first attitude
    /// innovation zero, as the start is), and P₀ says so where the layout carries those
    /// blocks. Left independent, P₀ claimed the start's tilt known to the white noise
    /// while it was off by the master's slow error, which then stays in the
    /// accelerometer bias and tilt the filter cannot tell apart (smooth-master blind
    /// seeds handed their truth: `docs/model-learning.md`, session 9).
    fn initial_factor(
        cfg: &EngineConfig<T>,
        start_c_bs_n: Option<&Matrix3<T>>,
        u: &mut StateMat<T, S>,
        d: &mut StateVec<T, S>,
    ) {
        initial_factor_n(cfg, start_c_bs_n, u.as_mut_slice(), d.as_mut_slice());
    }

    /// The filter back at P₀ ([`Engine::initial_factor`]), in its own storage. The one
    /// place the covariance restarts (configuration, reset, the solution's start), so the
    /// board's image holds one copy of the restart.
    fn restart_covariance(
        kf: &mut Kalman<T, S>,
        cfg: &EngineConfig<T>,
        start_c_bs_n: Option<&Matrix3<T>>,
    ) {
        kf.restart_factored(cfg.variance_floor, static_states(cfg), |u, d| {
            Self::initial_factor(cfg, start_c_bs_n, u, d)
        });
    }

    /// The configuration in use.
    pub fn config(&self) -> &EngineConfig<T> {
        &self.cfg
    }

    /// Input counters.
    pub fn counters(&self) -> Counters {
        self.counters
    }

    /// What became of the master messages [`Engine::counters`] does not count, the
    /// ones still queued included.
    pub fn master_fate(&self) -> MasterFate {
        MasterFate {
            pending: self.pending.len() as u32,
            ..self.fate
        }
    }

    /// Filter health.
    pub fn health(&self) -> Health {
        self.kf.health
    }

    /// The filter (for covariance checks and reports).
    pub fn filter(&self) -> &Kalman<T, S> {
        &self.kf
    }

    /// Freezes the calibrated quantities (misalignment, biases, augmented effects) at
    /// their current estimates; the navigation and flexure states go on being estimated.
    /// What follows is a prediction of the innovations by the frozen calibration.
    pub fn freeze_calibration(&mut self) {
        self.kf.freeze(MU..TH);
        for b in self.cfg.augmentation.blocks() {
            if !b.effect.is_gauss_markov() {
                self.kf.freeze(b.offset..b.offset + b.effect.states());
            }
        }
        self.frozen = true;
    }

    /// The augmented states that are calibration constants (every block but the
    /// master's Gauss-Markov errors, which go on being estimated when frozen).
    fn calibrated_effect_states(&self) -> impl Iterator<Item = usize> + '_ {
        self.cfg
            .augmentation
            .blocks()
            .filter(|b| !b.effect.is_gauss_markov())
            .flat_map(|b| b.offset..b.offset + b.effect.states())
    }

    /// The estimate of an augmented effect, if the layout carries it.
    pub fn effect_estimate(&self, effect: Effect) -> Option<EffectEstimate<T>> {
        let offset = self.cfg.augmentation.offset(effect)?;
        let mut e = EffectEstimate {
            effect,
            value: [T::zero(); 9],
            sigma: [T::zero(); 9],
        };
        for (k, (v, s)) in e
            .value
            .iter_mut()
            .zip(e.sigma.iter_mut())
            .take(effect.states())
            .enumerate()
        {
            // The block's states alone (the whole state formed per effect cost the board
            // ≈ 0.3k instructions a master update each).
            *v = self.kf.state_at(offset + k);
            *s = self.kf.sigma(offset + k);
        }
        if effect.is_clock() {
            if let Some(v) = e.value.first_mut() {
                *v += T::of(self.delay_s);
            }
        }
        if effect == Effect::ClockDrift {
            if let Some(v) = e.value.get_mut(1) {
                *v += T::of(self.delay_rate);
            }
        }
        Some(e)
    }

    /// The slave navigation solution, once initialized.
    pub fn nav(&self) -> Option<&NavState<T>> {
        self.strapdown.as_ref().map(|s| &s.nav)
    }

    /// The current estimates with their standard deviations.
    pub fn estimates(&self) -> Estimates<T> {
        let kf = &self.kf;
        let block = |b: usize| kf.state3(b);
        let sig =
            |b: usize| Vector3::new(self.kf.sigma(b), self.kf.sigma(b + 1), self.kf.sigma(b + 2));
        Estimates {
            t: self.last_update_t,
            gyro_bias: self.gyro_bias + block(BG),
            gyro_bias_sigma: sig(BG),
            accel_bias: self.accel_bias + block(BA),
            accel_bias_sigma: sig(BA),
            misalignment: self.misalignment + block(MU),
            misalignment_sigma: sig(MU),
            flexure: block(TH),
            // A rigid axis's θ is zero and known: its state's variance is a placeholder.
            flexure_sigma: Vector3::from_fn(|k, _| {
                if self.rigid_axes.get(k).copied().unwrap_or(false) {
                    T::zero()
                } else {
                    self.kf.sigma(TH + k)
                }
            }),
        }
    }

    /// Queues a master message; it is matched as soon as the slave solution reaches
    /// its time of validity (during this call if it already has). `reports` is cleared,
    /// then holds the matches this call made (kept on an overflow error too: the matches
    /// happened). It is the caller's, not returned, so that the call copies no reports
    /// (a `StepReports` is a few kilobytes; see `StepReports`).
    pub fn push_master(
        &mut self,
        msg: MasterNav<T>,
        reports: &mut StepReports<T>,
    ) -> Result<(), EngineError> {
        let _phase = probe::enter(Phase::Engine);
        reports.clear();
        let finite = msg.t.is_finite()
            && msg.q_bm_n.coords.iter().all(|v| v.is_finite())
            && msg.v_n.iter().all(|v| v.is_finite())
            && msg.w_ib_bm.is_none_or(|w| w.iter().all(|v| v.is_finite()));
        if !finite {
            self.fate.non_finite += 1;
            return Err(EngineError::NonFinite);
        }
        let newest_queued = self
            .pending
            .back()
            .map(|m| m.t)
            .or(self.prev_master.map(|p| p.t));
        if newest_queued.is_some_and(|t| msg.t <= t) {
            self.counters.master_out_of_order += 1;
            return Err(EngineError::MasterOutOfOrder);
        }
        let mut overflow = false;
        if self.pending.is_full() {
            let _ = self.pending.pop_front();
            self.counters.master_dropped += 1;
            overflow = true;
        }
        let _ = self.pending.push_back(msg);
        self.advance(reports);
        if overflow {
            Err(EngineError::PendingOverflow)
        } else {
            Ok(())
        }
    }

    /// Takes one IMU sample. It is integrated (strapdown, alignment buffer, the
    /// filter's time update when a period has elapsed) once a master message at or
    /// after its interval has arrived, or when `IMU_HOLD_DEPTH` later samples have:
    /// so a master message arriving late is still matched at its own filter epoch,
    /// and the estimates do not depend on the link's latency.
    ///
    /// `reports` is cleared, then holds the matches this call made (as for
    /// [`Engine::push_master`]).
    pub fn push_imu(
        &mut self,
        s: ImuIncrement<T>,
        reports: &mut StepReports<T>,
    ) -> Result<(), EngineError> {
        let _phase = probe::enter(Phase::Engine);
        reports.clear();
        // (Over the vectors' slices: nalgebra's iterators cost the board ≈ 100
        // instructions a sample here.)
        if !(s.t.is_finite()
            && s.dtheta_b
                .as_slice()
                .iter()
                .chain(s.dv_b.as_slice())
                .all(|v| v.is_finite()))
        {
            return Err(EngineError::NonFinite);
        }
        let Some(t_prev) = self.last_imu_t.replace(s.t) else {
            // The first sample only starts the clock (recording-v1).
            return Ok(());
        };
        if s.t <= t_prev {
            self.last_imu_t = Some(t_prev);
            return Err(EngineError::ImuTimeNotIncreasing);
        }
        self.counters.imu_samples += 1;
        let dt = s.t - t_prev;
        // After a gap (an interval much longer than the last) the coning and sculling
        // corrections must not pair this interval with one from before the gap.
        let gap = self.last_imu_dt.is_some_and(|last| dt > GAP_FACTOR * last);
        self.last_imu_dt = Some(dt);
        if self.held.is_full() {
            // The master is later than the hold allows: the oldest sample goes on alone.
            if let Some(oldest) = self.held.pop_front() {
                self.integrate(&oldest);
                self.process_pending(reports);
            }
        }
        let _ = self.held.push_back(HeldImu { s, dt, gap });
        self.advance(reports);
        Ok(())
    }

    /// Integrates every held IMU sample (end of stream: no master message will come
    /// for them) and matches what that reaches; `reports` is cleared, then holds those
    /// matches.
    pub fn flush(&mut self, reports: &mut StepReports<T>) {
        let _phase = probe::enter(Phase::Engine);
        reports.clear();
        while let Some(h) = self.held.pop_front() {
            self.integrate(&h);
            self.process_pending(reports);
        }
    }

    /// The slave time up to which the solution must be integrated before the master
    /// message stamped `t` is matched: its time of validity `t − τ̂`. With a delay in the
    /// layout or declared (`matches_off_epoch`) the matching time falls anywhere between
    /// filter epochs, and the flexure states are read from the nearer epoch
    /// (`flexure_lag`): in the first half of a period from the epoch before it (the slave
    /// goes to `t − τ̂`), in the second half from the epoch that ends it (the slave goes on
    /// to that epoch first). Reading
    /// from the epoch after it alone put a whole period between the flexure states
    /// and a matching time just past an epoch (a delay estimate crossing zero), whose
    /// linear read-back then missed the flexure's curvature and its rate's change:
    /// resets and gated innovations on a flexing draw (docs/diagnosis.md "Session 10").
    fn needed_until(&self, t: f64) -> f64 {
        let t_s = self.slave_time(t);
        if !self.off_epoch {
            return t_s;
        }
        let period = self.cfg.filter_period_s;
        match (self.epoch, self.strapdown.is_some()) {
            (Some(ep), true) => {
                let last = ep.next_t - period;
                if t_s <= last + self.epoch_reach_s {
                    t_s
                } else {
                    let k = libm::ceil((t_s - ep.next_t) / period - 1e-6).max(0.0);
                    let after = ep.next_t + k * period;
                    if t_s - (after - period) <= 0.5 * period {
                        t_s
                    } else {
                        after
                    }
                }
            }
            _ => t_s,
        }
    }

    /// Whether the layout carries the master delay (matching at t − τ̂, epoch-consistent):
    /// `time_delay` or `clock_drift`.
    fn has_delay(&self) -> bool {
        self.has_delay
    }

    /// Time of the master stamp `t` since the clock's reference t₀ (0 before the start).
    fn clock_dt(&self, t: f64) -> f64 {
        self.clock_t0.map_or(0.0, |t0| t - t0)
    }

    /// Slave time of the master stamp `t`: `t − τ(t)`. With no delay (τ ≡ +0, the
    /// declared model's) `t` itself, as the subtraction gives it (`t − (+0) = t`, −0 and
    /// NaN included), without its software `f64` (≈ 50 instructions a call, five or six
    /// calls a master update).
    fn slave_time(&self, t: f64) -> f64 {
        // Both bit patterns zero (+0), tested a word at a time as in `delay_at`.
        let zero = |x: f64| {
            let bits = x.to_bits();
            (bits as u32) | ((bits >> 32) as u32) == 0
        };
        if zero(self.delay_s) && zero(self.delay_rate) {
            return t;
        }
        t - self.delay_at(t)
    }

    /// The nominal delay of the master message stamped `t`: τ̂ + τ̂̇ (t − t₀), within
    /// ±`MAX_DELAY_S` (τ̂̇ is zero without `clock_drift`).
    ///
    /// Without a clock drift fed back the rate is zero, and τ̂ + 0 · Δt is τ̂ (Δt is finite;
    /// the one bit the sum could change is a zero τ̂'s sign, which `t − τ̂` loses): read
    /// without the product and the sum, each a software `f64` operation on the board (a
    /// call cost ≈ 340 instructions, six calls per master update). The rate's test is on
    /// its bits (either zero), not a software `f64` comparison. τ̂ itself is within
    /// ±`MAX_DELAY_S` (the Config's is checked, each fed-back one clamped) or NaN, which
    /// the clamp returns unchanged: it is returned as it is (the clamp's two comparisons
    /// were 0.5k instructions an update).
    fn delay_at(&self, t: f64) -> f64 {
        // The rate's bits as two words: as one (`bits << 1 == 0`) the compiler turned the
        // test back into a software `f64` comparison with zero (≈ 30 instructions).
        let bits = self.delay_rate.to_bits();
        if (bits as u32) | ((bits >> 32) as u32 & 0x7FFF_FFFF) == 0 {
            return self.delay_s;
        }
        (self.delay_s + self.delay_rate * self.clock_dt(t)).clamp(-MAX_DELAY_S, MAX_DELAY_S)
    }

    /// How long before the flexure states' epoch (the last time update) slave time
    /// `t_s` is (s; from −½ period, after that epoch, once `needed_until` held).
    fn flexure_lag(&self, t_s: f64) -> f64 {
        if !self.off_epoch {
            // No delay: matched at the epoch (`needed_until`).
            return 0.0;
        }
        self.epoch
            .map_or(0.0, |ep| ep.next_t - self.cfg.filter_period_s - t_s)
    }

    /// Integrates held IMU samples as far as the waiting master messages need (the
    /// sample whose interval contains a master's time of validity, and all before it),
    /// matching each master as soon as the slave solution reaches it.
    /// Reports are appended to `reports` (passed down, not returned: a `StepReports` is
    /// over a kilobyte, and copying it per IMU sample showed in the board's budget).
    fn advance(&mut self, reports: &mut StepReports<T>) {
        self.process_pending(reports);
        while let Some(front) = self.held.front() {
            let interval_start = front.s.t - front.dt;
            // A master message needs the slave up to its time of validity less the delay
            // (and, with a delay, up to the filter epoch after that: `needed_until`).
            let wanted = self
                .pending
                .back()
                .is_some_and(|m| self.needed_until(m.t) > interval_start);
            if !wanted {
                break;
            }
            if let Some(h) = self.held.pop_front() {
                self.integrate(&h);
            }
            self.process_pending(reports);
        }
    }

    /// One IMU sample into the strapdown, the alignment buffer and the filter's time update.
    fn integrate(&mut self, h: &HeldImu<T>) {
        let (s, dt) = (&h.s, h.dt);
        if let Some(sd) = self.strapdown.as_mut() {
            if h.gap {
                sd.reset_history();
            }
            let dtt = T::of(dt);
            // (Element by element, as nalgebra's operations form them: a loop each on
            // the board, at every IMU sample.)
            let (bg, ba) = (&self.gyro_bias, &self.accel_bias);
            let inc = Increments {
                dtheta_b: vec3(|i| vget(&s.dtheta_b, i) - vget(bg, i) * dtt),
                dv_b: vec3(|i| vget(&s.dv_b, i) - vget(ba, i) * dtt),
                dt: dtt,
            };
            {
                let _phase = probe::enter(Phase::Strapdown);
                sd.step_timed(&inc, dt);
            }
            let nav = sd.nav;
            self.buffer.push(Snapshot {
                t: s.t,
                q_b_n: nav.q_b_n,
                v_n: nav.v_n,
                dtheta_raw_b: s.dtheta_b,
                dv_raw_b: s.dv_b,
                dt,
            });
            if let Some(ep) = self.epoch.as_mut() {
                ep.dtheta = vec3(|i| vget(&ep.dtheta, i) + vget(&inc.dtheta_b, i));
                ep.dv = vec3(|i| vget(&ep.dv, i) + vget(&inc.dv_b, i));
                ep.dt += dt;
            }
            self.maybe_predict(s.t);
        } else {
            // Not initialized yet: keep the raw increments for the start.
            self.buffer.push(Snapshot {
                t: s.t,
                q_b_n: UnitQuaternion::identity(),
                v_n: Vector3::zeros(),
                dtheta_raw_b: s.dtheta_b,
                dv_raw_b: s.dv_b,
                dt,
            });
        }
    }

    fn maybe_predict(&mut self, t: f64) {
        let period = self.cfg.filter_period_s;
        let Some(ep) = self.epoch else { return };
        // A sample within a millionth of a period of the epoch counts as reaching it.
        if t + self.epoch_reach_s < ep.next_t || ep.dt <= 0.0 {
            return;
        }
        let Some(nav) = self.strapdown.as_ref().map(|s| s.nav) else {
            return;
        };
        let dtt = T::of(ep.dt);
        let f_b = vec3(|i| vget(&ep.dv, i) / dtt);
        let means = IntervalMeans {
            f_b,
            // The slave's mean force holds the bending arm's `R θ̈` of the period, which
            // the flexure states have not yet predicted: the master's force where it
            // carries one (docs/diagnosis.md "Session 12").
            f_g_b: self.g_force_bs.unwrap_or(f_b),
            w_ib_b: vec3(|i| vget(&ep.dtheta, i) / dtt),
            c_b_n: dcm(&nlerp(&ep.q_start, &nav.q_b_n, T::of(0.5))),
            v_n: nav.v_n,
            pos: nav.pos,
        };
        let model_phase = probe::enter(Phase::Model);
        // Φ written in place (returned by value, it was copied once more per update);
        // `transition_into` writes every row, so it starts zeroed, not as the identity.
        let mut phi = model::Phi::<T, S>::zeroed(model::PHI_ROWS);
        model::transition_into(
            &mut phi,
            &means,
            &self.cfg.flexure,
            &self.cfg.augmentation,
            dtt,
        );
        let mut q = model::process_noise::<T, S>(&self.cfg.process_noise, &self.cfg.flexure, dtt);
        if self.frozen {
            // Frozen quantities take no process noise either (their random walks stop).
            for i in (MU..TH).chain(self.calibrated_effect_states()) {
                if let Some(e) = q.diag.get_mut(i) {
                    *e = T::zero();
                }
            }
        }
        augment::add_process_noise(&mut q.diag, &self.cfg.augmentation, dtt);
        drop(model_phase);
        {
            let _phase = probe::enter(Phase::Predict);
            // The master's Gauss-Markov errors decay on their own, before Φ's other rows.
            let (states, decay) = augment::gauss_markov_states(&self.cfg.augmentation, dtt);
            for i in states {
                self.kf.decay(i, decay);
            }
            self.kf.predict(&phi, &q);
            if !self.frozen {
                floor_tilt_bias_product(&mut self.kf, &means.f_b);
            }
        }
        self.counters.predictions += 1;
        // The next epoch; after a gap, restart the grid from this sample.
        let mut next = ep.next_t + period;
        if next <= t {
            next = t + period;
        }
        self.epoch = Some(Epoch {
            next_t: next,
            q_start: nav.q_b_n,
            dtheta: Vector3::zeros(),
            dv: Vector3::zeros(),
            dt: 0.0,
        });
    }

    /// Matches the pending master messages the slave solution has reached; their reports
    /// are appended to `reports` (dropped when it is full, as before).
    fn process_pending(&mut self, reports: &mut StepReports<T>) {
        // A master that starts the solution leaves the samples after its time to be
        // integrated again, with their time updates, before the next one is matched:
        // done here, outside `match_ready`, whose frame would otherwise sit under the
        // time update's (the board's stack peak, `docs/performance.md`).
        while let Some(start) = self.match_ready(reports) {
            self.catch_up(start);
        }
    }

    /// Matches the pending masters the slave solution has reached, in order, until one
    /// starts the solution (then the start, for `catch_up`) or none is ready.
    #[inline(never)]
    fn match_ready(&mut self, reports: &mut StepReports<T>) -> Option<Start> {
        while let Some(msg) = self.pending.front().copied() {
            let newest = self.buffer.newest_time();
            let needed = self.needed_until(msg.t);
            // With a delay, `needed` may be an epoch computed on the filter grid: allow
            // its rounding against the IMU time stamps.
            let slack = self.match_slack_s;
            if newest.is_none_or(|t| needed > t + slack) {
                break;
            }
            let _ = self.pending.pop_front();
            if self.strapdown.is_none() {
                self.fate.initialized += 1;
                return Some(self.initialize(&msg));
            }
            // The report is written in its place in `reports` (built apart and pushed, it
            // was copied field by field and then whole: 1.3k instructions per master
            // update on the board), or in a spare one when `reports` is full (dropped, as
            // before).
            let fresh = MatchReport {
                t: msg.t,
                ..MatchReport::default()
            };
            let pushed = reports.push(fresh).is_ok();
            let mut spare = None;
            let report = match reports.last_mut() {
                Some(r) if pushed => r,
                _ => spare.insert(fresh),
            };
            match self.match_master(&msg, report) {
                Ok(()) => self.counters.master_matched += 1,
                Err(e) => {
                    if pushed {
                        let _ = reports.pop();
                    }
                    match e {
                        AlignError::TooOld => self.counters.master_stale += 1,
                        AlignError::NotYet => self.fate.unmatched += 1,
                    }
                }
            }
            self.prev_master = Some(PrevMaster {
                t: msg.t,
                q_bm_n: msg.q_bm_n,
            });
            // The rates' run in every layout (its cover holds the velocity and rate
            // channels, `measure`); the rates themselves for the delay's columns, the
            // g-sensitivity's rate column and the lever arm's instrument, the velocity
            // trend for the first two.
            let keep = self.has_delay()
                || self
                    .cfg
                    .augmentation
                    .offset(Effect::GyroGSensitivity)
                    .is_some();
            if let Some(w) = msg.w_ib_bm {
                self.rate_run.push(msg.t);
                if keep || self.fits_master_rate {
                    self.past_master_rates.push(msg.t, w);
                }
                if keep {
                    self.master_trend.push(msg.t, &msg.v_n);
                }
            }
        }
        None
    }

    /// Starts the slave solution at the master message's time of validity `t − τ̂` from
    /// the master's attitude (through μ̂₀), velocity (with the lever arm) and position;
    /// the buffered increments after that time are left to `catch_up`. The filter epochs
    /// follow from there, so that with a constant delay every master is matched at an
    /// epoch, as with none: read back from an epoch at the master's stamp instead, the
    /// flexure states' unpredicted motion over the lag (not in the predicted variance)
    /// cost a declared 20 ms on blind draw 107 0.27 in −2 ln L per innovation
    /// (`docs/diagnosis.md`, "A declared delay matched off the epochs").
    fn initialize(&mut self, msg: &MasterNav<T>) -> Start {
        let t_start = self.slave_time(msg.t);
        // The clock drift's reference: the first start (a reset keeps it, and τ̂ with it).
        self.clock_t0.get_or_insert(msg.t);
        let (nav, c_bs_n) = start_nav(msg, &self.cfg, &self.misalignment);
        // The start holds the master's smooth errors of this instant (see
        // `initial_factor`); only layouts carrying those blocks restart, once per start.
        if let Some(c_bs_n) = c_bs_n {
            Self::restart_covariance(&mut self.kf, &self.cfg, Some(&c_bs_n));
        }
        // The snapshots after the start are integrated again in place (`catch_up`), with no
        // copy of the buffer on the stack (it was the board's stack peak, 9.2 kB).
        self.buffer.drop_until(t_start);
        let raw_count = self.buffer.len();
        self.strapdown = Some(Strapdown::new(nav));
        self.epoch = Some(Epoch {
            next_t: t_start + self.cfg.filter_period_s,
            q_start: nav.q_b_n,
            dtheta: Vector3::zeros(),
            dv: Vector3::zeros(),
            dt: 0.0,
        });
        // The start goes behind the raw snapshots; `catch_up` takes each from the front
        // and puts its integrated copy at the back, so the ring ends oldest first. With
        // the ring full of them the start is left out: it would be the oldest of M + 1.
        if raw_count < ALIGN_DEPTH {
            self.buffer.push(Snapshot {
                t: t_start,
                q_b_n: nav.q_b_n,
                v_n: nav.v_n,
                dtheta_raw_b: Vector3::zeros(),
                dv_raw_b: Vector3::zeros(),
                dt: 0.0,
            });
        }
        self.prev_master = Some(PrevMaster {
            t: msg.t,
            q_bm_n: msg.q_bm_n,
        });
        self.last_update_t = msg.t;
        Start {
            t: t_start,
            raw_count,
        }
    }

    /// Integrates again, from the start `initialize` made, the snapshots the buffer held
    /// after the starting master's time (`start.raw_count`, oldest first): their
    /// increments count in the first filter period, and a period they complete is
    /// predicted before the next master is matched. With the IMU at the master's rate
    /// the first master waits for a sample after its time, so the first period is
    /// complete here; matched without its time update, the next master's attitude was
    /// taken as known to its noise (blind seed 41 handed its truth, attitude matched
    /// alone at 1e-7 rad: NEES 195, 40.5 with this, `docs/model-learning.md`).
    ///
    /// They go back to the front of the hold, where `advance` (or `flush`) integrates
    /// them as it does every sample, at no deeper stack than that (the board's peak is
    /// the time update's, `docs/performance.md`); only when the hold has no room for
    /// them are they integrated from here.
    #[inline(never)]
    fn catch_up(&mut self, start: Start) {
        let n = start.raw_count;
        let after_start =
            |buffer: &AlignBuffer<T, ALIGN_DEPTH>, k: usize| after_start(buffer, k, start.t);
        // One slot kept free: `push_imu` may be about to hold the sample it was given.
        if IMU_HOLD_DEPTH.saturating_sub(self.held.len()) > n {
            // Newest first, each to the front.
            for k in (0..n).rev() {
                if let Some(h) = after_start(&self.buffer, k) {
                    let _ = self.held.push_front(h);
                }
            }
            for _ in 0..n {
                let _ = self.buffer.pop_oldest();
            }
        } else {
            for _ in 0..n {
                if let Some(h) = after_start(&self.buffer, 0) {
                    let _ = self.buffer.pop_oldest();
                    self.integrate(&h);
                }
            }
        }
    }

    /// Matches `msg`: its channels' updates go into `report` (which holds its time, every
    /// channel `None`), the estimates are fed back.
    fn match_master(
        &mut self,
        msg: &MasterNav<T>,
        report: &mut MatchReport<T>,
    ) -> Result<(), AlignError> {
        // The master's state belongs to the slave's time t − τ̂ (τ̂ = 0 without the delay block).
        let _phase = probe::enter(Phase::Matching);
        // `match_ready` let a time of validity within its slack past the newest sample
        // through (an epoch on the filter grid against the IMU stamps' rounding): it is
        // read at that sample.
        let t_s = self.slave_time(msg.t);
        let t_s = self.buffer.at_most_newest(t_s);
        let slave = self.buffer.at(t_s)?;
        // The flexure states belong to the last epoch, `lag` after the matching time:
        // the measurement sees θ(t_s) = θ − lag θ̇ (exact for a flexure linear over the
        // period). Zero without a delay in the layout (matching at the epoch).
        let lag = T::of(self.flexure_lag(t_s));
        let theta_at = |kf: &Kalman<T, S>| {
            Vector3::from_fn(|k, _| kf.state_at(TH + k) - lag * kf.state_at(THD + k))
        };
        // ... and θ̇(t_s) = θ̇ − lag θ̈, θ̈ = α θ + β θ̇ from each axis's model: the rate
        // read at the epoch instead moved a fed-back delay estimate by ten times its σ
        // (docs/diagnosis.md "Session 13").
        // Only off the epoch (a delay in the layout) is the acceleration needed.
        let accel = if lag == T::zero() {
            [(T::zero(), T::zero()); 3]
        } else {
            let period = self.cfg.flexure.period_s;
            self.cfg.flexure.axes.map(|a| a.acceleration(period))
        };
        let flexure = (
            theta_at(&self.kf),
            Vector3::from_fn(|k, _| {
                let (th, thd) = (self.kf.state_at(TH + k), self.kf.state_at(THD + k));
                let (alpha, beta) = accel.get(k).copied().unwrap_or((T::zero(), T::zero()));
                thd - lag * (alpha * th + beta * thd)
            }),
        );
        let nominal = Nominal {
            cfg: &self.cfg,
            buffer: &self.buffer,
            gyro_bias: self.gyro_bias,
            accel_bias: self.accel_bias,
            misalignment: self.misalignment,
            prev_master: self.prev_master,
            past_master_rates: &self.past_master_rates,
            master_trend: &self.master_trend,
            has_delay: self.has_delay(),
            fits_master_rate: self.fits_master_rate,
            carried_force: self.carried_force,
            rates_cover: self.rate_run.covers(msg.t),
            clock_dt: self.clock_dt(msg.t),
        };
        let m = measure(&nominal, msg, t_s, &slave, &flexure);
        if m.held {
            self.fate.channels_held += 1;
        }
        let aug = self.cfg.augmentation;
        if let (Some(sig), Some(_)) = (&m.sig, msg.w_ib_bm) {
            if self.carried_force {
                self.g_force_bs = Some(sig.f_carried_bs);
            }
        }
        let update = |engine: &mut Self,
                      c: &Measured<T>,
                      channel: Channel,
                      out: &mut Option<[ScalarUpdate<T>; 3]>| {
            let mut rows: model::Rows<T, S> = [mat::zeros(), mat::zeros(), mat::zeros()];
            model::put_blocks(&mut rows, &c.blocks);
            if let Some(sig) = &m.sig {
                augment::add_measurement(&mut rows, &aug, channel, sig);
            }
            if lag != T::zero() {
                // a θ(t_s) + c θ̇(t_s) = (a − c lag α) θ + (c − a lag − c lag β) θ̇.
                for row in rows.iter_mut() {
                    for (k, &(alpha, beta)) in accel.iter().enumerate() {
                        let (a, c) = (vget(row, TH + k), vget(row, THD + k));
                        if let Some(e) = row.get_mut(TH + k) {
                            *e = a - c * lag * alpha;
                        }
                        if let Some(e) = row.get_mut(THD + k) {
                            *e = c - a * lag - c * lag * beta;
                        }
                    }
                }
            }
            // The rows' candidate columns: the declared blocks' (θ̇'s too when the lag
            // moves θ's into them), then every augmented one.
            let three = |o: usize| {
                u32::try_from(o)
                    .ok()
                    .and_then(|o| 0b111u32.checked_shl(o))
                    .unwrap_or(0)
            };
            let mut declared = 0;
            for (offset, _) in &c.blocks {
                declared |= three(*offset);
            }
            if lag != T::zero() {
                declared |= three(TH) | three(THD);
            }
            // A rigid axis's θ and θ̇ are inert (`AxisModel::is_rigid`): no column.
            for (k, &rigid) in engine.rigid_axes.iter().enumerate() {
                if rigid {
                    for row in rows.iter_mut() {
                        for i in [TH + k, THD + k] {
                            if let Some(e) = row.get_mut(i) {
                                *e = T::zero();
                            }
                        }
                    }
                }
            }
            let cols = (declared, N);
            let gate = engine.cfg.gate_sigma;
            engine.update3(&rows, cols, &c.z, c.r, gate, out.insert([unused(); 3]));
        };
        if let Some(c) = &m.velocity {
            update(self, c, Channel::Velocity, &mut report.velocity);
        }
        if let Some((z, r)) = m.attitude {
            // Linearized at the flexure at the matching time as the velocity update left
            // it, θ(t_s) = θ − lag θ̇.
            let blocks = attitude_blocks(&m.jr, &self.misalignment, &theta_at(&self.kf));
            let c = Measured { z, blocks, r };
            update(self, &c, Channel::Attitude, &mut report.attitude);
        }
        if let Some(c) = &m.angular_rate {
            update(self, c, Channel::AngularRate, &mut report.angular_rate);
        }
        {
            let _phase = probe::enter(Phase::Engine);
            self.feedback(t_s);
            self.reset_if_stuck(report);
        }
        self.last_update_t = msg.t;
        Ok(())
    }

    /// The three scalar updates of one channel's rows (`cols`: where they may be non-zero,
    /// a bit per column, see [`Kalman::update_scalar_on`]), their reports into `out`.
    fn update3(
        &mut self,
        rows: &model::Rows<T, S>,
        cols: (u32, usize),
        z: &Vector3<T>,
        r: Vector3<T>,
        gate: T,
        out: &mut [ScalarUpdate<T>; 3],
    ) {
        let _phase = probe::enter(Phase::Update);
        // `z` and `r` as slices (nalgebra's iterators are loops of their own on the board).
        let (z, r) = (z.as_slice(), r.as_slice());
        for (((row, slot), z), r) in rows.iter().zip(out.iter_mut()).zip(z).zip(r) {
            *slot = self.kf.update_scalar_on(row, cols, *z, *r, gate);
        }
    }

    /// Counts, per channel, the messages in a row with a rejected measurement and
    /// re-initializes after `RESET_AFTER_GATED_MESSAGES` of them: the slave solution
    /// restarts from the next master message and the covariance from its initial value,
    /// while the bias and misalignment estimates are kept as the new starting point.
    fn reset_if_stuck(&mut self, report: &MatchReport<T>) {
        // Borrowed, not copied (three scalar updates a channel: a `memcpy` each on the board).
        let channels = [&report.velocity, &report.attitude, &report.angular_rate];
        for (streak, channel) in self.gated_streaks.iter_mut().zip(channels) {
            let gated = channel
                .as_ref()
                .is_some_and(|u| u.iter().any(|s| !s.accepted));
            *streak = if gated { streak.saturating_add(1) } else { 0 };
        }
        if self
            .gated_streaks
            .iter()
            .any(|&s| s >= RESET_AFTER_GATED_MESSAGES)
        {
            self.reset();
        }
    }

    /// The re-initialization itself: slave solution dropped (the next master message
    /// restarts it), covariance back to P₀, health counters kept, the reset counted.
    fn reset(&mut self) {
        Self::restart_covariance(&mut self.kf, &self.cfg, None);
        self.strapdown = None;
        self.buffer.clear();
        self.epoch = None;
        self.gated_streaks = [0; 3];
        self.past_master_rates.clear();
        self.rate_run = RateRun::new();
        self.master_trend = VelocityTrend::new();
        self.g_force_bs = None;
        self.counters.resets += 1;
    }

    /// Closed loop: the estimated navigation errors, sensor biases and misalignment
    /// go into the nominal solution and their states return to zero. Flexure stays.
    /// `t`: the time of the master message just matched; later messages are later.
    fn feedback(&mut self, t: f64) {
        // The states read one by one (the whole state vector formed and copied cost the
        // board ≈ 0.5k instructions a call).
        let kf = &self.kf;
        let block = |b: usize| kf.state3(b);
        let (dv, psi) = (block(V), block(PSI));
        let (bg, ba, mu) = (block(BG), block(BA), block(MU));
        let delay = self.cfg.augmentation.offset(Effect::TimeDelay);
        let clock = self.cfg.augmentation.offset(Effect::ClockDrift);
        let at = |o: Option<usize>, k: usize| o.map_or(T::zero(), |o| kf.state_at(o + k));
        let (x_delay, x_clock, x_clock_rate) = (at(delay, 0), at(clock, 0), at(clock, 1));
        self.gyro_bias += bg;
        self.accel_bias += ba;
        self.misalignment += mu;
        if let Some(sd) = self.strapdown.as_mut() {
            // Compensated like the strapdown's own steps (a small ψ rounded into the
            // f32 quaternion would be lost systematically).
            sd.correct(&dv, &psi);
        }
        self.buffer.correct_since(t, &dv, &psi);
        self.kf.reset_states(V..TH);
        // The delay is fed back only once it is known to a fraction of a filter period:
        // early on, its estimate also carries the start's velocity and attitude errors,
        // and moving the matching time by such a guess corrupts the flexure states.
        if let Some(o) = delay.filter(|&o| self.kf.sigma(o).to_f64() < DELAY_FEEDBACK_SIGMA_S) {
            let tau = self.delay_s + x_delay.to_f64();
            self.delay_s = tau.clamp(-MAX_DELAY_S, MAX_DELAY_S);
            self.kf.reset_states(o..o + 1);
        }
        // The clock drift's pair once the delay it gives is known to 1 ms now and over
        // the next `CLOCK_DRIFT_PRIOR_SPAN_S` (σ bounded by σ(τ₀) + Δ σ(τ̇), the
        // correlation left out, Δ at least that span: near t₀ the rate is not yet known
        // however well the delay is, and a rate fed back early moves every later
        // matching time by its error).
        if let Some(o) = clock {
            let dt = self.clock_dt(t).abs().max(CLOCK_DRIFT_PRIOR_SPAN_S);
            let sigma = self.kf.sigma(o).to_f64() + dt * self.kf.sigma(o + 1).to_f64();
            if sigma < DELAY_FEEDBACK_SIGMA_S {
                let tau = self.delay_s + x_clock.to_f64();
                let rate = self.delay_rate + x_clock_rate.to_f64();
                self.delay_s = tau.clamp(-MAX_DELAY_S, MAX_DELAY_S);
                self.delay_rate = rate.clamp(-MAX_DELAY_RATE, MAX_DELAY_RATE);
                self.kf.reset_states(o..o + 2);
            }
        }
    }
}

/// The slave's navigation state at a start from the master message `msg`
/// ([`Engine::initialize`]): the master's attitude through μ̂₀ (`misalignment`), its
/// velocity with the lever arm's, its position moved by the arm; and, where the layout
/// carries the master's smooth errors (`initial_factor`), the slave's attitude `Ĉ_bs^n`
/// for the filter's restart. One copy for the board's two layouts (a copy per size cost
/// ≈ 0.8 kB of flash).
#[inline(never)]
fn start_nav<T: Real>(
    msg: &MasterNav<T>,
    cfg: &EngineConfig<T>,
    misalignment: &Vector3<T>,
) -> (NavState<T>, Option<Matrix3<T>>) {
    let c_bm_n = dcm(&msg.q_bm_n);
    let r0 = cfg.lever_arm_m;
    let q_bs_n = msg.q_bm_n * quat_exp(misalignment);
    let lever_v = c_bm_n * msg.w_ib_bm.map_or(Vector3::zeros(), |w| w.cross(&r0));
    let restart = Effect::MASTER_ERRORS
        .iter()
        .any(|&e| cfg.augmentation.offset(e).is_some());
    let c_bs_n = restart.then(|| dcm(&q_bs_n));
    let nav = NavState {
        q_b_n: q_bs_n,
        v_n: msg.v_n + lever_v,
        pos: earth::Local::at(&msg.pos).offset_position(&(c_bm_n * r0)),
    };
    (nav, c_bs_n)
}

/// The buffer's sample `k` (oldest first) of those after a start at `start_t`, its
/// interval cut at the start ([`Engine::catch_up`]); one copy for the board's two layouts.
#[inline(never)]
fn after_start<T: Real>(
    buffer: &AlignBuffer<T, ALIGN_DEPTH>,
    k: usize,
    start_t: f64,
) -> Option<HeldImu<T>> {
    let s = buffer.iter().nth(k)?;
    let dt = s.t - (s.t - s.dt).max(start_t);
    let frac = T::of(if s.dt > 0.0 {
        (dt / s.dt).clamp(0.0, 1.0)
    } else {
        0.0
    });
    Some(HeldImu {
        s: ImuIncrement {
            t: s.t,
            dtheta_b: s.dtheta_raw_b * frac,
            dv_b: s.dv_raw_b * frac,
        },
        dt,
        gap: false,
    })
}

/// [`Engine::initial_factor`] for any state dimension `n` (`d`'s length; `u` its
/// `n × n` storage, element `(i, j)` at `j n + i` as nalgebra's): one copy for the board's
/// two layouts (a copy per size cost ≈ 0.85 kB of flash).
#[inline(never)]
fn initial_factor_n<T: Real>(
    cfg: &EngineConfig<T>,
    start_c_bs_n: Option<&Matrix3<T>>,
    u: &mut [T],
    d: &mut [T],
) {
    let n = d.len();
    // `mat::get` and `mat::set` on the `n × n` storage: nothing outside it.
    let get_u = |u: &[T], i: usize, j: usize| {
        let e = if i < n && j < n {
            u.get(j * n + i)
        } else {
            None
        };
        e.copied().unwrap_or_else(T::zero)
    };
    let set_u = |u: &mut [T], i: usize, j: usize, v: T| {
        if let Some(e) = u.get_mut(j * n + i).filter(|_| i < n && j < n) {
            *e = v;
        }
    };
    let s = &cfg.initial_sigma;
    let sq = |x: T| x * x;
    let mut set_d = |i: usize, v: T| {
        if let Some(e) = d.get_mut(i) {
            *e = v;
        }
    };
    let blocks = [
        (V, sq(s.velocity_mps)),
        (MU, sq(s.misalignment_rad)),
        (BG, sq(s.gyro_bias_radps)),
        (BA, sq(s.accel_bias_mps2)),
    ];
    for (b, var) in blocks {
        for k in 0..3 {
            set_d(b + k, var);
        }
    }
    for (axis, ar) in cfg.flexure.axes.iter().enumerate() {
        let (i, j) = (TH + axis, THD + axis);
        if ar.is_rigid() {
            // Inert, as the states past the layout: unit variance, tied to nothing
            // (below: not to ψ either), read by no row (`match_master`).
            set_d(i, T::one());
            set_d(j, T::one());
            continue;
        }
        match ar.stationary_covariance(cfg.flexure.period_s) {
            Some(c) => {
                let (a, b, e) = (mat::get(&c, 0, 0), mat::get(&c, 0, 1), mat::get(&c, 1, 1));
                set_d(j, e);
                if e > T::zero() {
                    set_u(u, i, j, b / e);
                    set_d(i, (a - b * b / e).max(T::zero()));
                } else {
                    set_d(i, a);
                }
            }
            None => {
                let t = cfg.flexure.period_s;
                set_d(i, sq(s.flexure_rad));
                set_d(j, sq(s.flexure_rad / t));
            }
        }
    }
    // Augmented blocks: their priors; states past them are inert (unit variance).
    for b in cfg.augmentation.blocks() {
        for k in 0..b.effect.states() {
            let scale = T::of(b.effect.state_prior_scale(k));
            set_d(b.offset + k, sq(b.prior_sigma * scale));
        }
    }
    for i in cfg.augmentation.dimension()..n {
        set_d(i, T::one());
    }
    // ψ = −J (δμ + θ) + n. U maps the independent parts e (variances D) to the states,
    // x = U e, and θ = e_θ + U(θ, θ̇) e_θ̇: so ψ's row is −J at δμ and θ and
    // −J U(θ, θ̇) at θ̇. A rigid axis's θ is zero: nothing at its columns.
    let j = right_jacobian(&cfg.initial_misalignment_rad);
    for r in 0..3 {
        for c in 0..3 {
            let v = -mat::get(&j, r, c);
            set_u(u, PSI + r, MU + c, v);
            if cfg.flexure.axes.get(c).is_some_and(AxisModel::is_rigid) {
                continue;
            }
            set_u(u, PSI + r, TH + c, v);
            let w = v * get_u(u, TH + c, THD + c);
            set_u(u, PSI + r, THD + c, w);
        }
        let sigma = cfg.measurement_noise.attitude_rad.get(r).copied();
        set_d(PSI + r, sq(sigma.unwrap_or_else(T::zero)));
    }
    // The master's smooth errors at the start: ψ's row `Ĉ_bs^nᵀ` at φ_m's columns,
    // δv's the identity at δv_m's.
    let att = cfg.augmentation.offset(Effect::MasterAttitudeError);
    let vel = cfg.augmentation.offset(Effect::MasterVelocityError);
    if let Some(c_bs_n) = start_c_bs_n {
        for r in 0..3 {
            for c in 0..3 {
                if let Some(o) = att {
                    set_u(u, PSI + r, o + c, mat::get(c_bs_n, c, r));
                }
                if let (Some(o), true) = (vel, r == c) {
                    set_u(u, V + r, o + c, T::one());
                }
            }
        }
    }
}

/// Raises the accelerometer bias's variance along its sharpest direction to the floor
/// the tilt–bias product sets ([`tilt_bias::floor`]) where the filter claims less: the
/// velocity's second-order error that Φ leaves out, `½|∇⊥|²/|f|` along the specific
/// force, is that large whatever the vertical velocity says. `f_b`: the period's mean
/// specific force (m/s², slave body). A rank-one addition to the factors; nothing when
/// the floor does not bind (a ship whose motion parts the tilt from the biases).
fn floor_tilt_bias_product<T: Real, const S: usize>(kf: &mut Kalman<T, S>, f_b: &Vector3<T>) {
    let mut scratch = [[T::zero(); S]; 2];
    let [h, f] = &mut scratch;
    floor_tilt_bias_product_n(kf.parts(), f_b, [h, f]);
}

/// [`floor_tilt_bias_product`] for any state dimension: one copy for the board's two
/// layouts (a copy per size, inlined into each time update, cost ≈ 0.9 kB of flash).
/// `scratch`: two temporaries of the filter's dimension, zero.
#[inline(never)]
fn floor_tilt_bias_product_n<T: Real>(
    mut kf: Parts<'_, T>,
    f_b: &Vector3<T>,
    [h, f]: [&mut [T]; 2],
) {
    let (xx, yy, zz) = (
        kf.cov(BA, BA),
        kf.cov(BA + 1, BA + 1),
        kf.cov(BA + 2, BA + 2),
    );
    let (xy, xz, yz) = (
        kf.cov(BA, BA + 1),
        kf.cov(BA, BA + 2),
        kf.cov(BA + 1, BA + 2),
    );
    let p_ba = Matrix3::new(xx, xy, xz, xy, yy, yz, xz, yz, zz);
    // (The norm's square root the FPU's, not libm's software `sqrtf`: the same value.)
    let Some(fl) = tilt_bias::floor(&p_ba, f_b.norm_squared().sqrt_fast()) else {
        return;
    };
    let u = fl.direction_b;
    let c = [(BA, u.x), (BA + 1, u.y), (BA + 2, u.z)];
    if let Some(v) = kf
        .variance_along(&c, [&mut *h, f])
        .filter(|&v| v < fl.variance)
    {
        kf.add_rank_one(&c, fl.variance - v, h);
    }
}

/// What the matching of a master message reads of the engine besides its filter,
/// borrowed. The board instantiates the engine at two sizes (`Engine<f32, 21>` and
/// `Engine<f32, 33>`), and every method of it is one copy per size, also where its code
/// does not depend on the size: the matching's algebra is therefore in free functions
/// of this and the filter's few states they need ([`measure`], [`attitude_blocks`]), one
/// copy per `T` (docs/performance.md, "What issue12-s11 changed").
struct Nominal<'a, T: Real> {
    cfg: &'a EngineConfig<T>,
    buffer: &'a AlignBuffer<T, ALIGN_DEPTH>,
    gyro_bias: Vector3<T>,
    accel_bias: Vector3<T>,
    misalignment: Vector3<T>,
    prev_master: Option<PrevMaster<T>>,
    past_master_rates: &'a PastRates<T>,
    master_trend: &'a VelocityTrend<T>,
    /// Whether the layout carries the master delay (`Engine::has_delay`).
    has_delay: bool,
    /// Whether the layout has columns that take the master's rate from its past rates
    /// (`Engine::fits_master_rate`).
    fits_master_rate: bool,
    /// Whether the layout's dynamics columns take the master's carried force
    /// (`Engine::carried_force`).
    carried_force: bool,
    /// Whether the master's past rates cover their window before this message
    /// ([`RateRun::covers`]).
    rates_cover: bool,
    /// The message's time since the clock's reference t₀ (s; `Engine::clock_dt`).
    clock_dt: f64,
}

/// One three-axis matching measurement before the filter: its residual, its rows'
/// declared blocks ([`model::Blocks`]) and its noise variance per axis.
struct Measured<T: Real> {
    z: Vector3<T>,
    blocks: model::Blocks<T>,
    r: Vector3<T>,
}

/// What [`measure`] finds for one master message: each channel in use (the attitude's
/// residual and noise only: its rows are linearized at the flexure as the velocity update
/// leaves it, [`attitude_blocks`]), `J_r(μ̂)`, and the augmented columns' ingredients
/// when the layout has augmented blocks.
struct Measurements<T: Real> {
    velocity: Option<Measured<T>>,
    attitude: Option<(Vector3<T>, Vector3<T>)>,
    angular_rate: Option<Measured<T>>,
    jr: Matrix3<T>,
    sig: Option<Signature<T>>,
    /// Whether the velocity or rate channel in use was held (see [`MasterFate`]).
    held: bool,
}

/// The matching of the master message `msg` at slave time `t_s` (`slave`: the slave's
/// solution there) before the filter: residuals, the declared blocks of the velocity and
/// rate rows, the noises, the augmented columns' ingredients. `flexure`: the filter's
/// θ(t_s) = θ − lag θ̇ and θ̇(t_s) = θ̇ − lag θ̈ before any update of this message.
#[inline(never)]
fn measure<T: Real>(
    e: &Nominal<'_, T>,
    msg: &MasterNav<T>,
    t_s: f64,
    slave: &SlaveAt<T>,
    flexure: &(Vector3<T>, Vector3<T>),
) -> Measurements<T> {
    let c_bm_n = dcm(&msg.q_bm_n);
    let jr = right_jacobian(&e.misalignment);
    let m = e.cfg.matching;
    let noise = &e.cfg.measurement_noise;
    // The latitude's trig and radii once for every use at the master's position.
    let here = earth::Local::at(&msg.pos);
    let (w_eb, w_eb_var) =
        master_rate_wrt_earth(msg, e.prev_master.as_ref(), e.cfg, &here, &c_bm_n);
    let rate = e.buffer.rate_at(t_s).ok();
    // The master's angular acceleration at the message, for the delay's rate and
    // velocity columns, and its rate there from its previous rates, the lever-arm
    // columns' instrument.
    let gives_rate = msg.w_ib_bm.is_some();
    let covered = gives_rate && e.rates_cover;
    let fit = if (e.has_delay || e.fits_master_rate) && covered {
        // The master's own rate noise variance (rad²/s²; the lever arm's, which holds
        // none of the slave side's model error).
        let sigma = e.cfg.measurement_noise.lever_arm_rate_radps;
        let noise_var = sigma * sigma;
        e.past_master_rates.fit(msg.t, noise_var)
    } else {
        None
    };
    let slope = fit.filter(|_| e.has_delay).map(|f| f.slope);
    // Where the master gives its rate but its past rates do not yet cover their window
    // (the start, a gap), the delay has no rate or velocity column, while those
    // residuals hold the delay's `τ ω̇` and `τ v̇`: matched with a zero column, they
    // told the delay's state what the flexure could not take (a 5 ms delay on
    // noise-free data read as 0.2 ± 0.1 ms, docs/diagnosis.md "Session 14"). Those two
    // channels are held until the columns form; the attitude's is the master's rate.
    // Held in every layout, so that runs with and without the delay match the same
    // innovations and their likelihoods compare (`diagnose`).
    let held = gives_rate && (!covered || (e.has_delay && slope.is_none()));
    let sig = (!e.cfg.augmentation.is_empty()).then(|| {
        let ingredients = (rate.as_ref(), fit);
        signature(e, msg, ingredients, slave, &here, &c_bm_n, &w_eb, flexure)
    });
    let velocity = (m.velocity && !held).then(|| {
        let r0 = e.cfg.lever_arm_m;
        let z = model::velocity_residual(&slave.v_n, &msg.v_n, &c_bm_n, &w_eb, &r0);
        let r_bend = e.cfg.bending.matrix(&r0);
        let blocks =
            model::velocity_blocks(&c_bm_n, &w_eb, e.cfg.dynamic_lever_arm.then_some(&r_bend));
        // The master's velocity noise, plus the rate noise carried by the lever arm:
        // var(n_ω × r0) averaged over the axes is ⅔ |r0|² σ_ω².
        let lever = T::of(2.0 / 3.0) * r0.norm_squared() * w_eb_var;
        let r = noise.velocity_mps.map(|s| s * s + lever);
        Measured { z, blocks, r }
    });
    let attitude = m.attitude.then(|| {
        let z = model::attitude_residual(&e.misalignment, &c_bm_n, &dcm(&slave.q_b_n));
        (z, noise.attitude_rad.map(|s| s * s))
    });
    // The master's rate at t_v against the slave's, interpolated at t_v: each message
    // uses its own IMU intervals and its own master sample (white noise).
    let angular_rate = match (m.angular_rate && !held, msg.w_ib_bm, rate) {
        (true, Some(w_m), Some(slave_rate)) => {
            let w_m_bs = mul3v(&transpose3(&exp_so3(&e.misalignment)), &w_m);
            // `model::rate_residual` with Exp(μ̂)ᵀ ω_m computed once.
            // (Element by element, as nalgebra's operations form them: a loop each on the
            // board.)
            let z =
                vec3(|i| (vget(&slave_rate.raw_b, i) - vget(&e.gyro_bias, i)) - vget(&w_m_bs, i));
            let arw = e.cfg.process_noise.gyro_arw;
            let gyro = arw * arw * slave_rate.noise_gain;
            // The slave's rate is a mean over IMU intervals, the flexure state read at
            // t_s the rate at one instant: the flexure rate's diffusion between them is
            // noise of this match (`RateAt::departure_gain`), carried to the slave's axes
            // by J_r(μ̂). Not its diffusion between t_s and the states' epoch (a delay in
            // the layout): that part is the state's own process noise, and counted again
            // here it left structure on the rate (docs/diagnosis.md "Session 13").
            let q = Vector3::from(e.cfg.flexure.axes.map(|a| a.rate_diffusion()));
            let departure = slave_rate.departure_gain;
            let carried = mul3v(&zip3(&jr, &jr, |_, _, a, b| a * b), &q);
            let r = vec3(|i| {
                let s = vget(&noise.rate_radps, i);
                (s * s + gyro) + vget(&carried, i) * departure
            });
            Some(Measured {
                z,
                blocks: model::rate_blocks(&w_m_bs, &jr),
                r,
            })
        }
        _ => None,
    };
    Measurements {
        velocity,
        attitude,
        angular_rate,
        jr,
        sig,
        held: held && (m.velocity || m.angular_rate),
    }
}

/// The attitude rows' declared blocks ([`model::attitude_blocks`]) linearized at the
/// flexure `theta` = θ(t_s): `J_r⁻¹(J_r(μ̂) θ)` and `J_r(μ̂ + θ)`; `jr`: `J_r(μ̂)`.
#[inline(never)]
fn attitude_blocks<T: Real>(
    jr: &Matrix3<T>,
    misalignment: &Vector3<T>,
    theta: &Vector3<T>,
) -> model::Blocks<T> {
    model::attitude_blocks(
        &inverse_right_jacobian_small(&mul3v(jr, theta)),
        &right_jacobian(&(misalignment + theta)),
    )
}

/// The master body's rate relative to the Earth (rad/s, master body), for the
/// lever-arm velocity, with the variance of its noise, the mean over the axes
/// (rad²/s²): from the master's rate when given (`lever_arm_rate_radps`), else from the
/// change of its attitude since the previous message `prev` (√2 σ_att / Δt), else zero
/// with no noise.
/// `here`: the Earth model at the master's position.
fn master_rate_wrt_earth<T: Real>(
    msg: &MasterNav<T>,
    prev: Option<&PrevMaster<T>>,
    cfg: &EngineConfig<T>,
    here: &earth::Local<T>,
    c_bm_n: &Matrix3<T>,
) -> (Vector3<T>, T) {
    let noise = &cfg.measurement_noise;
    let w_ie_b = mul3v(&transpose3(c_bm_n), &here.earth_rate_n());
    if let Some(w) = msg.w_ib_bm {
        let sigma = noise.lever_arm_rate_radps;
        return (w - w_ie_b, sigma * sigma);
    }
    match prev {
        Some(p) if msg.t > p.t && msg.t - p.t <= 2.5 * cfg.filter_period_s.max(1e-3) => {
            let dt = T::of(msg.t - p.t);
            let w_nb = quat_log(&(p.q_bm_n.inverse() * msg.q_bm_n)) / dt;
            let w_en = here.transport_rate_n(&msg.v_n);
            let sigma = axes_rms(&noise.attitude_rad) / dt;
            (
                w_nb + mul3v(&transpose3(c_bm_n), &w_en),
                T::of(2.0) * sigma * sigma,
            )
        }
        _ => (Vector3::zeros(), T::zero()),
    }
}

/// Where the master's rates have run without a gap: a gap is a spacing longer than 2.5
/// of the run's shortest (the master's own period, whatever the filter's: compared with
/// the filter period, a 20 Hz master under a 100 Hz filter never formed the delay's
/// rate column). Kept as the rates arrive, so that the question "do the rates cover
/// their window?", asked of every message in every layout, costs no pass over them
/// (that pass, in software `f64` on the board, cost 23k instructions an update).
#[derive(Clone, Copy, Debug)]
struct RateRun {
    /// The run's first rate (s).
    start: f64,
    /// Its newest (s).
    last: f64,
    /// Its shortest spacing (s; infinite with one rate).
    shortest: f64,
}

impl RateRun {
    fn new() -> Self {
        Self {
            start: f64::INFINITY,
            last: f64::NEG_INFINITY,
            shortest: f64::INFINITY,
        }
    }

    /// A rate at `t`: the run goes on, or (the first rate, one not later than the
    /// previous, a gap) starts again at `t`.
    fn push(&mut self, t: f64) {
        let spacing = t - self.last;
        let goes_on = self.last.is_finite() && spacing > 0.0 && spacing <= 2.5 * self.shortest;
        if goes_on {
            self.shortest = self.shortest.min(spacing);
            self.last = t;
        } else {
            *self = Self {
                start: t,
                last: t,
                shortest: f64::INFINITY,
            };
        }
    }

    /// Whether the run covers `RATE_WINDOW_S` before its newest rate with at least
    /// `RATE_MIN` rates at its shortest spacing, and reaches the message at `t_msg`
    /// without a gap.
    fn covers(&self, t_msg: f64) -> bool {
        self.last - self.start >= RATE_WINDOW_S
            && self.shortest * (RATE_MIN - 1) as f64 <= RATE_WINDOW_S
            && t_msg - self.last <= 2.5 * self.shortest
    }
}

/// The columns' ingredients of the augmented blocks for the message `msg` matched at
/// slave time `t_s`; `rate`: the slave's rate there, `fit`: the master's rate and
/// angular acceleration at the message from its previous rates ([`PastRates::fit`],
/// `None` without a delay or a lever-arm block in the layout; its slope read only with
/// a delay, its rate only with a lever-arm block), `here`: the Earth model at the
/// master's position,
/// `flexure`: θ(t_s) and θ̇ (see [`measure`]).
#[allow(clippy::too_many_arguments)]
fn signature<T: Real>(
    e: &Nominal<'_, T>,
    msg: &MasterNav<T>,
    (rate, fit): (Option<&RateAt<T>>, Option<RateFit<T>>),
    slave: &SlaveAt<T>,
    here: &earth::Local<T>,
    c_bm_n: &Matrix3<T>,
    w_eb_bm: &Vector3<T>,
    flexure: &(Vector3<T>, Vector3<T>),
) -> Signature<T> {
    let slope = fit.filter(|_| e.has_delay).map(|f| f.slope);
    let c_bs_n = dcm(&slave.q_b_n);
    let w_ib_bs = rate.map_or(Vector3::zeros(), |r| r.raw_b - e.gyro_bias);
    let f_bs = rate.map_or(Vector3::zeros(), |r| r.f_raw_b - e.accel_bias);
    let w_ie = here.earth_rate_n();
    let w_en = here.transport_rate_n(&slave.v_n);
    // What a delay moves is the master. The slave's own gyro also senses the
    // flexure's rate of the moment, which the filter has not predicted and which is in
    // the same attitude innovation (errors in variables: a spurious delay of 2 ms on a
    // clean flexing draw, docs/diagnosis.md "Session 10"); so the attitude column is
    // the current master message's rate (its noise is not in the attitude
    // innovation), and the rate column the derivative of a quartic through the
    // master's previous rates (the current one's noise is in its own innovation; past
    // noise biases through the flexure states, hence a window of many rates). For a
    // master that gives no rate (a rate from attitude differences would carry the
    // current attitude noise), the slave's rate. The
    // velocity column likewise: the slave's sensed acceleration carries the bending
    // arm's R θ̈ of the moment (+3.4 ms on the same draw through velocity alone), so it
    // is the rate of change of the master's carried velocity, its lever-arm part from
    // the master's rates and angular acceleration, the master's own acceleration from
    // a line through its past velocities weighted over `MASTER_ACCEL_WINDOW_S` (the
    // master's smooth error's increments, which a short window's slope carries, biased
    // it the other way: docs/diagnosis.md "Session 11").
    let m_bs = transpose3(&exp_so3(&e.misalignment));
    let carried_force = e.carried_force;
    let w_nb_bm = w_eb_bm - mul3v(&transpose3(c_bm_n), &w_en);
    let (w_nb_bs, w_dot_bs) = match (slope, msg.w_ib_bm) {
        (Some(w_dot), _) => (mul3v(&m_bs, &w_nb_bm), mul3v(&m_bs, &w_dot)),
        // The rate and velocity channels are held ([`measure`]): the attitude's column
        // is still the master's rate.
        (None, Some(_)) => (mul3v(&m_bs, &w_nb_bm), Vector3::zeros()),
        (None, None) => (
            w_ib_bs - mul3v(&transpose3(&c_bs_n), &(w_ie + w_en)),
            Vector3::zeros(),
        ),
    };
    // Until the line spans its window the master's own acceleration is left out, and
    // until the rates cover theirs the column is zero, as the rate column: the slave's
    // sensed acceleration there (5 s, 500 messages of a 100 Hz master) gave seed 111 a
    // delay of +2 ms with the ship still (docs/diagnosis.md "Session 11").
    let v_dot_n = match (slope, msg.w_ib_bm) {
        (Some(w_dot), _) => augment::carried_acceleration(
            &e.master_trend.slope().unwrap_or_else(Vector3::zeros),
            c_bm_n,
            &w_nb_bm,
            w_eb_bm,
            &w_dot,
            &e.cfg.lever_arm_m,
        ),
        (None, Some(_)) => Vector3::zeros(),
        // A master without rate: v̇ = C f + g − (2ω_ie + ω_en) × v, from the sensed
        // force (not from differences of the snapshots, which closed-loop corrections
        // make jump).
        (None, None) => {
            c_bs_n * f_bs + here.gravity_n() - (w_ie * T::of(2.0) + w_en).cross(&slave.v_n)
        }
    };
    // The g-sensitivity's rate column, `G f`, and the accelerometer's dynamics columns
    // (`uses_carried_force`): the slave's sensed force holds the bending arm's `R θ̈` of
    // the moment, and the rate innovation the flexure's rate `θ̇` the filter has not
    // predicted, the velocity innovation its velocity `R θ̇` (errors in variables, as the
    // delay's columns: docs/diagnosis.md "Session 12", "Session 19"), so `f` is the
    // force the master carries to the arm, its lever-arm terms from the master's rates,
    // its own acceleration once the line spans its window, rotated to the slave body by
    // the estimated mounting. The angular acceleration is the quartic's slope where the
    // layout forms the fit (the delay's, the lever arm's, the scale factors'), else the
    // difference of the master's two previous rates (the parabola's f64 sums that came
    // before the quartic cost ~290k instructions a message on the board). The rate
    // channel needs a master that gives its rate; without one, the slave's force.
    let f_carried_bs = match msg.w_ib_bm {
        Some(_) if carried_force => {
            // With the quartic's slope the delay's velocity column is this acceleration.
            let a_c = match slope {
                Some(_) => v_dot_n,
                None => augment::carried_acceleration(
                    &e.master_trend.slope().unwrap_or_else(Vector3::zeros),
                    c_bm_n,
                    &w_nb_bm,
                    w_eb_bm,
                    &fit.map(|f| f.slope).unwrap_or_else(|| {
                        e.past_master_rates
                            .difference(e.cfg.filter_period_s)
                            .unwrap_or_else(Vector3::zeros)
                    }),
                    &e.cfg.lever_arm_m,
                ),
            };
            let two = T::of(2.0);
            augment::carried_specific_force(
                &a_c,
                &here.gravity_n(),
                &vec3(|i| vget(&w_ie, i) * two + vget(&w_en, i)).cross(&slave.v_n),
                &mul3(&m_bs, &transpose3(c_bm_n)),
            )
        }
        _ => f_bs,
    };
    // The lever-arm columns' rate: the instrument where the master's past rates give it
    // (`PastRates::fit`), as a rate relative to the Earth by the current message's
    // Earth part.
    let lever_rate = match (msg.w_ib_bm, fit.filter(|_| e.fits_master_rate)) {
        (Some(w_ib), Some(f)) => Some(vec3(|i| {
            vget(w_eb_bm, i) + (vget(&f.value, i) - vget(&w_ib, i))
        })),
        _ => None,
    };
    Signature {
        c_bm_n: *c_bm_n,
        w_eb_bm: lever_rate.unwrap_or(*w_eb_bm),
        lever_v_n: mul3v(c_bm_n, &w_eb_bm.cross(&e.cfg.lever_arm_m)),
        v_dot_n,
        w_nb_bs,
        w_dot_bs,
        w_ib_bs,
        w_carried_bs: match (fit.filter(|_| e.fits_master_rate), msg.w_ib_bm) {
            (Some(f), _) => mul3v(&m_bs, &f.value),
            (None, Some(w)) => mul3v(&m_bs, &w),
            (None, None) => w_ib_bs,
        },
        f_bs,
        f_carried_bs,
        c_bs_n,
        theta: flexure.0,
        theta_rate: flexure.1,
        clock_dt: T::of(e.clock_dt),
    }
}

/// A scalar update's report before the update writes it.
fn unused<T: Real>() -> ScalarUpdate<T> {
    ScalarUpdate {
        innovation: T::zero(),
        variance: T::zero(),
        test_ratio: T::zero(),
        accepted: false,
    }
}
