//! The application: link bytes in, estimates and status frames out, the engine in between.
//!
//! ```text
//! bytes ─> Receiver ─┬─ Config    ─> (re)create Engine<f32>, reset the identifiers
//!                    ├─ ImuSample ─> ReplaySource ─> Engine::push_imu ─┐
//!                    ├─ MasterNav ─> Engine::push_master ──────────────┼─> per master update:
//!                    └─ End       ─> Engine::flush, final reports      │   Estimates every n-th,
//!                                                                      │   Status every m-th,
//!                                                                      └─> AR identifier (θ̂)
//! ```
//!
//! Host-testable: no heap, no panic, no hardware. The board loop (`src/board/`) feeds it
//! the bytes of the USART and writes what it emits back to the USART; the host tests feed
//! it encoded recordings and compare with the engine driven directly.
//!
//! Order: every frame is handled completely before the next byte is taken, and the replay
//! queue is drained into the engine at once, so the engine sees IMU samples and master
//! messages exactly in stream order (as `flexcal calibrate` feeds them).
//!
//! Counting: link faults (framing, CRC, bad payloads, duplicates, out-of-order, gaps) are
//! counted by the [`Receiver`] and reported in every Status; what the application refuses or
//! drops is counted in [`AppCounters`] (logged at the end of the stream).
//!
//! Flexure identification: one [`ArIdentifier`] per axis runs alongside the filter on the
//! engine's **flexure estimate θ̂** (the `flexure` of [`Estimates`](flexcal_core::engine::Estimates)),
//! sampled after every master update. [`App::flexure_fit`] gives the BIC-selected AR order,
//! coefficients and noise per axis; the board logs them at the end of the stream.

use flexcal_core::engine::{Engine, ImuIncrement, MatchReport};
use flexcal_core::ident::{ArIdentifier, Criterion};
use flexcal_core::link::{
    ConfigMsg, Encoder, EstimatesMsg, HealthFlags, LinkCounters, Message, Receiver, StatusMsg,
    MAX_FRAME_LEN,
};

use crate::imu::ImuSource;
use crate::replay::ReplaySource;

/// Largest AR order the on-board flexure identifier fits.
pub const IDENT_MAX_ORDER: usize = 2;

/// What the application refused, dropped or sent (each a wrapping `u32`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AppCounters {
    /// Config messages that (re)created the engine.
    pub configs: u32,
    /// Config messages the engine refused (it then has no engine until the next good one).
    pub config_refused: u32,
    /// IMU and master messages dropped because no engine was configured.
    pub no_engine: u32,
    /// IMU increments the engine refused (non-finite, time not increasing).
    pub imu_refused: u32,
    /// IMU source errors (SPI source) or replay samples dropped for a full queue.
    pub imu_lost: u32,
    /// Master messages the engine refused (stale, out of order, overflow, non-finite).
    pub master_refused: u32,
    /// Master updates (matched master messages) since the last Config.
    pub master_updates: u32,
    /// Estimates frames sent.
    pub estimates_sent: u32,
    /// Status frames sent.
    pub status_sent: u32,
    /// Frames that could not be encoded (a non-finite estimate).
    pub encode_errors: u32,
    /// Board → host messages received (Estimates, Status): ignored.
    pub unexpected: u32,
    /// End messages received.
    pub ends: u32,
}

/// The flexure model identified on one axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisFit {
    /// Selected order (BIC), `0..=IDENT_MAX_ORDER`.
    pub order: usize,
    /// `[a1, a2]` (zeros beyond the order).
    pub coefficients: [f32; IDENT_MAX_ORDER],
    /// Driving-noise standard deviation (rad).
    pub sigma_rad: f32,
    /// Residuals used.
    pub residuals: usize,
}

/// The application state. Large (the engine is a few kB): keep one, in a static or low on
/// the stack.
#[derive(Clone, Debug)]
pub struct App {
    rx: Receiver,
    tx: Encoder,
    engine: Option<Engine<f32>>,
    config: Option<ConfigMsg>,
    replay: ReplaySource,
    ident: [ArIdentifier<f32, IDENT_MAX_ORDER>; 3],
    counters: AppCounters,
    /// Latest time of validity received (s).
    last_t: f64,
    ended: bool,
}

