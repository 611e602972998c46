//! `flexcal calibrate`: run the filter over a recording and write `summary.json`,
//! `estimates.csv` and plots of every estimate with its ±3σ band.

use crate::calib::config::CalibConfig;
use crate::calib::flexure_id::identify_flexure;
use crate::calib::prefilter::{self, PreFilter, CLOCK_SEARCH_S, CLOCK_WINDOW_S};
use crate::calib::run::{run_into, CalibResult, Precision, RunOptions, Source};
use crate::calib::score::{score, Score};
use crate::cmd::common::ModelArgs;
use crate::cmd::progress::Progress;
use crate::learn::increments::IncrementNoise;
use crate::learn::{learn, model_toml, start_from_nothing, LearnOptions, Learned};
use crate::recording::{open_recording, read_recording, RecordingMeta, Truth, SLAVE_FILE};
use crate::report::markdown::{report_md, ReportInput};
use crate::report::stream::{read_truth, StreamSink};
use crate::report::summary::EstimatesCsv;
use crate::report::units::{list, Unit, ACCEL_BIAS, ANGLE, GYRO_BIAS};
use crate::report::{plots, summary};
use crate::verdict::input::Scan;
use crate::verdict::Verdict;
use flexcal_core::augment::Effect;
use std::cell::RefCell;
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
            cfg.flexure_gauss_markov = None;
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

/// Resolves the declared configuration: an explicit file, else the recording's own
/// `calibrate.toml`; `None` when the recording declares nothing (the model is learned).
pub fn resolve_config(
    rec_dir: &Path,
    explicit: Option<&Path>,
) -> Result<Option<(CalibConfig, PathBuf)>, String> {
    if let Some(p) = explicit {
        return Ok(Some((CalibConfig::load(p)?, p.to_path_buf())));
    }
    let beside = rec_dir.join("calibrate.toml");
    if beside.exists() {
        return Ok(Some((CalibConfig::load(&beside)?, beside)));
    }
    Ok(None)
}

/// The configuration a command runs a recording with, and where it came from.
pub struct Prepared {
    /// The configuration.
    pub cfg: CalibConfig,
    /// Where the flexure model came from.
    pub flexure_source: String,
    /// The model learned from the recording, when it was learned.
    pub learned: Option<Learned>,
    /// The configuration file declared (`--config`, else the recording's `calibrate.toml`).
    pub config_file: Option<PathBuf>,
    /// What was done before the filter (clocks, mounting).
    pub pre_filter: PreFilter,
    /// The master delay (s) the model was learned with, found before the filter
    /// (`prefilter::delay_to_learn_with`); it is in `cfg.initial_delay_s`.
    pub learned_with_delay_s: Option<f64>,
}

/// The steps before the filter on `rec` (`calib::prefilter`), written into `cfg` and
/// said on stderr.
fn pre_filter(
    rec: &crate::recording::Recording,
    cfg: &mut CalibConfig,
    learning: bool,
) -> PreFilter {
    let p = prefilter::prepare(rec, cfg, learning);
    for l in p.lines() {
        eprintln!("flexcal: {l}");
    }
    p
}

