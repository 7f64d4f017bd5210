//! SBF decoded-navigation blocks to navigation records: GPSNav (5891), GALNav (4002), BDSNav
//! (4081) and GLONav (4004).
//!
//! What enters: a whole block with a valid CRC. What leaves: a [`NavRecord`] laid out as the
//! RINEX 3 navigation reader makes them (so [`crate::orbit::Ephemerides`] and the RINEX
//! writer take it unchanged), or why the block was refused; [`NavBlocks`] hands each
//! distinct ephemeris on once.
//!
//! The receiver has already checked and decoded the broadcast message: the fields are floats
//! in the message's units (angles in semicircles, × π here; GLONASS in km, km/s, km/s²),
//! indices as broadcast (URA, SISA) and times in seconds of week. Weeks: GPS WN, WNt_oc and
//! WNt_oe are modulo 1024, Galileo WNt_oe/WNt_oc GPS weeks modulo 4096 (not GST weeks: checked
//! on a receiver's log) and BeiDou's BDT weeks modulo 8192; each is taken as the full week nearest the block's own WNc (the continuous
//! GPS week of the time the block was sent), which is also the transmission time RINEX asks
//! for. BeiDou times are BDT (GPST − 14 s). Float fields the receiver marks do-not-use
//! (−2·10¹⁰) become 0.

use super::inav::sisa_metres;
use super::lnav::ura_metres;
use super::rtcm_eph::BDT_WEEK0;
use super::rtcm_msm::{leap_seconds, WEEK_MS};
use super::sbf::{time_tag, type_name, Le, BDS_NAV, GAL_NAV, GPS_NAV};
use super::sbf_obs::satellite;
use super::RawStats;
use crate::rinex::nav::{NavKind, NavRecord};
use crate::sv::{Constellation, Sv};
use hifitime::{Duration, Epoch};
use std::collections::HashMap;
use std::f64::consts::PI;

/// Why a navigation block was not turned into a record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NavError {
    /// The block is shorter than its fields.
    Short,
    /// The SVID is not a satellite of the block's system (the SVID given).
    Satellite(u8),
    /// The block's own time is do-not-use, so its weeks cannot be resolved.
    NoTime,
}

/// Minimum block length (sync included) of each navigation block.
fn needed(number: u16) -> usize {
    match number {
        GPS_NAV | BDS_NAV => 140,
        GAL_NAV => 148,
        _ => 96,
    }
}

/// The full week of `wn` (modulo `modulus`) nearest `reference`.
fn nearest_week(wn: u16, modulus: i64, reference: i64) -> i64 {
    let d = (wn as i64 - reference).rem_euclid(modulus);
    reference + if d > modulus / 2 { d - modulus } else { d }
}

fn gpst(week: i64, sow: f64) -> Epoch {
    Epoch::from_gpst_seconds(week as f64 * 604_800.0) + Duration::from_seconds(sow)
}

/// A float field with the do-not-use value (and non-finite values) as 0.
fn dnu(x: f64) -> f64 {
    if x.is_finite() && x != -2e10 {
        x
    } else {
        0.0
    }
}

/// Decode a navigation block (GPSNav, GALNav, BDSNav or GLONav).
pub fn decode_nav(number: u16, b: &[u8]) -> Result<NavRecord, NavError> {
    if b.len() < needed(number) {
        return Err(NavError::Short);
    }
    let (Some(tow), Some(wnc)) = time_tag(b) else {
        return Err(NavError::NoTime);
    };
    let now_ms = wnc as i64 * WEEK_MS + tow as i64;
    let f = Le(b);
    let svid = f.u8(14);
    let sys = match number {
        GPS_NAV => Constellation::Gps,
        GAL_NAV => Constellation::Galileo,
        BDS_NAV => Constellation::BeiDou,
        _ => Constellation::Glonass,
    };
    let sv = satellite(svid)
        .filter(|s| s.sys == sys)
        .ok_or(NavError::Satellite(svid))?;
    Ok(match number {
        GPS_NAV => gps(&f, sv, now_ms),
        GAL_NAV => galileo(&f, sv, now_ms),
        BDS_NAV => beidou(&f, sv, now_ms),
        _ => glonass(&f, sv, now_ms),
    })
}

