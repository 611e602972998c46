//! Steps of the master's attitude, found before the filter and taken out of it.
//!
//! A master that is itself a consumer-grade attitude filter corrects itself in steps:
//! its attitude jumps by up to 10–20° at a correction while its body rate does not. A
//! step is therefore an attitude change of the master that its own rate does not
//! explain. Between consecutive messages `a`, `b` the master's attitude is predicted
//! from `a` with its rate (`ω_nb = ω_ib − Cᵀ(ω_ie + ω_en)`, the two-sample rotation
//! `½(ω_a + ω_b)Δt + (ω_a × ω_b)Δt²/12`), and the residual
//! `r = Log(C_b (C_a Exp(φ))ᵀ)` is the jump of the master's output in the navigation
//! frame (ENU, rad). Per ENU axis, the residuals' spread is measured robustly (1.4826 ×
//! the median absolute deviation: the steps are a few intervals among thousands); an
//! interval whose residual exceeds [`STEP_SIGMAS`] of that spread, and at least
//! [`STEP_FLOOR_RAD`], on any axis holds a step, flagged on that axis (channel axis);
//! consecutive flagged intervals are one step (a correction spread over a few
//! messages), whose rotation is the composition of their residuals.
//!
//! Found steps are taken out of the master's attitude before the filter
//! ([`StepCorrection`]): every message after a step has the steps before it undone,
//! `q ← (S_k ⋯ S_1)⁻¹ q`. What is left of each step is the residual's noise (the
//! master's attitude noise of two messages and its rate noise over one interval), and
//! what the filter sees of the master's attitude error is its continuous part, which
//! the learned model's smooth master error takes. Why taking them out and not
//! down-weighting the attitude matching: `docs/diagnosis.md` (the measured table).

use super::clock::SlaveAngles;
use crate::recording::{MasterMsg, Recording};
use crate::verdict::input::median;
use flexcal_core::rotation::{quat_exp, quat_log};
use nalgebra::{UnitQuaternion, Vector3};
use serde::Serialize;

/// How many robust standard deviations of its axis a residual must exceed to be a step.
/// At 8σ a Gaussian residual passes once in 10¹⁵ tests; the margin is for the residual's
/// tails (the rate's integration error in fast motion).
pub const STEP_SIGMAS: f64 = 8.0;
/// The smallest step reported (rad, 0.05°), whatever the spread: a noiseless master's
/// residuals are the integration's rounding, and 8 of their spread is no step.
pub const STEP_FLOOR_RAD: f64 = 0.05 * std::f64::consts::PI / 180.0;
/// The time on either side of a step over which the master's mean error level is taken
/// to measure it ([`refine`], s): long enough to average the attitude noise of many
/// messages, short against a drifting error. Blind seed 6 (50 Hz, 0.035° attitude
/// noise, three 10° steps): the steps came out 0.021° off with 20 messages (0.4 s)
/// either side, and the accelerometer bias x ended 3.4σ off (the same seed without
/// steps 1.6σ).
pub const REFINE_S: f64 = 2.0;
/// Intervals longer than this many median intervals (a gap in the master's output) are
/// not tested: the rate's integration across them is not accurate enough.
pub const MAX_INTERVAL_MEDIANS: f64 = 3.0;

/// One step found in the master's attitude.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FoundStep {
    /// Time tag of the first message after the step (the master's own tags, s).
    pub t_s: f64,
    /// Time tag of the last message before it (s).
    pub after_s: f64,
    /// The jump of the master's output attitude, rotation vector, ENU (rad).
    pub rotation_rad: [f64; 3],
    /// Its size (deg).
    pub size_deg: f64,
    /// The ENU axes (0 east, 1 north, 2 up) whose residual exceeded the threshold.
    pub axes: Vec<usize>,
    /// Messages the step spans (1: between two consecutive messages).
    pub intervals: usize,
}

