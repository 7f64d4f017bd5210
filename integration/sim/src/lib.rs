#![deny(missing_docs)]
//! # sim — the simulator, with exact truth
//!
//! The flight simulator (`ppkat simulate`). Enters: a [`Scenario`] (TOML or built-in) and a folder. Leaves, in
//! that folder: base and rover RINEX 3.04 observations with flag-5 exposure events
//! ([`gnss_obs`]), a navigation file of synthetic constellations ([`constellation`]: GPS-
//! and Galileo-like by default, GLONASS- and QZSS-like when the scenario asks), the
//! exact truth (antenna trajectory, projection centres and attitudes, ground points, image
//! observations, blunders; written by `truth`) and a [`SimReport`]. Uses `gnss` (frames,
//! orbits, models, the navigation reader and the raw-log writers), `photo` (cameras,
//! rotations), `exposure` (attitude, exports), `adjust` (camera sections, project schema)
//! and `common` (atomic outputs); `integration`'s demo and the tests consume its files. Deterministic for a seed ([`rng`]).
//!
//! IMU data: [`imu`] puts a data sheet's noise and biases on the ideal increments
//! `ins::inverse` computes along a motion, and returns the true biases.
//!
//! Also here: simulated adjustment projects with truth ([`block`], [`closerange`]), which
//! write `ppkat adjust` inputs instead of GNSS files.
//!
//! Shared by the parts, each importing none of its users: `error` ([`SimError`]), `io` (the
//! file writer), `scenario` (the schema, [`ErrorModel`] among it), `site` (the ENU frame) and
//! `ground_points`. This module only runs a scenario from them.
//!
//! Frames and time: positions are built in the east-north-up frame at the site and written in
//! ECEF or geodetic coordinates; true times are GPST, receiver time tags are true time plus the
//! receiver clock offset.

mod builtin;
pub use builtin::{builtin, BUILTINS};
pub mod block;
pub use block::textured;
pub mod camera;
pub mod closerange;
pub mod constellation;
mod error;
pub mod flight;
mod glonass_nav;
pub mod gnss_obs;
mod ground_points;
pub mod imu;
pub mod ins_block;
pub mod ins_flight;
pub mod ins_motion;
mod io;
pub mod longbase;
pub mod longbase_faults;
pub mod lowcost;
mod obs_text;
pub mod rng;
mod scenario;
mod site;
mod truth;
pub use error::SimError;
pub use scenario::{
    BaseSpec, CameraToml, ErrorModel, FlightSpec, GnssSpec, GroundSpec, Scenario, SimSystem, Site,
};

use camera::{CameraSpec, Exposure, GroundPoint, ImageObs};
use flight::Flight;
use gnss::frame::Ecef;
use gnss::orbit::Ephemerides;
use gnss::rinex::nav::{Klobuchar, NavFile};
use gnss::rinex::ObsFile;
use hifitime::{Duration, Epoch};
use io::write;
use rng::Rng;
use site::SiteFrame;
use std::path::{Path, PathBuf};

/// What a simulation wrote.
#[derive(Clone, Debug)]
pub struct SimReport {
    /// The folder written.
    pub dir: PathBuf,
    /// Rover observations (RINEX 3.04).
    pub rover: PathBuf,
    /// Base observations (RINEX 3.04).
    pub base: PathBuf,
    /// Navigation file of the synthetic constellation.
    pub nav: PathBuf,
    /// First epoch of the flight (GPST, true time).
    pub start: Epoch,
    /// Length of the flight, seconds.
    pub duration_s: f64,
    /// What the rover file holds.
    pub rover_stats: gnss_obs::ObsStats,
    /// What the base file holds.
    pub base_stats: gnss_obs::ObsStats,
    /// Camera exposures (flag-5 events in the rover file).
    pub exposures: usize,
    /// Ground points.
    pub points: usize,
    /// Image observations.
    pub image_obs: usize,
    /// True base antenna position, ECEF.
    pub base_position: Ecef,
    /// Wall time of the simulation, seconds.
    pub seconds: f64,
}

impl std::fmt::Display for SimReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "simulated {:.0} s of flight in {:.2} s → {}",
            self.duration_s,
            self.seconds,
            self.dir.display()
        )?;
        writeln!(
            f,
            "  rover: {} epochs, {} satellite records, {} slips, {} MB",
            self.rover_stats.epochs,
            self.rover_stats.sat_records,
            self.rover_stats.slips,
            self.rover_stats.bytes as f64 / 1e6
        )?;
        writeln!(
            f,
            "  base:  {} epochs at {:.4} {:.4} {:.4} (ECEF)",
            self.base_stats.epochs,
            self.base_position.0.x,
            self.base_position.0.y,
            self.base_position.0.z
        )?;
        writeln!(
            f,
            "  {} exposures, {} ground points, {} image observations",
            self.exposures, self.points, self.image_obs
        )
    }
}

