//! Frames: encoding into a caller buffer, and the streaming decoder.
//!
//! On the wire a frame is `0x00, COBS(body), 0x00` where
//! `body = [type u8][seq u16 LE][payload][CRC-32C u32 LE of type, seq and payload]`.
//! The leading delimiter costs one byte and makes every frame self-synchronizing:
//! whatever garbage preceded it is closed off as a separate (rejected) frame, so a
//! good frame is lost only when its own bytes are damaged. Two delimiters in a row
//! (the end of one frame and the start of the next) make an empty frame, which is
//! ignored, as is any run of `0x00` (idle line).

use crate::link::cobs;
use crate::link::crc32c::{crc32c, Crc32c};
use crate::link::message::{EffectsError, EndMsg, Message, MessageKind, PayloadError};

/// Bytes before the payload: type and sequence number.
pub const HEADER_LEN: usize = 3;
/// Bytes of the CRC after the payload.
pub const CRC_LEN: usize = 4;
/// Largest frame body (type, seq, payload, CRC) before stuffing: COBS then adds
/// exactly one byte.
pub const MAX_BODY_LEN: usize = 254;
/// Largest payload a frame can carry (also for types this decoder does not know).
pub const MAX_PAYLOAD_LEN: usize = MAX_BODY_LEN - HEADER_LEN - CRC_LEN;
/// Largest stuffed body (between the delimiters); the decoder's buffer size.
pub const MAX_STUFFED_LEN: usize = cobs::max_encoded_len(MAX_BODY_LEN);
/// Largest frame on the wire, both delimiters included (257 bytes).
pub const MAX_FRAME_LEN: usize = MAX_STUFFED_LEN + 2;
/// Smallest body: header and CRC with an empty payload.
pub const MIN_BODY_LEN: usize = HEADER_LEN + CRC_LEN;

/// Length on the wire of a frame of this kind, both delimiters included
/// (payload + 3 header + 4 CRC + 1 COBS + 2 delimiters).
pub const fn frame_len(kind: MessageKind) -> usize {
    kind.payload_len() + HEADER_LEN + CRC_LEN + 1 + 2
}

/// A decoded frame: the stream's sequence number and the message.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// Sequence number within the message's stream (wrapping).
    pub seq: u16,
    /// The message.
    pub message: Message,
}

impl Frame {
    /// A placeholder (an End at 0 s, sequence 0), the slot [`Decoder::push_into`] writes.
    pub const EMPTY: Frame = Frame {
        seq: 0,
        message: Message::End(EndMsg { t: 0.0 }),
    };
}

/// Why a message could not be encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum EncodeError {
    /// The output buffer is shorter than the frame.
    BufferTooSmall {
        /// The frame's length.
        needed: usize,
    },
    /// A float is NaN or infinite (the receiver would reject the frame).
    NonFinite,
    /// A value is out of its domain (see [`PayloadError::BadValue`]).
    BadValue,
    /// The augmentation of a Config, or an Effects layout, is invalid.
    BadEffects(EffectsError),
}

/// Encodes one frame (both delimiters included) into the front of `out`; returns
/// its length, [`frame_len`] of the message's kind. The message is validated first
/// with the receiver's own checks, so whatever encodes also decodes.
pub fn encode(seq: u16, message: &Message, out: &mut [u8]) -> Result<usize, EncodeError> {
    match message.validate() {
        Ok(()) => {}
        Err(PayloadError::NonFinite) => return Err(EncodeError::NonFinite),
        Err(PayloadError::BadEffects(e)) => return Err(EncodeError::BadEffects(e)),
        Err(_) => return Err(EncodeError::BadValue),
    }
    let needed = frame_len(message.kind());
    if out.len() < needed {
        return Err(EncodeError::BufferTooSmall { needed });
    }
    let too_small = EncodeError::BufferTooSmall { needed };
    let mut body = [0u8; MAX_BODY_LEN];
    let (header, rest) = body
        .split_first_chunk_mut::<HEADER_LEN>()
        .ok_or(too_small)?;
    let [ty, s0, s1] = header;
    *ty = message.kind().type_byte();
    [*s0, *s1] = seq.to_le_bytes();
    let payload_len = message.write_payload(rest).ok_or(too_small)?;
    let crc_at = HEADER_LEN + payload_len;
    let crc = crc32c(body.get(..crc_at).ok_or(too_small)?);
    body.get_mut(crc_at..crc_at + CRC_LEN)
        .ok_or(too_small)?
        .copy_from_slice(&crc.to_le_bytes());
    let body = body.get(..crc_at + CRC_LEN).ok_or(too_small)?;
    let (first, tail) = out.split_first_mut().ok_or(too_small)?;
    *first = 0;
    let stuffed = cobs::encode(body, tail).ok_or(too_small)?;
    *tail.get_mut(stuffed).ok_or(too_small)? = 0;
    Ok(stuffed + 2)
}

/// Assigns per-stream sequence numbers and encodes.
#[derive(Clone, Debug, Default)]
pub struct Encoder {
    next_seq: [u16; MessageKind::COUNT],
}

