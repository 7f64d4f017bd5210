//! The smoother's σ inside GNSS gaps, checked against the GNSS itself.
//!
//! The bridges' ends ([`crate::loose::LooseRun::bridge_nis`]) test the forward filter's
//! prediction across a gap, whose σ is mostly the attitude's and the biases' uncertainty;
//! the smoothed σ in the middle of a gap, pinned at both ends, is mostly the IMU's random
//! walks over half the gap — a figure the ends cannot test, and the one a data sheet gets
//! wrong when the motion (a walker's steps, an engine's vibration) excites errors it does
//! not list. So trial gaps as long as the real ones are cut where the GNSS is continuous,
//! the run is repeated without the fixes inside them, and the smoothed antenna positions
//! there are compared with the fixes withheld: a mean NEES per axis near 1 says the σ of
//! the real gaps hold.
//!
//! What enters: the IMU samples, the fixes, the start, the IMU's figures and the run's
//! options. What leaves: the trial gaps and the NEES found there ([`TrialCheck`]).

use crate::errstate::{idx, skew, Mat};
use crate::filter::{Estimate, PositionFix};
use crate::imu::ImuSample;
use crate::loose::{run_with_phases, LooseOptions, BRIDGE};
use crate::spec::ImuSpec;
use crate::tight::Phases;
use hifitime::{Duration, Epoch};
use nalgebra::{SMatrix, Vector3};

/// Most trial gaps cut in one check.
pub const MOST_TRIALS: usize = 8;
/// The longest trial gap, s (a real gap longer than this is tried at this length).
pub const LONGEST_TRIAL: f64 = 60.0;

/// What a check of the smoothed σ in trial gaps found.
#[derive(Clone, Debug, PartialEq)]
pub struct TrialCheck {
    /// Trial gaps cut.
    pub gaps: usize,
    /// Their length, s: the median of the real gaps.
    pub length: f64,
    /// Fixes withheld in them and compared.
    pub fixes: usize,
    /// Mean normalised error squared per axis of the smoothed antenna positions against
    /// the withheld fixes (their own σ included): 1 when the σ hold.
    pub ratio: f64,
}

/// The real gaps of `times` (consecutive fixes further apart than [`BRIDGE`]) and, where
/// the fixes are continuous for long enough, up to [`MOST_TRIALS`] trial gaps as long as
/// the real ones' median (at most [`LONGEST_TRIAL`]), each with a quarter of its length (at
/// least 2 s) of fixes either side, spread evenly over the run. Empty when there is no real
/// gap: then no σ of a bridge is at stake.
pub fn trial_gaps(times: &[Epoch]) -> (f64, Vec<(Epoch, Epoch)>) {
    let mut real: Vec<f64> = times
        .windows(2)
        .map(|w| (w[1] - w[0]).to_seconds())
        .filter(|d| *d > BRIDGE)
        .collect();
    if real.is_empty() {
        return (0.0, Vec::new());
    }
    real.sort_by(f64::total_cmp);
    let length = real[real.len() / 2].min(LONGEST_TRIAL);
    let margin = (0.25 * length).max(2.0);
    let slot = length + 2.0 * margin;
    let mut slots = Vec::new();
    let mut from = 0;
    for i in 0..times.len() {
        let end_of_stretch =
            i + 1 == times.len() || (times[i + 1] - times[i]).to_seconds() > BRIDGE;
        if !end_of_stretch {
            continue;
        }
        let span = (times[i] - times[from]).to_seconds();
        let n = (span / slot).floor() as usize;
        let lead = 0.5 * (span - n as f64 * slot);
        for k in 0..n {
            let a = times[from] + Duration::from_seconds(lead + k as f64 * slot + margin);
            slots.push((a, a + Duration::from_seconds(length)));
        }
        from = i + 1;
    }
    let n = slots.len();
    let take = n.min(MOST_TRIALS);
    let gaps = (0..take)
        .map(|j| slots[(j * n + n / 2) / take.max(1) % n.max(1)])
        .collect();
    (length, gaps)
}