/// The analytic flight of a scenario: the path, its start epoch and a function giving the
/// true antenna position (ECEF) at a GPST epoch — for tests that need truth between samples.
pub fn truth_flight(s: &Scenario) -> Result<impl Fn(Epoch) -> Ecef, SimError> {
    let start = s.start_epoch()?;
    let site = SiteFrame::of(s);
    let flight = Flight::new(&s.plan(), &mut Rng::new(s.seed).fork(3));
    Ok(move |t: Epoch| site.to_ecef(&flight.at((t - start).to_seconds()).pos))
}

/// Run a scenario into `dir` (created if needed).
pub fn run(s: &Scenario, dir: &Path) -> Result<SimReport, SimError> {
    s.validate()?;
    let t_start = std::time::Instant::now();
    std::fs::create_dir_all(dir).map_err(gnss::Error::io(dir))?;
    let rng = Rng::new(s.seed);
    let start = s.start_epoch()?;
    let site = SiteFrame::of(s);
    let plan = s.plan();
    let flight = Flight::new(&plan, &mut rng.fork(3));
    let duration = flight.duration();
    let end = start + Duration::from_seconds(duration);
    let (nav_path, eph, klob) = broadcast_orbits(dir, start, end, s)?;
    let cam = s.camera();
    let exps = camera::exposures(
        &flight,
        &cam,
        s.flight.altitude,
        s.flight.speed,
        s.camera.forward_overlap,
    );
    let (points, obs) = ground_and_images(s, &cam, &exps, plan.heading, &mut rng.fork(4))?;
    // GNSS observations.
    let event_times: Vec<Epoch> = exps
        .iter()
        .map(|e| start + Duration::from_seconds(e.t))
        .collect();
    let rover_pos = |t: Epoch| site.to_ecef(&flight.at((t - start).to_seconds()).pos);
    let rover = gnss_obs::Receiver {
        name: "ROVER",
        pos: &rover_pos,
        clock: (2.0e-4, 3.0e-9),
        start,
        end,
        interval: 1.0 / s.flight.rate_hz,
        events: &event_times,
        faults: true,
        lose_lock: &lose_lock_times(s, &flight, start, &mut rng.fork(7)),
        glonass_phase_icb: s.errors.glonass_icb_m_per_channel[0],
        glonass_code_icb: s.errors.glonass_code_icb_m_per_channel[0],
    };
    let base_ecef = site.to_ecef(&s.base_enu());
    let base_pos = move |_t: Epoch| base_ecef;
    let base = gnss_obs::Receiver {
        name: "BASE",
        pos: &base_pos,
        clock: (-1.0e-4, -2.0e-9),
        start,
        end,
        interval: s.base.interval_s,
        events: &[],
        faults: false,
        lose_lock: &[],
        glonass_phase_icb: s.errors.glonass_icb_m_per_channel[1],
        glonass_code_icb: s.errors.glonass_code_icb_m_per_channel[1],
    };
    let (rtext, rstats) = gnss_obs::simulate(&rover, &eph, &klob, &s.errors, &rng.fork(5));
    let (btext, bstats) = gnss_obs::simulate(&base, &eph, &klob, &s.errors, &rng.fork(6));
    let rover_path = write(dir, "rover.obs", &rtext)?;
    let base_path = write(dir, "base.obs", &btext)?;
    let truth = truth::Truth {
        flight: &flight,
        start,
        exposures: &exps,
        points: &points,
        obs: &obs,
        rover_clock: if s.errors.receiver_clock {
            rover.clock
        } else {
            (0.0, 0.0)
        },
    };
    truth::write_all(dir, s, &site, &truth)?;
    Ok(SimReport {
        dir: dir.to_path_buf(),
        rover: rover_path,
        base: base_path,
        nav: nav_path,
        start,
        duration_s: duration,
        rover_stats: rstats,
        base_stats: bstats,
        exposures: exps.len(),
        points: points.len(),
        image_obs: obs.len(),
        base_position: base_ecef,
        seconds: t_start.elapsed().as_secs_f64(),
    })
}

