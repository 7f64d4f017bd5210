//! What a simulated aerial block is made of and what it leaves: the spec, the truth, and the
//! records shared by the simulation and the table writers (images, measurements, the time of
//! the first exposure).
//!
//! What enters: nothing (plain data; lengths in the units of each field's doc, ENU metres at
//! the origin, GPST seconds). What leaves: [`BlockSpec`] and [`BlockTruth`], and the records
//! `super` fills and `files` writes; this module uses neither of them.

use gnss::frame::Geodetic;
use nalgebra::{Vector2, Vector3};
use photo::camera::Pose;

/// An aerial block.
#[derive(Clone, Debug)]
pub struct BlockSpec {
    /// Project name.
    pub name: String,
    /// Seed of every random draw.
    pub seed: u64,
    /// Latitude of the origin (first image of the first strip), degrees.
    pub lat_deg: f64,
    /// Longitude of the origin, degrees.
    pub lon_deg: f64,
    /// Ellipsoidal height of the origin (the mean terrain), metres.
    pub ground_h: f64,
    /// Nominal principal distance, mm.
    pub focal_mm: f64,
    /// Square format side, mm.
    pub format_mm: f64,
    /// Pixel size, µm.
    pub pixel_um: f64,
    /// Photo scale denominator (flying height = scale · f).
    pub scale: f64,
    /// Forward overlap of consecutive images (0–1).
    pub forward_overlap: f64,
    /// Side overlap of neighbouring strips (0–1).
    pub side_overlap: f64,
    /// Photos in each strip (alternate strips are flown in opposite directions).
    pub strips: Vec<usize>,
    /// Ground speed, m/s.
    pub speed: f64,
    /// Time between strips (turn), seconds.
    pub turn_s: f64,
    /// Terrain relief amplitude, m.
    pub relief: f64,
    /// σ of each of ω, φ, κ away from a level photo, degrees.
    pub tilt_sigma_deg: f64,
    /// σ of an image measurement, µm.
    pub sigma_image_um: f64,
    /// Tie points per image on average.
    pub ties_per_image: usize,
    /// Check points.
    pub checks: usize,
    /// Four corner control points.
    pub corner_gcps: bool,
    /// σ of the control coordinates (E, N, U), metres (E and U are used: σ_xy, σ_z).
    pub gcp_sigma: [f64; 3],
    /// GNSS antenna σ per axis (E, N, U), metres.
    pub gnss_sigma: [f64; 3],
    /// GNSS antenna correlations E–N, E–U, N–U.
    pub gnss_corr: [f64; 3],
    /// Lever arm (u, v, w), camera frame, m.
    pub lever_arm: [f64; 3],
    /// Drift a + b·(t − t_first) over the whole block: a (E, N, U), m.
    pub drift_a: [f64; 3],
    /// Drift rate b (E, N, U), m/s.
    pub drift_b: [f64; 3],
    /// Gross errors injected in tie-point measurements (60 µm and up).
    pub image_blunders: usize,
    /// A control point with a wrong coordinate: shift (E, N, U) in metres.
    pub wrong_gcp: Option<[f64; 3]>,
    /// The true camera differs from the nominal one written to the project: principal
    /// distance offset (mm) — for self-calibration.
    pub true_focal_delta_mm: f64,
    /// True principal point (x0, y0), mm.
    pub true_principal_point_mm: [f64; 2],
    /// True radial distortion k1, 1/m².
    pub true_k1: f64,
    /// An ambiguity re-fix in the trajectory: from this image on (in flight order) the
    /// antenna positions carry this extra offset (m) and a new segment id.
    pub segment_jump: Option<(usize, [f64; 3])>,
    /// Extra lines for the project's `[[camera]]` (e.g. `self_calibrate = [...]`).
    pub camera_options: String,
    /// The `[gnss]` and `[adjustment]` sections of the project written with it.
    pub project_options: String,
}

impl BlockSpec {
    /// The classic test block: 2 strips, 29 photos, f = 152 mm, 23 cm format, 1:8000, 60 %
    /// forward overlap; GNSS σ 5 cm with correlations and a linear drift; 4 corner GCPs.
    pub fn classic() -> BlockSpec {
        BlockSpec {
            name: "classic 2-strip block 1:8000".into(),
            seed: 8000,
            lat_deg: 30.52,
            lon_deg: 114.36,
            ground_h: 35.0,
            focal_mm: 152.0,
            format_mm: 230.0,
            pixel_um: 10.0,
            scale: 8000.0,
            forward_overlap: 0.6,
            side_overlap: 0.3,
            strips: vec![15, 14],
            speed: 70.0,
            turn_s: 150.0,
            relief: 40.0,
            tilt_sigma_deg: 1.0,
            sigma_image_um: 5.0,
            ties_per_image: 40,
            checks: 40,
            corner_gcps: true,
            gcp_sigma: [0.02, 0.02, 0.03],
            gnss_sigma: [0.05, 0.05, 0.05],
            gnss_corr: [0.2, 0.3, 0.1],
            lever_arm: [0.12, -0.05, 1.45],
            drift_a: [0.25, -0.18, 0.30],
            drift_b: [0.0008, -0.0005, 0.0012],
            image_blunders: 0,
            wrong_gcp: None,
            true_focal_delta_mm: 0.0,
            true_principal_point_mm: [0.0; 2],
            true_k1: 0.0,
            segment_jump: None,
            camera_options: String::new(),
            project_options: String::new(),
        }
    }

    /// A large block for benchmarks: `strips` × `per_strip` photos (1:5000, 80 mm lens).
    pub fn large(strips: usize, per_strip: usize) -> BlockSpec {
        BlockSpec {
            name: format!("{strips}×{per_strip} benchmark block"),
            seed: 1000,
            focal_mm: 80.0,
            format_mm: 60.0,
            pixel_um: 6.0,
            scale: 5000.0,
            side_overlap: 0.3,
            strips: vec![per_strip; strips],
            turn_s: 60.0,
            ties_per_image: 60,
            checks: 50,
            drift_a: [0.0; 3],
            ..BlockSpec::classic()
        }
    }
}

/// What the simulation knows.
#[derive(Clone, Debug)]
pub struct BlockTruth {
    /// Origin of the ENU frame of the poses and points.
    pub origin: Geodetic,
    /// Image id, strip, pose (ENU at the origin), GPST seconds.
    pub images: Vec<(String, usize, Pose, f64)>,
    /// Point id, kind (gcp|check|tie), ENU.
    pub points: Vec<(String, &'static str, Vector3<f64>)>,
    /// GPST seconds of the first exposure (the drift's reference time).
    pub t_first: f64,
    /// (image, point) of every blundered measurement.
    pub blunders: Vec<(String, String)>,
    /// The control point given the wrong coordinate, if any.
    pub wrong_gcp: Option<String>,
    /// Image measurements written.
    pub measurements: usize,
}

/// An image of a simulated block: id, strip (from 0), pose (ENU at the origin), GPST seconds.
pub(super) type Image = (String, usize, Pose, f64);

/// An image measurement: image index, point index, image coordinates (m).
pub(super) type Measurement = (usize, usize, Vector2<f64>);

/// GPST seconds of the first exposure of a block.
pub(super) const T_FIRST: f64 = 1_400_000_000.0 + 3600.0 * 3.0;
