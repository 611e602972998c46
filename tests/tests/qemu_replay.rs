//! Recordings replayed through the board firmware: on the host (the firmware library's
//! `App` fed the encoded byte stream) and in QEMU `netduinoplus2` (the release image, link
//! frames in and estimates out), compared with `flexcal calibrate --precision f32`.
//!
//! The image is built once into `target/qemu-replay` (its own target directory: a nested cargo
//! must not wait on the lock of the cargo running these tests; `FLEXCAL_QEMU_TARGET_DIR`
//! moves it elsewhere).
//!
//! Augmented layouts: a 60 s `paper` recording (200 ppm gyro and accel scale factors the
//! declared model lacks) calibrated with `effects = ["gyro_scale_factor"]` by `flexcal
//! replay --qemu` and by `calibrate --precision f32`'s library, from the same configuration
//! file: the board's effect estimate, its σ and the usual estimates agree within 0.1 σ.
//!
//! Transports: the long recordings go through semihosting files (`Transport::Semihosting`),
//! because QEMU's USART model takes one byte per main-loop turn (about 18 kB/s of wall time,
//! ~1 s per recorded second at 200 Hz IMU + 100 Hz master); the USART itself is tested on a
//! short stream, clean (bit-identical to the semihosting run) and with link faults.
//!
//! `qemu-system-arm` missing is a failure, not a silent pass; set `FLEXCAL_SKIP_QEMU=1` to skip
//! the QEMU tests on a machine without it (the host test still runs).

use flexcal_core::augment::Effect;
use flexcal_core::engine::Engine;
use flexcal_core::link::{EstimatesMsg, HealthFlags, Message, Receiver, StatusMsg};
use flexcal_firmware::app::App;
use flexcal_sim::calib::config::CalibConfig;
use flexcal_sim::calib::run::{run, CalibResult, Precision};
use flexcal_sim::cmd::common::{ModelArgs, ScenarioArgs};
use flexcal_sim::cmd::replay::{
    encode_frames, first_flag, host_watch, run_qemu, stream_messages, QemuRun, Timing, Transport,
};
use flexcal_sim::recording::{read_recording, write_recording, Recording};
use flexcal_sim::sim::{simulate, Scenario};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::time::Duration;

mod support;

use support::{build_image, qemu_available_or_skip as qemu_or_skip, workspace_root};

const QEMU_TIMEOUT: Duration = Duration::from_secs(120);

/// The release image, built once per test process.
fn image() -> &'static Path {
    static ELF: OnceLock<PathBuf> = OnceLock::new();
    ELF.get_or_init(|| build_image("qemu-replay", &[]))
}

/// A simulated `moored` recording of `duration_s`, written and read back as `calibrate`
/// would see it, with the configuration its scenario declares.
fn moored(duration_s: f64, dir: &Path) -> (Recording, CalibConfig) {
    let mut sc = Scenario::load("moored").expect("moored scenario");
    sc.duration_s = duration_s;
    let out = simulate(&sc, 7);
    write_recording(dir, &out.recording).expect("write recording");
    let rec = read_recording(dir).expect("read recording");
    let cfg = CalibConfig::declared_for(&sc, 1.0 / sc.master.rate_hz);
    (rec, cfg)
}

fn replay(rec: &Recording, cfg: &CalibConfig, bytes: &[u8], t: Transport, dir: &Path) -> QemuRun {
    let _ = (rec, cfg);
    let run = run_qemu(image(), bytes, t, Timing::Wall, QEMU_TIMEOUT, dir).expect("QEMU run");
    assert_eq!(
        run.exit_code,
        Some(0),
        "firmware failed in QEMU; stdout:\n{}",
        run.stdout
    );
    assert!(
        run.stdout.contains("flexcal-firmware replay ok"),
        "{}",
        run.stdout
    );
    eprintln!(
        "QEMU {t:?}: {} bytes in {:.2} s wall",
        bytes.len(),
        run.wall.as_secs_f64()
    );
    run
}

