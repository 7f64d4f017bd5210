//! The project file (TOML) of `ppkat adjust` and the tables it names: cameras, the image list,
//! image measurements (CSV or PATB), ground points (control, check) and the GNSS input: the
//! antenna table written by `ppkat exposures --format antenna`, or a `.pos` trajectory read
//! into a `gnss::trajectory::Trajectory` and interpolated at the image times. Paths are
//! relative to the project file.
//! Every problem names the file, the line and what to do.

use super::camera_section::camera_def;
pub use super::camera_section::CameraSection;
use super::error::AdjustError;
use super::factors::DriftModel;
use super::input::perr;
pub use super::input::{
    Antenna, CameraDef, GroundPoint, ImageDef, MeasuredDistance, Measurement, PointKind,
};
pub use super::sections::LatencyGroup;
use super::start_file::{read_starts, StartPose};
use super::tables::{
    antennas_from_trajectory, read_antennas, read_distances, read_ground, read_images,
    read_measurements, read_patb, read_trajectory,
};
use exposure::export::Projection;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The TOML document.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProjectFile {
    /// A name for the reports.
    #[serde(default)]
    pub name: String,
    /// `aerial` (default) or `close-range`.
    #[serde(default)]
    pub mode: Mode,
    /// `geodetic`, `utm`, `utm:ZONE` or `gk:CM` for the outputs (default `utm`).
    #[serde(default = "default_output")]
    pub output: String,
    /// The cameras (`[[camera]]`).
    pub camera: Vec<CameraSection>,
    /// The image list and the image measurements.
    pub images: ImagesSection,
    /// Ground points (control, check) and measured distances.
    #[serde(default)]
    pub ground: Option<GroundSection>,
    /// GNSS antenna positions, lever arm and drift.
    #[serde(default)]
    pub gnss: Option<GnssSection>,
    /// Attitude observations at the exposures and the boresight.
    #[serde(default)]
    pub attitude: Option<super::sections::AttitudeSection>,
    /// Solver and statistics options.
    #[serde(default)]
    pub adjustment: AdjustmentSection,
    /// The datum when neither control nor GNSS gives one.
    #[serde(default)]
    pub datum: DatumSection,
}

/// The `[datum]` section.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DatumSection {
    /// A free network: with no control and no GNSS the block is adjusted under inner
    /// constraints over the image centres (no shift, rotation or scale of the centres from
    /// their start values, in the least-squares sense), so image residuals, relative
    /// precision and data snooping come out while the coordinates stay arbitrary; measured
    /// distances give the scale when there are any.
    #[serde(default)]
    pub free: bool,
}

fn default_output() -> String {
    "utm".into()
}

/// The kind of block.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Mode {
    /// Aerial: nadir images in strips.
    #[default]
    Aerial,
    /// Close range: terrestrial stations with compass angles.
    CloseRange,
}

/// The `[images]` section.
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
    /// Start orientations (`image,lat,lon,h,omega,phi,kappa`; see `start_file`), used before
    /// any other start value.
    #[serde(default)]
    pub start: Option<PathBuf>,
    /// How the camera sits on the aircraft, for start values from the flight direction: the
    /// angle (degrees, counter-clockwise seen from above) from the direction of flight to the
    /// camera's x axis (image columns). 0: x along the flight; 90: x to the left, across.
    #[serde(default)]
    pub kappa_deg: f64,
}

/// The `[ground]` section.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GroundSection {
    /// CSV `point,kind,…coordinates…,sigma_xy,sigma_z` with lat/lon/h, x/y/z (ECEF) or
    /// easting/northing/h (then `crs`).
    pub file: PathBuf,
    /// Projection of easting/northing columns: `utm:ZONE[N|S]` or `gk:CM`.
    #[serde(default)]
    pub crs: Option<String>,
    /// Control points to use as check points instead.
    #[serde(default)]
    pub as_check: Vec<String>,
    /// CSV `point_a,point_b,distance[,sigma]` of measured distances between points (m).
    #[serde(default)]
    pub distances: Option<PathBuf>,
}

