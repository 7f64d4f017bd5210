//! Septentrio SBF blocks: the byte stream cut into blocks with the CRC checked, block names
//! for reports, and ExtEvent (5924, time marks of camera exposures).
//!
//! What enters: a byte stream ([`FrameReader`]) or one whole block ([`decode_ext_event`]).
//! What leaves: blocks with valid CRCs and counts of everything skipped in [`RawStats`].
//! MeasEpoch blocks are decoded in [`super::sbf_meas`] and become RINEX observations
//! (signal codes, carrier phase in cycles, loss-of-lock rules) in [`super::sbf_obs`];
//! navigation blocks become ephemerides in [`super::sbf_nav`].
//!
//! A block is `$@` (0x24 0x40), a CRC-16-CCITT (polynomial 0x1021, initial value 0, u16 LE)
//! over everything from the ID to the end, the ID (u16 LE: block number in the low 13 bits,
//! revision in the high 3), the length of the whole block (u16 LE, a multiple of 4, at least
//! 8, at most [`MAX_BLOCK`]: RTKLIB's limit too, far above the largest MeasEpoch of a
//! receiver tracking 100 satellites on 5 signals), then the body: TOW (u32 ms, 4294967295 do
//! not use) and WNc (u16, the continuous GPS week, 65535 do not use) and the block's fields,
//! all little-endian, padded to the length. A block whose CRC fails is counted and the search
//! for the next `$@` resumes one byte after its start, so a corrupted length cannot swallow
//! good blocks. Every sub-block count and length is checked against the block's own length
//! before it is read.

use super::frames::{FrameScanner, Framing};
use super::RawStats;
use std::io::Read;

/// First sync byte (`$`).
pub const SYNC1: u8 = 0x24;
/// Second sync byte (`@`).
pub const SYNC2: u8 = 0x40;
/// Blocks announcing more bytes than this are taken for a corrupted length.
pub const MAX_BLOCK: usize = 16384;
/// MeasEpoch (version 2) block number.
pub const MEAS_EPOCH: u16 = 4027;
/// MeasExtra block number.
pub const MEAS_EXTRA: u16 = 4000;
/// GPSNav block number.
pub const GPS_NAV: u16 = 5891;
/// GALNav block number.
pub const GAL_NAV: u16 = 4002;
/// GLONav block number.
pub const GLO_NAV: u16 = 4004;
/// BDSNav block number.
pub const BDS_NAV: u16 = 4081;
/// ExtEvent block number.
pub const EXT_EVENT: u16 = 5924;

/// CRC-16-CCITT lookup tables (polynomial 0x1021), built at compile time: `CRC_TABLES[0]` is
/// the byte-wise table, `CRC_TABLES[k]` the contribution of a byte followed by `k` zero bytes
/// (slicing by 8: eight independent look-ups per 8 bytes instead of a chain of eight).
const CRC_TABLES: [[u16; 256]; 8] = {
    let mut t = [[0u16; 256]; 8];
    let mut i = 0;
    while i < 256 {
        let mut c = (i as u16) << 8;
        let mut k = 0;
        while k < 8 {
            c = if c & 0x8000 != 0 {
                (c << 1) ^ 0x1021
            } else {
                c << 1
            };
            k += 1;
        }
        t[0][i] = c;
        i += 1;
    }
    let mut k = 1;
    while k < 8 {
        let mut i = 0;
        while i < 256 {
            let v = t[k - 1][i];
            t[k][i] = (v << 8) ^ t[0][(v >> 8) as usize];
            i += 1;
        }
        k += 1;
    }
    t
};

/// One byte of the CRC.
fn crc_byte(c: u16, b: u8) -> u16 {
    (c << 8) ^ CRC_TABLES[0][((c >> 8) as u8 ^ b) as usize]
}

