//! Base epochs interpolated in time to rover epochs that a base log lacks (a low-cost base
//! logging over USB loses seconds to tens of seconds at a time).
//!
//! Ageing a base epoch by t seconds leaves the change of the base's atmosphere and of the
//! satellite clocks over t in the single difference; a base observation interpolated between
//! the epochs before and after the rover's, of its residual against the modelled range
//! (geometric range minus satellite clock, whose fast change the model carries), is off by
//! the curvature of that residual only. Across a base slip the phase is not interpolated (the
//! satellite's phase is left out of that epoch); whatever both base epochs share (the base's
//! clock, even a millisecond jump) is common to all satellites and leaves the double
//! differences. What is left is the residual's curvature, largest mid-gap: an interpolated
//! epoch's effective age, d₀·d₁/span (d₀, d₁ its distances to the real epochs around it, as
//! the spread of a bridge between two known ends), enters the variance as an age would.
//!
//! What enters: the rover epochs' times and pairing, the base's epochs, views, slips and
//! position, and the orbits. What leaves: the interpolated epochs appended to the base's,
//! the rover epochs paired with them, and for every base epoch the real one its slips are
//! counted from and its effective age.

use super::geometry::SatView;
use super::obs::{SatMeas, NF};
use super::slip::Slips;
use crate::frame::Ecef;
use crate::orbit::{Orbits, C};
use hifitime::Epoch;

/// A base's epochs as the passes read them.
pub(super) struct BaseEpochs<'a> {
    /// Time tags.
    pub(super) times: &'a mut Vec<Epoch>,
    /// Measurements.
    pub(super) meas: &'a mut Vec<Vec<SatMeas>>,
    /// Satellite views.
    pub(super) views: &'a mut Vec<Vec<Option<SatView>>>,
}

/// For every base epoch (real ones first, then the interpolated): the real epoch its slips are
/// counted from, and its effective age (s; 0 for a real one).
pub(super) struct Interpolated {
    /// Real epoch whose slips an epoch carries (itself for a real one; the one before the gap
    /// for an interpolated one).
    pub(super) slip_index: Vec<usize>,
    /// Effective age, s: d₀·d₁/span for an interpolated epoch, 0 for a real one.
    pub(super) age: Vec<f64>,
    /// Rover epochs paired with an interpolated base epoch.
    pub(super) count: usize,
}

/// Fewest satellites with phase an interpolated epoch must hold.
const MIN_SATS: usize = 4;

/// Interpolate base epochs for the rover epochs whose paired base epoch lies more than
/// `min_age` seconds away, between usable base epochs at most `max_span` seconds apart.
#[allow(clippy::too_many_arguments)]
pub(super) fn interpolate_gaps(
    rover_times: &[Epoch],
    matched: &mut [Option<usize>],
    base: BaseEpochs,
    usable: &[bool],
    breaks: &[Slips],
    at: &Ecef,
    orbits: &Orbits,
    (min_age, max_span): (f64, f64),
) -> Interpolated {
    let n0 = base.times.len();
    let mut out = Interpolated {
        slip_index: (0..n0).collect(),
        age: vec![0.0; n0],
        count: 0,
    };
    let ok: Vec<usize> = (0..n0).filter(|&j| usable[j]).collect();
    for (i, &t) in rover_times.iter().enumerate() {
        let Some(j) = matched[i].filter(|&j| j < n0) else {
            continue;
        };
        if (base.times[j] - t).to_seconds().abs() <= min_age {
            continue;
        }
        let k = ok.partition_point(|&j| base.times[j] <= t);
        let (Some(&j0), Some(&j1)) = (k.checked_sub(1).and_then(|k| ok.get(k)), ok.get(k)) else {
            continue;
        };
        let (t0, t1) = (base.times[j0], base.times[j1]);
        let span = (t1 - t0).to_seconds();
        if !(span > 0.0 && span <= max_span) {
            continue;
        }
        let w = (t - t0).to_seconds() / span;
        let slipped = |sv, f: usize| {
            breaks[j0 + 1..=j1]
                .iter()
                .any(|b: &Slips| b.get(&sv).is_some_and(|c| c[f].is_some()))
        };
        let mut meas = Vec::new();
        let mut views = Vec::new();
        for (m0, v0) in base.meas[j0].iter().zip(&base.views[j0]) {
            let Some(k1) = base.meas[j1].iter().position(|m| m.sv == m0.sv) else {
                continue;
            };
            let (m1, v1) = (&base.meas[j1][k1], &base.views[j1][k1]);
            let (Some(v0), Some(v1)) = (v0, v1) else {
                continue;
            };
            let sides = [(m0, v0), (m1, v1)];
            if let Some((m, v)) = interpolate_sat(sides, w, t, at, orbits, &slipped) {
                meas.push(m);
                views.push(Some(v));
            }
        }
        if meas
            .iter()
            .filter(|m| m.l.iter().any(|l| l.is_finite()))
            .count()
            < MIN_SATS
        {
            continue;
        }
        base.times.push(t);
        base.meas.push(meas);
        base.views.push(views);
        out.slip_index.push(j0);
        let (d0, d1) = ((t - t0).to_seconds(), (t1 - t).to_seconds());
        out.age.push(d0 * d1 / span);
        matched[i] = Some(base.times.len() - 1);
        out.count += 1;
    }
    out
}

/// One satellite at `t` from its measurements and views at the epochs before and after
/// (`w`: where `t` lies between them, 0–1): code and phase by their residuals against the
/// modelled range, Doppler and C/N0 as they are; a phase across a slip is left out.
fn interpolate_sat(
    [(m0, v0), (m1, v1)]: [(&SatMeas, &SatView); 2],
    w: f64,
    t: Epoch,
    at: &Ecef,
    orbits: &Orbits,
    slipped: &dyn Fn(crate::sv::Sv, usize) -> bool,
) -> Option<(SatMeas, SatView)> {
    let model = |v: &SatView| v.range(&at.0).0 - C * v.clock;
    let (md0, md1) = (model(v0), model(v1));
    let lerp = |a: f64, b: f64| a + w * (b - a);
    let mut m = m0.clone();
    // The satellite at t, seen through an approximate then the interpolated pseudorange.
    for f in 0..NF {
        m.p[f] = lerp(m0.p[f], m1.p[f]);
    }
    let mut v = SatView::at(orbits, &m, t)?;
    for _ in 0..2 {
        let md = model(&v);
        for f in 0..NF {
            m.p[f] = lerp(m0.p[f] - md0, m1.p[f] - md1) + md;
        }
        v = SatView::at(orbits, &m, t)?;
    }
    let md = model(&v);
    for f in 0..NF {
        let lam = m0.wavelength(f);
        m.l[f] = if slipped(m0.sv, f) {
            f64::NAN
        } else {
            (lerp(lam * m0.l[f] - md0, lam * m1.l[f] - md1) + md) / lam
        };
        m.d[f] = lerp(m0.d[f], m1.d[f]);
        m.lli[f] = (m0.lli[f] | m1.lli[f]) & super::obs::LLI_HALF_CYCLE;
        m.snr[f] = m0.snr[f].min(m1.snr[f]);
        m.set_cn0_drop(f, m0.cn0_drop(f).max(m1.cn0_drop(f)));
    }
    m.l.iter()
        .chain(&m.p)
        .any(|x| x.is_finite())
        .then_some((m, v))
}
