//! Coarse mounting alignment before the filter: the slave-to-master rotation from the
//! two units' own rotations over short blocks of time.
//!
//! The filter's misalignment states are small-angle errors about a nominal mounting
//! `μ̂₀`. Started at zero on a slave mounted 3° off, its first seconds run with a 3°
//! attitude error, and what the linearization gets wrong there stays in the bias states
//! (blind seed 14: 3.3° about y left the accelerometer bias x 1 mg and the misalignment
//! 3.4′ off, 9σ, where the same recording with 0.03° ends within 1σ). So the mounting is
//! found first, to a fraction of a degree, and the filter starts from it.
//!
//! Over a block `(t_a, t_b]` (about 0.2 s) the master turns by the rotation vector
//! `φ_m = Log(C_bm^n(t_a)ᵀ C_bm^n(t_b))` (its body frame; the Earth's and the transport
//! rate's share, < 2e-5 rad per block, is left in as noise) and the slave's gyro
//! increments over the same interval add up to `φ_s` (its body frame), so
//! `φ_m ≈ C_bs^bm φ_s` with `C_bs^bm = Exp(μ)` (recording-v1's misalignment: a slave-body
//! vector `x` is `Exp(μ) x` in the master body frame). The rotation that best maps the
//! `φ_s` onto the `φ_m` in least squares is Wahba's problem, solved by the singular
//! value decomposition of `B = Σ φ_m φ_sᵀ` (Markley's SVD method). It needs the platform
//! to turn about at least two axes; a ship's roll, pitch and yaw do, a slave at rest on
//! a quay does not, and then the alignment says so and the filter starts from zero.

use super::clock::SlaveAngles;
use super::config::CalibConfig;
use crate::learn::params::Param;
use crate::recording::Recording;
use flexcal_core::rotation::log_so3;
use nalgebra::{Matrix3, Vector3};

/// Length of one block (s): long enough for a ship's rotation to dominate the slave's
/// sample-boundary share, short enough that the rotation vector adds up linearly.
const BLOCK_S: f64 = 0.2;

/// The second singular value of `B` must be at least this fraction of the first: below
/// it the motion turns about one axis only and the mounting about it is not seen.
const MIN_SECOND_SINGULAR_RATIO: f64 = 1e-3;

/// The mounting found before the filter.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct CoarseMounting {
    /// `μ̂₀`: rotation vector of `C_bs^bm` (rad, slave body to master body).
    pub rotation_vector_rad: [f64; 3],
    /// Blocks used.
    pub blocks: usize,
    /// RMS of `φ_m − C_bs^bm φ_s` over the blocks (rad per block).
    pub rms_residual_rad: f64,
    /// RMS of `φ_m` over the blocks (rad per block): the motion the alignment saw.
    pub rms_rotation_rad: f64,
    /// Singular values of `B`, largest first (rad²): how many axes the motion turned
    /// about.
    pub singular_values: [f64; 3],
    /// Angle between the fits of the window's first and second halves (rad): what the
    /// blocks' correlated errors (the flexure's, slow against a block) do to a fit,
    /// which the residual's RMS, read as white, understates.
    pub split_half_rad: f64,
}

impl CoarseMounting {
    /// An upper bound (95 %) of the fit's error σ per axis (rad), from the two halves:
    /// their difference has variance 2σ_h² per axis, the whole window's fit σ_h²/2, so
    /// σ² ≈ |δ|²/12 with three degrees of freedom, and its 95 % upper bound is
    /// 3/χ²₃(0.05) = 8.5 times that: σ ≤ 0.84 |δ|. Never below what the residuals give
    /// read as white (`rms_residual / √(s₂ + s₃)`, the least-turned axes).
    pub fn sigma_bound_rad(&self) -> f64 {
        let [_, s2, s3] = self.singular_values;
        let white = self.rms_residual_rad / (s2 + s3).sqrt();
        (0.84 * self.split_half_rad).max(white)
    }

    /// Starts a model to be learned from this mounting: `mounting_estimate_rad`, and the
    /// misalignment prior about it [`Self::sigma_bound_rad`] (within the learner's
    /// bounds; the configuration's own when the bound is not a number). The built-in 1°
    /// about a mounting found to a tenth of a degree let the filter's first updates,
    /// against a precise master, resolve the misalignment from the errors' second-order
    /// products (~(1°)²): blind seed 41 handed its truth, attitude matched alone at a
    /// 1e-7 rad noise, NEES 40.5; with a 0.1° prior 4.6 (`docs/model-learning.md`,
    /// session 8).
    pub fn start_learning(&self, cfg: &mut CalibConfig) {
        cfg.mounting_estimate_rad = Some(self.rotation_vector_rad);
        let b = self.sigma_bound_rad();
        if b.is_finite() && b > 0.0 {
            let (lo, hi) = Param::InitialMisalignment.bounds();
            cfg.initial_misalignment_rad = b.clamp(lo, hi);
        }
    }
}

