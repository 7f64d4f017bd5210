//! Carrier-phase positioning of a rover against a base of known position, kinematic (a
//! position per epoch) or static (one position over the span): forward, backward and
//! combined passes of a double-difference Kalman filter with integer ambiguity resolution,
//! returning a [`Trajectory`] whose ambiguity segments the filter assigns. On long baselines
//! the ionosphere and the rover's zenith wet delay are estimated and the combined solution
//! is the two-filter smoother's.
//!
//! Modules, each using only the ones before it: `options` (the settings), [`obs`], [`slip`],
//! `checks` (base pairing, the Doppler verdict, warnings of bad inputs), `inputs` (what
//! every pass reads, prepared once), `geometry`, `state` (typed state layout), `dd` (DD
//! groups and their pivot), [`lambda`], `pair` (a satellite seen by both receivers),
//! `measure` (pure DD residuals, innovation gate), `ar` (partial fixing by success rate,
//! ratio test, fix-and-hold: functions on the state), `segment` (ambiguity segments),
//! `output` (what a pass and a run hand out), `smooth` (the backward prior fused into the
//! forward state), `filter` (one pass, epoch by epoch: owns the state, calls `measure`,
//! `smooth` and `ar`), [`combine`] (forward/backward). This module checks the files,
//! chooses the models, runs the passes and assembles the result.

mod ar;
mod checks;
pub mod codenoise;
pub mod combine;
pub mod consistency;
mod dd;
pub mod doppler;
mod filter;
pub(crate) mod geometry;
mod inputs;
mod interp;
pub mod lambda;
mod measure;
mod merge;
pub mod obs;
mod options;
mod output;
mod pair;
pub mod refusal;
pub mod repair;
mod segment;
pub mod slip;
mod smooth;
mod snr;
mod state;
mod still;
pub mod tight;
mod update;

pub use measure::GateReason;
pub use options::{
    ArMode, BasePosition, Estimate, FilterMode, Motion, PpkOptions, Reference, DEFAULT_FIXED_SIGMA,
};
pub use output::{
    AmbiguityRates, EpochSol, Models, PassDiagnostics, PassStats, PpkResult, Spread, StaticSolution,
};
pub use refusal::Refusal;
pub use still::STILL_M;

use crate::error::{Error, Result};
use crate::frame::Ecef;
use crate::model::antex::AntennaPcv;
use crate::orbit::Orbits;
use crate::rinex::{ObsEpoch, ObsFile};
use crate::trajectory::{SegmentSource, Trajectory};
use inputs::PassInputs;
use merge::{
    ambiguity_rates, arp_offset, diagnostics, merge_passes, output_epochs, OutputEpochs, PassOutput,
};

/// Median spacing of epochs, seconds.
fn interval(epochs: &[ObsEpoch]) -> f64 {
    crate::time::median_spacing(epochs.iter().map(|e| e.time))
}

/// Error unless the file holds carrier-phase observations.
pub fn require_phase(f: &ObsFile, role: &str) -> Result<()> {
    require_phase_in(f, &f.epochs, role)
}

/// [`require_phase`] of the file's records `epochs`, which may have been taken out of it.
fn require_phase_in(f: &ObsFile, epochs: &[ObsEpoch], role: &str) -> Result<()> {
    let any = epochs.iter().take(100).any(|e| {
        e.sats.iter().any(|s| {
            f.header
                .types_of(s.sv.sys)
                .iter()
                .zip(&s.obs)
                .any(|(c, o)| c.kind() == b'L' && o.is_present())
        })
    });
    if any {
        Ok(())
    } else {
        Err(Error::input(
            &f.path,
            format!("the {role} file has no carrier-phase observations: PPK needs phase (`ppkat spp` works with code only)"),
        ))
    }
}

/// The base marker position: given, or the header's (with a loud warning).
fn base_marker(base: &ObsFile, base_pos: BasePosition, warnings: &mut Vec<String>) -> Result<Ecef> {
    match base_pos {
        BasePosition::Given(p) => Ok(p),
        BasePosition::Header => {
            let p = base.header.approx_position.ok_or_else(|| {
                Error::input(&base.path, "no base position: give --base-pos X,Y,Z or --base-llh LAT,LON,H (the header has none either)")
            })?;
            warnings.push(format!(
                "BASE POSITION TAKEN FROM THE HEADER of {} ({:.3} {:.3} {:.3}; of a raw log, its RTCM 1005/1006 station message): its error goes straight into every rover position; give --base-pos or --base-llh",
                base.path.display(),
                p.0.x,
                p.0.y,
                p.0.z
            ));
            Ok(p)
        }
    }
}

