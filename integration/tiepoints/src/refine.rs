//! Sub-pixel measurements: each track's measurements refined by least-squares image matching
//! (`photo::features::lsm`) of a template around its first measurement, so that all of them
//! measure the one physical point that template shows, to a tenth of a pixel, instead of each
//! detector blob centre with its own error of a few tenths.
//!
//! Memory stays bounded by the photos worked on: a first pass decodes each photo once and cuts
//! the templates of the tracks that start in it; a second decodes each photo again and fits
//! every other measurement in it. A measurement whose fit fails (flat, leaves the image,
//! moves more than a few pixels, correlates weakly) keeps its keypoint position.

use super::decode;
use super::job::{Image, MatchJob};
use nalgebra::{Matrix2, Vector2};
use photo::features::lsm::{LsmOptions, Template};
use photo::features::tracks::Tracks;
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// A refined measurement: position (photograph pixels) and its formal σ (pixels).
#[derive(Clone, Copy, Debug)]
pub struct Measured {
    /// Column, row.
    pub px: Vector2<f64>,
    /// Formal σ of the fit.
    pub sigma: f64,
}

/// What refinement did.
#[derive(Clone, Debug, Default)]
pub struct Refinement {
    /// Per track, per measurement (in track order): the refined position, None where the
    /// keypoint's stays (the first measurement of every track: it defines the point).
    pub measured: Vec<Vec<Option<Measured>>>,
    /// Measurements refined.
    pub refined: usize,
    /// Measurements whose fit failed (their keypoint position kept).
    pub kept: usize,
}

/// The rotation by `t` radians.
fn rotation(t: f64) -> Matrix2<f64> {
    Matrix2::new(t.cos(), -t.sin(), t.sin(), t.cos())
}

/// Start maps for the fit: the keypoints' scale ratio and their orientation difference,
/// turned either way (detectors differ in their angle convention).
fn starts(a: &photo::features::Keypoint, b: &photo::features::Keypoint) -> [Matrix2<f64>; 2] {
    let s = if a.size > 0.0 { b.size / a.size } else { 1.0 };
    let d = (b.angle - a.angle).to_radians();
    [rotation(d) * s, rotation(-d) * s]
}

/// Of the start maps `maps`, the one whose template correlates best at `p0` (None without
/// maps).
fn best_start(
    tpl: &Template,
    gray: &photo::features::GrayImage,
    p0: Vector2<f64>,
    maps: impl IntoIterator<Item = Matrix2<f64>>,
) -> Option<Matrix2<f64>> {
    maps.into_iter()
        .map(|a| (tpl.ncc(gray, p0, &a).unwrap_or(-1.0), a))
        .max_by(|x, y| x.0.total_cmp(&y.0))
        .map(|x| x.1)
}

/// Patch size for a photo reduced by `scale`: at most [`PATCH_HALF_PHOTO_PX`] photograph pixels
/// each side, and no fewer than 5 pixels of the image matched in.
fn options(scale: f64) -> LsmOptions {
    let d = LsmOptions::default();
    LsmOptions {
        half: ((PATCH_HALF_PHOTO_PX / scale).floor() as usize).clamp(5, d.half),
        ..d
    }
}

/// Half the side of the largest patch matched, photograph pixels. A patch sees a piece of
/// ground the affine map must fit: with 84-pixel patches (Brighton Beach matched at a
/// quarter size) the self-calibrated focal length came out 6 % longer than with the
/// keypoints alone; at 42 (half size) it agreed with COLMAP's within 1 %.
pub const PATCH_HALF_PHOTO_PX: f64 = 20.0;

/// The template of every track `wanted`, cut around its first measurement (one pass over the
/// photos, each decoded once; `tick` after each photo).
fn templates(
    images: &[Image],
    tracks: &Tracks,
    wanted: &[bool],
    job: &MatchJob,
    decodes: &Decodes,
    tick: &(dyn Fn() + Sync),
) -> Vec<Option<Template>> {
    let mut firsts: Vec<Vec<usize>> = vec![Vec::new(); images.len()];
    for (t, nodes) in tracks.tracks.iter().enumerate() {
        if let (Some(&(i, _)), true) = (nodes.first(), wanted[t]) {
            firsts[i].push(t);
        }
    }
    let cut: Vec<Vec<(usize, Template)>> = (0..images.len())
        .into_par_iter()
        .map(|i| {
            let out = match firsts[i].is_empty() {
                true => Vec::new(),
                false => decodes
                    .get(i, &images[i], job)
                    .map_or(Vec::new(), |(gray, scale)| {
                        firsts[i]
                            .iter()
                            .filter_map(|&t| {
                                let q =
                                    images[i].features.keypoints[tracks.tracks[t][0].1 as usize];
                                let c = Vector2::new(q.x, q.y) / scale;
                                Some((t, Template::cut(&gray, c, &options(scale))?))
                            })
                            .collect()
                    }),
            };
            tick();
            out
        })
        .collect();
    let mut templates: Vec<Option<Template>> = vec![None; tracks.tracks.len()];
    for (t, tpl) in cut.into_iter().flatten() {
        templates[t] = Some(tpl);
    }
    templates
}

