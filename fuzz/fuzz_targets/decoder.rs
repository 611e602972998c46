//! Feeds arbitrary bytes to the link decoder and receiver.
//!
//! Checks, beyond "does not panic": the decoder's counters agree with what it
//! returned, at most one result per byte, anything accepted re-encodes to bytes that
//! were in the input, and a valid frame sent afterwards is always decoded.
#![no_main]

use flexcal_core::link::{encode, Frame, ImuSampleMsg, Message, Receiver, MAX_FRAME_LEN};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut rx = Receiver::new();
    let mut results = 0u32;
    for &b in data {
        if let Some(r) = rx.push(b) {
            results += 1;
            if let Ok(got) = r {
                let mut buf = [0u8; MAX_FRAME_LEN];
                let n = encode(got.frame.seq, &got.frame.message, &mut buf)
                    .expect("an accepted message encodes");
                let inner = &buf[1..n - 1];
                assert!(data.windows(inner.len()).any(|w| w == inner));
            }
        }
    }
    let c = rx.counters();
    assert_eq!(results, c.decoder.frames + c.decoder.errors());
    assert_eq!(
        c.decoder.frames,
        c.sequence.accepted + c.sequence.rejected()
    );

    // The link recovers: a fresh frame after the garbage is decoded.
    let probe = Frame {
        seq: 0,
        message: Message::ImuSample(ImuSampleMsg {
            t: 1.0,
            dtheta_b: [0.0; 3],
            dv_b: [0.0; 3],
        }),
    };
    let mut dec = flexcal_core::link::Decoder::new();
    data.iter().for_each(|b| {
        let _ = dec.push(*b);
    });
    let mut buf = [0u8; MAX_FRAME_LEN];
    let n = encode(probe.seq, &probe.message, &mut buf).expect("valid");
    let last = buf[..n].iter().filter_map(|b| dec.push(*b)).last();
    assert_eq!(last, Some(Ok(probe)));
});
