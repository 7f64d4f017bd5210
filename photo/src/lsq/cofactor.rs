//! The cofactors of the unknowns at a solution, without the full inverse: the reduced
//! system is inverted (dense when small, its selected inverse on the pattern of the sparse
//! Cholesky factor when large: `selinv`) and each eliminated block's cofactors follow from the Schur
//! complement, Q_ec = −V⁻¹·Σ W_c′·Q_c′c and Q_ee = V⁻¹ − (Σ_c Q_ec·W_cᵀ)·V⁻¹ — all a factor
//! touching one eliminated block and some kept ones needs; and from them each factor's
//! redundancy numbers and normalised residuals.

use super::error::SolveError;
use super::factor::FactorId;
use super::lin::Linearisation;
use super::linear::{Linear, Qcc};
use super::model::Model;
use super::reduced::Reduced;
use super::selinv::FactorFailure;
use super::slots::Slot;
use super::structure::Structure;
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use std::sync::Arc;

/// Cofactors of an eliminated block: its own and those with its neighbours.
struct EQ {
    qee: DMatrix<f64>,
    qec: Vec<DMatrix<f64>>,
}

/// Cofactors (units of σ0²) with the linearisation they were computed at.
pub(crate) struct Cofactors {
    pub(crate) st: Arc<Structure>,
    pub(crate) lin: Linearisation,
    /// The reduced system it was computed from (V⁻¹ and W are read again for correlations).
    pub(crate) red: Reduced,
    pub(crate) qcc: Qcc,
    qe: Vec<EQ>,
}

/// Reliability of one factor's components.
#[derive(Clone, Debug, PartialEq)]
pub struct Reliability {
    /// The factor.
    pub factor: FactorId,
    /// Redundancy numbers (0 = uncontrolled, 1 = fully controlled).
    pub redundancy: DVector<f64>,
    /// Normalised residuals v/(σ·√r) (Baarda's w).
    pub normalised: DVector<f64>,
}

impl Cofactors {
    /// The cofactor block between slots `a` and `b`; `None` where it is not available (two
    /// different eliminated blocks).
    fn pair(&self, a: &Slot, b: &Slot) -> Option<DMatrix<f64>> {
        let st = &self.st;
        let nbr = |e: usize, c: usize| st.nbrs(&st.eblocks[e]).binary_search(&c).ok();
        match (a.c, a.e, b.c, b.e) {
            (Some(ca), _, Some(cb), _) => self.qcc.block(st, ca, cb),
            (_, Some(ea), Some(cb), _) => Some(self.qe[ea].qec[nbr(ea, cb)?].clone()),
            (Some(ca), _, _, Some(eb)) => Some(self.qe[eb].qec[nbr(eb, ca)?].transpose()),
            (_, Some(ea), _, Some(eb)) if ea == eb => Some(self.qe[ea].qee.clone()),
            _ => None,
        }
    }

    /// The diagonal of J·Q·Jᵀ for active factor `k`.
    pub(crate) fn hat_diag(&self, k: usize) -> DVector<f64> {
        let (st, lin) = (&*self.st, &self.lin);
        let slots = st.slots.get(k);
        let m = st.m[k];
        let mut h = DVector::zeros(m);
        for sa in slots {
            let Some(ja) = lin.jac(st, k, sa) else {
                continue;
            };
            let ja = DMatrix::from_column_slice(m, sa.dim, ja);
            for sb in slots {
                let Some(jb) = lin.jac(st, k, sb) else {
                    continue;
                };
                let Some(q) = self.pair(sa, sb) else { continue };
                let jb = DMatrix::from_column_slice(m, sb.dim, jb);
                let jq = &ja * q;
                for i in 0..m {
                    h[i] += jq.row(i).dot(&jb.row(i));
                }
            }
        }
        h
    }

