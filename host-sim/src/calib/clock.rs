//! The clock offset between the master and the slave, from their body rates, before any
//! filter: the one implementation behind the verdict's clock check
//! (`verdict::motion`) and the coarse clock alignment of `calibrate` (`calib::prefilter`).
//!
//! Over blocks of master messages (at least `MIN_BLOCK_S` long) the master's body rate
//! is the rotation of its attitude over the block divided by the block's length (its
//! body frame; no rate field is needed). The slave's over the same interval, moved by a
//! trial offset τ, is the sum of its angle increments (each shared in proportion to its
//! overlap with the interval) divided by the same length. Sign: τ > 0 means the master's
//! time tags are late — the message stamped `t` holds the master at slave time `t − τ`
//! (the simulator's `undeclared.master_delay_s`, the filter's `time_delay`).
//!
//! The two rates agree at the right τ up to the mounting rotation `C_bs^bm`, which is
//! not known yet (it is found after the clock, `calib::mounting`, and may be anything).
//! The score of a trial τ is therefore the correlation *after the best rotation*: with
//! the centred rates `m_k`, `s_k` and `B = Σ m_k s_kᵀ`, the largest `Σ m_kᵀ R s_k` over
//! rotations R is the sum of B's singular values with the smallest signed by
//! `det(U Vᵀ)` (Wahba's problem, as in `calib::mounting`); divided by
//! `√(Σ|m_k|² Σ|s_k|²)` it is a correlation in [−1, 1], 1 when one rotation maps every
//! slave rate onto the master's. Centring removes the slave's gyro bias and the Earth's
//! rate.
//!
//! The search: a grid of one block over ±`max_offset_s`, then a grid of one IMU period
//! over ±1 block about the best, then a parabola through the best fine point and its two
//! neighbours, whose vertex places the peak below the IMU period.
//!
//! Quality: the peak correlation ρ and an approximate standard deviation from the peak's
//! curvature, `σ_τ² ≈ (1 − ρ²) / (N ρ (−ρ''))` (N blocks; the delay-estimation bound
//! for white noise on both rates, with `−ρ''/ρ` the rates' mean-square angular
//! frequency). It is refused — with the reason — when the platform hardly turned, when
//! the best correlation is too low to trust, when it turned about one axis only (the
//! rotation-free score cannot then tell τ from τ ± half a period), or when the best
//! offset is at the edge of the search.

use crate::recording::Recording;
use nalgebra::{Matrix3, Vector3};

/// Shortest block (s): long enough for a ship's rotation to dominate the master's
/// attitude noise over the block.
pub const MIN_BLOCK_S: f64 = 0.1;
/// Blocks needed for a correlation to count.
const MIN_BLOCKS: usize = 20;
/// The master's RMS body rate (centred, rad/s) below which the motion cannot place the
/// clocks: 0.06 °/s, 14 times the Earth's rate; a moored ship rolls at a few °/s.
pub const MIN_RATE_RMS_RADPS: f64 = 1e-3;
/// Correlation needed to trust the offset found.
pub const MIN_CORRELATION: f64 = 0.5;
/// At the peak, the second singular value of `B` must be at least this fraction of the
/// first. Below it the platform turned about one axis only, and the score cannot tell
/// the offset from one half a period away (a half turn about a perpendicular axis maps
/// `−ω` onto `ω`); a ship's roll, pitch and yaw at their own periods are far above it.
pub const MIN_SECOND_AXIS: f64 = 1e-2;

/// The clock offset found from the body rates.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct ClockOffset {
    /// τ (s): the master's time tags are this late on the slave's (negative: early).
    pub offset_s: f64,
    /// Approximate standard deviation of τ from the peak's curvature (s; see the module
    /// doc).
    pub sigma_s: f64,
    /// Correlation of the rates after the best rotation, at the peak (≤ 1).
    pub correlation: f64,
    /// Blocks compared at the peak.
    pub blocks: usize,
    /// Length of one block (s).
    pub block_s: f64,
    /// Step of the fine grid (s): the IMU period.
    pub fine_step_s: f64,
    /// The master's RMS body rate over the blocks, centred (rad/s): the motion seen.
    pub rate_rms_radps: f64,
    /// The half-width of the search (s).
    pub searched_s: f64,
}

/// Why the offset was not found, with the correlation when one was computed.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ClockRefusal {
    /// What prevented it, in words.
    pub reason: String,
    /// The best correlation, when the search ran.
    pub correlation: Option<f64>,
}

impl std::fmt::Display for ClockRefusal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.reason)
    }
}

fn refuse(reason: String, correlation: Option<f64>) -> ClockRefusal {
    ClockRefusal {
        reason,
        correlation,
    }
}

