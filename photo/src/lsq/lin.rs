//! Evaluating factors: whitened residuals and Jacobians of every active factor (in
//! parallel, into buffers kept between steps), the cost, and the small column-major
//! products the reduced system is built from.

use super::error::SolveError;
use super::factor::FactorId;
use super::factor::{Noise, Params};
use super::model::{Entry, Model, MAX_FACTOR_KEYS};
use super::slots::Slot;
use super::structure::Structure;
use super::value::Value;
use nalgebra::{DMatrixViewMut, SMatrixView, SMatrixViewMut};
use rayon::prelude::*;

/// Every active factor linearised, in one buffer laid out by the structure: per factor its
/// whitened residual, then its whitened Jacobian blocks (column-major, at the slots'
/// offsets); and the robust weight ρ′ at each residual.
#[derive(Clone, Debug, Default)]
pub(crate) struct Linearisation {
    pub j: Vec<f64>,
    pub w: Vec<f64>,
    /// (weight, cost, squares) per factor in buffer order (NaN weight: not evaluable).
    scratch: Vec<[f64; 3]>,
}

impl Linearisation {
    /// The residual of active factor `k`.
    pub fn res<'a>(&'a self, st: &Structure, k: usize) -> &'a [f64] {
        &self.j[st.base[k]..st.base[k] + st.m[k]]
    }

    /// The Jacobian block of slot `s` of active factor `k`.
    pub fn jac<'a>(&'a self, st: &Structure, k: usize, s: &Slot) -> Option<&'a [f64]> {
        s.joff.map(|o| &self.j[o..o + st.m[k] * s.dim])
    }

    /// The robust weight of active factor `k` (1 when no factor is robust).
    pub fn weight(&self, st: &Structure, k: usize) -> f64 {
        if st.robust {
            self.w[k]
        } else {
            1.0
        }
    }
}

/// Fewest items a parallel task takes (factors or blocks are too small to be tasks alone).
pub(crate) const MIN_LEN: usize = 256;

/// Cost ½Σρ and plain sum of squared whitened residuals.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Cost {
    pub cost: f64,
    pub squares: f64,
}

/// Evaluate one factor at `values`, whitened by its noise and group; the Jacobian blocks go to
/// `j` (the factor's part of the buffer, blocks in slot order) when asked.
fn evaluate(
    e: &Entry,
    scale: f64,
    values: &[Value],
    slots: &[Slot],
    r: &mut [f64],
    j: Option<&mut [f64]>,
) -> bool {
    let m = r.len();
    let x = Params::new(values, &e.blocks);
    let mut views: [Option<DMatrixViewMut<f64>>; MAX_FACTOR_KEYS] = Default::default();
    let n = e.blocks.len();
    let ok = match j {
        Some(j) => {
            let mut rest: &mut [f64] = j;
            for (k, s) in slots.iter().enumerate() {
                if s.joff.is_some() {
                    let (a, b) = rest.split_at_mut(m * s.dim);
                    views[k] = Some(DMatrixViewMut::from_slice(a, m, s.dim));
                    rest = b;
                }
            }
            let ok = e.factor.evaluate(&x, r, &mut views[..n]);
            if ok && !(scale == 1.0 && e.noise == Noise::Unit) {
                e.noise.whiten(scale, r, j);
            }
            ok
        }
        None => {
            let ok = e.factor.evaluate(&x, r, &mut views[..n]);
            if ok && !(scale == 1.0 && e.noise == Noise::Unit) {
                e.noise.whiten(scale, r, &mut []);
            }
            ok
        }
    };
    ok && r.iter().all(|v| v.is_finite())
}

/// Split `buf` into consecutive pieces of the given lengths.
pub(crate) fn pieces(mut buf: &mut [f64], lens: impl Iterator<Item = usize>) -> Vec<&mut [f64]> {
    lens.map(|n| {
        let (a, b) = std::mem::take(&mut buf).split_at_mut(n);
        buf = b;
        a
    })
    .collect()
}

