//! Single-point positioning: weighted least squares on first-frequency code with per-system
//! receiver clocks, elevation-dependent weights, broadcast ionosphere and troposphere models,
//! a chi-square validation of every solution and exclusion of faulty satellites (RAIM FDE).
//!
//! Enters: observation epochs (receiver time tags, GPST) with their header, the orbits and
//! [`SppOptions`]. Leaves: per epoch an [`SppSolution`] (receiver position ECEF, clocks per
//! system in metres, covariance m², DOPs) or the [`SppFailure`] with the satellites rejected;
//! [`run`] counts them over a file. The least squares of one epoch is in `lsq`.

mod lsq;

use crate::frame::{enu_rotation, Ecef};
use crate::orbit::{Orbits, C};
use crate::rinex::{ObsEpoch, ObsHeader, SatObs};
use crate::signal::{find_code, frequency, primary_codes};
use crate::sv::{Constellation, Sv};
use hifitime::{Duration, Epoch};
use lsq::{lsq, Lsq};
use nalgebra::{Matrix3, Vector3};
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
    /// No valid healthy ephemeris.
    NoEphemeris,
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
            Rejection::NoEphemeris => "no valid healthy ephemeris",
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
struct Meas {
    sv: Sv,
    /// Pseudorange, metres.
    pr: f64,
    /// Carrier frequency of the code, Hz.
    freq: f64,
    /// Satellite position at transmission, ECEF (before the Earth-rotation correction).
    sat: Ecef,
    /// Satellite clock minus group delay, seconds.
    sat_clock: f64,
}

/// Solve one epoch. `prior` speeds convergence (previous solution or header position).
pub fn solve_epoch(
    epoch: &ObsEpoch,
    header: &ObsHeader,
    orbits: &Orbits,
    opts: &SppOptions,
    prior: Option<Ecef>,
) -> Result<SppSolution, (SppFailure, Vec<(Sv, Rejection)>)> {
    let mut rejected = Vec::new();
    let mut meas = Vec::with_capacity(epoch.sats.len());
    for s in &epoch.sats {
        match measurement(s, epoch.time, header, orbits, opts) {
            Ok(m) => meas.push(m),
            Err(r) => rejected.push((s.sv, r)),
        }
    }
    let mut x0 = prior.map(|p| p.0).unwrap_or_else(Vector3::zeros);
    if x0.norm() > 1.0e8 {
        x0 = Vector3::zeros();
    }
    let all: Vec<usize> = (0..meas.len()).collect();
    let first = lsq(&meas, &all, x0, epoch.time, orbits, opts);
    let mut best = match first {
        Ok(s) => s,
        Err(f) => {
            rejected.sort();
            return Err((f, rejected));
        }
    };
    rejected.extend(
        best.masked
            .iter()
            .map(|&i| (meas[i].sv, Rejection::BelowMask)),
    );
    if opts.fde {
        let excluded;
        (best, excluded) = exclude_faulty(&meas, best, epoch.time, orbits, opts);
        rejected.extend(excluded.iter().map(|&i| (meas[i].sv, Rejection::Faulty)));
    }
    if best.inconsistent() {
        return Err((
            SppFailure::Inconsistent {
                chi2: best.chi2,
                threshold: best.chi2_threshold(),
            },
            rejected,
        ));
    }
    if best.dop.gdop > opts.max_gdop || !best.dop.gdop.is_finite() {
        return Err((
            SppFailure::PoorGeometry {
                gdop: best.dop.gdop,
            },
            rejected,
        ));
    }
    let n = best.used.len();
    Ok(SppSolution {
        time: epoch.time,
        pos: Ecef(best.x),
        clocks: best.clocks,
        cov: best.cov,
        nsat: n,
        dop: best.dop,
        rms: best.rms,
        used: best.used.iter().map(|&i| meas[i].sv).collect(),
        rejected,
    })
}