/// When the rover loses lock on every satellite (true GPST, sorted): at each strip start
/// (`slips_at_turns`) and once more a random time after it (`float_segment_s`).
fn lose_lock_times(s: &Scenario, flight: &Flight, start: Epoch, rng: &mut Rng) -> Vec<Epoch> {
    let mut t = Vec::new();
    for (_, t0, dur) in flight.strips() {
        if s.errors.slips_at_turns {
            t.push(t0);
        }
        if let Some([a, b]) = s.errors.float_segment_s {
            t.push(t0 + rng.range(a, b).min(dur));
        }
    }
    t.sort_by(f64::total_cmp);
    t.into_iter()
        .map(|x| start + Duration::from_seconds(x))
        .collect()
}

/// The rover and base of a simulation also as u-blox UBX logs (`rover.ubx`, `base.ubx`:
/// RXM-RAWX per epoch, TIM-TM2 per exposure), made from the RINEX files it wrote: their paths
/// and how many measurements UBX could not carry (none for the simulator's GPS L1/L2,
/// GLONASS L1/L2, Galileo E1/E5a and QZSS L1/L2).
pub fn write_ubx(rep: &SimReport) -> Result<(PathBuf, PathBuf, u64), SimError> {
    write_logs(rep, "ubx", gnss::raw::ubx_write::ubx_from_obs)
}

/// The rover's and base's RINEX files of a simulation re-encoded by `encode` (the log's bytes
/// and how many measurements it could not carry) into `rover.EXT` and `base.EXT`: their
/// paths and the measurements dropped in both.
fn write_logs(
    rep: &SimReport,
    ext: &str,
    encode: impl Fn(&ObsFile) -> (Vec<u8>, u64),
) -> Result<(PathBuf, PathBuf, u64), SimError> {
    let (rover_bytes, rover_dropped) = encode(&ObsFile::read(&rep.rover)?);
    let rover = io::write_bytes(&rep.dir, &format!("rover.{ext}"), &rover_bytes)?;
    drop(rover_bytes);
    let (base_bytes, base_dropped) = encode(&ObsFile::read(&rep.base)?);
    let base = io::write_bytes(&rep.dir, &format!("base.{ext}"), &base_bytes)?;
    Ok((rover, base, rover_dropped + base_dropped))
}

/// The rover and base of a simulation also as RTCM 3 logs (`rover.rtcm3`, `base.rtcm3`: 1005,
/// the constellations' ephemerides as 1019, 1044, 1046 and 1020, then MSM7 per system and epoch),
/// made from the RINEX files it wrote: their paths and how many measurements RTCM could not
/// carry. RTCM has no camera events (DJI writes them to a separate `.MRK` file). GLONASS
/// ephemerides come back rounded to the 1020 fields (positions 2⁻¹¹ km), unlike the others.
pub fn write_rtcm(rep: &SimReport) -> Result<(PathBuf, PathBuf, u64), SimError> {
    let nav = NavFile::read(&rep.nav)?;
    write_logs(rep, "rtcm3", |f| {
        gnss::raw::rtcm_write::rtcm_from_obs(f, &nav.records)
    })
}

/// The rover and base of a simulation also as Septentrio SBF logs (`rover.sbf`, `base.sbf`:
/// the constellation's ephemerides as GPSNav and GALNav, its Klobuchar parameters as GPSIon
/// and GPSUtc, then a MeasEpoch per epoch and an ExtEvent per exposure), made from the RINEX
/// files it wrote: their paths and how many measurements SBF could not carry (none for the
/// simulator's signals; GLONASS ephemerides as GLONav, none for QZSS, which the SBF writer
/// has no block for). SBF has no block for the station position or
/// antenna the RINEX header gives (a receiver logs them in its setup blocks, which ppkat does
/// not read).
pub fn write_sbf(rep: &SimReport) -> Result<(PathBuf, PathBuf, u64), SimError> {
    let nav = NavFile::read(&rep.nav)?;
    let iono = nav.gps_iono.map(|k| (k, nav.leap_seconds.unwrap_or(18)));
    write_logs(rep, "sbf", |f| {
        gnss::raw::sbf_write::sbf_from_obs(f, &nav.records, iono)
    })
}

