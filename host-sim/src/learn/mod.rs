//! Learning the filter's model from the recording itself (`docs/model-learning.md`).
//!
//! A user's recording comes with no description of its noise or its flexure. What
//! the filter must assume is estimated here by maximum likelihood of the filter's
//! own innovations (`search`), started from the slave's white noise read off its
//! increments (`increments`) and the built-in model, on the first minutes of the
//! recording; the learned model is adopted only when it predicts the held-out end of
//! the recording at least as well as the model it replaces.

pub mod flexure;
pub mod increments;
pub mod params;
pub mod search;
pub mod truth;

use crate::calib::config::CalibConfig;
use crate::calib::mounting::{coarse_mounting, CoarseMounting};
use crate::diagnose::evaluate::{holdout, Holdout};
use crate::recording::Recording;
use flexcal_core::augment::Effect;
use increments::IncrementNoise;
use params::{ModelParams, Param};
use search::{LearnedValue, Search};
use truth::IDENTIFIABLE_RELATIVE_SIGMA;

/// The size the search of a master's smooth attitude error starts its ladder from
/// (rad): the ladder tries 0.001–1× this (0.2″ to 3.4′).
const MASTER_ATTITUDE_SCALE_RAD: f64 = 1e-3;
/// The same for the velocity error (m/s): 0.1 mm/s to 0.1 m/s.
const MASTER_VELOCITY_SCALE_MPS: f64 = 0.1;

/// Seconds of the recording's start the coarse mounting alignment reads.
const MOUNTING_WINDOW_S: f64 = 60.0;

/// Covariance-matching iterations of the channel noise per pass.
const NOISE_ITERATIONS: usize = 4;

/// How the learner works.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct LearnOptions {
    /// Length of the recording's start the likelihood is searched on (s).
    pub window_s: f64,
    /// Sweeps over all quantities (the second with half the step).
    pub sweeps: usize,
    /// The held-out check freezes the calibration after this fraction of the recording.
    pub holdout_fraction: f64,
}

impl Default for LearnOptions {
    fn default() -> Self {
        Self {
            window_s: 180.0,
            sweeps: 2,
            holdout_fraction: 0.7,
        }
    }
}

/// The held-out check of the learned model against the one it would replace.
#[derive(Clone, Debug, serde::Serialize)]
pub struct HoldoutComparison {
    /// The starting model's held-out innovations.
    pub start: Holdout,
    /// The learned model's.
    pub learned: Holdout,
}

/// What the learner found.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Learned {
    /// Where the starting model came from (the built-in default, or a file with `tune`).
    pub start_origin: String,
    /// The model the search started from, with the mounting found before the filter
    /// (what [`relearn_with`] starts from again).
    #[serde(skip)]
    pub start: CalibConfig,
    /// The model to calibrate with: the learned one if adopted, else the start.
    #[serde(skip)]
    pub config: CalibConfig,
    /// The learned model, adopted or not.
    #[serde(skip)]
    pub learned_config: CalibConfig,
    /// Whether the learned model replaced the start (it predicts the held-out part at
    /// least as well).
    pub adopted: bool,
    /// Each learned quantity: start, value, σ, log-likelihood gain.
    pub values: Vec<LearnedValue>,
    /// The slave's white noise from its increments (the cross-check of the random walks).
    pub increments: Option<IncrementNoise>,
    /// The mounting found before the filter when the start had none
    /// (`calib::mounting`): `Ok` and carried by both the start and the learned model,
    /// or why not (the filter then starts from zero); `None` when the start declared it.
    pub mounting: Option<Result<CoarseMounting, String>>,
    /// Seconds of recording the search ran on.
    pub window_s: f64,
    /// −2 ln L of the starting model on the window.
    pub neg2ll_start: f64,
    /// −2 ln L of the learned model on the window.
    pub neg2ll_learned: f64,
    /// Log-likelihood gain of the learned model over the start on the window.
    pub log_likelihood_gain: f64,
    /// The held-out comparison on the whole recording.
    pub holdout: HoldoutComparison,
    /// Filter runs the search made.
    pub evaluations: usize,
    /// Wall time of the learning (s).
    pub seconds: f64,
}

