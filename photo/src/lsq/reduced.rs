//! One damped Gauss–Newton step through the Schur complement.
//!
//! The work is split into jobs that each own a copy of the reduced system: one job per range
//! of eliminated blocks (`Structure::chunks`) and one for the factors that touch no eliminated
//! block. A range job walks its eliminated blocks in order; for each it reads the factors
//! touching it (consecutive in the linearisation buffer), adds their direct terms Jₐᵀ·J_b and
//! Jₐᵀ·r, forms V (damped), gₑ and W, then V⁻¹ and Tₙ = Wₙᵀ·V⁻¹, and subtracts Tₐ·W_b and
//! Tₐ·gₑ. The copies are added in job order — a count fixed by the problem, never by the
//! threads — and the damping λ·clamp(diag JᵀJ) goes on the diagonal. Then the reduced solve,
//! back-substitution of the eliminated blocks, and the decrease the linear model promises.
//! Also the reduced matrix's stored blocks in a fixed order (`for_each_block`, `triplets`),
//! which the linear solvers and the selected inverse read.

use super::elim::EBlock;
use super::lin::{add_ab, add_atb, add_atv, add_av, pieces, Linearisation, MIN_LEN};
use super::model::Model;
use super::structure::Structure;
use super::value::Value;
use faer::sparse::Triplet;
use nalgebra::{DMatrix, Matrix3, SMatrixView, SMatrixViewMut};
use rayon::prelude::*;

/// Levenberg–Marquardt damping of a diagonal element: λ·clamp(d, 1e-6, 1e32) (as Ceres).
fn damp(lambda: f64, d: f64) -> f64 {
    lambda * d.clamp(1e-6, 1e32)
}

/// One job's sums: the reduced matrix, its right-hand side and the diagonal of the direct
/// terms (for the damping).
#[derive(Clone, Debug, Default)]
pub(crate) struct Sums {
    vals: Vec<f64>,
    g: Vec<f64>,
    diag: Vec<f64>,
}

impl Sums {
    fn zeroed(&mut self, st: &Structure) {
        for (buf, n) in [
            (&mut self.vals, st.nvals),
            (&mut self.g, st.nr),
            (&mut self.diag, st.nr),
        ] {
            buf.clear();
            buf.resize(n, 0.0);
        }
    }
}

/// The reduced system and what elimination keeps of the eliminated blocks, in shared
/// buffers laid out by the structure (`EBlock::{vbase, gbase, wbase}`).
#[derive(Clone, Debug, Default)]
pub(crate) struct Reduced {
    /// Lower blocks of S, row by row (see `Structure::rows`).
    pub vals: Vec<f64>,
    /// b = g_c − Σ Tₙ·gₑ.
    pub g: Vec<f64>,
    /// V⁻¹ of each eliminated block (dim × dim).
    pub vinv: Vec<f64>,
    /// Gradient Σ w·Jᵀr of each eliminated block.
    pub ge: Vec<f64>,
    /// Wₙ = Σ w·J_eᵀ·J_n per eliminated block and neighbour (dim × d_n).
    pub w: Vec<f64>,
    /// Each job's sums (kept to be reused).
    sums: Vec<Sums>,
}

/// A step: the reduced unknowns, and the eliminated blocks' (at their `gbase`).
pub(crate) struct Step {
    pub dc: Vec<f64>,
    pub de: Vec<f64>,
}

/// One eliminated block's part of the shared buffers.
struct EParts<'a> {
    vinv: &'a mut [f64],
    g: &'a mut [f64],
    w: &'a mut [f64],
}

/// Inverse of a small symmetric block into `out`; `false` when singular.
fn invert(v: &[f64], d: usize, out: &mut [f64]) -> bool {
    if d == 3 {
        let Some(m) = Matrix3::from_column_slice(v).try_inverse() else {
            return false;
        };
        out.copy_from_slice(m.as_slice());
        return true;
    }
    let Some(m) = DMatrix::from_column_slice(d, d, v).try_inverse() else {
        return false;
    };
    out.copy_from_slice(m.as_slice());
    true
}

