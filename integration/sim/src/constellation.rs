//! Documented synthetic constellations written as a RINEX 3.04 navigation file, so the
//! simulator needs no external data: GPS-like (6 planes × 4, i = 55°, a = 26 560 km) and
//! Galileo-like (3 planes × 8, i = 56°, a = 29 600 km) circular-ish Keplerian orbits with no
//! perturbation terms, broadcast every two hours, plus Klobuchar parameters; on request a
//! QZSS-like set (three quasi-zenith satellites on one figure-eight centred on 135° E and a
//! geostationary one at 127° E, Keplerian LNAV records broadcast every hour, as ppkat uses a
//! QZSS record within ±1 h of toe) and a GLONASS-like one (state-vector records every 30 min,
//! `glonass_nav`).
//!
//! The simulator computes every satellite position from this file as read back by our own
//! reader, so simulated observations and processing use the very same numbers. Every
//! Keplerian value lies on the grid of the broadcast messages (semicircles 2^-31, e 2^-33, √A
//! 2^-19, clock terms at GPS or Galileo resolution), as a satellite's would: encoding the file
//! as RTCM 3 (`simulate --raw rtcm3`) or navigation words then loses nothing. (GLONASS values
//! are not on the RTCM grid: see `glonass_nav`.)
//!
//! Enters: the GPST span of the flight, a seed and the systems. Leaves: the text of the
//! navigation file (times of ephemeris every 2 h for GPS and Galileo, 1 h for QZSS, GPST;
//! GLONASS every 30 min, UTC; angles radians; lengths metres as RINEX has them).

use super::rng::Rng;
use gnss::sv::Constellation;
use gnss::time::{from_week_tow, week_tow};
use hifitime::Epoch;
use std::f64::consts::PI;
use std::fmt::Write;

/// Klobuchar α0–α3 broadcast by the synthetic constellation (typical mid-activity values;
/// s, s/semicircle, s/semicircle², s/semicircle³).
pub const KLOB_ALPHA: [f64; 4] = [1.1176e-08, 7.4506e-09, -5.9605e-08, -5.9605e-08];
/// Klobuchar β0–β3 broadcast by the synthetic constellation (s, s/semicircle …).
pub const KLOB_BETA: [f64; 4] = [9.0112e-04, 1.6384e+04, -1.9661e+05, -6.5536e+04];

struct Sat {
    sys: char,
    prn: u8,
    sqrt_a: f64,
    e: f64,
    i0: f64,
    raan: f64,
    omega: f64,
    m_ref: f64,
    mu: f64,
    af0: f64,
    af1: f64,
}

/// `x` on the grid of a field of scale 2^e.
fn grid(x: f64, e: i32) -> f64 {
    (x * 2f64.powi(-e)).round() * 2f64.powi(e)
}

/// An angle (radians) on the grid of a semicircle field of scale 2^e.
fn grid_angle(x: f64, e: i32) -> f64 {
    grid(x / PI, e) * PI
}

/// An angle in [−π, π], as the two's-complement semicircle fields carry them.
fn wrap(x: f64) -> f64 {
    x - 2.0 * PI * (x / (2.0 * PI)).round()
}

/// Scale exponents of af0 and af1: GPS LNAV, Galileo.
fn clock_exp(sys: char) -> (i32, i32) {
    if sys == 'E' {
        (-34, -46)
    } else {
        (-31, -43)
    }
}

fn d19(v: f64) -> String {
    format!("{:>19}", format!("{v:.12E}"))
}

/// How many GPS satellites fly, plane by plane.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GpsLayout {
    /// The 24-slot baseline constellation, four per plane (the flight benches' own).
    Baseline24,
    /// 31 satellites as in 2024 (six in the first plane, five in the others): what a
    /// static receiver at mid-latitudes sees over a day, 8 to 12 above 10°.
    Operational31,
}

impl GpsLayout {
    fn per_plane(self) -> [usize; 6] {
        match self {
            GpsLayout::Baseline24 => [4; 6],
            GpsLayout::Operational31 => [6, 5, 5, 5, 5, 5],
        }
    }
}

fn sats(rng: &mut Rng, gps: GpsLayout) -> Vec<Sat> {
    let mut out = Vec::new();
    let mut add = |sys: char, per_plane: &[usize], a: f64, inc: f64, mu: f64, rng: &mut Rng| {
        let mut prn = 1u8;
        let planes = per_plane.len();
        for (p, &per) in per_plane.iter().enumerate() {
            for k in 0..per {
                out.push(Sat {
                    sys,
                    prn,
                    sqrt_a: grid(a.sqrt(), -19),
                    e: grid(rng.range(0.001, 0.01), -33),
                    i0: grid_angle(inc.to_radians() + rng.range(-0.01, 0.01), -31),
                    raan: 2.0 * PI * p as f64 / planes as f64,
                    omega: grid_angle(wrap(rng.range(0.0, 2.0 * PI)), -31),
                    m_ref: 2.0 * PI * (k as f64 / per as f64 + p as f64 / (planes * per) as f64),
                    mu,
                    af0: rng.range(-2e-4, 2e-4),
                    af1: grid(rng.range(-5e-12, 5e-12), clock_exp(sys).1),
                });
                prn += 1;
            }
        }
    };
    add('G', &gps.per_plane(), 26_559_700.0, 55.0, 3.986_005e14, rng);
    add('E', &[8; 3], 29_599_800.0, 56.0, 3.986_004_418e14, rng);
    out
}

