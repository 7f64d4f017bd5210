//! How well a receiver's Doppler predicts its phase: the noise of the Doppler-versus-phase
//! slip test, measured on the data, so that a single-frequency receiver (blind to the
//! geometry-free test) has a threshold that catches a slip of a cycle or two when its
//! Doppler allows, not one fixed for the noisiest receivers.
//!
//! What enters: one receiver's epochs of measurements (phase, Doppler, C/N0 drop) and, where
//! known, each satellite's line of sight. What leaves: [`MisfitNoise`], the robust sigma of
//! the misfit between the phase change and the integrated Doppler over consecutive epochs,
//! after the common part of each epoch is removed ([`remove_common`]), from clean signals
//! (C/N0 within 3 dB of the receiver's normal) that did not slip; the median absolute misfit
//! ignores the few that a manoeuvre or a slip spoils.
//!
//! The common part: with six satellites or more whose line of sight is known, a robust
//! least-squares fit of a velocity and a clock rate (what the receiver's acceleration
//! between the epochs leaves after the trapezoid rule projects on each line of sight as a
//! velocity would, and its clock's change is common), the worst misfit dropped while it
//! stands out; otherwise the epoch's median (the clock only). The same fit the fingerprint
//! tool makes, so that the thresholds are those of the noise it measures.

#[cfg(test)]
use super::obs::NO_DROP;
use super::obs::{SatMeas, NF};
use hifitime::Epoch;
use nalgebra::{Matrix4, Vector3, Vector4};

/// Fewest misfits with a line of sight for the velocity and clock-rate fit.
const FIT_MIN: usize = 6;
/// Misfit (m) beyond which, and beyond four robust sigmas of the fit, a satellite is dropped
/// from the fit (it may be the slip to find).
const FIT_FLOOR: f64 = 0.05;
/// Only misfits this close to the epoch's median (m) enter the fit: an aircraft's hardest
/// pull-up leaves decimetres a second, a slip from a cycle to thousands.
const FIT_PRESCREEN: f64 = 1.0;

/// The misfits (metres) less the epoch's common part: a velocity and clock-rate fit over
/// those with a line of sight (unit vector receiver → satellite) when six or more have one,
/// else the median (three or more). NaN stays NaN; all NaN when nothing can be removed.
pub fn remove_common(misfits: &[(f64, Option<Vector3<f64>>)]) -> Vec<f64> {
    let median = median_of(misfits);
    // Slips of cycles to thousands must not steer the fit: only misfits within
    // [`FIT_PRESCREEN`] of the median enter it (they are all tested against it).
    let with_los: Vec<usize> = (0..misfits.len())
        .filter(|&k| misfits[k].1.is_some() && (misfits[k].0 - median).abs() <= FIT_PRESCREEN)
        .collect();
    if with_los.len() >= FIT_MIN {
        if let Some(x) = robust_fit(misfits, with_los) {
            return misfits
                .iter()
                .map(|(m, e)| match e {
                    Some(e) => m - (Vector4::new(-e.x, -e.y, -e.z, 1.0).dot(&x)),
                    None => f64::NAN,
                })
                .collect();
        }
    }
    if median.is_nan() {
        return vec![f64::NAN; misfits.len()];
    }
    misfits.iter().map(|m| m.0 - median).collect()
}

/// The median of the finite misfits, NaN with fewer than three.
fn median_of(misfits: &[(f64, Option<Vector3<f64>>)]) -> f64 {
    let mut all: Vec<f64> = misfits
        .iter()
        .map(|m| m.0)
        .filter(|v| v.is_finite())
        .collect();
    if all.len() < 3 {
        return f64::NAN;
    }
    all.sort_by(f64::total_cmp);
    all[all.len() / 2]
}

