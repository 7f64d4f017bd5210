//! Simulated photogrammetric blocks with known truth, written as a ready-to-run `ppkat adjust`
//! project: an aerial block flown in strips (the classic 2-strip test block, or a large one
//! for benchmarks) with GNSS antenna positions carrying a lever arm, a drift and correlated
//! noise; or a close-range pair of terrestrial stations. Deterministic per seed.
//!
//! Frame: ENU tangent plane at the site (`lat`, `lon`, `ground_h`); files carry geodetic
//! coordinates, so the adjustment sees only what a user would give it.

use super::rng::Rng;
use super::{write, SimError};
use crate::exposure::export::{antenna_table, AntennaRow};
use gnss::frame::{enu_rotation, Enu, Geodetic};
use nalgebra::{Matrix3, Vector2, Vector3};
use photo::camera::{Camera, Pose};
use photo::rotation::{rot_z, Angles};
use std::fmt::Write as _;
use std::path::Path;

/// An aerial block.
#[derive(Clone, Debug)]
pub struct BlockSpec {
    pub name: String,
    pub seed: u64,
    pub lat_deg: f64,
    pub lon_deg: f64,
    pub ground_h: f64,
    pub focal_mm: f64,
    /// Square format side, mm.
    pub format_mm: f64,
    pub pixel_um: f64,
    /// Photo scale denominator (flying height = scale · f).
    pub scale: f64,
    pub forward_overlap: f64,
    pub side_overlap: f64,
    /// Photos in each strip (alternate strips are flown in opposite directions).
    pub strips: Vec<usize>,
    pub speed: f64,
    /// Time between strips (turn), seconds.
    pub turn_s: f64,
    /// Terrain relief amplitude, m.
    pub relief: f64,
    pub tilt_sigma_deg: f64,
    pub sigma_image_um: f64,
    /// Tie points per image on average.
    pub ties_per_image: usize,
    pub checks: usize,
    /// Four corner control points.
    pub corner_gcps: bool,
    pub gcp_sigma: [f64; 3],
    /// GNSS antenna σ per axis (E, N, U) and the E–N, E–U, N–U correlations.
    pub gnss_sigma: [f64; 3],
    pub gnss_corr: [f64; 3],
    /// Lever arm (u, v, w), camera frame, m.
    pub lever_arm: [f64; 3],
    /// Drift a + b·(t − t_first) over the whole block, m and m/s.
    pub drift_a: [f64; 3],
    pub drift_b: [f64; 3],
    pub image_blunders: usize,
    /// A control point with a wrong coordinate: shift (E, N, U) in metres.
    pub wrong_gcp: Option<[f64; 3]>,
    /// The true camera differs from the nominal one written to the project: principal
    /// distance (mm), principal point (mm), radial k1 (1/m²) — for self-calibration.
    pub true_focal_delta_mm: f64,
    pub true_principal_point_mm: [f64; 2],
    pub true_k1: f64,
    /// An ambiguity re-fix in the trajectory: from this image on (in flight order) the
    /// antenna positions carry this extra offset (m) and a new segment id.
    pub segment_jump: Option<(usize, [f64; 3])>,
    /// Extra lines for the project's `[[camera]]` (e.g. `self_calibrate = [...]`).
    pub camera_options: String,
    /// The `[gnss]` and `[adjustment]` sections of the project written with it.
    pub project_options: String,
}

