//! The images of the navigation-grade blocks (`nav-block`, `sparse-control`): the camera
//! format, an exposure ([`NavImage`]), an image measurement ([`Meas`]), where a point lands in
//! an image (`seen`) and the measurement noise (`noisy`). Shared by [`super::nav`], which flies
//! the block, and `sparse`, which measures sparse control in it.

use crate::rng::Rng;
use nalgebra::{Vector2, Vector3};
use photo::camera::{Camera, Pose};

/// Pixel size, metres.
pub(super) const PIXEL: f64 = 4.5e-6;
/// Along-track image size, pixels.
pub(super) const WIDTH_PX: usize = 5400;
/// Across-track image size, pixels.
pub(super) const HEIGHT_PX: usize = 8000;
/// σ of an image measurement, pixels.
pub(super) const SIGMA_PX: f64 = 1.0;

/// An exposure: id, strip (from 0), true pose (site ENU), GPST seconds, true velocity (ENU).
pub type NavImage = (String, usize, Pose, f64, Vector3<f64>);

/// Where `x` lands in the image, when inside the format 100 px from the edges.
pub(super) fn seen(cam: &Camera, pose: &Pose, x: &Vector3<f64>) -> Option<Vector2<f64>> {
    seen_inside(cam, pose, x, 100.0)
}

/// Where `x` lands in the image (metres), when inside the camera's format `margin` pixels
/// from its edges.
pub(crate) fn seen_inside(
    cam: &Camera,
    pose: &Pose,
    x: &Vector3<f64>,
    margin: f64,
) -> Option<Vector2<f64>> {
    let xy = cam.project(pose, x)?;
    let px = cam.image_to_pixel(xy);
    let inside = |v: f64, n: usize| (margin..n as f64 - margin).contains(&v);
    (inside(px.x, cam.width_px) && inside(px.y, cam.height_px)).then_some(xy)
}

/// An image measurement: image index, point index, image coordinates (m).
pub(super) type Meas = (usize, usize, Vector2<f64>);

/// `xy` with the measurement noise (σ [`SIGMA_PX`]) drawn from `rng`.
pub(super) fn noisy(xy: Vector2<f64>, rng: &mut Rng) -> Vector2<f64> {
    xy + Vector2::new(rng.normal(), rng.normal()) * (SIGMA_PX * PIXEL)
}