impl Encoder {
    /// Every stream starts at sequence number 0.
    pub const fn new() -> Self {
        Self {
            next_seq: [0; MessageKind::COUNT],
        }
    }

    /// Encodes `message` with its stream's next sequence number (which advances,
    /// wrapping, only when the frame was written).
    pub fn encode(&mut self, message: &Message, out: &mut [u8]) -> Result<usize, EncodeError> {
        let slot = self
            .next_seq
            .get_mut(message.kind().stream_index())
            .ok_or(EncodeError::BadValue)?;
        let n = encode(*slot, message, out)?;
        *slot = slot.wrapping_add(1);
        Ok(n)
    }

    /// The sequence number the next message of `kind` will get.
    pub fn next_seq(&self, kind: MessageKind) -> u16 {
        self.next_seq.get(kind.stream_index()).copied().unwrap_or(0)
    }
}

/// Why a frame was rejected. Each variant has its counter in [`DecoderCounters`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum DecodeError {
    /// More than [`MAX_STUFFED_LEN`] bytes without a delimiter; the bytes up to the
    /// next `0x00` are dropped (reported once, when the limit is crossed).
    Oversize,
    /// Invalid COBS (a code byte points past the end of the frame).
    Cobs,
    /// Fewer than [`MIN_BODY_LEN`] bytes after unstuffing.
    TooShort,
    /// CRC-32C mismatch.
    Crc,
    /// A good frame of a type this decoder does not know (skipped).
    UnknownType(u8),
    /// A good frame whose payload length is wrong for its type.
    BadLength {
        /// The type byte.
        msg_type: u8,
        /// The payload length received.
        len: usize,
    },
    /// A good frame (COBS, CRC, known type, its kind's payload length) of a kind the
    /// caller does not parse ([`Decoder::push_parsing`]; the board: the board-to-host
    /// kinds). Not an error: counted as a frame ([`DecoderCounters::frames`]); its payload
    /// is not read beyond the time of validity.
    NotParsed {
        /// The frame's kind.
        kind: MessageKind,
        /// Its sequence number.
        seq: u16,
        /// The bits of its time of validity (`f64::from_bits`), the payload's first 8
        /// bytes (every kind's `t`), not checked.
        t_bits: u64,
    },
    /// A good frame with a NaN or infinite float.
    NonFinite {
        /// The type byte.
        msg_type: u8,
    },
    /// A good frame with a value out of its domain (see [`PayloadError::BadValue`]).
    BadValue {
        /// The type byte.
        msg_type: u8,
    },
    /// A good frame whose augmentation (Config) or layout (Effects) is refused: unknown
    /// effect code, duplicate, more than `MAX_EFFECTS`, bad prior σ, stray slot bytes.
    /// Counted with the bad values ([`DecoderCounters::bad_value`]).
    BadEffects {
        /// The type byte.
        msg_type: u8,
        /// What is wrong.
        error: EffectsError,
    },
}

/// What the decoder has seen, each a wrapping `u32`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DecoderCounters {
    /// Frames decoded and passed on.
    pub frames: u32,
    /// [`DecodeError::Oversize`].
    pub oversize: u32,
    /// [`DecodeError::Cobs`].
    pub cobs: u32,
    /// [`DecodeError::TooShort`].
    pub too_short: u32,
    /// [`DecodeError::Crc`].
    pub crc: u32,
    /// [`DecodeError::UnknownType`].
    pub unknown_type: u32,
    /// [`DecodeError::BadLength`].
    pub bad_length: u32,
    /// [`DecodeError::NonFinite`].
    pub non_finite: u32,
    /// [`DecodeError::BadValue`] and [`DecodeError::BadEffects`].
    pub bad_value: u32,
}

impl DecoderCounters {
    /// All rejected frames.
    pub fn errors(&self) -> u32 {
        self.oversize
            .wrapping_add(self.cobs)
            .wrapping_add(self.too_short)
            .wrapping_add(self.crc)
            .wrapping_add(self.unknown_type)
            .wrapping_add(self.bad_length)
            .wrapping_add(self.non_finite)
            .wrapping_add(self.bad_value)
    }

    /// Framing errors: oversize, invalid COBS, too short.
    pub fn framing(&self) -> u32 {
        self.oversize
            .wrapping_add(self.cobs)
            .wrapping_add(self.too_short)
    }

    fn count(&mut self, e: &DecodeError) {
        let c = match e {
            DecodeError::Oversize => &mut self.oversize,
            DecodeError::Cobs => &mut self.cobs,
            DecodeError::TooShort => &mut self.too_short,
            DecodeError::Crc => &mut self.crc,
            DecodeError::UnknownType(_) => &mut self.unknown_type,
            DecodeError::BadLength { .. } => &mut self.bad_length,
            DecodeError::NonFinite { .. } => &mut self.non_finite,
            DecodeError::BadValue { .. } | DecodeError::BadEffects { .. } => &mut self.bad_value,
            DecodeError::NotParsed { .. } => &mut self.frames,
        };
        *c = c.wrapping_add(1);
    }
}

