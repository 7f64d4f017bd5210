//! Start values of the orientations, in order of preference: the attitude of the antenna
//! table; compass angles (refined by a three-angle resection on the control seen, close
//! range); nadir along the strip direction of the neighbouring antennas; a resection on ≥ 4
//! control points; a resection on tie points intersected from the images that have a start.
//! What enters: the project, the frame, the measurements by point and the antenna of each
//! image. What leaves: a pose per image, or an error naming the images without one.

use super::error::{problem_err as err, AdjustError};
use super::frame::LocalFrame;
use super::project::{Mode, PointKind, Project};
use nalgebra::{Matrix3, Vector2, Vector3};
use photo::camera::Pose;
use photo::intersection::{intersect, Ray};
use photo::lever::LeverArm;
use photo::resection::{resect, resect_angles, Control};
use std::collections::BTreeMap;

/// Measurements by point id (indices into the project's measurements), in id order.
pub(super) type Rays<'a> = BTreeMap<&'a str, Vec<usize>>;

/// Camera → ENU of a camera looking at `azimuth` (from north), `elevation`, rolled by `roll`.
pub fn compass_rotation(az: f64, el: f64, roll: f64) -> Matrix3<f64> {
    let d = Vector3::new(az.sin() * el.cos(), az.cos() * el.cos(), el.sin());
    let x0 = Vector3::new(az.cos(), -az.sin(), 0.0);
    let z = -d;
    let y0 = z.cross(&x0);
    let (c, s) = (roll.cos(), roll.sin());
    let x = x0 * c + y0 * s;
    let y = z.cross(&x);
    Matrix3::from_columns(&[x, y, z])
}

/// A point intersected from its measurements (indices) in the images that have a pose; `None`
/// with fewer than two such rays or when the rays do not meet.
pub(super) fn intersect_point<'a>(
    p: &'a Project,
    measurements: &[usize],
    pose_of: impl Fn(usize) -> Option<&'a Pose>,
) -> Option<Vector3<f64>> {
    let rays: Vec<Ray> = measurements
        .iter()
        .filter_map(|&k| {
            let m = &p.measurements[k];
            pose_of(m.image).map(|pose| Ray {
                camera: &p.cameras[p.images[m.image].camera].camera,
                pose,
                xy: m.xy,
                sigma: m.sigma,
            })
        })
        .collect();
    if rays.len() < 2 {
        return None;
    }
    intersect(&rays).ok().map(|x| x.point)
}

/// The measurements of image `i` whose points have object coordinates (`object_of`), for a
/// resection.
fn controls_in(
    p: &Project,
    i: usize,
    object_of: impl Fn(&str) -> Option<Vector3<f64>>,
) -> Vec<Control> {
    p.measurements
        .iter()
        .filter(|m| m.image == i)
        .filter_map(|m| {
            object_of(&m.point).map(|object| Control {
                object,
                image: m.xy,
                sigma: m.sigma,
            })
        })
        .collect()
}

/// The start orientation of every image.
pub(super) fn orientations(
    p: &Project,
    frame: &LocalFrame,
    rays: &Rays,
    antenna_of: &[Option<usize>],
) -> Result<Vec<Pose>, AdjustError> {
    let lever0 = p
        .file
        .gnss
        .as_ref()
        .map(|g| g.lever_arm())
        .unwrap_or_default();
    let mut start: Vec<Option<Pose>> = (0..p.images.len())
        .map(|i| {
            super::start_file::given_start(&p.starts, frame, i)
                .or_else(|| start_pose(p, frame, antenna_of, &lever0, i))
        })
        .collect();
    if start.iter().any(|s| s.is_none()) {
        resect_on_ties(p, rays, &mut start);
    }
    // Images without any start: refuse with the ids.
    let lost: Vec<&str> = p
        .images
        .iter()
        .zip(&start)
        .filter(|(_, s)| s.is_none())
        .map(|(im, _)| im.id.as_str())
        .collect();
    if !lost.is_empty() {
        return Err(err(format!(
            "no start orientation for image(s) {}: give a GNSS antenna position (with attitude or within a strip), compass angles, or at least 4 control or tie points in each that other images also see",
            lost.join(", ")
        )));
    }
    Ok(start.into_iter().flatten().collect())
}