/// The search's outcome.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StepSearch {
    /// Intervals tested.
    pub intervals: usize,
    /// Intervals not tested (a gap in the master's output, or where the slave's samples
    /// do not cover it).
    pub untested_gaps: usize,
    /// What predicted the master's rotation: `"master rate"` or `"slave gyro"`.
    pub source: &'static str,
    /// The master's time tags searched, first and last (s).
    pub span_s: [f64; 2],
    /// Robust σ of the residual per ENU axis (rad).
    pub noise_rad: [f64; 3],
    /// The threshold per ENU axis (rad).
    pub threshold_rad: [f64; 3],
    /// The steps, in time order.
    pub steps: Vec<FoundStep>,
}

/// The master's body rate relative to the navigation frame, `ω_nb^bm` (rad/s), from
/// its inertial rate: `None` when the message carries no rate.
fn rate_nb(m: &MasterMsg, q: &UnitQuaternion<f64>) -> Option<Vector3<f64>> {
    let w_ib = Vector3::from(m.omega_ib_bm_radps?);
    Some(w_ib - q.inverse_transform_vector(&m.nav_frame_rate_n()))
}

/// One tested interval: the later message's time, the earlier one's, the residual
/// rotation (ENU, rad).
struct Residual {
    t: f64,
    after: f64,
    r: UnitQuaternion<f64>,
}

/// Whether interval `i` starts where interval `i − 1` ends (no untested gap between).
fn contiguous(res: &[Residual], i: usize) -> bool {
    match (i.checked_sub(1).and_then(|j| res.get(j)), res.get(i)) {
        (Some(a), Some(b)) => a.t == b.after,
        _ => false,
    }
}

/// The step of the flagged run `i0..=i1` (composed residual `total`) measured between
/// the master's mean error level over up to [`REFINE_S`] on either
/// side instead of between the two messages around it: the residual of one interval
/// holds the attitude noise of both its messages; the levels average it down.
/// `Exp(A) total Exp(B)`, with `A` the mean of the error after the step relative to its
/// first message (the cumulated residuals after it) and `B` the last message before
/// relative to the mean before; each side stops at another flagged interval or a gap.
fn refine(
    res: &[Residual],
    vecs: &[Vector3<f64>],
    flagged: &[Vec<usize>],
    i0: usize,
    i1: usize,
    total: UnitQuaternion<f64>,
) -> UnitQuaternion<f64> {
    let clean = |i: usize| flagged.get(i).is_some_and(|f| f.is_empty());
    // After: e_{s+j} − e_s = Σ_{i=1..j} r, j = 0.. while clean and contiguous.
    let (mut cum, mut sum, mut n) = (Vector3::zeros(), Vector3::zeros(), 1.0);
    let end = res.get(i1).map_or(f64::NAN, |x| x.t);
    for (j, v) in vecs.iter().enumerate().skip(i1 + 1) {
        let within = res.get(j).is_some_and(|x| x.t - end <= REFINE_S);
        if !(within && clean(j) && contiguous(res, j)) {
            break;
        }
        cum += v;
        sum += cum;
        n += 1.0;
    }
    let after = sum / n;
    // Before: e_{s−1} − e_{s−1−j} = Σ_{i=0..j−1} r_{s−1−i}.
    let (mut cum, mut sum, mut n) = (Vector3::zeros(), Vector3::zeros(), 1.0);
    let start = res.get(i0).map_or(f64::NAN, |x| x.after);
    let mut j = i0;
    while j > 0 && clean(j - 1) && contiguous(res, j) {
        j -= 1;
        let (Some(v), Some(x)) = (vecs.get(j), res.get(j)) else {
            break;
        };
        if start - x.after > REFINE_S {
            break;
        }
        cum += v;
        sum += cum;
        n += 1.0;
    }
    let before = sum / n;
    quat_exp(&after) * total * quat_exp(&before)
}

