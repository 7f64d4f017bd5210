//! RTCM 3 ephemeris messages to navigation records: 1019 (GPS), 1020 (GLONASS), 1042
//! (BeiDou), 1044 (QZSS), 1045 (Galileo F/NAV) and 1046 (Galileo I/NAV).
//!
//! What enters: a message payload and the time the log has reached (GPST ms since the GPS
//! epoch, from its observations or the time hint). What leaves: a [`NavRecord`] laid out as
//! the RINEX 3 navigation reader makes them (so [`crate::orbit::Ephemerides`] and the RINEX
//! writer take it unchanged), or why the message was refused.
//!
//! Fields and scale factors as RTCM 10403.3 lists them (DF071–DF137 GPS, DF104–DF136
//! GLONASS, DF252–DF317 Galileo, DF429–DF452 QZSS, DF488–DF515 BeiDou): angles in
//! semicircles (× π), two's-complement fields except GLONASS, whose signed fields are
//! sign-magnitude (the top bit the sign). Weeks: Galileo (12 bits, + 1024) and BeiDou
//! (13 bits, BDT) are whole; the GPS and QZSS 10-bit week is resolved with [`gps_week`]; the
//! week is then moved so that toe lies within half a week of the log's time, as receivers
//! broadcast the week of transmission. GLONASS carries times of day only (Moscow time); the
//! day is the one nearest the log's time, so a 1020 before any time is known is refused.
//! The transmission time RINEX asks for is the log's time when the message was read.

use super::bits::bits_u;
use super::inav::sisa_metres;
use super::lnav::ura_metres;
use super::rtcm::message_number;
use super::rtcm_msm::{leap_seconds, WEEK_MS};
use crate::rinex::nav::{NavKind, NavRecord};
use crate::sv::{Constellation, Sv};
use hifitime::{Duration, Epoch};
use std::f64::consts::PI;

/// The ephemeris messages decoded here.
pub const EPHEMERIS_MESSAGES: [u16; 6] = [1019, 1020, 1042, 1044, 1045, 1046];
/// Weeks from the GPS epoch to the BeiDou epoch (2006-01-01).
pub const BDT_WEEK0: i64 = 1356;
const DAY_MS: i64 = 86_400_000;

/// Why an ephemeris message was not turned into a record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EphError {
    /// The payload is shorter than the message's fields.
    Short,
    /// The satellite id is outside the system's range (the id given).
    Satellite(u32),
    /// A GLONASS ephemeris before the log's time was known (its day cannot be placed).
    NoTime,
}

/// Bits needed by each message (payload, message number included).
fn needed_bits(msg: u16) -> usize {
    match msg {
        1019 => 488,
        1020 => 360,
        1042 => 511,
        1044 => 485,
        1045 => 496,
        _ => 504,
    }
}

/// A cursor over the fields of a payload, in order.
struct Fields<'a> {
    p: &'a [u8],
    pos: usize,
}

impl Fields<'_> {
    fn u(&mut self, n: usize) -> f64 {
        let v = bits_u(self.p, self.pos, n);
        self.pos += n;
        v as f64
    }
    /// A two's-complement field of `n` (≤ 32) bits.
    fn s(&mut self, n: usize) -> f64 {
        let u = bits_u(self.p, self.pos, n) as i64;
        self.pos += n;
        (if u >> (n - 1) & 1 == 1 {
            u - (1 << n)
        } else {
            u
        }) as f64
    }
    /// A sign-magnitude field of `n` bits (GLONASS): the top bit set means negative.
    fn g(&mut self, n: usize) -> f64 {
        let sign = bits_u(self.p, self.pos, 1);
        let mag = bits_u(self.p, self.pos + 1, n - 1) as f64;
        self.pos += n;
        if sign == 1 {
            -mag
        } else {
            mag
        }
    }
    fn skip(&mut self, n: usize) {
        self.pos += n;
    }
}

fn p2(e: i32) -> f64 {
    2f64.powi(e)
}

/// The full GPS week of a 10-bit broadcast week: the one nearest `reference` (a full week,
/// e.g. from a year hint), or without one in the cycle that began on 2019-04-07 (weeks
/// 2048–3071).
pub fn gps_week(wn10: u32, reference: Option<i64>) -> i64 {
    let wn = (wn10 & 0x3ff) as i64;
    match reference {
        Some(r) => wn + 1024 * ((r - wn) as f64 / 1024.0).round() as i64,
        None => 2048 + wn,
    }
}

