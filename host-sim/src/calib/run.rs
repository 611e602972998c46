//! Runs the engine over a recording in f64 or f32, exactly as the board would be fed
//! (IMU samples in order, each master message handed over once the slave has reached
//! its time of validity), and gathers estimates, innovations and covariance checks.

use super::config::CalibConfig;
use super::master_steps::StepCorrection;
use super::mounting::within_half_turn;
use super::residuals::InnovationSummary;
use crate::recording::{ImuSample, MasterMsg, Recording};
use flexcal_core::augment::Effect;
use flexcal_core::earth::Position;
use flexcal_core::engine::{
    Counters, Engine, ImuIncrement, MasterFate, MasterNav, MatchReport, StepReports,
};
use flexcal_core::kalman::Health;
use flexcal_core::model::{BA, BG, MU};
use flexcal_core::real::Real;
use nalgebra::{Quaternion, SMatrix, UnitQuaternion, Vector3};

/// Numeric precision of the engine.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Precision {
    /// Double precision (desktop reference).
    F64,
    /// Single precision (as on the board).
    F32,
}

/// The estimates after one master update (f64, SI).
#[derive(Clone, Copy, Debug, Default)]
pub struct EstimateRow {
    /// Time of validity (s).
    pub t: f64,
    /// Gyro bias (rad/s).
    pub gyro_bias: [f64; 3],
    /// σ.
    pub gyro_bias_sigma: [f64; 3],
    /// Accelerometer bias (m/s²).
    pub accel_bias: [f64; 3],
    /// σ.
    pub accel_bias_sigma: [f64; 3],
    /// Misalignment (rad).
    pub misalignment: [f64; 3],
    /// σ.
    pub misalignment_sigma: [f64; 3],
    /// Flexure angle (rad).
    pub flexure: [f64; 3],
    /// σ.
    pub flexure_sigma: [f64; 3],
}

/// One matching channel's scalar innovation.
#[derive(Clone, Copy, Debug)]
pub struct Innovation {
    /// Time of validity (s).
    pub t: f64,
    /// Channel: 0 velocity, 1 attitude, 2 angular rate.
    pub channel: usize,
    /// Axis 0..3.
    pub axis: usize,
    /// Innovation.
    pub value: f64,
    /// Its predicted variance.
    pub variance: f64,
    /// Whether it passed the gate.
    pub accepted: bool,
}

/// Channel names in the order of `Innovation::channel`.
pub const CHANNELS: [&str; 3] = ["velocity", "attitude", "angular_rate"];

/// Covariance health over the run.
#[derive(Clone, Copy, Debug, Default)]
pub struct CovarianceCheck {
    /// How many times the covariance was checked (after every master update).
    pub checks: usize,
    /// Checks where the covariance was not positive definite: a conditional variance of
    /// its UD factors (`Kalman::min_conditional_variance`) not positive.
    pub not_positive_definite: usize,
    /// Largest |P_ij − P_ji| seen, scaled units: zero by construction since the filter
    /// keeps the factors (`Kalman`), so it stays at its initial 0.
    pub max_asymmetry: f64,
    /// Smallest diagonal element seen, scaled units.
    pub min_diagonal: f64,
}

/// An augmented effect's estimate after one master update.
#[derive(Clone, Debug, PartialEq)]
pub struct EffectRow {
    /// Time of validity (s).
    pub t: f64,
    /// The effect.
    pub effect: Effect,
    /// Its states (SI unit of the effect).
    pub value: Vec<f64>,
    /// Their σ.
    pub sigma: Vec<f64>,
    /// The Wald statistic `x̂ᵀ P⁻¹ x̂` of the block (χ²(k) when the effect is absent).
    pub wald: f64,
}