/// The board's estimates after the reference's last master update (the board also flushes the
/// held IMU samples at End, which may match one more master message).
fn at_reference_end(run: &QemuRun, reference: &CalibResult) -> EstimatesMsg {
    let est = run.estimates();
    assert!(est.len() >= reference.rows.len(), "{} estimates", est.len());
    est[reference.rows.len() - 1]
}

fn last_estimates(run: &QemuRun) -> EstimatesMsg {
    *run.estimates().last().expect("no Estimates from the board")
}

fn last_status(run: &QemuRun) -> StatusMsg {
    run.last_status().expect("no Status from the board")
}

/// Final board estimates within `tol` σ of the f32 reference (`flexcal calibrate`'s library).
fn assert_close(board: &EstimatesMsg, reference: &CalibResult, tol: f64) {
    let r = reference.last();
    let groups = [
        ("gyro bias", board.gyro_bias, r.gyro_bias, r.gyro_bias_sigma),
        (
            "accel bias",
            board.accel_bias,
            r.accel_bias,
            r.accel_bias_sigma,
        ),
        (
            "misalignment",
            board.misalignment,
            r.misalignment,
            r.misalignment_sigma,
        ),
    ];
    for (name, b, want, sigma) in groups {
        for k in 0..3 {
            let z = (f64::from(b[k]) - want[k]) / sigma[k];
            assert!(
                z.abs() <= tol,
                "{name}[{k}]: board {} vs calibrate {} (σ {}): {z:.4} σ",
                b[k],
                want[k],
                sigma[k]
            );
        }
    }
}

#[test]
fn host_app_equals_the_engine_driven_directly() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (rec, cfg) = moored(20.0, dir.path());
    let msgs = stream_messages(&rec, &cfg, 1, 0);
    let bytes = encode_frames(&msgs).expect("encode").concat();

    let mut app = Box::new(App::new());
    let mut rx = Receiver::new();
    let mut sent = Vec::new();
    app.push_bytes(&bytes, &mut |frame: &[u8]| {
        for b in frame {
            if let Some(Ok(r)) = rx.push(*b) {
                sent.push(r.frame.message);
            }
        }
    });
    assert!(app.ended());

    // The same messages straight into Engine<f32>.
    let mut engine: Option<Engine<f32>> = None;
    let mut r = flexcal_core::engine::StepReports::new();
    let mut per_update = Vec::new();
    for m in &msgs {
        let reports = match m {
            Message::Config(c) => {
                engine = Some(Engine::new(c.to_engine()).expect("config"));
                continue;
            }
            Message::ImuSample(s) => engine.as_mut().unwrap().push_imu(s.to_engine(), &mut r),
            Message::MasterNav(s) => engine.as_mut().unwrap().push_master(s.to_engine(), &mut r),
            Message::End(_) => {
                engine.as_mut().unwrap().flush(&mut r);
                Ok(())
            }
            _ => continue,
        };
        let e = engine.as_ref().unwrap();
        for _ in reports.map(|()| r.len()).into_iter().flat_map(|n| 0..n) {
            let flags = HealthFlags::from_engine(&e.health(), &e.counters());
            per_update.push(EstimatesMsg::from_engine(&e.estimates(), flags));
        }
    }
    let board: Vec<EstimatesMsg> = sent
        .iter()
        .filter_map(|m| match m {
            Message::Estimates(e) => Some(*e),
            _ => None,
        })
        .collect();
    assert!(per_update.len() > 1000);
    assert_eq!(
        board.len(),
        per_update.len() + 1,
        "every update, and the final one"
    );
    assert_eq!(&board[..per_update.len()], &per_update[..], "bit-identical");

    // And the library reference of `flexcal calibrate --precision f32` (which does not flush
    // at the end: compare at its last update).
    let reference = run(&rec, &cfg, Precision::F32).expect("calibrate f32");
    assert_close(&board[reference.rows.len() - 1], &reference, 1e-9);
}

