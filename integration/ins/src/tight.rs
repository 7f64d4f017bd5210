//! Tight coupling: double-differenced carrier phases (rover minus a base, satellite minus a
//! pivot; `gnss::ppk::tight`) as updates of the filter where the GNSS positions are missing,
//! so that two or three satellites, too few for any position, still hold the IMU.
//!
//! An ambiguity is learnt while the positions hold the filter: at a sample where a GNSS
//! position was just used, each double difference whose range the filter knows within
//! [`LEARN_SIGMA`] (the σ along its direction and its own noise) gives λ·N = phase −
//! range(antenna), a candidate when within [`LEARN_FRACTION`] of an integer, taken when
//! [`LEARN_EPOCHS`] epochs in a row agree; a known integer is checked there again and dropped
//! when off by more than [`DROP_SIGMAS`]. The key of an ambiguity holds its four phases'
//! arcs, so an integer serves while they continue — across a gap, and after it. Where no
//! position is used (withheld, missing, or between the positions' epochs), the phases whose
//! integers are known update the filter: z = phase − λ·N − range(antenna), H = ∇range (position) and
//! −∇rangeᵀ·[C·lever]× (attitude); the rows sharing a pivot share its single difference's
//! variance, and each row carries a differential ionosphere and troposphere of 5 mm plus
//! 1 mm per km of baseline.
//!
//! What enters: the double differences of the rover epochs, which of them may update, the
//! filter and its lever arm. What leaves: updates and learnt integers.

use crate::errstate::{idx, N};
use crate::filter::Forward;
use gnss::ppk::tight::{DdAmbiguity, DdRow};
use hifitime::Epoch;
use nalgebra::{DMatrix, DVector, Vector3};
use std::collections::HashMap;

/// Largest σ (m) of a double difference's range (its own noise included) for its integer
/// to be learnt.
pub const LEARN_SIGMA: f64 = 0.02;
/// Largest distance (cycles) of λ·N/λ from an integer for it to be learnt.
pub const LEARN_FRACTION: f64 = 0.15;
/// Consecutive epochs that must round to the same integer before it is taken.
pub const LEARN_EPOCHS: u32 = 3;
/// A known integer whose residual exceeds this many σ where the positions hold the filter
/// is dropped (learnt again if it comes back).
pub const DROP_SIGMAS: f64 = 3.0;

/// One rover epoch's double differences.
#[derive(Clone, Debug)]
pub struct PhaseEpoch {
    /// True (GPST) time of the rover observations.
    pub time: Epoch,
    /// The rows.
    pub rows: Vec<DdRow>,
}

/// The phases of a run: epochs in time order and the baseline length (km) for the
/// differential atmosphere.
#[derive(Clone, Debug, Default)]
pub struct Phases {
    /// The epochs.
    pub epochs: Vec<PhaseEpoch>,
    /// Rover–base distance, km.
    pub baseline_km: f64,
    /// Rover epochs without double differences (no base epoch, too few satellites), and
    /// what the input checks said.
    pub missing: usize,
    /// The input checks' warnings.
    pub warnings: Vec<String>,
}

/// The integers learnt per ambiguity key (cycles), the candidates (integer, epochs agreeing)
/// and how many known integers were dropped.
#[derive(Clone, Debug, Default)]
pub struct Integers {
    known: HashMap<DdAmbiguity, f64>,
    candidates: HashMap<DdAmbiguity, (f64, u32)>,
    /// Integers dropped for a residual beyond [`DROP_SIGMAS`].
    pub dropped: usize,
}

/// The rows of one update: index into the epoch's rows, ∇range of the antenna, the
/// innovation (m).
type Used = (usize, Vector3<f64>, f64);

/// The variance (m²) of a row's own noise: its single differences and the atmosphere.
fn row_var(r: &DdRow, baseline_km: f64) -> f64 {
    r.sd_var_phase + r.pivot_var_phase + (0.005 + 0.001 * baseline_km).powi(2)
}

