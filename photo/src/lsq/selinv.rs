//! Selected inversion of a reduced system too large for a dense inverse.
//!
//! S is factorised as P·L·Lᵀ·Pᵀ by faer's supernodal sparse Cholesky, with a fill-reducing
//! ordering of the *blocks* (AMD on the block graph: each block's unknowns stay together,
//! and densely connected blocks — a lever arm, self-calibration, a drift shared by many
//! images — are ordered last by AMD's dense-row rule). The pivots of L give the datum-defect
//! check (each pivot against its own diagonal entry of S, as the dense path does). The
//! entries of Z = S⁻¹ on the pattern of L follow from Takahashi's recurrences, one supernode
//! (columns J, rows R below them) at a time from the root of the elimination tree down:
//!
//!   U = L_RJ·L_JJ⁻¹,  Z_RJ = −Z_RR·U,  Z_JJ = (L_JJ·L_JJᵀ)⁻¹ − Uᵀ·Z_RJ
//!
//! where Z_RR lies in the pattern of the supernodes above (the rows of a column of L form a
//! clique of the filled graph). The pattern of L holds every block of S, so each cofactor
//! block between two unknowns that share a factor or an eliminated block is there; other
//! blocks are solved for on demand with L. The supernodes of one depth of the tree are
//! independent and computed in parallel, each with sequential faer kernels, so the result
//! does not depend on the threads. Memory: L and Z (the same size), never n².

use super::reduced::Reduced;
use super::structure::Structure;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::matmul::matmul;
use faer::linalg::solvers::LltError as NumericError;
use faer::linalg::triangular_solve as tri;
use faer::sparse::linalg::cholesky::supernodal::{SupernodalLltRef, SymbolicSupernodalCholesky};
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky,
    SymbolicCholeskyRaw, SymmetricOrdering,
};
use faer::sparse::linalg::{amd, SupernodalThreshold};
use faer::sparse::{SparseColMat, SymbolicSparseColMatRef};
use faer::{Accum, Mat, Par};
use nalgebra::DMatrix;
use rayon::prelude::*;

/// Why the sparse factorisation failed.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum FactorFailure {
    /// S is not positive definite: the pivot of this column (reduced numbering) is not.
    Pivot(usize),
    /// Out of memory or of index range (what, in words).
    Resources(String),
}

/// A `Vec` of zeros whose allocation may fail (a value, never an abort).
fn zeros(n: usize, what: &str) -> Result<Vec<f64>, FactorFailure> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| {
        FactorFailure::Resources(format!("{what}: {} MB", n.saturating_mul(8) >> 20))
    })?;
    v.resize(n, 0.0);
    Ok(v)
}

/// The sparse Cholesky factor of the reduced matrix with its block ordering.
pub(crate) struct SparseFactor {
    sym: SymbolicCholesky<usize>,
    l: Vec<f64>,
    /// First permuted column of each reduced block.
    poff: Vec<usize>,
    /// Original column of each permuted column.
    fwd: Vec<usize>,
    /// S's diagonal in the permuted order.
    diag: Vec<f64>,
}

/// AMD on the block graph of S (the lower block pattern): the blocks in elimination order.
fn block_order(st: &Structure) -> Result<Vec<usize>, FactorFailure> {
    let nb = st.cdim.len();
    let mut col_ptr = vec![0usize; nb + 1];
    for (a, row) in st.rows.iter().enumerate() {
        for &(_, b) in row.entries.iter().filter(|e| e.1 != a) {
            col_ptr[b + 1] += 1;
        }
    }
    for b in 0..nb {
        col_ptr[b + 1] += col_ptr[b];
    }
    let mut row_idx = vec![0usize; col_ptr[nb]];
    let mut next = col_ptr.clone();
    // Rows in ascending order, so each column's rows are sorted.
    for (a, row) in st.rows.iter().enumerate() {
        for &(_, b) in row.entries.iter().filter(|e| e.1 != a) {
            row_idx[next[b]] = a;
            next[b] += 1;
        }
    }
    let pattern = SymbolicSparseColMatRef::new_checked(nb, nb, &col_ptr, None, &row_idx);
    let (mut perm, mut inv) = (vec![0usize; nb], vec![0usize; nb]);
    let fail = |e: faer::sparse::FaerError| FactorFailure::Resources(format!("ordering: {e:?}"));
    let mut mem = MemBuffer::try_new(amd::order_maybe_unsorted_scratch::<usize>(
        nb,
        row_idx.len(),
    ))
    .map_err(|_| FactorFailure::Resources("ordering workspace".into()))?;
    amd::order_maybe_unsorted(
        &mut perm,
        &mut inv,
        pattern,
        amd::Control::default(),
        MemStack::new(&mut mem),
    )
    .map_err(fail)?;
    Ok(perm)
}

