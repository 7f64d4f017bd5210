//! The photogrammetric block of `simulate --builtin ins`: a camera on the IMU's aircraft
//! photographs a 40 s stretch of each of the survey flight's first three strips (100–140 s,
//! 290–330 s across the GNSS outage, 460–500 s), 500 m above flat ground with 20 m of relief.
//! The strips lie 2.3 km apart: three single strips, whose roll about their own line GNSS
//! centres cannot see — what an IMU's attitude is bought for.
//!
//! The camera hangs [`CAMERA_OFFSET`] below the IMU, looking down with image x forward, and
//! is turned against the IMU's axes by a small boresight misalignment [`BORESIGHT_DEG`]: its
//! true rotation is R = R_obs·exp(b), R_obs the IMU attitude with the nominal mounting (the
//! convention `ppkat adjust` estimates b in). The antenna is where the flight's GNSS is.
//!
//! Writes `exposure_times.csv` (what `ppkat exposures --times` reads), `images.csv`,
//! `image_observations.csv` (σ 0.5 px), `ground_points.csv` (one control point per strip,
//! 150 m off its line, and five check points; σ 2 cm / 3 cm), `project.toml` (GNSS centres and
//! the INS attitude with a boresight), `project_gnss_only.toml` (the same without attitude)
//! and `truth_block.toml` (the boresight, the lever arm), `truth_block_exposures.csv`.

use crate::error::SimError;
use crate::ground_points::{write_ground_points, Point};
use crate::io::write;
use crate::rng::Rng;
use common::frame::{enu_rotation, Ecef, Geodetic};
use hifitime::{Duration, Epoch};
use ins::inverse::Motion;
use nalgebra::{Matrix3, Vector2, Vector3};
use photo::camera::{Camera, Pose};
use photo::rotation::exp_so3;
use std::fmt::Write as _;
use std::path::Path;

/// The camera's misalignment against the IMU, about the camera's x, y, z (degrees).
pub const BORESIGHT_DEG: [f64; 3] = [0.12, -0.08, 0.25];
/// IMU → camera in the body frame (forward, right, down), m.
pub const CAMERA_OFFSET: [f64; 3] = [0.0, 0.0, 0.3];
/// When the camera fires: strips' stretches (s from the start) and the interval (s).
const WINDOWS: [(f64, f64); 3] = [(100.0, 140.0), (290.0, 330.0), (460.0, 500.0)];
const INTERVAL: f64 = 1.5;
/// Principal distance, pixel size (m), format along × across track (pixels), σ (pixels).
const FOCAL: f64 = 0.035;
const PIXEL: f64 = 3.9e-6;
const WIDTH_PX: usize = 4000;
const HEIGHT_PX: usize = 6000;
const SIGMA_PX: f64 = 0.5;
/// Ground below the flight, m (ENU up at the origin), and its relief.
const GROUND: f64 = -500.0;
const RELIEF: f64 = 20.0;
/// Tie points per strip.
const TIES: usize = 400;
/// σ of the control and check points (horizontal, vertical), m.
const POINT_SIGMA: (f64, f64) = (0.02, 0.03);

/// Camera axes → body axes for the nominal mounting (x forward, z up in the camera; the
/// body's z is down).
fn mounting() -> Matrix3<f64> {
    Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0))
}

/// One exposure: id, strip (from 0), time (s from the start), true camera pose in the ENU at
/// the origin.
struct Shot {
    id: String,
    strip: usize,
    t: f64,
    pose: Pose,
}

/// Where `x` lands in the image (metres), when inside the format 50 px from the edges.
fn seen(cam: &Camera, pose: &Pose, x: &Vector3<f64>) -> Option<Vector2<f64>> {
    crate::block::nav_images::seen_inside(cam, pose, x, 50.0)
}

/// The lever arm antenna − camera in the true camera frame, m.
pub fn lever_in_camera(imu_to_antenna: &[f64; 3]) -> Vector3<f64> {
    let b = exp_so3(&Vector3::from(BORESIGHT_DEG).map(f64::to_radians));
    b.transpose() * mounting() * (Vector3::from(*imu_to_antenna) - Vector3::from(CAMERA_OFFSET))
}

