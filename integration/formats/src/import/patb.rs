//! `ppkat import patb`: PATB image coordinates and control points as a ppkat project.
//!
//! **Image coordinates** (`--images FILE`): blocks of a header line `PHOTO [CAMERA]`, then one
//! `POINT x y` line per measurement, closed by `-99`. Units ([`Units`]):
//! - `mm`: x right, y up, origin at the image centre (the fiducial centre, where PATB puts
//!   its origin; the principal point offset belongs to the camera), millimetres;
//! - `px`: column right, row down, origin at the top-left corner of the image, pixels.
//!
//! Both become ppkat pixels (column right, row down, origin top-left) with the camera's size
//! W × H and pixel pitch p: column = x/p + W/2, row = H/2 − y/p for millimetres (the inverse
//! of `photo::camera::Camera::pixel_to_image`). Every measurement must fall inside its image.
//!
//! **Cameras**: `--camera FILE.toml` holds `[[camera]]` tables of a ppkat project (a
//! `project.toml` works); a photo names its camera with the header's second field (needed
//! when there are several). Or the flags `--focal-mm --pixel-um --width-px --height-px` give
//! one ideal camera `cam`; without its size no photo can be converted (an error naming the
//! photo's line).
//!
//! **Control** (`--ground FILE`): lines `ID X Y Z [σX σY σZ | σXY σZ] [KIND]` with X east,
//! Y north, Z up (metres, in the `--crs` frame or a local frame, see [`super::GroundFrame`]);
//! `-99` lines are separators. KIND is `gcp` (default), `gcp-xy`, `gcp-z` or `check`;
//! `--check IDS` makes points check points. Without σ the job's default σ is used.
//!
//! Blank lines and lines starting with `#` are skipped everywhere. Points measured but not in
//! the control file are tie points. Skipped with a reason: photos without measurements,
//! control points never measured, cameras no photo uses. Errors name the file and line.

use super::common::{ferr, GroundFrame, ImportError, Summary};
use super::write::{CameraOut, GroundOut, ProjectOut};
use adjust::camera_section::{camera_def, CameraSection, INTERIOR_NAMES};
use nalgebra::{Vector2, Vector3};
use photo::camera::Camera;
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::{Path, PathBuf};

/// The units of PATB image coordinates.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Units {
    /// Millimetres, x right, y up, origin at the image centre.
    #[default]
    Mm,
    /// Pixels, column right, row down, origin at the top-left corner.
    Px,
}

/// One ideal camera given by its numbers.
#[derive(Clone, Copy, Debug)]
pub struct CameraNumbers {
    /// Principal distance, mm.
    pub focal_mm: f64,
    /// Pixel pitch, µm.
    pub pixel_um: f64,
    /// Image width, pixels (needed to convert).
    pub width_px: Option<usize>,
    /// Image height, pixels (needed to convert).
    pub height_px: Option<usize>,
    /// Image measurement σ, pixels.
    pub sigma_px: f64,
}

/// Where the cameras come from.
#[derive(Clone, Debug)]
pub enum CameraSource {
    /// `[[camera]]` tables of a ppkat project file.
    File(PathBuf),
    /// One ideal camera, id `cam`.
    Numbers(CameraNumbers),
}

/// What `ppkat import patb` reads.
#[derive(Clone, Debug)]
pub struct PatbJob {
    /// PATB image coordinates.
    pub images: PathBuf,
    /// Their units.
    pub units: Units,
    /// The cameras.
    pub camera: CameraSource,
    /// PATB control points.
    pub ground: Option<PathBuf>,
    /// Control points to use as check points.
    pub check: Vec<String>,
    /// σ of control points without their own, horizontal and vertical (m).
    pub ground_sigma: [f64; 2],
    /// `EPSG:326ZZ`, `utm:ZZN`…; none: a local frame.
    pub crs: Option<String>,
}

/// A measurement line: point, x, y (file units), line.
type PatbObs = (String, f64, f64, usize);

