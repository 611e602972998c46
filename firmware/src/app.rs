//! The application: link bytes in, estimates and status frames out, the engine in between.
//!
//! ```text
//! bytes ─> Receiver ─┬─ Config    ─> (re)create the engine, reset the identifiers
//!                    ├─ ImuSample ─> ReplaySource ─> Engine::push_imu ─┐
//!                    ├─ MasterNav ─> Engine::push_master ──────────────┼─> per master update:
//!                    └─ End       ─> Engine::flush, final reports      │   Estimates (+ Effects)
//!                                                                      │   every n-th,
//!                                                                      │   Status every m-th,
//!                                                                      └─> AR identifier (θ̂)
//! ```
//!
//! Engine size: the Config's layout chooses it ([`BoardEngine`]). The declared model runs
//! on `Engine<f32, 21>`, exactly as before augmentation existed (same code, same cost); a
//! layout with effects runs on `Engine<f32, FIRMWARE_MAX_STATES>` (states past the layout
//! are inert), so any layout of up to [`FIRMWARE_MAX_STATES`] states — e.g. time delay,
//! lever-arm error and both scale factors — runs by configuration, with no code change. A
//! larger layout is refused and counted ([`AppCounters::config_too_large`]). Both engines
//! live in one enum inside the [`App`]: no heap.
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

use flexcal_core::augment::{Effect, MAX_EFFECTS};
use flexcal_core::engine::{
    Counters, EffectEstimate, Engine, EngineConfig, EngineError, Estimates, ImuIncrement,
    MatchReport, StepReports,
};
use flexcal_core::ident::{ArIdentifier, Criterion};
use flexcal_core::kalman::Health;
use flexcal_core::link::{
    ConfigMsg, EffectsMsg, Encoder, EstimatesMsg, Frame, HealthFlags, LinkCounters, LinkError,
    Message, MessageKind, Receiver, StatusMsg, MAX_FRAME_LEN,
};
use flexcal_core::model::{N, TH};
use flexcal_core::probe::{self, Phase};
use flexcal_core::watch::Watch;
use nalgebra::Vector3;

use crate::imu::ImuSource;
use crate::replay::ReplaySource;

/// Largest AR order the on-board flexure identifier fits.
pub const IDENT_MAX_ORDER: usize = 2;

/// Largest state dimension the board runs: the declared 21 states and up to 12 added
/// ones (e.g. time delay 1 + lever-arm error 3 + gyro scale factor 3 + accel scale
/// factor 3 = 10, or a 9-state block and a 3-state one = 12).
pub const FIRMWARE_MAX_STATES: usize = 33;

/// The board's engine, sized at Config time from the layout.
#[derive(Clone, Debug)]
// Both variants live in the App (no heap, so no box); the larger one sets its size.
#[allow(clippy::large_enum_variant)]
pub enum BoardEngine {
    /// The declared model alone: 21 states, the engine the board always ran.
    Declared(Engine<f32, N>),
    /// A layout with effects: [`FIRMWARE_MAX_STATES`] states, those past the layout inert.
    Augmented(Engine<f32, FIRMWARE_MAX_STATES>),
}

/// Why the board refused a Config.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ConfigRefused {
    /// The layout needs more states than [`FIRMWARE_MAX_STATES`].
    TooManyStates {
        /// The layout's dimension (declared + added states).
        states: usize,
    },
    /// The engine refused the configuration.
    Engine(EngineError),
}

/// The same call on whichever engine is running.
macro_rules! on_engine {
    ($engine:expr, $e:ident => $body:expr) => {
        match $engine {
            BoardEngine::Declared($e) => $body,
            BoardEngine::Augmented($e) => $body,
        }
    };
}

