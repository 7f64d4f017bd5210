//! What a carrier-phase run did ([`PpkReport`]) and what `ppkat ppk` prints of it (its
//! `Display`, also the head of the PPK report page): the fix rate, what was estimated, how the
//! ambiguities went, why epochs stayed unsolved, each pass's resets, the static solution and
//! the warnings. `pipeline` makes it and `ppk_report` draws it; it uses neither.

use gnss::ppk::{AmbiguityRates, Models, PassStats, Refusal};
use gnss::time::format_ymdhms;
use hifitime::Epoch;
use std::fmt;
use std::path::PathBuf;

/// What a carrier-phase run did.
#[derive(Clone, Debug)]
pub struct PpkReport {
    /// The carrier-phase result (trajectory, pass counters, unsolved epochs).
    pub result: gnss::ppk::PpkResult,
    /// The `.pos` written.
    pub out: PathBuf,
    /// The static summary written beside it (`OUT.pos.json`; static runs only).
    pub summary: Option<PathBuf>,
    /// The quality report written (HTML), when asked for.
    pub report: Option<PathBuf>,
    /// The point of the rover the positions describe.
    pub refer: gnss::ppk::Reference,
    /// Problems with the inputs and the run.
    pub warnings: Vec<String>,
    /// What the run took from raw logs themselves (ephemerides, GPS week, base position),
    /// for standard error.
    pub notes: Vec<String>,
    /// Wall time, seconds.
    pub seconds: f64,
    /// Of it, reading and checking the inputs, seconds.
    pub read_seconds: f64,
    /// Of it, the carrier-phase engine, seconds.
    pub process_seconds: f64,
}

impl fmt::Display for PpkReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.write(f, true)
    }
}

/// A [`PpkReport`] shown without its wall time, for files that must be the same bytes on
/// every run (the HTML report).
pub struct Untimed<'a>(pub &'a PpkReport);

impl fmt::Display for Untimed<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.write(f, false)
    }
}

impl PpkReport {
    /// The summary, with the wall time when `timed`.
    fn write(&self, f: &mut fmt::Formatter<'_>, timed: bool) -> fmt::Result {
        let r = &self.result;
        let solved = r.trajectory.epochs.len();
        let took = if timed {
            format!(" in {:.2} s", self.seconds)
        } else {
            String::new()
        };
        writeln!(
            f,
            "ppk: {} rover epochs, {} solved, {} fixed ({:.1} % of solved){took} → {}",
            r.rover_epochs,
            solved,
            r.fixed(),
            100.0 * r.fixed() as f64 / solved.max(1) as f64,
            self.out.display()
        )?;
        writeln!(f, "  {}", models_line(&r.models))?;
        if let Some(l) = still_line(&r.models, r.rover_epochs) {
            writeln!(f, "  {l}")?;
        }
        if let Some(l) = code_noise_line(&r.models) {
            writeln!(f, "  {l}")?;
        }
        if let Some(l) = mended_line(&r.models) {
            writeln!(f, "  {l}")?;
        }
        if let Some(l) = ambiguities_line(&r.ambiguities) {
            writeln!(f, "  {l}")?;
        }
        if let Some(l) = refusals_line(&r.refusals) {
            writeln!(f, "  {l}")?;
        }
        let mut reasons: std::collections::BTreeMap<&str, (usize, Epoch)> = Default::default();
        for (t, why) in &r.unsolved {
            reasons.entry(why.as_str()).or_insert((0, *t)).0 += 1;
        }
        for (why, (n, first)) in reasons {
            writeln!(
                f,
                "  {n} epochs unsolved: {why} (first at {})",
                format_ymdhms(first)
            )?;
        }
        for (name, s) in [("forward", &r.forward), ("backward", &r.backward)] {
            if let Some(s) = s {
                writeln!(f, "  {}", pass_line(name, s))?;
            }
        }
        if let Some(st) = &r.static_solution {
            for l in crate::survey::lines(st, self.refer) {
                writeln!(f, "  {l}")?;
            }
            if let Some(p) = &self.summary {
                writeln!(f, "  summary → {}", p.display())?;
            }
        }
        if let Some(p) = &self.report {
            writeln!(f, "  report → {}", p.display())?;
        }
        for w in self.warnings.iter().take(20) {
            writeln!(f, "  warning: {w}")?;
        }
        Ok(())
    }
}

