//! The project a match run writes: cameras (from `--camera` or the metadata, self-calibrated
//! when a camera has enough photos), the photos of the main block, one measurement per track
//! and photo, GNSS camera positions (an exposures table, else EXIF GPS, with their σ), and
//! start orientations from DJI gimbal angles where present.

use super::camera::from_meta;
use super::job::{Image, MatchError, MatchJob};
use super::matched::Matched;
use super::positions::Position;
use adjust::compass_rotation;
use common::frame::{enu_rotation, Geodetic};
use formats::import::{CameraOut, ProjectOut, StartOut};
use nalgebra::{Matrix3, Vector3};
use photo::camera::Pose;
use photo::intersection::{intersect, Ray};
use rayon::prelude::*;
use std::collections::BTreeMap;

/// Interior parameters estimated for a camera with at least [`CALIBRATE_FROM`] photos.
pub const SELF_CALIBRATE: [&str; 7] = ["f", "x0", "y0", "k1", "k2", "p1", "p2"];

/// Fewest photos of a camera for self-calibration.
pub const CALIBRATE_FROM: usize = 5;

/// Measurement σ in the pixels features were extracted from (times the reduction factor).
pub const SIGMA_FEATURE_PX: f64 = 0.5;

/// What was written, for the summary and the report.
#[derive(Clone, Debug, Default)]
pub struct Written {
    /// The project.
    pub project: ProjectOut,
    /// Images of other components than the block: names.
    pub not_connected: Vec<String>,
    /// Photos whose camera could not be found: (name, reason).
    pub no_camera: Vec<(String, String)>,
    /// Tracks written.
    pub tracks: usize,
    /// Tracks seen in three or more photos.
    pub tracks_3plus: usize,
    /// Measurements written.
    pub observations: usize,
    /// Tracks left out for an implausible depth (see [`DEPTH_FACTOR`]).
    pub implausible_depth: usize,
    /// Photos with a GNSS position / with a start attitude.
    pub with_position: usize,
    /// Photos with a start attitude from the gimbal angles.
    pub with_attitude: usize,
    /// Photos whose gimbal yaw differs from the heading their overlaps give by more than 30°:
    /// (name, degrees).
    pub heading_disagrees: Vec<(String, f64)>,
    /// Cameras: id, source of the focal length, photos.
    pub cameras: Vec<(String, String, usize)>,
}

/// The position of every image: from the exposures `table` when one was given, else EXIF GPS
/// (with the DJI RTK σ of fixed solutions).
pub fn image_positions(
    table: Option<&BTreeMap<String, Position>>,
    m: &[Image],
) -> Vec<Option<Position>> {
    m.iter()
        .map(|im| {
            if let Some(t) = table {
                let name = im
                    .meta
                    .path
                    .file_name()
                    .map(|s| s.to_string_lossy().into_owned());
                return t
                    .get(&im.meta.id)
                    .or_else(|| name.and_then(|n| t.get(&n)))
                    .copied();
            }
            im.meta.gps.map(|(lat, lon, h)| Position {
                lat,
                lon,
                h,
                sigma: im
                    .meta
                    .dji
                    .rtk_std
                    .filter(|_| im.meta.dji.rtk_flag == Some(50))
                    .map(|s| [s[0], s[1], s[2]]),
            })
        })
        .collect()
}

/// Local east/north/up positions at the first position.
pub fn local_enu(pos: &[Option<Position>]) -> Vec<Option<Vector3<f64>>> {
    let origin = pos
        .iter()
        .flatten()
        .next()
        .map(|p| Geodetic::from_degrees(p.lat, p.lon, p.h));
    pos.iter()
        .map(|p| {
            let (o, p) = (origin.as_ref()?, p.as_ref()?);
            let e = Geodetic::from_degrees(p.lat, p.lon, p.h).to_ecef().0 - o.to_ecef().0;
            Some(enu_rotation(o) * e)
        })
        .collect()
}

/// Footprint radius of each image (m) from its height above take-off and its field of view,
/// when the metadata give both.
pub fn footprint_radii(images: &[Image]) -> Vec<Option<f64>> {
    images
        .iter()
        .map(|im| {
            let agl = im.meta.dji.relative_altitude.filter(|h| *h > 1.0)?;
            let c = from_meta(&im.meta, im.size.0, im.size.1).ok()?;
            let half_diag = (im.size.0 as f64).hypot(im.size.1 as f64) / 2.0;
            Some(agl * half_diag / (c.camera.f / c.camera.pixel))
        })
        .collect()
}

