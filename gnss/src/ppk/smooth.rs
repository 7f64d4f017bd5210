//! The two-filter smoother: at each epoch the forward filter's estimate (all data up to and
//! including the epoch) is combined with the backward filter's prediction (all data after
//! it), so every epoch sees the whole arc of each ambiguity without counting any data twice.
//!
//! The backward pass records, before each epoch's measurements, its states other than the
//! position ([`Prior`]: the position is re-initialised at every epoch and carries nothing).
//! Both passes cut the same arcs ([`super::slip::arc_breaks`]), so a state key names the same
//! physical quantity in both at that epoch. The forward state is then updated with the
//! recorded estimate as a measurement of the states both hold (z = x_b, H selects them,
//! R = P_b): x_s = x_f + K·(x_b − H·x_f), P_s = P_f − K·H·P_f with K = P_f·Hᵀ·(H·P_f·Hᵀ + R)⁻¹.
//! The position follows through its correlation with the ambiguities, ionosphere and
//! troposphere of the forward state.
//!
//! The double differences do not see a constant added to every single-difference ambiguity of
//! one system and slot, so each filter fixes that common part from its own start (phase minus
//! code; a receiver clock jump can move it by millions of cycles between the passes). Before
//! the combination the backward ambiguities of each system and slot are shifted by the mean
//! difference over the shared ones: the double differences are untouched, and the
//! combination no longer mixes that arbitrary difference into the other states. GLONASS
//! ambiguities (a different wavelength per satellite, so the common part is seen) are left
//! out of the combination.
//!
//! The priors of the states are counted in both filters; for ambiguities the double
//! differences do not see them, for the atmospheric states they are wide.
//!
//! What enters: forward [`State`]s and backward [`Prior`]s. What leaves: the smoothed
//! [`State`] (the forward layout). This module knows neither the filter nor the passes.

use super::state::{SatState, State, StateKey};
use crate::sv::Constellation;
use nalgebra::{DMatrix, DVector};
use std::collections::BTreeMap;

/// An aligned ambiguity the two passes disagree on by more than this (cycles) is left out.
const MAX_AMBIGUITY_DIFFERENCE: f64 = 1000.0;

/// The backward filter's estimate of its non-position states at one epoch, before that
/// epoch's measurements.
#[derive(Clone, Debug)]
pub struct Prior {
    /// The states, in `x` order, with their bookkeeping.
    sats: Vec<SatState>,
    /// Their keys.
    keys: Vec<StateKey>,
    /// Their values.
    x: DVector<f64>,
    /// Their covariance.
    p: DMatrix<f64>,
}

impl Prior {
    /// The non-position states of `state`.
    pub(super) fn of(state: &State) -> Prior {
        let (offsets, sats): (Vec<usize>, Vec<SatState>) =
            state.sats().map(|(k, s)| (k, s.clone())).unzip();
        let keys = sats.iter().map(|s| s.key).collect();
        Prior {
            sats,
            x: DVector::from_iterator(offsets.len(), offsets.iter().map(|&k| state.x[k])),
            p: DMatrix::from_fn(offsets.len(), offsets.len(), |i, j| {
                state.p[(offsets[i], offsets[j])]
            }),
            keys,
        }
    }

    /// The estimate as a filter state with an unknown position (for resolving its
    /// ambiguities alone).
    pub(super) fn to_state(&self) -> State {
        State::from_sats(&self.sats, &self.x, &self.p, 1e8)
    }
}