/// The first-frequency code of a satellite and the satellite at its transmission time
/// (receiver time `t` − pseudorange/c − satellite clock), or why it cannot be used.
fn measurement(
    s: &SatObs,
    t: Epoch,
    header: &ObsHeader,
    orbits: &Orbits,
    opts: &SppOptions,
) -> Result<Meas, Rejection> {
    let sys = s.sv.sys;
    if !opts.systems.contains(&sys) {
        return Err(Rejection::SystemNotSelected);
    }
    let types = header.types_of(sys);
    let k = find_code(types, primary_codes(sys)).ok_or(Rejection::NoCode)?;
    let pr = s.obs[k].value;
    if !(pr.is_finite() && pr > 1.0e7 && pr < 6.0e7) {
        return Err(Rejection::NoCode);
    }
    let band = types[k].band();
    let chan = header
        .glonass_channel(s.sv)
        .or_else(|| orbits.broadcast.glonass_channel(s.sv.prn));
    let freq = frequency(sys, band, chan).ok_or(Rejection::NoCode)?;
    let t0 = t - Duration::from_seconds(pr / C);
    let first = orbits.sat(s.sv, t0, band).ok_or(Rejection::NoEphemeris)?;
    let ttx = t0 - Duration::from_seconds(first.pv.clock - first.group_delay);
    let si = orbits.sat(s.sv, ttx, band).ok_or(Rejection::NoEphemeris)?;
    Ok(Meas {
        sv: s.sv,
        pr,
        freq,
        sat: si.pv.pos,
        sat_clock: si.pv.clock - si.group_delay,
    })
}

/// Fault detection and exclusion: while the solution fails the chi-square test, exclude the
/// satellite whose removal leaves the smallest chi-square per degree of freedom (at most
/// three, keeping at least two redundant satellites). Returns the solution and the indices
/// excluded.
fn exclude_faulty(
    meas: &[Meas],
    mut best: Lsq,
    t: Epoch,
    orbits: &Orbits,
    opts: &SppOptions,
) -> (Lsq, Vec<usize>) {
    let mut excluded: Vec<usize> = Vec::new();
    while best.inconsistent() {
        if best.used.len() < best.nx + 2 || excluded.len() >= 3 {
            break;
        }
        let mut cand: Option<(usize, Lsq)> = None;
        for &i in &best.used {
            let subset: Vec<usize> = best.used.iter().copied().filter(|&j| j != i).collect();
            if let Ok(s) = lsq(meas, &subset, best.x, t, orbits, opts) {
                let better = match &cand {
                    None => true,
                    Some((_, c)) => s.chi2_per_dof() < c.chi2_per_dof(),
                };
                if better {
                    cand = Some((i, s));
                }
            }
        }
        match cand {
            Some((i, s)) => {
                excluded.push(i);
                best = s;
            }
            None => break,
        }
    }
    (best, excluded)
}

/// Counts of a whole run.
#[derive(Clone, Debug, Default)]
pub struct SppRun {
    /// Solved epochs, in time order.
    pub solutions: Vec<SppSolution>,
    /// Epochs without a solution and why.
    pub failures: Vec<(Epoch, SppFailure)>,
    /// How often satellites were rejected, per reason.
    pub rejections: BTreeMap<Rejection, usize>,
}

/// Solve every epoch in order, each starting from the previous solution.
pub fn run(epochs: &[ObsEpoch], header: &ObsHeader, orbits: &Orbits, opts: &SppOptions) -> SppRun {
    let mut out = SppRun::default();
    let mut prior = header.approx_position;
    for e in epochs {
        match solve_epoch(e, header, orbits, opts, prior) {
            Ok(s) => {
                for (_, r) in &s.rejected {
                    *out.rejections.entry(*r).or_default() += 1;
                }
                prior = Some(s.pos);
                out.solutions.push(s);
            }
            Err((f, rej)) => {
                for (_, r) in &rej {
                    *out.rejections.entry(*r).or_default() += 1;
                }
                out.failures.push((e.time, f));
            }
        }
    }
    out
}
