//! `flexcal replay REC_DIR --qemu --out DIR`: the recording replayed through the board
//! firmware running in QEMU (`netduinoplus2`, the reference board's STM32F405).
//!
//! The configuration is resolved as `calibrate` does. The host then streams link frames
//! (`docs/link-protocol.md`) into the emulated USART1: Config, the recording's IMU samples
//! and master messages interleaved in time order exactly as `calibrate` feeds its engine, and
//! End. The firmware answers with Estimates (after every master update, or decimated) and
//! Status frames on the same line, and exits at End. The outputs are those of `calibrate`
//! (`summary.json` with `"precision": "f32"` and `"runner": "qemu"`, `estimates.csv`).
//!
//! Augmented layouts (`effects` in the configuration) travel in the Config; the board then
//! sends an Effects report after each Estimates, and the result carries the effects' rows
//! ([`CalibResult::effect_rows`]) like `calibrate`'s, so augmented runs compare too.
//!
//! Transport: QEMU connects its `-serial` to a TCP socket this process listens on. QEMU only
//! reads a byte from the socket when the emulated USART's receive register is free, so the
//! sender is held back by TCP flow control and no byte is lost (the Status counters prove it:
//! every frame sent is counted as received).

use crate::calib::config::CalibConfig;
use crate::calib::master_steps::StepCorrection;
use crate::calib::run::{CalibResult, CovarianceCheck, EffectRow, EstimateRow, Precision};
use crate::cmd::calibrate::prepare_config;
use crate::cmd::common::ModelArgs;
use crate::recording::{read_recording, Recording};
use crate::report::summary;
use flexcal_core::augment::{Effect, MAX_EFFECTS};
use flexcal_core::link::{
    ConfigMsg, EffectsMsg, EndMsg, EstimatesMsg, ImuSampleMsg, MasterNavMsg, Message, Receiver,
    StatusMsg, MAX_FRAME_LEN,
};
use flexcal_core::watch::{Verdict, Watch, WatchReport, AXES};
use nalgebra::SMatrix;
use std::io::{Read, Write};
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The firmware image `cargo fw-build` writes, relative to the workspace root.
pub const DEFAULT_ELF: &str = "target/thumbv7em-none-eabihf/firmware/flexcal-firmware";

/// Arguments of `flexcal replay`.
#[derive(clap::Args)]
pub struct Args {
    /// Recording directory (format v1).
    pub rec_dir: PathBuf,
    /// Run the firmware in QEMU (`qemu-system-arm -machine netduinoplus2`); the only runner.
    #[arg(long)]
    pub qemu: bool,
    /// Output directory.
    #[arg(long)]
    pub out: PathBuf,
    /// Firmware image (default: the `cargo fw-build` output).
    #[arg(long)]
    pub elf: Option<PathBuf>,
    /// Calibration configuration (TOML), resolved as `calibrate` does.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// The board sends Estimates after every n-th master update (the last one always).
    #[arg(long, default_value_t = 1)]
    pub estimates_every: u16,
    /// The board sends Status after every n-th master update (and at the end).
    #[arg(long, default_value_t = 1000)]
    pub status_every: u16,
    /// How the frames reach the firmware.
    #[arg(long, value_enum, default_value = "uart")]
    pub transport: Transport,
    /// Run QEMU with `-icount shift=0` (deterministic virtual time, for the cost figures).
    #[arg(long)]
    pub icount: bool,
    /// With `--icount`: run the board's sampling profiler instead of timing each read
    /// (`profile-*` samples per phase in `summary.json`, the split printed).
    #[arg(long, requires = "icount")]
    pub profile: bool,
    /// Wall-clock limit for the QEMU run (s).
    #[arg(long, default_value_t = 600)]
    pub timeout_s: u64,
    /// Model switches.
    #[command(flatten)]
    pub model: ModelArgs,
}

