//! The double-difference Kalman filter: rover position plus single-difference float
//! ambiguities per satellite and frequency; double differences are formed in the measurement
//! model against a reference satellite per system and frequency, so reference changes need no
//! state surgery. Integer resolution by LAMBDA with partial fixing and fix-and-hold.

use super::geometry::{tropo, SatView};
use super::obs::{SatMeas, NF};
use super::slip::{SlipCause, SlipDetector};
use super::{ArMode, PpkOptions};
use crate::frame::{Ecef, Geodetic};
use crate::model::antex::AntennaPcv;
use crate::orbit::{Orbits, C};
use crate::solution::Quality;
use crate::sv::{Constellation, Sv};
use hifitime::Epoch;
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use std::collections::BTreeMap;

/// One ambiguity state.
#[derive(Clone, Debug)]
pub(super) struct Amb {
    pub(super) sv: Sv,
    pub(super) f: usize,
    /// Epochs since (re)initialisation.
    pub(super) lock: usize,
    pub(super) last: Epoch,
}

/// A satellite observed by both receivers this epoch.
pub(super) struct Pair {
    pub(super) r: SatMeas,
    pub(super) b: SatMeas,
    pub(super) vr: SatView,
    pub(super) vb: SatView,
    pub(super) rho_b: f64,
    pub(super) tropo_b: f64,
    pub(super) el: f64,
    /// Antenna phase-centre correction per slot, rover minus base, metres.
    pub(super) ant: [f64; NF],
}

/// Result of one epoch of one pass.
#[derive(Clone, Debug)]
pub struct EpochSol {
    pub time: Epoch,
    pub pos: Ecef,
    pub cov: Matrix3<f64>,
    pub quality: Quality,
    pub nsat: usize,
    pub ratio: f64,
    pub age: f64,
    /// Number of double-difference ambiguities fixed.
    pub nfix: usize,
}

impl EpochSol {
    /// The `.pos` line of this solution.
    pub fn to_record(&self) -> crate::solution::PosRecord {
        crate::solution::PosRecord {
            time: self.time,
            pos: self.pos,
            quality: self.quality,
            nsat: self.nsat,
            cov: self.cov,
            age: self.age,
            ratio: self.ratio,
        }
    }
}

/// Counters of a pass.
#[derive(Clone, Debug, Default)]
pub struct PassStats {
    pub slips: BTreeMap<SlipCause, usize>,
    /// Ambiguities reset because their post-fit residual was too large.
    pub outlier_resets: usize,
    /// Measurements rejected by the innovation gate.
    pub rejected_innovations: usize,
    pub below_mask: usize,
    pub no_orbit: usize,
}

pub struct Filter<'a> {
    pub(super) opts: &'a PpkOptions,
    pub(super) orbits: &'a Orbits,
    pub(super) base: Ecef,
    pub(super) base_geo: Geodetic,
    pub(super) x: DVector<f64>,
    pub(super) p: DMatrix<f64>,
    pub(super) ambs: Vec<Amb>,
    pub(super) rover_slip: SlipDetector,
    pub(super) base_slip: SlipDetector,
    pub(super) last_base_time: Option<Epoch>,
    pub(super) base_slips: BTreeMap<Sv, [Option<SlipCause>; NF]>,
    pub(super) pending_reset: Vec<(Sv, usize)>,
    pub(super) last_time: Option<Epoch>,
    pub stats: PassStats,
    pub(super) last_ratio: Option<f64>,
    rover_ant: Option<AntennaPcv>,
    base_ant: Option<AntennaPcv>,
}

/// Slot number of the ionosphere state of a satellite (after the frequency slots).
pub(super) const IONO: usize = NF;

/// Whether a pair observes a state's quantity: phase of slot `f` on both receivers, or for the
/// ionosphere state any phase.
fn observed(p: &Pair, f: usize) -> bool {
    if f == IONO {
        (0..NF).any(|k| p.r.l[k].is_finite() && p.b.l[k].is_finite())
    } else {
        p.r.l[f].is_finite() && p.b.l[f].is_finite()
    }
}

