//! Interior orientation and the collinearity equations with analytic Jacobians.
//!
//! Image coordinates (x, y) are metric, origin at the image centre, x right, y up. With
//! R camera → object and projection centre S: v = Rᵀ(X − S), x_c = −f·v_x/v_z,
//! y_c = −f·v_y/v_z (the house convention), then Brown distortion and affinity evaluated at
//! the ideal point relative to the distortion centre: with d = (x_c, y_c) − (dx0, dy0),
//! x = x0 + x_c + Δx(d), y = y0 + y_c + Δy(d), where
//! Δx = d_x·(k1 r² + k2 r⁴ + k3 r⁶) + p1 (r² + 2 d_x²) + 2 p2 d_x d_y + b1 d_x + b2 d_y,
//! Δy = d_y·(k1 r² + k2 r⁴ + k3 r⁶) + p2 (r² + 2 d_y²) + 2 p1 d_x d_y, r = |d| (metres).
//! The distortion centre is held as an offset (dx0, dy0) from the principal point (zero by
//! default: distortion about the principal point); it moves with the principal point when
//! that is estimated, and is itself not estimated.
//! Conversions from MicMac and OpenCV/COLMAP models: [`crate::camera_convert`].

use crate::rotation::skew;
use nalgebra::{Matrix2, Matrix2x3, Matrix3, SMatrix, Vector2, Vector3};

/// Interior orientation: principal distance, principal point, Brown (k1–k3, p1, p2) and
/// affinity (b1, b2); plus the pixel grid for conversions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Principal distance (metres).
    pub f: f64,
    /// Principal point x (metres, image coordinates).
    pub x0: f64,
    /// Principal point y (metres, image coordinates).
    pub y0: f64,
    /// Radial distortion k1, k2, k3 (on radii in metres).
    pub k: [f64; 3],
    /// Decentring distortion p1, p2.
    pub p: [f64; 2],
    /// Affinity and shear b1, b2.
    pub b: [f64; 2],
    /// Distortion centre minus principal point (metres, image coordinates; zero by default).
    pub dc: [f64; 2],
    /// Pixel size (same unit as f).
    pub pixel: f64,
    /// Image width, pixels.
    pub width_px: usize,
    /// Image height, pixels.
    pub height_px: usize,
}

/// The 10 interior parameters in a fixed order: f, x0, y0, k1, k2, k3, p1, p2, b1, b2.
pub const N_INTERIOR: usize = 10;

/// An exterior orientation: rotation camera → object, projection centre.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Rotation camera → object frame.
    pub r: Matrix3<f64>,
    /// Projection centre in the object frame.
    pub centre: Vector3<f64>,
}

/// Jacobians of one projection: pose (δ rotation as a left perturbation R ← exp(δ)·R, then
/// the centre), object point, interior parameters.
#[derive(Clone, Copy, Debug)]
pub struct Jacobians {
    /// With respect to (δ rotation, centre).
    pub pose: SMatrix<f64, 2, 6>,
    /// With respect to the object point.
    pub point: Matrix2x3<f64>,
    /// With respect to f, x0, y0, k1, k2, k3, p1, p2, b1, b2.
    pub interior: SMatrix<f64, 2, N_INTERIOR>,
}

impl Camera {
    /// An ideal camera (no distortion).
    pub fn ideal(f: f64, pixel: f64, width_px: usize, height_px: usize) -> Camera {
        Camera {
            f,
            x0: 0.0,
            y0: 0.0,
            k: [0.0; 3],
            p: [0.0; 2],
            b: [0.0; 2],
            dc: [0.0; 2],
            pixel,
            width_px,
            height_px,
        }
    }

    /// Pixel (column right, row down, origin at the top-left corner) → image coordinates.
    pub fn pixel_to_image(&self, px: Vector2<f64>) -> Vector2<f64> {
        Vector2::new(
            (px.x - self.width_px as f64 / 2.0) * self.pixel,
            (self.height_px as f64 / 2.0 - px.y) * self.pixel,
        )
    }

