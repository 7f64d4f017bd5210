//! The reduced system's linear algebra: dense faer Cholesky when small, faer's sparse
//! Cholesky (symbolic factorisation kept while the structure holds) when large; pivots that
//! betray a datum defect; the cofactors for statistics — the whole inverse when small, the
//! selected inverse on the sparse factor's pattern when large (`selinv`), so that no n²
//! matrix is ever allocated above `Options::dense_limit`. This is the one place that sets
//! faer's parallelism. faer's results depend on the degree of parallelism it is given (its
//! matrix products block the sums by it), not on the rayon pool that runs the work, so it is
//! always given [`FAER_DEGREE`]: `Options::threads` (the pool) changes speed, never results.

use super::options::Options;
use super::reduced::{for_each_block, triplets, Reduced};
use super::selinv::{FactorFailure, Selected, SparseFactor};
use super::structure::Structure;
use faer::linalg::solvers::{DenseSolveCore, Solve};
use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
use faer::sparse::SparseColMat;

/// The degree of parallelism faer is always given, whatever the thread count: a degree
/// that followed the threads (sequential on one) gave other bits on 1, 2, 3 and 8 threads
/// (the demo block's σ0 differed in the 13th digit). The pool that runs the work is the
/// current rayon pool (`--threads`).
pub(crate) const FAER_DEGREE: usize = 8;

/// A symbolic sparse factorisation and the structure hash it was computed for.
pub(crate) type SymbolicCache = (u64, SymbolicLlt<usize>);

/// The reduced system's solves with the solver's settings, its symbolic factorisation and
/// the dense matrix reused from step to step.
pub(crate) struct Linear<'a> {
    /// Dense limit and threads.
    options: &'a Options,
    /// The symbolic factorisation kept between steps.
    symbolic: &'a std::sync::Mutex<Option<SymbolicCache>>,
    /// The dense reduced matrix, factorised in place: one allocation for all steps instead of
    /// two per step (a fresh matrix and the factor's copy of it).
    dense: std::cell::RefCell<faer::Mat<f64>>,
}

