//! Camera models of other tools converted into ppkat's [`Camera`].
//!
//! Both source families below work in pixels (column right, row down, origin at the top-left
//! corner of the image, as ppkat's pixels) with a camera frame whose z axis looks forward and
//! whose y axis points down; ppkat's camera looks along −z with y up (see [`crate::camera`]).
//! For a camera-frame point p of the source (p.z > 0), the ppkat camera with the rotation
//! R_ppkat = R_source·diag(1, −1, −1) sees v = (p.x, −p.y, −p.z), so x_c = f·p.x/p.z and
//! y_c = −f·p.y/p.z: the same ray, with the image y axis flipped. Principal point and
//! distortion centre become offsets from the image centre (y up); the pixel size `pixel`
//! (metres) only sets the metric scale of ppkat's image coordinates.
//!
//! - **MicMac** `CalibrationInternConique` with `eConvApero_DistM2C` ([`MicMacCalibration`]):
//!   u = PP + F·(p.x/p.z, p.y/p.z); distorted = CDist + (u − CDist)·(1 + K1 r² + K2 r⁴ +
//!   K3 r⁶ + K4 r⁸) with r = |u − CDist| in pixels (`ModRad`, coefficients of r³ r⁵ r⁷ r⁹), and for
//!   `ModPhgrStd` plus, on d = u − CDist, Δx = P1(r² + 2dx²) + 2P2·dx·dy + b1·dx + b2·dy,
//!   Δy = P2(r² + 2dy²) + 2P1·dx·dy (MicMac `cDistModStdPhpgr::Direct`). Exactly ppkat's form
//!   with k_i = K_i / pixel^(2i), p1 = P1 / pixel, p2 = −P2 / pixel, b1 = b1, b2 = −b2 and the
//!   distortion centre offset from the principal point; a fourth radial coefficient (r⁹) has
//!   no ppkat counterpart and is fitted into k1–k3 (the fit error is returned).
//! - **OpenCV / COLMAP** ([`ColmapCamera`]): x' = p.x/p.z, y' = p.y/p.z, r² = x'² + y'²,
//!   x'' = x'·g + 2p1 x'y' + p2(r² + 2x'²), y'' = y'·g + p1(r² + 2y'²) + 2p2 x'y' with
//!   g = (1 + k1 r² + k2 r⁴ + k3 r⁶)/(1 + k4 r² + k5 r⁴ + k6 r⁶), u = fx·x'' + cx,
//!   v = fy·y'' + cy. With fx = fy = F and no k4–k6 this is ppkat's form exactly:
//!   f = F·pixel, k_i = k_i' / f^(2i), p1 = p2' / f, p2 = −p1' / f. With fx ≠ fy or a rational
//!   term, ppkat's k1–k3, p1, p2, b1, b2 are fitted by linear least squares over the image (the
//!   fit error is returned): the aspect difference scales the distortion too, which ppkat's
//!   affinity (applied to the ideal point) does not.

use crate::camera::Camera;
use nalgebra::{DMatrix, DVector, Vector2, Vector3};

/// Why a camera model could not be converted.
#[derive(Debug, thiserror::Error, PartialEq)]
#[non_exhaustive]
pub enum ConvertError {
    /// The model name is not one ppkat converts.
    #[error("camera model `{0}` is not supported: use SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV or FULL_OPENCV")]
    UnknownModel(String),
    /// The parameter count does not match the model.
    #[error("camera model {model} takes {expected} parameters, found {found}")]
    ParameterCount {
        /// The model.
        model: String,
        /// Parameters it takes.
        expected: usize,
        /// Parameters given.
        found: usize,
    },
    /// A focal length, pixel size or image size is not positive, or a value is not finite.
    #[error("{0}")]
    Invalid(String),
}

/// A converted camera with the largest difference between the source model and the ppkat
/// camera over the image (pixels; ~0 when the conversion is exact).
#[derive(Clone, Copy, Debug)]
pub struct Converted {
    /// The ppkat camera.
    pub camera: Camera,
    /// Largest projection difference over a 41 × 41 grid covering the image, pixels.
    pub max_error_px: f64,
}

