//! Cycle-slip detection for one receiver: loss-of-lock indicators, geometry-free phase jumps,
//! Melbourne–Wübbena wide-lane jumps, Doppler against phase, and data gaps. A slip resets only
//! what it touches.
//!
//! The geometry-free test at intervals of `gf_extrapolate_after` (5 s) or more predicts the
//! combination from the two previous epochs (a linear extrapolation removes the ionosphere's
//! rate, which at 30 s intervals moves the combination by decimetres) and allows
//! `gf_threshold + gf_rate·Δt`; at shorter intervals, or with one previous epoch only, the
//! plain change is tested against `gf_threshold + gf_rate_first·Δt` (a rate from two epochs
//! 0.1 s apart is mostly noise: extrapolating with it raised false slips at 10 Hz). At 1 s
//! the threshold is about 5 cm; at 30 s 8 cm (extrapolated) or 20 cm (plain).

use super::obs::{SatMeas, LLI_HALF_CYCLE, NF};
use crate::orbit::C;
use crate::sv::Sv;
use hifitime::Epoch;
use nalgebra::Vector3;
use std::collections::{BTreeMap, HashMap};

/// The slips of one epoch: per satellite and frequency slot, why its phase does not continue
/// from the satellite's previous epoch (None: it does).
pub type Slips = BTreeMap<Sv, [Option<SlipCause>; NF]>;

/// Arc breaks of one receiver's phase, in forward time: element `i` holds the satellites and
/// slots whose phase at epoch `i` does not continue from their previous epoch. The detector
/// runs forward and backward and the union is kept, so that both passes of the filter cut the
/// same arcs (the two-filter smoother combines their estimates of one arc; a slip seen in one
/// direction only would otherwise join estimates of two different ambiguities). Without
/// `doppler` the Doppler test is left out (a receiver whose Doppler does not follow its phase,
/// see [`doppler_phase_ratio`]).
pub fn arc_breaks(
    times: &[Epoch],
    meas: &[Vec<SatMeas>],
    los: Option<&[Vec<Option<Vector3<f64>>>]>,
    max_gap: f64,
    doppler: bool,
) -> Vec<Slips> {
    let noise = if doppler {
        super::doppler::misfit_noise(times, meas, los, max_gap)
    } else {
        None
    };
    let los_at = |i: usize| los.and_then(|l| l.get(i)).map(|v| v.as_slice());
    let mut out: Vec<Slips> = vec![Slips::new(); times.len()];
    let mut merge = |i: usize, sv: Sv, causes: [Option<SlipCause>; NF]| {
        if causes.iter().any(Option::is_some) {
            let e = out[i].entry(sv).or_insert([None; NF]);
            for (a, b) in e.iter_mut().zip(causes) {
                *a = a.or(b);
            }
        }
    };
    let mut forward = SlipDetector::new(max_gap, false);
    forward.doppler = doppler;
    forward.noise = noise;
    for (i, (t, m)) in times.iter().zip(meas).enumerate() {
        for (sat, causes) in m.iter().zip(forward.check_epoch(*t, m, los_at(i))) {
            merge(i, sat.sv, causes);
        }
    }
    // Backward, a slip found at epoch i lies between i and the satellite's next epoch (in
    // forward time), where it is recorded.
    let mut backward = SlipDetector::new(max_gap, true);
    backward.doppler = doppler;
    backward.noise = noise;
    let mut next: HashMap<Sv, usize> = HashMap::new();
    for i in (0..times.len()).rev() {
        let m = &meas[i];
        for (sat, causes) in m.iter().zip(backward.check_epoch(times[i], m, los_at(i))) {
            if let Some(&j) = next.get(&sat.sv) {
                merge(j, sat.sv, causes);
            }
            next.insert(sat.sv, i);
        }
    }
    out
}