impl SparseFactor {
    /// Factorise the reduced matrix (lower blocks of `red`).
    pub(crate) fn new(st: &Structure, red: &Reduced) -> Result<SparseFactor, FactorFailure> {
        let nr = st.nr;
        let order = block_order(st)?;
        let mut poff = vec![0usize; order.len()];
        let mut fwd = Vec::with_capacity(nr);
        for &b in &order {
            poff[b] = fwd.len();
            fwd.extend(st.coff[b]..st.coff[b] + st.cdim[b]);
        }
        let mut inv = vec![0usize; nr];
        for (k, &o) in fwd.iter().enumerate() {
            inv[o] = k;
        }
        let mut sdiag = vec![0.0; nr];
        for (a, row) in st.rows.iter().enumerate() {
            let (o, d) = (row.start + row.diag, st.cdim[a]);
            for i in 0..d {
                sdiag[st.coff[a] + i] = red.vals[o + i * d + i];
            }
        }
        let diag = fwd.iter().map(|&o| sdiag[o]).collect();
        let m = SparseColMat::<usize, f64>::try_new_from_triplets(
            nr,
            nr,
            &super::reduced::triplets(st, red),
        )
        .map_err(|e| FactorFailure::Resources(format!("reduced matrix: {e:?}")))?;
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
            ..Default::default()
        };
        let perm = faer::perm::PermRef::new_checked(&fwd, &inv, nr);
        let sym = factorize_symbolic_cholesky(
            m.symbolic(),
            faer::Side::Lower,
            SymmetricOrdering::Custom(perm),
            params,
        )
        .map_err(|e| FactorFailure::Resources(format!("symbolic factorisation: {e:?}")))?;
        let mut l = zeros(sym.len_val(), "Cholesky factor")?;
        let par = faer::get_global_parallelism();
        let mut mem =
            MemBuffer::try_new(sym.factorize_numeric_llt_scratch::<f64>(par, Default::default()))
                .map_err(|_| FactorFailure::Resources("factorisation workspace".into()))?;
        let res = sym.factorize_numeric_llt(
            &mut l,
            m.as_ref(),
            faer::Side::Lower,
            Default::default(),
            par,
            MemStack::new(&mut mem),
            Default::default(),
        );
        match res {
            Ok(_) => {}
            Err(NumericError::NonPositivePivot { index }) => {
                return Err(FactorFailure::Pivot(fwd.get(index).copied().unwrap_or(0)))
            }
        }
        Ok(SparseFactor {
            sym,
            l,
            poff,
            fwd,
            diag,
        })
    }

    /// The supernodal structure (always: the factorisation is forced supernodal).
    fn supernodal(&self) -> Result<&SymbolicSupernodalCholesky<usize>, FactorFailure> {
        match self.sym.raw() {
            SymbolicCholeskyRaw::Supernodal(s) => Ok(s),
            SymbolicCholeskyRaw::Simplicial(_) => {
                Err(FactorFailure::Resources("a simplicial factor".into()))
            }
        }
    }

    /// The first column (reduced numbering) whose pivot is not significant: l² ≤ 10⁻¹¹·s
    /// against its own diagonal entry s, the dense path's criterion. `None`: regular.
    pub(crate) fn weak(&self) -> Result<Option<usize>, FactorFailure> {
        let sym = self.supernodal()?;
        let llt = SupernodalLltRef::new(sym, &self.l);
        let mut weak: Option<usize> = None;
        for s in 0..sym.n_supernodes() {
            let node = llt.supernode(s);
            let (f, v) = (node.start(), node.val());
            for j in 0..v.ncols() {
                let x = v[(j, j)];
                if x * x <= 1e-11 * self.diag[f + j] {
                    let col = self.fwd[f + j];
                    weak = Some(weak.map_or(col, |w| w.min(col)));
                }
            }
        }
        Ok(weak)
    }

    /// The cofactors on the pattern of L (Takahashi's recurrences).
    pub(crate) fn selected_inverse(self) -> Result<Selected, FactorFailure> {
        let sym = self.supernodal()?;
        let ns = sym.n_supernodes();
        let (begin, end) = (sym.supernode_begin(), sym.supernode_end());
        let mut sn = vec![0usize; sym.nrows()];
        for s in 0..ns {
            sn[begin[s]..end[s]].fill(s);
        }
        // Depth in the supernodal elimination tree (a parent comes after its children).
        let mut depth = vec![0usize; ns];
        for s in (0..ns).rev() {
            if let Some(&r) = sym.supernode(s).pattern().first() {
                depth[s] = depth[sn[r]] + 1;
            }
        }
        let mut levels: Vec<Vec<usize>> = vec![Vec::new(); depth.iter().max().map_or(0, |d| d + 1)];
        for (s, &d) in depth.iter().enumerate() {
            levels[d].push(s);
        }
        let mut z = zeros(self.l.len(), "selected inverse")?;
        let vptr = sym.col_ptr_for_val();
        for level in &levels {
            let parts: Vec<Result<Vec<f64>, FactorFailure>> = level
                .par_iter()
                .map(|&s| node_inverse(sym, &self.l, &z, &sn, s))
                .collect();
            for (&s, p) in level.iter().zip(parts) {
                z[vptr[s]..vptr[s + 1]].copy_from_slice(&p?);
            }
        }
        Ok(Selected {
            factor: self,
            z,
            sn,
        })
    }
}

