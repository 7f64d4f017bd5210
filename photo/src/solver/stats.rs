//! Statistics at the solution: cofactors of the unknowns, reliability (redundancy numbers,
//! normalised residuals), Baarda data snooping and Förstner variance components.
//!
//! The cofactor matrix is never formed in full for a block with points: the reduced system
//! over orientations and other non-point blocks is inverted (dense, faer when large), and the
//! point blocks follow from the Schur complement:
//! Q_pc = −V_p⁻¹·Σ W_pc'·Q_c'c and Q_pp = V_p⁻¹ − (Σ_c Q_pc·W_pcᵀ)·V_p⁻¹.
//! That is all a factor touching one point and some orientations needs, so the statistics
//! cost one inverse of the reduced system plus a few small products per point.

use super::reduced::{dense_factor, Reduced};
use super::{Lin, Problem, Reliability, SolveError, Stats};
use nalgebra::{DMatrix, DVector, Matrix3};
use rayon::prelude::*;
use std::collections::BTreeMap;

/// Cofactors with the linearisation they were computed at, shared by the cache.
pub(super) type Shared = std::sync::Arc<(Cofactors, Vec<Lin>)>;

/// Cofactor blocks of the free unknowns (in units of σ0²).
pub(super) enum Cofactors {
    /// The full inverse (factors tie points together).
    Full {
        off: Vec<Option<usize>>,
        q: DMatrix<f64>,
    },
    /// The reduced inverse and, per point, its own block and its blocks with the
    /// orientations it is tied to.
    Schur {
        red: Reduced,
        qcc: faer::Mat<f64>,
        off: Vec<Option<usize>>,
        points: BTreeMap<usize, PointQ>,
    },
}

pub(super) struct PointQ {
    qpp: Matrix3<f64>,
    qpc: BTreeMap<usize, DMatrix<f64>>,
}

/// A block of a faer matrix as a small nalgebra matrix.
fn sub(m: &faer::Mat<f64>, r: usize, c: usize, dims: (usize, usize)) -> DMatrix<f64> {
    DMatrix::from_fn(dims.0, dims.1, |i, j| m[(r + i, c + j)])
}

impl Cofactors {
    /// The cofactor block between two free blocks, `None` when it is not available (two
    /// different points, or a point and a block it has no observation with).
    pub fn block(&self, a: usize, b: usize, dims: (usize, usize)) -> Option<DMatrix<f64>> {
        match self {
            Cofactors::Full { off, q } => Some(q.view((off[a]?, off[b]?), dims).into_owned()),
            Cofactors::Schur {
                red, qcc, points, ..
            } => match (points.get(&a), points.get(&b)) {
                (None, None) => Some(sub(qcc, red.roff[a]?, red.roff[b]?, dims)),
                (Some(pa), None) => pa.qpc.get(&b).cloned(),
                (None, Some(pb)) => pb.qpc.get(&a).map(|m| m.transpose()),
                (Some(pa), Some(_)) if a == b => {
                    Some(DMatrix::from_column_slice(3, 3, pa.qpp.as_slice()))
                }
                _ => None,
            },
        }
    }

    fn free(&self, b: usize) -> bool {
        match self {
            Cofactors::Full { off, .. } | Cofactors::Schur { off, .. } => off[b].is_some(),
        }
    }
}

/// Covariance of each requested block (`None` for a fixed block).
pub type Covariances = Vec<Option<DMatrix<f64>>>;

/// Least redundancy of a group whose variance component is estimated.
pub const MIN_VCE_REDUNDANCY: f64 = 10.0;

impl Problem {
    /// Cofactors of the unknowns at the current values.
    /// Cofactors at the current state, reused while blocks, weights, removals and fixings are
    /// bit for bit those they were computed for (snooping, variance components and the report
    /// each ask for them; on a large block each computation is an inverse of the reduced
    /// system).
    pub(super) fn cofactors(&self) -> Result<Shared, SolveError> {
        let key = self.state_hash();
        if let Ok(cache) = self.cofactor_cache.lock() {
            if let Some((k, c)) = cache.as_ref() {
                if *k == key {
                    return Ok(c.clone());
                }
            }
        }
        // Free the old one before building the new (they can be hundreds of MB).
        if let Ok(mut cache) = self.cofactor_cache.lock() {
            *cache = None;
        }
        let t = std::time::Instant::now();
        let r = std::sync::Arc::new(self.cofactors_inner()?);
        if std::env::var_os("PPKAT_TRACE").is_some() {
            eprintln!("cofactors: {:.2} s", t.elapsed().as_secs_f64());
        }
        if let Ok(mut cache) = self.cofactor_cache.lock() {
            *cache = Some((key, r.clone()));
        }
        Ok(r)
    }

