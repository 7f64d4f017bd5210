//! Descriptor matching between two images: for every descriptor of the first image its nearest
//! and second-nearest neighbours in the second (squared Euclidean distance of the byte
//! descriptors), kept when nearest/second-nearest passes the ratio test and the pair is mutual
//! (the first descriptor is also the nearest of its match). Brute force, exact, deterministic.

use super::{Descriptor, Features};

/// A match: keypoint index in the first image, in the second.
pub type Match = (u32, u32);

/// Squared distance of two descriptors.
#[inline]
fn dist2(a: &Descriptor, b: &Descriptor) -> u32 {
    let mut s = 0u32;
    for k in 0..a.len() {
        let d = a[k] as i32 - b[k] as i32;
        s += (d * d) as u32;
    }
    s
}

/// Mutual nearest neighbours that pass the ratio test `ratio` (distance, not squared; Lowe
/// uses 0.8), in order of the first image's keypoints.
pub fn match_descriptors(a: &Features, b: &Features, ratio: f64) -> Vec<Match> {
    let nb = b.descriptors.len();
    if a.descriptors.is_empty() || nb < 2 {
        return Vec::new();
    }
    // Best of each b over all a, for the mutual check.
    let mut best_b = vec![(u32::MAX, u32::MAX); nb];
    let mut cand = Vec::with_capacity(a.descriptors.len());
    let r2 = ratio * ratio;
    for (i, da) in a.descriptors.iter().enumerate() {
        let (mut d1, mut d2, mut j1) = (u32::MAX, u32::MAX, 0usize);
        for (j, db) in b.descriptors.iter().enumerate() {
            let d = dist2(da, db);
            if d < d1 {
                d2 = d1;
                d1 = d;
                j1 = j;
            } else if d < d2 {
                d2 = d;
            }
            if d < best_b[j].0 {
                best_b[j] = (d, i as u32);
            }
        }
        if (d1 as f64) < r2 * d2 as f64 {
            cand.push((i as u32, j1 as u32));
        }
    }
    cand.retain(|&(i, j)| best_b[j as usize].1 == i);
    cand
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::features::Keypoint;

    fn feats(ds: &[Descriptor]) -> Features {
        Features {
            keypoints: vec![
                Keypoint {
                    x: 0.0,
                    y: 0.0,
                    size: 1.0,
                    angle: 0.0,
                    response: 1.0
                };
                ds.len()
            ],
            descriptors: ds.to_vec(),
        }
    }

    #[test]
    fn ratio_and_mutual_checks_reject_ambiguous_matches() {
        let mut d = [[0u8; 128]; 4];
        for (k, x) in d.iter_mut().enumerate() {
            x[k] = 200;
        }
        // b: exact copies of a0 and a1, two near-identical copies of a2 (ambiguous), and a
        // descriptor closest to a3 only in the sense of being the least far.
        let mut b = vec![d[0], d[1], d[2], d[2]];
        b[2][100] = 3;
        b[3][101] = 3;
        let mut far = [0u8; 128];
        far[60] = 150;
        b.push(far);
        let m = match_descriptors(&feats(&d), &feats(&b), 0.8);
        assert_eq!(m, vec![(0, 0), (1, 1)]);
    }
}
