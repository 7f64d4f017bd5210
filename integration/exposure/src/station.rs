//! A camera station ([`CameraStation`]): the projection centre of one exposure, as the
//! exposure stage computes it and the exports, the geotagging and the adjustment read it.

use gnss::frame::Ecef;
use gnss::solution::Quality;
use hifitime::Epoch;
use nalgebra::{Matrix3, Vector3};

/// Where a station's attitude came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AttitudeSource {
    /// From the attitude table.
    Table,
    /// Trajectory heading, zero pitch and roll (flagged).
    Heading,
}

/// A camera station: the projection centre of one exposure.
#[derive(Clone, Debug)]
pub struct CameraStation {
    /// Name: the photo's file name, a names file's line, `DJI_NNNN`, a CSV id or `E0001`
    /// (see [`super::names`]).
    pub id: String,
    /// Exposure time (event time plus delay), GPST.
    pub time: Epoch,
    /// Antenna position interpolated on the trajectory, ECEF.
    pub antenna: Ecef,
    /// Antenna velocity, ECEF, m/s: the derivative of the interpolation, which takes the
    /// trajectory's velocities or, when it has none (a PPK `.pos`), central differences of
    /// the neighbouring epochs. `ppkat adjust` needs it to estimate a GNSS latency.
    pub velocity: Vector3<f64>,
    /// Projection centre, ECEF (antenna minus the rotated lever arm).
    pub centre: Ecef,
    /// ECEF covariance of the centre, m² (from the trajectory).
    pub cov: Matrix3<f64>,
    /// Worst trajectory quality around the exposure.
    pub quality: Quality,
    /// Ambiguity segment of the trajectory at the exposure (for drift per segment).
    pub segment: u32,
    /// Camera → ENU at the station.
    pub rotation: Matrix3<f64>,
    /// Where the rotation came from.
    pub attitude: AttitudeSource,
    /// σ of the rotation about the camera's x, y, z (radians), when its source gives them
    /// (`exposures --ins`).
    pub rotation_sigma: Option<[f64; 3]>,
    /// What a user should look at (float neighbours, heading attitude, no lever arm).
    pub flags: Vec<String>,
}
