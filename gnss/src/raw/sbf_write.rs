//! Observations as a Septentrio SBF log: the ephemerides (GPSNav, GALNav, BDSNav, GLONav) and
//! GPS ionosphere (GPSIon, GPSUtc) first, then a MeasEpoch per epoch and an ExtEvent per
//! camera event, so that a simulated (or any RINEX) data set can also be given as an SBF log
//! (`simulate --raw sbf`).
//!
//! What enters: an [`ObsFile`], the navigation records and Klobuchar parameters to carry.
//! What leaves: SBF bytes whose reading through [`super::sbf_items`] gives back the same
//! epochs, values, loss-of-lock indicators and flag-5 events, and the count of what SBF
//! cannot carry. Per satellite the signal of the lowest SBF signal number with a pseudorange
//! is the Type-1 master and the others Type-2 sub-blocks relative to it. What SBF cannot
//! carry, counted: a code without an SBF signal number, a phase or Doppler without a
//! pseudorange, a Type-2 pseudorange more than ±262 m from its master's, satellites beyond
//! one block's length. Values are rounded to SBF's resolution (pseudorange 1 mm, carrier
//! 0.001 cycle after the pseudorange's share, Doppler 0.1 mHz, C/N0 0.25 dB-Hz, times 1 ms;
//! events to the f4 sub-millisecond offset). Loss of lock is written as it is read back: a
//! slip restarts the lock time at 0 s, otherwise it counts whole seconds rounded up (so a
//! lock started one epoch ago already reads 1 s and is not taken for a new one); the
//! half-cycle flag is LLI bit 1. Each lock arc's phase is shifted by the whole cycles that
//! bring it near the pseudorange (a constant integer per arc, which ambiguity resolution
//! absorbs) so that it fits the carrier field.

use super::sbf::{block, EXT_EVENT, MAX_BLOCK, MEAS_EPOCH};
use super::sbf_eph_write::{iono_blocks, nav_block};
use super::sbf_obs::{satellite, signal, svid};
use crate::rinex::nav::{Klobuchar, NavRecord};
use crate::rinex::{Event, ObsCode, ObsFile, SatObs};
use crate::signal::frequency;
use crate::sv::{Constellation, Sv};
use hifitime::Epoch;
use std::collections::HashMap;

const C: f64 = 299_792_458.0;

/// The SBF signal number of a system's RINEX code.
fn signal_number(sys: Constellation, code: [u8; 2]) -> Option<u8> {
    (0..64).find(|&s| signal(s) == Some((sys, code)))
}

/// A code and the columns of its code, phase, Doppler and C/N0 (C, L, D, S).
type CodeColumns = ([u8; 2], [Option<usize>; 4]);

/// The codes of a system's types with their columns.
fn code_columns(types: &[ObsCode]) -> Vec<CodeColumns> {
    let mut v: Vec<CodeColumns> = Vec::new();
    for (i, t) in types.iter().enumerate() {
        let Some(k) = b"CLDS".iter().position(|&c| c == t.kind()) else {
            continue;
        };
        let code = [t.band(), t.attribute()];
        let j = match v.iter().position(|c| c.0 == code) {
            Some(j) => j,
            None => {
                v.push((code, [None; 4]));
                v.len() - 1
            }
        };
        v[j].1[k].get_or_insert(i);
    }
    v
}

/// One signal to write, in physical units.
struct Sig {
    sig: u8,
    pr: f64,
    cp: Option<f64>,
    doppler: Option<f64>,
    cn0: Option<f64>,
    lock_s: u32,
    half: bool,
    freq: f64,
}

/// The lock time and phase shift of each signal's arc.
#[derive(Default)]
struct Arcs {
    /// Per satellite and code: the time the lock started and the whole cycles taken off.
    arcs: HashMap<(Sv, [u8; 2]), (Epoch, f64)>,
}

impl Arcs {
    /// The signals of one satellite at `t`; the measurements SBF cannot carry are counted.
    fn signals(
        &mut self,
        s: &SatObs,
        t: Epoch,
        codes: &[CodeColumns],
        fcn: Option<i8>,
        dropped: &mut u64,
    ) -> Vec<Sig> {
        let mut out = Vec::new();
        for (code, cols) in codes {
            let val = |k: usize| cols[k].map(|c| s.get(c)).filter(|o| o.is_present());
            let (c, l, d, n) = (val(0), val(1), val(2), val(3));
            let (Some(sig), Some(freq)) = (
                signal_number(s.sv.sys, *code),
                frequency(s.sv.sys, code[0], fcn),
            ) else {
                *dropped += u64::from(c.is_some() || l.is_some());
                continue;
            };
            let Some(c) = c else {
                *dropped += u64::from(l.is_some() || d.is_some());
                continue;
            };
            let lli = l.map_or(0, |o| o.lli);
            let lam = C / freq;
            let cp = l.map(|o| o.value);
            let shift = cp.map_or(0.0, |v| (v - c.value / lam).round());
            let arc = self.arcs.entry((s.sv, *code)).or_insert((t, shift));
            if lli & 1 != 0 {
                *arc = (t, shift);
            }
            // a lock seen for the first time has been held for a minute
            let held = (t - arc.0).to_seconds() + if lli & 1 != 0 { 0.0 } else { 60.0 };
            out.push(Sig {
                sig,
                pr: c.value,
                cp: cp.map(|v| v - arc.1),
                doppler: d.map(|o| o.value),
                cn0: n.map(|o| o.value),
                lock_s: held.ceil().clamp(0.0, 65534.0) as u32,
                half: lli & 2 != 0,
                freq,
            });
        }
        out.sort_by_key(|g| g.sig);
        out
    }
}

