//! An RTCM 3 encoder for MSM4 and MSM7 and the few other messages the decoder uses, to build
//! test data and synthetic logs (the inverse of [`super::rtcm_msm`] and
//! [`super::log_items`]).
//!
//! What enters: per satellite its signals in physical units (pseudorange m, phase cycles,
//! Doppler Hz, C/N0 dB-Hz, lock time ms, half-cycle flag). What leaves: whole frames with
//! their CRC. Values are rounded to the message's resolution; a value outside what the
//! message can carry (a phase range more than ±1171 m (MSM7) from the rough range) is sent as
//! invalid.

use super::bits::Writer;
use super::rtcm::frame;
use super::rtcm_msm::{lock_ms, lock_ms_ext, msm_code, msm_number, RANGE_MS};
use crate::rinex::nav::NavRecord;
use crate::rinex::ObsFile;
use crate::signal::frequency;
use crate::sv::{Constellation, Sv};
use std::collections::HashMap;

/// One signal to encode.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MsmSignal {
    /// MSM signal id (1..=32).
    pub id: u8,
    /// Pseudorange, m.
    pub pr: f64,
    /// Carrier phase, cycles (`NAN`: none).
    pub cp: f64,
    /// Doppler, Hz (`NAN`: none).
    pub doppler: f64,
    /// C/N0, dB-Hz.
    pub cno: f64,
    /// Lock time, ms.
    pub lock_ms: u64,
    /// Half-cycle ambiguity flag.
    pub half: bool,
}

/// One satellite to encode.
#[derive(Clone, Debug, PartialEq)]
pub struct MsmSat {
    /// Satellite id (1..=64: PRN, GLONASS slot, QZSS PRN − 192).
    pub id: u8,
    /// GLONASS frequency channel (sent in MSM7's extended information).
    pub glo_channel: Option<i8>,
    /// Its signals.
    pub sigs: Vec<MsmSignal>,
}

/// The largest indicator whose minimum lock time is at most `ms`.
fn lock_indicator(ms: u64, ext: bool) -> i64 {
    let (max, f): (u32, fn(u32) -> u64) = if ext {
        (704, lock_ms_ext)
    } else {
        (15, lock_ms)
    };
    (0..=max).rev().find(|&i| f(i) <= ms).unwrap_or(0) as i64
}

/// A signed field of `n` bits of `v / scale` rounded, or the invalid value when it does not fit.
fn fine(v: f64, scale: f64, n: usize) -> i64 {
    let x = (v / scale).round();
    let lim = (1i64 << (n - 1)) as f64;
    if x.is_finite() && x > -lim && x < lim {
        x as i64
    } else {
        -(1i64 << (n - 1))
    }
}

