//! Integer ambiguity resolution on the filter state.
//!
//! - Candidates: SD ambiguity states of non-GLONASS satellites (GLONASS SD ambiguities absorb
//!   inter-frequency biases and stay float) locked for `min_lock` epochs, observed this epoch
//!   above the AR elevation mask.
//! - Double differences per system and slot ([`DdGroup`]); pivot = the highest satellite among
//!   those locked for `mature_lock` epochs (a freshly reset pivot would make every DD of its
//!   group uncertain). The DD operator D maps the state to the DD ambiguities: +1 on the
//!   satellite's SD state, −1 on the pivot's.
//! - LAMBDA on a = D·x, Q_a = D·P·Dᵀ with the ratio test; when the full set fails on
//!   dual-frequency data, the wide lane (slot 0 − slot 1) is fixed first on a copy of the
//!   state; then partial fixing drops the newest, then the lowest satellite.
//! - Fixed position: x_pos − Q_pos,a·Q_a⁻¹·(a − ǎ), covariance P_pos − Q_pos,a·Q_a⁻¹·Q_a,pos.
//! - Fix-and-hold: the float state is constrained to D·x = ǎ with variance `hold_variance`.
//!
//! What enters: the filter state (read only), the options and the epoch's pairs. What leaves:
//! a [`Fix`] (or none) and the best ratio tried, from [`resolve`]; [`hold`] constrains the
//! state. The filter calls both; this module does not know the filter.

use super::dd::DdGroup;
use super::lambda::lambda;
use super::options::PpkOptions;
use super::pair::{has_phase, Pair};
use super::state::{AmbKey, State, StateKey};
use crate::sv::{Constellation, Sv};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use std::collections::BTreeMap;
use std::ops::Range;

/// An ambiguity that may be fixed this epoch.
#[derive(Clone, Copy, Debug)]
pub(super) struct Candidate {
    /// Offset of its SD state in the state vector.
    pub(super) state: usize,
    /// Satellite and slot.
    pub(super) amb: AmbKey,
    /// Rover elevation, radians.
    pub(super) elevation: f64,
    /// Epochs since the state was (re)initialised.
    pub(super) lock: usize,
    /// Arc of the state (see [`super::state::Track`]).
    pub(super) arc: u64,
}

impl Candidate {
    fn sv(&self) -> Sv {
        self.amb.sv
    }
}

/// A fixed solution.
#[derive(Clone, Debug)]
pub(super) struct Fix {
    /// Rover position conditioned on the integers, ECEF metres.
    pub(super) position: Vector3<f64>,
    /// Its covariance, m².
    pub(super) covariance: Matrix3<f64>,
    /// Ratio test value (capped at 999.9).
    pub(super) ratio: f64,
    /// Number of DD ambiguities fixed.
    pub(super) n_fixed: usize,
    /// DD operator (one row per fixed DD, over the whole state vector).
    pub(super) dd_operator: DMatrix<f64>,
    /// The integers, one per row of `dd_operator`.
    pub(super) integers: DVector<f64>,
    /// The groups the rows come from, in row order (one row per non-pivot member).
    pub(super) groups: Vec<DdGroup<Candidate>>,
}

/// Double-difference groups per system and slot over the candidates not excluded.
fn dd_groups(cands: &[Candidate], excluded: &[Sv], mature: usize) -> Vec<DdGroup<Candidate>> {
    let mut by_signal: BTreeMap<(Constellation, usize), Vec<Candidate>> = BTreeMap::new();
    for c in cands.iter().filter(|c| !excluded.contains(&c.sv())) {
        by_signal
            .entry((c.amb.sv.sys, c.amb.slot))
            .or_default()
            .push(*c);
    }
    by_signal
        .into_iter()
        .filter_map(|((_, slot), members)| {
            DdGroup::form(slot, members, |c| (c.lock >= mature, c.elevation))
        })
        .collect()
}

