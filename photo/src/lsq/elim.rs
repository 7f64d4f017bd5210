//! The eliminated blocks in the structure: what touches each (factors, the reduced blocks
//! tied to it), where its data lives in the shared buffers, where its products go in the
//! reduced matrix, and the ranges of blocks summed by separate jobs. Gathered per block, then
//! packed into flat arrays so that a step streams through them.

use super::slots::Slots;

/// An eliminated block and what touches it, as it is gathered.
#[derive(Clone, Debug, Default)]
pub(crate) struct EDraft {
    pub block: usize,
    pub dim: usize,
    pub terms: Vec<(usize, usize)>,
    pub nbrs: Vec<usize>,
    pub links: Vec<Vec<(usize, usize, usize)>>,
    pub woff: Vec<usize>,
    pub wlen: usize,
    pub pairs: Vec<(usize, usize, usize)>,
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

/// Flat lists of the eliminated blocks.
#[derive(Default)]
pub(crate) struct Flat {
    pub terms: Vec<ETerm>,
    pub links: Vec<(usize, usize, usize)>,
    pub nbrs: Vec<usize>,
    pub woff: Vec<usize>,
    pub pairs: Vec<(usize, usize, usize)>,
}

/// The drafts packed into flat arrays, with the buffer layout.
pub(crate) fn pack(
    drafts: Vec<EDraft>,
    m: &[usize],
    base: &[usize],
) -> (Vec<EBlock>, Flat, ESizes) {
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
pub(crate) fn link_eliminated(eblocks: &mut [EDraft], slots: &Slots) {
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
pub(crate) fn chunks(n: usize, work: usize, size: usize) -> Vec<std::ops::Range<usize>> {
    let k = (work / 50_000)
        .clamp(1, 4)
        .min(n.max(1))
        .min((64_000_000 / size.max(1)).max(1));
    (0..k).map(|i| i * n / k..(i + 1) * n / k).collect()
}