/// An MSM4 (`kind` 4) or MSM7 (`kind` 7) frame of one system; `epoch` is the 30-bit time
/// field as the system counts it, `more` the multiple-message bit.
pub fn msm(sys: Constellation, kind: u8, epoch: u32, more: bool, sats: &[MsmSat]) -> Vec<u8> {
    let seven = kind == 7;
    let mut sigs: Vec<u8> = sats
        .iter()
        .flat_map(|s| s.sigs.iter().map(|g| g.id))
        .collect();
    sigs.sort_unstable();
    sigs.dedup();
    let mut sats: Vec<&MsmSat> = sats.iter().collect();
    sats.sort_by_key(|s| s.id);
    let mut w = Writer {
        buf: Vec::new(),
        pos: 0,
    };
    w.put(12, msm_number(sys, kind) as i64);
    w.put(12, 0);
    w.put(30, epoch as i64);
    w.put(1, more as i64);
    w.put(3 + 7 + 2 + 2 + 1 + 3, 0);
    let mut mask = 0u64;
    for s in &sats {
        mask |= 1 << (64 - s.id as u64);
    }
    w.put(64, mask as i64);
    let mut smask = 0i64;
    for &g in &sigs {
        smask |= 1 << (32 - g as i64);
    }
    w.put(32, smask);
    let mut cells = Vec::new();
    for s in &sats {
        for &g in &sigs {
            let c = s.sigs.iter().find(|x| x.id == g);
            w.put(1, c.is_some() as i64);
            if let Some(c) = c {
                cells.push((*s, *c));
            }
        }
    }
    let rough: Vec<f64> = sats
        .iter()
        .map(|s| (s.sigs.first().map_or(0.0, |g| g.pr) / RANGE_MS * 1024.0).round() / 1024.0)
        .collect();
    let rate: Vec<f64> = sats
        .iter()
        .map(|s| {
            s.sigs
                .first()
                .map_or(0.0, |g| -g.doppler * lambda(sys, g.id, s.glo_channel))
                .round()
        })
        .collect();
    for r in &rough {
        w.put(8, r.floor() as i64);
    }
    if seven {
        for s in &sats {
            w.put(4, s.glo_channel.map_or(15, |c| c as i64 + 7));
        }
    }
    for r in &rough {
        w.put(10, ((r - r.floor()) * 1024.0).round() as i64);
    }
    if seven {
        for r in &rate {
            w.put(14, if r.is_finite() { *r as i64 } else { -8192 });
        }
    }
    let (fpr, fcp, flock, fcno) = if seven {
        (20, 24, 10, 10)
    } else {
        (15, 22, 4, 6)
    };
    let (sp, sc) = if seven {
        (2f64.powi(-29), 2f64.powi(-31))
    } else {
        (2f64.powi(-24), 2f64.powi(-29))
    };
    let idx = |s: &MsmSat| sats.iter().position(|x| x.id == s.id).unwrap_or(0);
    for (s, g) in &cells {
        w.put(fpr, fine(g.pr / RANGE_MS - rough[idx(s)], sp, fpr));
    }
    for (s, g) in &cells {
        let l = lambda(sys, g.id, s.glo_channel);
        w.put(fcp, fine(g.cp * l / RANGE_MS - rough[idx(s)], sc, fcp));
    }
    for (_, g) in &cells {
        w.put(flock, lock_indicator(g.lock_ms, seven));
    }
    for (_, g) in &cells {
        w.put(1, g.half as i64);
    }
    for (_, g) in &cells {
        w.put(
            fcno,
            (g.cno * if seven { 16.0 } else { 1.0 }).round() as i64,
        );
    }
    if seven {
        for (s, g) in &cells {
            let rr = -g.doppler * lambda(sys, g.id, s.glo_channel);
            w.put(15, fine(rr - rate[idx(s)], 1e-4, 15));
        }
    }
    frame(&w.buf)
}

/// Carrier wavelength (m) of a signal (`NAN` when unknown).
fn lambda(sys: Constellation, id: u8, chan: Option<i8>) -> f64 {
    msm_code(sys, id)
        .and_then(|c| frequency(sys, c[0], chan))
        .map_or(f64::NAN, |f| 299_792_458.0 / f)
}

/// A GPS ephemeris frame (1019) carrying only the week (modulo 1024) and time of clock, the
/// fields the decoder takes the log's week from; the orbit fields are zero.
pub fn week_1019(week: u16, toc_s: u32) -> Vec<u8> {
    let mut w = Writer {
        buf: vec![0; 61],
        pos: 0,
    };
    w.put(12, 1019);
    w.put(6, 1);
    w.put(10, (week % 1024) as i64);
    w.pos = 56;
    w.put(16, (toc_s / 16) as i64);
    frame(&w.buf)
}

/// A Galileo I/NAV ephemeris frame (1046) of satellite `prn` carrying only the GST week
/// (GPS week − 1024, 12 bits) and time of clock, the fields the decoder dates a log by; the
/// orbit fields are zero.
pub fn week_1046(prn: u8, gps_week: u16, toc_s: u32) -> Vec<u8> {
    let mut w = Writer {
        buf: vec![0; 63],
        pos: 0,
    };
    w.put(12, 1046);
    w.put(6, prn as i64);
    w.put(12, (gps_week.saturating_sub(1024) % 4096) as i64);
    w.pos = 62;
    w.put(14, (toc_s / 60) as i64);
    frame(&w.buf)
}

