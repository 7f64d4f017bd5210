//! `nav-block`: an awkward aerial block like the ones converted from other tools —
//! navigation-grade GPS at the exposures, no tie points, control and check points each
//! measured in a few images only.
//!
//! The block: 5 strips of 12 images flown in alternating directions (east, west, …) with a
//! wind that gives 62 m/s ground speed eastwards and 48 m/s westwards and crab angles of
//! +6° and −4° (±1°) between the track and the camera's x axis; a 24.3 × 36 mm frame camera,
//! f = 50 mm, 4.5 µm pixels, 1000 m above the ground (1:20 000, 60 % / 30 % overlap);
//! image σ 1 px. 70 control (σ 3 cm horizontal, 5 cm vertical) and 16 check points, each
//! measured in 1–6 of the images that see it; three images measure nothing, and several
//! measure only one or two points.
//!
//! The GNSS (antenna table `antennas.csv`, with velocities): the true antenna position
//! minus v·δ (a latency δ, [`LATENCY_S`] by default: the camera fires δ after the time the position is
//! given for) plus a constant offset [`OFFSET_ENU`] (E, N, U of the site; |a| = 15.3 m) plus
//! white noise of σ 2 m per axis; velocities are the true track velocity plus 5 cm/s noise.
//! The lever arm (0, 0, 0.5) m is known and held fixed (along the track it would be as
//! correlated with δ as a constant along-track offset). `project.toml` estimates the drift as
//! one block offset and the latency per block; `project_gcp_only.toml` leaves the GNSS out.
//!
//! With `min_control` = 4 ([`NavSpec::resectable`]) every image measures at least four control
//! points (more measurements, and extra control points where an image sees fewer than four)
//! and no image is left empty: a variant whose every image can be resected on control alone.
//!
//! Truth: `truth.toml` (latency, offset, lever arm, σ), `truth_exposures.csv` (centres,
//! attitudes, velocities) and `truth_points.csv`, beside the [`NavTruth`] returned. Frame:
//! ENU at the site origin (metres), GPST seconds.

use super::nav_images::{noisy, seen, Meas, NavImage, HEIGHT_PX, PIXEL, SIGMA_PX, WIDTH_PX};
use super::spec::T_FIRST;
use crate::error::SimError;
use crate::ground_points::{geodetic, write_ground_points, Point};
use crate::io::write;
use crate::rng::Rng;
use exposure::export::{antenna_table, AntennaRow};
use gnss::frame::{enu_rotation, Geodetic};
use nalgebra::{Matrix3, Vector2, Vector3};
use photo::camera::{Camera, Pose};
use photo::rotation::{rot_z, Angles};
use std::fmt::Write as _;
use std::path::Path;

/// The simulated latency δ, seconds.
pub const LATENCY_S: f64 = 0.8;
/// The simulated constant GNSS offset (E, N, U of the site frame), metres.
pub const OFFSET_ENU: [f64; 3] = [8.0, -12.0, 5.0];
/// The antenna lever arm (u, v, w) in the camera frame, metres (known, held fixed).
pub const LEVER_ARM: [f64; 3] = [0.0, 0.0, 0.5];
/// σ of the navigation-grade GNSS positions per axis, metres.
pub const GNSS_SIGMA: f64 = 2.0;

const FOCAL: f64 = 0.035;
const HEIGHT: f64 = 1000.0;
const GCP_SIGMA: (f64, f64) = (0.03, 0.05);

/// What to simulate.
#[derive(Clone, Debug)]
pub struct NavSpec {
    /// Seed of every random draw.
    pub seed: u64,
    /// Strips × images per strip.
    pub strips: usize,
    /// Images per strip.
    pub per_strip: usize,
    /// Control points placed over the block.
    pub control: usize,
    /// Check points placed over the block.
    pub checks: usize,
    /// Every image measures at least this many control points (0: as drawn).
    pub min_control: usize,
    /// Images (flight order) whose measurements are all dropped.
    pub empty_images: Vec<usize>,
    /// Name of the projects written.
    pub name: String,
    /// Air base over the along-track footprint (0.4: 60 % forward overlap).
    pub base_fraction: f64,
    /// Strip spacing over the across-track footprint (0.7: 30 % side overlap).
    pub spacing_fraction: f64,
    /// The constant GNSS offset (E, N, U of the site frame), metres.
    pub offset_enu: [f64; 3],
    /// The latency δ (s): the camera fires δ after the time of its GNSS position.
    pub latency_s: f64,
    /// Weights of 1, 2, 3, 4 and 5 control points measured per image (each image draws its
    /// count, then that many of the control points it sees; check points in 2–4 images
    /// each, see `block::sparse`); `None`: each point measured in 1–6 images as drawn.
    pub control_per_image: Option<[f64; 5]>,
}

