//! The inputs of the passes, prepared once per run: each receiver's measurements of the
//! processed systems, the base epoch of each rover epoch, the rover's start values from its
//! code solutions, and each receiver's arc breaks; with the warnings the input checks
//! ([`super::checks`]) owe.
//!
//! What enters: the two observation files, the orbits and the options. What leaves:
//! [`PassInputs`], which every pass reads and none changes; errors when no rover epoch pairs
//! with a base epoch.

use super::geometry::{ReceiverEpoch, SatView};
use super::obs::{extract, SatMeas, SignalPlan};
use super::options::PpkOptions;
use super::{checks, repair, slip};
use crate::error::{Error, Result};
use crate::frame::Ecef;
use crate::orbit::Orbits;
use crate::rinex::{ObsEpoch, ObsFile, ObsHeader};
use crate::spp::{self, SppOptions};
use hifitime::Epoch;

/// Everything a pass reads, per rover epoch. It holds no reference to the observation
/// files, so a caller done with their records may release them before the passes.
pub(super) struct PassInputs {
    /// The rover file's header.
    pub(super) rover_header: crate::rinex::ObsHeader,
    /// Time tag of each rover epoch.
    pub(super) rover_times: Vec<Epoch>,
    /// Time tag of each base epoch.
    pub(super) base_times: Vec<Epoch>,
    pub(super) rover_meas: Vec<Vec<SatMeas>>,
    pub(super) base_meas: Vec<Vec<SatMeas>>,
    /// Base epoch of each rover epoch.
    pub(super) matched: Vec<Option<usize>>,
    /// Start position and clock offset of each rover epoch.
    pub(super) starts: Vec<std::result::Result<(Ecef, f64), String>>,
    /// Arc breaks of the rover's phase, per rover epoch.
    pub(super) rover_breaks: Vec<slip::Slips>,
    /// Arc breaks of the base's phase, per base epoch.
    pub(super) base_breaks: Vec<slip::Slips>,
    /// Whether the rover stood still since the epoch before (see `ppk::still`), per rover
    /// epoch.
    pub(super) still: Vec<bool>,
    /// The rover's and the base's code noise measured on their data (`ppk::codenoise`).
    pub(super) code_noise: [Option<super::codenoise::CodeNoise>; 2],
    /// Each rover satellite's view, aligned with `rover_meas`.
    pub(super) rover_views: Vec<Vec<Option<SatView>>>,
    /// Each base satellite's view, aligned with `base_meas`.
    pub(super) base_views: Vec<Vec<Option<SatView>>>,
    /// For each base epoch (the real ones, then those interpolated into the log's gaps), the
    /// real epoch whose slips it carries, and its effective age (see `ppk::interp`).
    pub(super) base_interp: super::interp::Interpolated,
    /// What mending did to the rover's and the base's phases.
    pub(super) mended: [repair::Mended; 2],
}

impl PassInputs {
    /// Rover epoch `i` as the filter reads it.
    pub(super) fn rover_epoch(&self, i: usize) -> ReceiverEpoch<'_> {
        ReceiverEpoch {
            time: self.rover_times[i],
            meas: &self.rover_meas[i],
            views: &self.rover_views[i],
            age: 0.0,
        }
    }

    /// Release the measurements, views and arc breaks once the passes are done; the times,
    /// pairing and start values stay.
    pub(super) fn release_measurements(&mut self) {
        self.rover_meas = Vec::new();
        self.base_meas = Vec::new();
        self.rover_views = Vec::new();
        self.base_views = Vec::new();
        self.rover_breaks = Vec::new();
        self.base_breaks = Vec::new();
    }

    /// Base epoch `j` as the filter reads it.
    pub(super) fn base_epoch(&self, j: usize) -> ReceiverEpoch<'_> {
        ReceiverEpoch {
            time: self.base_times[j],
            meas: &self.base_meas[j],
            views: &self.base_views[j],
            age: self.base_interp.age[j],
        }
    }

    /// The real base epoch whose slips base epoch `j` carries.
    pub(super) fn base_slip_index(&self, j: usize) -> usize {
        self.base_interp.slip_index[j]
    }
}

