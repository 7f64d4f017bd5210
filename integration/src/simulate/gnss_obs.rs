//! Simulated GNSS observations (RINEX 3.04): geometric range with light time and Earth
//! rotation, satellite and receiver clocks, troposphere, frequency-scaled ionosphere,
//! elevation-dependent code and phase noise, multipath, integer ambiguities, cycle slips and
//! data gaps — each switchable — and flag-5 event records at exposure times.

use super::rng::Rng;
use super::ErrorModel;
use gnss::frame::{az_el, Ecef};
use gnss::model::{klobuchar_gps, troposphere};
use gnss::orbit::{Ephemerides, C};
use gnss::rinex::nav::Klobuchar;
use gnss::sv::{Constellation, Sv};
use gnss::time::week_tow;
use hifitime::{Duration, Epoch, TimeScale};
use nalgebra::Vector3;
use std::collections::HashMap;
use std::fmt::Write as _;

const OMEGA_E: f64 = 7.292_115_146_7e-5;
const F1: f64 = 1575.42e6;
/// Second frequency: GPS L2, Galileo E5a.
fn f2(sys: Constellation) -> f64 {
    if sys == Constellation::Galileo {
        1176.45e6
    } else {
        1227.60e6
    }
}
/// Elevation below which the simulated receivers track nothing.
const SIM_MASK_DEG: f64 = 5.0;

/// A receiver to simulate.
pub struct Receiver<'a> {
    pub name: &'a str,
    /// ECEF position at a true GPST time.
    pub pos: &'a dyn Fn(Epoch) -> Ecef,
    /// Clock offset (s) at the start and drift (s/s).
    pub clock: (f64, f64),
    pub start: Epoch,
    pub end: Epoch,
    pub interval: f64,
    /// True times of external events (camera exposures), written as flag-5 records.
    pub events: &'a [Epoch],
    /// Random cycle slips and gaps are injected in this receiver.
    pub faults: bool,
}

/// One satellite as observed (before formatting).
#[derive(Clone, Copy, Debug)]
pub struct SatObs {
    pub sv: Sv,
    /// C1, L1 (cycles), D1 (Hz), S1, C2, L2, D2, S2.
    pub v: [f64; 8],
    pub lli: [u8; 2],
}

/// Per-satellite persistent state of a receiver.
struct Track {
    amb: [f64; 2],
    mp_phase: f64,
    mp_period: f64,
}

/// What was simulated, for the report.
#[derive(Clone, Debug, Default)]
pub struct ObsStats {
    pub epochs: usize,
    pub sat_records: usize,
    pub slips: usize,
    pub gap_records: usize,
    pub bytes: usize,
}

fn clock_at(rx: &Receiver, t: Epoch, on: bool) -> f64 {
    if !on {
        return 0.0;
    }
    rx.clock.0 + rx.clock.1 * (t - rx.start).to_seconds()
}

/// Geometric range with light time and Earth rotation from the receiver at true time `t`;
/// returns (range, range rate, satellite clock incl. relativity, clock rate, sat position).
pub fn geometry(
    eph: &Ephemerides,
    sv: Sv,
    t: Epoch,
    rx: &Vector3<f64>,
    rx_vel: &Vector3<f64>,
) -> Option<(f64, f64, f64, f64, Vector3<f64>)> {
    let mut tau = 0.075;
    let mut out = None;
    for _ in 0..3 {
        let ttx = t - Duration::from_seconds(tau);
        let e = eph.select(sv, ttx)?;
        let s = e.compute(ttx);
        let th = OMEGA_E * tau;
        let (sn, cs) = th.sin_cos();
        let rot = |v: Vector3<f64>| Vector3::new(cs * v.x + sn * v.y, -sn * v.x + cs * v.y, v.z);
        let sp = rot(s.pos.0);
        let sv_vel = rot(s.vel);
        let d = sp - rx;
        let rho = d.norm();
        let rate = d.dot(&(sv_vel - rx_vel)) / rho;
        tau = rho / C;
        out = Some((rho, rate, s.clock, s.clock_rate, sp));
    }
    out
}

