//! `flexcal paper-figures`: the paper's figures 4 and 5 (accelerometer and gyro bias
//! estimates with and without dynamic lever-arm compensation) on one simulated run,
//! plus the final errors of both as a Markdown table.

use crate::calib::config::CalibConfig;
use crate::calib::run::{run as calibrate, EstimateRow, Precision};
use crate::calib::score::score;
use crate::cmd::common::ScenarioArgs;
use crate::plot::{Figure, Panel, Series};
use crate::sim::simulate;
use std::fmt::Write as _;
use std::path::PathBuf;

/// Arguments of `flexcal paper-figures`.
#[derive(clap::Args)]
pub struct Args {
    /// Scenario, duration, seed.
    #[command(flatten)]
    pub scenario: ScenarioArgs,
    /// Output directory (SVG figures and `table.md`).
    #[arg(long)]
    pub out: PathBuf,
}

fn figure(
    title: &str,
    unit: &str,
    scale: f64,
    get: fn(&EstimateRow) -> [f64; 3],
    with: &[EstimateRow],
    without: &[EstimateRow],
    truth: [f64; 3],
) -> Figure {
    let panel = |axis: usize| {
        let series = |rows: &[EstimateRow], name: &str| Series {
            name: name.into(),
            x: rows.iter().map(|r| r.t).collect(),
            y: rows.iter().map(|r| get(r)[axis] * scale).collect(),
        };
        let tx: Vec<f64> = with.iter().map(|r| r.t).collect();
        Panel {
            title: format!("{title} {}", ["x", "y", "z"][axis]),
            y_label: unit.into(),
            series: vec![series(with, "lever arm compensated")],
            bands: vec![],
            dashed: vec![
                series(without, "not compensated"),
                Series {
                    name: "truth".into(),
                    y: vec![truth[axis] * scale; tx.len()],
                    x: tx,
                },
            ],
        }
    };
    Figure {
        title: title.into(),
        x_label: "t (s)".into(),
        panels: (0..3).map(panel).collect(),
    }
}

/// Runs `flexcal paper-figures`.
pub fn run(a: &Args) -> Result<(), String> {
    let sc = a.scenario.load()?;
    let seed = a.scenario.seed;
    let rec = simulate(&sc, seed).recording;
    let truth = rec.truth.as_ref().ok_or("simulation wrote no truth")?;
    let cfg_with = CalibConfig::declared_for(&sc, 1.0 / sc.master.rate_hz);
    let cfg_without = CalibConfig {
        dynamic_lever_arm: false,
        ..cfg_with.clone()
    };
    let with = calibrate(&rec, &cfg_with, Precision::F64)?;
    let without = calibrate(&rec, &cfg_without, Precision::F64)?;
    let row0 = |names: [&str; 3]| truth.vec3(names, 0).unwrap_or([0.0; 3]);
    std::fs::create_dir_all(&a.out).map_err(|e| format!("{}: {e}", a.out.display()))?;
    let dph = 180.0 / std::f64::consts::PI * 3600.0;
    let mg = 1.0 / 9.806_65e-3;
    let f4 = figure(
        "Fig. 4: accelerometer bias",
        "mg",
        mg,
        |r| r.accel_bias,
        &with.rows,
        &without.rows,
        row0(["bax", "bay", "baz"]),
    );
    let f5 = figure(
        "Fig. 5: gyro bias",
        "deg/h",
        dph,
        |r| r.gyro_bias,
        &with.rows,
        &without.rows,
        row0(["bgx", "bgy", "bgz"]),
    );
    let stem = sc.name.clone();
    f4.write(&a.out.join(format!("fig4-accel-bias-{stem}.svg")))
        .map_err(|e| e.to_string())?;
    f5.write(&a.out.join(format!("fig5-gyro-bias-{stem}.svg")))
        .map_err(|e| e.to_string())?;
    let mut table = format!("Final errors on `{stem}` (seed {}, {} s)\n\n| model | gyro bias error x, y, z (deg/h) | accel bias error x, y, z (mg) | misalignment error x, y, z (arcsec) |\n|---|---|---|---|\n", seed, sc.duration_s);
    for (name, res) in [
        ("dynamic lever arm compensated", &with),
        ("not compensated", &without),
    ] {
        let s = score(res, truth).ok_or("no estimates")?;
        let f = |v: [f64; 3], k: f64| format!("{:.4}, {:.4}, {:.4}", v[0] * k, v[1] * k, v[2] * k);
        let _ = writeln!(
            table,
            "| {name} | {} | {} | {} |",
            f(s.gyro_bias, dph),
            f(s.accel_bias, mg),
            f(s.misalignment, dph)
        );
    }
    std::fs::write(a.out.join(format!("table-{stem}.md")), &table).map_err(|e| e.to_string())?;
    print!("{table}");
    Ok(())
}
