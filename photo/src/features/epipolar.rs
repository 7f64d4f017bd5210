//! Geometric verification of matches: the fundamental matrix F (x_bᵀ·F·x_a = 0) by RANSAC on
//! Hartley-normalised eight-point samples, scored by the Sampson distance, refitted on all its
//! inliers. No camera knowledge is needed, so it also holds where the focal length in the
//! metadata is wrong; lens distortion is absorbed by the threshold. Deterministic for a seed.

use crate::sample::Rng;
use nalgebra::{Matrix3, SMatrix, Vector2, Vector3};

/// How RANSAC runs.
#[derive(Clone, Copy, Debug)]
pub struct RansacOptions {
    /// Inlier threshold: Sampson distance, pixels.
    pub threshold_px: f64,
    /// Most iterations.
    pub max_iterations: usize,
    /// Probability of having drawn one all-inlier sample before stopping early.
    pub confidence: f64,
    /// Fewest inliers for a pair to count as matched.
    pub min_inliers: usize,
}

impl Default for RansacOptions {
    fn default() -> Self {
        RansacOptions {
            threshold_px: 3.0,
            max_iterations: 2000,
            confidence: 0.9999,
            min_inliers: 20,
        }
    }
}

/// A verified model: F and the indices of its inliers (ascending).
#[derive(Clone, Debug)]
pub struct Verified {
    /// The fundamental matrix, first image → epipolar lines in the second.
    pub f: Matrix3<f64>,
    /// Indices into the correspondences.
    pub inliers: Vec<usize>,
}

/// Hartley normalisation: centroid to the origin, mean distance √2.
fn normaliser(p: &[Vector2<f64>]) -> Matrix3<f64> {
    let n = p.len().max(1) as f64;
    let c = p.iter().fold(Vector2::zeros(), |s, x| s + x) / n;
    let d = p.iter().map(|x| (x - c).norm()).sum::<f64>() / n;
    let s = if d > 0.0 { 2f64.sqrt() / d } else { 1.0 };
    Matrix3::new(s, 0.0, -s * c.x, 0.0, s, -s * c.y, 0.0, 0.0, 1.0)
}

fn h(t: &Matrix3<f64>, p: &Vector2<f64>) -> Vector3<f64> {
    t * Vector3::new(p.x, p.y, 1.0)
}

/// F from ≥ 8 correspondences (least squares, rank 2 enforced), `None` when degenerate.
pub fn eight_point(a: &[Vector2<f64>], b: &[Vector2<f64>]) -> Option<Matrix3<f64>> {
    weighted_eight_point(a, b, None)
}

/// [`eight_point`] with each correspondence's algebraic error weighted (for Sampson
/// reweighting: 1 / the gradient norm² under the previous F).
fn weighted_eight_point(
    a: &[Vector2<f64>],
    b: &[Vector2<f64>],
    w: Option<&[f64]>,
) -> Option<Matrix3<f64>> {
    if a.len() < 8 || a.len() != b.len() {
        return None;
    }
    let (ta, tb) = (normaliser(a), normaliser(b));
    let mut ata = SMatrix::<f64, 9, 9>::zeros();
    for (k, (pa, pb)) in a.iter().zip(b).enumerate() {
        let (x, y) = (h(&ta, pa), h(&tb, pb));
        let row = SMatrix::<f64, 1, 9>::from_row_slice(&[
            y.x * x.x,
            y.x * x.y,
            y.x,
            y.y * x.x,
            y.y * x.y,
            y.y,
            x.x,
            x.y,
            1.0,
        ]);
        ata += row.transpose() * row * w.map_or(1.0, |w| w[k]);
    }
    let eig = ata.symmetric_eigen();
    let k = eig.eigenvalues.imin();
    let v = eig.eigenvectors.column(k);
    let fh = Matrix3::from_row_slice(v.as_slice());
    let svd = fh.svd(true, true);
    let (u, vt) = (svd.u?, svd.v_t?);
    let mut s = svd.singular_values;
    if s[0].is_nan() || s[0] <= 0.0 {
        return None;
    }
    // Smallest singular value to zero (the singular values are sorted, largest first).
    let kmin = s.imin();
    s[kmin] = 0.0;
    let f = tb.transpose() * u * Matrix3::from_diagonal(&s) * vt * ta;
    let nrm = f.norm();
    (nrm.is_finite() && nrm > 0.0).then(|| f / nrm)
}

