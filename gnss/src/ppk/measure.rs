//! The measurement model: double-difference residuals of carrier phase and code, their design
//! rows and covariance, formed without side effects; and the innovation gate, a separate pass
//! that removes rows and says why.
//!
//! Conventions:
//! - Single difference (SD) = rover − base; double difference (DD) = SD of a satellite − SD of
//!   the pivot of its group ([`DdGroup`]: one system, one slot, one kind; pivot = the highest
//!   satellite).
//! - Residual (innovation) v = observed − modelled, metres, at the state the rows are formed
//!   at; phase observed as λ·(L_rover − L_base), modelled with λ times the SD ambiguity states.
//! - Design row h = ∂(modelled)/∂x over the whole state vector: −(e_s − e_pivot) on the
//!   position block (e = unit vector receiver → satellite, ECEF), ±λ on the two SD ambiguity
//!   states of a phase row, ±μ (ionospheric scale of the slot, negative for phase) on the SD
//!   ionosphere states when the model has them, m_w(el_s) − m_w(el_pivot) (Niell wet mapping at
//!   the rover) on the zenith wet delay state when it has that.
//! - Covariance: SD variance 2·σ²(el) (σ² = a² + (b/sin el)², code scaled by the code/phase
//!   ratio²) plus each receiver's C/N0 term (`PpkOptions::snr_sigma`), the code's multiplied
//!   by its correlation over the rover interval (`code_correlation_s`), or, when larger, the
//!   two receivers' code variances measured on their own data (`ppk::codenoise`), plus the
//!   base age's (see `PpkOptions::age_error_rate`); DDs of one group share their pivot's SD
//!   variance.
//! - GLONASS code rows carry the inter-channel code bias state times the channel number
//!   difference of the two satellites; code rows of a slot whose two receivers track
//!   different codes carry ±1 on the two satellites' SD code-bias states.
//! - Row order: system (`Constellation::ALL`), slot, phase before code, then the pairs' order.

use super::dd::DdGroup;
use super::geometry::tropo;
use super::obs::NF;
use super::options::PpkOptions;
use super::pair::{has_code, has_phase, Pair};
use super::state::{AmbKey, State, StateKey};
use crate::frame::Ecef;
use crate::orbit::C;
use crate::sv::{Constellation, Sv};
use nalgebra::{DMatrix, DVector, Vector3};
use std::collections::{BTreeMap, BTreeSet};
use std::ops::Range;

/// Carrier phase or code.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum ObsKind {
    /// Carrier phase (needs SD ambiguity states).
    Phase,
    /// Pseudorange.
    Code,
}

/// Why the innovation gate removed a measurement row.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum GateReason {
    /// A carrier-phase DD innovation larger than the gate (`max_innovation`).
    PhaseInnovation,
    /// A code DD innovation larger than the gate (`max_innovation`).
    CodeInnovation,
}

/// One double-difference measurement row.
#[derive(Clone, Debug)]
pub(super) struct Row {
    /// Phase or code.
    pub(super) kind: ObsKind,
    /// The satellite differenced against the pivot.
    pub(super) sv: Sv,
    /// The pivot of its group.
    pub(super) pivot: Sv,
    /// Frequency slot.
    pub(super) slot: usize,
    /// Index of its group (rows of one group are consecutive).
    pub(super) group: usize,
    /// Design row over the whole state vector, its non-zero entries.
    pub(super) h: SparseRow,
    /// Observed − modelled, metres.
    pub(super) innovation: f64,
    /// SD variance of `sv` (the group adds its pivot's), m².
    pub(super) var: f64,
}

/// Most non-zero entries of a design row: the position (3), two ambiguities, two
/// ionosphere states and the zenith wet delay (a code row: the GLONASS code bias instead of
/// the ambiguities).
const ROW_ENTRIES: usize = 8;

/// The non-zero entries of a design row, (state offset, value), without an allocation.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct SparseRow {
    entries: [(usize, f64); ROW_ENTRIES],
    len: usize,
}

impl SparseRow {
    /// Set the entry of state `k` to `v` (replacing a value set before).
    fn set(&mut self, k: usize, v: f64) {
        if let Some(e) = self.entries[..self.len].iter_mut().find(|e| e.0 == k) {
            e.1 = v;
            return;
        }
        assert!(
            self.len < ROW_ENTRIES,
            "a design row has at most {ROW_ENTRIES} entries"
        );
        self.entries[self.len] = (k, v);
        self.len += 1;
    }

    /// The entries set, in the order first set.
    pub(super) fn entries(&self) -> &[(usize, f64)] {
        &self.entries[..self.len]
    }
}