/// Finds the steps of the master's attitude in `master` (time order, the master's own
/// tags) against its own rate, reading it once and keeping one residual per message.
/// Refused, saying why, when a message has no rate or there are too few messages; an
/// error of the source ends the search with it.
pub fn find_steps(
    master: impl IntoIterator<Item = Result<MasterMsg, String>>,
) -> Result<StepSearch, String> {
    search(master, "master rate", &mut |a, b, qa, qb| {
        let (Some(wa), Some(wb)) = (rate_nb(a, qa), rate_nb(b, qb)) else {
            return Err(format!(
                "the master message at t = {} s gives no angular rate: its attitude steps are not searched against its own rate",
                if a.omega_ib_bm_radps.is_none() { a.t } else { b.t }
            ));
        };
        let dt = b.t - a.t;
        Ok(Some(
            (wa + wb) * (0.5 * dt) + wa.cross(&wb) * (dt * dt / 12.0),
        ))
    })
}

/// [`find_steps`] for a master without rate: its rotation between two messages
/// predicted by the slave's gyro over the same interval on the slave's clock
/// (`clock_offset_s`, the master's tags late on the slave's), rotated into the master's
/// body by the mounting `C_bs^bm = Exp(mounting_rad)`, less the navigation frame's turn
/// (`Cᵀ(ω_ie + ω_en) Δt`). The slave's gyro bias (a few hundred °/h on a MEMS unit: a
/// few thousandths of a degree per interval) and the flexure's rate are in the
/// residual's spread; intervals the slave's samples do not cover are not tested.
pub fn find_steps_with_slave(
    master: &[MasterMsg],
    slave: &SlaveAngles,
    mounting_rad: [f64; 3],
    clock_offset_s: f64,
) -> Result<StepSearch, String> {
    let c = quat_exp(&Vector3::from(mounting_rad));
    search(
        master.iter().cloned().map(Ok),
        "slave gyro",
        &mut |a, b, qa, _| {
            let Some(phi_s) = slave.rotation(a.t - clock_offset_s, b.t - clock_offset_s) else {
                return Ok(None);
            };
            Ok(Some(
                c * phi_s - qa.inverse_transform_vector(&a.nav_frame_rate_n()) * (b.t - a.t),
            ))
        },
    )
}

/// The master's body rotation from message `a` to `b` (rad, master body, relative to
/// the navigation frame) as a source predicts it: `None` where it cannot (the interval
/// is then not tested), an error where it never will.
type Predict<'a> = dyn FnMut(
        &MasterMsg,
        &MasterMsg,
        &UnitQuaternion<f64>,
        &UnitQuaternion<f64>,
    ) -> Result<Option<Vector3<f64>>, String>
    + 'a;