impl<'a> Linear<'a> {
    /// The solves for `options`, keeping the symbolic factorisation in `symbolic`.
    pub(crate) fn new(
        options: &'a Options,
        symbolic: &'a std::sync::Mutex<Option<SymbolicCache>>,
    ) -> Linear<'a> {
        Linear {
            options,
            symbolic,
            dense: std::cell::RefCell::new(faer::Mat::new()),
        }
    }

    /// Set faer's parallelism (process-wide: set before each factorisation): always the
    /// degree [`FAER_DEGREE`], run by the current rayon pool, whose size (`--threads`) sets
    /// the speed. Not [`faer::Par::Seq`] on one thread either: that sums in another order.
    pub(crate) fn set_parallelism(&self) {
        faer::set_global_parallelism(faer::Par::rayon(FAER_DEGREE));
    }

    /// Solve S·δ = −b: dense when small, sparse when large. `None` when S is not positive
    /// definite.
    pub(crate) fn solve_reduced(&self, st: &Structure, red: &Reduced) -> Option<Vec<f64>> {
        self.set_parallelism();
        let nr = st.nr;
        let mut rhs = faer::Mat::<f64>::from_fn(nr, 1, |i, _| -red.g[i]);
        if nr <= self.options.dense_limit {
            self.dense_solve(st, red, rhs.as_mut())?;
        } else {
            let m = SparseColMat::<usize, f64>::try_new_from_triplets(nr, nr, &triplets(st, red))
                .ok()?;
            let mut cache = self.symbolic.lock().ok()?;
            if cache.as_ref().is_none_or(|c| c.0 != st.hash) {
                *cache = Some((
                    st.hash,
                    SymbolicLlt::try_new(m.symbolic(), faer::Side::Lower).ok()?,
                ));
            }
            let sym = cache.as_ref()?.1.clone();
            drop(cache);
            let llt = Llt::try_new_with_symbolic(sym, m.as_ref(), faer::Side::Lower).ok()?;
            llt.solve_in_place(rhs.as_mut());
        }
        Some((0..nr).map(|i| rhs[(i, 0)]).collect())
    }

    /// Factorise the lower triangle of S in the reused matrix and solve for `rhs` in place:
    /// the same faer calls, in the same order, as `Mat::llt` and `Llt::solve_in_place`.
    fn dense_solve(&self, st: &Structure, red: &Reduced, rhs: faer::MatMut<'_, f64>) -> Option<()> {
        use faer::dyn_stack::{MemBuffer, MemStack};
        use faer::linalg::cholesky::llt;
        let mut m = self.dense.borrow_mut();
        if m.nrows() != st.nr {
            *m = faer::Mat::zeros(st.nr, st.nr);
        } else {
            // The last factor is still there, fill-in included: S's empty blocks must be zero.
            m.as_mut().fill(0.0);
        }
        for_each_block(st, red, |r0, c0, dr, dc, b| {
            for j in 0..dc {
                for i in 0..dr {
                    if r0 + i >= c0 + j {
                        m[(r0 + i, c0 + j)] = b[j * dr + i];
                    }
                }
            }
        });
        let par = faer::get_global_parallelism();
        let need = llt::factor::cholesky_in_place_scratch::<f64>(st.nr, par, Default::default());
        let mut mem = MemBuffer::new(need);
        let stack = MemStack::new(&mut mem);
        llt::factor::cholesky_in_place(
            m.as_mut(),
            Default::default(),
            par,
            stack,
            Default::default(),
        )
        .ok()?;
        let stack = MemStack::new(&mut mem);
        llt::solve::solve_in_place_with_conj(m.as_ref(), faer::Conj::No, rhs, par, stack);
        Some(())
    }

    /// Dense Cholesky of the reduced matrix. Returns the first column whose pivot is not
    /// significant (a datum defect or dependency there; `None`: regular) and the inverse when
    /// asked; `None` when the matrix is not positive definite at all (then the column is found
    /// by bisection over leading minors).
    pub(crate) fn dense_factor(
        &self,
        st: &Structure,
        red: &Reduced,
        inverse: bool,
    ) -> Option<(Option<usize>, Option<faer::Mat<f64>>)> {
        self.set_parallelism();
        let m = dense(st, red);
        let n = m.nrows();
        let Ok(llt) = m.llt(faer::Side::Lower) else {
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
}

/// The reduced matrix as one dense symmetric faer matrix, from the lower triangle (the upper
/// triangle of a diagonal block is not kept up to date).
fn dense(st: &Structure, red: &Reduced) -> faer::Mat<f64> {
    let mut m = faer::Mat::<f64>::zeros(st.nr, st.nr);
    for_each_block(st, red, |r0, c0, dr, dc, b| {
        for j in 0..dc {
            for i in 0..dr {
                if r0 + i >= c0 + j {
                    m[(r0 + i, c0 + j)] = b[j * dr + i];
                    m[(c0 + j, r0 + i)] = b[j * dr + i];
                }
            }
        }
    });
    m
}

/// The cofactors of the reduced system: the whole inverse when small, the blocks on the
/// pattern of the sparse factor (and any other on demand) when large.
pub(crate) enum Qcc {
    /// The dense inverse.
    Dense(faer::Mat<f64>),
    /// The selected inverse (boxed: it is the larger).
    Sparse(Box<Selected>),
}

impl Qcc {
    /// The cofactor block between reduced blocks `ca` (rows) and `cb`.
    pub(crate) fn block(
        &self,
        st: &Structure,
        ca: usize,
        cb: usize,
    ) -> Option<nalgebra::DMatrix<f64>> {
        let (da, db) = (st.cdim[ca], st.cdim[cb]);
        match self {
            Qcc::Dense(m) => {
                let (ra, rb) = (st.coff[ca], st.coff[cb]);
                Some(nalgebra::DMatrix::from_fn(da, db, |i, j| {
                    m[(ra + i, rb + j)]
                }))
            }
            Qcc::Sparse(s) => s.block(ca, cb, da, db),
        }
    }

    /// S⁻¹·`rhs`; `None` when a workspace cannot be had.
    pub(crate) fn solve(&self, st: &Structure, rhs: faer::Mat<f64>) -> Option<faer::Mat<f64>> {
        match self {
            Qcc::Dense(m) if m.nrows() == st.nr => Some(m * rhs),
            Qcc::Dense(_) => None,
            Qcc::Sparse(s) => s.solve(rhs),
        }
    }
}

impl Linear<'_> {
    /// The first column of S whose pivot is not significant (`Ok(None)`: regular), by the
    /// dense factorisation when small, the sparse one when large; `Err` when S is not
    /// positive definite (the sparse path names the failing column) or too large.
    pub(crate) fn regularity(
        &self,
        st: &Structure,
        red: &Reduced,
    ) -> Result<Option<usize>, FactorFailure> {
        if st.nr <= self.options.dense_limit {
            return match self.dense_factor(st, red, false) {
                Some((weak, _)) => Ok(weak),
                None => Err(FactorFailure::Resources("dense factorisation".into())),
            };
        }
        self.set_parallelism();
        SparseFactor::new(st, red)?.weak()
    }

    /// The cofactors of S: the dense inverse when small, the selected inverse when large.
    pub(crate) fn cofactor_matrix(
        &self,
        st: &Structure,
        red: &Reduced,
    ) -> Result<Qcc, FactorFailure> {
        if st.nr <= self.options.dense_limit {
            return match self.dense_factor(st, red, true) {
                Some((_, Some(q))) => Ok(Qcc::Dense(q)),
                Some((col, None)) => Err(FactorFailure::Pivot(col.unwrap_or(0))),
                None => Err(FactorFailure::Resources("dense factorisation".into())),
            };
        }
        self.set_parallelism();
        Ok(Qcc::Sparse(Box::new(
            SparseFactor::new(st, red)?.selected_inverse()?,
        )))
    }
}