/// A photo block of a PATB image file.
#[derive(Clone, Debug)]
struct Photo {
    id: String,
    /// The header's second field.
    camera: Option<String>,
    line: usize,
    obs: Vec<PatbObs>,
}

/// A control point: id, position, σ (when given), kind (when given), line.
type Control = (
    String,
    Vector3<f64>,
    Option<[f64; 3]>,
    Option<&'static str>,
    usize,
);

/// Non-comment, non-blank lines split into fields, with their line numbers.
fn fields(path: &Path) -> Result<Vec<(usize, Vec<String>)>, ImportError> {
    Ok(super::common::lines(path)?
        .into_iter()
        .map(|(i, l)| (i, l.split_whitespace().map(String::from).collect()))
        .filter(|(_, f): &(usize, Vec<String>)| !f.is_empty())
        .collect())
}

/// A finite number, or an error naming the file, line and what was expected.
fn number(path: &Path, line: usize, s: &str, expected: &str) -> Result<f64, ImportError> {
    s.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| {
            ferr(
                path,
                Some(line),
                format!("`{s}` is not a number: expected {expected}"),
            )
        })
}

/// Read a PATB image-coordinate file; `sum` gets a note on extra fields.
fn read_images(path: &Path, sum: &mut Summary) -> Result<Vec<Photo>, ImportError> {
    const EXPECT: &str = "`POINT x y` (or -99 to close the photo)";
    let mut photos: Vec<Photo> = Vec::new();
    // First lines of the photos and of the current photo's points: duplicates found in O(1).
    let mut photo_lines: HashMap<String, usize> = HashMap::new();
    let mut point_lines: HashMap<String, usize> = HashMap::new();
    let mut open = false;
    let mut extra = (0usize, 0usize);
    for (line, f) in fields(path)? {
        if f[0] == "-99" {
            open = false;
            continue;
        }
        if !open {
            if let Some(first) = photo_lines.insert(f[0].clone(), line) {
                return Err(ferr(
                    path,
                    Some(line),
                    format!(
                        "photo {} is listed again (first at line {first}): give each photo one block",
                        f[0]
                    ),
                ));
            }
            point_lines.clear();
            extra.0 += usize::from(f.len() > 2);
            photos.push(Photo {
                id: f[0].clone(),
                camera: f.get(1).cloned(),
                line,
                obs: Vec::new(),
            });
            open = true;
            continue;
        }
        let Some(photo) = photos.last_mut() else {
            continue;
        };
        if f.len() < 3 {
            return Err(ferr(
                path,
                Some(line),
                format!(
                    "{} field(s) in photo {}: expected {EXPECT}",
                    f.len(),
                    photo.id
                ),
            ));
        }
        extra.1 += usize::from(f.len() > 3);
        let (x, y) = (
            number(path, line, &f[1], EXPECT)?,
            number(path, line, &f[2], EXPECT)?,
        );
        if let Some(first) = point_lines.insert(f[0].clone(), line) {
            return Err(ferr(
                path,
                Some(line),
                format!(
                    "point {} is measured twice in photo {} (first at line {first}): keep one",
                    f[0], photo.id
                ),
            ));
        }
        photo.obs.push((f[0].clone(), x, y, line));
    }
    if extra.0 + extra.1 > 0 {
        sum.notes.push(format!(
            "{}: fields after `PHOTO CAMERA` ({} header lines) and after `POINT x y` ({} lines) were not used",
            path.display(),
            extra.0,
            extra.1
        ));
    }
    Ok(photos)
}

/// The kind of a control point's KIND field.
fn kind_of(s: &str) -> Option<&'static str> {
    match s {
        "gcp" | "control" => Some("gcp"),
        "gcp-xy" => Some("gcp-xy"),
        "gcp-z" | "gcp-h" => Some("gcp-z"),
        "check" => Some("check"),
        _ => None,
    }
}

