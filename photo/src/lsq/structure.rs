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

use super::problem::Problem;
use std::hash::{Hash, Hasher};
use std::sync::Arc;

/// One block of one active factor.
#[derive(Clone, Debug)]
pub(crate) struct Slot {
    pub dim: usize,
    /// Offset of its Jacobian (m × dim) in the shared Jacobian buffer (`None`: fixed block).
    pub joff: Option<usize>,
    /// Index among the reduced (kept) blocks.
    pub c: Option<usize>,
    /// Index among the eliminated blocks.
    pub e: Option<usize>,
}

/// The slots of every active factor, in one list.
#[derive(Clone, Debug, Default)]
pub(crate) struct Slots {
    list: Vec<Slot>,
    /// Where factor k's slots start (and, at k + 1, end).
    at: Vec<usize>,
}

impl Slots {
    /// Factor `k`'s slots.
    pub fn get(&self, k: usize) -> &[Slot] {
        &self.list[self.at[k]..self.at[k + 1]]
    }

    /// Every factor's slots, in factor order.
    pub fn iter(&self) -> impl Iterator<Item = &[Slot]> + '_ {
        self.at.windows(2).map(|w| &self.list[w[0]..w[1]])
    }

    /// The number of factors.
    pub fn len(&self) -> usize {
        self.at.len().saturating_sub(1)
    }
}

/// An eliminated block and what touches it, as it is gathered.
#[derive(Clone, Debug, Default)]
struct EDraft {
    block: usize,
    dim: usize,
    terms: Vec<(usize, usize)>,
    nbrs: Vec<usize>,
    links: Vec<Vec<(usize, usize, usize)>>,
    woff: Vec<usize>,
    wlen: usize,
    pairs: Vec<(usize, usize, usize)>,
}

/// A factor touching an eliminated block: the factor, the offsets of its Jacobian of the
/// block and of its residual, its residual dimension, and the range of its links (reduced
/// blocks of the same factor) in `Structure::elinks`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ETerm {
    pub f: usize,
    pub jo: usize,
    pub ro: usize,
    pub m: usize,
    pub links: (usize, usize),
}

/// An eliminated block. Its lists live in the structure's flat arrays (consecutive blocks'
/// data are consecutive in memory, so a step streams through them).
#[derive(Clone, Copy, Debug)]
pub(crate) struct EBlock {
    pub block: usize,
    pub dim: usize,
    /// Range of its terms in `Structure::eterms`.
    pub terms: (usize, usize),
    /// Range of its neighbours (reduced blocks tied to it, ascending) in `Structure::enbrs`
    /// and of their W offsets in `Structure::ewoff`.
    pub nbrs: (usize, usize),
    /// Range of its pairs in `Structure::epairs`.
    pub pairs: (usize, usize),
    /// Length of its W (and T) data.
    pub wlen: usize,
    /// Where the block's data starts in the shared buffers: W, V⁻¹, gradient.
    pub wbase: usize,
    pub vbase: usize,
    pub gbase: usize,
}

/// Sizes of the shared buffers of the eliminated blocks.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct ESizes {
    pub w: usize,
    pub v: usize,
    pub g: usize,
}

/// One block row of the reduced system: where its lower blocks are stored.
#[derive(Clone, Debug, Default)]
pub(crate) struct Row {
    /// Offset of the row's first entry in the value buffer.
    pub start: usize,
    /// (entry offset within the row, column block) in ascending column order.
    pub entries: Vec<(usize, usize)>,
    /// Offset of the diagonal block within the row.
    pub diag: usize,
}

/// A factor's contribution Jₐᵀ·r to the gradient of a reduced block.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Grad {
    /// Jacobian offset, residual offset, residual dimension.
    pub ja: usize,
    pub ro: usize,
    pub m: usize,
    /// The reduced block, its dimension and offset.
    pub c: usize,
    pub da: usize,
    pub go: usize,
}

/// A factor's contribution Jₐᵀ·J_b to block (a, b ≤ a) of the reduced matrix.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Pair {
    pub ja: usize,
    pub jb: usize,
    pub m: usize,
    pub da: usize,
    pub db: usize,
    /// Offset of the block in the value buffer.
    pub off: usize,
}

/// Ranges of one factor's direct terms in `Structure::{grads, pairs}`.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Direct {
    pub grads: (usize, usize),
    pub pairs: (usize, usize),
}

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

impl Problem {
    /// A hash of everything the structure depends on.
    pub(crate) fn shape_hash(&self) -> u64 {
        let mut h = std::collections::hash_map::DefaultHasher::new();
        self.fixed.hash(&mut h);
        self.values.len().hash(&mut h);
        self.entries.len().hash(&mut h);
        self.entries.iter().for_each(|e| e.removed.hash(&mut h));
        self.options.eliminate.hash(&mut h);
        h.finish()
    }