/// The messages the host sends for a recording: Config, the IMU start sample, then every IMU
/// sample followed by the master messages up to its time (the order of `calibrate`), then End.
pub fn stream_messages(
    rec: &Recording,
    cfg: &CalibConfig,
    estimates_every: u16,
    status_every: u16,
) -> Vec<Message> {
    let engine_cfg = cfg.engine_config::<f32>(rec.meta.lever_arm_m);
    let mut config = ConfigMsg::from_engine(&engine_cfg, estimates_every, status_every);
    config.t = rec.imu_t0;
    let mut out = Vec::with_capacity(rec.imu.len() + rec.master.len() + 3);
    out.push(Message::Config(config));
    out.push(Message::ImuSample(ImuSampleMsg {
        t: rec.imu_t0,
        dtheta_b: [0.0; 3],
        dv_b: [0.0; 3],
    }));
    let f = |v: [f64; 3]| v.map(|x| x as f32);
    // The clock alignment found before the filter, as `calibrate` applies it: the
    // board receives the master's tags on the slave's time base.
    let shift = cfg.master_clock_offset_s.unwrap_or(0.0);
    // The master's attitude steps taken out as `calibrate` does (`calib::master_steps`).
    let steps = StepCorrection::new(cfg.master_attitude_steps.as_deref().unwrap_or(&[]));
    let corrected: Vec<_> = rec.master.iter().map(|m| steps.apply(m.clone())).collect();
    let mut masters = corrected.iter().peekable();
    let mut last_t = rec.imu_t0;
    for s in &rec.imu {
        out.push(Message::ImuSample(ImuSampleMsg {
            t: s.t,
            dtheta_b: f(s.dtheta_rad),
            dv_b: f(s.dv_mps),
        }));
        last_t = s.t;
        while let Some(m) = masters.next_if(|m| m.t - shift <= s.t) {
            out.push(Message::MasterNav(MasterNavMsg {
                t: m.t - shift,
                q_bm_n: m.q_bm_n,
                v_n: f(m.v_n_mps),
                lat_rad: m.lat_deg.to_radians(),
                lon_rad: m.lon_deg.to_radians(),
                height_m: m.height_m as f32,
                w_ib_bm: m.omega_ib_bm_radps.map(f),
            }));
        }
    }
    out.push(Message::End(EndMsg { t: last_t }));
    out
}

/// The watcher's report after one master update of the host's own run.
#[derive(Clone, Copy, Debug)]
pub struct WatchPoint {
    /// Master updates so far (the board numbers its Status frames by them).
    pub updates: u32,
    /// The update's time of validity (s).
    pub t: f64,
    /// What the watcher says then.
    pub report: WatchReport,
}

/// The board's watcher run on the host: the stream's messages (as [`stream_messages`]
/// builds them) through `Engine<f32>` of the board's size and [`Watch<f32>`], fed as the
/// firmware's application feeds them (each master message to the watcher before the
/// engine, each update's report after). One point per master update.
pub fn host_watch(msgs: &[Message]) -> Result<Vec<WatchPoint>, String> {
    let Some(Message::Config(c)) = msgs.first() else {
        return Err("the stream does not start with a Config".into());
    };
    let cfg = c.to_engine::<f32>();
    if cfg.augmentation.is_empty() {
        watch_run::<{ flexcal_core::model::N }>(cfg, msgs)
    } else {
        watch_run::<33>(cfg, msgs)
    }
}

fn watch_run<const S: usize>(
    cfg: flexcal_core::engine::EngineConfig<f32>,
    msgs: &[Message],
) -> Result<Vec<WatchPoint>, String> {
    use flexcal_core::engine::{Engine, StepReports};
    let mut watch = Watch::<f32>::new(&cfg);
    let mut engine = Engine::<f32, S>::new(cfg).map_err(|e| format!("engine: {e:?}"))?;
    let mut reports = StepReports::new();
    let mut out = Vec::new();
    let mut updates = 0u32;
    for m in msgs {
        match m {
            Message::ImuSample(s) => {
                // Refusals are the engine's counters, as on the board.
                let _ = engine.push_imu(s.to_engine(), &mut reports);
            }
            Message::MasterNav(n) => {
                let nav = n.to_engine();
                watch.observe_master(&nav);
                let _ = engine.push_master(nav, &mut reports);
            }
            Message::End(_) => engine.flush(&mut reports),
            _ => continue,
        }
        for r in &reports {
            watch.observe(r);
            updates += 1;
            out.push(WatchPoint {
                updates,
                t: r.t,
                report: watch.report(),
            });
        }
        reports.clear();
    }
    Ok(out)
}

/// Each message as one frame on the wire (sequence numbers per stream from 0).
pub fn encode_frames(msgs: &[Message]) -> Result<Vec<Vec<u8>>, String> {
    let mut enc = flexcal_core::link::Encoder::new();
    msgs.iter()
        .map(|m| {
            let mut buf = [0u8; MAX_FRAME_LEN];
            let n = enc
                .encode(m, &mut buf)
                .map_err(|e| format!("cannot encode {:?} at t = {}: {e:?}", m.kind(), m.time()))?;
            Ok(buf[..n].to_vec())
        })
        .collect()
}

/// How the link bytes reach the firmware in QEMU.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Transport {
    /// The board's USART1, connected to QEMU's `-serial` (a TCP socket of this process).
    Uart,
    /// Semihosting files read and written in 4 KiB blocks (`in=`/`out=`): the same frames,
    /// decoder and application, without QEMU's one-byte-per-main-loop-turn USART model.
    Semihosting,
}

/// How QEMU's clock runs and what the firmware measures with it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Timing {
    /// Real time; the firmware's SysTick figures are not meaningful.
    Wall,
    /// `-icount shift=0`: one nanosecond of virtual time per instruction; the firmware
    /// times the processing of each transport read (`systick-busy`).
    Icount,
    /// `-icount shift=0` and the firmware's sampling profiler (`profile-*` per phase).
    Profile,
}

/// The board's core clock in QEMU's virtual time: SysTick ticks per instruction under
/// `-icount shift=0` (168 MHz, 1 ns per instruction).
pub const TICKS_PER_INSTRUCTION: f64 = 0.168;

