//! The drone of the low-cost bench: a DJI Phantom 4 RTK-like flight of about eight minutes
//! whose receiver logs RTCM 3 MSM7 at 5 Hz (GPS, GLONASS, Galileo; L1/L2) into `PPKRAW.bin`
//! beside a `Timestamp.MRK` of its exposures, against a CORS's RINEX (L1/L2, 1 Hz) 1.7 km
//! away. Like the real log it imitates, `PPKRAW.bin` starts with stale GPS ephemerides the
//! receiver kept from earlier weeks (2018, 2019 and 2022, one at the very time of week of the
//! flight six weeks before), then the current GPS, GLONASS and Galileo ones (week 2024): the
//! log must be dated by their consensus, not by its first ephemeris.
//!
//! Enters: the output folder and a random stream. Leaves: `PPKRAW.bin`, `Timestamp.MRK`,
//! `base.obs`, `nav.rnx`, `ppk.toml`, `truth_trajectory.csv`, `truth_exposures.csv`, the
//! rover's RINEX (`rover_rinex.obs`) and `README.txt`; what was simulated.

use super::super::constellation::navigation_text_of;
use super::super::constellation::GpsLayout;
use super::super::error::SimError;
use super::super::flight::{Flight, FlightPlan};
use super::super::io::{write, write_bytes};
use super::super::rng::Rng;
use super::receiver::{self, GpsL1, LowCost, Profile, TrackStats};
use super::{constellation, gpst, truth_csv};
use gnss::frame::{enu_rotation, Ecef, Enu, Geodetic};
use gnss::raw::rtcm::message_number;
use gnss::raw::rtcm_eph_write::ephemeris_frame;
use gnss::raw::rtcm_msm::msm_kind;
use gnss::rinex::nav::{NavFile, NavRecord};
use gnss::rinex::ObsFile;
use gnss::sv::Constellation;
use hifitime::{Duration, Epoch};
use nalgebra::{Matrix3, Vector3};
use std::fmt::Write as _;
use std::path::Path;

/// The site (Nevada) and the take-off (GPST; 2018-10-24, GPS week 2024, a Wednesday).
const SITE: (f64, f64, f64) = (36.1162, -115.1420, 620.0);
const START: &str = "2018-10-24T17:30:00";
/// The CORS, ENU metres from the site.
const BASE: [f64; 3] = [1400.0, -900.0, 4.0];
/// The camera's offset from the antenna in the body frame (forward, right, down), metres.
const CAMERA: [f64; 3] = [0.03, 0.0, 0.17];
/// Seconds between exposures along a strip.
const EXPOSURE_EVERY: f64 = 2.0;

/// What the drone's simulation holds.
#[derive(Clone, Debug)]
pub struct DroneReport {
    /// The rover.
    pub rover: TrackStats,
    /// The CORS.
    pub base: TrackStats,
    /// Exposures in the MRK.
    pub exposures: usize,
    /// Stale ephemerides at the head of the log.
    pub stale: usize,
    /// The CORS position, ECEF.
    pub base_position: Ecef,
    /// Flight length, seconds.
    pub duration: f64,
}

/// A DJI-class multi-frequency receiver on a drone: open sky, short half cycles at arc starts,
/// noise and multipath as the walk's u-blox (the airframe reflects as the ground does).
fn drone_profile() -> Profile {
    Profile {
        cn0: (38.0, 52.0),
        canopy_db: (0.0, 0.0, 1.0),
        lock: (26.0, 29.0),
        half_s: [(0.5, 2.5), (0.5, 2.0)],
        half_offset_probability: 0.5,
        unflagged_slip_rate: 0.0005,
        code: (0.3, 0.5, 8.0),
        phase: (0.0015, 0.004, 1.0),
        doppler: 0.03,
        glonass_icb: (0.004, 0.12),
    }
}

/// A geodetic CORS receiver: no half cycles left, low noise, its own GLONASS biases.
fn cors_profile() -> Profile {
    Profile {
        cn0: (40.0, 51.0),
        half_s: [(0.0, 0.0), (0.0, 0.0)],
        unflagged_slip_rate: 0.0,
        code: (0.15, 0.15, 30.0),
        phase: (0.001, 0.0015, 10.0),
        doppler: 0.02,
        glonass_icb: (-0.009, -0.2),
        ..drone_profile()
    }
}

/// The flight: five strips of 350 m at 8 m/s, 80 m up, after 40 s on the ground.
fn plan() -> FlightPlan {
    FlightPlan {
        altitude: 80.0,
        speed: 8.0,
        strips: 5,
        strip_length: 350.0,
        strip_spacing: 45.0,
        heading: 25f64.to_radians(),
        static_start: 40.0,
        start: Vector3::new(-180.0, -160.0, 1.2),
    }
}

