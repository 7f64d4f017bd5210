//! The files of a simulated aerial block: the image list, the measurements, the antenna table
//! with its `.pos` trajectory, and `project.toml` (the ground points are written by
//! [`crate::ground_points`], shared with the close-range pair). Coordinates go out geodetic (degrees, ellipsoidal metres),
//! times as GPS week and seconds of week, covariances in ENU (m²).

use super::spec::{BlockSpec, Image, Measurement, T_FIRST};
use crate::error::SimError;
use crate::ground_points::{geodetic, Point};
use crate::io::write;
use crate::rng::Rng;
use exposure::export::{antenna_table, AntennaRow};
use gnss::frame::{enu_rotation, Geodetic};
use nalgebra::{Matrix3, Vector3};
use photo::camera::Camera;
use std::fmt::Write as _;
use std::path::Path;

/// `images.csv`: image, camera, strip (from 1), GPS week and seconds of week.
pub(super) fn images_table(images: &[Image]) -> String {
    let mut s = String::from("image,camera,strip,week,tow\n");
    for im in images {
        let (week, tow) = gnss::time::week_tow(gnss::time::from_week_tow(0, im.3));
        let _ = writeln!(s, "{},cam,{},{week},{tow:.6}", im.0, im.1 + 1);
    }
    s
}

/// `image_observations.csv`: the measurements in pixels of the nominal camera.
pub(super) fn measurements_table(
    spec: &BlockSpec,
    nominal: &Camera,
    meas: &[Measurement],
    images: &[Image],
    points: &[Point],
) -> String {
    let mut s = String::from("image,point,x_px,y_px,sigma_px\n");
    for (i, k, xy) in meas {
        let px = nominal.image_to_pixel(*xy);
        let _ = writeln!(
            s,
            "{},{},{:.3},{:.3},{}",
            images[*i].0,
            points[*k].0,
            px.x,
            px.y,
            spec.sigma_image_um / spec.pixel_um
        );
    }
    s
}

/// The GNSS antenna covariance in the site's ENU frame (m²) from the spec's σ and
/// correlations, and its Cholesky factor (the diagonal of σ when not positive definite).
fn gnss_covariance(spec: &BlockSpec) -> (Matrix3<f64>, Matrix3<f64>) {
    let [se, sn, su] = spec.gnss_sigma;
    let [ren, reu, rnu] = spec.gnss_corr;
    let cov = Matrix3::new(
        se * se,
        ren * se * sn,
        reu * se * su,
        ren * se * sn,
        sn * sn,
        rnu * sn * su,
        reu * se * su,
        rnu * sn * su,
        su * su,
    );
    let l = cov
        .cholesky()
        .map(|c| c.l())
        .unwrap_or_else(|| Matrix3::from_diagonal(&Vector3::from(spec.gnss_sigma)));
    (cov, l)
}

/// Write `antennas.csv` (antenna = centre + R·lever arm + drift + correlated noise, with the
/// segment jump) and `trajectory.pos` (the same antennas as a fixed trajectory, with epochs
/// every air-base interval through the turns so that it has no gaps).
pub(super) fn write_antennas(
    spec: &BlockSpec,
    dir: &Path,
    images: &[Image],
    origin: &Geodetic,
    air_base: f64,
    rng: &mut Rng,
) -> Result<(), SimError> {
    let (cov, l) = gnss_covariance(spec);
    let mut rows = Vec::new();
    let mut track: Vec<gnss::solution::PosRecord> = Vec::new();
    for (k, im) in images.iter().enumerate() {
        let dt = im.3 - T_FIRST;
        let mut drift = Vector3::from(spec.drift_a) + Vector3::from(spec.drift_b) * dt;
        let segment = match spec.segment_jump {
            Some((from, jump)) if k >= from => {
                drift += Vector3::from(jump);
                1
            }
            _ => 0,
        };
        let noise = l * Vector3::new(rng.normal(), rng.normal(), rng.normal());
        let lever = photo::lever::LeverArm::new(Vector3::from(spec.lever_arm));
        let a = lever.antenna(&im.2.centre, &im.2.r) + drift + noise;
        let g = geodetic(origin, &a);
        // Noise drawn in the site ENU: express the covariance in the ENU at the antenna.
        let ra = enu_rotation(&g);
        let m = ra * enu_rotation(origin).transpose();
        let c = m * cov * m.transpose();
        let time = gnss::time::from_week_tow(0, im.3);
        let rec = gnss::solution::PosRecord {
            time,
            pos: g.to_ecef(),
            quality: gnss::solution::Quality::Fixed,
            nsat: 12,
            cov: ra.transpose() * c * ra,
            age: 0.0,
            ratio: 99.0,
        };
        bridge_turn(&mut track, &rec, air_base / spec.speed);
        track.push(rec);
        rows.push(AntennaRow {
            id: &im.0,
            time,
            pos: g,
            cov_enu: c,
            quality: 1,
            segment,
            opk_deg: None,
            opk_sigma_deg: None,
            vel_enu: None,
        });
    }
    write(
        dir,
        "antennas.csv",
        &antenna_table(
            "simulated: antenna = centre + R*lever + drift + noise",
            &rows,
        ),
    )?;
    gnss::solution::write_pos(
        &dir.join("trajectory.pos"),
        &["program   : ppkat simulate (block antenna trajectory)".to_string()],
        &track,
        gnss::solution::PosFormat::Llh,
    )?;
    Ok(())
}

/// Epochs every `step` seconds on the straight line from the last record of `track` to
/// `next` (through the turns: their positions matter to nobody, they keep the trajectory
/// free of gaps).
fn bridge_turn(
    track: &mut Vec<gnss::solution::PosRecord>,
    next: &gnss::solution::PosRecord,
    step: f64,
) {
    let Some(prev) = track.last().cloned() else {
        return;
    };
    let gap = (next.time - prev.time).to_seconds();
    let n = (gap / step).floor() as usize;
    for j in 1..n {
        let f = j as f64 / n as f64;
        let mut mid = prev.clone();
        mid.time = prev.time + hifitime::Duration::from_seconds(gap * f);
        mid.pos = gnss::frame::Ecef(prev.pos.0 * (1.0 - f) + next.pos.0 * f);
        track.push(mid);
    }
}

/// The project file: one camera (nominal values), the tables, the spec's extra sections.
pub(super) fn project_toml(spec: &BlockSpec, npx: usize) -> String {
    format!(
        "name = \"{}\"\noutput = \"utm\"\n\n[[camera]]\nid = \"cam\"\nfocal_mm = {}\npixel_um = {}\nwidth_px = {npx}\nheight_px = {npx}\nsigma_px = {}\n{}\n[images]\nlist = \"images.csv\"\nmeasurements = \"image_observations.csv\"\n\n[ground]\nfile = \"ground_points.csv\"\n\n{}",
        spec.name, spec.focal_mm, spec.pixel_um, spec.sigma_image_um / spec.pixel_um, spec.camera_options, spec.project_options
    )
}