/// CRC-16-CCITT with initial value 0 (the XMODEM variant SBF uses).
pub fn crc16(data: &[u8]) -> u16 {
    let t = &CRC_TABLES;
    let mut chunks = data.chunks_exact(8);
    let mut c = 0u16;
    for b in &mut chunks {
        c = t[7][((c >> 8) as u8 ^ b[0]) as usize]
            ^ t[6][(c as u8 ^ b[1]) as usize]
            ^ t[5][b[2] as usize]
            ^ t[4][b[3] as usize]
            ^ t[3][b[4] as usize]
            ^ t[2][b[5] as usize]
            ^ t[1][b[6] as usize]
            ^ t[0][b[7] as usize];
    }
    chunks.remainder().iter().fold(c, |c, &b| crc_byte(c, b))
}

/// Whether a whole block (`$@` through its padding) has the right CRC.
pub fn crc_ok(block: &[u8]) -> bool {
    block.len() >= 8 && crc16(&block[4..]) == u16::from_le_bytes([block[2], block[3]])
}

/// A whole block of number `number` and revision `rev` around `body` (TOW, WNc and the
/// fields), padded with zeros to a multiple of 4 bytes, with its CRC (to build test data and
/// synthetic logs). A body that would make the block longer than [`MAX_BLOCK`] is cut.
pub fn block(number: u16, rev: u8, body: &[u8]) -> Vec<u8> {
    let body = &body[..body.len().min(MAX_BLOCK - 8)];
    let len = (8 + body.len()).next_multiple_of(4);
    let mut b = vec![SYNC1, SYNC2, 0, 0];
    b.extend_from_slice(&((number & 0x1fff) | (rev as u16 & 7) << 13).to_le_bytes());
    b.extend_from_slice(&(len as u16).to_le_bytes());
    b.extend_from_slice(body);
    b.resize(len, 0);
    let c = crc16(&b[4..]);
    b[2..4].copy_from_slice(&c.to_le_bytes());
    b
}

/// The length a block header (8 bytes) announces, when it is one.
fn header_len(h: &[u8]) -> Option<usize> {
    let len = u16::from_le_bytes([h[6], h[7]]) as usize;
    (h[0] == SYNC1 && h[1] == SYNC2 && len >= 8 && len.is_multiple_of(4) && len <= MAX_BLOCK)
        .then_some(len)
}

/// Whether a whole block with a valid CRC starts at `i` of `head`.
pub fn block_at(head: &[u8], i: usize) -> bool {
    let Some(h) = head.get(i..i + 8) else {
        return false;
    };
    header_len(h).is_some_and(|len| head.get(i..i + len).is_some_and(crc_ok))
}

/// The name of a block number for reports (`SBF 4013` for the ones not named here).
pub fn type_name(number: u16) -> String {
    let name = match number {
        MEAS_EPOCH => "MeasEpoch",
        MEAS_EXTRA => "MeasExtra",
        5922 => "EndOfMeas",
        4109 => "Meas3Ranges",
        4110 => "Meas3CN0HiRes",
        4111 => "Meas3Doppler",
        4112 => "Meas3PP",
        4113 => "Meas3MP",
        GPS_NAV => "GPSNav",
        5892 => "GPSAlm",
        5893 => "GPSIon",
        5894 => "GPSUtc",
        4042 => "GPSCNav",
        GAL_NAV => "GALNav",
        4003 => "GALAlm",
        4030 => "GALIon",
        4031 => "GALUtc",
        4032 => "GALGstGps",
        GLO_NAV => "GLONav",
        4005 => "GLOAlm",
        4036 => "GLOTime",
        BDS_NAV => "BDSNav",
        4119 => "BDSAlm",
        4120 => "BDSIon",
        4121 => "BDSUtc",
        4095 => "QZSNav",
        4017 => "GPSRawCA",
        4023 => "GALRawINAV",
        4022 => "GALRawFNAV",
        4026 => "GLORawCA",
        4047 => "BDSRaw",
        4006 => "PVTCartesian",
        4007 => "PVTGeodetic",
        4001 => "DOP",
        5921 => "EndOfPVT",
        5914 => "ReceiverTime",
        4013 => "ChannelStatus",
        4014 => "ReceiverStatus",
        5902 => "ReceiverSetup",
        EXT_EVENT => "ExtEvent",
        4037 => "ExtEventPVTCartesian",
        4038 => "ExtEventPVTGeodetic",
        _ => return format!("SBF {number}"),
    };
    format!("SBF {number} {name}")
}

