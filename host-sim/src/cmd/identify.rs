//! `flexcal identify`: identify the flexure AR model (order by AIC/BIC, Ljung-Box check,
//! exact-ML refinement) from a recording or from one column of a CSV file, write
//! `OUT/identify.json` (`formats/outputs.md`) and `OUT/prediction.svg`, and print the AIC/BIC
//! table in the shape of the paper's Table 3.
//!
//! From a recording, the sequence of every slave axis is identified (`axes` in the JSON); the
//! top-level keys hold the axis chosen with `--axis`. When the recording carries truth, the
//! true flexure of that axis is identified too (`truth_reference`), and for an angle sequence
//! the figure compares the model's one-step prediction with the true flexure.

use crate::identify::report::{prediction_figure, report_json, table};
use crate::identify::{
    ar2_second_order, flexure_sequence_with, identify_series, one_step_prediction, read_series_csv,
    Criterion, IdentifyOptions, IdentifyReport, SequenceKind, SequenceOptions,
};
use crate::recording::read_recording;
use serde_json::{json, Map, Value};
use std::path::{Path, PathBuf};

/// Order-selection criterion on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum CriterionArg {
    /// Akaike: `n ln σ² + 2p` (the paper's eq. 12).
    Aic,
    /// Schwarz/Bayesian: `n ln σ² + p ln n`.
    Bic,
}

/// Slave body axis on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum AxisArg {
    /// Right.
    X,
    /// Forward.
    Y,
    /// Up.
    Z,
}

/// Samples shown in the prediction figure (the paper's Fig. 3 shows 200).
const FIGURE_SAMPLES: usize = 200;
/// Axis names, in order.
const AXES: [&str; 3] = ["x", "y", "z"];

/// Arguments of `flexcal identify`.
#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// Recording directory (format v1); or give `--series`.
    #[arg(required_unless_present = "series", conflicts_with = "series")]
    pub rec_dir: Option<PathBuf>,
    /// A CSV file holding the series to identify (header line, comma separated, `#` comments).
    #[arg(long)]
    pub series: Option<PathBuf>,
    /// The column of `--series` to identify (may be omitted if the file has one column).
    #[arg(long, requires = "series")]
    pub column: Option<String>,
    /// Output directory (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    /// Largest AR order fitted (0..=12).
    #[arg(long, default_value_t = 6)]
    pub max_order: usize,
    /// Criterion that selects the order.
    #[arg(long, value_enum, default_value = "aic")]
    pub criterion: CriterionArg,
    /// Ljung-Box lags m (more than the max order).
    #[arg(long, default_value_t = 20)]
    pub lags: usize,
    /// Ljung-Box significance level.
    #[arg(long, default_value_t = 0.05)]
    pub alpha: f64,
    /// Which sequence to identify from a recording.
    #[arg(long, value_enum, default_value = "rate-integrated")]
    pub sequence: SequenceKind,
    /// Axis reported at the top level of identify.json and in the figure.
    #[arg(long, value_enum, default_value = "x")]
    pub axis: AxisArg,
    /// Sample period of the sequence, s (a whole number of master periods; default: the
    /// master period, which is the filter period). For `--series`: the period used only to
    /// label the figure's time axis (default 1).
    #[arg(long)]
    pub period: Option<f64>,
    /// Cut-off (Hz) of the zero-phase low-pass applied to the master rate by the
    /// `rate-integrated` sequence; 0 disables it.
    #[arg(long, default_value_t = 2.0)]
    pub master_lowpass: f64,
    /// Do not remove the mean of the series before fitting.
    #[arg(long)]
    pub no_demean: bool,
    /// Skip the exact maximum-likelihood refinement.
    #[arg(long)]
    pub no_exact_ml: bool,
    /// Also write the prediction figure (SVG) to this path.
    #[arg(long)]
    pub figure: Option<PathBuf>,
}

impl Args {
    /// The identification options these arguments ask for.
    pub fn options(&self) -> IdentifyOptions {
        IdentifyOptions {
            max_order: self.max_order,
            criterion: match self.criterion {
                CriterionArg::Aic => Criterion::Aic,
                CriterionArg::Bic => Criterion::Bic,
            },
            lags: self.lags,
            alpha: self.alpha,
            demean: !self.no_demean,
            exact_ml: !self.no_exact_ml,
        }
    }
}

