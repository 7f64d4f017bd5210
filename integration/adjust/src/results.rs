//! The numbers of an adjusted block, ready for the report: orientations and points with σ
//! (local frame, geodetic, projected), lever arm, drift, self-calibration, variance components,
//! reliability (redundancy, minimal detectable blunders), removed observations, residuals and
//! the check-point table.

use super::error::AdjustError;
pub use super::estimated::Estimated;
use super::factors::DriftModel;
use super::project::{Mode, PointKind, Project};
pub use super::quality::{GroupQuality, Removed};
pub use super::residuals::{
    ControlResidual, DistanceResidual, GnssResidual, ImageResidual, DELTA0,
};
use super::solve::Solved;
use nalgebra::{DMatrix, Vector3};
use photo::lsq::{CameraId, DriftId, ImageId, Key, PointId, Problem, Value};
use photo::rotation::Angles;
use serde::Serialize;

/// A position in the local frame, geodetic and in the output projection.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Position {
    /// Position, local ENU (m).
    pub local: [f64; 3],
    /// Latitude, degrees.
    pub lat: f64,
    /// Longitude, degrees.
    pub lon: f64,
    /// Ellipsoidal height, m.
    pub h: f64,
    /// Easting in the output projection (longitude when geodetic).
    pub easting: f64,
    /// Northing in the output projection (latitude when geodetic).
    pub northing: f64,
}

/// An adjusted image.
#[derive(Clone, Debug, Serialize)]
pub struct ImageResult {
    /// The image.
    pub id: String,
    /// Its strip.
    pub strip: String,
    /// The projection centre.
    #[serde(flatten)]
    pub position: Position,
    /// ω, φ, κ of R camera → local ENU, degrees.
    pub opk_deg: [f64; 3],
    /// σ of the centre, local E, N, U (m).
    pub sigma_centre: [f64; 3],
    /// σ of ω, φ, κ, degrees (the rotation covariance carried through the angle conversion).
    pub sigma_angles_deg: [f64; 3],
    /// Image measurements used.
    pub points: usize,
    /// RMS residual per coordinate, pixels.
    pub rms_px: f64,
}

/// An adjusted point.
#[derive(Clone, Debug, Serialize)]
pub struct PointResult {
    /// The point.
    pub id: String,
    /// Control, check or tie.
    pub kind: PointKind,
    /// Where it is.
    #[serde(flatten)]
    pub position: Position,
    /// σ, local E, N, U (m).
    pub sigma: [f64; 3],
    /// Image measurements of the point.
    pub rays: usize,
}

/// A check point against its known coordinates.
#[derive(Clone, Debug, Serialize)]
pub struct CheckPoint {
    /// The point.
    pub id: String,
    /// Adjusted − known, local E, N, U (m).
    pub d: [f64; 3],
    /// Theoretical σ of the adjusted point (m).
    pub sigma: [f64; 3],
    /// Adjusted − known as latitude and longitude (arc seconds) and height (m).
    pub dlat_arcsec: f64,
    /// Adjusted − known longitude, arc seconds.
    pub dlon_arcsec: f64,
    /// Adjusted − known height, m.
    pub dh: f64,
}

/// The check-point table and its summary.
#[derive(Clone, Debug, Default, Serialize)]
pub struct CheckTable {
    /// Every check point, in natural order.
    pub points: Vec<CheckPoint>,
    /// Mean difference, E, N, U (m).
    pub mean: [f64; 3],
    /// RMS difference, E, N, U (m).
    pub rms: [f64; 3],
    /// Largest |difference|, E, N, U (m).
    pub max: [f64; 3],
    /// √(mean σ²) per axis: the RMS the adjustment's own covariance predicts.
    pub theoretical_rms: [f64; 3],
}