/// The streaming decoder: feed it one byte at a time.
///
/// - Fixed memory ([`MAX_STUFFED_LEN`] bytes of buffer), no allocation, no panic on
///   any input.
/// - `O(1)` work per byte (a frame is unstuffed as its bytes arrive), plus `O(frame
///   length)` (the CRC) at a delimiter.
/// - At most one result per byte: `Some` at the delimiter that ends a non-empty
///   frame, or at the byte that makes a frame oversize.
/// - Resynchronizes on every `0x00`: garbage costs at most the frame it is in.
#[derive(Clone, Debug)]
pub struct Decoder {
    /// The frame's body so far, unstuffed (COBS) as its bytes arrive: at the delimiter
    /// only the CRC and the parse are left. A second pass over the frame there cost the
    /// board ≈ 1.45k instructions a master update; the blocks' bookkeeping in the run's
    /// copy costs ≈ 0.6k (issue12-s15).
    buf: [u8; MAX_STUFFED_LEN],
    /// Stuffed bytes of the frame received (the oversize limit counts these).
    len: usize,
    /// Unstuffed bytes in `buf`: below `len` once the frame has begun (the first byte is
    /// a code byte, and a later one adds at most the zero it stands for).
    out: usize,
    /// Data bytes still to come in the current COBS block; 0: the next byte is a code
    /// byte.
    block: u8,
    /// The last complete block stands for its data and a zero (its code was below
    /// 0xFF): the zero is written when a further block begins (a frame's last block
    /// has none).
    zero: bool,
    /// Dropping bytes until the next delimiter (after an oversize frame).
    discarding: bool,
    counters: DecoderCounters,
}

impl Default for Decoder {
    fn default() -> Self {
        Self::new()
    }
}

impl Decoder {
    /// An empty decoder, waiting for a frame.
    pub const fn new() -> Self {
        Self {
            buf: [0; MAX_STUFFED_LEN],
            len: 0,
            out: 0,
            block: 0,
            zero: false,
            discarding: false,
            counters: DecoderCounters {
                frames: 0,
                oversize: 0,
                cobs: 0,
                too_short: 0,
                crc: 0,
                unknown_type: 0,
                bad_length: 0,
                non_finite: 0,
                bad_value: 0,
            },
        }
    }

    /// The counters so far.
    pub fn counters(&self) -> DecoderCounters {
        self.counters
    }

    /// Forgets a partly received frame (the counters are kept).
    pub fn clear(&mut self) {
        self.restart();
        self.discarding = false;
    }

    /// Empties the frame's buffer and its COBS state.
    #[inline(always)]
    fn restart(&mut self) {
        self.len = 0;
        self.out = 0;
        self.block = 0;
        self.zero = false;
    }

    /// A byte inside a frame, buffered (or dropped while discarding): `true`, and
    /// [`Decoder::push`] would have returned `None`. `false` for a delimiter or a byte the
    /// buffer has no room for, which [`Decoder::push`] then takes. The per-byte path
    /// alone, for the caller to inline: most bytes end here (on the board, a call and a
    /// returned `Option` per byte cost more than the buffering).
    #[inline(always)]
    pub fn take(&mut self, byte: u8) -> bool {
        if byte == 0 {
            return false;
        }
        if self.discarding {
            return true;
        }
        if self.len >= MAX_STUFFED_LEN {
            return false;
        }
        self.len += 1;
        self.unstuff(byte);
        true
    }

    /// One stuffed byte (not zero) of the frame: a code byte opens a block (after the
    /// zero the previous block stands for, if any), a data byte is kept.
    #[inline(always)]
    fn unstuff(&mut self, byte: u8) {
        if self.block == 0 {
            if self.zero {
                self.put(0);
            }
            self.block = byte.wrapping_sub(1);
            self.zero = byte != 0xFF;
        } else {
            self.put(byte);
            self.block -= 1;
        }
    }

    /// Appends an unstuffed byte (always room: `out < len ≤ MAX_STUFFED_LEN`).
    #[inline(always)]
    fn put(&mut self, byte: u8) {
        if let Some(slot) = self.buf.get_mut(self.out) {
            *slot = byte;
            self.out += 1;
        }
    }

