//! `ppkat import colmap`: a COLMAP sparse model in text form — `cameras.txt` (converted by
//! `photo::camera_convert`), `images.txt` (poses: p = R(q)·X + t, camera z forward, y down;
//! centre −Rᵀt; ppkat's camera → world is Rᵀ·diag(1, −1, −1)) and `points3D.txt` (tracks).
//!
//! Datum: a COLMAP model has an arbitrary scale, position and rotation. The photos' EXIF GPS
//! (`--gnss-exif`) gives each image a GNSS camera position with a σ; the model is moved onto
//! them by a similarity transformation (Umeyama) for the start values, and the GNSS positions
//! enter the adjustment as antenna positions (lever arm zero, fixed). EXIF altitudes are
//! written as ellipsoidal heights (consumer GPS heights are often above sea level or biased:
//! the whole block shifts with them). Tie points seen in fewer than `min_track` images are
//! skipped and counted.

use super::common::{ferr, lines, ImportError, Summary};
use super::write::{CameraOut, ProjectOut, StartOut};
use ::common::frame::{enu_rotation, Ecef, Geodetic};
use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};
use photo::camera_convert::ColmapCamera;
use photo::relative::similarity;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// What `ppkat import colmap` reads.
#[derive(Clone, Debug)]
pub struct ColmapJob {
    /// Folder with `cameras.txt`, `images.txt`, `points3D.txt`.
    pub dir: PathBuf,
    /// Folder of the photos whose EXIF GPS gives the datum.
    pub gnss_exif: Option<PathBuf>,
    /// σ of the EXIF positions, horizontal and vertical (m).
    pub gnss_sigma: [f64; 2],
    /// Smallest track length kept.
    pub min_track: usize,
    /// Pixel size written for the cameras (µm).
    pub pixel_um: f64,
    /// Image measurement σ, pixels.
    pub sigma_px: f64,
}

/// One registered image: name, camera id, rotation world → camera, centre, observations.
struct Image {
    name: String,
    camera: u64,
    r: Matrix3<f64>,
    centre: Vector3<f64>,
    obs: Vec<(f64, f64, i64)>,
}

fn num<T: std::str::FromStr>(path: &Path, line: usize, s: Option<&str>) -> Result<T, ImportError> {
    s.and_then(|s| s.parse().ok()).ok_or_else(|| {
        ferr(
            path,
            Some(line),
            format!(
                "`{}` is not a number where one is expected",
                s.unwrap_or("")
            ),
        )
    })
}

fn read_cameras(path: &Path) -> Result<BTreeMap<u64, ColmapCamera>, ImportError> {
    let mut out = BTreeMap::new();
    for (n, l) in lines(path)? {
        let f: Vec<&str> = l.split_whitespace().collect();
        if f.is_empty() {
            continue;
        }
        let id: u64 = num(path, n, f.first().copied())?;
        let params = f
            .iter()
            .skip(4)
            .map(|s| num(path, n, Some(s)))
            .collect::<Result<Vec<f64>, _>>()?;
        let cam = ColmapCamera {
            model: f.get(1).unwrap_or(&"").to_string(),
            width: num(path, n, f.get(2).copied())?,
            height: num(path, n, f.get(3).copied())?,
            params,
        };
        if out.insert(id, cam).is_some() {
            return Err(ferr(
                path,
                Some(n),
                format!("camera {id} is listed twice: keep one"),
            ));
        }
    }
    Ok(out)
}