/// S_ab −= Tₐ·W_b for every pair of an eliminated block of dimension `E` whose neighbours all
/// have dimension `N` (sizes known at compile time: no dispatch per pair).
fn subtract_pairs<const N: usize, const E: usize>(
    pairs: &[(usize, usize, usize)],
    woff: &[usize],
    t: &[f64],
    w: &[f64],
    vals: &mut [f64],
) {
    for &(ia, ib, off) in pairs {
        let ta = SMatrixView::<f64, N, E>::from_slice(&t[woff[ia]..woff[ia] + N * E]);
        let wb = SMatrixView::<f64, E, N>::from_slice(&w[woff[ib]..woff[ib] + E * N]);
        let o = &mut vals[off..off + N * N];
        if ia == ib {
            // A diagonal block: only its lower triangle is ever read.
            for j in 0..N {
                for i in j..N {
                    let mut s = 0.0;
                    for k in 0..E {
                        s += ta[(i, k)] * wb[(k, j)];
                    }
                    o[j * N + i] -= s;
                }
            }
        } else {
            let mut o = SMatrixViewMut::<f64, N, N>::from_slice(o);
            o -= ta * wb;
        }
    }
}

/// Factor `k`'s direct terms: Jₐᵀ·r, Jₐᵀ·J_b and the diagonal of Jₐᵀ·Jₐ.
fn add_direct(st: &Structure, lin: &Linearisation, k: usize, w: f64, sums: &mut Sums) {
    let d = st.direct[k];
    for g in &st.grads[d.grads.0..d.grads.1] {
        let ja = &lin.j[g.ja..g.ja + g.m * g.da];
        add_atv(
            w,
            ja,
            &lin.j[g.ro..g.ro + g.m],
            &mut sums.g[g.go..g.go + g.da],
        );
        for (i, col) in ja.chunks_exact(g.m).enumerate() {
            sums.diag[g.go + i] += w * col.iter().map(|x| x * x).sum::<f64>();
        }
    }
    for p in &st.pairs[d.pairs.0..d.pairs.1] {
        let (ja, jb) = (
            &lin.j[p.ja..p.ja + p.m * p.da],
            &lin.j[p.jb..p.jb + p.m * p.db],
        );
        add_atb(
            w,
            ja,
            jb,
            p.m,
            &mut sums.vals[p.off..p.off + p.da * p.db],
            p.da,
        );
    }
}

impl Model {
    /// Eliminate one block: its factors' direct terms into `sums`; V (damped by `lambda`),
    /// gₑ, W and V⁻¹ into `out`; Tₙ = Wₙᵀ·V⁻¹ into `t`. `false` when V is singular.
    #[allow(clippy::too_many_arguments)]
    fn eliminate_block(
        st: &Structure,
        eb: &EBlock,
        lin: &Linearisation,
        lambda: f64,
        robust: bool,
        out: &mut EParts<'_>,
        t: &mut Vec<f64>,
        sums: &mut Sums,
    ) -> bool {
        let d = eb.dim;
        let mut stack = [0.0; 81];
        let mut heap = Vec::new();
        let v: &mut [f64] = if d * d <= 81 {
            &mut stack[..d * d]
        } else {
            heap.resize(d * d, 0.0);
            &mut heap
        };
        out.g.fill(0.0);
        out.w.fill(0.0);
        let woff = st.woff(eb);
        for term in st.terms(eb) {
            let (jo, m) = (term.jo, term.m);
            let wt = if robust { lin.weight(st, term.f) } else { 1.0 };
            add_direct(st, lin, term.f, wt, sums);
            let jp = &lin.j[jo..jo + m * d];
            add_atb(wt, jp, jp, m, v, d);
            add_atv(wt, jp, &lin.j[term.ro..term.ro + m], out.g);
            for &(jc, dc, ni) in st.links(term) {
                let o = woff[ni];
                add_atb(
                    wt,
                    jp,
                    &lin.j[jc..jc + m * dc],
                    m,
                    &mut out.w[o..o + d * dc],
                    d,
                );
            }
        }
        if lambda > 0.0 {
            for i in 0..d {
                v[i * d + i] += damp(lambda, v[i * d + i]);
            }
        }
        if !invert(v, d, out.vinv) {
            return false;
        }
        t.clear();
        t.resize(eb.wlen, 0.0);
        for (&c, &o) in st.nbrs(eb).iter().zip(woff) {
            let dn = st.cdim[c];
            add_atb(
                1.0,
                &out.w[o..o + d * dn],
                out.vinv,
                d,
                &mut t[o..o + d * dn],
                dn,
            );
        }
        true
    }