/// `week` moved by one when the instant `week`/`sow` (GPST, plus `offset_ms`) lies between
/// half a week and a week and a half from `now`: the week of transmission beside a toe of
/// the next or the last week. An instant farther away is a stale ephemeris kept from
/// another week, left as it is.
fn week_near(week: i64, sow: f64, offset_ms: i64, now: Option<i64>) -> i64 {
    let Some(now) = now else { return week };
    let t = week * WEEK_MS + (sow * 1000.0) as i64 + offset_ms;
    let off = t - now;
    if off.abs() <= WEEK_MS / 2 || off.abs() > 3 * WEEK_MS / 2 {
        week
    } else if off > 0 {
        week - 1
    } else {
        week + 1
    }
}

fn gpst(week: i64, sow: f64) -> Epoch {
    Epoch::from_gpst_seconds(week as f64 * 604_800.0) + Duration::from_seconds(sow)
}

/// The Keplerian elements every Keplerian message carries, in RINEX order from IODE to IDOT:
/// [iode, crs, Δn, M0, cuc, e, cus, √A, toe, cic, Ω0, cis, i0, crc, ω, Ω̇, IDOT].
type Kepler = [f64; 17];

/// Decode an ephemeris payload; `now` is the log's time (GPST ms), `week_ref` the full GPS
/// week a year or date hint points at (for the 10-bit GPS and QZSS weeks).
pub fn decode_ephemeris(
    p: &[u8],
    now: Option<i64>,
    week_ref: Option<i64>,
) -> Result<NavRecord, EphError> {
    let msg = message_number(p);
    if p.len() * 8 < needed_bits(msg) {
        return Err(EphError::Short);
    }
    let f = Fields { p, pos: 12 };
    match msg {
        1019 => gps_1019(f, now, week_ref),
        1020 => glonass_1020(f, now),
        1042 => beidou_1042(f, now),
        1044 => qzss_1044(f, now, week_ref),
        _ => galileo_1045_1046(f, msg == 1046, now),
    }
}

fn sat(sys: Constellation, id: f64, max: f64) -> Result<Sv, EphError> {
    if id < 1.0 || id > max {
        return Err(EphError::Satellite(id as u32));
    }
    Ok(Sv::new(sys, id as u8))
}

/// Seconds of the record's week at which it was read (RINEX's transmission time).
fn transmission(week: i64, now: Option<i64>, toe: f64) -> f64 {
    now.map_or(toe, |t| (t - week * WEEK_MS) as f64 * 1e-3)
}

fn gps_1019(mut f: Fields, now: Option<i64>, week_ref: Option<i64>) -> Result<NavRecord, EphError> {
    let sv = sat(Constellation::Gps, f.u(6), 32.0)?;
    let wn = f.u(10) as u32;
    let sva = f.u(4) as u32;
    let code = f.u(2);
    let idot = f.s(14) * p2(-43) * PI;
    let iode = f.u(8);
    let toc = f.u(16) * 16.0;
    let af2 = f.s(8) * p2(-55);
    let af1 = f.s(16) * p2(-43);
    let af0 = f.s(22) * p2(-31);
    let iodc = f.u(10);
    let mut k = kepler_body(&mut f, iode, &GPS);
    k[16] = idot;
    let tgd = f.s(8);
    let health = f.u(6);
    let l2p = f.u(1);
    let fit = if f.u(1) == 1.0 { 6.0 } else { 4.0 };
    let base = gps_week(wn, now.map(|t| t.div_euclid(WEEK_MS)).or(week_ref));
    let week = week_near(base, k[8], 0, now);
    let tgd = if tgd == -128.0 { 0.0 } else { tgd * p2(-31) };
    let tail = [
        code,
        week as f64,
        l2p,
        ura_metres(sva),
        health,
        tgd,
        iodc,
        transmission(week, now, k[8]),
        fit,
    ];
    Ok(record(sv, gpst(week, toc), [af0, af1, af2], &k, &tail))
}