    /// The cofactor block between two kept (not eliminated) blocks `a` and `b`.
    pub(crate) fn cross(&self, a: usize, b: usize) -> Option<DMatrix<f64>> {
        let st = &self.st;
        self.qcc.block(st, st.c_of(a)?, st.c_of(b)?)
    }

    /// The cofactor block of a block.
    pub(crate) fn block(&self, b: usize, dim: usize) -> Option<DMatrix<f64>> {
        let st = &self.st;
        if let Some(c) = st.c_of(b) {
            return self.qcc.block(st, c, c).filter(|m| m.nrows() == dim);
        }
        st.e_of(b).map(|e| self.qe[e].qee.clone())
    }
}

impl Model {
    /// The cofactors at the current values for the structure `st`.
    pub(crate) fn cofactors(
        &self,
        st: Arc<Structure>,
        linear: &Linear,
    ) -> Result<Cofactors, SolveError> {
        let mut lin = Linearisation::default();
        self.linearise(&st, &self.values, &mut lin)?;
        let singular = || SolveError::Singular(format!("{} unknowns", st.n));
        let mut red = Reduced::default();
        if !Model::reduce(&st, &lin, 0.0, false, &mut red) {
            return Err(singular());
        }
        let qcc = if st.nr == 0 {
            Qcc::Dense(faer::Mat::zeros(0, 0))
        } else {
            linear.cofactor_matrix(&st, &red).map_err(|e| match e {
                FactorFailure::Pivot(_) => singular(),
                FactorFailure::Resources(what) => SolveError::TooLarge(what),
            })?
        };
        let qe = st
            .eblocks
            .par_iter()
            .map(|eb| {
                let d = eb.dim;
                let vinv = DMatrix::from_column_slice(d, d, &red.vinv[eb.vbase..eb.vbase + d * d]);
                let (nbrs, woff) = (st.nbrs(eb), st.woff(eb));
                let w: Vec<DMatrix<f64>> = (0..nbrs.len())
                    .map(|n| {
                        let (dn, o) = (st.cdim[nbrs[n]], eb.wbase + woff[n]);
                        DMatrix::from_column_slice(d, dn, &red.w[o..o + d * dn])
                    })
                    .collect();
                let mut qec = Vec::with_capacity(w.len());
                let mut acc = DMatrix::<f64>::zeros(d, d);
                for (n, wn) in w.iter().enumerate() {
                    let (cn, dn) = (nbrs[n], wn.ncols());
                    let mut s = DMatrix::<f64>::zeros(d, dn);
                    for (n2, w2) in w.iter().enumerate() {
                        s += w2 * qcc.block(&st, nbrs[n2], cn)?;
                    }
                    let q = -(&vinv * s);
                    acc += &q * wn.transpose();
                    qec.push(q);
                }
                let qee = &vinv - acc * &vinv;
                Some(EQ { qee, qec })
            })
            .collect::<Option<Vec<EQ>>>()
            .ok_or_else(|| SolveError::TooLarge("a cofactor block".into()))?;
        Ok(Cofactors {
            st,
            lin,
            red,
            qcc,
            qe,
        })
    }
}

/// Redundancy numbers and normalised residuals of every active factor.
pub(crate) fn reliability_with(q: &Cofactors) -> Vec<Reliability> {
    (0..q.st.active.len())
        .into_par_iter()
        .map(|k| {
            let h = q.hat_diag(k);
            let r = q.lin.res(&q.st, k);
            let m = r.len();
            let rr = DVector::from_iterator(m, (0..m).map(|i| (1.0 - h[i]).max(0.0)));
            let w = DVector::from_iterator(
                m,
                (0..m).map(|i| {
                    if rr[i] > 1e-6 {
                        r[i] / rr[i].sqrt()
                    } else {
                        0.0
                    }
                }),
            );
            Reliability {
                factor: FactorId(q.st.active[k]),
                redundancy: rr,
                normalised: w,
            }
        })
        .collect()
}
