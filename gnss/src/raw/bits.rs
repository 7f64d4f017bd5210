//! Bit fields of navigation messages: unsigned and two's-complement fields of up to 32 bits
//! at any bit offset of a big-endian bit string (bit 0 is the most significant bit of byte 0),
//! as the interface documents number them.

/// An unsigned field of `len` (≤ 32) bits starting at bit `pos`; bits past the end read as 0.
pub fn bits_u(buf: &[u8], pos: usize, len: usize) -> u32 {
    let mut v = 0u32;
    for i in pos..pos + len {
        let bit = buf.get(i / 8).map_or(0, |b| (b >> (7 - i % 8)) & 1);
        v = (v << 1) | bit as u32;
    }
    v
}

/// A two's-complement field of `len` (1..=32) bits starting at bit `pos`.
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
pub fn crc24q(data: &[u8]) -> u32 {
    const POLY: u32 = 0x186_4CFB;
    let mut crc = 0u32;
    for &b in data {
        crc ^= (b as u32) << 16;
        for _ in 0..8 {
            crc <<= 1;
            if crc & 0x100_0000 != 0 {
                crc ^= POLY;
            }
        }
    }
    crc & 0xFF_FFFF
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

    #[test]
    fn crc24q_check_value() {
        // The catalogued check value of CRC-24/LTE-A (same polynomial, init 0, no reflection).
        assert_eq!(crc24q(b"123456789"), 0xCDE703);
    }
}
