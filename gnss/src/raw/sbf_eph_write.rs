//! SBF navigation blocks from navigation records (the inverse of [`super::sbf_nav`]), so that
//! `simulate --raw sbf` logs carry their own orbits, and GPSIon/GPSUtc for the Klobuchar
//! parameters.
//!
//! What enters: a [`NavRecord`] laid out as RINEX 3 has it (GPS, Galileo, BeiDou, GLONASS).
//! What leaves: a whole block (GPSNav, GALNav, BDSNav, GLONav) with its CRC, time-tagged with
//! the record's transmission time; `None` for a record no block carries (QZSS, SBAS, NavIC
//! here, RINEX 4 messages). The floats are as the receiver sends them (f4 where SBF has f4:
//! every broadcast field fits one exactly but the semicircle ones divided by π, within 10⁻⁷
//! relative); URA and SISA go back to their indices.

use super::rtcm_eph::BDT_WEEK0;
use super::rtcm_eph_write::{sisa_index, ura_index};
use super::rtcm_msm::WEEK_MS;
use super::sbf::{block, BDS_NAV, GAL_NAV, GLO_NAV, GPS_NAV};
use super::sbf_items::{GPS_ION, GPS_UTC};
use super::sbf_obs::svid;
use crate::rinex::nav::{Klobuchar, NavKind, NavRecord};
use crate::sv::Constellation;
use crate::time::week_tow;
use hifitime::Duration;
use std::f64::consts::PI;

/// A body being written at the offsets of the block (the 8 header bytes not included: offset
/// 8 is the body's first byte).
struct Body(Vec<u8>);

impl Body {
    fn new(len: usize, t_ms: i64) -> Self {
        let mut b = Body(vec![0; len - 8]);
        b.u32(8, t_ms.rem_euclid(WEEK_MS) as u32);
        b.u16(12, t_ms.div_euclid(WEEK_MS) as u16);
        b
    }
    fn put(&mut self, o: usize, v: &[u8]) {
        self.0[o - 8..o - 8 + v.len()].copy_from_slice(v);
    }
    fn u8(&mut self, o: usize, v: u8) {
        self.put(o, &[v]);
    }
    fn u16(&mut self, o: usize, v: u16) {
        self.put(o, &v.to_le_bytes());
    }
    fn u32(&mut self, o: usize, v: u32) {
        self.put(o, &v.to_le_bytes());
    }
    fn f32(&mut self, o: usize, v: f64) {
        self.put(o, &(v as f32).to_le_bytes());
    }
    fn f64(&mut self, o: usize, v: f64) {
        self.put(o, &v.to_le_bytes());
    }
}

/// The GPST ms at which the record was sent: its transmission time in the week of toe, or
/// toe when the record has none that is sane.
fn sent_ms(o: &[f64], week_offset: i64) -> i64 {
    let week = o[18] as i64 + week_offset;
    let ttr = o
        .get(24)
        .copied()
        .filter(|t| t.abs() <= 2.0 * 604_800.0)
        .unwrap_or(o[8]);
    week * WEEK_MS + (ttr * 1000.0).round() as i64
}

/// The Keplerian elements at the GPSNav/BDSNav offsets.
fn kepler_gps_layout(b: &mut Body, o: &[f64]) {
    b.f32(48, o[1]);
    b.f32(52, o[2] / PI);
    b.f64(56, o[3] / PI);
    b.f32(64, o[4]);
    b.f64(68, o[5]);
    b.f32(76, o[6]);
    b.f64(80, o[7]);
    b.u32(88, o[8].round() as u32);
    b.f32(92, o[9]);
    b.f64(96, o[10] / PI);
    b.f32(104, o[11]);
    b.f64(108, o[12] / PI);
    b.f32(116, o[13]);
    b.f64(120, o[14] / PI);
    b.f32(128, o[15] / PI);
    b.f32(132, o[16] / PI);
}

/// The block of one record; `None` when no SBF block carries it.
pub fn nav_block(r: &NavRecord) -> Option<Vec<u8>> {
    let id = svid(r.sv)?;
    match (r.kind, r.sv.sys) {
        (NavKind::Glonass, Constellation::Glonass) if r.orbit.len() >= 12 => Some(glonass(r, id)),
        (NavKind::Kepler, _) if r.orbit.len() < 25 => None,
        (NavKind::Kepler, Constellation::Gps) if r.orbit.len() >= 26 => Some(gps(r, id)),
        (NavKind::Kepler, Constellation::Galileo) => Some(galileo(r, id)),
        (NavKind::Kepler, Constellation::BeiDou) if r.orbit.len() >= 26 => Some(beidou(r, id)),
        _ => None,
    }
}

