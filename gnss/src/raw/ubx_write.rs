//! Observations as a u-blox UBX log: RXM-RAWX per epoch and TIM-TM2 per camera event, so that
//! a simulated (or any RINEX) data set can also be given as a raw log.
//!
//! What enters: an [`ObsFile`]. What leaves: UBX bytes whose conversion by [`super::convert`]
//! gives back the same epochs, values (Doppler through the f32 of RAWX, C/N0 through its
//! whole dB-Hz), loss-of-lock indicators and flag-5 events, and the count of what UBX cannot
//! carry. Signals become u-blox signal ids by band (GPS L1 C/A, L2 CL, L5 I; Galileo E1 C,
//! E5a I, E5b I; BeiDou B1I, B2I; GLONASS L1OF, L2OF with the header's frequency channel as
//! freqId; QZSS L1 C/A, L2 CL, L5 I), so RINEX attributes become those
//! convbin writes (C2W → C2X, C5Q → C5X …). Loss of lock is written as it is read back: a
//! slip restarts the lock time at 0, otherwise it grows with the time tracked.

use super::ubx::frame;
use crate::rinex::{Event, ObsCode, ObsFile, SatObs};
use crate::sv::{Constellation, Sv};
use crate::time::WEEK_SECONDS;
use hifitime::Epoch;
use std::collections::HashMap;

/// u-blox GNSS id and signal id of a system's band; `None` when UBX has no such signal.
fn ubx_signal(sys: Constellation, band: u8) -> Option<(u8, u8)> {
    use Constellation::*;
    Some(match (sys, band) {
        (Gps, b'1') => (0, 0),
        (Gps, b'2') => (0, 3),
        (Gps, b'5') => (0, 6),
        (Galileo, b'1') => (2, 0),
        (Galileo, b'5') => (2, 3),
        (Galileo, b'7') => (2, 5),
        (BeiDou, b'2') => (3, 0),
        (BeiDou, b'7') => (3, 2),
        (Glonass, b'1') => (6, 0),
        (Glonass, b'2') => (6, 2),
        (Qzss, b'1') => (5, 0),
        (Qzss, b'2') => (5, 4),
        (Qzss, b'5') => (5, 8),
        _ => return None,
    })
}

/// One measurement of a RAWX message.
struct Meas {
    pr: f64,
    cp: f64,
    doppler: f32,
    ids: (u8, u8, u8),
    /// GLONASS frequency channel + 7 (0 for other systems).
    freq_id: u8,
    locktime: u16,
    cno: u8,
    trk: u8,
}

/// A band and the columns of its code, phase, Doppler and C/N0 (C, L, D, S).
type BandColumns = (u8, [Option<usize>; 4]);

/// The bands of a system's types with their columns.
fn band_columns(types: &[ObsCode]) -> Vec<BandColumns> {
    let mut bands: Vec<BandColumns> = Vec::new();
    for (i, t) in types.iter().enumerate() {
        let Some(k) = b"CLDS".iter().position(|&c| c == t.kind()) else {
            continue;
        };
        let j = match bands.iter().position(|b| b.0 == t.band()) {
            Some(j) => j,
            None => {
                bands.push((t.band(), [None; 4]));
                bands.len() - 1
            }
        };
        bands[j].1[k].get_or_insert(i);
    }
    bands
}

/// Writes the epochs of one receiver, keeping each signal's lock time.
struct RawxWriter {
    /// Lock time (ms) and time of the last epoch, per satellite and band.
    locks: HashMap<(Sv, u8), (u32, Epoch)>,
}

impl RawxWriter {
    fn meas(
        &mut self,
        s: &SatObs,
        t: Epoch,
        band: u8,
        cols: &[Option<usize>; 4],
        channel: Option<i8>,
    ) -> Option<Meas> {
        let (gnss, sig) = ubx_signal(s.sv.sys, band)?;
        let freq_id = match (s.sv.sys, channel) {
            (Constellation::Glonass, Some(k)) => (k + 7) as u8,
            (Constellation::Glonass, None) => return None,
            _ => 0,
        };
        let val = |k: usize| cols[k].map(|c| s.get(c)).filter(|o| o.is_present());
        let (c, l, d, n) = (val(0), val(1), val(2), val(3));
        if c.is_none() && l.is_none() {
            return None;
        }
        let lli = l.map_or(0, |o| o.lli);
        let lock = match self.locks.get(&(s.sv, band)) {
            _ if lli & 1 != 0 => 0,
            Some(&(ms, last)) => (ms as f64 + (t - last).to_seconds() * 1e3).round() as u32,
            None => 1000,
        };
        self.locks.insert((s.sv, band), (lock, t));
        let trk = u8::from(c.is_some()) | u8::from(l.is_some()) << 1 | u8::from(lli & 2 == 0) << 2;
        Some(Meas {
            pr: c.map_or(0.0, |o| o.value),
            cp: l.map_or(0.0, |o| o.value),
            doppler: d.map_or(0.0, |o| o.value as f32),
            ids: (gnss, s.sv.prn, sig),
            freq_id,
            locktime: lock.min(64_500) as u16,
            cno: n.map_or(0.0, |o| o.value.round().clamp(0.0, 255.0)) as u8,
            trk,
        })
    }
}