/// The recording's first `seconds` (IMU and master; no truth).
pub fn window(rec: &Recording, seconds: f64) -> Recording {
    let end = rec.imu_t0 + seconds;
    Recording {
        meta: rec.meta.clone(),
        imu_t0: rec.imu_t0,
        imu: rec.imu.iter().filter(|s| s.t <= end).cloned().collect(),
        master: rec.master.iter().filter(|m| m.t <= end).cloned().collect(),
        truth: None,
    }
}

/// The search's start when nothing is declared: the built-in model at the master's
/// period, angular-rate matching only if the master gives its rate, and the gyro's and
/// the accelerometer's random walks from the increments (the velocity random walk from
/// the accelerometers' white density along the lever arm, `increments` module doc; where
/// that is only a bound, no larger than the built-in value).
pub fn default_start(rec: &Recording, inc: Option<&IncrementNoise>) -> CalibConfig {
    let mut c = CalibConfig::default();
    if rec.meta.master_rate_hz > 0.0 {
        c.filter_period_s = 1.0 / rec.meta.master_rate_hz;
    }
    // The built-in flexure's AR(2) belongs to its own period: re-derived at this one.
    let [a1, a2, sigma] = params::DEFAULT_FLEXURE.ar(c.filter_period_s);
    c.flexure_ar = [a1, a2];
    c.flexure_sigma_rad = sigma;
    c.flexure_axes = None;
    if !rec.master_has_rate() {
        c.matching.retain(|m| m != "angular_rate");
    }
    c.identify_flexure = false;
    if let Some(inc) = inc {
        let (lo, hi) = Param::GyroArw.bounds();
        c.gyro_arw_rad_rs = inc.gyro_arw().clamp(lo, hi);
        let (lo, hi) = Param::AccelVrw.bounds();
        // Read along the arm it is the start (the likelihood moves it only where it
        // resolves it): the 50-run's VRW error 80 % -> under 1 %. Where that is only a
        // bound (a band that is not white: the measured vehicle's, whose accelerometer
        // biases moved by 11σ from a start at its bound of 8.9e-3 m/s/√s), no larger
        // than the built-in value (`docs/model-learning.md`, sessions 21 and 22).
        let read = inc.accel_vrw_mps_rs;
        c.accel_vrw_mps_rs = if inc.accel_vrw_is_upper_bound {
            c.accel_vrw_mps_rs.min(read)
        } else {
            read
        }
        .clamp(lo, hi);
    }
    c
}

/// The search's start and the slave's increment noise when nothing is declared (what
/// `calibrate`, `diagnose` and `montecarlo --blind` learn from).
pub fn start_from_nothing(rec: &Recording) -> (CalibConfig, Result<IncrementNoise, String>) {
    let inc = increments::increment_noise(rec, 200_000);
    (default_start(rec, inc.as_ref().ok()), inc)
}

