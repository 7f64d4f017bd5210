//! The block pattern of the reduced system: which lower blocks each row stores and where,
//! and every factor's direct terms (Jₐᵀ·r and Jₐᵀ·J_b) with the offsets they add to.

use super::elim::{EBlock, Flat};
use super::slots::Slots;

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

/// The lower block pattern of the reduced system, every direct term of each row, and where
/// each eliminated block's products go.
pub(crate) fn rows(
    cdim: &[usize],
    slots: &Slots,
    eblocks: &mut [EBlock],
    fl: &mut Flat,
) -> (Vec<Row>, usize) {
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
        let nbrs = &fl.nbrs[eb.nbrs.0..eb.nbrs.1];
        for (i, &a) in nbrs.iter().enumerate() {
            cols[a].extend_from_slice(&nbrs[..i]);
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
        let p0 = fl.pairs.len();
        let nbrs = &fl.nbrs[eb.nbrs.0..eb.nbrs.1];
        for (ia, &a) in nbrs.iter().enumerate() {
            for (ib, &b) in nbrs[..=ia].iter().enumerate() {
                fl.pairs.push((ia, ib, entry(&rows, a, b)));
            }
        }
        eb.pairs = (p0, fl.pairs.len());
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
pub(crate) fn direct_terms(
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