/// Every master message of a run by what became of it: the fields other than `given`,
/// `before_slave_start` and `after_slave_end` add up to `given`, so none is lost
/// without a count.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct MasterAccount {
    /// Handed to the engine.
    pub given: u32,
    /// Matched (each made a filter update).
    pub matched: u32,
    /// Used to start or restart the slave solution.
    pub initialized: u32,
    /// Refused as older than the slave's alignment buffer.
    pub stale: u32,
    /// Refused as not later than the message before.
    pub out_of_order: u32,
    /// Refused for a non-finite value.
    pub non_finite: u32,
    /// Dropped by the engine's full master queue (`PENDING_DEPTH` messages).
    pub dropped_by_queue: u32,
    /// Due, but the slave solution could not be read at their time.
    pub unmatched: u32,
    /// Still queued when the slave's samples ended.
    pub left_pending: u32,
    /// Stamped (after the clock shift) before the slave's first line: not handed to the
    /// engine, which has nothing to match them with (handed over in one burst at the
    /// first sample, they overflowed the queue and started the solution from a
    /// message older than the slave).
    pub before_slave_start: u32,
    /// Read after the slave's last sample: not handed to the engine.
    pub after_slave_end: u32,
    /// Of `matched`: matched with the velocity and rate channels held, the delay's
    /// columns not formed yet (the master's rates not covering their window: the start,
    /// a gap; [`MasterFate::channels_held`]).
    pub matched_with_channels_held: u32,
}

impl MasterAccount {
    fn new(given: u32, c: &Counters, f: &MasterFate, outside: [u32; 2]) -> Self {
        Self {
            given,
            matched: c.master_matched,
            initialized: f.initialized,
            stale: c.master_stale,
            out_of_order: c.master_out_of_order,
            non_finite: f.non_finite,
            dropped_by_queue: c.master_dropped,
            unmatched: f.unmatched,
            left_pending: f.pending,
            before_slave_start: outside[0],
            after_slave_end: outside[1],
            matched_with_channels_held: f.channels_held,
        }
    }

    /// Messages handed to the engine that made no update and did not start the
    /// solution.
    pub fn lost(&self) -> u32 {
        self.stale
            + self.out_of_order
            + self.non_finite
            + self.dropped_by_queue
            + self.unmatched
            + self.left_pending
    }

    /// Whether every message handed to the engine is counted exactly once.
    pub fn balanced(&self) -> bool {
        self.matched + self.initialized + self.lost() == self.given
    }
}

/// Everything a calibration run produced.
pub struct CalibResult {
    /// Estimates after every master update ([`run`]), or a thinned set that holds the
    /// last one (a run into a [`RunSink`] that keeps less).
    pub rows: Vec<EstimateRow>,
    /// Scalar innovations ([`run`]; empty from a sink that does not keep them).
    pub innovations: Vec<Innovation>,
    /// What the innovations add up to, whether they were kept or not.
    pub summary: InnovationSummary,
    /// Input counters.
    pub counters: Counters,
    /// Every master message by what became of it (`None` from the board, whose
    /// `Status` carries the counters only).
    pub master: Option<MasterAccount>,
    /// Filter health.
    pub health: Health,
    /// Covariance checks.
    pub covariance: CovarianceCheck,
    /// Final covariance of (gyro bias, accel bias, misalignment), physical units.
    pub final_cov9: SMatrix<f64, 9, 9>,
    /// Precision used.
    pub precision: Precision,
    /// Augmented effects' estimates after every master update (empty for the declared
    /// model; from a sink that keeps less, the last of each effect).
    pub effect_rows: Vec<EffectRow>,
}

impl CalibResult {
    /// Mean normalized innovation squared over accepted scalar innovations (expect 1).
    pub fn nis_mean(&self) -> f64 {
        self.summary.nis_mean()
    }

    /// The last estimates.
    pub fn last(&self) -> EstimateRow {
        self.rows.last().copied().unwrap_or_default()
    }

    /// The last estimate of each augmented effect.
    pub fn final_effects(&self) -> Vec<EffectRow> {
        let mut out: Vec<EffectRow> = Vec::new();
        for r in self.effect_rows.iter().rev() {
            if !out.iter().any(|o| o.effect == r.effect) {
                out.push(r.clone());
            }
        }
        out.sort_by_key(|r| r.effect);
        out
    }

    /// −2 log-likelihood of the innovations (up to the constant `n ln 2π`):
    /// `Σ ln s + ν²/s` over every scalar innovation, gated or not.
    pub fn neg2_log_likelihood(&self) -> f64 {
        self.summary.neg2_log_likelihood()
    }
}

/// Where a run's outputs go as they are produced, in time order.
pub trait RunSink {
    /// One scalar innovation.
    fn innovation(&mut self, i: &Innovation);
    /// The estimates after one master update.
    fn row(&mut self, r: &EstimateRow);
    /// An augmented effect's estimate after one master update.
    fn effect(&mut self, e: EffectRow);
}