/// Why an ambiguity was reset.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum SlipCause {
    /// Loss-of-lock indicator set.
    LossOfLock,
    /// Geometry-free phase jump.
    GeometryFree,
    /// Melbourne–Wübbena wide-lane jump.
    MelbourneWubbena,
    /// Phase change disagrees with the integrated Doppler (after removing the common clock part).
    Doppler,
    /// A gap longer than the limit.
    Gap,
    /// The receiver resolved (or lost) the half-cycle ambiguity of the phase (RINEX LLI bit
    /// 1 changed): the phase may have stepped by half a cycle.
    HalfCycle,
}

#[derive(Clone, Debug)]
struct Hist {
    t: Epoch,
    l: [f64; NF],
    d: [f64; NF],
    gf: f64,
    /// The geometry-free combination one epoch earlier, when it followed without a gap.
    gf_before: Option<(Epoch, f64)>,
    mw_mean: f64,
    mw_n: usize,
    lli: [u8; NF],
}

/// Per-receiver detector; `backward` passes read the loss-of-lock flag of the later epoch.
#[derive(Clone, Debug)]
pub struct SlipDetector {
    hist: HashMap<Sv, Hist>,
    /// Geometry-free jump threshold, metres.
    pub gf_threshold: f64,
    /// Growth of that threshold with the interval when the combination is extrapolated from
    /// two epochs, m/s.
    pub gf_rate: f64,
    /// Growth of that threshold with the interval when the plain change is tested, m/s.
    pub gf_rate_first: f64,
    /// Shortest interval at which the combination is extrapolated, seconds.
    pub gf_extrapolate_after: f64,
    /// Melbourne–Wübbena jump threshold, wide-lane cycles.
    pub mw_threshold: f64,
    /// Longest tolerated gap, seconds.
    pub max_gap: f64,
    /// Doppler-versus-phase threshold, cycles (plus 0.5 cycle per second of interval).
    pub doppler_threshold: f64,
    /// A pass running backward in time.
    pub backward: bool,
    /// Whether the Doppler test runs.
    pub doppler: bool,
    /// The receiver's measured misfit noise: the Doppler test's threshold is then 5 of its
    /// sigmas (grown with the C/N0 drop and the interval), at least half a cycle, at most
    /// `doppler_threshold` (see [`super::doppler`]).
    pub noise: Option<super::doppler::MisfitNoise>,
}

impl SlipDetector {
    /// A detector with the given longest gap (s), for a forward or backward pass.
    pub fn new(max_gap: f64, backward: bool) -> Self {
        SlipDetector {
            hist: HashMap::new(),
            gf_threshold: 0.05,
            gf_rate: 0.001,
            gf_rate_first: 0.005,
            gf_extrapolate_after: 5.0,
            mw_threshold: 4.0,
            max_gap,
            doppler_threshold: 3.0,
            backward,
            doppler: true,
            noise: None,
        }
    }

    /// The Doppler test's threshold (cycles) for slot `f` of `m` over `dt` seconds, besides
    /// the allowance for dynamics.
    fn doppler_limit(&self, m: &SatMeas, f: usize, dt: f64) -> f64 {
        let fixed = self.doppler_threshold + 0.5 * dt;
        let Some(n) = self.noise else {
            return fixed;
        };
        let drop = if m.cn0_drop(f).is_finite() {
            m.cn0_drop(f)
        } else {
            0.0
        };
        let sigma =
            n.sigma / m.wavelength(f) * 10f64.powf(drop / 20.0) * (dt / n.interval).max(1.0);
        (5.0 * sigma).max(0.5).min(fixed)
    }

