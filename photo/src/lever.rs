//! The GNSS lever arm: where the antenna phase centre A sits relative to the projection
//! centre S, in the camera frame. One convention everywhere (the house plan's):
//! `X_A = X_S + R·(u, v, w)ᵀ`, R the camera rotation (camera frame → the frame of the
//! positions). Exposures subtract it from interpolated antenna positions, the joint
//! adjustment observes it, the simulators add it.

use nalgebra::{Matrix3, Vector3};

/// How a lever arm is turned into the frame of the positions.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Applied {
    /// By the camera rotation R (camera → object frame): X_A = X_S + R·(u, v, w).
    #[default]
    CameraRotation,
}

/// A lever arm (u, v, w) in the camera frame, metres, with its σ when measured.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LeverArm {
    /// (u, v, w): the antenna phase centre in the camera frame.
    pub uvw: Vector3<f64>,
    /// σ of u, v, w when the lever arm was measured (a prior), `None` when not known.
    pub sigma: Option<Vector3<f64>>,
    /// The rotation it is applied with.
    pub applied: Applied,
}

impl LeverArm {
    /// A lever arm without a σ.
    pub fn new(uvw: Vector3<f64>) -> LeverArm {
        LeverArm {
            uvw,
            ..LeverArm::default()
        }
    }

    /// With σ per component.
    pub fn with_sigma(mut self, sigma: Vector3<f64>) -> LeverArm {
        self.sigma = Some(sigma);
        self
    }

    /// R·(u, v, w): the offset from projection centre to antenna in the frame of the positions.
    pub fn offset(&self, r: &Matrix3<f64>) -> Vector3<f64> {
        match self.applied {
            Applied::CameraRotation => r * self.uvw,
        }
    }

    /// The antenna from the projection centre: X_A = X_S + R·(u, v, w).
    pub fn antenna(&self, centre: &Vector3<f64>, r: &Matrix3<f64>) -> Vector3<f64> {
        centre + self.offset(r)
    }

    /// The projection centre from the antenna: X_S = X_A − R·(u, v, w).
    pub fn centre(&self, antenna: &Vector3<f64>, r: &Matrix3<f64>) -> Vector3<f64> {
        antenna - self.offset(r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rotation::Angles;

    #[test]
    fn antenna_and_centre_invert_each_other() {
        let r = Angles::OmegaPhiKappa {
            omega: 0.1,
            phi: -0.2,
            kappa: 2.0,
        }
        .matrix();
        let l = LeverArm::new(Vector3::new(0.12, -0.05, 1.45));
        let s = Vector3::new(10.0, 20.0, 1200.0);
        let a = l.antenna(&s, &r);
        assert!(((a - s).norm() - l.uvw.norm()).abs() < 1e-12);
        assert!((l.centre(&a, &r) - s).norm() < 1e-12);
        // A nadir camera (R = diag(1, −1, −1)) puts w below… no: w along the camera's −z, up.
        let nadir = Matrix3::new(1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0);
        let up = LeverArm::new(Vector3::new(0.0, 0.0, -1.0)).offset(&nadir);
        assert!((up - Vector3::new(0.0, 0.0, 1.0)).norm() < 1e-15);
    }
}
