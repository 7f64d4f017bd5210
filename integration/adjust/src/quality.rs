//! The quality of an adjusted block beyond its residuals: reliability per observation group
//! (observations, σ factor, redundancy, uncontrolled components, the largest minimal
//! detectable blunder) and what data snooping removed, each read from its factor.

use super::factors::GnssCentre;
use super::groups::{GROUP_ATTITUDE, GROUP_NAMES, MISWEIGHTED};
use super::project::Project;
use super::residuals::DELTA0;
use super::solve::Solved;
use photo::factors::{Distance, ImagePoint, Prior};
use photo::lsq::{FactorId, Key, PointId, Reliability};
use serde::Serialize;

/// An observation removed by data snooping.
#[derive(Clone, Debug, Serialize)]
pub struct Removed {
    /// Its kind ("image point", "control point", "GNSS centre", …).
    pub kind: String,
    /// Which observation, with the project's ids.
    pub what: String,
    /// |w| when it was removed (0: removed with a point left undetermined).
    pub w: f64,
    /// Where it came from (file:line), when known.
    pub source: String,
}

/// Reliability of an observation group.
#[derive(Clone, Debug, Serialize)]
pub struct GroupQuality {
    /// The group's name.
    pub group: String,
    /// Residual components in the group.
    pub observations: usize,
    /// σ multiplier from variance component estimation (1 when not estimated).
    pub sigma_factor: f64,
    /// Mean redundancy number.
    pub mean_redundancy: f64,
    /// Least redundancy number.
    pub min_redundancy: f64,
    /// Components with a redundancy below 0.1: a blunder there is (nearly) undetectable.
    pub uncontrolled: usize,
    /// Largest minimal detectable blunder among the controlled components (redundancy ≥ 0.1),
    /// pixels for image points, degrees for attitudes, metres otherwise.
    pub max_mdb: f64,
    /// Unit of the MDB: px for image points, ° for attitudes, m otherwise.
    pub mdb_unit: String,
    /// The median σ given to its components (before the σ factor), in `mdb_unit`.
    pub given_sigma: f64,
}

/// Reliability per observation group (groups without observations left out).
pub(super) fn groups(p: &Project, s: &Solved, rel: &[Reliability]) -> Vec<GroupQuality> {
    let pr = &s.built.problem;
    let mut groups: Vec<GroupQuality> = GROUP_NAMES
        .iter()
        .enumerate()
        .map(|(g, n)| GroupQuality {
            group: n.to_string(),
            observations: 0,
            sigma_factor: s.components.get(g).copied().unwrap_or(1.0),
            mean_redundancy: 0.0,
            min_redundancy: f64::INFINITY,
            uncontrolled: 0,
            max_mdb: 0.0,
            mdb_unit: match g {
                0 => "px".into(),
                _ if g == GROUP_ATTITUDE.0 => "°".into(),
                _ => "m".into(),
            },
            given_sigma: 0.0,
        })
        .collect();
    let mut given: Vec<Vec<f64>> = vec![Vec::new(); groups.len()];
    for r in rel {
        let g = pr.group(r.factor);
        let scale = pr.group_sigma(g) * s.stats.sigma0;
        let noise = pr.noise(r.factor);
        let unit = match pr.factor_as::<ImagePoint>(r.factor) {
            Some(f) => p.cameras[p.images[f.image().index()].camera].camera.pixel,
            None if g == GROUP_ATTITUDE => 1f64.to_radians(),
            None => 1.0,
        };
        let q = &mut groups[g.0];
        for i in 0..r.redundancy.len() {
            given[g.0].push(noise.sigma(i) / unit);
            let rr = r.redundancy[i];
            q.observations += 1;
            q.mean_redundancy += rr;
            q.min_redundancy = q.min_redundancy.min(rr);
            if rr < 0.1 {
                q.uncontrolled += 1;
            } else {
                q.max_mdb = q
                    .max_mdb
                    .max(DELTA0 * noise.sigma(i) * scale / rr.sqrt() / unit);
            }
        }
    }
    for (q, given) in groups.iter_mut().zip(&mut given) {
        if !given.is_empty() {
            given.sort_by(f64::total_cmp);
            q.given_sigma = given[given.len() / 2];
        }
        if q.observations > 0 {
            q.mean_redundancy /= q.observations as f64;
        } else {
            q.min_redundancy = 0.0;
        }
    }
    groups.retain(|q| q.observations > 0);
    groups
}