impl Default for App {
    fn default() -> Self {
        Self::new()
    }
}

impl App {
    /// No engine yet: the first Config message creates it.
    pub fn new() -> Self {
        Self {
            rx: Receiver::new(),
            tx: Encoder::new(),
            engine: None,
            config: None,
            replay: ReplaySource::new(),
            ident: [ArIdentifier::new(); 3],
            counters: AppCounters::default(),
            last_t: 0.0,
            ended: false,
        }
    }

    /// Feeds one received byte; frames to send go to `out` (one call per frame).
    pub fn push_byte<W: FnMut(&[u8])>(&mut self, byte: u8, out: &mut W) {
        match self.rx.push(byte) {
            Some(Ok(r)) => self.handle(&r.frame.message, out),
            Some(Err(_e)) => {
                debug!("link: frame refused");
            }
            None => {}
        }
    }

    /// Feeds a run of received bytes.
    pub fn push_bytes<W: FnMut(&[u8])>(&mut self, bytes: &[u8], out: &mut W) {
        for b in bytes {
            self.push_byte(*b, out);
        }
    }

    /// Takes every increment `source` has ready (an SPI sensor, for instance) into the
    /// engine; returns how many.
    pub fn pump<S: ImuSource, W: FnMut(&[u8])>(&mut self, source: &mut S, out: &mut W) -> usize {
        let mut n = 0;
        loop {
            match source.poll() {
                Ok(Some(inc)) => {
                    n += 1;
                    self.push_increment(inc, out);
                }
                Ok(None) => return n,
                Err(_) => {
                    self.counters.imu_lost = self.counters.imu_lost.wrapping_add(1);
                    return n;
                }
            }
        }
    }

    /// Whether an End message has been handled (and no Config since).
    pub fn ended(&self) -> bool {
        self.ended
    }

    /// The application's counters.
    pub fn counters(&self) -> AppCounters {
        self.counters
    }

    /// The link's counters.
    pub fn link_counters(&self) -> LinkCounters {
        self.rx.counters()
    }

    /// The engine, once configured.
    pub fn engine(&self) -> Option<&Engine<f32>> {
        self.engine.as_ref()
    }

    /// The configuration in use.
    pub fn config(&self) -> Option<&ConfigMsg> {
        self.config.as_ref()
    }

    /// The Status message as it would be sent now.
    pub fn status(&self) -> StatusMsg {
        StatusMsg {
            t: self.last_t,
            link: self.rx.counters(),
            engine: self
                .engine
                .as_ref()
                .map(Engine::counters)
                .unwrap_or_default(),
            health: self.engine.as_ref().map(Engine::health).unwrap_or_default(),
        }
    }

    /// The Estimates message as it would be sent now (`None` before the first Config).
    pub fn estimates(&self) -> Option<EstimatesMsg> {
        let e = self.engine.as_ref()?;
        let flags = HealthFlags::from_engine(&e.health(), &e.counters());
        Some(EstimatesMsg::from_engine(&e.estimates(), flags))
    }

    /// The flexure AR model identified so far on each axis of θ̂ (`None`: not enough data).
    pub fn flexure_fit(&self) -> [Option<AxisFit>; 3] {
        self.ident.map(|id| {
            let fits = id.fit_all();
            fits.best(Criterion::Bic).map(|f| AxisFit {
                order: f.order,
                coefficients: f.coefficients,
                sigma_rad: nalgebra::ComplexField::sqrt(f.sigma2.max(0.0)),
                residuals: f.residuals,
            })
        })
    }

    /// Sends a Status frame now (the board's "ready" at start-up).
    pub fn send_status_now<W: FnMut(&[u8])>(&mut self, out: &mut W) {
        self.send_status(out);
    }