/// The sink of [`run`]: keeps everything, in memory.
#[derive(Default)]
pub struct KeepAll {
    rows: Vec<EstimateRow>,
    innovations: Vec<Innovation>,
    effect_rows: Vec<EffectRow>,
}

impl RunSink for KeepAll {
    fn innovation(&mut self, i: &Innovation) {
        self.innovations.push(*i);
    }
    fn row(&mut self, r: &EstimateRow) {
        self.rows.push(*r);
    }
    fn effect(&mut self, e: EffectRow) {
        self.effect_rows.push(e);
    }
}

/// What a run produced besides what went into its sink.
pub struct RunEnd {
    /// What the innovations add up to.
    pub summary: InnovationSummary,
    /// Input counters.
    pub counters: Counters,
    /// Every master message by what became of it.
    pub master: MasterAccount,
    /// Filter health.
    pub health: Health,
    /// Covariance checks.
    pub covariance: CovarianceCheck,
    /// Final covariance of (gyro bias, accel bias, misalignment), physical units.
    pub final_cov9: SMatrix<f64, 9, 9>,
    /// Precision used.
    pub precision: Precision,
}

impl RunEnd {
    /// The result of a run, with the rows, innovations and effect rows a sink kept.
    pub fn into_result(
        self,
        rows: Vec<EstimateRow>,
        innovations: Vec<Innovation>,
        effect_rows: Vec<EffectRow>,
    ) -> CalibResult {
        CalibResult {
            rows,
            innovations,
            summary: self.summary,
            counters: self.counters,
            master: Some(self.master),
            health: self.health,
            covariance: self.covariance,
            final_cov9: self.final_cov9,
            precision: self.precision,
            effect_rows,
        }
    }
}

/// The samples a run reads, in time order: the slave's clock-starting time, then its
/// samples and the master's messages, each possibly an error of the source (a line of
/// a file), which ends the run with that error.
pub struct Source<'a> {
    /// Time of the slave's first line (s).
    pub imu_t0: f64,
    /// Lever arm `r0`, master body frame, metres.
    pub lever_arm_m: [f64; 3],
    /// The slave's samples after the first line.
    pub imu: &'a mut dyn Iterator<Item = Result<ImuSample, String>>,
    /// The master's messages. Those after the slave's last sample are read to the end
    /// (their errors count) but not handed to the engine.
    pub master: &'a mut dyn Iterator<Item = Result<MasterMsg, String>>,
}

fn to3<T: Real>(v: &Vector3<T>) -> [f64; 3] {
    [v.x.to_f64(), v.y.to_f64(), v.z.to_f64()]
}

/// The master's message as the engine takes it (ENU, Hamilton scalar-first `q_bm^n`,
/// position in radians).
pub fn master_nav<T: Real>(m: &crate::recording::MasterMsg) -> MasterNav<T> {
    let q = m.q_bm_n.map(T::of);
    MasterNav {
        t: m.t,
        q_bm_n: UnitQuaternion::new_normalize(Quaternion::new(q[0], q[1], q[2], q[3])),
        v_n: Vector3::from(m.v_n_mps.map(T::of)),
        pos: Position {
            lat_rad: T::of(m.lat_deg.to_radians()),
            lon_rad: T::of(m.lon_deg.to_radians()),
            height_m: T::of(m.height_m),
        },
        w_ib_bm: m.omega_ib_bm_radps.map(|w| Vector3::from(w.map(T::of))),
    }
}

/// The scalar innovations of one master update.
fn innovations_of<T: Real>(r: &MatchReport<T>) -> impl Iterator<Item = Innovation> + '_ {
    [r.velocity, r.attitude, r.angular_rate]
        .into_iter()
        .enumerate()
        .filter_map(|(channel, ups)| ups.map(|ups| (channel, ups)))
        .flat_map(move |(channel, ups)| {
            ups.into_iter()
                .enumerate()
                .map(move |(axis, u)| Innovation {
                    t: r.t,
                    channel,
                    axis,
                    value: u.innovation.to_f64(),
                    variance: u.variance.to_f64(),
                    accepted: u.accepted,
                })
        })
}

/// The Wald statistic `x̂ᵀ P⁻¹ x̂` of states `offset..offset + k`.
fn wald<T: Real, const S: usize>(engine: &Engine<T, S>, offset: usize, value: &[f64]) -> f64 {
    let k = value.len();
    let p = nalgebra::DMatrix::from_fn(k, k, |i, j| {
        engine.filter().cov(offset + i, offset + j).to_f64()
    });
    let xv = nalgebra::DVector::from_column_slice(value);
    match p.cholesky() {
        Some(ch) => xv.dot(&ch.solve(&xv)),
        None => f64::NAN,
    }
}