/// Seconds of `week` at `now_ms` (RINEX's transmission time).
fn transmission(week: i64, now_ms: i64) -> f64 {
    (now_ms - week * WEEK_MS) as f64 * 1e-3
}

/// The Keplerian elements at the GPSNav/BDSNav offsets (the two blocks share them), in RINEX
/// order from the issue of data to IDOT.
fn kepler_gps_layout(f: &Le, iode: f64) -> Vec<f64> {
    let s = |o| f.f32(o) as f64;
    vec![
        iode,
        s(48),
        s(52) * PI,
        f.f64(56) * PI,
        s(64),
        f.f64(68),
        s(76),
        f.f64(80),
        f.u32(88) as f64,
        s(92),
        f.f64(96) * PI,
        s(104),
        f.f64(108) * PI,
        s(116),
        f.f64(120) * PI,
        s(128) * PI,
        s(132) * PI,
    ]
}

fn gps(f: &Le, sv: Sv, now_ms: i64) -> NavRecord {
    let wnc = now_ms.div_euclid(WEEK_MS);
    let mut orbit = kepler_gps_layout(f, f.u8(24) as f64);
    let week_toc = nearest_week(f.u16(136), 1024, wnc);
    let week_toe = nearest_week(f.u16(138), 1024, wnc);
    orbit.extend_from_slice(&[
        f.u8(18) as f64,
        week_toe as f64,
        f.u8(21) as f64,
        ura_metres(f.u8(19) as u32),
        f.u8(20) as f64,
        dnu(f.f32(28) as f64),
        f.u16(22) as f64,
        transmission(week_toe, now_ms),
        if f.u8(26) != 0 { 6.0 } else { 4.0 },
    ]);
    NavRecord {
        sv,
        kind: NavKind::Kepler,
        toc: gpst(week_toc, f.u32(32) as f64),
        clock: [f.f32(44) as f64, f.f32(40) as f64, f.f32(36) as f64],
        orbit,
        line: 0,
    }
}

fn beidou(f: &Le, sv: Sv, now_ms: i64) -> NavRecord {
    // the BDT week of the block's time (BDT = GPST − 14 s)
    let bdt_week = (now_ms - 14_000).div_euclid(WEEK_MS) - BDT_WEEK0;
    let mut orbit = kepler_gps_layout(f, f.u8(21) as f64);
    let week_toc = nearest_week(f.u16(136), 8192, bdt_week);
    let week_toe = nearest_week(f.u16(138), 8192, bdt_week);
    orbit.extend_from_slice(&[
        0.0,
        week_toe as f64,
        0.0,
        ura_metres(f.u8(18) as u32),
        f.u8(19) as f64,
        dnu(f.f32(24) as f64),
        dnu(f.f32(28) as f64),
        transmission(week_toe + BDT_WEEK0, now_ms - 14_000),
        f.u8(20) as f64,
    ]);
    NavRecord {
        sv,
        kind: NavKind::Kepler,
        toc: gpst(week_toc + BDT_WEEK0, f.u32(32) as f64) + Duration::from_seconds(14.0),
        clock: [f.f32(44) as f64, f.f32(40) as f64, f.f32(36) as f64],
        orbit,
        line: 0,
    }
}

