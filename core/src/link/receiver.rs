//! The receiving end of the link: the decoder followed by one sequence tracker per stream.

use crate::link::codec::{DecodeError, Decoder, DecoderCounters, Frame};
use crate::link::message::MessageKind;
use crate::link::sequence::{SequenceCounters, SequenceError, SequenceTracker, TimeRule};

/// Everything the receiving side counts (sent to the host in the Status message).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LinkCounters {
    /// The decoder's counters.
    pub decoder: DecoderCounters,
    /// The sequence trackers' counters, summed over the streams.
    pub sequence: SequenceCounters,
}

/// A frame that passed every check.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Received {
    /// The frame.
    pub frame: Frame,
    /// Messages of the same stream missed just before this one.
    pub missed: u16,
}

/// Why a frame was not passed on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum LinkError {
    /// The frame itself was bad.
    Decode(DecodeError),
    /// A good frame, refused by its stream's sequence tracker.
    Sequence {
        /// The stream.
        kind: MessageKind,
        /// Why.
        error: SequenceError,
    },
    /// A good frame, accepted by its stream's sequence tracker, of a kind this receiver
    /// does not parse ([`Receiver::parsing`]; the board's: the board-to-host kinds).
    NotParsed {
        /// The frame's kind.
        kind: MessageKind,
    },
}

/// Decoder plus per-stream sequence checks. The streams that feed the engine
/// (MasterNav, ImuSample) also require a strictly increasing time of validity.
///
/// `PARSE`: the kinds whose payloads are parsed (a set of [`MessageKind::bit`]s; every
/// kind by default). A good frame of another kind is checked, counted and sequenced as
/// any other, and reported as [`LinkError::NotParsed`]; its parsing code is not linked.
#[derive(Clone, Debug)]
pub struct Receiver<const PARSE: u8 = { MessageKind::EVERY }> {
    decoder: Decoder,
    trackers: [SequenceTracker; MessageKind::COUNT],
}

impl Default for Receiver {
    fn default() -> Self {
        Self::new()
    }
}

impl Receiver {
    /// A receiver with no history, parsing every kind.
    pub const fn new() -> Self {
        Self::parsing()
    }
}

impl<const PARSE: u8> Receiver<PARSE> {
    /// A receiver with no history, parsing the kinds in `PARSE` (the board's:
    /// `Receiver::<{ MessageKind::TO_BOARD }>::parsing()`).
    pub const fn parsing() -> Self {
        Self {
            decoder: Decoder::new(),
            trackers: [
                SequenceTracker::new(Self::rule(MessageKind::ALL[0])),
                SequenceTracker::new(Self::rule(MessageKind::ALL[1])),
                SequenceTracker::new(Self::rule(MessageKind::ALL[2])),
                SequenceTracker::new(Self::rule(MessageKind::ALL[3])),
                SequenceTracker::new(Self::rule(MessageKind::ALL[4])),
                SequenceTracker::new(Self::rule(MessageKind::ALL[5])),
                SequenceTracker::new(Self::rule(MessageKind::ALL[6])),
            ],
        }
    }

    /// The time rule of a stream.
    pub const fn rule(kind: MessageKind) -> TimeRule {
        match kind {
            MessageKind::MasterNav | MessageKind::ImuSample => TimeRule::StrictlyIncreasing,
            MessageKind::Estimates
            | MessageKind::Status
            | MessageKind::Config
            | MessageKind::End
            | MessageKind::Effects => TimeRule::Unchecked,
        }
    }

    /// Feeds one byte (see [`Decoder::push`] for the guarantees).
    pub fn push(&mut self, byte: u8) -> Option<Result<Received, LinkError>> {
        let mut frame = Frame::EMPTY;
        match self.push_into(byte, &mut frame)? {
            Ok(missed) => Some(Ok(Received { frame, missed })),
            Err(e) => Some(Err(e)),
        }
    }

    /// [`Receiver::push`] into `frame`: a frame that passed every check is written there
    /// in place (`Some(Ok(missed))`, the messages of its stream missed just before it);
    /// after anything else `frame` holds any frame. A byte inside a frame is buffered
    /// here, inlined into the caller ([`Decoder::take`]); the rest, a frame's end above
    /// all, in [`Receiver::push_end`].
    #[inline(always)]
    pub fn push_into(&mut self, byte: u8, frame: &mut Frame) -> Option<Result<u16, LinkError>> {
        if self.decoder.take(byte) {
            return None;
        }
        self.push_end(byte, frame)
    }