// The one-line dispatches below are `#[inline(always)]`: the App then calls each engine's
// methods directly, as it did when it held one engine. (Outlining them once made LLVM
// outline a `chunks_exact` zip in `model.rs` too, linking a division-by-zero panic path;
// `model.rs` now uses index loops there, and the image passes `check-no-panic.sh` with or
// without these attributes.)
impl BoardEngine {
    /// Puts into `slot` the smallest engine that holds the configuration's layout: 21
    /// states for the declared model, [`FIRMWARE_MAX_STATES`] for a layout with effects
    /// (`slot` is emptied when the configuration is refused).
    ///
    /// Built in place: an engine of the right size already in `slot` is reconfigured
    /// there ([`Engine::reconfigure`]); otherwise `slot` first gets an
    /// [`Engine::unconfigured`] (zeros and empty queues, which the compiler writes straight
    /// into the slot). No engine-sized temporary and no `S × S` initial covariance pass
    /// through the stack (they made the Config the stack's peak, docs/performance.md).
    /// Each size has a function of its own (not inlined), so the declared model's
    /// configuration is not as deep as the largest layout's.
    pub fn create(slot: &mut Option<Self>, cfg: EngineConfig<f32>) -> Result<(), ConfigRefused> {
        let states = cfg.augmentation.dimension();
        let result = if states > FIRMWARE_MAX_STATES {
            Err(ConfigRefused::TooManyStates { states })
        } else if cfg.augmentation.is_empty() {
            Self::configure_declared(slot, cfg).map_err(ConfigRefused::Engine)
        } else {
            Self::configure_augmented(slot, cfg).map_err(ConfigRefused::Engine)
        };
        if result.is_err() {
            *slot = None;
        }
        result
    }

    #[inline(never)]
    fn configure_declared(
        slot: &mut Option<Self>,
        cfg: EngineConfig<f32>,
    ) -> Result<(), EngineError> {
        let engine = match slot {
            Some(e @ BoardEngine::Declared(_)) => e,
            _ => slot.insert(BoardEngine::Declared(Engine::unconfigured(cfg))),
        };
        on_engine!(engine, e => e.reconfigure(cfg))
    }

    #[inline(never)]
    fn configure_augmented(
        slot: &mut Option<Self>,
        cfg: EngineConfig<f32>,
    ) -> Result<(), EngineError> {
        let engine = match slot {
            Some(e @ BoardEngine::Augmented(_)) => e,
            _ => slot.insert(BoardEngine::Augmented(Engine::unconfigured(cfg))),
        };
        on_engine!(engine, e => e.reconfigure(cfg))
    }

    /// State dimension of the running engine.
    #[inline(always)]
    pub fn dimension(&self) -> usize {
        match self {
            BoardEngine::Declared(_) => N,
            BoardEngine::Augmented(_) => FIRMWARE_MAX_STATES,
        }
    }

    /// See [`Engine::push_imu`].
    #[inline(always)]
    pub fn push_imu(
        &mut self,
        s: ImuIncrement<f32>,
        reports: &mut StepReports<f32>,
    ) -> Result<(), EngineError> {
        on_engine!(self, e => e.push_imu(s, reports))
    }

    /// See [`Engine::push_master`].
    #[inline(always)]
    pub fn push_master(
        &mut self,
        m: flexcal_core::engine::MasterNav<f32>,
        reports: &mut StepReports<f32>,
    ) -> Result<(), EngineError> {
        on_engine!(self, e => e.push_master(m, reports))
    }

    /// See [`Engine::flush`].
    #[inline(always)]
    pub fn flush(&mut self, reports: &mut StepReports<f32>) {
        on_engine!(self, e => e.flush(reports))
    }

    /// See [`Engine::estimates`].
    #[inline(always)]
    pub fn estimates(&self) -> Estimates<f32> {
        on_engine!(self, e => e.estimates())
    }

    /// The flexure states θ (rad): [`Engine::estimates`]'s `flexure`, without the other
    /// estimates and the standard deviations (each a sum along a row of the factors; the
    /// identifier reads θ after every update, 2k instructions a time).
    #[inline(always)]
    pub fn flexure(&self) -> Vector3<f32> {
        on_engine!(self, e => {
            let kf = e.filter();
            Vector3::new(kf.state_at(TH), kf.state_at(TH + 1), kf.state_at(TH + 2))
        })
    }

    /// See [`Engine::counters`].
    #[inline(always)]
    pub fn counters(&self) -> Counters {
        on_engine!(self, e => e.counters())
    }

    /// See [`Engine::health`].
    #[inline(always)]
    pub fn health(&self) -> Health {
        on_engine!(self, e => e.health())
    }

    /// See [`Engine::config`].
    #[inline(always)]
    pub fn config(&self) -> &EngineConfig<f32> {
        on_engine!(self, e => e.config())
    }

    /// See [`Engine::effect_estimate`].
    #[inline(always)]
    pub fn effect_estimate(&self, effect: Effect) -> Option<EffectEstimate<f32>> {
        on_engine!(self, e => e.effect_estimate(effect))
    }

