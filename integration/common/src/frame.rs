//! Terrestrial frames: WGS84 ECEF, geodetic coordinates and local east-north-up.

use nalgebra::{Matrix3, Vector3};

/// WGS84 semi-major axis (m).
pub const WGS84_A: f64 = 6_378_137.0;
/// WGS84 flattening.
pub const WGS84_F: f64 = 1.0 / 298.257_223_563;
/// WGS84 first eccentricity squared.
pub const WGS84_E2: f64 = WGS84_F * (2.0 - WGS84_F);

/// WGS84 rotation rate of the Earth, rad/s (the value GPS broadcasts, IS-GPS-200).
pub const OMEGA_E: f64 = 7.292_115_146_7e-5;

/// A satellite position `sat` (ECEF of the transmission time, metres) expressed in the ECEF
/// frame of the reception time, `tau` seconds of signal travel later: the Earth has turned by
/// `OMEGA_E·tau` about z meanwhile (the Sagnac correction). Also rotates velocities.
pub fn rotate_to_reception(sat: &Vector3<f64>, tau: f64) -> Vector3<f64> {
    let (s, c) = (OMEGA_E * tau).sin_cos();
    Vector3::new(c * sat.x + s * sat.y, -s * sat.x + c * sat.y, sat.z)
}

/// Earth-centred, Earth-fixed Cartesian position in WGS84, metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ecef(pub Vector3<f64>);

/// Geodetic coordinates on WGS84: latitude and longitude in radians, ellipsoidal height in metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Geodetic {
    /// Latitude, radians.
    pub lat: f64,
    /// Longitude, radians.
    pub lon: f64,
    /// Ellipsoidal height, metres.
    pub h: f64,
}

/// A vector in the local east-north-up frame of some origin, metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Enu(pub Vector3<f64>);

impl Ecef {
    /// A point from its ECEF coordinates, metres.
    pub fn new(x: f64, y: f64, z: f64) -> Self {
        Ecef(Vector3::new(x, y, z))
    }

    /// Geodetic coordinates (iterative, converges to well below a micrometre).
    pub fn to_geodetic(&self) -> Geodetic {
        let (x, y, z) = (self.0.x, self.0.y, self.0.z);
        let p2 = x * x + y * y;
        let p = p2.sqrt();
        if p < 1e-9 && z.abs() < 1e-9 {
            return Geodetic {
                lat: 0.0,
                lon: 0.0,
                h: -WGS84_A,
            };
        }
        let mut zk = z;
        let mut v = WGS84_A;
        for _ in 0..20 {
            let sinp = zk / (p2 + zk * zk).sqrt();
            v = WGS84_A / (1.0 - WGS84_E2 * sinp * sinp).sqrt();
            let znew = z + v * WGS84_E2 * sinp;
            if (znew - zk).abs() < 1e-6 {
                zk = znew;
                break;
            }
            zk = znew;
        }
        let lat = if p > 1e-12 {
            (zk / p).atan()
        } else if z > 0.0 {
            std::f64::consts::FRAC_PI_2
        } else {
            -std::f64::consts::FRAC_PI_2
        };
        let lon = if p2 > 1e-12 { y.atan2(x) } else { 0.0 };
        Geodetic {
            lat,
            lon,
            h: (p2 + zk * zk).sqrt() - v,
        }
    }

    /// The vector from `origin` to `self`, expressed in the ENU frame at `origin`.
    pub fn enu_from(&self, origin: &Ecef) -> Enu {
        let g = origin.to_geodetic();
        Enu(enu_rotation(&g) * (self.0 - origin.0))
    }

    /// Euclidean distance.
    pub fn distance(&self, other: &Ecef) -> f64 {
        (self.0 - other.0).norm()
    }
}

impl Geodetic {
    /// From degrees and metres (input/output convention).
    pub fn from_degrees(lat_deg: f64, lon_deg: f64, h: f64) -> Self {
        Geodetic {
            lat: lat_deg.to_radians(),
            lon: lon_deg.to_radians(),
            h,
        }
    }

    /// ECEF coordinates of this point.
    pub fn to_ecef(&self) -> Ecef {
        let (sl, cl) = self.lat.sin_cos();
        let (so, co) = self.lon.sin_cos();
        let v = WGS84_A / (1.0 - WGS84_E2 * sl * sl).sqrt();
        Ecef::new(
            (v + self.h) * cl * co,
            (v + self.h) * cl * so,
            (v * (1.0 - WGS84_E2) + self.h) * sl,
        )
    }
}

/// Rotation taking an ECEF difference vector into ENU at `g`.
pub fn enu_rotation(g: &Geodetic) -> Matrix3<f64> {
    let (sl, cl) = g.lat.sin_cos();
    let (so, co) = g.lon.sin_cos();
    Matrix3::new(-so, co, 0.0, -sl * co, -sl * so, cl, cl * co, cl * so, sl)
}

impl Enu {
    /// Point at `origin` + this ENU vector.
    pub fn to_ecef(&self, origin: &Ecef) -> Ecef {
        let r = enu_rotation(&origin.to_geodetic());
        Ecef(origin.0 + r.transpose() * self.0)
    }
    /// East component, metres.
    pub fn east(&self) -> f64 {
        self.0.x
    }
    /// North component, metres.
    pub fn north(&self) -> f64 {
        self.0.y
    }
    /// Up component, metres.
    pub fn up(&self) -> f64 {
        self.0.z
    }
    /// Horizontal length.
    pub fn horizontal(&self) -> f64 {
        self.0.x.hypot(self.0.y)
    }
}

/// Azimuth (from north, clockwise) and elevation, radians, of `target` seen from `receiver`.
/// `receiver_geo` is the receiver's geodetic position (passed in to avoid recomputing it).
pub fn az_el(receiver: &Ecef, receiver_geo: &Geodetic, target: &Ecef) -> (f64, f64) {
    let d = target.0 - receiver.0;
    let n = d.norm();
    if n < 1e-9 || receiver.0.norm() < 1.0 {
        return (0.0, std::f64::consts::FRAC_PI_2);
    }
    let e = enu_rotation(receiver_geo) * d / n;
    let az = e.x.atan2(e.y);
    let az = if az < 0.0 {
        az + 2.0 * std::f64::consts::PI
    } else {
        az
    };
    (az, e.z.clamp(-1.0, 1.0).asin())
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn geodetic_round_trip_and_enu() {
        let p = Ecef::new(3582105.2910, 532589.7313, 5232754.8054);
        let g = p.to_geodetic();
        let q = g.to_ecef();
        assert!((p.0 - q.0).norm() < 1e-6);
        // ESBC lies at about 55.49 N, 8.46 E.
        assert!(
            (g.lat.to_degrees() - 55.4927).abs() < 1e-3,
            "{}",
            g.lat.to_degrees()
        );
        assert!((g.lon.to_degrees() - 8.4569).abs() < 1e-3);
        let up = Geodetic { h: g.h + 10.0, ..g }.to_ecef();
        let enu = up.enu_from(&p);
        assert!((enu.up() - 10.0).abs() < 1e-6 && enu.horizontal() < 1e-6);
        assert!((enu.to_ecef(&p).0 - up.0).norm() < 1e-6);
        let (_, el) = az_el(&p, &g, &up);
        assert!((el - std::f64::consts::FRAC_PI_2).abs() < 1e-6);
    }
}