/// What a QEMU run gave back.
#[derive(Debug)]
pub struct QemuRun {
    /// Exit code of QEMU (the firmware's semihosting exit: 0 success).
    pub exit_code: Option<i32>,
    /// The firmware's semihosting stdout (result line and `key value` measurements).
    pub stdout: String,
    /// The firmware's defmt frames (semihosting stderr, binary).
    pub stderr: Vec<u8>,
    /// The messages the firmware sent on the serial line, in order.
    pub received: Vec<Message>,
    /// Frames on the serial line the host could not decode.
    pub rx_errors: u32,
    /// Wall-clock time of the run.
    pub wall: Duration,
}

impl QemuRun {
    /// The value of a `key value` line of the firmware's stdout.
    pub fn metric(&self, key: &str) -> Option<u64> {
        self.stdout.lines().find_map(|l| {
            let (k, v) = l.trim().split_once(' ')?;
            (k == key).then(|| v.trim().parse().ok())?
        })
    }

    /// Every `key value` line of the firmware's stdout.
    pub fn metrics(&self) -> std::collections::BTreeMap<String, u64> {
        self.stdout
            .lines()
            .filter_map(|l| {
                let (k, v) = l.trim().split_once(' ')?;
                Some((k.to_string(), v.trim().parse().ok()?))
            })
            .collect()
    }

    /// The messages received that `pick` takes, in order.
    fn received_of<M>(&self, pick: impl Fn(&Message) -> Option<M>) -> Vec<M> {
        self.received.iter().filter_map(pick).collect()
    }

    /// The Estimates messages received.
    pub fn estimates(&self) -> Vec<EstimatesMsg> {
        self.received_of(|m| match m {
            Message::Estimates(e) => Some(*e),
            _ => None,
        })
    }

    /// The Effects messages received.
    pub fn effects(&self) -> Vec<EffectsMsg> {
        self.received_of(|m| match m {
            Message::Effects(e) => Some(*e),
            _ => None,
        })
    }

    /// The last Status message received.
    pub fn last_status(&self) -> Option<StatusMsg> {
        self.statuses().last().copied()
    }

    /// Every Status message received, in order.
    pub fn statuses(&self) -> Vec<StatusMsg> {
        self.received_of(|m| match m {
            Message::Status(s) => Some(*s),
            _ => None,
        })
    }
}

/// The first time a watcher flagged the model incomplete, and the effect it named: from
/// `(time, report)` pairs in order.
pub fn first_flag(points: impl IntoIterator<Item = (f64, WatchReport)>) -> Option<(f64, Effect)> {
    points.into_iter().find_map(|(t, r)| match r.verdict {
        Verdict::ModelIncomplete { most_likely } => Some((t, most_likely)),
        _ => None,
    })
}

/// A watcher's report as JSON (`summary.json` → `watch`), with the first flag if any.
fn watch_json(r: &WatchReport, first: Option<(f64, Effect)>) -> serde_json::Value {
    serde_json::json!({
        "verdict": verdict_text(r.verdict),
        "windows": r.windows,
        "nis": r.nis,
        "whiteness": r.whiteness,
        "delay_s": r.delay.estimate,
        "delay_sigma_s": r.delay.sigma,
        "delay_lm": r.delay.lm,
        "delay_t2": r.delay.t2,
        "first_flag_t_s": first.map(|f| f.0),
        "first_flag_effect": first.map(|f| f.1.name()),
    })
}

/// A verdict in words ("model incomplete: most likely time_delay").
pub fn verdict_text(v: Verdict) -> String {
    const AXIS: [&str; AXES] = [
        "velocity E",
        "velocity N",
        "velocity U",
        "attitude x",
        "attitude y",
        "attitude z",
        "rate x",
        "rate y",
        "rate z",
    ];
    match v {
        Verdict::Warming => "warming up".into(),
        Verdict::Consistent => "consistent".into(),
        Verdict::ModelIncomplete { most_likely } => {
            format!("model incomplete: most likely {}", most_likely.name())
        }
        Verdict::NisOutOfBand { axis } => format!(
            "NIS out of band on {}, no candidate explains it",
            AXIS.get(usize::from(axis)).unwrap_or(&"?")
        ),
    }
}