/// The exposures along the motion, their true poses in the ENU at `origin`.
fn shoot(m: &dyn Motion, origin: &Geodetic) -> Vec<Shot> {
    let b = exp_so3(&Vector3::from(BORESIGHT_DEG).map(f64::to_radians));
    let to_enu = enu_rotation(origin);
    let o = origin.to_ecef().0;
    let mut out = Vec::new();
    for (s, (a, z)) in WINDOWS.iter().enumerate() {
        let n = ((z - a) / INTERVAL).round() as usize;
        for k in 0..=n {
            let t = a + k as f64 * INTERVAL;
            let km = m.at(t);
            let centre = km.position.0 + km.attitude * Vector3::from(CAMERA_OFFSET);
            out.push(Shot {
                id: format!("S{}_{:02}", s + 1, k + 1),
                strip: s,
                t,
                pose: Pose {
                    r: to_enu * km.attitude * mounting() * b,
                    centre: to_enu * (centre - o),
                },
            });
        }
    }
    out
}

/// Tie points over each strip's stretch ([`TIES`]), a control point 150 m off its line and five
/// check points, on the ground seen by two images at least.
fn place(cam: &Camera, shots: &[Shot], rng: &mut Rng) -> Vec<Point> {
    let mut out = Vec::new();
    for s in 0..WINDOWS.len() {
        let on: Vec<&Shot> = shots.iter().filter(|x| x.strip == s).collect();
        let (first, last) = (on[0].pose.centre, on[on.len() - 1].pose.centre);
        let along = (last - first).normalize();
        let across = Vector3::new(-along.y, along.x, 0.0);
        let mut add = |id: String, kind: &'static str, f: f64, c: f64, rng: &mut Rng| {
            let xy = first + (last - first) * f + across * c;
            let p = Vector3::new(xy.x, xy.y, GROUND + RELIEF * rng.range(-1.0, 1.0));
            if on
                .iter()
                .filter(|x| seen(cam, &x.pose, &p).is_some())
                .count()
                >= 2
            {
                out.push((id, kind, p));
            }
        };
        add(format!("G{}", s + 1), "gcp", 0.5, 150.0, rng);
        for k in 0..5 {
            let (f, c) = (
                0.1 + 0.2 * k as f64,
                if k % 2 == 0 { -140.0 } else { 140.0 },
            );
            add(format!("C{}{}", s + 1, k + 1), "check", f, c, rng);
        }
        for k in 0..TIES {
            let (f, c) = (rng.range(0.0, 1.0), rng.range(-170.0, 170.0));
            add(format!("T{}{:03}", s + 1, k + 1), "tie", f, c, rng);
        }
    }
    out
}

/// Write the block beside the flight's files (see the module's text); `imu_to_antenna` is the
/// flight's lever arm (body, m). Returns the photographs and the image observations.
pub fn write_block(
    out: &Path,
    m: &dyn Motion,
    origin: &Geodetic,
    start: Epoch,
    imu_to_antenna: &[f64; 3],
    seed: u64,
) -> Result<(usize, usize), SimError> {
    let mut rng = Rng::new(seed).fork(77);
    let cam = Camera::ideal(FOCAL, PIXEL, WIDTH_PX, HEIGHT_PX);
    let shots = shoot(m, origin);
    let points = place(&cam, &shots, &mut rng);
    let gps = |t: f64| gnss::time::week_tow(start + Duration::from_seconds(t));
    let (mut times, mut list) = (
        String::from("id,week,tow\n"),
        String::from("image,camera,strip,week,tow\n"),
    );
    let mut truth = String::from("# true exposures: projection centre in the ENU at the origin (m), omega/phi/kappa (deg) of R camera->ENU at the origin; GPST\nid,strip,week,tow,e,n,u,omega,phi,kappa\n");
    for s in &shots {
        let (w, tow) = gps(s.t);
        let _ = writeln!(times, "{},{w},{tow:.6}", s.id);
        let _ = writeln!(list, "{},cam,{},{w},{tow:.6}", s.id, s.strip + 1);
        let [o, p, k] = exposure::attitude::omega_phi_kappa(&s.pose.r).map(f64::to_degrees);
        let c = s.pose.centre;
        let _ = writeln!(
            truth,
            "{},{},{w},{tow:.6},{:.4},{:.4},{:.4},{o:.6},{p:.6},{k:.6}",
            s.id,
            s.strip + 1,
            c.x,
            c.y,
            c.z
        );
    }
    let mut obs = String::from("image,point,x_px,y_px,sigma_px\n");
    let mut n_obs = 0;
    for s in &shots {
        for (id, _, x) in &points {
            if let Some(xy) = seen(&cam, &s.pose, x) {
                let noisy = xy + Vector2::new(rng.normal(), rng.normal()) * (SIGMA_PX * PIXEL);
                let px = cam.image_to_pixel(noisy);
                let _ = writeln!(obs, "{},{id},{:.3},{:.3},{SIGMA_PX}", s.id, px.x, px.y);
                n_obs += 1;
            }
        }
    }
    write(out, "exposure_times.csv", &times)?;
    write(out, "images.csv", &list)?;
    write(out, "image_observations.csv", &obs)?;
    write(out, "truth_block_exposures.csv", &truth)?;
    let surveyed = points.iter().filter(|p| p.1 != "tie");
    write_ground_points(out, surveyed, POINT_SIGMA, None, origin, &mut rng)?;
    let lever = lever_in_camera(imu_to_antenna);
    for (name, attitude) in [("project.toml", true), ("project_gnss_only.toml", false)] {
        write(out, name, &project(&lever, attitude))?;
    }
    let b = BORESIGHT_DEG;
    write(
        out,
        "truth_block.toml",
        &format!(
            "# the block's truth: boresight (deg, about the camera's x, y, z; R = R_obs*exp(b)) and the lever arm antenna - camera in the camera frame (m)\nboresight_deg = [{}, {}, {}]\nlever_arm = [{:.6}, {:.6}, {:.6}]\n",
            b[0], b[1], b[2], lever.x, lever.y, lever.z
        ),
    )?;
    Ok((shots.len(), n_obs))
}