    /// The estimates of every block of the layout, in state order (empty for the
    /// declared model).
    pub fn effect_estimates(&self) -> heapless::Vec<EffectEstimate<f32>, MAX_EFFECTS> {
        let mut out = heapless::Vec::new();
        if let BoardEngine::Augmented(e) = self {
            for b in e.config().augmentation.blocks() {
                if let Some(est) = e.effect_estimate(b.effect) {
                    // Capacity MAX_EFFECTS, the most blocks a layout has: never full.
                    let _ = out.push(est);
                }
            }
        }
        out
    }
}

/// What the application refused, dropped or sent (each a wrapping `u32`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AppCounters {
    /// Config messages that (re)created the engine.
    pub configs: u32,
    /// Config messages refused, by the engine or for their size (the board then has no
    /// engine until the next good one).
    pub config_refused: u32,
    /// Of those, Configs whose layout needs more than [`FIRMWARE_MAX_STATES`] states.
    pub config_too_large: u32,
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
    /// Effects frames sent (with each Estimates, when the layout carries effects).
    pub effects_sent: u32,
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
    /// Parses the host-to-board kinds only: a board-to-host frame is checked, sequenced
    /// and counted ([`AppCounters::unexpected`]) without its payload being read.
    rx: Receiver<{ MessageKind::TO_BOARD }>,
    /// The frame the receiver parses into (in place: a message passed by value was copied
    /// whole, 240 bytes, at each layer).
    frame: Frame,
    tx: Encoder,
    engine: Option<BoardEngine>,
    config: Option<ConfigMsg>,
    replay: ReplaySource,
    ident: [ArIdentifier<f32, IDENT_MAX_ORDER>; 3],
    /// The watcher of the innovations (`flexcal_core::watch`), sent in every Status;
    /// started again at each Config.
    watch: Watch<f32>,
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
            rx: Receiver::parsing(),
            frame: Frame::EMPTY,
            tx: Encoder::new(),
            engine: None,
            config: None,
            replay: ReplaySource::new(),
            ident: [ArIdentifier::new(); 3],
            watch: Watch::with_geometry(&Vector3::zeros(), &Vector3::zeros()),
            counters: AppCounters::default(),
            last_t: 0.0,
            ended: false,
        }
    }

    /// Feeds one received byte; frames to send go to `out` (one call per frame).
    pub fn push_byte<W: FnMut(&[u8])>(&mut self, byte: u8, out: &mut W) {
        let _phase = probe::enter(Phase::Link);
        match self.rx.push_into(byte, &mut self.frame) {
            Some(Ok(_)) => self.handle(out),
            Some(Err(LinkError::NotParsed { .. })) => {
                self.counters.unexpected = self.counters.unexpected.wrapping_add(1);
            }
            Some(Err(_e)) => {
                debug!("link: frame refused");
            }
            None => {}
        }
    }

    /// Feeds a run of received bytes.
    pub fn push_bytes<W: FnMut(&[u8])>(&mut self, bytes: &[u8], out: &mut W) {
        self.push_bytes_until_end(bytes, out);
    }

    /// Feeds a run of received bytes up to the end of the first frame that ends the run
    /// ([`App::ended`]); returns how many were taken (all of them if none did). A frame's
    /// bytes before its delimiter are buffered in one loop ([`Receiver::take_run`]), the
    /// delimiter goes through [`App::push_byte`]: the same frames, handled in the same
    /// order, as byte by byte.
    pub fn push_bytes_until_end<W: FnMut(&[u8])>(&mut self, bytes: &[u8], out: &mut W) -> usize {
        let mut taken = 0;
        while let Some(rest) = bytes.get(taken..) {
            let run = self.rx.take_run(rest);
            taken += run;
            let Some(&b) = rest.get(run) else {
                break;
            };
            taken += 1;
            self.push_byte(b, out);
            if self.ended {
                break;
            }
        }
        taken
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
    pub fn engine(&self) -> Option<&BoardEngine> {
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
                .map(BoardEngine::counters)
                .unwrap_or_default(),
            health: self
                .engine
                .as_ref()
                .map(BoardEngine::health)
                .unwrap_or_default(),
            watch: self.watch.report(),
        }
    }

    /// The Estimates message as it would be sent now (`None` before the first Config).
    pub fn estimates(&self) -> Option<EstimatesMsg> {
        let e = self.engine.as_ref()?;
        let flags = HealthFlags::from_engine(&e.health(), &e.counters());
        Some(EstimatesMsg::from_engine(&e.estimates(), flags))
    }

    /// Frame `page` of the Effects report as it would be sent now (`None` past the last
    /// frame, for the declared model and before the first Config).
    pub fn effects(&self, page: usize) -> Option<EffectsMsg> {
        let e = self.engine.as_ref()?;
        let t = e.estimates().t;
        EffectsMsg::from_estimates(t, &e.effect_estimates(), page)
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

    /// The frame the receiver has just accepted (in `self.frame`): its message is copied
    /// out of the slot (a few words; a Config whole) before it is handled.
    fn handle<W: FnMut(&[u8])>(&mut self, out: &mut W) {
        match &self.frame.message {
            Message::Config(c) => {
                let c = *c;
                self.configure(&c)
            }
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
                // Converted first: the slot is borrowed until then.
                let nav = m.to_engine();
                self.drain_replay(out);
                let Some(engine) = self.engine.as_mut() else {
                    self.counters.no_engine = self.counters.no_engine.wrapping_add(1);
                    return;
                };
                let mut reports = StepReports::new();
                self.watch.observe_master(&nav);
                let pushed = engine.push_master(nav, &mut reports);
                // Matches made before an overflow refusal are reported all the same.
                self.on_reports(&reports, out);
                if pushed.is_err() {
                    self.counters.master_refused = self.counters.master_refused.wrapping_add(1);
                }
            }
            Message::End(_) => self.end(out),
            Message::Estimates(_) | Message::Status(_) | Message::Effects(_) => {
                self.counters.unexpected = self.counters.unexpected.wrapping_add(1);
            }
        }
    }

    fn configure(&mut self, c: &ConfigMsg) {
        self.replay.clear();
        self.ident = [ArIdentifier::new(); 3];
        self.counters.master_updates = 0;
        self.ended = false;
        self.config = None;
        // The old engine goes first (`create` empties the slot): the new one takes its place.
        let cfg = c.to_engine::<f32>();
        self.watch = Watch::new(&cfg);
        match BoardEngine::create(&mut self.engine, cfg) {
            Ok(()) => {
                if let Some(e) = self.engine.as_ref() {
                    info!(
                        "config: filter period {=f64} s, estimates every {=u16}, status every {=u16}, {=usize} states ({=usize} added), engine of {=usize}",
                        c.filter_period_s,
                        c.estimates_every,
                        c.status_every,
                        e.config().augmentation.dimension(),
                        e.config().augmentation.states(),
                        e.dimension()
                    );
                }
                self.config = Some(*c);
                self.counters.configs = self.counters.configs.wrapping_add(1);
            }
            Err(ConfigRefused::TooManyStates { states }) => {
                self.counters.config_refused = self.counters.config_refused.wrapping_add(1);
                self.counters.config_too_large = self.counters.config_too_large.wrapping_add(1);
                warn!(
                    "config refused: its layout needs {=usize} states, the board holds {=usize}",
                    states, FIRMWARE_MAX_STATES
                );
            }
            Err(ConfigRefused::Engine(_)) => {
                self.counters.config_refused = self.counters.config_refused.wrapping_add(1);
                warn!("config refused by the engine");
            }
        }
    }

    fn end<W: FnMut(&[u8])>(&mut self, out: &mut W) {
        self.counters.ends = self.counters.ends.wrapping_add(1);
        self.drain_replay(out);
        if let Some(engine) = self.engine.as_mut() {
            let mut reports = StepReports::new();
            engine.flush(&mut reports);
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
        let mut reports = StepReports::new();
        match engine.push_imu(inc, &mut reports) {
            Ok(()) => self.on_reports(&reports, out),
            Err(_) => self.counters.imu_refused = self.counters.imu_refused.wrapping_add(1),
        }
    }

    // The sending methods below take their sender as `dyn`: generic, they were one copy
    // per caller's closure type (the replay's two transports), 1.7 kB of flash in all.
    fn on_reports(&mut self, reports: &[MatchReport<f32>], out: &mut dyn FnMut(&[u8])) {
        let Some(cfg) = self.config else {
            return;
        };
        for r in reports {
            self.counters.master_updates = self.counters.master_updates.wrapping_add(1);
            self.watch.observe(r);
            if let Some(e) = self.engine.as_ref() {
                let _phase = probe::enter(Phase::Identifier);
                let th = e.flexure();
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

    /// Estimates, then (layouts with effects) the Effects frames of the same time.
    fn send_estimates(&mut self, out: &mut dyn FnMut(&[u8])) {
        let Some(e) = self.engine.as_ref() else {
            return;
        };
        let flags = HealthFlags::from_engine(&e.health(), &e.counters());
        let est = e.estimates();
        let augmented = matches!(e, BoardEngine::Augmented(_));
        if self.send(
            &Message::Estimates(EstimatesMsg::from_engine(&est, flags)),
            out,
        ) {
            self.counters.estimates_sent = self.counters.estimates_sent.wrapping_add(1);
        }
        // The declared model has no effects (and no Effects frame): its empty list is not
        // built (a copy of the list's whole capacity, 0.3k instructions an update).
        let Some(e) = self.engine.as_ref().filter(|_| augmented) else {
            return;
        };
        let blocks = e.effect_estimates();
        let mut page = 0;
        while let Some(m) = EffectsMsg::from_estimates(est.t, &blocks, page) {
            if self.send(&Message::Effects(m), out) {
                self.counters.effects_sent = self.counters.effects_sent.wrapping_add(1);
            }
            page += 1;
        }
    }

    fn send_status(&mut self, out: &mut dyn FnMut(&[u8])) {
        let m = self.status();
        if self.send(&Message::Status(m), out) {
            self.counters.status_sent = self.counters.status_sent.wrapping_add(1);
        }
    }

    fn send(&mut self, msg: &Message, out: &mut dyn FnMut(&[u8])) -> bool {
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
    use flexcal_core::flexure::{ArAxis, AxisModel, FlexureModel};
    use flexcal_core::link::{EndMsg, ImuSampleMsg, MasterNavMsg, Receiver};
    use flexcal_core::model::{LeverBending, ProcessNoise};
    use flexcal_core::watch::WatchReport;
    use nalgebra::Vector3;

    const DT: f64 = 0.01;
    const LAT: f64 = 0.7;
    const G: f32 = 9.80;
    const EARTH_RATE: f64 = 7.292_115e-5;

    fn config(estimates_every: u16, status_every: u16) -> ConfigMsg {
        config_with(estimates_every, status_every, &[])
    }

    /// The test configuration with the effects `effects` (default prior σ each).
    fn config_with(estimates_every: u16, status_every: u16, effects: &[Effect]) -> ConfigMsg {
        let mut augmentation = flexcal_core::augment::Augmentation::none();
        for e in effects {
            augmentation = augmentation
                .with(*e, e.default_prior_sigma() as f32)
                .unwrap();
        }
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
                axes: [AxisModel::Ar(ArAxis {
                    a1: 0.5,
                    a2: 0.0,
                    sigma_rad: 1e-5,
                }); 3],
                period_s: DT as f32,
            },
            process_noise: ProcessNoise {
                accel_vrw: 1e-4,
                gyro_arw: 1e-5,
                gyro_bias_rw: 0.0,
                accel_bias_rw: 0.0,
                misalignment_rw: 0.0,
            },
            measurement_noise: MeasurementNoise::uniform(0.01, 1e-4, 1e-4),
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
            augmentation,
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
    /// The engine and the watcher driven directly: the last estimates, the number of
    /// master updates and the watcher's report.
    fn direct(msgs: &[Message]) -> (EstimatesMsg, u32, WatchReport) {
        let mut engine: Option<Engine<f32>> = None;
        let mut watch = None;
        let mut updates = 0u32;
        let mut r = StepReports::new();
        for m in msgs {
            let e = engine.as_mut();
            let pushed = match m {
                Message::Config(c) => {
                    engine = Some(Engine::new(c.to_engine()).unwrap());
                    watch = Some(Watch::new(&c.to_engine()));
                    continue;
                }
                Message::ImuSample(s) => e.unwrap().push_imu(s.to_engine(), &mut r),
                Message::MasterNav(s) => {
                    let nav = s.to_engine();
                    watch.as_mut().unwrap().observe_master(&nav);
                    e.unwrap().push_master(nav, &mut r)
                }
                Message::End(_) => {
                    e.unwrap().flush(&mut r);
                    Ok(())
                }
                _ => continue,
            };
            if pushed.is_ok() {
                updates += r.len() as u32;
            }
            for report in &r {
                watch.as_mut().unwrap().observe(report);
            }
        }
        let e = engine.unwrap();
        let flags = HealthFlags::from_engine(&e.health(), &e.counters());
        let w = watch.unwrap().report();
        (EstimatesMsg::from_engine(&e.estimates(), flags), updates, w)
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
        let (want, updates, watch) = direct(&msgs);
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
        // The watcher saw every master message and every update, as driven directly.
        assert_eq!(st.watch, watch);
        assert!(
            st.watch.nis.iter().take(6).all(|n| *n > 0.0),
            "{:?}",
            st.watch
        );
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
    fn runs_of_bytes_are_handled_as_bytes_and_stop_after_end() {
        let mut bytes = encode_all(&stream(30, config(1, 3))).concat();
        let end_at = bytes.len();
        // After the End: the start of another stream, not to be taken.
        bytes.extend(encode_all(&stream(3, config(1, 1))).concat());
        let mut one = std::boxed::Box::new(App::new());
        let mut sent_one = std::vec::Vec::new();
        for b in &bytes {
            one.push_byte(*b, &mut |f: &[u8]| sent_one.extend_from_slice(f));
            if one.ended() {
                break;
            }
        }
        for run in [1, 2, 7, 42, 95, 512, bytes.len()] {
            let mut app = std::boxed::Box::new(App::new());
            let mut sent = std::vec::Vec::new();
            let mut taken = 0;
            for chunk in bytes.chunks(run) {
                taken += app.push_bytes_until_end(chunk, &mut |f: &[u8]| sent.extend_from_slice(f));
                if app.ended() {
                    break;
                }
            }
            assert_eq!(taken, end_at, "runs of {run}");
            assert_eq!(sent, sent_one, "runs of {run}");
            assert_eq!(app.counters(), one.counters());
            assert_eq!(app.link_counters(), one.link_counters());
        }
    }

    #[test]
    fn board_to_host_frames_are_counted_not_parsed() {
        let mut msgs = stream(20, config(1, 0));
        // The board's own Estimates and Status echoed back (a looped-back line), between
        // the host's messages: counted as unexpected, the run unchanged.
        let (_, sent) = run_app(&encode_all(&msgs).concat());
        let echoed: std::vec::Vec<Message> = sent
            .iter()
            .filter(|m| matches!(m, Message::Estimates(_) | Message::Status(_)))
            .take(4)
            .copied()
            .collect();
        assert_eq!(echoed.len(), 4);
        let end = msgs.pop().unwrap();
        let plain = encode_all(&msgs);
        let mut bytes = plain.concat();
        bytes.extend(encode_all(&echoed).concat());
        bytes.extend(encode_all(&[end]).concat());
        let (app, with_echo) = run_app(&bytes);
        let (reference, _) = run_app(&encode_all(&stream(20, config(1, 0))).concat());
        assert_eq!(app.counters().unexpected, 4);
        assert_eq!(reference.counters().unexpected, 0);
        let (a, r) = (app.link_counters(), reference.link_counters());
        assert_eq!(a.decoder.frames, r.decoder.frames + 4);
        assert_eq!(a.decoder.errors(), 0);
        assert_eq!(a.sequence.accepted, r.sequence.accepted + 4);
        assert_eq!(last_estimates(&with_echo), last_estimates(&sent));
    }

    /// A layout of 10 added states: time delay, lever-arm error, both scale factors.
    const BOARD_LAYOUT: [Effect; 4] = [
        Effect::TimeDelay,
        Effect::LeverArmError,
        Effect::GyroScaleFactor,
        Effect::AccelScaleFactor,
    ];

    #[test]
    fn augmented_layout_runs_by_configuration() {
        let msgs = stream(800, config_with(1, 0, &BOARD_LAYOUT));
        let (app, sent) = run_app(&encode_all(&msgs).concat());
        let engine = app.engine().unwrap();
        assert_eq!(engine.dimension(), FIRMWARE_MAX_STATES);
        assert_eq!(engine.config().augmentation.dimension(), 31);
        let c = app.counters();
        assert_eq!((c.configs, c.config_refused, c.config_too_large), (1, 0, 0));
        assert_eq!(
            c.effects_sent, c.estimates_sent,
            "one Effects frame (10 states) per Estimates"
        );

        // The same messages straight into Engine<f32, 33>: every report bit-identical.
        let mut direct: Option<Engine<f32, FIRMWARE_MAX_STATES>> = None;
        let mut r = StepReports::new();
        let mut want = std::vec::Vec::new();
        for m in &msgs {
            let reports = match m {
                Message::Config(cfg) => {
                    direct = Some(Engine::new(cfg.to_engine()).unwrap());
                    continue;
                }
                Message::ImuSample(s) => direct.as_mut().unwrap().push_imu(s.to_engine(), &mut r),
                Message::MasterNav(s) => {
                    direct.as_mut().unwrap().push_master(s.to_engine(), &mut r)
                }
                Message::End(_) => {
                    direct.as_mut().unwrap().flush(&mut r);
                    Ok(())
                }
                _ => continue,
            };
            let e = direct.as_ref().unwrap();
            for _ in 0..reports.map_or(0, |()| r.len()) {
                let blocks: std::vec::Vec<_> = BOARD_LAYOUT
                    .iter()
                    .map(|b| e.effect_estimate(*b).unwrap())
                    .collect();
                want.push(EffectsMsg::from_estimates(e.estimates().t, &blocks, 0).unwrap());
            }
        }
        let got: std::vec::Vec<EffectsMsg> = sent
            .iter()
            .filter_map(|m| match m {
                Message::Effects(e) => Some(*e),
                _ => None,
            })
            .collect();
        assert!(want.len() > 500, "{} updates", want.len());
        assert_eq!(got.len(), want.len() + 1, "every update, and the final one");
        assert_eq!(&got[..want.len()], &want[..]);
        // Each Effects frame follows the Estimates of its time.
        for (i, m) in sent.iter().enumerate() {
            if let Message::Effects(e) = m {
                match sent.get(i - 1) {
                    Some(Message::Estimates(est)) => assert_eq!(est.t, e.t),
                    other => panic!("Effects after {other:?}"),
                }
            }
        }
        let last = got.last().unwrap();
        let (states, sigmas) = (last.value, last.sigma);
        assert!(sigmas[..10].iter().all(|s| *s > 0.0) && sigmas[10..].iter().all(|s| *s == 0.0));
        assert!(states.iter().all(|v| v.is_finite()));

        // The declared model on the same App: back to the 21-state engine, no Effects.
        let (app, sent) = run_app(&encode_all(&stream(50, config(1, 0))).concat());
        assert_eq!(app.engine().unwrap().dimension(), 21);
        assert_eq!(app.counters().effects_sent, 0);
        assert!(!sent.iter().any(|m| matches!(m, Message::Effects(_))));
    }

    #[test]
    fn too_large_layout_is_refused_and_counted() {
        // 21 + 9 + 9 = 39 states: more than the board holds.
        let big = config_with(1, 0, &[Effect::GyroGSensitivity, Effect::LeverArmCoupling]);
        let mut msgs = stream(20, big);
        msgs.truncate(8);
        let (app, _) = run_app(&encode_all(&msgs).concat());
        let c = app.counters();
        assert_eq!((c.configs, c.config_refused, c.config_too_large), (0, 1, 1));
        assert_eq!(c.no_engine, 7, "IMU and master messages without an engine");
        assert!(app.engine().is_none());
        // 21 + 9 + 3 = 33 fits.
        let fits = config_with(1, 0, &[Effect::GyroGSensitivity, Effect::LeverArmError]);
        let (app, _) = run_app(&encode_all(&stream(20, fits)).concat());
        assert_eq!(app.counters().config_refused, 0);
        assert_eq!(app.engine().unwrap().dimension(), FIRMWARE_MAX_STATES);
    }

    #[test]
    fn app_state_size() {
        // Reported in docs/firmware.md; the board keeps one App.
        let n = core::mem::size_of::<App>();
        assert!(n < 48 * 1024, "App is {n} bytes");
        std::eprintln!(
            "App {n} bytes, BoardEngine {} bytes, Engine<f32, 21> {} bytes",
            core::mem::size_of::<BoardEngine>(),
            core::mem::size_of::<Engine<f32>>()
        );
    }
}
