//! A general least-squares adjustment over parameter blocks and factors (the Ceres / gtsam
//! pattern): a factor names the blocks it touches and returns its residual and Jacobians; a
//! diagonal noise model whitens it; an optional robust loss reweights it. The solver never
//! knows what a factor means. After convergence: σ0, covariances, redundancy numbers, Baarda
//! data snooping with removal, and variance components per observation group.
//!
//! Object points (blocks added with [`Problem::add_point`]) are eliminated by the Schur
//! complement in every step and the reduced system over the other blocks is solved densely;
//! factors are linearised in parallel. The statistics (covariances, redundancy numbers) use
//! the full inverse normal matrix, fine up to a few thousand unknowns.

use crate::camera::Pose;
use crate::rotation::exp_so3;
use faer::linalg::solvers::Solve;
use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
use faer::sparse::{SparseColMat, Triplet};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use rayon::prelude::*;
use std::collections::BTreeMap;

/// A parameter block.
#[derive(Clone, Debug)]
pub enum Block {
    /// Exterior orientation: updated by a left rotation perturbation and the centre (6).
    Pose(Pose),
    /// Any vector (object point, interior parameters, lever arm, drift …).
    Vector(DVector<f64>),
}

impl Block {
    pub fn dim(&self) -> usize {
        match self {
            Block::Pose(_) => 6,
            Block::Vector(v) => v.len(),
        }
    }
    fn update(&mut self, d: &[f64]) {
        match self {
            Block::Pose(p) => {
                p.r = exp_so3(&Vector3::new(d[0], d[1], d[2])) * p.r;
                p.centre += Vector3::new(d[3], d[4], d[5]);
            }
            Block::Vector(v) => {
                for (x, dx) in v.iter_mut().zip(d) {
                    *x += dx;
                }
            }
        }
    }
    pub fn pose(&self) -> Option<&Pose> {
        match self {
            Block::Pose(p) => Some(p),
            _ => None,
        }
    }
    pub fn vector(&self) -> Option<&DVector<f64>> {
        match self {
            Block::Vector(v) => Some(v),
            _ => None,
        }
    }
}

/// An observation: residual r(x) = predicted − measured and its Jacobians, per block.
pub trait Factor: Send + Sync {
    /// Indices of the blocks it touches.
    fn blocks(&self) -> &[usize];
    /// Residual and one Jacobian per block (rows = residual size); `None` when it cannot be
    /// evaluated (a point behind a camera).
    fn evaluate(&self, blocks: &[&Block]) -> Option<(DVector<f64>, Vec<DMatrix<f64>>)>;
    /// Standard deviation of each residual component.
    fn sigmas(&self) -> &DVector<f64>;
    /// Observation group (for variance components).
    fn group(&self) -> usize {
        0
    }
}

/// Robust loss on a factor's whitened residual norm s (in sigmas).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Loss {
    Trivial,
    Huber(f64),
    Cauchy(f64),
}

impl Loss {
    /// IRLS weight.
    fn weight(self, s: f64) -> f64 {
        match self {
            Loss::Trivial => 1.0,
            Loss::Huber(k) => {
                if s <= k {
                    1.0
                } else {
                    k / s
                }
            }
            Loss::Cauchy(c) => 1.0 / (1.0 + (s / c).powi(2)),
        }
    }
}

/// A problem: blocks, which of them are fixed, factors with a per-group variance factor.
pub struct Problem {
    pub blocks: Vec<Block>,
    pub fixed: Vec<bool>,
    /// Blocks eliminated by the Schur complement (object points).
    pub eliminate: Vec<bool>,
    pub factors: Vec<Box<dyn Factor>>,
    /// Factors removed by data snooping (never deleted: kept for the report).
    pub removed: Vec<bool>,
    /// Variance factor per group (σ² multipliers), 1 by default.
    pub group_scale: Vec<f64>,
    pub loss: Loss,
    /// Largest reduced system solved densely; larger ones go to faer's sparse Cholesky.
    pub dense_limit: usize,
    /// Symbolic factorisation of the sparse reduced system, with the block pattern it is for.
    symbolic: std::sync::Mutex<Option<SymbolicCache>>,
}

