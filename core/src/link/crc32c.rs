//! CRC-32C (Castagnoli), the checksum of every link frame.
//!
//! Parameters: reflected polynomial `0x82F63B78` (normal form `0x1EDC6F41`), initial
//! value `0xFFFFFFFF`, final xor `0xFFFFFFFF`, input and output reflected. The check
//! value (CRC of the ASCII bytes `"123456789"`) is `0xE3069283`.
//!
//! Byte-at-a-time with a 256-entry table (1 KiB of flash) built at compile time.

/// Reflected CRC-32C polynomial.
pub const POLY: u32 = 0x82F6_3B78;

/// The CRC of `"123456789"`, for self-tests.
pub const CHECK: u32 = 0xE306_9283;

/// One table entry: the CRC register after shifting the byte `index` through it.
const fn entry(index: u32) -> u32 {
    let mut crc = index;
    let mut bit = 0;
    while bit < 8 {
        crc = if crc & 1 == 1 {
            (crc >> 1) ^ POLY
        } else {
            crc >> 1
        };
        bit += 1;
    }
    crc
}

/// Builds the lookup table at compile time (`while` loops: `for` is not allowed in `const fn`).
const fn build_table() -> [u32; 256] {
    let mut table = [0u32; 256];
    let mut rest: &mut [u32] = &mut table;
    let mut i = 0;
    while let [slot, tail @ ..] = rest {
        *slot = entry(i);
        rest = tail;
        i += 1;
    }
    table
}

static TABLE: [u32; 256] = build_table();

/// An incremental CRC-32C computation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Crc32c {
    state: u32,
}

impl Default for Crc32c {
    fn default() -> Self {
        Self::new()
    }
}

impl Crc32c {
    /// A fresh computation (register `0xFFFFFFFF`).
    pub const fn new() -> Self {
        Self { state: 0xFFFF_FFFF }
    }

    /// Feeds bytes.
    ///
    /// Four bytes a turn with the one table: the CRC is linear, so the word's four bytes
    /// are xored into the register at once and four table steps follow, each
    /// `crc = (crc >> 8) ^ T[crc & 0xFF]` (byte by byte, each byte is xored in just
    /// before its step: the same bits, since the later bytes only ride along through
    /// the shifts). About 4 instructions a byte on the board instead of 7.
    pub fn update(&mut self, bytes: &[u8]) {
        let mut crc = self.state;
        let mut words = bytes.chunks_exact(4);
        for w in &mut words {
            let mut word = [0u8; 4];
            word.copy_from_slice(w);
            crc ^= u32::from_le_bytes(word);
            // Written out: `flexcal-core` is built for size, which does not unroll.
            crc = (crc >> 8) ^ table(crc as u8);
            crc = (crc >> 8) ^ table(crc as u8);
            crc = (crc >> 8) ^ table(crc as u8);
            crc = (crc >> 8) ^ table(crc as u8);
        }
        for &b in words.remainder() {
            crc = (crc >> 8) ^ table((crc as u8) ^ b);
        }
        self.state = crc;
    }

    /// The CRC of everything fed so far.
    pub const fn finish(&self) -> u32 {
        self.state ^ 0xFFFF_FFFF
    }
}

/// The table's entry for `index`.
#[inline(always)]
fn table(index: u8) -> u32 {
    // Always `Some`: a u8 index into a 256-entry table.
    TABLE.get(usize::from(index)).copied().unwrap_or(0)
}

/// CRC-32C of `bytes`.
pub fn crc32c(bytes: &[u8]) -> u32 {
    let mut c = Crc32c::new();
    c.update(bytes);
    c.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bit-by-bit reference (no table), to check the table.
    fn bitwise(bytes: &[u8]) -> u32 {
        let mut crc = 0xFFFF_FFFFu32;
        for &b in bytes {
            crc ^= u32::from(b);
            for _ in 0..8 {
                crc = if crc & 1 == 1 {
                    (crc >> 1) ^ POLY
                } else {
                    crc >> 1
                };
            }
        }
        !crc
    }

    #[test]
    fn check_value() {
        assert_eq!(crc32c(b"123456789"), CHECK);
        assert_eq!(crc32c(b"123456789"), 0xE306_9283);
    }

    #[test]
    fn empty_input() {
        assert_eq!(crc32c(&[]), 0);
    }

    #[test]
    fn iscsi_vectors() {
        // RFC 3720, appendix B.4.
        assert_eq!(crc32c(&[0u8; 32]), 0x8A91_36AA);
        assert_eq!(crc32c(&[0xFFu8; 32]), 0x62A8_AB43);
        let inc: [u8; 32] = core::array::from_fn(|i| i as u8);
        assert_eq!(crc32c(&inc), 0x46DD_794E);
        let dec: [u8; 32] = core::array::from_fn(|i| 31 - i as u8);
        assert_eq!(crc32c(&dec), 0x113F_DB5C);
    }

    #[test]
    fn table_matches_bitwise() {
        for i in 0..256u32 {
            assert_eq!(TABLE[i as usize], entry(i));
        }
        let data: [u8; 300] = core::array::from_fn(|i| (i * 7 + 3) as u8);
        for n in [0, 1, 2, 7, 100, 300] {
            assert_eq!(crc32c(&data[..n]), bitwise(&data[..n]));
        }
        // Every length and start (the word loop and the remainder), and pieces fed in
        // splits that cut words.
        for start in 0..8 {
            for n in 0..120 {
                let d = &data[start..start + n];
                assert_eq!(crc32c(d), bitwise(d), "start {start} len {n}");
                let mut c = Crc32c::new();
                let (a, b) = d.split_at(n / 3);
                c.update(a);
                c.update(b);
                assert_eq!(c.finish(), bitwise(d));
            }
        }
    }

    #[test]
    fn incremental_equals_one_shot() {
        let data = b"The quick brown fox jumps over the lazy dog";
        let mut c = Crc32c::new();
        let (a, b) = data.split_at(10);
        c.update(a);
        c.update(b);
        assert_eq!(c.finish(), crc32c(data));
    }

    #[test]
    fn detects_every_single_bit_flip() {
        let data: [u8; 64] = core::array::from_fn(|i| (i * 31 + 5) as u8);
        let good = crc32c(&data);
        for byte in 0..data.len() {
            for bit in 0..8 {
                let mut d = data;
                d[byte] ^= 1 << bit;
                assert_ne!(crc32c(&d), good);
            }
        }
    }
}
