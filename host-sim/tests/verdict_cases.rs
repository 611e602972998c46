//! Issue 11, acceptance 1: recordings and configurations that parse but are physically
//! or semantically wrong get the verdict they deserve. Each case mutates one clean,
//! short simulated `moored` recording (40 s) in a temporary folder, runs what
//! `flexcal calibrate` runs (read, configuration, filter, verdict) through the library,
//! and checks the verdict's level and that the finding naming the cause is among the
//! warnings or failures (a cause may be a WARN whose consequences FAIL the run, e.g. a
//! 0.5 s clock offset). None may PASS. The clean recording itself must PASS (control).

use flexcal_sim::calib::config::CalibConfig;
use flexcal_sim::calib::run::Precision;
use flexcal_sim::cmd::calibrate::calibrate;
use flexcal_sim::cmd::common::ModelArgs;
use flexcal_sim::cmd::progress::Progress;
use flexcal_sim::recording::{write_recording, Recording};
use flexcal_sim::sim::{simulate, Scenario};
use flexcal_sim::verdict::{Level, Severity, Verdict};
use std::path::{Path, PathBuf};

/// Duration of the clean recording (s): long enough for every state's σ to fall below
/// 90% of its prior on `moored`, short enough for 40+ cases in seconds.
const DURATION_S: f64 = 40.0;

fn clean() -> (Recording, CalibConfig) {
    let mut sc = Scenario::load("moored").unwrap();
    sc.duration_s = DURATION_S;
    let cfg = CalibConfig::declared_for(&sc, 1.0 / sc.master.rate_hz);
    (simulate(&sc, 3).recording, cfg)
}

/// What a case changes: the recording in memory, then the files as text.
struct Case {
    name: &'static str,
    level: Level,
    code: &'static str,
    recording: fn(&mut Recording),
    config: fn(&mut CalibConfig),
    files: fn(&Path),
}

fn same_rec(_: &mut Recording) {}
fn same_cfg(_: &mut CalibConfig) {}
fn same_files(_: &Path) {}

fn case(name: &'static str, level: Level, code: &'static str) -> Case {
    Case {
        name,
        level,
        code,
        recording: same_rec,
        config: same_cfg,
        files: same_files,
    }
}

impl Case {
    fn rec(mut self, f: fn(&mut Recording)) -> Self {
        self.recording = f;
        self
    }
    fn cfg(mut self, f: fn(&mut CalibConfig)) -> Self {
        self.config = f;
        self
    }
    fn files(mut self, f: fn(&Path)) -> Self {
        self.files = f;
        self
    }
}

fn edit(dir: &Path, file: &str, f: impl FnOnce(String) -> String) {
    let p = dir.join(file);
    let text = std::fs::read_to_string(&p).unwrap();
    std::fs::write(&p, f(text)).unwrap();
}

/// Rotates a quaternion (scalar first) about body x by `a` rad.
fn rotate_x(q: [f64; 4], a: f64) -> [f64; 4] {
    let (c, s) = ((a / 2.0).cos(), (a / 2.0).sin());
    let [w, x, y, z] = q;
    [w * c - x * s, w * s + x * c, y * c + z * s, z * c - y * s]
}