/// The camera rotation of image `i` from the antenna table's attitude, compass angles, or the
/// strip direction (nadir, x along the strip) of the neighbouring antennas.
fn start_rotation(
    p: &Project,
    frame: &LocalFrame,
    antenna_of: &[Option<usize>],
    i: usize,
) -> Option<Matrix3<f64>> {
    let im = &p.images[i];
    let antenna = antenna_of[i].map(|k| &p.antennas[k]);
    if let Some(r) = antenna.and_then(|a| a.rotation.map(|r| frame.from_enu_at(&a.pos) * r)) {
        return Some(r);
    }
    if let Some([az, el, roll]) = im.compass {
        return Some(compass_rotation(az, el, roll));
    }
    let a = antenna?;
    let here = frame.to_local(&a.pos);
    let mut dir = Vector2::zeros();
    for (j, other) in p.images.iter().enumerate() {
        if j != i && other.strip == im.strip {
            if let Some(b) = antenna_of[j].map(|k| &p.antennas[k]) {
                let d = frame.to_local(&b.pos) - here;
                let dt = (b.time - a.time).to_seconds();
                if dt != 0.0 && dt.abs() < 120.0 {
                    dir += Vector2::new(d.x, d.y) / dt;
                }
            }
        }
    }
    (dir.norm() > 0.0).then(|| photo::rotation::rot_z(dir.y.atan2(dir.x)))
}

/// The start pose of image `i` from its antenna and rotation, or a resection on the control
/// it sees.
fn start_pose(
    p: &Project,
    frame: &LocalFrame,
    antenna_of: &[Option<usize>],
    lever0: &LeverArm,
    i: usize,
) -> Option<Pose> {
    let cam = &p.cameras[p.images[i].camera].camera;
    let antenna = antenna_of[i].map(|k| &p.antennas[k]);
    let control_of = |id: &str| {
        p.ground
            .iter()
            .find(|g| g.id == id && g.kind == PointKind::Control)
    };
    let controls = controls_in(p, i, |id| control_of(id).map(|g| frame.to_local(&g.pos)));
    match (antenna, start_rotation(p, frame, antenna_of, i)) {
        (Some(a), Some(r)) => {
            let centre = lever0.centre(&frame.to_local(&a.pos), &r);
            // Close range: refine the compass angles on the control seen (≥ 2 points).
            let r = if p.file.mode == Mode::CloseRange && controls.len() >= 2 {
                resect_angles(cam, centre, &controls, Some(r))
                    .map(|x| x.pose.r)
                    .unwrap_or(r)
            } else {
                r
            };
            Some(Pose { r, centre })
        }
        (Some(a), None) if controls.len() >= 2 => {
            let centre = frame.to_local(&a.pos);
            resect_angles(cam, centre, &controls, None)
                .ok()
                .map(|x| x.pose)
        }
        _ if controls.len() >= 4 => resect(cam, &controls).ok().map(|x| x.pose),
        _ => None,
    }
}

/// Images still without a start (no GNSS, no control): resect them on tie points intersected
/// from the images that have one.
fn resect_on_ties(p: &Project, rays: &Rays, start: &mut [Option<Pose>]) {
    let known: BTreeMap<&str, Vector3<f64>> = rays
        .iter()
        .filter_map(|(id, ks)| intersect_point(p, ks, |i| start[i].as_ref()).map(|x| (*id, x)))
        .collect();
    for (i, st) in start.iter_mut().enumerate() {
        if st.is_some() {
            continue;
        }
        let pts = controls_in(p, i, |id| known.get(id).copied());
        if pts.len() >= 4 {
            let cam = &p.cameras[p.images[i].camera].camera;
            *st = resect(cam, &pts).ok().map(|x| x.pose);
        }
    }
}
