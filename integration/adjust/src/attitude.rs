//! Attitude observations: the camera rotation an IMU (or gimbal, or navigation system) gives
//! at an exposure, as a factor with its σ, and the boresight misalignment between that
//! attitude and the camera's, three angles per camera, as unknowns.
//!
//! The observed rotation R_obs (camera → local frame) comes from the antenna table's
//! ω-φ-κ (the exposure stage rotated the IMU attitude into the camera frame with the nominal
//! mounting), else from the image list's `omega,phi,kappa` (gimbal or navigation angles,
//! camera → the adjustment's local ENU). The camera's rotation is R = R_obs · B with B = exp(b) the boresight; the
//! residual is r = log(Bᵀ · R_obsᵀ · R), rotations about the camera's x, y, z axes (≈ ω, φ, κ
//! for a nadir camera), radians. Its σ: the antenna row's `sd_omega,sd_phi,sd_kappa` where the
//! table has them, else the section's `sigma_deg`.
//!
//! What enters: the project's `[attitude]` section and antenna table, the frame, the problem.
//! What leaves: the factors (group "attitude"), the boresight blocks and their results.

use super::error::{problem_err as err, AdjustError};
use super::estimated::Estimated;
use super::frame::LocalFrame;
use super::groups::{GROUP_ATTITUDE, GROUP_PRIOR};
use super::project::Project;
use nalgebra::{DMatrix, DMatrixViewMut, DVector, Matrix3, Vector3};
use photo::factors::Prior;
use photo::lsq::{CameraId, Factor, ImageId, Key, Loss, Noise, Params, Problem, Value};
use photo::rotation::{exp_so3, log_so3};

/// An observed camera rotation: r = log(exp(b + o)ᵀ · R_obsᵀ · R), b the camera's boresight
/// and o its strip's attitude offset, each when estimated.
pub struct AttitudeObs {
    /// The pose, then the boresight and the strip offset when they are estimated.
    keys: Vec<Key>,
    /// Observed rotation camera → adjustment frame.
    observed: Matrix3<f64>,
}

/// With `strip_offsets`, the share of an attitude observation's variance common to its
/// strip (the offset's prior; the rest stays the image's own): an INS's smoothed attitude
/// error changes little over a strip's minute.
pub const STRIP_SHARE: f64 = 0.9;

/// The kind name of the per-strip attitude offsets (`Key::Custom(STRIP_OFFSET, n)`, rad).
pub const STRIP_OFFSET: &str = "attitude offset of strip";

impl AttitudeObs {
    /// The residual at pose rotation `r` and boresight `b`.
    fn residual(&self, r: &Matrix3<f64>, b: &Vector3<f64>) -> Vector3<f64> {
        log_so3(&(exp_so3(b).transpose() * self.observed.transpose() * r))
    }
}