/// One linearised factor: whitened residual and Jacobian blocks at their column offsets.
struct Lin {
    factor: usize,
    r: DVector<f64>,
    j: Vec<(usize, DMatrix<f64>)>,
    /// The free blocks of `j`, in the same order.
    blocks: Vec<usize>,
}

/// Reliability of one factor's components.
#[derive(Clone, Debug)]
pub struct Reliability {
    pub factor: usize,
    /// Redundancy numbers (0 = uncontrolled, 1 = fully controlled).
    pub redundancy: DVector<f64>,
    /// Normalised residuals v/(σ·√r) (Baarda's w).
    pub normalised: DVector<f64>,
}

/// A symbolic sparse factorisation and the block pattern it was computed for.
type SymbolicCache = (Vec<(usize, usize)>, SymbolicLlt<usize>);

/// Statistics of an adjustment.
#[derive(Clone, Debug, Default)]
pub struct Stats {
    pub iterations: usize,
    pub sigma0: f64,
    pub redundancy: f64,
    pub observations: usize,
    pub unknowns: usize,
}

/// Why an adjustment fails.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SolveError {
    #[error("the normal equations are singular: {0}")]
    Singular(String),
    #[error("more unknowns ({0}) than observations ({1})")]
    Underdetermined(usize, usize),
    #[error("factor {0} cannot be evaluated (a point behind its camera?)")]
    Evaluation(usize),
}

impl Problem {
    pub fn new(loss: Loss) -> Problem {
        Problem {
            blocks: Vec::new(),
            fixed: Vec::new(),
            eliminate: Vec::new(),
            factors: Vec::new(),
            removed: Vec::new(),
            group_scale: vec![1.0],
            loss,
            dense_limit: 3000,
            symbolic: std::sync::Mutex::new(None),
        }
    }
    pub fn add_block(&mut self, b: Block, fixed: bool) -> usize {
        self.blocks.push(b);
        self.fixed.push(fixed);
        self.eliminate.push(false);
        self.blocks.len() - 1
    }

    /// An object point: a 3-vector eliminated by the Schur complement while solving.
    pub fn add_point(&mut self, x: Vector3<f64>, fixed: bool) -> usize {
        let id = self.add_block(
            Block::Vector(DVector::from_column_slice(x.as_slice())),
            fixed,
        );
        self.eliminate[id] = true;
        id
    }
    pub fn add_factor(&mut self, f: Box<dyn Factor>) -> usize {
        let g = f.group();
        if g >= self.group_scale.len() {
            self.group_scale.resize(g + 1, 1.0);
        }
        self.factors.push(f);
        self.removed.push(false);
        self.factors.len() - 1
    }

    /// Column offset of each free block in the normal equations.
    fn layout(&self) -> (Vec<Option<usize>>, usize) {
        let mut off = Vec::with_capacity(self.blocks.len());
        let mut n = 0;
        for (b, fixed) in self.blocks.iter().zip(&self.fixed) {
            if *fixed {
                off.push(None);
            } else {
                off.push(Some(n));
                n += b.dim();
            }
        }
        (off, n)
    }

    /// Linearise every active factor: whitened residual and whitened Jacobian blocks with their
    /// column offsets (fixed blocks dropped).
    fn linearise(&self, off: &[Option<usize>]) -> Result<Vec<Lin>, SolveError> {
        // In parallel, collected in factor order: the sums that follow are deterministic.
        let lin: Vec<Result<Option<Lin>, SolveError>> = self
            .factors
            .par_iter()
            .enumerate()
            .map(|(k, f)| {
                if self.removed[k] {
                    return Ok(None);
                }
                let bl: Vec<&Block> = f.blocks().iter().map(|&i| &self.blocks[i]).collect();
                let (r, js) = f.evaluate(&bl).ok_or(SolveError::Evaluation(k))?;
                let sig = f.sigmas() * self.group_scale[f.group()].sqrt();
                let rw = r.component_div(&sig);
                let mut jw = Vec::new();
                for (bi, mut j) in f.blocks().iter().copied().zip(js) {
                    if let Some(o) = off[bi] {
                        for i in 0..j.nrows() {
                            for c in 0..j.ncols() {
                                j[(i, c)] /= sig[i];
                            }
                        }
                        jw.push((o, j));
                    }
                }
                let blocks: Vec<usize> = f
                    .blocks()
                    .iter()
                    .copied()
                    .filter(|b| off[*b].is_some())
                    .collect();
                Ok(Some(Lin {
                    factor: k,
                    r: rw,
                    j: jw,
                    blocks,
                }))
            })
            .collect();
        lin.into_iter().filter_map(|x| x.transpose()).collect()
    }