/// The rows of one epoch at one state.
#[derive(Clone, Debug, Default)]
pub(super) struct Residuals {
    /// Rows in model order.
    pub(super) rows: Vec<Row>,
    /// SD variance of each group's pivot, m².
    pub(super) pivot_var: Vec<f64>,
}

/// Design matrix, innovations and their covariance of the rows kept.
pub(super) struct Linearised {
    /// Design matrix (rows × state length).
    pub(super) h: DMatrix<f64>,
    /// Innovations, metres.
    pub(super) v: DVector<f64>,
    /// Covariance of the innovations, m².
    pub(super) r: DMatrix<f64>,
    /// Satellites used (as satellite or pivot of a row).
    pub(super) used_sats: usize,
}

fn var_phase(el: f64, o: &PpkOptions) -> f64 {
    let s = el.sin().max(0.05);
    o.phase_sigma.0.powi(2) + (o.phase_sigma.1 / s).powi(2)
}

/// The C/N0 term of one receiver's variance (m²): the noise of a signal `drop` dB below the
/// receiver's normal C/N0 in excess of a normal one, σ²·(10^(drop/10) − 1) (σ at 3 dB below,
/// 5.5σ at 15 dB below; nothing when unknown).
fn var_snr(drop: f64, sigma: f64) -> f64 {
    if drop.is_nan() || drop <= 0.0 || sigma <= 0.0 {
        return 0.0;
    }
    sigma * sigma * (10f64.powf(drop.min(40.0) / 10.0) - 1.0)
}

/// The single-difference variance (m²) of slot `f` of pair `p`, phase or code: elevation
/// terms of both receivers (the code's scaled by the code/phase ratio), each receiver's C/N0
/// term, the excess phase and the code multiplied by their [`correlation`]s `corr` (phase,
/// code), and the base age.
fn sd_variance(p: &Pair, f: usize, phase: bool, o: &PpkOptions, corr: (f64, f64)) -> f64 {
    let el = 2.0 * var_phase(p.el, o);
    let v = if phase {
        // The excess of a weakened signal is multipath and diffraction (what lowers C/N0):
        // as correlated in time as they are.
        let snr = var_snr(p.r.cn0_drop(f), o.snr_sigma.0) + var_snr(p.b.cn0_drop(f), o.snr_sigma.0);
        el + snr * corr.0
    } else {
        let white = o.code_phase_ratio.powi(2) * el
            + var_snr(p.r.cn0_drop(f), o.snr_sigma.1)
            + var_snr(p.b.cn0_drop(f), o.snr_sigma.1);
        // What the receivers' own data say their codes are worth (`ppk::codenoise`), when
        // more than the model says.
        let measured = p.r.code_var(f) + p.b.code_var(f);
        if measured.is_finite() {
            (white * corr.1).max(measured)
        } else {
            white * corr.1
        }
    };
    v + p.age_var
}

/// How much each epoch's variance grows for errors correlated over `tau` seconds (a
/// first-order Gauss–Markov process sampled at the rover's interval Δt, lag-one correlation
/// ρ = e^(−Δt/τ)): a filter that takes the epochs as independent gains from n of them what n·(1 − ρ)/(1 + ρ)
/// independent ones would give, so each weighs as its variance times (1 + ρ)/(1 − ρ)
/// (about 2τ/Δt for τ ≫ Δt; 1 for τ = 0).
pub(super) fn correlation(tau: f64, o: &PpkOptions) -> f64 {
    if o.interval_s > 0.0 && tau > 0.0 {
        let rho = (-o.interval_s / tau).exp();
        (1.0 + rho) / (1.0 - rho)
    } else {
        1.0
    }
}

/// The GLONASS frequency channel number of slot `f` of a satellite (None for other
/// systems or an unknown frequency).
fn glonass_channel(m: &super::obs::SatMeas, f: usize) -> Option<f64> {
    if m.sv.sys != Constellation::Glonass || !m.freq[f].is_finite() {
        return None;
    }
    let (base, step) = if f == 0 {
        (1602.0e6, 0.5625e6)
    } else {
        (1246.0e6, 0.4375e6)
    };
    Some(((m.freq[f] - base) / step).round())
}

/// SD model pieces of one pair at the linearisation point.
struct Pre {
    /// Unit vector rover → satellite.
    e: Vector3<f64>,
    /// Modelled SD range without ambiguity, antenna and ionosphere, metres.
    sd_model: f64,
}