fn gps(r: &NavRecord, id: u8) -> Vec<u8> {
    let (o, c) = (&r.orbit, r.clock);
    let mut b = Body::new(140, sent_ms(o, 0));
    let (week_toc, toc) = week_tow(r.toc);
    b.u8(14, id);
    b.u16(16, (o[18] as i64).rem_euclid(1024) as u16);
    b.u8(18, o[17] as u8);
    b.u8(19, ura_index(o[20]) as u8);
    b.u8(20, o[21] as u8);
    b.u8(21, o[19] as u8);
    b.u16(22, o[23] as u16);
    b.u8(24, o[0] as u8);
    b.u8(25, o[0] as u8);
    b.u8(26, u8::from(o[25] > 4.0));
    b.f32(28, o[22]);
    b.u32(32, toc.round() as u32);
    b.f32(36, c[2]);
    b.f32(40, c[1]);
    b.f32(44, c[0]);
    kepler_gps_layout(&mut b, o);
    b.u16(136, (week_toc % 1024) as u16);
    b.u16(138, (o[18] as i64).rem_euclid(1024) as u16);
    block(GPS_NAV, 0, &b.0)
}

fn beidou(r: &NavRecord, id: u8) -> Vec<u8> {
    let (o, c) = (&r.orbit, r.clock);
    let mut b = Body::new(140, sent_ms(o, BDT_WEEK0) + 14_000);
    let (week_toc, toc) = week_tow(r.toc - Duration::from_seconds(14.0));
    b.u8(14, id);
    b.u16(16, o[18] as u16);
    b.u8(18, ura_index(o[20]) as u8);
    b.u8(19, o[21] as u8);
    b.u8(20, o[25] as u8);
    b.u8(21, o[0] as u8);
    b.f32(24, o[22]);
    b.f32(28, o[23]);
    b.u32(32, toc.round() as u32);
    b.f32(36, c[2]);
    b.f32(40, c[1]);
    b.f32(44, c[0]);
    kepler_gps_layout(&mut b, o);
    b.u16(136, (week_toc as i64 - BDT_WEEK0).rem_euclid(8192) as u16);
    b.u16(138, (o[18] as i64).rem_euclid(8192) as u16);
    block(BDS_NAV, 0, &b.0)
}

fn galileo(r: &NavRecord, id: u8) -> Vec<u8> {
    let (o, c) = (&r.orbit, r.clock);
    let src = o[17] as u32;
    let inav = src & (1 << 8) == 0 || src & (1 << 9) != 0;
    let mut b = Body::new(152, sent_ms(o, 0));
    let (week_toc, toc) = week_tow(r.toc);
    b.u8(14, id);
    b.u8(15, if inav { 2 } else { 16 });
    b.f64(16, o[7]);
    b.f64(24, o[3] / PI);
    b.f64(32, o[5]);
    b.f64(40, o[12] / PI);
    b.f64(48, o[14] / PI);
    b.f64(56, o[10] / PI);
    b.f32(64, o[15] / PI);
    b.f32(68, o[16] / PI);
    b.f32(72, o[2] / PI);
    for (off, k) in [(76, 4), (80, 6), (84, 13), (88, 1), (92, 9), (96, 11)] {
        b.f32(off, o[k]);
    }
    b.u32(100, o[8].round() as u32);
    b.u32(104, toc.round() as u32);
    b.f32(108, c[2]);
    b.f32(112, c[1]);
    b.f64(116, c[0]);
    b.u16(124, (o[18] as i64).rem_euclid(4096) as u16);
    b.u16(126, (week_toc % 4096) as u16);
    b.u16(128, o[0] as u16);
    let h = o[21] as u32;
    // every signal's bits marked valid: E1-B (RINEX bits 0–2), E5b (6–8), E5a (3–5)
    let ossol = 1 | (h & 7) << 1 | 1 << 4 | (h >> 6 & 7) << 5 | 1 << 8 | (h >> 3 & 7) << 9;
    b.u16(130, ossol as u16);
    let sisa = sisa_index(o[20]) as u8;
    b.u8(133, sisa);
    b.u8(134, sisa);
    b.u8(135, 255);
    b.f32(136, o[22]);
    b.f32(140, o[23]);
    b.f32(144, -2e10);
    block(GAL_NAV, 0, &b.0)
}