/// The `[gnss]` section.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GnssSection {
    /// The antenna table of `ppkat exposures --format antenna`…
    #[serde(default)]
    pub antennas: Option<PathBuf>,
    /// …or a trajectory (`.pos` of `ppkat ppk` or RTKLIB) interpolated at the image times of
    /// the image list (`week,tow` columns, GPST).
    #[serde(default)]
    pub trajectory: Option<PathBuf>,
    /// Multiplier of the trajectory σ (default 1).
    #[serde(default = "one")]
    pub sigma_scale: f64,
    /// Lever arm (u, v, w) in the camera frame, metres: the start value, and the prior when
    /// `lever_arm_sigma` is given.
    #[serde(default)]
    pub lever_arm: [f64; 3],
    /// σ of the lever arm per component (m): a prior; absent: free.
    #[serde(default)]
    pub lever_arm_sigma: Option<[f64; 3]>,
    /// Estimate the lever arm (default); `false`: hold it fixed.
    #[serde(default = "yes")]
    pub estimate_lever_arm: bool,
    /// auto (default), none, block, strip or segment.
    #[serde(default)]
    pub drift: DriftGroup,
    /// offset, linear or rate (of block, strip and segment drifts; auto drifts are offsets).
    #[serde(default = "default_drift_model")]
    pub drift_model: DriftModel,
    /// GNSS latency δ (exposure time → GNSS time): none (default), block or flight; see
    /// [`super::latency`].
    #[serde(default)]
    pub latency: LatencyGroup,
    /// Prior σ of the latency, seconds; absent: free.
    #[serde(default)]
    pub latency_sigma: Option<f64>,
    /// Start value of the latency, and the prior's mean with `latency_sigma` (s, default 0).
    #[serde(default)]
    pub latency_start: f64,
    /// loose (default: the antenna positions of a trajectory) or tight (the double-difference
    /// carrier phase and code of `rover` and `base`, ambiguities resolved in the adjustment).
    #[serde(default)]
    pub coupling: Coupling,
    /// Tight coupling: the rover's observation file (RINEX or a raw log).
    #[serde(default)]
    pub rover: Option<PathBuf>,
    /// Tight coupling: the base's observation file.
    #[serde(default)]
    pub base: Option<PathBuf>,
    /// Tight coupling: navigation files (broadcast orbits).
    #[serde(default, deserialize_with = "one_or_many")]
    pub nav: Vec<PathBuf>,
    /// Tight coupling: the base antenna reference point, ECEF (m); absent: the base file's
    /// header position.
    #[serde(default)]
    pub base_position: Option<[f64; 3]>,
    /// Tight coupling: prior σ of each satellite's single-difference ionosphere per km of
    /// baseline, mm/km (ppm; default 2, half the PPK filter's epoch prior: one value holds a whole arc). The double-difference ionosphere
    /// of an arc is held by √2 times that, at least 5 mm; raise it on a disturbed day, or
    /// fixes may be wrong.
    #[serde(default = "two")]
    pub iono_ppm: f64,
}

/// How GNSS enters the adjustment.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Coupling {
    /// Antenna positions from a trajectory (today's PPK, then the adjustment).
    #[default]
    Loose,
    /// Double-difference carrier phase and code at every exposure, float ambiguities in the
    /// adjustment, resolved to integers there (see `adjust::tight`).
    Tight,
}

/// One path or a list of paths.
fn one_or_many<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<PathBuf>, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum OneOrMany {
        One(PathBuf),
        Many(Vec<PathBuf>),
    }
    Ok(match OneOrMany::deserialize(d)? {
        OneOrMany::One(p) => vec![p],
        OneOrMany::Many(v) => v,
    })
}

impl GnssSection {
    /// The lever arm given (start value), with its σ when it is a prior.
    pub fn lever_arm(&self) -> photo::lever::LeverArm {
        let l = photo::lever::LeverArm::new(nalgebra::Vector3::from(self.lever_arm));
        match self.lever_arm_sigma {
            Some(s) => l.with_sigma(nalgebra::Vector3::from(s)),
            None => l,
        }
    }
}

fn one() -> f64 {
    1.0
}
fn two() -> f64 {
    2.0
}
fn yes() -> bool {
    true
}
fn default_drift_model() -> DriftModel {
    DriftModel::Linear
}

/// Which antenna positions share a drift. A drift is the GNSS antenna position minus the
/// adjusted one (X_S + R·lever arm), in the adjustment frame (east, north, up at the block
/// centre).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum DriftGroup {
    /// Only where the GNSS needs it: none for antennas of fixed (Q = 1) trajectory
    /// segments; an offset per float or single-point segment, held by a prior whose σ per
    /// axis is the segment's own RMS trajectory σ (the common-mode error a float ambiguity
    /// leaves). Keeps the GNSS datum where the trajectory is fixed.
    #[default]
    Auto,
    /// No drift.
    None,
    /// One drift for the whole block.
    Block,
    /// One per strip.
    Strip,
    /// One free drift per ambiguity segment of the trajectory.
    Segment,
}