#[test]
fn moored_120s_in_qemu_matches_calibrate_f32() {
    if !qemu_or_skip() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let (rec, cfg) = moored(120.0, &dir.path().join("rec"));
    let msgs = stream_messages(&rec, &cfg, 1, 1000);
    let frames = encode_frames(&msgs).expect("encode");
    let bytes = frames.concat();
    let run_q = replay(
        &rec,
        &cfg,
        &bytes,
        Transport::Semihosting,
        &dir.path().join("q"),
    );
    let st = last_status(&run_q);
    assert_eq!(
        st.link.decoder.frames as usize,
        frames.len(),
        "no frame lost"
    );
    assert_eq!(st.link.decoder.errors(), 0);
    let reference = run(&rec, &cfg, Precision::F32).expect("calibrate f32");
    assert!(st.engine.master_matched as usize >= reference.rows.len());
    assert_close(&at_reference_end(&run_q, &reference), &reference, 0.1);
}

#[test]
fn psins_vehicle_in_qemu_matches_calibrate_f32() {
    if !qemu_or_skip() {
        return;
    }
    let root = workspace_root();
    let rec_dir = root.join("../shared/data/psins-vehicle-fog-mems");
    let rec = read_recording(&rec_dir).expect("psins recording");
    let mut cfg = CalibConfig::load(&root.join("configs/mems-vehicle.toml")).expect("config");
    // As `calibrate`: the flexure model as configured or identified.
    let _ = flexcal_sim::cmd::calibrate::choose_flexure(&rec, &mut cfg);
    let msgs = stream_messages(&rec, &cfg, 1, 100);
    let frames = encode_frames(&msgs).expect("encode");
    let dir = tempfile::tempdir().expect("tempdir");
    let run_q = replay(
        &rec,
        &cfg,
        &frames.concat(),
        Transport::Semihosting,
        dir.path(),
    );
    let st = last_status(&run_q);
    assert_eq!(
        st.link.decoder.frames as usize,
        frames.len(),
        "no frame lost"
    );
    let reference = run(&rec, &cfg, Precision::F32).expect("calibrate f32");
    assert!(st.engine.master_matched as usize >= reference.rows.len());
    assert_close(&at_reference_end(&run_q, &reference), &reference, 0.1);
}

/// Deterministic pseudo-random bytes (no zero: a zero would just be one more delimiter).
fn noise(state: &mut u64, n: usize) -> Vec<u8> {
    (0..n)
        .map(|_| {
            *state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((*state >> 33) as u8).max(1)
        })
        .collect()
}

