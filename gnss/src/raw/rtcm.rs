//! RTCM 3 frames: the byte stream cut into messages with the CRC-24Q checked.
//!
//! What enters: a byte stream ([`FrameReader`]). What leaves: message payloads with a valid
//! CRC and their message numbers, and counts of everything skipped in [`RawStats`].
//! Messages are decoded in [`super::rtcm_msm`] (observations) and [`super::log_items`]
//! (the loop over a log, station position, GLONASS channels, the week hint).
//!
//! A frame is `D3`, six reserved bits and a 10-bit payload length, the payload (its first
//! 12 bits are the message number), and a CRC-24Q over header and payload. A frame whose CRC
//! fails is counted and the search for the next preamble resumes one byte after its start,
//! so a corrupted length cannot swallow good frames.

use super::bits::{bits_u, crc24q};
use super::frames::{FrameScanner, Framing};
use super::RawStats;
use std::io::Read;

/// The preamble byte of every frame.
pub const PREAMBLE: u8 = 0xD3;

/// Whether a whole frame (`D3 …` through its three CRC bytes) has the right CRC-24Q.
pub fn crc_ok(frame: &[u8]) -> bool {
    let n = frame.len();
    if n < 6 {
        return false;
    }
    let c = crc24q(&frame[..n - 3]);
    c == u32::from_be_bytes([0, frame[n - 3], frame[n - 2], frame[n - 1]])
}

/// The length of the payload announced by a frame header (`D3` and two bytes).
pub fn payload_len(h: &[u8]) -> usize {
    ((h[1] as usize & 3) << 8) | h[2] as usize
}

/// A whole frame around `payload` (at most 1023 bytes), with its CRC.
pub fn frame(payload: &[u8]) -> Vec<u8> {
    let n = payload.len().min(1023);
    let mut f = vec![PREAMBLE, (n >> 8) as u8, n as u8];
    f.extend_from_slice(&payload[..n]);
    let c = crc24q(&f);
    f.extend_from_slice(&c.to_be_bytes()[1..]);
    f
}

/// The message number of a payload (its first 12 bits).
pub fn message_number(payload: &[u8]) -> u16 {
    bits_u(payload, 0, 12) as u16
}

/// RTCM 3 framing: `D3`, six zero bits and a 10-bit payload length; CRC-24Q.
pub struct Rtcm3;

impl Framing for Rtcm3 {
    const HEADER: usize = 3;
    fn is_sync(b: u8) -> bool {
        b == PREAMBLE
    }
    fn frame_len(h: &[u8]) -> Option<usize> {
        (h[0] == PREAMBLE && h[1] & 0xfc == 0).then(|| payload_len(h) + 6)
    }
    fn check(frame: &[u8]) -> bool {
        crc_ok(frame)
    }
}

/// Reads the frames of a stream in a bounded buffer.
pub struct FrameReader<R: Read>(FrameScanner<R, Rtcm3>);

impl<R: Read> FrameReader<R> {
    /// A reader of the frames in `src`.
    pub fn new(src: R) -> Self {
        FrameReader(FrameScanner::new(src, 1 << 16))
    }

    /// The payload of the next frame with a valid CRC, or `None` at the end of the input.
    /// Skipped bytes, CRC failures and a truncated last frame are counted in `stats`.
    pub fn next_frame(&mut self, stats: &mut RawStats) -> std::io::Result<Option<&[u8]>> {
        Ok(self.0.next_frame(stats)?.map(|f| &f[3..f.len() - 3]))
    }
}

/// Whether a whole frame with a valid CRC starts at `i` of `head`.
pub fn frame_at(head: &[u8], i: usize) -> bool {
    if i + 6 > head.len() || head[i] != PREAMBLE || head[i + 1] & 0xfc != 0 {
        return false;
    }
    let end = i + payload_len(&head[i..]) + 6;
    end <= head.len() && crc_ok(&head[i..end])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_are_cut_and_bad_crcs_counted() {
        let a = frame(&[0x3e, 0xd0, 1, 2, 3]);
        let b = frame(&[0x3e, 0xe0, 9]);
        let mut bad = a.clone();
        bad[4] ^= 1;
        let mut s = b"junk".to_vec();
        for f in [&a, &bad, &b] {
            s.extend_from_slice(f);
        }
        s.extend_from_slice(&a[..5]);
        let mut st = RawStats::default();
        let mut r = FrameReader::new(&s[..]);
        assert_eq!(
            message_number(r.next_frame(&mut st).unwrap().unwrap()),
            1005
        );
        assert_eq!(
            message_number(r.next_frame(&mut st).unwrap().unwrap()),
            1006
        );
        assert!(r.next_frame(&mut st).unwrap().is_none());
        assert_eq!(
            (st.frames, st.checksum_failures, st.truncated_frames),
            (2, 1, 1)
        );
        assert!(frame_at(&a, 0) && !frame_at(&bad, 0));
    }
}