    /// A range of eliminated blocks into `sums`. `false` when a block is singular.
    fn eliminate_range(
        st: &Structure,
        lin: &Linearisation,
        (lambda, robust): (f64, bool),
        range: std::ops::Range<usize>,
        all: EParts<'_>,
        sums: &mut Sums,
    ) -> bool {
        sums.zeroed(st);
        let mut t = Vec::new();
        let Some(first) = st.eblocks.get(range.start).copied() else {
            return true;
        };
        for eb in &st.eblocks[range] {
            let (v0, g0, w0) = (
                eb.vbase - first.vbase,
                eb.gbase - first.gbase,
                eb.wbase - first.wbase,
            );
            let d = eb.dim;
            let mut out = EParts {
                vinv: &mut all.vinv[v0..v0 + d * d],
                g: &mut all.g[g0..g0 + d],
                w: &mut all.w[w0..w0 + eb.wlen],
            };
            if !Self::eliminate_block(st, eb, lin, lambda, robust, &mut out, &mut t, sums) {
                return false;
            }
            let (nbrs, woff) = (st.nbrs(eb), st.woff(eb));
            let pairs = st.pairs(eb);
            let same = |k: usize| nbrs.iter().all(|&c| st.cdim[c] == k);
            match d {
                3 if same(9) => subtract_pairs::<9, 3>(pairs, woff, &t, out.w, &mut sums.vals),
                3 if same(6) => subtract_pairs::<6, 3>(pairs, woff, &t, out.w, &mut sums.vals),
                3 if same(3) => subtract_pairs::<3, 3>(pairs, woff, &t, out.w, &mut sums.vals),
                _ => {
                    for &(ia, ib, off) in pairs {
                        let (da, db) = (st.cdim[nbrs[ia]], st.cdim[nbrs[ib]]);
                        let ta = &t[woff[ia]..woff[ia] + da * d];
                        let wb = &out.w[woff[ib]..woff[ib] + d * db];
                        add_ab(-1.0, ta, wb, da, d, &mut sums.vals[off..off + da * db]);
                    }
                }
            }
            for (&a, &wo) in nbrs.iter().zip(woff) {
                let (da, o) = (st.cdim[a], st.coff[a]);
                add_av(-1.0, &t[wo..wo + da * d], out.g, &mut sums.g[o..o + da]);
            }
        }
        true
    }

