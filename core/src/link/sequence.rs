//! Per-stream sequence and time checks.
//!
//! Each message kind is its own stream with a wrapping `u16` sequence number that the
//! sender increments by one per message. For a message with sequence number `s`
//! after the last accepted `l`, let `d = s − l (mod 2¹⁶)`:
//!
//! - `d = 0`: a duplicate, rejected;
//! - `d ≥ 2¹⁵`: an older message (out of order), rejected;
//! - otherwise it is newer: `d − 1` messages were missed (a gap when `d > 1`).
//!
//! Out-of-order and duplicated messages are rejected rather than passed on: they
//! would corrupt the time alignment downstream. With [`TimeRule::StrictlyIncreasing`]
//! a newer message whose time of validity is not later than the last accepted one is
//! also rejected (stale), and a NaN time is never accepted.
//!
//! A sender that restarts (sequence and time back to zero) would be rejected forever;
//! so after [`RESYNC_AFTER`] rejections in a row the tracker forgets its history and
//! accepts the next message as a first one (counted in `resyncs`).

/// Consecutive rejections after which a tracker starts afresh.
pub const RESYNC_AFTER: u32 = 16;

/// Whether a stream's time of validity must increase.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeRule {
    /// Each accepted message must be strictly later than the previous one
    /// (messages that feed the engine: MasterNav, ImuSample).
    StrictlyIncreasing,
    /// Time is not checked (e.g. estimates, whose time is that of the last filter update).
    Unchecked,
}

/// Why a message was rejected.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum SequenceError {
    /// The same sequence number as the last accepted message.
    Duplicate,
    /// An older sequence number than the last accepted message.
    OutOfOrder {
        /// How far behind (1 ..= 32768).
        behind: u16,
    },
    /// Newer by sequence number but not by time of validity.
    Stale,
}

/// What a tracker has seen, each a wrapping `u32`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SequenceCounters {
    /// Messages accepted.
    pub accepted: u32,
    /// Gaps (accepted messages that came after one or more missing ones).
    pub gaps: u32,
    /// Messages missing in those gaps.
    pub missed: u32,
    /// [`SequenceError::Duplicate`].
    pub duplicates: u32,
    /// [`SequenceError::OutOfOrder`].
    pub out_of_order: u32,
    /// [`SequenceError::Stale`].
    pub stale: u32,
    /// Times the tracker started afresh after [`RESYNC_AFTER`] rejections in a row.
    pub resyncs: u32,
}

impl SequenceCounters {
    /// The field-by-field (wrapping) sum, to total several streams.
    pub fn merged(&self, o: &Self) -> Self {
        Self {
            accepted: self.accepted.wrapping_add(o.accepted),
            gaps: self.gaps.wrapping_add(o.gaps),
            missed: self.missed.wrapping_add(o.missed),
            duplicates: self.duplicates.wrapping_add(o.duplicates),
            out_of_order: self.out_of_order.wrapping_add(o.out_of_order),
            stale: self.stale.wrapping_add(o.stale),
            resyncs: self.resyncs.wrapping_add(o.resyncs),
        }
    }

    /// All rejected messages.
    pub fn rejected(&self) -> u32 {
        self.duplicates
            .wrapping_add(self.out_of_order)
            .wrapping_add(self.stale)
    }
}

/// The checks of one stream.
#[derive(Clone, Copy, Debug)]
pub struct SequenceTracker {
    rule: TimeRule,
    /// Last accepted sequence number and time.
    last: Option<(u16, f64)>,
    rejected_in_a_row: u32,
    counters: SequenceCounters,
}

impl SequenceTracker {
    /// A tracker with no history: its first message is accepted whatever its number.
    pub const fn new(rule: TimeRule) -> Self {
        Self {
            rule,
            last: None,
            rejected_in_a_row: 0,
            counters: SequenceCounters {
                accepted: 0,
                gaps: 0,
                missed: 0,
                duplicates: 0,
                out_of_order: 0,
                stale: 0,
                resyncs: 0,
            },
        }
    }