#[test]
fn uart_link_with_faults_keeps_running_and_counts_them() {
    if !qemu_or_skip() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let (rec, cfg) = moored(4.0, &dir.path().join("rec"));
    let msgs = stream_messages(&rec, &cfg, 0, 0);
    let frames = encode_frames(&msgs).expect("encode");
    let n = frames.len();

    // Clean, over the USART: no byte lost, and bit-identical to the semihosting transport.
    let clean = replay(
        &rec,
        &cfg,
        &frames.concat(),
        Transport::Uart,
        &dir.path().join("u"),
    );
    let clean_st = last_status(&clean);
    assert_eq!(clean_st.link.decoder.frames as usize, n, "UART lost frames");
    assert_eq!(clean_st.link.decoder.errors(), 0);
    let files = replay(
        &rec,
        &cfg,
        &frames.concat(),
        Transport::Semihosting,
        &dir.path().join("s"),
    );
    assert_eq!(last_estimates(&clean), last_estimates(&files));

    // Faults that destroy no valid message: garbage between frames, duplicated frames.
    let mut rng = 0x5EED_u64;
    let mut bytes = Vec::new();
    let (mut garbage_runs, mut dups) = (0u32, 0u32);
    for (i, f) in frames.iter().enumerate() {
        bytes.extend_from_slice(f);
        if i > 0 && i + 1 < n && i % 9 == 4 {
            let len = 1 + (i % 40);
            bytes.extend(noise(&mut rng, len));
            garbage_runs += 1;
        }
        if i > 0 && i + 1 < n && i % 13 == 6 {
            bytes.extend_from_slice(f);
            dups += 1;
        }
    }
    let benign = replay(&rec, &cfg, &bytes, Transport::Uart, &dir.path().join("b"));
    let st = last_status(&benign);
    assert_eq!(
        last_estimates(&benign),
        last_estimates(&clean),
        "estimates changed"
    );
    assert_eq!(st.link.sequence.duplicates, dups, "duplicates counted");
    assert_eq!(st.link.decoder.frames as usize, n + dups as usize);
    // Each run of garbage is closed off by the next frame's delimiter: one rejected frame.
    assert_eq!(
        st.link.decoder.errors(),
        garbage_runs,
        "{:?}",
        st.link.decoder
    );

    // Destructive faults: truncated, bit-flipped, dropped, reordered frames.
    let mut bytes = Vec::new();
    let (mut truncated, mut flipped, mut dropped, mut reordered) = (0u32, 0u32, 0u32, 0u32);
    let mut i = 0;
    while i < n {
        let f = &frames[i];
        let inner = i > 1 && i + 3 < n;
        match i % 40 {
            10 if inner => {
                bytes.extend_from_slice(&f[..f.len() / 2]);
                truncated += 1;
            }
            20 if inner => {
                let mut g = f.clone();
                let k = 3 + (i % (g.len() - 6));
                g[k] ^= 0x04;
                if g[k] == 0 {
                    g[k] = 0x55;
                }
                bytes.extend_from_slice(&g);
                flipped += 1;
            }
            30 if inner => dropped += 1,
            35 if inner => {
                // The next frame of the same stream (two on: IMU and master alternate) first.
                bytes.extend_from_slice(&frames[i + 2]);
                bytes.extend_from_slice(&frames[i + 1]);
                bytes.extend_from_slice(f);
                reordered += 1;
                i += 2;
            }
            _ => bytes.extend_from_slice(f),
        }
        i += 1;
    }
    let hurt = replay(&rec, &cfg, &bytes, Transport::Uart, &dir.path().join("h"));
    let st = last_status(&hurt);
    let d = st.link.decoder;
    let s = st.link.sequence;
    eprintln!("destructive faults: {d:?}\n{s:?}");
    assert!(
        d.errors() >= truncated + flipped,
        "damaged frames rejected: {d:?}"
    );
    assert!(s.gaps >= dropped, "gaps counted: {s:?}");
    assert!(s.out_of_order >= reordered, "reordering counted: {s:?}");
    let e = last_estimates(&hurt);
    assert!(e.gyro_bias.iter().all(|v| v.is_finite()));
    assert!(st.engine.master_matched > 0);
}

/// The `paper` scenario simulated by `flexcal simulate` (which writes the declared model's
/// `calibrate.toml` beside the recording), and a copy of that configuration with `effects`.
fn paper_with_effects(duration_s: f64, dir: &Path, effects: &[Effect]) -> PathBuf {
    let rec_dir = dir.join("rec");
    flexcal_sim::cmd::simulate::run(&flexcal_sim::cmd::simulate::Args {
        scenario: ScenarioArgs {
            scenario: Some("paper".into()),
            blind: false,
            effect: Vec::new(),
            duration: Some(duration_s),
            seed: 7,
        },
        out: rec_dir.clone(),
        drawn: None,
        clock_offset: None,
        mounting_deg: None,
        master_steps: Default::default(),
    })
    .expect("flexcal simulate");
    let declared = std::fs::read_to_string(rec_dir.join("calibrate.toml")).expect("calibrate.toml");
    let names: Vec<String> = effects
        .iter()
        .map(|e| format!("\"{}\"", e.name()))
        .collect();
    let line = format!("effects = [{}]", names.join(", "));
    assert!(declared.contains("\neffects = []\n"), "{declared}");
    let text = declared.replace("\neffects = []\n", &format!("\n{line}\n"));
    let cfg_path = dir.join("augmented.toml");
    std::fs::write(&cfg_path, text).expect("write config");
    cfg_path
}