fn axis_index(a: AxisArg) -> usize {
    match a {
        AxisArg::X => 0,
        AxisArg::Y => 1,
        AxisArg::Z => 2,
    }
}

/// Puts the keys of `report` at the top of `obj` (after the ones already there).
fn merge(obj: &mut Map<String, Value>, report: Value) {
    if let Value::Object(m) = report {
        for (k, v) in m {
            obj.insert(k, v);
        }
    }
}

/// A window of [`FIGURE_SAMPLES`] samples from the middle of `x`, skipping NaN predictions.
fn window(len: usize) -> std::ops::Range<usize> {
    let start = (len / 2).min(len.saturating_sub(FIGURE_SAMPLES));
    start..(start + FIGURE_SAMPLES).min(len)
}

fn write_outputs(a: &Args, json: &Value, fig: &crate::plot::Figure) -> Result<(), String> {
    std::fs::create_dir_all(&a.out).map_err(|e| format!("{}: {e}", a.out.display()))?;
    super::common::write_json(&a.out.join("identify.json"), json)?;
    let svg = a.out.join("prediction.svg");
    fig.write(&svg)
        .map_err(|e| format!("{}: {e}", svg.display()))?;
    if let Some(extra) = &a.figure {
        if let Some(dir) = extra.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        }
        fig.write(extra)
            .map_err(|e| format!("{}: {e}", extra.display()))?;
    }
    Ok(())
}

/// Runs `flexcal identify`.
pub fn run(a: &Args) -> Result<(), String> {
    let opts = a.options();
    match (&a.rec_dir, &a.series) {
        (Some(_), Some(_)) => Err("give either a recording directory or --series, not both".into()),
        (None, None) => Err("give a recording directory or --series FILE.csv".into()),
        (None, Some(file)) => run_series(a, &opts, file),
        (Some(dir), None) => run_recording(a, &opts, dir),
    }
}

fn run_series(a: &Args, opts: &IdentifyOptions, file: &Path) -> Result<(), String> {
    let col = read_series_csv(file, a.column.as_deref())?;
    let rep = identify_series(&col.values, opts)
        .map_err(|e| format!("{}, column {}: {e}", file.display(), col.name))?;
    let mut obj = Map::new();
    obj.insert("tool_version".into(), json!(super::TOOL_VERSION));
    obj.insert(
        "input".into(),
        json!({ "kind": "series", "path": file.display().to_string(), "column": col.name }),
    );
    merge(&mut obj, report_json(&rep));
    let json = Value::Object(obj);
    say(&table(
        &rep,
        &format!("{} column {}", file.display(), col.name),
    ));
    let period = a.period.unwrap_or(1.0);
    let y: Vec<f64> = col.values.iter().map(|v| v - rep.mean_removed).collect();
    let coeffs = rep
        .selected()
        .map(|r| r.coefficients.clone())
        .unwrap_or_default();
    let pred = one_step_prediction(&y, &coeffs);
    let w = window(y.len());
    let t: Vec<f64> = w.clone().map(|k| k as f64 * period).collect();
    let fig = prediction_figure(
        &format!(
            "{}: AR({}) one-step prediction ({} samples)",
            col.name,
            rep.selected_order,
            w.len()
        ),
        &t,
        y.get(w.clone()).unwrap_or_default(),
        pred.get(w).unwrap_or_default(),
        &format!("{} (demeaned)", col.name),
        "prediction",
        1.0,
        &col.name,
    );
    write_outputs(a, &json, &fig)?;
    say(&format!(
        "wrote {}\n",
        a.out.join("identify.json").display()
    ));
    Ok(())
}

