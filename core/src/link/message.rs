//! The link's messages and their payload layouts (all little-endian, no padding).
//!
//! Every message starts with its time of validity `t` as an `f64` in seconds on the
//! slave's time base: that is the type the engine keys everything on
//! ([`MasterNav::t`](crate::engine::MasterNav), [`ImuIncrement::t`](crate::engine::ImuIncrement)),
//! so no conversion or rounding happens at the link, and an `f64` resolves better than
//! 1 µs for 270 years of uptime.
//!
//! The byte-by-byte layouts are in `docs/link-protocol.md`; the `*_LEN` constants and
//! the unit tests below pin them.
//!
//! Conventions are those of `recording-v1`: `n` is East-North-Up, body frames are
//! right-forward-up, quaternions are Hamilton, scalar first, `q_b^n`.

use crate::augment::{Augmentation, Effect, MAX_EFFECTS};
use crate::earth::Position;
use crate::engine::{
    Counters, EffectEstimate, EngineConfig, Estimates, ImuIncrement, InitialSigma, MasterNav,
    Matching, MeasurementNoise,
};
use crate::flexure::{ArAxis, AxisModel, FlexureModel, SecondOrderAxis};
use crate::kalman::Health;
use crate::link::codec::DecoderCounters;
use crate::link::receiver::LinkCounters;
use crate::link::sequence::SequenceCounters;
use crate::model::{LeverBending, ProcessNoise};
use crate::real::Real;
use crate::watch::{ScoreFigures, Verdict, WatchReport, AXES};
use nalgebra::{Quaternion, Vector3};

/// Payload length of [`MasterNavMsg`].
pub const MASTER_NAV_LEN: usize = 85;
/// Payload length of [`ImuSampleMsg`].
pub const IMU_SAMPLE_LEN: usize = 32;
/// Payload length of [`EstimatesMsg`].
pub const ESTIMATES_LEN: usize = 106;
/// Payload length of [`StatusMsg`]: 128 bytes of counters and, from protocol version
/// 5, 92 bytes of the watcher's report ([`WatchReport`]).
pub const STATUS_LEN: usize = 220;
/// Payload length of [`ConfigMsg`].
pub const CONFIG_LEN: usize = 208;
/// Payload length of [`EndMsg`].
pub const END_LEN: usize = 8;
/// Payload length of [`EffectsMsg`].
pub const EFFECTS_LEN: usize = 109;
/// Augmented states one [`EffectsMsg`] frame carries (the board's 12 added states fit one).
pub const EFFECT_STATES_PER_FRAME: usize = 12;
/// Bytes of one augmentation slot in a Config: effect code `u8`, prior σ `f32`.
const EFFECT_SLOT_LEN: usize = 5;

/// Largest allowed `| |q|² − 1 |` of a received quaternion (|q| within about 1e-6 of 1,
/// as in `recording-v1`).
pub const QUAT_NORM_TOL: f64 = 2e-6;

/// Slack on the ±π/2 latitude bound (rad), so that a pole latitude rounded to `f32`
/// (which rounds up, to 1.5707964) is still accepted.
pub const LAT_TOL: f64 = 1e-6;

/// Bit 0 of the MasterNav flag byte: the angular rate is present.
const FLAG_RATE: u8 = 0x01;

/// Config flag bit 0: velocity matching.
const CFG_VELOCITY: u8 = 0x01;
/// Config flag bit 1: attitude matching.
const CFG_ATTITUDE: u8 = 0x02;
/// Config flag bit 2: angular-rate matching.
const CFG_RATE: u8 = 0x04;
/// Config flag bit 3: the flexure-bent part of the lever arm is modelled.
const CFG_DYNAMIC_LEVER_ARM: u8 = 0x08;
/// Every defined Config flag bit.
const CFG_ALL: u8 = CFG_VELOCITY | CFG_ATTITUDE | CFG_RATE | CFG_DYNAMIC_LEVER_ARM;

/// The message types. Bit 7 of the type byte gives the direction: clear for
/// messages to the slave board, set for messages from it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MessageKind {
    /// `0x01`, master INS → board: the master's navigation solution.
    MasterNav,
    /// `0x02`, host → board: one slave IMU sample, for replay (QEMU, hardware in the loop).
    ImuSample,
    /// `0x03`, host → board: the engine configuration; (re)creates the engine.
    Config,
    /// `0x04`, host → board: end of stream; the board reports and stops.
    End,
    /// `0x81`, board → host: the calibration estimates.
    Estimates,
    /// `0x82`, board → host: link and engine counters.
    Status,
    /// `0x83`, board → host: the estimates of the augmented effects (with Estimates).
    Effects,
}

impl MessageKind {
    /// Number of kinds (and of sequence-number streams).
    pub const COUNT: usize = 7;

    /// Every kind, in stream-index order.
    pub const ALL: [MessageKind; Self::COUNT] = [
        MessageKind::MasterNav,
        MessageKind::ImuSample,
        MessageKind::Estimates,
        MessageKind::Status,
        MessageKind::Config,
        MessageKind::End,
        MessageKind::Effects,
    ];

    /// The type byte on the wire.
    pub const fn type_byte(self) -> u8 {
        match self {
            MessageKind::MasterNav => 0x01,
            MessageKind::ImuSample => 0x02,
            MessageKind::Config => 0x03,
            MessageKind::End => 0x04,
            MessageKind::Estimates => 0x81,
            MessageKind::Status => 0x82,
            MessageKind::Effects => 0x83,
        }
    }

    /// The kind of a type byte (`None`: unknown type).
    pub const fn from_type_byte(byte: u8) -> Option<Self> {
        match byte {
            0x01 => Some(MessageKind::MasterNav),
            0x02 => Some(MessageKind::ImuSample),
            0x03 => Some(MessageKind::Config),
            0x04 => Some(MessageKind::End),
            0x81 => Some(MessageKind::Estimates),
            0x82 => Some(MessageKind::Status),
            0x83 => Some(MessageKind::Effects),
            _ => None,
        }
    }

    /// The fixed payload length of this kind.
    pub const fn payload_len(self) -> usize {
        match self {
            MessageKind::MasterNav => MASTER_NAV_LEN,
            MessageKind::ImuSample => IMU_SAMPLE_LEN,
            MessageKind::Config => CONFIG_LEN,
            MessageKind::End => END_LEN,
            MessageKind::Estimates => ESTIMATES_LEN,
            MessageKind::Status => STATUS_LEN,
            MessageKind::Effects => EFFECTS_LEN,
        }
    }

    /// Every kind: a set of kinds is a byte with bit [`MessageKind::stream_index`] set
    /// for each of its kinds (a receiver's kinds to parse, [`crate::link::Receiver`]).
    pub const EVERY: u8 = (1 << Self::COUNT) - 1;

    /// The kinds a host sends to the board (type byte's bit 7 clear): MasterNav,
    /// ImuSample, Config and End; the board's receiver parses these only.
    pub const TO_BOARD: u8 = MessageKind::MasterNav.bit()
        | MessageKind::ImuSample.bit()
        | MessageKind::Config.bit()
        | MessageKind::End.bit();

    /// This kind's bit in a set of kinds ([`MessageKind::EVERY`]).
    pub const fn bit(self) -> u8 {
        1 << self.stream_index()
    }

    /// Whether this kind is in `set` (a set of [`MessageKind::bit`]s). A match with a
    /// constant per arm: with a constant set the compiler sees which kinds pass (a test of
    /// `bit()` it does not relate to the kind's other matches).
    #[inline(always)]
    pub const fn in_set(self, set: u8) -> bool {
        match self {
            MessageKind::MasterNav => set & MessageKind::MasterNav.bit() != 0,
            MessageKind::ImuSample => set & MessageKind::ImuSample.bit() != 0,
            MessageKind::Config => set & MessageKind::Config.bit() != 0,
            MessageKind::End => set & MessageKind::End.bit() != 0,
            MessageKind::Estimates => set & MessageKind::Estimates.bit() != 0,
            MessageKind::Status => set & MessageKind::Status.bit() != 0,
            MessageKind::Effects => set & MessageKind::Effects.bit() != 0,
        }
    }

    /// Index of this kind's stream, `0..COUNT` (sequence numbers are per stream).
    pub const fn stream_index(self) -> usize {
        match self {
            MessageKind::MasterNav => 0,
            MessageKind::ImuSample => 1,
            MessageKind::Estimates => 2,
            MessageKind::Status => 3,
            MessageKind::Config => 4,
            MessageKind::End => 5,
            MessageKind::Effects => 6,
        }
    }
}

/// The master's navigation message (type `0x01`, 85-byte payload).
///
/// Precision on the wire: the quaternion is `f64` (an `f32` component rounds by up
/// to 3e-8, so about 6e-8 rad of attitude noise, too close to the 1e-7 rad this
/// calibration resolves to be left to the wire; 16 bytes more per message); latitude
/// and longitude are `f64` (an `f32` is 0.6 m at Earth scale); velocity, height and
/// angular rate are `f32` (relative 6e-8: 2e-5 m/s at 300 m/s, 1 mm at 16 km, 6e-8 rad/s at 1 rad/s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MasterNavMsg {
    /// Time of validity (s).
    pub t: f64,
    /// Attitude `q_bm^n` as `[w, x, y, z]` (unit norm within [`QUAT_NORM_TOL`]).
    pub q_bm_n: [f64; 4],
    /// Velocity `v^n` as `[E, N, U]` (m/s).
    pub v_n: [f32; 3],
    /// Geodetic latitude (rad, within ±π/2, up to [`LAT_TOL`]).
    pub lat_rad: f64,
    /// Longitude (rad).
    pub lon_rad: f64,
    /// Height above the ellipsoid (m).
    pub height_m: f32,
    /// Angular rate `ω_ib^bm` as `[x, y, z]` (rad/s), when the master gives it.
    pub w_ib_bm: Option<[f32; 3]>,
}

/// One slave IMU sample for replay (type `0x02`, 32-byte payload): increments over
/// `(t_prev, t]` in the slave body frame. `f32` like the board's engine and the
/// IMU's own output registers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuSampleMsg {
    /// End of the interval (s).
    pub t: f64,
    /// ∫ ω_ib^bs dt as `[x, y, z]` (rad).
    pub dtheta_b: [f32; 3],
    /// ∫ f^bs dt as `[x, y, z]` (m/s).
    pub dv_b: [f32; 3],
}

/// Health flags sent with the estimates (a `u16`; bits not defined here are kept
/// as received and ignored).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct HealthFlags(pub u16);

impl HealthFlags {
    /// The last scalar measurement was rejected by the innovation gate.
    pub const GATING: u16 = 1 << 0;
    /// A non-finite input or result was refused at least once.
    pub const NON_FINITE: u16 = 1 << 1;
    /// A variance was clamped to its floor at least once.
    pub const VARIANCE_CLAMPED: u16 = 1 << 2;
    /// An update was refused for a non-positive innovation variance at least once.
    pub const BAD_INNOVATION_VARIANCE: u16 = 1 << 3;
    /// The filter was re-initialized at least once.
    pub const RESET: u16 = 1 << 4;
    /// Master messages were lost at least once (stale, out of order or dropped).
    pub const MASTER_LOST: u16 = 1 << 5;
    /// No master message has been matched yet (the estimates are the priors).
    pub const NO_MATCH_YET: u16 = 1 << 6;

