//! Relative orientation of two calibrated images from their corresponding rays: the essential
//! matrix from five correspondences (the constraints det E = 0 and 2·E·Eᵀ·E − tr(E·Eᵀ)·E = 0
//! on the four-dimensional null space of the epipolar equations, solved by Gauss–Jordan
//! elimination and the eigenvectors of the 10 × 10 action matrix of x, as Stewénius, Engels
//! and Nistér describe it), RANSAC over five-point samples, and the rotation and baseline
//! direction of the solution with the points in front of both cameras.
//!
//! What enters: unit rays in each camera's frame (x right, y up, the camera looking along
//! −z; see [`crate::camera`]). What leaves: E with x_bᵀ·E·x_a = 0, the second camera's pose
//! relative to the first (first at the origin, unrotated; baseline of length 1) and the
//! inliers. Works on planar scenes, where the eight-point F is degenerate. Deterministic for a
//! seed. And the similarity that places such a block onto known points ([`similarity`]).

use crate::camera::Pose;
use nalgebra::{DMatrix, Matrix3, SMatrix, Vector3};

/// Exponents (x, y, z) of the 20 monomials of degree ≤ 3: the ten cubics first, then the
/// basis of the quotient ring (x², xy, xz, y², yz, z², x, y, z, 1).
const MONOMIALS: [(u8, u8, u8); 20] = [
    (3, 0, 0),
    (2, 1, 0),
    (2, 0, 1),
    (1, 2, 0),
    (1, 1, 1),
    (1, 0, 2),
    (0, 3, 0),
    (0, 2, 1),
    (0, 1, 2),
    (0, 0, 3),
    (2, 0, 0),
    (1, 1, 0),
    (1, 0, 1),
    (0, 2, 0),
    (0, 1, 1),
    (0, 0, 2),
    (1, 0, 0),
    (0, 1, 0),
    (0, 0, 1),
    (0, 0, 0),
];

/// A polynomial in x, y, z of degree ≤ 3, by [`MONOMIALS`].
type Poly = [f64; 20];

fn index_of(e: (u8, u8, u8)) -> usize {
    MONOMIALS
        .iter()
        .position(|&m| m == e)
        .expect("degree at most 3")
}

fn mul(p: &Poly, q: &Poly) -> Poly {
    let mut r = [0.0; 20];
    for (i, &a) in p.iter().enumerate().filter(|(_, a)| **a != 0.0) {
        for (j, &b) in q.iter().enumerate().filter(|(_, b)| **b != 0.0) {
            let (m, n) = (MONOMIALS[i], MONOMIALS[j]);
            r[index_of((m.0 + n.0, m.1 + n.1, m.2 + n.2))] += a * b;
        }
    }
    r
}

fn add(p: &Poly, q: &Poly, s: f64) -> Poly {
    std::array::from_fn(|i| p[i] + s * q[i])
}

/// The essential matrices of five correspondences `b[i]ᵀ·E·a[i] = 0` (up to ten).
pub fn five_point(a: &[Vector3<f64>; 5], b: &[Vector3<f64>; 5]) -> Vec<Matrix3<f64>> {
    // The epipolar equations: row i is b_i ⊗ a_i over E's entries, row by row.
    let mut q = SMatrix::<f64, 9, 9>::zeros();
    for i in 0..5 {
        for j in 0..3 {
            for k in 0..3 {
                q[(i, 3 * j + k)] = b[i][j] * a[i][k];
            }
        }
    }
    let svd = q.svd(false, true);
    let Some(vt) = svd.v_t else {
        return Vec::new();
    };
    // The four right singular vectors of the smallest singular values span the null space.
    let mut order: Vec<usize> = (0..9).collect();
    order.sort_by(|&i, &j| svd.singular_values[i].total_cmp(&svd.singular_values[j]));
    let basis: Vec<[f64; 9]> = order[..4]
        .iter()
        .map(|&r| std::array::from_fn(|c| vt[(r, c)]))
        .collect();
    // E = x·X + y·Y + z·Z + W: each entry a linear polynomial.
    let entry = |j: usize, k: usize| -> Poly {
        let mut p = [0.0; 20];
        p[index_of((1, 0, 0))] = basis[0][3 * j + k];
        p[index_of((0, 1, 0))] = basis[1][3 * j + k];
        p[index_of((0, 0, 1))] = basis[2][3 * j + k];
        p[index_of((0, 0, 0))] = basis[3][3 * j + k];
        p
    };
    let e: [[Poly; 3]; 3] = std::array::from_fn(|j| std::array::from_fn(|k| entry(j, k)));
    let m = constraints(&e);
    let Some(action) = action_matrix(&m) else {
        return Vec::new();
    };
    solutions(&action)
        .into_iter()
        .map(|(x, y, z)| {
            Matrix3::from_fn(|j, k| {
                x * basis[0][3 * j + k]
                    + y * basis[1][3 * j + k]
                    + z * basis[2][3 * j + k]
                    + basis[3][3 * j + k]
            })
        })
        .collect()
}

