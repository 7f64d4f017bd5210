//! `textured-block`: a small aerial block whose photos are rendered, so that a feature
//! matcher can be checked against exact truth to the subpixel.
//!
//! The scene: a terrain of gentle relief (an analytic height, ±3 m or so: [`Terrain`]) with a
//! procedural texture draped on it (fields, gabled roofs, roads with dashed marks, small
//! rectangles and discs, fine value noise, and a target at each control and check point:
//! [`Texture`]), all drawn from the seed. The block ([`TexturedSpec::builtin`]): 3 strips of
//! 8 photos, the middle strip flown west, 65 % forward and 35 % side overlap, 100 m above
//! the origin; a 1600 × 1200 px frame camera of 4 µm pixels and f = 8 mm (5 cm on the
//! ground), principal point (12, −8) µm off centre and radial distortion k1 = −150 m⁻²
//! (−2.4 px in the corners); ω, φ and κ off level and off the strip direction by up to ±2°.
//! GNSS antenna positions (σ 2/2/3.5 cm, correlated; lever arm (3, −2, 15) cm), five control
//! points (σ 2 cm / 3 cm) and four check points, as the other blocks have them.
//!
//! Rendering ([`render`]): every pixel's rays go through the exact camera (its distortion
//! inverted), meet the terrain, and sample the texture 3 × 3 times per pixel; sensor noise of
//! σ 1 grey level; 8-bit greyscale PNG. Images are rendered in parallel (rayon); the result
//! is the same bytes for the same seed whatever the thread count.
//!
//! Leaves in the folder:
//! - `project.toml` (the exact camera, no self-calibration), `images.csv`,
//!   `image_observations.csv` (the exact pixel of every tie, control and check point in each
//!   photo that sees it, to 1e-6 px: adjusting it is adjusting "with exact points"),
//!   `ground_points.csv` (control and check points, noisy by their σ), `antennas.csv` (GNSS
//!   antenna positions with covariance: the positions a matcher should use, e.g. to choose
//!   image pairs — they are the antenna, 15 cm above the projection centre, not the centre),
//!   `trajectory.pos`;
//! - `camera.toml`: the same `[[camera]]` table alone (`--camera DIR/camera.toml`);
//! - `photos/<image id>.png`, one per row of `images.csv`;
//! - the truth: `truth.toml`, `truth_exposures.csv` (exact poses), `truth_points.csv`; read
//!   back by [`Truth::load`].
//!
//! Pixels everywhere: column right, row down, origin at the top-left corner of the top-left
//! pixel; pixel (i, j) covers [i, i+1] × [j, j+1] and has its centre at (i + 0.5, j + 0.5)
//! (`photo::camera::Camera::pixel_to_image`). Frame: ENU at the site origin, metres; GPST.

mod files;
pub mod render;
pub mod terrain;
pub mod texture;
mod truth;

pub use render::{GreyImage, RenderOptions};
pub use terrain::{pixel_ray, undistort, Extent, Ray, Terrain};
pub use texture::Texture;
pub use truth::Truth;

use super::files::{images_table, write_antennas};
use super::spec::{BlockSpec, Image, T_FIRST};
use crate::error::SimError;
use crate::ground_points::{write_ground_points, Point};
use crate::io::{write, write_bytes};
use crate::rng::Rng;
use gnss::frame::Geodetic;
use nalgebra::{Vector2, Vector3};
use photo::camera::Camera;
use rayon::prelude::*;
use std::path::Path;
use truth::{exposures_csv, parse_camera, pose_of, Exposure, TruthToml};

/// The antenna lever arm (u, v, w) in the camera frame, metres.
pub const LEVER_ARM: [f64; 3] = [0.03, -0.02, 0.15];
/// σ of the GNSS antenna positions (E, N, U), metres.
pub const GNSS_SIGMA: [f64; 3] = [0.02, 0.02, 0.035];
/// An exact image measurement: image index, point index, pixel.
type Measurement = (usize, usize, Vector2<f64>);

/// Ground speed, m/s.
const SPEED: f64 = 8.0;
/// Pixels kept free at the image border when measuring points.
const BORDER_PX: f64 = 8.0;