/// A MicMac `CalibrationInternConique` (`eConvApero_DistM2C`), all in pixels.
#[derive(Clone, Debug, PartialEq)]
pub struct MicMacCalibration {
    /// Principal point `PP` (column, row).
    pub pp: [f64; 2],
    /// Focal length `F`, pixels.
    pub f: f64,
    /// Image size `SzIm` (width, height).
    pub size: [usize; 2],
    /// Distortion centre `CDist` (column, row).
    pub cdist: [f64; 2],
    /// `CoeffDist`: coefficients of r³, r⁵, r⁷, r⁹ (up to four).
    pub radial: Vec<f64>,
    /// Decentring `P1`, `P2` (`ModPhgrStd`; zero for `ModRad`).
    pub p: [f64; 2],
    /// Affinity `b1`, `b2` (`ModPhgrStd`; zero for `ModRad`).
    pub b: [f64; 2],
}

impl MicMacCalibration {
    /// The distorted pixel of a camera-frame point (MicMac frame, p.z > 0), by MicMac's
    /// formula; `None` behind the camera.
    pub fn project(&self, p: &Vector3<f64>) -> Option<Vector2<f64>> {
        (p.z > 0.0).then(|| self.distort(Vector2::new(p.x / p.z, p.y / p.z)))
    }

    /// Distorted pixel of normalised ideal coordinates m = (p.x/p.z, p.y/p.z).
    fn distort(&self, m: Vector2<f64>) -> Vector2<f64> {
        let u = Vector2::new(self.pp[0], self.pp[1]) + self.f * m;
        let c = Vector2::new(self.cdist[0], self.cdist[1]);
        let d = u - c;
        let r2 = d.norm_squared();
        let mut g = 1.0;
        let mut pw = r2;
        for k in &self.radial {
            g += k * pw;
            pw *= r2;
        }
        let [p1, p2] = self.p;
        let [b1, b2] = self.b;
        let tang = Vector2::new(
            (2.0 * d.x * d.x + r2) * p1 + 2.0 * d.x * d.y * p2 + b1 * d.x + b2 * d.y,
            (2.0 * d.y * d.y + r2) * p2 + 2.0 * d.x * d.y * p1,
        );
        c + d * g + tang
    }

    /// The ppkat camera for pixels of `pixel` metres.
    pub fn to_camera(&self, pixel: f64) -> Result<Converted, ConvertError> {
        let vals = [
            self.f,
            pixel,
            self.pp[0],
            self.pp[1],
            self.cdist[0],
            self.cdist[1],
        ];
        if !(self.f > 0.0 && pixel > 0.0 && self.size[0] > 0 && self.size[1] > 0)
            || vals.iter().chain(&self.radial).any(|v| !v.is_finite())
            || self.radial.len() > 4
        {
            return Err(ConvertError::Invalid(format!(
                "MicMac calibration: F {}, image size {}×{}, pixel {pixel} m, {} radial coefficients: F, the size and the pixel must be positive, values finite, at most 4 coefficients",
                self.f,
                self.size[0],
                self.size[1],
                self.radial.len()
            )));
        }
        let mut cam = Camera::ideal(self.f * pixel, pixel, self.size[0], self.size[1]);
        let pp = cam.pixel_to_image(Vector2::new(self.pp[0], self.pp[1]));
        let cd = cam.pixel_to_image(Vector2::new(self.cdist[0], self.cdist[1]));
        cam.x0 = pp.x;
        cam.y0 = pp.y;
        cam.dc = [cd.x - pp.x, cd.y - pp.y];
        for (i, k) in self.radial.iter().take(3).enumerate() {
            cam.k[i] = k / pixel.powi(2 * (i as i32 + 1));
        }
        cam.p = [self.p[0] / pixel, -self.p[1] / pixel];
        cam.b = [self.b[0], -self.b[1]];
        let target = |m: Vector2<f64>| self.distort(m);
        let needs_fit = self.radial.len() == 4 && self.radial[3] != 0.0;
        Ok(finish(cam, &target, needs_fit))
    }
}

/// A camera of COLMAP's `cameras.txt` (OpenCV models), in pixels.
#[derive(Clone, Debug, PartialEq)]
pub struct ColmapCamera {
    /// `SIMPLE_PINHOLE`, `PINHOLE`, `SIMPLE_RADIAL`, `RADIAL`, `OPENCV` or `FULL_OPENCV`.
    pub model: String,
    /// Image width, pixels.
    pub width: usize,
    /// Image height, pixels.
    pub height: usize,
    /// The model's parameters in COLMAP's order.
    pub params: Vec<f64>,
}

/// OpenCV's parameters in full: fx, fy, cx, cy, k1–k6, p1, p2.
struct OpenCv {
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
    k: [f64; 6],
    p: [f64; 2],
}