/// One block: number, revision and all its bytes (CRC verified).
pub struct Block<'a> {
    /// Block number (low 13 bits of the ID).
    pub number: u16,
    /// Block revision (high 3 bits of the ID).
    pub rev: u8,
    /// The whole block, sync through padding.
    pub bytes: &'a [u8],
}

/// SBF framing: `$@`, CRC, ID, length of the whole block; CRC-16-CCITT.
pub struct Sbf;

impl Framing for Sbf {
    const HEADER: usize = 8;
    fn is_sync(b: u8) -> bool {
        b == SYNC1
    }
    fn frame_len(h: &[u8]) -> Option<usize> {
        header_len(h)
    }
    fn check(frame: &[u8]) -> bool {
        crc_ok(frame)
    }
}

/// Streams blocks out of a reader with a bounded buffer.
pub struct FrameReader<R: Read>(FrameScanner<R, Sbf>);

impl<R: Read> FrameReader<R> {
    /// A reader of the blocks in `src`.
    pub fn new(src: R) -> Self {
        FrameReader(FrameScanner::new(src, 1 << 17))
    }

    /// The next block with a valid CRC, or `None` at the end of the input. Skipped bytes, CRC
    /// failures and a truncated last block are counted in `stats`.
    pub fn next_block(&mut self, stats: &mut RawStats) -> std::io::Result<Option<Block<'_>>> {
        Ok(self.0.next_frame(stats)?.map(|b| {
            let id = u16::from_le_bytes([b[4], b[5]]);
            Block {
                number: id & 0x1fff,
                rev: (id >> 13) as u8,
                bytes: b,
            }
        }))
    }
}

/// Little-endian fields of a block at byte offsets from its sync (callers check the length
/// first; a field past the end reads as zeros rather than panicking).
pub(crate) struct Le<'a>(pub(crate) &'a [u8]);

impl Le<'_> {
    fn arr<const N: usize>(&self, o: usize) -> [u8; N] {
        self.0
            .get(o..o + N)
            .and_then(|s| s.try_into().ok())
            .unwrap_or([0; N])
    }
    pub(crate) fn u8(&self, o: usize) -> u8 {
        self.0.get(o).copied().unwrap_or(0)
    }
    pub(crate) fn i8(&self, o: usize) -> i8 {
        self.u8(o) as i8
    }
    pub(crate) fn u16(&self, o: usize) -> u16 {
        u16::from_le_bytes(self.arr(o))
    }
    pub(crate) fn u32(&self, o: usize) -> u32 {
        u32::from_le_bytes(self.arr(o))
    }
    pub(crate) fn i32(&self, o: usize) -> i32 {
        i32::from_le_bytes(self.arr(o))
    }
    pub(crate) fn f32(&self, o: usize) -> f32 {
        f32::from_le_bytes(self.arr(o))
    }
    pub(crate) fn f64(&self, o: usize) -> f64 {
        f64::from_le_bytes(self.arr(o))
    }
}

/// The time tag of a block: TOW (ms) and WNc, `None` where the receiver sent do-not-use.
pub fn time_tag(block: &[u8]) -> (Option<u32>, Option<u16>) {
    let f = Le(block);
    let (tow, wnc) = (f.u32(8), f.u16(12));
    (
        (tow != u32::MAX).then_some(tow),
        (wnc != u16::MAX).then_some(wnc),
    )
}

/// An ExtEvent block: the time of an edge on an event input.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExtEvent {
    /// Time of week, ms (`None`: do not use).
    pub tow_ms: Option<u32>,
    /// GPS week (`None`: do not use).
    pub wnc: Option<u16>,
    /// Event input (1: EventA, 2: EventB).
    pub source: u8,
    /// Edge polarity (0: rising, 1: falling).
    pub polarity: u8,
    /// Sub-millisecond part of the event time, s.
    pub offset_s: f64,
    /// Receiver clock bias at the event, s (0 when do-not-use).
    pub clk_bias_s: f64,
}

