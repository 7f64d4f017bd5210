//! The eliminated blocks in the structure: what touches each (factors, the reduced blocks
//! tied to it), where its data lives in the shared buffers, where its products go in the
//! reduced matrix, and the ranges of blocks summed by separate jobs. Gathered per block, then
//! packed into flat arrays so that a step streams through them.

use super::slots::Slots;

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

/// Flat lists of the eliminated blocks.
#[derive(Default)]
pub(crate) struct Flat {
    pub terms: Vec<ETerm>,
    pub links: Vec<(usize, usize, usize)>,
    pub nbrs: Vec<usize>,
    pub woff: Vec<usize>,
    pub pairs: Vec<(usize, usize, usize)>,
}

/// The eliminated blocks (`(block, dim)` in order) with their terms, neighbours, links and
/// buffer layout, gathered straight into flat arrays (pairs come later, with the pattern).
pub(crate) fn gather(
    blocks: &[(usize, usize)],
    slots: &Slots,
    m: &[usize],
    base: &[usize],
) -> (Vec<EBlock>, Flat, ESizes) {
    // Terms bucketed by eliminated block, each bucket in factor order.
    let mut count = vec![0usize; blocks.len() + 1];
    for ss in slots.iter() {
        for s in ss.iter().filter(|s| s.joff.is_some()) {
            if let Some(e) = s.e {
                count[e + 1] += 1;
            }
        }
    }
    for i in 1..count.len() {
        count[i] += count[i - 1];
    }
    let mut at = count.clone();
    let mut raw = vec![(0usize, 0usize); count[blocks.len()]];
    for (f, ss) in slots.iter().enumerate() {
        for s in ss {
            if let (Some(e), Some(j)) = (s.e, s.joff) {
                raw[at[e]] = (f, j);
                at[e] += 1;
            }
        }
    }
    let mut fl = Flat::default();
    let mut sizes = ESizes::default();
    let mut nbrs: Vec<(usize, usize)> = Vec::new();
    let eblocks = blocks
        .iter()
        .enumerate()
        .map(|(e, &(block, dim))| {
            let terms = &raw[count[e]..count[e + 1]];
            nbrs.clear();
            for &(f, _) in terms {
                nbrs.extend(slots.get(f).iter().filter_map(|s| s.c.map(|c| (c, s.dim))));
            }
            nbrs.sort_unstable();
            nbrs.dedup();
            let t0 = fl.terms.len();
            for &(f, jo) in terms {
                let l0 = fl.links.len();
                for s in slots.get(f) {
                    if let (Some(c), Some(j)) = (s.c, s.joff) {
                        let ni = nbrs.partition_point(|n| n.0 < c);
                        fl.links.push((j, s.dim, ni));
                    }
                }
                let links = (l0, fl.links.len());
                fl.terms.push(ETerm {
                    f,
                    jo,
                    ro: base[f],
                    m: m[f],
                    links,
                });
            }
            let n0 = fl.nbrs.len();
            let mut wlen = 0;
            for &(c, d) in &nbrs {
                fl.nbrs.push(c);
                fl.woff.push(wlen);
                wlen += dim * d;
            }
            let eb = EBlock {
                block,
                dim,
                terms: (t0, fl.terms.len()),
                nbrs: (n0, fl.nbrs.len()),
                pairs: (0, 0),
                wlen,
                wbase: sizes.w,
                vbase: sizes.v,
                gbase: sizes.g,
            };
            sizes.w += wlen;
            sizes.v += dim * dim;
            sizes.g += dim;
            eb
        })
        .collect();
    (eblocks, fl, sizes)
}

/// Ranges of eliminated blocks summed separately: one per 50 000 block products (`work`), up
/// to four, and fewer when the copies of the reduced system (`size` values each) would take
/// more than 512 MB.
pub(crate) fn chunks(n: usize, work: usize, size: usize) -> Vec<std::ops::Range<usize>> {
    let k = (work / 50_000)
        .clamp(1, 4)
        .min(n.max(1))
        .min((64_000_000 / size.max(1)).max(1));
    (0..k).map(|i| i * n / k..(i + 1) * n / k).collect()
}