    /// The flags summarizing the engine's health and counters.
    pub fn from_engine(health: &Health, counters: &Counters) -> Self {
        let mut f = 0u16;
        let mut set = |on: bool, bit: u16| {
            if on {
                f |= bit;
            }
        };
        set(health.gated_streak > 0, Self::GATING);
        set(health.non_finite > 0, Self::NON_FINITE);
        set(health.variance_clamped > 0, Self::VARIANCE_CLAMPED);
        set(
            health.bad_innovation_variance > 0,
            Self::BAD_INNOVATION_VARIANCE,
        );
        set(counters.resets > 0, Self::RESET);
        set(
            counters.master_stale > 0
                || counters.master_out_of_order > 0
                || counters.master_dropped > 0,
            Self::MASTER_LOST,
        );
        set(counters.master_matched == 0, Self::NO_MATCH_YET);
        Self(f)
    }

    /// Whether every bit of `bits` is set.
    pub const fn contains(self, bits: u16) -> bool {
        self.0 & bits == bits
    }
}

/// The calibration estimates (type `0x81`, 106-byte payload); `f32`, the board's
/// precision (and far finer than any σ here).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EstimatesMsg {
    /// Time of the latest filter update (s).
    pub t: f64,
    /// Gyro bias (rad/s, slave body x, y, z).
    pub gyro_bias: [f32; 3],
    /// Its standard deviation (≥ 0).
    pub gyro_bias_sigma: [f32; 3],
    /// Accelerometer bias (m/s², slave body).
    pub accel_bias: [f32; 3],
    /// Its standard deviation (≥ 0).
    pub accel_bias_sigma: [f32; 3],
    /// Misalignment μ (rad, rotation vector).
    pub misalignment: [f32; 3],
    /// Its standard deviation (≥ 0).
    pub misalignment_sigma: [f32; 3],
    /// Flexure angle θ (rad, rotation vector).
    pub flexure: [f32; 3],
    /// Its standard deviation (≥ 0).
    pub flexure_sigma: [f32; 3],
    /// Health flags.
    pub health: HealthFlags,
}

/// Status (type `0x82`, 220-byte payload): the board's link counters, the engine's
/// input counters and the filter's health counters, each a wrapping `u32`, then what
/// the board's watcher (`crate::watch`) says of the innovations.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StatusMsg {
    /// Time the counters were read (s).
    pub t: f64,
    /// The receiving side of the link.
    pub link: LinkCounters,
    /// The engine's input counters.
    pub engine: Counters,
    /// The filter's health counters.
    pub health: Health,
    /// The watcher's figures and verdict.
    pub watch: WatchReport,
}

/// One block of the augmentation as a Config carries it: the effect and the prior σ of
/// each of its states (SI unit of the effect, [`Effect::unit`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EffectPrior {
    /// The effect (on the wire: [`Effect::code`]).
    pub effect: Effect,
    /// Prior σ of each of its states, > 0 and finite.
    pub prior_sigma: f32,
}

/// Why the augmentation part of a Config or an Effects message is refused
/// ([`PayloadError::BadEffects`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EffectsError {
    /// The Config's block count is above [`MAX_EFFECTS`].
    TooMany {
        /// The count received.
        count: u8,
    },
    /// A code that is no [`Effect::code`].
    UnknownCode {
        /// The code received.
        code: u8,
    },
    /// The same effect twice in one layout.
    Duplicate {
        /// Its code.
        code: u8,
    },
    /// A prior σ that is not a positive finite number (zero, negative, NaN, ±∞).
    BadPrior {
        /// The effect's code.
        code: u8,
    },
    /// A block after an empty slot, or an unused slot whose bytes are not all zero.
    UnusedSlot,
}

/// The engine configuration (type `0x03`, 208-byte payload): every field of
/// [`EngineConfig`], the augmentation included, plus how often the board reports. The
/// board (re)creates its engine from it, so it runs exactly the model the desktop chose
/// (a layout recommended by `flexcal diagnose` too), with no code change.
///
/// Floats are `f32` (the board's precision: `T::of` of an `f64` configuration value
/// rounds to the same `f32` on the desktop's `f32` engine), except the periods, which
/// are `f64` like [`EngineConfig::filter_period_s`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConfigMsg {
    /// Time the configuration was sent (s; informational, not checked).
    pub t: f64,
    /// Filter period (s), > 0.
    pub filter_period_s: f64,
    /// Matching channels in use.
    pub matching: Matching,
    /// Whether the flexure-bent part of the lever arm is modelled.
    pub dynamic_lever_arm: bool,
    /// How flexure bends the lever arm.
    pub bending: LeverBending,
    /// Static lever arm r0, master body frame (m).
    pub lever_arm_m: [f32; 3],
    /// Period the flexure model's coefficients belong to (s), > 0.
    pub flexure_period_s: f64,
    /// Per-axis flexure model: `[a1, a2, σ]` of an AR(2) (σ in rad, ≥ 0), or, where
    /// `flexure_second_order` says so, `[ω rad/s, ζ, σ_θ rad]` of a second-order
    /// Gauss-Markov axis (ω > 0, ζ > 0, σ_θ ≥ 0).
    pub flexure: [[f32; 3]; 3],
    /// Which flexure axes are second-order Gauss-Markov (`flexcal_core::flexure`).
    pub flexure_second_order: [bool; 3],
    /// σ of the master's rate noise the lever arm carries into the velocity matching
    /// (rad/s, ≥ 0; [`MeasurementNoise::lever_arm_rate_radps`]).
    pub lever_arm_rate_noise: f32,
    /// Process noise `[accel VRW, gyro ARW, gyro bias RW, accel bias RW, misalignment RW]`
    /// (units of [`ProcessNoise`], each ≥ 0).
    pub process_noise: [f32; 5],
    /// Measurement noise σ per channel and axis (each ≥ 0): `[velocity m/s (ENU),
    /// attitude rad (slave body), rate rad/s (slave body)]`, each `[x, y, z]`.
    pub measurement_noise: [[f32; 3]; 3],
    /// Initial σ `[velocity m/s, misalignment rad, gyro bias rad/s, accel bias m/s²,
    /// flexure rad]` (each ≥ 0).
    pub initial_sigma: [f32; 5],
    /// Initial misalignment estimate μ̂₀ (rad).
    pub initial_misalignment_rad: [f32; 3],
    /// Innovation gate (σ), > 0.
    pub gate_sigma: f32,
    /// Smallest scaled variance, ≥ 0.
    pub variance_floor: f32,
    /// The board sends Estimates after every `estimates_every`-th master update
    /// (0: only at the end of the stream).
    pub estimates_every: u16,
    /// The board sends Status after every `status_every`-th master update
    /// (0: only at the end of the stream).
    pub status_every: u16,
    /// The augmentation ([`EngineConfig::augmentation`]): the blocks appended after the
    /// declared 21 states, in state order, then `None`s. Each effect at most once.
    pub effects: [Option<EffectPrior>; MAX_EFFECTS],
    /// Starting value of the master delay (s, |τ| ≤ `MAX_DELAY_S`) when the layout
    /// carries `time_delay` ([`EngineConfig::initial_delay_s`]).
    pub initial_delay_s: f32,
    /// Correlation time of the master's Gauss-Markov error blocks (s, > 0), used when
    /// the layout carries `master_attitude_error` or `master_velocity_error`.
    pub master_error_correlation_s: f32,
}

impl ConfigMsg {
    /// The wire form of an engine configuration (rounded to `f32`) with the report rates.
    pub fn from_engine<T: Real>(
        c: &EngineConfig<T>,
        estimates_every: u16,
        status_every: u16,
    ) -> Self {
        let f = |x: T| x.to_f64() as f32;
        let p = &c.process_noise;
        let m = &c.measurement_noise;
        let s = &c.initial_sigma;
        Self {
            t: 0.0,
            filter_period_s: c.filter_period_s,
            matching: c.matching,
            dynamic_lever_arm: c.dynamic_lever_arm,
            bending: c.bending,
            lever_arm_m: to_f32s(&c.lever_arm_m),
            flexure_period_s: c.flexure.period_s.to_f64(),
            flexure: c.flexure.axes.map(|a| match a {
                AxisModel::Ar(a) => [f(a.a1), f(a.a2), f(a.sigma_rad)],
                AxisModel::SecondOrder(g) => [f(g.omega_rad_s), f(g.damping), f(g.sigma_rad)],
            }),
            flexure_second_order: c
                .flexure
                .axes
                .map(|a| matches!(a, AxisModel::SecondOrder(_))),
            lever_arm_rate_noise: f(m.lever_arm_rate_radps),
            process_noise: [
                f(p.accel_vrw),
                f(p.gyro_arw),
                f(p.gyro_bias_rw),
                f(p.accel_bias_rw),
                f(p.misalignment_rw),
            ],
            measurement_noise: [
                to_f32s(&m.velocity_mps),
                to_f32s(&m.attitude_rad),
                to_f32s(&m.rate_radps),
            ],
            initial_sigma: [
                f(s.velocity_mps),
                f(s.misalignment_rad),
                f(s.gyro_bias_radps),
                f(s.accel_bias_mps2),
                f(s.flexure_rad),
            ],
            initial_misalignment_rad: to_f32s(&c.initial_misalignment_rad),
            gate_sigma: f(c.gate_sigma),
            variance_floor: f(c.variance_floor),
            estimates_every,
            status_every,
            effects: {
                let mut e = [None; MAX_EFFECTS];
                for (slot, b) in e.iter_mut().zip(c.augmentation.blocks()) {
                    *slot = Some(EffectPrior {
                        effect: b.effect,
                        prior_sigma: f(b.prior_sigma),
                    });
                }
                e
            },
            initial_delay_s: c.initial_delay_s as f32,
            master_error_correlation_s: f(c.augmentation.master_error_correlation_s()),
        }
    }

    /// The augmentation in precision `T`. Exact for every message that passes
    /// [`Message::validate`] (every decoded one); of an invalid one, the blocks the layout
    /// refuses are left out.
    pub fn augmentation<T: Real>(&self) -> Augmentation<T> {
        let tau = T::of(f64::from(self.master_error_correlation_s));
        let none = Augmentation::none();
        let mut aug = none.with_master_error_correlation(tau).unwrap_or(none);
        for e in self.effects.iter().map_while(|e| e.as_ref()) {
            if let Ok(a) = aug.with(e.effect, T::of(f64::from(e.prior_sigma))) {
                aug = a;
            }
        }
        aug
    }

    /// The engine configuration.
    pub fn to_engine<T: Real>(&self) -> EngineConfig<T> {
        let c = |x: f32| T::of(f64::from(x));
        let [av, ga, gb, ab, mr] = self.process_noise;
        let [mv, ma, mrate] = self.measurement_noise;
        let [sv, sm, sg, sa, sf] = self.initial_sigma;
        EngineConfig {
            filter_period_s: self.filter_period_s,
            matching: self.matching,
            lever_arm_m: from_f32s(&self.lever_arm_m),
            bending: self.bending,
            dynamic_lever_arm: self.dynamic_lever_arm,
            flexure: FlexureModel {
                axes: self.flexure_axes(),
                period_s: T::of(self.flexure_period_s),
            },
            process_noise: ProcessNoise {
                accel_vrw: c(av),
                gyro_arw: c(ga),
                gyro_bias_rw: c(gb),
                accel_bias_rw: c(ab),
                misalignment_rw: c(mr),
            },
            measurement_noise: MeasurementNoise {
                velocity_mps: from_f32s(&mv),
                attitude_rad: from_f32s(&ma),
                rate_radps: from_f32s(&mrate),
                lever_arm_rate_radps: c(self.lever_arm_rate_noise),
            },
            initial_sigma: InitialSigma {
                velocity_mps: c(sv),
                misalignment_rad: c(sm),
                gyro_bias_radps: c(sg),
                accel_bias_mps2: c(sa),
                flexure_rad: c(sf),
            },
            initial_misalignment_rad: from_f32s(&self.initial_misalignment_rad),
            gate_sigma: c(self.gate_sigma),
            variance_floor: c(self.variance_floor),
            augmentation: self.augmentation(),
            initial_delay_s: f64::from(self.initial_delay_s),
        }
    }

