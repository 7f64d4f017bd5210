//! RTCM 3 MSM4/5/6/7 (multiple signal messages) to observation epochs.
//!
//! What enters: MSM payloads of GPS (107x), GLONASS (108x), Galileo (109x), QZSS (111x) and
//! BeiDou (112x) in file order, GLONASS frequency channels (from 1020) and a time hint (GPST
//! milliseconds near the log's start). What leaves: [`RawEpoch`]s as the UBX path makes them
//! (RINEX codes, values, loss-of-lock indicators), one per epoch time, all systems together.
//!
//! Rules (RTCM 10403.3 and a reading of RTKLIB `rtcm3.c`):
//! - time: GPS, Galileo and QZSS carry the time of week in ms, BeiDou in BDT (GPST − 14 s),
//!   GLONASS the time of day in Moscow time (UTC + 3 h); the week (the day for GLONASS) is the
//!   one that puts the epoch nearest the hint, and the hint follows the epochs;
//! - values: rough range (ms, 1/1024 ms) plus fine pseudorange / phase range; the phase in
//!   cycles of the signal's carrier, the Doppler from the phase range rate (MSM5/7 only), C/N0
//!   in dB-Hz; values flagged invalid are left blank;
//! - LLI bit 0 when the lock time indicator fell, or is zero twice running; bit 1 when the
//!   half-cycle ambiguity flag is set;
//! - a GLONASS signal has phase and Doppler only when its frequency channel is known (MSM5/7
//!   extended information or 1020); otherwise they are dropped and counted;
//! - each satellite has the UBX path's slots by band (`ubx_obs::SLOTS`); a signal of another band, or a
//!   second signal of a band already filled (signal ids ascending), is dropped and counted.

use super::bits::{bits_s, bits_u};
use super::slots::SlotTable;
use super::ubx_obs::{RawEpoch, RawSat, RawSignal};
use super::RawStats;
use crate::signal::frequency;
use crate::sv::{Constellation, Sv};
use std::collections::BTreeMap;

/// Metres per millisecond of range (c · 1 ms).
pub const RANGE_MS: f64 = 299_792.458;
/// Milliseconds in a GPS week.
pub const WEEK_MS: i64 = 604_800_000;
const DAY_MS: i64 = 86_400_000;

/// System and MSM type (4..=7) of a message number; `None` for other messages.
pub fn msm_kind(msg: u16) -> Option<(Constellation, u8)> {
    let sys = match msg / 10 {
        107 => Constellation::Gps,
        108 => Constellation::Glonass,
        109 => Constellation::Galileo,
        111 => Constellation::Qzss,
        112 => Constellation::BeiDou,
        _ => return None,
    };
    let k = (msg % 10) as u8;
    (4..=7).contains(&k).then_some((sys, k))
}

/// The MSM message number of a system and type.
pub fn msm_number(sys: Constellation, kind: u8) -> u16 {
    let base = match sys {
        Constellation::Glonass => 1080,
        Constellation::Galileo => 1090,
        Constellation::Qzss => 1110,
        Constellation::BeiDou => 1120,
        _ => 1070,
    };
    base + kind as u16
}

/// RINEX band and attribute of an MSM signal id (1..=32) of a system.
pub fn msm_code(sys: Constellation, id: u8) -> Option<[u8; 2]> {
    use Constellation::*;
    let s: &[u8; 2] = match (sys, id) {
        (Gps | Qzss | Galileo | Glonass, 2) => b"1C",
        (Gps | Glonass, 3) => b"1P",
        (Gps, 4) => b"1W",
        (Gps | Glonass, 8) => b"2C",
        (Gps | Glonass, 9) => b"2P",
        (Gps, 10) => b"2W",
        (Gps | Qzss, 15) => b"2S",
        (Gps | Qzss, 16) => b"2L",
        (Gps | Qzss, 17) => b"2X",
        (Gps | Qzss | Galileo, 22) => b"5I",
        (Gps | Qzss | Galileo, 23) => b"5Q",
        (Gps | Qzss | Galileo | BeiDou, 24) => b"5X",
        (Gps | Qzss, 30) => b"1S",
        (Gps | Qzss, 31) => b"1L",
        (Gps | Qzss | BeiDou, 32) => b"1X",
        (Galileo, 3) => b"1A",
        (Galileo, 4) => b"1B",
        (Galileo, 5) => b"1X",
        (Galileo, 6) => b"1Z",
        (Galileo, 8) => b"6C",
        (Galileo, 9) => b"6A",
        (Galileo, 10) => b"6B",
        (Galileo | Qzss, 11) | (BeiDou, 10) => b"6X",
        (Galileo, 12) => b"6Z",
        (Galileo | BeiDou, 14) => b"7I",
        (Galileo | BeiDou, 15) => b"7Q",
        (Galileo | BeiDou, 16) => b"7X",
        (Galileo, 18) => b"8I",
        (Galileo, 19) => b"8Q",
        (Galileo, 20) => b"8X",
        (Qzss, 9) => b"6S",
        (Qzss, 10) => b"6L",
        (BeiDou, 2) => b"2I",
        (BeiDou, 3) => b"2Q",
        (BeiDou, 4) => b"2X",
        (BeiDou, 8) => b"6I",
        (BeiDou, 9) => b"6Q",
        (BeiDou, 22) => b"5D",
        (BeiDou, 23) => b"5P",
        (BeiDou, 25) => b"7D",
        (BeiDou, 30) => b"1D",
        (BeiDou, 31) => b"1P",
        _ => return None,
    };
    Some(*s)
}

