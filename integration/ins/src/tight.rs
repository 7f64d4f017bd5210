//! Tight coupling: double-differenced carrier phases (rover minus a base, satellite minus a
//! pivot; `gnss::ppk::tight`) as updates of the filter where the GNSS positions are missing,
//! so that two or three satellites, too few for any position, still hold the IMU.
//!
//! An ambiguity is learnt while the positions hold the filter: at a GNSS epoch whose position
//! was used, each double difference whose range the filter knows within [`LEARN_SIGMA`] (its
//! σ along the double difference's direction) gives λ·N = phase − range(antenna), taken when
//! it lies within [`LEARN_FRACTION`] of an integer. The key of an ambiguity holds its four
//! phases' arcs, so an integer learnt once serves while they continue — across the gap, and
//! after it. Where the positions are missing (withheld, or none), the phases whose integers
//! are known update the filter: z = phase − λ·N − range(antenna), H = ∇range (position) and
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

/// Largest σ (m) of a double difference's range for its integer to be learnt.
pub const LEARN_SIGMA: f64 = 0.02;
/// Largest distance (cycles) of λ·N/λ from an integer for it to be learnt.
pub const LEARN_FRACTION: f64 = 0.15;

/// One rover epoch's double differences, and whether they may update the filter (the
/// positions are missing there) or only teach integers.
#[derive(Clone, Debug)]
pub struct PhaseEpoch {
    /// True (GPST) time of the rover observations.
    pub time: Epoch,
    /// The rows.
    pub rows: Vec<DdRow>,
    /// The phases update the filter here.
    pub update: bool,
}

/// The phases of a run: epochs in time order and the baseline length (km) for the
/// differential atmosphere.
#[derive(Clone, Debug, Default)]
pub struct Phases {
    /// The epochs.
    pub epochs: Vec<PhaseEpoch>,
    /// Rover–base distance, km.
    pub baseline_km: f64,
}

/// The integers learnt, per ambiguity key (cycles).
#[derive(Clone, Debug, Default)]
pub struct Integers(pub HashMap<DdAmbiguity, f64>);

/// The rows of one update: index into the epoch's rows, ∇range of the antenna, the
/// innovation (m).
type Used = (usize, Vector3<f64>, f64);

/// Learn the integers of `e`'s rows from the filter's antenna (`lever` from the IMU, body).
pub fn learn(f: &Forward, e: &PhaseEpoch, lever: &Vector3<f64>, known: &mut Integers) -> usize {
    let est = f.estimate();
    let arm = est.nav.attitude.matrix() * lever;
    let ant = est.nav.position.0 + arm;
    let p = f.covariance();
    let mut learnt = 0;
    for r in &e.rows {
        let Some(key) = r.ambiguity else { continue };
        if known.0.contains_key(&key) || !r.phase.is_finite() {
            continue;
        }
        let (range, g) = r.range(&ant);
        let h = jacobian_row(&g, &arm);
        let var = (h.transpose() * p * h)[(0, 0)];
        if var.sqrt() > LEARN_SIGMA {
            continue;
        }
        let n = (r.phase - range) / r.wavelength;
        if (n - n.round()).abs() <= LEARN_FRACTION {
            known.0.insert(key, n.round());
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
            let n = *known.0.get(&r.ambiguity?)?;
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
    let atmosphere = (0.005 + 0.001 * baseline_km).powi(2);
    for (a, (i, g, dz)) in used.iter().enumerate() {
        h.row_mut(a).copy_from(&jacobian_row(g, &arm).transpose());
        z[a] = *dz;
        let ra = &e.rows[*i];
        for (b, (j, _, _)) in used.iter().enumerate() {
            let rb = &e.rows[*j];
            if ra.pivot == rb.pivot && ra.slot == rb.slot {
                r[(a, b)] += ra.pivot_var_phase;
            }
        }
        r[(a, a)] += ra.sd_var_phase + atmosphere;
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