    /// The leading bytes of `bytes` inside a frame, buffered at once (see
    /// [`Decoder::take_run`]); returns how many. The next byte, if any, goes to
    /// [`Receiver::push_into`]. Out of line: one copy for the board's transports (a call
    /// per run of bytes, ≈ 10 instructions a frame; inlined, each copy was ≈ 240 B).
    #[inline(never)]
    pub fn take_run(&mut self, bytes: &[u8]) -> usize {
        self.decoder.take_run(bytes)
    }

    /// [`Receiver::push_into`] of a byte [`Decoder::take`] did not take.
    #[inline(never)]
    fn push_end(&mut self, byte: u8, frame: &mut Frame) -> Option<Result<u16, LinkError>> {
        let (kind, seq, t, parsed) = match self.decoder.push_into::<PARSE>(byte, frame)? {
            Ok(()) => (frame.message.kind(), frame.seq, frame.message.time(), true),
            Err(DecodeError::NotParsed { kind, seq, t_bits }) => {
                (kind, seq, f64::from_bits(t_bits), false)
            }
            Err(e) => return Some(Err(LinkError::Decode(e))),
        };
        let tracker = self.trackers.get_mut(kind.stream_index())?;
        Some(match tracker.check(seq, t) {
            Ok(missed) if parsed => Ok(missed),
            Ok(_) => Err(LinkError::NotParsed { kind }),
            Err(error) => Err(LinkError::Sequence { kind, error }),
        })
    }

    /// The decoder's and all streams' counters.
    pub fn counters(&self) -> LinkCounters {
        LinkCounters {
            decoder: self.decoder.counters(),
            sequence: self
                .trackers
                .iter()
                .fold(SequenceCounters::default(), |acc, t| {
                    acc.merged(&t.counters())
                }),
        }
    }

    /// One stream's tracker.
    pub fn tracker(&self, kind: MessageKind) -> Option<&SequenceTracker> {
        self.trackers.get(kind.stream_index())
    }

