//! Descriptor matching between two images: for every descriptor of the first image its nearest
//! and second-nearest neighbours in the second (squared Euclidean distance of the byte
//! descriptors), kept when nearest/second-nearest passes the ratio test and the pair is mutual
//! (the first descriptor is also the nearest of its match). Brute force, exact, deterministic.

use super::{Descriptor, Features, DESCRIPTOR_LEN};
use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, Par};

/// A match: keypoint index in the first image, in the second.
pub type Match = (u32, u32);

/// Rows of the first image's descriptors per block of the distance computation.
const BLOCK: usize = 512;

fn norm2(d: &Descriptor) -> i64 {
    d.iter().map(|&v| v as i64 * v as i64).sum()
}

/// Mutual nearest neighbours that pass the ratio test `ratio` (distance, not squared; Lowe
/// uses 0.8), in order of the first image's keypoints.
///
/// Distances come from dot products computed as one matrix product per block (faer, SIMD):
/// the descriptors' bytes and their products are small integers, and every dot product stays
/// below 2²⁴, so the single-precision sums are exact in any order and the result is
/// bit-identical on every machine.
pub fn match_descriptors(a: &Features, b: &Features, ratio: f64) -> Vec<Match> {
    let (na, nb) = (a.descriptors.len(), b.descriptors.len());
    if na == 0 || nb < 2 {
        return Vec::new();
    }
    let bt = Mat::<f32>::from_fn(nb, DESCRIPTOR_LEN, |j, k| b.descriptors[j][k] as f32);
    let bn: Vec<i64> = b.descriptors.iter().map(norm2).collect();
    let mut best_b = vec![(i64::MAX, u32::MAX); nb];
    let mut dots = Mat::<f32>::zeros(nb, BLOCK.min(na));
    let mut cand = Vec::with_capacity(na);
    let r2 = ratio * ratio;
    for i0 in (0..na).step_by(BLOCK) {
        let i1 = (i0 + BLOCK).min(na);
        let at = Mat::<f32>::from_fn(DESCRIPTOR_LEN, i1 - i0, |k, i| {
            a.descriptors[i0 + i][k] as f32
        });
        matmul(
            dots.as_mut().subcols_mut(0, i1 - i0),
            Accum::Replace,
            bt.as_ref(),
            at.as_ref(),
            1.0f32,
            Par::Seq,
        );
        for i in i0..i1 {
            let an = norm2(&a.descriptors[i]);
            let col = dots.col(i - i0);
            let (mut d1, mut d2, mut j1) = (i64::MAX, i64::MAX, 0usize);
            for j in 0..nb {
                let d = an + bn[j] - 2 * col[j] as i64;
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
