//! Septentrio SBF blocks: the byte stream cut into blocks with the CRC checked, and the two
//! blocks `convert` needs beyond the navigation ones: MeasEpoch (4027, measurements) and
//! ExtEvent (5924, time marks of camera exposures).
//!
//! What enters: a byte stream ([`FrameReader`]) or one whole block ([`decode_meas_epoch`],
//! [`decode_ext_event`]). What leaves: blocks with valid CRCs, their raw fields in physical
//! units, and counts of everything skipped in [`RawStats`]. Measurements become RINEX
//! observations (signal codes, carrier phase in cycles, loss-of-lock rules) in
//! [`super::sbf_obs`]; navigation blocks become ephemerides in [`super::sbf_nav`].
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

/// CRC-16-CCITT lookup table (polynomial 0x1021), built at compile time.
const CRC_TABLE: [u16; 256] = {
    let mut t = [0u16; 256];
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
        t[i] = c;
        i += 1;
    }
    t
};

/// CRC-16-CCITT with initial value 0 (the XMODEM variant SBF uses).
pub fn crc16(data: &[u8]) -> u16 {
    data.iter().fold(0u16, |c, &b| {
        (c << 8) ^ CRC_TABLE[((c >> 8) as u8 ^ b) as usize]
    })
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
    const SYNC: u8 = SYNC1;
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

/// One signal of a MeasEpoch, as the block carries it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SigMeas {
    /// SBF signal number (0..=63: the type field's low 5 bits, or 32 + ObsInfo bits 3–7
    /// when they are 31).
    pub sig: u8,
    /// Antenna (0 main, 1 Aux1, 2 Aux2).
    pub antenna: u8,
    /// Pseudorange, m (`None`: do not use).
    pub pr: Option<f64>,
    /// Carrier phase minus pseudorange over wavelength, cycles (`None`: do not use).
    pub carrier: Option<f64>,
    /// Doppler, Hz; in a Type-2 sub-block the offset from the master's Doppler scaled to this
    /// signal's frequency (`None`: do not use).
    pub doppler: Option<f64>,
    /// C/N0, dB-Hz (`None`: do not use).
    pub cn0: Option<f64>,
    /// Lock time, s (clipped by the receiver at 65534 in Type-1, 254 in Type-2; `None`: do
    /// not use).
    pub lock: Option<u16>,
    /// ObsInfo bit 2: the phase has a half-cycle ambiguity.
    pub half: bool,
    /// From a Type-2 sub-block (offsets from the Type-1 master).
    pub type2: bool,
}

/// One satellite of a MeasEpoch: its Type-1 sub-block and the Type-2 ones after it.
#[derive(Clone, Debug, PartialEq)]
pub struct SatMeas {
    /// SBF SVID.
    pub svid: u8,
    /// GLONASS frequency number (−7..=6) when the master signal is a GLONASS FDMA one.
    pub fcn: Option<i8>,
    /// The Type-1 signal first, then the Type-2 ones.
    pub sigs: Vec<SigMeas>,
}

/// A decoded MeasEpoch block.
#[derive(Clone, Debug, PartialEq)]
pub struct MeasEpoch {
    /// Receiver time of week, ms (`None`: do not use).
    pub tow_ms: Option<u32>,
    /// GPS week (`None`: do not use).
    pub wnc: Option<u16>,
    /// CommonFlags (bit 7: measurements scrambled).
    pub flags: u8,
    /// Satellites in block order.
    pub sats: Vec<SatMeas>,
}

/// C/N0 in dB-Hz of a raw value: 0.25 dB-Hz steps, plus 10 dB-Hz except for GPS L1P and L2P
/// (signal numbers 1 and 2); 255 is do-not-use.
pub fn cn0(raw: u8, sig: u8) -> Option<f64> {
    (raw != 255).then_some(raw as f64 * 0.25 + if sig == 1 || sig == 2 { 0.0 } else { 10.0 })
}

/// The signal number of a type field and ObsInfo byte.
fn signal_number(typ: u8, info: u8) -> u8 {
    match typ & 0x1f {
        31 => 32 + (info >> 3),
        s => s,
    }
}

/// A two's-complement field of `n` bits in the low bits of `v`.
fn signed(v: u8, n: u32) -> i32 {
    let v = v as i32 & ((1 << n) - 1);
    if v >> (n - 1) & 1 == 1 {
        v - (1 << n)
    } else {
        v
    }
}

