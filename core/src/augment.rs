//! Candidate effects the declared 21-state model lacks, each a block of states the
//! filter can carry after the declared ones. The diagnosis adds the block of an effect
//! it finds in the residuals; the board runs the same layout from its configuration.
//!
//! Every block but the master's errors is a constant (no process noise). The master's
//! smooth output errors (`master_attitude_error`, `master_velocity_error`) are
//! first-order Gauss-Markov processes with one correlation time for both (the layout's
//! [`Augmentation::master_error_correlation_s`], by default
//! [`MASTER_ERROR_CORRELATION_S`]) and the block's prior σ as their stationary σ: a real
//! master's errors are slow, not white, and a constant misalignment can only be told
//! from them by their time behaviour. All but the clock blocks (`time_delay`,
//! `clock_drift`) stay in the filter's state, not fed back into the nominal solution, so
//! their estimate and σ are read from the filter at any time; a clock block's states are
//! the errors of the engine's nominal τ̂ (and τ̂̇), fed back once known to 1 ms
//! (`Engine::effect_estimate` adds the two). Conventions (the
//! simulator injects the effects the same way):
//!
//! | effect | states | meaning | enters |
//! |---|---|---|---|
//! | `gyro_scale_factor` | `s_g` (3, –) | gyro measures `(I + diag s_g) ω` | ψ̇ += diag(ω) s_g |
//! | `gyro_misalignment` | `n_g = [xy, xz, yz]` (rad) | gyro measures `(I + N_g) ω`, `N_g` symmetric, zero diagonal | ψ̇ += N_g ω |
//! | `accel_scale_factor` | `s_a` (3, –) | accelerometer measures `(I + diag s_a) f` | δv̇ += C diag(f) s_a |
//! | `accel_misalignment` | `n_a` (rad) | as the gyro's, on `f` | δv̇ += C N_a f |
//! | `time_delay` | `τ` (1, s) | the master message stamped `t` is the master at `t − τ` | z_v += d/dt(v_m + C_bm^n (ω_eb × r0)) τ, z_a += ω_nb τ, z_ω += ω̇ τ |
//! | `clock_drift` | `[τ₀, τ̇]` (2: s, s/s) | the master message stamped `t` is the master at `t − τ₀ − τ̇ (t − t₀)`, `t₀` the engine's first message | the delay's columns times `[1, t − t₀]` |
//! | `lever_arm_error` | `δr` (3, m, master body) | the true arm is `r0 + δr` | z_v += C_bm^n [ω_eb×] δr |
//! | `gyro_g_sensitivity` | `G` (9, rad/s per m/s², row-major) | gyro measures `ω + G f` | ψ̇ += G f |
//! | `lever_arm_coupling` | `δR` (9, m/rad, row-major) | the true bending is `R + δR` | z_v += C_bm^n ([ω_eb×] δR θ + δR θ̇) |
//! | `master_attitude_error` | `φ_m` (3, rad, ENU) | the master reports `Exp(φ_m) C_bm^n` | z_a −= Ĉ_bs^nᵀ φ_m; z_v −= φ_m × C_bm^n (ω_eb^bm × r0); φ̇_m = −φ_m/τ + w |
//! | `master_velocity_error` | `δv_m` (3, m/s, ENU) | the master reports `v_m + δv_m` | z_v −= δv_m; δv̇_m = −δv_m/τ + w |
//!
//! `docs/diagnosis.md` derives each column; `core/tests/linearization_f.rs` and
//! `host-sim/tests/linearization_aug.rs` check them against the nonlinear models.

use crate::mat::{mul3, mul3v, vec3, vget};
use crate::model::N;
use crate::real::Real;
use crate::rotation::skew;
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

/// Most effects one layout carries at a time.
pub const MAX_EFFECTS: usize = 4;

/// Default correlation time of the master's smooth output errors (s): inside the range
/// real master errors show (tens to hundreds of seconds). The model learner sets the
/// layout's own from the data.
pub const MASTER_ERROR_CORRELATION_S: f64 = 60.0;

/// A candidate effect: its name is the vocabulary of `diagnosis.json`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Effect {
    /// Gyro scale factor errors, per axis (dimensionless).
    GyroScaleFactor,
    /// Gyro axis non-orthogonality `[xy, xz, yz]` (rad).
    GyroMisalignment,
    /// Accelerometer scale factor errors, per axis (dimensionless).
    AccelScaleFactor,
    /// Accelerometer axis non-orthogonality `[xy, xz, yz]` (rad).
    AccelMisalignment,
    /// Master/slave time delay: the master is late by τ (s).
    TimeDelay,
    /// Error of the declared static lever arm, master body frame (m).
    LeverArmError,
    /// Gyro g-sensitivity matrix (rad/s per m/s², row-major).
    GyroGSensitivity,
    /// Error of the bending matrix R of `r = r0 + R θ` (m/rad, row-major).
    LeverArmCoupling,
    /// The master's smooth attitude error, ENU (rad): Gauss-Markov.
    MasterAttitudeError,
    /// The master's smooth velocity error, ENU (m/s): Gauss-Markov.
    MasterVelocityError,
    /// Master/slave clock drift: the delay at the engine's first message τ₀ (s) and its
    /// rate τ̇ (s/s), the master late by `τ₀ + τ̇ (t − t₀)`. The time delay with a rate:
    /// a layout carries at most one of the two.
    ClockDrift,
}

