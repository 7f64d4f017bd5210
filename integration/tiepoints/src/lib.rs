#![deny(missing_docs)]
//! # tiepoints — photographs in, a block of tie points out
//!
//! `ppkat match`: automatic tie points from a folder of photographs, written as a ppkat
//! project that `ppkat adjust` runs as it is.
//!
//! Stages: metadata of every photo ([`meta`]; EXIF and DJI XMP), cameras ([`camera`]),
//! positions (an exposures table from [`positions`] before EXIF GPS), features of every photo
//! decoded at a reduced size ([`decode`], `photo::features`; one photo per thread at a time,
//! only keypoints and descriptors kept), pairs ([`pairs`]), matching and RANSAC per pair,
//! tracks, their completion and consistency (`block`), sub-pixel measurements
//! ([`refine`]), the connected block, and the project ([`project`]) with a report
//! ([`report`]).
//!
//! Every photo left out is named with its reason; images not connected to the main block are
//! named too. Deterministic: parallel stages collect in input order.

mod block;
pub mod cache;
pub mod camera;
pub mod decode;
mod job;
mod matched;
pub mod meta;
pub mod pair_cache;
pub mod pairs;
pub mod positions;
pub mod project;
pub mod refine;
pub mod report;

use photo::features::epipolar::{coherent, verify, RansacOptions};
use photo::features::guided::{guided, GuidedOptions};
use photo::features::matching::{match_descriptors, Match};
use photo::features::{extract, tracks, FeatureOptions};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

pub use job::{
    Image, MatchError, MatchJob, PairResult, COHERENCE_NEIGHBOURS, DECODED_BUDGET, GUIDED_RADIUS,
    LONE_FACTOR,
};
pub use matched::Matched;
pub use pairs::PairMode;

/// The photographs of a folder (JPEG, PNG by extension), sorted by name; other files counted.
fn list(dir: &Path) -> Result<(Vec<PathBuf>, usize), MatchError> {
    let rd = std::fs::read_dir(dir).map_err(|e| {
        MatchError::Input(format!("{}: cannot read the folder: {e}", dir.display()))
    })?;
    let mut photos = Vec::new();
    let mut other = 0;
    for e in rd.flatten() {
        let p = e.path();
        if !p.is_file() {
            continue;
        }
        let ext = p
            .extension()
            .map(|x| x.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        if matches!(ext.as_str(), "jpg" | "jpeg" | "png") {
            photos.push(p);
        } else {
            other += 1;
        }
    }
    photos.sort();
    Ok((photos, other))
}

/// Where a photo's features came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Source {
    /// Extracted (and cached, when a cache is kept and could be written).
    Extracted { cached: bool },
    /// Read from the cache.
    Cache,
}

/// The features of one photo: from the cache when it holds them under the photo's key, else
/// extracted (and stored in the cache).
fn features_of(
    path: &Path,
    job: &MatchJob,
    opts: &FeatureOptions,
) -> Result<(cache::Cached, Source, Option<u64>), String> {
    let key = (job.cache.is_some() || job.shared_cache.is_some())
        .then(|| cache::key(path, job.max_image_size, opts).ok())
        .flatten();
    let slot = job
        .cache
        .as_ref()
        .zip(key)
        .map(|((old, new), key)| (cache::path(old, path), cache::path(new, path), key));
    let shared = job.shared_cache.as_ref().zip(key);
    // The project's own cache first: a rerun links its files instead of writing them.
    if let Some((old, new, key)) = &slot {
        if let Some(c) = cache::load(old, *key) {
            if old != new {
                // The old run's folder is replaced when this run commits: keep the file.
                let _ = std::fs::remove_file(new);
                if std::fs::hard_link(old, new).is_err() {
                    let _ = cache::store(new, *key, &c);
                }
            }
            return Ok((c, Source::Cache, Some(*key)));
        }
    }
    if let Some((dir, key)) = shared {
        if let Some(c) = cache::load(&cache::shared_path(dir, key), key) {
            if let Some((_, new, _)) = &slot {
                let _ = cache::store(new, key, &c);
            }
            return Ok((c, Source::Cache, Some(key)));
        }
    }
    let d = decode::decode(path, job.max_image_size)?;
    let c = cache::Cached {
        size: d.full,
        scale: d.scale,
        features: extract(&d.gray, d.scale, opts),
    };
    let cached = slot.is_some_and(|(_, new, key)| cache::store(&new, key, &c).is_ok());
    if let Some((dir, key)) = shared {
        let _ = cache::store(&cache::shared_path(dir, key), key, &c);
    }
    Ok((c, Source::Extracted { cached }, key))
}

