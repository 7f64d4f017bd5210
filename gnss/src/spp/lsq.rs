//! The least squares of one epoch: code observations linearised at the current position
//! (Earth rotation during signal travel, elevation mask, broadcast ionosphere, Saastamoinen
//! troposphere, elevation-dependent variances), position and one receiver clock per system
//! solved by weighted least squares until the step is below 0.1 mm, then the chi-square,
//! RMS, covariance and DOPs at the solution.
//!
//! Enters: the epoch's measurements (satellites at transmission time, ECEF) and a starting
//! position (ECEF, metres). Leaves: an [`Lsq`] (position ECEF, clocks in metres, covariance
//! m²) or the [`SppFailure`]. Residuals are observed − computed, metres.

use super::types::{chi2_999, Dop, Meas, SppFailure, SppOptions};
use crate::frame::{az_el, enu_rotation, rotate_to_reception, Ecef, Geodetic};
use crate::model;
use crate::orbit::{Orbits, C};
use crate::rinex::nav::Klobuchar;
use crate::sv::Constellation;
use hifitime::Epoch;
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use std::collections::BTreeMap;

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

/// A converged least-squares solution.
pub(super) struct Lsq {
    /// Receiver position, ECEF.
    pub(super) x: Vector3<f64>,
    /// Receiver clock per system, metres.
    pub(super) clocks: BTreeMap<Constellation, f64>,
    /// Position covariance, ECEF, m².
    pub(super) cov: Matrix3<f64>,
    /// Weighted sum of squared post-fit residuals.
    pub(super) chi2: f64,
    /// RMS of the post-fit residuals, metres.
    pub(super) rms: f64,
    /// Dilutions of precision at the solution.
    pub(super) dop: Dop,
    /// Indices (into the measurements) used.
    pub(super) used: Vec<usize>,
    /// Indices below the elevation mask.
    pub(super) masked: Vec<usize>,
    /// Number of unknowns: position and one clock per system.
    pub(super) nx: usize,
}

impl Lsq {
    /// Critical chi-square (0.1 %) for the solution's redundancy.
    pub(super) fn chi2_threshold(&self) -> f64 {
        chi2_999(self.used.len() - self.nx)
    }
    /// Redundant and failing the chi-square test.
    pub(super) fn inconsistent(&self) -> bool {
        self.used.len() > self.nx && self.chi2 > self.chi2_threshold()
    }
    /// Chi-square per degree of freedom (for comparing exclusions).
    pub(super) fn chi2_per_dof(&self) -> f64 {
        self.chi2 / ((self.used.len() - self.nx).max(1) as f64)
    }
}

/// One linearised code observation: measurement index, unit vector receiver → satellite
/// (ECEF), observed − computed (m), variance (m²).
type Row = (usize, Vector3<f64>, f64, f64);

/// Iterated weighted least squares on the measurements `subset` from `x0` (ECEF): position
/// and one clock per system, up to 12 iterations until the position step is below 0.1 mm.
pub(super) fn lsq(
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