/// The slave's angle increments summed from its first line, to read the rotation over
/// any interval with each sample shared in proportion to its overlap.
pub struct SlaveAngles {
    /// Sample boundaries (s): the first line's time, then every sample's.
    t: Vec<f64>,
    /// Sum of the increments up to each boundary (rad, slave body).
    sum: Vec<Vector3<f64>>,
}

impl SlaveAngles {
    /// The running sums of `rec`'s slave increments.
    pub fn new(rec: &Recording) -> Self {
        let mut t = Vec::with_capacity(rec.imu.len() + 1);
        let mut sum = Vec::with_capacity(rec.imu.len() + 1);
        let mut acc = Vector3::zeros();
        t.push(rec.imu_t0);
        sum.push(acc);
        for s in &rec.imu {
            acc += Vector3::from(s.dtheta_rad);
            t.push(s.t);
            sum.push(acc);
        }
        Self { t, sum }
    }

    /// The summed increments at time `x` (rad): linear within a sample. `None` outside
    /// the samples.
    fn at(&self, x: f64) -> Option<Vector3<f64>> {
        let k = self.t.partition_point(|&t| t < x);
        if k == 0 {
            return (self.t.first() == Some(&x)).then(|| self.sum[0]);
        }
        let (t1, s1) = (*self.t.get(k)?, self.sum.get(k)?);
        let (t0, s0) = (self.t[k - 1], self.sum[k - 1]);
        let w = if t1 > t0 { (x - t0) / (t1 - t0) } else { 1.0 };
        Some(s0 + (s1 - s0) * w)
    }

    /// The slave's rotation over `(a, b]` (rad, slave body): the increments summed, the
    /// samples at the ends in proportion to their overlap. `None` when the samples do
    /// not cover the interval.
    pub fn rotation(&self, a: f64, b: f64) -> Option<Vector3<f64>> {
        Some(self.at(b)? - self.at(a)?)
    }