/// The forward `state` combined with the backward `prior` (states both hold); None when
/// they share no state or the combination is singular.
pub(super) fn fuse(state: &State, prior: &Prior) -> Option<State> {
    let shared: Vec<(usize, usize)> = prior
        .keys
        .iter()
        .enumerate()
        .filter(|(_, k)| !matches!(k, StateKey::Ambiguity(a) if a.sv.sys == Constellation::Glonass))
        .filter_map(|(i, k)| state.offset(*k).map(|f| (f, i)))
        .collect();
    // The backward values with each system's and slot's common ambiguity part aligned by
    // the median difference; an ambiguity whose difference is far from it belongs to arcs
    // the passes started apart (a clock jump between them) and is left out.
    let group = |i: usize| match prior.keys[i] {
        StateKey::Ambiguity(a) => Some((a.sv.sys, a.slot)),
        _ => None,
    };
    let mut diffs: BTreeMap<(Constellation, usize), Vec<f64>> = BTreeMap::new();
    for &(f, b) in &shared {
        if let Some(g) = group(b) {
            diffs.entry(g).or_default().push(prior.x[b] - state.x[f]);
        }
    }
    let shift: BTreeMap<(Constellation, usize), f64> = diffs
        .into_iter()
        .map(|(g, mut d)| {
            d.sort_by(f64::total_cmp);
            (g, d[d.len() / 2])
        })
        .collect();
    let xb = |b: usize| prior.x[b] - group(b).and_then(|g| shift.get(&g)).copied().unwrap_or(0.0);
    let common: Vec<(usize, usize)> = shared
        .into_iter()
        .filter(|&(f, b)| (xb(b) - state.x[f]).abs() < MAX_AMBIGUITY_DIFFERENCE)
        .collect();
    if common.is_empty() {
        return None;
    }
    let m = common.len();
    let n = state.x.len();
    // H·P_f (m × n) and H·P_f·Hᵀ + R.
    let hp = DMatrix::from_fn(m, n, |r, c| state.p[(common[r].0, c)]);
    let s = DMatrix::from_fn(m, m, |r, c| {
        state.p[(common[r].0, common[c].0)] + prior.p[(common[r].1, common[c].1)]
    });
    let ch = ((&s + s.transpose()) * 0.5).cholesky()?;
    let innov = DVector::from_fn(m, |r, _| xb(common[r].1) - state.x[common[r].0]);
    let k = ch.solve(&hp).transpose(); // n × m
    let mut out = state.clone();
    out.x = &state.x + &k * innov;
    let p = &state.p - &k * &hp;
    out.p = (&p + p.transpose()) * 0.5;
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ppk::state::AmbKey;
    use crate::sv::{Constellation, Sv};

    fn amb(prn: u8) -> StateKey {
        StateKey::Ambiguity(AmbKey {
            sv: Sv::new(Constellation::Gps, prn),
            slot: 0,
        })
    }

    /// Two independent estimates of a shared state combine by their weights; a state only
    /// one side holds keeps its value; the position follows through its correlation.
    #[test]
    fn fusion_weights_by_precision_and_carries_correlation() {
        let t = crate::time::from_week_tow(2300, 0.0);
        let mut f = State::new(1.0);
        f.add(amb(1), t, 10.0, 4.0);
        f.add(amb(2), t, 5.0, 1.0);
        // Position x correlated with ambiguity 1: cov 1.0 (position variance 1).
        let a1 = f.offset(amb(1)).unwrap();
        f.p[(0, a1)] = 1.0;
        f.p[(a1, 0)] = 1.0;
        let mut b = State::new(1e6);
        b.add(amb(1), t, 12.0, 4.0);
        b.add(amb(3), t, 0.0, 1.0);
        let prior = Prior::of(&b);
        assert_eq!(prior.keys.len(), 2);
        let s = fuse(&f, &prior).unwrap();
        // Ambiguity 1 is the only shared one of its group: its common part is aligned away.
        assert!((s.x[a1] - 10.0).abs() < 1e-12);
        assert!((s.p[(a1, a1)] - 2.0).abs() < 1e-12);
        let a2 = f.offset(amb(2)).unwrap();
        assert_eq!(s.x[a2], 5.0);
        // A shared tropospheric delay combines by weights, and the position follows through
        // its correlation: cov(x, T)/var(T) times T's change.
        let mut f2 = State::new(1.0);
        f2.add(StateKey::Tropo, t, 0.10, 4.0);
        f2.p[(0, 3)] = 1.0;
        f2.p[(3, 0)] = 1.0;
        let mut b2 = State::new(1e6);
        b2.add(StateKey::Tropo, t, 0.12, 4.0);
        let s2 = fuse(&f2, &Prior::of(&b2)).unwrap();
        assert!((s2.x[3] - 0.11).abs() < 1e-12, "equal weights: the mean");
        assert!((s2.x[0] - 0.0025).abs() < 1e-12, "{}", s2.x[0]);
        assert!(fuse(&State::new(1.0), &prior).is_none());
    }
}