fn cases() -> Vec<Case> {
    use Level::{Fail, Warn};
    vec![
        // Clocks and time spans.
        case("master clock 1000 s late", Fail, "time_no_overlap")
            .rec(|r| r.master.iter_mut().for_each(|m| m.t += 1000.0)),
        case("master clock 1000 s early", Fail, "time_no_overlap")
            .rec(|r| r.master.iter_mut().for_each(|m| m.t -= 1000.0)),
        case("master 2 s late", Fail, "master_time_offset")
            .rec(|r| r.master.iter_mut().for_each(|m| m.t += 2.0)),
        // Within the ±1 s search `calibrate` aligns the clocks before the filter: the
        // calibration holds, the recording's offset is still reported.
        case(
            "master 0.5 s late: aligned before the filter",
            Warn,
            "master_time_offset",
        )
        .rec(|r| r.master.iter_mut().for_each(|m| m.t += 0.5)),
        case("master 1.5 s early", Fail, "master_time_offset")
            .rec(|r| r.master.iter_mut().for_each(|m| m.t -= 1.5)),
        case(
            "master starts 25 s after the slave",
            Fail,
            "time_overlap_low",
        )
        .rec(|r| r.master.iter_mut().for_each(|m| m.t += 25.0)),
        // Messages stamped before the slave's first line are not handed to the engine.
        case(
            "master 30 s early: three quarters before the slave",
            Fail,
            "time_overlap_low",
        )
        .rec(|r| r.master.iter_mut().for_each(|m| m.t -= 30.0)),
        // A starting delay of −0.25 s at 100 Hz wants 25 messages queued, the queue
        // holds 8: every message is dropped or left queued, and the verdict says so.
        case(
            "a −0.25 s starting delay: the master queue overflows",
            Fail,
            "queue_dropped",
        )
        .cfg(|c| {
            c.effects = vec!["time_delay".into()];
            c.initial_delay_s = -0.25;
        }),
        case("master clock jumps 1000 s midway", Fail, "time_overlap_low").rec(|r| {
            let n = r.master.len() / 2;
            r.master.iter_mut().skip(n).for_each(|m| m.t += 1000.0)
        }),
        case("master time tags at half speed", Fail, "rate_mismatch")
            .rec(|r| r.master.iter_mut().for_each(|m| m.t *= 2.0)),
        case("slave time in milliseconds", Fail, "rate_mismatch").rec(|r| {
            r.imu_t0 *= 1000.0;
            r.imu.iter_mut().for_each(|s| s.t *= 1000.0)
        }),
        // Units of the slave.
        case(
            "slave angle increments in degrees",
            Fail,
            "slave_gyro_scale",
        )
        .rec(|r| {
            r.imu
                .iter_mut()
                .for_each(|s| s.dtheta_rad = s.dtheta_rad.map(f64::to_degrees))
        }),
        case(
            "slave rates written as increments",
            Fail,
            "slave_accel_scale",
        )
        .rec(|r| {
            r.imu.iter_mut().for_each(|s| {
                s.dtheta_rad = s.dtheta_rad.map(|v| v * 200.0);
                s.dv_mps = s.dv_mps.map(|v| v * 200.0);
            })
        }),
        case(
            "slave gyro rates written as increments",
            Fail,
            "slave_gyro_scale",
        )
        .rec(|r| {
            r.imu
                .iter_mut()
                .for_each(|s| s.dtheta_rad = s.dtheta_rad.map(|v| v * 200.0))
        }),
        case(
            "slave increments declared as rates",
            Fail,
            "slave_accel_scale",
        )
        .files(|d| {
            edit(d, "recording.toml", |t| {
                t.replace("\"increments\"", "\"rates\"")
            });
            edit(d, "slave_imu.csv", |t| {
                t.replacen("t,dthx,dthy,dthz,dvx,dvy,dvz", "t,gx,gy,gz,ax,ay,az", 1)
            });
        }),
        case(
            "slave velocity increments in g·s",
            Fail,
            "slave_accel_scale",
        )
        .rec(|r| {
            r.imu
                .iter_mut()
                .for_each(|s| s.dv_mps = s.dv_mps.map(|v| v / 9.806_65))
        }),
        case(
            "slave velocity increments in mm/s",
            Fail,
            "slave_accel_scale",
        )
        .rec(|r| {
            r.imu
                .iter_mut()
                .for_each(|s| s.dv_mps = s.dv_mps.map(|v| v * 1000.0))
        }),
        // Units of the master.
        case("master rate in deg/s", Fail, "master_rate_scale").rec(|r| {
            r.master.iter_mut().for_each(|m| {
                m.omega_ib_bm_radps = m.omega_ib_bm_radps.map(|w| w.map(f64::to_degrees))
            })
        }),
        case("master rate in deg/h", Fail, "master_rate_scale").rec(|r| {
            r.master.iter_mut().for_each(|m| {
                m.omega_ib_bm_radps = m
                    .omega_ib_bm_radps
                    .map(|w| w.map(|v| v.to_degrees() * 3600.0))
            })
        }),
        case(
            "master latitude and longitude in radians",
            Fail,
            "master_position_radians",
        )
        .rec(|r| {
            r.master.iter_mut().for_each(|m| {
                m.lat_deg = m.lat_deg.to_radians();
                m.lon_deg = m.lon_deg.to_radians();
            })
        }),
        case("site 2° of latitude from the master", Fail, "site_mismatch")
            .rec(|r| r.meta.site.lat_deg += 2.0),
        case("site 5 km from the master", Warn, "site_mismatch")
            .rec(|r| r.meta.site.lat_deg += 0.045),
        case("site height 1e6 m", Fail, "height_implausible").rec(|r| r.meta.site.height_m = 1e6),
        case("master height -50 km", Fail, "height_implausible")
            .rec(|r| r.master.iter_mut().for_each(|m| m.height_m = -50_000.0)),
        case("master velocity in km/h", Fail, "nis_out_of_band").rec(|r| {
            r.master
                .iter_mut()
                .for_each(|m| m.v_n_mps = m.v_n_mps.map(|v| v * 3.6))
        }),
        case(
            "master attitude jumps 30° once",
            Warn,
            "master_attitude_jump",
        )
        .rec(|r| {
            let k = r.master.len() / 2;
            r.master[k].q_bm_n = rotate_x(r.master[k].q_bm_n, 30f64.to_radians());
        }),
        case("master attitude written as q_n^b", Fail, "nis_out_of_band").rec(|r| {
            r.master.iter_mut().for_each(|m| {
                let [w, x, y, z] = m.q_bm_n;
                m.q_bm_n = [w, -x, -y, -z];
            })
        }),
        // Lever arm.
        case("lever arm 1e9 m", Fail, "lever_arm_implausible")
            .rec(|r| r.meta.lever_arm_m = [1e9, 0.0, 0.0]),
        case("lever arm in millimetres", Fail, "lever_arm_implausible")
            .rec(|r| r.meta.lever_arm_m = r.meta.lever_arm_m.map(|v| v * 1000.0)),
        case("lever arm sign flipped", Fail, "nis_out_of_band")
            .rec(|r| r.meta.lever_arm_m = r.meta.lever_arm_m.map(|v| -v)),
        case("lever arm x and y swapped", Fail, "nis_out_of_band").rec(|r| {
            let [x, y, z] = r.meta.lever_arm_m;
            r.meta.lever_arm_m = [y, x, z];
        }),
        // Gaps, rates, files.
        case("10 s slave gap", Fail, "slave_gap")
            .rec(|r| r.imu.retain(|s| !(10.0..20.0).contains(&s.t))),
        case("three slave samples missing", Warn, "slave_gap")
            .rec(|r| r.imu.retain(|s| !(10.0..10.02).contains(&s.t))),
        case("5 s master gap", Warn, "master_gap")
            .rec(|r| r.master.retain(|m| !(10.0..15.0).contains(&m.t))),
        case("slave rate_hz 4× wrong", Fail, "rate_mismatch").rec(|r| r.meta.slave_rate_hz *= 4.0),
        case("master rate_hz 4× wrong", Fail, "rate_mismatch")
            .rec(|r| r.meta.master_rate_hz /= 4.0),
        case("slave rate_hz 10% wrong", Warn, "rate_mismatch").rec(|r| r.meta.slave_rate_hz *= 1.1),
        case(
            "slave file cut in the middle of a number",
            Warn,
            "last_line_cut",
        )
        .files(|d| edit(d, "slave_imu.csv", |t| t[..t.len() - 4].to_string())),
        case(
            "master file cut in the middle of a number",
            Warn,
            "last_line_cut",
        )
        .files(|d| edit(d, "master.csv", |t| t[..t.len() - 6].to_string())),
        case("slave gyro x and y swapped", Fail, "nis_out_of_band").rec(|r| {
            r.imu.iter_mut().for_each(|s| {
                let [x, y, z] = s.dtheta_rad;
                s.dtheta_rad = [y, x, z];
            })
        }),
        case(
            "slave with MEMS-grade biases under the FOG model",
            Fail,
            "nis_out_of_band",
        )
        .rec(|r| {
            let (bg, ba) = (300f64.to_radians() / 3600.0, 0.02 * 9.806_65);
            let mut prev = r.imu_t0;
            r.imu.iter_mut().for_each(|s| {
                let dt = s.t - prev;
                prev = s.t;
                s.dtheta_rad = s.dtheta_rad.map(|v| v + bg * dt);
                s.dv_mps = s.dv_mps.map(|v| v + ba * dt);
            })
        }),
        // Configuration.
        case(
            "configuration with noise keys missing",
            Warn,
            "config_default_model",
        )
        .files(|d| {
            edit(d, "calibrate.toml", |t| {
                t.lines()
                    .filter(|l| !l.starts_with("gyro_arw") && !l.starts_with("velocity_noise"))
                    .collect::<Vec<_>>()
                    .join("\n")
            })
        }),
        case(
            "gyro ARW declared 100× too small",
            Warn,
            "config_noise_mismatch",
        )
        .cfg(|c| c.gyro_arw_rad_rs /= 100.0),
        case(
            "accelerometer VRW declared 1000× too large",
            Warn,
            "config_noise_mismatch",
        )
        .cfg(|c| c.accel_vrw_mps_rs *= 1000.0),
        case(
            "attitude noise declared 10× too small",
            Fail,
            "nis_out_of_band",
        )
        .cfg(|c| c.attitude_noise_rad = c.attitude_noise_rad.map(|v| v / 10.0)),
        case(
            "velocity noise declared 10× too large",
            Warn,
            "nis_out_of_band",
        )
        .cfg(|c| c.velocity_noise_mps = c.velocity_noise_mps.map(|v| v * 10.0)),
        case("innovation gate at 1σ", Fail, "gated_fraction_high").cfg(|c| c.gate_sigma = 1.0),
        case("gyro bias prior 1000× too tight", Warn, "sigma_not_falling")
            .cfg(|c| c.initial_gyro_bias_radps /= 1000.0),
    ]
}

