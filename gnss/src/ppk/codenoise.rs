//! A receiver's own code noise, measured from its data: the code minus the carrier phase of
//! each arc (CMC: the code's multipath and noise, twice the ionosphere and a constant
//! ambiguity), detrended by a quadratic in time over pieces of an arc, is the code error with
//! its slow part removed. Its variance per C/N0 class, and how strongly it is correlated from
//! one epoch to the next, say how much a code measurement is worth: a low-cost receiver
//! under trees was measured with a code error of a metre whose autocorrelation is still 0.87
//! after a second, where the default model assumes 0.4 m and a ten-second memory. A filter
//! that takes such epochs as independent averages a correlated error down that does not go
//! down, and claims centimetres on a float a metre off.
//!
//! What leaves: per receiver, [`CodeNoise`] — the variance of each C/N0 class and the
//! variance inflation 1 + 2·Σ ρₖ (ρₖ the autocorrelation at k epochs, summed while it stays
//! positive): what one epoch's code is worth among its neighbours. Each measurement then
//! carries its own code variance ([`SatMeas::code_var`]); the filter takes the larger of
//! that and its model's. Excursions (a residual beyond five robust σ of its receiver) are
//! left out of the measure: the filter leaves them out of the solution too.
//!
//! What enters: one receiver's measurements, times, arc breaks and nominal interval.

use super::obs::{SatMeas, NF};
use super::slip::Slips;
use crate::sv::Sv;
use hifitime::Epoch;
use std::collections::HashMap;

/// C/N0 class edges, dB-Hz: below 30, 30–35, 35–40, 40–45, 45 and above.
const EDGES: [f64; 4] = [30.0, 35.0, 40.0, 45.0];
/// Number of C/N0 classes (one more: the measurement has no C/N0).
pub const CLASSES: usize = EDGES.len() + 2;
/// Fewest epochs of a piece of an arc that is detrended and measured.
const MIN_PIECE: usize = 20;
/// Longest piece of an arc, seconds.
const MAX_PIECE_S: f64 = 300.0;
/// Fewest residuals a class's variance is taken from.
const MIN_CLASS: usize = 50;
/// Residuals beyond this many robust σ are excursions, left out.
const OUTLIER: f64 = 5.0;
/// Largest lag summed into the inflation, epochs.
const MAX_LAG: usize = 60;

/// The C/N0 class of a measurement (the last class when it has no C/N0).
pub fn class(cn0: f64) -> usize {
    if cn0.is_nan() {
        return CLASSES - 1;
    }
    EDGES.iter().take_while(|&&e| cn0 >= e).count()
}

/// A receiver's measured code noise.
#[derive(Clone, Debug, PartialEq)]
pub struct CodeNoise {
    /// Variance of the code error per C/N0 class, m² (NaN: too few samples).
    pub var: [f64; CLASSES],
    /// What one epoch's code is worth among its correlated neighbours: the variance of a
    /// mean of n epochs is var·inflation/n.
    pub inflation: f64,
    /// Residuals measured.
    pub samples: usize,
}

impl CodeNoise {
    /// The variance a filter that takes epochs as independent should give a measurement of
    /// C/N0 `cn0` (var·inflation; the nearest measured class's where its own is unknown),
    /// m²; NaN when nothing was measured.
    pub fn effective(&self, cn0: f64) -> f64 {
        let c = class(cn0);
        let known = (0..CLASSES).filter(|&k| self.var[k].is_finite());
        let k = known.min_by_key(|&k| k.abs_diff(c));
        k.map_or(f64::NAN, |k| self.var[k] * self.inflation)
    }
}

/// One arc's samples: time (s), CMC (m), C/N0 class.
type Arc = Vec<(f64, f64, usize)>;

