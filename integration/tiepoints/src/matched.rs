//! Everything a match run found ([`Matched`]): what the project and the report are written
//! from.

use super::job::{Image, PairResult};
use super::{positions, refine};
use photo::features::tracks;

/// Everything a match run found.
#[derive(Clone, Debug)]
pub struct Matched {
    /// The photos that were read, in name order.
    pub images: Vec<Image>,
    /// The position of every photo (exposures table, else EXIF GPS).
    pub positions: Vec<Option<positions::Position>>,
    /// The same in a local east/north/up frame at the first position (m).
    pub enu: Vec<Option<nalgebra::Vector3<f64>>>,
    /// Every pair tried.
    pub pairs: Vec<PairResult>,
    /// How pairs were chosen.
    pub pair_note: String,
    /// Tracks (image index, keypoint index).
    pub tracks: tracks::Tracks,
    /// Measurements track completion added (found in photos the track's pairs did not match).
    pub completed: usize,
    /// Measurements added by fitting a track's patch where its epipolar lines cross in a photo
    /// with no keypoint there.
    pub patch_measured: usize,
    /// Sub-pixel positions of the tracks' measurements.
    pub refinement: refine::Refinement,
    /// Measurements cut from tracks for disagreeing with the epipolar geometry of the track's
    /// other photos.
    pub inconsistent: usize,
    /// Component number of every image (0 = the largest block).
    pub component: Vec<usize>,
    /// Photos left out: (file name, reason).
    pub skipped: Vec<(String, String)>,
    /// Other files in the folder that are not photographs.
    pub other_files: usize,
    /// Seconds per stage: (stage, seconds).
    pub timing: Vec<(String, f64)>,
    /// Photos whose features were read from the cache.
    pub from_cache: usize,
    /// Photos whose features were extracted but could not be cached.
    pub not_cached: usize,
    /// Pairs whose matches were read from the cache.
    pub pairs_from_cache: usize,
    /// Whether the pairs could not be written to the cache (a cache was asked for).
    pub pairs_not_cached: bool,
}
