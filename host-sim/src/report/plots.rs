//! SVG plots of the estimates with their ±3σ bands and the truth (in another colour)
//! when known: the whole run, the converged part framed on its own, and the error
//! against the truth with ±σ and ±3σ.

use crate::calib::run::EstimateRow;
use crate::plot::{Band, Figure, Panel, Series};
use crate::recording::Truth;
use crate::report::units::{sig3, ACCEL_BIAS, ANGLE, GYRO_BIAS};
use std::path::Path;

/// One plotted quantity: file stem, title, field getter, truth columns, display unit and scale.
struct Quantity {
    stem: &'static str,
    title: &'static str,
    get: fn(&EstimateRow) -> ([f64; 3], [f64; 3]),
    truth: [&'static str; 3],
    unit: &'static str,
    scale: f64,
}

const QUANTITIES: [Quantity; 4] = [
    Quantity {
        stem: "gyro_bias",
        title: "Gyro bias",
        get: |r| (r.gyro_bias, r.gyro_bias_sigma),
        truth: ["bgx", "bgy", "bgz"],
        unit: GYRO_BIAS.name,
        scale: GYRO_BIAS.scale,
    },
    Quantity {
        stem: "accel_bias",
        title: "Accelerometer bias",
        get: |r| (r.accel_bias, r.accel_bias_sigma),
        truth: ["bax", "bay", "baz"],
        unit: ACCEL_BIAS.name,
        scale: ACCEL_BIAS.scale,
    },
    Quantity {
        stem: "misalignment",
        title: "Misalignment",
        get: |r| (r.misalignment, r.misalignment_sigma),
        truth: ["mux", "muy", "muz"],
        unit: ANGLE.name,
        scale: ANGLE.scale,
    },
    Quantity {
        stem: "flexure",
        title: "Flexure angle",
        get: |r| (r.flexure, r.flexure_sigma),
        truth: ["thx", "thy", "thz"],
        unit: ANGLE.name,
        scale: ANGLE.scale,
    },
];

/// The first time from which every axis's σ stays within `CONVERGED_FACTOR` times its
/// final value: where the estimate has settled, and the framing of `_converged.svg`.
const CONVERGED_FACTOR: f64 = 3.0;

fn converged_from(rows: &[EstimateRow], q: &Quantity) -> usize {
    let Some(last) = rows.last() else { return 0 };
    let final_sigma = (q.get)(last).1;
    rows.iter()
        .rposition(|r| {
            let s = (q.get)(r).1;
            (0..3).any(|a| s[a] > CONVERGED_FACTOR * final_sigma[a])
        })
        .map_or(0, |i| (i + 1).min(rows.len() - 1))
}

/// The value of truth column `col` at `t`, linearly interpolated between the times
/// about index `k`, the first time at or after `t` (`times.partition_point(|&x| x < t)`).
fn truth_at(times: &[f64], col: &[f64], t: f64, k: usize) -> Option<f64> {
    match (k.checked_sub(1), times.get(k)) {
        (_, Some(&tk)) if tk == t => col.get(k).copied(),
        (Some(j), Some(&tk)) => {
            let (tj, vj, vk) = (*times.get(j)?, *col.get(j)?, *col.get(k)?);
            Some(vj + (vk - vj) * (t - tj) / (tk - tj))
        }
        _ => None,
    }
}

/// `times.partition_point(|&x| x < t)` for times asked in order: on sorted `times`, a
/// time at or after the last one asked starts from the last answer and walks on (the
/// rows and the truth advance together, a step or two each), which is the binary
/// search's answer; unsorted times, or a time before the last, take the binary search.
struct TimeCursor<'a> {
    times: &'a [f64],
    sorted: bool,
    last: Option<(f64, usize)>,
}

impl<'a> TimeCursor<'a> {
    fn new(times: &'a [f64]) -> Self {
        Self {
            times,
            sorted: times.windows(2).all(|w| w[0] <= w[1]),
            last: None,
        }
    }