/// The Type-1 sub-block at `o`: the satellite and its master signal, and its Type-2 count.
fn type1(f: &Le, o: usize) -> (SatMeas, usize) {
    let typ = f.u8(o + 1);
    let info = f.u8(o + 18);
    let sig = signal_number(typ, info);
    let code_msb = f.u8(o + 3) & 0x0f;
    let code_lsb = f.u32(o + 4);
    let doppler = f.i32(o + 8);
    let (c_lsb, c_msb) = (f.u16(o + 12), f.i8(o + 14));
    let lock = f.u16(o + 16);
    let m = SigMeas {
        sig,
        antenna: typ >> 5,
        pr: (code_msb != 0 || code_lsb != 0)
            .then_some(code_msb as f64 * 4_294_967.296 + code_lsb as f64 * 0.001),
        carrier: (c_msb != -128 || c_lsb != 0)
            .then(|| (c_msb as i32 * 65536 + c_lsb as i32) as f64 * 0.001),
        doppler: (doppler != i32::MIN).then_some(doppler as f64 * 1e-4),
        cn0: cn0(f.u8(o + 15), sig),
        lock: (lock != u16::MAX).then_some(lock),
        half: info & 4 != 0,
        type2: false,
    };
    let fcn = (8..=11)
        .contains(&(typ & 0x1f))
        .then(|| (info >> 3) as i8 - 8);
    let sat = SatMeas {
        svid: f.u8(o + 2),
        fcn,
        sigs: vec![m],
    };
    (sat, f.u8(o + 19) as usize)
}

/// The Type-2 sub-block at `o`, relative to the master's pseudorange `pr1`.
fn type2(f: &Le, o: usize, pr1: Option<f64>) -> SigMeas {
    let typ = f.u8(o);
    let info = f.u8(o + 5);
    let sig = signal_number(typ, info);
    let msb = f.u8(o + 3);
    let (code_msb, dopp_msb) = (signed(msb, 3), signed(msb >> 3, 5));
    let code_lsb = f.u16(o + 6);
    let (c_msb, c_lsb) = (f.i8(o + 4), f.u16(o + 8));
    let d_lsb = f.u16(o + 10);
    let lock = f.u8(o + 1);
    SigMeas {
        sig,
        antenna: typ >> 5,
        pr: pr1
            .filter(|_| code_msb != -4 || code_lsb != 0)
            .map(|p| p + code_msb as f64 * 65.536 + code_lsb as f64 * 0.001),
        carrier: (c_msb != -128 || c_lsb != 0)
            .then(|| (c_msb as i32 * 65536 + c_lsb as i32) as f64 * 0.001),
        doppler: (dopp_msb != -16 || d_lsb != 0)
            .then_some(dopp_msb as f64 * 6.5536 + d_lsb as f64 * 1e-4),
        cn0: cn0(f.u8(o + 2), sig),
        lock: (lock != u8::MAX).then_some(lock as u16),
        half: info & 4 != 0,
        type2: true,
    }
}