/// Simulate one receiver: RINEX text and counts.
pub fn simulate(
    rx: &Receiver,
    eph: &Ephemerides,
    klob: &Klobuchar,
    err: &ErrorModel,
    rng: &Rng,
) -> (String, ObsStats) {
    let sats: Vec<Sv> = eph.satellites().copied().collect();
    let mut rng_noise = rng.fork(1);
    let mut rng_fault = rng.fork(2);
    let mut tracks: HashMap<Sv, Track> = HashMap::new();
    let mut stats = ObsStats::default();
    let n_epochs = ((rx.end - rx.start).to_seconds() / rx.interval).floor() as usize + 1;
    // Faults: slips (epoch, satellite index, frequency) and gaps (start epoch, length, satellite).
    let mut slips: Vec<(usize, usize, usize)> = Vec::new();
    let mut gaps: Vec<(usize, usize, usize)> = Vec::new();
    if rx.faults {
        for _ in 0..err.cycle_slips {
            slips.push((
                (rng_fault.uniform() * n_epochs as f64) as usize,
                (rng_fault.uniform() * sats.len() as f64) as usize,
                (rng_fault.uniform() * 2.0) as usize,
            ));
        }
        for _ in 0..err.gaps {
            let len = (rng_fault.range(5.0, 30.0) / rx.interval) as usize;
            gaps.push((
                (rng_fault.uniform() * n_epochs as f64) as usize,
                len,
                (rng_fault.uniform() * sats.len() as f64) as usize,
            ));
        }
    }
    let mut body = String::with_capacity(n_epochs * 600);
    let mut events: Vec<Epoch> = rx
        .events
        .iter()
        .map(|t| *t + Duration::from_seconds(clock_at(rx, *t, err.receiver_clock)))
        .collect();
    events.sort();
    let mut ev_i = 0;
    let mut first_pos = None;
    for k in 0..n_epochs {
        let tag = rx.start + Duration::from_seconds(k as f64 * rx.interval);
        // Event records that fall before this epoch's tag.
        while ev_i < events.len() && events[ev_i] < tag {
            let _ = writeln!(body, "> {}  5  0", epoch_fields(events[ev_i]));
            ev_i += 1;
        }
        let dtr = clock_at(rx, tag, err.receiver_clock);
        let t = tag - Duration::from_seconds(dtr);
        let p = (rx.pos)(t);
        let p2 = (rx.pos)(t + Duration::from_seconds(0.01));
        let vel = (p2.0 - p.0) / 0.01;
        first_pos.get_or_insert(p);
        let g = p.to_geodetic();
        let (_, tow) = week_tow(t);
        let mut recs: Vec<SatObs> = Vec::new();
        for (si, &sv) in sats.iter().enumerate() {
            if gaps
                .iter()
                .any(|&(s, len, gs)| gs == si && k >= s && k < s + len)
            {
                stats.gap_records += 1;
                continue;
            }
            let Some((rho, rate, dts, dts_rate, sp)) = geometry(eph, sv, t, &p.0, &vel) else {
                continue;
            };
            let (az, el) = az_el(&p, &g, &Ecef(sp));
            if el < SIM_MASK_DEG.to_radians() {
                tracks.remove(&sv);
                continue;
            }
            let tr = tracks.entry(sv).or_insert_with(|| Track {
                amb: if err.ambiguities {
                    [
                        (rng_noise.uniform() * 2.0e6 - 1.0e6).round(),
                        (rng_noise.uniform() * 2.0e6 - 1.0e6).round(),
                    ]
                } else {
                    [0.0, 0.0]
                },
                mp_phase: rng_noise.range(0.0, 6.3),
                mp_period: rng_noise.range(200.0, 600.0),
            });
            let mut lli = [0u8; 2];
            for &(s, gs, f) in &slips {
                if s == k && gs == si {
                    tr.amb[f] += rng_fault.range(1.0, 20.0).round();
                    lli[f] |= 1;
                    stats.slips += 1;
                }
            }
            let trop = if err.troposphere {
                troposphere(&g, el)
            } else {
                0.0
            };
            let i1 = if err.ionosphere {
                klobuchar_gps(klob, &g, az, el, tow)
            } else {
                0.0
            };
            let se = el.sin();
            let noise = |sigma: f64, r: &mut Rng| {
                if sigma > 0.0 {
                    sigma * (0.5 + 0.5 / se) * r.normal()
                } else {
                    0.0
                }
            };
            let ts = (t - rx.start).to_seconds();
            let mp = if err.multipath {
                (-el.to_degrees() / 20.0).exp()
                    * (2.0 * std::f64::consts::PI * ts / tr.mp_period + tr.mp_phase).sin()
            } else {
                0.0
            };
            let base = rho + C * (dtr - dts);
            let rate_all = rate + C * (err.receiver_clock as u8 as f64 * rx.clock.1 - dts_rate);
            let mut v = [0.0; 8];
            for (f, freq) in [F1, f2(sv.sys)].into_iter().enumerate() {
                let lam = C / freq;
                let i = i1 * (F1 / freq).powi(2);
                let code = base + trop + i + 0.5 * mp + noise(err.code_noise, &mut rng_noise);
                let phase = base + trop - i + 0.005 * mp + noise(err.phase_noise, &mut rng_noise);
                v[4 * f] = code;
                v[4 * f + 1] = phase / lam + tr.amb[f];
                v[4 * f + 2] = -rate_all / lam
                    + if err.code_noise > 0.0 {
                        0.02 * rng_noise.normal()
                    } else {
                        0.0
                    };
                v[4 * f + 3] = (30.0 + 20.0 * se).round();
            }
            recs.push(SatObs { sv, v, lli });
        }
        stats.epochs += 1;
        stats.sat_records += recs.len();
        let _ = writeln!(body, "> {}  0{:3}", epoch_fields(tag), recs.len());
        for r in &recs {
            let _ = write!(body, "{}", r.sv);
            let ssi = char::from(b'0' + ((r.v[3].min(54.0) / 6.0) as u8).clamp(1, 9));
            for (j, val) in r.v.iter().enumerate() {
                let lli = match j {
                    1 if r.lli[0] > 0 => char::from(b'0' + r.lli[0]),
                    5 if r.lli[1] > 0 => char::from(b'0' + r.lli[1]),
                    _ => ' ',
                };
                let ssi = if j % 4 < 2 { ssi } else { ' ' };
                let _ = write!(body, "{val:14.3}{lli}{ssi}");
            }
            body.push('\n');
        }
    }
    while ev_i < events.len() {
        let _ = writeln!(body, "> {}  5  0", epoch_fields(events[ev_i]));
        ev_i += 1;
    }
    let header = header(rx, first_pos.unwrap_or(Ecef::new(0.0, 0.0, 0.0)));
    let text = header + &body;
    stats.bytes = text.len();
    (text, stats)
}

