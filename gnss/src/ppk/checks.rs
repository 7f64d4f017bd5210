//! Input habits of the carrier-phase engine: which base epoch each rover epoch is paired
//! with, whether a receiver's Doppler may feed the slip test, and the warnings a run owes its
//! user when its inputs are beyond what it models (a very long baseline, rover epochs with
//! nothing to difference against).
//!
//! What enters: epoch times (GPST), the per-epoch measurements of [`super::obs`], the ratio
//! measured by [`super::slip::doppler_phase_ratio`], the longest baseline (metres). What
//! leaves: the pairing, with what it skipped, and warning sentences; nothing here changes a
//! measurement.

use super::obs::SatMeas;
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

/// Longest baseline (metres) the atmospheric models are meant for.
pub const MAX_MODELLED_BASELINE: f64 = 500_000.0;

/// The warning of a run whose longest baseline (metres) is beyond [`MAX_MODELLED_BASELINE`].
pub fn baseline_warning(longest: f64) -> Option<String> {
    (longest > MAX_MODELLED_BASELINE).then(|| {
        format!(
            "the longest baseline is {:.0} km: the atmospheric models are not meant for baselines beyond {:.0} km; expect float solutions and wrong fixes",
            longest / 1000.0,
            MAX_MODELLED_BASELINE / 1000.0
        )
    })
}

/// Whether each rover epoch has nothing to difference against: no base epoch, or no
/// satellite with phase at both receivers.
pub fn without_common(
    rover_meas: &[Vec<SatMeas>],
    base_meas: &[Vec<SatMeas>],
    matched: &[Option<usize>],
) -> Vec<bool> {
    rover_meas
        .iter()
        .zip(matched)
        .map(|(r, m)| match m {
            Some(j) => !r.iter().any(|s| base_meas[*j].iter().any(|b| b.sv == s.sv)),
            None => true,
        })
        .collect()
}

/// A stretch of rover epochs a warning is owed for: longer than this (seconds) …
pub const LONELY_SPAN: f64 = 60.0;
/// … and of more epochs than this.
pub const LONELY_EPOCHS: usize = 3;

/// The runs of consecutive flagged epochs longer than [`LONELY_SPAN`] (first to last time)
/// and of more than [`LONELY_EPOCHS`] epochs: (first time, last time, epochs).
pub fn lonely_stretches(times: &[Epoch], flagged: &[bool]) -> Vec<(Epoch, Epoch, usize)> {
    let mut out = Vec::new();
    let mut start: Option<usize> = None;
    for i in 0..=times.len().min(flagged.len()) {
        let on = i < times.len() && flagged[i];
        match (on, start) {
            (true, None) => start = Some(i),
            (false, Some(s)) => {
                let n = i - s;
                if n > LONELY_EPOCHS && (times[i - 1] - times[s]).to_seconds() > LONELY_SPAN {
                    out.push((times[s], times[i - 1], n));
                }
                start = None;
            }
            _ => {}
        }
    }
    out
}

/// The warning of each stretch of rover epochs with nothing to difference against.
pub fn lonely_warnings(stretches: &[(Epoch, Epoch, usize)]) -> Vec<String> {
    stretches
        .iter()
        .map(|(a, b, n)| {
            format!(
                "{n} rover epochs from {} to {} GPST have no satellite in common with a base epoch (or no base epoch within the age limit): no carrier-phase solution there",
                format_ymdhms(*a),
                format_ymdhms(*b)
            )
        })
        .collect()
}

/// The slots (system, slot) that rover and base both fill for a system processed (GLONASS
/// aside: its slots differ per satellite), with each file's columns for them.
fn shared_slots(
    rover: &crate::rinex::ObsHeader,
    base: &crate::rinex::ObsHeader,
    systems: &[crate::sv::Constellation],
    nf: usize,
) -> Vec<(crate::sv::Constellation, usize, [super::obs::SlotCols; 2])> {
    use super::obs::SignalPlan;
    let (r, b) = (SignalPlan::new(rover), SignalPlan::new(base));
    let mut out = Vec::new();
    for (sys, rc) in &r.cols {
        let Some(bc) = b.cols.get(sys) else { continue };
        if !systems.contains(sys) || *sys == crate::sv::Constellation::Glonass {
            continue;
        }
        for slot in 0..nf.min(rc.len()) {
            if let (Some(x), Some(y)) = (rc[slot], bc[slot]) {
                out.push((*sys, slot, [x, y]));
            }
        }
    }
    out
}

/// Slots (system, slot) where rover and base take different signals of a band.
#[derive(Clone, Debug, Default, PartialEq)]
pub(super) struct MixedSignals {
    /// Phases of different signals (L2W against L2X, E1C against E1X), which may differ by a
    /// fraction of a cycle, where not both headers declare their phases aligned
    /// (`SYS / PHASE SHIFT`, RINEX 3.01 and later): their ambiguities stay float.
    pub(super) misaligned: Vec<(crate::sv::Constellation, usize)>,
    /// Codes of different signals (C1W against C1C, C2X against C2W): each satellite's code
    /// differs between them by the satellite's own bias (P1−C1: up to a metre), which no
    /// double difference removes; the filter estimates those biases per satellite.
    pub(super) mismatched_codes: Vec<(crate::sv::Constellation, usize)>,
}

