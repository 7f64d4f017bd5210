//! A general least-squares adjustment over parameter blocks and factors (the Ceres / gtsam
//! pattern): a factor names the blocks it touches and returns its residual and Jacobians; a
//! diagonal noise model whitens it; an optional robust loss reweights it. The solver never
//! knows what a factor means. After convergence: σ0, covariances, redundancy numbers, Baarda
//! data snooping with removal, and variance components per observation group.
//!
//! Object points (blocks added with [`Problem::add_point`]) are eliminated by the Schur
//! complement in every step and the reduced system over the other blocks is solved densely;
//! factors are linearised in parallel. The statistics (covariances, redundancy numbers) use
//! the inverse of the reduced system and the Schur complement per point (see `stats`).

use crate::camera::Pose;
use crate::rotation::exp_so3;
use faer::sparse::linalg::solvers::SymbolicLlt;
use nalgebra::{DMatrix, DVector, Vector3};
use rayon::prelude::*;

mod reduced;
mod stats;
pub use stats::{normal_quantile, snooping_critical};

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
    /// The removed/fixed flags for which the normals were last found regular: the check (a
    /// dense factorisation) is repeated only when they change.
    regular_for: Option<(Vec<bool>, Vec<bool>)>,
    /// The last cofactors and the state (hash) they are for.
    cofactor_cache: std::sync::Mutex<Option<(u64, stats::Shared)>>,
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
    #[error("block {0} is not determined by its observations (observed too few times, or only along one ray)")]
    Undetermined(usize),
    #[error("the normal equations are singular at block {0}: a datum defect (no control, nothing fixed) or unknowns that cannot be told apart")]
    Dependent(usize),
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
            regular_for: None,
            cofactor_cache: std::sync::Mutex::new(None),
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
    /// Gauss–Newton with Levenberg damping until the step is tiny.
    pub fn solve(&mut self, max_iterations: usize) -> Result<Stats, SolveError> {
        let t = std::time::Instant::now();
        let r = self.solve_inner(max_iterations);
        if std::env::var_os("PPKAT_TRACE").is_some() {
            let it = r.as_ref().map(|s| s.iterations).unwrap_or(0);
            eprintln!("solve: {it} iterations, {:.2} s", t.elapsed().as_secs_f64());
        }
        r
    }

    fn solve_inner(&mut self, max_iterations: usize) -> Result<Stats, SolveError> {
        let (off, n) = self.layout();
        let mut lambda = 1e-6;
        let mut stats = Stats::default();
        let mut cost = self.cost(&off)?;
        // Every free block must be determined by its own observations (a point seen by one
        // ray, a camera without points are not): check its diagonal block of the normals.
        {
            let lin = self.linearise(&off)?;
            let mut diag: Vec<Option<DMatrix<f64>>> = vec![None; self.blocks.len()];
            for l in &lin {
                for (b, (_, j)) in l.blocks.iter().zip(&l.j) {
                    let e = diag[*b].get_or_insert_with(|| DMatrix::zeros(j.ncols(), j.ncols()));
                    *e += j.transpose() * j;
                }
            }
            for (b, o) in off.iter().enumerate() {
                if o.is_none() {
                    continue;
                }
                let ok = diag[b].as_ref().is_some_and(|m| {
                    let e = m.clone().symmetric_eigenvalues();
                    let (lo, hi) = (e.min(), e.max());
                    hi > 0.0 && lo > 1e-10 * hi
                });
                if !ok {
                    return Err(SolveError::Undetermined(b));
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
                if rel < 1e-14 {
                    // No gain at all: keep the values as they were (a converged problem solved
                    // again stays bit for bit where it was, so its statistics can be reused).
                    self.blocks = saved;
                    break;
                }
                cost = new_cost;
                lambda = (lambda / 10.0).max(1e-12);
                if rel < 1e-12 || dx.norm() < 1e-12 {
                    break;
                }
            } else {
                self.blocks = saved;
                // A step that loses only round-off: converged.
                if (new_cost - cost) < 1e-12 * cost {
                    break;
                }
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
        let flags = (self.removed.clone(), self.fixed.clone());
        let known = self.regular_for.as_ref() == Some(&flags);
        match if known {
            Ok(())
        } else {
            self.regular(&lin, &off, n)
        } {
            Ok(()) => self.regular_for = Some(flags),
            Err(Some(b)) => return Err(SolveError::Dependent(b)),
            Err(None) => {
                return Err(SolveError::Singular(format!(
                    "{n} unknowns: a datum defect (no control points, nothing fixed)"
                )))
            }
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
}
