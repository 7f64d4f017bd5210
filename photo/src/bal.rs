//! "Bundle Adjustment in the Large" problems: reader, writer of the cost, and a
//! Levenberg–Marquardt bundle adjuster with Schur elimination of the points.
//!
//! BAL camera: Rodrigues rotation, translation, f, k1, k2; P = R·X + t, p = −P/P.z,
//! r(p) = 1 + k1‖p‖² + k2‖p‖⁴, predicted = f·r(p)·p. Inside the solver a rotation is updated
//! by a left perturbation R ← exp(δ)·R; the cost is the file's, ½Σr².

use crate::rotation::{exp_so3, log_so3, skew};
use faer::linalg::solvers::Solve;
use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
use faer::sparse::{SparseColMat, Triplet};
use nalgebra::{DMatrix, DVector, Matrix2x3, Matrix3, SMatrix, SVector, Vector2, Vector3};
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::path::Path;

/// Errors reading a BAL file.
#[derive(Debug, thiserror::Error)]
pub enum BalError {
    #[error("{path}: cannot read: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("{path}: {what}")]
    Format { path: String, what: String },
}

/// A BAL camera as the solver holds it.
#[derive(Clone, Debug)]
pub struct BalCamera {
    pub r: Matrix3<f64>,
    pub t: Vector3<f64>,
    pub f: f64,
    pub k1: f64,
    pub k2: f64,
}

/// One observation: camera, point, measured image point.
#[derive(Clone, Copy, Debug)]
pub struct BalObs {
    pub cam: usize,
    pub pt: usize,
    pub uv: Vector2<f64>,
}

/// A BAL problem.
#[derive(Clone, Debug)]
pub struct BalProblem {
    pub cameras: Vec<BalCamera>,
    pub points: Vec<Vector3<f64>>,
    pub obs: Vec<BalObs>,
}

impl BalProblem {
    pub fn read(path: &Path) -> Result<BalProblem, BalError> {
        let p = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| BalError::Io {
            path: p.clone(),
            source,
        })?;
        let mut it = text.split_ascii_whitespace();
        let mut next = |what: &str| -> Result<f64, BalError> {
            let tok = it.next().ok_or_else(|| BalError::Format {
                path: p.clone(),
                what: format!("the file ends before {what}"),
            })?;
            let v: f64 = tok.parse().map_err(|_| BalError::Format {
                path: p.clone(),
                what: format!("'{tok}' is not a number ({what})"),
            })?;
            if v.is_finite() {
                Ok(v)
            } else {
                Err(BalError::Format {
                    path: p.clone(),
                    what: format!("{what} is not finite"),
                })
            }
        };
        let (nc, np, no) = (
            next("the camera count")? as usize,
            next("the point count")? as usize,
            next("the observation count")? as usize,
        );
        let mut obs = Vec::with_capacity(no);
        for k in 0..no {
            let cam = next("an observation's camera")? as usize;
            let pt = next("an observation's point")? as usize;
            let (u, v) = (next("an image x")?, next("an image y")?);
            if cam >= nc || pt >= np {
                return Err(BalError::Format {
                    path: p.clone(),
                    what: format!(
                        "observation {k} names camera {cam} / point {pt} beyond {nc} / {np}"
                    ),
                });
            }
            obs.push(BalObs {
                cam,
                pt,
                uv: Vector2::new(u, v),
            });
        }
        let mut cameras = Vec::with_capacity(nc);
        for _ in 0..nc {
            let mut c = [0.0; 9];
            for x in c.iter_mut() {
                *x = next("camera parameters")?;
            }
            cameras.push(BalCamera {
                r: exp_so3(&Vector3::new(c[0], c[1], c[2])),
                t: Vector3::new(c[3], c[4], c[5]),
                f: c[6],
                k1: c[7],
                k2: c[8],
            });
        }
        let mut points = Vec::with_capacity(np);
        for _ in 0..np {
            points.push(Vector3::new(
                next("a point")?,
                next("a point")?,
                next("a point")?,
            ));
        }
        Ok(BalProblem {
            cameras,
            points,
            obs,
        })
    }

    /// Residual (predicted − observed) of one observation.
    pub fn residual(&self, o: &BalObs) -> Vector2<f64> {
        project(&self.cameras[o.cam], &self.points[o.pt]).0 - o.uv
    }

    /// ½Σr².
    pub fn cost(&self) -> f64 {
        self.obs
            .par_iter()
            .map(|o| 0.5 * self.residual(o).norm_squared())
            .collect::<Vec<f64>>()
            .iter()
            .sum()
    }

    /// Rodrigues vector of a camera (for writing back in BAL form).
    pub fn rodrigues(&self, cam: usize) -> Vector3<f64> {
        log_so3(&self.cameras[cam].r)
    }
}

