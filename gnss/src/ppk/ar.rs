//! Integer ambiguity resolution on the filter state.
//!
//! - Candidates: SD ambiguity states of non-GLONASS satellites (GLONASS SD ambiguities absorb
//!   inter-frequency biases and stay float) locked for `min_lock` epochs, observed this epoch
//!   above the AR elevation mask, whose phase carries no unresolved half cycle at either
//!   receiver (such a phase may be half a cycle off: it stays float and is never held).
//! - Double differences per system and slot ([`DdGroup`]); pivot = the highest satellite among
//!   those locked for `mature_lock` epochs (a freshly reset pivot would make every DD of its
//!   group uncertain). The DD operator D maps the state to the DD ambiguities: +1 on the
//!   satellite's SD state, −1 on the pivot's.
//! - Partial resolution: a = D·x, Q_a = D·P·Dᵀ are decorrelated (LAMBDA, ẑ = Zᵀ·a); the
//!   subset S of the most precise decorrelated ambiguities whose bootstrapped success rate
//!   reaches `min_success_rate` is searched (integer least squares) and must pass the ratio
//!   test, else S loses its least precise member and is tried again. On long baselines the
//!   wide lanes enter S long before the narrow lanes; on short ones S is the whole set.
//! - The fixed subset as constraints on the state: C = Z_Sᵀ·D, C·x = ž_S. Fixed position:
//!   x_pos − P_pos·Cᵀ·Q⁻¹·(C·x − ž), covariance P_pos − P_pos·Cᵀ·Q⁻¹·C·P_pos (Q = C·P·Cᵀ),
//!   plus (1 − P_s)·δ·δᵀ where δ is the position shift to the second-best candidate: the σ
//!   of a fix whose validation is weak includes the chance that it is wrong. A fix counts
//!   (Q = 1) only when that position σ is at most `max_partial_fix_sigma`: a wide-lane-only
//!   fix improves the float solution but is no fixed solution.
//! - Fix-and-hold: the float state is constrained to C·x = ž with variance `hold_variance`.
//! - [`resolve_without`] resolves with one satellite's ambiguities kept float (the filter's
//!   smoother tries each of [`candidate_satellites`] when the whole set will not fix); the
//!   [`Fix`] names the satellite left out.
//!
//! What enters: the filter state (read only), the options and the epoch's pairs. What leaves:
//! a [`Fix`] (or the check that refused one, a [`Refusal`]) and the best ratio tried, from [`resolve`] or [`resolve_without`];
//! [`hold`] constrains the state. The filter calls them; this module does not know the filter.

use super::dd::DdGroup;
use super::lambda::{decorrelate, Decorrelated, IntegerCandidates};
use super::options::PpkOptions;
use super::pair::{has_phase, Pair};
use super::refusal::Refusal;
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
    /// Its covariance, m² (including the wrong-fix term).
    pub(super) covariance: Matrix3<f64>,
    /// Ratio test value of the accepted subset (capped at 999.9).
    pub(super) ratio: f64,
    /// Number of decorrelated ambiguities fixed.
    pub(super) n_fixed: usize,
    /// Constraint rows C over the whole state vector, one per fixed decorrelated ambiguity.
    pub(super) constraints: DMatrix<f64>,
    /// The integers ž, one per row of `constraints`.
    pub(super) integers: DVector<f64>,
    /// The DD groups, in DD row order (one row per non-pivot member).
    pub(super) groups: Vec<DdGroup<Candidate>>,
    /// Each DD ambiguity's integer when the fix determines it (conditioned σ below 0.02
    /// cycle), in DD row order.
    pub(super) dd_integers: Vec<Option<i64>>,
    /// Satellites whose double-difference wide lane (first minus second slot, one pivot for
    /// both) the fix determines (conditioned σ below 0.02 cycle).
    pub(super) widelanes: usize,
    /// The integers determine the position (at least three satellites fixed on every slot,
    /// `min_fix_ambiguities` DD integers in all: a wide-lane-only fix is not); how precisely
    /// is [`Fix::sigma_3d`]'s to say.
    pub(super) complete: bool,
    /// The satellite whose ambiguities were kept float for this fix (see
    /// [`resolve_without`]), if any.
    pub(super) left_out: Option<Sv>,
}

impl Fix {
    /// The 3D σ of the fixed position, metres.
    pub(super) fn sigma_3d(&self) -> f64 {
        self.covariance.trace().sqrt()
    }

    /// The fix determines the position within [`PpkOptions::fixed_sigma_limit`].
    pub(super) fn precise(&self, o: &PpkOptions) -> bool {
        self.complete && self.sigma_3d() <= o.fixed_sigma_limit()
    }