/// Sampson distance (pixels) of a correspondence from F.
pub fn sampson(f: &Matrix3<f64>, a: &Vector2<f64>, b: &Vector2<f64>) -> f64 {
    let (x, y) = (Vector3::new(a.x, a.y, 1.0), Vector3::new(b.x, b.y, 1.0));
    let fx = f * x;
    let ftx = f.transpose() * y;
    let e = y.dot(&fx);
    let d = fx.x * fx.x + fx.y * fx.y + ftx.x * ftx.x + ftx.y * ftx.y;
    if d > 0.0 {
        (e * e / d).sqrt()
    } else {
        f64::INFINITY
    }
}

/// 1 / the squared gradient norm of x_bᵀ·F·x_a (pixels; bounded).
fn gradient_weight(f: &Matrix3<f64>, a: &Vector2<f64>, b: &Vector2<f64>) -> f64 {
    let (x, y) = (Vector3::new(a.x, a.y, 1.0), Vector3::new(b.x, b.y, 1.0));
    let (fx, ftx) = (f * x, f.transpose() * y);
    let d = fx.x * fx.x + fx.y * fx.y + ftx.x * ftx.x + ftx.y * ftx.y;
    if d > 0.0 {
        1.0 / d
    } else {
        0.0
    }
}

fn inliers_of(f: &Matrix3<f64>, a: &[Vector2<f64>], b: &[Vector2<f64>], t: f64) -> Vec<usize> {
    (0..a.len())
        .filter(|&i| sampson(f, &a[i], &b[i]) < t)
        .collect()
}

/// RANSAC for F on correspondences `a[i] ↔ b[i]`; `None` when fewer than
/// `opts.min_inliers` agree.
pub fn verify(
    a: &[Vector2<f64>],
    b: &[Vector2<f64>],
    opts: &RansacOptions,
    seed: u64,
) -> Option<Verified> {
    let n = a.len();
    if n < opts.min_inliers.max(8) || n != b.len() {
        return None;
    }
    let mut rng = Rng(seed ^ 0x5EED_F00D);
    let mut best: Vec<usize> = Vec::new();
    let mut needed = opts.max_iterations;
    let mut it = 0;
    let (mut sa, mut sb) = (Vec::with_capacity(8), Vec::with_capacity(8));
    while it < needed.min(opts.max_iterations) {
        it += 1;
        let idx: [usize; 8] = rng.distinct(n);
        sa.clear();
        sb.clear();
        sa.extend(idx.iter().map(|&i| a[i]));
        sb.extend(idx.iter().map(|&i| b[i]));
        let Some(f) = eight_point(&sa, &sb) else {
            continue;
        };
        let inl = inliers_of(&f, a, b, opts.threshold_px);
        if inl.len() > best.len() {
            best = inl;
            let w = best.len() as f64 / n as f64;
            let p_fail = 1.0 - w.powi(8);
            needed = if p_fail <= 0.0 {
                it
            } else {
                ((1.0 - opts.confidence).ln() / p_fail.ln()).ceil() as usize
            };
        }
    }
    // Refit on the inliers, Sampson-reweighted, until the set settles.
    let mut f: Option<Matrix3<f64>> = None;
    for _ in 0..4 {
        if best.len() < 8 {
            break;
        }
        let (ia, ib): (Vec<_>, Vec<_>) = best.iter().map(|&i| (a[i], b[i])).unzip();
        let w: Option<Vec<f64>> = f.map(|g| {
            ia.iter()
                .zip(&ib)
                .map(|(p, q)| gradient_weight(&g, p, q))
                .collect()
        });
        let Some(g) = weighted_eight_point(&ia, &ib, w.as_deref()) else {
            break;
        };
        best = inliers_of(&g, a, b, opts.threshold_px);
        f = Some(g);
    }
    let f = f?;
    (best.len() >= opts.min_inliers).then_some(Verified { f, inliers: best })
}

/// The componentwise median of displacements (the mean of the two middle values for an even
/// count); zero for none.
pub(crate) fn median_shift<'a>(disp: impl Iterator<Item = &'a Vector2<f64>>) -> Vector2<f64> {
    let (mut x, mut y): (Vec<f64>, Vec<f64>) = disp.map(|v| (v.x, v.y)).unzip();
    if x.is_empty() {
        return Vector2::zeros();
    }
    let med = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        let n = v.len();
        (v[(n - 1) / 2] + v[n / 2]) / 2.0
    };
    Vector2::new(med(&mut x), med(&mut y))
}