    /// The leading bytes of `bytes` that [`Decoder::take`] would take, taken: a frame's
    /// bytes up to its delimiter (or up to the buffer's limit), each block's data copied
    /// in one loop, its code byte handled between them, the decoder's state in locals
    /// meanwhile; returns how many. The next byte, if any, is for [`Decoder::push`].
    #[inline(always)]
    pub fn take_run(&mut self, bytes: &[u8]) -> usize {
        if self.discarding {
            return bytes.iter().take_while(|b| **b != 0).count();
        }
        // The stuffed bytes the buffer still takes.
        let room = MAX_STUFFED_LEN.saturating_sub(self.len);
        let src = bytes.get(..room).unwrap_or(bytes);
        let (mut out, mut block, mut zero) = (self.out, self.block, self.zero);
        let mut taken = 0;
        while let Some(&code) = src.get(taken) {
            if code == 0 {
                break;
            }
            if block == 0 {
                // A code byte: the zero the previous block stands for, a new block.
                if zero {
                    if let Some(slot) = self.buf.get_mut(out) {
                        *slot = 0;
                        out += 1;
                    }
                }
                block = code.wrapping_sub(1);
                zero = code != 0xFF;
                taken += 1;
                continue;
            }
            // The block's data bytes, up to its end, a delimiter or the run's end.
            let data = src.get(taken..).unwrap_or_default();
            let data = data.get(..usize::from(block)).unwrap_or(data);
            let dst = self.buf.get_mut(out..).unwrap_or_default();
            // Four bytes a turn while none of them is zero (a word's test: it has a zero
            // byte iff `(w − 0x01…01) & !w & 0x80…80 ≠ 0`), then byte by byte up to a
            // delimiter: ≈ 3 instructions a byte on the board instead of 7.
            let mut n = 0;
            for (d, s) in dst.chunks_exact_mut(4).zip(data.chunks_exact(4)) {
                let w = <[u8; 4]>::try_from(s).map_or(0, u32::from_le_bytes);
                if w.wrapping_sub(0x0101_0101) & !w & 0x8080_8080 != 0 {
                    break;
                }
                d.copy_from_slice(&w.to_le_bytes());
                n += 4;
            }
            let rest = dst.get_mut(n..).unwrap_or_default();
            for (slot, b) in rest.iter_mut().zip(data.get(n..).unwrap_or_default()) {
                if *b == 0 {
                    break;
                }
                *slot = *b;
                n += 1;
            }
            taken += n;
            out += n;
            // n ≤ block.
            block -= n as u8;
        }
        self.len += taken;
        (self.out, self.block, self.zero) = (out, block, zero);
        taken
    }

    /// Feeds one byte; returns a frame or an error when one ends here.
    pub fn push(&mut self, byte: u8) -> Option<Result<Frame, DecodeError>> {
        let mut frame = Frame::EMPTY;
        match self.push_into::<{ MessageKind::EVERY }>(byte, &mut frame)? {
            Ok(()) => Some(Ok(frame)),
            Err(e) => Some(Err(e)),
        }
    }

    /// [`Decoder::push`] into `frame` (written in place, valid when `Some(Ok(()))` comes
    /// back), parsing only the kinds in `PARSE` (a set of [`MessageKind::bit`]s): a good
    /// frame of another kind is checked (COBS, CRC, type, length) and counted as a frame,
    /// and comes back as [`DecodeError::NotParsed`]. With a constant set the other kinds'
    /// parsing is not linked (the board's receiver: Status, Estimates and Effects).
    pub fn push_into<const PARSE: u8>(
        &mut self,
        byte: u8,
        frame: &mut Frame,
    ) -> Option<Result<(), DecodeError>> {
        if byte != 0 {
            if self.take(byte) {
                return None;
            }
            // No room (a frame of stuffed bytes longer than the buffer).
            self.discarding = true;
            self.restart();
            return Some(self.fail(DecodeError::Oversize));
        }
        // A delimiter.
        let (len, out, open) = (self.len, self.out, self.block != 0);
        self.restart();
        if core::mem::replace(&mut self.discarding, false) || len == 0 {
            return None;
        }
        let result = if open {
            // A code byte announced more data bytes than the frame holds.
            Err(DecodeError::Cobs)
        } else {
            decode::<PARSE>(self.buf.get(..out).unwrap_or_default(), frame)
        };
        match &result {
            Ok(()) => self.counters.frames = self.counters.frames.wrapping_add(1),
            Err(e) => self.counters.count(e),
        }
        Some(result)
    }

    fn fail(&mut self, e: DecodeError) -> Result<(), DecodeError> {
        self.counters.count(&e);
        Err(e)
    }
}