    /// Solve the reduced system (blocks at offsets) for −g: dense when small, faer's sparse
    /// Cholesky when large, its symbolic factorisation kept while the pattern is unchanged.
    fn solve_reduced(
        &self,
        nr: usize,
        u: &BTreeMap<(usize, usize), DMatrix<f64>>,
        g: &DVector<f64>,
    ) -> Option<DVector<f64>> {
        if nr <= self.dense_limit {
            let mut m = DMatrix::<f64>::zeros(nr, nr);
            for (&(r, c), b) in u {
                m.view_mut((r, c), (b.nrows(), b.ncols())).copy_from(b);
            }
            return Some(m.cholesky()?.solve(&(-g)));
        }
        let mut t = Vec::new();
        for (&(r0, c0), b) in u {
            for i in 0..b.nrows() {
                for j in 0..b.ncols() {
                    if r0 + i >= c0 + j {
                        t.push(Triplet {
                            row: r0 + i,
                            col: c0 + j,
                            val: b[(i, j)],
                        });
                    }
                }
            }
        }
        let m = SparseColMat::<usize, f64>::try_new_from_triplets(nr, nr, &t).ok()?;
        let pattern: Vec<(usize, usize)> = u.keys().copied().collect();
        let mut cache = self.symbolic.lock().ok()?;
        if cache.as_ref().map(|c| c.0 != pattern).unwrap_or(true) {
            faer::set_global_parallelism(faer::Par::Seq);
            *cache = Some((
                pattern,
                SymbolicLlt::try_new(m.symbolic(), faer::Side::Lower).ok()?,
            ));
        }
        let sym = cache.as_ref()?.1.clone();
        let llt = Llt::try_new_with_symbolic(sym, m.as_ref(), faer::Side::Lower).ok()?;
        let mut rhs = faer::Mat::<f64>::from_fn(nr, 1, |i, _| -g[i]);
        llt.solve_in_place(rhs.as_mut());
        Some(DVector::from_fn(nr, |i, _| rhs[(i, 0)]))
    }

