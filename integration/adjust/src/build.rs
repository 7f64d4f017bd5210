//! From a loaded project to a `photo::lsq::Problem`: the inputs checked (every image measured,
//! every ground point measured, GNSS in every strip, a datum), the local frame (ENU tangent
//! plane at the block centre), start values (`start`) and the blocks and factors
//! (`assemble`). Input problems are refused here with the ids that cause them.
//!
//! Keys: `Pose(ImageId(i))` for the i-th image of the list, `Point(PointId(k))` for the k-th
//! measured point id in sorted order (`Built::point_names`), `LeverArm(CameraId(c))` and
//! `Camera(CameraId(c))` for camera c, `Drift(DriftId(d))` for `Built::drifts[d]`,
//! `Latency(LatencyId(g))` for `Built::latencies[g]`.

use super::assemble::problem;
pub use super::assemble::DriftBlock;
use super::error::{problem_err as err, AdjustError};
pub use super::frame::LocalFrame;
pub use super::groups::{
    GROUP_ATTITUDE, GROUP_CONTROL, GROUP_DISTANCE, GROUP_GNSS, GROUP_IMAGE, GROUP_NAMES,
    GROUP_PRIOR,
};
use super::project::{PointKind, Project};
use super::rays::Rays;
pub use super::start::compass_rotation;
use super::start::orientations;
use gnss::frame::Ecef;
use nalgebra::{Matrix3, Vector3};
use photo::lsq::Problem;
use std::collections::BTreeMap;

/// The assembled problem and how to read it back.
pub struct Built {
    /// The local frame the block is adjusted in.
    pub frame: LocalFrame,
    /// The problem: blocks and factors.
    pub problem: Problem,
    /// Measured point ids by `PointId` (sorted); those with a block are adjusted.
    pub point_names: Vec<String>,
    /// The drift groups, by `DriftId`.
    pub drifts: Vec<DriftBlock>,
    /// The GNSS latency groups, by `LatencyId`.
    pub latencies: Vec<super::latency::LatencyBlock>,
    /// Points measured in a single image (not determinable): id and its image.
    pub single_ray: Vec<(String, String)>,
    /// Images and points left out of the adjustment: what ("image X", "point Y") and why.
    pub left_out: Vec<(String, String)>,
    /// Antenna records whose image is not in the list.
    pub unused_antennas: Vec<String>,
    /// Images without an antenna record in a project with GNSS (adjusted from their points).
    pub without_antenna: Vec<String>,
    /// Tight coupling: the double differences and ambiguities (None: loose).
    pub tight: Option<super::tight::Tight>,
    /// A free network: the datum is the inner constraints over the image centres.
    pub free_network: bool,
    /// How the block was started when from its tie points alone.
    pub start_note: Option<String>,
}