    /// A hash of everything the cofactors depend on.
    fn state_hash(&self) -> u64 {
        use std::hash::{Hash, Hasher};
        let mut h = std::collections::hash_map::DefaultHasher::new();
        for b in &self.blocks {
            match b {
                super::Block::Pose(p) => {
                    p.r.iter()
                        .chain(p.centre.iter())
                        .for_each(|x| x.to_bits().hash(&mut h))
                }
                super::Block::Vector(v) => v.iter().for_each(|x| x.to_bits().hash(&mut h)),
            }
        }
        self.fixed.hash(&mut h);
        self.eliminate.hash(&mut h);
        self.removed.hash(&mut h);
        self.factors.len().hash(&mut h);
        self.group_scale
            .iter()
            .for_each(|x| x.to_bits().hash(&mut h));
        h.finish()
    }

    fn cofactors_inner(&self) -> Result<(Cofactors, Vec<Lin>), SolveError> {
        let (off, n) = self.layout();
        let lin = self.linearise(&off)?;
        let singular = || SolveError::Singular(format!("{n} unknowns"));
        if self.points_tied(&lin) {
            let (nm, _) = Self::normal_matrix(&lin, n, None);
            let q = nm.cholesky().ok_or_else(singular)?.inverse();
            return Ok((Cofactors::Full { off, q }, lin));
        }
        let red = self.reduce(&lin, &off, 0.0, false).ok_or_else(singular)?;
        let qcc = if red.nr == 0 {
            faer::Mat::zeros(0, 0)
        } else {
            dense_factor(red.dense(), true)
                .and_then(|(_, q)| q)
                .ok_or_else(singular)?
        };
        let points: BTreeMap<usize, PointQ> = red
            .vinv
            .par_iter()
            .map(|(p, (vi, _))| {
                let vi_d = DMatrix::from_column_slice(3, 3, vi.as_slice());
                let ws = red.w.get(p).map(|x| x.as_slice()).unwrap_or(&[]);
                let mut qpc = BTreeMap::new();
                let mut acc = DMatrix::<f64>::zeros(3, 3);
                for (c, wc) in ws {
                    let rc = red.roff[*c].unwrap_or(0);
                    let mut s = DMatrix::<f64>::zeros(3, wc.ncols());
                    for (c2, w2) in ws {
                        let r2 = red.roff[*c2].unwrap_or(0);
                        s += w2 * sub(&qcc, r2, rc, (w2.ncols(), wc.ncols()));
                    }
                    let q = -(&vi_d * s);
                    acc += &q * wc.transpose();
                    qpc.insert(*c, q);
                }
                let qpp = &vi_d - acc * &vi_d;
                (
                    *p,
                    PointQ {
                        qpp: Matrix3::from_iterator(qpp.iter().copied()),
                        qpc,
                    },
                )
            })
            .collect();
        Ok((
            Cofactors::Schur {
                red,
                qcc,
                off,
                points,
            },
            lin,
        ))
    }

    /// Whether the undamped normal equations are regular at the current values. `Err` names
    /// the first block whose unknowns depend on the others (a datum defect), when known.
    pub(super) fn regular(
        &self,
        lin: &[Lin],
        off: &[Option<usize>],
        n: usize,
    ) -> Result<(), Option<usize>> {
        let block_at = |layout: &[Option<usize>], col: usize| {
            layout.iter().enumerate().find_map(|(b, o)| {
                o.filter(|o| col >= *o && col < o + self.blocks[b].dim())
                    .map(|_| b)
            })
        };
        if self.points_tied(lin) {
            let (nm, _) = Self::normal_matrix(lin, n, None);
            let nm = faer::Mat::<f64>::from_fn(n, n, |i, j| nm[(i, j)]);
            return match dense_factor(nm, false) {
                Some((None, _)) => Ok(()),
                Some((Some(c), _)) => Err(block_at(off, c)),
                None => Err(None),
            };
        }
        match self.reduce(lin, off, 0.0, false) {
            Some(red) if red.nr == 0 => Ok(()),
            Some(red) => match dense_factor(red.dense(), false) {
                Some((None, _)) => Ok(()),
                Some((Some(c), _)) => Err(block_at(&red.roff, c)),
                None => Err(None),
            },
            None => Err(None),
        }
    }

