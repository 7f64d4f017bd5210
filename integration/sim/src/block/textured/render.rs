//! The renderer of the textured block: one 8-bit grey image of the textured terrain through
//! the exact camera, and its PNG encoding.
//!
//! What enters: a [`Terrain`], a [`Texture`], a `photo` camera and pose (site ENU), the
//! [`RenderOptions`] and a random stream for the sensor noise. What leaves: a [`GreyImage`]
//! (row-major, top row first) and PNG bytes.
//!
//! Pixel convention (that of `photo::camera` and `image_observations.csv`): pixel (i, j) —
//! column i from the left, row j from the top — covers the square [i, i+1] × [j, j+1] of pixel
//! coordinates, whose origin is the top-left corner of the top-left pixel; its centre is
//! (i + 0.5, j + 0.5). A pixel's value is the mean of n × n samples at
//! (i + (a + ½)/n, j + (b + ½)/n) of the texture's sharp elements, plus the smooth background
//! and fine noise at the pixel centre, plus Gaussian sensor noise, rounded and clamped to 0–255.
//!
//! Each sample's ray is the camera's exact ray (distortion inverted by Newton) intersected
//! with the terrain to 0.1 mm; to keep rendering fast this is done exactly every
//! `grid_step` pixels and the ground positions in between are interpolated bilinearly (for
//! this terrain and 4 px, under 0.005 px of error: the map pixel → ground is smooth at that
//! scale).

use super::terrain::{pixel_ray, Terrain};
use super::texture::Texture;
use crate::rng::Rng;
use nalgebra::Vector2;
use photo::camera::{Camera, Pose};

/// How to render.
#[derive(Clone, Copy, Debug)]
pub struct RenderOptions {
    /// Samples per pixel along each axis (3: 3 × 3 per pixel).
    pub supersample: usize,
    /// σ of the Gaussian sensor noise, grey levels (0: none).
    pub noise_grey: f64,
    /// Pixels between exact ray–terrain intersections (ground positions interpolated
    /// between them).
    pub grid_step: usize,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            supersample: 3,
            noise_grey: 1.0,
            grid_step: 4,
        }
    }
}

/// An 8-bit grey image.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GreyImage {
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels.
    pub height: usize,
    /// Grey values, row-major, top row first.
    pub data: Vec<u8>,
}

impl GreyImage {
    /// The value of pixel (column, row).
    pub fn at(&self, col: usize, row: usize) -> u8 {
        self.data[row * self.width + col]
    }

    /// The image as a PNG file (8-bit greyscale).
    pub fn png(&self) -> Result<Vec<u8>, image::ImageError> {
        use image::codecs::png::{CompressionType, FilterType, PngEncoder};
        use image::ImageEncoder as _;
        let mut out = Vec::new();
        PngEncoder::new_with_quality(&mut out, CompressionType::Fast, FilterType::Adaptive)
            .write_image(
                &self.data,
                self.width as u32,
                self.height as u32,
                image::ExtendedColorType::L8,
            )?;
        Ok(out)
    }
}

/// The ground (east, north) at the corners of the intersection grid: every `step` pixels,
/// `nx` × `ny` nodes, row-major; NaN where a ray misses.
fn ground_grid(
    terrain: &Terrain,
    cam: &Camera,
    pose: &Pose,
    step: usize,
    nx: usize,
    ny: usize,
) -> Vec<Vector2<f64>> {
    let mut grid = Vec::with_capacity(nx * ny);
    let mut guess = terrain.height(pose.centre.xy());
    for j in 0..ny {
        for i in 0..nx {
            let px = Vector2::new((i * step) as f64, (j * step) as f64);
            let ray = pixel_ray(cam, pose, px);
            match terrain.intersect(&ray, guess, 1e-4) {
                Some(p) => {
                    guess = p.z;
                    grid.push(p.xy());
                }
                None => grid.push(Vector2::repeat(f64::NAN)),
            }
        }
    }
    grid
}

/// Render the terrain and texture seen by `cam` at `pose` (site ENU).
pub fn render(
    terrain: &Terrain,
    texture: &Texture,
    cam: &Camera,
    pose: &Pose,
    opts: &RenderOptions,
    rng: &mut Rng,
) -> GreyImage {
    let (w, h) = (cam.width_px, cam.height_px);
    let s = opts.grid_step.max(1);
    let (nx, ny) = (w.div_ceil(s) + 1, h.div_ceil(s) + 1);
    let grid = ground_grid(terrain, cam, pose, s, nx, ny);
    let n = opts.supersample.max(1);
    let offsets: Vec<f64> = (0..n).map(|a| (a as f64 + 0.5) / n as f64).collect();
    let mut data = vec![0u8; w * h];
    for j in 0..h {
        let cj = j / s;
        for i in 0..w {
            let ci = i / s;
            let c00 = grid[cj * nx + ci];
            let c10 = grid[cj * nx + ci + 1];
            let c01 = grid[(cj + 1) * nx + ci];
            let c11 = grid[(cj + 1) * nx + ci + 1];
            // Ground at pixel position (u, v), bilinear in the grid cell.
            let at = |u: f64, v: f64| {
                let fx = (u - (ci * s) as f64) / s as f64;
                let fy = (v - (cj * s) as f64) / s as f64;
                let a = c00 + (c10 - c00) * fx;
                let b = c01 + (c11 - c01) * fx;
                a + (b - a) * fy
            };
            let centre = at(i as f64 + 0.5, j as f64 + 0.5);
            let noise = opts.noise_grey * rng.normal();
            if !(centre.x.is_finite() && centre.y.is_finite()) {
                continue;
            }
            let bg = texture.background(centre);
            let mut sum = 0.0;
            for &dv in &offsets {
                for &du in &offsets {
                    let p = at(i as f64 + du, j as f64 + dv);
                    sum += texture.layer(p).unwrap_or(bg);
                }
            }
            let v = sum / (n * n) as f64 + texture.detail(centre) + noise;
            data[j * w + i] = v.round().clamp(0.0, 255.0) as u8;
        }
    }
    GreyImage {
        width: w,
        height: h,
        data,
    }
}