/// Everything an adjustment produced, for the reports (`report.json` is this, serialised).
#[derive(Clone, Debug, Serialize)]
pub struct Results {
    /// The project's name.
    pub name: String,
    /// Aerial or close range.
    pub mode: Mode,
    /// The output coordinate system.
    pub crs: String,
    /// Origin of the local frame: latitude, longitude (degrees), height (m).
    pub origin_deg: [f64; 3],
    /// A posteriori σ of unit weight.
    pub sigma0: f64,
    /// Redundancy (observations − unknowns).
    pub redundancy: f64,
    /// Residual components.
    pub observations: usize,
    /// Free unknowns.
    pub unknowns: usize,
    /// Iterations of the last solve.
    pub iterations: usize,
    /// Critical |w| of data snooping.
    pub critical_w: f64,
    /// The images.
    pub images: Vec<ImageResult>,
    /// The points.
    pub points: Vec<PointResult>,
    /// Lever arms per camera.
    pub lever_arms: Vec<Estimated>,
    /// Boresight misalignment per camera with attitude observations (degrees).
    pub boresights: Vec<Estimated>,
    /// Drift per group.
    pub drifts: Vec<Estimated>,
    /// GNSS latency δ per group (s; see `adjust::latency` for its sign).
    pub latencies: Vec<Estimated>,
    /// Interior orientations estimated by self-calibration.
    pub interiors: Vec<Estimated>,
    /// Reliability per observation group.
    pub groups: Vec<GroupQuality>,
    /// What data snooping removed.
    pub removed: Vec<Removed>,
    /// What data snooping found suspect but kept, because removing it would have left a
    /// parameter undetermined (|w| when found).
    pub kept_suspects: Vec<Removed>,
    /// The check-point table.
    pub checks: CheckTable,
    /// Image residuals.
    pub image_residuals: Vec<ImageResidual>,
    /// Control-point residuals.
    pub control_residuals: Vec<ControlResidual>,
    /// GNSS residuals.
    pub gnss_residuals: Vec<GnssResidual>,
    /// Measured distances between points, with their residuals.
    pub distance_residuals: Vec<DistanceResidual>,
    /// What the user should know (inputs left out, float positions …).
    pub warnings: Vec<String>,
    /// Images and points left out of the adjustment, each with the reason (also among the
    /// warnings): the run finished without them.
    pub left_out: Vec<String>,
    /// How the block was started when from its tie points alone.
    pub start_note: Option<String>,
    /// Tight coupling: ambiguities fixed before and after, per exposure (None: loose).
    pub tight: Option<super::tight_report::TightSummary>,
    /// The solver's timed stages (solves, cofactor computations), for benchmarks; not
    /// written to the reports (their bytes must not depend on the machine).
    #[serde(skip)]
    pub timings: Vec<photo::lsq::Timing>,
}