/// Motion coherence: which correspondences move like their `k` nearest neighbours (in the
/// first image) do — their displacement within `tol_px` of the neighbours' median
/// displacement. A wrong match that happens to lie near its epipolar line still lands far
/// from where its neighbours go; relief changes displacements smoothly, so true matches pass.
pub fn coherent(a: &[Vector2<f64>], b: &[Vector2<f64>], k: usize, tol_px: f64) -> Vec<bool> {
    let n = a.len();
    if n <= k {
        return vec![true; n];
    }
    let disp: Vec<Vector2<f64>> = a.iter().zip(b).map(|(p, q)| q - p).collect();
    (0..n)
        .map(|i| {
            let mut d: Vec<(f64, usize)> = (0..n)
                .filter(|&j| j != i)
                .map(|j| ((a[j] - a[i]).norm_squared(), j))
                .collect();
            d.select_nth_unstable_by(k - 1, |x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
            let m = median_shift(d[..k].iter().map(|&(_, j)| &disp[j]));
            (disp[i] - m).norm() <= tol_px
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two cameras looking at a non-planar cloud; returns projections and the outlier count.
    fn scene(n: usize, outliers: usize) -> (Vec<Vector2<f64>>, Vec<Vector2<f64>>) {
        let mut rng = Rng(3);
        let mut u = || (rng.next() >> 11) as f64 / (1u64 << 53) as f64;
        let (f, c) = (1000.0, Vector2::new(640.0, 480.0));
        let rot = nalgebra::Rotation3::from_euler_angles(0.02, -0.1, 0.05);
        let t = Vector3::new(-1.0, 0.1, 0.05);
        let (mut a, mut b) = (Vec::new(), Vec::new());
        for i in 0..n {
            let p = Vector3::new(u() * 8.0 - 4.0, u() * 6.0 - 3.0, 8.0 + u() * 6.0);
            let q = rot * p + t;
            a.push(c + Vector2::new(p.x / p.z, p.y / p.z) * f);
            if i < outliers {
                b.push(Vector2::new(u() * 1280.0, u() * 960.0));
            } else {
                b.push(c + Vector2::new(q.x / q.z, q.y / q.z) * f);
            }
        }
        (a, b)
    }

    #[test]
    fn ransac_finds_the_inliers_among_forty_percent_outliers() {
        let (a, b) = scene(300, 120);
        let v = verify(&a, &b, &RansacOptions::default(), 1).expect("a model");
        let wrong_in = v.inliers.iter().filter(|&&i| i < 120).count();
        let right_in = v.inliers.iter().filter(|&&i| i >= 120).count();
        assert_eq!(right_in, 180, "every true match kept");
        // A random point lies within 3 px of its epipolar line now and then.
        assert!(wrong_in <= 3, "{wrong_in} outliers accepted");
        // Exact data: the eight-point fit is exact.
        let g = eight_point(&a[120..], &b[120..]).unwrap();
        let w8 = (120..300)
            .map(|i| sampson(&g, &a[i], &b[i]))
            .fold(0.0, f64::max);
        assert!(w8 < 1e-6, "{w8}");
        // With an accepted outlier the refit bends, but little.
        let mut d: Vec<f64> = (120..300).map(|i| sampson(&v.f, &a[i], &b[i])).collect();
        d.sort_by(f64::total_cmp);
        assert!(
            d[90] < 0.2 && d[179] < 1.5,
            "median {} largest {} px",
            d[90],
            d[179]
        );
        // Deterministic.
        let w = verify(&a, &b, &RansacOptions::default(), 1).unwrap();
        assert_eq!(v.inliers, w.inliers);
    }

    #[test]
    fn a_match_that_leaves_its_neighbours_is_not_coherent() {
        let mut a = Vec::new();
        let mut b = Vec::new();
        for i in 0..100 {
            let p = Vector2::new((i % 10) as f64 * 50.0, (i / 10) as f64 * 50.0);
            a.push(p);
            // Smooth motion (a shift growing across the image, like relief).
            b.push(p + Vector2::new(300.0 + p.x * 0.05, -20.0));
        }
        b[55] += Vector2::new(0.0, 200.0);
        let c = coherent(&a, &b, 8, 30.0);
        assert!(!c[55]);
        assert_eq!(c.iter().filter(|&&x| x).count(), 99);
    }

    #[test]
    fn too_few_agreeing_matches_give_none() {
        let (a, b) = scene(40, 35);
        assert!(verify(&a, &b, &RansacOptions::default(), 1).is_none());
    }
}