/// Learns the model of `rec` starting from `start` (see the module doc).
pub fn learn(
    rec: &Recording,
    start: &CalibConfig,
    start_origin: &str,
    inc: Option<IncrementNoise>,
    opts: &LearnOptions,
) -> Result<Learned, String> {
    let clock = std::time::Instant::now();
    // The mounting first: the filter's misalignment states are small errors about it.
    let mut start = start.clone();
    let mounting = start.mounting_estimate_rad.is_none().then(|| {
        let found = coarse_mounting(rec, MOUNTING_WINDOW_S);
        if let Ok(m) = &found {
            m.start_learning(&mut start);
        }
        found
    });
    let start = &start;
    let win = window(rec, opts.window_s);
    let span = match (win.master.first(), win.master.last()) {
        (Some(a), Some(b)) if b.t > a.t => b.t - a.t,
        _ => return Err("the recording has too few master messages to learn a model".into()),
    };
    let mut model = ModelParams::from_config(start);
    model.velocity_floor_mps = params::velocity_noise_floor(rec.master.iter().map(|m| m.v_n_mps));
    let mut s = Search::new(&win, model)?;
    let neg2ll_start = s.current.total;
    let m = start.matching_flags();
    // A random walk that would move a state by its prior σ over the window.
    let per_window = 1.0 / span.sqrt();
    for sweep in 0..opts.sweeps.max(1) {
        let h = std::f64::consts::LN_2 / (1u32 << sweep.min(8)) as f64;
        if sweep > 0 {
            // The angle random walk, where the increments give only an upper bound (a
            // band with vibration peaks, or one the flexure's rate fills: neither
            // accumulates into attitude): the likelihood may lower it, and keeps what it
            // resolves. First in the second sweep: the flexure is known by then, and
            // every quantity after it (the channel noise, the master's errors) is sized
            // against it. Where the increments' band fits white plus red, their floor
            // is the angle random walk and stays: searched there too (blind Monte Carlo,
            // 50 × 600 s) the likelihood took it 3–8× below the draw on five seeds whose
            // matching noise sat at its floor, and the mean NEES from 10.89 to 11.23. On
            // the measured vehicle recording the bound (0.98 °/√h) held the attitude NIS
            // at 0.10–0.28 (`docs/model-learning.md`, session 7). Searched again at the
            // end, on the whole recording (below).
            search_arw_under_bound(&mut s, inc.as_ref(), h);
        }
        s.match_noise(&win, NOISE_ITERATIONS);
        // What of the rate matching's noise the lever arm carries into the velocity
        // (the master's own rate noise), from the ladder that includes none: on a
        // noiseless master the rate matching's noise is the slave's side (model error),
        // and carried by a 26 m arm it held the velocity NIS at 0.13–0.69 (blind seed 14,
        // measured with the noise floors at the f32 resolution; docs/model-learning.md).
        if m.velocity && m.angular_rate {
            s.shrinking(Param::LeverArmRateNoise, h);
        }
        // The master's smooth errors, jointly with the white noise they would otherwise
        // be taken for (a smooth master drives the white noise to its floor and drags
        // the misalignment and biases); absent unless the likelihood wants them.
        if m.attitude {
            s.vanishing(Param::MasterAttitudeError, MASTER_ATTITUDE_SCALE_RAD, h);
        }
        if m.velocity {
            s.vanishing(Param::MasterVelocityError, MASTER_VELOCITY_SCALE_MPS, h);
        }
        let smooth_master = [Param::MasterAttitudeError, Param::MasterVelocityError]
            .iter()
            .any(|&p| s.model.get(p) > 0.0);
        if smooth_master {
            s.line(&[Param::MasterErrorCorrelation], h);
        }
        s.identify_flexure();
        // The sensor's grade (with the flexure known: a wrong flexure model makes any
        // prior look too narrow): decades first, then octaves.
        for p in [
            Param::InitialGyroBias,
            Param::InitialAccelBias,
            Param::InitialMisalignment,
        ] {
            if sweep == 0 {
                s.line(&[p], std::f64::consts::LN_10);
            }
            s.line(&[p], h);
        }
        if sweep == 0 {
            continue;
        }
        // The velocity random walk hides under the master's velocity noise: kept only
        // where the likelihood resolves it, else the start (bounded by the increments).
        let vrw_start = s.model.get(Param::AccelVrw);
        s.line(&[Param::AccelVrw], h);
        s.keep_only_if_resolved(Param::AccelVrw, vrw_start, IDENTIFIABLE_RELATIVE_SIGMA);
        s.vanishing(
            Param::GyroBiasRw,
            start.initial_gyro_bias_radps * per_window,
            h,
        );
        s.vanishing(
            Param::AccelBiasRw,
            start.initial_accel_bias_mps2 * per_window,
            h,
        );
        s.vanishing(
            Param::MisalignmentRw,
            start.initial_misalignment_rad * per_window,
            h,
        );
    }
    let neg2ll_learned = s.current.total;
    // On the whole recording the calibration will run on: the master's smooth error
    // again, then the channel noise matched once more (the search's record and count
    // carried over).
    let mut whole = Search::new(rec, s.model)?;
    whole.values = s.values;
    whole.evaluations += s.evaluations;
    if rec.master.len() > win.master.len() {
        refine_smooth_master(&mut whole, std::f64::consts::LN_2 / 2.0);
    }
    whole.match_noise(rec, NOISE_ITERATIONS);
    // The angle random walk once more where it is only bounded, against the rate noise
    // just matched: the rate matching's noise holds the flexure's rate diffusion (the
    // engine's, since session 13) beside the gyro's and the matched part at its floor,
    // so what the likelihood wants of the ARW moves with the last match. Blind draw 25
    // (600 s): the window's search left it at 3.15e-7 (drawn 1.86e-7), and the final
    // model preferred half that by 471 in −2 ln L (`docs/model-learning.md`, session 14).
    if search_arw_under_bound(&mut whole, inc.as_ref(), std::f64::consts::LN_2 / 2.0) {
        whole.match_noise(rec, NOISE_ITERATIONS);
    }
    let learned_config = whole.model.config();
    let (h_start, h_learned) = rayon::join(
        || holdout(rec, start, opts.holdout_fraction),
        || holdout(rec, &learned_config, opts.holdout_fraction),
    );
    let holdout = HoldoutComparison {
        start: h_start?,
        learned: h_learned?,
    };
    let adopted = holdout.learned.neg2ll <= holdout.start.neg2ll;
    Ok(Learned {
        start_origin: start_origin.to_string(),
        start: start.clone(),
        config: if adopted {
            learned_config.clone()
        } else {
            start.clone()
        },
        learned_config,
        adopted,
        values: whole.values,
        increments: inc,
        mounting,
        window_s: span,
        neg2ll_start,
        neg2ll_learned,
        log_likelihood_gain: (neg2ll_start - neg2ll_learned) / 2.0,
        holdout,
        evaluations: whole.evaluations,
        seconds: clock.elapsed().as_secs_f64(),
    })
}