    /// The median sample period (s).
    fn period(&self) -> f64 {
        median(self.t.windows(2).map(|w| w[1] - w[0]).collect())
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.retain(|x| x.is_finite());
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// One block of the master: its interval and its mean body rate (rad/s, master body).
struct Block {
    a: f64,
    b: f64,
    rate: Vector3<f64>,
}

/// The master's blocks in `[from, to]`: consecutive runs of messages at least
/// `MIN_BLOCK_S` long (and the block length used).
fn master_blocks(rec: &Recording, from: f64, to: f64) -> (Vec<Block>, f64) {
    let dt = median(rec.master.windows(2).map(|w| w[1].t - w[0].t).collect());
    let stride = if dt > 0.0 {
        ((MIN_BLOCK_S / dt) - 1e-9).ceil().max(1.0) as usize
    } else {
        1
    };
    let inside: Vec<_> = rec
        .master
        .iter()
        .filter(|m| m.t >= from && m.t <= to)
        .step_by(stride)
        .collect();
    let blocks = inside
        .windows(2)
        .filter_map(|w| {
            let (a, b) = (w[0], w[1]);
            let len = b.t - a.t;
            let q = |q: [f64; 4]| {
                nalgebra::UnitQuaternion::new_normalize(nalgebra::Quaternion::new(
                    q[0], q[1], q[2], q[3],
                ))
            };
            (len > 0.0).then(|| Block {
                a: a.t,
                b: b.t,
                rate: (q(a.q_bm_n).inverse() * q(b.q_bm_n)).scaled_axis() / len,
            })
        })
        .collect();
    (blocks, stride as f64 * dt)
}

/// The score of one trial offset.
#[derive(Clone, Copy)]
struct Score {
    /// Correlation after the best rotation.
    r: f64,
    /// Blocks compared.
    n: usize,
    /// Second singular value of `B` over the first.
    second_axis: f64,
}

/// The correlation after the best rotation of the master's rates with the slave's
/// moved by `tau` (see the module doc), and the blocks it used; `None` with fewer than
/// `MIN_BLOCKS`.
fn score(blocks: &[Block], slave: &SlaveAngles, tau: f64) -> Option<Score> {
    // Consecutive blocks share an end: the slave's sum there, read for one block's end,
    // serves the next one's start (`SlaveAngles::rotation` of each block, halved).
    let mut end: Option<(u64, Vector3<f64>)> = None;
    let pairs: Vec<(Vector3<f64>, Vector3<f64>)> = blocks
        .iter()
        .filter_map(|k| {
            let (a, b) = (k.a - tau, k.b - tau);
            let at_a = match end {
                Some((x, v)) if x == a.to_bits() => Some(v),
                _ => slave.at(a),
            };
            let at_b = slave.at(b);
            end = at_b.map(|v| (b.to_bits(), v));
            let s = (at_b? - at_a?) / (k.b - k.a);
            Some((k.rate, s))
        })
        .collect();
    let n = pairs.len();
    if n < MIN_BLOCKS {
        return None;
    }
    let mm = pairs.iter().map(|p| p.0).sum::<Vector3<f64>>() / n as f64;
    let sm = pairs.iter().map(|p| p.1).sum::<Vector3<f64>>() / n as f64;
    let (mut b, mut vm, mut vs) = (Matrix3::zeros(), 0.0, 0.0);
    for (m, s) in &pairs {
        let (dm, ds) = (m - mm, s - sm);
        b += dm * ds.transpose();
        vm += dm.norm_squared();
        vs += ds.norm_squared();
    }
    let svd = b.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    let mut sv = [
        svd.singular_values[0],
        svd.singular_values[1],
        svd.singular_values[2],
    ];
    sv.sort_by(|x, y| y.total_cmp(x));
    let d = (u.determinant() * v_t.determinant()).signum();
    let r = (sv[0] + sv[1] + d * sv[2]) / (vm * vs).sqrt();
    r.is_finite().then_some(Score {
        r,
        n,
        second_axis: sv[1] / sv[0],
    })
}

/// The best of `scores` by correlation, with its index; `None` when none scores.
fn best(scores: &[Option<Score>]) -> Option<(usize, Score)> {
    scores
        .iter()
        .enumerate()
        .filter_map(|(i, s)| s.map(|s| (i, s)))
        .max_by(|x, y| x.1.r.total_cmp(&y.1.r))
}

/// Finds the clock offset within ±`max_offset_s` from the master's messages in
/// `[from, to]` (slave time) and the slave's increments (see the module doc).
pub fn clock_offset(
    rec: &Recording,
    max_offset_s: f64,
    from: f64,
    to: f64,
) -> Result<ClockOffset, ClockRefusal> {
    let slave = SlaveAngles::new(rec);
    let (blocks, block_s) = master_blocks(rec, from, to);
    if blocks.len() < MIN_BLOCKS {
        return Err(refuse(
            format!(
                "{} master blocks of {block_s:.3} s in [{from:.1}, {to:.1}] s: at least {MIN_BLOCKS} are needed to compare the clocks",
                blocks.len()
            ),
            None,
        ));
    }
    let n = blocks.len() as f64;
    let mean = blocks.iter().map(|k| k.rate).sum::<Vector3<f64>>() / n;
    let rate_rms = (blocks
        .iter()
        .map(|k| (k.rate - mean).norm_squared())
        .sum::<f64>()
        / n)
        .sqrt();
    if rate_rms.is_nan() || rate_rms < MIN_RATE_RMS_RADPS {
        return Err(refuse(
            format!(
                "the platform hardly turned (the master's body rate varies by {:.3} °/s RMS over {} blocks, {:.3} °/s needed): the clocks cannot be compared by rotation",
                rate_rms.to_degrees(),
                blocks.len(),
                MIN_RATE_RMS_RADPS.to_degrees()
            ),
            None,
        ));
    }
    // Coarse: one block per step.
    let lags = (max_offset_s / block_s).round().max(1.0) as i64;
    let coarse: Vec<f64> = (-lags..=lags).map(|l| l as f64 * block_s).collect();
    let coarse_scores: Vec<_> = coarse.iter().map(|&t| score(&blocks, &slave, t)).collect();
    let Some((
        ic,
        Score {
            r: rc, second_axis, ..
        },
    )) = best(&coarse_scores)
    else {
        return Err(refuse(
            format!("no offset within ±{max_offset_s} s leaves {MIN_BLOCKS} blocks inside the slave's samples"),
            None,
        ));
    };
    if rc < MIN_CORRELATION {
        return Err(refuse(
            format!(
                "the body rates correlate at most {rc:.3} within ±{max_offset_s} s (≥ {MIN_CORRELATION} needed): the clocks were not compared"
            ),
            Some(rc),
        ));
    }
    if second_axis.is_nan() || second_axis < MIN_SECOND_AXIS {
        return Err(refuse(
            format!(
                "the platform turned about one axis only (second singular value {second_axis:.1e} of the first, ≥ {MIN_SECOND_AXIS} needed): the offset is ambiguous by half a period"
            ),
            Some(rc),
        ));
    }
    if ic == 0 || ic + 1 == coarse.len() {
        return Err(refuse(
            format!(
                "the body rates match best at the edge of the search ({:+.2} s of ±{max_offset_s} s, correlation {rc:.3}): the offset may be larger",
                coarse[ic]
            ),
            Some(rc),
        ));
    }
    // Fine: one IMU period per step over ±1 block about the coarse peak.
    let step = slave.period().min(block_s);
    let half = (block_s / step).ceil() as i64;
    let fine: Vec<f64> = (-half..=half)
        .map(|j| coarse[ic] + j as f64 * step)
        .collect();
    let fine_scores: Vec<_> = fine.iter().map(|&t| score(&blocks, &slave, t)).collect();
    let Some((i, Score { r: r0, n: used, .. })) = best(&fine_scores) else {
        return Err(refuse("the fine search found no score".into(), Some(rc)));
    };
    // The parabola through the best fine point and its neighbours.
    let neighbour = |k: Option<usize>| {
        k.and_then(|k| fine_scores.get(k).copied().flatten())
            .map(|s| s.r)
    };
    let (offset, curvature) = match (neighbour(i.checked_sub(1)), neighbour(Some(i + 1))) {
        (Some(rm), Some(rp)) => {
            let c = rm - 2.0 * r0 + rp;
            let shift = if c < 0.0 {
                (0.5 * (rm - rp) / c).clamp(-0.5, 0.5)
            } else {
                0.0
            };
            (fine[i] + shift * step, c / (step * step))
        }
        _ => (fine[i], f64::NAN),
    };
    let sigma = if curvature < 0.0 && r0 > 0.0 {
        ((1.0 - r0 * r0).max(0.0) / (used as f64 * r0 * -curvature)).sqrt()
    } else {
        f64::NAN
    };
    Ok(ClockOffset {
        offset_s: offset,
        sigma_s: sigma,
        correlation: r0,
        blocks: used,
        block_s,
        fine_step_s: step,
        rate_rms_radps: rate_rms,
        searched_s: max_offset_s,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::{simulate, Scenario};

    fn moored(seconds: f64, delay_s: f64, mounting_deg: [f64; 3]) -> Recording {
        let mut sc = Scenario::load("moored").expect("built-in");
        sc.duration_s = seconds;
        sc.undeclared.master_delay_s = delay_s;
        sc.misalignment_deg = mounting_deg;
        simulate(&sc, 5).recording
    }

    /// Offsets of either sign, under any mounting, found well within 5 ms.
    #[test]
    fn finds_the_offset_under_any_mounting() {
        for (tau, mounting) in [
            (0.4, [0.0, 0.0, 0.0]),
            (-0.4, [90.0, 0.0, 0.0]),
            (0.013, [0.0, 0.0, 180.0]),
            (-0.75, [30.0, -20.0, 45.0]),
        ] {
            let rec = moored(60.0, tau, mounting);
            let c = clock_offset(&rec, 1.0, 0.0, 60.0).expect("found");
            eprintln!("τ {tau} s, mounting {mounting:?}°: {c:?}");
            assert!((c.offset_s - tau).abs() < 2e-3, "τ {tau}: {c:?}");
            assert!(c.correlation > 0.99 && c.sigma_s < 2e-3, "{c:?}");
        }
    }

    /// A platform at rest: refused, saying why. With the master's attitude noise
    /// (0.005° per message) its rate over 0.1 s blocks varies by 0.07 °/s, noise the
    /// slave's rate does not share: the correlation refuses. Without that noise the
    /// motion itself does.
    #[test]
    fn refuses_without_rotation() {
        let mut sc = Scenario::load("moored").expect("built-in");
        sc.duration_s = 30.0;
        sc.motion.roll_amp_deg = 0.0;
        sc.motion.pitch_amp_deg = 0.0;
        sc.motion.yaw_amp_deg = 0.0;
        let rec = simulate(&sc, 5).recording;
        let e = clock_offset(&rec, 1.0, 0.0, 30.0).expect_err("refused");
        assert!(
            e.reason.contains("not compared") && e.correlation.is_some_and(|r| r < 0.5),
            "{e}"
        );
        sc.master.attitude_noise_deg = 0.0;
        let rec = simulate(&sc, 5).recording;
        let e = clock_offset(&rec, 1.0, 0.0, 30.0).expect_err("refused");
        assert!(e.reason.contains("hardly turned"), "{e}");
    }

    /// A roll alone: refused as ambiguous, not reported.
    #[test]
    fn refuses_a_rotation_about_one_axis() {
        let mut sc = Scenario::load("moored").expect("built-in");
        sc.duration_s = 30.0;
        sc.motion.pitch_amp_deg = 0.0;
        sc.motion.yaw_amp_deg = 0.0;
        let rec = simulate(&sc, 5).recording;
        let e = clock_offset(&rec, 1.0, 0.0, 30.0).expect_err("refused");
        assert!(e.reason.contains("one axis"), "{e}");
    }

    /// An offset beyond the search: refused at the edge, not reported as the edge.
    #[test]
    fn refuses_an_offset_beyond_the_search() {
        let rec = moored(40.0, 0.9, [0.0; 3]);
        let e = clock_offset(&rec, 0.5, 0.0, 40.0).expect_err("refused");
        assert!(e.reason.contains("edge"), "{e}");
    }
}