/// Learns the model of a recording from `start` and says on stderr what it found.
pub fn learn_and_say(
    rec: &crate::recording::Recording,
    start: &CalibConfig,
    origin: &str,
    inc: Option<IncrementNoise>,
) -> Result<Learned, String> {
    eprintln!("flexcal: learning the model from the recording, starting from the {origin}");
    let l = learn(rec, start, origin, inc, &LearnOptions::default())?;
    eprintln!(
        "flexcal: learned in {:.1} s ({} filter runs on the first {:.0} s): log-likelihood {:+.1} over the start; held-out -2 ln L {:.1} learned vs {:.1} start: {}",
        l.seconds,
        l.evaluations,
        l.window_s,
        l.log_likelihood_gain,
        l.holdout.learned.neg2ll,
        l.holdout.start.neg2ll,
        if l.adopted { "adopted" } else { "NOT adopted, the start is kept" }
    );
    if let Some(inc) = &l.increments {
        eprintln!(
            "flexcal:   from the increments ({:.0}-{:.0} Hz): gyro angle random walk {:.3e} rad/√s (axes {:.3e}), accelerometer white floor {:.3e} m/s/√s, velocity random walk along the arm {:.3e} m/s/√s{}",
            inc.band_from_hz,
            inc.band_to_hz,
            inc.gyro_arw(),
            inc.gyro_arw_rad_rs.map(|v| (v * 1e9).round() / 1e9)[0],
            inc.accel_floor(),
            inc.accel_vrw_mps_rs,
            if inc.accel_vrw_is_upper_bound { " (a bound)" } else { "" }
        );
    }
    match &l.mounting {
        Some(Ok(m)) => eprintln!(
            "flexcal:   mounting before the filter: [{:.3}, {:.3}, {:.3}]° (rotation vector, {} blocks, residual {:.2e} of {:.2e} rad per block)",
            m.rotation_vector_rad[0].to_degrees(),
            m.rotation_vector_rad[1].to_degrees(),
            m.rotation_vector_rad[2].to_degrees(),
            m.blocks,
            m.rms_residual_rad,
            m.rms_rotation_rad
        ),
        Some(Err(e)) => eprintln!("flexcal:   mounting not aligned before the filter (starts from zero): {e}"),
        None => {}
    }
    for v in &l.values {
        let sigma = v.sigma.map(|s| format!(" ± {s:.3e}")).unwrap_or_default();
        eprintln!(
            "flexcal:   {:<26} {:.4e}{sigma} (start {:.4e}, gain {:.1})",
            v.name, v.value, v.start, v.log_likelihood_gain
        );
    }
    Ok(l)
}

/// The configuration a command runs a recording with: the declared one (`--config`, else
/// the recording's `calibrate.toml`) taken as the truth about the data unless it says
/// `tune = true`; with `tune`, or when nothing is declared, the model is learned from the
/// recording (`crate::learn`). The model switches are applied first (the effects they add
/// are learned jointly), angular-rate matching is dropped when the master gives no rate,
/// and the flexure is identified when a declared configuration asks; says on stderr what
/// it chose. Before learning, the steps before the filter run (`calib::prefilter`), and
/// a master delay they find within the engine's reach is compensated while the model is
/// learned (`Prepared::learned_with_delay_s`), unless the start declares a delay.
pub fn prepare_config(
    rec: &crate::recording::Recording,
    rec_dir: &Path,
    explicit: Option<&Path>,
    model: &ModelArgs,
) -> Result<Prepared, String> {
    let declared = resolve_config(rec_dir, explicit)?;
    let config_file = declared.as_ref().map(|(_, p)| p.clone());
    let fixed = declared.as_ref().is_some_and(|(c, _)| !c.tune);
    if fixed {
        let Some((cfg, origin)) = declared else {
            return Err("internal: declared configuration vanished".into());
        };
        let mut cfg = apply_declared(cfg, &origin, model, rec.master_has_rate())?;
        let pre_filter = pre_filter(rec, &mut cfg, false);
        let flexure_source = choose_flexure(rec, &mut cfg);
        eprintln!("flexcal: flexure model: {flexure_source}");
        return Ok(Prepared {
            cfg,
            flexure_source,
            learned: None,
            config_file,
            pre_filter,
            learned_with_delay_s: None,
        });
    }
    let (nothing, inc) = start_from_nothing(rec);
    let inc = inc
        .map_err(|e| eprintln!("flexcal: IMU noise not read from the increments: {e}"))
        .ok();
    let (mut start, origin) = match declared {
        Some((c, o)) => (c, format!("{} (tune = true)", o.display())),
        None => {
            eprintln!("flexcal: no configuration given and none beside the recording");
            (nothing, "built-in default".to_string())
        }
    };
    model.apply(&mut start)?;
    drop_rate_matching_without_rate(rec.master_has_rate(), &mut start);
    let pre_filter = pre_filter(rec, &mut start, true);
    let declares_delay =
        start.initial_delay_s != 0.0 || start.effects.iter().any(|e| e == Effect::TimeDelay.name());
    let learned_with_delay_s =
        prefilter::delay_to_learn_with(&pre_filter).filter(|_| !declares_delay);
    if let Some(d) = learned_with_delay_s {
        start.initial_delay_s = d;
        eprintln!(
            "flexcal: the model is learned with the master's delay found before the filter compensated ({:+.1} ms, initial_delay_s)",
            1e3 * d
        );
    }
    let learned = learn_and_say(rec, &start, &origin, inc)?;
    Ok(Prepared {
        cfg: learned.config.clone(),
        flexure_source: format!(
            "learned from the recording ({})",
            if learned.adopted {
                "adopted"
            } else {
                "not adopted: start kept"
            }
        ),
        learned: Some(learned),
        config_file,
        pre_filter,
        learned_with_delay_s,
    })
}

