//! What `ppkat import micmac` is asked to read ([`MicMacJob`]) and what its GNSS positions are
//! ([`GnssKind`]).

use std::path::PathBuf;

/// What GNSS camera positions are, for their σ and drift when the file does not say.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GnssKind {
    /// RTK or PPK positions: σ 5 cm / 10 cm, no drift.
    Survey,
    /// Navigation-grade positions (code GPS, an autopilot's log, EXIF): σ 3 m / 5 m and an
    /// unknown offset of the whole block estimated (`drift = "block"`, offset).
    Navigation,
}

impl GnssKind {
    /// The σ (horizontal, vertical) assumed for this kind, metres.
    pub fn sigma(self) -> [f64; 2] {
        match self {
            GnssKind::Survey => [0.05, 0.10],
            GnssKind::Navigation => [3.0, 5.0],
        }
    }
}

/// What `ppkat import micmac` reads.
#[derive(Clone, Debug, Default)]
pub struct MicMacJob {
    /// Ground control (`DicoAppuisFlottant`).
    pub ground: PathBuf,
    /// Image measurements of the control (`SetOfMesureAppuisFlottants`).
    pub measures: PathBuf,
    /// Calibration (`CalibrationInternConique`); else the orientations' `FileInterne`.
    pub calibration: Option<PathBuf>,
    /// Check points and their measurements.
    pub check: Option<(PathBuf, PathBuf)>,
    /// `EPSG:326ZZ`, `utm:ZZN`…; none: a local frame.
    pub crs: Option<String>,
    /// GNSS camera positions (text) and their format (`#F=N X Y Z`).
    pub gnss: Option<(PathBuf, String)>,
    /// σ of the GNSS positions, horizontal and vertical (m); `None`: by `gnss_kind`.
    pub gnss_sigma: Option<[f64; 2]>,
    /// What the positions are (`None`: survey-grade assumed, and said).
    pub gnss_kind: Option<GnssKind>,
    /// A folder of `Orientation-*.xml` start orientations.
    pub orientations: Option<PathBuf>,
    /// Pixel size (µm) written for the camera (MicMac works in pixels).
    pub pixel_um: f64,
    /// Image measurement σ, pixels.
    pub sigma_px: f64,
}
