//! What a project's tables hold once read: cameras with their estimation choices, images,
//! image measurements, ground points, GNSS antenna positions. Plain values: the tables
//! (`tables`) produce them, the project (`project`) holds them, the adjustment reads them.

use super::error::AdjustError;
use gnss::frame::Ecef;
use hifitime::Epoch;
use nalgebra::{Matrix3, Vector2, Vector3};
use photo::camera::Camera;
use std::path::Path;

/// An error about a project file or table (the file named).
pub(super) fn perr(path: &Path, what: impl Into<String>) -> AdjustError {
    AdjustError::Project {
        path: path.display().to_string(),
        what: what.into(),
    }
}

/// A camera with its estimation choices.
#[derive(Clone, Debug)]
pub struct CameraDef {
    /// The camera's id in the project.
    pub id: String,
    /// Its interior orientation (start values when self-calibrating).
    pub camera: Camera,
    /// Indices into the interior parameter order of `photo::camera`.
    pub calibrate: Vec<usize>,
    /// Default image measurement σ, pixels.
    pub sigma_px: f64,
}

/// One image.
#[derive(Clone, Debug)]
pub struct ImageDef {
    /// The image's id.
    pub id: String,
    /// Index of its camera in the project's cameras.
    pub camera: usize,
    /// Its strip (for drift per strip and start attitudes).
    pub strip: String,
    /// Approximate viewing direction from a compass: azimuth, elevation, roll (radians).
    pub compass: Option<[f64; 3]>,
    /// Attitude from the list's `omega,phi,kappa` (radians; R camera → local ENU of the
    /// adjustment frame, R = Rω·Rφ·Rκ): an observation under `[attitude]`, a start value.
    pub opk: Option<[f64; 3]>,
    /// Exposure time (GPST), when the list gives `week,tow`.
    pub time: Option<hifitime::Epoch>,
}

/// One image measurement, metric image coordinates.
#[derive(Clone, Debug)]
pub struct Measurement {
    /// Index of the image in the project's images.
    pub image: usize,
    /// The point's id.
    pub point: String,
    /// Image coordinates (metres, origin at the image centre, x right, y up).
    pub xy: Vector2<f64>,
    /// σ in metres on the image (the camera's default when not given).
    pub sigma: f64,
    /// Where it came from (file:line), for the report.
    pub source: String,
}

/// What a ground point is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum PointKind {
    /// Control: its coordinates are observations of the adjustment.
    Control,
    /// Check: never in the adjustment; intersected from the adjusted orientations afterwards
    /// and compared with its coordinates.
    Check,
    /// Tie: no known coordinates.
    Tie,
}

/// A ground point with known coordinates (control or check).
#[derive(Clone, Debug)]
pub struct GroundPoint {
    /// The point's id.
    pub id: String,
    /// Control or check.
    pub kind: PointKind,
    /// Its position.
    pub pos: Ecef,
    /// σ east, north, up, metres.
    pub sigma: [f64; 3],
    /// The axes a control point fixes: east, north, up.
    pub axes: ControlAxes,
    /// Where it came from (file:line).
    pub source: String,
}

/// Which coordinates of a control point are observations.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ControlAxes {
    /// East, north and up (`gcp`).
    #[default]
    All,
    /// East and north only (`gcp-xy`, planimetric).
    Horizontal,
    /// Up only (`gcp-z`, a height).
    Height,
}

impl ControlAxes {
    /// The observed components (0 east, 1 north, 2 up).
    pub fn indices(self) -> &'static [usize] {
        match self {
            ControlAxes::All => &[0, 1, 2],
            ControlAxes::Horizontal => &[0, 1],
            ControlAxes::Height => &[2],
        }
    }
}

/// A GNSS antenna position at an exposure.
#[derive(Clone, Debug)]
pub struct Antenna {
    /// The image whose exposure it belongs to.
    pub image: String,
    /// Exposure time (GPST).
    pub time: Epoch,
    /// Antenna phase centre position.
    pub pos: Ecef,
    /// Covariance in the local ENU at the antenna, m².
    pub cov_enu: Matrix3<f64>,
    /// Ambiguity segment of the trajectory at the exposure.
    pub segment: u32,
    /// Solution quality as RTKLIB's Q (1 fixed, 2 float, 5 single).
    pub quality: u8,
    /// Camera → local ENU at the antenna, when the table carries an attitude.
    pub rotation: Option<Matrix3<f64>>,
    /// σ of that attitude about the camera's x, y, z axes (radians), when the table carries
    /// `sd_omega,sd_phi,sd_kappa` (degrees): it wins over the `[attitude]` section's
    /// `sigma_deg`.
    pub rotation_sigma: Option<Vector3<f64>>,
    /// Antenna velocity in the local ENU at the antenna (m/s), when the table carries one
    /// (`ve,vn,vu`) or the trajectory gives it: what a GNSS latency is linearised with.
    pub vel_enu: Option<Vector3<f64>>,
}

/// A measured distance between two points.
#[derive(Clone, Debug)]
pub struct MeasuredDistance {
    /// The two points' ids.
    pub points: [String; 2],
    /// The distance, metres.
    pub distance: f64,
    /// Its σ, metres.
    pub sigma: f64,
    /// Where it came from (file:line).
    pub source: String,
}
