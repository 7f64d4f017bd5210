//! Tracks: keypoints joined across images by pairwise matches (union–find). A track that
//! holds two keypoints of one image is in conflict: those keypoints are cut from it (the rest
//! stays a track when it still spans two images), and the cut is counted.

use super::matching::Match;

/// A keypoint of an image: (image index, keypoint index).
pub type Node = (usize, u32);

/// The tracks and what building them cut.
#[derive(Clone, Debug, Default)]
pub struct Tracks {
    /// Each track's keypoints, one per image, sorted by image; tracks in order of their first
    /// keypoint.
    pub tracks: Vec<Vec<Node>>,
    /// Keypoints cut because their track had another keypoint of the same image.
    pub conflicts: usize,
}

fn find(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        let p = parent[x as usize];
        parent[x as usize] = parent[p as usize];
        x = p;
    }
    x
}

/// Tracks from verified matches: `pairs` lists (image a, image b, matches a → b);
/// `counts[i]` is the number of keypoints of image i.
pub fn build(counts: &[usize], pairs: &[(usize, usize, Vec<Match>)]) -> Tracks {
    let mut offset = Vec::with_capacity(counts.len() + 1);
    let mut n = 0usize;
    for &c in counts {
        offset.push(n);
        n += c;
    }
    offset.push(n);
    let mut parent: Vec<u32> = (0..n as u32).collect();
    for (a, b, ms) in pairs {
        for &(i, j) in ms {
            let x = find(&mut parent, (offset[*a] + i as usize) as u32);
            let y = find(&mut parent, (offset[*b] + j as usize) as u32);
            if x != y {
                let (lo, hi) = (x.min(y), x.max(y));
                parent[hi as usize] = lo;
            }
        }
    }
    let roots: Vec<u32> = (0..n as u32).map(|g| find(&mut parent, g)).collect();
    let mut size = vec![0u32; n];
    for &r in &roots {
        size[r as usize] += 1;
    }
    let mut members: std::collections::BTreeMap<u32, Vec<Node>> = Default::default();
    for (img, w) in offset.windows(2).enumerate() {
        for (g, &r) in roots.iter().enumerate().take(w[1]).skip(w[0]) {
            if size[r as usize] >= 2 {
                members.entry(r).or_default().push((img, (g - w[0]) as u32));
            }
        }
    }
    let mut out = Tracks::default();
    for (_, mut t) in members {
        t.sort_unstable();
        let mut keep: Vec<Node> = Vec::with_capacity(t.len());
        let mut k = 0;
        while k < t.len() {
            let mut e = k + 1;
            while e < t.len() && t[e].0 == t[k].0 {
                e += 1;
            }
            if e - k == 1 {
                keep.push(t[k]);
            } else {
                out.conflicts += e - k;
            }
            k = e;
        }
        if keep.len() >= 2 {
            out.tracks.push(keep);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_chain_into_tracks_and_conflicts_are_cut() {
        // Images 0,1,2 with 3 keypoints each. Track A: 0:0-1:0-2:0. Track B: 0:1-1:1, and
        // 1:1-2:1 and 1:2-2:1 (so 2:1 joins 1:1 and 1:2 of image 1: both cut).
        let pairs = vec![
            (0, 1, vec![(0, 0), (1, 1)]),
            (1, 2, vec![(0, 0), (1, 1), (2, 1)]),
        ];
        let t = build(&[3, 3, 3], &pairs);
        assert_eq!(t.tracks[0], vec![(0, 0), (1, 0), (2, 0)]);
        assert_eq!(t.tracks[1], vec![(0, 1), (2, 1)]);
        assert_eq!(t.tracks.len(), 2);
        assert_eq!(t.conflicts, 2);
    }
}