/// What to simulate.
#[derive(Clone, Debug)]
pub struct TexturedSpec {
    /// Seed of every random draw (terrain, texture, flight, points, GNSS, sensor noise).
    pub seed: u64,
    /// Strips (alternate strips flown west).
    pub strips: usize,
    /// Photos per strip.
    pub per_strip: usize,
    /// Image width (along the strips), pixels.
    pub width_px: usize,
    /// Image height (across the strips), pixels.
    pub height_px: usize,
    /// Pixel size, µm.
    pub pixel_um: f64,
    /// Principal distance, mm.
    pub focal_mm: f64,
    /// Principal point (x0, y0), mm from the image centre, x right, y up.
    pub principal_point_mm: [f64; 2],
    /// Radial distortion k1 on image coordinates in metres (1/m²).
    pub k1: f64,
    /// Flying height above the origin, m.
    pub flying_height: f64,
    /// Forward overlap (0–1).
    pub forward_overlap: f64,
    /// Side overlap (0–1).
    pub side_overlap: f64,
    /// ω, φ and κ (about the strip direction) drawn uniformly within ± this, degrees.
    pub tilt_deg: f64,
    /// Tie points placed over the block.
    pub ties: usize,
    /// Check points placed over the block.
    pub checks: usize,
    /// How the photos are rendered.
    pub render: RenderOptions,
}

impl TexturedSpec {
    /// The block of `ppkat simulate --builtin textured-block`: 3 × 8 photos of
    /// 1600 × 1200 px at 5 cm.
    pub fn builtin() -> TexturedSpec {
        TexturedSpec {
            seed: 15,
            strips: 3,
            per_strip: 8,
            width_px: 1600,
            height_px: 1200,
            pixel_um: 4.0,
            focal_mm: 8.0,
            principal_point_mm: [0.012, -0.008],
            k1: -150.0,
            flying_height: 100.0,
            forward_overlap: 0.65,
            side_overlap: 0.35,
            tilt_deg: 2.0,
            ties: 300,
            checks: 4,
            render: RenderOptions::default(),
        }
    }

    /// A reduced block for tests: 2 × 4 photos of 400 × 300 px of 16 µm (the same footprint,
    /// 20 cm on the ground).
    pub fn reduced() -> TexturedSpec {
        TexturedSpec {
            strips: 2,
            per_strip: 4,
            width_px: 400,
            height_px: 300,
            pixel_um: 16.0,
            ties: 120,
            ..TexturedSpec::builtin()
        }
    }

    /// The camera, exactly as `ppkat adjust` reads it from the written `[[camera]]` table.
    pub fn camera(&self) -> Result<Camera, SimError> {
        parse_camera(&files::camera_toml(self), Path::new("camera.toml"))
    }

    /// Ground footprint of an image (along, across the strips), air base and strip
    /// spacing, metres.
    fn layout(&self) -> (f64, f64, f64, f64) {
        let scale = self.flying_height / (self.focal_mm * 1e-3);
        let along = self.width_px as f64 * self.pixel_um * 1e-6 * scale;
        let across = self.height_px as f64 * self.pixel_um * 1e-6 * scale;
        (
            along,
            across,
            along * (1.0 - self.forward_overlap),
            across * (1.0 - self.side_overlap),
        )
    }

    /// The rectangle the terrain and texture cover: the footprints plus 15 m.
    fn extent(&self) -> Extent {
        let (along, across, base, spacing) = self.layout();
        Extent {
            xmin: -along / 2.0 - 15.0,
            xmax: (self.per_strip.max(1) - 1) as f64 * base + along / 2.0 + 15.0,
            ymin: -across / 2.0 - 15.0,
            ymax: (self.strips.max(1) - 1) as f64 * spacing + across / 2.0 + 15.0,
        }
    }
}

/// What a textured block wrote.
#[derive(Clone, Debug)]
pub struct TexturedReport {
    /// Photos rendered (one per image).
    pub images: usize,
    /// Their size, pixels (width, height).
    pub size_px: (usize, usize),
    /// Ground points measured (ties, control and check points).
    pub points: usize,
    /// Exact image measurements written.
    pub measurements: usize,
    /// Wall time of the rendering (all photos, PNG included), seconds.
    pub render_seconds: f64,
}