/// Runs `elf` in QEMU netduinoplus2 in replay mode, sends `bytes` through `transport` and
/// collects what it sends back until it exits (or `timeout` passes: then it is killed and this
/// fails). `work_dir` holds the semihosting files.
pub fn run_qemu(
    elf: &Path,
    bytes: &[u8],
    transport: Transport,
    timing: Timing,
    timeout: Duration,
    work_dir: &Path,
) -> Result<QemuRun, String> {
    if !elf.is_file() {
        return Err(format!(
            "no firmware image at {} (build it with `cargo fw-build`)",
            elf.display()
        ));
    }
    let mut semihosting =
        String::from("enable=on,target=native,arg=flexcal-firmware,arg=mode=replay");
    let mut cmd = Command::new("qemu-system-arm");
    cmd.args([
        "-cpu",
        "cortex-m4",
        "-machine",
        "netduinoplus2",
        "-nographic",
    ])
    .args(["-monitor", "none"]);
    if timing != Timing::Wall {
        cmd.args(["-icount", "shift=0"]);
    }
    if timing == Timing::Profile {
        semihosting.push_str(",arg=profile");
    }
    let listener = match transport {
        Transport::Uart => {
            let l = TcpListener::bind("127.0.0.1:0")
                .map_err(|e| format!("cannot listen on localhost: {e}"))?;
            let port = l.local_addr().map_err(|e| e.to_string())?.port();
            cmd.args(["-serial", &format!("tcp:127.0.0.1:{port}")]);
            l.set_nonblocking(true).map_err(|e| e.to_string())?;
            Some(l)
        }
        Transport::Semihosting => None,
    };
    let files = match transport {
        Transport::Uart => None,
        Transport::Semihosting => {
            std::fs::create_dir_all(work_dir)
                .map_err(|e| format!("{}: {e}", work_dir.display()))?;
            let dir = std::fs::canonicalize(work_dir).map_err(|e| e.to_string())?;
            let (i, o) = (dir.join("link-in.bin"), dir.join("link-out.bin"));
            for p in [&i, &o] {
                let text = p.to_string_lossy();
                if text.contains(',') || text.contains(' ') || text.len() > 250 {
                    return Err(format!(
                        "semihosting path unusable (comma, space or long): {text}"
                    ));
                }
            }
            std::fs::write(&i, bytes).map_err(|e| format!("{}: {e}", i.display()))?;
            let _ = std::fs::remove_file(&o);
            semihosting.push_str(&format!(",arg=in={},arg=out={}", i.display(), o.display()));
            cmd.args(["-serial", "null"]);
            Some(o)
        }
    };
    cmd.args(["-semihosting-config", &semihosting]);
    let start = Instant::now();
    let mut child = cmd
        .arg("-kernel")
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot start qemu-system-arm: {e}"))?;
    let mut out_pipe = child.stdout.take().ok_or("no stdout pipe")?;
    let mut err_pipe = child.stderr.take().ok_or("no stderr pipe")?;
    let out_reader = std::thread::spawn(move || {
        let mut b = Vec::new();
        let _ = out_pipe.read_to_end(&mut b);
        b
    });
    let err_reader = std::thread::spawn(move || {
        let mut b = Vec::new();
        let _ = err_pipe.read_to_end(&mut b);
        b
    });

    let mut serial_threads = None;
    if let Some(listener) = listener {
        // QEMU connects at start-up; wait for it (or for it to die).
        let stream = loop {
            match listener.accept() {
                Ok((s, _)) => break s,
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                    if let Ok(Some(st)) = child.try_wait() {
                        return Err(format!(
                            "qemu-system-arm exited ({st}) before connecting its serial port"
                        ));
                    }
                    if start.elapsed() > Duration::from_secs(30) {
                        let _ = child.kill();
                        let _ = child.wait();
                        return Err("qemu-system-arm did not connect its serial port".into());
                    }
                    std::thread::sleep(Duration::from_millis(5));
                }
                Err(e) => return Err(format!("accept: {e}")),
            }
        };
        stream.set_nonblocking(false).map_err(|e| e.to_string())?;
        let _ = stream.set_nodelay(true);
        let mut tx = stream.try_clone().map_err(|e| e.to_string())?;
        let mut rx = stream;
        let payload = bytes.to_vec();
        let (ready_tx, ready_rx) = std::sync::mpsc::channel::<()>();
        let writer = std::thread::spawn(move || -> Result<(), String> {
            // The board's first frame says its USART is enabled: bytes sent earlier are lost.
            ready_rx
                .recv_timeout(Duration::from_secs(30))
                .map_err(|_| "the firmware never said it was ready".to_string())?;
            // Blocks whenever QEMU's USART holds back (TCP flow control): nothing is dropped.
            tx.write_all(&payload)
                .map_err(|e| format!("serial write: {e}"))?;
            tx.flush().map_err(|e| format!("serial write: {e}"))
        });
        let reader = std::thread::spawn(move || {
            let mut receiver = Receiver::new();
            let mut decoded = Decoded::default();
            let mut ready = Some(ready_tx);
            let mut buf = [0u8; 4096];
            loop {
                match rx.read(&mut buf) {
                    Ok(0) | Err(_) => break,
                    Ok(n) => {
                        decoded.push(&mut receiver, &buf[..n]);
                        if !decoded.msgs.is_empty() {
                            if let Some(r) = ready.take() {
                                let _ = r.send(());
                            }
                        }
                    }
                }
            }
            decoded
        });
        serial_threads = Some((writer, reader));
    }

    let status = loop {
        if let Ok(Some(st)) = child.try_wait() {
            break Some(st);
        }
        if start.elapsed() > timeout {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    let wall = start.elapsed();
    let stdout = String::from_utf8_lossy(&out_reader.join().unwrap_or_default()).into_owned();
    let stderr = err_reader.join().unwrap_or_default();
    let (decoded, write_result) = match (serial_threads, files) {
        (Some((writer, reader)), _) => (
            reader.join().unwrap_or_default(),
            writer
                .join()
                .unwrap_or_else(|_| Err("serial writer panicked".into())),
        ),
        (None, Some(out_file)) => {
            let bytes = std::fs::read(&out_file).unwrap_or_default();
            let mut d = Decoded::default();
            d.push(&mut Receiver::new(), &bytes);
            (d, Ok(()))
        }
        (None, None) => (Decoded::default(), Ok(())),
    };
    let Some(status) = status else {
        return Err(format!(
            "the firmware did not end within {timeout:?} in QEMU (killed); stdout:\n{stdout}"
        ));
    };
    if let Err(e) = write_result {
        if !stdout.contains("flexcal-firmware replay ok") {
            return Err(format!("{e}; QEMU {status}, stdout:\n{stdout}"));
        }
    }
    Ok(QemuRun {
        exit_code: status.code(),
        stdout,
        stderr,
        received: decoded.msgs,
        rx_errors: decoded.errors,
        wall,
    })
}

#[derive(Default)]
struct Decoded {
    msgs: Vec<Message>,
    errors: u32,
}

impl Decoded {
    fn push(&mut self, receiver: &mut Receiver, bytes: &[u8]) {
        for b in bytes {
            match receiver.push(*b) {
                Some(Ok(r)) => self.msgs.push(r.frame.message),
                Some(Err(_)) => self.errors += 1,
                None => {}
            }
        }
    }
}

/// The Estimates messages as `calibrate`'s rows (f64, SI).
pub fn rows(estimates: &[EstimatesMsg]) -> Vec<EstimateRow> {
    let d = |v: [f32; 3]| v.map(f64::from);
    estimates
        .iter()
        .map(|e| EstimateRow {
            t: e.t,
            gyro_bias: d(e.gyro_bias),
            gyro_bias_sigma: d(e.gyro_bias_sigma),
            accel_bias: d(e.accel_bias),
            accel_bias_sigma: d(e.accel_bias_sigma),
            misalignment: d(e.misalignment),
            misalignment_sigma: d(e.misalignment_sigma),
            flexure: d(e.flexure),
            flexure_sigma: d(e.flexure_sigma),
        })
        .collect()
}

/// One Effects report: every block of the layout at one time.
type EffectsReport = Vec<EffectRow>;

/// The board's Effects frames reassembled into reports, one per Estimates, each with one
/// row per block in state order. A report is complete when every page of its layout has
/// arrived with the same time and layout; an incomplete one (a lost frame) is skipped.
///
/// `wald` of a board row is `Σ (value/σ)²` over the block: the board sends each state's σ
/// but not the block's off-diagonal covariance, so this is the Wald statistic
/// `x̂ᵀ P⁻¹ x̂` of `calibrate` with P taken diagonal (the same for a one-state block such
/// as `time_delay`; for a larger block it ignores the correlations between its states).
pub fn effect_reports(msgs: &[EffectsMsg]) -> Vec<EffectsReport> {
    /// A report being gathered: its time and layout, its states so far, pages seen.
    struct Open {
        t: f64,
        layout: [Option<Effect>; MAX_EFFECTS],
        states: Vec<(f32, f32)>,
        pages: usize,
    }
    let mut out = Vec::new();
    let mut open: Option<Open> = None;
    for m in msgs {
        let next = open
            .as_ref()
            .is_some_and(|o| o.t == m.t && o.layout == m.layout && o.pages == usize::from(m.page));
        if !next {
            // A new report starts at its first page; anything else is a fragment.
            open = (m.page == 0).then(|| Open {
                t: m.t,
                layout: m.layout,
                states: Vec::new(),
                pages: 0,
            });
        }
        let Some(o) = open.as_mut() else {
            continue;
        };
        o.states.extend(m.states().map(|(_, _, v, s)| (v, s)));
        o.pages += 1;
        if o.pages < EffectsMsg::frames(&m.layout) {
            continue;
        }
        let mut rows = Vec::new();
        let mut at = 0;
        for effect in o.layout.iter().flatten() {
            let k = effect.states();
            let block = o.states.get(at..at + k).unwrap_or(&[]);
            at += k;
            let value: Vec<f64> = block.iter().map(|(v, _)| f64::from(*v)).collect();
            let sigma: Vec<f64> = block.iter().map(|(_, s)| f64::from(*s)).collect();
            let wald = value
                .iter()
                .zip(&sigma)
                .map(|(v, s)| (v / s) * (v / s))
                .sum();
            rows.push(EffectRow {
                t: o.t,
                effect: *effect,
                value,
                sigma,
                wald,
            });
        }
        out.push(rows);
        open = None;
    }
    out
}

/// A `CalibResult` from what the board sent: the rows, the effects' rows (layouts with
/// effects; `wald` as [`effect_reports`] says), the counters of its last Status, the
/// diagonal of the final covariance from the σ (the board sends no innovations and no
/// off-diagonal covariance).
pub fn result_from_board(run: &QemuRun) -> Result<CalibResult, String> {
    let mut est = run.estimates();
    let mut effects = effect_reports(&run.effects());
    // The final Estimates repeats the last update's (sent again at End): keep one, and
    // the same for the Effects report that goes with it.
    if est.len() >= 2 && est[est.len() - 1] == est[est.len() - 2] {
        est.pop();
        if effects.len() >= 2 && effects[effects.len() - 1] == effects[effects.len() - 2] {
            effects.pop();
        }
    }
    let rows = rows(&est);
    let status = run
        .last_status()
        .ok_or("the firmware sent no Status message")?;
    let last = rows.last().copied().unwrap_or_default();
    let sig: Vec<f64> = [
        last.gyro_bias_sigma,
        last.accel_bias_sigma,
        last.misalignment_sigma,
    ]
    .concat();
    let final_cov9 =
        SMatrix::<f64, 9, 9>::from_fn(|i, j| if i == j { sig[i] * sig[i] } else { 0.0 });
    Ok(CalibResult {
        rows,
        innovations: Vec::new(),
        summary: Default::default(),
        counters: status.engine,
        master: None,
        health: status.health,
        covariance: CovarianceCheck::default(),
        final_cov9,
        precision: Precision::F32,
        effect_rows: effects.into_iter().flatten().collect(),
    })
}

/// What `flexcal replay` did, before its outputs are written.
pub struct Replayed {
    /// The recording.
    pub rec: Recording,
    /// The model learned from the recording, when none was declared (or `tune = true`).
    pub learned: Option<crate::learn::Learned>,
    /// The configuration as resolved (and the flexure model as chosen).
    pub cfg: CalibConfig,
    /// The configuration file declared, if any.
    pub config_file: Option<PathBuf>,
    /// Where the flexure model came from.
    pub flexure_source: String,
    /// Frames sent to the board.
    pub frames_sent: usize,
    /// The QEMU run.
    pub qemu: QemuRun,
    /// The board's results as `calibrate`'s (effects' rows included).
    pub result: CalibResult,
    /// The host's own run of the board's watcher over the same stream ([`host_watch`]).
    pub host_watch: Vec<WatchPoint>,
}

/// `flexcal replay` up to its outputs: resolves the configuration as `calibrate` does,
/// streams the recording through the firmware in QEMU and gathers what it sent. Fails if
/// the firmware does.
pub fn replay(a: &Args) -> Result<Replayed, String> {
    if !a.qemu {
        return Err("replay needs a runner: only `--qemu` exists".into());
    }
    let rec = read_recording(&a.rec_dir).map_err(|e| e.to_string())?;
    let crate::cmd::calibrate::Prepared {
        cfg,
        flexure_source,
        learned,
        config_file,
        ..
    } = prepare_config(&rec, &a.rec_dir, a.config.as_deref(), &a.model)?;
    let msgs = stream_messages(&rec, &cfg, a.estimates_every, a.status_every);
    let frames = encode_frames(&msgs)?;
    let bytes = frames.concat();
    let elf = a.elf.clone().unwrap_or_else(|| PathBuf::from(DEFAULT_ELF));
    let qemu = run_qemu(
        &elf,
        &bytes,
        a.transport,
        a.timing(),
        Duration::from_secs(a.timeout_s),
        &a.out,
    )?;
    if qemu.exit_code != Some(0) || !qemu.stdout.contains("flexcal-firmware replay ok") {
        return Err(format!(
            "the firmware failed in QEMU (exit {:?}); stdout:\n{}",
            qemu.exit_code, qemu.stdout
        ));
    }
    if qemu.metric("config-refused").is_some_and(|n| n > 0) {
        let dim = cfg.augmentation::<f64>().map_or(0, |a| a.dimension());
        return Err(if qemu.metric("config-too-large").is_some_and(|n| n > 0) {
            format!(
                "the board refused the configuration: its layout ({}) needs {dim} states, \
                 more than the firmware holds (`FIRMWARE_MAX_STATES`, firmware/src/app.rs)",
                cfg.effects.join(", ")
            )
        } else {
            "the board's engine refused the configuration".to_string()
        });
    }
    let result = result_from_board(&qemu)?;
    let host_watch = host_watch(&msgs)?;
    Ok(Replayed {
        rec,
        learned,
        cfg,
        config_file,
        flexure_source,
        frames_sent: frames.len(),
        qemu,
        result,
        host_watch,
    })
}

impl Args {
    /// The clock the run asks for.
    pub fn timing(&self) -> Timing {
        match (self.icount, self.profile) {
            (false, _) => Timing::Wall,
            (true, false) => Timing::Icount,
            (true, true) => Timing::Profile,
        }
    }
}

/// Instructions per master update of an `--icount` run, whole (`Timing::Icount`) or per
/// profiler phase (`Timing::Profile`: `(phase, instructions)`, the idle loop left out).
pub fn cost_per_update(run: &QemuRun) -> Option<Vec<(String, f64)>> {
    let updates = run.metric("master-updates").filter(|&n| n > 0)? as f64;
    let per_update = |ticks: f64| ticks / TICKS_PER_INSTRUCTION / updates;
    if let Some(busy) = run.metric("systick-busy") {
        return Some(vec![("total".to_string(), per_update(busy as f64))]);
    }
    let period = run.metric("profile-period-ticks")? as f64;
    let phases: Vec<(String, f64)> = run
        .metrics()
        .into_iter()
        .filter_map(|(k, v)| {
            let name = k.strip_prefix("profile-")?;
            (name != "period-ticks" && name != "idle")
                .then(|| (name.to_string(), per_update(v as f64 * period)))
        })
        .collect();
    Some(phases)
}

/// Runs `flexcal replay`.
pub fn run(a: &Args) -> Result<(), String> {
    let progress = crate::cmd::progress::Progress::start("replaying through the firmware in QEMU");
    let r = replay(a)?;
    drop(progress);
    write_outputs(a, &r)?;
    if a.icount {
        if let Some(cost) = cost_per_update(&r.qemu) {
            let sum: f64 = cost.iter().map(|(_, v)| v).sum();
            let parts: Vec<String> = cost
                .iter()
                .map(|(k, v)| format!("{k} {:.1}k", v / 1e3))
                .collect();
            println!(
                "  instructions per master update: {} (sum {:.1}k); stack high-water {} B",
                parts.join(", "),
                sum / 1e3,
                r.qemu.metric("stack-high-water-bytes").unwrap_or(0)
            );
        }
    }
    Ok(())
}

/// Writes `summary.json` and `estimates.csv` of a replay into `a.out` and prints the
/// summary line and the verdict; fails when the verdict is FAIL (frames lost on the
/// way to the board are a FAIL).
pub fn write_outputs(a: &Args, r: &Replayed) -> Result<(), String> {
    let (rec, cfg, flexure_source, qemu, res) =
        (&r.rec, &r.cfg, &r.flexure_source, &r.qemu, &r.result);
    let status = qemu.last_status().ok_or("no Status")?;
    let sent_frames = r.frames_sent as u32;
    let lost = sent_frames.wrapping_sub(status.link.decoder.frames);
    std::fs::create_dir_all(&a.out).map_err(|e| format!("{}: {e}", a.out.display()))?;
    let duration = match rec.imu.last() {
        Some(l) => l.t - rec.imu_t0,
        None => 0.0,
    };
    let mut doc = summary::summary_json(
        &a.rec_dir.display().to_string(),
        duration,
        cfg,
        flexure_source,
        res,
        None,
    );
    if let Some(obj) = doc.as_object_mut() {
        obj.insert("runner".into(), serde_json::json!("qemu"));
        obj.insert(
            "transport".into(),
            serde_json::json!(match a.transport {
                Transport::Uart => "uart",
                Transport::Semihosting => "semihosting",
            }),
        );
        obj.insert(
            "link".into(),
            serde_json::json!({
                "frames_sent": sent_frames,
                "frames_received_by_board": status.link.decoder.frames,
                "frames_lost": lost,
                "frame_errors_on_board": status.link.decoder.errors(),
                "sequence_rejected_on_board": status.link.sequence.rejected(),
                "estimates_frames_from_board": qemu.estimates().len(),
                "frame_errors_from_board": qemu.rx_errors,
            }),
        );
        let board_first = first_flag(qemu.statuses().iter().map(|s| (s.t, s.watch)));
        let host_first = first_flag(r.host_watch.iter().map(|p| (p.t, p.report)));
        let host_last = r.host_watch.last().map(|p| p.report).unwrap_or_default();
        obj.insert(
            "watch".into(),
            serde_json::json!({
                "board": watch_json(&status.watch, board_first),
                "host": watch_json(&host_last, host_first),
            }),
        );
        obj.insert(
            "qemu".into(),
            serde_json::json!({
                "wall_s": qemu.wall.as_secs_f64(),
                "icount": a.icount,
                "profile": a.profile,
                "firmware": qemu.metrics(),
            }),
        );
    }
    let mut doc = crate::cmd::calibrate::with_learned(doc, r.learned.as_ref());
    let mut scan = crate::verdict::input::Scan::of_dir(&a.rec_dir)?;
    let mut verdict = crate::verdict::of_calibration(
        &mut scan,
        r.config_file.as_deref(),
        r.learned.as_ref(),
        cfg,
        res,
    );
    if lost != 0 {
        verdict.extend([crate::verdict::Finding::new(
            crate::verdict::Severity::Fail,
            "frames_lost",
            format!("{lost} of {sent_frames} frames were lost on the way to the board"),
        )
        .num("frames_lost", f64::from(lost))
        .num("frames_sent", f64::from(sent_frames))]);
    }
    verdict.insert_into(&mut doc);
    if let Some(l) = &r.learned {
        crate::cmd::calibrate::write_model_toml(&a.out, l)?;
    }
    super::common::write_json(&a.out.join("summary.json"), &doc)?;
    summary::write_estimates_csv(&a.out.join("estimates.csv"), &res.rows)
        .map_err(|e| e.to_string())?;
    let label = a.rec_dir.display().to_string();
    let plot_files =
        crate::report::plots::write_estimate_plots(&a.out, &label, &res.rows, rec.truth.as_ref())
            .map_err(|e| e.to_string())?;
    let report = crate::report::markdown::ReportInput {
        label: &label,
        meta: &rec.meta,
        master_total: rec.master.len(),
        duration_s: duration,
        cfg,
        model_origin: crate::cmd::calibrate::model_origin(
            r.config_file.as_deref(),
            r.learned.as_ref(),
        ),
        flexure_source,
        score: None,
        plots: &plot_files,
    };
    let path = a.out.join("report.md");
    std::fs::write(
        &path,
        crate::report::markdown::report_md(&report, res, &verdict),
    )
    .map_err(|e| format!("{}: {e}", path.display()))?;
    println!(
        "replayed {} ({} s) in QEMU: {} frames sent, {} received by the board, {} estimates back ({:.1} s) -> {}",
        a.rec_dir.display(),
        duration,
        sent_frames,
        status.link.decoder.frames,
        res.rows.len(),
        qemu.wall.as_secs_f64(),
        a.out.display()
    );
    let board_first = first_flag(qemu.statuses().iter().map(|s| (s.t, s.watch)));
    let host_first = first_flag(r.host_watch.iter().map(|p| (p.t, p.report)));
    let flag = |f: Option<(f64, Effect)>| {
        f.map_or(String::new(), |(t, e)| {
            format!(", first flagged at {t:.2} s ({})", e.name())
        })
    };
    let w = &status.watch;
    println!(
        "  watch (board): {}{}; delay {:+.2} ± {:.2} ms (t² {:.1}) over the last {} s window",
        verdict_text(w.verdict),
        flag(board_first),
        w.delay.estimate * 1e3,
        w.delay.sigma * 1e3,
        w.delay.t2,
        flexcal_core::watch::WINDOW_S
    );
    println!(
        "  watch NIS (vel E N U, att x y z, rate x y z): {:.2?}; lag-1 whiteness: {:.2?}",
        w.nis, w.whiteness
    );
    if let Some(h) = r.host_watch.last() {
        println!(
            "  watch (host, same stream): {}{}",
            verdict_text(h.report.verdict),
            flag(host_first)
        );
    }
    for r in res.final_effects() {
        use crate::report::units::{list, of_effect_unit};
        let u = of_effect_unit(r.effect.unit());
        println!(
            "  {} ({}): [{}] ± [{}]",
            r.effect.name(),
            u.name,
            list(&r.value, u),
            list(&r.sigma, u)
        );
    }
    verdict.conclude()
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;
    use flexcal_core::engine::EffectEstimate;

    fn block(effect: Effect, base: f64) -> EffectEstimate<f64> {
        let mut b = EffectEstimate {
            effect,
            value: [0.0; 9],
            sigma: [0.0; 9],
        };
        for k in 0..effect.states() {
            b.value[k] = base + k as f64;
            b.sigma[k] = 0.5;
        }
        b
    }

    fn pages(t: f64, blocks: &[EffectEstimate<f64>]) -> Vec<EffectsMsg> {
        (0..)
            .map_while(|p| EffectsMsg::from_estimates(t, blocks, p))
            .collect()
    }

    #[test]
    fn effects_frames_reassemble_into_reports() {
        // 9 + 9 + 1 = 19 states: two frames per report.
        let blocks = [
            block(Effect::GyroGSensitivity, 1.0),
            block(Effect::LeverArmCoupling, 10.0),
            block(Effect::TimeDelay, -2.0),
        ];
        let mut msgs = pages(1.0, &blocks);
        assert_eq!(msgs.len(), 2);
        // A report that lost its first frame, then a whole one.
        msgs.push(pages(2.0, &blocks)[1]);
        msgs.extend(pages(3.0, &blocks));
        let reports = effect_reports(&msgs);
        assert_eq!(reports.len(), 2, "the fragment is skipped");
        let r = &reports[1];
        assert_eq!(r.len(), 3);
        assert_eq!((r[0].t, r[0].effect), (3.0, Effect::GyroGSensitivity));
        assert_eq!(r[1].value, (10..19).map(f64::from).collect::<Vec<_>>());
        assert_eq!(r[2].value, [-2.0]);
        assert_eq!(r[2].sigma, [0.5]);
        assert_eq!(r[2].wald, 16.0, "(−2 / 0.5)²");
        let want: f64 = (1..10).map(|v| (f64::from(v) / 0.5).powi(2)).sum();
        assert!((r[0].wald - want).abs() < 1e-9 * want);
    }
}