/// Ground-track centre (east longitude, degrees) of the QZSS-like quasi-zenith satellites, and
/// the longitude of the geostationary one.
const QZSS_CENTRE_DEG: f64 = 135.0;
const QZSS_GEO_DEG: f64 = 127.0;

/// The QZSS-like satellites: J02, J03, J04 on quasi-zenith orbits (geosynchronous, e = 0.075,
/// i = 41°, ω = 270° so that apogee is over the north; nodes 120° apart and mean anomalies
/// 120° the other way, so all three follow one figure-eight centred on 135° E, 8 h apart),
/// and J07 geostationary at 127° E. Elements fixed; clocks drawn from `rng`.
fn qzss_sats(rng: &mut Rng) -> Vec<Sat> {
    let mu = 3.986_005e14;
    let we = gnss::frame::OMEGA_E;
    // Geosynchronous: mean motion = Earth rotation rate.
    let a: f64 = (mu / (we * we)).cbrt();
    let mut out = Vec::new();
    let mut add = |prn: u8, e: f64, inc: f64, raan: f64, omega: f64, centre: f64| {
        let m_ref = wrap(centre.to_radians() - omega.to_radians() - raan.to_radians());
        out.push(Sat {
            sys: 'J',
            prn,
            sqrt_a: grid(a.sqrt(), -19),
            e: grid(e, -33),
            i0: grid_angle(inc.to_radians(), -31),
            raan: raan.to_radians(),
            omega: grid_angle(wrap(omega.to_radians()), -31),
            m_ref,
            mu,
            af0: rng.range(-2e-4, 2e-4),
            af1: grid(rng.range(-5e-12, 5e-12), clock_exp('J').1),
        });
    };
    for (k, prn) in [2u8, 3, 4].into_iter().enumerate() {
        add(prn, 0.075, 41.0, 120.0 * k as f64, 270.0, QZSS_CENTRE_DEG);
    }
    add(7, 0.0002, 0.05, 0.0, 0.0, QZSS_GEO_DEG);
    out
}

/// The RINEX letter of a system the simulator broadcasts.
fn letter_in(systems: &[Constellation], c: char) -> bool {
    systems.iter().any(|s| s.letter() == c)
}

/// RINEX 3.04 navigation text of the GPS-like and Galileo-like constellations covering
/// `[start − 2 h, end + 2 h]` (what [`navigation_text_of`] writes for `G` and `E`).
pub fn navigation_text(start: Epoch, end: Epoch, seed: u64) -> String {
    navigation_text_of(
        start,
        end,
        seed,
        &[Constellation::Gps, Constellation::Galileo],
    )
}

/// RINEX 3.04 navigation text of the synthetic constellations of `systems` (any of GPS,
/// Galileo, GLONASS, QZSS) covering `[start − 2 h, end + 2 h]`: GPS and Galileo records every
/// 2 h, QZSS every hour, then GLONASS every 30 min (`glonass_nav`). The GPS and
/// Galileo values do not depend on which other systems are asked for.
pub fn navigation_text_of(
    start: Epoch,
    end: Epoch,
    seed: u64,
    systems: &[Constellation],
) -> String {
    navigation_text_with(start, end, seed, systems, GpsLayout::Baseline24)
}

/// [`navigation_text_of`] with the GPS satellites of `gps`.
pub fn navigation_text_with(
    start: Epoch,
    end: Epoch,
    seed: u64,
    systems: &[Constellation],
    gps: GpsLayout,
) -> String {
    let mut rng = Rng::new(seed).fork(0x6e6176);
    let sats: Vec<Sat> = sats(&mut rng, gps)
        .into_iter()
        .filter(|s| letter_in(systems, s.sys))
        .collect();
    let mut s = header();
    // Reference epoch of the orbits: the start of the GPS week of `start`.
    let (week0, _) = week_tow(start);
    let t_ref = from_week_tow(week0, 0.0);
    let first = start - hifitime::Duration::from_seconds(2.0 * 3600.0);
    let last = end + hifitime::Duration::from_seconds(2.0 * 3600.0);
    kepler_records(&mut s, &sats, (first, last), t_ref, (7200.0, 0.0), REGULAR);
    if letter_in(systems, 'J') {
        let qzss = qzss_sats(&mut Rng::new(seed).fork(0x717a7373));
        kepler_records(&mut s, &qzss, (first, last), t_ref, (3600.0, 0.0), REGULAR);
    }
    if letter_in(systems, 'R') {
        s += &super::glonass_nav::records(first, last, t_ref, seed);
    }
    s
}