/// σ of ω, φ, κ from the covariance of the rotation's left perturbation (first 3×3 of the
/// pose covariance): J·Σ·Jᵀ with J = ∂(ω, φ, κ)/∂δ by central differences.
fn opk_sigmas(r: &nalgebra::Matrix3<f64>, c: &DMatrix<f64>) -> [f64; 3] {
    let angles = |m: &nalgebra::Matrix3<f64>| match Angles::omega_phi_kappa(m) {
        Angles::OmegaPhiKappa { omega, phi, kappa } => [omega, phi, kappa],
        _ => [0.0; 3],
    };
    let wrap = |a: f64| {
        (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
    };
    let h = 1e-6;
    let mut j = nalgebra::Matrix3::<f64>::zeros();
    for k in 0..3 {
        let mut d = Vector3::zeros();
        d[k] = h;
        let a = angles(&(photo::rotation::exp_so3(&d) * r));
        let b = angles(&(photo::rotation::exp_so3(&-d) * r));
        for i in 0..3 {
            j[(i, k)] = wrap(a[i] - b[i]) / (2.0 * h);
        }
    }
    let s = nalgebra::Matrix3::from_fn(|i, k| c[(i, k)]);
    let q = j * s * j.transpose();
    [0, 1, 2].map(|i| q[(i, i)].max(0.0).sqrt())
}

fn sig3(c: &DMatrix<f64>, o: usize) -> [f64; 3] {
    [0, 1, 2].map(|i| c[(o + i, o + i)].max(0.0).sqrt())
}

fn estimated(
    name: String,
    labels: &[&str],
    pr: &Problem,
    key: Key,
    cov: Option<&DMatrix<f64>>,
    t0: f64,
) -> Estimated {
    let v = pr
        .value(key)
        .and_then(Value::vector)
        .cloned()
        .unwrap_or_default();
    Estimated {
        name,
        values: v.iter().copied().collect(),
        sigmas: (0..v.len())
            .map(|i| cov.map(|c| c[(i, i)].max(0.0).sqrt()).unwrap_or(0.0))
            .collect(),
        labels: labels.iter().map(|s| s.to_string()).collect(),
        t0,
        fixed: pr.is_fixed(key),
    }
}

/// What every part of the results reads: the problem, its frame, the output projection, the
/// covariances of every block and the reliability of every factor.
struct Context<'a> {
    pr: &'a Problem,
    frame: &'a super::frame::LocalFrame,
    tm: Option<common::tmerc::TransverseMercator>,
    keys: Vec<Key>,
    covs: photo::lsq::Covariances,
}

impl Context<'_> {
    /// A local point, geodetic and projected (lon/lat when the output is geodetic).
    fn project(&self, v: &Vector3<f64>) -> (gnss::frame::Geodetic, Position) {
        let g = self.frame.to_ecef(v).to_geodetic();
        let (easting, northing) = self
            .tm
            .as_ref()
            .map(|t| {
                let q = t.forward(&g);
                (q.easting, q.northing)
            })
            .unwrap_or((g.lon.to_degrees(), g.lat.to_degrees()));
        let p = Position {
            local: [v.x, v.y, v.z],
            lat: g.lat.to_degrees(),
            lon: g.lon.to_degrees(),
            h: g.h,
            easting,
            northing,
        };
        (g, p)
    }

    /// The covariance of a block.
    fn cov_of(&self, key: Key) -> Option<&DMatrix<f64>> {
        self.keys
            .iter()
            .position(|w| *w == key)
            .and_then(|i| self.covs[i].as_ref())
    }
}

/// The numbers of an adjusted block, read from the problem and its factors.
pub fn collect(p: &Project, s: &Solved) -> Result<Results, AdjustError> {
    let b = &s.built;
    let pr = &b.problem;
    let (tm, crs) = match p.output.mercator(&b.frame.geodetic) {
        Some((t, n)) => (Some(t), n),
        None => (None, "WGS84 geodetic".to_string()),
    };
    // Covariances of every block and the reliability of every factor in one pass.
    let keys: Vec<Key> = pr.keys().to_vec();
    let (covs, rel) = pr.statistics(&keys, s.stats.sigma0)?;
    let ctx = Context {
        pr,
        frame: &b.frame,
        tm,
        keys,
        covs,
    };
    let res = super::residuals::collect(p, s, &rel);
    let (points, checks, not_compared) = point_results(p, b, &ctx, s.stats.sigma0);
    let g = &b.frame.geodetic;
    let kept: Vec<Removed> = pr
        .kept_suspects()
        .iter()
        .map(|&(k, w)| super::quality::removed_observation(p, b, k, w))
        .collect();
    let groups = super::quality::groups(p, s, &rel);
    let misweighted = super::quality::misweighted(&groups);
    Ok(Results {
        name: p.file.name.clone(),
        mode: p.file.mode,
        crs,
        origin_deg: [g.lat.to_degrees(), g.lon.to_degrees(), g.h],
        sigma0: s.stats.sigma0,
        redundancy: s.stats.redundancy,
        observations: s.stats.observations,
        unknowns: s.stats.unknowns,
        iterations: s.stats.iterations,
        critical_w: s.critical,
        images: image_results(p, &ctx, &res.per_image),
        points,
        lever_arms: lever_arms(p, &ctx),
        boresights: super::attitude::boresights(p, pr, |k| ctx.cov_of(k)),
        drifts: drifts(b, &ctx),
        latencies: latencies(b, &ctx),
        interiors: interiors(p, &ctx),
        groups,
        removed: s
            .removed
            .iter()
            .map(|&(k, w)| super::quality::removed_observation(p, b, k, w))
            .collect(),
        kept_suspects: kept.clone(),
        checks,
        image_residuals: res.image,
        control_residuals: res.control,
        gnss_residuals: res.gnss,
        distance_residuals: res.distance,
        tight: super::tight_report::summary(p, s),
        start_note: b.start_note.clone(),
        left_out: b
            .left_out
            .iter()
            .map(|(what, why)| format!("{what}: {why}"))
            .collect(),
        warnings: misweighted
            .into_iter()
            .chain(warnings(p, b))
            .chain(not_compared)
            .chain(kept.iter().map(|k| {
                format!(
                    "{} {} ({}): |w| {:.1} is above the critical {:.2}, but it is kept: removing it would leave a parameter undetermined; its σ is multiplied by 100 — check it",
                    k.kind, k.what, k.source, k.w, s.critical
                )
            }))
            .collect(),
        timings: pr.take_timings(),
    })
}