/// Rover and base antenna calibrations from the ANTEX file of the options, looked up by the
/// headers' antenna types; what is missing or replaced is told in `warnings`.
fn antenna_calibrations(
    opts: &PpkOptions,
    rover: &ObsFile,
    base: &ObsFile,
    warnings: &mut Vec<String>,
) -> (Option<AntennaPcv>, Option<AntennaPcv>) {
    let Some(atx) = &opts.antex else {
        return (None, None);
    };
    let mut pick =
        |f: &ObsFile, role: &str| atx.calibration(&f.header.antenna, role, warnings).cloned();
    (pick(rover, "rover"), pick(base, "base"))
}

/// The sigma (horizontal, vertical) of the phase-centre error between rover and base
/// antennas: zero for one antenna type at both ends or both calibrated, else
/// `uncalibrated_antenna_sigma` (with a warning naming the two types).
fn antenna_model_error(
    opts: &PpkOptions,
    rover: &ObsFile,
    base: &ObsFile,
    calibrated: &(Option<AntennaPcv>, Option<AntennaPcv>),
    warnings: &mut Vec<String>,
) -> (f64, f64) {
    let norm = |s: &str| s.split_whitespace().collect::<Vec<_>>().join(" ");
    let (r, b) = (norm(&rover.header.antenna), norm(&base.header.antenna));
    if r == b || (calibrated.0.is_some() && calibrated.1.is_some()) {
        return (0.0, 0.0);
    }
    let s = opts.uncalibrated_antenna_sigma;
    warnings.push(format!(
        "rover antenna '{r}' and base antenna '{b}' differ and are not both calibrated: their phase centres may put positions centimetres off (sigmas include {:.0} mm horizontal, {:.0} mm vertical); give --antex",
        s.0 * 1000.0,
        s.1 * 1000.0
    ));
    s
}

/// Settle the `Auto` atmospheric models for a run whose longest baseline is `longest`
/// metres; what is estimated.
fn choose_models(opts: &mut PpkOptions, longest: f64) -> Models {
    let iono = opts.iono.resolve(longest, opts.long_baseline);
    let tropo = opts.tropo.resolve(longest, opts.long_baseline);
    let on = |b: bool| if b { Estimate::On } else { Estimate::Off };
    opts.iono = on(iono);
    opts.tropo = on(tropo);
    Models {
        longest_baseline: longest,
        iono,
        tropo,
        glonass_float: false,
        code_biases: opts.code_bias_slots.clone(),
        still: (0, 0),
        code_noise: [None, None],
        mended: Default::default(),
    }
}

/// The union of the breaks at `range` of a table.
fn breaks_in(table: &[slip::Slips], range: std::ops::Range<usize>) -> slip::Slips {
    let mut out = slip::Slips::new();
    for b in &table[range] {
        for (sv, causes) in b {
            let e = out.entry(*sv).or_insert([None; obs::NF]);
            for (a, c) in e.iter_mut().zip(causes) {
                *a = a.or(*c);
            }
        }
    }
    out
}

/// The breaks a step from epoch `prev` to epoch `now` crosses (indices of one receiver's
/// epochs; a break at k lies between k and the epoch before it): (prev, now] forward,
/// (now, prev] backward, none at the first step.
fn crossed(table: &[slip::Slips], prev: Option<usize>, now: usize) -> slip::Slips {
    match prev {
        Some(p) if p < now => breaks_in(table, p + 1..now + 1),
        Some(p) if p > now => breaks_in(table, now + 1..p + 1),
        _ => slip::Slips::new(),
    }
}

