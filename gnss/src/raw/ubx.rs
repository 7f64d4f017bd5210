//! u-blox UBX frames and the two messages `convert` uses: RXM-RAWX (raw measurements) and
//! TIM-TM2 (time marks of camera exposures).
//!
//! What enters: a byte stream ([`FrameReader`]) or one payload ([`decode_rawx`],
//! [`decode_tm2`]). What leaves: frames with valid checksums, decoded messages, and counts of
//! everything skipped in [`RawStats`]. Measurements become RINEX
//! observations (with their loss-of-lock rules) in [`super::ubx_obs`].
//!
//! A frame is `B5 62`, class, id, payload length (u16 LE), payload, and a two-byte Fletcher
//! checksum over class..payload. A frame with a bad checksum is counted and the search for the
//! next sync resumes one byte after its start, so a corrupted length cannot swallow good frames.

use super::frames::{FrameScanner, Framing};
use super::RawStats;
use std::io::Read;

/// First sync byte.
pub const SYNC1: u8 = 0xB5;
/// Second sync byte.
pub const SYNC2: u8 = 0x62;
/// Frames longer than this are taken for a corrupted length (RTKLIB's limit too).
const MAX_PAYLOAD: usize = 16384 - 8;

/// Whether the Fletcher checksum of a whole frame (`B5 62 … CK_A CK_B`) is right.
pub fn checksum_ok(frame: &[u8]) -> bool {
    let n = frame.len();
    if n < 8 {
        return false;
    }
    let (a, b) = fletcher(&frame[2..n - 2]);
    a == frame[n - 2] && b == frame[n - 1]
}

fn fletcher(data: &[u8]) -> (u8, u8) {
    let (mut a, mut b) = (0u8, 0u8);
    for &x in data {
        a = a.wrapping_add(x);
        b = b.wrapping_add(a);
    }
    (a, b)
}

/// A whole UBX frame with its checksum (to build test data and synthetic logs).
pub fn frame(class: u8, id: u8, payload: &[u8]) -> Vec<u8> {
    let mut f = vec![SYNC1, SYNC2, class, id];
    f.extend_from_slice(&(payload.len() as u16).to_le_bytes());
    f.extend_from_slice(payload);
    let (a, b) = fletcher(&f[2..]);
    f.extend_from_slice(&[a, b]);
    f
}

/// The name of a message type (`RXM-RAWX`, or `0x02-0x15`-style when unknown) for reports.
pub fn type_name(class: u8, id: u8) -> String {
    let c = match class {
        0x01 => "NAV",
        0x02 => "RXM",
        0x04 => "INF",
        0x05 => "ACK",
        0x06 => "CFG",
        0x09 => "UPD",
        0x0a => "MON",
        0x0d => "TIM",
        0x13 => "MGA",
        0x21 => "LOG",
        0x27 => "SEC",
        _ => return format!("UBX 0x{class:02x}-0x{id:02x}"),
    };
    let known = match (class, id) {
        (0x02, 0x15) => "RAWX",
        (0x02, 0x13) => "SFRBX",
        (0x02, 0x14) => "MEASX",
        (0x0d, 0x03) => "TM2",
        (0x01, 0x07) => "PVT",
        (0x01, 0x35) => "SAT",
        (0x01, 0x43) => "SIG",
        (0x01, 0x22) => "CLOCK",
        (0x01, 0x14) => "HPPOSLLH",
        (0x01, 0x13) => "HPPOSECEF",
        (0x01, 0x3c) => "RELPOSNED",
        (0x01, 0x20) => "TIMEGPS",
        _ => return format!("{c}-0x{id:02x}"),
    };
    format!("{c}-{known}")
}

/// One frame: class, id and payload.
pub struct Frame<'a> {
    /// Message class.
    pub class: u8,
    /// Message id.
    pub id: u8,
    /// Payload bytes (checksum verified).
    pub payload: &'a [u8],
}

/// UBX framing: `B5 62`, class, id, a u16 LE payload length; Fletcher checksum.
pub struct Ubx;

impl Framing for Ubx {
    const HEADER: usize = 6;
    fn is_sync(b: u8) -> bool {
        b == SYNC1
    }
    fn frame_len(h: &[u8]) -> Option<usize> {
        let len = u16::from_le_bytes([h[4], h[5]]) as usize;
        (h[0] == SYNC1 && h[1] == SYNC2 && len <= MAX_PAYLOAD).then_some(len + 8)
    }
    fn check(frame: &[u8]) -> bool {
        checksum_ok(frame)
    }
}

