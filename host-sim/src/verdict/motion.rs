//! Units and clocks checked against the motion itself: the slave's specific force
//! against gravity, the slave's and the master's rotation against the master's
//! attitude, and the two clocks against each other by cross-correlating the body
//! rates. A recording in the wrong units (degrees, rates written as increments, a
//! master rate in °/s) or with a clock off by seconds parses; these catch it.
//! Thresholds: `docs/verdict.md`.

use super::input::median;
use super::{g3, Finding, Severity};
use crate::calib::clock::clock_offset;
use crate::recording::{Recording, MASTER_FILE, SLAVE_FILE};
use nalgebra::Vector3;

/// Standard gravity (m/s²).
const G0: f64 = 9.806_65;
/// Window of the scale checks (s).
const WINDOW_S: f64 = 1.0;
/// A scale (measured over expected) outside this range is a unit error, not a sensor's.
pub const SCALE_RANGE: [f64; 2] = [0.5, 2.0];
/// A window is used for a rotation scale when the master turned at least this much (rad):
/// 140 times the Earth's rotation in it, 10 times a 200 °/h MEMS bias.
const MIN_ROTATION_RAD: f64 = 0.01;
/// Windows needed before a scale is judged.
const MIN_WINDOWS: usize = 5;
/// Largest clock offset searched (s).
pub const MAX_OFFSET_S: f64 = 5.0;
/// An offset at least this large (s) is a WARN.
pub const OFFSET_WARN_S: f64 = 0.2;
/// At least this large (s), a FAIL.
pub const OFFSET_FAIL_S: f64 = 1.0;

/// Every motion finding of a recording.
pub fn check(rec: &Recording) -> Vec<Finding> {
    let slave = Slave::new(rec);
    let mut out = Vec::new();
    out.extend(accel_scale(rec, &slave));
    out.extend(gyro_scale(rec, &slave));
    out.extend(master_rate_scale(rec));
    out.extend(time_offset(rec));
    out
}

/// The slave's increments as running sums, to sum any window in O(log n).
struct Slave {
    t: Vec<f64>,
    dtheta: Vec<Vector3<f64>>,
    dv: Vec<Vector3<f64>>,
}

impl Slave {
    fn new(rec: &Recording) -> Self {
        let n = rec.imu.len();
        let mut t = Vec::with_capacity(n + 1);
        let mut dtheta = Vec::with_capacity(n + 1);
        let mut dv = Vec::with_capacity(n + 1);
        t.push(rec.imu_t0);
        dtheta.push(Vector3::zeros());
        dv.push(Vector3::zeros());
        for s in &rec.imu {
            t.push(s.t);
            dtheta.push(dtheta[dtheta.len() - 1] + Vector3::from(s.dtheta_rad));
            dv.push(dv[dv.len() - 1] + Vector3::from(s.dv_mps));
        }
        Self { t, dtheta, dv }
    }

    /// The sample boundaries nearest to `[a, b]`, or `None` outside the span.
    fn span(&self, a: f64, b: f64) -> Option<(usize, usize)> {
        let last = *self.t.last()?;
        if a < self.t[0] || b > last {
            return None;
        }
        let i = self.t.partition_point(|&t| t < a);
        let j = self.t.partition_point(|&t| t < b);
        (j > i).then_some((i, j))
    }

    /// Sums of the angle and velocity increments over `[a, b]` and the time they cover.
    fn sum(&self, a: f64, b: f64) -> Option<(Vector3<f64>, Vector3<f64>, f64)> {
        let (i, j) = self.span(a, b)?;
        Some((
            self.dtheta[j] - self.dtheta[i],
            self.dv[j] - self.dv[i],
            self.t[j] - self.t[i],
        ))
    }
}

/// Windows of `WINDOW_S` over `[a, b]`.
fn windows(a: f64, b: f64) -> impl Iterator<Item = (f64, f64)> {
    let n = ((b - a) / WINDOW_S).floor().max(0.0) as usize;
    (0..n).map(move |k| (a + k as f64 * WINDOW_S, a + (k + 1) as f64 * WINDOW_S))
}

/// What a scale far from 1 most likely means, from its size.
fn reading(scale: f64, rate_hz: f64) -> String {
    let near = |x: f64| (scale / x).ln().abs() < 0.3;
    if near(rate_hz) {
        format!(
            "about the sample rate ({} Hz): rates written as increments?",
            g3(rate_hz)
        )
    } else if near(1.0 / rate_hz) {
        "about one sample period: increments written as rates?".to_string()
    } else if near(180.0 / std::f64::consts::PI) {
        "about 180/π: degrees written as radians?".to_string()
    } else if near(std::f64::consts::PI / 180.0) {
        "about π/180: radians where degrees were meant?".to_string()
    } else {
        "a unit error".to_string()
    }
}

