//! The local adjustment frame: an ENU tangent plane at a named origin (Z up), in which the
//! block is adjusted; conversions to and from ECEF and of ENU matrices at other points.

use gnss::frame::{enu_rotation, Ecef, Geodetic};
use nalgebra::{Matrix3, Vector3};

/// The local adjustment frame: ENU axes at `origin`.
#[derive(Clone, Debug)]
pub struct LocalFrame {
    /// The origin.
    pub origin: Ecef,
    /// The origin, geodetic.
    pub geodetic: Geodetic,
    /// ECEF → ENU.
    pub rot: Matrix3<f64>,
}

impl LocalFrame {
    /// The ENU frame at `g`.
    pub fn new(g: Geodetic) -> LocalFrame {
        LocalFrame {
            origin: g.to_ecef(),
            geodetic: g,
            rot: enu_rotation(&g),
        }
    }
    /// ECEF → local ENU coordinates (m).
    pub fn to_local(&self, p: &Ecef) -> Vector3<f64> {
        self.rot * (p.0 - self.origin.0)
    }
    /// Local ENU coordinates → ECEF.
    pub fn to_ecef(&self, v: &Vector3<f64>) -> Ecef {
        Ecef(self.origin.0 + self.rot.transpose() * v)
    }
    /// A matrix expressed in the ENU frame at `at` → the same in this frame.
    pub fn from_enu_at(&self, at: &Ecef) -> Matrix3<f64> {
        self.rot * enu_rotation(&at.to_geodetic()).transpose()
    }
}