/// A declared configuration taken as given: the model switches applied, angular-rate
/// matching dropped when the master gives no rate (`master_has_rate`); says its file.
fn apply_declared(
    mut cfg: CalibConfig,
    origin: &Path,
    model: &ModelArgs,
    master_has_rate: bool,
) -> Result<CalibConfig, String> {
    model.apply(&mut cfg)?;
    drop_rate_matching_without_rate(master_has_rate, &mut cfg);
    eprintln!("flexcal: configuration: {}", origin.display());
    Ok(cfg)
}

fn drop_rate_matching_without_rate(master_has_rate: bool, cfg: &mut CalibConfig) {
    if cfg.matching_flags().angular_rate && !master_has_rate {
        cfg.matching.retain(|m| m != "angular_rate");
        eprintln!("flexcal: the master gives no angular rate: angular-rate matching is off (velocity and attitude matching only)");
    }
}

/// A calibration of a recording folder, before its outputs other than
/// `estimates.csv` are written.
pub struct Calibration {
    /// The recording's description.
    pub meta: RecordingMeta,
    /// From the slave's first line to its last sample (s).
    pub duration_s: f64,
    /// Master messages in the recording.
    pub master_total: usize,
    /// How the configuration was chosen, and the configuration.
    pub prepared: Prepared,
    /// The run: every update's estimates thinned to
    /// [`THIN_CAPACITY`](crate::report::stream::THIN_CAPACITY) with the last kept, the
    /// innovations summed up, not kept.
    pub res: CalibResult,
    /// The truth thinned like the rows, for the plots, when the recording has one.
    pub truth: Option<Truth>,
    /// Errors against the truth.
    pub score: Option<Score>,
    /// The verdict.
    pub verdict: Verdict,
}

/// Whether the configuration of a calibration needs the whole recording in memory:
/// to learn the model (nothing declared, or `tune = true`) or to identify the flexure.
fn needs_whole_recording(declared: Option<&(CalibConfig, PathBuf)>, model: &ModelArgs) -> bool {
    match declared {
        Some((c, _)) => c.tune || c.identify_flexure || model.identify_flexure,
        None => true,
    }
}