/// The learned quantities that compete with an added effect for the same residuals,
/// learned again with that effect in the layout (`cfg` carries it). Learned without the
/// effect, they take its signature: a 0.5 m lever-arm error on blind draw 102 (white
/// master, 5 mm/s) was learned as a smooth master velocity error of 0.21 m/s (τ 1 920 s),
/// against which the lever arm grew the structure's size and was rejected
/// (`docs/diagnosis.md`, "Session 15").
///
/// Learned again: the master's smooth errors, each tried against zero and smaller sizes
/// (two passes), and their correlation time; then the white noise of the channels whose
/// smooth error moved (velocity, attitude). Nothing else: the slave's noise and the
/// flexure are the sensor's and the hull's, which an effect does not replace, and the
/// rate noise, matched again, moved where nothing competes (blind lever arm 109: y
/// 4.0e-5 → 1.1e-5 rad/s), after which the structure's size, measured on innovations
/// whitened by it, was no longer comparable with the model's (0.567 → 0.597, the lever
/// arm rejected).
///
/// The search starts from the values of `learned` (the model learned without any
/// effect), so that a model that dropped an effect finds its smooth errors again.
/// `None` when `learned` carries no smooth master error (nothing competes).
pub fn refit_competing(
    rec: &Recording,
    cfg: &CalibConfig,
    learned: &CalibConfig,
) -> Result<Option<Refit>, String> {
    let from = ModelParams::from_config(learned);
    let competing: Vec<Param> = [Param::MasterAttitudeError, Param::MasterVelocityError]
        .into_iter()
        .filter(|&p| from.get(p) > 0.0)
        .collect();
    if competing.is_empty() {
        return Ok(None);
    }
    let clock = std::time::Instant::now();
    let mut model = ModelParams::from_config(cfg);
    // A smooth error the layout no longer carries comes back only where the layout has
    // room for its block (`MAX_EFFECTS`): PSINS, round 3, the delay and the lever arm
    // in, the attitude error dropped by round 2's refit.
    let mut blocks = cfg.effects.len();
    for &p in &competing {
        if model.get(p) == 0.0 {
            if blocks >= flexcal_core::augment::MAX_EFFECTS {
                continue;
            }
            blocks += 1;
        }
        model.set(p, from.get(p));
    }
    model.set(
        Param::MasterErrorCorrelation,
        from.get(Param::MasterErrorCorrelation),
    );
    model.velocity_floor_mps = params::velocity_noise_floor(rec.master.iter().map(|m| m.v_n_mps));
    let mut s = Search::new(rec, model)?;
    let h = std::f64::consts::LN_2 / 2.0;
    // Twice: each was shrunk with the other still at its learned size (blind lever arm
    // 101: the attitude error, tried first, kept 1.1 of 1.5 mrad while the velocity error
    // of 0.30 m/s was still in; the velocity error then went to zero).
    for _ in 0..2 {
        for &p in &competing {
            s.shrinking(p, h);
        }
    }
    if competing.iter().any(|&p| s.model.get(p) > 0.0) {
        s.line(&[Param::MasterErrorCorrelation], h);
    }
    // The white noise of the channels whose smooth error moved, matched again: learned
    // beside a smooth error, it was the smaller share (blind lever arm 107: both errors
    // went to zero, the velocity and attitude noise stayed, and `lever_arm_coupling` and
    // `gyro_scale_factor` took what was left, two spurious effects).
    let moved = |p: Param| s.model.get(p) != from.get(p);
    let channels = [
        moved(Param::MasterVelocityError),
        moved(Param::MasterAttitudeError),
        false,
    ];
    if channels.iter().any(|&c| c) {
        s.match_noise_of(rec, NOISE_ITERATIONS, channels);
    }
    Ok(Some(Refit {
        cfg: s.model.config(),
        values: s.values,
        evaluations: s.evaluations,
        seconds: clock.elapsed().as_secs_f64(),
    }))
}