fn qzss_1044(
    mut f: Fields,
    now: Option<i64>,
    week_ref: Option<i64>,
) -> Result<NavRecord, EphError> {
    let sv = sat(Constellation::Qzss, f.u(4), 10.0)?;
    let toc = f.u(16) * 16.0;
    let af2 = f.s(8) * p2(-55);
    let af1 = f.s(16) * p2(-43);
    let af0 = f.s(22) * p2(-31);
    let iode = f.u(8);
    let mut k = kepler_body(&mut f, iode, &GPS);
    k[16] = f.s(14) * p2(-43) * PI;
    let code = f.u(2);
    let wn = f.u(10) as u32;
    let sva = f.u(4) as u32;
    let health = f.u(6);
    let tgd = f.s(8) * p2(-31);
    let iodc = f.u(10);
    let fit = if f.u(1) == 1.0 { 4.0 } else { 2.0 };
    let base = gps_week(wn, now.map(|t| t.div_euclid(WEEK_MS)).or(week_ref));
    let week = week_near(base, k[8], 0, now);
    let tail = [
        code,
        week as f64,
        1.0,
        ura_metres(sva),
        health,
        tgd,
        iodc,
        transmission(week, now, k[8]),
        fit,
    ];
    Ok(record(sv, gpst(week, toc), [af0, af1, af2], &k, &tail))
}

/// How a system's message lays out the elements from crs to Ω̇.
struct Layout {
    /// Bit width of the harmonic terms.
    harmonic_bits: usize,
    /// Scale exponents of the radius and of the angle harmonics.
    radius_exp: i32,
    angle_exp: i32,
    /// Bit width of toe and the seconds of one step.
    toe_bits: usize,
    toe_unit: f64,
}

const GPS: Layout = Layout {
    harmonic_bits: 16,
    radius_exp: -5,
    angle_exp: -29,
    toe_bits: 16,
    toe_unit: 16.0,
};
const GALILEO: Layout = Layout {
    toe_bits: 14,
    toe_unit: 60.0,
    ..GPS
};
const BEIDOU: Layout = Layout {
    harmonic_bits: 18,
    radius_exp: -6,
    angle_exp: -31,
    toe_bits: 17,
    toe_unit: 8.0,
};

/// The elements from crs to Ω̇ (in the same order in every Keplerian message), with `iode`
/// first; IDOT is left 0 for the caller.
fn kepler_body(f: &mut Fields, iode: f64, l: &Layout) -> Kepler {
    let (hb, rs, as_) = (l.harmonic_bits, l.radius_exp, l.angle_exp);
    let crs = f.s(hb) * p2(rs);
    let dn = f.s(16) * p2(-43) * PI;
    let m0 = f.s(32) * p2(-31) * PI;
    let cuc = f.s(hb) * p2(as_);
    let e = f.u(32) * p2(-33);
    let cus = f.s(hb) * p2(as_);
    let sqrt_a = f.u(32) * p2(-19);
    let toe = f.u(l.toe_bits) * l.toe_unit;
    let cic = f.s(hb) * p2(as_);
    let omega0 = f.s(32) * p2(-31) * PI;
    let cis = f.s(hb) * p2(as_);
    let i0 = f.s(32) * p2(-31) * PI;
    let crc = f.s(hb) * p2(rs);
    let omega = f.s(32) * p2(-31) * PI;
    let omega_dot = f.s(24) * p2(-43) * PI;
    [
        iode, crs, dn, m0, cuc, e, cus, sqrt_a, toe, cic, omega0, cis, i0, crc, omega, omega_dot,
        0.0,
    ]
}

fn record(sv: Sv, toc: Epoch, clock: [f64; 3], k: &Kepler, tail: &[f64]) -> NavRecord {
    let mut orbit = k.to_vec();
    orbit.extend_from_slice(tail);
    NavRecord {
        sv,
        kind: NavKind::Kepler,
        toc,
        clock,
        orbit,
        line: 0,
    }
}

fn beidou_1042(mut f: Fields, now: Option<i64>) -> Result<NavRecord, EphError> {
    let sv = sat(Constellation::BeiDou, f.u(6), 63.0)?;
    let bdt_week = f.u(13) as i64;
    let sva = f.u(4) as u32;
    let idot = f.s(14) * p2(-43) * PI;
    let aode = f.u(5);
    let toc = f.u(17) * 8.0;
    let af2 = f.s(11) * p2(-66);
    let af1 = f.s(22) * p2(-50);
    let af0 = f.s(24) * p2(-33);
    let aodc = f.u(5);
    let mut k = kepler_body(&mut f, aode, &BEIDOU);
    k[16] = idot;
    let tgd1 = f.s(10) * 1e-10;
    let tgd2 = f.s(10) * 1e-10;
    let sath1 = f.u(1);
    // BDT = GPST − 14 s: the week is moved with toe seen in GPST.
    let week = week_near(BDT_WEEK0 + bdt_week, k[8], 14_000, now) - BDT_WEEK0;
    let tail = [
        0.0,
        week as f64,
        0.0,
        ura_metres(sva),
        sath1,
        tgd1,
        tgd2,
        transmission(week + BDT_WEEK0, now, k[8]),
        aodc,
    ];
    let toc = gpst(week + BDT_WEEK0, toc) + Duration::from_seconds(14.0);
    Ok(record(sv, toc, [af0, af1, af2], &k, &tail))
}

