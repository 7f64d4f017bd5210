//! Start values of the orientations, in order of preference: the attitude of the antenna
//! table; compass angles (refined by a three-angle resection on the control seen, close
//! range); nadir along the strip direction of the neighbouring antennas; a resection on ≥ 4
//! control points (RANSAC over their triples, so a wrong point does not spoil it), or on 3 (aerial: of the exact solutions, the camera above the points
//! looking down); the same on tie points intersected from the images that have a start,
//! growing the block until no image gains one; and when no image starts from its own data,
//! a relative orientation from the tie points seeds the block (`start_relative`).
//! What enters: the project, the frame, the measurements by point and the antenna of each
//! image. What leaves: a pose per image that can have one and the images left without
//! (named, with the reason); an error only when no image has a start.

use super::error::{problem_err as err, AdjustError};
use super::frame::LocalFrame;
use super::input::ControlAxes;
use super::project::{Mode, PointKind, Project};
use super::rays::{intersect_point, Rays};
use nalgebra::{Matrix3, Vector2, Vector3};
use photo::camera::Pose;
use photo::lever::LeverArm;
use photo::resection::{resect, resect_angles, resect_robust, resect_three, Control};
use std::collections::BTreeMap;

/// Something left out of the adjustment (e.g. `image 17`) and why.
pub(super) type LeftOut = (String, String);

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

/// What the start values look up per image, indexed once (looked up by scanning, they made
/// the start quadratic in the block size: 10,000 images took 20 s).
struct Index<'a> {
    /// Measurement indices per image, in the project's order.
    by_image: Vec<Vec<usize>>,
    /// Image indices per strip, in the project's order.
    by_strip: BTreeMap<&'a str, Vec<usize>>,
    /// Control points with all three coordinates, by id (the first of an id).
    control: BTreeMap<&'a str, &'a super::input::GroundPoint>,
}

impl<'a> Index<'a> {
    fn new(p: &'a Project) -> Self {
        let mut by_image = vec![Vec::new(); p.images.len()];
        for (k, m) in p.measurements.iter().enumerate() {
            if let Some(v) = by_image.get_mut(m.image) {
                v.push(k);
            }
        }
        let mut by_strip: BTreeMap<&str, Vec<usize>> = BTreeMap::new();
        for (i, im) in p.images.iter().enumerate() {
            by_strip.entry(im.strip.as_str()).or_default().push(i);
        }
        let mut control = BTreeMap::new();
        for g in &p.ground {
            if g.kind == PointKind::Control && g.axes == ControlAxes::All {
                control.entry(g.id.as_str()).or_insert(g);
            }
        }
        Index {
            by_image,
            by_strip,
            control,
        }
    }
}

/// The measurements of image `i` whose points have object coordinates (`object_of`), for a
/// resection.
fn controls_in(
    p: &Project,
    ix: &Index,
    i: usize,
    object_of: impl Fn(&str) -> Option<Vector3<f64>>,
) -> Vec<Control> {
    ix.by_image[i]
        .iter()
        .map(|&k| &p.measurements[k])
        .filter_map(|m| {
            object_of(&m.point).map(|object| Control {
                object,
                image: m.xy,
                sigma: m.sigma,
            })
        })
        .collect()
}

