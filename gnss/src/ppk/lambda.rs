//! Integer least-squares ambiguity resolution: LAMBDA decorrelation (Teunissen 1995) with the
//! modified search of Chang, Yang and Zhou (MLAMBDA, 2005), and partial resolution of the most
//! precise decorrelated ambiguities by their bootstrapped success rate (Teunissen 1998;
//! Verhagen et al.).
//!
//! Matrices are column-major `Vec<f64>`; `m(i, j) = v[i + j * n]`. After the reduction,
//! Q_ẑ = Lᵀ·D·L with ẑ = Zᵀ·a; the search fixes ẑ from the last element to the first, each
//! conditioned on those after it, so `d[i]` is the conditional variance of ẑ_i given
//! ẑ_{i+1..n}. The last `k` elements form a subset whose own factorisation is the lower-right
//! k×k part of L and D: it can be searched and validated alone.

/// The best `m` integer vectors and their squared distances (ascending).
#[derive(Clone, Debug)]
pub struct IntegerCandidates {
    /// Integer vectors, best first.
    pub fixes: Vec<Vec<f64>>,
    /// Their squared distances (Q⁻¹ norm) from the float vector.
    pub distances: Vec<f64>,
}

impl IntegerCandidates {
    /// Ratio of the second-best to the best squared distance.
    pub fn ratio(&self) -> f64 {
        match (self.distances.first(), self.distances.get(1)) {
            (Some(a), Some(b)) if *a > 0.0 => b / a,
            (Some(_), Some(_)) => f64::INFINITY,
            _ => 0.0,
        }
    }
}

const LOOPMAX: usize = 100_000;

fn round(x: f64) -> f64 {
    (x + 0.5).floor()
}
fn sgn(x: f64) -> f64 {
    if x <= 0.0 {
        -1.0
    } else {
        1.0
    }
}

/// L^T·D·L factorisation of a symmetric positive-definite `q` (n×n).
fn ld(n: usize, q: &[f64]) -> Option<(Vec<f64>, Vec<f64>)> {
    let mut a = q.to_vec();
    let mut l = vec![0.0; n * n];
    let mut d = vec![0.0; n];
    for i in (0..n).rev() {
        d[i] = a[i + i * n];
        if d[i] <= 0.0 || !d[i].is_finite() {
            return None;
        }
        let s = d[i].sqrt();
        for j in 0..=i {
            l[i + j * n] = a[i + j * n] / s;
        }
        for j in 0..i {
            for k in 0..=j {
                a[j + k * n] -= l[i + k * n] * l[i + j * n];
            }
        }
        let lii = l[i + i * n];
        for j in 0..=i {
            l[i + j * n] /= lii;
        }
    }
    Some((l, d))
}

fn gauss(n: usize, l: &mut [f64], z: &mut [f64], i: usize, j: usize) {
    let mu = round(l[i + j * n]);
    if mu != 0.0 {
        for k in i..n {
            l[k + n * j] -= mu * l[k + i * n];
        }
        for k in 0..n {
            z[k + n * j] -= mu * z[k + i * n];
        }
    }
}

fn perm(n: usize, l: &mut [f64], d: &mut [f64], j: usize, del: f64, z: &mut [f64]) {
    let eta = d[j] / del;
    let lam = d[j + 1] * l[j + 1 + j * n] / del;
    d[j] = eta * d[j + 1];
    d[j + 1] = del;
    for k in 0..j {
        let a0 = l[j + k * n];
        let a1 = l[j + 1 + k * n];
        l[j + k * n] = -l[j + 1 + j * n] * a0 + a1;
        l[j + 1 + k * n] = eta * a0 + lam * a1;
    }
    l[j + 1 + j * n] = lam;
    for k in j + 2..n {
        l.swap(k + j * n, k + (j + 1) * n);
    }
    for k in 0..n {
        z.swap(k + j * n, k + (j + 1) * n);
    }
}