    /// The flexure axes in precision `T`. Exact for every message that passes
    /// [`Message::validate`]; a second-order axis whose values that check refuses is
    /// carried as an AR(2) with no dynamics and no noise (a flexure of zero).
    fn flexure_axes<T: Real>(&self) -> [AxisModel<T>; 3] {
        let c = |x: f32| T::of(f64::from(x));
        let mut axes = [AxisModel::Ar(ArAxis {
            a1: T::zero(),
            a2: T::zero(),
            sigma_rad: T::zero(),
        }); 3];
        for ((slot, [a, b, sigma]), second_order) in axes
            .iter_mut()
            .zip(self.flexure)
            .zip(self.flexure_second_order)
        {
            if second_order {
                let period = T::of(self.flexure_period_s);
                if let Some(g) = SecondOrderAxis::new(c(a), c(b), c(sigma), period) {
                    *slot = AxisModel::SecondOrder(g);
                }
            } else {
                *slot = AxisModel::Ar(ArAxis {
                    a1: c(a),
                    a2: c(b),
                    sigma_rad: c(sigma),
                });
            }
        }
        axes
    }

    fn flexure_kinds(&self) -> u8 {
        let mut bits = 0;
        for (k, on) in self.flexure_second_order.iter().enumerate() {
            if *on {
                bits |= 1 << k;
            }
        }
        bits
    }

    fn flags(&self) -> u8 {
        let mut f = 0;
        for (on, bit) in [
            (self.matching.velocity, CFG_VELOCITY),
            (self.matching.attitude, CFG_ATTITUDE),
            (self.matching.angular_rate, CFG_RATE),
            (self.dynamic_lever_arm, CFG_DYNAMIC_LEVER_ARM),
        ] {
            if on {
                f |= bit;
            }
        }
        f
    }

    fn floats32(&self) -> impl Iterator<Item = f32> + '_ {
        self.lever_arm_m
            .iter()
            .chain(self.flexure.iter().flatten())
            .chain(self.process_noise.iter())
            .chain(self.measurement_noise.iter().flatten())
            .chain(self.initial_sigma.iter())
            .chain(self.initial_misalignment_rad.iter())
            .copied()
            .chain([
                self.gate_sigma,
                self.variance_floor,
                self.initial_delay_s,
                self.master_error_correlation_s,
                self.lever_arm_rate_noise,
            ])
    }
}

/// The augmented effects' estimates (type `0x83`, 109-byte payload), sent by the board
/// right after each Estimates when its layout carries effects.
///
/// Compact and of fixed length: the layout's added states (in state order, block after
/// block, as in the filter) are cut into pages of [`EFFECT_STATES_PER_FRAME`]; frame `page`
/// carries states `12·page ..` with their σ, zeros past the layout's last state. The
/// board's largest layout (12 added states) is one frame per report; the largest the link
/// allows (4 blocks of 9) is three. Every frame names the whole layout, so it is
/// understood without the Config; the frames of one report share `t`, the time of the
/// Estimates they go with. [`EffectsMsg::states`] maps a frame's slots back to
/// (effect, state of the block).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EffectsMsg {
    /// Time of the latest filter update (s), as in the Estimates sent just before.
    pub t: f64,
    /// The layout: the effects in state order, then `None`s (at least one effect).
    pub layout: [Option<Effect>; MAX_EFFECTS],
    /// Which page of the layout's states this frame carries, `< frames(layout)`.
    pub page: u8,
    /// The states' estimates (SI unit of their effect); 0 past the layout's last state.
    pub value: [f32; EFFECT_STATES_PER_FRAME],
    /// Their standard deviations (≥ 0); 0 past the layout's last state.
    pub sigma: [f32; EFFECT_STATES_PER_FRAME],
}

impl EffectsMsg {
    /// Number of added states of a layout.
    pub fn layout_states(layout: &[Option<Effect>; MAX_EFFECTS]) -> usize {
        layout.iter().flatten().map(|e| e.states()).sum()
    }

    /// Number of Effects frames a report of this layout takes (0 for no effect).
    pub fn frames(layout: &[Option<Effect>; MAX_EFFECTS]) -> usize {
        Self::layout_states(layout).div_ceil(EFFECT_STATES_PER_FRAME)
    }

    /// Frame `page` of the report of `blocks` (the engine's
    /// [`effect_estimate`](crate::engine::Engine::effect_estimate) of each block of the
    /// layout, in state order; at most [`MAX_EFFECTS`] are used), rounded to `f32`.
    /// `None` when `page` is past the report's last frame.
    pub fn from_estimates<T: Real>(
        t: f64,
        blocks: &[EffectEstimate<T>],
        page: usize,
    ) -> Option<Self> {
        let mut layout = [None; MAX_EFFECTS];
        for (slot, b) in layout.iter_mut().zip(blocks) {
            *slot = Some(b.effect);
        }
        if page >= Self::frames(&layout) {
            return None;
        }
        let mut m = Self {
            t,
            layout,
            page: u8::try_from(page).ok()?,
            value: [0.0; EFFECT_STATES_PER_FRAME],
            sigma: [0.0; EFFECT_STATES_PER_FRAME],
        };
        let first = page * EFFECT_STATES_PER_FRAME;
        let states = blocks.iter().take(MAX_EFFECTS).flat_map(|b| {
            b.value
                .iter()
                .zip(b.sigma.iter())
                .take(b.effect.states())
                .map(|(v, s)| (v.to_f64() as f32, s.to_f64() as f32))
        });
        for ((v, s), (dv, ds)) in states
            .skip(first)
            .zip(m.value.iter_mut().zip(m.sigma.iter_mut()))
        {
            *dv = v;
            *ds = s;
        }
        Some(m)
    }

    /// The states this frame carries: `(effect, index of the state within its block,
    /// value, σ)`, in state order.
    pub fn states(&self) -> impl Iterator<Item = (Effect, usize, f32, f32)> + '_ {
        let first = usize::from(self.page) * EFFECT_STATES_PER_FRAME;
        self.layout
            .iter()
            .flatten()
            .flat_map(|e| (0..e.states()).map(move |k| (*e, k)))
            .enumerate()
            .filter_map(move |(g, (e, k))| {
                let j = g.checked_sub(first)?;
                Some((e, k, *self.value.get(j)?, *self.sigma.get(j)?))
            })
    }
}

/// End of stream (type `0x04`, 8-byte payload): the host has sent everything. The board
/// answers with its final Estimates and Status and stops (under QEMU: exits with 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EndMsg {
    /// Time of the last message sent before it (s; informational, not checked).
    pub t: f64,
}

/// One message of any kind.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Message {
    /// See [`MasterNavMsg`].
    MasterNav(MasterNavMsg),
    /// See [`ImuSampleMsg`].
    ImuSample(ImuSampleMsg),
    /// See [`EstimatesMsg`].
    Estimates(EstimatesMsg),
    /// See [`StatusMsg`].
    Status(StatusMsg),
    /// See [`ConfigMsg`].
    Config(ConfigMsg),
    /// See [`EndMsg`].
    End(EndMsg),
    /// See [`EffectsMsg`].
    Effects(EffectsMsg),
}

/// Why a payload is refused (on encoding as on decoding).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum PayloadError {
    /// The payload length is not the kind's fixed length.
    BadLength,
    /// A float is NaN or infinite.
    NonFinite,
    /// A value is out of its domain: non-unit quaternion, latitude beyond ±π/2,
    /// negative σ, unknown MasterNav flag bits, rate bytes set while the rate is absent.
    BadValue,
    /// The augmentation of a Config, or the layout of an Effects message, is refused.
    BadEffects(EffectsError),
}

impl Message {
    /// This message's kind.
    pub const fn kind(&self) -> MessageKind {
        match self {
            Message::MasterNav(_) => MessageKind::MasterNav,
            Message::ImuSample(_) => MessageKind::ImuSample,
            Message::Estimates(_) => MessageKind::Estimates,
            Message::Status(_) => MessageKind::Status,
            Message::Config(_) => MessageKind::Config,
            Message::End(_) => MessageKind::End,
            Message::Effects(_) => MessageKind::Effects,
        }
    }

    /// Time of validity (s).
    pub const fn time(&self) -> f64 {
        match self {
            Message::MasterNav(m) => m.t,
            Message::ImuSample(m) => m.t,
            Message::Estimates(m) => m.t,
            Message::Status(m) => m.t,
            Message::Config(m) => m.t,
            Message::End(m) => m.t,
            Message::Effects(m) => m.t,
        }
    }

    /// Checks the values (the same checks on both ends of the link).
    pub fn validate(&self) -> Result<(), PayloadError> {
        match self {
            Message::MasterNav(m) => {
                let floats_ok = finite64(&[m.t, m.lat_rad, m.lon_rad])
                    && finite64(&m.q_bm_n)
                    && finite32(&m.v_n)
                    && m.height_m.is_finite()
                    && m.w_ib_bm.as_ref().is_none_or(|w| finite32(w));
                if !floats_ok {
                    return Err(PayloadError::NonFinite);
                }
                if !unit_norm(&m.q_bm_n) || m.lat_rad.abs() > core::f64::consts::FRAC_PI_2 + LAT_TOL
                {
                    return Err(PayloadError::BadValue);
                }
                Ok(())
            }
            Message::ImuSample(m) => {
                if m.t.is_finite() && finite32(&m.dtheta_b) && finite32(&m.dv_b) {
                    Ok(())
                } else {
                    Err(PayloadError::NonFinite)
                }
            }
            Message::Estimates(m) => {
                let values = [m.gyro_bias, m.accel_bias, m.misalignment, m.flexure];
                let sigmas = [
                    m.gyro_bias_sigma,
                    m.accel_bias_sigma,
                    m.misalignment_sigma,
                    m.flexure_sigma,
                ];
                let all_finite = m.t.is_finite()
                    && values.iter().all(|v| finite32(v))
                    && sigmas.iter().all(|v| finite32(v));
                if !all_finite {
                    return Err(PayloadError::NonFinite);
                }
                if sigmas.iter().flatten().any(|s| *s < 0.0) {
                    return Err(PayloadError::BadValue);
                }
                Ok(())
            }
            Message::Status(m) => {
                let w = &m.watch;
                let d = &w.delay;
                let figures = [d.lm, d.t2, d.estimate, d.sigma];
                if !(m.t.is_finite()
                    && finite32(&w.nis)
                    && finite32(&w.whiteness)
                    && finite32(&figures))
                {
                    return Err(PayloadError::NonFinite);
                }
                match w.verdict {
                    Verdict::NisOutOfBand { axis } if usize::from(axis) >= AXES => {
                        Err(PayloadError::BadValue)
                    }
                    _ => Ok(()),
                }
            }
            Message::Config(m) => {
                // The augmentation first: a non-finite prior is a bad prior, like zero.
                check_layout(m.effects.map(|e| e.map(|p| p.effect)))?;
                if let Some(p) = m
                    .effects
                    .iter()
                    .flatten()
                    .find(|p| !(p.prior_sigma > 0.0 && p.prior_sigma.is_finite()))
                {
                    return Err(PayloadError::BadEffects(EffectsError::BadPrior {
                        code: p.effect.code(),
                    }));
                }
                let finite = finite64(&[m.t, m.filter_period_s, m.flexure_period_s])
                    && m.floats32().all(f32::is_finite);
                if !finite {
                    return Err(PayloadError::NonFinite);
                }
                let second_order_ok =
                    m.flexure
                        .iter()
                        .zip(m.flexure_second_order)
                        .all(|([w, z, sigma], on)| {
                            !on || SecondOrderAxis::new(
                                f64::from(*w),
                                f64::from(*z),
                                f64::from(*sigma),
                                m.flexure_period_s,
                            )
                            .is_some()
                        });
                let sigmas_ok = second_order_ok
                    && m.flexure.iter().all(|[_, _, s]| *s >= 0.0)
                    && m.process_noise.iter().all(|x| *x >= 0.0)
                    && m.measurement_noise.iter().flatten().all(|x| *x >= 0.0)
                    && m.lever_arm_rate_noise >= 0.0
                    && m.initial_sigma.iter().all(|x| *x >= 0.0);
                if !(sigmas_ok
                    && m.filter_period_s > 0.0
                    && m.flexure_period_s > 0.0
                    && m.gate_sigma > 0.0
                    && m.variance_floor >= 0.0
                    && m.master_error_correlation_s > 0.0
                    && f64::from(m.initial_delay_s).abs() <= crate::engine::MAX_DELAY_S)
                {
                    return Err(PayloadError::BadValue);
                }
                Ok(())
            }
            Message::End(m) => {
                if m.t.is_finite() {
                    Ok(())
                } else {
                    Err(PayloadError::NonFinite)
                }
            }
            Message::Effects(m) => {
                check_layout(m.layout)?;
                if !(m.t.is_finite() && finite32(&m.value) && finite32(&m.sigma)) {
                    return Err(PayloadError::NonFinite);
                }
                let frames = EffectsMsg::frames(&m.layout);
                let used = EffectsMsg::layout_states(&m.layout)
                    .saturating_sub(usize::from(m.page) * EFFECT_STATES_PER_FRAME);
                let unused_zero = m
                    .value
                    .iter()
                    .zip(m.sigma.iter())
                    .skip(used)
                    .all(|(v, s)| *v == 0.0 && *s == 0.0);
                if usize::from(m.page) >= frames || m.sigma.iter().any(|s| *s < 0.0) || !unused_zero
                {
                    return Err(PayloadError::BadValue);
                }
                Ok(())
            }
        }
    }

