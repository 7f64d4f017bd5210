//! Input habits of the carrier-phase engine: which base epoch each rover epoch is paired
//! with, whether a receiver's Doppler may feed the slip test, and the warnings a run owes its
//! user when its inputs are beyond what it models (a very long baseline, rover epochs with
//! nothing to difference against).
//!
//! What enters: epoch times (GPST), the per-epoch measurements of [`super::obs`], the ratio
//! measured by [`super::slip::doppler_phase_ratio`], the longest baseline (metres). What
//! leaves: the pairing, with what it skipped, and warning sentences; nothing here changes a
//! measurement.

use super::slip::DopplerRatio;
use crate::time::format_ymdhms;
use hifitime::Epoch;

/// The base epoch of each rover epoch, and the base epochs the pairing could not use.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BasePairing {
    /// Base epoch (index) of each rover epoch, None when none usable lies within `max_age`.
    pub matched: Vec<Option<usize>>,
    /// Base epochs skipped: they hold no phase of the processed systems.
    pub skipped: usize,
    /// First and last time of those epochs.
    pub skipped_span: Option<(Epoch, Epoch)>,
}

/// The usable base epoch (`usable[j]`) nearest each rover time, within `max_age` seconds;
/// the unusable ones are skipped and counted. `base` is in time order.
pub fn pair_base_epochs(
    rover: &[Epoch],
    base: &[Epoch],
    usable: &[bool],
    max_age: f64,
) -> BasePairing {
    let ok: Vec<usize> = (0..base.len()).filter(|&j| usable[j]).collect();
    let bt: Vec<Epoch> = ok.iter().map(|&j| base[j]).collect();
    let matched = rover
        .iter()
        .map(|&t| {
            let i = bt.partition_point(|b| *b <= t);
            [i.checked_sub(1), (i < bt.len()).then_some(i)]
                .into_iter()
                .flatten()
                .min_by(|&a, &b| {
                    let da = (bt[a] - t).to_seconds().abs();
                    let db = (bt[b] - t).to_seconds().abs();
                    da.total_cmp(&db)
                })
                .filter(|&k| (bt[k] - t).to_seconds().abs() <= max_age)
                .map(|k| ok[k])
        })
        .collect();
    let mut unusable = (0..base.len()).filter(|&j| !usable[j]).map(|j| base[j]);
    let first = unusable.next();
    let (skipped, last) = unusable.fold((usize::from(first.is_some()), first), |(n, _), t| {
        (n + 1, Some(t))
    });
    BasePairing {
        matched,
        skipped,
        skipped_span: first.zip(last),
    }
}

/// The warning of a pairing that skipped base epochs, naming the processed `systems`.
pub fn skipped_base_warning(p: &BasePairing, systems: &str) -> Option<String> {
    let (a, b) = p.skipped_span?;
    Some(format!(
        "{} base epochs between {} and {} GPST hold no carrier phase of the processed systems ({systems}): rover epochs were paired with the nearest base epoch that does",
        p.skipped,
        format_ymdhms(a),
        format_ymdhms(b)
    ))
}

/// The range of [`DopplerRatio::median`] within which a receiver's Doppler feeds the slip
/// test.
pub const DOPPLER_RATIO_RANGE: std::ops::RangeInclusive<f64> = 0.9..=1.1;

/// Whether a receiver's Doppler may feed the slip test (no measured ratio: it has none to
/// feed), and the warning when not.
pub fn doppler_verdict(
    ratio: Option<DopplerRatio>,
    role: &str,
    file: &str,
) -> (bool, Option<String>) {
    match ratio {
        Some(r) if !DOPPLER_RATIO_RANGE.contains(&r.median) => (
            false,
            Some(format!(
                "{role} {file}: integrated Doppler over phase change is {:.3} (median of {} samples; expected 1): Doppler ignored for slip detection",
                r.median, r.samples
            )),
        ),
        _ => (true, None),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hifitime::Duration;

    fn at(s: f64) -> Epoch {
        crate::time::gpst(2024, 1, 1, 0, 0, 0, 0) + Duration::from_seconds(s)
    }

    /// A base of 1 s epochs whose odd epochs hold only another system: each rover epoch goes
    /// to the nearest even one, the odd ones are counted with their span.
    #[test]
    fn pairing_skips_base_epochs_without_processed_phase() {
        let base: Vec<Epoch> = (0..10).map(|k| at(k as f64)).collect();
        let usable: Vec<bool> = (0..10).map(|k| k % 2 == 0).collect();
        let rover: Vec<Epoch> = [0.0, 1.0, 2.9, 7.2, 9.0, 12.0, 20.0]
            .iter()
            .map(|&s| at(s))
            .collect();
        let p = pair_base_epochs(&rover, &base, &usable, 2.5);
        // 1.0 is as near 0 as 2: the earlier wins; 7.2 and 9.0 go to 8; 12.0 is 4 s from 8.
        assert_eq!(
            p.matched,
            vec![Some(0), Some(0), Some(2), Some(8), Some(8), None, None]
        );
        assert_eq!(p.skipped, 5);
        assert_eq!(p.skipped_span, Some((at(1.0), at(9.0))));
        let w = skipped_base_warning(&p, "GPS").unwrap();
        assert!(
            w.starts_with(
                "5 base epochs between 2024/01/01 00:00:01.000 and 2024/01/01 00:00:09.000 GPST"
            ),
            "{w}"
        );
        let all = pair_base_epochs(&rover, &base, &[true; 10], 2.5);
        assert_eq!(all.matched[1], Some(1));
        assert_eq!(all.skipped, 0);
        assert_eq!(skipped_base_warning(&all, "GPS"), None);
    }

    #[test]
    fn doppler_outside_the_range_is_ignored_with_a_warning() {
        let r = |median| {
            Some(DopplerRatio {
                median,
                samples: 300,
            })
        };
        assert_eq!(doppler_verdict(r(1.002), "base", "b.obs"), (true, None));
        assert_eq!(doppler_verdict(None, "base", "b.obs"), (true, None));
        let (use_it, w) = doppler_verdict(r(-0.998), "base", "b.obs");
        assert!(!use_it);
        assert_eq!(
            w.unwrap(),
            "base b.obs: integrated Doppler over phase change is -0.998 (median of 300 samples; expected 1): Doppler ignored for slip detection"
        );
        assert!(!doppler_verdict(r(0.19), "rover", "r.obs").0);
    }
}
