//! Start values from tie points alone, for blocks where no image can start from its own data
//! (no GNSS with attitude or strip, no compass, fewer than three control points per image):
//! the relative orientation of the best pair (most shared points, enough parallax; five-point
//! essential matrix with RANSAC, [`photo::relative`]) seeds the block, `start` grows it by
//! resection on intersected tie points with a local bundle adjustment each time it has grown
//! by a fifth ([`local_bundle`]), and the grown block is placed by a similarity onto
//! the control points it intersects or the GNSS centres of its images (a free network stays
//! in the arbitrary frame of the pair: first camera at the origin, nadir, 100 units above the
//! median point).
//!
//! What enters: the project, the frame, the measurements by point, the images to skip. What
//! leaves: the two seed poses, and the similarity placing a grown block.

use super::frame::LocalFrame;
use super::input::ControlAxes;
use super::project::{PointKind, Project};
use super::rays::{intersect_point, Rays};
use nalgebra::{Matrix3, Vector3};
use photo::camera::Pose;
use photo::relative::{relative_orientation, similarity};
use photo::resection::ray;
use std::collections::BTreeMap;

/// A similarity: scale, rotation, shift (x ↦ s·R·x + t).
pub(super) type Similarity = (f64, Matrix3<f64>, Vector3<f64>);

/// Pairs tried, by the number of points they share.
const PAIRS_TRIED: usize = 10;
/// Fewest agreeing points for a seed pair.
const MIN_INLIERS: usize = 30;
/// Median intersection angle below which a pair's depths are too uncertain, radians (1°).
const MIN_PARALLAX: f64 = 0.0175;
/// Median depth of the seed pair's points, in the free network's units.
const SEED_DEPTH: f64 = 100.0;

/// Image pairs by the number of points measured in both (most first; ties by index).
fn pairs_by_shared(p: &Project, rays: &Rays, skip: &[bool]) -> Vec<((usize, usize), usize)> {
    let mut count: BTreeMap<(usize, usize), usize> = BTreeMap::new();
    for ks in rays.values() {
        let mut ims: Vec<usize> = ks
            .iter()
            .map(|&k| p.measurements[k].image)
            .filter(|&i| !skip[i])
            .collect();
        ims.sort_unstable();
        ims.dedup();
        for (x, &i) in ims.iter().enumerate() {
            for &j in &ims[x + 1..] {
                *count.entry((i, j)).or_default() += 1;
            }
        }
    }
    let mut v: Vec<_> = count.into_iter().collect();
    v.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    v
}

/// The rays of the points images `i` and `j` both measure, in each camera's frame.
fn shared_rays(
    p: &Project,
    rays: &Rays,
    i: usize,
    j: usize,
) -> (Vec<Vector3<f64>>, Vec<Vector3<f64>>) {
    let cam = |im: usize| &p.cameras[p.images[im].camera].camera;
    let (mut a, mut b) = (Vec::new(), Vec::new());
    for ks in rays.values() {
        let find = |im: usize| {
            ks.iter()
                .map(|&k| &p.measurements[k])
                .find(|m| m.image == im)
        };
        if let (Some(mi), Some(mj)) = (find(i), find(j)) {
            a.push(ray(cam(i), &mi.xy));
            b.push(ray(cam(j), &mj.xy));
        }
    }
    (a, b)
}

/// The median of `v` (empty: 0).
fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The seed of a block: the two start poses and the number of points that agree with them.
pub(super) type Seed = ([(usize, Pose); 2], usize);

/// The two start poses of the best pair: of the most connected pairs, the one with most
/// points agreeing with its relative orientation, weighted by parallax up to 3°.
pub(super) fn seed_pair(p: &Project, rays: &Rays, skip: &[bool]) -> Option<Seed> {
    let mut best: Option<(f64, Seed)> = None;
    for ((i, j), n) in pairs_by_shared(p, rays, skip).into_iter().take(PAIRS_TRIED) {
        if n < MIN_INLIERS {
            break;
        }
        let (a, b) = shared_rays(p, rays, i, j);
        let cam = &p.cameras[p.images[i].camera].camera;
        let sigma = p.cameras[p.images[i].camera].sigma_px.max(0.5) * cam.pixel / cam.f;
        let seed = (i as u64) << 32 | j as u64;
        let Some(rel) = relative_orientation(&a, &b, 4.0 * sigma, MIN_INLIERS, seed) else {
            continue;
        };
        let second = &rel.second;
        let (mut angles, mut depths) = (Vec::new(), Vec::new());
        for &k in &rel.inliers {
            let (ra, rb) = (a[k], second.r * b[k]);
            angles.push(ra.dot(&rb).clamp(-1.0, 1.0).acos());
            // Depth along ray a of the point nearest both rays (baseline of length 1).
            let c = second.centre;
            let (aa, ab, bb) = (1.0, ra.dot(&rb), 1.0);
            let (d, e) = (ra.dot(&c), rb.dot(&c));
            let den = aa * bb - ab * ab;
            if den > 1e-12 {
                depths.push((d * bb - ab * e) / den);
            }
        }
        let parallax = median(angles);
        if parallax < MIN_PARALLAX {
            continue;
        }
        let score = rel.inliers.len() as f64 * (parallax / (3.0 * MIN_PARALLAX)).min(1.0);
        let depth = median(depths);
        if depth <= 0.0 {
            continue;
        }
        let scale = SEED_DEPTH / depth;
        let poses = [
            (
                i,
                Pose {
                    r: Matrix3::identity(),
                    centre: Vector3::new(0.0, 0.0, SEED_DEPTH),
                },
            ),
            (
                j,
                Pose {
                    r: second.r,
                    centre: Vector3::new(0.0, 0.0, SEED_DEPTH) + second.centre * scale,
                },
            ),
        ];
        if best.as_ref().is_none_or(|b| score > b.0) {
            best = Some((score, (poses, rel.inliers.len())));
        }
    }
    best.map(|b| b.1)
}