    /// Image coordinates → pixel.
    pub fn image_to_pixel(&self, xy: Vector2<f64>) -> Vector2<f64> {
        Vector2::new(
            xy.x / self.pixel + self.width_px as f64 / 2.0,
            self.height_px as f64 / 2.0 - xy.y / self.pixel,
        )
    }

    /// Distortion Δ at an ideal point and its 2×2 derivative.
    fn distortion(&self, c: Vector2<f64>) -> (Vector2<f64>, Matrix2<f64>) {
        let (x, y) = (c.x, c.y);
        let r2 = x * x + y * y;
        let [k1, k2, k3] = self.k;
        let [p1, p2] = self.p;
        let [b1, b2] = self.b;
        let radial = k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2;
        let dr = 2.0 * (k1 + 2.0 * k2 * r2 + 3.0 * k3 * r2 * r2); // d radial / d(x or y) = dr·(x or y)
        let dx = x * radial + p1 * (r2 + 2.0 * x * x) + 2.0 * p2 * x * y + b1 * x + b2 * y;
        let dy = y * radial + p2 * (r2 + 2.0 * y * y) + 2.0 * p1 * x * y;
        let j = Matrix2::new(
            radial + x * dr * x + 6.0 * p1 * x + 2.0 * p2 * y + b1,
            x * dr * y + 2.0 * p1 * y + 2.0 * p2 * x + b2,
            y * dr * x + 2.0 * p2 * x + 2.0 * p1 * y,
            radial + y * dr * y + 6.0 * p2 * y + 2.0 * p1 * x,
        );
        (Vector2::new(dx, dy), j)
    }

    /// Project an object point; `None` behind the camera.
    pub fn project(&self, pose: &Pose, x: &Vector3<f64>) -> Option<Vector2<f64>> {
        self.project_with_jacobians(pose, x).map(|(p, _)| p)
    }

    /// Projection and its analytic Jacobians.
    pub fn project_with_jacobians(
        &self,
        pose: &Pose,
        x: &Vector3<f64>,
    ) -> Option<(Vector2<f64>, Jacobians)> {
        let d = x - pose.centre;
        let v = pose.r.transpose() * d;
        if v.z >= -1e-12 {
            return None;
        }
        let c = Vector2::new(-self.f * v.x / v.z, -self.f * v.y / v.z);
        let q = c - Vector2::new(self.dc[0], self.dc[1]);
        let (delta, dj) = self.distortion(q);
        let out = Vector2::new(self.x0, self.y0) + c + delta;
        let dc_dv = Matrix2x3::new(
            -self.f / v.z,
            0.0,
            self.f * v.x / (v.z * v.z),
            0.0,
            -self.f / v.z,
            self.f * v.y / (v.z * v.z),
        );
        let a = (Matrix2::identity() + dj) * dc_dv; // d out / d v
        let rt = pose.r.transpose();
        let mut jp = SMatrix::<f64, 2, 6>::zeros();
        jp.fixed_view_mut::<2, 3>(0, 0)
            .copy_from(&(a * rt * skew(&d)));
        jp.fixed_view_mut::<2, 3>(0, 3).copy_from(&(-(a * rt)));
        let mut ji = SMatrix::<f64, 2, N_INTERIOR>::zeros();
        ji.set_column(0, &((Matrix2::identity() + dj) * (c / self.f)));
        ji[(0, 1)] = 1.0;
        ji[(1, 2)] = 1.0;
        let r2 = q.norm_squared();
        for (k, pw) in [r2, r2 * r2, r2 * r2 * r2].into_iter().enumerate() {
            ji.set_column(3 + k, &(q * pw));
        }
        ji.set_column(6, &Vector2::new(r2 + 2.0 * q.x * q.x, 2.0 * q.x * q.y));
        ji.set_column(7, &Vector2::new(2.0 * q.x * q.y, r2 + 2.0 * q.y * q.y));
        ji.set_column(8, &Vector2::new(q.x, 0.0));
        ji.set_column(9, &Vector2::new(q.y, 0.0));
        Some((
            out,
            Jacobians {
                pose: jp,
                point: a * rt,
                interior: ji,
            },
        ))
    }