fn var_phase(el: f64, o: &PpkOptions) -> f64 {
    let s = el.sin().max(0.05);
    o.phase_sigma.0.powi(2) + (o.phase_sigma.1 / s).powi(2)
}

impl<'a> Filter<'a> {
    pub fn new(
        opts: &'a PpkOptions,
        orbits: &'a Orbits,
        base: Ecef,
        backward: bool,
        antennas: (Option<AntennaPcv>, Option<AntennaPcv>),
    ) -> Self {
        Filter {
            opts,
            orbits,
            base,
            base_geo: base.to_geodetic(),
            x: DVector::zeros(3),
            p: DMatrix::identity(3, 3) * 1e4,
            ambs: Vec::new(),
            rover_slip: SlipDetector::new(opts.max_gap, backward),
            base_slip: SlipDetector::new(opts.max_gap.max(3.0 * opts.max_age), backward),
            last_base_time: None,
            base_slips: BTreeMap::new(),
            pending_reset: Vec::new(),
            last_time: None,
            stats: PassStats::default(),
            last_ratio: None,
            rover_ant: antennas.0,
            base_ant: antennas.1,
        }
    }

    pub(super) fn idx(&self, sv: Sv, f: usize) -> Option<usize> {
        self.ambs
            .iter()
            .position(|a| a.sv == sv && a.f == f)
            .map(|i| 3 + i)
    }

    fn remove_state(&mut self, k: usize) {
        let n = self.x.len();
        let keep: Vec<usize> = (0..n).filter(|&i| i != k).collect();
        self.x = DVector::from_iterator(n - 1, keep.iter().map(|&i| self.x[i]));
        self.p = DMatrix::from_fn(n - 1, n - 1, |i, j| self.p[(keep[i], keep[j])]);
        self.ambs.remove(k - 3);
    }

    fn add_state(&mut self, a: Amb, value: f64, var: f64) {
        let n = self.x.len();
        let mut x = DVector::zeros(n + 1);
        x.rows_mut(0, n).copy_from(&self.x);
        x[n] = value;
        let mut p = DMatrix::zeros(n + 1, n + 1);
        p.view_mut((0, 0), (n, n)).copy_from(&self.p);
        p[(n, n)] = var;
        self.x = x;
        self.p = p;
        self.ambs.push(a);
    }