/// One pass of the filter over every rover epoch (forward or backward in time). With
/// `priors` (the backward pass's, by rover epoch) each solution is the smoother's.
fn run_pass(
    inputs: &PassInputs,
    mut f: filter::Filter,
    backward: bool,
    priors: Option<&[Option<smooth::Prior>]>,
    progress: &dyn crate::progress::Progress,
) -> PassOutput {
    let n = inputs.rover_times.len();
    let mut out = PassOutput {
        sols: vec![None; n],
        stats: PassStats::default(),
        priors: Vec::new(),
        resets: Vec::new(),
    };
    let order: Box<dyn Iterator<Item = usize>> = if backward {
        Box::new((0..n).rev())
    } else {
        Box::new(0..n)
    };
    let (mut prev_i, mut prev_j) = (None, None);
    for (count, i) in order.enumerate() {
        if count % 500 == 0 {
            progress.inc(500.min(n - count) as u64);
        }
        let (Some(j), Ok((start, _))) = (inputs.matched[i], &inputs.starts[i]) else {
            continue;
        };
        // An interpolated base epoch carries the slips of the real one before its gap.
        let js = inputs.base_slip_index(j);
        let slips = filter::StepSlips {
            rover: crossed(&inputs.rover_breaks, prev_i, i),
            base: crossed(&inputs.base_breaks, prev_j, js),
        };
        // Still over the step when still at every epoch change it crosses.
        let still = prev_i.is_some_and(|p: usize| {
            let (a, b) = (p.min(i), p.max(i));
            (a + 1..=b).all(|k| inputs.still[k])
        });
        (prev_i, prev_j) = (Some(i), Some(js));
        let resets_before = f.stats.resets();
        out.sols[i] = f.step(
            inputs.rover_epoch(i),
            inputs.base_epoch(j),
            (*start, still),
            &slips,
            priors.and_then(|p| p[i].as_ref()),
        );
        if let Some(p) = f.take_prior() {
            out.priors.resize_with(n, || None);
            out.priors[i] = Some(p);
        }
        let reset = f.stats.resets().saturating_sub(resets_before);
        if reset > 0 {
            out.resets.push((i, reset.min(u32::MAX as usize) as u32));
        }
    }
    out.stats = f.stats;
    out
}

/// The warning of a kinematic run with integer resolution in one pass only on a long baseline
/// (the ionosphere estimated): its fixes are held without the smoother's check against both
/// halves of the data (BELL–EBRE, 115 km: 109 fixed epochs beyond 10 cm forward, 162
/// backward, against 17 combined).
fn single_pass_warning(opts: &PpkOptions, models: &Models) -> Option<String> {
    (models.iono
        && opts.filter != FilterMode::Combined
        && opts.motion == Motion::Kinematic
        && opts.ar != ArMode::Off)
        .then(|| {
            format!(
                "one filter pass on a {:.0} km baseline: its fixes are held unchecked by the data on the other side of each epoch and may be wrong by decimetres; --filter combined checks them",
                models.longest_baseline / 1000.0
            )
        })
}

/// Memory the backward pass's recorded states may take for the two-filter smoother; beyond
/// it the passes are combined epoch by epoch instead.
const SMOOTHER_BUDGET: usize = 1 << 30;

/// Memory the smoother would need: every rover epoch's state (position excluded) with its
/// covariance, at the largest state the data allow.
fn smoother_bytes(inputs: &PassInputs, opts: &PpkOptions) -> usize {
    let sats = inputs.rover_meas.iter().map(Vec::len).max().unwrap_or(0);
    let per_sat =
        opts.nf + usize::from(opts.iono == Estimate::On) + opts.code_bias_slots.len().min(opts.nf);
    let n = 1 + sats * per_sat;
    inputs.rover_meas.len() * (n * n + 2 * n) * 8
}

/// Run the carrier-phase engine: forward, backward or both passes of the filter over the
/// rover epochs matched to base epochs, combined (static runs: forward only, one position);
/// the trajectory of the rover's ARP or marker (`opts.refer`) at the true reception times,
/// with the filter's ambiguity segments.
pub fn process(
    rover: &ObsFile,
    base: &ObsFile,
    base_pos: BasePosition,
    orbits: &Orbits,
    opts: &PpkOptions,
    progress: &dyn crate::progress::Progress,
) -> Result<PpkResult> {
    let records = (
        inputs::Records::Borrowed(&rover.epochs),
        inputs::Records::Borrowed(&base.epochs),
    );
    let prepared = prepare_run(rover, base, records, base_pos, orbits, opts)?;
    Ok(run_prepared(prepared, progress))
}

