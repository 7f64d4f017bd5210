//! The Earth the mechanisation moves on: WGS84 normal gravity (Somigliana's formula with the
//! second-order height term and the small northward component above the ellipsoid) and the
//! Earth's rotation. The simulator makes its IMU data with the same functions, so that a
//! perfect IMU mechanised here follows the truth.

use common::frame::{enu_rotation, Ecef, Geodetic, OMEGA_E, WGS84_A, WGS84_F};
use nalgebra::Vector3;

/// WGS84 normal gravity on the equator, m/s².
const GAMMA_E: f64 = 9.780_325_335_9;
/// Somigliana's constant k = (b·γ_p)/(a·γ_e) − 1.
const SOMIGLIANA_K: f64 = 0.001_931_852_652_41;
/// m = ω²a²b/GM.
const M: f64 = 0.003_449_786_506_84;
/// WGS84 first eccentricity squared.
const E2: f64 = common::frame::WGS84_E2;

/// Magnitude of normal gravity (gravitation and centrifugal), m/s², at a geodetic position.
pub fn normal_gravity(g: &Geodetic) -> f64 {
    let s2 = g.lat.sin().powi(2);
    let surface = GAMMA_E * (1.0 + SOMIGLIANA_K * s2) / (1.0 - E2 * s2).sqrt();
    let h = g.h;
    surface
        * (1.0 - 2.0 / WGS84_A * (1.0 + WGS84_F + M - 2.0 * WGS84_F * s2) * h
            + 3.0 * h * h / (WGS84_A * WGS84_A))
}

/// Normal gravity as an ECEF vector at `r` (m/s²): down the ellipsoid's normal, with the
/// −8.08·10⁻⁹·h·sin 2φ m/s² northward part it has above the ellipsoid (Groves, eq. 2.140).
pub fn gravity_ecef(r: &Ecef) -> Vector3<f64> {
    gravity_at(&r.to_geodetic())
}

/// [`gravity_ecef`] at a position given by its geodetic coordinates.
pub fn gravity_at(geo: &Geodetic) -> Vector3<f64> {
    let rot = enu_rotation(geo);
    let north = rot.row(1).transpose();
    let up = rot.row(2).transpose();
    let north_part = -8.08e-9 * geo.h * (2.0 * geo.lat).sin();
    -normal_gravity(geo) * up + north_part * north
}

/// The Earth's rotation rate as an ECEF vector, rad/s.
pub fn earth_rate() -> Vector3<f64> {
    Vector3::new(0.0, 0.0, OMEGA_E)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Published WGS84 normal gravity: 9.7803253359 m/s² on the equator, 9.8321849379 m/s² at
    /// the poles (NIMA TR8350.2, table 3.4); the free-air gradient near the surface is about
    /// −3.086·10⁻⁶ s⁻².
    #[test]
    fn normal_gravity_matches_the_published_values() {
        let at = |lat_deg: f64, h: f64| {
            normal_gravity(&Geodetic {
                lat: lat_deg.to_radians(),
                lon: 0.0,
                h,
            })
        };
        assert!((at(0.0, 0.0) - 9.780_325_335_9).abs() < 1e-9);
        assert!((at(90.0, 0.0) - 9.832_184_937_9).abs() < 1e-8);
        let gradient = (at(45.0, 1000.0) - at(45.0, 0.0)) / 1000.0;
        assert!((gradient + 3.086e-6).abs() < 0.01e-6, "{gradient}");
    }

    /// The vector points down the ellipsoid's normal on the surface.
    #[test]
    fn gravity_points_down_the_normal() {
        let geo = Geodetic {
            lat: 0.7,
            lon: 0.2,
            h: 0.0,
        };
        let g = gravity_ecef(&geo.to_ecef());
        let up = enu_rotation(&geo).row(2).transpose();
        assert!((g.normalize() + up).norm() < 1e-9);
    }
}