fn run_recording(a: &Args, opts: &IdentifyOptions, dir: &Path) -> Result<(), String> {
    let rec = read_recording(dir).map_err(|e| e.to_string())?;
    let period = match a.period {
        Some(p) => p,
        None => 1.0 / rec.meta.master_rate_hz,
    };
    let seq_opts = SequenceOptions {
        master_lowpass_hz: a.master_lowpass,
    };
    let seq = flexure_sequence_with(&rec, a.sequence, period, &seq_opts)?;
    let ax = axis_index(a.axis);
    let mut axes_json = Map::new();
    let mut reports: Vec<Option<IdentifyReport>> = Vec::new();
    for (i, name) in AXES.iter().enumerate() {
        let x = seq.axes.get(i).map(Vec::as_slice).unwrap_or_default();
        match identify_series(x, opts) {
            Ok(r) => {
                let mark = if i == ax { " (reported axis)" } else { "" };
                say(&table(
                    &r,
                    &format!(
                        "{}: sequence {}, axis {name}{mark}, period {period} s",
                        dir.display(),
                        seq.kind.name()
                    ),
                ));
                let mut j = report_json(&r);
                if let Some(line) = second_order_line(&r, period, &mut j) {
                    say(&format!("{line}\n"));
                }
                axes_json.insert((*name).into(), j);
                reports.push(Some(r));
            }
            Err(e) => {
                if i == ax {
                    return Err(format!(
                        "{}: sequence {}, axis {name}: {e}",
                        dir.display(),
                        seq.kind.name()
                    ));
                }
                eprintln!("flexcal: axis {name}: {e}");
                axes_json.insert((*name).into(), json!({ "error": e }));
                reports.push(None);
            }
        }
    }
    let rep = reports
        .get(ax)
        .and_then(Option::as_ref)
        .ok_or("internal: reported axis missing")?;
    let mut obj = Map::new();
    obj.insert("tool_version".into(), json!(super::TOOL_VERSION));
    obj.insert(
        "input".into(),
        json!({ "kind": "recording", "path": dir.display().to_string() }),
    );
    obj.insert("sequence".into(), json!(seq.kind.name()));
    obj.insert("sequence_unit".into(), json!(seq.kind.unit()));
    obj.insert("sequence_notes".into(), json!(seq.notes));
    obj.insert("period_s".into(), json!(period));
    obj.insert("master_lowpass_hz".into(), json!(a.master_lowpass));
    obj.insert("axis".into(), json!(AXES.get(ax).copied().unwrap_or("x")));
    merge(&mut obj, report_json(rep));
    if let Some(v) = axes_json
        .get(AXES.get(ax).copied().unwrap_or("x"))
        .and_then(|a| a.get("ar2_second_order"))
    {
        obj.insert("ar2_second_order".into(), v.clone());
    }
    obj.insert("axes".into(), Value::Object(axes_json));

    // The true flexure, when the recording has it: reference identification and figure data.
    let truth = if rec.truth.is_some() {
        Some(flexure_sequence_with(
            &rec,
            SequenceKind::Truth,
            period,
            &seq_opts,
        )?)
    } else {
        None
    };
    let truth_axis: Option<Vec<f64>> = truth.as_ref().and_then(|t| t.axes.get(ax).cloned());
    if let (Some(th), true) = (&truth_axis, a.sequence != SequenceKind::Truth) {
        match identify_series(th, opts) {
            Ok(r) => {
                say(&table(
                    &r,
                    &format!(
                        "reference: true flexure, axis {}",
                        AXES.get(ax).copied().unwrap_or("x")
                    ),
                ));
                let mut j = report_json(&r);
                if let Some(line) = second_order_line(&r, period, &mut j) {
                    say(&format!("{line}\n"));
                }
                obj.insert("truth_reference".into(), j);
            }
            Err(e) => {
                obj.insert("truth_reference".into(), json!({ "error": e }));
            }
        }
        if seq.kind.unit() == "rad" {
            obj.insert(
                "sequence_vs_truth".into(),
                compare_to_truth(
                    &seq.t,
                    seq.axes.get(ax),
                    truth.as_ref().map(|t| (&t.t, t.axes.get(ax))),
                ),
            );
        }
    }

    // Figure: the identified model's one-step prediction of the true flexure (angle sequences
    // with truth), else of the identified sequence itself.
    let coeffs = rep
        .selected()
        .map(|r| r.coefficients.clone())
        .unwrap_or_default();
    let axis_name = AXES.get(ax).copied().unwrap_or("x");
    let (t_all, y, label) = match (&truth, &truth_axis, seq.kind.unit() == "rad") {
        (Some(tr), Some(th), true) => {
            let mean = finite_mean(th);
            (
                tr.t.clone(),
                th.iter().map(|v| v - mean).collect::<Vec<f64>>(),
                format!("true flexure θ{axis_name}"),
            )
        }
        _ => {
            let x = seq.axes.get(ax).cloned().unwrap_or_default();
            let mean = finite_mean(&x);
            (
                seq.t.clone(),
                x.iter().map(|v| v - mean).collect(),
                format!("{} {axis_name}", seq.kind.name()),
            )
        }
    };
    let pred = one_step_prediction(&y, &coeffs);
    let w = window(y.len());
    let (scale, unit) = match seq.kind.unit() {
        "rad" => (1e6, "µrad"),
        _ => (1e6, "µrad/s"),
    };
    let fig = prediction_figure(
        &format!(
            "{}: AR({}) identified from `{}`, one-step prediction over {} samples",
            dir.display(),
            rep.selected_order,
            seq.kind.name(),
            w.len()
        ),
        t_all.get(w.clone()).unwrap_or_default(),
        y.get(w.clone()).unwrap_or_default(),
        pred.get(w).unwrap_or_default(),
        &label,
        &format!("AR({}) prediction", rep.selected_order),
        scale,
        unit,
    );
    write_outputs(a, &Value::Object(obj), &fig)?;
    say(&format!(
        "wrote {}\n",
        a.out.join("identify.json").display()
    ));
    Ok(())
}