/// Body (forward, right, down) to ENU for a yaw (from north, clockwise), pitch and roll.
fn body_to_enu(yaw: f64, pitch: f64, roll: f64) -> Matrix3<f64> {
    let (sy, cy, sp, cp, sr, cr) = (
        yaw.sin(),
        yaw.cos(),
        pitch.sin(),
        pitch.cos(),
        roll.sin(),
        roll.cos(),
    );
    // Body → NED (yaw-pitch-roll), then NED → ENU.
    let ned = Matrix3::new(
        cy * cp,
        cy * sp * sr - sy * cr,
        cy * sp * cr + sy * sr,
        sy * cp,
        sy * sp * sr + cy * cr,
        sy * sp * cr - cy * sr,
        -sp,
        cp * sr,
        cp * cr,
    );
    Matrix3::new(0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0) * ned
}

/// Simulate the drone into `dir`.
pub(super) fn drone(dir: &Path, rng: &Rng) -> Result<DroneReport, SimError> {
    let start = gpst(START)?;
    let site_geo = Geodetic::from_degrees(SITE.0, SITE.1, SITE.2);
    let site = site_geo.to_ecef();
    let rot = enu_rotation(&site_geo).transpose();
    let flight = Flight::new(&plan(), &mut rng.fork(4));
    let duration = flight.duration();
    let systems = [
        Constellation::Gps,
        Constellation::Glonass,
        Constellation::Galileo,
    ];
    let (base_start, base_end) = (
        start - Duration::from_seconds(120.0),
        start + Duration::from_seconds(duration + 120.0),
    );
    let (nav, eph) = constellation(
        dir,
        (base_start, base_end),
        2024,
        &systems,
        GpsLayout::Baseline24,
    )?;
    let klob = nav.gps_iono.unwrap_or_default();
    let rover_at = |t: Epoch| {
        let s = flight.at((t - start).to_seconds());
        (Enu(s.pos).to_ecef(&site), rot * s.vel)
    };
    let base_pos = Enu(Vector3::from(BASE)).to_ecef(&site);
    let base_at = move |_t: Epoch| (base_pos, Vector3::zeros());
    let open = |_t: f64| 0.0;
    let rover = LowCost {
        name: "P4RTK",
        at: &rover_at,
        canopy: &open,
        clock: (1.5e-4, 1.2e-8),
        span: (start, start + Duration::from_seconds(duration), 0.2),
        bands: 2,
        mask_deg: 10.0,
        atmosphere: None,
        code_bias: [0.0; 2],
        gps_l1: GpsL1::CaAsP,
        impair: None,
        profile: drone_profile(),
    };
    let base = LowCost {
        name: "CORS",
        at: &base_at,
        canopy: &open,
        clock: (-2.0e-5, 0.0),
        span: (base_start, base_end, 1.0),
        bands: 2,
        mask_deg: 5.0,
        atmosphere: None,
        code_bias: [0.0; 2],
        gps_l1: GpsL1::CaAsP,
        impair: None,
        profile: cors_profile(),
    };
    let (rtext, rstats) = receiver::simulate(&rover, &eph, &klob, &rng.fork(1), &|_| true);
    let (btext, bstats) = receiver::simulate(&base, &eph, &klob, &rng.fork(2), &|_| true);
    let rover_rinex = write(dir, "rover_rinex.obs", &rtext)?;
    write(dir, "base.obs", &btext)?;
    let stale = stale_ephemerides(dir, start)?;
    let current: Vec<&NavRecord> = nav
        .records
        .iter()
        .filter(|r| (r.toc - start).to_seconds().abs() <= 7200.0)
        .collect();
    let log = ppkraw(&ObsFile::read(&rover_rinex)?, &stale, &current);
    write_bytes(dir, "PPKRAW.bin", &log)?;
    let exposures = exposure_times(&flight, start);
    write(
        dir,
        "Timestamp.MRK",
        &mrk(&flight, start, &site, &exposures, rng),
    )?;
    write(
        dir,
        "truth_exposures.csv",
        &truth_exposures(&flight, start, &site, &exposures),
    )?;
    write(
        dir,
        "truth_trajectory.csv",
        &truth_csv(start, duration, 0.2, rover.clock, &rover_at),
    )?;
    let toml = format!(
        "# ppkat ppk --config ppk.toml: the simulated DJI flight (see README.txt)\n\
         rover = \"PPKRAW.bin\"\nbase = \"base.obs\"\nbase_pos = \"{:.4},{:.4},{:.4}\"\n\
         out = \"ppk.pos\"\n",
        base_pos.0.x, base_pos.0.y, base_pos.0.z
    );
    write(dir, "ppk.toml", &toml)?;
    Ok(DroneReport {
        rover: rstats,
        base: bstats,
        exposures: exposures.len(),
        stale: stale.len(),
        base_position: base_pos,
        duration,
    })
}

