//! The normal equations with the object points eliminated (Schur complement): built once per
//! step for the solve, and once at the solution for the statistics (regularity check,
//! cofactors). The reduced matrix is kept as blocks keyed by their offsets, so it goes to a
//! dense or a sparse Cholesky without knowing what the blocks mean.

use super::{Lin, Loss, Problem};
use faer::linalg::solvers::{DenseSolveCore, Solve};
use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
use faer::sparse::{SparseColMat, Triplet};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use std::collections::BTreeMap;

/// The reduced normal equations over the non-point free blocks, and what the elimination of
/// each point needs for back-substitution and cofactors.
pub(super) struct Reduced {
    /// Offset of each non-point free block in the reduced system.
    pub roff: Vec<Option<usize>>,
    pub nr: usize,
    /// Reduced matrix blocks keyed by (row offset, column offset).
    pub u: BTreeMap<(usize, usize), DMatrix<f64>>,
    pub gr: DVector<f64>,
    /// Per point: the (damped) inverse of its 3×3 normal block and its gradient.
    pub vinv: BTreeMap<usize, (Matrix3<f64>, Vector3<f64>)>,
    /// Per point: the non-point blocks it is tied to, with Wᵀ (3 × d) = J_pᵀ·J_b.
    pub w: BTreeMap<usize, Vec<(usize, DMatrix<f64>)>>,
}

impl Reduced {
    /// The reduced matrix as one dense symmetric faer matrix.
    pub fn dense(&self) -> faer::Mat<f64> {
        let mut m = faer::Mat::<f64>::zeros(self.nr, self.nr);
        for (&(r, c), b) in &self.u {
            for j in 0..b.ncols() {
                for i in 0..b.nrows() {
                    m[(r + i, c + j)] = b[(i, j)];
                }
            }
        }
        m
    }
}

/// faer's kernels split their work by this fixed count, not by the size of rayon's pool: the
/// same bits whatever RAYON_NUM_THREADS says. Set before every factorisation, as the setting
/// is process-wide (the BAL solver sets its own).
fn fixed_split() {
    faer::set_global_parallelism(faer::Par::rayon(2));
}

/// Dense Cholesky (faer) of a symmetric positive matrix. Returns the first column whose pivot
/// is not significant (a datum defect or dependency there; `None`: regular) and the inverse
/// when asked. `None` when the matrix is not positive definite at all.
pub(super) fn dense_factor(
    m: faer::Mat<f64>,
    inverse: bool,
) -> Option<(Option<usize>, Option<faer::Mat<f64>>)> {
    fixed_split();
    let n = m.nrows();
    let Ok(llt) = m.llt(faer::Side::Lower) else {
        // Not positive definite: find the first leading minor that is not (bisection), to
        // name the unknowns that depend on the others.
        let (mut lo, mut hi) = (0usize, n);
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if m.as_ref()
                .submatrix(0, 0, mid, mid)
                .llt(faer::Side::Lower)
                .is_ok()
            {
                lo = mid
            } else {
                hi = mid
            }
        }
        return Some((Some(hi - 1), None));
    };
    let l = llt.L();
    // Each pivot against its own diagonal entry: a (near-)dependent unknown loses all its
    // significant digits there, however the unknowns are scaled.
    let weak = (0..n).find(|&i| l[(i, i)] * l[(i, i)] <= 1e-11 * m[(i, i)]);
    drop(m);
    let inv = inverse.then(|| llt.inverse());
    Some((weak, inv))
}

impl Problem {
    /// Whether a factor ties two eliminated points together (then no Schur elimination).
    pub(super) fn points_tied(&self, lin: &[Lin]) -> bool {
        lin.iter()
            .any(|l| l.blocks.iter().filter(|b| self.eliminate[**b]).count() > 1)
    }