/// The `[adjustment]` section.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AdjustmentSection {
    /// Levenberg–Marquardt iterations per solve.
    #[serde(default = "default_iterations")]
    pub max_iterations: usize,
    /// Baarda data snooping with removal.
    #[serde(default = "yes")]
    pub snooping: bool,
    /// Family-wise error rate of data snooping (Bonferroni over all tests).
    #[serde(default = "default_alpha")]
    pub alpha: f64,
    /// Estimate a variance component per observation group.
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

/// A loaded project.
#[derive(Clone, Debug)]
pub struct Project {
    /// The project file.
    pub path: PathBuf,
    /// Its TOML document.
    pub file: ProjectFile,
    /// The output coordinates.
    pub output: Projection,
    /// The cameras.
    pub cameras: Vec<CameraDef>,
    /// The images.
    pub images: Vec<ImageDef>,
    /// The image measurements.
    pub measurements: Vec<Measurement>,
    /// The control and check points.
    pub ground: Vec<GroundPoint>,
    /// The GNSS antenna positions.
    pub antennas: Vec<Antenna>,
    /// Measured distances between points.
    pub distances: Vec<MeasuredDistance>,
    /// What loading noticed (images outside the trajectory, …), for the report.
    pub warnings: Vec<String>,
    /// Start orientations given by `[images] start`, by image index.
    pub starts: BTreeMap<usize, StartPose>,
}

impl Project {
    /// Read the project file and every table it names.
    pub fn load(path: &Path) -> Result<Project, AdjustError> {
        let text =
            std::fs::read_to_string(path).map_err(|e| perr(path, format!("cannot read: {e}")))?;
        let file: ProjectFile = toml::from_str(&text).map_err(|e| perr(path, e.to_string()))?;
        let dir = path.parent().unwrap_or(Path::new("."));
        let output = Projection::parse(&file.output)
            .filter(|p| !matches!(p, Projection::Epsg(_)))
            .ok_or_else(|| {
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
        let cameras = file
            .camera
            .iter()
            .map(|c| camera_def(c, path))
            .collect::<Result<Vec<_>, _>>()?;
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
            Some(g) => read_ground(&dir.join(&g.file), g.crs.as_deref(), &g.as_check)?,
            None => Vec::new(),
        };
        let distances = match file.ground.as_ref().and_then(|g| g.distances.as_ref()) {
            Some(d) => read_distances(&dir.join(d))?,
            None => Vec::new(),
        };
        let mut warnings = Vec::new();
        let antennas = match &file.gnss {
            Some(g) => load_antennas(path, dir, g, &images, &mut warnings)?,
            None => Vec::new(),
        };
        let starts = match &file.images.start {
            Some(s) => read_starts(&dir.join(s), &images)?,
            None => BTreeMap::new(),
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
            distances,
            warnings,
            starts,
        })
    }
}

/// The GNSS antenna positions: the antenna table, or a trajectory interpolated at the image
/// times; a warning counts and names the positions that are not ambiguity-fixed.
fn load_antennas(
    path: &Path,
    dir: &Path,
    g: &GnssSection,
    images: &[ImageDef],
    warnings: &mut Vec<String>,
) -> Result<Vec<Antenna>, AdjustError> {
    let antennas = match (&g.antennas, &g.trajectory) {
        (Some(a), None) => read_antennas(&dir.join(a), g.sigma_scale)?,
        (None, Some(t)) => {
            let path = dir.join(t);
            let traj = read_trajectory(&path)?;
            antennas_from_trajectory(&traj, &path, images, g.sigma_scale, warnings)?
        }
        _ => {
            return Err(perr(
                path,
                "[gnss]: give exactly one of `antennas` (table) or `trajectory` (.pos)",
            ))
        }
    };
    let unfixed: Vec<&str> = antennas
        .iter()
        .filter(|a| a.quality != 1)
        .map(|a| a.image.as_str())
        .collect();
    if !unfixed.is_empty() && g.coupling == Coupling::Loose {
        warnings.push(format!(
            "{} of {} GNSS positions are not ambiguity-fixed (Q ≠ 1; first: {}): they enter with their larger covariance",
            unfixed.len(),
            antennas.len(),
            unfixed[..unfixed.len().min(5)].join(", ")
        ));
    }
    Ok(antennas)
}
