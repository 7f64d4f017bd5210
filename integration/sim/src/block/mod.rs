//! Simulated photogrammetric blocks with known truth, written as a ready-to-run `ppkat adjust`
//! project: an aerial block flown in strips (the classic 2-strip test block, or a large one
//! for benchmarks) with GNSS antenna positions carrying a lever arm, a drift and correlated
//! noise; the close-range pair of terrestrial stations is in [`super::closerange`]; blocks
//! with awkward GNSS in [`nav`]; a small block with rendered photos in [`textured`].
//! Deterministic per seed.
//!
//! Enters: a [`BlockSpec`] and a folder. Leaves: `project.toml`, `images.csv`,
//! `image_observations.csv`, `ground_points.csv`, `antennas.csv` (written by
//! [`exposure::export::antenna_table`]) and `trajectory.pos` in the folder, and the
//! [`BlockTruth`]. Uses `photo` (camera, rotations, lever arm) and `gnss` (frames, time,
//! `.pos`); read back by [`adjust`]. This module simulates; `files` writes the tables;
//! `spec` holds the spec, the truth and the records both share.
//!
//! Frame: ENU tangent plane at the site (`lat`, `lon`, `ground_h`); files carry geodetic
//! coordinates, so the adjustment sees only what a user would give it. Times are GPST
//! seconds from the GPS epoch (week 0).

mod files;
pub mod nav;
pub(crate) mod nav_images;
mod sparse;
mod spec;
pub mod textured;

pub use nav::{nav_block, NavSpec, NavTruth};
pub use spec::{BlockSpec, BlockTruth};

use super::error::SimError;
use super::ground_points::{write_ground_points, Point};
use super::io::write;
use super::rng::Rng;
use files::{images_table, measurements_table, project_toml, write_antennas};
use gnss::frame::Geodetic;
use nalgebra::{Vector2, Vector3};
use photo::camera::{Camera, Pose};
use photo::rotation::{rot_z, Angles};
use spec::{Image, Measurement, T_FIRST};
use std::path::Path;

fn terrain(relief: f64, x: f64, y: f64) -> f64 {
    relief * (0.6 * (x / 1700.0).sin() * (y / 1300.0).cos() + 0.4 * ((x + y) / 2900.0).sin())
}

/// The block's layout in metres, from the spec.
struct Layout {
    /// Square format side.
    fmt: f64,
    /// Ground footprint of an image side.
    foot: f64,
    /// Air base (distance between exposures along a strip).
    base: f64,
    /// Distance between strips.
    spacing: f64,
    /// Flying height above the origin.
    height: f64,
}

impl Layout {
    fn of(spec: &BlockSpec) -> Layout {
        let f = spec.focal_mm * 1e-3;
        let fmt = spec.format_mm * 1e-3;
        let foot = spec.scale * fmt;
        Layout {
            fmt,
            foot,
            base: foot * (1.0 - spec.forward_overlap),
            spacing: foot * (1.0 - spec.side_overlap),
            height: spec.scale * f,
        }
    }

    /// Along-track extent of the longest strip and across-track extent of the block.
    fn extent(&self, spec: &BlockSpec) -> (f64, f64) {
        let xmax = (spec
            .strips
            .iter()
            .copied()
            .max()
            .unwrap_or(1)
            .saturating_sub(1)) as f64
            * self.base;
        let ymax = (spec.strips.len().saturating_sub(1)) as f64 * self.spacing;
        (xmax, ymax)
    }
}

