//! Residuals of an adjusted block with each observation's reliability: image points (pixels,
//! redundancy numbers, w), control points (with MDB per axis), GNSS antennas (local E, N, U).

use super::build::Obs;
use super::project::Project;
use super::results::DELTA0;
use super::Solved;
use nalgebra::Vector3;
use serde::Serialize;

#[derive(Clone, Debug, Serialize)]
pub struct ImageResidual {
    pub image: String,
    pub point: String,
    /// Measured position and residual (predicted − measured), pixels.
    pub px: [f64; 2],
    pub v_px: [f64; 2],
    /// Redundancy numbers and normalised residuals (Baarda's w) of x and y.
    pub r: [f64; 2],
    pub w: [f64; 2],
}

/// A control point's residual (adjusted − given, local E, N, U) with its reliability.
#[derive(Clone, Debug, Serialize)]
pub struct ControlResidual {
    pub id: String,
    pub v: [f64; 3],
    pub r: [f64; 3],
    pub w: [f64; 3],
    /// Minimal detectable blunder per axis (m), None where the redundancy is ~0.
    pub mdb: [Option<f64>; 3],
}

#[derive(Clone, Debug, Serialize)]
pub struct GnssResidual {
    pub image: String,
    pub strip: String,
    pub tow: f64,
    /// Predicted − observed antenna, local E, N, U (m).
    pub v: [f64; 3],
}

/// The residual tables and, per image, (measurements, sum of squared pixel residuals).
pub struct Residuals {
    pub image: Vec<ImageResidual>,
    pub control: Vec<ControlResidual>,
    pub gnss: Vec<GnssResidual>,
    pub per_image: Vec<(usize, f64)>,
}

pub fn collect(p: &Project, s: &Solved, rel: &[photo::solver::Reliability]) -> Residuals {
    let b = &s.built;
    let pr = &b.problem;
    let s0 = s.stats.sigma0;
    // Residuals, with each factor's reliability.
    let rel_of: std::collections::BTreeMap<usize, &photo::solver::Reliability> =
        rel.iter().map(|r| (r.factor, r)).collect();
    let rw = |k: usize, i: usize| {
        rel_of
            .get(&k)
            .map(|x| (x.redundancy[i], x.normalised[i]))
            .unwrap_or((0.0, 0.0))
    };
    let mut control_residuals = Vec::new();
    let mut image_residuals = Vec::new();
    let mut gnss_residuals = Vec::new();
    let mut per_image: Vec<(usize, f64)> = vec![(0, 0.0); p.images.len()];
    for (k, f) in pr.factors.iter().enumerate() {
        if pr.removed[k] {
            continue;
        }
        let bl: Vec<&photo::solver::Block> = f.blocks().iter().map(|&i| &pr.blocks[i]).collect();
        let Some((r, _)) = f.evaluate(&bl) else {
            continue;
        };
        match &b.obs[k] {
            Obs::Image(m) => {
                let m = &p.measurements[*m];
                let cam = &p.cameras[p.images[m.image].camera].camera;
                let v = [r[0] / cam.pixel, -r[1] / cam.pixel];
                let px = cam.image_to_pixel(m.xy);
                per_image[m.image].0 += 1;
                per_image[m.image].1 += v[0] * v[0] + v[1] * v[1];
                let ((rx, wx), (ry, wy)) = (rw(k, 0), rw(k, 1));
                image_residuals.push(ImageResidual {
                    image: p.images[m.image].id.clone(),
                    point: m.point.clone(),
                    px: [px.x, px.y],
                    v_px: v,
                    r: [rx, ry],
                    w: [wx, wy],
                });
            }
            Obs::Control(g) => {
                let gp = &p.ground[*g];
                let scale = pr.group_scale.get(f.group()).copied().unwrap_or(1.0).sqrt() * s0;
                let mut c = ControlResidual {
                    id: gp.id.clone(),
                    v: [r[0], r[1], r[2]],
                    r: [0.0; 3],
                    w: [0.0; 3],
                    mdb: [None; 3],
                };
                for a in 0..3 {
                    let (ra, wa) = rw(k, a);
                    c.r[a] = ra;
                    c.w[a] = wa;
                    c.mdb[a] = (ra > 1e-3).then(|| DELTA0 * f.sigmas()[a] * scale / ra.sqrt());
                }
                control_residuals.push(c);
            }
            Obs::Gnss {
                antenna,
                image,
                unwhiten,
            } => {
                let ant = &p.antennas[*antenna];
                let v = unwhiten * Vector3::new(r[0], r[1], r[2]);
                gnss_residuals.push(GnssResidual {
                    image: ant.image.clone(),
                    strip: p.images[*image].strip.clone(),
                    tow: gnss::time::week_tow(ant.time).1,
                    v: [v.x, v.y, v.z],
                });
            }
            _ => {}
        }
    }
    Residuals {
        image: image_residuals,
        control: control_residuals,
        gnss: gnss_residuals,
        per_image,
    }
}