/// The velocity (3) and clock rate of the misfits `use_` (indices), the worst dropped while
/// more than [`FIT_MIN`] are left and its residual against the fit of the others (a slip
/// spreads over a fit that includes it) lies beyond [`FIT_FLOOR`] and four robust sigmas of
/// the others about that fit.
fn robust_fit(
    misfits: &[(f64, Option<Vector3<f64>>)],
    mut use_: Vec<usize>,
) -> Option<Vector4<f64>> {
    let row = |k: usize| {
        let e = misfits[k].1.unwrap_or_default();
        Vector4::new(-e.x, -e.y, -e.z, 1.0)
    };
    let fit = |use_: &[usize], skip: Option<usize>| {
        let mut n = Matrix4::zeros();
        let mut b = Vector4::zeros();
        for &k in use_.iter().filter(|&&k| Some(k) != skip) {
            let a = row(k);
            n += a * a.transpose();
            b += a * misfits[k].0;
        }
        n.try_inverse().map(|ni| ni * b)
    };
    loop {
        let x = fit(&use_, None)?;
        if use_.len() <= FIT_MIN {
            return Some(x);
        }
        let loo: Vec<f64> = use_
            .iter()
            .map(|&k| fit(&use_, Some(k)).map_or(0.0, |y| (misfits[k].0 - row(k).dot(&y)).abs()))
            .collect();
        let (worst, w) = loo.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1))?;
        // the others' spread about the fit without the worst
        let y = fit(&use_, Some(use_[worst]))?;
        let mut others: Vec<f64> = (use_.iter().enumerate())
            .filter(|(i, _)| *i != worst)
            .map(|(_, &k)| (misfits[k].0 - row(k).dot(&y)).abs())
            .collect();
        others.sort_by(f64::total_cmp);
        let sigma = 1.4826 * others[others.len() / 2];
        if *w > FIT_FLOOR.max(4.0 * sigma) {
            use_.swap_remove(worst);
            continue;
        }
        return Some(x);
    }
}

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
/// epoch's common part removed ([`remove_common`], with the lines of sight `los` of the
/// current epoch when given). Empty when fewer than three misfits.
fn epoch_misfits(
    prev: &[SatMeas],
    cur: &[SatMeas],
    dt: f64,
    los: Option<&[Option<Vector3<f64>>]>,
) -> Vec<(f64, bool)> {
    let mut v: Vec<(f64, Option<Vector3<f64>>, bool)> = Vec::new();
    for (k, m) in cur.iter().enumerate() {
        let Some(h) = prev.iter().find(|h| h.sv == m.sv) else {
            continue;
        };
        let e = los.and_then(|l| l.get(k).copied().flatten());
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
            v.push((misfit, e, clean));
        }
    }
    if v.len() < 3 {
        return Vec::new();
    }
    let pairs: Vec<(f64, Option<Vector3<f64>>)> = v.iter().map(|x| (x.0, x.1)).collect();
    remove_common(&pairs)
        .into_iter()
        .zip(v)
        .filter(|(r, _)| r.is_finite())
        .map(|(r, x)| (r, x.2))
        .collect()
}

/// The noise of a receiver's misfit over its consecutive epochs at most `max_gap` apart;
/// None with fewer than `MIN_SAMPLES` clean misfits (no Doppler, or no C/N0 to tell clean
/// signals by).
pub fn misfit_noise(
    times: &[Epoch],
    meas: &[Vec<SatMeas>],
    los: Option<&[Vec<Option<Vector3<f64>>>]>,
    max_gap: f64,
) -> Option<MisfitNoise> {
    let mut res = Vec::new();
    let mut dts = Vec::new();
    for i in 1..times.len().min(meas.len()) {
        let dt = (times[i] - times[i - 1]).to_seconds();
        if !(dt > 0.0 && dt <= max_gap) {
            continue;
        }
        let l = los.and_then(|l| l.get(i)).map(|v| v.as_slice());
        let clean: Vec<f64> = epoch_misfits(&meas[i - 1], &meas[i], dt, l)
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

    /// A receiver accelerating between two epochs leaves each satellite a misfit of its line
    /// of sight times the trapezoid's error, plus the clock's change: the fit takes both out
    /// and leaves a slip of half a cycle standing, where the median leaves decimetres.
    #[test]
    fn the_fit_takes_out_acceleration_and_clock() {
        let accel = Vector3::new(0.3, -0.2, 0.1);
        let dirs: Vec<Vector3<f64>> = (0..9)
            .map(|k| {
                let (az, el) = (0.7 * k as f64, 0.2 + 0.15 * k as f64);
                Vector3::new(el.cos() * az.sin(), el.cos() * az.cos(), el.sin())
            })
            .collect();
        let misfits: Vec<(f64, Option<Vector3<f64>>)> = dirs
            .iter()
            .enumerate()
            .map(|(k, e)| {
                let slip = if k == 4 { 0.095 } else { 0.0 };
                (-e.dot(&accel) + 12.0 + slip, Some(*e))
            })
            .collect();
        let r = remove_common(&misfits);
        for (k, v) in r.iter().enumerate() {
            let want = if k == 4 { 0.095 } else { 0.0 };
            assert!((v - want).abs() < 1e-9, "{k}: {v}");
        }
        let median: Vec<(f64, Option<Vector3<f64>>)> =
            misfits.iter().map(|m| (m.0, None)).collect();
        let spread = remove_common(&median)
            .iter()
            .fold(0.0f64, |a, v| a.max(v.abs()));
        assert!(spread > 0.2, "{spread}");
    }

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
                            code_var: [f32::NAN; NF],
                        }
                    })
                    .collect()
            })
            .collect();
        let n = misfit_noise(&times, &meas, None, 5.0).unwrap();
        let cycles = n.sigma / lam;
        assert!((cycles - 0.1 / 2f64.sqrt()).abs() < 0.02, "{n:?} {cycles}");
        assert_eq!(n.interval, 1.0);
    }
}
