//! A simulated close-range job: one camera at a few ground stations whose positions come from
//! GNSS, approximate angles from a compass, a distant target with control, check and feature
//! points. Written as a `mode = "close-range"` project for `ppkat adjust`.
//!
//! Enters: a [`CloseRangeSpec`] and a folder. Leaves: `project.toml`, `images.csv` (with
//! compass azimuth, elevation, roll), `image_observations.csv`, `ground_points.csv` and
//! `antennas.csv` in the folder, and the [`CloseRangeTruth`]. Uses the compass rotation of
//! [`adjust::build`] and the ground-point writer shared with [`super::block`]. Frame:
//! ENU at the site, the target to the north; angles in the files are degrees.

use super::error::SimError;
use super::ground_points::{geodetic, write_ground_points, Point};
use super::io::write;
use super::rng::Rng;
use adjust::build::compass_rotation;
use exposure::export::{antenna_table, AntennaRow};
use gnss::frame::Geodetic;
use nalgebra::{Matrix3, Vector2, Vector3};
use photo::camera::{Camera, Pose};
use std::fmt::Write as _;
use std::path::Path;

/// A close-range job.
#[derive(Clone, Debug)]
pub struct CloseRangeSpec {
    /// Seed of every random draw.
    pub seed: u64,
    /// Latitude of the site, degrees.
    pub lat_deg: f64,
    /// Longitude of the site, degrees.
    pub lon_deg: f64,
    /// Ellipsoidal height of the site, metres.
    pub h: f64,
    /// Station east coordinates (north = 0, up = 1.5 m).
    pub stations: Vec<f64>,
    /// Distance to the target, m.
    pub distance: f64,
    /// Principal distance, mm.
    pub focal_mm: f64,
    /// Pixel size, µm.
    pub pixel_um: f64,
    /// Image width, pixels.
    pub width_px: usize,
    /// Image height, pixels.
    pub height_px: usize,
    /// σ of an image measurement, pixels.
    pub sigma_px: f64,
    /// GNSS σ of a station (E, N, U), metres.
    pub gnss_sigma: [f64; 3],
    /// σ of the compass azimuth, degrees (elevation and roll: half of it).
    pub compass_sigma_deg: f64,
    /// Control points on the target.
    pub controls: usize,
    /// Check points on the target.
    pub checks: usize,
    /// Feature (tie) points on the target.
    pub features: usize,
}

impl Default for CloseRangeSpec {
    /// Two stations 120 m apart, 380 m from the target, 3 control points seen by both.
    fn default() -> Self {
        CloseRangeSpec {
            seed: 380,
            lat_deg: 46.55,
            lon_deg: 7.98,
            h: 1650.0,
            stations: vec![-60.0, 60.0],
            distance: 380.0,
            focal_mm: 50.0,
            pixel_um: 4.0,
            width_px: 6000,
            height_px: 4000,
            sigma_px: 0.5,
            gnss_sigma: [0.02, 0.02, 0.03],
            compass_sigma_deg: 2.0,
            controls: 3,
            checks: 12,
            features: 80,
        }
    }
}

