//! Scoring against `truth.csv`: final errors and the normalized estimation error
//! squared (NEES) of the calibrated quantities.

use super::mounting::nearest_equivalent;
use super::run::CalibResult;
use crate::recording::Truth;
use nalgebra::SVector;

/// Final errors (estimate minus truth) and NEES.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct Score {
    /// Gyro bias error (rad/s).
    pub gyro_bias: [f64; 3],
    /// Accelerometer bias error (m/s²).
    pub accel_bias: [f64; 3],
    /// Misalignment error (rad).
    pub misalignment: [f64; 3],
    /// NEES of the 9 calibrated states at the end (χ²(9) if consistent).
    pub nees_mean: f64,
}

/// Scores the last estimates against the truth row closest to their time.
pub fn score(res: &CalibResult, truth: &Truth) -> Option<Score> {
    let last = res.rows.last()?;
    let row = truth
        .t
        .iter()
        .enumerate()
        .min_by(|a, b| (a.1 - last.t).abs().total_cmp(&(b.1 - last.t).abs()))?
        .0;
    let bg = truth.vec3(["bgx", "bgy", "bgz"], row)?;
    let ba = truth.vec3(["bax", "bay", "baz"], row)?;
    // A mounting near a half turn has two rotation vectors: the one the estimate is near.
    let mu = nearest_equivalent(truth.vec3(["mux", "muy", "muz"], row)?, last.misalignment);
    let d = |e: [f64; 3], t: [f64; 3]| [e[0] - t[0], e[1] - t[1], e[2] - t[2]];
    let (eg, ea, em) = (
        d(last.gyro_bias, bg),
        d(last.accel_bias, ba),
        d(last.misalignment, mu),
    );
    let e = SVector::<f64, 9>::from_iterator(eg.iter().chain(ea.iter()).chain(em.iter()).copied());
    let nees = res
        .final_cov9
        .cholesky()
        .map(|c| e.dot(&c.solve(&e)))
        .unwrap_or(f64::NAN);
    Some(Score {
        gyro_bias: eg,
        accel_bias: ea,
        misalignment: em,
        nees_mean: nees,
    })
}
