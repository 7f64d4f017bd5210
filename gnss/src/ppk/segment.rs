//! Ambiguity segments as the filter sees them (the rule is stated in
//! [`crate::trajectory`]'s module docs).
//!
//! Within a pass, [`SegmentTracker`] starts a new segment at a solved epoch when, since the
//! previous solved epoch, the fixed state was entered or left, a common ambiguity was fixed to
//! a different integer ([`FixedIntegers::conflicts`]), more than 2.5 nominal intervals passed,
//! or every ambiguity state was reset. [`output_segments`] renumbers the epochs of the output
//! (one pass, or both combined) in time order: a boundary wherever a pass has one between
//! consecutive output epochs, or the output Q changes.

use super::ar::{Candidate, Fix};
use crate::solution::Quality;
use crate::sv::Constellation;
use crate::sv::Sv;
use hifitime::Epoch;
use std::collections::BTreeMap;

/// The integers of a fix, per system and slot: for each ambiguity arc (state), its DD
/// integer against the group's pivot (0 for the pivot itself). The ambiguities are named by
/// `K`: their arc within a pass (`u64`, across epochs) or their satellite (within one epoch,
/// across passes and smoother).
#[derive(Clone, Debug, Default, PartialEq)]
pub(super) struct FixedIntegers<K: Ord = u64>(BTreeMap<(Constellation, usize), BTreeMap<K, i64>>);

impl FixedIntegers<u64> {
    /// The integers of a fix, by arc.
    pub(super) fn of(fix: &Fix) -> Self {
        Self::named(fix, |c| c.arc)
    }
}

impl FixedIntegers<Sv> {
    /// The integers of a fix, by satellite.
    pub(super) fn by_satellite(fix: &Fix) -> Self {
        Self::named(fix, |c| c.amb.sv)
    }
}

impl<K: Ord + Copy> FixedIntegers<K> {
    /// The integers of a fix, each ambiguity named by `name`.
    fn named(fix: &Fix, name: impl Fn(&Candidate) -> K) -> Self {
        let mut out = BTreeMap::new();
        let mut row = 0;
        for g in &fix.groups {
            let ints: &mut BTreeMap<K, i64> = out.entry((g.pivot.amb.sv.sys, g.slot)).or_default();
            let mut any = false;
            for c in &g.others {
                if let Some(n) = fix.dd_integers[row] {
                    ints.insert(name(c), n);
                    any = true;
                }
                row += 1;
            }
            if any {
                ints.insert(name(&g.pivot), 0);
            }
        }
        FixedIntegers(out)
    }

    /// Whether every ambiguity fixed here (beyond each group's reference) is fixed in
    /// `other` too.
    pub(super) fn covered_by(&self, other: &Self) -> bool {
        self.0.iter().all(|(key, a)| {
            a.keys().all(|k| {
                other
                    .0
                    .get(key)
                    .is_some_and(|b| b.len() >= 2 && b.contains_key(k))
            })
        })
    }

    /// Whether an ambiguity fixed in both has a different integer: the difference between two
    /// arcs fixed in both is compared, so a change of pivot alone is no conflict.
    pub(super) fn conflicts(&self, other: &Self) -> bool {
        self.0.iter().any(|(key, a)| {
            let Some(b) = other.0.get(key) else {
                return false;
            };
            let mut common = a.keys().filter(|k| b.contains_key(k));
            let Some(r) = common.next() else {
                return false;
            };
            common.any(|s| a[s] - a[r] != b[s] - b[r])
        })
    }
}

/// Segment ids of one pass, assigned as its epochs are solved.
#[derive(Clone, Debug)]
pub(super) struct SegmentTracker {
    /// Longest step between solved epochs within a segment, seconds.
    max_gap: f64,
    id: u32,
    /// Time and integers (None: float) of the previous solved epoch.
    last: Option<(Epoch, Option<FixedIntegers>)>,
    /// Every ambiguity state was reset since the previous solved epoch.
    all_reset: bool,
}

impl SegmentTracker {
    /// A tracker that breaks segments at steps longer than `max_gap` seconds.
    pub(super) fn new(max_gap: f64) -> Self {
        SegmentTracker {
            max_gap,
            id: 0,
            last: None,
            all_reset: false,
        }
    }

    /// Every ambiguity state has just been reset.
    pub(super) fn note_all_reset(&mut self) {
        self.all_reset = true;
    }

    /// The segment of a solved epoch at `t`, fixed to `fixed` (None: float).
    pub(super) fn next(&mut self, t: Epoch, fixed: Option<FixedIntegers>) -> u32 {
        if let Some((lt, lf)) = &self.last {
            let gap = (t - *lt).to_seconds().abs() > self.max_gap;
            let changed = match (lf, &fixed) {
                (Some(a), Some(b)) => a.conflicts(b),
                (None, None) => false,
                _ => true,
            };
            if gap || changed || self.all_reset {
                self.id += 1;
            }
        }
        self.all_reset = false;
        self.last = Some((t, fixed));
        self.id
    }
}

