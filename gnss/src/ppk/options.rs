//! The options of the carrier-phase engine: resolution mode, passes, noise and thresholds of
//! the filter, and where the base antenna is.
//!
//! What enters: nothing (plain settings, units in each field's doc). What leaves: the
//! [`PpkOptions`] every stage of a pass reads, and the [`BasePosition`] the run starts from;
//! this module uses none of the stages.

use crate::frame::Ecef;
use crate::model::antex::Antex;
use crate::sv::Constellation;

/// Integer ambiguity resolution mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ArMode {
    /// Float ambiguities only.
    Off,
    /// Resolve every epoch; the filter keeps float ambiguities.
    Continuous,
    /// Resolve every epoch from that epoch's data alone.
    Instantaneous,
    /// Resolve, then constrain the filter to the fixed integers.
    FixAndHold,
}

/// Which passes to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FilterMode {
    /// Forward in time only.
    Forward,
    /// Backward in time only.
    Backward,
    /// Forward and backward, combined epoch by epoch.
    Combined,
}

/// Options of the carrier-phase engine.
#[derive(Clone, Debug)]
pub struct PpkOptions {
    /// Elevation mask, radians.
    pub elev_mask: f64,
    /// Systems used.
    pub systems: Vec<Constellation>,
    /// Frequency slots used (1–3).
    pub nf: usize,
    /// Integer ambiguity resolution mode.
    pub ar: ArMode,
    /// Which passes run.
    pub filter: FilterMode,
    /// Ratio-test threshold (second best / best squared distance).
    pub ratio_threshold: f64,
    /// Largest base-rover time difference, seconds.
    pub max_age: f64,
    /// Gap after which an ambiguity is reset, seconds (0: five rover intervals, at least 5 s).
    pub max_gap: f64,
    /// Undifferenced phase sigma a + b/sin(el), metres.
    pub phase_sigma: (f64, f64),
    /// Code sigma over phase sigma.
    pub code_phase_ratio: f64,
    /// Ambiguity random walk, cycles/√s.
    pub amb_process_noise: f64,
    /// Initial ambiguity sigma, cycles.
    pub amb_init_sigma: f64,
    /// Innovation gate, metres.
    pub max_innovation: f64,
    /// Post-fit phase residual that resets an ambiguity, metres.
    pub max_phase_residual: f64,
    /// Epochs an ambiguity must be locked before it may be fixed.
    pub min_lock: usize,
    /// Lock count below which a satellite counts as newly risen for partial fixing.
    pub mature_lock: usize,
    /// Elevation mask of the ambiguities fixed, radians.
    pub ar_elev_mask: f64,
    /// Satellites partial fixing may drop, at most.
    pub max_partial_drops: usize,
    /// A partial fix whose 3D position sigma exceeds this (m) is not accepted.
    pub max_partial_fix_sigma: f64,
    /// Fewest double-difference ambiguities for a fix.
    pub min_fix_ambiguities: usize,
    /// Variance of the fix-and-hold constraint, cycles².
    pub hold_variance: f64,
    /// Estimate a single-difference slant ionosphere per satellite (ionosphere-weighted model).
    pub estimate_iono: bool,
    /// Prior sigma of that delay per km of baseline, metres.
    pub iono_sigma_per_km: f64,
    /// Its random walk per km of baseline, m/√s.
    pub iono_process_noise_per_km: f64,
    /// Receiver antenna calibrations (ANTEX); the header antenna types are looked up in it.
    pub antex: Option<std::sync::Arc<Antex>>,
}

impl Default for PpkOptions {
    fn default() -> Self {
        PpkOptions {
            elev_mask: 15f64.to_radians(),
            systems: Constellation::CDMA.to_vec(),
            nf: 2,
            ar: ArMode::FixAndHold,
            filter: FilterMode::Combined,
            ratio_threshold: 3.0,
            max_age: 30.0,
            max_gap: 0.0,
            phase_sigma: (0.003, 0.003),
            code_phase_ratio: 100.0,
            amb_process_noise: 1e-4,
            amb_init_sigma: 30.0,
            max_innovation: 30.0,
            max_phase_residual: 0.1,
            min_lock: 1,
            mature_lock: 5,
            ar_elev_mask: 15f64.to_radians(),
            max_partial_drops: 6,
            max_partial_fix_sigma: 0.03,
            min_fix_ambiguities: 4,
            hold_variance: 0.001,
            estimate_iono: false,
            iono_sigma_per_km: 0.001,
            iono_process_noise_per_km: 1e-4,
            antex: None,
        }
    }
}

/// Where the base antenna is.
#[derive(Clone, Copy, Debug)]
pub enum BasePosition {
    /// Given by the user (marker, ECEF).
    Given(Ecef),
    /// The header's approximate position (warned about loudly).
    Header,
}