/// The clock drift's rate state has the prior σ of its delay state over this span (s):
/// with the delay's 0.1 s, 1e-3 s/s (1000 ppm, beyond any crystal's).
pub const CLOCK_DRIFT_PRIOR_SPAN_S: f64 = 100.0;

impl Effect {
    /// Every candidate, in the order the diagnosis tries them.
    pub const ALL: [Effect; 8] = [
        Effect::GyroScaleFactor,
        Effect::GyroMisalignment,
        Effect::AccelScaleFactor,
        Effect::AccelMisalignment,
        Effect::TimeDelay,
        Effect::LeverArmError,
        Effect::GyroGSensitivity,
        Effect::LeverArmCoupling,
    ];

    /// Candidates the diagnosis tries only when asked (`flexcal diagnose --candidates`):
    /// the clock drift, which on a constant 10 ms delay at 120 s was named in the delay's
    /// place (`docs/diagnosis.md`, "Clock drift: results").
    pub const OPT_IN: [Effect; 1] = [Effect::ClockDrift];

    /// Whether the block models the master's clock (`time_delay`, `clock_drift`): the
    /// matching time follows its estimate in closed loop.
    pub const fn is_clock(self) -> bool {
        matches!(self, Effect::TimeDelay | Effect::ClockDrift)
    }

    /// The prior σ of the block's state `k` per unit of the block's prior σ: 1 but for
    /// the clock drift's rate, `1 / CLOCK_DRIFT_PRIOR_SPAN_S` (per second).
    pub fn state_prior_scale(self, k: usize) -> f64 {
        match (self, k) {
            (Effect::ClockDrift, 1) => 1.0 / CLOCK_DRIFT_PRIOR_SPAN_S,
            _ => 1.0,
        }
    }

    /// The master's smooth errors: blocks of the noise model (chosen by the model
    /// learner), not sensor or installation effects the diagnosis looks for.
    pub const MASTER_ERRORS: [Effect; 2] =
        [Effect::MasterAttitudeError, Effect::MasterVelocityError];

    /// Whether the block is a Gauss-Markov process (else a constant).
    pub const fn is_gauss_markov(self) -> bool {
        matches!(
            self,
            Effect::MasterAttitudeError | Effect::MasterVelocityError
        )
    }

    /// Number of states of the block.
    pub const fn states(self) -> usize {
        match self {
            Effect::TimeDelay => 1,
            Effect::ClockDrift => 2,
            Effect::GyroGSensitivity | Effect::LeverArmCoupling => 9,
            _ => 3,
        }
    }