/// A BeiDou ephemeris frame (1042) of satellite `prn` carrying only the BDT week (GPS week
/// − 1356, 13 bits) and time of clock (GPST seconds of week, BDT = GPST − 14 s), the fields
/// the decoder dates a log by; the orbit fields are zero.
pub fn week_1042(prn: u8, gps_week: u16, toc_s: u32) -> Vec<u8> {
    let mut w = Writer {
        buf: vec![0; 64],
        pos: 0,
    };
    w.put(12, 1042);
    w.put(6, prn as i64);
    w.put(13, (gps_week.saturating_sub(1356) % 8192) as i64);
    w.pos = 54;
    w.put(17, (toc_s.saturating_sub(14) / 8) as i64);
    frame(&w.buf)
}

/// A GLONASS ephemeris frame (1020) carrying only the slot and frequency channel.
pub fn channel_1020(slot: u8, channel: i8) -> Vec<u8> {
    let mut w = Writer {
        buf: vec![0; 45],
        pos: 0,
    };
    w.put(12, 1020);
    w.put(6, slot as i64);
    w.put(5, (channel + 7) as i64);
    frame(&w.buf)
}

/// A station position frame (1005), ECEF metres.
pub fn station_1005(x: [f64; 3]) -> Vec<u8> {
    let mut w = Writer {
        buf: Vec::new(),
        pos: 0,
    };
    w.put(12, 1005);
    w.put(12, 0);
    w.put(6 + 4, 0b11);
    let c = |v: f64| (v * 1e4).round() as i64;
    w.put(38, c(x[0]));
    w.put(2, 0);
    w.put(38, c(x[1]));
    w.put(2, 0);
    w.put(38, c(x[2]));
    frame(&w.buf)
}

/// A receiver and antenna descriptor frame (1033) of station 0: antenna descriptor (IGS name
/// and radome), antenna serial, receiver type, firmware and serial, each cut to 31
/// characters.
pub fn descriptor_1033(
    antenna: &str,
    antenna_serial: &str,
    receiver: &str,
    firmware: &str,
    receiver_serial: &str,
) -> Vec<u8> {
    fn put(p: &mut Vec<u8>, s: &str) {
        let b = &s.as_bytes()[..s.len().min(31)];
        p.push(b.len() as u8);
        p.extend_from_slice(b);
    }
    let mut p = vec![(1033u16 >> 4) as u8, ((1033u16 & 0xf) << 4) as u8, 0];
    put(&mut p, antenna);
    p.push(0); // antenna setup id
    for s in [antenna_serial, receiver, firmware, receiver_serial] {
        put(&mut p, s);
    }
    frame(&p)
}

/// A station position frame with antenna height (1006): the ARP, ECEF metres, and its height
/// above the marker, metres.
pub fn station_1006(arp: [f64; 3], height: f64) -> Vec<u8> {
    let mut f = station_1005(arp);
    let mut p = f[3..f.len() - 3].to_vec();
    super::bits::set_bits(&mut p, 0, 12, 1006);
    p.extend_from_slice(&((height * 1e4).round() as u16).to_be_bytes());
    f = frame(&p);
    f
}

/// The 30-bit MSM epoch field of GPST `t_ms` (ms since the GPS epoch) for a system.
pub fn epoch_field(sys: Constellation, t_ms: i64) -> u32 {
    use super::rtcm_msm::{leap_seconds, WEEK_MS};
    (match sys {
        Constellation::Glonass => {
            let utc = t_ms - leap_seconds(t_ms) * 1000;
            (utc + 10_800_000).rem_euclid(86_400_000)
        }
        Constellation::BeiDou => (t_ms - 14_000).rem_euclid(WEEK_MS),
        _ => t_ms.rem_euclid(WEEK_MS),
    }) as u32
}