fn glonass(r: &NavRecord, id: u8) -> Vec<u8> {
    let (o, c) = (&r.orbit, r.clock);
    let t_ms = (r.toc.to_gpst_seconds() * 1000.0).round() as i64;
    let mut b = Body::new(96, t_ms);
    let (week_toe, toe) = week_tow(r.toc);
    b.u8(14, id);
    b.u8(15, (o[7] + 8.0) as u8);
    b.f64(16, o[0]);
    b.f64(24, o[4]);
    b.f64(32, o[8]);
    for (off, k) in [(40, 1), (44, 5), (48, 9), (52, 2), (56, 6), (60, 10)] {
        b.f32(off, o[k]);
    }
    b.f32(64, c[1]);
    b.f32(68, -c[0]);
    b.u32(76, toe.round() as u32);
    b.u16(80, (week_toe % 1024) as u16);
    b.u8(84, o[11] as u8);
    b.u8(85, (o[3] as u8 & 1) << 2);
    block(GLO_NAV, 0, &b.0)
}

/// GPSIon and GPSUtc blocks carrying the Klobuchar parameters and leap seconds, at GPST `t_ms`.
pub fn iono_blocks(k: &Klobuchar, leap: i32, t_ms: i64) -> Vec<u8> {
    let mut ion = Body::new(48, t_ms);
    ion.u8(14, 1);
    for i in 0..4 {
        ion.f32(16 + 4 * i, k.alpha[i]);
        ion.f32(32 + 4 * i, k.beta[i]);
    }
    let mut utc = Body::new(40, t_ms);
    utc.u8(14, 1);
    utc.u8(33, leap as i8 as u8);
    utc.u8(36, leap as i8 as u8);
    let mut out = block(GPS_ION, 0, &ion.0);
    out.extend(block(GPS_UTC, 0, &utc.0));
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raw::sbf_nav::decode_nav;
    use crate::sv::Sv;
    use hifitime::Epoch;

    /// Every field back within the f4 precision SBF carries (10⁻⁷ relative).
    fn same(a: &NavRecord, b: &NavRecord) {
        assert_eq!((a.sv, a.kind, a.toc), (b.sv, b.kind, b.toc));
        assert_eq!(a.orbit.len(), b.orbit.len());
        for (x, y) in a
            .clock
            .iter()
            .chain(&a.orbit)
            .zip(b.clock.iter().chain(&b.orbit))
        {
            assert!((x - y).abs() <= 1e-7 * y.abs(), "{x} vs {y}");
        }
    }

    #[test]
    fn beidou_and_glonass_blocks_read_back() {
        // BDT week 944 (GPS week 2300), toc = toe = 3600 s BDT
        let toc = Epoch::from_gpst_seconds(2300.0 * 604_800.0 + 3600.0 + 14.0);
        let mut orbit = vec![
            1.0,
            331.890625,
            -4.659e-9,
            0.8665 * PI,
            1.1011e-5,
            9.5e-4,
            -1.409e-5,
            6493.38,
            3600.0,
            -2.6e-8,
            0.134 * PI,
            -2.3e-8,
            0.0135 * PI,
            424.171875,
            0.433 * PI,
            -5.5e-9,
            -2.8e-10,
        ];
        orbit.extend([0.0, 944.0, 0.0, 2.0, 0.0, 2e-10, -9.5e-9, 3000.0, 1.0]);
        let bds = NavRecord {
            sv: crate::sv::Sv::new(Constellation::BeiDou, 45),
            kind: NavKind::Kepler,
            toc,
            clock: [3.94e-4, 2.5e-11, 0.0],
            orbit,
            line: 0,
        };
        let b = nav_block(&bds).unwrap();
        same(&decode_nav(BDS_NAV, &b).unwrap(), &bds);

        // GLONASS slot 3, channel −4, toe 395118 s of GPS week 2300 (frame time in UTC)
        let toe = Epoch::from_gpst_seconds(2300.0 * 604_800.0 + 395_118.0);
        let glo = NavRecord {
            sv: Sv::new(Constellation::Glonass, 3),
            kind: NavKind::Glonass,
            toc: toe,
            clock: [1.259408891201e-4, 9.094947017729e-13, 395_100.0],
            orbit: vec![
                -7741.1689453125,
                -2.988474845886,
                0.0,
                1.0,
                10624.01220703125,
                0.1815881729126,
                1.862645149231e-9,
                -4.0,
                21866.857421875,
                -1.144448280334,
                -2.793967723846e-9,
                3.0,
            ],
            line: 0,
        };
        let b = nav_block(&glo).unwrap();
        same(&decode_nav(GLO_NAV, &b).unwrap(), &glo);
    }
}