/// What `flexcal calibrate` decides about the recording in `dir` (its estimates
/// written beside it).
fn verdict_of(dir: &Path) -> Result<Verdict, String> {
    let progress = Progress::start("calibrating");
    let c = calibrate(
        dir,
        None,
        &ModelArgs::default(),
        Precision::F64,
        &dir.join("estimates.csv"),
        &progress,
    )?;
    Ok(c.verdict)
}

fn write_case(root: &Path, i: usize, c: &Case, base: &(Recording, CalibConfig)) -> PathBuf {
    let dir = root.join(format!("case{i:02}"));
    let (mut rec, mut cfg) = base.clone();
    (c.recording)(&mut rec);
    (c.config)(&mut cfg);
    write_recording(&dir, &rec).unwrap();
    std::fs::write(dir.join("calibrate.toml"), toml::to_string(&cfg).unwrap()).unwrap();
    (c.files)(&dir);
    dir
}

#[test]
fn every_semantic_bad_input_gets_its_verdict() {
    let base = clean();
    let tmp = tempfile::tempdir().unwrap();
    let control = write_case(tmp.path(), 99, &case("clean", Level::Pass, ""), &base);
    let v = verdict_of(&control).unwrap();
    assert_eq!(
        v.level(),
        Level::Pass,
        "the clean recording:\n{}",
        v.lines().join("\n")
    );
    let cases = cases();
    assert!(cases.len() >= 40, "{} cases", cases.len());
    let mut wrong = Vec::new();
    for (i, c) in cases.iter().enumerate() {
        let dir = write_case(tmp.path(), i, c, &base);
        match verdict_of(&dir) {
            Ok(v) if v.level() == c.level && v.codes(Severity::Warn).contains(&c.code) => {}
            Ok(v) => wrong.push(format!(
                "{i:02} {}: expected {:?} with `{}`, got\n{}",
                c.name,
                c.level,
                c.code,
                v.lines().join("\n")
            )),
            Err(e) => wrong.push(format!("{i:02} {}: refused: {e}", c.name)),
        }
    }
    assert!(
        wrong.is_empty(),
        "{} case(s) wrong:\n{}",
        wrong.len(),
        wrong.join("\n")
    );
}