/// The search of [`find_steps`] with the master's rotation between messages from
/// `predict`.
fn search(
    master: impl IntoIterator<Item = Result<MasterMsg, String>>,
    source: &'static str,
    predict: &mut Predict<'_>,
) -> Result<StepSearch, String> {
    let mut all = Vec::new();
    let mut dts = Vec::new();
    let mut unpredicted = 0;
    let mut prev: Option<(MasterMsg, UnitQuaternion<f64>)> = None;
    for m in master {
        let m = m?;
        let q = m.attitude();
        if let Some((a, qa)) = &prev {
            let dt = m.t - a.t;
            match predict(a, &m, qa, &q)? {
                Some(phi) => {
                    all.push((
                        dt,
                        Residual {
                            t: m.t,
                            after: a.t,
                            r: q * (qa * quat_exp(&phi)).inverse(),
                        },
                    ));
                    dts.push(dt);
                }
                None => unpredicted += 1,
            }
        }
        prev = Some((m, q));
    }
    let dt_median = median(dts);
    if all.len() < 20 || dt_median <= 0.0 {
        return Err(format!(
            "{} master messages are too few to search their attitude for steps",
            all.len() + 1
        ));
    }
    let max_dt = MAX_INTERVAL_MEDIANS * dt_median;
    let untested_gaps = unpredicted
        + all
            .iter()
            .filter(|(dt, _)| !(*dt > 0.0 && *dt <= max_dt))
            .count();
    let res: Vec<Residual> = all
        .into_iter()
        .filter(|(dt, _)| *dt > 0.0 && *dt <= max_dt)
        .map(|(_, r)| r)
        .collect();
    let vecs: Vec<Vector3<f64>> = res.iter().map(|x| quat_log(&x.r)).collect();
    let mut centre = [0.0; 3];
    let mut noise_rad = [0.0; 3];
    for k in 0..3 {
        centre[k] = median(vecs.iter().map(|v| v[k]).collect());
        noise_rad[k] = 1.4826 * median(vecs.iter().map(|v| (v[k] - centre[k]).abs()).collect());
    }
    let threshold_rad = noise_rad.map(|s| (STEP_SIGMAS * s).max(STEP_FLOOR_RAD));
    let flagged: Vec<Vec<usize>> = vecs
        .iter()
        .map(|v| {
            (0..3)
                .filter(|&k| (v[k] - centre[k]).abs() > threshold_rad[k])
                .collect()
        })
        .collect();
    // Runs of consecutive flagged intervals (each the next message's interval).
    let mut runs: Vec<(usize, usize)> = Vec::new();
    for (i, f) in flagged.iter().enumerate() {
        if f.is_empty() {
            continue;
        }
        match runs.last_mut() {
            Some((_, end)) if *end + 1 == i && contiguous(&res, i) => *end = i,
            _ => runs.push((i, i)),
        }
    }
    let steps = runs
        .into_iter()
        .filter_map(|(i0, i1)| {
            let total = res
                .get(i0..=i1)?
                .iter()
                .fold(UnitQuaternion::identity(), |acc, x| x.r * acc);
            let rv = quat_log(&refine(&res, &vecs, &flagged, i0, i1, total));
            let mut axes: Vec<usize> = flagged.get(i0..=i1)?.iter().flatten().copied().collect();
            axes.sort_unstable();
            axes.dedup();
            Some(FoundStep {
                t_s: res.get(i0)?.t,
                after_s: res.get(i0)?.after,
                rotation_rad: rv.into(),
                size_deg: rv.norm().to_degrees(),
                axes,
                intervals: i1 - i0 + 1,
            })
        })
        .collect();
    Ok(StepSearch {
        source,
        span_s: [
            res.first().map_or(f64::NAN, |x| x.after),
            res.last().map_or(f64::NAN, |x| x.t),
        ],
        intervals: res.len(),
        untested_gaps,
        noise_rad,
        threshold_rad,
        steps,
    })
}

/// Undoes steps in the master's attitude, message by message in time order: the
/// message stamped `t` has every step with `t_s ≤ t` undone, `q ← (S_k ⋯ S_1)⁻¹ q`
/// (`S_j = Exp(rotation_j)`, ENU, on the left).
pub struct StepCorrection {
    /// `(t_s, (S_k ⋯ S_1)⁻¹)` after each step.
    undo: Vec<(f64, UnitQuaternion<f64>)>,
}

impl StepCorrection {
    /// The correction of steps `[t_s, x, y, z]` (time tag of the first message after,
    /// rotation vector ENU in rad), in time order.
    pub fn new(steps: &[[f64; 4]]) -> Self {
        let mut total = UnitQuaternion::identity();
        let undo = steps
            .iter()
            .map(|&[t, x, y, z]| {
                total = quat_exp(&Vector3::new(x, y, z)) * total;
                (t, total.inverse())
            })
            .collect();
        Self { undo }
    }

    /// `m` with the steps up to its time undone (unchanged before the first).
    pub fn apply(&self, mut m: MasterMsg) -> MasterMsg {
        let k = self.undo.partition_point(|(t, _)| *t <= m.t);
        if let Some((_, u)) = k.checked_sub(1).and_then(|i| self.undo.get(i)) {
            let q = u * m.attitude();
            m.q_bm_n = [q.w, q.i, q.j, q.k];
        }
        m
    }
}

/// `rec` with the master's attitude steps `steps` (`[t_s, x, y, z]`, as
/// [`StepCorrection::new`]) taken out: the master as the filter sees it. A copy only
/// when there are any.
pub fn without_steps<'a>(
    rec: &'a Recording,
    steps: Option<&[[f64; 4]]>,
) -> std::borrow::Cow<'a, Recording> {
    match steps {
        Some(steps) if !steps.is_empty() => {
            let c = StepCorrection::new(steps);
            let mut r = rec.clone();
            r.master = rec.master.iter().map(|m| c.apply(m.clone())).collect();
            std::borrow::Cow::Owned(r)
        }
        _ => std::borrow::Cow::Borrowed(rec),
    }
}