    /// The name in `diagnosis.json` and in configuration files.
    pub const fn name(self) -> &'static str {
        match self {
            Effect::GyroScaleFactor => "gyro_scale_factor",
            Effect::GyroMisalignment => "gyro_misalignment",
            Effect::AccelScaleFactor => "accel_scale_factor",
            Effect::AccelMisalignment => "accel_misalignment",
            Effect::TimeDelay => "time_delay",
            Effect::LeverArmError => "lever_arm_error",
            Effect::GyroGSensitivity => "gyro_g_sensitivity",
            Effect::LeverArmCoupling => "lever_arm_coupling",
            Effect::MasterAttitudeError => "master_attitude_error",
            Effect::MasterVelocityError => "master_velocity_error",
            Effect::ClockDrift => "clock_drift",
        }
    }

    /// SI unit of the block's states (the clock drift's: of its delay; its rate is in s/s).
    pub const fn unit(self) -> &'static str {
        match self {
            Effect::ClockDrift => "s",
            Effect::GyroScaleFactor | Effect::AccelScaleFactor => "1",
            Effect::GyroMisalignment | Effect::AccelMisalignment => "rad",
            Effect::TimeDelay => "s",
            Effect::LeverArmError => "m",
            Effect::GyroGSensitivity => "rad/s/(m/s^2)",
            Effect::LeverArmCoupling => "m/rad",
            Effect::MasterAttitudeError => "rad",
            Effect::MasterVelocityError => "m/s",
        }
    }

    /// The effect of a name, if it is one of the vocabulary.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL
            .iter()
            .chain(&Self::MASTER_ERRORS)
            .chain(&Self::OPT_IN)
            .copied()
            .find(|e| e.name() == name)
    }

    /// Wire code of the effect (link Config message); `from_code` inverts it.
    pub const fn code(self) -> u8 {
        match self {
            Effect::GyroScaleFactor => 1,
            Effect::GyroMisalignment => 2,
            Effect::AccelScaleFactor => 3,
            Effect::AccelMisalignment => 4,
            Effect::TimeDelay => 5,
            Effect::LeverArmError => 6,
            Effect::GyroGSensitivity => 7,
            Effect::LeverArmCoupling => 8,
            Effect::MasterAttitudeError => 9,
            Effect::MasterVelocityError => 10,
            Effect::ClockDrift => 11,
        }
    }

    /// The effect of a wire code.
    pub fn from_code(code: u8) -> Option<Self> {
        Self::ALL
            .iter()
            .chain(&Self::MASTER_ERRORS)
            .chain(&Self::OPT_IN)
            .copied()
            .find(|e| e.code() == code)
    }

    /// The smallest magnitude (SI, any state of the block) the diagnosis reports the
    /// effect at, however significant. Zero except for the delay: its estimate carries a
    /// bias of up to +0.6 ms on simulated complete models (`docs/diagnosis.md`, Open;
    /// the floor is set from that measurement at 300 s, not derived). For the clock
    /// drift it is the floor of the delay's change over the recording (`|τ̇| × span`).
    pub fn resolution_floor(self) -> f64 {
        match self {
            Effect::TimeDelay | Effect::ClockDrift => 5e-4,
            _ => 0.0,
        }
    }

    /// A prior σ wide enough for any plausible sensor or installation (SI): 1000 ppm,
    /// 1 mrad, 0.1 s, 2 m, 100 °/h per g, 100 m/rad. The filter's evidence for an effect
    /// is its estimate against its posterior σ, which a wide prior leaves to the data.
    /// For the master's errors it is their stationary σ, a model quantity (10″, 2 cm/s
    /// here; the learner sets it from the data). The clock drift's is its delay's (its
    /// rate's: `state_prior_scale`).
    pub fn default_prior_sigma(self) -> f64 {
        match self {
            Effect::ClockDrift => 0.1,
            Effect::GyroScaleFactor | Effect::AccelScaleFactor => 1e-3,
            Effect::GyroMisalignment | Effect::AccelMisalignment => 1e-3,
            Effect::TimeDelay => 0.1,
            Effect::LeverArmError => 2.0,
            Effect::GyroGSensitivity => 100.0 * (core::f64::consts::PI / 180.0 / 3600.0) / 9.806_65,
            Effect::LeverArmCoupling => 100.0,
            Effect::MasterAttitudeError => 5e-5,
            Effect::MasterVelocityError => 0.02,
        }
    }
}

/// One effect's block in a layout.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Block<T> {
    /// The effect.
    pub effect: Effect,
    /// Index of its first state.
    pub offset: usize,
    /// Prior σ of each of its states (SI unit of the effect).
    pub prior_sigma: T,
}

/// Why a layout could not be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AugmentError {
    /// The effect is already in the layout (or, for a clock block, the other one:
    /// `time_delay` and `clock_drift` model the same clock).
    Duplicate,
    /// The layout carries `MAX_EFFECTS` effects already.
    Full,
    /// The prior σ is not a positive finite number.
    BadPrior,
}

/// The effects appended to the declared 21 states, in order: the layout of the state
/// vector from index `N` on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Augmentation<T> {
    blocks: [Option<Block<T>>; MAX_EFFECTS],
    /// Correlation time of the master's Gauss-Markov error blocks (s); `None`: the
    /// default [`MASTER_ERROR_CORRELATION_S`].
    master_tau_s: Option<T>,
}

impl<T: Real> Default for Augmentation<T> {
    fn default() -> Self {
        Self::none()
    }
}

impl<T: Real> Augmentation<T> {
    /// The declared model alone.
    pub const fn none() -> Self {
        Self {
            blocks: [None; MAX_EFFECTS],
            master_tau_s: None,
        }
    }

    /// This layout with the master's errors' correlation time `tau_s` (s).
    pub fn with_master_error_correlation(mut self, tau_s: T) -> Result<Self, AugmentError> {
        if !(tau_s > T::zero() && tau_s.is_finite()) {
            return Err(AugmentError::BadPrior);
        }
        self.master_tau_s = Some(tau_s);
        Ok(self)
    }