    /// Build the reduced system at the linearisation `lin` with damping `lambda` (0: none)
    /// and the robust weights when `robust`. `false` when an eliminated block is singular.
    pub(crate) fn reduce(
        st: &Structure,
        lin: &Linearisation,
        lambda: f64,
        robust: bool,
        red: &mut Reduced,
    ) -> bool {
        let z = st.esizes;
        for (buf, n) in [(&mut red.vinv, z.v), (&mut red.ge, z.g), (&mut red.w, z.w)] {
            buf.resize(n, 0.0);
        }
        // Each range's part of the shared buffers (consecutive blocks, consecutive data).
        let eb = &st.eblocks;
        let base = |r: &std::ops::Range<usize>, f: fn(&EBlock) -> usize, len: usize| {
            let at = |i: usize| eb.get(i).map_or(len, f);
            at(r.end) - at(r.start)
        };
        let vl: Vec<usize> = st
            .chunks
            .iter()
            .map(|r| base(r, |e| e.vbase, z.v))
            .collect();
        let gl: Vec<usize> = st
            .chunks
            .iter()
            .map(|r| base(r, |e| e.gbase, z.g))
            .collect();
        let wl: Vec<usize> = st
            .chunks
            .iter()
            .map(|r| base(r, |e| e.wbase, z.w))
            .collect();
        let mut parts = pieces(&mut red.vinv, vl.into_iter())
            .into_iter()
            .zip(pieces(&mut red.ge, gl.into_iter()))
            .zip(pieces(&mut red.w, wl.into_iter()));
        red.sums.resize_with(st.chunks.len() + 1, Sums::default);
        let (tail_sums, range_sums) = red.sums.split_last_mut().expect("one job at least");
        let jobs: Vec<_> = st
            .chunks
            .iter()
            .zip(range_sums.iter_mut())
            .map(|(r, sums)| {
                let ((vinv, g), w) = parts.next().expect("one part per range");
                (r.clone(), EParts { vinv, g, w }, sums)
            })
            .collect();
        let (ok, ()) = rayon::join(
            || {
                jobs.into_par_iter()
                    .map(|(range, all, sums)| {
                        Self::eliminate_range(st, lin, (lambda, robust), range, all, sums)
                    })
                    .collect::<Vec<bool>>()
            },
            || {
                if st.tail.is_empty() {
                    return;
                }
                tail_sums.zeroed(st);
                for &k in &st.tail {
                    let w = if robust { lin.weight(st, k) } else { 1.0 };
                    add_direct(st, lin, k, w, tail_sums);
                }
            },
        );
        if ok.iter().any(|x| !x) {
            return false;
        }
        Self::sum_jobs(st, lambda, red);
        true
    }

    /// S and b as the sum of the jobs' copies (the factors without eliminated blocks first,
    /// then the ranges in order), damped.
    fn sum_jobs(st: &Structure, lambda: f64, red: &mut Reduced) {
        let tail = (!st.tail.is_empty()).then_some(red.sums.len() - 1);
        let order: Vec<usize> = tail.into_iter().chain(0..red.sums.len() - 1).collect();
        red.vals.clear();
        red.vals.resize(st.nvals, 0.0);
        red.g.clear();
        red.g.resize(st.nr, 0.0);
        let mut diag = vec![0.0; st.nr];
        for &j in &order {
            let s = &red.sums[j];
            red.vals.iter_mut().zip(&s.vals).for_each(|(x, y)| *x += y);
            red.g.iter_mut().zip(&s.g).for_each(|(x, y)| *x += y);
            diag.iter_mut().zip(&s.diag).for_each(|(x, y)| *x += y);
        }
        if lambda > 0.0 {
            for (a, row) in st.rows.iter().enumerate() {
                let (da, o) = (st.cdim[a], st.coff[a]);
                for i in 0..da {
                    red.vals[row.start + row.diag + i * da + i] += damp(lambda, diag[o + i]);
                }
            }
        }
    }

    /// The eliminated blocks' steps from the reduced one: δe = V⁻¹·(−gₑ − Σ Wₙ·δcₙ), in runs
    /// of blocks (one task each).
    pub(crate) fn back_substitute(st: &Structure, red: &Reduced, dc: Vec<f64>) -> Step {
        let mut de = vec![0.0; st.esizes.g];
        let eb = &st.eblocks;
        let runs: Vec<(usize, usize)> = (0..eb.len())
            .step_by(MIN_LEN)
            .map(|a| (a, (a + MIN_LEN).min(eb.len())))
            .collect();
        let lens = runs.iter().map(|&(a, b)| {
            let end = eb.get(b).map_or(st.esizes.g, |e| e.gbase);
            end - eb[a].gbase
        });
        let outs = pieces(&mut de, lens);
        runs.into_par_iter().zip(outs).for_each(|((a, b), out)| {
            let g0 = eb[a].gbase;
            for e in &eb[a..b] {
                let d = e.dim;
                let mut rhs = [0.0; 16];
                let rhs = &mut rhs[..d];
                for (x, g) in rhs.iter_mut().zip(&red.ge[e.gbase..e.gbase + d]) {
                    *x = -g;
                }
                for (&c, &wo) in st.nbrs(e).iter().zip(st.woff(e)) {
                    let (dn, o) = (st.cdim[c], e.wbase + wo);
                    add_av(
                        -1.0,
                        &red.w[o..o + d * dn],
                        &dc[st.coff[c]..st.coff[c] + dn],
                        rhs,
                    );
                }
                let o = e.gbase - g0;
                add_av(
                    1.0,
                    &red.vinv[e.vbase..e.vbase + d * d],
                    rhs,
                    &mut out[o..o + d],
                );
            }
        });
        Step { dc, de }
    }