impl Model {
    /// Linearise every active factor at `values` into `lin` (buffers reused): runs of factors
    /// in buffer order, one task each, so every task writes one stretch of memory.
    pub(crate) fn linearise(
        &self,
        st: &Structure,
        values: &[Value],
        lin: &mut Linearisation,
    ) -> Result<Cost, SolveError> {
        lin.j.resize(st.nbuf, 0.0);
        lin.w.resize(st.active.len(), 1.0);
        lin.scratch.resize(st.active.len(), [0.0; 3]);
        let mut jobs = Vec::with_capacity(st.lin_groups.len());
        let (mut buf, mut scratch): (&mut [f64], &mut [[f64; 3]]) = (&mut lin.j, &mut lin.scratch);
        for &(a, b, start, end) in &st.lin_groups {
            let (jb, rest) = std::mem::take(&mut buf).split_at_mut(end - start);
            let (sb, srest) = std::mem::take(&mut scratch).split_at_mut(b - a);
            (buf, scratch) = (rest, srest);
            jobs.push((a, start, jb, sb));
        }
        jobs.into_par_iter().for_each(|(a, start, jb, sb)| {
            for (i, out) in sb.iter_mut().enumerate() {
                let k = st.order[a + i];
                let e = &self.entries[st.active[k]];
                let scale = self.group_scale[e.group.0];
                let slots = st.slots.get(k);
                let region = &mut jb[st.base[k] - start..];
                let (r, j) = region.split_at_mut(st.m[k]);
                let len = slots
                    .iter()
                    .filter(|s| s.joff.is_some())
                    .map(|s| s.dim)
                    .sum::<usize>();
                *out = if evaluate(e, scale, values, slots, r, Some(&mut j[..st.m[k] * len])) {
                    let s2: f64 = r.iter().map(|x| x * x).sum();
                    [e.loss.weight(s2.sqrt()), e.loss.cost(s2), s2]
                } else {
                    [f64::NAN; 3]
                };
            }
        });
        let mut c = Cost::default();
        for k in 0..st.active.len() {
            let [w, cost, s2] = lin.scratch[st.pos[k]];
            if w.is_nan() {
                return Err(SolveError::Evaluation(FactorId(st.active[k])));
            }
            lin.w[k] = w;
            c.cost += cost;
            c.squares += s2;
        }
        Ok(c)
    }
}

impl Model {
    /// The diagonal block of the normals of free block `b` from its own active factors at
    /// the current values (whitened, without robust weights): what
    /// [`Model::undetermined_blocks`] tests for every block, here for one block from the
    /// factors that touch it alone (data snooping asks after each removal, where linearising
    /// the whole problem each time cost 30 s of a 40 s adjustment), with how many factors
    /// those are.
    pub(crate) fn block_normals(
        &self,
        b: usize,
    ) -> Result<(nalgebra::DMatrix<f64>, usize), SolveError> {
        let dim = self.values[b].dim();
        let mut n = nalgebra::DMatrix::<f64>::zeros(dim, dim);
        let mut count = 0;
        for (i, e) in self.entries.iter().enumerate() {
            if !e.removed && e.blocks.contains(&b) {
                self.add_factor_normals(i, b, &mut n)?;
                count += 1;
            }
        }
        Ok((n, count))
    }

    /// Add factor `i`'s part of block `b`'s normals to `n` (`b` must be one of its blocks,
    /// free; whether the factor is removed is not asked).
    pub(crate) fn add_factor_normals(
        &self,
        i: usize,
        b: usize,
        n: &mut nalgebra::DMatrix<f64>,
    ) -> Result<(), SolveError> {
        let e = &self.entries[i];
        let (m, dim) = (e.factor.dim(), self.values[b].dim());
        let mut slots = Vec::with_capacity(e.blocks.len());
        let (mut len, mut at) = (0, 0);
        for &x in &e.blocks {
            let d = self.values[x].dim();
            let joff = (!self.fixed[x]).then_some(len);
            if x == b {
                at = len;
            }
            if joff.is_some() {
                len += m * d;
            }
            slots.push(Slot {
                dim: d,
                joff,
                c: None,
                e: None,
            });
        }
        let (mut r, mut j) = (vec![0.0; m], vec![0.0; len]);
        let scale = self.group_scale[e.group.0];
        if !evaluate(e, scale, &self.values, &slots, &mut r, Some(&mut j)) {
            return Err(SolveError::Evaluation(FactorId(i)));
        }
        let jb = &j[at..at + m * dim];
        add_atb(1.0, jb, jb, m, n.as_mut_slice(), dim);
        Ok(())
    }
}

/// Whether a diagonal block of the normals is regular, independently of the units of its
/// parameters (radians and metres, pixels and metres): the block is scaled by its diagonal
/// (Jacobi, D^-1/2·M·D^-1/2, a correlation-like matrix of eigenvalues in [0, dim]) before its
/// eigenvalues are compared. A parameter with no weight at all is undetermined.
pub(crate) fn regular(m: nalgebra::DMatrix<f64>) -> bool {
    let d: Vec<f64> = m.diagonal().iter().copied().collect();
    if d.iter().any(|&x| !(x.is_finite() && x > 0.0)) {
        return false;
    }
    let s = nalgebra::DMatrix::from_fn(m.nrows(), m.ncols(), |i, j| {
        m[(i, j)] / (d[i] * d[j]).sqrt()
    });
    let e = s.symmetric_eigenvalues();
    e.min() > 1e-10 * e.max().max(1.0)
}

