//! `ppkat demo`: simulate a short built-in flight, run the whole chain — single point,
//! carrier phase, exposures, antenna table, joint adjustment — and compare with the exact
//! truth. The stages pass values: the exposures are computed on the carrier-phase
//! [`gnss::trajectory::Trajectory`] in memory, with the filter's ambiguity segments
//! (`rover_ppk.pos` is written for the user, not read back).
//!
//! Enters: an output folder and the adjustment's run options. Leaves: the simulator's files,
//! `rover_ppk.pos`, `imu_attitude.csv`, `camera_stations.csv`, the adjustment's inputs
//! (`antennas.csv`, `images.csv`, `project.toml`) and outputs (`adjust/`) in that folder, and a
//! [`DemoReport`] of errors against truth (metres). Uses [`crate::simulate`], `gnss::spp`,
//! `gnss::ppk`, [`crate::exposure`] and [`crate::adjust`]. Also used by the tests: the truth
//! reader ([`read_truth`], [`truth_at`]) and [`SimInputs`].

use crate::exposure::attitude::{AngleConvention, AttitudeTable};
use crate::exposure::export::{self, Format, Projection};
use crate::exposure::{CameraStation, ExposureResult};
use crate::simulate::{self, SimError, SimReport};
use gnss::frame::Ecef;
use gnss::orbit::{Ephemerides, Orbits};
use gnss::ppk::{self, BasePosition, PpkOptions};
use gnss::rinex::nav::NavFile;
use gnss::rinex::ObsFile;
use gnss::solution::{PosFormat, Quality};
use gnss::spp::{self, SppOptions};
use gnss::trajectory::Trajectory;
use nalgebra::Vector3;
use std::fmt;
use std::path::Path;

/// Errors of a whole-chain run.
#[derive(Debug, thiserror::Error)]
pub enum ChainError {
    /// The simulation failed.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// Reading or processing GNSS data failed.
    #[error(transparent)]
    Gnss(#[from] gnss::Error),
    /// A truth file of the simulation could not be read.
    #[error("{path}: {what}")]
    Truth {
        /// The file.
        path: String,
        /// What went wrong.
        what: String,
    },
}

/// A failed whole-output write, as the [`gnss::Error`] of the same message.
impl From<common::atomic::Error> for ChainError {
    fn from(e: common::atomic::Error) -> Self {
        ChainError::Gnss(e.into())
    }
}

/// A truth trajectory sample: GPST seconds, ECEF position and velocity.
#[derive(Clone, Copy, Debug)]
pub struct TruthSample {
    /// GPST seconds (week × 604800 + seconds of week).
    pub t: f64,
    /// Antenna position, ECEF, metres.
    pub pos: Vector3<f64>,
    /// Antenna velocity, ECEF, m/s.
    pub vel: Vector3<f64>,
}

/// Read `truth_trajectory.csv` of the simulator.
pub fn read_truth(path: &Path) -> Result<Vec<TruthSample>, ChainError> {
    let text = std::fs::read_to_string(path).map_err(|e| ChainError::Truth {
        path: path.display().to_string(),
        what: e.to_string(),
    })?;
    let mut out = Vec::new();
    for (i, l) in text.lines().enumerate() {
        if l.starts_with('#') || l.starts_with("week") || l.trim().is_empty() {
            continue;
        }
        let f: Vec<f64> = l
            .split(',')
            .map(|x| x.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| ChainError::Truth {
                path: path.display().to_string(),
                what: format!("line {}: not numbers", i + 1),
            })?;
        if f.len() < 8 {
            return Err(ChainError::Truth {
                path: path.display().to_string(),
                what: format!("line {}: too few columns", i + 1),
            });
        }
        out.push(TruthSample {
            t: f[0] * gnss::time::WEEK_SECONDS + f[1],
            pos: Vector3::new(f[2], f[3], f[4]),
            vel: Vector3::new(f[5], f[6], f[7]),
        });
    }
    Ok(out)
}

/// Truth at GPST seconds `t` by cubic Hermite interpolation with the velocities.
pub fn truth_at(truth: &[TruthSample], t: f64) -> Option<Vector3<f64>> {
    if truth.len() < 2 {
        return None;
    }
    let i = truth
        .partition_point(|s| s.t <= t)
        .clamp(1, truth.len() - 1);
    let (a, b) = (&truth[i - 1], &truth[i]);
    let h = b.t - a.t;
    let s = (t - a.t) / h;
    // Up to one sample beyond either end (receiver clock offsets put epochs just outside).
    if !(-1.0..=2.0).contains(&s) {
        return None;
    }
    let (h00, h10, h01, h11) = (
        2.0 * s.powi(3) - 3.0 * s * s + 1.0,
        s.powi(3) - 2.0 * s * s + s,
        -2.0 * s.powi(3) + 3.0 * s * s,
        s.powi(3) - s * s,
    );
    Some(a.pos * h00 + a.vel * (h10 * h) + b.pos * h01 + b.vel * (h11 * h))
}

/// The files of a simulation, read: rover and base observations and the orbits.
pub struct SimInputs {
    /// Rover observations.
    pub rover: ObsFile,
    /// Base observations.
    pub base: ObsFile,
    /// Broadcast orbits of the simulated navigation file.
    pub orbits: Orbits,
}

impl SimInputs {
    /// Read the files a simulation wrote.
    pub fn read(sim: &SimReport) -> Result<SimInputs, ChainError> {
        Ok(SimInputs {
            rover: ObsFile::read(&sim.rover)?,
            base: ObsFile::read(&sim.base)?,
            orbits: Orbits::broadcast(Ephemerides::from_nav(&[NavFile::read(&sim.nav)?])),
        })
    }