fn read_images(path: &Path) -> Result<BTreeMap<u64, Image>, ImportError> {
    let ls = lines(path)?;
    let mut out = BTreeMap::new();
    let mut it = ls.iter();
    while let Some((n, l)) = it.next() {
        let f: Vec<&str> = l.split_whitespace().collect();
        if f.is_empty() {
            continue;
        }
        if f.len() < 10 {
            return Err(ferr(
                path,
                Some(*n),
                "expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME",
            ));
        }
        let v: Vec<f64> = (1..8)
            .map(|k| num(path, *n, Some(f[k])))
            .collect::<Result<_, _>>()?;
        let q = UnitQuaternion::from_quaternion(Quaternion::new(v[0], v[1], v[2], v[3]));
        let r = q.to_rotation_matrix().into_inner();
        let t = Vector3::new(v[4], v[5], v[6]);
        let id: u64 = num(path, *n, Some(f[0]))?;
        let obs_line = it.next().map(|x| x.1.clone()).unwrap_or_default();
        let o: Vec<&str> = obs_line.split_whitespace().collect();
        let mut obs = Vec::with_capacity(o.len() / 3);
        for c in o.chunks(3) {
            if c.len() == 3 {
                obs.push((
                    num(path, n + 1, Some(c[0]))?,
                    num(path, n + 1, Some(c[1]))?,
                    num(path, n + 1, Some(c[2]))?,
                ));
            }
        }
        let img = Image {
            name: f[9..].join(" "),
            camera: num(path, *n, Some(f[8]))?,
            r,
            centre: -(r.transpose() * t),
            obs,
        };
        if out.insert(id, img).is_some() {
            return Err(ferr(
                path,
                Some(*n),
                format!("image {id} is listed twice: keep one"),
            ));
        }
    }
    Ok(out)
}

/// Track length of every point of `points3D.txt`.
fn read_tracks(path: &Path) -> Result<BTreeMap<i64, usize>, ImportError> {
    let mut out = BTreeMap::new();
    for (n, l) in lines(path)? {
        let f: Vec<&str> = l.split_whitespace().collect();
        if f.is_empty() {
            continue;
        }
        if f.len() < 8 || !(f.len() - 8).is_multiple_of(2) {
            return Err(ferr(
                path,
                Some(n),
                "expected POINT3D_ID X Y Z R G B ERROR (IMAGE_ID POINT2D_IDX)…",
            ));
        }
        let id: i64 = num(path, n, Some(f[0]))?;
        if out.insert(id, (f.len() - 8) / 2).is_some() {
            return Err(ferr(
                path,
                Some(n),
                format!("point {id} is listed twice: keep one"),
            ));
        }
    }
    Ok(out)
}

/// Import a COLMAP sparse text model: the ppkat project and what was read and skipped.
pub fn import(job: &ColmapJob) -> Result<(ProjectOut, Summary), ImportError> {
    let Some(photos) = &job.gnss_exif else {
        return Err(ImportError::Usage("a COLMAP model has no datum: give --gnss-exif PHOTO_DIR (the photos' EXIF GPS become GNSS camera positions)".into()));
    };
    let cameras = read_cameras(&job.dir.join("cameras.txt"))?;
    let images = read_images(&job.dir.join("images.txt"))?;
    let tracks = read_tracks(&job.dir.join("points3D.txt"))?;
    let mut sum = Summary::default();
    sum.read.push(("cameras".into(), cameras.len()));
    sum.read.push(("images".into(), images.len()));
    sum.read.push(("points".into(), tracks.len()));
    let mut out = ProjectOut {
        name: format!("COLMAP import of {}", job.dir.display()),
        output: "utm".into(),
        notes: vec!["written by ppkat import colmap; datum from the photos' EXIF GPS".into()],
        ..Default::default()
    };
    add_cameras(job, &cameras, &mut out, &mut sum)?;
    let gps = exif_positions(job, photos, &images, &mut sum);
    let datum = Datum::fit(photos, &images, &gps, &mut sum)?;
    let mut counts = ObsCounts::default();
    for (id, im) in &images {
        if !cameras.contains_key(&im.camera) {
            return Err(ferr(
                &job.dir.join("images.txt"),
                None,
                format!(
                    "image {} uses camera {} that cameras.txt does not list",
                    im.name, im.camera
                ),
            ));
        }
        out.images
            .push((im.name.clone(), format!("c{}", im.camera)));
        out.starts.push(datum.start(im));
        if let Some(g) = gps.get(id) {
            out.gnss.push((
                im.name.clone(),
                g.to_ecef(),
                [job.gnss_sigma[0], job.gnss_sigma[0], job.gnss_sigma[1]],
            ));
        }
        add_observations(job, im, &tracks, &mut out, &mut sum, &mut counts);
    }
    counts.say(job, &mut sum);
    Ok((out, sum))
}