/// out (p×q) += w·Aᵀ·B for A (m×p) and B (m×q), all column-major. Common block sizes
/// run through code with every size known at compile time (unrolled, in registers).
pub(crate) fn add_atb(w: f64, a: &[f64], b: &[f64], m: usize, out: &mut [f64], p: usize) {
    let q = b.len() / m.max(1);
    macro_rules! fixed {
        ($(($m:literal, $p:literal, $q:literal)),*) => {
            match (m, p, q) {
                $(($m, $p, $q) => return add_atb_n::<$m, $p, $q>(w, a, b, out),)*
                _ => {}
            }
        };
    }
    fixed!(
        (1, 3, 3),
        (1, 3, 6),
        (1, 3, 9),
        (1, 6, 3),
        (1, 6, 6),
        (1, 6, 9),
        (1, 9, 3),
        (1, 9, 6),
        (1, 9, 9),
        (2, 3, 3),
        (2, 3, 6),
        (2, 3, 9),
        (2, 6, 3),
        (2, 6, 6),
        (2, 6, 9),
        (2, 9, 3),
        (2, 9, 6),
        (2, 9, 9),
        (3, 3, 3),
        (3, 3, 6),
        (3, 3, 9),
        (3, 6, 3),
        (3, 6, 6),
        (3, 6, 9),
        (3, 9, 3),
        (3, 9, 6),
        (3, 9, 9)
    );
    for j in 0..q {
        let bj = &b[j * m..(j + 1) * m];
        for i in 0..p {
            let ai = &a[i * m..(i + 1) * m];
            let s: f64 = ai.iter().zip(bj).map(|(x, y)| x * y).sum();
            out[j * p + i] += w * s;
        }
    }
}

/// [`add_atb`] with every size known at compile time.
fn add_atb_n<const M: usize, const P: usize, const Q: usize>(
    w: f64,
    a: &[f64],
    b: &[f64],
    out: &mut [f64],
) {
    let a: &[f64] = &a[..M * P];
    let b: &[f64] = &b[..M * Q];
    let out: &mut [f64] = &mut out[..P * Q];
    for j in 0..Q {
        let mut bj = [0.0; M];
        bj.copy_from_slice(&b[j * M..j * M + M]);
        for i in 0..P {
            let mut s = 0.0;
            for k in 0..M {
                s += a[i * M + k] * bj[k];
            }
            out[j * P + i] += w * s;
        }
    }
}

/// out (p) += w·Aᵀ·v for A (m×p).
pub(crate) fn add_atv(w: f64, a: &[f64], v: &[f64], out: &mut [f64]) {
    let m = v.len();
    for (i, o) in out.iter_mut().enumerate() {
        let s: f64 = a[i * m..(i + 1) * m]
            .iter()
            .zip(v)
            .map(|(x, y)| x * y)
            .sum();
        *o += w * s;
    }
}

/// out (p×q) += s·A·B for A (p×k) and B (k×q); common sizes unrolled as in [`add_atb`].
pub(crate) fn add_ab(s: f64, a: &[f64], b: &[f64], p: usize, k: usize, out: &mut [f64]) {
    let q = b.len() / k.max(1);
    macro_rules! fixed {
        ($(($p:literal, $k:literal, $q:literal)),*) => {
            match (p, k, q) {
                $(($p, $k, $q) => return add_ab_n::<$p, $k, $q>(s, a, b, out),)*
                _ => {}
            }
        };
    }
    fixed!(
        (3, 3, 3),
        (3, 3, 6),
        (3, 3, 9),
        (6, 3, 3),
        (6, 3, 6),
        (6, 3, 9),
        (9, 3, 3),
        (9, 3, 6),
        (9, 3, 9)
    );
    for j in 0..q {
        for l in 0..k {
            let blj = s * b[j * k + l];
            let al = &a[l * p..(l + 1) * p];
            for (o, x) in out[j * p..(j + 1) * p].iter_mut().zip(al) {
                *o += x * blj;
            }
        }
    }
}

/// [`add_ab`] with every size known at compile time.
fn add_ab_n<const P: usize, const K: usize, const Q: usize>(
    s: f64,
    a: &[f64],
    b: &[f64],
    out: &mut [f64],
) {
    let am = SMatrixView::<f64, P, K>::from_slice(&a[..P * K]);
    let bm = SMatrixView::<f64, K, Q>::from_slice(&b[..K * Q]);
    let mut om = SMatrixViewMut::<f64, P, Q>::from_slice(&mut out[..P * Q]);
    om += (am * bm) * s;
}

/// out (p) += s·A·v for A (p×k).
pub(crate) fn add_av(s: f64, a: &[f64], v: &[f64], out: &mut [f64]) {
    let p = out.len();
    for (l, vl) in v.iter().enumerate() {
        let x = s * vl;
        for (o, al) in out.iter_mut().zip(&a[l * p..(l + 1) * p]) {
            *o += al * x;
        }
    }
}
