//! Consistent Overhead Byte Stuffing (COBS), with `0x00` as the frame delimiter.
//!
//! The encoded form of `n` bytes holds no `0x00` and is at most
//! `n + ceil(n / 254)` bytes long (`n + 1` for `1 ≤ n ≤ 254`). Each block is a code
//! byte `c` (1..=255) followed by `c − 1` data bytes; a block with `c < 255` stands
//! for its data followed by one `0x00`, except for the last block of the frame
//! (the implicit trailing zero is dropped). The encoder writes the canonical form:
//! after a full block (`c = 255`) a new block is started only if data remain.
//!
//! Both functions work on caller buffers, never allocate and never panic.

/// Errors of [`decode_in_place`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum CobsError {
    /// A `0x00` inside the encoded frame (it can only be a delimiter).
    ZeroByte,
    /// A code byte announces more data bytes than the frame holds.
    Truncated,
}

/// Largest encoded length of `n` bytes (without delimiters).
pub const fn max_encoded_len(n: usize) -> usize {
    if n == 0 {
        1
    } else {
        n + n.div_ceil(254)
    }
}

/// Encodes `src` into `dst` (no delimiters written). Returns the encoded length, or
/// `None` if `dst` is too small (then `dst` holds garbage).
///
/// A block at a time: the block's bytes copied up to its zero (or its 254th byte) in one
/// loop, its code byte written after (a byte at a time with the code's bookkeeping per
/// byte cost 21 instructions a byte on the board).
pub fn encode(src: &[u8], dst: &mut [u8]) -> Option<usize> {
    let mut out = 0usize;
    let mut rest = src;
    loop {
        let limit = rest.len().min(254);
        let head = rest.get(..limit)?;
        // The block's bytes copied while its zero is looked for (one pass).
        let (code, room) = dst.get_mut(out..)?.split_first_mut()?;
        let mut run = 0;
        for (d, s) in room.iter_mut().zip(head) {
            if *s == 0 {
                break;
            }
            *d = *s;
            run += 1;
        }
        if head.get(run).is_some_and(|b| *b != 0) {
            // The copy stopped at the end of `dst`, not at a zero or the block's end.
            return None;
        }
        // run ≤ 254: the code byte is at most 0xFF.
        *code = (run + 1) as u8;
        out += 1 + run;
        if run < limit {
            // A zero: the block's implicit one. A zero at the very end leaves an empty
            // slice, whose block (code 1) the next turn writes.
            rest = rest.get(run + 1..)?;
        } else if run == 254 && rest.len() > 254 {
            // A full block (no implicit zero) with data after it.
            rest = rest.get(254..)?;
        } else {
            return Some(out);
        }
    }
}