/// At an epoch where a position holds the filter (`dt` seconds after the state's time):
/// check the known integers of `e`'s rows against it (dropping those off by more than
/// [`DROP_SIGMAS`]) and learn new ones, each taken when [`LEARN_EPOCHS`] epochs in a row
/// round to it. Returns the integers taken.
pub fn learn(
    f: &Forward,
    e: &PhaseEpoch,
    (lever, dt): (&Vector3<f64>, f64),
    baseline_km: f64,
    ints: &mut Integers,
) -> usize {
    let est = f.estimate();
    let arm = est.nav.attitude.matrix() * lever;
    let ant = est.nav.position.0 + dt * est.nav.velocity + arm;
    let p = f.covariance();
    let mut learnt = 0;
    for r in &e.rows {
        let Some(key) = r.ambiguity else { continue };
        if !r.phase.is_finite() {
            continue;
        }
        let (range, g) = r.range(&ant);
        let h = jacobian_row(&g, &arm);
        let var = (h.transpose() * p * h)[(0, 0)] + row_var(r, baseline_km);
        if let Some(n) = ints.known.get(&key) {
            if (r.phase - r.wavelength * n - range).abs() > DROP_SIGMAS * var.sqrt() {
                ints.known.remove(&key);
                ints.dropped += 1;
            }
            continue;
        }
        let n = (r.phase - range) / r.wavelength;
        if var.sqrt() > LEARN_SIGMA || (n - n.round()).abs() > LEARN_FRACTION {
            ints.candidates.remove(&key);
            continue;
        }
        let c = ints.candidates.entry(key).or_insert((n.round(), 0));
        if c.0 != n.round() {
            *c = (n.round(), 0);
        }
        c.1 += 1;
        if c.1 >= LEARN_EPOCHS {
            ints.known.insert(key, n.round());
            ints.candidates.remove(&key);
            learnt += 1;
        }
    }
    learnt
}

/// The filter's row for a double difference with gradient `g` of an antenna `arm` from the IMU.
fn jacobian_row(g: &Vector3<f64>, arm: &Vector3<f64>) -> nalgebra::SVector<f64, N> {
    let mut h = nalgebra::SVector::<f64, N>::zeros();
    let att = -(crate::errstate::skew(arm).transpose() * g);
    for k in 0..3 {
        h[idx::POS + k] = g[k];
        h[idx::ATT + k] = att[k];
    }
    h
}

/// Update the filter with `e`'s phases whose integers are known, carried `offset` seconds
/// from the state's time; returns the rows used and the normalised innovation squared (None
/// when no row has a known integer).
pub fn update(
    f: &mut Forward,
    e: &PhaseEpoch,
    lever: &Vector3<f64>,
    offset: f64,
    known: &Integers,
    baseline_km: f64,
) -> Option<(usize, f64)> {
    let est = *f.estimate();
    let arm = est.nav.attitude.matrix() * lever;
    let ant = est.nav.position.0 + offset * est.nav.velocity + arm;
    let used: Vec<Used> = e
        .rows
        .iter()
        .enumerate()
        .filter_map(|(i, r)| {
            let n = *known.known.get(&r.ambiguity?)?;
            let (range, g) = r.range(&ant);
            r.phase
                .is_finite()
                .then_some((i, g, r.phase - r.wavelength * n - range))
        })
        .collect();
    if used.is_empty() {
        return None;
    }
    let m = used.len();
    let mut h = DMatrix::zeros(m, N);
    let mut z = DVector::zeros(m);
    let mut r = DMatrix::zeros(m, m);
    for (a, (i, g, dz)) in used.iter().enumerate() {
        h.row_mut(a).copy_from(&jacobian_row(g, &arm).transpose());
        z[a] = *dz;
        let ra = &e.rows[*i];
        for (b, (j, _, _)) in used.iter().enumerate() {
            let rb = &e.rows[*j];
            if a != b && ra.pivot == rb.pivot && ra.slot == rb.slot {
                r[(a, b)] += ra.pivot_var_phase;
            }
        }
        r[(a, a)] += row_var(ra, baseline_km);
    }
    f.update_rows(&h, &z, &r).map(|nis| (m, nis))
}

/// The rows of `rows` within a sky of `keep` satellites: the pivot with the most satellites
/// (one system: a double difference needs two satellites of it) and its `keep − 1` highest.
pub fn thin(rows: Vec<DdRow>, keep: usize) -> Vec<DdRow> {
    let mut pivots: Vec<(gnss::sv::Sv, Vec<(f64, gnss::sv::Sv)>)> = Vec::new();
    for r in &rows {
        let at = match pivots.iter().position(|p| p.0 == r.pivot) {
            Some(k) => k,
            None => {
                pivots.push((r.pivot, Vec::new()));
                pivots.len() - 1
            }
        };
        if !pivots[at].1.iter().any(|s| s.1 == r.sv) {
            pivots[at].1.push((r.elevation, r.sv));
        }
    }
    let Some((pivot, mut sats)) = pivots
        .into_iter()
        .max_by(|a, b| a.1.len().cmp(&b.1.len()).then(b.0.cmp(&a.0)))
    else {
        return Vec::new();
    };
    sats.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    sats.truncate(keep.saturating_sub(1));
    rows.into_iter()
        .filter(|r| r.pivot == pivot && sats.iter().any(|s| s.1 == r.sv))
        .collect()
}
