//! Statistics at the solution: cofactors of the unknowns, covariances of chosen blocks, and
//! the reliability of every factor (redundancy numbers, Baarda's normalised residuals).
//!
//! The cofactor matrix is never formed in full when blocks are eliminated: the reduced
//! system is inverted (dense) and each eliminated block's cofactors follow from the Schur
//! complement, Q_ec = −V⁻¹·Σ W_c′·Q_c′c and Q_ee = V⁻¹ − (Σ_c Q_ec·W_cᵀ)·V⁻¹ — all a factor
//! touching one eliminated block and some kept ones needs. The cofactors are cached against
//! a hash of the state (values, weights, removals, fixings).

use super::lin::Linearisation;
use super::problem::Problem;
use super::reduced::Reduced;
use super::slots::Slot;
use super::structure::Structure;
use super::{FactorId, Key, SolveError};
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use std::hash::{Hash, Hasher};
use std::sync::Arc;

/// Cofactors of an eliminated block: its own and those with its neighbours.
struct EQ {
    qee: DMatrix<f64>,
    qec: Vec<DMatrix<f64>>,
}

/// Cofactors (units of σ0²) with the linearisation they were computed at.
pub(crate) struct Cofactors {
    st: Arc<Structure>,
    lin: Linearisation,
    qcc: faer::Mat<f64>,
    qe: Vec<EQ>,
}

/// Cofactors shared by the cache.
pub(crate) type SharedCofactors = Arc<Cofactors>;

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

/// Covariance of each requested block (`None` for a fixed or unknown block).
pub type Covariances = Vec<Option<DMatrix<f64>>>;

impl Cofactors {
    /// The cofactor block between slots `a` and `b`; `None` where it is not available (two
    /// different eliminated blocks).
    fn pair(&self, a: &Slot, b: &Slot) -> Option<DMatrix<f64>> {
        let st = &self.st;
        let qcc = |ca: usize, cb: usize| {
            let (ra, rb) = (st.coff[ca], st.coff[cb]);
            DMatrix::from_fn(a.dim, b.dim, |i, j| self.qcc[(ra + i, rb + j)])
        };
        let nbr = |e: usize, c: usize| st.nbrs(&st.eblocks[e]).binary_search(&c).ok();
        match (a.c, a.e, b.c, b.e) {
            (Some(ca), _, Some(cb), _) => Some(qcc(ca, cb)),
            (_, Some(ea), Some(cb), _) => Some(self.qe[ea].qec[nbr(ea, cb)?].clone()),
            (Some(ca), _, _, Some(eb)) => Some(self.qe[eb].qec[nbr(eb, ca)?].transpose()),
            (_, Some(ea), _, Some(eb)) if ea == eb => Some(self.qe[ea].qee.clone()),
            _ => None,
        }
    }

    /// The diagonal of J·Q·Jᵀ for active factor `k`.
    fn hat_diag(&self, k: usize) -> DVector<f64> {
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

    /// The cofactor block of a block.
    fn block(&self, b: usize, dim: usize) -> Option<DMatrix<f64>> {
        let st = &self.st;
        if let Some(c) = st.c_of(b) {
            let r = st.coff[c];
            return Some(DMatrix::from_fn(dim, dim, |i, j| self.qcc[(r + i, r + j)]));
        }
        st.e_of(b).map(|e| self.qe[e].qee.clone())
    }
}

impl Problem {
    /// A hash of everything the cofactors depend on.
    fn state_hash(&self) -> u64 {
        let mut h = std::collections::hash_map::DefaultHasher::new();
        self.shape_hash().hash(&mut h);
        self.values.iter().for_each(|v| v.hash_bits(&mut h));
        self.group_scale
            .iter()
            .for_each(|x| x.to_bits().hash(&mut h));
        h.finish()
    }