/// The DD operator of groups: one row per non-pivot member, +1 on its state, −1 on the pivot's.
fn dd_operator(groups: &[DdGroup<Candidate>], n: usize) -> DMatrix<f64> {
    let m = groups.iter().map(|g| g.others.len()).sum();
    let mut d = DMatrix::zeros(m, n);
    let rows = groups
        .iter()
        .flat_map(|g| g.others.iter().map(move |c| (c.state, g.pivot.state)));
    for (i, (a, r)) in rows.enumerate() {
        d[(i, a)] = 1.0;
        d[(i, r)] = -1.0;
    }
    d
}

/// Constrain `x`, `p` to `d·x = z` with variance `var` (a Kalman update).
fn constrain(
    x: &mut DVector<f64>,
    p: &mut DMatrix<f64>,
    d: &DMatrix<f64>,
    z: &DVector<f64>,
    var: f64,
) -> bool {
    let v = z - d * &*x;
    let s = d * &*p * d.transpose() + DMatrix::identity(d.nrows(), d.nrows()) * var;
    let Some(ch) = s.cholesky() else { return false };
    let dp = d * &*p;
    let k = ch.solve(&dp).transpose();
    *x += &k * v;
    *p = &*p - &k * &dp;
    *p = (&*p + p.transpose()) * 0.5;
    true
}

/// The ambiguities that may be fixed this epoch, in state order.
fn candidates(st: &State, o: &PpkOptions, pairs: &[Pair]) -> Vec<Candidate> {
    let mut cands = Vec::new();
    for (state, s) in st.sats() {
        let StateKey::Ambiguity(amb) = s.key else {
            continue;
        };
        if amb.sv.sys == Constellation::Glonass || s.track.lock < o.min_lock {
            continue;
        }
        let Some(p) = pairs
            .iter()
            .find(|p| p.r.sv == amb.sv && has_phase(p, amb.slot))
        else {
            continue;
        };
        if p.el >= o.ar_elev_mask {
            cands.push(Candidate {
                state,
                amb,
                elevation: p.el,
                lock: s.track.lock,
                arc: s.track.arc,
            });
        }
    }
    cands
}

/// Offsets of the position block.
fn position_range(st: &State) -> Range<usize> {
    st.index()
        .range(StateKey::Position)
        .expect("the position block exists")
}

/// LAMBDA on the groups' DDs; the fix when the ratio test passes. Records the best ratio
/// seen in `best_ratio`.
fn try_fix(
    st: &State,
    o: &PpkOptions,
    best_ratio: &mut Option<f64>,
    x: &DVector<f64>,
    p: &DMatrix<f64>,
    groups: Vec<DdGroup<Candidate>>,
) -> Option<Fix> {
    let d = dd_operator(&groups, x.len());
    let m = d.nrows();
    let a = &d * x;
    let q = &d * p * d.transpose();
    let q = (&q + q.transpose()) * 0.5;
    let c = lambda(a.as_slice(), q.as_slice(), 2)?;
    let ratio = c.ratio().min(999.9);
    *best_ratio = Some(best_ratio.map_or(ratio, |r: f64| r.max(ratio)));
    if ratio < o.ratio_threshold {
        return None;
    }
    let fix = DVector::from_vec(c.fixes[0].clone());
    let pos = position_range(st);
    let (p0, n) = (pos.start, pos.len());
    let qxa = p.rows(p0, n) * d.transpose();
    let ch = q.cholesky()?;
    let x_fixed = x.rows(p0, n) - &qxa * ch.solve(&(&a - &fix));
    let cov = p.view((p0, p0), (n, n)) - &qxa * ch.solve(&qxa.transpose());
    Some(Fix {
        position: Vector3::new(x_fixed[0], x_fixed[1], x_fixed[2]),
        covariance: Matrix3::from_fn(|i, j| cov[(i, j)]),
        ratio,
        n_fixed: m,
        dd_operator: d,
        integers: fix,
        groups,
    })
}