/// The arcs of code and phase of one receiver, per satellite and slot, broken at gaps longer
/// than 1.5 intervals, losses of lock, arc breaks and missing code or phase.
fn arcs(times: &[Epoch], meas: &[Vec<SatMeas>], breaks: &[Slips], interval: f64) -> Vec<Arc> {
    let mut open: HashMap<(Sv, usize), (f64, Arc)> = HashMap::new();
    let mut done = Vec::new();
    let t0 = times.first().copied();
    for (i, (t, ms)) in times.iter().zip(meas).enumerate() {
        let ts = t0.map_or(0.0, |t0| (*t - t0).to_seconds());
        for m in ms {
            for f in 0..NF {
                let ok = m.p[f].is_finite() && m.l[f].is_finite();
                let key = (m.sv, f);
                let broken = m.lli[f] & 1 != 0
                    || breaks
                        .get(i)
                        .and_then(|b| b.get(&m.sv))
                        .is_some_and(|c| c[f].is_some());
                let entry = open.remove(&key);
                let mut arc = match entry {
                    Some((last, arc)) if ok && !broken && ts - last <= 1.5 * interval => arc,
                    Some((_, arc)) => {
                        done.push(arc);
                        Vec::new()
                    }
                    None => Vec::new(),
                };
                if ok {
                    arc.push((ts, m.p[f] - m.wavelength(f) * m.l[f], class(m.cn0(f))));
                    open.insert(key, (ts, arc));
                }
            }
        }
    }
    done.extend(open.into_values().map(|(_, a)| a));
    done.retain(|a| a.len() >= MIN_PIECE);
    done
}

/// Residuals of a quadratic in time fitted to `piece` (scaled by √(n/(n−3)) for the three
/// parameters), the fit repeated once without the residuals beyond `limit` (NaN there).
fn detrend(piece: &[(f64, f64, usize)], limit: f64) -> Vec<f64> {
    let n = piece.len();
    let tm = piece.iter().map(|p| p.0).sum::<f64>() / n as f64;
    let mut keep = vec![true; n];
    let mut res = vec![0.0; n];
    for _ in 0..2 {
        let mut a = nalgebra::Matrix3::zeros();
        let mut b = nalgebra::Vector3::zeros();
        for (p, _) in piece.iter().zip(&keep).filter(|(_, k)| **k) {
            let x = p.0 - tm;
            let row = nalgebra::Vector3::new(1.0, x, x * x);
            a += row * row.transpose();
            b += row * p.1;
        }
        let Some(c) = a.try_inverse().map(|ai| ai * b) else {
            return vec![f64::NAN; n];
        };
        let scale = (n as f64 / (n as f64 - 3.0)).sqrt();
        for (k, p) in piece.iter().enumerate() {
            let x = p.0 - tm;
            res[k] = (p.1 - c[0] - c[1] * x - c[2] * x * x) * scale;
            keep[k] = res[k].abs() <= limit;
        }
    }
    piece
        .iter()
        .zip(&res)
        .map(|(_, r)| if r.abs() <= limit { *r } else { f64::NAN })
        .collect()
}

/// The residuals of every piece of `arcs` (pieces of at most [`MAX_PIECE_S`]), with their
/// classes; excursions beyond `limit` NaN.
fn pieces(arcs: &[Arc], limit: f64) -> Vec<(Vec<f64>, Vec<usize>)> {
    let mut out = Vec::new();
    for a in arcs {
        let span = a.last().map_or(0.0, |l| l.0) - a[0].0;
        let parts = ((span / MAX_PIECE_S).ceil() as usize).max(1);
        let len = a.len().div_ceil(parts);
        for p in a.chunks(len).filter(|p| p.len() >= MIN_PIECE) {
            out.push((detrend(p, limit), p.iter().map(|s| s.2).collect()));
        }
    }
    out
}

/// The robust σ (1.4826 × median absolute value) of the residuals of a first detrending with
/// no limit.
fn robust_sigma(arcs: &[Arc]) -> f64 {
    let mut abs: Vec<f64> = pieces(arcs, f64::INFINITY)
        .into_iter()
        .flat_map(|(r, _)| r)
        .map(f64::abs)
        .filter(|v| v.is_finite())
        .collect();
    if abs.is_empty() {
        return f64::NAN;
    }
    let mid = abs.len() / 2;
    let (_, m, _) = abs.select_nth_unstable_by(mid, f64::total_cmp);
    1.4826 * *m
}

