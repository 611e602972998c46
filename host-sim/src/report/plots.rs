//! SVG plots of the estimates with their ±3σ bands, and the truth when known.

use crate::calib::run::EstimateRow;
use crate::plot::{Band, Figure, Panel, Series};
use crate::recording::Truth;
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
        unit: "deg/h",
        scale: 180.0 / std::f64::consts::PI * 3600.0,
    },
    Quantity {
        stem: "accel_bias",
        title: "Accelerometer bias",
        get: |r| (r.accel_bias, r.accel_bias_sigma),
        truth: ["bax", "bay", "baz"],
        unit: "mg",
        scale: 1.0 / 9.806_65e-3,
    },
    Quantity {
        stem: "misalignment",
        title: "Misalignment",
        get: |r| (r.misalignment, r.misalignment_sigma),
        truth: ["mux", "muy", "muz"],
        unit: "arcmin",
        scale: 180.0 / std::f64::consts::PI * 60.0,
    },
    Quantity {
        stem: "flexure",
        title: "Flexure angle",
        get: |r| (r.flexure, r.flexure_sigma),
        truth: ["thx", "thy", "thz"],
        unit: "arcmin",
        scale: 180.0 / std::f64::consts::PI * 60.0,
    },
];

/// Writes `<stem>.svg` for every quantity into `dir`; returns the files written.
pub fn write_estimate_plots(
    dir: &Path,
    label: &str,
    rows: &[EstimateRow],
    truth: Option<&Truth>,
) -> std::io::Result<Vec<String>> {
    let mut written = Vec::new();
    let t: Vec<f64> = rows.iter().map(|r| r.t).collect();
    for q in &QUANTITIES {
        let mut panels = Vec::new();
        for (axis, name) in ["x", "y", "z"].iter().enumerate() {
            let est: Vec<f64> = rows.iter().map(|r| (q.get)(r).0[axis] * q.scale).collect();
            let sig: Vec<f64> = rows.iter().map(|r| (q.get)(r).1[axis] * q.scale).collect();
            let mut dashed = Vec::new();
            if let Some(tr) = truth {
                if let Some(col) = tr.column(q.truth[axis]) {
                    dashed.push(Series {
                        name: "truth".into(),
                        x: tr.t.clone(),
                        y: col.iter().map(|v| v * q.scale).collect(),
                    });
                }
            }
            panels.push(Panel {
                title: format!("{} {name}", q.title),
                y_label: q.unit.to_string(),
                bands: vec![Band {
                    name: "±3σ".into(),
                    x: t.clone(),
                    lo: est.iter().zip(&sig).map(|(e, s)| e - 3.0 * s).collect(),
                    hi: est.iter().zip(&sig).map(|(e, s)| e + 3.0 * s).collect(),
                }],
                series: vec![Series {
                    name: "estimate".into(),
                    x: t.clone(),
                    y: est,
                }],
                dashed,
            });
        }
        let fig = Figure {
            title: format!("{} — {label}", q.title),
            x_label: "t (s)".into(),
            panels,
        };
        let file = format!("{}.svg", q.stem);
        fig.write(&dir.join(&file))?;
        written.push(file);
    }
    Ok(written)
}