/// The synthetic constellation of a simulation also as precise orbits (`orbits.sp3`, SP3-c,
/// frame WGS84, time GPS): every satellite's position and clock every 5 minutes from an hour
/// before the flight's first epoch to an hour after its last, as the simulation computed them
/// from its navigation file (the clocks without the relativistic correction, as SP3 has them;
/// no group delay). Lets `ppk`, `spp` and `ppp` be tried with `--sp3` and without `--nav`.
/// Its path.
pub fn write_sp3(rep: &SimReport) -> Result<PathBuf, SimError> {
    let eph = Ephemerides::from_nav(&[NavFile::read(&rep.nav)?]);
    let step = 300.0;
    let (week, sow) = gnss::time::week_tow(rep.start);
    let from = (sow / step).floor() * step - 3600.0;
    let n = ((rep.duration_s + 7200.0) / step).ceil() as usize + 2;
    let epochs: Vec<Epoch> = (0..n)
        .map(|k| gnss::time::from_week_tow(week, from + step * k as f64))
        .collect();
    let sats = eph
        .satellites()
        .map(|&sv| {
            (
                sv,
                epochs.iter().map(|&t| sp3_sample(&eph, sv, t)).collect(),
            )
        })
        .collect();
    let sp3 = gnss::orbit::Sp3 {
        frame: "WGS84".into(),
        epochs,
        interval: step,
        sats,
        ..gnss::orbit::Sp3::default()
    };
    write(&rep.dir, "orbits.sp3", &gnss::orbit::sp3_text(&sp3))
}

/// The position (m) and clock (s, without the relativistic correction) of `sv` at `t` as the
/// simulation computed them, NaN without a record. Outside the broadcast validity the
/// nearest Keplerian record is extrapolated, which is exact for the synthetic orbits (no
/// perturbations); GLONASS records are not.
fn sp3_sample(eph: &Ephemerides, sv: gnss::sv::Sv, t: Epoch) -> (nalgebra::Vector3<f64>, f64) {
    use gnss::orbit::Eph;
    let nearest_kepler = || {
        let d = |e: &&Eph| (t - e.toe()).to_seconds().abs();
        (eph.of(sv).iter())
            .filter(|e| matches!(e, Eph::Kepler(_)))
            .min_by(|a, b| d(a).total_cmp(&d(b)))
    };
    match eph.select(sv, t).or_else(nearest_kepler) {
        Some(e) => {
            let pc = e.compute(t);
            let rel = gnss::orbit::relativistic_clock(&pc.pos.0, &pc.vel);
            (pc.pos.0, pc.clock - rel)
        }
        None => (nalgebra::Vector3::repeat(f64::NAN), f64::NAN),
    }
}

/// The navigation file of the scenario's synthetic constellations for `[start, end]` (GPST),
/// written to `dir/nav.rnx` and read back with our own reader: its path, the ephemerides and
/// the GPS Klobuchar parameters the simulation uses.
pub(crate) fn broadcast_orbits(
    dir: &Path,
    start: Epoch,
    end: Epoch,
    s: &Scenario,
) -> Result<(PathBuf, Ephemerides, Klobuchar), SimError> {
    let nav_text = constellation::navigation_text_of(start, end, s.seed, &s.systems());
    let nav_path = write(dir, "nav.rnx", &nav_text)?;
    let nav = NavFile::read(&nav_path)?;
    let klob = nav.gps_iono.unwrap_or(Klobuchar {
        alpha: constellation::KLOB_ALPHA,
        beta: constellation::KLOB_BETA,
    });
    Ok((nav_path, Ephemerides::from_nav(&[nav]), klob))
}

/// Ground points over the block (the strips plus 30 % of an image width each side) and their
/// noisy image observations, both drawn from `rng`; an error when no image sees a point.
fn ground_and_images(
    s: &Scenario,
    cam: &CameraSpec,
    exps: &[Exposure],
    heading: f64,
    rng: &mut Rng,
) -> Result<(Vec<GroundPoint>, Vec<ImageObs>), SimError> {
    let half_along = s.flight.strip_length / 2.0;
    let half_across = ((s.flight.strips - 1) as f64 * s.flight.strip_spacing) / 2.0
        + 0.3 * s.flight.altitude * cam.height_px as f64 * cam.pixel / cam.focal;
    let points = camera::ground_points(
        rng,
        half_along,
        half_across,
        heading,
        s.ground.relief,
        [s.ground.gcps, s.ground.checks, s.ground.ties],
    );
    let obs = camera::image_observations(
        exps,
        &points,
        cam,
        s.errors.image_noise_px,
        s.errors.image_blunders,
        rng,
    );
    if obs.is_empty() && !points.is_empty() {
        return Err(SimError::Key { key: "camera", what: "no ground point is seen by any image: check focal_mm, pixel_um, the image size and flight.altitude".into() });
    }
    Ok((points, obs))
}