    /// Build the reduced system with Levenberg damping `lambda` (0 for statistics) and the
    /// robust loss applied when `robust`.
    pub(super) fn reduce(
        &self,
        lin: &[Lin],
        off: &[Option<usize>],
        lambda: f64,
        robust: bool,
    ) -> Option<Reduced> {
        let is_pt = |b: usize| self.eliminate[b];
        let mut roff: Vec<Option<usize>> = vec![None; self.blocks.len()];
        let mut nr = 0;
        for (b, o) in off.iter().enumerate() {
            if o.is_some() && !is_pt(b) {
                roff[b] = Some(nr);
                nr += self.blocks[b].dim();
            }
        }
        let mut u: BTreeMap<(usize, usize), DMatrix<f64>> = BTreeMap::new();
        let mut gr = DVector::<f64>::zeros(nr);
        let mut v: BTreeMap<usize, (Matrix3<f64>, Vector3<f64>)> = BTreeMap::new();
        let mut w: BTreeMap<(usize, usize), DMatrix<f64>> = BTreeMap::new();
        for l in lin {
            let wt = if robust {
                self.loss.weight(l.r.norm())
            } else {
                1.0
            };
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
                            *w.entry((*ba, *bb))
                                .or_insert_with(|| DMatrix::zeros(3, jb.ncols())) +=
                                ja.transpose() * jb * wt;
                        }
                        _ => {}
                    }
                }
            }
        }
        if lambda > 0.0 {
            for ((ra, rb), m) in u.iter_mut() {
                if ra == rb {
                    for i in 0..m.nrows() {
                        m[(i, i)] += lambda * m[(i, i)].max(1e-12);
                    }
                }
            }
        }
        let mut by_point: BTreeMap<usize, Vec<(usize, DMatrix<f64>)>> = BTreeMap::new();
        for ((p, b), m) in w {
            by_point.entry(p).or_default().push((b, m));
        }
        let mut vinv = BTreeMap::new();
        for (p, (vp, gp)) in &v {
            let mut vd = *vp;
            for d in 0..3 {
                vd[(d, d)] += lambda * vp[(d, d)].max(1e-12);
            }
            let vi = vd.try_inverse()?;
            vinv.insert(*p, (vi, *gp));
            let cams = by_point.get(p).map(|x| x.as_slice()).unwrap_or(&[]);
            for (a, wa) in cams {
                let ra = roff[*a]?;
                let t = wa.transpose() * DMatrix::from_column_slice(3, 3, vi.as_slice());
                let mut gv = gr.rows_mut(ra, wa.ncols());
                gv -= &t * DVector::from_column_slice(gp.as_slice());
                for (b, wb) in cams {
                    let rb = roff[*b]?;
                    *u.entry((ra, rb))
                        .or_insert_with(|| DMatrix::zeros(wa.ncols(), wb.ncols())) -= &t * wb;
                }
            }
        }
        Some(Reduced {
            roff,
            nr,
            u,
            gr,
            vinv,
            w: by_point,
        })
    }

    /// Solve the reduced system for −g: dense when small, faer's sparse Cholesky when large,
    /// its symbolic factorisation kept while the pattern is unchanged.
    fn solve_reduced(&self, red: &Reduced) -> Option<DVector<f64>> {
        fixed_split();
        let nr = red.nr;
        if nr <= self.dense_limit {
            let llt = red.dense().llt(faer::Side::Lower).ok()?;
            let mut rhs = faer::Mat::<f64>::from_fn(nr, 1, |i, _| -red.gr[i]);
            llt.solve_in_place(rhs.as_mut());
            return Some(DVector::from_fn(nr, |i, _| rhs[(i, 0)]));
        }
        let mut t = Vec::new();
        for (&(r0, c0), b) in &red.u {
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
        let pattern: Vec<(usize, usize)> = red.u.keys().copied().collect();
        let mut cache = self.symbolic.lock().ok()?;
        if cache.as_ref().map(|c| c.0 != pattern).unwrap_or(true) {
            *cache = Some((
                pattern,
                SymbolicLlt::try_new(m.symbolic(), faer::Side::Lower).ok()?,
            ));
        }
        let sym = cache.as_ref()?.1.clone();
        let llt = Llt::try_new_with_symbolic(sym, m.as_ref(), faer::Side::Lower).ok()?;
        let mut rhs = faer::Mat::<f64>::from_fn(nr, 1, |i, _| -red.gr[i]);
        llt.solve_in_place(rhs.as_mut());
        Some(DVector::from_fn(nr, |i, _| rhs[(i, 0)]))
    }

    /// One damped Gauss–Newton step with the point blocks eliminated by the Schur complement.
    /// Falls back to the full normals when a factor ties two points together.
    pub(super) fn schur_step(
        &self,
        lin: &[Lin],
        off: &[Option<usize>],
        n: usize,
        lambda: f64,
    ) -> Option<DVector<f64>> {
        if self.points_tied(lin) {
            let (nm, g) = Self::normal_matrix(lin, n, Some(self.loss));
            let mut d = nm.clone();
            for i in 0..n {
                d[(i, i)] += lambda * nm[(i, i)].max(1e-12);
            }
            return Some(d.cholesky()?.solve(&(-g)));
        }
        let red = self.reduce(lin, off, lambda, true)?;
        let dr = self.solve_reduced(&red)?;
        let mut dx = DVector::<f64>::zeros(n);
        for (b, o) in off.iter().enumerate() {
            if let (Some(o), Some(ro)) = (o, red.roff[b]) {
                let d = self.blocks[b].dim();
                dx.rows_mut(*o, d).copy_from(&dr.rows(ro, d));
            }
        }
        for (p, (vi, gp)) in &red.vinv {
            let mut rhs = -gp;
            for (a, wa) in red.w.get(p).map(|x| x.as_slice()).unwrap_or(&[]) {
                let ra = red.roff[*a]?;
                let da = dr.rows(ra, wa.ncols());
                rhs -= Vector3::from_iterator((wa * da).iter().copied());
            }
            let o = off[*p]?;
            dx.rows_mut(o, 3).copy_from(&(vi * rhs));
        }
        Some(dx)
    }

    /// Full normal matrix and gradient (small problems, statistics fallback).
    pub(super) fn normal_matrix(
        lin: &[Lin],
        n: usize,
        loss: Option<Loss>,
    ) -> (DMatrix<f64>, DVector<f64>) {
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
}