/// The raw C/N0 field of a value in dB-Hz (255: none).
fn cn0_field(cn0: Option<f64>, sig: u8) -> u8 {
    let off = if sig == 1 || sig == 2 { 0.0 } else { 10.0 };
    cn0.map_or(255, |v| ((v - off) / 0.25).round().clamp(0.0, 254.0) as u8)
}

/// The carrier field (MSB, LSB) of the phase minus the pseudorange's share, in 0.001 cycles
/// (`(-128, 0)`: none, or out of the field's reach).
fn carrier_field(cp: Option<f64>, pr: f64, freq: f64) -> (i8, u16) {
    let Some(cp) = cp else { return (-128, 0) };
    let v = ((cp - pr * freq / C) / 0.001).round();
    if !v.is_finite() || v.abs() >= 8_388_608.0 {
        return (-128, 0);
    }
    let v = v as i64;
    ((v >> 16) as i8, (v & 0xffff) as u16)
}

/// The Type-1 sub-block of a satellite's master signal, announcing `n2` Type-2 ones.
fn type1(id: u8, fcn: Option<i8>, g: &Sig, n2: u8) -> [u8; 20] {
    let mut t = [0u8; 20];
    t[1] = g.sig.min(31);
    t[2] = id;
    let mm = (g.pr / 0.001).round() as u64;
    // the carrier field is relative to the pseudorange as the decoder reads it
    let pr = mm as f64 * 0.001;
    t[3] = (mm >> 32) as u8 & 0x0f;
    t[4..8].copy_from_slice(&(mm as u32).to_le_bytes());
    let d = g.doppler.map_or(i32::MIN, |d| (d / 1e-4).round() as i32);
    t[8..12].copy_from_slice(&d.to_le_bytes());
    let (msb, lsb) = carrier_field(g.cp, pr, g.freq);
    t[12..14].copy_from_slice(&lsb.to_le_bytes());
    t[14] = msb as u8;
    t[15] = cn0_field(g.cn0, g.sig);
    t[16..18].copy_from_slice(&(g.lock_s as u16).to_le_bytes());
    let hi = match (g.sig, fcn) {
        (32.., _) => g.sig - 32,
        (8..=11, Some(f)) => (f.clamp(-8, 23) + 8) as u8,
        _ => 0,
    };
    t[18] = hi << 3 | u8::from(g.half) << 2;
    t[19] = n2;
    t
}

/// The Type-2 sub-block of signal `g` relative to the master `m`; `None` when its
/// pseudorange is out of the offset's reach.
fn type2(m: &Sig, g: &Sig) -> Option<[u8; 12]> {
    let mut t = [0u8; 12];
    // the decoder adds the offset to the master's pseudorange as decoded (1 mm steps)
    let pr1 = (m.pr / 0.001).round() * 0.001;
    let off = ((g.pr - pr1) / 0.001).round() as i64;
    if !(-4 * 65536..4 * 65536).contains(&off) {
        return None;
    }
    let pr2 = pr1 + off as f64 * 0.001;
    let (code_msb, code_lsb) = ((off >> 16) as i8, (off & 0xffff) as u16);
    let dopp = match (m.doppler, g.doppler) {
        (Some(d1), Some(d2)) => {
            let d1 = (d1 / 1e-4).round() * 1e-4;
            let v = ((d2 - d1 * g.freq / m.freq) / 1e-4).round() as i64;
            (-16 * 65536..16 * 65536).contains(&v).then_some(v)
        }
        _ => None,
    };
    let (d_msb, d_lsb) = dopp.map_or((-16i8, 0u16), |v| ((v >> 16) as i8, (v & 0xffff) as u16));
    t[0] = g.sig.min(31);
    t[1] = g.lock_s.min(254) as u8;
    t[2] = cn0_field(g.cn0, g.sig);
    t[3] = (code_msb as u8 & 7) | (d_msb as u8 & 0x1f) << 3;
    let (c_msb, c_lsb) = carrier_field(g.cp, pr2, g.freq);
    t[4] = c_msb as u8;
    t[5] = if g.sig >= 32 { (g.sig - 32) << 3 } else { 0 } | u8::from(g.half) << 2;
    t[6..8].copy_from_slice(&code_lsb.to_le_bytes());
    t[8..10].copy_from_slice(&c_lsb.to_le_bytes());
    t[10..12].copy_from_slice(&d_lsb.to_le_bytes());
    Some(t)
}