    /// The values after a step, written into `out` (its vectors reused).
    pub(crate) fn apply_into(&self, st: &Structure, step: &Step, out: &mut Vec<Value>) {
        if out.len() != self.values.len() {
            *out = self.values.clone();
        } else {
            for (o, v) in out.iter_mut().zip(&self.values) {
                o.assign(v);
            }
        }
        for (i, &b) in st.cblocks.iter().enumerate() {
            out[b].plus(&step.dc[st.coff[i]..st.coff[i] + st.cdim[i]]);
        }
        for eb in &st.eblocks {
            out[eb.block].plus(&step.de[eb.gbase..eb.gbase + eb.dim]);
        }
    }

    /// The cost decrease the linear model predicts for a step: −Σ w·(Jδ)ᵀr − ½Σ w·‖Jδ‖², summed
    /// in runs of factors, then the runs in order.
    pub(crate) fn model_decrease(st: &Structure, lin: &Linearisation, step: &Step) -> f64 {
        let n = st.slots.len();
        let parts: Vec<f64> = (0..n.div_ceil(MIN_LEN))
            .into_par_iter()
            .map(|c| {
                (c * MIN_LEN..((c + 1) * MIN_LEN).min(n))
                    .map(|k| Self::factor_decrease(st, lin, step, k))
                    .sum()
            })
            .collect();
        parts.iter().sum()
    }

    /// One factor's part of the model decrease.
    fn factor_decrease(st: &Structure, lin: &Linearisation, step: &Step, k: usize) -> f64 {
        let r = lin.res(st, k);
        let (mut stack, mut heap) = ([0.0; 16], Vec::new());
        let jd: &mut [f64] = if r.len() <= 16 {
            &mut stack[..r.len()]
        } else {
            heap.resize(r.len(), 0.0);
            &mut heap
        };
        for s in st.slots.get(k) {
            let Some(j) = lin.jac(st, k, s) else { continue };
            let d = match (s.c, s.e) {
                (Some(c), _) => &step.dc[st.coff[c]..st.coff[c] + s.dim],
                (_, Some(e)) => {
                    let g = st.eblocks[e].gbase;
                    &step.de[g..g + s.dim]
                }
                _ => continue,
            };
            add_av(1.0, j, d, jd);
        }
        let jr: f64 = jd.iter().zip(r).map(|(a, b)| a * b).sum();
        let jj: f64 = jd.iter().map(|a| a * a).sum();
        -lin.weight(st, k) * (jr + 0.5 * jj)
    }
}

/// The lower triangle of the reduced matrix as triplets (in a fixed order).
pub(crate) fn triplets(st: &Structure, red: &Reduced) -> Vec<Triplet<usize, usize, f64>> {
    let mut t = Vec::with_capacity(red.vals.len());
    for_each_block(st, red, |r0, c0, dr, dc, b| {
        for j in 0..dc {
            for i in 0..dr {
                if r0 + i >= c0 + j {
                    t.push(Triplet {
                        row: r0 + i,
                        col: c0 + j,
                        val: b[j * dr + i],
                    });
                }
            }
        }
    });
    t
}

/// Call `f(row offset, column offset, rows, columns, block)` for every stored block.
pub(super) fn for_each_block(
    st: &Structure,
    red: &Reduced,
    mut f: impl FnMut(usize, usize, usize, usize, &[f64]),
) {
    for (a, row) in st.rows.iter().enumerate() {
        let da = st.cdim[a];
        for &(off, b) in &row.entries {
            let db = st.cdim[b];
            let o = row.start + off;
            f(st.coff[a], st.coff[b], da, db, &red.vals[o..o + da * db]);
        }
    }
}