/// GPS week and nanoseconds of week of `t`, from integer nanoseconds (seconds since 1980 as
/// an f64 would lose the 100 ns RINEX keeps).
fn week_ns(t: Epoch) -> (u16, u64) {
    let ns = t.to_gpst_nanoseconds().unwrap_or(0);
    let week = (WEEK_SECONDS * 1e9) as u64;
    ((ns / week) as u16, ns % week)
}

/// An RXM-RAWX payload (version 1) at GPST `t`.
fn rawx_payload(t: Epoch, meas: &[Meas]) -> Vec<u8> {
    let (week, in_week) = week_ns(t);
    let tow = in_week as f64 * 1e-9;
    let mut p = vec![0u8; 16 + 32 * meas.len()];
    p[0..8].copy_from_slice(&tow.to_le_bytes());
    p[8..10].copy_from_slice(&week.to_le_bytes());
    p[10] = 18;
    p[11] = meas.len() as u8;
    p[12] = 1; // leap seconds determined
    p[13] = 1;
    for (m, q) in meas.iter().zip(p[16..].chunks_exact_mut(32)) {
        q[0..8].copy_from_slice(&m.pr.to_le_bytes());
        q[8..16].copy_from_slice(&m.cp.to_le_bytes());
        q[16..20].copy_from_slice(&m.doppler.to_le_bytes());
        (q[20], q[21], q[22]) = m.ids;
        q[23] = m.freq_id;
        q[24..26].copy_from_slice(&m.locktime.to_le_bytes());
        q[26] = m.cno;
        q[28] = 1; // cpStdev: 0.004 cycles
        q[30] = m.trk;
    }
    p
}

/// A TIM-TM2 payload: a falling edge (the one convbin writes as a flag-5 record) at `t`, in
/// GNSS time, valid, with edge count `count`.
fn tm2_payload(t: Epoch, count: u16) -> Vec<u8> {
    let (week, in_week) = week_ns(t);
    let mut p = vec![0u8; 28];
    p[1] = 0x04 | 0x08 | 0x40; // new falling edge, GNSS time base, time valid
    p[2..4].copy_from_slice(&count.to_le_bytes());
    p[6..8].copy_from_slice(&week.to_le_bytes());
    p[16..20].copy_from_slice(&((in_week / 1_000_000) as u32).to_le_bytes());
    p[20..24].copy_from_slice(&((in_week % 1_000_000) as u32).to_le_bytes());
    p
}

/// The observations of `obs` as a UBX log, and how many measurements UBX could not carry
/// (a band without a u-blox signal, a system it does not have here, more than 255 in an
/// epoch).
pub fn ubx_from_obs(obs: &ObsFile) -> (Vec<u8>, u64) {
    let bands: HashMap<Constellation, Vec<BandColumns>> = obs
        .header
        .obs_types
        .iter()
        .map(|(sys, types)| (*sys, band_columns(types)))
        .collect();
    let mut w = RawxWriter {
        locks: HashMap::new(),
    };
    let mut events: Vec<&Event> = obs.exposure_events().collect();
    events.sort_by(|a, b| {
        a.time
            .partial_cmp(&b.time)
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    let (mut out, mut dropped, mut next_event) = (Vec::new(), 0u64, 0);
    for e in &obs.epochs {
        while let Some(ev) = events.get(next_event).filter(|ev| ev.time <= Some(e.time)) {
            let t = ev.time.unwrap_or(e.time);
            out.extend(frame(0x0d, 0x03, &tm2_payload(t, next_event as u16 + 1)));
            next_event += 1;
        }
        let mut meas = Vec::new();
        for s in &e.sats {
            for (band, cols) in bands.get(&s.sv.sys).map_or(&[][..], |b| b.as_slice()) {
                let channel = obs.header.glonass_channel(s.sv);
                match w.meas(s, e.time, *band, cols, channel) {
                    Some(m) if meas.len() < 255 => meas.push(m),
                    Some(_) => dropped += 1,
                    None => dropped += u64::from(ubx_signal(s.sv.sys, *band).is_none()),
                }
            }
        }
        out.extend(frame(0x02, 0x15, &rawx_payload(e.time, &meas)));
    }
    for (k, ev) in events.iter().enumerate().skip(next_event) {
        if let Some(t) = ev.time {
            out.extend(frame(0x0d, 0x03, &tm2_payload(t, k as u16 + 1)));
        }
    }
    (out, dropped)
}