    /// Carrier-phase positioning of the simulated rover against the simulated base.
    pub fn ppk(&self, sim: &SimReport, opts: &PpkOptions) -> Result<ppk::PpkResult, ChainError> {
        Ok(ppk::process(
            &self.rover,
            &self.base,
            BasePosition::Given(sim.base_position),
            &self.orbits,
            opts,
            &common::progress::NoProgress,
        )?)
    }
}

/// What the demo measured.
#[derive(Clone, Debug)]
pub struct DemoReport {
    /// What the simulation wrote.
    pub sim: SimReport,
    /// Single-point epochs solved.
    pub spp_epochs: usize,
    /// Single-point horizontal RMS against truth, metres.
    pub spp_h_rms: f64,
    /// Single-point vertical RMS against truth, metres.
    pub spp_v_rms: f64,
    /// Carrier-phase epochs solved.
    pub ppk_epochs: usize,
    /// Carrier-phase epochs fixed.
    pub ppk_fixed: usize,
    /// 3D RMS of the fixed epochs against truth, metres.
    pub ppk_3d_rms_fixed: f64,
    /// Largest 3D error of a fixed epoch, metres.
    pub ppk_max_fixed: f64,
    /// Camera stations computed.
    pub stations: usize,
    /// Exposures refused.
    pub stations_refused: usize,
    /// 3D RMS of the projection centres against truth, metres.
    pub centre_3d_rms: f64,
    /// The joint adjustment of the flight's photographs (None when it could not run).
    pub adjust: Option<crate::adjust::results::Results>,
    /// Why the adjustment could not run.
    pub adjust_error: Option<String>,
    /// The adjusted projection centres against truth: mean east/north/up error and 3D RMS,
    /// metres.
    pub adjusted_centres: Option<([f64; 3], f64)>,
    /// Wall time of the whole demo, seconds.
    pub seconds: f64,
}

impl fmt::Display for DemoReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.sim)?;
        writeln!(
            f,
            "single point: {} epochs, horizontal RMS {:.2} m, vertical RMS {:.2} m vs truth",
            self.spp_epochs, self.spp_h_rms, self.spp_v_rms
        )?;
        writeln!(
            f,
            "carrier phase: {} epochs, {} fixed ({:.1} %), fixed 3D RMS {:.1} mm, worst {:.1} mm vs truth",
            self.ppk_epochs,
            self.ppk_fixed,
            100.0 * self.ppk_fixed as f64 / self.ppk_epochs.max(1) as f64,
            self.ppk_3d_rms_fixed * 1000.0,
            self.ppk_max_fixed * 1000.0
        )?;
        writeln!(
            f,
            "exposures: {} camera stations ({} refused), projection centres 3D RMS {:.1} mm vs truth (lever arm rotated by the simulated IMU attitude)",
            self.stations,
            self.stations_refused,
            self.centre_3d_rms * 1000.0
        )?;
        match (&self.adjust, &self.adjust_error) {
            (Some(r), _) => {
                let c = &r.checks;
                writeln!(
                    f,
                    "adjustment: {} images, {} points, σ0 {:.2}, {} observations removed by data snooping",
                    r.images.len(),
                    r.points.len(),
                    r.sigma0,
                    r.removed.len()
                )?;
                writeln!(
                    f,
                    "check points: {}, RMS E/N/U {:.3} {:.3} {:.3} m (theoretical {:.3} {:.3} {:.3} m)",
                    c.points.len(),
                    c.rms[0],
                    c.rms[1],
                    c.rms[2],
                    c.theoretical_rms[0],
                    c.theoretical_rms[1],
                    c.theoretical_rms[2]
                )?;
                if let Some((m, rms3)) = self.adjusted_centres {
                    writeln!(
                        f,
                        "adjusted centres: mean error E/N/U {:.4} {:.4} {:.4} m, 3D RMS {:.4} m vs truth",
                        m[0], m[1], m[2], rms3
                    )?;
                }
                for l in &r.lever_arms {
                    writeln!(
                        f,
                        "lever arm: {:.3} {:.3} {:.3} m (σ {:.3} {:.3} {:.3})",
                        l.values[0],
                        l.values[1],
                        l.values[2],
                        l.sigmas[0],
                        l.sigmas[1],
                        l.sigmas[2]
                    )?;
                }
                writeln!(
                    f,
                    "report: {}",
                    self.sim.dir.join("adjust/report.html").display()
                )?;
            }
            (None, Some(e)) => writeln!(f, "adjustment failed: {e}")?,
            _ => {}
        }
        writeln!(
            f,
            "demo finished in {:.1} s; outputs in {}",
            self.seconds,
            self.sim.dir.display()
        )
    }
}

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt()
}