    /// One damped Gauss–Newton step with the point blocks eliminated by the Schur complement
    /// (the reduced system over the other blocks is solved densely). Falls back to the full
    /// normals when a factor ties two points together.
    fn schur_step(
        &self,
        lin: &[Lin],
        off: &[Option<usize>],
        n: usize,
        lambda: f64,
    ) -> Option<DVector<f64>> {
        let is_pt = |b: usize| self.eliminate[b];
        if lin
            .iter()
            .any(|l| l.blocks.iter().filter(|b| is_pt(**b)).count() > 1)
        {
            let (nm, g) = Self::normal_matrix(lin, n, Some(self.loss));
            let mut d = nm.clone();
            for i in 0..n {
                d[(i, i)] += lambda * nm[(i, i)].max(1e-12);
            }
            return Some(d.cholesky()?.solve(&(-g)));
        }
        // Reduced layout: the non-point free blocks.
        let mut roff: Vec<Option<usize>> = vec![None; self.blocks.len()];
        let mut nr = 0;
        for (b, o) in off.iter().enumerate() {
            if o.is_some() && !is_pt(b) {
                roff[b] = Some(nr);
                nr += self.blocks[b].dim();
            }
        }
        // The reduced matrix as blocks keyed by (row offset, column offset).
        let mut u: BTreeMap<(usize, usize), DMatrix<f64>> = BTreeMap::new();
        let mut gr = DVector::<f64>::zeros(nr);
        let mut v: BTreeMap<usize, (Matrix3<f64>, Vector3<f64>)> = BTreeMap::new();
        let mut w: BTreeMap<(usize, usize), DMatrix<f64>> = BTreeMap::new(); // (point, block) → 3×d
        for l in lin {
            let wt = self.loss.weight(l.r.norm());
            for (ba, (_, ja)) in l.blocks.iter().zip(&l.j) {
                let ga = ja.transpose() * &l.r * wt;
                if is_pt(*ba) {
                    let e = v.entry(*ba).or_insert((Matrix3::zeros(), Vector3::zeros()));
                    e.0 += Matrix3::from_iterator((ja.transpose() * ja * wt).iter().copied());
                    e.1 += Vector3::from_iterator(ga.iter().copied());
                } else if let Some(ra) = roff[*ba] {
                    let mut gv = gr.rows_mut(ra, ja.ncols());
                    gv += &ga;
                }
                for (bb, (_, jb)) in l.blocks.iter().zip(&l.j) {
                    match (is_pt(*ba), is_pt(*bb), roff[*ba], roff[*bb]) {
                        (false, false, Some(ra), Some(rb)) => {
                            *u.entry((ra, rb))
                                .or_insert_with(|| DMatrix::zeros(ja.ncols(), jb.ncols())) +=
                                ja.transpose() * jb * wt;
                        }
                        (true, false, _, Some(_)) => {
                            let e = w
                                .entry((*ba, *bb))
                                .or_insert_with(|| DMatrix::zeros(3, jb.ncols()));
                            *e += ja.transpose() * jb * wt;
                        }
                        _ => {}
                    }
                }
            }
        }
        for ((ra, rb), m) in u.iter_mut() {
            if ra == rb {
                for i in 0..m.nrows() {
                    m[(i, i)] += lambda * m[(i, i)].max(1e-12);
                }
            }
        }
        // Eliminate each point.
        let mut vinv: BTreeMap<usize, Matrix3<f64>> = BTreeMap::new();
        let mut by_point: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
        for &(p, b) in w.keys() {
            by_point.entry(p).or_default().push(b);
        }
        for (p, (vp, gp)) in &v {
            let mut vd = *vp;
            for d in 0..3 {
                vd[(d, d)] += lambda * vp[(d, d)].max(1e-12);
            }
            let vi = vd.try_inverse()?;
            vinv.insert(*p, vi);
            let cams = by_point.get(p).cloned().unwrap_or_default();
            for &a in &cams {
                let wa = &w[&(*p, a)];
                let ra = roff[a]?;
                let t = wa.transpose() * DMatrix::from_column_slice(3, 3, vi.as_slice());
                let mut gv = gr.rows_mut(ra, wa.ncols());
                gv -= &t * DVector::from_column_slice(gp.as_slice());
                for &b in &cams {
                    let wb = &w[&(*p, b)];
                    let rb = roff[b]?;
                    *u.entry((ra, rb))
                        .or_insert_with(|| DMatrix::zeros(wa.ncols(), wb.ncols())) -= &t * wb;
                }
            }
        }
        let dr = self.solve_reduced(nr, &u, &gr)?;
        // Back-substitution and the full step.
        let mut dx = DVector::<f64>::zeros(n);
        for (b, o) in off.iter().enumerate() {
            if let (Some(o), Some(ro)) = (o, roff[b]) {
                let d = self.blocks[b].dim();
                dx.rows_mut(*o, d).copy_from(&dr.rows(ro, d));
            }
        }
        for (p, (_, gp)) in &v {
            let mut rhs = -gp;
            for &a in by_point.get(p).map(|x| x.as_slice()).unwrap_or(&[]) {
                let ra = roff[a]?;
                let wa = &w[&(*p, a)];
                let da = dr.rows(ra, wa.ncols());
                rhs -= Vector3::from_iterator((wa * da).iter().copied());
            }
            let dp = vinv[p] * rhs;
            let o = off[*p]?;
            dx.rows_mut(o, 3).copy_from(&dp);
        }
        Some(dx)
    }

