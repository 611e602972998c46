//! The steps before the filter: the master's attitude steps found and taken out
//! (`calib::master_steps`), the two clocks aligned from the body rates
//! (`calib::clock`), then, on a model learned from the recording, the mounting found on
//! the aligned data (`calib::mounting`). The clocks and the mounting are found on the
//! master with its steps taken out: a 10° step inside one of their blocks is that
//! block's rotation wrong by 10°.
//!
//! The engine follows a master delay itself (`time_delay`, `docs/diagnosis.md`) only
//! within its reach: a master late by τ is matched from the slave's alignment buffer
//! (`ALIGN_DEPTH` IMU samples, and at most `MAX_DELAY_S`), a master early by τ waits in
//! the master queue (`PENDING_DEPTH` messages, which at 100 Hz hold 70 ms: a −0.25 s
//! starting delay dropped 5993 of 6001 messages of a 60 s recording, all it was given
//! but the 8 left queued). So an offset found beyond that reach is removed before the
//! filter — every master time tag moved by it (`CalibConfig::master_clock_offset_s`) —
//! and what is left for the filter's delay is the coarse estimate's error, a few
//! milliseconds. An offset within the reach is left to the model (the diagnosis's
//! `time_delay` candidate measures it to a fraction of a millisecond) and only reported.

use super::clock::SlaveAngles;
use super::clock::{clock_offset, ClockOffset, ClockRefusal};
use super::config::CalibConfig;
use super::master_steps::{
    find_steps, find_steps_with_slave, without_steps, FoundStep, StepSearch,
};
use super::mounting::{coarse_mounting_after_clock, CoarseMounting};
use crate::recording::{open_recording, MasterMsg, Recording};
use flexcal_core::engine::{ALIGN_DEPTH, MAX_DELAY_S, PENDING_DEPTH};
use serde_json::{json, Value};
use std::path::Path;

/// Half-width of the clock search (s).
pub const CLOCK_SEARCH_S: f64 = 1.0;
/// Master time the clocks are compared over, from the first message (s).
pub const CLOCK_WINDOW_S: f64 = 120.0;
/// The mounting's window (s): the learner's own (`learn`), so a learned model is found
/// from the same data whether or not the clocks were moved.
pub const MOUNTING_WINDOW_S: f64 = 60.0;

/// Where the clock alignment came from.
#[derive(Clone, Debug)]
pub enum ClockSource {
    /// `master_clock_offset_s` in the configuration: not searched.
    Configured,
    /// Found from the body rates, or not, with the reason.
    Searched(Result<ClockOffset, ClockRefusal>),
}

/// The clock step: what was found, the engine's reach, what was applied.
#[derive(Clone, Debug)]
pub struct ClockStep {
    /// Configured or searched.
    pub source: ClockSource,
    /// The largest offset the engine follows as a delay on this recording: master
    /// early, master late (s).
    pub reach_s: [f64; 2],
    /// The shift applied to the master's time tags (s; 0 when none).
    pub applied_s: f64,
}

/// Where the master's attitude steps came from.
#[derive(Clone, Debug)]
pub enum StepsSource {
    /// `master_attitude_steps` in the configuration: not searched.
    Configured(usize),
    /// Searched in the master's attitude against its rate, or not, with the reason.
    Searched(Result<StepSearch, String>),
}

/// Everything done before the filter.
#[derive(Clone, Debug)]
pub struct PreFilter {
    /// The master's attitude steps.
    pub steps: StepsSource,
    /// The clocks.
    pub clock: ClockStep,
    /// The mounting found on the aligned data, when this step found it (a learned model
    /// after a clock shift; otherwise the learner finds it itself, or the configuration
    /// gives it).
    pub mounting: Option<Result<CoarseMounting, String>>,
}