    /// Slips of every satellite of an epoch: [`Self::check`] per satellite, plus the
    /// Doppler test, which needs the whole epoch to remove what is common to its satellites
    /// (a clock jump; with their lines of sight `los`, aligned with `sats`, the receiver's
    /// acceleration too: [`super::doppler::remove_common`]) before comparing each phase
    /// change with its integrated Doppler.
    pub fn check_epoch(
        &mut self,
        t: Epoch,
        sats: &[SatMeas],
        los: Option<&[Option<Vector3<f64>>]>,
    ) -> Vec<[Option<SlipCause>; NF]> {
        // Doppler misfits (metres) against the previous epoch, before the history moves on.
        let mut misfit: Vec<[f64; NF]> = vec![[f64::NAN; NF]; sats.len()];
        // Allowance for dynamics: the trapezoid rule errs by up to half the Doppler change
        // times the interval when the receiver accelerates abruptly (take-off, pull-up).
        let mut allowance: Vec<[f64; NF]> = vec![[0.0; NF]; sats.len()];
        let mut dt_all = f64::NAN;
        for (k, m) in sats.iter().enumerate() {
            let Some(h) = self.hist.get(&m.sv).filter(|_| self.doppler) else {
                continue;
            };
            let dt = (t - h.t).to_seconds();
            if dt == 0.0 || dt.abs() > self.max_gap {
                continue;
            }
            dt_all = dt.abs();
            for (f, mis) in misfit[k].iter_mut().enumerate() {
                if m.l[f].is_finite()
                    && h.l[f].is_finite()
                    && m.d[f].is_finite()
                    && h.d[f].is_finite()
                {
                    // Phase (cycles) shrinks with the range, Doppler is positive when approaching.
                    let predicted = -0.5 * (m.d[f] + h.d[f]) * dt;
                    *mis = (m.l[f] - h.l[f] - predicted) * m.wavelength(f);
                    allowance[k][f] = 0.5 * (m.d[f] - h.d[f]).abs() * dt.abs();
                }
            }
        }
        let flat: Vec<(f64, Option<Vector3<f64>>)> = misfit
            .iter()
            .enumerate()
            .flat_map(|(k, m)| {
                let e = los.and_then(|l| l.get(k).copied().flatten());
                m.iter().map(move |v| (*v, e))
            })
            .collect();
        let residual = super::doppler::remove_common(&flat);
        let mut out: Vec<[Option<SlipCause>; NF]> = sats.iter().map(|m| self.check(t, m)).collect();
        for (k, m) in sats.iter().enumerate() {
            for f in 0..NF {
                let r = residual[k * NF + f];
                if r.is_finite()
                    && (r / m.wavelength(f)).abs()
                        > self.doppler_limit(m, f, dt_all) + allowance[k][f]
                {
                    out[k][f] = out[k][f].or(Some(SlipCause::Doppler));
                }
            }
        }
        out
    }

    /// Whether the geometry-free combination `gf` at `t` jumped against the history `h`.
    fn gf_jump(&self, t: Epoch, gf: f64, h: &Hist) -> bool {
        if !(gf.is_finite() && h.gf.is_finite()) {
            return false;
        }
        let dt = (t - h.t).to_seconds();
        let (predicted, allowed) = match h.gf_before {
            Some((t0, g0))
                if dt.abs() >= self.gf_extrapolate_after && (h.t - t0).to_seconds() != 0.0 =>
            {
                let rate = (h.gf - g0) / (h.t - t0).to_seconds();
                (
                    h.gf + rate * dt,
                    self.gf_threshold + self.gf_rate * dt.abs(),
                )
            }
            _ => (h.gf, self.gf_threshold + self.gf_rate_first * dt.abs()),
        };
        (gf - predicted).abs() > allowed
    }

