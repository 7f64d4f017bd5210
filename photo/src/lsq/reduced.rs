//! One damped Gauss–Newton step through the Schur complement: per eliminated block its
//! normal block V (damped), gradient and couplings W (in parallel); per block row of the
//! reduced system its blocks and gradient (in parallel, each row summing its terms in a fixed
//! order); the reduced solve; back-substitution of the eliminated blocks; and the decrease of
//! the linear model that the step promises.

use super::lin::{add_ab, add_atb, add_atv, add_av, pieces, Linearisation};
use super::problem::Problem;
use super::structure::{EBlock, Structure};
use super::value::Value;
use nalgebra::{DMatrix, Matrix3, SMatrixView, SMatrixViewMut};
use rayon::prelude::*;

/// Levenberg–Marquardt damping of a diagonal element: λ·clamp(d, 1e-6, 1e32) (as Ceres).
fn damp(lambda: f64, d: f64) -> f64 {
    lambda * d.clamp(1e-6, 1e32)
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
    /// Per range of eliminated blocks: its sums of S and b (kept to be reused).
    sums: Vec<(Vec<f64>, Vec<f64>)>,
}

/// A step: reduced unknowns and each eliminated block's.
pub(crate) struct Step {
    pub dc: Vec<f64>,
    pub de: Vec<Vec<f64>>,
}

/// One eliminated block's part of the shared buffers, and room for its Tₙ = Wₙᵀ·V⁻¹
/// (d_n × dim, at the same offsets as Wₙ).
struct EParts<'a> {
    vinv: &'a mut [f64],
    g: &'a mut [f64],
    w: &'a mut [f64],
    t: &'a mut Vec<f64>,
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
        let mut o = SMatrixViewMut::<f64, N, N>::from_slice(&mut vals[off..off + N * N]);
        o -= ta * wb;
    }
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

impl Problem {
    /// Eliminate one block: V (damped by `lambda`), g, W, V⁻¹ and T.
    fn eliminate_block(
        st: &Structure,
        eb: &EBlock,
        lin: &Linearisation,
        lambda: f64,
        robust: bool,
        out: &mut EParts<'_>,
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
        let EParts { vinv, g, w, t } = out;
        let woff = st.woff(eb);
        for term in st.terms(eb) {
            let (jo, m) = (term.jo, term.m);
            let wt = if robust { lin.weight(st, term.f) } else { 1.0 };
            let jp = &lin.j[jo..jo + m * d];
            add_atb(wt, jp, jp, m, v, d);
            add_atv(wt, jp, &lin.j[term.ro..term.ro + m], g);
            for &(jc, dc, ni) in st.links(term) {
                let o = woff[ni];
                add_atb(wt, jp, &lin.j[jc..jc + m * dc], m, &mut w[o..o + d * dc], d);
            }
        }
        if lambda > 0.0 {
            for i in 0..d {
                v[i * d + i] += damp(lambda, v[i * d + i]);
            }
        }
        if !invert(v, d, vinv) {
            return false;
        }
        t.clear();
        t.resize(eb.wlen, 0.0);
        for (&c, &o) in st.nbrs(eb).iter().zip(woff) {
            let dn = st.cdim[c];
            add_atb(1.0, &w[o..o + d * dn], vinv, d, &mut t[o..o + d * dn], dn);
        }
        true
    }