/// Segment ids of the output epochs: `passes[k][i]` is pass k's segment and Q at epoch i
/// (None when it did not solve it), `quality[i]` the output Q (None: no output). Ids start at
/// 0 and grow in time order at each boundary between consecutive output epochs: Q changes;
/// between fixed outputs, unless some pass is fixed at both within one segment and none is
/// fixed at both across a boundary (one pass still float at an end of the other's fixed span
/// adds nothing to the fixed output there); between float outputs, wherever a pass's id
/// differs (or it solved one of the two and not the other).
pub(super) fn output_segments(
    passes: &[&[Option<(u32, Quality)>]],
    quality: &[Option<Quality>],
) -> Vec<Option<u32>> {
    let mut out = vec![None; quality.len()];
    let mut prev: Option<usize> = None;
    let mut id = 0u32;
    for (i, q) in quality.iter().enumerate() {
        if q.is_none() {
            continue;
        }
        if let Some(a) = prev {
            let boundary = if quality[a] != *q {
                true
            } else if *q == Some(Quality::Fixed) {
                let fixed_both: Vec<bool> = passes
                    .iter()
                    .filter_map(|p| match (p[a], p[i]) {
                        (Some((x, Quality::Fixed)), Some((y, Quality::Fixed))) => Some(x == y),
                        _ => None,
                    })
                    .collect();
                fixed_both.is_empty() || fixed_both.contains(&false)
            } else {
                passes
                    .iter()
                    .any(|p| p[a].map(|s| s.0) != p[i].map(|s| s.0))
            };
            if boundary {
                id += 1;
            }
        }
        out[i] = Some(id);
        prev = Some(i);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// System, frequency slot and (arc, integer) pairs of one DD group.
    type Group<'a> = (Constellation, usize, &'a [(u64, i64)]);

    fn ints(groups: &[Group]) -> FixedIntegers {
        FixedIntegers(
            groups
                .iter()
                .map(|(s, f, v)| ((*s, *f), v.iter().copied().collect()))
                .collect(),
        )
    }

    /// Same integers under another pivot are no re-fix; a changed difference is; arcs seen
    /// in only one epoch are not compared.
    #[test]
    fn refix_is_a_changed_difference_between_common_arcs() {
        use Constellation::{Galileo as E, Gps as G};
        let a = ints(&[
            (G, 0, &[(1, 0), (2, 5), (3, -2)]),
            (E, 0, &[(7, 0), (8, 1)]),
        ]);
        // Pivot 2 instead of 1: every integer shifts by −5.
        let b = ints(&[
            (G, 0, &[(1, -5), (2, 0), (3, -7), (4, 9)]),
            (E, 0, &[(7, 0)]),
        ]);
        assert!(!a.conflicts(&b) && !b.conflicts(&a));
        let c = ints(&[(G, 0, &[(1, 0), (2, 5), (3, -1)])]);
        assert!(a.conflicts(&c));
        // Arc 3 reset (a new arc 9): its new integer is not compared.
        let d = ints(&[(G, 0, &[(1, 0), (2, 5), (9, 40)])]);
        assert!(!a.conflicts(&d));
    }

    /// Boundaries: entering and leaving the fixed state, a re-fix, a gap, an all-ambiguity
    /// reset.
    #[test]
    fn tracker_breaks_where_the_ambiguity_set_changes() {
        let t0 = crate::time::from_week_tow(2300, 0.0);
        let t = |s: f64| t0 + hifitime::Duration::from_seconds(s);
        let fix = |n: i64| Some(ints(&[(Constellation::Gps, 0, &[(1, 0), (2, n)])]));
        let mut tr = SegmentTracker::new(2.5);
        let ids: Vec<u32> = vec![
            tr.next(t(0.0), None),
            tr.next(t(1.0), fix(3)),
            tr.next(t(2.0), fix(3)),
            tr.next(t(3.0), fix(4)),
            tr.next(t(4.0), fix(4)),
            tr.next(t(8.0), fix(4)),
            {
                tr.note_all_reset();
                tr.next(t(9.0), fix(4))
            },
            tr.next(t(10.0), None),
            tr.next(t(11.0), None),
        ];
        assert_eq!(ids, vec![0, 1, 1, 2, 2, 3, 4, 5, 5]);
    }

    /// Combined ids: between fixed outputs a boundary only where no pass carries the fix
    /// across or a pass fixed at both breaks; between float outputs the union of the passes'
    /// boundaries; Q changes; renumbered in time order over the output epochs.
    #[test]
    fn output_ids_follow_the_passes_that_carry_the_output() {
        use Quality::{Fixed as X, Float as F};
        let p = |v: &[Option<(u32, Quality)>]| v.to_vec();
        let fw = p(&[
            Some((0, F)),
            Some((1, X)),
            Some((1, X)),
            None,
            Some((2, X)),
            Some((2, X)),
            Some((2, X)),
            Some((2, X)),
            Some((3, F)),
            Some((3, F)),
        ]);
        // Backward ids grow backwards in time; it is float at the last epochs.
        let bw = p(&[
            Some((4, X)),
            Some((4, X)),
            Some((4, X)),
            None,
            Some((4, X)),
            Some((3, X)),
            Some((2, F)),
            Some((1, F)),
            Some((0, F)),
            Some((0, F)),
        ]);
        let q = [
            Some(X),
            Some(X),
            Some(X),
            None,
            Some(X),
            Some(X),
            Some(X),
            Some(X),
            Some(F),
            Some(F),
        ];
        let ids = output_segments(&[&fw, &bw], &q);
        // 0–1: only the backward pass is fixed at both, no break; 2–4: the forward pass
        // breaks (gap); 4–5: the backward pass breaks while the forward holds: a break;
        // 5–6, 6–7: the forward pass alone carries the fix; 7–8: Q changes; 8–9: float, the
        // same ids in both passes.
        assert_eq!(
            ids,
            vec![
                Some(0),
                Some(0),
                Some(0),
                None,
                Some(1),
                Some(2),
                Some(2),
                Some(2),
                Some(3),
                Some(3)
            ]
        );
    }
}