    /// Interior parameters as a vector (order of [`N_INTERIOR`]).
    pub fn interior(&self) -> [f64; N_INTERIOR] {
        [
            self.f, self.x0, self.y0, self.k[0], self.k[1], self.k[2], self.p[0], self.p[1],
            self.b[0], self.b[1],
        ]
    }

    /// The camera with interior parameters replaced.
    pub fn with_interior(&self, v: &[f64; N_INTERIOR]) -> Camera {
        Camera {
            f: v[0],
            x0: v[1],
            y0: v[2],
            k: [v[3], v[4], v[5]],
            p: [v[6], v[7]],
            b: [v[8], v[9]],
            ..*self
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rotation::{exp_so3, Angles};

    fn setup() -> (Camera, Pose, Vector3<f64>) {
        let cam = Camera {
            f: 0.035,
            x0: 1.2e-4,
            y0: -0.8e-4,
            k: [-0.05 / 0.035f64.powi(2), 0.01, 0.0],
            p: [1e-3, -2e-3],
            b: [1e-4, -2e-4],
            dc: [2e-4, 1e-4],
            pixel: 3.9e-6,
            width_px: 6000,
            height_px: 4000,
        };
        let pose = Pose {
            r: Angles::OmegaPhiKappa {
                omega: 0.02,
                phi: -0.03,
                kappa: 1.2,
            }
            .matrix(),
            centre: Vector3::new(10.0, -20.0, 350.0),
        };
        (cam, pose, Vector3::new(40.0, 15.0, 3.0))
    }

    #[test]
    fn jacobians_match_finite_differences() {
        let (cam, pose, x) = setup();
        let (p0, j) = cam.project_with_jacobians(&pose, &x).unwrap();
        let h = 1e-6;
        for k in 0..6 {
            let mut d = [0.0; 6];
            d[k] = h;
            let pp = Pose {
                r: exp_so3(&Vector3::new(d[0], d[1], d[2])) * pose.r,
                centre: pose.centre + Vector3::new(d[3], d[4], d[5]),
            };
            let pm = Pose {
                r: exp_so3(&Vector3::new(-d[0], -d[1], -d[2])) * pose.r,
                centre: pose.centre - Vector3::new(d[3], d[4], d[5]),
            };
            let num = (cam.project(&pp, &x).unwrap() - cam.project(&pm, &x).unwrap()) / (2.0 * h);
            assert!(
                (num - j.pose.column(k)).norm() < 1e-6 * (1.0 + num.norm()),
                "pose {k}: {num} vs {}",
                j.pose.column(k)
            );
        }
        for k in 0..3 {
            let e = Vector3::ith(k, h);
            let num = (cam.project(&pose, &(x + e)).unwrap()
                - cam.project(&pose, &(x - e)).unwrap())
                / (2.0 * h);
            assert!((num - j.point.column(k)).norm() < 1e-9, "point {k}");
        }
        let base = cam.interior();
        for k in 0..N_INTERIOR {
            let hk = 1e-7 * base[k].abs().max(1e-3);
            let (mut a, mut b) = (base, base);
            a[k] += hk;
            b[k] -= hk;
            let num = (cam.with_interior(&a).project(&pose, &x).unwrap()
                - cam.with_interior(&b).project(&pose, &x).unwrap())
                / (2.0 * hk);
            assert!(
                (num - j.interior.column(k)).norm() < 1e-6 * (1.0 + num.norm()),
                "interior {k}: {num} vs {}",
                j.interior.column(k)
            );
        }
        // Pixel conversions invert each other.
        let px = cam.image_to_pixel(p0);
        assert!((cam.pixel_to_image(px) - p0).norm() < 1e-15);
    }
}