    /// Build the reduced system at the linearisation `lins` with damping `lambda` (0: none)
    /// and the robust weights when `robust`. `false` when an eliminated block is singular.
    pub(crate) fn reduce(
        &self,
        st: &Structure,
        lin: &Linearisation,
        lambda: f64,
        robust: bool,
        red: &mut Reduced,
    ) -> bool {
        red.vals.clear();
        red.vals.resize(st.nvals, 0.0);
        red.g.clear();
        red.g.resize(st.nr, 0.0);
        // Direct terms: each row owns its blocks and its part of the gradient.
        let vals = pieces(&mut red.vals, st.rows.iter().map(|r| r.len));
        let gs = pieces(&mut red.g, st.cdim.iter().copied());
        vals.into_par_iter()
            .zip(gs)
            .enumerate()
            .for_each(|(a, (vals, g))| Self::assemble_row(st, a, lin, lambda, robust, vals, g));
        // Eliminated blocks: each range into its own copy, the copies added in order.
        let z = st.esizes;
        for (buf, n) in [(&mut red.vinv, z.v), (&mut red.ge, z.g), (&mut red.w, z.w)] {
            buf.resize(n, 0.0);
        }
        let eb = &st.eblocks;
        let mut parts = pieces(&mut red.vinv, eb.iter().map(|e| e.dim * e.dim))
            .into_iter()
            .zip(pieces(&mut red.ge, eb.iter().map(|e| e.dim)))
            .zip(pieces(&mut red.w, eb.iter().map(|e| e.wlen)));
        red.sums.resize_with(st.chunks.len(), Default::default);
        let jobs: Vec<_> = st
            .chunks
            .iter()
            .zip(red.sums.iter_mut())
            .map(|(r, sum)| {
                let p = parts.by_ref().take(r.len()).collect::<Vec<_>>();
                (r.clone(), p, sum)
            })
            .collect();
        let ok: Vec<bool> = jobs
            .into_par_iter()
            .map(|(range, parts, sum)| {
                Self::eliminate_range(st, lin, lambda, robust, range, parts, sum)
            })
            .collect();
        if ok.iter().any(|x| !x) {
            return false;
        }
        for (vals, g) in &red.sums {
            red.vals.iter_mut().zip(vals).for_each(|(x, y)| *x += y);
            red.g.iter_mut().zip(g).for_each(|(x, y)| *x += y);
        }
        true
    }

    /// Eliminate a range of blocks; their −Tₐ·W_b and −Tₐ·gₑ summed into `sum` (a copy of
    /// the reduced system). `false` when a block is singular.
    #[allow(clippy::type_complexity)]
    fn eliminate_range(
        st: &Structure,
        lin: &Linearisation,
        lambda: f64,
        robust: bool,
        range: std::ops::Range<usize>,
        parts: Vec<((&mut [f64], &mut [f64]), &mut [f64])>,
        sum: &mut (Vec<f64>, Vec<f64>),
    ) -> bool {
        let (vals, g) = sum;
        for (buf, n) in [(&mut *vals, st.nvals), (&mut *g, st.nr)] {
            buf.clear();
            buf.resize(n, 0.0);
        }
        let mut t = Vec::new();
        for (eb, ((vinv, ge), w)) in st.eblocks[range].iter().zip(parts) {
            let mut out = EParts {
                vinv,
                g: ge,
                w,
                t: &mut t,
            };
            if !Self::eliminate_block(st, eb, lin, lambda, robust, &mut out) {
                return false;
            }
            let (d, t, w, ge) = (eb.dim, &*out.t, &*out.w, &*out.g);
            let (nbrs, woff) = (st.nbrs(eb), st.woff(eb));
            let pairs = st.pairs(eb);
            let same = |k: usize| nbrs.iter().all(|&c| st.cdim[c] == k);
            match d {
                3 if same(9) => subtract_pairs::<9, 3>(pairs, woff, t, w, vals),
                3 if same(6) => subtract_pairs::<6, 3>(pairs, woff, t, w, vals),
                3 if same(3) => subtract_pairs::<3, 3>(pairs, woff, t, w, vals),
                _ => {
                    for &(ia, ib, off) in pairs {
                        let (da, db) = (st.cdim[nbrs[ia]], st.cdim[nbrs[ib]]);
                        let ta = &t[woff[ia]..woff[ia] + da * d];
                        let wb = &w[woff[ib]..woff[ib] + d * db];
                        add_ab(-1.0, ta, wb, da, d, &mut vals[off..off + da * db]);
                    }
                }
            }
            for (&a, &wo) in nbrs.iter().zip(woff) {
                let (da, o) = (st.cdim[a], st.coff[a]);
                add_av(-1.0, &t[wo..wo + da * d], ge, &mut g[o..o + da]);
            }
        }
        true
    }

