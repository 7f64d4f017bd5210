//! Residuals of an adjusted block with each observation's reliability: image points (pixels,
//! redundancy numbers, w), control points (with MDB per axis), GNSS antennas (local E, N, U).

use super::factors::GnssCentre;
use super::project::Project;
use super::solve::Solved;
use photo::factors::{Distance, ImagePoint, Prior};
use photo::lsq::{FactorId, Key, PointId, Reliability};
use serde::Serialize;

/// Lower bound of the non-centrality for α0 = 0.1 % (two-sided) and power 80 %: the minimal
/// detectable blunder is δ0·σ/√r (Baarda).
pub const DELTA0: f64 = 4.13;

/// An image measurement's residual with its reliability.
#[derive(Clone, Debug, Serialize)]
pub struct ImageResidual {
    /// The image.
    pub image: String,
    /// The point.
    pub point: String,
    /// Measured position and residual (predicted − measured), pixels.
    pub px: [f64; 2],
    /// Residual (predicted − measured), pixels (column, row).
    pub v_px: [f64; 2],
    /// Redundancy numbers and normalised residuals (Baarda's w) of x and y.
    pub r: [f64; 2],
    /// Normalised residuals (Baarda's w) of x and y.
    pub w: [f64; 2],
}

/// A control point's residual (adjusted − given, local E, N, U) with its reliability.
#[derive(Clone, Debug, Serialize)]
pub struct ControlResidual {
    /// The point.
    pub id: String,
    /// Adjusted − given, local E, N, U (m); NaN on an axis the point does not fix.
    pub v: [f64; 3],
    /// Redundancy numbers per axis.
    pub r: [f64; 3],
    /// Normalised residuals per axis.
    pub w: [f64; 3],
    /// Minimal detectable blunder per axis (m), None where the redundancy is ~0.
    pub mdb: [Option<f64>; 3],
}

/// A GNSS antenna position's residual.
#[derive(Clone, Debug, Serialize)]
pub struct GnssResidual {
    /// The image.
    pub image: String,
    /// Its strip.
    pub strip: String,
    /// GPS time of week of the exposure, s.
    pub tow: f64,
    /// The exposure time (GPST; GPS week 0 when the source knew no times and numbered the
    /// exposures instead).
    #[serde(skip)]
    pub time: hifitime::Epoch,
    /// Predicted − observed antenna, local E, N, U (m).
    pub v: [f64; 3],
}

/// A measured distance's residual (adjusted − measured, m) with its reliability.
#[derive(Clone, Debug, Serialize)]
pub struct DistanceResidual {
    /// The two points.
    pub points: [String; 2],
    /// The measured distance (m).
    pub distance: f64,
    /// Adjusted − measured (m).
    pub v: f64,
    /// Redundancy number and Baarda's w.
    pub r: f64,
    /// Normalised residual.
    pub w: f64,
    /// Where it came from (file:line).
    pub source: String,
}

/// The residual tables and, per image, (measurements, sum of squared pixel residuals).
pub struct Residuals {
    /// Image measurements.
    pub image: Vec<ImageResidual>,
    /// Control points.
    pub control: Vec<ControlResidual>,
    /// GNSS antenna positions.
    pub gnss: Vec<GnssResidual>,
    /// Measured distances.
    pub distance: Vec<DistanceResidual>,
    /// Per image: measurements and the sum of squared pixel residuals.
    pub per_image: Vec<(usize, f64)>,
}

/// The residual tables, read from the factors of the adjusted problem.
pub fn collect(p: &Project, s: &Solved, rel: &[Reliability]) -> Residuals {
    let b = &s.built;
    let pr = &b.problem;
    let s0 = s.stats.sigma0;
    let rel_of: std::collections::BTreeMap<FactorId, &Reliability> =
        rel.iter().map(|r| (r.factor, r)).collect();
    let rw = |k: FactorId, i: usize| {
        rel_of
            .get(&k)
            .map(|x| (x.redundancy[i], x.normalised[i]))
            .unwrap_or((0.0, 0.0))
    };
    let point = |id: PointId| b.point_names.get(id.index()).cloned().unwrap_or_default();
    let mut res = Residuals {
        image: Vec::new(),
        control: Vec::new(),
        gnss: Vec::new(),
        distance: Vec::new(),
        per_image: vec![(0, 0.0); p.images.len()],
    };
    for (k, _) in pr.factors() {
        if pr.is_removed(k) {
            continue;
        }
        let Some(r) = pr.residual(k) else { continue };
        if let Some(f) = pr.factor_as::<ImagePoint>(k) {
            let i = f.image().index();
            let cam = &p.cameras[p.images[i].camera].camera;
            let v = [r[0] / cam.pixel, -r[1] / cam.pixel];
            let px = cam.image_to_pixel(f.xy);
            res.per_image[i].0 += 1;
            res.per_image[i].1 += v[0] * v[0] + v[1] * v[1];
            let ((rx, wx), (ry, wy)) = (rw(k, 0), rw(k, 1));
            res.image.push(ImageResidual {
                image: p.images[i].id.clone(),
                point: point(f.point()),
                px: [px.x, px.y],
                v_px: v,
                r: [rx, ry],
                w: [wx, wy],
            });
        } else if let Some((Key::Point(id), axes)) =
            pr.factor_as::<Prior>(k).map(|f| (f.key(), f.axes()))
        {
            let scale = pr.group_sigma(pr.group(k)) * s0;
            let noise = pr.noise(k);
            // Axes a planimetric or height control point does not observe stay NaN.
            let mut c = ControlResidual {
                id: point(id),
                v: [f64::NAN; 3],
                r: [0.0; 3],
                w: [0.0; 3],
                mdb: [None; 3],
            };
            for (row, &a) in axes.iter().enumerate() {
                let (ra, wa) = rw(k, row);
                c.v[a] = r[row];
                c.r[a] = ra;
                c.w[a] = wa;
                c.mdb[a] = (ra > 1e-3).then(|| DELTA0 * noise.sigma(row) * scale / ra.sqrt());
            }
            res.control.push(c);
        } else if let Some(f) = pr.factor_as::<Distance>(k) {
            let (r_, w) = rw(k, 0);
            let [a, b] = f.points().map(|k| match k {
                Key::Point(id) => point(id),
                k => k.to_string(),
            });
            res.distance.push(DistanceResidual {
                points: [a, b],
                distance: f.distance,
                v: r[0],
                r: r_,
                w,
                source: f.source.clone(),
            });
        } else if let Some(f) = pr.factor_as::<GnssCentre>(k) {
            let ant = &p.antennas[f.record];
            res.gnss.push(GnssResidual {
                image: ant.image.clone(),
                strip: p.images[f.image().index()].strip.clone(),
                tow: gnss::time::week_tow(ant.time).1,
                time: ant.time,
                v: [r[0], r[1], r[2]],
            });
        }
    }
    res
}