/// The ten cubic constraints on E's polynomial entries: det E and the nine entries of
/// 2·E·Eᵀ·E − tr(E·Eᵀ)·E.
fn constraints(e: &[[Poly; 3]; 3]) -> [Poly; 10] {
    let mut out = [[0.0; 20]; 10];
    let minor = |a: usize, b: usize, c: usize, d: usize| {
        add(&mul(&e[1][a], &e[2][b]), &mul(&e[1][c], &e[2][d]), -1.0)
    };
    let det = add(
        &add(
            &mul(&e[0][0], &minor(1, 2, 2, 1)),
            &mul(&e[0][1], &minor(0, 2, 2, 0)),
            -1.0,
        ),
        &mul(&e[0][2], &minor(0, 1, 1, 0)),
        1.0,
    );
    out[0] = det;
    // E·Eᵀ (quadratics) and its trace.
    let eet: [[Poly; 3]; 3] = std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            (0..3).fold([0.0; 20], |s, k| add(&s, &mul(&e[i][k], &e[j][k]), 1.0))
        })
    });
    let trace = add(&add(&eet[0][0], &eet[1][1], 1.0), &eet[2][2], 1.0);
    for i in 0..3 {
        for j in 0..3 {
            let eete = (0..3).fold([0.0; 20], |s, k| add(&s, &mul(&eet[i][k], &e[k][j]), 1.0));
            out[1 + 3 * i + j] = add(&add(&[0.0; 20], &eete, 2.0), &mul(&trace, &e[i][j]), -1.0);
        }
    }
    out
}

/// Gauss–Jordan on the cubics, then the action matrix of multiplication by x on the basis
/// (x², xy, xz, y², yz, z², x, y, z, 1); `None` when the cubics are dependent.
fn action_matrix(m: &[Poly; 10]) -> Option<SMatrix<f64, 10, 10>> {
    let c = DMatrix::from_fn(10, 10, |r, k| m[r][k]);
    let d = DMatrix::from_fn(10, 10, |r, k| m[r][10 + k]);
    // Each cubic monomial = −Σ B[m, c]·basis_c.
    let b = c.lu().solve(&d)?;
    let mut a = SMatrix::<f64, 10, 10>::zeros();
    // x·x², x·xy, x·xz, x·y², x·yz, x·z² are the cubics x³, x²y, x²z, xy², xyz, xz².
    for r in 0..6 {
        for k in 0..10 {
            a[(r, k)] = -b[(r, k)];
        }
    }
    // x·x = x², x·y = xy, x·z = xz, x·1 = x.
    a[(6, 0)] = 1.0;
    a[(7, 1)] = 1.0;
    a[(8, 2)] = 1.0;
    a[(9, 6)] = 1.0;
    a.iter().all(|v| v.is_finite()).then_some(a)
}

/// (x, y, z) of each real eigenvalue of the action matrix, read off its eigenvector.
fn solutions(a: &SMatrix<f64, 10, 10>) -> Vec<(f64, f64, f64)> {
    let mut out = Vec::new();
    for ev in a.complex_eigenvalues().iter() {
        if ev.im.abs() > 1e-8 * (1.0 + ev.re.abs()) {
            continue;
        }
        let shifted = a - SMatrix::<f64, 10, 10>::identity() * ev.re;
        let svd = shifted.svd(false, true);
        let Some(vt) = svd.v_t else {
            continue;
        };
        let (row, _) = svd.singular_values.argmin();
        let v = vt.row(row);
        if v[9].abs() < 1e-12 {
            continue;
        }
        out.push((v[6] / v[9], v[7] / v[9], v[8] / v[9]));
    }
    out
}

