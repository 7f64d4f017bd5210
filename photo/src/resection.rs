//! Space resection: the six exterior elements from three or more control points with a
//! closed-form start (Grunert's P3P on three well-spread points, the candidate that best fits
//! all points), or only the three angles when the projection centre is known (closed-form
//! start by aligning ray directions, or a given start such as a compass); both refined by
//! least squares on the image residuals, with covariance.

use crate::camera::{Camera, Pose};
use crate::rotation::exp_so3;
use nalgebra::{Matrix3, Matrix4, SMatrix, SVector, Vector2, Vector3};

/// A control point seen in the image.
#[derive(Clone, Copy, Debug)]
pub struct Control {
    /// Its object coordinates.
    pub object: Vector3<f64>,
    /// Its measured image point (metres, image coordinates).
    pub image: Vector2<f64>,
    /// σ of the image point (metres).
    pub sigma: f64,
}

/// A resected exterior orientation.
#[derive(Clone, Debug)]
pub struct Resection {
    /// The orientation.
    pub pose: Pose,
    /// Covariance of (δ rotation, centre) — δ is a small rotation of R from the left.
    pub cov: SMatrix<f64, 6, 6>,
    /// A posteriori sigma of unit weight.
    pub sigma0: f64,
}

/// Why a resection fails.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ResectionError {
    /// Too few control points (given, needed).
    #[error("{0} control point(s): resection needs at least {1}")]
    TooFewPoints(usize, usize),
    /// The control points do not determine the orientation.
    #[error("the control points are (nearly) collinear: the orientation is not determined")]
    Collinear,
    /// No closed-form solution fits.
    #[error("no closed-form start fits the control points")]
    NoStart,
    /// Gauss–Newton did not converge.
    #[error("the adjustment does not converge")]
    NoConvergence,
}

/// The unit ray of image coordinates `xy` in the camera frame (x right, y up, looking along
/// −z), distortion left out: the direction start values are computed from.
pub fn ray(cam: &Camera, xy: &Vector2<f64>) -> Vector3<f64> {
    Vector3::new(xy.x - cam.x0, xy.y - cam.y0, -cam.f).normalize()
}

/// Rotation best aligning `from` vectors to `to` vectors (Kabsch / Wahba).
fn align(from: &[Vector3<f64>], to: &[Vector3<f64>]) -> Option<Matrix3<f64>> {
    let mut h = Matrix3::zeros();
    for (a, b) in from.iter().zip(to) {
        h += b * a.transpose();
    }
    // nalgebra's SVD has no iteration bound: on NaN (huge coordinates overflowed) it never ends.
    if !h.iter().all(|v| v.is_finite()) {
        return None;
    }
    let svd = h.svd(true, true);
    let (u, vt) = (svd.u?, svd.v_t?);
    let d = (u * vt).determinant().signum();
    Some(u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * vt)
}

fn real_quartic_roots(c: [f64; 5]) -> Vec<f64> {
    // A double root (the camera near the "danger cylinder", or narrow aerial bundles whose
    // ray cosines are all near 1) splits into a complex pair under image noise: 1 px on a
    // 35 mm aerial camera gave 1.056 ± 0.0075i. Its real part is the start the refinement
    // needs, so nearly real roots count as real.
    const NEAR_REAL: f64 = 0.05;
    // c[0] v⁴ + c[1] v³ + c[2] v² + c[3] v + c[4]
    if c[0].abs() < 1e-300 {
        return Vec::new();
    }
    let m = Matrix4::new(
        -c[1] / c[0],
        -c[2] / c[0],
        -c[3] / c[0],
        -c[4] / c[0],
        1.0,
        0.0,
        0.0,
        0.0,
        0.0,
        1.0,
        0.0,
        0.0,
        0.0,
        0.0,
        1.0,
        0.0,
    );
    m.complex_eigenvalues()
        .iter()
        .filter(|z| z.im.abs() <= NEAR_REAL * (1.0 + z.re.abs()))
        .map(|z| z.re)
        .collect()
}