/// Decodes one frame (the bytes between two delimiters) in place; returns the decoded
/// length, the decoded bytes being `buf[..len]`. `O(buf.len())`. The link's streaming
/// decoder (`codec::Decoder`) unstuffs as the bytes arrive instead; its tests check it
/// against this whole-frame form.
pub fn decode_in_place(buf: &mut [u8]) -> Result<usize, CobsError> {
    let n = buf.len();
    let mut read = 0usize;
    let mut write = 0usize;
    // Invariant: write < read + 1 (decoding never grows): each block's data move towards
    // the front, each byte read before the place it came from is overwritten.
    while let Some(&code) = buf.get(read) {
        if code == 0 {
            return Err(CobsError::ZeroByte);
        }
        let start = read + 1;
        let end = start + usize::from(code) - 1;
        if end > n {
            return Err(CobsError::Truncated);
        }
        // The block's data, `start..end`, moved to `write..`: one loop that checks each
        // byte for a zero and moves it (`copy_within` keeps a panic path in the board
        // image; a separate zero scan cost a pass of its own).
        let seg = buf.get_mut(write..end).ok_or(CobsError::Truncated)?;
        let shift = start - write;
        for k in shift..seg.len() {
            let b = *seg.get(k).ok_or(CobsError::Truncated)?;
            if b == 0 {
                return Err(CobsError::ZeroByte);
            }
            *seg.get_mut(k - shift).ok_or(CobsError::Truncated)? = b;
        }
        write += end - start;
        read = end;
        if code != 0xFF && read < n {
            *buf.get_mut(write).ok_or(CobsError::Truncated)? = 0;
            write += 1;
        }
    }
    Ok(write)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn roundtrip(src: &[u8]) -> ([u8; 1024], usize) {
        let mut enc = [0u8; 1024];
        let n = encode(src, &mut enc).unwrap();
        assert!(n <= max_encoded_len(src.len()), "len {n} for {}", src.len());
        assert!(!enc[..n].contains(&0));
        let mut dec = enc;
        let m = decode_in_place(&mut dec[..n]).unwrap();
        assert_eq!(&dec[..m], src);
        (enc, n)
    }

    // The byte-at-a-time encoder and the two-pass decoder this module had before
    // (issue12-s13b): the block-wise ones must give the same bytes and the same errors.
    /// Encodes `src` into `dst` (no delimiters written). Returns the encoded length, or
    /// `None` if `dst` is too small (then `dst` holds garbage).
    fn reference_encode(src: &[u8], dst: &mut [u8]) -> Option<usize> {
        // Position of the current block's code byte, and its code so far.
        let mut code_at = 0usize;
        let mut code = 1u8;
        let mut out = 1usize;
        // After a full block, whether the next block has been opened.
        let mut open = true;
        for &b in src {
            if !open {
                code_at = out;
                code = 1;
                out += 1;
                open = true;
            }
            if b == 0 {
                *dst.get_mut(code_at)? = code;
                code_at = out;
                code = 1;
                out += 1;
            } else {
                *dst.get_mut(out)? = b;
                out += 1;
                code += 1;
                if code == 0xFF {
                    *dst.get_mut(code_at)? = code;
                    open = false;
                }
            }
        }
        if open {
            *dst.get_mut(code_at)? = code;
        }
        Some(out)
    }

    /// Decodes one frame (the bytes between two delimiters) in place; returns the decoded
    /// length, the decoded bytes being `buf[..len]`. `O(buf.len())`.
    fn reference_decode(buf: &mut [u8]) -> Result<usize, CobsError> {
        let n = buf.len();
        let mut read = 0usize;
        let mut write = 0usize;
        // Invariant: write ≤ read (decoding never grows), so copies never overlap badly.
        while let Some(&code) = buf.get(read) {
            if code == 0 {
                return Err(CobsError::ZeroByte);
            }
            let start = read + 1;
            let end = start + usize::from(code) - 1;
            if end > n {
                return Err(CobsError::Truncated);
            }
            let data = buf.get(start..end).ok_or(CobsError::Truncated)?;
            if data.contains(&0) {
                return Err(CobsError::ZeroByte);
            }
            // In bounds: start ≤ end ≤ n and write + (end − start) ≤ end. Byte by byte with
            // checked accesses: `copy_within` keeps a panic path in the board image.
            for k in 0..end - start {
                let b = *buf.get(start + k).ok_or(CobsError::Truncated)?;
                *buf.get_mut(write + k).ok_or(CobsError::Truncated)? = b;
            }
            write += end - start;
            read = end;
            if code != 0xFF && read < n {
                *buf.get_mut(write).ok_or(CobsError::Truncated)? = 0;
                write += 1;
            }
        }
        Ok(write)
    }

    #[test]
    fn block_wise_equals_byte_wise() {
        let mut x = 0x2545_F491u32;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x
        };
        for len in (0..600).chain(0..600) {
            // Zeros dense, sparse or absent, so that blocks are short, long and full.
            let density = next() % 4;
            let src: [u8; 600] = core::array::from_fn(|_| {
                let r = next();
                match density {
                    0 => (r as u8) % 3,
                    1 => (r as u8) | u8::from(r % 40 != 0),
                    _ => (r as u8) | 1,
                }
            });
            let src = &src[..len];
            let (mut a, mut b) = ([0u8; 700], [0u8; 700]);
            let (na, nb) = (encode(src, &mut a), reference_encode(src, &mut b));
            assert_eq!(na, nb, "len {len}");
            let n = na.unwrap();
            assert_eq!(&a[..n], &b[..n], "len {len}");
            for cut in [n, n.saturating_sub(1), n / 2] {
                assert_eq!(encode(src, &mut a[..cut]).is_some(), cut >= n);
            }
            // Decoding: the encoding, and the encoding damaged (a byte changed, zeros).
            for damage in 0..4 {
                let mut e = b;
                if damage > 0 && n > 0 {
                    let at = next() as usize % n;
                    e[at] = if damage == 1 { 0 } else { next() as u8 };
                }
                let (mut d1, mut d2) = (e, e);
                let r1 = decode_in_place(&mut d1[..n]);
                let r2 = reference_decode(&mut d2[..n]);
                assert_eq!(r1, r2, "len {len} damage {damage}");
                if let Ok(m) = r1 {
                    assert_eq!(&d1[..m], &d2[..m]);
                }
            }
        }
    }

    #[test]
    fn reference_vectors() {
        // The classic examples (Cheshire & Baker; also listed on Wikipedia).
        let cases: &[(&[u8], &[u8])] = &[
            (&[], &[0x01]),
            (&[0x00], &[0x01, 0x01]),
            (&[0x00, 0x00], &[0x01, 0x01, 0x01]),
            (&[0x00, 0x11, 0x00], &[0x01, 0x02, 0x11, 0x01]),
            (&[0x11, 0x22, 0x00, 0x33], &[0x03, 0x11, 0x22, 0x02, 0x33]),
            (&[0x11, 0x22, 0x33, 0x44], &[0x05, 0x11, 0x22, 0x33, 0x44]),
            (&[0x11, 0x00, 0x00, 0x00], &[0x02, 0x11, 0x01, 0x01, 0x01]),
        ];
        for (src, want) in cases {
            let (enc, n) = roundtrip(src);
            assert_eq!(&enc[..n], *want, "src {src:02x?}");
        }
    }

    #[test]
    fn long_blocks() {
        // 254 non-zero bytes: one full block, no trailing code byte.
        let a: [u8; 254] = core::array::from_fn(|i| (i + 1) as u8);
        let (enc, n) = roundtrip(&a);
        assert_eq!(n, 255);
        assert_eq!(enc[0], 0xFF);
        // A zero then 254 non-zero bytes.
        let mut b = [0u8; 255];
        b[1..].copy_from_slice(&a);
        let (enc, n) = roundtrip(&b);
        assert_eq!(n, 256);
        assert_eq!(&enc[..2], &[0x01, 0xFF]);
        // 255 non-zero bytes: a full block then a block of one.
        let c: [u8; 255] = core::array::from_fn(|i| (i % 255 + 1) as u8);
        let (enc, n) = roundtrip(&c);
        assert_eq!(n, 257);
        assert_eq!(enc[0], 0xFF);
        assert_eq!(&enc[255..257], &[0x02, c[254]]);
        // A full block followed by a zero.
        let mut d = [0u8; 255];
        d[..254].copy_from_slice(&a);
        let (enc, n) = roundtrip(&d);
        assert_eq!(&enc[254..n], &[a[253], 0x01, 0x01][..n - 254]);
    }

    #[test]
    fn all_short_patterns_roundtrip() {
        // Every 3-byte string over {0, 1, 0xFF}, and lengths around block boundaries.
        let alphabet = [0u8, 1, 0xFF];
        for a in alphabet {
            for b in alphabet {
                for c in alphabet {
                    roundtrip(&[a, b, c]);
                }
            }
        }
        for len in [253, 254, 255, 256, 508, 509, 510] {
            let v: [u8; 600] = core::array::from_fn(|i| if i % 300 == 299 { 0 } else { 7 });
            roundtrip(&v[..len]);
        }
    }

    #[test]
    fn small_destination() {
        let mut dst = [0u8; 4];
        assert_eq!(encode(&[1, 2, 3, 4], &mut dst), None);
        assert_eq!(encode(&[1, 2, 3], &mut dst), Some(4));
        assert_eq!(encode(&[], &mut []), None);
    }

    #[test]
    fn invalid_frames() {
        assert_eq!(
            decode_in_place(&mut [0x03, 0x11]),
            Err(CobsError::Truncated)
        );
        assert_eq!(decode_in_place(&mut [0x02, 0x00]), Err(CobsError::ZeroByte));
        assert_eq!(decode_in_place(&mut [0x00]), Err(CobsError::ZeroByte));
        assert_eq!(
            decode_in_place(&mut [0x01, 0x05]),
            Err(CobsError::Truncated)
        );
        assert_eq!(decode_in_place(&mut []), Ok(0));
    }

    #[test]
    fn arbitrary_input_never_panics() {
        // Every 1- and 2-byte input, and a pseudo-random sweep of longer ones.
        for a in 0..=255u8 {
            let _ = decode_in_place(&mut [a]);
            for b in 0..=255u8 {
                let _ = decode_in_place(&mut [a, b]);
            }
        }
        let mut x = 0x1234_5678u32;
        for len in 0..300 {
            let mut buf = [0u8; 300];
            for byte in buf.iter_mut().take(len) {
                x ^= x << 13;
                x ^= x >> 17;
                x ^= x << 5;
                *byte = x as u8;
            }
            if let Ok(n) = decode_in_place(&mut buf[..len]) {
                assert!(n <= len);
            }
        }
    }
}