/// Run the demo into `out`.
pub fn run(out: &Path, run: &crate::adjust::RunOptions) -> Result<DemoReport, ChainError> {
    let t0 = std::time::Instant::now();
    let scenario = simulate::builtin("demo").expect("the demo scenario exists");
    let sim = simulate::run(&scenario, out)?;
    let truth = read_truth(&out.join("truth_trajectory.csv"))?;
    let inputs = SimInputs::read(&sim)?;
    let (rover, orbits) = (&inputs.rover, &inputs.orbits);
    // Single point.
    let sppr = spp::run(&rover.epochs, &rover.header, orbits, &SppOptions::default());
    let (h, v) = spp_errors(&sppr.solutions, &truth);
    // Carrier phase.
    let res = inputs.ppk(&sim, &PpkOptions::default())?;
    let d = fixed_errors(&res.trajectory, &truth);
    // The trajectory as a file for the user; the chain goes on with the value itself (full
    // precision, the filter's ambiguity segments).
    res.trajectory.write_pos(
        &out.join("rover_ppk.pos"),
        &["program   : ppkat demo (carrier-phase kinematic)".to_string()],
        PosFormat::Llh,
    )?;
    let ex = exposures(out, &scenario, rover, &res.trajectory)?;
    let truth_c = truth_centres(out)?;
    let ce = centre_errors(&truth_c, &ex.stations);
    write_adjust_project(out, &scenario, &ex.stations)?;
    let (adjust, adjust_error) =
        match crate::adjust::run(&out.join("project.toml"), &out.join("adjust"), run) {
            Ok(r) => (Some(r), None),
            Err(e) => (None, Some(e.to_string())),
        };
    let adjusted_centres = adjust.as_ref().and_then(|r| adjusted_errors(r, &truth_c));
    Ok(DemoReport {
        adjusted_centres,
        adjust,
        adjust_error,
        stations: ex.stations.len(),
        stations_refused: ex.refused.len(),
        centre_3d_rms: rms(&ce),
        spp_epochs: sppr.solutions.len(),
        spp_h_rms: rms(&h),
        spp_v_rms: rms(&v),
        ppk_epochs: res.trajectory.epochs.len(),
        ppk_fixed: res.fixed(),
        ppk_3d_rms_fixed: rms(&d),
        ppk_max_fixed: d.iter().copied().fold(0.0, f64::max),
        seconds: t0.elapsed().as_secs_f64(),
        sim,
    })
}