impl ColmapCamera {
    /// The model's parameters spelled out as the full OpenCV model.
    fn opencv(&self) -> Result<OpenCv, ConvertError> {
        let expected = match self.model.as_str() {
            "SIMPLE_PINHOLE" => 3,
            "PINHOLE" | "SIMPLE_RADIAL" => 4,
            "RADIAL" => 5,
            "OPENCV" => 8,
            "FULL_OPENCV" => 12,
            m => return Err(ConvertError::UnknownModel(m.to_string())),
        };
        let v = &self.params;
        if v.len() != expected {
            return Err(ConvertError::ParameterCount {
                model: self.model.clone(),
                expected,
                found: v.len(),
            });
        }
        let mut o = OpenCv {
            fx: v[0],
            fy: v[0],
            cx: v[1],
            cy: v[2],
            k: [0.0; 6],
            p: [0.0; 2],
        };
        match self.model.as_str() {
            "SIMPLE_RADIAL" => o.k[0] = v[3],
            "RADIAL" => o.k[..2].copy_from_slice(&v[3..5]),
            "PINHOLE" | "OPENCV" | "FULL_OPENCV" => {
                (o.fy, o.cx, o.cy) = (v[1], v[2], v[3]);
                if v.len() >= 8 {
                    o.k[..2].copy_from_slice(&v[4..6]);
                    o.p.copy_from_slice(&v[6..8]);
                }
                if v.len() == 12 {
                    o.k[2..].copy_from_slice(&v[8..12]);
                }
            }
            _ => {}
        }
        Ok(o)
    }

    /// The distorted pixel of a camera-frame point (COLMAP frame, p.z > 0), by OpenCV's
    /// formula; `None` behind the camera or for an unknown model.
    pub fn project(&self, p: &Vector3<f64>) -> Option<Vector2<f64>> {
        let o = self.opencv().ok()?;
        (p.z > 0.0).then(|| o.distort(Vector2::new(p.x / p.z, p.y / p.z)))
    }

    /// The ppkat camera for pixels of `pixel` metres (f = fy·pixel when fx ≠ fy).
    pub fn to_camera(&self, pixel: f64) -> Result<Converted, ConvertError> {
        let o = self.opencv()?;
        let finite = self.params.iter().all(|v| v.is_finite());
        if !(finite && o.fx > 0.0 && o.fy > 0.0 && pixel > 0.0 && self.width > 0 && self.height > 0)
        {
            return Err(ConvertError::Invalid(format!(
                "COLMAP camera {}: focal lengths, pixel size and image size must be positive and every parameter finite",
                self.model
            )));
        }
        let f = o.fy * pixel;
        let mut cam = Camera::ideal(f, pixel, self.width, self.height);
        let pp = cam.pixel_to_image(Vector2::new(o.cx, o.cy));
        cam.x0 = pp.x;
        cam.y0 = pp.y;
        for i in 0..3 {
            cam.k[i] = o.k[i] / f.powi(2 * (i as i32 + 1));
        }
        cam.p = [o.p[1] / f, -o.p[0] / f];
        let needs_fit = o.fx != o.fy || o.k[3..].iter().any(|k| *k != 0.0);
        let target = |m: Vector2<f64>| o.distort(m);
        Ok(finish(cam, &target, needs_fit))
    }
}

impl OpenCv {
    fn distort(&self, m: Vector2<f64>) -> Vector2<f64> {
        let (x, y) = (m.x, m.y);
        let r2 = x * x + y * y;
        let k = &self.k;
        let g = (1.0 + r2 * (k[0] + r2 * (k[1] + r2 * k[2])))
            / (1.0 + r2 * (k[3] + r2 * (k[4] + r2 * k[5])));
        let [p1, p2] = self.p;
        let xd = x * g + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
        let yd = y * g + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
        Vector2::new(self.fx * xd + self.cx, self.fy * yd + self.cy)
    }
}

/// Normalised ideal coordinates (source frame, y down) of a ppkat ideal point c (metres, y up,
/// relative to the principal point).
fn normalised(cam: &Camera, c: Vector2<f64>) -> Vector2<f64> {
    Vector2::new(c.x / cam.f, -c.y / cam.f)
}

