//! The site's east-north-up frame of a simulated flight, where the flight, the base and the
//! ground are built.
//!
//! What enters: the scenario's site (geodetic degrees, ellipsoidal metres). What leaves:
//! [`SiteFrame`], turning ENU vectors (metres) into ECEF.

use super::scenario::Scenario;
use gnss::frame::{Ecef, Enu, Geodetic};
use nalgebra::Vector3;

/// The site's east-north-up frame: its geodetic origin (on the terrain) and the conversion
/// of ENU vectors (metres) to ECEF.
pub(super) struct SiteFrame {
    /// Geodetic origin of the frame, on the terrain.
    pub(super) geo: Geodetic,
    /// The origin in ECEF.
    ecef: Ecef,
}

impl SiteFrame {
    /// The frame at the scenario's site.
    pub(super) fn of(s: &Scenario) -> SiteFrame {
        let geo = Geodetic::from_degrees(s.site.lat_deg, s.site.lon_deg, s.site.ground_height);
        SiteFrame {
            geo,
            ecef: geo.to_ecef(),
        }
    }

    /// ECEF of an ENU vector (metres) of the frame.
    pub(super) fn to_ecef(&self, v: &Vector3<f64>) -> Ecef {
        Enu(*v).to_ecef(&self.ecef)
    }
}