    fn index(&mut self, t: f64) -> usize {
        let k = match self.last {
            Some((last_t, mut k)) if self.sorted && t >= last_t => {
                while self.times.get(k).is_some_and(|&x| x < t) {
                    k += 1;
                }
                k
            }
            _ => self.times.partition_point(|&x| x < t),
        };
        self.last = Some((t, k));
        k
    }
}

/// One panel per axis of quantity `q` over `rows`: the estimate (blue) with its ±3σ
/// band and the truth (red) when known.
fn estimate_panels(q: &Quantity, rows: &[EstimateRow], truth: Option<&Truth>) -> Vec<Panel> {
    let t: Vec<f64> = rows.iter().map(|r| r.t).collect();
    let (t0, t1) = (
        t.first().copied().unwrap_or(0.0),
        t.last().copied().unwrap_or(0.0),
    );
    let mut panels = Vec::new();
    for (axis, name) in ["x", "y", "z"].iter().enumerate() {
        let est: Vec<f64> = rows.iter().map(|r| (q.get)(r).0[axis] * q.scale).collect();
        let sig: Vec<f64> = rows.iter().map(|r| (q.get)(r).1[axis] * q.scale).collect();
        let mut series = vec![Series {
            name: "estimate".into(),
            x: t.clone(),
            y: est.clone(),
        }];
        if let Some(col) = truth.and_then(|tr| tr.column(q.truth[axis]).map(|c| (tr, c))) {
            let (tr, col) = col;
            let (x, y): (Vec<f64>, Vec<f64>) =
                tr.t.iter()
                    .zip(col)
                    .filter(|(x, _)| (t0..=t1).contains(*x))
                    .map(|(x, v)| (*x, v * q.scale))
                    .unzip();
            series.push(Series {
                name: "truth".into(),
                x,
                y,
            });
        }
        panels.push(Panel {
            title: format!(
                "{} {name}: final {} ± {} {}",
                q.title,
                sig3(*est.last().unwrap_or(&f64::NAN)),
                sig3(*sig.last().unwrap_or(&f64::NAN)),
                q.unit
            ),
            y_label: q.unit.to_string(),
            bands: vec![Band {
                name: "±3σ".into(),
                x: t.clone(),
                lo: est.iter().zip(&sig).map(|(e, s)| e - 3.0 * s).collect(),
                hi: est.iter().zip(&sig).map(|(e, s)| e + 3.0 * s).collect(),
            }],
            series,
            dashed: vec![],
        });
    }
    panels
}

/// One panel per axis of the error against the truth with its ±σ and ±3σ bands;
/// `None` when the truth lacks the quantity.
fn error_panels(q: &Quantity, rows: &[EstimateRow], truth: &Truth) -> Option<Vec<Panel>> {
    let mut panels = Vec::new();
    for (axis, name) in ["x", "y", "z"].iter().enumerate() {
        let col = truth.column(q.truth[axis])?;
        let (mut x, mut err, mut sig) = (Vec::new(), Vec::new(), Vec::new());
        let mut cursor = TimeCursor::new(&truth.t);
        for r in rows {
            if let Some(v) = truth_at(&truth.t, col, r.t, cursor.index(r.t)) {
                let (e, s) = (q.get)(r);
                x.push(r.t);
                err.push((e[axis] - v) * q.scale);
                sig.push(s[axis] * q.scale);
            }
        }
        let band = |name: &str, k: f64| Band {
            name: name.into(),
            x: x.clone(),
            lo: sig.iter().map(|s| -k * s).collect(),
            hi: sig.iter().map(|s| k * s).collect(),
        };
        panels.push(Panel {
            title: format!("{} {name}: estimate − truth", q.title),
            y_label: q.unit.to_string(),
            bands: vec![band("±σ", 1.0), band("±3σ", 3.0)],
            series: vec![Series {
                name: "error".into(),
                x: x.clone(),
                y: err,
            }],
            dashed: vec![],
        });
    }
    Some(panels)
}