    /// One block row of S and its part of b.
    fn assemble_row(
        st: &Structure,
        a: usize,
        lin: &Linearisation,
        lambda: f64,
        robust: bool,
        vals: &mut [f64],
        g: &mut [f64],
    ) {
        let row = &st.rows[a];
        let da = st.cdim[a];
        for &(f, ja, jb, m, db, off) in &row.pairs {
            let w = if robust { lin.weight(st, f) } else { 1.0 };
            let (ja, jb) = (&lin.j[ja..ja + m * da], &lin.j[jb..jb + m * db]);
            add_atb(w, ja, jb, m, &mut vals[off..off + da * db], da);
        }
        for &(f, ja, ro, m) in &row.grad {
            let w = if robust { lin.weight(st, f) } else { 1.0 };
            add_atv(w, &lin.j[ja..ja + m * da], &lin.j[ro..ro + m], g);
        }
        if lambda > 0.0 {
            for i in 0..da {
                let k = row.diag + i * da + i;
                vals[k] += damp(lambda, vals[k]);
            }
        }
    }

    /// The eliminated blocks' steps from the reduced one: δe = V⁻¹·(−gₑ − Σ Wₙ·δcₙ).
    pub(crate) fn back_substitute(st: &Structure, red: &Reduced, dc: Vec<f64>) -> Step {
        let de = st
            .eblocks
            .par_iter()
            .map(|eb| {
                let d = eb.dim;
                let mut rhs: Vec<f64> = red.ge[eb.gbase..eb.gbase + d].iter().map(|x| -x).collect();
                for (&c, &wo) in st.nbrs(eb).iter().zip(st.woff(eb)) {
                    let (dn, o) = (st.cdim[c], eb.wbase + wo);
                    let w = &red.w[o..o + d * dn];
                    add_av(-1.0, w, &dc[st.coff[c]..st.coff[c] + dn], &mut rhs);
                }
                let mut out = vec![0.0; d];
                add_av(1.0, &red.vinv[eb.vbase..eb.vbase + d * d], &rhs, &mut out);
                out
            })
            .collect();
        Step { dc, de }
    }

    /// The values after a step.
    pub(crate) fn apply(&self, st: &Structure, step: &Step) -> Vec<Value> {
        let mut v = self.values.clone();
        for (i, &b) in st.cblocks.iter().enumerate() {
            v[b].plus(&step.dc[st.coff[i]..st.coff[i] + st.cdim[i]]);
        }
        for (eb, d) in st.eblocks.iter().zip(&step.de) {
            v[eb.block].plus(d);
        }
        v
    }

    /// The cost decrease the linear model predicts for a step: −Σ w·(Jδ)ᵀr − ½Σ w·‖Jδ‖².
    pub(crate) fn model_decrease(st: &Structure, lin: &Linearisation, step: &Step) -> f64 {
        let parts: Vec<f64> = st
            .slots
            .par_iter()
            .enumerate()
            .map(|(k, slots)| {
                let r = lin.res(st, k);
                let (mut stack, mut heap) = ([0.0; 16], Vec::new());
                let jd: &mut [f64] = if r.len() <= 16 {
                    &mut stack[..r.len()]
                } else {
                    heap.resize(r.len(), 0.0);
                    &mut heap
                };
                for s in slots {
                    let Some(j) = lin.jac(st, k, s) else { continue };
                    let d = match (s.c, s.e) {
                        (Some(c), _) => &step.dc[st.coff[c]..st.coff[c] + s.dim],
                        (_, Some(e)) => &step.de[e][..],
                        _ => continue,
                    };
                    add_av(1.0, j, d, jd);
                }
                let jr: f64 = jd.iter().zip(r).map(|(a, b)| a * b).sum();
                let jj: f64 = jd.iter().map(|a| a * a).sum();
                -lin.weight(st, k) * (jr + 0.5 * jj)
            })
            .collect();
        parts.iter().sum()
    }
}
