//! From a loaded project to a `photo::lsq::Problem`: the local frame (ENU tangent plane at
//! the block centre), start values (GNSS centres and attitude, compass angles refined by a
//! three-angle resection, or nadir along the strip; points by forward intersection) and one
//! factor per observation, each keeping its own bookkeeping (image, point, antenna record,
//! source line). Input problems are refused here with the ids that cause them.
//!
//! Keys: `Pose(ImageId(i))` for the i-th image of the list, `Point(PointId(k))` for the k-th
//! measured point id in sorted order (`Built::point_names`), `LeverArm(CameraId(c))` and
//! `Camera(CameraId(c))` for camera c, `Drift(DriftId(d))` for `Built::drifts[d]`.

use super::error::AdjustError;
use super::factors::{DriftModel, GnssCentre};
use super::project::{DriftGroup, Mode, PointKind, Project};
use gnss::frame::{enu_rotation, Ecef, Geodetic};
use nalgebra::{DMatrix, DVector, Matrix3, Vector2, Vector3};
use photo::camera::Pose;
use photo::factors::{ImagePoint, Prior};
use photo::intersection::{intersect, Ray};
use photo::lsq::{
    CameraId, DriftId, Group, ImageId, Key, Loss, Noise, Options, PointId, Problem, Value,
};
use photo::resection::{resect, resect_angles, Control};
use std::collections::BTreeMap;

/// The local adjustment frame: ENU axes at `origin`.
#[derive(Clone, Debug)]
pub struct LocalFrame {
    pub origin: Ecef,
    pub geodetic: Geodetic,
    /// ECEF → ENU.
    pub rot: Matrix3<f64>,
}

impl LocalFrame {
    pub fn new(g: Geodetic) -> LocalFrame {
        LocalFrame {
            origin: g.to_ecef(),
            geodetic: g,
            rot: enu_rotation(&g),
        }
    }
    pub fn to_local(&self, p: &Ecef) -> Vector3<f64> {
        self.rot * (p.0 - self.origin.0)
    }
    pub fn to_ecef(&self, v: &Vector3<f64>) -> Ecef {
        Ecef(self.origin.0 + self.rot.transpose() * v)
    }
    /// A matrix expressed in the ENU frame at `at` → the same in this frame.
    pub fn from_enu_at(&self, at: &Ecef) -> Matrix3<f64> {
        self.rot * enu_rotation(&at.to_geodetic()).transpose()
    }
}

/// Observation groups (variance components).
pub const GROUP_IMAGE: Group = Group(0);
/// Control points.
pub const GROUP_CONTROL: Group = Group(1);
/// GNSS antenna positions.
pub const GROUP_GNSS: Group = Group(2);
/// Lever-arm priors.
pub const GROUP_PRIOR: Group = Group(3);
/// Measured distances.
pub const GROUP_DISTANCE: Group = Group(4);
/// Names of the groups, by index.
pub const GROUP_NAMES: [&str; 5] = [
    "image points",
    "control points",
    "GNSS centres",
    "lever-arm prior",
    "distances",
];

/// A drift group (key `Drift(DriftId(index))`): its name, model and reference time.
#[derive(Clone, Debug)]
pub struct DriftBlock {
    pub name: String,
    pub model: DriftModel,
    /// Reference time t0, GPST seconds.
    pub t0: f64,
}

/// The assembled problem and how to read it back.
pub struct Built {
    pub frame: LocalFrame,
    pub problem: Problem,
    /// Measured point ids by `PointId` (sorted); those with a block are adjusted.
    pub point_names: Vec<String>,
    pub drifts: Vec<DriftBlock>,
    /// Points measured in a single image (not determinable): id and its image.
    pub single_ray: Vec<(String, String)>,
    /// Antenna records whose image is not in the list.
    pub unused_antennas: Vec<String>,
}

fn err(what: String) -> AdjustError {
    AdjustError::Problem(what)
}

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
fn intersect_point<'a>(
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