/// A receiver's observation records as [`prepare`] takes them: borrowed from a file that
/// keeps them, or handed over, so that each chunk is released as soon as what the passes
/// read is drawn from it (the records never sit beside the measurements in memory).
pub(super) enum Records<'a> {
    /// Records the caller keeps.
    Borrowed(&'a [ObsEpoch]),
    /// Records released chunk by chunk.
    Owned(Vec<ObsEpoch>),
}

impl Records<'_> {
    /// The records.
    pub(super) fn as_slice(&self) -> &[ObsEpoch] {
        match self {
            Records::Borrowed(r) => r,
            Records::Owned(r) => r,
        }
    }

    /// The records' time tags.
    fn times(&self) -> Vec<Epoch> {
        self.as_slice().iter().map(|e| e.time).collect()
    }
}

/// Start position and receiver clock offset (s) of a rover epoch, or why there is none.
type Start = std::result::Result<(Ecef, f64), String>;

/// What the passes read of one receiver's records: measurements of the processed systems,
/// the satellites' views, and (rover only) the start values; aligned with the records.
#[derive(Default)]
struct Drawn {
    meas: Vec<Vec<SatMeas>>,
    views: Vec<Vec<Option<SatView>>>,
    starts: Vec<Start>,
}

/// Draw from `records` in chunks of [`START_CHUNK`] epochs solved in parallel (each chunk's
/// start values from the header's position on, so the same whatever the number of
/// threads); owned records are released chunk by chunk.
fn draw(
    records: Records<'_>,
    h: &ObsHeader,
    orbits: &Orbits,
    opts: &PpkOptions,
    with_starts: bool,
) -> Drawn {
    use rayon::prelude::*;
    let plan = SignalPlan::new(h);
    let sopts = with_starts.then(|| SppOptions {
        elev_mask: opts.elev_mask,
        systems: opts.systems.clone(),
        ..SppOptions::default()
    });
    let chunk = |c: &[ObsEpoch]| draw_chunk(c, h, &plan, orbits, opts, sopts.as_ref());
    let parts: Vec<Drawn> = match records {
        Records::Borrowed(r) => r.par_chunks(START_CHUNK).map(chunk).collect(),
        Records::Owned(r) => {
            let mut rest = r.into_iter();
            let chunks: Vec<Vec<ObsEpoch>> = std::iter::from_fn(|| {
                let c: Vec<ObsEpoch> = rest.by_ref().take(START_CHUNK).collect();
                (!c.is_empty()).then_some(c)
            })
            .collect();
            // Each chunk is dropped as soon as it is drawn, and its pages handed back: the
            // allocator would keep them for the reading thread, not for the drawing ones.
            chunks
                .into_par_iter()
                .map(|c| {
                    let d = chunk(&c);
                    drop(c);
                    crate::memory::release_freed();
                    d
                })
                .collect()
        }
    };
    let mut all = Drawn::default();
    for p in parts {
        all.meas.extend(p.meas);
        all.views.extend(p.views);
        all.starts.extend(p.starts);
    }
    all
}

/// [`draw`] of one chunk, on one thread.
fn draw_chunk(
    chunk: &[ObsEpoch],
    h: &ObsHeader,
    plan: &SignalPlan,
    orbits: &Orbits,
    opts: &PpkOptions,
    sopts: Option<&SppOptions>,
) -> Drawn {
    let meas: Vec<Vec<SatMeas>> = chunk
        .iter()
        .map(|e| extract(e, h, plan, &opts.systems, opts.nf, &orbits.broadcast))
        .collect();
    let views = chunk
        .iter()
        .zip(&meas)
        .map(|(e, m)| m.iter().map(|s| SatView::at(orbits, s, e.time)).collect())
        .collect();
    let starts = sopts.map_or_else(Vec::new, |s| start_values(chunk, h, orbits, s));
    Drawn {
        meas,
        views,
        starts,
    }
}