/// Calibrates the recording in `dir` as `flexcal calibrate` does, writing
/// `estimates.csv` to `estimates` as the filter runs. The recording is read once, one
/// sample at a time, the checks of the verdict fed as it goes; only when the model is
/// learned or the flexure identified is it first read whole for that (and dropped
/// before the run).
pub fn calibrate(
    dir: &Path,
    explicit: Option<&Path>,
    model: &ModelArgs,
    precision: Precision,
    estimates: &Path,
    progress: &Progress,
) -> Result<Calibration, String> {
    let declared = resolve_config(dir, explicit)?;
    let mut stream = open_recording(dir).map_err(|e| e.to_string())?;
    let prepared = if needs_whole_recording(declared.as_ref(), model) {
        progress.phase("reading the whole recording to learn its model");
        let rec = read_recording(dir).map_err(|e| e.to_string())?;
        progress.phase("preparing the model");
        prepare_config(&rec, dir, explicit, model)?
    } else {
        let Some((cfg, origin)) = declared else {
            return Err("internal: declared configuration vanished".into());
        };
        let mut cfg = apply_declared(cfg, &origin, model, stream.master.has_rate())?;
        // The first seconds of the recording, read once more, unless the configuration
        // gives the clock offset and the mounting (then only the recording's rates are
        // read).
        let window = if cfg.master_clock_offset_s.is_some() && cfg.mounting_estimate_rad.is_some() {
            crate::recording::Recording {
                meta: stream.meta.clone(),
                imu_t0: stream.slave.t0(),
                imu: Vec::new(),
                master: Vec::new(),
                truth: None,
            }
        } else {
            progress.phase("aligning the clocks and the mounting");
            prefilter::read_window(dir, CLOCK_WINDOW_S + CLOCK_SEARCH_S + 1.0)?
        };
        progress.phase("searching the master's attitude for steps");
        // Against the master's rate over all its messages; without one, against the
        // slave's gyro over the window.
        let steps = prefilter::steps_step(
            prefilter::master_messages(dir)?,
            stream.master.has_rate(),
            &window,
            &mut cfg,
        );
        let pre_filter = prefilter::prepare_after_steps(&window, &mut cfg, false, steps);
        for l in pre_filter.lines() {
            eprintln!("flexcal: {l}");
        }
        eprintln!("flexcal: flexure model: configured");
        Prepared {
            cfg,
            flexure_source: "configured".into(),
            learned: None,
            config_file: Some(origin),
            pre_filter,
            learned_with_delay_s: None,
        }
    };
    let scan = RefCell::new(Scan::new(
        dir,
        stream.meta.clone(),
        stream.slave.t0(),
        stream.slave.line(),
    ));
    let slave_t0 = stream.slave.t0();
    let slave_bytes = std::fs::metadata(dir.join(SLAVE_FILE)).map_or(0, |m| m.len());
    progress.counted("filtering", slave_bytes);
    let slave = &mut stream.slave;
    let mut imu = std::iter::from_fn(|| match slave.next() {
        Some(Ok(s)) => {
            scan.borrow_mut().slave(&s, slave.line());
            progress.set(slave.bytes_read());
            Some(Ok(s))
        }
        Some(Err(e)) => Some(Err(e.to_string())),
        None => {
            scan.borrow_mut().slave_finished();
            None
        }
    });
    let master_reader = &mut stream.master;
    let mut master = std::iter::from_fn(|| match master_reader.next()? {
        Ok(m) => {
            scan.borrow_mut().master(&m, master_reader.line());
            Some(Ok(m))
        }
        Err(e) => Some(Err(e.to_string())),
    });
    let src = Source {
        imu_t0: slave_t0,
        lever_arm_m: stream.meta.lever_arm_m,
        imu: &mut imu,
        master: &mut master,
    };
    let csv =
        EstimatesCsv::create(estimates).map_err(|e| format!("{}: {e}", estimates.display()))?;
    let mut sink = StreamSink::new(csv);
    let end = run_into(
        src,
        &prepared.cfg,
        precision,
        &RunOptions::default(),
        &mut sink,
    )?;
    let (rows, effects) = sink
        .finish()
        .map_err(|e| format!("{}: {e}", estimates.display()))?;
    let res = end.into_result(rows, Vec::new(), effects);
    let mut scan = scan.into_inner();
    let (t0, t1) = scan.slave_span();
    let (truth, score) = match stream.truth {
        Some(reader) => {
            progress.phase("reading the truth");
            let t_end = res.rows.last().map_or(t1, |r| r.t);
            let (thinned, nearest) = read_truth(reader, t_end).map_err(|e| e.to_string())?;
            let sc = score(&res, &nearest);
            (Some(thinned), sc)
        }
        None => (None, None),
    };
    progress.phase("checking");
    let verdict = crate::verdict::of_calibration(
        &mut scan,
        prepared.config_file.as_deref(),
        prepared.learned.as_ref(),
        &prepared.cfg,
        &res,
    );
    Ok(Calibration {
        meta: stream.meta,
        duration_s: t1 - t0,
        master_total: scan.master_total(),
        prepared,
        res,
        truth,
        score,
        verdict,
    })
}