impl NavSpec {
    /// The awkward block of `ppkat simulate --builtin nav-block`.
    pub fn awkward() -> NavSpec {
        NavSpec {
            seed: 2025,
            strips: 6,
            per_strip: 10,
            control: 70,
            checks: 16,
            min_control: 0,
            empty_images: vec![5, 23, 41],
            name: "nav-block".into(),
            base_fraction: 0.4,
            spacing_fraction: 0.7,
            offset_enu: OFFSET_ENU,
            latency_s: LATENCY_S,
            control_per_image: None,
        }
    }

    /// `simulate --builtin sparse-control`: 10 strips of 29 images at 84 % / 69 % overlap,
    /// 71 control and 16 check points, the control measured as in a real film block (of 290
    /// images, 202 measure one control point, 49 two, 25 three, 10 four, 4 five), a 14 m
    /// GNSS offset and the 0.8 s latency.
    pub fn sparse_control() -> NavSpec {
        NavSpec {
            seed: 48,
            strips: 10,
            per_strip: 29,
            control: 71,
            checks: 16,
            min_control: 0,
            empty_images: Vec::new(),
            name: "sparse-control".into(),
            base_fraction: 0.16,
            spacing_fraction: 0.31,
            offset_enu: [6.0, -12.0, 4.0],
            latency_s: LATENCY_S,
            control_per_image: Some([202.0, 49.0, 25.0, 10.0, 4.0]),
        }
    }

    /// The same block with at least four control points in every image and none empty.
    pub fn resectable() -> NavSpec {
        NavSpec {
            min_control: 4,
            empty_images: Vec::new(),
            ..NavSpec::awkward()
        }
    }
}

/// What the simulation knows.
#[derive(Clone, Debug)]
pub struct NavTruth {
    /// Origin of the site ENU frame.
    pub origin: Geodetic,
    /// The exposures.
    pub images: Vec<NavImage>,
    /// Ground points written (id, kind gcp|check, true ENU).
    pub points: Vec<Point>,
    /// Measurements per image, in image order.
    pub per_image: Vec<usize>,
    /// Control measurements per image, in image order.
    pub control_per_image: Vec<usize>,
    /// Image measurements written.
    pub measurements: usize,
}

fn terrain(x: f64, y: f64) -> f64 {
    60.0 * ((x / 900.0).sin() * (y / 700.0).cos())
}

/// Simulate the block and write both projects and the truth into `dir`.
pub fn nav_block(spec: &NavSpec, dir: &Path) -> Result<NavTruth, SimError> {
    let mut rng = Rng::new(spec.seed);
    let cam = Camera::ideal(FOCAL, PIXEL, WIDTH_PX, HEIGHT_PX);
    let origin = Geodetic::from_degrees(46.52, 7.45, 620.0);
    let images = fly(spec, &mut rng);
    let mut points = place(spec, &cam, &images, &mut rng);
    let mut meas = match spec.control_per_image {
        Some(w) => super::sparse::measure(&w, &cam, &images, &points, &mut rng),
        None => measure(&cam, &images, &points, &mut rng),
    };
    if spec.min_control > 0 {
        fill_control(spec, &cam, &images, &mut points, &mut meas, &mut rng);
    }
    meas.retain(|m| !spec.empty_images.contains(&m.0));
    let mut seen = vec![false; points.len()];
    meas.iter().for_each(|m| seen[m.1] = true);
    let kept: Vec<Point> = (0..points.len())
        .filter(|&k| seen[k])
        .map(|k| points[k].clone())
        .collect();
    write(dir, "images.csv", &images_csv(&images))?;
    write(
        dir,
        "image_observations.csv",
        &measurements_csv(&cam, &images, &points, &meas),
    )?;
    write_ground_points(dir, &kept, GCP_SIGMA, None, &origin, &mut rng)?;
    write(
        dir,
        "antennas.csv",
        &antennas_csv(&images, &origin, spec, &mut rng),
    )?;
    write(dir, "project.toml", &project(&spec.name, true))?;
    write(dir, "project_gcp_only.toml", &project(&spec.name, false))?;
    write(dir, "truth.toml", &truth_toml(&origin, spec))?;
    write(dir, "truth_exposures.csv", &truth_exposures(&images))?;
    write(dir, "truth_points.csv", &truth_points(&kept))?;
    let mut per_image = vec![0; images.len()];
    let mut control_per_image = vec![0; images.len()];
    for m in &meas {
        per_image[m.0] += 1;
        control_per_image[m.0] += (points[m.1].1 == "gcp") as usize;
    }
    Ok(NavTruth {
        origin,
        images,
        points: kept,
        per_image,
        control_per_image,
        measurements: meas.len(),
    })
}

