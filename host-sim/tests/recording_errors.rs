//! Every way a recording can break the contract gives the right error kind,
//! and a message naming the file and the line, column or key.

use std::path::Path;

use flexcal_sim::recording::{
    read_recording, write_recording, ErrorKind, ImuOutput, Recording, RecordingError, Truth,
};
use tempfile::TempDir;

const META: &str = r#"format = "slave-ins-recording"
version = 1

[site]
lat_deg = 37.5
lon_deg = 121.4
height_m = 0.0

[lever_arm]
r0_m = [10.0, 4.0, 15.0]

[slave_imu]
rate_hz = 100.0
output = "increments"

[master]
rate_hz = 10.0
"#;

const SLAVE: &str = "t,dthx,dthy,dthz,dvx,dvy,dvz
0,0,0,0,0,0,0
0.01,1e-5,2e-5,3e-5,0.001,0.002,0.098
0.02,1e-5,2e-5,3e-5,0.001,0.002,0.098
";

const MASTER: &str = "t,qw,qx,qy,qz,ve,vn,vu,lat_deg,lon_deg,height_m
0.0,1,0,0,0,0,0,0,37.5,121.4,0
0.1,0.7071067811865476,0,0,0.7071067811865476,0,0,0,37.5,121.4,0
";

/// A recording folder: the valid files above, with `changes` applied
/// (`Some(text)` replaces or adds a file, `None` removes it).
fn folder(changes: &[(&str, Option<&str>)]) -> TempDir {
    let dir = tempfile::tempdir().unwrap();
    let mut files = vec![
        ("recording.toml", Some(META)),
        ("slave_imu.csv", Some(SLAVE)),
        ("master.csv", Some(MASTER)),
    ];
    for &(name, text) in changes {
        match files.iter_mut().find(|(n, _)| *n == name) {
            Some(entry) => entry.1 = text,
            None => files.push((name, text)),
        }
    }
    for (name, text) in files {
        if let Some(text) = text {
            std::fs::write(dir.path().join(name), text).unwrap();
        }
    }
    dir
}

/// The error from reading the folder with `changes`.
fn error(changes: &[(&str, Option<&str>)]) -> RecordingError {
    let dir = folder(changes);
    match read_recording(dir.path()) {
        Ok(_) => panic!("expected an error for {changes:?}"),
        Err(e) => e,
    }
}

/// The message contains every one of `parts`.
fn assert_message(err: &RecordingError, parts: &[&str]) {
    let msg = err.to_string();
    for part in parts {
        assert!(msg.contains(part), "message {msg:?} lacks {part:?}");
    }
    assert!(!msg.contains('\n'), "message {msg:?} spans lines");
}

fn replace(text: &str, from: &str, to: &str) -> String {
    assert!(text.contains(from), "{from:?} not in fixture");
    text.replacen(from, to, 1)
}

#[test]
fn valid_fixture_reads() {
    let dir = folder(&[]);
    let rec = read_recording(dir.path()).unwrap();
    assert_eq!(rec.imu_t0, 0.0);
    assert_eq!(rec.imu.len(), 2);
    assert_eq!(rec.imu[0].dtheta_rad, [1e-5, 2e-5, 3e-5]);
    assert_eq!(rec.master.len(), 2);
    assert!(!rec.master_has_rate());
    assert!(rec.truth.is_none());
    assert_eq!(rec.meta.lever_arm_m, [10.0, 4.0, 15.0]);
    assert_eq!(rec.meta.notes, None);
}

#[test]
fn missing_file() {
    let err = error(&[("master.csv", None)]);
    assert!(matches!(err.kind(), ErrorKind::MissingFile));
    assert_message(&err, &["master.csv", "file not found"]);
    let err = error(&[("recording.toml", None)]);
    assert!(matches!(err.kind(), ErrorKind::MissingFile));
    assert_message(&err, &["recording.toml"]);
}

#[test]
fn unreadable_file_is_io_error() {
    let dir = folder(&[("slave_imu.csv", None)]);
    std::fs::create_dir(dir.path().join("slave_imu.csv")).unwrap();
    let err = read_recording(dir.path()).unwrap_err();
    assert!(matches!(err.kind(), ErrorKind::Io(_)));
    assert_message(&err, &["slave_imu.csv", "i/o error"]);
}