/// Grunert's three-point solutions: camera poses mapping the rays onto the points.
fn p3p(cam: &Camera, pts: [&Control; 3]) -> Vec<Pose> {
    let j: Vec<Vector3<f64>> = pts.iter().map(|p| ray(cam, &p.image)).collect();
    let (x1, x2, x3) = (pts[0].object, pts[1].object, pts[2].object);
    let (a, b, c) = ((x2 - x3).norm(), (x1 - x3).norm(), (x1 - x2).norm());
    let (ca, cb, cg) = (j[1].dot(&j[2]), j[0].dot(&j[2]), j[0].dot(&j[1]));
    let (a2, b2, c2) = (a * a, b * b, c * c);
    let q = (a2 - c2) / b2;
    // Eliminating s1 and u (u = N(v)/D(v), linear in u) leaves, with D² multiplied through,
    // D² + N² − 2cγ·N·D − (c²/b²)(1 + v² − 2cβ·v)·D² = 0: a quartic in v built exactly by
    // polynomial arithmetic (coefficients in ascending powers).
    let mul = |x: &[f64], y: &[f64]| -> Vec<f64> {
        let mut r = vec![0.0; x.len() + y.len() - 1];
        for (i, a) in x.iter().enumerate() {
            for (k, b) in y.iter().enumerate() {
                r[i + k] += a * b;
            }
        }
        r
    };
    let nq = [1.0 + q, -2.0 * q * cb, q - 1.0];
    let dl = [2.0 * cg, -2.0 * ca];
    let d2 = mul(&dl, &dl);
    let mut poly = [0.0f64; 5];
    for (k, c) in mul(&nq, &nq).iter().enumerate() {
        poly[k] += c;
    }
    for (k, c) in d2.iter().enumerate() {
        poly[k] += c;
    }
    for (k, c) in mul(&nq, &dl).iter().enumerate() {
        poly[k] -= 2.0 * cg * c;
    }
    for (k, c) in mul(&[1.0, -2.0 * cb, 1.0], &d2).iter().enumerate() {
        poly[k] -= c2 / b2 * c;
    }
    let coef = [poly[4], poly[3], poly[2], poly[1], poly[0]];
    let mut out = Vec::new();
    for v in real_quartic_roots(coef) {
        if v <= 0.0 {
            continue;
        }
        let den = 2.0 * (cg - v * ca);
        if den.abs() < 1e-12 {
            continue;
        }
        let u = ((-1.0 + q) * v * v - 2.0 * q * cb * v + 1.0 + q) / den;
        let s1sq = b2 / (1.0 + v * v - 2.0 * v * cb);
        if u <= 0.0 || s1sq <= 0.0 {
            continue;
        }
        let s1 = s1sq.sqrt();
        let cam_pts = [j[0] * s1, j[1] * (u * s1), j[2] * (v * s1)];
        let obj = [x1, x2, x3];
        let (cc, oc) = (
            cam_pts.iter().sum::<Vector3<f64>>() / 3.0,
            obj.iter().sum::<Vector3<f64>>() / 3.0,
        );
        let from: Vec<Vector3<f64>> = cam_pts.iter().map(|p| p - cc).collect();
        let to: Vec<Vector3<f64>> = obj.iter().map(|p| p - oc).collect();
        if let Some(r) = align(&from, &to) {
            out.push(Pose {
                r,
                centre: oc - r * cc,
            });
        }
    }
    out
}

fn rms(cam: &Camera, pose: &Pose, pts: &[Control]) -> f64 {
    pts.iter()
        .map(|p| {
            cam.project(pose, &p.object)
                .map(|q| ((q - p.image) / p.sigma).norm_squared())
                .unwrap_or(1e30)
        })
        .sum::<f64>()
}