    /// Checks the message `(seq, t)`: `Ok(missed)` if accepted (it becomes the last
    /// one), with the number of messages missed just before it.
    pub fn check(&mut self, seq: u16, t: f64) -> Result<u16, SequenceError> {
        let result = self.classify(seq, t);
        let c = &mut self.counters;
        match result {
            Ok(missed) => {
                self.last = Some((seq, t));
                self.rejected_in_a_row = 0;
                c.accepted = c.accepted.wrapping_add(1);
                if missed > 0 {
                    c.gaps = c.gaps.wrapping_add(1);
                    c.missed = c.missed.wrapping_add(u32::from(missed));
                }
            }
            Err(e) => {
                let slot = match e {
                    SequenceError::Duplicate => &mut c.duplicates,
                    SequenceError::OutOfOrder { .. } => &mut c.out_of_order,
                    SequenceError::Stale => &mut c.stale,
                };
                *slot = slot.wrapping_add(1);
                self.rejected_in_a_row += 1;
                if self.rejected_in_a_row >= RESYNC_AFTER {
                    self.last = None;
                    self.rejected_in_a_row = 0;
                    c.resyncs = c.resyncs.wrapping_add(1);
                }
            }
        }
        result
    }

    fn classify(&self, seq: u16, t: f64) -> Result<u16, SequenceError> {
        let time_ok = |last_t: f64| match self.rule {
            TimeRule::StrictlyIncreasing => t > last_t,
            TimeRule::Unchecked => true,
        };
        let Some((last_seq, last_t)) = self.last else {
            return if time_ok(f64::NEG_INFINITY) {
                Ok(0)
            } else {
                Err(SequenceError::Stale)
            };
        };
        let d = seq.wrapping_sub(last_seq);
        if d == 0 {
            Err(SequenceError::Duplicate)
        } else if d >= 0x8000 {
            Err(SequenceError::OutOfOrder {
                behind: last_seq.wrapping_sub(seq),
            })
        } else if !time_ok(last_t) {
            Err(SequenceError::Stale)
        } else {
            Ok(d - 1)
        }
    }

    /// Forgets the history (the counters are kept).
    pub fn reset(&mut self) {
        self.last = None;
        self.rejected_in_a_row = 0;
    }

    /// The counters so far.
    pub fn counters(&self) -> SequenceCounters {
        self.counters
    }