/// Everything a pass reads: measurements (with each one's C/N0 drop below its receiver's
/// normal, `ppk::snr`; the base at `base_at`), base pairing (base epochs without phase of the
/// processed systems skipped), start values and arc breaks (each receiver's Doppler in the
/// slip test only when it follows its phase); what was skipped, ignored or left without a
/// base goes to `warnings`. An error when no rover epoch pairs with a base epoch.
pub(super) fn prepare(
    (rover, rover_records): (&ObsFile, Records<'_>),
    (base, base_records): (&ObsFile, Records<'_>),
    orbits: &Orbits,
    opts: &PpkOptions,
    base_at: &Ecef,
    warnings: &mut Vec<String>,
) -> Result<PassInputs> {
    let (rover_times, base_times) = (rover_records.times(), base_records.times());
    let (rover_drawn, base_drawn) = rayon::join(
        || draw(rover_records, &rover.header, orbits, opts, true),
        || draw(base_records, &base.header, orbits, opts, false),
    );
    let (mut rover_meas, mut base_meas) = (rover_drawn.meas, base_drawn.meas);
    let starts = &rover_drawn.starts;
    let rover_at = |i: usize| starts.get(i).and_then(|s| s.as_ref().ok()).map(|s| s.0);
    let mended = mark_and_mend(
        (&rover_times, &mut rover_meas, &rover_drawn.views, &rover_at),
        (&base_times, &mut base_meas, &base_drawn.views, &|_| {
            Some(*base_at)
        }),
    );
    let usable: Vec<bool> = base_meas.iter().map(|m| !m.is_empty()).collect();
    let pairing = checks::pair_base_epochs(&rover_times, &base_times, &usable, opts.max_age);
    let systems: Vec<String> = opts
        .systems
        .iter()
        .map(|s| s.letter().to_string())
        .collect();
    require_pairs(
        rover,
        base,
        &usable,
        &pairing.matched,
        opts,
        &systems.join(" "),
    )?;
    warnings.extend(checks::skipped_base_warning(&pairing, &systems.join(" ")));
    let base_gap = opts.max_gap.max(3.0 * opts.max_age);
    let (rover_breaks, base_breaks) = arc_breaks_of(
        (
            rover,
            &rover_times,
            &rover_meas,
            (&rover_drawn.views, &rover_drawn.starts),
        ),
        (base, &base_times, &base_meas, &base_drawn.views),
        base_at,
        (opts.max_gap, base_gap),
        warnings,
    );
    let code_noise = [
        learn_code_noise(&rover_times, &mut rover_meas, &rover_breaks),
        learn_code_noise(&base_times, &mut base_meas, &base_breaks),
    ];
    let still = if opts.use_stillness {
        super::still::stood_still(
            &rover_times,
            &rover_meas,
            &rover_drawn.views,
            &rover_drawn.starts,
            &rover_breaks,
        )
    } else {
        vec![false; rover_times.len()]
    };
    let lonely = checks::without_common(&rover_meas, &base_meas, &pairing.matched);
    let stretches = checks::lonely_stretches(&rover_times, &lonely);
    warnings.extend(checks::lonely_warnings(&stretches));
    let mut matched = pairing.matched;
    let (mut base_times, mut base_views) = (base_times, base_drawn.views);
    let base_interval = crate::time::median_spacing(base_times.iter().copied());
    let base_interp = super::interp::interpolate_gaps(
        &rover_times,
        &mut matched,
        super::interp::BaseEpochs {
            times: &mut base_times,
            meas: &mut base_meas,
            views: &mut base_views,
        },
        &usable,
        &base_breaks,
        base_at,
        orbits,
        (
            1.5 * base_interval,
            if opts.interpolate_base {
                2.0 * opts.max_age
            } else {
                0.0
            },
        ),
    );
    if base_interp.count > 0 {
        warnings.push(format!(
            "{} rover epochs fall in gaps of the base's log: their base epochs are interpolated between the base epochs around them (up to {:.0} s apart)",
            base_interp.count,
            2.0 * opts.max_age
        ));
    }
    Ok(PassInputs {
        rover_header: rover.header.clone(),
        rover_times,
        base_times,
        rover_meas,
        base_meas,
        matched,
        starts: rover_drawn.starts,
        rover_breaks,
        base_breaks,
        still,
        code_noise,
        rover_views: rover_drawn.views,
        base_views,
        base_interp,
        mended,
    })
}

/// Longest gap (s) across which a phase back after a loss of lock is joined to its arc.
const MAX_BRIDGE: f64 = 10.0;

/// One receiver's times, measurements, satellite views and approximate position by epoch,
/// for [`mark_and_mend`].
type Mendable<'a> = (
    &'a [Epoch],
    &'a mut [Vec<SatMeas>],
    Views<'a>,
    &'a (dyn Fn(usize) -> Option<Ecef> + Sync),
);

/// Each receiver's C/N0 drops marked (`ppk::snr`), then its phases mended
/// ([`repair::mend`]); the rover and the base at once.
fn mark_and_mend(rover: Mendable<'_>, base: Mendable<'_>) -> [repair::Mended; 2] {
    let one = |(times, meas, views, at): Mendable<'_>| {
        super::snr::mark_drops(meas, views, at);
        repair::mend(times, meas, &ranges_of(views, at), MAX_BRIDGE)
    };
    let (r, b) = rayon::join(|| one(rover), || one(base));
    [r, b]
}