/// Where row `i` is among the rows of supernode `t` (its columns, then its pattern).
fn row_pos(sym: &SymbolicSupernodalCholesky<usize>, t: usize, i: usize) -> Option<usize> {
    let (ft, et) = (sym.supernode_begin()[t], sym.supernode_end()[t]);
    if (ft..et).contains(&i) {
        return Some(i - ft);
    }
    let p = sym.supernode(t).pattern().binary_search(&i).ok()?;
    Some(et - ft + p)
}

/// The row index at position `p` of supernode `t`'s rows.
fn row_at(sym: &SymbolicSupernodalCholesky<usize>, t: usize, p: usize) -> Option<usize> {
    let (ft, et) = (sym.supernode_begin()[t], sym.supernode_end()[t]);
    if p < et - ft {
        return Some(ft + p);
    }
    sym.supernode(t).pattern().get(p - (et - ft)).copied()
}

/// Z_RR of supernode rows `pat` from the finished supernodes above, as a full symmetric
/// matrix.
fn gather(
    sym: &SymbolicSupernodalCholesky<usize>,
    z: &[f64],
    sn: &[usize],
    pat: &[usize],
) -> Result<Mat<f64>, FactorFailure> {
    let r = pat.len();
    let missing = || FactorFailure::Resources("a cofactor outside the factor's pattern".into());
    let mut m = Mat::<f64>::zeros(r, r);
    let vptr = sym.col_ptr_for_val();
    for q in 0..r {
        let k = pat[q];
        let t = sn[k];
        let (ft, et) = (sym.supernode_begin()[t], sym.supernode_end()[t]);
        let pt = sym.supernode(t).pattern();
        let ld = et - ft + pt.len();
        let col = &z[vptr[t] + (k - ft) * ld..][..ld];
        // Rows past the supernode's columns are a sorted subset of its pattern: merge.
        let mut p = pat[q..]
            .iter()
            .find(|&&i| i >= et)
            .map_or(pt.len(), |&i| pt.partition_point(|&x| x < i));
        for (qq, &i) in pat.iter().enumerate().skip(q) {
            let pos = if i < et {
                i - ft
            } else {
                while p < pt.len() && pt[p] < i {
                    p += 1;
                }
                if pt.get(p) != Some(&i) {
                    return Err(missing());
                }
                et - ft + p
            };
            m[(qq, q)] = col[pos];
            m[(q, qq)] = col[pos];
        }
    }
    Ok(m)
}

/// Supernode `s`'s part of Z (its columns: Z_JJ over Z_RJ, column-major, as L is stored).
fn node_inverse(
    sym: &SymbolicSupernodalCholesky<usize>,
    l: &[f64],
    z: &[f64],
    sn: &[usize],
    s: usize,
) -> Result<Vec<f64>, FactorFailure> {
    let node = SupernodalLltRef::new(sym, l).supernode(s);
    let (pat, lv) = (node.pattern(), node.val());
    let (n, r) = (lv.ncols(), pat.len());
    let ljj = lv.submatrix(0, 0, n, n);
    let mut linv = Mat::<f64>::identity(n, n);
    tri::solve_lower_triangular_in_place(ljj, linv.as_mut(), Par::Seq);
    // Uᵀ = L_JJ⁻ᵀ·L_RJᵀ.
    let mut ut = lv.submatrix(n, 0, r, n).transpose().to_owned();
    tri::solve_upper_triangular_in_place(ljj.transpose(), ut.as_mut(), Par::Seq);
    let zrr = gather(sym, z, sn, pat)?;
    let mut zrj = Mat::<f64>::zeros(r, n);
    matmul(
        zrj.as_mut(),
        Accum::Replace,
        zrr.as_ref(),
        ut.transpose(),
        -1.0,
        Par::Seq,
    );
    let mut zjj = Mat::<f64>::zeros(n, n);
    matmul(
        zjj.as_mut(),
        Accum::Replace,
        linv.transpose(),
        linv.as_ref(),
        1.0,
        Par::Seq,
    );
    matmul(
        zjj.as_mut(),
        Accum::Add,
        ut.as_ref(),
        zrj.as_ref(),
        -1.0,
        Par::Seq,
    );
    let mut out = Vec::with_capacity((n + r) * n);
    for j in 0..n {
        out.extend((0..n).map(|i| zjj[(i, j)]));
        out.extend((0..r).map(|i| zrj[(i, j)]));
    }
    Ok(out)
}