/// Options of a run beyond its configuration.
#[derive(Clone, Copy, Debug, Default)]
pub struct RunOptions {
    /// Freeze the calibrated quantities at this time (s): the innovations after it are
    /// predicted by the calibration estimated before it (the held-out check).
    pub freeze_at_s: Option<f64>,
    /// Keep only the innovations (and counters): no estimate rows, no effect rows, no
    /// per-update covariance check. For the likelihood evaluations of the model search
    /// and the held-out check, which read nothing else: the per-update bookkeeping is
    /// about a fifth of a run.
    pub innovations_only: bool,
}

/// Calibrates a recording with a configuration, in precision `T` and state dimension `S`.
fn run_generic<T: Real, const S: usize>(
    src: Source<'_>,
    cfg: &CalibConfig,
    precision: Precision,
    opts: &RunOptions,
    sink: &mut dyn RunSink,
) -> Result<RunEnd, String> {
    let mut frozen = false;
    let mut engine = Engine::<T, S>::new(cfg.engine_config::<T>(src.lever_arm_m))
        .map_err(|e| format!("engine configuration refused: {e:?}"))?;
    let aug = engine.config().augmentation;
    let mut summary = InnovationSummary::default();
    let mut cov = CovarianceCheck {
        min_diagonal: f64::INFINITY,
        ..Default::default()
    };
    let start = ImuIncrement {
        t: src.imu_t0,
        dtheta_b: Vector3::zeros(),
        dv_b: Vector3::zeros(),
    };
    // Lent to every engine call, which fills it with the matches it made.
    let mut reports = StepReports::new();
    engine
        .push_imu(start, &mut reports)
        .map_err(|e| format!("IMU start at t = {}: {e:?}", src.imu_t0))?;
    // The clock alignment found before the filter (or configured): the master's tags
    // moved onto the slave's time base.
    let shift = cfg.master_clock_offset_s.unwrap_or(0.0);
    // The master's attitude steps found before the filter (or configured), undone on
    // the master's own tags, before the shift.
    let steps = StepCorrection::new(cfg.master_attitude_steps.as_deref().unwrap_or(&[]));
    let mut masters = src
        .master
        .map(|m| {
            m.map(|m| {
                let mut m = steps.apply(m);
                m.t -= shift;
                m
            })
        })
        .peekable();
    let (mut given, mut before_slave_start) = (0u32, 0u32);
    let mut handle =
        |engine: &Engine<T, S>, reports: &[MatchReport<T>], cov: &mut CovarianceCheck| {
            for r in reports {
                for i in innovations_of(r) {
                    summary.push(&i);
                    sink.innovation(&i);
                }
                if opts.innovations_only {
                    continue;
                }
                for b in aug.blocks() {
                    if let Some(est) = engine.effect_estimate(b.effect) {
                        let k = b.effect.states();
                        // A clock's states are the errors of its fed-back nominal values:
                        // the estimate (nominal + state) is what the Wald statistic tests.
                        let value: Vec<f64> = est.value[..k].iter().map(|v| v.to_f64()).collect();
                        sink.effect(EffectRow {
                            t: r.t,
                            effect: b.effect,
                            wald: wald(engine, b.offset, &value),
                            value,
                            sigma: est.sigma[..k].iter().map(|v| v.to_f64()).collect(),
                        });
                    }
                }
                let e = engine.estimates();
                sink.row(&EstimateRow {
                    t: r.t,
                    gyro_bias: to3(&e.gyro_bias),
                    gyro_bias_sigma: to3(&e.gyro_bias_sigma),
                    accel_bias: to3(&e.accel_bias),
                    accel_bias_sigma: to3(&e.accel_bias_sigma),
                    misalignment: within_half_turn(to3(&e.misalignment)),
                    misalignment_sigma: to3(&e.misalignment_sigma),
                    flexure: to3(&e.flexure),
                    flexure_sigma: to3(&e.flexure_sigma),
                });
                // The filter keeps the covariance as its UD factors, in the engine's own
                // precision (the board's f32 path included): it is positive definite exactly
                // when every conditional variance D_j is positive (and finite). A covariance
                // formed from them in f32 may not factor where the factors do (that is why
                // the filter keeps them), so the factors are what is checked.
                let kf = engine.filter();
                let d_min = kf.min_conditional_variance().to_f64();
                cov.checks += 1;
                for i in 0..S {
                    cov.min_diagonal = cov.min_diagonal.min(kf.scaled_variance(i).to_f64());
                }
                if d_min.is_nan() || d_min <= 0.0 {
                    cov.not_positive_definite += 1;
                }
            }
        };
    for s in src.imu {
        let s = s?;
        let inc = ImuIncrement {
            t: s.t,
            dtheta_b: Vector3::from(s.dtheta_rad.map(T::of)),
            dv_b: Vector3::from(s.dv_mps.map(T::of)),
        };
        engine
            .push_imu(inc, &mut reports)
            .map_err(|e| format!("IMU sample at t = {}: {e:?}", s.t))?;
        handle(&engine, &reports, &mut cov);
        while let Some(m) = masters.next_if(|m| !matches!(m, Ok(m) if m.t > s.t)) {
            let m = m?;
            if m.t < src.imu_t0 {
                before_slave_start += 1;
                continue;
            }
            if !frozen && opts.freeze_at_s.is_some_and(|t| m.t >= t) {
                engine.freeze_calibration();
                frozen = true;
            }
            // Refused messages are counted by the engine and reported in the summary;
            // the matches a call made before refusing (a queue overflow) are kept.
            given += 1;
            let _ = engine.push_master(master_nav::<T>(&m), &mut reports);
            handle(&engine, &reports, &mut cov);
        }
    }
    let mut after_slave_end = 0u32;
    for m in masters {
        m?;
        after_slave_end += 1;
    }
    let p = engine.filter().covariance();
    let idx = [BG, BG + 1, BG + 2, BA, BA + 1, BA + 2, MU, MU + 1, MU + 2];
    let final_cov9 = SMatrix::<f64, 9, 9>::from_fn(|i, j| p[(idx[i], idx[j])].to_f64());
    Ok(RunEnd {
        summary,
        counters: engine.counters(),
        master: MasterAccount::new(
            given,
            &engine.counters(),
            &engine.master_fate(),
            [before_slave_start, after_slave_end],
        ),
        health: engine.health(),
        covariance: cov,
        final_cov9,
        precision,
    })
}