#[test]
fn paper_gyro_scale_factor_in_qemu_matches_calibrate_f32() {
    if !qemu_or_skip() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let cfg_path = paper_with_effects(60.0, dir.path(), &[Effect::GyroScaleFactor]);
    let args = flexcal_sim::cmd::replay::Args {
        rec_dir: dir.path().join("rec"),
        qemu: true,
        out: dir.path().join("q"),
        elf: Some(image().to_path_buf()),
        config: Some(cfg_path.clone()),
        estimates_every: 1,
        status_every: 1000,
        transport: Transport::Semihosting,
        icount: false,
        profile: false,
        timeout_s: QEMU_TIMEOUT.as_secs(),
        model: ModelArgs {
            no_dynamic_lever_arm: false,
            identify_flexure: false,
            effects: Vec::new(),
            keep_master_steps: false,
        },
    };
    // `flexcal replay --qemu --config augmented.toml --transport semihosting`.
    let r = flexcal_sim::cmd::replay::replay(&args).expect("flexcal replay");
    flexcal_sim::cmd::replay::write_outputs(&args, &r).expect("replay outputs");
    eprintln!(
        "QEMU paper + gyro_scale_factor: {:.2} s wall",
        r.qemu.wall.as_secs_f64()
    );
    assert_eq!(r.cfg.effects, ["gyro_scale_factor"]);
    let st = last_status(&r.qemu);
    assert_eq!(
        st.link.decoder.frames as usize, r.frames_sent,
        "no frame lost"
    );
    assert_eq!(st.link.decoder.errors(), 0);
    assert_eq!(r.qemu.metric("config-refused"), Some(0));
    assert_eq!(
        r.qemu.metric("engine-states"),
        Some(33),
        "{}",
        r.qemu.stdout
    );

    // `calibrate --precision f32`'s library on the same recording and configuration file,
    // which names no mounting: both start from the one found before the filter.
    let file = CalibConfig::load(&cfg_path).expect("config");
    assert!(r.cfg.mounting_estimate_rad.is_some(), "{:?}", r.cfg);
    assert_eq!(
        file,
        CalibConfig {
            mounting_estimate_rad: None,
            ..r.cfg.clone()
        }
    );
    let cfg = r.cfg.clone();
    let reference = run(&r.rec, &cfg, Precision::F32).expect("calibrate f32");
    assert_close(&at_reference_end(&r.qemu, &reference), &reference, 0.1);

    // The effect: the board's report at the reference's last update, value and σ.
    let want = reference.effect_rows.last().expect("reference effect rows");
    assert_eq!(reference.effect_rows.len(), reference.rows.len());
    let board = &r.result.effect_rows;
    assert!(
        board.len() >= reference.effect_rows.len(),
        "{} board effect rows",
        board.len()
    );
    let got = &board[reference.effect_rows.len() - 1];
    assert_eq!((got.effect, got.t), (Effect::GyroScaleFactor, want.t));
    for k in 0..3 {
        let z = (got.value[k] - want.value[k]) / want.sigma[k];
        let zs = (got.sigma[k] - want.sigma[k]) / want.sigma[k];
        eprintln!(
            "gyro scale factor [{k}]: board {:.4e} ± {:.3e}, calibrate {:.4e} ± {:.3e}: {z:.2e} σ, σ {zs:.2e}",
            got.value[k], got.sigma[k], want.value[k], want.sigma[k]
        );
        assert!(z.abs() <= 0.1, "value [{k}]: {z} σ");
        assert!(zs.abs() <= 0.1, "σ [{k}]: {zs} relative");
    }
    // The board's Wald statistic is Σ (value/σ)² (diagonal P); the scale factors are there.
    let diag: f64 = (0..3)
        .map(|k| (want.value[k] / want.sigma[k]).powi(2))
        .sum();
    assert!(
        (got.wald - diag).abs() <= 0.1 * diag.max(1.0),
        "{} vs {diag}",
        got.wald
    );
    // And `flexcal replay`'s summary carries the effect.
    let summary: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(args.out.join("summary.json")).expect("summary.json"),
    )
    .expect("json");
    assert_eq!(
        summary["effects"][0]["name"], "gyro_scale_factor",
        "{summary}"
    );
}