/// Every adjusted image's orientation with σ, its measurement count and RMS residual (`per_image`:
/// measurements and sum of squared pixel residuals).
fn image_results(p: &Project, ctx: &Context, per_image: &[(usize, f64)]) -> Vec<ImageResult> {
    p.images
        .iter()
        .enumerate()
        // Images left out (no block, or fixed with their factors removed) are not results.
        .filter(|(i, _)| {
            let key = Key::Pose(ImageId::from(*i));
            ctx.pr.contains(key) && !ctx.pr.is_fixed(key)
        })
        .map(|(i, im)| {
            let key = Key::Pose(ImageId::from(i));
            let pose =
                ctx.pr
                    .value(key)
                    .and_then(Value::pose)
                    .copied()
                    .unwrap_or(photo::camera::Pose {
                        r: nalgebra::Matrix3::identity(),
                        centre: Vector3::zeros(),
                    });
            let (_, position) = ctx.project(&pose.centre);
            let Angles::OmegaPhiKappa { omega, phi, kappa } = Angles::omega_phi_kappa(&pose.r)
            else {
                unreachable!("omega_phi_kappa returns that convention")
            };
            let c = ctx.cov_of(key);
            let (n_pts, ss) = per_image[i];
            ImageResult {
                id: im.id.clone(),
                strip: im.strip.clone(),
                position,
                opk_deg: [omega, phi, kappa].map(f64::to_degrees),
                sigma_centre: c.map(|c| sig3(c, 3)).unwrap_or_default(),
                sigma_angles_deg: c
                    .map(|c| opk_sigmas(&pose.r, c).map(f64::to_degrees))
                    .unwrap_or_default(),
                points: n_pts,
                rms_px: if n_pts > 0 {
                    (ss / (2 * n_pts) as f64).sqrt()
                } else {
                    0.0
                },
            }
        })
        .collect()
}