    /// Process one rover epoch against a base epoch. `start` is a position to linearise about
    /// (single point or previous solution).
    pub fn step(
        &mut self,
        t: Epoch,
        rover: &[SatMeas],
        tb: Epoch,
        base: &[SatMeas],
        start: Ecef,
    ) -> Option<EpochSol> {
        let o = self.opts;
        let dt = self
            .last_time
            .map(|l| (t - l).to_seconds().abs())
            .unwrap_or(0.0);
        self.last_time = Some(t);
        // Base slips only when the base epoch changes (a 1 Hz base serves many 10 Hz epochs).
        if self.last_base_time != Some(tb) {
            self.last_base_time = Some(tb);
            let s = self.base_slip.check_epoch(tb, base);
            self.base_slips = base.iter().map(|m| m.sv).zip(s).collect();
        }
        // Pairs of satellites seen by both receivers.
        let mut pairs: Vec<Pair> = Vec::new();
        let rover_slips: BTreeMap<Sv, [Option<SlipCause>; NF]> = rover
            .iter()
            .map(|m| m.sv)
            .zip(self.rover_slip.check_epoch(t, rover))
            .collect();
        let start_geo = start.to_geodetic();
        for r in rover {
            let Some(b) = base.iter().find(|b| b.sv == r.sv) else {
                continue;
            };
            let (Some(vr), Some(vb)) = (
                SatView::at(self.orbits, r, t),
                SatView::at(self.orbits, b, tb),
            ) else {
                self.stats.no_orbit += 1;
                continue;
            };
            // Mask and weights from the rover's view (an aircraft sees more sky than its base).
            let (az, el) = vr.az_el(&start, &start_geo);
            let (az_b, el_b) = vb.az_el(&self.base, &self.base_geo);
            if el < o.elev_mask {
                self.stats.below_mask += 1;
                continue;
            }
            let (rho_b, _) = vb.range(&self.base.0);
            pairs.push(Pair {
                r: r.clone(),
                b: b.clone(),
                vr,
                vb,
                rho_b,
                tropo_b: tropo(&self.base_geo, el_b),
                el,
                ant: std::array::from_fn(|f| {
                    let band = super::obs::slot_band(r.sv.sys, f);
                    let c = |a: &Option<AntennaPcv>, az, el| {
                        a.as_ref()
                            .map_or(0.0, |a| a.correction(r.sv.sys, band, az, el))
                    };
                    c(&self.rover_ant, az, el) - c(&self.base_ant, az_b, el_b)
                }),
            });
        }
        // Prediction: position from the start value with a wide variance (no dynamics model).
        let n = self.x.len();
        self.x.rows_mut(0, 3).copy_from(&start.0);
        for i in 0..n {
            for j in 0..3 {
                self.p[(i, j)] = 0.0;
                self.p[(j, i)] = 0.0;
            }
        }
        for j in 0..3 {
            self.p[(j, j)] = 30.0f64.powi(2);
        }
        // Ionosphere: single-difference slant delay per satellite, constrained by the baseline.
        let bl_km = (start.0 - self.base.0).norm() / 1000.0;
        let iono_sigma0 = (o.iono_sigma_per_km * bl_km).max(0.002);
        let iono_q = (o.iono_process_noise_per_km * bl_km).max(1e-5);
        // Ambiguity bookkeeping: resets for slips, outliers, gaps; instantaneous mode resets all.
        let mut k = 0;
        while k < self.ambs.len() {
            let a = self.ambs[k].clone();
            let rs = rover_slips
                .get(&a.sv)
                .and_then(|s| s.get(a.f).copied().flatten());
            let bs = self
                .base_slips
                .get(&a.sv)
                .and_then(|s| s.get(a.f).copied().flatten());
            let gap = (t - a.last).to_seconds().abs() > o.max_gap;
            let pending = self.pending_reset.contains(&(a.sv, a.f));
            if o.ar == ArMode::Instantaneous || rs.is_some() || bs.is_some() || gap || pending {
                if let Some(c) = rs.or(bs) {
                    *self.stats.slips.entry(c).or_default() += 1;
                } else if gap {
                    *self.stats.slips.entry(SlipCause::Gap).or_default() += 1;
                }
                self.remove_state(3 + k);
            } else {
                let i = 3 + k;
                let q = if a.f == IONO {
                    iono_q
                } else {
                    o.amb_process_noise
                };
                self.p[(i, i)] += q.powi(2) * dt;
                k += 1;
            }
        }
        self.pending_reset.clear();
        // Base slips apply once, to the first rover epoch that uses the new base epoch.
        self.base_slips.clear();
        // New ambiguity states from phase minus code.
        for pr in &pairs {
            for f in 0..o.nf {
                let (lr, lb) = (pr.r.l[f], pr.b.l[f]);
                if !(lr.is_finite() && lb.is_finite()) || self.idx(pr.r.sv, f).is_some() {
                    continue;
                }
                let lam = pr.r.wavelength(f);
                let (pr_r, pr_b) = (pr.r.p[f], pr.b.p[f]);
                let n0 = if pr_r.is_finite() && pr_b.is_finite() {
                    (lr - lb) - (pr_r - pr_b) / lam
                } else {
                    continue;
                };
                self.add_state(
                    Amb {
                        sv: pr.r.sv,
                        f,
                        lock: 0,
                        last: t,
                    },
                    n0,
                    o.amb_init_sigma.powi(2),
                );
            }
        }
        if o.estimate_iono {
            for pr in &pairs {
                if observed(pr, IONO) && self.idx(pr.r.sv, IONO).is_none() {
                    let a = Amb {
                        sv: pr.r.sv,
                        f: IONO,
                        lock: 0,
                        last: t,
                    };
                    self.add_state(a, 0.0, iono_sigma0.powi(2));
                }
            }
        }
        // Measurement update (iterated).
        let x0 = self.x.clone();
        let p0 = self.p.clone();
        let mut used_sats = 0;
        // Two linearisations: the geometry hardly cares about metres of start error, but the
        // rover troposphere does (5 m of height is 6 mm at 15° elevation).
        for _iter in 0..2 {
            let (h, v, r, _, nused) = self.measurements(&pairs, &self.x.clone(), true)?;
            used_sats = nused;
            // IEKF: innovation about the prior.
            let dxi = &x0 - &self.x;
            let innov = &v - &h * &dxi;
            let s = &h * &p0 * h.transpose() + &r;
            let ch = s.cholesky()?;
            // K = P·Hᵀ·S⁻¹, obtained as Kᵀ = S⁻¹·(H·P) without forming the inverse.
            let hp = &h * &p0;
            let k = ch.solve(&hp).transpose();
            self.x = &x0 + &k * innov;
            self.p = &p0 - &k * &hp;
        }
        self.p = (&self.p + self.p.transpose()) * 0.5;
        // Post-fit phase residuals: large ones betray an undetected slip.
        if let Some((_, v, _, rows, _)) = self.measurements(&pairs, &self.x.clone(), false) {
            for (i, (is_phase, sv, f)) in rows.iter().enumerate() {
                if *is_phase && v[i].abs() > o.max_phase_residual {
                    self.pending_reset.push((*sv, *f));
                    self.stats.outlier_resets += 1;
                }
            }
        }
        for a in self.ambs.iter_mut() {
            if pairs.iter().any(|p| p.r.sv == a.sv && observed(p, a.f)) {
                a.lock += 1;
                a.last = t;
            }
        }
        let float_pos = Vector3::new(self.x[0], self.x[1], self.x[2]);
        let float_cov = self.p.fixed_view::<3, 3>(0, 0).into_owned();
        let mut sol = EpochSol {
            time: t,
            pos: Ecef(float_pos),
            cov: float_cov,
            quality: Quality::Float,
            nsat: used_sats,
            ratio: 0.0,
            age: (t - tb).to_seconds(),
            nfix: 0,
        };
        if o.ar != ArMode::Off {
            if let Some((pos, cov, ratio, nfix, d, fix)) = self.resolve(&pairs) {
                sol.pos = Ecef(pos);
                sol.cov = cov;
                sol.quality = Quality::Fixed;
                sol.ratio = ratio;
                sol.nfix = nfix;
                if o.ar == ArMode::FixAndHold {
                    self.hold(&d, &fix);
                }
            } else if let Some(r) = self.last_ratio {
                sol.ratio = r;
            }
        }
        Some(sol)
    }
}