/// The largest master delay the engine follows on a recording of these rates (s):
/// `[early, late]`. Early: the queue's `PENDING_DEPTH − 1` master periods; late: the
/// alignment buffer's `ALIGN_DEPTH − 1` IMU periods; both at most `MAX_DELAY_S`.
pub fn delay_reach(master_rate_hz: f64, imu_rate_hz: f64) -> [f64; 2] {
    let early = (PENDING_DEPTH as f64 - 1.0) / master_rate_hz;
    let late = (ALIGN_DEPTH as f64 - 1.0) / imu_rate_hz;
    [early.min(MAX_DELAY_S), late.min(MAX_DELAY_S)]
}

/// The clock step on `rec` for `cfg`: searched unless configured, applied beyond the
/// engine's reach.
pub fn clock_step(rec: &Recording, cfg: &CalibConfig) -> ClockStep {
    let reach_s = delay_reach(rec.meta.master_rate_hz, rec.meta.slave_rate_hz);
    if let Some(v) = cfg.master_clock_offset_s {
        return ClockStep {
            source: ClockSource::Configured,
            reach_s,
            applied_s: v,
        };
    }
    let from = rec.master.first().map_or(0.0, |m| m.t);
    let found = clock_offset(rec, CLOCK_SEARCH_S, from, from + CLOCK_WINDOW_S);
    let applied_s = match &found {
        Ok(c) if c.offset_s < -reach_s[0] || c.offset_s > reach_s[1] => c.offset_s,
        _ => 0.0,
    };
    ClockStep {
        source: ClockSource::Searched(found),
        reach_s,
        applied_s,
    }
}

/// The master's attitude steps, searched unless configured: against the master's own
/// rate in `master` (all its messages) when it gives one, else against the slave's gyro
/// in `rec` (the whole recording, or a window of it when it is streamed); the steps
/// found are written into `cfg` (`master_attitude_steps`), so every run of the filter
/// takes them out.
pub fn steps_step(
    master: impl IntoIterator<Item = Result<MasterMsg, String>>,
    master_has_rate: bool,
    rec: &Recording,
    cfg: &mut CalibConfig,
) -> StepsSource {
    if let Some(s) = &cfg.master_attitude_steps {
        return StepsSource::Configured(s.len());
    }
    let found = if master_has_rate {
        find_steps(master)
    } else {
        steps_from_slave(rec, cfg)
    };
    if let Ok(f) = &found {
        if !f.steps.is_empty() {
            cfg.master_attitude_steps = Some(f.steps.iter().map(FoundStep::as_config).collect());
        }
    }
    StepsSource::Searched(found)
}

/// The steps of a master without rate, against the slave's gyro: the clocks and the
/// mounting first (configured, else found on the recording as it is), then the steps;
/// then, when steps were found and the clocks or the mounting were not configured, both
/// found again on the master with those steps taken out, and the steps searched again
/// with them. A 10° step spoils the clock's and the mounting's blocks it falls in (blind
/// seed 3: the steps came out 0.35° off, the mounting's error times each interval's
/// rotation adding up in the levels the steps are measured between).
fn steps_from_slave(rec: &Recording, cfg: &CalibConfig) -> Result<StepSearch, String> {
    let slave = SlaveAngles::new(rec);
    let (tau, mounting) = slave_alignment(rec, cfg)?;
    let first = find_steps_with_slave(&rec.master, &slave, mounting, tau)?;
    let configured = cfg.master_clock_offset_s.is_some() && cfg.mounting_estimate_rad.is_some();
    if first.steps.is_empty() || configured {
        return Ok(first);
    }
    let mut without = cfg.clone();
    without.master_attitude_steps = Some(first.steps.iter().map(FoundStep::as_config).collect());
    let (tau, mounting) = slave_alignment(
        without_steps(rec, without.master_attitude_steps.as_deref()).as_ref(),
        cfg,
    )?;
    find_steps_with_slave(&rec.master, &slave, mounting, tau)
}