fn galileo_1045_1046(mut f: Fields, inav: bool, now: Option<i64>) -> Result<NavRecord, EphError> {
    let sv = sat(Constellation::Galileo, f.u(6), 36.0)?;
    let gst_week = f.u(12) as i64;
    let iod = f.u(10);
    let sisa = f.u(8) as u32;
    let idot = f.s(14) * p2(-43) * PI;
    let toc = f.u(14) * 60.0;
    let af2 = f.s(6) * p2(-59);
    let af1 = f.s(21) * p2(-46);
    let af0 = f.s(31) * p2(-34);
    let mut k = kepler_body(&mut f, iod, &GALILEO);
    k[16] = idot;
    let bgd_a = f.s(10) * p2(-32);
    let (bgd_b, health, source) = if inav {
        let bgd_b = f.s(10) * p2(-32);
        let (e5b_hs, e5b_dvs, e1_hs, e1_dvs) = (f.u(2), f.u(1), f.u(2), f.u(1));
        let h = e5b_hs * 128.0 + e5b_dvs * 64.0 + e1_hs * 2.0 + e1_dvs;
        // I/NAV on E1-B and E5b; clock for E5b,E1
        (bgd_b, h, (1 | 1 << 2 | 1 << 9) as f64)
    } else {
        let (e5a_hs, e5a_dvs) = (f.u(2), f.u(1));
        // F/NAV on E5a-I; clock for E5a,E1
        (0.0, e5a_hs * 16.0 + e5a_dvs * 8.0, (1 << 1 | 1 << 8) as f64)
    };
    let week = week_near(gst_week + 1024, k[8], 0, now);
    let tail = [
        source,
        week as f64,
        0.0,
        sisa_metres(sisa),
        health,
        bgd_a,
        bgd_b,
        transmission(week, now, k[8]),
    ];
    Ok(record(sv, gpst(week, toc), [af0, af1, af2], &k, &tail))
}

/// The instant (ms) of a time of day `tod_ms` on the day nearest `near` (same time scale).
pub(crate) fn nearest_day(tod_ms: i64, near: i64) -> i64 {
    let base = near - near.rem_euclid(DAY_MS) + tod_ms.rem_euclid(DAY_MS);
    [base - DAY_MS, base, base + DAY_MS]
        .into_iter()
        .min_by_key(|t| (t - near).abs())
        .unwrap_or(base)
}

fn glonass_1020(mut f: Fields, now: Option<i64>) -> Result<NavRecord, EphError> {
    let sv = sat(Constellation::Glonass, f.u(6), 63.0)?;
    let channel = f.u(5) - 7.0;
    f.skip(1 + 1 + 2);
    let tk_s = f.u(5) * 3600.0 + f.u(6) * 60.0 + f.u(1) * 30.0;
    let bn = f.u(1);
    f.skip(1);
    let tb = f.u(7);
    let mut xyz = [[0.0; 3]; 3];
    for c in &mut xyz {
        let vel = f.g(24) * p2(-20);
        let pos = f.g(27) * p2(-11);
        let acc = f.g(5) * p2(-30);
        *c = [pos, vel, acc];
    }
    f.skip(1);
    let gamma = f.g(11) * p2(-40);
    f.skip(3);
    let tau = f.g(22) * p2(-30);
    f.skip(5);
    let age = f.u(5);
    let now = now.ok_or(EphError::NoTime)?;
    let leap = leap_seconds(now) * 1000;
    // Moscow time (UTC + 3 h) of day → UTC on the day nearest the log's time → GPST
    let toe_utc = nearest_day((tb * 900.0 - 10_800.0) as i64 * 1000, now - leap);
    let tof_utc = nearest_day((tk_s - 10_800.0) as i64 * 1000, toe_utc);
    let [x, y, z] = xyz;
    Ok(NavRecord {
        sv,
        kind: NavKind::Glonass,
        toc: Epoch::from_gpst_seconds((toe_utc + leap) as f64 * 1e-3),
        clock: [-tau, gamma, tof_utc.rem_euclid(WEEK_MS) as f64 * 1e-3],
        orbit: vec![
            x[0], x[1], x[2], bn, y[0], y[1], y[2], channel, z[0], z[1], z[2], age,
        ],
        line: 0,
    })
}
