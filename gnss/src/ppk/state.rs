//! The filter's state: a typed layout that says what each element of the state vector is,
//! the vector itself and its covariance.
//!
//! Layout (the only place that knows offsets):
//! ```text
//! x = [ rover position (ECEF X, Y, Z; m)            ← kinematic block, StateKey::Position
//!       per-satellite states, in the order added:
//!         StateKey::Ambiguity(AmbKey { sv, slot })  single-difference (rover − base) carrier
//!                                                   ambiguity, cycles of that slot
//!         StateKey::Iono(sv)                        single-difference slant ionospheric delay
//!                                                   on slot 0, metres (optional model)
//!         StateKey::Tropo                           rover zenith wet delay residual, metres
//!                                                   (optional model; one state, never reset)
//!         StateKey::GlonassCodeBias                 GLONASS inter-channel code bias, rover
//!                                                   − base, metres per channel number
//!                                                   (with GLONASS; one state, never reset)
//!         StateKey::CodeBias(AmbKey { sv, slot })   single-difference code bias of a slot
//!                                                   whose two receivers track different
//!                                                   codes (C1W against C1C), metres;
//!                                                   kept through slips ]
//! ```
//! The satellite part is built from the satellites in view: a state is added when its
//! satellite is first seen (or seen again after a reset) and removed when it is reset, and the
//! vector is compacted, so states keep the order in which they were added. The kinematic block
//! is first and fixed in size; a velocity block would be a second kinematic block placed
//! after the position (there is none: the filter has no dynamics model).
//!
//! Every satellite state carries its bookkeeping ([`Track`]): lock count, last epoch observed
//! and an arc number that changes whenever the state is (re)initialised, so a fixed integer
//! is compared with an earlier one only when both belong to the same arc.

use crate::sv::Sv;
use hifitime::Epoch;
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use std::collections::BTreeMap;
use std::ops::Range;

/// A carrier-phase ambiguity: one satellite on one frequency slot (the system is the
/// satellite's).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub(super) struct AmbKey {
    /// The satellite.
    pub(super) sv: Sv,
    /// Frequency slot (0..`NF`).
    pub(super) slot: usize,
}

/// What a block of the state vector is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub(super) enum StateKey {
    /// Rover antenna position, ECEF metres (three elements).
    Position,
    /// Single-difference ambiguity, cycles.
    Ambiguity(AmbKey),
    /// Single-difference slant ionospheric delay on slot 0, metres.
    Iono(Sv),
    /// Rover zenith wet delay on top of the a-priori model (relative to the base's), metres.
    Tropo,
    /// GLONASS inter-channel code bias, rover minus base, metres per frequency channel
    /// number (one state, never reset).
    GlonassCodeBias,
    /// Single-difference code bias of one satellite on one slot, metres: the two receivers
    /// track different codes of the band (P1 against C1), which differ by the satellite's
    /// own bias. A property of the satellite, not of the arc: slips do not reset it.
    CodeBias(AmbKey),
}

/// Bookkeeping of a per-satellite state.
#[derive(Clone, Copy, Debug)]
pub(super) struct Track {
    /// Epochs observed since (re)initialisation.
    pub(super) lock: usize,
    /// Last epoch at which the state was observed.
    pub(super) last: Epoch,
    /// Number of this arc: unique within a pass, new at every (re)initialisation.
    pub(super) arc: u64,
}

/// One per-satellite state: what it is and its bookkeeping.
#[derive(Clone, Debug)]
pub(super) struct SatState {
    /// What the state is (never [`StateKey::Position`]; [`StateKey::Tropo`] is listed here
    /// too, though it belongs to no satellite).
    pub(super) key: StateKey,
    /// Its bookkeeping.
    pub(super) track: Track,
}

/// Size of the kinematic block (position only: no velocity, no dynamics model).
const KINEMATIC: usize = 3;

/// Where each state lives in the vector.
#[derive(Clone, Debug, Default)]
pub(super) struct StateIndex {
    /// Per-satellite states in vector order (after the kinematic block).
    sats: Vec<SatState>,
    /// Offset of each per-satellite state in the vector.
    offsets: BTreeMap<StateKey, usize>,
}