/// The σ of the three axes of `q` as log₁₀ of its display unit, one panel: how fast each
/// state is observed, decades apart on one axis (the plot engine has linear axes, so
/// the axis carries log₁₀ σ and says so).
fn sigma_panels(q: &Quantity, rows: &[EstimateRow]) -> Vec<Panel> {
    let t: Vec<f64> = rows.iter().map(|r| r.t).collect();
    let series = ["x", "y", "z"]
        .iter()
        .enumerate()
        .map(|(axis, name)| Series {
            name: format!("σ {name}"),
            x: t.clone(),
            y: rows
                .iter()
                .map(|r| ((q.get)(r).1[axis] * q.scale).log10())
                .collect(),
        })
        .collect();
    vec![Panel {
        title: format!("{}: σ of each axis", q.title),
        y_label: format!("log₁₀ σ ({})", q.unit),
        series,
        bands: vec![],
        dashed: vec![],
    }]
}

/// Writes, for every quantity into `dir`: `<stem>.svg` (the whole run),
/// `<stem>_converged.svg` (framed from the time every σ is within 3 times its final
/// value), `<stem>_sigma.svg` (log₁₀ σ of each axis) and, with a truth, `<stem>_error.svg` (estimate − truth with ±σ and ±3σ).
/// Returns the files written.
pub fn write_estimate_plots(
    dir: &Path,
    label: &str,
    rows: &[EstimateRow],
    truth: Option<&Truth>,
) -> std::io::Result<Vec<String>> {
    let mut written = Vec::new();
    for q in &QUANTITIES {
        let from = converged_from(rows, q);
        let t_from = rows.get(from).map_or(0.0, |r| r.t);
        let figures = [
            (
                format!("{}.svg", q.stem),
                format!("{} — {label}", q.title),
                Some(estimate_panels(q, rows, truth)),
            ),
            (
                format!("{}_converged.svg", q.stem),
                format!(
                    "{} from t = {} s (σ within 3× its final value) — {label}",
                    q.title,
                    sig3(t_from)
                ),
                Some(estimate_panels(q, rows.get(from..).unwrap_or(rows), truth)),
            ),
            (
                format!("{}_sigma.svg", q.stem),
                format!("{}: σ on a log scale — {label}", q.title),
                Some(sigma_panels(q, rows)),
            ),
            (
                format!("{}_error.svg", q.stem),
                format!(
                    "{}: error against the truth from t = {} s — {label}",
                    q.title,
                    sig3(t_from)
                ),
                truth.and_then(|tr| error_panels(q, rows.get(from..).unwrap_or(rows), tr)),
            ),
        ];
        for (file, title, panels) in figures {
            let Some(panels) = panels else { continue };
            let fig = Figure {
                title,
                x_label: "t (s)".into(),
                panels,
            };
            fig.write(&dir.join(&file))?;
            written.push(file);
        }
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The cursor gives the binary search's index for times asked in order, out of
    /// order, repeated, between and beyond the times, on sorted times with repeats and on
    /// unsorted ones.
    #[test]
    fn the_time_cursor_is_the_binary_search() {
        let sorted = [0.0, 0.5, 0.5, 1.0, 2.0, 2.0, 2.0, 3.5];
        let unsorted = [0.0, 1.0, 0.5, 2.0, 1.5, 3.0];
        let asked = [
            -1.0,
            0.0,
            0.0,
            0.25,
            0.5,
            0.75,
            2.0,
            1.0,
            2.0,
            2.5,
            3.5,
            4.0,
            f64::NAN,
            0.5,
            9.0,
        ];
        for times in [&sorted[..], &unsorted[..], &[][..], &[1.0][..]] {
            let mut cursor = TimeCursor::new(times);
            for t in asked {
                assert_eq!(
                    cursor.index(t),
                    times.partition_point(|&x| x < t),
                    "{times:?} at {t}"
                );
            }
        }
    }
}
