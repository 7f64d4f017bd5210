//! Carrier-phase kinematic positioning of a rover against a base of known position: forward,
//! backward and combined passes of a double-difference Kalman filter with integer ambiguity
//! resolution, returning a [`Trajectory`] whose ambiguity segments the filter assigns.
//!
//! Modules, each using only the ones before it: `options` (the settings), [`obs`], [`slip`],
//! `geometry`, `state` (typed state layout), `dd` (DD groups and their pivot), [`lambda`],
//! `pair` (a satellite seen by both receivers), `measure` (pure DD residuals, innovation
//! gate), `ar` (LAMBDA, partial fixing, fix-and-hold: functions on the state), `segment`
//! (ambiguity segments), `output` (what a pass and a run hand out), `filter` (one pass, epoch
//! by epoch: owns the state, calls `measure` and `ar`), [`combine`] (forward/backward). This
//! module prepares the inputs and runs the passes.

mod ar;
pub mod combine;
mod dd;
mod filter;
mod geometry;
pub mod lambda;
mod measure;
pub mod obs;
mod options;
mod output;
mod pair;
mod segment;
pub mod slip;
mod state;

pub use measure::GateReason;
pub use options::{ArMode, BasePosition, FilterMode, PpkOptions};
pub use output::{EpochSol, PassStats, PpkResult};

use crate::error::{Error, Result};
use crate::frame::{enu_rotation, Ecef};
use crate::model::antex::AntennaPcv;
use crate::orbit::Orbits;
use crate::rinex::{ObsFile, ObsHeader};
use crate::solution::Quality;
use crate::spp::{self, SppOptions};
use crate::trajectory::{SegmentSource, Trajectory, TrajectoryEpoch};
use hifitime::Epoch;
use nalgebra::Vector3;
use obs::{extract, SatMeas, SignalPlan};

/// ENU antenna offset (header H/E/N) as an ECEF vector at `at`.
fn arp_offset(h: &ObsHeader, at: &Ecef) -> Vector3<f64> {
    let d = h.antenna_delta;
    let r = enu_rotation(&at.to_geodetic());
    r.transpose() * Vector3::new(d.east, d.north, d.up)
}

/// Median spacing of epochs, seconds.
fn interval(f: &ObsFile) -> f64 {
    crate::time::median_spacing(f.epochs.iter().map(|e| e.time))
}