/// The observations of `obs` as an RTCM 3 log: 1005 (the header's approximate position), the
/// ephemerides `nav` (1019, 1020, 1042, 1044, 1045/1046; a week-only 1019 when there are
/// none), 1020 channel messages for GLONASS slots without an ephemeris, then one MSM7 per
/// system and epoch; and how many
/// measurements RTCM could not carry (a code without an MSM signal id, no pseudorange).
/// Lock times grow with the epochs and restart at an LLI slip; the half-cycle flag is LLI bit 1.
/// Each lock arc's phase is shifted by the whole cycles that bring it near the pseudorange
/// (a constant integer per arc, which ambiguity resolution absorbs).
pub fn rtcm_from_obs(obs: &ObsFile, nav: &[NavRecord]) -> (Vec<u8>, u64) {
    let mut out = header_frames(obs, nav);
    let mut arcs = LockArcs::default();
    let mut last_t: Option<i64> = None;
    let systems = [
        Constellation::Gps,
        Constellation::Glonass,
        Constellation::Galileo,
        Constellation::Qzss,
        Constellation::BeiDou,
    ];
    for e in &obs.epochs {
        let t = epoch_ms(e);
        let dt = last_t.map_or(0, |l| (t - l).max(0) as u64);
        last_t = Some(t);
        let present: Vec<Constellation> = systems
            .into_iter()
            .filter(|s| e.sats.iter().any(|x| x.sv.sys == *s))
            .collect();
        for (n, &sys) in present.iter().enumerate() {
            let types = obs
                .header
                .obs_types
                .get(&sys)
                .map_or(&[][..], |v| v.as_slice());
            let mut sats = Vec::new();
            for s in e.sats.iter().filter(|s| s.sv.sys == sys) {
                let ch = obs.header.glonass_channels.get(&s.sv.prn).copied();
                let sigs = arcs.signals(sys, types, dt, s, ch);
                if !sigs.is_empty() {
                    sats.push(MsmSat {
                        id: s.sv.prn,
                        glo_channel: ch,
                        sigs,
                    });
                }
            }
            let last = n + 1 == present.len();
            out.extend(msm_frames(sys, epoch_field(sys, t), last, &sats));
        }
    }
    (out, arcs.dropped)
}

/// The GPST time tag of an epoch, ms since the GPS epoch.
fn epoch_ms(e: &crate::rinex::ObsEpoch) -> i64 {
    (e.time.to_gpst_nanoseconds().unwrap_or(0) / 1_000_000) as i64
}

/// The frames of [`rtcm_from_obs`] before the observations: 1006 (the header's approximate
/// position), the ephemerides `nav` (a week-only 1019 when there are none), and 1020 channel
/// messages for GLONASS slots without an ephemeris.
fn header_frames(obs: &ObsFile, nav: &[NavRecord]) -> Vec<u8> {
    let mut out = Vec::new();
    if let Some(p) = obs.header.approx_position {
        // the ARP above the marker (RTCM carries no horizontal antenna offset)
        let h = obs.header.antenna_delta.up;
        let arp = crate::frame::Enu(nalgebra::Vector3::new(0.0, 0.0, h)).to_ecef(&p);
        out.extend(station_1006([arp.0.x, arp.0.y, arp.0.z], h));
    }
    let mut with_eph = std::collections::BTreeSet::new();
    for r in nav {
        if let Some(f) = super::rtcm_eph_write::ephemeris_frame(r) {
            out.extend(f);
            with_eph.insert(r.sv);
        }
    }
    if let Some(e) = obs.epochs.first().filter(|_| with_eph.is_empty()) {
        let t = epoch_ms(e);
        let week = (t / super::rtcm_msm::WEEK_MS) as u16;
        let tow = (t % super::rtcm_msm::WEEK_MS / 1000) as u32;
        out.extend(week_1019(week, tow / 16 * 16));
    }
    for (&slot, &ch) in &obs.header.glonass_channels {
        if !with_eph.contains(&Sv::new(Constellation::Glonass, slot)) {
            out.extend(channel_1020(slot, ch));
        }
    }
    out
}

