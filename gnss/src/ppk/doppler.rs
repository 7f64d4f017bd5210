//! How well a receiver's Doppler predicts its phase: the noise of the Doppler-versus-phase
//! slip test, measured on the data, so that a single-frequency receiver (blind to the
//! geometry-free test) has a threshold that catches a slip of a cycle or two when its
//! Doppler allows, not one fixed for the noisiest receivers.
//!
//! What enters: one receiver's epochs of measurements (phase, Doppler, C/N0 drop). What
//! leaves: [`MisfitNoise`], the robust sigma of the misfit between the phase change and the
//! integrated Doppler over consecutive epochs, after the common (receiver clock) part of each
//! epoch is removed, from clean signals (C/N0 within 3 dB of the receiver's normal) that did
//! not slip; the median absolute misfit ignores the few that a manoeuvre or a slip spoils.

#[cfg(test)]
use super::obs::NO_DROP;
use super::obs::{SatMeas, NF};
use hifitime::Epoch;

/// What the noise is measured from: signals this far at most below their receiver's normal
/// C/N0, dB.
const CLEAN_DROP: f64 = 3.0;
/// Fewest misfits the noise is measured from.
const MIN_SAMPLES: usize = 50;

/// The noise of a receiver's Doppler-versus-phase misfit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MisfitNoise {
    /// Robust sigma (1.4826 × median absolute value) of the misfit, metres.
    pub sigma: f64,
    /// The median interval it was measured over, seconds.
    pub interval: f64,
    /// Misfits behind it.
    pub samples: usize,
}

/// The misfits (metres) of epoch `i` against epoch `i − 1` of the satellites and slots seen
/// at both with phase and Doppler and no loss of lock, and whether each is clean; the
/// epoch's median removed. Empty when the epochs are more than `max_gap` apart.
fn epoch_misfits(prev: &[SatMeas], cur: &[SatMeas], dt: f64) -> Vec<(f64, bool)> {
    let mut v: Vec<(f64, bool)> = Vec::new();
    for m in cur {
        let Some(h) = prev.iter().find(|h| h.sv == m.sv) else {
            continue;
        };
        for f in 0..NF {
            let ok = m.l[f].is_finite()
                && h.l[f].is_finite()
                && m.d[f].is_finite()
                && h.d[f].is_finite()
                && m.lli[f] & 1 == 0;
            if !ok {
                continue;
            }
            let predicted = -0.5 * (m.d[f] + h.d[f]) * dt;
            let misfit = (m.l[f] - h.l[f] - predicted) * m.wavelength(f);
            let clean = m.cn0_drop(f) <= CLEAN_DROP && h.cn0_drop(f) <= CLEAN_DROP;
            v.push((misfit, clean));
        }
    }
    if v.len() < 3 {
        return Vec::new();
    }
    let mut sorted: Vec<f64> = v.iter().map(|x| x.0).collect();
    sorted.sort_by(f64::total_cmp);
    let common = sorted[sorted.len() / 2];
    v.into_iter().map(|(x, c)| (x - common, c)).collect()
}

/// The noise of a receiver's misfit over its consecutive epochs at most `max_gap` apart;
/// None with fewer than `MIN_SAMPLES` clean misfits (no Doppler, or no C/N0 to tell clean
/// signals by).
pub fn misfit_noise(times: &[Epoch], meas: &[Vec<SatMeas>], max_gap: f64) -> Option<MisfitNoise> {
    let mut res = Vec::new();
    let mut dts = Vec::new();
    for i in 1..times.len().min(meas.len()) {
        let dt = (times[i] - times[i - 1]).to_seconds();
        if !(dt > 0.0 && dt <= max_gap) {
            continue;
        }
        let clean: Vec<f64> = epoch_misfits(&meas[i - 1], &meas[i], dt)
            .into_iter()
            .filter_map(|(x, c)| c.then_some(x.abs()))
            .collect();
        if !clean.is_empty() {
            dts.push(dt);
        }
        res.extend(clean);
    }
    if res.len() < MIN_SAMPLES {
        return None;
    }
    let mid = res.len() / 2;
    let (_, median, _) = res.select_nth_unstable_by(mid, f64::total_cmp);
    let sigma = 1.4826 * *median;
    let mid = dts.len() / 2;
    let (_, interval, _) = dts.select_nth_unstable_by(mid, f64::total_cmp);
    Some(MisfitNoise {
        sigma,
        interval: *interval,
        samples: res.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sv::{Constellation, Sv};
    use hifitime::Duration;

    /// Doppler with 0.1 Hz of noise at 1 Hz on L1: the misfit's sigma is about 0.1/√2 cycles
    /// (the trapezoid averages two Dopplers), whatever a common clock jump does.
    #[test]
    fn the_misfit_noise_is_measured() {
        let t0 = crate::time::gpst(2024, 1, 1, 0, 0, 0, 0);
        let f = 1575.42e6;
        let lam = crate::orbit::C / f;
        let mut rng = 12345u64;
        let mut normal = move || {
            // Irwin–Hall approximation of a standard normal from 12 uniforms.
            let mut s = 0.0;
            for _ in 0..12 {
                rng = rng
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                s += (rng >> 11) as f64 / (1u64 << 53) as f64;
            }
            s - 6.0
        };
        let times: Vec<Epoch> = (0..200)
            .map(|k| t0 + Duration::from_seconds(k as f64))
            .collect();
        let meas: Vec<Vec<SatMeas>> = (0..200)
            .map(|k| {
                let clock = if k >= 100 { 3000.0 } else { 0.0 };
                (1..=8u8)
                    .map(|prn| {
                        let rate = -300.0 + 80.0 * prn as f64;
                        let range = 2.1e7 + rate * k as f64 + clock;
                        SatMeas {
                            sv: Sv::new(Constellation::Gps, prn),
                            freq: [f, f64::NAN, f64::NAN],
                            l: [range / lam, f64::NAN, f64::NAN],
                            p: [range, f64::NAN, f64::NAN],
                            d: [-rate / lam + 0.1 * normal(), f64::NAN, f64::NAN],
                            lli: [0; NF],
                            snr: [180, 0, 0],
                            snr_drop: [0, NO_DROP, NO_DROP],
                        }
                    })
                    .collect()
            })
            .collect();
        let n = misfit_noise(&times, &meas, 5.0).unwrap();
        let cycles = n.sigma / lam;
        assert!((cycles - 0.1 / 2f64.sqrt()).abs() < 0.02, "{n:?} {cycles}");
        assert_eq!(n.interval, 1.0);
    }
}