/// Records of an older upload that daily merged navigation files keep beside the fresh ones
/// (issue 49, BELL–EBRE 2002-01-30: PRN 21's 23:00 set of a day-old upload, sent before the
/// fresh 22:00 one, lies 9 m from it): for every `every`-th GPS satellite of the layout, a set
/// at each odd hour of `[start − 2 h, end + 2 h]`, sent 2.5 h before its toe (before the fresh
/// set of the hour before it), with the satellite `along_track_m` metres ahead of the truth.
/// A selection by toe alone takes it for the hour centred on each odd hour; one that knows
/// the fresher upload passes it over. Returns the records' text and their count.
pub fn stale_gps_records(
    span: (Epoch, Epoch),
    seed: u64,
    gps: GpsLayout,
    every: usize,
    along_track_m: f64,
) -> (String, usize) {
    let sent = Sent {
        before_toe_s: 9000.0,
        iod_shift: 128.0,
    };
    offset_gps_records(
        span,
        seed,
        gps,
        &|k, _| k % every.max(1) == 0,
        along_track_m,
        3600.0,
        sent,
    )
}

/// The records of GPS satellite `prn` on the regular 2 h grid, with the satellite
/// `along_track_m` metres ahead of the truth: a satellite flying on a stale upload with no
/// fresher set in the file (BELL–EBRE's PRN 21 all afternoon, 9 m from its next upload). With
/// [`without_gps`] they replace its true records.
pub fn off_gps_records(
    span: (Epoch, Epoch),
    seed: u64,
    gps: GpsLayout,
    prn: u8,
    along_track_m: f64,
) -> String {
    offset_gps_records(
        span,
        seed,
        gps,
        &|_, p| p == prn,
        along_track_m,
        0.0,
        REGULAR,
    )
    .0
}

/// Navigation text without the records of GPS satellite `prn` (RINEX 3: a record's first
/// line names the satellite, its continuation lines start with four spaces).
pub fn without_gps(text: &str, prn: u8) -> String {
    split_records(text, &format!("G{prn:02} ")).0
}

/// Navigation text split into the records whose first line does not start with `head` and
/// those that do (RINEX 3: continuation lines start with four spaces).
pub fn split_records(text: &str, head: &str) -> (String, String) {
    let (mut rest, mut matching) = (String::new(), String::new());
    let mut inside = false;
    for line in text.lines() {
        if line.starts_with(head) {
            inside = true;
        } else if !line.starts_with("    ") {
            inside = false;
        }
        let out = if inside { &mut matching } else { &mut rest };
        out.push_str(line);
        out.push('\n');
    }
    (rest, matching)
}

/// Records of the GPS satellites `pick` (index among the GPS satellites, PRN) moved
/// `along_track_m` metres ahead, on the 2 h grid shifted by `toe_offset_s`, sent as `sent`
/// says, over `[start − 2 h, end + 2 h]`; their text and count.
fn offset_gps_records(
    (start, end): (Epoch, Epoch),
    seed: u64,
    gps: GpsLayout,
    pick: &dyn Fn(usize, u8) -> bool,
    along_track_m: f64,
    toe_offset_s: f64,
    sent: Sent,
) -> (String, usize) {
    let mut rng = Rng::new(seed).fork(0x6e6176);
    let (week0, _) = week_tow(start);
    let t_ref = from_week_tow(week0, 0.0);
    let moved: Vec<Sat> = sats(&mut rng, gps)
        .into_iter()
        .filter(|s| s.sys == 'G')
        .enumerate()
        .filter(|(k, s)| pick(*k, s.prn))
        .map(|(_, s)| Sat {
            m_ref: s.m_ref + along_track_m / (s.sqrt_a * s.sqrt_a),
            ..s
        })
        .collect();
    let two_hours = hifitime::Duration::from_seconds(7200.0);
    let mut text = String::new();
    let n = kepler_records(
        &mut text,
        &moved,
        (start - two_hours, end + two_hours),
        t_ref,
        (7200.0, toe_offset_s),
        sent,
    );
    (text, n)
}