/// Metadata and features of one photo, or why it is left out.
fn read_one(path: &Path, job: &MatchJob, opts: &FeatureOptions) -> Result<(Image, Source), String> {
    let meta = meta::read(path)?;
    let (c, source, key) = features_of(path, job, opts)?;
    let (w, h) = (c.size.0 as f64, c.size.1 as f64);
    let seeds = photo::features::strongest(&c.features, job.seed_features, w, h, opts);
    Ok((
        Image {
            meta,
            size: c.size,
            scale: c.scale,
            features: c.features,
            seeds,
            key,
            measured: 0,
        },
        source,
    ))
}

/// Each photo's most alike others by VLAD over its seed descriptors (vocabulary from the
/// block); every photo alike none when the block has too few descriptors for a vocabulary.
fn alike(images: &[Image]) -> Vec<Vec<usize>> {
    use photo::features::vlad::{most_alike, VladOptions, Vocabulary};
    let descs: Vec<&[photo::features::Descriptor]> = images
        .iter()
        .map(|i| i.seeds.1.descriptors.as_slice())
        .collect();
    let Some(voc) = Vocabulary::build(&descs, &VladOptions::default()) else {
        return vec![Vec::new(); images.len()];
    };
    let vlads: Vec<Vec<f32>> = descs.par_iter().map(|d| voc.vlad(d)).collect();
    most_alike(&vlads, pairs::MOST_ALIKE)
}

/// Match one pair: ratio/mutual test, then RANSAC (seeded by the pair).
fn match_pair(images: &[Image], a: usize, b: usize, job: &MatchJob) -> PairResult {
    let (fa, fb) = (&images[a].features, &images[b].features);
    let (sa, sb) = (&images[a].seeds, &images[b].seeds);
    let m: Vec<Match> = match_descriptors(&sa.1, &sb.1, job.ratio)
        .into_iter()
        .map(|(i, j)| (sa.0[i as usize], sb.0[j as usize]))
        .collect();
    let pa: Vec<_> = m
        .iter()
        .map(|&(i, _)| {
            let k = fa.keypoints[i as usize];
            nalgebra::Vector2::new(k.x, k.y)
        })
        .collect();
    let pb: Vec<_> = m
        .iter()
        .map(|&(_, j)| {
            let k = fb.keypoints[j as usize];
            nalgebra::Vector2::new(k.x, k.y)
        })
        .collect();
    let opts = RansacOptions {
        threshold_px: job.ransac_px * images[a].scale.max(images[b].scale),
        min_inliers: job.min_matches,
        ..RansacOptions::default()
    };
    let seed = pair_cache::seed(a, b);
    let model = verify(&pa, &pb, &opts, seed);
    let f = model.as_ref().map(|v| v.f);
    let verified = model
        .map(|v| {
            // Then motion coherence: each inlier moves as its nearest neighbours do.
            let (ia, ib): (Vec<_>, Vec<_>) = v.inliers.iter().map(|&k| (pa[k], pb[k])).unzip();
            let (w, h) = images[a].size;
            let tol = (0.02 * (w as f64).hypot(h as f64)).max(20.0);
            let ok = coherent(&ia, &ib, COHERENCE_NEIGHBOURS, tol);
            let kept: Vec<Match> = v
                .inliers
                .iter()
                .zip(ok)
                .filter(|(_, ok)| *ok)
                .map(|(&k, _)| m[k])
                .collect();
            if kept.len() < job.min_matches {
                return Vec::new();
            }
            if job.guided_ratio <= 0.0 {
                return kept;
            }
            let o = GuidedOptions {
                radius_px: GUIDED_RADIUS * opts.threshold_px,
                epipolar_px: opts.threshold_px,
                ratio: job.guided_ratio,
                neighbours: COHERENCE_NEIGHBOURS,
                duplicate_px: opts.threshold_px,
            };
            guided(fa, fb, &v.f, &kept, &o)
        })
        .unwrap_or_default();
    let f = f.filter(|_| !verified.is_empty());
    PairResult {
        a,
        b,
        putative: m.len(),
        verified,
        f,
    }
}

