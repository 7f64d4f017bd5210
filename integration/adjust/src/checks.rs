//! Check points stay out of the adjustment: afterwards each is intersected from the adjusted
//! orientations of the images that measure it, and its covariance propagates both the image
//! measurement noise and the joint covariance of those orientations (cross terms included),
//! so the RMS of the differences can be compared with a theoretical σ that belongs to them.
//!
//! What enters: the project and the adjusted problem. What leaves: per check point its
//! intersected position (local frame), covariance and number of rays, or why it could not be
//! compared.

use super::build::Built;
use super::groups::GROUP_IMAGE;
use super::project::{PointKind, Project};
use nalgebra::{DMatrix, Matrix3, Vector3};
use photo::camera::{Camera, Pose, N_INTERIOR};
use photo::intersection::{intersect, Ray};
use photo::lsq::{CameraId, ImageId, Key, Problem, Value};

/// A check point intersected from the adjusted orientations.
pub(super) struct Intersected {
    /// The point's id.
    pub id: String,
    /// Its position, local frame.
    pub x: Vector3<f64>,
    /// Its covariance (m²): image noise and orientation uncertainty.
    pub cov: Matrix3<f64>,
    /// Rays used.
    pub rays: usize,
}

/// Every check point intersected, and the ones that could not be, with the reason.
pub(super) fn intersect_checks(
    p: &Project,
    b: &Built,
    sigma0: f64,
) -> (Vec<Intersected>, Vec<String>) {
    let pr = &b.problem;
    let (mut out, mut skipped) = (Vec::new(), Vec::new());
    for g in p.ground.iter().filter(|g| g.kind == PointKind::Check) {
        let rays: Vec<(usize, usize)> = p
            .measurements
            .iter()
            .enumerate()
            .filter(|(_, m)| m.point == g.id)
            .filter(|(_, m)| adjusted(pr, m.image))
            .map(|(k, m)| (k, m.image))
            .collect();
        match intersect_one(p, pr, &rays, sigma0) {
            Ok((x, cov)) => out.push(Intersected {
                id: g.id.clone(),
                x,
                cov,
                rays: rays.len(),
            }),
            Err(why) => skipped.push(format!("check point {} is not compared: {why}", g.id)),
        }
    }
    (out, skipped)
}

/// Whether image `i` has a free (adjusted) orientation.
fn adjusted(pr: &Problem, i: usize) -> bool {
    let k = Key::Pose(ImageId::from(i));
    pr.contains(k) && !pr.is_fixed(k)
}

/// The adjusted camera of image `i` (self-calibrated interior applied).
fn camera_of(p: &Project, pr: &Problem, i: usize) -> Camera {
    let c = p.images[i].camera;
    let cd = &p.cameras[c];
    match pr.value(Key::Camera(CameraId::from(c))) {
        Some(Value::Vector(v)) if v.len() == cd.calibrate.len() => {
            let mut all: [f64; N_INTERIOR] = cd.camera.interior();
            for (k, &j) in cd.calibrate.iter().enumerate() {
                all[j] = v[k];
            }
            cd.camera.with_interior(&all)
        }
        _ => cd.camera,
    }
}

/// Intersect one check point from its measurements `rays` (measurement, image) and propagate
/// Σx = N⁻¹ + N⁻¹·(Σᵢⱼ Aᵢᵀ Wᵢ Bᵢ Σ_pᵢpⱼ Bⱼᵀ Wⱼ Aⱼ)·N⁻¹ with A = ∂proj/∂X, B = ∂proj/∂pose.
fn intersect_one(
    p: &Project,
    pr: &Problem,
    rays: &[(usize, usize)],
    sigma0: f64,
) -> Result<(Vector3<f64>, Matrix3<f64>), String> {
    if rays.len() < 2 {
        return Err(format!(
            "measured in {} adjusted image(s); two are needed",
            rays.len()
        ));
    }
    let poses: Vec<Pose> = rays
        .iter()
        .map(|&(_, i)| {
            pr.value(Key::Pose(ImageId::from(i)))
                .and_then(Value::pose)
                .copied()
                .ok_or_else(|| "an orientation is missing".to_string())
        })
        .collect::<Result<_, _>>()?;
    let cams: Vec<Camera> = rays.iter().map(|&(_, i)| camera_of(p, pr, i)).collect();
    // Image noise as the adjustment weighted it (variance component and σ0 applied).
    let scale = pr.group_sigma(GROUP_IMAGE) * sigma0;
    let sig: Vec<f64> = rays
        .iter()
        .map(|&(k, _)| p.measurements[k].sigma * scale)
        .collect();
    let rs: Vec<Ray> = rays
        .iter()
        .enumerate()
        .map(|(n, &(k, _))| Ray {
            camera: &cams[n],
            pose: &poses[n],
            xy: p.measurements[k].xy,
            sigma: sig[n],
        })
        .collect();
    let x = intersect(&rs).map_err(|e| e.to_string())?.point;
    let mut n_mat = Matrix3::zeros();
    let mut awb: Vec<nalgebra::Matrix3x6<f64>> = Vec::new();
    for (n, cam) in cams.iter().enumerate() {
        let (_, j) = cam
            .project_with_jacobians(&poses[n], &x)
            .ok_or_else(|| "the point falls behind a camera".to_string())?;
        let w = 1.0 / (sig[n] * sig[n]);
        n_mat += j.point.transpose() * j.point * w;
        awb.push(j.point.transpose() * j.pose * w);
    }
    let n_inv = n_mat
        .try_inverse()
        .ok_or_else(|| "its rays are (nearly) parallel".to_string())?;
    let keys: Vec<Key> = rays
        .iter()
        .map(|&(_, i)| Key::Pose(ImageId::from(i)))
        .collect();
    let sp = pr
        .joint_covariance(&keys, sigma0)
        .ok()
        .flatten()
        .unwrap_or_else(|| DMatrix::zeros(6 * keys.len(), 6 * keys.len()));
    let mut m = Matrix3::zeros();
    for (a, wa) in awb.iter().enumerate() {
        for (c, wc) in awb.iter().enumerate() {
            let s = sp.fixed_view::<6, 6>(6 * a, 6 * c);
            m += wa * s * wc.transpose();
        }
    }
    let cov = n_inv + n_inv * m * n_inv;
    Ok((x, (cov + cov.transpose()) * 0.5))
}