/// Cameras of the block's images: (index of each image's camera or why none, the cameras).
#[allow(clippy::type_complexity)]
fn cameras(
    job: &MatchJob,
    m: &Matched,
    block: &[usize],
) -> Result<(Vec<Result<usize, String>>, Vec<(CameraOut, String)>), MatchError> {
    let mut cams: Vec<(CameraOut, String)> = Vec::new();
    if let Some(path) = &job.camera {
        let file = formats::import::patb::camera_file(path)
            .map_err(|e| MatchError::Input(e.to_string()))?;
        cams = file
            .into_iter()
            .map(|c| (c, "--camera".to_string()))
            .collect();
    }
    let given = !cams.is_empty();
    let mut of = Vec::new();
    for &i in block {
        let im = &m.images[i];
        let (w, h) = im.size;
        if given {
            of.push(
                cams.iter()
                    .position(|(c, _)| {
                        c.camera.width_px == w as usize && c.camera.height_px == h as usize
                    })
                    .ok_or_else(|| format!("no camera of --camera is {w} × {h} pixels")),
            );
            continue;
        }
        match from_meta(&im.meta, w, h) {
            Ok(f) => {
                let k = match cams.iter().position(|(c, _)| c.id == f.key) {
                    Some(k) => k,
                    None => {
                        cams.push((
                            CameraOut {
                                id: f.key.clone(),
                                camera: f.camera,
                                sigma_px: SIGMA_FEATURE_PX * im.scale,
                                self_calibrate: Vec::new(),
                            },
                            f.source.to_string(),
                        ));
                        cams.len() - 1
                    }
                };
                of.push(Ok(k));
            }
            Err(e) => of.push(Err(e)),
        }
    }
    if !given {
        for (k, (c, _)) in cams.iter_mut().enumerate() {
            let n = of.iter().filter(|x| **x == Ok(k)).count();
            if n >= CALIBRATE_FROM {
                c.self_calibrate = SELF_CALIBRATE.iter().map(|s| s.to_string()).collect();
            }
        }
    }
    Ok((of, cams))
}

/// Least-squares similarity q ≈ z·p + t between matched pixel positions (complex z, t).
fn similarity(p: &[(f64, f64)], q: &[(f64, f64)]) -> Option<((f64, f64), (f64, f64))> {
    let n = p.len() as f64;
    if p.len() < 3 {
        return None;
    }
    let mp = p
        .iter()
        .fold((0.0, 0.0), |s, a| (s.0 + a.0 / n, s.1 + a.1 / n));
    let mq = q
        .iter()
        .fold((0.0, 0.0), |s, a| (s.0 + a.0 / n, s.1 + a.1 / n));
    let (mut re, mut im, mut den) = (0.0, 0.0, 0.0);
    for (a, b) in p.iter().zip(q) {
        let (ax, ay, bx, by) = (a.0 - mp.0, a.1 - mp.1, b.0 - mq.0, b.1 - mq.1);
        // (b) · conj(a)
        re += bx * ax + by * ay;
        im += by * ax - bx * ay;
        den += ax * ax + ay * ay;
    }
    if den <= 0.0 {
        return None;
    }
    let z = (re / den, im / den);
    let t = (
        mq.0 - (z.0 * mp.0 - z.1 * mp.1),
        mq.1 - (z.0 * mp.1 + z.1 * mp.0),
    );
    Some((z, t))
}