/// The cofactors of the reduced system on the pattern of its Cholesky factor, with the
/// factor for the blocks outside it.
pub(crate) struct Selected {
    factor: SparseFactor,
    z: Vec<f64>,
    /// Supernode of each permuted column.
    sn: Vec<usize>,
}

impl Selected {
    /// The cofactor block between reduced blocks `ca` (rows, dimension `da`) and `cb`: from
    /// the selected entries when in the pattern of L, else solved for with L (`None` when
    /// its workspace cannot be had).
    pub(crate) fn block(&self, ca: usize, cb: usize, da: usize, db: usize) -> Option<DMatrix<f64>> {
        let f = &self.factor;
        let (pa, pb) = (f.poff[ca], f.poff[cb]);
        self.stored(pa, pb, da, db)
            .or_else(|| self.solved(ca, cb, da, db))
    }

    /// The entry at permuted row `r` and column `c` (r ≥ c: the lower triangle) when the
    /// pattern holds it (what a 1 × 1 `stored` block gives, without allocating one).
    fn element(&self, r: usize, c: usize) -> Option<f64> {
        let sym = self.factor.supernodal().ok()?;
        let t = self.sn[c];
        let ft = sym.supernode_begin()[t];
        let ld = sym.supernode_end()[t] - ft + sym.supernode(t).pattern().len();
        let p = row_pos(sym, t, r)?;
        Some(self.z[sym.col_ptr_for_val()[t] + (c - ft) * ld + p])
    }

    /// The block at permuted offsets (`pa`, `pb`) when the pattern holds it.
    fn stored(&self, pa: usize, pb: usize, da: usize, db: usize) -> Option<DMatrix<f64>> {
        if pa < pb {
            return self.stored(pb, pa, db, da).map(|m| m.transpose());
        }
        let sym = self.factor.supernodal().ok()?;
        let vptr = sym.col_ptr_for_val();
        let mut m = DMatrix::zeros(da, db);
        for j in 0..db {
            let c = pb + j;
            let t = self.sn[c];
            let ft = sym.supernode_begin()[t];
            let ld = sym.supernode_end()[t] - ft + sym.supernode(t).pattern().len();
            let col = &self.z[vptr[t] + (c - ft) * ld..][..ld];
            let mut pos = None;
            for i in 0..da {
                // The upper triangle of a diagonal block: its mirror image.
                if pa + i < c {
                    m[(i, j)] = self.element(c, pa + i)?;
                    continue;
                }
                let next = pos.map(|p: usize| p + 1);
                let p = match next.filter(|&p| row_at(sym, t, p) == Some(pa + i)) {
                    Some(p) => p,
                    None => row_pos(sym, t, pa + i)?,
                };
                m[(i, j)] = col[p];
                pos = Some(p);
            }
        }
        Some(m)
    }

    /// The block by solving S·X = E_b with the factor (a block outside the pattern).
    fn solved(&self, ca: usize, cb: usize, da: usize, db: usize) -> Option<DMatrix<f64>> {
        let f = &self.factor;
        // Original offsets of the two blocks: where their first permuted columns came from.
        let (oa, ob) = (f.fwd[f.poff[ca]], f.fwd[f.poff[cb]]);
        let x = Mat::<f64>::from_fn(f.fwd.len(), db, |i, j| if i == ob + j { 1.0 } else { 0.0 });
        let x = self.solve(x)?;
        Some(DMatrix::from_fn(da, db, |i, j| x[(oa + i, j)]))
    }

    /// S⁻¹·`rhs` (original order) with the factor; `None` when its workspace cannot be had.
    pub(crate) fn solve(&self, mut rhs: Mat<f64>) -> Option<Mat<f64>> {
        let f = &self.factor;
        let par = Par::Seq;
        let req = f.sym.solve_in_place_scratch::<f64>(rhs.ncols(), par);
        let mut mem = MemBuffer::try_new(req).ok()?;
        LltRef::new(&f.sym, &f.l).solve_in_place_with_conj(
            faer::Conj::No,
            rhs.as_mut(),
            par,
            MemStack::new(&mut mem),
        );
        Some(rhs)
    }
}

#[cfg(test)]
#[path = "selinv_tests.rs"]
mod tests;