/// Each measurement's range less its satellite's clock, with its line of sight, from the
/// receiver's position at epoch `i` (`at`); None without an orbit or a position.
fn ranges_of(
    views: &[Vec<Option<SatView>>],
    at: &dyn Fn(usize) -> Option<Ecef>,
) -> Vec<Vec<repair::Range>> {
    views
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let p = at(i);
            v.iter()
                .map(|s| {
                    let s = s.as_ref()?;
                    let (r, e) = s.range(&p?.0);
                    Some((r - crate::orbit::C * s.clock, e))
                })
                .collect()
        })
        .collect()
}

/// Each epoch's satellite views.
type Views<'a> = &'a [Vec<Option<SatView>>];

/// One receiver as [`arc_breaks_of`] reads it: its file, times, measurements and `T`.
type Receiver<'a, T> = (&'a ObsFile, &'a [Epoch], &'a [Vec<SatMeas>], T);

/// Error unless some base epoch holds phase of the processed systems (`usable`) and some
/// rover epoch pairs with one (`matched`).
fn require_pairs(
    rover: &ObsFile,
    base: &ObsFile,
    usable: &[bool],
    matched: &[Option<usize>],
    opts: &PpkOptions,
    systems: &str,
) -> Result<()> {
    if !usable.iter().any(|u| *u) {
        return Err(Error::NoData(format!(
            "{}: no epoch holds phase of the processed systems ({systems}) with an orbit: check \
             that --systems names systems the file contains and that the navigation or orbit \
             files cover them",
            base.path.display(),
        )));
    }
    if matched.iter().all(|m| m.is_none()) {
        return Err(Error::NoData(format!(
            "{} and {}: no rover epoch has a base epoch within {} s holding phase of the processed systems ({systems}): the files do not cover a common time",
            rover.path.display(),
            base.path.display(),
            opts.max_age,
        )));
    }
    Ok(())
}

/// Each receiver's arc breaks: its Doppler in the slip test only when it follows its phase
/// (else a warning), the test's common part fitted over the satellites' lines of sight (the
/// rover's from its start positions, the base's from `base_at`); `gaps`: the longest gaps
/// (rover, base) an arc bridges.
fn arc_breaks_of(
    (rover, rover_times, rover_meas, (rover_views, rover_starts)): Receiver<
        '_,
        (Views<'_>, &[Start]),
    >,
    (base, base_times, base_meas, base_views): Receiver<'_, Views<'_>>,
    base_at: &Ecef,
    gaps: (f64, f64),
    warnings: &mut Vec<String>,
) -> (Vec<slip::Slips>, Vec<slip::Slips>) {
    let mut doppler = |f: &ObsFile, t: &[Epoch], m: &[Vec<SatMeas>], gap: f64, role: &str| {
        let ratio = slip::doppler_phase_ratio(t, m, gap);
        let (ok, w) = checks::doppler_verdict(ratio, role, &f.path.display().to_string());
        warnings.extend(w);
        ok
    };
    let rover_doppler = doppler(rover, rover_times, rover_meas, gaps.0, "rover");
    let base_doppler = doppler(base, base_times, base_meas, gaps.1, "base");
    let rover_los = lines_of_sight(rover_views, &|i| {
        rover_starts
            .get(i)
            .and_then(|s| s.as_ref().ok())
            .map(|s| s.0)
    });
    let base_los = lines_of_sight(base_views, &|_| Some(*base_at));
    rayon::join(
        || {
            let los = Some(rover_los.as_slice());
            slip::arc_breaks(rover_times, rover_meas, los, gaps.0, rover_doppler)
        },
        || {
            let los = Some(base_los.as_slice());
            slip::arc_breaks(base_times, base_meas, los, gaps.1, base_doppler)
        },
    )
}

/// A receiver's code noise measured on its data (`ppk::codenoise`), each measurement marked
/// with its code variance; None when too little could be measured.
fn learn_code_noise(
    times: &[Epoch],
    meas: &mut [Vec<SatMeas>],
    breaks: &[slip::Slips],
) -> Option<super::codenoise::CodeNoise> {
    let interval = crate::time::median_spacing(times.iter().copied());
    let noise = super::codenoise::measure(times, meas, breaks, interval);
    if let Some(n) = &noise {
        super::codenoise::mark(meas, n);
    }
    noise
}

/// Each satellite's line of sight (unit vector receiver → satellite, ECEF) per epoch, from the
/// receiver's position at epoch `i` (`at`); None without an orbit or a position.
fn lines_of_sight(
    views: &[Vec<Option<SatView>>],
    at: &dyn Fn(usize) -> Option<Ecef>,
) -> Vec<Vec<Option<nalgebra::Vector3<f64>>>> {
    views
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let p = at(i);
            v.iter().map(|s| Some(s.as_ref()?.range(&p?.0).1)).collect()
        })
        .collect()
}