/// The depths along the rays `a` (first camera) and `b` (second) of the point where they
/// meet, with `x_b = R·x_a + t`; least squares on s_a·R·a − s_b·b = −t.
fn depths(r: &Matrix3<f64>, t: &Vector3<f64>, a: &Vector3<f64>, b: &Vector3<f64>) -> (f64, f64) {
    let ra = r * a;
    let m = nalgebra::Matrix3x2::from_columns(&[ra, -b]);
    let mtm = m.transpose() * m;
    match mtm.try_inverse() {
        Some(inv) => {
            let s = inv * (m.transpose() * -t);
            (s[0], s[1])
        }
        None => (-1.0, -1.0),
    }
}

/// Rays point away from the camera along −z, so a point in front has a positive depth along
/// its ray.
fn in_front(r: &Matrix3<f64>, t: &Vector3<f64>, a: &Vector3<f64>, b: &Vector3<f64>) -> bool {
    let (sa, sb) = depths(r, t, a, b);
    sa > 0.0 && sb > 0.0
}

/// The four (R, t) of an essential matrix (x_b = R·x_a + t, |t| = 1).
fn decompose(e: &Matrix3<f64>) -> Vec<(Matrix3<f64>, Vector3<f64>)> {
    let svd = e.svd(true, true);
    let (Some(mut u), Some(mut vt)) = (svd.u, svd.v_t) else {
        return Vec::new();
    };
    if u.determinant() < 0.0 {
        u = -u;
    }
    if vt.determinant() < 0.0 {
        vt = -vt;
    }
    let w = Matrix3::new(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0);
    let t: Vector3<f64> = u.column(2).into();
    let (r1, r2) = (u * w * vt, u * w.transpose() * vt);
    vec![(r1, t), (r1, -t), (r2, t), (r2, -t)]
}

/// The angular epipolar error of a correspondence: the distance of `b` from the plane of the
/// epipolar line, and of `a` from its own, radians (the larger).
fn epipolar_error(e: &Matrix3<f64>, a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    let (la, lb) = (e.transpose() * b, e * a);
    let v = b.dot(&lb).abs();
    let da = v / la.norm().max(1e-300);
    let db = v / lb.norm().max(1e-300);
    da.max(db)
}

/// A relative orientation found by RANSAC.
#[derive(Clone, Debug)]
pub struct Relative {
    /// The essential matrix, `b ᵀ·E·a = 0`.
    pub e: Matrix3<f64>,
    /// The second camera's pose in the first camera's frame (centre at distance 1).
    pub second: Pose,
    /// Indices of the correspondences that agree, ascending.
    pub inliers: Vec<usize>,
}

fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// Gauss–Newton on the five elements (a rotation step, the baseline direction in its tangent
/// plane) over the inliers' epipolar errors, from the minimal sample's solution.
fn refine(
    mut r: Matrix3<f64>,
    mut t: Vector3<f64>,
    inliers: &[usize],
    a: &[Vector3<f64>],
    b: &[Vector3<f64>],
) -> (Matrix3<f64>, Vector3<f64>) {
    let residuals = |r: &Matrix3<f64>, t: &Vector3<f64>| -> Vec<f64> {
        let e = skew(t) * r;
        inliers.iter().map(|&i| b[i].dot(&(e * a[i]))).collect()
    };
    let step = |r: &Matrix3<f64>, t: &Vector3<f64>, d: &[f64; 5]| {
        let (u, v) = tangent(t);
        let r = crate::rotation::exp_so3(&Vector3::new(d[0], d[1], d[2])) * r;
        let t = (t + u * d[3] + v * d[4]).normalize();
        (r, t)
    };
    for _ in 0..10 {
        let r0 = residuals(&r, &t);
        let h = 1e-7;
        let cols: Vec<Vec<f64>> = (0..5)
            .map(|k| {
                let mut d = [0.0; 5];
                d[k] = h;
                let (rk, tk) = step(&r, &t, &d);
                residuals(&rk, &tk)
                    .iter()
                    .zip(&r0)
                    .map(|(x, y)| (x - y) / h)
                    .collect()
            })
            .collect();
        let j = DMatrix::from_fn(r0.len(), 5, |i, k| cols[k][i]);
        let f = nalgebra::DVector::from_vec(r0);
        let Some(dx) = (j.transpose() * &j).lu().solve(&(j.transpose() * -f)) else {
            break;
        };
        let d = [dx[0], dx[1], dx[2], dx[3], dx[4]];
        (r, t) = step(&r, &t, &d);
        if dx.norm() < 1e-12 {
            break;
        }
    }
    (r, t)
}

/// Two unit vectors spanning the plane perpendicular to `t`.
fn tangent(t: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let any = if t.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let u = t.cross(&any).normalize();
    (u, t.cross(&u))
}