/// Read a PATB control file.
fn read_control(path: &Path) -> Result<Vec<Control>, ImportError> {
    const EXPECT: &str = "`ID X Y Z [σX σY σZ | σXY σZ] [gcp|gcp-xy|gcp-z|check]`";
    let mut out: Vec<Control> = Vec::new();
    let mut point_lines: HashMap<String, usize> = HashMap::new();
    for (line, f) in fields(path)? {
        if f[0] == "-99" {
            continue;
        }
        if f.len() < 4 {
            return Err(ferr(
                path,
                Some(line),
                format!("{} field(s): expected {EXPECT}", f.len()),
            ));
        }
        let mut rest = &f[4..];
        let kind = match rest.last().filter(|s| s.parse::<f64>().is_err()) {
            Some(k) => {
                let kind = kind_of(k).ok_or_else(|| {
                    ferr(
                        path,
                        Some(line),
                        format!("`{k}` is not a number nor a kind: expected {EXPECT}"),
                    )
                })?;
                rest = &rest[..rest.len() - 1];
                Some(kind)
            }
            None => None,
        };
        let n: Vec<f64> = f[1..4]
            .iter()
            .chain(rest)
            .map(|s| number(path, line, s, EXPECT))
            .collect::<Result<_, _>>()?;
        let sigma = match n[3..] {
            [] => None,
            [h, v] => Some([h, h, v]),
            [x, y, z] => Some([x, y, z]),
            _ => {
                return Err(ferr(
                    path,
                    Some(line),
                    format!("{} σ values: expected {EXPECT}", n.len() - 3),
                ))
            }
        };
        if sigma.is_some_and(|s| s.iter().any(|v| *v <= 0.0)) {
            return Err(ferr(path, Some(line), "σ must be positive"));
        }
        if let Some(first) = point_lines.insert(f[0].clone(), line) {
            return Err(ferr(
                path,
                Some(line),
                format!(
                    "point {} is listed twice (first at line {first}): keep one",
                    f[0]
                ),
            ));
        }
        out.push((
            f[0].clone(),
            Vector3::new(n[0], n[1], n[2]),
            sigma,
            kind,
            line,
        ));
    }
    Ok(out)
}

/// Cameras with their ids, σ and parameters to estimate; a camera without a size has
/// `width_px == 0`.
fn cameras(source: &CameraSource) -> Result<Vec<CameraOut>, ImportError> {
    match source {
        CameraSource::Numbers(c) => {
            let ok = |v: f64| v.is_finite() && v > 0.0;
            if !(ok(c.focal_mm) && ok(c.pixel_um) && ok(c.sigma_px)) {
                return Err(ImportError::Usage(
                    "--focal-mm, --pixel-um and --sigma-px must be positive numbers".into(),
                ));
            }
            let (w, h) = (c.width_px.unwrap_or(0), c.height_px.unwrap_or(0));
            Ok(vec![CameraOut {
                id: "cam".into(),
                camera: Camera::ideal(c.focal_mm * 1e-3, c.pixel_um * 1e-6, w, h),
                sigma_px: c.sigma_px,
                self_calibrate: Vec::new(),
            }])
        }
        CameraSource::File(path) => camera_file(path),
    }
}