    /// The structure for the current shape (cached).
    pub(crate) fn structure(&self) -> Arc<Structure> {
        let hash = self.shape_hash();
        if let Ok(mut c) = self.caches.structure.lock() {
            if let Some(s) = c.as_ref().filter(|s| s.hash == hash) {
                return s.clone();
            }
            let s = Arc::new(self.build_structure(hash));
            *c = Some(s.clone());
            return s;
        }
        Arc::new(self.build_structure(hash))
    }

    /// Which free blocks the Schur complement eliminates: those of the chosen kinds, unless a
    /// factor ties two of them together (then none).
    fn eliminated(&self, active: &[usize]) -> Vec<bool> {
        let mut elim: Vec<bool> = (0..self.values.len())
            .map(|b| !self.fixed[b] && self.options.eliminate.contains(&self.keys[b].kind()))
            .collect();
        let tied = active
            .iter()
            .any(|&f| self.entries[f].blocks.iter().filter(|&&b| elim[b]).count() > 1);
        if tied {
            elim.iter_mut().for_each(|x| *x = false);
        }
        elim
    }

    fn build_structure(&self, hash: u64) -> Structure {
        let active: Vec<usize> = (0..self.entries.len())
            .filter(|&f| !self.entries[f].removed)
            .collect();
        let elim = self.eliminated(&active);
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
                eblocks.push(EDraft {
                    block: b,
                    dim: v.dim(),
                    ..EDraft::default()
                });
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
            .any(|&f| self.entries[f].loss != super::Loss::Trivial);
        let Layout {
            slots,
            m,
            base,
            order,
            nbuf,
        } = layout;
        let nres = m.iter().sum();
        link_eliminated(&mut eblocks, &slots);
        let (rows, nvals) = rows(&cdim, &slots, &mut eblocks);
        let (direct, grads, pairs) = direct_terms(&cdim, &coff, &slots, &m, &base, &rows);
        let tail: Vec<usize> = (0..active.len())
            .filter(|&k| slots.get(k).iter().all(|s| s.e.is_none()))
            .collect();
        let work: usize = eblocks.iter().map(|e| e.pairs.len()).sum();
        let chunks = chunks(eblocks.len(), work, nvals + nr);
        let (eblocks, flat, esizes) = pack(eblocks, &m, &base);
        Structure {
            hash,
            active,
            slots,
            m,
            base,
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
        let mut slots = Slots {
            list: Vec::with_capacity(self.entries.len() * 2),
            at: Vec::with_capacity(active.len() + 1),
        };
        for (k, &f) in active.iter().enumerate() {
            slots.at.push(slots.list.len());
            let mut j = base[k] + m[k];
            for &b in &self.entries[f].blocks {
                let dim = self.values[b].dim();
                let joff = (!self.fixed[b]).then(|| {
                    j += m[k] * dim;
                    j - m[k] * dim
                });
                slots.list.push(Slot {
                    dim,
                    joff,
                    c: cidx[b],
                    e: eidx[b],
                });
            }
        }
        slots.at.push(slots.list.len());
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

/// Flat lists of the eliminated blocks.
#[derive(Default)]
struct Flat {
    terms: Vec<ETerm>,
    links: Vec<(usize, usize, usize)>,
    nbrs: Vec<usize>,
    woff: Vec<usize>,
    pairs: Vec<(usize, usize, usize)>,
}

/// The drafts packed into flat arrays, with the buffer layout.
fn pack(drafts: Vec<EDraft>, m: &[usize], base: &[usize]) -> (Vec<EBlock>, Flat, ESizes) {
    let mut f = Flat::default();
    let mut sizes = ESizes::default();
    let range = |v: usize, n: usize| (v, v + n);
    let blocks = drafts
        .into_iter()
        .map(|d| {
            let t0 = f.terms.len();
            for (&(fa, jo), l) in d.terms.iter().zip(&d.links) {
                let links = range(f.links.len(), l.len());
                f.links.extend_from_slice(l);
                f.terms.push(ETerm {
                    f: fa,
                    jo,
                    ro: base[fa],
                    m: m[fa],
                    links,
                });
            }
            let eb = EBlock {
                block: d.block,
                dim: d.dim,
                terms: (t0, f.terms.len()),
                nbrs: range(f.nbrs.len(), d.nbrs.len()),
                pairs: range(f.pairs.len(), d.pairs.len()),
                wlen: d.wlen,
                wbase: sizes.w,
                vbase: sizes.v,
                gbase: sizes.g,
            };
            f.nbrs.extend_from_slice(&d.nbrs);
            f.woff.extend_from_slice(&d.woff);
            f.pairs.extend_from_slice(&d.pairs);
            sizes.w += d.wlen;
            sizes.v += d.dim * d.dim;
            sizes.g += d.dim;
            eb
        })
        .collect();
    (blocks, f, sizes)
}

/// Terms, neighbours and W layout of every eliminated block.
fn link_eliminated(eblocks: &mut [EDraft], slots: &Slots) {
    for (f, ss) in slots.iter().enumerate() {
        for s in ss {
            if let (Some(e), Some(j)) = (s.e, s.joff) {
                eblocks[e].terms.push((f, j));
            }
        }
    }
    for eb in eblocks.iter_mut() {
        let mut nbrs: Vec<(usize, usize)> = eb
            .terms
            .iter()
            .flat_map(|&(f, _)| slots.get(f).iter().filter_map(|s| s.c.map(|c| (c, s.dim))))
            .collect();
        nbrs.sort_unstable();
        nbrs.dedup();
        eb.links = eb
            .terms
            .iter()
            .map(|&(f, _)| {
                slots
                    .get(f)
                    .iter()
                    .filter_map(|s| {
                        let (c, j) = (s.c?, s.joff?);
                        Some((j, s.dim, nbrs.iter().position(|n| n.0 == c)?))
                    })
                    .collect()
            })
            .collect();
        let mut at = 0;
        eb.woff = nbrs
            .iter()
            .map(|&(_, d)| {
                at += eb.dim * d;
                at - eb.dim * d
            })
            .collect();
        eb.wlen = at;
        eb.nbrs = nbrs.into_iter().map(|n| n.0).collect();
    }
}

/// Ranges of eliminated blocks summed separately: one per 50 000 block products (`work`), up
/// to four, and fewer when the copies of the reduced system (`size` values each) would take
/// more than 512 MB.
fn chunks(n: usize, work: usize, size: usize) -> Vec<std::ops::Range<usize>> {
    let k = (work / 50_000)
        .clamp(1, 4)
        .min(n.max(1))
        .min((64_000_000 / size.max(1)).max(1));
    (0..k).map(|i| i * n / k..(i + 1) * n / k).collect()
}

/// The lower block pattern of the reduced system, every direct term of each row, and where
/// each eliminated block's products go.
fn rows(cdim: &[usize], slots: &Slots, eblocks: &mut [EDraft]) -> (Vec<Row>, usize) {
    let nc = cdim.len();
    // Column blocks of each row.
    let mut cols: Vec<Vec<usize>> = (0..nc).map(|r| vec![r]).collect();
    for ss in slots.iter() {
        for a in ss.iter().filter_map(|s| s.c) {
            for b in ss.iter().filter_map(|s| s.c).filter(|&b| b < a) {
                cols[a].push(b);
            }
        }
    }
    for eb in eblocks.iter() {
        for (i, &a) in eb.nbrs.iter().enumerate() {
            cols[a].extend_from_slice(&eb.nbrs[..i]);
        }
    }
    let mut rows: Vec<Row> = Vec::with_capacity(nc);
    let mut start = 0;
    for (r, c) in cols.iter_mut().enumerate() {
        c.sort_unstable();
        c.dedup();
        let mut at = 0;
        let entries: Vec<(usize, usize)> = c
            .iter()
            .map(|&col| {
                at += cdim[r] * cdim[col];
                (at - cdim[r] * cdim[col], col)
            })
            .collect();
        let diag = entries.last().map(|e| e.0).unwrap_or(0);
        rows.push(Row {
            start,
            entries,
            diag,
        });
        start += at;
    }
    for eb in eblocks.iter_mut() {
        for (ia, &a) in eb.nbrs.iter().enumerate() {
            for (ib, &b) in eb.nbrs[..=ia].iter().enumerate() {
                eb.pairs.push((ia, ib, entry(&rows, a, b)));
            }
        }
    }
    (rows, start)
}

/// Offset of block (row, col ≤ row) in the value buffer.
fn entry(rows: &[Row], r: usize, col: usize) -> usize {
    let row = &rows[r];
    let i = row.entries.partition_point(|e| e.1 < col);
    row.start + row.entries[i].0
}

/// Every active factor's gradient and pair terms among the reduced blocks.
#[allow(clippy::type_complexity)]
fn direct_terms(
    cdim: &[usize],
    coff: &[usize],
    slots: &Slots,
    m: &[usize],
    base: &[usize],
    rows: &[Row],
) -> (Vec<Direct>, Vec<Grad>, Vec<Pair>) {
    let (mut grads, mut pairs) = (Vec::new(), Vec::new());
    let direct = slots
        .iter()
        .enumerate()
        .map(|(f, ss)| {
            let (g0, p0) = (grads.len(), pairs.len());
            for sa in ss {
                let (Some(a), Some(ja)) = (sa.c, sa.joff) else {
                    continue;
                };
                grads.push(Grad {
                    ja,
                    ro: base[f],
                    m: m[f],
                    c: a,
                    da: cdim[a],
                    go: coff[a],
                });
                for sb in ss {
                    if let (Some(b), Some(jb)) = (sb.c.filter(|&b| b <= a), sb.joff) {
                        pairs.push(Pair {
                            ja,
                            jb,
                            m: m[f],
                            da: cdim[a],
                            db: cdim[b],
                            off: entry(rows, a, b),
                        });
                    }
                }
            }
            Direct {
                grads: (g0, grads.len()),
                pairs: (p0, pairs.len()),
            }
        })
        .collect();
    (direct, grads, pairs)
}