#[test]
fn not_utf8() {
    let dir = folder(&[]);
    let mut bytes = SLAVE.as_bytes().to_vec();
    bytes.extend_from_slice(b"0.03,\xff,0,0,0,0,0\n");
    std::fs::write(dir.path().join("slave_imu.csv"), bytes).unwrap();
    let err = read_recording(dir.path()).unwrap_err();
    assert!(matches!(err.kind(), ErrorKind::NotUtf8));
    assert_message(&err, &["slave_imu.csv", "line 5"]);
}

#[test]
fn unreadable_toml() {
    let meta = replace(META, "[site]", "[site");
    let err = error(&[("recording.toml", Some(&meta))]);
    assert!(matches!(err.kind(), ErrorKind::Toml(_)));
    assert_message(&err, &["recording.toml", "line 4", "unreadable TOML"]);
}

#[test]
fn section_that_is_not_a_table() {
    let meta = replace(META, "[site]\n", "site = 3\n[elsewhere]\n");
    let err = error(&[("recording.toml", Some(&meta))]);
    assert!(matches!(err.kind(), ErrorKind::Toml(_)));
    assert_message(
        &err,
        &["recording.toml", "line 4", "expected a table [site]"],
    );
}

#[test]
fn missing_key() {
    let meta = replace(META, "rate_hz = 10.0\n", "");
    let err = error(&[("recording.toml", Some(&meta))]);
    assert!(matches!(err.kind(), ErrorKind::MissingKey));
    assert_eq!(err.key(), Some("master.rate_hz"));
    assert_message(
        &err,
        &[
            "recording.toml",
            "key master.rate_hz",
            "missing required key",
        ],
    );

    let meta = replace(META, "[lever_arm]\nr0_m = [10.0, 4.0, 15.0]\n", "");
    let err = error(&[("recording.toml", Some(&meta))]);
    assert!(matches!(err.kind(), ErrorKind::MissingKey));
    assert_message(&err, &["key lever_arm.r0_m"]);
}

#[test]
fn wrong_format() {
    let meta = replace(META, "slave-ins-recording", "something-else");
    let err = error(&[("recording.toml", Some(&meta))]);
    assert!(matches!(err.kind(), ErrorKind::WrongFormat { .. }));
    assert_message(
        &err,
        &["recording.toml", "line 1", "key format", "something-else"],
    );
}

#[test]
fn wrong_version() {
    for bad in ["version = 2", "version = 1.0", "version = \"1\""] {
        let meta = replace(META, "version = 1", bad);
        let err = error(&[("recording.toml", Some(&meta))]);
        assert!(
            matches!(err.kind(), ErrorKind::WrongVersion { .. }),
            "{bad}"
        );
        assert_message(&err, &["recording.toml", "line 2", "key version"]);
    }
}

#[test]
fn bad_output() {
    let meta = replace(META, "\"increments\"", "\"counts\"");
    let err = error(&[("recording.toml", Some(&meta))]);
    assert!(matches!(err.kind(), ErrorKind::BadOutput { .. }));
    assert_message(
        &err,
        &[
            "recording.toml",
            "line 14",
            "key slave_imu.output",
            "counts",
        ],
    );
}

#[test]
fn non_positive_rate() {
    for bad in ["rate_hz = 0.0", "rate_hz = -100", "rate_hz = -0.0"] {
        let meta = replace(META, "rate_hz = 100.0", bad);
        let err = error(&[("recording.toml", Some(&meta))]);
        assert!(
            matches!(err.kind(), ErrorKind::NonPositiveRate { .. }),
            "{bad}"
        );
        assert_message(
            &err,
            &["recording.toml", "line 13", "key slave_imu.rate_hz"],
        );
    }
}

#[test]
fn invalid_value_type_or_shape() {
    let meta = replace(META, "rate_hz = 10.0", "rate_hz = \"fast\"");
    let err = error(&[("recording.toml", Some(&meta))]);
    assert!(matches!(err.kind(), ErrorKind::InvalidValue { .. }));
    assert_message(
        &err,
        &[
            "recording.toml",
            "line 17",
            "key master.rate_hz",
            "a number",
        ],
    );

    let meta = replace(META, "[10.0, 4.0, 15.0]", "[10.0, 4.0]");
    let err = error(&[("recording.toml", Some(&meta))]);
    assert!(matches!(err.kind(), ErrorKind::InvalidValue { .. }));
    assert_message(&err, &["line 10", "key lever_arm.r0_m", "3 numbers"]);

    let meta = format!("{META}\n[notes]\ntext = 5\n");
    let err = error(&[("recording.toml", Some(&meta))]);
    assert!(matches!(err.kind(), ErrorKind::InvalidValue { .. }));
    assert_message(&err, &["key notes.text", "a string"]);
}