impl FoundStep {
    /// The step as the configuration keeps it: `[t_s, x, y, z]` (s, rad ENU).
    pub fn as_config(&self) -> [f64; 4] {
        let r = self.rotation_rad;
        [self.t_s, r[0], r[1], r[2]]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use flexcal_core::earth;

    /// A master turning about a tilted axis at a varying rate, with steps.
    fn master(steps: &[(f64, [f64; 3])]) -> Vec<MasterMsg> {
        let dt = 0.05;
        let w = |t: f64| Vector3::new(0.2 * (0.7 * t).sin(), 0.1 * (0.5 * t).cos(), 0.05);
        let mut q = UnitQuaternion::identity();
        let mut out = Vec::new();
        for k in 0..2000 {
            let t = k as f64 * dt;
            if k > 0 {
                // Fine integration of the true body rate over the interval.
                for j in 0..100 {
                    let s = t - dt + (j as f64 + 0.5) * dt / 100.0;
                    q *= quat_exp(&(w(s) * (dt / 100.0)));
                }
            }
            let mut rep = q;
            for (ts, r) in steps {
                if t >= *ts {
                    rep = quat_exp(&Vector3::from(*r)) * rep;
                }
            }
            // ω_ib = ω_nb + Cᵀ ω_ie at latitude 0 (no velocity).
            let w_ib = w(t) + q.inverse_transform_vector(&earth::earth_rate_n(0.0));
            out.push(MasterMsg {
                t,
                q_bm_n: [rep.w, rep.i, rep.j, rep.k],
                v_n_mps: [0.0; 3],
                lat_deg: 0.0,
                lon_deg: 0.0,
                height_m: 0.0,
                omega_ib_bm_radps: Some(w_ib.into()),
            });
        }
        out
    }

    #[test]
    fn steps_are_found_with_their_size_and_axes_and_nothing_else() {
        let truth = [(20.0, [0.0, 0.0, 0.1745]), (61.0, [0.1, -0.1, 0.0])];
        let m = master(&truth);
        let s = find_steps(m.into_iter().map(Ok)).expect("searched");
        assert_eq!(s.steps.len(), 2, "{:?}", s.steps);
        for (f, (t, r)) in s.steps.iter().zip(truth) {
            assert!((f.t_s - t).abs() < 1e-9, "step at {} for {t}", f.t_s);
            let e = (Vector3::from(f.rotation_rad) - Vector3::from(r)).norm();
            assert!(e < 1e-4, "step {:?} for {r:?}", f.rotation_rad);
        }
        assert_eq!(s.steps[0].axes, vec![2]);
        assert_eq!(s.steps[1].axes, vec![0, 1]);
        assert!(find_steps(master(&[]).into_iter().map(Ok))
            .expect("searched")
            .steps
            .is_empty());
    }

    #[test]
    fn undoing_the_found_steps_gives_the_master_without_them() {
        let with = master(&[(20.0, [0.0, 0.0, 0.1745]), (61.0, [0.1, -0.1, 0.0])]);
        let without = master(&[]);
        let found: Vec<[f64; 4]> = find_steps(with.iter().cloned().map(Ok))
            .expect("searched")
            .steps
            .iter()
            .map(FoundStep::as_config)
            .collect();
        let c = StepCorrection::new(&found);
        for (a, b) in with.iter().zip(&without) {
            let d = c.apply(a.clone()).attitude().angle_to(&b.attitude());
            assert!(d < 2e-4, "t = {}: {d} rad off", a.t);
        }
    }

    #[test]
    fn a_master_without_rate_is_refused_saying_so() {
        let mut m = master(&[]);
        m[3].omega_ib_bm_radps = None;
        let e = find_steps(m.into_iter().map(Ok)).expect_err("no rate");
        assert!(e.contains("no angular rate"), "{e}");
    }
}