/// Wide-lane (slot 0 − slot 1) double differences fixed on a copy of the state.
fn widelane(
    st: &State,
    o: &PpkOptions,
    cands: &[Candidate],
) -> Option<(DVector<f64>, DMatrix<f64>)> {
    let n = st.x.len();
    let mut rows: Vec<[(usize, f64); 4]> = Vec::new();
    for sys in Constellation::ALL {
        // Satellites of this system with both slot-0 and slot-1 candidates.
        let both: Vec<(Candidate, Candidate)> = cands
            .iter()
            .filter(|c| c.amb.sv.sys == sys && c.amb.slot == 0)
            .filter_map(|c1| {
                cands
                    .iter()
                    .find(|c2| c2.amb.sv == c1.amb.sv && c2.amb.slot == 1)
                    .map(|c2| (*c1, *c2))
            })
            .collect();
        let Some(g) = DdGroup::form(0, both, |(c1, _)| c1.elevation) else {
            continue;
        };
        let (r1, r2) = g.pivot;
        for (s1, s2) in &g.others {
            rows.push([
                (s1.state, 1.0),
                (s2.state, -1.0),
                (r1.state, -1.0),
                (r2.state, 1.0),
            ]);
        }
    }
    if rows.len() < o.min_fix_ambiguities {
        return None;
    }
    let mut d = DMatrix::zeros(rows.len(), n);
    for (i, row) in rows.iter().enumerate() {
        for (k, v) in row {
            d[(i, *k)] = *v;
        }
    }
    let (x, p) = (&st.x, &st.p);
    let a = &d * x;
    let q = &d * p * d.transpose();
    let q = (&q + q.transpose()) * 0.5;
    let c = lambda(a.as_slice(), q.as_slice(), 2)?;
    if c.ratio() < o.ratio_threshold {
        return None;
    }
    let (mut x, mut p) = (x.clone(), p.clone());
    let z = DVector::from_vec(c.fixes[0].clone());
    constrain(&mut x, &mut p, &d, &z, o.hold_variance).then_some((x, p))
}

/// Resolve the ambiguities of this epoch on the filter state `st`: full set, wide lane
/// first, then partial sets. `best_ratio` is set to the best ratio tried (None when no
/// set was tried).
pub(super) fn resolve(
    st: &State,
    o: &PpkOptions,
    pairs: &[Pair],
    best_ratio: &mut Option<f64>,
) -> Option<Fix> {
    let cands = candidates(st, o, pairs);
    let (mut x, mut p) = (st.x.clone(), st.p.clone());
    let mut excluded: Vec<Sv> = Vec::new();
    let mut widelane_tried = o.nf < 2;
    *best_ratio = None;
    let mut attempt = 0;
    while attempt <= o.max_partial_drops {
        let groups = dd_groups(&cands, &excluded, o.mature_lock);
        let n_dd: usize = groups.iter().map(|g| g.others.len()).sum();
        if n_dd < o.min_fix_ambiguities {
            return None;
        }
        if let Some(f) = try_fix(st, o, best_ratio, &x, &p, groups) {
            // A partial fix that leaves the position at several centimetres is no fix:
            // the solution stays float rather than claim what it does not have.
            if !excluded.is_empty() && f.covariance.trace().sqrt() > o.max_partial_fix_sigma {
                return None;
            }
            return Some(f);
        }
        if !widelane_tried {
            widelane_tried = true;
            if let Some((xw, pw)) = widelane(st, o, &cands) {
                (x, p) = (xw, pw);
                continue;
            }
        }
        // Partial fixing: drop the newest, then the lowest satellite.
        let worst = cands
            .iter()
            .filter(|c| !excluded.contains(&c.sv()))
            .min_by(|a, b| {
                let ka = (a.lock >= o.mature_lock, a.elevation);
                let kb = (b.lock >= o.mature_lock, b.elevation);
                ka.partial_cmp(&kb).unwrap_or(std::cmp::Ordering::Equal)
            })?;
        excluded.push(worst.sv());
        attempt += 1;
    }
    None
}

/// Fix-and-hold: constrain the float ambiguities of `st` to the fixed integers with
/// variance `var` (cycles²).
pub(super) fn hold(st: &mut State, fix: &Fix, var: f64) {
    constrain(&mut st.x, &mut st.p, &fix.dd_operator, &fix.integers, var);
}