impl ExtEvent {
    /// GPST week and time of week (s) of the event: TOW + Offset − RxClkBias, as RTKLIB
    /// reads it; `None` when the block's time is do-not-use.
    pub fn time(&self) -> Option<(u16, f64)> {
        let (tow, mut week) = (self.tow_ms?, self.wnc?);
        let mut t = tow as f64 * 1e-3 + self.offset_s - self.clk_bias_s;
        if t < 0.0 {
            t += 604_800.0;
            week = week.checked_sub(1)?;
        } else if t >= 604_800.0 {
            t -= 604_800.0;
            week = week.checked_add(1)?;
        }
        Some((week, t))
    }
}

/// Decode an ExtEvent block (at least 28 bytes, fields through RxClkBias); `None` when shorter.
pub fn decode_ext_event(b: &[u8]) -> Option<ExtEvent> {
    if b.len() < 28 {
        return None;
    }
    let f = Le(b);
    let (tow_ms, wnc) = time_tag(b);
    let offset = f.f32(16);
    let bias = f.f64(20);
    let finite = |x: f64| x.is_finite() && x != -2e10 && x.abs() < 1.0;
    Some(ExtEvent {
        tow_ms,
        wnc,
        source: f.u8(14),
        polarity: f.u8(15),
        offset_s: if finite(offset as f64) {
            offset as f64
        } else {
            0.0
        },
        clk_bias_s: if finite(bias) { bias } else { 0.0 },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_is_ccitt_with_initial_zero() {
        // the XMODEM check value of "123456789"
        assert_eq!(crc16(b"123456789"), 0x31c3);
        // slicing by 8 equals the byte-wise CRC at every length and alignment
        let data: Vec<u8> = (0..40u32).map(|i| (i * 37 + 11) as u8).collect();
        for a in 0..8 {
            for n in 0..data.len() - a {
                let d = &data[a..a + n];
                assert_eq!(
                    crc16(d),
                    d.iter().fold(0, |c, &b| crc_byte(c, b)),
                    "{a} {n}"
                );
            }
        }
        let b = block(4027, 1, &[1, 2, 3, 4, 5, 6]);
        assert_eq!(b.len(), 16);
        assert_eq!(&b[4..8], &[0xbb, 0x2f, 16, 0]); // 4027 | 1 << 13 = 0x2fbb
        assert!(crc_ok(&b) && block_at(&b, 0));
        let mut bad = b.clone();
        bad[9] ^= 1;
        assert!(!crc_ok(&bad) && !block_at(&bad, 0));
    }

    #[test]
    fn blocks_survive_noise_bad_crcs_and_truncation() {
        let good = block(5924, 1, &[0; 24]);
        let mut bad = block(4027, 1, &[0; 12]);
        bad[10] ^= 1;
        let mut log = b"xyz".to_vec();
        log.extend_from_slice(&bad);
        log.extend_from_slice(&good);
        log.extend_from_slice(&good[..12]);
        let mut st = RawStats::default();
        let mut r = FrameReader::new(&log[..]);
        let b = r.next_block(&mut st).unwrap().unwrap();
        assert_eq!((b.number, b.rev, b.bytes.len()), (5924, 1, 32));
        assert!(r.next_block(&mut st).unwrap().is_none());
        assert_eq!(
            (st.frames, st.checksum_failures, st.truncated_frames),
            (1, 1, 1)
        );
        assert_eq!(st.skipped_bytes, 3 + bad.len() as u64 + 12);
    }

    #[test]
    fn ext_event_time() {
        let mut body = vec![0u8; 20];
        body[0..4].copy_from_slice(&100_000u32.to_le_bytes());
        body[4..6].copy_from_slice(&2300u16.to_le_bytes());
        body[6] = 1;
        body[7] = 1;
        body[8..12].copy_from_slice(&0.000_25f32.to_le_bytes());
        body[12..20].copy_from_slice(&1e-7f64.to_le_bytes());
        let e = decode_ext_event(&block(EXT_EVENT, 1, &body)).unwrap();
        let (w, t) = e.time().unwrap();
        assert_eq!((w, e.source, e.polarity), (2300, 1, 1));
        assert!((t - (100.000_25 - 1e-7)).abs() < 1e-9);
        assert!(decode_ext_event(&block(EXT_EVENT, 1, &body)[..20]).is_none());
    }
}