    /// Correlation time of the master's Gauss-Markov error blocks (s).
    pub fn master_error_correlation_s(&self) -> T {
        self.master_tau_s
            .unwrap_or_else(|| T::of(MASTER_ERROR_CORRELATION_S))
    }

    /// This layout with `effect` appended, its states starting after the last block's.
    pub fn with(mut self, effect: Effect, prior_sigma: T) -> Result<Self, AugmentError> {
        if !(prior_sigma > T::zero() && prior_sigma.is_finite()) {
            return Err(AugmentError::BadPrior);
        }
        if self.offset(effect).is_some()
            || (effect.is_clock() && self.blocks().any(|b| b.effect.is_clock()))
        {
            return Err(AugmentError::Duplicate);
        }
        let offset = N + self.states();
        let slot = self
            .blocks
            .iter_mut()
            .find(|b| b.is_none())
            .ok_or(AugmentError::Full)?;
        *slot = Some(Block {
            effect,
            offset,
            prior_sigma,
        });
        Ok(self)
    }

    /// The blocks, in state order.
    pub fn blocks(&self) -> impl Iterator<Item = &Block<T>> {
        self.blocks.iter().flatten()
    }

    /// Whether no effect is added.
    pub fn is_empty(&self) -> bool {
        self.blocks().next().is_none()
    }

    /// Number of added states.
    pub fn states(&self) -> usize {
        self.blocks().map(|b| b.effect.states()).sum()
    }

    /// Dimension of the state vector the layout needs (declared + added).
    pub fn dimension(&self) -> usize {
        N + self.states()
    }

    /// Index of the effect's first state, if the layout carries it.
    pub fn offset(&self, effect: Effect) -> Option<usize> {
        self.blocks().find(|b| b.effect == effect).map(|b| b.offset)
    }
}

/// Adds `block` (3 rows × `C` columns) into `m` at `(row, col)`; entries outside are skipped.
fn add_block<T: Real, const R: usize, const S: usize, const C: usize>(
    m: &mut SMatrix<T, R, S>,
    row: usize,
    col: usize,
    block: &SMatrix<T, 3, C>,
) {
    for r in 0..3 {
        for c in 0..C {
            if let (Some(e), Some(&v)) = (m.get_mut((row + r, col + c)), block.get((r, c))) {
                *e += v;
            }
        }
    }
}

/// `N ω` for the symmetric zero-diagonal `N` of `[xy, xz, yz]`, as a matrix on those three.
fn nonorthogonality_columns<T: Real>(w: &Vector3<T>) -> Matrix3<T> {
    let z = T::zero();
    Matrix3::new(w.y, w.z, z, w.x, z, w.z, z, w.x, w.y)
}

/// `G f` for a row-major `G`, as a 3×9 matrix on G's entries.
fn row_major_columns<T: Real>(f: &Vector3<T>) -> SMatrix<T, 3, 9> {
    let mut m = SMatrix::<T, 3, 9>::zeros();
    for i in 0..3 {
        for j in 0..3 {
            if let (Some(e), Some(&v)) = (m.get_mut((i, 3 * i + j)), f.get(j)) {
                *e = v;
            }
        }
    }
    m
}

/// Adds the augmented blocks' columns to rows of the continuous-time dynamics `f` (R×S,
/// the rows with dynamics): the rows of δv (at `v_row`) and ψ (at `psi_row`), from the
/// period's mean rate `w_ib_b` (rad/s, slave body) and attitude `c_b_n`; the
/// accelerometer's and the g-sensitivity's from `f_g_b` (m/s², slave body: the specific
/// force without the flexure's motion where the master carries it, see
/// [`crate::model::IntervalMeans::f_g_b`]: the slave's own holds the bending arm's `R θ̈`,
/// errors in variables against the velocity innovation).
pub fn add_dynamics<T: Real, const R: usize, const S: usize>(
    f: &mut SMatrix<T, R, S>,
    aug: &Augmentation<T>,
    rows: (usize, usize),
    f_g_b: &Vector3<T>,
    w_ib_b: &Vector3<T>,
    c_b_n: &Matrix3<T>,
) {
    let (v_row, psi_row) = rows;
    for b in aug.blocks() {
        let o = b.offset;
        match b.effect {
            Effect::GyroScaleFactor => add_block(f, psi_row, o, &Matrix3::from_diagonal(w_ib_b)),
            Effect::GyroMisalignment => add_block(f, psi_row, o, &nonorthogonality_columns(w_ib_b)),
            Effect::AccelScaleFactor => {
                add_block(f, v_row, o, &(c_b_n * Matrix3::from_diagonal(f_g_b)))
            }
            Effect::AccelMisalignment => {
                add_block(f, v_row, o, &(c_b_n * nonorthogonality_columns(f_g_b)))
            }
            Effect::GyroGSensitivity => add_block(f, psi_row, o, &row_major_columns(f_g_b)),
            // Their own decay is applied apart (`gauss_markov_states`).
            Effect::MasterAttitudeError
            | Effect::MasterVelocityError
            | Effect::TimeDelay
            | Effect::ClockDrift
            | Effect::LeverArmError
            | Effect::LeverArmCoupling => {}
        }
    }
}