/// Refine the measurements of `tracks` (keypoints of `images`); `progress(done, total)`.
pub fn refine(
    images: &[Image],
    tracks: &Tracks,
    job: &MatchJob,
    decodes: &Decodes,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Refinement {
    let n = images.len();
    // Per image: (track, node) pairs, node 0 being the track's template.
    let mut at: Vec<Vec<(usize, usize)>> = vec![Vec::new(); n];
    for (t, nodes) in tracks.tracks.iter().enumerate() {
        for (k, &(i, _)) in nodes.iter().enumerate() {
            at[i].push((t, k));
        }
    }
    let done = std::sync::atomic::AtomicUsize::new(0);
    let tick = || {
        let k = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        progress(k, 2 * n);
    };
    let wanted = vec![true; tracks.tracks.len()];
    let templates = templates(images, tracks, &wanted, job, decodes, &tick);
    let fitted: Vec<Vec<(usize, usize, Option<Measured>)>> = (0..n)
        .into_par_iter()
        .map(|c| {
            let todo: Vec<(usize, usize)> = at[c]
                .iter()
                .copied()
                .filter(|&(t, k)| k > 0 && templates[t].is_some())
                .collect();
            let out = match (todo.is_empty(), decodes.get(c, &images[c], job)) {
                (false, Some((gray, scale))) => todo
                    .iter()
                    .map(|&(t, k)| {
                        let (r, rk) = tracks.tracks[t][0];
                        let q = images[c].features.keypoints[tracks.tracks[t][k].1 as usize];
                        let kr = images[r].features.keypoints[rk as usize];
                        let tpl = templates[t].as_ref().expect("filtered");
                        let p0 = Vector2::new(q.x, q.y) / scale;
                        let a0 = best_start(tpl, &gray, p0, starts(&kr, &q)).expect("two starts");
                        let m = tpl.fit(&gray, p0, &a0, &options(scale)).map(|f| Measured {
                            px: f.position * scale,
                            sigma: f.sigma * scale,
                        });
                        (t, k, m)
                    })
                    .collect(),
                _ => todo.iter().map(|&(t, k)| (t, k, None)).collect(),
            };
            tick();
            out
        })
        .collect();
    let mut r = Refinement {
        measured: tracks.tracks.iter().map(|t| vec![None; t.len()]).collect(),
        ..Refinement::default()
    };
    for (t, k, m) in fitted.into_iter().flatten() {
        match m {
            Some(_) => r.refined += 1,
            None => r.kept += 1,
        }
        r.measured[t][k] = m;
    }
    r
}

/// A decoded grey image and its photograph pixels per pixel.
type Decoded = (Arc<photo::features::GrayImage>, f64);

/// The photos decoded again for patch measurement and refinement, kept up to a memory budget
/// so the two stages decode each photo once where they can (only speed depends on it).
pub struct Decodes {
    budget: usize,
    kept: Mutex<(usize, HashMap<usize, Decoded>)>,
}

impl Decodes {
    /// Keep decoded photos up to `budget` bytes.
    pub fn new(budget: usize) -> Decodes {
        Decodes {
            budget,
            kept: Mutex::new((0, HashMap::new())),
        }
    }

    /// Photo `i` (`im`) decoded as its features were; None when it cannot be read again.
    fn get(&self, i: usize, im: &Image, job: &MatchJob) -> Option<Decoded> {
        if let Some(d) = self.kept.lock().ok()?.1.get(&i) {
            return Some(d.clone());
        }
        // At the features' size: at full size (Brighton Beach, 4000 px) the same patches see
        // half the ground and the adjusted image RMS was 0.72 px against 0.66.
        let d = decode::decode(&im.meta.path, job.max_image_size).ok()?;
        let out = (Arc::new(d.gray), d.scale);
        if let Ok(mut k) = self.kept.lock() {
            let bytes = out.0.data.len();
            if k.0 + bytes <= self.budget {
                k.0 += bytes;
                k.1.insert(i, out.clone());
            }
        }
        Some(out)
    }
}

/// Factor on the formal σ of a fit: the residuals of neighbouring pixels are correlated (the
/// image is interpolated and blurred), so the formal σ is several times too small.
pub const FORMAL_SIGMA_FACTOR: f64 = 3.0;

/// Least σ of a refined measurement, pixels of the image matched in (interpolation and the
/// affine model's limits).
pub const SIGMA_FLOOR_PX: f64 = 0.1;

/// The σ given to a refined measurement of formal σ `formal` (photograph pixels) in a photo
/// reduced by `scale`. With these weights (keypoint measurements keep 0.5 px of the reduced
/// image) the textured block's centres came out 1.45× the exact-point run's (1.74× with
/// every tie at one σ); on Brighton Beach the image points' variance factor is 1.46 (real
/// JPEGs match worse than the formal σ says: the adjustment scales the group).
pub fn sigma(formal: f64, scale: f64) -> f64 {
    (SIGMA_FLOOR_PX * scale).hypot(FORMAL_SIGMA_FACTOR * formal)
}

/// Measure each track where completion found its epipolar lines crossing but no keypoint
/// (`misses`): its template fitted there (from the rotation of a quarter turn that
/// correlates best at the start: nadir strips are flown both ways). A fit becomes a new
/// keypoint of the photo (the track's first descriptor, its size and orientation carried by
/// the fit) and a measurement of the track, unless another track is already measured within
/// two pixels there (then it is the same point, or too close to tell). Returns the
/// measurements added.
pub fn measure_misses(
    images: &mut [Image],
    tracks: &mut Tracks,
    misses: &[photo::features::complete::Miss],
    job: &MatchJob,
    decodes: &Decodes,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> usize {
    let n = images.len();
    let mut wanted = vec![false; tracks.tracks.len()];
    let mut by_image: Vec<Vec<&photo::features::complete::Miss>> = vec![Vec::new(); n];
    for m in misses {
        wanted[m.track] = true;
        by_image[m.image].push(m);
    }
    let done = std::sync::atomic::AtomicUsize::new(0);
    let tick = || {
        let k = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        progress(k, 2 * n);
    };
    let templates = templates(images, tracks, &wanted, job, decodes, &tick);
    let imgs: &[Image] = images;
    let found: Vec<Vec<(usize, photo::features::Keypoint)>> = (0..n)
        .into_par_iter()
        .map(|c| {
            let todo: Vec<_> = by_image[c]
                .iter()
                .filter(|m| templates[m.track].is_some())
                .collect();
            let out = match (todo.is_empty(), decodes.get(c, &imgs[c], job)) {
                (false, Some((gray, scale))) => todo
                    .iter()
                    .filter_map(|m| {
                        let tpl = templates[m.track].as_ref()?;
                        let (r, rk) = tracks.tracks[m.track][0];
                        let kr = imgs[r].features.keypoints[rk as usize];
                        let p0 = m.at / scale;
                        let quarter_turns =
                            (0..4).map(|q| rotation(q as f64 * std::f64::consts::FRAC_PI_2));
                        let a0 = best_start(tpl, &gray, p0, quarter_turns)?;
                        let f = tpl.fit(&gray, p0, &a0, &options(scale))?;
                        let px = f.position * scale;
                        Some((
                            m.track,
                            photo::features::Keypoint {
                                x: px.x,
                                y: px.y,
                                size: kr.size * f.affine.determinant().abs().sqrt(),
                                angle: kr.angle
                                    + f.affine[(1, 0)].atan2(f.affine[(0, 0)]).to_degrees(),
                                response: 0.0,
                            },
                        ))
                    })
                    .collect(),
                _ => Vec::new(),
            };
            tick();
            out
        })
        .collect();
    // The keypoints of each photo already in a track, gathered once (scanning every track
    // for every photo made this quadratic in the block).
    let mut in_tracks: Vec<Vec<u32>> = vec![Vec::new(); n];
    for &(i, k) in tracks.tracks.iter().flatten() {
        in_tracks[i].push(k);
    }
    let mut added = 0;
    for (c, new) in found.into_iter().enumerate() {
        // Measurements of tracks already in this photo, on a 2-pixel grid.
        let mut taken: std::collections::HashSet<(i64, i64)> = Default::default();
        let cell = |x: f64, y: f64| ((x / 2.0).floor() as i64, (y / 2.0).floor() as i64);
        let near = |taken: &std::collections::HashSet<(i64, i64)>, x: f64, y: f64| {
            let (i, j) = cell(x, y);
            (-1..=1).any(|di| (-1..=1).any(|dj| taken.contains(&(i + di, j + dj))))
        };
        for &k in &in_tracks[c] {
            let q = images[c].features.keypoints[k as usize];
            taken.insert(cell(q.x, q.y));
        }
        for (t, kp) in new {
            if near(&taken, kp.x, kp.y) {
                continue;
            }
            taken.insert(cell(kp.x, kp.y));
            let (r, rk) = tracks.tracks[t][0];
            let d = images[r].features.descriptors[rk as usize];
            let f = &mut images[c].features;
            f.keypoints.push(kp);
            f.descriptors.push(d);
            images[c].measured += 1;
            tracks.tracks[t].push((c, f.keypoints.len() as u32 - 1));
            tracks.tracks[t].sort_unstable();
            added += 1;
        }
    }
    added
}