/// Every adjusted point with σ, and the check-point table.
fn point_results(
    p: &Project,
    b: &super::build::Built,
    ctx: &Context,
    sigma0: f64,
) -> (Vec<PointResult>, CheckTable, Vec<String>) {
    let mut rays = std::collections::BTreeMap::<&str, usize>::new();
    for m in &p.measurements {
        *rays.entry(m.point.as_str()).or_default() += 1;
    }
    let mut points = Vec::new();
    let mut checks = CheckTable::default();
    for (k, id) in b.point_names.iter().enumerate() {
        let key = Key::Point(PointId::from(k));
        let Some(x) = ctx.pr.value(key).and_then(Value::as_point) else {
            continue;
        };
        if ctx.pr.is_fixed(key) {
            // Left out as undetermined (named in the warnings).
            continue;
        }
        let (_, position) = ctx.project(&x);
        let ground = p.ground.iter().find(|g| &g.id == id);
        let kind = ground.map(|g| g.kind).unwrap_or(PointKind::Tie);
        let sigma = ctx.cov_of(key).map(|c| sig3(c, 0)).unwrap_or_default();
        points.push(PointResult {
            id: id.clone(),
            kind,
            position,
            sigma,
            rays: rays.get(id.as_str()).copied().unwrap_or(0),
        });
    }
    // Check points: intersected from the adjusted orientations, never adjusted.
    let (intersected, not_compared) = super::checks::intersect_checks(p, b, sigma0);
    for c in intersected {
        let Some(gp) = p.ground.iter().find(|g| g.id == c.id) else {
            continue;
        };
        let (g, position) = ctx.project(&c.x);
        let d = c.x - ctx.frame.to_local(&gp.pos);
        let kg = gp.pos.to_geodetic();
        // The difference's σ: the intersected point's and the known coordinates' own.
        let sd = [0, 1, 2].map(|a| (c.cov[(a, a)] + gp.sigma[a].powi(2)).max(0.0).sqrt());
        checks.points.push(CheckPoint {
            id: c.id.clone(),
            d: [d.x, d.y, d.z],
            sigma: sd,
            dlat_arcsec: (g.lat - kg.lat).to_degrees() * 3600.0,
            dlon_arcsec: (g.lon - kg.lon).to_degrees() * 3600.0,
            dh: g.h - kg.h,
        });
        points.push(PointResult {
            id: c.id,
            kind: PointKind::Check,
            position,
            sigma: [0, 1, 2].map(|a| c.cov[(a, a)].max(0.0).sqrt()),
            rays: c.rays,
        });
    }
    checks.summarise();
    (points, checks, not_compared)
}

impl CheckTable {
    /// Sort the points naturally (C2 before C10) and compute mean, RMS, max and the RMS the
    /// adjustment's own covariance predicts.
    fn summarise(&mut self) {
        self.points.sort_by_key(|c| natural(&c.id));
        let nc = self.points.len() as f64;
        if nc == 0.0 {
            return;
        }
        for a in 0..3 {
            let d = || self.points.iter().map(|c| c.d[a]);
            self.mean[a] = d().sum::<f64>() / nc;
            self.rms[a] = (d().map(|x| x * x).sum::<f64>() / nc).sqrt();
            self.max[a] = d().map(f64::abs).fold(0.0, f64::max);
            let s2 = self.points.iter().map(|c| c.sigma[a].powi(2)).sum::<f64>();
            self.theoretical_rms[a] = (s2 / nc).sqrt();
        }
    }
}

/// The lever arm of every camera with GNSS.
fn lever_arms(p: &Project, ctx: &Context) -> Vec<Estimated> {
    p.cameras
        .iter()
        .enumerate()
        .map(|(i, c)| (c, Key::LeverArm(CameraId::from(i))))
        .filter(|(_, k)| ctx.pr.contains(*k))
        .map(|(c, k)| {
            let name = format!("lever arm ({})", c.id);
            estimated(name, &["u", "v", "w"], ctx.pr, k, ctx.cov_of(k), 0.0)
        })
        .collect()
}