/// The `[[camera]]` tables of a ppkat camera file (the format of `project.toml`'s cameras);
/// also `ppkat match --camera`.
pub fn camera_file(path: &Path) -> Result<Vec<CameraOut>, ImportError> {
    #[derive(serde::Deserialize)]
    struct CameraFile {
        #[serde(default)]
        camera: Vec<CameraSection>,
    }
    let text =
        std::fs::read_to_string(path).map_err(|e| ferr(path, None, format!("cannot read: {e}")))?;
    let file: CameraFile = toml::from_str(&text).map_err(|e| {
        let line = e.span().map(|s| text[..s.start].matches('\n').count() + 1);
        ferr(
            path,
            line,
            format!("not a ppkat camera file: {}", e.message()),
        )
    })?;
    if file.camera.is_empty() {
        return Err(ferr(
            path,
            None,
            "no [[camera]] table: add one (id, focal_mm, pixel_um, width_px, height_px)",
        ));
    }
    file.camera
        .iter()
        .map(|c| {
            let d = camera_def(c, path).map_err(|e| ferr(path, None, e.to_string()))?;
            Ok(CameraOut {
                id: d.id,
                camera: d.camera,
                sigma_px: d.sigma_px,
                self_calibrate: d
                    .calibrate
                    .iter()
                    .map(|&i| INTERIOR_NAMES[i].to_string())
                    .collect(),
            })
        })
        .collect()
}

/// The index of a photo's camera, or an error naming the photo's line.
fn camera_of(
    path: &Path,
    photo: &Photo,
    cams: &[CameraOut],
    sum: &mut Summary,
) -> Result<usize, ImportError> {
    let named = photo
        .camera
        .as_ref()
        .and_then(|c| cams.iter().position(|k| k.id == *c));
    let k = match (named, cams.len()) {
        (Some(k), _) => k,
        (None, 1) => {
            if let Some(c) = &photo.camera {
                sum.notes.push(format!(
                    "{}:{}: photo {}: `{c}` is not a camera id; the only camera {} is used",
                    path.display(),
                    photo.line,
                    photo.id,
                    cams[0].id
                ));
            }
            0
        }
        _ => {
            let ids: Vec<&str> = cams.iter().map(|c| c.id.as_str()).collect();
            return Err(ferr(
                path,
                Some(photo.line),
                format!(
                    "photo {}: name its camera ({}) as the second field of the header line",
                    photo.id,
                    ids.join(", ")
                ),
            ));
        }
    };
    let c = &cams[k];
    if c.camera.width_px == 0 || c.camera.height_px == 0 {
        return Err(ferr(
            path,
            Some(photo.line),
            format!(
                "photo {}: camera {} has no image size, needed to turn PATB coordinates into pixels from the top-left corner: give --width-px and --height-px (or width_px, height_px in the camera file)",
                photo.id, c.id
            ),
        ));
    }
    Ok(k)
}

/// One measurement as ppkat pixels (column, row from the top-left corner), or an error when
/// it falls outside the image.
fn to_pixel(
    path: &Path,
    units: Units,
    cam: &CameraOut,
    photo: &str,
    o: &PatbObs,
) -> Result<Vector2<f64>, ImportError> {
    let (p, x, y, line) = o;
    let px = match units {
        Units::Mm => cam.camera.image_to_pixel(Vector2::new(x * 1e-3, y * 1e-3)),
        Units::Px => Vector2::new(*x, *y),
    };
    let (w, h) = (cam.camera.width_px as f64, cam.camera.height_px as f64);
    // On the edge counts as inside (1e-6 px for the rounding of mm → px).
    let inside = |v: f64, n: f64| (-1e-6..=n + 1e-6).contains(&v);
    if !inside(px.x, w) || !inside(px.y, h) {
        let unit = if units == Units::Mm { "mm" } else { "px" };
        return Err(ferr(
            path,
            Some(*line),
            format!(
                "point {p} in photo {photo}: ({x}, {y}) {unit} is pixel ({:.1}, {:.1}), outside the {w} × {h} px image of camera {}: check --units and the camera",
                px.x, px.y, cam.id
            ),
        ));
    }
    Ok(px)
}

