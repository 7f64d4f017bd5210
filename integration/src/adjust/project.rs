//! The project file (TOML) of `ppkat adjust` and the tables it names: cameras, the image list,
//! image measurements (CSV or PATB), ground points (control, check) and the GNSS antenna table
//! written by `ppkat exposures --format antenna`. Paths are relative to the project file.
//! Every problem names the file, the line and what to do.

use super::factors::DriftModel;
use super::AdjustError;
use crate::exposure::export::Projection;
use gnss::frame::{Ecef, Geodetic};
use hifitime::Epoch;
use nalgebra::{Matrix3, Vector2};
use photo::camera::Camera;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The TOML document.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProjectFile {
    #[serde(default)]
    pub name: String,
    /// `aerial` (default) or `close-range`.
    #[serde(default)]
    pub mode: Mode,
    /// `geodetic`, `utm`, `utm:ZONE` or `gk:CM` for the outputs (default `utm`).
    #[serde(default = "default_output")]
    pub output: String,
    pub camera: Vec<CameraSection>,
    pub images: ImagesSection,
    #[serde(default)]
    pub ground: Option<GroundSection>,
    #[serde(default)]
    pub gnss: Option<GnssSection>,
    #[serde(default)]
    pub adjustment: AdjustmentSection,
}

fn default_output() -> String {
    "utm".into()
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Mode {
    #[default]
    Aerial,
    CloseRange,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSection {
    pub id: String,
    pub focal_mm: f64,
    pub pixel_um: f64,
    pub width_px: usize,
    pub height_px: usize,
    #[serde(default)]
    pub principal_point_mm: [f64; 2],
    /// Radial k1, k2, k3 (image coordinates in metres).
    #[serde(default)]
    pub k: [f64; 3],
    #[serde(default)]
    pub p: [f64; 2],
    /// Image measurement σ, pixels (default 0.5).
    #[serde(default = "default_sigma_px")]
    pub sigma_px: f64,
    /// Interior parameters to estimate: f, x0, y0, k1, k2, k3, p1, p2, b1, b2.
    #[serde(default)]
    pub self_calibrate: Vec<String>,
}

fn default_sigma_px() -> f64 {
    0.5
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImagesSection {
    /// CSV `image[,camera][,strip][,azimuth,elevation,roll]`.
    pub list: PathBuf,
    /// CSV `image,point,x_px,y_px[,sigma_px]`.
    #[serde(default)]
    pub measurements: Option<PathBuf>,
    /// PATB-style image coordinates (mm): a photo id line, `point x y` lines, `-99`.
    #[serde(default)]
    pub patb: Option<PathBuf>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GroundSection {
    /// CSV `point,kind,…coordinates…,sigma_xy,sigma_z` with lat/lon/h, x/y/z (ECEF) or
    /// easting/northing/h (then `crs`).
    pub file: PathBuf,
    #[serde(default)]
    pub crs: Option<String>,
    /// Control points to use as check points instead.
    #[serde(default)]
    pub as_check: Vec<String>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GnssSection {
    /// The antenna table of `ppkat exposures --format antenna`.
    pub antennas: PathBuf,
    /// Multiplier of the trajectory σ (default 1).
    #[serde(default = "one")]
    pub sigma_scale: f64,
    /// Lever arm (u, v, w) in the camera frame, metres: the start value, and the prior when
    /// `lever_arm_sigma` is given.
    #[serde(default)]
    pub lever_arm: [f64; 3],
    #[serde(default)]
    pub lever_arm_sigma: Option<[f64; 3]>,
    #[serde(default = "yes")]
    pub estimate_lever_arm: bool,
    /// none, block, strip or segment.
    #[serde(default)]
    pub drift: DriftGroup,
    #[serde(default = "default_drift_model")]
    pub drift_model: DriftModel,
}

fn one() -> f64 {
    1.0
}
fn yes() -> bool {
    true
}
fn default_drift_model() -> DriftModel {
    DriftModel::Linear
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum DriftGroup {
    #[default]
    None,
    Block,
    Strip,
    Segment,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AdjustmentSection {
    #[serde(default = "default_iterations")]
    pub max_iterations: usize,
    #[serde(default = "yes")]
    pub snooping: bool,
    /// Family-wise error rate of data snooping (Bonferroni over all tests).
    #[serde(default = "default_alpha")]
    pub alpha: f64,
    #[serde(default = "yes")]
    pub variance_components: bool,
    /// none, huber or cauchy (with data snooping, none is the usual choice).
    #[serde(default = "default_loss")]
    pub loss: String,
}

impl Default for AdjustmentSection {
    fn default() -> Self {
        AdjustmentSection {
            max_iterations: default_iterations(),
            snooping: true,
            alpha: default_alpha(),
            variance_components: true,
            loss: default_loss(),
        }
    }
}

fn default_iterations() -> usize {
    50
}
fn default_alpha() -> f64 {
    0.05
}
fn default_loss() -> String {
    "none".into()
}

/// A camera with its estimation choices.
#[derive(Clone, Debug)]
pub struct CameraDef {
    pub id: String,
    pub camera: Camera,
    /// Indices into the interior parameter order of `photo::camera`.
    pub calibrate: Vec<usize>,
    pub sigma_px: f64,
}

/// One image.
#[derive(Clone, Debug)]
pub struct ImageDef {
    pub id: String,
    pub camera: usize,
    pub strip: String,
    /// Approximate viewing direction from a compass: azimuth, elevation, roll (radians).
    pub compass: Option<[f64; 3]>,
}

/// One image measurement, metric image coordinates.
#[derive(Clone, Debug)]
pub struct Measurement {
    pub image: usize,
    pub point: String,
    pub xy: Vector2<f64>,
    /// σ in metres on the image (the camera's default when not given).
    pub sigma: f64,
    /// Where it came from (file:line), for the report.
    pub source: String,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum PointKind {
    Control,
    Check,
    Tie,
}

/// A ground point with known coordinates (control or check).
#[derive(Clone, Debug)]
pub struct GroundPoint {
    pub id: String,
    pub kind: PointKind,
    pub pos: Ecef,
    /// σ east, north, up, metres.
    pub sigma: [f64; 3],
    pub source: String,
}

/// A GNSS antenna position at an exposure.
#[derive(Clone, Debug)]
pub struct Antenna {
    pub image: String,
    pub time: Epoch,
    pub pos: Ecef,
    /// Covariance in the local ENU at the antenna, m².
    pub cov_enu: Matrix3<f64>,
    pub segment: u32,
    /// Camera → local ENU at the antenna, when the table carries an attitude.
    pub rotation: Option<Matrix3<f64>>,
}

/// A loaded project.
#[derive(Clone, Debug)]
pub struct Project {
    pub path: PathBuf,
    pub file: ProjectFile,
    pub output: Projection,
    pub cameras: Vec<CameraDef>,
    pub images: Vec<ImageDef>,
    pub measurements: Vec<Measurement>,
    pub ground: Vec<GroundPoint>,
    pub antennas: Vec<Antenna>,
}

fn perr(path: &Path, what: impl Into<String>) -> AdjustError {
    AdjustError::Project {
        path: path.display().to_string(),
        what: what.into(),
    }
}

/// A CSV table: header names, then rows with their line numbers (comments `#` skipped).
struct Table {
    path: PathBuf,
    cols: Vec<String>,
    rows: Vec<(usize, Vec<String>)>,
}

impl Table {
    fn read(path: &Path) -> Result<Table, AdjustError> {
        let text =
            std::fs::read_to_string(path).map_err(|e| perr(path, format!("cannot read: {e}")))?;
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
        let (_, head) = lines
            .next()
            .ok_or_else(|| perr(path, "empty table: a header line is needed"))?;
        let cols = head
            .split(',')
            .map(|c| c.trim().trim_start_matches('#').to_ascii_lowercase())
            .collect();
        let rows = lines.map(|(i, l)| (i + 1, split_csv(l))).collect();
        Ok(Table {
            path: path.to_path_buf(),
            cols,
            rows,
        })
    }
    fn col(&self, name: &str) -> Option<usize> {
        self.cols.iter().position(|c| c == name)
    }
    fn need(&self, name: &str) -> Result<usize, AdjustError> {
        self.col(name).ok_or_else(|| {
            perr(
                &self.path,
                format!("no `{name}` column (header: {})", self.cols.join(",")),
            )
        })
    }
    fn num(&self, line: usize, row: &[String], c: usize) -> Result<f64, AdjustError> {
        let s = row.get(c).map(|s| s.trim()).unwrap_or("");
        s.parse::<f64>().map_err(|_| AdjustError::Input {
            path: self.path.display().to_string(),
            line,
            what: format!("`{s}` is not a number (column {})", self.cols[c]),
        })
    }
    fn text(&self, row: &[String], c: usize) -> String {
        row.get(c).map(|s| s.trim().to_string()).unwrap_or_default()
    }
}

fn split_csv(l: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut quoted = false;
    for ch in l.chars() {
        match ch {
            '"' => quoted = !quoted,
            ',' if !quoted => out.push(std::mem::take(&mut cur)),
            c => cur.push(c),
        }
    }
    out.push(cur);
    out
}

const INTERIOR_NAMES: [&str; 10] = ["f", "x0", "y0", "k1", "k2", "k3", "p1", "p2", "b1", "b2"];

impl Project {
    /// Read the project file and every table it names.
    pub fn load(path: &Path) -> Result<Project, AdjustError> {
        let text =
            std::fs::read_to_string(path).map_err(|e| perr(path, format!("cannot read: {e}")))?;
        let file: ProjectFile = toml::from_str(&text).map_err(|e| perr(path, e.to_string()))?;
        let dir = path.parent().unwrap_or(Path::new("."));
        let output = Projection::parse(&file.output).ok_or_else(|| {
            perr(
                path,
                format!(
                    "output = \"{}\": use geodetic, utm, utm:ZONE or gk:CM",
                    file.output
                ),
            )
        })?;
        if file.camera.is_empty() {
            return Err(perr(path, "no [[camera]]: describe at least one camera"));
        }
        let mut cameras = Vec::new();
        for c in &file.camera {
            if !(c.focal_mm > 0.0 && c.pixel_um > 0.0 && c.width_px > 0 && c.height_px > 0) {
                return Err(perr(
                    path,
                    format!(
                        "camera {}: focal_mm, pixel_um, width_px and height_px must be positive",
                        c.id
                    ),
                ));
            }
            let mut cam = Camera::ideal(
                c.focal_mm * 1e-3,
                c.pixel_um * 1e-6,
                c.width_px,
                c.height_px,
            );
            cam.x0 = c.principal_point_mm[0] * 1e-3;
            cam.y0 = c.principal_point_mm[1] * 1e-3;
            cam.k = c.k;
            cam.p = c.p;
            let mut calibrate = Vec::new();
            for n in &c.self_calibrate {
                let i = INTERIOR_NAMES.iter().position(|x| x == n).ok_or_else(|| {
                    perr(
                        path,
                        format!(
                            "camera {}: self_calibrate `{n}`: use {}",
                            c.id,
                            INTERIOR_NAMES.join(", ")
                        ),
                    )
                })?;
                if !calibrate.contains(&i) {
                    calibrate.push(i);
                }
            }
            calibrate.sort();
            cameras.push(CameraDef {
                id: c.id.clone(),
                camera: cam,
                calibrate,
                sigma_px: c.sigma_px,
            });
        }
        let images = read_images(&dir.join(&file.images.list), &cameras)?;
        let index: BTreeMap<&str, usize> = images
            .iter()
            .enumerate()
            .map(|(i, im)| (im.id.as_str(), i))
            .collect();
        let measurements = match (&file.images.measurements, &file.images.patb) {
            (Some(m), None) => read_measurements(&dir.join(m), &index, &images, &cameras)?,
            (None, Some(p)) => read_patb(&dir.join(p), &index, &images, &cameras)?,
            _ => {
                return Err(perr(
                    path,
                    "[images]: give exactly one of `measurements` (CSV) or `patb`",
                ))
            }
        };
        let ground = match &file.ground {
            Some(g) => read_ground(&dir.join(&g.file), g)?,
            None => Vec::new(),
        };
        let antennas = match &file.gnss {
            Some(g) => read_antennas(&dir.join(&g.antennas), g.sigma_scale)?,
            None => Vec::new(),
        };
        Ok(Project {
            path: path.to_path_buf(),
            file,
            output,
            cameras,
            images,
            measurements,
            ground,
            antennas,
        })
    }
}

fn read_images(path: &Path, cameras: &[CameraDef]) -> Result<Vec<ImageDef>, AdjustError> {
    let t = Table::read(path)?;
    let ci = t.need("image")?;
    let cc = t.col("camera");
    let cs = t.col("strip");
    let compass = match (t.col("azimuth"), t.col("elevation"), t.col("roll")) {
        (Some(a), Some(e), Some(r)) => Some([a, e, r]),
        _ => None,
    };
    let mut out: Vec<ImageDef> = Vec::new();
    for (line, row) in &t.rows {
        let id = t.text(row, ci);
        let camera = match cc {
            Some(c) => {
                let name = t.text(row, c);
                cameras
                    .iter()
                    .position(|x| x.id == name)
                    .ok_or_else(|| AdjustError::Input {
                        path: path.display().to_string(),
                        line: *line,
                        what: format!("image {id}: unknown camera `{name}`"),
                    })?
            }
            None if cameras.len() == 1 => 0,
            None => return Err(perr(path, "several cameras: a `camera` column is needed")),
        };
        if out.iter().any(|x| x.id == id) {
            return Err(AdjustError::Input {
                path: path.display().to_string(),
                line: *line,
                what: format!("image {id} listed twice"),
            });
        }
        let compass = match compass {
            Some(c) => Some([
                t.num(*line, row, c[0])?.to_radians(),
                t.num(*line, row, c[1])?.to_radians(),
                t.num(*line, row, c[2])?.to_radians(),
            ]),
            None => None,
        };
        out.push(ImageDef {
            id,
            camera,
            strip: cs.map(|c| t.text(row, c)).unwrap_or_else(|| "1".into()),
            compass,
        });
    }
    if out.is_empty() {
        return Err(perr(path, "no images listed"));
    }
    Ok(out)
}

fn read_measurements(
    path: &Path,
    index: &BTreeMap<&str, usize>,
    images: &[ImageDef],
    cameras: &[CameraDef],
) -> Result<Vec<Measurement>, AdjustError> {
    let t = Table::read(path)?;
    let (ci, cp, cx, cy) = (
        t.need("image")?,
        t.need("point")?,
        t.need("x_px")?,
        t.need("y_px")?,
    );
    let cs = t.col("sigma_px");
    let mut out = Vec::new();
    for (line, row) in &t.rows {
        let im = t.text(row, ci);
        let &i = index.get(im.as_str()).ok_or_else(|| AdjustError::Input {
            path: path.display().to_string(),
            line: *line,
            what: format!("image `{im}` is not in the image list"),
        })?;
        let cam = &cameras[images[i].camera];
        let px = Vector2::new(t.num(*line, row, cx)?, t.num(*line, row, cy)?);
        let sigma_px = match cs {
            Some(c) if !t.text(row, c).is_empty() => t.num(*line, row, c)?,
            _ => cam.sigma_px,
        };
        out.push(Measurement {
            image: i,
            point: t.text(row, cp),
            xy: cam.camera.pixel_to_image(px),
            sigma: sigma_px * cam.camera.pixel,
            source: format!("{}:{line}", path.display()),
        });
    }
    Ok(out)
}

/// PATB-style image coordinates: a line with the photo id, then `point x y` in millimetres
/// (x right, y up, from the principal point's origin), closed by `-99`.
fn read_patb(
    path: &Path,
    index: &BTreeMap<&str, usize>,
    images: &[ImageDef],
    cameras: &[CameraDef],
) -> Result<Vec<Measurement>, AdjustError> {
    let text =
        std::fs::read_to_string(path).map_err(|e| perr(path, format!("cannot read: {e}")))?;
    let bad = |line: usize, what: String| AdjustError::Input {
        path: path.display().to_string(),
        line,
        what,
    };
    let mut out = Vec::new();
    let mut current: Option<usize> = None;
    for (n, l) in text.lines().enumerate() {
        let line = n + 1;
        let f: Vec<&str> = l.split_whitespace().collect();
        match (current, f.as_slice()) {
            (_, []) => {}
            (_, ["-99", ..]) => current = None,
            (None, [id, ..]) => {
                current =
                    Some(*index.get(id).ok_or_else(|| {
                        bad(line, format!("photo `{id}` is not in the image list"))
                    })?)
            }
            (Some(i), [p, x, y, ..]) => {
                let num = |s: &str| {
                    s.parse::<f64>()
                        .map_err(|_| bad(line, format!("`{s}` is not a number")))
                };
                let cam = &cameras[images[i].camera];
                out.push(Measurement {
                    image: i,
                    point: p.to_string(),
                    xy: Vector2::new(num(x)? * 1e-3, num(y)? * 1e-3),
                    sigma: cam.sigma_px * cam.camera.pixel,
                    source: format!("{}:{line}", path.display()),
                });
            }
            (Some(_), _) => {
                return Err(bad(line, "expected `point x y` (mm) or -99".into()));
            }
        }
    }
    Ok(out)
}

fn read_ground(path: &Path, g: &GroundSection) -> Result<Vec<GroundPoint>, AdjustError> {
    let t = Table::read(path)?;
    let (cp, ck) = (t.need("point")?, t.need("kind")?);
    enum Coords {
        Geo(usize, usize, usize),
        Xyz(usize, usize, usize),
        Proj(usize, usize, usize),
    }
    let lat = t.col("lat").or(t.col("lat_deg"));
    let lon = t.col("lon").or(t.col("lon_deg"));
    let coords = if let (Some(a), Some(b), Some(c)) = (lat, lon, t.col("h")) {
        Coords::Geo(a, b, c)
    } else if let (Some(a), Some(b), Some(c)) = (t.col("x"), t.col("y"), t.col("z")) {
        Coords::Xyz(a, b, c)
    } else if let (Some(a), Some(b), Some(c)) = (t.col("easting"), t.col("northing"), t.col("h")) {
        Coords::Proj(a, b, c)
    } else {
        return Err(perr(path, "coordinates: give lat,lon,h or x,y,z (ECEF) or easting,northing,h (with crs in [ground])"));
    };
    let tm = match (&coords, &g.crs) {
        (Coords::Proj(..), Some(c)) => {
            let p = Projection::parse(c)
                .ok_or_else(|| perr(path, format!("crs `{c}`: use utm:ZONE or gk:CM")))?;
            match p {
                Projection::Utm(None) | Projection::Geodetic => {
                    return Err(perr(path, "crs: give the UTM zone (utm:ZONE) or gk:CM"))
                }
                _ => {
                    let lat = if c.ends_with(['S', 's']) { -1.0 } else { 1.0 };
                    p.mercator(&Geodetic::from_degrees(lat, 0.0, 0.0))
                }
            }
        }
        (Coords::Proj(..), None) => {
            return Err(perr(
                path,
                "easting/northing columns need `crs` in [ground]",
            ))
        }
        _ => None,
    };
    let sig = |row: &[String], line: usize| -> Result<[f64; 3], AdjustError> {
        if let (Some(a), Some(b)) = (t.col("sigma_xy"), t.col("sigma_z")) {
            let (h, v) = (t.num(line, row, a)?, t.num(line, row, b)?);
            return Ok([h, h, v]);
        }
        if let (Some(a), Some(b), Some(c)) = (t.col("sigma_e"), t.col("sigma_n"), t.col("sigma_u"))
        {
            return Ok([
                t.num(line, row, a)?,
                t.num(line, row, b)?,
                t.num(line, row, c)?,
            ]);
        }
        Ok([0.02, 0.02, 0.03])
    };
    let mut out = Vec::new();
    for (line, row) in &t.rows {
        let id = t.text(row, cp);
        let kind = match t.text(row, ck).to_ascii_lowercase().as_str() {
            "gcp" | "control" => PointKind::Control,
            "check" => PointKind::Check,
            "tie" => continue,
            k => {
                return Err(AdjustError::Input {
                    path: path.display().to_string(),
                    line: *line,
                    what: format!("point {id}: kind `{k}`: use gcp, check or tie"),
                })
            }
        };
        let kind = if kind == PointKind::Control && g.as_check.contains(&id) {
            PointKind::Check
        } else {
            kind
        };
        let pos = match coords {
            Coords::Geo(a, b, c) => Geodetic::from_degrees(
                t.num(*line, row, a)?,
                t.num(*line, row, b)?,
                t.num(*line, row, c)?,
            )
            .to_ecef(),
            Coords::Xyz(a, b, c) => Ecef::new(
                t.num(*line, row, a)?,
                t.num(*line, row, b)?,
                t.num(*line, row, c)?,
            ),
            Coords::Proj(a, b, c) => {
                let (tm, _) = tm.as_ref().ok_or_else(|| perr(path, "crs missing"))?;
                let p = gnss::tmerc::Projected {
                    easting: t.num(*line, row, a)?,
                    northing: t.num(*line, row, b)?,
                };
                tm.inverse(&p, t.num(*line, row, c)?).to_ecef()
            }
        };
        let sigma = sig(row, *line)?;
        if sigma.iter().any(|s| s.is_nan() || *s <= 0.0) && kind == PointKind::Control {
            return Err(AdjustError::Input {
                path: path.display().to_string(),
                line: *line,
                what: format!("control point {id}: σ must be positive"),
            });
        }
        if out.iter().any(|p: &GroundPoint| p.id == id) {
            return Err(AdjustError::Input {
                path: path.display().to_string(),
                line: *line,
                what: format!("point {id} listed twice"),
            });
        }
        out.push(GroundPoint {
            id,
            kind,
            pos,
            sigma,
            source: format!("{}:{line}", path.display()),
        });
    }
    Ok(out)
}

fn read_antennas(path: &Path, scale: f64) -> Result<Vec<Antenna>, AdjustError> {
    let t = Table::read(path)?;
    let need: Vec<usize> = [
        "id", "week", "tow", "lat", "lon", "h", "c_ee", "c_en", "c_eu", "c_nn", "c_nu", "c_uu",
    ]
    .iter()
    .map(|c| t.need(c))
    .collect::<Result<_, _>>()?;
    let seg = t.col("segment");
    let opk = match (t.col("omega"), t.col("phi"), t.col("kappa")) {
        (Some(a), Some(b), Some(c)) => Some([a, b, c]),
        _ => None,
    };
    let mut out = Vec::new();
    for (line, row) in &t.rows {
        let v: Vec<f64> = need[1..]
            .iter()
            .map(|&c| t.num(*line, row, c))
            .collect::<Result<_, _>>()?;
        let cov =
            Matrix3::new(v[5], v[6], v[7], v[6], v[8], v[9], v[7], v[9], v[10]) * (scale * scale);
        if cov.cholesky().is_none() {
            return Err(AdjustError::Input {
                path: path.display().to_string(),
                line: *line,
                what: "the covariance is not positive definite".into(),
            });
        }
        let rotation = match opk {
            Some(c) => Some(
                photo::rotation::Angles::OmegaPhiKappa {
                    omega: t.num(*line, row, c[0])?.to_radians(),
                    phi: t.num(*line, row, c[1])?.to_radians(),
                    kappa: t.num(*line, row, c[2])?.to_radians(),
                }
                .matrix(),
            ),
            None => None,
        };
        out.push(Antenna {
            image: t.text(row, need[0]),
            time: gnss::time::from_week_tow(v[0] as u32, v[1]),
            pos: Geodetic::from_degrees(v[2], v[3], v[4]).to_ecef(),
            cov_enu: cov,
            segment: match seg {
                Some(c) => t.num(*line, row, c)? as u32,
                None => 0,
            },
            rotation,
        });
    }
    Ok(out)
}
