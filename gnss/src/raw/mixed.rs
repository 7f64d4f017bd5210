//! Logs that mix protocols: u-blox UBX, RTCM 3 and NMEA 0183 in one byte stream, as a base
//! receiver logs them (RXM-RAWX beside the RTCM 3 corrections it sends, NMEA for a display).
//!
//! What enters: a byte stream. What leaves: each whole frame whose checksum holds, tagged with
//! its protocol ([`MixedFrame`]), and counts per protocol in [`RawStats::protocols`]. A frame of
//! one protocol is never read as noise by another: the scanner tries, at each byte, the
//! protocol whose sync that byte is (`B5 62` UBX, `D3` RTCM 3, `$` and a sentence address
//! NMEA), so the RTCM 3 frames between UBX ones are frames, not checksum failures. A header
//! whose checksum fails still costs one byte, as in [`super::frames`].
//!
//! NMEA sentences are `$`, an address of letters and digits, fields, `*`, two hex digits of the
//! XOR of the bytes between `$` and `*`, and a line end; sentences without a checksum are not
//! taken (nothing would tell them from noise).

use super::frames::{FrameScanner, Framing};
use super::rtcm::{self, Rtcm3};
use super::ubx::{self, Ubx};
use super::RawStats;
use std::io::Read;

/// The longest NMEA sentence taken, bytes (`$` through the line end): NMEA 0183 allows 82,
/// u-blox's PUBX sentences run longer.
const NMEA_MAX: usize = 200;

/// A protocol of a mixed log.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Protocol {
    /// u-blox UBX.
    Ubx,
    /// RTCM 3.
    Rtcm3,
    /// NMEA 0183.
    Nmea,
}

impl Protocol {
    /// The protocol's name for reports.
    pub fn name(self) -> &'static str {
        match self {
            Protocol::Ubx => "UBX",
            Protocol::Rtcm3 => "RTCM 3",
            Protocol::Nmea => "NMEA",
        }
    }
}

/// The length of an NMEA sentence starting at `h[0] == '$'` (through its line end), when `h`
/// holds one with a two-digit checksum field.
fn nmea_len(h: &[u8]) -> Option<usize> {
    let addr = h.iter().skip(1).take_while(|c| c.is_ascii_alphanumeric());
    let n_addr = addr.clone().count();
    if !(2..=8).contains(&n_addr) || !addr.take(1).all(|c| c.is_ascii_uppercase()) {
        return None;
    }
    if h.get(1 + n_addr) != Some(&b',') {
        return None;
    }
    let star = h
        .iter()
        .position(|&c| c == b'*' || !(0x20..0x7f).contains(&c))?;
    if h[star] != b'*' {
        return None;
    }
    match h.get(star + 3..star + 5) {
        Some([b'\r', b'\n', ..]) => Some(star + 5),
        Some([b'\n', ..]) => Some(star + 4),
        _ if h.get(star + 3) == Some(&b'\n') => Some(star + 4),
        _ => None,
    }
}

/// Whether an NMEA sentence's checksum holds (`$…*HH` and its line end).
fn nmea_ok(s: &[u8]) -> bool {
    let Some(star) = s.iter().position(|&c| c == b'*') else {
        return false;
    };
    let sum = s[1..star].iter().fold(0u8, |a, &c| a ^ c);
    let hex = std::str::from_utf8(s.get(star + 1..star + 3).unwrap_or(&[])).ok();
    hex.and_then(|h| u8::from_str_radix(h, 16).ok()) == Some(sum)
}

/// The framing of a mixed log: each byte is tried as the sync of the protocol it starts.
pub struct Mixed;

impl Framing for Mixed {
    const HEADER: usize = 6;
    const LOOKAHEAD: usize = NMEA_MAX;
    fn is_sync(b: u8) -> bool {
        b == ubx::SYNC1 || b == rtcm::PREAMBLE || b == b'$'
    }
    fn frame_len(h: &[u8]) -> Option<usize> {
        match h[0] {
            ubx::SYNC1 => Ubx::frame_len(h),
            rtcm::PREAMBLE => Rtcm3::frame_len(h),
            b'$' => nmea_len(h),
            _ => None,
        }
    }
    fn check(frame: &[u8]) -> bool {
        match frame[0] {
            ubx::SYNC1 => Ubx::check(frame),
            rtcm::PREAMBLE => Rtcm3::check(frame),
            _ => nmea_ok(frame),
        }
    }
}