/// A plain warning for each group whose σ factor is beyond [`MISWEIGHTED`]: what its σ
/// behave like, what was given, that the estimate is used, and what to do.
pub(super) fn misweighted(groups: &[GroupQuality]) -> Vec<String> {
    let amount = |v: f64, unit: &str| match unit {
        "px" => format!("{v:.2} px"),
        "°" => format!("{v:.4}°"),
        _ if v >= 1.0 => format!("{v:.1} m"),
        _ if v >= 0.01 => format!("{:.1} cm", v * 100.0),
        _ => format!("{:.1} mm", v * 1000.0),
    };
    groups
        .iter()
        .filter(|g| g.sigma_factor > MISWEIGHTED || g.sigma_factor < 1.0 / MISWEIGHTED)
        .map(|g| {
            let advice = match g.group.as_str() {
                "GNSS centres" if g.sigma_factor > 1.0 => "if they are navigation-grade positions, import with --gnss-kind nav or give --gnss-sigma (or their σ in the antenna table)",
                "image points" if g.sigma_factor > 1.0 => "check the cameras' interior orientation (self-calibration, distortion) and the measurements' σ (sigma_px)",
                "control points" if g.sigma_factor > 1.0 => "check the control coordinates, their σ and their datum",
                _ if g.sigma_factor < 1.0 => "the σ given are too pessimistic: give smaller ones",
                _ => "check the σ given for them",
            };
            format!(
                "the {} behave like σ ≈ {}, not the {} given (σ factor {:.1}, estimated from the residuals and used in this adjustment): {advice}",
                g.group,
                amount(g.given_sigma * g.sigma_factor, &g.mdb_unit),
                amount(g.given_sigma, &g.mdb_unit),
                g.sigma_factor
            )
        })
        .collect()
}

/// What a factor removed by data snooping was, read from the factor itself.
pub(super) fn removed_observation(
    p: &Project,
    b: &super::build::Built,
    k: FactorId,
    w: f64,
) -> Removed {
    let pr = &b.problem;
    let point = |id: PointId| b.point_names.get(id.index()).cloned().unwrap_or_default();
    let (kind, what, source) = if let Some(f) = pr.factor_as::<ImagePoint>(k) {
        let image = &p.images[f.image().index()].id;
        let what = format!("point {} in image {image}", point(f.point()));
        ("image point", what, f.source.clone())
    } else if let Some(f) = pr.factor_as::<Prior>(k) {
        match f.key() {
            Key::Point(id) => {
                let what = format!("control point {} (kept as a tie point)", point(id));
                ("control point", what, f.source.clone())
            }
            Key::LeverArm(c) => {
                let what = format!("camera {}", p.cameras[c.index()].id);
                ("lever-arm prior", what, f.source.clone())
            }
            other => ("prior", other.to_string(), f.source.clone()),
        }
    } else if let Some(f) = pr.factor_as::<GnssCentre>(k) {
        let what = format!("antenna of image {}", p.antennas[f.record].image);
        ("GNSS centre", what, String::new())
    } else if let Some(f) = pr.factor_as::<Distance>(k) {
        let [a, c] = f.points().map(|k| match k {
            Key::Point(id) => point(id),
            k => k.to_string(),
        });
        ("distance", format!("distance {a} – {c}"), f.source.clone())
    } else {
        ("observation", format!("factor {}", k.0), String::new())
    };
    Removed {
        kind: kind.into(),
        what,
        w,
        source,
    }
}