/// Simulate the block and write the project (`project.toml` and its tables) into `dir`.
pub fn aerial(spec: &BlockSpec, dir: &Path) -> Result<BlockTruth, SimError> {
    let mut rng = Rng::new(spec.seed);
    let npx = (spec.format_mm * 1e3 / spec.pixel_um).round() as usize;
    let nominal = Camera::ideal(spec.focal_mm * 1e-3, spec.pixel_um * 1e-6, npx, npx);
    let cam = true_camera(spec, &nominal);
    let layout = Layout::of(spec);
    let origin = Geodetic::from_degrees(spec.lat_deg, spec.lon_deg, spec.ground_h);
    let images = fly_strips(spec, &layout, &mut rng);
    let points = place_points(spec, &layout, images.len(), &mut rng);
    let (mut meas, count) = measure(spec, &layout, &cam, &images, &points, &mut rng);
    let blunders = inject_blunders(spec, &mut meas, &count, &images, &points, &mut rng);
    write(dir, "images.csv", &images_table(&images))?;
    write(
        dir,
        "image_observations.csv",
        &measurements_table(spec, &nominal, &meas, &images, &points),
    )?;
    let control = points
        .iter()
        .enumerate()
        .filter(|(k, p)| p.1 != "tie" && count[*k] >= 2)
        .map(|(_, p)| p);
    let wrong = write_ground_points(
        dir,
        control,
        (spec.gcp_sigma[0], spec.gcp_sigma[2]),
        spec.wrong_gcp,
        &origin,
        &mut rng,
    )?;
    write_antennas(spec, dir, &images, &origin, layout.base, &mut rng)?;
    write(dir, "project.toml", &project_toml(spec, npx))?;
    let measurements = meas.len();
    Ok(BlockTruth {
        origin,
        images,
        points,
        t_first: T_FIRST,
        blunders,
        wrong_gcp: wrong,
        measurements,
    })
}

/// The camera the images are simulated with: the nominal one with the spec's true principal
/// distance, principal point and k1.
fn true_camera(spec: &BlockSpec, nominal: &Camera) -> Camera {
    let mut cam = *nominal;
    cam.f += spec.true_focal_delta_mm * 1e-3;
    cam.x0 = spec.true_principal_point_mm[0] * 1e-3;
    cam.y0 = spec.true_principal_point_mm[1] * 1e-3;
    cam.k[0] = spec.true_k1;
    cam
}

/// The exposures strip by strip (alternate strips flown west), each with a random tilt and
/// a few metres of position noise, timed at the spec's speed with a turn between strips.
fn fly_strips(spec: &BlockSpec, layout: &Layout, rng: &mut Rng) -> Vec<Image> {
    let mut t = T_FIRST;
    let mut images = Vec::new();
    for (s, &n) in spec.strips.iter().enumerate() {
        let east = s % 2 == 0;
        for k in 0..n {
            let i = if east { k } else { n - 1 - k };
            let (x, y) = (i as f64 * layout.base, s as f64 * layout.spacing);
            let heading = if east { 0.0 } else { std::f64::consts::PI };
            let sd = spec.tilt_sigma_deg.to_radians();
            let tilt = Angles::OmegaPhiKappa {
                omega: sd * rng.normal(),
                phi: sd * rng.normal(),
                kappa: sd * rng.normal(),
            }
            .matrix();
            let z = layout.height + spec.ground_h * 0.0 + 3.0 * rng.normal();
            let pose = Pose {
                r: rot_z(heading) * tilt,
                centre: Vector3::new(x + 2.0 * rng.normal(), y + 2.0 * rng.normal(), z),
            };
            images.push((format!("{}{:02}", s + 1, i + 1), s, pose, t));
            t += layout.base / spec.speed;
        }
        t += spec.turn_s;
    }
    images
}

/// Ground points on the terrain: four corner control points (when asked), check points over
/// the block, tie points a little beyond it.
fn place_points(spec: &BlockSpec, layout: &Layout, n_images: usize, rng: &mut Rng) -> Vec<Point> {
    let (xmax, ymax) = layout.extent(spec);
    let (foot, base) = (layout.foot, layout.base);
    // Across the outer strips: 90 % of the measurable half-width.
    let margin = 0.9 * spec.scale * (layout.fmt / 2.0 - 0.005);
    let mut points: Vec<Point> = Vec::new();
    let ground = |x: f64, y: f64| Vector3::new(x, y, terrain(spec.relief, x, y));
    if spec.corner_gcps {
        let inset = 0.06 * foot;
        let last = spec.strips.len().saturating_sub(1);
        let end =
            |s: usize| spec.strips.get(s).copied().unwrap_or(1).saturating_sub(1) as f64 * base;
        for (k, (x, y)) in [
            (inset, -margin),
            (end(0) - inset, -margin),
            (inset, ymax + margin),
            (end(last) - inset, ymax + margin),
        ]
        .iter()
        .enumerate()
        {
            points.push((format!("G{}", k + 1), "gcp", ground(*x, *y)));
        }
    }
    for k in 0..spec.checks {
        let (x, y) = (
            rng.range(0.0, xmax),
            rng.range(-0.3 * foot, ymax + 0.3 * foot),
        );
        points.push((format!("C{}", k + 1), "check", ground(x, y)));
    }
    let n_ties = spec.ties_per_image * n_images / 3;
    for k in 0..n_ties {
        let (x, y) = (
            rng.range(-0.4 * foot, xmax + 0.4 * foot),
            rng.range(-margin, ymax + margin),
        );
        points.push((format!("T{}", k + 1), "tie", ground(x, y)));
    }
    points
}