/// [`process`], releasing the files' observation records as the passes' inputs are drawn
/// from them, chunk by chunk: the passes read only those, so the records (the largest part
/// of the input) never sit beside them in memory. The files keep their headers and events;
/// their records are gone, also when this fails.
pub fn process_releasing(
    rover: &mut ObsFile,
    base: &mut ObsFile,
    base_pos: BasePosition,
    orbits: &Orbits,
    opts: &PpkOptions,
    progress: &dyn crate::progress::Progress,
) -> Result<PpkResult> {
    let records = (
        inputs::Records::Owned(std::mem::take(&mut rover.epochs)),
        inputs::Records::Owned(std::mem::take(&mut base.epochs)),
    );
    let prepared = prepare_run(rover, base, records, base_pos, orbits, opts);
    // What the preparation freed besides the chunks (the records' own list among it) leaves
    // the process before the passes.
    crate::memory::release_freed();
    Ok(run_prepared(prepared?, progress))
}

/// What a run has settled before its passes.
struct Prepared {
    inputs: inputs::PassInputs,
    opts: PpkOptions,
    warnings: Vec<String>,
    base_marker: Ecef,
    base_arp: Ecef,
    antennas: (Option<AntennaPcv>, Option<AntennaPcv>),
    antenna_sigma: (f64, f64),
    models: Models,
    segment_gap: f64,
}

/// The checks, the models and the passes' inputs of a run, drawn from `records` (the
/// files' own, borrowed or taken out of them).
fn prepare_run(
    rover: &ObsFile,
    base: &ObsFile,
    records: (inputs::Records<'_>, inputs::Records<'_>),
    base_pos: BasePosition,
    orbits: &Orbits,
    opts: &PpkOptions,
) -> Result<Prepared> {
    require_phase_in(rover, records.0.as_slice(), "rover")?;
    require_phase_in(base, records.1.as_slice(), "base")?;
    let interval = interval(records.0.as_slice());
    let mut warnings = Vec::new();
    let base_marker = base_marker(base, base_pos, &mut warnings)?;
    let base_arp = Ecef(base_marker.0 + arp_offset(&base.header, &base_marker));
    let antennas = antenna_calibrations(opts, rover, base, &mut warnings);
    let antenna_sigma = antenna_model_error(opts, rover, base, &antennas, &mut warnings);
    let mut opts = opts.clone();
    if opts.motion == Motion::Static {
        // One position accumulated over the span: the last epoch has seen all the data.
        opts.filter = FilterMode::Forward;
    }
    if opts.max_gap <= 0.0 {
        opts.max_gap = (5.0 * interval).max(5.0);
    }
    if opts.interval_s <= 0.0 {
        opts.interval_s = interval;
    }
    let mixed = checks::mixed_signals(
        &rover.header,
        &base.header,
        &opts.systems,
        opts.nf,
        &mut warnings,
    );
    opts.float_slots.extend(mixed.misaligned);
    opts.code_bias_slots.extend(mixed.mismatched_codes);
    let inputs = inputs::prepare(
        (rover, records.0),
        (base, records.1),
        orbits,
        &opts,
        &base_arp,
        &mut warnings,
    )?;
    // Only epochs paired with a base epoch count: a cold start's wild code solutions where
    // the base has no phase would otherwise switch the long-baseline models on.
    let starts: Vec<_> = (inputs.starts.iter().zip(&inputs.matched))
        .map(|(s, m)| match (s, m) {
            (Ok(s), Some(_)) => Ok(*s),
            _ => Err(String::new()),
        })
        .collect();
    let longest = inputs::longest_baseline(&starts, &inputs.rover_times, &base_arp);
    let mut models = choose_models(&mut opts, longest);
    models.glonass_float = inputs.rover_meas.iter().any(|m| {
        m.iter()
            .any(|s| s.sv.sys == crate::sv::Constellation::Glonass)
    });
    warnings.extend(checks::baseline_warning(longest));
    if opts.motion == Motion::Kinematic {
        models.still = still::stretches(&inputs.still);
    }
    models.code_noise = inputs.code_noise.clone();
    models.mended = inputs.mended;
    // A step longer than 2.5 nominal intervals between solved epochs starts a new segment.
    let segment_gap = 2.5 * interval;
    Ok(Prepared {
        inputs,
        opts,
        warnings,
        base_marker,
        base_arp,
        antennas,
        antenna_sigma,
        models,
        segment_gap,
    })
}