/// The binary end to end: a FAIL still writes its outputs, prints the verdict last,
/// puts it in `summary.json` and exits non-zero.
#[test]
fn fail_writes_outputs_prints_last_and_exits_non_zero() {
    let base = clean();
    let tmp = tempfile::tempdir().unwrap();
    let c = case("master clock 1000 s late", Level::Fail, "time_no_overlap")
        .rec(|r| r.master.iter_mut().for_each(|m| m.t += 1000.0));
    let dir = write_case(tmp.path(), 0, &c, &base);
    let out = tmp.path().join("cal");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_flexcal"))
        .arg("calibrate")
        .arg(&dir)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(!o.status.success());
    let stdout = String::from_utf8_lossy(&o.stdout);
    let verdict_line = stdout.lines().position(|l| l.starts_with("verdict: "));
    let findings_after =
        verdict_line.map(|i| stdout.lines().skip(i + 1).all(|l| l.starts_with("  ")));
    assert_eq!(findings_after, Some(true), "{stdout}");
    assert!(stdout.contains("verdict: FAIL"), "{stdout}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["verdict"]["level"], "FAIL");
    let codes: Vec<&str> = summary["verdict"]["findings"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|f| f["code"].as_str())
        .collect();
    assert!(
        codes.contains(&"time_no_overlap") && codes.contains(&"nothing_estimated"),
        "{codes:?}"
    );
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(report.contains("## Verdict: **FAIL**"), "{report}");
}

/// `montecarlo --runs 0` is refused instead of printing NaN.
#[test]
fn montecarlo_refuses_zero_runs() {
    let tmp = tempfile::tempdir().unwrap();
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_flexcal"))
        .args([
            "montecarlo",
            "--scenario",
            "matched",
            "--runs",
            "0",
            "--out",
        ])
        .arg(tmp.path())
        .output()
        .unwrap();
    let (stdout, stderr) = (
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr),
    );
    assert!(!o.status.success());
    assert!(stderr.contains("--runs must be at least 1"), "{stderr}");
    assert!(!stdout.contains("NaN"), "{stdout}");
}