/// Simulate the textured block of `spec` and write the project, the photos and the truth
/// into `dir` (created if needed).
pub fn textured_block(spec: &TexturedSpec, dir: &Path) -> Result<TexturedReport, SimError> {
    if spec.strips == 0 || spec.per_strip == 0 || spec.width_px < 16 || spec.height_px < 16 {
        return Err(SimError::Key {
            key: "textured-block",
            what: "needs at least one strip of one photo of 16 × 16 px".into(),
        });
    }
    let rng = Rng::new(spec.seed);
    let cam = spec.camera()?;
    let extent = spec.extent();
    let origin = Geodetic::from_degrees(47.38, 8.55, 450.0);
    let terrain = Terrain::generate(spec.seed, &extent);
    let exposures = fly(spec, &mut rng.fork(1));
    let images: Vec<Image> = exposures
        .iter()
        .map(|(id, s, t, c, opk)| (id.clone(), *s, pose_of(*c, *opk), *t))
        .collect();
    let points = place_points(spec, &terrain, &mut rng.fork(2));
    let (meas, seen) = measure(&cam, &images, &points);
    let kept: Vec<&Point> = (0..points.len())
        .filter(|&k| seen[k] >= 2)
        .map(|k| &points[k])
        .collect();
    let ids: Vec<String> = images.iter().map(|im| im.0.clone()).collect();
    write(dir, "images.csv", &images_table(&images))?;
    write(
        dir,
        "image_observations.csv",
        &files::measurements_csv(&meas, &ids, &points),
    )?;
    let control = kept.iter().copied().filter(|p| p.1 != "tie");
    write_ground_points(dir, control, (0.02, 0.03), None, &origin, &mut rng.fork(3))?;
    let bs = block_spec(spec);
    let (_, _, base, _) = spec.layout();
    write_antennas(&bs, dir, &images, &origin, base, &mut rng.fork(4))?;
    let gnss = super::gnss_section(&bs, [0.0; 3], "auto", "offset");
    write(dir, "project.toml", &files::project_toml(spec, &gnss))?;
    write(dir, "camera.toml", &files::camera_toml(spec))?;
    let truth = TruthToml {
        seed: spec.seed,
        origin: [origin.lat.to_degrees(), origin.lon.to_degrees(), origin.h],
        extent: [extent.xmin, extent.xmax, extent.ymin, extent.ymax],
        lever_arm: LEVER_ARM,
        gnss_sigma: GNSS_SIGMA,
    };
    write(dir, "truth.toml", &truth.text())?;
    write(dir, "truth_exposures.csv", &exposures_csv(&exposures))?;
    write(dir, "truth_points.csv", &files::truth_points_csv(&kept))?;
    let targets: Vec<Vector2<f64>> = points
        .iter()
        .filter(|p| p.1 != "tie")
        .map(|p| p.2.xy())
        .collect();
    let texture = Texture::generate(spec.seed, &extent, &targets);
    let t0 = std::time::Instant::now();
    render_photos(spec, &terrain, &texture, &cam, &images, &dir.join("photos"))?;
    Ok(TexturedReport {
        images: images.len(),
        size_px: (cam.width_px, cam.height_px),
        points: kept.len(),
        measurements: meas.len(),
        render_seconds: t0.elapsed().as_secs_f64(),
    })
}

/// Render every image in parallel into `photos/<id>.png`; each image's sensor noise has its
/// own random stream, so the bytes do not depend on the thread count.
fn render_photos(
    spec: &TexturedSpec,
    terrain: &Terrain,
    texture: &Texture,
    cam: &Camera,
    images: &[Image],
    photos: &Path,
) -> Result<(), SimError> {
    images
        .par_iter()
        .enumerate()
        .map(|(k, im)| {
            let mut rng = Rng::new(spec.seed).fork(1000 + k as u64);
            let img = render::render(terrain, texture, cam, &im.2, &spec.render, &mut rng);
            let name = format!("{}.png", im.0);
            let bytes = img.png().map_err(|e| SimError::File {
                path: photos.join(&name).display().to_string(),
                what: format!("cannot encode the PNG: {e}"),
            })?;
            write_bytes(photos, &name, &bytes).map(|_| ())
        })
        .collect()
}