    /// The arcs of every ambiguity the fix took part in (pivots and others).
    pub(super) fn arcs(&self) -> impl Iterator<Item = u64> + '_ {
        self.groups
            .iter()
            .flat_map(|g| g.others.iter().chain([&g.pivot]))
            .map(|c| c.arc)
    }
}

/// Whether the DD integers a fix determines (`dd_integers`, in the rows of `groups`) fix
/// the position: at least three satellites (with their pivots, four) have the integers of
/// every slot they were candidates on, and `min_total` DD integers are fixed in all. A
/// satellite with the L1 integer alone fixes nothing when the ionosphere is estimated.
fn determines_position(
    groups: &[DdGroup<Candidate>],
    dd_integers: &[Option<i64>],
    min_total: usize,
) -> bool {
    // Per satellite: (DDs it is in, DDs of it fixed).
    let mut per_sat: BTreeMap<Sv, (usize, usize)> = BTreeMap::new();
    let mut row = 0;
    for g in groups {
        for c in &g.others {
            let e = per_sat.entry(c.sv()).or_default();
            e.0 += 1;
            e.1 += usize::from(dd_integers[row].is_some());
            row += 1;
        }
    }
    let complete = per_sat.values().filter(|(n, k)| n == k).count();
    let total: usize = per_sat.values().map(|(_, k)| k).sum();
    complete >= 3 && total >= min_total
}