impl Factor for AttitudeObs {
    photo::keys_in_field!();
    fn dim(&self) -> usize {
        3
    }
    fn evaluate(
        &self,
        x: &Params<'_>,
        r: &mut [f64],
        j: &mut [Option<DMatrixViewMut<'_, f64>>],
    ) -> bool {
        let Some(pose) = x.pose(0) else {
            return false;
        };
        let mut b = Vector3::zeros();
        for k in 1..self.keys.len() {
            match x.vector(k) {
                Some(v) if v.len() == 3 => b += Vector3::new(v[0], v[1], v[2]),
                _ => return false,
            }
        }
        let r0 = self.residual(&pose.r, &b);
        r.copy_from_slice(r0.as_slice());
        // Central differences: the pose block's left perturbation R ← exp(δ)·R (its centre
        // does not enter), the boresight's plain increments.
        const H: f64 = 1e-6;
        if let Some(m) = &mut j[0] {
            m.fill(0.0);
            for k in 0..3 {
                let d = Vector3::ith(k, H);
                let c = (self.residual(&(exp_so3(&d) * pose.r), &b)
                    - self.residual(&(exp_so3(&-d) * pose.r), &b))
                    / (2.0 * H);
                m.column_mut(k).rows_mut(0, 3).copy_from(&c);
            }
        }
        // The boresight and the offset enter as their sum: the same columns for both.
        let mut sum = DMatrix::zeros(3, 3);
        for k in 0..3 {
            let d = Vector3::ith(k, H);
            let c =
                (self.residual(&pose.r, &(b + d)) - self.residual(&pose.r, &(b - d))) / (2.0 * H);
            sum.column_mut(k).copy_from(&c);
        }
        for m in j.iter_mut().skip(1).flatten() {
            m.copy_from(&sum);
        }
        true
    }
}

/// One attitude factor per adjusted image whose antenna record carries an attitude, and a
/// boresight block per camera observed (with its prior when asked).
pub(super) fn factors(
    p: &Project,
    frame: &LocalFrame,
    pr: &mut Problem,
    antenna_of: &[Option<usize>],
    loss: Loss,
) -> Result<(), AdjustError> {
    let Some(sec) = p.file.attitude.as_ref() else {
        return Ok(());
    };
    const GIVE_SIGMA: &str = "[attitude] sigma_deg: give three positive σ in degrees (e.g. [0.05, 0.05, 0.2]), or sd_omega, sd_phi, sd_kappa columns in the antenna table";
    if let Some(s) = sec.sigma_deg {
        if s.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
            return Err(err(GIVE_SIGMA.to_string()));
        }
    }
    let built = |e: photo::lsq::BuildError| err(e.to_string());
    // The section's σ, for the observations without their own.
    let default_sigma = sec.sigma_deg.map(|s| Vector3::from(s).map(f64::to_radians));
    let mut obs = Vec::new();
    for (i, a) in antenna_of.iter().enumerate() {
        let pose = Key::Pose(ImageId::from(i));
        // The antenna table's attitude (ENU at the antenna), else the image list's (local).
        let from_list = p.images[i].opk.map(|[omega, phi, kappa]| {
            photo::rotation::Angles::OmegaPhiKappa { omega, phi, kappa }.matrix()
        });
        // With the antenna row's σ when it has them.
        let Some((rot, own_sigma)) = a
            .and_then(|k| {
                let ant = &p.antennas[k];
                ant.rotation
                    .map(|r| (frame.from_enu_at(&ant.pos) * r, ant.rotation_sigma))
            })
            .or(from_list.map(|r| (r, None)))
        else {
            continue;
        };
        if !pr.contains(pose) || pr.is_fixed(pose) {
            continue;
        }
        let Some(sigma) = own_sigma.or(default_sigma) else {
            return Err(err(GIVE_SIGMA.to_string()));
        };
        obs.push((i, rot, sigma));
    }
    if obs.is_empty() {
        return Err(err("[attitude] is given but neither the antenna table nor the image list carries an attitude (omega, phi, kappa columns): add them, or drop [attitude]".to_string()));
    }
    let offsets = if sec.strip_offsets {
        strip_offsets(p, &obs, pr, loss)?
    } else {
        Vec::new()
    };
    // With the strip offsets, each observation's variance is split between them (the part
    // common along a strip) and the image's own.
    let own = if sec.strip_offsets {
        (1.0 - STRIP_SHARE).sqrt()
    } else {
        1.0
    };
    for (i, rot, sigma) in obs {
        let sigma = sigma * own;
        let mut keys = vec![Key::Pose(ImageId::from(i))];
        if sec.boresight {
            keys.push(boresight_block(
                sec,
                CameraId::from(p.images[i].camera),
                pr,
                loss,
            )?);
        }
        if let Some((_, k)) = offsets.iter().find(|(s, _)| *s == p.images[i].strip) {
            keys.push(*k);
        }
        let f = AttitudeObs {
            keys,
            observed: rot,
        };
        pr.add_factor(f, Noise::sigmas(sigma.as_slice()), loss, GROUP_ATTITUDE)
            .map_err(built)?;
    }
    Ok(())
}

