//! Single-point positioning: weighted least squares on first-frequency code with per-system
//! receiver clocks, elevation-dependent weights, broadcast ionosphere and troposphere models,
//! a chi-square validation of every solution and exclusion of faulty satellites (RAIM FDE).
//!
//! Enters: observation epochs (receiver time tags, GPST) with their header, the orbits and
//! [`SppOptions`]. Leaves: per epoch an [`SppSolution`] (receiver position ECEF, clocks per
//! system in metres, covariance m², DOPs) or the [`SppFailure`] with the satellites rejected;
//! [`run`] counts them over a file. The least squares of one epoch is in `lsq`; the types both
//! use are in `types`.

mod lsq;
mod types;

pub use types::{chi2_999, Dop, Rejection, SppFailure, SppOptions, SppSolution};

use crate::frame::Ecef;
use crate::orbit::{Orbits, Unavailable, C};
use crate::rinex::{ObsEpoch, ObsHeader, SatObs};
use crate::signal::{find_code, frequency, primary_codes};
use crate::sv::Sv;
use hifitime::{Duration, Epoch};
use lsq::{lsq, Lsq};
use nalgebra::Vector3;
use std::collections::BTreeMap;
use types::Meas;

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
    let pr = s.get(k).value;
    if !(pr.is_finite() && pr > 1.0e7 && pr < 6.0e7) {
        return Err(Rejection::NoCode);
    }
    let band = types[k].band();
    let chan = header
        .glonass_channel(s.sv)
        .or_else(|| orbits.broadcast.glonass_channel(s.sv.prn));
    let freq = frequency(sys, band, chan).ok_or(Rejection::NoCode)?;
    let t0 = t - Duration::from_seconds(pr / C);
    let why = |u: Unavailable| match u {
        Unavailable::NoOrbit => Rejection::NoEphemeris,
        Unavailable::NoClock => Rejection::NoClock,
    };
    let first = orbits.sat_or_why(s.sv, t0, band).map_err(why)?;
    let ttx = t0 - Duration::from_seconds(first.clock - first.group_delay);
    let si = orbits.sat_or_why(s.sv, ttx, band).map_err(why)?;
    Ok(Meas {
        sv: s.sv,
        pr,
        freq,
        sat: si.pos,
        sat_clock: si.clock - si.group_delay,
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
    run_with_progress(epochs, header, orbits, opts, &crate::progress::NoProgress)
}

/// [`run`], counting the epochs done on `progress` (stage "single point").
pub fn run_with_progress(
    epochs: &[ObsEpoch],
    header: &ObsHeader,
    orbits: &Orbits,
    opts: &SppOptions,
    progress: &dyn crate::progress::Progress,
) -> SppRun {
    let mut out = SppRun::default();
    let mut prior = header.approx_position;
    progress.set_len("single point", epochs.len() as u64);
    for (i, e) in epochs.iter().enumerate() {
        if i % 256 == 255 {
            progress.inc(256);
        }
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
    progress.finish();
    out
}