/// The frequency slot (see [`crate::raw::ubx_obs::SLOTS`]) of a band of a system, as the
/// UBX path fills them.
pub fn band_slot(sys: Constellation, band: u8) -> Option<usize> {
    use Constellation::*;
    match (sys, band) {
        (BeiDou, b'2') | (Gps | Qzss | Glonass | Galileo, b'1') => Some(0),
        (Galileo | BeiDou, b'7') | (Gps | Qzss | Glonass, b'2') => Some(1),
        (Gps | Qzss | Galileo | BeiDou, b'5') => Some(2),
        (Galileo | BeiDou, b'6') => Some(3),
        (BeiDou, b'1') => Some(4),
        _ => None,
    }
}

/// Minimum lock time (ms) of a 4-bit MSM4/5 lock time indicator (DF402).
pub fn lock_ms(ind: u32) -> u64 {
    if ind == 0 {
        0
    } else {
        1 << (ind.min(15) + 4)
    }
}

/// Minimum lock time (ms) of a 10-bit MSM6/7 extended lock time indicator (DF407): 1 ms
/// steps up to 63, then blocks of 32 indicators whose step doubles, up to 704.
pub fn lock_ms_ext(ind: u32) -> u64 {
    if ind < 64 {
        return ind as u64;
    }
    // block k (of 32 indicators) starts at 64 + 32·(2^(k+1) − 2) ms and steps by 2^(k+1)
    let ind = ind.min(704) as u64;
    let (k, within) = ((ind - 64) / 32, (ind - 64) % 32);
    let step = 2u64 << k;
    64 + 32 * (step - 2) + within * step
}

/// One cell (satellite × signal) of an MSM, in physical units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MsmCell {
    /// Index of the satellite in [`Msm::sats`].
    pub sat: usize,
    /// Signal id (1..=32).
    pub sig: u8,
    /// Pseudorange, ms of range (`None`: invalid).
    pub pr_ms: Option<f64>,
    /// Phase range, ms of range (`None`: invalid).
    pub cp_ms: Option<f64>,
    /// Phase range rate, m/s (`None`: invalid or not in this MSM type).
    pub rate: Option<f64>,
    /// Minimum lock time, ms.
    pub lock_ms: u64,
    /// Half-cycle ambiguity flag.
    pub half: bool,
    /// C/N0, dB-Hz (0: none).
    pub cno: f64,
}

/// A decoded MSM.
#[derive(Clone, Debug, PartialEq)]
pub struct Msm {
    /// System.
    pub sys: Constellation,
    /// MSM type, 4..=7.
    pub kind: u8,
    /// Epoch time field (30 bits, as the system counts it).
    pub epoch: u32,
    /// Satellite ids (1..=64) in mask order.
    pub sats: Vec<u8>,
    /// Extended satellite information (MSM5/7; 15 otherwise).
    pub ext: Vec<u8>,
    /// Cells in mask order.
    pub cells: Vec<MsmCell>,
}

fn field_bits(kind: u8) -> (usize, usize, usize, usize, bool) {
    // fine pseudorange, fine phase range, lock, C/N0 bits; whether rates are present
    match kind {
        4 => (15, 22, 4, 6, false),
        5 => (15, 22, 4, 6, true),
        6 => (20, 24, 10, 10, false),
        _ => (20, 24, 10, 10, true),
    }
}