/// Run again without the fixes inside `gaps` and compare the smoothed antenna positions
/// at their times with them; None when no fix falls in a gap or no checkpoint was made.
pub fn check(
    samples: &[ImuSample],
    (fixes, phases): (&[(Epoch, PositionFix)], &Phases),
    start: (Estimate, Mat),
    spec: &ImuSpec,
    o: &LooseOptions,
    (length, gaps): (f64, &[(Epoch, Epoch)]),
) -> Option<TrialCheck> {
    let inside = |t: Epoch| gaps.iter().any(|(a, b)| t > *a && t < *b);
    let (held, kept): (Vec<_>, Vec<_>) = fixes.iter().copied().partition(|(t, _)| inside(*t));
    if held.is_empty() {
        return None;
    }
    let trial = LooseOptions {
        every: usize::MAX,
        marks: held.iter().map(|(t, _)| *t).collect(),
        ..o.clone()
    };
    let r = run_with_phases(samples, &kept, phases, start, spec, &trial);
    let (mut sum, mut n) = (0.0, 0usize);
    for (t, fix) in &held {
        let j = r.smoothed.partition_point(|(c, _)| c < t);
        let near = [j.checked_sub(1), Some(j)]
            .into_iter()
            .flatten()
            .filter_map(|i| r.smoothed.get(i))
            .min_by_key(|(c, _)| (*c - *t).abs());
        let Some((c, s)) = near else { continue };
        let dt = (*t - *c).to_seconds();
        if dt.abs() > 0.5 {
            continue;
        }
        let arm = s.est.nav.attitude.matrix() * o.lever_arm;
        let at = s.est.nav.position.0 + dt * s.est.nav.velocity + arm;
        let d: Vector3<f64> = fix.position.0 - at;
        let mut h = SMatrix::<f64, 3, 15>::zeros();
        h.fixed_view_mut::<3, 3>(0, idx::POS)
            .copy_from(&nalgebra::Matrix3::identity());
        h.fixed_view_mut::<3, 3>(0, idx::ATT)
            .copy_from(&(-skew(&arm)));
        let cov = h * s.cov * h.transpose() + fix.cov;
        if let Some(inv) = cov.try_inverse() {
            sum += (d.transpose() * inv * d)[(0, 0)] / 3.0;
            n += 1;
        }
    }
    (n > 0).then(|| TrialCheck {
        gaps: gaps.len(),
        length,
        fixes: n,
        ratio: sum / n as f64,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(s: f64) -> Epoch {
        Epoch::from_gregorian_utc_at_midnight(2026, 6, 1) + Duration::from_seconds(s)
    }

    #[test]
    fn trial_gaps_are_as_long_as_the_real_ones_and_fall_where_the_fixes_are_continuous() {
        // Fixes every second for 200 s with real gaps 40–55 and 100–115.
        let times: Vec<Epoch> = (0..=200)
            .map(f64::from)
            .filter(|s| !(41.0..55.0).contains(s) && !(101.0..115.0).contains(s))
            .map(at)
            .collect();
        let (length, gaps) = trial_gaps(&times);
        assert_eq!(length, 15.0);
        // Slots of 15 + 2·3.75 s: one in 0–40, two in 55–100, three in 115–200.
        assert_eq!(gaps.len(), 6, "{gaps:?}");
        for (a, b) in &gaps {
            assert_eq!((*b - *a).to_seconds(), 15.0);
            let held: Vec<_> = times.iter().filter(|t| *t > a && *t < b).collect();
            assert!((14..=15).contains(&held.len()), "{a} {b}");
            let s = (*a - at(0.0)).to_seconds();
            assert!(
                (3.75..=25.0).contains(&s)
                    || (58.75..=81.25).contains(&s)
                    || (118.75..=181.25).contains(&s),
                "{s}"
            );
        }
        // No real gap: nothing to try.
        let even: Vec<Epoch> = (0..100).map(|s| at(f64::from(s))).collect();
        assert!(trial_gaps(&even).1.is_empty());
    }
}
