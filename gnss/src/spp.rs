//! Single-point positioning: weighted least squares on first-frequency code with per-system
//! receiver clocks, elevation-dependent weights, broadcast ionosphere and troposphere models,
//! a chi-square validation of every solution and exclusion of faulty satellites (RAIM FDE).

use crate::frame::{az_el, enu_rotation, rotate_to_reception, Ecef, Geodetic};
use crate::model;
use crate::orbit::{Orbits, C};
use crate::rinex::nav::Klobuchar;
use crate::rinex::{ObsEpoch, ObsHeader, SatObs};
use crate::signal::{find_code, frequency, primary_codes};
use crate::sv::{Constellation, Sv};
use hifitime::{Duration, Epoch};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
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

/// Elevation-dependent code variance (m²) with the model errors added.
fn variance(sys: Constellation, el: f64, iono: f64, tropo: f64) -> f64 {
    let efact = match sys {
        Constellation::Glonass => 1.5,
        Constellation::Sbas => 3.0,
        _ => 1.0,
    };
    let s = el.sin().max(0.05);
    efact * (0.3f64.powi(2) + 0.3f64.powi(2) / s)
        + 0.3f64.powi(2)
        + (0.5 * iono).powi(2)
        + (0.3 / (s + 0.1)).powi(2) * (tropo > 0.0) as u8 as f64
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

/// A converged least-squares solution.
struct Lsq {
    /// Receiver position, ECEF.
    x: Vector3<f64>,
    /// Receiver clock per system, metres.
    clocks: BTreeMap<Constellation, f64>,
    /// Position covariance, ECEF, m².
    cov: Matrix3<f64>,
    /// Weighted sum of squared post-fit residuals.
    chi2: f64,
    /// RMS of the post-fit residuals, metres.
    rms: f64,
    dop: Dop,
    /// Indices (into the measurements) used.
    used: Vec<usize>,
    /// Indices below the elevation mask.
    masked: Vec<usize>,
    /// Number of unknowns: position and one clock per system.
    nx: usize,
}

impl Lsq {
    fn chi2_threshold(&self) -> f64 {
        chi2_999(self.used.len() - self.nx)
    }
    /// Redundant and failing the chi-square test.
    fn inconsistent(&self) -> bool {
        self.used.len() > self.nx && self.chi2 > self.chi2_threshold()
    }
    fn chi2_per_dof(&self) -> f64 {
        self.chi2 / ((self.used.len() - self.nx).max(1) as f64)
    }
}

/// One linearised code observation: measurement index, unit vector receiver → satellite
/// (ECEF), observed − computed (m), variance (m²).
type Row = (usize, Vector3<f64>, f64, f64);

/// Iterated weighted least squares on the measurements `subset` from `x0` (ECEF): position
/// and one clock per system, up to 12 iterations until the position step is below 0.1 mm.
fn lsq(
    meas: &[Meas],
    subset: &[usize],
    x0: Vector3<f64>,
    t: Epoch,
    orbits: &Orbits,
    opts: &SppOptions,
) -> Result<Lsq, SppFailure> {
    let mut x = x0;
    let mut clk: BTreeMap<Constellation, f64> = BTreeMap::new();
    let (_, tow) = crate::time::week_tow(t);
    for iter in 0..12 {
        let (rows, masked) = linearize(meas, subset, &x, &clk, tow, orbits, opts);
        // Unknowns: position + one clock per system present.
        let mut systems: Vec<Constellation> = rows.iter().map(|r| meas[r.0].sv.sys).collect();
        systems.sort();
        systems.dedup();
        let nx = 3 + systems.len();
        if rows.len() < nx {
            return Err(SppFailure::TooFewSatellites {
                usable: rows.len(),
                needed: nx,
            });
        }
        let n = rows.len();
        let (h, v, w) = design(meas, &rows, &systems);
        let mut htw = h.transpose();
        for c in 0..n {
            for r in 0..nx {
                htw[(r, c)] *= w[c];
            }
        }
        let nmat = &htw * &h;
        let Some(q) = nmat.clone().try_inverse() else {
            return Err(SppFailure::PoorGeometry {
                gdop: f64::INFINITY,
            });
        };
        let dx = &q * (&htw * &v);
        x += Vector3::new(dx[0], dx[1], dx[2]);
        for (k, s) in systems.iter().enumerate() {
            *clk.entry(*s).or_insert(0.0) += dx[3 + k];
        }
        clk.retain(|s, _| systems.contains(s));
        if dx.rows(0, 3).norm() < 1e-4 && iter > 0 {
            // Post-fit residuals and statistics at the converged point.
            let post = &v - &h * &dx;
            let chi2: f64 = post.iter().zip(w.iter()).map(|(r, w)| r * r * w).sum();
            let rms = (post.iter().map(|r| r * r).sum::<f64>() / n as f64).sqrt();
            let dop = dops(&h, &Ecef(x).to_geodetic(), nx);
            let cov = q.fixed_view::<3, 3>(0, 0).into_owned();
            return Ok(Lsq {
                x,
                clocks: clk,
                cov,
                chi2,
                rms,
                dop,
                used: rows.iter().map(|r| r.0).collect(),
                masked,
                nx,
            });
        }
    }
    Err(SppFailure::NoConvergence)
}

/// The observation rows at receiver position `x` (ECEF) with clocks `clk` (m) at GPS
/// seconds of week `tow`, and the measurements below the elevation mask. Elevation, mask
/// and atmosphere apply only once `x` is near the Earth's surface.
fn linearize(
    meas: &[Meas],
    subset: &[usize],
    x: &Vector3<f64>,
    clk: &BTreeMap<Constellation, f64>,
    tow: f64,
    orbits: &Orbits,
    opts: &SppOptions,
) -> (Vec<Row>, Vec<usize>) {
    let near_earth = x.norm() > 6.0e6;
    let g = Ecef(*x).to_geodetic();
    let rx = Ecef(*x);
    let mut rows = Vec::with_capacity(subset.len());
    let mut masked = Vec::new();
    for &i in subset {
        let m = &meas[i];
        let sp = rotate_to_reception(&m.sat.0, (m.sat.0 - x).norm() / C);
        let d = sp - x;
        let rho = d.norm();
        let (az, el) = if near_earth {
            az_el(&rx, &g, &Ecef(sp))
        } else {
            (0.0, std::f64::consts::FRAC_PI_2)
        };
        if near_earth && el < opts.elev_mask {
            masked.push(i);
            continue;
        }
        let (iono, tropo) = if near_earth && g.h > -1000.0 && g.h < 1.0e5 {
            let ion = broadcast_iono(m, orbits, &g, az, el, tow);
            (ion.unwrap_or(0.0), model::troposphere(&g, el))
        } else {
            (0.0, 0.0)
        };
        let dtr = *clk.get(&m.sv.sys).unwrap_or(&0.0);
        let pred = rho + dtr - C * m.sat_clock + iono + tropo;
        let var = variance(m.sv.sys, el, iono, tropo)
            + if near_earth && orbits.broadcast.gps_iono.is_none() {
                25.0
            } else {
                0.0
            };
        rows.push((i, d / rho, m.pr - pred, var));
    }
    (rows, masked)
}

/// Broadcast ionosphere delay (m) on the measurement's frequency: Klobuchar, BeiDou's own
/// parameters for BeiDou when broadcast; `None` without parameters.
fn broadcast_iono(
    m: &Meas,
    orbits: &Orbits,
    g: &Geodetic,
    az: f64,
    el: f64,
    tow: f64,
) -> Option<f64> {
    let f1 = 1575.42e6;
    let gps = |k: &Klobuchar| model::klobuchar_gps(k, g, az, el, tow) * (f1 / m.freq).powi(2);
    match m.sv.sys {
        Constellation::BeiDou => orbits
            .broadcast
            .bds_iono
            .map(|k| {
                model::klobuchar_bds(&k, g, az, el, (tow - 14.0).rem_euclid(604800.0))
                    * (1561.098e6 / m.freq).powi(2)
            })
            .or_else(|| orbits.broadcast.gps_iono.map(|k| gps(&k))),
        _ => orbits.broadcast.gps_iono.map(|k| gps(&k)),
    }
}

/// Design matrix (−unit vector, 1 in the system's clock column), residual vector and weights
/// (1/variance) of the rows.
fn design(
    meas: &[Meas],
    rows: &[Row],
    systems: &[Constellation],
) -> (DMatrix<f64>, DVector<f64>, DVector<f64>) {
    let n = rows.len();
    let nx = 3 + systems.len();
    let mut h = DMatrix::<f64>::zeros(n, nx);
    let mut v = DVector::<f64>::zeros(n);
    let mut w = DVector::<f64>::zeros(n);
    for (r, (i, e, res, var)) in rows.iter().enumerate() {
        h[(r, 0)] = -e.x;
        h[(r, 1)] = -e.y;
        h[(r, 2)] = -e.z;
        let k = systems
            .iter()
            .position(|s| *s == meas[*i].sv.sys)
            .unwrap_or(0);
        h[(r, 3 + k)] = 1.0;
        v[r] = *res;
        w[r] = 1.0 / var;
    }
    (h, v, w)
}

fn dops(h: &DMatrix<f64>, g: &Geodetic, nx: usize) -> Dop {
    let q = (h.transpose() * h).try_inverse();
    let Some(q) = q else {
        return Dop {
            gdop: f64::INFINITY,
            pdop: f64::INFINITY,
            hdop: f64::INFINITY,
            vdop: f64::INFINITY,
        };
    };
    let r = enu_rotation(g);
    let qp = q.fixed_view::<3, 3>(0, 0).into_owned();
    let qe = r * qp * r.transpose();
    let tr_clk: f64 = (3..nx).map(|i| q[(i, i)]).sum();
    Dop {
        gdop: (qp.trace() + tr_clk).sqrt(),
        pdop: qp.trace().sqrt(),
        hdop: (qe[(0, 0)] + qe[(1, 1)]).sqrt(),
        vdop: qe[(2, 2)].sqrt(),
    }
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
