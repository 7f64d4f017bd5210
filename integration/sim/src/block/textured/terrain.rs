//! The terrain of the textured block and the geometry of a pixel's ray: an analytic smooth
//! height over the site's ENU plane (a few long sinusoids plus Gaussian bumps, drawn from the
//! seed), a camera ray through a pixel (the distortion of `photo::camera` inverted by Newton),
//! and the ray's intersection with the terrain (Newton on the height along the ray).
//!
//! What enters: a seed and the block's [`Extent`]; a camera, a pose and a pixel. What leaves:
//! heights with their gradient, [`Ray`]s and ground points (ENU at the site origin, metres).
//! Used by the renderer and by [`super::Truth`].
//!
//! The terrain's slope stays below 0.35 and the rays of the block below 40° from the vertical,
//! so the height along a ray is monotonic: a ray meets the terrain exactly once (no
//! occlusion), and Newton converges from any start.

use crate::rng::Rng;
use nalgebra::{Matrix2, Vector2, Vector3};
use photo::camera::{Camera, Pose};

/// A rectangle of the site's ENU plane, metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Extent {
    /// Westmost east coordinate.
    pub xmin: f64,
    /// Eastmost east coordinate.
    pub xmax: f64,
    /// Southmost north coordinate.
    pub ymin: f64,
    /// Northmost north coordinate.
    pub ymax: f64,
}

/// One long sinusoid: amplitude (m), wave vector (rad/m), phase (rad).
#[derive(Clone, Copy, Debug)]
struct Wave {
    amp: f64,
    k: Vector2<f64>,
    phase: f64,
}

/// One Gaussian bump: amplitude (m, ±), centre (ENU m), σ (m).
#[derive(Clone, Copy, Debug)]
struct Bump {
    amp: f64,
    centre: Vector2<f64>,
    sigma: f64,
}

/// The terrain height `u = h(e, n)` in the site's ENU frame: a sum of three sinusoids of
/// 60–140 m wavelength and 0.6–1.2 m amplitude and six Gaussian bumps of ±1–2 m and σ 12–25 m,
/// about 3 % of a 100 m flying height.
#[derive(Clone, Debug)]
pub struct Terrain {
    base: f64,
    waves: Vec<Wave>,
    bumps: Vec<Bump>,
}

/// The salt of the terrain's random stream (`Rng::fork`).
const TERRAIN_SALT: u64 = 71;

impl Terrain {
    /// The terrain of a seed over an extent (the bumps' centres lie in it).
    pub fn generate(seed: u64, extent: &Extent) -> Terrain {
        let mut rng = Rng::new(seed).fork(TERRAIN_SALT);
        let waves = (0..3)
            .map(|_| {
                let lambda = rng.range(60.0, 140.0);
                let dir = rng.range(0.0, std::f64::consts::PI);
                let k = Vector2::new(dir.cos(), dir.sin()) * (std::f64::consts::TAU / lambda);
                Wave {
                    amp: rng.range(0.6, 1.2),
                    k,
                    phase: rng.range(0.0, std::f64::consts::TAU),
                }
            })
            .collect();
        let bumps = (0..6)
            .map(|k| Bump {
                amp: rng.range(1.0, 2.0) * if k % 2 == 0 { 1.0 } else { -1.0 },
                centre: Vector2::new(
                    rng.range(extent.xmin, extent.xmax),
                    rng.range(extent.ymin, extent.ymax),
                ),
                sigma: rng.range(12.0, 25.0),
            })
            .collect();
        Terrain {
            base: 0.0,
            waves,
            bumps,
        }
    }

    /// A level plane at height `u` (m), for tests.
    pub fn flat(u: f64) -> Terrain {
        Terrain {
            base: u,
            waves: Vec::new(),
            bumps: Vec::new(),
        }
    }

    /// Height (m) at a horizontal position (east, north; m) and its gradient.
    pub fn height_gradient(&self, p: Vector2<f64>) -> (f64, Vector2<f64>) {
        let mut h = self.base;
        let mut g = Vector2::zeros();
        for w in &self.waves {
            let (s, c) = (w.k.dot(&p) + w.phase).sin_cos();
            h += w.amp * s;
            g += w.k * (w.amp * c);
        }
        for b in &self.bumps {
            let d = p - b.centre;
            let e = b.amp * (-d.norm_squared() / (2.0 * b.sigma * b.sigma)).exp();
            h += e;
            g -= d * (e / (b.sigma * b.sigma));
        }
        (h, g)
    }