/// The board's watcher and the host's run of it over the same stream: `(first flag,
/// last Status)`, after checking that no frame was lost and that board and host agree
/// (the first flag within one Status interval, 1 s; the last figures within 1 %).
fn watched(sc: &Scenario, seed: u64, dir: &Path) -> (Option<(f64, Effect)>, StatusMsg) {
    let rec = simulate(sc, seed).recording;
    let cfg = CalibConfig::declared_for(sc, 1.0 / sc.master.rate_hz);
    // Status after every 100th master update: once a second at 100 Hz.
    let msgs = stream_messages(&rec, &cfg, 0, 100);
    let frames = encode_frames(&msgs).expect("encode");
    let run_q = replay(&rec, &cfg, &frames.concat(), Transport::Semihosting, dir);
    let statuses = run_q.statuses();
    let last = *statuses.last().expect("no Status");
    assert_eq!(
        last.link.decoder.frames as usize,
        frames.len(),
        "no frame lost"
    );
    let board = first_flag(statuses.iter().map(|s| (s.t, s.watch)));
    let host = host_watch(&msgs).expect("host watch");
    let host_first = first_flag(host.iter().map(|p| (p.t, p.report)));
    eprintln!("board: first flag {board:?}, last {:?}", last.watch);
    eprintln!(
        "host:  first flag {host_first:?}, last {:?}",
        host.last().map(|p| p.report)
    );
    match (board, host_first) {
        (Some((tb, eb)), Some((th, eh))) => {
            assert_eq!(eb, eh, "board and host name the same effect");
            assert!((tb - th).abs() <= 1.0, "board {tb} s, host {th} s");
        }
        (None, None) => {}
        other => panic!("board and host disagree: {other:?}"),
    }
    let h = host.last().expect("host points").report;
    assert_eq!(h.verdict, last.watch.verdict);
    for (b, h) in last.watch.nis.iter().zip(h.nis.iter()) {
        assert!(
            (b - h).abs() <= 0.01 * h.abs().max(1e-3),
            "NIS board {b} host {h}"
        );
    }
    (board, last)
}

/// Issue 10, acceptance 6: a recording whose master delay (20 ms) appears halfway
/// (`scenarios/moored-delay-onset.toml`, onset at 120 s of 240 s): the board's Status
/// flags the model incomplete, naming the delay, within 60 s of the onset; the same
/// recording without the delay raises no flag. Board and host agree.
#[test]
fn the_board_names_a_delay_that_appears_in_service() {
    if !qemu_or_skip() {
        return;
    }
    let root = workspace_root();
    let dir = tempfile::tempdir().expect("tempdir");
    let onset_file = root.join("scenarios/moored-delay-onset.toml");
    let onset = Scenario::load(&onset_file.display().to_string()).expect("scenario");
    let (flag, last) = watched(&onset, 7, &dir.path().join("onset"));
    let (t, effect) = flag.expect("the board never flagged the model incomplete");
    eprintln!(
        "onset at 120 s, flagged at {t:.2} s: {:.2} s later",
        t - 120.0
    );
    assert_eq!(effect, Effect::TimeDelay);
    assert!(t > 120.0 && t <= 180.0, "flagged at {t} s");
    assert!(matches!(
        last.watch.verdict,
        flexcal_core::watch::Verdict::ModelIncomplete {
            most_likely: Effect::TimeDelay
        }
    ));
    // The same ship, seed and length, no delay.
    let mut clean = onset.clone();
    clean.undeclared.master_delay_s = 0.0;
    clean.undeclared.master_delay_from_s = None;
    let (flag, last) = watched(&clean, 7, &dir.path().join("clean"));
    assert_eq!(flag, None, "a clean recording flagged");
    assert_eq!(last.watch.verdict, flexcal_core::watch::Verdict::Consistent);
}