/// Gauss–Newton on the chosen parameters: `free_centre` adds the centre to the rotation.
fn refine(
    cam: &Camera,
    mut pose: Pose,
    pts: &[Control],
    free_centre: bool,
) -> Result<Resection, ResectionError> {
    let n = if free_centre { 6 } else { 3 };
    for _ in 0..30 {
        let mut nm = SMatrix::<f64, 6, 6>::zeros();
        let mut g = SVector::<f64, 6>::zeros();
        let mut vtpv = 0.0;
        for p in pts {
            let (q, j) = cam
                .project_with_jacobians(&pose, &p.object)
                .ok_or(ResectionError::NoConvergence)?;
            let v = p.image - q;
            let w = 1.0 / (p.sigma * p.sigma);
            nm += j.pose.transpose() * j.pose * w;
            g += j.pose.transpose() * v * w;
            vtpv += v.norm_squared() * w;
        }
        let sub = nm.view((0, 0), (n, n)).into_owned();
        let inv = sub.try_inverse().ok_or(ResectionError::Collinear)?;
        let dx = &inv * g.rows(0, n);
        pose.r = exp_so3(&Vector3::new(dx[0], dx[1], dx[2])) * pose.r;
        if free_centre {
            pose.centre += Vector3::new(dx[3], dx[4], dx[5]);
        }
        if dx.norm() < 1e-12 * (1.0 + pose.centre.norm()) || dx.rows(0, 3).norm() < 1e-13 {
            let dof = 2 * pts.len() - n;
            let sigma0 = if dof > 0 {
                (vtpv / dof as f64).sqrt()
            } else {
                1.0
            };
            let scale = if dof > 0 { sigma0 * sigma0 } else { 1.0 };
            let mut cov = SMatrix::<f64, 6, 6>::zeros();
            cov.view_mut((0, 0), (n, n)).copy_from(&(inv * scale));
            return Ok(Resection { pose, cov, sigma0 });
        }
    }
    Err(ResectionError::NoConvergence)
}

/// All six elements from ≥ 3 control points, no starting value needed. With exactly three
/// points up to four exact solutions exist; the one returned is the best fit, which is only
/// unique from four points on.
pub fn resect(cam: &Camera, pts: &[Control]) -> Result<Resection, ResectionError> {
    if pts.len() < 3 {
        return Err(ResectionError::TooFewPoints(pts.len(), 3));
    }
    // Three well-spread points: the largest triangle.
    let mut best = (0.0, [0, 1, 2]);
    let span = pts
        .iter()
        .map(|p| (p.object - pts[0].object).norm())
        .fold(0.0, f64::max);
    for i in 0..pts.len() {
        for j in i + 1..pts.len() {
            for k in j + 1..pts.len() {
                let area = (pts[j].object - pts[i].object)
                    .cross(&(pts[k].object - pts[i].object))
                    .norm();
                if area > best.0 {
                    best = (area, [i, j, k]);
                }
            }
        }
    }
    if best.0 < 1e-6 * span * span {
        return Err(ResectionError::Collinear);
    }
    let [i, j, k] = best.1;
    let start = p3p(cam, [&pts[i], &pts[j], &pts[k]])
        .into_iter()
        .min_by(|a, b| {
            rms(cam, a, pts)
                .partial_cmp(&rms(cam, b, pts))
                .unwrap_or(std::cmp::Ordering::Equal)
        })
        .ok_or(ResectionError::NoStart)?;
    refine(cam, start, pts, true)
}

/// Triples of points tried by [`resect_robust`].
const TRIPLES_TRIED: usize = 200;