/// Start position and receiver clock offset (s) of each epoch of a chunk from its code
/// solution, each from the previous one and the first from the header's position, or why
/// there is none. As in RTKLIB, an epoch whose code solution fails (too few satellites,
/// GDOP > 30, inconsistent) gets no carrier-phase solution either: its geometry cannot be
/// trusted.
fn start_values(
    chunk: &[ObsEpoch],
    h: &ObsHeader,
    orbits: &Orbits,
    sopts: &SppOptions,
) -> Vec<Start> {
    let mut prior = h.approx_position;
    chunk
        .iter()
        .map(|e| match spp::solve_epoch(e, h, orbits, sopts, prior) {
            Ok(s) => {
                prior = Some(s.pos);
                let clock = s.clocks.values().next().copied().unwrap_or(0.0) / crate::orbit::C;
                Ok((s.pos, clock))
            }
            Err((why, _)) => Err(why.kind().to_string()),
        })
        .collect()
}

/// Rover epochs per chunk of start values solved on one thread.
const START_CHUNK: usize = 2048;

/// The longest distance of a rover start position from the base antenna, metres, over the
/// start positions that a neighbouring epoch confirms (within 100 m plus 100 m/s of their
/// time difference): a wild code solution alone must not switch the long-baseline models on.
pub(super) fn longest_baseline(
    starts: &[std::result::Result<(Ecef, f64), String>],
    times: &[Epoch],
    base: &Ecef,
) -> f64 {
    let ok: Vec<(Epoch, &Ecef)> = starts
        .iter()
        .zip(times)
        .filter_map(|(s, t)| s.as_ref().ok().map(|(p, _)| (*t, p)))
        .collect();
    let agree = |a: &(Epoch, &Ecef), b: &(Epoch, &Ecef)| {
        (a.1 .0 - b.1 .0).norm() <= 100.0 + 100.0 * (a.0 - b.0).to_seconds().abs()
    };
    (0..ok.len())
        .filter(|&i| {
            (i > 0 && agree(&ok[i], &ok[i - 1])) || (i + 1 < ok.len() && agree(&ok[i], &ok[i + 1]))
        })
        .map(|i| (ok[i].1 .0 - base.0).norm())
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A wild start between two sane ones is not the longest baseline; a confirmed one is.
    #[test]
    fn a_lone_wild_start_does_not_make_the_baseline_long() {
        let t0 = crate::time::from_week_tow(2300, 0.0);
        let t = |s: f64| t0 + hifitime::Duration::from_seconds(s);
        let base = Ecef::new(4_000_000.0, 500_000.0, 4_900_000.0);
        let at = |dx: f64| Ok((Ecef::new(base.0.x + dx, base.0.y, base.0.z), 0.0));
        let starts = vec![
            at(1000.0),
            at(69_000.0),
            at(1001.0),
            Err("no".to_string()),
            at(1002.0),
        ];
        let times = [t(0.0), t(1.0), t(2.0), t(3.0), t(4.0)];
        assert!((longest_baseline(&starts, &times, &base) - 1002.0).abs() < 1e-6);
        let starts = vec![at(1000.0), at(69_000.0), at(69_050.0)];
        assert!((longest_baseline(&starts, &times[..3], &base) - 69_050.0).abs() < 1e-6);
    }
}
