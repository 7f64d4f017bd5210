//! Correlations between the normalised residuals of a few factors (the suspects of a data
//! snooping round), for removing several suspects in one round.
//!
//! With the whitened Jacobian Ā and the cofactors Q of all unknowns, the residuals' cofactors
//! are Q_v̄v̄ = I − Ā·Q·Āᵀ, so between components a ≠ b of two factors ρ_ab = −(Ā·Q·Āᵀ)_ab /
//! √(r_a·r_b), and a blunder showing as w_a in component a shifts w_b by ρ_ab·w_a. The
//! columns Q·Ā_jᵀ come from the Schur complement: b̃_c = Ā_j,cᵀ − Σₑ Wₑ,cᵀ·Vₑ⁻¹·Ā_j,eᵀ,
//! y_c = S⁻¹·b̃_c (the dense inverse, or a solve with the sparse factor), and
//! yₑ = Vₑ⁻¹·(Ā_j,eᵀ − Σ_c Wₑ,c·y_c) where needed.

use super::cofactor::Cofactors;
use nalgebra::DMatrix;
use rayon::prelude::*;

impl Cofactors {
    /// Q·Ā_jᵀ of active factor `j` at every slot of the factors `at` (per factor, per slot:
    /// dim × m_j; `None` for a fixed slot); `None` when a solve fails.
    #[allow(clippy::type_complexity)]
    fn q_column(&self, j: usize, at: &[usize]) -> Option<Vec<Vec<Option<DMatrix<f64>>>>> {
        let (st, lin, red) = (&*self.st, &self.lin, &self.red);
        let m = st.m[j];
        let mut rhs = faer::Mat::<f64>::zeros(st.nr, m);
        // Ā_j,eᵀ per eliminated block of j.
        let mut be: Vec<(usize, DMatrix<f64>)> = Vec::new();
        for s in st.slots.get(j) {
            let Some(jac) = lin.jac(st, j, s) else {
                continue;
            };
            let jt = DMatrix::from_column_slice(m, s.dim, jac).transpose();
            if let Some(c) = s.c {
                for r in 0..s.dim {
                    for k in 0..m {
                        rhs[(st.coff[c] + r, k)] += jt[(r, k)];
                    }
                }
            }
            if let Some(e) = s.e {
                be.push((e, jt));
            }
        }
        let w_of = |e: usize, n: usize| {
            let eb = &st.eblocks[e];
            let (c, o) = (st.nbrs(eb)[n], eb.wbase + st.woff(eb)[n]);
            (
                c,
                DMatrix::from_column_slice(eb.dim, st.cdim[c], &red.w[o..o + eb.dim * st.cdim[c]]),
            )
        };
        let vinv = |e: usize| {
            let eb = &st.eblocks[e];
            DMatrix::from_column_slice(
                eb.dim,
                eb.dim,
                &red.vinv[eb.vbase..eb.vbase + eb.dim * eb.dim],
            )
        };
        for (e, b) in &be {
            let t = vinv(*e) * b;
            for n in 0..st.nbrs(&st.eblocks[*e]).len() {
                let (c, w) = w_of(*e, n);
                let d = w.transpose() * &t;
                for r in 0..st.cdim[c] {
                    for k in 0..m {
                        rhs[(st.coff[c] + r, k)] -= d[(r, k)];
                    }
                }
            }
        }
        let y = self.qcc.solve(st, rhs)?;
        let yc = |c: usize| DMatrix::from_fn(st.cdim[c], m, |r, k| y[(st.coff[c] + r, k)]);
        let ye = |e: usize| {
            let eb = &st.eblocks[e];
            let mut acc = be
                .iter()
                .find(|(x, _)| *x == e)
                .map_or_else(|| DMatrix::zeros(eb.dim, m), |(_, b)| b.clone());
            for n in 0..st.nbrs(eb).len() {
                let (c, w) = w_of(e, n);
                acc -= w * yc(c);
            }
            vinv(e) * acc
        };
        let out = at
            .iter()
            .map(|&i| {
                st.slots
                    .get(i)
                    .iter()
                    .map(|s| {
                        s.joff?;
                        s.c.map(yc).or_else(|| s.e.map(ye))
                    })
                    .collect()
            })
            .collect();
        Some(out)
    }

    /// For active factors `ks`: `out[j][i]` = |ρ| between the normalised residuals of
    /// factors ks[i] and ks[j], m_i × m_j (`r` their redundancy numbers per factor; a
    /// component without redundancy has ρ = 0). `None` when a solve fails.
    pub(crate) fn correlations(
        &self,
        ks: &[usize],
        r: &[&nalgebra::DVector<f64>],
    ) -> Option<Vec<Vec<DMatrix<f64>>>> {
        let st = &*self.st;
        ks.par_iter()
            .map(|&j| {
                let y = self.q_column(j, ks)?;
                let mut row = Vec::with_capacity(ks.len());
                for (ii, &i) in ks.iter().enumerate() {
                    let mut c = DMatrix::<f64>::zeros(st.m[i], st.m[j]);
                    for (s, ys) in st.slots.get(i).iter().zip(&y[ii]) {
                        let (Some(jac), Some(ys)) = (self.lin.jac(st, i, s), ys) else {
                            continue;
                        };
                        c += DMatrix::from_column_slice(st.m[i], s.dim, jac) * ys;
                    }
                    let jj = ks.iter().position(|&x| x == j)?;
                    for a in 0..st.m[i] {
                        for b in 0..st.m[j] {
                            let rr = r[ii][a] * r[jj][b];
                            c[(a, b)] = if rr > 1e-12 {
                                c[(a, b)].abs() / rr.sqrt()
                            } else {
                                0.0
                            };
                        }
                    }
                    row.push(c);
                }
                Some(row)
            })
            .collect()
    }
}