/// The whole model learned again from the search's own start (`from.start`) with the
/// effects of `layout` (adopted by the diagnosis) in its layout, and its delay where
/// the layout sets one. Learned with an effect in the data and not in the layout, the
/// model takes the effect's signature into quantities no refit of the smooth master
/// errors undoes: blind lever arm 108 (noiseless master) learned the 0.5 m arm as a
/// master velocity error of 0.091 m/s (τ 1 627 s), an accelerometer bias random walk of
/// 1.2e-2 and a flexure about z of 1.75 mrad against a drawn 0.49, and read the arm's z
/// 4.1σ off; blind 103's learned model predicted the held-out part so badly that the
/// start was kept (`docs/diagnosis.md`, "Session 17").
///
/// The smooth master errors are the learner's own blocks: left out of the start, learned
/// again (they are in `layout` when the first model carried them).
///
/// The master's delay: where `layout` carries a clock effect, learned from the delay it
/// starts at; else from the learning's own (`from.start`: the delay found before the
/// filter compensated, or none), as the first model was learned, and the model returned
/// (`learned_config`, `config`) then carries `layout`'s delay, so that it is judged in
/// the search's terms (a model learned with a delay compensated is searched without it,
/// `cmd::diagnose`). Learned without the compensation, the two-effect draw 103's
/// 49.6 ms delay would go into the quantities the arm is judged with.
pub fn relearn_with(
    rec: &Recording,
    from: &Learned,
    layout: &CalibConfig,
) -> Result<Learned, String> {
    let mut l = learn(
        rec,
        &relearn_start(from, layout),
        &from.start_origin,
        from.increments,
        &LearnOptions::default(),
    )?;
    carry_layout_delay(&mut l, layout);
    Ok(l)
}

/// The model [`relearn_with`] learns from for `layout`: the learning's start with
/// `layout`'s effects but the master's errors, and `layout`'s delay where it carries a
/// clock effect. The learning depends on nothing else of `layout`: two layouts with the
/// same start are learned alike (`diagnose` learns each once).
pub fn relearn_start(from: &Learned, layout: &CalibConfig) -> CalibConfig {
    let mut start = from.start.clone();
    start.effects = layout
        .effects
        .iter()
        .filter(|e| !Effect::MASTER_ERRORS.iter().any(|m| m.name() == e.as_str()))
        .cloned()
        .collect();
    if layout.clock_effect().is_some() {
        start.initial_delay_s = layout.initial_delay_s;
    }
    start
}