    fn normal_matrix(lin: &[Lin], n: usize, loss: Option<Loss>) -> (DMatrix<f64>, DVector<f64>) {
        let mut nm = DMatrix::<f64>::zeros(n, n);
        let mut g = DVector::<f64>::zeros(n);
        for l in lin {
            let w = loss.map(|x| x.weight(l.r.norm())).unwrap_or(1.0);
            for (oa, ja) in &l.j {
                let mut gv = g.rows_mut(*oa, ja.ncols());
                gv += ja.transpose() * &l.r * w;
                for (ob, jb) in &l.j {
                    let mut v = nm.view_mut((*oa, *ob), (ja.ncols(), jb.ncols()));
                    v += ja.transpose() * jb * w;
                }
            }
        }
        (nm, g)
    }

    /// Diagonal of J·Q·Jᵀ for one linearised factor.
    fn hat_diag(l: &Lin, q: &DMatrix<f64>) -> DVector<f64> {
        let m = l.r.len();
        let mut h = DMatrix::<f64>::zeros(m, m);
        for (oa, ja) in &l.j {
            for (ob, jb) in &l.j {
                h += ja * q.view((*oa, *ob), (ja.ncols(), jb.ncols())) * jb.transpose();
            }
        }
        h.diagonal()
    }

    /// Gauss–Newton with Levenberg damping until the step is tiny.
    pub fn solve(&mut self, max_iterations: usize) -> Result<Stats, SolveError> {
        let (off, n) = self.layout();
        let mut lambda = 1e-6;
        let mut stats = Stats::default();
        let mut cost = self.cost(&off)?;
        // Every free block must be determined by its own observations (a point seen by one
        // ray, a camera without points are not): check its diagonal block of the normals.
        {
            let lin = self.linearise(&off)?;
            let (nm, _) = Self::normal_matrix(&lin, n, None);
            for (b, o) in off.iter().enumerate() {
                let Some(o) = o else { continue };
                let d = self.blocks[b].dim();
                let e = nm
                    .view((*o, *o), (d, d))
                    .into_owned()
                    .symmetric_eigenvalues();
                let (lo, hi) = (e.min(), e.max());
                if !(hi > 0.0 && lo > 1e-10 * hi) {
                    return Err(SolveError::Singular(format!("block {b} is not determined by its observations (observed too few times or not at all)")));
                }
            }
        }
        for it in 1..=max_iterations {
            stats.iterations = it;
            let lin = self.linearise(&off)?;
            let dx = self
                .schur_step(&lin, &off, n, lambda)
                .ok_or_else(|| SolveError::Singular(format!("{n} unknowns")))?;
            let saved = self.blocks.clone();
            for (b, o) in self.blocks.iter_mut().zip(&off) {
                if let Some(o) = o {
                    let d: Vec<f64> = dx.rows(*o, b.dim()).iter().copied().collect();
                    b.update(&d);
                }
            }
            let new_cost = self.cost(&off)?;
            if new_cost <= cost {
                let rel = (cost - new_cost) / cost.max(1e-300);
                cost = new_cost;
                lambda = (lambda / 10.0).max(1e-12);
                if rel < 1e-12 || dx.norm() < 1e-12 {
                    break;
                }
            } else {
                self.blocks = saved;
                lambda *= 10.0;
                if lambda > 1e8 {
                    break;
                }
            }
        }
        let lin = self.linearise(&off)?;
        let m: usize = lin.iter().map(|l| l.r.len()).sum();
        if m < n {
            return Err(SolveError::Underdetermined(n, m));
        }
        // The undamped normals must be regular: otherwise a datum defect (no control, nothing fixed).
        let (nm, _) = Self::normal_matrix(&lin, n, None);
        let max_diag = nm.diagonal().max();
        let regular = nm
            .cholesky()
            .map(|c| c.l().diagonal().iter().all(|d| d * d > 1e-12 * max_diag))
            .unwrap_or(false);
        if !regular {
            return Err(SolveError::Singular(format!(
                "{n} unknowns: a datum defect (no control points, nothing fixed)"
            )));
        }
        stats.observations = m;
        stats.unknowns = n;
        stats.redundancy = (m - n) as f64;
        stats.sigma0 = if m > n {
            (2.0 * cost / (m - n) as f64).sqrt()
        } else {
            1.0
        };
        Ok(stats)
    }

