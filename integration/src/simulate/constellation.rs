//! A documented synthetic constellation written as a RINEX 3.04 navigation file, so the
//! simulator needs no external data: GPS-like (6 planes × 4, i = 55°, a = 26 560 km) and
//! Galileo-like (3 planes × 8, i = 56°, a = 29 600 km) circular-ish Keplerian orbits with no
//! perturbation terms, broadcast every two hours, plus Klobuchar parameters.
//!
//! The simulator computes every satellite position from this file as read back by our own
//! reader, so simulated observations and processing use the very same numbers. Every value
//! lies on the grid of the broadcast messages (semicircles 2^-31, e 2^-33, √A 2^-19, clock
//! terms at GPS or Galileo resolution), as a satellite's would: encoding the file as RTCM 3
//! (`simulate --raw rtcm3`) or navigation words then loses nothing.
//!
//! Enters: the GPST span of the flight and a seed. Leaves: the text of the navigation file
//! (times of ephemeris every 2 h, GPST; angles radians; lengths metres as RINEX has them).

use super::rng::Rng;
use gnss::time::{from_week_tow, week_tow, WEEK_SECONDS};
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

fn sats(rng: &mut Rng) -> Vec<Sat> {
    let mut out = Vec::new();
    let mut add =
        |sys: char, planes: usize, per: usize, a: f64, inc: f64, mu: f64, rng: &mut Rng| {
            let mut prn = 1u8;
            for p in 0..planes {
                for k in 0..per {
                    out.push(Sat {
                        sys,
                        prn,
                        sqrt_a: grid(a.sqrt(), -19),
                        e: grid(rng.range(0.001, 0.01), -33),
                        i0: grid_angle(inc.to_radians() + rng.range(-0.01, 0.01), -31),
                        raan: 2.0 * PI * p as f64 / planes as f64,
                        omega: grid_angle(wrap(rng.range(0.0, 2.0 * PI)), -31),
                        m_ref: 2.0
                            * PI
                            * (k as f64 / per as f64 + p as f64 / (planes * per) as f64),
                        mu,
                        af0: rng.range(-2e-4, 2e-4),
                        af1: grid(rng.range(-5e-12, 5e-12), clock_exp(sys).1),
                    });
                    prn += 1;
                }
            }
        };
    add('G', 6, 4, 26_559_700.0, 55.0, 3.986_005e14, rng);
    add('E', 3, 8, 29_599_800.0, 56.0, 3.986_004_418e14, rng);
    out
}

/// RINEX 3.04 navigation text covering `[start − 2 h, end + 2 h]`.
pub fn navigation_text(start: Epoch, end: Epoch, seed: u64) -> String {
    let mut rng = Rng::new(seed).fork(0x6e6176);
    let sats = sats(&mut rng);
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
    // Reference epoch of the orbits: the start of the GPS week of `start`.
    let (week0, _) = week_tow(start);
    let t_ref = from_week_tow(week0, 0.0);
    let first = start - hifitime::Duration::from_seconds(2.0 * 3600.0);
    let last = end + hifitime::Duration::from_seconds(2.0 * 3600.0);
    let (w, tow) = week_tow(first);
    let mut toe = from_week_tow(w, (tow / 7200.0).floor() * 7200.0);
    while toe <= last {
        let (week, sow) = week_tow(toe);
        let dt_ref = (toe - t_ref).to_seconds();
        let week_start = from_week_tow(week, 0.0);
        let dweek = (week_start - t_ref).to_seconds();
        let (y, mo, d, h, mi, sec, _) = toe.to_gregorian(hifitime::TimeScale::GPST);
        for sat in &sats {
            let n = (sat.mu / sat.sqrt_a.powi(6)).sqrt();
            let m0 = grid_angle(wrap(sat.m_ref + n * dt_ref), -31);
            // Ω(t) = RAAN − ωe·(t − t_ref): broadcast Ω0 refers to the record's week start.
            let omega0 = grid_angle(wrap(sat.raan - gnss::frame::OMEGA_E * dweek), -31);
            let af0 = grid(sat.af0 + sat.af1 * dt_ref, clock_exp(sat.sys).0);
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
                [(dt_ref / 7200.0).rem_euclid(256.0).floor(), 0.0, 0.0, m0],
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
                [
                    2.0,
                    0.0,
                    0.0,
                    if sat.sys == 'E' {
                        0.0
                    } else {
                        (dt_ref / 7200.0).rem_euclid(256.0).floor()
                    },
                ],
                [sow - 3600.0_f64.min(sow), 4.0, 0.0, 0.0],
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
        toe += hifitime::Duration::from_seconds(7200.0);
        let _ = WEEK_SECONDS;
    }
    s
}