/// Decode a whole MeasEpoch block; `None` when its sub-block lengths are shorter than their
/// fields (Type-1 20 bytes, Type-2 12) or its sub-blocks run past its end.
pub fn decode_meas_epoch(b: &[u8]) -> Option<MeasEpoch> {
    if b.len() < 20 {
        return None;
    }
    let f = Le(b);
    let (n1, sb1, sb2) = (f.u8(14) as usize, f.u8(15) as usize, f.u8(16) as usize);
    if n1 > 0 && sb1 < 20 {
        return None;
    }
    let (tow_ms, wnc) = time_tag(b);
    let mut sats = Vec::with_capacity(n1.min((b.len() - 20) / 20));
    let mut o = 20;
    for _ in 0..n1 {
        if o + sb1 > b.len() {
            return None;
        }
        let (mut sat, n2) = type1(&f, o);
        o += sb1;
        if n2 > 0 && (sb2 < 12 || o + n2 * sb2 > b.len()) {
            return None;
        }
        let pr1 = sat.sigs[0].pr;
        for _ in 0..n2 {
            sat.sigs.push(type2(&f, o, pr1));
            o += sb2;
        }
        sats.push(sat);
    }
    Some(MeasEpoch {
        tow_ms,
        wnc,
        flags: f.u8(17),
        sats,
    })
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

    /// A MeasEpoch with one GPS satellite: L1 C/A in Type-1, L2P in a Type-2, values worked
    /// out by hand from the SBF definitions.
    #[test]
    fn meas_epoch_fields_by_hand() {
        let mut body = vec![0u8; 12];
        body[0..4].copy_from_slice(&345_600_100u32.to_le_bytes());
        body[4..6].copy_from_slice(&2300u16.to_le_bytes());
        body[6] = 1; // N1
        body[7] = 20; // SB1Length
        body[8] = 12; // SB2Length
        let mut t1 = [0u8; 20];
        t1[1] = 0; // GPS L1 C/A, main antenna
        t1[2] = 5; // G05
        t1[3] = 5; // CodeMSB 5
        t1[4..8].copy_from_slice(&1_234_567u32.to_le_bytes());
        t1[8..12].copy_from_slice(&(-12_345_678i32).to_le_bytes());
        t1[12..14].copy_from_slice(&40_000u16.to_le_bytes());
        t1[14] = (-2i8) as u8;
        t1[15] = 160;
        t1[16..18].copy_from_slice(&75u16.to_le_bytes());
        t1[18] = 4; // half-cycle ambiguity
        t1[19] = 1; // N2
        let mut t2 = [0u8; 12];
        t2[0] = 2; // GPS L2P
        t2[1] = 74;
        t2[2] = 100;
        t2[3] = (0b11111 << 3) | 0b001; // Doppler MSB −1 (bits 3–7), code MSB +1 (bits 0–2)
        t2[4] = 1; // CarrierMSB
        t2[6..8].copy_from_slice(&500u16.to_le_bytes());
        t2[8..10].copy_from_slice(&7u16.to_le_bytes());
        t2[10..12].copy_from_slice(&30_000u16.to_le_bytes());
        body.extend_from_slice(&t1);
        body.extend_from_slice(&t2);
        let m = decode_meas_epoch(&block(MEAS_EPOCH, 1, &body)).unwrap();
        assert_eq!((m.tow_ms, m.wnc), (Some(345_600_100), Some(2300)));
        let s = &m.sats[0];
        assert_eq!((s.svid, s.fcn, s.sigs.len()), (5, None, 2));
        let (a, b) = (s.sigs[0], s.sigs[1]);
        // 5 · 4294967.296 + 1234.567 m
        assert!((a.pr.unwrap() - 21_476_071.047).abs() < 1e-6);
        // (−2 · 65536 + 40000) · 0.001 cycles
        assert!((a.carrier.unwrap() - -91.072).abs() < 1e-9);
        assert!((a.doppler.unwrap() - -1234.5678).abs() < 1e-9);
        assert_eq!((a.cn0, a.lock, a.half), (Some(50.0), Some(75), true));
        // + 1 · 65.536 + 0.5 m
        assert!((b.pr.unwrap() - 21_476_137.083).abs() < 1e-6);
        assert!((b.carrier.unwrap() - 65.543).abs() < 1e-9);
        // −1 · 6.5536 + 3.0 Hz
        assert!((b.doppler.unwrap() - -3.5536).abs() < 1e-9);
        // L2P: no +10 dB
        assert_eq!(
            (b.cn0, b.lock, b.half, b.type2),
            (Some(25.0), Some(74), false, true)
        );
        // a Type-2 count that runs past the block is refused
        let mut short = body.clone();
        short[12 + 19] = 2;
        assert!(decode_meas_epoch(&block(MEAS_EPOCH, 1, &short)).is_none());
    }

    #[test]
    fn do_not_use_values_and_glonass_channel() {
        let mut body = vec![0u8; 12];
        body[6] = 1;
        body[7] = 20;
        body[8] = 12;
        let mut t1 = [0u8; 20];
        t1[1] = 8; // GLONASS L1 C/A
        t1[2] = 40; // R03
        t1[8..12].copy_from_slice(&i32::MIN.to_le_bytes());
        t1[14] = 0x80; // CarrierMSB −128 and LSB 0: no phase
        t1[15] = 255;
        t1[16..18].copy_from_slice(&u16::MAX.to_le_bytes());
        t1[18] = 5 << 3; // frequency number −3 (+ 8)
        body.extend_from_slice(&t1);
        let m = decode_meas_epoch(&block(MEAS_EPOCH, 1, &body)).unwrap();
        let s = &m.sats[0];
        assert_eq!(s.fcn, Some(-3));
        let a = s.sigs[0];
        assert_eq!(
            (a.pr, a.carrier, a.doppler, a.cn0, a.lock),
            (None, None, None, None, None)
        );
        // signal numbers ≥ 32 through ObsInfo
        assert_eq!(signal_number(31, 2 << 3), 34);
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