type CamJ = SMatrix<f64, 2, 9>;

/// Prediction and, when asked, the Jacobians with respect to (δ, t, f, k1, k2) and X.
fn project(c: &BalCamera, x: &Vector3<f64>) -> (Vector2<f64>, Option<(CamJ, Matrix2x3<f64>)>) {
    let rx = c.r * x;
    let pc = rx + c.t;
    let z = pc.z;
    let p = Vector2::new(-pc.x / z, -pc.y / z);
    let n = p.norm_squared();
    let r = 1.0 + c.k1 * n + c.k2 * n * n;
    let pred = p * (c.f * r);
    let dpred_dp = (nalgebra::Matrix2::identity() * r
        + p * p.transpose() * (2.0 * (c.k1 + 2.0 * c.k2 * n)))
        * c.f;
    let dp_dpc = Matrix2x3::new(-1.0 / z, 0.0, pc.x / (z * z), 0.0, -1.0 / z, pc.y / (z * z));
    let a = dpred_dp * dp_dpc; // 2×3: d pred / d P
    let mut jc = CamJ::zeros();
    jc.fixed_view_mut::<2, 3>(0, 0)
        .copy_from(&(a * (-skew(&rx))));
    jc.fixed_view_mut::<2, 3>(0, 3).copy_from(&a);
    jc.set_column(6, &(p * r));
    jc.set_column(7, &(p * (c.f * n)));
    jc.set_column(8, &(p * (c.f * n * n)));
    (pred, Some((jc, a * c.r)))
}

/// Options of the Levenberg–Marquardt solver.
#[derive(Clone, Debug)]
pub struct LmOptions {
    pub max_iterations: usize,
    /// Stop when the relative cost decrease of an accepted step falls below this.
    pub function_tolerance: f64,
    /// Initial trust-region radius (damping = 1/radius on the scaled diagonal).
    pub initial_radius: f64,
    /// Largest reduced camera system solved densely; larger ones go to faer's sparse
    /// Cholesky with the symbolic factorisation computed once.
    pub dense_limit: usize,
}

impl Default for LmOptions {
    fn default() -> Self {
        LmOptions {
            max_iterations: 100,
            function_tolerance: 1e-6,
            initial_radius: 1e4,
            dense_limit: 2000,
        }
    }
}

/// What the solver did.
#[derive(Clone, Debug)]
pub struct LmReport {
    pub initial_cost: f64,
    pub final_cost: f64,
    pub iterations: usize,
    pub successful: usize,
    pub seconds: f64,
    pub rms_px: f64,
}

fn apply(p: &BalProblem, dc: &[SVector<f64, 9>], dp: &[Vector3<f64>]) -> BalProblem {
    let mut q = p.clone();
    for (c, d) in q.cameras.iter_mut().zip(dc) {
        c.r = exp_so3(&Vector3::new(d[0], d[1], d[2])) * c.r;
        c.t += Vector3::new(d[3], d[4], d[5]);
        c.f += d[6];
        c.k1 += d[7];
        c.k2 += d[8];
    }
    for (x, d) in q.points.iter_mut().zip(dp) {
        *x += d;
    }
    q
}

type Blocks = BTreeMap<(usize, usize), SMatrix<f64, 9, 9>>;

fn solve_dense(n: usize, blocks: &Blocks, b: &DVector<f64>) -> Option<DVector<f64>> {
    let mut s = DMatrix::<f64>::zeros(n, n);
    for (&(i, k), m) in blocks {
        s.view_mut((9 * i, 9 * k), (9, 9)).copy_from(m);
        if i != k {
            s.view_mut((9 * k, 9 * i), (9, 9)).copy_from(&m.transpose());
        }
    }
    Some(s.cholesky()?.solve(b))
}