/// Adds `ar2_second_order` (the order-2 fit read as a sampled second-order system) to a report
/// object and returns the line to print, if that fit exists and has complex poles.
fn second_order_line(r: &IdentifyReport, period: f64, j: &mut Value) -> Option<String> {
    let c = &r.order(2)?.coefficients;
    let (a1, a2) = (*c.first()?, *c.get(1)?);
    let (wn, zeta) = ar2_second_order(a1, a2, period)?;
    if let Value::Object(m) = j {
        m.insert(
            "ar2_second_order".into(),
            json!({ "omega_n_rad_s": wn, "zeta": zeta, "period_s": period }),
        );
    }
    Some(format!(
        "  AR(2) as a sampled second-order system: omega_n = {wn:.4} rad/s, zeta = {zeta:.4}"
    ))
}

/// Writes to standard output, ignoring a closed pipe (e.g. `| head`): the results are in the
/// files, the printout is a courtesy.
fn say(text: &str) {
    use std::io::Write as _;
    let _ = std::io::stdout().lock().write_all(text.as_bytes());
}

fn finite_mean(x: &[f64]) -> f64 {
    let (s, n) = x
        .iter()
        .filter(|v| v.is_finite())
        .fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    if n > 0 {
        s / n as f64
    } else {
        0.0
    }
}

/// How far an angle sequence is from the true flexure at the same instants: RMS of the truth,
/// RMS of the difference (both demeaned), and their correlation.
fn compare_to_truth(
    t: &[f64],
    seq: Option<&Vec<f64>>,
    truth: Option<(&Vec<f64>, Option<&Vec<f64>>)>,
) -> Value {
    let (Some(seq), Some((tt, Some(th)))) = (seq, truth) else {
        return Value::Null;
    };
    // Pair samples by time (both grids are master-message boundaries).
    let mut pairs = Vec::new();
    let mut j = 0usize;
    for (i, &ti) in t.iter().enumerate() {
        while tt.get(j).is_some_and(|&v| v < ti - 1e-9) {
            j += 1;
        }
        if let (Some(&tj), Some(&a), Some(&b)) = (tt.get(j), seq.get(i), th.get(j)) {
            if (tj - ti).abs() < 1e-6 && a.is_finite() && b.is_finite() {
                pairs.push((a, b));
            }
        }
    }
    if pairs.len() < 2 {
        return Value::Null;
    }
    let n = pairs.len() as f64;
    let ma = pairs.iter().map(|p| p.0).sum::<f64>() / n;
    let mb = pairs.iter().map(|p| p.1).sum::<f64>() / n;
    let (mut saa, mut sbb, mut sab, mut sdd) = (0.0, 0.0, 0.0, 0.0);
    for (a, b) in &pairs {
        let (da, db) = (a - ma, b - mb);
        saa += da * da;
        sbb += db * db;
        sab += da * db;
        sdd += (da - db) * (da - db);
    }
    json!({
        "samples": pairs.len(),
        "truth_rms": (sbb / n).sqrt(),
        "error_rms": (sdd / n).sqrt(),
        "correlation": if saa > 0.0 && sbb > 0.0 { sab / (saa * sbb).sqrt() } else { 0.0 },
    })
}
