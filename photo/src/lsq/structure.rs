//! The shape of the normal equations for the current fixed blocks, removed factors and
//! eliminated kinds: which factors are active, where each Jacobian block lives, which blocks
//! the Schur complement eliminates, and the block pattern of the reduced system with, per
//! block row, every term that adds to it. Built once per shape and reused by every step, so a
//! step only does arithmetic.
//!
//! Reduced system: with the eliminated blocks e and the others c, S = U − Σₑ Wₑᵀ·Vₑ⁻¹·Wₑ and
//! b = g_c − Σₑ Wₑᵀ·Vₑ⁻¹·gₑ. S is kept as the lower blocks (row ≥ column) of the c blocks;
//! each row is assembled by its own task, summing its terms in a fixed order (factors in
//! order, then eliminated blocks in order), so the result does not depend on the threads.

use super::elim::{chunks, gather, EBlock, ESizes, ETerm};
use super::key::KeyKind;
use super::model::Model;
use super::pattern::{direct_terms, rows, Direct, Grad, Pair, Row};
pub(crate) use super::slots::{Slot, Slots};
use std::hash::{Hash, Hasher};

/// The structure of the normal equations.
pub(crate) struct Structure {
    pub hash: u64,
    /// Active factors (entry indices).
    pub active: Vec<usize>,
    pub slots: Slots,
    /// Residual dimension of each active factor, and where its region (residual, then its
    /// Jacobian blocks) starts in the linearisation buffer.
    pub m: Vec<usize>,
    pub base: Vec<usize>,
    /// Where each active factor is in `order`.
    pub pos: Vec<usize>,
    /// Consecutive runs of `order` linearised by one task each: (first, end) positions in
    /// `order` and the buffer range of their regions.
    pub lin_groups: Vec<(usize, usize, usize, usize)>,
    /// Active factors in buffer order: grouped by the first eliminated block they touch, so
    /// that eliminating a block reads one stretch of memory.
    pub order: Vec<usize>,
    /// Residual components in all, and the buffer length.
    pub nres: usize,
    pub nbuf: usize,
    /// Whether any active factor has a robust loss (else every weight is 1).
    pub robust: bool,
    /// Free unknowns in all.
    pub n: usize,
    /// Reduced blocks (block indices), their offsets and dimensions; nr unknowns in all.
    pub cblocks: Vec<usize>,
    pub coff: Vec<usize>,
    pub cdim: Vec<usize>,
    pub nr: usize,
    pub eblocks: Vec<EBlock>,
    /// Factors touching each eliminated block, in factor order.
    pub eterms: Vec<ETerm>,
    /// Per term: (Jacobian offset of a reduced block in that factor, its dim, index of the
    /// block among the eliminated block's neighbours).
    pub elinks: Vec<(usize, usize, usize)>,
    /// Neighbours (reduced block indices) and the offsets of Wₑ,ₙ (dim × d_n) from `wbase`.
    pub enbrs: Vec<usize>,
    pub ewoff: Vec<usize>,
    /// (neighbour a, neighbour b ≤ a, offset of the block (a, b) in the reduced value
    /// buffer): where −Tₐ·W_b goes.
    pub epairs: Vec<(usize, usize, usize)>,
    pub esizes: ESizes,
    /// Consecutive ranges of eliminated blocks, each summed into its own copy of the reduced
    /// system (in parallel) before the copies are added in order: a count fixed by the
    /// problem, never by the threads, so the sums are the same bits on any machine.
    pub chunks: Vec<std::ops::Range<usize>>,
    /// Active factors touching no eliminated block (summed by a job of their own).
    pub tail: Vec<usize>,
    /// Every active factor's direct terms.
    pub direct: Vec<Direct>,
    pub grads: Vec<Grad>,
    pub pairs: Vec<Pair>,
    pub rows: Vec<Row>,
    /// Length of the reduced value buffer.
    pub nvals: usize,
}

/// Factors linearised by one task.
const LIN_GROUP: usize = 256;

impl Structure {
    /// Reduced-block index of a block, when it is one.
    pub fn c_of(&self, block: usize) -> Option<usize> {
        self.cblocks.binary_search(&block).ok()
    }

    /// Eliminated-block index of a block, when it is one.
    pub fn e_of(&self, block: usize) -> Option<usize> {
        self.eblocks.binary_search_by_key(&block, |e| e.block).ok()
    }

    /// The factors touching an eliminated block.
    pub fn terms(&self, eb: &EBlock) -> &[ETerm] {
        &self.eterms[eb.terms.0..eb.terms.1]
    }

    /// A term's links.
    pub fn links(&self, t: &ETerm) -> &[(usize, usize, usize)] {
        &self.elinks[t.links.0..t.links.1]
    }

    /// An eliminated block's neighbours.
    pub fn nbrs(&self, eb: &EBlock) -> &[usize] {
        &self.enbrs[eb.nbrs.0..eb.nbrs.1]
    }

    /// Offsets of an eliminated block's W per neighbour (from its `wbase`).
    pub fn woff(&self, eb: &EBlock) -> &[usize] {
        &self.ewoff[eb.nbrs.0..eb.nbrs.1]
    }

    /// Where an eliminated block's products go.
    pub fn pairs(&self, eb: &EBlock) -> &[(usize, usize, usize)] {
        &self.epairs[eb.pairs.0..eb.pairs.1]
    }
}