    fn handle<W: FnMut(&[u8])>(&mut self, msg: &Message, out: &mut W) {
        match msg {
            Message::Config(c) => self.configure(c),
            Message::ImuSample(m) => {
                self.last_t = m.t;
                if self.engine.is_none() {
                    self.counters.no_engine = self.counters.no_engine.wrapping_add(1);
                    return;
                }
                if !self.replay.offer(m.to_engine()) {
                    self.counters.imu_lost = self.counters.imu_lost.wrapping_add(1);
                }
                self.drain_replay(out);
            }
            Message::MasterNav(m) => {
                self.last_t = m.t;
                self.drain_replay(out);
                let Some(engine) = self.engine.as_mut() else {
                    self.counters.no_engine = self.counters.no_engine.wrapping_add(1);
                    return;
                };
                match engine.push_master(m.to_engine()) {
                    Ok(reports) => self.on_reports(&reports, out),
                    Err(_) => {
                        self.counters.master_refused = self.counters.master_refused.wrapping_add(1);
                    }
                }
            }
            Message::End(_) => self.end(out),
            Message::Estimates(_) | Message::Status(_) => {
                self.counters.unexpected = self.counters.unexpected.wrapping_add(1);
            }
        }
    }

    fn configure(&mut self, c: &ConfigMsg) {
        self.replay.clear();
        self.ident = [ArIdentifier::new(); 3];
        self.counters.master_updates = 0;
        self.ended = false;
        match Engine::new(c.to_engine::<f32>()) {
            Ok(e) => {
                self.engine = Some(e);
                self.config = Some(*c);
                self.counters.configs = self.counters.configs.wrapping_add(1);
                info!(
                    "config: filter period {=f64} s, estimates every {=u16}, status every {=u16}",
                    c.filter_period_s, c.estimates_every, c.status_every
                );
            }
            Err(_) => {
                self.engine = None;
                self.config = None;
                self.counters.config_refused = self.counters.config_refused.wrapping_add(1);
                warn!("config refused by the engine");
            }
        }
    }

    fn end<W: FnMut(&[u8])>(&mut self, out: &mut W) {
        self.counters.ends = self.counters.ends.wrapping_add(1);
        self.drain_replay(out);
        if let Some(engine) = self.engine.as_mut() {
            let reports = engine.flush();
            self.on_reports(&reports, out);
        }
        self.send_estimates(out);
        self.send_status(out);
        self.ended = true;
    }

    fn drain_replay<W: FnMut(&[u8])>(&mut self, out: &mut W) {
        while let Ok(Some(inc)) = self.replay.poll() {
            self.push_increment(inc, out);
        }
    }

    fn push_increment<W: FnMut(&[u8])>(&mut self, inc: ImuIncrement<f32>, out: &mut W) {
        let Some(engine) = self.engine.as_mut() else {
            self.counters.no_engine = self.counters.no_engine.wrapping_add(1);
            return;
        };
        match engine.push_imu(inc) {
            Ok(reports) => self.on_reports(&reports, out),
            Err(_) => self.counters.imu_refused = self.counters.imu_refused.wrapping_add(1),
        }
    }

    fn on_reports<W: FnMut(&[u8])>(&mut self, reports: &[MatchReport<f32>], out: &mut W) {
        let Some(cfg) = self.config else {
            return;
        };
        for _ in reports {
            self.counters.master_updates = self.counters.master_updates.wrapping_add(1);
            if let Some(e) = self.engine.as_ref() {
                let th = e.estimates().flexure;
                for (id, x) in self.ident.iter_mut().zip(th.iter()) {
                    id.push(*x);
                }
            }
            let k = self.counters.master_updates;
            if cfg.estimates_every != 0 && k % u32::from(cfg.estimates_every) == 0 {
                self.send_estimates(out);
            }
            if cfg.status_every != 0 && k % u32::from(cfg.status_every) == 0 {
                self.send_status(out);
            }
        }
    }

    fn send_estimates<W: FnMut(&[u8])>(&mut self, out: &mut W) {
        if let Some(m) = self.estimates() {
            if self.send(&Message::Estimates(m), out) {
                self.counters.estimates_sent = self.counters.estimates_sent.wrapping_add(1);
            }
        }
    }

