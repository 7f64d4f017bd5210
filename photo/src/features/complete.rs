//! Track completion: a track seen in some photos is looked for in each other photo that has a
//! verified pair with at least two of them. There the point must lie on the epipolar line of
//! every such track photo and near where that photo's verified neighbours move; several lines
//! cross at one place, so far fewer look-alikes remain than pair by pair, and the nearest
//! descriptor among the keypoints left (its worst distance to the track's descriptors) is
//! taken when it passes the ratio test against the second. A point in photos A and B is so
//! found in C, also when A–C and B–C matching alone did not take it. Where the lines cross
//! clearly and no keypoint is taken there, the place is handed back (a [`Miss`]) to be
//! measured by the track's patch.
//!
//! Only keypoints in no track (nor within a few pixels of one) are taken; a keypoint two
//! tracks want goes to the closer descriptor. Deterministic: tracks are searched in parallel
//! and the claims resolved in a fixed order.

use super::epipolar::sampson;
use super::matching::Match;
use super::near::{dist2, nearest_two, xy, Grid, Mover};
use super::tracks::{Node, Tracks};
use super::Features;
use nalgebra::{Matrix3, Vector2};
use rayon::prelude::*;

/// A verified pair of images and its geometry.
#[derive(Clone, Copy, Debug)]
pub struct PairGeometry<'a> {
    /// First image.
    pub a: usize,
    /// Second image.
    pub b: usize,
    /// Fundamental matrix, x_bᵀ·F·x_a = 0 (photograph pixels).
    pub f: Matrix3<f64>,
    /// The pair's verified matches (keypoints of a, of b).
    pub matches: &'a [Match],
    /// Largest Sampson distance of a point on its epipolar line, pixels.
    pub epipolar_px: f64,
}

/// How tracks are completed.
#[derive(Clone, Copy, Debug)]
pub struct CompleteOptions {
    /// Search radius around the predicted position, in the pairs' epipolar thresholds.
    pub radius: f64,
    /// Ratio test among the candidates (distance, not squared).
    pub ratio: f64,
    /// Verified matches whose median displacement predicts a point's position.
    pub neighbours: usize,
    /// Fewest track photos with a verified pair to the photo searched (each gives a line).
    pub min_views: usize,
    /// Keypoints this close to a track's keypoint are taken as that keypoint, pixels.
    pub duplicate_px: f64,
    /// A lone candidate is taken when two of the lines cross at this angle or more, degrees,
    /// and its distance² to the track is at most `lone_factor` times the largest between
    /// the track's own descriptors.
    pub min_crossing: f64,
    /// See `min_crossing` (0: no lone candidate is taken).
    pub lone_factor: f64,
}

/// One direction of a verified pair: from an image to another.
struct Edge {
    to: usize,
    pair: usize,
    forward: bool,
    mover: Mover,
}

impl Edge {
    /// Sampson distance of `p` (in the edge's first image) and `q` (in its second).
    fn sampson(&self, pairs: &[PairGeometry], p: &Vector2<f64>, q: &Vector2<f64>) -> f64 {
        let f = &pairs[self.pair].f;
        if self.forward {
            sampson(f, p, q)
        } else {
            sampson(f, q, p)
        }
    }
}

/// Per image: its keypoint positions, a grid over them, and which are taken by a track.
struct Image {
    points: Vec<Vector2<f64>>,
    grid: Grid,
    used: Vec<bool>,
}

fn images(features: &[&Features], tracks: &Tracks, o: &CompleteOptions, cell: f64) -> Vec<Image> {
    let mut out: Vec<Image> = features
        .iter()
        .map(|f| {
            let points: Vec<Vector2<f64>> = f.keypoints.iter().map(xy).collect();
            let grid = Grid::new(&points, cell);
            let used = vec![false; points.len()];
            Image { points, grid, used }
        })
        .collect();
    let mut buf = Vec::new();
    for &(i, k) in tracks.tracks.iter().flatten() {
        let im = &mut out[i];
        let p = im.points[k as usize];
        im.grid.within(&im.points, &p, o.duplicate_px, &mut buf);
        im.used[k as usize] = true;
        buf.iter().for_each(|&j| im.used[j as usize] = true);
    }
    out
}