fn reduction(n: usize, l: &mut [f64], d: &mut [f64], z: &mut [f64]) {
    if n < 2 {
        return;
    }
    let mut j = n as isize - 2;
    let mut k = n as isize - 2;
    while j >= 0 {
        let ju = j as usize;
        if j <= k {
            for i in ju + 1..n {
                gauss(n, l, z, i, ju);
            }
        }
        let del = d[ju] + l[ju + 1 + ju * n] * l[ju + 1 + ju * n] * d[ju + 1];
        if del + 1e-6 < d[ju + 1] {
            perm(n, l, d, ju, del, z);
            k = j;
            j = n as isize - 2;
        } else {
            j -= 1;
        }
    }
}

fn search(
    n: usize,
    m: usize,
    l: &[f64],
    d: &[f64],
    zs: &[f64],
) -> Option<(Vec<Vec<f64>>, Vec<f64>)> {
    let mut s_mat = vec![0.0; n * n];
    let mut dist = vec![0.0; n];
    let mut zb = vec![0.0; n];
    let mut z = vec![0.0; n];
    let mut step = vec![0.0; n];
    let mut zn: Vec<Vec<f64>> = Vec::with_capacity(m);
    let mut s: Vec<f64> = Vec::with_capacity(m);
    let mut imax = 0usize;
    let mut maxdist = f64::INFINITY;
    let mut k = n - 1;
    zb[k] = zs[k];
    z[k] = round(zb[k]);
    let mut y = zb[k] - z[k];
    step[k] = sgn(y);
    let mut done = false;
    for _ in 0..LOOPMAX {
        let newdist = dist[k] + y * y / d[k];
        if newdist < maxdist {
            if k != 0 {
                k -= 1;
                dist[k] = newdist;
                for i in 0..=k {
                    s_mat[k + i * n] =
                        s_mat[k + 1 + i * n] + (z[k + 1] - zb[k + 1]) * l[k + 1 + i * n];
                }
                zb[k] = zs[k] + s_mat[k + k * n];
                z[k] = round(zb[k]);
                y = zb[k] - z[k];
                step[k] = sgn(y);
            } else {
                if zn.len() < m {
                    if zn.is_empty() || newdist > s[imax] {
                        imax = zn.len();
                    }
                    zn.push(z.clone());
                    s.push(newdist);
                } else {
                    if newdist < s[imax] {
                        zn[imax] = z.clone();
                        s[imax] = newdist;
                        imax = 0;
                        for i in 0..m {
                            if s[imax] < s[i] {
                                imax = i;
                            }
                        }
                    }
                    maxdist = s[imax];
                }
                z[0] += step[0];
                y = zb[0] - z[0];
                step[0] = -step[0] - sgn(step[0]);
            }
        } else if k == n - 1 {
            done = true;
            break;
        } else {
            k += 1;
            z[k] += step[k];
            y = zb[k] - z[k];
            step[k] = -step[k] - sgn(step[k]);
        }
    }
    if !done || zn.is_empty() {
        return None;
    }
    let mut idx: Vec<usize> = (0..zn.len()).collect();
    idx.sort_by(|&a, &b| s[a].partial_cmp(&s[b]).unwrap_or(std::cmp::Ordering::Equal));
    Some((
        idx.iter().map(|&i| zn[i].clone()).collect(),
        idx.iter().map(|&i| s[i]).collect(),
    ))
}

/// Float ambiguities after the LAMBDA reduction: what partial resolution reads.
#[derive(Clone, Debug)]
pub struct Decorrelated {
    /// Number of ambiguities.
    pub n: usize,
    /// Unit lower-triangular factor of Q_ẑ = Lᵀ·D·L (column-major).
    l: Vec<f64>,
    /// Conditional variances of the decorrelated ambiguities.
    pub d: Vec<f64>,
    /// The transformation: ẑ = Zᵀ·a (column-major n×n, integer entries).
    pub z: Vec<f64>,
    /// The decorrelated float ambiguities ẑ.
    pub zs: Vec<f64>,
}