fn undifferenced(pairs: &[Pair], rx: &Vector3<f64>) -> Vec<Pre> {
    let rg = Ecef(*rx).to_geodetic();
    pairs
        .iter()
        .map(|p| {
            let (rho_r, e) = p.vr.range(rx);
            let tr = tropo(&rg, p.el, p.doy);
            Pre {
                e,
                sd_model: (rho_r - p.rho_b) - C * (p.vr.clock - p.vb.clock) + (tr - p.tropo_b),
            }
        })
        .collect()
}

/// Each pair's state offsets, looked up once per epoch (the rows read them many times).
struct StateOffsets {
    /// SD ambiguity state per pair and slot.
    ambiguity: Vec<[Option<usize>; NF]>,
    /// SD ionosphere state per pair.
    iono: Vec<Option<usize>>,
    /// SD code-bias state per pair and slot.
    code_bias: Vec<[Option<usize>; NF]>,
}

impl StateOffsets {
    fn of(pairs: &[Pair], state: &State, nf: usize) -> Self {
        let ambiguity = pairs
            .iter()
            .map(|p| {
                std::array::from_fn(|slot| {
                    (slot < nf)
                        .then(|| state.offset(StateKey::Ambiguity(AmbKey { sv: p.r.sv, slot })))
                        .flatten()
                })
            })
            .collect();
        let iono = pairs
            .iter()
            .map(|p| state.offset(StateKey::Iono(p.r.sv)))
            .collect();
        let code_bias = pairs
            .iter()
            .map(|p| {
                std::array::from_fn(|slot| {
                    (slot < nf)
                        .then(|| state.offset(StateKey::CodeBias(AmbKey { sv: p.r.sv, slot })))
                        .flatten()
                })
            })
            .collect();
        StateOffsets {
            ambiguity,
            iono,
            code_bias,
        }
    }
}

/// The single differences of one slot and kind at the current state: what the rows of one
/// group read of each pair (by index `i` into `pairs`).
struct SlotModel<'a> {
    /// The epoch's rover–base pairs.
    pairs: &'a [Pair],
    /// Their SD model pieces.
    pre: &'a [Pre],
    /// Their state offsets.
    offsets: &'a StateOffsets,
    /// The state vector.
    x: &'a DVector<f64>,
    /// Zenith wet delay state.
    ztd: Option<usize>,
    /// GLONASS inter-channel code bias state.
    glo_bias: Option<usize>,
    /// The options (variance model).
    o: &'a PpkOptions,
    /// Variance correlation factors (phase, code), see [`correlation`].
    corr: (f64, f64),
    /// Frequency slot.
    f: usize,
    /// Phase or code.
    kind: ObsKind,
    /// Whether `kind` is phase.
    phase: bool,
}