/// One receiver's code noise; None with fewer than [`MIN_CLASS`] residuals in all.
pub fn measure(
    times: &[Epoch],
    meas: &[Vec<SatMeas>],
    breaks: &[Slips],
    interval: f64,
) -> Option<CodeNoise> {
    let arcs = arcs(times, meas, breaks, interval);
    let sigma = robust_sigma(&arcs);
    if !sigma.is_finite() || sigma <= 0.0 {
        return None;
    }
    let res = pieces(&arcs, OUTLIER * sigma);
    let mut sum = [0.0; CLASSES];
    let mut count = [0usize; CLASSES];
    let mut lag = [0.0; MAX_LAG + 1];
    for (r, c) in &res {
        for (v, k) in r.iter().zip(c).filter(|(v, _)| v.is_finite()) {
            sum[*k] += v * v;
            count[*k] += 1;
        }
        for (k, l) in lag.iter_mut().enumerate() {
            *l += r
                .iter()
                .zip(r.iter().skip(k))
                .filter(|(a, b)| a.is_finite() && b.is_finite())
                .map(|(a, b)| a * b)
                .sum::<f64>();
        }
    }
    let samples: usize = count.iter().sum();
    if samples < MIN_CLASS || lag[0] <= 0.0 {
        return None;
    }
    let mut inflation = 1.0;
    for l in &lag[1..] {
        let rho = l / lag[0];
        if rho <= 0.0 {
            break;
        }
        inflation += 2.0 * rho;
    }
    let var = std::array::from_fn(|k| {
        if count[k] >= MIN_CLASS {
            sum[k] / count[k] as f64
        } else {
            f64::NAN
        }
    });
    Some(CodeNoise {
        var,
        inflation,
        samples,
    })
}

/// Set each measurement's code variance from its receiver's measured noise.
pub fn mark(meas: &mut [Vec<SatMeas>], noise: &CodeNoise) {
    for m in meas.iter_mut().flatten() {
        for f in 0..NF {
            if m.p[f].is_finite() {
                m.set_code_var(f, noise.effective(m.cn0(f)));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sv::Constellation;

    /// A first-order Gauss–Markov code error of 1 m and 5 s (inflation (1 + ρ)/(1 − ρ) ≈ 10
    /// at 1 Hz) on arcs of 200 s with a ramp of ionosphere: the variance and the inflation
    /// are found, the ramp removed, an excursion of 20 m left out.
    #[test]
    fn the_noise_and_its_memory_are_measured() {
        let t0 = crate::time::gpst(2024, 1, 1, 0, 0, 0, 0);
        let lam = crate::orbit::C / 1575.42e6;
        let mut seed = 99u64;
        let mut normal = move || {
            let mut s = 0.0;
            for _ in 0..12 {
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                s += (seed >> 11) as f64 / (1u64 << 53) as f64;
            }
            s - 6.0
        };
        let rho = (-1.0f64 / 5.0).exp();
        let n = 2000;
        let mut err = [0.0f64; 8];
        let mut times = Vec::new();
        let mut meas = Vec::new();
        for k in 0..n {
            times.push(t0 + hifitime::Duration::from_seconds(k as f64));
            let mut epoch = Vec::new();
            for (s, e) in err.iter_mut().enumerate() {
                *e = rho * *e + (1.0 - rho * rho).sqrt() * normal();
                let excursion = if k == 700 && s == 2 { 20.0 } else { 0.0 };
                let iono = 0.002 * k as f64;
                let range = 2.2e7 + 100.0 * k as f64;
                let mut m = SatMeas {
                    sv: Sv::new(Constellation::Gps, s as u8 + 1),
                    freq: [1575.42e6, f64::NAN, f64::NAN],
                    l: [(range - iono) / lam + 1e6, f64::NAN, f64::NAN],
                    p: [range + iono + *e + excursion, f64::NAN, f64::NAN],
                    d: [f64::NAN; NF],
                    // an arc break every 200 epochs
                    lli: [u8::from(k % 200 == 0), 0, 0],
                    snr: [0; NF],
                    snr_drop: [super::super::obs::NO_DROP; NF],
                    code_var: [f32::NAN; NF],
                };
                m.set_cn0(0, 47.0);
                epoch.push(m);
            }
            meas.push(epoch);
        }
        let noise = measure(&times, &meas, &vec![Slips::new(); n], 1.0).unwrap();
        let var = noise.var[class(47.0)];
        // detrending 200-s pieces takes a little of the slow part out
        assert!((0.8..1.1).contains(&var), "{noise:?}");
        let want = (1.0 + rho) / (1.0 - rho);
        assert!(
            (0.6 * want..1.2 * want).contains(&noise.inflation),
            "{noise:?} {want}"
        );
        assert!((noise.effective(47.0) - var * noise.inflation).abs() < 1e-12);
        // a class without samples takes the nearest measured one
        assert_eq!(noise.effective(20.0), noise.effective(47.0));
        mark(&mut meas, &noise);
        assert!((f64::from(meas[5][0].code_var[0]) - noise.effective(47.0)).abs() < 1e-3);
    }
}