/// The states of the Gauss-Markov blocks and their decay `e^{−t/τ}` over a period `t`
/// (s): their transition, which no other row of Φ reads (`Kalman::decay` applies it).
pub fn gauss_markov_states<T: Real>(
    aug: &Augmentation<T>,
    t: T,
) -> (impl Iterator<Item = usize> + '_, T) {
    let decay = (-t / aug.master_error_correlation_s()).exp();
    let states = aug
        .blocks()
        .filter(|b| b.effect.is_gauss_markov())
        .flat_map(|b| b.offset..b.offset + b.effect.states());
    (states, decay)
}

/// Adds the discrete process noise of the Gauss-Markov blocks over a period `t` (s) to
/// the diagonal `q_diag` of Q: `σ² (1 − e^{−2t/τ})` per state keeps each at its
/// stationary σ.
pub fn add_process_noise<T: Real>(q_diag: &mut [T], aug: &Augmentation<T>, t: T) {
    for b in aug.blocks().filter(|b| b.effect.is_gauss_markov()) {
        let decay = (-(t + t) / aug.master_error_correlation_s()).exp();
        let v = b.prior_sigma * b.prior_sigma * (T::one() - decay);
        for k in 0..b.effect.states() {
            if let Some(e) = q_diag.get_mut(b.offset + k) {
                *e += v;
            }
        }
    }
}

/// What the measurement columns of the augmented blocks are made of, at one master
/// message's time of validity.
#[derive(Clone, Copy, Debug)]
pub struct Signature<T: Real> {
    /// Master attitude `C_bm^n`.
    pub c_bm_n: Matrix3<T>,
    /// Master body rate relative to the Earth, master body (rad/s).
    pub w_eb_bm: Vector3<T>,
    /// The static lever arm's velocity `C_bm^n (ω_eb^bm × r0)`, ENU (m/s): the master's
    /// attitude carries it to the slave, so the master's attitude error moves it.
    pub lever_v_n: Vector3<T>,
    /// Rate of change of what a delay moves in the velocity matching, the master's
    /// carried velocity `v_m + C_bm^n (ω_eb^bm × r0)`, ENU (m/s²)
    /// ([`carried_acceleration`]; zero before the master's rates cover their window,
    /// the slave's sensed acceleration for a master that gives no rate).
    pub v_dot_n: Vector3<T>,
    /// Slave body rate relative to the navigation frame, slave body (rad/s).
    pub w_nb_bs: Vector3<T>,
    /// Rate of change of the slave's angular rate, slave body (rad/s²).
    pub w_dot_bs: Vector3<T>,
    /// Slave angular rate ω_ib, bias-corrected, slave body (rad/s).
    pub w_ib_bs: Vector3<T>,
    /// The rate the slave would sense without flexure, slave body (rad/s): the master's
    /// `ω_ib` at the message from its past rates (`RateFit::value`) carried by the
    /// estimated mounting, `Exp(μ̂)ᵀ ω_ib^bm` (its current rate until they cover their
    /// window; the slave's `w_ib_bs` for a master that gives no rate). The gyro scale
    /// factor's and non-orthogonality's rate columns. The slave's measured rate holds
    /// the flexure's rate of the moment, which is in the same rate innovation: as that
    /// column (errors in variables), a draw with the flexure about all three axes and
    /// no scale factor read 1.5 % (docs/diagnosis.md, "Session 18 (sf-flexure)"). The
    /// master's current rate holds its own noise, also in that innovation with the
    /// other sign (−1.0σ on `moored`'s x axis, −2.3σ on z, seeds 1–8). What the column
    /// leaves out, `diag(θ̇ + [ω×]θ) s`, is of second order.
    pub w_carried_bs: Vector3<T>,
    /// Slave specific force, bias-corrected, slave body (m/s²).
    pub f_bs: Vector3<T>,
    /// The specific force the slave would sense without flexure, slave body (m/s²): the
    /// master's carried force ([`carried_specific_force`]), the g-sensitivity's rate
    /// column. None of the slave's flexure is in it (docs/diagnosis.md, "Session 12").
    pub f_carried_bs: Vector3<T>,
    /// Slave attitude `Ĉ_bs^n` (the strapdown's).
    pub c_bs_n: Matrix3<T>,
    /// Flexure angle estimate θ̂ (rad) and rate θ̂̇ (rad/s), slave body.
    pub theta: Vector3<T>,
    /// See `theta`.
    pub theta_rate: Vector3<T>,
    /// Time of the master message since the clock's reference `t₀`, the engine's first
    /// master message (s): the clock drift's rate column is its delay column times it.
    pub clock_dt: T,
}

