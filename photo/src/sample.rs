//! The deterministic random draws of RANSAC: a SplitMix64 generator and samples of distinct
//! indices (from any generator), so a seed gives the same result on every machine.

/// A small deterministic generator (SplitMix64).
pub(crate) struct Rng(pub(crate) u64);

impl Rng {
    /// The next 64 random bits.
    pub(crate) fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// A number in `0..n` (`n` > 0).
    pub(crate) fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }

    /// `K` distinct indices in `0..n` (`n` ≥ `K`), in the order drawn.
    pub(crate) fn distinct<const K: usize>(&mut self, n: usize) -> [usize; K] {
        distinct(n, |n| self.below(n))
    }
}

/// `K` distinct indices in `0..n` (`n` ≥ `K`) from `below(n)` draws, in the order drawn
/// (a repeat is drawn again).
pub(crate) fn distinct<const K: usize>(
    n: usize,
    mut below: impl FnMut(usize) -> usize,
) -> [usize; K] {
    let mut idx = [0usize; K];
    let mut k = 0;
    while k < K {
        let c = below(n);
        if !idx[..k].contains(&c) {
            idx[k] = c;
            k += 1;
        }
    }
    idx
}