impl SlotModel<'_> {
    /// SD ambiguity state of pair `i`.
    fn amb(&self, i: usize) -> Option<usize> {
        self.offsets.ambiguity[i][self.f]
    }

    /// SD code-bias state of pair `i` (code rows only).
    fn code_bias(&self, i: usize) -> Option<usize> {
        self.offsets.code_bias[i][self.f].filter(|_| self.kind == ObsKind::Code)
    }

    /// Observed SD of pair `i`, metres.
    fn obs_sd(&self, i: usize) -> f64 {
        let (p, f) = (&self.pairs[i], self.f);
        if self.phase {
            p.r.wavelength(f) * (p.r.l[f] - p.b.l[f])
        } else {
            p.r.p[f] - p.b.p[f]
        }
    }

    /// SD variance of pair `i`, m².
    fn sd_var(&self, i: usize) -> f64 {
        sd_variance(&self.pairs[i], self.f, self.phase, self.o, self.corr)
    }

    /// GLONASS code: the inter-channel bias state and the channel of pair `i`.
    fn chan(&self, i: usize) -> Option<(usize, f64)> {
        self.glo_bias
            .filter(|_| !self.phase)
            .and_then(|k| Some((k, glonass_channel(&self.pairs[i].r, self.f)?)))
    }

    /// Ionosphere scale of this slot relative to the first (delays code, advances phase).
    fn mu(&self, i: usize) -> f64 {
        let p = &self.pairs[i];
        (p.r.freq[0] / p.r.freq[self.f]).powi(2) * if self.phase { -1.0 } else { 1.0 }
    }

    /// Modelled SD of pair `i` at the state, metres.
    fn model_sd(&self, i: usize) -> f64 {
        let mut m = self.pre[i].sd_model + self.pairs[i].ant[self.f];
        if self.phase {
            let k = self.amb(i).unwrap_or(0);
            m += self.pairs[i].r.wavelength(self.f) * self.x[k];
        }
        if let Some(k) = self.offsets.iono[i] {
            m += self.mu(i) * self.x[k];
        }
        if let Some(k) = self.ztd {
            m += self.pairs[i].map_wet * self.x[k];
        }
        if let Some((k, ch)) = self.chan(i) {
            m += ch * self.x[k];
        }
        if let Some(k) = self.code_bias(i) {
            m += self.x[k];
        }
        m
    }

    /// Design row of the DD of pair `i` against pivot `refi`; `pos` the position block.
    fn design_row(&self, i: usize, refi: usize, pos: &Range<usize>) -> SparseRow {
        let mut hr = SparseRow::default();
        let de = -(self.pre[i].e - self.pre[refi].e);
        for (k, v) in pos.clone().zip(de.iter()) {
            hr.set(k, *v);
        }
        if let (Some(ki), Some(kr)) = (self.offsets.iono[i], self.offsets.iono[refi]) {
            hr.set(ki, self.mu(i));
            hr.set(kr, -self.mu(refi));
        }
        if let Some(k) = self.ztd {
            hr.set(k, self.pairs[i].map_wet - self.pairs[refi].map_wet);
        }
        if let (Some((k, a)), Some((_, b))) = (self.chan(i), self.chan(refi)) {
            hr.set(k, a - b);
        }
        if let Some(k) = self.code_bias(i) {
            hr.set(k, 1.0);
        }
        if let Some(k) = self.code_bias(refi) {
            hr.set(k, -1.0);
        }
        if self.phase {
            if let (Some(ki), Some(kr)) = (self.amb(i), self.amb(refi)) {
                hr.set(ki, self.pairs[i].r.wavelength(self.f));
                hr.set(kr, -self.pairs[refi].r.wavelength(self.f));
            }
        }
        hr
    }

    /// Append the rows of `group` to `out`, and its pivot's SD variance.
    fn push_group(&self, group: &DdGroup<usize>, pos: &Range<usize>, out: &mut Residuals) {
        let refi = group.pivot;
        let y_ref = self.obs_sd(refi) - self.model_sd(refi);
        let gi = out.pivot_var.len();
        for &i in &group.others {
            let v = (self.obs_sd(i) - self.model_sd(i)) - y_ref;
            out.rows.push(Row {
                kind: self.kind,
                sv: self.pairs[i].r.sv,
                pivot: self.pairs[refi].r.sv,
                slot: group.slot,
                group: gi,
                h: self.design_row(i, refi, pos),
                innovation: v,
                var: self.sd_var(i),
            });
        }
        out.pivot_var.push(self.sd_var(refi));
    }
}

/// Every DD row of the epoch at the current state, none rejected.
pub(super) fn residuals(pairs: &[Pair], state: &State, o: &PpkOptions) -> Residuals {
    let x = &state.x;
    let pos = state
        .index()
        .range(StateKey::Position)
        .expect("the position block exists");
    let rx = Vector3::from_iterator(x.rows_range(pos.clone()).iter().copied());
    let pre = undifferenced(pairs, &rx);
    let offsets = StateOffsets::of(pairs, state, o.nf);
    let ztd = state.offset(StateKey::Tropo);
    let glo_bias = state.offset(StateKey::GlonassCodeBias);
    let corr = (
        correlation(o.phase_correlation_s, o),
        correlation(o.code_correlation_s, o),
    );
    let mut out = Residuals::default();
    for sys in Constellation::ALL {
        if !pairs.iter().any(|p| p.r.sv.sys == sys) {
            continue;
        }
        for f in 0..o.nf {
            for kind in [ObsKind::Phase, ObsKind::Code] {
                let model = SlotModel {
                    pairs,
                    pre: &pre,
                    offsets: &offsets,
                    x,
                    ztd,
                    glo_bias,
                    o,
                    corr,
                    f,
                    kind,
                    phase: kind == ObsKind::Phase,
                };
                // Members with the needed data (and an ambiguity state for phase).
                let members: Vec<usize> = (0..pairs.len())
                    .filter(|&i| {
                        let p = &pairs[i];
                        p.r.sv.sys == sys
                            && match kind {
                                ObsKind::Phase => has_phase(p, f) && model.amb(i).is_some(),
                                ObsKind::Code => has_code(p, f),
                            }
                    })
                    .collect();
                let Some(group) = DdGroup::form(f, members, |&i| pairs[i].el) else {
                    continue;
                };
                model.push_group(&group, &pos, &mut out);
            }
        }
    }
    out
}