/// Along-track footprint, base and strip spacing (m).
fn layout(spec: &NavSpec) -> (f64, f64, f64) {
    let scale = HEIGHT / FOCAL;
    let along = WIDTH_PX as f64 * PIXEL * scale;
    let across = HEIGHT_PX as f64 * PIXEL * scale;
    (
        along,
        along * spec.base_fraction,
        across * spec.spacing_fraction,
    )
}

/// The exposures strip by strip, alternate strips flown west, with crab and tilt.
fn fly(spec: &NavSpec, rng: &mut Rng) -> Vec<NavImage> {
    let (_, base, spacing) = layout(spec);
    let mut t = T_FIRST;
    let mut images = Vec::new();
    for s in 0..spec.strips {
        let east = s % 2 == 0;
        let (speed, crab) = if east { (62.0, 6.0) } else { (48.0, -4.0) };
        let track = if east { 0.0 } else { std::f64::consts::PI };
        let vel = Vector3::new(track.cos() * speed, 0.0, 0.0);
        for k in 0..spec.per_strip {
            let i = if east { k } else { spec.per_strip - 1 - k };
            let kappa = track + (crab + rng.normal()).to_radians();
            let tilt = Angles::OmegaPhiKappa {
                omega: 1.5f64.to_radians() * rng.normal(),
                phi: 1.5f64.to_radians() * rng.normal(),
                kappa: 0.0,
            }
            .matrix();
            let centre = Vector3::new(
                i as f64 * base,
                s as f64 * spacing + 3.0 * rng.normal(),
                HEIGHT + 5.0 * rng.normal(),
            );
            let pose = Pose {
                r: rot_z(kappa) * tilt,
                centre,
            };
            images.push((format!("{}{:02}", s + 1, i + 1), s, pose, t, vel));
            t += base / speed;
        }
        t += 120.0;
    }
    images
}

/// Control and check points at random over the block, each seen by at least one image.
fn place(spec: &NavSpec, cam: &Camera, images: &[NavImage], rng: &mut Rng) -> Vec<Point> {
    let (along, base, spacing) = layout(spec);
    let xmax = (spec.per_strip - 1) as f64 * base + 0.3 * along;
    let ymax = (spec.strips - 1) as f64 * spacing + 0.4 * spacing;
    let mut points = Vec::new();
    for (kind, prefix, n) in [("gcp", "G", spec.control), ("check", "C", spec.checks)] {
        let mut k = 0;
        while k < n {
            let (x, y) = (
                rng.range(-0.3 * along, xmax),
                rng.range(-0.4 * spacing, ymax),
            );
            let p = Vector3::new(x, y, terrain(x, y));
            if images.iter().any(|im| seen(cam, &im.2, &p).is_some()) {
                k += 1;
                points.push((format!("{prefix}{k}"), kind, p));
            }
        }
    }
    points
}

/// Each point measured in 1–6 (at most all) of the images that see it, picked at random.
fn measure(cam: &Camera, images: &[NavImage], points: &[Point], rng: &mut Rng) -> Vec<Meas> {
    let mut meas = Vec::new();
    for (k, p) in points.iter().enumerate() {
        let mut sees: Vec<(usize, Vector2<f64>)> = images
            .iter()
            .enumerate()
            .filter_map(|(i, im)| seen(cam, &im.2, &p.2).map(|xy| (i, xy)))
            .collect();
        let n = (1 + (rng.uniform() * 6.0) as usize).min(sees.len());
        for _ in 0..n {
            let j = ((rng.uniform() * sees.len() as f64) as usize).min(sees.len() - 1);
            let (i, xy) = sees.swap_remove(j);
            meas.push((i, k, noisy(xy, rng)));
        }
    }
    meas.sort_by_key(|a| (a.0, a.1));
    meas
}