    fn send_status<W: FnMut(&[u8])>(&mut self, out: &mut W) {
        let m = self.status();
        if self.send(&Message::Status(m), out) {
            self.counters.status_sent = self.counters.status_sent.wrapping_add(1);
        }
    }

    fn send<W: FnMut(&[u8])>(&mut self, msg: &Message, out: &mut W) -> bool {
        let mut buf = [0u8; MAX_FRAME_LEN];
        match self.tx.encode(msg, &mut buf) {
            Ok(n) => {
                out(buf.get(..n).unwrap_or(&[]));
                true
            }
            Err(_) => {
                self.counters.encode_errors = self.counters.encode_errors.wrapping_add(1);
                false
            }
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use flexcal_core::engine::{EngineConfig, InitialSigma, Matching, MeasurementNoise};
    use flexcal_core::flexure::{ArAxis, FlexureModel};
    use flexcal_core::link::{EndMsg, ImuSampleMsg, MasterNavMsg, Receiver};
    use flexcal_core::model::{LeverBending, ProcessNoise};
    use nalgebra::Vector3;

    const DT: f64 = 0.01;
    const LAT: f64 = 0.7;
    const G: f32 = 9.80;
    const EARTH_RATE: f64 = 7.292_115e-5;

    fn config(estimates_every: u16, status_every: u16) -> ConfigMsg {
        let cfg = EngineConfig::<f32> {
            filter_period_s: DT,
            matching: Matching {
                velocity: true,
                attitude: true,
                angular_rate: false,
            },
            lever_arm_m: Vector3::new(1.0, 2.0, 0.5),
            bending: LeverBending::UniformArc,
            dynamic_lever_arm: true,
            flexure: FlexureModel {
                axes: [ArAxis {
                    a1: 0.5,
                    a2: 0.0,
                    sigma_rad: 1e-5,
                }; 3],
                period_s: DT as f32,
            },
            process_noise: ProcessNoise {
                accel_vrw: 1e-4,
                gyro_arw: 1e-5,
                gyro_bias_rw: 0.0,
                accel_bias_rw: 0.0,
                misalignment_rw: 0.0,
            },
            measurement_noise: MeasurementNoise {
                velocity_mps: 0.01,
                attitude_rad: 1e-4,
                rate_radps: 1e-4,
            },
            initial_sigma: InitialSigma {
                velocity_mps: 0.1,
                misalignment_rad: 0.0175,
                gyro_bias_radps: 4.8e-6,
                accel_bias_mps2: 9.8e-3,
                flexure_rad: 1e-3,
            },
            initial_misalignment_rad: Vector3::zeros(),
            gate_sigma: 5.0,
            variance_floor: 1e-9,
            augmentation: flexcal_core::augment::Augmentation::none(),
            initial_delay_s: 0.0,
        };
        ConfigMsg::from_engine(&cfg, estimates_every, status_every)
    }

    /// A stationary, level platform: Config, the IMU start sample, then `n` IMU samples
    /// each followed by the master message of the same time, then End.
    fn stream(n: usize, cfg: ConfigMsg) -> std::vec::Vec<Message> {
        let mut v = std::vec![Message::Config(cfg)];
        let w = [
            0.0,
            (EARTH_RATE * LAT.cos() * DT) as f32,
            (EARTH_RATE * LAT.sin() * DT) as f32,
        ];
        let imu = |t: f64| {
            Message::ImuSample(ImuSampleMsg {
                t,
                dtheta_b: w,
                dv_b: [1e-6, -2e-6, G * DT as f32],
            })
        };
        v.push(Message::ImuSample(ImuSampleMsg {
            t: 0.0,
            dtheta_b: [0.0; 3],
            dv_b: [0.0; 3],
        }));
        for k in 1..=n {
            let t = k as f64 * DT;
            v.push(imu(t));
            v.push(Message::MasterNav(MasterNavMsg {
                t,
                q_bm_n: [1.0, 0.0, 0.0, 0.0],
                v_n: [0.0; 3],
                lat_rad: LAT,
                lon_rad: 0.2,
                height_m: 10.0,
                w_ib_bm: None,
            }));
        }
        v.push(Message::End(EndMsg { t: n as f64 * DT }));
        v
    }

    fn encode_all(msgs: &[Message]) -> std::vec::Vec<std::vec::Vec<u8>> {
        let mut enc = Encoder::new();
        msgs.iter()
            .map(|m| {
                let mut buf = [0u8; MAX_FRAME_LEN];
                let n = enc.encode(m, &mut buf).unwrap();
                buf[..n].to_vec()
            })
            .collect()
    }

    /// Runs the app over `bytes`; returns it and the messages it sent.
    fn run_app(bytes: &[u8]) -> (App, std::vec::Vec<Message>) {
        let mut app = std::boxed::Box::new(App::new());
        let mut rx = Receiver::new();
        let mut sent = std::vec::Vec::new();
        app.push_bytes(bytes, &mut |frame: &[u8]| {
            for b in frame {
                if let Some(Ok(r)) = rx.push(*b) {
                    sent.push(r.frame.message);
                }
            }
        });
        (*app, sent)
    }

    /// The engine driven directly with the same messages, as `flexcal calibrate` does.
    fn direct(msgs: &[Message]) -> (EstimatesMsg, u32) {
        let mut engine: Option<Engine<f32>> = None;
        let mut updates = 0u32;
        for m in msgs {
            match m {
                Message::Config(c) => engine = Some(Engine::new(c.to_engine()).unwrap()),
                Message::ImuSample(s) => {
                    if let Ok(r) = engine.as_mut().unwrap().push_imu(s.to_engine()) {
                        updates += r.len() as u32;
                    }
                }
                Message::MasterNav(s) => {
                    if let Ok(r) = engine.as_mut().unwrap().push_master(s.to_engine()) {
                        updates += r.len() as u32;
                    }
                }
                Message::End(_) => updates += engine.as_mut().unwrap().flush().len() as u32,
                _ => {}
            }
        }
        let e = engine.unwrap();
        let flags = HealthFlags::from_engine(&e.health(), &e.counters());
        (EstimatesMsg::from_engine(&e.estimates(), flags), updates)
    }

    fn last_estimates(sent: &[Message]) -> EstimatesMsg {
        sent.iter()
            .rev()
            .find_map(|m| match m {
                Message::Estimates(e) => Some(*e),
                _ => None,
            })
            .unwrap()
    }

    fn last_status(sent: &[Message]) -> StatusMsg {
        sent.iter()
            .rev()
            .find_map(|m| match m {
                Message::Status(s) => Some(*s),
                _ => None,
            })
            .unwrap()
    }

    #[test]
    fn app_equals_the_engine_driven_directly() {
        let msgs = stream(1500, config(1, 100));
        let bytes: std::vec::Vec<u8> = encode_all(&msgs).concat();
        let (app, sent) = run_app(&bytes);
        let (want, updates) = direct(&msgs);
        assert!(app.ended());
        assert!(updates > 1000, "{updates} master updates");
        let c = app.counters();
        assert_eq!(c.master_updates, updates);
        assert_eq!(c.configs, 1);
        assert_eq!(
            c.estimates_sent,
            updates + 1,
            "every update, and the final one"
        );
        assert_eq!(c.status_sent, updates / 100 + 1);
        assert_eq!(
            (c.imu_refused, c.master_refused, c.no_engine, c.imu_lost),
            (0, 0, 0, 0)
        );
        assert_eq!(last_estimates(&sent), want);
        let st = last_status(&sent);
        assert_eq!(st.link.decoder.frames, msgs.len() as u32);
        assert_eq!(st.link.decoder.errors(), 0);
        assert_eq!(st.engine.master_matched, updates);
        assert_eq!(st.engine.imu_samples, 1500);
        // The identifier ran on θ̂ after every update.
        let fits = app.flexure_fit();
        assert!(fits.iter().all(|f| f.is_some_and(|f| f.residuals > 1000)));
    }

    #[test]
    fn decimation_of_estimates() {
        let msgs = stream(300, config(10, 0));
        let (app, sent) = run_app(&encode_all(&msgs).concat());
        let c = app.counters();
        assert_eq!(c.estimates_sent, c.master_updates / 10 + 1);
        assert_eq!(c.status_sent, 1, "only the final one");
        let n_est = sent
            .iter()
            .filter(|m| matches!(m, Message::Estimates(_)))
            .count();
        assert_eq!(n_est as u32, c.estimates_sent);
    }

    #[test]
    fn garbage_and_duplicates_change_nothing_but_the_counters() {
        let msgs = stream(600, config(0, 0));
        let frames = encode_all(&msgs);
        let (clean, clean_sent) = run_app(&frames.concat());
        let mut bytes = std::vec::Vec::new();
        let mut x: u32 = 12345;
        for (i, f) in frames.iter().enumerate() {
            bytes.extend_from_slice(f);
            if i % 7 == 3 {
                // Random bytes between frames (closed off by the next frame's delimiter).
                for _ in 0..(i % 23 + 1) {
                    x = x.wrapping_mul(1_103_515_245).wrapping_add(12345);
                    bytes.push((x >> 16) as u8);
                }
            }
            if i % 11 == 5 {
                bytes.extend_from_slice(f); // duplicated frame
            }
        }
        let (faulty, sent) = run_app(&bytes);
        assert_eq!(last_estimates(&sent), last_estimates(&clean_sent));
        assert_eq!(
            faulty.counters().master_updates,
            clean.counters().master_updates
        );
        let st = last_status(&sent);
        let dups = frames
            .iter()
            .enumerate()
            .filter(|(i, _)| i % 11 == 5)
            .count();
        assert_eq!(st.link.sequence.duplicates as usize, dups);
        assert!(st.link.decoder.errors() > 0, "garbage counted");
    }

    #[test]
    fn damaged_dropped_and_reordered_frames_are_counted_and_survived() {
        let msgs = stream(600, config(0, 0));
        let frames = encode_all(&msgs);
        let mut bytes = std::vec::Vec::new();
        let n = frames.len();
        let mut i = 0;
        while i < n {
            let f = &frames[i];
            match i % 50 {
                10 => bytes.extend_from_slice(&f[..f.len() / 2]), // truncated
                20 => {
                    let mut g = f.clone();
                    g[5] ^= 0x10; // flipped bit
                    bytes.extend_from_slice(&g);
                }
                30 => {} // dropped
                40 if i + 2 < n - 1 => {
                    // Reordered: the next frame of the same stream overtakes this one.
                    bytes.extend_from_slice(&frames[i + 2]);
                    bytes.extend_from_slice(&frames[i + 1]);
                    bytes.extend_from_slice(f);
                    i += 2;
                }
                _ => bytes.extend_from_slice(f),
            }
            i += 1;
        }
        let (app, sent) = run_app(&bytes);
        assert!(app.ended());
        let st = last_status(&sent);
        let d = st.link.decoder;
        let s = st.link.sequence;
        assert!(d.crc + d.cobs + d.too_short >= 20, "{d:?}");
        assert!(s.gaps > 0 && s.missed > 0, "{s:?}");
        assert!(s.out_of_order > 0, "{s:?}");
        let e = last_estimates(&sent);
        assert!(e.gyro_bias.iter().all(|v| v.is_finite()));
    }

    #[test]
    fn messages_before_config_and_bad_config_are_counted() {
        let mut msgs = stream(50, config(1, 0));
        let cfg = msgs.remove(0);
        let mut bad = match cfg {
            Message::Config(c) => c,
            _ => unreachable!(),
        };
        bad.flexure_period_s = 0.02; // differs from the filter period: engine refuses
        let mut all = std::vec![Message::Config(bad)];
        all.extend(msgs.iter().take(5).copied());
        let (app, _) = run_app(&encode_all(&all).concat());
        let c = app.counters();
        assert_eq!(c.config_refused, 1);
        assert_eq!(c.no_engine, 5);
        assert!(app.engine().is_none());
    }

    #[test]
    fn app_state_size() {
        // Reported in docs/firmware.md; the board keeps one App.
        let n = core::mem::size_of::<App>();
        assert!(n < 48 * 1024, "App is {n} bytes");
    }
}
