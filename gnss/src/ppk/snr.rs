//! How far below its own normal C/N0 each measurement of a receiver lies: the weighting's
//! measure of excess noise (trees, multipath, a body shading the antenna).
//!
//! A receiver's normal C/N0 is a function of elevation, signal and antenna that no constant
//! describes (a geodetic choke ring and a patch differ by 5–10 dB at low elevations), so it is
//! learnt from the data: per system and frequency slot, the 75th percentile of the C/N0 in
//! bins of 5° of elevation, filled from the neighbouring bins where a bin has too few
//! samples, made non-decreasing with elevation and interpolated between bin centres. A
//! measurement's drop is how far it lies below that, less a 1 dB dead band for the scatter
//! of clean signals.
//!
//! What enters: one receiver's measurements with their satellites' views and its position at
//! each epoch. What leaves: [`SatMeas::snr_drop`] set (NaN where the file has no C/N0 or the
//! elevation is unknown).

use super::geometry::SatView;
use super::obs::{SatMeas, NF};
use crate::frame::Ecef;
use crate::sv::Constellation;
use std::collections::BTreeMap;

/// Width of an elevation bin, degrees.
const BIN_DEG: f64 = 5.0;
/// Bins from the horizon to the zenith.
const BINS: usize = 18;
/// Fewest samples a bin's percentile is taken from.
const MIN_SAMPLES: usize = 20;
/// The scatter of clean signals around their normal C/N0 not counted as a drop, dB.
const DEAD_BAND: f64 = 1.0;

/// Normal C/N0 per elevation bin (NaN: unknown).
type Curve = [f64; BINS];

fn bin_of(el_deg: f64) -> usize {
    ((el_deg / BIN_DEG).floor().max(0.0) as usize).min(BINS - 1)
}

/// The 75th percentile of each bin with enough samples, NaN elsewhere.
fn percentiles(samples: &mut [Vec<f64>; BINS]) -> Curve {
    let mut c = [f64::NAN; BINS];
    for (b, v) in samples.iter_mut().enumerate() {
        if v.len() >= MIN_SAMPLES {
            v.sort_by(f64::total_cmp);
            c[b] = v[(v.len() - 1) * 3 / 4];
        }
    }
    c
}

/// Empty bins from the nearest known one (`fallback`'s bin first), then non-decreasing with
/// elevation (a running maximum from the horizon up).
fn complete(mut c: Curve, fallback: Option<&Curve>) -> Curve {
    for b in 0..BINS {
        if c[b].is_nan() {
            c[b] = fallback.map_or(f64::NAN, |f| f[b]);
        }
    }
    let known: Vec<usize> = (0..BINS).filter(|&b| c[b].is_finite()).collect();
    if known.is_empty() {
        return c;
    }
    let filled: Curve = std::array::from_fn(|b| {
        let k = *known
            .iter()
            .min_by_key(|&&k| k.abs_diff(b))
            .expect("known is not empty");
        c[k]
    });
    let mut out = filled;
    for b in 1..BINS {
        out[b] = out[b].max(out[b - 1]);
    }
    out
}

/// The curve at an elevation (degrees), linear between bin centres.
fn at(c: &Curve, el_deg: f64) -> f64 {
    let x = (el_deg / BIN_DEG - 0.5).clamp(0.0, (BINS - 1) as f64);
    let i = (x.floor() as usize).min(BINS - 2);
    let w = x - i as f64;
    c[i] * (1.0 - w) + c[i + 1] * w
}

/// Set the C/N0 drop of every measurement of one receiver: `views` aligned with `meas`, the
/// receiver's position at epoch `i` from `position(i)`.
pub(super) fn mark_drops(
    meas: &mut [Vec<SatMeas>],
    views: &[Vec<Option<SatView>>],
    position: &dyn Fn(usize) -> Option<Ecef>,
) {
    // Elevation of every measurement (degrees; NaN unknown).
    let els: Vec<Vec<f64>> = meas
        .iter()
        .zip(views)
        .enumerate()
        .map(|(i, (m, v))| {
            let Some(p) = position(i) else {
                return vec![f64::NAN; m.len()];
            };
            let g = p.to_geodetic();
            v.iter()
                .map(|v| v.map_or(f64::NAN, |v| v.az_el(&p, &g).1.to_degrees()))
                .collect()
        })
        .collect();
    let mut by_signal: BTreeMap<(Constellation, usize), [Vec<f64>; BINS]> = BTreeMap::new();
    let mut by_slot: [[Vec<f64>; BINS]; NF] = Default::default();
    for (m, e) in meas.iter().zip(&els) {
        for (s, &el) in m.iter().zip(e) {
            if !el.is_finite() {
                continue;
            }
            for (f, slot) in by_slot.iter_mut().enumerate() {
                let cn0 = s.cn0(f);
                if cn0.is_finite() {
                    let b = bin_of(el);
                    by_signal.entry((s.sv.sys, f)).or_default()[b].push(cn0);
                    slot[b].push(cn0);
                }
            }
        }
    }
    let slot_curves: [Curve; NF] =
        std::array::from_fn(|f| complete(percentiles(&mut by_slot[f]), None));
    let curves: BTreeMap<(Constellation, usize), Curve> = by_signal
        .into_iter()
        .map(|((sys, f), mut v)| {
            (
                (sys, f),
                complete(percentiles(&mut v), Some(&slot_curves[f])),
            )
        })
        .collect();
    for (m, e) in meas.iter_mut().zip(&els) {
        for (s, &el) in m.iter_mut().zip(e) {
            for f in 0..NF {
                let normal = curves.get(&(s.sv.sys, f)).map_or(f64::NAN, |c| at(c, el));
                // NaN (unknown) when either is.
                s.set_cn0_drop(f, normal - s.cn0(f) - DEAD_BAND);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bins fill from their neighbours and rise with elevation; values interpolate between
    /// bin centres.
    #[test]
    fn the_normal_curve_is_filled_monotone_and_interpolated() {
        let mut c = [f64::NAN; BINS];
        c[2] = 38.0;
        c[3] = 37.0; // a dip: the running maximum lifts it
        c[10] = 48.0;
        let full = complete(c, None);
        assert_eq!(full[0], 38.0);
        assert_eq!(full[3], 38.0);
        assert_eq!(full[6], 38.0);
        assert_eq!(full[7], 48.0);
        assert_eq!(full[17], 48.0);
        // 37.5° is the centre of bin 7, 32.5° of bin 6: halfway is 35°.
        assert!((at(&full, 35.0) - 43.0).abs() < 1e-12);
    }
}