/// Streams frames out of a reader with a bounded buffer.
pub struct FrameReader<R: Read>(FrameScanner<R, Ubx>);

impl<R: Read> FrameReader<R> {
    /// A reader of the frames in `src`.
    pub fn new(src: R) -> Self {
        FrameReader(FrameScanner::new(src, 1 << 17))
    }

    /// The next frame with a valid checksum, or `None` at the end of the input. Skipped bytes,
    /// checksum failures and a truncated last frame are counted in `stats`.
    pub fn next_frame(&mut self, stats: &mut RawStats) -> std::io::Result<Option<Frame<'_>>> {
        Ok(self.0.next_frame(stats)?.map(|f| Frame {
            class: f[2],
            id: f[3],
            payload: &f[6..f.len() - 2],
        }))
    }
}

/// RXM-RAWX header fields.
#[derive(Clone, Debug, PartialEq)]
pub struct Rawx {
    /// Receiver time of week, seconds.
    pub rcv_tow: f64,
    /// GPS week (0 before the receiver knows it).
    pub week: u16,
    /// GPS − UTC leap seconds as the receiver knows them.
    pub leap_s: i8,
    /// recStat bit 0: leap seconds determined.
    pub leap_valid: bool,
    /// recStat bit 1: the receiver clock was reset (clock jump).
    pub clk_reset: bool,
    /// Message version.
    pub version: u8,
    /// The measurements in message order.
    pub meas: Vec<RawxMeas>,
}

/// One RXM-RAWX measurement.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RawxMeas {
    /// Pseudorange, metres.
    pub pr: f64,
    /// Carrier phase, cycles.
    pub cp: f64,
    /// Doppler, Hz.
    pub doppler: f32,
    /// u-blox GNSS id (0 GPS, 1 SBAS, 2 Galileo, 3 BeiDou, 5 QZSS, 6 GLONASS, 7 NavIC).
    pub gnss_id: u8,
    /// Satellite id within the system.
    pub sv_id: u8,
    /// Signal id within the system.
    pub sig_id: u8,
    /// GLONASS frequency slot + 7.
    pub freq_id: u8,
    /// Carrier-phase lock time, ms (saturates at 64500).
    pub locktime: u16,
    /// C/N0, dB-Hz.
    pub cno: u8,
    /// Pseudorange σ index: 0.01·2ⁿ m.
    pub pr_stdev: u8,
    /// Carrier-phase σ index: n·0.004 cycles.
    pub cp_stdev: u8,
    /// Doppler σ index: 0.002·2ⁿ Hz.
    pub do_stdev: u8,
    /// trkStat: bit 0 prValid, 1 cpValid, 2 halfCyc (valid), 3 subHalfCyc.
    pub trk_stat: u8,
}

impl RawxMeas {
    /// Pseudorange valid.
    pub fn pr_valid(&self) -> bool {
        self.trk_stat & 1 != 0
    }
    /// Carrier phase valid.
    pub fn cp_valid(&self) -> bool {
        self.trk_stat & 2 != 0
    }
    /// Half-cycle ambiguity resolved.
    pub fn half_cyc(&self) -> bool {
        self.trk_stat & 4 != 0
    }
    /// A half cycle was subtracted from the phase.
    pub fn sub_half_cyc(&self) -> bool {
        self.trk_stat & 8 != 0
    }
}

fn f64_at(p: &[u8], o: usize) -> f64 {
    f64::from_le_bytes(p[o..o + 8].try_into().unwrap_or([0; 8]))
}
fn u16_at(p: &[u8], o: usize) -> u16 {
    u16::from_le_bytes([p[o], p[o + 1]])
}
fn u32_at(p: &[u8], o: usize) -> u32 {
    u32::from_le_bytes([p[o], p[o + 1], p[o + 2], p[o + 3]])
}