/// Finds the mounting from the first `window_s` seconds of `rec`.
pub fn coarse_mounting(rec: &Recording, window_s: f64) -> Result<CoarseMounting, String> {
    coarse_mounting_after_clock(rec, window_s, 0.0)
}

/// [`coarse_mounting`] with the master's time tags `clock_offset_s` late on the slave's
/// (`calib::clock`): the master's block `(t_a, t_b]` is compared with the slave's
/// `(t_a − τ, t_b − τ]`. Blocks of 0.2 s need the clocks aligned to a small fraction of
/// a block: at τ = 0.4 s unaligned, no block shares an instant with its partner.
pub fn coarse_mounting_after_clock(
    rec: &Recording,
    window_s: f64,
    clock_offset_s: f64,
) -> Result<CoarseMounting, String> {
    let Some(first) = rec.master.first() else {
        return Err("no master messages to align the mounting with".into());
    };
    let end = first.t + window_s;
    let stride = ((BLOCK_S * rec.meta.master_rate_hz).ceil() as usize).max(1);
    let masters: Vec<_> = rec
        .master
        .iter()
        .filter(|m| m.t <= end)
        .step_by(stride)
        .collect();
    let slave = SlaveAngles::new(rec);
    let tau = clock_offset_s;
    let mut pairs = Vec::new();
    for w in masters.windows(2) {
        let [a, b] = [w[0], w[1]];
        if let (Some(phi_m), Some(phi_s)) = (
            rec.master_rotation(a.t, b.t),
            slave.rotation(a.t - tau, b.t - tau),
        ) {
            pairs.push((phi_m, phi_s));
        }
    }
    if pairs.len() < 3 {
        return Err(format!(
            "{} blocks of {BLOCK_S} s in the first {window_s} s: too few to align the mounting",
            pairs.len()
        ));
    }
    let (r, sv) = fit(&pairs)?;
    let half = pairs.len() / 2;
    let split_half_rad = match (
        fit(pairs.get(..half).unwrap_or(&[])),
        fit(pairs.get(half..).unwrap_or(&[])),
    ) {
        (Ok((r1, _)), Ok((r2, _))) => log_so3(&(r1.transpose() * r2)).norm(),
        _ => f64::NAN,
    };
    let mu = log_so3(&r);
    let n = pairs.len() as f64;
    let mean_square_residual = pairs
        .iter()
        .map(|(m, s)| (m - r * s).norm_squared())
        .sum::<f64>()
        / n;
    let mean_square_rotation = pairs.iter().map(|(m, _)| m.norm_squared()).sum::<f64>() / n;
    Ok(CoarseMounting {
        rotation_vector_rad: [mu.x, mu.y, mu.z],
        blocks: pairs.len(),
        rms_residual_rad: mean_square_residual.sqrt(),
        rms_rotation_rad: mean_square_rotation.sqrt(),
        singular_values: sv,
        split_half_rad,
    })
}

/// The rotation `C_bs^bm` that best takes the slave's block rotations onto the master's
/// (Wahba's problem by the SVD of `B = Σ φ_m φ_sᵀ`), with `B`'s singular values, largest
/// first; refused when the blocks turned about fewer than two axes.
fn fit(pairs: &[(Vector3<f64>, Vector3<f64>)]) -> Result<(Matrix3<f64>, [f64; 3]), String> {
    let b: Matrix3<f64> = pairs.iter().map(|(m, s)| m * s.transpose()).sum();
    let svd = b.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Err("the alignment's singular value decomposition failed".into());
    };
    let mut sv = [
        svd.singular_values[0],
        svd.singular_values[1],
        svd.singular_values[2],
    ];
    sv.sort_by(|x, y| y.total_cmp(x));
    if !(sv[0] > 0.0 && sv[1] >= MIN_SECOND_SINGULAR_RATIO * sv[0]) {
        return Err(format!(
            "the platform turned about fewer than two axes in {} s \
             (singular values {:.3e}, {:.3e}, {:.3e} rad²): the mounting about the missing \
             axis cannot be seen by its rotation",
            pairs.len() as f64 * BLOCK_S,
            sv[0],
            sv[1],
            sv[2]
        ));
    }
    let d = (u.determinant() * v_t.determinant()).signum();
    let r = u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * v_t;
    Ok((r, sv))
}