/// The drift of every drift group still in the adjustment (one left out is named among the
/// left out).
fn drifts(b: &super::build::Built, ctx: &Context) -> Vec<Estimated> {
    b.drifts
        .iter()
        .enumerate()
        .filter(|(i, _)| !ctx.pr.is_fixed(Key::Drift(DriftId::from(*i))))
        .map(|(i, d)| {
            let key = Key::Drift(DriftId::from(i));
            let labels: &[&str] = match d.model {
                DriftModel::Offset => &["aE", "aN", "aU"],
                DriftModel::Rate => &["bE", "bN", "bU"],
                DriftModel::Linear => &["aE", "aN", "aU", "bE", "bN", "bU"],
            };
            estimated(d.name.clone(), labels, ctx.pr, key, ctx.cov_of(key), d.t0)
        })
        .collect()
}

/// The latency of every latency group.
fn latencies(b: &super::build::Built, ctx: &Context) -> Vec<Estimated> {
    b.latencies
        .iter()
        .enumerate()
        .map(|(i, l)| {
            let key = Key::Latency(photo::lsq::LatencyId::from(i));
            let name = format!("GNSS latency ({})", l.name);
            estimated(name, &["dt"], ctx.pr, key, ctx.cov_of(key), 0.0)
        })
        .collect()
}

/// The estimated interior parameters of every self-calibrated camera.
fn interiors(p: &Project, ctx: &Context) -> Vec<Estimated> {
    const NAMES: [&str; 10] = ["f", "x0", "y0", "k1", "k2", "k3", "p1", "p2", "b1", "b2"];
    p.cameras
        .iter()
        .enumerate()
        .map(|(i, c)| (c, Key::Camera(CameraId::from(i))))
        .filter(|(_, k)| ctx.pr.contains(*k))
        .map(|(c, k)| {
            let labels: Vec<&str> = c.calibrate.iter().map(|&i| NAMES[i]).collect();
            let name = format!("interior ({})", c.id);
            estimated(name, &labels, ctx.pr, k, ctx.cov_of(k), 0.0)
        })
        .collect()
}

/// The project's warnings, points left out for a single ray, images and points left out as
/// undetermined, antennas of unknown images.
fn warnings(p: &Project, b: &super::build::Built) -> Vec<String> {
    let mut warnings = p.warnings.clone();
    if b.free_network {
        warnings.push(format!(
            "a free network: no control and no GNSS, so the coordinates are arbitrary (the datum is the inner constraints over the image centres; {}); image residuals, σ0, data snooping and the precision relative to the centres' centroid are the block's own",
            if p.distances.is_empty() { "the scale is that of the start values" } else { "the scale from the measured distances" }
        ));
    }
    if !b.single_ray.is_empty() {
        let list: Vec<String> = b
            .single_ray
            .iter()
            .take(10)
            .map(|(pt, im)| format!("{pt} ({im})"))
            .collect();
        warnings.push(format!(
            "{} point(s) measured in one image only are not adjusted: {}{}",
            b.single_ray.len(),
            list.join(", "),
            if b.single_ray.len() > 10 { ", …" } else { "" }
        ));
    }
    for (what, why) in &b.left_out {
        warnings.push(format!("{what} is left out of the adjustment: {why}"));
    }
    if !b.without_antenna.is_empty() {
        warnings.push(format!(
            "{} image(s) have no antenna record and are adjusted from their points only (first: {}): check their ids in the antenna table",
            b.without_antenna.len(),
            b.without_antenna[0]
        ));
    }
    if !b.unused_antennas.is_empty() {
        warnings.push(format!(
            "{} antenna record(s) name images not in the list (first: {})",
            b.unused_antennas.len(),
            b.unused_antennas[0]
        ));
    }
    warnings
}

/// A sort key that puts C2 before C10: the text before the first digit, then the number.
fn natural(id: &str) -> (String, u64, String) {
    let i = id.find(|c: char| c.is_ascii_digit()).unwrap_or(id.len());
    let j = id[i..]
        .find(|c: char| !c.is_ascii_digit())
        .map(|k| i + k)
        .unwrap_or(id.len());
    (
        id[..i].to_string(),
        id[i..j].parse().unwrap_or(0),
        id[j..].to_string(),
    )
}