#[test]
fn non_finite_in_toml() {
    let meta = replace(META, "height_m = 0.0", "height_m = nan");
    let err = error(&[("recording.toml", Some(&meta))]);
    assert!(matches!(err.kind(), ErrorKind::NonFinite { .. }));
    assert_message(&err, &["recording.toml", "line 7", "key site.height_m"]);

    let meta = replace(META, "[10.0, 4.0, 15.0]", "[10.0, inf, 15.0]");
    let err = error(&[("recording.toml", Some(&meta))]);
    assert!(matches!(err.kind(), ErrorKind::NonFinite { .. }));
    assert_message(&err, &["key lever_arm.r0_m"]);
}

#[test]
fn latitude_out_of_range() {
    let meta = replace(META, "lat_deg = 37.5", "lat_deg = 91");
    let err = error(&[("recording.toml", Some(&meta))]);
    assert!(matches!(err.kind(), ErrorKind::OutOfRange { .. }));
    assert_message(&err, &["recording.toml", "line 5", "key site.lat_deg"]);

    let master = replace(
        MASTER,
        "0,0,0,37.5,121.4,0\n0.1",
        "0,0,0,-90.5,121.4,0\n0.1",
    );
    let err = error(&[("master.csv", Some(&master))]);
    assert!(matches!(err.kind(), ErrorKind::OutOfRange { .. }));
    assert_message(&err, &["master.csv", "line 2", "column 9 (lat_deg)"]);
}

#[test]
fn empty_file() {
    for text in ["", "\n\n", "# only a comment\n   \n"] {
        let err = error(&[("master.csv", Some(text))]);
        assert!(matches!(err.kind(), ErrorKind::EmptyFile), "{text:?}");
        assert_message(&err, &["master.csv", "empty file"]);
    }
}

#[test]
fn no_samples() {
    let slave = "t,dthx,dthy,dthz,dvx,dvy,dvz\n0,0,0,0,0,0,0\n";
    let err = error(&[("slave_imu.csv", Some(slave))]);
    assert!(matches!(err.kind(), ErrorKind::NoSamples { .. }));
    assert_message(&err, &["slave_imu.csv", "no samples"]);

    let master = "t,qw,qx,qy,qz,ve,vn,vu,lat_deg,lon_deg,height_m\n# nothing\n";
    let err = error(&[("master.csv", Some(master))]);
    assert!(matches!(err.kind(), ErrorKind::NoSamples { .. }));
    assert_message(&err, &["master.csv", "no samples"]);

    let err = error(&[("truth.csv", Some("t,bgx\n"))]);
    assert!(matches!(err.kind(), ErrorKind::NoSamples { .. }));
    assert_message(&err, &["truth.csv"]);
}

#[test]
fn missing_column() {
    let slave = replace(SLAVE, "dthy,", "");
    let err = error(&[("slave_imu.csv", Some(&slave))]);
    assert!(matches!(err.kind(), ErrorKind::MissingColumn { name } if name == "dthy"));
    assert_message(&err, &["slave_imu.csv", "line 1", "`dthy`"]);

    // A rates header does not satisfy output = "increments".
    let slave = "# logger v2\nt,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,0\n";
    let err = error(&[("slave_imu.csv", Some(slave))]);
    assert!(matches!(err.kind(), ErrorKind::MissingColumn { name } if name == "dthx"));
    assert_message(&err, &["slave_imu.csv", "line 2", "`dthx`"]);

    let err = error(&[("truth.csv", Some("time,bgx\n0,1\n"))]);
    assert!(matches!(err.kind(), ErrorKind::MissingColumn { name } if name == "t"));
    assert_message(&err, &["truth.csv", "line 1"]);
}

#[test]
fn duplicate_column() {
    let slave = replace(SLAVE, "dvz\n", "dvz,dthx\n").replace(",0.098\n", ",0.098,1\n");
    let slave = replace(&slave, "0,0,0,0,0,0,0\n", "0,0,0,0,0,0,0,0\n");
    let err = error(&[("slave_imu.csv", Some(&slave))]);
    assert!(matches!(
        err.kind(),
        ErrorKind::DuplicateColumn { first: 2 }
    ));
    assert_message(&err, &["slave_imu.csv", "line 1", "column 8 (dthx)"]);
}