/// Check the inputs, choose the frame and the start values, assemble the problem.
pub fn build(p: &Project) -> Result<Built, AdjustError> {
    let (rays, empty) = measured(p)?;
    let (antenna_of, unused_antennas) = antennas_by_image(p)?;
    let without_antenna: Vec<String> = match p.file.gnss {
        Some(_) => (0..p.images.len())
            .filter(|&i| antenna_of[i].is_none())
            .map(|i| p.images[i].id.clone())
            .collect(),
        None => Vec::new(),
    };
    check_datum(p, &antenna_of)?;
    let frame = frame_of(p, antenna_of.iter().any(Option::is_some));
    let skip: Vec<bool> = (0..p.images.len()).map(|i| empty.contains(&i)).collect();
    let mut left_out: Vec<(String, String)> = empty
        .iter()
        .map(|&i| {
            (
                format!("image {}", p.images[i].id),
                "no measured points".to_string(),
            )
        })
        .collect();
    let (start, lost, start_note) = orientations(p, &frame, &rays, &antenna_of, &skip)?;
    left_out.extend(
        lost.into_iter()
            .map(|(id, why)| (format!("image {id}"), why)),
    );
    let lat = super::latency::groups(p, &antenna_of)?;
    // Tight coupling: the images carried by double differences get no loose GNSS factor.
    let dd = super::tight::load(p, &antenna_of)?;
    let loose_of: Vec<Option<usize>> = match &dd {
        Some(d) => {
            let tight = d.images();
            (antenna_of.iter().enumerate())
                .map(|(i, a)| a.filter(|_| !tight.contains(&i)))
                .collect()
        }
        None => antenna_of.clone(),
    };
    let (mut pr, point_names, single_ray, drifts) =
        problem(p, &frame, &rays, &start, &loose_of, &lat)?;
    let tight = match dd {
        Some(d) => Some(super::tight::add(p, &frame, &mut pr, d, &antenna_of)?),
        None => None,
    };
    let names = super::leave_out::Names {
        project: p,
        points: &point_names,
        drifts: &drifts,
    };
    super::leave_out::undetermined(&names, &mut pr, &mut left_out)?;
    let free = free_network(p, &antenna_of);
    if free {
        inner_constraints(&mut pr, !p.distances.is_empty())?;
    }
    Ok(Built {
        frame,
        problem: pr,
        point_names,
        drifts,
        latencies: lat.blocks,
        single_ray,
        left_out,
        unused_antennas,
        without_antenna,
        tight,
        free_network: free,
        start_note,
    })
}

/// The measurements of each point, and the images without any (to be left out); refused
/// when a ground point has none.
fn measured(p: &Project) -> Result<(Rays<'_>, Vec<usize>), AdjustError> {
    let mut rays: Rays = BTreeMap::new();
    let mut per_image = vec![0usize; p.images.len()];
    for (k, m) in p.measurements.iter().enumerate() {
        rays.entry(m.point.as_str()).or_default().push(k);
        per_image[m.image] += 1;
    }
    let empty: Vec<usize> = (0..p.images.len()).filter(|&i| per_image[i] == 0).collect();
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
    for d in &p.distances {
        let check = |id: &String| {
            p.ground
                .iter()
                .any(|g| g.id == *id && g.kind == PointKind::Check)
        };
        if let Some(id) = d.points.iter().find(|id| check(id)) {
            return Err(err(format!(
                "{}: the distance names check point {id}, and check points stay out of the adjustment: list it as a tie point, or drop the distance",
                d.source
            )));
        }
        if let Some(id) = d.points.iter().find(|id| !rays.contains_key(id.as_str())) {
            return Err(err(format!(
                "{}: the distance names point {id}, which no image measures: check the id",
                d.source
            )));
        }
    }
    Ok((rays, empty))
}