    /// Writes the payload into the front of `out`; returns its length, or `None` if
    /// `out` is shorter than [`MessageKind::payload_len`]. Does not validate.
    pub fn write_payload(&self, out: &mut [u8]) -> Option<usize> {
        let mut w = Writer { buf: out, len: 0 };
        match self {
            Message::MasterNav(m) => {
                w.f64(m.t)?;
                w.f64s(&m.q_bm_n)?;
                w.f32s(&m.v_n)?;
                w.f64(m.lat_rad)?;
                w.f64(m.lon_rad)?;
                w.f32(m.height_m)?;
                match &m.w_ib_bm {
                    Some(rate) => {
                        w.u8(FLAG_RATE)?;
                        w.f32s(rate)?;
                    }
                    None => {
                        w.u8(0)?;
                        w.bytes([0u8; 12])?;
                    }
                }
            }
            Message::ImuSample(m) => {
                w.f64(m.t)?;
                w.f32s(&m.dtheta_b)?;
                w.f32s(&m.dv_b)?;
            }
            Message::Estimates(m) => {
                w.f64(m.t)?;
                for v in [
                    &m.gyro_bias,
                    &m.gyro_bias_sigma,
                    &m.accel_bias,
                    &m.accel_bias_sigma,
                    &m.misalignment,
                    &m.misalignment_sigma,
                    &m.flexure,
                    &m.flexure_sigma,
                ] {
                    w.f32s(v)?;
                }
                w.bytes(m.health.0.to_le_bytes())?;
            }
            Message::Status(m) => {
                w.f64(m.t)?;
                for c in status_counters(m) {
                    w.bytes(c.to_le_bytes())?;
                }
                let r = &m.watch;
                w.f32s(&r.nis)?;
                w.f32s(&r.whiteness)?;
                let d = &r.delay;
                w.f32s(&[d.lm, d.t2, d.estimate, d.sigma])?;
                w.bytes(r.windows.to_le_bytes())?;
                let (kind, detail) = verdict_bytes(r.verdict);
                w.u8(kind)?;
                w.u8(detail)?;
            }
            Message::Config(m) => {
                w.f64(m.t)?;
                w.f64(m.filter_period_s)?;
                w.u8(m.flags())?;
                w.u8(match m.bending {
                    LeverBending::Paper => 0,
                    LeverBending::UniformArc => 1,
                })?;
                w.f32s(&m.lever_arm_m)?;
                w.f64(m.flexure_period_s)?;
                for axis in &m.flexure {
                    w.f32s(axis)?;
                }
                w.f32s(&m.process_noise)?;
                for channel in &m.measurement_noise {
                    w.f32s(channel)?;
                }
                w.f32s(&m.initial_sigma)?;
                w.f32s(&m.initial_misalignment_rad)?;
                w.f32(m.gate_sigma)?;
                w.f32(m.variance_floor)?;
                w.bytes(m.estimates_every.to_le_bytes())?;
                w.bytes(m.status_every.to_le_bytes())?;
                let count = m.effects.iter().take_while(|e| e.is_some()).count();
                w.u8(u8::try_from(count).ok()?)?;
                for slot in &m.effects {
                    match slot {
                        Some(e) => {
                            w.u8(e.effect.code())?;
                            w.f32(e.prior_sigma)?;
                        }
                        None => w.bytes([0u8; EFFECT_SLOT_LEN])?,
                    }
                }
                w.f32(m.initial_delay_s)?;
                w.f32(m.master_error_correlation_s)?;
                w.u8(m.flexure_kinds())?;
                w.f32(m.lever_arm_rate_noise)?;
            }
            Message::End(m) => {
                w.f64(m.t)?;
            }
            Message::Effects(m) => {
                w.f64(m.t)?;
                for e in &m.layout {
                    w.u8(e.map_or(0, Effect::code))?;
                }
                w.u8(m.page)?;
                w.f32s(&m.value)?;
                w.f32s(&m.sigma)?;
            }
        }
        Some(w.len)
    }

    /// Parses and validates a payload of the given kind.
    pub fn read_payload(kind: MessageKind, payload: &[u8]) -> Result<Self, PayloadError> {
        let mut msg = Message::End(EndMsg { t: 0.0 });
        Self::read_payload_into::<{ MessageKind::EVERY }>(kind, payload, &mut msg)?;
        Ok(msg)
    }

    /// [`Message::read_payload`] into `out` (each kind's fields written in place: a
    /// message returned by value was copied whole, 240 bytes, at every layer of the
    /// board's receiver), compiled for the kinds in `PARSE` only (a set of
    /// [`MessageKind::bit`]s, [`MessageKind::in_set`]); a kind not in it is refused as
    /// [`PayloadError::BadLength`] (the caller tests the kind first). With a constant set
    /// the other kinds' parsing is not compiled in. On an error `out` holds any message.
    #[inline(always)]
    pub fn read_payload_into<const PARSE: u8>(
        kind: MessageKind,
        payload: &[u8],
        out: &mut Self,
    ) -> Result<(), PayloadError> {
        if payload.len() != kind.payload_len() {
            return Err(PayloadError::BadLength);
        }
        Self::parse::<PARSE>(kind, payload, out).ok_or(PayloadError::BadLength)??;
        out.validate()
    }

    /// Each arm's guard is a constant: the arms of the kinds not in `PARSE` are not
    /// compiled in.
    #[inline(always)]
    fn parse<const PARSE: u8>(
        kind: MessageKind,
        payload: &[u8],
        out: &mut Self,
    ) -> Option<Result<(), PayloadError>> {
        let takes = |k: MessageKind| k.in_set(PARSE);
        let mut r = Reader { rest: payload };
        match kind {
            MessageKind::MasterNav if takes(MessageKind::MasterNav) => {
                *out = {
                    let t = r.f64()?;
                    let q_bm_n = r.f64s()?;
                    let v_n = r.f32s()?;
                    let lat_rad = r.f64()?;
                    let lon_rad = r.f64()?;
                    let height_m = r.f32()?;
                    let flags = r.u8()?;
                    let rate_bytes: [u8; 12] = r.bytes()?;
                    let w_ib_bm = match flags {
                        FLAG_RATE => {
                            let mut rr = Reader { rest: &rate_bytes };
                            Some(rr.f32s()?)
                        }
                        0 if rate_bytes == [0u8; 12] => None,
                        _ => return Some(Err(PayloadError::BadValue)),
                    };
                    Message::MasterNav(MasterNavMsg {
                        t,
                        q_bm_n,
                        v_n,
                        lat_rad,
                        lon_rad,
                        height_m,
                        w_ib_bm,
                    })
                }
            }
            MessageKind::ImuSample if takes(MessageKind::ImuSample) => {
                *out = {
                    Message::ImuSample(ImuSampleMsg {
                        t: r.f64()?,
                        dtheta_b: r.f32s()?,
                        dv_b: r.f32s()?,
                    })
                }
            }
            MessageKind::Estimates if takes(MessageKind::Estimates) => {
                *out = {
                    Message::Estimates(EstimatesMsg {
                        t: r.f64()?,
                        gyro_bias: r.f32s()?,
                        gyro_bias_sigma: r.f32s()?,
                        accel_bias: r.f32s()?,
                        accel_bias_sigma: r.f32s()?,
                        misalignment: r.f32s()?,
                        misalignment_sigma: r.f32s()?,
                        flexure: r.f32s()?,
                        flexure_sigma: r.f32s()?,
                        health: HealthFlags(u16::from_le_bytes(r.bytes()?)),
                    })
                }
            }
            MessageKind::Status if takes(MessageKind::Status) => {
                *out = {
                    let t = r.f64()?;
                    let mut c = [0u32; STATUS_COUNTERS];
                    for slot in c.iter_mut() {
                        *slot = r.u32()?;
                    }
                    let mut m = status_from_counters(t, &c);
                    let nis = r.f32s()?;
                    let whiteness = r.f32s()?;
                    let [lm, t2, estimate, sigma] = r.f32s()?;
                    let windows = u16::from_le_bytes(r.bytes()?);
                    let (kind, detail) = (r.u8()?, r.u8()?);
                    let Some(verdict) = verdict_of(kind, detail) else {
                        return Some(Err(PayloadError::BadValue));
                    };
                    m.watch = WatchReport {
                        nis,
                        whiteness,
                        delay: ScoreFigures {
                            lm,
                            t2,
                            estimate,
                            sigma,
                        },
                        windows,
                        verdict,
                    };
                    Message::Status(m)
                }
            }
            MessageKind::Config if takes(MessageKind::Config) => {
                *out = {
                    let t = r.f64()?;
                    let filter_period_s = r.f64()?;
                    let flags = r.u8()?;
                    let bending = match r.u8()? {
                        0 => LeverBending::Paper,
                        1 => LeverBending::UniformArc,
                        _ => return Some(Err(PayloadError::BadValue)),
                    };
                    if flags & !CFG_ALL != 0 {
                        return Some(Err(PayloadError::BadValue));
                    }
                    let lever_arm_m = r.f32s()?;
                    let flexure_period_s = r.f64()?;
                    let flexure = [r.f32s()?, r.f32s()?, r.f32s()?];
                    let process_noise = r.f32s()?;
                    let measurement_noise = [r.f32s()?, r.f32s()?, r.f32s()?];
                    let initial_sigma = r.f32s()?;
                    let initial_misalignment_rad = r.f32s()?;
                    let gate_sigma = r.f32()?;
                    let variance_floor = r.f32()?;
                    let estimates_every = u16::from_le_bytes(r.bytes()?);
                    let status_every = u16::from_le_bytes(r.bytes()?);
                    let count = r.u8()?;
                    if usize::from(count) > MAX_EFFECTS {
                        return Some(Err(PayloadError::BadEffects(EffectsError::TooMany {
                            count,
                        })));
                    }
                    let mut effects = [None; MAX_EFFECTS];
                    for (i, slot) in effects.iter_mut().enumerate() {
                        let code = r.u8()?;
                        let prior_sigma = r.f32()?;
                        if i < usize::from(count) {
                            match Effect::from_code(code) {
                                Some(effect) => {
                                    *slot = Some(EffectPrior {
                                        effect,
                                        prior_sigma,
                                    })
                                }
                                None => {
                                    return Some(Err(PayloadError::BadEffects(
                                        EffectsError::UnknownCode { code },
                                    )))
                                }
                            }
                        } else if code != 0 || prior_sigma.to_bits() != 0 {
                            return Some(Err(PayloadError::BadEffects(EffectsError::UnusedSlot)));
                        }
                    }
                    let initial_delay_s = r.f32()?;
                    let master_error_correlation_s = r.f32()?;
                    let kinds = r.u8()?;
                    if kinds & !0b111 != 0 {
                        return Some(Err(PayloadError::BadValue));
                    }
                    let flexure_second_order = [0, 1, 2].map(|k| kinds & (1 << k) != 0);
                    let lever_arm_rate_noise = r.f32()?;
                    Message::Config(ConfigMsg {
                        t,
                        filter_period_s,
                        matching: Matching {
                            velocity: flags & CFG_VELOCITY != 0,
                            attitude: flags & CFG_ATTITUDE != 0,
                            angular_rate: flags & CFG_RATE != 0,
                        },
                        dynamic_lever_arm: flags & CFG_DYNAMIC_LEVER_ARM != 0,
                        bending,
                        lever_arm_m,
                        flexure_period_s,
                        flexure,
                        flexure_second_order,
                        lever_arm_rate_noise,
                        process_noise,
                        measurement_noise,
                        initial_sigma,
                        initial_misalignment_rad,
                        gate_sigma,
                        variance_floor,
                        estimates_every,
                        status_every,
                        effects,
                        initial_delay_s,
                        master_error_correlation_s,
                    })
                }
            }
            MessageKind::End if takes(MessageKind::End) => {
                *out = Message::End(EndMsg { t: r.f64()? })
            }
            MessageKind::Effects if takes(MessageKind::Effects) => {
                *out = {
                    let t = r.f64()?;
                    let mut layout = [None; MAX_EFFECTS];
                    for slot in layout.iter_mut() {
                        let code = r.u8()?;
                        if code != 0 {
                            match Effect::from_code(code) {
                                Some(e) => *slot = Some(e),
                                None => {
                                    return Some(Err(PayloadError::BadEffects(
                                        EffectsError::UnknownCode { code },
                                    )))
                                }
                            }
                        }
                    }
                    Message::Effects(EffectsMsg {
                        t,
                        layout,
                        page: r.u8()?,
                        value: r.f32s()?,
                        sigma: r.f32s()?,
                    })
                }
            }
            _ => return None,
        }
        if r.rest.is_empty() {
            Some(Ok(()))
        } else {
            None
        }
    }
}