/// The project: GNSS centres from `antennas.csv` (written by `ppkat exposures --ins`), the
/// lever arm held, and with `attitude` the INS attitude with its own σ and a boresight.
fn project(lever: &Vector3<f64>, attitude: bool) -> String {
    let mut s = format!(
        "# ppkat adjust --project {}: first ppkat ins --config ins.toml, then\n# ppkat exposures --trajectory gnss.pos --times exposure_times.csv --ins ins.csv --format antenna -o antennas.csv\nname = \"ins block{}\"\noutput = \"utm\"\n\n[[camera]]\nid = \"cam\"\nfocal_mm = {}\npixel_um = {}\nwidth_px = {WIDTH_PX}\nheight_px = {HEIGHT_PX}\nsigma_px = {SIGMA_PX}\n\n[images]\nlist = \"images.csv\"\nmeasurements = \"image_observations.csv\"\n\n[ground]\nfile = \"ground_points.csv\"\n\n[gnss]\nantennas = \"antennas.csv\"\nlever_arm = [{:.6}, {:.6}, {:.6}]\nestimate_lever_arm = false\ndrift = \"none\"\n",
        if attitude { "project.toml" } else { "project_gnss_only.toml" },
        if attitude { "" } else { " (GNSS centres only)" },
        FOCAL * 1e3,
        PIXEL * 1e6,
        lever.x,
        lever.y,
        lever.z
    );
    if attitude {
        s += "\n[attitude]\nboresight = true\nstrip_offsets = true\n";
    }
    s
}

/// The antenna position of the flight at `t` (for the tests): IMU plus the lever arm.
pub fn antenna_at(m: &dyn Motion, t: f64, imu_to_antenna: &[f64; 3]) -> Ecef {
    let k = m.at(t);
    Ecef(k.position.0 + k.attitude * Vector3::from(*imu_to_antenna))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ins_motion::Survey;
    use common::frame::Enu;
    use exposure::attitude::from_yaw_pitch_roll;
    use ins::attitude::{ned_to_ecef, Euler};

    /// The nominal mounting is the exposure stage's: a level IMU heading east gives the
    /// camera rotation `from_yaw_pitch_roll`, and the antenna lies at the centre plus R·lever.
    #[test]
    fn the_mounting_and_lever_agree_with_the_exposure_stage() {
        let origin = Geodetic::from_degrees(47.3, 8.5, 800.0);
        let m = Survey::new(origin, 600.0, &[170.0, 350.0, 530.0]);
        let k = m.at(200.0);
        let g = k.position.to_geodetic();
        let e = Euler::from_matrix(&(ned_to_ecef(&g).transpose() * k.attitude));
        let nominal = enu_rotation(&g) * k.attitude * mounting();
        let ypr = from_yaw_pitch_roll(e.heading, e.pitch, e.roll);
        assert!((nominal - ypr).norm() < 1e-12, "{nominal} {ypr}");
        let lever = [0.2, 0.1, -1.5];
        let shots = shoot(&m, &origin);
        let s = &shots[3];
        let ant = antenna_at(&m, s.t, &lever);
        let c = Enu(s.pose.centre).to_ecef(&origin.to_ecef());
        let back = enu_rotation(&origin).transpose() * (s.pose.r * lever_in_camera(&lever));
        assert!((c.0 + back - ant.0).norm() < 1e-9);
    }
}