/// The edges leaving each image, both directions of every pair.
fn edges(
    features: &[&Features],
    pairs: &[PairGeometry],
    o: &CompleteOptions,
    cell: f64,
) -> Vec<Vec<Edge>> {
    let built: Vec<[Edge; 2]> = pairs
        .par_iter()
        .enumerate()
        .map(|(n, p)| {
            let (fa, fb) = (features[p.a], features[p.b]);
            let pa: Vec<Vector2<f64>> = p
                .matches
                .iter()
                .map(|&(i, _)| xy(&fa.keypoints[i as usize]))
                .collect();
            let pb: Vec<Vector2<f64>> = p
                .matches
                .iter()
                .map(|&(_, j)| xy(&fb.keypoints[j as usize]))
                .collect();
            let extent = |f: &Features| {
                f.keypoints
                    .iter()
                    .fold((1.0f64, 1.0f64), |(w, h), k| (w.max(k.x), h.max(k.y)))
            };
            let ab = Mover::new(pa.clone(), &pb, o.neighbours, extent(fa), cell);
            let ba = Mover::new(pb, &pa, o.neighbours, extent(fb), cell);
            [
                Edge {
                    to: p.b,
                    pair: n,
                    forward: true,
                    mover: ab,
                },
                Edge {
                    to: p.a,
                    pair: n,
                    forward: false,
                    mover: ba,
                },
            ]
        })
        .collect();
    let mut out: Vec<Vec<Edge>> = (0..features.len()).map(|_| Vec::new()).collect();
    for (p, [ab, ba]) in pairs.iter().zip(built) {
        out[p.a].push(ab);
        out[p.b].push(ba);
    }
    out
}

/// A keypoint proposed for a track: (image, keypoint, descriptor distance², track).
type Claim = (usize, u32, i64, usize);

/// The keypoint of image `c` that completes `track`, seen there through `views` (track
/// member, edge from the member's image to `c`).
#[allow(clippy::too_many_arguments)]
fn search(
    c: usize,
    views: &[(Node, &Edge)],
    features: &[&Features],
    pairs: &[PairGeometry],
    imgs: &[Image],
    o: &CompleteOptions,
    buf: &mut Vec<u32>,
    cand: &mut Vec<u32>,
) -> Outcome {
    let mut predicted = Vec::with_capacity(views.len());
    let mut radius = 0.0f64;
    for &((i, k), e) in views {
        let p = imgs[i].points[k as usize];
        let Some(shift) = e.mover.shift(&p, buf) else {
            return Outcome::Nothing;
        };
        predicted.push(p + shift);
        radius = radius.max(o.radius * pairs[e.pair].epipolar_px);
    }
    let centre = predicted.iter().sum::<Vector2<f64>>() / predicted.len() as f64;
    if predicted.iter().any(|q| (q - centre).norm() > radius) {
        return Outcome::Nothing; // the views disagree about where the point is
    }
    let im = &imgs[c];
    im.grid.within(&im.points, &centre, radius, cand);
    let (d1, d2, k1) = nearest_two(
        cand.iter()
            .filter(|&&k| {
                let q = &im.points[k as usize];
                !im.used[k as usize]
                    && views.iter().all(|&((i, ki), e)| {
                        let p = &imgs[i].points[ki as usize];
                        e.sampson(pairs, p, q) <= pairs[e.pair].epipolar_px
                    })
            })
            .map(|&k| {
                let d = features[c].descriptors[k as usize];
                let worst = views
                    .iter()
                    .map(|&((i, ki), _)| dist2(&features[i].descriptors[ki as usize], &d))
                    .max()
                    .unwrap_or(i64::MAX);
                (k, worst)
            }),
    );
    let crossed = || crossing(views, pairs, imgs) >= o.min_crossing.to_radians().sin();
    let passes = match (k1 == u32::MAX, d2 == i64::MAX) {
        (true, _) => false,
        // A lone candidate: taken where the lines cross at a clear angle and its descriptor is
        // no further from the track's than the track's own are from each other.
        (false, true) => crossed() && (d1 as f64) <= o.lone_factor * spread(views, features) as f64,
        (false, false) => (d1 as f64) < o.ratio * o.ratio * d2 as f64,
    };
    if passes {
        return Outcome::Found(k1, d1);
    }
    // No keypoint there, or none told apart: where the lines cross clearly the point may still
    // be measured by its patch (on Brighton Beach those told apart from nothing brought the
    // tracks in three or more photos from 7,038 to 7,216; the textured block stayed 99.35 %
    // right).
    match crossed()
        .then(|| intersection(views, pairs, imgs))
        .flatten()
    {
        Some(x) if (x - centre).norm() <= radius => Outcome::Miss(x),
        _ => Outcome::Nothing,
    }
}