#[test]
fn empty_column_name() {
    let slave = replace(SLAVE, "dvz\n", "dvz,\n");
    let err = error(&[("slave_imu.csv", Some(&slave))]);
    assert!(matches!(err.kind(), ErrorKind::EmptyColumnName));
    assert_message(&err, &["slave_imu.csv", "line 1", "column 8"]);
}

#[test]
fn incomplete_master_rate() {
    let master = replace(MASTER, "height_m\n", "height_m,wx,wy\n").replace(",0\n", ",0,0,0\n");
    let err = error(&[("master.csv", Some(&master))]);
    assert!(matches!(err.kind(), ErrorKind::IncompleteMasterRate { missing } if missing == "wz"));
    assert_message(&err, &["master.csv", "line 1", "`wz`"]);
}

#[test]
fn wrong_column_count() {
    let slave = replace(SLAVE, "0.02,1e-5,", "0.02,");
    let err = error(&[("slave_imu.csv", Some(&slave))]);
    assert!(matches!(
        err.kind(),
        ErrorKind::ColumnCount {
            expected: 7,
            found: 6
        }
    ));
    assert_message(&err, &["slave_imu.csv", "line 4", "6 fields", "7 columns"]);
}

#[test]
fn not_a_number() {
    let slave = replace(SLAVE, "3e-5,0.001", "3e-5,1.0.2");
    let err = error(&[("slave_imu.csv", Some(&slave))]);
    assert!(matches!(err.kind(), ErrorKind::NotANumber { .. }));
    assert_message(
        &err,
        &["slave_imu.csv", "line 3", "column 5 (dvx)", "\"1.0.2\""],
    );

    let master = replace(
        MASTER,
        "0.1,0.7071067811865476,0,",
        "0.1,0.7071067811865476,,",
    );
    let err = error(&[("master.csv", Some(&master))]);
    assert!(matches!(err.kind(), ErrorKind::NotANumber { .. }));
    assert_message(&err, &["master.csv", "line 3", "column 3 (qx)"]);
}

#[test]
fn non_finite_value() {
    for bad in ["inf", "NaN", "-infinity", "1e999"] {
        let slave = replace(
            SLAVE,
            "0.02,1e-5,2e-5,3e-5",
            &format!("0.02,1e-5,{bad},3e-5"),
        );
        let err = error(&[("slave_imu.csv", Some(&slave))]);
        assert!(matches!(err.kind(), ErrorKind::NonFinite { .. }), "{bad}");
        assert_message(&err, &["slave_imu.csv", "line 4", "column 3 (dthy)", bad]);
    }
}

#[test]
fn time_not_strictly_increasing() {
    for bad in ["0.01", "0.005"] {
        let slave = replace(SLAVE, "0.02,", &format!("{bad},"));
        let err = error(&[("slave_imu.csv", Some(&slave))]);
        assert!(
            matches!(err.kind(), ErrorKind::TimeNotIncreasing { .. }),
            "{bad}"
        );
        assert_message(&err, &["slave_imu.csv", "line 4", "column 1 (t)"]);
    }
    let err = error(&[("truth.csv", Some("bgx,t\n1,0\n2,1\n3,1\n"))]);
    assert!(matches!(err.kind(), ErrorKind::TimeNotIncreasing { .. }));
    assert_message(&err, &["truth.csv", "line 4", "column 2 (t)"]);
}

#[test]
fn non_unit_quaternion() {
    let master = replace(MASTER, "0.0,1,0,0,0,", "0.0,1.00001,0,0,0,");
    let err = error(&[("master.csv", Some(&master))]);
    assert!(matches!(err.kind(), ErrorKind::NonUnitQuaternion { .. }));
    assert_message(&err, &["master.csv", "line 2", "column 2 (qw)", "1e-6"]);

    // Within the tolerance: accepted and kept as written.
    let master = replace(MASTER, "0.0,1,0,0,0,", "0.0,1.0000009,0,0,0,");
    let dir = folder(&[("master.csv", Some(&master))]);
    let rec = read_recording(dir.path()).unwrap();
    assert_eq!(rec.master[0].q_bm_n[0], 1.0000009);
}

