//! What a pass and a run hand out: the solution of one epoch of one pass, the counters of a
//! pass, and the result of a whole run.
//!
//! What enters: nothing (plain data, ECEF metres, GPST). What leaves: [`EpochSol`] and
//! [`PassStats`], filled by the filter and combined by [`super::combine`], and [`PpkResult`],
//! assembled by [`super::process`]; this module uses none of them.

use super::measure::GateReason;
use super::slip::SlipCause;
use crate::frame::Ecef;
use crate::solution::Quality;
use crate::trajectory::{Trajectory, TrajectoryEpoch};
use hifitime::Epoch;
use nalgebra::Matrix3;
use std::collections::BTreeMap;

/// Result of one epoch of one pass.
#[derive(Clone, Debug)]
pub struct EpochSol {
    /// Receiver time tag of the rover epoch (GPST).
    pub time: Epoch,
    /// Rover antenna position, ECEF.
    pub pos: Ecef,
    /// Its covariance, ECEF, m².
    pub cov: Matrix3<f64>,
    /// Fixed or float.
    pub quality: Quality,
    /// Satellites used in the double differences.
    pub nsat: usize,
    /// Ratio test value (of the fix, or the best tried when float).
    pub ratio: f64,
    /// Rover minus base time, seconds.
    pub age: f64,
    /// Number of double-difference ambiguities fixed.
    pub nfix: usize,
    /// Satellites whose wide lane the epoch's integer search determined (also when the
    /// narrow lanes were not: a float epoch may have its wide lanes fixed).
    pub widelanes: usize,
    /// Ambiguity segment of this epoch within its pass (see [`crate::trajectory`]).
    pub segment: u32,
    /// The float solution (position, covariance) of a fixed epoch, for a demotion.
    pub float: Option<(Ecef, Matrix3<f64>)>,
    /// Of a float epoch, the check that refused its fix (None when none was tried).
    pub refused: Option<super::refusal::Refusal>,
    /// Of a smoothed epoch, the forward filter's own solution (position, covariance) before
    /// the backward pass's estimate was fused in: with the backward pass's solution of the
    /// epoch, the two halves whose disagreement checks the smoothed σ.
    pub alone: Option<(Ecef, Matrix3<f64>)>,
}

impl StaticSolution {
    /// The last epoch of a static run's output `epochs` with the counts of `stats` (its one
    /// pass); None when nothing was solved.
    pub fn of(epochs: &[TrajectoryEpoch], stats: &PassStats) -> Option<Self> {
        let (first, last) = (epochs.first()?, epochs.last()?);
        Some(StaticSolution {
            pos: last.pos,
            cov: last.cov,
            quality: last.quality,
            ratio: last.ratio,
            span: (first.time, last.time),
            epochs: epochs.len(),
            fixed_epochs: epochs
                .iter()
                .filter(|e| e.quality == Quality::Fixed)
                .count(),
            residuals: (stats.phase_residuals, stats.code_residuals),
        })
    }
}

/// Counters of a pass.
#[derive(Clone, Debug, Default)]
pub struct PassStats {
    /// Ambiguity resets per cause.
    pub slips: BTreeMap<SlipCause, usize>,
    /// Ambiguities reset because their post-fit residual was too large.
    pub outlier_resets: usize,
    /// Satellite-epochs whose code was left out for its post-fit residual (an excursion).
    pub code_outliers: usize,
    /// Epochs at which the code contradicted the state's position beyond its σ for tens of
    /// seconds and the state's covariance was widened (see `ppk::filter::selfcheck`).
    pub widened: usize,
    /// Measurement rows removed by the innovation gate, per reason (counted at each of the
    /// two linearisations of an epoch).
    pub rejected: BTreeMap<GateReason, usize>,
    /// Satellite-epochs below the elevation mask.
    pub below_mask: usize,
    /// Satellite-epochs without an orbit.
    pub no_orbit: usize,
    /// Smoothed fixes rejected because the data before or after the epoch alone fixed an
    /// ambiguity to another integer.
    pub smoothed_fixes_rejected: usize,
    /// Fixes refused on long baselines because they lay farther from the float solution than
    /// its covariance allows (χ²(3) at 99 %).
    pub far_from_float_fixes: usize,
    /// Fixed solutions found with one satellite's ambiguities left float (long baselines,
    /// when the whole set would not fix).
    pub left_out_fixes: usize,
    /// Ambiguity-epochs kept float because a receiver had not resolved the half-cycle
    /// ambiguity of the phase.
    pub half_cycle_float: usize,
    /// Post-fit double-difference phase residuals of the float solution, metres.
    pub phase_residuals: Spread,
    /// Post-fit double-difference code residuals of the float solution, metres.
    pub code_residuals: Spread,
    /// Ambiguity arcs (per pass) whose integer was held in the filter state (fix-and-hold).
    pub held_arcs: std::collections::BTreeSet<u64>,
}

/// Size of a set of residuals: count, root mean square and largest magnitude.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Spread {
    /// Number of residuals.
    pub count: usize,
    /// Sum of their squares.
    pub sum_sq: f64,
    /// Largest magnitude.
    pub max_abs: f64,
}

impl Spread {
    /// Add one residual.
    pub fn add(&mut self, v: f64) {
        self.count += 1;
        self.sum_sq += v * v;
        self.max_abs = self.max_abs.max(v.abs());
    }

    /// Root mean square (0 when empty).
    pub fn rms(&self) -> f64 {
        (self.sum_sq / self.count.max(1) as f64).sqrt()
    }
}

