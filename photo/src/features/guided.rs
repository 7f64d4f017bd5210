//! Guided matching: once a pair's geometry is known (its fundamental matrix and the verified
//! matches), every keypoint of the first image not yet matched is looked for again in the
//! second, among the few keypoints that lie where its verified neighbours say it moves to and
//! on its epipolar line. The ratio test is then taken among those candidates only, so a
//! feature whose descriptor has a look-alike elsewhere in the image (a roof among roofs, a
//! dashed line) is matched once its place is known. This is what turns many two-photo tracks
//! into tracks across the block.

use super::epipolar::sampson;
use super::matching::Match;
use super::near::{dist2, nearest_two, xy, Grid, Mover};
use super::Features;
use nalgebra::{Matrix3, Vector2};

/// How guided matching searches.
#[derive(Clone, Copy, Debug)]
pub struct GuidedOptions {
    /// Radius around the predicted position in which candidates are taken, pixels.
    pub radius_px: f64,
    /// Largest Sampson distance from the pair's fundamental matrix, pixels.
    pub epipolar_px: f64,
    /// Ratio test among the candidates (distance, not squared).
    pub ratio: f64,
    /// Verified matches whose median displacement predicts a keypoint's position.
    pub neighbours: usize,
    /// Keypoints this close to a verified match's keypoint (another scale or orientation of
    /// the same feature) are left alone, pixels: matching them again would only put two
    /// keypoints of one image in one track.
    pub duplicate_px: f64,
}

