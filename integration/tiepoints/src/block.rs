//! Tracks across the block: completed in further photos, cut where they disagree with the
//! epipolar geometry of their photos, and the connected components of the photos.

use super::job::{Image, MatchJob, PairResult, COHERENCE_NEIGHBOURS, GUIDED_RADIUS, LONE_FACTOR};
use photo::features::matching::Match;
use photo::features::tracks;

/// Look for every track in the other photos that have verified pairs with two or more of its
/// photos ([`photo::features::complete`]); returns the measurements added and where a track's
/// lines cross with no keypoint there.
pub(super) fn complete_tracks(
    tracks: &mut tracks::Tracks,
    images: &[Image],
    canon: &[Vec<u32>],
    results: &[PairResult],
    verified: &[(usize, usize, Vec<Match>)],
    job: &MatchJob,
) -> (usize, Vec<photo::features::complete::Miss>) {
    use photo::features::complete::{complete, CompleteOptions, PairGeometry};
    if job.complete_ratio <= 0.0 {
        return (0, Vec::new());
    }
    let fs: std::collections::HashMap<(usize, usize), nalgebra::Matrix3<f64>> = results
        .iter()
        .filter_map(|p| p.f.map(|f| ((p.a, p.b), f)))
        .collect();
    let pairs: Vec<PairGeometry> = verified
        .iter()
        .filter_map(|(a, b, m)| {
            Some(PairGeometry {
                a: *a,
                b: *b,
                f: *fs.get(&(*a, *b))?,
                matches: m,
                epipolar_px: job.ransac_px * images[*a].scale.max(images[*b].scale),
            })
        })
        .collect();
    let features: Vec<&photo::features::Features> = images.iter().map(|i| &i.features).collect();
    let o = CompleteOptions {
        radius: GUIDED_RADIUS,
        ratio: job.complete_ratio,
        neighbours: COHERENCE_NEIGHBOURS,
        min_views: 2,
        duplicate_px: job.ransac_px,
        min_crossing: 20.0,
        lone_factor: LONE_FACTOR,
    };
    complete(&features, canon, &pairs, tracks, &o)
}

/// Cut from every track of three or more photos the measurements that disagree with the
/// epipolar geometry of its other photos (each verified pair of the track's photos checks its
/// two measurements, not only the pairs that made the track): the measurement with the most
/// disagreements goes first, until none disagree. Returns the measurements cut.
pub(super) fn consistent_tracks(
    tracks: &mut tracks::Tracks,
    images: &[Image],
    pairs: &[PairResult],
    job: &MatchJob,
) -> usize {
    use photo::features::epipolar::sampson;
    let fs: std::collections::HashMap<(usize, usize), nalgebra::Matrix3<f64>> = pairs
        .iter()
        .filter_map(|p| p.f.map(|f| ((p.a, p.b), f)))
        .collect();
    let px = |(i, k): (usize, u32)| {
        let q = images[i].features.keypoints[k as usize];
        nalgebra::Vector2::new(q.x, q.y)
    };
    let mut cut = 0;
    for t in tracks.tracks.iter_mut().filter(|t| t.len() >= 3) {
        loop {
            let mut bad = vec![0usize; t.len()];
            for x in 0..t.len() {
                for y in x + 1..t.len() {
                    let (a, b) = (t[x], t[y]);
                    let Some(f) = fs.get(&(a.0, b.0)) else {
                        continue;
                    };
                    let tol = job.ransac_px * images[a.0].scale.max(images[b.0].scale);
                    if sampson(f, &px(a), &px(b)) > tol {
                        bad[x] += 1;
                        bad[y] += 1;
                    }
                }
            }
            let (worst, &n) = bad
                .iter()
                .enumerate()
                .max_by(|p, q| p.1.cmp(q.1).then(q.0.cmp(&p.0)))
                .unwrap_or((0, &0));
            if n == 0 {
                break;
            }
            t.remove(worst);
            cut += 1;
        }
    }
    tracks.tracks.retain(|t| t.len() >= 2);
    cut
}

/// Connected components of the images by verified pairs, numbered by size (0 largest).
pub(super) fn components(n: usize, pairs: &[PairResult]) -> Vec<usize> {
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(p: &mut [usize], mut x: usize) -> usize {
        while p[x] != x {
            p[x] = p[p[x]];
            x = p[x];
        }
        x
    }
    for p in pairs.iter().filter(|p| !p.verified.is_empty()) {
        let (x, y) = (root(&mut parent, p.a), root(&mut parent, p.b));
        parent[x.max(y)] = x.min(y);
    }
    let roots: Vec<usize> = (0..n).map(|i| root(&mut parent, i)).collect();
    let mut size = vec![0usize; n];
    roots.iter().for_each(|&r| size[r] += 1);
    let mut order: Vec<usize> = (0..n).filter(|&r| size[r] > 0).collect();
    order.sort_by(|&a, &b| size[b].cmp(&size[a]).then(a.cmp(&b)));
    let mut number = vec![0usize; n];
    for (k, &r) in order.iter().enumerate() {
        number[r] = k;
    }
    roots.iter().map(|&r| number[r]).collect()
}
