//! Bit fields of navigation messages: unsigned and two's-complement fields of up to 32 bits
//! at any bit offset of a big-endian bit string (bit 0 is the most significant bit of byte 0),
//! as the interface documents number them; and `Writer`, which writes such fields.

/// An unsigned field of `len` (≤ 32) bits starting at bit `pos`; bits past the end read as 0.
#[inline]
pub fn bits_u(buf: &[u8], pos: usize, len: usize) -> u32 {
    // Eight bytes at once where the buffer has them (the field spans at most five).
    if (1..=32).contains(&len) {
        if let Some(b) = buf.get(pos / 8..pos / 8 + 8) {
            let acc = u64::from_be_bytes(b.try_into().unwrap_or([0; 8]));
            return ((acc >> (64 - pos % 8 - len)) & ((1u64 << len) - 1)) as u32;
        }
    }
    bits_u_near_end(buf, pos, len)
}

/// [`bits_u`] of a field of any length, or within eight bytes of the end.
#[cold]
fn bits_u_near_end(buf: &[u8], pos: usize, len: usize) -> u32 {
    if len == 0 {
        return 0;
    }
    if len > 32 {
        // The low 32 bits, as shifting the whole field through a u32 would leave them.
        return bits_u(buf, pos + len - 32, 32);
    }
    // The (at most five) bytes the field spans, big-endian in a u64.
    let (first, last) = (pos / 8, (pos + len - 1) / 8);
    let acc = (first..=last).fold(0u64, |acc, i| {
        (acc << 8) | u64::from(buf.get(i).copied().unwrap_or(0))
    });
    let shift = (last - first + 1) * 8 - pos % 8 - len;
    ((acc >> shift) & ((1u64 << len) - 1)) as u32
}

/// A two's-complement field of `len` (1..=32) bits starting at bit `pos`.
#[inline]
pub fn bits_s(buf: &[u8], pos: usize, len: usize) -> i32 {
    let u = bits_u(buf, pos, len);
    if len == 32 {
        u as i32
    } else {
        ((u << (32 - len)) as i32) >> (32 - len)
    }
}

/// Write the low `len` bits of `v` at bit `pos` (the buffer must be long enough).
pub fn set_bits(buf: &mut [u8], pos: usize, len: usize, v: u32) {
    for k in 0..len {
        let i = pos + k;
        let bit = (v >> (len - 1 - k)) & 1;
        let mask = 1u8 << (7 - i % 8);
        if bit == 1 {
            buf[i / 8] |= mask;
        } else {
            buf[i / 8] &= !mask;
        }
    }
}

/// CRC-24Q (the Qualcomm CRC of Galileo I/NAV, RTCM 3 and SBAS) of whole bytes.
///
/// Four bytes a step ("slicing by four"): the CRC is kept in the top 24 bits of a 32-bit
/// register, where a step is that of a 32-bit CRC with the tables of `CRC24Q_SLICES`.
pub fn crc24q(data: &[u8]) -> u32 {
    let t = &CRC24Q_SLICES;
    let mut chunks = data.chunks_exact(4);
    let mut r = 0u32; // CRC << 8
    for c in &mut chunks {
        r ^= u32::from_be_bytes([c[0], c[1], c[2], c[3]]);
        r = t[3][(r >> 24) as usize]
            ^ t[2][(r >> 16 & 0xFF) as usize]
            ^ t[1][(r >> 8 & 0xFF) as usize]
            ^ t[0][(r & 0xFF) as usize];
    }
    let crc = chunks.remainder().iter().fold(r >> 8, |crc, &b| {
        ((crc << 8) ^ CRC24Q_TABLE[((crc >> 16) as u8 ^ b) as usize]) & 0xFF_FFFF
    });
    crc & 0xFF_FFFF
}

/// The byte tables of a four-byte step: `[k][i]` is the register after byte `i` followed by
/// `k` zero bytes (the CRC of byte `i`, shifted into the top 24 bits, for `k` = 0).
const CRC24Q_SLICES: [[u32; 256]; 4] = {
    let mut t = [[0u32; 256]; 4];
    let mut i = 0;
    while i < 256 {
        t[0][i] = CRC24Q_TABLE[i] << 8;
        i += 1;
    }
    let mut k = 1;
    while k < 4 {
        let mut i = 0;
        while i < 256 {
            let p = t[k - 1][i];
            t[k][i] = (p << 8) ^ t[0][(p >> 24) as usize];
            i += 1;
        }
        k += 1;
    }
    t
};