/// Noisy image coordinates of every point inside the measurable format (5 mm from the edge),
/// keeping points seen at least twice; also how often each point was seen.
fn measure(
    spec: &BlockSpec,
    layout: &Layout,
    cam: &Camera,
    images: &[Image],
    points: &[Point],
    rng: &mut Rng,
) -> (Vec<Measurement>, Vec<usize>) {
    let sig = spec.sigma_image_um * 1e-6;
    let lim = layout.fmt / 2.0 - 0.005;
    let mut meas: Vec<Measurement> = Vec::new();
    let near = Near::new(points);
    let fov = (2f64.sqrt() * lim / cam.f).atan();
    for (i, im) in images.iter().enumerate() {
        for k in near.candidates(&im.2, fov) {
            let p = &points[k];
            if let Some(xy) = cam.project(&im.2, &p.2) {
                if xy.x.abs() < lim && xy.y.abs() < lim {
                    meas.push((i, k, xy + Vector2::new(rng.normal(), rng.normal()) * sig));
                }
            }
        }
    }
    let mut count = vec![0usize; points.len()];
    for m in &meas {
        count[m.1] += 1;
    }
    meas.retain(|m| count[m.1] >= 2);
    (meas, count)
}

/// The points an image may see, found without projecting every point into every image
/// (which made the 10,000-image bench block take 82 s to simulate): the points sorted by
/// east, and per image those within the horizontal reach of its view cone above the lowest
/// point, in index order — so the measurements, and the random numbers drawn for them, are
/// exactly those of projecting every point.
struct Near {
    /// Point indices sorted by east, with their east and north.
    by_east: Vec<(f64, f64, usize)>,
    /// The lowest point's height.
    low: f64,
    /// How many points there are.
    n: usize,
}

impl Near {
    fn new(points: &[Point]) -> Near {
        let mut by_east: Vec<(f64, f64, usize)> = points
            .iter()
            .enumerate()
            .map(|(k, p)| (p.2.x, p.2.y, k))
            .collect();
        by_east.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.2.cmp(&b.2)));
        let low = points.iter().map(|p| p.2.z).fold(f64::INFINITY, f64::min);
        Near {
            by_east,
            low,
            n: points.len(),
        }
    }

    /// The indices, ascending, of the points within reach of a camera at `pose` whose format
    /// spans `fov` (half-angle of its diagonal, rad) around the axis; all points when the
    /// cone reaches near the horizon.
    fn candidates(&self, pose: &Pose, fov: f64) -> Vec<usize> {
        let axis = pose.r * Vector3::new(0.0, 0.0, -1.0);
        let tilt = (-axis.z).clamp(-1.0, 1.0).acos();
        // Distortion and rounding: a generous margin on the cone.
        let reach_angle = tilt + 1.1 * fov + 0.02;
        let depth = pose.centre.z - self.low;
        if reach_angle >= 80f64.to_radians() || depth <= 0.0 || !depth.is_finite() {
            return (0..self.n).collect();
        }
        let reach = depth * reach_angle.tan() * 1.01 + 1.0;
        let (cx, cy) = (pose.centre.x, pose.centre.y);
        let from = self.by_east.partition_point(|p| p.0 < cx - reach);
        let mut out: Vec<usize> = self.by_east[from..]
            .iter()
            .take_while(|p| p.0 <= cx + reach)
            .filter(|p| (p.0 - cx).hypot(p.1 - cy) <= reach)
            .map(|p| p.2)
            .collect();
        out.sort_unstable();
        out
    }
}

