//! A satellite observed by both receivers in one epoch, with its geometry: what the
//! measurement model and the ambiguity resolution read, and what they ask of it.
//!
//! What enters: the rover and base measurements of a satellite and its views from both
//! receivers (ECEF metres, radians). What leaves: [`Pair`], and whether a pair observes a
//! phase or a state; this module uses neither the filter nor its readers.

use super::geometry::SatView;
use super::obs::{SatMeas, NF};
use super::state::StateKey;

/// A satellite observed by both receivers this epoch.
#[derive(Clone, Debug)]
pub(super) struct Pair {
    /// Rover measurements.
    pub(super) r: SatMeas,
    /// Base measurements.
    pub(super) b: SatMeas,
    /// The satellite seen by the rover.
    pub(super) vr: SatView,
    /// The satellite seen by the base.
    pub(super) vb: SatView,
    /// Geometric range base → satellite, metres.
    pub(super) rho_b: f64,
    /// Base troposphere, metres.
    pub(super) tropo_b: f64,
    /// Rover elevation, radians.
    pub(super) el: f64,
    /// Niell wet mapping function at the rover elevation.
    pub(super) map_wet: f64,
    /// Day of year of the epoch (for the hydrostatic mapping function).
    pub(super) doy: f64,
    /// Variance added to each single difference for the base epoch's age (the base sees
    /// the ionosphere and troposphere of another moment), m².
    pub(super) age_var: f64,
    /// Antenna phase-centre correction per slot, rover minus base, metres.
    pub(super) ant: [f64; NF],
}

/// Whether a pair observes the phase of slot `slot` on both receivers.
pub(super) fn has_phase(p: &Pair, slot: usize) -> bool {
    p.r.l[slot].is_finite() && p.b.l[slot].is_finite()
}

/// Whether a pair observes the code of slot `slot` on both receivers.
pub(super) fn has_code(p: &Pair, slot: usize) -> bool {
    p.r.p[slot].is_finite() && p.b.p[slot].is_finite()
}

/// Whether a pair observes what a per-satellite state describes: the phase of its slot for an
/// ambiguity, any phase for the ionosphere, the code of its slot for a code bias.
pub(super) fn observes(p: &Pair, key: StateKey) -> bool {
    match key {
        StateKey::Position | StateKey::Tropo => true,
        StateKey::GlonassCodeBias => p.r.sv.sys == crate::sv::Constellation::Glonass,
        StateKey::Ambiguity(a) => p.r.sv == a.sv && has_phase(p, a.slot),
        StateKey::Iono(sv) => p.r.sv == sv && (0..NF).any(|k| has_phase(p, k)),
        StateKey::CodeBias(a) => p.r.sv == a.sv && has_code(p, a.slot),
    }
}