/// The similarity (scale, rotation, shift) that places a block grown from a seed pair: onto
/// the control points it intersects (≥ 3), else onto the GNSS antenna positions of its
/// images (≥ 3, lever arm neglected), with what it was placed on; `None` for a free
/// network.
pub(super) fn placement(
    p: &Project,
    frame: &LocalFrame,
    rays: &Rays,
    start: &[Option<Pose>],
    antenna_of: &[Option<usize>],
) -> Option<(Similarity, String)> {
    let (mut from, mut to) = (Vec::new(), Vec::new());
    for g in &p.ground {
        if g.kind != PointKind::Control || g.axes != ControlAxes::All {
            continue;
        }
        let Some(ks) = rays.get(g.id.as_str()) else {
            continue;
        };
        if let Some(x) = intersect_point(p, ks, |i| start[i].as_ref()) {
            from.push(x);
            to.push(frame.to_local(&g.pos));
        }
    }
    let mut what = format!("{} control points", from.len());
    if from.len() < 3 {
        (from, to) = (Vec::new(), Vec::new());
        for (i, s) in start.iter().enumerate() {
            if let (Some(s), Some(k)) = (s, antenna_of[i]) {
                from.push(s.centre);
                to.push(frame.to_local(&p.antennas[k].pos));
            }
        }
        what = format!("{} GNSS centres", from.len());
    }
    similarity(&from, &to).map(|s| (s, what))
}

/// `start` moved by the similarity `(s, r, t)`: centres mapped, rotations turned.
pub(super) fn place(start: &mut [Option<Pose>], (s, r, t): Similarity) {
    for pose in start.iter_mut().flatten() {
        pose.centre = r * pose.centre * s + t;
        pose.r = r * pose.r;
    }
}

/// The block has grown by this factor since its last local bundle adjustment: adjust again.
pub(super) const BA_GROWTH: f64 = 1.2;

/// A bundle adjustment of the started images and the tie points they intersect, in the
/// block's own frame (inner constraints over the centres keep it there; cameras as given;
/// Huber loss against wrong ties), so that the growth resects on refined points and does not
/// drift. The start values are kept when it fails.
pub(super) fn local_bundle(p: &Project, rays: &Rays, start: &mut [Option<Pose>]) {
    use photo::factors::ImagePoint;
    use photo::lsq::{Group, ImageId, Key, Loss, Noise, Options, PointId, Problem, Value};
    let mut pr = Problem::new(Options {
        max_iterations: 100,
        function_tolerance: 1e-8,
        ..Options::default()
    });
    let (mut ids, mut centres) = (Vec::new(), Vec::new());
    for (i, s) in start.iter().enumerate() {
        if let Some(s) = s {
            if pr
                .add_block(Key::Pose(ImageId::from(i)), Value::Pose(*s))
                .is_err()
            {
                return;
            }
            ids.push(ImageId::from(i));
            centres.push(s.centre);
        }
    }
    for (k, ks) in rays.values().enumerate() {
        let Some(x) = intersect_point(p, ks, |i| start[i].as_ref()) else {
            continue;
        };
        let key = Key::Point(PointId::from(k));
        if pr.add_block(key, Value::point(&x)).is_err() {
            return;
        }
        for &m in ks {
            let ms = &p.measurements[m];
            if start[ms.image].is_none() {
                continue;
            }
            let cam = p.cameras[p.images[ms.image].camera].camera;
            let f = ImagePoint::new(cam, ImageId::from(ms.image), PointId::from(k), ms.xy);
            if pr
                .add_factor(f, Noise::isotropic(2, ms.sigma), Loss::Huber(3.0), Group(0))
                .is_err()
            {
                return;
            }
        }
    }
    let Some(datum) = photo::datum::InnerConstraints::new(&ids, &centres, true) else {
        return;
    };
    let noise = datum.noise();
    if pr
        .add_factor(datum, noise, Loss::Trivial, Group(1))
        .is_err()
    {
        return;
    }
    if pr.solve().is_err() {
        return;
    }
    for id in ids {
        if let Some(Value::Pose(pose)) = pr.value(Key::Pose(id)) {
            start[id.index()] = Some(*pose);
        }
    }
}