fn galileo(f: &Le, sv: Sv, now_ms: i64) -> NavRecord {
    let wnc = now_ms.div_euclid(WEEK_MS);
    let s = |o| f.f32(o) as f64;
    let inav = f.u8(15) != 16;
    let week_toe = nearest_week(f.u16(124), 4096, wnc);
    let week_toc = nearest_week(f.u16(126), 4096, wnc);
    let h = f.u16(130) as u32;
    // Health_OSSOL: per signal a valid bit, then DVS and the 2-bit HS, which RINEX keeps in
    // the same order (E1-B bits 0–2, E5a 3–5, E5b 6–8)
    let mut health = 0;
    for (valid, from, to) in [(0, 1, 0), (8, 9, 3), (4, 5, 6)] {
        if h >> valid & 1 == 1 {
            health |= (h >> from & 7) << to;
        }
    }
    let sisa = f.u8(if inav { 134 } else { 133 });
    let orbit = vec![
        f.u16(128) as f64,
        s(88),
        s(72) * PI,
        f.f64(24) * PI,
        s(76),
        f.f64(32),
        s(80),
        f.f64(16),
        f.u32(100) as f64,
        s(92),
        f.f64(56) * PI,
        s(96),
        f.f64(40) * PI,
        s(84),
        f.f64(48) * PI,
        s(64) * PI,
        s(68) * PI,
        // data sources: I/NAV E1-B and E5b, clock for E5b/E1; F/NAV E5a, clock for E5a/E1
        if inav {
            (1 | 1 << 2 | 1 << 9) as f64
        } else {
            (1 << 1 | 1 << 8) as f64
        },
        week_toe as f64,
        0.0,
        sisa_metres(sisa as u32),
        health as f64,
        dnu(s(136)),
        dnu(s(140)),
        transmission(week_toe, now_ms),
    ];
    NavRecord {
        sv,
        kind: NavKind::Kepler,
        toc: gpst(week_toc, f.u32(104) as f64),
        clock: [f.f64(116), s(112), s(108)],
        orbit,
        line: 0,
    }
}

fn glonass(f: &Le, sv: Sv, now_ms: i64) -> NavRecord {
    let wnc = now_ms.div_euclid(WEEK_MS);
    let s = |o| f.f32(o) as f64;
    let week_toe = nearest_week(f.u16(80), 1024, wnc);
    let toe = gpst(week_toe, f.u32(76) as f64);
    // message frame time: the block's time, in UTC seconds of the week as RINEX has it
    let utc_ms = now_ms - leap_seconds(now_ms) * 1000;
    NavRecord {
        sv,
        kind: NavKind::Glonass,
        toc: toe,
        clock: [-s(68), s(64), utc_ms.rem_euclid(WEEK_MS) as f64 * 1e-3],
        orbit: vec![
            f.f64(16),
            s(40),
            s(52),
            (f.u8(85) >> 2 & 1) as f64,
            f.f64(24),
            s(44),
            s(56),
            f.u8(15) as f64 - 8.0,
            f.f64(32),
            s(48),
            s(60),
            f.u8(84) as f64,
        ],
        line: 0,
    }
}

/// Navigation blocks turned into records, each distinct ephemeris once.
#[derive(Default)]
pub struct NavBlocks {
    /// The fields (after the time tag) of the last block of each block number and SVID.
    last: HashMap<(u16, u8), Vec<u8>>,
}

impl NavBlocks {
    /// Decode one navigation block: the record when it differs from the satellite's last of
    /// that block; refused blocks and repeats counted in `stats`.
    pub fn push(&mut self, number: u16, b: &[u8], stats: &mut RawStats) -> Option<NavRecord> {
        stats.nav.messages += 1;
        let key = (number, b.get(14).copied().unwrap_or(0));
        let fields = b.get(14..).unwrap_or(&[]);
        if self.last.get(&key).is_some_and(|l| l.as_slice() == fields) {
            return None;
        }
        match decode_nav(number, b) {
            Ok(r) => {
                self.last.insert(key, fields.to_vec());
                stats.nav.ephemerides += 1;
                Some(r)
            }
            Err(NavError::Short) => {
                *stats.malformed.entry(type_name(number)).or_default() += 1;
                None
            }
            Err(NavError::Satellite(_)) => {
                *stats
                    .malformed
                    .entry(format!("{} (SVID not of its system)", type_name(number)))
                    .or_default() += 1;
                None
            }
            Err(NavError::NoTime) => {
                stats.nav.before_week_known += 1;
                None
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weeks_nearest_the_block() {
        assert_eq!(nearest_week(2300 % 1024, 1024, 2300), 2300);
        assert_eq!(nearest_week(2299 % 1024, 1024, 2300), 2299);
        assert_eq!(nearest_week(1023, 1024, 2048), 2047);
        assert_eq!(nearest_week(0, 1024, 2047), 2048);
        assert_eq!(nearest_week(1276, 4096, 1276), 1276);
    }
}
