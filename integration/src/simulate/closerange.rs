//! A simulated close-range job: one camera at a few ground stations whose positions come from
//! GNSS, approximate angles from a compass, a distant target with control, check and feature
//! points. Written as a `mode = "close-range"` project for `ppkat adjust`.

use super::rng::Rng;
use super::{write, SimError};
use crate::adjust::build::compass_rotation;
use crate::exposure::export::{antenna_table, AntennaRow};
use gnss::frame::{Enu, Geodetic};
use nalgebra::{Matrix3, Vector2, Vector3};
use photo::camera::{Camera, Pose};
use std::fmt::Write as _;
use std::path::Path;

#[derive(Clone, Debug)]
pub struct CloseRangeSpec {
    pub seed: u64,
    pub lat_deg: f64,
    pub lon_deg: f64,
    pub h: f64,
    /// Station east coordinates (north = 0, up = 1.5 m).
    pub stations: Vec<f64>,
    /// Distance to the target, m.
    pub distance: f64,
    pub focal_mm: f64,
    pub pixel_um: f64,
    pub width_px: usize,
    pub height_px: usize,
    pub sigma_px: f64,
    pub gnss_sigma: [f64; 3],
    pub compass_sigma_deg: f64,
    pub controls: usize,
    pub checks: usize,
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
    pub origin: Geodetic,
    pub poses: Vec<Pose>,
    pub points: Vec<(String, &'static str, Vector3<f64>)>,
}

pub fn close_range(spec: &CloseRangeSpec, dir: &Path) -> Result<CloseRangeTruth, SimError> {
    let mut rng = Rng::new(spec.seed);
    let px = spec.pixel_um * 1e-6;
    let cam = Camera::ideal(spec.focal_mm * 1e-3, px, spec.width_px, spec.height_px);
    let origin = Geodetic::from_degrees(spec.lat_deg, spec.lon_deg, spec.h);
    let d = spec.distance;
    // Target: a rough slope facing the stations, ~70 % of the narrower view.
    let half_w = 0.35 * d * spec.width_px as f64 * px / cam.f;
    let half_h = 0.35 * d * spec.height_px as f64 * px / cam.f;
    let target = |rng: &mut Rng| {
        let e = rng.range(-half_w, half_w);
        let u = rng.range(-half_h, half_h) + 25.0;
        Vector3::new(e, d + 15.0 * (e / 40.0).sin() + 0.2 * u, u)
    };
    let mut points = Vec::new();
    for k in 0..spec.controls {
        // Spread the control: left, right, top of the target.
        let a = k as f64 / spec.controls.max(1) as f64 * std::f64::consts::TAU + 0.3;
        let (e, u) = (0.8 * half_w * a.cos(), 25.0 + 0.8 * half_h * a.sin());
        points.push((
            format!("P{}", k + 1),
            "gcp",
            Vector3::new(e, d + 15.0 * (e / 40.0).sin() + 0.2 * u, u),
        ));
    }
    for k in 0..spec.checks {
        points.push((format!("C{}", k + 1), "check", target(&mut rng)));
    }
    for k in 0..spec.features {
        points.push((format!("F{}", k + 1), "tie", target(&mut rng)));
    }
    // Stations looking at the target centre.
    let aim = Vector3::new(0.0, d, 25.0);
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
    let mut s = String::from("image,point,x_px,y_px,sigma_px\n");
    for (i, pose) in poses.iter().enumerate() {
        for (id, _, x) in &points {
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
    write(dir, "image_observations.csv", &s)?;
    let geo = |v: &Vector3<f64>| Enu(*v).to_ecef(&origin.to_ecef()).to_geodetic();
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
    write(dir, "images.csv", &s)?;
    let mut s = String::from("point,kind,lat,lon,h,sigma_xy,sigma_z\n");
    for (id, kind, x) in points.iter().filter(|p| p.1 != "tie") {
        let mut x = *x;
        if *kind == "gcp" {
            x += Vector3::new(
                0.01 * rng.normal(),
                0.01 * rng.normal(),
                0.015 * rng.normal(),
            );
        }
        let g = geo(&x);
        let _ = writeln!(
            s,
            "{id},{kind},{:.10},{:.10},{:.4},0.01,0.015",
            g.lat.to_degrees(),
            g.lon.to_degrees(),
            g.h
        );
    }
    write(dir, "ground_points.csv", &s)?;
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
                pos: geo(&a),
                cov_enu: Matrix3::from_diagonal(&Vector3::new(se * se, sn * sn, su * su)),
                quality: 1,
                segment: 0,
                opk_deg: None,
            }
        })
        .collect();
    write(
        dir,
        "antennas.csv",
        &antenna_table("simulated station positions", &rows),
    )?;
    let project = format!(
        "name = \"close-range pair\"\nmode = \"close-range\"\noutput = \"geodetic\"\n\n[[camera]]\nid = \"cam\"\nfocal_mm = {}\npixel_um = {}\nwidth_px = {}\nheight_px = {}\nsigma_px = {}\n\n[images]\nlist = \"images.csv\"\nmeasurements = \"image_observations.csv\"\n\n[ground]\nfile = \"ground_points.csv\"\n\n[gnss]\nantennas = \"antennas.csv\"\nestimate_lever_arm = false\n",
        spec.focal_mm, spec.pixel_um, spec.width_px, spec.height_px, spec.sigma_px
    );
    write(dir, "project.toml", &project)?;
    Ok(CloseRangeTruth {
        origin,
        poses,
        points,
    })
}
