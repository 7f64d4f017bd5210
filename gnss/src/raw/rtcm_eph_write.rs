//! RTCM 3 ephemeris messages from navigation records (the inverse of
//! [`super::rtcm_eph`]), to build test data and to let `simulate --raw rtcm3` logs carry their
//! own orbits.
//!
//! What enters: a [`NavRecord`] laid out as RINEX 3 has it (GPS, QZSS, Galileo, BeiDou,
//! GLONASS). What leaves: a whole frame (1019, 1044, 1045 or 1046, 1042, 1020) with its CRC,
//! each value rounded to the field's resolution (a record already on the broadcast grid goes
//! through unchanged); `None` for a record no message carries (SBAS, RINEX 4 messages).

use super::bits::Writer;
use super::inav::sisa_metres;
use super::lnav::ura_metres;
use super::rtcm::frame;
use super::rtcm_msm::leap_seconds;
use crate::rinex::nav::{NavKind, NavRecord};
use crate::sv::Constellation;
use crate::time::week_tow;
use hifitime::Duration;
use std::f64::consts::PI;

/// `x / 2^e` rounded: the integer a field of scale 2^e carries.
fn q(x: f64, e: i32) -> i64 {
    (x * 2f64.powi(-e)).round() as i64
}

/// An angle (radians) in semicircles of scale 2^e.
fn qa(x: f64, e: i32) -> i64 {
    q(x / PI, e)
}

/// A sign-magnitude field of `n` bits (GLONASS).
fn put_sm(w: &mut Writer, n: usize, v: i64) {
    let mag = v.unsigned_abs().min((1 << (n - 1)) - 1) as i64;
    w.put(1, (v < 0) as i64);
    w.put(n - 1, mag);
}

/// The URA index (0–15) whose nominal value is the first at least `m` metres.
pub(crate) fn ura_index(m: f64) -> i64 {
    (0..15).find(|&n| ura_metres(n) >= m).unwrap_or(15) as i64
}

/// The SISA index nearest `m` metres (255: no accuracy prediction).
pub(crate) fn sisa_index(m: f64) -> i64 {
    if m < 0.0 {
        return 255;
    }
    (0..=125u32)
        .min_by(|&a, &b| {
            (sisa_metres(a) - m)
                .abs()
                .total_cmp(&(sisa_metres(b) - m).abs())
        })
        .unwrap_or(255) as i64
}

/// The frame of one record; `None` when no RTCM message carries it (or it is incomplete).
pub fn ephemeris_frame(r: &NavRecord) -> Option<Vec<u8>> {
    let o = &r.orbit;
    let payload = match (r.kind, r.sv.sys) {
        (NavKind::Glonass, Constellation::Glonass) if o.len() >= 12 => glonass_1020(r),
        (NavKind::Kepler, _) if o.len() < 24 => return None,
        (NavKind::Kepler, Constellation::Gps) => gps_1019(r),
        (NavKind::Kepler, Constellation::Qzss) => qzss_1044(r),
        (NavKind::Kepler, Constellation::BeiDou) => beidou_1042(r),
        (NavKind::Kepler, Constellation::Galileo) => galileo(r),
        _ => return None,
    };
    Some(frame(&payload))
}

/// crs … Ω̇ in message order: harmonic bits, radius and angle-harmonic scale exponents, toe
/// bits and seconds per toe step.
fn kepler_body(w: &mut Writer, o: &[f64], hb: usize, rs: i32, hs: i32, toe: (usize, f64)) {
    w.put(hb, q(o[1], rs));
    w.put(16, qa(o[2], -43));
    w.put(32, qa(o[3], -31));
    w.put(hb, q(o[4], hs));
    w.put(32, q(o[5], -33));
    w.put(hb, q(o[6], hs));
    w.put(32, q(o[7], -19));
    w.put(toe.0, (o[8] / toe.1).round() as i64);
    w.put(hb, q(o[9], hs));
    w.put(32, qa(o[10], -31));
    w.put(hb, q(o[11], hs));
    w.put(32, qa(o[12], -31));
    w.put(hb, q(o[13], rs));
    w.put(32, qa(o[14], -31));
    w.put(24, qa(o[15], -43));
}

/// Seconds of the GPS week of the time of clock.
fn toc_sow(r: &NavRecord, shift_s: f64) -> f64 {
    week_tow(r.toc - Duration::from_seconds(shift_s)).1
}

fn gps_1019(r: &NavRecord) -> Vec<u8> {
    let (o, c) = (&r.orbit, r.clock);
    let mut w = Writer::new();
    w.put(12, 1019);
    w.put(6, r.sv.prn as i64);
    w.put(10, (o[18] as i64).rem_euclid(1024));
    w.put(4, ura_index(o[20]));
    w.put(2, o[17] as i64);
    w.put(14, qa(o[16], -43));
    w.put(8, o[0] as i64);
    w.put(16, (toc_sow(r, 0.0) / 16.0).round() as i64);
    w.put(8, q(c[2], -55));
    w.put(16, q(c[1], -43));
    w.put(22, q(c[0], -31));
    w.put(10, o[23] as i64);
    kepler_body(&mut w, o, 16, -5, -29, (16, 16.0));
    w.put(8, q(o[22], -31));
    w.put(6, o[21] as i64);
    w.put(1, o[19] as i64);
    w.put(1, (o.get(25).copied().unwrap_or(4.0) > 4.0) as i64);
    w.buf
}