/// The CRC-24Q polynomial, x²⁴ + … + 1.
const CRC24Q_POLY: u32 = 0x186_4CFB;

/// The CRC-24Q of each byte value (a byte at a time instead of a bit at a time).
const CRC24Q_TABLE: [u32; 256] = {
    let mut t = [0u32; 256];
    let mut i = 0;
    while i < 256 {
        let mut crc = (i as u32) << 16;
        let mut k = 0;
        while k < 8 {
            crc <<= 1;
            if crc & 0x100_0000 != 0 {
                crc ^= CRC24Q_POLY;
            }
            k += 1;
        }
        t[i] = crc & 0xFF_FFFF;
        i += 1;
    }
    t
};

/// A payload written field by field, most significant bit first.
pub(crate) struct Writer {
    pub(crate) buf: Vec<u8>,
    pub(crate) pos: usize,
}

impl Writer {
    /// An empty payload.
    pub(crate) fn new() -> Self {
        Writer {
            buf: Vec::new(),
            pos: 0,
        }
    }

    /// Append the low `n` (≤ 64) bits of `v` (two's complement for negative values).
    pub(crate) fn put(&mut self, n: usize, v: i64) {
        if self.buf.len() * 8 < self.pos + n {
            self.buf.resize((self.pos + n).div_ceil(8), 0);
        }
        if n > 32 {
            set_bits(&mut self.buf, self.pos, n - 32, (v >> 32) as u32);
            set_bits(&mut self.buf, self.pos + n - 32, 32, v as u32);
        } else {
            set_bits(&mut self.buf, self.pos, n, v as u32);
        }
        self.pos += n;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_round_trip_across_byte_edges() {
        let mut b = [0u8; 8];
        set_bits(&mut b, 5, 13, 0x1abc);
        set_bits(&mut b, 18, 7, 0x45);
        assert_eq!(bits_u(&b, 5, 13), 0x1abc);
        assert_eq!(bits_u(&b, 18, 7), 0x45);
        set_bits(&mut b, 30, 10, (-3i32) as u32 & 0x3ff);
        assert_eq!(bits_s(&b, 30, 10), -3);
        set_bits(&mut b, 32, 32, 0x8000_0001);
        assert_eq!(bits_s(&b, 32, 32), i32::MIN + 1);
        assert_eq!(bits_u(&b, 60, 8), 0x10, "bits past the end read as 0");
    }

    /// The byte-wise field reader equals reading bit by bit, at every offset and length,
    /// across the end of the buffer too.
    #[test]
    fn fields_equal_bit_by_bit_reading() {
        let buf: Vec<u8> = (0..9u32).map(|i| (i * 97 + 13) as u8 ^ 0xA5).collect();
        let slow = |pos: usize, len: usize| {
            (pos..pos + len).fold(0u32, |v, i| {
                let bit = buf.get(i / 8).map_or(0, |b| (b >> (7 - i % 8)) & 1);
                (v << 1) | u32::from(bit)
            })
        };
        for pos in 0..80 {
            for len in 0..=40 {
                assert_eq!(
                    bits_u(&buf, pos, len),
                    slow(pos, len),
                    "pos {pos} len {len}"
                );
            }
        }
    }

    #[test]
    fn crc24q_check_value() {
        // The catalogued check value of CRC-24/LTE-A (same polynomial, init 0, no reflection).
        assert_eq!(crc24q(b"123456789"), 0xCDE703);
        // four bytes a step equal one byte a step, at every length and alignment
        let data: Vec<u8> = (0..300u32).map(|i| (i * 131 + 7) as u8 ^ 0x5C).collect();
        let bytewise = |d: &[u8]| {
            d.iter().fold(0u32, |crc, &b| {
                ((crc << 8) ^ CRC24Q_TABLE[((crc >> 16) as u8 ^ b) as usize]) & 0xFF_FFFF
            })
        };
        for a in 0..5 {
            for n in 0..data.len() - a {
                assert_eq!(
                    crc24q(&data[a..a + n]),
                    bytewise(&data[a..a + n]),
                    "{a} {n}"
                );
            }
        }
    }
}