/// Satellite data of an MSM from bit `pos` (for its first `ns` ≤ 64 satellites): rough ranges
/// (ms), extended information and rough phase range rates (m/s); `None` where flagged
/// invalid. Returns the bit after them too. Fixed arrays: nothing is allocated per message.
struct SatData {
    rough: [Option<f64>; 64],
    ext: [u8; 64],
    rough_rate: [Option<f64>; 64],
    end: usize,
}

fn sat_data(p: &[u8], mut pos: usize, ns: usize, rates: bool) -> SatData {
    let mut d = SatData {
        rough: [None; 64],
        ext: [15; 64],
        rough_rate: [None; 64],
        end: 0,
    };
    for (s, r) in d.rough[..ns].iter_mut().enumerate() {
        let int = bits_u(p, pos + 8 * s, 8);
        *r = (int != 255).then_some(int as f64);
    }
    pos += 8 * ns;
    if rates {
        for (s, e) in d.ext[..ns].iter_mut().enumerate() {
            *e = bits_u(p, pos + 4 * s, 4) as u8;
        }
        pos += 4 * ns;
    }
    for (s, r) in d.rough[..ns].iter_mut().enumerate() {
        if let Some(v) = r.as_mut() {
            *v += bits_u(p, pos + 10 * s, 10) as f64 / 1024.0;
        }
    }
    pos += 10 * ns;
    if rates {
        for (s, r) in d.rough_rate[..ns].iter_mut().enumerate() {
            let v = bits_s(p, pos + 14 * s, 14);
            *r = (v != -8192).then_some(v as f64);
        }
        pos += 14 * ns;
    }
    d.end = pos;
    d
}

/// Decode an MSM payload; `None` when it is not an MSM or is shorter than its masks announce.
pub fn decode_msm(p: &[u8]) -> Option<Msm> {
    let (sys, kind) = msm_kind(super::rtcm::message_number(p))?;
    let epoch = bits_u(p, 24, 30);
    let sat_mask = (bits_u(p, 73, 32) as u64) << 32 | bits_u(p, 105, 32) as u64;
    let sig_mask = bits_u(p, 137, 32);
    let sats: Vec<u8> = (0..64)
        .filter(|i| sat_mask >> (63 - i) & 1 == 1)
        .map(|i| i as u8 + 1)
        .collect();
    let (mut sigs, mut ng) = ([0u8; 32], 0);
    for i in (0..32).filter(|i| sig_mask >> (31 - i) & 1 == 1) {
        sigs[ng] = i as u8 + 1;
        ng += 1;
    }
    let ns = sats.len();
    if ns * ng > 64 {
        return None;
    }
    // the cell mask: at most 64 bits, read at once
    let cell_mask = if ns * ng > 0 {
        u64::from(bits_u(p, 169, (ns * ng).min(32))) << (ns * ng).saturating_sub(32)
            | if ns * ng > 32 {
                u64::from(bits_u(p, 201, ns * ng - 32))
            } else {
                0
            }
    } else {
        0
    };
    let mut cell_ids = [(0usize, 0u8); 64];
    let mut nc = 0;
    for k in 0..ns * ng {
        if cell_mask >> (ns * ng - 1 - k) & 1 == 1 {
            cell_ids[nc] = (k / ng, sigs[k % ng]);
            nc += 1;
        }
    }
    let pos = 169 + ns * ng;
    let (fpr, fcp, flock, fcno, rates) = field_bits(kind);
    let sat_bits = if rates { 36 } else { 18 };
    let cell_bits = fpr + fcp + flock + 1 + fcno + if rates { 15 } else { 0 };
    if pos + ns * sat_bits + nc * cell_bits > p.len() * 8 {
        return None;
    }
    let SatData {
        rough,
        ext,
        rough_rate,
        end: pos,
    } = sat_data(p, pos, ns, rates);
    let field = |base: usize, n: usize, k: usize, signed: bool| -> i64 {
        if signed {
            bits_s(p, base + n * k, n) as i64
        } else {
            bits_u(p, base + n * k, n) as i64
        }
    };
    let (pr_scale, cp_scale) = if fpr == 15 {
        (2f64.powi(-24), 2f64.powi(-29))
    } else {
        (2f64.powi(-29), 2f64.powi(-31))
    };
    let mut cells = Vec::with_capacity(nc);
    let (p_pr, p_cp) = (pos, pos + nc * fpr);
    let p_lock = p_cp + nc * fcp;
    let p_half = p_lock + nc * flock;
    let p_cno = p_half + nc;
    let p_rate = p_cno + nc * fcno;
    for (k, &(s, g)) in cell_ids[..nc].iter().enumerate() {
        let pr = field(p_pr, fpr, k, true);
        let cp = field(p_cp, fcp, k, true);
        let lock = field(p_lock, flock, k, false) as u32;
        let half = field(p_half, 1, k, false) == 1;
        let cno = field(p_cno, fcno, k, false) as f64;
        let rate = if rates {
            Some(field(p_rate, 15, k, true))
        } else {
            None
        };
        let r = rough[s];
        cells.push(MsmCell {
            sat: s,
            sig: g,
            pr_ms: r
                .filter(|_| pr != -(1 << (fpr - 1)))
                .map(|r| r + pr as f64 * pr_scale),
            cp_ms: r
                .filter(|_| cp != -(1 << (fcp - 1)))
                .map(|r| r + cp as f64 * cp_scale),
            rate: match (rough_rate[s], rate) {
                (Some(rr), Some(f)) if f != -16384 => Some(rr + f as f64 * 1e-4),
                _ => None,
            },
            lock_ms: if flock == 4 {
                lock_ms(lock)
            } else {
                lock_ms_ext(lock)
            },
            half,
            cno: if fcno == 6 { cno } else { cno / 16.0 },
        });
    }
    Some(Msm {
        sys,
        kind,
        epoch,
        ext: ext[..ns].to_vec(),
        sats,
        cells,
    })
}