/// One frame of a mixed log.
pub enum MixedFrame<'a> {
    /// A UBX frame.
    Ubx(ubx::Frame<'a>),
    /// An RTCM 3 message payload (its first 12 bits are the message number).
    Rtcm(&'a [u8]),
    /// An NMEA sentence between `$` and `*` (address and fields).
    Nmea(&'a str),
}

impl MixedFrame<'_> {
    /// The frame's protocol.
    pub fn protocol(&self) -> Protocol {
        match self {
            MixedFrame::Ubx(_) => Protocol::Ubx,
            MixedFrame::Rtcm(_) => Protocol::Rtcm3,
            MixedFrame::Nmea(_) => Protocol::Nmea,
        }
    }
}

/// Streams the frames of a mixed log in a bounded buffer.
pub struct MixedReader<R: Read>(FrameScanner<R, Mixed>);

impl<R: Read> MixedReader<R> {
    /// A reader of the frames in `src`.
    pub fn new(src: R) -> Self {
        MixedReader(FrameScanner::new(src, 1 << 17))
    }

    /// The next frame whose checksum holds, or `None` at the end of the input; counted per
    /// protocol in `stats.protocols`, and what was skipped as [`FrameScanner`] counts it.
    pub fn next_frame(&mut self, stats: &mut RawStats) -> std::io::Result<Option<MixedFrame<'_>>> {
        let Some(f) = self.0.next_frame(stats)? else {
            return Ok(None);
        };
        let frame = match f[0] {
            ubx::SYNC1 => MixedFrame::Ubx(ubx::Frame {
                class: f[2],
                id: f[3],
                payload: &f[6..f.len() - 2],
            }),
            rtcm::PREAMBLE => MixedFrame::Rtcm(&f[3..f.len() - 3]),
            _ => {
                let star = f.iter().position(|&c| c == b'*').unwrap_or(f.len());
                // Printable ASCII by `nmea_len`, so always UTF-8.
                MixedFrame::Nmea(std::str::from_utf8(&f[1..star]).unwrap_or(""))
            }
        };
        *stats
            .protocols
            .entry(frame.protocol().name().to_string())
            .or_default() += 1;
        Ok(Some(frame))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An NMEA sentence with its checksum and line end.
    pub(crate) fn sentence(body: &str) -> Vec<u8> {
        let sum = body.bytes().fold(0u8, |a, c| a ^ c);
        format!("${body}*{sum:02X}\r\n").into_bytes()
    }

    /// UBX, RTCM 3 and NMEA frames interleaved with noise are each read as their protocol,
    /// with no checksum failure; a corrupted frame of each is one failure and costs nothing
    /// else.
    #[test]
    fn every_protocol_is_a_frame() {
        let u = ubx::frame(0x02, 0x15, &[7; 20]);
        let r = rtcm::frame(&[0x3e, 0xd0, 1, 2, 3]);
        let n = sentence("GNGGA,123519.00,4807.038,N,01131.000,E,4,08,0.9,545.4,M,46.9,M,1.0,0000");
        let mut log = b"\x00\x01junk$".to_vec();
        for f in [&u, &r, &n, &r, &u] {
            log.extend_from_slice(f);
        }
        let mut bad_u = u.clone();
        bad_u[10] ^= 1;
        let mut bad_n = n.clone();
        bad_n[8] = b'9';
        log.extend_from_slice(&bad_u);
        log.extend_from_slice(&bad_n);
        log.extend_from_slice(&r);
        let mut st = RawStats::default();
        let mut rd = MixedReader::new(&log[..]);
        let mut kinds = Vec::new();
        while let Some(f) = rd.next_frame(&mut st).unwrap() {
            if let MixedFrame::Nmea(s) = &f {
                assert!(s.starts_with("GNGGA,123519.00"), "{s}");
            }
            kinds.push(f.protocol());
        }
        use Protocol::*;
        assert_eq!(kinds, vec![Ubx, Rtcm3, Nmea, Rtcm3, Ubx, Rtcm3]);
        assert_eq!(st.checksum_failures, 2);
        assert_eq!(st.protocols.get("RTCM 3"), Some(&3));
        assert_eq!(st.protocols.get("NMEA"), Some(&1));
        assert_eq!(st.protocols.get("UBX"), Some(&2));
    }
}