/// What the search of a track in a photo found.
enum Outcome {
    /// A keypoint and its descriptor distance².
    Found(u32, i64),
    /// No keypoint told apart where the lines cross (there).
    Miss(Vector2<f64>),
    /// Nothing usable.
    Nothing,
}

/// The epipolar line of each view in the photo searched, normalised (a·x + b·y + c = 0 with
/// a² + b² = 1).
fn lines(
    views: &[(Node, &Edge)],
    pairs: &[PairGeometry],
    imgs: &[Image],
) -> Vec<nalgebra::Vector3<f64>> {
    views
        .iter()
        .filter_map(|&((i, k), e)| {
            let p = imgs[i].points[k as usize];
            let x = nalgebra::Vector3::new(p.x, p.y, 1.0);
            let f = &pairs[e.pair].f;
            let l = if e.forward { f * x } else { f.transpose() * x };
            let n = l.x.hypot(l.y);
            (n > 0.0).then(|| l / n)
        })
        .collect()
}

/// The point nearest to the views' epipolar lines in the least-squares sense.
fn intersection(
    views: &[(Node, &Edge)],
    pairs: &[PairGeometry],
    imgs: &[Image],
) -> Option<Vector2<f64>> {
    let mut n = nalgebra::Matrix2::zeros();
    let mut b = Vector2::zeros();
    for l in lines(views, pairs, imgs) {
        let a = Vector2::new(l.x, l.y);
        n += a * a.transpose();
        b -= a * l.z;
    }
    n.try_inverse().map(|inv| inv * b)
}

/// The largest sine of the angle between two of the views' epipolar lines in the photo
/// searched (0 with one view or parallel lines).
fn crossing(views: &[(Node, &Edge)], pairs: &[PairGeometry], imgs: &[Image]) -> f64 {
    let normals = lines(views, pairs, imgs);
    let mut best = 0.0f64;
    for (n, u) in normals.iter().enumerate() {
        for v in &normals[n + 1..] {
            best = best.max((u.x * v.y - u.y * v.x).abs());
        }
    }
    best
}

/// The largest descriptor distance² between two of the views' keypoints.
fn spread(views: &[(Node, &Edge)], features: &[&Features]) -> i64 {
    let d = |(i, k): Node| &features[i].descriptors[k as usize];
    let mut worst = 0;
    for (n, &(u, _)) in views.iter().enumerate() {
        for &(v, _) in &views[n + 1..] {
            worst = worst.max(dist2(d(u), d(v)));
        }
    }
    worst
}