/// Error unless the file holds carrier-phase observations.
pub fn require_phase(f: &ObsFile, role: &str) -> Result<()> {
    let any = f.epochs.iter().take(100).any(|e| {
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
                "BASE POSITION TAKEN FROM THE HEADER of {} ({:.3} {:.3} {:.3}): its error goes straight into every rover position; give --base-pos or --base-llh",
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
    let mut pick = |f: &ObsFile, role: &str| {
        let name = f.header.antenna.trim().to_string();
        match atx.find(&name) {
            Some((a, fallback)) => {
                if fallback {
                    warnings.push(format!(
                        "{role} antenna '{name}': no calibration with this radome, using '{}'",
                        a.name
                    ));
                }
                Some(a.clone())
            }
            None => {
                warnings.push(format!("{role} antenna '{name}' is not in the ANTEX file: no phase-centre correction for it"));
                None
            }
        }
    };
    (pick(rover, "rover"), pick(base, "base"))
}

/// The base epoch nearest each rover epoch, within `max_age` seconds.
fn match_base_epochs(rover: &ObsFile, base: &ObsFile, max_age: f64) -> Vec<Option<usize>> {
    let bt: Vec<Epoch> = base.epochs.iter().map(|e| e.time).collect();
    rover
        .epochs
        .iter()
        .map(|e| {
            let i = bt.partition_point(|t| *t <= e.time);
            [i.checked_sub(1), (i < bt.len()).then_some(i)]
                .into_iter()
                .flatten()
                .min_by(|&a, &b| {
                    let da = (bt[a] - e.time).to_seconds().abs();
                    let db = (bt[b] - e.time).to_seconds().abs();
                    da.partial_cmp(&db).unwrap_or(std::cmp::Ordering::Equal)
                })
                .filter(|&j| (bt[j] - e.time).to_seconds().abs() <= max_age)
        })
        .collect()
}

/// Start position and receiver clock offset (s) of each rover epoch from its code
/// solution, or why there is none. As in RTKLIB, an epoch whose code solution fails (too few
/// satellites, GDOP > 30, inconsistent) gets no carrier-phase solution either: its geometry
/// cannot be trusted.
fn start_values(
    rover: &ObsFile,
    orbits: &Orbits,
    opts: &PpkOptions,
) -> Vec<std::result::Result<(Ecef, f64), String>> {
    let sopts = SppOptions {
        elev_mask: opts.elev_mask,
        systems: opts.systems.clone(),
        ..SppOptions::default()
    };
    let mut starts = Vec::with_capacity(rover.epochs.len());
    let mut prior = rover.header.approx_position;
    for e in &rover.epochs {
        match spp::solve_epoch(e, &rover.header, orbits, &sopts, prior) {
            Ok(s) => {
                prior = Some(s.pos);
                let clock = s.clocks.values().next().copied().unwrap_or(0.0) / crate::orbit::C;
                starts.push(Ok((s.pos, clock)));
            }
            Err((why, _)) => starts.push(Err(why.kind().to_string())),
        }
    }
    starts
}

/// Everything a pass reads, per rover epoch.
struct PassInputs<'a> {
    rover: &'a ObsFile,
    base: &'a ObsFile,
    rover_meas: Vec<Vec<SatMeas>>,
    base_meas: Vec<Vec<SatMeas>>,
    /// Base epoch of each rover epoch.
    matched: Vec<Option<usize>>,
    /// Start position and clock offset of each rover epoch.
    starts: Vec<std::result::Result<(Ecef, f64), String>>,
}

/// One pass of the filter over every rover epoch (forward or backward in time): its
/// solution per epoch (None when unsolved) and its counters.
fn run_pass(
    inputs: &PassInputs,
    mut f: filter::Filter,
    backward: bool,
    progress: &(dyn Fn(usize) + Sync),
) -> (Vec<Option<EpochSol>>, PassStats) {
    let n = inputs.rover.epochs.len();
    let mut out: Vec<Option<EpochSol>> = vec![None; n];
    let order: Box<dyn Iterator<Item = usize>> = if backward {
        Box::new((0..n).rev())
    } else {
        Box::new(0..n)
    };
    for (count, i) in order.enumerate() {
        if count % 500 == 0 {
            progress(500.min(n - count));
        }
        let (Some(j), Ok((start, _))) = (inputs.matched[i], &inputs.starts[i]) else {
            continue;
        };
        out[i] = f.step(
            inputs.rover.epochs[i].time,
            &inputs.rover_meas[i],
            inputs.base.epochs[j].time,
            &inputs.base_meas[j],
            *start,
        );
    }
    (out, f.stats)
}

/// A pass's solutions and counters.
type Pass = (Vec<Option<EpochSol>>, PassStats);

/// The output solution of each epoch (the one pass, or both combined) with its ambiguity
/// segment (the union of the passes' boundaries plus Q changes).
fn merge_passes(fw: Option<&Pass>, bw: Option<&Pass>) -> Vec<Option<(EpochSol, u32)>> {
    let merged: Vec<Option<EpochSol>> = match (fw, bw) {
        (Some((f, _)), Some((b, _))) => f
            .iter()
            .zip(b)
            .map(|(a, b)| combine::combine(a.as_ref(), b.as_ref()))
            .collect(),
        (Some((f, _)), None) => f.clone(),
        (None, Some((b, _))) => b.clone(),
        (None, None) => Vec::new(),
    };
    let segments_of = |(sols, _): &Pass| -> Vec<Option<u32>> {
        sols.iter().map(|s| s.as_ref().map(|s| s.segment)).collect()
    };
    let pass_segments: Vec<Vec<Option<u32>>> =
        [fw, bw].into_iter().flatten().map(segments_of).collect();
    let passes: Vec<&[Option<u32>]> = pass_segments.iter().map(|p| p.as_slice()).collect();
    let quality: Vec<Option<Quality>> = merged
        .iter()
        .map(|s| s.as_ref().map(|s| s.quality))
        .collect();
    let segments = segment::output_segments(&passes, &quality);
    merged
        .into_iter()
        .zip(segments)
        .map(|(s, id)| s.map(|s| (s, id.unwrap_or(0))))
        .collect()
}

/// Run the carrier-phase engine: forward, backward or both passes of the filter over the
/// rover epochs matched to base epochs, combined; the trajectory of the rover marker at the
/// true reception times, with the filter's ambiguity segments.
pub fn process(
    rover: &ObsFile,
    base: &ObsFile,
    base_pos: BasePosition,
    orbits: &Orbits,
    opts: &PpkOptions,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<PpkResult> {
    let mut warnings = Vec::new();
    require_phase(rover, "rover")?;
    require_phase(base, "base")?;
    let base_marker = base_marker(base, base_pos, &mut warnings)?;
    let base_arp = Ecef(base_marker.0 + arp_offset(&base.header, &base_marker));
    let antennas = antenna_calibrations(opts, rover, base, &mut warnings);
    let mut opts = opts.clone();
    if opts.max_gap <= 0.0 {
        opts.max_gap = (5.0 * interval(rover)).max(5.0);
    }
    let matched = match_base_epochs(rover, base, opts.max_age);
    if matched.iter().all(|m| m.is_none()) {
        return Err(Error::NoData(format!(
            "{} and {}: no rover epoch has a base epoch within {} s: the files do not cover a common time",
            rover.path.display(),
            base.path.display(),
            opts.max_age
        )));
    }
    let eph = &orbits.broadcast;
    let measurements = |f: &ObsFile| -> Vec<Vec<SatMeas>> {
        let plan = SignalPlan::new(&f.header);
        f.epochs
            .iter()
            .map(|e| extract(e, &f.header, &plan, &opts.systems, opts.nf, eph))
            .collect()
    };
    let inputs = PassInputs {
        rover,
        base,
        rover_meas: measurements(rover),
        base_meas: measurements(base),
        matched,
        starts: start_values(rover, orbits, &opts),
    };
    // A step longer than 2.5 nominal intervals between solved epochs starts a new segment.
    let segment_gap = 2.5 * interval(rover);
    let run = |backward: bool| -> Pass {
        let f = filter::Filter::new(
            &opts,
            orbits,
            base_arp,
            backward,
            antennas.clone(),
            segment_gap,
        );
        run_pass(&inputs, f, backward, progress)
    };
    let (fw, bw) = match opts.filter {
        FilterMode::Forward => (Some(run(false)), None),
        FilterMode::Backward => (None, Some(run(true))),
        FilterMode::Combined => {
            let (a, b) = rayon::join(|| run(false), || run(true));
            (Some(a), Some(b))
        }
    };
    let merged = merge_passes(fw.as_ref(), bw.as_ref());
    let mut epochs = Vec::with_capacity(rover.epochs.len());
    let mut unsolved = Vec::new();
    for (i, s) in merged.into_iter().enumerate() {
        match s {
            Some((s, segment)) => {
                // Rover marker = antenna reference point − header offset.
                let pos = Ecef(s.pos.0 - arp_offset(&rover.header, &s.pos));
                // The position belongs to the true reception time: the receiver's time tag
                // minus its clock offset (as RTKLIB reports it). A moving rover at 60 m/s
                // moves 6 cm in a millisecond of clock offset.
                let mut time = s.time;
                if let Ok((_, clock)) = &inputs.starts[i] {
                    time -= hifitime::Duration::from_seconds(*clock);
                }
                epochs.push(TrajectoryEpoch {
                    time,
                    pos,
                    cov: s.cov,
                    vel: None,
                    quality: s.quality,
                    nsat: s.nsat,
                    ratio: s.ratio,
                    age: s.age,
                    segment,
                });
            }
            None => {
                let why = if inputs.matched[i].is_none() {
                    format!("no base epoch within {} s", opts.max_age)
                } else if let Err(why) = &inputs.starts[i] {
                    format!("no single-point solution: {why}")
                } else {
                    "fewer than two satellites common to rover and base above the mask".to_string()
                };
                unsolved.push((rover.epochs[i].time, why));
            }
        }
    }
    Ok(PpkResult {
        trajectory: Trajectory::new(epochs, SegmentSource::Filter),
        forward: fw.map(|x| x.1),
        backward: bw.map(|x| x.1),
        unsolved,
        rover_epochs: rover.epochs.len(),
        base_marker,
        warnings,
    })
}