/// Runs `flexcal calibrate`.
pub fn run(a: &Args) -> Result<(), String> {
    std::fs::create_dir_all(&a.out).map_err(|e| format!("{}: {e}", a.out.display()))?;
    let progress = Progress::start("reading the recording");
    let c = calibrate(
        &a.rec_dir,
        a.config.as_deref(),
        &a.model,
        a.precision,
        &a.out.join("estimates.csv"),
        &progress,
    )?;
    progress.phase("writing the outputs");
    let Prepared {
        cfg,
        flexure_source,
        learned,
        config_file,
        pre_filter,
        ..
    } = &c.prepared;
    let (res, verdict, duration) = (&c.res, &c.verdict, c.duration_s);
    let doc = summary::summary_json(
        &a.rec_dir.display().to_string(),
        duration,
        cfg,
        flexure_source,
        res,
        c.score.as_ref(),
    );
    let mut doc = with_learned(doc, learned.as_ref());
    if let Some(obj) = doc.as_object_mut() {
        obj.insert("pre_filter".into(), pre_filter.json());
    }
    verdict.insert_into(&mut doc);
    if let Some(l) = learned {
        write_model_toml(&a.out, l)?;
    }
    super::common::write_json(&a.out.join("summary.json"), &doc)?;
    let label = a.rec_dir.display().to_string();
    let plot_files = plots::write_estimate_plots(&a.out, &label, &res.rows, c.truth.as_ref())
        .map_err(|e| e.to_string())?;
    let report = ReportInput {
        label: &label,
        meta: &c.meta,
        master_total: c.master_total,
        duration_s: duration,
        cfg,
        model_origin: model_origin(config_file.as_deref(), learned.as_ref()),
        flexure_source,
        score: c.score.as_ref(),
        plots: &plot_files,
    };
    let path = a.out.join("report.md");
    std::fs::write(&path, report_md(&report, res, verdict))
        .map_err(|e| format!("{}: {e}", path.display()))?;
    drop(progress);
    let last = res.last();
    println!(
        "calibrated {} ({} s, {:?}) -> {}",
        label,
        duration,
        a.precision,
        a.out.display()
    );
    let line = |name: &str, u: Unit, v: [f64; 3], s: [f64; 3]| {
        println!(
            "  {name:<13} ({}): [{}] ± [{}]",
            u.name,
            list(&v, u),
            list(&s, u)
        );
    };
    line("gyro bias", GYRO_BIAS, last.gyro_bias, last.gyro_bias_sigma);
    line(
        "accel bias",
        ACCEL_BIAS,
        last.accel_bias,
        last.accel_bias_sigma,
    );
    line(
        "misalignment",
        ANGLE,
        last.misalignment,
        last.misalignment_sigma,
    );
    println!(
        "  NIS mean {:.3}, gated {}",
        res.nis_mean(),
        res.summary.gated
    );
    for l in pre_filter.lines() {
        println!("  {l}");
    }
    for l in summary::master_lines(res) {
        println!("  {l}");
    }
    if let Some(s) = c.score {
        let f = |x: [f64; 3], u: Unit| list(&x, u);
        println!(
            "  errors: gyro bias [{}] {}, accel bias [{}] {}, misalignment [{}] {}, NEES {:.2}",
            f(s.gyro_bias, GYRO_BIAS),
            GYRO_BIAS.name,
            f(s.accel_bias, ACCEL_BIAS),
            ACCEL_BIAS.name,
            f(s.misalignment, ANGLE),
            ANGLE.name,
            s.nees_mean
        );
    }
    println!("  report: {}", path.display());
    verdict.conclude()
}

/// Adds the learned model (`learned_model`) to a `summary.json` document.
pub fn with_learned(mut doc: serde_json::Value, learned: Option<&Learned>) -> serde_json::Value {
    if let (Some(l), Some(obj)) = (learned, doc.as_object_mut()) {
        obj.insert(
            "learned_model".into(),
            serde_json::to_value(l).unwrap_or(serde_json::Value::Null),
        );
    }
    doc
}

/// Writes `model.toml` (the configuration calibrated with, loadable with `--config`).
pub fn write_model_toml(out: &Path, l: &Learned) -> Result<(), String> {
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let path = out.join("model.toml");
    std::fs::write(&path, model_toml(l)?).map_err(|e| format!("{}: {e}", path.display()))?;
    eprintln!("flexcal: model written to {}", path.display());
    Ok(())
}

/// Where the model of a run came from, in words: the configuration file, or learned
/// from the recording (adopted or not) from its start.
pub fn model_origin(config_file: Option<&Path>, learned: Option<&Learned>) -> String {
    match (learned, config_file) {
        (Some(l), _) => format!(
            "learned from the recording starting from the {} ({})",
            l.start_origin,
            if l.adopted {
                "adopted"
            } else {
                "not adopted: the start is kept"
            }
        ),
        (None, Some(p)) => format!("the configuration file `{}`", p.display()),
        (None, None) => "the built-in default".to_string(),
    }
}