/// The claims of one track on the photos it is not in.
fn claims_of(
    t: usize,
    track: &[Node],
    features: &[&Features],
    pairs: &[PairGeometry],
    edges: &[Vec<Edge>],
    imgs: &[Image],
    o: &CompleteOptions,
) -> (Vec<Claim>, Vec<Miss>) {
    let mut views: Vec<(usize, Node, &Edge)> = track
        .iter()
        .flat_map(|&n| edges[n.0].iter().map(move |e| (e.to, n, e)))
        .filter(|(c, _, _)| !track.iter().any(|n| n.0 == *c))
        .collect();
    views.sort_by_key(|&(c, n, _)| (c, n));
    let (mut buf, mut cand) = (Vec::new(), Vec::new());
    let (mut out, mut misses) = (Vec::new(), Vec::new());
    for group in views.chunk_by(|x, y| x.0 == y.0) {
        if group.len() < o.min_views.max(1) {
            continue;
        }
        let c = group[0].0;
        let v: Vec<(Node, &Edge)> = group.iter().map(|&(_, n, e)| (n, e)).collect();
        match search(c, &v, features, pairs, imgs, o, &mut buf, &mut cand) {
            Outcome::Found(k, d) => out.push((c, k, d, t)),
            Outcome::Miss(at) => misses.push(Miss {
                track: t,
                image: c,
                at,
            }),
            Outcome::Nothing => {}
        }
    }
    (out, misses)
}

/// A track not found in a photo for want of a keypoint (or of one told apart from the others)
/// where its epipolar lines cross clearly: the place to measure it otherwise (by its patch).
#[derive(Clone, Copy, Debug)]
pub struct Miss {
    /// The track (index into the tracks completed).
    pub track: usize,
    /// The photo.
    pub image: usize,
    /// Where the track's epipolar lines cross in the photo, pixels.
    pub at: Vector2<f64>,
}

