//! Triples of point indices for RANSAC over P3P ([`crate::resection::resect_robust`]):
//! a fixed, even spread over all C(n, 3) in lexicographic order, each picked by its rank.

/// `count` triples i < j < k < n spread evenly over all C(n, 3) in lexicographic order (all
/// of them when there are no more): each picked by its rank, so an image with thousands of
/// points costs `count` triples, not the n³/6 a full list would hold (gigabytes at 3,000).
pub(crate) fn spread_triples(n: usize, count: usize) -> Vec<[usize; 3]> {
    let total = n * n.saturating_sub(1) * n.saturating_sub(2) / 6;
    if total <= count {
        return (0..total).map(|r| triple_of_rank(n, r)).collect();
    }
    let step = total as f64 / count as f64;
    (0..count)
        .map(|m| triple_of_rank(n, (m as f64 * step) as usize))
        .collect()
}

/// The triple of lexicographic rank `r` among the C(n, 3) triples i < j < k < n.
fn triple_of_rank(n: usize, mut r: usize) -> [usize; 3] {
    let mut i = 0;
    loop {
        // Triples starting with i: C(n − 1 − i, 2).
        let m = n - 1 - i;
        let with_i = m * (m - 1) / 2;
        if r < with_i {
            break;
        }
        r -= with_i;
        i += 1;
    }
    let mut j = i + 1;
    while r >= n - 1 - j {
        r -= n - 1 - j;
        j += 1;
    }
    [i, j, j + 1 + r]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Ranked triples are the lexicographic list, whole or spread, without building it.
    #[test]
    fn triples_by_rank_match_the_full_list() {
        for n in [3, 4, 7, 12, 30] {
            let mut all = Vec::new();
            for i in 0..n {
                for j in i + 1..n {
                    for k in j + 1..n {
                        all.push([i, j, k]);
                    }
                }
            }
            let spread = spread_triples(n, 200);
            if all.len() <= 200 {
                assert_eq!(spread, all);
            } else {
                let step = all.len() as f64 / 200.0;
                let want: Vec<_> = (0..200).map(|m| all[(m as f64 * step) as usize]).collect();
                assert_eq!(spread, want);
            }
        }
        // 5,000 points: C(n, 3) ≈ 2·10¹⁰ triples, none of them listed.
        let t = spread_triples(5000, 200);
        assert_eq!((t.len(), t[0], t[199][0] > 3000), (200, [0, 1, 2], true));
    }
}
