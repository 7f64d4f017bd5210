//! The blocks and factors of the adjustment: a pose per image, a point per measured point
//! with two rays or more (or control), interior blocks for self-calibration, lever arms and
//! drift groups; one factor per image measurement, control point, lever-arm prior and GNSS
//! antenna position, each with its noise model, the project's loss and its group.

use super::error::{problem_err as err, AdjustError};
use super::factors::{DriftModel, GnssCentre};
use super::frame::LocalFrame;
use super::groups::{GROUP_CONTROL, GROUP_DISTANCE, GROUP_GNSS, GROUP_IMAGE, GROUP_PRIOR};
use super::latency::{self, Latencies};
use super::project::{DriftGroup, PointKind, Project};
use super::rays::{intersect_point, Rays};
use nalgebra::{DMatrix, DVector, Vector3};
use photo::camera::Pose;
use photo::factors::{Distance, ImagePoint, Prior};
use photo::lsq::{CameraId, DriftId, ImageId, Key, Loss, Noise, Options, PointId, Problem, Value};
use std::collections::BTreeMap;

/// A drift group (key `Drift(DriftId(index))`): its name, model and reference time.
#[derive(Clone, Debug)]
pub struct DriftBlock {
    /// The group's name ("block", "strip 2", "segment 5").
    pub name: String,
    /// Which drift terms it has.
    pub model: DriftModel,
    /// Reference time t0, GPST seconds.
    pub t0: f64,
    /// σ per axis of the prior holding it at zero (auto drifts); None: free.
    pub prior_sigma: Option<[f64; 3]>,
}

