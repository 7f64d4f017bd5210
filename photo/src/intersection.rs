//! Forward intersection: an object point from two or more image rays, by least squares on the
//! image residuals, with its covariance.

use crate::camera::{Camera, Pose};
use nalgebra::{Matrix3, Vector2, Vector3};

/// One ray: the camera, its exterior orientation, the measured image point and its sigma.
#[derive(Clone, Copy, Debug)]
pub struct Ray<'a> {
    /// The camera's interior orientation.
    pub camera: &'a Camera,
    /// Its exterior orientation.
    pub pose: &'a Pose,
    /// The measured image point (metres, image coordinates).
    pub xy: Vector2<f64>,
    /// Its σ (metres).
    pub sigma: f64,
}

/// An intersected point.
#[derive(Clone, Debug)]
pub struct Intersection {
    /// The point.
    pub point: Vector3<f64>,
    /// Its covariance (σ0² applied).
    pub cov: Matrix3<f64>,
    /// A posteriori sigma of unit weight (1 when there is no redundancy).
    pub sigma0: f64,
    /// Gauss–Newton iterations.
    pub iterations: usize,
}

/// Why a point cannot be intersected.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum IntersectError {
    /// Fewer than two rays.
    #[error("{0} ray(s): intersection needs at least two")]
    TooFewRays(usize),
    /// The rays do not determine the point.
    #[error("the rays are (nearly) parallel: the point is not determined")]
    Parallel,
    /// The point falls behind this camera (index of the ray).
    #[error("the point falls behind camera {0}")]
    BehindCamera(usize),
    /// Gauss–Newton did not converge.
    #[error("no convergence")]
    NoConvergence,
}

/// Intersect the rays.
pub fn intersect(rays: &[Ray]) -> Result<Intersection, IntersectError> {
    if rays.len() < 2 {
        return Err(IntersectError::TooFewRays(rays.len()));
    }
    // Start: the point closest to all rays (distortion ignored).
    let mut a = Matrix3::zeros();
    let mut b = Vector3::zeros();
    for r in rays {
        let d = (r.pose.r * Vector3::new(r.xy.x - r.camera.x0, r.xy.y - r.camera.y0, -r.camera.f))
            .normalize();
        let p = Matrix3::identity() - d * d.transpose();
        a += p;
        b += p * r.pose.centre;
    }
    let eig = a.symmetric_eigenvalues();
    if eig.min() < 1e-6 * eig.max() {
        return Err(IntersectError::Parallel);
    }
    let mut x = a.try_inverse().ok_or(IntersectError::Parallel)? * b;
    for it in 1..=20 {
        let mut n = Matrix3::zeros();
        let mut g = Vector3::zeros();
        let mut vtpv = 0.0;
        for (k, r) in rays.iter().enumerate() {
            let (p, j) = r
                .camera
                .project_with_jacobians(r.pose, &x)
                .ok_or(IntersectError::BehindCamera(k))?;
            let v = r.xy - p;
            let w = 1.0 / (r.sigma * r.sigma);
            n += j.point.transpose() * j.point * w;
            g += j.point.transpose() * v * w;
            vtpv += v.norm_squared() * w;
        }
        let ninv = n.try_inverse().ok_or(IntersectError::Parallel)?;
        let dx = ninv * g;
        x += dx;
        if dx.norm() < 1e-9 * (1.0 + x.norm()) {
            let dof = 2 * rays.len() - 3;
            let sigma0 = if dof > 0 {
                (vtpv / dof as f64).sqrt()
            } else {
                1.0
            };
            // Scaled by the a posteriori variance factor when there is redundancy.
            let scale = if dof > 0 { sigma0 * sigma0 } else { 1.0 };
            return Ok(Intersection {
                point: x,
                cov: ninv * scale,
                sigma0,
                iterations: it,
            });
        }
    }
    Err(IntersectError::NoConvergence)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rotation::Angles;

    #[test]
    fn recovers_a_point_within_its_own_precision() {
        let cam = Camera::ideal(0.035, 3.9e-6, 6000, 4000);
        let poses: Vec<Pose> = (0..4)
            .map(|k| Pose {
                r: Angles::OmegaPhiKappa {
                    omega: 0.01 * k as f64,
                    phi: -0.01,
                    kappa: 0.3,
                }
                .matrix(),
                centre: Vector3::new(60.0 * k as f64, 5.0 * k as f64, 350.0),
            })
            .collect();
        let truth = Vector3::new(95.0, 12.0, 4.0);
        let sigma = 3.9e-6; // one pixel
        let noise = [0.7, -1.1, 0.4, 0.9, -0.3, -0.8, 1.2, 0.1];
        let rays: Vec<Ray> = poses
            .iter()
            .enumerate()
            .map(|(k, p)| {
                let xy = cam.project(p, &truth).unwrap()
                    + Vector2::new(noise[2 * k], noise[2 * k + 1]) * sigma;
                Ray {
                    camera: &cam,
                    pose: p,
                    xy,
                    sigma,
                }
            })
            .collect();
        let s = intersect(&rays).unwrap();
        for k in 0..3 {
            let z = (s.point[k] - truth[k]) / s.cov[(k, k)].sqrt();
            assert!(
                z.abs() < 3.0,
                "axis {k}: {z} sigma ({} vs {})",
                s.point[k],
                truth[k]
            );
        }
        assert!(
            s.cov[(2, 2)].sqrt() < 0.5 && s.cov[(2, 2)].sqrt() > 0.01,
            "{}",
            s.cov[(2, 2)].sqrt()
        );
        assert_eq!(
            intersect(&rays[..1]).unwrap_err(),
            IntersectError::TooFewRays(1)
        );
        let same = [
            rays[0],
            Ray {
                xy: rays[0].xy,
                ..rays[0]
            },
        ];
        assert_eq!(intersect(&same).unwrap_err(), IntersectError::Parallel);
    }
}