/// The header: version, program, comment, GPS Klobuchar parameters, leap seconds.
fn header() -> String {
    let mut s = String::new();
    let line = |s: &mut String, a: &str, b: &str| {
        let _ = writeln!(s, "{a:<60}{b}");
    };
    line(
        &mut s,
        "     3.04           N: GNSS NAV DATA    M: MIXED",
        "RINEX VERSION / TYPE",
    );
    line(&mut s, "ppkat simulate      ppkat", "PGM / RUN BY / DATE");
    line(
        &mut s,
        "Synthetic constellation of the ppkat simulator (not real satellites)",
        "COMMENT",
    );
    let k = |c: &[f64; 4]| c.iter().map(|v| format!("{v:12.4E}")).collect::<String>();
    line(
        &mut s,
        &format!("GPSA {}", k(&KLOB_ALPHA)),
        "IONOSPHERIC CORR",
    );
    line(
        &mut s,
        &format!("GPSB {}", k(&KLOB_BETA)),
        "IONOSPHERIC CORR",
    );
    line(&mut s, "    18", "LEAP SECONDS");
    line(&mut s, "", "END OF HEADER");
    s
}

/// The records of Keplerian satellites `sats` for every toe on the grid of `period` seconds
/// (of the GPS week) shifted by `offset` seconds, from the last one at or before `first` to
/// `last`, sent as `sent` says; the orbits refer to `t_ref`, and the issue of data counts
/// periods since it. Returns how many were written.
fn kepler_records(
    s: &mut String,
    sats: &[Sat],
    (first, last): (Epoch, Epoch),
    t_ref: Epoch,
    (period, offset): (f64, f64),
    sent: Sent,
) -> usize {
    let mut n = 0;
    if sats.is_empty() {
        return n;
    }
    let (w, tow) = week_tow(first);
    let mut toe = from_week_tow(w, (tow / period).floor() * period + offset);
    while toe <= last {
        for sat in sats {
            kepler_record(s, sat, toe, t_ref, period, sent);
            n += 1;
        }
        toe += hifitime::Duration::from_seconds(period);
    }
    n
}

/// When a record was transmitted and which issue of data it carries: the regular sets are sent
/// an hour before their toe with the issue counted in periods; a stale upload's earlier, with
/// the issue shifted by 128.
#[derive(Clone, Copy)]
struct Sent {
    before_toe_s: f64,
    iod_shift: f64,
}

const REGULAR: Sent = Sent {
    before_toe_s: 3600.0,
    iod_shift: 0.0,
};

/// One LNAV-like (or Galileo) record of `sat` at `toe`, with the issue of data counted in
/// `period`s since `t_ref` and the transmission time as `sent` says (negative seconds of week
/// when it falls in the week before toe's, as RINEX allows).
fn kepler_record(s: &mut String, sat: &Sat, toe: Epoch, t_ref: Epoch, period: f64, sent: Sent) {
    let (week, sow) = week_tow(toe);
    let dt_ref = (toe - t_ref).to_seconds();
    let week_start = from_week_tow(week, 0.0);
    let dweek = (week_start - t_ref).to_seconds();
    let (y, mo, d, h, mi, sec, _) = toe.to_gregorian(hifitime::TimeScale::GPST);
    let n = (sat.mu / sat.sqrt_a.powi(6)).sqrt();
    let m0 = grid_angle(wrap(sat.m_ref + n * dt_ref), -31);
    // Ω(t) = RAAN − ωe·(t − t_ref): broadcast Ω0 refers to the record's week start.
    let omega0 = grid_angle(wrap(sat.raan - gnss::frame::OMEGA_E * dweek), -31);
    let af0 = grid(sat.af0 + sat.af1 * dt_ref, clock_exp(sat.sys).0);
    let iod = (dt_ref / period + sent.iod_shift).rem_euclid(256.0).floor();
    let _ = writeln!(
        s,
        "{}{:02} {y:04} {mo:02} {d:02} {h:02} {mi:02} {sec:02}{}{}{}",
        sat.sys,
        sat.prn,
        d19(af0),
        d19(sat.af1),
        d19(0.0)
    );
    let rows: [[f64; 4]; 7] = [
        [iod, 0.0, 0.0, m0],
        [0.0, sat.e, 0.0, sat.sqrt_a],
        [sow, 0.0, omega0, 0.0],
        [sat.i0, 0.0, sat.omega, 0.0],
        [
            0.0,
            if sat.sys == 'E' { 517.0 } else { 1.0 },
            week as f64,
            0.0,
        ],
        // Accuracy, health, group delays zero (Galileo's second BGD sits where GPS has IODC).
        [2.0, 0.0, 0.0, if sat.sys == 'E' { 0.0 } else { iod }],
        // Transmission time; fit interval: GPS 4 h, QZSS the flag 0 (2 h).
        [
            sow - sent.before_toe_s,
            if sat.sys == 'J' { 0.0 } else { 4.0 },
            0.0,
            0.0,
        ],
    ];
    for r in rows {
        let _ = writeln!(
            s,
            "    {}{}{}{}",
            d19(r[0]),
            d19(r[1]),
            d19(r[2]),
            d19(r[3])
        );
    }
}