/// GPS − UTC leap seconds at a GPST time (ms since the GPS epoch), from 2009 on.
pub(crate) fn leap_seconds(t_ms: i64) -> i64 {
    let week = t_ms / WEEK_MS;
    match week {
        w if w >= 1930 => 18,
        w if w >= 1851 => 17,
        w if w >= 1695 => 16,
        _ => 15,
    }
}

/// The GPST (ms since the GPS epoch) of an MSM epoch field, nearest to `hint`.
pub fn msm_time(sys: Constellation, epoch: u32, hint: i64) -> i64 {
    let (v, period) = match sys {
        Constellation::Glonass => {
            let tod = (epoch & 0x7ff_ffff) as i64;
            let v = tod - 10_800_000 + leap_seconds(hint) * 1000;
            (v.rem_euclid(DAY_MS), DAY_MS)
        }
        Constellation::BeiDou => ((epoch as i64 + 14_000).rem_euclid(WEEK_MS), WEEK_MS),
        _ => (epoch as i64, WEEK_MS),
    };
    let base = hint - hint.rem_euclid(period);
    [base - period, base, base + period]
        .into_iter()
        .map(|b| b + v)
        .min_by_key(|t| (t - hint).abs())
        .unwrap_or(base + v)
}

/// Turns MSMs into epochs; keeps lock times, GLONASS channels and the current epoch.
#[derive(Default)]
pub struct MsmDecoder {
    locks: SlotTable<Option<u64>>,
    /// GLONASS frequency channels known (slot → channel).
    pub glonass: BTreeMap<u8, i8>,
    hint: Option<i64>,
    cur: Option<(i64, RawEpoch)>,
}

impl MsmDecoder {
    /// A decoder whose first epochs are placed near `hint` (GPST ms since the GPS epoch).
    pub fn new(hint: Option<i64>) -> Self {
        MsmDecoder {
            hint,
            ..Self::default()
        }
    }

