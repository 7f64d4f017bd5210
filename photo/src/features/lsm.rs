//! Least-squares image matching (Grün 1985): a template patch around a point of one image is
//! fitted into another image under an affine map and a radiometric offset and scale,
//! T(x) ≈ r₀ + r₁·S(p + A·x), by Gauss–Newton over the eight unknowns. The fitted position p
//! comes with its formal σ (from the residuals and the normal equations) and the normalised
//! cross-correlation of the fitted patches. This is what places a track's measurements on one
//! physical point to a tenth of a pixel, where detectors each find their own blob centre.
//!
//! Positions are in the image's pixels with the origin at the top-left corner of the top-left
//! pixel (a pixel's value lies at its centre), as keypoints are.

use super::GrayImage;
use nalgebra::{Matrix2, SMatrix, SVector, Vector2};

/// How patches are fitted.
#[derive(Clone, Copy, Debug)]
pub struct LsmOptions {
    /// Half the template's side, pixels (side 2·half + 1).
    pub half: usize,
    /// Most Gauss–Newton iterations.
    pub max_iterations: usize,
    /// Smallest normalised cross-correlation of a fit that is kept.
    pub min_ncc: f64,
    /// Farthest the fitted position may move from its start, pixels.
    pub max_move_px: f64,
    /// Smallest standard deviation of the template's grey values (a flat patch fixes nothing).
    pub min_contrast: f64,
}

impl Default for LsmOptions {
    fn default() -> Self {
        LsmOptions {
            half: 10,
            max_iterations: 20,
            min_ncc: 0.8,
            max_move_px: 3.0,
            min_contrast: 4.0,
        }
    }
}

/// A template: grey values on the grid of integer offsets around a point, interpolated, kept
/// to 1/256 of a grey level (two bytes a value: a survey's templates stay in memory).
#[derive(Clone, Debug)]
pub struct Template {
    values: Vec<u16>,
    half: usize,
}

/// A fitted patch.
#[derive(Clone, Copy, Debug)]
pub struct Fit {
    /// The template centre's position in the searched image, pixels.
    pub position: Vector2<f64>,
    /// Formal σ of the position (root mean of the two variances), pixels.
    pub sigma: f64,
    /// Normalised cross-correlation of the template and the fitted patch.
    pub ncc: f64,
    /// The fitted affine map (template offsets to image offsets).
    pub affine: Matrix2<f64>,
}

/// Bilinear grey value at `p` (corner convention); None outside the pixel centres.
fn sample(img: &GrayImage, p: Vector2<f64>) -> Option<f64> {
    let (u, v) = (p.x - 0.5, p.y - 0.5);
    if !(u >= 0.0 && v >= 0.0) {
        return None;
    }
    // Non-negative here, so truncation is the floor (and no libm call on baseline x86-64,
    // where `floor` took 2.5 % of a Brighton match).
    let (i, j) = (u as usize, v as usize);
    let w = img.width as usize;
    if i >= w.saturating_sub(1) || j >= (img.height as usize).saturating_sub(1) {
        return None;
    }
    let (fx, fy) = (u - i as f64, v - j as f64);
    let at = |x: usize, y: usize| img.data[y * w + x] as f64;
    let top = at(i, j) * (1.0 - fx) + at(i + 1, j) * fx;
    let bottom = at(i, j + 1) * (1.0 - fx) + at(i + 1, j + 1) * fx;
    Some(top * (1.0 - fy) + bottom * fy)
}

fn offsets(half: usize) -> impl Iterator<Item = Vector2<f64>> {
    let h = half as i64;
    (-h..=h).flat_map(move |y| (-h..=h).map(move |x| Vector2::new(x as f64, y as f64)))
}

/// Mean and standard deviation.
fn moments(v: impl Iterator<Item = f64> + Clone) -> (f64, f64) {
    let n = v.clone().count().max(1) as f64;
    let m = v.clone().sum::<f64>() / n;
    let s = (v.map(|x| (x - m) * (x - m)).sum::<f64>() / n).sqrt();
    (m, s)
}