/// `yyyy mm dd hh mm ss.sssssss` as RINEX 3 epoch lines have it (seconds F11.7).
fn epoch_fields(t: Epoch) -> String {
    // Round to 100 ns first so that a time like 59.99999999 does not print as 60.
    let t = Epoch::from_gpst_nanoseconds(
        ((t.to_gpst_nanoseconds().unwrap_or(0) as f64 / 100.0).round() * 100.0) as u64,
    );
    let (y, mo, d, h, mi, s, ns) = t.to_gregorian(TimeScale::GPST);
    format!(
        "{y:04} {mo:02} {d:02} {h:02} {mi:02}{:11.7}",
        s as f64 + ns as f64 * 1e-9
    )
}

fn header(rx: &Receiver, p: Ecef) -> String {
    let mut s = String::new();
    let mut line = |a: String, b: &str| {
        let _ = writeln!(s, "{a:<60}{b}");
    };
    line(
        "     3.04           OBSERVATION DATA    M".into(),
        "RINEX VERSION / TYPE",
    );
    line("ppkat simulate      ppkat".into(), "PGM / RUN BY / DATE");
    line(
        "Simulated by ppkat: synthetic constellation, exact truth".into(),
        "COMMENT",
    );
    line(rx.name.to_string(), "MARKER NAME");
    line(format!("{:<20}{:<20}", "SIM", "PPKAT"), "OBSERVER / AGENCY");
    line(
        format!("{:<20}{:<20}{:<20}", "1", "PPKAT SIMULATOR", "1.0"),
        "REC # / TYPE / VERS",
    );
    line(
        format!("{:<20}{:<20}", "1", "PPKATSIM        NONE"),
        "ANT # / TYPE",
    );
    line(
        format!("{:14.4}{:14.4}{:14.4}", p.0.x, p.0.y, p.0.z),
        "APPROX POSITION XYZ",
    );
    line(
        format!("{:14.4}{:14.4}{:14.4}", 0.0, 0.0, 0.0),
        "ANTENNA: DELTA H/E/N",
    );
    line(
        "G    8 C1C L1C D1C S1C C2W L2W D2W S2W".into(),
        "SYS / # / OBS TYPES",
    );
    line(
        "E    8 C1C L1C D1C S1C C5Q L5Q D5Q S5Q".into(),
        "SYS / # / OBS TYPES",
    );
    line(format!("{:10.3}", rx.interval), "INTERVAL");
    let (y, mo, d, h, mi, sec, ns) = rx.start.to_gregorian(TimeScale::GPST);
    line(
        format!(
            "{y:6}{mo:6}{d:6}{h:6}{mi:6}{:13.7}     GPS",
            sec as f64 + ns as f64 * 1e-9
        ),
        "TIME OF FIRST OBS",
    );
    line(String::new(), "END OF HEADER");
    s
}