/// The start orientation of every image that can have one (`skip[i]`: image i is already
/// left out), the images left without one (id, reason), and how the block was started when
/// from its tie points alone; refused only when no image has a start.
#[allow(clippy::type_complexity)]
pub(super) fn orientations(
    p: &Project,
    frame: &LocalFrame,
    rays: &Rays,
    antenna_of: &[Option<usize>],
    skip: &[bool],
) -> Result<(Vec<Option<Pose>>, Vec<LeftOut>, Option<String>), AdjustError> {
    let lever0 = p
        .file
        .gnss
        .as_ref()
        .map(|g| g.lever_arm())
        .unwrap_or_default();
    let ix = Index::new(p);
    let mut start: Vec<Option<Pose>> = (0..p.images.len())
        .map(|i| {
            if skip[i] {
                None
            } else {
                super::start_file::given_start(&p.starts, frame, i)
                    .or_else(|| start_pose(p, &ix, frame, antenna_of, &lever0, i))
            }
        })
        .collect();
    if start.iter().zip(skip).any(|(s, &k)| s.is_none() && !k) {
        grow(p, &ix, rays, &mut start, skip, false);
    }
    let mut note = None;
    if start.iter().all(Option::is_none) {
        // Nothing starts from its own data: a relative orientation seeds the block from the
        // tie points, which then grows and is placed on what control or GNSS it has.
        if let Some((seed, agree)) = super::start_relative::seed_pair(p, rays, skip) {
            for (i, pose) in &seed {
                start[*i] = Some(*pose);
            }
            grow(p, &ix, rays, &mut start, skip, true);
            super::start_relative::local_bundle(p, rays, &mut start);
            let placed = super::start_relative::placement(p, frame, rays, &start, antenna_of);
            let on = match placed {
                Some((sim, what)) => {
                    super::start_relative::place(&mut start, sim);
                    format!("placed on {what} by a similarity")
                }
                None => "left in the pair's arbitrary frame".to_string(),
            };
            note = Some(format!(
                "start orientations from the tie points alone: the relative orientation of images {} and {} ({agree} points agree), grown to {} images by resection with local bundle adjustments, {on}",
                p.images[seed[0].0].id,
                p.images[seed[1].0].id,
                start.iter().flatten().count()
            ));
        }
    }
    let lost: Vec<LeftOut> = (0..p.images.len())
        .filter(|&i| start[i].is_none() && !skip[i])
        .map(|i| {
            let n = ix.by_image[i]
                .iter()
                .filter(|&&k| ix.control.contains_key(p.measurements[k].point.as_str()))
                .count();
            let why = if n >= 3 {
                format!("no start orientation: the resection on its {n} control points failed (points nearly in a line, or on a circle through the image's nadir: the critical configuration); measure a point elsewhere in the image")
            } else {
                "no start orientation: no GNSS antenna position with attitude or strip, no compass angles, and fewer than 3 control or tie points seen by other images".to_string()
            };
            (p.images[i].id.clone(), why)
        })
        .collect();
    if start.iter().all(Option::is_none) {
        return Err(err(format!(
            "no image has a start orientation (first: {}): give GNSS antenna positions (with attitude or within strips), compass angles, or at least 4 control points in some images",
            lost.first().map_or("none", |l| l.0.as_str())
        )));
    }
    Ok((start, lost, note))
}

/// The camera rotation of image `i` from the antenna table's attitude, compass angles, or the
/// strip direction (nadir, x at `[images] kappa_deg` from the strip) of the neighbouring
/// antennas.
fn start_rotation(
    p: &Project,
    ix: &Index,
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
    if let Some([omega, phi, kappa]) = im.opk {
        return Some(photo::rotation::Angles::OmegaPhiKappa { omega, phi, kappa }.matrix());
    }
    let a = antenna?;
    let here = frame.to_local(&a.pos);
    let mut dir = Vector2::zeros();
    for &j in ix.by_strip.get(im.strip.as_str()).into_iter().flatten() {
        if j != i {
            if let Some(b) = antenna_of[j].map(|k| &p.antennas[k]) {
                let d = frame.to_local(&b.pos) - here;
                let dt = (b.time - a.time).to_seconds();
                if dt != 0.0 && dt.abs() < 120.0 {
                    dir += Vector2::new(d.x, d.y) / dt;
                }
            }
        }
    }
    let mounting = p.file.images.kappa_deg.to_radians();
    (dir.norm() > 0.0).then(|| photo::rotation::rot_z(dir.y.atan2(dir.x) + mounting))
}

/// The start pose of image `i` from its antenna and rotation, or a resection on the control
/// it sees.
fn start_pose(
    p: &Project,
    ix: &Index,
    frame: &LocalFrame,
    antenna_of: &[Option<usize>],
    lever0: &LeverArm,
    i: usize,
) -> Option<Pose> {
    let cam = &p.cameras[p.images[i].camera].camera;
    let antenna = antenna_of[i].map(|k| &p.antennas[k]);
    let controls = controls_in(p, ix, i, |id| {
        ix.control.get(id).map(|g| frame.to_local(&g.pos))
    });
    match (antenna, start_rotation(p, ix, frame, antenna_of, i)) {
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
        _ if controls.len() >= 4 => robust_start(cam, &controls),
        _ if controls.len() == 3 && p.file.mode != Mode::CloseRange => {
            resect_three(cam, &controls, looking_down(&controls))
                .ok()
                .map(|x| x.pose)
        }
        _ => None,
    }
}

