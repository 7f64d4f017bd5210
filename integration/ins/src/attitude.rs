//! Attitude conventions. The body frame: x forward, y right, z down (as `docs/ARCHITECTURE.md`
//! states for an IMU). The local level frame: north, east, down at the body's position.
//! Roll φ, pitch θ and heading ψ give body → NED as C = Rz(ψ)·Ry(θ)·Rx(φ): heading from north
//! towards east, pitch nose up, roll right wing down.

use common::frame::{enu_rotation, Geodetic};
use nalgebra::Matrix3;

/// Roll, pitch and heading, radians.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Euler {
    /// Roll (about x), right wing down positive.
    pub roll: f64,
    /// Pitch (about y), nose up positive.
    pub pitch: f64,
    /// Heading (about z, down), from north towards east.
    pub heading: f64,
}

impl Euler {
    /// The body → NED rotation matrix.
    pub fn to_matrix(&self) -> Matrix3<f64> {
        let (sr, cr) = self.roll.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        let (sh, ch) = self.heading.sin_cos();
        let rz = Matrix3::new(ch, -sh, 0.0, sh, ch, 0.0, 0.0, 0.0, 1.0);
        let ry = Matrix3::new(cp, 0.0, sp, 0.0, 1.0, 0.0, -sp, 0.0, cp);
        let rx = Matrix3::new(1.0, 0.0, 0.0, 0.0, cr, -sr, 0.0, sr, cr);
        rz * ry * rx
    }

    /// The angles of a body → NED rotation matrix; heading in [0, 2π).
    pub fn from_matrix(c: &Matrix3<f64>) -> Euler {
        let pitch = (-c[(2, 0)]).clamp(-1.0, 1.0).asin();
        let roll = c[(2, 1)].atan2(c[(2, 2)]);
        let heading = c[(1, 0)].atan2(c[(0, 0)]).rem_euclid(std::f64::consts::TAU);
        Euler {
            roll,
            pitch,
            heading,
        }
    }
}

/// The NED frame at a geodetic position in ECEF: NED → ECEF (columns north, east, down).
pub fn ned_to_ecef(g: &Geodetic) -> Matrix3<f64> {
    let enu = enu_rotation(g);
    Matrix3::from_columns(&[
        enu.row(1).transpose(),
        enu.row(0).transpose(),
        -enu.row(2).transpose(),
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn angles_survive_the_matrix_and_mean_what_they_say() {
        let e = Euler {
            roll: 0.3,
            pitch: -0.2,
            heading: 5.9,
        };
        let back = Euler::from_matrix(&e.to_matrix());
        assert!((back.roll - 0.3).abs() < 1e-12);
        assert!((back.pitch + 0.2).abs() < 1e-12);
        assert!((back.heading - 5.9).abs() < 1e-12);
        // Heading 90°: the nose (body x) points east.
        let east = Euler {
            roll: 0.0,
            pitch: 0.0,
            heading: std::f64::consts::FRAC_PI_2,
        };
        let nose = east.to_matrix() * nalgebra::Vector3::x();
        assert!((nose - nalgebra::Vector3::y()).norm() < 1e-12);
        // Pitch up: the nose has a negative down component.
        let up = Euler {
            roll: 0.0,
            pitch: 0.1,
            heading: 0.0,
        };
        assert!((up.to_matrix() * nalgebra::Vector3::x()).z < 0.0);
        // Roll right: the right wing (body y) goes down.
        let right = Euler {
            roll: 0.1,
            pitch: 0.0,
            heading: 0.0,
        };
        assert!((right.to_matrix() * nalgebra::Vector3::y()).z > 0.0);
    }

    #[test]
    fn ned_is_orthonormal_and_down_is_down() {
        let g = Geodetic {
            lat: 0.8,
            lon: -1.2,
            h: 300.0,
        };
        let c = ned_to_ecef(&g);
        assert!((c.transpose() * c - Matrix3::identity()).norm() < 1e-12);
        assert!((c.determinant() - 1.0).abs() < 1e-12);
        let up_ecef = g.to_ecef().0.normalize();
        assert!(c.column(2).dot(&up_ecef) < -0.99);
    }
}