/// The ppkat camera's distorted pixel for normalised ideal coordinates (source frame).
fn ppkat_pixel(cam: &Camera, m: Vector2<f64>) -> Option<Vector2<f64>> {
    let pose = crate::camera::Pose {
        r: nalgebra::Matrix3::identity(),
        centre: Vector3::zeros(),
    };
    let v = Vector3::new(m.x, -m.y, -1.0);
    cam.project(&pose, &v).map(|xy| cam.image_to_pixel(xy))
}

/// Ideal points c (metres, relative to the principal point) on an n × n grid covering the
/// image.
fn grid(cam: &Camera, n: usize) -> Vec<Vector2<f64>> {
    let mut out = Vec::with_capacity(n * n);
    for i in 0..n {
        for j in 0..n {
            let px = Vector2::new(
                cam.width_px as f64 * i as f64 / (n - 1) as f64,
                cam.height_px as f64 * j as f64 / (n - 1) as f64,
            );
            out.push(cam.pixel_to_image(px) - Vector2::new(cam.x0, cam.y0));
        }
    }
    out
}

/// Largest difference (pixels) over the grid between the source model and the ppkat camera.
fn max_error(cam: &Camera, target: &dyn Fn(Vector2<f64>) -> Vector2<f64>) -> f64 {
    grid(cam, 41)
        .into_iter()
        .map(|c| {
            let m = normalised(cam, c);
            ppkat_pixel(cam, m).map_or(f64::INFINITY, |p| (p - target(m)).norm())
        })
        .fold(0.0, f64::max)
}

/// The closed-form camera, or when the source has terms ppkat lacks (`needs_fit`), k1–k3,
/// p1, p2, b1, b2 fitted by linear least squares to the source's distortion over the image
/// (the distortion is linear in them at fixed f, principal point and distortion centre).
fn finish(
    cam: Camera,
    target: &dyn Fn(Vector2<f64>) -> Vector2<f64>,
    needs_fit: bool,
) -> Converted {
    let exact = Converted {
        camera: cam,
        max_error_px: max_error(&cam, target),
    };
    if !needs_fit {
        return exact;
    }
    let pts = grid(&cam, 41);
    let n = pts.len();
    let mut a = DMatrix::zeros(2 * n, 7);
    let mut b = DVector::zeros(2 * n);
    let dc = Vector2::new(cam.dc[0], cam.dc[1]);
    for (i, c) in pts.iter().enumerate() {
        let m = normalised(&cam, *c);
        let t = cam.pixel_to_image(target(m)) - Vector2::new(cam.x0, cam.y0) - c;
        let d = c - dc;
        let r2 = d.norm_squared();
        let cols = [
            d * r2,
            d * r2 * r2,
            d * r2 * r2 * r2,
            Vector2::new(r2 + 2.0 * d.x * d.x, 2.0 * d.x * d.y),
            Vector2::new(2.0 * d.x * d.y, r2 + 2.0 * d.y * d.y),
            Vector2::new(d.x, 0.0),
            Vector2::new(d.y, 0.0),
        ];
        for (j, col) in cols.iter().enumerate() {
            a[(2 * i, j)] = col.x;
            a[(2 * i + 1, j)] = col.y;
        }
        b[2 * i] = t.x;
        b[2 * i + 1] = t.y;
    }
    // Scale the columns to unit norm: r⁶ and r² differ by many orders of magnitude.
    let scale: Vec<f64> = (0..7).map(|j| a.column(j).norm().max(1e-300)).collect();
    for (j, s) in scale.iter().enumerate() {
        a.column_mut(j).scale_mut(1.0 / s);
    }
    // Values near 1e300 (a hostile file) overflow r⁶ to inf and the scaling to NaN, on which
    // nalgebra's SVD, unbounded by default, never ends: refuse them, and bound the iterations.
    if !(a.iter().chain(b.iter()).all(|v| v.is_finite())) {
        return exact;
    }
    let Some(svd) = a.try_svd(true, true, f64::EPSILON, 10_000) else {
        return exact;
    };
    let Ok(x) = svd.solve(&b, 1e-14) else {
        return exact;
    };
    let mut fitted = cam;
    let v: Vec<f64> = (0..7).map(|j| x[j] / scale[j]).collect();
    fitted.k = [v[0], v[1], v[2]];
    fitted.p = [v[3], v[4]];
    fitted.b = [v[5], v[6]];
    let fit = Converted {
        camera: fitted,
        max_error_px: max_error(&fitted, target),
    };
    if fit.max_error_px < exact.max_error_px {
        fit
    } else {
        exact
    }
}

#[cfg(test)]
#[path = "camera_convert_tests.rs"]
mod tests;