/// The rotation vector of the same rotation with its angle within [0, π] (a mounting
/// reported within ±180°): the engine adds its corrections to `μ̂` as a vector, which
/// leaves it longer than π when the mounting is near a half turn.
pub fn within_half_turn(v: [f64; 3]) -> [f64; 3] {
    let n = Vector3::from(v).norm();
    if !n.is_finite() || n <= std::f64::consts::PI {
        return v;
    }
    let tau = 2.0 * std::f64::consts::PI;
    let m = n - tau * ((n + std::f64::consts::PI) / tau).floor();
    v.map(|x| x * m / n)
}

/// Of the rotation vectors of the rotation `v` (its angle plus whole turns, about its
/// axis), the one nearest `to`: a truth of 180° about z is `[0, 0, π]` and `[0, 0, −π]`,
/// and an estimate is scored against the one it is near.
pub fn nearest_equivalent(v: [f64; 3], to: [f64; 3]) -> [f64; 3] {
    let v = Vector3::from(v);
    let n = v.norm();
    if !n.is_finite() || n <= 0.0 {
        return v.into();
    }
    let tau = 2.0 * std::f64::consts::PI;
    [-1.0, 0.0, 1.0]
        .map(|k| v * ((n + k * tau) / n))
        .into_iter()
        .min_by(|a, b| {
            (a - Vector3::from(to))
                .norm()
                .total_cmp(&(b - Vector3::from(to)).norm())
        })
        .unwrap_or(v)
        .into()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::{simulate, Scenario};

    /// A scenario with a large mounting: found to a small fraction of a degree.
    #[test]
    fn finds_a_large_mounting_from_the_ships_motion() {
        for mis in [
            [3.3, -1.0, 0.4],
            [30.0, 0.0, 0.0],
            [0.0, 90.0, 0.0],
            [0.0, 0.0, 180.0],
            [-10.0, 20.0, 170.0],
        ] {
            let mut sc = Scenario::load("moored").expect("built-in");
            sc.duration_s = 60.0;
            sc.misalignment_deg = mis;
            let rec = simulate(&sc, 3).recording;
            let found = coarse_mounting(&rec, 60.0).expect("aligns");
            let truth =
                nalgebra::Rotation3::from_scaled_axis(Vector3::from(mis.map(f64::to_radians)));
            let got =
                nalgebra::Rotation3::from_scaled_axis(Vector3::from(found.rotation_vector_rad));
            let err_deg = (truth.inverse() * got).angle().to_degrees();
            eprintln!("mounting {mis:?}°: found to {err_deg:.4}°");
            assert!(err_deg < 0.1, "{mis:?}: off by {err_deg}° ({found:?})");
        }
    }

    /// With the master's tags 0.4 s late, the blocks compare nothing until the clock
    /// offset moves them back.
    #[test]
    fn finds_the_mounting_once_the_clocks_are_aligned() {
        let mut sc = Scenario::load("moored").expect("built-in");
        sc.duration_s = 60.0;
        sc.misalignment_deg = [0.0, 90.0, 0.0];
        sc.undeclared.master_delay_s = 0.4;
        let rec = simulate(&sc, 3).recording;
        let truth =
            nalgebra::Rotation3::from_scaled_axis(Vector3::new(0.0, 90f64.to_radians(), 0.0));
        let err = |m: &CoarseMounting| {
            let got = nalgebra::Rotation3::from_scaled_axis(Vector3::from(m.rotation_vector_rad));
            (truth.inverse() * got).angle().to_degrees()
        };
        let aligned = coarse_mounting_after_clock(&rec, 60.0, 0.4).expect("aligns");
        assert!(err(&aligned) < 0.1, "{aligned:?}");
        let unaligned = coarse_mounting(&rec, 60.0);
        assert!(
            unaligned.as_ref().map_or(true, |m| err(m) > 1.0),
            "{unaligned:?}"
        );
    }

    /// A rotation vector longer than π comes back within it, the same rotation; a
    /// truth of a half turn is scored against its representation nearest the estimate.
    #[test]
    fn half_turns_are_reported_within_180_degrees() {
        let pi = std::f64::consts::PI;
        for v in [
            [0.0, 0.0, 1.01 * pi],
            [2.5, -2.5, 7.85],
            [0.3, 0.0, 0.0],
            [0.0, 0.0, -3.0 * pi - 0.1],
        ] {
            let w = within_half_turn(v);
            let n = Vector3::from(w).norm();
            assert!(n <= pi + 1e-12, "{v:?} -> {w:?}");
            let (a, b) = (
                nalgebra::Rotation3::from_scaled_axis(Vector3::from(v)),
                nalgebra::Rotation3::from_scaled_axis(Vector3::from(w)),
            );
            assert!((a.matrix() - b.matrix()).norm() < 1e-12, "{v:?} -> {w:?}");
        }
        let near = nearest_equivalent([0.0, 0.0, pi], [0.0, 0.0, -pi + 0.01]);
        assert!((near[2] + pi).abs() < 1e-12, "{near:?}");
    }
}
