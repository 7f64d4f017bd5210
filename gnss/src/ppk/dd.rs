//! Double-difference groups: the satellites of one system on one frequency slot, each
//! differenced against one pivot (reference) satellite of the group.
//!
//! A double difference of a quantity q is (q_s − q_pivot) of the single differences
//! (rover − base) of satellite s and of the pivot. The measurement model and the ambiguity
//! resolution both form such groups; each picks its pivot by its own rule (highest elevation,
//! or highest among the satellites locked for a while).

use std::cmp::Ordering;

/// Satellites of one system on one slot, split into the pivot and the others (in their original
/// order).
#[derive(Clone, Debug)]
pub(super) struct DdGroup<M> {
    /// The frequency slot of every member (0 for a wide-lane group of slots 0 and 1).
    pub(super) slot: usize,
    /// The reference member.
    pub(super) pivot: M,
    /// The other members, each giving one double difference against the pivot.
    pub(super) others: Vec<M>,
}

impl<M> DdGroup<M> {
    /// The group of `members` (satellites of one system on `slot`) with the greatest `rank`
    /// as pivot (the last of equal ranks; incomparable ranks count as equal). None with fewer
    /// than two members: a lone satellite gives no double difference.
    pub(super) fn form<K: PartialOrd>(
        slot: usize,
        mut members: Vec<M>,
        rank: impl Fn(&M) -> K,
    ) -> Option<Self> {
        if members.len() < 2 {
            return None;
        }
        let (i, _) = members
            .iter()
            .enumerate()
            .max_by(|a, b| rank(a.1).partial_cmp(&rank(b.1)).unwrap_or(Ordering::Equal))?;
        let pivot = members.remove(i);
        Some(DdGroup {
            slot,
            pivot,
            others: members,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pivot is the highest-ranked member, the last one among equals; the others keep
    /// their order.
    #[test]
    fn pivot_is_the_last_maximum() {
        let g = DdGroup::form(0, vec![1, 5, 3, 5, 2], |m| *m).unwrap();
        assert_eq!(g.pivot, 5);
        assert_eq!(g.others, vec![1, 5, 3, 2]);
        let g = DdGroup::form(0, vec![(0, 1.0), (1, 3.0), (2, 3.0)], |m| m.1).unwrap();
        assert_eq!(g.pivot.0, 2);
        assert!(DdGroup::form(0, vec![1], |m| *m).is_none());
    }
}