impl MasterNavMsg {
    /// The wire form of an engine message (velocity, height and rate rounded to `f32`).
    pub fn from_engine<T: Real>(m: &MasterNav<T>) -> Self {
        let q = m.q_bm_n.quaternion();
        Self {
            t: m.t,
            q_bm_n: [q.w.to_f64(), q.i.to_f64(), q.j.to_f64(), q.k.to_f64()],
            v_n: to_f32s(&m.v_n),
            lat_rad: m.pos.lat_rad.to_f64(),
            lon_rad: m.pos.lon_rad.to_f64(),
            height_m: m.pos.height_m.to_f64() as f32,
            w_ib_bm: m.w_ib_bm.as_ref().map(to_f32s),
        }
    }

    /// The engine message (the quaternion is renormalized in `T`).
    pub fn to_engine<T: Real>(&self) -> MasterNav<T> {
        let [w, x, y, z] = self.q_bm_n;
        MasterNav {
            t: self.t,
            q_bm_n: crate::rotation::normalize(&Quaternion::new(
                T::of(w),
                T::of(x),
                T::of(y),
                T::of(z),
            )),
            v_n: from_f32s(&self.v_n),
            pos: Position {
                lat_rad: T::of(self.lat_rad),
                lon_rad: T::of(self.lon_rad),
                height_m: T::of(f64::from(self.height_m)),
            },
            w_ib_bm: self.w_ib_bm.as_ref().map(from_f32s),
        }
    }
}

impl ImuSampleMsg {
    /// The wire form of an engine sample (rounded to `f32`).
    pub fn from_engine<T: Real>(s: &ImuIncrement<T>) -> Self {
        Self {
            t: s.t,
            dtheta_b: to_f32s(&s.dtheta_b),
            dv_b: to_f32s(&s.dv_b),
        }
    }

    /// The engine sample.
    pub fn to_engine<T: Real>(&self) -> ImuIncrement<T> {
        ImuIncrement {
            t: self.t,
            dtheta_b: from_f32s(&self.dtheta_b),
            dv_b: from_f32s(&self.dv_b),
        }
    }
}

impl EstimatesMsg {
    /// The wire form of the engine's estimates (rounded to `f32`).
    pub fn from_engine<T: Real>(e: &Estimates<T>, health: HealthFlags) -> Self {
        Self {
            t: e.t,
            gyro_bias: to_f32s(&e.gyro_bias),
            gyro_bias_sigma: to_f32s(&e.gyro_bias_sigma),
            accel_bias: to_f32s(&e.accel_bias),
            accel_bias_sigma: to_f32s(&e.accel_bias_sigma),
            misalignment: to_f32s(&e.misalignment),
            misalignment_sigma: to_f32s(&e.misalignment_sigma),
            flexure: to_f32s(&e.flexure),
            flexure_sigma: to_f32s(&e.flexure_sigma),
            health,
        }
    }

    /// The engine's estimates type.
    pub fn to_engine<T: Real>(&self) -> Estimates<T> {
        Estimates {
            t: self.t,
            gyro_bias: from_f32s(&self.gyro_bias),
            gyro_bias_sigma: from_f32s(&self.gyro_bias_sigma),
            accel_bias: from_f32s(&self.accel_bias),
            accel_bias_sigma: from_f32s(&self.accel_bias_sigma),
            misalignment: from_f32s(&self.misalignment),
            misalignment_sigma: from_f32s(&self.misalignment_sigma),
            flexure: from_f32s(&self.flexure),
            flexure_sigma: from_f32s(&self.flexure_sigma),
        }
    }
}

/// Number of `u32` counters in a Status payload.
const STATUS_COUNTERS: usize = 30;

/// The Status counters in wire order.
fn status_counters(m: &StatusMsg) -> [u32; STATUS_COUNTERS] {
    let d = &m.link.decoder;
    let s = &m.link.sequence;
    let e = &m.engine;
    let h = &m.health;
    [
        d.frames,
        d.oversize,
        d.cobs,
        d.too_short,
        d.crc,
        d.unknown_type,
        d.bad_length,
        d.non_finite,
        d.bad_value,
        s.accepted,
        s.gaps,
        s.missed,
        s.duplicates,
        s.out_of_order,
        s.stale,
        s.resyncs,
        e.imu_samples,
        e.master_matched,
        e.master_stale,
        e.master_out_of_order,
        e.master_dropped,
        e.predictions,
        e.resets,
        h.updates,
        h.gated,
        h.max_gated_streak,
        h.gated_streak,
        h.non_finite,
        h.variance_clamped,
        h.bad_innovation_variance,
    ]
}

/// A watcher's verdict on the wire: kind (0 warming, 1 consistent, 2 model incomplete,
/// 3 NIS out of band) and detail (the effect's code for 2, the channel axis for 3, else 0).
fn verdict_bytes(v: Verdict) -> (u8, u8) {
    match v {
        Verdict::Warming => (0, 0),
        Verdict::Consistent => (1, 0),
        Verdict::ModelIncomplete { most_likely } => (2, most_likely.code()),
        Verdict::NisOutOfBand { axis } => (3, axis),
    }
}

/// The inverse of [`verdict_bytes`]; `None` for bytes it never writes (an unknown kind
/// or effect, an axis past the last, a detail where none belongs).
fn verdict_of(kind: u8, detail: u8) -> Option<Verdict> {
    match (kind, detail) {
        (0, 0) => Some(Verdict::Warming),
        (1, 0) => Some(Verdict::Consistent),
        (2, code) => {
            Effect::from_code(code).map(|most_likely| Verdict::ModelIncomplete { most_likely })
        }
        (3, axis) if usize::from(axis) < AXES => Some(Verdict::NisOutOfBand { axis }),
        _ => None,
    }
}

/// The inverse of [`status_counters`].
fn status_from_counters(t: f64, c: &[u32; STATUS_COUNTERS]) -> StatusMsg {
    let [frames, oversize, cobs, too_short, crc, unknown_type, bad_length, non_finite, bad_value, accepted, gaps, missed, duplicates, out_of_order, stale, resyncs, imu_samples, master_matched, master_stale, master_out_of_order, master_dropped, predictions, resets, updates, gated, max_gated_streak, gated_streak, h_non_finite, variance_clamped, bad_innovation_variance] =
        *c;
    StatusMsg {
        t,
        link: LinkCounters {
            decoder: DecoderCounters {
                frames,
                oversize,
                cobs,
                too_short,
                crc,
                unknown_type,
                bad_length,
                non_finite,
                bad_value,
            },
            sequence: SequenceCounters {
                accepted,
                gaps,
                missed,
                duplicates,
                out_of_order,
                stale,
                resyncs,
            },
        },
        engine: Counters {
            imu_samples,
            master_matched,
            master_stale,
            master_out_of_order,
            master_dropped,
            predictions,
            resets,
        },
        health: Health {
            updates,
            gated,
            max_gated_streak,
            gated_streak,
            non_finite: h_non_finite,
            variance_clamped,
            bad_innovation_variance,
        },
        watch: WatchReport::default(),
    }
}

/// A layout is effects in state order, then empty slots, each effect at most once.
fn check_layout(layout: [Option<Effect>; MAX_EFFECTS]) -> Result<(), PayloadError> {
    let mut ended = false;
    for (i, slot) in layout.iter().enumerate() {
        match slot {
            None => ended = true,
            Some(_) if ended => return Err(PayloadError::BadEffects(EffectsError::UnusedSlot)),
            Some(e) => {
                // The two clock blocks (`time_delay`, `clock_drift`) model one clock: a
                // layout carries one (`Augmentation::with` refuses the second).
                if layout
                    .iter()
                    .take(i)
                    .flatten()
                    .any(|p| p == e || (p.is_clock() && e.is_clock()))
                {
                    return Err(PayloadError::BadEffects(EffectsError::Duplicate {
                        code: e.code(),
                    }));
                }
            }
        }
    }
    Ok(())
}

/// Whether `|q|² = Σ q_i²` (summed in `f64`) is within [`QUAT_NORM_TOL`] of 1, the
/// answer decided in `f32` first where it can be: the board has no `f64` hardware, and
/// the sum's eight software operations cost it about 1.5k instructions a master message.
/// In `f32` (each component rounded, squared and summed: at most six roundings of
/// 2⁻²⁴ relative, the terms being positive, and `s − 1` exact near 1) `|s − 1|` is
/// within 4·10⁻⁷ of the exact `|q|² − 1`, and the `f64` sum within 10⁻¹⁵ of it: an `f32`
/// distance up to 10⁻⁶ puts the `f64` one below 1.4·10⁻⁶ < [`QUAT_NORM_TOL`], which
/// accepts it too. Anything else is decided by the `f64` sum as before.
fn unit_norm(q: &[f64; 4]) -> bool {
    const SURELY_UNIT: f32 = 1e-6;
    let s: f32 = q.iter().map(|&c| (c as f32) * (c as f32)).sum();
    if (s - 1.0).abs() <= SURELY_UNIT {
        return true;
    }
    let n2: f64 = q.iter().map(|c| c * c).sum();
    let off = (n2 - 1.0).abs() > QUAT_NORM_TOL;
    !off
}

