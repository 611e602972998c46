//! The serial link codec shared by the board and the desktop.
//!
//! - [`cobs`]: byte stuffing, `0x00` delimits frames.
//! - [`crc32c`]: CRC-32C (Castagnoli) of every frame.
//! - [`message`]: the messages and their fixed little-endian payload layouts.
//! - [`codec`]: frame encoding into caller buffers and the streaming [`Decoder`].
//! - [`sequence`]: per-stream sequence-number and time-of-validity checks.
//! - [`receiver`]: the decoder and the trackers together.
//!
//! A frame on the wire is `0x00, COBS([type][seq u16][payload][CRC-32C u32]), 0x00`;
//! `docs/link-protocol.md` gives every byte. No allocation, no panics, bounded work per byte.
//!
//! ```
//! use flexcal_core::link::{Encoder, Message, ImuSampleMsg, Receiver, MAX_FRAME_LEN};
//!
//! let msg = Message::ImuSample(ImuSampleMsg { t: 0.005, dtheta_b: [1e-5, 0.0, 0.0], dv_b: [0.0, 0.0, 0.049] });
//! let mut enc = Encoder::new();
//! let mut buf = [0u8; MAX_FRAME_LEN];
//! let n = enc.encode(&msg, &mut buf).unwrap();
//!
//! let mut rx = Receiver::new();
//! let got: Vec<_> = buf[..n].iter().filter_map(|b| rx.push(*b)).collect();
//! assert_eq!(got.len(), 1);
//! assert_eq!(got[0].unwrap().frame.message, msg);
//! ```

pub mod cobs;
pub mod codec;
pub mod crc32c;
pub mod message;
pub mod receiver;
pub mod sequence;

pub use codec::{
    encode, frame_len, DecodeError, Decoder, DecoderCounters, EncodeError, Encoder, Frame,
    MAX_FRAME_LEN, MAX_PAYLOAD_LEN,
};
pub use message::{
    ConfigMsg, EffectPrior, EffectsError, EffectsMsg, EndMsg, EstimatesMsg, HealthFlags,
    ImuSampleMsg, MasterNavMsg, Message, MessageKind, StatusMsg, EFFECT_STATES_PER_FRAME,
};
pub use receiver::{LinkCounters, LinkError, Received, Receiver};
pub use sequence::{SequenceCounters, SequenceError, SequenceTracker, TimeRule};
