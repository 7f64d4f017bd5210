//! The settings of a PPP run ([`PppOptions`]) and the reasons a satellite is left out at an
//! epoch ([`Reject`]): what the run's parts share, apart from the run itself.

use crate::model::antex::Antex;
use crate::ppk::{Motion, Reference};
use crate::sv::Constellation;

/// Settings of a PPP run.
#[derive(Clone, Debug)]
pub struct PppOptions {
    /// Systems used.
    pub systems: Vec<Constellation>,
    /// Elevation mask, radians.
    pub elev_mask: f64,
    /// Static (one position) or kinematic (a position per epoch).
    pub motion: Motion,
    /// The point the positions describe.
    pub refer: Reference,
    /// Code σ per frequency at zenith (m); the ionosphere-free combination triples it.
    pub sigma_code: f64,
    /// Phase σ per frequency at zenith (m).
    pub sigma_phase: f64,
    /// σ of the satellite orbit and clock per epoch (m): interpolating 15-min SP3 clocks
    /// leaves centimetres, 30-s clock files millimetres.
    pub sigma_sat: f64,
    /// Random-walk intensity (m²/s) of a satellite clock between its records: an
    /// interpolated clock's variance is `clock_walk·a·b/(a+b)` at `a` and `b` seconds from
    /// the records (a Brownian bridge), so the phase weight falls between records. 1.1e-5
    /// gives 5 cm half-way between 15-min SP3 records (2005-era caesium clocks) and 9 mm
    /// between 30-s clock records.
    pub clock_walk: f64,
    /// Random walk of the zenith wet delay, m/√s.
    pub zwd_walk: f64,
    /// Seconds a satellite stays unused after leaving the Earth's shadow (its yaw is not
    /// known while the attitude recovers).
    pub eclipse_wait: f64,
    /// ANTEX files: the first gives the satellite and receiver antenna model, the others
    /// only assign satellites to blocks for a block-only model.
    pub antex: Vec<Antex>,
}

impl Default for PppOptions {
    fn default() -> Self {
        PppOptions {
            systems: vec![Constellation::Gps, Constellation::Galileo],
            elev_mask: 10f64.to_radians(),
            motion: Motion::Static,
            refer: Reference::Marker,
            sigma_code: 0.3,
            sigma_phase: 0.003,
            sigma_sat: 0.01,
            clock_walk: 1.1e-5,
            zwd_walk: 1.0e-4,
            eclipse_wait: 1800.0,
            antex: Vec::new(),
        }
    }
}

/// Why a satellite was not used at an epoch.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Reject {
    /// Not both frequencies of code and phase.
    SingleFrequency,
    /// No precise orbit or clock at the time.
    NoOrbit,
    /// Below the elevation mask.
    BelowMask,
    /// In the Earth's shadow or recovering from it.
    Eclipse,
    /// Code far from the model (outlier).
    CodeOutlier,
    /// Phase jumped against the model: its ambiguity was restarted.
    PhaseOutlier,
}

impl Reject {
    /// Words for reports.
    pub fn describe(self) -> &'static str {
        match self {
            Reject::SingleFrequency => "without two frequencies of code and phase",
            Reject::NoOrbit => "without precise orbit or clock",
            Reject::BelowMask => "below the elevation mask",
            Reject::Eclipse => "in or just after the Earth's shadow",
            Reject::CodeOutlier => "code outliers",
            Reject::PhaseOutlier => "phase outliers (ambiguity restarted)",
        }
    }
}