    /// Height (m) at a horizontal position (east, north; m).
    pub fn height(&self, p: Vector2<f64>) -> f64 {
        self.height_gradient(p).0
    }

    /// The first point where the ray meets the terrain, to `tol` metres along the ray; `None`
    /// when the ray points up or does not converge. `start` is a guess of the height there.
    pub fn intersect(&self, ray: &Ray, start: f64, tol: f64) -> Option<Vector3<f64>> {
        let d = ray.dir;
        if d.z >= -1e-9 {
            return None;
        }
        let mut t = (start - ray.origin.z) / d.z;
        for _ in 0..60 {
            let p = ray.origin + d * t;
            let (h, g) = self.height_gradient(p.xy());
            let slope = d.z - g.dot(&d.xy());
            if slope.abs() < 1e-12 {
                return None;
            }
            let step = (p.z - h) / slope;
            t -= step;
            if step.abs() < tol {
                return (t > 0.0).then_some(ray.origin + d * t);
            }
        }
        None
    }
}

/// A ray in the site's ENU frame: the projection centre and a unit direction.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    /// Where the ray starts (the projection centre), m.
    pub origin: Vector3<f64>,
    /// Unit direction.
    pub dir: Vector3<f64>,
}

/// The ideal (undistorted, principal-point-free) image coordinates whose projection through
/// `cam` is `xy` (metres, `photo::camera` image coordinates): Newton on the camera's own
/// forward model, to 1e-15 m.
pub fn undistort(cam: &Camera, xy: Vector2<f64>) -> Vector2<f64> {
    let level = Pose {
        r: nalgebra::Matrix3::identity(),
        centre: Vector3::zeros(),
    };
    let mut c = xy - Vector2::new(cam.x0, cam.y0);
    for _ in 0..20 {
        let Some((f, j)) = cam.project_with_jacobians(&level, &Vector3::new(c.x, c.y, -cam.f))
        else {
            break;
        };
        let jc = Matrix2::new(
            j.point[(0, 0)],
            j.point[(0, 1)],
            j.point[(1, 0)],
            j.point[(1, 1)],
        );
        let Some(inv) = jc.try_inverse() else {
            break;
        };
        let step = inv * (f - xy);
        c -= step;
        if step.norm() < 1e-15 {
            break;
        }
    }
    c
}

/// The ray through a pixel position (column right, row down, origin at the top-left corner
/// of the top-left pixel, as `photo::camera::Camera::pixel_to_image`).
pub fn pixel_ray(cam: &Camera, pose: &Pose, px: Vector2<f64>) -> Ray {
    let c = undistort(cam, cam.pixel_to_image(px));
    let dir = pose.r * Vector3::new(c.x, c.y, -cam.f);
    Ray {
        origin: pose.centre,
        dir: dir.normalize(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gradient_matches_finite_differences_and_slope_is_gentle() {
        let ext = Extent {
            xmin: -50.0,
            xmax: 250.0,
            ymin: -40.0,
            ymax: 120.0,
        };
        let t = Terrain::generate(5, &ext);
        let mut worst: f64 = 0.0;
        for i in 0..40 {
            for j in 0..40 {
                let p = Vector2::new(-50.0 + 7.5 * i as f64, -40.0 + 4.0 * j as f64);
                let (_, g) = t.height_gradient(p);
                let h = 1e-5;
                let num = Vector2::new(
                    t.height(p + Vector2::new(h, 0.0)) - t.height(p - Vector2::new(h, 0.0)),
                    t.height(p + Vector2::new(0.0, h)) - t.height(p - Vector2::new(0.0, h)),
                ) / (2.0 * h);
                assert!((num - g).norm() < 1e-7, "{num} {g}");
                worst = worst.max(g.norm());
            }
        }
        assert!(worst < 0.35, "slope {worst}");
    }
}