/// Match every pair of `list` in parallel, or read it from the cache of a previous run;
/// returns the results in list order and how many came from the cache.
fn match_pairs(
    images: &[Image],
    list: &[(usize, usize)],
    job: &MatchJob,
    progress: &(dyn Fn(&str, usize, usize) + Sync),
) -> (Vec<PairResult>, usize) {
    let old = job
        .cache
        .as_ref()
        .map(|(old, _)| pair_cache::load(&pair_cache::path(old)))
        .unwrap_or_default();
    let done = std::sync::atomic::AtomicUsize::new(0);
    let hits = std::sync::atomic::AtomicUsize::new(0);
    let results = list
        .par_iter()
        .map(|&(a, b)| {
            let stored = images[a].key.zip(images[b].key).and_then(|(ka, kb)| {
                old.get(&(ka, kb, pair_cache::settings(job, pair_cache::seed(a, b))))
            });
            let r = match stored {
                Some(s) => {
                    hits.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    s.result(a, b)
                }
                None => match_pair(images, a, b, job),
            };
            let k = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            progress("pairs", k, list.len());
            r
        })
        .collect();
    (results, hits.into_inner())
}

/// The photos read: the usable ones, those left out (file name, reason), and how many came
/// from the feature cache or could not be stored in it.
struct Photos {
    images: Vec<Image>,
    skipped: Vec<(String, String)>,
    from_cache: usize,
    not_cached: usize,
}

/// Read every photo's metadata and features in parallel (the "features" stage); an error
/// when fewer than two are usable.
fn read_photos(
    job: &MatchJob,
    files: &[PathBuf],
    opts: &FeatureOptions,
    progress: &(dyn Fn(&str, usize, usize) + Sync),
) -> Result<Photos, MatchError> {
    let done = std::sync::atomic::AtomicUsize::new(0);
    let read: Vec<Result<(Image, Source), String>> = files
        .par_iter()
        .map(|p| {
            let r = read_one(p, job, opts);
            let k = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            progress("features", k, files.len());
            r
        })
        .collect();
    let mut out = Photos {
        images: Vec::new(),
        skipped: Vec::new(),
        from_cache: 0,
        not_cached: 0,
    };
    for (p, r) in files.iter().zip(read) {
        let r = r.map(|(im, source)| {
            match source {
                Source::Cache => out.from_cache += 1,
                Source::Extracted { cached: false } if job.cache.is_some() => out.not_cached += 1,
                Source::Extracted { .. } => {}
            }
            im
        });
        let name = p
            .file_name()
            .unwrap_or_default()
            .to_string_lossy()
            .into_owned();
        match r {
            Ok(im) if im.features.keypoints.len() < job.min_matches => out.skipped.push((
                name,
                format!(
                    "only {} features found (texture too weak or image too small)",
                    im.features.keypoints.len()
                ),
            )),
            Ok(im) => out.images.push(im),
            Err(e) => out.skipped.push((name, e)),
        }
    }
    if out.images.len() < 2 {
        return Err(MatchError::Nothing(format!(
            "{}: {} usable photograph(s); matching needs at least two{}",
            job.photos.display(),
            out.images.len(),
            out.skipped
                .iter()
                .map(|(n, r)| format!("\n  {n}: {r}"))
                .collect::<String>()
        )));
    }
    Ok(out)
}

/// Store the pairs' matches in the cache when one is kept: whether all is well (no cache
/// asked for, or the pairs written).
fn cache_pairs(job: &MatchJob, images: &[Image], results: &[PairResult]) -> bool {
    job.cache.as_ref().is_none_or(|(_, new)| {
        let keyed = results.iter().filter_map(|p| {
            let (ka, kb) = images[p.a].key.zip(images[p.b].key)?;
            Some((
                (
                    ka,
                    kb,
                    pair_cache::settings(job, pair_cache::seed(p.a, p.b)),
                ),
                p,
            ))
        });
        pair_cache::store(&pair_cache::path(new), keyed).is_ok()
    })
}

/// The verified matches of the pairs: (photo a, photo b, keypoint pairs).
type PairMatches = Vec<(usize, usize, Vec<Match>)>;