/// The cameras of the model as ppkat cameras (`c<id>`), with how far each conversion is from
/// COLMAP's model in a note.
fn add_cameras(
    job: &ColmapJob,
    cameras: &BTreeMap<u64, ColmapCamera>,
    out: &mut ProjectOut,
    sum: &mut Summary,
) -> Result<(), ImportError> {
    let cpath = job.dir.join("cameras.txt");
    for (id, c) in cameras {
        let conv = c
            .to_camera(job.pixel_um * 1e-6)
            .map_err(|e| ferr(&cpath, None, format!("camera {id}: {e}")))?;
        sum.notes.push(format!(
            "camera {id} ({}): largest difference to COLMAP's model over the image {:.3} px",
            c.model, conv.max_error_px
        ));
        out.cameras.push(CameraOut {
            id: format!("c{id}"),
            camera: conv.camera,
            sigma_px: job.sigma_px,
            self_calibrate: Vec::new(),
        });
    }
    Ok(())
}

/// The EXIF GPS positions of the registered images (those without one skipped, named).
fn exif_positions(
    job: &ColmapJob,
    photos: &Path,
    images: &BTreeMap<u64, Image>,
    sum: &mut Summary,
) -> BTreeMap<u64, Geodetic> {
    let mut gps: BTreeMap<u64, Geodetic> = BTreeMap::new();
    for (id, im) in images {
        match exposure::photos::read_position(&photos.join(&im.name)) {
            Some((lat, lon, h)) => {
                gps.insert(*id, Geodetic::from_degrees(lat, lon, h));
            }
            None => sum.skipped.push((
                format!("GNSS of image {}", im.name),
                format!("no EXIF GPS in {}", photos.join(&im.name).display()),
            )),
        }
    }
    sum.read.push(("EXIF GPS positions".into(), gps.len()));
    sum.notes.push(format!(
        "GNSS positions from EXIF GPS: σ {} m horizontal, {} m vertical (--gnss-sigma; consumer GPS by default); no drift: the block takes their datum, a bias of their heights included",
        job.gnss_sigma[0], job.gnss_sigma[1]
    ));
    gps
}

/// The model moved onto the EXIF positions: the ENU frame at the first of them and the
/// similarity (scale, rotation, shift) from model to ENU.
struct Datum {
    o_ecef: Ecef,
    r0: Matrix3<f64>,
    scale: f64,
    rot: Matrix3<f64>,
    shift: Vector3<f64>,
}

impl Datum {
    /// Fit the similarity of the image centres onto their EXIF positions (3D RMS in a note).
    fn fit(
        photos: &Path,
        images: &BTreeMap<u64, Image>,
        gps: &BTreeMap<u64, Geodetic>,
        sum: &mut Summary,
    ) -> Result<Datum, ImportError> {
        let origin = gps.values().next().copied().ok_or_else(|| {
            ferr(
                photos,
                None,
                "no photo with EXIF GPS: the model has no datum",
            )
        })?;
        let o_ecef = origin.to_ecef();
        let r0 = enu_rotation(&origin);
        let enu = |g: &Geodetic| r0 * (g.to_ecef().0 - o_ecef.0);
        let (from, to): (Vec<_>, Vec<_>) = gps
            .iter()
            .map(|(id, g)| (images[id].centre, enu(g)))
            .unzip();
        let (scale, rot, shift) = similarity(&from, &to).ok_or_else(|| {
            ferr(
                photos,
                None,
                "fewer than 3 EXIF positions, or all on a line: no datum for the model",
            )
        })?;
        let rms = (from
            .iter()
            .zip(&to)
            .map(|(a, b)| (scale * rot * a + shift - b).norm_squared())
            .sum::<f64>()
            / from.len() as f64)
            .sqrt();
        sum.notes.push(format!(
            "model moved onto the EXIF GPS: scale {scale:.4}, 3D RMS {rms:.2} m"
        ));
        Ok(Datum {
            o_ecef,
            r0,
            scale,
            rot,
            shift,
        })
    }

