//! Cost probe: which phase of a master update the board is in, for the board's sampling
//! profiler (`docs/performance.md`). The engine and the firmware mark their phases with
//! [`enter`]; on the board a timer interrupt reads [`current`] and counts samples per
//! phase, which splits a master update's instructions into strapdown, matching, Φ and Q,
//! predict, updates and link.
//!
//! Only the board keeps the mark (one byte store per phase change, a few dozen per master
//! update); on any other target [`enter`] compiles to nothing, so the desktop's engine,
//! multi-threaded in the Monte Carlo, never shares a written cache line through it.

#[cfg(target_os = "none")]
use core::sync::atomic::{compiler_fence, AtomicU8, Ordering};

/// Phases of the board's work, as the profiler reports them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Phase {
    /// Waiting for input (polling the transport): not part of the cost.
    Idle = 0,
    /// Link frames: decoding, encoding, the application's bookkeeping.
    Link = 1,
    /// The engine outside the phases below: queues, alignment buffer, feedback.
    Engine = 2,
    /// Strapdown integration of IMU increments.
    Strapdown = 3,
    /// Matching: residuals and measurement rows of a master message.
    Matching = 4,
    /// Building the transition Φ and the process noise Q.
    Model = 5,
    /// Covariance propagation (`Kalman::predict`).
    Predict = 6,
    /// Sequential scalar measurement updates (`Kalman::update_scalar`).
    Update = 7,
    /// The flexure AR identifier on the board.
    Identifier = 8,
}

/// Number of phases.
pub const PHASES: usize = 9;

impl Phase {
    /// Every phase, in the order of their numbers.
    pub const ALL: [Phase; PHASES] = [
        Phase::Idle,
        Phase::Link,
        Phase::Engine,
        Phase::Strapdown,
        Phase::Matching,
        Phase::Model,
        Phase::Predict,
        Phase::Update,
        Phase::Identifier,
    ];

    /// The phase's name in reports.
    pub fn name(self) -> &'static str {
        match self {
            Phase::Idle => "idle",
            Phase::Link => "link",
            Phase::Engine => "engine",
            Phase::Strapdown => "strapdown",
            Phase::Matching => "matching",
            Phase::Model => "phi-q",
            Phase::Predict => "predict",
            Phase::Update => "update",
            Phase::Identifier => "identifier",
        }
    }

    /// The phase numbered `n` (`Idle` for an unknown number).
    pub fn from_u8(n: u8) -> Phase {
        Phase::ALL
            .get(usize::from(n))
            .copied()
            .unwrap_or(Phase::Idle)
    }
}

#[cfg(target_os = "none")]
static CURRENT: AtomicU8 = AtomicU8::new(Phase::Idle as u8);

/// The phase current when it was made; restores it when dropped (phases nest).
#[must_use = "the phase lasts until the mark is dropped"]
pub struct Mark {
    #[cfg(target_os = "none")]
    previous: u8,
}

/// Enters `phase` until the returned mark is dropped.
#[inline(always)]
pub fn enter(phase: Phase) -> Mark {
    #[cfg(target_os = "none")]
    {
        let previous = CURRENT.load(Ordering::Relaxed);
        CURRENT.store(phase as u8, Ordering::Relaxed);
        compiler_fence(Ordering::SeqCst);
        Mark { previous }
    }
    #[cfg(not(target_os = "none"))]
    {
        let _ = phase;
        Mark {}
    }
}

impl Drop for Mark {
    #[inline(always)]
    fn drop(&mut self) {
        #[cfg(target_os = "none")]
        {
            compiler_fence(Ordering::SeqCst);
            CURRENT.store(self.previous, Ordering::Relaxed);
        }
    }
}

/// The phase the board is in now (what the profiler's interrupt samples).
#[inline(always)]
pub fn current() -> Phase {
    #[cfg(target_os = "none")]
    {
        Phase::from_u8(CURRENT.load(Ordering::Relaxed))
    }
    #[cfg(not(target_os = "none"))]
    {
        Phase::Idle
    }
}