/// The clock offset (s) and the mounting (rad) the slave's gyro is compared with:
/// configured, else found on `rec`.
fn slave_alignment(rec: &Recording, cfg: &CalibConfig) -> Result<(f64, [f64; 3]), String> {
    let from = rec.master.first().map_or(0.0, |m| m.t);
    let tau = match cfg.master_clock_offset_s {
        Some(v) => v,
        None => clock_offset(rec, CLOCK_SEARCH_S, from, from + CLOCK_WINDOW_S)
            .map(|c| c.offset_s)
            .map_err(|e| {
                format!("the master gives no rate and the clocks are not aligned, so its attitude steps are not searched: {e}")
            })?,
    };
    let mounting = match cfg.mounting_estimate_rad {
        Some(m) => m,
        None => coarse_mounting_after_clock(rec, MOUNTING_WINDOW_S, tau)
            .map(|m| m.rotation_vector_rad)
            .map_err(|e| {
                format!("the master gives no rate and the mounting is not found, so its attitude steps are not searched: {e}")
            })?,
    };
    Ok((tau, mounting))
}

/// The steps before the filter on the whole recording `rec`: the master's attitude
/// steps, the clocks, and the mounting when none is configured ([`mounting_step`]).
/// Writes the steps, the clock shift (and that mounting) into `cfg`.
pub fn prepare(rec: &Recording, cfg: &mut CalibConfig, learning: bool) -> PreFilter {
    let steps = steps_step(
        rec.master.iter().cloned().map(Ok),
        rec.master_has_rate(),
        rec,
        cfg,
    );
    prepare_after_steps(rec, cfg, learning, steps)
}

/// [`prepare`] once the steps are known (`steps`, already in `cfg`): `rec` may then be a
/// window of the recording, the steps searched on the whole of it.
pub fn prepare_after_steps(
    rec: &Recording,
    cfg: &mut CalibConfig,
    learning: bool,
    steps: StepsSource,
) -> PreFilter {
    let rec = without_steps(rec, cfg.master_attitude_steps.as_deref());
    let rec = rec.as_ref();
    let took_out = cfg
        .master_attitude_steps
        .as_ref()
        .is_some_and(|s| !s.is_empty());
    let clock = clock_step(rec, cfg);
    if clock.applied_s != 0.0 {
        cfg.master_clock_offset_s = Some(clock.applied_s);
    }
    let mounting = mounting_step(rec, cfg, learning, clock.applied_s != 0.0 || took_out);
    PreFilter {
        steps,
        clock,
        mounting,
    }
}

/// The mounting found on the aligned data (`rec` with its steps out, the clocks moved by
/// `cfg.master_clock_offset_s`) and written into `cfg` as `mounting_estimate_rad`, when
/// the configuration names none. A model to be learned (`learning`) takes it here only
/// when the clocks were moved or steps taken out (`moved`); otherwise the learner finds
/// it itself on the recording as it is, the same data; either way with the misalignment
/// prior from the fit (`CoarseMounting::start_learning`). A declared configuration takes
/// it always, its prior as declared: its misalignment σ then describes the error about
/// the mounting found, a few hundredths to two tenths of a degree, instead of about
/// zero, where a mounting of a few degrees is left to the filter's linearization (blind
/// seed 104's model declared, 2.1° with σ 1°, 120 s: NEES 303 from zero, 9.7 from the
/// mounting found; `scripts/declared-mounting-table.sh`, `docs/diagnosis.md`).
fn mounting_step(
    rec: &Recording,
    cfg: &mut CalibConfig,
    learning: bool,
    moved: bool,
) -> Option<Result<CoarseMounting, String>> {
    if cfg.mounting_estimate_rad.is_some() || (learning && !moved) {
        return None;
    }
    let found = coarse_mounting_after_clock(
        rec,
        MOUNTING_WINDOW_S,
        cfg.master_clock_offset_s.unwrap_or(0.0),
    );
    match &found {
        Ok(m) if learning => m.start_learning(cfg),
        Ok(m) => cfg.mounting_estimate_rad = Some(m.rotation_vector_rad),
        Err(_) => {}
    }
    Some(found)
}