/// The slots where rover and base take different signals of a band, with a warning for each.
pub(super) fn mixed_signals(
    rover: &crate::rinex::ObsHeader,
    base: &crate::rinex::ObsHeader,
    systems: &[crate::sv::Constellation],
    nf: usize,
    warnings: &mut Vec<String>,
) -> MixedSignals {
    let code = |h: &crate::rinex::ObsHeader, sys: crate::sv::Constellation, col: Option<usize>| {
        h.obs_types.get(&sys).and_then(|t| t.get(col?)).copied()
    };
    let mut out = MixedSignals::default();
    for (sys, slot, [x, y]) in shared_slots(rover, base, systems, nf) {
        let aligned = rover.phase_aligned.contains(&sys) && base.phase_aligned.contains(&sys);
        if x.phase_code != y.phase_code && !aligned {
            out.misaligned.push((sys, slot));
            warnings.push(format!(
                "{sys:?} phases: the rover's {} and the base's {} may differ by a quarter or half cycle (not both files declare them aligned, SYS / PHASE SHIFT): their ambiguities are kept float",
                x.phase_code, y.phase_code
            ));
        }
        if let (Some(cx), Some(cy)) = (code(rover, sys, x.code), code(base, sys, y.code)) {
            if cx != cy {
                out.mismatched_codes.push((sys, slot));
                warnings.push(format!(
                    "{sys:?} codes: the rover's {cx} and the base's {cy} differ by each satellite's own bias (P1−C1 or the like), which double differences keep: estimated per satellite"
                ));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use hifitime::Duration;

    /// A RINEX 3.04 header with these GPS observation types.
    fn gps_header(types: [&[u8; 3]; 4]) -> crate::rinex::ObsHeader {
        let mut h = crate::rinex::ObsHeader::new(3.04);
        let types = types.map(|c| crate::rinex::ObsCode(*c));
        h.obs_types
            .insert(crate::sv::Constellation::Gps, types.to_vec());
        h
    }

    /// Rover L2X against base L2W: slot 1 of GPS stays float, with a warning, unless both
    /// headers declare their phases aligned; the same signal at both ends is never a concern.
    #[test]
    fn different_signals_of_a_band_stay_float_unless_declared_aligned() {
        use crate::sv::Constellation::Gps;
        let header = |l2: &[u8; 3]| gps_header([b"C1C", b"L1C", b"C2X", l2]);
        let (rover, base) = (header(b"L2X"), header(b"L2W"));
        let mut w = Vec::new();
        assert_eq!(
            mixed_signals(&rover, &base, &[Gps], 2, &mut w).misaligned,
            vec![(Gps, 1)]
        );
        assert!(w[0].contains("L2X") && w[0].contains("L2W"), "{w:?}");
        let (mut r, mut b) = (rover.clone(), base.clone());
        r.phase_aligned.insert(Gps);
        b.phase_aligned.insert(Gps);
        assert_eq!(mixed_signals(&r, &b, &[Gps], 2, &mut w), Default::default());
        assert_eq!(
            mixed_signals(&rover, &rover, &[Gps], 2, &mut w),
            Default::default()
        );
        assert_eq!(w.len(), 1);
    }

    /// A P1 rover against a C1 base: GPS slot 0 gets per-satellite code biases, with a
    /// warning naming both codes; L2 (P2 at both ends) and a file against itself do not.
    #[test]
    fn different_codes_of_a_band_are_named() {
        use crate::sv::Constellation::Gps;
        let header = |c1: &[u8; 3]| gps_header([c1, b"L1C", b"C2W", b"L2W"]);
        let (rover, base) = (header(b"C1W"), header(b"C1C"));
        let mut w = Vec::new();
        assert_eq!(
            mixed_signals(&rover, &base, &[Gps], 2, &mut w).mismatched_codes,
            vec![(Gps, 0)]
        );
        assert!(w[0].contains("C1W") && w[0].contains("C1C"), "{w:?}");
        assert_eq!(
            mixed_signals(&rover, &rover, &[Gps], 2, &mut w),
            Default::default()
        );
        assert_eq!(
            mixed_signals(&rover, &base, &[], 2, &mut w),
            Default::default()
        );
        assert_eq!(w.len(), 1);
    }

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

    #[test]
    fn baselines_beyond_500_km_are_warned_about() {
        assert_eq!(baseline_warning(115_284.0), None);
        assert_eq!(baseline_warning(500_000.0), None);
        let w = baseline_warning(812_400.0).unwrap();
        assert!(w.starts_with("the longest baseline is 812 km"), "{w}");
    }

    /// Runs of 4 epochs over more than 60 s are reported; 3 epochs or 60 s are not; a run at
    /// the end counts.
    #[test]
    fn stretches_without_common_satellites() {
        let times: Vec<Epoch> = (0..20).map(|k| at(30.0 * k as f64)).collect();
        let mut flagged = vec![false; 20];
        for k in [1, 2, 3, 5, 6, 7, 8, 16, 17, 18, 19] {
            flagged[k] = true;
        }
        let s = lonely_stretches(&times, &flagged);
        assert_eq!(
            s,
            vec![(at(150.0), at(240.0), 4), (at(480.0), at(570.0), 4)]
        );
        let w = lonely_warnings(&s);
        assert!(
            w[0].starts_with(
                "4 rover epochs from 2024/01/01 00:02:30.000 to 2024/01/01 00:04:00.000 GPST"
            ),
            "{}",
            w[0]
        );
        // Four epochs at 1 s: 3 s long.
        let fast: Vec<Epoch> = (0..6).map(|k| at(k as f64)).collect();
        assert!(lonely_stretches(&fast, &[true; 6]).is_empty());
        // Two epochs 100 s apart are not more than three epochs.
        assert!(lonely_stretches(&[at(0.0), at(100.0)], &[true, true]).is_empty());
    }
}
