//! The Kalman measurement update, sparse in the design matrix and without the gain.
//!
//! A double-difference row touches the position, two ambiguities and perhaps an ionosphere
//! or troposphere state: a handful of the state's fifty-odd elements. So P·Hᵀ and H·P·Hᵀ are
//! formed from each row's non-zero columns only, and with S = L·Lᵀ the update needs one
//! triangular solve, not the gain K = P·Hᵀ·S⁻¹:
//! W = L⁻¹·(P·Hᵀ)ᵀ,  x = x₀ + Wᵀ·(L⁻¹·ν),  P = P₀ − Wᵀ·W.
//! What enters: the prior covariance, the linearised rows, the innovations about the prior.
//! What leaves: the state correction and the posterior covariance (`None` when S is not
//! positive definite).

use nalgebra::{DMatrix, DVector};

/// The update of a prior with covariance `p0` by the rows `h` (design matrix) with
/// covariance `r` and innovations `innov`: the correction to add to the prior state, and the
/// posterior covariance.
pub(super) fn update(
    p0: &DMatrix<f64>,
    h: &DMatrix<f64>,
    r: &DMatrix<f64>,
    innov: &DVector<f64>,
) -> Option<(DVector<f64>, DMatrix<f64>)> {
    update_keeping_gain(p0, h, r, innov).map(|(dx, p, _)| (dx, p))
}

/// The gain of an update, W and L, kept to correct the prior by other innovations of the
/// same rows (the second linearisation of an iterated update, when the design rows have
/// hardly changed).
pub(super) struct Gain {
    /// Wᵀ = (P·Hᵀ)·L⁻ᵀ, state × rows.
    wt: DMatrix<f64>,
    /// The Cholesky factor of S, lower triangle.
    l: DMatrix<f64>,
}

impl Gain {
    /// The correction Wᵀ·(L⁻¹·ν) to add to the prior state for innovations `innov` of the
    /// rows the gain was formed for.
    pub(super) fn correction(&self, innov: &DVector<f64>) -> DVector<f64> {
        let l = &self.l;
        let mut u = innov.clone();
        for i in 0..u.len() {
            for k in 0..i {
                let lik = l[(i, k)];
                if lik != 0.0 {
                    u[i] -= lik * u[k];
                }
            }
            u[i] /= l[(i, i)];
        }
        &self.wt * u
    }
}

/// [`update`], with the gain it used.
pub(super) fn update_keeping_gain(
    p0: &DMatrix<f64>,
    h: &DMatrix<f64>,
    r: &DMatrix<f64>,
    innov: &DVector<f64>,
) -> Option<(DVector<f64>, DMatrix<f64>, Gain)> {
    let (m, n) = h.shape();
    let nz: Vec<Vec<(usize, f64)>> = (0..m)
        .map(|i| {
            (0..n)
                .filter_map(|j| {
                    let v = h[(i, j)];
                    (v != 0.0).then_some((j, v))
                })
                .collect()
        })
        .collect();
    // P·Hᵀ, column i = Σⱼ h_ij·P[:, j] (P is symmetric).
    let mut pht = DMatrix::zeros(n, m);
    for (i, row) in nz.iter().enumerate() {
        let mut col = pht.column_mut(i);
        for &(j, v) in row {
            col.axpy(v, &p0.column(j), 1.0);
        }
    }
    // S = H·(P·Hᵀ) + R; the Cholesky factorisation reads its lower triangle.
    let mut s = r.clone();
    for b in 0..m {
        let col = pht.column(b);
        for a in b..m {
            s[(a, b)] += nz[a].iter().map(|&(j, v)| v * col[j]).sum::<f64>();
        }
    }
    let l = s.cholesky()?.unpack_dirty();
    // Wᵀ = (P·Hᵀ)·L⁻ᵀ, column by column: Wᵀ[:, i] = (PHᵀ[:, i] − Σₖ₍ₖ₌₀..ᵢ₎ L[i,k]·Wᵀ[:, k]) / L[i,i];
    // every step an axpy over a contiguous column.
    let mut wt = pht;
    for i in 0..m {
        for k in 0..i {
            let lik = l[(i, k)];
            if lik != 0.0 {
                let (done, mut rest) = wt.columns_range_pair_mut(k, i..);
                rest.column_mut(0).axpy(-lik, &done, 1.0);
            }
        }
        wt.column_mut(i).unscale_mut(l[(i, i)]);
    }
    let p = p0 - &wt * wt.transpose();
    let gain = Gain { wt, l };
    Some((gain.correction(innov), p, gain))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sparse, gain-free update equals the textbook one, K = P·Hᵀ·S⁻¹.
    #[test]
    fn equals_the_textbook_update() {
        let n = 7;
        let a = DMatrix::from_fn(n, n, |i, j| ((i * 7 + j * 3) % 11) as f64 * 0.1);
        let p0 = &a * a.transpose() + DMatrix::identity(n, n);
        let mut h = DMatrix::zeros(4, n);
        for (i, cols) in [[0, 3], [1, 4], [2, 5], [0, 6]].iter().enumerate() {
            h[(i, cols[0])] = 0.7 - i as f64 * 0.1;
            h[(i, cols[1])] = 1.0;
        }
        let mut r = DMatrix::from_element(4, 4, 0.2);
        for i in 0..4 {
            r[(i, i)] += 0.5;
        }
        let v = DVector::from_vec(vec![0.3, -0.1, 0.05, 0.2]);
        let (dx, p) = update(&p0, &h, &r, &v).unwrap();
        let s = &h * &p0 * h.transpose() + &r;
        let k = &p0 * h.transpose() * s.try_inverse().unwrap();
        let (dx_ref, p_ref) = (&k * &v, &p0 - &k * &h * &p0);
        assert!((dx - dx_ref).amax() < 1e-12);
        assert!((p - p_ref).amax() < 1e-12);
        // The kept gain corrects the prior for other innovations as K·ν does.
        let (dx, _, gain) = update_keeping_gain(&p0, &h, &r, &v).unwrap();
        assert!((gain.correction(&v) - &dx).amax() < 1e-14);
        let v2 = DVector::from_vec(vec![-0.7, 0.4, 0.01, 1.5]);
        assert!((gain.correction(&v2) - &k * &v2).amax() < 1e-12);
    }
}