    /// Take one decoded MSM; returns the previous epoch when this one starts a new time.
    /// Without a time hint the message cannot be placed: counted and skipped.
    pub fn push(&mut self, m: &Msm, st: &mut RawStats) -> Option<RawEpoch> {
        let Some(hint) = self.hint else {
            st.drop("MSM before the GPS week was known (no 1019/1042/1045/1046 before it)");
            return None;
        };
        let t = msm_time(m.sys, m.epoch, hint);
        self.hint = Some(t);
        let done = match &self.cur {
            Some((ct, _)) if *ct == t => None,
            _ => self.cur.take().map(|c| c.1).filter(|e| !e.sats.is_empty()),
        };
        let (_, e) = self.cur.get_or_insert_with(|| {
            (
                t,
                RawEpoch {
                    week: (t / WEEK_MS) as u16,
                    tow: (t % WEEK_MS) as f64 * 1e-3,
                    sats: Vec::new(),
                    glonass: Vec::new(),
                },
            )
        });
        for (s, &id) in m.sats.iter().enumerate() {
            if m.sys == Constellation::Glonass && m.ext[s] <= 13 {
                self.glonass.insert(id, m.ext[s] as i8 - 7);
            }
        }
        for c in &m.cells {
            let sv = Sv::new(m.sys, m.sats[c.sat]);
            let Some(code) = msm_code(m.sys, c.sig) else {
                st.drop(&format!(
                    "{} MSM signal id {} (unknown)",
                    m.sys.letter(),
                    c.sig
                ));
                continue;
            };
            let Some(slot) = band_slot(m.sys, code[0]) else {
                st.drop(&format!(
                    "{} {} (no RINEX slot)",
                    m.sys.letter(),
                    String::from_utf8_lossy(&code)
                ));
                continue;
            };
            let k = match e.sats.iter().position(|x| x.sv == sv) {
                Some(k) => k,
                None => {
                    e.sats.push(RawSat {
                        sv,
                        sig: [None; crate::raw::ubx_obs::SLOTS],
                    });
                    e.sats.len() - 1
                }
            };
            if e.sats[k].sig[slot].is_some() {
                st.drop("second signal of a band (the first kept)");
                continue;
            }
            let chan = self.glonass.get(&sv.prn).copied();
            if sv.sys == Constellation::Glonass {
                if let Some(ch) = chan {
                    if !e.glonass.iter().any(|g| g.0 == sv.prn) {
                        e.glonass.push((sv.prn, ch));
                    }
                }
            }
            let f = frequency(m.sys, code[0], chan);
            if f.is_none() && (c.cp_ms.is_some() || c.rate.is_some()) {
                st.drop("GLONASS phase/Doppler without a frequency channel (no 1020, MSM4/6)");
            }
            let prev = self.locks.get_mut(sv, slot).replace(c.lock_ms);
            let slip =
                (c.lock_ms == 0 && prev.unwrap_or(0) == 0) || prev.is_some_and(|p| c.lock_ms < p);
            let lam = f.map(|f| 299_792_458.0 / f);
            let cp = match (c.cp_ms, lam) {
                (Some(v), Some(l)) => v * RANGE_MS / l,
                _ => 0.0,
            };
            e.sats[k].sig[slot] = Some(RawSignal {
                code,
                pr: c.pr_ms.map_or(0.0, |v| v * RANGE_MS),
                cp,
                doppler: match (c.rate, lam) {
                    (Some(r), Some(l)) => -r / l,
                    _ => 0.0,
                },
                cno: c.cno,
                lli: if cp != 0.0 {
                    u8::from(slip) | u8::from(c.half) << 1
                } else {
                    0
                },
            });
        }
        done
    }

    /// The time the log has reached (GPST ms): the last epoch's, or the start hint.
    pub fn time(&self) -> Option<i64> {
        self.hint
    }

    /// Set a GLONASS slot's frequency channel (from 1020).
    pub fn set_glonass_channel(&mut self, slot: u8, channel: i8) {
        self.glonass.insert(slot, channel);
    }

    /// The last epoch, at the end of the log.
    pub fn finish(&mut self) -> Option<RawEpoch> {
        self.cur.take().map(|c| c.1).filter(|e| !e.sats.is_empty())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extended_lock_table() {
        assert_eq!(lock_ms_ext(63), 63);
        assert_eq!(lock_ms_ext(64), 64);
        assert_eq!(lock_ms_ext(96), 128);
        assert_eq!(lock_ms_ext(128), 256);
        assert_eq!(lock_ms_ext(704), 67_108_864);
        assert_eq!(lock_ms_ext(1023), 67_108_864);
        // the closed form equals stepping through the blocks
        for ind in 64..=704u64 {
            let (mut t, mut i, mut step) = (64u64, 64u64, 2u64);
            while i + 32 <= ind {
                t += 32 * step;
                i += 32;
                step *= 2;
            }
            assert_eq!(lock_ms_ext(ind as u32), t + (ind - i) * step, "{ind}");
        }
        assert_eq!(lock_ms(1), 32);
        assert_eq!(lock_ms(15), 524_288);
    }

    #[test]
    fn times_are_placed_near_the_hint() {
        let hint = 2300 * WEEK_MS + 1000;
        // GPS tow late in the previous week
        assert_eq!(
            msm_time(Constellation::Gps, (WEEK_MS - 500) as u32, hint),
            2300 * WEEK_MS - 500
        );
        // BeiDou: BDT + 14 s
        assert_eq!(
            msm_time(Constellation::BeiDou, 0, hint),
            2300 * WEEK_MS + 14_000
        );
        // GLONASS: Moscow 03:00:00 is 00:00:00 UTC, + 18 s
        assert_eq!(
            msm_time(Constellation::Glonass, 10_800_000, hint),
            2300 * WEEK_MS + 18_000
        );
    }
}