/// Blocks and factors; returns the problem, the point names by `PointId`, the points left
/// out for having a single ray (id, image) and the drift groups.
#[allow(clippy::type_complexity)]
pub(super) fn problem(
    p: &Project,
    frame: &LocalFrame,
    rays: &Rays,
    start: &[Option<Pose>],
    antenna_of: &[Option<usize>],
    lat: &Latencies,
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
    // Images left out (no points, no start) have no block; their measurements no factor.
    for (i, s) in start.iter().enumerate() {
        if let Some(s) = s {
            pr.add_block(Key::Pose(ImageId::from(i)), Value::Pose(*s))
                .map_err(built)?;
        }
    }
    let point_names: Vec<String> = rays.keys().map(|s| s.to_string()).collect();
    let mut single_ray = Vec::new();
    // Ground points by id (the first of an id), looked up once per point, not scanned.
    let mut ground_of = std::collections::BTreeMap::new();
    for g in &p.ground {
        ground_of.entry(g.id.as_str()).or_insert(g);
    }
    for (k, (id, ks)) in rays.iter().enumerate() {
        let ground = ground_of.get(*id).copied();
        if ground.is_some_and(|g| g.kind == PointKind::Check) {
            // Check points stay independent: intersected after the adjustment.
            continue;
        }
        let control = ground.is_some_and(|g| g.kind == PointKind::Control);
        let images: std::collections::BTreeSet<usize> = ks
            .iter()
            .map(|k| p.measurements[*k].image)
            .filter(|&i| start[i].is_some())
            .collect();
        let x = match ground {
            Some(g) if control => Some(frame.to_local(&g.pos)),
            _ if images.len() >= 2 => intersect_point(p, ks, |i| start[i].as_ref()),
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
    distance_factors(p, &mut pr, &index, loss).map_err(built)?;
    let drifts = match p.file.gnss.as_ref() {
        Some(_) => gnss_factors(p, frame, &mut pr, (antenna_of, lat), loss)?,
        None => Vec::new(),
    };
    super::attitude::factors(p, frame, &mut pr, antenna_of, loss)?;
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
        if !pr.contains(Key::Point(pt)) || !pr.contains(Key::Pose(ImageId::from(m.image))) {
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
        let axes = g.axes.indices();
        let f = Prior::point(pt, frame.to_local(&g.pos))
            .on_axes(axes)
            .with_source(g.source.clone());
        let sigma: Vec<f64> = axes.iter().map(|&a| g.sigma[a]).collect();
        pr.add_factor(f, Noise::sigmas(&sigma), loss, GROUP_CONTROL)?;
    }
    Ok(())
}

/// One factor per measured distance between two adjusted points.
fn distance_factors(
    p: &Project,
    pr: &mut Problem,
    index: &BTreeMap<&str, PointId>,
    loss: Loss,
) -> Result<(), photo::lsq::BuildError> {
    for d in &p.distances {
        let ids = d
            .points
            .each_ref()
            .map(|id| index.get(id.as_str()).copied());
        let [Some(a), Some(b)] = ids else { continue };
        if !(pr.contains(Key::Point(a)) && pr.contains(Key::Point(b))) {
            continue;
        }
        let f = Distance::new(a, b, d.distance).with_source(d.source.clone());
        pr.add_factor(f, Noise::sigmas(&[d.sigma]), loss, GROUP_DISTANCE)?;
    }
    Ok(())
}

/// Lever arms (with their priors), drift groups, latency groups and one GNSS factor per image
/// with an antenna.
fn gnss_factors(
    p: &Project,
    frame: &LocalFrame,
    pr: &mut Problem,
    (antenna_of, lat): (&[Option<usize>], &Latencies),
    loss: Loss,
) -> Result<Vec<DriftBlock>, AdjustError> {
    let Some(gs) = p.file.gnss.as_ref() else {
        return Ok(Vec::new());
    };
    let built = |e: photo::lsq::BuildError| err(e.to_string());
    latency::add_blocks(gs, pr, lat, loss).map_err(built)?;
    for (c, _) in p.cameras.iter().enumerate() {
        if !p.images.iter().enumerate().any(|(i, im)| {
            im.camera == c && antenna_of[i].is_some() && pr.contains(Key::Pose(ImageId::from(i)))
        }) {
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
        let a = &p.antennas[k];
        match gs.drift {
            DriftGroup::None => None,
            DriftGroup::Auto if a.quality == 1 => None,
            DriftGroup::Auto => Some(format!("float segment {}", a.segment)),
            DriftGroup::Block => Some("block".into()),
            DriftGroup::Strip => Some(format!("strip {}", p.images[i].strip)),
            DriftGroup::Segment => Some(format!("segment {}", a.segment)),
        }
    };
    // Per group: times and the sum of the antennas' ENU variances.
    let mut groups: BTreeMap<String, (Vec<f64>, Vector3<f64>)> = BTreeMap::new();
    let posed = |i: usize| pr.contains(Key::Pose(ImageId::from(i)));
    for (i, a) in antenna_of.iter().enumerate() {
        if let (Some(k), true) = (a, posed(i)) {
            if let Some(name) = key(i, *k) {
                let g = groups.entry(name).or_default();
                g.0.push(p.antennas[*k].time.to_gpst_seconds());
                g.1 += p.antennas[*k].cov_enu.diagonal();
            }
        }
    }
    let model = match gs.drift {
        DriftGroup::Auto => DriftModel::Offset,
        _ => gs.drift_model,
    };
    let mut drifts: Vec<DriftBlock> = Vec::new();
    for (name, (times, var_sum)) in &groups {
        let t0 = match model {
            DriftModel::Rate => times.iter().cloned().fold(f64::INFINITY, f64::min),
            _ => times.iter().sum::<f64>() / times.len() as f64,
        };
        let id = Key::Drift(DriftId::from(drifts.len()));
        pr.add_block(id, Value::Vector(DVector::zeros(model.dim())))
            .map_err(built)?;
        let prior_sigma = (gs.drift == DriftGroup::Auto).then(|| {
            let rms = var_sum.map(|v| (v / times.len() as f64).max(1e-12).sqrt());
            [rms.x, rms.y, rms.z]
        });
        if let Some(sig) = prior_sigma {
            let f = Prior::new(id, DVector::zeros(3));
            pr.add_factor(f, Noise::sigmas(&sig), loss, GROUP_PRIOR)
                .map_err(built)?;
        }
        drifts.push(DriftBlock {
            name: name.clone(),
            model,
            t0,
            prior_sigma,
        });
    }
    for (i, a) in antenna_of.iter().enumerate() {
        let Some(k) = *a else { continue };
        let ant = &p.antennas[k];
        let cam = CameraId::from(p.images[i].camera);
        if !pr.contains(Key::LeverArm(cam)) || !pr.contains(Key::Pose(ImageId::from(i))) {
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
        let f = match latency::of(p, frame, lat, i, k) {
            Some((l, v)) => f.with_latency(l, v),
            None => f,
        };
        pr.add_factor(f, noise, loss, GROUP_GNSS).map_err(built)?;
    }
    Ok(drifts)
}