pub fn build(p: &Project) -> Result<Built, AdjustError> {
    let gnss = p.file.gnss.as_ref();
    // Measured points and images.
    let mut rays: BTreeMap<&str, Vec<usize>> = BTreeMap::new();
    let mut per_image = vec![0usize; p.images.len()];
    for (k, m) in p.measurements.iter().enumerate() {
        rays.entry(m.point.as_str()).or_default().push(k);
        per_image[m.image] += 1;
    }
    let empty: Vec<&str> = p
        .images
        .iter()
        .zip(&per_image)
        .filter(|(_, n)| **n == 0)
        .map(|(im, _)| im.id.as_str())
        .collect();
    if !empty.is_empty() {
        return Err(err(format!(
            "image(s) {} have no measured points: measure tie points in them or remove them from the image list",
            empty.join(", ")
        )));
    }
    let unmeasured: Vec<&str> = p
        .ground
        .iter()
        .filter(|g| !rays.contains_key(g.id.as_str()))
        .map(|g| g.id.as_str())
        .collect();
    if !unmeasured.is_empty() {
        return Err(err(format!(
            "ground point(s) {} are not measured in any image: check their ids against the measurements, or remove them",
            unmeasured.join(", ")
        )));
    }
    let n_control = p
        .ground
        .iter()
        .filter(|g| g.kind == PointKind::Control)
        .count();
    // Antennas by image.
    let image_index: BTreeMap<&str, usize> = p
        .images
        .iter()
        .enumerate()
        .map(|(i, im)| (im.id.as_str(), i))
        .collect();
    let mut antenna_of: Vec<Option<usize>> = vec![None; p.images.len()];
    let mut unused_antennas = Vec::new();
    if gnss.is_some() {
        for (k, a) in p.antennas.iter().enumerate() {
            match image_index.get(a.image.as_str()) {
                Some(&i) => antenna_of[i] = Some(k),
                None => unused_antennas.push(a.image.clone()),
            }
        }
        let mut strips: BTreeMap<&str, (usize, usize)> = BTreeMap::new();
        for (i, im) in p.images.iter().enumerate() {
            let e = strips.entry(im.strip.as_str()).or_default();
            e.0 += 1;
            e.1 += antenna_of[i].is_some() as usize;
        }
        let bare: Vec<String> = strips
            .iter()
            .filter(|(_, (_, g))| *g == 0)
            .map(|(s, (n, _))| format!("strip {s} ({n} images)"))
            .collect();
        if !bare.is_empty() {
            return Err(err(format!(
                "{} without any GNSS antenna position: check the image ids of the antenna table, or drop [gnss] and use control points",
                bare.join(", ")
            )));
        }
    }
    let n_gnss = antenna_of.iter().flatten().count();
    if n_gnss == 0 && n_control < 3 {
        return Err(err(format!(
            "datum defect: {n_control} control point(s) and no GNSS centres — the block's position, orientation and scale are not determined; give at least 3 control points or GNSS antenna positions"
        )));
    }
    // The frame: tangent plane at the centre of the GNSS centres or of the control.
    let centre_pts: Vec<Ecef> = if n_gnss > 0 {
        p.antennas.iter().map(|a| a.pos).collect()
    } else {
        p.ground.iter().map(|g| g.pos).collect()
    };
    let mean = centre_pts.iter().fold(Vector3::zeros(), |a, x| a + x.0) / centre_pts.len() as f64;
    let mut g0 = Ecef(mean).to_geodetic();
    g0.h = if p.ground.is_empty() {
        0.0
    } else {
        p.ground.iter().map(|g| g.pos.to_geodetic().h).sum::<f64>() / p.ground.len() as f64
    };
    let frame = LocalFrame::new(g0);
    let lever0 = gnss.map(|g| g.lever_arm()).unwrap_or_default();

    // Start orientations.
    let control_of = |id: &str| {
        p.ground
            .iter()
            .find(|g| g.id == id && g.kind == PointKind::Control)
    };
    let mut start: Vec<Option<Pose>> = vec![None; p.images.len()];
    for (i, im) in p.images.iter().enumerate() {
        let cam = &p.cameras[im.camera].camera;
        let antenna = antenna_of[i].map(|k| &p.antennas[k]);
        let rot = if let Some(r) =
            antenna.and_then(|a| a.rotation.map(|r| frame.from_enu_at(&a.pos) * r))
        {
            Some(r)
        } else if let Some([az, el, roll]) = im.compass {
            Some(compass_rotation(az, el, roll))
        } else if let Some(a) = antenna {
            // Nadir, x along the strip (from the neighbouring antennas of the strip).
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
        } else {
            None
        };
        let controls = controls_in(p, i, |id| control_of(id).map(|g| frame.to_local(&g.pos)));
        start[i] = match (antenna, rot) {
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
        };
    }
    // Images still without a start (no GNSS, no control): resect them on tie points
    // intersected from the images that have one.
    if start.iter().any(|s| s.is_none()) {
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
    let start: Vec<Pose> = start.into_iter().flatten().collect();

    let (pr, point_names, single_ray, drifts) = problem(p, &frame, &rays, &start, &antenna_of)?;
    Ok(Built {
        frame,
        problem: pr,
        point_names,
        drifts,
        single_ray,
        unused_antennas,
    })
}

/// Blocks and factors; returns the problem, the point names by `PointId`, the points left
/// out for having a single ray (id, image) and the drift groups.
#[allow(clippy::type_complexity)]
fn problem(
    p: &Project,
    frame: &LocalFrame,
    rays: &BTreeMap<&str, Vec<usize>>,
    start: &[Pose],
    antenna_of: &[Option<usize>],
) -> Result<(Problem, Vec<String>, Vec<(String, String)>, Vec<DriftBlock>), AdjustError> {
    let opts = &p.file.adjustment;
    let loss = match opts.loss.as_str() {
        "huber" => Loss::Huber(3.0),
        "cauchy" => Loss::Cauchy(3.0),
        _ => Loss::Trivial,
    };
    let mut pr = Problem::new(Options {
        max_iterations: opts.max_iterations,
        ..Options::default()
    });
    let built = |e: photo::lsq::BuildError| err(e.to_string());
    for (i, s) in start.iter().enumerate() {
        pr.add_block(Key::Pose(ImageId::from(i)), Value::Pose(*s))
            .map_err(built)?;
    }
    let point_names: Vec<String> = rays.keys().map(|s| s.to_string()).collect();
    let mut single_ray = Vec::new();
    for (k, (id, ks)) in rays.iter().enumerate() {
        let ground = p.ground.iter().find(|g| g.id == *id);
        let control = ground.is_some_and(|g| g.kind == PointKind::Control);
        let images: std::collections::BTreeSet<usize> =
            ks.iter().map(|k| p.measurements[*k].image).collect();
        let x = match ground {
            Some(g) if control => Some(frame.to_local(&g.pos)),
            _ if images.len() >= 2 => intersect_point(p, ks, |i| Some(&start[i])),
            _ => None,
        };
        match x {
            Some(x) if images.len() >= 2 || control => pr
                .add_block(Key::Point(PointId::from(k)), Value::point(&x))
                .map_err(built)?,
            _ => single_ray.push((
                id.to_string(),
                p.images[p.measurements[ks[0]].image].id.clone(),
            )),
        }
    }
    for (c, cd) in p.cameras.iter().enumerate() {
        if !cd.calibrate.is_empty() {
            let v = ImagePoint::interior_start(&cd.camera, &cd.calibrate);
            pr.add_block(Key::Camera(CameraId::from(c)), Value::Vector(v))
                .map_err(built)?;
        }
    }
    let index: BTreeMap<&str, PointId> = point_names
        .iter()
        .enumerate()
        .map(|(k, n)| (n.as_str(), PointId::from(k)))
        .collect();
    image_factors(p, &mut pr, &index, loss).map_err(built)?;
    control_factors(p, frame, &mut pr, &index, loss).map_err(built)?;
    let drifts = match p.file.gnss.as_ref() {
        Some(_) => gnss_factors(p, frame, &mut pr, antenna_of, loss)?,
        None => Vec::new(),
    };
    Ok((pr, point_names, single_ray, drifts))
}

/// One factor per image measurement of an adjusted point.
fn image_factors(
    p: &Project,
    pr: &mut Problem,
    index: &BTreeMap<&str, PointId>,
    loss: Loss,
) -> Result<(), photo::lsq::BuildError> {
    for m in &p.measurements {
        let Some(&pt) = index.get(m.point.as_str()) else {
            continue;
        };
        if !pr.contains(Key::Point(pt)) {
            continue;
        }
        let c = p.images[m.image].camera;
        let cd = &p.cameras[c];
        let f = ImagePoint::self_calibrating(
            cd.camera,
            ImageId::from(m.image),
            pt,
            CameraId::from(c),
            cd.calibrate.clone(),
            m.xy,
        )
        .with_source(m.source.clone());
        pr.add_factor(f, Noise::isotropic(2, m.sigma), loss, GROUP_IMAGE)?;
    }
    Ok(())
}

/// One prior per control point (σ per axis).
fn control_factors(
    p: &Project,
    frame: &LocalFrame,
    pr: &mut Problem,
    index: &BTreeMap<&str, PointId>,
    loss: Loss,
) -> Result<(), photo::lsq::BuildError> {
    for g in p.ground.iter().filter(|g| g.kind == PointKind::Control) {
        let Some(&pt) = index.get(g.id.as_str()) else {
            continue;
        };
        if !pr.contains(Key::Point(pt)) {
            continue;
        }
        let f = Prior::point(pt, frame.to_local(&g.pos)).with_source(g.source.clone());
        pr.add_factor(f, Noise::sigmas(&g.sigma), loss, GROUP_CONTROL)?;
    }
    Ok(())
}

/// Lever arms (with their priors), drift groups and one GNSS factor per image with an antenna.
fn gnss_factors(
    p: &Project,
    frame: &LocalFrame,
    pr: &mut Problem,
    antenna_of: &[Option<usize>],
    loss: Loss,
) -> Result<Vec<DriftBlock>, AdjustError> {
    let Some(gs) = p.file.gnss.as_ref() else {
        return Ok(Vec::new());
    };
    let built = |e: photo::lsq::BuildError| err(e.to_string());
    for (c, _) in p.cameras.iter().enumerate() {
        if !p
            .images
            .iter()
            .enumerate()
            .any(|(i, im)| im.camera == c && antenna_of[i].is_some())
        {
            continue;
        }
        let key = Key::LeverArm(CameraId::from(c));
        pr.add_block(
            key,
            Value::Vector(DVector::from_column_slice(&gs.lever_arm)),
        )
        .map_err(built)?;
        pr.set_fixed(key, !gs.estimate_lever_arm).map_err(built)?;
        if let (Some(s), true) = (gs.lever_arm_sigma, gs.estimate_lever_arm) {
            let sig: Vec<f64> = s.iter().map(|x| x.max(1e-6)).collect();
            let f = Prior::new(key, DVector::from_column_slice(&gs.lever_arm));
            pr.add_factor(f, Noise::sigmas(&sig), loss, GROUP_PRIOR)
                .map_err(built)?;
        }
    }
    // Drift groups.
    let key = |i: usize, k: usize| -> Option<String> {
        match gs.drift {
            DriftGroup::None => None,
            DriftGroup::Block => Some("block".into()),
            DriftGroup::Strip => Some(format!("strip {}", p.images[i].strip)),
            DriftGroup::Segment => Some(format!("segment {}", p.antennas[k].segment)),
        }
    };
    let mut groups: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    for (i, a) in antenna_of.iter().enumerate() {
        if let Some(k) = a {
            if let Some(name) = key(i, *k) {
                groups
                    .entry(name)
                    .or_default()
                    .push(p.antennas[*k].time.to_gpst_seconds());
            }
        }
    }
    let mut drifts: Vec<DriftBlock> = Vec::new();
    for (name, times) in &groups {
        let t0 = match gs.drift_model {
            DriftModel::Rate => times.iter().cloned().fold(f64::INFINITY, f64::min),
            _ => times.iter().sum::<f64>() / times.len() as f64,
        };
        let v = Value::Vector(DVector::zeros(gs.drift_model.dim()));
        pr.add_block(Key::Drift(DriftId::from(drifts.len())), v)
            .map_err(built)?;
        drifts.push(DriftBlock {
            name: name.clone(),
            model: gs.drift_model,
            t0,
        });
    }
    for (i, a) in antenna_of.iter().enumerate() {
        let Some(k) = *a else { continue };
        let ant = &p.antennas[k];
        let cam = CameraId::from(p.images[i].camera);
        if !pr.contains(Key::LeverArm(cam)) {
            continue;
        }
        let drift = key(i, k)
            .and_then(|n| drifts.iter().position(|d| d.name == n))
            .map(|d| {
                let dt = ant.time.to_gpst_seconds() - drifts[d].t0;
                (DriftId::from(d), drifts[d].model, dt)
            });
        let m = frame.from_enu_at(&ant.pos);
        let cov = m * ant.cov_enu * m.transpose();
        let noise = Noise::covariance(&DMatrix::from_column_slice(3, 3, cov.as_slice()))
            .ok_or_else(|| {
                err(format!(
                    "antenna of image {}: the covariance is not positive definite",
                    ant.image
                ))
            })?;
        let f = GnssCentre::new(ImageId::from(i), cam, drift, frame.to_local(&ant.pos), k);
        pr.add_factor(f, noise, loss, GROUP_GNSS).map_err(built)?;
    }
    Ok(drifts)
}
