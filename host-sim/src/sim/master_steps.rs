//! The attitude error of a master that is itself a consumer-grade attitude filter
//! (`scenario::AttitudeSteps`): it drifts between its corrections and jumps at each.
//!
//! [`draw_steps`] draws such a schedule from a seed (a step of a stated size about a
//! random axis at stated or drawn times, a drift of a stated rate about a random axis
//! in each interval); the schedule is written into the scenario, so the blind truth
//! file (`OUT.drawn.toml`) holds every step and `--scenario` reproduces the recording.
//! [`StepError`] evaluates `E(t)` message by message.

use super::scenario::{AttitudeStep, AttitudeSteps};
use flexcal_core::rotation::quat_exp;
use nalgebra::{UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// A unit vector drawn uniformly on the sphere.
fn random_axis(rng: &mut impl Rng) -> Vector3<f64> {
    loop {
        let v = Vector3::from_fn(|_, _| rng.sample::<f64, _>(StandardNormal));
        let n = v.norm();
        if n > 1e-6 {
            return v / n;
        }
    }
}

/// How the steps' times are chosen.
#[derive(Clone, Debug, PartialEq)]
pub enum StepTimes {
    /// At these master times (s).
    Stated(Vec<f64>),
    /// Drawn: each interval (the first from the start too) uniform in
    /// `[0.5, 1.5] × mean_interval_s`, until the recording's end.
    Drawn {
        /// Mean interval between corrections (s).
        mean_interval_s: f64,
    },
}

/// Draws a schedule of steps over `duration_s` from `seed`: every step a rotation of
/// `size_deg` about an axis drawn uniformly on the sphere, at `times`; before the first
/// step and after each, a drift of `drift_deg_s` about a drawn axis. Its own random
/// stream: the recording's other draws are the same with or without it.
pub fn draw_steps(
    seed: u64,
    duration_s: f64,
    size_deg: f64,
    times: &StepTimes,
    drift_deg_s: f64,
) -> Result<AttitudeSteps, String> {
    if !(size_deg.is_finite() && size_deg > 0.0 && size_deg < 180.0) {
        return Err(format!(
            "the master's attitude step must be in (0, 180) degrees, got {size_deg}"
        ));
    }
    if !(drift_deg_s.is_finite() && drift_deg_s >= 0.0) {
        return Err(format!(
            "the master's attitude drift must be ≥ 0 deg/s, got {drift_deg_s}"
        ));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x57e9_5a1d_c0de_0ff5);
    let at: Vec<f64> = match times {
        StepTimes::Stated(t) => t.clone(),
        StepTimes::Drawn { mean_interval_s } => {
            if !(mean_interval_s.is_finite() && *mean_interval_s > 0.0) {
                return Err(format!(
                    "the mean interval between the master's steps must be positive, got {mean_interval_s} s"
                ));
            }
            let mut out = Vec::new();
            let mut t = 0.0;
            loop {
                t += mean_interval_s * rng.gen_range(0.5..=1.5);
                if t >= duration_s {
                    break out;
                }
                out.push(t);
            }
        }
    };
    let drift = |rng: &mut ChaCha8Rng| (random_axis(rng) * drift_deg_s).into();
    let initial_drift_deg_s = drift(&mut rng);
    let steps = at
        .into_iter()
        .map(|t_s| AttitudeStep {
            t_s,
            rotation_deg: (random_axis(&mut rng) * size_deg).into(),
            drift_deg_s: drift(&mut rng),
        })
        .collect();
    Ok(AttitudeSteps {
        initial_drift_deg_s,
        steps,
    })
}

/// `E(t)` of a schedule, for messages in time order.
pub struct StepError {
    /// Each segment: its start (s), `E` at its start (after the step), its drift (rad/s,
    /// ENU).
    segments: Vec<(f64, UnitQuaternion<f64>, Vector3<f64>)>,
}

impl StepError {
    /// The segments of `s`: before the first step, then after each.
    pub fn new(s: &AttitudeSteps) -> Self {
        let rad = |v: [f64; 3]| Vector3::from(v).map(f64::to_radians);
        let mut segments = vec![(
            f64::NEG_INFINITY,
            UnitQuaternion::identity(),
            rad(s.initial_drift_deg_s),
        )];
        let mut from = (0.0, UnitQuaternion::identity(), rad(s.initial_drift_deg_s));
        for st in &s.steps {
            let before = quat_exp(&(from.2 * (st.t_s - from.0))) * from.1;
            let after = quat_exp(&rad(st.rotation_deg)) * before;
            from = (st.t_s, after, rad(st.drift_deg_s));
            segments.push(from);
        }
        Self { segments }
    }

    /// The master's output attitude error at its time tag `t`: `q_rep = E(t) q_true`.
    pub fn at(&self, t: f64) -> UnitQuaternion<f64> {
        let k = self.segments.partition_point(|s| s.0 <= t);
        match k.checked_sub(1).and_then(|i| self.segments.get(i)) {
            Some(&(t0, e0, d)) => {
                let since = if t0.is_finite() { t - t0 } else { t };
                quat_exp(&(d * since)) * e0
            }
            None => UnitQuaternion::identity(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use flexcal_core::rotation::quat_log;

    #[test]
    fn a_drawn_schedule_has_its_size_and_spacing() {
        let times = StepTimes::Drawn {
            mean_interval_s: 20.0,
        };
        let s = draw_steps(7, 300.0, 10.0, &times, 0.01).expect("draws");
        assert_eq!(s, draw_steps(7, 300.0, 10.0, &times, 0.01).expect("draws"));
        assert!((8..=30).contains(&s.steps.len()), "{} steps", s.steps.len());
        let mut before = 0.0;
        for st in &s.steps {
            let n = Vector3::from(st.rotation_deg).norm();
            assert!((n - 10.0).abs() < 1e-9, "step of {n}°");
            let gap = st.t_s - before;
            assert!((10.0..=30.0).contains(&gap), "interval {gap} s");
            assert!((Vector3::from(st.drift_deg_s).norm() - 0.01).abs() < 1e-12);
            before = st.t_s;
        }
        assert!(s.steps.iter().all(|st| st.t_s < 300.0));
    }

    #[test]
    fn the_error_jumps_by_the_step_and_drifts_between() {
        let s = AttitudeSteps {
            initial_drift_deg_s: [0.0, 0.0, 0.1],
            steps: vec![AttitudeStep {
                t_s: 10.0,
                rotation_deg: [10.0, 0.0, 0.0],
                drift_deg_s: [0.0, 0.0, 0.0],
            }],
        };
        let e = StepError::new(&s);
        let deg = |q: UnitQuaternion<f64>| quat_log(&q).map(f64::to_degrees);
        assert!((deg(e.at(0.0))).norm() < 1e-12);
        assert!((deg(e.at(5.0)) - Vector3::new(0.0, 0.0, 0.5)).norm() < 1e-9);
        // The jump across the step is the step's rotation (on the left).
        let jump = e.at(10.0) * e.at(10.0 - 1e-9).inverse();
        assert!((deg(jump) - Vector3::new(10.0, 0.0, 0.0)).norm() < 1e-6);
        // After it no drift: the error stays.
        assert!((deg(e.at(50.0)) - deg(e.at(10.0))).norm() < 1e-12);
    }

    #[test]
    fn a_scenario_with_steps_out_of_order_is_refused_naming_the_step() {
        let mut sc = crate::sim::Scenario::load("moored").expect("built-in");
        let step = |t_s| AttitudeStep {
            t_s,
            rotation_deg: [0.0, 0.0, 10.0],
            drift_deg_s: [0.0; 3],
        };
        sc.undeclared.master_attitude_steps = Some(AttitudeSteps {
            initial_drift_deg_s: [0.0; 3],
            steps: vec![step(20.0), step(10.0)],
        });
        let e = sc.validate().expect_err("out of order");
        assert!(e.contains("steps[1].t_s"), "{e}");
    }

    #[test]
    fn bad_sizes_are_refused_with_their_value() {
        let t = StepTimes::Stated(vec![1.0]);
        let e = draw_steps(1, 10.0, -1.0, &t, 0.0).expect_err("negative size");
        assert!(e.contains("-1"), "{e}");
        let e = draw_steps(1, 10.0, 5.0, &t, f64::NAN).expect_err("NaN drift");
        assert!(e.contains("NaN"), "{e}");
    }
}
