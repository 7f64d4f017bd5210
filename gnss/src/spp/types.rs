//! The data of single-point positioning shared by the epoch solver and its least squares:
//! options, dilutions of precision, rejections and failures, the solution, a satellite's code
//! measurement, and the chi-square critical value.
//!
//! What enters: nothing (plain data, units in each field's doc). What leaves: the types
//! [`super::solve_epoch`] and `lsq` fill and hand out; this module uses neither of them.

use crate::frame::{enu_rotation, Ecef};
use crate::sv::{Constellation, Sv};
use hifitime::Epoch;
use nalgebra::Matrix3;
use std::collections::BTreeMap;

/// Options of the single-point solution.
#[derive(Clone, Debug)]
pub struct SppOptions {
    /// Elevation mask, radians.
    pub elev_mask: f64,
    /// Systems to use.
    pub systems: Vec<Constellation>,
    /// Detect and exclude faulty satellites.
    pub fde: bool,
    /// Solutions with a larger geometric dilution of precision are refused.
    pub max_gdop: f64,
}

impl Default for SppOptions {
    fn default() -> Self {
        SppOptions {
            elev_mask: 15f64.to_radians(),
            systems: [Constellation::CDMA.as_slice(), &[Constellation::Glonass]].concat(),
            fde: true,
            max_gdop: 30.0,
        }
    }
}

/// Dilutions of precision.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Dop {
    /// Geometric.
    pub gdop: f64,
    /// Position.
    pub pdop: f64,
    /// Horizontal.
    pub hdop: f64,
    /// Vertical.
    pub vdop: f64,
}

/// Why a satellite was not used in an epoch.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Rejection {
    /// The satellite's system was not asked for.
    SystemNotSelected,
    /// No usable code observation.
    NoCode,
    /// No valid healthy ephemeris (or, with precise orbits, no precise position).
    NoEphemeris,
    /// A precise position but no precise clock (outside the clock records or in a gap).
    NoClock,
    /// Below the elevation mask.
    BelowMask,
    /// Excluded by fault detection.
    Faulty,
}

impl std::fmt::Display for Rejection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Rejection::SystemNotSelected => "system not selected",
            Rejection::NoCode => "no usable code observation",
            Rejection::NoEphemeris => "no valid healthy ephemeris or precise orbit",
            Rejection::NoClock => "no precise clock (outside the clock records or in a gap)",
            Rejection::BelowMask => "below elevation mask",
            Rejection::Faulty => "excluded by fault detection",
        })
    }
}

/// Why an epoch has no solution.
#[derive(Clone, Debug, PartialEq)]
pub enum SppFailure {
    /// Fewer satellites than unknowns.
    TooFewSatellites {
        /// Satellites usable.
        usable: usize,
        /// Satellites needed (the number of unknowns).
        needed: usize,
    },
    /// The least squares did not converge.
    NoConvergence,
    /// The solution failed the chi-square test and no exclusion repaired it.
    Inconsistent {
        /// Chi-square of the residuals.
        chi2: f64,
        /// Its critical value.
        threshold: f64,
    },
    /// Geometric dilution of precision above 30.
    PoorGeometry {
        /// The GDOP.
        gdop: f64,
    },
}

impl SppFailure {
    /// The kind of failure without its numbers (for grouping in reports).
    pub fn kind(&self) -> &'static str {
        match self {
            SppFailure::TooFewSatellites { .. } => "too few satellites",
            SppFailure::NoConvergence => "no convergence",
            SppFailure::Inconsistent { .. } => "inconsistent residuals",
            SppFailure::PoorGeometry { .. } => "poor geometry (GDOP > 30)",
        }
    }
}

impl std::fmt::Display for SppFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SppFailure::TooFewSatellites { usable, needed } => {
                write!(f, "too few satellites ({usable} usable, {needed} needed)")
            }
            SppFailure::NoConvergence => write!(f, "least squares did not converge"),
            SppFailure::Inconsistent { chi2, threshold } => write!(
                f,
                "residuals inconsistent (chi-square {chi2:.1} > {threshold:.1}) and no single exclusion repairs them"
            ),
            SppFailure::PoorGeometry { gdop } => write!(f, "poor geometry (GDOP {gdop:.1})"),
        }
    }
}

/// A single-point solution.
#[derive(Clone, Debug)]
pub struct SppSolution {
    /// Receiver time tag, GPST.
    pub time: Epoch,
    /// Position, ECEF.
    pub pos: Ecef,
    /// Receiver clock per system, metres.
    pub clocks: BTreeMap<Constellation, f64>,
    /// Position covariance in ECEF, m².
    pub cov: Matrix3<f64>,
    /// Satellites used.
    pub nsat: usize,
    /// Dilutions of precision.
    pub dop: Dop,
    /// Root mean square of the post-fit residuals, metres.
    pub rms: f64,
    /// Satellites used.
    pub used: Vec<Sv>,
    /// Satellites not used, and why.
    pub rejected: Vec<(Sv, Rejection)>,
}

impl SppSolution {
    /// Covariance in the local ENU frame of the solution.
    pub fn cov_enu(&self) -> Matrix3<f64> {
        let r = enu_rotation(&self.pos.to_geodetic());
        r * self.cov * r.transpose()
    }
}

/// Upper 0.1 % point of the chi-square distribution (Wilson–Hilferty).
pub fn chi2_999(dof: usize) -> f64 {
    let k = dof.max(1) as f64;
    let z = 3.090_232;
    k * (1.0 - 2.0 / (9.0 * k) + z * (2.0 / (9.0 * k)).sqrt()).powi(3)
}

/// A satellite's first-frequency code with the satellite at its transmission time.
pub(super) struct Meas {
    /// The satellite.
    pub(super) sv: Sv,
    /// Pseudorange, metres.
    pub(super) pr: f64,
    /// Carrier frequency of the code, Hz.
    pub(super) freq: f64,
    /// Satellite position at transmission, ECEF (before the Earth-rotation correction).
    pub(super) sat: Ecef,
    /// Satellite clock minus group delay, seconds.
    pub(super) sat_clock: f64,
}