/// A resection on ≥ 4 points that a wrong one cannot spoil: RANSAC over the triples with a
/// 20-pixel tolerance, then the plain best fit when too few agree.
fn robust_start(cam: &photo::camera::Camera, pts: &[Control]) -> Option<Pose> {
    resect_robust(cam, pts, 20.0 * cam.pixel)
        .map(|(r, _)| r.pose)
        .or_else(|_| resect(cam, pts).map(|r| r.pose))
        .ok()
}

/// The aerial preference among the exact three-point solutions: the centre above the points,
/// the camera looking down (its z axis, opposite the viewing direction, up).
fn looking_down(pts: &[Control]) -> impl Fn(&Pose) -> f64 {
    let mean_z = pts.iter().map(|c| c.object.z).sum::<f64>() / pts.len().max(1) as f64;
    move |pose: &Pose| (pose.centre.z - mean_z).signum() + pose.r[(2, 2)]
}

/// Fewest intersected tie points an image of a block grown from its ties is resected on.
const GROWN_FEWEST: usize = 6;

/// Whether the points a resection was made on lie in front of the camera (all but a tenth:
/// a mirror solution, or one from wrongly intersected points, puts many behind it).
fn in_front(pose: &Pose, pts: &[Control]) -> bool {
    let behind = pts
        .iter()
        .filter(|c| (pose.r.transpose() * (c.object - pose.centre)).z >= 0.0)
        .count();
    10 * behind <= pts.len()
}

/// Images still without a start (no GNSS, no control): resect them on tie points intersected
/// from the images that have one, growing the block until no image gains a start; with
/// `bundle` (a block seeded from its ties, in its own frame), a local bundle adjustment each
/// time the block has grown by a fifth.
fn grow(
    p: &Project,
    ix: &Index,
    rays: &Rays,
    start: &mut [Option<Pose>],
    skip: &[bool],
    bundle: bool,
) {
    let mut adjusted_at = start.iter().flatten().count();
    loop {
        if bundle {
            let n = start.iter().flatten().count();
            if n as f64 >= super::start_relative::BA_GROWTH * adjusted_at as f64 {
                super::start_relative::local_bundle(p, rays, start);
                adjusted_at = n;
            }
        }
        let known: BTreeMap<&str, Vector3<f64>> = rays
            .iter()
            .filter_map(|(id, ks)| intersect_point(p, ks, |i| start[i].as_ref()).map(|x| (*id, x)))
            .collect();
        let candidates: Vec<(usize, Vec<Control>)> = (0..start.len())
            .filter(|&i| start[i].is_none() && !skip[i])
            .map(|i| (i, controls_in(p, ix, i, |id| known.get(id).copied())))
            .collect();
        // Grown from its own ties, a block is only as good as its worst resection: an image
        // waits until it sees enough points and at least half as many as the best-seen one
        // of this round (the best placed first, as incremental reconstruction does).
        let best = candidates.iter().map(|(_, c)| c.len()).max().unwrap_or(0);
        let fewest = if bundle {
            GROWN_FEWEST.max(best.div_ceil(2))
        } else {
            3
        };
        let mut gained = false;
        for (i, pts) in candidates {
            if pts.len() < fewest {
                continue;
            }
            let cam = &p.cameras[p.images[i].camera].camera;
            let pose = if pts.len() >= 4 {
                robust_start(cam, &pts)
            } else if pts.len() == 3 && p.file.mode != Mode::CloseRange {
                resect_three(cam, &pts, looking_down(&pts))
                    .ok()
                    .map(|x| x.pose)
            } else {
                None
            };
            start[i] = pose.filter(|pose| in_front(pose, &pts));
            gained |= start[i].is_some();
        }
        if !gained {
            return;
        }
    }
}