    /// Slips per frequency slot of `m` at `t` (None = no slip), and update the history.
    pub fn check(&mut self, t: Epoch, m: &SatMeas) -> [Option<SlipCause>; NF] {
        let mut out = [None; NF];
        let gf = if m.l[0].is_finite() && m.l[1].is_finite() {
            m.wavelength(0) * m.l[0] - m.wavelength(1) * m.l[1]
        } else {
            f64::NAN
        };
        let mw =
            if m.l[0].is_finite() && m.l[1].is_finite() && m.p[0].is_finite() && m.p[1].is_finite()
            {
                let (f1, f2) = (m.freq[0], m.freq[1]);
                let lw = C / (f1 - f2);
                (m.l[0] - m.l[1]) - (f1 * m.p[0] + f2 * m.p[1]) / ((f1 + f2) * lw)
            } else {
                f64::NAN
            };
        match self.hist.get(&m.sv) {
            None => {}
            Some(h) => {
                let gap = (t - h.t).to_seconds().abs();
                if gap > self.max_gap {
                    out = [Some(SlipCause::Gap); NF];
                } else {
                    for (f, o) in out.iter_mut().enumerate() {
                        let flag = if self.backward { h.lli[f] } else { m.lli[f] };
                        if flag & 1 != 0 {
                            *o = Some(SlipCause::LossOfLock);
                        } else if (h.lli[f] ^ m.lli[f]) & LLI_HALF_CYCLE != 0
                            && m.l[f].is_finite()
                            && h.l[f].is_finite()
                        {
                            *o = Some(SlipCause::HalfCycle);
                        }
                    }
                    if self.gf_jump(t, gf, h) {
                        out[0] = out[0].or(Some(SlipCause::GeometryFree));
                        out[1] = out[1].or(Some(SlipCause::GeometryFree));
                    }
                    if mw.is_finite() && h.mw_n >= 5 && (mw - h.mw_mean).abs() > self.mw_threshold {
                        out[0] = out[0].or(Some(SlipCause::MelbourneWubbena));
                        out[1] = out[1].or(Some(SlipCause::MelbourneWubbena));
                    }
                }
            }
        }
        let reset_mw = out[0].is_some() || out[1].is_some();
        let h = self.hist.entry(m.sv).or_insert(Hist {
            t,
            l: m.l,
            d: m.d,
            gf,
            gf_before: None,
            mw_mean: 0.0,
            mw_n: 0,
            lli: m.lli,
        });
        let follows = (t - h.t).to_seconds().abs() <= self.max_gap && t != h.t;
        h.gf_before =
            (follows && h.gf.is_finite() && out.iter().all(Option::is_none)).then_some((h.t, h.gf));
        h.t = t;
        h.l = m.l;
        h.d = m.d;
        h.gf = gf;
        h.lli = m.lli;
        if reset_mw || !mw.is_finite() {
            h.mw_n = 0;
            h.mw_mean = 0.0;
        }
        if mw.is_finite() {
            h.mw_n += 1;
            h.mw_mean += (mw - h.mw_mean) / h.mw_n as f64;
        }
        out
    }
}

/// How a receiver's Doppler follows its phase: see [`doppler_phase_ratio`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DopplerRatio {
    /// Median of the integrated Doppler over the phase change; 1 when the Doppler follows the
    /// convention of the Doppler test, −1 when its sign is reversed.
    pub median: f64,
    /// Samples (satellite, slot, pair of consecutive epochs) behind the median.
    pub samples: usize,
}

/// Fewest samples [`doppler_phase_ratio`] judges from.
const MIN_DOPPLER_SAMPLES: usize = 20;

/// Smallest phase change (cycles) a sample of [`doppler_phase_ratio`] may have: the ratio of
/// a slowly moving satellite is mostly noise and clock drift.
const MIN_PHASE_CHANGE: f64 = 10.0;