/// The boresight block of camera `cam`, added (with its prior when asked) on first use.
fn boresight_block(
    sec: &super::sections::AttitudeSection,
    cam: CameraId,
    pr: &mut Problem,
    loss: Loss,
) -> Result<Key, AdjustError> {
    let built = |e: photo::lsq::BuildError| err(e.to_string());
    let bk = Key::Boresight(cam);
    if !pr.contains(bk) {
        pr.add_block(bk, Value::Vector(DVector::zeros(3)))
            .map_err(built)?;
        if let Some(s) = sec.boresight_sigma_deg {
            let s: Vec<f64> = s.iter().map(|x| x.to_radians().max(1e-9)).collect();
            let f = Prior::new(bk, DVector::zeros(3));
            pr.add_factor(f, Noise::sigmas(&s), loss, GROUP_PRIOR)
                .map_err(built)?;
        }
    }
    Ok(bk)
}

/// One attitude offset per strip observed, held at zero by a prior of the median σ of its
/// observations per axis times √[`STRIP_SHARE`] (an INS's attitude error drifts over minutes: along a strip it is
/// nearly one offset, which one boresight for the whole flight must not take as known).
fn strip_offsets(
    p: &Project,
    obs: &[(usize, Matrix3<f64>, Vector3<f64>)],
    pr: &mut Problem,
    loss: Loss,
) -> Result<Vec<(String, Key)>, AdjustError> {
    let built = |e: photo::lsq::BuildError| err(e.to_string());
    let mut strips: Vec<&str> = obs.iter().map(|o| p.images[o.0].strip.as_str()).collect();
    strips.sort_unstable();
    strips.dedup();
    let mut out = Vec::new();
    for (n, strip) in strips.into_iter().enumerate() {
        let mut sigma = [0.0; 3];
        for (axis, s) in sigma.iter_mut().enumerate() {
            let mut v: Vec<f64> = obs
                .iter()
                .filter(|o| p.images[o.0].strip == strip)
                .map(|o| o.2[axis])
                .collect();
            v.sort_by(f64::total_cmp);
            *s = v[v.len() / 2] * STRIP_SHARE.sqrt();
        }
        let k = Key::Custom(STRIP_OFFSET, n as u32);
        pr.add_block(k, Value::Vector(DVector::zeros(3)))
            .map_err(built)?;
        pr.add_factor(
            Prior::new(k, DVector::zeros(3)),
            Noise::sigmas(&sigma),
            loss,
            GROUP_PRIOR,
        )
        .map_err(built)?;
        out.push((strip.to_string(), k));
    }
    Ok(out)
}

/// The boresight of every camera that has one, in degrees (about the camera's x, y, z).
pub(super) fn boresights<'a>(
    p: &Project,
    pr: &Problem,
    cov_of: impl Fn(Key) -> Option<&'a DMatrix<f64>>,
) -> Vec<Estimated> {
    p.cameras
        .iter()
        .enumerate()
        .map(|(i, c)| (c, Key::Boresight(CameraId::from(i))))
        .filter(|(_, k)| pr.contains(*k))
        .map(|(c, k)| {
            let v = pr
                .value(k)
                .and_then(Value::vector)
                .cloned()
                .unwrap_or_default();
            let cov = cov_of(k);
            Estimated {
                name: format!("boresight ({})", c.id),
                values: v.iter().map(|x| x.to_degrees()).collect(),
                sigmas: (0..v.len())
                    .map(|i| cov.map_or(0.0, |m| m[(i, i)].max(0.0).sqrt().to_degrees()))
                    .collect(),
                labels: ["rx", "ry", "rz"].iter().map(|s| s.to_string()).collect(),
                t0: 0.0,
                fixed: pr.is_fixed(k),
            }
        })
        .collect()
}