fn qzss_1044(r: &NavRecord) -> Vec<u8> {
    let (o, c) = (&r.orbit, r.clock);
    let mut w = Writer::new();
    w.put(12, 1044);
    w.put(4, r.sv.prn as i64);
    w.put(16, (toc_sow(r, 0.0) / 16.0).round() as i64);
    w.put(8, q(c[2], -55));
    w.put(16, q(c[1], -43));
    w.put(22, q(c[0], -31));
    w.put(8, o[0] as i64);
    kepler_body(&mut w, o, 16, -5, -29, (16, 16.0));
    w.put(14, qa(o[16], -43));
    w.put(2, o[17] as i64);
    w.put(10, (o[18] as i64).rem_euclid(1024));
    w.put(4, ura_index(o[20]));
    w.put(6, o[21] as i64);
    w.put(8, q(o[22], -31));
    w.put(10, o[23] as i64);
    w.put(1, (o.get(25).copied().unwrap_or(2.0) > 2.0) as i64);
    w.buf
}

fn beidou_1042(r: &NavRecord) -> Vec<u8> {
    let (o, c) = (&r.orbit, r.clock);
    let mut w = Writer::new();
    w.put(12, 1042);
    w.put(6, r.sv.prn as i64);
    w.put(13, (o[18] as i64).rem_euclid(8192));
    w.put(4, ura_index(o[20]));
    w.put(14, qa(o[16], -43));
    w.put(5, o[0] as i64);
    w.put(17, (toc_sow(r, 14.0) / 8.0).round() as i64);
    w.put(11, q(c[2], -66));
    w.put(22, q(c[1], -50));
    w.put(24, q(c[0], -33));
    w.put(5, o.get(25).copied().unwrap_or(0.0) as i64);
    kepler_body(&mut w, o, 18, -6, -31, (17, 8.0));
    w.put(10, (o[22] * 1e10).round() as i64);
    w.put(10, (o[23] * 1e10).round() as i64);
    w.put(1, o[21] as i64);
    w.buf
}

/// 1046 for an I/NAV record (data source bit 0 or 2, or 9), else 1045 (F/NAV).
fn galileo(r: &NavRecord) -> Vec<u8> {
    let (o, c) = (&r.orbit, r.clock);
    let src = o[17] as u32;
    let inav = src & (1 << 8) == 0 || src & (1 << 9) != 0;
    let mut w = Writer::new();
    w.put(12, if inav { 1046 } else { 1045 });
    w.put(6, r.sv.prn as i64);
    w.put(12, (o[18] as i64 - 1024).rem_euclid(4096));
    w.put(10, o[0] as i64);
    w.put(8, sisa_index(o[20]));
    w.put(14, qa(o[16], -43));
    w.put(14, (toc_sow(r, 0.0) / 60.0).round() as i64);
    w.put(6, q(c[2], -59));
    w.put(21, q(c[1], -46));
    w.put(31, q(c[0], -34));
    kepler_body(&mut w, o, 16, -5, -29, (14, 60.0));
    w.put(10, q(o[22], -32));
    let h = o[21] as i64;
    if inav {
        w.put(10, q(o[23], -32));
        w.put(2, h >> 7 & 3);
        w.put(1, h >> 6 & 1);
        w.put(2, h >> 1 & 3);
        w.put(1, h & 1);
        w.put(2, 0);
    } else {
        w.put(2, h >> 4 & 3);
        w.put(1, h >> 3 & 1);
        w.put(7, 0);
    }
    w.buf
}

fn glonass_1020(r: &NavRecord) -> Vec<u8> {
    let (o, c) = (&r.orbit, r.clock);
    let t_ms = (r.toc.to_gpst_seconds() * 1000.0).round() as i64;
    // GPST → UTC → Moscow time of day
    let moscow = |utc_ms: i64| (utc_ms + 10_800_000).rem_euclid(86_400_000) / 1000;
    let tb = moscow(t_ms - leap_seconds(t_ms) * 1000) / 900;
    let tk = moscow((c[2] * 1000.0).round() as i64);
    let mut w = Writer::new();
    w.put(12, 1020);
    w.put(6, r.sv.prn as i64);
    w.put(5, o[7] as i64 + 7);
    w.put(1 + 1 + 2, 0);
    w.put(5, tk / 3600);
    w.put(6, tk % 3600 / 60);
    w.put(1, (tk % 60 >= 30) as i64);
    w.put(1, (o[3] != 0.0) as i64);
    w.put(1, 0);
    w.put(7, tb);
    for k in 0..3 {
        put_sm(&mut w, 24, q(o[4 * k + 1], -20));
        put_sm(&mut w, 27, q(o[4 * k], -11));
        put_sm(&mut w, 5, q(o[4 * k + 2], -30));
    }
    w.put(1, 0);
    put_sm(&mut w, 11, q(c[1], -40));
    w.put(3, 0);
    put_sm(&mut w, 22, q(-c[0], -30));
    put_sm(&mut w, 5, 0);
    w.put(5, o[11] as i64);
    // P4, FT, NT, M, additional data (none), NA, τc, N4, τGPS, ln, reserved
    for n in [1, 4, 11, 2, 1, 11, 32, 5, 22, 1, 7] {
        w.put(n, 0);
    }
    w.buf
}