/// The standard normal distribution's error function, erf(x), to about 1e-7 (Numerical
/// Recipes' Chebyshev fit of erfc).
fn erf(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.26551223
        + t * (1.00002368
            + t * (0.37409196
                + t * (0.09678418
                    + t * (-0.18628806
                        + t * (0.27886807
                            + t * (-1.13520398
                                + t * (1.48851587 + t * (-0.82215223 + t * 0.17087277))))))));
    let erfc = t * poly.exp();
    if x >= 0.0 {
        1.0 - erfc
    } else {
        erfc - 1.0
    }
}

/// A decorrelated ambiguity's chance of rounding to its integer, 2Φ(1 / (2σ)) − 1, from its
/// conditional variance `d`.
fn fix_rate(d: f64) -> f64 {
    erf(1.0 / (2.0 * (2.0 * d).sqrt()))
}

impl Decorrelated {
    /// Bootstrapped success rate of fixing the last `k` decorrelated ambiguities:
    /// Π (2Φ(1 / (2σ_i)) − 1) over their conditional sigmas, a sharp lower bound of the
    /// integer least-squares success rate.
    pub fn success_rate(&self, k: usize) -> f64 {
        self.d[self.n - k.min(self.n)..]
            .iter()
            .map(|&d| fix_rate(d))
            .product()
    }

    /// The largest `k` whose [`Self::success_rate`] reaches `p_min` (0 when not even one).
    /// Each ambiguity's rate is computed once (the products, in the same order as
    /// [`Self::success_rate`]'s, are cheap; `erf` is not).
    pub fn most_fixable(&self, p_min: f64) -> usize {
        let rates: Vec<f64> = self.d.iter().map(|&d| fix_rate(d)).collect();
        (1..=self.n)
            .take_while(|&k| rates[self.n - k..].iter().product::<f64>() >= p_min)
            .last()
            .unwrap_or(0)
    }

    /// Integer least squares on the last `k` decorrelated ambiguities alone: the `m` best
    /// integer vectors of ẑ_{n−k..n} (in ẑ space) and their squared distances.
    pub fn search_last(&self, k: usize, m: usize) -> Option<IntegerCandidates> {
        let n = self.n;
        if k == 0 || k > n {
            return None;
        }
        let s0 = n - k;
        let l: Vec<f64> = (0..k * k)
            .map(|idx| {
                let (i, j) = (idx % k, idx / k);
                self.l[(s0 + i) + (s0 + j) * n]
            })
            .collect();
        let (fixes, distances) = search(k, m, &l, &self.d[s0..], &self.zs[s0..])?;
        Some(IntegerCandidates { fixes, distances })
    }

    /// Column `j` of Z: how the decorrelated ambiguity ẑ_j combines the original ones.
    pub fn z_column(&self, j: usize) -> &[f64] {
        &self.z[j * self.n..(j + 1) * self.n]
    }
}

/// The LAMBDA reduction of float ambiguities `a` with covariance `q` (n×n, column-major);
/// `None` when `q` is not positive definite.
pub fn decorrelate(a: &[f64], q: &[f64]) -> Option<Decorrelated> {
    let n = a.len();
    if n == 0 || q.len() != n * n {
        return None;
    }
    let (mut l, mut d) = ld(n, q)?;
    let mut z = vec![0.0; n * n];
    for i in 0..n {
        z[i + i * n] = 1.0;
    }
    reduction(n, &mut l, &mut d, &mut z);
    let zs: Vec<f64> = (0..n)
        .map(|j| (0..n).map(|i| z[i + j * n] * a[i]).sum())
        .collect();
    Some(Decorrelated { n, l, d, z, zs })
}

