//! Where each active factor's blocks are: their dimension, the offset of their Jacobian in the
//! linearisation buffer, and whether the block is kept in the reduced system or eliminated.

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
    /// Room for `factors` factors and `slots` slots in all.
    pub fn with_capacity(factors: usize, slots: usize) -> Slots {
        Slots {
            list: Vec::with_capacity(slots),
            at: Vec::with_capacity(factors + 1),
        }
    }

    /// Start the next factor's slots.
    pub fn begin(&mut self) {
        self.at.push(self.list.len());
    }

    /// A slot of the current factor.
    pub fn push(&mut self, s: Slot) {
        self.list.push(s);
    }

    /// Close the list after the last factor.
    pub fn finish(&mut self) {
        self.at.push(self.list.len());
    }

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