/// The one position of a static run (`Motion::Static`): the last epoch's accumulated
/// solution with what it rests on.
#[derive(Clone, Debug)]
pub struct StaticSolution {
    /// The rover position (marker or ARP, as the options refer), ECEF.
    pub pos: Ecef,
    /// Its covariance, ECEF, m².
    pub cov: Matrix3<f64>,
    /// Fixed when the last epoch's ambiguities were fixed, else float.
    pub quality: Quality,
    /// Ratio test value at the last epoch.
    pub ratio: f64,
    /// First and last solved epoch (GPST).
    pub span: (Epoch, Epoch),
    /// Epochs that entered the solution.
    pub epochs: usize,
    /// Of them, epochs whose accumulated solution was fixed.
    pub fixed_epochs: usize,
    /// Post-fit residuals over the span: phase and code.
    pub residuals: (Spread, Spread),
}

impl PassStats {
    /// Rows removed by the innovation gate, all reasons.
    pub fn rejected_innovations(&self) -> usize {
        self.rejected.values().sum()
    }
}

/// The atmospheric delays a run estimated (beyond the a-priori models), settled from the
/// options and the longest baseline.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Models {
    /// Longest distance of a rover start position (single-point) from the base, metres.
    pub longest_baseline: f64,
    /// A single-difference slant ionospheric delay per satellite was estimated.
    pub iono: bool,
    /// The rover's zenith wet delay was estimated.
    pub tropo: bool,
    /// GLONASS was processed: its ambiguities stayed float (inter-channel phase biases of
    /// two receivers differ unless they are identical; they are not calibrated) and its
    /// inter-channel code bias was estimated.
    pub glonass_float: bool,
    /// Per-satellite code biases were estimated on these slots (system, slot): rover and
    /// base track different codes there (P1 against C1).
    pub code_biases: Vec<(crate::sv::Constellation, usize)>,
    /// Rover epochs at which the filter held the position from the epoch before (the rover
    /// stood still, `PpkOptions::use_stillness`), and the stretches of them.
    pub still: (usize, usize),
    /// The rover's and the base's code noise measured on their own data (see
    /// [`super::codenoise`]), where enough arcs allowed it.
    pub code_noise: [Option<super::codenoise::CodeNoise>; 2],
    /// What [`super::repair::mend`] did to the rover's and the base's phases.
    pub mended: [super::repair::Mended; 2],
}

/// How far the output epochs' ambiguities were resolved: wide lanes (with two or more
/// frequencies) and narrow lanes (the fixed solution).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AmbiguityRates {
    /// Solved epochs.
    pub solved: usize,
    /// Epochs whose wide lanes were fixed on at least three satellites besides the pivot
    /// (enough to carry the position once the narrow lanes follow).
    pub widelane: usize,
    /// Epochs with the fixed solution (Q = 1: the narrow lanes, or L1, fixed).
    pub narrowlane: usize,
    /// Ambiguity arcs held in the filter state, summed over the passes.
    pub arcs_held: usize,
    /// Two or more frequencies were processed (wide lanes exist).
    pub dual_frequency: bool,
}

/// Output of a carrier-phase run.
#[derive(Clone, Debug)]
pub struct PpkResult {
    /// How the output epochs' ambiguities were resolved.
    pub ambiguities: AmbiguityRates,
    /// The rover trajectory (of the chosen filter mode): ARP or marker positions (as the
    /// options refer) at the true reception times, with the filter's ambiguity segments.
    pub trajectory: Trajectory,
    /// Counters of the forward pass, when it ran.
    pub forward: Option<PassStats>,
    /// Counters of the backward pass, when it ran.
    pub backward: Option<PassStats>,
    /// Rover epochs without a solution and why.
    pub unsolved: Vec<(Epoch, String)>,
    /// Float output epochs whose fix a check refused, and which one, in time order (the
    /// receiver's time tags).
    pub refusals: Vec<(Epoch, super::refusal::Refusal)>,
    /// Rover epochs read.
    pub rover_epochs: usize,
    /// Base marker position used, ECEF.
    pub base_marker: Ecef,
    /// The atmospheric models the filter estimated, and why.
    pub models: Models,
    /// What the run noticed: base position from the header, antennas not calibrated, base
    /// epochs skipped for holding no phase of the processed systems, a receiver's Doppler
    /// ignored for slip detection, a baseline beyond the models, rover epochs with nothing
    /// to difference against.
    pub warnings: Vec<String>,
    /// The static solution (static runs only).
    pub static_solution: Option<StaticSolution>,
    /// What the passes say of each epoch: their separation and their ambiguity resets.
    pub diagnostics: PassDiagnostics,
}

/// What the forward and backward passes say of each epoch, for the quality report.
#[derive(Clone, Debug, Default)]
pub struct PassDiagnostics {
    /// Forward minus backward solution of each epoch both passes solved, in time order.
    /// With the two-filter smoother the forward pass is the smoothed one.
    pub separation: Vec<Separation>,
    /// Rover epochs at which the forward pass reset ambiguities (slips, gaps, outliers), with
    /// how many, in time order.
    pub forward_resets: Vec<(Epoch, u32)>,
    /// The same for the backward pass, in time order.
    pub backward_resets: Vec<(Epoch, u32)>,
}

/// The two passes' solutions of one epoch compared.
#[derive(Clone, Copy, Debug)]
pub struct Separation {
    /// The epoch (the forward solution's time).
    pub time: Epoch,
    /// Forward minus backward position, ECEF metres.
    pub d: nalgebra::Vector3<f64>,
    /// Whether both passes fixed the epoch (then they should agree to millimetres).
    pub both_fixed: bool,
}

impl PassStats {
    /// Ambiguity resets so far: slips of every cause and post-fit outliers.
    pub fn resets(&self) -> usize {
        self.slips.values().sum::<usize>() + self.outlier_resets
    }
}

impl PpkResult {
    /// Number of fixed epochs.
    pub fn fixed(&self) -> usize {
        self.trajectory.fixed()
    }
}