/// The delay's velocity column: the rate of change of the master's carried velocity
/// `v_m + C_bm^n (ω_eb^bm × r0)`, ENU (m/s²),
/// `a_m + C_bm^n (ω̇ × r0 + ω_nb^bm × (ω_eb^bm × r0))`, from the master's own acceleration
/// `a_m` (ENU), its attitude, its rates relative to the navigation frame and the Earth
/// (master body) and its angular acceleration `w_dot_bm` (master body). What a delay
/// moves, and none of the slave's flexure (docs/diagnosis.md, "Session 11").
pub fn carried_acceleration<T: Real>(
    a_m_n: &Vector3<T>,
    c_bm_n: &Matrix3<T>,
    w_nb_bm: &Vector3<T>,
    w_eb_bm: &Vector3<T>,
    w_dot_bm: &Vector3<T>,
    r0: &Vector3<T>,
) -> Vector3<T> {
    a_m_n + c_bm_n * (w_dot_bm.cross(r0) + w_nb_bm.cross(&w_eb_bm.cross(r0)))
}

/// The specific force at the slave without flexure, slave body (m/s²): the master's
/// carried acceleration `a_c` (ENU, [`carried_acceleration`]) less gravity `g_n` (ENU,
/// `[0, 0, −g]`) plus the Coriolis and transport term `(2ω_ie + ω_en) × v` (ENU), rotated
/// to the slave body by `c_n_bs` = `Exp(μ̂)ᵀ C_bm^nᵀ` (the estimated mounting):
/// `v̇ = C f + g − (2ω_ie + ω_en) × v` solved for `f`. What the slave's accelerometer
/// senses but its bending arm's `R θ̈` and the rest of the flexure's motion.
pub fn carried_specific_force<T: Real>(
    a_c_n: &Vector3<T>,
    g_n: &Vector3<T>,
    coriolis_n: &Vector3<T>,
    c_n_bs: &Matrix3<T>,
) -> Vector3<T> {
    // (Element by element and the product written out, as nalgebra forms them: a loop
    // each on the board.)
    mul3v(
        c_n_bs,
        &vec3(|i| (vget(a_c_n, i) - vget(g_n, i)) + vget(coriolis_n, i)),
    )
}

/// Which matching measurement a row belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Channel {
    /// Velocity matching (m/s, ENU).
    Velocity,
    /// Attitude matching (rad, slave body).
    Attitude,
    /// Angular-rate matching (rad/s, slave body).
    AngularRate,
}

/// Adds `block` (3 × `C`) to the three rows from column `col` on.
fn add_columns<T: Real, const C: usize>(
    rows: &mut [&mut [T]; 3],
    col: usize,
    block: &SMatrix<T, 3, C>,
) {
    for (axis, row) in rows.iter_mut().enumerate() {
        for k in 0..C {
            if let (Some(e), Some(&v)) = (row.get_mut(col + k), block.get((axis, k))) {
                *e += v;
            }
        }
    }
}

/// Adds the augmented blocks' columns to the three rows of one matching measurement.
pub fn add_measurement<T: Real, const S: usize>(
    rows: &mut [SVector<T, S>; 3],
    aug: &Augmentation<T>,
    channel: Channel,
    sig: &Signature<T>,
) {
    let [r0, r1, r2] = rows;
    let mut rows = [r0.as_mut_slice(), r1.as_mut_slice(), r2.as_mut_slice()];
    add_measurement_n(&mut rows, aug, channel, sig);
}

