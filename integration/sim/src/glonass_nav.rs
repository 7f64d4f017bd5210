//! The synthetic GLONASS-like constellation as RINEX 3.04 GLONASS navigation records: 24
//! satellites in 3 planes × 8 (slots 1–8, 9–16, 17–24; nodes 120° apart, satellites 45° apart
//! in a plane and 15° from plane to plane), a = 25 510 km, i = 64.8°, near-circular, on the
//! FDMA channels of the real constellation (−7…6, the two antipodal satellites of a plane
//! sharing one).
//!
//! Each satellite flies ONE trajectory: a Keplerian state at the reference epoch (the start of
//! the GPS week) integrated by ppkat's own GLONASS propagator ([`GlonassEph::compute`]: RK4
//! with J2 in the Earth-fixed frame, luni-solar accelerations 0) and sampled every 30 min, each
//! sample carried on from the last unrounded one. A record is such a sample, so switching from
//! one record to the next at the mid-point moves a satellite by well under a millimetre (the
//! integrator runs forward from one record and backward from the other), and the clock
//! (−τn + γn·(t − tb), one linear clock per satellite) does not jump at all.
//!
//! Records sit on the UTC half-hours (GLONASS records are in UTC; GPST − UTC from hifitime's
//! leap-second table, 18 s since 2017), luni-solar acceleration fields 0, health 0, age 0,
//! message frame time 15 min before tb (seconds of the UTC week). The values are written with
//! D19.12's 13 significant digits (0.01 mm in position) and NOT rounded to the broadcast
//! grid: RTCM 1020 would round positions to 2⁻¹¹ km (0.49 m) and τn to 2⁻³⁰ s (0.3 m), so a
//! GLONASS scenario encoded as RTCM (`simulate --raw rtcm3`) does not decode to these orbits
//! exactly as the GPS and Galileo ones do.
//!
//! Enters: the GPST span to cover, the reference epoch and the seed. Leaves: the records'
//! text (positions km, velocities km/s, accelerations km/s², as RINEX has them).

use super::rng::Rng;
use gnss::orbit::GlonassEph;
use hifitime::{Duration, Epoch, TimeScale};
use nalgebra::Vector3;
use std::f64::consts::PI;
use std::fmt::Write;

/// Gravitational constant of PZ-90 (the propagator's), m³/s².
const MU: f64 = 3.986_004_4e14;
/// Earth rotation rate of PZ-90 (the propagator's), rad/s.
const OMEGA: f64 = 7.292_115e-5;
/// Semi-major axis, metres.
const A: f64 = 25_510_000.0;
/// Inclination, degrees.
const INC_DEG: f64 = 64.8;
/// Seconds between records.
pub const INTERVAL_S: f64 = 1800.0;

/// Frequency channel of slots 1–24, as the real constellation has them (slots k and k + 4 of
/// a plane, 180° apart, share a channel).
pub const CHANNELS: [i8; 24] = [
    1, -4, 5, 6, 1, -4, 5, 6, // plane 1
    -2, -7, 0, -1, -2, -7, 0, -1, // plane 2
    4, -3, 3, 2, 4, -3, 3, 2, // plane 3
];

/// One satellite: its state at the reference epoch and its clock.
struct GloSat {
    slot: u8,
    /// Position (m) and velocity (m/s), Earth-fixed, at the reference epoch.
    pos: Vector3<f64>,
    vel: Vector3<f64>,
    /// Clock offset −τ (s) at the reference epoch and its rate γ.
    clock0: f64,
    gamma: f64,
}

/// Position and velocity of Keplerian elements (radians, metres) in the frame whose axes
/// the node longitude `raan` refers to.
fn kepler_state(e: f64, inc: f64, raan: f64, omega: f64, m: f64) -> (Vector3<f64>, Vector3<f64>) {
    let mut ea = m;
    for _ in 0..20 {
        ea = m + e * ea.sin();
    }
    let nu = ((1.0 - e * e).sqrt() * ea.sin()).atan2(ea.cos() - e);
    let p = A * (1.0 - e * e);
    let r = p / (1.0 + e * nu.cos());
    let vf = (MU / p).sqrt();
    let (pq_r, pq_v) = (
        Vector3::new(r * nu.cos(), r * nu.sin(), 0.0),
        Vector3::new(-vf * nu.sin(), vf * (e + nu.cos()), 0.0),
    );
    let rot = nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), raan)
        * nalgebra::Rotation3::from_axis_angle(&Vector3::x_axis(), inc)
        * nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), omega);
    (rot * pq_r, rot * pq_v)
}