/// The code noise measured on each receiver's own data: σ per C/N0 class and what one
/// epoch is worth among its correlated neighbours.
fn code_noise_line(m: &Models) -> Option<String> {
    let names = ["< 30", "30-35", "35-40", "40-45", ">= 45"];
    let one = |who: &str, n: &gnss::ppk::codenoise::CodeNoise| {
        let classes: Vec<String> = names
            .iter()
            .zip(&n.var)
            .filter(|(_, v)| v.is_finite())
            .map(|(c, v)| format!("{:.2} m at {c}", v.sqrt()))
            .collect();
        format!(
            "{who} {} dB-Hz, an epoch's code worth 1/{:.0} of an independent one",
            classes.join(", "),
            n.inflation
        )
    };
    let parts: Vec<String> = ["rover", "base"]
        .iter()
        .zip(&m.code_noise)
        .filter_map(|(who, n)| Some(one(who, n.as_ref()?)))
        .collect();
    (!parts.is_empty()).then(|| {
        format!(
            "code noise measured (code minus carrier): {}; the code weighted by it where the model says less",
            parts.join("; ")
        )
    })
}

/// What mending did to the phases (slips repaired instead of cutting the arc), per receiver.
fn mended_line(m: &Models) -> Option<String> {
    let parts: Vec<String> = ["rover", "base"]
        .iter()
        .zip(&m.mended)
        .filter(|(_, d)| **d != gnss::ppk::repair::Mended::default())
        .map(|(who, d)| {
            format!(
                "{who} {} jumps mended, {} arcs joined across a loss of lock or gap, {} jumps cut (not a multiple of half a cycle), {} on weak signals left to the slip detectors",
                d.jumps, d.bridged, d.cut, d.left
            )
        })
        .collect();
    (!parts.is_empty()).then(|| {
        format!(
            "phases mended from the satellites' time-differenced fit (a slip of whole or half cycles repaired, its arc kept): {}",
            parts.join("; ")
        )
    })
}

/// How much of the track the rover stood still (the position held from epoch to epoch).
fn still_line(m: &Models, epochs: usize) -> Option<String> {
    let (still, stretches) = m.still;
    (still > 0).then(|| {
        format!(
            "stood still at {still} epochs ({:.1} % of the track, {stretches} stretches): the position held from one epoch to the next there (the carrier phase's displacement within {:.0} mm/s horizontally, {:.0} mm/s vertically)",
            100.0 * still as f64 / epochs.max(1) as f64,
            1e3 * gnss::ppk::STILL_M.0,
            1e3 * gnss::ppk::STILL_M.1
        )
    })
}

/// The longest baseline and what was estimated beside the position and the ambiguities.
fn models_line(m: &Models) -> String {
    let mut estimated: Vec<String> = [
        (m.iono, "slant ionosphere per satellite"),
        (m.tropo, "rover zenith wet delay"),
    ]
    .iter()
    .filter(|(on, _)| *on)
    .map(|(_, what)| what.to_string())
    .collect();
    if !m.code_biases.is_empty() {
        let slots: Vec<String> = m
            .code_biases
            .iter()
            .map(|(sys, slot)| format!("{sys:?} signal {}", slot + 1))
            .collect();
        estimated.push(format!(
            "code biases per satellite ({}: rover and base track different codes)",
            slots.join(", ")
        ));
    }
    format!(
        "longest baseline {:.1} km; estimated: {}{}",
        m.longest_baseline / 1000.0,
        if estimated.is_empty() {
            "no atmospheric delays (a-priori models only)".to_string()
        } else {
            estimated.join(", ")
        },
        if m.glonass_float {
            "; GLONASS ambiguities kept float (the receivers' inter-channel phase biases are not calibrated), its inter-channel code bias estimated"
        } else {
            ""
        }
    )
}

/// How the ambiguities went: wide and narrow lanes (or, with one frequency, the fixed
/// solution) and the arcs held; None when nothing was solved.
fn ambiguities_line(a: &AmbiguityRates) -> Option<String> {
    if a.solved == 0 {
        return None;
    }
    let pct = |k: usize| 100.0 * k as f64 / a.solved as f64;
    let fixed = if a.dual_frequency {
        format!(
            "wide lanes fixed at {:.1} % of solved epochs (3 satellites or more), narrow lanes at {:.1} % (the fixed solution)",
            pct(a.widelane),
            pct(a.narrowlane)
        )
    } else {
        format!("fixed at {:.1} % of solved epochs", pct(a.narrowlane))
    };
    Some(format!(
        "ambiguities: {fixed}; {} ambiguity arcs held",
        a.arcs_held
    ))
}