/// All six elements from ≥ 4 control points of which some may be wrong (a mismeasured point,
/// a wrong id): every triple (all of them up to 20 points, then a fixed spread of 200) gives
/// its P3P solutions, each scored by the points it reprojects within `tolerance` (metres in
/// the image); the best is refined on its inliers, which are returned (indices) with it.
/// Deterministic. Fails when fewer than four points agree.
pub fn resect_robust(
    cam: &Camera,
    pts: &[Control],
    tolerance: f64,
) -> Result<(Resection, Vec<usize>), ResectionError> {
    let n = pts.len();
    if n < 4 {
        return Err(ResectionError::TooFewPoints(n, 4));
    }
    let triples = crate::resection_triples::spread_triples(n, TRIPLES_TRIED);
    let inliers_of = |pose: &Pose| -> Vec<usize> {
        (0..n)
            .filter(|&m| {
                cam.project(pose, &pts[m].object)
                    .is_some_and(|q| (q - pts[m].image).norm() <= tolerance)
            })
            .collect()
    };
    let mut best: Option<(Vec<usize>, Pose)> = None;
    for t in triples {
        for pose in p3p(cam, [&pts[t[0]], &pts[t[1]], &pts[t[2]]]) {
            let inl = inliers_of(&pose);
            if best.as_ref().is_none_or(|b| inl.len() > b.0.len()) {
                best = Some((inl, pose));
            }
        }
    }
    let (inl, start) = best.ok_or(ResectionError::NoStart)?;
    if inl.len() < 4 {
        return Err(ResectionError::NoStart);
    }
    let kept: Vec<Control> = inl.iter().map(|&m| pts[m]).collect();
    let r = refine(cam, start, &kept, true)?;
    let inl = inliers_of(&r.pose);
    Ok((r, inl))
}

/// All six elements from exactly three control points: of the (up to four) exact P3P
/// solutions, the one `prefer` scores highest (e.g. an aerial camera looking down from above
/// the points), refined. From four points on, [`resect`].
pub fn resect_three(
    cam: &Camera,
    pts: &[Control],
    prefer: impl Fn(&Pose) -> f64,
) -> Result<Resection, ResectionError> {
    if pts.len() != 3 {
        return resect(cam, pts);
    }
    let span = (pts[1].object - pts[0].object)
        .norm()
        .max((pts[2].object - pts[0].object).norm());
    let area = (pts[1].object - pts[0].object)
        .cross(&(pts[2].object - pts[0].object))
        .norm();
    if area < 1e-6 * span * span {
        return Err(ResectionError::Collinear);
    }
    let start = p3p(cam, [&pts[0], &pts[1], &pts[2]])
        .into_iter()
        .max_by(|a, b| prefer(a).total_cmp(&prefer(b)))
        .ok_or(ResectionError::NoStart)?;
    refine(cam, start, pts, true)
}

