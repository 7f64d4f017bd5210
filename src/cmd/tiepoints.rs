//! `ppkat match`: automatic tie points from a folder of photographs, as a ppkat project.

use anyhow::{Context, Result};
use integration::tiepoints::{self, project, report, MatchJob, PairMode};
use std::path::PathBuf;

/// Find tie points in a folder of photographs and write a ppkat project that `ppkat adjust`
/// runs as it is.
///
/// Reads every JPEG or PNG of the folder: EXIF (GPS, focal length, 35 mm equivalent, size,
/// model) and DJI XMP (altitudes, gimbal angles, calibrated focal length, RTK σ). Extracts
/// SIFT features from each photo reduced to --max-image-size (or reads them from the cache of
/// an earlier run in the output folder, features/), matches the pairs (the strongest 6,000
/// features all against all: nearest neighbours with the ratio test and a mutual check),
/// verifies each pair by RANSAC on the fundamental matrix, finds the other features by guided
/// matching along the pair's epipolar lines (or reads the pair from the cache), joins matches
/// into tracks across photos, looks for each track in the further photos where two or more
/// of its epipolar lines cross, refines every measurement to a tenth of a pixel by
/// least-squares matching of its track's first patch (each with its own σ in
/// image_observations.csv), and writes the main connected
/// block: project.toml (cameras from the metadata, self-calibrated with 5 or more photos),
/// images.csv, image_observations.csv (pixels, column right, row down, origin at the top-left
/// corner), antennas.csv (camera positions with σ), start.csv (start attitudes from DJI gimbal
/// angles), match.json and match_report.html (per photo: features, verified pairs,
/// measurements; the pair graph). Photos that cannot be read, have no focal length or are not
/// connected to the block are named with the reason, and the exit code is 3.
#[derive(clap::Args)]
pub struct Args {
    /// Folder of photographs (JPEG or PNG; other files are counted and ignored).
    #[arg(long, value_name = "DIR")]
    photos: PathBuf,
    /// Exposure positions replacing the photos' EXIF GPS: a ppkat exposures CSV or antenna
    /// table (columns id, lat, lon, h and optionally sigma_e/n/u or c_ee/c_nn/c_uu), rows
    /// named as the photo files (with or without the extension).
    #[arg(long, value_name = "FILE")]
    exposures: Option<PathBuf>,
    /// Camera file with [[camera]] tables as in project.toml (chosen by image size); default:
    /// from each photo's metadata.
    #[arg(long, value_name = "FILE.toml")]
    camera: Option<PathBuf>,
    /// Most features kept per photo (spread over the image by a grid). The strongest 6,000 of
    /// them (spread the same way) are matched all against all; the rest are found by guided
    /// matching along the epipolar lines once a pair's geometry is known.
    #[arg(long, value_name = "N", default_value_t = 16000)]
    max_features: usize,
    /// Longer side of the reduced image features are extracted from, pixels (photos are
    /// reduced by 2, 4 or 8 to fit; positions are written in the photo's own pixels).
    #[arg(long, value_name = "PX", default_value_t = 2000)]
    max_image_size: u32,
    /// Pairs to match: auto (every pair up to 40 photos; above, by overlapping footprints when
    /// every photo has a position, else by appearance), exhaustive, gnss (by footprints;
    /// positions required), or appearance (each photo with the 12 that look most alike by a
    /// global descriptor built from the block, and 2 neighbours on each side in name order).
    #[arg(long, value_name = "MODE", default_value = "auto",
          value_parser = ["auto", "exhaustive", "gnss", "appearance"])]
    pairs: String,
    /// σ of positions that carry none, horizontal,vertical (m): consumer GPS by default.
    #[arg(long, value_name = "H,V", default_value = "3,5", value_parser = sigma_pair)]
    gnss_sigma: SigmaPair,
    /// Use no position from the photos' EXIF/XMP (when they are wrong, or to start from the
    /// photos alone): without positions the block starts from a relative orientation of its
    /// best pair and the project is a free network (coordinates arbitrary) unless control
    /// points are added.
    #[arg(long)]
    ignore_gps: bool,
    /// Also keep every photo's features in DIR, a folder several projects share: a photo
    /// whose image data and extraction settings it already holds is not extracted again
    /// (its metadata may differ: a photo geotagged or retagged since keeps its features).
    /// Files are named by that key and written whole; the results are the same bytes as
    /// without.
    #[arg(long, value_name = "DIR")]
    feature_cache: Option<PathBuf>,
    /// Output project folder (written whole, or not at all). Its features/ subfolder caches
    /// every photo's features and every pair's matches: a rerun into the same folder extracts
    /// and matches only photos that are new or changed (the summary says how many came from
    /// the cache), and writes the same bytes.
    #[arg(short = 'o', long = "out", value_name = "DIR")]
    out: PathBuf,
}

/// `--gnss-sigma H,V`.
#[derive(Clone, Copy, Debug)]
struct SigmaPair([f64; 2]);

fn sigma_pair(s: &str) -> std::result::Result<SigmaPair, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| {
            x.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite() && *v > 0.0)
        })
        .collect::<Option<_>>()
        .ok_or("give two positive numbers H,V in metres")?;
    match v[..] {
        [h, u] => Ok(SigmaPair([h, u])),
        _ => Err("give two positive numbers H,V in metres".into()),
    }
}