/// The master messages of the recording in `dir`, read one at a time (for the step
/// search over a recording that is streamed).
pub fn master_messages(
    dir: &Path,
) -> Result<impl Iterator<Item = Result<MasterMsg, String>>, String> {
    let s = open_recording(dir).map_err(|e| e.to_string())?;
    Ok(s.master.map(|m| m.map_err(|e| e.to_string())))
}

/// A master delay found before the filter and within the engine's reach, for the
/// learner to compensate (`initial_delay_s`) while it learns the model: `τ` when
/// `|τ| ≥ DELAY_TO_LEARN_WITH_SIGMAS σ`, else none. A delay the model is learned without
/// is taken by the flexure and the master's error models: blind seed 102 (300 s, a 50 ms
/// delay) learned a flexure 10–20× its drawn size and a 1.6 mrad smooth master attitude
/// error, after which `diagnose` estimated the delay at 10.5 ± 0.15 ms
/// (`docs/model-learning.md`).
pub fn delay_to_learn_with(p: &PreFilter) -> Option<f64> {
    match &p.clock.source {
        ClockSource::Searched(Ok(f))
            if p.clock.applied_s == 0.0
                && f.offset_s.abs() >= DELAY_TO_LEARN_WITH_SIGMAS * f.sigma_s =>
        {
            Some(f.offset_s)
        }
        _ => None,
    }
}

/// How many of its σ a delay found before the filter must be for the learner to
/// compensate it: where it may be zero (a clean recording) the learner is left alone.
pub const DELAY_TO_LEARN_WITH_SIGMAS: f64 = 3.0;

/// The first `seconds` of the recording in `dir` (slave samples and master messages
/// up to that long after the slave's first line; no truth): what the clock step needs
/// when the run itself streams the recording.
pub fn read_window(dir: &Path, seconds: f64) -> Result<Recording, String> {
    let mut s = open_recording(dir).map_err(|e| e.to_string())?;
    let t0 = s.slave.t0();
    let end = t0 + seconds;
    let mut imu = Vec::new();
    for x in s.slave.by_ref() {
        let x = x.map_err(|e| e.to_string())?;
        let past = x.t > end;
        imu.push(x);
        if past {
            break;
        }
    }
    let mut master = Vec::new();
    for m in s.master.by_ref() {
        let m = m.map_err(|e| e.to_string())?;
        if m.t > end {
            break;
        }
        master.push(m);
    }
    Ok(Recording {
        meta: s.meta,
        imu_t0: t0,
        imu,
        master,
        truth: None,
    })
}

impl PreFilter {
    /// The lines `calibrate` and `diagnose` print about it.
    pub fn lines(&self) -> Vec<String> {
        let c = &self.clock;
        let reach = format!(
            "the engine follows −{:.0}…+{:.0} ms as a delay",
            1e3 * c.reach_s[0],
            1e3 * c.reach_s[1]
        );
        let mut out = self.step_lines();
        out.push(match &c.source {
            ClockSource::Configured => format!(
                "clock: the configuration moves the master's time tags by {:+.4} s (master_clock_offset_s)",
                -c.applied_s
            ),
            ClockSource::Searched(Ok(f)) if c.applied_s != 0.0 => format!(
                "clock: the master's time tags are {:+.4} ± {:.4} s late on the slave's (body rates correlate {:.4} after the best rotation, {} blocks of {:.2} s): moved by {:+.4} s before the filter ({reach})",
                f.offset_s, f.sigma_s, f.correlation, f.blocks, f.block_s, -c.applied_s
            ),
            ClockSource::Searched(Ok(f)) => format!(
                "clock: the master's time tags are {:+.4} ± {:.4} s late on the slave's (correlation {:.4}): within reach, left to the model ({reach})",
                f.offset_s, f.sigma_s, f.correlation
            ),
            ClockSource::Searched(Err(e)) => {
                format!("clock: not aligned before the filter, the tags are used as recorded: {e}")
            }
        });
        match &self.mounting {
            Some(Ok(m)) => {
                let d = m.rotation_vector_rad.map(f64::to_degrees);
                out.push(format!(
                    "mounting on the aligned data: [{:.3}, {:.3}, {:.3}]° (rotation vector, {} blocks)",
                    d[0], d[1], d[2], m.blocks
                ));
            }
            Some(Err(e)) => out.push(format!(
                "mounting: not found on the aligned data (the filter starts from zero): {e}"
            )),
            None => {}
        }
        out
    }