impl Model {
    /// A hash of everything the structure depends on.
    pub(crate) fn shape_hash(&self, eliminate: &[KeyKind]) -> u64 {
        let mut h = std::collections::hash_map::DefaultHasher::new();
        self.fixed.hash(&mut h);
        self.values.len().hash(&mut h);
        self.entries.len().hash(&mut h);
        self.entries.iter().for_each(|e| e.removed.hash(&mut h));
        eliminate.hash(&mut h);
        h.finish()
    }

    /// Which free blocks the Schur complement eliminates: those of the chosen kinds, unless a
    /// factor ties two of them together (then none).
    fn eliminated(&self, eliminate: &[KeyKind], active: &[usize]) -> Vec<bool> {
        let mut elim: Vec<bool> = (0..self.values.len())
            .map(|b| !self.fixed[b] && eliminate.contains(&self.keys[b].kind()))
            .collect();
        let tied = active
            .iter()
            .any(|&f| self.entries[f].blocks.iter().filter(|&&b| elim[b]).count() > 1);
        if tied {
            elim.iter_mut().for_each(|x| *x = false);
        }
        elim
    }

    pub(crate) fn build_structure(&self, eliminate: &[KeyKind], hash: u64) -> Structure {
        let active: Vec<usize> = (0..self.entries.len())
            .filter(|&f| !self.entries[f].removed)
            .collect();
        let elim = self.eliminated(eliminate, &active);
        let mut cblocks = Vec::new();
        let (mut coff, mut cdim) = (Vec::new(), Vec::new());
        let (mut n, mut nr) = (0, 0);
        let mut cidx = vec![None; self.values.len()];
        let mut eidx = vec![None; self.values.len()];
        let mut eblocks = Vec::new();
        for (b, v) in self.values.iter().enumerate() {
            if self.fixed[b] {
                continue;
            }
            n += v.dim();
            if elim[b] {
                eidx[b] = Some(eblocks.len());
                eblocks.push((b, v.dim()));
            } else {
                cidx[b] = Some(cblocks.len());
                cblocks.push(b);
                coff.push(nr);
                cdim.push(v.dim());
                nr += v.dim();
            }
        }
        let layout = self.layout(&active, &cidx, &eidx);
        let robust = active
            .iter()
            .any(|&f| self.entries[f].loss != super::factor::Loss::Trivial);
        let Layout {
            slots,
            m,
            base,
            order,
            nbuf,
        } = layout;
        let mut pos = vec![0; order.len()];
        for (i, &k) in order.iter().enumerate() {
            pos[k] = i;
        }
        let lin_groups = (0..order.len())
            .step_by(LIN_GROUP)
            .map(|a| {
                let b = (a + LIN_GROUP).min(order.len());
                let end = if b < order.len() {
                    base[order[b]]
                } else {
                    nbuf
                };
                (a, b, base[order[a]], end)
            })
            .collect();
        let nres = m.iter().sum();
        let (mut eblocks, mut flat, esizes) = gather(&eblocks, &slots, &m, &base);
        let (rows, nvals) = rows(&cdim, &slots, &mut eblocks, &mut flat);
        let (direct, grads, pairs) = direct_terms(&cdim, &coff, &slots, &m, &base, &rows);
        let tail: Vec<usize> = (0..active.len())
            .filter(|&k| slots.get(k).iter().all(|s| s.e.is_none()))
            .collect();
        let chunks = chunks(eblocks.len(), flat.pairs.len(), nvals + nr);
        Structure {
            hash,
            active,
            slots,
            m,
            base,
            pos,
            lin_groups,
            order,
            nres,
            nbuf,
            robust,
            n,
            cblocks,
            coff,
            cdim,
            nr,
            eblocks,
            eterms: flat.terms,
            elinks: flat.links,
            enbrs: flat.nbrs,
            ewoff: flat.woff,
            epairs: flat.pairs,
            esizes,
            chunks,
            tail,
            direct,
            grads,
            pairs,
            rows,
            nvals,
        }
    }

    /// Where every active factor's residual and Jacobian blocks go.
    fn layout(&self, active: &[usize], cidx: &[Option<usize>], eidx: &[Option<usize>]) -> Layout {
        let m: Vec<usize> = active
            .iter()
            .map(|&f| self.entries[f].factor.dim())
            .collect();
        let first_e = |k: usize| {
            self.entries[active[k]]
                .blocks
                .iter()
                .find_map(|&b| eidx[b])
                .unwrap_or(usize::MAX)
        };
        let mut order: Vec<usize> = (0..active.len()).collect();
        order.sort_by_key(|&k| (first_e(k), k));
        let mut base = vec![0; active.len()];
        let mut at = 0;
        for &k in &order {
            base[k] = at;
            let e = &self.entries[active[k]];
            let free = e.blocks.iter().filter(|&&b| !self.fixed[b]);
            at += m[k] * (1 + free.map(|&b| self.values[b].dim()).sum::<usize>());
        }
        let mut slots = Slots::with_capacity(active.len(), self.entries.len() * 2);
        for (k, &f) in active.iter().enumerate() {
            slots.begin();
            let mut j = base[k] + m[k];
            for &b in &self.entries[f].blocks {
                let dim = self.values[b].dim();
                let joff = (!self.fixed[b]).then(|| {
                    j += m[k] * dim;
                    j - m[k] * dim
                });
                slots.push(Slot {
                    dim,
                    joff,
                    c: cidx[b],
                    e: eidx[b],
                });
            }
        }
        slots.finish();
        Layout {
            slots,
            m,
            base,
            order,
            nbuf: at,
        }
    }
}

/// The linearisation buffer's layout.
struct Layout {
    slots: Slots,
    m: Vec<usize>,
    base: Vec<usize>,
    order: Vec<usize>,
    nbuf: usize,
}