/// The heading of each near-nadir photo (azimuth of its image's top, radians) from its
/// overlaps: for a verified pair the ground point at one photo's centre moves across the other
/// against the camera's motion, whose azimuth the positions give. The circular median over the
/// photo's pairs with baselines of at least `min_base` m. Metadata headings can be wrong (a
/// Phantom 3 writes a gimbal yaw turned by 180° on strips flown back, while its photos are
/// not): this is what the photos say.
pub fn headings_from_overlap(
    m: &Matched,
    enu: &[Option<Vector3<f64>>],
    min_base: f64,
) -> Vec<Option<f64>> {
    let mut votes: Vec<Vec<(f64, usize)>> = vec![Vec::new(); m.images.len()];
    for pr in m.pairs.iter().filter(|p| p.verified.len() >= 10) {
        let (Some(pa), Some(pb)) = (enu[pr.a], enu[pr.b]) else {
            continue;
        };
        for (x, y, flip) in [(pr.a, pr.b, false), (pr.b, pr.a, true)] {
            let d = if flip { pa - pb } else { pb - pa };
            if d.xy().norm() < min_base {
                continue;
            }
            let kx = |img: usize, k: u32| {
                let q = m.images[img].features.keypoints[k as usize];
                (q.x, q.y)
            };
            // Positions in x (camera of interest) and y.
            let (px, py): (Vec<_>, Vec<_>) = pr
                .verified
                .iter()
                .map(|&(i, j)| {
                    if flip {
                        (kx(x, j), kx(y, i))
                    } else {
                        (kx(x, i), kx(y, j))
                    }
                })
                .unzip();
            // Map y → x; the ground point at y's centre appears in x at z·c + t.
            let Some((z, t)) = similarity(&py, &px) else {
                continue;
            };
            let c = (
                m.images[y].size.0 as f64 / 2.0,
                m.images[y].size.1 as f64 / 2.0,
            );
            let q = (z.0 * c.0 - z.1 * c.1 + t.0, z.0 * c.1 + z.1 * c.0 + t.1);
            // Seen in x at q, it is at c in y: the flow in x's pixels (y down) against the
            // motion; the motion in x's image axes (x right, y up) is (f.x, −f.y).
            let f = (q.0 - c.0, q.1 - c.1);
            let heading = d.x.atan2(d.y) - f.0.atan2(-f.1);
            votes[x].push((heading, pr.verified.len()));
        }
    }
    votes
        .iter()
        .map(|v| {
            if v.is_empty() {
                return None;
            }
            // Circular median: the vote with the smallest weighted sum of angular distances.
            v.iter()
                .map(|&(h, _)| {
                    let cost: f64 = v
                        .iter()
                        .map(|&(g, w)| {
                            let d = (g - h).rem_euclid(std::f64::consts::TAU);
                            d.min(std::f64::consts::TAU - d) * w as f64
                        })
                        .sum();
                    (cost, h)
                })
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .map(|x| x.1.rem_euclid(std::f64::consts::TAU))
        })
        .collect()
}

/// Depths of a track's rays (distance along the viewing direction) intersected with the start
/// poses; `None` when it cannot be intersected.
fn track_depths(
    m: &Matched,
    t: &[photo::features::tracks::Node],
    pose_of: &[Option<(Pose, usize)>],
    cams: &[(CameraOut, String)],
) -> Option<Vec<f64>> {
    let rays: Vec<Ray> = t
        .iter()
        .filter_map(|&(i, kp)| {
            let (pose, c) = pose_of[i].as_ref()?;
            let cam = &cams[*c].0.camera;
            let q = m.images[i].features.keypoints[kp as usize];
            Some(Ray {
                camera: cam,
                pose,
                xy: cam.pixel_to_image(nalgebra::Vector2::new(q.x, q.y)),
                sigma: cam.pixel,
            })
        })
        .collect();
    if rays.len() < 2 {
        return None;
    }
    let x = intersect(&rays).ok()?.point;
    Some(
        rays.iter()
            .map(|r| -(r.pose.r.transpose() * (x - r.pose.centre)).z)
            .collect(),
    )
}