    /// The lines about the master's attitude steps: one, then one per step found.
    fn step_lines(&self) -> Vec<String> {
        const AXES: [&str; 3] = ["east", "north", "up"];
        match &self.steps {
            StepsSource::Configured(n) => vec![format!(
                "master attitude steps: {n} taken out as configured (master_attitude_steps), none searched"
            )],
            StepsSource::Searched(Err(e)) => vec![format!("master attitude steps: {e}")],
            StepsSource::Searched(Ok(f)) => {
                let noise = f.noise_rad.map(f64::to_degrees);
                let thr = f.threshold_rad.map(f64::to_degrees);
                let mut out = vec![format!(
                    "master attitude steps: {} found in {} intervals ({:.1}–{:.1} s) and taken out before the filter (the attitude the {} does not explain; residual σ E/N/U [{:.4}, {:.4}, {:.4}]°, threshold [{:.3}, {:.3}, {:.3}]°{})",
                    f.steps.len(),
                    f.intervals,
                    f.span_s[0],
                    f.span_s[1],
                    if f.source == "master rate" { "master's own rate" } else { "slave's gyro (rotated by the mounting)" },
                    noise[0],
                    noise[1],
                    noise[2],
                    thr[0],
                    thr[1],
                    thr[2],
                    if f.untested_gaps > 0 {
                        format!("; {} gaps not tested", f.untested_gaps)
                    } else {
                        String::new()
                    }
                )];
                for s in &f.steps {
                    let r = s.rotation_rad.map(f64::to_degrees);
                    let axes: Vec<&str> = s.axes.iter().filter_map(|&k| AXES.get(k).copied()).collect();
                    out.push(format!(
                        "  step at t = {:.3} s: {:.3}° [{:+.3}, {:+.3}, {:+.3}]° ENU, attitude channel {}",
                        s.t_s,
                        s.size_deg,
                        r[0],
                        r[1],
                        r[2],
                        axes.join(", ")
                    ));
                }
                out
            }
        }
    }

    /// The `pre_filter` object of `summary.json`.
    pub fn json(&self) -> Value {
        let c = &self.clock;
        let clock = match &c.source {
            ClockSource::Configured => json!({"source": "configuration"}),
            ClockSource::Searched(Ok(f)) => json!({"source": "body rates", "found": f}),
            ClockSource::Searched(Err(e)) => {
                json!({"source": "body rates", "refused": e.reason, "correlation": e.correlation})
            }
        };
        let mut clock = clock;
        if let Some(o) = clock.as_object_mut() {
            o.insert("applied_shift_s".into(), json!(0.0 - c.applied_s));
            o.insert("master_clock_offset_s".into(), json!(c.applied_s));
            o.insert(
                "delay_reach_s".into(),
                json!({"master_early": c.reach_s[0], "master_late": c.reach_s[1]}),
            );
        }
        let mounting = match &self.mounting {
            Some(Ok(m)) => json!(m),
            Some(Err(e)) => json!({"refused": e}),
            None => Value::Null,
        };
        let steps = match &self.steps {
            StepsSource::Configured(n) => json!({"source": "configuration", "taken_out": n}),
            StepsSource::Searched(Ok(f)) => json!({"source": f.source, "found": f}),
            StepsSource::Searched(Err(e)) => json!({"refused": e}),
        };
        json!({"master_attitude_steps": steps, "clock": clock, "mounting": mounting})
    }
}