/// Gives a learning's models (`learned_config`, `config`) `layout`'s delay, as
/// [`relearn_with`] returns them.
pub fn carry_layout_delay(l: &mut Learned, layout: &CalibConfig) {
    l.learned_config.initial_delay_s = layout.initial_delay_s;
    l.config.initial_delay_s = layout.initial_delay_s;
}

/// What [`refit_competing`] learned again.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Refit {
    /// The model with the effect and the competing quantities learned again.
    #[serde(skip)]
    pub cfg: CalibConfig,
    /// Each quantity searched: value before (`start`) and after.
    pub values: Vec<LearnedValue>,
    /// Filter runs.
    pub evaluations: usize,
    /// Wall time (s).
    pub seconds: f64,
}

/// The angle random walk searched by the likelihood where the increments give only an
/// upper bound of it (see `learn`), kept at or under that bound and only where the
/// likelihood resolves it; whether it moved.
fn search_arw_under_bound(s: &mut Search<'_>, inc: Option<&IncrementNoise>, h: f64) -> bool {
    let Some(bound) = inc
        .filter(|i| i.gyro_arw_is_upper_bound())
        .map(IncrementNoise::gyro_arw)
    else {
        return false;
    };
    let arw_start = s.model.get(Param::GyroArw);
    s.line(&[Param::GyroArw], h);
    s.at_most(Param::GyroArw, bound);
    s.keep_only_if_resolved(Param::GyroArw, arw_start, IDENTIFIABLE_RELATIVE_SIGMA);
    s.model.get(Param::GyroArw) != arw_start
}

/// The master's smooth errors searched once more, on the whole recording when it is
/// longer than the window (on the window alone it would only repeat the search): the window
/// (180 s) is shorter than the correlation times a master's slow error may have (the
/// blind draw goes to 200 s), and over a window shorter than τ a Gauss-Markov error is
/// seen by its diffusion `2σ²/τ` more than by σ and τ apart: blind seed 8 (600 s) learned
/// σ_att 18 µrad, σ_v 0.019 m/s, τ 59 s on the window against 46 µrad, 0.035 m/s, 110 s
/// drawn. First τ along that diffusion's level set (σ ∝ √τ), then each σ on its own.
fn refine_smooth_master(s: &mut Search<'_>, h: f64) {
    let carried: Vec<Param> = [Param::MasterAttitudeError, Param::MasterVelocityError]
        .into_iter()
        .filter(|&p| s.model.get(p) > 0.0)
        .collect();
    if carried.is_empty() {
        return;
    }
    let mut direction = vec![(Param::MasterErrorCorrelation, 1.0)];
    direction.extend(carried.iter().map(|&p| (p, 0.5)));
    s.line_along(&direction, h);
    for p in carried {
        s.line(&[p], h);
    }
}

/// `model.toml`: the configuration to calibrate with, loadable with `--config` and
/// runnable on the board unchanged, headed by what was learned.
pub fn model_toml(l: &Learned) -> Result<String, String> {
    let body = toml::to_string(&l.config).map_err(|e| e.to_string())?;
    let mut head =
        String::from("# Model learned from the recording by flexcal (docs/model-learning.md).\n");
    head += &format!(
        "# Start: {}. Learned model {} (held-out −2 ln L {:.1} learned vs {:.1} start).\n",
        l.start_origin,
        if l.adopted {
            "adopted"
        } else {
            "NOT adopted: the start predicts the held-out part better"
        },
        l.holdout.learned.neg2ll,
        l.holdout.start.neg2ll
    );
    for v in &l.values {
        let sigma = v.sigma.map(|s| format!(" ± {s:.3e}")).unwrap_or_default();
        head += &format!(
            "#   {} = {:.4e}{sigma} (start {:.4e}, log-likelihood gain {:.1})\n",
            v.name, v.value, v.start, v.log_likelihood_gain
        );
    }
    Ok(head + &body)
}