/// Tracks whose points lie at a plausible depth from every camera seeing them: within a
/// factor [`DEPTH_FACTOR`] of the median depth of all tracks. A wrong match can pass the
/// epipolar test and put its point just below a camera, where it would dominate (and spoil)
/// the adjustment's normal equations. Tracks seen by fewer than two posed cameras are kept (the adjustment
/// judges them); those that cannot be placed from two posed cameras are left out.
fn depth_check(
    m: &Matched,
    pose_of: &[Option<(Pose, usize)>],
    cams: &[(CameraOut, String)],
) -> Vec<bool> {
    let depths: Vec<Option<Vec<f64>>> = m
        .tracks
        .tracks
        .par_iter()
        .map(|t| track_depths(m, t, pose_of, cams))
        .collect();
    let mut all: Vec<f64> = depths
        .iter()
        .flatten()
        .flatten()
        .copied()
        .filter(|d| *d > 0.0)
        .collect();
    if all.is_empty() {
        return vec![true; depths.len()];
    }
    all.sort_by(f64::total_cmp);
    let med = all[all.len() / 2];
    depths
        .iter()
        .zip(&m.tracks.tracks)
        .map(|(d, t)| match d {
            // Not placeable with two posed rays: parallel rays (reflections on water, or a
            // wrong match along the flight line) or a point behind a camera.
            None => t.iter().filter(|(i, _)| pose_of[*i].is_some()).count() < 2,
            Some(d) => d
                .iter()
                .all(|&x| x > med / DEPTH_FACTOR && x < med * DEPTH_FACTOR),
        })
        .collect()
}

/// Depths accepted: within this factor of the median.
pub const DEPTH_FACTOR: f64 = 2.0;

/// The project of the main block (component 0) of `m`.
pub fn build(job: &MatchJob, m: &Matched) -> Result<Written, MatchError> {
    let mut w = Written::default();
    let block: Vec<usize> = (0..m.images.len())
        .filter(|&i| m.component[i] == 0)
        .collect();
    w.not_connected = (0..m.images.len())
        .filter(|&i| m.component[i] != 0)
        .map(|i| m.images[i].meta.id.clone())
        .collect();
    let (cam_of, cams) = cameras(job, m, &block)?;
    let (pos, enu) = (&m.positions, &m.enu);
    let heading = headings_from_overlap(m, enu, 5.0);
    let mut in_project = vec![false; m.images.len()];
    let mut pose_of: Vec<Option<(Pose, usize)>> = vec![None; m.images.len()];
    let mut p = ProjectOut {
        name: "ppkat match".into(),
        output: "geodetic".into(),
        ..ProjectOut::default()
    };
    for (&i, c) in block.iter().zip(&cam_of) {
        let im = &m.images[i];
        let k = match c {
            Ok(k) => *k,
            Err(e) => {
                w.no_camera.push((im.meta.id.clone(), e.clone()));
                continue;
            }
        };
        in_project[i] = true;
        p.images.push((im.meta.id.clone(), cams[k].0.id.clone()));
        let Some(ps) = pos[i] else { continue };
        let g = Geodetic::from_degrees(ps.lat, ps.lon, ps.h);
        let s = ps
            .sigma
            .unwrap_or([job.gnss_sigma[0], job.gnss_sigma[0], job.gnss_sigma[1]]);
        p.gnss.push((im.meta.id.clone(), g.to_ecef(), s));
        w.with_position += 1;
        let start = start_rotation(im, heading[i], &mut w);
        if let (Some(r), Some(c)) = (start, enu[i]) {
            pose_of[i] = Some((Pose { r, centre: c }, k));
        }
        if let Some(r_enu) = start {
            p.starts.push(StartOut {
                image: im.meta.id.clone(),
                pos: g.to_ecef(),
                r_enu,
            });
            w.with_attitude += 1;
        }
    }
    let depth_ok = depth_check(m, &pose_of, &cams);
    add_tracks(m, &in_project, &depth_ok, &mut p, &mut w);
    w.observations = p.measurements.len();
    let mut used: BTreeMap<String, usize> = BTreeMap::new();
    for (_, c) in &p.images {
        *used.entry(c.clone()).or_default() += 1;
    }
    w.cameras = cams
        .iter()
        .filter(|(c, _)| used.contains_key(&c.id))
        .map(|(c, s)| (c.id.clone(), s.clone(), used[&c.id]))
        .collect();
    p.cameras = cams
        .into_iter()
        .filter(|(c, _)| used.contains_key(&c.id))
        .map(|x| x.0)
        .collect();
    p.notes = vec![
        format!("written by ppkat match from {}", job.photos.display()),
        "positions: ".to_string()
            + if job.exposures.is_some() { "the exposures table" } else if job.ignore_gps { "none (--ignore-gps)" } else { "EXIF GPS (altitudes taken as ellipsoidal heights: consumer GPS heights are often biased, the block shifts with them)" },
        "start attitudes: nadir photos headed as their overlaps with neighbours say, others from DJI gimbal yaw/pitch/roll".into(),
    ];
    if p.gnss.is_empty() {
        p.free_datum = true;
        p.notes.push("no positions: a free network (coordinates arbitrary) until control points or positions are added; adjust starts it from the relative orientation of its best pair".into());
    }
    w.project = p;
    Ok(w)
}