impl StateIndex {
    /// Offsets of a block: three for the position, one for a satellite state.
    pub(super) fn range(&self, key: StateKey) -> Option<Range<usize>> {
        match key {
            StateKey::Position => Some(0..KINEMATIC),
            _ => self.offsets.get(&key).map(|&k| k..k + 1),
        }
    }

    /// Offset of a per-satellite state.
    pub(super) fn offset(&self, key: StateKey) -> Option<usize> {
        self.offsets.get(&key).copied()
    }

    /// Length of the state vector.
    #[cfg(test)]
    fn len(&self) -> usize {
        KINEMATIC + self.sats.len()
    }

    /// Per-satellite states in vector order with their offsets.
    pub(super) fn sats(&self) -> impl Iterator<Item = (usize, &SatState)> {
        self.sats
            .iter()
            .enumerate()
            .map(|(i, s)| (KINEMATIC + i, s))
    }

    fn rebuild_offsets(&mut self) {
        self.offsets = self
            .sats
            .iter()
            .enumerate()
            .map(|(i, s)| (s.key, KINEMATIC + i))
            .collect();
    }
}

/// State vector, covariance and layout.
#[derive(Clone, Debug)]
pub(super) struct State {
    /// State vector (layout in [`StateIndex`]).
    pub(super) x: DVector<f64>,
    /// Its covariance.
    pub(super) p: DMatrix<f64>,
    index: StateIndex,
    next_arc: u64,
}

impl State {
    /// Position only, zero with a variance of `var` (m²) per axis.
    pub(super) fn new(var: f64) -> Self {
        State {
            x: DVector::zeros(KINEMATIC),
            p: DMatrix::identity(KINEMATIC, KINEMATIC) * var,
            index: StateIndex::default(),
            next_arc: 0,
        }
    }

    /// The layout.
    pub(super) fn index(&self) -> &StateIndex {
        &self.index
    }

    /// Offset of a per-satellite state.
    pub(super) fn offset(&self, key: StateKey) -> Option<usize> {
        self.index.offset(key)
    }

    /// Whether a state exists.
    pub(super) fn has(&self, key: StateKey) -> bool {
        self.index.offsets.contains_key(&key)
    }

    /// Per-satellite states in vector order with their offsets.
    pub(super) fn sats(&self) -> impl Iterator<Item = (usize, &SatState)> {
        self.index.sats()
    }

    /// Bookkeeping of every per-satellite state, mutable.
    pub(super) fn tracks_mut(&mut self) -> impl Iterator<Item = (StateKey, &mut Track)> {
        self.index.sats.iter_mut().map(|s| (s.key, &mut s.track))
    }

    /// Rover position (ECEF, m).
    pub(super) fn position(&self) -> Vector3<f64> {
        Vector3::from_iterator(self.x.rows_range(0..KINEMATIC).iter().copied())
    }

    /// Covariance of the position block (ECEF, m²).
    pub(super) fn position_cov(&self) -> Matrix3<f64> {
        self.p.fixed_view::<3, 3>(0, 0).into_owned()
    }

    /// Re-initialise the position at `pos` with variance `var` per axis, uncorrelated with
    /// everything else (the prediction of a filter without a dynamics model).
    pub(super) fn reset_position(&mut self, pos: &Vector3<f64>, var: f64) {
        let n = self.x.len();
        self.x.rows_mut(0, KINEMATIC).copy_from(pos);
        for i in 0..n {
            for j in 0..KINEMATIC {
                self.p[(i, j)] = 0.0;
                self.p[(j, i)] = 0.0;
            }
        }
        for j in 0..KINEMATIC {
            self.p[(j, j)] = var;
        }
    }

    /// Add `var` (m²) to the variance of each position coordinate (a random walk of the
    /// position kept from the epoch before).
    pub(super) fn add_position_variance(&mut self, var: f64) {
        for j in 0..KINEMATIC {
            self.p[(j, j)] += var;
        }
    }