/// `calibrate` reads the recording one sample at a time and keeps sums, not sequences:
/// its estimates, counters, residual statistics and verdict are those of the run over
/// the recording held in memory, and `estimates.csv` has a row per update.
#[test]
fn streaming_calibration_equals_the_one_in_memory() {
    use flexcal_sim::calib::residuals::channel_residuals;
    use flexcal_sim::calib::run::run;
    use flexcal_sim::recording::read_recording;
    use flexcal_sim::verdict::input::Scan;
    use flexcal_sim::verdict::of_calibration;

    let base = clean();
    let tmp = tempfile::tempdir().unwrap();
    let dir = write_case(tmp.path(), 0, &case("clean", Level::Pass, ""), &base);
    let estimates = tmp.path().join("estimates.csv");
    let progress = Progress::start("calibrating");
    let c = calibrate(
        &dir,
        None,
        &ModelArgs::default(),
        Precision::F64,
        &estimates,
        &progress,
    )
    .unwrap();
    let rec = read_recording(&dir).unwrap();
    let whole = run(&rec, &c.prepared.cfg, Precision::F64).unwrap();
    assert_eq!(format!("{:?}", c.res.last()), format!("{:?}", whole.last()));
    assert_eq!(
        format!("{:?}", c.res.counters),
        format!("{:?}", whole.counters)
    );
    let lines = std::fs::read_to_string(&estimates).unwrap().lines().count();
    assert_eq!(lines, whole.rows.len() + 1);
    let (a, b) = (
        c.res.summary.residuals(),
        channel_residuals(&whole.innovations),
    );
    assert_eq!(a.len(), b.len());
    for (a, b) in a.iter().zip(&b) {
        assert_eq!((a.count, a.nis_mean), (b.count, b.nis_mean));
        assert!((a.ljung_box_q - b.ljung_box_q).abs() <= 1e-9 * b.ljung_box_q);
    }
    let again = of_calibration(
        &mut Scan::of_dir(&dir).unwrap(),
        c.prepared.config_file.as_deref(),
        None,
        &c.prepared.cfg,
        &whole,
    );
    assert_eq!(again.lines(), c.verdict.lines());
}

/// An input finding names the exact line of its sample, comment lines counted.
#[test]
fn input_findings_name_the_exact_line() {
    use flexcal_sim::verdict::input::Scan;

    let mut base = clean();
    base.0.master[10].height_m = 1e6;
    let tmp = tempfile::tempdir().unwrap();
    let dir = write_case(tmp.path(), 0, &case("height", Level::Fail, ""), &base);
    let path = dir.join("master.csv");
    let text = std::fs::read_to_string(&path).unwrap();
    let (header, rest) = text.split_once('\n').unwrap();
    std::fs::write(&path, format!("{header}\n# a comment\n\n{rest}")).unwrap();
    let findings = Scan::of_dir(&dir).unwrap().findings();
    let f = findings
        .iter()
        .find(|f| f.code == "height_implausible")
        .unwrap();
    // Header, comment, blank line, then message 0 on line 4: message 10 is on line 14.
    assert!(
        f.location.starts_with("master.csv line 14 (t = "),
        "{}",
        f.location
    );
}