/// The verified matches `seeds` of images `a` and `b` with fundamental matrix `f`
/// (x_bᵀ·F·x_a = 0, photograph pixels), and the matches guided search adds: for each keypoint
/// of `a` not in a seed, the keypoints of `b` (not in a seed) within `radius_px` of where its
/// `neighbours` nearest seeds move and within `epipolar_px` of its epipolar line; the nearest
/// descriptor among them is kept when it passes the ratio test against the second nearest
/// (a lone candidate is not), no other keypoint of `a` claims it more closely, and searched
/// back in `a` the same way it finds the same keypoint. Seeds and added matches together,
/// sorted; deterministic.
pub fn guided(
    a: &Features,
    b: &Features,
    f: &Matrix3<f64>,
    seeds: &[Match],
    o: &GuidedOptions,
) -> Vec<Match> {
    if seeds.len() < o.neighbours.max(1) {
        return seeds.to_vec();
    }
    let pa: Vec<Vector2<f64>> = a.keypoints.iter().map(xy).collect();
    let pb: Vec<Vector2<f64>> = b.keypoints.iter().map(xy).collect();
    let sa: Vec<Vector2<f64>> = seeds.iter().map(|&(i, _)| pa[i as usize]).collect();
    let sb: Vec<Vector2<f64>> = seeds.iter().map(|&(_, j)| pb[j as usize]).collect();
    let cell = o.radius_px.max(1.0);
    let mut buf = Vec::new();
    let (w, h) = pa
        .iter()
        .fold((1.0f64, 1.0f64), |(w, h), p| (w.max(p.x), h.max(p.y)));
    let mover = Mover::new(sa, &sb, o.neighbours, (w, h), cell);
    let b_grid = Grid::new(&pb, cell);
    let mut used_a = vec![false; pa.len()];
    let mut used_b = vec![false; pb.len()];
    let a_grid = Grid::new(&pa, cell);
    for &(i, j) in seeds {
        a_grid.within(&pa, &pa[i as usize], o.duplicate_px, &mut buf);
        buf.iter().for_each(|&k| used_a[k as usize] = true);
        b_grid.within(&pb, &pb[j as usize], o.duplicate_px, &mut buf);
        buf.iter().for_each(|&k| used_b[k as usize] = true);
    }
    // Best claim on each keypoint of b: (distance², keypoint of a).
    let mut claim: Vec<Option<(i64, u32)>> = vec![None; pb.len()];
    let mut found: Vec<(u32, u32, Vector2<f64>)> = Vec::new();
    let mut cand = Vec::new();
    let r2 = o.ratio * o.ratio;
    for (i, p) in pa.iter().enumerate() {
        if used_a[i] {
            continue;
        }
        let Some(shift) = mover.shift(p, &mut buf) else {
            continue;
        };
        b_grid.within(&pb, &(p + shift), o.radius_px, &mut cand);
        let (d1, d2, j1) = nearest_two(
            cand.iter()
                .filter(|&&j| {
                    !used_b[j as usize] && sampson(f, p, &pb[j as usize]) <= o.epipolar_px
                })
                .map(|&j| (j, dist2(&a.descriptors[i], &b.descriptors[j as usize]))),
        );
        // A lone candidate has nothing to be told apart from: not taken (taking those whose
        // descriptor is as close as the seeds' lowered the correct share on the textured
        // block).
        let passes = d2 != i64::MAX && (d1 as f64) < r2 * d2 as f64;
        if j1 != u32::MAX && passes {
            found.push((i as u32, j1, shift));
            let c = &mut claim[j1 as usize];
            if c.is_none_or(|(d, k)| (d1, i as u32) < (d, k)) {
                *c = Some((d1, i as u32));
            }
        }
    }
    // Mutual: the keypoint of b, searched back in a the same way, finds the same keypoint.
    let back = |i: u32, j: u32, shift: Vector2<f64>, cand: &mut Vec<u32>| {
        let q = pb[j as usize];
        a_grid.within(&pa, &(q - shift), o.radius_px, cand);
        let (d1, d2, k1) = nearest_two(
            cand.iter()
                .filter(|&&k| {
                    !used_a[k as usize] && sampson(f, &pa[k as usize], &q) <= o.epipolar_px
                })
                .map(|&k| {
                    (
                        k,
                        dist2(&a.descriptors[k as usize], &b.descriptors[j as usize]),
                    )
                }),
        );
        k1 == i && (d2 == i64::MAX || (d1 as f64) < r2 * d2 as f64)
    };
    let mut out = seeds.to_vec();
    for (i, j, shift) in found {
        if claim[j as usize].is_some_and(|(_, k)| k == i) && back(i, j, shift, &mut cand) {
            out.push((i, j));
        }
    }
    out.sort_unstable();
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::features::{Descriptor, Keypoint};

    fn kp(x: f64, y: f64) -> Keypoint {
        Keypoint {
            x,
            y,
            size: 4.0,
            angle: 0.0,
            response: 1.0,
        }
    }

    fn desc(v: u8, w: u8) -> Descriptor {
        let mut d = [0u8; 128];
        d[0] = v;
        d[1] = w;
        d
    }

    /// Image b is image a moved 100 px right (F of a pure x translation: epipolar lines are
    /// the rows). Seeds on a 5 × 5 grid; one extra keypoint of a whose descriptor also has a
    /// look-alike far away in b (a global ratio test would refuse it), a candidate off its
    /// row (the epipolar test removes it) and another feature on it.
    #[test]
    fn guided_search_finds_a_repeated_feature_where_its_neighbours_go() {
        let mut a = Features::default();
        let mut b = Features::default();
        let mut seeds = Vec::new();
        for r in 0..5 {
            for c in 0..5 {
                let (x, y) = (50.0 + 100.0 * c as f64, 50.0 + 100.0 * r as f64);
                let d = desc(10 * (r * 5 + c) as u8, 0);
                seeds.push((a.keypoints.len() as u32, b.keypoints.len() as u32));
                a.keypoints.push(kp(x, y));
                a.descriptors.push(d);
                b.keypoints.push(kp(x + 100.0, y));
                b.descriptors.push(d);
            }
        }
        let ia = a.keypoints.len() as u32;
        a.keypoints.push(kp(230.0, 260.0));
        a.descriptors.push(desc(0, 200));
        let jb = b.keypoints.len() as u32;
        b.keypoints.push(kp(330.5, 260.0)); // the true position, half a pixel off
        b.descriptors.push(desc(0, 198));
        b.keypoints.push(kp(330.0, 275.0)); // off the epipolar line, identical descriptor
        b.descriptors.push(desc(0, 200));
        b.keypoints.push(kp(345.0, 260.0)); // on the line, another feature
        b.descriptors.push(desc(0, 100));
        b.keypoints.push(kp(900.0, 900.0)); // far away, identical descriptor
        b.descriptors.push(desc(0, 200));
        let f = Matrix3::new(0.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0);
        let o = GuidedOptions {
            radius_px: 30.0,
            epipolar_px: 2.0,
            ratio: 0.8,
            neighbours: 4,
            duplicate_px: 1.0,
        };
        let m = guided(&a, &b, &f, &seeds, &o);
        assert_eq!(m.len(), seeds.len() + 1);
        assert!(m.contains(&(ia, jb)));
        // Without the epipolar test the identical descriptor off the line would win.
        let loose = GuidedOptions {
            epipolar_px: 100.0,
            ..o
        };
        let m = guided(&a, &b, &f, &seeds, &loose);
        assert!(m.contains(&(ia, jb + 1)));
    }
}