    /// The start orientation of an image: its centre in ECEF and camera → local ENU.
    fn start(&self, im: &Image) -> StartOut {
        let flip = Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0));
        let c_enu = self.scale * self.rot * im.centre + self.shift;
        let pos = Ecef(self.o_ecef.0 + self.r0.transpose() * c_enu);
        let r_here = enu_rotation(&pos.to_geodetic()) * self.r0.transpose();
        StartOut {
            image: im.name.clone(),
            pos,
            r_enu: r_here * self.rot * im.r.transpose() * flip,
        }
    }
}

/// Observations left out in bulk (counted, said once) and kept.
#[derive(Default)]
struct ObsCounts {
    /// Of points seen in fewer than `--min-track` images.
    short: usize,
    /// Second observations of a point in one image.
    twice: usize,
    /// Kept.
    kept: usize,
}

impl ObsCounts {
    /// The counts into the summary.
    fn say(&self, job: &ColmapJob, sum: &mut Summary) {
        if self.twice > 0 {
            sum.skipped.push((
                format!("{} observations", self.twice),
                "a second observation of a point in the same image (the first is kept)".into(),
            ));
        }
        if self.short > 0 {
            sum.skipped.push((
                format!("{} observations", self.short),
                format!(
                    "their points are seen in fewer than {} images (--min-track)",
                    job.min_track
                ),
            ));
        }
        sum.read.push(("observations kept".into(), self.kept));
    }
}

/// The observations of one image whose points are in at least `--min-track` images.
fn add_observations(
    job: &ColmapJob,
    im: &Image,
    tracks: &BTreeMap<i64, usize>,
    out: &mut ProjectOut,
    sum: &mut Summary,
    counts: &mut ObsCounts,
) {
    let mut in_image = std::collections::BTreeSet::new();
    for &(x, y, p) in &im.obs {
        if p < 0 {
            continue;
        }
        if !in_image.insert(p) {
            // COLMAP may keep two keypoints of one image in one track: one is kept.
            counts.twice += 1;
            continue;
        }
        match tracks.get(&p) {
            Some(&n) if n >= job.min_track => {
                counts.kept += 1;
                out.measurements
                    .push((im.name.clone(), format!("t{p}"), x, y));
            }
            Some(_) => counts.short += 1,
            None => sum.skipped.push((
                format!("observation of point {p} in {}", im.name),
                "point not in points3D.txt".into(),
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn similarity_recovers_a_known_transformation() {
        let r = UnitQuaternion::from_euler_angles(0.3, -0.2, 1.1)
            .to_rotation_matrix()
            .into_inner();
        let from = [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(1.0, 0.2, 0.0),
            Vector3::new(0.1, 2.0, 0.3),
            Vector3::new(-1.0, 0.5, 1.0),
        ];
        let to: Vec<_> = from
            .iter()
            .map(|a| 2.5 * r * a + Vector3::new(10.0, -4.0, 3.0))
            .collect();
        let (s, rr, t) = similarity(&from, &to).unwrap();
        assert!((s - 2.5).abs() < 1e-12 && (rr - r).norm() < 1e-12);
        assert!((t - Vector3::new(10.0, -4.0, 3.0)).norm() < 1e-11);
        assert!(similarity(&from[..2], &to[..2]).is_none());
    }
}