impl BlockSpec {
    /// The classic test block: 2 strips, 29 photos, f = 152 mm, 23 cm format, 1:8000, 60 %
    /// forward overlap; GNSS σ 5 cm with correlations and a linear drift; 4 corner GCPs.
    pub fn classic() -> BlockSpec {
        BlockSpec {
            name: "classic 2-strip block 1:8000".into(),
            seed: 8000,
            lat_deg: 30.52,
            lon_deg: 114.36,
            ground_h: 35.0,
            focal_mm: 152.0,
            format_mm: 230.0,
            pixel_um: 10.0,
            scale: 8000.0,
            forward_overlap: 0.6,
            side_overlap: 0.3,
            strips: vec![15, 14],
            speed: 70.0,
            turn_s: 150.0,
            relief: 40.0,
            tilt_sigma_deg: 1.0,
            sigma_image_um: 5.0,
            ties_per_image: 40,
            checks: 40,
            corner_gcps: true,
            gcp_sigma: [0.02, 0.02, 0.03],
            gnss_sigma: [0.05, 0.05, 0.05],
            gnss_corr: [0.2, 0.3, 0.1],
            lever_arm: [0.12, -0.05, 1.45],
            drift_a: [0.25, -0.18, 0.30],
            drift_b: [0.0008, -0.0005, 0.0012],
            image_blunders: 0,
            wrong_gcp: None,
            true_focal_delta_mm: 0.0,
            true_principal_point_mm: [0.0; 2],
            true_k1: 0.0,
            segment_jump: None,
            camera_options: String::new(),
            project_options: String::new(),
        }
    }

    /// A large block for benchmarks: `strips` × `per_strip` photos (1:5000, 80 mm lens).
    pub fn large(strips: usize, per_strip: usize) -> BlockSpec {
        BlockSpec {
            name: format!("{strips}×{per_strip} benchmark block"),
            seed: 1000,
            focal_mm: 80.0,
            format_mm: 60.0,
            pixel_um: 6.0,
            scale: 5000.0,
            side_overlap: 0.3,
            strips: vec![per_strip; strips],
            turn_s: 60.0,
            ties_per_image: 60,
            checks: 50,
            drift_a: [0.0; 3],
            ..BlockSpec::classic()
        }
    }
}