/// One pass's counters: resets by cause, outliers, the innovation gate, the mask and orbits.
fn pass_line(name: &str, s: &PassStats) -> String {
    let slips: Vec<String> = s.slips.iter().map(|(c, n)| format!("{c:?} {n}")).collect();
    let gated: Vec<String> = s
        .rejected
        .iter()
        .map(|(c, n)| format!("{c:?} {n}"))
        .collect();
    format!(
        "{name}: ambiguity resets {} [{}], post-fit outliers {}{}{}, innovations rejected {} [{}], satellite-epochs below mask {}, without orbit {}{}{}{}",
        s.slips.values().sum::<usize>(),
        slips.join(", "),
        s.outlier_resets,
        if s.code_outliers > 0 {
            format!(", codes left out for their post-fit residual {}", s.code_outliers)
        } else {
            String::new()
        },
        if s.widened > 0 {
            format!(", covariance widened where the code contradicted the state {}", s.widened)
        } else {
            String::new()
        },
        s.rejected_innovations(),
        gated.join(", "),
        s.below_mask,
        s.no_orbit,
        if s.half_cycle_float > 0 {
            format!(", ambiguity-epochs kept float for an unresolved half cycle {}", s.half_cycle_float)
        } else {
            String::new()
        },
        if s.left_out_fixes > 0 {
            format!(", fixes with one satellite left float {}", s.left_out_fixes)
        } else {
            String::new()
        },
        refused_fixes(s)
    )
}

/// The fixes a pass found but did not take, by reason (empty when none).
fn refused_fixes(s: &PassStats) -> String {
    let counts = [
        (s.smoothed_fixes_rejected, "halves disagree"),
        (s.far_from_float_fixes, "far from the float"),
    ];
    let total: usize = counts.iter().map(|(n, _)| n).sum();
    if total == 0 {
        return String::new();
    }
    let reasons: Vec<String> = counts
        .iter()
        .filter(|(n, _)| *n > 0)
        .map(|(n, why)| format!("{why} {n}"))
        .collect();
    format!(", fixes refused {total} [{}]", reasons.join(", "))
}

/// Why the float epochs were not fixed: each check that refused a fix, at how many epochs
/// and over which minutes of the run (its [`LONGEST_SPANS`] longest stretches, epochs less
/// than [`SPAN_GAP_S`] apart joined); None when no fix was refused.
fn refusals_line(refusals: &[(Epoch, Refusal)]) -> Option<String> {
    let t0 = refusals.first()?.0;
    let parts: Vec<String> = Refusal::ALL
        .iter()
        .filter_map(|&why| {
            let times: Vec<f64> = refusals
                .iter()
                .filter(|(_, r)| *r == why)
                .map(|(t, _)| (*t - t0).to_seconds())
                .collect();
            (!times.is_empty()).then(|| {
                let spans: Vec<String> = spans(&times)
                    .iter()
                    .map(|(a, b)| format!("{:.0}–{:.0}", a / 60.0, b / 60.0))
                    .collect();
                format!("{why} {} (min {})", times.len(), spans.join(", "))
            })
        })
        .collect();
    Some(format!(
        "fixes refused at {} float epochs, by the check that refused them (minutes from the first): {}",
        refusals.len(),
        parts.join("; ")
    ))
}

/// Stretches of one refusal further apart than this, seconds, are told apart.
const SPAN_GAP_S: f64 = 30.0;

/// Stretches named per refusal.
const LONGEST_SPANS: usize = 3;

/// The [`LONGEST_SPANS`] longest stretches (start, end) of ascending `times`, in time order.
fn spans(times: &[f64]) -> Vec<(f64, f64)> {
    let mut all: Vec<(f64, f64)> = Vec::new();
    for &t in times {
        match all.last_mut() {
            Some(last) if t - last.1 <= SPAN_GAP_S => last.1 = t,
            _ => all.push((t, t)),
        }
    }
    all.sort_by(|a, b| {
        (b.1 - b.0)
            .total_cmp(&(a.1 - a.0))
            .then(a.0.total_cmp(&b.0))
    });
    all.truncate(LONGEST_SPANS);
    all.sort_by(|a, b| a.0.total_cmp(&b.0));
    all
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each check is counted with its longest stretches in minutes, in time order; one
    /// refusal's epochs further apart than the gap are separate stretches.
    #[test]
    fn the_refusals_are_counted_and_placed_in_time() {
        let t0 = gnss::time::from_week_tow(2300, 0.0);
        let at = |s: f64| t0 + hifitime::Duration::from_seconds(s);
        let mut r: Vec<(Epoch, Refusal)> =
            (0..180).map(|k| (at(k as f64), Refusal::Ratio)).collect();
        r.extend((780..1140).map(|k| (at(k as f64), Refusal::Ratio)));
        r.extend((1200..1210).map(|k| (at(k as f64), Refusal::PassesDisagree)));
        r.extend([(at(1300.0), Refusal::Ratio), (at(1400.0), Refusal::Ratio)]);
        let line = refusals_line(&r).unwrap();
        assert!(
            line.contains("at 552 float epochs")
                && line.contains("ratio test 542 (min 0–3, 13–19, 22–22)")
                && line.contains("passes disagree 10 (min 20–20)"),
            "{line}"
        );
        assert!(refusals_line(&[]).is_none());
        assert_eq!(
            spans(&[0.0, 10.0, 50.0, 51.0, 52.0, 200.0]),
            vec![(0.0, 10.0), (50.0, 52.0), (200.0, 200.0)]
        );
    }
}