/// Calibrates a recording in the requested precision, with the smallest engine whose
/// state holds the configuration's layout (the declared model runs at 21 states).
pub fn run(
    rec: &Recording,
    cfg: &CalibConfig,
    precision: Precision,
) -> Result<CalibResult, String> {
    run_with(rec, cfg, precision, &RunOptions::default())
}

/// [`run`] with options.
pub fn run_with(
    rec: &Recording,
    cfg: &CalibConfig,
    precision: Precision,
    opts: &RunOptions,
) -> Result<CalibResult, String> {
    let mut imu = rec.imu.iter().cloned().map(Ok);
    let mut master = rec.master.iter().cloned().map(Ok);
    let src = Source {
        imu_t0: rec.imu_t0,
        lever_arm_m: rec.meta.lever_arm_m,
        imu: &mut imu,
        master: &mut master,
    };
    let mut all = KeepAll::default();
    let end = run_into(src, cfg, precision, opts, &mut all)?;
    Ok(end.into_result(all.rows, all.innovations, all.effect_rows))
}

/// Runs the engine over `src` in the requested precision, handing every output to
/// `sink` as it is produced: memory does not grow with the run's length unless the
/// sink keeps what it is given.
pub fn run_into(
    src: Source<'_>,
    cfg: &CalibConfig,
    precision: Precision,
    opts: &RunOptions,
    sink: &mut dyn RunSink,
) -> Result<RunEnd, String> {
    let dim = cfg.augmentation::<f64>()?.dimension();
    macro_rules! dispatch {
        ($($s:literal),*) => {
            $(if dim <= $s {
                return match precision {
                    Precision::F64 => run_generic::<f64, $s>(src, cfg, precision, opts, sink),
                    Precision::F32 => run_generic::<f32, $s>(src, cfg, precision, opts, sink),
                };
            })*
        };
    }
    dispatch!(21, 24, 27, 30, 36, 48);
    Err(format!(
        "a layout of {dim} states is larger than the largest engine (48)"
    ))
}