impl Template {
    /// The template of `img` around `centre`; None when it leaves the image or is too flat.
    /// (Centred on the nearest pixel centre instead, uninterpolated, the fits that fail keep
    /// their keypoints' point while the others move to the pixel centre's: worse on both the
    /// textured block and Brighton Beach.)
    pub fn cut(img: &GrayImage, centre: Vector2<f64>, o: &LsmOptions) -> Option<Template> {
        let values = offsets(o.half)
            .map(|d| sample(img, centre + d).map(|x| (x * 256.0).round() as u16))
            .collect::<Option<Vec<u16>>>()?;
        let t = Template {
            values,
            half: o.half,
        };
        let (_, s) = moments(t.grey());
        (s >= o.min_contrast).then_some(t)
    }

    /// The grey values.
    fn grey(&self) -> impl Iterator<Item = f64> + Clone + '_ {
        self.values.iter().map(|&x| x as f64 / 256.0)
    }

    /// Normalised cross-correlation with the patch of `img` at `p` under `a`.
    pub fn ncc(&self, img: &GrayImage, p: Vector2<f64>, a: &Matrix2<f64>) -> Option<f64> {
        let s = offsets(self.half)
            .map(|d| sample(img, p + a * d))
            .collect::<Option<Vec<f64>>>()?;
        let t: Vec<f64> = self.grey().collect();
        let (mt, st) = moments(t.iter().copied());
        let (ms, ss) = moments(s.iter().copied());
        if st <= 0.0 || ss <= 0.0 {
            return Some(0.0);
        }
        let c = t
            .iter()
            .zip(&s)
            .map(|(x, y)| (x - mt) * (y - ms))
            .sum::<f64>();
        Some(c / (t.len() as f64 * st * ss))
    }

    /// Fit the template into `img` from position `p` and affine map `a` (template offsets to
    /// image offsets); None when it does not converge, leaves the image, moves too far, ends
    /// with a degenerate map or correlates too weakly.
    pub fn fit(
        &self,
        img: &GrayImage,
        p0: Vector2<f64>,
        a0: &Matrix2<f64>,
        o: &LsmOptions,
    ) -> Option<Fit> {
        let (mut p, mut a) = (p0, *a0);
        let t: Vec<f64> = self.grey().collect();
        let (mt, st) = moments(t.iter().copied());
        let s0 = offsets(self.half)
            .map(|d| sample(img, p + a * d))
            .collect::<Option<Vec<f64>>>()?;
        let (ms, ss) = moments(s0.iter().copied());
        let mut r1 = if ss > 0.0 { st / ss } else { 1.0 };
        let mut r0 = mt - r1 * ms;
        let mut converged = false;
        let mut last = None;
        for _ in 0..o.max_iterations {
            let mut n = SMatrix::<f64, 8, 8>::zeros();
            let mut g = SVector::<f64, 8>::zeros();
            let mut sq = 0.0;
            for (d, tv) in offsets(self.half).zip(&t) {
                let y = p + a * d;
                let s = sample(img, y)?;
                let gx = (sample(img, y + Vector2::x())? - sample(img, y - Vector2::x())?) / 2.0;
                let gy = (sample(img, y + Vector2::y())? - sample(img, y - Vector2::y())?) / 2.0;
                let e = r0 + r1 * s - tv;
                let j = SVector::<f64, 8>::from([
                    r1 * gx,
                    r1 * gy,
                    r1 * gx * d.x,
                    r1 * gx * d.y,
                    r1 * gy * d.x,
                    r1 * gy * d.y,
                    1.0,
                    s,
                ]);
                n += j * j.transpose();
                g += j * e;
                sq += e * e;
            }
            let chol = n.cholesky()?;
            let dx = chol.solve(&(-g));
            p += Vector2::new(dx[0], dx[1]);
            a += Matrix2::new(dx[2], dx[3], dx[4], dx[5]);
            r0 += dx[6];
            r1 += dx[7];
            last = Some((chol, sq));
            if (p - p0).norm() > o.max_move_px || !dx.iter().all(|x| x.is_finite()) {
                return None;
            }
            if dx[0].hypot(dx[1]) < 1e-3 {
                converged = true;
                break;
            }
        }
        let (chol, sq) = last?;
        let sv = a.singular_values();
        if !converged || sv.min() < 0.5 || sv.max() > 2.0 || r1 <= 0.0 {
            return None;
        }
        let dof = (t.len() as f64 - 8.0).max(1.0);
        let cov = chol.inverse() * (sq / dof);
        let ncc = self.ncc(img, p, &a)?;
        (ncc >= o.min_ncc).then_some(Fit {
            position: p,
            sigma: ((cov[(0, 0)] + cov[(1, 1)]) / 2.0).sqrt(),
            ncc,
            affine: a,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth textured image: a sum of blobs and waves.
    fn image(w: u32, h: u32, shift: Vector2<f64>, rot: f64) -> GrayImage {
        let (c, s) = (rot.cos(), rot.sin());
        let centre = Vector2::new(w as f64 / 2.0, h as f64 / 2.0);
        let mut data = Vec::with_capacity((w * h) as usize);
        for y in 0..h {
            for x in 0..w {
                // The scene point seen at this pixel centre: undo the rotation about the
                // centre, then the shift.
                let q = Vector2::new(x as f64 + 0.5, y as f64 + 0.5) - centre - shift;
                let r = Vector2::new(c * q.x + s * q.y, -s * q.x + c * q.y);
                let v = 128.0
                    + 50.0 * (r.x / 5.3).sin() * (r.y / 4.1).cos()
                    + 40.0 * (-((r.x - 3.0).powi(2) + (r.y + 2.0).powi(2)) / 30.0).exp()
                    + 20.0 * ((r.x + r.y) / 7.7).sin();
                data.push(v.round().clamp(0.0, 255.0) as u8);
            }
        }
        GrayImage {
            width: w,
            height: h,
            data,
        }
    }

    #[test]
    fn a_shifted_and_rotated_patch_is_found_to_a_twentieth_of_a_pixel() {
        let o = LsmOptions::default();
        let a = image(80, 80, Vector2::zeros(), 0.0);
        let shift = Vector2::new(1.37, -0.84);
        let rot = 0.12;
        let b = image(80, 80, shift, rot);
        let centre = Vector2::new(40.0, 40.0);
        let t = Template::cut(&a, centre, &o).unwrap();
        // The true position of the template's centre in b: rotated about b's centre, shifted.
        let (c, s) = (rot.cos(), rot.sin());
        let a_true = Matrix2::new(c, -s, s, c);
        let truth = centre + shift; // the template's centre is b's rotation centre
        let start = centre + Vector2::new(1.0, -1.0);
        let f = t.fit(&b, start, &Matrix2::identity(), &o).unwrap();
        let err = (f.position - truth).norm();
        assert!(err < 0.05, "{err} px off ({:?})", f.position);
        assert!(f.ncc > 0.99 && f.sigma < 0.05, "{f:?}");
        assert!(t.ncc(&b, truth, &a_true).unwrap() > 0.99);
        // A flat template is refused; a start too far off does not converge to a fit.
        let flat = GrayImage {
            width: 40,
            height: 40,
            data: vec![100; 1600],
        };
        assert!(Template::cut(&flat, Vector2::new(20.0, 20.0), &o).is_none());
        let far = t.fit(
            &b,
            centre + Vector2::new(9.0, 7.0),
            &Matrix2::identity(),
            &o,
        );
        assert!(far.is_none_or(|f| (f.position - truth).norm() < 0.05));
    }
}