/// What the simulation knows: the stations' true poses and the points (ENU at the site).
#[derive(Clone, Debug)]
pub struct CloseRangeTruth {
    /// Origin of the ENU frame.
    pub origin: Geodetic,
    /// True poses of the stations, in order S1, S2 …
    pub poses: Vec<Pose>,
    /// Point id, kind (gcp|check|tie), ENU.
    pub points: Vec<(String, &'static str, Vector3<f64>)>,
}

/// Simulate the pair of stations and write the project (`project.toml` and its tables) into
/// `dir`.
pub fn close_range(spec: &CloseRangeSpec, dir: &Path) -> Result<CloseRangeTruth, SimError> {
    let mut rng = Rng::new(spec.seed);
    let px = spec.pixel_um * 1e-6;
    let cam = Camera::ideal(spec.focal_mm * 1e-3, px, spec.width_px, spec.height_px);
    let origin = Geodetic::from_degrees(spec.lat_deg, spec.lon_deg, spec.h);
    let points = target_points(spec, &cam, &mut rng);
    let (poses, compass) = stations(spec, &mut rng);
    let measurements = measurements_table(spec, &cam, &poses, &points, &mut rng);
    write(dir, "image_observations.csv", &measurements)?;
    write(dir, "images.csv", &compass_table(&compass))?;
    let control = points.iter().filter(|p| p.1 != "tie");
    write_ground_points(dir, control, (0.01, 0.015), None, &origin, &mut rng)?;
    write_antennas(spec, dir, &poses, &origin, &mut rng)?;
    write(dir, "project.toml", &project_toml(spec))?;
    Ok(CloseRangeTruth {
        origin,
        poses,
        points,
    })
}

/// Points on the target, a rough slope facing the stations over ~70 % of the view: control
/// points spread round its centre, then check and feature points at random.
fn target_points(spec: &CloseRangeSpec, cam: &Camera, rng: &mut Rng) -> Vec<Point> {
    let d = spec.distance;
    let px = spec.pixel_um * 1e-6;
    let half_w = 0.35 * d * spec.width_px as f64 * px / cam.f;
    let half_h = 0.35 * d * spec.height_px as f64 * px / cam.f;
    let slope = |e: f64, u: f64| Vector3::new(e, d + 15.0 * (e / 40.0).sin() + 0.2 * u, u);
    let target = |rng: &mut Rng| {
        let e = rng.range(-half_w, half_w);
        let u = rng.range(-half_h, half_h) + 25.0;
        slope(e, u)
    };
    let mut points = Vec::new();
    for k in 0..spec.controls {
        // Spread the control: left, right, top of the target.
        let a = k as f64 / spec.controls.max(1) as f64 * std::f64::consts::TAU + 0.3;
        let (e, u) = (0.8 * half_w * a.cos(), 25.0 + 0.8 * half_h * a.sin());
        points.push((format!("P{}", k + 1), "gcp", slope(e, u)));
    }
    for k in 0..spec.checks {
        points.push((format!("C{}", k + 1), "check", target(rng)));
    }
    for k in 0..spec.features {
        points.push((format!("F{}", k + 1), "tie", target(rng)));
    }
    points
}

/// The stations (1.5 m above the site, north = 0) looking at the target centre with a small
/// roll, and their compass readings (azimuth, elevation, roll in radians) with noise.
fn stations(spec: &CloseRangeSpec, rng: &mut Rng) -> (Vec<Pose>, Vec<[f64; 3]>) {
    let aim = Vector3::new(0.0, spec.distance, 25.0);
    let mut poses = Vec::new();
    let mut compass = Vec::new();
    for &e in &spec.stations {
        let c = Vector3::new(e, 0.0, 1.5);
        let v = aim - c;
        let (az, el) = (v.x.atan2(v.y), v.z.atan2(v.x.hypot(v.y)));
        let roll = 0.01 * rng.normal();
        poses.push(Pose {
            r: compass_rotation(az, el, roll),
            centre: c,
        });
        let s = spec.compass_sigma_deg.to_radians();
        compass.push([
            az + s * rng.normal(),
            el + 0.5 * s * rng.normal(),
            roll + 0.5 * s * rng.normal(),
        ]);
    }
    (poses, compass)
}

/// `image_observations.csv`: noisy pixel coordinates of every point inside each image.
fn measurements_table(
    spec: &CloseRangeSpec,
    cam: &Camera,
    poses: &[Pose],
    points: &[Point],
    rng: &mut Rng,
) -> String {
    let mut s = String::from("image,point,x_px,y_px,sigma_px\n");
    for (i, pose) in poses.iter().enumerate() {
        for (id, _, x) in points {
            if let Some(xy) = cam.project(pose, x) {
                let p = cam.image_to_pixel(xy)
                    + Vector2::new(rng.normal(), rng.normal()) * spec.sigma_px;
                if p.x > 0.0
                    && p.y > 0.0
                    && p.x < spec.width_px as f64
                    && p.y < spec.height_px as f64
                {
                    let _ = writeln!(s, "S{},{id},{:.3},{:.3},{}", i + 1, p.x, p.y, spec.sigma_px);
                }
            }
        }
    }
    s
}

/// `images.csv`: the stations with their compass azimuth, elevation and roll in degrees.
fn compass_table(compass: &[[f64; 3]]) -> String {
    let mut s = String::from("image,camera,strip,azimuth,elevation,roll\n");
    for (i, c) in compass.iter().enumerate() {
        let _ = writeln!(
            s,
            "S{},cam,1,{:.4},{:.4},{:.4}",
            i + 1,
            c[0].to_degrees(),
            c[1].to_degrees(),
            c[2].to_degrees()
        );
    }
    s
}

/// `antennas.csv`: the station centres with GNSS noise, a minute apart.
fn write_antennas(
    spec: &CloseRangeSpec,
    dir: &Path,
    poses: &[Pose],
    origin: &Geodetic,
    rng: &mut Rng,
) -> Result<(), SimError> {
    let [se, sn, su] = spec.gnss_sigma;
    let ids: Vec<String> = (1..=poses.len()).map(|i| format!("S{i}")).collect();
    let rows: Vec<AntennaRow> = poses
        .iter()
        .zip(&ids)
        .enumerate()
        .map(|(i, (p, id))| {
            let a =
                p.centre + Vector3::new(se * rng.normal(), sn * rng.normal(), su * rng.normal());
            AntennaRow {
                id,
                time: gnss::time::from_week_tow(2300, 200000.0 + 60.0 * i as f64),
                pos: geodetic(origin, &a),
                cov_enu: Matrix3::from_diagonal(&Vector3::new(se * se, sn * sn, su * su)),
                quality: 1,
                segment: 0,
                opk_deg: None,
                opk_sigma_deg: None,
                vel_enu: None,
            }
        })
        .collect();
    write(
        dir,
        "antennas.csv",
        &antenna_table("simulated station positions", &rows),
    )?;
    Ok(())
}

/// The project file: close-range mode, one camera, the tables, no lever arm.
fn project_toml(spec: &CloseRangeSpec) -> String {
    format!(
        "name = \"close-range pair\"\nmode = \"close-range\"\noutput = \"geodetic\"\n\n[[camera]]\nid = \"cam\"\nfocal_mm = {}\npixel_um = {}\nwidth_px = {}\nheight_px = {}\nsigma_px = {}\n\n[images]\nlist = \"images.csv\"\nmeasurements = \"image_observations.csv\"\n\n[ground]\nfile = \"ground_points.csv\"\n\n[gnss]\nantennas = \"antennas.csv\"\nestimate_lever_arm = false\n",
        spec.focal_mm, spec.pixel_um, spec.width_px, spec.height_px, spec.sigma_px
    )
}