    /// Diagonal of J·Q·Jᵀ for one linearised factor.
    fn hat_diag(&self, l: &Lin, q: &Cofactors) -> DVector<f64> {
        let m = l.r.len();
        let mut h = DMatrix::<f64>::zeros(m, m);
        for (ba, (_, ja)) in l.blocks.iter().zip(&l.j) {
            for (bb, (_, jb)) in l.blocks.iter().zip(&l.j) {
                if let Some(qab) = q.block(*ba, *bb, (ja.ncols(), jb.ncols())) {
                    h += ja * qab * jb.transpose();
                }
            }
        }
        h.diagonal()
    }

    /// Covariance of a free block (σ0² applied).
    pub fn covariance(
        &self,
        block: usize,
        sigma0: f64,
    ) -> Result<Option<DMatrix<f64>>, SolveError> {
        Ok(self.covariances(&[block], sigma0)?.pop().flatten())
    }

    /// Covariances of several blocks from one computation of the cofactors.
    pub fn covariances(&self, blocks: &[usize], sigma0: f64) -> Result<Covariances, SolveError> {
        let shared = self.cofactors()?;
        Ok(self.block_covariances(&shared.0, blocks, sigma0))
    }

    fn block_covariances(&self, q: &Cofactors, blocks: &[usize], sigma0: f64) -> Covariances {
        blocks
            .iter()
            .map(|&b| {
                if !q.free(b) {
                    return None;
                }
                let d = self.blocks[b].dim();
                q.block(b, b, (d, d)).map(|m| m * (sigma0 * sigma0))
            })
            .collect()
    }

    /// Per active factor: redundancy numbers and normalised residuals w = v/(σ·√r) of its
    /// components.
    pub fn reliability(&self) -> Result<Vec<Reliability>, SolveError> {
        let shared = self.cofactors()?;
        let (q, lin) = (&shared.0, &shared.1);
        Ok(self.reliability_with(q, lin))
    }

    /// Covariances of `blocks` and the reliability of every factor from one computation of
    /// the cofactors (the expensive part on large blocks).
    pub fn statistics(
        &self,
        blocks: &[usize],
        sigma0: f64,
    ) -> Result<(Covariances, Vec<Reliability>), SolveError> {
        let shared = self.cofactors()?;
        let (q, lin) = (&shared.0, &shared.1);
        Ok((
            self.block_covariances(q, blocks, sigma0),
            self.reliability_with(q, lin),
        ))
    }

    fn reliability_with(&self, q: &Cofactors, lin: &[Lin]) -> Vec<Reliability> {
        lin.par_iter()
            .map(|l| {
                let h = self.hat_diag(l, q);
                let m = l.r.len();
                let rr = DVector::from_iterator(m, (0..m).map(|i| (1.0 - h[i]).max(0.0)));
                let w = DVector::from_iterator(
                    m,
                    (0..m).map(|i| {
                        if rr[i] > 1e-6 {
                            l.r[i] / rr[i].sqrt()
                        } else {
                            0.0
                        }
                    }),
                );
                Reliability {
                    factor: l.factor,
                    redundancy: rr,
                    normalised: w,
                }
            })
            .collect()
    }

    /// Baarda data snooping: adjust, remove the factor with the largest |w| above `critical`
    /// (3.29 for α = 0.1 %), repeat. Returns the removed factors in removal order with their
    /// |w|; a point that a removal leaves undetermined (fewer than two rays) is fixed out and
    /// its remaining factors follow with w = 0.
    pub fn data_snooping(
        &mut self,
        critical: f64,
        max_iterations: usize,
    ) -> Result<(Stats, Vec<(usize, f64)>), SolveError> {
        let mut removed = Vec::new();
        loop {
            let stats = self.solve(max_iterations)?;
            let rel = self.reliability()?;
            let worst = rel
                .iter()
                .map(|r| (r.factor, r.normalised.amax()))
                .max_by(|a, b| a.1.total_cmp(&b.1));
            match worst {
                Some((k, w)) if w > critical => {
                    self.removed[k] = true;
                    removed.push((k, w));
                    self.drop_undetermined_points(k, &mut removed);
                }
                _ => return Ok((stats, removed)),
            }
        }
    }