    fn cost(&self, off: &[Option<usize>]) -> Result<f64, SolveError> {
        Ok(self
            .linearise(off)?
            .iter()
            .map(|l| 0.5 * l.r.norm_squared())
            .sum())
    }

    /// Inverse normal matrix (cofactors of the unknowns, in units of σ0²).
    fn cofactors(&self) -> Result<(DMatrix<f64>, Vec<Lin>), SolveError> {
        let (off, n) = self.layout();
        let lin = self.linearise(&off)?;
        let (nm, _) = Self::normal_matrix(&lin, n, None);
        let q = nm
            .cholesky()
            .ok_or_else(|| SolveError::Singular(format!("{n} unknowns")))?
            .inverse();
        Ok((q, lin))
    }

    /// Covariance of a free block (σ0² applied).
    pub fn covariance(
        &self,
        block: usize,
        sigma0: f64,
    ) -> Result<Option<DMatrix<f64>>, SolveError> {
        let (off, _) = self.layout();
        let Some(o) = off[block] else { return Ok(None) };
        let (q, _) = self.cofactors()?;
        let d = self.blocks[block].dim();
        Ok(Some(q.view((o, o), (d, d)) * (sigma0 * sigma0)))
    }

    /// Per active factor: redundancy numbers and normalised residuals w = v/(σ·√r) of its
    /// components.
    pub fn reliability(&self) -> Result<Vec<Reliability>, SolveError> {
        let (q, lin) = self.cofactors()?;
        Ok(lin
            .iter()
            .map(|l| {
                let h = Self::hat_diag(l, &q);
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
            .collect())
    }

    /// Baarda data snooping: adjust, remove the factor with the largest |w| above `critical`
    /// (3.29 for α = 0.1 %), repeat. Returns the removed factors in removal order.
    pub fn data_snooping(
        &mut self,
        critical: f64,
        max_iterations: usize,
    ) -> Result<(Stats, Vec<usize>), SolveError> {
        let mut removed = Vec::new();
        loop {
            let stats = self.solve(max_iterations)?;
            let rel = self.reliability()?;
            let worst = rel
                .iter()
                .map(|r| {
                    (
                        r.factor,
                        r.normalised.iter().fold(0.0f64, |m, x| m.max(x.abs())),
                    )
                })
                .max_by(|a, b| a.1.partial_cmp(&b.1).unwrap_or(std::cmp::Ordering::Equal));
            match worst {
                Some((k, w)) if w > critical => {
                    self.removed[k] = true;
                    removed.push(k);
                }
                _ => return Ok((stats, removed)),
            }
        }
    }

    /// Variance component estimation (Förstner): per group σ̂² = vᵀPv / r over the group,
    /// iterated until the factors settle. Returns each group's σ multiplier (√ of its factor).
    pub fn variance_components(
        &mut self,
        max_rounds: usize,
        max_iterations: usize,
    ) -> Result<Vec<f64>, SolveError> {
        for _ in 0..max_rounds {
            self.solve(max_iterations)?;
            let (q, lin) = self.cofactors()?;
            let ng = self.group_scale.len();
            let mut num = vec![0.0; ng];
            let mut red = vec![0.0; ng];
            for l in &lin {
                let g = self.factors[l.factor].group();
                let h = Self::hat_diag(l, &q);
                for i in 0..l.r.len() {
                    num[g] += l.r[i] * l.r[i];
                    red[g] += 1.0 - h[i];
                }
            }
            let mut change: f64 = 0.0;
            for g in 0..ng {
                if red[g] > 1.0 {
                    let f = num[g] / red[g];
                    self.group_scale[g] *= f;
                    change = change.max((f - 1.0).abs());
                }
            }
            if change < 1e-4 {
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