/// The receiver's integrated Doppler against its phase change, `−½(D₀ + D₁)·Δt / Δφ` (the
/// prediction of the Doppler test, Hz·s over cycles), over every satellite and slot seen at
/// two consecutive epochs `0 < Δt ≤ max_gap` apart with phase and Doppler at both, no
/// loss-of-lock flag at the second and `|Δφ| ≥ 10` cycles; the median, which a receiver clock
/// jump in a few epochs does not move. None with fewer than 20 samples (no Doppler).
pub fn doppler_phase_ratio(
    times: &[Epoch],
    meas: &[Vec<SatMeas>],
    max_gap: f64,
) -> Option<DopplerRatio> {
    let mut ratios = Vec::new();
    for i in 1..times.len().min(meas.len()) {
        let dt = (times[i] - times[i - 1]).to_seconds();
        if !(dt > 0.0 && dt <= max_gap) {
            continue;
        }
        for m in &meas[i] {
            let Some(h) = meas[i - 1].iter().find(|h| h.sv == m.sv) else {
                continue;
            };
            for f in 0..NF {
                let dl = m.l[f] - h.l[f];
                let predicted = -0.5 * (m.d[f] + h.d[f]) * dt;
                if m.lli[f] & 1 == 0 && predicted.is_finite() && dl.abs() >= MIN_PHASE_CHANGE {
                    ratios.push(predicted / dl);
                }
            }
        }
    }
    if ratios.len() < MIN_DOPPLER_SAMPLES {
        return None;
    }
    let mid = ratios.len() / 2;
    let (_, median, _) = ratios.select_nth_unstable_by(mid, |a, b| a.total_cmp(b));
    Some(DopplerRatio {
        median: *median,
        samples: ratios.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sv::{Constellation, Sv};
    use hifitime::Duration;

    /// A slip is recorded at the epoch after it, whichever direction found it; a loss-of-lock
    /// flag too.
    #[test]
    fn arc_breaks_are_the_union_of_both_directions() {
        let t0 = crate::time::gpst(2024, 1, 1, 0, 0, 0, 0);
        let times: Vec<Epoch> = (0..6)
            .map(|k| t0 + Duration::from_seconds(k as f64))
            .collect();
        let meas: Vec<Vec<SatMeas>> = (0..6)
            .map(|k| {
                let mut s = sat(1, k as f64, 300.0, 0.0);
                if k >= 3 {
                    s.l[0] += 7.0;
                }
                let mut other = sat(2, k as f64, -200.0, 0.0);
                if k == 5 {
                    other.lli[0] = 1;
                }
                vec![
                    s,
                    other,
                    sat(3, k as f64, 50.0, 0.0),
                    sat(4, k as f64, -500.0, 0.0),
                ]
            })
            .collect();
        let b = arc_breaks(&times, &meas, None, 10.0, true);
        let g = |prn| Sv::new(Constellation::Gps, prn);
        assert_eq!(
            b[3].get(&g(1)).map(|c| c[0]),
            Some(Some(SlipCause::Doppler))
        );
        assert_eq!(
            b[5].get(&g(2)).map(|c| c[0]),
            Some(Some(SlipCause::LossOfLock))
        );
        let others: usize = b.iter().map(|e| e.len()).sum();
        assert_eq!(others, 2, "{b:?}");
    }

    /// The half-cycle flag appearing or clearing breaks the arc in both directions (the
    /// receiver may step the phase by half a cycle when it resolves it); a flag held over an
    /// arc breaks nothing.
    #[test]
    fn half_cycle_flag_changes_break_the_arc() {
        let t0 = crate::time::gpst(2024, 1, 1, 0, 0, 0, 0);
        let times: Vec<Epoch> = (0..8)
            .map(|k| t0 + Duration::from_seconds(k as f64))
            .collect();
        let meas: Vec<Vec<SatMeas>> = (0..8)
            .map(|k| {
                let mut s = sat(1, k as f64, 300.0, 0.0);
                // unresolved at epochs 0–3, resolved (half a cycle subtracted) from 4 on
                if k < 4 {
                    s.lli[0] = LLI_HALF_CYCLE;
                } else {
                    s.l[0] -= 0.5;
                }
                let mut held = sat(2, k as f64, -200.0, 0.0);
                held.lli[0] = LLI_HALF_CYCLE;
                vec![
                    s,
                    held,
                    sat(3, k as f64, 50.0, 0.0),
                    sat(4, k as f64, -500.0, 0.0),
                ]
            })
            .collect();
        let b = arc_breaks(&times, &meas, None, 10.0, true);
        let g = |prn| Sv::new(Constellation::Gps, prn);
        assert_eq!(
            b[4].get(&g(1)).map(|c| c[0]),
            Some(Some(SlipCause::HalfCycle))
        );
        let all: usize = b.iter().map(|e| e.len()).sum();
        assert_eq!(all, 1, "{b:?}");
    }

    fn sat(prn: u8, t: f64, rate: f64, clock_m: f64) -> SatMeas {
        let f = 1575.42e6;
        let lam = C / f;
        let range = 2.2e7 + rate * t;
        SatMeas {
            sv: Sv::new(Constellation::Gps, prn),
            freq: [f, f64::NAN, f64::NAN],
            l: [(range + clock_m) / lam, f64::NAN, f64::NAN],
            p: [range + clock_m, f64::NAN, f64::NAN],
            d: [-rate / lam, f64::NAN, f64::NAN],
            lli: [0; NF],
            snr: [0; NF],
            snr_drop: [crate::ppk::obs::NO_DROP; NF],
            code_var: [f32::NAN; NF],
        }
    }

    #[test]
    fn doppler_test_finds_a_single_frequency_slip_and_ignores_a_clock_jump() {
        let t0 = crate::time::gpst(2024, 1, 1, 0, 0, 0, 0);
        let rates = [-600.0, -150.0, 80.0, 420.0, 700.0];
        let mut det = SlipDetector::new(10.0, false);
        for k in 0..4 {
            let t = t0 + Duration::from_seconds(k as f64);
            // A 1 ms receiver clock jump at epoch 2, common to all satellites.
            let clock = if k >= 2 { 299_792.458 } else { 0.0 };
            let mut sats: Vec<SatMeas> = rates
                .iter()
                .enumerate()
                .map(|(i, r)| sat(i as u8 + 1, k as f64, *r, clock))
                .collect();
            if k >= 3 {
                sats[2].l[0] += 7.0; // a 7-cycle slip on one satellite
            }
            let out = det.check_epoch(t, &sats, None);
            for (i, o) in out.iter().enumerate() {
                let want = (k == 3 && i == 2).then_some(SlipCause::Doppler);
                assert_eq!(o[0], want, "epoch {k} satellite {i}");
            }
        }
    }

    /// Doppler with the test's sign gives a ratio of 1 (a clock jump in one epoch does not
    /// move the median), reversed −1; without Doppler there is no verdict, and a receiver
    /// whose Doppler is left out of the test gets no Doppler slips.
    #[test]
    fn doppler_ratio_measures_sign_and_scale() {
        let t0 = crate::time::gpst(2024, 1, 1, 0, 0, 0, 0);
        let times: Vec<Epoch> = (0..10)
            .map(|k| t0 + Duration::from_seconds(k as f64))
            .collect();
        let rates = [-600.0, -150.0, 80.0, 420.0, 700.0];
        let epochs = |flip: f64, doppler: bool| -> Vec<Vec<SatMeas>> {
            (0..10)
                .map(|k| {
                    let clock = if k >= 5 { 299_792.458 } else { 0.0 };
                    rates
                        .iter()
                        .enumerate()
                        .map(|(i, r)| {
                            let mut s = sat(i as u8 + 1, k as f64, *r, clock);
                            s.d[0] = if doppler { flip * s.d[0] } else { f64::NAN };
                            s
                        })
                        .collect()
                })
                .collect()
        };
        let right = doppler_phase_ratio(&times, &epochs(1.0, true), 10.0).unwrap();
        assert_eq!(right.samples, 45);
        assert!((right.median - 1.0).abs() < 1e-9, "{right:?}");
        let reversed = doppler_phase_ratio(&times, &epochs(-1.0, true), 10.0).unwrap();
        assert!((reversed.median + 1.0).abs() < 1e-9, "{reversed:?}");
        assert_eq!(doppler_phase_ratio(&times, &epochs(1.0, false), 10.0), None);
        let with = arc_breaks(&times, &epochs(-1.0, true), None, 10.0, true);
        assert!(with.iter().map(|e| e.len()).sum::<usize>() > 0);
        let without = arc_breaks(&times, &epochs(-1.0, true), None, 10.0, false);
        assert_eq!(
            without.iter().map(|e| e.len()).sum::<usize>(),
            0,
            "{without:?}"
        );
    }
}