/// Horizontal and vertical errors (m) of single-point solutions against the truth at the
/// true time (receiver time tag minus the first system's clock).
fn spp_errors(solutions: &[spp::SppSolution], truth: &[TruthSample]) -> (Vec<f64>, Vec<f64>) {
    let (mut h, mut v) = (Vec::new(), Vec::new());
    for s in solutions {
        let clock = s.clocks.values().next().copied().unwrap_or(0.0) / gnss::orbit::C;
        if let Some(p) = truth_at(truth, s.time.to_gpst_seconds() - clock) {
            let e = s.pos.enu_from(&Ecef(p));
            h.push(e.horizontal());
            v.push(e.up());
        }
    }
    (h, v)
}

/// 3D errors (m) of the fixed epochs of a trajectory against the truth.
fn fixed_errors(traj: &Trajectory, truth: &[TruthSample]) -> Vec<f64> {
    let mut d = Vec::new();
    for s in traj.epochs.iter().filter(|s| s.quality == Quality::Fixed) {
        if let Some(p) = truth_at(truth, s.time.to_gpst_seconds()) {
            d.push((s.pos.0 - p).norm());
        }
    }
    d
}

/// A truth file of the simulation in `out`, as text.
fn truth_text(out: &Path, name: &str) -> Result<String, ChainError> {
    std::fs::read_to_string(out.join(name)).map_err(|e| ChainError::Truth {
        path: name.into(),
        what: e.to_string(),
    })
}

/// Camera stations from the rover's events on the PPK trajectory, the lever arm rotated by
/// the attitude an IMU would give (the simulated attitude, written as `imu_attitude.csv`);
/// written as `camera_stations.csv`.
pub(crate) fn exposures(
    out: &Path,
    scenario: &simulate::Scenario,
    rover: &ObsFile,
    traj: &Trajectory,
) -> Result<ExposureResult, ChainError> {
    let (mut events, _) = crate::exposure::events::from_rinex(rover, traj);
    // The simulator names its images 1, 2, 3 … in exposure order: the adjustment project's
    // image ids, which the antenna table must carry.
    for (k, e) in events.iter_mut().enumerate() {
        e.id = (k + 1).to_string();
    }
    let att_path = out.join("imu_attitude.csv");
    let mut att = String::from("# simulated IMU attitude: week,tow,yaw,pitch,roll (degrees)\n");
    for l in truth_text(out, "truth_trajectory.csv")?.lines() {
        let f: Vec<&str> = l.split(',').collect();
        if f.len() == 11 && f[0].chars().all(|c| c.is_ascii_digit()) {
            att.push_str(&format!("{},{},{},{},{}\n", f[0], f[1], f[10], f[9], f[8]));
        }
    }
    common::atomic::write_atomic(&att_path, |w| w.write_all(att.as_bytes()))?;
    let attitude = AttitudeTable::read_csv(&att_path, AngleConvention::YawPitchRoll)?;
    let lever = photo::lever::LeverArm::new(Vector3::from(scenario.camera.lever_arm));
    let opts = crate::exposure::ExposureOptions {
        lever_arm: Some(lever),
        attitude: Some(attitude),
        ..Default::default()
    };
    let ex = crate::exposure::compute(events, traj, &opts);
    write_stations(out, "camera_stations.csv", &ex.stations, Format::Csv)?;
    Ok(ex)
}

/// Stations in `out/name`, in a format, with geodetic coordinates.
fn write_stations(
    out: &Path,
    name: &str,
    stations: &[CameraStation],
    format: Format,
) -> Result<(), ChainError> {
    Ok(export::write(
        &out.join(name),
        stations,
        format,
        Projection::Geodetic,
        &crate::height::Heights::Ellipsoidal,
    )?)
}