/// Lower-triangle triplets of the block matrix (in a fixed order).
fn triplets(blocks: &Blocks) -> Vec<Triplet<usize, usize, f64>> {
    let mut t = Vec::with_capacity(blocks.len() * 81);
    for (&(i, k), m) in blocks {
        for r in 0..9 {
            for c in 0..9 {
                let (row, col) = (9 * i + r, 9 * k + c);
                if row >= col {
                    t.push(Triplet {
                        row,
                        col,
                        val: m[(r, c)],
                    });
                }
            }
        }
    }
    t
}

fn sparse_symbolic(n: usize, blocks: &Blocks) -> Option<SymbolicLlt<usize>> {
    // Sequential factorisation: bit-identical results whatever the thread count.
    faer::set_global_parallelism(faer::Par::Seq);
    let m = SparseColMat::<usize, f64>::try_new_from_triplets(n, n, &triplets(blocks)).ok()?;
    SymbolicLlt::try_new(m.symbolic(), faer::Side::Lower).ok()
}

fn solve_sparse(
    sym: &SymbolicLlt<usize>,
    n: usize,
    blocks: &Blocks,
    b: &DVector<f64>,
) -> Option<DVector<f64>> {
    let m = SparseColMat::<usize, f64>::try_new_from_triplets(n, n, &triplets(blocks)).ok()?;
    let llt = Llt::try_new_with_symbolic(sym.clone(), m.as_ref(), faer::Side::Lower).ok()?;
    let mut rhs = faer::Mat::<f64>::from_fn(n, 1, |i, _| b[i]);
    llt.solve_in_place(rhs.as_mut());
    Some(DVector::from_fn(n, |i, _| rhs[(i, 0)]))
}