/// The innovation gate: rows whose |innovation| exceeds `max_innovation` (m) are removed.
/// Returns the rows kept (in order) and how many were removed, per reason.
pub(super) fn gate(
    res: Residuals,
    max_innovation: f64,
) -> (Residuals, BTreeMap<GateReason, usize>) {
    let mut counts = BTreeMap::new();
    let Residuals { rows, pivot_var } = res;
    let rows = rows
        .into_iter()
        .filter(|r| {
            if r.innovation.abs() > max_innovation {
                let reason = match r.kind {
                    ObsKind::Phase => GateReason::PhaseInnovation,
                    ObsKind::Code => GateReason::CodeInnovation,
                };
                *counts.entry(reason).or_insert(0) += 1;
                false
            } else {
                true
            }
        })
        .collect();
    (Residuals { rows, pivot_var }, counts)
}

/// What identifies a row: its kind, satellite, pivot and slot.
pub(super) type RowId = (ObsKind, Sv, Sv, usize);

impl Residuals {
    /// The rows' identities, in order.
    pub(super) fn row_ids(&self) -> Vec<RowId> {
        self.rows
            .iter()
            .map(|r| (r.kind, r.sv, r.pivot, r.slot))
            .collect()
    }

    /// Design matrix, innovations and covariance for a state of length `nx`; None without
    /// rows.
    pub(super) fn linearise(&self, nx: usize) -> Option<Linearised> {
        let rows = &self.rows;
        let m = rows.len();
        if m == 0 {
            return None;
        }
        let mut h = DMatrix::zeros(m, nx);
        for (i, r) in rows.iter().enumerate() {
            for &(j, v) in r.h.entries() {
                h[(i, j)] = v;
            }
        }
        let v = DVector::from_iterator(m, rows.iter().map(|r| r.innovation));
        let mut r = DMatrix::zeros(m, m);
        let mut at = 0;
        while at < m {
            let g = rows[at].group;
            let len = rows[at..].iter().take_while(|x| x.group == g).count();
            let vref = self.pivot_var[g];
            for a in 0..len {
                for b in 0..len {
                    r[(at + a, at + b)] = if a == b {
                        rows[at + a].var + vref
                    } else {
                        vref
                    };
                }
            }
            at += len;
        }
        let used: BTreeSet<Sv> = rows.iter().flat_map(|r| [r.sv, r.pivot]).collect();
        Some(Linearised {
            h,
            v,
            r,
            used_sats: used.len(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(kind: ObsKind, prn: u8, group: usize, innovation: f64) -> Row {
        Row {
            kind,
            sv: Sv::new(Constellation::Gps, prn),
            pivot: Sv::new(Constellation::Gps, 1),
            slot: 0,
            group,
            h: {
                let mut h = SparseRow::default();
                (0..4).for_each(|j| h.set(j, prn as f64));
                h
            },
            innovation,
            var: prn as f64,
        }
    }

    /// The gate removes exactly the rows beyond it, keeps the order, counts per reason; the
    /// covariance of what is left keeps each group's pivot variance on its block.
    #[test]
    fn gate_removes_counts_and_keeps_groups() {
        let res = Residuals {
            rows: vec![
                row(ObsKind::Phase, 2, 0, 0.01),
                row(ObsKind::Phase, 3, 0, 31.0),
                row(ObsKind::Phase, 4, 0, -0.02),
                row(ObsKind::Code, 2, 1, -40.0),
                row(ObsKind::Code, 3, 1, 35.0),
                row(ObsKind::Code, 5, 2, 1.0),
            ],
            pivot_var: vec![0.5, 7.0, 9.0],
        };
        let (kept, counts) = gate(res, 30.0);
        let prns: Vec<u8> = kept.rows.iter().map(|r| r.sv.prn).collect();
        assert_eq!(prns, vec![2, 4, 5]);
        assert_eq!(counts.get(&GateReason::PhaseInnovation), Some(&1));
        assert_eq!(counts.get(&GateReason::CodeInnovation), Some(&2));
        let lin = kept.linearise(4).unwrap();
        assert_eq!(lin.v.as_slice(), &[0.01, -0.02, 1.0]);
        assert_eq!(lin.r[(0, 0)], 2.5);
        assert_eq!(lin.r[(0, 1)], 0.5);
        assert_eq!(lin.r[(1, 1)], 4.5);
        assert_eq!(lin.r[(2, 2)], 14.0);
        assert_eq!(lin.r[(1, 2)], 0.0);
        assert_eq!(lin.h[(2, 3)], 5.0);
        assert_eq!(lin.used_sats, 4);
        let (empty, _) = gate(
            Residuals {
                rows: vec![row(ObsKind::Code, 2, 0, 99.0)],
                pivot_var: vec![1.0],
            },
            30.0,
        );
        assert!(empty.linearise(4).is_none());
    }
}