/// Double-difference groups per system and slot over the candidates but those of `left_out`.
fn dd_groups(cands: &[Candidate], left_out: Option<Sv>, mature: usize) -> Vec<DdGroup<Candidate>> {
    let mut by_signal: BTreeMap<(Constellation, usize), Vec<Candidate>> = BTreeMap::new();
    for c in cands.iter().filter(|c| Some(c.sv()) != left_out) {
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

/// The DD operator of groups, kept sparse: per row (one per non-pivot member) the state
/// offsets of its +1 (the member) and its −1 (the pivot). Products with it are differences
/// of two rows or columns, rounded once as the dense products would round them.
fn dd_operator(groups: &[DdGroup<Candidate>]) -> Vec<(usize, usize)> {
    groups
        .iter()
        .flat_map(|g| g.others.iter().map(move |c| (c.state, g.pivot.state)))
        .collect()
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
    let r = DMatrix::identity(d.nrows(), d.nrows()) * var;
    let Some((dx, pn)) = super::update::update(p, d, &r, &v) else {
        return false;
    };
    *x += dx;
    *p = (&pn + pn.transpose()) * 0.5;
    true
}

/// Whether either receiver's phase of `slot` carries an unresolved half-cycle ambiguity.
pub(super) fn half_cycle(p: &Pair, slot: usize) -> bool {
    p.r.half_cycle(slot) || p.b.half_cycle(slot)
}

/// The ambiguities that may be fixed this epoch, in state order: locked long enough, above
/// the AR mask, and (with `half_cycle_float`) without an unresolved half cycle.
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
        if o.half_cycle_float && half_cycle(p, amb.slot) {
            continue;
        }
        if o.float_slots.contains(&(amb.sv.sys, amb.slot)) {
            continue;
        }
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

/// Pairs of DD rows (first slot, second slot) of one satellite against one pivot: its
/// wide lane is their difference.
fn widelane_rows(groups: &[DdGroup<Candidate>]) -> Vec<(usize, usize)> {
    let mut rows: BTreeMap<(Sv, usize), (Sv, usize)> = BTreeMap::new();
    let mut row = 0;
    for g in groups {
        for c in &g.others {
            rows.insert((c.sv(), g.slot), (g.pivot.sv(), row));
            row += 1;
        }
    }
    rows.iter()
        .filter(|((_, slot), _)| *slot == 0)
        .filter_map(|((sv, _), (pivot, i))| {
            let (p2, j) = rows.get(&(*sv, 1))?;
            (p2 == pivot).then_some((*i, *j))
        })
        .collect()
}

/// The float DD ambiguities of the groups and their covariance.
struct FloatDd {
    /// DD operator (DD rows × state), as [`dd_operator`] gives it.
    d: Vec<(usize, usize)>,
    /// Float DD ambiguities, cycles.
    a: DVector<f64>,
    /// Their covariance, cycles².
    q: DMatrix<f64>,
}

impl FloatDd {
    fn of(st: &State, groups: &[DdGroup<Candidate>]) -> FloatDd {
        let d = dd_operator(groups);
        let m = d.len();
        let a = DVector::from_iterator(m, d.iter().map(|&(i, r)| st.x[i] - st.x[r]));
        // D·P row by row (P is symmetric: its rows are its columns), then (D·P)·Dᵀ.
        let dp = DMatrix::from_fn(m, st.x.len(), |i, j| {
            let (a, r) = d[i];
            st.p[(a, j)] - st.p[(r, j)]
        });
        let q = DMatrix::from_fn(m, m, |i, j| {
            let (a, r) = d[j];
            dp[(i, a)] - dp[(i, r)]
        });
        let q = (&q + q.transpose()) * 0.5;
        FloatDd { d, a, q }
    }

    /// D·M for a matrix M over the state (rows: state).
    fn times(&self, m: &DMatrix<f64>) -> DMatrix<f64> {
        DMatrix::from_fn(self.d.len(), m.ncols(), |i, j| {
            let (a, r) = self.d[i];
            m[(a, j)] - m[(r, j)]
        })
    }
}

/// The position conditioned on a set of integers.
struct FixedSolution {
    position: Vector3<f64>,
    /// Includes the chance of a wrong fix.
    covariance: Matrix3<f64>,
    /// Rows: the fixed combinations of the state.
    constraints: DMatrix<f64>,
    /// Each DD ambiguity's integer when the fix determines it.
    dd_integers: Vec<Option<i64>>,
    /// Satellites whose wide lane the fix determines.
    widelanes: usize,
}

/// The fixed solution for the best integers of `cands` (with the runner-up weighted by the
/// chance of a wrong fix) of the last `k` decorrelated ambiguities of the float DD
/// ambiguities of `groups`; None when the constrained system is singular.
fn fixed_solution(
    st: &State,
    (fl, groups): (&FloatDd, &[DdGroup<Candidate>]),
    dec: &Decorrelated,
    k: usize,
    cands: &IntegerCandidates,
) -> Option<FixedSolution> {
    let n = dec.n;
    let zs = DMatrix::from_fn(n, k, |i, j| dec.z_column(n - k + j)[i]);
    // C = Z_Sᵀ·D, k × state: integers, exact in any order.
    let mut c = DMatrix::zeros(k, st.x.len());
    for (row, &(a, r)) in fl.d.iter().enumerate() {
        for i in 0..k {
            c[(i, a)] += zs[(row, i)];
            c[(i, r)] -= zs[(row, i)];
        }
    }
    let pc = &st.p * c.transpose(); // m × k
    let q = &c * &pc;
    let ch = ((&q + q.transpose()) * 0.5).cholesky()?;
    let best = DVector::from_column_slice(&cands.fixes[0]);
    let shift = ch.solve(&(&c * &st.x - &best));
    let pos = position_range(st);
    let p_pos = pc.rows(pos.start, pos.len());
    let x = st.x.rows(pos.start, pos.len()) - p_pos * &shift;
    let mut cov = st.p.view((pos.start, pos.start), (3, 3)) - p_pos * ch.solve(&p_pos.transpose());
    if let Some(second) = cands.fixes.get(1) {
        let delta = p_pos * ch.solve(&(DVector::from_column_slice(second) - &best));
        cov += &delta * delta.transpose() * (1.0 - dec.success_rate(k));
    }
    // The DD ambiguities conditioned on the fix: those it determines become integers.
    let qac = fl.times(&pc); // DD × k
    let a_fixed = &fl.a - &qac * &shift;
    // Only the diagonal of Q_a − Q_ac·Q⁻¹·Q_ca is read: column sums of squares of L⁻¹·Q_ca.
    let y = ch.l_dirty().solve_lower_triangular(&qac.transpose())?;
    let dd_integers = (0..fl.a.len())
        .map(|i| {
            let var = fl.q[(i, i)] - y.column(i).norm_squared();
            (var.max(0.0).sqrt() < 0.02).then(|| a_fixed[i].round() as i64)
        })
        .collect();
    // The wide lane of a satellite: its first-slot DD row minus its second-slot one, when
    // both groups have the same pivot; conditioned variance from the same columns.
    let widelanes = widelane_rows(groups)
        .into_iter()
        .filter(|&(i, j)| {
            let var = fl.q[(i, i)] + fl.q[(j, j)]
                - 2.0 * fl.q[(i, j)]
                - (y.column(i) - y.column(j)).norm_squared();
            var.max(0.0).sqrt() < 0.02
        })
        .count();
    Some(FixedSolution {
        position: Vector3::new(x[0], x[1], x[2]),
        covariance: Matrix3::from_fn(|i, j| cov[(i, j)]),
        constraints: c,
        dd_integers,
        widelanes,
    })
}

/// Resolve the ambiguities of this epoch on the filter state `st` by partial resolution of
/// the most precise decorrelated ambiguities. `best_ratio` is set to the best ratio tried
/// (None when no subset was tried); without a fix, the check that refused it.
pub(super) fn resolve(
    st: &State,
    o: &PpkOptions,
    pairs: &[Pair],
    best_ratio: &mut Option<f64>,
) -> Result<Fix, Refusal> {
    resolve_without(st, o, pairs, best_ratio, None)
}

/// The satellites with an ambiguity that may be fixed this epoch, in order.
pub(super) fn candidate_satellites(st: &State, o: &PpkOptions, pairs: &[Pair]) -> Vec<Sv> {
    let mut out: Vec<Sv> = candidates(st, o, pairs).iter().map(Candidate::sv).collect();
    out.sort_unstable();
    out.dedup();
    out
}

/// [`resolve`] with the ambiguities of satellite `left_out` (when given) kept float.
pub(super) fn resolve_without(
    st: &State,
    o: &PpkOptions,
    pairs: &[Pair],
    best_ratio: &mut Option<f64>,
    left_out: Option<Sv>,
) -> Result<Fix, Refusal> {
    *best_ratio = None;
    let cands = candidates(st, o, pairs);
    let groups = dd_groups(&cands, left_out, o.mature_lock);
    let fl = FloatDd::of(st, &groups);
    if fl.a.len() < o.min_fix_ambiguities {
        return Err(Refusal::Candidates);
    }
    // A float covariance the decomposition cannot take is as good as no float to fix.
    let dec = decorrelate(fl.a.as_slice(), fl.q.as_slice()).ok_or(Refusal::SuccessRate)?;
    let mut k = dec.most_fixable(o.min_success_rate);
    if k < o.min_fix_ambiguities {
        return Err(Refusal::SuccessRate);
    }
    while k >= o.min_fix_ambiguities {
        let c = dec.search_last(k, 2).ok_or(Refusal::Ratio)?;
        let ratio = c.ratio().min(999.9);
        *best_ratio = Some(best_ratio.map_or(ratio, |r: f64| r.max(ratio)));
        if ratio >= o.ratio_threshold {
            let FixedSolution {
                position,
                covariance,
                constraints,
                dd_integers,
                widelanes,
            } = fixed_solution(st, (&fl, &groups), &dec, k, &c).ok_or(Refusal::SigmaLimit)?;
            let complete = determines_position(&groups, &dd_integers, o.min_fix_ambiguities);
            return Ok(Fix {
                complete,
                position,
                covariance,
                ratio,
                n_fixed: k,
                constraints,
                integers: DVector::from_column_slice(&c.fixes[0]),
                groups,
                dd_integers,
                widelanes,
                left_out,
            });
        }
        k -= 1;
    }
    Err(Refusal::Ratio)
}

/// Fix-and-hold: constrain the float ambiguities of `st` to the fixed integers with
/// variance `var` (cycles²).
pub(super) fn hold(st: &mut State, fix: &Fix, var: f64) {
    constrain(&mut st.x, &mut st.p, &fix.constraints, &fix.integers, var);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cand(prn: u8, slot: usize, state: usize) -> Candidate {
        Candidate {
            state,
            amb: AmbKey {
                sv: Sv::new(Constellation::Gps, prn),
                slot,
            },
            elevation: 0.5,
            lock: 10,
            arc: state as u64,
        }
    }

    /// A satellite's wide lane pairs its first- and second-slot DD rows when both groups
    /// share the pivot; a satellite on one slot only, or against another pivot, has none.
    #[test]
    fn widelanes_pair_the_rows_of_one_satellite_against_one_pivot() {
        let l1 = DdGroup {
            slot: 0,
            pivot: cand(1, 0, 0),
            others: vec![cand(2, 0, 1), cand(3, 0, 2), cand(4, 0, 3)],
        };
        let l2 = DdGroup {
            slot: 1,
            pivot: cand(1, 1, 4),
            others: vec![cand(3, 1, 5), cand(2, 1, 6)],
        };
        // Rows: L1 of G02, G03, G04 (0, 1, 2), then L2 of G03, G02 (3, 4).
        let mut pairs = widelane_rows(&[l1.clone(), l2]);
        pairs.sort_unstable();
        assert_eq!(pairs, vec![(0, 4), (1, 3)]);
        let other_pivot = DdGroup {
            slot: 1,
            pivot: cand(2, 1, 4),
            others: vec![cand(3, 1, 5), cand(1, 1, 6)],
        };
        assert!(widelane_rows(&[l1, other_pivot]).is_empty());
    }
}
