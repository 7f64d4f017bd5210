//! The flight simulator: a scenario (TOML or built-in) → base and rover RINEX 3.04 with
//! flag-5 exposure events, a navigation file of a synthetic constellation, and exact truth
//! (antenna trajectory, projection centres and attitudes, ground points, image observations).
//! Deterministic for a seed.

mod builtin;
pub use builtin::{builtin, BUILTINS};
pub mod block;
pub mod camera;
pub mod closerange;
pub mod constellation;
pub mod flight;
pub mod gnss_obs;
pub mod rng;

use camera::{CameraSpec, PointKind};
use flight::{Flight, FlightPlan};
use gnss::frame::{Ecef, Enu, Geodetic};
use gnss::orbit::Ephemerides;
use gnss::rinex::nav::{Klobuchar, NavFile};
use hifitime::{Duration, Epoch};
use nalgebra::Vector3;
use rng::Rng;
use serde::Deserialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Errors of the simulator: a scenario key and what is wrong with it, or an I/O failure.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    #[error("scenario: {0}")]
    Parse(String),
    #[error("scenario key `{key}`: {what}")]
    Key { key: &'static str, what: String },
    #[error(transparent)]
    Gnss(#[from] gnss::Error),
}

fn d_seed() -> u64 {
    1
}
fn d_rate() -> f64 {
    10.0
}
fn d_static() -> f64 {
    60.0
}
fn d_base_rate() -> f64 {
    1.0
}
fn d_true() -> bool {
    true
}
fn d_code() -> f64 {
    0.3
}
fn d_phase() -> f64 {
    0.002
}
fn d_img() -> f64 {
    0.5
}

/// A simulation scenario (every key is checked; unknown keys are errors).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    pub name: String,
    #[serde(default = "d_seed")]
    pub seed: u64,
    /// Start of the flight, GPST, `YYYY-MM-DDTHH:MM:SS`.
    pub start: String,
    pub site: Site,
    pub flight: FlightSpec,
    pub camera: CameraToml,
    pub base: BaseSpec,
    pub ground: GroundSpec,
    #[serde(default)]
    pub errors: ErrorModel,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Site {
    pub lat_deg: f64,
    pub lon_deg: f64,
    /// Ellipsoidal height of the terrain, metres.
    pub ground_height: f64,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FlightSpec {
    /// Above the terrain, metres.
    pub altitude: f64,
    /// Cruise speed, m/s.
    pub speed: f64,
    pub strips: usize,
    pub strip_length: f64,
    pub strip_spacing: f64,
    /// Strip direction, degrees from north.
    pub heading_deg: f64,
    /// Rover observation rate, Hz (≤ 20).
    #[serde(default = "d_rate")]
    pub rate_hz: f64,
    /// Seconds on the ground before take-off.
    #[serde(default = "d_static")]
    pub static_start_s: f64,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraToml {
    pub focal_mm: f64,
    /// Sensor size in pixels: x along track, y across track.
    pub width_px: usize,
    pub height_px: usize,
    pub pixel_um: f64,
    pub forward_overlap: f64,
    /// Antenna phase centre in the camera frame (x forward, y left, z up), metres.
    pub lever_arm: [f64; 3],
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BaseSpec {
    /// Position relative to the site origin, metres.
    pub east: f64,
    pub north: f64,
    pub height_above_ground: f64,
    /// Observation interval, seconds.
    #[serde(default = "d_base_rate")]
    pub interval_s: f64,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GroundSpec {
    pub gcps: usize,
    pub checks: usize,
    pub ties: usize,
    /// Terrain relief (± metres).
    pub relief: f64,
}

/// Error model; every part can be switched off.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ErrorModel {
    #[serde(default = "d_true")]
    pub receiver_clock: bool,
    #[serde(default = "d_true")]
    pub troposphere: bool,
    #[serde(default = "d_true")]
    pub ionosphere: bool,
    /// Code noise at zenith, metres (0 = off).
    #[serde(default = "d_code")]
    pub code_noise: f64,
    /// Phase noise at zenith, metres (0 = off).
    #[serde(default = "d_phase")]
    pub phase_noise: f64,
    #[serde(default = "d_true")]
    pub multipath: bool,
    #[serde(default = "d_true")]
    pub ambiguities: bool,
    #[serde(default)]
    pub cycle_slips: usize,
    #[serde(default)]
    pub gaps: usize,
    /// Image measurement noise, pixels.
    #[serde(default = "d_img")]
    pub image_noise_px: f64,
    #[serde(default)]
    pub image_blunders: usize,
}

impl Default for ErrorModel {
    fn default() -> Self {
        toml::from_str("").expect("all keys have defaults")
    }
}

impl ErrorModel {
    /// Every error source off (for consistency tests).
    pub fn none() -> Self {
        ErrorModel {
            receiver_clock: false,
            troposphere: false,
            ionosphere: false,
            code_noise: 0.0,
            phase_noise: 0.0,
            multipath: false,
            ambiguities: false,
            cycle_slips: 0,
            gaps: 0,
            image_noise_px: 0.0,
            image_blunders: 0,
        }
    }
}

impl Scenario {
    pub fn from_toml(text: &str) -> Result<Scenario, SimError> {
        let s: Scenario = toml::from_str(text).map_err(|e| {
            SimError::Parse(
                e.message().to_string()
                    + &e.span()
                        .map(|r| format!(" (at byte {})", r.start))
                        .unwrap_or_default(),
            )
        })?;
        s.validate()?;
        Ok(s)
    }

    pub fn start_epoch(&self) -> Result<Epoch, SimError> {
        let bad = |what: String| SimError::Key { key: "start", what };
        let p: Vec<&str> = self.start.split(['-', 'T', ':', ' ']).collect();
        let n: Vec<i64> = p
            .iter()
            .map(|x| x.parse::<i64>())
            .collect::<Result<_, _>>()
            .map_err(|_| bad(format!("'{}' is not YYYY-MM-DDTHH:MM:SS", self.start)))?;
        if n.len() != 6 {
            return Err(bad(format!("'{}' is not YYYY-MM-DDTHH:MM:SS", self.start)));
        }
        if !(1999..=2099).contains(&n[0]) {
            return Err(bad(format!(
                "year {} is outside the ephemeris set the simulator can broadcast (1999–2099)",
                n[0]
            )));
        }
        Epoch::maybe_from_gregorian(
            n[0] as i32,
            n[1] as u8,
            n[2] as u8,
            n[3] as u8,
            n[4] as u8,
            n[5] as u8,
            0,
            hifitime::TimeScale::GPST,
        )
        .map_err(|e| bad(format!("'{}' is not a valid date: {e}", self.start)))
    }

    pub fn validate(&self) -> Result<(), SimError> {
        let k = |key: &'static str, ok: bool, what: &str| {
            if ok {
                Ok(())
            } else {
                Err(SimError::Key {
                    key,
                    what: what.to_string(),
                })
            }
        };
        let f = &self.flight;
        k(
            "flight.speed",
            f.speed > 0.0 && f.speed < 300.0,
            "must be a speed in m/s between 0 and 300",
        )?;
        k(
            "flight.altitude",
            f.altitude > 0.0 && f.altitude < 10_000.0,
            "must be a height above ground in metres, 0–10 000",
        )?;
        k(
            "flight.strips",
            (1..=100).contains(&f.strips),
            "must be 1–100",
        )?;
        k(
            "flight.strip_length",
            f.strip_length > 0.0,
            "must be positive (metres)",
        )?;
        k(
            "flight.strip_spacing",
            f.strip_spacing > 0.0,
            "must be positive (metres)",
        )?;
        k(
            "flight.rate_hz",
            f.rate_hz > 0.0 && f.rate_hz <= 20.0,
            "must be 0–20 Hz",
        )?;
        k(
            "flight.static_start_s",
            f.static_start_s >= 0.0,
            "must not be negative",
        )?;
        let c = &self.camera;
        k("camera.focal_mm", c.focal_mm > 0.0, "must be positive")?;
        k("camera.pixel_um", c.pixel_um > 0.0, "must be positive")?;
        k(
            "camera.width_px",
            c.width_px > 0 && c.height_px > 0,
            "image size must be positive",
        )?;
        k(
            "camera.forward_overlap",
            (0.0..0.95).contains(&c.forward_overlap),
            "must be 0–0.95",
        )?;
        k(
            "base.interval_s",
            self.base.interval_s > 0.0 && self.base.interval_s <= 60.0,
            "must be 0–60 s",
        )?;
        k(
            "site.lat_deg",
            self.site.lat_deg.abs() < 85.0,
            "must be within ±85°",
        )?;
        let e = &self.errors;
        k(
            "errors.code_noise",
            e.code_noise >= 0.0,
            "must not be negative",
        )?;
        k(
            "errors.phase_noise",
            e.phase_noise >= 0.0,
            "must not be negative",
        )?;
        k(
            "errors.image_noise_px",
            e.image_noise_px >= 0.0,
            "must not be negative",
        )?;
        self.start_epoch()?;
        Ok(())
    }

    fn camera(&self) -> CameraSpec {
        let c = &self.camera;
        CameraSpec {
            focal: c.focal_mm / 1000.0,
            width_px: c.width_px,
            height_px: c.height_px,
            pixel: c.pixel_um * 1e-6,
            lever: photo::lever::LeverArm::new(Vector3::from(c.lever_arm)),
        }
    }
}

/// What a simulation wrote.
#[derive(Clone, Debug)]
pub struct SimReport {
    pub dir: PathBuf,
    pub rover: PathBuf,
    pub base: PathBuf,
    pub nav: PathBuf,
    pub duration_s: f64,
    pub rover_stats: gnss_obs::ObsStats,
    pub base_stats: gnss_obs::ObsStats,
    pub exposures: usize,
    pub points: usize,
    pub image_obs: usize,
    pub base_position: Ecef,
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

/// Write a simulated file atomically, creating its folder.
fn write(dir: &Path, name: &str, text: &str) -> Result<PathBuf, SimError> {
    std::fs::create_dir_all(dir).map_err(|source| gnss::Error::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let p = dir.join(name);
    gnss::solution::write_atomic(&p, |w| w.write_all(text.as_bytes()))?;
    Ok(p)
}

/// The analytic flight of a scenario: the path, its start epoch and a function giving the
/// true antenna position (ECEF) at a GPST epoch — for tests that need truth between samples.
pub fn truth_flight(s: &Scenario) -> Result<impl Fn(Epoch) -> Ecef, SimError> {
    let start = s.start_epoch()?;
    let origin =
        Geodetic::from_degrees(s.site.lat_deg, s.site.lon_deg, s.site.ground_height).to_ecef();
    let flight = Flight::new(&plan_of(s), &mut Rng::new(s.seed).fork(3));
    Ok(move |t: Epoch| Enu(flight.at((t - start).to_seconds()).pos).to_ecef(&origin))
}

fn plan_of(s: &Scenario) -> FlightPlan {
    let base_enu = Vector3::new(s.base.east, s.base.north, s.base.height_above_ground);
    FlightPlan {
        altitude: s.flight.altitude,
        speed: s.flight.speed,
        strips: s.flight.strips,
        strip_length: s.flight.strip_length,
        strip_spacing: s.flight.strip_spacing,
        heading: s.flight.heading_deg.to_radians(),
        static_start: s.flight.static_start_s,
        start: base_enu + Vector3::new(30.0, 0.0, 0.0),
    }
}

/// Run a scenario into `dir` (created if needed).
pub fn run(s: &Scenario, dir: &Path) -> Result<SimReport, SimError> {
    s.validate()?;
    let t_start = std::time::Instant::now();
    std::fs::create_dir_all(dir).map_err(|source| gnss::Error::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let rng = Rng::new(s.seed);
    let start = s.start_epoch()?;
    let origin_geo = Geodetic::from_degrees(s.site.lat_deg, s.site.lon_deg, s.site.ground_height);
    let origin = origin_geo.to_ecef();
    let to_ecef = |v: &Vector3<f64>| Enu(*v).to_ecef(&origin);
    let base_enu = Vector3::new(s.base.east, s.base.north, s.base.height_above_ground);
    let plan = plan_of(s);
    let flight = Flight::new(&plan, &mut rng.fork(3));
    let duration = flight.duration();
    let end = start + Duration::from_seconds(duration);
    // Navigation: write, then read back with our own reader (the simulation uses those numbers).
    let nav_text = constellation::navigation_text(start, end, s.seed);
    let nav_path = write(dir, "nav.rnx", &nav_text)?;
    let nav = NavFile::read(&nav_path)?;
    let klob = nav.gps_iono.unwrap_or(Klobuchar {
        alpha: constellation::KLOB_ALPHA,
        beta: constellation::KLOB_BETA,
    });
    let eph = Ephemerides::from_nav(&[nav]);
    // Camera, exposures, ground and image observations.
    let cam = s.camera();
    let exps = camera::exposures(
        &flight,
        &cam,
        s.flight.altitude,
        s.flight.speed,
        s.camera.forward_overlap,
    );
    let half_along = s.flight.strip_length / 2.0;
    let half_across = ((s.flight.strips - 1) as f64 * s.flight.strip_spacing) / 2.0
        + 0.3 * s.flight.altitude * cam.height_px as f64 * cam.pixel / cam.focal;
    let mut prng = rng.fork(4);
    let points = camera::ground_points(
        &mut prng,
        half_along,
        half_across,
        plan.heading,
        s.ground.relief,
        [s.ground.gcps, s.ground.checks, s.ground.ties],
    );
    let obs = camera::image_observations(
        &exps,
        &points,
        &cam,
        s.errors.image_noise_px,
        s.errors.image_blunders,
        &mut prng,
    );
    if obs.is_empty() && !points.is_empty() {
        return Err(SimError::Key { key: "camera", what: "no ground point is seen by any image: check focal_mm, pixel_um, the image size and flight.altitude".into() });
    }
    // GNSS observations.
    let event_times: Vec<Epoch> = exps
        .iter()
        .map(|e| start + Duration::from_seconds(e.t))
        .collect();
    let rover_pos = |t: Epoch| to_ecef(&flight.at((t - start).to_seconds()).pos);
    let rover = gnss_obs::Receiver {
        name: "ROVER",
        pos: &rover_pos,
        clock: (2.0e-4, 3.0e-9),
        start,
        end,
        interval: 1.0 / s.flight.rate_hz,
        events: &event_times,
        faults: true,
    };
    let base_ecef = to_ecef(&base_enu);
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
    };
    let (rtext, rstats) = gnss_obs::simulate(&rover, &eph, &klob, &s.errors, &rng.fork(5));
    let (btext, bstats) = gnss_obs::simulate(&base, &eph, &klob, &s.errors, &rng.fork(6));
    let rover_path = write(dir, "rover.obs", &rtext)?;
    let base_path = write(dir, "base.obs", &btext)?;
    // Truth files.
    let mut traj = String::from("# antenna phase centre, true GPST; ECEF metres; velocity m/s; attitude degrees (NED body)\nweek,tow,x,y,z,vx,vy,vz,roll,pitch,yaw\n");
    // One sample past the end so that every observation epoch lies inside the truth.
    let n = (duration * s.flight.rate_hz).ceil() as usize + 1;
    let rot = gnss::frame::enu_rotation(&origin_geo).transpose();
    for k in 0..=n {
        let t = k as f64 / s.flight.rate_hz;
        let st = flight.at(t);
        let p = to_ecef(&st.pos);
        let v = rot * st.vel;
        let (w, tow) = gnss::time::week_tow(start + Duration::from_seconds(t));
        let _ = writeln!(
            traj,
            "{w},{tow:.3},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.5},{:.5},{:.5}",
            p.0.x,
            p.0.y,
            p.0.z,
            v.x,
            v.y,
            v.z,
            st.roll.to_degrees(),
            st.pitch.to_degrees(),
            st.yaw.to_degrees()
        );
    }
    write(dir, "truth_trajectory.csv", &traj)?;
    let mut ex = String::from("# exposures, true GPST; projection centre S and antenna A in ECEF metres and local ENU (site origin); angles degrees; omega/phi/kappa: R = Rω·Rφ·Rκ camera→ENU\nid,strip,week,tow,xs,ys,zs,xa,ya,za,es,ns,us,roll,pitch,yaw,omega,phi,kappa\n");
    for e in &exps {
        let (w, tow) = gnss::time::week_tow(start + Duration::from_seconds(e.t));
        let sx = to_ecef(&e.centre);
        let ax = to_ecef(&e.state.pos);
        let [om, ph, ka] = crate::exposure::attitude::omega_phi_kappa(&e.r);
        let _ = writeln!(ex, "{},{},{w},{tow:.6},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.5},{:.5},{:.5},{:.6},{:.6},{:.6}", e.id, e.strip + 1, sx.0.x, sx.0.y, sx.0.z, ax.0.x, ax.0.y, ax.0.z, e.centre.x, e.centre.y, e.centre.z, e.state.roll.to_degrees(), e.state.pitch.to_degrees(), e.state.yaw.to_degrees(), om.to_degrees(), ph.to_degrees(), ka.to_degrees());
    }
    write(dir, "truth_exposures.csv", &ex)?;
    let mut gp = format!("# ground points; local ENU at lat {} lon {} h {} (metres) and geodetic; sigmas of control in metres\npoint,kind,east,north,up,lat_deg,lon_deg,h,sigma_xy,sigma_z\n", s.site.lat_deg, s.site.lon_deg, s.site.ground_height);
    for p in &points {
        let g = to_ecef(&p.enu).to_geodetic();
        let (sxy, sz) = if p.kind == PointKind::Tie {
            (0.0, 0.0)
        } else {
            (0.02, 0.03)
        };
        let _ = writeln!(
            gp,
            "{},{},{:.4},{:.4},{:.4},{:.9},{:.9},{:.4},{sxy},{sz}",
            p.id,
            p.kind.name(),
            p.enu.x,
            p.enu.y,
            p.enu.z,
            g.lat.to_degrees(),
            g.lon.to_degrees(),
            g.h
        );
    }
    write(dir, "ground_points.csv", &gp)?;
    let mut io = String::from("# image measurements, pixels (x along track to the right, y down), with their sigma\nimage,point,x_px,y_px,sigma_px\n");
    let mut bl = String::from("# injected image blunders (truth)\nimage,point,dx_px\n");
    for o in &obs {
        let _ = writeln!(
            io,
            "{},{},{:.3},{:.3},{}",
            o.image, o.point, o.x, o.y, o.sigma
        );
        if o.blunder != 0.0 {
            let _ = writeln!(bl, "{},{},{:.3}", o.image, o.point, o.blunder);
        }
    }
    write(dir, "image_observations.csv", &io)?;
    write(dir, "truth_blunders.csv", &bl)?;
    write(
        dir,
        "camera.toml",
        &format!(
            "focal_mm = {}\nwidth_px = {}\nheight_px = {}\npixel_um = {}\nlever_arm = {:?}\n",
            s.camera.focal_mm,
            s.camera.width_px,
            s.camera.height_px,
            s.camera.pixel_um,
            s.camera.lever_arm
        ),
    )?;
    Ok(SimReport {
        dir: dir.to_path_buf(),
        rover: rover_path,
        base: base_path,
        nav: nav_path,
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