/// Control points into `out` as ground points; kinds from the file and `--check`.
fn add_control(
    job: &PatbJob,
    path: &Path,
    frame: &GroundFrame,
    measured: &BTreeSet<String>,
    out: &mut ProjectOut,
    sum: &mut Summary,
) -> Result<(), ImportError> {
    let control = read_control(path)?;
    for id in &job.check {
        if !control.iter().any(|c| c.0 == *id) {
            return Err(ImportError::Usage(format!(
                "--check {id}: no such point in {}: give ids of its lines",
                path.display()
            )));
        }
    }
    let [h, v] = job.ground_sigma;
    let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
    for (id, p, sigma, kind, line) in control {
        let kind = if job.check.contains(&id) {
            "check"
        } else {
            kind.unwrap_or("gcp")
        };
        *counts.entry(kind).or_default() += 1;
        if !measured.contains(id.as_str()) {
            sum.skipped.push((
                format!("{kind} point {id} ({}:{line})", path.display()),
                format!("not measured in {}", job.images.display()),
            ));
            continue;
        }
        out.ground.push(GroundOut {
            id,
            kind,
            pos: frame.to_ecef(&p),
            sigma: sigma.unwrap_or([h, h, v]),
        });
    }
    for kind in ["gcp", "gcp-xy", "gcp-z", "check"] {
        sum.read.push((
            format!("{kind} points"),
            counts.get(kind).copied().unwrap_or(0),
        ));
    }
    Ok(())
}

/// Import PATB image coordinates (and control): the ppkat project and what was read and
/// skipped.
pub fn import(job: &PatbJob) -> Result<(ProjectOut, Summary), ImportError> {
    let frame = GroundFrame::parse(job.crs.as_deref())?;
    let mut sum = Summary::default();
    let cams = cameras(&job.camera)?;
    let photos = read_images(&job.images, &mut sum)?;
    let unit = match job.units {
        Units::Mm => "mm, x right, y up from the image centre",
        Units::Px => "px, column right, row down from the top-left corner",
    };
    let mut out = ProjectOut {
        name: format!("PATB import of {}", job.images.display()),
        output: frame.output(),
        notes: vec![
            format!(
                "written by ppkat import patb ({unit}); {}",
                frame.describe()
            ),
            "image measurements in pixels: column right, row down from the top-left corner".into(),
        ],
        ..Default::default()
    };
    sum.read.push(("cameras".into(), cams.len()));
    sum.read.push(("photos".into(), photos.len()));
    let mut used = vec![false; cams.len()];
    for photo in &photos {
        if photo.obs.is_empty() {
            sum.skipped.push((
                format!(
                    "photo {} ({}:{})",
                    photo.id,
                    job.images.display(),
                    photo.line
                ),
                "no measurements".into(),
            ));
            continue;
        }
        let k = camera_of(&job.images, photo, &cams, &mut sum)?;
        used[k] = true;
        out.images.push((photo.id.clone(), cams[k].id.clone()));
        for o in &photo.obs {
            let px = to_pixel(&job.images, job.units, &cams[k], &photo.id, o)?;
            out.measurements
                .push((photo.id.clone(), o.0.clone(), px.x, px.y));
        }
    }
    sum.read
        .push(("image measurements".into(), out.measurements.len()));
    let measured: BTreeSet<String> = out.measurements.iter().map(|m| m.1.clone()).collect();
    if let Some(g) = &job.ground {
        add_control(job, g, &frame, &measured, &mut out, &mut sum)?;
    } else if !job.check.is_empty() {
        return Err(ImportError::Usage(
            "--check needs --ground (the file the check points are in)".into(),
        ));
    }
    let known: BTreeSet<&str> = out.ground.iter().map(|g| g.id.as_str()).collect();
    let ties = measured
        .iter()
        .filter(|p| !known.contains(p.as_str()))
        .count();
    sum.read.push(("tie points".into(), ties));
    for (c, u) in cams.into_iter().zip(used) {
        if u {
            out.cameras.push(c);
        } else {
            sum.skipped
                .push((format!("camera {}", c.id), "no photo uses it".into()));
        }
    }
    sum.read.push(("images".into(), out.images.len()));
    sum.notes.push(frame.describe());
    Ok((out, sum))
}

#[cfg(test)]
#[path = "patb_tests.rs"]
mod tests;