/// The three angles only, the projection centre known (≥ 2 points). `start`: a rotation to
/// begin from (e.g. from a compass); without it the rays are aligned with the directions to
/// the points in closed form.
pub fn resect_angles(
    cam: &Camera,
    centre: Vector3<f64>,
    pts: &[Control],
    start: Option<Matrix3<f64>>,
) -> Result<Resection, ResectionError> {
    if pts.len() < 2 {
        return Err(ResectionError::TooFewPoints(pts.len(), 2));
    }
    let r = match start {
        Some(r) => r,
        None => {
            let from: Vec<Vector3<f64>> = pts.iter().map(|p| ray(cam, &p.image)).collect();
            let to: Vec<Vector3<f64>> = pts
                .iter()
                .map(|p| (p.object - centre).normalize())
                .collect();
            if from.iter().skip(1).all(|f| f.cross(&from[0]).norm() < 1e-9) {
                return Err(ResectionError::Collinear);
            }
            align(&from, &to).ok_or(ResectionError::NoStart)?
        }
    };
    refine(cam, Pose { r, centre }, pts, false)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rotation::{log_so3, Angles};

    /// A double root split by noise into 1.056 ± 0.0075i (a real aerial image's three control
    /// points) is kept as the real start it is; a genuinely complex pair is not.
    #[test]
    fn nearly_real_quartic_roots_count() {
        // (v − 2)(v + 1)((v − 1.056)² + 0.0075²) and the same with ± 0.5i.
        let quartic = |im: f64| {
            let (a, b) = (-2.0 * 1.056, 1.056f64.powi(2) + im * im);
            // (v² − v − 2)(v² + a v + b)
            [1.0, a - 1.0, b - a - 2.0, -b - 2.0 * a, -2.0 * b]
        };
        let roots = real_quartic_roots(quartic(0.0075));
        assert_eq!(roots.len(), 4, "{roots:?}");
        assert!(roots.iter().filter(|r| (*r - 1.056).abs() < 1e-6).count() == 2);
        let roots = real_quartic_roots(quartic(0.5));
        assert_eq!(roots.len(), 2, "{roots:?}");
    }

    fn scene() -> (Camera, Pose, Vec<Control>) {
        let cam = Camera::ideal(0.035, 3.9e-6, 6000, 4000);
        let pose = Pose {
            r: Angles::OmegaPhiKappa {
                omega: 0.03,
                phi: -0.02,
                kappa: 2.1,
            }
            .matrix(),
            centre: Vector3::new(120.0, -40.0, 360.0),
        };
        let sigma = 3.9e-6;
        let noise = [
            0.6, -0.9, 1.1, 0.2, -0.5, 0.8, -1.2, -0.3, 0.4, 1.0, -0.7, 0.5, 0.9, -0.2,
        ];
        let objs = [
            [100.0, -60.0, 2.0],
            [160.0, -20.0, 8.0],
            [90.0, -10.0, -3.0],
            [140.0, -70.0, 5.0],
            [125.0, -45.0, 12.0],
            [105.0, -30.0, 0.0],
            [150.0, -55.0, -1.0],
        ];
        let pts = objs
            .iter()
            .enumerate()
            .map(|(k, o)| {
                let x = Vector3::new(o[0], o[1], o[2]);
                Control {
                    object: x,
                    image: cam.project(&pose, &x).unwrap()
                        + Vector2::new(noise[2 * k], noise[2 * k + 1]) * sigma,
                    sigma,
                }
            })
            .collect();
        (cam, pose, pts)
    }

    #[test]
    fn six_elements_from_no_starting_value() {
        let (cam, truth, pts) = scene();
        let r = resect(&cam, &pts).unwrap();
        let drot = log_so3(&(r.pose.r * truth.r.transpose()));
        for k in 0..3 {
            assert!(
                drot[k].abs() < 3.0 * r.cov[(k, k)].sqrt(),
                "angle {k}: {} vs σ {}",
                drot[k],
                r.cov[(k, k)].sqrt()
            );
            let dc = r.pose.centre[k] - truth.centre[k];
            assert!(
                dc.abs() < 3.0 * r.cov[(3 + k, 3 + k)].sqrt(),
                "centre {k}: {dc} vs σ {}",
                r.cov[(3 + k, 3 + k)].sqrt()
            );
        }
        // Four points: unique, still no guess.
        let r4 = resect(&cam, &pts[..4]).unwrap();
        for k in 0..3 {
            let dc = r4.pose.centre[k] - truth.centre[k];
            assert!(
                dc.abs() < 3.0 * r4.cov[(3 + k, 3 + k)].sqrt(),
                "4 points, centre {k}: {dc} vs σ {}",
                r4.cov[(3 + k, 3 + k)].sqrt()
            );
        }
        // Three points admit up to four exact solutions (Grunert): the true one is among them.
        let exact: Vec<Control> = pts[..3]
            .iter()
            .map(|p| Control {
                image: cam.project(&truth, &p.object).unwrap(),
                ..*p
            })
            .collect();
        let cands = p3p(&cam, [&exact[0], &exact[1], &exact[2]]);
        assert!(
            cands
                .iter()
                .any(|c| (c.centre - truth.centre).norm() < 1e-4 && (c.r - truth.r).norm() < 1e-6),
            "{} candidates: {:?}",
            cands.len(),
            cands.iter().map(|c| c.centre).collect::<Vec<_>>()
        );
    }

    /// Three points: of the P3P solutions, the aerial preference (camera above the points,
    /// looking down) picks the true one; the best-fit choice of `resect` cannot (all fit).
    #[test]
    fn three_points_with_a_preference() {
        let (cam, truth, pts) = scene();
        let three = [pts[0], pts[1], pts[2]];
        let mean_z = three.iter().map(|p| p.object.z).sum::<f64>() / 3.0;
        let aerial = |p: &Pose| (p.centre.z - mean_z).signum() + p.r[(2, 2)];
        let cands = p3p(&cam, [&three[0], &three[1], &three[2]]);
        assert!(cands.len() >= 2, "an ambiguous triple: {}", cands.len());
        let r = resect_three(&cam, &three, aerial).unwrap();
        // The branch nearest the truth is chosen (a 60 m triangle seen from 360 m leaves the
        // exact three-point solution metres from the truth with 1 px of noise).
        let nearest = cands
            .iter()
            .min_by(|a, b| {
                (a.centre - truth.centre)
                    .norm()
                    .total_cmp(&(b.centre - truth.centre).norm())
            })
            .unwrap();
        assert!(
            (r.pose.centre - nearest.centre).norm() < 0.5,
            "{:?}",
            r.pose.centre
        );
        assert!(
            (r.pose.centre - truth.centre).norm() < 10.0,
            "{:?}",
            r.pose.centre
        );
    }

    /// Two of seven points wrong by hundreds of pixels: the robust resection finds the
    /// orientation on the five good ones and names them.
    #[test]
    fn robust_resection_ignores_wrong_points() {
        let (cam, truth, mut pts) = scene();
        pts[1].image.x += 400.0 * 3.9e-6;
        pts[4].image.y -= 900.0 * 3.9e-6;
        let (r, inliers) = resect_robust(&cam, &pts, 10.0 * 3.9e-6).unwrap();
        assert_eq!(inliers, vec![0, 2, 3, 5, 6]);
        for k in 0..3 {
            let e = r.pose.centre[k] - truth.centre[k];
            assert!(
                e.abs() < 3.0 * r.cov[(3 + k, 3 + k)].sqrt(),
                "axis {k}: {e}"
            );
        }
        assert!(resect_robust(&cam, &pts[..3], 1e-5).is_err());
    }

    #[test]
    fn three_angles_with_the_centre_known() {
        let (cam, truth, pts) = scene();
        for start in [
            None,
            Some(
                Angles::OmegaPhiKappa {
                    omega: 0.0,
                    phi: 0.0,
                    kappa: 2.0,
                }
                .matrix(),
            ),
        ] {
            let r = resect_angles(&cam, truth.centre, &pts[..3], start).unwrap();
            let d = log_so3(&(r.pose.r * truth.r.transpose()));
            for k in 0..3 {
                assert!(
                    d[k].abs() < 3.0 * r.cov[(k, k)].sqrt(),
                    "angle {k}: {} vs σ {}",
                    d[k],
                    r.cov[(k, k)].sqrt()
                );
            }
        }
    }

    #[test]
    fn bad_geometry_is_refused() {
        let (cam, _, pts) = scene();
        assert_eq!(
            resect(&cam, &pts[..2]).unwrap_err(),
            ResectionError::TooFewPoints(2, 3)
        );
        let line: Vec<Control> = (0..4)
            .map(|k| Control {
                object: Vector3::new(10.0 * k as f64, 5.0 * k as f64, 0.0),
                ..pts[0]
            })
            .collect();
        assert_eq!(resect(&cam, &line).unwrap_err(), ResectionError::Collinear);
        assert_eq!(
            resect_angles(&cam, Vector3::zeros(), &pts[..1], None).unwrap_err(),
            ResectionError::TooFewPoints(1, 2)
        );
    }
}