/// Measurements of control points until every image measures `spec.min_control` of them,
/// at least one in each quarter of the image: an unmeasured control point the image sees in
/// that quarter, or a new one (`GX…`) on the terrain under the quarter's centre.
fn fill_control(
    spec: &NavSpec,
    cam: &Camera,
    images: &[NavImage],
    points: &mut Vec<Point>,
    meas: &mut Vec<Meas>,
    rng: &mut Rng,
) {
    let quarter = |xy: &Vector2<f64>| (xy.x > 0.0) as usize + 2 * (xy.y > 0.0) as usize;
    let mut extra = 0;
    for (i, im) in images.iter().enumerate() {
        let measured = |meas: &[Meas], points: &[Point]| -> Vec<Vector2<f64>> {
            meas.iter()
                .filter(|m| m.0 == i && points[m.1].1 == "gcp")
                .map(|m| m.2)
                .collect()
        };
        for q in 0..4 {
            if measured(meas, points).iter().any(|xy| quarter(xy) == q) {
                continue;
            }
            let old = (0..points.len()).find_map(|k| {
                let xy = seen(cam, &im.2, &points[k].2)?;
                let new = points[k].1 == "gcp" && !meas.iter().any(|m| m.0 == i && m.1 == k);
                (new && quarter(&xy) == q).then_some((k, xy))
            });
            if let Some((k, xy)) = old {
                meas.push((i, k, noisy(xy, rng)));
                continue;
            }
            let sx = if q % 2 == 1 { 1.0 } else { -1.0 };
            let sy = if q >= 2 { 1.0 } else { -1.0 };
            let (w, h) = (WIDTH_PX as f64 * PIXEL, HEIGHT_PX as f64 * PIXEL);
            let xy = Vector2::new(
                sx * w * rng.range(0.15, 0.35),
                sy * h * rng.range(0.15, 0.35),
            );
            let p = on_terrain(&im.2, &xy);
            if let Some(xy) = seen(cam, &im.2, &p) {
                extra += 1;
                points.push((format!("GX{extra}"), "gcp", p));
                meas.push((i, points.len() - 1, noisy(xy, rng)));
            }
        }
        debug_assert!(measured(meas, points).len() >= spec.min_control.min(4));
    }
    meas.sort_by_key(|a| (a.0, a.1));
}

/// The terrain point seen at image coordinates `xy` (a few fixed-point steps on the ray).
fn on_terrain(pose: &Pose, xy: &Vector2<f64>) -> Vector3<f64> {
    let d = pose.r * Vector3::new(xy.x, xy.y, -FOCAL);
    let mut z = terrain(pose.centre.x, pose.centre.y);
    let mut p = pose.centre;
    for _ in 0..5 {
        p = pose.centre + d * ((z - pose.centre.z) / d.z);
        z = terrain(p.x, p.y);
    }
    Vector3::new(p.x, p.y, z)
}

fn images_csv(images: &[NavImage]) -> String {
    let mut s = String::from("image,camera,strip,week,tow\n");
    for im in images {
        let (week, tow) = gnss::time::week_tow(gnss::time::from_week_tow(0, im.3));
        let _ = writeln!(s, "{},cam,{},{week},{tow:.6}", im.0, im.1 + 1);
    }
    s
}

fn measurements_csv(cam: &Camera, images: &[NavImage], points: &[Point], meas: &[Meas]) -> String {
    let mut s = String::from("image,point,x_px,y_px,sigma_px\n");
    for (i, k, xy) in meas {
        let px = cam.image_to_pixel(*xy);
        let _ = writeln!(
            s,
            "{},{},{:.3},{:.3},{SIGMA_PX}",
            images[*i].0, points[*k].0, px.x, px.y
        );
    }
    s
}