fn finite64(x: &[f64]) -> bool {
    x.iter().all(|v| v.is_finite())
}

fn finite32(x: &[f32]) -> bool {
    x.iter().all(|v| v.is_finite())
}

fn to_f32s<T: Real>(v: &Vector3<T>) -> [f32; 3] {
    [
        v.x.to_f64() as f32,
        v.y.to_f64() as f32,
        v.z.to_f64() as f32,
    ]
}

fn from_f32s<T: Real>(a: &[f32; 3]) -> Vector3<T> {
    let [x, y, z] = *a;
    Vector3::new(
        T::of(f64::from(x)),
        T::of(f64::from(y)),
        T::of(f64::from(z)),
    )
}

/// Appends little-endian fields to a byte buffer.
struct Writer<'a> {
    buf: &'a mut [u8],
    len: usize,
}

impl Writer<'_> {
    fn bytes<const N: usize>(&mut self, b: [u8; N]) -> Option<()> {
        let dst = self.buf.get_mut(self.len..self.len.checked_add(N)?)?;
        dst.copy_from_slice(&b);
        self.len += N;
        Some(())
    }
    fn u8(&mut self, x: u8) -> Option<()> {
        self.bytes([x])
    }
    fn f32(&mut self, x: f32) -> Option<()> {
        self.bytes(x.to_le_bytes())
    }
    fn f64(&mut self, x: f64) -> Option<()> {
        self.bytes(x.to_le_bytes())
    }
    fn f32s(&mut self, x: &[f32]) -> Option<()> {
        x.iter().try_for_each(|v| self.f32(*v))
    }
    fn f64s(&mut self, x: &[f64]) -> Option<()> {
        x.iter().try_for_each(|v| self.f64(*v))
    }
}

/// Reads little-endian fields from the front of a byte slice.
struct Reader<'a> {
    rest: &'a [u8],
}