/// Decode an RXM-RAWX payload; `None` when it is shorter than its measurement count needs.
pub fn decode_rawx(p: &[u8]) -> Option<Rawx> {
    if p.len() < 16 {
        return None;
    }
    let n = p[11] as usize;
    if p.len() < 16 + 32 * n {
        return None;
    }
    let meas = (0..n)
        .map(|i| {
            let m = &p[16 + 32 * i..16 + 32 * (i + 1)];
            RawxMeas {
                pr: f64_at(m, 0),
                cp: f64_at(m, 8),
                doppler: f32::from_le_bytes([m[16], m[17], m[18], m[19]]),
                gnss_id: m[20],
                sv_id: m[21],
                sig_id: m[22],
                freq_id: m[23],
                locktime: u16_at(m, 24),
                cno: m[26],
                pr_stdev: m[27] & 15,
                cp_stdev: m[28] & 15,
                do_stdev: m[29] & 15,
                trk_stat: m[30],
            }
        })
        .collect();
    Some(Rawx {
        rcv_tow: f64_at(p, 0),
        week: u16_at(p, 8),
        leap_s: p[10] as i8,
        leap_valid: p[12] & 1 != 0,
        clk_reset: p[12] & 2 != 0,
        version: p[13],
        meas,
    })
}

/// A TIM-TM2 time-mark message.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tm2 {
    /// Time-mark channel.
    pub channel: u8,
    /// Rising-edge counter.
    pub count: u16,
    /// A new rising edge is reported.
    pub new_rising: bool,
    /// A new falling edge is reported.
    pub new_falling: bool,
    /// Time base: 0 receiver, 1 GNSS, 2 UTC.
    pub time_base: u8,
    /// The time is valid.
    pub time_valid: bool,
    /// Rising edge: week and time of week (s).
    pub rising: (u16, f64),
    /// Falling edge: week and time of week (s).
    pub falling: (u16, f64),
    /// Accuracy estimate, ns.
    pub acc_ns: u32,
}

/// Decode a TIM-TM2 payload (28 bytes); `None` when shorter.
pub fn decode_tm2(p: &[u8]) -> Option<Tm2> {
    if p.len() < 28 {
        return None;
    }
    let tow = |ms: usize, sub: usize| u32_at(p, ms) as f64 * 1e-3 + u32_at(p, sub) as f64 * 1e-9;
    let flags = p[1];
    Some(Tm2 {
        channel: p[0],
        count: u16_at(p, 2),
        new_falling: flags & 4 != 0,
        time_base: (flags >> 3) & 3,
        time_valid: flags & 0x40 != 0,
        new_rising: flags & 0x80 != 0,
        rising: (u16_at(p, 4), tow(8, 12)),
        falling: (u16_at(p, 6), tow(16, 20)),
        acc_ns: u32_at(p, 24),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_survive_noise_bad_checksums_and_truncation() {
        let good = frame(0x02, 0x15, &[0; 16]);
        let mut bad = frame(0x0d, 0x03, &[7; 28]);
        bad[10] ^= 1;
        let mut log = b"xx".to_vec();
        log.extend_from_slice(&bad);
        log.extend_from_slice(&good);
        log.extend_from_slice(&good[..10]);
        let mut st = RawStats::default();
        let mut r = FrameReader::new(&log[..]);
        let f = r.next_frame(&mut st).unwrap().unwrap();
        assert_eq!((f.class, f.id, f.payload.len()), (0x02, 0x15, 16));
        assert!(r.next_frame(&mut st).unwrap().is_none());
        assert_eq!(st.frames, 1);
        assert_eq!(st.checksum_failures, 1);
        assert_eq!(st.truncated_frames, 1);
        assert_eq!(st.bytes, log.len() as u64);
        assert_eq!(st.skipped_bytes, 2 + bad.len() as u64 + 10);
    }

    #[test]
    fn tm2_fields() {
        let mut p = [0u8; 28];
        p[1] = 0x80 | 0x40 | 0x08 | 0x04;
        p[2..4].copy_from_slice(&7u16.to_le_bytes());
        p[6..8].copy_from_slice(&2380u16.to_le_bytes());
        p[16..20].copy_from_slice(&345_600_123u32.to_le_bytes());
        p[20..24].copy_from_slice(&456_789u32.to_le_bytes());
        let t = decode_tm2(&p).unwrap();
        assert_eq!(t.count, 7);
        assert!(t.new_falling && t.new_rising && t.time_valid);
        assert_eq!(t.time_base, 1);
        assert_eq!(t.falling.0, 2380);
        assert!((t.falling.1 - 345_600.123_456_789).abs() < 1e-9);
        assert!(decode_tm2(&p[..27]).is_none());
    }
}
