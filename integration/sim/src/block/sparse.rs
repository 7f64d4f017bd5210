//! The measurements of `sparse-control`: control points measured image by image as in a real
//! block converted from another tool (most images measure one control point, a few two to
//! five), check points in two to four images each, no tie points.
//!
//! What enters: the weights of 1–5 control points per image, the camera, the exposures and
//! the ground points of [`super::nav`]. What leaves: the measurements (image, point, image
//! coordinates with noise), sorted by image and point. Deterministic per seed.

use super::nav_images::{noisy, seen, Meas, NavImage};
use crate::ground_points::Point;
use crate::rng::Rng;
use nalgebra::Vector2;
use photo::camera::Camera;

/// The number of control points each of `n` images measures: 1..=5 in the proportions of
/// `w` (rounded), in random order.
fn counts(w: &[f64; 5], n: usize, rng: &mut Rng) -> Vec<usize> {
    let total: f64 = w.iter().sum();
    let mut out: Vec<usize> = Vec::with_capacity(n);
    for (k, &x) in w.iter().enumerate() {
        let m = (x / total * n as f64).round() as usize;
        out.extend(std::iter::repeat_n(k + 1, m));
    }
    out.resize(n, 1);
    for i in (1..out.len()).rev() {
        let j = ((rng.uniform() * (i + 1) as f64) as usize).min(i);
        out.swap(i, j);
    }
    out
}

/// `n` of `cands` picked at random (all of them when there are fewer).
fn pick(
    mut cands: Vec<(usize, Vector2<f64>)>,
    n: usize,
    rng: &mut Rng,
) -> Vec<(usize, Vector2<f64>)> {
    let mut out = Vec::new();
    while out.len() < n && !cands.is_empty() {
        let j = ((rng.uniform() * cands.len() as f64) as usize).min(cands.len() - 1);
        out.push(cands.swap_remove(j));
    }
    out
}

/// Each image measures its number of the control points it sees (fewer when it sees fewer);
/// each check point is measured in 2–4 of the images that see it, first those that measure
/// two or more control points (where an operator measured what the image shows).
pub(super) fn measure(
    w: &[f64; 5],
    cam: &Camera,
    images: &[NavImage],
    points: &[Point],
    rng: &mut Rng,
) -> Vec<Meas> {
    let mut meas = Vec::new();
    let counts = counts(w, images.len(), rng);
    let mut rich = vec![false; images.len()];
    for (i, im) in images.iter().enumerate() {
        let n = counts[i];
        let cands: Vec<(usize, Vector2<f64>)> = (0..points.len())
            .filter(|&k| points[k].1 == "gcp")
            .filter_map(|k| seen(cam, &im.2, &points[k].2).map(|xy| (k, xy)))
            .collect();
        let picked = pick(cands, n, rng);
        rich[i] = picked.len() >= 2;
        for (k, xy) in picked {
            meas.push((i, k, noisy(xy, rng)));
        }
    }
    for (k, p) in points.iter().enumerate().filter(|(_, p)| p.1 == "check") {
        let sees: Vec<(usize, Vector2<f64>)> = (0..images.len())
            .filter_map(|i| seen(cam, &images[i].2, &p.2).map(|xy| (i, xy)))
            .collect();
        let n = 2 + (rng.uniform() * 3.0) as usize;
        let (first, rest): (Vec<_>, Vec<_>) = sees.into_iter().partition(|s| rich[s.0]);
        let mut picked = pick(first, n, rng);
        let more = n - picked.len();
        picked.extend(pick(rest, more, rng));
        for (i, xy) in picked {
            meas.push((i, k, noisy(xy, rng)));
        }
    }
    meas.sort_by_key(|a| (a.0, a.1));
    meas
}