/// The simulator's true projection centres: exposure id, GPST seconds, ECEF.
fn truth_centres(out: &Path) -> Result<Vec<(String, f64, Vector3<f64>)>, ChainError> {
    Ok(truth_text(out, "truth_exposures.csv")?
        .lines()
        .filter(|l| l.chars().next().is_some_and(|c| c.is_ascii_digit()))
        .filter_map(|l| {
            let id = l.split(',').next()?.to_string();
            let f: Vec<f64> = l
                .split(',')
                .map(|x| x.parse().ok())
                .collect::<Option<_>>()?;
            Some((
                id,
                f[2] * gnss::time::WEEK_SECONDS + f[3],
                Vector3::new(f[4], f[5], f[6]),
            ))
        })
        .collect())
}

/// 3D errors (m) of the projection centres against the truth exposure within 10 ms.
fn centre_errors(truth: &[(String, f64, Vector3<f64>)], stations: &[CameraStation]) -> Vec<f64> {
    let mut ce = Vec::new();
    for st in stations {
        let t = st.time.to_gpst_seconds();
        if let Some((_, _, c)) = truth.iter().find(|(_, tt, _)| (tt - t).abs() < 0.01) {
            ce.push((st.centre.0 - c).norm());
        }
    }
    ce
}

/// Mean east/north/up error and 3D RMS (m) of the adjusted projection centres against the
/// truth (matched by image id = exposure id); None without a match.
fn adjusted_errors(
    r: &crate::adjust::results::Results,
    truth: &[(String, f64, Vector3<f64>)],
) -> Option<([f64; 3], f64)> {
    let mut sum = Vector3::zeros();
    let mut sq = Vec::new();
    for im in &r.images {
        let Some((_, _, t)) = truth.iter().find(|(id, _, _)| *id == im.id) else {
            continue;
        };
        let p = &im.position;
        let adj = gnss::frame::Geodetic::from_degrees(p.lat, p.lon, p.h).to_ecef();
        let e = adj.enu_from(&Ecef(*t)).0;
        sum += e;
        sq.push(e.norm());
    }
    let n = sq.len();
    (n > 0).then(|| {
        let m = sum / n as f64;
        ([m.x, m.y, m.z], rms(&sq))
    })
}

/// The joint adjustment's inputs in `out`: the antenna table of the exposures stage, the
/// images with their strips (photographs in which nothing was measured, over the turns'
/// edges, stay out) and `project.toml` (the scenario's camera and lever arm with the 5 mm σ
/// of a tape measurement (`ppkat leverarm`), drift only for float segments (`auto`)); the image measurements and ground points are the simulator's.
pub(crate) fn write_adjust_project(
    out: &Path,
    scenario: &simulate::Scenario,
    stations: &[CameraStation],
) -> Result<(), ChainError> {
    write_stations(out, "antennas.csv", stations, Format::Antenna)?;
    let measured: std::collections::BTreeSet<String> = truth_text(out, "image_observations.csv")?
        .lines()
        .filter_map(|l| l.split(',').next().map(str::to_string))
        .collect();
    let mut images = String::from("image,strip\n");
    for l in truth_text(out, "truth_exposures.csv")?.lines() {
        let f: Vec<&str> = l.split(',').collect();
        if f.len() > 2 && f[0].chars().all(|c| c.is_ascii_digit()) && measured.contains(f[0]) {
            images.push_str(&format!("{},{}\n", f[0], f[1]));
        }
    }
    common::atomic::write_atomic(&out.join("images.csv"), |w| w.write_all(images.as_bytes()))?;
    let c = &scenario.camera;
    let l = c.lever_arm;
    let project = format!(
        "name = \"ppkat demo flight\"\noutput = \"utm\"\n\n[[camera]]\nid = \"demo\"\nfocal_mm = {}\npixel_um = {}\nwidth_px = {}\nheight_px = {}\n\n[images]\nlist = \"images.csv\"\nmeasurements = \"image_observations.csv\"\n\n[ground]\nfile = \"ground_points.csv\"\n\n[gnss]\nantennas = \"antennas.csv\"\nlever_arm = [{}, {}, {}]\nlever_arm_sigma = [0.005, 0.005, 0.005]\ndrift = \"auto\"\n",
        c.focal_mm, c.pixel_um, c.width_px, c.height_px, l[0], l[1], l[2]
    );
    common::atomic::write_atomic(&out.join("project.toml"), |w| {
        w.write_all(project.as_bytes())
    })?;
    Ok(())
}