    /// After removing factor `k`: a point it touched that is left with fewer than four
    /// residual rows (two rays) cannot be determined — its remaining factors are removed too
    /// (reported with w = 0) and the point is fixed out of the adjustment.
    fn drop_undetermined_points(&mut self, k: usize, removed: &mut Vec<(usize, f64)>) {
        let points: Vec<usize> = self.factors[k]
            .blocks()
            .iter()
            .copied()
            .filter(|b| self.eliminate[*b])
            .collect();
        for p in points {
            let active: Vec<usize> = (0..self.factors.len())
                .filter(|&j| !self.removed[j] && self.factors[j].blocks().contains(&p))
                .collect();
            let rows: usize = active.iter().map(|&j| self.factors[j].sigmas().len()).sum();
            if rows < 4 {
                for j in active {
                    self.removed[j] = true;
                    removed.push((j, 0.0));
                }
                self.fixed[p] = true;
            }
        }
    }

    /// Variance component estimation (Förstner): per group σ̂² = vᵀPv / r over the group,
    /// iterated until the factors settle; groups with a redundancy below
    /// [`MIN_VCE_REDUNDANCY`] keep their weights. Returns each group's σ multiplier (√ of its factor).
    pub fn variance_components(
        &mut self,
        max_rounds: usize,
        max_iterations: usize,
    ) -> Result<Vec<f64>, SolveError> {
        for _ in 0..max_rounds {
            self.solve(max_iterations)?;
            let shared = self.cofactors()?;
            let (q, lin) = (&shared.0, &shared.1);
            let ng = self.group_scale.len();
            let mut num = vec![0.0; ng];
            let mut red = vec![0.0; ng];
            for l in lin.iter() {
                let g = self.factors[l.factor].group();
                let h = self.hat_diag(l, q);
                for i in 0..l.r.len() {
                    num[g] += l.r[i] * l.r[i];
                    red[g] += 1.0 - h[i];
                }
            }
            let mut change: f64 = 0.0;
            for g in 0..ng {
                // A group with little redundancy keeps its weight: its estimate would be noise.
                if red[g] >= MIN_VCE_REDUNDANCY {
                    let f = num[g] / red[g];
                    self.group_scale[g] *= f;
                    change = change.max((f - 1.0).abs());
                }
            }
            if change < 0.01 {
                break;
            }
        }
        Ok(self.group_scale.iter().map(|s| s.sqrt()).collect())
    }
}
/// Upper quantile of the standard normal distribution (Acklam's rational approximation,
/// relative error below 1.2e-9).
pub fn normal_quantile(p: f64) -> f64 {
    let p = p.clamp(1e-300, 1.0 - 1e-16);
    let a = [
        -3.969683028665376e+01,
        2.209460984245205e+02,
        -2.759285104469687e+02,
        1.38357751867269e+02,
        -3.066479806614716e+01,
        2.506628277459239e+00,
    ];
    let b = [
        -5.447609879822406e+01,
        1.615858368580409e+02,
        -1.556989798598866e+02,
        6.680131188771972e+01,
        -1.328068155288572e+01,
    ];
    let c = [
        -7.784894002430293e-03,
        -3.223964580411365e-01,
        -2.400758277161838e+00,
        -2.549732539343734e+00,
        4.374664141464968e+00,
        2.938163982698783e+00,
    ];
    let d = [
        7.784695709041462e-03,
        3.224671290700398e-01,
        2.445134137142996e+00,
        3.754408661907416e+00,
    ];
    let lo = 0.02425;
    if p < lo {
        let q = (-2.0 * p.ln()).sqrt();
        (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5])
            / ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1.0)
    } else if p <= 1.0 - lo {
        let q = p - 0.5;
        let r = q * q;
        (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q
            / (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1.0)
    } else {
        -normal_quantile(1.0 - p)
    }
}

/// Critical value of the normalised residual for `tests` two-sided tests at a family-wise
/// error `alpha` (Bonferroni): with thousands of observations, Baarda's per-test 3.29
/// (α = 0.1 %) would reject a few good observations by chance alone.
pub fn snooping_critical(alpha: f64, tests: usize) -> f64 {
    normal_quantile(1.0 - alpha / (2.0 * tests.max(1) as f64))
}

#[cfg(test)]
mod quantile_tests {
    #[test]
    fn quantiles() {
        assert!((super::normal_quantile(0.975) - 1.959964).abs() < 1e-5);
        assert!((super::normal_quantile(0.9995) - 3.290527).abs() < 1e-5);
        assert!((super::snooping_critical(0.001, 1) - 3.290527).abs() < 1e-5);
    }
}