/// Integer least squares: the `m` best integer vectors for float `a` with covariance `q`
/// (n×n, column-major). `None` when `q` is not positive definite or the search fails.
pub fn lambda(a: &[f64], q: &[f64], m: usize) -> Option<IntegerCandidates> {
    let Decorrelated { n, l, d, z, zs } = decorrelate(a, q)?;
    let (e, s) = search(n, m, &l, &d, &zs)?;
    // F = Z⁻ᵀ·E: solve Zᵀ·f = e for each candidate.
    let zt = nalgebra::DMatrix::from_fn(n, n, |i, j| z[j + i * n]);
    let lu = zt.lu();
    let fixes = e
        .iter()
        .map(|ei| {
            let f = lu.solve(&nalgebra::DVector::from_column_slice(ei))?;
            Some(f.iter().map(|v| v.round()).collect::<Vec<f64>>())
        })
        .collect::<Option<Vec<_>>>()?;
    Some(IntegerCandidates {
        fixes,
        distances: s,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_nearest_integers_of_a_correlated_float_vector() {
        // A strongly correlated 3×3 covariance (typical of DD ambiguities).
        let q = [
            6.290, 5.978, 0.544, //
            5.978, 6.292, 2.340, //
            0.544, 2.340, 6.288,
        ];
        let a = [5.45, 3.10, 2.97];
        let c = lambda(&a, &q, 2).unwrap();
        // Brute force over a box for the reference answer.
        let qi = nalgebra::Matrix3::from_column_slice(&q)
            .try_inverse()
            .unwrap();
        let mut best = (f64::INFINITY, [0.0; 3]);
        for i in -5..15 {
            for j in -5..15 {
                for k in -5..15 {
                    let d =
                        nalgebra::Vector3::new(a[0] - i as f64, a[1] - j as f64, a[2] - k as f64);
                    let s = (d.transpose() * qi * d)[0];
                    if s < best.0 {
                        best = (s, [i as f64, j as f64, k as f64]);
                    }
                }
            }
        }
        assert_eq!(c.fixes[0], best.1.to_vec());
        assert!((c.distances[0] - best.0).abs() < 1e-9);
        assert!(c.ratio() >= 1.0);
        // The whole set searched as a subset gives the same answer in ẑ space.
        let dec = decorrelate(&a, &q).unwrap();
        let all = dec.search_last(3, 2).unwrap();
        let zfix: Vec<f64> = (0..3)
            .map(|j| (0..3).map(|i| dec.z_column(j)[i] * best.1[i]).sum())
            .collect();
        assert_eq!(all.fixes[0], zfix);
    }

    /// Success rates: one ambiguity with σ = 0.1 cycle fixes with 2Φ(5) − 1 = 1 − 5.7e-7;
    /// σ = 0.5 with 2Φ(1) − 1 = 0.6827; the product over a subset; the largest subset above
    /// a bound.
    #[test]
    fn bootstrapped_success_rate() {
        assert!((erf(1.0) - 0.842_700_79).abs() < 2e-7);
        assert!((erf(-0.5) + 0.520_499_88).abs() < 2e-7);
        let dec = Decorrelated {
            n: 3,
            l: vec![1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
            d: vec![0.25, 0.01, 0.0001],
            z: vec![1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
            zs: vec![0.4, 1.1, 2.0],
        };
        let p1 = dec.success_rate(1);
        assert!((1.0 - p1) < 1e-20 + 1e-7, "{p1}");
        assert!((dec.success_rate(2) - p1 * (1.0 - 5.733e-7)).abs() < 2e-7);
        assert!((dec.success_rate(3) / dec.success_rate(2) - 0.682_689_5).abs() < 2e-7);
        assert_eq!(dec.most_fixable(0.999), 2);
        assert_eq!(dec.most_fixable(0.5), 3);
        let two = dec.search_last(2, 2).unwrap();
        assert_eq!(two.fixes[0], vec![1.0, 2.0]);
    }
}