/// The block spec whose GNSS settings `write_antennas` and `gnss_section` take.
fn block_spec(spec: &TexturedSpec) -> BlockSpec {
    BlockSpec {
        name: "textured block".into(),
        seed: spec.seed,
        speed: SPEED,
        gnss_sigma: GNSS_SIGMA,
        gnss_corr: [0.1, 0.2, 0.1],
        lever_arm: LEVER_ARM,
        drift_a: [0.0; 3],
        drift_b: [0.0; 3],
        segment_jump: None,
        ..BlockSpec::classic()
    }
}

/// The exposures strip by strip (odd strips flown west), centres within 0.3 m of the plan,
/// ω, φ and κ off level and off the track direction by up to ± `tilt_deg`.
fn fly(spec: &TexturedSpec, rng: &mut Rng) -> Vec<Exposure> {
    let (_, _, base, spacing) = spec.layout();
    let mut t = T_FIRST;
    let mut out = Vec::new();
    let tilt = spec.tilt_deg;
    for s in 0..spec.strips {
        let east = s % 2 == 0;
        let heading = if east { 0.0 } else { 180.0 };
        for k in 0..spec.per_strip {
            let i = if east { k } else { spec.per_strip - 1 - k };
            let centre = Vector3::new(
                i as f64 * base + 0.3 * rng.normal(),
                s as f64 * spacing + 0.3 * rng.normal(),
                spec.flying_height + 0.3 * rng.normal(),
            );
            let opk = [
                rng.range(-tilt, tilt),
                rng.range(-tilt, tilt),
                heading + rng.range(-tilt, tilt),
            ];
            out.push((format!("{}{:02}", s + 1, i + 1), s, t, centre, opk));
            t += base / SPEED;
        }
        t += 40.0;
    }
    out
}

/// Control points at the block's corners and centre, check and tie points at
/// random over it; all on the terrain.
fn place_points(spec: &TexturedSpec, terrain: &Terrain, rng: &mut Rng) -> Vec<Point> {
    let (along, across, base, spacing) = spec.layout();
    let xl = (spec.per_strip - 1) as f64 * base;
    let yl = (spec.strips - 1) as f64 * spacing;
    let on = |x: f64, y: f64| Vector3::new(x, y, terrain.height(Vector2::new(x, y)));
    let mut points: Vec<Point> = Vec::new();
    // Half an air base in from the ends of the outer strips, a quarter footprint outside
    // them: each seen by two photos of its strip.
    let (gx, gy) = (0.5 * base, 0.25 * across);
    let corners = [
        (gx, -gy),
        (xl - gx, -gy),
        (gx, yl + gy),
        (xl - gx, yl + gy),
        (xl / 2.0, yl / 2.0),
    ];
    for (k, (x, y)) in corners.into_iter().enumerate() {
        points.push((format!("G{}", k + 1), "gcp", on(x, y)));
    }
    for k in 0..spec.checks {
        let (x, y) = (rng.range(0.0, xl), rng.range(0.0, yl.max(1.0)));
        points.push((format!("C{}", k + 1), "check", on(x, y)));
    }
    for k in 0..spec.ties {
        let x = rng.range(-0.45 * along, xl + 0.45 * along);
        let y = rng.range(-0.45 * across, yl + 0.45 * across);
        points.push((format!("T{}", k + 1), "tie", on(x, y)));
    }
    points
}

/// The exact pixel of every point in every image that sees it away from the border, for
/// points seen at least twice; also how many images see each point.
fn measure(cam: &Camera, images: &[Image], points: &[Point]) -> (Vec<Measurement>, Vec<usize>) {
    let (w, h) = (cam.width_px as f64, cam.height_px as f64);
    let mut meas = Vec::new();
    for (i, im) in images.iter().enumerate() {
        for (k, p) in points.iter().enumerate() {
            let Some(xy) = cam.project(&im.2, &p.2) else {
                continue;
            };
            let px = cam.image_to_pixel(xy);
            let inside = |v: f64, n: f64| (BORDER_PX..n - BORDER_PX).contains(&v);
            if inside(px.x, w) && inside(px.y, h) {
                meas.push((i, k, px));
            }
        }
    }
    let mut seen = vec![0usize; points.len()];
    meas.iter().for_each(|m| seen[m.1] += 1);
    meas.retain(|m| seen[m.1] >= 2);
    (meas, seen)
}