impl Reader<'_> {
    fn bytes<const N: usize>(&mut self) -> Option<[u8; N]> {
        let (head, tail) = self.rest.split_first_chunk::<N>()?;
        self.rest = tail;
        Some(*head)
    }
    fn u8(&mut self) -> Option<u8> {
        self.bytes::<1>().map(|[b]| b)
    }
    fn u32(&mut self) -> Option<u32> {
        self.bytes().map(u32::from_le_bytes)
    }
    fn f32(&mut self) -> Option<f32> {
        self.bytes().map(f32::from_le_bytes)
    }
    fn f64(&mut self) -> Option<f64> {
        self.bytes().map(f64::from_le_bytes)
    }
    fn f32s<const N: usize>(&mut self) -> Option<[f32; N]> {
        let mut out = [0f32; N];
        for slot in out.iter_mut() {
            *slot = self.f32()?;
        }
        Some(out)
    }
    fn f64s<const N: usize>(&mut self) -> Option<[f64; N]> {
        let mut out = [0f64; N];
        for slot in out.iter_mut() {
            *slot = self.f64()?;
        }
        Some(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_norm_decides_as_the_f64_sum() {
        // Quaternions of norm² 1 ± up to 3·QUAT_NORM_TOL in many directions, the band
        // where the f32 pre-check and the f64 rule could part.
        let mut seed = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let (mut accepted, mut refused) = (0, 0);
        for k in 0..200_000 {
            let q = [next(), next(), next(), next()];
            let n = q.iter().map(|c| c * c).sum::<f64>().sqrt();
            let target = 1.0 + 3.0 * QUAT_NORM_TOL * next() + if k % 7 == 0 { 0.1 } else { 0.0 };
            let q = q.map(|c| c / n * target.sqrt());
            let n2: f64 = q.iter().map(|c| c * c).sum();
            let rule = (n2 - 1.0).abs() <= QUAT_NORM_TOL;
            assert_eq!(unit_norm(&q), rule, "{q:?}: |q|² − 1 = {:e}", n2 - 1.0);
            if rule {
                accepted += 1;
            } else {
                refused += 1;
            }
        }
        assert!(accepted > 10_000 && refused > 10_000);
        assert!(unit_norm(&[1.0, 0.0, 0.0, 0.0]));
        assert!(!unit_norm(&[1e300, 0.0, 0.0, 0.0]));
    }

    pub(crate) fn master(rate: bool) -> MasterNavMsg {
        let h = core::f64::consts::FRAC_1_SQRT_2;
        MasterNavMsg {
            t: 12.5,
            q_bm_n: [h, 0.0, 0.0, h],
            v_n: [1.5, -2.25, 0.125],
            lat_rad: 0.6544984694978736,
            lon_rad: 2.118_977_208_085_815,
            height_m: 12.0,
            w_ib_bm: rate.then_some([0.01, -0.02, 0.03]),
        }
    }

    fn payload(m: &Message) -> ([u8; 256], usize) {
        let mut buf = [0xAAu8; 256];
        let n = m.write_payload(&mut buf).unwrap();
        assert_eq!(n, m.kind().payload_len());
        (buf, n)
    }

    fn f64_at(b: &[u8], off: usize) -> f64 {
        f64::from_le_bytes(b[off..off + 8].try_into().unwrap())
    }
    fn f32_at(b: &[u8], off: usize) -> f32 {
        f32::from_le_bytes(b[off..off + 4].try_into().unwrap())
    }
    fn u32_at(b: &[u8], off: usize) -> u32 {
        u32::from_le_bytes(b[off..off + 4].try_into().unwrap())
    }

    #[test]
    fn kinds_are_consistent() {
        for (i, k) in MessageKind::ALL.into_iter().enumerate() {
            assert_eq!(k.stream_index(), i);
            assert_eq!(MessageKind::from_type_byte(k.type_byte()), Some(k));
            assert_ne!(MessageKind::EVERY & k.bit(), 0);
            // The board parses exactly the kinds whose type byte has bit 7 clear.
            assert_eq!(
                MessageKind::TO_BOARD & k.bit() != 0,
                k.type_byte() & 0x80 == 0
            );
        }
        assert_eq!(MessageKind::EVERY.count_ones() as usize, MessageKind::COUNT);
        let known = (0..=255u8)
            .filter(|b| MessageKind::from_type_byte(*b).is_some())
            .count();
        assert_eq!(known, MessageKind::COUNT);
    }

    #[test]
    fn master_nav_layout() {
        let m = master(true);
        let (b, n) = payload(&Message::MasterNav(m));
        assert_eq!(n, 85);
        assert_eq!(f64_at(&b, 0), 12.5);
        for (i, q) in m.q_bm_n.iter().enumerate() {
            assert_eq!(f64_at(&b, 8 + 8 * i), *q);
        }
        assert_eq!(
            [f32_at(&b, 40), f32_at(&b, 44), f32_at(&b, 48)],
            [1.5, -2.25, 0.125]
        );
        assert_eq!(f64_at(&b, 52), m.lat_rad);
        assert_eq!(f64_at(&b, 60), m.lon_rad);
        assert_eq!(f32_at(&b, 68), 12.0);
        assert_eq!(b[72], 1);
        assert_eq!(
            [f32_at(&b, 73), f32_at(&b, 77), f32_at(&b, 81)],
            [0.01, -0.02, 0.03]
        );
        assert_eq!(b[85], 0xAA, "nothing written past the payload");
        let back = Message::read_payload(MessageKind::MasterNav, &b[..n]).unwrap();
        assert_eq!(back, Message::MasterNav(m));

        let m = master(false);
        let (b, n) = payload(&Message::MasterNav(m));
        assert_eq!(b[72], 0);
        assert!(b[73..85].iter().all(|x| *x == 0));
        let back = Message::read_payload(MessageKind::MasterNav, &b[..n]).unwrap();
        assert_eq!(back, Message::MasterNav(m));
    }

    #[test]
    fn master_nav_bad_values() {
        let (b, n) = payload(&Message::MasterNav(master(false)));
        let read = |b: &[u8]| Message::read_payload(MessageKind::MasterNav, b);
        let mut x = b;
        x[72] = 2;
        assert_eq!(read(&x[..n]), Err(PayloadError::BadValue));
        let mut x = b;
        x[80] = 1; // rate bytes set while the flag says absent
        assert_eq!(read(&x[..n]), Err(PayloadError::BadValue));
        let mut x = b;
        x[8..16].copy_from_slice(&0.9f64.to_le_bytes()); // non-unit quaternion
        assert_eq!(read(&x[..n]), Err(PayloadError::BadValue));
        let mut x = b;
        x[52..60].copy_from_slice(&2.0f64.to_le_bytes()); // latitude beyond 90°
        assert_eq!(read(&x[..n]), Err(PayloadError::BadValue));
        let mut x = b;
        x[40..44].copy_from_slice(&f32::NAN.to_le_bytes());
        assert_eq!(read(&x[..n]), Err(PayloadError::NonFinite));
        let mut x = b;
        x[0..8].copy_from_slice(&f64::INFINITY.to_le_bytes());
        assert_eq!(read(&x[..n]), Err(PayloadError::NonFinite));
        assert_eq!(read(&b[..n - 1]), Err(PayloadError::BadLength));
        assert_eq!(read(&b[..n + 1]), Err(PayloadError::BadLength));
        assert_eq!(read(&[]), Err(PayloadError::BadLength));
    }

    #[test]
    fn imu_sample_layout() {
        let m = ImuSampleMsg {
            t: -3.0,
            dtheta_b: [1e-5, 2e-5, 3e-5],
            dv_b: [0.1, 0.2, 0.049],
        };
        let (b, n) = payload(&Message::ImuSample(m));
        assert_eq!(n, 32);
        assert_eq!(f64_at(&b, 0), -3.0);
        assert_eq!(f32_at(&b, 8), 1e-5);
        assert_eq!(f32_at(&b, 16), 3e-5);
        assert_eq!(f32_at(&b, 20), 0.1);
        assert_eq!(f32_at(&b, 28), 0.049);
        let back = Message::read_payload(MessageKind::ImuSample, &b[..n]).unwrap();
        assert_eq!(back, Message::ImuSample(m));
    }

    #[test]
    fn estimates_layout() {
        let v = |k: f32| [k, k + 1.0, k + 2.0];
        let m = EstimatesMsg {
            t: 100.0,
            gyro_bias: v(1.0),
            gyro_bias_sigma: v(10.0),
            accel_bias: v(20.0),
            accel_bias_sigma: v(30.0),
            misalignment: v(40.0),
            misalignment_sigma: v(50.0),
            flexure: v(60.0),
            flexure_sigma: v(70.0),
            health: HealthFlags(0xBEEF),
        };
        let (b, n) = payload(&Message::Estimates(m));
        assert_eq!(n, 106);
        for (i, base) in [1.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0]
            .into_iter()
            .enumerate()
        {
            let off = 8 + 12 * i;
            assert_eq!(f32_at(&b, off), base);
            assert_eq!(f32_at(&b, off + 8), base + 2.0);
        }
        assert_eq!(&b[104..106], &[0xEF, 0xBE]);
        let back = Message::read_payload(MessageKind::Estimates, &b[..n]).unwrap();
        assert_eq!(back, Message::Estimates(m));
        let mut bad = m;
        bad.flexure_sigma[1] = -1.0;
        assert_eq!(
            Message::Estimates(bad).validate(),
            Err(PayloadError::BadValue)
        );
    }

    #[test]
    fn status_layout() {
        let mut c = [0u32; STATUS_COUNTERS];
        for (i, x) in c.iter_mut().enumerate() {
            *x = 1000 + i as u32;
        }
        let m = status_from_counters(7.0, &c);
        assert_eq!(status_counters(&m), c);
        assert_eq!(m.link.decoder.frames, 1000);
        assert_eq!(m.link.decoder.bad_value, 1008);
        assert_eq!(m.link.sequence.accepted, 1009);
        assert_eq!(m.link.sequence.resyncs, 1015);
        assert_eq!(m.engine.imu_samples, 1016);
        assert_eq!(m.engine.resets, 1022);
        assert_eq!(m.health.updates, 1023);
        assert_eq!(m.health.gated, 1024);
        assert_eq!(m.health.bad_innovation_variance, 1029);
        let mut m = m;
        m.watch = WatchReport {
            nis: core::array::from_fn(|i| 1.0 + i as f32 / 8.0),
            whiteness: core::array::from_fn(|i| -0.5 + i as f32 / 16.0),
            delay: ScoreFigures {
                lm: 120.5,
                t2: 30.25,
                estimate: 0.0185,
                sigma: 2.5e-4,
            },
            windows: 0x1234,
            verdict: Verdict::ModelIncomplete {
                most_likely: Effect::TimeDelay,
            },
        };
        let (b, n) = payload(&Message::Status(m));
        assert_eq!(n, 220);
        assert_eq!(f64_at(&b, 0), 7.0);
        for (i, want) in c.iter().enumerate() {
            assert_eq!(u32_at(&b, 8 + 4 * i), *want);
        }
        for i in 0..9 {
            assert_eq!(f32_at(&b, 128 + 4 * i), m.watch.nis[i]);
            assert_eq!(f32_at(&b, 164 + 4 * i), m.watch.whiteness[i]);
        }
        assert_eq!(
            [200, 204, 208, 212].map(|o| f32_at(&b, o)),
            [120.5, 30.25, 0.0185, 2.5e-4]
        );
        assert_eq!(&b[216..220], &[0x34, 0x12, 2, 5]);
        let back = Message::read_payload(MessageKind::Status, &b[..n]).unwrap();
        assert_eq!(back, Message::Status(m));
    }

    /// Every verdict survives the link; bytes the encoder never writes are refused.
    #[test]
    fn status_verdicts_round_trip_and_bad_ones_are_refused() {
        let mut m = StatusMsg::default();
        let verdicts = [
            Verdict::Warming,
            Verdict::Consistent,
            Verdict::ModelIncomplete {
                most_likely: Effect::TimeDelay,
            },
            Verdict::NisOutOfBand { axis: 8 },
        ];
        for v in verdicts {
            m.watch.verdict = v;
            let (b, n) = payload(&Message::Status(m));
            let back = Message::read_payload(MessageKind::Status, &b[..n]).unwrap();
            assert_eq!(back, Message::Status(m));
        }
        for bad in [[0u8, 1], [1, 7], [2, 0], [2, 200], [3, 9], [4, 0]] {
            let (mut b, n) = payload(&Message::Status(m));
            b[218..220].copy_from_slice(&bad);
            assert_eq!(
                Message::read_payload(MessageKind::Status, &b[..n]),
                Err(PayloadError::BadValue),
                "{bad:?}"
            );
        }
        m.watch.verdict = Verdict::NisOutOfBand { axis: 9 };
        assert_eq!(Message::Status(m).validate(), Err(PayloadError::BadValue));
        m.watch.verdict = Verdict::Consistent;
        m.watch.delay.t2 = f32::NAN;
        assert_eq!(Message::Status(m).validate(), Err(PayloadError::NonFinite));
        let (mut b, n) = payload(&Message::Status(StatusMsg::default()));
        b[132..136].copy_from_slice(&f32::INFINITY.to_le_bytes());
        assert_eq!(
            Message::read_payload(MessageKind::Status, &b[..n]),
            Err(PayloadError::NonFinite)
        );
    }

    pub(crate) fn config() -> ConfigMsg {
        ConfigMsg {
            t: 1.25,
            filter_period_s: 0.01,
            matching: Matching {
                velocity: true,
                attitude: false,
                angular_rate: true,
            },
            dynamic_lever_arm: true,
            bending: LeverBending::UniformArc,
            lever_arm_m: [10.0, -2.5, 0.75],
            flexure_period_s: 0.01,
            flexure: [[1.9, -0.95, 1e-5], [1.8, -0.9, 2e-5], [1.5, 0.3, 3e-5]],
            flexure_second_order: [false, false, true],
            lever_arm_rate_noise: 5e-4,
            process_noise: [1e-4, 1e-5, 1e-9, 1e-7, 0.0],
            measurement_noise: [[0.01, 0.02, 0.03], [1e-4, 2e-4, 3e-4], [2e-4, 4e-4, 6e-4]],
            initial_sigma: [0.1, 0.0174, 4.8e-6, 9.8e-3, 1e-3],
            initial_misalignment_rad: [0.001, -0.002, 0.003],
            gate_sigma: 5.0,
            variance_floor: 1e-9,
            estimates_every: 10,
            status_every: 100,
            effects: [
                Some(EffectPrior {
                    effect: Effect::TimeDelay,
                    prior_sigma: 0.2,
                }),
                Some(EffectPrior {
                    effect: Effect::GyroScaleFactor,
                    prior_sigma: 1e-3,
                }),
                None,
                None,
            ],
            initial_delay_s: 0.02,
            master_error_correlation_s: 45.0,
        }
    }

    #[test]
    fn config_layout() {
        let m = config();
        let (b, n) = payload(&Message::Config(m));
        assert_eq!(n, CONFIG_LEN);
        assert_eq!(f64_at(&b, 0), 1.25);
        assert_eq!(f64_at(&b, 8), 0.01);
        assert_eq!(b[16], 0b1101, "velocity, rate, dynamic lever arm");
        assert_eq!(b[17], 1, "uniform arc");
        assert_eq!(f32_at(&b, 18), 10.0);
        assert_eq!(f32_at(&b, 26), 0.75);
        assert_eq!(f64_at(&b, 30), 0.01);
        assert_eq!(f32_at(&b, 38), 1.9);
        assert_eq!(f32_at(&b, 70), 3e-5);
        assert_eq!(f32_at(&b, 74), 1e-4);
        assert_eq!(f32_at(&b, 90), 0.0);
        assert_eq!(f32_at(&b, 94), 0.01, "velocity noise x");
        assert_eq!(f32_at(&b, 98), 0.02, "velocity noise y");
        assert_eq!(f32_at(&b, 106), 1e-4, "attitude noise x");
        assert_eq!(f32_at(&b, 126), 6e-4, "rate noise z");
        assert_eq!(f32_at(&b, 130), 0.1);
        assert_eq!(f32_at(&b, 146), 1e-3);
        assert_eq!(f32_at(&b, 150), 0.001);
        assert_eq!(f32_at(&b, 162), 5.0);
        assert_eq!(f32_at(&b, 166), 1e-9);
        assert_eq!(&b[170..174], &[10, 0, 100, 0]);
        assert_eq!(b[174], 2, "two effects");
        assert_eq!(b[175], Effect::TimeDelay.code());
        assert_eq!(f32_at(&b, 176), 0.2);
        assert_eq!(b[180], Effect::GyroScaleFactor.code());
        assert_eq!(f32_at(&b, 181), 1e-3);
        assert!(b[185..195].iter().all(|x| *x == 0), "unused slots are zero");
        assert_eq!(f32_at(&b, 195), 0.02, "initial delay");
        assert_eq!(f32_at(&b, 199), 45.0, "master error correlation time");
        assert_eq!(b[203], 0b100, "axis z second-order Gauss-Markov");
        assert_eq!(f32_at(&b, 204), 5e-4, "lever-arm rate noise");
        assert_eq!(b[208], 0xAA, "nothing written past the payload");
        let back = Message::read_payload(MessageKind::Config, &b[..n]).unwrap();
        assert_eq!(back, Message::Config(m));

        let read = |b: &[u8]| Message::read_payload(MessageKind::Config, b);
        let mut x = b;
        x[16] = 0x10; // unknown flag bit
        assert_eq!(read(&x[..n]), Err(PayloadError::BadValue));
        let mut x = b;
        x[17] = 2; // unknown bending
        assert_eq!(read(&x[..n]), Err(PayloadError::BadValue));
        let mut x = b;
        x[8..16].copy_from_slice(&0.0f64.to_le_bytes()); // zero period
        assert_eq!(read(&x[..n]), Err(PayloadError::BadValue));
        let mut x = b;
        x[94..98].copy_from_slice(&(-1.0f32).to_le_bytes()); // negative noise
        assert_eq!(read(&x[..n]), Err(PayloadError::BadValue));
        let mut x = b;
        x[162..166].copy_from_slice(&0.0f32.to_le_bytes()); // zero gate
        assert_eq!(read(&x[..n]), Err(PayloadError::BadValue));
        let mut x = b;
        x[42..46].copy_from_slice(&f32::NAN.to_le_bytes());
        assert_eq!(read(&x[..n]), Err(PayloadError::NonFinite));
        let mut x = b;
        x[203] = 0b1000; // an axis that does not exist
        assert_eq!(read(&x[..n]), Err(PayloadError::BadValue));
        let mut x = b;
        x[66..70].copy_from_slice(&0.0f32.to_le_bytes()); // second-order axis z, ζ = 0
        assert_eq!(read(&x[..n]), Err(PayloadError::BadValue));
        let mut x = b;
        x[203] = 0b110; // axis y second-order too: its a2 = −0.9 is no damping ratio
        assert_eq!(read(&x[..n]), Err(PayloadError::BadValue));
        assert_eq!(read(&b[..n - 1]), Err(PayloadError::BadLength));
    }

    #[test]
    fn config_augmentation_refusals() {
        let m = config();
        let (b, n) = payload(&Message::Config(m));
        let read = |b: &[u8]| Message::read_payload(MessageKind::Config, b);
        let bad = |e| Err(PayloadError::BadEffects(e));
        let mut x = b;
        x[174] = 5; // more blocks than MAX_EFFECTS
        assert_eq!(read(&x[..n]), bad(EffectsError::TooMany { count: 5 }));
        let mut x = b;
        x[180] = 0; // code 0 in a used slot
        assert_eq!(read(&x[..n]), bad(EffectsError::UnknownCode { code: 0 }));
        let mut x = b;
        x[180] = 42;
        assert_eq!(read(&x[..n]), bad(EffectsError::UnknownCode { code: 42 }));
        let mut x = b;
        x[180] = Effect::TimeDelay.code();
        let dup = EffectsError::Duplicate {
            code: Effect::TimeDelay.code(),
        };
        assert_eq!(read(&x[..n]), bad(dup));
        let prior = EffectsError::BadPrior {
            code: Effect::GyroScaleFactor.code(),
        };
        for p in [0.0f32, -0.0, -1e-3, f32::NAN, f32::INFINITY] {
            let mut x = b;
            x[181..185].copy_from_slice(&p.to_le_bytes());
            assert_eq!(read(&x[..n]), bad(prior), "prior {p}");
        }
        let mut x = b;
        x[174] = 1; // the second block's bytes are now an unused slot, not zero
        assert_eq!(read(&x[..n]), bad(EffectsError::UnusedSlot));
        let mut x = b;
        x[194] = 1; // stray byte in the last, unused slot
        assert_eq!(read(&x[..n]), bad(EffectsError::UnusedSlot));
        // A block after an empty slot cannot be encoded.
        let mut gap = m;
        gap.effects = [m.effects[0], None, m.effects[1], None];
        assert_eq!(
            Message::Config(gap).validate(),
            Err(PayloadError::BadEffects(EffectsError::UnusedSlot))
        );
        // Four blocks, the most a layout holds, are fine; no block at all too.
        let mut four = m;
        four.effects = [
            Effect::LeverArmCoupling,
            Effect::GyroGSensitivity,
            Effect::AccelMisalignment,
            Effect::LeverArmError,
        ]
        .map(|effect| {
            Some(EffectPrior {
                effect,
                prior_sigma: 0.5,
            })
        });
        let (b4, n4) = payload(&Message::Config(four));
        assert_eq!(read(&b4[..n4]), Ok(Message::Config(four)));
        assert_eq!(four.augmentation::<f32>().dimension(), 21 + 9 + 9 + 3 + 3);
        let mut none = m;
        none.effects = [None; MAX_EFFECTS];
        let (b0, n0) = payload(&Message::Config(none));
        assert!(b0[174..195].iter().all(|x| *x == 0));
        assert_eq!(read(&b0[..n0]), Ok(Message::Config(none)));
        assert!(none.augmentation::<f64>().is_empty());
    }

    #[test]
    fn config_engine_round_trip() {
        let m = config();
        let e: EngineConfig<f32> = m.to_engine();
        assert_eq!(e.augmentation.offset(Effect::TimeDelay), Some(21));
        assert_eq!(e.augmentation.offset(Effect::GyroScaleFactor), Some(22));
        assert_eq!(e.augmentation.dimension(), 25);
        let priors: [f32; 2] = [0.2, 1e-3];
        for (b, p) in e.augmentation.blocks().zip(priors) {
            assert_eq!(b.prior_sigma, p);
        }
        assert_eq!(e.filter_period_s, 0.01);
        assert!(matches!(e.flexure.axes[1], AxisModel::Ar(a) if a.a2 == -0.9));
        assert!(
            matches!(e.flexure.axes[2], AxisModel::SecondOrder(g) if g.omega_rad_s == 1.5 && g.damping == 0.3)
        );
        assert_eq!(e.bending, LeverBending::UniformArc);
        assert!(e.dynamic_lever_arm && !e.matching.attitude);
        let mut back = ConfigMsg::from_engine(&e, 10, 100);
        back.t = m.t;
        // The f32 engine keeps the flexure period in f32: back on the f64 wire field it
        // differs by that rounding, and converts to the same f32 again.
        assert_eq!(back.flexure_period_s, f64::from(0.01f32));
        assert_eq!(back.to_engine::<f32>().flexure.period_s, e.flexure.period_s);
        back.flexure_period_s = m.flexure_period_s;
        assert_eq!(back, m);
        let e64: EngineConfig<f64> = m.to_engine();
        let mut back = ConfigMsg::from_engine(&e64, 10, 100);
        back.t = m.t;
        assert_eq!(back, m, "f32 -> f64 -> f32 is exact");
    }

    fn effect_estimate(effect: Effect, base: f32) -> EffectEstimate<f32> {
        let mut e = EffectEstimate {
            effect,
            value: [0.0; 9],
            sigma: [0.0; 9],
        };
        for k in 0..effect.states() {
            e.value[k] = base + k as f32;
            e.sigma[k] = 0.5 * (base + k as f32);
        }
        e
    }

    type StateEntry = (Effect, usize, f32, f32);

    fn collect_states(it: impl Iterator<Item = StateEntry>) -> ([StateEntry; 40], usize) {
        let mut out = [(Effect::TimeDelay, 99, 0.0, 0.0); 40];
        let mut n = 0;
        for e in it {
            out[n] = e;
            n += 1;
        }
        (out, n)
    }

    #[test]
    fn effects_layout_and_pages() {
        let blocks = [
            effect_estimate(Effect::TimeDelay, 1.0),
            effect_estimate(Effect::LeverArmError, 10.0),
            effect_estimate(Effect::GyroScaleFactor, 20.0),
            effect_estimate(Effect::AccelScaleFactor, 30.0),
        ];
        // 1 + 3 + 3 + 3 = 10 states: one frame, the board's case.
        let m = EffectsMsg::from_estimates(4.5, &blocks, 0).unwrap();
        assert!(EffectsMsg::from_estimates(4.5, &blocks, 1).is_none());
        assert_eq!(EffectsMsg::frames(&m.layout), 1);
        let (b, n) = payload(&Message::Effects(m));
        assert_eq!(n, EFFECTS_LEN);
        assert_eq!(f64_at(&b, 0), 4.5);
        assert_eq!(&b[8..12], &[5, 6, 1, 3], "codes in state order");
        assert_eq!(b[12], 0, "page");
        assert_eq!(f32_at(&b, 13), 1.0, "time delay");
        assert_eq!(f32_at(&b, 17), 10.0, "lever arm x");
        assert_eq!(f32_at(&b, 13 + 4 * 9), 32.0, "accel scale factor z");
        assert_eq!(f32_at(&b, 13 + 4 * 10), 0.0, "past the layout");
        assert_eq!(f32_at(&b, 61), 0.5, "σ of the time delay");
        assert_eq!(f32_at(&b, 61 + 4 * 9), 16.0);
        assert_eq!(b[109], 0xAA, "nothing written past the payload");
        let back = Message::read_payload(MessageKind::Effects, &b[..n]).unwrap();
        assert_eq!(back, Message::Effects(m));
        let (states, len) = collect_states(m.states());
        assert_eq!(len, 10);
        assert_eq!(states[0], (Effect::TimeDelay, 0, 1.0, 0.5));
        assert_eq!(states[3], (Effect::LeverArmError, 2, 12.0, 6.0));
        assert_eq!(states[9], (Effect::AccelScaleFactor, 2, 32.0, 16.0));

        // 9 + 9 + 3 = 21 states: two frames, the second carries states 12..21.
        let big = [
            effect_estimate(Effect::GyroGSensitivity, 100.0),
            effect_estimate(Effect::LeverArmCoupling, 200.0),
            effect_estimate(Effect::GyroMisalignment, 300.0),
        ];
        let p0 = EffectsMsg::from_estimates(1.0, &big, 0).unwrap();
        let p1 = EffectsMsg::from_estimates(1.0, &big, 1).unwrap();
        assert!(EffectsMsg::from_estimates(1.0, &big, 2).is_none());
        let (all, len) = collect_states(p0.states().chain(p1.states()));
        assert_eq!(len, 21);
        assert_eq!(all[11], (Effect::LeverArmCoupling, 2, 202.0, 101.0));
        assert_eq!(all[12], (Effect::LeverArmCoupling, 3, 203.0, 101.5));
        assert_eq!(all[20], (Effect::GyroMisalignment, 2, 302.0, 151.0));
        assert_eq!(p1.value[9], 0.0);
        for p in [p0, p1] {
            assert_eq!(Message::Effects(p).validate(), Ok(()));
        }
        assert!(EffectsMsg::from_estimates::<f32>(1.0, &[], 0).is_none());
    }

    #[test]
    fn effects_refusals() {
        let blocks = [effect_estimate(Effect::GyroScaleFactor, 1.0)];
        let m = EffectsMsg::from_estimates(2.0, &blocks, 0).unwrap();
        let (b, n) = payload(&Message::Effects(m));
        let read = |b: &[u8]| Message::read_payload(MessageKind::Effects, b);
        let mut x = b;
        x[9] = 99;
        assert_eq!(
            read(&x[..n]),
            Err(PayloadError::BadEffects(EffectsError::UnknownCode {
                code: 99
            }))
        );
        let mut x = b;
        x[9] = Effect::GyroScaleFactor.code();
        assert_eq!(
            read(&x[..n]),
            Err(PayloadError::BadEffects(EffectsError::Duplicate {
                code: Effect::GyroScaleFactor.code()
            }))
        );
        let mut x = b;
        x[8] = 0; // a block after an empty slot
        x[9] = Effect::GyroScaleFactor.code();
        assert_eq!(
            read(&x[..n]),
            Err(PayloadError::BadEffects(EffectsError::UnusedSlot))
        );
        let mut x = b;
        x[8] = 0; // no block at all
        assert_eq!(read(&x[..n]), Err(PayloadError::BadValue));
        let mut x = b;
        x[12] = 1; // page past the layout's only frame
        assert_eq!(read(&x[..n]), Err(PayloadError::BadValue));
        let mut x = b;
        x[13 + 12..13 + 16].copy_from_slice(&1.0f32.to_le_bytes()); // state 3: past the block
        assert_eq!(read(&x[..n]), Err(PayloadError::BadValue));
        let mut x = b;
        x[61..65].copy_from_slice(&(-1.0f32).to_le_bytes()); // negative σ
        assert_eq!(read(&x[..n]), Err(PayloadError::BadValue));
        let mut x = b;
        x[13..17].copy_from_slice(&f32::NAN.to_le_bytes());
        assert_eq!(read(&x[..n]), Err(PayloadError::NonFinite));
    }

    #[test]
    fn end_layout() {
        let m = EndMsg { t: 321.5 };
        let (b, n) = payload(&Message::End(m));
        assert_eq!(n, END_LEN);
        assert_eq!(f64_at(&b, 0), 321.5);
        let back = Message::read_payload(MessageKind::End, &b[..n]).unwrap();
        assert_eq!(back, Message::End(m));
        assert_eq!(
            Message::End(EndMsg { t: f64::NAN }).validate(),
            Err(PayloadError::NonFinite)
        );
    }

    #[test]
    fn short_buffer_refused() {
        let m = Message::MasterNav(master(true));
        let mut buf = [0u8; 84];
        assert_eq!(m.write_payload(&mut buf), None);
    }

    #[test]
    fn engine_conversions() {
        let m = master(true);
        let e: MasterNav<f64> = m.to_engine();
        assert_eq!(MasterNavMsg::from_engine(&e), m);
        let e32: MasterNav<f32> = m.to_engine();
        let back = MasterNavMsg::from_engine(&e32);
        assert_eq!(back.v_n, m.v_n);
        assert_eq!(back.w_ib_bm, m.w_ib_bm);
        assert!((back.q_bm_n[0] - m.q_bm_n[0]).abs() < 1e-7);
        assert!(Message::MasterNav(back).validate().is_ok());

        let s = ImuSampleMsg {
            t: 1.0,
            dtheta_b: [1.0, 2.0, 3.0],
            dv_b: [4.0, 5.0, 6.0],
        };
        assert_eq!(ImuSampleMsg::from_engine(&s.to_engine::<f32>()), s);

        let est = EstimatesMsg {
            t: 2.0,
            gyro_bias: [1e-6; 3],
            gyro_bias_sigma: [1e-7; 3],
            accel_bias: [1e-3; 3],
            accel_bias_sigma: [1e-4; 3],
            misalignment: [0.01; 3],
            misalignment_sigma: [1e-4; 3],
            flexure: [1e-4; 3],
            flexure_sigma: [1e-5; 3],
            health: HealthFlags(3),
        };
        assert_eq!(
            EstimatesMsg::from_engine(&est.to_engine::<f64>(), est.health),
            est
        );
    }

    #[test]
    fn health_flags() {
        let h = Health::default();
        let c = Counters::default();
        assert_eq!(
            HealthFlags::from_engine(&h, &c),
            HealthFlags(HealthFlags::NO_MATCH_YET)
        );
        let h = Health {
            gated_streak: 2,
            variance_clamped: 1,
            ..Health::default()
        };
        let c = Counters {
            master_matched: 5,
            master_dropped: 1,
            resets: 1,
            ..Counters::default()
        };
        let f = HealthFlags::from_engine(&h, &c);
        assert!(f.contains(
            HealthFlags::GATING
                | HealthFlags::VARIANCE_CLAMPED
                | HealthFlags::RESET
                | HealthFlags::MASTER_LOST
        ));
        assert!(!f.contains(HealthFlags::NO_MATCH_YET));
        assert!(!f.contains(HealthFlags::NON_FINITE));
    }
}