/// The 24 satellites at the reference epoch; eccentricity, inclination offsets, perigees and
/// clocks drawn from `rng`.
fn sats(rng: &mut Rng) -> Vec<GloSat> {
    let mut out = Vec::with_capacity(24);
    for p in 0..3 {
        for k in 0..8 {
            let e = rng.range(0.0002, 0.002);
            let inc = (INC_DEG + rng.range(-0.3, 0.3)).to_radians();
            let omega = rng.range(0.0, 2.0 * PI);
            let raan = 2.0 * PI * p as f64 / 3.0 + 0.3;
            let u = 2.0 * PI * (k as f64 / 8.0 + p as f64 / 24.0);
            let (pos, v_inertial) = kepler_state(e, inc, raan, omega, u - omega);
            // Earth-fixed velocity: the inertial one minus ω × r.
            let vel = v_inertial - Vector3::new(0.0, 0.0, OMEGA).cross(&pos);
            out.push(GloSat {
                slot: (8 * p + k + 1) as u8,
                pos,
                vel,
                clock0: rng.range(-1e-4, 1e-4),
                gamma: (rng.range(-3.0, 3.0).round()) * 2f64.powi(-40),
            });
        }
    }
    out
}

/// `state` at `from` carried to `to` by the propagator ppkat reads GLONASS records with.
fn propagate(pos: Vector3<f64>, vel: Vector3<f64>, from: Epoch, to: Epoch) -> GlonassEph {
    let eph = GlonassEph {
        slot: 0,
        toe: from,
        minus_tau: 0.0,
        gamma: 0.0,
        pos,
        vel,
        acc: Vector3::zeros(),
        health: 0,
        channel: 0,
        line: 0,
    };
    let s = eph.compute(to);
    GlonassEph {
        toe: to,
        pos: s.pos.0,
        vel: s.vel,
        ..eph
    }
}

fn d19(v: f64) -> String {
    format!("{:>19}", format!("{v:.12E}"))
}

/// The UTC half-hour at or before GPST `t`, as a GPST epoch.
fn half_hour_before(t: Epoch) -> Epoch {
    let (y, mo, d, h, mi, _, _) = t.to_gregorian(TimeScale::UTC);
    let e = Epoch::from_gregorian(y, mo, d, h, mi - mi % 30, 0, 0, TimeScale::UTC);
    gnss::time::to_gpst(e)
}

/// The GLONASS records of every UTC half-hour from the one at or before `first` to `last`
/// (GPST), the trajectories starting from Keplerian states at `t_ref`.
pub(super) fn records(first: Epoch, last: Epoch, t_ref: Epoch, seed: u64) -> String {
    let sats = sats(&mut Rng::new(seed).fork(0x676c6f));
    let tb0 = half_hour_before(first);
    let mut states: Vec<GlonassEph> = sats
        .iter()
        .map(|s| propagate(s.pos, s.vel, t_ref, tb0))
        .collect();
    let mut out = String::new();
    let mut tb = tb0;
    while tb <= last {
        let (y, mo, d, h, mi, sec, _) = tb.to_gregorian(TimeScale::UTC);
        // Seconds of the UTC week: the UTC calendar read as GPST's.
        let utc_as_gpst = Epoch::from_gregorian(y, mo, d, h, mi, sec, 0, TimeScale::GPST);
        let tk = (gnss::time::week_tow(utc_as_gpst).1 - 900.0).rem_euclid(gnss::time::WEEK_SECONDS);
        for (sat, st) in sats.iter().zip(&states) {
            let minus_tau = sat.clock0 + sat.gamma * (tb - t_ref).to_seconds();
            let _ = writeln!(
                out,
                "R{:02} {y:04} {mo:02} {d:02} {h:02} {mi:02} {sec:02}{}{}{}",
                sat.slot,
                d19(minus_tau),
                d19(sat.gamma),
                d19(tk)
            );
            let extra = [0.0, CHANNELS[sat.slot as usize - 1] as f64, 0.0];
            for (j, x) in extra.iter().enumerate() {
                let _ = writeln!(
                    out,
                    "    {}{}{}{}",
                    d19(st.pos[j] / 1e3),
                    d19(st.vel[j] / 1e3),
                    d19(0.0),
                    d19(*x)
                );
            }
        }
        let next = tb + Duration::from_seconds(INTERVAL_S);
        for st in &mut states {
            *st = propagate(st.pos, st.vel, tb, next);
        }
        tb = next;
    }
    out
}