    /// Forgets partial frames and every stream's history (counters are kept).
    pub fn reset(&mut self) {
        self.decoder.clear();
        self.trackers.iter_mut().for_each(SequenceTracker::reset);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::codec::{encode, MAX_FRAME_LEN};
    use crate::link::message::{EstimatesMsg, HealthFlags, ImuSampleMsg, Message};

    /// An Estimates message at time `t` with every flexure angle `flexure` (rad), the
    /// rest zero.
    fn est(t: f64, flexure: f32) -> Message {
        Message::Estimates(EstimatesMsg {
            t,
            gyro_bias: [0.0; 3],
            gyro_bias_sigma: [0.0; 3],
            accel_bias: [0.0; 3],
            accel_bias_sigma: [0.0; 3],
            misalignment: [0.0; 3],
            misalignment_sigma: [0.0; 3],
            flexure: [flexure; 3],
            flexure_sigma: [0.0; 3],
            health: HealthFlags(0),
        })
    }
    extern crate std;
    use std::vec::Vec;

    fn imu(t: f64) -> Message {
        Message::ImuSample(ImuSampleMsg {
            t,
            dtheta_b: [0.0; 3],
            dv_b: [0.0, 0.0, 0.049],
        })
    }

    fn send(rx: &mut Receiver, seq: u16, m: &Message) -> Option<Result<Received, LinkError>> {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let n = encode(seq, m, &mut buf).unwrap();
        let mut last = None;
        for b in &buf[..n] {
            if let Some(r) = rx.push(*b) {
                assert!(last.is_none(), "one result per frame");
                last = Some(r);
            }
        }
        last
    }

    #[test]
    fn state_is_small() {
        assert!(core::mem::size_of::<Decoder>() <= 320);
        assert!(
            core::mem::size_of::<Receiver>() <= 800,
            "seven stream trackers"
        );
    }

    #[test]
    fn gaps_duplicates_and_stale() {
        let mut rx = Receiver::new();
        assert_eq!(send(&mut rx, 7, &imu(1.0)).unwrap().unwrap().missed, 0);
        assert_eq!(send(&mut rx, 10, &imu(2.0)).unwrap().unwrap().missed, 2);
        assert_eq!(
            send(&mut rx, 10, &imu(2.0)),
            Some(Err(LinkError::Sequence {
                kind: MessageKind::ImuSample,
                error: SequenceError::Duplicate
            }))
        );
        assert_eq!(
            send(&mut rx, 9, &imu(1.5)),
            Some(Err(LinkError::Sequence {
                kind: MessageKind::ImuSample,
                error: SequenceError::OutOfOrder { behind: 1 }
            }))
        );
        assert_eq!(
            send(&mut rx, 11, &imu(2.0)),
            Some(Err(LinkError::Sequence {
                kind: MessageKind::ImuSample,
                error: SequenceError::Stale
            }))
        );
        let c = rx.counters().sequence;
        assert_eq!(
            (
                c.accepted,
                c.gaps,
                c.missed,
                c.duplicates,
                c.out_of_order,
                c.stale
            ),
            (2, 1, 2, 1, 1, 1)
        );
        assert_eq!(
            rx.tracker(MessageKind::ImuSample).unwrap().last(),
            Some((10, 2.0))
        );
    }

    #[test]
    fn a_board_receiver_checks_and_sequences_what_it_does_not_parse() {
        let mut board = Receiver::<{ MessageKind::TO_BOARD }>::parsing();
        let mut host = Receiver::new();
        let mut feed = |seq: u16, m: &Message| {
            let mut buf = [0u8; MAX_FRAME_LEN];
            let n = encode(seq, m, &mut buf).unwrap();
            let (mut b, mut h) = (None, None);
            for byte in &buf[..n] {
                b = board.push(*byte).or(b);
                h = host.push(*byte).or(h);
            }
            (b.unwrap(), h.unwrap())
        };
        // Host-to-board kinds: both parse them alike.
        let (b, h) = feed(0, &imu(1.0));
        assert_eq!(b, h);
        assert_eq!(b.unwrap().frame.message, imu(1.0));
        // Board-to-host kinds: checked and sequenced, not parsed by the board.
        let (b, h) = feed(3, &est(2.0, 0.5));
        assert_eq!(
            b,
            Err(LinkError::NotParsed {
                kind: MessageKind::Estimates
            })
        );
        assert_eq!(h.unwrap().frame.message, est(2.0, 0.5));
        let (b, _) = feed(3, &est(2.0, 0.5));
        assert_eq!(
            b,
            Err(LinkError::Sequence {
                kind: MessageKind::Estimates,
                error: SequenceError::Duplicate
            })
        );
        assert_eq!(
            board.tracker(MessageKind::Estimates).unwrap().last(),
            Some((3, 2.0))
        );
        assert_eq!(board.counters(), host.counters());
        // A damaged frame of a kind not parsed is refused as any other.
        let mut buf = [0u8; MAX_FRAME_LEN];
        let n = encode(4, &est(3.0, 0.5), &mut buf).unwrap();
        buf[5] ^= 0x10;
        let got: Vec<_> = buf[..n].iter().filter_map(|b| board.push(*b)).collect();
        assert_eq!(got, [Err(LinkError::Decode(DecodeError::Crc))]);
        assert_eq!(board.counters().decoder.crc, 1);
        assert_eq!(board.counters().decoder.frames, 3);
    }

    #[test]
    fn streams_are_independent_and_estimates_time_unchecked() {
        let mut rx = Receiver::new();
        assert!(send(&mut rx, 0, &imu(1.0)).unwrap().is_ok());
        assert!(send(&mut rx, 0, &est(5.0, 0.0)).unwrap().is_ok());
        // Same time again is fine for estimates (no filter update in between).
        assert!(send(&mut rx, 1, &est(5.0, 0.0)).unwrap().is_ok());
        assert!(send(&mut rx, 1, &imu(1.1)).unwrap().is_ok());
        assert_eq!(rx.counters().sequence.accepted, 4);
        assert_eq!(rx.counters().sequence.rejected(), 0);
        rx.reset();
        assert!(send(&mut rx, 0, &imu(0.0)).unwrap().is_ok());
    }
}
