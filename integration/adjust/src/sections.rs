//! Sections of `project.toml` that the adjustment's parts read beside the project loader:
//! `[attitude]` ([`AttitudeSection`]) and the latency grouping of `[gnss]` ([`LatencyGroup`]).

use serde::Deserialize;

/// The `[attitude]` section: attitude observations at the exposures.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AttitudeSection {
    /// σ of the observed attitude about the camera's x, y, z axes (≈ ω, φ, κ), degrees: the
    /// σ for the antennas without their own `sd_omega, sd_phi, sd_kappa` columns (and for the
    /// image list's angles); the table's σ win where given.
    #[serde(default)]
    pub sigma_deg: Option<[f64; 3]>,
    /// Estimate a boresight misalignment per camera (default); `false`: the attitude is the
    /// camera's.
    #[serde(default = "yes")]
    pub boresight: bool,
    /// σ of a prior on the boresight (degrees, about x, y, z); omit: free.
    #[serde(default)]
    pub boresight_sigma_deg: Option<[f64; 3]>,
    /// One attitude offset per strip (the images list's strip column), held at zero by a prior
    /// of the median σ of the strip's observations, 90 % of each observation's variance
    /// moved to it (the rest stays the image's own): for an INS, whose attitude error drifts
    /// over minutes and is nearly constant along a strip, so that the boresight's σ count the
    /// strips, not the images. Default false (errors independent from image to image).
    #[serde(default)]
    pub strip_offsets: bool,
}

fn yes() -> bool {
    true
}

/// Which antenna positions share a latency.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum LatencyGroup {
    /// No latency (δ = 0).
    #[default]
    None,
    /// One latency for the whole block.
    Block,
    /// One per flight (antenna times split at gaps longer than [`super::latency::FLIGHT_GAP_S`]).
    Flight,
}