/// The lock arcs of [`rtcm_from_obs`] across the epochs: each signal's lock time and the whole
/// cycles taken off its phase, and the count of measurements RTCM could not carry.
#[derive(Default)]
struct LockArcs {
    /// Lock time (ms) and phase shift (cycles) by satellite and signal code.
    locks: HashMap<(Sv, [u8; 2]), (u64, f64)>,
    /// Measurements dropped so far.
    dropped: u64,
}

impl LockArcs {
    /// The MSM signals of satellite `s` of system `sys` (observation types `types`, GLONASS
    /// channel `ch`), one per signal code with a pseudorange and an MSM signal id, in code
    /// order; its lock arcs grown by `dt` ms since the previous epoch, or restarted.
    fn signals(
        &mut self,
        sys: Constellation,
        types: &[crate::rinex::ObsCode],
        dt: u64,
        s: &crate::rinex::SatObs,
        ch: Option<i8>,
    ) -> Vec<MsmSignal> {
        let mut sigs = Vec::new();
        let mut codes: Vec<[u8; 2]> = types.iter().map(|t| [t.band(), t.attribute()]).collect();
        codes.sort_unstable();
        codes.dedup();
        for code in codes {
            let col = |k: u8| {
                types
                    .iter()
                    .position(|t| t.0 == [k, code[0], code[1]])
                    .and_then(|i| s.obs.get(i))
                    .map_or((f64::NAN, 0), |o| (o.value, o.lli))
            };
            let (pr, _) = col(b'C');
            let (cp, lli) = col(b'L');
            if pr.is_nan() {
                self.dropped += u64::from(!cp.is_nan());
                continue;
            }
            let Some(id) = (1..=32).find(|&i| super::rtcm_msm::msm_code(sys, i) == Some(code))
            else {
                self.dropped += 1;
                continue;
            };
            // whole cycles taken off the phase (per lock arc, as encoders do) so that
            // it stays within the message's reach of the pseudorange
            let shift = (cp - pr / lambda(sys, id, ch)).round();
            let (lock, off) = self.locks.entry((s.sv, code)).or_insert((600_000, shift));
            if lli & 1 != 0 || !off.is_finite() {
                (*lock, *off) = (if lli & 1 != 0 { 0 } else { *lock }, shift);
            } else {
                *lock += dt;
            }
            let cp = if off.is_finite() { cp - *off } else { cp };
            sigs.push(MsmSignal {
                id,
                pr,
                cp,
                doppler: col(b'D').0,
                cno: col(b'S').0,
                lock_ms: *lock,
                half: lli & 2 != 0,
            });
        }
        sigs
    }
}

/// The MSM7 frames of one system's satellites `sats` at one epoch (`epoch` the MSM time
/// field), at most 64 cells (satellites × signals) each; the multiple-message bit is set on
/// all but the last frame of the last system (`last`) of the epoch.
fn msm_frames(sys: Constellation, epoch: u32, last: bool, sats: &[MsmSat]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut ids: Vec<u8> = sats
        .iter()
        .flat_map(|s: &MsmSat| s.sigs.iter().map(|g| g.id))
        .collect();
    ids.sort_unstable();
    ids.dedup();
    // at most 64 cells (satellites × signals) per message
    let per = (64 / ids.len().max(1)).max(1);
    let chunks: Vec<&[MsmSat]> = sats.chunks(per).collect();
    for (k, c) in chunks.iter().enumerate() {
        let more = !last || k + 1 < chunks.len();
        out.extend(msm(sys, 7, epoch, more, c));
    }
    out
}
