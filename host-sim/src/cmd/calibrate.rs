//! `flexcal calibrate`: run the filter over a recording and write `summary.json`,
//! `estimates.csv` and plots of every estimate with its ±3σ band.

use crate::calib::config::CalibConfig;
use crate::calib::flexure_id::identify_flexure;
use crate::calib::run::{self as runner, Precision};
use crate::calib::score::score;
use crate::cmd::common::ModelArgs;
use crate::recording::read_recording;
use crate::report::{plots, summary};
use std::path::{Path, PathBuf};

/// Arguments of `flexcal calibrate`.
#[derive(clap::Args)]
pub struct Args {
    /// Recording directory (format v1).
    pub rec_dir: PathBuf,
    /// Output directory.
    #[arg(long)]
    pub out: PathBuf,
    /// Calibration configuration (TOML). Default: `REC_DIR/calibrate.toml` when the
    /// simulator wrote one, else the built-in configuration (the `moored` model).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Numeric precision of the engine.
    #[arg(long, value_enum, default_value = "f64")]
    pub precision: Precision,
    /// Model switches.
    #[command(flatten)]
    pub model: ModelArgs,
}

/// Identifies the flexure model when the configuration asks for it
/// (`identify_flexure`) and puts it in the configuration; returns where the model
/// came from. A failed identification keeps the configured model and says why.
pub fn choose_flexure(rec: &crate::recording::Recording, cfg: &mut CalibConfig) -> String {
    if !cfg.identify_flexure {
        return "configured".to_string();
    }
    match identify_flexure(rec, cfg) {
        Ok(id) => {
            cfg.flexure_axes = Some(
                id.axes
                    .clone()
                    .map(|a| [a.coefficients[0], a.coefficients[1], a.sigma_rad]),
            );
            let orders: Vec<String> = id.axes.iter().map(|a| a.order.to_string()).collect();
            let white: Vec<&str> = id
                .axes
                .iter()
                .map(|a| if a.white { "white" } else { "not white" })
                .collect();
            format!(
                "identified from the {} sequence (orders {}; residuals {})",
                id.sequence,
                orders.join(", "),
                white.join(", ")
            )
        }
        Err(e) => {
            eprintln!("flexcal: flexure identification failed, keeping the configured model: {e}");
            format!("configured (identification failed: {e})")
        }
    }
}

/// Resolves the configuration: explicit file, the recording's own, or the default.
pub fn resolve_config(
    rec_dir: &Path,
    explicit: Option<&Path>,
) -> Result<(CalibConfig, String), String> {
    if let Some(p) = explicit {
        return Ok((CalibConfig::load(p)?, p.display().to_string()));
    }
    let beside = rec_dir.join("calibrate.toml");
    if beside.exists() {
        return Ok((CalibConfig::load(&beside)?, beside.display().to_string()));
    }
    Ok((CalibConfig::default(), "built-in default".to_string()))
}

/// The configuration a command runs a recording with: resolved (`resolve_config`), the
/// model switches applied, angular-rate matching dropped when the master gives no rate,
/// the flexure identified when asked; says on stderr what it chose. Returns it with where
/// the flexure model came from.
pub fn prepare_config(
    rec: &crate::recording::Recording,
    rec_dir: &Path,
    explicit: Option<&Path>,
    model: &ModelArgs,
) -> Result<(CalibConfig, String), String> {
    let (mut cfg, origin) = resolve_config(rec_dir, explicit)?;
    model.apply(&mut cfg)?;
    if cfg.matching_flags().angular_rate && !rec.master_has_rate() {
        cfg.matching.retain(|m| m != "angular_rate");
        eprintln!("flexcal: the master gives no angular rate: angular-rate matching is off (velocity and attitude matching only)");
    }
    eprintln!("flexcal: configuration: {origin}");
    let flexure_source = choose_flexure(rec, &mut cfg);
    eprintln!("flexcal: flexure model: {flexure_source}");
    Ok((cfg, flexure_source))
}

/// Runs `flexcal calibrate`.
pub fn run(a: &Args) -> Result<(), String> {
    let rec = read_recording(&a.rec_dir).map_err(|e| e.to_string())?;
    let (cfg, flexure_source) = prepare_config(&rec, &a.rec_dir, a.config.as_deref(), &a.model)?;
    let res = runner::run(&rec, &cfg, a.precision)?;
    let sc = rec.truth.as_ref().and_then(|t| score(&res, t));
    std::fs::create_dir_all(&a.out).map_err(|e| format!("{}: {e}", a.out.display()))?;
    let duration = match (rec.imu.first(), rec.imu.last()) {
        (Some(_), Some(l)) => l.t - rec.imu_t0,
        _ => 0.0,
    };
    let doc = summary::summary_json(
        &a.rec_dir.display().to_string(),
        duration,
        &cfg,
        &flexure_source,
        &res,
        sc.as_ref(),
    );
    let text = serde_json::to_string_pretty(&doc).map_err(|e| e.to_string())?;
    let path = a.out.join("summary.json");
    std::fs::write(&path, text + "\n").map_err(|e| format!("{}: {e}", path.display()))?;
    summary::write_estimates_csv(&a.out.join("estimates.csv"), &res.rows)
        .map_err(|e| e.to_string())?;
    let label = a.rec_dir.display().to_string();
    plots::write_estimate_plots(&a.out, &label, &res.rows, rec.truth.as_ref())
        .map_err(|e| e.to_string())?;
    let last = res.last();
    let dph = 180.0 / std::f64::consts::PI * 3600.0;
    println!(
        "calibrated {} ({} s, {:?}) -> {}",
        label,
        duration,
        a.precision,
        a.out.display()
    );
    println!(
        "  gyro bias  (deg/h): {:?} ± {:?}",
        last.gyro_bias.map(|v| round(v * dph)),
        last.gyro_bias_sigma.map(|v| round(v * dph))
    );
    println!(
        "  accel bias (mg):    {:?} ± {:?}",
        last.accel_bias.map(|v| round(v / 9.806_65e-3)),
        last.accel_bias_sigma.map(|v| round(v / 9.806_65e-3))
    );
    println!(
        "  misalignment (deg): {:?} ± {:?}",
        last.misalignment.map(|v| round(v.to_degrees())),
        last.misalignment_sigma.map(|v| round(v.to_degrees()))
    );
    println!(
        "  NIS mean {:.3}, gated {}",
        res.nis_mean(),
        res.innovations.iter().filter(|i| !i.accepted).count()
    );
    if let Some(s) = sc {
        println!(
            "  errors: gyro bias {:?} deg/h, accel bias {:?} mg, NEES {:.2}",
            s.gyro_bias.map(|v| round(v * dph)),
            s.accel_bias.map(|v| round(v / 9.806_65e-3)),
            s.nees_mean
        );
    }
    Ok(())
}

fn round(v: f64) -> f64 {
    if v == 0.0 || !v.is_finite() {
        return v;
    }
    let mag = 10f64.powi(3 - v.abs().log10().ceil() as i32);
    (v * mag).round() / mag
}