    /// Add a per-satellite state at the end with `value`, variance `var`, uncorrelated,
    /// locked since `t` (lock count 0), with a new arc number.
    pub(super) fn add(&mut self, key: StateKey, t: Epoch, value: f64, var: f64) {
        debug_assert!(key != StateKey::Position && !self.has(key));
        let n = self.x.len();
        let mut x = DVector::zeros(n + 1);
        x.rows_mut(0, n).copy_from(&self.x);
        x[n] = value;
        let mut p = DMatrix::zeros(n + 1, n + 1);
        p.view_mut((0, 0), (n, n)).copy_from(&self.p);
        p[(n, n)] = var;
        self.x = x;
        self.p = p;
        self.index.offsets.insert(key, n);
        self.index.sats.push(SatState {
            key,
            track: Track {
                lock: 0,
                last: t,
                arc: self.next_arc,
            },
        });
        self.next_arc += 1;
    }

    /// A state of the given per-satellite states with values `x` and covariance `p` (in
    /// their order) and an unknown position (zero, variance `position_var` per axis,
    /// uncorrelated).
    pub(super) fn from_sats(
        sats: &[SatState],
        x: &DVector<f64>,
        p: &DMatrix<f64>,
        position_var: f64,
    ) -> State {
        let n = KINEMATIC + sats.len();
        let mut out = State {
            x: DVector::zeros(n),
            p: DMatrix::identity(n, n) * position_var,
            index: StateIndex {
                sats: sats.to_vec(),
                offsets: BTreeMap::new(),
            },
            next_arc: 0,
        };
        out.x.rows_mut(KINEMATIC, sats.len()).copy_from(x);
        out.p
            .view_mut((KINEMATIC, KINEMATIC), (sats.len(), sats.len()))
            .copy_from(p);
        out.index.rebuild_offsets();
        out
    }

    /// Remove per-satellite states; the others keep their order.
    pub(super) fn remove(&mut self, keys: &[StateKey]) {
        if keys.is_empty() {
            return;
        }
        let gone: Vec<usize> = keys.iter().filter_map(|k| self.offset(*k)).collect();
        let n = self.x.len();
        let keep: Vec<usize> = (0..n).filter(|i| !gone.contains(i)).collect();
        let m = keep.len();
        self.x = DVector::from_iterator(m, keep.iter().map(|&i| self.x[i]));
        self.p = DMatrix::from_fn(m, m, |i, j| self.p[(keep[i], keep[j])]);
        self.index.sats.retain(|s| !keys.contains(&s.key));
        self.index.rebuild_offsets();
    }

    /// Add `var` to the variance of a per-satellite state (process noise).
    pub(super) fn add_variance(&mut self, key: StateKey, var: f64) {
        if let Some(k) = self.offset(key) {
            self.p[(k, k)] += var;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sv::Constellation;

    fn amb(prn: u8, slot: usize) -> StateKey {
        StateKey::Ambiguity(AmbKey {
            sv: Sv::new(Constellation::Gps, prn),
            slot,
        })
    }

    /// States keep their order and covariance blocks through additions and removals.
    #[test]
    fn add_remove_keeps_order_and_blocks() {
        let t = crate::time::from_week_tow(2300, 0.0);
        let mut s = State::new(1.0);
        for (k, prn) in [3u8, 7, 9].iter().enumerate() {
            s.add(amb(*prn, 0), t, k as f64, 10.0 + k as f64);
        }
        let (a, c) = (s.offset(amb(3, 0)).unwrap(), s.offset(amb(9, 0)).unwrap());
        s.p[(a, c)] = 0.5;
        s.p[(c, a)] = 0.5;
        s.remove(&[amb(7, 0)]);
        assert_eq!(s.index().len(), 5);
        let (a, c) = (s.offset(amb(3, 0)).unwrap(), s.offset(amb(9, 0)).unwrap());
        assert!(a < c);
        assert_eq!((s.x[a], s.x[c]), (0.0, 2.0));
        assert_eq!((s.p[(a, a)], s.p[(c, c)], s.p[(a, c)]), (10.0, 12.0, 0.5));
        assert!(!s.has(amb(7, 0)));
        // A state added again starts a new arc.
        s.add(amb(7, 0), t, 0.0, 1.0);
        let arc = |k| s.sats().find(|(_, x)| x.key == k).unwrap().1.track.arc;
        assert_eq!(arc(amb(7, 0)), 3);
        assert_eq!(s.index().range(StateKey::Position), Some(0..3));
    }
}
