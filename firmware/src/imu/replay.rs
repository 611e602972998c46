//! Replay IMU source: increments received over the link (`ImuSample` messages) instead of
//! read from the SPI sensor. QEMU has no sensor, so the same application code runs there on
//! a recording; hardware-in-the-loop benches can use it too.
//!
//! A fixed-size FIFO (no heap): the link side [`ReplaySource::offer`]s samples, the
//! application [`ImuSource::poll`]s them. A sample offered to a full queue is dropped and
//! counted, never blocks and never overwrites an older one (the engine needs them in order).

use core::convert::Infallible;

use flexcal_core::engine::ImuIncrement;
use heapless::Deque;

use crate::imu::ImuSource;

/// Samples the replay queue holds. The application drains it after every received frame,
/// so it holds at most one in the replay loop; the slack is for a loop that polls less often.
pub const REPLAY_DEPTH: usize = 16;

/// IMU increments received over the link, waiting for the engine.
#[derive(Clone, Debug, Default)]
pub struct ReplaySource {
    queue: Deque<ImuIncrement<f32>, REPLAY_DEPTH>,
    offered: u32,
    overflow: u32,
}

impl ReplaySource {
    /// An empty queue.
    pub const fn new() -> Self {
        Self {
            queue: Deque::new(),
            offered: 0,
            overflow: 0,
        }
    }

    /// Queues one received sample; `false` (and counted) if the queue was full.
    pub fn offer(&mut self, s: ImuIncrement<f32>) -> bool {
        self.offered = self.offered.wrapping_add(1);
        if self.queue.push_back(s).is_err() {
            self.overflow = self.overflow.wrapping_add(1);
            return false;
        }
        true
    }

    /// Samples waiting.
    pub fn len(&self) -> usize {
        self.queue.len()
    }

    /// Whether no sample is waiting.
    pub fn is_empty(&self) -> bool {
        self.queue.is_empty()
    }

    /// Samples offered so far (wrapping).
    pub fn offered(&self) -> u32 {
        self.offered
    }

    /// Samples dropped because the queue was full (wrapping).
    pub fn overflow(&self) -> u32 {
        self.overflow
    }

    /// Forgets the waiting samples (the counters are kept).
    pub fn clear(&mut self) {
        self.queue.clear();
    }
}

impl ImuSource for ReplaySource {
    type Error = Infallible;

    fn poll(&mut self) -> Result<Option<ImuIncrement<f32>>, Self::Error> {
        Ok(self.queue.pop_front())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    fn s(t: f64) -> ImuIncrement<f32> {
        ImuIncrement {
            t,
            dtheta_b: Vector3::zeros(),
            dv_b: Vector3::new(0.0, 0.0, 0.049),
        }
    }

    #[test]
    fn fifo_in_order_and_overflow_counted() {
        let mut r = ReplaySource::new();
        assert_eq!(r.poll().unwrap().map(|x| x.t), None);
        for k in 0..REPLAY_DEPTH + 3 {
            let accepted = r.offer(s(k as f64));
            assert_eq!(accepted, k < REPLAY_DEPTH);
        }
        assert_eq!(r.len(), REPLAY_DEPTH);
        assert_eq!(r.overflow(), 3);
        assert_eq!(r.offered(), REPLAY_DEPTH as u32 + 3);
        for k in 0..REPLAY_DEPTH {
            assert_eq!(r.poll().unwrap().map(|x| x.t), Some(k as f64));
        }
        assert!(r.is_empty());
        r.offer(s(1.0));
        r.clear();
        assert!(r.poll().unwrap().is_none());
    }
}