/// A FAIL when the median of the per-window `ratios` (at least `MIN_WINDOWS` of them)
/// is outside `SCALE_RANGE`; `what` says it from the median and the window count.
fn scale_check(
    ratios: Vec<f64>,
    code: &'static str,
    file: &str,
    what: impl FnOnce(f64, usize) -> String,
) -> Option<Finding> {
    let n = ratios.len();
    if n < MIN_WINDOWS {
        return None;
    }
    let scale = median(ratios);
    (!(SCALE_RANGE[0]..=SCALE_RANGE[1]).contains(&scale)).then(|| {
        Finding::new(Severity::Fail, code, what(scale, n))
            .at(file.to_string())
            .num("scale", scale)
            .num("windows", n as f64)
            .num("range_lo", SCALE_RANGE[0])
            .num("range_hi", SCALE_RANGE[1])
    })
}

/// The slave's specific force over 1 s windows: its median magnitude is gravity's
/// (within the vehicle's own accelerations) on any body not in free fall.
fn accel_scale(rec: &Recording, slave: &Slave) -> Option<Finding> {
    let (a, b) = (slave.t[0], *slave.t.last()?);
    let f: Vec<f64> = windows(a, b)
        .filter_map(|(x, y)| slave.sum(x, y))
        .map(|(_, dv, dt)| dv.norm() / dt / G0)
        .collect();
    scale_check(f, "slave_accel_scale", SLAVE_FILE, |scale, n| {
        format!(
            "the slave's specific force is {} g in the median of {n} one-second windows, where gravity alone gives 1 g: {}",
            g3(scale),
            reading(scale, rec.meta.slave_rate_hz)
        )
    })
}

/// The slave's rotation over 1 s windows against the master's (the misalignment does
/// not change a rotation's angle).
fn gyro_scale(rec: &Recording, slave: &Slave) -> Option<Finding> {
    let (a, b) = (
        slave.t[0].max(rec.master.first()?.t),
        slave.t.last()?.min(rec.master.last()?.t),
    );
    let r: Vec<f64> = windows(a, b)
        .filter_map(|(x, y)| {
            let m = rec.master_rotation(x, y)?.norm();
            let (dth, _, _) = slave.sum(x, y)?;
            (m >= MIN_ROTATION_RAD).then(|| dth.norm() / m)
        })
        .collect();
    scale_check(r, "slave_gyro_scale", SLAVE_FILE, |scale, n| {
        format!(
            "the slave's angle increments add up to {} times the master's rotation (median of {n} one-second windows where the master turned ≥ {}°): {}",
            g3(scale),
            g3(MIN_ROTATION_RAD.to_degrees()),
            reading(scale, rec.meta.slave_rate_hz)
        )
    })
}

/// The master's own angular rate, integrated over 1 s windows, against its attitude.
fn master_rate_scale(rec: &Recording) -> Option<Finding> {
    if !rec.master_has_rate() {
        return None;
    }
    let (a, b) = (rec.master.first()?.t, rec.master.last()?.t);
    let r: Vec<f64> = windows(a, b)
        .filter_map(|(x, y)| {
            let (i, j) = (rec.master_index(x)?, rec.master_index(y)?);
            let m = rec.master_rotation(x, y)?.norm();
            let mut integral = Vector3::zeros();
            for k in i + 1..=j {
                let w = rec.master[k].omega_ib_bm_radps?;
                integral += Vector3::from(w) * (rec.master[k].t - rec.master[k - 1].t);
            }
            (m >= MIN_ROTATION_RAD).then(|| integral.norm() / m)
        })
        .collect();
    scale_check(r, "master_rate_scale", MASTER_FILE, |scale, n| {
        format!(
            "the master's rate `wx,wy,wz` integrates to {} times the rotation of its own attitude (median of {n} one-second windows): {} (recording-v1 wants rad/s)",
            g3(scale),
            reading(scale, rec.meta.master_rate_hz)
        )
    })
}

/// The clock offset from the body rates (`calib::clock`, the implementation
/// `calibrate` aligns the clocks with), searched over ±`MAX_OFFSET_S` on the whole
/// recording.
fn time_offset(rec: &Recording) -> Option<Finding> {
    let (a, b) = (rec.master.first()?.t, rec.master.last()?.t);
    let found = clock_offset(rec, MAX_OFFSET_S, a, b);
    let (offset, r) = match found {
        Ok(c) => (c.offset_s, c.correlation),
        Err(e) => {
            let f = Finding::new(
                Severity::Note,
                "clock_offset_unchecked",
                format!("the clocks were not compared: {e}"),
            );
            return Some(match e.correlation {
                Some(r) => f.num("correlation", r),
                None => f,
            });
        }
    };
    let sev = if offset.abs() >= OFFSET_FAIL_S {
        Severity::Fail
    } else if offset.abs() >= OFFSET_WARN_S {
        Severity::Warn
    } else {
        return None;
    };
    Some(
        Finding::new(
            sev,
            "master_time_offset",
            format!(
                "the master's time tags are {} s {} the slave's: its body rate matches the slave's best (correlation {}) shifted by that much; recording-v1 puts both on one time base",
                g3(offset.abs()),
                if offset > 0.0 { "late on" } else { "early on" },
                g3(r)
            ),
        )
        .at(MASTER_FILE.to_string())
        .num("offset_s", offset)
        .num("correlation", r),
    )
}