/// GPS ephemerides of the same constellation as broadcast 6, 5 and 2 weeks before the
/// flight (weeks 2018, 2019, 2022): one set at the flight's own time of week six weeks before,
/// the others a day earlier in their week; three satellites each. Their navigation files
/// are kept in `dir/stale/` (what the receiver remembered).
fn stale_ephemerides(dir: &Path, start: Epoch) -> Result<Vec<NavRecord>, SimError> {
    let week = Duration::from_seconds(604_800.0);
    let mut out = Vec::new();
    for (weeks, shift_h) in [(6.0, 0.0), (5.0, -24.0), (2.0, -24.0)] {
        let t = start - week * weeks + Duration::from_seconds(shift_h * 3600.0);
        let text = navigation_text_of(
            t,
            t + Duration::from_seconds(3600.0),
            2024,
            &[Constellation::Gps],
        );
        let (w, _) = gnss::time::week_tow(t);
        let path = write(&dir.join("stale"), &format!("week{w}.rnx"), &text)?;
        let nav = NavFile::read(&path)?;
        out.extend(
            nav.records
                .into_iter()
                .filter(|r| (r.toc - t).to_seconds().abs() <= 3600.0)
                .take(3),
        );
    }
    Ok(out)
}

/// The rover's `PPKRAW.bin`: a 1033 naming the antenna, the stale ephemerides, then the
/// current ones, then the MSM7 frames of every epoch.
fn ppkraw(obs: &ObsFile, stale: &[NavRecord], current: &[&NavRecord]) -> Vec<u8> {
    // The simulated receivers share one antenna model (no phase-centre differences simulated),
    // which the log names as the CORS's RINEX does.
    let mut out = gnss::raw::rtcm_write::descriptor_1033(
        "PPKATSIM        NONE",
        "",
        "PPKAT SIMULATOR DJI",
        "1.0",
        "",
    );
    for r in stale.iter().chain(current.iter().copied()) {
        if let Some(f) = ephemeris_frame(r) {
            out.extend(f);
        }
    }
    let (rtcm, _) = gnss::raw::rtcm_write::rtcm_from_obs(obs, &[]);
    let mut i = 0;
    while i + 6 <= rtcm.len() {
        let n = gnss::raw::rtcm::payload_len(&rtcm[i..]) + 6;
        if msm_kind(message_number(&rtcm[i + 3..i + n - 3])).is_some() {
            out.extend_from_slice(&rtcm[i..i + n]);
        }
        i += n;
    }
    out
}

/// Exposure times (seconds from the start): every [`EXPOSURE_EVERY`] s along each strip.
fn exposure_times(flight: &Flight, _start: Epoch) -> Vec<f64> {
    let mut out = Vec::new();
    for (_, t0, dur) in flight.strips() {
        let mut t = t0 + 0.5;
        while t < t0 + dur - 0.5 {
            out.push(t);
            t += EXPOSURE_EVERY;
        }
    }
    out
}

/// The antenna (ECEF) and the camera's offset from it (ENU, m) at `t` seconds.
fn antenna_and_offset(flight: &Flight, site: &Ecef, t: f64) -> (Ecef, Vector3<f64>) {
    let s = flight.at(t);
    let r = body_to_enu(s.yaw, s.pitch, s.roll);
    (Enu(s.pos).to_ecef(site), r * Vector3::from(CAMERA))
}

/// The `Timestamp.MRK`: index, GPS seconds of week, [week], the camera's offset from the
/// antenna N, E, V (mm, V down), the drone's own RTK position of the antenna (a few cm of
/// noise), its sigmas and quality 50 (fixed).
fn mrk(flight: &Flight, start: Epoch, site: &Ecef, times: &[f64], rng: &Rng) -> String {
    let mut rng = rng.fork(9);
    let mut s = String::new();
    for (k, &t) in times.iter().enumerate() {
        let (ant, off) = antenna_and_offset(flight, site, t);
        let g = Ecef(ant.0 + Vector3::new(rng.normal(), rng.normal(), rng.normal()) * 0.02)
            .to_geodetic();
        let (w, tow) = gnss::time::week_tow(start + Duration::from_seconds(t));
        let _ = writeln!(
            s,
            "{}\t{tow:.6}\t[{w}]\t{:6.0},N\t{:6.0},E\t{:6.0},V\t{:.8},Lat\t{:.8},Lon\t{:.3},Ellh\t0.012345, 0.011234, 0.023456\t50,Q",
            k + 1,
            off.y * 1000.0,
            off.x * 1000.0,
            -off.z * 1000.0,
            g.lat.to_degrees(),
            g.lon.to_degrees(),
            g.h
        );
    }
    s
}

/// The exposures' truth: index, GPS week and seconds, camera centre and antenna (ECEF).
fn truth_exposures(flight: &Flight, start: Epoch, site: &Ecef, times: &[f64]) -> String {
    let mut s = String::from("# exposures of the simulated DJI flight, true GPST; camera centre S and antenna A, ECEF metres\nid,week,tow,xs,ys,zs,xa,ya,za\n");
    for (k, &t) in times.iter().enumerate() {
        let (ant, off) = antenna_and_offset(flight, site, t);
        let cam = Enu(off).to_ecef(&ant);
        let (w, tow) = gnss::time::week_tow(start + Duration::from_seconds(t));
        let _ = writeln!(
            s,
            "DJI_{:04},{w},{tow:.6},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4}",
            k + 1,
            cam.0.x,
            cam.0.y,
            cam.0.z,
            ant.0.x,
            ant.0.y,
            ant.0.z
        );
    }
    s
}
