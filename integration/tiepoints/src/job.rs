//! What `ppkat match` is asked to do ([`MatchJob`], with the matching constants), a photo as
//! the stages hold it ([`Image`]), one pair's outcome ([`PairResult`]) and why a run fails
//! ([`MatchError`]): what every stage of the matching shares.

use super::meta;
use super::pairs::PairMode;
use photo::features::matching::Match;
use photo::features::Features;
use std::path::PathBuf;

/// What `ppkat match` is asked to do.
#[derive(Clone, Debug)]
pub struct MatchJob {
    /// The folder of photographs.
    pub photos: PathBuf,
    /// An exposures table whose positions replace the photos' EXIF GPS.
    pub exposures: Option<PathBuf>,
    /// A camera file (`[[camera]]` tables) replacing the metadata's camera.
    pub camera: Option<PathBuf>,
    /// Features per photo.
    pub max_features: usize,
    /// Features per photo matched all against all (the strongest, spread over the photo);
    /// the rest by guided matching.
    pub seed_features: usize,
    /// Longer side of the images features are extracted from, pixels.
    pub max_image_size: u32,
    /// How pairs are chosen.
    pub pairs: PairMode,
    /// σ of positions without their own, horizontal and vertical (m).
    pub gnss_sigma: [f64; 2],
    /// Ratio test threshold.
    pub ratio: f64,
    /// RANSAC threshold (Sampson distance) in the pixels features were extracted from; scaled
    /// to the photograph by the reduction factor.
    pub ransac_px: f64,
    /// Fewest verified matches for a pair.
    pub min_matches: usize,
    /// Ratio test of guided matching, among the candidates near a keypoint's predicted
    /// position on its epipolar line (0: no guided matching). 0.6, stricter than the 0.8 of
    /// the matching all with all: at 0.8 the textured block's tracks were 99.04 % right and
    /// Brighton Beach's image RMS 0.60 px; at 0.7 99.29 % and 0.53 px, for 4 % fewer tracks;
    /// at 0.6 Brighton's RMS is 0.50 px for 5 % fewer again. At 0.7 the 28-photo free
    /// network of `start_from_ties` ended singular (its start is sensitive to a few more
    /// tracks: not understood yet).
    pub guided_ratio: f64,
    /// Ratio test of track completion, among the keypoints where two or more of a track's
    /// epipolar lines cross in a photo it is not in (0: no completion). On Brighton Beach
    /// completion turns 10 % more tracks into tracks of three or more photos.
    pub complete_ratio: f64,
    /// Refine every track's measurements by least-squares matching of its first one's patch
    /// ([`crate::refine`]), each then with its own σ.
    pub refine: bool,
    /// Use no position from the photos' metadata.
    pub ignore_gps: bool,
    /// Feature cache: the folder read from (a previous run's) and the folder written to
    /// (this run's; every photo's features end up there). None: no cache.
    pub cache: Option<(PathBuf, PathBuf)>,
    /// A feature cache shared by several projects (files named by their key: the photo's
    /// image data and the extraction settings), read before extracting and written after.
    /// None: none.
    pub shared_cache: Option<PathBuf>,
}

impl MatchJob {
    /// A job on `photos` with the default settings.
    pub fn new(photos: PathBuf) -> MatchJob {
        MatchJob {
            photos,
            exposures: None,
            camera: None,
            max_features: 16000,
            seed_features: 6000,
            max_image_size: 2000,
            pairs: PairMode::Auto,
            gnss_sigma: [3.0, 5.0],
            ratio: 0.8,
            ransac_px: 1.5,
            min_matches: 20,
            guided_ratio: 0.6,
            complete_ratio: 0.8,
            refine: true,
            ignore_gps: false,
            cache: None,
            shared_cache: None,
        }
    }
}

/// Radius of guided matching around a keypoint's predicted position, in RANSAC thresholds
/// (12 px at 1.5 px: relief moves a point from where its neighbours go by a few pixels; a
/// wider search found a few more tracks on Brighton Beach and more wrong ones on the
/// textured block).
pub const GUIDED_RADIUS: f64 = 8.0;

/// Track completion takes a lone candidate whose descriptor distance² to the track is at most
/// this many times the largest among the track's own (on Brighton Beach 1.5 gave 5,362 tracks
/// in three or more photos against 5,223 at 1.0 and 5,070 taking none; the textured block's
/// correct share stayed at 99.4 %).
pub const LONE_FACTOR: f64 = 1.5;

/// Bytes of decoded photos kept between patch measurement and refinement (each is decoded
/// again beyond it).
pub const DECODED_BUDGET: usize = 512 << 20;

/// Neighbours a match's displacement is compared with (motion coherence).
pub const COHERENCE_NEIGHBOURS: usize = 8;

/// A photo that takes part: its metadata, its features, the reduced size's factor.
#[derive(Clone, Debug)]
pub struct Image {
    /// Metadata.
    pub meta: meta::PhotoMeta,
    /// Photograph width and height, pixels.
    pub size: (u32, u32),
    /// Photograph pixels per pixel of the image features were extracted from.
    pub scale: f64,
    /// Keypoints (photograph pixels) and descriptors.
    pub features: Features,
    /// The keypoints matched all against all (indices into `features`), and their features:
    /// the others are found by guided matching once a pair's geometry is known.
    pub seeds: (Vec<u32>, Features),
    /// The key its features are cached under (None without a cache).
    pub key: Option<u64>,
    /// Keypoints added at the end of `features` by measuring tracks' patches (not extracted).
    pub measured: usize,
}

/// A matched pair: image indices, putative matches, verified matches.
#[derive(Clone, Debug)]
pub struct PairResult {
    /// First image.
    pub a: usize,
    /// Second image.
    pub b: usize,
    /// Matches after the ratio and mutual tests.
    pub putative: usize,
    /// Matches RANSAC kept (empty when the pair failed).
    pub verified: Vec<Match>,
    /// The fundamental matrix of a verified pair (x_bᵀ·F·x_a = 0).
    pub f: Option<nalgebra::Matrix3<f64>>,
}

/// Why a match run failed as a whole.
#[derive(Debug, thiserror::Error)]
pub enum MatchError {
    /// A problem with a file given by the user.
    #[error("{0}")]
    Input(String),
    /// Nothing usable came out.
    #[error("{0}")]
    Nothing(String),
}