/// Gross errors of 60, 75, 90 … µm on tie-point measurements of points seen at least four
/// times; returns (image, point) of each.
fn inject_blunders(
    spec: &BlockSpec,
    meas: &mut [Measurement],
    count: &[usize],
    images: &[Image],
    points: &[Point],
    rng: &mut Rng,
) -> Vec<(String, String)> {
    let mut blunders = Vec::new();
    for b in 0..spec.image_blunders {
        let ties: Vec<usize> = (0..meas.len())
            .filter(|&j| points[meas[j].1].1 == "tie" && count[meas[j].1] >= 4)
            .collect();
        if ties.is_empty() {
            break;
        }
        let j = ties[(b * 7919 + 101) % ties.len()];
        let size = (60.0 + 15.0 * b as f64) * 1e-6;
        let a = rng.range(0.0, std::f64::consts::TAU);
        meas[j].2 += Vector2::new(a.cos(), a.sin()) * size;
        blunders.push((images[meas[j].0].0.clone(), points[meas[j].1].0.clone()));
    }
    blunders
}

/// How far the simulated tape measurement of the lever arm is off truth (m).
pub const TAPE_ERROR: [f64; 3] = [0.015, -0.010, 0.015];

/// The `[gnss]` section of a simulated project: the antenna table, the lever arm as a tape
/// measurement `tape_error` off truth with a 2 cm prior, drift per `group` with `model`.
pub fn gnss_section(spec: &BlockSpec, tape_error: [f64; 3], group: &str, model: &str) -> String {
    let l = spec.lever_arm;
    format!(
        "[gnss]\nantennas = \"antennas.csv\"\nlever_arm = [{}, {}, {}]\nlever_arm_sigma = [0.02, 0.02, 0.02]\ndrift = \"{group}\"\ndrift_model = \"{model}\"\n",
        l[0] + tape_error[0],
        l[1] + tape_error[1],
        l[2] + tape_error[2]
    )
}

/// Built-in simulated adjustment projects: `classic-block` (the 2-strip block, 4 corner GCPs,
/// tape-measured lever arm, linear drift), `close-range` (two stations), `block1000`
/// (20 strips × 50 photos for benchmarks), `nav-block` (navigation-grade GPS with a
/// latency, control only in a few images each; see [`nav`]), `sparse-control` (the same GNSS
/// over 290 images of which most measure one control point) and `textured-block` (3 × 8
/// rendered photos with exact truth, for feature matchers; see [`textured`]). Returns a
/// one-line summary.
pub fn builtin(name: &str, dir: &Path) -> Option<Result<String, SimError>> {
    builtin_seeded(name, dir, None)
}