/// The antenna record of each image (with GNSS), and the antenna records naming no image;
/// refused when a strip has no antenna at all.
fn antennas_by_image(p: &Project) -> Result<(Vec<Option<usize>>, Vec<String>), AdjustError> {
    let mut antenna_of: Vec<Option<usize>> = vec![None; p.images.len()];
    let mut unused = Vec::new();
    if p.file.gnss.is_none() {
        return Ok((antenna_of, unused));
    }
    let image_index: BTreeMap<&str, usize> = p
        .images
        .iter()
        .enumerate()
        .map(|(i, im)| (im.id.as_str(), i))
        .collect();
    for (k, a) in p.antennas.iter().enumerate() {
        match image_index.get(a.image.as_str()) {
            Some(&i) => antenna_of[i] = Some(k),
            None => unused.push(a.image.clone()),
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
    Ok((antenna_of, unused))
}

/// Whether the block is a free network: `[datum] free = true` and no control point and no
/// GNSS centre to give it a datum.
pub(super) fn free_network(p: &Project, antenna_of: &[Option<usize>]) -> bool {
    p.file.datum.free
        && antenna_of.iter().all(Option::is_none)
        && !p.ground.iter().any(|g| g.kind == PointKind::Control)
}

/// The datum of a free network: inner constraints over the centres of the images adjusted
/// (without the scale row when distances give the scale).
fn inner_constraints(pr: &mut photo::lsq::Problem, scaled: bool) -> Result<(), AdjustError> {
    use photo::lsq::{ImageId, Key, Loss};
    let (ids, centres): (Vec<ImageId>, Vec<Vector3<f64>>) = pr
        .keys()
        .iter()
        .filter(|k| !pr.is_fixed(**k))
        .filter_map(|k| match (k, pr.value(*k).and_then(|v| v.pose())) {
            (Key::Pose(i), Some(pose)) => Some((*i, pose.centre)),
            _ => None,
        })
        .unzip();
    let f = photo::datum::InnerConstraints::new(&ids, &centres, !scaled).ok_or_else(|| {
        err("a free network needs at least two images at different places".into())
    })?;
    let noise = f.noise();
    pr.add_factor(f, noise, Loss::Trivial, super::groups::GROUP_DATUM)
        .map_err(|e| err(e.to_string()))?;
    Ok(())
}

/// Refused without GNSS and with fewer than three control points, unless a free network.
fn check_datum(p: &Project, antenna_of: &[Option<usize>]) -> Result<(), AdjustError> {
    let n_control = p
        .ground
        .iter()
        .filter(|g| g.kind == PointKind::Control)
        .count();
    if free_network(p, antenna_of) {
        return Ok(());
    }
    if antenna_of.iter().all(Option::is_none) && n_control < 3 {
        return Err(err(format!(
            "datum defect: {n_control} control point(s) and no GNSS centres — the block's position, orientation and scale are not determined; give at least 3 control points or GNSS antenna positions, or adjust a free network ([datum] free = true: coordinates arbitrary)"
        )));
    }
    Ok(())
}

/// The tangent plane at the centre of the GNSS antennas (or of the ground points), at the
/// mean height of the ground points.
fn frame_of(p: &Project, gnss: bool) -> LocalFrame {
    let centre_pts: Vec<Ecef> = if gnss {
        p.antennas.iter().map(|a| a.pos).collect()
    } else {
        p.ground.iter().map(|g| g.pos).collect()
    };
    if centre_pts.is_empty() {
        // A free network: the frame of the start values, placed at 0°, 0°.
        return LocalFrame::new(gnss::frame::Geodetic::from_degrees(0.0, 0.0, 0.0));
    }
    let mean = centre_pts.iter().fold(Vector3::zeros(), |a, x| a + x.0) / centre_pts.len() as f64;
    let mut g0 = Ecef(mean).to_geodetic();
    g0.h = if p.ground.is_empty() {
        0.0
    } else {
        p.ground.iter().map(|g| g.pos.to_geodetic().h).sum::<f64>() / p.ground.len() as f64
    };
    LocalFrame::new(g0)
}

/// A start orientation for a start table: the projection centre and the rotation camera →
/// ENU at the centre.
pub type StartPose = (Ecef, Matrix3<f64>);

/// The start orientation of every image of a loaded project as the adjustment begins from
/// it (for `match` to write them): the projection centre and the rotation camera → ENU at
/// the centre; `None` for an image without one.
pub fn start_poses(p: &Project) -> Result<Vec<Option<StartPose>>, AdjustError> {
    let (rays, empty) = measured(p)?;
    let (antenna_of, _) = antennas_by_image(p)?;
    let frame = frame_of(p, antenna_of.iter().any(Option::is_some));
    let skip: Vec<bool> = (0..p.images.len()).map(|i| empty.contains(&i)).collect();
    let (start, _, _) = orientations(p, &frame, &rays, &antenna_of, &skip)?;
    Ok(start
        .iter()
        .map(|s| {
            s.map(|pose| {
                let c = frame.to_ecef(&pose.centre);
                (c, frame.from_enu_at(&c).transpose() * pose.r)
            })
        })
        .collect())
}