    /// The last accepted sequence number and time.
    pub fn last(&self) -> Option<(u16, f64)> {
        self.last
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn in_order_stream() {
        let mut s = SequenceTracker::new(TimeRule::StrictlyIncreasing);
        for i in 0..70_000u32 {
            let seq = (i.wrapping_add(65_000) & 0xFFFF) as u16;
            assert_eq!(s.check(seq, f64::from(i)), Ok(0), "i {i}");
        }
        let c = s.counters();
        assert_eq!(c.accepted, 70_000);
        assert_eq!(c.rejected() + c.gaps + c.missed + c.resyncs, 0);
    }

    #[test]
    fn first_message_any_number() {
        let mut s = SequenceTracker::new(TimeRule::StrictlyIncreasing);
        assert_eq!(s.check(40_000, -5.0), Ok(0));
        assert_eq!(s.last(), Some((40_000, -5.0)));
    }

    #[test]
    fn gaps_across_wrap() {
        let mut s = SequenceTracker::new(TimeRule::StrictlyIncreasing);
        assert_eq!(s.check(65_534, 1.0), Ok(0));
        assert_eq!(s.check(2, 2.0), Ok(3)); // 65535, 0, 1 missing
        assert_eq!(s.check(3, 3.0), Ok(0));
        assert_eq!(s.check(3 + 0x7FFF, 4.0), Ok(0x7FFE)); // the largest gap
        let c = s.counters();
        assert_eq!((c.accepted, c.gaps, c.missed), (4, 2, 3 + 0x7FFE));
    }

    #[test]
    fn duplicates_and_out_of_order_rejected() {
        let mut s = SequenceTracker::new(TimeRule::StrictlyIncreasing);
        assert_eq!(s.check(10, 1.0), Ok(0));
        assert_eq!(s.check(10, 1.0), Err(SequenceError::Duplicate));
        assert_eq!(
            s.check(9, 0.9),
            Err(SequenceError::OutOfOrder { behind: 1 })
        );
        // Half the ring behind is still "older".
        assert_eq!(
            s.check(10u16.wrapping_sub(0x8000), 5.0),
            Err(SequenceError::OutOfOrder { behind: 0x8000 })
        );
        assert_eq!(s.check(12, 1.2), Ok(1));
        // The rejected ones did not move the reference.
        assert_eq!(
            s.check(11, 1.1),
            Err(SequenceError::OutOfOrder { behind: 1 })
        );
        let c = s.counters();
        assert_eq!((c.duplicates, c.out_of_order, c.accepted), (1, 3, 2));
    }

    #[test]
    fn stale_time_rejected() {
        let mut s = SequenceTracker::new(TimeRule::StrictlyIncreasing);
        assert_eq!(s.check(1, 10.0), Ok(0));
        assert_eq!(s.check(2, 10.0), Err(SequenceError::Stale));
        assert_eq!(s.check(3, 9.0), Err(SequenceError::Stale));
        assert_eq!(s.check(4, f64::NAN), Err(SequenceError::Stale));
        assert_eq!(s.check(5, 10.5), Ok(3));
        assert_eq!(s.counters().stale, 3);
        let mut fresh = SequenceTracker::new(TimeRule::StrictlyIncreasing);
        assert_eq!(fresh.check(0, f64::NAN), Err(SequenceError::Stale));
    }

    #[test]
    fn unchecked_time() {
        let mut s = SequenceTracker::new(TimeRule::Unchecked);
        assert_eq!(s.check(1, 10.0), Ok(0));
        assert_eq!(s.check(2, 10.0), Ok(0));
        assert_eq!(s.check(3, 1.0), Ok(0));
        assert_eq!(s.check(3, 2.0), Err(SequenceError::Duplicate));
    }

    #[test]
    fn restarted_sender_resyncs() {
        let mut s = SequenceTracker::new(TimeRule::StrictlyIncreasing);
        assert_eq!(s.check(1000, 1000.0), Ok(0));
        // The sender restarts at 0: its numbers look older.
        for i in 0..RESYNC_AFTER {
            assert!(s.check(i as u16, f64::from(i)).is_err());
        }
        assert_eq!(s.counters().resyncs, 1);
        assert_eq!(s.check(RESYNC_AFTER as u16, 100.0), Ok(0));
        assert_eq!(s.check(RESYNC_AFTER as u16 + 1, 101.0), Ok(0));
        // An isolated rejection does not trigger a resync.
        assert!(s.check(RESYNC_AFTER as u16 + 1, 101.0).is_err());
        assert_eq!(s.check(RESYNC_AFTER as u16 + 2, 102.0), Ok(0));
        assert_eq!(s.counters().resyncs, 1);
    }

    #[test]
    fn reset_forgets() {
        let mut s = SequenceTracker::new(TimeRule::StrictlyIncreasing);
        assert_eq!(s.check(5, 5.0), Ok(0));
        s.reset();
        assert_eq!(s.check(1, 1.0), Ok(0));
        assert_eq!(s.counters().accepted, 2);
    }

    #[test]
    fn merged_sums() {
        let a = SequenceCounters {
            accepted: 1,
            gaps: 2,
            missed: 3,
            duplicates: 4,
            out_of_order: 5,
            stale: 6,
            resyncs: 7,
        };
        let m = a.merged(&a);
        assert_eq!(m.missed, 6);
        assert_eq!(m.rejected(), 30);
    }
}