/// The passes of a prepared run and their output.
fn run_prepared(p: Prepared, progress: &dyn crate::progress::Progress) -> PpkResult {
    let Prepared {
        mut inputs,
        opts,
        mut warnings,
        base_marker,
        base_arp,
        antennas,
        antenna_sigma,
        models,
        segment_gap,
    } = p;
    let n_rover = inputs.rover_times.len();
    let run = |backward: bool, o: &PpkOptions, priors: Option<&[Option<smooth::Prior>]>| {
        let mut f = filter::Filter::new(o, base_arp, antennas.clone(), segment_gap);
        if backward && priors.is_none() && o.ar == ArMode::Off {
            f.record_priors();
        }
        run_pass(&inputs, f, backward, priors, progress)
    };
    let mut smoothed = false;
    let passes = if opts.filter == FilterMode::Combined {
        2
    } else {
        1
    };
    let stage = match opts.filter {
        FilterMode::Forward => "PPK forward pass",
        FilterMode::Backward => "PPK backward pass",
        FilterMode::Combined => "PPK forward and backward passes",
    };
    progress.set_len(stage, (passes * n_rover) as u64);
    warnings.extend(single_pass_warning(&opts, &models));
    let (fw, bw) = match opts.filter {
        FilterMode::Forward => (Some(run(false, &opts, None)), None),
        FilterMode::Backward => (None, Some(run(true, &opts, None))),
        FilterMode::Combined
            if models.iono && smoother_bytes(&inputs, &opts) <= SMOOTHER_BUDGET =>
        {
            // The backward pass stays float: its estimates enter the smoother, and a held
            // integer there would be counted as data.
            let float = PpkOptions {
                ar: ArMode::Off,
                ..opts.clone()
            };
            let b = run(true, &float, None);
            let smoothing = PpkOptions {
                ratio_threshold: opts.smoothed_ratio_threshold,
                ..opts.clone()
            };
            let f = run(false, &smoothing, Some(&b.priors));
            smoothed = true;
            (Some(f), Some(b))
        }
        FilterMode::Combined if models.iono => {
            warnings.push(format!(
                "the two-filter smoother would need {:.1} GiB: the forward and backward passes are combined epoch by epoch instead",
                smoother_bytes(&inputs, &opts) as f64 / (1u64 << 30) as f64
            ));
            let (a, b) = rayon::join(|| run(false, &opts, None), || run(true, &opts, None));
            (Some(a), Some(b))
        }
        FilterMode::Combined => {
            let (a, b) = rayon::join(|| run(false, &opts, None), || run(true, &opts, None));
            let refused = (opts.ar == ArMode::FixAndHold)
                .then(|| consistency::holds_refused(&a.sols, &b.sols))
                .flatten();
            if let Some(warning) = refused {
                // A held wrong fix makes every float after it claim millimetres: resolve each
                // epoch on its own instead (the combination still checks every fix).
                warnings.push(warning);
                let continuous = PpkOptions {
                    ar: ArMode::Continuous,
                    ..opts.clone()
                };
                progress.set_len(stage, (passes * n_rover) as u64);
                let (a, b) = rayon::join(
                    || run(false, &continuous, None),
                    || run(true, &continuous, None),
                );
                (Some(a), Some(b))
            } else {
                (Some(a), Some(b))
            }
        }
    };
    progress.finish();
    // Only the epochs' times, pairing and start values are read from here on.
    inputs.release_measurements();
    crate::memory::release_freed();
    let diagnostics = diagnostics(fw.as_ref(), bw.as_ref(), &inputs.rover_times);
    let merged = merge_passes(fw.as_ref(), bw.as_ref(), smoothed);
    let keep_stats = |p: Option<PassOutput>| p.map(|p| p.stats);
    let (fw, bw) = (keep_stats(fw), keep_stats(bw));
    let ambiguities = ambiguity_rates(&merged, [&fw, &bw], opts.nf >= 2);
    let OutputEpochs {
        epochs,
        unsolved,
        refusals,
    } = output_epochs(merged, &inputs, &opts, antenna_sigma, &base_arp);
    let static_solution = match (opts.motion, &fw) {
        (Motion::Static, Some(fw)) => StaticSolution::of(&epochs, fw),
        _ => None,
    };
    PpkResult {
        ambiguities,
        static_solution,
        trajectory: Trajectory::new(epochs, SegmentSource::Filter),
        forward: fw,
        backward: bw,
        unsolved,
        refusals,
        rover_epochs: n_rover,
        base_marker,
        models,
        warnings,
        diagnostics,
    }
}