#[test]
fn syntax_freedoms_are_accepted() {
    // Comments, blank lines, CRLF, spaces around fields, a BOM, columns in any
    // order, unknown columns (even non-numeric ones), and the master rate.
    let slave = "\u{feff}# exported by a logger\r\n\r\nstatus,dvz,dvy,dvx,dthz,dthy,dthx,t\r\n\
                 ok, 0, 0, 0, 0, 0, 0, 5.0\r\n# pause\r\nok,3,2,1,0.3,0.2,0.1,5.5\r\n";
    let master = "wz,wy,wx,t,qw,qx,qy,qz,ve,vn,vu,lat_deg,lon_deg,height_m\n\
                  0.3,0.2,0.1,5.0,1,0,0,0,1,2,3,37.5,121.4,10\n";
    let truth = "t,bgx,custom\n5,1e-5,7\n6,2e-5,8\n";
    let dir = folder(&[
        ("slave_imu.csv", Some(slave)),
        ("master.csv", Some(master)),
        ("truth.csv", Some(truth)),
    ]);
    let rec = read_recording(dir.path()).unwrap();
    assert_eq!(rec.imu_t0, 5.0);
    assert_eq!(rec.imu.len(), 1);
    assert_eq!(rec.imu[0].t, 5.5);
    assert_eq!(rec.imu[0].dtheta_rad, [0.1, 0.2, 0.3]);
    assert_eq!(rec.imu[0].dv_mps, [1.0, 2.0, 3.0]);
    assert!(rec.master_has_rate());
    assert_eq!(rec.master[0].omega_ib_bm_radps, Some([0.1, 0.2, 0.3]));
    assert_eq!(rec.master[0].v_n_mps, [1.0, 2.0, 3.0]);
    let truth = rec.truth.unwrap();
    assert_eq!(truth.names, ["bgx", "custom"]);
    assert_eq!(truth.column("custom"), Some(&[7.0, 8.0][..]));
    assert_eq!(truth.column("t"), Some(&[5.0, 6.0][..]));
    assert_eq!(truth.column("bax"), None);
    assert_eq!(
        truth.vec3(["bgx", "custom", "t"], 1),
        Some([2e-5, 8.0, 6.0])
    );
    assert_eq!(truth.vec3(["bgx", "custom", "t"], 2), None);
}

#[test]
fn rates_are_converted_to_increments() {
    let meta = replace(META, "\"increments\"", "\"rates\"");
    let slave = "t,gx,gy,gz,ax,ay,az\n1.0,9,9,9,9,9,9\n1.5,0.2,0.4,0.6,2,4,9.8\n2.0,1,1,1,1,1,1\n";
    let dir = folder(&[
        ("recording.toml", Some(&meta)),
        ("slave_imu.csv", Some(slave)),
    ]);
    let rec = read_recording(dir.path()).unwrap();
    assert_eq!(rec.meta.slave_output, ImuOutput::Rates);
    assert_eq!(rec.imu_t0, 1.0);
    assert_eq!(rec.imu.len(), 2);
    assert_eq!(rec.imu[0].dtheta_rad, [0.1, 0.2, 0.3]);
    assert_eq!(rec.imu[0].dv_mps, [1.0, 2.0, 4.9]);
    assert_eq!(rec.imu[1].dv_mps, [0.5, 0.5, 0.5]);

    // A rate times dt that overflows is reported, not turned into infinity.
    let slave = "t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,0\n1e300,0,0,0,0,0,1e300\n";
    let err = error(&[
        ("recording.toml", Some(&meta)),
        ("slave_imu.csv", Some(slave)),
    ]);
    assert!(matches!(err.kind(), ErrorKind::NonFinite { .. }));
    assert_message(&err, &["slave_imu.csv", "line 3", "column 7 (az)"]);
}

#[test]
fn psins_example_loads() {
    let dir = Path::new("/work/shared/data/psins-vehicle-fog-mems");
    if !dir.exists() {
        eprintln!("skipped: {} not present", dir.display());
        return;
    }
    let rec = read_recording(dir).unwrap();
    // 10001 data lines: the first starts the clock, 10000 samples follow.
    assert_eq!(rec.imu_t0, 0.0);
    assert_eq!(rec.imu.len(), 10_000);
    assert_eq!(rec.imu.last().unwrap().t, 100.0);
    assert_eq!(rec.master.len(), 1000);
    assert!(!rec.master_has_rate());
    assert!(rec.truth.is_none());
    assert_eq!(rec.meta.slave_output, ImuOutput::Increments);
    assert_eq!(rec.meta.slave_rate_hz, 100.0);
    assert_eq!(rec.meta.master_rate_hz, 10.0);
    assert_eq!(rec.meta.lever_arm_m, [0.0; 3]);
    assert!(rec.meta.notes.as_deref().unwrap().contains("PSINS"));
}