/// [`add_measurement`] on the rows as slices: one copy for every state dimension (the
/// board's two layouts; a copy per size cost ≈ 0.7 kB of flash).
#[inline(never)]
fn add_measurement_n<T: Real>(
    rows: &mut [&mut [T]; 3],
    aug: &Augmentation<T>,
    channel: Channel,
    sig: &Signature<T>,
) {
    for b in aug.blocks() {
        let o = b.offset;
        match (b.effect, channel) {
            (Effect::TimeDelay, Channel::Velocity) => add_columns(rows, o, &sig.v_dot_n),
            (Effect::TimeDelay, Channel::Attitude) => add_columns(rows, o, &sig.w_nb_bs),
            (Effect::TimeDelay, Channel::AngularRate) => add_columns(rows, o, &sig.w_dot_bs),
            (Effect::ClockDrift, _) => {
                // δτ(t) = δτ₀ + δτ̇ (t − t₀): the delay's column, and it times t − t₀.
                let col = match channel {
                    Channel::Velocity => sig.v_dot_n,
                    Channel::Attitude => sig.w_nb_bs,
                    Channel::AngularRate => sig.w_dot_bs,
                };
                add_columns(rows, o, &col);
                add_columns(rows, o + 1, &(col * sig.clock_dt));
            }
            (Effect::GyroScaleFactor, Channel::AngularRate) => {
                add_columns(rows, o, &Matrix3::from_diagonal(&sig.w_carried_bs))
            }
            (Effect::GyroMisalignment, Channel::AngularRate) => {
                add_columns(rows, o, &nonorthogonality_columns(&sig.w_carried_bs))
            }
            (Effect::GyroGSensitivity, Channel::AngularRate) => {
                add_columns(rows, o, &row_major_columns(&sig.f_carried_bs))
            }
            (Effect::LeverArmError, Channel::Velocity) => {
                add_columns(rows, o, &mul3(&sig.c_bm_n, &skew(&sig.w_eb_bm)))
            }
            (Effect::LeverArmCoupling, Channel::Velocity) => {
                // C [ω×] δR θ + C δR θ̇, δR's entries as the unknowns (row-major).
                let m = sig.c_bm_n * skew(&sig.w_eb_bm) * row_major_columns(&sig.theta)
                    + sig.c_bm_n * row_major_columns(&sig.theta_rate);
                add_columns(rows, o, &m);
            }
            (Effect::MasterAttitudeError, Channel::Attitude) => {
                add_columns(rows, o, &(-sig.c_bs_n.transpose()))
            }
            (Effect::MasterAttitudeError, Channel::Velocity) => {
                // The reported Exp(φ_m) C_bm^n turns the lever arm's velocity u by φ_m:
                // z_v −= φ_m × u.
                add_columns(rows, o, &skew(&sig.lever_v_n))
            }
            (Effect::MasterVelocityError, Channel::Velocity) => {
                add_columns(rows, o, &(-Matrix3::identity()))
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_offsets_follow_the_declared_states() {
        let a = Augmentation::<f64>::none()
            .with(Effect::TimeDelay, 0.1)
            .unwrap()
            .with(Effect::GyroScaleFactor, 1e-3)
            .unwrap();
        assert_eq!(a.offset(Effect::TimeDelay), Some(N));
        assert_eq!(a.offset(Effect::GyroScaleFactor), Some(N + 1));
        assert_eq!(a.dimension(), N + 4);
        assert_eq!(
            a.with(Effect::TimeDelay, 0.1).unwrap_err(),
            AugmentError::Duplicate
        );
        assert_eq!(
            a.with(Effect::AccelScaleFactor, -1.0).unwrap_err(),
            AugmentError::BadPrior
        );
        // One clock per layout: the drift carries the delay.
        assert_eq!(
            a.with(Effect::ClockDrift, 0.1).unwrap_err(),
            AugmentError::Duplicate
        );
        let c = Augmentation::<f64>::none()
            .with(Effect::ClockDrift, 0.1)
            .unwrap();
        assert_eq!(c.dimension(), N + 2);
        assert_eq!(
            c.with(Effect::TimeDelay, 0.1).unwrap_err(),
            AugmentError::Duplicate
        );
    }

    #[test]
    fn a_layout_holds_at_most_max_effects() {
        let mut a = Augmentation::<f32>::none();
        for e in Effect::ALL.iter().take(MAX_EFFECTS) {
            a = a.with(*e, 1.0).unwrap();
        }
        assert_eq!(
            a.with(Effect::LeverArmCoupling, 1.0).unwrap_err(),
            AugmentError::Full
        );
    }

    #[test]
    fn names_and_codes_round_trip() {
        for e in Effect::ALL {
            assert_eq!(Effect::from_name(e.name()), Some(e));
            assert_eq!(Effect::from_code(e.code()), Some(e));
        }
        for e in Effect::MASTER_ERRORS.into_iter().chain(Effect::OPT_IN) {
            assert_eq!(Effect::from_name(e.name()), Some(e));
            assert_eq!(Effect::from_code(e.code()), Some(e));
        }
        assert_eq!(Effect::from_name("clock_offset"), None);
        assert_eq!(Effect::from_code(0), None);
    }

    /// A master at rest, level, turned by a heading: the carried force is gravity's
    /// reaction, `g` up, in the slave body through the mounting; the g-sensitivity's
    /// rate column is `G f` of it.
    #[test]
    fn carried_specific_force_at_rest_is_gravity_through_the_mounting() {
        use crate::rotation::exp_so3;
        let c_bm_n = exp_so3(&Vector3::new(0.0, 0.0, 0.7));
        let mu = Vector3::new(0.02, -0.01, 0.3);
        let g_n = Vector3::new(0.0, 0.0, -9.8);
        let c_n_bs = exp_so3(&mu).transpose() * c_bm_n.transpose();
        let f = carried_specific_force(&Vector3::zeros(), &g_n, &Vector3::zeros(), &c_n_bs);
        let expected = exp_so3(&mu).transpose() * Vector3::new(0.0, 0.0, 9.8);
        assert!((f - expected).norm() < 1e-12, "{f} vs {expected}");
        let a = Augmentation::<f64>::none()
            .with(Effect::GyroGSensitivity, 1e-5)
            .unwrap();
        let o = a.offset(Effect::GyroGSensitivity).unwrap();
        let z = Vector3::zeros();
        let sig = Signature {
            c_bm_n,
            w_eb_bm: z,
            lever_v_n: z,
            v_dot_n: z,
            w_nb_bs: z,
            w_dot_bs: z,
            w_ib_bs: z,
            w_carried_bs: z,
            f_bs: Vector3::new(1.0, 2.0, 3.0),
            f_carried_bs: f,
            c_bs_n: c_bm_n * exp_so3(&mu),
            theta: z,
            theta_rate: z,
            clock_dt: 0.0,
        };
        let mut rows = [SVector::<f64, { N + 9 }>::zeros(); 3];
        add_measurement(&mut rows, &a, Channel::AngularRate, &sig);
        let g = Matrix3::new(1e-5, 2e-5, 3e-5, -1e-5, 4e-5, 0.0, 5e-6, 0.0, -2e-5);
        let g_entries = SVector::<f64, 9>::from_row_slice(g.transpose().as_slice());
        let modelled =
            Vector3::from_fn(|i, _| (rows[i].fixed_rows::<9>(o).transpose() * g_entries)[0]);
        assert!((modelled - g * f).norm() < 1e-15, "{modelled} vs {}", g * f);
    }

    #[test]
    fn nonorthogonality_columns_apply_the_symmetric_matrix() {
        let w = Vector3::new(0.3, -0.2, 0.7);
        let n = [1e-3, -2e-3, 4e-3];
        let m = Matrix3::new(0.0, n[0], n[1], n[0], 0.0, n[2], n[1], n[2], 0.0);
        let cols = nonorthogonality_columns(&w);
        assert!((cols * Vector3::from(n) - m * w).norm() < 1e-15);
    }
}

#[cfg(test)]
mod master_error_tests {
    use super::*;
    use crate::rotation::{exp_so3, log_so3};

    /// The attitude column of a master attitude error against the matching's nonlinear
    /// definition `z_a = Log(Exp(−μ̂) C_repᵀ Ĉ_bs^n)`, `C_rep = Exp(φ_m) C_bm^n`.
    #[test]
    fn attitude_column_matches_the_nonlinear_matching() {
        let mu = Vector3::new(0.01, -0.02, 0.015);
        let c_bm_n = exp_so3(&Vector3::new(0.2, -0.1, 1.3));
        // The slave as the master sees it, plus a small attitude error.
        let c_bs_n = c_bm_n * exp_so3(&(mu + Vector3::new(2e-4, -1e-4, 3e-4)));
        let z = |phi: &Vector3<f64>| {
            let c_rep = exp_so3(phi) * c_bm_n;
            log_so3(&(exp_so3(&(-mu)) * c_rep.transpose() * c_bs_n))
        };
        let column: Matrix3<f64> = -c_bs_n.transpose();
        let h = 1e-6;
        for k in 0..3 {
            let mut d = Vector3::zeros();
            d[k] = h;
            let numeric = (z(&d) - z(&(-d))) / (2.0 * h);
            let err = (numeric - column.column(k)).norm();
            assert!(err < 1e-3, "axis {k}: {numeric} vs {}", column.column(k));
        }
    }

    #[test]
    fn gauss_markov_blocks_keep_their_stationary_sigma() {
        let a = Augmentation::<f64>::none()
            .with(Effect::MasterVelocityError, 0.03)
            .unwrap()
            .with_master_error_correlation(35.0)
            .unwrap();
        assert_eq!(a.master_error_correlation_s(), 35.0);
        let t = 0.1;
        let mut q = [0.0; 24];
        add_process_noise(&mut q, &a, t);
        let (states, phi) = gauss_markov_states(&a, t);
        assert!(states.eq([N, N + 1, N + 2]));
        assert_eq!(phi, (-t / 35.0f64).exp());
        // Stationary: σ² = φ² σ² + q.
        let stationary = q[N] / (1.0 - phi * phi);
        assert!((stationary.sqrt() / 0.03 - 1.0).abs() < 1e-12);
        assert_eq!(q[N - 1], 0.0);
    }
}