/// Checks a frame's unstuffed `body`; parses it into `frame` if its kind is in `PARSE`.
#[inline(always)]
fn decode<const PARSE: u8>(body: &[u8], frame: &mut Frame) -> Result<(), DecodeError> {
    let n = body.len();
    let (covered, crc) = body
        .split_last_chunk::<CRC_LEN>()
        .filter(|_| n >= MIN_BODY_LEN)
        .ok_or(DecodeError::TooShort)?;
    let mut c = Crc32c::new();
    c.update(covered);
    if c.finish() != u32::from_le_bytes(*crc) {
        return Err(DecodeError::Crc);
    }
    let ([msg_type, s0, s1], payload) = covered
        .split_first_chunk::<HEADER_LEN>()
        .map(|(h, p)| (*h, p))
        .ok_or(DecodeError::TooShort)?;
    let kind = MessageKind::from_type_byte(msg_type).ok_or(DecodeError::UnknownType(msg_type))?;
    let seq = u16::from_le_bytes([s0, s1]);
    if !kind.in_set(PARSE) {
        if payload.len() != kind.payload_len() {
            return Err(DecodeError::BadLength {
                msg_type,
                len: payload.len(),
            });
        }
        // Every kind's payload starts with its time of validity (8 bytes).
        let t = payload
            .first_chunk::<8>()
            .map_or(u64::MAX, |b| u64::from_le_bytes(*b));
        return Err(DecodeError::NotParsed {
            kind,
            seq,
            t_bits: t,
        });
    }
    Message::read_payload_into::<PARSE>(kind, payload, &mut frame.message).map_err(
        |e| match e {
            PayloadError::NonFinite => DecodeError::NonFinite { msg_type },
            PayloadError::BadValue => DecodeError::BadValue { msg_type },
            PayloadError::BadEffects(error) => DecodeError::BadEffects { msg_type, error },
            PayloadError::BadLength => DecodeError::BadLength {
                msg_type,
                len: payload.len(),
            },
        },
    )?;
    frame.seq = seq;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::message::{ImuSampleMsg, MasterNavMsg, StatusMsg};
    extern crate std;
    use std::vec::Vec;

    fn imu(t: f64) -> Message {
        Message::ImuSample(ImuSampleMsg {
            t,
            dtheta_b: [1e-4, -2e-4, 3e-4],
            dv_b: [0.0, 0.0, 0.049],
        })
    }

    fn master() -> Message {
        Message::MasterNav(MasterNavMsg {
            t: 1.0,
            q_bm_n: [1.0, 0.0, 0.0, 0.0],
            v_n: [0.0; 3],
            lat_rad: 0.5,
            lon_rad: 0.0,
            height_m: 0.0,
            w_ib_bm: None,
        })
    }

    fn feed(d: &mut Decoder, bytes: &[u8]) -> ([Option<Result<Frame, DecodeError>>; 8], usize) {
        let mut out = [None; 8];
        let mut n = 0;
        for b in bytes {
            if let Some(r) = d.push(*b) {
                out[n] = Some(r);
                n += 1;
            }
        }
        (out, n)
    }

    /// A frame with an arbitrary body (valid CRC appended), as a sender of another
    /// protocol version could produce.
    fn raw_frame(ty: u8, payload: &[u8], out: &mut [u8; 600]) -> usize {
        let mut body = [0u8; 300];
        body[0] = ty;
        body[1..3].copy_from_slice(&7u16.to_le_bytes());
        body[3..3 + payload.len()].copy_from_slice(payload);
        let n = 3 + payload.len();
        let crc = crc32c(&body[..n]);
        body[n..n + 4].copy_from_slice(&crc.to_le_bytes());
        out[0] = 0;
        let m = cobs::encode(&body[..n + 4], &mut out[1..]).unwrap();
        out[m + 1] = 0;
        m + 2
    }

    #[test]
    fn runs_decode_as_bytes() {
        // Frames, garbage, an oversize run and idle zeros, fed byte by byte and in runs
        // of every length up to 40 (`take_run`, then `push` of the byte it leaves).
        let mut stream = [0u8; 2000];
        let mut n = 0;
        let mut put = |bytes: &[u8]| {
            stream[n..n + bytes.len()].copy_from_slice(bytes);
            n += bytes.len();
        };
        let mut buf = [0u8; MAX_FRAME_LEN];
        for (seq, m) in [imu(1.0), master(), imu(2.0)].iter().enumerate() {
            let k = encode(seq as u16, m, &mut buf).unwrap();
            put(&buf[..k]);
            put(&[7, 0, 0]);
        }
        // A block cut by a delimiter after 0 to 8 of its data bytes (`take_run`'s four
        // bytes a turn stop at a zero anywhere in a word).
        for k in 0..9u8 {
            put(&[20]);
            put(&[0x33, 0x44, 0x55, 0x66, 0x77, 0x88, 0x99, 0xAA][..usize::from(k)]);
            put(&[0]);
        }
        put(&[0x5A; 300]);
        let k = encode(9, &imu(3.0), &mut buf).unwrap();
        put(&buf[..k]);
        let stream = &stream[..n];
        let mut d = Decoder::new();
        let by_byte: Vec<_> = stream.iter().filter_map(|b| d.push(*b)).collect();
        assert_eq!(by_byte.iter().filter(|r| r.is_ok()).count(), 4);
        assert!(by_byte.contains(&Err(DecodeError::Oversize)));
        for run in 1..=40 {
            let (got, counters) = decode_in_runs(stream, run);
            assert_eq!(got, by_byte, "runs of {run}");
            assert_eq!(counters, d.counters());
        }
    }

    /// `stream` fed to a fresh decoder in chunks of `run` bytes, each chunk through
    /// `take_run` and `push` as the transports feed it: the results and the counters.
    fn decode_in_runs(
        stream: &[u8],
        run: usize,
    ) -> (Vec<Result<Frame, DecodeError>>, DecoderCounters) {
        let mut r = Decoder::new();
        let mut got = Vec::new();
        for chunk in stream.chunks(run) {
            let mut rest = chunk;
            while !rest.is_empty() {
                let t = r.take_run(rest);
                rest = &rest[t..];
                if let Some((b, tail)) = rest.split_first() {
                    got.extend(r.push(*b));
                    rest = tail;
                }
            }
        }
        (got, r.counters())
    }

    /// The decoder as it was before issue12-s15: a frame's stuffed bytes buffered, and
    /// unstuffed at its delimiter by [`cobs::decode_in_place`].
    struct Buffered {
        buf: [u8; MAX_STUFFED_LEN],
        len: usize,
        discarding: bool,
    }

    impl Buffered {
        fn push(&mut self, byte: u8) -> Option<Result<Frame, DecodeError>> {
            if byte != 0 {
                if self.discarding {
                    return None;
                }
                if self.len < MAX_STUFFED_LEN {
                    self.buf[self.len] = byte;
                    self.len += 1;
                    return None;
                }
                self.discarding = true;
                self.len = 0;
                return Some(Err(DecodeError::Oversize));
            }
            let len = core::mem::replace(&mut self.len, 0);
            if core::mem::replace(&mut self.discarding, false) || len == 0 {
                return None;
            }
            let mut frame = Frame::EMPTY;
            Some(match cobs::decode_in_place(&mut self.buf[..len]) {
                Err(_) => Err(DecodeError::Cobs),
                Ok(n) => {
                    decode::<{ MessageKind::EVERY }>(&self.buf[..n], &mut frame).map(|()| frame)
                }
            })
        }
    }

    #[test]
    fn unstuffing_as_bytes_arrive_decodes_as_the_whole_frame_did() {
        // Frames with damage of every kind (a byte changed, a zero put in, bytes dropped
        // or repeated, code bytes pointing past the end), full blocks, garbage of small
        // values and 0xFF, oversize runs: the results the buffered decoder gave, fed by
        // byte and in runs.
        let mut x = 0x2545_F491_4F6C_DD1Du64;
        let mut rand = move |m: u64| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x % m
        };
        let mut stream = Vec::new();
        let mut raw = [0u8; 600];
        let mut buf = [0u8; MAX_FRAME_LEN];
        for i in 0..3000 {
            let n = match rand(4) {
                0 => encode(i as u16, &imu(i as f64 * 0.005), &mut buf).unwrap(),
                1 => encode(i as u16, &master(), &mut buf).unwrap(),
                2 => {
                    let len = rand(MAX_PAYLOAD_LEN as u64 + 2) as usize;
                    let payload: Vec<u8> = (0..len)
                        .map(|_| if rand(8) == 0 { 0 } else { 1 + rand(255) as u8 })
                        .collect();
                    let n = raw_frame(1 + rand(8) as u8, &payload, &mut raw);
                    buf[..n.min(MAX_FRAME_LEN)].copy_from_slice(&raw[..n.min(MAX_FRAME_LEN)]);
                    n.min(MAX_FRAME_LEN)
                }
                _ => {
                    let len = rand(300) as usize;
                    let pick = rand(3);
                    for b in buf.iter_mut().take(len.min(MAX_FRAME_LEN)) {
                        *b = match pick {
                            0 => rand(6) as u8,
                            1 => 0xFF,
                            _ => rand(256) as u8,
                        };
                    }
                    len.min(MAX_FRAME_LEN)
                }
            };
            let mut f = buf[..n].to_vec();
            for _ in 0..rand(3) {
                if f.is_empty() {
                    break;
                }
                let at = rand(f.len() as u64) as usize;
                match rand(4) {
                    0 => f[at] = rand(256) as u8,
                    1 => f[at] = 1 + rand(8) as u8,
                    2 => {
                        f.remove(at);
                    }
                    _ => f.insert(at, f[at]),
                }
            }
            stream.extend_from_slice(&f);
        }
        let mut reference = Buffered {
            buf: [0; MAX_STUFFED_LEN],
            len: 0,
            discarding: false,
        };
        let want: Vec<_> = stream.iter().filter_map(|b| reference.push(*b)).collect();
        assert!(want.iter().filter(|r| r.is_ok()).count() > 500);
        for e in [DecodeError::Cobs, DecodeError::Oversize, DecodeError::Crc] {
            assert!(want.contains(&Err(e)), "{e:?} in the stream");
        }
        let mut d = Decoder::new();
        let by_byte: Vec<_> = stream.iter().filter_map(|b| d.push(*b)).collect();
        assert_eq!(by_byte, want);
        for run in [1, 2, 3, 7, 64, 255, 512] {
            let (got, counters) = decode_in_runs(&stream, run);
            assert_eq!(got, want, "runs of {run}");
            assert_eq!(counters, d.counters());
        }
    }

    #[test]
    fn frame_sizes() {
        assert_eq!(MAX_PAYLOAD_LEN, 247);
        assert_eq!(MAX_STUFFED_LEN, 255);
        assert_eq!(MAX_FRAME_LEN, 257);
        assert_eq!(frame_len(MessageKind::MasterNav), 95);
        assert_eq!(frame_len(MessageKind::ImuSample), 42);
        assert_eq!(frame_len(MessageKind::Estimates), 116);
        assert_eq!(frame_len(MessageKind::Status), 230);
        assert_eq!(frame_len(MessageKind::Config), 218);
        assert_eq!(frame_len(MessageKind::End), 18);
        assert_eq!(frame_len(MessageKind::Effects), 119);
        for k in MessageKind::ALL {
            assert!(k.payload_len() <= MAX_PAYLOAD_LEN);
        }
    }

    #[test]
    fn encode_then_decode() {
        for (seq, msg) in [
            (0u16, imu(0.5)),
            (0xFFFF, master()),
            (3, Message::Status(StatusMsg::default())),
        ] {
            let mut buf = [0u8; MAX_FRAME_LEN];
            let n = encode(seq, &msg, &mut buf).unwrap();
            assert_eq!(n, frame_len(msg.kind()));
            assert_eq!(buf[0], 0);
            assert_eq!(buf[n - 1], 0);
            assert!(!buf[1..n - 1].contains(&0));
            let mut d = Decoder::new();
            let (out, k) = feed(&mut d, &buf[..n]);
            assert_eq!(k, 1);
            assert_eq!(out[0], Some(Ok(Frame { seq, message: msg })));
            assert_eq!(d.counters().frames, 1);
            assert_eq!(d.counters().errors(), 0);
        }
    }

    #[test]
    fn body_bytes_are_as_documented() {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let n = encode(0x1234, &imu(0.5), &mut buf).unwrap();
        let mut body = buf;
        let m = cobs::decode_in_place(&mut body[1..n - 1]).unwrap();
        let body = &body[1..1 + m];
        assert_eq!(m, 3 + 32 + 4);
        assert_eq!(&body[..3], &[0x02, 0x34, 0x12]);
        assert_eq!(&body[3..11], &0.5f64.to_le_bytes());
        let crc = crc32c(&body[..35]);
        assert_eq!(&body[35..], &crc.to_le_bytes());
    }

    #[test]
    fn encoder_sequences_per_stream() {
        let mut e = Encoder::new();
        let mut buf = [0u8; MAX_FRAME_LEN];
        let mut d = Decoder::new();
        let mut seqs = [0u16; 5];
        for (i, msg) in [imu(1.0), imu(2.0), master(), imu(3.0), master()]
            .iter()
            .enumerate()
        {
            let n = e.encode(msg, &mut buf).unwrap();
            let (out, _) = feed(&mut d, &buf[..n]);
            seqs[i] = out[0].unwrap().unwrap().seq;
        }
        assert_eq!(seqs, [0, 1, 0, 2, 1]);
        assert_eq!(e.next_seq(MessageKind::ImuSample), 3);
        assert_eq!(e.next_seq(MessageKind::Status), 0);
        // A failed encode does not consume a number.
        assert!(e.encode(&imu(f64::NAN), &mut buf).is_err());
        assert!(e.encode(&imu(4.0), &mut buf[..10]).is_err());
        assert_eq!(e.next_seq(MessageKind::ImuSample), 3);
    }

    #[test]
    fn encode_errors() {
        let mut buf = [0u8; MAX_FRAME_LEN];
        assert_eq!(
            encode(0, &imu(1.0), &mut buf[..41]),
            Err(EncodeError::BufferTooSmall { needed: 42 })
        );
        assert_eq!(encode(0, &imu(1.0), &mut buf[..42]), Ok(42));
        assert_eq!(
            encode(0, &imu(f64::INFINITY), &mut buf),
            Err(EncodeError::NonFinite)
        );
        let Message::MasterNav(mut m) = master() else {
            unreachable!()
        };
        m.q_bm_n = [2.0, 0.0, 0.0, 0.0];
        assert_eq!(
            encode(0, &Message::MasterNav(m), &mut buf),
            Err(EncodeError::BadValue)
        );
    }

    #[test]
    fn crc_error_detected() {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let n = encode(1, &imu(1.0), &mut buf).unwrap();
        buf[10] = if buf[10] == 0x10 {
            0x30
        } else {
            buf[10] ^ 0x10
        };
        let mut d = Decoder::new();
        let (out, k) = feed(&mut d, &buf[..n]);
        assert_eq!(k, 1);
        assert_eq!(out[0], Some(Err(DecodeError::Crc)));
        assert_eq!(d.counters().crc, 1);
    }

    #[test]
    fn framing_errors() {
        let mut d = Decoder::new();
        // Idle zeros are not frames.
        assert_eq!(feed(&mut d, &[0, 0, 0, 0]).1, 0);
        // Bad COBS: the code byte points past the end.
        let (out, _) = feed(&mut d, &[0, 9, 1, 2, 0]);
        assert_eq!(out[0], Some(Err(DecodeError::Cobs)));
        // Too short: 6 body bytes.
        let (out, _) = feed(&mut d, &[7, 1, 2, 3, 4, 5, 6, 0]);
        assert_eq!(out[0], Some(Err(DecodeError::TooShort)));
        let (out, _) = feed(&mut d, &[1, 0]);
        assert_eq!(out[0], Some(Err(DecodeError::TooShort)));
        let c = d.counters();
        assert_eq!((c.cobs, c.too_short, c.frames), (1, 2, 0));
    }

    #[test]
    fn oversize_then_recovery() {
        let mut d = Decoder::new();
        let mut results = 0;
        for i in 0..1000 {
            if let Some(r) = d.push(1 + (i % 200) as u8) {
                assert_eq!(r, Err(DecodeError::Oversize));
                results += 1;
            }
        }
        assert_eq!(results, 1, "reported once");
        let mut buf = [0u8; MAX_FRAME_LEN];
        let n = encode(9, &imu(1.0), &mut buf).unwrap();
        let (out, k) = feed(&mut d, &buf[..n]);
        assert_eq!(
            k, 1,
            "the delimiter closing the oversize frame reports nothing"
        );
        assert_eq!(out[0].unwrap().unwrap().seq, 9);
        assert_eq!(d.counters().oversize, 1);
        // Exactly at the limit is fine: a 255-byte stuffed frame is decoded (here it fails the CRC).
        let mut d = Decoder::new();
        let (out, k) = feed(&mut d, &[0xFF; MAX_STUFFED_LEN]);
        assert_eq!(k, 0);
        assert!(out[0].is_none());
        assert_eq!(d.push(0), Some(Err(DecodeError::Crc)));
    }

    #[test]
    fn largest_unknown_frame_is_skipped() {
        let mut raw = [0u8; 600];
        let payload = [0x55u8; MAX_PAYLOAD_LEN];
        let n = raw_frame(0x7F, &payload, &mut raw);
        assert_eq!(n, MAX_FRAME_LEN);
        let mut d = Decoder::new();
        let (out, k) = feed(&mut d, &raw[..n]);
        assert_eq!(k, 1);
        assert_eq!(out[0], Some(Err(DecodeError::UnknownType(0x7F))));
        // One more payload byte no longer fits.
        let payload = [0x55u8; MAX_PAYLOAD_LEN + 1];
        let n = raw_frame(0x7F, &payload, &mut raw);
        let (out, _) = feed(&mut d, &raw[..n]);
        assert_eq!(out[0], Some(Err(DecodeError::Oversize)));
        // And the decoder goes on.
        let mut buf = [0u8; MAX_FRAME_LEN];
        let n = encode(1, &imu(1.0), &mut buf).unwrap();
        assert!(matches!(feed(&mut d, &buf[..n]).0[0], Some(Ok(_))));
        let c = d.counters();
        assert_eq!((c.unknown_type, c.oversize, c.frames), (1, 1, 1));
    }

    #[test]
    fn bad_length_and_values() {
        let mut raw = [0u8; 600];
        let mut d = Decoder::new();
        let n = raw_frame(0x02, &[0u8; 31], &mut raw);
        assert_eq!(
            feed(&mut d, &raw[..n]).0[0],
            Some(Err(DecodeError::BadLength {
                msg_type: 2,
                len: 31
            }))
        );
        let mut p = [0u8; 32];
        p[8..12].copy_from_slice(&f32::NAN.to_le_bytes());
        let n = raw_frame(0x02, &p, &mut raw);
        assert_eq!(
            feed(&mut d, &raw[..n]).0[0],
            Some(Err(DecodeError::NonFinite { msg_type: 2 }))
        );
        let mut buf = [0u8; MAX_FRAME_LEN];
        let n = encode(0, &master(), &mut buf).unwrap();
        let mut body = [0u8; MAX_FRAME_LEN];
        let m = {
            body[..n].copy_from_slice(&buf[..n]);
            cobs::decode_in_place(&mut body[1..n - 1]).unwrap()
        };
        let payload = &mut body[1 + 3..1 + m - 4];
        payload[72] = 0x80; // unknown flag bit
        let n = raw_frame(0x01, payload, &mut raw);
        assert_eq!(
            feed(&mut d, &raw[..n]).0[0],
            Some(Err(DecodeError::BadValue { msg_type: 1 }))
        );
        let c = d.counters();
        assert_eq!((c.bad_length, c.non_finite, c.bad_value), (1, 1, 1));
        assert_eq!(c.errors(), 3);
    }

    #[test]
    fn garbage_before_frame_is_isolated() {
        let mut d = Decoder::new();
        let mut buf = [0u8; MAX_FRAME_LEN];
        let n = encode(5, &imu(2.0), &mut buf).unwrap();
        // Garbage with no delimiter, then the frame: its leading 0x00 closes the garbage.
        let (out, k) = feed(&mut d, &[0x13, 0x37, 0x42]);
        assert_eq!(k, 0);
        assert!(out[0].is_none());
        let (out, k) = feed(&mut d, &buf[..n]);
        assert_eq!(k, 2);
        assert!(matches!(out[0], Some(Err(_))));
        assert_eq!(out[1].unwrap().unwrap().seq, 5);
    }

    #[test]
    fn clear_drops_partial_frame() {
        let mut d = Decoder::new();
        let mut buf = [0u8; MAX_FRAME_LEN];
        let n = encode(5, &imu(2.0), &mut buf).unwrap();
        feed(&mut d, &buf[1..10]);
        d.clear();
        let (out, k) = feed(&mut d, &buf[1..n]);
        assert_eq!(k, 1);
        assert!(out[0].unwrap().is_ok());
    }
}