/// GPST ms of an epoch.
fn t_ms(t: Epoch) -> i64 {
    (t.to_gpst_nanoseconds().unwrap_or(0) as f64 / 1e6).round() as i64
}

/// A MeasEpoch body (revision 1) at GPST `t` of the satellites' sub-blocks.
fn meas_epoch(t: Epoch, n1: u8, subs: &[u8]) -> Vec<u8> {
    let ms = t_ms(t);
    let mut b = Vec::with_capacity(12 + subs.len());
    b.extend_from_slice(&(ms.rem_euclid(604_800_000) as u32).to_le_bytes());
    b.extend_from_slice(&(ms.div_euclid(604_800_000) as u16).to_le_bytes());
    b.extend_from_slice(&[n1, 20, 12, 0, 0, 0]);
    b.extend_from_slice(subs);
    block(MEAS_EPOCH, 1, &b)
}

/// An ExtEvent (falling edge on EventA) at GPST `t`: the ms in TOW, the rest in the offset.
fn ext_event(t: Epoch) -> Vec<u8> {
    let ns = t.to_gpst_nanoseconds().unwrap_or(0);
    let ms = (ns / 1_000_000) as i64;
    let mut b = Vec::with_capacity(22);
    b.extend_from_slice(&(ms.rem_euclid(604_800_000) as u32).to_le_bytes());
    b.extend_from_slice(&(ms.div_euclid(604_800_000) as u16).to_le_bytes());
    b.extend_from_slice(&[1, 1]);
    b.extend_from_slice(&(((ns % 1_000_000) as f64 * 1e-9) as f32).to_le_bytes());
    b.extend_from_slice(&0f64.to_le_bytes());
    b.extend_from_slice(&0u16.to_le_bytes());
    block(EXT_EVENT, 1, &b)
}

/// The observations of `obs` as an SBF log, with the ephemerides `nav` and the GPS
/// ionosphere `iono` (Klobuchar, leap seconds); and how many measurements SBF could not
/// carry.
pub fn sbf_from_obs(
    obs: &ObsFile,
    nav: &[NavRecord],
    iono: Option<(Klobuchar, i32)>,
) -> (Vec<u8>, u64) {
    let mut out = Vec::new();
    for r in nav {
        if let Some(b) = nav_block(r) {
            out.extend(b);
        }
    }
    if let (Some((k, leap)), Some(e)) = (iono, obs.epochs.first()) {
        out.extend(iono_blocks(&k, leap, t_ms(e.time)));
    }
    let codes: HashMap<Constellation, Vec<CodeColumns>> = obs
        .header
        .obs_types
        .iter()
        .map(|(sys, types)| (*sys, code_columns(types)))
        .collect();
    let mut events: Vec<&Event> = obs.exposure_events().collect();
    events.sort_by(|a, b| {
        a.time
            .partial_cmp(&b.time)
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    let (mut arcs, mut dropped, mut next_event) = (Arcs::default(), 0u64, 0);
    for e in &obs.epochs {
        while let Some(ev) = events.get(next_event).filter(|ev| ev.time <= Some(e.time)) {
            out.extend(ext_event(ev.time.unwrap_or(e.time)));
            next_event += 1;
        }
        let (mut n1, mut subs) = (0u8, Vec::new());
        for s in &e.sats {
            let Some(id) = svid(s.sv).filter(|&i| satellite(i) == Some(s.sv)) else {
                dropped += s.obs.iter().filter(|o| o.is_present()).count() as u64;
                continue;
            };
            let fcn = obs.header.glonass_channels.get(&s.sv.prn).copied();
            let fcn = fcn.filter(|_| s.sv.sys == Constellation::Glonass);
            let cols = codes.get(&s.sv.sys).map_or(&[][..], |c| c.as_slice());
            let sigs = arcs.signals(s, e.time, cols, fcn, &mut dropped);
            let Some((m, rest)) = sigs.split_first() else {
                continue;
            };
            let t2: Vec<[u8; 12]> = rest.iter().filter_map(|g| type2(m, g)).collect();
            dropped += (rest.len() - t2.len()) as u64;
            if 20 + subs.len() + 20 + 12 * t2.len() > MAX_BLOCK - 8 || n1 == u8::MAX {
                dropped += sigs.len() as u64;
                continue;
            }
            subs.extend_from_slice(&type1(id, fcn, m, t2.len() as u8));
            t2.iter().for_each(|t| subs.extend_from_slice(t));
            n1 += 1;
        }
        out.extend(meas_epoch(e.time, n1, &subs));
    }
    for ev in events.iter().skip(next_event) {
        if let Some(t) = ev.time {
            out.extend(ext_event(t));
        }
    }
    (out, dropped)
}
