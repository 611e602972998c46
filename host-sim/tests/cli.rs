//! The `flexcal` binary end to end: the README's main job (simulate, calibrate) and
//! the measured recording with the shipped MEMS configuration (issue 2, acceptance 6).

use std::path::Path;
use std::process::Command;

fn flexcal() -> Command {
    Command::new(env!("CARGO_BIN_EXE_flexcal"))
}

fn workspace() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap()
}

fn check_summary(dir: &Path) -> serde_json::Value {
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    for key in [
        "tool_version",
        "recording",
        "duration_s",
        "precision",
        "model",
        "gyro_bias",
        "gyro_bias_sigma",
        "accel_bias",
        "accel_bias_sigma",
        "misalignment",
        "misalignment_sigma",
        "innovations",
    ] {
        assert!(v.get(key).is_some(), "summary.json lacks `{key}`");
    }
    let csv = std::fs::read_to_string(dir.join("estimates.csv")).unwrap();
    let header = csv.lines().next().unwrap();
    for col in ["t", "bgx", "bgx_sigma", "bax", "mux", "muz_sigma"] {
        assert!(
            header.split(',').any(|c| c == col),
            "estimates.csv lacks `{col}`"
        );
    }
    for svg in ["gyro_bias.svg", "accel_bias.svg", "misalignment.svg"] {
        assert!(dir.join(svg).exists(), "{svg} missing");
    }
    v
}

/// Simulates `moored` for `duration_s` into `dir/rec`, calibrates it into `dir/cal`
/// with the extra `calibrate` arguments, and returns the checked `summary.json`.
fn simulate_and_calibrate(
    dir: &Path,
    duration_s: &str,
    calibrate_args: &[&str],
) -> serde_json::Value {
    let (rec, out) = (dir.join("rec"), dir.join("cal"));
    let st = flexcal()
        .args([
            "simulate",
            "--scenario",
            "moored",
            "--duration",
            duration_s,
            "--out",
        ])
        .arg(&rec)
        .status()
        .unwrap();
    assert!(st.success());
    let st = flexcal()
        .arg("calibrate")
        .arg(&rec)
        .args(calibrate_args)
        .arg("--out")
        .arg(&out)
        .status()
        .unwrap();
    assert!(st.success());
    check_summary(&out)
}

#[test]
fn simulate_then_calibrate_writes_the_contract_outputs() {
    let tmp = tempfile::tempdir().unwrap();
    let v = simulate_and_calibrate(tmp.path(), "30", &[]);
    assert!(
        v["errors"]["nees_mean"].as_f64().unwrap().is_finite(),
        "truth was given: errors expected"
    );
    assert_eq!(v["model"]["states"], 21);
}

#[test]
fn calibrate_identifies_the_flexure_when_asked_and_says_so() {
    let tmp = tempfile::tempdir().unwrap();
    let v = simulate_and_calibrate(tmp.path(), "60", &["--identify-flexure"]);
    let source = v["model"]["flexure_source"].as_str().unwrap();
    assert!(
        source.starts_with("identified from the rate-integrated sequence"),
        "{source}"
    );
    let order = v["model"]["flexure_ar_order"].as_u64().unwrap();
    assert!(order <= 2, "the filter carries AR(2) at most, got {order}");
    let models = v["model"]["flexure_models"].as_array().unwrap();
    assert_eq!(models.len(), 3);
}

#[test]
fn measured_psins_recording_calibrates_with_the_mems_config() {
    let data = workspace().join("../shared/data/psins-vehicle-fog-mems");
    assert!(
        data.exists(),
        "the measured recording is expected at {}",
        data.display()
    );
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("psins");
    let st = flexcal()
        .arg("calibrate")
        .arg(&data)
        .arg("--config")
        .arg(workspace().join("configs/mems-vehicle.toml"))
        .arg("--out")
        .arg(&out)
        .status()
        .unwrap();
    assert!(st.success());
    let v = check_summary(&out);
    assert_eq!(
        v["model"]["matching"],
        serde_json::json!(["velocity", "attitude"])
    );
    assert!(v.get("errors").is_none(), "no truth: no errors");
    assert_eq!(v["covariance"]["not_positive_definite"], 0);
}