// ---- the writer refuses what the reader would refuse ----

fn valid_recording() -> Recording {
    read_recording(folder(&[]).path()).unwrap()
}

fn write_error(rec: &Recording) -> RecordingError {
    let dir = tempfile::tempdir().unwrap();
    let err = write_recording(dir.path(), rec).unwrap_err();
    assert!(
        std::fs::read_dir(dir.path()).unwrap().next().is_none(),
        "a refused recording left files behind"
    );
    err
}

#[test]
fn writer_refuses_invalid_values() {
    let mut rec = valid_recording();
    rec.master[1].q_bm_n = [1.0, 1.0, 0.0, 0.0];
    let err = write_error(&rec);
    assert!(matches!(err.kind(), ErrorKind::NonUnitQuaternion { .. }));
    assert_message(&err, &["master.csv", "line 3", "column 2 (qw)"]);

    let mut rec = valid_recording();
    rec.imu[1].dv_mps[2] = f64::NAN;
    let err = write_error(&rec);
    assert!(matches!(err.kind(), ErrorKind::NonFinite { .. }));
    assert_message(&err, &["slave_imu.csv", "line 4", "column 7 (dvz)"]);

    let mut rec = valid_recording();
    rec.imu_t0 = rec.imu[0].t;
    let err = write_error(&rec);
    assert!(matches!(err.kind(), ErrorKind::TimeNotIncreasing { .. }));
    assert_message(&err, &["slave_imu.csv", "line 3", "column 1 (t)"]);

    let mut rec = valid_recording();
    rec.meta.master_rate_hz = 0.0;
    let err = write_error(&rec);
    assert!(matches!(err.kind(), ErrorKind::NonPositiveRate { .. }));
    assert_message(&err, &["recording.toml", "key master.rate_hz"]);

    let mut rec = valid_recording();
    rec.imu.clear();
    assert!(matches!(
        write_error(&rec).kind(),
        ErrorKind::NoSamples { .. }
    ));
}

#[test]
fn writer_refuses_mixed_master_rate() {
    let mut rec = valid_recording();
    rec.master[0].omega_ib_bm_radps = Some([0.0; 3]);
    let err = write_error(&rec);
    assert!(matches!(err.kind(), ErrorKind::MixedMasterRate));
    assert_message(&err, &["master.csv", "line 3"]);
}

#[test]
fn writer_refuses_bad_truth() {
    let truth = |names: &[&str], columns: Vec<Vec<f64>>| Truth {
        names: names.iter().map(|s| s.to_string()).collect(),
        t: vec![0.0, 1.0],
        columns,
    };
    for name in ["", "t", " x", "a,b", "a\nb"] {
        let mut rec = valid_recording();
        rec.truth = Some(truth(&[name], vec![vec![0.0, 0.0]]));
        let err = write_error(&rec);
        assert!(
            matches!(err.kind(), ErrorKind::InvalidColumnName { .. }),
            "{name:?}"
        );
        assert_message(&err, &["truth.csv", "line 1", "column 2"]);
    }
    let mut rec = valid_recording();
    rec.truth = Some(truth(&["a", "a"], vec![vec![0.0; 2], vec![0.0; 2]]));
    let err = write_error(&rec);
    assert!(matches!(
        err.kind(),
        ErrorKind::DuplicateColumn { first: 2 }
    ));
    assert_message(&err, &["truth.csv", "column 3 (a)"]);

    let mut rec = valid_recording();
    rec.truth = Some(truth(&["a", "b"], vec![vec![0.0; 2], vec![0.0; 3]]));
    let err = write_error(&rec);
    assert!(matches!(err.kind(), ErrorKind::LengthMismatch { .. }));
    assert_message(&err, &["truth.csv", "column 3 (b)"]);
}

#[test]
fn writer_removes_stale_truth() {
    let dir = folder(&[("truth.csv", Some("t,x\n0,1\n"))]);
    let mut rec = read_recording(dir.path()).unwrap();
    assert!(rec.truth.is_some());
    rec.truth = None;
    write_recording(dir.path(), &rec).unwrap();
    assert_eq!(read_recording(dir.path()).unwrap(), rec);
}