/// Complete `tracks` (keypoints of `features`, joined by the verified `pairs`) in the other
/// photos that see them; `canon` maps every keypoint to the one measurement of its position
/// (as the tracks were built). Returns the measurements added and the misses (in track
/// order, then photo).
pub fn complete(
    features: &[&Features],
    canon: &[Vec<u32>],
    pairs: &[PairGeometry],
    tracks: &mut Tracks,
    o: &CompleteOptions,
) -> (usize, Vec<Miss>) {
    let cell = pairs
        .iter()
        .map(|p| o.radius * p.epipolar_px)
        .fold(1.0f64, f64::max);
    let imgs = images(features, tracks, o, cell);
    let edges = edges(features, pairs, o, cell);
    let found: Vec<(Vec<Claim>, Vec<Miss>)> = tracks
        .tracks
        .par_iter()
        .enumerate()
        .map(|(t, track)| claims_of(t, track, features, pairs, &edges, &imgs, o))
        .collect();
    let mut claims: Vec<Claim> = Vec::new();
    let mut misses = Vec::new();
    for (c, m) in found {
        claims.extend(
            c.into_iter()
                .map(|(c, k, d, t)| (c, canon[c][k as usize], d, t)),
        );
        misses.extend(m);
    }
    // A keypoint wanted by several tracks goes to the closest descriptor (then the first track).
    claims.sort_unstable_by_key(|&(c, k, d, t)| (c, k, d, t));
    claims.dedup_by_key(|x| (x.0, x.1));
    for &(c, k, _, t) in &claims {
        tracks.tracks[t].push((c, k));
    }
    for t in &mut tracks.tracks {
        t.sort_unstable();
    }
    (claims.len(), misses)
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

    /// F of a pure translation of the camera along x (lines are the rows) and along y (lines
    /// are the columns).
    fn along_x() -> Matrix3<f64> {
        Matrix3::new(0.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0)
    }
    fn along_y() -> Matrix3<f64> {
        Matrix3::new(0.0, 0.0, 1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0)
    }

    /// Three images: b is a moved 100 px right, c is a moved 100 px down. A 5 × 5 grid of
    /// points seen in all three, matched a–b, a–c, b–c. One more point is matched a–b only.
    /// In c it lies where the row line from b and the column line from a cross; c also has a
    /// look-alike on a's column line only, and another feature at the crossing.
    #[test]
    fn a_two_photo_track_is_found_where_two_epipolar_lines_cross() {
        let mut f = [
            Features::default(),
            Features::default(),
            Features::default(),
        ];
        let shift = [(0.0, 0.0), (100.0, 0.0), (0.0, 100.0)];
        for r in 0..5 {
            for col in 0..5 {
                let (x, y) = (50.0 + 100.0 * col as f64, 50.0 + 100.0 * r as f64);
                for (im, s) in f.iter_mut().zip(shift) {
                    im.keypoints.push(kp(x + s.0, y + s.1));
                    im.descriptors.push(desc(10 * (r * 5 + col) as u8, 0));
                }
            }
        }
        let grid: Vec<Match> = (0..25).map(|k| (k, k)).collect();
        let mut ab = grid.clone();
        ab.push((25, 25));
        f[0].keypoints.push(kp(230.0, 260.0));
        f[0].descriptors.push(desc(0, 200));
        f[1].keypoints.push(kp(330.0, 260.0));
        f[1].descriptors.push(desc(0, 201));
        // c: the true point (25), a look-alike on a's column only (26), another feature near
        // the crossing (27).
        f[2].keypoints.push(kp(230.4, 360.0));
        f[2].descriptors.push(desc(0, 198));
        f[2].keypoints.push(kp(230.0, 335.0));
        f[2].descriptors.push(desc(0, 200));
        f[2].keypoints.push(kp(230.9, 359.5));
        f[2].descriptors.push(desc(0, 120));
        let pairs = [
            PairGeometry {
                a: 0,
                b: 1,
                f: along_x(),
                matches: &ab,
                epipolar_px: 1.0,
            },
            PairGeometry {
                a: 0,
                b: 2,
                f: along_y(),
                matches: &grid,
                epipolar_px: 1.0,
            },
            PairGeometry {
                a: 1,
                b: 2,
                // b → c: the camera moves down-left: x_c = x_b − 100, y_c = y_b + 100.
                f: Matrix3::new(0.0, 0.0, 1.0, 0.0, 0.0, 1.0, -1.0, -1.0, 0.0),
                matches: &grid,
                epipolar_px: 1.0,
            },
        ];
        let counts: Vec<usize> = f.iter().map(|x| x.keypoints.len()).collect();
        let mut tracks = crate::features::tracks::build(
            &counts,
            &[
                (0, 1, ab.clone()),
                (0, 2, grid.clone()),
                (1, 2, grid.clone()),
            ],
        );
        assert_eq!(tracks.tracks.len(), 26);
        let canon: Vec<Vec<u32>> = counts.iter().map(|&n| (0..n as u32).collect()).collect();
        let o = CompleteOptions {
            radius: 40.0,
            ratio: 0.8,
            neighbours: 4,
            min_views: 2,
            duplicate_px: 1.0,
            min_crossing: 20.0,
            lone_factor: 0.0,
        };
        let refs: Vec<&Features> = f.iter().collect();
        let (added, _) = complete(&refs, &canon, &pairs, &mut tracks, &o);
        assert_eq!(added, 1);
        let t = tracks.tracks.iter().find(|t| t[0] == (0, 25)).unwrap();
        assert_eq!(t, &vec![(0, 25), (1, 25), (2, 25)]);
        // With one line (a's column) the look-alike on it wins: the second line is what
        // tells them apart.
        let one = CompleteOptions { min_views: 1, ..o };
        let mut tracks = crate::features::tracks::build(&counts, &[(0, 1, ab.clone())]);
        let pairs = [pairs[0], pairs[1]];
        complete(&refs, &canon, &pairs, &mut tracks, &one);
        let t = tracks.tracks.iter().find(|t| t[0] == (0, 25)).unwrap();
        assert_eq!(t, &vec![(0, 25), (1, 25), (2, 26)]);
    }
}