/// The antenna table: true antenna − v·δ + offset + 2 m noise; velocity + 5 cm/s noise;
/// both expressed in the ENU at the antenna.
fn antennas_csv(images: &[NavImage], origin: &Geodetic, spec: &NavSpec, rng: &mut Rng) -> String {
    let offset = spec.offset_enu;
    let lever = photo::lever::LeverArm::new(Vector3::from(LEVER_ARM));
    let mut rows = Vec::new();
    for im in images {
        let noise = Vector3::new(rng.normal(), rng.normal(), rng.normal()) * GNSS_SIGMA;
        let a = lever.antenna(&im.2.centre, &im.2.r) - im.4 * spec.latency_s
            + Vector3::from(offset)
            + noise;
        let g = geodetic(origin, &a);
        let m = enu_rotation(&g) * enu_rotation(origin).transpose();
        let v = m * (im.4 + Vector3::new(rng.normal(), rng.normal(), rng.normal()) * 0.05);
        rows.push((im.0.clone(), im.3, g, v));
    }
    let rows: Vec<AntennaRow> = rows
        .iter()
        .map(|(id, t, g, v)| AntennaRow {
            id,
            time: gnss::time::from_week_tow(0, *t),
            pos: *g,
            cov_enu: Matrix3::identity() * GNSS_SIGMA.powi(2),
            quality: 5,
            segment: 0,
            opk_deg: None,
            opk_sigma_deg: None,
            vel_enu: Some([v.x, v.y, v.z]),
        })
        .collect();
    antenna_table(
        "simulated navigation-grade GPS: antenna - v*latency + offset + noise",
        &rows,
    )
}

/// `project.toml` (with the GNSS: block offset, block latency) or `project_gcp_only.toml`.
fn project(name: &str, gnss: bool) -> String {
    let mut s = format!(
        "name = \"{name}{}\"\noutput = \"utm\"\n\n[[camera]]\nid = \"cam\"\nfocal_mm = {}\npixel_um = {}\nwidth_px = {WIDTH_PX}\nheight_px = {HEIGHT_PX}\nsigma_px = {SIGMA_PX}\n\n[images]\nlist = \"images.csv\"\nmeasurements = \"image_observations.csv\"\n\n[ground]\nfile = \"ground_points.csv\"\n",
        if gnss { "" } else { " (control only)" },
        FOCAL * 1e3,
        PIXEL * 1e6
    );
    if gnss {
        let _ = write!(
            s,
            "\n[gnss]\nantennas = \"antennas.csv\"\nlever_arm = [{}, {}, {}]\nestimate_lever_arm = false\ndrift = \"block\"\ndrift_model = \"offset\"\nlatency = \"block\"\n",
            LEVER_ARM[0], LEVER_ARM[1], LEVER_ARM[2]
        );
    }
    s
}

fn truth_toml(origin: &Geodetic, spec: &NavSpec) -> String {
    let (offset, latency) = (spec.offset_enu, spec.latency_s);
    format!(
        "# nav-block / sparse-control truth. latency: the camera fires latency_s after the time of its GNSS position\n# (antenna at the exposure = GNSS position + v * latency_s). offset: GNSS minus true antenna,\n# E/N/U of the site frame (m). Frame: ENU at origin (lat, lon deg, h m).\nlatency_s = {latency}\noffset_enu = [{}, {}, {}]\nlever_arm = [{}, {}, {}]\ngnss_sigma_m = {GNSS_SIGMA}\nvelocity_sigma_ms = 0.05\norigin = [{:.9}, {:.9}, {:.3}]\n",
        offset[0],
        offset[1],
        offset[2],
        LEVER_ARM[0],
        LEVER_ARM[1],
        LEVER_ARM[2],
        origin.lat.to_degrees(),
        origin.lon.to_degrees(),
        origin.h
    )
}

fn truth_exposures(images: &[NavImage]) -> String {
    let mut s = String::from("# true exposures: projection centre in the site ENU (m), omega/phi/kappa (deg) of R camera->ENU, true antenna velocity ENU (m/s); GPST\nid,strip,week,tow,e,n,u,omega,phi,kappa,ve,vn,vu\n");
    for (id, strip, pose, t, v) in images {
        let (week, tow) = gnss::time::week_tow(gnss::time::from_week_tow(0, *t));
        let [o, p, k] = exposure::attitude::omega_phi_kappa(&pose.r).map(f64::to_degrees);
        let c = pose.centre;
        let _ = writeln!(
            s,
            "{id},{},{week},{tow:.6},{:.4},{:.4},{:.4},{o:.6},{p:.6},{k:.6},{:.3},{:.3},{:.3}",
            strip + 1,
            c.x,
            c.y,
            c.z,
            v.x,
            v.y,
            v.z
        );
    }
    s
}

fn truth_points(points: &[Point]) -> String {
    let mut s = String::from("# true ground points, site ENU (m)\npoint,kind,e,n,u\n");
    for (id, kind, x) in points {
        let _ = writeln!(s, "{id},{kind},{:.4},{:.4},{:.4}", x.x, x.y, x.z);
    }
    s
}