/// [`builtin`] drawn from `seed` instead of the project's own (another realisation of the
/// same block: noise, blunders, terrain and points; the layout stays).
pub fn builtin_seeded(
    name: &str,
    dir: &Path,
    seed: Option<u64>,
) -> Option<Result<String, SimError>> {
    let seeded = |own: u64| seed.unwrap_or(own);
    let classic_gnss = |spec: &BlockSpec| gnss_section(spec, TAPE_ERROR, "block", "linear");
    let aerial_summary = |spec: BlockSpec| {
        aerial(&spec, dir).map(|t| {
            format!(
                "{}: {} images, {} points, {} image measurements → {}",
                spec.name,
                t.images.len(),
                t.points.len(),
                t.measurements,
                dir.join("project.toml").display()
            )
        })
    };
    match name {
        "classic-block" => {
            let mut spec = BlockSpec::classic();
            spec.seed = seeded(spec.seed);
            spec.project_options = classic_gnss(&spec);
            Some(aerial_summary(spec))
        }
        "block1000" => {
            let mut spec = BlockSpec::large(20, 50);
            spec.seed = seeded(spec.seed);
            spec.project_options = classic_gnss(&spec);
            Some(aerial_summary(spec))
        }
        "close-range" => Some(
            super::closerange::close_range(
                &super::closerange::CloseRangeSpec {
                    seed: seeded(super::closerange::CloseRangeSpec::default().seed),
                    ..Default::default()
                },
                dir,
            )
            .map(
                |t| {
                    format!(
                        "close-range pair: {} stations, {} points → {}",
                        t.poses.len(),
                        t.points.len(),
                        dir.join("project.toml").display()
                    )
                },
            ),
        ),
        "nav-block" => Some(nav_block(&NavSpec { seed: seeded(NavSpec::awkward().seed), ..NavSpec::awkward() }, dir).map(|t| {
            format!(
                "nav-block: {} images ({} without measurements), {} ground points, {} image measurements, GNSS latency {} s → {} (and project_gcp_only.toml)",
                t.images.len(),
                t.per_image.iter().filter(|n| **n == 0).count(),
                t.points.len(),
                t.measurements,
                nav::LATENCY_S,
                dir.join("project.toml").display()
            )
        })),
        "sparse-control" => Some(nav_block(&NavSpec { seed: seeded(NavSpec::sparse_control().seed), ..NavSpec::sparse_control() }, dir).map(|t| {
            let per = |n: usize| t.control_per_image.iter().filter(|&&c| c == n).count();
            format!(
                "sparse-control: {} images (control measured: {} in one, {} in two, {} in three, {} in four or more), {} ground points, {} image measurements, GNSS offset 14 m, latency {} s → {} (and project_gcp_only.toml)",
                t.images.len(),
                per(1),
                per(2),
                per(3),
                t.control_per_image.iter().filter(|&&c| c >= 4).count(),
                t.points.len(),
                t.measurements,
                nav::LATENCY_S,
                dir.join("project.toml").display()
            )
        })),
        "textured-block" => Some(textured::textured_block(&textured::TexturedSpec { seed: seeded(textured::TexturedSpec::builtin().seed), ..textured::TexturedSpec::builtin() }, dir).map(|r| {
            format!(
                "textured-block: {} images of {} × {} px rendered in {:.1} s into {}, {} points, {} exact image measurements → {}",
                r.images,
                r.size_px.0,
                r.size_px.1,
                r.render_seconds,
                dir.join("photos").display(),
                r.points,
                r.measurements,
                dir.join("project.toml").display()
            )
        })),
        _ => None,
    }
}

/// Names of the built-in adjustment projects.
pub const BUILTINS: [&str; 6] = [
    "classic-block",
    "close-range",
    "block1000",
    "nav-block",
    "sparse-control",
    "textured-block",
];

#[cfg(test)]
mod tests {
    use super::*;

    /// The view-cone prefilter never leaves out a point that projects into the format: every
    /// image of a tilted, self-calibrated block sees exactly what projecting every point sees.
    #[test]
    fn the_prefilter_keeps_every_visible_point() {
        for spec in [BlockSpec::classic(), BlockSpec::large(4, 30)] {
            let mut rng = Rng::new(spec.seed);
            let npx = (spec.format_mm * 1e3 / spec.pixel_um).round() as usize;
            let nominal = Camera::ideal(spec.focal_mm * 1e-3, spec.pixel_um * 1e-6, npx, npx);
            let cam = true_camera(&spec, &nominal);
            let layout = Layout::of(&spec);
            let images = fly_strips(&spec, &layout, &mut rng);
            let points = place_points(&spec, &layout, images.len(), &mut rng);
            let lim = layout.fmt / 2.0 - 0.005;
            let near = Near::new(&points);
            let fov = (2f64.sqrt() * lim / cam.f).atan();
            let mut seen = 0;
            for im in &images {
                let all: Vec<usize> = (0..points.len())
                    .filter(|&k| {
                        cam.project(&im.2, &points[k].2)
                            .is_some_and(|xy| xy.x.abs() < lim && xy.y.abs() < lim)
                    })
                    .collect();
                let cand = near.candidates(&im.2, fov);
                assert!(cand.len() < points.len() / 2, "a real cut: {}", cand.len());
                assert!(all.iter().all(|k| cand.binary_search(k).is_ok()));
                seen += all.len();
            }
            assert!(seen > 10 * images.len(), "{seen}");
        }
    }
}