/// Measurement rows: (is_phase, satellite, frequency slot).
type Rows = Vec<(bool, Sv, usize)>;

impl Filter<'_> {
    /// Double-difference residuals, design matrix and covariance at state `x`.
    #[allow(clippy::type_complexity)]
    fn measurements(
        &mut self,
        pairs: &[Pair],
        x: &DVector<f64>,
        gate: bool,
    ) -> Option<(DMatrix<f64>, DVector<f64>, DMatrix<f64>, Rows, usize)> {
        let o = self.opts;
        let rx = Vector3::new(x[0], x[1], x[2]);
        let rg = Ecef(rx).to_geodetic();
        // Per pair: undifferenced-model pieces.
        struct Pre {
            e: Vector3<f64>,
            sd_model: f64,
        }
        let pre: Vec<Pre> = pairs
            .iter()
            .map(|p| {
                let (rho_r, e) = p.vr.range(&rx);
                let tr = if rg.h > -500.0 && rg.h < 2.0e4 {
                    tropo(&rg, p.el)
                } else {
                    0.0
                };
                Pre {
                    e,
                    sd_model: (rho_r - p.rho_b) - C * (p.vr.clock - p.vb.clock) + (tr - p.tropo_b),
                }
            })
            .collect();
        let nx = x.len();
        let mut hrows: Vec<DVector<f64>> = Vec::new();
        let mut vs: Vec<f64> = Vec::new();
        let mut blocks: Vec<(Vec<f64>, f64)> = Vec::new(); // (variances of non-ref SDs, ref SD variance)
        let mut rows: Rows = Vec::new();
        let mut used = std::collections::BTreeSet::new();
        for sys in Constellation::ALL {
            for f in 0..o.nf {
                for phase in [true, false] {
                    // Candidates with the needed data (and an ambiguity state for phase).
                    let cand: Vec<usize> = (0..pairs.len())
                        .filter(|&i| {
                            let p = &pairs[i];
                            p.r.sv.sys == sys
                                && if phase {
                                    p.r.l[f].is_finite()
                                        && p.b.l[f].is_finite()
                                        && self.idx(p.r.sv, f).is_some()
                                } else {
                                    p.r.p[f].is_finite() && p.b.p[f].is_finite()
                                }
                        })
                        .collect();
                    if cand.len() < 2 {
                        continue;
                    }
                    let refi = *cand.iter().max_by(|&&a, &&b| {
                        pairs[a]
                            .el
                            .partial_cmp(&pairs[b].el)
                            .unwrap_or(std::cmp::Ordering::Equal)
                    })?;
                    let obs_sd = |i: usize| -> f64 {
                        let p = &pairs[i];
                        if phase {
                            p.r.wavelength(f) * (p.r.l[f] - p.b.l[f])
                        } else {
                            p.r.p[f] - p.b.p[f]
                        }
                    };
                    let fac = if phase {
                        1.0
                    } else {
                        o.code_phase_ratio.powi(2)
                    };
                    let sd_var = |i: usize| 2.0 * fac * var_phase(pairs[i].el, o);
                    // Ionosphere scale of this slot relative to the first (delays code, advances phase).
                    let mu = |i: usize| {
                        (pairs[i].r.freq[0] / pairs[i].r.freq[f]).powi(2)
                            * if phase { -1.0 } else { 1.0 }
                    };
                    let model_sd = |s: &Self, i: usize| -> f64 {
                        let mut m = pre[i].sd_model + pairs[i].ant[f];
                        if phase {
                            let k = s.idx(pairs[i].r.sv, f).unwrap_or(0);
                            m += pairs[i].r.wavelength(f) * x[k];
                        }
                        if let Some(k) = s.idx(pairs[i].r.sv, IONO) {
                            m += mu(i) * x[k];
                        }
                        m
                    };
                    let y_ref = obs_sd(refi) - model_sd(self, refi);
                    let mut vars = Vec::new();
                    for &i in &cand {
                        if i == refi {
                            continue;
                        }
                        let v = (obs_sd(i) - model_sd(self, i)) - y_ref;
                        if gate && v.abs() > o.max_innovation {
                            self.stats.rejected_innovations += 1;
                            continue;
                        }
                        let mut hr = DVector::zeros(nx);
                        let de = -(pre[i].e - pre[refi].e);
                        hr[0] = de.x;
                        hr[1] = de.y;
                        hr[2] = de.z;
                        if let (Some(ki), Some(kr)) = (
                            self.idx(pairs[i].r.sv, IONO),
                            self.idx(pairs[refi].r.sv, IONO),
                        ) {
                            hr[ki] = mu(i);
                            hr[kr] = -mu(refi);
                        }
                        if phase {
                            let ki = self.idx(pairs[i].r.sv, f)?;
                            let kr = self.idx(pairs[refi].r.sv, f)?;
                            hr[ki] = pairs[i].r.wavelength(f);
                            hr[kr] = -pairs[refi].r.wavelength(f);
                        }
                        hrows.push(hr);
                        vs.push(v);
                        vars.push(sd_var(i));
                        rows.push((phase, pairs[i].r.sv, f));
                        used.insert(pairs[i].r.sv);
                        used.insert(pairs[refi].r.sv);
                    }
                    if !vars.is_empty() {
                        blocks.push((vars, sd_var(refi)));
                    }
                }
            }
        }
        let m = vs.len();
        if m == 0 {
            return None;
        }
        let h = DMatrix::from_fn(m, nx, |i, j| hrows[i][j]);
        let v = DVector::from_vec(vs);
        let mut r = DMatrix::zeros(m, m);
        let mut at = 0;
        for (vars, vref) in &blocks {
            for a in 0..vars.len() {
                for b in 0..vars.len() {
                    r[(at + a, at + b)] = if a == b { vars[a] + vref } else { *vref };
                }
            }
            at += vars.len();
        }
        Some((h, v, r, rows, used.len()))
    }
}