/// The files a match run writes (an earlier run's folder may be replaced).
const OUTPUTS: [&str; 8] = [
    "project.toml",
    "images.csv",
    "image_observations.csv",
    "antennas.csv",
    "start.csv",
    "match.json",
    "match_report.html",
    "features",
];

/// Run `ppkat match`.
pub fn run(args: Args) -> Result<()> {
    let mut job = MatchJob::new(args.photos);
    job.exposures = args.exposures;
    job.camera = args.camera;
    job.max_features = args.max_features.max(100);
    job.max_image_size = args.max_image_size.max(200);
    job.pairs = match args.pairs.as_str() {
        "exhaustive" => PairMode::Exhaustive,
        "gnss" => PairMode::Gnss,
        "appearance" => PairMode::Appearance,
        _ => PairMode::Auto,
    };
    job.gnss_sigma = args.gnss_sigma.0;
    job.ignore_gps = args.ignore_gps;
    // Staged first: the features of this run are cached in the new folder as they are made,
    // those of an earlier run read from the old one.
    let staged = common::atomic::StagedDir::new(&args.out, &OUTPUTS)?;
    job.cache = Some((args.out.join("features"), staged.path().join("features")));
    job.shared_cache = args.feature_cache.clone();
    let bar = indicatif::ProgressBar::new(0);
    if super::quiet() {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    bar.set_style(
        indicatif::ProgressStyle::with_template("{msg:9} {bar:30} {pos}/{len} (ETA {eta})")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let m = tiepoints::run(&job, &|stage, done, total| {
        bar.set_message(stage.to_string());
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    });
    bar.finish_and_clear();
    let m = m?;
    let mut w = project::build(&job, &m)?;
    w.project
        .write(staged.path())
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    if w.project.free_datum {
        w.with_attitude = project::tie_starts(&mut w.project, staged.path())?;
    }
    let json = report::json_text(&m, &w);
    std::fs::write(staged.path().join("match.json"), json)
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    std::fs::write(
        staged.path().join("match_report.html"),
        report::html(&m, &w),
    )
    .with_context(|| format!("cannot write {}", args.out.display()))?;
    staged.commit()?;
    print_summary(&m, &w);
    let skipped: Vec<String> = m
        .skipped
        .iter()
        .chain(&w.no_camera)
        .map(|(n, r)| format!("{n}: {r}"))
        .chain(
            w.not_connected
                .iter()
                .map(|n| format!("{n}: not connected to the block (no verified pair with it)")),
        )
        .collect();
    super::complete(skipped)
}

fn print_summary(m: &tiepoints::Matched, w: &project::Written) {
    println!(
        "photos: {} read, {} in the block, {} not connected, {} left out{}",
        m.images.len() + m.skipped.len(),
        w.project.images.len(),
        w.not_connected.len(),
        m.skipped.len() + w.no_camera.len(),
        if m.other_files > 0 {
            format!(" ({} other files ignored)", m.other_files)
        } else {
            String::new()
        }
    );
    for (c, s, n) in &w.cameras {
        println!("camera {c}: {n} photos, focal length from {s}");
    }
    println!("pairs: {}", m.pair_note);
    println!(
        "pairs verified: {} of {}",
        m.pairs.iter().filter(|p| !p.verified.is_empty()).count(),
        m.pairs.len()
    );
    println!(
        "tracks: {} ({} in 3 or more photos), {} measurements ({} found by completing tracks in further photos: {} at keypoints, {} by their patches where no keypoint was); cut: {} conflicting keypoints, {} measurements off the epipolar lines of their track",
        w.tracks, w.tracks_3plus, w.observations, m.completed + m.patch_measured, m.completed, m.patch_measured, m.tracks.conflicts, m.inconsistent
    );
    println!(
        "sub-pixel: {} measurements refined by least-squares matching against their track's first, {} kept at their keypoints (flat or weakly alike patches)",
        m.refinement.refined, m.refinement.kept
    );
    if w.implausible_depth > 0 {
        println!(
            "tracks left out: {} (their points would lie at an implausible depth: wrong matches)",
            w.implausible_depth
        );
    }
    println!(
        "positions: {} photos, start attitudes: {}",
        w.with_position, w.with_attitude
    );
    for (n, d) in &w.heading_disagrees {
        println!("note: {n}: the gimbal yaw differs by {d:.0}° from the heading its overlaps give; the overlaps' is used");
    }
    let read = m.images.len() + m.skipped.len();
    println!(
        "features: {} of {read} photos from the cache, {} extracted{}",
        m.from_cache,
        read - m.from_cache,
        if m.not_cached > 0 {
            format!(
                " ({} could not be cached: the next run extracts them again)",
                m.not_cached
            )
        } else {
            String::new()
        }
    );
    println!(
        "pair matches: {} of {} pairs from the cache, {} matched{}",
        m.pairs_from_cache,
        m.pairs.len(),
        m.pairs.len() - m.pairs_from_cache,
        if m.pairs_not_cached {
            " (could not be cached: the next run matches them again)"
        } else {
            ""
        }
    );
    for (s, t) in &m.timing {
        println!("time {s}: {t:.1} s");
    }
}