/// Each photo's keypoints joined by position (keypoints of other orientations at the same
/// place join their first: one measurement per image position), and the verified matches of
/// every pair in those terms, sorted and without repeats.
fn verified_matches(images: &[Image], results: &[PairResult]) -> (Vec<Vec<u32>>, PairMatches) {
    let canon: Vec<Vec<u32>> = images
        .iter()
        .map(|i| photo::features::same_position(&i.features.keypoints))
        .collect();
    let verified = results
        .iter()
        .filter(|p| !p.verified.is_empty())
        .map(|p| {
            let mut v: Vec<Match> = p
                .verified
                .iter()
                .map(|&(i, j)| (canon[p.a][i as usize], canon[p.b][j as usize]))
                .collect();
            v.sort_unstable();
            v.dedup();
            (p.a, p.b, v)
        })
        .collect();
    (canon, verified)
}

/// Run the matching stages; `progress(stage, done, total)` is called as work completes.
pub fn run(
    job: &MatchJob,
    progress: &(dyn Fn(&str, usize, usize) + Sync),
) -> Result<Matched, MatchError> {
    let (files, other_files) = list(&job.photos)?;
    if files.is_empty() {
        return Err(MatchError::Nothing(format!(
            "{}: no JPEG or PNG photographs in the folder",
            job.photos.display()
        )));
    }
    // The exposures table is read before the long stages, so a bad one fails at once.
    let table = match &job.exposures {
        Some(p) => Some(positions::read(p).map_err(MatchError::Input)?),
        None => None,
    };
    let opts = FeatureOptions {
        max_features: job.max_features,
        ..FeatureOptions::default()
    };
    let t = std::time::Instant::now();
    let Photos {
        mut images,
        skipped,
        from_cache,
        not_cached,
    } = read_photos(job, &files, &opts, progress)?;
    let mut timing = vec![("features".to_string(), t.elapsed().as_secs_f64())];
    let positions = if job.ignore_gps && table.is_none() {
        vec![None; images.len()]
    } else {
        project::image_positions(table.as_ref(), &images)
    };
    let enu = project::local_enu(&positions);
    let radius = project::footprint_radii(&images);
    let alike = pairs::wants_appearance(job.pairs, &enu).then(|| {
        let t = std::time::Instant::now();
        let a = alike(&images);
        timing.push(("global descriptors".into(), t.elapsed().as_secs_f64()));
        a
    });
    let (list, pair_note) =
        pairs::choose(job.pairs, &enu, &radius, alike.as_deref()).map_err(MatchError::Input)?;
    let t = std::time::Instant::now();
    let (results, pairs_from_cache) = match_pairs(&images, &list, job, progress);
    let pairs_not_cached = !cache_pairs(job, &images, &results);
    timing.push(("matching".into(), t.elapsed().as_secs_f64()));
    let counts: Vec<usize> = images.iter().map(|i| i.features.keypoints.len()).collect();
    let (canon, verified) = verified_matches(&images, &results);
    let mut tracks = tracks::build(&counts, &verified);
    let t = std::time::Instant::now();
    let (completed, misses) =
        block::complete_tracks(&mut tracks, &images, &canon, &results, &verified, job);
    timing.push(("track completion".into(), t.elapsed().as_secs_f64()));
    let t = std::time::Instant::now();
    let decodes = refine::Decodes::new(DECODED_BUDGET);
    let patch_measured = match job.refine {
        true => {
            refine::measure_misses(&mut images, &mut tracks, &misses, job, &decodes, &|k, n| {
                progress("patches", k, n)
            })
        }
        false => 0,
    };
    timing.push(("patches".into(), t.elapsed().as_secs_f64()));
    let inconsistent = block::consistent_tracks(&mut tracks, &images, &results, job);
    let component = block::components(images.len(), &results);
    let t = std::time::Instant::now();
    let refinement = if job.refine {
        refine::refine(&images, &tracks, job, &decodes, &|k, n| {
            progress("sub-pixel", k, n)
        })
    } else {
        refine::Refinement::default()
    };
    timing.push(("sub-pixel".into(), t.elapsed().as_secs_f64()));
    Ok(Matched {
        images,
        positions,
        enu,
        pairs: results,
        pair_note,
        tracks,
        completed,
        patch_measured,
        refinement,
        inconsistent,
        component,
        skipped,
        other_files,
        timing,
        from_cache,
        not_cached,
        pairs_from_cache,
        pairs_not_cached,
    })
}