    /// Cofactors at the current state (cached).
    pub(crate) fn cofactors(&self) -> Result<SharedCofactors, SolveError> {
        let key = self.state_hash();
        if let Ok(mut cache) = self.caches.cofactors.lock() {
            if let Some((k, c)) = cache.as_ref() {
                if *k == key {
                    return Ok(c.clone());
                }
            }
            // Free the old one before building the new (they can be hundreds of MB).
            *cache = None;
        }
        let t = std::time::Instant::now();
        let c = Arc::new(self.compute_cofactors()?);
        self.time("cofactors", t);
        if let Ok(mut cache) = self.caches.cofactors.lock() {
            *cache = Some((key, c.clone()));
        }
        Ok(c)
    }

    fn compute_cofactors(&self) -> Result<Cofactors, SolveError> {
        let st = self.structure();
        let mut lin = Linearisation::default();
        self.linearise(&st, &self.values, &mut lin)?;
        let singular = || SolveError::Singular(format!("{} unknowns", st.n));
        let mut red = Reduced::default();
        if !self.reduce(&st, &lin, 0.0, false, &mut red) {
            return Err(singular());
        }
        let qcc = if st.nr == 0 {
            faer::Mat::zeros(0, 0)
        } else {
            self.dense_factor(&st, &red, true)
                .and_then(|(_, q)| q)
                .ok_or_else(singular)?
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
                        let (r2, rn) = (st.coff[nbrs[n2]], st.coff[cn]);
                        let q = DMatrix::from_fn(w2.ncols(), dn, |i, j| qcc[(r2 + i, rn + j)]);
                        s += w2 * q;
                    }
                    let q = -(&vinv * s);
                    acc += &q * wn.transpose();
                    qec.push(q);
                }
                let qee = &vinv - acc * &vinv;
                EQ { qee, qec }
            })
            .collect();
        Ok(Cofactors { st, lin, qcc, qe })
    }

    /// Covariance of one block (σ0² applied).
    pub fn covariance(&self, key: Key, sigma0: f64) -> Result<Option<DMatrix<f64>>, SolveError> {
        Ok(self.covariances(&[key], sigma0)?.pop().flatten())
    }

    /// Covariances of several blocks from one computation of the cofactors.
    pub fn covariances(&self, keys: &[Key], sigma0: f64) -> Result<Covariances, SolveError> {
        let q = self.cofactors()?;
        Ok(self.block_covariances(&q, keys, sigma0))
    }

    fn block_covariances(&self, q: &Cofactors, keys: &[Key], sigma0: f64) -> Covariances {
        keys.iter()
            .map(|k| {
                let b = *self.index.get(k)?;
                if self.fixed[b] {
                    return None;
                }
                q.block(b, self.values[b].dim())
                    .map(|m| m * (sigma0 * sigma0))
            })
            .collect()
    }

    /// Per active factor: redundancy numbers and normalised residuals of its components.
    pub fn reliability(&self) -> Result<Vec<Reliability>, SolveError> {
        let q = self.cofactors()?;
        Ok(reliability_with(&q))
    }

    /// Covariances of `keys` and the reliability of every factor from one computation of the
    /// cofactors (the expensive part on large blocks).
    pub fn statistics(
        &self,
        keys: &[Key],
        sigma0: f64,
    ) -> Result<(Covariances, Vec<Reliability>), SolveError> {
        let q = self.cofactors()?;
        Ok((
            self.block_covariances(&q, keys, sigma0),
            reliability_with(&q),
        ))
    }

    /// Per group: Σ of squared whitened residuals and of redundancy numbers (variance
    /// components).
    pub(crate) fn group_sums(&self) -> Result<(Vec<f64>, Vec<f64>), SolveError> {
        let q = self.cofactors()?;
        let ng = self.group_scale.len();
        let (mut num, mut red) = (vec![0.0; ng], vec![0.0; ng]);
        let h: Vec<DVector<f64>> = (0..q.st.active.len())
            .into_par_iter()
            .map(|k| q.hat_diag(k))
            .collect();
        for (k, hk) in h.iter().enumerate() {
            let g = self.entries[q.st.active[k]].group.0;
            let r = q.lin.res(&q.st, k);
            for i in 0..r.len() {
                num[g] += r[i] * r[i];
                red[g] += 1.0 - hk[i];
            }
        }
        Ok((num, red))
    }
}

fn reliability_with(q: &Cofactors) -> Vec<Reliability> {
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