/// Minimise ½Σr² by Levenberg–Marquardt; the points are eliminated by the Schur complement
/// and the reduced camera system is solved by dense Cholesky when small, by faer's sparse
/// Cholesky (symbolic factorisation reused across iterations) when large.
pub fn solve(problem: &mut BalProblem, opts: &LmOptions) -> LmReport {
    let t0 = std::time::Instant::now();
    let nc = problem.cameras.len();
    let np = problem.points.len();
    // Observations grouped by point (fixed order: deterministic sums).
    let mut by_point: Vec<Vec<usize>> = vec![Vec::new(); np];
    for (k, o) in problem.obs.iter().enumerate() {
        by_point[o.pt].push(k);
    }
    let initial = problem.cost();
    let mut cost = initial;
    let mut radius = opts.initial_radius;
    let mut nu = 2.0;
    let (mut iterations, mut successful) = (0, 0);
    // The sparsity of the reduced system never changes: its symbolic factorisation is reused.
    let mut symbolic: Option<SymbolicLlt<usize>> = None;
    while iterations < opts.max_iterations {
        iterations += 1;
        // Jacobians and residuals, in parallel.
        let lin: Vec<(CamJ, Matrix2x3<f64>, Vector2<f64>)> = problem
            .obs
            .par_iter()
            .map(|o| {
                let (pred, j) = project(&problem.cameras[o.cam], &problem.points[o.pt]);
                let (jc, jp) = j.expect("asked for Jacobians");
                (jc, jp, pred - o.uv)
            })
            .collect();
        let mut u = vec![SMatrix::<f64, 9, 9>::zeros(); nc];
        let mut gc = vec![SVector::<f64, 9>::zeros(); nc];
        for (o, (jc, _, r)) in problem.obs.iter().zip(&lin) {
            u[o.cam] += jc.transpose() * jc;
            gc[o.cam] += jc.transpose() * r;
        }
        let lambda = 1.0 / radius;
        // Damped point blocks and their inverses.
        let vinv: Vec<Option<Matrix3<f64>>> = by_point
            .par_iter()
            .map(|ks| {
                let mut v = Matrix3::zeros();
                for &k in ks {
                    v += lin[k].1.transpose() * lin[k].1;
                }
                for d in 0..3 {
                    v[(d, d)] += lambda * v[(d, d)].clamp(1e-6, 1e32);
                }
                v.try_inverse()
            })
            .collect();
        let gp: Vec<Vector3<f64>> = by_point
            .iter()
            .map(|ks| ks.iter().map(|&k| lin[k].1.transpose() * lin[k].2).sum())
            .collect();
        // Reduced camera system S·Δc = b, kept as 9×9 blocks of its lower triangle.
        let n = 9 * nc;
        let mut blocks: Blocks = BTreeMap::new();
        let mut b = DVector::<f64>::zeros(n);
        for i in 0..nc {
            let mut ui = u[i];
            for d in 0..9 {
                ui[(d, d)] += lambda * ui[(d, d)].clamp(1e-6, 1e32);
            }
            blocks.insert((i, i), ui);
            b.rows_mut(9 * i, 9).copy_from(&(-gc[i]));
        }
        for (j, ks) in by_point.iter().enumerate() {
            let Some(vi) = vinv[j] else {
                // Keep the sparsity pattern fixed (the symbolic factorisation is reused).
                for &a in ks {
                    for &c in ks {
                        let (ci, ck) = (problem.obs[a].cam, problem.obs[c].cam);
                        if ck <= ci {
                            blocks.entry((ci, ck)).or_insert_with(SMatrix::zeros);
                        }
                    }
                }
                continue;
            };
            let ws: Vec<(usize, SMatrix<f64, 9, 3>)> = ks
                .iter()
                .map(|&k| (problem.obs[k].cam, lin[k].0.transpose() * lin[k].1))
                .collect();
            let vg = vi * gp[j];
            for (ci, wi) in &ws {
                let wv = wi * vi;
                let mut bv = b.rows_mut(9 * ci, 9);
                bv += wi * vg;
                for (ck, wk) in &ws {
                    if ck <= ci {
                        *blocks.entry((*ci, *ck)).or_insert_with(SMatrix::zeros) -=
                            wv * wk.transpose();
                    }
                }
            }
        }
        let solved = if n <= opts.dense_limit {
            solve_dense(n, &blocks, &b)
        } else {
            if symbolic.is_none() {
                symbolic = sparse_symbolic(n, &blocks);
            }
            symbolic
                .as_ref()
                .and_then(|sym| solve_sparse(sym, n, &blocks, &b))
        };
        let Some(dc_all) = solved else {
            radius /= nu;
            nu *= 2.0;
            continue;
        };
        let dc: Vec<SVector<f64, 9>> = (0..nc)
            .map(|i| SVector::<f64, 9>::from_iterator(dc_all.rows(9 * i, 9).iter().copied()))
            .collect();
        let dp: Vec<Vector3<f64>> = by_point
            .iter()
            .enumerate()
            .map(|(j, ks)| {
                let Some(vi) = vinv[j] else {
                    return Vector3::zeros();
                };
                let mut rhs = -gp[j];
                for &k in ks {
                    rhs -= (lin[k].0.transpose() * lin[k].1).transpose() * dc[problem.obs[k].cam];
                }
                vi * rhs
            })
            .collect();
        let candidate = apply(problem, &dc, &dp);
        let new_cost = candidate.cost();
        // Predicted decrease of the linear model: −(Δᵀg) − ½ΔᵀJᵀJΔ = ½Δᵀ(λD·Δ − g) in effect.
        let mut model = 0.0;
        for (i, d) in dc.iter().enumerate() {
            model -= d.dot(&gc[i]);
        }
        for (j, d) in dp.iter().enumerate() {
            model -= d.dot(&gp[j]);
        }
        let mut jd2 = 0.0;
        for (o, (jc, jp, _)) in problem.obs.iter().zip(&lin) {
            let v = jc * dc[o.cam] + jp * dp[o.pt];
            jd2 += v.norm_squared();
        }
        model -= 0.5 * jd2;
        let rho = if model > 0.0 {
            (cost - new_cost) / model
        } else {
            -1.0
        };
        if new_cost.is_finite() && rho > 1e-3 {
            let rel = (cost - new_cost) / cost;
            *problem = candidate;
            cost = new_cost;
            successful += 1;
            radius /= (1.0f64 / 3.0).max(1.0 - (2.0 * rho - 1.0).powi(3));
            nu = 2.0;
            if rel < opts.function_tolerance {
                break;
            }
        } else {
            radius /= nu;
            nu *= 2.0;
            if radius < 1e-32 {
                break;
            }
        }
    }
    LmReport {
        initial_cost: initial,
        final_cost: cost,
        iterations,
        successful,
        seconds: t0.elapsed().as_secs_f64(),
        rms_px: (2.0 * cost / problem.obs.len().max(1) as f64).sqrt(),
    }
}