/// The start rotation (camera → ENU) of a photo: near-nadir photos take the heading their
/// overlaps give (`heading`, noted when the gimbal's yaw disagrees by more than 30°), others
/// the DJI gimbal's angles; `None` without either.
fn start_rotation(im: &Image, heading: Option<f64>, w: &mut Written) -> Option<Matrix3<f64>> {
    let nadir = im.meta.dji.gimbal.is_none_or(|g| g[1] < -60.0);
    match (heading, im.meta.dji.gimbal) {
        (Some(h), _) if nadir => {
            if let Some([_, _, yaw]) = im.meta.dji.gimbal {
                let d = (h.to_degrees() - yaw).rem_euclid(360.0);
                if d.min(360.0 - d) > 30.0 {
                    w.heading_disagrees
                        .push((im.meta.id.clone(), d.min(360.0 - d)));
                }
            }
            Some(compass_rotation(h, -std::f64::consts::FRAC_PI_2, 0.0))
        }
        (_, Some([roll, pitch, yaw])) => Some(compass_rotation(
            yaw.to_radians(),
            pitch.to_radians(),
            roll.to_radians(),
        )),
        _ => None,
    }
}

/// The measurements of every track seen in two or more photos of the project whose depths
/// are plausible (`depth_ok`), each with its σ: the sub-pixel measurement's where there is
/// one, else the feature's.
fn add_tracks(
    m: &Matched,
    in_project: &[bool],
    depth_ok: &[bool],
    p: &mut ProjectOut,
    w: &mut Written,
) {
    for (k, t) in m.tracks.tracks.iter().enumerate() {
        let nodes: Vec<_> = t
            .iter()
            .enumerate()
            .filter(|(_, (i, _))| in_project[*i])
            .collect();
        if nodes.len() < 2 {
            continue;
        }
        if !depth_ok[k] {
            w.implausible_depth += 1;
            continue;
        }
        w.tracks += 1;
        if nodes.len() >= 3 {
            w.tracks_3plus += 1;
        }
        let measured = m.refinement.measured.get(k);
        let any = measured.is_some_and(|r| r.iter().any(Option::is_some));
        for &(n, &(i, kp)) in &nodes {
            let q = m.images[i].features.keypoints[kp as usize];
            let refined = measured.and_then(|r| r[n]);
            let (x, y) = refined.map_or((q.x, q.y), |r| (r.px.x, r.px.y));
            p.measurements
                .push((m.images[i].meta.id.clone(), format!("T{:06}", k + 1), x, y));
            let s = m.images[i].scale;
            p.measurement_sigmas.push(match refined {
                Some(r) => super::refine::sigma(r.sigma, s),
                // The template's own point: measured by definition, as well as its fits.
                None if n == 0 && any => super::refine::sigma(0.0, s),
                None => SIGMA_FEATURE_PX * s,
            });
        }
    }
}

/// A project without positions (a free network) given the start orientations `adjust` finds
/// from its tie points alone (the relative orientation of its best pair, grown by resection),
/// rewritten into `dir` where it was written; returns the photos with a start.
pub fn tie_starts(p: &mut ProjectOut, dir: &std::path::Path) -> Result<usize, MatchError> {
    use adjust::{build::start_poses, project::Project};
    let loaded =
        Project::load(&dir.join("project.toml")).map_err(|e| MatchError::Nothing(e.to_string()))?;
    let poses = start_poses(&loaded).map_err(|e| MatchError::Nothing(e.to_string()))?;
    p.starts = loaded
        .images
        .iter()
        .zip(&poses)
        .filter_map(|(im, s)| {
            s.map(|(pos, r_enu)| StartOut {
                image: im.id.clone(),
                pos,
                r_enu,
            })
        })
        .collect();
    p.write(dir)
        .map_err(|e| MatchError::Nothing(e.to_string()))?;
    Ok(p.starts.len())
}