/// What the simulation knows.
#[derive(Clone, Debug)]
pub struct BlockTruth {
    pub origin: Geodetic,
    /// Image id, strip, pose (ENU at the origin), GPST seconds.
    pub images: Vec<(String, usize, Pose, f64)>,
    /// Point id, kind (gcp|check|tie), ENU.
    pub points: Vec<(String, &'static str, Vector3<f64>)>,
    pub t_first: f64,
    /// (image, point) of every blundered measurement.
    pub blunders: Vec<(String, String)>,
    pub wrong_gcp: Option<String>,
    pub measurements: usize,
}

fn terrain(relief: f64, x: f64, y: f64) -> f64 {
    relief * (0.6 * (x / 1700.0).sin() * (y / 1300.0).cos() + 0.4 * ((x + y) / 2900.0).sin())
}

/// An image of a simulated block: id, strip (from 0), pose (ENU at the origin), GPST seconds.
type Image = (String, usize, Pose, f64);

/// A ground point: id, kind (`gcp`, `check` or `tie`), ENU at the origin.
pub(super) type Point = (String, &'static str, Vector3<f64>);

/// An image measurement: image index, point index, image coordinates (m).
type Measurement = (usize, usize, Vector2<f64>);

/// GPST seconds of the first exposure of a block.
const T_FIRST: f64 = 1_400_000_000.0 + 3600.0 * 3.0;

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
    for (i, im) in images.iter().enumerate() {
        for (k, p) in points.iter().enumerate() {
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

/// `images.csv`: image, camera, strip (from 1), GPS week and seconds of week.
fn images_table(images: &[Image]) -> String {
    let mut s = String::from("image,camera,strip,week,tow\n");
    for im in images {
        let (week, tow) = gnss::time::week_tow(gnss::time::from_week_tow(0, im.3));
        let _ = writeln!(s, "{},cam,{},{week},{tow:.6}", im.0, im.1 + 1);
    }
    s
}

/// `image_observations.csv`: the measurements in pixels of the nominal camera.
fn measurements_table(
    spec: &BlockSpec,
    nominal: &Camera,
    meas: &[Measurement],
    images: &[Image],
    points: &[Point],
) -> String {
    let mut s = String::from("image,point,x_px,y_px,sigma_px\n");
    for (i, k, xy) in meas {
        let px = nominal.image_to_pixel(*xy);
        let _ = writeln!(
            s,
            "{},{},{:.3},{:.3},{}",
            images[*i].0,
            points[*k].0,
            px.x,
            px.y,
            spec.sigma_image_um / spec.pixel_um
        );
    }
    s
}

/// Geodetic coordinates of a point of the ENU frame at `origin`.
pub(super) fn geodetic(origin: &Geodetic, v: &Vector3<f64>) -> Geodetic {
    Enu(*v).to_ecef(&origin.to_ecef()).to_geodetic()
}

/// Write `ground_points.csv` (point, kind, lat, lon in degrees, h and sigmas in metres) for
/// the control and check points given (ENU at `origin`). Control points are observed with
/// noise of σ = (σ_xy, σ_xy, σ_z) = `sigma` per ENU axis drawn from `rng`; the first one also
/// carries the `wrong` shift (E, N, U, metres) when given — its id is returned.
pub(super) fn write_ground_points<'a>(
    dir: &Path,
    points: impl IntoIterator<Item = &'a Point>,
    sigma: (f64, f64),
    wrong: Option<[f64; 3]>,
    origin: &Geodetic,
    rng: &mut Rng,
) -> Result<Option<String>, SimError> {
    let (sx, sz) = sigma;
    let mut s = String::from("point,kind,lat,lon,h,sigma_xy,sigma_z\n");
    let mut wrong_id = None;
    for (id, kind, x) in points {
        let mut v = *x;
        if *kind == "gcp" {
            v += Vector3::new(sx * rng.normal(), sx * rng.normal(), sz * rng.normal());
            if let (Some(d), None) = (wrong, &wrong_id) {
                v += Vector3::from(d);
                wrong_id = Some(id.clone());
            }
        }
        let g = geodetic(origin, &v);
        let _ = writeln!(
            s,
            "{id},{kind},{:.10},{:.10},{:.4},{sx},{sz}",
            g.lat.to_degrees(),
            g.lon.to_degrees(),
            g.h
        );
    }
    write(dir, "ground_points.csv", &s)?;
    Ok(wrong_id)
}

/// The GNSS antenna covariance in the site's ENU frame (m²) from the spec's σ and
/// correlations, and its Cholesky factor (the diagonal of σ when not positive definite).
fn gnss_covariance(spec: &BlockSpec) -> (Matrix3<f64>, Matrix3<f64>) {
    let [se, sn, su] = spec.gnss_sigma;
    let [ren, reu, rnu] = spec.gnss_corr;
    let cov = Matrix3::new(
        se * se,
        ren * se * sn,
        reu * se * su,
        ren * se * sn,
        sn * sn,
        rnu * sn * su,
        reu * se * su,
        rnu * sn * su,
        su * su,
    );
    let l = cov
        .cholesky()
        .map(|c| c.l())
        .unwrap_or_else(|| Matrix3::from_diagonal(&Vector3::from(spec.gnss_sigma)));
    (cov, l)
}

/// Write `antennas.csv` (antenna = centre + R·lever arm + drift + correlated noise, with the
/// segment jump) and `trajectory.pos` (the same antennas as a fixed trajectory, with epochs
/// every air-base interval through the turns so that it has no gaps).
fn write_antennas(
    spec: &BlockSpec,
    dir: &Path,
    images: &[Image],
    origin: &Geodetic,
    air_base: f64,
    rng: &mut Rng,
) -> Result<(), SimError> {
    let (cov, l) = gnss_covariance(spec);
    let mut rows = Vec::new();
    let mut track: Vec<gnss::solution::PosRecord> = Vec::new();
    for (k, im) in images.iter().enumerate() {
        let dt = im.3 - T_FIRST;
        let mut drift = Vector3::from(spec.drift_a) + Vector3::from(spec.drift_b) * dt;
        let segment = match spec.segment_jump {
            Some((from, jump)) if k >= from => {
                drift += Vector3::from(jump);
                1
            }
            _ => 0,
        };
        let noise = l * Vector3::new(rng.normal(), rng.normal(), rng.normal());
        let lever = photo::lever::LeverArm::new(Vector3::from(spec.lever_arm));
        let a = lever.antenna(&im.2.centre, &im.2.r) + drift + noise;
        let g = geodetic(origin, &a);
        // Noise drawn in the site ENU: express the covariance in the ENU at the antenna.
        let ra = enu_rotation(&g);
        let m = ra * enu_rotation(origin).transpose();
        let c = m * cov * m.transpose();
        let time = gnss::time::from_week_tow(0, im.3);
        let rec = gnss::solution::PosRecord {
            time,
            pos: g.to_ecef(),
            quality: gnss::solution::Quality::Fixed,
            nsat: 12,
            cov: ra.transpose() * c * ra,
            age: 0.0,
            ratio: 99.0,
        };
        bridge_turn(&mut track, &rec, air_base / spec.speed);
        track.push(rec);
        rows.push(AntennaRow {
            id: &im.0,
            time,
            pos: g,
            cov_enu: c,
            quality: 1,
            segment,
            opk_deg: None,
        });
    }
    write(
        dir,
        "antennas.csv",
        &antenna_table(
            "simulated: antenna = centre + R*lever + drift + noise",
            &rows,
        ),
    )?;
    gnss::solution::write_pos(
        &dir.join("trajectory.pos"),
        &["program   : ppkat simulate (block antenna trajectory)".to_string()],
        &track,
        gnss::solution::PosFormat::Llh,
    )?;
    Ok(())
}

/// Epochs every `step` seconds on the straight line from the last record of `track` to
/// `next` (through the turns: their positions matter to nobody, they keep the trajectory
/// free of gaps).
fn bridge_turn(
    track: &mut Vec<gnss::solution::PosRecord>,
    next: &gnss::solution::PosRecord,
    step: f64,
) {
    let Some(prev) = track.last().cloned() else {
        return;
    };
    let gap = (next.time - prev.time).to_seconds();
    let n = (gap / step).floor() as usize;
    for j in 1..n {
        let f = j as f64 / n as f64;
        let mut mid = prev.clone();
        mid.time = prev.time + hifitime::Duration::from_seconds(gap * f);
        mid.pos = gnss::frame::Ecef(prev.pos.0 * (1.0 - f) + next.pos.0 * f);
        track.push(mid);
    }
}

/// The project file: one camera (nominal values), the tables, the spec's extra sections.
fn project_toml(spec: &BlockSpec, npx: usize) -> String {
    format!(
        "name = \"{}\"\noutput = \"utm\"\n\n[[camera]]\nid = \"cam\"\nfocal_mm = {}\npixel_um = {}\nwidth_px = {npx}\nheight_px = {npx}\nsigma_px = {}\n{}\n[images]\nlist = \"images.csv\"\nmeasurements = \"image_observations.csv\"\n\n[ground]\nfile = \"ground_points.csv\"\n\n{}",
        spec.name, spec.focal_mm, spec.pixel_um, spec.sigma_image_um / spec.pixel_um, spec.camera_options, spec.project_options
    )
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
/// tape-measured lever arm, linear drift), `close-range` (two stations) and `block1000`
/// (20 strips × 50 photos for benchmarks). Returns a one-line summary.
pub fn builtin(name: &str, dir: &Path) -> Option<Result<String, SimError>> {
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
            spec.project_options = classic_gnss(&spec);
            Some(aerial_summary(spec))
        }
        "block1000" => {
            let mut spec = BlockSpec::large(20, 50);
            spec.project_options = classic_gnss(&spec);
            Some(aerial_summary(spec))
        }
        "close-range" => Some(
            super::closerange::close_range(&super::closerange::CloseRangeSpec::default(), dir).map(
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
        _ => None,
    }
}

/// Names of the built-in adjustment projects.
pub const BUILTINS: [&str; 3] = ["classic-block", "close-range", "block1000"];