/// A small deterministic generator for the samples.
struct Lcg(u64);

impl Lcg {
    fn below(&mut self, n: usize) -> usize {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 33) % n as u64) as usize
    }
}

/// RANSAC over five-point samples of the rays `a[i] ↔ b[i]` (unit vectors in each camera's
/// frame): the essential matrix with most correspondences within `threshold` radians of
/// their epipolar planes, then the pose of the second camera with most of them in front of
/// both. `None` with fewer than `min_inliers` agreeing.
pub fn relative_orientation(
    a: &[Vector3<f64>],
    b: &[Vector3<f64>],
    threshold: f64,
    min_inliers: usize,
    seed: u64,
) -> Option<Relative> {
    let n = a.len();
    if n < min_inliers.max(5) || b.len() != n {
        return None;
    }
    let mut rng = Lcg(seed ^ 0x0005_0017);
    let (mut best_e, mut best): (Option<Matrix3<f64>>, Vec<usize>) = (None, Vec::new());
    let (mut it, mut needed) = (0usize, 500usize);
    while it < needed.min(500) {
        it += 1;
        let idx: [usize; 5] = crate::sample::distinct(n, |n| rng.below(n));
        let (sa, sb) = (idx.map(|i| a[i]), idx.map(|i| b[i]));
        for e in five_point(&sa, &sb) {
            let inl: Vec<usize> = (0..n)
                .filter(|&i| epipolar_error(&e, &a[i], &b[i]) < threshold)
                .collect();
            if inl.len() > best.len() {
                best = inl;
                best_e = Some(e);
                let w = best.len() as f64 / n as f64;
                let p_fail = 1.0 - w.powi(5);
                needed = if p_fail <= 1e-12 {
                    it
                } else {
                    ((1e-4f64).ln() / p_fail.ln()).ceil() as usize
                };
            }
        }
    }
    let e = best_e?;
    if best.len() < min_inliers {
        return None;
    }
    let (r, t, _) = decompose(&e)
        .into_iter()
        .map(|(r, t)| {
            let front = best
                .iter()
                .filter(|&&i| in_front(&r, &t, &a[i], &b[i]))
                .count();
            (r, t, front)
        })
        .max_by_key(|x| x.2)?;
    let inliers: Vec<usize> = best
        .into_iter()
        .filter(|&i| in_front(&r, &t, &a[i], &b[i]))
        .collect();
    if inliers.len() < min_inliers {
        return None;
    }
    let (r, t) = refine(r, t, &inliers, a, b);
    let e = skew(&t) * r;
    Some(Relative {
        e,
        second: Pose {
            r: r.transpose(),
            centre: -(r.transpose() * t),
        },
        inliers,
    })
}

/// Similarity (scale, rotation, translation) mapping `from` onto `to` in least squares
/// (Umeyama 1991); `None` with fewer than 3 points or when they are collinear.
pub fn similarity(
    from: &[Vector3<f64>],
    to: &[Vector3<f64>],
) -> Option<(f64, Matrix3<f64>, Vector3<f64>)> {
    let n = from.len() as f64;
    if from.len() < 3 {
        return None;
    }
    let (mf, mt) = (
        from.iter().sum::<Vector3<f64>>() / n,
        to.iter().sum::<Vector3<f64>>() / n,
    );
    let mut cov = Matrix3::zeros();
    let mut var = 0.0;
    for (a, b) in from.iter().zip(to) {
        cov += (b - mt) * (a - mf).transpose();
        var += (a - mf).norm_squared();
    }
    // nalgebra's SVD has no iteration bound: on NaN (huge coordinates overflowed) it never ends.
    if !cov.iter().all(|v| v.is_finite()) {
        return None;
    }
    let svd = cov.svd(true, true);
    let (u, vt) = (svd.u?, svd.v_t?);
    let mut s = Matrix3::identity();
    if (u * vt).determinant() < 0.0 {
        s[(2, 2)] = -1.0;
    }
    let sv = svd.singular_values;
    if sv[1] < 1e-9 * sv[0] || var <= 0.0 {
        return None;
    }
    let r = u * s * vt;
    let scale = (sv[0] * s[(0, 0)] + sv[1] * s[(1, 1)] + sv[2] * s[(2, 2)]) / var;
    Some((scale, r, mt - scale * r * mf))
}

#[cfg(test)]
#[path = "relative_tests.rs"]
mod tests;
