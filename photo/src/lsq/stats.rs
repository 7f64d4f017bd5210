//! Statistics at the solution: covariances of chosen blocks and the reliability of every
//! factor (redundancy numbers, Baarda's normalised residuals), from the cofactors
//! (`cofactor`), which are cached against a hash of the state (values, weights, removals,
//! fixings): snooping, variance components and the report share one computation.

use super::cofactor::{reliability_with, Cofactors, Reliability};
use super::error::SolveError;
use super::key::Key;
use super::linear::Linear;
use super::problem::Problem;
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use std::hash::{Hash, Hasher};
use std::sync::Arc;

/// Covariance of each requested block (`None` for a fixed or unknown block).
pub type Covariances = Vec<Option<DMatrix<f64>>>;

impl Problem {
    /// A hash of everything the cofactors depend on.
    fn state_hash(&self) -> u64 {
        let mut h = std::collections::hash_map::DefaultHasher::new();
        self.model.shape_hash(&self.options.eliminate).hash(&mut h);
        self.model.values.iter().for_each(|v| v.hash_bits(&mut h));
        self.model
            .group_scale
            .iter()
            .for_each(|x| x.to_bits().hash(&mut h));
        // Kept suspects had their weights changed.
        self.model.kept.len().hash(&mut h);
        h.finish()
    }

    /// Cofactors at the current state (cached).
    pub(crate) fn cofactors(&self) -> Result<Arc<Cofactors>, SolveError> {
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
        let linear = Linear::new(&self.options, &self.caches.symbolic);
        let c = Arc::new(self.model.cofactors(self.structure(), &linear)?);
        self.time("cofactors", t);
        if let Ok(mut cache) = self.caches.cofactors.lock() {
            *cache = Some((key, c.clone()));
        }
        Ok(c)
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
                let b = *self.model.index.get(k)?;
                if self.model.fixed[b] {
                    return None;
                }
                q.block(b, self.model.values[b].dim())
                    .map(|m| m * (sigma0 * sigma0))
            })
            .collect()
    }

    /// The joint covariance (σ0² applied) of several kept blocks (not of an eliminated kind,
    /// e.g. poses), cross terms included, in the order of `keys`; None when one is fixed,
    /// unknown or eliminated.
    pub fn joint_covariance(
        &self,
        keys: &[Key],
        sigma0: f64,
    ) -> Result<Option<DMatrix<f64>>, SolveError> {
        let q = self.cofactors()?;
        let mut blocks = Vec::with_capacity(keys.len());
        for k in keys {
            let Some(&b) = self.model.index.get(k) else {
                return Ok(None);
            };
            if self.model.fixed[b] {
                return Ok(None);
            }
            blocks.push((b, self.model.values[b].dim()));
        }
        let n: usize = blocks.iter().map(|b| b.1).sum();
        let mut out = DMatrix::zeros(n, n);
        let mut ra = 0;
        for &(a, da) in &blocks {
            let mut rb = 0;
            for &(b, db) in &blocks {
                let Some(m) = q.cross(a, b).filter(|m| m.shape() == (da, db)) else {
                    return Ok(None);
                };
                out.view_mut((ra, rb), (da, db)).copy_from(&m);
                rb += db;
            }
            ra += da;
        }
        Ok(Some(out * (sigma0 * sigma0)))
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
        let t = std::time::Instant::now();
        let q = self.cofactors()?;
        let out = (
            self.block_covariances(&q, keys, sigma0),
            reliability_with(&q),
        );
        self.time("statistics", t);
        Ok(out)
    }

    /// Per group: Σ of squared whitened residuals and of redundancy numbers (variance
    /// components).
    pub(crate) fn group_sums(&self) -> Result<(Vec<f64>, Vec<f64>), SolveError> {
        let q = self.cofactors()?;
        let ng = self.model.group_scale.len();
        let (mut num, mut red) = (vec![0.0; ng], vec![0.0; ng]);
        let h: Vec<DVector<f64>> = (0..q.st.active.len())
            .into_par_iter()
            .map(|k| q.hat_diag(k))
            .collect();
        for (k, hk) in h.iter().enumerate() {
            let g = self.model.entries[q.st.active[k]].group.0;
            let r = q.lin.res(&q.st, k);
            for i in 0..r.len() {
                num[g] += r[i] * r[i];
                red[g] += 1.0 - hk[i];
            }
        }
        Ok((num, red))
    }
}
